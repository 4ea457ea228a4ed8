"""The bin motion model (Gutiérrez-Antuñano et al. 2018) for a pulsed DBS lidar: its own
beam-pair terms (Yamaguchi & Ishihara 2016, Eqs. 3-4) with the cross term between the tilt
leak and the head translation, in the bin draws, the global fit and the propagation."""

from __future__ import annotations

import functools

import numpy as np
import pandas as pd
import pytest
from oracles import dbs_sigma_z_from_terms

from flidar_uq.correction.propagation import PropagationSettings, draw_corrected_ti
from flidar_uq.inference import (
    BinFit,
    Priors,
    SamplerSettings,
    effective_sigma_z_ms,
    fit_global,
    log_prob_global,
    record_sigma_z_moments,
    records_wind_body_deg,
    translation_unit_sq,
)
from flidar_uq.physics.dbs_sigma_z import (
    dbs_record_terms,
    dbs_tilt_lever_terms,
    wind_to_body_deg,
)
from flidar_uq.physics.lidar import get_lidar
from flidar_uq.physics.surrogate import get_surrogate
from flidar_uq.validation.regimes import scenario_records

LIDAR = "windcube_v2"
SHAPE = (4, 25)


@pytest.fixture(scope="module")
def surrogate():
    return get_surrogate(LIDAR)


def _unimodal(amp, per, bin_id=0):
    """A bin fit whose draws are the given amplitudes (deg) and periods (s), (4, 25) each."""
    return BinFit(
        draws={
            "amplitude_deg": np.reshape(amp, SHAPE),
            "period_s": np.reshape(per, SHAPE),
            "scatter_amplitude": np.full(SHAPE, 0.1),
            "scatter_period": np.full(SHAPE, 0.1),
        },
        log_lik=np.zeros(SHAPE + (1,)),
        diagnostics={},
        failure_reasons=[],
        info={"bin_id": bin_id, "model": "unimodal", "n_records": 1, "n_imu": 1,
              "prior_only": False, "loo": {}},
    )  # fmt: skip


def _draws(seed):
    rng = np.random.default_rng(np.random.SeedSequence(seed))
    return rng.uniform(1.0, 6.0, SHAPE), rng.uniform(2.5, 9.0, SHAPE)


def _record_sigma_z(hws, amp, per, lever, beta, scale=1.0):
    """The record model's DBS sigma_Z of equal roll and pitch harmonics (dbs_record_terms),
    the hull response 0 as in the bin model, draws x records."""
    hws, amp, per, beta = np.broadcast_arrays(hws[None, :], amp[:, None], per[:, None], beta)
    gram = dbs_record_terms(
        hws.ravel(), amp.ravel(), amp.ravel(), per.ravel(), wind_body_deg=beta.ravel()
    ) if np.all(np.isfinite(beta)) else dbs_record_terms(
        hws.ravel(), amp.ravel(), amp.ravel(), per.ravel()
    )  # fmt: skip
    sz = dbs_sigma_z_from_terms(gram, lever_arm_m=lever, hull_response=0.0, motion_scale=scale)
    return sz.reshape(hws.shape)


def test_dbs_tilt_lever_terms_are_dbs_record_terms_with_equal_roll_and_pitch():
    """The bin model's fast form is dbs_record_terms at roll = pitch amplitude and period:
    sigma_Z within 1e-4 at any lever arm (its table's accuracy, 3e-5 measured next to the
    zeros at 1 and 2 beam dwells), at known wind directions and averaged over headings
    (NaN), for two lidars, periods over the whole 1-20 s range; the cross term averages
    to 0 over headings and is not small at a known direction."""
    rng = np.random.default_rng(np.random.SeedSequence(3))
    n = 400
    hws, amp = rng.uniform(3.0, 20.0, n), rng.uniform(0.3, 9.0, n)
    per, beta = np.exp(rng.uniform(0.0, np.log(20.0), n)), rng.uniform(0.0, 360.0, n)
    for lidar in (LIDAR, "windcube_v2_1"):
        for b in (beta, None):
            want = dbs_record_terms(hws, amp, amp, per, wind_body_deg=b, lidar=lidar)
            kk, kl, ll = dbs_tilt_lever_terms(hws, amp, per, wind_body_deg=b, lidar=lidar)
            for lever in (0.0, 2.0, 5.0):
                np.testing.assert_allclose(
                    np.sqrt(kk + 2.0 * lever * kl + lever**2 * ll),
                    dbs_sigma_z_from_terms(want, lever_arm_m=lever, hull_response=0.0),
                    rtol=1e-4,
                )
        assert np.max(np.abs(kl) / np.sqrt(kk * ll)) < 1e-9  # heading-averaged: no cross term
    kk, kl, ll = dbs_tilt_lever_terms(hws, amp, per, wind_body_deg=beta)
    assert np.max(np.abs(kl) / np.sqrt(kk * ll)) > 0.5
    # draws x records in one call; NaN outside the domain (negative speed, period < 1 s)
    kk = dbs_tilt_lever_terms(
        hws[None, :5], amp[:3, None], per[:3, None], wind_body_deg=beta[None, :5]
    )[0]
    assert kk.shape == (3, 5)
    bad = dbs_tilt_lever_terms(
        np.array([8.0, -1.0, 8.0]), np.array([2.0, 2.0, 2.0]), np.array([4.0, 4.0, 0.5])
    )
    assert np.isfinite(bad[0][0]) and np.all(np.isnan([b[1:] for b in bad]))


