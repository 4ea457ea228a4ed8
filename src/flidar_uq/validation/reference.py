"""Validation of the corrected TI against a reference instrument, in the field's own terms.

Floating-lidar TI is judged against a cup anemometer or a fixed lidar per wind-speed bin
(the IEC 61400-12-1 1-m/s bins) and over all paired records: the mean bias (absolute and
relative), the RMSE, the ordinary least-squares line ``estimate = slope * reference +
offset`` with its R², and the error of the representative TI (IEC 61400-1 ed. 4: the
mean plus 1.28 standard deviations of the 10-min TI of a bin).

Out of sample: :func:`holdout_mask` selects reference records by time blocks (every other
week, or the last N days); the pipeline fits the motion model without them
(:func:`withhold_reference`) and scores the corrected TI on them.

Also the IEC 61400-1 ed. 4 turbulence category of a representative TI
(:func:`iec_category`).
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np
import pandas as pd

from flidar_uq.data.binning import speed_bin_ms
from flidar_uq.data.metrics import interval_coverage, representative_ti

__all__ = [
    "AGREEMENT_COLUMNS",
    "HOLDOUT_MODES",
    "IEC_TURBULENCE_CATEGORIES",
    "Agreement",
    "agreement",
    "agreement_by_speed_bin",
    "holdout_mask",
    "iec_category",
    "iec_representative_ti",
    "validation_summary",
    "validation_tables",
    "withhold_reference",
]

#: Reference turbulence intensity I_ref of the IEC 61400-1 ed. 4 (2019) turbulence
#: categories (Table 1), -, from the most to the least turbulent.
IEC_TURBULENCE_CATEGORIES = {"A+": 0.18, "A": 0.16, "B": 0.14, "C": 0.12}

#: Ways of holding reference records out of the fit (config ``validation.holdout.mode``).
HOLDOUT_MODES = ("none", "alternate_weeks", "last_days")

#: Monday 1970-01-05 00:00 UTC: the weeks of ``alternate_weeks`` start on it (s).
_WEEK_ANCHOR_S = 4 * 86400.0


def iec_representative_ti(hws_ms, i_ref: float) -> np.ndarray:
    """Representative TI of an IEC turbulence category: ``I_ref (0.75 + 5.6 / V)``.

    The normal turbulence model of IEC 61400-1 ed. 4 (2019), Eq. (10):
    ``sigma_1 = I_ref (0.75 V_hub + b)``, ``b = 5.6 m/s``, divided by ``V_hub``.

    Parameters
    ----------
    hws_ms : array_like
        Hub-height wind speed V (m/s), > 0.
    i_ref : float
        Reference turbulence intensity of the category (-).

    Returns
    -------
    numpy.ndarray
        Representative (90 % quantile) TI (-).
    """
    v = np.asarray(hws_ms, dtype=float)
    return i_ref * (0.75 + 5.6 / v)  # Eq. (10) of IEC 61400-1 ed. 4 divided by V


def iec_category(ti_rep: float, hws_ms: float = 15.0) -> str:
    """The least turbulent IEC 61400-1 ed. 4 category whose curve covers ``ti_rep``.

    Parameters
    ----------
    ti_rep : float
        A site's representative TI at ``hws_ms`` (-).
    hws_ms : float
        The wind speed of ``ti_rep`` (m/s; 15 m/s, where I_ref is defined).

    Returns
    -------
    str
        "C", "B", "A" or "A+": the first category (from C up) whose representative TI
        ``I_ref (0.75 + 5.6 / V)`` at ``hws_ms`` is at least ``ti_rep``; "above A+" when
        none is; "" when ``ti_rep`` is not finite.
    """
    if not np.isfinite(ti_rep):
        return ""
    for cat, i_ref in reversed(IEC_TURBULENCE_CATEGORIES.items()):
        if ti_rep <= float(iec_representative_ti(hws_ms, i_ref)):
            return cat
    return "above A+"


@dataclass(frozen=True)
class Agreement:
    """Agreement of estimated with reference TI over paired records (all TI, -).

    Attributes
    ----------
    n : int
        Pairs with both values finite.
    bias : float
        Mean of ``estimate - reference`` (-).
    bias_rel : float
        ``bias / mean(reference)`` (-; x 100 for %).
    rmse : float
        Root mean square of ``estimate - reference`` (-).
    slope, offset : float
        Ordinary least-squares line ``estimate = slope * reference + offset`` (slope -,
        offset in TI, -).
    r2 : float
        Coefficient of determination of that line (the squared Pearson r, -).
    """

    n: int
    bias: float
    bias_rel: float
    rmse: float
    slope: float
    offset: float
    r2: float


#: Field names of :class:`Agreement`, the columns of the tables below.
AGREEMENT_COLUMNS = ("n", "bias", "bias_rel", "rmse", "slope", "offset", "r2")


def agreement(estimate, reference) -> Agreement:
    """Bias, RMSE and the least-squares line of ``estimate`` against ``reference``.

    Parameters
    ----------
    estimate, reference : array_like, shape (n,)
        TI of the floating lidar (corrected or not) and of the reference (-); pairs with a
        NaN are ignored.

    Returns
    -------
    Agreement
        NaN statistics without a pair; slope, offset and R² NaN for fewer than 2 pairs or
        a constant reference.

    Raises
    ------
    ValueError
        If the shapes differ.
    """
    e = np.asarray(estimate, dtype=float)
    r = np.asarray(reference, dtype=float)
    if e.shape != r.shape:
        raise ValueError(f"agreement: shapes differ, {e.shape} vs {r.shape}")
    ok = np.isfinite(e) & np.isfinite(r)
    e, r = e[ok], r[ok]
    n = int(e.size)
    if n == 0:
        return Agreement(0, *([np.nan] * 6))
    d = e - r
    bias, rmse = float(d.mean()), float(np.sqrt(np.mean(d**2)))
    bias_rel = bias / float(r.mean()) if r.mean() != 0 else np.nan
    slope = offset = r2 = np.nan
    sxx = float(np.sum((r - r.mean()) ** 2))
    if n >= 2 and sxx > 0:
        sxy = float(np.sum((r - r.mean()) * (e - e.mean())))
        syy = float(np.sum((e - e.mean()) ** 2))
        slope = sxy / sxx
        offset = float(e.mean() - slope * r.mean())
        r2 = sxy**2 / (sxx * syy) if syy > 0 else np.nan
    return Agreement(n, bias, bias_rel, rmse, float(slope), offset, float(r2))


def agreement_by_speed_bin(
    hws_ms, estimate, reference, *, bin_width_ms: float = 1.0, min_count: int = 10
) -> pd.DataFrame:
    """Agreement and representative-TI error per wind-speed bin.

    Parameters
    ----------
    hws_ms : array_like, shape (n,)
        10-min mean wind speed of each record (m/s): its bin (centred on multiples of
        ``bin_width_ms``, :func:`flidar_uq.data.binning.speed_bin_ms`).
    estimate, reference : array_like, shape (n,)
        Estimated and reference TI (-); records with a NaN are not counted.
    bin_width_ms : float
        Bin width (m/s).
    min_count : int
        Fewest pairs for a bin's statistics; a bin with fewer keeps its count, NaN values.

    Returns
    -------
    pandas.DataFrame
        One row per bin with a pair, by speed: ``hws_bin_ms`` (m/s), the
        :data:`AGREEMENT_COLUMNS`, ``ti_rep_estimate`` and ``ti_rep_reference`` (mean +
        1.28 std of the bin's TI, -), ``ti_rep_error`` (their difference, -) and
        ``ti_rep_error_rel`` (relative to the reference's, -).
    """
    hws = np.asarray(hws_ms, dtype=float)
    e = np.asarray(estimate, dtype=float)
    r = np.asarray(reference, dtype=float)
    ok = np.isfinite(hws) & np.isfinite(e) & np.isfinite(r)
    centre = speed_bin_ms(hws[ok], bin_width_ms)
    rows = []
    for c in np.unique(centre):
        m = centre == c
        ee, rr = e[ok][m], r[ok][m]
        row = {"hws_bin_ms": float(c)} | asdict(agreement(ee, rr))
        rep_e = rep_r = np.nan
        if m.sum() < min_count:
            row |= {k: np.nan for k in AGREEMENT_COLUMNS if k != "n"}
        else:
            rep_e, rep_r = representative_ti(ee), representative_ti(rr)
        rows.append(
            row
            | {
                "ti_rep_estimate": rep_e,
                "ti_rep_reference": rep_r,
                "ti_rep_error": rep_e - rep_r,
                "ti_rep_error_rel": (rep_e - rep_r) / rep_r if rep_r > 0 else np.nan,
            }
        )
    cols = ["hws_bin_ms", *AGREEMENT_COLUMNS, "ti_rep_estimate", "ti_rep_reference"]
    return pd.DataFrame(rows, columns=[*cols, "ti_rep_error", "ti_rep_error_rel"])


def _seconds(timestamps) -> np.ndarray:
    t = pd.to_datetime(pd.Series(np.asarray(timestamps)), utc=True, errors="coerce")
    out = (t - pd.Timestamp(0, tz="UTC")).dt.total_seconds().to_numpy(dtype=float)
    return out


def holdout_mask(timestamps, *, mode: str, days: float = 7.0, end=None) -> np.ndarray:
    """Which records are held out of the fit, by time blocks.

    Parameters
    ----------
    timestamps : array_like, shape (n,)
        Record times (anything :func:`pandas.to_datetime` reads; naive times are UTC).
    mode : {"none", "alternate_weeks", "last_days"}
        ``none``: nothing held out. ``alternate_weeks``: the odd-numbered weeks (Monday to
        Monday, UTC, counted from 1970-01-05), so every other calendar week is held out
        whichever records a table holds. ``last_days``: the records after ``end - days``.
    days : float
        ``last_days``: the length of the held-out end of the campaign (day).
    end : timestamp, optional
        ``last_days``: the end of the campaign (default: the latest of ``timestamps``);
        give the whole campaign's end when ``timestamps`` is a subset of it.

    Returns
    -------
    numpy.ndarray of bool, shape (n,)
        True where the record is held out (never for a record without a time).

    Raises
    ------
    ValueError
        For an unknown ``mode`` or ``days <= 0``.
    """
    if mode not in HOLDOUT_MODES:
        raise ValueError(f"holdout_mask: mode={mode!r} must be one of {', '.join(HOLDOUT_MODES)}")
    t = _seconds(timestamps)
    if mode == "none":
        return np.zeros(t.shape, dtype=bool)
    if mode == "alternate_weeks":
        week = np.floor((t - _WEEK_ANCHOR_S) / (7 * 86400.0))
        return np.isfinite(week) & (np.mod(week, 2) == 1)
    if not days > 0:
        raise ValueError(f"holdout_mask: days={days!r} must be > 0")
    t_end = float(np.nanmax(t)) if end is None else float(_seconds([end])[0])
    return np.isfinite(t) & (t > t_end - days * 86400.0)


def withhold_reference(records: pd.DataFrame, held_out) -> pd.DataFrame:
    """A copy of ``records`` with the reference columns (``ref_*``) NaN where ``held_out``.

    The fit input of an out-of-sample validation: a record without a reference does not
    calibrate the motion model (it is corrected like a deployment record).

    Parameters
    ----------
    records : pandas.DataFrame
        Record table (columns ``ref_hws_mean_ms``, ``ref_hws_std_ms``, ... when present).
    held_out : array_like of bool, shape (len(records),)
        :func:`holdout_mask` of the records.

    Returns
    -------
    pandas.DataFrame
    """
    held = np.asarray(held_out, dtype=bool)
    if held.shape != (len(records),):
        raise ValueError(
            f"withhold_reference: held_out has shape {held.shape}, {len(records)} rows"
        )
    out = records.copy()
    for col in [c for c in out.columns if c.startswith("ref_")]:
        if pd.api.types.is_float_dtype(out[col]):
            out.loc[held, col] = np.nan
    return out


def validation_summary(
    records: pd.DataFrame, held_out, *, reference_scale=None, all_held_out: bool = False
) -> pd.DataFrame:
    """The validation headline: corrected and uncorrected TI against the reference.

    Parameters
    ----------
    records : pandas.DataFrame
        results/ti/records.csv rows: ``ti_corrected_median``, ``ti_corrected_lo``,
        ``ti_corrected_hi``, ``ti_uncorrected`` and ``ti_ref`` (-). Scored: the records
        with a corrected TI and a reference TI (the same records for both estimates).
    held_out : array_like of bool, shape (len(records),)
        Records whose reference the fit never saw (:func:`holdout_mask`).
    reference_scale : array_like, shape (len(records),), optional
        Factor from the corrected (point) TI to the reference's terms: the fixed reference
        lidar's std ratio ``g`` (``lidar_std_ratio``, -); None for a cup or a sonic.
    all_held_out : bool
        Every reference record is out of sample (the fit came from another campaign).

    Returns
    -------
    pandas.DataFrame
        One row per sample ("held out", "in sample"; a sample without a record is left
        out) and estimate ("corrected", "uncorrected"): ``sample``, ``estimate``, the
        :data:`AGREEMENT_COLUMNS` and ``coverage`` (share of the reference TI inside the
        corrected TI's credible interval, -; NaN for the uncorrected TI).
    """
    held = np.asarray(held_out, dtype=bool) | bool(all_held_out)
    g = np.ones(len(records)) if reference_scale is None else np.asarray(reference_scale, float)
    ref = records["ti_ref"].to_numpy(dtype=float)
    corr = records["ti_corrected_median"].to_numpy(dtype=float) * g
    scored = np.isfinite(ref) & np.isfinite(corr)
    rows = []
    for sample, mask in (("held out", scored & held), ("in sample", scored & ~held)):
        if not mask.any():
            continue
        for name, est in (
            ("corrected", corr),
            ("uncorrected", records["ti_uncorrected"].to_numpy(dtype=float)),
        ):
            stats = asdict(agreement(np.where(mask, est, np.nan), np.where(mask, ref, np.nan)))
            cov = np.nan
            if name == "corrected":
                lo = records["ti_corrected_lo"].to_numpy(dtype=float) * g
                hi = records["ti_corrected_hi"].to_numpy(dtype=float) * g
                cov = interval_coverage(ref, lo, hi, mask)
            rows.append({"sample": sample, "estimate": name} | stats | {"coverage": cov})
    return pd.DataFrame(rows, columns=["sample", "estimate", *AGREEMENT_COLUMNS, "coverage"])


def validation_tables(
    records: pd.DataFrame,
    held_out,
    *,
    reference_scale=None,
    all_held_out: bool = False,
    min_count: int = 10,
) -> dict[str, pd.DataFrame]:
    """Every validation table of a campaign against its reference, in one call.

    Parameters
    ----------
    records : pandas.DataFrame
        results/ti/records.csv rows (see :func:`validation_summary`; ``height_m`` in m and
        ``hws_mean_ms`` in m/s for the per-bin tables).
    held_out, reference_scale, all_held_out
        As :func:`validation_summary`.
    min_count : int
        Fewest pairs for a bin's statistics (-).

    Returns
    -------
    dict of str -> pandas.DataFrame
        ``"summary"``: :func:`validation_summary` over all heights; ``"by_height"``: the
        same per height (column ``height_m``); ``"per_bin"``: per height, estimate
        ("corrected", "uncorrected") and 1-m/s bin, :func:`agreement_by_speed_bin` of the
        validation sample (the held-out records when there are any, else the in-sample
        ones; column ``sample`` says which).
    """
    held = np.asarray(held_out, dtype=bool) | bool(all_held_out)
    g = np.ones(len(records)) if reference_scale is None else np.asarray(reference_scale, float)
    ref = records["ti_ref"].to_numpy(dtype=float)
    corr = records["ti_corrected_median"].to_numpy(dtype=float) * g
    scored = np.isfinite(ref) & np.isfinite(corr)
    sample, use = ("held out", scored & held) if (scored & held).any() else ("in sample", scored)
    heights = records["height_m"].to_numpy(dtype=float)
    by_height, per_bin = [], []
    for h in np.unique(heights[scored]):
        at = heights == h
        sub = records[at]
        tab = validation_summary(
            sub, held[at], reference_scale=None if reference_scale is None else g[at]
        )
        by_height.append(tab.assign(height_m=h))
        for name, est in (("corrected", corr), ("uncorrected", records["ti_uncorrected"])):
            e = np.where(use & at, np.asarray(est, dtype=float), np.nan)
            b = agreement_by_speed_bin(
                records["hws_mean_ms"], e, np.where(use & at, ref, np.nan), min_count=min_count
            )
            per_bin.append(b.assign(height_m=h, estimate=name, sample=sample))
    cols = ["height_m", "sample", "estimate"]
    return {
        "summary": validation_summary(
            records, held, reference_scale=reference_scale, all_held_out=all_held_out
        ),
        "by_height": _front(by_height, cols),
        "per_bin": _front(per_bin, cols),
    }


def _front(tables: list[pd.DataFrame], cols: list[str]) -> pd.DataFrame:
    if not tables:
        return pd.DataFrame(columns=cols)
    out = pd.concat(tables, ignore_index=True)
    return out[[*cols, *[c for c in out.columns if c not in cols]]]
