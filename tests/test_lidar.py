"""Tests of lidar geometries and wind retrieval (Malekmohammadi et al., 2024, Eqs. 1-4, Yamaguchi and Ishihara (2016), Eq. 3)."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from flidar_uq.physics.lidar import (
    WINDCUBE_V1,
    WINDCUBE_V1_5BEAM,
    ZEPHIR300,
    LidarGeometry,
    beam_index,
    beam_unit_vectors_body,
    get_lidar,
    retrieve_wind,
    scan_times_azimuths,
    wind_direction_deg,
    wind_vector_ms,
)


def test_zephir300_geometry_matches_gutierrez2018_and_malekmohammadi2024():
    g = get_lidar("ZephIR300")
    assert g is ZEPHIR300
    assert (g.kind, g.half_cone_angle_deg, g.n_los, g.scan_period_s, g.signed) == (
        "vad",
        30.0,
        50,
        1.0,
        False,
    )
    t, az = scan_times_azimuths(g, 0.5)
    assert t.shape == az.shape == (50,)
    np.testing.assert_allclose(np.diff(t), 0.02)
    np.testing.assert_allclose(np.diff(az), 2 * np.pi / 50)
    assert az[0] == 0.5


def test_windcube_v1_geometry_four_beams_one_second_each():
    t, az = scan_times_azimuths(WINDCUBE_V1)
    np.testing.assert_allclose(t, [0, 1, 2, 3])
    np.testing.assert_allclose(np.rad2deg(az), [0, 90, 180, 270])
    t5, az5 = scan_times_azimuths(WINDCUBE_V1_5BEAM)
    assert t5.shape == (5,) and np.isnan(az5[-1])
    np.testing.assert_allclose(beam_unit_vectors_body(WINDCUBE_V1_5BEAM, az5)[-1], [0, 0, 1])


def test_beam_index_matches_azimuths_and_the_vertical_beam_to_the_scan_pattern():
    az = np.radians([270.0, 0.0, 360.0 - 1e-9, 90.0, 45.0, np.nan])
    assert beam_index(WINDCUBE_V1_5BEAM, az).tolist() == [3, 0, 0, 1, -1, 4]
    assert beam_index(WINDCUBE_V1, az).tolist() == [3, 0, 0, 1, -1, -1]  # no vertical beam
    assert beam_index(WINDCUBE_V1, np.radians([90.05]), tol_rad=1e-3).tolist() == [1]
    assert beam_index(WINDCUBE_V1, np.radians([90.1]), tol_rad=1e-3).tolist() == [-1]


def test_get_lidar_unknown_name_lists_known():
    with pytest.raises(ValueError, match=r"unknown lidar 'foo'; known lidars: .*zephir300"):
        get_lidar("foo")


def test_lidar_geometry_validation_names_the_field():
    with pytest.raises(ValueError, match="half_cone_angle_deg must be in"):
        dataclasses.replace(ZEPHIR300, half_cone_angle_deg=95.0)
    with pytest.raises(ValueError, match="n_los >= 3"):
        dataclasses.replace(ZEPHIR300, n_los=2)
    with pytest.raises(ValueError, match="permutation"):
        LidarGeometry("x", "dbs", 30.0, 4, 4.0, beam_azimuths_deg=(0.0, 45.0, 180.0, 270.0))
    with pytest.raises(ValueError, match="kind must be"):
        LidarGeometry("x", "ppi", 30.0, 4, 4.0)


def test_beam_vectors_are_unit_and_follow_conventions():
    d = beam_unit_vectors_body(ZEPHIR300, np.array([0.0, np.pi / 2]))
    np.testing.assert_allclose(np.linalg.norm(d, axis=-1), 1.0)
    # azimuth 0 points north (body y), 90 deg east (body x); 30 deg from the z axis
    np.testing.assert_allclose(d[0], [0, 0.5, np.sqrt(3) / 2], atol=1e-15)
    np.testing.assert_allclose(d[1], [0.5, 0, np.sqrt(3) / 2], atol=1e-15)


def test_wind_vector_meteorological_convention():
    # wind from the north blows towards the south: v < 0
    np.testing.assert_allclose(wind_vector_ms(5.0, 0.0), [0, -5, 0], atol=1e-12)
    np.testing.assert_allclose(wind_vector_ms(5.0, 90.0), [-5, 0, 0], atol=1e-12)
    assert wind_direction_deg(-5.0, 0.0) == pytest.approx(90.0)


@settings(max_examples=30, deadline=None)
@given(
    hws=st.floats(0.5, 30),
    wd=st.floats(0, 360, exclude_max=True),
    w=st.floats(-1, 1),
    phase=st.floats(0, 6.28),
)
def test_vad_least_squares_exact_for_homogeneous_wind(hws, wd, w, phase):
    _, az = scan_times_azimuths(ZEPHIR300, phase)
    vr = beam_unit_vectors_body(ZEPHIR300, az) @ wind_vector_ms(hws, wd, w)
    r = retrieve_wind(ZEPHIR300, az, vr)
    assert r.hws_ms == pytest.approx(hws, rel=1e-12)
    assert r.w_ms == pytest.approx(w, abs=1e-12)
    assert abs((r.wd_deg - wd + 180) % 360 - 180) < 1e-9
    assert r.residual_ms < 1e-12


@settings(max_examples=30, deadline=None)
@given(
    hws=st.floats(0.5, 30),
    wd=st.floats(0, 360, exclude_max=True),
    w=st.floats(-1, 1),
    phase=st.floats(0, 6.28),
)
def test_cw_sign_ambiguity_fit_malekmohammadi2024_eq4(hws, wd, w, phase):
    _, az = scan_times_azimuths(ZEPHIR300, phase)
    vr = np.abs(beam_unit_vectors_body(ZEPHIR300, az) @ wind_vector_ms(hws, wd, w))
    r = retrieve_wind(ZEPHIR300, az, vr, sign_ambiguity=True)
    assert r.hws_ms == pytest.approx(hws, rel=1e-9)
    # direction known modulo 180 deg; default branch in [0, 180) (up to rounding at the ends)
    assert r.wd_deg <= 180 + 1e-9 or r.wd_deg >= 360 - 1e-9
    assert abs((r.wd_deg - wd + 90) % 180 - 90) < 1e-6
    r2 = retrieve_wind(ZEPHIR300, az, vr, sign_ambiguity=True, reference_wd_deg=wd)
    assert abs((r2.wd_deg - wd + 180) % 360 - 180) < 1e-6
    assert r2.w_ms == pytest.approx(w, abs=1e-8)


@pytest.mark.parametrize("lidar", [WINDCUBE_V1, WINDCUBE_V1_5BEAM])
@pytest.mark.parametrize("phase", [0.0, 2.0, 4.0, 6.0])
def test_dbs_exact_for_static_homogeneous_wind(lidar, phase):
    wind = wind_vector_ms(9.0, 237.0, 0.4)
    _, az = scan_times_azimuths(lidar, phase)
    vr = beam_unit_vectors_body(lidar, az) @ wind
    r = retrieve_wind(lidar, az, vr)
    np.testing.assert_allclose([r.u_ms, r.v_ms, r.w_ms], wind, atol=1e-12)
    assert r.wd_deg == pytest.approx(237.0)


def test_dbs_beam_pairs_yamaguchi2016_eq3_by_hand():
    # V_N = v s + w c, V_E = u s + w c, ... with s = sin 30, c = cos 30
    s, c = 0.5, np.sqrt(3) / 2
    u, v, w = 3.0, -4.0, 0.2
    vr = np.array([v * s + w * c, u * s + w * c, -v * s + w * c, -u * s + w * c])
    r = retrieve_wind(WINDCUBE_V1, np.deg2rad([0, 90, 180, 270]), vr)
    assert (r.u_ms, r.v_ms) == (pytest.approx(u), pytest.approx(v))
    assert r.w_ms == pytest.approx(w)


def test_retrieve_wind_is_vectorised_over_scans(rng):
    _, az = scan_times_azimuths(ZEPHIR300)
    wind = np.stack(
        [
            wind_vector_ms(h, d)
            for h, d in zip(rng.uniform(1, 20, 7), rng.uniform(0, 360, 7), strict=True)
        ]
    )
    vr = wind @ beam_unit_vectors_body(ZEPHIR300, az).T  # (7, 50)
    r = retrieve_wind(ZEPHIR300, az, vr)
    assert r.hws_ms.shape == (7,)
    np.testing.assert_allclose(r.hws_ms, np.hypot(wind[:, 0], wind[:, 1]), rtol=1e-12)


def test_retrieve_wind_length_mismatch_raises():
    with pytest.raises(
        ValueError, match="radial_speed_ms has 3 lines of sight but azimuth_rad has 50"
    ):
        retrieve_wind(ZEPHIR300, scan_times_azimuths(ZEPHIR300)[1], np.zeros(3))
