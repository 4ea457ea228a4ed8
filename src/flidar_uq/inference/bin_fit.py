"""Stage 1: posterior of one bin's motion parameters from its records' IMU statistics."""

from __future__ import annotations

from dataclasses import asdict

import numpy as np
import pandas as pd
from emcee.ensemble import walkers_independent

from flidar_uq.inference.densities import (
    _log_prob_two_period,
    _log_prob_unimodal,
    _loglik_pointwise_two_period,
    _loglik_pointwise_unimodal,
    _MotionData,
    _TwoPeriodData,
    log_prob_two_period,
    log_prob_unimodal,
)
from flidar_uq.inference.diagnostics import _diagnostics, _thin
from flidar_uq.inference.loo import _loo
from flidar_uq.inference.observations import (
    _distinct_imu_records,
    imu_observations,
    two_peak_observations,
)
from flidar_uq.inference.priors import Priors, SamplerSettings, sample_motion_prior
from flidar_uq.inference.results import BinFit
from flidar_uq.inference.sampler import _INIT_WIDENING, _run_ensembles
from flidar_uq.seeding import as_seedsequence
from flidar_uq.threads import single_threaded

_UNI_NAMES = ["amplitude_deg", "period_s", "scatter_amplitude", "scatter_period"]


_TWO_NAMES = [
    "amplitude_deg",
    "period1_s",
    "period2_s",
    "weight1",
    "scatter_amplitude",
    "scatter_period",
    "weight_concentration",
]


def _to_natural(theta, model):
    out = np.exp(theta)
    if model == "two_period":
        out[..., 3] = 1.0 / (1.0 + np.exp(-theta[..., 3]))
    return out


def _init_fn(obs, priors, ndim):
    """Overdispersed start: a widened normal approximation of the posterior.

    Centre: the data moments (the two-peaked records' periods and the method-of-moments
    concentration of their variance shares for the two-period model); spread:
    ``_INIT_WIDENING`` times the large-sample posterior sd of each parameter (``sd /
    sqrt(n)`` for a location, ``1 / sqrt(2 n)`` for a log-scale, ``1 / sqrt(n w (1 -
    w))`` for the logit weight), so the ensembles start overdispersed relative to the
    posterior (R-hat across ensembles stays meaningful) yet close enough for a short
    burn-in. With fewer than 2 usable records: prior draws. Walkers started outside the
    support are redrawn from the prior.
    """
    log_amp, log_per = obs[0], obs[1]
    la = log_amp[np.isfinite(log_amp)]
    if ndim == 4:
        lt = log_per[np.isfinite(log_per)]
        ok = la.size >= 2 and lt.size >= 2
    else:
        two = np.isfinite(obs[2]) & np.isfinite(obs[3]) & np.isfinite(obs[4])
        p1, p2, sh = obs[2][two], obs[3][two], obs[4][two]
        ok = la.size >= 2 and p1.size >= 2
    if ok:
        sa = float(np.clip(la.std(), 0.03, 1.0))
        na = la.size
        if ndim == 4:
            st, nt = float(np.clip(lt.std(), 0.03, 1.0)), lt.size
            c = np.array([la.mean(), lt.mean(), np.log(sa), np.log(st)])
            sd = np.array(
                [sa / np.sqrt(na), st / np.sqrt(nt), 1 / np.sqrt(2 * na), 1 / np.sqrt(2 * nt)]
            )
        else:
            nt = p1.size
            st = float(np.clip(np.sqrt(0.5 * (p1.var() + p2.var())), 0.03, 1.0))
            w = float(np.clip(sh.mean(), 0.05, 0.95))
            conc = float(np.clip(w * (1 - w) / max(sh.var(), 1e-6) - 1.0, 1.0, 500.0))
            t1, t2 = float(p1.mean()), float(max(p2.mean(), p1.mean() + 0.05))
            c = np.array([la.mean(), t1, t2, np.log(w / (1 - w)), np.log(sa), np.log(st)])
            c = np.append(c, np.log(conc))
            sd = np.array(
                [
                    sa / np.sqrt(na),
                    st / np.sqrt(nt),
                    st / np.sqrt(nt),
                    1 / np.sqrt(nt * w * (1 - w)),
                    1 / np.sqrt(2 * na),
                    1 / np.sqrt(4 * nt),
                    1 / np.sqrt(nt),
                ]
            )
    lp_fn = log_prob_unimodal if ndim == 4 else log_prob_two_period

    def init(rng, nwalkers):
        p0 = sample_motion_prior(rng, nwalkers, priors, ndim)
        if ok:
            p0 = c + _INIT_WIDENING * sd * rng.standard_normal((nwalkers, ndim))
            if ndim == 7:
                p0[:, 1:3] = np.sort(p0[:, 1:3], axis=1)
        bad = ~np.isfinite(lp_fn(p0, *obs, priors))
        if np.any(bad):
            p0[bad] = sample_motion_prior(rng, int(bad.sum()), priors, ndim)
        return p0 if walkers_independent(p0) else sample_motion_prior(rng, nwalkers, priors, ndim)

    return init


