"""Workflow step of the report: the self-contained HTML report from the result files."""

from __future__ import annotations

import os
from collections.abc import Sequence
from pathlib import Path

import numpy as np
import pandas as pd
from markupsafe import Markup, escape

from flidar_uq.data.io import read_table
from flidar_uq.threads import numeric_environment
from flidar_uq.workflow import report as rep
from flidar_uq.workflow.files import bin_file, read_csv

__all__ = [
    "build_developer_report",
    "build_report",
    "file_provenance",
    "git_revision",
    "loo_statement",
    "public_config",
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
    :func:`flidar_uq.validation.regimes.scenario_calibration` does (speed group; sea state,
    heading and wave period where the truth columns ``true_swell_present`` /
    ``true_weathervane`` / ``true_period_s`` exist). With a reference lidar's campaign-wide error of ``g`` in the total interval
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
    if "true_period_s" not in records:
        tab = tab[tab["grouping"] != "wave_period"]
    cols = ["grouping", "group", "n", "answered_share", "coverage", "coverage_lo"]
    cols += ["coverage_hi", "mean_rel_error", "mean_rel_error_se", "median_rel_width"]
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
    "regime_discrepancy": "regime discrepancy",
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
        "cup": "cup anemometer: the point wind, through the floating lidar's std ratio g, "
        "which the cup calibrates",
        "sonic": "sonic anemometer: the point wind, through the floating lidar's std ratio g, "
        "which the sonic calibrates",
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
        n_rows = None
        if p.suffix == ".csv":
            n_rows = data.count(b"\n") - 1
        elif p.suffix == ".parquet":  # the pipeline's record tables
            import pyarrow.parquet as pq

            n_rows = pq.ParquetFile(p).metadata.num_rows
        rows.append(
            {
                "file": label,
                "sha256": hashlib.sha256(data).hexdigest(),
                "bytes": len(data),
                "data rows": n_rows,
            }
        )
    return pd.DataFrame(rows, columns=["file", "sha256", "bytes", "data rows"])


def fitted_records_words(n_fitted: int, n_usable: int) -> str:
    """How many records the global fit used (records), and whether they were a subsample
    (:func:`flidar_uq.inference.record_fit.fit_subsample`)."""
    if n_usable > n_fitted:
        return (
            f"{n_fitted} records fitted, a subsample of the {n_usable} usable stratified by "
            "height and wind speed (inference.record_fit_max_records)"
        )
    return f"{n_fitted} records fitted"


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
            "records": b["n"],
            "mean TI [interval]": [
                _fmt_interval(*x) for x in b[["ti_mean", "ti_mean_lo", "ti_mean_hi"]].to_numpy()
            ],
            "representative TI (ed. 3, mean + 1.28 sd) [interval]": [
                _fmt_interval(*x) for x in b[["ti_rep", "ti_rep_lo", "ti_rep_hi"]].to_numpy()
            ],
            "P90 TI (ed. 4 repr.) [interval]": [
                _fmt_interval(*x) for x in b[["ti_p90", "ti_p90_lo", "ti_p90_hi"]].to_numpy()
            ],
            "uncorrected mean": b["ti_mean_uncorrected"].map(_f3),
            "uncorrected repr.": b["ti_rep_uncorrected"].map(_f3),
        }
    ).assign(
        **(
            {"the interval comes from": b["interval_from"].fillna("").to_numpy()}
            if "interval_from" in b
            else {}
        )
    )


def _f3(v) -> str:
    return f"{v:.3f}" if np.isfinite(v) else "–"


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


def _plain_warnings(gfit, bins, records, global_summary, motion_model, coverage) -> list[str]:
    """The fit's and the data's warnings in plain words: what they mean, what to do."""
    from flidar_uq.workflow.report_summary import lever_arm_words, motion_scale_words

    out = []
    if gfit.info.get("motion_scale_warning"):
        k = float(np.median(gfit.flat("motion_scale"))) if "motion_scale" in gfit.draws else np.nan
        out.append(motion_scale_words(k, coverage))
    if gfit.info.get("lever_arm_warning") and "lever_arm_m" in gfit.draws:
        prior = gfit.info.get("lever_arm_prior")
        configured = float(prior[0]) if prior else None
        out.append(lever_arm_words(gfit.flat("lever_arm_m"), configured, coverage))
    loo_words = loo_statement(global_summary)
    if "per bin to the single global rho" in loo_words:
        out.append(
            "The correlation between the motion error and the turbulence (rho) differs "
            "between wind-speed bins: the single global rho is a compromise, so the "
            "intervals of bins far from the average may be too narrow or too wide. Check the "
            "per-bin validation below before relying on a single bin."
        )
    if gfit.info.get("prior_only"):
        out.append(
            "Without a reference std (ref_hws_std_ms) the correlation rho between the motion "
            "error and the turbulence stays at its prior: the corrected TI and its per-bin "
            "statistics carry that prior's wide intervals. A reference narrows them."
        )
    if not gfit.converged:
        out.append(
            "The fit's chains did not meet the convergence criteria ("
            + "; ".join(gfit.failure_reasons)
            + "): its records have no trustworthy corrected TI (flag global_fit_failed). "
            "Rerun with more sampler steps (inference.nsteps, nburn)."
        )
    st = bins["status"].value_counts()
    n_failed = int(st.get("failed", 0) + st.get("error", 0))
    if n_failed and motion_model == "bin":
        out.append(
            f"{n_failed} wind-speed/motion bins could not be fitted: their records have no "
            "corrected TI (flagged bin_failed or bin_error). More records per bin "
            "(binning.min_count) or the record motion model (inference.motion_model) helps."
        )
    n_neg = int(records["flags"].fillna("").str.contains("discriminant_negative").sum())
    if n_neg:
        out.append(
            f"{n_neg} records measured less variance than their motion alone would add "
            "(discriminant_negative): their corrected TI is 0 at the median and their "
            "interval is one-sided. Usually calm wind and large motion; few of them do not "
            "move the bin statistics."
        )
    return out


