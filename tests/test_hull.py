"""The hull in six degrees of freedom: responses, wave kinematics, the band sum of sigma_Z."""

from __future__ import annotations

import dataclasses

import numpy as np
import pandas as pd
import pytest

from flidar_uq.physics import motion_spectrum as ms
from flidar_uq.physics.hull import (
    G_MS2,
    HULLS,
    DofResponse,
    get_hull,
    orbital_lever_arm_m,
    phase_speed_ms,
)
from flidar_uq.physics.lidar import get_lidar
from flidar_uq.physics.seastate import WaveSystem, hull_motion_series, tilt_series
from flidar_uq.physics.six_dof_sigma_z import six_dof_band_sigma_z_ms, translation_unit_sq


def test_orbital_lever_arm_and_phase_speed_of_deep_water_waves():
    """g / omega^2: ~2 m at 3 s, ~9 m at 6 s, ~25 m at 10 s; c = g T / (2 pi)."""
    np.testing.assert_allclose(
        orbital_lever_arm_m([3.0, 6.0, 10.0]), [2.236, 8.943, 24.84], rtol=1e-3
    )
    np.testing.assert_allclose(phase_speed_ms(8.0), G_MS2 * 8.0 / (2 * np.pi))


def test_named_hull_responses():
    t = np.array([1.5, 3.0, 6.0, 12.0, 60.0])
    rx, rz = HULLS["wave_follower"].relative_responses(t)
    np.testing.assert_array_equal(rx, 1.0)
    np.testing.assert_array_equal(rz, 1.0)
    rx, rz = HULLS["rotation_only"].relative_responses(t)
    np.testing.assert_array_equal(rx, 0.0)
    np.testing.assert_array_equal(rz, 0.0)
    # an oscillator follows waves much longer than its natural period, not much shorter ones
    h = DofResponse(natural_period_s=3.0, damping_ratio=0.3)
    assert abs(h.rao(300.0)) == pytest.approx(1.0, abs=1e-3)
    assert abs(h.rao(0.3)) < 0.011
    heave = np.abs(HULLS["discus_buoy"].heave.rao([1.0, 60.0]))
    assert heave[1] > 0.99 and heave[0] < 0.5
    spar = HULLS["spar"]
    assert np.all(np.abs(spar.heave.rao([3.0, 6.0, 10.0])) < 0.2)


def test_unknown_hull_names_the_known_ones():
    with pytest.raises(
        ValueError, match="known hulls: discus_buoy, rotation_only, spar, wave_follower"
    ):
        get_hull("barge")
    with pytest.raises(ValueError, match="natural_period_s and damping_ratio"):
        DofResponse(natural_period_s=-1.0)


def _unidirectional(direction_deg, hull="wave_follower", seed=3):
    sea = [WaveSystem(3.0, 7.0, gamma=10.0, direction_deg=direction_deg, spread_deg=0.0)]
    rng = np.random.default_rng(seed)
    return hull_motion_series(12000, 0.1, sea, rng, hull)


@pytest.mark.parametrize("direction_deg", [0.0, 60.0, -150.0])
def test_wave_follower_kinematics_of_linear_waves(direction_deg):
    """Linear deep-water waves, Fourier component by component: the heave velocity in phase
    with the lean along the direction of travel and ``c = g / omega`` times it (the water
    rises on the front face, where the hull leans forward); the horizontal orbital velocity
    in phase with the elevation and ``omega`` times it (forward at a crest); nothing across
    the direction of travel without spreading."""
    dt = 0.1
    m = _unidirectional(direction_deg)
    e = np.array([np.cos(np.deg2rad(direction_deg)), np.sin(np.deg2rad(direction_deg))])
    lean = (
        np.deg2rad(m["pitch_deg"]) * e[0] - np.deg2rad(m["roll_deg"]) * e[1]
    )  # body z (pitch, -roll)
    horiz = m["surge_m"] * e[0] + m["sway_m"] * e[1]
    f = np.fft.rfftfreq(lean.size, dt)
    lean_f, heave_f, horiz_f = (np.fft.rfft(x) for x in (lean, m["heave_m"], horiz))
    w = 2 * np.pi * f
    band = np.abs(lean_f) > 1e-3 * np.abs(lean_f).max()
    assert band.sum() > 50
    heave_velocity_per_lean = (1j * w * heave_f)[band] / lean_f[band]
    np.testing.assert_allclose(heave_velocity_per_lean, G_MS2 / w[band], rtol=1e-9)
    horiz_velocity_per_elevation = (1j * w * horiz_f)[band] / heave_f[band]
    np.testing.assert_allclose(horiz_velocity_per_elevation, w[band], rtol=1e-9)
    across = -m["surge_m"] * e[1] + m["sway_m"] * e[0]
    assert np.std(across) < 1e-9 * np.std(horiz)


