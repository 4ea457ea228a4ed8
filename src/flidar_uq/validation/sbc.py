"""Simulation-based calibration (Talts et al. 2018) of the inference on the statistical mode.

One replication draws the parameters from the priors, a campaign from the Bayesian model
itself (:func:`flidar_uq.campaign.statistical_mode.generate_statistical_campaign`), fits
every bin and the global model and returns the rank of each true value among posterior
draws; uniform ranks over many replications <=> calibrated (``tests/test_sbc.py``,
``benchmarks/sbc.py``).
"""

from __future__ import annotations

import numpy as np
import pandas as pd
from scipy import stats

from flidar_uq.campaign.statistical_mode import draw_true_params, generate_statistical_campaign
from flidar_uq.correction.propagation import (
    PropagationSettings,
    draw_corrected_ti,
    record_summary,
)
from flidar_uq.data.imu import follower_translation_columns
from flidar_uq.inference import (
    Priors,
    SamplerSettings,
    fit_bin,
    fit_global,
    fit_record_model,
)
from flidar_uq.inference.record_fit import RECORD_MODEL_NAMES
from flidar_uq.inference.record_motion import gram_sigma_z_ms, motion_gram
from flidar_uq.physics.motion_spectrum import TiltBandSpectrum
from flidar_uq.physics.surrogate import default_surrogate
from flidar_uq.seeding import as_seedsequence

__all__ = [
    "SBC_PARAMS",
    "SBC_RECORD_PARAMS",
    "draw_record_campaign",
    "draw_record_prior",
    "propagation_ranks",
    "rank_uniformity",
    "sbc_record_replication",
    "sbc_replication",
]

_PRIORS = Priors()


def rank_uniformity(ranks, n_rank_draws: int = 99, n_hist_bins: int = 10):
    """Chi-square test of uniformity of SBC ranks (Talts et al. 2018).

    Parameters
    ----------
    ranks : array_like of int
        Ranks in ``0 .. n_rank_draws``.
    n_rank_draws : int
    n_hist_bins : int
        Histogram bins; ``n_rank_draws + 1`` must be a multiple of it.

    Returns
    -------
    (float, numpy.ndarray)
        p-value and the histogram counts, shape (n_hist_bins,).
    """
    if (n_rank_draws + 1) % n_hist_bins:
        raise ValueError(
            f"rank_uniformity: n_rank_draws + 1 = {n_rank_draws + 1} is not a multiple of "
            f"n_hist_bins = {n_hist_bins}"
        )
    counts = np.bincount(
        np.asarray(ranks, dtype=int) * n_hist_bins // (n_rank_draws + 1), minlength=n_hist_bins
    )
    return float(stats.chisquare(counts).pvalue), counts


def _rank(x, true, n_rank_draws):
    """Rank (0 .. ``n_rank_draws``) of ``true`` among ``n_rank_draws`` draws taken uniformly
    from the flat stored draws ``x`` (Talts et al. 2018, Algorithm 1)."""
    x = np.asarray(x, dtype=float).ravel()
    idx = np.linspace(0, x.size - 1, n_rank_draws).astype(int)
    return int(np.sum(x[idx] < true))


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
    surrogate = default_surrogate(surrogate)
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
        out[f"rank_{name}"] = _rank(src.flat(name), true, n_rank_draws)
        out[f"true_{name}"] = float(true)
    return out


# --- the record motion model (flidar_uq.inference.record_fit) -------------------------

#: Parameters of the record motion model whose ranks :func:`sbc_record_replication` returns
#: (every parameter of the model).
SBC_RECORD_PARAMS = RECORD_MODEL_NAMES


def _trunc_halfnormal(rng, scale, lo, hi):
    """One draw of HalfNormal(``scale``) truncated to (``lo``, ``hi``) (rejection)."""
    while True:
        x = abs(rng.normal(0.0, scale))
        if lo < x < hi:
            return float(x)