def _first_screen(ctx: dict) -> str:
    """The first screen (report_summary.first_screen_html) from the loaded results."""
    from flidar_uq.workflow.report_summary import (
        FirstScreen,
        bin_tables,
        campaign_name,
        file_identity,
        first_screen_html,
        hull_model_short,
        missing_motion_words,
        motion_description_summary,
        reference_speed_bins,
        representative_at_15,
        uncorrected_at_15,
    )

    records, config, mass = ctx["records"], ctx["config"], ctx["mass"]
    min_count, corrected = ctx["min_count"], ctx["corrected"]
    ts = pd.to_datetime(records["timestamp"], utc=True, errors="coerce")
    name, sha = file_identity(ctx["input_file"]) if ctx["input_file"] else ("", "")
    n_corr = int(records["ti_corrected_median"].notna().sum())
    speed_bins = ctx["speed_bins"]
    facts = [
        ("campaign", campaign_name(config)),
        ("input", f"{name} (SHA-256 {sha[:12]}…)" if sha else name or "–"),
        (
            "period (UTC)",
            f"{ts.min():%Y-%m-%d %H:%M} to {ts.max():%Y-%m-%d %H:%M}" if ts.notna().any() else "",
        ),
        ("heights", ", ".join(f"{h:g} m" for h in ctx["heights"])),
        (
            "records",
            f"{len(records)} input, {n_corr} with a corrected TI"
            if corrected
            else f"{len(records)} input, {int(records['flags'].isin(MODEL_FLAGS).sum())} kept "
            "by QC, none corrected for motion",
        ),
        ("reference", ctx["reference_kind"]),
        ("lidar", str((config.get("campaign") or {}).get("lidar", ""))),
    ]
    described = motion_description_summary(records)
    if described:
        facts.append(("motion description", described))
    hull = hull_model_short(ctx["gfit"].info if ctx.get("gfit") is not None else {})
    if hull:
        facts.append(("hull model", hull))
    screen = FirstScreen(
        title=campaign_name(config),
        facts=facts,
        rep15=(representative_at_15 if corrected else uncorrected_at_15)(speed_bins, min_count),
        bin_tables=bin_tables(
            speed_bins, reference_speed_bins(records, min_count), min_count, corrected
        ),
        validation=ctx["validation"],
        warnings=ctx["warnings"],
        mass=mass,
        missing_motion=(
            "" if corrected else missing_motion_words(ctx["motion_missing"], "ti_ref" in records)
        ),
    )
    return first_screen_html(screen)


def _ti_section(ctx: dict) -> rep.Section:
    """TI per height and 1-m/s bin: the figure (corrected, uncorrected, reference, IEC
    curves) and the full per-bin table of each height."""
    from flidar_uq.workflow import plots
    from flidar_uq.workflow.report_summary import reference_speed_bins

    records, speed_bins, mass = ctx["records"], ctx["speed_bins"], ctx["mass"]
    corrected, min_count = ctx["corrected"], ctx["min_count"]
    truth_bins = _truth_speed_bins(records)
    ref_bins = reference_speed_bins(records, min_count)
    body = (
        f"<p>{rep.caption('speed_bins', mass=mass, min_count=min_count)}</p>"
        if corrected
        else "<p>Per height and 1-m/s speed bin (centred on integers, IEC 61400-12-1): the "
        "mean, representative TI (mean + 1.28 std, IEC 61400-1) and 90th percentile (P90) "
        "of the floating lidar's TI as measured, over the records kept by QC, not corrected "
        f"for the buoy's motion. Bins with fewer than {min_count} records show their count "
        "only.</p>"
    )
    ti_col = "ti_corrected_median" if corrected else "ti_uncorrected"
    for h in ctx["heights"]:
        b = speed_bins[speed_bins["height_m"] == h].sort_values("hws_bin_ms")
        rec_h = records[(records["height_m"] == h) & records[ti_col].notna()]
        if not corrected:
            rec_h = rec_h[rec_h["flags"].isin(MODEL_FLAGS)]  # kept by QC
        fig = plots.ti_speed_bins_figure(
            b,
            rec_h,
            credible_mass=mass,
            title=f"{h:g} m",
            truth=truth_bins[truth_bins["height_m"] == h] if len(truth_bins) else None,
            reference=ref_bins[ref_bins["height_m"] == h].dropna() if len(ref_bins) else None,
            corrected=corrected,
        )
        body += f"<h3>{h:g} m</h3>" + rep.img_html(
            rep.figure_to_data_uri(fig),
            rep.caption("ti_speed_bins", mass=mass, height=f"{h:g}")
            if corrected
            else f"{h:g} m: uncorrected TI per 1-m/s speed bin, bin mean (dashed) and "
            "representative TI (dotted), the records' TI (grey) and the IEC 61400-1 ed. 4 "
            "turbulence categories (green)",
        )
        table = _speed_bin_table(b[b["n"] > 0])
        if not corrected:
            table = table.drop(columns=[c for c in table if "[interval]" in c])
            table["uncorrected P90"] = b.loc[b["n"] > 0, "ti_p90_uncorrected"].map(_f3)
        body += rep.table_html(
            table,
            caption=f"{h:g} m: TI per 1-m/s bin ({mass:.0%} intervals of the bin statistic)"
            if corrected
            else f"{h:g} m: uncorrected TI per 1-m/s bin",
        )
    if len(truth_bins):
        body += f"<p>{_truth_check(speed_bins, truth_bins)}</p>"
    return rep.Section("Turbulence intensity per height and wind-speed bin", body)


