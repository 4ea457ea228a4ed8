"""Moving-lidar simulator and the sigma_Z / E(Z) phase-moment integral (Gutiérrez-Antuñano et al., 2018).

Size: the scan simulation and the phase-moment integral share the VAD coefficient kernels; kept together so that the sigma_Z integral and the scans it is checked against cannot drift apart (~710 lines, half of it docstrings).

Building blocks (vectorised over any batch of scans, for campaign generators):

- :func:`los_vectors_earth` – earth-frame unit vectors of the lines of sight of tilted scans;
- :func:`simulate_scans` – radial speeds and the (uncorrected) retrieved wind of a batch of
  scans given the attitude at each line of sight;
- :func:`simulate_scan` – one scan under a :class:`~flidar_uq.physics.motion.PlatformMotion`;
- :func:`sigma_z` – std and mean of ``Z = retrieved HWS - true HWS`` over uniform roll,
  pitch and scan phases (Gutiérrez-Antuñano et al., 2018, Eqs. 1-14), by a fast exact reformulation of the VAD
  retrieval (see ``docs/simulator.md``) and trapezoidal quadrature on a grid chosen from an
  a-priori bound of its geometric convergence rate (doubled while the error estimate is above
  ``rtol``).
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np

from flidar_uq.physics.lidar import (
    LidarGeometry,
    WindRetrieval,
    beam_unit_vectors_body,
    get_lidar,
    retrieve_wind,
    scan_times_azimuths,
    wind_direction_deg,
)
from flidar_uq.physics.motion import rotation_matrix, rotation_matrix_derivatives

__all__ = [
    "ScanResult",
    "SigmaZResult",
    "los_vectors_earth",
    "simulate_scans",
    "simulate_scan",
    "sigma_z",
    "sigma_z_grid",
    "sigma_z_direction_average",
    "vad_hws_coefficients",
]


def los_vectors_earth(
    lidar: str | LidarGeometry, azimuth_rad, roll_rad, pitch_rad, yaw_rad=0.0
) -> np.ndarray:
    """Earth-frame unit vectors of lines of sight under tilt, ``R @ d_body``.

    Parameters
    ----------
    lidar : str or LidarGeometry
    azimuth_rad : array_like, shape (..., n)
        Body-frame beam azimuths, rad (``NaN``: vertical beam).
    roll_rad, pitch_rad, yaw_rad : array_like, shape (..., n)
        Attitude at each line of sight, rad (broadcast with ``azimuth_rad``).

    Returns
    -------
    ndarray, shape (..., n, 3)
    """
    d = beam_unit_vectors_body(lidar, azimuth_rad)
    r = rotation_matrix(roll_rad, pitch_rad, yaw_rad)
    return np.einsum("...ij,...j->...i", r, d)


def simulate_scans(
    lidar: str | LidarGeometry,
    wind_ms,
    roll_rad,
    pitch_rad,
    *,
    yaw_rad=0.0,
    head_velocity_ms=None,
    azimuth_rad=None,
    sign_ambiguity: bool | None = None,
) -> tuple[np.ndarray, WindRetrieval]:
    """Radial speeds and retrieved wind of a batch of scans on a moving platform.

    The lidar retrieves with its nominal (level) geometry, i.e. without motion
    correction, as in Gutiérrez-Antuñano et al.'s (2018) simulator; the horizontal wind is then rotated by the
    mean yaw of the scan (compass correction, Gutiérrez-Antuñano et al. (2018), Sec. 2.2).

    Parameters
    ----------
    lidar : str or LidarGeometry
    wind_ms : array_like, shape (..., 3) or (..., n, 3)
        ENU wind per scan or per line of sight, m/s.
    roll_rad, pitch_rad : array_like, shape (..., n)
        Attitude at the time of each line of sight, rad.
    yaw_rad : array_like, shape (..., n), optional
        Yaw at each line of sight, rad.
    head_velocity_ms : array_like, shape (..., n, 3), optional
        Earth-frame velocity of the lidar head (translation and lever arm), m/s.
    azimuth_rad : array_like, shape (..., n) or (n,), optional
        Body azimuths; default ``scan_times_azimuths(lidar)[1]``.
    sign_ambiguity : bool, optional
        Report ``|v_r|`` and fit the CW model (Malekmohammadi et al., 2024, Eq. 4). Default: ``not lidar.signed``.

    Returns
    -------
    radial_speed_ms : ndarray, shape (..., n)
        ``d_earth . (u - v_head)`` (Yamaguchi and Ishihara, 2016, Eq. 3), or its absolute value.
    retrieval : WindRetrieval
        Retrieved wind, batch shape ``(...)``, horizontal components in the earth frame.
    """
    g = get_lidar(lidar)
    if azimuth_rad is None:
        azimuth_rad = scan_times_azimuths(g)[1]
    amb = (not g.signed) if sign_ambiguity is None else bool(sign_ambiguity)
    d_earth = los_vectors_earth(g, azimuth_rad, roll_rad, pitch_rad, yaw_rad)
    wind = np.asarray(wind_ms, float)
    if wind.ndim < d_earth.ndim:
        wind = wind[..., None, :]
    rel = wind if head_velocity_ms is None else wind - np.asarray(head_velocity_ms, float)
    v_r = np.einsum("...i,...i->...", d_earth, rel)  # Eq. (3) of Yamaguchi and Ishihara (2016)
    if amb:
        v_r = np.abs(v_r)  # Eq. (4) of Malekmohammadi et al. (2024): a CW lidar measures |v_r|
    ret = retrieve_wind(g, np.broadcast_to(azimuth_rad, v_r.shape), v_r, sign_ambiguity=amb)
    yaw_mean = np.mean(np.broadcast_to(np.asarray(yaw_rad, float), v_r.shape), axis=-1)
    if np.any(yaw_mean != 0):
        c, s = np.cos(yaw_mean), np.sin(yaw_mean)
        u = c * ret.u_ms - s * ret.v_ms
        v = s * ret.u_ms + c * ret.v_ms
        ret = WindRetrieval(u, v, ret.w_ms, ret.hws_ms, wind_direction_deg(u, v), ret.residual_ms)
    return v_r, ret


@dataclass(frozen=True)
class ScanResult:
    """One simulated scan.

    Attributes
    ----------
    t_s : ndarray, shape (n,)
        Time of each line of sight, s.
    azimuth_rad : ndarray, shape (n,)
        Body azimuth of each line of sight, rad.
    radial_speed_ms : ndarray, shape (n,)
        Measured radial speeds, m/s.
    hws_ms, wd_deg, w_ms : float
        Retrieved horizontal speed (m/s), direction (deg), vertical speed (m/s).
    z_ms : float
        ``Z = retrieved HWS - true HWS`` (Gutiérrez-Antuñano et al., 2018, Eq. 1), m/s.
    residual_ms : float
        RMS fit residual, m/s.
    """

    t_s: np.ndarray
    azimuth_rad: np.ndarray
    radial_speed_ms: np.ndarray
    hws_ms: float
    wd_deg: float
    w_ms: float
    z_ms: float
    residual_ms: float


def simulate_scan(
    lidar: str | LidarGeometry,
    motion,
    wind_ms,
    t_start_s: float = 0.0,
    scan_phase_rad: float = 0.0,
    *,
    height_m: float | None = None,
    shear_exponent: float = 0.0,
    sign_ambiguity: bool | None = None,
) -> ScanResult:
    """Simulate one scan of a lidar on a moving platform (Gutiérrez-Antuñano et al., 2018, Sec. 2.2).

    Parameters
    ----------
    lidar : str or LidarGeometry
    motion : PlatformMotion or SampledMotion
        Anything with ``attitude_rad(t)``, ``head_velocity_ms(t)`` and
        ``head_displacement_m(t)`` (see :mod:`flidar_uq.physics.motion`).
    wind_ms : array_like, shape (3,), or callable
        ENU wind at the reference height, m/s; or ``f(t_s, xyz_m) -> (..., 3)`` with
        ``xyz_m`` the measurement points relative to the lidar head at rest (m).
    t_start_s : float
        Time of the first line of sight, s.
    scan_phase_rad : float
        Azimuth of the first line of sight (Gutiérrez-Antuñano et al., 2018, Sec. 2.2), rad.
    height_m : float, optional
        Measurement height above the lidar, m; needed for shear and callable winds.
        The focus (range) of the inclined beams is ``height_m / cos(half cone)``.
    shear_exponent : float
        Power-law exponent ``alpha`` of ``u(z) = u_ref (z / height_m) ** alpha`` (Yamaguchi and Ishihara (2016)
        uses 0.1); a tilted cone then samples height-varying wind.
    sign_ambiguity : bool, optional
        Default ``not lidar.signed`` (a CW lidar reports ``|v_r|``).

    Returns
    -------
    ScanResult
    """
    g = get_lidar(lidar)
    t_rel, az = scan_times_azimuths(g, scan_phase_rad)
    t = t_start_s + t_rel
    roll, pitch, yaw = motion.attitude_rad(t)
    v_head = motion.head_velocity_ms(t)
    needs_points = callable(wind_ms) or shear_exponent != 0.0
    if needs_points and height_m is None:
        raise ValueError("simulate_scan: height_m is required with a callable wind or shear")
    if needs_points:
        d_earth = los_vectors_earth(g, az, roll, pitch, yaw)
        rng_m = np.where(np.isnan(az), height_m, height_m / np.cos(g.half_cone_angle_rad))
        xyz = motion.head_displacement_m(t) + rng_m[:, None] * d_earth
        if callable(wind_ms):
            wind = np.asarray(wind_ms(t, xyz), float)
            truth = np.asarray(
                wind_ms(
                    np.array([t_start_s + 0.5 * g.scan_period_s]), np.array([[0, 0, height_m]])
                ),
                float,
            )[0]
        else:
            truth = np.asarray(wind_ms, float)
            zr = xyz[:, 2] / height_m
            with np.errstate(invalid="ignore", divide="ignore"):
                fac = np.where(zr > 0, np.abs(zr) ** shear_exponent, np.nan)
            wind = truth[None, :] * fac[:, None]
    else:
        truth = np.asarray(wind_ms, float)
        if truth.shape != (3,):
            raise ValueError(f"simulate_scan: wind_ms must have shape (3,), got {truth.shape}")
        wind = truth
    v_r, ret = simulate_scans(
        g,
        wind,
        roll,
        pitch,
        yaw_rad=yaw,
        head_velocity_ms=v_head,
        azimuth_rad=az,
        sign_ambiguity=sign_ambiguity,
    )
    hws_true = float(np.hypot(truth[0], truth[1]))
    return ScanResult(
        t_s=t,
        azimuth_rad=az,
        radial_speed_ms=v_r,
        hws_ms=float(ret.hws_ms),
        wd_deg=float(ret.wd_deg),
        w_ms=float(ret.w_ms),
        z_ms=float(ret.hws_ms) - hws_true,  # Eq. (1) of Gutiérrez-Antuñano et al. (2018)
        residual_ms=float(ret.residual_ms),
    )


# --------------------------------------------------------------------------------------
# Fast kernel for VAD lidars.
#
# For equally spaced azimuths az_k = phi_s + alpha_k, the least-squares VAD retrieval is
# u + i v = (2 / (n sin th)) sum_k v_k exp(i (pi/2 - az_k)) and, writing the radial speed as
# v_k = sin th (sin az_k X_k + cos az_k Y_k) + cos th Z_k with X, Y, Z the projections of the
# relative wind on the tilted body axes, the retrieved horizontal wind is exactly a
# trigonometric polynomial of degree 2 in the scan phase:
#     u + i v = A0 + A1 exp(-i phi_s) + A2 exp(-2 i phi_s),
#     A0 = mean_k(X_k + i Y_k), A1 = (2 i cot th / n) sum_k Z_k exp(-i alpha_k),
#     A2 = -mean_k((X_k - i Y_k) exp(-2 i alpha_k)).
# X, Y, Z are sums of products f(roll_k) g(pitch_k) (R = Ry(p) Rx(r); the lever-arm term is
# d . (omega_body x r) with omega_body = (rdot, pdot cos r, -pdot sin r)), so the sums over
# the lines of sight for all (roll phase, pitch phase) pairs are one matrix product.
# --------------------------------------------------------------------------------------

# Roll factors: 0: 1, 1: cos r, 2: sin r, 3: rdot; pitch factors: 0: 1, 1: cos p, 2: sin p, 3: pdot.


def _xyz_coefficients(u_x: float, u_y: float, arm: np.ndarray) -> np.ndarray:
    """Coefficients C[q, a, b] of X (q=0), Y (1), Z (2) in the products f_a(roll) g_b(pitch)."""
    rx, ry, rz = arm
    c = np.zeros((3, 4, 4))
    # X = cos p U_x - (omega x r)_x,  (omega x r)_x = pdot (cos r r_z + sin r r_y)
    c[0, 0, 1] += u_x
    c[0, 1, 3] -= rz
    c[0, 2, 3] -= ry
    # Y = sin r sin p U_x + cos r U_y - (omega x r)_y, (omega x r)_y = -pdot sin r r_x - rdot r_z
    c[1, 2, 2] += u_x
    c[1, 1, 0] += u_y
    c[1, 2, 3] += rx
    c[1, 3, 0] += rz
    # Z = cos r sin p U_x - sin r U_y - (omega x r)_z, (omega x r)_z = rdot r_y - pdot cos r r_x
    c[2, 1, 2] += u_x
    c[2, 2, 0] -= u_y
    c[2, 3, 0] -= ry
    c[2, 1, 3] += rx
    return c


@functools.lru_cache(maxsize=8)
def _vad_weight_table(g: LidarGeometry) -> np.ndarray:
    """Per-LOS weights ``W[s, k, (c, a), b]`` of ``Re/Im(A0, A1, A2)`` (``c``) in the products
    ``f_a(roll_k) g_b(pitch_k)`` for the five linear sources ``s`` = (U_x, U_y, r_x, r_y, r_z).

    The retrieved coefficients are linear in the wind and in the lever arm, so the weights of
    any case are ``(U_x, U_y, r_x, r_y, r_z) @ W``: a parameter-independent table (cached
    per geometry, read-only).
    """
    n = g.n_los
    th = g.half_cone_angle_rad
    alpha = 2.0 * np.pi * np.arange(n) / n
    # Per-k complex weights of the three coefficients (see the block comment above).
    # A0 <- (X + i Y)/n ; A1 <- Z (2i cot th / n) e^{-i alpha} ; A2 <- -(X - i Y) e^{-2 i alpha}/n
    e1, e2 = np.exp(-1j * alpha), np.exp(-2j * alpha)
    out = np.empty((5, n, 24, 4))
    unit = np.eye(3)
    sources = [(1.0, 0.0, np.zeros(3)), (0.0, 1.0, np.zeros(3))] + [(0.0, 0.0, e) for e in unit]
    for s, (u_x, u_y, arm) in enumerate(sources):
        coef = _xyz_coefficients(u_x, u_y, arm)
        cm = np.stack(
            [
                (coef[0] + 1j * coef[1])[..., None] * (np.ones(n) / n),
                coef[2][..., None] * (2j / (n * np.tan(th)) * e1),
                -(coef[0] - 1j * coef[1])[..., None] * (e2 / n),
            ]
        )  # (3, 4a, 4b, n)
        # real and imaginary parts side by side: real matrix products only (a mixed
        # real-complex product takes a slow path in numpy, see docs/simulator.md)
        cm_ri = np.concatenate([cm.real, cm.imag])  # (6 = 2 x 3m, 4a, 4b, n)
        out[s] = np.transpose(cm_ri, (3, 0, 1, 2)).reshape(n, 24, 4)
    out = out.reshape(5, n * 96)
    out.flags.writeable = False
    return out


@functools.lru_cache(maxsize=32)
def _scan_basis(nscan: int) -> np.ndarray:
    """``B`` (2 nscan, 6): ``(u, v)`` on the scan-phase grid from ``Re/Im(A0, A1, A2)``.

    ``A_m q^m`` with ``q = exp(-i phi_s)`` and ``A_m = x_m + i y_m`` has real part
    ``x_m cos(m phi_s) + y_m sin(m phi_s)`` and imaginary part
    ``y_m cos(m phi_s) - x_m sin(m phi_s)`` (cached per grid size).
    """
    phi_s = 2.0 * np.pi * np.arange(nscan) / nscan
    c = np.cos(np.outer(phi_s, np.arange(3)))
    s = np.sin(np.outer(phi_s, np.arange(3)))
    b = np.block([[c, s], [-s, c]])
    b.flags.writeable = False
    return b


@functools.lru_cache(maxsize=8)
def _scan_times(g: LidarGeometry) -> np.ndarray:
    """Line-of-sight times of one scan, s (``scan_times_azimuths``; cached, read-only)."""
    t_s = scan_times_azimuths(g)[0]
    t_s.flags.writeable = False
    return t_s


def _factor_table(angle_rad: np.ndarray, rate_rad_s: np.ndarray) -> np.ndarray:
    """Stack (1, cos, sin, rate) along a new first axis: (n, m) -> (4, n, m)."""
    f = np.empty((4,) + angle_rad.shape)
    f[0] = 1.0
    np.cos(angle_rad, out=f[1])
    np.sin(angle_rad, out=f[2])
    f[3] = rate_rad_s
    return f


def _vad_coefficients_ri(g: LidarGeometry, sources, roll_f: np.ndarray, pitch_f: np.ndarray):
    """``Re/Im(A0, A1, A2)`` (6, mp, mr) for factor tables roll_f (4, n, mr), pitch_f (4, n, mp)
    and the sources (U_x, U_y, r_x, r_y, r_z) (m/s, m/s, m, m, m)."""
    n = g.n_los
    mp, mr = pitch_f.shape[2], roll_f.shape[2]
    cm = (np.asarray(sources, float) @ _vad_weight_table(g)).reshape(n, 24, 4)
    # x[k, (c, a), j] = sum_b cm[k, (c, a), b] g[b, k, j]: one small product per LOS k
    x = np.matmul(cm, pitch_f.transpose(1, 0, 2))  # (n, 24, mp)
    rhs = x.reshape(n, 6, 4, mp).transpose(1, 3, 2, 0).reshape(6 * mp, 4 * n)
    return (rhs @ roll_f.reshape(4 * n, mr)).reshape(6, mp, mr)


def vad_hws_coefficients(
    lidar: LidarGeometry,
    wind_ms,
    roll_rad: np.ndarray,
    roll_rate: np.ndarray,
    pitch_rad: np.ndarray,
    pitch_rate: np.ndarray,
    lever_arm_m=(0.0, 0.0, 0.0),
) -> np.ndarray:
    """Scan-phase Fourier coefficients of the retrieved horizontal wind (VAD, exact).

    For every pair (roll history ``i``, pitch history ``j``) returns ``A[m, i, j]``
    with ``u + i v = A0 + A1 exp(-i phi_s) + A2 exp(-2 i phi_s)`` the wind retrieved by
    least squares from a scan starting at azimuth ``phi_s`` (no yaw).

    Parameters
    ----------
    lidar : LidarGeometry
        A VAD geometry.
    wind_ms : array_like, shape (2,) or (3,)
        ENU wind (the vertical component is ignored: ``w = 0`` is assumed), m/s.
    roll_rad, roll_rate : ndarray, shape (mr, n)
        Roll (rad) and its rate (rad/s) at the ``n`` line-of-sight times, for ``mr`` histories.
    pitch_rad, pitch_rate : ndarray, shape (mp, n)
        The same for pitch.
    lever_arm_m : array_like, shape (3,)
        Head position relative to the rotation centre, body frame, m.

    Returns
    -------
    ndarray, complex, shape (3, mr, mp)
    """
    arm = np.asarray(lever_arm_m, float)
    src = (float(wind_ms[0]), float(wind_ms[1]), arm[0], arm[1], arm[2])
    f = _factor_table(np.asarray(roll_rad, float).T, np.asarray(roll_rate, float).T)
    gp = _factor_table(np.asarray(pitch_rad, float).T, np.asarray(pitch_rate, float).T)
    a = _vad_coefficients_ri(lidar, src, f, gp)  # (6, mp, mr)
    return np.transpose(a[:3] + 1j * a[3:], (0, 2, 1))


@functools.lru_cache(maxsize=32)
def _phase_grid(nphase: int) -> np.ndarray:
    """The uniform periodic grid ``2 pi k / nphase``, rad (cached, read-only)."""
    phi = 2.0 * np.pi * np.arange(nphase) / nphase
    phi.flags.writeable = False
    return phi


def _histories(components, t_s: np.ndarray, nphase: int):
    """Angle (rad) and rate (rad/s) of a sum of harmonic components ``amp sin(w t + phi)``
    at times ``t_s`` over the product grid of their phases: each (n_times, nphase**m),
    the first component's phase varying slowest."""
    phi = _phase_grid(nphase)
    ang = rate = None
    for amp_rad, period_s in components:
        w = 2.0 * np.pi / period_s
        arg = np.add.outer(w * t_s, phi)
        a = np.sin(arg)
        a *= amp_rad
        r = np.cos(arg, out=arg)
        r *= amp_rad * w
        if ang is None:
            ang, rate = a, r
        else:
            ang = (ang[:, :, None] + a[:, None, :]).reshape(t_s.size, -1)
            rate = (rate[:, :, None] + r[:, None, :]).reshape(t_s.size, -1)
    return ang, rate


