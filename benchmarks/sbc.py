"""Simulation-based calibration (Talts et al. 2018) of the bin model or the record motion model.

Each replication draws parameters from the model's priors, a campaign from the model,
fits it, and records the rank of each true value among 99 posterior draws. Uniform ranks
<=> calibrated (chi-square p > 0.01 per parameter).

- ``--model bin`` (the statistical-mode campaign): every bin and the global model are
  fitted with small sampler settings (``SETTINGS``); 3 bins x 10 records a replication.
  Writes ``benchmarks/results/sbc_ranks.csv``, ``sbc_summary.csv`` and ``sbc_ranks.png``.
- ``--model record``: the seven parameters (``SBC_RECORD_PARAMS``) drawn from the record
  model's prior, ``--records`` records from its likelihood as written, fitted with
  ``fit_record_model`` (fixed-length chains); target >= 100 replications. Writes
  ``benchmarks/results/sbc_record_ranks.csv``, ``sbc_record_summary.csv`` and
  ``sbc_record_ranks.png``.

Replications are seeded by ``SeedSequence(--seed).spawn(--replications)``.

Usage: ``python benchmarks/sbc.py [--model bin|record] [--replications N] [--seed S]
[--records N]`` (defaults: 120 replications of the bin model, 200 of the record model with
400 records each).
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
from scipy import stats  # noqa: E402

from flidar_uq.inference import SamplerSettings  # noqa: E402
from flidar_uq.physics.surrogate import get_surrogate  # noqa: E402
from flidar_uq.validation.sbc import (  # noqa: E402
    SBC_PARAMS,
    SBC_RECORD_PARAMS,
    rank_uniformity,
    sbc_record_replication,
    sbc_replication,
)

RESULTS = Path(__file__).parent / "results"
N_RANK_DRAWS = 99  # ranks 0..99
N_HIST_BINS = 10
SETTINGS = SamplerSettings(
    nwalkers=16, nsteps=200, nburn=100, ndraws=100, mixture="never", global_step_factor=2.0
)
DEFAULT_REPLICATIONS = {"bin": 120, "record": 200}


def run(model: str, n_rep: int, seed: int, n_records: int) -> pd.DataFrame:
    """Run ``n_rep`` replications of ``model``; one row per replication (with its wall time)."""
    sur = get_surrogate()
    rows = []
    for i, child in enumerate(np.random.SeedSequence(seed).spawn(n_rep)):
        t0 = time.perf_counter()
        if model == "bin":
            row = sbc_replication(
                child,
                surrogate=sur,
                settings=SETTINGS,
                n_bins=3,
                records_per_bin=10,
                n_rank_draws=N_RANK_DRAWS,
            )
        else:
            row = sbc_record_replication(
                child, n_records=n_records, n_rank_draws=N_RANK_DRAWS, surrogate=sur
            )
        rows.append({"replication": i, **row, "wall_s": time.perf_counter() - t0})
    return pd.DataFrame(rows)


def summarise(df: pd.DataFrame, names: tuple[str, ...], png: Path, title: str) -> pd.DataFrame:
    """Chi-square uniformity of each parameter's ranks; the rank histograms to ``png``."""
    n_rep = len(df)
    lo, hi = stats.binom.ppf([0.005, 0.995], n_rep, 1.0 / N_HIST_BINS)
    rows = []
    fig, axes = plt.subplots(1, len(names), figsize=(3.2 * len(names), 3), sharey=True)
    for ax, name in zip(axes, names, strict=True):
        p, counts = rank_uniformity(df[f"rank_{name}"].to_numpy(), N_RANK_DRAWS, N_HIST_BINS)
        rows.append(
            {
                "param": name,
                "chi2_pvalue": p,
                "pass_1pct": p > 0.01,
                "pass_1pct_bonferroni": p > 0.01 / len(names),
                "min_count": int(counts.min()),
                "max_count": int(counts.max()),
                "band99_lo": lo,
                "band99_hi": hi,
                "outside_band": int(np.sum((counts < lo) | (counts > hi))),
            }
        )
        ax.bar(np.arange(N_HIST_BINS), counts, color="C0")
        ax.axhspan(lo, hi, color="0.8", zorder=0, label="99% band")
        ax.set_title(f"{name}\nchi2 p = {p:.2f}", fontsize=9)
        ax.set_xlabel("rank decile")
    axes[0].set_ylabel(f"count ({n_rep} replications)")
    axes[0].legend(fontsize=7)
    fig.suptitle(title, fontsize=9)
    fig.tight_layout()
    fig.savefig(png, dpi=110)
    plt.close(fig)
    summ = pd.DataFrame(rows)
    summ["n_replications"] = n_rep
    return summ


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--model", choices=("bin", "record"), default="bin")
    ap.add_argument("--replications", type=int, default=None, help="default: 120 bin, 200 record")
    ap.add_argument("--seed", type=int, default=20181122)
    ap.add_argument("--records", type=int, default=400, help="records a campaign (record model)")
    a = ap.parse_args(argv)
    n_rep = a.replications or DEFAULT_REPLICATIONS[a.model]
    RESULTS.mkdir(exist_ok=True)
    t0 = time.perf_counter()
    df = run(a.model, n_rep, a.seed, a.records)
    wall = time.perf_counter() - t0
    if a.model == "bin":
        df.to_csv(RESULTS / "sbc_ranks.csv", index=False)
        summ = summarise(df, SBC_PARAMS, RESULTS / "sbc_ranks.png", "Bin-model SBC")
        summ["share_converged_small_settings"] = df["converged"].mean()
        summ["min_records_in_global_fit"] = df["n_records_global"].min()
        out = RESULTS / "sbc_summary.csv"
    else:
        df.to_csv(RESULTS / "sbc_record_ranks.csv", index=False)
        title = f"Record-model SBC, {a.records} records per campaign"
        summ = summarise(df, SBC_RECORD_PARAMS, RESULTS / "sbc_record_ranks.png", title)
        summ["n_records"] = a.records
        summ["share_converged"] = df["converged"].mean()
        summ["min_rank_spacing_over_tau"] = df["rank_spacing_over_tau"].min()
        out = RESULTS / "sbc_record_summary.csv"
    summ["wall_s"] = wall
    summ["wall_s_per_replication"] = wall / n_rep
    summ.to_csv(out, index=False)
    print(summ.to_string(index=False))
    print(f"{n_rep} replications in {wall:.0f} s ({wall / n_rep:.2f} s each)")


if __name__ == "__main__":
    main()
