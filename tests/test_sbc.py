"""Simulation-based calibration (Talts et al. 2018) of the cut model on the statistical mode."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
from scipy import stats

from flidar_uq.inference import SamplerSettings
from flidar_uq.physics.surrogate import get_surrogate
from flidar_uq.validation.sbc import (
    SBC_PARAMS,
    SBC_RECORD_PARAMS,
    draw_record_prior,
    rank_uniformity,
    sbc_record_replication,
    sbc_replication,
)

N_REP = 100
N_RANK_DRAWS = 99  # ranks 0..99 -> 10 histogram bins of 10 ranks
SMALL = SamplerSettings(
    nwalkers=16,
    nsteps=200,
    nburn=100,
    ndraws=100,
    mixture="never",
    global_step_factor=2.0,
    max_step_factor=1.0,  # fixed length: SBC does not need (or condition on) convergence
    global_max_step_factor=1.0,
)


@pytest.mark.slow
def test_sbc_rank_histograms_uniform_for_rho_and_motion_parameters():
    sur = get_surrogate("zephir300")
    root = np.random.SeedSequence(20181122)
    rows = [
        sbc_replication(
            child,
            surrogate=sur,
            settings=SMALL,
            n_bins=2,
            records_per_bin=10,
            n_rank_draws=N_RANK_DRAWS,
        )
        for child in root.spawn(N_REP)
    ]
    # chi-square per parameter at 1 %, Bonferroni-corrected over the parameters tested
    alpha = 0.01 / len(SBC_PARAMS)
    pvalues = {}
    for name in SBC_PARAMS:
        ranks = np.array([r[f"rank_{name}"] for r in rows])
        assert ranks.min() >= 0 and ranks.max() <= N_RANK_DRAWS
        counts = np.bincount(ranks * 10 // (N_RANK_DRAWS + 1), minlength=10)
        pvalues[name] = stats.chisquare(counts).pvalue
    assert all(p > alpha for p in pvalues.values()), pvalues


# --- the record motion model -----------------------------------------------------------

N_REP_RECORD = 100
N_RECORDS = 400
N_PROPAGATED = 5  # records per replication whose corrected TI is ranked too


def test_record_sbc_replication_shape_ranges_and_determinism():
    tiny = SamplerSettings(nwalkers=10, nsteps=20, nburn=10, ndraws=20, global_max_step_factor=1.0)
    seeds = np.random.SeedSequence(11).spawn(2)
    rows = [sbc_record_replication(s, n_records=30, settings=tiny, n_rank_draws=19) for s in seeds]
    for row in rows:
        for name in SBC_RECORD_PARAMS:
            assert 0 <= row[f"rank_{name}"] <= 19
            assert np.isfinite(row[f"true_{name}"])
        assert 0 < row["n_records"] <= 30  # the fit drops records drawn with s <= 0
    again = sbc_record_replication(
        np.random.SeedSequence(11).spawn(2)[0], n_records=30, settings=tiny, n_rank_draws=19
    )
    assert pd.Series(again).equals(pd.Series(rows[0]))  # NaN tau of tiny chains: equal


def test_record_prior_draws_lie_in_the_record_model_prior_support():
    from flidar_uq.inference import Priors
    from flidar_uq.inference.record_fit import _log_prior

    rng = np.random.default_rng(0)
    draws = [draw_record_prior(rng) for _ in range(500)]
    theta = np.array(
        [
            [
                d["rho"],
                np.log(d["kappa"]),
                np.log(d["kappa_z"]),
                d["lever_arm_m"],
                np.log(d["motion_scale"]),
                np.log(d["hull_response"]),
                np.log(d["rho_sd"]),
            ]
            for d in draws
        ]
    )
    _, ok = _log_prior(theta, Priors(), None)
    assert ok.all()
    # half-normal(0.3) on kappa_z: median 0.3 * 0.674
    assert np.median(theta[:, 2]) == pytest.approx(np.log(0.3 * 0.674), abs=0.15)
    # log-normal on rho_sd: median and log-sd of the prior
    assert np.median(theta[:, 6]) == pytest.approx(np.log(Priors().rho_sd_median), abs=0.1)
    assert np.std(theta[:, 6]) == pytest.approx(Priors().rho_sd_log_sd, rel=0.1)


def test_rank_uniformity_rejects_bins_that_do_not_divide_the_ranks():
    with pytest.raises(ValueError, match="not a multiple of n_hist_bins"):
        rank_uniformity([0, 1], n_rank_draws=98, n_hist_bins=10)


@pytest.mark.slow
def test_record_model_sbc_ranks_uniform_at_1pct_for_all_seven_parameters():
    """>= 100 replications, chi-square p > 0.01 per parameter (uncorrected), and the
    propagation: the true TI's ranks among the corrected-TI draws uniform at 1 %, the 90 %
    intervals' coverage as the number of draws gives it."""
    sur = get_surrogate("zephir300")
    root = np.random.SeedSequence(20260101)
    rows = [
        sbc_record_replication(
            child,
            n_records=N_RECORDS,
            n_rank_draws=N_RANK_DRAWS,
            surrogate=sur,
            n_propagated=N_PROPAGATED,
        )  # fmt: skip
        for child in root.spawn(N_REP_RECORD)
    ]
    pvalues = {
        name: rank_uniformity([r[f"rank_{name}"] for r in rows], N_RANK_DRAWS, 10)[0]
        for name in SBC_RECORD_PARAMS
    }
    # the propagation: ranks of the true TI of N_PROPAGATED records per replication
    pvalues["corrected_ti"] = rank_uniformity(
        np.concatenate([r["propagation_ranks"] for r in rows]), N_RANK_DRAWS, 10
    )[0]
    assert all(p > 0.01 for p in pvalues.values()), pvalues
    # the 90 % interval of N_RANK_DRAWS draws (linear interpolation between order
    # statistics) holds a calibrated truth with probability (n - 1) 0.9 / (n + 1)
    expected = (N_RANK_DRAWS - 1) * 0.9 / (N_RANK_DRAWS + 1)
    coverage = np.mean([r["propagation_coverage_90"] for r in rows])
    assert abs(coverage - expected) < 0.01, (coverage, expected)
    # rank draws nearly independent: one walker's rank draws many autocorrelation times apart
    assert min(r["rank_spacing_over_tau"] for r in rows) > 2.0
