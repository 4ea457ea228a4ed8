"""Tests of flidar_uq.physics.lidar_response: the HWS std a motionless lidar measures vs the point std."""

from __future__ import annotations

import numpy as np
import pytest

from flidar_uq.physics import lidar
from flidar_uq.physics.lidar_response import lidar_point_log_sd, lidar_std_ratio, scan_response
from flidar_uq.physics.turbulence import kaimal_series


def test_scan_response_limits_zephir300():
    # f -> 0: the scan sees a constant wind exactly (u' passes, v' and w' cancel)
    h = scan_response([1e-6, 200.0], "zephir300")
    np.testing.assert_allclose(h[:, 0], [1.0, 0.0, 0.0], atol=1e-9)
    # far above the line-of-sight rate the boxcar of each line of sight removes it all
    assert np.all(h[:, 1] < 1e-3)


def test_scan_response_w_peak_at_scan_frequency_cot_theta():
    # For a VAD of N equally spaced lines of sight over T, w' enters the along-wind
    # retrieval as (2 cot(th) / N) sum cos(psi_k) w'(t_k): a fluctuation at the scan
    # frequency 1 / T: sum_k cos(psi0 + 2 pi k / N) exp(2 pi i k / N) = N exp(-i psi0) / 2,
    # so |H|^2 = (cot th)^2 whatever the scan phase (times the boxcar of a LOS).
    g = lidar.get_lidar("zephir300")
    h = scan_response([1.0 / g.scan_period_s], g)
    box = np.sinc(g.los_duration_s / g.scan_period_s) ** 2
    expected = box / np.tan(g.half_cone_angle_rad) ** 2
    assert h[2, 0] == pytest.approx(expected, rel=1e-9)


