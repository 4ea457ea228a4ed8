"""Tests of the moving-lidar simulator and the sigma_Z phase integral (Gutiérrez-Antuñano et al., 2018, Eqs. 1-14)."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import assume, example, given, settings
from hypothesis import strategies as st

import flidar_uq
from flidar_uq.physics.lidar import WINDCUBE_V1, ZEPHIR300, wind_vector_ms
from flidar_uq.physics.motion import Harmonic, PlatformMotion, harmonic_motion
from flidar_uq.physics.simulator import (
    los_vectors_earth,
    sigma_z,
    sigma_z_grid,
    simulate_scan,
    simulate_scans,
)


def _static(roll_deg=0.0, pitch_deg=0.0):
    """Static tilt as a harmonic of huge period at its crest."""
    comp = dict(period_s=1e12, phase_rad=np.pi / 2)
    return PlatformMotion(roll=(Harmonic(roll_deg, **comp),), pitch=(Harmonic(pitch_deg, **comp),))


def _seed_loop(hws, amp, period, wd, n, arm=0.0, lidar=ZEPHIR300):
    """Gutiérrez-Antuñano et al.'s (2018) procedure written out: one scan simulation per (roll, pitch, scan) phase."""
    phases = 2 * np.pi * np.arange(n) / n
    wind = wind_vector_ms(hws, wd)
    z = [
        simulate_scan(
            lidar,
            harmonic_motion(amp, period, pr, pp, lever_arm_m=arm),
            wind,
            0.0,
            ps,
            sign_ambiguity=False,
        ).z_ms
        for pr in phases
        for pp in phases
        for ps in phases
    ]
    return np.std(z), np.mean(z)


def test_public_import_sigma_z():
    r = flidar_uq.sigma_z(8.0, 3.0, 4.0)
    assert r.sigma_z_ms > 0 and np.isfinite(r.mean_z_ms)


@pytest.mark.parametrize("lidar", [ZEPHIR300, WINDCUBE_V1])
def test_zero_motion_gives_zero_error(lidar):
    res = simulate_scan(lidar, PlatformMotion(), wind_vector_ms(8.0, 33.0), 0.0, 1.1)
    assert abs(res.z_ms) < 1e-12
    assert res.wd_deg == pytest.approx(33.0)
    s = sigma_z(8.0, 0.0, 4.0, 33.0, lidar)
    assert s.sigma_z_ms < 1e-12 and abs(s.mean_z_ms) < 1e-12


@pytest.mark.parametrize("lidar", [ZEPHIR300, WINDCUBE_V1])
def test_static_tilt_error_is_second_order(lidar):
    wind = wind_vector_ms(10.0, 200.0)
    z1 = simulate_scan(lidar, _static(0.5, 0.3), wind, sign_ambiguity=False).z_ms
    z2 = simulate_scan(lidar, _static(1.0, 0.6), wind, sign_ambiguity=False).z_ms
    assert z1 != 0
    assert z2 / z1 == pytest.approx(4.0, rel=1e-3)


def test_static_tilt_analytic_projection():
    # static tilt: the VAD retrieves the wind projected on the tilted body x, y axes
    roll, pitch = np.deg2rad(4.0), np.deg2rad(-3.0)
    wind = wind_vector_ms(9.0, 70.0)
    res = simulate_scan(ZEPHIR300, _static(4.0, -3.0), wind, sign_ambiguity=False)
    ux = np.cos(pitch) * wind[0]
    uy = np.sin(roll) * np.sin(pitch) * wind[0] + np.cos(roll) * wind[1]
    assert res.hws_ms == pytest.approx(np.hypot(ux, uy), rel=1e-12)


def test_fast_kernel_equals_scan_by_scan_simulation():
    for arm in (0.0, 4.0):
        ref = _seed_loop(8.0, 3.0, 4.0, 30.0, 5, arm)
        got = sigma_z_grid(8.0, 3.0, 4.0, 30.0, nphase=5, nphase_scan=5, lever_arm_m=arm)
        np.testing.assert_allclose(got, ref, rtol=1e-10)


