"""The record motion model: per-record sigma_Z description and the global fit on it."""

import logging

import numpy as np
import pandas as pd
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from flidar_uq.inference import SamplerSettings, translation_unit_sq
from flidar_uq.inference import loo as loo_mod
from flidar_uq.inference import record_fit as rf
from flidar_uq.inference.loo import _loo
from flidar_uq.inference.record_fit import (
    RECORD_MODEL_NAMES,
    _record_loglik_pointwise,
    fit_record_model,
    log_prob_record_model,
)
from flidar_uq.inference.record_motion import (
    MOTION_DESCRIPTIONS,
    gram_from_cw_terms,
    per_record_motion,
)
from flidar_uq.physics.surrogate import get_surrogate


def test_along_wind_description_is_a_single_axis_tilt_of_sqrt2_std():
    rec = pd.DataFrame(
        {
            "hws_mean_ms": [8.0, 8.0],
            "tilt_along_wind_std_deg": [2.0, 0.0],
            "tilt_period_mean_s": [4.0, 4.0],
            "roll_amplitude_deg": [9.0, 9.0],  # ignored: the richer description wins
            "pitch_amplitude_deg": [9.0, 9.0],
            "roll_period_s": [9.0, 9.0],
            "pitch_period_s": [9.0, 9.0],
        }
    )
    out = per_record_motion(rec)
    assert list(out["motion_description"]) == ["along_wind", "along_wind"]
    assert out["motion_amplitude_deg"].iloc[0] == pytest.approx(2.0 * np.sqrt(2.0))
    expect = get_surrogate().sigma_z_ms(8.0, 2.0 * np.sqrt(2.0), 4.0)
    assert out["sigma_z_rot_ms"].iloc[0] == pytest.approx(float(expect))
    assert out["translation_unit_sq"].iloc[0] == pytest.approx(
        float(translation_unit_sq(2.0 * np.sqrt(2.0), 4.0))
    )
    # zero tilt along the wind: zero motion error, whatever the roll/pitch columns say
    assert out["sigma_z_rot_ms"].iloc[1] == pytest.approx(0.0, abs=1e-6)


def _band_columns(period_s, var_along_deg2, var_across_deg2):
    """The tilt-band columns of records (arrays of shape (n, 8))."""
    from flidar_uq.data.schema import tilt_band_column_names

    cols = {}
    for b in range(8):
        per, along, across = tilt_band_column_names(b + 1)
        cols |= {per: period_s[:, b], along: var_along_deg2[:, b], across: var_across_deg2[:, b]}
    return cols


def test_fallbacks_bands_then_zero_crossing_period_then_roll_pitch_then_none():
    nan = np.full((4, 8), np.nan)
    per = np.where(np.arange(4)[:, None] == 0, np.geomspace(1.3, 17.0, 8), nan)
    var = np.where(np.arange(4)[:, None] == 0, 0.3, nan)
    rec = pd.DataFrame(
        {
            "hws_mean_ms": [8.0, 8.0, 8.0, 8.0],
            "tilt_along_wind_std_deg": [np.nan, 2.0, np.nan, np.nan],
            "tilt_period_zero_crossing_s": [np.nan, 5.0, np.nan, np.nan],
            "roll_amplitude_deg": [np.nan, np.nan, 2.0, np.nan],
            "pitch_amplitude_deg": [np.nan, np.nan, 8.0, np.nan],
            "roll_period_s": [np.nan, np.nan, 4.0, np.nan],
            "pitch_period_s": [np.nan, np.nan, 9.0, np.nan],
        }
        | _band_columns(per, var, 0.5 * var)
    )
    out = per_record_motion(rec)
    assert tuple(out["motion_description"]) == MOTION_DESCRIPTIONS
    # the bands' along-wind amplitude sqrt(2 sum var_along) and mean period m0 / m1
    assert out["motion_amplitude_deg"].iloc[0] == pytest.approx(np.sqrt(2 * 8 * 0.3))
    assert out["motion_period_s"].iloc[0] == pytest.approx(8 / np.sum(1 / per[0]))
    assert out["motion_period_s"].iloc[1] == pytest.approx(5.0)
    assert out["motion_amplitude_deg"].iloc[2] == pytest.approx(4.0)  # geometric mean
    assert out["motion_period_s"].iloc[2] == pytest.approx(6.0)
    assert np.isnan(out["sigma_z_rot_ms"].iloc[3])


def test_band_description_is_the_six_dof_band_sum():
    """Records with tilt bands: the record model's sigma_Z for any lever arm and hull
    response is the band sum of :func:`six_dof_band_sigma_z_ms` (h = 0 rotation only, 1
    wave follower), whatever the moments columns say; swell bands (wave age > 1.2) enter
    with the side of their travel unknown."""
    from flidar_uq.inference.record_motion import BAND_NODES, gram_sigma_z_ms, motion_gram
    from flidar_uq.physics.motion_spectrum import band_edges_s, expand_bands
    from flidar_uq.physics.seastate import downwind_side_known
    from flidar_uq.physics.six_dof_sigma_z import six_dof_band_sigma_z_ms

    rng = np.random.default_rng(11)
    n = 6
    per = np.geomspace(1.3, 17.0, 8)[None, :] * rng.uniform(0.95, 1.05, (n, 8))
    va, vc = rng.uniform(0, 1.5, (n, 8)), rng.uniform(0, 1.5, (n, 8))
    hws = rng.uniform(4, 18, n)
    rec = pd.DataFrame(
        {
            "hws_mean_ms": hws,
            "tilt_along_wind_std_deg": 9.0,  # ignored: the bands win
            "tilt_period_mean_s": 3.0,
        }
        | _band_columns(per, va, vc)
    )
    share = va / (va + vc)
    cos = np.where(share > 0.5, np.abs(2 * share - 1) ** 0.25, 0.0)
    cos = np.where(downwind_side_known(per, hws[:, None]), cos, 0.0)  # swell: side unknown
    amp = np.sqrt(2 * (va + vc))
    for nodes in (1, BAND_NODES):  # each band as `nodes` harmonics spread over it
        gram = motion_gram(rec, band_nodes=nodes)
        assert (gram["motion_description"] == "tilt_bands").all()
        bands = expand_bands(amp, per, band_edges_s(8), cos, share, n_nodes=nodes)
        for lever, h, hull in (
            (0.0, 0.0, "rotation_only"),
            (2.5, 0.0, "rotation_only"),
            (2.5, 1.0, "wave_follower"),
        ):
            got = gram_sigma_z_ms(gram, lever_arm_m=lever, hull_response=h)
            want = six_dof_band_sigma_z_ms(
                hws, *bands[:2], band_cos_psi=bands[2], band_cos_sq_psi=bands[3],
                lever_arm_m=lever, hull=hull,
            )  # fmt: skip
            np.testing.assert_allclose(got, want, rtol=1e-10)


