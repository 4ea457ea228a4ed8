"""Tests of rotations, platform motion and Nassif et al. (2020) tilt geometry."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from oracles import tilted_scan_heights, total_tilt_deg

from flidar_uq.physics.motion import (
    Harmonic,
    PlatformMotion,
    SampledMotion,
    _rotation_entries,
    _trig,
    harmonic_motion,
    rotation_matrix,
    rotation_matrix_derivatives,
)

angles = st.floats(-1.5, 1.5)


def test_rotation_order_rz_ry_rx_and_right_handed():
    a = 0.3
    # roll: right-handed about x sends body y towards +z
    np.testing.assert_allclose(rotation_matrix(a, 0, 0) @ [0, 1, 0], [0, np.cos(a), np.sin(a)])
    # pitch: right-handed about y sends body z towards +x
    np.testing.assert_allclose(rotation_matrix(0, a, 0) @ [0, 0, 1], [np.sin(a), 0, np.cos(a)])
    # yaw counter-clockwise from above sends x (east) towards north
    np.testing.assert_allclose(rotation_matrix(0, 0, a) @ [1, 0, 0], [np.cos(a), np.sin(a), 0])
    r, p, y = 0.1, -0.2, 0.7
    expected = rotation_matrix(0, 0, y) @ rotation_matrix(0, p, 0) @ rotation_matrix(r, 0, 0)
    np.testing.assert_allclose(rotation_matrix(r, p, y), expected, atol=1e-15)


def test_rotation_matrix_equals_nassif2020_eqs2_4_for_zero_yaw():
    # Nassif et al. (2020) V = Y P R V' with P, R as its Eqs. (3)-(4) (its R has a typo "1 1 0" in row 1)
    a, b = np.deg2rad(7.0), np.deg2rad(-4.0)  # pitch alpha, roll beta
    p = np.array([[np.cos(a), 0, np.sin(a)], [0, 1, 0], [-np.sin(a), 0, np.cos(a)]])
    r = np.array([[1, 0, 0], [0, np.cos(b), -np.sin(b)], [0, np.sin(b), np.cos(b)]])
    np.testing.assert_allclose(rotation_matrix(b, a, 0.0), p @ r, atol=1e-15)


@settings(max_examples=40, deadline=None)
@given(r=angles, p=angles, y=st.floats(-3.1, 3.1))
def test_rotation_matrix_is_orthonormal(r, p, y):
    m = rotation_matrix(r, p, y)
    np.testing.assert_allclose(m @ m.T, np.eye(3), atol=1e-12)
    assert np.linalg.det(m) == pytest.approx(1.0)


def test_rotation_matrix_broadcasts():
    m = rotation_matrix(np.zeros((4, 5)), np.ones(5) * 0.1, 0.0)
    assert m.shape == (4, 5, 3, 3)


def test_rotation_matrix_written_in_place_equals_its_entries_bit_for_bit(rng):
    # the entries computed into the stacked array are the closed-form entries themselves
    # (the campaign generator's output depends on these bits)
    r, p = 0.2 * rng.standard_normal((2, 7, 5))
    for y in (0.7, 0.3 * rng.standard_normal((7, 5))):  # constant or varying yaw
        m = rotation_matrix(r, p, y)
        entries = _rotation_entries(*_trig(r, p, y))
        for i in range(3):
            for j in range(3):
                want = np.broadcast_to(entries[i][j], r.shape)
                assert m[..., i, j].tobytes() == want.tobytes(), (i, j)
    assert rotation_matrix(0.1, 0.2, 0.3).shape == (3, 3)


@settings(max_examples=30, deadline=None)
@given(r=angles, p=angles, y=angles, dr=angles, dp=angles, dy=angles)
def test_rotation_derivative_matches_finite_difference(r, p, y, dr, dp, dy):
    h = 1e-6
    num = (
        rotation_matrix(r + dr * h, p + dp * h, y + dy * h)
        - rotation_matrix(r - dr * h, p - dp * h, y - dy * h)
    ) / (2 * h)
    np.testing.assert_allclose(rotation_matrix_derivatives(r, p, y, dr, dp, dy), num, atol=1e-7)


def _elementary(roll, pitch, yaw):
    """``Rz(yaw) @ Ry(pitch) @ Rx(roll)`` from the textbook elementary matrices."""
    c, s = np.cos, np.sin
    rx = np.array([[1, 0, 0], [0, c(roll), -s(roll)], [0, s(roll), c(roll)]])
    ry = np.array([[c(pitch), 0, s(pitch)], [0, 1, 0], [-s(pitch), 0, c(pitch)]])
    rz = np.array([[c(yaw), -s(yaw), 0], [s(yaw), c(yaw), 0], [0, 0, 1]])
    return rz @ ry @ rx


@settings(max_examples=40, deadline=None)
@given(r=st.floats(-3.1, 3.1), p=st.floats(-3.1, 3.1), y=st.floats(-3.1, 3.1))
def test_closed_form_rotation_equals_product_of_elementary_rotations(r, p, y):
    np.testing.assert_allclose(rotation_matrix(r, p, y), _elementary(r, p, y), atol=1e-15)


def test_closed_form_rotation_batched_equals_elementary_product():
    rng = np.random.default_rng(7)
    ang = rng.uniform(-np.pi, np.pi, (3, 50))
    expected = np.stack([_elementary(*a) for a in ang.T])
    got = rotation_matrix(*ang)
    assert got.shape == (50, 3, 3) and got.flags.c_contiguous
    np.testing.assert_allclose(got, expected, atol=1e-15)


@settings(max_examples=30, deadline=None)
@given(r=angles, p=angles, y=angles, dr=angles, dp=angles, dy=angles)
def test_rotation_derivative_equals_elementary_chain_rule(r, p, y, dr, dp, dy):
    # dR/dt = Rz' Ry Rx yaw_rate + Rz Ry' Rx pitch_rate + Rz Ry Rx' roll_rate, each
    # derivative of an elementary rotation being its generator times the matrix.
    gx = np.array([[0, 0, 0], [0, 0, -1], [0, 1, 0]])
    gy = np.array([[0, 0, 1], [0, 0, 0], [-1, 0, 0]])
    gz = np.array([[0, -1, 0], [1, 0, 0], [0, 0, 0]])
    rx, ry, rz = _elementary(r, 0, 0), _elementary(0, p, 0), _elementary(0, 0, y)
    expected = gz @ rz @ ry @ rx * dy + rz @ gy @ ry @ rx * dp + rz @ ry @ gx @ rx * dr
    np.testing.assert_allclose(
        rotation_matrix_derivatives(r, p, y, dr, dp, dy), expected, atol=1e-14
    )


def test_sampled_head_velocity_is_derivative_of_displacement():
    # Between IMU samples the series are linear, so away from the knots the central
    # difference of the head displacement is exact up to rounding, with the attitude
    # rates of the same segment: use a series whose np.gradient equals the segment slope
    # (linear in time), all six degrees of freedom and an off-axis lever arm.
    ts = np.linspace(0.0, 10.0, 11)
    m = SampledMotion(
        ts,
        roll_deg=2.0 + 1.5 * ts,
        pitch_deg=-3.0 + 0.8 * ts,
        yaw_deg=10.0 - 2.0 * ts,
        surge_m=0.1 * ts,
        sway_m=-0.2 * ts,
        heave_m=0.05 * ts,
        lever_arm_m=(0.5, -0.3, 4.0),
    )
    t = np.array([0.37, 2.5, 5.91, 9.2])
    h = 1e-5
    num = (m.head_displacement_m(t + h) - m.head_displacement_m(t - h)) / (2 * h)
    np.testing.assert_allclose(m.head_velocity_ms(t), num, atol=1e-8)


def test_harmonic_value_and_rate():
    h = Harmonic(3.0, 4.0, 0.5)
    t = np.linspace(0, 10, 7)
    np.testing.assert_allclose(h.value(t), 3 * np.sin(2 * np.pi * t / 4 + 0.5))
    np.testing.assert_allclose(h.rate(t), 3 * 2 * np.pi / 4 * np.cos(2 * np.pi * t / 4 + 0.5))
    with pytest.raises(ValueError, match="period_s must be finite and > 0"):
        Harmonic(1.0, 0.0)


def test_head_velocity_lever_arm_is_omega_cross_r():
    # pure roll about x with the head 4 m above: v = omega x (R r) = (0, -4 rdot cos r, -4 rdot sin r)
    m = PlatformMotion(roll=(Harmonic(3.0, 4.0),), lever_arm_m=(0, 0, 4.0))
    t = np.array([0.0, 0.7, 1.3])
    roll = np.deg2rad(3.0) * np.sin(2 * np.pi * t / 4)
    rate = np.deg2rad(3.0) * 2 * np.pi / 4 * np.cos(2 * np.pi * t / 4)
    expected = np.stack([0 * t, -4 * rate * np.cos(roll), -4 * rate * np.sin(roll)], -1)
    np.testing.assert_allclose(m.head_velocity_ms(t), expected, atol=1e-14)


def test_head_velocity_is_derivative_of_displacement():
    m = PlatformMotion(
        roll=(Harmonic(5.0, 6.0, 0.2), Harmonic(2.0, 13.0, 1.0)),
        pitch=(Harmonic(4.0, 7.0, 1.1),),
        yaw=(Harmonic(1.0, 30.0),),
        surge=(Harmonic(0.5, 8.0),),
        heave=(Harmonic(1.0, 9.0, 0.3),),
        lever_arm_m=(0.5, -0.3, 4.0),
    )
    t = np.linspace(0, 20, 11)
    h = 1e-5
    num = (m.head_displacement_m(t + h) - m.head_displacement_m(t - h)) / (2 * h)
    np.testing.assert_allclose(m.head_velocity_ms(t), num, atol=1e-8)


def test_sampled_motion_reproduces_harmonic_motion():
    ref = harmonic_motion(3.0, 4.0, 0.4, 1.2, lever_arm_m=4.0)
    ts = np.arange(0, 30, 0.005)
    roll, pitch, _ = ref.attitude_rad(ts)
    s = SampledMotion(ts, np.rad2deg(roll), np.rad2deg(pitch), lever_arm_m=(0, 0, 4.0))
    t = np.linspace(1, 25, 17)
    np.testing.assert_allclose(s.attitude_rad(t)[0], ref.attitude_rad(t)[0], atol=1e-6)
    np.testing.assert_allclose(s.head_velocity_ms(t), ref.head_velocity_ms(t), atol=1e-4)


def test_sampled_motion_takes_a_measured_translation_velocity_axis_by_axis():
    """Yamaguchi and Ishihara (2016), Eq. 4 differentiated: ``v_head = v_trans + omega x
    (R r)``. A measured velocity of the rotation centre (ENU) is that axis's ``v_trans``,
    interpolated linearly, in place of its displacement's rate; the other axes and the
    head displacement are unchanged."""
    ts = np.linspace(0.0, 10.0, 101)
    base = dict(
        roll_deg=2.0 + 1.5 * ts,
        pitch_deg=-3.0 + 0.8 * ts,
        yaw_deg=10.0 - 2.0 * ts,
        surge_m=0.1 * ts,  # east at 0.1 m/s, not measured
        lever_arm_m=(0.5, -0.3, 4.0),
    )
    rotating = SampledMotion(ts, **base)
    up = 0.3 * np.sin(ts)
    m = SampledMotion(ts, **base, velocity_north_ms=np.full_like(ts, -0.2), velocity_up_ms=up)
    t = np.array([0.37, 2.5, 5.91, 9.2])
    added = np.stack([0.0 * t, np.full_like(t, -0.2), np.interp(t, ts, up)], axis=-1)
    np.testing.assert_allclose(
        m.head_velocity_ms(t), rotating.head_velocity_ms(t) + added, atol=1e-12
    )
    np.testing.assert_array_equal(m.head_displacement_m(t), rotating.head_displacement_m(t))
    with pytest.raises(ValueError, match="velocity_up_ms has shape"):
        SampledMotion(ts, ts, ts, velocity_up_ms=np.zeros(3))


def test_sampled_motion_rejects_bad_series():
    with pytest.raises(ValueError, match="strictly increasing"):
        SampledMotion(np.array([0.0, 0.0, 1.0]), np.zeros(3), np.zeros(3))
    with pytest.raises(ValueError, match="pitch_deg has shape"):
        SampledMotion(np.arange(3.0), np.zeros(3), np.zeros(4))


def test_total_tilt_nassif2020_eq8_matches_rotated_z_axis():
    roll, pitch = 7.0, -11.0
    z = rotation_matrix(np.deg2rad(roll), np.deg2rad(pitch), 0.3) @ [0, 0, 1]
    assert total_tilt_deg(roll, pitch) == pytest.approx(np.rad2deg(np.arccos(z[2])))
    assert total_tilt_deg(0.0, 5.0) == pytest.approx(5.0)


# Nassif et al. (2020), Table 3: rows z', z_min, z_max, dz; columns z = 10, 100, 200 m x delta = 5, 10, 15 deg.
NASSIF2020_TABLE3 = {
    "z_prime": [9.9, 9.8, 9.6, 99.6, 98.5, 96.6, 199.2, 197.0, 193.2],
    "z_min": [9.4, 8.8, 8.2, 94.6, 88.4, 81.6, 189.2, 176.9, 163.3],
    "z_max": [10.5, 10.8, 11.1, 104.6, 108.5, 111.5, 209.3, 217.0, 223.1],
    "dz": [1.0, 2.0, 3.0, 10.1, 20.0, 29.9, 20.1, 40.1, 59.8],
}


def test_nassif2020_table3_heights():
    z = np.repeat([10.0, 100.0, 200.0], 3)
    delta = np.tile([5.0, 10.0, 15.0], 3)
    got = dict(zip(NASSIF2020_TABLE3, tilted_scan_heights(z, delta, 30.0), strict=True))
    n = 0
    for key, ref in NASSIF2020_TABLE3.items():
        np.testing.assert_allclose(got[key], ref, atol=0.1, err_msg=key)
        n += len(ref)
    assert n == 36  # the 27 heights z', z_min, z_max plus the 9 thicknesses dz


def test_tilted_scan_heights_level_and_out_of_domain():
    zp, zmin, zmax, dz = tilted_scan_heights(100.0, 0.0)
    assert (zp, zmin, zmax, dz) == (100.0, 100.0, 100.0, 0.0)
    assert np.isnan(tilted_scan_heights(100.0, 60.0)[1])
    assert np.isnan(tilted_scan_heights(100.0, -1.0)[0])
