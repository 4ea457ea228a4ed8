"""Benchmark: one call of the record fit's likelihood sum, as sessions 7, 8 and 9 computed
it, side by side in one run (issue 13 item 2; docs/performance.md).

Session 7 ("old"): the (walkers x records) pointwise array of the record model on whole
blocks of walkers (``_record_loglik_pointwise`` as it stood then, ``_old_pointwise`` below,
a copy), then its row sums. Session 8: in place on cache-sized blocks of records, one
logarithm per value (``_s8_sum`` below, on the library's pointwise kernel). Session 9
("new"): :func:`flidar_uq.inference.record_fit._record_loglik_sum`, the same blocks with one
logarithm per 8 records' tau^2 (their product). Records: the rows of a pipeline run's
``results/bins/assignments.csv`` (``--assignments``; e.g. a year's) with their own motion
description and the default scenario's reference-lidar pair term, at 1, 32 and 64
walkers (the Laplace search, a DE half-ensemble, the independence move). Per case: the best
of ``--repeats`` CPU times, the ratio old / new and the largest relative difference of the
sums. Writes ``benchmarks/results/record_loglik_speed.csv`` and ``.png``.

Usage: ``python benchmarks/record_loglik_speed.py --assignments <run>/results/bins/assignments.csv``
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pandas as pd  # noqa: E402

from flidar_uq.inference import record_fit  # noqa: E402
from flidar_uq.physics.surrogate import get_surrogate  # noqa: E402
from flidar_uq.threads import single_threaded  # noqa: E402
from flidar_uq.workflow.files import read_csv  # noqa: E402

REPO = Path(__file__).resolve().parents[1]
OUT = REPO / "benchmarks" / "results" / "record_loglik_speed"
_LOG2PI = np.log(2 * np.pi)


def _old_pointwise(theta, s, r, sz_rot, u2, pair_sq):
    """The record model's pointwise log-likelihood as session 7 computed it (a copy)."""
    rho = theta[:, 0:1]
    kappa_sq = np.exp(2.0 * theta[:, 1:2])
    kz_sq = np.exp(2.0 * theta[:, 2:3])
    lever_sq = theta[:, 3:4] ** 2
    k_sq = np.exp(2.0 * theta[:, 4:5])
    sz_sq = k_sq * sz_rot**2 + lever_sq * u2
    sz = np.sqrt(sz_sq)
    mu_sq = np.maximum(r**2 + sz_sq + 2.0 * rho * r * sz, 1e-12)
    dmu = (sz + rho * r) ** 2 / mu_sq
    tau_sq = kappa_sq * mu_sq + kz_sq * sz_sq * dmu + 1e-8
    if np.any(pair_sq):
        tau_sq += pair_sq * r**2 * (r + rho * sz) ** 2 / mu_sq
    z = s - np.sqrt(mu_sq)
    return -0.5 * (z * z / tau_sq + np.log(tau_sq) + _LOG2PI)


def _old_sum(theta, s, r, sz_rot, u2, pair_sq):
    """Session 7's sum: whole rows, blocks of walkers of at most 2**20 values."""
    step = max(1, 2**20 // s.size)
    out = np.empty(theta.shape[0])
    for a in range(0, theta.shape[0], step):
        out[a : a + step] = _old_pointwise(theta[a : a + step], s, r, sz_rot, u2, pair_sq).sum(1)
    return out


def _s8_sum(theta, s, r, sz_rot, u2, pair_sq):
    """Session 8's sum: blocks of records in place, one logarithm per value."""
    n = s.size
    out = np.zeros(theta.shape[0])
    b = max(1, record_fit._SUM_BLOCK_ELEMENTS // theta.shape[0])
    for a in range(0, n, b):
        out += record_fit._record_neg2_loglik(
            theta, s[a : a + b], r[a : a + b], sz_rot[a : a + b], u2[a : a + b], pair_sq[a : a + b]
        ).sum(axis=1)
    return -0.5 * (out + n * _LOG2PI)


def _best_cpu(fn, args, repeats):
    best = np.inf
    for _ in range(repeats):
        t0 = time.process_time()
        value = fn(*args)
        best = min(best, time.process_time() - t0)
    return best, value


@single_threaded
def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--assignments", type=Path, required=True)
    ap.add_argument("--repeats", type=int, default=5)
    args = ap.parse_args()
    records = read_csv(args.assignments)
    (s, r, szr, u2), use, _ = record_fit._record_observations(
        records, get_surrogate("zephir300"), 1.0
    )
    pair_sq = np.full(s.size, 0.05**2)  # the default campaign's median pair log-sd ~0.051
    rng = np.random.default_rng(8)
    rows = []
    for walkers in (1, 32, 64):
        centre = np.array([-0.012, np.log(1e-4), np.log(0.09), 2.44, 0.03])
        theta = centre + 0.01 * rng.standard_normal((walkers, 5))
        inputs = (theta, s, r, szr, u2, pair_sq)
        t_old, old = _best_cpu(_old_sum, inputs, args.repeats)
        t_s8, s8 = _best_cpu(_s8_sum, inputs, args.repeats)
        t_new, new = _best_cpu(record_fit._record_loglik_sum, inputs, args.repeats)
        rows.append(
            {
                "n_records": s.size,
                "walkers": walkers,
                "old_cpu_ms": 1e3 * t_old,
                "s8_cpu_ms": 1e3 * t_s8,
                "new_cpu_ms": 1e3 * t_new,
                "ratio_old_over_new": t_old / t_new,
                "ratio_s8_over_new": t_s8 / t_new,
                "ns_per_value_new": 1e9 * t_new / (walkers * s.size),
                "max_rel_diff": float(np.max(np.abs(new - old) / np.abs(old))),
                "max_rel_diff_s8": float(np.max(np.abs(new - s8) / np.abs(s8))),
            }
        )
        print(
            f"{walkers:3d} walkers x {s.size:,} records: session 7 {1e3 * t_old:7.1f} ms, "
            f"session 8 {1e3 * t_s8:7.1f} ms, new {1e3 * t_new:7.1f} ms; ratios "
            f"{t_old / t_new:.2f} and {t_s8 / t_new:.2f}; max rel diff "
            f"{rows[-1]['max_rel_diff']:.1e} and {rows[-1]['max_rel_diff_s8']:.1e}"
        )
    table = pd.DataFrame(rows)
    OUT.parent.mkdir(parents=True, exist_ok=True)
    table.to_csv(OUT.with_suffix(".csv"), index=False, float_format="%.6g")
    fig, ax = plt.subplots(figsize=(5.5, 3.6))
    x = np.arange(len(table))
    ax.bar(x - 0.27, table.old_cpu_ms, 0.27, label="session 7 (whole rows)")
    ax.bar(x, table.s8_cpu_ms, 0.27, label="session 8 (in place, blocks of records)")
    ax.bar(x + 0.27, table.new_cpu_ms, 0.27, label="session 9 (+ one log per 8 records)")
    ax.set_xticks(x, [f"{w} walkers" for w in table.walkers])
    ax.set_yscale("log")
    ax.set_ylabel("CPU per likelihood call (ms)")
    ax.set_title(f"record-model likelihood sum, {s.size:,} records")
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(OUT.with_suffix(".png"), dpi=110)


if __name__ == "__main__":
    main()