@pytest.mark.parametrize("lidar", ["zephir300", "windcube_v2"])
def test_band_sums_chunk_by_chunk_equal_the_whole_and_a_table_without_bands_falls_back(
    monkeypatch, lidar
):
    """The band sums run a chunk of records at a time: with chunks of 3 the Gram matrices
    are those of one pass; a table whose bands are all incomplete gets the next
    description (along-wind tilt for a CW lidar, roll and pitch for a DBS lidar) for every
    record: no chunk of bands, no error."""
    from flidar_uq.inference import record_motion
    from flidar_uq.inference.record_motion import motion_gram

    rng = np.random.default_rng(5)
    n = 8
    per = np.geomspace(1.3, 17.0, 8)[None, :] * rng.uniform(0.95, 1.05, (n, 8))
    va, vc = rng.uniform(0, 1.5, (n, 8)), rng.uniform(0, 1.5, (n, 8))
    va[2, 4] = np.nan  # one record's bands incomplete
    rec = pd.DataFrame(
        {"hws_mean_ms": rng.uniform(4, 18, n), "wd_mean_deg": rng.uniform(0, 360, n),
         "heading_mean_deg": rng.uniform(-180, 180, n), "tilt_along_wind_std_deg": 1.5,
         "tilt_period_zero_crossing_s": 4.0, "roll_amplitude_deg": 2.0,
         "pitch_amplitude_deg": 3.0, "roll_period_s": 4.0, "pitch_period_s": 5.0}
        | _band_columns(per, va, vc)
    )  # fmt: skip
    whole = motion_gram(rec, lidar=lidar)
    monkeypatch.setattr(record_motion, "_BAND_CHUNK", 3)
    assert record_motion._row_chunks(0) == []
    assert [c.indices(7) for c in record_motion._row_chunks(7)] == [(0, 3, 1), (3, 6, 1), (6, 7, 1)]
    pd.testing.assert_frame_equal(motion_gram(rec, lidar=lidar), whole)
    described = whole["motion_description"].to_numpy()
    assert described[2] != "tilt_bands" and (np.delete(described, 2) == "tilt_bands").all()
    no_bands = rec.assign(**{c: np.nan for c in rec if c.startswith("tilt_band")})
    gram = motion_gram(no_bands, lidar=lidar)
    assert (gram["motion_description"] == described[2]).all()
    assert np.isfinite(gram[list(record_motion.GRAM_COLUMNS)].to_numpy()).all()
    # ... the description record 2 got within the whole table
    pd.testing.assert_series_equal(gram.iloc[2], whole.iloc[2])


def test_shear_exponent_fitted_to_each_timestamps_heights():
    """A power-law profile at each time stamp's heights gives its exponent; one height, no
    positive mean or a fit out of bounds gives NaN; a given column wins where finite."""
    from flidar_uq.inference.observations import records_shear_exponent, with_shear_exponent

    z = np.array([40.0, 80.0, 120.0])
    alpha = np.array([0.1, 0.25, -0.05, 0.3, 2.0])
    hws = 9.0 * (z[None, :] / 80.0) ** alpha[:, None]
    hws[3, 1] = np.nan  # two heights left: still a fit
    rec = pd.DataFrame(
        {
            "timestamp": np.repeat(pd.date_range("2026-01-01", periods=5, freq="10min"), 3),
            "height_m": np.tile(z, 5),
            "hws_mean_ms": hws.ravel(),
        }
    )
    lone = pd.DataFrame(
        {"timestamp": [pd.Timestamp("2026-02-01")], "height_m": [80.0], "hws_mean_ms": [7.0]}
    )
    got = records_shear_exponent(pd.concat([rec, lone], ignore_index=True))
    # the row without a mean HWS (10) has the fit of its time stamp's others
    want = np.r_[np.repeat([0.1, 0.25, -0.05, 0.3, np.nan], 3), np.nan]
    np.testing.assert_allclose(got, want, atol=1e-12)
    given = rec.assign(shear_exponent=np.r_[np.full(3, 0.5), np.full(12, np.nan)])
    np.testing.assert_allclose(
        records_shear_exponent(given)[:6], np.r_[np.full(3, 0.5), np.full(3, 0.25)]
    )
    assert np.isnan(records_shear_exponent(rec.drop(columns="timestamp"))).all()
    # the subset of one height keeps what the whole table found
    one_height = with_shear_exponent(rec).query("height_m == 80.0")
    np.testing.assert_allclose(
        records_shear_exponent(one_height), [0.1, 0.25, -0.05, 0.3, np.nan], atol=1e-12
    )


def test_dbs_record_model_takes_each_timestamps_shear():
    """A DBS lidar's sigma_Z takes the time stamp's shear (the tilt moves its range gates
    through it): fitted to the heights or given, the same; no shear found, no term; a
    conical scan ignores it."""
    from flidar_uq.inference.record_motion import gram_sigma_z_ms, motion_gram

    rng = np.random.default_rng(7)
    n = 6
    per = np.geomspace(1.3, 17.0, 8)[None, :] * rng.uniform(0.95, 1.05, (n, 8))
    va, vc = rng.uniform(0, 1.5, (n, 8)), rng.uniform(0, 1.5, (n, 8))
    heights = np.tile([40.0, 80.0, 120.0], 2)
    alpha = np.repeat([0.0, 0.3], 3)
    rec = pd.DataFrame(
        {"timestamp": np.repeat(pd.date_range("2026-01-01", periods=2, freq="10min"), 3),
         "height_m": heights, "hws_mean_ms": 10.0 * (heights / 80.0) ** alpha,
         "wd_mean_deg": 250.0, "heading_mean_deg": 20.0}
        | _band_columns(per, va, vc)
    )  # fmt: skip
    fitted = motion_gram(rec, lidar="windcube_v2")
    given = motion_gram(rec.assign(shear_exponent=alpha), lidar="windcube_v2")
    pd.testing.assert_frame_equal(fitted, given, rtol=1e-9)
    none = motion_gram(rec.drop(columns="timestamp"), lidar="windcube_v2")

    def sz(g):
        return gram_sigma_z_ms(g, lever_arm_m=2.0, hull_response=1.0)

    np.testing.assert_allclose(sz(fitted)[:3], sz(none)[:3], rtol=1e-9)
    assert np.all(np.abs(sz(fitted)[3:] / sz(none)[3:] - 1.0) > 1e-3)
    pd.testing.assert_frame_equal(
        motion_gram(rec.assign(shear_exponent=alpha), lidar="zephir300"),
        motion_gram(rec, lidar="zephir300"),
    )