def test_hull_motion_keeps_the_tilt_series_draws_and_rotation_only_stays():
    sea = [WaveSystem(3.0, 5.0), WaveSystem(1.5, 10.0, 6.0, 90.0, 10.0)]
    r0, p0 = tilt_series(4096, 0.05, sea, np.random.default_rng(8))
    m = hull_motion_series(4096, 0.05, sea, np.random.default_rng(8), "wave_follower")
    np.testing.assert_array_equal(m["roll_deg"], r0)
    np.testing.assert_array_equal(m["pitch_deg"], p0)
    still = hull_motion_series(4096, 0.05, sea, np.random.default_rng(8), "rotation_only")
    for k in ("surge_m", "sway_m", "heave_m"):
        np.testing.assert_array_equal(still[k], 0.0)
    assert np.std(m["heave_m"]) > 0.1


def _harmonic_six_dof(psi_deg, period_s, amplitude_deg, lever_arm_m, hull_gain, n=36000, dt=0.05):
    """A single wave by hand: lean A sin(w t) along the direction psi from downwind (the body
    x axis, east), horizontal displacement -g/w^2 phi, heave velocity c phi (times the gain)."""
    t = np.arange(n) * dt
    w = 2 * np.pi / period_s
    phi = np.deg2rad(amplitude_deg) * np.sin(w * t)
    e = np.array([np.cos(np.deg2rad(psi_deg)), np.sin(np.deg2rad(psi_deg))])
    pitch, roll = np.rad2deg(phi * e[0]), -np.rad2deg(phi * e[1])
    x_h = -hull_gain * G_MS2 / w**2 * phi
    heave = -hull_gain * (G_MS2 / w) * np.deg2rad(amplitude_deg) * np.cos(w * t) / w
    trans = np.column_stack([x_h * e[0], x_h * e[1], heave])
    return t, roll, pitch, trans


@pytest.mark.parametrize(
    ("psi_deg", "hws_ms", "lever_arm_m", "hull"),
    [
        (0.0, 8.0, 0.0, "wave_follower"),  # wind sea: (U - c) leak, orbital lever arm
        (0.0, 12.0, 3.0, "wave_follower"),
        (90.0, 8.0, 0.0, "wave_follower"),  # across the wind: heave only
        (180.0, 8.0, 0.0, "wave_follower"),  # against the wind: (U + c)
        (0.0, 8.0, 3.0, "rotation_only"),
    ],
)
def test_band_sum_matches_the_six_dof_replay_of_one_wave(psi_deg, hws_ms, lever_arm_m, hull):
    """The band sum of one harmonic against the scan simulator's replay of hand-built
    kinematics (independent of hull_motion_series): within 4 % (the replay's phase sampling
    and second-order terms)."""
    gain = 0.0 if hull == "rotation_only" else 1.0
    t, roll, pitch, trans = _harmonic_six_dof(psi_deg, 6.3, 3.0, lever_arm_m, gain)
    rep = ms.replay_sigma_z(
        t, roll, pitch, hws_ms=hws_ms, wd_deg=270.0, lever_arm_m=lever_arm_m, translation_m=trans
    ).sigma_z_ms
    got = six_dof_band_sigma_z_ms(
        hws_ms,
        [3.0],
        [6.3],
        band_cos_psi=[np.cos(np.deg2rad(psi_deg))],
        lever_arm_m=lever_arm_m,
        hull=hull,
    )
    assert got == pytest.approx(rep, rel=0.04)
    if psi_deg == 90.0:  # the tilt-only model calls this sea harmless
        tilt_only = six_dof_band_sigma_z_ms(
            hws_ms, [3.0], [6.3], band_cos_psi=[0.0], hull="rotation_only"
        )
        assert tilt_only < 1e-12 and rep > 0.05


def test_band_sum_reduces_to_the_lever_arm_model_without_translation():
    """rotation_only: sqrt(sZ_rot^2 + L^2 u^2) of the record model, term for term."""
    from flidar_uq.physics.surrogate import get_surrogate

    sur = get_surrogate("zephir300")
    got = six_dof_band_sigma_z_ms(
        [6.0, 11.0],
        [[2.0, 1.0]],
        [[4.0, 9.0]],
        band_cos_psi=[[1.0, 1.0]],
        lever_arm_m=2.5,
        hull="rotation_only",
    )
    hws = np.array([6.0, 11.0])[:, None]
    rot = sur.sigma_z_ms(hws, np.array([[2.0, 1.0]]), np.array([[4.0, 9.0]]))
    u2 = translation_unit_sq(np.array([2.0, 1.0]), np.array([4.0, 9.0]))
    want = np.sqrt(np.sum(rot**2 + 2.5**2 * u2, axis=-1))
    np.testing.assert_allclose(got, want, rtol=1e-12)


