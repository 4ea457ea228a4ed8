"""Tests of flidar_uq.campaign.physics_mode (physics mode of the virtual campaign)."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from flidar_uq.campaign.physics_mode import generate_campaign
from flidar_uq.campaign.scenarios import CampaignConfig, load_scenario
from flidar_uq.data.io import (
    read_records,
    validate_imu_series,
    validate_los_series,
    validate_records,
    write_records,
)
from flidar_uq.physics import lidar
from flidar_uq.physics.motion import rotation_matrix
from flidar_uq.physics.simulator import sigma_z, simulate_scans

SHIPPED = ("default", "tiny", "ijmuiden_60day", "hexapod_catalogue", "reservoir")


def _harmonic_scenario(n_records, *, ti=0.0, lever_arm_m=0.0, amp=3.0, per=4.0, hws=8.0):
    """Single harmonic roll/pitch motion, constant wind: the sigma_Z kernel's setting."""
    return {
        "name": "harmonic_test",
        "n_records": n_records,
        "heights_m": [85.0],
        "chunk_records": 8,
        "lidar": {
            "scan_dropout_probability": 0.0,
            "record_outage_probability": 0.0,
            "lever_arm_m": [0.0, 0.0, lever_arm_m],
        },
        "wind": {
            "hws_min_ms": hws,
            "hws_max_ms": hws,
            "wd_sd_deg": 0.0,
            "shear_exponent_mean": 0.0,
            "shear_exponent_sd": 0.0,
            "ti_model": "constant_ti",
            "ti_params": {"ti": ti},
        },
        "motion": {
            "model": "harmonic",
            "harmonic": {"amplitude_range_deg": [amp, amp], "period_range_s": [per, per]},
        },
        "imu": {"gap_probability": 0.0},
    }


@pytest.fixture(scope="module")
def tiny():
    # the first 48 records (8 h) of the tiny scenario, with the large LOS output
    sc = load_scenario("tiny") | {"n_records": 48}
    return generate_campaign(sc, 20181122, return_imu=True, return_los=True)


# --------------------------------------------------------------------------- adapters


@pytest.mark.parametrize("cw", [True, False])
def test_vad_adapter_reproduces_simulator_simulate_scans(rng, cw):
    """The vectorised path of the campaign = simulator.simulate_scans, scan by scan."""
    g = lidar.ZEPHIR300
    n_scans, n_los = 40, g.n_los
    shift = rng.integers(0, n_los, n_scans)  # scan phase: cyclic shift of the azimuth slots
    a_idx = (shift[:, None] + np.arange(n_los)) % n_los
    az_slots = 2 * np.pi * np.arange(n_los) / n_los
    t = np.arange(n_los) * g.los_duration_s
    ph = rng.uniform(0, 2 * np.pi, (2, n_scans, 1))
    roll = np.deg2rad(4.0) * np.sin(2 * np.pi * t / 3.0 + ph[0])
    pitch = np.deg2rad(4.0) * np.sin(2 * np.pi * t / 3.0 + ph[1])
    hws = rng.uniform(3.0, 15.0, n_scans)
    wd = rng.uniform(0.0, 2 * np.pi, n_scans)
    wind = np.stack([-hws * np.sin(wd), -hws * np.cos(wd), 0.3 * rng.standard_normal(n_scans)], -1)
    # head velocity of a 2.5 m lever arm (omega x r ~ 0.3 m/s), smooth during the scan
    v_head = np.zeros((n_scans, n_los, 3))
    v_head[..., 0] = 2.5 * np.gradient(pitch, g.los_duration_s, axis=-1)
    v_head[..., 1] = -2.5 * np.gradient(roll, g.los_duration_s, axis=-1)
    v_r_sim, ret = simulate_scans(
        g,
        wind,
        roll,
        pitch,
        head_velocity_ms=v_head,
        azimuth_rad=az_slots[a_idx],
        sign_ambiguity=cw,
    )
    m_body = lidar.beam_unit_vectors_body(g, az_slots)[a_idx]
    pinv_t = lidar.vad_pseudo_inverse(lidar.beam_unit_vectors_body(g, az_slots)).T[a_idx]
    d_earth = np.einsum("...ij,...j->...i", rotation_matrix(roll, pitch, 0.0 * roll), m_body)
    v_r = np.einsum("...k,...k->...", d_earth, wind[:, None, :] - v_head)
    np.testing.assert_allclose(np.abs(v_r), np.abs(v_r_sim), atol=1e-12)
    uvw, resid = lidar.vad_sign_unfolding(pinv_t, m_body, np.abs(v_r), np.sign(v_r), 1 if cw else 0)
    hws = np.hypot(uvw[:, 0], uvw[:, 1])
    if cw:
        # |v_r| is not smooth where a line of sight crosses v_r = 0: the sign unfolding and
        # the simulator's Gauss-Newton may stop at stationary points mm/s apart
        assert np.median(np.abs(hws - ret.hws_ms)) < 1e-9
        np.testing.assert_allclose(hws, ret.hws_ms, atol=5e-3)
    else:
        np.testing.assert_allclose(hws, ret.hws_ms, atol=1e-9)
        np.testing.assert_allclose(resid, ret.residual_ms, atol=1e-9)


