"""The method frontier: wall time against accuracy of every TI correction, on one campaign with truth.

Methods, all on the QC-kept records of the same virtual campaign (default scenario), scored
against the true point TI (``true_ti``):

* uncorrected (the floating lidar's TI);
* Gutiérrez-Antuñano et al.'s (2018) U, C, PC laws (:func:`flidar_uq.correction.propagation.variance_law_baselines`
  and Eqs. 15-17 inverted; one shared wall time: the three come from one call);
* the Bayesian correction: the record motion model
  (:func:`flidar_uq.inference.fit_record_model`) propagated by
  :func:`flidar_uq.correction.propagation.draw_corrected_ti` (point target, as the pipeline),
  at several sampler budgets (walkers x fixed steps, and the default adaptive budget);
* its Laplace approximation (:func:`flidar_uq.inference.laplace.laplace_record_model`)
  through the same propagation;
* the LOS-level least-squares correction (:func:`flidar_uq.correction.los.correct_least_squares`
  with the campaign's 5-Hz noisy IMU), which needs LOS data: a separate, smaller LOS
  campaign of the same scenario (``N_LOS_RECORDS`` records x 3 heights), scored with its own
  uncorrected row; its time is the correction alone (not the LOS simulation).

Wall times are measured in this run (one process, single-threaded fits); the Bayesian and
Laplace times include the point-target terms (:func:`point_target`) and the propagation.
Per method and per speed group (true HWS < 6, 6-10, >= 10 m/s): mean |relative TI error|
per record, 90 % interval coverage and median interval width where the method gives
intervals. Writes benchmarks/results/method_frontier.csv and method_frontier.png and prints
the table with the time and error ratios to the uncorrected row side by side.

Usage: python benchmarks/method_frontier.py [records.csv | --plot-only]
(records.csv: the default pipeline's ``results/campaign/records.parquet``; without it the
default scenario is generated here, ~2 min on 2 cores.)
"""

from __future__ import annotations

import copy
import subprocess
import sys
import time
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pandas as pd  # noqa: E402
import yaml  # noqa: E402

from flidar_uq.campaign.physics_mode import generate_campaign  # noqa: E402
from flidar_uq.campaign.scenarios import DEFAULT_SCENARIO, load_scenario  # noqa: E402
from flidar_uq.correction import propagation as prop  # noqa: E402
from flidar_uq.correction.los import correct_least_squares  # noqa: E402
from flidar_uq.data import binning, io, qc  # noqa: E402
from flidar_uq.inference import fit_record_model  # noqa: E402
from flidar_uq.inference.laplace import laplace_record_model  # noqa: E402
from flidar_uq.inference.priors import SamplerSettings  # noqa: E402
from flidar_uq.physics import motion as M  # noqa: E402
from flidar_uq.physics.surrogate import get_surrogate  # noqa: E402
from flidar_uq.physics.variance_laws import corrected_std  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent
OUT = Path(__file__).parent / "results"
CONFIG = yaml.safe_load((ROOT / "config" / "config.yaml").read_text())
SEED = 20261128
CREDIBLE_MASS = 0.9
NDRAWS = 400  # propagated draws per record (config propagation.ndraws default)
N_LOS_RECORDS = 24
# sampler budgets: (label, nwalkers, nsteps, nburn, global_max_step_factor); the last is the
# pipeline default (adaptive extension up to 12 x nsteps until the convergence criteria hold)
BUDGETS = [
    ("Bayes 12w x 40", 12, 40, 20, 1.0),
    ("Bayes 16w x 100", 16, 100, 50, 1.0),
    ("Bayes default (adaptive)", 16, 250, 100, 12.0),
]


def speed_group(hws_ms):
    return np.where(hws_ms < 6, "<6", np.where(hws_ms < 10, "6-10", ">=10"))


def prepare(records):
    """QC (config), motion statistics and bins (config) as the pipeline does them."""
    res = qc.run_qc(records, qc.QCConfig(**CONFIG["qc"]))
    kept = binning.add_harmonic_motion(res.kept)
    b = CONFIG["binning"]
    assigned, _ = binning.bin_records(
        kept,
        hws_width_ms=b["hws_width_ms"],
        amplitude_width_deg=b["amplitude_width_deg"],
        period_width_s=b["period_width_s"],
        min_count=b["min_count"],
    )
    kept["bin_id"] = assigned["case_no"].reindex(kept.index).where(lambda c: c > 0)
    return kept.reset_index(drop=True)


