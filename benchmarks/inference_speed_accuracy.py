"""Speed-accuracy chart of the per-bin inference, one-bin time and all-bins / global times.

Accuracy of a sampler setting = the largest error, over the bin's parameters, of the
posterior median and of the 5% / 95% quantiles against a long reference run, in units of
the reference posterior std. Timing: one bin with the default settings, 100 statistical-
mode bins x 30 records in ``workers`` processes and their global fit; and, if the
pipeline has written ``results/bins/`` (the default physics-mode campaign), all its
fitted bins in ``workers`` processes and the global fit on their records (both models,
and each model alone: the two can run as parallel jobs, see
``inference.select_global_model``). Writes benchmarks/results/inference_speed_accuracy.csv,
inference_speed_accuracy.png and inference_timing.csv (with the 1-min load average before
and after each timing: the machine is shared).

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

from flidar_uq.campaign.statistical_mode import generate_statistical_campaign  # noqa: E402
from flidar_uq.inference import (  # noqa: E402
    SamplerSettings,
    fit_bin,
    fit_global,
    select_global_model,
)
from flidar_uq.physics.surrogate import get_surrogate  # noqa: E402
from flidar_uq.workflow.data_steps import kept_records  # noqa: E402
from flidar_uq.workflow.inference_steps import bin_seed  # noqa: E402

RESULTS = Path(__file__).parent / "results"
PIPELINE_BINS = Path(__file__).parents[1] / "results" / "bins"
NAMES = ["amplitude_deg", "period_s", "scatter_amplitude", "scatter_period"]
REFERENCE = SamplerSettings(nwalkers=48, nsteps=6000, nburn=1000, ndraws=4000, mixture="never")
GRID = [(nw, ns) for nw in (16, 24, 32) for ns in (100, 150, 250, 400, 800)]


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
    assert ref.converged, ref.failure_reasons
    rows = []
    for nw, ns in GRID:
        # fixed length (no adaptive extension) so that the grid shows the raw trade-off;
        # every draw kept, so that the error is the chain's, not that of thinning
        st = SamplerSettings(
            nwalkers=nw, nsteps=ns, mixture="never", max_step_factor=1.0, ndraws=nw * ns
        )
        for rep in range(4):
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
    ax.set_title(
        f"per-bin posterior: accuracy vs time (labels: nsteps; burn-in {st.nburn})", fontsize=9
    )
    ax.legend()
    fig.tight_layout()
    fig.savefig(RESULTS / "inference_speed_accuracy.png", dpi=110)

    timing = _timing(n_bins_all, workers, sur)
    timing.to_csv(RESULTS / "inference_timing.csv", index=False)
    print(agg.to_string())
    print(timing.to_string(index=False))


def _timed(rows, what, fn, target_s=np.nan):
    """Run ``fn``, append a timing row (wall time, target, load before / after); return its result."""
    load0 = os.getloadavg()[0]
    t0 = time.perf_counter()
    out = fn()
    wall = time.perf_counter() - t0
    rows.append(
        {
            "what": what,
            "wall_s": wall,
            "target_s": target_s,
            "wall_over_target": wall / target_s,
            "load_1min_before": load0,
            "load_1min_after": os.getloadavg()[0],
        }
    )
    return out


def _fit_all(jobs, workers):
    with ProcessPoolExecutor(workers) as ex:
        return list(ex.map(_fit_one, jobs))


def _timing(n_bins_all, workers, sur) -> pd.DataFrame:
    default = SamplerSettings()
    rows = []
    rec, _ = generate_statistical_campaign(1, 30, seed=3, surrogate=sur)
    fit_bin(rec, settings=default, seed=199)  # warm-up (imports, caches)
    for rep in range(3):
        _timed(
            rows,
            f"one unimodal bin x 30 records, default settings (rep {rep})",
            lambda rep=rep: fit_bin(rec, settings=default, seed=200 + rep),
            target_s=2.0,  # target: one bin of 30 records in 2 s
        )
    rec2, _ = generate_statistical_campaign(1, 30, seed=4, surrogate=sur, two_period_bins=1)
    f2 = _timed(
        rows,
        "one two-period bin x 30 records",
        lambda: fit_bin(rec2, settings=default, seed=5),
        target_s=2.0,
    )
    share = f2.info["loo"]["two_peak_share"]
    rows[-1]["what"] += f", two-peaked records: {share:.0%}, model chosen: {f2.model}"
    camp, _ = generate_statistical_campaign(
        n_bins_all, 30, seed=6, surrogate=sur, two_period_bins=n_bins_all // 3
    )
    jobs = [(g, np.random.SeedSequence([7, int(b)]), default) for b, g in camp.groupby("bin_id")]
    fits = _timed(
        rows,
        f"{n_bins_all} bins x 30 records (a third two-period), {workers} processes",
        lambda: _fit_all(jobs, workers),
        target_s=60.0,
    )
    rows.append(
        {
            "what": "  share of these bins converged",
            "value": float(np.mean([f.converged for f in fits])),
        }
    )
    gf = _timed(
        rows,
        f"global fit, {len(camp)} records, both models (lever_arm='auto')",
        lambda: fit_global(camp, fits, surrogate=sur, settings=default, seed=8),
    )
    rows.append({"what": "  global fit converged", "value": float(gf.converged)})
    if (PIPELINE_BINS / "assignments.parquet").exists():
        _timing_default_campaign(rows, default, workers)
    return pd.DataFrame(rows)


def _timing_default_campaign(rows, default, workers) -> None:
    """All fitted bins of the pipeline's campaign (results/bins/) and the global fit."""
    res = PIPELINE_BINS.parent
    assigned = kept_records(
        res / "data" / "records.parquet", res / "motion" / "records.parquet",
        PIPELINE_BINS / "assignments.parquet",
    )  # fmt: skip
    table = pd.read_csv(PIPELINE_BINS / "table.csv")
    bins = table.loc[table["fitted"].astype(bool), "bin_id"].astype(int)
    recs = assigned[assigned["bin_id"].isin(bins)].reset_index(drop=True)
    jobs = [(g, bin_seed(42, int(b)), default) for b, g in recs.groupby("bin_id")]
    jobs.sort(key=lambda j: -len(j[0]))  # largest first: better load balance
    fits = _timed(
        rows,
        f"default campaign: {len(jobs)} bins, {len(recs)} records, {workers} processes",
        lambda: _fit_all(jobs, workers),
        target_s=60.0,  # target: all bins of the default campaign in 60 s on 2 cores
    )
    rows.append(
        {
            "what": "  share of these bins converged",
            "value": float(np.mean([f.converged for f in fits])),
        }
    )
    rows.append(
        {
            "what": "  bins with the two-period model",
            "value": float(np.sum([f.model == "two_period" for f in fits])),
        }
    )

    def seed():  # the pipeline's; a fresh SeedSequence per fit (spawning advances it)
        return np.random.SeedSequence(entropy=42, spawn_key=(0,))

    gf = _timed(
        rows,
        "default campaign: global fit, both models (lever_arm='auto')",
        lambda: fit_global(recs, fits, settings=default, seed=seed()),
        target_s=40.0,
    )
    rows.append(
        {
            "what": f"  global fit converged, model {gf.info['loo']['model']}",
            "value": float(gf.converged),
        }
    )
    single = {}
    for lev in (False, True):
        single[lev] = _timed(
            rows,
            f"default campaign: global fit, lever_arm={lev} only",
            lambda lev=lev: fit_global(recs, fits, settings=default, seed=seed(), lever_arm=lev),
        )
    sel = _timed(
        rows,
        "default campaign: select_global_model",
        lambda: select_global_model(single[False], single[True], settings=default),
    )
    rows.append(
        {
            "what": "  select_global_model == fit_global('auto')",
            "value": float(np.array_equal(sel.flat("rho"), gf.flat("rho"))),
        }
    )


if __name__ == "__main__":
    main(*(int(a) for a in sys.argv[1:3]))
