"""Benchmark: one call of the record fit's likelihood sum, two ways side by side in one run.

- ``whole_rows``: the (walkers x records) pointwise log-likelihood of the record model
  (:func:`flidar_uq.inference.record_fit._record_loglik_pointwise`), then its row sums:
  what a straightforward implementation does;
- ``library``: :func:`flidar_uq.inference.record_fit._record_loglik_sum`, the sampler's hot
  loop (cache-sized blocks of records, in place, one logarithm per 8 records' tau^2).

Both on the per-record Gram matrices of the motion error
(:func:`flidar_uq.inference.record_motion.motion_gram`) of a virtual campaign's records
(the default scenario, ``--records`` 10-min records x 3 heights; or a pipeline run's
``results/bins/assignments.csv`` with ``--assignments``), with the default scenario's
reference-lidar pair term, at 1, 32 and 64 walkers (the Laplace search, a DE
half-ensemble, the independence move). Per case: the best of ``--repeats`` CPU times, the
ratio and the largest relative difference of the sums. Writes
``benchmarks/results/record_loglik_speed.csv`` and ``.png``.

Usage: ``PYTHONPATH=src python benchmarks/record_loglik_speed.py [--records 2000]``
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from timing import best_time  # noqa: E402

from flidar_uq.data.io import read_csv  # noqa: E402
from flidar_uq.inference import record_fit  # noqa: E402
from flidar_uq.physics.surrogate import get_surrogate  # noqa: E402
from flidar_uq.threads import single_threaded  # noqa: E402

REPO = Path(__file__).resolve().parents[1]
OUT = REPO / "benchmarks" / "results" / "record_loglik_speed"
SEED = 20181122  # the default campaign's seed


def _whole_rows(theta, s, r, gram, pair_sq):
    """The pointwise array of every walker and record, then its row sums."""
    return record_fit._record_loglik_pointwise(theta, s, r, gram, pair_sq).sum(axis=1)


def _records(args):
    if args.assignments is not None:
        return read_csv(args.assignments)
    from flidar_uq.campaign.physics_mode import generate_campaign
    from flidar_uq.campaign.scenarios import load_scenario

    scenario = load_scenario("default") | {"n_records": int(args.records)}
    return generate_campaign(scenario, SEED, n_workers=1).records


@single_threaded
def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--assignments", type=Path, default=None)
    ap.add_argument("--records", type=int, default=2000)
    ap.add_argument("--repeats", type=int, default=5)
    args = ap.parse_args()
    (s, r, gram), _, _ = record_fit._record_observations(
        _records(args), get_surrogate("zephir300"), 1.0
    )
    pair_sq = np.full(s.size, 0.05**2)  # the default campaign's median pair log-sd ~0.051
    rng = np.random.default_rng(8)
    rows = []
    # sampler coordinates: rho, log kappa, log kappa_z, L, log k, log h, log rho_sd
    centre = np.array([-0.012, np.log(1e-4), np.log(0.09), 2.44, 0.03, np.log(0.3), np.log(0.08)])
    for walkers in (1, 32, 64):
        theta = centre + 0.01 * rng.standard_normal((walkers, centre.size))
        inputs = (theta, s, r, gram, pair_sq)
        t_rows, rows_sum = best_time(
            _whole_rows, *inputs, repeats=args.repeats, clock=time.process_time
        )
        t_lib, lib_sum = best_time(
            record_fit._record_loglik_sum, *inputs, repeats=args.repeats, clock=time.process_time
        )
        rel = float(np.max(np.abs(lib_sum - rows_sum) / np.abs(rows_sum)))
        rows.append(
            {
                "n_records": s.size,
                "walkers": walkers,
                "whole_rows_cpu_ms": 1e3 * t_rows,
                "library_cpu_ms": 1e3 * t_lib,
                "ratio_whole_rows_over_library": t_rows / t_lib,
                "ns_per_value_library": 1e9 * t_lib / (walkers * s.size),
                "max_rel_diff": rel,
            }
        )
        print(
            f"{walkers:3d} walkers x {s.size:,} records: whole rows {1e3 * t_rows:7.1f} ms, "
            f"library {1e3 * t_lib:7.1f} ms; ratio {t_rows / t_lib:.2f}; max rel diff {rel:.1e}"
        )
    import pandas as pd

    table = pd.DataFrame(rows)
    OUT.parent.mkdir(parents=True, exist_ok=True)
    table.to_csv(OUT.with_suffix(".csv"), index=False, float_format="%.6g")
    fig, ax = plt.subplots(figsize=(5.5, 3.6))
    x = np.arange(len(table))
    ax.bar(x - 0.2, table.whole_rows_cpu_ms, 0.4, label="whole rows, then sums")
    ax.bar(x + 0.2, table.library_cpu_ms, 0.4, label="library (blocks, grouped logarithm)")
    ax.set_xticks(x, [f"{w} walkers" for w in table.walkers])
    ax.set_yscale("log")
    ax.set_ylabel("CPU per likelihood call (ms)")
    ax.set_title(f"record-model likelihood sum, {s.size:,} records")
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(OUT.with_suffix(".png"), dpi=110)


if __name__ == "__main__":
    main()