def test_bin_model_sigma_z_of_a_dbs_lidar_is_its_beam_pair_form_not_the_vad_form(surrogate):
    """BinFit.sigma_z_draws with a DBS lidar's surrogate equals the record model's DBS
    quadratic form (dbs_record_terms, hull response 0) at each draw's amplitude and period,
    the lever arm and the record's wind direction relative to the beams (averaged where it
    is NaN), and not the VAD form (surrogate's rotational sigma_Z plus the uniform head
    velocity over a scan, translation_unit_sq, no cross term) the bin model used before."""
    amp, per = _draws(5)
    fit = _unimodal(amp, per)
    hws = np.array([5.0, 8.0, 12.0, 16.0])
    beta = np.array([30.0, 75.0, 200.0, np.nan])
    lever = 2.0
    got = fit.sigma_z_draws(hws, surrogate, lever_arm_m=lever, wind_body_deg=beta)
    a, t = amp.ravel(), per.ravel()
    want = _record_sigma_z(hws[:3], a, t, lever, beta[None, :3])
    np.testing.assert_allclose(got[:, :3], want, rtol=1e-6)
    np.testing.assert_allclose(
        got[:, 3], _record_sigma_z(hws[3:], a, t, lever, np.full((1, 1), np.nan))[:, 0], rtol=1e-6
    )
    vad = effective_sigma_z_ms(
        surrogate.sigma_z_ms(hws[None, :], a[:, None], t[:, None]),
        translation_unit_sq(a[:, None], t[:, None], get_lidar(LIDAR).scan_period_s),
        lever,
    )
    # the two forms differ by far more than the equality's tolerance above (median 5 % for
    # the WindCube v2's wind after every beam)
    assert np.median(np.abs(got / vad - 1.0)) > 1e-3
    # without a lever arm: the DBS tilt leak alone
    rot = fit.sigma_z_draws(hws[:3], surrogate, wind_body_deg=beta[:3])
    np.testing.assert_allclose(rot, _record_sigma_z(hws[:3], a, t, 0.0, beta[None, :3]), rtol=1e-6)


def test_two_period_bin_adds_its_components_gram_matrices(surrogate):
    """A two-period draw (A, T1, T2, w) is two independent components, A sqrt(w) at T1 and
    A sqrt(1 - w) at T2: their Gram matrices add (the variances of independent components
    add), cross terms included."""
    rng = np.random.default_rng(np.random.SeedSequence(9))
    amp = rng.uniform(1.0, 5.0, SHAPE)
    t1, t2 = rng.uniform(2.5, 4.5, SHAPE), rng.uniform(7.0, 12.0, SHAPE)
    w = rng.uniform(0.2, 0.8, SHAPE)
    fit = _unimodal(amp, t1)
    fit.draws = {
        "amplitude_deg": amp, "period1_s": t1, "period2_s": t2, "weight1": w,
        "scatter_amplitude": np.full(SHAPE, 0.1), "scatter_period": np.full(SHAPE, 0.1),
        "weight_concentration": np.full(SHAPE, 10.0),
    }  # fmt: skip
    fit.info["model"] = "two_period"
    hws, beta, lever = np.array([6.0, 11.0]), np.array([40.0, 130.0]), 2.5
    got = fit.sigma_z_draws(hws, surrogate, lever_arm_m=lever, wind_body_deg=beta)
    a, ww = amp.ravel()[:, None], w.ravel()[:, None]
    parts = [
        dbs_tilt_lever_terms(hws[None, :], a * np.sqrt(sh), t.ravel()[:, None], wind_body_deg=beta[None, :])
        for sh, t in ((ww, t1), (1.0 - ww, t2))
    ]  # fmt: skip
    kk, kl, ll = (p1 + p2 for p1, p2 in zip(*parts, strict=True))
    np.testing.assert_allclose(got, np.sqrt(kk + 2.0 * lever * kl + lever**2 * ll), rtol=1e-6)
    # each component alone is the record model's form at its own amplitude and period
    one = _record_sigma_z(hws, (a * np.sqrt(ww)).ravel(), t1.ravel(), lever, beta[None, :])
    np.testing.assert_allclose(
        np.sqrt(parts[0][0] + 2 * lever * parts[0][1] + lever**2 * parts[0][2]), one, rtol=1e-6
    )
    assert np.all(got > one)