#: Readable names of the per-bin validation columns.
_PER_BIN_LABELS = {
    "hws_bin_ms": "HWS bin (m/s)",
    "n": "records",
    "bias": "bias",
    "bias_rel": "bias (%)",
    "rmse": "RMSE",
    "ti_rep_estimate": "repr. TI",
    "ti_rep_reference": "reference repr. TI",
    "ti_rep_error": "repr. TI error",
    "ti_rep_error_rel": "repr. TI error (%)",
}


def _per_bin_table(per_bin: pd.DataFrame) -> pd.DataFrame:
    """Corrected and uncorrected side by side per bin, readable names, fixed precision."""
    c = per_bin[per_bin["estimate"] == "corrected"].set_index("hws_bin_ms")
    u = per_bin[per_bin["estimate"] == "uncorrected"].set_index("hws_bin_ms")
    out = pd.DataFrame({"HWS bin (m/s)": [f"{v:g}" for v in c.index], "records": c["n"].to_numpy()})
    for tab, who in ((c, "corrected"), (u, "uncorrected")):
        for col in ("bias", "rmse", "ti_rep_error"):
            out[f"{who} {_PER_BIN_LABELS[col]}"] = [
                f"{x:+.4f}"
                if col != "rmse" and np.isfinite(x)
                else (f"{x:.4f}" if np.isfinite(x) else "–")
                for x in tab[col].reindex(c.index)
            ]
        out[f"{who} {_PER_BIN_LABELS['ti_rep_error_rel']}"] = [
            f"{100 * x:+.1f}" if np.isfinite(x) else "–"
            for x in tab["ti_rep_error_rel"].reindex(c.index)
        ]
    out["reference repr. TI"] = [_f3(x) for x in c["ti_rep_reference"]]
    return out


def _validation_section(ctx: dict) -> rep.Section:
    """Validation against the reference: statement, per-height statistics in and out of
    sample, scatter with regression lines, bias per bin, coverage per bin."""
    from flidar_uq.workflow import plots
    from flidar_uq.workflow.report_summary import VALIDATION_LABELS

    v, records, mass = ctx["validation"], ctx["records"], ctx["mass"]
    if v is None:
        return rep.Section(
            "Validation against the reference",
            "<p>The input has no reference TI (ref_* columns): no validation.</p>",
        )
    body = f"<p>{v.statement}</p>"
    bh = v.tables["by_height"]
    tab = pd.DataFrame({"height (m)": bh["height_m"].map(lambda x: f"{x:g}")})
    for c in ("sample", "estimate", "n"):
        tab[VALIDATION_LABELS[c]] = bh[c].to_numpy()
    for c, f in (("bias", "{:+.4f}"), ("rmse", "{:.4f}"), ("slope", "{:.3f}"),
                 ("offset", "{:+.4f}"), ("r2", "{:.3f}")):  # fmt: skip
        tab[VALIDATION_LABELS[c]] = [f.format(x) if np.isfinite(x) else "–" for x in bh[c]]
    tab["bias (%)"] = [f"{100 * x:+.1f}" if np.isfinite(x) else "–" for x in bh["bias_rel"]]
    tab["coverage"] = [f"{100 * x:.1f} %" if np.isfinite(x) else "–" for x in bh["coverage"]]
    body += rep.table_html(tab, caption=rep.caption("validation_by_height", mass=mass))
    g = records["lidar_std_ratio"].to_numpy(dtype=float) if v.lidar_reference else 1.0
    ref = records["ti_ref"].to_numpy(dtype=float)
    use = np.isfinite(ref) & np.isfinite(records["ti_corrected_median"].to_numpy(dtype=float))
    if v.sample == "held out":
        use &= ctx["held_out"]
    for h in ctx["heights"]:
        at = use & (records["height_m"].to_numpy(dtype=float) == h)
        if not at.any():
            continue
        corr = records["ti_corrected_median"].to_numpy(dtype=float) * g
        fig = plots.ti_scatter_figure(
            np.where(at, ref, np.nan), np.where(at, corr, np.nan),
            np.where(at, records["ti_uncorrected"].to_numpy(dtype=float), np.nan),
            title=f"{h:g} m, {v.sample} records",
        )  # fmt: skip
        body += f"<h3>{h:g} m</h3>" + rep.img_html(
            rep.figure_to_data_uri(fig), rep.caption("ti_scatter", sample=v.sample, height=f"{h:g}")
        )
        pb = v.tables["per_bin"]
        pb = pb[pb["height_m"] == h]
        bars = plots.bias_bars_figure(
            pb[pb["estimate"] == "corrected"], pb[pb["estimate"] == "uncorrected"],
            title=f"{h:g} m, {v.sample} records",
        )  # fmt: skip
        body += rep.img_html(
            rep.figure_to_data_uri(bars), rep.caption("bias_bars", sample=v.sample)
        )
        body += rep.table_html(
            _per_bin_table(pb),
            caption=f"{h:g} m, {v.sample} records: bias, RMSE and representative-TI error per "
            f"1-m/s bin (bins with fewer than {ctx['min_count']} pairs: count only)",
        )
    hws = records["hws_mean_ms"].to_numpy(dtype=float)
    body += rep.img_html(
        rep.figure_to_data_uri(
            plots.calibration_figure(
                np.where(use, hws, np.nan),
                records["ti_corrected_median"].to_numpy(dtype=float),
                records["ti_corrected_lo"].to_numpy(dtype=float),
                records["ti_corrected_hi"].to_numpy(dtype=float),
                {f"reference ({v.sample})": (ref, g) if v.lidar_reference else ref},
                credible_mass=mass,
                speed_bin_width_ms=1.0,
            )
        ),
        rep.caption("calibration", mass=mass),
    )
    return rep.Section("Validation against the reference", body)