def test_fast_kernel_equals_direct_method_two_period_and_lever_vector():
    kw = dict(nphase=4, amplitude2_deg=2.0, period2_s=9.0, lever_arm_m=(0.5, -0.2, 3.0))
    a = sigma_z_grid(7.0, 4.0, 3.0, 100.0, method="fourier", **kw)
    b = sigma_z_grid(7.0, 4.0, 3.0, 100.0, method="direct", **kw)
    np.testing.assert_allclose(a, b, rtol=1e-10)


def test_quadrature_converges_geometrically():
    ref = sigma_z_grid(8.0, 5.0, 3.0, 40.0, nphase=64, lever_arm_m=2.0)[0]
    errs = [
        abs(sigma_z_grid(8.0, 5.0, 3.0, 40.0, nphase=n, lever_arm_m=2.0)[0] - ref)
        for n in (4, 8, 16)
    ]
    assert errs[0] > 1e-4 * ref  # the coarse grid is not exact ...
    assert errs[1] < 1e-3 * errs[0]  # ... and the error falls by orders of magnitude per doubling
    assert errs[2] < 1e-12 * ref
    res = sigma_z(8.0, 5.0, 3.0, 40.0, lever_arm_m=2.0)
    assert res.converged and res.sigma_z_ms == pytest.approx(ref, rel=1e-6)


@settings(max_examples=15, deadline=None)
@given(
    hws=st.floats(0.5, 25), factor=st.floats(0.1, 4), amp=st.floats(0.5, 15), per=st.floats(1, 20)
)
def test_sigma_z_scales_exactly_with_hws_without_lever_arm(hws, factor, amp, per):
    # the retrieval is linear in the wind and HWS is homogeneous of degree 1
    a = sigma_z_grid(hws, amp, per, 20.0, nphase=6)
    b = sigma_z_grid(hws * factor, amp, per, 20.0, nphase=6)
    np.testing.assert_allclose(np.array(b), factor * np.array(a), rtol=1e-9, atol=1e-15)


@pytest.mark.parametrize("period_s", [1.0, 2.0, 4.0, 10.0])
def test_gutierrez2018_fig3_equal_roll_pitch_sigma_z_independent_of_wd(period_s):
    vals = [sigma_z(10.0, 3.5, period_s, wd).sigma_z_ms for wd in range(0, 360, 30)]
    assert max(vals) / min(vals) - 1 < 0.01


def test_gutierrez2018_sec25_roll_only_depends_on_wd():
    vals = [
        sigma_z(10.0, 3.5, 4.0, wd, pitch_amplitude_deg=0.0).sigma_z_ms for wd in range(0, 181, 30)
    ]
    assert max(vals) > 2 * min(vals)
    # rolling about the wind axis (wind from the east) leaves the retrieval exact
    assert sigma_z(10.0, 3.5, 4.0, 90.0, pitch_amplitude_deg=0.0).sigma_z_ms < 1e-12


def test_lever_arm_design_brief_values():
    # design.md quotes 0.18 -> 0.28 m/s (8 m/s) and 0.11 -> 0.24 m/s (5 m/s) for 3 deg, 4 s, 4 m
    assert sigma_z(8.0, 3.0, 4.0).sigma_z_ms == pytest.approx(0.18, abs=0.005)
    assert sigma_z(8.0, 3.0, 4.0, lever_arm_m=4.0).sigma_z_ms == pytest.approx(0.28, abs=0.005)
    assert sigma_z(5.0, 3.0, 4.0).sigma_z_ms == pytest.approx(0.11, abs=0.005)
    assert sigma_z(5.0, 3.0, 4.0, lever_arm_m=4.0).sigma_z_ms == pytest.approx(0.24, abs=0.005)


def test_dbs_sigma_z_finite_and_grows_with_amplitude():
    a = sigma_z(8.0, 2.0, 6.0, 0.0, "windcube_v1")
    b = sigma_z(8.0, 4.0, 6.0, 0.0, "windcube_v1")
    assert a.method == "direct" and a.converged
    assert 0 < a.sigma_z_ms < b.sigma_z_ms