# The scan-phase integral of the fast kernel is cheap (the coefficients are computed once per
# roll/pitch pair) and is the hardest one when the motion period is near the scan period,
# so it gets this many times more points (measured: docs/simulator.md).
_SCAN_PHASE_FACTOR = 4


def _hws_vad(g, wind, roll_comps, pitch_comps, arm, nphase, nscan):
    """Retrieved HWS (m/s) on the phase grid, axes (scan, pitch phase(s), roll phase(s))."""
    t_s = _scan_times(g)
    f = _factor_table(*_histories(roll_comps, t_s, nphase))
    gp = f if pitch_comps == roll_comps else _factor_table(*_histories(pitch_comps, t_s, nphase))
    a = _vad_coefficients_ri(g, (wind[0], wind[1], arm[0], arm[1], arm[2]), f, gp)
    # h = |A0 + A1 q + A2 q^2|, q = exp(-i phi_s): (u, v) on the scan grid by one real product
    uv = _scan_basis(nscan) @ a.reshape(6, -1)  # (2 nscan, mp * mr)
    uv *= uv
    h = uv[:nscan]
    h += uv[nscan:]
    np.sqrt(h, out=h)
    return h.reshape((nscan,) + (nphase,) * (len(pitch_comps) + len(roll_comps)))


