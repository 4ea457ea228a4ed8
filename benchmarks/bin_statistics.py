"""Benchmark: the per-bin mean and representative TI against the truth, before and after the
measurement-error model (docs/inference.md, "Bin statistics" and "Regime discrepancy").

Each scenario is generated and corrected as the acceptance tests do
(``validation.regimes.scenario_records``, seeds spawned from one root, none of them an
acceptance seed); from the same posterior draws of every record, per height and 1-m/s bin
with >= 30 records:

* ``draws``: the statistic over each draw's records (the tables before the model);
* ``population``: :func:`flidar_uq.correction.bin_population.population_statistic_draws`;
* ``population + regime``: the same with the regime discrepancy learnt on the reference
  records (:func:`flidar_uq.correction.regime_discrepancy.fit_regime_discrepancy`; equal to
  ``population`` where cross-validation does not keep it).

against the truth over the bin's records: whether the 90 % interval holds the true mean TI
and the true representative TI (mean + 1.28 sd), the relative error of the median and the
interval's relative width. Writes benchmarks/results/bin_statistics.csv (one row per bin and
method), bin_statistics_summary.csv and bin_statistics.png, and prints the summary; and
bin_statistics_regimes.csv: every campaign's regimes (smoothed residual, noise, ``delta``,
kept or not) and, printed last, the sd of the model's regime error per campaign
(:func:`regime_spread`), which sets the prior sd of the regime discrepancy without a
reference (``reference.regime_discrepancy_prior_sd``). ``--tag``
appends a suffix to every output's name (a development run beside the published one).

Usage: python benchmarks/bin_statistics.py [--records N] [--campaigns K] [--seed ROOT]
       [--tag NAME]
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
from _acceptance_runs import campaign_seeds  # noqa: E402

from flidar_uq.campaign.scenarios import load_scenario  # noqa: E402
from flidar_uq.correction.bin_population import population_statistic_draws  # noqa: E402
from flidar_uq.correction.regime_discrepancy import (  # noqa: E402
    fit_regime_discrepancy,
    regime_keys,
)
from flidar_uq.data.binning import speed_bin_ms  # noqa: E402
from flidar_uq.validation.regimes import scenario_records  # noqa: E402

RESULTS = Path(__file__).parent / "results"
OUT = RESULTS / "bin_statistics"
MIN_BIN = 30
#: (scenario, reference instrument, lidar): the campaigns of the comparison.
CASES = (
    ("cup_reference", "cup", None),
    ("fixed_lidar_reference", "fixed_lidar", None),
    ("wave_follower", "cup", None),
    ("dbs_wave_follower", "cup", "windcube_v2"),
)


def _interval(x, truth):
    lo, med, hi = np.quantile(x, [0.05, 0.5, 0.95])
    return bool(lo <= truth <= hi), med / truth - 1.0, (hi - lo) / truth


def one_campaign(scenario: str, kind: str, lidar: str | None, seed: int, n_records: int):
    """Every bin's statistics of one campaign by the three methods."""
    cfg = dict(load_scenario(scenario)) | {"reference_instrument": kind}
    t0 = time.perf_counter()
    rec, _, ti = scenario_records(
        cfg, seed, lidar=lidar, n_records=n_records, n_workers=1, ndraws=400, return_draws=True
    )
    t_campaign = time.perf_counter() - t0
    ti_ref = rec["ref_hws_std_ms"].to_numpy(float) / rec["ref_hws_mean_ms"].to_numpy(float)
    if kind == "fixed_lidar":
        ti_ref = ti_ref / rec["lidar_std_ratio"].to_numpy(float)
    day = pd.to_datetime(rec["timestamp"], utc=True).dt.floor("D").to_numpy()
    keys = regime_keys(rec)
    disc = fit_regime_discrepancy(rec["ti_corrected_median"].to_numpy(float), ti_ref, keys, day)
    shift = disc.draws(keys, ti.shape[0], np.random.default_rng(seed))
    truth = rec["ti_true"].to_numpy(float)
    ok = np.all(np.isfinite(ti), axis=0)
    bins = pd.DataFrame(
        {"h": rec["height_m"].to_numpy(float), "b": speed_bin_ms(rec["hws_mean_ms"].to_numpy())}
    )
    rows = []
    for (h, b), idx in bins.groupby(["h", "b"]).indices.items():
        k = idx[ok[idx]]
        if k.size < MIN_BIN:
            continue
        t = truth[k]
        true_mean, true_rep = t.mean(), t.mean() + 1.28 * t.std(ddof=1)
        x = ti[:, k].astype(float)
        draw_mean = x.mean(axis=1)
        methods = {"draws": (draw_mean, draw_mean + 1.28 * x.std(axis=1, ddof=1))}
        t1 = time.perf_counter()
        m, _, rep, _ = population_statistic_draws(ti, np.random.default_rng(seed), k)
        t_pop = time.perf_counter() - t1
        methods["population"] = (m, rep)
        if shift is not None:
            m, _, rep, _ = population_statistic_draws(
                ti, np.random.default_rng(seed), k, shift=shift
            )
        methods["population + regime"] = (m, rep)
        for name, (mean_d, rep_d) in methods.items():
            cm, em, wm = _interval(mean_d, true_mean)
            cr, er, wr = _interval(rep_d, true_rep)
            rows.append(
                {
                    "scenario": scenario, "reference": kind, "seed": seed, "height_m": h,
                    "hws_bin_ms": b, "n": k.size, "method": name, "mean_covered": cm,
                    "mean_error": em, "mean_width": wm, "rep_covered": cr, "rep_error": er,
                    "rep_width": wr, "regime_kept": disc.kept, "regime_reason": disc.reason,
                    "population_s": t_pop, "campaign_s": t_campaign,
                }
            )  # fmt: skip
    regimes = disc.regimes.assign(scenario=scenario, reference=kind, seed=seed, kept=disc.kept)
    return pd.DataFrame(rows), regimes


