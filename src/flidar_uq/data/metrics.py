"""Comparison metrics of a moving (floating) instrument against a reference.

MD and RMSE (Gutiérrez-Antuñano et al., 2018, Eqs. 18-19), APE (Malekmohammadi et al., 2024, Eq. 11), Pearson r and
Deming regression (Malekmohammadi et al., 2024, Sec. 4.2), TI by speed bin and the representative
TI (IEC 61400-1: mean + 1.28 std), and the IEA Wind RP 18 mean-speed KPIs.

Pairs where either value is NaN are ignored; a metric without any valid pair
(or undefined, e.g. zero variance) is NaN.  Shape mismatches raise ValueError.
"""

from __future__ import annotations

import numpy as np
import pandas as pd

__all__ = [
    "REPRESENTATIVE_TI_FACTOR",
    "mean_deviation",
    "rmse",
    "md_rmse",
    "removable_error_removed",
    "interval_coverage",
    "reference_values",
    "reference_label",
    "REFERENCE_LABELS",
    "LIDAR_REFERENCE_LABELS",
    "score_estimates",
    "CORRECTION_ESTIMATES",
    "SCORE_COLUMNS",
    "ape_pct",
    "pearson_r",
    "turbulence_intensity",
    "representative_ti",
]

#: IEC 61400-1 representative TI: 90 % quantile of sigma for a normal distribution.
REPRESENTATIVE_TI_FACTOR = 1.28


def _pair(x, y, name: str) -> tuple[np.ndarray, np.ndarray]:
    x = np.asarray(x, dtype=np.float64)
    y = np.asarray(y, dtype=np.float64)
    if x.shape != y.shape:
        raise ValueError(f"{name}: shapes differ, {x.shape} vs {y.shape}")
    ok = np.isfinite(x) & np.isfinite(y)
    return x[ok], y[ok]


def mean_deviation(moving, reference) -> float:
    """Mean deviation ``MD = sum(moving - reference) / N``, Gutiérrez-Antuñano et al. (2018), Eq. (18).

    Parameters
    ----------
    moving : array_like, shape (n,)
        Floating-lidar values (e.g. ``hws_std_ms``, m/s, or TI).
    reference : array_like, shape (n,)
        Reference or corrected values, same unit.

    Returns
    -------
    float
        MD, unit of the inputs (NaN without valid pairs).
    """
    m, r = _pair(moving, reference, "mean_deviation")
    return (
        float(np.mean(m - r)) if m.size else np.nan
    )  # Eq. (18) of Gutiérrez-Antuñano et al. (2018)


def rmse(moving, reference) -> float:
    """Root-mean-square error ``sqrt(sum((moving - reference)^2) / N)``, Gutiérrez-Antuñano et al. (2018), Eq. (19).

    Parameters and returns as :func:`mean_deviation`.
    """
    m, r = _pair(moving, reference, "rmse")
    return (
        float(np.sqrt(np.mean((m - r) ** 2))) if m.size else np.nan
    )  # Eq. (19) of Gutiérrez-Antuñano et al. (2018)


def removable_error_removed(rmse_uncorrected, rmse_corrected, rmse_floor) -> float:
    """Share of the removable per-record error that a correction removes (-):
    ``(RMSE_uncorrected - RMSE_corrected) / (RMSE_uncorrected - RMSE_floor)``.

    The floor is the RMSE of the same lidar held still with its std ratio ``g`` to the
    point wind divided out (a virtual campaign's motionless lidar): its 10-min sampling
    scatter, which no correction from 10-min statistics can take out of one record. 1 =
    down to the floor, 0 = nothing removed, < 0 = worse than uncorrected, > 1 = below the
    floor.

    Parameters
    ----------
    rmse_uncorrected, rmse_corrected, rmse_floor : float
        Per-record RMSE (:func:`rmse`) against the same truth of the uncorrected TI, the
        corrected TI and the still lidar's TI over ``g`` (-).

    Returns
    -------
    float
        The share (-).

    Raises
    ------
    ValueError
        If ``rmse_uncorrected`` is not above ``rmse_floor``: there is nothing to remove.
    """
    u, c, f = float(rmse_uncorrected), float(rmse_corrected), float(rmse_floor)
    if not u > f:
        raise ValueError(
            f"removable_error_removed: rmse_uncorrected={u} must be above rmse_floor={f} "
            "(no removable error)"
        )
    return (u - c) / (u - f)


def md_rmse(x, reference) -> tuple[float, float, int]:
    """MD and RMSE of ``x`` against ``reference`` (Gutiérrez-Antuñano et al., 2018, Eqs. 18-19) and the pair count.

    Parameters
    ----------
    x, reference : array_like, shape (n,)
        Estimates and reference values, same unit (std in m/s, or TI, -).

    Returns
    -------
    md, rmse : float
        Unit of the inputs (NaN without finite pairs).
    n : int
        Number of pairs where both values are finite.
    """
    n = int(np.sum(np.isfinite(x) & np.isfinite(reference)))
    return mean_deviation(x, reference), rmse(x, reference), n