def _fit_motion_model(model, obs, settings, seedseq, priors):
    """Sample one motion model; ``obs`` = (log_amp, log_per) for the unimodal model, plus
    (log_p1, log_p2, share1) for the two-period model (:func:`two_peak_observations`)."""
    ndim = 4 if model == "unimodal" else 7
    names = _UNI_NAMES if model == "unimodal" else _TWO_NAMES
    s = settings
    if model == "two_period":
        f = settings.two_period_step_factor
        s = SamplerSettings(
            **{
                **asdict(settings),
                "nwalkers": max(settings.nwalkers, 2 * ndim + 2),
                "nsteps": int(round(settings.nsteps * f)),
                "nburn": int(round(settings.nburn * f)),
            }
        )
        fn, data = _log_prob_two_period, _TwoPeriodData.from_observations(*obs)
        pll = _loglik_pointwise_two_period
    else:
        fn, data = _log_prob_unimodal, _MotionData.from_observations(*obs)
        pll = _loglik_pointwise_unimodal
    chains, diag, reasons = _run_ensembles(
        fn,
        (data, priors),
        _init_fn(obs, priors, ndim),
        ndim,
        s,
        seedseq,
        lambda ch: _diagnostics(_to_natural(ch, model), names, s),
    )
    thin = _thin(chains, s.ndraws)
    ok = np.isfinite(obs[0]) | np.isfinite(obs[1])
    flat = thin.reshape(-1, ndim)
    ll = pll(flat, *(x[ok] for x in obs)).reshape(thin.shape[0], thin.shape[1], -1)
    draws = {n: _to_natural(thin, model)[..., k] for k, n in enumerate(names)}
    return draws, ll, diag, reasons


@single_threaded
def fit_bin(
    bin_records: pd.DataFrame,
    *,
    surrogate=None,
    settings: SamplerSettings = SamplerSettings(),
    seed,
    priors: Priors = Priors(),
    bin_id=None,
) -> BinFit:
    """Posterior of one bin's motion parameters from its records' IMU statistics (stage 1).

    Parameters
    ----------
    bin_records : pandas.DataFrame
        The bin's records (core record columns; ``bin_id`` column optional). Records of
        the same ``timestamp`` with identical IMU statistics (the heights of one 10-min
        record) count once in the motion likelihood.
    surrogate : SigmaZSurrogate, optional
        Not needed by the motion likelihood; accepted for API symmetry (the returned fit
        computes sigma_Z draws on demand with :meth:`BinFit.sigma_z_draws`).
    settings : SamplerSettings
    seed : int or numpy.random.SeedSequence
        Root of the ensembles' seeds (spawned, one child per ensemble and model).
    priors : Priors
    bin_id : optional
        Default: the unique ``bin_id`` of the records (or None).

    Returns
    -------
    BinFit
        ``converged`` False (with ``failure_reasons``) if any convergence criterion (docs/inference.md) fails.
        With no usable IMU statistics the posterior is the prior (``prior_only``) and a
        reason ``"no IMU statistics"`` is recorded: the bin is failed, its sigma_Z is unknown.

    Raises
    ------
    ValueError
        If ``bin_records`` is empty or holds several ``bin_id`` values.
    """
    if len(bin_records) == 0:
        raise ValueError("fit_bin: bin_records is empty")
    if bin_id is None and "bin_id" in bin_records:
        ids = pd.unique(bin_records["bin_id"])
        if len(ids) > 1:
            raise ValueError(f"fit_bin: records hold several bin_id values {list(ids)[:5]}")
        bin_id = ids[0].item() if hasattr(ids[0], "item") else ids[0]
    seedseq = as_seedsequence(seed)
    ss_uni, ss_two = seedseq.spawn(2)
    imu = _distinct_imu_records(bin_records)
    log_amp, log_per = imu_observations(imu)
    two_peak = two_peak_observations(imu)
    n_imu = int(np.sum(np.isfinite(log_amp) & np.isfinite(log_per)))
    n_two = int(np.sum(np.isfinite(two_peak[1]) & np.isfinite(log_amp)))
    share = n_two / n_imu if n_imu else 0.0
    two = n_two >= 3 and (
        settings.mixture == "always"
        or (settings.mixture == "auto" and share >= settings.two_period_min_share)
    )
    chosen = "two_period" if two else "unimodal"
    if two:
        result = _fit_motion_model(
            "two_period", (log_amp, log_per, *two_peak), settings, ss_two, priors
        )
    else:
        result = _fit_motion_model("unimodal", (log_amp, log_per), settings, ss_uni, priors)
    loo_info = {"n_two_peak": n_two, "two_peak_share": share}
    lo = None
    if n_imu >= 1:
        lo = _loo(result[1])
        if lo is not None:
            loo_info[f"{chosen}_elpd"] = lo["elpd"]
            loo_info[f"{chosen}_pareto_k_max"] = float(np.max(lo["pareto_k"]))
    draws, ll, diag, reasons = result
    reasons = list(reasons)
    if n_imu == 0:
        reasons.append("no IMU statistics: motion posterior equals the prior")
    loo_info["chosen"] = chosen
    hws = (
        bin_records["hws_mean_ms"].to_numpy(dtype=float)
        if "hws_mean_ms" in bin_records
        else np.full(len(bin_records), np.nan)
    )
    info = {
        "bin_id": bin_id,
        "model": chosen,
        "n_records": len(bin_records),
        "n_imu": n_imu,
        "prior_only": n_imu == 0,
        "loo": loo_info,
        "constant": {"record_index": np.asarray(bin_records.index), "hws_mean_ms": hws},
    }
    return BinFit(
        draws=draws,
        log_lik=ll,
        diagnostics=diag,
        failure_reasons=reasons,
        info=info,
        pointwise_loo=lo,  # what save_fit keeps instead of log_lik, computed once
    )
