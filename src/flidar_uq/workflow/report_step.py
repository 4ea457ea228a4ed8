"""Workflow step of the report: the self-contained HTML report from the result files."""

from __future__ import annotations

import os
from collections.abc import Sequence
from pathlib import Path

import numpy as np
import pandas as pd
from markupsafe import Markup

from flidar_uq.threads import numeric_environment
from flidar_uq.workflow.files import bin_file, read_csv

__all__ = [
    "build_developer_report",
    "build_report",
    "file_provenance",
    "git_revision",
    "loo_statement",
    "reference_kind",
]


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
    exist). With a reference lidar's campaign-wide error of ``g`` in the total interval
    (``ti_corrected_lo_total`` differs from ``ti_corrected_lo``), also the coverage and
    median width of the total interval (``coverage_total``, ``median_rel_width_total``).
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
    total = ("ti_corrected_lo_total", "ti_corrected_hi_total")
    if all(c in pool for c in total) and not pool[list(total)].equals(
        pool[["ti_corrected_lo", "ti_corrected_hi"]].set_axis(list(total), axis=1)
    ):
        wide = scenario_calibration(
            pool.assign(ti_corrected_lo=pool[total[0]], ti_corrected_hi=pool[total[1]])
        )
        tab = tab.assign(
            coverage_total=wide.loc[tab.index, "coverage"],
            median_rel_width_total=wide.loc[tab.index, "median_rel_width"],
        )
        cols += ["coverage_total", "median_rel_width_total"]
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


#: Sources of the uncertainty budget in the report's words.
SOURCE_LABELS = {
    "motion": "motion (sigma_Z)",
    "rho": "rho",
    "noise_model": "noise model",
    "reference_response": "reference response g",
    "sampling": "10-min std sampling",
}


def reference_kind(config: dict, metrics: pd.DataFrame | None = None) -> str:
    """What the corrected TI is calibrated against, in words.

    The kind the run resolved (``metrics["reference_kind"]``, written by the propagation:
    the config's ``reference.kind``, or the virtual scenario's reference instrument),
    else ``config["reference"]["kind"]``; the corrected TI is the point (cup-like) TI.
    """
    kind = None
    if metrics is not None and "reference_kind" in metrics and len(metrics):
        kind = str(metrics["reference_kind"].iloc[0])
    kind = kind or (config.get("reference") or {}).get("kind") or "none"
    words = {
        "cup": "cup anemometer: the model is calibrated to the point wind directly",
        "sonic": "sonic anemometer: the model is calibrated to the point wind directly",
        "fixed_lidar": "fixed (motionless) lidar: the point TI through its std ratio g, "
        "with g's uncertainty",
        "none": "none: the point TI through a motionless lidar of the floating lidar's type",
    }
    return f"{kind} ({words.get(kind, kind)}); corrected TI given as the point (cup-like) TI"


def file_provenance(paths: dict[str, str | os.PathLike]) -> pd.DataFrame:
    """Name, SHA-256, size and data rows of each existing file (the report's provenance)."""
    import hashlib

    rows = []
    for label, path in paths.items():
        p = Path(path)
        if not p.is_file():
            continue
        data = p.read_bytes()
        n_rows = data.count(b"\n") - 1 if p.suffix == ".csv" else None
        rows.append(
            {
                "file": label,
                "sha256": hashlib.sha256(data).hexdigest(),
                "bytes": len(data),
                "data rows": n_rows,
            }
        )
    return pd.DataFrame(rows, columns=["file", "sha256", "bytes", "data rows"])


def loo_statement(global_summary: pd.DataFrame) -> str:
    """The global model's PSIS-LOO comparisons (global.csv) in words; "" without any."""
    if not len(global_summary):
        return ""
    row = global_summary.iloc[0]
    out = []
    model = row.get("global_model", "")
    if isinstance(model, str) and model:
        out.append(f"Global model chosen: {model}.")
    d, se = row.get("elpd_diff_per_bin_rho", np.nan), row.get("elpd_diff_se", np.nan)
    if row.get("preferred_rho_model") == "per_bin":
        out.append(
            f"PSIS-LOO prefers a separate rho per bin to the single global rho (elpd "
            f"difference {d:.0f} +- {se:.0f}): the correlation between the motion error and "
            "the turbulence differs between bins, so the global rho is a compromise and the "
            "intervals of bins far from the average may be too narrow or too wide."
        )
    elif np.isfinite(d):
        out.append(
            f"A per-bin rho is not preferred to the global rho by PSIS-LOO (elpd difference "
            f"{d:.1f} +- {se:.1f})."
        )
    return " ".join(out)


