"""sigma_Z of each record from its own measured motion (the per-record motion model).

Seed 000 computes sigma_Z for harmonic roll and pitch at one period; a real sea is
broadband and directional, and only the tilt along the wind matters to first order
(design.md, "What real seas add"). With the record's tilt variance along the wind and its
mean period (record-table columns derived by :mod:`flidar_uq.data.imu` from the raw IMU
series), a single-axis tilt of amplitude ``A = sqrt(2) std_along`` along the wind gives
the same sigma_Z as seed 000's roll-and-pitch case at amplitude ``A``; evaluated at the
spectral mean period it reproduces the realised sigma_Z of a broadband sea within a few
percent, against 0.6-0.95 for the harmonic value at the spectral-peak period.

When a record has only the core IMU columns (roll and pitch amplitude and period), the
seed's harmonic description is used (``motion_description = "roll_pitch"``); the global
fit's motion-error term then widens the intervals accordingly.
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from flidar_uq.physics.six_dof_sigma_z import translation_unit_sq
from flidar_uq.physics.surrogate import default_surrogate

__all__ = ["ALONG_WIND_COLUMNS", "MOTION_DESCRIPTIONS", "record_motion"]

#: Record-table columns of the along-wind description (tilt std along the wind, deg; its
#: spectral mean period m0/m1, s; the zero-crossing period stands in when the mean period
#: is absent). The mean period is used because the realised sigma_Z of broadband seas lies
#: between the values at the mean and the zero-crossing periods, nearer the former
#: (docs/motion_spectrum.md, docs/inference.md).
ALONG_WIND_COLUMNS = ("tilt_along_wind_std_deg", "tilt_period_mean_s")

#: Values of ``motion_description``: which description gave a record's sigma_Z.
MOTION_DESCRIPTIONS = ("along_wind", "roll_pitch", "none")


def _col(records: pd.DataFrame, name: str) -> np.ndarray:
    if name in records:
        return records[name].to_numpy(dtype=float)
    return np.full(len(records), np.nan)


def _geometric_mean(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Geometric mean of two positive columns; one missing falls back to the other."""
    x = np.stack([np.log(np.where(a > 0, a, np.nan)), np.log(np.where(b > 0, b, np.nan))])
    n = np.sum(np.isfinite(x), axis=0)
    with np.errstate(invalid="ignore"):
        s = np.nansum(np.where(np.isfinite(x), x, 0.0), axis=0) / np.maximum(n, 1)
    return np.where(n > 0, np.exp(s), np.nan)


def record_motion(
    records: pd.DataFrame, *, surrogate=None, scan_period_s: float = 1.0
) -> pd.DataFrame:
    """Per-record motion amplitude, period, rotational sigma_Z and translation unit.

    Parameters
    ----------
    records : pandas.DataFrame
        Records with ``hws_mean_ms`` and either the along-wind columns
        (:data:`ALONG_WIND_COLUMNS`) or the core IMU columns ``roll_amplitude_deg``,
        ``pitch_amplitude_deg``, ``roll_period_s``, ``pitch_period_s``.
    surrogate : SigmaZSurrogate, optional
        sigma_Z surrogate of the lidar (default: the ZephIR 300's).
    scan_period_s : float
        VAD scan duration (s), for the head-translation term.

    Returns
    -------
    pandas.DataFrame
        Index of ``records``; ``motion_amplitude_deg`` (single-axis tilt amplitude along
        the wind, deg), ``motion_period_s`` (s), ``sigma_z_rot_ms`` (rotational sigma_Z at
        unit motion scale, m/s), ``translation_unit_sq`` ((m/s)^2 per m^2 of lever arm,
        :func:`flidar_uq.inference.translation_unit_sq`), ``motion_description`` (one of
        :data:`MOTION_DESCRIPTIONS`; ``"none"`` where neither description is complete:
        sigma_Z is NaN there).
    """
    surrogate = default_surrogate(surrogate)
    std_along = _col(records, ALONG_WIND_COLUMNS[0])
    per_along = _col(records, ALONG_WIND_COLUMNS[1])
    per_along = np.where(
        np.isfinite(per_along), per_along, _col(records, "tilt_period_zero_crossing_s")
    )
    amp_rp = _geometric_mean(
        _col(records, "roll_amplitude_deg"), _col(records, "pitch_amplitude_deg")
    )
    per_rp = _geometric_mean(_col(records, "roll_period_s"), _col(records, "pitch_period_s"))
    along = np.isfinite(std_along) & (std_along >= 0) & np.isfinite(per_along) & (per_along > 0)
    rp = ~along & np.isfinite(amp_rp) & np.isfinite(per_rp)
    amp = np.where(along, np.sqrt(2.0) * std_along, np.where(rp, amp_rp, np.nan))
    per = np.where(along, per_along, np.where(rp, per_rp, np.nan))
    hws = _col(records, "hws_mean_ms")
    ok = np.isfinite(amp) & np.isfinite(per) & np.isfinite(hws)
    sz = np.full(len(records), np.nan)
    u2 = np.full(len(records), np.nan)
    if np.any(ok):
        sz[ok] = surrogate.sigma_z_ms(hws[ok], amp[ok], per[ok])
        u2[ok] = translation_unit_sq(amp[ok], per[ok], scan_period_s)
    kind = np.where(along & ok, "along_wind", np.where(rp & ok, "roll_pitch", "none"))
    return pd.DataFrame(
        {
            "motion_amplitude_deg": amp,
            "motion_period_s": per,
            "sigma_z_rot_ms": sz,
            "translation_unit_sq": u2,
            "motion_description": kind,
        },
        index=records.index,
    )