def _moments_generic(g, wind, roll_comps, pitch_comps, arm, nphase, nscan, sign_ambiguity):
    """Direct evaluation for any lidar (DBS: the scan phase selects the starting beam)."""
    t_s, _ = scan_times_azimuths(g)
    ang, rate = (x.T for x in _histories(roll_comps, t_s, nphase))
    pang, prate = (x.T for x in _histories(pitch_comps, t_s, nphase))
    if g.kind == "dbs":
        phases = 2.0 * np.pi * (np.arange(g.n_los) + 0.5) / g.n_los
    else:
        phases = 2.0 * np.pi * np.arange(nscan) / nscan
    az = np.stack([scan_times_azimuths(g, p)[1] for p in phases])  # (ns, n)
    shape = (ang.shape[0], pang.shape[0], len(phases), t_s.size)
    roll = np.broadcast_to(ang[:, None, None, :], shape)
    pitch = np.broadcast_to(pang[None, :, None, :], shape)
    head = None
    if np.any(arm != 0):
        droll = np.broadcast_to(rate[:, None, None, :], shape)
        dpitch = np.broadcast_to(prate[None, :, None, :], shape)
        head = rotation_matrix_derivatives(roll, pitch, 0.0, droll, dpitch, 0.0) @ arm
    _, ret = simulate_scans(
        g,
        wind,
        roll,
        pitch,
        head_velocity_ms=head,
        azimuth_rad=np.broadcast_to(az[None, None], shape),
        sign_ambiguity=sign_ambiguity,
    )
    return ret.hws_ms