def _direction_section(ctx: dict) -> rep.Section:
    """TI rose, and the corrected mean TI per direction sector and sea-state class."""
    from flidar_uq.workflow import plots

    groups, mass = ctx["groups"], ctx["mass"]
    body = f"<p>{rep.caption('groups', mass=mass, min_count=ctx['min_count'])}</p>"
    sectors = groups[groups["grouping"] == "direction sector"]
    if len(sectors):
        body += rep.img_html(
            rep.figure_to_data_uri(plots.ti_rose_figure(sectors)),
            "TI rose: mean corrected TI per wind-direction sector and height (sectors with "
            f"fewer than {ctx['min_count']} records left out)",
        )
    body += rep.table_html(
        _group_pivot(groups, "direction sector", "sector centre (deg)"),
        caption="corrected mean TI per wind-direction sector",
    )
    body += rep.table_html(
        _group_pivot(groups, "sea state", "sea-state class"),
        caption="corrected mean TI per sea-state class (from the record's motion)",
    )
    return rep.Section("Direction sectors and sea states", body)


def _motion_section(ctx: dict) -> rep.Section:
    """The buoy's motion: tilt and period distributions; the correction's error by sea state."""
    from flidar_uq.correction.campaign import record_groups
    from flidar_uq.workflow import plots

    data, records, v = ctx["data"], ctx["records"], ctx["validation"]
    amp = [c for c in ("roll_amplitude_deg", "pitch_amplitude_deg") if c in data]
    tilt = data[amp].max(axis=1).to_numpy(dtype=float) if amp else np.full(len(data), np.nan)
    per = next((c for c in ("period1_s", "roll_period_s", "pitch_period_s") if c in data), None)
    period = data[per].to_numpy(dtype=float) if per else np.full(len(data), np.nan)
    err = None
    if v is not None:
        g = records["lidar_std_ratio"].to_numpy(dtype=float) if v.lidar_reference else 1.0
        ref = records["ti_ref"].to_numpy(dtype=float)
        corr = records["ti_corrected_median"].to_numpy(dtype=float) * g
        use = np.isfinite(ref) & np.isfinite(corr)
        if v.sample == "held out":
            use &= ctx["held_out"]
        state = record_groups(data)["sea_state"].to_numpy()
        d = pd.DataFrame({"sea_state": state, "corrected": corr - ref,
                          "uncorrected": records["ti_uncorrected"].to_numpy(float) - ref})[use]  # fmt: skip
        counts = d.groupby("sea_state").size()
        err = d.groupby("sea_state")[["corrected", "uncorrected"]].mean()
        err = err[counts >= ctx["min_count"]].reset_index()
    waves = [c for c in data.columns if c.startswith(("wave_", "hs_", "tp_"))]
    body = rep.img_html(
        rep.figure_to_data_uri(plots.motion_context_figure(tilt, period, err)),
        rep.caption("motion_context", sample=v.sample if v else "", min_count=ctx["min_count"]),
    )
    if not waves:
        body += "<p>The input has no wave height or wave period columns: the sea state is " \
            "described by the buoy's own motion (one or two spectral peaks of roll and pitch, " \
            "tilt along or across the wind).</p>"  # fmt: skip
    return rep.Section("Motion of the buoy", body)