# --------------------------------------------------------------------------- format


def test_tiny_campaign_passes_data_layer_validation_unchanged(tiny):
    validated = validate_records(tiny.records, "tiny")
    assert len(validated) == len(tiny.records) == 48 * 3
    validate_imu_series(tiny.imu, "tiny-imu")
    validate_los_series(tiny.los, "tiny-los")
    rec = tiny.records
    for col in (
        "true_hws_mean_ms",
        "true_hws_std_ms",
        "true_ti",
        "true_amplitude_deg",
        "true_period_s",
    ):
        assert col in rec and rec[col].notna().all()
    assert rec["ref_hws_std_ms"].notna().all()


def test_tiny_campaign_round_trips_through_the_record_writer(tiny, tmp_path):
    path = write_records(tiny.records, tmp_path / "tiny.csv")
    back = read_records(path)
    assert list(back.columns) == list(validate_records(tiny.records).columns)
    np.testing.assert_allclose(back["hws_std_ms"], tiny.records["hws_std_ms"], rtol=1e-9)


def test_tiny_campaign_imu_statistics_track_the_truth(tiny):
    rec = tiny.records.drop_duplicates("timestamp")
    ok = rec["roll_amplitude_deg"].notna()
    # IMU noise 0.05 deg and sqrt(2)*std estimator: amplitudes within a few %
    ratio = rec.loc[ok, "roll_amplitude_deg"] / rec.loc[ok, "true_roll_amplitude_deg"]
    assert ratio.median() == pytest.approx(1.0, abs=0.02)
    # the motion's dominant period matches the sea state's (unimodal records)
    uni = ok & rec["true_period2_s"].isna()
    per = 0.5 * (rec.loc[uni, "roll_period_s"] + rec.loc[uni, "pitch_period_s"])
    assert (per / rec.loc[uni, "true_period_s"]).median() == pytest.approx(1.0, abs=0.05)


def test_reference_lidar_sees_the_true_variance(tiny):
    r = tiny.records
    ratio = (r["ref_hws_std_ms"] / r["true_hws_std_ms"]).median()
    assert ratio == pytest.approx(1.0, abs=0.1)
    # the moving lidar sees more (motion adds variance)
    assert (r["hws_std_ms"] > r["ref_hws_std_ms"]).mean() > 0.8


def test_imu_gaps_and_outages_are_flagged_not_dropped(tiny):
    r = tiny.records
    assert r["imu_availability_pct"].min() < 100.0  # tiny.yaml: gaps are frequent
    out = r["availability_pct"] == 0.0
    assert r.loc[out, "hws_mean_ms"].isna().all()


# --------------------------------------------------------------------------- determinism


def test_same_seed_identical_and_independent_of_chunking_and_workers():
    sc = load_scenario("tiny") | {"n_records": 10}
    a = generate_campaign(sc, 3, chunk_records=3).records
    b = generate_campaign(sc, 3, chunk_records=10).records
    pd.testing.assert_frame_equal(a, b)
    c = generate_campaign(sc, np.random.SeedSequence(3), chunk_records=4, n_workers=2).records
    pd.testing.assert_frame_equal(a, c)
    d = generate_campaign(sc, 4).records
    assert not np.allclose(a["hws_std_ms"], d["hws_std_ms"], equal_nan=True)


# --------------------------------------------------------------------------- configs


@pytest.mark.parametrize("name", SHIPPED)
def test_shipped_scenarios_load_and_validate(name):
    cfg = CampaignConfig.from_dict(load_scenario(name))
    assert cfg["name"] == name


def test_default_campaign_is_about_8600_records_of_60_days():
    cfg = CampaignConfig.from_dict(load_scenario("default"))
    assert cfg["n_records"] * 600.0 / 86400.0 == pytest.approx(60.0)
    assert len(cfg["heights_m"]) == 3


def test_hexapod_catalogue_has_seed001_table_a1_motion_types():
    cases = load_scenario("hexapod_catalogue")["motion"]["harmonic"]["cases"]
    keys = {k for c in cases for k, v in c.items() if k.endswith(("_deg", "_m")) and v}
    assert {"heave_amplitude_m", "sway_amplitude_m", "yaw_amplitude_deg"} <= keys
    assert {"roll_amplitude_deg", "pitch_amplitude_deg"} <= keys
    # Table A1: test 52 is a 20 deg N-S tilt (pitch) at 0.1 Hz
    t52 = next(c for c in cases if c["label"].startswith("test 52"))
    assert t52["pitch_amplitude_deg"] == 20 and t52["period_s"] == pytest.approx(10.0)


