"""Speed-accuracy chart of the per-bin inference, one-bin time and an all-bins time.

Accuracy of a sampler setting = the largest error, over the bin's parameters, of the
posterior median and of the 5% / 95% quantiles against a long reference run, in units of
the reference posterior std. Writes benchmarks/results/inference_speed_accuracy.csv,
inference_speed_accuracy.png and inference_timing.csv.

Usage: python benchmarks/inference_speed_accuracy.py [n_bins_all=100] [workers=2]
"""

from __future__ import annotations

import os
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pandas as pd  # noqa: E402

from flidar_uq.campaign_statistical import generate_statistical_campaign  # noqa: E402
from flidar_uq.inference import SamplerSettings, fit_bin, fit_global  # noqa: E402
from flidar_uq.surrogate import get_surrogate  # noqa: E402

RESULTS = Path(__file__).parent / "results"
NAMES = ["amplitude_deg", "period_s", "scatter_amplitude", "scatter_period"]
REFERENCE = SamplerSettings(nwalkers=48, nsteps=6000, nburn=1000, ndraws=4000, mixture="never")
GRID = [(nw, ns) for nw in (16, 24, 32) for ns in (100, 200, 400, 800)]


def _error(fit, ref) -> float:
    errs = []
    for n in NAMES:
        r = ref.flat(n)
        x = fit.flat(n)
        for q in (0.05, 0.5, 0.95):
            errs.append(abs(np.quantile(x, q) - np.quantile(r, q)) / np.std(r))
    return float(max(errs))


def _fit_one(args):
    g, seed, settings = args
    return fit_bin(g, settings=settings, seed=seed)


def main(n_bins_all: int = 100, workers: int = 2) -> None:
    RESULTS.mkdir(exist_ok=True)
    sur = get_surrogate()
    rec, _ = generate_statistical_campaign(1, 30, seed=3, surrogate=sur)
    ref = fit_bin(rec, settings=REFERENCE, seed=1)
    rows = []
    for nw, ns in GRID:
        # fixed length (no adaptive extension) so that the grid shows the raw trade-off
        st = SamplerSettings(nwalkers=nw, nsteps=ns, mixture="never", max_step_factor=1.0)
        for rep in range(2):
            t0 = time.perf_counter()
            fit = fit_bin(rec, settings=st, seed=100 + rep)
            wall = time.perf_counter() - t0
            rows.append(
                {
                    "nwalkers": nw,
                    "nsteps": ns,
                    "nburn": st.nburn,
                    "rep": rep,
                    "wall_s": wall,
                    "max_error_in_ref_sd": _error(fit, ref),
                    "converged": fit.converged,
                }
            )
    df = pd.DataFrame(rows)
    df.to_csv(RESULTS / "inference_speed_accuracy.csv", index=False)
    agg = df.groupby(["nwalkers", "nsteps"]).agg(
        wall_s=("wall_s", "median"),
        max_error_in_ref_sd=("max_error_in_ref_sd", "median"),
        converged=("converged", "mean"),
    )
    fig, ax = plt.subplots(figsize=(5.5, 4))
    for nw, g in agg.reset_index().groupby("nwalkers"):
        ax.plot(g.wall_s, g.max_error_in_ref_sd, "o-", label=f"{nw} walkers")
        for _, r in g.iterrows():
            ax.annotate(str(int(r.nsteps)), (r.wall_s, r.max_error_in_ref_sd), fontsize=7)
    ax.set_xlabel("wall time per bin, 4 ensembles (s)")
    ax.set_ylabel("max quantile error / reference posterior sd")
    ax.set_yscale("log")
    ax.set_title("per-bin posterior: accuracy vs time (labels: nsteps)")
    ax.legend()
    fig.tight_layout()
    fig.savefig(RESULTS / "inference_speed_accuracy.png", dpi=110)

    # one bin with the default settings (unimodal and two-period bins), and all bins
    default = SamplerSettings()
    one = []
    for rep in range(3):
        t0 = time.perf_counter()
        fit_bin(rec, settings=default, seed=200 + rep)
        one.append(time.perf_counter() - t0)
    rec2, _ = generate_statistical_campaign(1, 30, seed=4, surrogate=sur, two_period_bins=1)
    t0 = time.perf_counter()
    f2 = fit_bin(rec2, settings=default, seed=5)
    two = time.perf_counter() - t0
    camp, _ = generate_statistical_campaign(
        n_bins_all, 30, seed=6, surrogate=sur, two_period_bins=n_bins_all // 3
    )
    jobs = [(g, np.random.SeedSequence([7, int(b)]), default) for b, g in camp.groupby("bin_id")]
    t0 = time.perf_counter()
    with ProcessPoolExecutor(workers) as ex:
        fits = list(ex.map(_fit_one, jobs))
    t_bins = time.perf_counter() - t0
    t0 = time.perf_counter()
    gf = fit_global(camp, fits, surrogate=sur, settings=default, seed=8)
    t_glob = time.perf_counter() - t0
    timing = pd.DataFrame(
        [
            {
                "what": "one unimodal bin, default settings (median of 3)",
                "wall_s": float(np.median(one)),
            },
            {"what": f"one screened bin (model chosen: {f2.model})", "wall_s": two},
            {"what": f"{n_bins_all} bins x 30 records, {workers} processes", "wall_s": t_bins},
            {"what": f"global fit, {len(camp)} records", "wall_s": t_glob},
            {"what": "all bins + global", "wall_s": t_bins + t_glob},
            {
                "what": "share of bins converged",
                "wall_s": float(np.mean([f.converged for f in fits])),
            },
            {"what": "global converged", "wall_s": float(gf.converged)},
        ]
    )
    timing["load_average_1min"] = os.getloadavg()[0]
    timing.to_csv(RESULTS / "inference_timing.csv", index=False)
    print(agg.to_string())
    print(timing.to_string(index=False))


if __name__ == "__main__":
    main(*(int(a) for a in sys.argv[1:3]))
