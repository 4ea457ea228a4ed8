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
from collections.abc import Sequence
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
    "category_move_words",
    "correction_size_words",
    "coverage_words",
    "first_screen_html",
    "held_out_records",
    "hull_model_short",
    "hull_model_words",
    "lever_arm_words",
    "missing_motion_words",
    "model_selection_words",
    "motion_description_summary",
    "motion_scale_words",
    "reference_speed_bins",
    "representative_at_15",
    "uncorrected_at_15",
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


#: Columns of :func:`representative_at_15`.
_REP15_COLUMNS = ["height_m", "n", "ti_rep", "ti_rep_lo", "ti_rep_hi", "category",
                  "ti_rep_uncorrected", "category_uncorrected", "note"]  # fmt: skip


def representative_at_15(speed_bins: pd.DataFrame, min_count: int = 10) -> pd.DataFrame:
    """Per height: the representative TI of the 15-m/s bin and its IEC category, corrected
    and uncorrected.

    Returns ``height_m``, ``n``, ``ti_rep``, ``ti_rep_lo``, ``ti_rep_hi`` (-), ``category``
    (:func:`flidar_uq.validation.reference.iec_category` of the value, and of the interval
    bounds when they fall in other categories), ``ti_rep_uncorrected`` (-) and
    ``category_uncorrected`` (of the floating lidar's TI as measured, the records with a
    corrected TI) and ``note`` (why a height has none).
    """
    rows = []
    for h, b in speed_bins.groupby("height_m", sort=True):
        at = b[np.isclose(b["hws_bin_ms"], IEC_REFERENCE_SPEED_MS)]
        n = int(at["n"].iloc[0]) if len(at) else 0
        vals = at[["ti_rep", "ti_rep_lo", "ti_rep_hi", "ti_rep_uncorrected"]].to_numpy(float)
        if n < min_count or not len(vals) or not np.isfinite(vals[0, 0]):
            rows.append({"height_m": h, "n": n, "ti_rep": np.nan, "ti_rep_lo": np.nan,
                         "ti_rep_hi": np.nan, "category": "", "ti_rep_uncorrected": np.nan,
                         "category_uncorrected": "",
                         "note": f"too few records in the 15-m/s bin ({n})"})  # fmt: skip
            continue
        v, lo, hi, unc = vals[0]
        cats = dict.fromkeys(iec_category(x) for x in (lo, v, hi))
        cat = iec_category(v) + (f" (interval spans {' to '.join(cats)})" if len(cats) > 1 else "")
        rows.append({"height_m": h, "n": n, "ti_rep": v, "ti_rep_lo": lo, "ti_rep_hi": hi,
                     "category": cat, "ti_rep_uncorrected": unc,
                     "category_uncorrected": iec_category(unc), "note": ""})  # fmt: skip
    return pd.DataFrame(rows, columns=_REP15_COLUMNS)


def uncorrected_at_15(speed_bins: pd.DataFrame, min_count: int = 10) -> pd.DataFrame:
    """:func:`representative_at_15` of the uncorrected TI (a campaign without motion
    statistics): ``ti_rep`` and its bounds are ``ti_rep_uncorrected``, ``category`` its
    IEC category."""
    u = speed_bins["ti_rep_uncorrected"]
    return representative_at_15(speed_bins.assign(ti_rep=u, ti_rep_lo=u, ti_rep_hi=u), min_count)


def correction_size_words(row) -> str:
    """The correction's size at 15 m/s of one height in plain words ("" without a value).

    ``row``: a row of :func:`representative_at_15`, e.g. "At 85 m the representative TI
    at 15 m/s falls from 0.142 to 0.135 (-5.0 %; corrected interval 0.131-0.139): IEC
    category B -> C."
    """
    before, after = float(row.ti_rep_uncorrected), float(row.ti_rep)
    if not (np.isfinite(before) and np.isfinite(after)):
        return ""
    verb = "falls" if after < before else "rises" if after > before else "stays"
    cat_before, cat_after = row.category_uncorrected, iec_category(after)
    cats = (
        f"IEC category {cat_before} -> {cat_after}"
        if cat_before != cat_after
        else f"IEC category {cat_after} either way"
    )
    return (
        f"At {row.height_m:g} m the representative TI at 15 m/s {verb} from {before:.3f} to "
        f"{after:.3f} ({100 * (after / before - 1.0):+.1f} %; corrected interval "
        f"{row.ti_rep_lo:.3f}-{row.ti_rep_hi:.3f}): {cats}."
    )