def _diagnostics_section(ctx: dict) -> rep.Section:
    """Appendix: the global posterior, its convergence, and (bin model) the per-bin fits."""
    from flidar_uq import inference as inf
    from flidar_uq.workflow import plots

    gfit, gs, bin_fits, config = ctx["gfit"], ctx["global_summary"], ctx["bin_fits"], ctx["config"]
    loo_words = loo_statement(gs)
    body = (f"<p>{loo_words}</p>" if loo_words else "") + rep.img_html(
        rep.figure_to_data_uri(
            plots.posterior_figure(
                {k: np.asarray(v) for k, v in gfit.draws.items()},
                title="global posterior, one line per ensemble",
            )
        ),
        rep.caption("global_posterior", names=", ".join(gfit.draws)),
    )
    cols = [c for c in ("param", "mean", "sd", "q05", "median", "q95", "rhat", "ess_bulk",
                        "ess_tail", "nsteps_over_tau") if c in gs]  # fmt: skip
    names = {"param": "parameter", "q05": "5 %", "q95": "95 %", "rhat": "rank R-hat",
             "ess_bulk": "bulk ESS", "ess_tail": "tail ESS",
             "nsteps_over_tau": "steps / autocorr. time"}  # fmt: skip
    status = "converged" if gfit.converged else "NOT converged: " + "; ".join(gfit.failure_reasons)
    n_fit = int(gs["n_records"].iloc[0]) if "n_records" in gs and len(gs) else 0
    fitted = fitted_records_words(n_fit, int(gfit.info.get("n_records_usable", n_fit)))
    body += rep.table_html(
        gs[cols].rename(columns=names),
        caption=f"{rep.caption('global_summary')}: {fitted}, {status}",
    )
    if ctx["motion_model"] == "bin":
        ok = bin_fits.loc[bin_fits["status"] == "ok", "bin_id"].astype(int).head(1).tolist()
        for bid in ok:
            bfit = inf.load_fit(bin_file(ctx["batch_dirs"], bid))
            body += rep.img_html(
                rep.figure_to_data_uri(
                    plots.posterior_figure(
                        {k: np.asarray(v) for k, v in bfit.draws.items()},
                        title=f"case no. {bid}: motion posterior",
                    )
                ),
                rep.caption("bin_posterior", bin_id=bid),
            )
        body += rep.img_html(
            rep.figure_to_data_uri(
                plots.convergence_figure(
                    bin_fits,
                    rhat_max=config["inference"]["rhat_max"],
                    ess_min=config["inference"]["ess_min"],
                )
            ),
            rep.caption("convergence"),
        )
    return rep.Section("Appendix A. Bayesian diagnostics", body)


def _bin_table_section(ctx: dict) -> rep.Section:
    """Appendix: the per-bin motion fits that feed the answer (bin model), or one line
    saying they were not run (record model)."""
    title = "Appendix B. Per-bin motion fits"
    if ctx["motion_model"] != "bin":
        return rep.Section(
            title,
            "<p>The bin motion model was not run (inference.motion_model: record): each "
            "record's sigma_Z comes from its own motion, and no per-bin fit is made.</p>",
        )
    bins, bin_fits, mass = ctx["bins"], ctx["bin_fits"], ctx["mass"]
    cols = [c for c in ("bin_id", "hws_ms", "amplitude_deg", "period_s", "count", "sigma_z_ms",
                        "mean_z_ms", "status", "model", "ti_uncorrected_mean",
                        "ti_corrected_median_mean", "ti_true_mean") if c in bins]  # fmt: skip
    shown = bins["status"] != "not_fitted"
    table1 = bins.loc[shown, cols].head(15).rename(
        columns={"bin_id": "case no.", "hws_ms": "HWS (m/s)", "amplitude_deg": "AA (deg)",
                 "period_s": "T (s)", "count": "records", "sigma_z_ms": "sigma_Z (m/s)",
                 "mean_z_ms": "mean_Z (m/s)", "ti_uncorrected_mean": "uncorrected TI",
                 "ti_corrected_median_mean": "corrected TI", "ti_true_mean": "true TI"}
    )  # fmt: skip
    intro = "With the bin motion model each record's sigma_Z comes from its bin's fit."
    st = bin_fits["status"].value_counts()
    intro += (
        f" Fits: {int(st.get('ok', 0))} ok, {int(st.get('failed', 0))} missed the convergence "
        f"criteria, {int(st.get('error', 0))} raised. The 15 bins with the most records are shown."
    )
    return rep.Section(
        title + " (they feed the corrected TI: bin model)",
        f"<p>{intro}</p>"
        + rep.table_html(
            table1, caption=rep.caption("bin_table", mass=mass, n_hidden=int((~shown).sum()))
        ),
    )


def _model_selection_section(ctx: dict) -> rep.Section | None:
    """Appendix: which motion description the data favour, in words (None without a
    comparison: a configured hull model, or the bin motion model)."""
    from flidar_uq.workflow.report_summary import hull_model_words, model_selection_words

    words = model_selection_words(ctx["gfit"].info)
    if not words:
        return None
    body = "<ul>" + "".join(f"<li>{escape(w)}</li>" for w in words) + "</ul>"
    body += f"<p>In full: {escape(hull_model_words(ctx['gfit'].info))}.</p>"
    return rep.Section("Appendix E. Which description of the buoy's motion the data favour", body)