def _one_band_records(std_along_deg, period_s, hws_ms):
    """Records of one harmonic band along the wind with a wave follower's translation."""
    import pandas as pd

    c = phase_speed_ms(period_s)
    sig = np.deg2rad(std_along_deg)
    return pd.DataFrame(
        {
            "hws_mean_ms": hws_ms,
            "tilt_along_wind_std_deg": std_along_deg,
            "tilt_across_wind_std_deg": 0.0,
            "tilt_period_mean_s": period_s,
            "follower_heave_velocity_std_ms": c * sig,
            "follower_heave_period_s": period_s,
            "follower_velocity_along_wind_std_ms": c * sig,
            "follower_heave_tilt_correlation": 1.0,
        }
    )


def test_record_terms_equal_the_band_sum_for_one_band():
    """The moments description of the record model is the band sum when the record's sea is
    one band: (U - c)^2 leak and (L - g / omega^2)^2 translation, for any lever arm."""
    from flidar_uq.inference.record_motion import gram_sigma_z_ms, motion_gram, per_record_motion

    hws = np.array([5.0, 9.0, 14.0])
    rec = _one_band_records(np.array([1.2, 2.0, 3.1]), np.array([3.5, 6.0, 8.0]), hws)
    mot = per_record_motion(rec)
    gram = motion_gram(rec)
    for lever in (0.0, 2.5):
        got = gram_sigma_z_ms(gram, lever_arm_m=lever, hull_response=1.0)
        want = [
            six_dof_band_sigma_z_ms(u, [np.sqrt(2) * a], [t], band_cos_psi=[1.0], lever_arm_m=lever)
            for u, a, t in zip(
                hws, rec.tilt_along_wind_std_deg, rec.tilt_period_mean_s, strict=True
            )
        ]
        np.testing.assert_allclose(got, want, rtol=1e-9)
        # h = 0: the rotation-only record model, sqrt(sZ_rot^2 + L^2 u^2)
        from flidar_uq.inference import effective_sigma_z_ms

        rot = gram_sigma_z_ms(gram, lever_arm_m=lever, hull_response=0.0)
        want0 = effective_sigma_z_ms(mot["sigma_z_rot_ms"], mot["translation_unit_sq"], lever)
        np.testing.assert_allclose(rot, want0, rtol=1e-12)


def test_record_terms_are_zero_without_the_follower_columns():
    from oracles import six_dof_terms

    from flidar_uq.inference.record_motion import per_record_motion

    rec = _one_band_records(np.array([1.5]), np.array([5.0]), np.array([8.0]))
    rec = rec.drop(columns=["follower_heave_velocity_std_ms"])
    terms = six_dof_terms(rec, per_record_motion(rec))
    assert (terms.to_numpy() == 0.0).all()