def category_move_words(rep15: pd.DataFrame) -> str:
    """One sentence when the correction moves every height (two or more, each with a value)
    from one IEC category to the same other one, else "" (``rep15``:
    :func:`representative_at_15`)."""
    r = rep15[np.isfinite(rep15["ti_rep"].to_numpy(float))]
    r = r[np.isfinite(r["ti_rep_uncorrected"].to_numpy(float))]
    if len(r) < 2 or len(r) < len(rep15):
        return ""
    cats = zip(r["category_uncorrected"], r["ti_rep"], strict=True)
    moves = {(before, iec_category(after)) for before, after in cats}
    if len(moves) != 1:
        return ""
    ((before, after),) = moves
    if before == after:
        return ""
    n = {2: "both", 3: "all three"}.get(len(r), f"all {len(r)}")
    return f"The correction moves {n} heights from IEC category {before} to {after}."


def _cell(v: float, lo: float = np.nan, hi: float = np.nan) -> tuple[str, str]:
    if not np.isfinite(v):
        return ("–", "")
    return (f"{v:.3f}", f"{lo:.3f}–{hi:.3f}" if np.isfinite(lo) else "")


def _bin_rows(
    b: pd.DataFrame, ref: pd.DataFrame, min_count: int, corrected: bool = True
) -> list[list[tuple]]:
    """Cells (value, interval line) of one height's per-bin table (``corrected`` False:
    the uncorrected mean, representative TI and P90 only)."""
    ref = ref.set_index("hws_bin_ms") if len(ref) else None
    rows = []
    for _, r in b[b["n"] > 0].sort_values("hws_bin_ms").iterrows():
        few = r["n"] < min_count
        row = [(f"{r['hws_bin_ms']:g}", ""), (f"{int(r['n'])}", "")]
        if not corrected:
            stats = ("ti_mean_uncorrected", "ti_rep_uncorrected", "ti_p90_uncorrected")
            rows.append(row + [("–", "") if few else _cell(r[c]) for c in stats])
            continue
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


def coverage_words(v: Validation, mass: float) -> str:
    """The held-out records' interval coverage in words ("" when in sample: the fit saw
    those records, so their coverage says nothing about new ones)."""
    if v.sample != "held out":
        return ""
    s = v.tables["summary"]
    row = s[(s["sample"] == "held out") & (s["estimate"] == "corrected")]
    if not len(row) or not np.isfinite(row["coverage"].iloc[0]):
        return ""
    cov, n = float(row["coverage"].iloc[0]), int(row["n"].iloc[0])
    return (
        f"On the {n} held-out records, which the fit never saw, the corrected TI's {mass:.0%} "
        f"interval holds the reference TI in {100 * cov:.1f} % of them ({mass:.0%} expected: "
        "fewer means intervals too narrow, more too wide)."
    )


def _headline_table(v: Validation) -> str:
    """The validation headline: bias, RMSE, slope, offset, R² (the coverage is in words,
    :func:`coverage_words`)."""
    tab = v.tables["summary"].copy()
    out = pd.DataFrame({VALIDATION_LABELS[c]: tab[c] for c in ("sample", "estimate", "n")})
    for c, fmt in (("bias", "{:+.4f}"), ("bias_rel", "{:+.1f}"), ("rmse", "{:.4f}"),
                   ("slope", "{:.3f}"), ("offset", "{:+.4f}"), ("r2", "{:.3f}")):  # fmt: skip
        scale = 100.0 if c == "bias_rel" else 1.0
        out[VALIDATION_LABELS[c]] = [
            fmt.format(scale * x) if np.isfinite(x) else "–" for x in tab[c]
        ]
    return rep.table_html(out, caption="")


@dataclass(frozen=True)
class FirstScreen:
    """What the first screen shows (the report step builds it from the results)."""

    title: str
    facts: list
    rep15: pd.DataFrame
    bin_tables: list
    validation: Validation | None
    warnings: list
    mass: float
    #: Without motion statistics: what is missing and what it would take
    #: (:func:`missing_motion_words`); the TI is then the uncorrected one.
    missing_motion: str = ""


def first_screen_html(screen: FirstScreen) -> str:
    """The first screen's HTML (``templates/sections/first_screen.html.j2``)."""
    v = screen.validation
    corrected = not screen.missing_motion
    rep15 = [
        {
            "height": f"{r.height_m:g}",
            "value": _cell(r.ti_rep, r.ti_rep_lo, r.ti_rep_hi) if corrected else _cell(r.ti_rep),
            "category": r.category,
            "words": correction_size_words(r) if corrected else "",
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
            moves=category_move_words(screen.rep15) if corrected else "",
            bin_tables=screen.bin_tables,
            headline=Markup(_headline_table(v)) if v else "",
            statement=v.statement if v else "",
            sample=v.sample if v else "",
            coverage=coverage_words(v, screen.mass) if v else "",
            lidar_reference=bool(v and v.lidar_reference),
            warnings=screen.warnings,
            mass=f"{screen.mass:.0%}",
            missing_motion=screen.missing_motion,
        )
    )