def interval_coverage(reference, lo, hi, used) -> float:
    """Share of ``reference`` inside ``[lo, hi]`` over the ``used`` records with a finite reference.

    Parameters
    ----------
    reference, lo, hi : array_like, shape (n,)
        Reference values and interval bounds, same unit (TI, -).
    used : array_like of bool, shape (n,)
        Records scored.

    Returns
    -------
    float
        Coverage in [0, 1], dimensionless (NaN without a scored record).
    """
    reference = np.asarray(reference, dtype=np.float64)
    ok = np.asarray(used, dtype=bool) & np.isfinite(reference)
    inside = (reference >= lo) & (reference <= hi)
    return float(inside[ok].mean())


#: Name of the reference instrument in score tables and report labels, per
#: ``reference.kind`` (a lidar reference is compared with the motionless-lidar value).
REFERENCE_LABELS = {
    "cup": "reference cup",
    "sonic": "reference sonic",
    "fixed_lidar": "reference fixed lidar",
    None: "reference instrument",
}

#: Labels of the references that are lidars (scored against the point value times g).
LIDAR_REFERENCE_LABELS = (REFERENCE_LABELS["fixed_lidar"],)


def reference_label(kind: str | None) -> str:
    """Label of the reference instrument ``kind`` (``reference.kind``) in tables and reports.

    Raises
    ------
    ValueError
        If ``kind`` is not a reference kind with ``ref_*`` columns (cup, sonic, fixed_lidar)
        or None (not named).
    """
    if kind not in REFERENCE_LABELS:
        raise ValueError(f"reference_label: kind={kind!r} must be cup, sonic, fixed_lidar or None")
    return REFERENCE_LABELS[kind]


def reference_values(
    records: pd.DataFrame, kind: str | None = None
) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """Std (m/s) and TI (-) the estimates are scored against: the truth and/or the reference.

    Parameters
    ----------
    records : pandas.DataFrame
        Records with ``true_hws_std_ms`` (and ``true_ti`` or ``true_hws_mean_ms``, m/s) for
        a virtual campaign and/or ``ref_hws_std_ms`` and ``ref_hws_mean_ms`` (m/s) for a
        reference instrument.
    kind : {"cup", "sonic", "fixed_lidar"} or None
        The reference instrument (``reference.kind``): names it (:func:`reference_label`);
        "none" counts as None.

    Returns
    -------
    dict of str -> (numpy.ndarray, numpy.ndarray)
        ``"truth"`` and/or the reference's label (``"reference cup"``, ``"reference
        sonic"``, ``"reference fixed lidar"``; ``"reference instrument"`` when not named)
        -> (std in m/s, TI, -), per record.
    """
    out = {}
    if "true_hws_std_ms" in records:
        std = records["true_hws_std_ms"].to_numpy(dtype=float)
        ti = (
            records["true_ti"].to_numpy(dtype=float)
            if "true_ti" in records
            else std / records["true_hws_mean_ms"].to_numpy(dtype=float)
        )
        out["truth"] = (std, ti)
    if "ref_hws_std_ms" in records:
        std = records["ref_hws_std_ms"].to_numpy(dtype=float)
        out[reference_label(None if kind == "none" else kind)] = (
            std,
            std / records["ref_hws_mean_ms"].to_numpy(dtype=float),
        )
    return out


#: Estimates scored by :func:`score_estimates`: method -> (std column, m/s; TI column, -).
CORRECTION_ESTIMATES = {
    "uncorrected": ("hws_std_ms", "ti_uncorrected"),
    "U": ("std_corrected_u_ms", "ti_corrected_u"),
    "C": ("std_corrected_c_ms", "ti_corrected_c"),
    "PC": ("std_corrected_pc_ms", "ti_corrected_pc"),
    "Bayesian": ("std_corrected_median_ms", "ti_corrected_median"),
}

#: Columns of the score table of :func:`score_estimates`.
SCORE_COLUMNS = [
    "reference", "method", "n", "md_std_ms", "rmse_std_ms", "md_ti", "rmse_ti",
    "mean_rel_ti_error", "mean_abs_rel_ti_error", "coverage",
]  # fmt: skip