def test_simulate_scan_shear_tilted_cone_sees_height_varying_wind():
    wind = wind_vector_ms(10.0, 180.0)
    flat = simulate_scan(ZEPHIR300, _static(0.0, 10.0), wind, height_m=100.0, sign_ambiguity=False)
    shear = simulate_scan(
        ZEPHIR300,
        _static(0.0, 10.0),
        wind,
        height_m=100.0,
        shear_exponent=0.1,
        sign_ambiguity=False,
    )
    assert shear.z_ms != pytest.approx(flat.z_ms, abs=1e-6)
    level = simulate_scan(
        ZEPHIR300, PlatformMotion(), wind, height_m=100.0, shear_exponent=0.1, sign_ambiguity=False
    )
    assert abs(level.z_ms) < 1e-12


def test_simulate_scan_callable_wind_and_errors():
    def field(t_s, xyz_m):
        return np.broadcast_to(wind_vector_ms(6.0, 45.0), np.shape(xyz_m))

    res = simulate_scan(ZEPHIR300, PlatformMotion(), field, height_m=80.0, sign_ambiguity=False)
    assert abs(res.z_ms) < 1e-12
    with pytest.raises(ValueError, match="height_m is required"):
        simulate_scan(ZEPHIR300, PlatformMotion(), field)


def test_simulate_scans_vectorised_matches_single_scans(rng):
    motion = harmonic_motion(4.0, 5.0, 0.3, 2.0, lever_arm_m=3.0)
    wind = wind_vector_ms(9.0, 250.0)
    starts = rng.uniform(0, 100, 6)
    single = [
        simulate_scan(ZEPHIR300, motion, wind, t0, sign_ambiguity=False).hws_ms for t0 in starts
    ]
    t = starts[:, None] + np.arange(50) / 50
    roll, pitch, yaw = motion.attitude_rad(t)
    _, ret = simulate_scans(
        ZEPHIR300,
        wind,
        roll,
        pitch,
        yaw_rad=yaw,
        head_velocity_ms=motion.head_velocity_ms(t),
        sign_ambiguity=False,
    )
    np.testing.assert_allclose(ret.hws_ms, single, rtol=1e-12)
    assert los_vectors_earth(ZEPHIR300, np.zeros(3), roll[:, :3], pitch[:, :3]).shape == (6, 3, 3)


def test_yaw_is_compass_corrected():
    m = PlatformMotion(yaw=(Harmonic(20.0, 1e12, np.pi / 2),))
    res = simulate_scan(ZEPHIR300, m, wind_vector_ms(8.0, 100.0), sign_ambiguity=False)
    assert res.wd_deg == pytest.approx(100.0)
    assert abs(res.z_ms) < 1e-12


def test_cw_sign_ambiguity_same_hws_as_signed_for_small_tilt():
    m = harmonic_motion(2.0, 5.0, 0.4, 1.0)
    wind = wind_vector_ms(8.0, 60.0)
    a = simulate_scan(ZEPHIR300, m, wind, 0.3, sign_ambiguity=True)
    b = simulate_scan(ZEPHIR300, m, wind, 0.3, sign_ambiguity=False)
    assert a.hws_ms == pytest.approx(b.hws_ms, abs=0.05)
    np.testing.assert_allclose(a.radial_speed_ms, np.abs(b.radial_speed_ms))


# ---- stability (documented in docs/simulator.md) -------------------------------------


def test_stability_period_near_scan_period_is_smooth_maximum():
    vals = {t: sigma_z(8.0, 3.0, t).sigma_z_ms for t in (0.9, 0.98, 1.0, 1.02, 1.1, 2.0)}
    assert all(sigma_z(8.0, 3.0, t).converged for t in (0.98, 1.0, 1.02))
    assert vals[1.0] > vals[0.9] and vals[1.0] > vals[1.1] > vals[2.0]
    assert abs(vals[0.98] - vals[1.02]) < 0.01 * vals[1.0]  # no singularity, a broad peak