def test_hexapod_cases_generate_with_their_motion():
    sc = load_scenario("hexapod_catalogue")
    cases = [c | {"n_records": 1} for c in sc["motion"]["harmonic"]["cases"][:8]]
    sc["motion"]["harmonic"]["cases"] = cases
    rec = generate_campaign(sc, 1).records
    validate_records(rec, "hexapod")
    first = rec.groupby("true_case")["true_pitch_amplitude_deg"].first()
    assert first.loc[0] == 0.0  # baseline
    assert first.loc[5] == pytest.approx(3.0, rel=1e-3)  # test 08: 3 deg N-S tilt


def test_scenario_misuse_raises():
    with pytest.raises(ValueError, match="unknown key 'wind.hws_mean'"):
        CampaignConfig.from_dict({"wind": {"hws_mean": 8.0}})
    with pytest.raises(ValueError, match=r"imu.rate_hz must be in \[5, 20\] Hz, got 50"):
        CampaignConfig.from_dict({"imu": {"rate_hz": 50.0}})
    with pytest.raises(ValueError, match="no scenario file"):
        load_scenario("no_such_scenario")
    with pytest.raises(ValueError, match="start_utc must be a UTC time on a record boundary"):
        CampaignConfig.from_dict({"start_utc": "2015-04-01T00:05:00Z"})
    with pytest.raises(ValueError, match="n_records must be a positive integer"):
        CampaignConfig.from_dict({"n_records": 0})


# --------------------------------------------------------------------------- physics


def _excess_vs_kernel(rec, lever_arm_m, amp, per, hws):
    k = sigma_z(hws, amp, per, float(rec["true_wd_deg"].iloc[0]), lever_arm_m=lever_arm_m)
    z2 = rec["true_sigma_z_ms"] ** 2
    return z2, k.sigma_z_ms**2


@pytest.mark.parametrize(
    ("lever_arm_m", "per", "scan_phase"),
    [(0.0, 4.3, "prism"), (3.0, 4.0, "random")],
)
def test_single_harmonic_motion_sigma_z_matches_kernel(lever_arm_m, per, scan_phase):
    """No turbulence: the scan-to-scan std of Z equals the sigma_Z phase integral."""
    amp, hws = 3.0, 8.0
    # the within-record var(Z) depends on the fixed roll-pitch phase offset (CV ~0.6
    # across records): 48 records give a ~9 % standard error on the mean of var(Z)
    sc = _harmonic_scenario(48, lever_arm_m=lever_arm_m, amp=amp, per=per, hws=hws)
    sc["lidar"]["scan_phase"] = scan_phase
    rec = generate_campaign(sc, 5).records
    z2, k2 = _excess_vs_kernel(rec, lever_arm_m, amp, per, hws)
    se = z2.std(ddof=1) / np.sqrt(len(z2))
    assert abs(z2.mean() - k2) < 3 * se + 0.01 * k2
    assert rec["true_amplitude_deg"].to_numpy() == pytest.approx(amp, rel=1e-3)


@pytest.mark.slow
def test_single_harmonic_excess_variance_matches_sigma_z_kernel_with_turbulence():
    """sigma_moving^2 - sigma_ref^2 = sigma_Z^2 within sampling error (design.md)."""
    amp, per, hws, arm = 3.0, 4.3, 8.0, 2.5
    rec = generate_campaign(
        _harmonic_scenario(120, ti=0.1, lever_arm_m=arm, amp=amp, per=per, hws=hws), 9
    ).records
    excess = rec["hws_std_ms"] ** 2 - rec["ref_hws_std_ms"] ** 2
    k2 = sigma_z(hws, amp, per, float(rec["true_wd_deg"].iloc[0]), lever_arm_m=arm).sigma_z_ms ** 2
    se = excess.std(ddof=1) / np.sqrt(len(excess))
    assert abs(excess.mean() - k2) < 3 * se


def test_lever_arm_raises_sigma_z_design_fact():
    # design.md: a head 4 m above the rotation centre raises sigma_Z at 3 deg, 4 s
    base = generate_campaign(_harmonic_scenario(4, lever_arm_m=0.0, hws=5.0), 2).records
    arm = generate_campaign(_harmonic_scenario(4, lever_arm_m=4.0, hws=5.0), 2).records
    assert arm["true_sigma_z_ms"].mean() > 1.5 * base["true_sigma_z_ms"].mean()
