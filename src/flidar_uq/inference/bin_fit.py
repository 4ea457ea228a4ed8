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
    log_prob_two_period,
    log_prob_unimodal,
)
from flidar_uq.inference.diagnostics import _diagnostics, _thin
from flidar_uq.inference.loo import _loo, _loo_compare, period_kurtosis_ppc
from flidar_uq.inference.observations import _distinct_imu_records, imu_observations
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
]


def _to_natural(theta, model):
    out = np.exp(theta)
    if model == "two_period":
        out[..., 3] = 1.0 / (1.0 + np.exp(-theta[..., 3]))
    return out


def _two_normal_mixture_em(x, niter=50):
    """Maximum-likelihood 2-component normal mixture with a common sd (EM), for a start.

    Returns ``(mu1, mu2, w, sd)`` with ``mu1 <= mu2`` and ``w`` the weight of ``mu1``.
    """
    mu = np.quantile(x, [0.25, 0.75])
    w, sd = 0.5, max(float(np.std(x)) / 2.0, 1e-3)
    for _ in range(niter):
        l1 = np.log(w) - 0.5 * ((x - mu[0]) / sd) ** 2
        l2 = np.log1p(-w) - 0.5 * ((x - mu[1]) / sd) ** 2
        g = 1.0 / (1.0 + np.exp(np.clip(l2 - l1, -700, 700)))  # responsibility of component 1
        w = float(np.clip(g.mean(), 0.02, 0.98))
        mu = np.array(
            [np.sum(g * x) / max(g.sum(), 1e-12), np.sum((1 - g) * x) / max((1 - g).sum(), 1e-12)]
        )
        sd = max(
            float(np.sqrt(np.sum(g * (x - mu[0]) ** 2 + (1 - g) * (x - mu[1]) ** 2) / x.size)), 1e-3
        )
    return float(mu.min()), float(mu.max()), (w if mu[0] <= mu[1] else 1.0 - w), sd


def _init_fn(log_amp, log_per, priors, ndim):
    """Overdispersed start: a widened normal approximation of the posterior.

    Centre: the data moments (unimodal) or an EM mixture fit of the log-periods
    (two-period); spread: ``_INIT_WIDENING`` times the large-sample posterior sd of each
    parameter (``sd / sqrt(n)`` for a location, ``1 / sqrt(2 n)`` for a log-scale,
    ``1 / sqrt(n w (1 - w))`` for the logit weight), so the ensembles start overdispersed
    relative to the posterior (R-hat across ensembles stays meaningful) yet close enough
    for a short burn-in. With fewer than 2 amplitudes or periods: prior draws. Walkers
    started outside the support are redrawn from the prior.
    """
    la, lt = log_amp[np.isfinite(log_amp)], log_per[np.isfinite(log_per)]
    ok = la.size >= 2 and lt.size >= 2
    if ok:
        sa = float(np.clip(la.std(), 0.03, 1.0))
        st = float(np.clip(lt.std(), 0.03, 1.0))
        na, nt = la.size, lt.size
        if ndim == 4:
            c = np.array([la.mean(), lt.mean(), np.log(sa), np.log(st)])
            sd = np.array(
                [sa / np.sqrt(na), st / np.sqrt(nt), 1 / np.sqrt(2 * na), 1 / np.sqrt(2 * nt)]
            )
        else:
            t1, t2, w, st = _two_normal_mixture_em(lt)
            st = max(st, 0.03)
            c = np.array(
                [la.mean(), t1, max(t2, t1 + 0.05), np.log(w / (1 - w)), np.log(sa), np.log(st)]
            )
            sd = np.array(
                [
                    sa / np.sqrt(na),
                    st / np.sqrt(nt * w),
                    st / np.sqrt(nt * (1 - w)),
                    1 / np.sqrt(nt * w * (1 - w)),
                    1 / np.sqrt(2 * na),
                    1 / np.sqrt(2 * nt),
                ]
            )
    lp_fn = log_prob_unimodal if ndim == 4 else log_prob_two_period

    def init(rng, nwalkers):
        p0 = sample_motion_prior(rng, nwalkers, priors, ndim)
        if ok:
            p0 = c + _INIT_WIDENING * sd * rng.standard_normal((nwalkers, ndim))
            if ndim == 6:
                p0[:, 1:3] = np.sort(p0[:, 1:3], axis=1)
        bad = ~np.isfinite(lp_fn(p0, log_amp, log_per, priors))
        if np.any(bad):
            p0[bad] = sample_motion_prior(rng, int(bad.sum()), priors, ndim)
        return p0 if walkers_independent(p0) else sample_motion_prior(rng, nwalkers, priors, ndim)

    return init