def _budget_section(ctx: dict) -> rep.Section:
    """Appendix: the uncertainty budget."""
    from flidar_uq.correction.uncertainty_budget import BUDGET_SOURCES
    from flidar_uq.workflow import plots

    budget, mass = ctx["budget"], ctx["mass"]
    sources = [k for k in BUDGET_SOURCES if f"share_{k}" in budget]
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
            "share of the variance of each 1-m/s speed bin's mean corrected TI per source",
        )
    return rep.Section("Appendix C. Uncertainty budget", body)


def _qc_section(ctx: dict) -> rep.Section:
    """Appendix: what was flagged and why, the QC filters, the roll-pitch correlation."""
    flags = ctx["records"]["flags"].fillna("").replace("", "(none: corrected)")
    counts = flags.value_counts().rename_axis("flags").rename("records").reset_index()
    qc = ctx["qc_counts"].rename(
        columns={"reason": "filter", "enabled": "on", "threshold": "threshold",
                 "n_failed": "records failing", "n_failed_only": "failing only this"}
    )  # fmt: skip
    body = rep.table_html(counts, caption=rep.caption("flags")) + rep.table_html(
        qc, caption=rep.caption("qc_filters")
    )
    if not ctx["corrected"]:  # no motion statistics: no roll-pitch correlation either
        return rep.Section("Appendix. Quality control and flags", body)
    rp = ctx["roll_pitch"].rename(
        columns={"r_amplitude": "r (amplitude)", "r_period": "r (period)", "n": "records"}
    )
    body += rep.table_html(rp, caption=rep.caption("roll_pitch"))
    return rep.Section("Appendix D. Quality control and flags", body)


#: Readable names of the method-comparison table (results/ti/metrics.csv).
_METRIC_LABELS = {
    "reference": "against", "method": "method", "n": "records",
    "md_std_ms": "MD std (m/s)", "rmse_std_ms": "RMSE std (m/s)", "md_ti": "MD TI",
    "rmse_ti": "RMSE TI", "mean_rel_ti_error": "mean rel. TI error",
    "mean_abs_rel_ti_error": "mean abs. rel. TI error", "coverage": "coverage",
}  # fmt: skip


def _methods_section(results_dir: Path) -> rep.Section | None:
    """The developer report's comparison of a campaign's corrections: the
    Gutiérrez-Antuñano et al. (2018) U / C / PC laws beside the Bayesian correction (their
    Tables 2-3 and Fig. 5), and (virtual campaigns) the truth check; None when
    ``results_dir`` holds no corrected campaign (results/ti/metrics.csv and
    results/posterior/global.nc)."""
    from flidar_uq import inference as inf
    from flidar_uq.physics import variance_laws as correction
    from flidar_uq.workflow import plots

    paths = [results_dir / "ti" / f for f in ("records.csv", "metrics.csv")]
    paths.append(results_dir / "posterior" / "global.nc")
    if not all(p.is_file() for p in paths):
        return None
    records, metrics = read_csv(paths[0]), read_csv(paths[1])
    gfit = inf.load_fit(paths[2])
    mass = float(metrics["credible_mass"].iloc[0]) if len(metrics) else 0.9
    m = metrics[[c for c in _METRIC_LABELS if c in metrics]]
    body = rep.table_html(m.rename(columns=_METRIC_LABELS), caption=rep.caption("metrics"))
    rho_med = float(np.median(gfit.flat("rho")))
    rho_seed = (
        float(metrics["rho_bin_correlation"].iloc[0])
        if "rho_bin_correlation" in metrics and len(metrics)
        else np.nan
    )
    ref_col = next((c for c in ("ref_hws_std_ms", "true_hws_std_ms") if c in records), None)
    if ref_col is not None:
        r = records[records["ti_corrected_median"].notna()]
        ref = r[ref_col].to_numpy(dtype=float)
        rho_pc, rho_src = (
            (rho_seed, "Gutiérrez-Antuñano et al. 2018")
            if np.isfinite(rho_seed)
            else (rho_med, "posterior median")
        )
        szb = r["sigma_z_baseline_ms"].to_numpy(dtype=float)
        corr = {
            "U": correction.sigma_moving_u(ref, szb),
            "C": correction.sigma_moving_c(ref, szb),
            "PC": correction.sigma_moving_pc(ref, szb, rho_pc),
            "Bayesian": correction.sigma_moving_pc(ref, r["sigma_z_median_ms"].to_numpy(dtype=float), rho_med),
        }  # fmt: skip
        label = "reference" if ref_col == "ref_hws_std_ms" else "truth"
        body += rep.img_html(
            rep.figure_to_data_uri(
                plots.sigma_scatter_figure(r["hws_std_ms"].to_numpy(), ref, corr, ref_label=label)
            ),
            rep.caption("sigma_scatter", label=label, rho_pc=rho_pc, rho_src=rho_src),
        )
    if "ti_true" in records:
        body += rep.table_html(
            regime_calibration_table(records).rename(columns=_REGIME_LABELS),
            caption=rep.caption("regimes", mass=mass),
        )
    return rep.Section(
        f"Correction methods compared on {results_dir.name}/ (Gutiérrez-Antuñano et al. 2018, "
        "Tables 2-3)",
        body,
    )