def _subgrid(z: np.ndarray, step: int, scan_nested: bool) -> np.ndarray:
    """Every ``step``-th point of each phase axis: the nested grid of ``n / step`` points.

    The trapezoid grid ``2 pi k / n`` contains ``2 pi k / (n / step)``, so the coarser
    resolution costs nothing. A DBS scan axis (its beams) is kept whole.
    """
    sl = (slice(None, None, step),) * (z.ndim - 1)
    return z[sl + ((slice(None, None, step),) if scan_nested else (slice(None),))]


@dataclass(frozen=True)
class SigmaZResult:
    """Result of :func:`sigma_z`.

    Attributes
    ----------
    sigma_z_ms : float
        Standard deviation of ``Z`` over the phases (Gutiérrez-Antuñano et al., 2018, Eq. 4), m/s.
    mean_z_ms : float
        ``E(Z)``, m/s.
    n_phase : int
        Quadrature points per phase dimension of the returned value.
    error_estimate_ms : float
        ``max(|d sigma|, |d mean|)`` between the returned grid and its nested half grid
        (every second point of each phase), m/s, times the a-priori contraction
        ``rho ** (n_phase / 2)`` of the geometric convergence where ``rho`` is bounded
        (VAD kernel, one period; see :func:`sigma_z` and docs/simulator.md), else times 1.
    converged : bool
        Whether ``error_estimate_ms <= rtol * max(sigma_z_ms, |mean_z_ms|)`` was reached,
        or both moments are round-off (``<= 1e-12 max(hws_ms, 1)`` m/s: no motion).
    method : str
        ``"vad-fourier"`` (fast exact kernel) or ``"direct"``.
    """

    sigma_z_ms: float
    mean_z_ms: float
    n_phase: int
    error_estimate_ms: float
    converged: bool
    method: str


