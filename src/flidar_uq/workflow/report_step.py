"""Workflow step of the report: the self-contained HTML report from the result files."""

from __future__ import annotations

import os
from collections.abc import Sequence
from pathlib import Path

import numpy as np
import pandas as pd

from flidar_uq.workflow.files import bin_file, read_csv

__all__ = ["build_report", "git_revision"]


def git_revision(repo_dir: str | os.PathLike) -> str:
    """Git revision (HEAD) of ``repo_dir``, "" outside a git checkout or without git.

    Read when the report is written (not a rule parameter, so a commit alone does not
    rerun the report).
    """
    import subprocess

    try:
        out = subprocess.run(
            ["git", "-C", str(repo_dir), "rev-parse", "HEAD"],
            capture_output=True,
            text=True,
            check=True,
        )
    except (OSError, subprocess.CalledProcessError):
        return ""
    return out.stdout.strip()


def regime_calibration_table(records: pd.DataFrame) -> pd.DataFrame:
    """Calibration of the corrected TI per regime of a records.csv table with ``ti_true``.

    The QC-kept records (no QC reason in ``flags``) in 3-20 m/s, grouped as
    :func:`flidar_uq.validation.regimes.scenario_calibration` does (speed group; sea state
    and heading where the truth columns ``true_swell_present`` / ``true_weathervane``
    exist).
    """
    from flidar_uq.validation.regimes import regime_labels, scenario_calibration

    qc_reasons = (
        records["flags"]
        .fillna("")
        .str.split(";")
        .map(lambda fl: any(f and f not in MODEL_FLAGS for f in fl))
    )
    hws = records["hws_mean_ms"].to_numpy(dtype=float)
    pool = records[~qc_reasons.to_numpy() & (hws >= 3.0) & (hws < 20.0)]
    pool = pd.concat([pool, regime_labels(pool)], axis=1)
    tab = scenario_calibration(pool)
    if "true_swell_present" not in records:
        tab = tab[~tab["grouping"].isin(["sea_state", "sea_state_heading"])]
    if "true_weathervane" not in records:
        tab = tab[~tab["grouping"].isin(["heading", "sea_state_heading"])]
    cols = ["grouping", "group", "n", "answered_share", "coverage", "coverage_lo"]
    cols += ["coverage_hi", "mean_rel_error", "median_rel_width"]
    return tab[cols].round(4)


#: Flags set by the model (not by QC): a record with only these was kept by QC.
MODEL_FLAGS = (
    "unbinned",
    "bin_not_fitted",
    "bin_failed",
    "bin_error",
    "no_motion_description",
    "discriminant_negative",
    "global_fit_failed",
)


def _capped_table(rep, df: pd.DataFrame, name: str, max_rows: int = 40) -> str:
    caption = name if len(df) <= max_rows else f"{name}: first {max_rows} of {len(df)} rows"
    return rep.table_html(df.head(max_rows), caption=caption)


