"""Comparison metrics of a moving (floating) instrument against a reference.

MD and RMSE (seed 000 Eqs. 18-19), APE (seed 001 Eq. 11), Pearson r and
Deming regression (seed 001 Sec. 4.2), TI by speed bin and the representative
TI (IEC 61400-1: mean + 1.28 std), and the IEA Wind RP 18 mean-speed KPIs.

Pairs where either value is NaN are ignored; a metric without any valid pair
(or undefined, e.g. zero variance) is NaN.  Shape mismatches raise ValueError.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd

__all__ = [
    "REPRESENTATIVE_TI_FACTOR",
    "RP18_SLOPE_RANGE",
    "RP18_R2_MIN",
    "mean_deviation",
    "rmse",
    "ape_pct",
    "pearson_r",
    "DemingFit",
    "deming_regression",
    "turbulence_intensity",
    "representative_ti",
    "ti_by_speed_bin",
    "RP18KPIs",
    "rp18_mean_speed_kpis",
]

#: IEC 61400-1 representative TI: 90 % quantile of sigma for a normal distribution.
REPRESENTATIVE_TI_FACTOR = 1.28
#: IEA Wind RP 18 best-practice acceptance of the mean-speed slope through the origin.
RP18_SLOPE_RANGE = (0.98, 1.02)
#: IEA Wind RP 18 best-practice minimum coefficient of determination.
RP18_R2_MIN = 0.98


def _pair(x, y, name: str) -> tuple[np.ndarray, np.ndarray]:
    x = np.asarray(x, dtype=np.float64)
    y = np.asarray(y, dtype=np.float64)
    if x.shape != y.shape:
        raise ValueError(f"{name}: shapes differ, {x.shape} vs {y.shape}")
    ok = np.isfinite(x) & np.isfinite(y)
    return x[ok], y[ok]


def mean_deviation(moving, reference) -> float:
    """Mean deviation ``MD = sum(moving - reference) / N``, seed 000 Eq. (18).

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
    return float(np.mean(m - r)) if m.size else np.nan  # Eq. (18) of seed 000


def rmse(moving, reference) -> float:
    """Root-mean-square error ``sqrt(sum((moving - reference)^2) / N)``, seed 000 Eq. (19).

    Parameters and returns as :func:`mean_deviation`.
    """
    m, r = _pair(moving, reference, "rmse")
    return float(np.sqrt(np.mean((m - r) ** 2))) if m.size else np.nan  # Eq. (19) of seed 000


