"""One per-record Gram matrix of the motion error for every lidar (record_motion.motion_gram)."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
from oracles import dbs_sigma_z_from_terms, six_dof_terms

from flidar_uq.inference.record_fit import _record_loglik_pointwise, _record_observations
from flidar_uq.inference.record_motion import (
    DBS_COLUMNS,
    FOLLOWER_COLUMNS,
    GRAM_COLUMNS,
    describe_motion,
    gram_from_cw_terms,
    gram_hws_error_ms,
    gram_sigma_z_ms,
    motion_gram,
    per_record_motion,
)
from flidar_uq.physics.dbs_sigma_z import (
    dbs_record_terms,
    hws_error_moments,
    wind_to_body_deg,
)


def _records(n, seed=0, *, follower=True, measured=False):
    """Random records with the along-wind, roll/pitch, heading and follower columns."""
    rng = np.random.default_rng(seed)
    rec = pd.DataFrame(
        {
            "hws_mean_ms": rng.uniform(4.0, 16.0, n),
            "hws_std_ms": rng.uniform(0.4, 1.6, n),
            "ref_hws_std_ms": rng.uniform(0.4, 1.5, n),
            "wd_mean_deg": rng.uniform(0.0, 360.0, n),
            "heading_mean_deg": rng.uniform(-180.0, 180.0, n),
            "roll_amplitude_deg": rng.uniform(0.5, 6.0, n),
            "pitch_amplitude_deg": rng.uniform(0.5, 6.0, n),
            "roll_period_s": rng.uniform(3.0, 10.0, n),
            "pitch_period_s": rng.uniform(3.0, 10.0, n),
            "tilt_along_wind_std_deg": rng.uniform(0.3, 4.0, n),
            "tilt_across_wind_std_deg": rng.uniform(0.1, 3.0, n),
            "tilt_period_mean_s": rng.uniform(3.0, 10.0, n),
        }
    )
    if follower:
        rec["follower_heave_velocity_std_ms"] = rng.uniform(0.1, 0.8, n)
        rec["follower_heave_period_s"] = rng.uniform(3.0, 10.0, n)
        rec["follower_velocity_along_wind_std_ms"] = rng.uniform(0.1, 0.8, n)
        rec["follower_heave_tilt_correlation"] = rng.uniform(0.2, 1.0, n)
    if measured:  # half the records with a measured heave and surge
        v = rec["follower_heave_velocity_std_ms"].to_numpy() * rng.uniform(0.3, 1.2, n)
        rec["heave_velocity_std_ms"] = np.where(np.arange(n) % 2 == 0, v, np.nan)
        rec["surge_velocity_std_ms"] = np.where(np.arange(n) % 2 == 0, 0.8 * v, np.nan)
    return rec


def _former_sigma_z(mot, terms, lever, h, k):
    """The ZephIR-style sigma_Z as the record model wrote it before the Gram matrix."""
    sz, u2 = mot["sigma_z_rot_ms"].to_numpy(), mot["translation_unit_sq"].to_numpy()
    x, hh, y, o, meas = (terms[c].to_numpy() for c in terms.columns)
    h = h + meas * (1.0 - h)
    leak = sz**2 - 2.0 * h * x + h**2 * hh
    trans = lever**2 * u2 - 2.0 * lever * h * y + h**2 * o
    return np.sqrt(np.maximum(k**2 * leak + trans, 0.0))


def _draws(n=7, seed=1):
    rng = np.random.default_rng(seed)
    return (
        rng.uniform(0.0, 4.0, (n, 1)),  # lever arm, m
        rng.uniform(0.0, 1.2, (n, 1)),  # hull response
        rng.uniform(0.8, 1.25, (n, 1)),  # motion scale
    )


def test_zephir_gram_gives_the_former_sigma_z_and_likelihood():
    rec = _records(400, measured=True)
    mot = per_record_motion(rec)
    terms = six_dof_terms(rec, mot)
    assert terms["translation_measured"].sum() > 50  # the measured branch is exercised
    gram = motion_gram(rec, lidar="zephir300")
    lever, h, k = _draws()
    want = _former_sigma_z(mot, terms, lever, h, k)
    got = gram_sigma_z_ms(gram, lever_arm_m=lever, hull_response=h, motion_scale=k)
    np.testing.assert_allclose(got, want, rtol=1e-12, atol=1e-15)
    assert np.ptp(want) > 0.1  # records and draws differ: the comparison is not trivial
    # the likelihood's sigma_Z (one walker): equal to a rotation-only record of that sigma_Z
    (s, r, g), use, _ = _record_observations(rec, None, None, "zephir300")
    assert use.all()
    theta = np.array(
        [[0.2, np.log(0.04), np.log(0.12), lever[0, 0], np.log(k[0, 0]), np.log(h[0, 0]), -2.3]]
    )
    same = gram_from_cw_terms(want[0] / k[0, 0], np.zeros(len(rec)))
    np.testing.assert_allclose(
        _record_loglik_pointwise(theta, s, r, g),
        _record_loglik_pointwise(theta, s, r, same),
        rtol=1e-12,
    )
    # a zephir300 given by name is the default lidar
    pd.testing.assert_frame_equal(gram, motion_gram(rec))


def test_dbs_gram_is_dbs_record_terms_with_the_records_heading():
    rec = _records(60)
    gram = motion_gram(rec, lidar="windcube_v2")
    beta = wind_to_body_deg(rec["wd_mean_deg"], rec["heading_mean_deg"])
    g4 = dbs_record_terms(
        rec["hws_mean_ms"],
        rec["roll_amplitude_deg"],
        rec["pitch_amplitude_deg"],
        rec["pitch_period_s"],
        wind_body_deg=beta,
        roll_period_s=rec["roll_period_s"],
        lidar="windcube_v2",
    )
    lever, h, k = _draws()
    want = dbs_sigma_z_from_terms(g4, lever_arm_m=lever, hull_response=h, motion_scale=k)
    along = gram[[*GRAM_COLUMNS, "translation_measured"]]  # the along-wind error alone
    got = gram_sigma_z_ms(along, lever_arm_m=lever, hull_response=h, motion_scale=k)
    np.testing.assert_allclose(got, want, rtol=1e-12)
    assert (gram["motion_description"] == "roll_pitch").all()
    # with the cross-wind error: sigma_Z and the mean to fourth order in it
    g3 = dbs_record_terms(
        rec["hws_mean_ms"], rec["roll_amplitude_deg"], rec["pitch_amplitude_deg"],
        rec["pitch_period_s"], wind_body_deg=beta, roll_period_s=rec["roll_period_s"],
        lidar="windcube_v2", cross_wind=True,
    )  # fmt: skip
    np.testing.assert_array_equal(g3[:, 0], g4)
    forms = [
        dbs_sigma_z_from_terms(g3[:, p], lever_arm_m=lever, hull_response=h, motion_scale=k) ** 2
        for p in (0, 1)
    ]
    v = np.stack(np.broadcast_arrays(k, k * h, lever, h))[..., 0]  # (4, n_draws)
    cov = np.einsum("id,nij,jd->dn", v, g3[:, 2], v)
    var, mean = hws_error_moments(*forms, cov, rec["hws_mean_ms"].to_numpy())
    full = gram_sigma_z_ms(gram, lever_arm_m=lever, hull_response=h, motion_scale=k)
    np.testing.assert_allclose(full, np.sqrt(var), rtol=1e-10)
    both = gram_hws_error_ms(gram, lever_arm_m=lever, hull_response=h, motion_scale=k)
    np.testing.assert_array_equal(both[0], full)  # one evaluation gives both
    mean_z = both[1]
    np.testing.assert_allclose(mean_z, mean, rtol=1e-10)
    assert np.all(mean_z > 0) and np.any(np.abs(full / got - 1) > 1e-3)
    np.testing.assert_array_equal(
        gram_hws_error_ms(motion_gram(rec), lever_arm_m=2.0, hull_response=0.5)[1], 0.0
    )  # a CW lidar: none
    # heading unknown: the average over headings
    blind = motion_gram(rec.drop(columns="heading_mean_deg"), lidar="windcube_v2")
    g_avg = dbs_record_terms(
        rec["hws_mean_ms"],
        rec["roll_amplitude_deg"],
        rec["pitch_amplitude_deg"],
        rec["pitch_period_s"],
        roll_period_s=rec["roll_period_s"],
        lidar="windcube_v2",
        n_headings=24,
    )
    want_avg = dbs_sigma_z_from_terms(g_avg, lever_arm_m=lever, hull_response=h, motion_scale=k)
    got_avg = gram_sigma_z_ms(
        blind[along.columns], lever_arm_m=lever, hull_response=h, motion_scale=k
    )
    np.testing.assert_allclose(got_avg, want_avg, rtol=1e-12)
    assert not np.allclose(got_avg, got, rtol=1e-3)


def test_a_negative_cross_wind_form_is_zero_in_the_likelihood_and_the_propagation():
    # band direction moments that no spread of directions has (a narrow band oblique to the
    # wind with <sin psi cos psi> = 0) can make the cross-wind form s_b^2 negative: the
    # likelihood and the propagation both take it as 0, so they keep the same sigma_Z
    rec = _records(80)
    (s, r, g), use, _ = _record_observations(rec, None, None, "windcube_v2")
    assert use.all() and g.shape[0] == 43  # with the sampling rows
    flipped, zeroed = g.copy(), g.copy()
    flipped[11:21] *= -1.0  # the cross-wind Gram negated: s_b^2 <= 0
    zeroed[11:21] = 0.0
    lever, h, k = _draws()
    theta = np.array(
        [[0.2, np.log(0.04), np.log(0.12), lever[0, 0], np.log(k[0, 0]), np.log(h[0, 0]), -2.3]]
    )
    np.testing.assert_array_equal(
        _record_loglik_pointwise(theta, s, r, flipped),
        _record_loglik_pointwise(theta, s, r, zeroed),
    )
    assert np.all(
        _record_loglik_pointwise(theta, s, r, flipped) != _record_loglik_pointwise(theta, s, r, g)
    )
    names = [*GRAM_COLUMNS, "translation_measured", *DBS_COLUMNS]
    sz = {}
    for key, rows in (("flipped", flipped), ("zeroed", zeroed)):
        gram = dict(zip(names, rows, strict=True))
        sz[key], mean_z = gram_hws_error_ms(
            gram, lever_arm_m=lever, hull_response=h, motion_scale=k
        )
        np.testing.assert_array_equal(mean_z, 0.0)
    np.testing.assert_array_equal(sz["flipped"], sz["zeroed"])


def test_dbs_gram_without_follower_columns_is_rotation_only():
    rec = _records(20, follower=False)
    gram = motion_gram(rec, lidar="windcube_v2")
    lever, h, k = _draws()
    s0 = gram_sigma_z_ms(gram, lever_arm_m=lever, hull_response=0.0, motion_scale=k)
    np.testing.assert_array_equal(
        gram_sigma_z_ms(gram, lever_arm_m=lever, hull_response=h, motion_scale=k), s0
    )
    assert (describe_motion(rec, lidar="windcube_v2")["translation_description"] == "none").all()
    full = motion_gram(_records(20), lidar="windcube_v2")
    assert (full["gram_kh_kh"] > 0).all()


def test_heading_turned_by_90_deg_changes_a_dbs_lidars_sigma_z_not_a_cw_lidars():
    """A CW conical scan is azimuth symmetric; a DBS lidar's opposite-beam pairs are taken
    at different times, so the leak goes as 1 + sin(2 beta) cos(omega tau)
    (physics/dbs_sigma_z.py): turning the wind by 90 deg relative to the beams flips it."""
    rec = _records(40).assign(wd_mean_deg=270.0 - 45.0, heading_mean_deg=0.0)  # beta = 45 deg
    turned = rec.assign(heading_mean_deg=90.0)  # beta = -45 deg
    for lidar, changes in (("windcube_v2", True), ("zephir300", False)):
        a = gram_sigma_z_ms(motion_gram(rec, lidar=lidar), lever_arm_m=2.0, hull_response=0.5)
        b = gram_sigma_z_ms(motion_gram(turned, lidar=lidar), lever_arm_m=2.0, hull_response=0.5)
        if changes:
            assert np.median(np.abs(a / b - 1.0)) > 0.02
        else:
            np.testing.assert_array_equal(a, b)


def _record_fit(make, lever=2.0, hull=0.3):
    return make(
        record=True,
        shape=(2, 50),
        rho=0.1,
        kappa=1e-6,
        kappa_z=1e-6,
        lever_arm_m=lever,
        motion_scale=1.0,
        hull_response=hull,
    )


def test_propagation_uses_the_configured_lidars_sigma_z(constant_fit):
    from flidar_uq.correction.propagation import PropagationSettings, draw_corrected_ti

    rec = _records(30).assign(bin_id=0)
    fit = _record_fit(constant_fit)
    out = {}
    for lidar in ("zephir300", "windcube_v2"):
        draws = draw_corrected_ti(
            rec, [], fit, settings=PropagationSettings(ndraws=50, lidar=lidar), seed=3
        )
        want = gram_sigma_z_ms(motion_gram(rec, lidar=lidar), lever_arm_m=2.0, hull_response=0.3)
        np.testing.assert_allclose(draws.sigma_z_median_ms, want, rtol=1e-4)
        out[lidar] = draws.ti_quantiles[1]
        # the TI's denominator: the mean HWS less the motion's mean error (a DBS lidar's
        # cross-wind error; none for a CW lidar)
        mean_z = gram_hws_error_ms(
            motion_gram(rec, lidar=lidar), lever_arm_m=2.0, hull_response=0.3
        )[1]
        np.testing.assert_allclose(
            draws.ti_quantiles[1] * (rec["hws_mean_ms"] - mean_z), draws.sigma_quantiles[1],
            rtol=1e-9,
        )  # fmt: skip
        assert (mean_z > 0).all() if lidar == "windcube_v2" else (mean_z == 0).all()
    ok = np.isfinite(out["zephir300"]) & np.isfinite(out["windcube_v2"])
    assert ok.sum() > 20
    assert np.median(np.abs(out["windcube_v2"][ok] / out["zephir300"][ok] - 1.0)) > 0.01


@pytest.mark.parametrize("lidar", ["zephir300", "windcube_v2"])
def test_record_observations_hold_the_gram_of_the_configured_lidar(lidar):
    rec = _records(25)
    (s, r, g), use, kinds = _record_observations(rec, None, None, lidar)
    gram = motion_gram(rec, lidar=lidar)
    np.testing.assert_array_equal(g[:10], gram[list(GRAM_COLUMNS)].to_numpy().T[:, use])
    # a DBS lidar's: + the cross-wind error and its output's two sampling terms
    rows = 11 if lidar == "zephir300" else 11 + len(DBS_COLUMNS)
    assert g.shape == (rows, use.sum()) and set(FOLLOWER_COLUMNS) <= set(rec)


def test_reference_hull_scales_the_translation_by_its_response_and_the_propagation_follows(
    constant_fit,
):
    """inference.hull_reference: with moments the heave and orbital terms take the hull's
    relative responses at the heave's mean period (a discus buoy's differ from 1 below its
    natural periods, a wave follower's are 1); measured records keep the measured size
    with the reference hull's phase; the rotational terms do not change; the propagation
    uses the fit's reference hull."""
    from flidar_uq.correction.propagation import PropagationSettings, draw_corrected_ti
    from flidar_uq.physics.hull import get_hull

    rec = _records(40, measured=True).assign(bin_id=0)
    fol = motion_gram(rec)
    dis = motion_gram(rec, hull="discus_buoy")
    meas = fol["translation_measured"].to_numpy() > 0
    assert meas.any() and (~meas).any()
    rx, rz = get_hull("discus_buoy").relative_responses(
        np.clip(rec["follower_heave_period_s"].to_numpy(), 1.0, 20.0)
    )
    free = ~meas
    np.testing.assert_allclose(
        dis["gram_kh_kh"][free], fol["gram_kh_kh"][free] * np.abs(rz[free]) ** 2
    )
    np.testing.assert_allclose(dis["gram_k_kh"][free], fol["gram_k_kh"][free] * rz.real[free])
    np.testing.assert_allclose(dis["gram_hh"][free], fol["gram_hh"][free] * np.abs(rx[free]) ** 2)
    np.testing.assert_allclose(dis["gram_l_h"][free], fol["gram_l_h"][free] * rx.real[free])
    for col in ("gram_kk", "gram_ll"):
        np.testing.assert_array_equal(dis[col], fol[col])
    # measured heave: the heave's size is the measurement's, its cross term takes the
    # reference hull's phase; the horizontal motion (no sway measured) is taken at the
    # heave's ratio to the reference hull's
    for col in ("gram_kk", "gram_ll", "gram_kh_kh"):
        np.testing.assert_allclose(dis[col][meas], fol[col][meas], rtol=1e-12)
    np.testing.assert_allclose(
        dis["gram_k_kh"][meas], fol["gram_k_kh"][meas] * (rz.real / np.abs(rz))[meas]
    )
    np.testing.assert_allclose(
        dis["gram_hh"][meas], fol["gram_hh"][meas] * (np.abs(rx) / np.abs(rz))[meas] ** 2
    )
    np.testing.assert_allclose(
        dis["gram_l_h"][meas], fol["gram_l_h"][meas] * (rx.real / np.abs(rz))[meas]
    )
    assert not np.allclose(dis["gram_k_kh"][meas], fol["gram_k_kh"][meas])
    assert not np.allclose(dis["gram_hh"][free], fol["gram_hh"][free])
    fit = _record_fit(constant_fit, hull=1.0)
    fit.info["hull_reference"] = "discus_buoy"
    draws = draw_corrected_ti(rec, [], fit, settings=PropagationSettings(ndraws=50), seed=3)
    want = gram_sigma_z_ms(dis, lever_arm_m=2.0, hull_response=1.0)
    np.testing.assert_allclose(draws.sigma_z_median_ms, want, rtol=1e-4)