@pytest.mark.parametrize(
    "hull, h", [("rotation_only", 0.0), ("wave_follower", 1.0), ("discus_buoy", 1.0), ("spar", 1.0)]
)
def test_band_terms_give_the_band_sum_for_any_lever_arm(hull, h):
    """six_dof_band_terms of a reference hull assembled with a hull response h is the band
    sum of that hull (h = 1) or of the rotation-only one (h = 0), record by record, for
    several lever arms; sZ^2 is convex in h."""
    from flidar_uq.physics.six_dof_sigma_z import six_dof_band_terms
    from flidar_uq.physics.surrogate import get_surrogate

    rng = np.random.default_rng(7)
    n, nb = 40, 8
    amp = rng.uniform(0.0, 6.0, (n, nb)) * (rng.random((n, nb)) > 0.2)  # some empty bands
    per = np.geomspace(1.2, 18.0, nb)[None, :] * rng.uniform(0.9, 1.1, (n, nb))
    c2 = rng.uniform(0.0, 1.0, (n, nb))
    c1 = np.sqrt(c2) * rng.uniform(-1.0, 1.0, (n, nb))
    hws = rng.uniform(3.0, 20.0, n)
    sur = get_surrogate("zephir300")
    ref = "wave_follower" if hull == "rotation_only" else hull
    t = six_dof_band_terms(
        hws,
        amp,
        per,
        band_cos_psi=c1,
        band_cos_sq_psi=c2,
        surrogate=sur,
        scan_period_s=1.0,
        hull=ref,
    )

    def assembled(lever, hh):
        return np.sqrt(
            t["sigma_z_rot_ms"] ** 2
            - 2 * hh * t["heave_cross_sq"]
            + hh**2 * t["heave_leak_sq"]
            + lever**2 * t["translation_unit_sq"]
            - 2 * lever * hh * t["orbital_cross_sq"]
            + hh**2 * t["orbital_sq"]
        )

    for lever in (0.0, 1.5, 6.0):
        want = six_dof_band_sigma_z_ms(
            hws, amp, per, band_cos_psi=c1, band_cos_sq_psi=c2, lever_arm_m=lever, hull=hull
        )
        np.testing.assert_allclose(assembled(lever, h), want, rtol=1e-10)
    lo = six_dof_band_sigma_z_ms(
        hws, amp, per, band_cos_psi=c1, band_cos_sq_psi=c2, hull="rotation_only"
    )
    hi = six_dof_band_sigma_z_ms(hws, amp, per, band_cos_psi=c1, band_cos_sq_psi=c2, hull=ref)
    # sZ^2 is a convex quadratic in h (its h^2 coefficient H + O >= 0)
    mid = assembled(0.0, 0.5)
    assert np.all(mid**2 <= 0.5 * (lo**2 + hi**2) + 1e-12)
    assert not np.allclose(mid, lo) and not np.allclose(mid, hi)


def _follower_sea(
    direction_deg, spread_deg, hull="wave_follower", seed=1, fs=5.0, n=3000, tp_s=6.0
):
    """A 10-min JONSWAP sea (Tp ``tp_s``, 6 s) running ``direction_deg`` from the body x
    axis (east, yaw 0): roll, pitch (deg) and the hull's vertical velocity (m/s)."""
    systems = {
        "amplitude_deg": [[4.0]],
        "tp_s": [[tp_s]],
        "gamma": [[3.3]],
        "direction_deg": [[direction_deg]],
        "spread_deg": [[spread_deg]],
    }
    h = hull_motion_series(n, 1.0 / fs, systems, np.random.default_rng(seed), hull)
    return h["roll_deg"][0], h["pitch_deg"][0], np.gradient(h["heave_m"][0], 1.0 / fs)


@pytest.mark.parametrize("hull", ["wave_follower", "discus_buoy"])
@pytest.mark.parametrize("direction_deg", [0.0, 60.0, 90.0, 180.0, 240.0])
def test_heave_gives_each_bands_signed_direction_of_travel(direction_deg, hull):
    """The heave-tilt co-spectra give <cos psi> and <sin psi> of a narrow sea with their
    signs: waves running downwind (wind from the west, waves towards east) cos +1, upwind
    -1; waves running north, to the left of the wind, sin +1, south -1. For a
    wrapped-normal spread s, <cos psi> = cos(psi) exp(-s^2 / 2) and <sin psi> = sin(psi)
    exp(-s^2 / 2); a hull whose heave lags its tilt by phi (its response amplitude
    operators) gives those times cos(phi)."""
    from flidar_uq.data.imu import band_direction_moments, tilt_band_statistics
    from flidar_uq.physics.hull import get_hull

    spread = 10.0
    roll, pitch, w = _follower_sea(direction_deg, spread, hull)
    spec = tilt_band_statistics(roll, pitch, 0.0, 270.0, 5.0, velocity_up_ms=w)
    var = spec.var_along_deg2[0] + spec.var_across_deg2[0]
    strong = var > 0.05 * var.max()  # the bands that carry the sea
    _, r_z = get_hull(hull).relative_responses(spec.period_s[0])
    scale = np.exp(-0.5 * np.deg2rad(spread) ** 2) * np.cos(np.angle(r_z))
    psi = np.deg2rad(direction_deg)
    np.testing.assert_allclose(spec.cos_psi[0][strong], (np.cos(psi) * scale)[strong], atol=0.08)
    np.testing.assert_allclose(spec.sin_psi[0][strong], (np.sin(psi) * scale)[strong], atol=0.08)
    # <sin psi cos psi> = sin(2 psi) exp(-2 s^2) / 2, from the tilt alone (no hull phase)
    sincos = 0.5 * np.sin(2.0 * psi) * np.exp(-2.0 * np.deg2rad(spread) ** 2)
    np.testing.assert_allclose(spec.sincos_psi[0][strong], sincos, atol=0.04)
    # the tilt alone cannot tell the side: without the heave there is no measured side,
    # but the same <sin psi cos psi> (the tilt's own co-spectrum, taken from the PSD of the
    # along + across tilt), and with it the band's axis: <cos psi> of waves running along
    # that axis on its downwind side, |cos psi| exp(-s^2 / 2) for the follower
    alone = tilt_band_statistics(roll, pitch, 0.0, 270.0, 5.0)
    assert alone.cos_psi is None and alone.sin_psi is None
    np.testing.assert_allclose(alone.sincos_psi, spec.sincos_psi, rtol=0, atol=1e-12)
    _, axis = band_direction_moments(alone.var_along_deg2, alone.var_across_deg2, alone.sincos_psi)
    _, wind_axis = band_direction_moments(alone.var_along_deg2, alone.var_across_deg2)
    r1 = np.exp(-0.5 * np.deg2rad(spread) ** 2)
    np.testing.assert_allclose(axis[0][strong], abs(np.cos(psi)) * r1, atol=0.03)
    if direction_deg in (60.0, 240.0):  # the wind's axis alone: (2 cos^2 - 1)^(1/4) cos 60
        assert np.all(wind_axis[0][strong] < axis[0][strong] - 0.1)