def test_describe_motion_agrees_with_the_terms_the_model_uses():
    from oracles import six_dof_terms

    from flidar_uq.inference.record_motion import FOLLOWER_COLUMNS, describe_motion

    rec = pd.DataFrame(
        {
            "hws_mean_ms": [8.0, 8.0, 8.0, 8.0],
            "tilt_along_wind_std_deg": [2.0, 2.0, np.nan, np.nan],
            "tilt_period_mean_s": [4.0, 4.0, np.nan, np.nan],
            "roll_amplitude_deg": [np.nan, np.nan, 2.0, np.nan],
            "pitch_amplitude_deg": [np.nan, np.nan, 3.0, np.nan],
            "roll_period_s": [np.nan, np.nan, 4.0, np.nan],
            "pitch_period_s": [np.nan, np.nan, 5.0, np.nan],
        }
    )
    for c in FOLLOWER_COLUMNS:  # complete on the first and the roll/pitch record only
        rec[c] = [0.5, np.nan, 0.5, 0.5]
    d = describe_motion(rec)
    assert list(d["motion_description"]) == list(per_record_motion(rec)["motion_description"])
    assert list(d["translation_description"]) == ["tilt_spectrum", "none", "none", "none"]
    kept_rotation = describe_motion(rec, hull_model="rotation_only")
    assert kept_rotation["translation_description"].eq("none").all()
    terms = six_dof_terms(rec, per_record_motion(rec))
    assert list(terms["heave_leak_sq"].to_numpy() > 0) == [True, False, False, False]


def _draw_records(rng, n, truth):
    """Records drawn from the record model itself (known parameters; the wave follower's
    translation columns of one band along and one across the wind)."""
    from flidar_uq.validation.sbc import draw_record_campaign

    return draw_record_campaign(rng, n, truth)


@pytest.mark.parametrize("seed", [3, 4])
def test_record_model_recovers_known_parameters(seed):
    truth = {
        "rho": 0.1,
        "kappa": 0.03,
        "kappa_z": 0.15,
        "lever_arm_m": 2.5,
        "motion_scale": 1.0,
        "hull_response": 0.6,
        "rho_sd": 0.1,
    }
    rec = _draw_records(np.random.default_rng(seed), 1500, truth)
    fit = fit_record_model(rec, seed=seed, settings=SamplerSettings(nsteps=200, nburn=100))
    assert fit.converged, fit.failure_reasons
    for name in RECORD_MODEL_NAMES:
        lo, hi = np.quantile(fit.flat(name), [0.001, 0.999])
        assert lo <= truth[name] <= hi, (name, lo, hi)
    assert "motion_scale_warning" not in fit.info
    assert "lever_arm_warning" not in fit.info


def test_lever_arm_check_flags_an_arm_the_geometry_cannot_have():
    from flidar_uq.inference.record_fit import LEVER_ARM_PLAUSIBLE_MAX_M, lever_arm_check

    near = np.linspace(2.3, 2.7, 401)  # median 2.50 m
    assert lever_arm_check(near) == ""
    assert lever_arm_check(near, (2.4, 0.3)) == ""
    # 1.2 m from the configured arm: beyond max(0.5 m, 3 x 0.3 m)
    msg = lever_arm_check(near, (1.3, 0.3))
    assert "1.20 m from the configured 1.30 m" in msg and "\n" not in msg
    # a wide configured sd widens the tolerance (3 sd = 1.5 m)
    assert lever_arm_check(near, (1.3, 0.5)) == ""
    far = LEVER_ARM_PLAUSIBLE_MAX_M + 1.0 + near - 2.5
    assert "exceeds" in lever_arm_check(far)
    assert lever_arm_check(np.full(10, LEVER_ARM_PLAUSIBLE_MAX_M - 0.1)) == ""


def test_lever_arm_words_say_what_it_means_and_what_to_do():
    from flidar_uq.workflow.report_summary import lever_arm_words

    d = np.linspace(5.5, 6.5, 1001)  # median 6.00 m, 90 % interval 5.55-6.45 m
    txt = lever_arm_words(d, 2.0, 0.91)
    assert "6.00 m above" in txt and "5.55-6.45 m" in txt and "2.00 m of the buoy's geometry" in txt
    assert "91 %" in txt and "What to do" in txt
    assert "any height" in lever_arm_words(d, None, np.nan)