def test_reference_hull_with_tilt_bands_is_that_hulls_band_sum():
    """With tilt bands each band takes the reference hull's response at its own period: h = 1
    gives the band sum of that hull (six_dof_band_sigma_z_ms), here a spar's and a discus
    buoy's, different from the wave follower's."""
    from flidar_uq.data.schema import tilt_band_column_names
    from flidar_uq.inference.record_motion import BAND_NODES
    from flidar_uq.physics.motion_spectrum import band_edges_s, expand_bands
    from flidar_uq.physics.seastate import downwind_side_known
    from flidar_uq.physics.six_dof_sigma_z import six_dof_band_sigma_z_ms

    rng = np.random.default_rng(5)
    n = 12
    per = np.geomspace(1.3, 17.0, 8)[None, :] * rng.uniform(0.95, 1.05, (n, 8))
    va, vc = rng.uniform(0, 1.5, (n, 8)), rng.uniform(0, 1.5, (n, 8))
    hws = rng.uniform(4, 18, n)
    rec = pd.DataFrame({"hws_mean_ms": hws})
    for b in range(8):
        p, a, c = tilt_band_column_names(b + 1)
        rec[p], rec[a], rec[c] = per[:, b], va[:, b], vc[:, b]
    share = va / (va + vc)
    cos = np.where(share > 0.5, np.abs(2 * share - 1) ** 0.25, 0.0)
    cos = np.where(downwind_side_known(per, hws[:, None]), cos, 0.0)
    amp = np.sqrt(2 * (va + vc))
    bands = expand_bands(amp, per, band_edges_s(8), cos, share, n_nodes=BAND_NODES)
    got = {}
    for hull in ("wave_follower", "discus_buoy", "spar"):
        got[hull] = gram_sigma_z_ms(motion_gram(rec, hull=hull), lever_arm_m=1.5, hull_response=1.0)
        want = six_dof_band_sigma_z_ms(
            hws, *bands[:2], band_cos_psi=bands[2], band_cos_sq_psi=bands[3],
            lever_arm_m=1.5, hull=hull,
        )  # fmt: skip
        np.testing.assert_allclose(got[hull], want, rtol=1e-10)
    assert not np.allclose(got["discus_buoy"], got["wave_follower"])
    assert not np.allclose(got["spar"], got["wave_follower"])
    # a translation measured at the reference hull's own size gives that hull's band sum
    # at h = 1, whatever the fitted response; at twice its size the translation terms x 2
    from flidar_uq.inference.record_motion import reference_translation_ratio

    rec = rec.assign(
        follower_heave_velocity_std_ms=rng.uniform(0.2, 0.8, n), follower_heave_period_s=5.0,
        follower_velocity_along_wind_std_ms=0.3, follower_heave_tilt_correlation=0.5,
    )  # fmt: skip
    for hull in ("discus_buoy", "spar"):
        q_z, q_x = reference_translation_ratio(rec, hull)
        assert np.all((q_z > 0) & (q_x > 0)) and not np.allclose(q_z, q_x)
        sig = rec["follower_heave_velocity_std_ms"].to_numpy()
        for size in (1.0, 2.0):
            meas = rec.assign(
                heave_velocity_std_ms=size * q_z * sig, surge_velocity_std_ms=size * q_x * sig
            )
            gram = motion_gram(meas, hull=hull)
            assert gram["translation_measured"].eq(1.0).all()
            free = motion_gram(rec, hull=hull)
            for h in (0.2, 1.0):
                np.testing.assert_allclose(
                    gram_sigma_z_ms(gram, lever_arm_m=1.5, hull_response=h),
                    gram_sigma_z_ms(free, lever_arm_m=1.5, hull_response=size),
                    rtol=1e-9,
                )


