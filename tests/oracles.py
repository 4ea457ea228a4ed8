"""Reference implementations the tests check the product against.

Each is a direct, slower or more literal form of what the product computes another way:
the published frame conversions and formulas of the LOS-level corrections
(Malekmohammadi et al., 2024; Nassif et al., 2020), the wind-frame tilt in one call, the
per-record sigma_Z by the best motion description, the DBS sigma_Z from the record's
harmonics and from the Gram matrix's quadratic form, and the hull's translation terms of
the record model in one call.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
import pandas as pd

from flidar_uq.inference.record_motion import _band_terms, _translation_terms, default_surrogate
from flidar_uq.physics.dbs_sigma_z import (
    _heading_grid,
    dbs_harmonic_sigma_z_ms,
    direction_moments,
    rotate_moments,
    wind_to_body_deg,
)
from flidar_uq.physics.lidar import LidarGeometry
from flidar_uq.physics.motion import rotation_matrix
from flidar_uq.physics.motion_spectrum import (
    TiltBandSpectrum,
    _surrogate,
    harmonic_sigma_z_ms,
    moments_sigma_z_ms,
    project_tilt_on_wind_deg,
    spectral_sigma_z_ms,
    tilt_vector_en,
)

# Malekmohammadi et al. (2024) frame (x south, y west, z down) -> ENU: columns are the paper's axes in ENU.
_C_SWD_TO_ENU = np.array([[0.0, -1.0, 0.0], [-1.0, 0.0, 0.0], [0.0, 0.0, -1.0]])


def rotation_from_swd_frame(roll_rad, pitch_rad, yaw_rad) -> np.ndarray:
    """ENU body-to-earth rotation from IMU angles given in Malekmohammadi et al.'s (2024) frame.

    Malekmohammadi et al. (2024) (Sec. 3, Eq. 6) uses x south, y west, z down, and the passive matrices
    ``Rx(beta)``, ``Ry(phi)``, ``Rz(psi)`` of its Eq. (6) (earth -> body, composed
    ``Rx Ry Rz``: yaw first). The active body->earth rotation in that frame is the
    transpose; it is carried to ENU by ``C R C^T`` with ``C`` the axis map
    (south -> -y, west -> -x, down -> -z). A pure Malekmohammadi et al. (2024) roll ``beta`` (about south)
    is therefore an ENU pitch of ``-beta``.

    Parameters
    ----------
    roll_rad, pitch_rad, yaw_rad : array_like
        Malekmohammadi et al. (2024) roll beta (about south), pitch phi (about west), yaw psi (about down),
        rad, broadcastable to shape ``(...)``.

    Returns
    -------
    numpy.ndarray
        ENU rotation matrices, shape ``(..., 3, 3)``.
    """
    b, p, y = np.broadcast_arrays(
        *(np.asarray(x, dtype=float) for x in (roll_rad, pitch_rad, yaw_rad))
    )
    zero = np.zeros_like(b)
    # Eq. (6) of Malekmohammadi et al. (2024) (passive) equals the active rotation by the opposite angle.
    rx = rotation_matrix(-b, zero, zero)
    ry = rotation_matrix(zero, -p, zero)
    rz = rotation_matrix(zero, zero, -y)
    r_earth_to_body = rx @ ry @ rz
    r_body_to_earth = np.swapaxes(r_earth_to_body, -1, -2)
    return _C_SWD_TO_ENU @ r_body_to_earth @ _C_SWD_TO_ENU.T


def velocity_from_swd_frame(velocity_ms) -> np.ndarray:
    """Translational velocity from Malekmohammadi et al.'s (2024) frame (x south, y west, z down) to ENU.

    Parameters
    ----------
    velocity_ms : array_like
        Velocity (m/s), shape ``(..., 3)`` in Malekmohammadi et al. (2024) axes.

    Returns
    -------
    numpy.ndarray
        ENU velocity (m/s), shape ``(..., 3)``.
    """
    v = np.asarray(velocity_ms, dtype=float)
    if v.shape[-1:] != (3,):
        raise ValueError(f"velocity_from_swd_frame: last axis must be 3, got shape {v.shape}")
    return np.einsum("ij,...j->...i", _C_SWD_TO_ENU, v)


def rotate_to_earth(wind_body_ms, roll_deg, pitch_deg, yaw_deg=0.0) -> np.ndarray:
    """Instrument-frame wind to the earth frame, ``V = Y P R V'`` (Eqs. 1-4 of Nassif et al. (2020)).

    Nassif et al.'s (2020) yaw (Eq. 2), pitch (Eq. 3) and roll (Eq. 4, read with ``R[0, 1] = 0``;
    the printed 1 is a typo) matrices, applied yaw-pitch-roll, are the project's
    ``rotation_matrix`` (``docs/conventions.md``); Nassif et al. (2020) sets yaw to 0 for its
    north-moored buoy.

    Parameters
    ----------
    wind_body_ms : array_like
        Wind in the instrument frame (m/s), shape ``(..., 3)``.
    roll_deg, pitch_deg, yaw_deg : array_like
        Attitude (deg), broadcastable to ``(...)``.

    Returns
    -------
    numpy.ndarray
        Earth-frame (ENU) wind (m/s), shape ``(..., 3)``.
    """
    v = np.asarray(wind_body_ms, dtype=float)
    if v.shape[-1:] != (3,):
        raise ValueError(f"rotate_to_earth: wind_body_ms last axis must be 3, got {v.shape}")
    rot = rotation_matrix(np.radians(roll_deg), np.radians(pitch_deg), np.radians(yaw_deg))
    return np.einsum("...ij,...j->...i", rot, v)  # Eq. (1) of Nassif et al. (2020): V = Y P R V'


def tilted_scan_heights(height_m, tilt_deg, half_cone_angle_deg: float = 30.0):
    """Heights of a tilted VAD cone (Nassif et al., 2020, Eqs. 5-7, Table 3).

    Parameters
    ----------
    height_m : array_like
        Target height ``z`` (cone centre height when level), m.
    tilt_deg : array_like
        Total tilt ``delta``, deg.
    half_cone_angle_deg : float
        Half-cone angle, deg (30 in Nassif et al. (2020)).

    Returns
    -------
    z_prime_m, z_min_m, z_max_m, dz_m : ndarray
        Height of the cone centre, lowest and highest scanned heights and their
        difference, m. NaN where the lowest beam is not above the lidar
        (``tilt + half cone >= 90 deg``) or the tilt is negative.
    """
    z = np.asarray(height_m, float)
    d = np.deg2rad(np.asarray(tilt_deg, float))
    th = np.deg2rad(half_cone_angle_deg)
    valid = (d >= 0) & (d + th < np.pi / 2)
    z_prime = z * np.cos(d)  # Eq. (5) of Nassif et al. (2020)
    z_max = z * np.cos(th - d) / np.cos(th)  # Eq. (6) of Nassif et al. (2020)
    z_min = z * np.cos(th + d) / np.cos(th)  # Eq. (7) of Nassif et al. (2020)
    out = [np.where(valid, a, np.nan) for a in (z_prime, z_min, z_max, z_max - z_min)]
    return tuple(out)


def total_tilt_deg(roll_deg, pitch_deg) -> np.ndarray:
    """Total tilt of the body z axis, ``delta = acos(cos(pitch) cos(roll))`` (Nassif et al., 2020, Eq. 8).

    Exact for ``R = Rz Ry Rx``: the earth z component of the body z axis is
    ``cos(pitch) cos(roll)``.

    Parameters
    ----------
    roll_deg, pitch_deg : array_like
        Angles, deg.

    Returns
    -------
    ndarray
        Tilt, deg in [0, 180].
    """
    c = np.cos(np.deg2rad(pitch_deg)) * np.cos(np.deg2rad(roll_deg))
    return np.rad2deg(np.arccos(np.clip(c, -1.0, 1.0)))  # Eq. (8) of Nassif et al. (2020)


def height_correct_profile(hws_ms, height_m, tilt_deg) -> np.ndarray:
    """Height correction of a tilted VAD profile (Eq. 5 of Nassif et al. (2020)).

    A cone tilted by ``delta`` samples, around the target height ``z``, the centre
    height ``z' = z cos(delta)`` (Eq. 5 of Nassif et al. (2020)). The retrieved speeds are
    re-assigned to ``z'`` and the profile is brought back to the target heights by
    interpolation linear in ``ln(z)`` (exact for a logarithmic profile; the end segments
    are extrapolated, which the top level always needs).

    Parameters
    ----------
    hws_ms : array_like
        Retrieved HWS at the target heights (m/s), shape ``(..., nheight)``.
    height_m : array_like
        Target heights (m), shape ``(nheight,)``, increasing, > 0, ``nheight >= 2``.
    tilt_deg : array_like
        Total tilt ``delta`` of each profile (deg, Nassif et al. (2020), Eq. 8,
        :func:`total_tilt_deg`), shape ``(...)``; NaN where :func:`tilted_scan_heights`
        says the tilted cone is not valid (negative tilt, tilt + half cone >= 90 deg).

    Returns
    -------
    numpy.ndarray
        Height-corrected HWS at ``height_m`` (m/s), shape ``(..., nheight)``.
    """
    z = np.asarray(height_m, dtype=float)
    hws = np.asarray(hws_ms, dtype=float)
    if z.ndim != 1 or z.size < 2 or np.any(z <= 0) or np.any(np.diff(z) <= 0):
        raise ValueError(
            f"height_correct_profile: height_m must be >= 2 increasing positive "
            f"heights, got {z.tolist()}"
        )
    if hws.shape[-1:] != z.shape:
        raise ValueError(
            f"height_correct_profile: hws_ms last axis {hws.shape[-1:]} must match "
            f"height_m ({z.size},)"
        )
    z_prime = tilted_scan_heights(z, np.asarray(tilt_deg, dtype=float)[..., None])[0]
    log_z_true = np.log(z_prime)  # Eq. (5) of Nassif et al. (2020): z' = z cos(delta)
    log_z = np.broadcast_to(np.log(z), np.broadcast_shapes(log_z_true.shape, hws.shape))
    log_z_true = np.broadcast_to(log_z_true, log_z.shape)
    hws = np.broadcast_to(hws, log_z.shape)
    # z' = z cos(delta) keeps the order of z, so segment k of the target grid is found
    # by searchsorted on each profile's re-assigned heights.
    k = np.clip(np.sum(log_z_true[..., None, :] <= log_z[..., :, None], axis=-1) - 1, 0, z.size - 2)
    x0 = np.take_along_axis(log_z_true, k, -1)
    x1 = np.take_along_axis(log_z_true, k + 1, -1)
    y0, y1 = np.take_along_axis(hws, k, -1), np.take_along_axis(hws, k + 1, -1)
    return y0 + (log_z - x0) * (y1 - y0) / (x1 - x0)


def wind_frame_tilt_deg(roll_deg, pitch_deg, yaw_deg=0.0, wd_deg=0.0):
    """Tilt components along and across the wind, per sample.

    The tilt vector is the horizontal part of the body z axis in the earth frame,
    ``R @ (0, 0, 1)`` with ``R = Rz(yaw) Ry(pitch) Rx(roll)`` (docs/conventions.md):
    ``(cy sp cr + sy sr, sy sp cr - cy sr)`` (east, north), small-angle
    ``Rz(yaw) (pitch, -roll)``. It is projected on the wind axis
    ``e_w = (sin wd, cos wd)`` (along) and on ``(cos wd, -sin wd)`` (across).

    Parameters
    ----------
    roll_deg, pitch_deg : array_like
        Roll about body x and pitch about body y, deg.
    yaw_deg : array_like
        Yaw about body z, deg, counter-clockwise from above (body y = north at 0).
        For a compass heading ``hdg`` (clockwise from north) pass ``-hdg``.
    wd_deg : array_like
        Meteorological wind direction (from, clockwise from north), deg; broadcast
        with the angles (e.g. shape ``(nrec, 1)`` against series ``(nrec, n)``).

    Returns
    -------
    along_deg, across_deg : ndarray
        Broadcast shape; ``arcsin`` of the components, deg. A pure pitch tilt with
        yaw 0 is along the wind for ``wd = 90`` or ``270`` deg (wind along east-west).
    """
    return project_tilt_on_wind_deg(*tilt_vector_en(roll_deg, pitch_deg, yaw_deg), wd_deg)


#: Methods of :func:`record_sigma_z_ms`, best first.
RECORD_METHODS = ("bands", "moments", "harmonic", "none")


def record_sigma_z_ms(
    hws_ms,
    *,
    spectrum: TiltBandSpectrum | None = None,
    tilt_along_wind_std_deg=None,
    tilt_period_zero_crossing_s=None,
    amplitude_deg=None,
    period_s=None,
    lever_arm_m=0.0,
    lidar: str | LidarGeometry = "zephir300",
    surrogate=None,
) -> tuple[np.ndarray, np.ndarray]:
    """sigma_Z per record with the best motion description each record has.

    Per record, in this order: the band sum (:func:`spectral_sigma_z_ms`) where ``spectrum``
    has finite bands; else the moments-only value (:func:`moments_sigma_z_ms`) where the
    optional record columns ``tilt_along_wind_std_deg`` and ``tilt_period_zero_crossing_s``
    are finite; else the Gutiérrez-Antuñano et al. (2018) harmonic (:func:`harmonic_sigma_z_ms`) at the record's
    ``amplitude_deg`` / ``period_s`` (e.g. ``flidar_uq.data.binning.add_harmonic_motion``), which
    ignores the wind direction (0.43-1.88 of the realised value in
    ``benchmarks/spectral_sigma_z.py``: give it wider intervals); else NaN.

    Parameters
    ----------
    hws_ms : array_like, shape (nrec,)
        m/s.
    spectrum : TiltBandSpectrum, optional
        Bands of the same ``nrec`` records (NaN rows where no raw IMU series).
    tilt_along_wind_std_deg, tilt_period_zero_crossing_s : array_like, shape (nrec,), optional
        Record columns, deg and s.
    amplitude_deg, period_s : array_like, shape (nrec,), optional
        Gutiérrez-Antuñano et al. (2018) single harmonic (roll and pitch amplitude, deg; period, s).
    lever_arm_m, lidar, surrogate
        As in :func:`spectral_sigma_z_ms`.

    Returns
    -------
    sigma_z_ms : ndarray, shape (nrec,)
        m/s.
    method : ndarray of str, shape (nrec,)
        One of :data:`RECORD_METHODS` per record.
    """
    hws = np.atleast_1d(np.asarray(hws_ms, float))
    n = hws.size
    sur = _surrogate(surrogate, lidar)
    arm = np.broadcast_to(np.asarray(lever_arm_m, float), (n,))
    out = np.full(n, np.nan)
    method = np.full(n, "none", dtype=object)

    def _fill(values, ok, label):
        use = ok & (method == "none") & np.isfinite(values)
        out[use] = values[use]
        method[use] = label

    if spectrum is not None:
        ok = np.isfinite(spectrum.var_along_deg2).all(axis=-1) & np.isfinite(spectrum.period_s).all(
            axis=-1
        )
        if ok.shape != (n,):
            raise ValueError(f"record_sigma_z_ms: spectrum has {ok.size} records, hws_ms has {n}")
        var = np.where(ok[:, None], spectrum.var_along_deg2, 0.0)
        per = np.where(ok[:, None], spectrum.period_s, 4.0)
        _fill(spectral_sigma_z_ms(hws, var, per, lever_arm_m=arm, surrogate=sur), ok, "bands")
    if tilt_along_wind_std_deg is not None and tilt_period_zero_crossing_s is not None:
        sd = np.broadcast_to(np.asarray(tilt_along_wind_std_deg, float), (n,))
        tz = np.broadcast_to(np.asarray(tilt_period_zero_crossing_s, float), (n,))
        ok = np.isfinite(sd) & np.isfinite(tz)
        _fill(moments_sigma_z_ms(hws, sd, tz, lever_arm_m=arm, surrogate=sur), ok, "moments")
    if amplitude_deg is not None and period_s is not None:
        a = np.broadcast_to(np.asarray(amplitude_deg, float), (n,))
        t = np.broadcast_to(np.asarray(period_s, float), (n,))
        ok = np.isfinite(a) & np.isfinite(t)
        _fill(harmonic_sigma_z_ms(hws, a, t, lever_arm_m=arm, surrogate=sur), ok, "harmonic")
    return out, method.astype(str)


def dbs_heading_average_sigma_z_ms(
    amplitude_deg,
    period_s,
    direction_to_wind_deg=None,
    *,
    hws_ms,
    moments_to_wind=None,
    n_headings: int = 24,
    **kwargs,
):
    """sigma_Z of a DBS lidar whose heading (the wind direction relative to the beams) is unknown.

    The sea is given relative to the wind: each component's direction of travel minus the
    wind's (``direction_to_wind_deg``, deg) or each band's direction moments in that frame
    (``moments_to_wind``, :func:`direction_moments`). The wind's direction in the body frame
    is taken uniform over ``n_headings`` values (the sea turning with it). Other keywords:
    :func:`dbs_harmonic_sigma_z_ms`.

    Returns
    -------
    rms, spread : ndarray, shape (...)
        The root-mean-square sigma_Z over the headings and the std of sigma_Z over them
        (the uncertainty an unknown heading leaves), m/s.
    """
    beta = _heading_grid(n_headings)
    hws = np.asarray(hws_ms, float)
    if moments_to_wind is None:
        mom = direction_moments(np.asarray(direction_to_wind_deg, float))
    else:
        mom = np.asarray(moments_to_wind, float)
    s = np.stack(
        [
            dbs_harmonic_sigma_z_ms(
                amplitude_deg,
                period_s,
                hws_ms=hws,
                wind_body_deg=b,
                direction_moments_=rotate_moments(mom, b),
                **kwargs,
            )
            for b in beta
        ],
        axis=-1,
    )
    return np.sqrt(np.mean(s**2, axis=-1)), np.std(s, axis=-1)


def dbs_record_sigma_z_ms(
    hws_ms,
    roll_amplitude_deg,
    pitch_amplitude_deg,
    period_s,
    *,
    heading_deg=None,
    wd_deg=None,
    lever_arm_m: float = 0.0,
    hull="wave_follower",
    lidar: str | LidarGeometry | Mapping = "windcube_v2",
    roll_period_s=None,
    n_headings: int = 24,
    dwell_average: bool = True,
):
    """sigma_Z (m/s) of a DBS lidar per record from the record table's motion columns.

    Each record's motion is taken as a roll harmonic (about the body x axis: the hull
    leans along the body y axis) and a pitch harmonic (leans along the body x axis),
    independent, with their amplitudes (``sqrt(2)`` x std, deg) and periods; the hull's
    translation follows from the tilt through its response (:mod:`flidar_uq.physics.hull`).
    With the heading (``heading_deg``, yaw: body x axis, deg counter-clockwise from east,
    docs/conventions.md) and the wind direction ``wd_deg`` the wind's direction relative to
    the beams is known; without either it is averaged over ``n_headings``
    (:func:`dbs_heading_average_sigma_z_ms`), and ``spread`` says how much it can differ.

    Parameters
    ----------
    hws_ms, roll_amplitude_deg, pitch_amplitude_deg, period_s : array_like, shape (n,)
        HWS (m/s), amplitudes (deg) and the pitch period (s; also the roll's unless
        ``roll_period_s`` is given).
    heading_deg, wd_deg : array_like, shape (n,), optional
    lever_arm_m, hull, lidar, dwell_average
        As :func:`dbs_harmonic_sigma_z_ms` (here the dwell average is on by default: a
        pulsed lidar accumulates over the beam, as the virtual campaign does).

    Returns
    -------
    sigma_z, spread : ndarray, shape (n,)
        sigma_Z (m/s; rms over headings when unknown) and its std over headings (0 when the
        heading is known).
    """
    hws = np.asarray(hws_ms, float)
    p_pitch = np.asarray(period_s, float)
    p_roll = p_pitch if roll_period_s is None else np.asarray(roll_period_s, float)
    amp = np.stack(np.broadcast_arrays(roll_amplitude_deg, pitch_amplitude_deg), -1)
    per = np.stack(np.broadcast_arrays(p_roll, p_pitch), -1)
    kw = dict(lever_arm_m=lever_arm_m, hull=hull, lidar=lidar, dwell_average=dwell_average)
    # roll leans the hull along +y, pitch along +x: the side the waves run on is not in a
    # record's amplitudes (for a hull that heaves it sets the heave-tilt cross term's sign)
    body_dir = np.array([90.0, 0.0])
    amp, per = np.broadcast_arrays(amp, per)
    if heading_deg is not None and wd_deg is not None:
        beta = wind_to_body_deg(wd_deg, heading_deg)
        s = dbs_harmonic_sigma_z_ms(
            amp, per, np.broadcast_to(body_dir, amp.shape), hws_ms=hws, wind_body_deg=beta, **kw
        )
        return s, np.zeros_like(s)
    beta = _heading_grid(n_headings)
    s = np.stack(
        [
            dbs_harmonic_sigma_z_ms(
                amp, per, np.broadcast_to(body_dir, amp.shape), hws_ms=hws, wind_body_deg=b, **kw
            )
            for b in beta
        ],
        axis=-1,
    )
    return np.sqrt(np.mean(s**2, axis=-1)), np.std(s, axis=-1)


def dbs_sigma_z_from_terms(gram, *, lever_arm_m, hull_response, motion_scale=1.0):
    """sigma_Z (m/s) from :func:`dbs_record_terms` for a lever arm ``L`` (m), a hull response
    ``h`` (-) and a motion scale ``k`` (-), broadcasting over draws given as arrays of shape
    (n_draws, 1): ``sqrt(v^T G v)``, ``v = (k, k h, L, h)``."""
    g = np.asarray(gram, float)
    k = np.asarray(motion_scale, float)
    h = np.asarray(hull_response, float)
    lev = np.asarray(lever_arm_m, float)
    v = np.broadcast_arrays(k, k * h, lev, h)
    var = sum(v[i] * v[j] * g[..., i, j] for i in range(4) for j in range(4))
    return np.sqrt(np.maximum(var, 0.0))


def six_dof_terms(
    records: pd.DataFrame,
    motion: pd.DataFrame,
    *,
    surrogate=None,
    scan_period_s: float = 1.0,
    hull="wave_follower",
) -> pd.DataFrame:
    """Per-record terms of the hull's translation in sigma_Z in one call: the record model's
    ``record_motion._translation_terms`` with its band terms computed here, returned as a
    DataFrame (``heave_cross_sq``, ``heave_leak_sq``, ``orbital_cross_sq``, ``orbital_sq``,
    ``translation_measured``)."""
    surrogate = default_surrogate(surrogate)
    band_terms = _band_terms(records, surrogate, scan_period_s)
    return _translation_terms(records, motion, surrogate, scan_period_s, hull, band_terms)