def ape_pct(reference_mean, moving_mean) -> np.ndarray:
    """Absolute percentage error ``|U_ref - U_moving| / U_ref * 100``, seed 001 Eq. (11).

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
        out = np.abs(r - m) / r * 100.0  # Eq. (11) of seed 001
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


@dataclass(frozen=True)
class DemingFit:
    """Deming regression ``y = slope * x + intercept`` (intercept in the unit of y)."""

    slope: float
    intercept: float
    n: int


def deming_regression(x, y, *, delta: float = 1.0) -> DemingFit:
    """Deming (errors-in-variables) regression of ``y`` on ``x``.

    ``slope = (s_yy - delta s_xx + sqrt((s_yy - delta s_xx)^2 + 4 delta s_xy^2)) / (2 s_xy)``
    with ``delta = var(error of y) / var(error of x)`` (1: orthogonal regression).

    Parameters
    ----------
    x, y : array_like, shape (n,)
        Reference and moving values (same unit).
    delta : float
        Ratio of the error variances, dimensionless, > 0.

    Returns
    -------
    DemingFit
        Slope (dimensionless), intercept (unit of y) and number of pairs; NaN if
        fewer than 2 pairs or ``s_xy == 0``.
    """
    if not delta > 0:
        raise ValueError(f"deming_regression: delta must be > 0, got {delta!r}")
    a, b = _pair(x, y, "deming_regression")
    if a.size < 2:
        return DemingFit(np.nan, np.nan, int(a.size))
    sxx = np.mean((a - a.mean()) ** 2)
    syy = np.mean((b - b.mean()) ** 2)
    sxy = np.mean((a - a.mean()) * (b - b.mean()))
    if sxy == 0:
        return DemingFit(np.nan, np.nan, int(a.size))
    d = syy - delta * sxx
    slope = (d + np.sqrt(d**2 + 4.0 * delta * sxy**2)) / (2.0 * sxy)
    return DemingFit(float(slope), float(b.mean() - slope * a.mean()), int(a.size))


def turbulence_intensity(hws_std_ms, hws_mean_ms) -> np.ndarray:
    """TI = std / mean of the 10-min HWS (seed 001 Eq. 10); NaN where mean <= 0."""
    s = np.asarray(hws_std_ms, dtype=np.float64)
    m = np.asarray(hws_mean_ms, dtype=np.float64)
    with np.errstate(invalid="ignore", divide="ignore"):
        ti = s / m  # Eq. (10) of seed 001
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


def ti_by_speed_bin(
    hws_mean_ms,
    hws_std_ms,
    *,
    bin_width_ms: float = 1.0,
    hws_min_ms: float = 3.0,
    hws_max_ms: float = 20.0,
) -> pd.DataFrame:
    """TI statistics per HWS bin (bins centred on multiples of ``bin_width_ms``).

    Parameters
    ----------
    hws_mean_ms, hws_std_ms : array_like, shape (n,)
        10-min mean and std of HWS, m/s.
    bin_width_ms : float
        Bin width, m/s (1, as seed 000 Fig. 8b); edges at ``(k -/+ 0.5) * width``.
    hws_min_ms, hws_max_ms : float
        HWS range considered, m/s, inclusive (3-20, seed 000 Sec. 3.5).

    Returns
    -------
    pandas.DataFrame
        ``hws_bin_ms`` (bin centre), ``count``, ``ti_mean``, ``ti_std`` (ddof=1),
        ``ti_representative`` (mean + 1.28 std), sorted by HWS.
    """
    if not bin_width_ms > 0:
        raise ValueError(f"ti_by_speed_bin: bin_width_ms must be > 0, got {bin_width_ms!r}")
    m = np.asarray(hws_mean_ms, dtype=np.float64)
    ti = turbulence_intensity(hws_std_ms, m)
    ok = np.isfinite(ti) & (m >= hws_min_ms) & (m <= hws_max_ms)
    centre = np.floor(m[ok] / bin_width_ms + 0.5) * bin_width_ms
    g = pd.Series(ti[ok]).groupby(centre)
    out = pd.DataFrame({"count": g.size(), "ti_mean": g.mean(), "ti_std": g.std(ddof=1)})
    out["ti_representative"] = out["ti_mean"] + REPRESENTATIVE_TI_FACTOR * out["ti_std"]
    out.index.name = "hws_bin_ms"
    return out.reset_index()


@dataclass(frozen=True)
class RP18KPIs:
    """IEA Wind RP 18 mean-wind-speed KPIs of a moving vs a reference instrument.

    Attributes
    ----------
    slope : float
        Slope of the least-squares line through the origin, moving = slope * reference.
    r2 : float
        Coefficient of determination of the ordinary (with intercept) regression.
    slope_ok, r2_ok : bool
        Best-practice acceptance: slope in [0.98, 1.02], R^2 > 0.98.
    n : int
        Pairs used.
    """

    slope: float
    r2: float
    slope_ok: bool
    r2_ok: bool
    n: int


def rp18_mean_speed_kpis(moving_ms, reference_ms) -> RP18KPIs:
    """IEA Wind RP 18 (floating lidar) mean-speed KPIs.

    Parameters
    ----------
    moving_ms, reference_ms : array_like, shape (n,)
        Paired 10-min mean HWS of the floating lidar and the reference, m/s.

    Returns
    -------
    RP18KPIs
        Slope through the origin ``sum(x y) / sum(x^2)`` (x = reference), R^2 of
        the ordinary least-squares line (= Pearson r^2), and the pass flags.
    """
    y, x = _pair(moving_ms, reference_ms, "rp18_mean_speed_kpis")
    if x.size < 2 or np.sum(x**2) == 0:
        return RP18KPIs(np.nan, np.nan, False, False, int(x.size))
    slope = float(np.sum(x * y) / np.sum(x**2))
    r = pearson_r(x, y)
    r2 = float(r**2) if np.isfinite(r) else np.nan
    lo, hi = RP18_SLOPE_RANGE
    return RP18KPIs(slope, r2, bool(lo <= slope <= hi), bool(r2 > RP18_R2_MIN), int(x.size))