def test_hull_response_at_its_lower_end_is_negligible_not_when_it_moves_sigma_z():
    """The record fit waits for the hull response's chains only when its posterior moves a
    record's sigma_Z by more than 1 %: draws near 0 on a translating record table do not,
    draws near 1 do, and records without translation never do."""
    from flidar_uq.inference.record_fit import _hull_response_negligible

    rec = _records(30)
    (_, _, g), _, _ = _record_observations(rec, None, None)
    rng = np.random.default_rng(2)

    def nat(h):
        return {
            "hull_response": h * np.exp(0.1 * rng.standard_normal(400)),
            "lever_arm_m": np.full(400, 2.0),
            "motion_scale": np.ones(400),
        }

    assert _hull_response_negligible(nat(1e-4), g)
    assert not _hull_response_negligible(nat(1.0), g)
    (_, _, g0), _, _ = _record_observations(rec.drop(columns=list(FOLLOWER_COLUMNS)), None, None)
    assert _hull_response_negligible(nat(1.0), g0)


def test_rotation_only_observations_have_no_translation_even_with_tilt_bands():
    """The rotation-only hull model leaves the translation out whatever the columns hold:
    dropping the follower columns is not enough once the tilt bands carry the translation."""
    from flidar_uq.data.schema import tilt_band_column_names
    from flidar_uq.inference.record_motion import _HULL_ENTRIES

    rec = _records(20).drop(columns=list(FOLLOWER_COLUMNS))
    rng = np.random.default_rng(9)
    for b in range(8):
        p, a, c = tilt_band_column_names(b + 1)
        rec[p] = 1.3 * 1.42**b
        rec[a], rec[c] = rng.uniform(0, 1, 20), rng.uniform(0, 1, 20)
    (_, _, g), _, kinds = _record_observations(rec, None, None)
    assert set(kinds) == {"tilt_bands"}
    assert np.any(g[list(_HULL_ENTRIES)] != 0)  # the bands give the translation
    (_, _, g0), _, _ = _record_observations(rec, None, None, translation=False)
    np.testing.assert_array_equal(g0[list(_HULL_ENTRIES)], 0.0)
    np.testing.assert_array_equal(g0[0], g[0])