def _fmt_interval(med, lo, hi, digits: int = 3) -> str | None:
    if not np.isfinite(med):
        return None
    return f"{med:.{digits}f} [{lo:.{digits}f}, {hi:.{digits}f}]"


def _link_note(n_shown: int, n_total: int, csv: str) -> str:
    """'n of N rows shown; full table: <link>' below a summarised table."""
    from markupsafe import escape

    shown = f"all {n_total} rows" if n_shown >= n_total else f"{n_shown} of {n_total} rows shown"
    return (
        f'<p class="more">{shown}; full table: <a href="../{escape(csv)}">'
        f"results/{escape(csv)}</a></p>"
    )


def _summarised(rep, df: pd.DataFrame, caption: str, csv: str, max_rows: int = 15) -> str:
    return rep.table_html(df.head(max_rows), caption=caption) + _link_note(
        min(max_rows, len(df)), len(df), csv
    )


def _truth_speed_bins(records: pd.DataFrame) -> pd.DataFrame:
    """True TI per height and speed bin over the records with a corrected TI (virtual campaigns)."""
    from flidar_uq.data.binning import speed_bin_ms
    from flidar_uq.data.metrics import representative_ti

    if "ti_true" not in records:
        return pd.DataFrame(columns=["height_m", "hws_bin_ms", "ti_mean", "ti_rep"])
    r = records[records["ti_corrected_median"].notna()]
    r = r.assign(hws_bin_ms=speed_bin_ms(r["hws_mean_ms"].to_numpy(dtype=float)))
    g = r.groupby(["height_m", "hws_bin_ms"])["ti_true"]
    return pd.DataFrame({"ti_mean": g.mean(), "ti_rep": g.agg(representative_ti)}).reset_index()


def _truth_check(speed_bins: pd.DataFrame, truth_bins: pd.DataFrame) -> str:
    """How often the bin-statistic intervals hold the true statistic (virtual campaigns)."""
    m = speed_bins.merge(truth_bins, on=["height_m", "hws_bin_ms"], suffixes=("", "_true"))
    m = m.dropna(subset=["ti_mean", "ti_mean_true"])
    parts = []
    for stat, name in (("ti_mean", "mean"), ("ti_rep", "representative TI")):
        inside = (m[f"{stat}_lo"] <= m[f"{stat}_true"]) & (m[f"{stat}_true"] <= m[f"{stat}_hi"])
        err = float(np.mean(m[stat] / m[f"{stat}_true"] - 1.0)) if len(m) else np.nan
        parts.append(
            f"the interval of the bin {name} holds the true value in {int(inside.sum())} of "
            f"{len(m)} bins (mean relative error {100 * err:+.1f} %)"
        )
    return (
        "Against the virtual campaign's truth: "
        + "; ".join(parts)
        + ". The bin-statistic intervals carry the posterior uncertainty only; a systematic "
        "model error of a few tenths of a percent, small against the per-record intervals, "
        "is of the order of these narrow intervals."
    )


def _speed_bin_table(b: pd.DataFrame) -> pd.DataFrame:
    return pd.DataFrame(
        {
            "HWS bin (m/s)": b["hws_bin_ms"].map(lambda v: f"{v:g}"),
            "n": b["n"],
            "mean TI [interval]": [
                _fmt_interval(*x) for x in b[["ti_mean", "ti_mean_lo", "ti_mean_hi"]].to_numpy()
            ],
            "representative TI [interval]": [
                _fmt_interval(*x) for x in b[["ti_rep", "ti_rep_lo", "ti_rep_hi"]].to_numpy()
            ],
            "P90 TI [interval]": [
                _fmt_interval(*x) for x in b[["ti_p90", "ti_p90_lo", "ti_p90_hi"]].to_numpy()
            ],
            "uncorrected mean": b["ti_mean_uncorrected"],
            "uncorrected repr.": b["ti_rep_uncorrected"],
        }
    )


def _group_pivot(groups: pd.DataFrame, grouping: str, label: str) -> pd.DataFrame:
    """One row per group, one column per height: 'mean [lo, hi] (n)'."""
    g = groups[groups["grouping"] == grouping]
    out = {}
    for h, sub in g.groupby("height_m", sort=True):
        cells = {}
        for _, r in sub.iterrows():
            txt = _fmt_interval(r["ti_mean"], r["ti_mean_lo"], r["ti_mean_hi"])
            cells[r["group"]] = f"{txt} (n={int(r['n'])})" if txt else f"too few (n={int(r['n'])})"
        out[f"{h:g} m: mean TI [interval] (n)"] = cells
    tab = pd.DataFrame(out)
    tab.index.name = label
    return tab.reset_index()


