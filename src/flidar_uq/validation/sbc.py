"""Simulation-based calibration (Talts et al. 2018) of the inference on the statistical mode.

One replication draws the parameters from the priors, a campaign from the Bayesian model
itself (:func:`flidar_uq.campaign.statistical_mode.generate_statistical_campaign`), fits
every bin and the global model and returns the rank of each true value among posterior
draws; uniform ranks over many replications <=> calibrated (``tests/test_sbc.py``,
``benchmarks/sbc.py``).
"""

from __future__ import annotations

import numpy as np

from flidar_uq.campaign.statistical_mode import draw_true_params, generate_statistical_campaign
from flidar_uq.inference import Priors, SamplerSettings, fit_bin, fit_global
from flidar_uq.seeding import as_seedsequence

__all__ = ["SBC_PARAMS", "sbc_replication"]

_PRIORS = Priors()

#: Parameters whose ranks one replication returns (global: rho, tau0_ms, kappa; bin 0:
#: amplitude_deg, period_s).
SBC_PARAMS = ("rho", "tau0_ms", "kappa", "amplitude_deg", "period_s")


def sbc_replication(
    seed,
    *,
    surrogate=None,
    settings=None,
    n_bins: int = 3,
    records_per_bin: int = 10,
    n_rank_draws: int = 99,
    priors: Priors = _PRIORS,
) -> dict:
    """One simulation-based-calibration replication (Talts et al. 2018) on the statistical mode.

    Draws the parameters from the priors, a campaign from the model, fits every bin
    (unimodal model) and the global model, and returns the rank of each true value among
    ``n_rank_draws`` posterior draws thinned uniformly from the stored draws.

    Parameters
    ----------
    seed : int or numpy.random.SeedSequence
    surrogate : SigmaZSurrogate, optional
    settings : SamplerSettings, optional
        Default: ``SamplerSettings(mixture="never")``.
    n_bins, records_per_bin : int
    n_rank_draws : int
        Ranks are in ``0 .. n_rank_draws``.
    priors : Priors

    Returns
    -------
    dict
        ``rank_<param>`` for :data:`SBC_PARAMS` (motion parameters of bin 0), ``converged``
        (all fits), and the true values ``true_<param>``.
    """
    if settings is None:
        settings = SamplerSettings(mixture="never")
    if surrogate is None:
        from flidar_uq.physics.surrogate import get_surrogate

        surrogate = get_surrogate()
    ss = as_seedsequence(seed)
    ss_truth, ss_data, ss_fit, ss_glob = ss.spawn(4)
    truth = draw_true_params(n_bins, priors=priors, rng=np.random.default_rng(ss_truth))
    rec, _ = generate_statistical_campaign(
        n_bins, records_per_bin, truth, seed=ss_data, surrogate=surrogate, priors=priors
    )
    fits = [
        fit_bin(g, settings=settings, seed=child, priors=priors)
        for (_, g), child in zip(rec.groupby("bin_id"), ss_fit.spawn(n_bins), strict=True)
    ]
    # SBC must not condition on convergence: every bin's records enter the global fit
    gf = fit_global(
        rec,
        fits,
        surrogate=surrogate,
        settings=settings,
        seed=ss_glob,
        priors=priors,
        use_unconverged_bins=True,
        lever_arm=False,  # the generative model has no lever arm
    )
    out = {
        "converged": all(f.converged for f in fits) and gf.converged,
        "n_records_global": gf.info["n_records"],
    }
    for name in SBC_PARAMS:
        src = gf if name in ("rho", "tau0_ms", "kappa") else fits[0]
        true = truth[name] if src is gf else truth["bins"][0][name]
        x = src.flat(name)
        idx = np.linspace(0, x.size - 1, n_rank_draws).astype(int)
        out[f"rank_{name}"] = int(np.sum(x[idx] < true))
        out[f"true_{name}"] = float(true)
    return out