def _dbs_records(n, seed):
    rng = np.random.default_rng(np.random.SeedSequence(seed))
    amp = rng.uniform(2.0, 3.0, n)
    per = rng.uniform(3.0, 3.5, n)
    return pd.DataFrame(
        {
            "bin_id": 0,
            "hws_mean_ms": rng.uniform(4.0, 14.0, n),
            "hws_std_ms": np.nan,
            "roll_amplitude_deg": amp,
            "pitch_amplitude_deg": amp,
            "roll_period_s": per,
            "pitch_period_s": per,
            "wd_mean_deg": rng.uniform(0.0, 360.0, n),
            "heading_mean_deg": np.where(np.arange(n) % 4 == 3, np.nan, 30.0),
        }
    )


def test_propagation_bin_path_uses_the_dbs_terms_at_each_records_heading(surrogate, constant_fit):
    """draw_corrected_ti on the bin model with a DBS lidar: each record's sigma_Z median is
    the DBS quadratic form at the global lever arm and motion scale, with the record's own
    wind direction relative to the beams (wd_mean_deg, heading_mean_deg), the heading
    averaged where it is NaN."""
    rec = _dbs_records(8, 4).assign(hws_std_ms=1.2)
    fit = _unimodal(np.full(SHAPE, 3.0), np.full(SHAPE, 3.2))
    lever, k = 2.0, 1.1
    gf = constant_fit(
        shape=SHAPE, rho=0.0, tau0_ms=1e-6, kappa=1e-6, lever_arm_m=lever, motion_scale=k
    )
    d = draw_corrected_ti(
        rec, [fit], gf, settings=PropagationSettings(ndraws=50, lidar=LIDAR), seed=1
    )
    beta = wind_to_body_deg(rec["wd_mean_deg"], rec["heading_mean_deg"])
    np.testing.assert_array_equal(records_wind_body_deg(rec), beta)
    hws = rec["hws_mean_ms"].to_numpy()
    known = np.isfinite(beta)
    want = np.empty(len(rec))
    want[known] = _record_sigma_z(
        hws[known], np.array([3.0]), np.array([3.2]), lever, beta[None, known], k
    )[0]
    want[~known] = _record_sigma_z(hws[~known], np.array([3.0]), np.array([3.2]), lever, np.full((1, 1), np.nan), k)[0]  # fmt: skip
    np.testing.assert_allclose(d.sigma_z_median_ms, want, rtol=1e-6)