@pytest.mark.parametrize("tp_s", [4.0, 14.0])
@pytest.mark.parametrize("direction_deg", [60.0, 200.0])
def test_heave_acceleration_gives_the_directions_its_velocity_gives(direction_deg, tp_s):
    """An inertial unit without a velocity output: the heave acceleration, integrated per
    frequency, gives each band's <cos psi>, <sin psi> and <sin psi cos psi> as the heave
    velocity does, in a short wind sea and in a 14-s swell (the longest tilt band,
    13-20 s); with an accelerometer's white noise; and across a 60-s gap in the series,
    which a time-domain integration would turn into an offset of the rest of the window."""
    from flidar_uq.data.imu import band_direction_from_heave, tilt_band_statistics

    roll, pitch, w = _follower_sea(direction_deg, 10.0, tp_s=tp_s)
    acc = np.gradient(w, 1.0 / 5.0)
    noisy = acc + 0.01 * np.random.default_rng(3).standard_normal(acc.size)
    from_w = tilt_band_statistics(roll, pitch, 0.0, 270.0, 5.0, velocity_up_ms=w)
    var = from_w.var_along_deg2[0] + from_w.var_across_deg2[0]
    strong = var > 0.05 * var.max()
    assert strong.sum() >= 2
    for a in (acc, noisy):
        from_a = tilt_band_statistics(roll, pitch, 0.0, 270.0, 5.0, acceleration_up_ms2=a)
        for key in ("cos_psi", "sin_psi", "sincos_psi"):
            got, want = getattr(from_a, key)[0], getattr(from_w, key)[0]
            np.testing.assert_allclose(got[strong], want[strong], atol=0.005, err_msg=key)
    # a 60-s gap (filled linearly) costs the acceleration about what it costs the velocity
    # (0.02-0.09 in <cos psi> here, the gap's own loss)
    gap = np.zeros(acc.size, bool)
    gap[1000:1300] = True
    gapped_w = tilt_band_statistics(
        roll, pitch, 0.0, 270.0, 5.0, velocity_up_ms=np.where(gap, np.nan, w)
    )
    gapped_a = tilt_band_statistics(
        roll, pitch, 0.0, 270.0, 5.0, acceleration_up_ms2=np.where(gap, np.nan, acc)
    )
    err_w, err_a = (
        np.abs(g.cos_psi[0] - from_w.cos_psi[0])[strong].max() for g in (gapped_w, gapped_a)
    )
    assert err_a <= 1.25 * err_w + 0.01, (err_a, err_w)
    # a velocity given wins over the acceleration
    both = tilt_band_statistics(
        roll, pitch, 0.0, 270.0, 5.0, velocity_up_ms=w, acceleration_up_ms2=5.0 * noisy
    )
    np.testing.assert_array_equal(both.cos_psi, from_w.cos_psi)
    with pytest.raises(ValueError, match="velocity_up_ms or acceleration_up_ms2"):
        band_direction_from_heave(None, roll[None], pitch[None], 5.0)