def _check_scalar(name: str, value, *, lo=None, hi=None, lo_open=False) -> float:
    try:
        x = float(value)
    except (TypeError, ValueError):
        raise ValueError(f"sigma_z: {name} must be a number, got {value!r}") from None
    bad = not math.isfinite(x) or (lo is not None and (x <= lo if lo_open else x < lo))
    bad = bad or (hi is not None and x > hi)
    if bad:
        lo_s = "" if lo is None else (f"> {lo}" if lo_open else f">= {lo}")
        hi_s = "" if hi is None else f"<= {hi}"
        rng_s = " and ".join(s for s in (lo_s, hi_s) if s)
        raise ValueError(
            f"sigma_z: {name} must be finite{' and ' + rng_s if rng_s else ''}, got {value!r}"
        )
    return x


def sigma_z_grid(
    hws_ms: float,
    amplitude_deg: float,
    period_s: float,
    wd_deg: float = 0.0,
    lidar: str | LidarGeometry = "zephir300",
    *,
    nphase: int,
    amplitude2_deg: float | None = None,
    period2_s: float | None = None,
    lever_arm_m=0.0,
    method: str = "auto",
    sign_ambiguity: bool = False,
    pitch_amplitude_deg: float | None = None,
    nphase_scan: int | None = None,
) -> tuple[float, float]:
    """``(sigma_Z, E(Z))`` on a fixed grid of ``nphase`` points per phase (no adaptation).

    Same arguments as :func:`sigma_z`; ``method`` is ``"auto"`` (fast kernel for VAD),
    ``"fourier"`` or ``"direct"`` (the scan simulated line of sight by line of sight).
    ``nphase_scan`` is the number of scan-phase points (VAD; default ``4 * nphase``; a DBS
    scan phase only selects the first of the ``n_los`` beams, which are all used).

    Returns
    -------
    sigma_z_ms, mean_z_ms : float
    """
    z, _ = _z_grid(
        hws_ms,
        amplitude_deg,
        period_s,
        wd_deg,
        lidar,
        nphase=nphase,
        amplitude2_deg=amplitude2_deg,
        period2_s=period2_s,
        lever_arm_m=lever_arm_m,
        method=method,
        sign_ambiguity=sign_ambiguity,
        pitch_amplitude_deg=pitch_amplitude_deg,
        nphase_scan=nphase_scan,
    )
    return _moments(z)


