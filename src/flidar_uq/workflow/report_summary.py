"""The report's first screen and its validation against the reference.

The first screen answers: per height, the TI per IEC 1-m/s bin (records, corrected mean
and representative TI with their intervals, uncorrected, reference); the representative
TI at 15 m/s with its IEC 61400-1 ed. 4 category; the validation headline (bias, RMSE,
slope, offset, R² of corrected and uncorrected TI against the reference, in sample or
held out); the campaign's name, input file and period; the warnings in plain words.
The statistics come from :mod:`flidar_uq.validation.reference`; this module lays them out.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd
from markupsafe import Markup

from flidar_uq.data.binning import speed_bin_ms
from flidar_uq.data.metrics import representative_ti
from flidar_uq.physics.hull import get_hull
from flidar_uq.validation.reference import holdout_mask, iec_category, validation_tables
from flidar_uq.workflow import report as rep

__all__ = [
    "Validation",
    "campaign_name",
    "first_screen_html",
    "held_out_records",
    "hull_model_words",
    "lever_arm_words",
    "motion_description_summary",
    "motion_scale_words",
    "reference_speed_bins",
    "representative_at_15",
    "validate",
]

#: Wind speed of the IEC 61400-1 reference turbulence intensity (m/s).
IEC_REFERENCE_SPEED_MS = 15.0

#: Readable names of the validation columns (TI statistics, -; bias % relative).
VALIDATION_LABELS = {
    "sample": "records",
    "estimate": "TI",
    "n": "n",
    "bias": "bias",
    "bias_rel": "bias (%)",
    "rmse": "RMSE",
    "slope": "slope",
    "offset": "offset",
    "r2": "R²",
    "coverage": "coverage of the 90 % interval",
}


def campaign_name(config: dict) -> str:
    """The campaign's name: ``report.title``, else the input file's or scenario's name."""
    title = (config.get("report") or {}).get("title") or ""
    if title:
        return str(title)
    camp = config.get("campaign") or {}
    if camp.get("source") == "files" and camp.get("records"):
        return Path(str(camp["records"])).stem
    return f"virtual campaign '{Path(str(camp.get('scenario', ''))).stem}'"


@dataclass(frozen=True)
class Validation:
    """The validation of a campaign: its tables and what was held out, in words."""

    tables: dict
    statement: str
    sample: str
    lidar_reference: bool


def held_out_records(records: pd.DataFrame, config: dict) -> tuple[np.ndarray, str, bool]:
    """Which records' reference the fit never saw, a sentence saying so, and whether all.

    From the config's ``validation`` section (the same :func:`flidar_uq.validation.
    reference.holdout_mask` as the fit's input, the campaign ending at the latest record
    of ``records``: results/ti/records.csv holds every validated record).
    """
    val = config.get("validation") or {}
    ts = records["timestamp"]
    has_ref = np.isfinite(records["ti_ref"].to_numpy(dtype=float))
    trial = val.get("trial_posterior") or ""
    if trial:
        return (
            np.ones(len(records), dtype=bool),
            f"Held out: the model was fitted on a trial campaign (posterior "
            f"{Path(trial).name}); none of this campaign's {int(has_ref.sum())} reference "
            "records was fitted.",
            True,
        )
    hold = val.get("holdout") or {}
    mode, days = hold.get("mode", "none"), float(hold.get("days", 7))
    held = holdout_mask(ts, mode=mode, days=days)
    if mode == "none":
        return (
            held,
            "In sample: the model was fitted on these same reference records, so the "
            "figures show how well it fits them, not how well it predicts new ones (config "
            "validation.holdout holds part of the reference out).",
            False,
        )
    what = (
        "every other calendar week (odd weeks, Monday to Monday UTC)"
        if mode == "alternate_weeks"
        else f"the last {days:g} days"
    )
    return (
        held,
        f"Held out: the reference of {what} was removed from the fit ({int((held & has_ref).sum())} "
        f"records with a reference); the validation is computed on those of them with a "
        f"corrected TI, the in-sample figures (of the {int((~held & has_ref).sum())} "
        "reference records the model could be fitted on) beside.",
        False,
    )


def validate(records: pd.DataFrame, config: dict, reference_kind: str) -> Validation | None:
    """The validation tables of ``records`` (results/ti/records.csv), None without a reference.

    ``reference_kind``: the resolved ``reference.kind``; against a lidar (fixed_lidar) the
    corrected point TI is compared in the lidar's terms (times ``lidar_std_ratio``).
    """
    if "ti_ref" not in records or not np.isfinite(records["ti_ref"].to_numpy(float)).any():
        return None
    held, statement, all_held = held_out_records(records, config)
    lidar = reference_kind in ("fixed_lidar", "none")
    scale = records["lidar_std_ratio"].to_numpy(dtype=float) if lidar else None
    min_count = int((config.get("report") or {}).get("group_min_count", 10))
    tables = validation_tables(
        records, held, reference_scale=scale, all_held_out=all_held, min_count=min_count
    )
    sample = "held out" if (tables["summary"]["sample"] == "held out").any() else "in sample"
    return Validation(tables, statement, sample, lidar)