def build_report(
    *,
    out_path: str | os.PathLike,
    results_dir: str | os.PathLike,
    batch_dirs: Sequence[str | os.PathLike],
    config: dict,
    git_revision: str = "",
    input_files: dict[str, str | os.PathLike] | None = None,
    frontier_png: str | os.PathLike | None = None,
    series_paths: dict | None = None,
) -> str:
    """Write the self-contained HTML report of the user's campaign from the result files.

    Parameters
    ----------
    out_path : path
        The HTML file (normally results/report/report.html: the links to the full CSV
        tables are relative to it, ``../ti/...``).
    results_dir : path
        The pipeline's ``results/`` directory (ti/, bins/, qc/, motion/, inference/,
        posterior/, data/).
    batch_dirs : sequence of path
        The per-bin inference batch directories.
    config : dict
        The run's configuration (provenance, thresholds, reference kind).
    git_revision : str
        Revision of the workflow's repository.
    input_files : dict of str -> path, optional
        Files whose SHA-256 and row count go into the provenance (label -> path): the
        input record table, the validated table, requirements.lock.
    frontier_png : path, optional
        The method-frontier chart (benchmarks), shown when the file exists.
    series_paths : dict, optional
        Result files of the raw IMU series and the LOS branch, when given
        (:func:`flidar_uq.workflow.series_report.series_sections`).

    Returns
    -------
    str
        The HTML text written.
    """
    from flidar_uq import inference as inf
    from flidar_uq.correction.propagation import UNCERTAINTY_SOURCES
    from flidar_uq.physics import variance_laws as correction
    from flidar_uq.workflow import plots
    from flidar_uq.workflow import report as rep

    res = Path(results_dir)
    records = read_csv(res / "ti" / "records.csv")
    bins = read_csv(res / "ti" / "bins.csv")
    speed_bins = read_csv(res / "ti" / "speed_bins.csv")
    groups = read_csv(res / "ti" / "groups.csv")
    budget = read_csv(res / "ti" / "uncertainty_budget.csv")
    metrics = read_csv(res / "ti" / "metrics.csv")
    qc_counts = read_csv(res / "qc" / "summary.csv")
    roll_pitch = read_csv(res / "motion" / "roll_pitch.csv")
    bin_fits = read_csv(res / "inference" / "bin_fits.csv")
    global_summary = read_csv(res / "inference" / "global.csv")
    gfit = inf.load_fit(res / "posterior" / "global.nc")
    mass = float(config["propagation"]["credible_mass"])
    min_count = int(config.get("report", {}).get("group_min_count", 10))
    sections = []

    # ------------------------------------------------------------------ summary
    heights = sorted(records["height_m"].dropna().unique())
    ts = pd.to_datetime(records["timestamp"], utc=True, errors="coerce")
    status_counts = bins["status"].value_counts()
    n_failed = int(status_counts.get("failed", 0) + status_counts.get("error", 0))
    flags = records["flags"].fillna("")
    model_flag = flags.str.split(";").map(lambda fl: all(f in MODEL_FLAGS for f in fl if f))
    n_qc = int(((flags != "") & ~model_flag).sum())
    warnings = []
    if gfit.info.get("motion_scale_warning"):
        warnings.append("Model discrepancy: " + gfit.info["motion_scale_warning"] + ".")
    loo_words = loo_statement(global_summary)
    if "per bin to the single global rho" in loo_words:
        warnings.append(loo_words.split("Global model chosen: ")[-1].split(". ", 1)[-1])
    if not gfit.converged:
        warnings.append(
            "The global fit missed the convergence criteria: every record is flagged "
            "global_fit_failed (" + "; ".join(gfit.failure_reasons) + ")."
        )
    motion_model = "record" if inf.is_record_model(gfit) else "bin"
    if n_failed and motion_model == "bin":
        warnings.append(f"{n_failed} bin fits failed; their records have no corrected TI.")
    elif n_failed:
        warnings.append(
            f"{n_failed} per-bin motion fits (reported for seed 000's bin table) missed the "
            "convergence criteria; the corrected TI does not use them (record motion model)."
        )
    n_neg = int(flags.str.contains("discriminant_negative").sum())
    if n_neg:
        warnings.append(
            f"{n_neg} records have a measured std below the motion-induced std "
            "(discriminant_negative): corrected TI 0 at the posterior median."
        )
    camp = groups[groups["grouping"] == "campaign"].set_index("height_m")
    headline = pd.DataFrame(
        {
            "height (m)": [f"{h:g}" for h in camp.index],
            "records": camp["n"].to_numpy(),
            f"corrected mean TI [{mass:.0%} interval]": [
                _fmt_interval(*x, digits=4)
                for x in camp[["ti_mean", "ti_mean_lo", "ti_mean_hi"]].to_numpy()
            ],
            "uncorrected mean TI": camp["ti_mean_uncorrected"].map(lambda v: f"{v:.4f}"),
        }
    )
    flag_counts = flags.replace("", "(none: corrected)").value_counts()
    campaign_cfg = config.get("campaign", {})
    what = (
        f"virtual campaign, scenario {campaign_cfg.get('scenario')}, seed {campaign_cfg.get('seed')}"
        if campaign_cfg.get("source") == "virtual"
        else f"records file {campaign_cfg.get('records')}"
    )
    facts = pd.DataFrame(
        [
            ("campaign", what),
            ("lidar", campaign_cfg.get("lidar", "")),
            ("heights (m)", ", ".join(f"{h:g}" for h in heights)),
            (
                "period (UTC)",
                f"{ts.min():%Y-%m-%d %H:%M} to {ts.max():%Y-%m-%d %H:%M}"
                if ts.notna().any()
                else "",
            ),
            (
                "records",
                f"{len(records)} input, {int(records['ti_corrected_median'].notna().sum())} "
                f"with a corrected TI, {n_qc} removed by QC",
            ),
            ("reference", reference_kind(config, metrics)),
            (
                "model",
                f"{motion_model} motion model"
                + (
                    f", global model {gfit.info['loo'].get('model')}"
                    if gfit.info.get("loo")
                    else ""
                )
                + f"; global fit {'converged' if gfit.converged else 'NOT converged'}",
            ),
        ],
        columns=["item", "value"],
    )
    summary_html = (
        rep.templates()
        .get_template("sections/summary.html.j2")
        .render(
            facts=Markup(rep.table_html(facts, caption="")),
            headline=Markup(
                rep.table_html(
                    headline,
                    caption=f"headline: corrected TI per height, campaign mean over the records "
                    f"with a corrected TI ({mass:.0%} credible interval of the mean)",
                )
            ),
            warnings=warnings,
            top_flags=[(str(k), int(v)) for k, v in flag_counts.head(4).items()],
            loo=loo_words,
        )
    )

    # ------------------------------------------------------------------ speed bins per height
    truth_bins = _truth_speed_bins(records)
    body = f"<p>{rep.caption('speed_bins', mass=mass, min_count=min_count)}</p>"
    for h in heights:
        b = speed_bins[speed_bins["height_m"] == h].sort_values("hws_bin_ms")
        rec_h = records[(records["height_m"] == h) & records["ti_corrected_median"].notna()]
        fig = plots.ti_speed_bins_figure(
            b,
            rec_h,
            credible_mass=mass,
            title=f"{h:g} m",
            truth=truth_bins[truth_bins["height_m"] == h] if len(truth_bins) else None,
        )
        body += f"<h3>{h:g} m</h3>" + rep.img_html(
            rep.figure_to_data_uri(fig), rep.caption("ti_speed_bins", mass=mass, height=f"{h:g}")
        )
        body += rep.table_html(
            _speed_bin_table(b[b["n"] > 0]),
            caption=f"{h:g} m: TI per 1-m/s bin ({mass:.0%} intervals of the bin statistic)",
        )
    body += _link_note(len(speed_bins), len(speed_bins), "ti/speed_bins.csv")
    if len(truth_bins):
        body += f"<p>{_truth_check(speed_bins, truth_bins)}</p>"
    sections.append(rep.Section("Turbulence intensity per height and speed bin", body))

    # ------------------------------------------------------------------ sectors and sea states
    body = f"<p>{rep.caption('groups', mass=mass, min_count=min_count)}</p>"
    sec = _group_pivot(groups, "direction sector", "sector centre (deg)")
    body += rep.table_html(sec, caption="corrected mean TI per wind-direction sector")
    body += rep.table_html(
        _group_pivot(groups, "sea state", "sea-state class"),
        caption="corrected mean TI per sea-state class (from the record's motion)",
    )
    body += _link_note(len(groups), len(groups), "ti/groups.csv")
    sections.append(rep.Section("Direction sectors and sea states", body))

    # ------------------------------------------------------------------ budget
    sources = [k for k in UNCERTAINTY_SOURCES if f"share_{k}" in budget]
    cb = budget[budget["grouping"] == "campaign"]
    btab = pd.DataFrame({"height (m)": cb["height_m"].map(lambda v: f"{v:g}")})
    btab[f"{mass:.0%} width of the mean"] = cb["width"].map(lambda v: f"{v:.2g}")
    for k in sources:
        btab[SOURCE_LABELS[k] + " (%)"] = (100 * cb[f"share_{k}"]).map(lambda v: f"{v:.0f}")
    btab["remainder (%)"] = (100 * cb["remainder"]).map(lambda v: f"{v:.0f}")
    body = f"<p>{rep.caption('budget')}</p>" + rep.table_html(
        btab, caption="campaign-mean corrected TI per height: share of the posterior variance"
    )
    sb = budget[budget["grouping"] == "speed bin"]
    if len(sb):
        body += rep.img_html(
            rep.figure_to_data_uri(plots.budget_figure(sb, sources)),
            "share of the variance of each speed bin's mean corrected TI per source",
        )
    body += _link_note(len(budget), len(budget), "ti/uncertainty_budget.csv")
    sections.append(rep.Section("Uncertainty budget", body))

    # ------------------------------------------------------------------ flags and QC
    sections.append(
        rep.Section(
            "What was flagged and why",
            rep.table_html(
                flag_counts.rename_axis("flags").rename("records").reset_index(),
                caption="records of results/ti/records.csv per flag string (QC reasons, "
                "no_motion_description, discriminant_negative, bin_* with the bin model)",
            )
            + _link_note(0, len(records), "ti/records.csv").replace("0 of", "per record, 0 of"),
        )
    )
    sections.append(
        rep.Section(
            "Quality control",
            rep.table_html(qc_counts, caption=rep.caption("qc_filters"))
            + rep.table_html(roll_pitch, caption=rep.caption("roll_pitch")),
        )
    )

    # ------------------------------------------------------------------ validation
    body = rep.table_html(metrics, caption=rep.caption("metrics"))
    rho_med = float(np.median(gfit.flat("rho")))
    rho_seed = float(metrics["rho_seed000"].iloc[0]) if len(metrics) else float("nan")
    ref_col = next((c for c in ("ref_hws_std_ms", "true_hws_std_ms") if c in records), None)
    if ref_col is not None:
        r = records[records["ti_corrected_median"].notna()]
        ref = r[ref_col].to_numpy(dtype=float)
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
        body += rep.img_html(
            rep.figure_to_data_uri(
                plots.sigma_scatter_figure(r["hws_std_ms"].to_numpy(), ref, corr, ref_label=label)
            ),
            rep.caption("sigma_scatter", label=label, rho_pc=rho_pc, rho_src=rho_src),
        )
    refs = {}
    if "ti_true" in records:
        refs["truth"] = records["ti_true"].to_numpy(dtype=float)
    if "ti_ref" in records:
        from flidar_uq.data.metrics import LIDAR_REFERENCE_LABELS, REFERENCE_LABELS

        label = next(
            (r for r in metrics.get("reference", []) if r != "truth"), REFERENCE_LABELS[None]
        )
        if label in (*LIDAR_REFERENCE_LABELS, REFERENCE_LABELS[None]):
            refs[f"{label} (interval x lidar_std_ratio)"] = (
                records["ti_ref"].to_numpy(dtype=float),
                records["lidar_std_ratio"].to_numpy(dtype=float),
            )
        else:  # a cup or sonic: the point value itself
            refs[label] = records["ti_ref"].to_numpy(dtype=float)
    if refs:
        body += rep.img_html(
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
        )
    if "ti_true" in records:
        body += rep.table_html(
            regime_calibration_table(records),
            caption=f"{mass:.0%} intervals of the corrected TI against the virtual "
            "campaign's truth, QC-kept records in 3-20 m/s, per 3-m/s speed group, "
            "sea state and heading (truth columns); answered_share: records with a "
            "corrected TI; coverage with its 95 % Wilson interval; the record interval is "
            "given the reference's std ratio g, *_total adds g's campaign-wide error "
            "(reference lidar only)",
        )
    sections.append(
        rep.Section("Validation against the reference (seed 000 Tables 2-3 style)", body)
    )

    # ------------------------------------------------------------------ bin table
    cols = [
        c
        for c in (
            "bin_id", "hws_ms", "amplitude_deg", "period_s", "count", "sigma_z_ms", "mean_z_ms",
            "status", "model", "ti_uncorrected_mean", "ti_corrected_median_mean",
            "ti_true_mean",
        )
        if c in bins
    ]  # fmt: skip
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
            _summarised(
                rep,
                table1,
                rep.caption("bin_table", mass=mass, n_hidden=int((~shown).sum())),
                "ti/bins.csv",
            ),
        )
    )

    # ------------------------------------------------------------------ posteriors
    names = list(gfit.draws)
    post = (f"<p>{loo_words}</p>" if loo_words else "") + rep.img_html(
        rep.figure_to_data_uri(
            plots.posterior_figure(
                {k: np.asarray(v) for k, v in gfit.draws.items()},
                title="global posterior, one line per ensemble",
            )
        ),
        rep.caption("global_posterior", names=", ".join(names)),
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
    worst = bin_fits.sort_values("status", key=lambda s: s.eq("ok"))
    post += _summarised(rep, worst, rep.caption("bin_fits"), "inference/bin_fits.csv")
    sections.append(rep.Section("Posteriors and convergence", post))

    if frontier_png is not None and Path(frontier_png).is_file():
        sections.append(
            rep.Section(
                "Method frontier",
                rep.img_html(
                    rep.png_bytes_to_data_uri(Path(frontier_png).read_bytes()),
                    "wall time against accuracy of the correction methods on a campaign "
                    "with truth (benchmarks/results/method_frontier.png)",
                ),
            )
        )

    from flidar_uq.workflow.series_report import series_sections

    sections += series_sections(**(series_paths or {}))  # raw IMU series, LOS branch
    sections.append(
        rep.Section(
            "How to cite", rep.templates().get_template("sections/references.html.j2").render()
        )
    )
    prov = file_provenance(input_files or {})
    sections.append(
        rep.Section(
            "Provenance and how to rerun",
            rep.templates()
            .get_template("sections/rerun.html.j2")
            .render(files=Markup(rep.table_html(prov, caption="input files")))
            + rep.provenance_html(
                config, git_revision, rep.package_versions(), numeric_environment()
            ),
        )
    )
    text = rep.render_html(
        "flidar_uq report: motion-corrected turbulence intensity",
        sections,
        intro_html=summary_html,
    )
    Path(out_path).parent.mkdir(parents=True, exist_ok=True)
    Path(out_path).write_text(text, encoding="utf-8")
    return text


def build_developer_report(
    *,
    out_path: str | os.PathLike,
    benchmarks_dir: str | os.PathLike,
    git_revision: str = "",
) -> str:
    """Write the developer report: the project's benchmark charts and LOS comparison tables.

    Kept apart from the user's campaign report (results/report/report.html).

    Parameters
    ----------
    out_path : path
        The HTML file (normally results/report/developer.html).
    benchmarks_dir : path
        Directory of benchmark PNG charts and ``los*comparison.csv`` tables.
    git_revision : str
        Revision of the repository.

    Returns
    -------
    str
        The HTML text written.

    Raises
    ------
    ValueError
        If ``benchmarks_dir`` is not a directory.
    """
    from flidar_uq.workflow import report as rep

    bdir = Path(benchmarks_dir)
    if not bdir.is_dir():
        raise ValueError(f"build_developer_report: {bdir} is not a directory")
    sections = []
    los = sorted(bdir.glob("los*comparison.csv"))
    if los:
        sections.append(
            rep.Section(
                "LOS-level correction compared with the statistical correction",
                "".join(rep.table_html(read_csv(p), caption=p.name) for p in los),
            )
        )
    pngs = sorted(bdir.glob("*.png"))
    sections.append(
        rep.Section(
            f"Speed-accuracy charts ({bdir.name})",
            "".join(rep.img_html(rep.png_bytes_to_data_uri(p.read_bytes()), p.name) for p in pngs)
            or "<p>no chart found</p>",
        )
    )
    sections.append(
        rep.Section(
            "Provenance",
            rep.provenance_html({}, git_revision, rep.package_versions(), numeric_environment()),
        )
    )
    text = rep.render_html("flidar_uq developer report: benchmarks", sections)
    Path(out_path).parent.mkdir(parents=True, exist_ok=True)
    Path(out_path).write_text(text, encoding="utf-8")
    return text
