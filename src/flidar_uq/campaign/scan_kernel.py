"""Compiled line-of-sight loop of the virtual campaign.

One pass over every line of sight of a chunk of records, fusing what
:func:`flidar_uq.campaign.physics_mode._simulate_chunk` did before in ~40 NumPy passes
over ``(records, scans, lines of sight)`` arrays: the attitude's rotation matrix at the
line of sight's time, the beam direction in the earth frame, the lidar head's velocity,
the sheared mean wind at the tilted focus height plus the turbulence, the radial speed
``v_r = d_earth . (u_wind - v_head)`` (Yamaguchi and Ishihara, 2016, Eq. 3, docs/conventions.md) and the VAD
least squares of each scan with the CW sign unfolded (Malekmohammadi et al., 2024, Eq. 4;
:func:`flidar_uq.physics.lidar.vad_sign_unfolding`), and the fixed reference lidar's
radial speeds and fit; then the record's true motion statistics (:func:`attitude_truth`).
The generator calls it a record at a time, right after drawing the record's series.

The arithmetic is the NumPy pipeline's, operation for operation, except for the sums:
BLAS computed the 3-term products (``R @ m``, ``R @ r``) with fused multiply-adds on some
CPUs and the scans' fits (sums over their lines of sight) and NumPy the residuals' means in
their own orders; the kernel adds plain products left to right, on every CPU (LLVM
contracts no multiply-add without fast-math flags). Differences of rounding size only.
The attitude's cosines and sines are computed once per LOS slot, a record at a time into a
scratch array that stays in cache for its lines of sight and its truth (the chunk-wide
:func:`attitude_trig` and :func:`attitude_truth` compute the same, the tests' reference for
the kernel's per-record pass), by libm.

Compiled with numba on first use in a process and cached on disk
(:func:`flidar_uq.compiled.compiled`).
"""

from __future__ import annotations

import math

import numpy as np

from flidar_uq.compiled import compiled

__all__ = ["attitude_trig", "attitude_truth", "simulate_chunk_scans"]


@compiled
def _trig_into(roll_deg, pitch_deg, yaw_deg, c, out, oc):
    """Record ``c``'s cosines and sines (:func:`attitude_trig`) into ``out[:, oc, :]``."""
    n = roll_deg.shape[1]
    to_rad = np.pi / 180.0
    for t in range(n):
        r = roll_deg[c, t] * to_rad
        p = pitch_deg[c, t] * to_rad
        out[0, oc, t] = math.cos(r)
        out[1, oc, t] = math.sin(r)
        out[2, oc, t] = math.cos(p)
        out[3, oc, t] = math.sin(p)
    if yaw_deg.shape[1] == 1:
        y = yaw_deg[c, 0] * to_rad
        cy, sy = math.cos(y), math.sin(y)
        for t in range(n):
            out[4, oc, t] = cy
            out[5, oc, t] = sy
    else:
        for t in range(n):
            y = yaw_deg[c, t] * to_rad
            out[4, oc, t] = math.cos(y)
            out[5, oc, t] = math.sin(y)


@compiled
def attitude_trig(roll_deg, pitch_deg, yaw_deg):
    """Cosines and sines ``cr, sr, cp, sp, cy, sy`` of the attitude, shape (6, C, N).

    ``roll_deg``, ``pitch_deg``: shape (C, N), deg; ``yaw_deg``: (C, N), or (C, 1) for a
    constant heading (one cosine and sine a record, broadcast). The angle in rad is
    ``deg * (pi / 180)`` as ``numpy.deg2rad`` computes it; the cosines and sines are
    libm's.
    """
    n_c, n = roll_deg.shape
    out = np.empty((6, n_c, n))
    for c in range(n_c):
        _trig_into(roll_deg, pitch_deg, yaw_deg, c, out, c)
    return out