def draw_record_prior(rng, *, priors: Priors = _PRIORS, lever_arm_prior=None) -> dict:
    """One draw from the record model's prior, as ``record_fit._log_prior`` states it.

    ``rho ~ U(-1, 1)``; ``kappa ~ HalfNormal(kappa_scale)`` on (``kappa_min``, 2);
    ``kappa_z ~ HalfNormal(kappa_z_scale)`` on (``kappa_min``, 5); lever arm (m)
    ``~ HalfNormal(lever_arm_scale_m)`` on [0, ``lever_arm_max_m``) or, with
    ``lever_arm_prior = (mean, sd)``, ``Normal(mean, sd)`` on the same interval;
    ``log motion_scale ~ N(0, record_motion_scale_log_sd)`` on ``|log k| < log 5``;
    ``hull_response ~ HalfNormal(hull_response_scale)`` on (1e-8, ``hull_response_max``);
    ``log rho_sd ~ N(log rho_sd_median, rho_sd_log_sd)`` on (``kappa_min``, 2).

    Parameters
    ----------
    rng : numpy.random.Generator
    priors : Priors
    lever_arm_prior : (float, float), optional

    Returns
    -------
    dict
        The seven parameters of :data:`SBC_RECORD_PARAMS` on their natural scale.
    """
    rho = float(rng.uniform(-1.0, 1.0))
    kappa = _trunc_halfnormal(rng, priors.kappa_scale, priors.kappa_min, 2.0)
    kappa_z = _trunc_halfnormal(rng, priors.kappa_z_scale, priors.kappa_min, 5.0)
    while True:
        if lever_arm_prior is None:
            lever = abs(rng.normal(0.0, priors.lever_arm_scale_m))
        else:
            lever = rng.normal(lever_arm_prior[0], lever_arm_prior[1])
        if 0.0 <= lever < priors.lever_arm_max_m:
            break
    while True:
        log_k = rng.normal(0.0, priors.record_motion_scale_log_sd)
        if abs(log_k) < np.log(5.0):
            break
    while True:
        rho_sd = float(np.exp(rng.normal(np.log(priors.rho_sd_median), priors.rho_sd_log_sd)))
        if priors.kappa_min < rho_sd < 2.0:
            break
    return {
        "rho": rho,
        "kappa": kappa,
        "kappa_z": kappa_z,
        "lever_arm_m": float(lever),
        "motion_scale": float(np.exp(log_k)),
        "hull_response": _trunc_halfnormal(
            rng, priors.hull_response_scale, 1e-8, priors.hull_response_max
        ),
        "rho_sd": rho_sd,
    }


def draw_record_campaign(
    rng,
    n_records: int,
    truth: dict,
    *,
    surrogate=None,
    pair_log_sd: float = 0.0,
    hull="wave_follower",
) -> pd.DataFrame:
    """Records drawn from the record model's likelihood exactly as it is written.

    Covariates: ``hws ~ U(4, 18)`` m/s, TI log-normal (median 0.08, log-sd 0.3), reference
    std ``r = TI hws``; tilt std along the wind log-normal (median 1.6 deg, log-sd 0.4),
    mean period ``U(2.5, 7)`` s; across the wind log-normal (median 1.0 deg, log-sd 0.5);
    the wave follower's translation of :func:`flidar_uq.data.imu.follower_translation_columns`
    for one band along and one across the wind at periods ``T`` and ``T U(1, 1.6)``. With
    ``sZ`` of :func:`~flidar_uq.inference.record_motion.gram_sigma_z_ms` (lever arm, hull
    response, motion scale) times ``exp(kappa_z^2 / 2)`` (the realised error's mean),
    ``mu^2 = r^2 + sZ^2 + 2 rho r sZ`` (Eq. (15) of Gutiérrez-Antuñano et al. (2018)) and
    ``tau^2 = (kappa mu)^2 + (kappa_z sZ dmu/dsZ)^2 + (rho_sd (1 - rho^2) r sZ / mu)^2
    + (pair_log_sd r dmu/dr)^2 + 1e-8``, the
    floating-lidar std is
    ``s ~ Normal(mu, tau)`` (the record model's likelihood, not a different generative
    story: SBC ranks are uniform only for the model as written).

    Parameters
    ----------
    rng : numpy.random.Generator
    n_records : int
    truth : dict
        The seven parameters of :data:`SBC_RECORD_PARAMS`.
    surrogate : SigmaZSurrogate, optional
    pair_log_sd : float
        The known relative sampling scatter of a reference lidar pair (-), every record
        (``fit_record_model(pair_log_sd=...)``); 0: a point reference.
    hull : str or HullResponse
        The reference hull whose translation the hull response scales
        (:func:`~flidar_uq.inference.record_motion.motion_gram`; default the wave follower).

    Returns
    -------
    pandas.DataFrame
        ``hws_mean_ms``, ``tilt_along_wind_std_deg``, ``tilt_period_mean_s``,
        ``hws_std_ms``, ``ref_hws_std_ms``.
    """
    hws = rng.uniform(4.0, 18.0, n_records)
    r = np.exp(rng.normal(np.log(0.08), 0.3, n_records)) * hws
    along = np.exp(rng.normal(np.log(1.6), 0.4, n_records))
    across = np.exp(rng.normal(np.log(1.0), 0.5, n_records))
    per = rng.uniform(2.5, 7.0, n_records)
    per_across = per * rng.uniform(1.0, 1.6, n_records)
    rec = pd.DataFrame(
        {
            "hws_mean_ms": hws,
            "tilt_along_wind_std_deg": along,
            "tilt_across_wind_std_deg": across,
            "tilt_period_mean_s": per,
        }
    )
    bands = TiltBandSpectrum(
        np.array([1.0, 5.0, 20.0]),
        np.column_stack([per, per_across]),
        np.column_stack([along**2, np.zeros(n_records)]),
        np.column_stack([np.zeros(n_records), across**2]),
        *(np.zeros(n_records) for _ in range(5)),
    )
    for col, val in follower_translation_columns(bands).items():
        rec[col] = val
    sz = gram_sigma_z_ms(
        motion_gram(rec, surrogate=surrogate, hull=hull),
        lever_arm_m=truth["lever_arm_m"],
        hull_response=truth["hull_response"],
        motion_scale=truth["motion_scale"],
    )
    sz = sz * np.exp(0.5 * truth["kappa_z"] ** 2)  # the realised error's mean (record_fit)
    sz_sq = sz**2
    mu_sq = np.maximum(
        r**2 + sz_sq + 2.0 * truth["rho"] * r * sz, 1e-12
    )  # Eq. (15) of Gutiérrez-Antuñano et al. (2018)
    dmu_sq = (sz + truth["rho"] * r) ** 2 / mu_sq
    dmu_r_sq = (r + truth["rho"] * sz) ** 2 / mu_sq
    tau = np.sqrt(
        truth["kappa"] ** 2 * mu_sq
        + truth["kappa_z"] ** 2 * sz_sq * dmu_sq
        + (truth["rho_sd"] * (1.0 - truth["rho"] ** 2)) ** 2 * r**2 * sz_sq / mu_sq
        + float(pair_log_sd) ** 2 * r**2 * dmu_r_sq
        + 1e-8
    )
    rec["hws_std_ms"] = np.sqrt(mu_sq) + tau * rng.standard_normal(n_records)
    rec["ref_hws_std_ms"] = r
    return rec