def test_lever_arm_prior_from_geometry_pulls_the_lever_arm(caplog):
    truth = {
        "rho": 0.0,
        "kappa": 0.03,
        "kappa_z": 0.15,
        "lever_arm_m": 2.5,
        "motion_scale": 1.0,
        "hull_response": 0.6,
        "rho_sd": 0.1,
    }
    rec = _draw_records(np.random.default_rng(5), 300, truth)
    with caplog.at_level(logging.INFO, logger="flidar_uq.inference.sampler"):
        fit = fit_record_model(
            rec, seed=5, lever_arm_prior=(2.5, 0.05), settings=SamplerSettings(nsteps=150)
        )
    assert np.std(fit.flat("lever_arm_m")) < 0.06
    # the sampler's phases in the log (progress of the long record fit), steps growing
    phases = [r.getMessage() for r in caplog.records if r.name == "flidar_uq.inference.sampler"]
    assert phases[0].startswith("record model: burn-in, first half,")
    assert phases[1].startswith("record model: burn-in done,")
    # burn-in rounds refitting the independence proposal, at most three (sampler._ADAPT_ROUNDS)
    rounds = sum(p.startswith("record model: burn-in extended (independence") for p in phases)
    assert rounds <= 3 and all(
        p.startswith("record model: burn-in extended") for p in phases[2 : 2 + rounds]
    )
    assert phases[2 + rounds].startswith("record model: main phase,")
    steps = [int(p.split(" steps per walker")[0].rsplit(" ", 1)[1]) for p in phases]
    nburn = SamplerSettings().nburn
    burned = [nburn * (1 + i) for i in range(rounds + 1)]
    assert steps[: 3 + rounds] == [nburn // 2, *burned, burned[-1] + 150]
    assert steps == sorted(steps)
    with pytest.raises(ValueError, match="lever_arm_prior"):
        fit_record_model(rec, seed=5, lever_arm_prior=(2.5, 0.0))


def test_record_log_prob_is_finite_or_minus_inf_never_nan():
    rng = np.random.default_rng(0)
    s, r = rng.uniform(0.1, 2, 50), rng.uniform(0.1, 2, 50)
    szr, u2 = rng.uniform(0, 0.5, 50), rng.uniform(0, 0.01, 50)
    theta = np.array(
        [
            [0.0, np.log(0.05), np.log(0.1), 2.0, 0.0, -0.7, np.log(0.1)],
            [1.5, np.log(0.05), np.log(0.1), 2.0, 0.0, -0.7, np.log(0.1)],  # |rho| > 1
            [0.0, np.nan, np.log(0.1), 2.0, 0.0, -0.7, np.log(0.1)],
            [0.0, np.log(0.05), np.inf, 2.0, 0.0, -0.7, np.log(0.1)],
            [0.0, np.log(0.05), np.log(0.1), -1.0, 0.0, 0.5, np.log(0.1)],  # negative lever arm
            [0.0, np.log(0.05), np.log(0.1), 2.0, 0.0, 0.5, np.log(0.1)],  # h 1.65 > 1.5
            [0.0, np.log(0.05), np.log(0.1), 2.0, 0.0, -0.7, np.log(3.0)],  # rho_sd 3 > 2
            [0.99, -30.0, -30.0, 19.9, 1.6, -1.2, -18.0],
        ]
    )
    lp = log_prob_record_model(theta, s, r, gram_from_cw_terms(szr, u2))
    assert not np.any(np.isnan(lp))
    assert np.isfinite(lp[0]) and np.all(np.isneginf(lp[1:7]))


def test_log_kappa_posterior_is_the_priors_exp_tail_where_the_data_hold_no_kappa():
    """With a reference lidar the pair term explains the floating lidar's scatter and
    kappa goes to 0: below what the data resolve the log-kappa posterior is the half-normal
    prior's ``exp(log kappa)`` tail (slope 1), with no wall at 1e-4 where a year of records
    puts its peak (a wall there made the sampler four times slower, docs/performance.md)."""
    truth = {
        "rho": 0.1,
        "kappa": 0.0,
        "kappa_z": 0.15,
        "lever_arm_m": 2.5,
        "motion_scale": 1.0,
        "hull_response": 0.0,
        "rho_sd": 0.1,
    }
    rec = _draw_records(np.random.default_rng(12), 500, truth)
    mot = per_record_motion(rec)
    args = (
        rec["hws_std_ms"].to_numpy(),
        rec["ref_hws_std_ms"].to_numpy(),
        gram_from_cw_terms(mot["sigma_z_rot_ms"].to_numpy(), mot["translation_unit_sq"].to_numpy()),
    )
    log_kappa = np.log([1e-7, 1e-6, 1e-5])
    theta = np.column_stack(
        [
            np.full(3, 0.1),
            log_kappa,
            np.full(3, np.log(0.15)),
            np.full(3, 2.5),
            np.zeros(3),
            np.zeros(3),
            np.full(3, np.log(0.1)),
        ]
    )
    lp = log_prob_record_model(theta, *args)
    assert np.all(np.isfinite(lp))
    np.testing.assert_allclose(np.diff(lp), np.diff(log_kappa), rtol=1e-3)


def test_record_loglik_reduces_to_eq15_without_motion_noise():
    # kappa_z, rho_sd -> 0, k = 1, L = 0: s ~ N(mu, kappa mu), mu^2 = r^2 + sZ^2 + 2 rho r sZ
    s, r, szr = np.array([1.1]), np.array([1.0]), np.array([0.3])
    theta = np.array([[0.2, np.log(0.05), np.log(1e-9), 0.0, 0.0, 0.0, -40.0]])
    mu = np.sqrt(1.0 + 0.09 + 2 * 0.2 * 0.3)
    tau = 0.05 * mu
    expect = -0.5 * ((1.1 - mu) ** 2 / tau**2 + np.log(2 * np.pi * tau**2))
    got = _record_loglik_pointwise(theta, s, r, gram_from_cw_terms(szr, np.zeros(1)))
    assert got[0, 0] == pytest.approx(expect, rel=1e-6)


@pytest.mark.parametrize("sz_over_r", [0.0, 1.0, 3.0])
def test_reference_pair_scatter_enters_through_the_turbulent_part_only(sz_over_r):
    # the reference lidar's std scatters about the floating lidar's motionless std by
    # exp(p N(0, 1)): s = sqrt((r e)^2 + sZ^2 + 2 rho r e sZ) scatters by p r dmu/dr, far
    # less than p mu where the motion dominates (the former (kappa^2 + p^2) mu^2)
    rho, p, r = 0.3, 0.05, np.array([1.0])
    szr = np.array([sz_over_r])
    theta = np.array([[rho, np.log(1e-7), np.log(1e-7), 0.0, 0.0, 0.0, -40.0]])
    mu = np.sqrt(1.0 + sz_over_r**2 + 2 * rho * sz_over_r)
    ll = _record_loglik_pointwise(
        theta, np.array([mu]), r, gram_from_cw_terms(szr, np.zeros(1)), np.array([p**2])
    )
    tau_model = np.sqrt(np.exp(-2.0 * ll[0, 0]) / (2 * np.pi))
    e = np.exp(p * np.random.default_rng(3).standard_normal(400_000))
    s = np.sqrt(e**2 + sz_over_r**2 + 2 * rho * e * sz_over_r)
    assert tau_model == pytest.approx(np.std(s), rel=0.02)
    if sz_over_r >= 3.0:
        assert tau_model < 0.5 * p * mu


def test_record_loglik_sum_in_blocks_of_records_equals_the_whole_row_sums(monkeypatch):
    """The sampler's sum runs over cache-sized blocks of records, in place: the row sums of
    the pointwise log-likelihood to rounding, with and without the pair term."""
    rng = np.random.default_rng(1)
    n = 2500
    s, r = rng.uniform(0.1, 2, n), rng.uniform(0.1, 2, n)
    szr, u2, pair_sq = rng.uniform(0, 0.5, n), rng.uniform(0, 0.01, n), rng.uniform(0, 1e-3, n)
    theta = np.array(
        [0.0, np.log(0.05), np.log(0.15), 2.0, 0.0, -0.7, np.log(0.1)]
    ) + 0.1 * rng.standard_normal((10, 7))
    monkeypatch.setattr(rf, "_SUM_BLOCK_ELEMENTS", 10 * 700)  # 700, 700, 700, 400 records
    g = gram_from_cw_terms(szr, u2)
    for p in (pair_sq, 0.0):
        whole = _record_loglik_pointwise(theta, s, r, g, p).sum(axis=1)
        got = rf._record_loglik_sum(theta, s, r, g, p)
        np.testing.assert_allclose(got, whole, rtol=1e-13, atol=0)
        assert not np.allclose(got, rf._record_loglik_sum(theta, s, r, g, 0.5 + p))


def test_record_fit_loo_in_blocks_equals_loo_of_the_whole_pointwise_matrix(monkeypatch):
    """The record fit never holds the (draws x records) log-likelihood: its sampler sums in
    blocks of records, its PSIS-LOO runs per block of records. Draws identical whatever the
    block sizes (the sums differ by rounding, ~1e-15, which no accept/reject meets here); LOO equal to the whole matrix's (1e-9 relative: the matrix is rebuilt here
    from the stored natural-scale draws, whose log/exp round trip rounds)."""
    truth = {
        "rho": 0.1,
        "kappa": 0.03,
        "kappa_z": 0.15,
        "lever_arm_m": 2.5,
        "motion_scale": 1.0,
        "hull_response": 0.6,
        "rho_sd": 0.1,
    }
    rec = _draw_records(np.random.default_rng(6), 300, truth)
    pair = np.random.default_rng(7).uniform(0.0, 0.02, len(rec))
    kw = {"seed": 6, "settings": SamplerSettings(nsteps=150, nburn=60), "pair_log_sd": pair}
    a = fit_record_model(rec, **kw)
    monkeypatch.setattr(rf, "_SUM_BLOCK_ELEMENTS", 32 * 40)  # the sampler: 40 records a block
    monkeypatch.setattr(loo_mod, "_LOO_CHUNK_ELEMENTS", 7 * a.flat("rho").size)  # 7 records
    b = fit_record_model(rec, **kw)
    assert a.log_lik is None and b.log_lik is None
    for name in RECORD_MODEL_NAMES:
        np.testing.assert_array_equal(a.draws[name], b.draws[name])
    theta = np.column_stack(
        [
            np.log(a.flat(n)) if k in rf._LOGS else a.flat(n)
            for k, n in enumerate(RECORD_MODEL_NAMES)
        ]
    )
    (s, rr, gram), use, _ = rf._record_observations(rec, None, 1.0)
    assert use.all()
    whole = _loo(_record_loglik_pointwise(theta, s, rr, gram, pair**2))
    for fit in (a, b):
        got = fit.loo()
        assert got["elpd"] == fit.info["loo"]["record_elpd"]
        for k in ("elpd", "se", "p_loo", "elpd_i", "pareto_k"):
            np.testing.assert_allclose(got[k], whole[k], rtol=1e-9, atol=0)


@settings(max_examples=50, deadline=None)
@given(
    st.integers(0, 70),
    st.integers(1, 4),
    st.floats(-8.0, 4.0),
    st.floats(0.0, 8.0),
    st.integers(0, 2**32 - 1),
)
def test_grouped_log_sum_equals_the_sum_of_logs(n_cols, n_rows, log10_lo, span, seed):
    """The sampler's sum takes one logarithm per 8 records' tau^2 (a product of 8): the same
    row sums as one logarithm each, to rounding, for any width (remainders included) and any
    tau^2 in the model's range [1e-8, 1e4] (m/s)^2."""
    rng = np.random.default_rng(seed)
    x = 10.0 ** rng.uniform(log10_lo, min(log10_lo + span, 4.0), (n_rows, n_cols))
    got = rf._sum_log_rows(x)
    want = np.log(x).sum(axis=1)
    np.testing.assert_allclose(got, want, rtol=1e-13, atol=1e-12)


@pytest.mark.parametrize(("hull_response", "kept"), [(1e-3, "rotation_only"), (1.0, "translating")])
def test_hull_model_selection_keeps_the_simplest_description_the_data_support(hull_response, kept):
    from flidar_uq.inference import fit_record_model_selecting_hull

    truth = {
        "rho": 0.0,
        "kappa": 0.03,
        "kappa_z": 0.1,
        "lever_arm_m": 2.0,
        "motion_scale": 1.0,
        "hull_response": hull_response,
        "rho_sd": 0.1,
    }
    rec = _draw_records(np.random.default_rng(21), 600, truth)
    fit = fit_record_model_selecting_hull(
        rec, seed=21, settings=SamplerSettings(nsteps=200, nburn=100)
    )
    cmp = fit.info["hull_model_comparison"]
    assert fit.info["hull_model"] == cmp["kept"] == kept, cmp
    if kept == "translating":  # decisively: it would pass a margin three times as strict
        assert cmp["elpd_difference"] > 3 * max(4.0, 2 * cmp["elpd_difference_se"]), cmp
    else:  # a hull that only rotates: the extra parameter buys nothing
        assert abs(cmp["elpd_difference"]) < 4.0, cmp
    # without the translation columns there is nothing to compare
    from flidar_uq.inference.record_motion import FOLLOWER_COLUMNS

    plain = fit_record_model_selecting_hull(
        rec.drop(columns=list(FOLLOWER_COLUMNS)), seed=21,
        settings=SamplerSettings(nsteps=50, nburn=20),
    )  # fmt: skip
    assert plain.info["hull_model"] == "rotation_only"
    assert "hull_model_comparison" not in plain.info
    # its hull response has no effect: left out of the convergence check
    assert plain.info["hull_response_identified"] is False
    assert "hull_response" not in plain.diagnostics and "rho" in plain.diagnostics
    assert fit.info["hull_response_identified"] is (kept == "translating")
    with pytest.raises(ValueError, match="rotation_only, translating"):
        fit_record_model_selecting_hull(rec, hull_model="follower", seed=1)


@pytest.mark.parametrize("hull", ["wave_follower", "discus_buoy"])
def test_reference_hull_selection_finds_the_hull_the_records_were_drawn_with(hull):
    """hull="auto": records drawn with a wave follower's translation keep the wave follower
    (the simpler reference); records drawn with a discus buoy's, whose response falls and
    lags below its natural periods, keep the discus buoy, decisively; the propagation gets
    the kept reference (info["hull_reference"]), and the report names it."""
    from flidar_uq.inference import fit_record_model_selecting_hull
    from flidar_uq.validation.sbc import draw_record_campaign
    from flidar_uq.workflow.report_summary import hull_model_words

    truth = {"rho": 0.0, "kappa": 0.03, "kappa_z": 0.1, "lever_arm_m": 2.0,
             "motion_scale": 1.0, "hull_response": 1.0, "rho_sd": 0.1}  # fmt: skip
    rec = draw_record_campaign(np.random.default_rng(31), 800, truth, hull=hull)
    settings = SamplerSettings(nsteps=200, nburn=100)
    fit = fit_record_model_selecting_hull(
        rec, hull_model="translating", hull="auto", seed=np.random.SeedSequence(31),
        settings=settings,
    )  # fmt: skip
    # the kept fit is the fit with that hull named, draw for draw: every candidate runs
    # from the same random streams, also from a SeedSequence that a fit spawns from
    named = fit_record_model_selecting_hull(
        rec, hull_model="translating", hull=hull, seed=np.random.SeedSequence(31),
        settings=settings,
    )  # fmt: skip
    np.testing.assert_array_equal(fit.flat("lever_arm_m"), named.flat("lever_arm_m"))
    rc = fit.info["hull_reference_comparison"]
    assert fit.info["hull_reference"] == rc["kept"] == hull, rc
    (row,) = rc["candidates"][1:]
    assert row["hull_reference"] == "discus_buoy" and row["against"] == "wave_follower"
    margin = max(4.0, 2 * row["elpd_difference_se"])
    if hull == "discus_buoy":
        assert row["elpd_difference"] > margin, row
    else:
        assert row["elpd_difference"] < margin, row
    assert f"Reference hull kept by PSIS-LOO: {hull}" in hull_model_words(fit.info)
    lo, hi = np.quantile(fit.flat("lever_arm_m"), [0.001, 0.999])
    assert lo <= truth["lever_arm_m"] <= hi


def test_hull_model_words_state_the_comparison():
    from flidar_uq.workflow.report_summary import hull_model_words

    info = {
        "hull_model": "rotation_only",
        "hull_model_comparison": {"elpd_difference": 1.25, "elpd_difference_se": 2.0},
    }
    txt = hull_model_words(info)
    assert txt.startswith("rotation about a fixed centre") and "+1.2 ± 2.0" in txt
    assert hull_model_words({}) == ""


def _with_measured_translation(rec, ratio):
    """The records' translation 'measured' at ``ratio`` times the wave follower's."""
    out = rec.copy()
    out["heave_velocity_std_ms"] = ratio * rec["follower_heave_velocity_std_ms"]
    # deep-water orbits are circular: the follower's horizontal std equals its heave std
    out["surge_velocity_std_ms"] = ratio * rec["follower_heave_velocity_std_ms"] * 0.8
    out["sway_velocity_std_ms"] = ratio * rec["follower_heave_velocity_std_ms"] * 0.6
    return out


def test_measured_translation_fixes_the_hull_response_of_its_records():
    from flidar_uq.inference.record_motion import (
        describe_motion,
        gram_sigma_z_ms,
        measured_response,
        motion_gram,
    )

    truth = {"rho": 0.0, "kappa": 0.03, "kappa_z": 0.1, "lever_arm_m": 2.0,
             "motion_scale": 1.0, "hull_response": 0.6, "rho_sd": 0.1}  # fmt: skip
    rec = _draw_records(np.random.default_rng(8), 50, truth)
    meas = _with_measured_translation(rec, 0.6)
    r_z, r_x = measured_response(meas)
    np.testing.assert_allclose(r_z, 0.6, rtol=1e-12)
    np.testing.assert_allclose(r_x, 0.6, rtol=1e-12)
    assert np.all(np.isnan(measured_response(rec)[0]))
    t_meas, t_foll = motion_gram(meas), motion_gram(rec)
    assert t_meas["translation_measured"].eq(1.0).all()
    assert t_foll["translation_measured"].eq(0.0).all()
    expect = gram_sigma_z_ms(t_foll, lever_arm_m=2.0, hull_response=0.6)
    for h in (0.0, 0.3, 1.4):  # the fitted response no longer matters where measured
        got = gram_sigma_z_ms(t_meas, lever_arm_m=2.0, hull_response=h)
        np.testing.assert_allclose(got, expect, rtol=1e-12)
    assert describe_motion(meas)["translation_description"].eq("measured").all()
    # a displacement std stands in for a missing velocity std at the heave's mean period
    disp = rec.assign(
        heave_std_m=0.6 * rec["follower_heave_velocity_std_ms"]
        * rec["follower_heave_period_s"] / (2 * np.pi)
    )  # fmt: skip
    np.testing.assert_allclose(measured_response(disp)[0], 0.6, rtol=1e-9)
    np.testing.assert_allclose(measured_response(disp)[1], 0.6, rtol=1e-9)  # taken equal


def test_imu_series_responses_are_a_measured_translation_below_the_mru():
    """The IMU series' heave and horizontal responses (heave_response_ratio,
    horizontal_response_ratio) are R_z and R_x where no MRU or GNSS std is given: the
    record's sigma_Z is that of a measured translation of that size whatever the fitted
    hull response, described as "imu_series"; the heave alone sets both; an MRU std of
    the same motion wins over the series, which still gives the motion the MRU lacks."""
    from flidar_uq.inference.record_motion import (
        describe_motion,
        gram_sigma_z_ms,
        measured_response,
        motion_gram,
    )

    truth = {"rho": 0.0, "kappa": 0.03, "kappa_z": 0.1, "lever_arm_m": 2.0,
             "motion_scale": 1.0, "hull_response": 0.6, "rho_sd": 0.1}  # fmt: skip
    rec = _draw_records(np.random.default_rng(8), 50, truth)
    series = rec.assign(heave_response_ratio=0.5, horizontal_response_ratio=0.2)
    r_z, r_x = measured_response(series)
    np.testing.assert_allclose(r_z, 0.5, rtol=1e-12)
    np.testing.assert_allclose(r_x, 0.2, rtol=1e-12)
    heave_only = series.drop(columns="horizontal_response_ratio")
    np.testing.assert_allclose(measured_response(heave_only)[1], 0.5, rtol=1e-12)
    gram = motion_gram(series)
    assert gram["translation_measured"].eq(1.0).all()
    # the same as an MRU measuring that heave and horizontal velocity
    mru = rec.assign(
        heave_velocity_std_ms=0.5 * rec["follower_heave_velocity_std_ms"],
        surge_velocity_std_ms=0.2 * rec["follower_heave_velocity_std_ms"],
        sway_velocity_std_ms=0.0,
    )
    for h in (0.0, 1.4):
        np.testing.assert_allclose(
            gram_sigma_z_ms(gram, lever_arm_m=2.0, hull_response=h),
            gram_sigma_z_ms(motion_gram(mru), lever_arm_m=2.0, hull_response=1.0),
            rtol=1e-12,
        )
    assert describe_motion(series)["translation_description"].eq("imu_series").all()
    both = mru.assign(heave_response_ratio=0.9, horizontal_response_ratio=0.9)
    np.testing.assert_allclose(measured_response(both)[0], 0.5, rtol=1e-12)
    np.testing.assert_allclose(measured_response(both)[1], 0.2, rtol=1e-12)
    assert describe_motion(both)["translation_description"].eq("measured").all()
    # an MRU that gives the heave only: the series' horizontal response beside it
    heave_mru = mru.drop(columns=["surge_velocity_std_ms", "sway_velocity_std_ms"])
    mixed = heave_mru.assign(heave_response_ratio=0.9, horizontal_response_ratio=0.3)
    np.testing.assert_allclose(measured_response(mixed)[0], 0.5, rtol=1e-12)
    np.testing.assert_allclose(measured_response(mixed)[1], 0.3, rtol=1e-12)


def test_record_model_with_measured_translation_recovers_lever_arm_and_scale():
    truth = {"rho": 0.1, "kappa": 0.03, "kappa_z": 0.15, "lever_arm_m": 2.5,
             "motion_scale": 1.0, "hull_response": 0.6, "rho_sd": 0.1}  # fmt: skip
    rec = _with_measured_translation(_draw_records(np.random.default_rng(9), 1500, truth), 0.6)
    fit = fit_record_model(rec, seed=9, settings=SamplerSettings(nsteps=200, nburn=100))
    assert fit.converged, fit.failure_reasons
    for name in ("rho", "kappa", "kappa_z", "lever_arm_m", "motion_scale"):
        lo, hi = np.quantile(fit.flat(name), [0.001, 0.999])
        assert lo <= truth[name] <= hi, (name, lo, hi)
    # the hull response is not identified by records whose translation is measured: its
    # posterior is its half-normal(1) prior (median 0.67)
    assert 0.3 < np.median(fit.flat("hull_response")) < 1.1


def test_propagation_of_a_rotation_only_hull_model_ignores_the_translation_columns():
    from flidar_uq.correction.propagation import PropagationSettings, draw_corrected_ti
    from flidar_uq.inference.record_motion import FOLLOWER_COLUMNS

    truth = {"rho": 0.0, "kappa": 0.03, "kappa_z": 0.1, "lever_arm_m": 2.0,
             "motion_scale": 1.0, "hull_response": 0.8, "rho_sd": 0.1}  # fmt: skip
    rec = _draw_records(np.random.default_rng(12), 200, truth).assign(bin_id=0)
    fit = fit_record_model(rec, seed=12, settings=SamplerSettings(nsteps=60, nburn=30))
    plain = rec.drop(columns=list(FOLLOWER_COLUMNS))

    def sz(records, hull_model):
        fit.info["hull_model"] = hull_model
        settings = PropagationSettings(ndraws=50)
        return draw_corrected_ti(records, [], fit, settings=settings, seed=3).sigma_z_median_ms

    np.testing.assert_array_equal(sz(rec, "rotation_only"), sz(plain, "translating"))
    assert np.mean(np.abs(sz(rec, "translating") / sz(plain, "translating") - 1)) > 0.05


def test_record_grams_kept_by_the_caller_are_computed_once_and_read_in_later_passes():
    """The uncertainty budget's passes share one dict of Gram matrices: the first pass
    fills it, the later ones read it (a changed entry changes their sigma_Z), a pass of
    another hull model adds its own; without the dict every call computes its own and the
    draws are the same."""
    from flidar_uq.correction.propagation import (
        PropagationSettings,
        draw_corrected_ti,
        draw_held_ti,
    )

    truth = {"rho": 0.0, "kappa": 0.03, "kappa_z": 0.1, "lever_arm_m": 2.0,
             "motion_scale": 1.0, "hull_response": 0.8, "rho_sd": 0.1}  # fmt: skip
    rec = _draw_records(np.random.default_rng(13), 120, truth).assign(bin_id=0)
    fit = fit_record_model(rec, seed=13, settings=SamplerSettings(nsteps=60, nburn=30))
    fit.info["hull_model"] = "translating"
    settings = PropagationSettings(ndraws=40)
    grams: dict = {}

    def held(hold=()):
        return draw_held_ti(rec, [], fit, hold, settings=settings, seed=3, record_grams=grams)

    first = held()
    assert len(grams) == 1 and len(next(iter(grams.values()))) == len(rec)
    alone = draw_corrected_ti(rec, [], fit, settings=settings, seed=3)
    np.testing.assert_array_equal(first.ti, alone.ti)
    assert not np.array_equal(held({"motion"}).ti, alone.ti)  # another pass, same grams
    assert len(grams) == 1
    (key,) = grams
    grams[key] = grams[key] * 4.0  # the variance form x 4: sigma_Z x 2 if read
    np.testing.assert_allclose(held().sigma_z_median_ms, 2.0 * first.sigma_z_median_ms)
    fit.info["hull_model"] = "rotation_only"
    rotation = held()
    assert len(grams) == 2
    np.testing.assert_array_equal(
        rotation.ti, draw_corrected_ti(rec, [], fit, settings=settings, seed=3).ti
    )


def test_swell_band_of_unknown_side_has_no_heave_cross_term():
    """A tilt record cannot tell waves running downwind from waves running upwind: a band
    older than a fully developed wind sea (c / U > 1.2, Pierson & Moskowitz 1964) enters
    with <cos psi> = 0 (no heave-tilt cross term), a wind-sea band with its downwind
    cosine; the same band at a wind strong enough to drive it counts as wind sea."""
    from flidar_uq.inference.record_motion import motion_gram
    from flidar_uq.physics.seastate import WIND_SEA_MAX_WAVE_AGE, downwind_side_known

    assert downwind_side_known(6.0, 9.37 / WIND_SEA_MAX_WAVE_AGE + 0.01)
    assert not downwind_side_known(6.0, 9.37 / WIND_SEA_MAX_WAVE_AGE - 0.01)
    per = np.tile(np.geomspace(1.3, 17.0, 8), (2, 1))
    va = np.zeros((2, 8))
    va[:, 4] = 1.0  # one band, all along the wind, at ~6 s (c ~ 9.4 m/s)
    rec = pd.DataFrame(
        {
            "hws_mean_ms": [4.0, 15.0],
            "tilt_along_wind_std_deg": 1.0,
            "tilt_period_mean_s": 6.0,
            "follower_heave_velocity_std_ms": 0.2,
            "follower_heave_period_s": 6.0,
            "follower_velocity_along_wind_std_ms": 0.2,
            "follower_heave_tilt_correlation": 1.0,
        }
        | _band_columns(per, va, 0.0 * va)
    )
    gram = motion_gram(rec)
    assert gram["gram_k_kh"].iloc[0] == 0.0  # swell at 4 m/s: side unknown
    assert gram["gram_k_kh"].iloc[1] < 0.0  # wind sea at 15 m/s: heave against the tilt
    assert (gram["gram_kh_kh"] > 0).all()


def test_fit_subsample_keeps_each_strata_share_evenly_through_time():
    rng = np.random.default_rng(11)
    n = 9_000
    rec = pd.DataFrame(
        {
            "hws_mean_ms": rng.gamma(4.0, 2.5, n),
            "height_m": rng.choice([40.0, 80.0, 120.0], n, p=[0.5, 0.3, 0.2]),
        }
    )
    keep = rf.fit_subsample(rec, 1_000)
    assert keep.dtype == bool and keep.sum() == 1_000
    np.testing.assert_array_equal(keep, rf.fit_subsample(rec, 1_000))  # deterministic
    assert rf.fit_subsample(rec, n).all()
    strata = pd.MultiIndex.from_arrays([rec["height_m"], np.floor(rec["hws_mean_ms"])])
    full = pd.Series(1, index=strata).groupby(level=[0, 1]).size()
    kept = pd.Series(1, index=strata[keep]).groupby(level=[0, 1]).size()
    kept = kept.reindex(full.index, fill_value=0)
    # largest remainder: every stratum within one record of its proportional share
    assert np.all(np.abs(kept - full * 1_000 / n) < 1.0)
    # evenly spaced through time: the kept half of each large stratum sits in its
    # first half of the campaign as often as in its second
    first_half = np.arange(n) < n / 2
    assert abs(keep[first_half].sum() - keep[~first_half].sum()) <= 0.05 * 1_000


def test_record_model_on_a_subsample_fits_the_stated_number_and_agrees_with_the_whole():
    truth = {
        "rho": 0.1,
        "kappa": 0.03,
        "kappa_z": 0.15,
        "lever_arm_m": 2.5,
        "motion_scale": 1.0,
        "hull_response": 0.6,
        "rho_sd": 0.1,
    }
    rec = _draw_records(np.random.default_rng(5), 2400, truth)
    quick = {"nsteps": 150, "nburn": 100}
    whole = fit_record_model(rec, seed=5, settings=SamplerSettings(**quick))
    sub = fit_record_model(
        rec, seed=5, settings=SamplerSettings(**quick, record_fit_max_records=800)
    )
    assert whole.info["n_records"] == whole.info["n_records_usable"] == 2400
    assert sub.info["n_records"] == 800 and sub.info["n_records_usable"] == 2400
    assert len(sub.info["constant"]["record_index"]) == 800
    for name in ("lever_arm_m", "motion_scale", "hull_response", "rho"):
        a, b = whole.flat(name), sub.flat(name)
        # the subsample's posterior holds the whole fit's median and is wider (fewer data)
        assert np.quantile(b, 0.005) <= np.median(a) <= np.quantile(b, 0.995), name
        assert np.std(b) > np.std(a), name


def test_describe_motion_says_whether_the_wave_directions_were_measured():
    """Tilt bands with the translation from the tilt spectrum: the bands' directions of
    travel are "measured" where the record has them from the heave
    (tilt_band{b}_cos_psi), else "assumed"; "" where they do not enter (moments, or the
    rotation-only hull)."""
    from flidar_uq.inference.record_motion import FOLLOWER_COLUMNS, describe_motion

    n = 3
    cols = {"hws_mean_ms": np.full(n, 8.0)}
    for b in range(1, 9):
        cols[f"tilt_band{b}_period_s"] = np.full(n, 1.3 * 1.45 ** (b - 1))
        cols[f"tilt_band{b}_along_wind_var_deg2"] = np.full(n, 1.0)
        cols[f"tilt_band{b}_across_wind_var_deg2"] = np.full(n, 0.5)
    rec = pd.DataFrame(cols)
    for c in FOLLOWER_COLUMNS:
        rec[c] = 0.5
    assert describe_motion(rec)["motion_description"].eq("tilt_bands").all()
    assert describe_motion(rec)["wave_direction_description"].eq("assumed").all()
    heave = rec.assign(**{f"tilt_band{b}_cos_psi": [0.4, np.nan, 0.1] for b in range(1, 9)})
    d = describe_motion(heave)
    assert list(d["wave_direction_description"]) == ["measured", "assumed", "measured"]
    rotation = describe_motion(heave, hull_model="rotation_only")
    assert rotation["wave_direction_description"].eq("").all()
    moments = describe_motion(rec.drop(columns=[c for c in rec if c.startswith("tilt_band")]))
    assert moments["wave_direction_description"].eq("").all()