_REGIME_LABELS = {
    "grouping": "grouping", "group": "group", "n": "records", "answered_share": "answered",
    "coverage": "coverage", "coverage_lo": "coverage low", "coverage_hi": "coverage high",
    "mean_rel_error": "mean rel. error", "mean_rel_error_se": "its std. error",
    "median_rel_width": "median rel. width",
    "coverage_total": "coverage (total)", "median_rel_width_total": "median rel. width (total)",
}  # fmt: skip


def public_config(config: dict) -> dict:
    """The config as the report shows it: an absolute path becomes its file name."""
    if isinstance(config, dict):
        return {k: public_config(v) for k, v in config.items()}
    if isinstance(config, list):
        return [public_config(v) for v in config]
    if isinstance(config, str) and os.path.isabs(config):
        return Path(config).name
    return config


def _load(res: Path, batch_dirs, config: dict, motion_missing: Sequence[str] = ()) -> dict:
    """The result tables the report reads, and what is derived from them once.

    The per-bin tables (results/ti/bins.csv, results/inference/bin_fits.csv) are read
    with the bin motion model only: the record motion model runs no per-bin fit, and its
    ``bins`` and ``bin_fits`` are empty tables (no bin failed). Without motion statistics
    (``motion_missing``, the missing columns) only the records, the speed bins and QC
    exist: ``corrected`` is False.
    """
    if motion_missing:
        ctx = {
            "records": read_csv(res / "ti" / "records.csv"),
            "speed_bins": read_csv(res / "ti" / "speed_bins.csv"),
            "qc_counts": read_csv(res / "qc" / "summary.csv"),
            "corrected": False,
            "motion_missing": tuple(motion_missing),
            "gfit": None,
        }
        return _load_common(ctx, config, None)
    from flidar_uq import inference as inf

    gfit = inf.load_fit(res / "posterior" / "global.nc")
    motion_model = "record" if inf.is_record_model(gfit) else "bin"
    no_bins = pd.DataFrame({"status": pd.Series(dtype=str)})
    ctx = {
        "records": read_csv(res / "ti" / "records.csv"),
        "data": read_table(res / "data" / "records.parquet"),
        "bins": read_csv(res / "ti" / "bins.csv") if motion_model == "bin" else no_bins,
        "speed_bins": read_csv(res / "ti" / "speed_bins.csv"),
        "groups": read_csv(res / "ti" / "groups.csv"),
        "budget": read_csv(res / "ti" / "uncertainty_budget.csv"),
        "metrics": read_csv(res / "ti" / "metrics.csv"),
        "qc_counts": read_csv(res / "qc" / "summary.csv"),
        "roll_pitch": read_csv(res / "motion" / "roll_pitch.csv"),
        "bin_fits": (
            read_csv(res / "inference" / "bin_fits.csv") if motion_model == "bin" else no_bins
        ),
        "global_summary": read_csv(res / "inference" / "global.csv"),
        "gfit": gfit,
        "motion_model": motion_model,
        "batch_dirs": list(batch_dirs),
        "corrected": True,
    }
    m = ctx["metrics"]
    kind = str(m["reference_kind"].iloc[0]) if "reference_kind" in m and len(m) else None
    return _load_common(ctx, config, kind)


def _load_common(ctx: dict, config: dict, kind: str | None) -> dict:
    """What :func:`_load` derives alike with and without motion statistics: the heights,
    the credible mass, the bins' fewest records and the reference kind (``kind``, the one
    the propagation resolved, else the config's)."""
    ctx["config"] = config
    ctx["mass"] = float(config["propagation"]["credible_mass"])
    ctx["min_count"] = int(config.get("report", {}).get("group_min_count", 10))
    ctx["heights"] = sorted(ctx["records"]["height_m"].dropna().unique())
    ctx["reference_kind_code"] = kind or (config.get("reference") or {}).get("kind") or "none"
    ctx["reference_kind"] = {
        "cup": "cup anemometer",
        "sonic": "sonic anemometer",
        "fixed_lidar": "fixed (motionless) lidar",
        "none": "none",
    }.get(ctx["reference_kind_code"], ctx["reference_kind_code"])
    return ctx