def sbc_record_replication(
    seed,
    *,
    n_records: int = 400,
    settings=None,
    priors: Priors = _PRIORS,
    lever_arm_prior=None,
    n_rank_draws: int = 99,
    surrogate=None,
    pair_log_sd: float = 0.0,
    n_propagated: int = 0,
) -> dict:
    """One simulation-based-calibration replication (Talts et al. 2018) of the record model.

    Draws the seven parameters from the record model's prior (:func:`draw_record_prior`),
    a campaign from its likelihood (:func:`draw_record_campaign`), fits it with
    :func:`~flidar_uq.inference.record_fit.fit_record_model` and returns the rank of each
    true value among ``n_rank_draws`` posterior draws taken uniformly from the stored
    (already thinned) draws.

    Parameters
    ----------
    seed : int or numpy.random.SeedSequence
    n_records : int
    settings : SamplerSettings, optional
        Default: ``SamplerSettings(nsteps=300, nburn=150, ndraws=100,
        global_max_step_factor=1.0)`` (fixed length: SBC does not condition on convergence).
    priors : Priors
    lever_arm_prior : (float, float), optional
        Passed to both the prior draw and the fit.
    n_rank_draws : int
        Ranks are in ``0 .. n_rank_draws``.
    surrogate : SigmaZSurrogate, optional
    pair_log_sd : float
        Known sampling scatter of a reference lidar pair (-), in the data and in the fit
        (:func:`draw_record_campaign`); 0: a point reference.
    n_propagated : int
        Records whose corrected TI is checked too (:func:`propagation_ranks`); 0: none.

    Returns
    -------
    dict
        ``rank_<param>`` and ``true_<param>`` for :data:`SBC_RECORD_PARAMS`, ``converged``,
        ``n_records``, ``max_tau_steps`` (largest integrated autocorrelation time, steps)
        and ``rank_spacing_over_tau`` (steps between two rank draws of one walker over
        ``max_tau_steps``; above ~2 the rank draws are nearly independent).
    """
    if settings is None:
        settings = SamplerSettings(nsteps=300, nburn=150, ndraws=100, global_max_step_factor=1.0)
    ss_truth, ss_data, ss_fit = as_seedsequence(seed).spawn(3)
    truth = draw_record_prior(
        np.random.default_rng(ss_truth), priors=priors, lever_arm_prior=lever_arm_prior
    )
    rec = draw_record_campaign(
        np.random.default_rng(ss_data), n_records, truth, surrogate=surrogate,
        pair_log_sd=pair_log_sd,
    )  # fmt: skip
    fit = fit_record_model(
        rec,
        surrogate=surrogate,
        settings=settings,
        seed=ss_fit,
        priors=priors,
        lever_arm_prior=lever_arm_prior,
        pair_log_sd=np.full(len(rec), float(pair_log_sd)) if pair_log_sd > 0 else None,
    )
    taus = [fit.diagnostics[n]["tau"] for n in SBC_RECORD_PARAMS]
    nsteps_run = fit.diagnostics["rho"]["nsteps_over_tau"] * fit.diagnostics["rho"]["tau"]
    nens = fit.draws["rho"].shape[0]
    # walker-major pooling: consecutive rank draws of one walker are this many steps apart
    spacing = nens * settings.nwalkers * nsteps_run / n_rank_draws
    finite = [t for t in taus if np.isfinite(t)]
    tau_max = float(max(finite)) if finite else float("nan")  # too short a chain: unknown
    out = {
        "converged": bool(fit.converged),
        "n_records": int(fit.info["n_records"]),
        "max_tau_steps": tau_max,
        "rank_spacing_over_tau": float(spacing / tau_max),
    }
    for name in SBC_RECORD_PARAMS:
        out[f"rank_{name}"] = _rank(fit.flat(name), truth[name], n_rank_draws)
        out[f"true_{name}"] = truth[name]
    if n_propagated:
        out |= propagation_ranks(
            fit, rec, seed=ss_fit.spawn(1)[0], n_check=n_propagated,
            n_rank_draws=n_rank_draws, surrogate=surrogate,
        )  # fmt: skip
    return out