def _fit_motion_model(model, log_amp, log_per, settings, seedseq, priors):
    ndim = 4 if model == "unimodal" else 6
    names = _UNI_NAMES if model == "unimodal" else _TWO_NAMES
    fn = _log_prob_unimodal if model == "unimodal" else _log_prob_two_period
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
    data = _MotionData.from_observations(log_amp, log_per)
    chains, diag, reasons = _run_ensembles(
        fn,
        (data, priors),
        _init_fn(log_amp, log_per, priors, ndim),
        ndim,
        s,
        seedseq,
        lambda ch: _diagnostics(_to_natural(ch, model), names, s),
    )
    thin = _thin(chains, s.ndraws)
    ok = np.isfinite(log_amp) | np.isfinite(log_per)
    pll = _loglik_pointwise_unimodal if model == "unimodal" else _loglik_pointwise_two_period
    flat = thin.reshape(-1, ndim)
    ll = pll(flat, log_amp[ok], log_per[ok]).reshape(thin.shape[0], thin.shape[1], -1)
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
        ``converged`` False (with ``failure_reasons``) if any criterion of design.md fails.
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
    ss_uni, ss_two, ss_ppc = seedseq.spawn(3)
    log_amp, log_per = imu_observations(_distinct_imu_records(bin_records))
    n_imu = int(np.sum(np.isfinite(log_amp) & np.isfinite(log_per)))
    results = {
        "unimodal": _fit_motion_model("unimodal", log_amp, log_per, settings, ss_uni, priors)
    }
    ppc_p = period_kurtosis_ppc(log_per, results["unimodal"][0], rng=np.random.default_rng(ss_ppc))
    n_peak2 = (
        int(np.sum(np.isfinite(bin_records["period2_s"]))) if "period2_s" in bin_records else 0
    )
    screened = bool(ppc_p < settings.screen_pvalue)
    loo_info = {
        "ppc_kurtosis_p": ppc_p,
        "n_second_peak": n_peak2,
        "two_period_screened": bool(screened),
    }
    chosen = "unimodal"
    if n_imu >= 3 and (settings.mixture == "always" or (settings.mixture == "auto" and screened)):
        results["two_period"] = _fit_motion_model(
            "two_period", log_amp, log_per, settings, ss_two, priors
        )
        loos = {m: _loo(r[1]) for m, r in results.items()}
        if any(lo is None for lo in loos.values()):
            loo_info["loo_failed"] = True
            loos = {}
        for m, lo in loos.items():
            loo_info[f"{m}_elpd"] = lo["elpd"]
            loo_info[f"{m}_se"] = lo["se"]
            loo_info[f"{m}_pareto_k_max"] = float(np.max(lo["pareto_k"]))
            loo_info[f"{m}_converged"] = not results[m][3]
        d, se = _loo_compare(loos["two_period"], loos["unimodal"]) if loos else (np.nan, np.nan)
        loo_info["elpd_diff"], loo_info["elpd_diff_se"] = d, se
        if settings.mixture == "always" or (
            not results["two_period"][3] and d > settings.loo_threshold_se * se and d > 0
        ):
            chosen = "two_period"
    elif n_imu >= 1:
        lo = _loo(results["unimodal"][1])
        if lo is not None:
            loo_info["unimodal_elpd"] = lo["elpd"]
            loo_info["unimodal_pareto_k_max"] = float(np.max(lo["pareto_k"]))
    draws, ll, diag, reasons = results[chosen]
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
    return BinFit(draws=draws, log_lik=ll, diagnostics=diag, failure_reasons=reasons, info=info)