def _moments(z: np.ndarray) -> tuple[float, float]:
    """``(sigma_Z, E(Z))`` of ``Z`` on a uniform product grid of phases (all axes)."""
    # Eqs. (6)-(14) of Gutiérrez-Antuñano et al. (2018): uniform phases, product trapezoid rule (a plain ufunc
    # reduction: np.mean's Python wrapper costs as much as the sum on these small grids)
    mean = float(np.add.reduce(z, None)) / z.size
    d = z - mean
    var = (
        float(np.vdot(d, d)) / d.size
    )  # Eq. (4) of Gutiérrez-Antuñano et al. (2018) (two-pass form)
    return math.sqrt(var), mean


def _motion_setup(
    hws_ms,
    amplitude_deg,
    period_s,
    wd_deg,
    amplitude2_deg,
    period2_s,
    lever_arm_m,
    pitch_amplitude_deg,
):
    """``(wind (3,) m/s, roll components, pitch components, lever arm (3,) m)`` of the
    :func:`sigma_z` arguments; components are ``(amplitude rad, period s)`` pairs."""
    arm = (
        np.array([0.0, 0.0, float(lever_arm_m)])
        if np.ndim(lever_arm_m) == 0
        else np.asarray(lever_arm_m, float)
    )
    comps = [(math.radians(amplitude_deg), period_s)]
    if amplitude2_deg is not None:
        comps.append((math.radians(amplitude2_deg), period2_s))
    if pitch_amplitude_deg is None:
        pcomps = comps
    else:
        pcomps = [
            (a * pitch_amplitude_deg / amplitude_deg if amplitude_deg > 0 else 0.0, t)
            for a, t in comps
        ]
    wd = math.radians(wd_deg)  # scalar form of wind_vector_ms (docs/conventions.md)
    wind = np.array([-hws_ms * math.sin(wd), -hws_ms * math.cos(wd), 0.0])
    return wind, comps, pcomps, arm


def _z_grid(
    hws_ms,
    amplitude_deg,
    period_s,
    wd_deg,
    lidar,
    *,
    nphase,
    amplitude2_deg,
    period2_s,
    lever_arm_m,
    method,
    sign_ambiguity,
    pitch_amplitude_deg,
    nphase_scan,
):
    """``Z`` (m/s) on the phase grid, one axis per phase (roll 1[, 2], pitch 1[, 2], scan),
    and whether the scan axis is a uniform grid of the scan phase (VAD; DBS: the beams)."""
    g = get_lidar(lidar)
    wind, comps, pcomps, arm = _motion_setup(
        hws_ms,
        amplitude_deg,
        period_s,
        wd_deg,
        amplitude2_deg,
        period2_s,
        lever_arm_m,
        pitch_amplitude_deg,
    )
    nscan = _SCAN_PHASE_FACTOR * nphase if nphase_scan is None else int(nphase_scan)
    if method == "auto":
        method = "fourier" if (g.kind == "vad" and not sign_ambiguity) else "direct"
    if method == "fourier":
        if g.kind != "vad" or sign_ambiguity:
            raise ValueError("sigma_z_grid: method='fourier' needs a VAD lidar and signed speeds")
        m = len(comps)
        hws = _hws_vad(g, wind, comps, pcomps, arm, nphase, nscan)  # (scan, pitch.., roll..)
        hws = hws.transpose(tuple(range(1 + m, 1 + 2 * m)) + tuple(range(1, 1 + m)) + (0,))
    elif method == "direct":
        hws = _moments_generic(g, wind, comps, pcomps, arm, nphase, nscan, sign_ambiguity)
        hws = hws.reshape((nphase,) * (2 * len(comps)) + (-1,))
    else:
        raise ValueError(
            f"sigma_z_grid: method must be 'auto', 'fourier' or 'direct', got {method!r}"
        )
    return hws - hws_ms, g.kind == "vad"  # Eq. (1) of Gutiérrez-Antuñano et al. (2018)


def sigma_z_direction_average(
    hws_ms: float,
    amplitude_deg: float,
    period_s: float,
    lidar: str | LidarGeometry = "zephir300",
    *,
    lever_arm_m=0.0,
    nphase: int = 16,
    n_wd: int = 16,
) -> tuple[float, float]:
    """sigma_Z and E(Z) averaged over uniformly distributed wind directions (VAD).

    The retrieved wind is linear in the wind vector and in the lever arm, so the scan-phase
    coefficients are computed once for a unit east wind, a unit north wind and the lever
    arm, and combined for ``n_wd`` equally spaced directions (exact for the direction
    harmonics below ``n_wd``).

    Parameters
    ----------
    hws_ms, amplitude_deg, period_s : float
        As in :func:`sigma_z` (fixed grid of ``nphase`` roll/pitch points, 4x scan phases).
    lidar : str or LidarGeometry
        A VAD lidar.
    lever_arm_m : float or array_like of 3
        As in :func:`sigma_z`.
    nphase, n_wd : int
        Quadrature points per roll/pitch phase and number of directions.

    Returns
    -------
    sigma_rms_ms : float
        ``sqrt(mean_wd sigma_Z(wd)^2)``, m/s.
    mean_z_ms : float
        ``mean_wd E(Z)(wd)``, m/s.
    """
    g = get_lidar(lidar)
    if g.kind != "vad":
        raise ValueError(f"sigma_z_direction_average: needs a VAD lidar, got {g.name!r}")
    arm = (
        np.array([0.0, 0.0, float(lever_arm_m)])
        if np.ndim(lever_arm_m) == 0
        else np.asarray(lever_arm_m, float)
    )
    t_s, _ = scan_times_azimuths(g)
    ang, rate = (x.T for x in _histories([(np.deg2rad(amplitude_deg), period_s)], t_s, nphase))
    zero = np.zeros(3)
    a_x = vad_hws_coefficients(g, (1.0, 0.0), ang, rate, ang, rate, zero)
    a_y = vad_hws_coefficients(g, (0.0, 1.0), ang, rate, ang, rate, zero)
    a_l = vad_hws_coefficients(g, (0.0, 0.0), ang, rate, ang, rate, arm)
    nscan = _SCAN_PHASE_FACTOR * nphase
    q = np.exp(-2j * np.pi * np.arange(nscan) / nscan)
    wd = 2.0 * np.pi * np.arange(n_wd) / n_wd
    u_x, u_y = -hws_ms * np.sin(wd), -hws_ms * np.cos(wd)
    coef = u_x[:, None, None, None] * a_x + u_y[:, None, None, None] * a_y + a_l  # (nwd, 3, mr, mp)
    h = coef[:, 0, :, :, None] + coef[:, 1, :, :, None] * q + coef[:, 2, :, :, None] * q**2
    z = np.abs(h) - hws_ms  # Eq. (1) of Gutiérrez-Antuñano et al. (2018)
    mean = z.mean(axis=(1, 2, 3))
    var = ((z - mean[:, None, None, None]) ** 2).mean(
        axis=(1, 2, 3)
    )  # Eq. (4) of Gutiérrez-Antuñano et al. (2018)
    return float(np.sqrt(np.mean(var))), float(np.mean(mean))