@pytest.mark.parametrize("direction_deg", [60.0, 200.0])
def test_heave_direction_of_a_band_is_weighted_by_its_tilt_power_not_its_frequencies(
    direction_deg,
):
    """Two follower waves in one band (periods 6.25 and 4.55 s, both inside the 4.47-6.50 s
    band, equal tilt amplitude, running ``direction_deg`` against the wind): the band's
    <cos psi> and <sin psi> are those of the direction. The heave velocity is ``g / omega``
    times the tilt, so the band's co-spectrum over the root of its summed heave and tilt
    powers falls short by sum(1/omega) / sqrt(2 sum(1/omega^2)) = 0.988 (0.494 for cos 60
    deg); each frequency's own ratio sqrt(P_tilt / P_w) does not."""
    from flidar_uq.data.imu import band_direction_from_heave
    from flidar_uq.physics.hull import G_MS2

    fs, t = 5.0, np.arange(3000) / 5.0
    psi = np.deg2rad(direction_deg)
    along = np.zeros_like(t)
    across = np.zeros_like(t)
    w = np.zeros_like(t)
    for f_hz, phase in ((0.16, 0.3), (0.22, 2.1)):  # bins of the 200-s Welch segments
        lean_deg = 2.0 * np.sin(2.0 * np.pi * f_hz * t + phase)
        along -= np.cos(psi) * lean_deg  # positive where the mast leans upwind
        across += np.sin(psi) * lean_deg
        w += np.deg2rad(lean_deg) * G_MS2 / (2.0 * np.pi * f_hz)
    cos_psi, sin_psi, _, _ = band_direction_from_heave(w[None], along[None], across[None], fs)
    band = 4
    edges = ms.band_edges_s(8, 1.0, 20.0)
    assert edges[band] < 1 / 0.22 and 1 / 0.16 < edges[band + 1]  # 4.47-6.50 s
    assert cos_psi[0, band] == pytest.approx(np.cos(psi), abs=0.002)
    assert sin_psi[0, band] == pytest.approx(np.sin(psi), abs=0.002)


@pytest.mark.parametrize("response", [1.0, 0.4, 0.0])
def test_heave_response_is_the_heave_against_a_wave_follower_with_the_same_tilt(response):
    """A hull whose heave is ``response`` times a wave follower's (``g / omega`` times its
    tilt, frequency by frequency) at two periods of different bands (4 and 9 s), plus a
    35-s heave (a mooring's surge of the water level) outside the tilt bands: the IMU
    series' heave response is ``response``, the 35-s heave not counted; from the heave
    acceleration the same; a series without a finite heave sample gives NaN, and so does
    one whose ratio is above the columns' bound of 10."""
    from flidar_uq.data.imu import band_direction_from_heave
    from flidar_uq.physics.hull import G_MS2

    fs, t = 5.0, np.arange(3000) / 5.0
    along, w = np.zeros_like(t), np.zeros_like(t)
    for f_hz, amp_deg, phase in ((0.25, 2.0, 0.3), (1.0 / 9.0, 1.0, 2.1)):
        lean_deg = amp_deg * np.sin(2.0 * np.pi * f_hz * t + phase)
        along -= lean_deg
        w += response * np.deg2rad(lean_deg) * G_MS2 / (2.0 * np.pi * f_hz)
    w += 0.3 * np.sin(2.0 * np.pi * t / 35.0)
    across = np.zeros_like(t)
    *_, got = band_direction_from_heave(w[None], along[None], across[None], fs)
    assert got[0] == pytest.approx(response, abs=0.01)
    acc = np.gradient(w, 1.0 / fs)
    *_, from_acc = band_direction_from_heave(
        None, along[None], across[None], fs, acceleration_up_ms2=acc[None]
    )
    assert from_acc[0] == pytest.approx(response, abs=0.02)
    *_, none = band_direction_from_heave(
        np.full((1, t.size), np.nan), along[None], across[None], fs
    )
    assert np.isnan(none[0])
    # a heave 100 times too large (cm/s read as m/s) is no measurement: NaN, not 40 or 100
    *_, wrong = band_direction_from_heave(100.0 * w[None], along[None], across[None], fs)
    assert np.isnan(wrong[0]) or response == 0.0