def reference_speed_bins(records: pd.DataFrame, min_count: int = 10) -> pd.DataFrame:
    """The reference instrument's TI per height and 1-m/s bin: ``n``, ``ti_mean``, ``ti_rep``.

    Over the records with a reference TI and a corrected TI (bins with fewer than
    ``min_count`` keep their count, NaN statistics).
    """
    cols = ["height_m", "hws_bin_ms", "n", "ti_mean", "ti_rep"]
    if "ti_ref" not in records:
        return pd.DataFrame(columns=cols)
    r = records[np.isfinite(records["ti_ref"]) & np.isfinite(records["ti_corrected_median"])]
    r = r.assign(hws_bin_ms=speed_bin_ms(r["hws_mean_ms"].to_numpy(dtype=float)))
    g = r.groupby(["height_m", "hws_bin_ms"])["ti_ref"]
    out = pd.DataFrame({"n": g.size(), "ti_mean": g.mean(), "ti_rep": g.agg(representative_ti)})
    out.loc[out["n"] < min_count, ["ti_mean", "ti_rep"]] = np.nan
    return out.reset_index()[cols]


def representative_at_15(speed_bins: pd.DataFrame, min_count: int = 10) -> pd.DataFrame:
    """Per height: the corrected representative TI of the 15-m/s bin and its IEC category.

    Returns ``height_m``, ``n``, ``ti_rep``, ``ti_rep_lo``, ``ti_rep_hi`` (-), ``category``
    (:func:`flidar_uq.validation.reference.iec_category` of the value, and of the interval
    bounds when they fall in other categories) and ``note`` (why a height has none).
    """
    rows = []
    for h, b in speed_bins.groupby("height_m", sort=True):
        at = b[np.isclose(b["hws_bin_ms"], IEC_REFERENCE_SPEED_MS)]
        n = int(at["n"].iloc[0]) if len(at) else 0
        vals = at[["ti_rep", "ti_rep_lo", "ti_rep_hi"]].to_numpy(dtype=float)
        if n < min_count or not len(vals) or not np.isfinite(vals[0, 0]):
            rows.append({"height_m": h, "n": n, "ti_rep": np.nan, "ti_rep_lo": np.nan,
                         "ti_rep_hi": np.nan, "category": "",
                         "note": f"too few records in the 15-m/s bin ({n})"})  # fmt: skip
            continue
        v, lo, hi = vals[0]
        cats = dict.fromkeys(iec_category(x) for x in (lo, v, hi))
        cat = iec_category(v) + (f" (interval spans {' to '.join(cats)})" if len(cats) > 1 else "")
        rows.append({"height_m": h, "n": n, "ti_rep": v, "ti_rep_lo": lo, "ti_rep_hi": hi,
                     "category": cat, "note": ""})  # fmt: skip
    return pd.DataFrame(
        rows, columns=["height_m", "n", "ti_rep", "ti_rep_lo", "ti_rep_hi", "category", "note"]
    )


def _cell(v: float, lo: float = np.nan, hi: float = np.nan) -> tuple[str, str]:
    if not np.isfinite(v):
        return ("–", "")
    return (f"{v:.3f}", f"{lo:.3f}–{hi:.3f}" if np.isfinite(lo) else "")


def _bin_rows(b: pd.DataFrame, ref: pd.DataFrame, min_count: int) -> list[list[tuple]]:
    """Cells (value, interval line) of one height's per-bin table."""
    ref = ref.set_index("hws_bin_ms") if len(ref) else None
    rows = []
    for _, r in b[b["n"] > 0].sort_values("hws_bin_ms").iterrows():
        few = r["n"] < min_count
        row = [(f"{r['hws_bin_ms']:g}", ""), (f"{int(r['n'])}", "")]
        row.append(("–", "") if few else _cell(r["ti_mean"], r["ti_mean_lo"], r["ti_mean_hi"]))
        row.append(("–", "") if few else _cell(r["ti_rep"], r["ti_rep_lo"], r["ti_rep_hi"]))
        row.append(
            ("–", "")
            if few
            else (f"{r['ti_mean_uncorrected']:.3f}", f"{r['ti_rep_uncorrected']:.3f}")
        )
        if ref is not None:
            x = ref.loc[r["hws_bin_ms"]] if r["hws_bin_ms"] in ref.index else None
            row.append(
                ("–", "")
                if x is None or not np.isfinite(x["ti_mean"])
                else (
                    f"{x['ti_mean']:.3f}",
                    f"{x['ti_rep']:.3f}" + (f" (n={int(x['n'])})" if x["n"] != r["n"] else ""),
                )
            )
        rows.append(row)
    return rows