def test_global_likelihood_of_a_dbs_lidar_has_the_cross_term():
    """log_prob_global with a DBS lidar's correlation c: Eq. 15 of Gutiérrez-Antuñano et al.
    (2018) at sZ^2 = (k sZ_rot)^2 + 2 c k sZ_rot L u + L^2 u^2, its variance through the
    rotational part; c = 0 is the CW form."""
    from scipy import stats

    s, r = np.array([0.5, 1.0, 0.7]), np.array([0.4, 0.9, 0.75])
    szm, szv = np.array([0.2, 0.3, 0.1]), np.array([1e-3, 0.0, 4e-4])
    u2, corr = np.array([0.01, 0.02, 0.004]), np.array([-0.6, 0.3, 0.9])
    rho, tau0, kappa, lev, k = 0.3, 0.05, 0.08, 2.0, 1.2
    pr = Priors()

    def loglik(sz, var_sz):
        mu = np.sqrt(r**2 + sz**2 + 2 * rho * r * sz)
        tau = np.sqrt((kappa * mu) ** 2 + tau0**2 + ((sz + rho * r) / mu) ** 2 * var_sz)
        return stats.norm.logpdf(s, mu, tau).sum()

    th = [rho, np.log(tau0), np.log(kappa), lev, np.log(k)]
    prior = log_prob_global([th], s, r, szm, szv, u2=u2)[0] - loglik(
        np.sqrt((k * szm) ** 2 + lev**2 * u2), k**2 * szv * (k * szm) ** 2 / ((k * szm) ** 2 + lev**2 * u2)
    )  # fmt: skip
    sz = np.sqrt((k * szm) ** 2 + 2 * corr * k * szm * lev * np.sqrt(u2) + lev**2 * u2)
    var = (k * (k * szm + corr * lev * np.sqrt(u2)) / sz) ** 2 * szv
    got = log_prob_global([th], s, r, szm, szv, pr, u2, corr)[0]
    assert got == pytest.approx(loglik(sz, var) + prior, abs=1e-10)
    assert log_prob_global([th], s, r, szm, szv, pr, u2, np.zeros(3))[0] == pytest.approx(
        log_prob_global([th], s, r, szm, szv, pr, u2)[0], abs=1e-12
    )


def test_global_fit_of_a_dbs_lidar_recovers_the_lever_arm_of_its_beam_pair_form(surrogate):
    """Records whose std follows Eq. 15 with the DBS form at a 2-m lever arm (a known
    heading, the wind from every direction): the lever-arm model's moments carry the cross
    term (record_sigma_z_moments' correlation, of either sign by the wind's direction
    against the beams) and its posterior holds the lever arm."""
    n = 400
    rec = _dbs_records(n, 11)
    rec["heading_mean_deg"] = 30.0
    fit = _unimodal(np.full(SHAPE, 2.5), np.full(SHAPE, 3.2))
    rng = np.random.default_rng(np.random.SeedSequence(12))
    hws = rec["hws_mean_ms"].to_numpy()
    beta = records_wind_body_deg(rec)
    sz = _record_sigma_z(hws, np.array([2.5]), np.array([3.2]), 2.0, beta[None, :])[0]
    r = 0.1 * hws * np.exp(0.15 * rng.standard_normal(n))
    rec["ref_hws_std_ms"] = r
    rec["hws_std_ms"] = np.sqrt(r**2 + sz**2) * (1.0 + 0.02 * rng.standard_normal(n))
    szm, szv, u2m, corr = record_sigma_z_moments(rec, [fit], surrogate=surrogate, seed=1)
    # of either sign and not small: +-0.31 for the WindCube v2's wind after every beam (once
    # a cycle +-1: the tilt's leak through opposite beams turns sign with their order in the
    # window, which changes from window to window, the head's translation does not)
    assert corr.min() < -0.2 and corr.max() > 0.2
    np.testing.assert_allclose(effective_sigma_z_ms(szm, u2m, 2.0, correlation=corr), sz, rtol=1e-6)
    settings = SamplerSettings(nwalkers=16, nsteps=200, nburn=100, ndraws=100, ess_min=100.0,
                               n_autocorr=10.0)  # fmt: skip
    gf = fit_global(rec, [fit], surrogate=surrogate, settings=settings, seed=3, lever_arm=True)
    assert gf.converged, gf.failure_reasons
    lo, hi = np.quantile(gf.flat("lever_arm_m"), [0.005, 0.995])
    assert lo < 2.0 < hi, (lo, hi)


def test_scenario_bins_are_the_configs_default_bins():
    """validation.regimes' bin model bins the records as the pipeline's default config does."""
    import yaml

    from flidar_uq.validation.regimes import DEFAULT_BINNING
    from flidar_uq.workflow.inputs import SCHEMA_PATH

    schema = yaml.safe_load(SCHEMA_PATH.read_text(encoding="utf-8"))
    binning = schema["properties"]["binning"]["properties"]
    assert DEFAULT_BINNING == {k: v["default"] for k, v in binning.items()}


