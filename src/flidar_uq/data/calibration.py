"""Calibration of corrected TI by regime: coverage, relative error and interval width per group.

Calibration is judged per regime (wind speed, sea state, heading), never only in
aggregate: a single campaign-wide correction can be right on average and wrong in every
sea state (docs/motion_spectrum.md). :func:`calibration_by_group` scores the
per-record corrected TI and its credible interval against a known TI (the truth of a
virtual campaign, or a reference instrument) within each group of records.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import pandas as pd
from scipy import stats

from flidar_uq.data.metrics import interval_coverage

__all__ = [
    "HEIGHT_SUMMARY_COLUMNS",
    "SPEED_GROUP_WIDTH_MS",
    "calibration_by_group",
    "height_summary",
    "speed_group_label",
    "wilson_interval",
]

#: Columns of :func:`height_summary`, one row per height of a campaign.
HEIGHT_SUMMARY_COLUMNS = (
    "height_m",
    "n_records",
    "n_corrected",
    "ti_mean",
    "ti_mean_lo",
    "ti_mean_hi",
    "ti_mean_uncorrected",
    "n_truth",
    "coverage",
    "credible_mass",
    "reference_kind",
)

#: Width of the wind-speed groups in which calibration is judged (m/s), from 3 m/s.
SPEED_GROUP_WIDTH_MS = 3.0


def wilson_interval(k: int, n: int, level: float = 0.95) -> tuple[float, float]:
    """Wilson score interval of a binomial proportion ``k / n`` (Wilson 1927).

    SciPy's ``binomtest(k, n).proportion_ci(method="wilson")``, with NaN bounds for no
    trials.

    Parameters
    ----------
    k, n : int
        Successes and trials (counts), ``0 <= k <= n``; ``n = 0`` gives NaN.
    level : float
        Confidence level in (0, 1).

    Returns
    -------
    lo, hi : float
        Interval bounds, in [0, 1].
    """
    if n == 0:
        return float("nan"), float("nan")
    ci = stats.binomtest(int(k), int(n)).proportion_ci(confidence_level=level, method="wilson")
    return float(ci.low), float(ci.high)


def speed_group_label(hws_ms, width_ms: float = SPEED_GROUP_WIDTH_MS, start_ms: float = 3.0):
    """Label of the wind-speed group ``[start + j w, start + (j + 1) w)`` of each record.

    Parameters
    ----------
    hws_ms : array_like
        Mean horizontal wind speed (m/s).
    width_ms, start_ms : float
        Group width and lower edge of the first group (m/s).

    Returns
    -------
    numpy.ndarray of str
        ``"3-6 m/s"``-style labels; ``""`` below ``start_ms`` or for NaN.
    """
    x = np.asarray(hws_ms, dtype=float)
    with np.errstate(invalid="ignore"):
        j = np.floor((x - start_ms) / width_ms)
    lo = start_ms + j * width_ms
    out = np.array([f"{a:g}-{a + width_ms:g} m/s" for a in np.nan_to_num(lo)], dtype=object)
    out[~np.isfinite(x) | (x < start_ms)] = ""
    return out


def calibration_by_group(
    records: pd.DataFrame,
    by: str | Sequence[str],
    *,
    known: str = "ti_true",
    median: str = "ti_corrected_median",
    lo: str = "ti_corrected_lo",
    hi: str = "ti_corrected_hi",
    min_count: int = 1,
) -> pd.DataFrame:
    """Coverage, mean relative error and interval width of the corrected TI per group.

    Parameters
    ----------
    records : pandas.DataFrame
        One row per record with the columns named below and the grouping column(s).
    by : str or sequence of str
        Grouping column(s) (e.g. a speed-group label, a sea-state class).
    known : str
        Column of the known TI (truth or reference), dimensionless.
    median, lo, hi : str
        Columns of the corrected TI's posterior median and credible-interval bounds.
    min_count : int
        Groups with fewer scored records are left out.

    Returns
    -------
    pandas.DataFrame
        One row per group: ``n`` (records with a finite known TI), ``n_answered`` (of
        those, with a finite interval), ``answered_share``, ``coverage`` (share of
        answered records whose interval holds the known TI) with its 95 % Wilson
        interval ``coverage_lo``, ``coverage_hi``, ``mean_rel_error`` (mean of
        median / known - 1) with its standard error ``mean_rel_error_se`` (the sample
        standard deviation over the square root of ``n_answered``, records taken as
        independent; NaN below two answered records), ``median_rel_width`` (median of
        (hi - lo) / median). The standard error says how far a group's mean error can
        stray from zero by chance alone: with a per-record scatter of 10 %, 200 records
        give 0.7 %.
    """
    by = [by] if isinstance(by, str) else list(by)
    for c in (*by, known, median, lo, hi):
        if c not in records:
            raise ValueError(f"calibration_by_group: records lack column {c!r}")
    t = records[known].to_numpy(dtype=float)
    m = records[median].to_numpy(dtype=float)
    a = records[lo].to_numpy(dtype=float)
    b = records[hi].to_numpy(dtype=float)
    scored = np.isfinite(t) & (t > 0)
    answered = scored & np.isfinite(m) & np.isfinite(a) & np.isfinite(b)
    df = records[by].copy()
    df["_scored"] = scored
    df["_answered"] = answered
    with np.errstate(invalid="ignore", divide="ignore"):
        df["_inside"] = answered & (a <= t) & (t <= b)
        df["_rel_err"] = np.where(answered, m / t - 1.0, np.nan)
        df["_rel_width"] = np.where(answered, (b - a) / m, np.nan)
    rows = []
    for key, g in df.groupby(by, sort=True, dropna=False):
        n = int(g["_scored"].sum())
        if n < min_count:
            continue
        k = int(g["_answered"].sum())
        inside = int(g["_inside"].sum())
        c_lo, c_hi = wilson_interval(inside, k)
        key = key if isinstance(key, tuple) else (key,)
        rows.append(
            {
                **dict(zip(by, key, strict=True)),
                "n": n,
                "n_answered": k,
                "answered_share": k / n if n else np.nan,
                "coverage": inside / k if k else np.nan,
                "coverage_lo": c_lo,
                "coverage_hi": c_hi,
                "mean_rel_error": float(np.nanmean(g["_rel_err"])) if k else np.nan,
                "mean_rel_error_se": (
                    float(np.nanstd(g["_rel_err"], ddof=1) / np.sqrt(k)) if k >= 2 else np.nan
                ),
                "median_rel_width": float(np.nanmedian(g["_rel_width"])) if k else np.nan,
            }
        )
    return pd.DataFrame(rows)


def height_summary(
    records: pd.DataFrame, groups: pd.DataFrame, metrics: pd.DataFrame
) -> pd.DataFrame:
    """One campaign's corrected TI per height: records, campaign means and coverage.

    Parameters
    ----------
    records : pandas.DataFrame
        The corrected records (``ti/records.csv``): ``height_m`` (m),
        ``ti_corrected_median``, ``ti_corrected_lo``, ``ti_corrected_hi`` and, in a
        virtual campaign, ``ti_true`` (all -).
    groups : pandas.DataFrame
        The group table (``ti/groups.csv``); its ``grouping == "campaign"`` rows give
        ``ti_mean``, ``ti_mean_lo``, ``ti_mean_hi`` and ``ti_mean_uncorrected`` (-) per
        height.
    metrics : pandas.DataFrame
        The run's metrics (``ti/metrics.csv``): ``reference_kind``, ``credible_mass`` (-).

    Returns
    -------
    pandas.DataFrame
        One row per height, ascending: ``height_m`` (m), ``n_records`` (records at the
        height), ``n_corrected`` (with a corrected TI), ``ti_mean``, ``ti_mean_lo``,
        ``ti_mean_hi``, ``ti_mean_uncorrected`` (NaN without a campaign row), ``n_truth``
        (corrected records with a true TI), ``coverage`` (share of their credible intervals
        holding the true TI, :func:`flidar_uq.data.metrics.interval_coverage`; NaN without
        truth), ``credible_mass`` and ``reference_kind``.
    """
    whole = groups[groups["grouping"] == "campaign"]
    rows = []
    kind = str(metrics["reference_kind"].iloc[0]) if len(metrics) else ""
    mass = float(metrics["credible_mass"].iloc[0]) if len(metrics) else np.nan
    for height in sorted(records["height_m"].dropna().unique()):
        at = records[np.isclose(records["height_m"], height)]
        corrected = np.isfinite(at["ti_corrected_median"].to_numpy(dtype=float))
        row = whole[np.isclose(whole["height_m"], height)]
        stat = {
            c: (float(row[c].iloc[0]) if len(row) else np.nan)
            for c in ("ti_mean", "ti_mean_lo", "ti_mean_hi", "ti_mean_uncorrected")
        }
        n_truth, coverage = 0, np.nan
        if "ti_true" in at:
            truth = at["ti_true"].to_numpy(dtype=float)
            n_truth = int((corrected & np.isfinite(truth)).sum())
            if n_truth:
                coverage = interval_coverage(
                    truth,
                    at["ti_corrected_lo"].to_numpy(dtype=float),
                    at["ti_corrected_hi"].to_numpy(dtype=float),
                    corrected,
                )
        rows.append(
            {
                "height_m": float(height),
                "n_records": len(at),
                "n_corrected": int(corrected.sum()),
                **stat,
                "n_truth": n_truth,
                "coverage": coverage,
                "credible_mass": mass,
                "reference_kind": kind,
            }
        )
    return pd.DataFrame(rows, columns=list(HEIGHT_SUMMARY_COLUMNS))
