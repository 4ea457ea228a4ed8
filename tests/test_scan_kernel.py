"""The compiled line-of-sight loop of the virtual campaign against the NumPy physics it fuses.

The reference below is written with the package's own NumPy functions (rotation matrices of
:mod:`flidar_uq.physics.motion`, :func:`flidar_uq.physics.lidar.vad_sign_unfolding`), the
arithmetic the generator used before the kernel (issue 13 item 7): the two agree to
rounding (BLAS fuses multiply-adds where the kernel does not), for a moving and a fixed
lidar head, a translating buoy, a signed and a CW (sign-unfolded) lidar.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from flidar_uq import compiled as compiled_module
from flidar_uq.campaign import scan_kernel
from flidar_uq.campaign.scan_kernel import attitude_trig, simulate_chunk_scans
from flidar_uq.physics import lidar as _lidar
from flidar_uq.physics.motion import rotation_matrix
from flidar_uq.physics.turbulence import wind_enu_ms


def _inputs(rng, *, lever, translate, n_c=2, n_j=7, n_los=12, n_h=3, step=5, const_yaw=False):
    n_slots = n_j * (n_los + 3)
    roll, pitch = (rng.normal(0.0, 6.0, (n_c, n_slots)) for _ in range(2))
    yaw = rng.normal(30.0, 20.0, (n_c, 1 if const_yaw else n_slots))  # (C,1): a constant heading
    starts = np.sort(rng.integers(0, n_slots - 2, (n_c, n_j)), axis=1)
    starts[:, 0] = 0  # the record's first slot: one-sided head velocity
    starts[:, -1] = n_slots - 3  # a scan running past the record's end (slots clipped)
    az = 2.0 * np.pi * np.arange(n_los) / n_los
    th = np.deg2rad(30.0)
    d_body = np.stack(
        [np.sin(th) * np.cos(az), np.sin(th) * np.sin(az), np.full(n_los, np.cos(th))], -1
    )
    wd = rng.uniform(0.0, 2.0 * np.pi, n_c)
    return dict(
        roll=roll,
        pitch=pitch,
        yaw=yaw,
        trans=rng.normal(0.0, 0.5, (n_c, n_slots, 3)) if translate else np.empty((n_c, 0, 3)),
        starts=starts,
        k0=rng.integers(0, n_los, n_c),
        phase_slots=rng.integers(0, n_los, (n_c, n_j)),
        d_body=d_body,
        pinv_t=_lidar.vad_pseudo_inverse(d_body).T,
        fluct_uvw=rng.normal(0.0, 1.0, (n_c, n_h, 3, -(-n_slots // step))),
        wd_deg=np.rad2deg(wd),
        hws_h=rng.uniform(3.0, 15.0, (n_c, n_h)),
        e_wind=np.stack([-np.sin(wd), -np.cos(wd), np.zeros(n_c)], -1),
        alpha=rng.uniform(0.05, 0.2, n_c),
        lever=np.asarray(lever, float),
        dt_s=0.02,
        step=step,
        cos_half_cone=np.cos(th),
    )


def _numpy_reference(a, n_sign_iter):
    """The generator's former NumPy pipeline for the same inputs."""
    n_c, n_j = a["starts"].shape
    n_los = a["d_body"].shape[0]
    n_slots = a["roll"].shape[1]
    n_h = a["hws_h"].shape[1]
    idx = np.minimum(a["starts"][..., None] + np.arange(n_los), n_slots - 1)
    a_idx = (idx + a["k0"][:, None, None] + a["phase_slots"][..., None]) % n_los
    # neighbouring slots of the head's central difference (clipped at the record's ends)
    slot = a["starts"][..., None] + np.arange(n_los)
    lo = np.clip(slot - 1, 0, n_slots - 1)
    hi = np.minimum(slot + 1, n_slots - 1)
    cc = np.arange(n_c)[:, None, None]

    att = {k: np.broadcast_to(a[k], a["roll"].shape) for k in ("roll", "pitch", "yaw")}

    def rot(s):
        return rotation_matrix(*(np.deg2rad(att[k][cc, s]) for k in ("roll", "pitch", "yaw")))

    m_body = a["d_body"][a_idx]
    d_earth = (rot(idx) @ m_body[..., None])[..., 0]
    pos_lo, pos_hi = ((rot(s) @ a["lever"]) for s in (lo, hi))
    if a["trans"].shape[1]:
        pos_lo, pos_hi = pos_lo + a["trans"][cc, lo], pos_hi + a["trans"][cc, hi]
    v_head = (pos_hi - pos_lo) / (np.maximum(hi - lo, 1) * a["dt_s"])[..., None]
    h = (np.arange(n_j) % n_h)[None, :, None]
    fl_enu = wind_enu_ms(0.0, a["wd_deg"][:, None], a["fluct_uvw"])  # (C,H,Nw,3)
    fl = fl_enu[cc, h, idx // a["step"]]
    mean = a["hws_h"][cc, h][..., None]
    x = d_earth[..., 2:] / a["cos_half_cone"] - 1.0
    al = a["alpha"][:, None, None, None]
    wind = mean * (1.0 + al * x * (1.0 + 0.5 * (al - 1.0) * x)) * a["e_wind"][:, None, None] + fl
    v_r = ((wind - v_head) * d_earth).sum(-1)
    v_r0 = ((mean * a["e_wind"][:, None, None] + fl) * m_body).sum(-1)
    pt = a["pinv_t"][a_idx]
    uvw, resid = _lidar.vad_sign_unfolding(pt, m_body, np.abs(v_r), np.sign(v_r), n_sign_iter)
    uvw0 = (v_r0[..., None, :] @ pt)[..., 0, :]
    return v_r, uvw, uvw0, resid


def _kernel(a, n_sign_iter, *, with_truth=False):
    keys = ("roll", "pitch", "yaw", "trans", "starts", "k0", "phase_slots", "d_body", "pinv_t")
    one_point = np.zeros(a["starts"].shape[:1] + a["d_body"].shape[:1], np.int64)
    out = simulate_chunk_scans(
        *(a[k] for k in keys),
        a.get("fluct_points", a["fluct_uvw"][:, :, None]),  # (C,H,P,3,Nw)
        a.get("point_float", one_point),
        a.get("point_ref", one_point),
        a["hws_h"],
        a["e_wind"],
        a["alpha"],
        a["lever"],
        a["dt_s"],
        a["step"],
        a["cos_half_cone"],
        n_sign_iter,
        a["wd_deg"],
        5,
        a.get("yaw_still", np.zeros(a["starts"].shape[0])),
    )
    return out if with_truth else out[:4]


@pytest.mark.parametrize("n_sign_iter", [0, 1])
@pytest.mark.parametrize(
    ("lever", "translate", "const_yaw"),
    [
        ((0.0, 0.0, 0.0), False, False),
        ((0.3, -0.2, 2.5), False, False),
        ((0.3, -0.2, 2.5), True, False),
        ((0.3, -0.2, 2.5), False, True),
    ],
)
def test_kernel_is_the_numpy_pipeline(n_sign_iter, lever, translate, const_yaw):
    rng = np.random.default_rng(7)
    for _ in range(3):
        a = _inputs(rng, lever=lever, translate=translate, const_yaw=const_yaw)
        got = _kernel(a, n_sign_iter)
        want = _numpy_reference(a, n_sign_iter)
        for g, w, name in zip(got, want, ("v_r", "uvw", "uvw0", "resid"), strict=True):
            assert g.shape == w.shape, name
            np.testing.assert_allclose(g, w, rtol=0, atol=1e-12, err_msg=name)


def test_head_motion_changes_the_radial_speeds():
    """The lever arm and the translation enter (a kernel ignoring them would pass the
    comparison above only if the reference ignored them too: check they matter)."""
    rng = np.random.default_rng(3)
    still = _inputs(rng, lever=(0.0, 0.0, 0.0), translate=False)
    moving = dict(still, lever=np.array([0.3, -0.2, 2.5]))
    shifted = dict(moving, trans=rng.normal(0.0, 0.5, still["roll"].shape + (3,)))
    v0, v1, v2 = (_kernel(a, 1)[0] for a in (still, moving, shifted))
    assert np.abs(v1 - v0).max() > 1e-3 and np.abs(v2 - v1).max() > 1e-3


def test_records_are_independent_of_their_chunk():
    """A record's results are the same bits whether simulated alone or with others."""
    a = _inputs(np.random.default_rng(11), lever=(0.3, -0.2, 2.5), translate=True, n_c=3)
    together = _kernel(a, 1, with_truth=True)
    per_record = (
        "roll", "pitch", "yaw", "trans", "starts", "k0", "phase_slots", "fluct_uvw", "hws_h",
        "e_wind", "alpha", "wd_deg",
    )  # fmt: skip
    for c in range(3):
        one = {k: v[c : c + 1] if k in per_record else v for k, v in a.items()}
        alone = _kernel(one, 1, with_truth=True)
        for g, w in zip(alone[:4], together[:4], strict=True):
            np.testing.assert_array_equal(g[0], w[c])
        np.testing.assert_array_equal(alone[4][:, 0], together[4][:, c])


@pytest.mark.parametrize("n_sign_iter", [0, 1])
def test_still_lidar_is_the_floating_lidar_without_its_motion(n_sign_iter):
    """The lidar the motion's error is taken against is the floating lidar held still at
    its heading: with no roll, pitch, lever arm or translation and a constant heading its
    radial speeds and (signed speeds) winds are the floating lidar's (the fixed reference
    lidar's, at a heading of 0, are not), and at a heading of 0 they are the reference
    lidar's."""
    a = _inputs(np.random.default_rng(13), lever=(0.0, 0.0, 0.0), translate=False, n_c=2)
    a = dict(a, roll=np.zeros_like(a["roll"]), pitch=np.zeros_like(a["pitch"]))
    a["yaw"] = np.ascontiguousarray(np.array([[35.0], [-120.0]]))
    a["yaw_still"] = np.array([35.0, -120.0])
    out = _kernel(a, n_sign_iter, with_truth=True)
    uvw, uvw0, uvws = out[1], out[2], out[6]
    hws = lambda x: np.hypot(x[..., 0], x[..., 1])  # noqa: E731
    np.testing.assert_allclose(out[7], out[0], rtol=0, atol=1e-9)  # the radial speeds
    assert np.abs(hws(uvw0) - hws(uvw)).max() > 1e-3
    if n_sign_iter == 0:  # a CW lidar's fit of |v_r| may unfold a sign otherwise
        np.testing.assert_allclose(hws(uvws), hws(uvw), rtol=0, atol=1e-9)
    zero = _kernel(dict(a, yaw_still=np.zeros(2)), n_sign_iter, with_truth=True)
    np.testing.assert_allclose(zero[6], zero[2], rtol=0, atol=1e-12)


def test_kernel_truth_is_attitude_truth():
    """The truth the kernel computes a record at a time is attitude_truth's of the chunk's
    cosines and sines, bit for bit."""
    a = _inputs(np.random.default_rng(5), lever=(0.0, 0.0, 0.0), translate=False, n_c=3)
    truth = _kernel(a, 1, with_truth=True)[4]
    trig = attitude_trig(a["roll"], a["pitch"], a["yaw"])
    want = scan_kernel.attitude_truth(trig, a["roll"], a["pitch"], a["wd_deg"], 5)
    np.testing.assert_array_equal(truth, want)


@pytest.mark.parametrize("constant_yaw", [True, False])
def test_attitude_trig_is_numpy_cos_and_sin(constant_yaw):
    """The attitude's cosines and sines, a constant heading broadcast over the record."""
    rng = np.random.default_rng(2)
    roll, pitch = rng.normal(0.0, 8.0, (2, 3, 500))
    yaw = rng.uniform(-180.0, 180.0, (3, 1 if constant_yaw else 500))
    got = attitude_trig(roll, pitch, yaw)
    assert got.shape == (6, 3, 500)
    for k, a in enumerate((roll, pitch, np.broadcast_to(yaw, roll.shape))):
        r = np.deg2rad(a)
        np.testing.assert_allclose(got[2 * k], np.cos(r), rtol=0, atol=2e-16)
        np.testing.assert_allclose(got[2 * k + 1], np.sin(r), rtol=0, atol=2e-16)


def _trig_of(roll_deg, pitch_deg=None):
    """``cos`` and ``sin`` of roll and of pitch of one record (no heading) and the angles in
    rad as the kernel forms them."""
    roll = np.asarray(roll_deg, float)[None, :]
    pitch = np.zeros_like(roll) if pitch_deg is None else np.asarray(pitch_deg, float)[None, :]
    got = attitude_trig(roll, pitch, np.zeros((1, 1)))
    to_rad = np.pi / 180.0
    return got[0, 0], got[1, 0], roll[0] * to_rad, got[2, 0], got[3, 0], pitch[0] * to_rad


def _bits(a):
    return np.asarray(a, np.float64).view(np.int64)


def _libm(x):
    """glibc's cosines and sines of ``x`` (Python's math module calls the C library)."""
    return np.array([math.cos(v) for v in x.tolist()]), np.array([math.sin(v) for v in x.tolist()])


@pytest.mark.parametrize("axis", ["roll", "pitch"])
def test_attitude_trig_is_libm(axis):
    """The kernel's roll and pitch cosines and sines are libm's, bit for bit, at small and
    large angles (zeros keep their sign)."""
    big = np.concatenate([np.linspace(-20.0, 60.0, 1001), [0.0, -0.0]])
    small = np.concatenate([np.linspace(-5.0, 5.0, 1001), [-0.0, 0.0]])
    roll, pitch = (big, small) if axis == "roll" else (small, big)
    cr, sr, xr, cp, sp, xp = _trig_of(roll, pitch)
    for got, want in zip((cr, sr, cp, sp), (*_libm(xr), *_libm(xp)), strict=True):
        np.testing.assert_array_equal(_bits(got), _bits(want))


def test_without_a_writable_cache_the_kernel_compiles_uncached(monkeypatch):
    """numba raises at decoration when no cache directory is writable: the decorator
    falls back to compiling in every process instead of failing the import."""
    calls = []

    def fake_njit(*, cache, nogil):
        calls.append(cache)
        if cache:
            raise RuntimeError("cannot cache function 'f': no locator available")
        return lambda f: ("compiled", f)

    monkeypatch.setattr(compiled_module.numba, "njit", fake_njit)

    def f():
        return 1

    assert compiled_module.compiled(f) == ("compiled", f)
    assert calls == [True, False]


@pytest.mark.parametrize(("stride", "constant_yaw"), [(1, False), (5, True), (7, False)])
def test_attitude_truth_is_the_numpy_definition(stride, constant_yaw):
    """Roll/pitch amplitudes (sqrt 2 std), the tilt along / across the wind (the body z axis
    R e_z leaning toward where the wind blows / 90 deg to its left) and the circular-mean
    heading, from the rotation matrix itself, on every ``stride``-th slot (a stride that
    does not divide the record included)."""
    rng = np.random.default_rng(7)
    n_c, n = 3, 603
    roll, pitch = rng.normal(0.0, 6.0, (2, n_c, n))
    yaw = rng.uniform(-180.0, 180.0, (n_c, 1)) + (
        0.0 if constant_yaw else rng.normal(0, 20, (n_c, n))
    )
    wd = rng.uniform(0.0, 360.0, n_c)
    got = scan_kernel.attitude_truth(attitude_trig(roll, pitch, yaw), roll, pitch, wd, stride)
    assert got.shape == (5, n_c)
    np.testing.assert_allclose(got[0], np.sqrt(2.0) * roll.std(axis=-1), rtol=1e-13)
    np.testing.assert_allclose(got[1], np.sqrt(2.0) * pitch.std(axis=-1), rtol=1e-13)
    y = np.broadcast_to(yaw, roll.shape)[:, ::stride]
    z_axis = rotation_matrix(*np.deg2rad((roll[:, ::stride], pitch[:, ::stride], y)))[..., :, 2]
    w = np.deg2rad(wd)[:, None]
    to_e, to_n = -np.sin(w), -np.cos(w)  # where the wind blows to (east, north)
    along = np.degrees(np.arctan2(z_axis[..., 0] * to_e + z_axis[..., 1] * to_n, z_axis[..., 2]))
    left_e, left_n = -to_n, to_e
    across = np.degrees(
        np.arctan2(z_axis[..., 0] * left_e + z_axis[..., 1] * left_n, z_axis[..., 2])
    )
    np.testing.assert_allclose(got[2], np.sqrt(2.0) * along.std(axis=-1), rtol=1e-12)
    np.testing.assert_allclose(got[3], np.sqrt(2.0) * across.std(axis=-1), rtol=1e-12)
    r = np.deg2rad(y)
    heading = np.degrees(np.arctan2(np.sin(r).mean(-1), np.cos(r).mean(-1)))
    np.testing.assert_allclose(got[4], heading, rtol=0, atol=1e-10)
    assert ((got[4] >= -180.0) & (got[4] < 180.0)).all()


def test_each_lidar_samples_its_own_point_of_a_spatial_field():
    """With the turbulence at several points (a spatial field), the floating and held-still
    lidars read ``point_float``'s and the fixed reference lidar ``point_ref``'s: each is the
    uniform-wind kernel run on that point's series."""
    rng = np.random.default_rng(17)
    a = _inputs(rng, lever=(0.3, -0.2, 2.5), translate=True)
    other = rng.normal(0.0, 1.0, a["fluct_uvw"].shape)
    n_c, n_los = a["starts"].shape[0], a["d_body"].shape[0]
    spatial = dict(
        a,
        fluct_points=np.stack([a["fluct_uvw"], other], axis=2),  # (C,H,2,3,Nw)
        point_float=np.zeros((n_c, n_los), np.int64),
        point_ref=np.ones((n_c, n_los), np.int64),
    )
    got = _kernel(spatial, 1, with_truth=True)
    floating = _kernel(a, 1, with_truth=True)
    reference = _kernel(dict(a, fluct_uvw=other), 1, with_truth=True)
    for i in (0, 1, 3, 6, 7):  # v_r, uvw, resid, uvw_still, v_r_still
        np.testing.assert_array_equal(got[i], floating[i])
    for i in (2, 5):  # uvw0, v_r0
        np.testing.assert_array_equal(got[i], reference[i])
        assert np.abs(got[i] - floating[i]).max() > 1e-3