def _simulated_ratio(u_ms, z_m, n_records, rng):
    """Variance ratio from simulated scans of a motionless ZephIR-like VAD (linear fit).

    Scans start after a random refocus delay (0.3-0.7 s, as the virtual campaign's), so
    they are not phase-locked to the record: contiguous 1-s scans would alias the
    w' content at the scan frequency to a record-constant bias that a std cannot see.
    Each fluctuation component is simulated on its own (the others zero) and the
    variances summed, which removes the noisy cross terms of a joint estimate.
    """
    g = lidar.get_lidar("zephir300")
    dt = g.los_duration_s
    n = int(600.0 / dt)
    x = kaimal_series(n, dt, np.full(n_records, u_ms), 1.0, z_m, rng, exact_variance=True)
    ratios = []
    for r in range(n_records):
        gaps = g.n_los + rng.integers(15, 36, size=n // g.n_los)  # 0.3-0.7 s delays
        starts = np.cumsum(gaps) - gaps[0]
        starts = starts[starts + g.n_los <= n]
        idx = starts[:, None] + np.arange(g.n_los)  # (J, L) sample of every line of sight
        beta = rng.uniform(0, 2 * np.pi)  # wind direction relative to the scan
        az = (
            rng.uniform(0, 2 * np.pi, size=(starts.size, 1))
            + 2 * np.pi * np.arange(g.n_los) / g.n_los
        )
        d = lidar.beam_unit_vectors_body(g, az)  # (J, L, 3)
        p = lidar.vad_pseudo_inverse(d)  # (J, 3, L)
        e = np.array(
            [[np.cos(beta), np.sin(beta), 0.0], [-np.sin(beta), np.cos(beta), 0.0], [0.0, 0.0, 1.0]]
        )
        var_scan = var_point = 0.0
        for j in range(3):
            wind = u_ms * e[0] + x[r, j, :, None] * e[j]  # (n, 3)
            vr = np.einsum("jlk,jlk->jl", d, wind[idx])
            uvw = np.einsum("jkl,jl->jk", p, vr)
            var_scan += np.hypot(uvw[:, 0], uvw[:, 1]).var()
            var_point += np.hypot(*wind[:, :2].T).var()
        ratios.append(var_scan / var_point)
    ratios = np.array(ratios)
    return ratios.mean(), ratios.std(ddof=1) / np.sqrt(n_records)


@pytest.mark.parametrize(("u_ms", "z_m"), [(6.0, 85.0), (14.0, 27.0)])
def test_lidar_std_ratio_matches_simulated_vad_scans(u_ms, z_m):
    # independent check: least-squares VAD of simulated Kaimal series (u', v', w') at the
    # line-of-sight rate (band-limited at its Nyquist frequency, 25 Hz) against the
    # spectral formula (Sathe et al. 2011, temporal part)
    rng = np.random.default_rng(11)
    mean, se = _simulated_ratio(u_ms, z_m, 32, rng)
    nyquist = 0.5 / lidar.get_lidar("zephir300").los_duration_s
    g = float(lidar_std_ratio(u_ms, z_m, "zephir300", turbulence_max_frequency_hz=nyquist))
    assert g > 1.0  # in-scan leakage of w' dominates the scan averaging for a ZephIR
    # the formula neglects the second-order cross-wind term (both sides, < 1e-3)
    assert g**2 == pytest.approx(mean, abs=3 * se + 1e-3)
    # the continuous spectrum puts the variance above 25 Hz out of reach of the scan
    assert lidar_std_ratio(u_ms, z_m) < g


def test_lidar_std_ratio_depends_on_lambda1_over_u_only():
    # Kaimal spectra depend on L / U: doubling both z (below 60 m) and U changes nothing
    a = lidar_std_ratio(5.0, 20.0)
    b = lidar_std_ratio(10.0, 40.0)
    assert a == pytest.approx(b, rel=1e-6)
    # above 60 m Lambda_1 is constant (IEC 61400-1 Eq. 5)
    assert lidar_std_ratio(9.0, 85.0) == pytest.approx(lidar_std_ratio(9.0, 120.0), rel=1e-12)


def test_lidar_std_ratio_without_vertical_turbulence_is_below_one():
    # with no w' the scan only averages u' (and v' enters at 2/T): the lidar sees less
    g = lidar_std_ratio(np.array([5.0, 10.0, 15.0]), 85.0, sigma_ratios=(1.0, 0.0, 0.0))
    assert np.all(g < 1.0) and np.all(g > 0.95)
    # the slower DBS scan (4 s) averages more of u'
    g_dbs = lidar_std_ratio(
        np.array([5.0, 10.0, 15.0]), 85.0, "windcube_v1", sigma_ratios=(1, 0, 0)
    )
    assert np.all(g_dbs < g)


def test_lidar_std_ratio_invalid_inputs():
    out = lidar_std_ratio(np.array([0.0, 8.0, np.nan, 8.0]), np.array([85.0, -1.0, 85.0, 85.0]))
    assert np.all(np.isnan(out[:3])) and np.isfinite(out[3])
    with pytest.raises(ValueError, match="record_length_s"):
        lidar_std_ratio(8.0, 85.0, record_length_s=0.0)
    with pytest.raises(ValueError, match="sigma_ratios"):
        lidar_std_ratio(8.0, 85.0, sigma_ratios=(1.0, 0.8))
    with pytest.raises(ValueError, match="turbulence_max_frequency_hz"):
        lidar_std_ratio(8.0, 85.0, turbulence_max_frequency_hz=-1.0)
    with pytest.raises(ValueError, match="n_dir"):
        scan_response([1.0], n_dir=2)


def test_point_scatter_and_ratio_match_the_virtual_campaign():
    # The virtual campaign's motionless reference lidar against its point truth (1-Hz
    # series): neither function sees the campaign; both get only its sampling
    # (campaign.reference_sampling). 150 records x 3 heights.
    from flidar_uq.campaign.physics_mode import generate_campaign
    from flidar_uq.campaign.scenarios import load_scenario, reference_sampling

    scen = load_scenario("default") | {"n_records": 150}
    rec = generate_campaign(scen, 5, n_workers=1).records
    rec = rec[(rec["ref_hws_mean_ms"] > 3) & (rec["ref_hws_mean_ms"] < 20)]
    samp = reference_sampling(scen)
    hws, z = rec["ref_hws_mean_ms"].to_numpy(), rec["height_m"].to_numpy()
    g = lidar_std_ratio(hws, z, turbulence_max_frequency_hz=0.5 / samp["turbulence_dt_s"])
    e = np.log(rec["ref_hws_std_ms"].to_numpy() / (g * rec["true_hws_std_ms"].to_numpy()))
    sd = lidar_point_log_sd(
        hws,
        z,
        heights_in_turn=samp["heights_in_turn"],
        refocus_delay_s=samp["refocus_delay_s"],
        point_sample_interval_s=samp["point_sample_interval_s"],
        turbulence_dt_s=samp["turbulence_dt_s"],
    )
    n = e.size
    # mean log ratio ~ 0 once divided by g (its sampling error: sd / sqrt(n))
    assert abs(e.mean()) < 3 * e.std() / np.sqrt(n) + 0.003
    # scatter: the sample sd of n values has a relative error ~ 1 / sqrt(2 n)
    assert np.sqrt(np.mean(sd**2)) == pytest.approx(e.std(ddof=1), rel=3 / np.sqrt(2 * n) + 0.05)
    # without dividing by g the campaign's ratio is biased high (what g removes)
    assert np.mean(e + np.log(g)) > 3 * e.std() / np.sqrt(n)


def test_point_scatter_deterministic_and_grows_with_fewer_scans():
    a = lidar_point_log_sd([6.0, 12.0], 85.0, heights_in_turn=1, n_records=16, seed=4)
    b = lidar_point_log_sd([6.0, 12.0], 85.0, heights_in_turn=1, n_records=16, seed=4)
    np.testing.assert_array_equal(a, b)
    c = lidar_point_log_sd([6.0, 12.0], 85.0, heights_in_turn=4, n_records=16, seed=4)
    assert np.all(c > a)  # a quarter of the scans per height: a noisier lidar std
    assert np.all(np.isnan(lidar_point_log_sd([0.0], 85.0, n_records=16)))
    with pytest.raises(ValueError, match="heights_in_turn"):
        lidar_point_log_sd(6.0, 85.0, heights_in_turn=0)
    with pytest.raises(ValueError, match="n_records"):
        lidar_point_log_sd(6.0, 85.0, n_records=2)


def test_dbs_std_ratio_turns_with_the_wind_against_its_beams():
    """A DBS lidar's beams are fixed to its body and taken one after another: its std ratio
    to the point std depends on the wind's direction against them, half-turn periodic (a
    quarter turn changes which pair, taken at which instants, sees the along-wind
    component). The average over directions of g^2 is the direction-averaged g^2 (the
    transfer is linear in the spectra); NaN is that average; a conical scan ignores it."""
    hws, z = 8.0, 80.0
    beta = np.arange(0.0, 360.0, 5.0)
    g = lidar_std_ratio(np.full(beta.size, hws), z, "windcube_v2", wind_body_deg=beta)
    g_avg = float(lidar_std_ratio(hws, z, "windcube_v2"))
    np.testing.assert_allclose(g[:36], g[36:], rtol=1e-12)  # half-turn periodic
    assert g[9] - g[27] > 0.03  # 45 deg against 135 deg: not quarter-turn periodic
    # exact on the nodes; between them the 7.5-deg interpolation
    np.testing.assert_allclose(np.sqrt(np.mean(g**2)), g_avg, rtol=2e-4)
    assert float(lidar_std_ratio(hws, z, "windcube_v2", wind_body_deg=np.nan)) == g_avg
    flat = lidar_std_ratio(np.full(beta.size, hws), z, "zephir300", wind_body_deg=beta)
    np.testing.assert_array_equal(flat, lidar_std_ratio(hws, z, "zephir300"))


def test_dbs_direction_swing_of_the_std_ratio_matches_simulated_scans():
    """The analytic g(beta) of a WindCube v2 against 10-min records of simulated scans
    (IEC Kaimal series, the beams at their own instants): the swing between the wind
    blowing between its first two beams (45 deg) and between the second and third (135
    deg) is the simulated one within 0.015 in log (the simulated means' standard error
    ~0.004); and the simulated scatter is larger at 45 deg, as lidar_point_log_sd has it."""
    from flidar_uq.physics import lidar_response as lr

    sim = lr._scan_settings("test", "windcube_v2", 1, (0.0, 0.0), 0.25, 1.0, 600.0)
    hws, n = 6.0, 160
    logs = {}
    for b in (45.0, 135.0):
        rng = np.random.default_rng(17)
        x_t = sim.held_turbulence(rng, n, hws, 85.0)
        out = []
        for r in range(n):
            starts, phase = sim.schedule(rng)
            wind = sim.wind(hws, x_t[r], np.deg2rad(b))
            out.append(sim.log_ratio(wind, starts, phase, sim.point_std(wind)))
        logs[b] = np.asarray(out)
    simulated = logs[45.0].mean() - logs[135.0].mean()
    g = lidar_std_ratio(
        np.full(2, hws), 85.0, "windcube_v2", turbulence_max_frequency_hz=2.0,
        wind_body_deg=np.array([45.0, 135.0]),
    )  # fmt: skip
    assert abs(np.log(g[0] / g[1]) - simulated) < 0.015, (np.log(g[0] / g[1]), simulated)
    sd = lidar_point_log_sd(
        np.full(2, hws), 85.0, "windcube_v2", turbulence_dt_s=0.25, seed=5,
        wind_body_deg=np.array([45.0, 135.0]),
    )  # fmt: skip
    assert sd[0] > sd[1] + 0.004
    assert logs[45.0].std() > logs[135.0].std()