def build_report(
    *,
    out_path: str | os.PathLike,
    results_dir: str | os.PathLike,
    batch_dirs: Sequence[str | os.PathLike],
    config: dict,
    git_revision: str = "",
    input_files: dict[str, str | os.PathLike] | None = None,
    series_paths: dict | None = None,
    motion_missing: Sequence[str] = (),
) -> str:
    """Write the self-contained HTML report of the user's campaign from the result files.

    The first screen answers (TI per height and 1-m/s bin, the representative TI at
    15 m/s with its IEC category, the validation headline, the campaign and its input
    file, warnings in plain words); the sections after it hold the figures analysts
    expect, the appendix the rest. The developer's benchmark charts are not in it
    (:func:`build_developer_report`). No absolute path is written: files by name.

    Parameters
    ----------
    out_path : path
        The HTML file (normally results/report/report.html).
    results_dir : path
        The pipeline's ``results/`` directory (ti/, bins/, qc/, motion/, inference/,
        posterior/, data/).
    batch_dirs : sequence of path
        The per-bin inference batch directories.
    config : dict
        The run's configuration (provenance, thresholds, reference kind, hold-out).
    git_revision : str
        Revision of the workflow's repository.
    input_files : dict of str -> path, optional
        Files whose SHA-256 and row count go into the provenance (label -> path); the
        first is the input record table named on the first screen.
    series_paths : dict, optional
        Result files of the raw IMU series and the LOS branch, when given
        (:func:`flidar_uq.workflow.series_report.series_sections`).
    motion_missing : sequence of str
        The motion columns the records lack
        (:func:`flidar_uq.workflow.inputs.missing_motion_columns`): the campaign was not
        corrected (results/ti/ of the ``uncorrected`` rule), and the report gives the
        uncorrected TI per height and speed bin with its IEC category, what is missing and
        what a correction would take; no fit, motion or validation section.

    Returns
    -------
    str
        The HTML text written.
    """
    from flidar_uq.workflow.report_summary import campaign_name

    ctx = _load(Path(results_dir), batch_dirs, config, motion_missing)
    ctx["input_file"] = next(iter((input_files or {}).values()), None)
    if ctx["corrected"]:
        sections = _corrected_sections(ctx, series_paths)
        title = f"{campaign_name(config)}: motion-corrected turbulence intensity"
    else:
        ctx["validation"], ctx["warnings"] = None, []
        sections = [_ti_section(ctx), _qc_section(ctx)]
        title = f"{campaign_name(config)}: turbulence intensity, not corrected for motion"
    sections.append(
        rep.Section(
            "How to cite", rep.templates().get_template("sections/references.html.j2").render()
        )
    )
    prov = file_provenance(input_files or {})
    shown = public_config(config)
    sections.append(
        rep.Section(
            "Provenance and how to rerun",
            rep.templates()
            .get_template("sections/rerun.html.j2")
            .render(files=Markup(rep.table_html(prov, caption="input files")))
            + rep.provenance_html(
                shown, git_revision, rep.package_versions(), numeric_environment()
            ),
        )
    )
    text = rep.render_html(title, sections, intro_html=_first_screen(ctx))
    Path(out_path).parent.mkdir(parents=True, exist_ok=True)
    Path(out_path).write_text(text, encoding="utf-8")
    return text


def _corrected_sections(ctx: dict, series_paths: dict | None) -> list[rep.Section]:
    """The sections of a corrected campaign's report before the citation and provenance;
    sets the validation and the warnings of the first screen in ``ctx``."""
    from flidar_uq.workflow.report_summary import held_out_records, validate
    from flidar_uq.workflow.series_report import series_sections

    records, config = ctx["records"], ctx["config"]
    ctx["validation"] = validate(records, config, ctx["reference_kind_code"])
    ctx["held_out"] = (
        held_out_records(records, config)[0] if ctx["validation"] else np.zeros(len(records), bool)
    )
    coverage = np.nan
    if ctx["validation"] is not None:
        s = ctx["validation"].tables["summary"]
        row = s[(s["sample"] == ctx["validation"].sample) & (s["estimate"] == "corrected")]
        coverage = float(row["coverage"].iloc[0]) if len(row) else np.nan
    ctx["warnings"] = _plain_warnings(
        ctx["gfit"], ctx["bins"], records, ctx["global_summary"], ctx["motion_model"], coverage
    )
    v = ctx["validation"]
    if v is not None and not (config.get("validation") or {}).get("trial_posterior"):
        if not (v.tables["summary"]["sample"] == "in sample").any():
            ctx["warnings"].append(
                "The hold-out removed every reference record from the fit: the model ran on "
                "its priors and the correction is not calibrated. Hold out less "
                "(validation.holdout.days) or use alternate_weeks on a longer campaign."
            )
    return [
        _ti_section(ctx),
        _validation_section(ctx),
        _direction_section(ctx),
        _motion_section(ctx),
        _diagnostics_section(ctx),
        _bin_table_section(ctx),
        _budget_section(ctx),
        _qc_section(ctx),
        *filter(None, [_model_selection_section(ctx)]),
        *series_sections(**(series_paths or {})),  # raw IMU series, LOS branch
    ]


def build_developer_report(
    *,
    out_path: str | os.PathLike,
    benchmarks_dir: str | os.PathLike,
    git_revision: str = "",
    results_dir: str | os.PathLike | None = None,
) -> str:
    """Write the developer report: benchmark charts, LOS tables, correction methods compared.

    The project's benchmark charts and LOS comparison tables, and a corrected campaign's
    comparison of the correction methods.

    Kept apart from the user's campaign report (results/report/report.html).

    Parameters
    ----------
    out_path : path
        The HTML file (normally results/report/developer.html).
    benchmarks_dir : path
        Directory of benchmark PNG charts and ``los*comparison.csv`` tables.
    git_revision : str
        Revision of the repository.
    results_dir : path, optional
        A pipeline's ``results/``: when it holds a corrected campaign, the MD / RMSE of the
        uncorrected, U, C, PC and Bayesian std and TI against the reference or truth
        (Gutiérrez-Antuñano et al. 2018, Tables 2-3; results/ti/metrics.csv), the corrected
        stds against the reference (their Fig. 5) and, for virtual campaigns, the
        calibration per regime.

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
    methods = _methods_section(Path(results_dir)) if results_dir is not None else None
    if methods is not None:
        sections.append(methods)
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
