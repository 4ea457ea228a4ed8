"""Laplace approximation of the record motion model's global posterior: a fast stand-in for emcee.

:func:`~flidar_uq.inference.sampler.laplace_approximation` gives the posterior mode and
the Hessian of the negative log posterior in the sampler's coordinates (``rho``,
``log kappa``, ``log kappa_z``, ``lever_arm_m``, ``log motion_scale``);
:func:`laplace_record_model` turns ``N(mode, inv(Hessian))`` into a
:class:`~flidar_uq.inference.results.GlobalFit` of independent normal draws that
:func:`flidar_uq.correction.propagation.corrected_ti` propagates like the emcee fit.

Where it breaks (docs/inference.md, "Method frontier"): the normal approximation has
unbounded support; where the posterior sits against a bound of the support (``|rho|``
near 1, the lever arm near 0 m when the data hold none) the mode is on or near the edge,
the Hessian there describes only one side (or, with the mode on the edge, differences
across it: an sd near 0) and a share of the normal draws falls outside the support. Such
draws are redrawn (the approximation is truncated to the support) and their share is
reported in ``info["laplace"]["outside_support_frac"]``; a mode on the edge, a share
above ``_OUTSIDE_SUPPORT_WARN`` or a Hessian that is not positive definite is a failure
reason (the fit is then not ``converged``: use emcee).
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from flidar_uq.inference.priors import Priors
from flidar_uq.inference.record_fit import (
    RECORD_MODEL_NAMES,
    _record_observations,
    _start,
    log_prob_record_model,
    natural_draws,
)
from flidar_uq.inference.results import GlobalFit
from flidar_uq.inference.sampler import _HESSIAN_STEP, laplace_approximation
from flidar_uq.seeding import as_seedsequence

__all__ = ["laplace_record_model", "normal_draws"]

#: Share of normal draws outside the support above which the approximation is flagged.
_OUTSIDE_SUPPORT_WARN = 0.01


def normal_draws(log_prob, args, mode, hessian, ndraws: int, rng) -> tuple[np.ndarray, float]:
    """``ndraws`` draws of ``N(mode, inv(hessian))`` truncated to ``log_prob``'s support.

    Parameters
    ----------
    log_prob : callable
        Vectorised log posterior, ``log_prob(theta (n, ndim), *args) -> (n,)``; a draw is
        in the support where it is finite.
    args : tuple
        Extra arguments of ``log_prob``.
    mode : array_like, shape (ndim,)
    hessian : array_like, shape (ndim, ndim)
        Of the negative log posterior at ``mode`` (must be positive definite).
    ndraws : int
        Number of draws (>= 1).
    rng : numpy.random.Generator

    Returns
    -------
    draws : numpy.ndarray, shape (ndraws, ndim)
    outside_frac : float
        Share of the first ``ndraws`` normal draws outside the support (-).

    Raises
    ------
    ValueError
        If ``hessian`` is not positive definite, ``ndraws < 1``, or fewer than 1 % of
        1000 rounds of draws fall in the support.
    """
    if ndraws < 1:
        raise ValueError(f"normal_draws: ndraws={ndraws} must be >= 1")
    mode = np.asarray(mode, dtype=float)
    try:
        chol = np.linalg.cholesky(np.linalg.inv(np.asarray(hessian, dtype=float)))
    except np.linalg.LinAlgError:
        raise ValueError("normal_draws: the Hessian is not positive definite") from None
    out = np.empty((0, mode.size))
    outside_frac = None
    for _ in range(1000):
        x = mode + rng.standard_normal((ndraws, mode.size)) @ chol.T
        ok = np.isfinite(log_prob(x, *args))
        if outside_frac is None:
            outside_frac = float(1.0 - ok.mean())
        out = np.concatenate([out, x[ok]])
        if len(out) >= ndraws:
            return out[:ndraws], outside_frac
    raise ValueError(
        f"normal_draws: only {len(out)} of {1000 * ndraws} normal draws in the support"
    )


def laplace_record_model(
    records: pd.DataFrame,
    *,
    surrogate=None,
    ndraws: int = 400,
    seed,
    priors: Priors = Priors(),
    lever_arm_prior: tuple[float, float] | None = None,
    scan_period_s: float | None = None,
    lidar=None,
) -> GlobalFit:
    """Laplace approximation of :func:`~flidar_uq.inference.record_fit.fit_record_model`'s posterior.

    Same data selection, likelihood, priors and starting point as the emcee fit; the
    draws are independent normal draws about the posterior mode in the sampler's
    coordinates, mapped back to the natural scale.

    Parameters
    ----------
    records : pandas.DataFrame
        As for ``fit_record_model``.
    surrogate : SigmaZSurrogate, optional
        The lidar's sigma_Z surrogate (default: ZephIR 300).
    ndraws : int
        Normal draws stored (one chain).
    seed : int or numpy.random.SeedSequence
    priors : Priors
    lever_arm_prior : (float, float), optional
        Mean and sd (m) of the lever arm from the buoy's geometry.
    scan_period_s : float, optional
        A CW lidar's scan duration (s); default the lidar's.
    lidar : str, LidarGeometry or mapping, optional
        The floating lidar, as for ``fit_record_model`` (default the ZephIR 300).

    Returns
    -------
    GlobalFit
        Draws of shape (1, ndraws) per parameter, no pointwise log-likelihood (zero
        observations), no MCMC diagnostics; ``info["loo"]["model"] = "record"`` so that
        the propagation treats it as the record model; ``info["laplace"]`` holds the mode,
        the posterior sd of the approximation (sampler coordinates) and
        ``outside_support_frac``. ``failure_reasons`` name a mode on the edge of the
        support (within the Hessian's difference stencil), a Hessian that is not positive
        definite (the draws are then the mode only) or a share of draws outside the
        support above 1 %.
    """
    for c in ("hws_mean_ms", "hws_std_ms"):
        if c not in records:
            raise ValueError(f"laplace_record_model: records lack column {c!r}")
    rng = np.random.default_rng(as_seedsequence(seed))
    (s, r, gram), use, _ = _record_observations(records, surrogate, scan_period_s, lidar)
    if not use.any():
        raise ValueError(
            "laplace_record_model: no record with a reference std and a motion description"
        )
    args = (s, r, gram, priors, lever_arm_prior, None)
    x0 = _start(lever_arm_prior)
    mode, hess = laplace_approximation(log_prob_record_model, args, x0)
    reasons = []
    # a mode within the Hessian's stencil of the support's edge: the differences there
    # cross the bound and the Hessian (hence the sd) is meaningless
    reach = 2.0 * _HESSIAN_STEP * np.array([[-1.0], [1.0]])
    edge = [
        n
        for k, n in enumerate(RECORD_MODEL_NAMES)
        if not np.all(
            np.isfinite(log_prob_record_model(mode + reach * np.eye(mode.size)[k], *args))
        )
    ]
    if edge:
        reasons.append(
            f"laplace: the mode sits on the edge of the support in {', '.join(edge)}: "
            "the normal approximation does not hold there, use emcee"
        )
    try:
        theta, outside = normal_draws(log_prob_record_model, args, mode, hess, ndraws, rng)
        sd = np.sqrt(np.diag(np.linalg.inv(hess)))
    except ValueError as err:
        reasons.append(f"laplace: {err}")
        theta, outside, sd = np.tile(mode, (ndraws, 1)), float("nan"), np.full(mode.size, np.nan)
    if outside > _OUTSIDE_SUPPORT_WARN:
        reasons.append(
            f"laplace: {outside:.1%} of the normal draws outside the support (mode near a "
            "bound): the approximation is truncated there, use emcee"
        )
    draws = {n: v[None, :] for n, v in natural_draws(theta).items()}
    info = {
        "n_records": int(use.sum()),
        "prior_only": False,
        "excluded_bins": [],
        "loo": {"model": "record"},
        "laplace": {
            "mode": dict(zip(RECORD_MODEL_NAMES, mode.tolist(), strict=True)),
            "sd": dict(zip(RECORD_MODEL_NAMES, sd.tolist(), strict=True)),
            "outside_support_frac": outside,
        },
    }
    return GlobalFit(
        draws=draws,
        log_lik=np.zeros((1, ndraws, 0)),
        diagnostics={},
        failure_reasons=reasons,
        info=info,
    )
