"""sigma_Z of each record from its own measured motion (the per-record motion model).

Gutiérrez-Antuñano et al. (2018) computes sigma_Z for harmonic roll and pitch at one period; a real sea is
broadband and directional, and only the tilt along the wind matters to first order
(docs/motion_spectrum.md). With the record's tilt variance along the wind and its
mean period (record-table columns derived by :mod:`flidar_uq.data.imu` from the raw IMU
series), a single-axis tilt of amplitude ``A = sqrt(2) std_along`` along the wind gives
the same sigma_Z as Gutiérrez-Antuñano et al.'s (2018) roll-and-pitch case at amplitude ``A``; evaluated at the
spectral mean period it reproduces the realised sigma_Z of a broadband sea within a few
percent, against 0.6-0.95 for the harmonic value at the spectral-peak period.

When a record has only the core IMU columns (roll and pitch amplitude and period), the
seed's harmonic description is used (``motion_description = "roll_pitch"``); the global
fit's motion-error term then widens the intervals accordingly.
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from flidar_uq.data.imu import tilt_bands_from_records
from flidar_uq.physics.hull import G_MS2
from flidar_uq.physics.six_dof_sigma_z import six_dof_band_terms, translation_unit_sq
from flidar_uq.physics.surrogate import default_surrogate

__all__ = [
    "ALONG_WIND_COLUMNS",
    "MEASURED_TRANSLATION_COLUMNS",
    "MOTION_DESCRIPTIONS",
    "TRANSLATION_DESCRIPTIONS",
    "describe_motion",
    "hull_sigma_z_ms",
    "measured_response",
    "per_record_motion",
    "six_dof_terms",
]

#: Record-table columns of the along-wind description (tilt std along the wind, deg; its
#: spectral mean period m0/m1, s; the zero-crossing period stands in when the mean period
#: is absent). The mean period is used because the realised sigma_Z of broadband seas lies
#: between the values at the mean and the zero-crossing periods, nearer the former
#: (docs/motion_spectrum.md, docs/inference.md).
ALONG_WIND_COLUMNS = ("tilt_along_wind_std_deg", "tilt_period_mean_s")

#: Values of ``motion_description``: which description gave a record's sigma_Z, best first:
#: ``"tilt_bands"`` the record's tilt spectrum by period bands along and across the wind
#: (``tilt_band{b}_*`` columns: the six-degree-of-freedom band sum,
#: :func:`flidar_uq.physics.six_dof_sigma_z.six_dof_band_terms`), ``"along_wind"`` its
#: moments (std along the wind at the mean period), ``"roll_pitch"`` the harmonic roll and
#: pitch of Gutiérrez-Antuñano et al. (2018).
MOTION_DESCRIPTIONS = ("tilt_bands", "along_wind", "roll_pitch", "none")

#: Values of ``translation_description``: where a record's hull translation comes from.
#: ``"measured"``: the record's MRU or GNSS translation stds
#: (:data:`MEASURED_TRANSLATION_COLUMNS`, :func:`measured_response`) with the wave
#: follower's phases, the hull response known; ``"tilt_spectrum"``: the translation a wave follower has with the record's tilt spectrum
#: (:data:`FOLLOWER_COLUMNS`), scaled by the fitted hull response; ``"none"``: the buoy is
#: taken to rotate about a fixed centre (the rotation-only model).
TRANSLATION_DESCRIPTIONS = ("measured", "tilt_spectrum", "none")


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


def _tilt_description(records: pd.DataFrame):
    """Tilt amplitude (deg) and period (s) of each record, and the masks of the along-wind
    and the roll/pitch descriptions (the former wins where both are complete)."""
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
    return amp, per, along, rp


def _band_terms(records: pd.DataFrame, surrogate, scan_period_s: float):
    """Mask of the records described by tilt bands (all band values finite, a finite mean
    speed, every band inside the surrogate's range) and their band-sum terms
    (:func:`flidar_uq.physics.six_dof_sigma_z.six_dof_band_terms`, the wave follower's
    translation scaled by the hull response)."""
    bands = tilt_bands_from_records(records)
    if bands is None:
        return np.zeros(len(records), dtype=bool), None
    hws = _col(records, "hws_mean_ms")
    use = bands["complete"] & np.isfinite(hws)
    terms = six_dof_band_terms(
        hws[use],
        bands["amplitude_deg"][use],
        bands["period_s"][use],
        band_cos_psi=bands["cos_psi"][use],
        band_cos_sq_psi=bands["cos_sq_psi"][use],
        surrogate=surrogate,
        scan_period_s=scan_period_s,
    )
    finite = np.all(np.stack([np.isfinite(v) for v in terms.values()]), axis=0)
    use[use] = finite
    return use, {k: v[finite] for k, v in terms.items()}


def per_record_motion(
    records: pd.DataFrame, *, surrogate=None, scan_period_s: float = 1.0
) -> pd.DataFrame:
    """Per-record motion amplitude, period, rotational sigma_Z and translation unit.

    Parameters
    ----------
    records : pandas.DataFrame
        Records with ``hws_mean_ms`` and, best first, the tilt-band columns
        (``tilt_band{b}_*``, :func:`flidar_uq.data.imu.tilt_bands_from_records`: the
        six-degree-of-freedom band sum of :mod:`flidar_uq.physics.six_dof_sigma_z`), the
        along-wind columns (:data:`ALONG_WIND_COLUMNS`) or the core IMU columns
        ``roll_amplitude_deg``, ``pitch_amplitude_deg``, ``roll_period_s``,
        ``pitch_period_s``.
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
    amp, per, along, rp = _tilt_description(records)
    hws = _col(records, "hws_mean_ms")
    ok = np.isfinite(amp) & np.isfinite(per) & np.isfinite(hws)
    sz = np.full(len(records), np.nan)
    u2 = np.full(len(records), np.nan)
    if np.any(ok):
        sz[ok] = surrogate.sigma_z_ms(hws[ok], amp[ok], per[ok])
        u2[ok] = translation_unit_sq(amp[ok], per[ok], scan_period_s)
    kind = np.where(along & ok, "along_wind", np.where(rp & ok, "roll_pitch", "none"))
    banded, terms = _band_terms(records, surrogate, scan_period_s)
    if banded.any():
        sz[banded] = terms["sigma_z_rot_ms"]
        u2[banded] = terms["translation_unit_sq"]
        kind = np.where(banded, "tilt_bands", kind)
        # the bands' along-wind amplitude and mean period where the moments are absent
        bands = tilt_bands_from_records(records)
        va = 0.5 * bands["amplitude_deg"] ** 2 * bands["cos_sq_psi"]
        with np.errstate(invalid="ignore", divide="ignore"):
            per_b = np.sum(va, axis=-1) / np.sum(va / bands["period_s"], axis=-1)
        fill = banded & ~ok
        amp = np.where(fill, np.sqrt(2.0 * np.sum(va, axis=-1)), amp)
        per = np.where(fill, per_b, per)
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


#: Record columns of a wave follower's translation implied by the tilt spectrum
#: (:func:`flidar_uq.data.imu.follower_translation_columns`).
FOLLOWER_COLUMNS = (
    "follower_heave_velocity_std_ms",
    "follower_heave_period_s",
    "follower_velocity_along_wind_std_ms",
    "follower_heave_tilt_correlation",
)


#: Record columns of a measured translation (MRU or GNSS, m/s and m): the velocity stds,
#: else the displacement stds (turned into velocities at the wave follower's heave mean
#: period). Heave positive up, surge and sway along the body x and y axes.
MEASURED_TRANSLATION_COLUMNS = (
    "heave_velocity_std_ms",
    "surge_velocity_std_ms",
    "sway_velocity_std_ms",
    "heave_std_m",
    "surge_std_m",
    "sway_std_m",
)


def measured_response(records: pd.DataFrame) -> tuple[np.ndarray, np.ndarray]:
    """The hull's measured vertical and horizontal responses relative to a wave follower.

    A wave follower with the record's tilt spectrum heaves with the velocity std
    ``sigma_h`` (``follower_heave_velocity_std_ms``) and, deep-water orbital motion being
    circular, moves horizontally with the same total std. A measured translation gives the
    ratios ``R_z = sigma_heave / sigma_h`` and ``R_x = sqrt(sigma_surge^2 + sigma_sway^2) /
    sigma_h`` (velocity stds; a displacement std times ``2 pi / T_h``, ``T_h`` the
    follower's heave mean period). With only the heave, or only the horizontal motion,
    measured the other ratio is taken equal to it. The phases stay the wave follower's (a
    hull's response in phase with the waves, right well above its natural periods).

    Parameters
    ----------
    records : pandas.DataFrame
        Records with :data:`FOLLOWER_COLUMNS` and any of
        :data:`MEASURED_TRANSLATION_COLUMNS`.

    Returns
    -------
    (numpy.ndarray, numpy.ndarray)
        ``R_z``, ``R_x`` (-), NaN where the translation is not measured.
    """
    sig_h = _col(records, FOLLOWER_COLUMNS[0])
    omega_h = 2.0 * np.pi / np.clip(_col(records, FOLLOWER_COLUMNS[1]), 1.0, 20.0)

    def velocity(v_col, x_col):
        v = _col(records, v_col)
        return np.where(np.isfinite(v), v, _col(records, x_col) * omega_h)

    heave = velocity("heave_velocity_std_ms", "heave_std_m")
    surge = velocity("surge_velocity_std_ms", "surge_std_m")
    sway = velocity("sway_velocity_std_ms", "sway_std_m")
    horiz = np.sqrt(surge**2 + sway**2)
    with np.errstate(invalid="ignore", divide="ignore"):
        r_z = np.where(sig_h > 0, heave / sig_h, np.nan)
        r_x = np.where(sig_h > 0, horiz / sig_h, np.nan)
    r_z, r_x = np.where(np.isfinite(r_z), r_z, r_x), np.where(np.isfinite(r_x), r_x, r_z)
    return r_z, r_x


def six_dof_terms(
    records: pd.DataFrame, motion: pd.DataFrame, *, surrogate=None, scan_period_s: float = 1.0
) -> pd.DataFrame:
    """Per-record terms of the hull's translation in sigma_Z.

    Where the record's tilt bands are given (``tilt_band{b}_*``), the terms of the
    six-degree-of-freedom band sum itself
    (:func:`flidar_uq.physics.six_dof_sigma_z.six_dof_band_terms`). Else the band sum with
    the record's moments instead of its bands: the tilt's vertical-wind leak ``sZ_rot``
    (:func:`per_record_motion`), the heave's ``hl = Lambda(A, T_h) sqrt(2) sigma_h`` with
    ``Lambda = sZ(1 m/s, A, T) / A`` of the surrogate at the total tilt amplitude and the
    heave's mean period, correlated by ``rho_h``; the orbital velocity along the wind
    ``sigma_u`` against the lever arm's ``L dphi/dt`` (covariance ``-g sigma_along^2`` per
    metre, exact for linear waves). For a hull response ``h`` (0 rotation only, 1 wave
    follower; :func:`hull_sigma_z_ms`):

    ``sZ^2 = k^2 (sZ_rot^2 - 2 h heave_cross_sq + h^2 heave_leak_sq)
    + L^2 u^2 - 2 L h orbital_cross_sq + h^2 orbital_sq``.

    Where the record's translation is measured (:func:`measured_response`), the heave
    terms are scaled by ``R_z`` (the cross term) and ``R_z^2``, the orbital ones by ``R_x``
    and ``R_x^2``, and ``translation_measured`` is 1: the hull response is known there,
    ``h = 1`` in :func:`hull_sigma_z_ms` and the likelihood.

    Parameters
    ----------
    records : pandas.DataFrame
        Records with the along-wind and :data:`FOLLOWER_COLUMNS` columns.
    motion : pandas.DataFrame
        :func:`per_record_motion` of the same records.
    surrogate, scan_period_s
        As :func:`per_record_motion`.

    Returns
    -------
    pandas.DataFrame
        ``heave_cross_sq``, ``heave_leak_sq`` ((m/s)^2), ``orbital_cross_sq`` ((m/s)^2 per
        m of lever arm), ``orbital_sq`` ((m/s)^2); 0 where the follower columns are absent
        (the rotation-only model); ``translation_measured`` (1 or 0, -).
    """
    surrogate = default_surrogate(surrogate)
    sig_h, per_h, sig_u, rho_h = (_col(records, c) for c in FOLLOWER_COLUMNS)
    follower = _follower_complete(records)
    std_a = _col(records, ALONG_WIND_COLUMNS[0])
    std_c = _col(records, "tilt_across_wind_std_deg")
    per_m = motion["motion_period_s"].to_numpy(dtype=float)
    sz_rot = motion["sigma_z_rot_ms"].to_numpy(dtype=float)
    amp_tot = np.sqrt(2.0 * (std_a**2 + np.nan_to_num(std_c) ** 2))
    ok = follower & np.isfinite(amp_tot) & (amp_tot > 0) & np.isfinite(sz_rot) & np.isfinite(per_m)
    out = {k: np.zeros(len(records)) for k in ("heave_cross_sq", "heave_leak_sq")}
    out |= {k: np.zeros(len(records)) for k in ("orbital_cross_sq", "orbital_sq")}
    if np.any(ok):
        a, th = amp_tot[ok], np.clip(per_h[ok], 1.0, 20.0)
        lam = surrogate.sigma_z_ms(1.0, a, th) / np.deg2rad(a)  # per m/s of vertical wind, per rad
        hl = lam * np.sqrt(2.0) * sig_h[ok]
        out["heave_cross_sq"][ok] = rho_h[ok] * sz_rot[ok] * hl
        out["heave_leak_sq"][ok] = hl**2
        sinc_m = np.sinc(scan_period_s / per_m[ok])
        sinc_h = np.sinc(scan_period_s / th)
        out["orbital_cross_sq"][ok] = G_MS2 * np.deg2rad(std_a[ok]) ** 2 * sinc_m**2
        out["orbital_sq"][ok] = (sig_u[ok] * sinc_h) ** 2
    banded, bt = _band_terms(records, surrogate, scan_period_s)
    if banded.any():  # the band sum where the record's tilt bands are given
        ok = ok | banded
        for key in ("heave_cross_sq", "heave_leak_sq", "orbital_cross_sq", "orbital_sq"):
            out[key][banded] = bt[key]
    r_z, r_x = measured_response(records)
    meas = ok & np.isfinite(r_z) & np.isfinite(r_x)
    out["heave_cross_sq"][meas] *= r_z[meas]
    out["heave_leak_sq"][meas] *= r_z[meas] ** 2
    out["orbital_cross_sq"][meas] *= r_x[meas]
    out["orbital_sq"][meas] *= r_x[meas] ** 2
    out["translation_measured"] = meas.astype(float)
    return pd.DataFrame(out, index=records.index)


def _follower_complete(records: pd.DataFrame) -> np.ndarray:
    """Records whose :data:`FOLLOWER_COLUMNS` are all finite."""
    ok = np.ones(len(records), dtype=bool)
    for c in FOLLOWER_COLUMNS:
        ok &= np.isfinite(_col(records, c))
    return ok


def describe_motion(records: pd.DataFrame, *, hull_model: str | None = None) -> pd.DataFrame:
    """Which motion description each record gets in the record model, without evaluating it.

    Parameters
    ----------
    records : pandas.DataFrame
        Record table (the columns :func:`per_record_motion` and :func:`six_dof_terms` read).
    hull_model : str, optional
        The fit's kept hull model (``GlobalFit.info["hull_model"]``): ``"rotation_only"``
        describes no record's translation, whatever its columns.

    Returns
    -------
    pandas.DataFrame
        Index of ``records``; ``motion_description`` (the tilt's, one of
        :data:`MOTION_DESCRIPTIONS`, as :func:`per_record_motion` gives it) and
        ``translation_description`` (one of :data:`TRANSLATION_DESCRIPTIONS`;
        ``"tilt_spectrum"`` only where the tilt is described along the wind, by bands or
        moments).
    """
    amp, per, along, rp = _tilt_description(records)
    ok = np.isfinite(amp) & np.isfinite(per) & np.isfinite(_col(records, "hws_mean_ms"))
    tilt = np.where(along & ok, "along_wind", np.where(rp & ok, "roll_pitch", "none"))
    follower = along & ok & _follower_complete(records)
    bands = tilt_bands_from_records(records)
    if bands is not None:
        banded = bands["complete"] & np.isfinite(_col(records, "hws_mean_ms"))
        tilt = np.where(banded, "tilt_bands", tilt)
        follower = follower | banded
    r_z, r_x = measured_response(records)
    measured = follower & np.isfinite(r_z) & np.isfinite(r_x)
    trans = np.where(measured, "measured", np.where(follower, "tilt_spectrum", "none"))
    if hull_model == "rotation_only":
        trans = np.full(len(records), "none")
    return pd.DataFrame(
        {"motion_description": tilt, "translation_description": trans}, index=records.index
    )


def hull_sigma_z_ms(motion, terms, *, lever_arm_m, hull_response, motion_scale=1.0):
    """sigma_Z (m/s) of records for a lever arm ``L`` (m), a hull response ``h`` (-: 0
    rotates about a fixed centre, 1 follows the waves) and a motion scale ``k`` (-), from
    :func:`per_record_motion` and :func:`six_dof_terms` (broadcasting over draws of ``L, h, k``
    given as arrays of shape (n_draws, 1))."""
    sz = np.asarray(motion["sigma_z_rot_ms"], float)
    u2 = np.asarray(motion["translation_unit_sq"], float)
    h = np.asarray(hull_response, float)
    if "translation_measured" in terms:  # measured translation: the response is known
        meas = np.asarray(terms["translation_measured"], float)
        h = h + meas * (1.0 - h)
    lev = np.asarray(lever_arm_m, float)
    leak = (
        sz**2
        - 2.0 * h * np.asarray(terms["heave_cross_sq"])
        + h**2 * np.asarray(terms["heave_leak_sq"])
    )
    trans = lev**2 * u2 - 2.0 * lev * h * np.asarray(terms["orbital_cross_sq"])
    trans = trans + h**2 * np.asarray(terms["orbital_sq"])
    return np.sqrt(np.maximum(np.asarray(motion_scale, float) ** 2 * leak + trans, 0.0))