def score(name, family, wall_s, ti, truth, hws, lo=None, hi=None, extra=None):
    rows = []
    groups = speed_group(hws)
    for g in ("all", "<6", "6-10", ">=10"):
        m = np.isfinite(ti) & np.isfinite(truth) & ((groups == g) if g != "all" else True)
        if not m.any():  # e.g. no record >= 10 m/s in the small LOS campaign
            continue
        row = dict(
            method=name,
            family=family,
            speed_group_ms=g,
            wall_s=wall_s,
            wall_s_per_record=wall_s / len(ti),
            n_records=int(m.sum()),
            mean_abs_rel_err=float(np.mean(np.abs(ti[m] - truth[m]) / truth[m])),
            mean_rel_err=float(np.mean((ti[m] - truth[m]) / truth[m])),
            coverage_90=np.nan,
            median_width=np.nan,
        )
        if lo is not None:
            row["coverage_90"] = float(np.mean((lo[m] <= truth[m]) & (truth[m] <= hi[m])))
            row["median_width"] = float(np.median(hi[m] - lo[m]))
        rows.append({**row, **(extra or {})})
    return rows


def campaign_methods(rec, sur):
    rows = []
    truth = rec["true_ti"].to_numpy(dtype=float)
    hws_true = rec["true_hws_mean_ms"].to_numpy(dtype=float)
    m = rec["hws_mean_ms"].to_numpy(dtype=float)
    s = rec["hws_std_ms"].to_numpy(dtype=float)

    t0 = time.perf_counter()
    ti_unc = s / m
    rows += score("uncorrected", "uncorrected", time.perf_counter() - t0, ti_unc, truth, hws_true)

    t0 = time.perf_counter()
    sz_seed, rho_seed = prop.variance_law_baselines(rec, sur)
    with np.errstate(invalid="ignore", divide="ignore"):
        laws = {
            "U (rho=0)": corrected_std(s, sz_seed, 0.0)[0] / m,
            "C (rho=1)": corrected_std(s, sz_seed, 1.0)[0] / m,
            f"PC (rho={rho_seed:.2f})": corrected_std(s, sz_seed, np.clip(rho_seed, -1, 1))[0] / m,
        }
    t_laws = time.perf_counter() - t0
    for k, ti in laws.items():
        rows += score(k, "Gutiérrez-Antuñano et al. (2018) law", t_laws, ti, truth, hws_true)

    t0 = time.perf_counter()
    heights = int(rec["height_m"].nunique())
    g_ratio, log_sd = prop.point_target(
        m,
        rec["height_m"].to_numpy(dtype=float),
        "zephir300",
        heights_in_turn=heights,
        refocus_delay_s=(0.3, 0.7),
        point_sample_interval_s=1.0,
        turbulence_dt_s=DEFAULT_SCENARIO["wind"]["wind_dt_s"],
        seed=SEED,
    )
    t_point = time.perf_counter() - t0

    def propagate(gfit, seed):
        t = time.perf_counter()
        draws = prop.draw_corrected_ti(
            rec,
            [],
            gfit,
            surrogate=sur,
            settings=prop.PropagationSettings(ndraws=NDRAWS, credible_mass=CREDIBLE_MASS),
            target=prop.PointTarget(lidar_std_ratio=g_ratio, point_log_sd=log_sd),
            seed=seed,
        )
        per = prop.record_summary(rec, draws, (sz_seed, rho_seed))
        return per, time.perf_counter() - t

    def score_fit(label, method, fit, t_fit, prop_seed, **extra):
        """Propagate a global fit and score it (wall time: fit + propagation + point target)."""
        per, t_prop = propagate(fit, prop_seed)
        return score(
            label,
            method,
            t_fit + t_prop + t_point,
            per["ti_corrected_median"].to_numpy(),
            truth,
            hws_true,
            per["ti_corrected_lo"].to_numpy(),
            per["ti_corrected_hi"].to_numpy(),
            dict(
                fit_s=t_fit,
                converged=fit.converged,
                rho_median=float(np.median(fit.flat("rho"))),
                lever_arm_median_m=float(np.median(fit.flat("lever_arm_m"))),
                **extra,
            ),
        )

    for i, (label, nw, ns, nb, maxf) in enumerate(BUDGETS):
        settings = SamplerSettings(
            nwalkers=nw, nsteps=ns, nburn=nb, ndraws=min(ns, 250), global_max_step_factor=maxf
        )
        t0 = time.perf_counter()
        fit = fit_record_model(rec, surrogate=sur, settings=settings, seed=SEED + i)
        t_fit = time.perf_counter() - t0
        rows += score_fit(
            label,
            "Bayesian (emcee)",
            fit,
            t_fit,
            SEED + 100 + i,
            log_prob_evals_nominal=nw * fit.draws["rho"].shape[0] * (ns + nb),
        )
    t0 = time.perf_counter()
    lap = laplace_record_model(rec, surrogate=sur, ndraws=1000, seed=SEED + 50)
    t_fit = time.perf_counter() - t0
    rows += score_fit("Laplace", "Laplace approximation", lap, t_fit, SEED + 150)
    for r in rows:
        r.update(campaign=f"default scenario, {len(rec)} QC-kept records", point_target_s=t_point)
    return rows


