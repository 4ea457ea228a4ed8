"""Benchmark: how far each acceptance group's calibration strays from campaign to campaign.

The acceptance asks every group of >= 200 records (3-m/s speed, sea state x heading, wave
period) for a 90 % coverage within 85-95 % and a mean relative error of the corrected TI
within +-1.5 %. A group of 200-300 records holds a finite sample: its mean error scatters
about the model's true bias by its standard error (the records' scatter over the square
root of their number), whatever the model. This script runs each scenario on many
campaigns (seeds spawned from one SeedSequence, none of them an acceptance seed) through
the same steps as the acceptance tests (``validation.regimes.scenario_records``) and
measures, per group:

* the mean error and its standard error within each campaign, and their ratio
  ``z = error / se``: a model without bias in the group gives z ~ N(0, 1) across
  campaigns, a biased one shifts it;
* how often the group misses the +-1.5 % bound, against the rate an unbiased model with
  that standard error would miss it by chance (``P(|N(0, se)| > 1.5 %)``);
* how often the coverage leaves 85-95 %;
* the hull parameters (lever arm, motion scale) against the scenario's truth, and the
  reference hull the record model kept (``inference.hull_reference: auto``).

Writes benchmarks/results/group_error_spread.csv (one row per campaign and group),
group_error_spread_summary.csv (one row per scenario and group) and
group_error_spread.png.

Usage: python benchmarks/group_error_spread.py [--campaigns N] [--workers W]
       [--scenarios NAME ...] [--seed ROOT]
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
from _acceptance_runs import SCENARIO_OPTIONS, campaign_seeds, run_campaigns  # noqa: E402
from scipy import stats  # noqa: E402

from flidar_uq.threads import single_threaded  # noqa: E402
from flidar_uq.validation.regimes import scenario_calibration, scenario_records  # noqa: E402

RESULTS = Path(__file__).parent / "results"
OUT = RESULTS / "group_error_spread"
#: The acceptance's bounds (issue texts): groups of >= 200 records.
MIN_GROUP = 200
ERROR_BOUND = 0.015
COVERAGE_BOUNDS = (0.85, 0.95)
DEFAULT_SCENARIOS = ("wave_follower", "discus_buoy", "dbs_wave_follower")


@single_threaded
def one_campaign(scenario: str, seed: int) -> pd.DataFrame:
    """Every group's calibration on one campaign, with the fit's hull parameters."""
    t0 = time.perf_counter()
    records, fit = scenario_records(scenario, seed, n_workers=1, **SCENARIO_OPTIONS[scenario])
    tab = scenario_calibration(records)
    tab = tab[(tab["grouping"] == "all") | (tab["n"] >= MIN_GROUP)].copy()
    hull = {
        f"{p}_median": float(np.median(fit.flat(p)))
        for p in ("lever_arm_m", "motion_scale", "hull_response")
    }
    return tab.assign(
        scenario=scenario,
        seed=seed,
        converged=bool(fit.converged),
        answered_share_all=float(records["ti_corrected_median"].notna().mean()),
        true_lever_arm_m=float(records["true_lever_arm_m"].iloc[0]),
        hull_reference=fit.info.get("hull_reference", ""),
        wall_s=time.perf_counter() - t0,
        **hull,
    )


def summarise(rows: pd.DataFrame) -> pd.DataFrame:
    """Per scenario and group: the spread of the error between campaigns, its mean
    within-campaign standard error, the mean z, and the observed against the expected
    rate of misses of the +-1.5 % bound."""
    r = rows.assign(
        z=rows["mean_rel_error"] / rows["mean_rel_error_se"],
        miss_error=rows["mean_rel_error"].abs() > ERROR_BOUND,
        p_miss_chance=2.0 * stats.norm.sf(ERROR_BOUND / rows["mean_rel_error_se"]),
        miss_coverage=~rows["coverage"].between(*COVERAGE_BOUNDS),
    )
    g = r.groupby(["scenario", "grouping", "group"], sort=False)
    out = g.agg(
        campaigns=("seed", "size"),
        n_mean=("n", "mean"),
        error_mean=("mean_rel_error", "mean"),
        error_sd_between=("mean_rel_error", "std"),
        se_within=("mean_rel_error_se", "mean"),
        z_mean=("z", "mean"),
        z_sd=("z", "std"),
        error_misses=("miss_error", "sum"),
        error_misses_expected=("p_miss_chance", "sum"),
        coverage_mean=("coverage", "mean"),
        coverage_misses=("miss_coverage", "sum"),
    ).reset_index()
    # a group without bias: z_mean ~ N(0, 1 / campaigns)
    out["z_mean_p"] = 2.0 * stats.norm.sf(np.abs(out["z_mean"]) * np.sqrt(out["campaigns"]))
    return out


def plot(rows: pd.DataFrame, summary: pd.DataFrame, path: Path) -> None:
    scen = list(dict.fromkeys(rows["scenario"]))
    fig, axes = plt.subplots(len(scen), 2, figsize=(13, 3.6 * len(scen)), squeeze=False)
    for (ax_e, ax_c), s in zip(axes, scen, strict=True):
        r = rows[rows["scenario"] == s]
        labels = list(dict.fromkeys(r["grouping"] + ": " + r["group"]))
        pos = {lab: i for i, lab in enumerate(labels)}
        x = (r["grouping"] + ": " + r["group"]).map(pos).to_numpy(dtype=float)
        jitter = (r.groupby(["grouping", "group"]).cumcount().to_numpy() - 3.5) * 0.05
        ax_e.errorbar(
            x + jitter,
            100 * r["mean_rel_error"],
            yerr=200 * r["mean_rel_error_se"],
            fmt="o",
            ms=3,
            lw=0.8,
            alpha=0.7,
        )
        ax_e.axhspan(-100 * ERROR_BOUND, 100 * ERROR_BOUND, color="g", alpha=0.1)
        ax_e.axhline(0, color="k", lw=0.5)
        ax_e.set_xticks(range(len(labels)), labels, rotation=60, ha="right", fontsize=7)
        ax_e.set_ylabel("mean rel. error, % (+-2 se)")
        ax_e.set_title(f"{s}: group mean error per campaign (band: +-1.5 %)", fontsize=9)
        ax_c.plot(x + jitter, r["coverage"], "o", ms=3, alpha=0.7)
        ax_c.axhspan(*COVERAGE_BOUNDS, color="g", alpha=0.1)
        ax_c.axhline(0.9, color="k", lw=0.5)
        ax_c.set_xticks(range(len(labels)), labels, rotation=60, ha="right", fontsize=7)
        ax_c.set_ylabel("90 % coverage")
        ax_c.set_title(f"{s}: group coverage per campaign (band: 85-95 %)", fontsize=9)
    fig.tight_layout()
    fig.savefig(path, dpi=90, metadata={"Software": None})
    plt.close(fig)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--campaigns", type=int, default=8, help="campaigns per scenario")
    ap.add_argument("--workers", type=int, default=2, help="processes")
    ap.add_argument(
        "--scenarios", nargs="+", default=list(DEFAULT_SCENARIOS), choices=SCENARIO_OPTIONS
    )
    ap.add_argument("--seed", type=int, default=20261205, help="root of the campaign seeds")
    args = ap.parse_args()
    RESULTS.mkdir(exist_ok=True)
    seeds = campaign_seeds(args.seed, args.campaigns)
    jobs = [(s, seed) for s in args.scenarios for seed in seeds]
    t0 = time.perf_counter()

    def report(i: int, n: int, part: pd.DataFrame) -> None:
        a = part[part["grouping"] == "all"].iloc[0]
        print(
            f"[{i}/{n}] {a['scenario']} seed {a['seed']}: coverage "
            f"{a['coverage']:.3f}, error {100 * a['mean_rel_error']:+.2f} % "
            f"(se {100 * a['mean_rel_error_se']:.2f} %), lever arm "
            f"{a['lever_arm_m_median']:.2f} m (truth {a['true_lever_arm_m']:.1f} m), "
            f"reference hull {a['hull_reference']}, {a['wall_s']:.0f} s",
            flush=True,
        )

    parts = run_campaigns(one_campaign, jobs, workers=args.workers, report=report)
    rows = pd.concat(parts, ignore_index=True)
    summary = summarise(rows[rows["grouping"] != "all"])
    rows.to_csv(f"{OUT}.csv", index=False)
    summary.to_csv(f"{OUT}_summary.csv", index=False)
    plot(rows[rows["grouping"] != "all"], summary, Path(f"{OUT}.png"))
    cols = ["scenario", "grouping", "group", "campaigns", "error_mean", "error_sd_between"]
    cols += ["se_within", "z_mean", "z_mean_p", "error_misses", "error_misses_expected"]
    cols += ["coverage_mean", "coverage_misses"]
    with pd.option_context("display.width", 200, "display.max_columns", 20):
        print(summary[cols].round(4).to_string(index=False))
    for s, r in rows[rows["grouping"] == "all"].groupby("scenario", sort=False):
        lev = r["lever_arm_m_median"]
        print(
            f"{s}: lever arm {lev.mean():.2f} +- {lev.std():.2f} m between campaigns "
            f"(truth {r['true_lever_arm_m'].iloc[0]:.1f} m; within 0.5 m on "
            f"{int((np.abs(lev - r['true_lever_arm_m']) <= 0.5).sum())} of {len(r)}), "
            f"motion scale {r['motion_scale_median'].mean():.3f} +- "
            f"{r['motion_scale_median'].std():.3f}; reference hull "
            f"{', '.join(f'{k} {v}' for k, v in r['hull_reference'].value_counts().items())}"
        )
    s = summary
    print(
        f"group misses of +-1.5 %: {int(s['error_misses'].sum())} observed against "
        f"{s['error_misses_expected'].sum():.1f} expected by chance for a model without "
        f"bias; coverage outside 85-95 %: {int(s['coverage_misses'].sum())} of "
        f"{int(s['campaigns'].sum())}; {time.perf_counter() - t0:.0f} s wall"
    )


if __name__ == "__main__":
    main()
