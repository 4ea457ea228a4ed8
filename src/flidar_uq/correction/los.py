"""LOS-level motion correction of floating-lidar wind retrievals (Malekmohammadi et al., 2024; Yamaguchi and Ishihara, 2016; Nassif et al., 2020).

Size: the LOS-level corrections share the beam geometry helpers; one module keeps the methods comparable (~600 lines, half of it docstrings).

When the line-of-sight (LOS) speeds and the IMU series are available, the motion can be
removed scan by scan instead of statistically (``correction.py``). Two published
methods are implemented, both in the project's ENU frame (``docs/conventions.md``):

* Malekmohammadi et al. (2024) (Grimstad hexapod), Eq. (7): least-squares wind vector from the LOS speeds
  with every beam rotated by the platform attitude at its own LOS time and the head
  velocity projected out, ``u = [(RN)^T RN]^-1 (RN)^T (v_r - v_rT)``.
  :func:`correct_least_squares` (VAD / CW with its sign ambiguity, and DBS / pulsed).
* Yamaguchi and Ishihara (2016), pulsed DBS lidar: LOS speeds interpolated along
  each beam to the target height, then the horizontal wind in the two opposite-beam
  planes; the *conventional* algorithm freezes attitude and velocity at the reference
  LOS of the DBS cycle, the *new* one uses them at each LOS time.
  :func:`correct_dbs_motion`.

Frames: Malekmohammadi et al. (2024) uses x south, y west, z down (its attitude and
velocity are converted to ENU before they enter here); Yamaguchi and Ishihara's (2016)
Eq. (3) read with its Table 1 beam order gives ``u`` from ``V_W - V_E`` but ``v`` from
``V_N - V_S`` (inconsistent signs as printed; here both from speeds positive away); Nassif
et al. (2020) use ENU with our rotation order (its Eq. 4 has a typo, ``R[0, 1] = 1``, read as 0).

Radial speeds are positive away from the lidar, ``v_r = d_earth . (u - v_head)``, so the
corrected LOS speed entering every solver is ``v_r + d_earth . v_head``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from flidar_uq.physics.lidar import (
    LidarGeometry,
    beam_index,
    beam_unit_vectors_body,
    get_lidar,
    scan_times_azimuths,
    wind_direction_deg,
)
from flidar_uq.physics.motion import rotation_matrix

__all__ = [
    "WindEstimate",
    "imu_rotation_velocity",
    "earth_beam_vectors",
    "correct_least_squares",
    "correct_dbs_motion",
]


@dataclass(frozen=True)
class WindEstimate:
    """Wind vectors retrieved window by window from LOS data.

    Attributes
    ----------
    t_s : numpy.ndarray
        Reference time of each window (s), shape ``(nwin,)``.
    u_ms, v_ms, w_ms : numpy.ndarray
        ENU wind components (m/s), shape ``(nwin,)`` or ``(nwin, nheight)``;
        ``w_ms`` is NaN for Yamaguchi and Ishihara (2016) (horizontal-only algorithm).
    hws_ms : numpy.ndarray
        Horizontal wind speed ``sqrt(u^2 + v^2)`` (m/s), same shape.
    wd_deg : numpy.ndarray
        Meteorological wind direction (deg, from, clockwise from north), same shape.
    residual_ms : numpy.ndarray
        RMS least-squares residual of the window (m/s); NaN where not defined.
    """

    t_s: np.ndarray
    u_ms: np.ndarray
    v_ms: np.ndarray
    w_ms: np.ndarray
    hws_ms: np.ndarray
    wd_deg: np.ndarray
    residual_ms: np.ndarray


def _wind_estimate(t_s, u, v, w, residual) -> WindEstimate:
    return WindEstimate(t_s, u, v, w, np.hypot(u, v), wind_direction_deg(u, v), residual)


def _check_los(t_s, azimuth_rad, radial_speed_ms, where: str, ndim_radial=(1,), geom=None):
    t = np.asarray(t_s, dtype=float)
    az = np.asarray(azimuth_rad, dtype=float)
    vr = np.asarray(radial_speed_ms, dtype=float)
    if t.ndim != 1 or t.size == 0:
        raise ValueError(f"{where}: t_s must be a non-empty 1-D array, got shape {t.shape}")
    if az.shape != t.shape:
        raise ValueError(
            f"{where}: azimuth_rad shape {az.shape} does not match t_s shape {t.shape}"
        )
    if vr.ndim not in ndim_radial or vr.shape[0] != t.size:
        raise ValueError(
            f"{where}: radial_speed_ms shape {vr.shape} must be "
            f"{' or '.join('(n,)' if d == 1 else '(n, nlevel)' for d in ndim_radial)}"
            f" with n = len(t_s) = {t.size}"
        )
    vertical_ok = geom is not None and geom.vertical_beam
    if not (np.all(np.isfinite(t)) and np.all(np.isfinite(az) | (vertical_ok & np.isnan(az)))):
        raise ValueError(
            f"{where}: t_s and azimuth_rad must be finite (NaN azimuth only marks the "
            "vertical beam of a DBS lidar that has one)"
        )
    if t.size > 1 and np.any(np.diff(t) <= 0):
        i = int(np.argmax(np.diff(t) <= 0))
        raise ValueError(f"{where}: t_s must be strictly increasing (t_s[{i + 1}] <= t_s[{i}])")
    return t, az, vr


def _window_index(n: int, size: int, step: int, where: str) -> np.ndarray:
    if step < 1:
        raise ValueError(f"{where}: step must be >= 1, got {step}")
    if n < size:
        raise ValueError(f"{where}: {n} LOS are fewer than one window of {size} LOS")
    nwin = (n - size) // step + 1
    return np.arange(nwin)[:, None] * step + np.arange(size)[None, :]


def imu_rotation_velocity(motion, t_s) -> tuple[np.ndarray, np.ndarray]:
    """Body-to-earth rotation matrices and head velocities from an IMU motion model.

    Parameters
    ----------
    motion : PlatformMotion or SampledMotion or None
        Anything with ``attitude_rad(t_s) -> (roll, pitch, yaw)`` and
        ``head_velocity_ms(t_s) -> (..., 3)`` (``flidar_uq.physics.motion``). ``None``: no
        motion information (identity rotation, zero velocity: the uncorrected retrieval).
    t_s : array_like
        LOS times (s), shape ``(n,)``.

    Returns
    -------
    rotation : numpy.ndarray
        ``R = Rz(yaw) Ry(pitch) Rx(roll)`` at each time, shape ``(n, 3, 3)``.
    head_velocity_ms : numpy.ndarray
        Earth-frame velocity of the lidar head (m/s), shape ``(n, 3)``.
    """
    t = np.asarray(t_s, dtype=float)
    if motion is None:
        rot = np.broadcast_to(np.eye(3), (*t.shape, 3, 3))
        return rot, np.zeros((*t.shape, 3))
    if not (hasattr(motion, "attitude_rad") and hasattr(motion, "head_velocity_ms")):
        raise ValueError(
            f"imu_rotation_velocity: motion of type {type(motion).__name__} has no "
            "attitude_rad/head_velocity_ms methods (use flidar_uq.physics.motion models or None)"
        )
    roll, pitch, yaw = motion.attitude_rad(t)
    rot = rotation_matrix(roll, pitch, yaw)
    vel = np.broadcast_to(np.asarray(motion.head_velocity_ms(t), dtype=float), (*t.shape, 3))
    return rot, vel


def earth_beam_vectors(lidar, azimuth_rad, rotation) -> np.ndarray:
    """Earth-frame unit vectors of the beams: ``d_earth = R @ d_body``.

    Parameters
    ----------
    lidar : LidarGeometry or str
        Scan geometry (``flidar_uq.physics.lidar``).
    azimuth_rad : array_like
        Body-frame beam azimuths (rad, clockwise from body y), shape ``(n,)``.
    rotation : array_like
        Body-to-earth rotation matrices, shape ``(n, 3, 3)`` or ``(3, 3)``.

    Returns
    -------
    numpy.ndarray
        Unit vectors (-), shape ``(n, 3)``.
    """
    d_body = beam_unit_vectors_body(get_lidar(lidar), np.asarray(azimuth_rad, dtype=float))
    return np.einsum("...ij,...j->...i", rotation, d_body)


def _ls_operator(a, valid):
    """Batched least-squares operator of Malekmohammadi et al. (2024), Eq. (7) over the valid LOS.

    a (nwin, k, 3) earth-frame beam vectors; valid (nwin, k). Returns the operator
    ``[(RN)^T RN]^-1 (RN)^T`` (nwin, 3, k), with invalid LOS weighted 0, and a (nwin,)
    flag of solvable windows (>= 3 valid LOS, non-singular geometry).
    """
    aw_t = np.swapaxes(a * valid[..., None], 1, 2)
    ata = aw_t @ a
    ok = (valid.sum(axis=1) >= 3) & (np.abs(np.linalg.det(ata)) > 1e-9)
    return np.linalg.solve(np.where(ok[:, None, None], ata, np.eye(3)), aw_t), ok


def _apply_ls(op, a, valid, b):
    """u = op b and the RMS residual over valid LOS; b (nwin, k, c) -> u (nwin, 3, c)."""
    b0 = np.where(valid[..., None], b, 0.0)
    u = op @ b0  # Eq. (7) of Malekmohammadi et al. (2024)
    r2 = np.sum(((a @ u - b0) * valid[..., None]) ** 2, axis=1)
    return u, np.sqrt(r2 / np.maximum(valid.sum(axis=1), 1)[:, None])


def _ls_unsigned(
    a, valid, m, vproj, ncandidates: int, niter: int, reference_wd_deg=None, nstart: int = 2
):
    """Malekmohammadi et al. (2024), Eq. (7) for a CW lidar reporting |v_r| (Malekmohammadi et al., 2024, Eq. 4).

    The sign of each LOS speed is unknown. Candidate sign patterns: those of an
    algebraic fit of ``m^2 - vp^2 = d^T (u u^T) d - 2 vp d.u`` (linear in the entries of
    ``u u^T`` and in ``u``), with ``u`` taken either from its linear part (exact when the
    head velocity identifies it) or, up to sign, from ``u u^T`` (exact without head
    velocity; the start of ``lidar.retrieve_wind``'s |A cos + C| fit), each with its
    opposite; the patterns of horizontal winds from ``ncandidates`` directions; and the
    two one-signed patterns (no zero crossing when ``|w| cos th > hws sin th``). The best
    ``nstart`` candidates and their opposites (the 180-deg ambiguity) are refined by the
    fixed-point iteration ``s = sign(d . u - d . v_head)``; the solution is then chosen by
    residual and direction (below).
    """
    nwin, k = m.shape
    op, ok = _ls_operator(a, valid)
    a0 = np.where(valid[..., None], a, 0.0)
    vp0 = np.where(valid, vproj, 0.0)
    dx, dy, dz = a0[..., 0], a0[..., 1], a0[..., 2]
    basis = np.stack(
        [dx * dx, dy * dy, dz * dz, 2 * dx * dy, 2 * dx * dz, 2 * dy * dz]
        + [-2.0 * vp0 * dx, -2.0 * vp0 * dy, -2.0 * vp0 * dz],
        axis=-1,
    )
    rhs = np.where(valid, m**2 - vproj**2, 0.0)[..., None]
    btb = np.swapaxes(basis, 1, 2) @ basis
    ridge = 1e-10 * np.trace(btb, axis1=1, axis2=2)[:, None, None] * np.eye(9) + 1e-300
    coef = np.linalg.solve(btb + ridge, np.swapaxes(basis, 1, 2) @ rhs)  # ~ min-norm
    proj_lin = (a @ coef[:, 6:])[..., 0]
    # u up to sign from the identifiable entries of u u^T (level cone: S_xx + S_yy and
    # S_zz are not separable): (u + i v)^2 = S_xx - S_yy + 2 i S_xy, w from S_xz, S_yz.
    c = coef[..., 0]
    uv = np.sqrt((c[:, 0] - c[:, 1]) + 2j * c[:, 3])
    h2 = np.abs(uv) ** 2
    w0 = (uv.real * c[:, 4] + uv.imag * c[:, 5]) / np.where(h2 > 0, h2, 1.0)
    proj_sq = a @ np.stack([uv.real, uv.imag, w0], axis=-1)[..., None]
    nc = 2 * (ncandidates // 2)
    phi = 2.0 * np.pi * np.arange(nc) / nc
    e = np.stack([np.sin(phi), np.cos(phi)])  # (2, nc)
    ones = np.ones((nwin, k, 1))
    s = np.concatenate(
        [
            np.sign(proj_lin - vproj)[..., None],
            np.sign(-proj_lin - vproj)[..., None],
            np.sign(proj_sq[..., 0] - vproj)[..., None],
            np.sign(-proj_sq[..., 0] - vproj)[..., None],
            np.sign(a[..., :2] @ e),
            ones,
            -ones,
        ],
        axis=-1,
    )  # (nwin, k, ncand)
    s[s == 0] = 1.0
    mirror = np.r_[1, 0, 3, 2, 4 + (np.arange(nc) + nc // 2) % nc, nc + 5, nc + 4]
    b = s * m[..., None] + vproj[..., None]
    _, res = _apply_ls(op, a, valid, b)
    # refine the `nstart` best candidates and their opposites
    order = np.argsort(np.where(np.isfinite(res), res, np.inf), axis=1)[:, :nstart]
    starts = np.concatenate([order, mirror[order]], axis=1)  # (nwin, 2 nstart)
    b = np.take_along_axis(b, starts[:, None, :], axis=2)
    u, res = _apply_ls(op, a, valid, b)
    for _ in range(niter):
        s = np.sign(a @ u - vproj[..., None])
        s[s == 0] = 1.0
        u, res = _apply_ls(op, a, valid, s * m[..., None] + vproj[..., None])
    # The 180-deg branch (Malekmohammadi et al., 2024, Eq. 4: B = Theta or Theta +- 180 deg). Only the head
    # velocity separates the two branches; when it is nearly uniform over a scan the mirror
    # fits almost as well and turbulence decides scan by scan, wrongly a third of the time
    # (measured). So a scan takes its lowest-residual solution only when it beats every
    # solution pointing the other way (> 90 deg apart) decisively; otherwise the
    # lowest-residual solution within 90 deg of a reference direction: ``reference_wd_deg``
    # (a vane) if given, else the orientation of the record's wind axis with the lower
    # total squared residual (the record-level sum averages the turbulence out); with no
    # head velocity at all (exact ties) lidar.retrieve_wind's rule, direction in [0, 180).
    res_f = np.where(np.isfinite(res), res, np.inf)
    rows = np.arange(nwin)
    best = np.argmin(res_f, axis=1)
    lo = res_f[rows, best]
    wd = wind_direction_deg(u[:, 0, :], u[:, 1, :])  # (nwin, 2 nstart)

    def dist(ref_deg):
        return np.abs((wd - np.asarray(ref_deg)[..., None] + 180.0) % 360.0 - 180.0)

    hi = np.min(np.where(dist(wd[rows, best]) > 90.0, res_f, np.inf), axis=1)
    decisive = np.isfinite(lo) & (hi - lo > 0.05 + 2.0 * lo)

    def nearest(ref_deg):
        near = dist(ref_deg) <= 90.0
        choice = np.argmin(np.where(near, res_f, np.inf), axis=1)
        return np.where(decisive | ~np.any(near, axis=1), best, choice)

    fin = np.isfinite(lo)
    if reference_wd_deg is not None:
        pick = nearest(reference_wd_deg)
    elif not np.any(fin & (np.isfinite(hi) & (hi - lo > 1e-9 * (1.0 + lo)))):
        pick = nearest(90.0)  # no head velocity: exact ties; direction in [0, 180)
    else:
        two = np.radians(2.0 * wd[fin, best[fin]])  # wind axis: doubled-angle mean
        axis = 0.5 * np.degrees(np.arctan2(np.mean(np.sin(two)), np.mean(np.cos(two))))
        picks = [nearest(axis), nearest(axis + 180.0)]
        score = [np.sum(np.where(fin, res_f[rows, p], 0.0) ** 2) for p in picks]
        pick = picks[int(np.argmin(score))]
    u_pick, res_pick = u[rows, :, pick], res_f[rows, pick]
    # Neighbour pass: the wind changes little from one scan to the next, so the chosen
    # solutions of the adjacent windows are starts that escape local sign patterns.
    # After the first pass only the neighbours of improved windows are retried.
    w = np.arange(nwin)
    for _ in range(3 if nwin > 1 else 0):  # a bad run of scans is repaired from its ends
        nb = np.stack([u_pick[np.maximum(w - 1, 0)], u_pick[np.minimum(w + 1, nwin - 1)]], -1)
        for _ in range(niter + 1):
            s = np.sign(a[w] @ nb - vproj[w][..., None])
            s[s == 0] = 1.0
            nb, res_nb = _apply_ls(op[w], a[w], valid[w], s * m[w][..., None] + vproj[w][..., None])
        res_nb = np.where(np.isfinite(res_nb), res_nb, np.inf)
        j = np.argmin(res_nb, axis=1)
        r = np.arange(w.size)
        better = res_nb[r, j] < res_pick[w] - 1e-12
        u_pick[w[better]] = nb[r, :, j][better]
        res_pick[w[better]] = res_nb[r, j][better]
        w = np.unique(np.clip(np.r_[w[better] - 1, w[better] + 1], 0, nwin - 1))
        if w.size == 0:
            break
    return u_pick, np.where(np.isfinite(res_pick), res_pick, np.nan), ok


def correct_least_squares(
    lidar,
    t_s,
    azimuth_rad,
    radial_speed_ms,
    motion=None,
    *,
    los_per_window: int | None = None,
    step: int | None = None,
    rotation=None,
    head_velocity_ms=None,
    ncandidates: int = 8,
    niter: int = 2,
    reference_wd_deg: float | None = None,
) -> WindEstimate:
    """Least-squares motion-corrected wind vector per scan (Eq. 7 of Malekmohammadi et al. (2024)).

    Each LOS keeps its own attitude and head velocity (interpolated from the IMU at the
    LOS time): ``d_i = R(t_i) d_body(az_i)``, corrected speed ``y_i = v_r,i + d_i . v_head(t_i)``
    and ``u = (A^T A)^-1 A^T y`` with ``A`` the stacked ``d_i`` of one window.
    Vectorised across windows.

    A CW lidar reports ``|v_r|`` (Malekmohammadi et al., 2024, Eq. 4): the sign of every LOS is resolved with
    the wind (candidate sign patterns refined by fixed-point iteration, then the previous
    and next scans' solutions as starts), and the 180-deg branch, which only the head
    velocity separates, is chosen per record (see ``reference_wd_deg``). So CW windows
    of one call are not independent: pass a whole record, not scans one by one.

    Parameters
    ----------
    lidar : LidarGeometry or str
        ``"zephir300"`` (CW VAD, unsigned speeds) or a pulsed DBS geometry.
    t_s : array_like
        LOS times (s), shape ``(n,)``, strictly increasing; the record starts at the first
        LOS of a scan.
    azimuth_rad : array_like
        Body-frame beam azimuths (rad), shape ``(n,)``.
    radial_speed_ms : array_like
        Measured radial speeds (m/s, positive away; ``|v_r|`` for a CW lidar), shape
        ``(n,)``; NaN marks a missing LOS.
    motion : PlatformMotion or SampledMotion or None
        IMU motion model; ``None`` gives the uncorrected (body-geometry) retrieval.
    los_per_window : int, optional
        LOS per retrieval window; default ``lidar.n_los`` (one scan / DBS cycle).
    step : int, optional
        LOS between successive windows; default ``los_per_window`` (non-overlapping).
    rotation, head_velocity_ms : array_like, optional
        Explicit per-LOS rotation matrices ``(n, 3, 3)`` and head velocities ``(n, 3)``
        (ENU body-to-earth, e.g. converted from another frame's attitude), used instead of
        ``motion``.
    ncandidates, niter : int
        CW sign resolution: number of candidate sign patterns and refinement iterations.
    reference_wd_deg : float, optional
        CW only: direction (deg, e.g. from a vane) that selects the 180-deg branch of the
        scans the head velocity does not decide (residual gap < 0.05 m/s + 2 x residual).
        Default: the orientation of the record's wind axis with the lower total squared
        residual; with no head velocity at all, the branch with direction in [0, 180)
        (``lidar.retrieve_wind``'s rule).

    Returns
    -------
    WindEstimate
        One wind vector per window, ``t_s`` the mean LOS time of the window. Windows
        with fewer than 3 valid LOS or a singular geometry give NaN.
    """
    where = "correct_least_squares"
    geom: LidarGeometry = get_lidar(lidar)
    t, az, vr = _check_los(t_s, azimuth_rad, radial_speed_ms, where, geom=geom)
    size = int(los_per_window or geom.n_los)
    idx = _window_index(t.size, size, int(step or size), where)
    if rotation is None:
        rot, vel = imu_rotation_velocity(motion, t)
    else:
        rot = np.asarray(rotation, dtype=float)
        vel = np.asarray(head_velocity_ms if head_velocity_ms is not None else np.zeros(3))
        if rot.shape != (t.size, 3, 3):
            raise ValueError(f"{where}: rotation shape {rot.shape} must be ({t.size}, 3, 3)")
        if vel.shape not in ((3,), (t.size, 3)):
            raise ValueError(
                f"{where}: head_velocity_ms shape {vel.shape} must be (3,) or ({t.size}, 3)"
            )
        vel = np.broadcast_to(vel, (t.size, 3))
    d = earth_beam_vectors(
        geom, az, rot
    )  # R N of Eq. (5) of Malekmohammadi et al. (2024), row by row
    vproj = np.einsum(
        "ni,ni->n", d, vel
    )  # v_rT of Eq. (7) of Malekmohammadi et al. (2024) (per LOS)
    a, m, vp = d[idx], vr[idx], vproj[idx]
    valid = np.isfinite(m)
    if geom.signed:
        op, ok = _ls_operator(a, valid)
        u, res = _apply_ls(
            op, a, valid, (m + vp)[..., None]
        )  # Eq. (7) of Malekmohammadi et al. (2024)
        u, res = u[..., 0], res[:, 0]
    else:
        if np.any(m[valid] < 0):
            raise ValueError(f"{where}: CW lidar {geom.name!r} needs |v_r| >= 0 (negative found)")
        u, res, ok = _ls_unsigned(a, valid, m, vp, ncandidates, niter, reference_wd_deg)
    u = np.where(ok[:, None], u, np.nan)
    res = np.where(ok, res, np.nan)
    return _wind_estimate(t[idx].mean(axis=1), u[:, 0], u[:, 1], u[:, 2], res)


def _beam_ids(geom: LidarGeometry, az: np.ndarray, where: str) -> np.ndarray:
    """Index of each LOS in the lidar's scan pattern, matched by body azimuth."""
    ids = beam_index(geom, az)
    bad = ids < 0
    if np.any(bad):
        i = int(np.argmax(bad))
        raise ValueError(
            f"{where}: azimuth_rad[{i}] = {az[i]:.6f} rad is not a beam of {geom.name!r}"
        )
    return ids


def _interp_along_beam(vr, range_m, target_range_m):
    """Linear interpolation of LOS speeds from range gates to target ranges.

    vr (nwin, k, nlev); range_m (nlev,) increasing; target (nwin, k, nh). NaN outside. A
    target on a gate takes that gate's speed, so a missing neighbouring gate does not spoil it.
    """
    j = np.clip(np.searchsorted(range_m, target_range_m) - 1, 0, range_m.size - 2)
    r0, r1 = range_m[j], range_m[j + 1]
    f = (target_range_m - r0) / (r1 - r0)
    v0 = np.take_along_axis(vr, j, axis=-1)
    v1 = np.take_along_axis(vr, j + 1, axis=-1)
    out = np.where(f == 0.0, v0, np.where(f == 1.0, v1, v0 + f * (v1 - v0)))
    inside = (target_range_m >= range_m[0] - 1e-9) & (target_range_m <= range_m[-1] + 1e-9)
    return np.where(inside, out, np.nan)


def correct_dbs_motion(
    lidar,
    t_s,
    azimuth_rad,
    radial_speed_ms,
    motion=None,
    *,
    range_height_m,
    target_height_m=None,
    method: str = "new",
    step: int = 1,
) -> WindEstimate:
    """Motion compensation of a pulsed DBS lidar, conventional or new (Yamaguchi and Ishihara, 2016).

    Steps (Yamaguchi and Ishihara, 2016, Sec. 3-4): (1) interpolate each LOS speed along its beam to the
    point at the target height; (2) horizontal wind in the planes of the opposite beams
    (E-W and N-S), with the head velocity added back to each LOS speed; (3) horizontal
    wind vector from the two in-plane horizontal components. ``method="conventional"``
    freezes attitude and velocity at the reference LOS of the window (Yamaguchi and
    Ishihara, 2016, Table 2: the third of four), ``"new"`` uses them at each LOS time (Table 3),
    ``"none"`` is the fixed-lidar DBS formula (Yamaguchi and Ishihara, 2016, Eq. 3) with no motion data.

    Windows are ``lidar.n_los`` consecutive LOS (one DBS cycle; a vertical beam is carried
    but unused, as in Yamaguchi and Ishihara (2016), Table 3) and must hold every beam once. The height of a
    beam point includes the head's height change (``motion.head_displacement_m``: heave and
    lever arm, Yamaguchi and Ishihara (2016), Eq. 4), frozen like the attitude in the conventional algorithm.
    Vectorised across windows and heights.

    Parameters
    ----------
    lidar : LidarGeometry or str
        Pulsed DBS geometry (signed speeds), e.g. ``"windcube_v1"``.
    t_s, azimuth_rad : array_like
        LOS times (s) and body azimuths (rad), shape ``(n,)``.
    radial_speed_ms : array_like
        Radial speeds at the range gates (m/s, positive away), shape ``(n, nlevel)``.
    motion : PlatformMotion or SampledMotion or None
        IMU motion model (required unless ``method="none"``).
    range_height_m : array_like
        Nominal (untilted) heights of the range gates (m), shape ``(nlevel,)``,
        increasing; the gate ranges are ``height / cos(half_cone_angle)``.
    target_height_m : array_like, optional
        Heights to report (m), shape ``(nheight,)``; default ``range_height_m``.
    method : {"new", "conventional", "none"}
        Algorithm.
    step : int
        LOS between windows; 1 (default) gives one estimate per LOS as in Yamaguchi and Ishihara (2016).

    Returns
    -------
    WindEstimate
        Arrays of shape ``(nwin, nheight)``; ``t_s`` is the reference LOS time; ``w_ms``
        and ``residual_ms`` are NaN. Targets outside the gates give NaN.
    """
    where = "correct_dbs_motion"
    geom: LidarGeometry = get_lidar(lidar)
    if not geom.signed or geom.kind != "dbs":
        raise ValueError(f"{where}: needs a pulsed DBS lidar, got {geom.name!r} ({geom.kind})")
    if method not in ("new", "conventional", "none"):
        raise ValueError(f"{where}: method must be 'new', 'conventional' or 'none', got {method!r}")
    if method != "none" and motion is None:
        raise ValueError(f"{where}: method={method!r} needs a motion model (got None)")
    t, az, vr = _check_los(t_s, azimuth_rad, radial_speed_ms, where, ndim_radial=(2,), geom=geom)
    h_gate = np.asarray(range_height_m, dtype=float)
    if h_gate.ndim != 1 or h_gate.size != vr.shape[1] or np.any(np.diff(h_gate) <= 0):
        raise ValueError(
            f"{where}: range_height_m must be increasing with {vr.shape[1]} values "
            f"(one per column of radial_speed_ms), got {h_gate.tolist()}"
        )
    if h_gate.size < 2:
        raise ValueError(f"{where}: height interpolation needs at least 2 range gates")
    h_tgt = h_gate if target_height_m is None else np.atleast_1d(np.asarray(target_height_m, float))
    cos_th = np.cos(np.radians(geom.half_cone_angle_deg))
    range_m = h_gate / cos_th

    size = int(geom.n_los)
    idx = _window_index(t.size, size, step, where)
    ids = _beam_ids(geom, az, where)
    _, az_pattern = scan_times_azimuths(geom)
    d_body_pattern = beam_unit_vectors_body(geom, az_pattern)
    oblique = np.flatnonzero(d_body_pattern[:, 2] < 1.0 - 1e-9)
    pairs = []
    for b in oblique:
        opp = np.flatnonzero(
            np.abs(np.angle(np.exp(1j * (az_pattern[oblique] - az_pattern[b] - np.pi)))) < 1e-6
        )
        if opp.size and b < oblique[opp[0]]:
            pairs.append((b, oblique[opp[0]]))
    if len(pairs) < 2:
        raise ValueError(f"{where}: {geom.name!r} has fewer than two opposite beam pairs")
    win_ids = ids[idx]
    if np.any(np.sort(win_ids, axis=1) != np.arange(size)[None, :]):
        w = int(np.argmax(np.any(np.sort(win_ids, axis=1) != np.arange(size), axis=1)))
        raise ValueError(
            f"{where}: window {w} (LOS {idx[w, 0]}..{idx[w, -1]}) does not hold each of the "
            f"{size} beams once; the LOS sequence is not a regular DBS cycle"
        )
    pos = np.argsort(win_ids, axis=1)  # pos[w, beam] = position of that beam in window w
    ref = idx[
        :, size // 2
    ]  # Table 2 of Yamaguchi and Ishihara (2016): attitude/velocity at t = 3 of t = 1..4

    rot, vel = imu_rotation_velocity(None if method == "none" else motion, t)
    los = np.take_along_axis(idx, pos, axis=1)  # (nwin, size) LOS index ordered by beam
    if method == "conventional":
        rot_w = np.broadcast_to(rot[ref][:, None], (*los.shape, 3, 3))
        vel_w = np.broadcast_to(vel[ref][:, None], (*los.shape, 3))
    else:
        rot_w, vel_w = rot[los], vel[los]
    d = np.einsum("wkij,wkj->wki", rot_w, d_body_pattern[None, :, :])
    # Head height change (heave + lever arm; Eq. 4 of Yamaguchi and Ishihara (2016)), same freezing rule.
    dz = np.zeros(t.size)
    if method != "none" and hasattr(motion, "head_displacement_m"):
        dz = np.asarray(motion.head_displacement_m(t), dtype=float)[..., 2]
    dz_w = dz[ref][:, None] if method == "conventional" else dz[los]
    # Step 1 of Yamaguchi and Ishihara (2016): the point of each beam at the target height, lambda_i
    with np.errstate(divide="ignore", invalid="ignore"):
        r_tgt = (h_tgt[None, None, :] - dz_w[..., None]) / d[..., 2:3]
    r_tgt = np.where(d[..., 2:3] > 0, r_tgt, np.nan)
    v_tgt = _interp_along_beam(vr[los], range_m, np.nan_to_num(r_tgt, nan=-1.0))
    v_tgt = v_tgt + np.einsum("wki,wki->wk", d, vel_w)[..., None]  # step 4: add floater speed

    comps, dirs = [], []
    for b1, b2 in pairs[:2]:  # step 2: horizontal wind in the o-lambda-lambda' planes
        d1, d2 = d[:, b1], d[:, b2]
        normal = np.cross(d1, d2)
        e = np.cross(np.array([0.0, 0.0, 1.0]), normal)
        e /= np.linalg.norm(e, axis=-1, keepdims=True)
        e *= np.sign(np.einsum("wi,wi->w", e, d1))[:, None]
        g11, g12, g22 = (d1 * d1).sum(-1), (d1 * d2).sum(-1), (d2 * d2).sum(-1)
        p1, p2 = (d1 * e).sum(-1), (d2 * e).sum(-1)
        det = g11 * g22 - g12**2
        alpha, beta = (g22 * p1 - g12 * p2) / det, (g11 * p2 - g12 * p1) / det
        comps.append(alpha[:, None] * v_tgt[:, b1] + beta[:, None] * v_tgt[:, b2])
        dirs.append(e[:, :2])
    (e1, e2), (c1, c2) = dirs, comps  # step 3: [e1; e2] (u, v) = (c1, c2)
    det = e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0]
    u = (e2[:, 1, None] * c1 - e1[:, 1, None] * c2) / det[:, None]
    v = (e1[:, 0, None] * c2 - e2[:, 0, None] * c1) / det[:, None]
    nan = np.full_like(u, np.nan)
    return _wind_estimate(t[ref], u, v, nan, nan)