def regime_spread(regimes: pd.DataFrame) -> float:
    """The sd (log TI) of the model's regime error about 0 over the given regimes: the mean
    square of their smoothed residuals less that of their noise (the method of moments;
    the posterior means ``delta`` are shrunk towards 0 by the noise)."""
    excess = np.mean(regimes["residual"] ** 2) - np.mean(regimes["noise_sd"] ** 2)
    return float(np.sqrt(max(excess, 0.0)))


def summarise(d: pd.DataFrame) -> pd.DataFrame:
    """Coverage, median and worst error and median width per case and method."""
    g = d.groupby(["scenario", "reference", "method"], sort=False)
    return g.agg(
        bins=("n", "size"),
        mean_coverage=("mean_covered", "mean"),
        mean_error_median=("mean_error", "median"),
        rep_coverage=("rep_covered", "mean"),
        rep_error_median=("rep_error", "median"),
        rep_error_worst=("rep_error", lambda e: e.abs().max()),
        rep_width_median=("rep_width", "median"),
        population_s=("population_s", "sum"),
    ).reset_index()


def plot(s: pd.DataFrame, path: Path) -> None:
    """Coverage of the mean and of the representative TI per case, before and after."""
    cases = s[["scenario", "reference"]].drop_duplicates().apply(" / ".join, axis=1).tolist()
    methods = list(dict.fromkeys(s["method"]))
    fig, axes = plt.subplots(1, 3, figsize=(14, 4))
    for ax, (col, title) in zip(
        axes,
        (("mean_coverage", "90 % interval holds the true mean"),
         ("rep_coverage", "... the true representative TI"),
         ("rep_error_median", "representative TI: median relative error")),
        strict=True,
    ):  # fmt: skip
        for j, m in enumerate(methods):
            v = s[s["method"] == m][col].to_numpy()
            ax.bar(np.arange(len(cases)) + 0.27 * (j - 1), v, 0.27, label=m)
        ax.set_xticks(np.arange(len(cases)), cases, rotation=20, ha="right", fontsize=8)
        ax.set_title(title, fontsize=10)
        ax.grid(alpha=0.3, axis="y")
    axes[0].axhline(0.9, color="k", lw=0.8)
    axes[1].axhline(0.9, color="k", lw=0.8)
    axes[2].axhline(0.0, color="k", lw=0.8)
    axes[0].legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=110)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--records", type=int, default=2880, help="10-min records per campaign")
    ap.add_argument("--campaigns", type=int, default=1, help="campaigns per case")
    ap.add_argument("--seed", type=int, default=20261207, help="root of the campaign seeds")
    ap.add_argument("--tag", default="", help="suffix of the outputs' names")
    args = ap.parse_args()
    parts, regimes = [], []
    for scenario, kind, lidar in CASES:
        for seed in campaign_seeds(args.seed, args.campaigns):
            rows, reg = one_campaign(scenario, kind, lidar, seed, args.records)
            parts.append(rows)
            regimes.append(reg)
            print(f"{scenario} / {kind} seed {seed}: {len(rows) // 3} bins", flush=True)
    d = pd.concat(parts, ignore_index=True)
    out = f"{OUT}_{args.tag}" if args.tag else str(OUT)
    RESULTS.mkdir(exist_ok=True)
    d.to_csv(f"{out}.csv", index=False)
    s = summarise(d)
    s.to_csv(f"{out}_summary.csv", index=False)
    plot(s, Path(f"{out}.png"))
    r = pd.concat(regimes, ignore_index=True)
    r.to_csv(f"{out}_regimes.csv", index=False)
    with pd.option_context("display.width", 200, "display.max_columns", 20):
        print(s.round(4).to_string(index=False))
        low = d[(d["hws_bin_ms"] <= 4.0) & (d["method"] != "draws")]
        print(low.groupby(["scenario", "method", "hws_bin_ms"])[
            ["mean_error", "mean_width", "mean_covered", "rep_error", "rep_covered"]
        ].mean().round(4).to_string())  # fmt: skip
    for (scenario, kind), g in r.groupby(["scenario", "reference"]):
        print(f"{scenario} / {kind}: {len(g)} regimes, regime error sd {regime_spread(g):.4f}")
    print(f"all {len(r)} regimes: regime error sd {regime_spread(r):.4f} (log TI)")


if __name__ == "__main__":
    main()
