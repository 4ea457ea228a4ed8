"""Convergence diagnostics: rank R-hat, bulk/tail ESS, autocorrelation times; thinning.

The rank R-hat and the bulk and tail ESS are arviz-stats' (``array_stats.rhat(method=
"rank")``, ``array_stats.ess(method="bulk" / "tail")``; Vehtari et al. 2021, Bayesian
Analysis 16(2), "Rank-normalization, folding, and localization: an improved R-hat"),
computed across the independent ensembles, each ensemble's walkers pooled into one chain;
the autocorrelation times are emcee's (``emcee.autocorr.integrated_time``, Sokal's window
``c = 5``) per ensemble.
"""

from __future__ import annotations

import emcee
import numpy as np
from arviz_stats.base import array_stats


def _diagnostics(chains, names, settings):
    """Rank R-hat across ensembles (walkers pooled), bulk/tail ESS, autocorrelation times."""
    nens, nsteps, nwalk, ndim = chains.shape
    # each ensemble's walkers pooled into ONE chain, walker-major (walker 0's trace, then 1...)
    pooled = np.transpose(chains, (3, 0, 2, 1)).reshape(ndim, nens, nwalk * nsteps)
    with np.errstate(all="ignore"):  # a stuck (constant) or non-finite chain gives NaN: a failure
        rhat = array_stats.rhat(pooled, chain_axis=-2, draw_axis=-1, method="rank")
        ess_b = array_stats.ess(pooled, chain_axis=-2, draw_axis=-1, method="bulk")
        # tail ESS: the smaller ESS of the 5 % and 95 % quantiles (Vehtari et al. 2021)
        ess_t = array_stats.ess(
            pooled, chain_axis=-2, draw_axis=-1, method="tail", prob=(0.05, 0.95)
        )
        # per ensemble, shape (nens, ndim): the walkers' autocorrelation functions averaged
        taus = np.array([emcee.autocorr.integrated_time(c, tol=0, quiet=True) for c in chains])
    diag, reasons = {}, []
    for k, n in enumerate(names):
        tau = float(np.max(taus[:, k])) if np.all(np.isfinite(taus[:, k])) else float("nan")
        d = {
            "rhat": float(rhat[k]),
            "ess_bulk": float(ess_b[k]),
            "ess_tail": float(ess_t[k]),
            "tau": tau,
            "nsteps_over_tau": nsteps / tau if tau > 0 else float("inf"),
        }
        diag[n] = d
        if not np.isfinite(d["rhat"]) or d["rhat"] >= settings.rhat_max:
            reasons.append(f"{n}: rank R-hat {d['rhat']:.4f} >= {settings.rhat_max}")
        if not np.isfinite(d["ess_bulk"]) or d["ess_bulk"] < settings.ess_min:
            reasons.append(f"{n}: bulk ESS {d['ess_bulk']:.0f} < {settings.ess_min:.0f}")
        if not np.isfinite(d["ess_tail"]) or d["ess_tail"] < settings.ess_min:
            reasons.append(f"{n}: tail ESS {d['ess_tail']:.0f} < {settings.ess_min:.0f}")
        if not d["nsteps_over_tau"] > settings.n_autocorr:
            reasons.append(
                f"{n}: chain {nsteps} steps = {d['nsteps_over_tau']:.1f} autocorrelation "
                f"times <= {settings.n_autocorr:.0f}"
            )
    return diag, reasons


def _thin(chains, ndraws):
    """(nens, nsteps, nwalk, ndim) -> (nens, ndraws, ndim), uniform over the pooled walkers."""
    nens, nsteps, nwalk, ndim = chains.shape
    pooled = np.transpose(chains, (0, 2, 1, 3)).reshape(nens, nwalk * nsteps, ndim)
    idx = np.linspace(0, nwalk * nsteps - 1, min(ndraws, nwalk * nsteps)).astype(int)
    return pooled[:, idx, :]
