"""Benchmark: PSIS-LOO as the pipeline computes it against the library call, side by side in
one run (docs/performance.md).

Library: ``arviz_stats.base.array_stats.loo`` (``r_eff = 1``), one call on the whole
(observations, 1, draws) log-likelihood, which loops over the observations in Python. Now:
:func:`flidar_uq.inference.loo._loo` (the vectorised PSIS of ``_psis_loo`` in blocks of
observations). Sizes of the pipeline's fits: 1,000 draws (4 ensembles x 250) of a bin's
60 and 400 records, and of a campaign's 24,522 records (the global and record fits). The
log-likelihood: normal columns of different widths plus a tenth Student-t (3 dof) columns,
whose heavy tails give Pareto k above 0.7. Per size: the best of ``--repeats`` CPU times
of each, interleaved, and the largest absolute differences of the pointwise results.
Writes ``benchmarks/results/loo_speed.csv``.

Usage: ``python benchmarks/loo_speed.py [--repeats 5]``
"""

from __future__ import annotations

import argparse
import os
import time
from pathlib import Path

import numpy as np
import pandas as pd
from arviz_stats.base import array_stats

from flidar_uq.inference.loo import _loo
from flidar_uq.threads import single_threaded

OUT = Path(__file__).resolve().parent / "results"

SIZES = {  # name: (draws, observations)
    "bin, 60 records": (1000, 60),
    "bin, 400 records": (1000, 400),
    "campaign, 24,522 records": (1000, 24522),
}


def _library(ll):
    n_s, n_obs = ll.shape
    with np.errstate(all="ignore"):
        return array_stats.loo(ll.T.reshape(n_obs, 1, n_s), chain_axis=-2, draw_axis=-1, r_eff=1.0)


def _log_lik(rng, n_s, n_obs):
    n_t = n_obs // 10
    scale = rng.uniform(0.1, 3.0, n_obs - n_t)
    normal = rng.standard_normal((n_s, n_obs - n_t)) * scale - 1.0
    return np.concatenate([normal, rng.standard_t(3, (n_s, n_t))], axis=1)


def _cpu(fn, x):
    t = time.process_time()
    fn(x)
    return time.process_time() - t


@single_threaded
def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--out", type=Path, default=OUT / "loo_speed.csv")
    args = ap.parse_args()
    rng = np.random.default_rng(20261207)
    rows = []
    for name, (n_s, n_obs) in SIZES.items():
        ll = _log_lik(rng, n_s, n_obs)
        lib, cur = _library(ll), _loo(ll)
        t_lib, t_cur = [], []
        for _ in range(args.repeats):  # interleaved, best of each
            t_lib.append(_cpu(_library, ll))
            t_cur.append(_cpu(_loo, ll))
        rows.append(
            {
                "size": name,
                "draws": n_s,
                "observations": n_obs,
                "library_ms": 1e3 * min(t_lib),
                "current_ms": 1e3 * min(t_cur),
                "ratio": min(t_lib) / min(t_cur),
                "max_abs_diff_elpd_i": float(np.max(np.abs(cur["elpd_i"] - lib[0]))),
                "max_abs_diff_pareto_k": float(np.max(np.abs(cur["pareto_k"] - lib[1]))),
                "max_abs_diff_elpd": abs(cur["elpd"] - float(np.sum(lib[0]))),
                "max_abs_diff_p_loo": abs(cur["p_loo"] - float(np.sum(lib[2]))),
                "pareto_k_max": float(np.max(cur["pareto_k"])),
                "load1": os.getloadavg()[0],
            }
        )
        r = rows[-1]
        print(
            f"{name:26s} library {r['library_ms']:8.1f} ms  current {r['current_ms']:7.1f} ms  "
            f"ratio {r['ratio']:.1f}x  max abs diff elpd_i {r['max_abs_diff_elpd_i']:.1e} "
            f"pareto_k {r['max_abs_diff_pareto_k']:.1e} p_loo {r['max_abs_diff_p_loo']:.1e}",
            flush=True,
        )
    args.out.parent.mkdir(parents=True, exist_ok=True)
    pd.DataFrame(rows).to_csv(args.out, index=False)
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