def los_methods():
    """LOS-level LS on a small LOS campaign of the default scenario (5-Hz IMU with noise, gaps)."""
    sc = copy.deepcopy(DEFAULT_SCENARIO)
    sc.update(name="method_frontier_los", n_records=N_LOS_RECORDS)
    t0 = time.perf_counter()
    out = generate_campaign(sc, SEED, return_imu=True, return_los=True, n_workers=1)
    t_gen = time.perf_counter() - t0
    lever = tuple(sc["lidar"]["lever_arm_m"])
    origin = out.records.timestamp.min()
    los = out.los.sort_values("timestamp")
    t_los = (los.timestamp - origin).dt.total_seconds().to_numpy()
    imu_t = out.imu.dropna().sort_values("timestamp")
    t_imu = (imu_t.timestamp - origin).dt.total_seconds().to_numpy()
    ti_ls, ti_unc, truth, hws, t_ls = [], [], [], [], 0.0
    for rec in out.records.itertuples():
        t0s = (rec.timestamp - origin).total_seconds()
        sel_i = (t_imu >= t0s - 5.0) & (t_imu <= t0s + sc["record_length_s"] + 5.0)
        if sel_i.sum() < 10 or not np.isfinite(rec.hws_std_ms) or not np.isfinite(rec.true_ti):
            continue
        sel = (t_los >= t0s) & (t_los < t0s + sc["record_length_s"])
        sel &= los.height_m.to_numpy() == rec.height_m
        n = int(sel.sum()) // 50 * 50
        t = t_los[sel][:n]
        az = np.radians(los.azimuth_deg.to_numpy()[sel][:n])
        vr = los.radial_speed_ms.to_numpy()[sel][:n]
        t1 = time.perf_counter()
        motion = M.SampledMotion(
            t_imu[sel_i],
            imu_t.roll_deg.to_numpy()[sel_i],
            imu_t.pitch_deg.to_numpy()[sel_i],
            imu_t.yaw_deg.to_numpy()[sel_i],
            lever_arm_m=lever,
        )
        h = correct_least_squares("zephir300", t, az, vr, motion).hws_ms
        ti_ls.append(np.nanstd(h) / np.nanmean(h))
        t_ls += time.perf_counter() - t1
        ti_unc.append(rec.hws_std_ms / rec.hws_mean_ms)
        truth.append(rec.true_ti)
        hws.append(rec.true_hws_mean_ms)
    truth, hws = np.array(truth), np.array(hws)
    camp = f"LOS campaign (default scenario, {len(truth)} records)"
    rows = score("uncorrected (LOS campaign)", "uncorrected", 0.0, np.array(ti_unc), truth, hws)
    rows += score("LOS least squares", "LOS-level", t_ls, np.array(ti_ls), truth, hws)
    for r in rows:
        r.update(campaign=camp, los_generation_s=t_gen)
    return rows


