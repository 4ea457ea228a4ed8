"""The convergence diagnostics equal arviz-stats' rank R-hat / bulk ESS and emcee's
autocorrelation times (the library functions, called here as the pipeline called them up to
session 9), on chains with the ties of rejected moves, a constant parameter and NaN draws."""

from __future__ import annotations

import emcee
import numpy as np
import pytest
from arviz_stats.base import array_stats
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy import stats

from flidar_uq.inference.diagnostics import _autocorr_times, _diagnostics, _z_scale
from flidar_uq.inference.priors import SamplerSettings


def _library_diagnostics(chains):
    """Rank R-hat, bulk ESS (arviz-stats) and autocorrelation times (emcee), per parameter."""
    nens, nsteps, nwalk, ndim = chains.shape
    pooled = np.transpose(chains, (3, 0, 2, 1)).reshape(ndim, nens, nwalk * nsteps)
    with np.errstate(all="ignore"):
        rhat = array_stats.rhat(pooled, chain_axis=-2, draw_axis=-1, method="rank")
        ess = array_stats.ess(pooled, chain_axis=-2, draw_axis=-1, method="bulk")
        taus = np.array([emcee.autocorr.integrated_time(c, tol=0, quiet=True) for c in chains])
    return rhat, ess, taus


def _mcmc_like_chains(rng, nens, nsteps, nwalk, ndim, phi):
    """AR(1) chains whose rejected steps (half) repeat the previous value, as MCMC's do."""
    e = rng.standard_normal((nens, nsteps, nwalk, ndim))
    x = np.empty_like(e)
    x[:, 0] = e[:, 0]
    reject = rng.random((nens, nsteps, nwalk)) < 0.5
    for t in range(1, nsteps):
        x[:, t] = np.where(reject[:, t, :, None], x[:, t - 1], phi * x[:, t - 1] + e[:, t])
    return x


def _ours(chains):
    diag, _ = _diagnostics(chains, [f"p{k}" for k in range(chains.shape[-1])], SamplerSettings())
    return (
        np.array([d["rhat"] for d in diag.values()]),
        np.array([d["ess_bulk"] for d in diag.values()]),
    )


@settings(max_examples=25, deadline=None)
@given(
    seed=st.integers(0, 2**32 - 1),
    nsteps=st.integers(3, 300),
    nwalk=st.integers(1, 9),
    phi=st.floats(0.0, 0.97),
)
def test_rank_rhat_and_bulk_ess_equal_arviz_stats_bit_for_bit(seed, nsteps, nwalk, phi):
    rng = np.random.default_rng(seed)
    x = _mcmc_like_chains(rng, 4, nsteps, nwalk, 5, phi)
    x[..., 1] = np.round(x[..., 1], 1)  # many ties
    x[..., 2] += 0.5 * np.arange(4)[:, None, None]  # ensembles that disagree: R-hat > 1
    x[..., 3] = 2.5  # a stuck parameter: NaN R-hat, ESS = the draw count
    rhat, ess, _ = _library_diagnostics(x)
    ours_rhat, ours_ess = _ours(x)
    np.testing.assert_array_equal(ours_rhat, rhat)
    np.testing.assert_array_equal(ours_ess, ess)


def test_non_finite_draws_give_arviz_stats_verdict():
    x = _mcmc_like_chains(np.random.default_rng(3), 4, 200, 8, 3, 0.5)
    x[1, 17, 2, 0] = np.nan
    rhat, ess, _ = _library_diagnostics(x)
    ours_rhat, ours_ess = _ours(x)
    assert np.isnan(ours_rhat[0]) and np.isnan(rhat[0])
    np.testing.assert_array_equal(ours_rhat, rhat)
    np.testing.assert_array_equal(ours_ess, ess)


@pytest.mark.parametrize("nsteps", [1, 2, 7, 64, 250, 257, 500])
def test_autocorrelation_times_equal_emcee(nsteps):
    x = _mcmc_like_chains(np.random.default_rng(nsteps), 4, nsteps, 16, 4, 0.9)
    x[2, :, :, 3] = 1.0  # a stuck ensemble: NaN, as emcee gives
    _, _, taus = _library_diagnostics(x)
    ours = _autocorr_times(x)
    np.testing.assert_array_equal(np.isnan(ours), np.isnan(taus))
    np.testing.assert_allclose(ours, taus, rtol=1e-12, atol=0)


def test_z_scale_is_the_blom_normal_score_of_the_average_rank():
    rng = np.random.default_rng(5)
    x = np.round(rng.standard_normal((3, 1001)), 1)
    n = x.shape[1]
    expected = np.array([stats.norm.ppf((stats.rankdata(r) - 3 / 8) / (n + 1 / 4)) for r in x])
    np.testing.assert_array_equal(_z_scale(x), expected)