def test_scenario_bin_model_fits_the_calibration_records_as_given(monkeypatch):
    """bin_model_fit's global fit reads the calibration table it is given (its reference
    std in the floating lidar's response), not the records' raw reference std."""
    from types import SimpleNamespace

    from flidar_uq.validation import regimes

    rec = _dbs_records(300, 5).assign(
        hws_mean_ms=np.linspace(8.1, 8.9, 300),
        hws_std_ms=0.9,
        ref_hws_std_ms=np.linspace(0.5, 1.5, 300),
        wd_mean_deg=0.0,
    )
    calibration = rec.iloc[::2].assign(ref_hws_std_ms=rec["ref_hws_std_ms"].iloc[::2] / 1.05)
    seen = {}
    monkeypatch.setattr(
        regimes, "fit_bin", lambda group, **kw: SimpleNamespace(converged=True, bin_id=kw["bin_id"])
    )

    def fake_global(calib, fits, **kw):
        seen["calib"] = calib
        return "fit"

    monkeypatch.setattr(regimes, "fit_global", fake_global)
    settings = SamplerSettings(nwalkers=8, nsteps=10, nburn=5, ndraws=10)
    bin_id, fits, fit = regimes.bin_model_fit(
        calibration, rec, get_surrogate("windcube_v2"), settings, np.random.SeedSequence(3)
    )
    assert fit == "fit" and fits
    calib = seen["calib"]
    assert len(calib) > 0 and calib.index.isin(calibration.index).all()
    np.testing.assert_allclose(
        calib["ref_hws_std_ms"], calibration.loc[calib.index, "ref_hws_std_ms"]
    )
    np.testing.assert_array_equal(calib["bin_id"], bin_id[calib.index])


def test_scenario_records_refuses_an_unknown_motion_model():
    with pytest.raises(ValueError, match="motion_model='bins' is not 'record' or 'bin'"):
        scenario_records("tiny", 1, motion_model="bins")


#: Two seeds drawn fresh (secrets.randbelow(10**6)) for this test, not chosen after the result.
SCENARIO_SEEDS = (527423, 854725)


@functools.cache
def _scenario(seed):
    return scenario_records("dbs_tilt_only", seed, lidar=LIDAR, motion_model="bin")


@pytest.mark.slow
@pytest.mark.parametrize("seed", SCENARIO_SEEDS)
def test_bin_model_finds_the_lever_arm_of_a_dbs_buoy_and_corrects_its_ti(seed):
    """The bin model on ``dbs_tilt_only`` (a WindCube v2 2 m above the centre of a buoy that
    only tilts, fixed heading; 7 days x 3 heights; the records of the bins with >= 30
    records, about 45 %, are corrected) with the DBS lidar's own terms: the mean relative
    error of the corrected TI against the point truth is within +-1.5 %, and where PSIS-LOO
    keeps a lever arm (by more than 2 se) it is within half of the true 2 m.

    With one wind a cycle the tilt's leak and the head's translation are fully correlated
    at a known heading and LOO keeps the lever arm on both seeds (L 1.84 m [1.58, 2.10] and
    2.79 m [2.45, 3.12], elpd over rho only +63 +- 16 and +86 +- 15; mean error +0.4 % and
    +0.3 %, uncorrected +13 %, +17 %). After every beam (the WindCube v2's output) the
    order of opposite beams turns from window to window, the cross term averages down
    (correlation at most 0.31) and the lever arm's own share of sigma_Z^2 is 1-13 %
    (``benchmarks/dbs_sigma_z.py --study mechanisms``): on seed 527423 LOO keeps rho only (elpd of the
    lever arm +1.0), on 854725 the lever arm.
    The bin model's harmonic roll and pitch at the bin's peak period carry the
    description's error into ``L`` (the record model's roll-and-pitch description is
    0.75 m off, docs/dbs-lidars.md): hence half the lever arm, not its 90 % interval. The
    VAD form the bin model used before on the same seeds: L 7.95 m [5.4, 10.0] and the
    lever arm not kept (elpd +1.8 +- 1.3); mean error +0.2 % for both: the aggregate is
    corrected either way, what changes is that the lever arm is the buoy's."""
    records, fit = _scenario(seed)
    assert fit.converged, fit.failure_reasons
    loo = fit.info["loo"]
    if loo["model"] in ("lever_arm", "lever_arm_scale"):
        assert loo["lever_arm_elpd_diff"] > 2.0 * loo["lever_arm_elpd_diff_se"], loo
        lever = float(np.median(fit.flat("lever_arm_m")))
        assert abs(lever - 2.0) <= 1.0, lever
    answered = records[records["ti_corrected_median"].notna() & (records["ti_true"] > 0)]
    err = float(np.mean(answered["ti_corrected_median"] / answered["ti_true"] - 1.0))
    assert abs(err) <= 0.015, err
