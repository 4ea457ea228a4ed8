"""emcee inference of per-bin motion parameters and the global correlation rho (cut model).

Two stages, matching the Snakemake fan-out/gather (docs/inference.md):

1. :func:`fit_bin` (one job per bin): posterior of the bin's motion parameters from the
   records' IMU statistics only. Unimodal model ``(A, T, s_a, s_T)``; two-period model
   ``(A, T1 < T2, w, s_a, s_T)``; the two-period model is kept only if PSIS-LOO prefers it.
2. :func:`fit_global` (gather): posterior of ``rho``, ``tau0`` and ``kappa`` from the
   records with a reference std, with each record's sigma_Z carried from stage 1 (its
   posterior median and variance; a cut model: the observation model does not feed back
   into the motion parameters). PSIS-LOO compares the global rho with a per-bin rho,
   and (:func:`select_global_model`) the rho-only model with the lever-arm model.

Observation model (docs/inference.md): ``s_i ~ Normal(mu_i, tau_i)``,
``mu_i = sqrt(r_i^2 + sZ_i^2 + 2 rho r_i sZ_i)`` (Eq. 15 of Gutiérrez-Antuñano et al. (2018)),
``tau_i^2 = (kappa mu_i)^2 + tau0^2 + (dmu/dsZ)^2 Var(sZ_i)``; ``kappa`` is the relative
sampling std of a 10-min std (inferred), ``tau0`` the model error (m/s).

Every log-probability here is vectorised over walkers, module level (picklable) and
returns ``-inf`` (never NaN) outside the support.

Sampling (:func:`_run_ensembles`): the ``nensembles`` independent ensembles run as blocks
of one emcee sampler (moves act within a block), so one vectorised log-probability call
serves all ensembles; they start from a widened normal approximation of the posterior
(overdispersed, so R-hat across ensembles stays meaningful); the burn-in fits a per-block
Student-t independence proposal that makes the main-phase autocorrelation time ~2-4 steps.

Rule of this folder: ``flidar_uq.inference`` imports only ``flidar_uq.physics``,
``flidar_uq.data`` and the dependency-free ``flidar_uq.seeding`` / ``flidar_uq.threads``;
never ``campaign``, ``correction`` or ``workflow``. One concern per module:

- :mod:`.priors` -- ``Priors``, ``SamplerSettings``, draws from the motion prior
- :mod:`.densities` -- model log-densities and pointwise log-likelihoods
- :mod:`.observations` -- IMU observations, translation unit, sigma_Z moments
- :mod:`.moves` -- emcee moves (block DE, Student-t independence proposal)
- :mod:`.sampler` -- ensembles, burn-in, main phase and its extension
- :mod:`.diagnostics` -- R-hat, ESS, autocorrelation times
- :mod:`.loo` -- PSIS-LOO and the posterior predictive check
- :mod:`.results` -- ``BinFit``, ``GlobalFit``, ``FailedFit``; NetCDF writer and reader
- :mod:`.bin_fit`, :mod:`.global_fit` -- the two stages (bin motion model)
- :mod:`.record_motion`, :mod:`.record_fit` -- the record motion model: each record's
  sigma_Z from its own along-wind tilt description, and the global fit on it
- :mod:`.laplace` -- Laplace (normal) approximation of the record model's posterior, a fast
  stand-in for emcee that says where it breaks
- :mod:`.predictive` -- prior predictive draws

This module only re-exports the public API.
"""

from flidar_uq.inference.bin_fit import fit_bin
from flidar_uq.inference.densities import log_prob_global, log_prob_two_period, log_prob_unimodal
from flidar_uq.inference.global_fit import fit_global, select_global_model
from flidar_uq.inference.observations import (
    effective_sigma_z_ms,
    imu_observations,
    record_sigma_z_moments,
    records_wind_body_deg,
    two_peak_observations,
)
from flidar_uq.inference.predictive import prior_predictive
from flidar_uq.inference.priors import Priors, SamplerSettings, sample_motion_prior
from flidar_uq.inference.record_fit import (
    fit_record_model,
    fit_record_model_selecting_hull,
    is_record_model,
    log_prob_record_model,
)
from flidar_uq.inference.record_motion import per_record_motion
from flidar_uq.inference.results import (
    BinFit,
    FailedFit,
    GlobalFit,
    load_fit,
    save_fit,
    write_failed_fit,
)
from flidar_uq.physics.six_dof_sigma_z import translation_unit_sq

__all__ = [
    "fit_record_model",
    "fit_record_model_selecting_hull",
    "is_record_model",
    "log_prob_record_model",
    "per_record_motion",
    "Priors",
    "SamplerSettings",
    "BinFit",
    "GlobalFit",
    "fit_bin",
    "fit_global",
    "select_global_model",
    "load_fit",
    "save_fit",
    "write_failed_fit",
    "FailedFit",
    "log_prob_unimodal",
    "log_prob_two_period",
    "log_prob_global",
    "imu_observations",
    "two_peak_observations",
    "prior_predictive",
    "sample_motion_prior",
    "record_sigma_z_moments",
    "translation_unit_sq",
    "effective_sigma_z_ms",
    "records_wind_body_deg",
]