@compiled
def _amplitude(x, n):
    """``sqrt(2)`` x the std (``ddof=0``) of ``x[:n]``, two passes (docs/conventions.md).

    Each pass keeps four interleaved partial sums: independent additions pipeline (~3x
    faster than one running sum; a different order of rounding than NumPy's pairwise sum).
    """
    n4 = n - n % 4
    s0 = s1 = s2 = s3 = 0.0
    for k in range(0, n4, 4):
        s0 += x[k]
        s1 += x[k + 1]
        s2 += x[k + 2]
        s3 += x[k + 3]
    for k in range(n4, n):
        s0 += x[k]
    mean = ((s0 + s1) + (s2 + s3)) / n
    s0 = s1 = s2 = s3 = 0.0
    for k in range(0, n4, 4):
        d0, d1, d2, d3 = x[k] - mean, x[k + 1] - mean, x[k + 2] - mean, x[k + 3] - mean
        s0 += d0 * d0
        s1 += d1 * d1
        s2 += d2 * d2
        s3 += d3 * d3
    for k in range(n4, n):
        d = x[k] - mean
        s0 += d * d
    return math.sqrt(2.0) * math.sqrt(((s0 + s1) + (s2 + s3)) / n)


@compiled
def _truth_into(trig, oc, roll_deg, pitch_deg, c, wd_deg, stride, along, across, out):
    """Record ``c``'s true motion statistics (:func:`attitude_truth`) into ``out[:, c]``,
    from its cosines and sines ``trig[:, oc, :]``; ``along``, ``across``: scratch of
    the strided slots' count."""
    n = roll_deg.shape[1]
    m = (n + stride - 1) // stride
    to_rad = np.pi / 180.0
    to_deg = 180.0 / np.pi
    out[0, c] = _amplitude(roll_deg[c], n)
    out[1, c] = _amplitude(pitch_deg[c], n)
    wd = wd_deg * to_rad
    sw, cw = math.sin(wd), math.cos(wd)
    sum_cy = 0.0
    sum_sy = 0.0
    for k in range(m):
        t = k * stride
        ze, zn, zz = _rotate_at(trig, oc, t, 0.0, 0.0, 1.0)  # the body z axis, R e_z
        along[k] = math.atan2(-sw * ze - cw * zn, zz) * to_deg
        across[k] = math.atan2(cw * ze - sw * zn, zz) * to_deg
        sum_cy += trig[4, oc, t]
        sum_sy += trig[5, oc, t]
    out[2, c] = _amplitude(along, m)
    out[3, c] = _amplitude(across, m)
    yaw_mean = (math.atan2(sum_sy, sum_cy) * to_deg) % 360.0
    out[4, c] = (yaw_mean + 180.0) % 360.0 - 180.0


@compiled
def attitude_truth(trig, roll_deg, pitch_deg, wd_deg, stride):
    """The records' true motion statistics from the noise-free attitude, shape (5, C).

    Rows: the amplitudes (``sqrt(2)`` x std, deg) of roll and of pitch over all N slots;
    of the tilt along and across the wind (the lean of the body z axis ``R e_z`` toward
    the direction the wind blows to / 90 deg to its left, ``atan2`` of its horizontal
    component over its vertical one) on every ``stride``-th slot; and the mean heading,
    the circular mean of those slots' yaw, in [-180, 180) deg.

    ``trig``: :func:`attitude_trig`'s (6, C, N); ``roll_deg``, ``pitch_deg``: (C, N), deg;
    ``wd_deg``: (C,), the wind direction (compass, from), deg.
    """
    n_c, n = roll_deg.shape
    m = (n + stride - 1) // stride
    along = np.empty(m)
    across = np.empty(m)
    out = np.empty((5, n_c))
    for c in range(n_c):
        _truth_into(trig, c, roll_deg, pitch_deg, c, wd_deg[c], stride, along, across, out)
    return out


@compiled
def _rotate(cr, sr, cp, sp, cy, sy, v0, v1, v2):
    """``R @ v`` with ``R = Rz(yaw) Ry(pitch) Rx(roll)`` from its cosines and sines, the
    entries of :func:`flidar_uq.physics.motion._rotation_entries`."""
    spcr = sp * cr
    spsr = sp * sr
    r00 = cy * cp
    r01 = cy * spsr - sy * cr
    r02 = cy * spcr + sy * sr
    r10 = sy * cp
    r11 = sy * spsr + cy * cr
    r12 = sy * spcr - cy * sr
    r20 = -sp
    r21 = cp * sr
    r22 = cp * cr
    return (
        r00 * v0 + r01 * v1 + r02 * v2,
        r10 * v0 + r11 * v1 + r12 * v2,
        r20 * v0 + r21 * v1 + r22 * v2,
    )