def propagation_ranks(
    fit, records: pd.DataFrame, *, seed, n_check: int, n_rank_draws: int = 99, surrogate=None
) -> dict:
    """The propagation's part of simulation-based calibration: ranks of true TIs.

    The records come from the record model (:func:`draw_record_campaign`), so each one's
    true point std is its ``ref_hws_std_ms`` (a point reference, no sampling scatter of
    its own). :func:`~flidar_uq.correction.propagation.draw_corrected_ti` draws
    ``n_rank_draws`` corrected TIs of each record from the fit's posterior; the rank of the
    true TI ``ref_hws_std_ms / hws_mean_ms`` among them is uniform on ``0 .. n_rank_draws``
    when the propagation is calibrated. ``n_check`` records are drawn at random (without
    replacement) among those with finite draws, so that the ranks of one replication share
    little more than the posterior.

    Parameters
    ----------
    fit : GlobalFit
        The record model's fit of ``records``.
    records : pandas.DataFrame
        :func:`draw_record_campaign`'s records.
    seed : int or numpy.random.SeedSequence
    n_check : int
        Records whose rank is returned.
    n_rank_draws : int
    surrogate : SigmaZSurrogate, optional

    Returns
    -------
    dict
        ``propagation_ranks`` (list of ``n_check`` ints in ``0 .. n_rank_draws``) and
        ``propagation_coverage_90`` (the fraction of all records with finite draws whose
        90 % interval holds the true TI, -).
    """
    ss_prop, ss_pick = as_seedsequence(seed).spawn(2)
    rec = records.assign(bin_id=0)
    draws = draw_corrected_ti(
        rec, [], fit, surrogate=surrogate, settings=PropagationSettings(ndraws=n_rank_draws),
        seed=ss_prop,
    )  # fmt: skip
    no_baseline = (np.full(len(rec), np.nan), np.nan)  # the intervals only
    per_record, ti = record_summary(rec, draws, no_baseline), draws.ti
    true_ti = (records["ref_hws_std_ms"] / records["hws_mean_ms"]).to_numpy()
    finite = np.flatnonzero(np.all(np.isfinite(ti), axis=0))
    pick = np.random.default_rng(ss_pick).choice(
        finite, size=min(n_check, finite.size), replace=False
    )
    ranks = [int(np.sum(ti[:, j] < true_ti[j])) for j in np.sort(pick)]
    lo = per_record["ti_corrected_lo"].to_numpy()[finite]
    hi = per_record["ti_corrected_hi"].to_numpy()[finite]
    inside = (lo <= true_ti[finite]) & (true_ti[finite] <= hi)
    return {"propagation_ranks": ranks, "propagation_coverage_90": float(np.mean(inside))}