def _headline_table(v: Validation) -> str:
    tab = v.tables["summary"].copy()
    out = pd.DataFrame({VALIDATION_LABELS[c]: tab[c] for c in ("sample", "estimate", "n")})
    for c, fmt in (("bias", "{:+.4f}"), ("bias_rel", "{:+.1f}"), ("rmse", "{:.4f}"),
                   ("slope", "{:.3f}"), ("offset", "{:+.4f}"), ("r2", "{:.3f}")):  # fmt: skip
        scale = 100.0 if c == "bias_rel" else 1.0
        out[VALIDATION_LABELS[c]] = [
            fmt.format(scale * x) if np.isfinite(x) else "–" for x in tab[c]
        ]
    out["coverage"] = [f"{100 * x:.1f} %" if np.isfinite(x) else "–" for x in tab["coverage"]]
    return rep.table_html(out, caption="")


@dataclass(frozen=True)
class FirstScreen:
    """What the first screen shows (built by :func:`build_first_screen` from the results)."""

    title: str
    facts: list
    rep15: pd.DataFrame
    bin_tables: list
    validation: Validation | None
    warnings: list
    mass: float


def first_screen_html(screen: FirstScreen) -> str:
    """The first screen's HTML (``templates/sections/first_screen.html.j2``)."""
    v = screen.validation
    rep15 = [
        {
            "height": f"{r.height_m:g}",
            "value": _cell(r.ti_rep, r.ti_rep_lo, r.ti_rep_hi),
            "category": r.category,
            "note": r.note,
        }
        for r in screen.rep15.itertuples()
    ]
    return (
        rep.templates()
        .get_template("sections/first_screen.html.j2")
        .render(
            facts=screen.facts,
            rep15=rep15,
            bin_tables=screen.bin_tables,
            headline=Markup(_headline_table(v)) if v else "",
            statement=v.statement if v else "",
            lidar_reference=bool(v and v.lidar_reference),
            warnings=screen.warnings,
            mass=f"{screen.mass:.0%}",
        )
    )


def bin_tables(speed_bins: pd.DataFrame, ref_bins: pd.DataFrame, min_count: int) -> list[dict]:
    """The per-height bin tables of the first screen (template context)."""
    out = []
    for h, b in speed_bins.groupby("height_m", sort=True):
        ref = ref_bins[np.isclose(ref_bins["height_m"], h)] if len(ref_bins) else ref_bins
        out.append(
            {
                "height": f"{h:g}",
                "id": f"bins-{h:g}".replace(".", "_"),
                "reference": bool(len(ref_bins)),
                "rows": _bin_rows(b, ref, min_count),
            }
        )
    return out


def file_identity(path: str | os.PathLike) -> tuple[str, str]:
    """The file's name (never its directory) and its SHA-256 ("" when absent)."""
    import hashlib

    p = Path(path)
    if not p.is_file():
        return p.name, ""
    return p.name, hashlib.sha256(p.read_bytes()).hexdigest()


def motion_scale_words(motion_scale: float, coverage: float) -> str:
    """The motion-scale check in plain words: what it means for the numbers, what to do.

    ``motion_scale``: posterior median of the record model's motion scale (-);
    ``coverage``: the corrected TI's interval coverage of the reference TI on the
    validation records (-, NaN without a reference).
    """
    k = f"{motion_scale:.2f}" if np.isfinite(motion_scale) else "outside 0.8-1.25"
    cov = (
        f" On the validation records the intervals hold the reference TI in "
        f"{100 * coverage:.0f} % of the records, so the numbers can be used as validated."
        if np.isfinite(coverage)
        else ""
    )
    return (
        f"The buoy's measured motion explains the extra variance the floating lidar sees "
        f"only when scaled by {k} (expected 0.8-1.25). The corrected TI is then calibrated "
        f"by the reference more than by the motion physics: it holds for sea states like "
        f"those of the reference period.{cov} What to do: check campaign.lidar and the "
        "lever arm (inference.lever_arm_m); with roll and pitch only in the input (no heave "
        "or surge), a scale above 1 stands for the missing translation, and a hold-out "
        "(validation.holdout) shows whether the correction still predicts."
    )