@compiled
def _rotate_at(trig, c, t, v0, v1, v2):
    """``R @ v`` at slot ``t`` of record ``c`` from :func:`attitude_trig`'s array."""
    return _rotate(
        trig[0, c, t],
        trig[1, c, t],
        trig[2, c, t],
        trig[3, c, t],
        trig[4, c, t],
        trig[5, c, t],
        v0,
        v1,
        v2,
    )


@compiled
def simulate_chunk_scans(
    roll_deg,
    pitch_deg,
    yaw_deg,
    trans,
    starts,
    k0,
    phase_slots,
    d_body,
    pinv_t,
    fluct_uvw,
    point_float,
    point_ref,
    hws_h,
    e_wind,
    alpha,
    lever,
    dt_s,
    wind_step,
    cos_half_cone,
    n_sign_iter,
    wd_deg,
    truth_stride,
    yaw_still_deg,
):
    """Radial speeds and VAD fits of every scan of a chunk of records.

    Parameters
    ----------
    roll_deg, pitch_deg : ndarray, shape (C, N)
        Attitude on the LOS clock of each record (N slots of ``dt_s``), deg; ``yaw_deg``
        (C, N), or (C, 1) for a constant heading. Their cosines and sines are computed a
        record at a time (:func:`attitude_trig`'s), kept in cache for its lines of sight
        and its truth.
    trans : ndarray, shape (C, N, 3) or (C, 0, 3)
        Translation of the rotation centre, m (earth frame); zero size: none.
    starts, phase_slots : ndarray of int, shape (C, J)
        First slot and prism phase (azimuth slots) of each scan.
    k0 : ndarray of int, shape (C,)
        Azimuth slot of the prism at the record's first slot.
    d_body, pinv_t : ndarray, shape (L, 3)
        Beam unit vectors (body frame) and the transposed VAD pseudo-inverse of the L
        azimuth slots (:func:`flidar_uq.physics.lidar.vad_pseudo_inverse`).
    fluct_uvw : ndarray, shape (C, H, P, 3, Nw)
        Turbulent wind along the mean wind, to its left and up, m/s, at P points of each
        height, one sample per ``wind_step`` slots; turned to east, north, up with
        ``e_wind`` as :func:`flidar_uq.physics.turbulence.wind_enu_ms` does.
    point_float, point_ref : ndarray of int, shape (C, L)
        The point of ``fluct_uvw`` each azimuth slot's line of sight samples: of the
        floating lidar (moving and held still) and of the fixed reference lidar (all 0 for
        a spatially uniform wind, P = 1).
    hws_h : ndarray, shape (C, H)
        Mean horizontal wind speed at each height, m/s; ``e_wind`` (C, 3): the unit vector
        it blows along; ``alpha`` (C,): the power-law shear exponent.
    lever : ndarray, shape (3,)
        Lidar head position from the rotation centre, body frame, m.
    dt_s : float
        LOS duration, s. ``wind_step``: LOS slots per turbulence sample.
    cos_half_cone : float
        Cosine of the half-cone angle (focus height follows the tilted beam, Nassif et al. (2020), Eq. 5).
    n_sign_iter : int
        CW sign-unfolding iterations (0: a lidar that measures the sign).
    wd_deg : ndarray, shape (C,)
        Wind direction (compass, from), deg; ``truth_stride``: slots between the samples of
        the tilt along / across the wind and the heading (:func:`attitude_truth`).
    yaw_still_deg : ndarray, shape (C,)
        Heading of the floating lidar held still (its record's mean yaw, deg): the
        motionless lidar against which the motion's error ``Z`` is taken is the floating
        lidar without its motion, its beams at this heading (the fixed reference lidar's
        are at a heading of 0: at another heading the two sample the turbulence along
        other beams).

    Returns
    -------
    v_r : ndarray, shape (C, J, L)
        Radial speed of the moving lidar, m/s (signed).
    uvw, uvw0 : ndarray, shape (C, J, 3)
        VAD wind of the moving lidar (body frame, sign unfolded) and of the fixed
        reference lidar, m/s.
    resid : ndarray, shape (C, J)
        RMS fit residual of the moving lidar, m/s.
    truth : ndarray, shape (5, C)
        The records' true motion statistics, :func:`attitude_truth`'s.
    v_r0 : ndarray, shape (C, J, L)
        Radial speed of the fixed reference lidar, m/s (signed).
    uvw_still, v_r_still : ndarray, shape (C, J, 3) and (C, J, L)
        Wind (body frame) and radial speeds (signed) of the floating lidar held still at
        ``yaw_still_deg``, m/s.
    """
    to_rad = np.pi / 180.0
    n_c, n_j = starts.shape
    n_los = d_body.shape[0]
    n_slots = roll_deg.shape[1]
    n_h = hws_h.shape[1]
    moving = trans.shape[1] > 0 or lever[0] != 0.0 or lever[1] != 0.0 or lever[2] != 0.0
    v_r = np.empty((n_c, n_j, n_los))
    v_r0 = np.empty((n_c, n_j, n_los))
    uvw = np.empty((n_c, n_j, 3))
    uvw0 = np.empty((n_c, n_j, 3))
    v_rs = np.empty((n_c, n_j, n_los))
    uvws = np.empty((n_c, n_j, 3))
    resid = np.empty((n_c, n_j))
    y_abs = np.empty(n_los)
    sgn = np.empty(n_los)
    a_row = np.empty(n_los, np.int64)
    pos = np.empty((n_slots if moving else 0, 3))
    trig = np.empty((6, 1, n_slots))  # one record's cosines and sines
    m_truth = (n_slots + truth_stride - 1) // truth_stride
    along = np.empty(m_truth)
    across = np.empty(m_truth)
    truth = np.empty((5, n_c))
    for c in range(n_c):
        _trig_into(roll_deg, pitch_deg, yaw_deg, c, trig, 0)
        e0, e1, e2 = e_wind[c, 0], e_wind[c, 1], e_wind[c, 2]
        a_ = alpha[c]
        cys = math.cos(yaw_still_deg[c] * to_rad)
        sys_ = math.sin(yaw_still_deg[c] * to_rad)
        # head position R(t) r + translation at every slot (Yamaguchi and Ishihara, 2016, Eq. 4), once a record
        for t in range(pos.shape[0]):
            x0, x1, x2 = _rotate_at(trig, 0, t, lever[0], lever[1], lever[2])
            if trans.shape[1] > 0:
                x0 += trans[c, t, 0]
                x1 += trans[c, t, 1]
                x2 += trans[c, t, 2]
            pos[t, 0], pos[t, 1], pos[t, 2] = x0, x1, x2
        for j in range(n_j):
            h = j % n_h
            mean_los = hws_h[c, h]
            s0 = starts[c, j]
            p0 = 0.0
            p1 = 0.0
            p2 = 0.0
            q0 = 0.0
            q1 = 0.0
            q2 = 0.0
            g0 = 0.0
            g1 = 0.0
            g2 = 0.0
            # the slot, its azimuth slot and turbulence sample, stepped along the scan (one
            # modulo and one division a scan, not a line of sight); past the record's last
            # slot (a scan that does not fit, not kept) the last slot is repeated
            slot = min(s0, n_slots - 1)
            a = (slot + k0[c] + phase_slots[c, j]) % n_los
            w_i = slot // wind_step
            w_rem = slot - w_i * wind_step
            for k in range(n_los):
                if k > 0 and s0 + k <= n_slots - 1:
                    slot += 1
                    a += 1
                    if a == n_los:
                        a = 0
                    w_rem += 1
                    if w_rem == wind_step:
                        w_rem = 0
                        w_i += 1
                a_row[k] = a
                m0, m1, m2 = d_body[a, 0], d_body[a, 1], d_body[a, 2]
                d0, d1, d2 = _rotate_at(trig, 0, slot, m0, m1, m2)
                p_ = point_float[c, a]
                fu = fluct_uvw[c, h, p_, 0, w_i]
                fv = fluct_uvw[c, h, p_, 1, w_i]
                f0 = fu * e0 + fv * -e1  # east: u e + v l, l = (-e_north, e_east) to the left
                f1 = fu * e1 + fv * e0
                f2 = fluct_uvw[c, h, p_, 2, w_i]
                # (1 + x)^alpha to second order in the tilt-induced relative height change
                x = d2 / cos_half_cone - 1.0
                ms = mean_los * (1.0 + a_ * x * (1.0 + 0.5 * (a_ - 1.0) * x))
                w0 = ms * e0 + f0
                w1 = ms * e1 + f1
                w2 = ms * e2 + f2
                if moving:
                    # central difference of R(t) r + translation (Yamaguchi and Ishihara, 2016, Eq. 4
                    # differentiated), one-sided at the record's ends
                    lo = min(max(s0 + k - 1, 0), n_slots - 1)
                    hi = min(s0 + k + 1, n_slots - 1)
                    span = max(hi - lo, 1) * dt_s
                    w0 -= (pos[hi, 0] - pos[lo, 0]) / span
                    w1 -= (pos[hi, 1] - pos[lo, 1]) / span
                    w2 -= (pos[hi, 2] - pos[lo, 2]) / span
                vr = w0 * d0 + w1 * d1 + w2 * d2
                v_r[c, j, k] = vr
                y_abs[k] = abs(vr)
                sgn[k] = np.sign(vr)
                sv = sgn[k] * y_abs[k]
                p0 += sv * pinv_t[a, 0]
                p1 += sv * pinv_t[a, 1]
                p2 += sv * pinv_t[a, 2]
                # the fixed reference lidar: the same wind, no motion, the body geometry
                r0, r1, r2 = f0, f1, f2
                p_ = point_ref[c, a]
                if p_ != point_float[c, a]:  # its own focus point in a spatial field
                    fu = fluct_uvw[c, h, p_, 0, w_i]
                    fv = fluct_uvw[c, h, p_, 1, w_i]
                    r0 = fu * e0 + fv * -e1
                    r1 = fu * e1 + fv * e0
                    r2 = fluct_uvw[c, h, p_, 2, w_i]
                vr0 = (mean_los * e0 + r0) * m0 + (mean_los * e1 + r1) * m1
                vr0 += (mean_los * e2 + r2) * m2
                v_r0[c, j, k] = vr0
                q0 += vr0 * pinv_t[a, 0]
                q1 += vr0 * pinv_t[a, 1]
                q2 += vr0 * pinv_t[a, 2]
                # the floating lidar held still: the body geometry turned by its heading
                s0_, s1_, s2_ = _rotate(1.0, 0.0, 1.0, 0.0, cys, sys_, m0, m1, m2)
                vrs = (mean_los * e0 + f0) * s0_ + (mean_los * e1 + f1) * s1_
                vrs += (mean_los * e2 + f2) * s2_
                v_rs[c, j, k] = vrs
                g0 += vrs * pinv_t[a, 0]
                g1 += vrs * pinv_t[a, 1]
                g2 += vrs * pinv_t[a, 2]
            # sign fixed point (vad_sign_unfolding): s <- sign(M p), p <- pinv (s |v_r|)
            for _ in range(n_sign_iter):
                n0 = 0.0
                n1 = 0.0
                n2 = 0.0
                for k in range(n_los):
                    a = a_row[k]
                    mp_ = d_body[a, 0] * p0 + d_body[a, 1] * p1 + d_body[a, 2] * p2
                    sgn[k] = 1.0 if mp_ >= 0.0 else -1.0
                    sv = sgn[k] * y_abs[k]
                    n0 += sv * pinv_t[a, 0]
                    n1 += sv * pinv_t[a, 1]
                    n2 += sv * pinv_t[a, 2]
                p0, p1, p2 = n0, n1, n2
            ss = 0.0
            for k in range(n_los):
                a = a_row[k]
                model = d_body[a, 0] * p0 + d_body[a, 1] * p1 + d_body[a, 2] * p2
                if n_sign_iter > 0:  # CW: residual of the |.| model
                    r = y_abs[k] - abs(model)
                else:  # signed speeds: residual of the linear model
                    r = sgn[k] * y_abs[k] - model
                ss += r * r
            resid[c, j] = np.sqrt(ss / n_los)
            uvw[c, j, 0], uvw[c, j, 1], uvw[c, j, 2] = p0, p1, p2
            uvw0[c, j, 0], uvw0[c, j, 1], uvw0[c, j, 2] = q0, q1, q2
            uvws[c, j, 0], uvws[c, j, 1], uvws[c, j, 2] = g0, g1, g2
        _truth_into(trig, 0, roll_deg, pitch_deg, c, wd_deg[c], truth_stride, along, across, truth)
    return v_r, uvw, uvw0, resid, truth, v_r0, uvws, v_rs