@pytest.mark.parametrize("hull", ["wave_follower", "discus_buoy", "spar"])
def test_series_velocities_measure_the_hulls_heave_and_horizontal_response(hull):
    """A 10-min sea under each named hull (yaw 0, so the body axes are east and north): the
    IMU series' heave velocity and its east and north velocities give the hull's heave and
    horizontal responses against a wave follower's with the same tilt
    (``heave_response``, ``horizontal_response``): within 2 % of the hull's own
    ``|R_z|``, ``|R_x|`` (relative to its tilt, :meth:`HullResponse.relative_responses`)
    weighted over the bands by a follower's translation power ``var_b c_b^2``, and 1
    within 2 % for the wave follower. The spar heaves more than a follower with its tilt
    and moves sideways less (1.45 and 0.24 here): one campaign-wide hull response cannot be
    both, the measurement is."""
    from flidar_uq.data.imu import tilt_band_statistics
    from flidar_uq.physics.hull import get_hull
    from flidar_uq.physics.seastate import hull_motion_series

    fs, n = 5.0, 3000
    systems = {
        "amplitude_deg": [[4.0]],
        "tp_s": [[6.0]],
        "gamma": [[3.3]],
        "direction_deg": [[60.0]],
        "spread_deg": [[10.0]],
    }
    h = hull_motion_series(n, 1.0 / fs, systems, np.random.default_rng(4), hull)
    roll, pitch = h["roll_deg"][0], h["pitch_deg"][0]
    w, ve, vn = (np.gradient(h[k][0], 1.0 / fs) for k in ("heave_m", "surge_m", "sway_m"))
    spec = tilt_band_statistics(
        roll, pitch, 0.0, 270.0, fs, velocity_up_ms=w, velocity_east_ms=ve, velocity_north_ms=vn
    )
    var = spec.var_along_deg2[0] + spec.var_across_deg2[0]
    weight = var * spec.period_s[0] ** 2  # var_b c_b^2 up to a constant
    r_x, r_z = get_hull(hull).relative_responses(spec.period_s[0])
    want_z = np.sqrt(np.sum(weight * np.abs(r_z) ** 2) / weight.sum())
    want_x = np.sqrt(np.sum(weight * np.abs(r_x) ** 2) / weight.sum())
    assert spec.heave_response[0] == pytest.approx(want_z, rel=0.02)
    assert spec.horizontal_response[0] == pytest.approx(want_x, rel=0.02)
    if hull == "wave_follower":
        assert spec.heave_response[0] == pytest.approx(1.0, abs=0.02)
        assert spec.horizontal_response[0] == pytest.approx(1.0, abs=0.02)
    if hull == "spar":
        assert spec.heave_response[0] > 1.1 and spec.horizontal_response[0] < 0.5


@pytest.mark.parametrize("direction_deg", [45.0, 130.0])
def test_measured_band_moments_are_a_spread_of_directions_and_reach_the_dbs_sigma_z(direction_deg):
    """The heave-tilt and tilt-tilt co-spectra of one band make a moment matrix of
    (1, cos psi, sin psi) that is positive semi-definite, as that of any spread of
    directions is (so are then the DBS Gram matrices). With <sin psi cos psi> taken as 0 instead
    (the record without its tilt_band{b}_sincos_psi columns), a narrow sea oblique to the
    wind has a matrix that no spread of directions has (a negative eigenvalue). The record
    model's DBS sigma_Z takes the measured moment: it is the harmonic sum with these
    moments, and not with the moment taken as 0."""
    from flidar_uq.data.imu import (
        tilt_band_statistics,
        tilt_bands_from_records,
        tilt_spectrum_columns,
    )
    from flidar_uq.inference.record_motion import gram_sigma_z_ms, motion_gram
    from flidar_uq.physics.dbs_sigma_z import (
        _moment_matrix,
        band_moments_to_wind,
        dbs_harmonic_sigma_z_ms,
        rotate_moments,
    )

    roll, pitch, w = _follower_sea(direction_deg, 10.0)
    spec = tilt_band_statistics(roll, pitch, 0.0, 270.0, 5.0, velocity_up_ms=w)
    # the directions alone: the heave's measured size (0.99-1.00 of a follower's here)
    # would set the translation instead of the hull response h = 1 below
    rec = (
        pd.DataFrame(tilt_spectrum_columns(spec))
        .drop(columns="heave_response_ratio")
        .assign(hws_mean_ms=8.0, wd_mean_deg=270.0, heading_mean_deg=0.0)
    )
    sincos = [f"tilt_band{b}_sincos_psi" for b in range(1, 9)]
    assert set(sincos) <= set(rec.columns)
    bands = tilt_bands_from_records(rec)
    var = spec.var_along_deg2[0] + spec.var_across_deg2[0]
    strong = var > 0.05 * var.max()

    def min_eigenvalue(sc):
        mom = band_moments_to_wind(
            bands["cos_psi_measured"][0], bands["cos_sq_psi"][0],
            bands["sin_psi_measured"][0], sc,
        )  # fmt: skip
        return np.linalg.eigvalsh(_moment_matrix(mom)[strong]).min()

    assert min_eigenvalue(bands["sincos_psi_measured"][0]) > -0.01
    assert min_eigenvalue(0.0) < -0.1
    # the record model's DBS sigma_Z is the harmonic sum over the bands with these measured
    # moments turned into the body frame (heading 30 deg: the wind blows towards 330 deg)
    turned = rec.assign(heading_mean_deg=30.0)
    mom = band_moments_to_wind(
        bands["cos_psi_measured"][0], bands["cos_sq_psi"][0],
        bands["sin_psi_measured"][0], bands["sincos_psi_measured"][0],
    )  # fmt: skip
    want = dbs_harmonic_sigma_z_ms(
        bands["amplitude_deg"][0], bands["period_s"][0], hws_ms=8.0, wind_body_deg=330.0,
        direction_moments_=rotate_moments(mom, 330.0), lever_arm_m=3.0, lidar="windcube_v2",
        dwell_average=True,
    )  # fmt: skip
    for table, same in ((turned, True), (turned.assign(**dict.fromkeys(sincos, 0.0)), False)):
        gram = motion_gram(table, lidar="windcube_v2", band_nodes=1)
        got = gram_sigma_z_ms(gram, lever_arm_m=3.0, hull_response=1.0)[0]
        assert np.isclose(got, want, rtol=1e-9) == same, (got, want)
    # how much the cross moment weighs: for a WindCube v2 that gave one wind a cycle 11 % and
    # 1.3 % here; after every beam (its windows' five beam orders) 3e-5 and 4e-4
    once = dataclasses.replace(get_lidar("windcube_v2"), every_beam_output=False)
    want_once = dbs_harmonic_sigma_z_ms(
        bands["amplitude_deg"][0], bands["period_s"][0], hws_ms=8.0, wind_body_deg=330.0,
        direction_moments_=rotate_moments(mom, 330.0), lever_arm_m=3.0, lidar=once,
        dwell_average=True,
    )  # fmt: skip
    gram = motion_gram(turned.assign(**dict.fromkeys(sincos, 0.0)), lidar=once, band_nodes=1)
    got = gram_sigma_z_ms(gram, lever_arm_m=3.0, hull_response=1.0)[0]
    assert abs(got / want_once - 1.0) > 1e-3