def plot(df, path, load):
    """Wall time for the main campaign; the LOS rows extrapolated linearly (per-record cost)."""
    allr = df[df.speed_group_ms == "all"].copy()
    n_main = int(allr[allr.family == "Bayesian (emcee)"].n_records.iloc[0])
    los = allr.family == "LOS-level"
    allr.loc[los, "wall_s"] = allr.loc[los, "wall_s_per_record"] * n_main
    allr.loc[los, "method"] = (
        allr.loc[los, "method"] + f" (x{n_main // allr.loc[los, 'n_records'].iloc[0]} extrapolated)"
    )
    fig, (a1, a2) = plt.subplots(1, 2, figsize=(12, 5.6))
    marks = {
        "uncorrected": "o",
        "Gutiérrez-Antuñano et al. (2018) law": "s",
        "Bayesian (emcee)": "D",
        "Laplace approximation": "*",
        "LOS-level": "^",
    }
    for i, (_, r) in enumerate(allr.iterrows()):
        x = max(r.wall_s, 1e-5)  # the LOS campaign's uncorrected row costs nothing
        kw = dict(
            marker=marks[r.family],
            ms=12 if r.family == "Laplace approximation" else 7,
            color=f"C{i % 10}",
            ls="none",
            alpha=0.85,
        )
        a1.plot(x, 100 * r.mean_abs_rel_err, label=r.method, **kw)
        if np.isfinite(r.coverage_90):
            a2.plot(x, 100 * r.coverage_90, label=f"{r.method}: width {r.median_width:.4f}", **kw)
    bayes = allr[allr.family == "Bayesian (emcee)"]
    a1.plot(bayes.wall_s, 100 * bayes.mean_abs_rel_err, color="0.6", lw=0.8)
    a2.plot(bayes.wall_s, 100 * bayes.coverage_90, color="0.6", lw=0.8)
    for a in (a1, a2):
        a.set_xscale("log")
        a.set_xlabel(f"wall time for {n_main} records (s, log; this run, 1 thread)")
        a.grid(alpha=0.3, which="both")
    a1.set_ylabel("mean |relative TI error| per record vs true TI (%)")
    a2.axhline(90, color="k", lw=0.8, ls="--")
    a2.set_ylim(80, 100)
    a1.legend(fontsize=7, loc="upper center", bbox_to_anchor=(0.5, -0.16), ncol=2)
    a2.legend(fontsize=7, loc="upper center", bbox_to_anchor=(0.5, -0.16), ncol=1)
    a2.set_ylabel("90 % interval coverage of the true TI (%)")
    a1.set_title("accuracy (LOS rows: a smaller LOS campaign, own uncorrected)", fontsize=9)
    a2.set_title("interval coverage (methods with intervals)", fontsize=9)
    fig.suptitle(
        f"Method frontier, default scenario; load average during the run: {load}", fontsize=9
    )
    fig.tight_layout()
    fig.savefig(path, dpi=110)


def main(records_path: str | None = None) -> None:
    OUT.mkdir(exist_ok=True)
    if records_path == "--plot-only":  # redraw the PNG from the CSV of the last run
        df = pd.read_csv(OUT / "method_frontier.csv")
        plot(df, OUT / "method_frontier.png", df["uptime_load_1_5_15"].iloc[0])
        return
    t_start = time.perf_counter()
    if records_path:
        records = io.read_records(records_path)
        source = records_path
    else:
        scen = load_scenario("default")
        records = generate_campaign(scen, CONFIG["campaign"]["seed"], n_workers=2).records
        source = "generated (default scenario, config seed)"
    rec = prepare(records)
    sur = get_surrogate("zephir300")
    rows = campaign_methods(rec, sur) + los_methods()
    load = subprocess.run(["uptime"], capture_output=True, text=True).stdout.strip()
    load = load.split("load average:")[-1].strip()
    df = pd.DataFrame(rows)
    df["records_source"] = source
    df["uptime_load_1_5_15"] = load
    df["total_benchmark_s"] = time.perf_counter() - t_start
    df.to_csv(OUT / "method_frontier.csv", index=False)
    plot(df, OUT / "method_frontier.png", load)
    allr = df[df.speed_group_ms == "all"].copy()
    for _camp, g in allr.groupby("campaign", sort=False):
        base = g[g.family == "uncorrected"].iloc[0]
        allr.loc[g.index, "err_ratio_to_uncorrected"] = g.mean_abs_rel_err / base.mean_abs_rel_err
    bayes_default = allr[allr.method == "Bayes default (adaptive)"].iloc[0]
    allr["time_ratio_to_bayes_default"] = allr.wall_s / bayes_default.wall_s
    cols = ["method", "wall_s", "fit_s", "time_ratio_to_bayes_default", "mean_abs_rel_err",
            "err_ratio_to_uncorrected", "coverage_90", "median_width", "n_records"]  # fmt: skip
    with pd.option_context("display.width", 200, "display.float_format", "{:.4g}".format):
        print(allr[cols].to_string(index=False))
        print("\nper speed group (true HWS, m/s):")
        print(
            df.pivot_table(
                index="method", columns="speed_group_ms", values="mean_abs_rel_err", sort=False
            ).to_string()  # fmt: skip
        )
    print(f"\nload average (1, 5, 15 min): {load}; total {time.perf_counter() - t_start:.0f} s")


if __name__ == "__main__":
    main(*sys.argv[1:2])
