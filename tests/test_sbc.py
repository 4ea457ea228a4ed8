"""Simulation-based calibration (Talts et al. 2018) of the cut model on the statistical mode."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import stats

from flidar_uq.inference import SamplerSettings
from flidar_uq.physics.surrogate import get_surrogate
from flidar_uq.validation.sbc import SBC_PARAMS, sbc_replication

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