def missing_motion_words(missing: Sequence[str], has_reference: bool) -> str:
    """What a campaign without motion statistics lacks and what its correction would take,
    in plain words (the first screen's statement).

    Parameters
    ----------
    missing : sequence of str
        The motion columns the records lack
        (:func:`flidar_uq.workflow.inputs.missing_motion_columns`).
    has_reference : bool
        The records carry a reference instrument's TI.
    """
    cols = ", ".join(missing)
    reference = (
        "The input's reference TI will then validate the correction."
        if has_reference
        else "Ideally, add a period with a reference instrument beside the buoy (a fixed "
        "lidar, cup or sonic anemometer: columns ref_hws_mean_ms and ref_hws_std_ms) to "
        "validate the correction."
    )
    return (
        f"Not corrected for the buoy's motion: the input has no {cols} "
        f"column{'s' if len(missing) > 1 else ''} and no raw IMU series. The TI here is the "
        "floating lidar's TI as measured; the buoy's motion adds to it, so it may overstate "
        "the wind's TI and its IEC category. To correct it, give each 10-min record's roll "
        "and pitch amplitude and period (roll_amplitude_deg, pitch_amplitude_deg, "
        "roll_period_s, pitch_period_s; the record format of docs/data-format.md) or the "
        f"buoy's IMU series (config campaign.imu_series), and run again. {reference}"
    )


def bin_tables(
    speed_bins: pd.DataFrame, ref_bins: pd.DataFrame, min_count: int, corrected: bool = True
) -> list[dict]:
    """The per-height bin tables of the first screen (template context; ``corrected``
    False: the uncorrected statistics only)."""
    out = []
    for h, b in speed_bins.groupby("height_m", sort=True):
        ref = ref_bins[np.isclose(ref_bins["height_m"], h)] if len(ref_bins) else ref_bins
        out.append(
            {
                "height": f"{h:g}",
                "id": f"bins-{h:g}".replace(".", "_"),
                "reference": bool(len(ref_bins)),
                "rows": _bin_rows(b, ref, min_count, corrected),
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


#: The reference hulls in a reader's words (physics.hull.HULLS names).
_HULL_PLAIN = {
    "wave_follower": "the hull that follows the waves",
    "discus_buoy": "the large discus buoy's hull (follows the waves longer than about 4 s)",
    "spar": "the deep-draught spar's hull",
}


def _hull_plain(name: str) -> str:
    return _HULL_PLAIN.get(name, f"the {name.replace('_', ' ')} hull")


def hull_model_short(info: dict) -> str:
    """The record model's hull description in a few words, from the global fit's ``info``
    ("" without one); the comparison that chose it is :func:`model_selection_words`'."""
    kept = info.get("hull_model")
    if not kept:
        return ""
    if kept == "rotation_only":
        return "rotation about a fixed centre, no translation"
    return f"rotation and translation of {_hull_plain(info.get('hull_reference', 'wave_follower'))}"


def _margin_words(d: float, se: float) -> str:
    """How clearly a PSIS-LOO elpd difference ``d`` (± ``se``) favours a model, in words
    (the selection's rule: clear beyond max(4, 2 se))."""
    if d > max(4.0, 2.0 * se):
        return "by a clear margin"
    return "slightly, within the noise of the comparison, so the simpler one is kept"


def _favour(first: str, second: str, d: float, se: float) -> str:
    if d > 0:
        return f"The data favour {first} over {second}, {_margin_words(d, se)}"
    return f"The data do not favour {first} over {second}"


def model_selection_words(info: dict) -> list[str]:
    """The record model's hull comparisons in words a reader can use ([] without any), e.g.
    "The data favour the hull that follows the waves over rotation only, by a clear
    margin." Each sentence ends with the statistic behind it (PSIS-LOO elpd difference,
    Vehtari et al. 2017)."""
    out = []
    cmp = info.get("hull_model_comparison")
    if cmp:
        d, se = float(cmp["elpd_difference"]), float(cmp["elpd_difference_se"])
        ref = _hull_plain(info.get("hull_reference", "wave_follower"))
        out.append(
            _favour(ref, "rotation only", d, se)
            + f" (PSIS-LOO elpd difference {d:+.1f} ± {se:.1f})."
        )
    rc = info.get("hull_reference_comparison")
    if rc and info.get("hull_model") == "translating":
        for c in rc["candidates"][1:]:
            d, se = float(c["elpd_difference"]), float(c["elpd_difference_se"])
            out.append(
                _favour(_hull_plain(c["hull_reference"]), _hull_plain(c["against"]), d, se)
                + f" (elpd difference {d:+.1f} ± {se:.1f}); kept: {_hull_plain(rc['kept'])}."
            )
    return out


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