def sigma_z(
    hws_ms: float,
    amplitude_deg: float,
    period_s: float,
    wd_deg: float = 0.0,
    lidar: str | LidarGeometry = "zephir300",
    *,
    amplitude2_deg: float | None = None,
    period2_s: float | None = None,
    lever_arm_m=0.0,
    rtol: float = 1e-6,
    nphase_start: int | None = None,
    nphase_max: int | None = None,
    sign_ambiguity: bool = False,
    pitch_amplitude_deg: float | None = None,
) -> SigmaZResult:
    """Motion-induced HWS error std sigma_Z and mean E(Z) (Gutiérrez-Antuñano et al., 2018, Eqs. 1-14).

    Roll and pitch are harmonic with equal amplitude and period and independent uniform
    phases; the scan phase is uniform too (Gutiérrez-Antuñano et al., 2018, Secs. 2.3-2.4). The phase integrals
    use the trapezoid rule on uniform periodic grids (geometrically convergent for this
    smooth periodic integrand), doubled from ``nphase_start`` until the error estimate is
    below ``rtol``: the change from the nested half grid (every second point, no extra
    evaluation) times the contraction ``rho ** (N / 2)`` that geometric convergence at a
    rate ``rho`` per point implies from ``N / 2`` to ``N`` points. ``rho`` is bounded a
    priori from the motion (VAD kernel, one period >= 2 s, amplitude <= 20 deg, lever-arm
    ratio ``lambda = A omega |r| / HWS < 0.5``):
    ``rho <= 0.05 + 0.8 A + 2.5 lambda`` (``A`` the larger of the roll and pitch
    amplitudes, rad), about 1.3 times the envelope measured against a 64-point reference
    (docs/simulator.md); elsewhere the contraction is 1 (the plain half-grid difference).

    Parameters
    ----------
    hws_ms : float
        True horizontal wind speed, m/s (>= 0).
    amplitude_deg : float
        Roll and pitch amplitude, deg, in [0, 45]. With a second component this is the
        amplitude of the first one (``A1``).
    period_s : float
        Roll and pitch period, s (> 0).
    wd_deg : float
        Wind direction (from, clockwise from north), deg.
    lidar : str or LidarGeometry
        Default ``"zephir300"``.
    amplitude2_deg, period2_s : float, optional
        Second harmonic component of both roll and pitch (two-period motion, each with
        its own uniform phases: 5 phases in total). Give both or neither.
    lever_arm_m : float or array_like of 3
        Head height above the rotation centre (body vector ``(0, 0, h)``) or a body-frame
        vector, m. Adds ``omega x r`` to the head velocity.
    rtol : float
        Relative convergence tolerance on sigma_Z (and on E(Z) relative to
        ``max(sigma_Z, |E(Z)|)``).
    nphase_start, nphase_max : int
        First (even) and largest number of roll/pitch points per phase (the scan phase
        gets 4 times more, see :func:`sigma_z_grid`). Default start: 8 where ``rho < 0.2``,
        12 where ``rho < 0.35``, else 16. Default max: 256 for one period, 64 for
        two periods; direct method 64, or 16 with two periods or ``sign_ambiguity``.
    sign_ambiguity : bool
        VAD only: simulate the CW ``|v_r|`` and its nonlinear fit (slow direct method).
        Default False: Gutiérrez-Antuñano et al.'s (2018) linear VAD retrieval on signed speeds.
    pitch_amplitude_deg : float, optional
        Pitch amplitude if it differs from the roll amplitude ``amplitude_deg`` (e.g. 0
        for roll-only motion, Gutiérrez-Antuñano et al. (2018), Sec. 2.5); a second component is scaled alike.

    Returns
    -------
    SigmaZResult

    Raises
    ------
    ValueError
        Non-finite or out-of-range arguments, unknown lidar.
    """
    g = get_lidar(lidar)
    hws = _check_scalar("hws_ms", hws_ms, lo=0.0)
    amp = _check_scalar("amplitude_deg", amplitude_deg, lo=0.0, hi=45.0)
    pamp = None
    if pitch_amplitude_deg is not None:
        pamp = _check_scalar("pitch_amplitude_deg", pitch_amplitude_deg, lo=0.0, hi=45.0)
        if amp == 0.0 and pamp > 0.0:
            raise ValueError(
                "sigma_z: pitch_amplitude_deg > 0 needs amplitude_deg > 0 (use pitch as roll)"
            )
    per = _check_scalar("period_s", period_s, lo=0.0, lo_open=True)
    wd = _check_scalar("wd_deg", wd_deg)
    if (amplitude2_deg is None) != (period2_s is None):
        raise ValueError("sigma_z: give both amplitude2_deg and period2_s, or neither")
    two = amplitude2_deg is not None
    if two:
        amp2 = _check_scalar("amplitude2_deg", amplitude2_deg, lo=0.0, hi=45.0)
        per2 = _check_scalar("period2_s", period2_s, lo=0.0, lo_open=True)
    arm = np.atleast_1d(np.asarray(lever_arm_m, dtype=float))
    if arm.shape not in ((1,), (3,)) or not np.all(np.isfinite(arm)):
        raise ValueError(
            f"sigma_z: lever_arm_m must be a finite number or 3-vector, got {lever_arm_m!r}"
        )
    _check_scalar("rtol", rtol, lo=0.0, lo_open=True)
    fast = g.kind == "vad" and not sign_ambiguity
    if nphase_max is None:
        if fast:
            nphase_max = 64 if two else 256
        else:  # the direct method is much slower; the CW |v_r| fit is also non-smooth
            nphase_max = 16 if (two or sign_ambiguity) else 64
    wind, comps, pcomps, arm3 = _motion_setup(
        hws,
        amp,
        per,
        wd,
        amp2 if two else None,
        per2 if two else None,
        float(arm[0]) if arm.shape == (1,) else arm,
        pamp,
    )
    rho = _rate_bound(comps, pcomps, arm3, hws) if fast else 1.0
    if nphase_start is None:  # measured: rho < 0.2 mostly passes at 8, rho < 0.35 at 12
        nphase_start = 8 if rho < 0.2 else (12 if rho < 0.35 else 16)
    n = _check_scalar("nphase_start", nphase_start)
    if n < 2 or n % 2 or n != int(n):
        raise ValueError(f"sigma_z: nphase_start must be an even number >= 2, got {nphase_start!r}")
    n = int(n)
    # moments of round-off size (no motion): the retrieved HWS differs from hws_ms by a few
    # ulp per grid point, ~1e-14 hws_ms (hypothesis found 4.3e-14 m/s at 2 m/s and 1e-12
    # deg), which no finer grid resolves; 1e-12 m/s is no physical motion-induced error
    tiny = 1e-12 * max(hws, 1.0)
    while True:
        if fast:  # the kernel's retrieved HWS itself: Z = HWS_retrieved - hws (Eq. 1 of Gutiérrez-Antuñano et al. (2018))
            z = _hws_vad(g, wind, comps, pcomps, arm3, n, _SCAN_PHASE_FACTOR * n)
            scan_nested, shift = True, hws
        else:
            z, scan_nested = _z_grid(
                hws,
                amp,
                per,
                wd,
                g,
                nphase=n,
                method="direct",
                nphase_scan=None,
                amplitude2_deg=amp2 if two else None,
                period2_s=per2 if two else None,
                lever_arm_m=arm3,
                sign_ambiguity=sign_ambiguity,
                pitch_amplitude_deg=pamp,
            )
            shift = 0.0
        (s, m), half = _moments(z), _moments(_subgrid(z, 2, scan_nested))
        m -= shift
        # the half grid's error (nested: no second evaluation) contracted by rho^(n/2)
        err = max(abs(s - half[0]), abs(m + shift - half[1])) * min(1.0, rho ** (n // 2))
        scale = max(s, abs(m))
        if err <= rtol * scale or scale <= tiny or 2 * n > nphase_max:
            break
        n *= 2
    converged = bool(err <= rtol * scale or scale <= tiny)
    return SigmaZResult(s, m, n, float(err), converged, "vad-fourier" if fast else "direct")


# A-priori bound of the per-point geometric rate of the phase quadrature: the
# trapezoid error of this smooth periodic integrand falls like rho^N, rho set by the size of
# the perturbation of the retrieved wind (tilt amplitude A and lever-arm head speed over the
# wind speed). Measured envelope of (err(N) / err(N/2))^(2/N), N = 8, 12, 16, against a
# 64-point reference over 500 cases (2-21 m/s, 0-25 deg, 2-20 s, lever arm 0-3 m, any
# direction, equal / half / zero pitch; docs/simulator.md): rho <= 0.04 + 0.6 A + 1.9 lambda
# for lambda < 0.5; used with ~1.3x margin, where it was checked: A <= 20 deg (above, near
# T = 2 s, the convergence stalls at 1e-5 for a while: no bound).
_RATE_BOUND = (0.05, 0.8, 2.5)  # (constant, per rad of amplitude, per unit lambda)
_RATE_AMPLITUDE_MAX_RAD = math.radians(20.0)
_RATE_LAMBDA_MAX = 0.5  # beyond: the retrieved vector can pass near 0, a cusp (no bound)
_RATE_PERIOD_MIN_S = 2.0  # shorter periods approach the scan period: not bounded here


def _rate_bound(comps, pcomps, arm_m: np.ndarray, hws_ms: float) -> float:
    """A-priori bound on the geometric convergence rate per phase point (1.0: no bound).

    ``comps``/``pcomps`` are the roll/pitch ``(amplitude rad, period s)`` components, ``arm_m``
    the lever arm (m), ``hws_ms`` the wind speed (m/s). Bounded for one period >= 2 s and
    a lever-arm ratio ``lambda = A omega |r| / HWS < 0.5``, amplitude ``A <= 20`` deg.
    """
    if len(comps) != 1 or comps[0][1] < _RATE_PERIOD_MIN_S:
        return 1.0
    amp = max(comps[0][0], pcomps[0][0])
    if amp > _RATE_AMPLITUDE_MAX_RAD:
        return 1.0
    arm = math.sqrt(float(arm_m @ arm_m))
    head_speed = amp * 2.0 * math.pi / comps[0][1] * arm  # m/s
    if head_speed == 0.0:
        lam = 0.0
    elif hws_ms > 0.0:
        lam = head_speed / hws_ms
    else:
        return 1.0
    if lam >= _RATE_LAMBDA_MAX:
        return 1.0
    c0, c_amp, c_lam = _RATE_BOUND
    return min(1.0, c0 + c_amp * amp + c_lam * lam)