def test_stability_period_half_scan_period_dip():
    # motion at twice the scan rate is orthogonal to the first VAD harmonic: for wind from
    # north (U_x = 0) sigma_Z vanishes at T = 0.5 s and recovers quickly on both sides
    at = sigma_z(8.0, 3.0, 0.5, 0.0)
    assert at.converged and at.sigma_z_ms < 1e-9
    assert sigma_z(8.0, 3.0, 0.45, 0.0).sigma_z_ms > 0.05
    assert sigma_z(8.0, 3.0, 0.5, 45.0).sigma_z_ms > 1e-4  # not for other directions


@pytest.mark.parametrize("amp", [20.0, 25.0, 45.0])
def test_stability_large_tilt_converges(amp):
    res = sigma_z(8.0, amp, 4.0, 10.0)
    assert res.converged
    assert res.sigma_z_ms == pytest.approx(
        sigma_z_grid(8.0, amp, 4.0, 10.0, nphase=64)[0], rel=1e-6
    )
    np.testing.assert_allclose(
        sigma_z_grid(8.0, amp, 4.0, 10.0, nphase=8, method="direct"),
        sigma_z_grid(8.0, amp, 4.0, 10.0, nphase=8, method="fourier"),
        rtol=1e-10,
    )


def test_stability_hws_near_zero():
    # without lever arm Z is proportional to HWS: exact zero at HWS = 0
    assert sigma_z(0.0, 3.0, 4.0).sigma_z_ms == 0.0
    assert sigma_z(1e-3, 3.0, 4.0).sigma_z_ms == pytest.approx(
        1e-3 / 8 * sigma_z(8.0, 3.0, 4.0).sigma_z_ms
    )
    # with a lever arm the head velocity alone gives a positive retrieved speed: E(Z) > 0
    # and the integrand has a cusp, so more points are needed (algebraic convergence)
    res = sigma_z(0.05, 3.0, 4.0, lever_arm_m=4.0, rtol=1e-4)
    assert res.converged and res.mean_z_ms > 0.1 and res.n_phase >= 64


def test_stability_static_limit_long_period():
    amp = np.deg2rad(3.0)
    wind = wind_vector_ms(8.0, 30.0)
    ph = 2 * np.pi * (np.arange(400) + 0.5) / 400
    r = amp * np.sin(ph)[:, None]
    p = amp * np.sin(ph)[None, :]
    hws = np.hypot(np.cos(p) * wind[0], np.sin(r) * np.sin(p) * wind[0] + np.cos(r) * wind[1])
    z = hws - 8.0
    res = sigma_z(8.0, 3.0, 1e7, 30.0)
    assert res.sigma_z_ms == pytest.approx(np.std(z), rel=1e-6)
    assert res.mean_z_ms == pytest.approx(np.mean(z), rel=1e-6)


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        (dict(hws_ms=-1.0), "hws_ms must be finite and >= 0"),
        (dict(hws_ms=np.nan), "hws_ms must be finite"),
        (dict(amplitude_deg=50.0), "amplitude_deg must be finite and >= 0.0 and <= 45"),
        (dict(period_s=0.0), "period_s must be finite and > 0"),
        (dict(period_s="x"), "period_s must be a number"),
        (dict(lidar="nope"), "unknown lidar 'nope'"),
        (dict(amplitude2_deg=1.0), "give both amplitude2_deg and period2_s"),
    ],
)
def test_sigma_z_rejects_bad_input(kwargs, match):
    args = dict(hws_ms=8.0, amplitude_deg=3.0, period_s=4.0) | kwargs
    with pytest.raises(ValueError, match=match):
        sigma_z(**args)