def lever_arm_words(lever_arm_draws_m, configured_m: float | None, coverage: float) -> str:
    """The lever-arm check in plain words: what it means for the numbers, what to do.

    ``lever_arm_draws_m``: posterior draws of the record model's lever arm (m);
    ``configured_m``: the lever arm of the config (``inference.lever_arm_m``, m; None when
    the fit infers it); ``coverage``: as :func:`motion_scale_words`.
    """
    d = np.asarray(lever_arm_draws_m, dtype=float)
    lo, med, hi = np.quantile(d, [0.05, 0.5, 0.95])
    where = (
        f"the {configured_m:.2f} m of the buoy's geometry in the config"
        if configured_m is not None
        else "any height a floating lidar's head sits above its buoy's rotation centre"
    )
    cov = (
        f" On the validation records the intervals hold the reference TI in "
        f"{100 * coverage:.0f} % of the records."
        if np.isfinite(coverage)
        else ""
    )
    return (
        f"The fit places the lidar head {med:.2f} m above the buoy's rotation centre (90 % "
        f"interval {lo:.2f}-{hi:.2f} m), which does not agree with {where}. The lever arm "
        "then stands for motion the model does not describe (the hull's surge, sway and "
        "heave, or a lidar of another type): the corrected TI is calibrated by the "
        f"reference period and holds for sea states like those in it.{cov} What to do: "
        "check inference.lever_arm_m and campaign.lidar, give the buoy's translation "
        "(MRU or wave-sensor columns, docs/data-format.md) if it has any, and use a "
        "hold-out (validation.holdout) to see whether the correction still predicts."
    )


#: Plain words for the record model's motion descriptions (records.csv columns
#: ``motion_description`` and ``translation_description``).
_TILT_WORDS = {
    "tilt_bands": "tilt spectrum by period bands from the IMU",
    "along_wind": "tilt along the wind from the IMU spectrum",
    "roll_pitch": "roll and pitch amplitude and period only",
}
_TRANSLATION_WORDS = {
    "measured": "surge, sway and heave measured (MRU or GNSS stds), the hull response known",
    "imu_series": "translation measured in the IMU series (its heave velocity or "
    "acceleration; surge and sway from their velocities where given, else in proportion), "
    "the hull response known",
    "tilt_spectrum": "surge and heave from the tilt spectrum through the fitted hull response",
    "none": "no translation (rotation about a fixed centre)",
}


#: How the tilt bands' directions of travel were found (records.csv column
#: ``wave_direction_description``, for tilt bands with a translation): measured from the
#: heave, or assumed.
_DIRECTION_WORDS = {
    "measured": "each wave band's direction of travel measured from the heave",
    "assumed": (
        "the wave bands' directions of travel assumed (wind sea downwind, swell of either "
        "side alike), so the motion scale and the lever arm are less certain: a heave "
        "velocity or acceleration in the IMU series measures them"
    ),
}


def motion_description_summary(records: pd.DataFrame) -> str:
    """Which motion description the corrected records got, counted ("" without the columns),
    with how the tilt bands' directions of travel were found where they enter."""
    if "translation_description" not in records:
        return ""
    used = records[records["motion_description"].isin(list(_TILT_WORDS))]
    if used.empty:
        return "none"
    directions = used.get("wave_direction_description", pd.Series("", index=used.index))
    keys = [used["motion_description"], used["translation_description"], directions.fillna("")]
    counts = used.groupby(keys).size()
    parts = []
    for (t, tr, d), n in counts.sort_values(ascending=False).items():
        words = f"{n:,} records: {_TILT_WORDS[t]}; {_TRANSLATION_WORDS.get(tr, tr)}"
        parts.append(f"{words}, {_DIRECTION_WORDS[d]}" if d in _DIRECTION_WORDS else words)
    return " · ".join(parts)


def hull_model_words(info: dict) -> str:
    """The record model's hull description and why, from the global fit's ``info``."""
    kept = info.get("hull_model")
    if not kept:
        return ""
    ref = info.get("hull_reference", "wave_follower")
    name = {
        "rotation_only": "rotation about a fixed centre",
        "translating": f"surge, sway and heave of the {ref} hull "
        f"({get_hull(ref).description}) with the record's tilt spectrum, at the measured "
        "size where the translation is measured, else times a fitted hull response",
    }[kept]
    cmp = info.get("hull_model_comparison")
    rc = info.get("hull_reference_comparison") if kept == "translating" else None
    if rc:
        diffs = "; ".join(
            f"elpd of {c['hull_reference']} minus {c['against']} {c['elpd_difference']:+.1f} ± "
            f"{c['elpd_difference_se']:.1f}"
            for c in rc["candidates"][1:]
        )
        name += (
            f". Reference hull kept by PSIS-LOO: {rc['kept']} ({diffs}; a hull with its own "
            "response is kept only when it is better by more than max(4, 2 se))"
        )
    if not cmp:
        why = (
            "the hull model configured"
            if rc
            else "configured, or no translation description in the records"
        )
        return f"{name} ({why})"
    return (
        f"{name}. The PSIS-LOO elpd of the translating model minus the rotation-only one is "
        f"{cmp['elpd_difference']:+.1f} ± {cmp['elpd_difference_se']:.1f}; the translating "
        "model is kept only when it is better by more than max(4, 2 se)"
    )
