"""Simulation-based calibration of the record motion model (Talts et al. 2018).

Each replication draws the seven parameters (SBC_RECORD_PARAMS) from the record
model's prior, a campaign of records from its likelihood as written, fits it with
fit_record_model (fixed-length chains) and records the rank of each true value among 99
posterior draws. Uniform ranks <=> calibrated (target: >= 100 replications, chi-square
p > 0.01 per parameter).
Writes benchmarks/results/sbc_record_ranks.csv, sbc_record_summary.csv and
sbc_record_ranks.png.

Usage: python benchmarks/sbc_record_model.py [n_replications] [seed] [n_records]
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pandas as pd  # noqa: E402
from scipy import stats  # noqa: E402

from flidar_uq.physics.surrogate import get_surrogate  # noqa: E402
from flidar_uq.validation.sbc import (  # noqa: E402
    SBC_RECORD_PARAMS,
    rank_uniformity,
    sbc_record_replication,
)

RESULTS = Path(__file__).parent / "results"
N_RANK_DRAWS = 99  # ranks 0..99
N_HIST_BINS = 10


def run(n_rep: int, seed: int, n_records: int) -> pd.DataFrame:
    """Run ``n_rep`` replications (seeds spawned from ``SeedSequence(seed)``)."""
    sur = get_surrogate()
    rows = []
    for i, child in enumerate(np.random.SeedSequence(seed).spawn(n_rep)):
        t0 = time.perf_counter()
        row = sbc_record_replication(
            child, n_records=n_records, n_rank_draws=N_RANK_DRAWS, surrogate=sur
        )
        rows.append({"replication": i, **row, "wall_s": time.perf_counter() - t0})
    return pd.DataFrame(rows)


def main(n_rep: int = 200, seed: int = 20181122, n_records: int = 400) -> None:
    RESULTS.mkdir(exist_ok=True)
    t0 = time.perf_counter()
    df = run(n_rep, seed, n_records)
    wall = time.perf_counter() - t0
    df.to_csv(RESULTS / "sbc_record_ranks.csv", index=False)
    lo, hi = stats.binom.ppf([0.005, 0.995], n_rep, 1.0 / N_HIST_BINS)
    names = SBC_RECORD_PARAMS
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
    fig.suptitle(f"Record-model SBC, {n_records} records per campaign", fontsize=9)
    fig.tight_layout()
    fig.savefig(RESULTS / "sbc_record_ranks.png", dpi=110)
    summ = pd.DataFrame(rows)
    summ["n_replications"] = n_rep
    summ["n_records"] = n_records
    summ["share_converged"] = df["converged"].mean()
    summ["min_rank_spacing_over_tau"] = df["rank_spacing_over_tau"].min()
    summ["wall_s"] = wall
    summ["wall_s_per_replication"] = wall / n_rep
    summ.to_csv(RESULTS / "sbc_record_summary.csv", index=False)
    print(summ.to_string(index=False))
    print(f"{n_rep} replications in {wall:.0f} s ({wall / n_rep:.2f} s each)")


if __name__ == "__main__":
    main(*(int(a) for a in sys.argv[1:4]))