@settings(max_examples=10, deadline=None)
@given(
    wd=st.floats(0, 360),
    amp=st.floats(0.5, 20),
    per=st.floats(1, 20),
    arm=st.sampled_from([0.0, 3.0]),
)
def test_sigma_z_exact_direction_symmetries(wd, amp, per, arm):
    # equal roll/pitch amplitude: sigma_Z(wd) = sigma_Z(-wd) = sigma_Z(wd + 180) exactly
    # (the surrogate's cosine series in 2 wd relies on this)
    # (wd + 180 flips the wind: exact on any grid; -wd maps the phase grid onto a shifted
    # one: equal to the quadrature error. At 24 points that is below 1e-15 up to 12 deg
    # amplitude (any period >= 1 s, lever arm 0 or 3 m; measured 6e-16), but at 20 deg and
    # 1-2 s it reaches 1e-6 (hypothesis found 2.3e-7 at 20 deg, 1.5 s, 3 m): the -wd check
    # runs where the 24-point grid is converged)
    checks = [(16, wd + 180.0, 1e-12)] + ([(24, -wd, 1e-9)] if amp <= 12.0 else [])
    for n, other, tol in checks:
        ref = sigma_z_grid(8.0, amp, per, wd, nphase=n, lever_arm_m=arm)
        np.testing.assert_allclose(
            sigma_z_grid(8.0, amp, per, other, nphase=n, lever_arm_m=arm),
            ref,
            rtol=0,
            atol=tol * ref[0],
        )


@settings(max_examples=40, deadline=None)
@example(hws=2.0, amp=1e-12, per=1.0, wd=0.0, arm=0.0, pitch_ratio=None)  # round-off moments
@given(
    hws=st.floats(2.0, 21.0),
    amp=st.floats(0.0, 25.0),
    per=st.floats(1.0, 20.0),
    wd=st.floats(0.0, 360.0),
    arm=st.sampled_from([0.0, 2.5]),
    pitch_ratio=st.sampled_from([None, 0.0, 0.5]),
)
def test_sigma_z_default_within_rtol_of_a_finer_grid(hws, amp, per, wd, arm, pitch_ratio):
    """The default (rtol 1e-6, error from the nested half grid) against an independent grid
    twice as fine in every phase, over the pipeline's parameter space (bins 2-21 m/s, the
    surrogate's 0-25 deg x 1-20 s, any direction, the default scenario's 2.5 m lever arm,
    roll-only and unequal pitch). Issue 13 item 4."""
    pamp = None if pitch_ratio is None or amp == 0.0 else pitch_ratio * amp
    kw = dict(lever_arm_m=arm, pitch_amplitude_deg=pamp)
    res = sigma_z(hws, amp, per, wd, **kw)
    assert res.converged
    ref = sigma_z_grid(hws, amp, per, wd, nphase=2 * res.n_phase, **kw)
    scale = max(ref[0], abs(ref[1]), 1e-8 * hws)  # floor: no motion, round-off only
    assert abs(res.sigma_z_ms - ref[0]) <= 1e-6 * scale
    assert abs(res.mean_z_ms - ref[1]) <= 1e-6 * scale


@settings(max_examples=5, deadline=None)
@given(hws=st.floats(2.0, 21.0), amp=st.floats(0.5, 10.0), per=st.floats(1.0, 20.0))
def test_sigma_z_default_within_rtol_dbs(hws, amp, per):
    """The same for a DBS lidar (direct method; the beams are not subsampled)."""
    res = sigma_z(hws, amp, per, 30.0, WINDCUBE_V1)
    assert res.converged
    ref = sigma_z_grid(hws, amp, per, 30.0, WINDCUBE_V1, nphase=2 * res.n_phase)
    scale = max(ref[0], abs(ref[1]))
    assert abs(res.sigma_z_ms - ref[0]) <= 1e-6 * scale
    assert abs(res.mean_z_ms - ref[1]) <= 1e-6 * scale


# ---- issue 13 item 4: the a-priori error bound of the default ---------------------------