def score_estimates(
    records: pd.DataFrame, references: dict[str, tuple[np.ndarray, np.ndarray]]
) -> pd.DataFrame:
    """MD / RMSE of std and TI, relative TI error and interval coverage per method (Tables 2-3).

    Every method is scored over the same records: those with a Bayesian corrected value
    (finite ``ti_corrected_median``). The Bayesian estimate is compared in the reference's
    own terms: its point value against the truth, a cup or a sonic, times
    ``lidar_std_ratio`` (the motionless-lidar value) against a fixed lidar or an unnamed
    reference instrument. Gutiérrez-Antuñano et al.'s (2018) U / C / PC laws estimate the reference instrument's
    std, as published.

    Parameters
    ----------
    records : pandas.DataFrame
        results/ti/records.csv columns: the std (m/s) and TI (-) columns of
        :data:`CORRECTION_ESTIMATES`, ``ti_corrected_lo`` / ``ti_corrected_hi`` (-) and
        ``lidar_std_ratio`` (-).
    references : dict
        :func:`reference_values` of the records: name -> (std in m/s, TI, -).

    Returns
    -------
    pandas.DataFrame
        One row per (reference, method), columns :data:`SCORE_COLUMNS`: ``n`` (records),
        ``md_std_ms`` / ``rmse_std_ms`` (m/s), ``md_ti`` / ``rmse_ti`` (-),
        ``mean_rel_ti_error`` / ``mean_abs_rel_ti_error`` (mean of ``TI / TI_ref - 1``, -),
        ``coverage`` (share of the reference TI inside the credible interval, Bayesian only).
    """
    used = np.isfinite(records["ti_corrected_median"].to_numpy())  # same records for every method
    g_all = records["lidar_std_ratio"].to_numpy(dtype=float)
    rows = []
    for ref_name, (ref_std, ref_ti) in references.items():
        lo_hi = (records["ti_corrected_lo"].to_numpy(), records["ti_corrected_hi"].to_numpy())
        for name, (scol, tcol) in CORRECTION_ESTIMATES.items():
            lidar_ref = ref_name in (*LIDAR_REFERENCE_LABELS, REFERENCE_LABELS[None])
            scale = g_all if (name == "Bayesian" and lidar_ref) else 1.0
            std = np.where(used, records[scol].to_numpy(dtype=float) * scale, np.nan)
            ti = np.where(used, records[tcol].to_numpy(dtype=float) * scale, np.nan)
            md_s, rmse_s, n_s = md_rmse(std, ref_std)
            md_t, rmse_t, _ = md_rmse(ti, ref_ti)
            with np.errstate(all="ignore"):
                rel = ti / ref_ti - 1.0
                mean_rel = float(np.nanmean(rel)) if n_s else float("nan")
                mean_abs_rel = float(np.nanmean(np.abs(rel))) if n_s else float("nan")
            coverage = float("nan")
            if name == "Bayesian" and n_s:
                coverage = interval_coverage(ref_ti, lo_hi[0] * scale, lo_hi[1] * scale, used)
            rows.append(
                {
                    "reference": ref_name,
                    "method": name,
                    "n": n_s,
                    "md_std_ms": md_s,
                    "rmse_std_ms": rmse_s,
                    "md_ti": md_t,
                    "rmse_ti": rmse_t,
                    "mean_rel_ti_error": mean_rel,
                    "mean_abs_rel_ti_error": mean_abs_rel,
                    "coverage": coverage,
                }
            )
    return pd.DataFrame(rows, columns=SCORE_COLUMNS)


def ape_pct(reference_mean, moving_mean) -> np.ndarray:
    """Absolute percentage error ``|U_ref - U_moving| / U_ref * 100``, Malekmohammadi et al. (2024), Eq. (11).

    Parameters
    ----------
    reference_mean, moving_mean : array_like
        Mean wind speeds, m/s (broadcast).

    Returns
    -------
    numpy.ndarray
        APE, % (NaN where ``reference_mean`` is 0 or NaN).
    """
    r = np.asarray(reference_mean, dtype=np.float64)
    m = np.asarray(moving_mean, dtype=np.float64)
    with np.errstate(invalid="ignore", divide="ignore"):
        out = np.abs(r - m) / r * 100.0  # Eq. (11) of Malekmohammadi et al. (2024)
    return np.where(r != 0, out, np.nan)


def pearson_r(x, y) -> float:
    """Pearson correlation coefficient of paired samples.

    Parameters
    ----------
    x, y : array_like, shape (n,)
        Paired samples.

    Returns
    -------
    float
        r in [-1, 1] (NaN for fewer than 2 pairs or zero variance).
    """
    a, b = _pair(x, y, "pearson_r")
    if a.size < 2:
        return np.nan
    da, db = a - a.mean(), b - b.mean()
    den = np.sqrt(np.sum(da**2) * np.sum(db**2))
    return float(np.clip(np.sum(da * db) / den, -1.0, 1.0)) if den > 0 else np.nan


def turbulence_intensity(hws_std_ms, hws_mean_ms) -> np.ndarray:
    """TI = std / mean of the 10-min HWS (Malekmohammadi et al., 2024, Eq. 10); NaN where mean <= 0."""
    s = np.asarray(hws_std_ms, dtype=np.float64)
    m = np.asarray(hws_mean_ms, dtype=np.float64)
    with np.errstate(invalid="ignore", divide="ignore"):
        ti = s / m  # Eq. (10) of Malekmohammadi et al. (2024)
    return np.where(m > 0, ti, np.nan)


def representative_ti(ti) -> float:
    """Representative TI ``mean(TI) + 1.28 std(TI)`` (IEC 61400-1; sample std, ddof=1).

    Parameters
    ----------
    ti : array_like, shape (n,)
        TI values of one speed bin, dimensionless (NaN ignored).

    Returns
    -------
    float
        Representative TI (NaN for fewer than 2 finite values).
    """
    t = np.asarray(ti, dtype=np.float64)
    t = t[np.isfinite(t)]
    if t.size < 2:
        return np.nan
    return float(t.mean() + REPRESENTATIVE_TI_FACTOR * t.std(ddof=1))
