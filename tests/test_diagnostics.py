"""The convergence diagnostics: arviz-stats' rank R-hat and bulk/tail ESS across the
ensembles (each ensemble's walkers pooled into one chain), emcee's autocorrelation times
per ensemble, and the verdicts drawn from them."""

from __future__ import annotations

import numpy as np
from arviz_stats.base import array_stats

from flidar_uq.inference.diagnostics import _diagnostics
from flidar_uq.inference.priors import SamplerSettings


def _mcmc_like_chains(rng, nens, nsteps, nwalk, ndim, phi):
    """AR(1) chains whose rejected steps (half) repeat the previous value, as MCMC's do."""
    e = rng.standard_normal((nens, nsteps, nwalk, ndim))
    x = np.empty_like(e)
    x[:, 0] = e[:, 0]
    reject = rng.random((nens, nsteps, nwalk)) < 0.5
    for t in range(1, nsteps):
        x[:, t] = np.where(reject[:, t, :, None], x[:, t - 1], phi * x[:, t - 1] + e[:, t])
    return x


def _run(chains):
    return _diagnostics(chains, [f"p{k}" for k in range(chains.shape[-1])], SamplerSettings())


def test_rhat_and_ess_are_over_ensembles_with_walkers_pooled_walker_major():
    x = _mcmc_like_chains(np.random.default_rng(1), 4, 120, 6, 2, 0.5)
    x[..., 1] += 0.3 * np.arange(6)[None, None, :]  # walkers that differ within an ensemble
    diag, _ = _run(x)
    for k in range(2):
        # one chain per ensemble: walker 0's whole trace, then walker 1's, ...
        chains = np.stack([np.concatenate([x[e, :, w, k] for w in range(6)]) for e in range(4)])
        assert diag[f"p{k}"]["rhat"] == array_stats.rhat(chains, method="rank")
        assert diag[f"p{k}"]["ess_bulk"] == array_stats.ess(chains, method="bulk")
        tail = array_stats.ess(chains, method="tail", prob=(0.05, 0.95))
        assert diag[f"p{k}"]["ess_tail"] == tail
    # the walkers as chains would be another R-hat (here far above 1)
    walkers = x[..., 1].transpose(0, 2, 1).reshape(24, 120)
    assert array_stats.rhat(walkers, method="rank") > 1.1 > diag["p1"]["rhat"]


def test_disagreeing_ensembles_fail_the_rank_rhat():
    x = _mcmc_like_chains(np.random.default_rng(2), 4, 250, 16, 2, 0.3)
    x[2, ..., 0] += 0.5  # one ensemble elsewhere
    diag, reasons = _run(x)
    assert diag["p0"]["rhat"] > 1.01 > diag["p1"]["rhat"]
    assert [r for r in reasons if "R-hat" in r] == [
        f"p0: rank R-hat {diag['p0']['rhat']:.4f} >= 1.01"
    ]


def test_autocorrelation_time_of_an_ar1_chain():
    # AR(1) with coefficient phi: integrated autocorrelation time (1 + phi) / (1 - phi) = 9
    phi = 0.8
    e = np.random.default_rng(3).standard_normal((4, 4000, 16, 1))
    x = np.empty_like(e)
    x[:, 0] = e[:, 0] / np.sqrt(1 - phi**2)
    for t in range(1, 4000):
        x[:, t] = phi * x[:, t - 1] + e[:, t]
    diag, reasons = _run(x)
    assert abs(diag["p0"]["tau"] - 9.0) < 0.9  # the largest of the 4 ensembles' estimates
    assert diag["p0"]["nsteps_over_tau"] == 4000 / diag["p0"]["tau"]
    assert reasons == []


def test_short_chain_misses_the_autocorrelation_criterion():
    x = _mcmc_like_chains(np.random.default_rng(4), 4, 250, 16, 1, 0.97)
    diag, reasons = _run(x)
    assert diag["p0"]["nsteps_over_tau"] <= 50
    assert any(r.startswith("p0: chain 250 steps = ") for r in reasons)


def test_stuck_and_non_finite_parameters_fail():
    x = _mcmc_like_chains(np.random.default_rng(5), 4, 200, 8, 3, 0.5)
    x[..., 1] = 2.5  # a stuck parameter
    x[1, 17, 2, 2] = np.nan  # one non-finite draw
    diag, reasons = _run(x)
    assert np.isfinite(diag["p0"]["rhat"]) and np.isfinite(diag["p0"]["tau"])
    assert np.isnan(diag["p1"]["rhat"]) and np.isnan(diag["p1"]["tau"])
    assert np.isnan(diag["p2"]["rhat"])
    for n in ("p1", "p2"):
        assert any(r.startswith(f"{n}: rank R-hat nan") for r in reasons)
