"""Simulation-based calibration of the inference on the statistical-mode campaign.

Each replication draws parameters from the priors, a campaign from the model, fits every
bin and the global model (small sampler settings), and records the rank of the true
value among 99 posterior draws (Talts et al. 2018). Uniform ranks <=> calibrated.
Writes benchmarks/results/sbc_ranks.csv, sbc_summary.csv and sbc_ranks.png.

Usage: python benchmarks/sbc.py [n_replications] [seed]
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

from flidar_uq.inference import SamplerSettings  # noqa: E402
from flidar_uq.physics.surrogate import get_surrogate  # noqa: E402
from flidar_uq.validation.sbc import (  # noqa: E402
    SBC_PARAMS,
    rank_uniformity,
    sbc_replication,
)

RESULTS = Path(__file__).parent / "results"
N_RANK_DRAWS = 99  # ranks 0..99
N_HIST_BINS = 10
SETTINGS = SamplerSettings(
    nwalkers=16, nsteps=200, nburn=100, ndraws=100, mixture="never", global_step_factor=2.0
)


def run(n_rep: int, seed: int, *, n_bins: int = 3, records_per_bin: int = 10) -> pd.DataFrame:
    """Run ``n_rep`` replications; returns one row per replication."""
    sur = get_surrogate()
    root = np.random.SeedSequence(seed)
    return pd.DataFrame(
        [
            sbc_replication(
                child,
                surrogate=sur,
                settings=SETTINGS,
                n_bins=n_bins,
                records_per_bin=records_per_bin,
                n_rank_draws=N_RANK_DRAWS,
            )
            for child in root.spawn(n_rep)
        ]
    )


def main(n_rep: int = 120, seed: int = 20181122) -> None:
    RESULTS.mkdir(exist_ok=True)
    t0 = time.perf_counter()
    df = run(n_rep, seed)
    wall = time.perf_counter() - t0
    df.to_csv(RESULTS / "sbc_ranks.csv", index=False)
    lo, hi = stats.binom.ppf([0.005, 0.995], n_rep, 1.0 / N_HIST_BINS)
    rows = []
    fig, axes = plt.subplots(1, len(SBC_PARAMS), figsize=(3.2 * len(SBC_PARAMS), 3), sharey=True)
    for ax, name in zip(axes, SBC_PARAMS, strict=True):
        p, counts = rank_uniformity(df[f"rank_{name}"].to_numpy(), N_RANK_DRAWS, N_HIST_BINS)
        rows.append(
            {
                "param": name,
                "chi2_pvalue": p,
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
    fig.tight_layout()
    fig.savefig(RESULTS / "sbc_ranks.png", dpi=110)
    summ = pd.DataFrame(rows)
    summ["n_replications"] = n_rep
    summ["share_converged_small_settings"] = df["converged"].mean()
    summ["wall_s"] = wall
    summ["min_records_in_global_fit"] = df["n_records_global"].min()
    summ.to_csv(RESULTS / "sbc_summary.csv", index=False)
    print(summ.to_string(index=False))
    print(f"{n_rep} replications in {wall:.0f} s ({wall / n_rep:.2f} s each)")


if __name__ == "__main__":
    main(*(int(a) for a in sys.argv[1:3]))
