"""Benchmark: the convergence diagnostics of a fit as the library calls computed them and as
they are computed now, side by side in one run (docs/performance.md).

Library calls ("library", ``_library_diagnostics`` below): arviz-stats' ``rhat(method="rank")``,
``ess(method="bulk")`` and ``ess(method="tail")`` on the pooled chains, and emcee's
``integrated_time`` per ensemble. Now: :func:`flidar_uq.inference.diagnostics._diagnostics`
(one ranking of the split chains shared by the rank R-hat and the bulk ESS, a table of
normal scores, one real FFT for all walkers; the tail ESS still arviz-stats'). Chains of
the shapes the pipeline checks: a unimodal bin (4 ensembles x 250 steps x 16 walkers x 4
parameters), a two-period bin (500 steps, 7 parameters), a two-period bin extended to
1,500 steps, the record fit (250 steps, 32 walkers, 5 parameters), MCMC-like (AR(1) with
half the steps rejected, so ties as in emcee's chains). Per shape: the best of
``--repeats`` CPU times of each, interleaved, and the largest differences of the results.
Writes ``benchmarks/results/diagnostics_speed.csv`` and ``.png``.

Usage: ``python benchmarks/diagnostics_speed.py [--repeats 15]``
"""

from __future__ import annotations

import argparse
import os
import time
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import emcee  # noqa: E402
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pandas as pd  # noqa: E402
from arviz_stats.base import array_stats  # noqa: E402

from flidar_uq.inference.diagnostics import _diagnostics  # noqa: E402
from flidar_uq.inference.priors import SamplerSettings  # noqa: E402
from flidar_uq.threads import single_threaded  # noqa: E402

OUT = Path(__file__).resolve().parent / "results"

SHAPES = {  # name: (ensembles, steps, walkers, parameters)
    "unimodal bin": (4, 250, 16, 4),
    "two-period bin": (4, 500, 16, 7),
    "two-period bin, extended": (4, 1500, 16, 7),
    "record fit": (4, 250, 32, 5),
}


def _library_diagnostics(chains):
    """The library calls: rank R-hat, bulk and tail ESS (arviz-stats), tau (emcee)."""
    nens, nsteps, nwalk, ndim = chains.shape
    pooled = np.transpose(chains, (3, 0, 2, 1)).reshape(ndim, nens, nwalk * nsteps)
    rhat = array_stats.rhat(pooled, chain_axis=-2, draw_axis=-1, method="rank")
    ess_b = array_stats.ess(pooled, chain_axis=-2, draw_axis=-1, method="bulk")
    ess_t = array_stats.ess(pooled, chain_axis=-2, draw_axis=-1, method="tail", prob=(0.05, 0.95))
    with np.errstate(all="ignore"):
        taus = np.array([emcee.autocorr.integrated_time(c, tol=0, quiet=True) for c in chains])
    return rhat, ess_b, ess_t, np.max(taus, axis=0)


def _current(chains):
    diag, _ = _diagnostics(chains, [f"p{k}" for k in range(chains.shape[-1])], SamplerSettings())
    return tuple(
        np.array([d[k] for d in diag.values()]) for k in ("rhat", "ess_bulk", "ess_tail", "tau")
    )


def _chains(rng, shape, phi=0.8):
    nens, nsteps, nwalk, ndim = shape
    e = rng.standard_normal(shape)
    x = np.empty(shape)
    x[:, 0] = e[:, 0]
    reject = rng.random((nens, nsteps, nwalk)) < 0.5
    for t in range(1, nsteps):
        x[:, t] = np.where(reject[:, t, :, None], x[:, t - 1], phi * x[:, t - 1] + e[:, t])
    return x


def _cpu(fn, x):
    t = time.process_time()
    fn(x)
    return time.process_time() - t


@single_threaded
def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=15)
    ap.add_argument("--out", type=Path, default=OUT / "diagnostics_speed.csv")
    args = ap.parse_args()
    rng = np.random.default_rng(20261129)
    rows = []
    for name, shape in SHAPES.items():
        x = _chains(rng, shape)
        lib, cur = _library_diagnostics(x), _current(x)
        t_lib, t_cur = [], []
        for _ in range(args.repeats):  # interleaved, best of each
            t_lib.append(_cpu(_library_diagnostics, x))
            t_cur.append(_cpu(_current, x))
        diff = {
            f"max_rel_diff_{k}": float(np.max(np.abs(c - ref) / np.abs(ref)))
            for k, c, ref in zip(("rhat", "ess_bulk", "ess_tail", "tau"), cur, lib, strict=True)
        }
        rows.append(
            {
                "shape": name,
                "ensembles_steps_walkers_params": "x".join(map(str, shape)),
                "library_ms": 1e3 * min(t_lib),
                "current_ms": 1e3 * min(t_cur),
                "speedup": min(t_lib) / min(t_cur),
                **diff,
                "load1": os.getloadavg()[0],
            }
        )
        r = rows[-1]
        print(
            f"{name:26s} library {r['library_ms']:7.1f} ms  current {r['current_ms']:7.1f} ms  "
            f"ratio {r['speedup']:.2f}x  max rel diff rhat {diff['max_rel_diff_rhat']:.1e} "
            f"ess {diff['max_rel_diff_ess_bulk']:.1e} tau {diff['max_rel_diff_tau']:.1e}",
            flush=True,
        )
    df = pd.DataFrame(rows)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    df.to_csv(args.out, index=False)
    fig, ax = plt.subplots(figsize=(7.5, 3.6), layout="constrained")
    y = np.arange(len(df))
    ax.barh(y + 0.2, df["library_ms"], height=0.4, label="library: arviz-stats + emcee calls")
    ax.barh(y - 0.2, df["current_ms"], height=0.4, label="now: shared ranks, one FFT")
    for yi, r in zip(y, df.itertuples(), strict=True):
        ax.text(r.library_ms, yi + 0.2, f" {r.speedup:.2f}x", va="center", fontsize=8)
    ax.set_yticks(y, df["shape"])
    ax.set_xlabel("CPU time per convergence check, ms (best of repeats)")
    ax.set_title("Convergence diagnostics of one fit (rank R-hat, bulk/tail ESS, tau)")
    ax.legend(fontsize=8, loc="lower right")
    fig.savefig(args.out.with_suffix(".png"), dpi=120)
    print(f"wrote {args.out} and {args.out.with_suffix('.png')}")


if __name__ == "__main__":
    main()