def test_measured_direction_reaches_the_record_columns_and_the_record_model():
    """tilt_spectrum_columns writes tilt_band{b}_cos_psi; tilt_bands_from_records reads it;
    the record model's band sum takes it instead of the wave-age rule (a wave follower's
    heave-tilt cross term changes sign when the waves run upwind)."""
    from flidar_uq.data.imu import (
        tilt_band_statistics,
        tilt_bands_from_records,
        tilt_spectrum_columns,
    )
    from flidar_uq.inference.record_motion import motion_gram

    grams = {}
    for d in (0.0, 180.0):
        roll, pitch, w = _follower_sea(d, 10.0)
        spec = tilt_band_statistics(roll, pitch, 0.0, 270.0, 5.0, velocity_up_ms=w)
        rec = pd.DataFrame(tilt_spectrum_columns(spec)).assign(hws_mean_ms=8.0)
        assert {f"tilt_band{b}_cos_psi" for b in range(1, 9)} <= set(rec.columns)
        assert {f"tilt_band{b}_sin_psi" for b in range(1, 9)} <= set(rec.columns)
        bands = tilt_bands_from_records(rec)
        np.testing.assert_array_equal(bands["cos_psi_measured"][0], spec.cos_psi[0])
        np.testing.assert_array_equal(bands["sin_psi_measured"][0], spec.sin_psi[0])
        np.testing.assert_array_equal(bands["sincos_psi_measured"][0], spec.sincos_psi[0])
        grams[d] = motion_gram(rec)
        # without the measured direction the wave-age rule takes the wind sea downwind
        grams[d, "rule"] = motion_gram(
            rec.drop(columns=[f"tilt_band{b}_cos_psi" for b in range(1, 9)])
        )
    cross = [c for c in grams[0.0].columns if c.startswith("gram_") and c != "gram_kk"]
    downwind, upwind = grams[0.0], grams[180.0]
    # the same tilt spectrum, so the rule gives the same gram for both seas ...
    np.testing.assert_allclose(
        grams[0.0, "rule"][cross].to_numpy(float),
        grams[180.0, "rule"][cross].to_numpy(float),
        rtol=0.05,
    )
    # ... while the measured direction tells them apart
    assert not np.allclose(downwind[cross].to_numpy(float), upwind[cross].to_numpy(float), rtol=0.2)