def build_report(
    *,
    out_path: str | os.PathLike,
    results_dir: str | os.PathLike,
    batch_dirs: Sequence[str | os.PathLike],
    config: dict,
    benchmarks_dir: str | os.PathLike | None = None,
    git_revision: str = "",
    series_paths: dict | None = None,
) -> str:
    """Write the self-contained HTML report from the pipeline's result files.

    Parameters
    ----------
    out_path : path
        The HTML file.
    results_dir : path
        The pipeline's ``results/`` directory (ti/, bins/, qc/, motion/, inference/, posterior/).
    batch_dirs : sequence of path
        The per-bin inference batch directories.
    config : dict
        The run's configuration (provenance; thresholds of the convergence plot).
    benchmarks_dir : path, optional
        Directory of benchmark PNG charts (and ``los_*.csv`` comparison tables); skipped if absent.
    git_revision : str
        Revision of the workflow's repository.
    series_paths : dict, optional
        Result files of the raw IMU series and the LOS branch, when given
        (:func:`flidar_uq.workflow.series_report.series_sections`).

    Returns
    -------
    str
        The HTML text written.
    """
    from flidar_uq import inference as inf
    from flidar_uq.physics import variance_laws as correction
    from flidar_uq.workflow import plots
    from flidar_uq.workflow import report as rep

    res = Path(results_dir)
    records = read_csv(res / "ti" / "records.csv")
    bins = read_csv(res / "ti" / "bins.csv")
    metrics = read_csv(res / "ti" / "metrics.csv")
    qc_counts = read_csv(res / "qc" / "summary.csv")
    roll_pitch = read_csv(res / "motion" / "roll_pitch.csv")
    bin_fits = read_csv(res / "inference" / "bin_fits.csv")
    global_summary = read_csv(res / "inference" / "global.csv")
    gfit = inf.load_fit(res / "posterior" / "global.nc")
    mass = float(config["propagation"]["credible_mass"])
    sections = []

    n_in = len(records)
    kept = records["flags"].fillna("").eq("") | records["ti_corrected_median"].notna()
    status_counts = bins["status"].value_counts()
    overview = pd.DataFrame(
        [
            ("input records", n_in),
            ("records with a corrected TI", int(records["ti_corrected_median"].notna().sum())),
            ("records flagged (any reason)", int((records["flags"].fillna("") != "").sum())),
            ("bins", len(bins)),
            ("bins fitted and converged (ok)", int(status_counts.get("ok", 0))),
            ("bins failed (convergence missed)", int(status_counts.get("failed", 0))),
            ("bins whose fit raised (error)", int(status_counts.get("error", 0))),
            ("bins not fitted (too few records)", int(status_counts.get("not_fitted", 0))),
            ("global fit converged", bool(gfit.converged)),
            ("motion model", "record" if inf.is_record_model(gfit) else "bin"),
        ],
        columns=["quantity", "value"],
    )
    del kept
    sections.append(rep.Section("Overview", rep.table_html(overview)))
    warning = gfit.info.get("motion_scale_warning")
    if warning:
        sections.append(rep.Section("Warning: model discrepancy", f"<p>{warning}</p>"))
    flag_counts = (
        records["flags"]
        .fillna("")
        .replace("", "(none: corrected)")
        .value_counts()
        .rename_axis("flags")
    )
    sections.append(
        rep.Section(
            "What was flagged and why",
            rep.table_html(
                flag_counts.rename("records").reset_index(),
                caption="records of results/ti/records.csv per flag string (QC reasons, "
                "no_motion_description, discriminant_negative, bin_* with the bin model)",
            ),
        )
    )

    sections.append(
        rep.Section(
            "Quality control",
            rep.table_html(qc_counts, caption=rep.caption("qc_filters"))
            + rep.table_html(
                roll_pitch,
                caption=rep.caption("roll_pitch"),
            ),
        )
    )

    cols = [
        c
        for c in (
            "bin_id",
            "hws_ms",
            "amplitude_deg",
            "period_s",
            "count",
            "sigma_z_ms",
            "mean_z_ms",
            "status",
            "model",
            "ti_uncorrected_mean",
            "ti_corrected_median_mean",
            "ti_corrected_lo_mean",
            "ti_corrected_hi_mean",
            "ti_true_mean",
        )
        if c in bins
    ]
    shown = bins["status"] != "not_fitted"
    table1 = bins.loc[shown, cols].rename(
        columns={
            "bin_id": "case no.",
            "hws_ms": "HWS (m/s)",
            "amplitude_deg": "AA (deg)",
            "period_s": "T (s)",
            "count": "count no.",
            "sigma_z_ms": "sigma_Z (m/s)",
        }
    )
    sections.append(
        rep.Section(
            "Bin table (seed 000 Table 1 style)",
            rep.table_html(
                table1,
                caption=rep.caption("bin_table", mass=mass, n_hidden=int((~shown).sum())),
            ),
        )
    )

    rho_med = float(np.median(gfit.flat("rho")))
    rho_seed = float(metrics["rho_seed000"].iloc[0]) if len(metrics) else float("nan")
    ref_col = next((c for c in ("ref_hws_std_ms", "true_hws_std_ms") if c in records), None)
    if ref_col is not None:
        ok = records["ti_corrected_median"].notna()
        r = records[ok]
        ref = r[ref_col].to_numpy(dtype=float)
        # seed 000's rho needs >= 3 bins; otherwise the PC curve uses the posterior median
        rho_pc, rho_src = (
            (rho_seed, "seed 000") if np.isfinite(rho_seed) else (rho_med, "posterior median")
        )
        szb = r["sigma_z_seed000_ms"].to_numpy(dtype=float)
        corr = {
            "U": correction.sigma_moving_u(ref, szb),
            "C": correction.sigma_moving_c(ref, szb),
            "PC": correction.sigma_moving_pc(ref, szb, rho_pc),
            "Bayesian": correction.sigma_moving_pc(
                ref, r["sigma_z_median_ms"].to_numpy(dtype=float), rho_med
            ),
        }
        label = "reference" if ref_col == "ref_hws_std_ms" else "truth"
        body = rep.img_html(
            rep.figure_to_data_uri(
                plots.sigma_scatter_figure(r["hws_std_ms"].to_numpy(), ref, corr, ref_label=label)
            ),
            rep.caption("sigma_scatter", label=label, rho_pc=rho_pc, rho_src=rho_src),
        )
        top = bins.loc[bins["status"] == "ok", "bin_id"].head(3).tolist()
        for bid in top:
            sel = (r["bin_id"] == bid).to_numpy()
            sub = {k: v[sel] for k, v in corr.items() if k in ("PC", "Bayesian")}
            body += rep.img_html(
                rep.figure_to_data_uri(
                    plots.sigma_scatter_figure(
                        r["hws_std_ms"].to_numpy()[sel], ref[sel], sub, ref_label=label
                    )
                ),
                rep.caption("sigma_scatter_case", bin_id=bid),
            )
        sections.append(
            rep.Section(
                "sigma_moving against sigma_ref and sigma_corr (seed 000 Figs. 4-5 style)", body
            )
        )

    sections.append(
        rep.Section(
            "MD and RMSE by correction method (seed 000 Tables 2-3 style)",
            rep.table_html(
                metrics,
                caption=rep.caption("metrics"),
            ),
        )
    )
    refs = {}
    if "ti_true" in records:
        refs["truth"] = records["ti_true"].to_numpy(dtype=float)
    if "ti_ref" in records:
        refs["reference lidar (interval x lidar_std_ratio)"] = (
            records["ti_ref"].to_numpy(dtype=float),
            records["lidar_std_ratio"].to_numpy(dtype=float),
        )
    if refs:
        sections.append(
            rep.Section(
                "Calibration of the credible intervals by wind speed",
                rep.img_html(
                    rep.figure_to_data_uri(
                        plots.calibration_figure(
                            records["hws_mean_ms"].to_numpy(dtype=float),
                            records["ti_corrected_median"].to_numpy(dtype=float),
                            records["ti_corrected_lo"].to_numpy(dtype=float),
                            records["ti_corrected_hi"].to_numpy(dtype=float),
                            refs,
                            credible_mass=mass,
                        )
                    ),
                    rep.caption("calibration", mass=mass),
                ),
            )
        )
    if "ti_true" in records:
        sections.append(
            rep.Section(
                "Calibration by regime (against the truth)",
                rep.table_html(
                    regime_calibration_table(records),
                    caption=f"{mass:.0%} intervals of the corrected TI against the virtual "
                    "campaign's truth, QC-kept records in 3-20 m/s, per 3-m/s speed group, "
                    "sea state and heading (truth columns); answered_share: records with a "
                    "corrected TI; coverage with its 95 % Wilson interval",
                ),
            )
        )
    sections.append(
        rep.Section(
            "TI against HWS with credible bands (seed 000 Fig. 8 style)",
            rep.img_html(
                rep.figure_to_data_uri(plots.ti_vs_hws_figure(records, credible_mass=mass)),
                rep.caption("ti_vs_hws", mass=mass),
            ),
        )
    )

    post = rep.img_html(
        rep.figure_to_data_uri(
            plots.posterior_figure(
                {k: np.asarray(v) for k, v in gfit.draws.items()},
                title="global posterior, one line per ensemble",
            )
        ),
        rep.caption("global_posterior"),
    )
    post += rep.table_html(global_summary, caption=rep.caption("global_summary"))
    ok_bins = bin_fits.loc[bin_fits["status"] == "ok", "bin_id"].astype(int).head(1).tolist()
    for bid in ok_bins:
        bfit = inf.load_fit(bin_file(batch_dirs, bid))
        post += rep.img_html(
            rep.figure_to_data_uri(
                plots.posterior_figure(
                    {k: np.asarray(v) for k, v in bfit.draws.items()},
                    title=f"case no. {bid}: motion posterior",
                )
            ),
            rep.caption("bin_posterior", bin_id=bid),
        )
    post += rep.img_html(
        rep.figure_to_data_uri(
            plots.convergence_figure(
                bin_fits,
                rhat_max=config["inference"]["rhat_max"],
                ess_min=config["inference"]["ess_min"],
            )
        ),
        rep.caption("convergence"),
    )
    post += rep.table_html(bin_fits, caption=rep.caption("bin_fits"))
    sections.append(rep.Section("Posteriors and convergence", post))

    if benchmarks_dir is not None and Path(benchmarks_dir).is_dir():
        bdir = Path(benchmarks_dir)
        los = sorted(bdir.glob("los*comparison.csv"))
        if los:
            sections.append(
                rep.Section(
                    "LOS-level correction compared with the statistical correction",
                    "".join(_capped_table(rep, read_csv(p), p.name) for p in los),
                )
            )
        pngs = sorted(bdir.glob("*.png"))
        if pngs:
            sections.append(
                rep.Section(
                    "Speed-accuracy charts (benchmarks/results)",
                    "".join(
                        rep.img_html(rep.png_bytes_to_data_uri(p.read_bytes()), p.name)
                        for p in pngs
                    ),
                )
            )

    from flidar_uq.workflow.series_report import series_sections

    sections += series_sections(**(series_paths or {}))  # raw IMU series, LOS branch
    sections.append(
        rep.Section("Provenance", rep.provenance_html(config, git_revision, rep.package_versions()))
    )
    text = rep.render_html("flidar_uq report: motion-corrected turbulence intensity", sections)
    Path(out_path).parent.mkdir(parents=True, exist_ok=True)
    Path(out_path).write_text(text, encoding="utf-8")
    return text