@settings(max_examples=40, deadline=None)
@given(
    hws=st.floats(2.0, 21.0),
    amp=st.floats(0.0, 20.0),
    per=st.floats(2.0, 20.0),
    wd=st.floats(0.0, 360.0),
    arm=st.floats(0.0, 3.0),
    pitch_ratio=st.sampled_from([None, 0.0, 0.5]),
)
def test_sigma_z_default_within_rtol_of_converged_reference(hws, amp, per, wd, arm, pitch_ratio):
    """The default (a-priori rate bound, start grid 8/12/16) against a converged 48 x 48 x 192
    reference over the project's ranges (bins 2-21 m/s, amplitude <= 20 deg, periods
    2-20 s, lever arm 0-3 m, any direction, equal / half / zero pitch): relative error
    <= 1e-6 of max(sigma_Z, |E(Z)|), and the returned error estimate bounds the error."""
    pamp = None if pitch_ratio is None or amp == 0.0 else pitch_ratio * amp
    kw = dict(lever_arm_m=arm, pitch_amplitude_deg=pamp)
    res = sigma_z(hws, amp, per, wd, **kw)
    assert res.converged
    # 48 x 48 x 192 (converged to 1e-13 where the bound applies), always finer than the default
    n_ref = max(48, 2 * res.n_phase)
    assume(n_ref <= 128)  # beyond (a cusp near HWS ~ head speed) no finer grid fits in memory
    ref = sigma_z_grid(hws, amp, per, wd, nphase=n_ref, **kw)
    scale = max(ref[0], abs(ref[1]), 1e-8 * hws)  # floor: no motion, round-off only
    err = max(abs(res.sigma_z_ms - ref[0]), abs(res.mean_z_ms - ref[1]))
    assert err <= 1e-6 * scale
    assert err <= max(res.error_estimate_ms, 1e-12 * hws)  # floor: round-off


def _cusp_case():
    """The default's relative error and error estimate with the head's speed near the wind
    speed (19 deg at 2.69 s, 2 m lever arm, 2 m/s), against a converged 48-point grid."""
    kw = dict(lever_arm_m=2.0, pitch_amplitude_deg=9.5)
    res = sigma_z(2.0, 19.0, 2.69, 45.0, **kw)
    ref = sigma_z_grid(2.0, 19.0, 2.69, 45.0, nphase=48, **kw)
    err = max(abs(res.sigma_z_ms - ref[0]), abs(res.mean_z_ms - ref[1]))
    return err / max(ref[0], abs(ref[1])), err, res.error_estimate_ms


@pytest.mark.xfail(
    strict=True,
    reason="known limit: near the head-speed cusp the a-priori 16-point grid is 1.1e-6 "
    "off, above its 1e-6 target and its own error estimate (6.4e-7); 1e-5 holds (next test)",
)
def test_sigma_z_default_bound_near_the_head_speed_cusp():
    rel, err, estimate = _cusp_case()
    assert rel <= 1e-6
    assert err <= estimate


def test_sigma_z_default_near_the_head_speed_cusp_within_1e5():
    assert _cusp_case()[0] <= 1e-5


def test_sigma_z_default_grid_is_chosen_a_priori():
    # inside the bounded domain one grid is evaluated: 8 points where rho < 0.2, 12 where
    # rho < 0.35, 16 above, and the result is the converged value
    cases = [((8.0, 3.0, 4.0), 0.0, 8), ((8.0, 12.0, 6.0), 0.0, 12), ((8.0, 18.0, 6.0), 2.5, 16)]
    for args, arm, n in cases:
        res = sigma_z(*args, lever_arm_m=arm)
        assert res.n_phase == n and res.converged
        ref = sigma_z_grid(*args, nphase=48, lever_arm_m=arm)
        assert res.sigma_z_ms == pytest.approx(ref[0], rel=1e-6)
        assert res.mean_z_ms == pytest.approx(ref[1], abs=1e-6 * ref[0])
    # outside it (period near the scan period, 25 deg) the plain half-grid difference from
    # 16 points decides, as before: the 16 -> 32 doubling
    extreme = sigma_z(8.0, 25.0, 1.2)
    assert extreme.n_phase == 32 and extreme.converged
    # the estimate is the half-grid difference contracted by rho^(N/2) < 1 in the domain
    small = sigma_z(8.0, 3.0, 4.0)
    z = sigma_z_grid(8.0, 3.0, 4.0, nphase=8)
    half = sigma_z_grid(8.0, 3.0, 4.0, nphase=4)
    d = max(abs(z[0] - half[0]), abs(z[1] - half[1]))
    assert 0 < small.error_estimate_ms < 1e-2 * d
