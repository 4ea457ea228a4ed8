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

Observation model (design.md): ``s_i ~ Normal(mu_i, tau_i)``,
``mu_i = sqrt(r_i^2 + sZ_i^2 + 2 rho r_i sZ_i)`` (Eq. 15 of seed 000),
``tau_i^2 = (kappa mu_i)^2 + tau0^2 + (dmu/dsZ)^2 Var(sZ_i)``; ``kappa`` is the relative
sampling std of a 10-min std (inferred), ``tau0`` the model error (m/s).

Every log-probability here is vectorised over walkers, module level (picklable) and
returns ``-inf`` (never NaN) outside the support.

Sampling (:func:`_run_ensembles`): the ``nensembles`` independent ensembles run as blocks
of one emcee sampler (moves act within a block), so one vectorised log-probability call
serves all ensembles; they start from a widened normal approximation of the posterior
(overdispersed, so R-hat across ensembles stays meaningful); the burn-in fits a per-block
Student-t independence proposal that makes the main-phase autocorrelation time ~2-4 steps.
"""

from __future__ import annotations

import json
from dataclasses import asdict, dataclass, field

import arviz as az
import emcee
import numpy as np
import pandas as pd
import xarray as xr
from arviz_stats.base import array_stats
from emcee.ensemble import walkers_independent
from scipy import optimize, stats
from scipy.special import logsumexp

from flidar_uq.physics.variance_laws import sigma_moving_pc

__all__ = [
    "Priors",
    "SamplerSettings",
    "BinFit",
    "GlobalFit",
    "fit_bin",
    "fit_global",
    "select_global_model",
    "load_fit",
    "log_prob_unimodal",
    "log_prob_two_period",
    "log_prob_global",
    "imu_observations",
    "prior_predictive",
    "sample_motion_prior",
    "period_kurtosis_ppc",
    "record_sigma_z_moments",
    "translation_unit_sq",
]

_LOG2PI = np.log(2.0 * np.pi)
# Sampler tuning, chosen with the speed-accuracy benchmark and the per-bin
# autocorrelation times of the default campaign (docs/inference.md):
# scale of the Student-t independence proposal relative to the burn-in covariance
_PROPOSAL_SCALE = 1.2
# the first burn-in half's proposal is fitted to its last (1 - _FIT_FRAC) share
_FIT_FRAC = 0.5
# initial ensembles: this many posterior sd of the normal approximation (overdispersed)
_INIT_WIDENING = 3.0
# expected acceptance rate of the independence move at and above which the main phase
# uses the full independence_weight (below: proportionally less, the rest DE)
_INDEPENDENCE_FULL_ACCEPTANCE = 0.5


@dataclass(frozen=True)
class Priors:
    """Weakly informative, physical priors (justified in docs/inference.md).

    Amplitude ``A`` (deg): log-normal, median ``amplitude_median_deg``, log-sd
    ``amplitude_log_sd``, truncated to [``amplitude_min_deg``, ``amplitude_max_deg``].
    Periods ``T`` (s): log-normal, median ``period_median_s``, log-sd ``period_log_sd``,
    truncated to [``period_min_s``, ``period_max_s``]; two-period: both periods with this
    prior and ordered ``T1 < T2``; weight ``w ~ Beta(weight_beta, weight_beta)``.
    Within-bin log-scatter of the IMU statistics: half-normal(``scatter_scale``) on
    [``scatter_min``, ``scatter_max``]. ``rho ~ Uniform(-1, 1)``;
    ``tau0 ~ HalfNormal(tau0_scale_ms)``; ``kappa ~ HalfNormal(kappa_scale)``;
    effective lever arm ``L ~ HalfNormal(lever_arm_scale_m)`` on [0, ``lever_arm_max_m``);
    motion-model scale of the surrogate's rotational sigma_Z
    ``log k ~ Normal(0, motion_scale_log_sd)`` on ``|log k| < log 5``.
    """

    amplitude_median_deg: float = 3.0
    amplitude_log_sd: float = 0.8
    amplitude_min_deg: float = 0.05
    amplitude_max_deg: float = 25.0
    period_median_s: float = 5.0
    period_log_sd: float = 0.5
    period_min_s: float = 1.0
    period_max_s: float = 20.0
    weight_beta: float = 2.0
    scatter_scale: float = 0.3
    scatter_min: float = 0.03
    scatter_max: float = 2.0
    tau0_scale_ms: float = 0.1
    kappa_scale: float = 0.2
    tau0_min_ms: float = 1e-4
    kappa_min: float = 1e-4
    lever_arm_scale_m: float = 3.0
    lever_arm_max_m: float = 20.0
    motion_scale_log_sd: float = 0.3


@dataclass(frozen=True)
class SamplerSettings:
    """emcee and convergence settings.

    Parameters
    ----------
    nwalkers : int
        Walkers per ensemble (the two-period model uses at least 2 * ndim + 2 = 14).
    nsteps : int
        Steps kept per ensemble after burn-in.
    nburn : int
        Burn-in steps discarded per ensemble.
    nensembles : int
        Independent ensembles (>= 4); R-hat is computed across them.
    ndraws : int
        Draws stored per ensemble (thinned uniformly from the pooled walkers).
    snooker_weight : float
        Share of DESnookerMove (rest DEMove) during the first half of the burn-in (mild
        multimodality).
    independence_weight : float
        Share of the Student-t independence Metropolis move (fitted to the burn-in, per
        ensemble) in the second half of the burn-in and the main phase; the rest is
        DEMove. It cuts the autocorrelation time to ~2-4 steps for near-Gaussian
        posteriors. In the main phase it is scaled down in proportion to the move's
        expected acceptance rate when that is below 0.5 (a posterior at a boundary or
        banana-shaped is left mostly to DE; the adaptive extension lengthens such chains).
    mixture : str
        ``"auto"``: fit the unimodal model; if the posterior predictive check of the
        periods' kurtosis has p < ``screen_pvalue``, also fit the two-period model and keep it if
        PSIS-LOO prefers it by more than ``loo_threshold_se`` standard errors and it
        converged. ``"never"`` or ``"always"`` (fit both, keep the two-period model).
    max_step_factor : float
        The main phase is extended adaptively (all ensembles equally) until it exceeds
        ``1.1 n_autocorr`` autocorrelation times, at most to this many times ``nsteps``.
    two_period_step_factor : float
        The two-period model (6 parameters, longer autocorrelation) runs this many times
        ``nsteps`` and ``nburn``.
    global_step_factor : float
        The global fit runs this many times ``nsteps`` and ``nburn`` (1: on a campaign its
        3-4 parameter posterior is near-Gaussian, autocorrelation time ~2-3 steps, and it
        starts from a widened Laplace approximation).
    global_max_step_factor : float
        ``max_step_factor`` of the global fit (relative to its ``nsteps``): with few
        records the ``tau0``/``kappa`` posterior is banana-shaped (autocorrelation time
        ~20-40 steps) and needs the longer extension; a near-Gaussian one never uses it.
    rhat_max, ess_min, n_autocorr : float
        Convergence thresholds of design.md (rank R-hat, bulk and tail ESS, chain length
        in integrated autocorrelation times).
    """

    nwalkers: int = 16
    nsteps: int = 250
    nburn: int = 100
    nensembles: int = 4
    ndraws: int = 250
    snooker_weight: float = 0.2
    independence_weight: float = 0.85
    two_period_step_factor: float = 2.0
    max_step_factor: float = 6.0
    global_step_factor: float = 1.0
    global_max_step_factor: float = 12.0
    screen_pvalue: float = 0.05
    mixture: str = "auto"
    loo_threshold_se: float = 2.0
    rhat_max: float = 1.01
    ess_min: float = 400.0
    n_autocorr: float = 50.0
    n_sz_draws: int = 200

    def __post_init__(self):
        if self.nensembles < 4:
            raise ValueError(f"SamplerSettings: nensembles={self.nensembles} < 4 (design.md)")
        if self.mixture not in {"auto", "never", "always"}:
            raise ValueError(f"SamplerSettings: mixture={self.mixture!r} not auto/never/always")
        if self.nsteps < 10 or self.nburn < 0 or self.nwalkers < 8:
            raise ValueError(
                f"SamplerSettings: need nsteps >= 10, nburn >= 0, nwalkers >= 8; got "
                f"{self.nsteps}, {self.nburn}, {self.nwalkers}"
            )


# ----------------------------------------------------------------------------- log densities
def _norm_logpdf(x, mu, sd):
    return -0.5 * ((x - mu) / sd) ** 2 - np.log(sd) - 0.5 * _LOG2PI


def _log_halfnormal_logscale(log_s, scale):
    """Log density of log(s) when s ~ HalfNormal(scale) (includes the Jacobian s)."""
    s = np.exp(log_s)
    return np.log(2.0) + _norm_logpdf(s, 0.0, scale) + log_s


def _in(x, lo, hi):
    return (x > lo) & (x < hi)


def _log_prior_motion(log_a, log_ts, log_sa, log_st, priors):
    """Shared prior terms; log_ts is a list of log-period arrays. Returns (lp, ok)."""
    ok = _in(log_a, np.log(priors.amplitude_min_deg), np.log(priors.amplitude_max_deg))
    lp = _norm_logpdf(log_a, np.log(priors.amplitude_median_deg), priors.amplitude_log_sd)
    for log_t in log_ts:
        ok &= _in(log_t, np.log(priors.period_min_s), np.log(priors.period_max_s))
        lp = lp + _norm_logpdf(log_t, np.log(priors.period_median_s), priors.period_log_sd)
    for log_s in (log_sa, log_st):
        ok &= _in(log_s, np.log(priors.scatter_min), np.log(priors.scatter_max))
        lp = lp + _log_halfnormal_logscale(log_s, priors.scatter_scale)
    return lp, ok


def _loglik_pointwise_unimodal(theta, log_amp, log_per):
    """(n_walkers, n_obs) pointwise log-likelihood; NaN observations contribute 0."""
    log_a, log_t, log_sa, log_st = (theta[:, k : k + 1] for k in range(4))
    with np.errstate(invalid="ignore"):
        la = _norm_logpdf(log_amp[None, :], log_a, np.exp(log_sa))
        lt = _norm_logpdf(log_per[None, :], log_t, np.exp(log_st))
    return np.where(np.isfinite(la), la, 0.0) + np.where(np.isfinite(lt), lt, 0.0)


def _loglik_pointwise_two_period(theta, log_amp, log_per):
    """(n_walkers, n_obs) pointwise log-likelihood; NaN observations contribute 0."""
    log_a, log_t1, log_t2, logit_w, log_sa, log_st = (theta[:, k : k + 1] for k in range(6))
    st = np.exp(log_st)
    log_w = -np.logaddexp(0.0, -logit_w)
    log_1mw = -np.logaddexp(0.0, logit_w)
    with np.errstate(invalid="ignore"):
        la = _norm_logpdf(log_amp[None, :], log_a, np.exp(log_sa))
        lt = np.logaddexp(
            log_w + _norm_logpdf(log_per[None, :], log_t1, st),
            log_1mw + _norm_logpdf(log_per[None, :], log_t2, st),
        )
    return np.where(np.isfinite(la), la, 0.0) + np.where(np.isfinite(lt), lt, 0.0)


@dataclass(frozen=True)
class _MotionData:
    """Sufficient statistics of a bin's IMU observations for the motion log-densities.

    ``n``, ``mean``, ``ss`` (sum of squared deviations) of the finite log amplitudes and
    log periods (the normal likelihood depends on the data only through them), and the
    distinct finite log periods with their counts (the mixture likelihood is a sum over
    distinct values: records at several heights share one IMU record).
    """

    n_amp: int
    mean_amp: float
    ss_amp: float
    n_per: int
    mean_per: float
    ss_per: float
    per_values: np.ndarray
    per_counts: np.ndarray

    @classmethod
    def from_observations(cls, log_amp, log_per):
        la = np.asarray(log_amp, dtype=float)
        lt = np.asarray(log_per, dtype=float)
        la, lt = la[np.isfinite(la)], lt[np.isfinite(lt)]
        ma = float(la.mean()) if la.size else 0.0
        mt = float(lt.mean()) if lt.size else 0.0
        values, counts = np.unique(lt, return_counts=True)
        return cls(
            la.size,
            ma,
            float(np.sum((la - ma) ** 2)),
            lt.size,
            mt,
            float(np.sum((lt - mt) ** 2)),
            values,
            counts.astype(float),
        )


def _normal_loglik(n, mean, ss, mu, log_sd):
    """Sum of N(mu, exp(log_sd)) log densities of n values with this mean and ss."""
    return -0.5 * (ss + n * (mean - mu) ** 2) * np.exp(-2.0 * log_sd) - n * (log_sd + 0.5 * _LOG2PI)


def _log_prob_unimodal(theta, data, priors):
    """:func:`log_prob_unimodal` on :class:`_MotionData` (the sampler's target)."""
    theta = np.atleast_2d(np.asarray(theta, dtype=float))
    with np.errstate(all="ignore"):
        lp, ok = _log_prior_motion(theta[:, 0], [theta[:, 1]], theta[:, 2], theta[:, 3], priors)
        out = (
            lp
            + _normal_loglik(data.n_amp, data.mean_amp, data.ss_amp, theta[:, 0], theta[:, 2])
            + _normal_loglik(data.n_per, data.mean_per, data.ss_per, theta[:, 1], theta[:, 3])
        )
    return np.where(ok & np.isfinite(out), out, -np.inf)


def log_prob_unimodal(theta, log_amp, log_per, priors=Priors()):
    """Log posterior of the unimodal per-bin motion model, vectorised over walkers.

    Parameters
    ----------
    theta : array_like, shape (n_walkers, 4) or (4,)
        ``(log A_deg, log T_s, log s_a, log s_T)``.
    log_amp, log_per : numpy.ndarray, shape (n_obs,)
        Log of the records' IMU amplitude (deg) and period (s); NaN = missing.
    priors : Priors

    Returns
    -------
    numpy.ndarray, shape (n_walkers,)
        Log posterior up to a constant; ``-inf`` outside the support, never NaN.
    """
    return _log_prob_unimodal(theta, _MotionData.from_observations(log_amp, log_per), priors)


def _log_prob_two_period(theta, data, priors):
    """:func:`log_prob_two_period` on :class:`_MotionData` (the sampler's target)."""
    theta = np.atleast_2d(np.asarray(theta, dtype=float))
    with np.errstate(all="ignore"):
        lp, ok = _log_prior_motion(
            theta[:, 0], [theta[:, 1], theta[:, 2]], theta[:, 4], theta[:, 5], priors
        )
        ok &= (theta[:, 1] < theta[:, 2]) & (np.abs(theta[:, 3]) < 12.0)
        log_w = -np.logaddexp(0.0, -theta[:, 3])
        log_1mw = -np.logaddexp(0.0, theta[:, 3])
        # Beta(b, b) on w plus the logit Jacobian w (1 - w); log 2: two orderings
        lp = lp + priors.weight_beta * (log_w + log_1mw) + np.log(2.0)
        ll_a = _normal_loglik(data.n_amp, data.mean_amp, data.ss_amp, theta[:, 0], theta[:, 4])
        inv_sd = np.exp(-theta[:, 5:6])
        x = data.per_values[None, :]
        mix = np.logaddexp(
            log_w[:, None] - 0.5 * ((x - theta[:, 1:2]) * inv_sd) ** 2,
            log_1mw[:, None] - 0.5 * ((x - theta[:, 2:3]) * inv_sd) ** 2,
        )
        ll_t = mix @ data.per_counts - data.n_per * (theta[:, 5] + 0.5 * _LOG2PI)
        out = lp + ll_a + ll_t
    return np.where(ok & np.isfinite(out), out, -np.inf)


def log_prob_two_period(theta, log_amp, log_per, priors=Priors()):
    """Log posterior of the two-period per-bin model, vectorised over walkers.

    Parameters
    ----------
    theta : array_like, shape (n_walkers, 6) or (6,)
        ``(log A_deg, log T1_s, log T2_s, logit w, log s_a, log s_T)``, ``T1 < T2``.
    log_amp, log_per : numpy.ndarray, shape (n_obs,)
    priors : Priors

    Returns
    -------
    numpy.ndarray, shape (n_walkers,)
        ``-inf`` outside the support (incl. ``T1 >= T2``), never NaN.
    """
    return _log_prob_two_period(theta, _MotionData.from_observations(log_amp, log_per), priors)


def _global_loglik_pointwise(theta, s, r, sz_med, sz_var, u2=None):
    """(n_walkers, n_obs) pointwise log-likelihood of the observation model.

    ``s_i ~ N(mu_i, tau_i)``, ``mu_i^2 = r_i^2 + sZ_i^2 + 2 rho r_i sZ_i`` (Eq. (15) of seed
    000), ``tau_i^2 = kappa^2 mu_i^2 + tau0^2 + (dmu_i/dsZ_i)^2 Var(sZ_i)`` with
    ``dmu/dsZ = (sZ + rho r) / mu``. With a 4th column (lever arm ``L``) and ``u2``:
    ``sZ^2 = sZ_rot^2 + L^2 u^2`` and ``Var(sZ)`` scaled by ``(sZ_rot / sZ)^2``; with a 5th
    column ``log k`` the surrogate's rotational sigma_Z is scaled first, ``sZ_rot = k sZ``.
    Written with in-place operations: this is the global fit's inner loop.
    """
    rho = theta[:, 0:1]
    tau0_sq = np.exp(2.0 * theta[:, 1:2])
    kappa_sq = np.exp(2.0 * theta[:, 2:3])
    if u2 is not None and theta.shape[1] >= 4:
        sz_rot_sq = sz_med**2
        if theta.shape[1] == 5:  # motion-model scale of the surrogate
            k_sq = np.exp(2.0 * theta[:, 4:5])
            sz_rot_sq = k_sq * sz_rot_sq
            sz_var = k_sq * sz_var
        sz_sq = sz_rot_sq + theta[:, 3:4] ** 2 * u2  # translation of the head
        sz = np.sqrt(sz_sq)
        sz_var = sz_var * sz_rot_sq / np.maximum(sz_sq, 1e-24)
        var = rho * r * sz
        var *= 2.0
        var += sz_sq
        var += r**2
    else:
        sz = sz_med
        var = rho * (2.0 * r * sz)
        var += r**2 + sz**2
    np.maximum(var, 1e-12, out=var)  # mu^2, Eq. (15) of seed 000
    tau_sq = rho * r
    tau_sq += sz
    tau_sq *= tau_sq
    tau_sq *= sz_var
    tau_sq /= var  # (dmu/dsZ)^2 Var(sZ)
    tau_sq += kappa_sq * var
    tau_sq += tau0_sq
    z = np.sqrt(var)
    np.subtract(s, z, out=z)
    z *= z
    z /= tau_sq
    z += np.log(tau_sq)
    z += _LOG2PI
    z *= -0.5
    return z


def log_prob_global(theta, s, r, sz_med, sz_var, priors=Priors(), u2=None):
    """Log posterior of the global observation model, vectorised over walkers.

    Parameters
    ----------
    theta : array_like, shape (n_walkers, 3, 4 or 5)
        ``(rho, log tau0_ms, log kappa[, lever_arm_m[, log motion_scale]])``; the 4th and 5th
        columns only with ``u2``.
    s, r : numpy.ndarray, shape (n_obs,)
        Floating-lidar and reference 10-min HWS std (m/s).
    sz_med, sz_var : numpy.ndarray, shape (n_obs,)
        Posterior median (m/s) and variance (m^2/s^2) of each record's sigma_Z.
    priors : Priors
    u2 : numpy.ndarray, shape (n_obs,), optional
        Squared translational error per metre of lever arm ((m/s)^2 / m^2), see
        :func:`translation_unit_sq`; enables the lever-arm model.

    Returns
    -------
    numpy.ndarray, shape (n_walkers,)
        ``-inf`` outside ``|rho| < 1`` and the scale bounds; never NaN.
    """
    theta = np.atleast_2d(np.asarray(theta, dtype=float))
    if theta.shape[1] >= 4 and u2 is None:
        raise ValueError("log_prob_global: a 4- or 5-column theta (lever arm) needs u2")
    with np.errstate(all="ignore"):
        ok = (np.abs(theta[:, 0]) < 1.0) & _in(
            theta[:, 1], np.log(priors.tau0_min_ms), np.log(10.0)
        )
        ok &= _in(theta[:, 2], np.log(priors.kappa_min), np.log(2.0))
        lp = _log_halfnormal_logscale(theta[:, 1], priors.tau0_scale_ms)
        lp = lp + _log_halfnormal_logscale(theta[:, 2], priors.kappa_scale)
        if theta.shape[1] >= 4:
            ok &= (theta[:, 3] >= 0.0) & (theta[:, 3] < priors.lever_arm_max_m)
            lp = lp + _norm_logpdf(theta[:, 3], 0.0, priors.lever_arm_scale_m)
        if theta.shape[1] == 5:
            ok &= np.abs(theta[:, 4]) < np.log(5.0)
            lp = lp + _norm_logpdf(theta[:, 4], 0.0, priors.motion_scale_log_sd)
        out = np.full(theta.shape[0], -np.inf)
        if np.any(ok):  # the likelihood only where the prior is positive
            ll = _global_loglik_pointwise(theta[ok], s, r, sz_med, sz_var, u2).sum(axis=1)
            out[ok] = lp[ok] + ll
    return np.where(np.isfinite(out), out, -np.inf)


def translation_unit_sq(amplitude_deg, period_s, scan_period_s=1.0):
    """Squared HWS error per metre of lever arm from the head's translation, (m/s)^2 / m^2.

    Roll and pitch ``A sin(2 pi t / T + phi)`` about a centre ``L`` below the head move it
    horizontally at ``L A (2 pi / T) cos(...)`` per axis; with independent phases the
    component along the wind has variance ``(L A 2 pi / T)^2 / 2``. The VAD fit over one
    scan of ``scan_period_s`` averages it by ``sinc(scan / T)``. Checked against
    design.md: 3 deg, 4 s, 4 m gives 0.21 m/s (design.md: sqrt(0.28^2 - 0.18^2) = 0.21).

    Parameters
    ----------
    amplitude_deg, period_s : array_like
        Motion amplitude (deg) and period (s), broadcastable.
    scan_period_s : float
        Duration of one VAD scan (s).

    Returns
    -------
    numpy.ndarray
        ``u^2`` such that ``sigma_Z,trans = L u``.
    """
    a = np.deg2rad(np.asarray(amplitude_deg, dtype=float))
    t = np.asarray(period_s, dtype=float)
    return 0.5 * (a * 2.0 * np.pi / t * np.sinc(scan_period_s / t)) ** 2


# ----------------------------------------------------------------------------- data
def imu_observations(records: pd.DataFrame) -> tuple[np.ndarray, np.ndarray]:
    """Per-record log amplitude and log period from the IMU statistics.

    The record's motion amplitude (period) is the geometric mean of the roll and pitch
    amplitudes (periods); a missing axis falls back to the other; NaN if both missing.

    Parameters
    ----------
    records : pandas.DataFrame
        Core record columns ``roll_amplitude_deg``, ``pitch_amplitude_deg``,
        ``roll_period_s``, ``pitch_period_s`` (missing columns count as NaN).

    Returns
    -------
    log_amp, log_per : numpy.ndarray, shape (n_records,)
        Natural logs of deg and s; NaN where unavailable or non-positive.
    """

    def col(name):
        if name in records:
            x = records[name].to_numpy(dtype=float)
        else:
            x = np.full(len(records), np.nan)
        return np.log(np.where(x > 0, x, np.nan))

    out = []
    for a, b in (
        ("roll_amplitude_deg", "pitch_amplitude_deg"),
        ("roll_period_s", "pitch_period_s"),
    ):
        x = np.stack([col(a), col(b)])
        with np.errstate(all="ignore"):
            n = np.sum(np.isfinite(x), axis=0)
            m = np.where(
                n > 0,
                np.nansum(np.where(np.isfinite(x), x, 0.0), axis=0) / np.maximum(n, 1),
                np.nan,
            )
        out.append(m)
    return out[0], out[1]


# ----------------------------------------------------------------------------- sampling core
def _as_seedsequence(seed) -> np.random.SeedSequence:
    if isinstance(seed, np.random.SeedSequence):
        return seed
    if seed is None:
        raise ValueError("seed is required (int or numpy.random.SeedSequence from config)")
    return np.random.SeedSequence(seed)


class _BlockRedBlueMove(emcee.moves.Move):
    """A red-blue ensemble move applied within each of ``nblocks`` stacked ensembles.

    The sampler's walkers are ``nblocks`` independent ensembles of equal size, stored one
    after the other. Each block is split at random into the wrapped move's ``nsplits``
    sub-ensembles, and a walker's proposal uses only walkers of its own block (as
    :class:`emcee.moves.RedBlueMove` does within one ensemble), so the blocks stay
    independent Markov chains while one vectorised log-probability call serves all.
    """

    def __init__(self, move, nblocks):
        self.move = move
        self.nblocks = int(nblocks)

    def propose(self, model, state):
        nwalk, _ = state.coords.shape
        nb = self.nblocks
        w = nwalk // nb
        k = self.move.nsplits
        self.move.setup(state.coords[:w])
        # a random split of every block; index arrays (nb, group size) per sub-ensemble
        perm = np.argsort(model.random.rand(nb, w), axis=1) + (w * np.arange(nb))[:, None]
        groups = [perm[:, j::k] for j in range(k)]
        accepted = np.zeros(nwalk, dtype=bool)
        for j in range(k):
            rest = np.concatenate([groups[i] for i in range(k) if i != j], axis=1)
            if isinstance(self.move, emcee.moves.DEMove):
                q, f = self._de_proposal(state.coords, groups[j], rest, model.random)
            else:
                props = [
                    self.move.get_proposal(
                        state.coords[groups[j][b]],
                        [state.coords[groups[i][b]] for i in range(k) if i != j],
                        model.random,
                    )
                    for b in range(nb)
                ]
                q = np.concatenate([p[0] for p in props])
                f = np.concatenate([p[1] for p in props])
            idx = groups[j].ravel()
            new_lp, _ = model.compute_log_prob_fn(q)
            acc = f + new_lp - state.log_prob[idx] > np.log(model.random.rand(idx.size))
            state.coords[idx[acc]] = q[acc]
            state.log_prob[idx[acc]] = new_lp[acc]
            accepted[idx[acc]] = True
        return state, accepted

    def _de_proposal(self, coords, sub, rest, random):
        """:class:`emcee.moves.DEMove`'s proposal for all blocks at once.

        Walker ``sub[b, i]`` moves along the difference of two distinct walkers drawn
        from its own block's complementary set ``rest[b]``, scaled by
        ``gamma0 (1 + sigma N(0, 1))`` (Nelson et al. 2013, as emcee).
        """
        nb, ns = sub.shape
        nc = rest.shape[1]
        i = random.randint(nc, size=(nb, ns))
        j = (i + random.randint(1, nc, size=(nb, ns))) % nc  # uniform over ordered pairs
        rows = np.arange(nb)[:, None]
        diffs = coords[rest[rows, j]] - coords[rest[rows, i]]
        gamma = self.move.g0 * (1.0 + self.move.sigma * random.randn(nb, ns, 1))
        q = (coords[sub] + gamma * diffs).reshape(nb * ns, -1)
        return q, np.zeros(nb * ns)


class StudentTIndependenceProposal:
    """Independence proposal for :class:`emcee.moves.MHMove`: multivariate Student-t.

    One Student-t per ensemble block (the sampler's walkers are ``nblocks`` stacked
    ensembles of equal size, see :class:`_BlockRedBlueMove`), fitted to that block's
    burn-in (mean, covariance), so the blocks stay independent. Heavy tails (``df``) keep
    the importance ratio bounded. Module-level and picklable.

    Parameters
    ----------
    mean : numpy.ndarray, shape (nblocks, ndim)
    cov : numpy.ndarray, shape (nblocks, ndim, ndim)
        Scale matrices (the t covariance is ``cov * df / (df - 2)``).
    df : float
    """

    def __init__(self, mean, cov, df=5.0):
        self.mean = np.atleast_2d(np.asarray(mean, dtype=float))
        ndim = self.mean.shape[1]
        cov = np.asarray(cov, dtype=float).reshape(-1, ndim, ndim) + 1e-10 * np.eye(ndim)
        self.chol = np.linalg.cholesky(cov)
        self.inv_chol_t = np.swapaxes(np.linalg.inv(self.chol), 1, 2)
        self.df = float(df)

    def _blocks(self, x):
        return np.asarray(x).reshape(self.mean.shape[0], -1, self.mean.shape[1])

    def log_q(self, x):
        """Log proposal density up to a constant, shape (n,)."""
        z = (self._blocks(x) - self.mean[:, None, :]) @ self.inv_chol_t  # (nblocks, w, ndim)
        q = np.sum(z**2, axis=2).ravel()
        return -0.5 * (self.df + self.mean.shape[1]) * np.log1p(q / self.df)

    def __call__(self, coords, random):
        nb, ndim = self.mean.shape
        w = coords.shape[0] // nb
        z = random.standard_normal((nb, w, ndim)) @ np.swapaxes(self.chol, 1, 2)
        g = random.chisquare(self.df, (nb, w)) / self.df
        x = (self.mean[:, None, :] + z / np.sqrt(g)[..., None]).reshape(coords.shape)
        return x, self.log_q(coords) - self.log_q(x)


def _fit_proposal(sampler, nens, start_frac):
    """Student-t proposal per ensemble block from a burn-in phase's samples.

    Uses the steps from ``start_frac`` of the phase on, and only samples inside the 99.9 %
    highest-density region of a normal approximation (log-prob within
    ``chi2_ndim(0.999) / 2`` of the block's best), so that a few walkers still far from the
    bulk do not inflate the proposal; the independence move then pulls them in.
    """
    chain, lp = sampler.get_chain(), sampler.get_log_prob()
    start = int(start_frac * chain.shape[0])
    ndim = chain.shape[-1]
    x = np.moveaxis(chain[start:].reshape(-1, nens, chain.shape[1] // nens, ndim), 1, 0)
    x = x.reshape(nens, -1, ndim)
    lp = np.moveaxis(lp[start:].reshape(-1, nens, chain.shape[1] // nens), 1, 0).reshape(nens, -1)
    mean = np.empty((nens, ndim))
    cov = np.empty((nens, ndim, ndim))
    cut = 0.5 * stats.chi2.ppf(0.999, ndim)
    for b in range(nens):
        keep = lp[b] >= np.max(lp[b]) - cut
        if keep.sum() < 4 * ndim:  # too few: the better half
            keep = lp[b] >= np.median(lp[b])
        mean[b] = x[b, keep].mean(axis=0)
        cov[b] = np.cov(x[b, keep], rowvar=False)
    return StudentTIndependenceProposal(mean, cov * _PROPOSAL_SCALE**2)


def _independence_acceptance(prop, state, log_prob, args, nens, seedseq, nrep=4):
    """Expected acceptance rate of the independence move at stationarity, worst ensemble.

    ``E[min(1, w(y) / w(x))]`` with ``w = p / q``, ``x`` the current (burnt-in) walkers
    and ``y`` fresh proposals (``nrep`` per walker; Tierney 1994).
    """
    random = np.random.RandomState(seedseq.generate_state(4, np.uint32))
    lw_x = state.log_prob - prop.log_q(state.coords)
    acc = []
    for _ in range(nrep):
        y, _ = prop(state.coords, random)
        with np.errstate(all="ignore"):
            d = log_prob(y, *args) - prop.log_q(y) - lw_x
        acc.append(np.exp(np.minimum(np.where(np.isnan(d), -np.inf, d), 0.0)))
    return float(np.min(np.mean(acc, axis=0).reshape(nens, -1).mean(axis=1)))


def _sampler(log_prob, args, ndim, nwalk, moves, random_state):
    sm = emcee.EnsembleSampler(nwalk, ndim, log_prob, args=args, moves=moves, vectorize=True)
    sm.random_state = random_state
    return sm


def _run_ensembles(log_prob, args, init_fn, ndim, settings, seedseq):
    """Run ``settings.nensembles`` independent ensembles as blocks of one emcee sampler.

    Each ensemble's initial positions come from its own child of ``seedseq`` (``init_fn``:
    overdispersed relative to the posterior); its moves use only its own walkers
    (:class:`_BlockRedBlueMove`, a per-block Student-t), so the ensembles are independent
    chains. Burn-in, first half: DE + DE-snooker moves; second half: the main kernel with
    a Student-t fitted to the first half (it pulls stragglers into the bulk). Main phase (a
    fixed kernel): DE + the independence Student-t Metropolis move refitted to the second
    half, its weight ``independence_weight`` scaled down when the Student-t fits the
    posterior poorly (:func:`_independence_acceptance` below
    ``_INDEPENDENCE_FULL_ACCEPTANCE``; all adaptation ends with the burn-in). The main phase is extended (all ensembles equally) while it is shorter than
    ``1.1 n_autocorr`` autocorrelation times, up to ``max_step_factor * nsteps``.
    Returns chains of shape (nensembles, nsteps', nwalkers, ndim).
    """
    nens, nw = settings.nensembles, settings.nwalkers
    *children, ss_mcmc, ss_check = seedseq.spawn(nens + 2)
    p0 = np.concatenate([init_fn(np.random.default_rng(c), nw) for c in children])
    random_state = np.random.RandomState(ss_mcmc.generate_state(4, np.uint32)).get_state()
    burn_moves = [
        (_BlockRedBlueMove(emcee.moves.DEMove(), nens), 1.0 - settings.snooker_weight),
        (_BlockRedBlueMove(emcee.moves.DESnookerMove(), nens), settings.snooker_weight),
    ]
    burn = _sampler(log_prob, args, ndim, nens * nw, burn_moves, random_state)
    nburn = max(settings.nburn, 4)
    state = burn.run_mcmc(p0, nburn // 2, progress=False)
    random_state = burn.random_state

    def main_moves(prop, weight):
        moves = [(_BlockRedBlueMove(emcee.moves.DEMove(), nens), 1.0 - weight)]
        if weight > 0:
            moves.append((emcee.moves.MHMove(prop), weight))
        return moves

    # second half of the burn-in with the main kernel fitted to the first half: its
    # independence move pulls stragglers into the bulk, so the final fit sees the bulk only
    # (a collapsed ensemble is left to fail the diagnostics rather than raise here)
    w_ind = settings.independence_weight
    prop = _fit_proposal(burn, nens, _FIT_FRAC) if w_ind > 0 else None
    burn2 = _sampler(log_prob, args, ndim, nens * nw, main_moves(prop, w_ind), random_state)
    state = burn2.run_mcmc(state, nburn - nburn // 2, skip_initial_state_check=True)
    if w_ind > 0:
        prop = _fit_proposal(burn2, nens, 0.0)
        # the independence move's share follows how well the fitted Student-t matches the
        # posterior (its expected acceptance rate, worst ensemble): a non-Gaussian posterior
        # (a boundary, a banana) is left mostly to DE
        acc = _independence_acceptance(prop, state, log_prob, args, nens, ss_check)
        w_ind *= min(1.0, acc / _INDEPENDENCE_FULL_ACCEPTANCE)
    main = _sampler(log_prob, args, ndim, nens * nw, main_moves(prop, w_ind), burn2.random_state)
    main.run_mcmc(state, settings.nsteps, skip_initial_state_check=True)

    def chains():
        return np.moveaxis(main.get_chain().reshape(-1, nens, nw, ndim), 1, 0)

    # adaptive length (emcee practice): extend ALL ensembles equally until the chains are
    # longer than n_autocorr (+10 %) autocorrelation times, up to max_step_factor * nsteps
    nsteps = settings.nsteps
    while nsteps < settings.max_step_factor * settings.nsteps:
        tau = _max_autocorr_time(chains())
        need = int(np.ceil(1.1 * settings.n_autocorr * tau)) if np.isfinite(tau) else 2 * nsteps
        if nsteps >= need:
            break
        extra = min(need, int(settings.max_step_factor * settings.nsteps)) - nsteps
        main.run_mcmc(None, extra, skip_initial_state_check=True)
        nsteps += extra
    return chains()


def _autocorr_times(chains):
    """Integrated autocorrelation time per ensemble and parameter, shape (nens, ndim)."""
    with np.errstate(all="ignore"):  # a stuck (constant) chain gives NaN: a failure
        return np.array([emcee.autocorr.integrated_time(c, tol=0, quiet=True) for c in chains])


def _max_autocorr_time(chains):
    tau = _autocorr_times(chains)
    return float(np.max(tau)) if np.all(np.isfinite(tau)) else float("nan")


def _diagnostics(chains, names, settings):
    """Rank R-hat across ensembles (walkers pooled), bulk/tail ESS, autocorrelation times."""
    nens, nsteps, nwalk, ndim = chains.shape
    # each ensemble's walkers pooled into ONE chain, walker-major (walker 0's trace, then 1...)
    pooled = np.transpose(chains, (3, 0, 2, 1)).reshape(ndim, nens, nwalk * nsteps)
    rhat = array_stats.rhat(pooled, chain_axis=-2, draw_axis=-1, method="rank")
    ess_b = array_stats.ess(pooled, chain_axis=-2, draw_axis=-1, method="bulk")
    # tail ESS: the smaller ESS of the 5 % and 95 % quantiles (Vehtari et al. 2021)
    ess_t = array_stats.ess(pooled, chain_axis=-2, draw_axis=-1, method="tail", prob=(0.05, 0.95))
    taus = _autocorr_times(chains)
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


def _logsumexp_rows(x):
    """log(sum(exp(x), axis=1)) of a 2-D array, stable; shape (n_rows,).

    (scipy.special.logsumexp does the same with array-API overhead that dominates
    PSIS-LOO on ~20,000 observations.)
    """
    m = np.max(x, axis=1)
    m = np.where(np.isfinite(m), m, 0.0)
    with np.errstate(divide="ignore"):
        return np.log(np.sum(np.exp(x - m[:, None]), axis=1)) + m


def _psis_loo(log_lik):
    """PSIS-LOO (Vehtari et al. 2017, 2024) vectorised over observations.

    The algorithm of ``arviz_stats`` (``array_stats.loo`` with ``r_eff = 1``: right-tail
    generalised Pareto fit of the largest ``3 sqrt(S)`` importance ratios, Zhang-Stephens
    empirical Bayes estimate with the weak prior on k, smoothing, truncation), computed
    for all observations at once instead of one Python call per observation; the test
    suite checks it against ``arviz_stats`` to rounding error.

    Parameters
    ----------
    log_lik : numpy.ndarray, shape (n_samples, n_obs)

    Returns
    -------
    elpd_i, pareto_k, p_loo_i : numpy.ndarray, shape (n_obs,)

    Raises
    ------
    ValueError
        If an observation's tail ratios are all equal (as ``arviz_stats``).
    """
    n_s, n_obs = log_lik.shape
    n_tail = int(np.floor(3 * np.sqrt(n_s)) if n_s > 225 else np.floor(n_s / 5))
    # log importance ratios -log_lik, one observation per row, sorted (the LOO sums are
    # permutation invariant, so everything is computed in sorted order); lw <= 0
    lw_sorted = np.sort(-log_lik.T, axis=1)
    shift = lw_sorted[:, -1].copy()  # max(-log_lik) per observation
    lw_sorted -= shift[:, None]
    tail_log = lw_sorted[:, n_s - n_tail :]  # (n_obs, n_tail), ascending
    if np.any(np.abs(tail_log[:, -1] - tail_log[:, 0]) < np.finfo(float).tiny):
        raise ValueError("PSIS: all tail values are the same")
    cutoff = np.exp(lw_sorted[:, n_s - n_tail - 1 : n_s - n_tail])  # (n_obs, 1)
    x = np.exp(tail_log) - cutoff  # sorted exceedances
    # generalised Pareto fit (Zhang & Stephens 2009; prior on k as in Vehtari et al. 2024)
    m_est = 30 + int(n_tail**0.5)
    xstar = x[:, int((n_tail / 4 + 0.5) - 1)]
    with np.errstate(all="ignore"):
        b = (1 - np.sqrt(m_est / (np.arange(1, m_est + 1) - 0.5)))[None, :] / (3 * xstar[:, None])
        b += 1 / x[:, -1:]  # (n_obs, m_est)
        k_b = np.empty_like(b)
        for c in range(0, n_obs, 1024):  # (chunk, m_est, n_tail) at a time
            sl = slice(c, c + 1024)
            k_b[sl] = np.log1p(-b[sl, :, None] * x[sl, None, :]).mean(axis=2)
        len_scale = n_tail * (np.log(-b / k_b) - k_b - 1)
        w = np.exp(len_scale - _logsumexp_rows(len_scale)[:, None])
        keep = w >= 10 * np.finfo(float).eps  # negligible weights removed (as arviz_stats)
        w = np.where(keep, w, 0.0)
        b_post = np.sum(np.where(keep, b * w, 0.0), axis=1) / w.sum(axis=1)
        k = np.mean(np.log1p(-b_post[:, None] * x), axis=1)
        sigma = -k / b_post
        k = (n_tail * k + 10 * 0.5) / (n_tail + 10)
        k = np.where(np.isnan(k), np.inf, k)
        no_fit = xstar <= x[:, 0]  # far from a generalised Pareto: no smoothing, k NaN
        k = np.where(no_fit, np.nan, k)
        sigma = np.where(no_fit, np.nan, sigma)[:, None]
        kk = np.where(k == 0, 1.0, k)[:, None]
        p = (np.arange(n_tail) + 0.5) / n_tail
        q = np.where(
            (k == 0)[:, None],
            cutoff - sigma * np.log1p(-p),
            cutoff + sigma * np.expm1(-kk * np.log1p(-p)) / kk,
        )
        q = np.log(np.where(sigma <= 0, np.nan, q))
        q = np.minimum(q, tail_log[:, -1:])  # truncation at the largest raw ratio
        smooth = np.isfinite(k)[:, None]
        tail_new = np.where(smooth, q, tail_log)
        # normalised smoothed log weights lw - lse; on the body lw + log_lik = -shift
        body = n_s - n_tail
        lse = np.log(np.sum(np.exp(lw_sorted[:, :body]), axis=1) + np.sum(np.exp(tail_new), axis=1))
        elpd_i = (
            np.log(body + np.sum(np.exp(tail_new - tail_log), axis=1)) - lse - shift
        )  # log sum_s w_s p(y_i | theta_s)
    lppd_i = _logsumexp_rows(-lw_sorted) - shift - np.log(n_s)
    return elpd_i, k, lppd_i - elpd_i


def _loo(log_lik):
    """PSIS-LOO from a (chain, draw, obs) pointwise log-likelihood; returns dict or None.

    ``r_eff = 1`` (the stored draws are thinned, nearly independent). None if PSIS fails
    (e.g. a degenerate, constant log-likelihood) or gives a non-finite elpd.
    """
    n = log_lik.shape[-1]
    if n == 0:
        return None
    try:
        elpd_i, pareto_k, p_loo_i = _psis_loo(log_lik.reshape(-1, n))
    except ValueError:
        return None
    if not np.all(np.isfinite(elpd_i)):
        return None
    return {
        "elpd": float(elpd_i.sum()),
        "se": float(np.sqrt(n * np.var(elpd_i, ddof=1))) if n > 1 else 0.0,
        "p_loo": float(np.sum(p_loo_i)),
        "elpd_i": elpd_i,
        "pareto_k": pareto_k,
    }


def _loo_compare(a, b):
    """elpd(a) - elpd(b) with the pointwise standard error of the difference."""
    d = a["elpd_i"] - b["elpd_i"]
    return float(d.sum()), float(np.sqrt(d.size * np.var(d))) if d.size > 1 else float("nan")


def period_kurtosis_ppc(log_per, draws, *, rng, nrep=400) -> float:
    """Posterior predictive p-value of the log-periods' kurtosis under the unimodal model.

    Two well separated periods give a platykurtic (kurtosis < 3) sample; the p-value is
    ``P(k_rep <= k_obs)`` over replicated data sets drawn from the unimodal posterior.

    Parameters
    ----------
    log_per : numpy.ndarray, shape (n_obs,)
        Log IMU periods (NaN ignored).
    draws : dict
        Unimodal posterior draws ``period_s`` and ``scatter_period``.
    rng : numpy.random.Generator
    nrep : int

    Returns
    -------
    float
        p-value in [0, 1]; NaN with fewer than 4 periods.
    """
    x = log_per[np.isfinite(log_per)]
    if x.size < 4:
        return float("nan")

    def kurt(y):
        d = y - y.mean(axis=-1, keepdims=True)
        return np.mean(d**4, axis=-1) / np.maximum(np.mean(d**2, axis=-1) ** 2, 1e-300)

    t = np.log(np.asarray(draws["period_s"]).ravel())
    sd = np.asarray(draws["scatter_period"]).ravel()
    idx = rng.choice(t.size, size=nrep)
    rep = t[idx, None] + sd[idx, None] * rng.standard_normal((nrep, x.size))
    return float(np.mean(kurt(rep) <= kurt(x)))


# ----------------------------------------------------------------------------- fit results
def _jsonable(x):
    if isinstance(x, dict):
        return {k: _jsonable(v) for k, v in x.items()}
    if isinstance(x, list | tuple):
        return [_jsonable(v) for v in x]
    if isinstance(x, np.ndarray):
        return x.tolist()
    if isinstance(x, np.floating | np.integer | np.bool_):
        return x.item()
    return x


@dataclass
class _FitBase:
    kind = "base"
    draws: dict  # name -> (nensembles, ndraws)
    log_lik: np.ndarray  # (nensembles, ndraws, n_obs)
    diagnostics: dict
    failure_reasons: list
    info: dict = field(default_factory=dict)

    @property
    def converged(self) -> bool:
        """True only if every convergence criterion of design.md is met."""
        return len(self.failure_reasons) == 0

    def flat(self, name: str) -> np.ndarray:
        """All stored draws of one parameter, shape (nensembles * ndraws,)."""
        return np.asarray(self.draws[name]).reshape(-1)

    def _summary_rows(self, extra):
        rows = []
        for n, d in self.draws.items():
            x = np.asarray(d).ravel()
            q = np.quantile(x, [0.05, 0.5, 0.95])
            rows.append(
                {
                    **extra,
                    "param": n,
                    "mean": float(np.mean(x)),
                    "sd": float(np.std(x)),
                    "q05": q[0],
                    "median": q[1],
                    "q95": q[2],
                    **{k: v for k, v in self.diagnostics.get(n, {}).items()},
                    "converged": self.converged,
                    "failure_reasons": "; ".join(self.failure_reasons),
                }
            )
        return pd.DataFrame(rows)

    def to_datatree(self):
        """ArviZ 1.x DataTree: posterior, log_likelihood, constant_data; diagnostics in attrs."""
        post = {n: np.asarray(v) for n, v in self.draws.items()}
        dt = az.from_dict(
            {
                "posterior": post,
                "log_likelihood": {"obs": self.log_lik},
                "constant_data": {
                    k: np.asarray(v) for k, v in self.info.get("constant", {}).items()
                },
            }
        )
        dt.attrs["flidar_uq_kind"] = self.kind
        dt.attrs["converged"] = int(self.converged)
        dt.attrs["failure_reasons"] = json.dumps(self.failure_reasons)
        dt.attrs["diagnostics"] = json.dumps(_jsonable(self.diagnostics))
        meta = {k: v for k, v in self.info.items() if k != "constant"}
        dt.attrs["info"] = json.dumps(_jsonable(meta))
        return dt

    def to_netcdf(self, path) -> None:
        """Write :meth:`to_datatree` to NetCDF (h5netcdf engine)."""
        self.to_datatree().to_netcdf(path, engine="h5netcdf")


@dataclass
class BinFit(_FitBase):
    """Posterior of one bin's motion parameters (stage 1).

    Attributes
    ----------
    draws : dict
        ``amplitude_deg``, ``period_s`` (``period1_s``, ``period2_s``, ``weight1`` for the
        two-period model), ``scatter_amplitude``, ``scatter_period``; each (nensembles, ndraws).
    info : dict
        ``bin_id``, ``model`` ("unimodal"/"two_period"), ``n_records``, ``n_imu``,
        ``prior_only`` (no IMU statistics: posterior = prior), ``loo`` (elpd, se, p_loo,
        max Pareto k of each model, elpd difference two_period - unimodal and its se),
        ``constant`` (record_index, hws_mean_ms).
    """

    kind = "bin"

    @property
    def bin_id(self):
        return self.info["bin_id"]

    @property
    def model(self) -> str:
        return self.info["model"]

    def sigma_z_draws(
        self, hws_ms, surrogate=None, *, ndraws=None, rng=None, lever_arm_m=None, scan_period_s=1.0
    ) -> np.ndarray:
        """Draws of sigma_Z (m/s) for records at mean HWS ``hws_ms``.

        Parameters
        ----------
        hws_ms : array_like, shape (n,)
            Records' mean HWS (m/s).
        surrogate : SigmaZSurrogate, optional
            Default ``get_surrogate()``.
        ndraws : int, optional
            Number of posterior draws (random without replacement if fewer than stored;
            all stored draws by default).
        rng : numpy.random.Generator, optional
            Needed when ``ndraws`` subsamples.
        lever_arm_m : float or array_like, shape (ndraws, 1), optional
            Effective lever arm (m) per draw; adds the head translation,
            ``sZ^2 = sZ_rot^2 + L^2 u^2`` (:func:`translation_unit_sq`).
        scan_period_s : float
            VAD scan duration (s) for the translation term.

        Returns
        -------
        numpy.ndarray, shape (ndraws, n)
        """
        sz, u2 = self._motion_draws(hws_ms, surrogate, self._draw_index(ndraws, rng), scan_period_s)
        if lever_arm_m is None:
            return sz
        return np.sqrt(sz**2 + np.asarray(lever_arm_m, dtype=float) ** 2 * u2)

    def _motion_draws(self, hws_ms, surrogate, idx, scan_period_s=1.0):
        """Rotational sigma_Z draws (ndraws, n) and translation units u^2 (ndraws, 1)."""
        surrogate = _default_surrogate(surrogate)
        hws = np.asarray(hws_ms, dtype=float)[None, :]
        a = self.flat("amplitude_deg")[idx][:, None]
        if self.model == "two_period":
            t1 = self.flat("period1_s")[idx][:, None]
            t2 = self.flat("period2_s")[idx][:, None]
            w = self.flat("weight1")[idx][:, None]
            sz = surrogate.sigma_z_two_period_ms(hws, a, t1, t2, w)
            u2 = w * translation_unit_sq(a, t1, scan_period_s) + (1 - w) * translation_unit_sq(
                a, t2, scan_period_s
            )
        else:
            t = self.flat("period_s")[idx][:, None]
            sz = surrogate.sigma_z_ms(hws, a, t)
            u2 = translation_unit_sq(a, t, scan_period_s)
        return np.asarray(sz, dtype=float), np.asarray(u2, dtype=float)

    def _draw_index(self, ndraws, rng):
        n = self.flat("amplitude_deg").size
        if ndraws is None or ndraws >= n:
            return np.arange(n)
        if rng is None:
            raise ValueError("BinFit.sigma_z_draws: rng is required when ndraws subsamples")
        return rng.choice(n, size=ndraws, replace=False)

    def summary(self) -> pd.DataFrame:
        """One row per parameter: moments, quantiles, R-hat, ESS, tau, convergence, model, LOO."""
        loo = self.info.get("loo", {})
        extra = {
            "bin_id": self.bin_id,
            "model": self.model,
            "n_records": self.info["n_records"],
            "n_imu": self.info["n_imu"],
            "prior_only": self.info["prior_only"],
            "ppc_kurtosis_p": loo.get("ppc_kurtosis_p", np.nan),
            "elpd_diff_two_period": loo.get("elpd_diff", np.nan),
            "elpd_diff_se": loo.get("elpd_diff_se", np.nan),
            "pareto_k_max": loo.get(f"{self.model}_pareto_k_max", np.nan),
        }
        return self._summary_rows(extra)


@dataclass
class GlobalFit(_FitBase):
    """Posterior of the global parameters ``rho``, ``tau0_ms``, ``kappa`` [, ``lever_arm_m``
    [, ``motion_scale``]] (stage 2).

    ``info`` holds ``n_records`` used, ``excluded_bins`` (bins not converged, never used),
    ``prior_only`` (no reference data), ``loo`` (global vs per-bin rho).
    """

    kind = "global"

    def summary(self) -> pd.DataFrame:
        """One row per parameter with diagnostics and the global-vs-per-bin-rho LOO result."""
        loo = self.info.get("loo", {})
        extra = {
            "n_records": self.info["n_records"],
            "prior_only": self.info["prior_only"],
            "excluded_bins": json.dumps(_jsonable(self.info.get("excluded_bins", []))),
            "elpd_diff_per_bin_rho": loo.get("elpd_diff", np.nan),
            "elpd_diff_se": loo.get("elpd_diff_se", np.nan),
            "pareto_k_max": loo.get("global_pareto_k_max", np.nan),
            "preferred_rho_model": loo.get("preferred", "global"),
            "global_model": loo.get("model", "rho_only"),
            "elpd_diff_lever_arm": loo.get("lever_arm_elpd_diff", np.nan),
            "elpd_diff_lever_arm_se": loo.get("lever_arm_elpd_diff_se", np.nan),
            "elpd_diff_motion_scale": loo.get("lever_arm_scale_elpd_diff", np.nan),
            "elpd_diff_motion_scale_se": loo.get("lever_arm_scale_elpd_diff_se", np.nan),
        }
        return self._summary_rows(extra)


def load_fit(path) -> BinFit | GlobalFit:
    """Read a fit written by ``BinFit.to_netcdf`` / ``GlobalFit.to_netcdf``."""
    dt = xr.open_datatree(path, engine="h5netcdf").load()
    kind = dt.attrs["flidar_uq_kind"]
    post = dt["posterior"].to_dataset()
    draws = {n: post[n].values for n in post.data_vars}
    log_lik = dt["log_likelihood"].to_dataset()["obs"].values
    info = json.loads(dt.attrs["info"])
    if "constant_data" in dt.children:
        cd = dt["constant_data"].to_dataset()
        info["constant"] = {n: cd[n].values for n in cd.data_vars}
    cls = {"bin": BinFit, "global": GlobalFit}[kind]
    return cls(
        draws=draws,
        log_lik=log_lik,
        diagnostics=json.loads(dt.attrs["diagnostics"]),
        failure_reasons=json.loads(dt.attrs["failure_reasons"]),
        info=info,
    )


def _default_surrogate(surrogate):
    if surrogate is not None:
        return surrogate
    from flidar_uq.physics.surrogate import get_surrogate

    return get_surrogate()


# ----------------------------------------------------------------------------- stage 1
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


def sample_motion_prior(rng, n, priors, ndim):
    """Draws from the per-bin motion prior, in the sampler's (log / logit) coordinates.

    Parameters
    ----------
    rng : numpy.random.Generator
    n : int
        Number of draws.
    priors : Priors
    ndim : int
        4 (unimodal: log A, log T, log s_a, log s_T) or 6 (two-period: log A, log T1,
        log T2, logit w, log s_a, log s_T with T1 < T2).

    Returns
    -------
    numpy.ndarray, shape (n, ndim)
    """

    def trunc_lognormal(median, sd, lo, hi):
        x = np.exp(rng.normal(np.log(median), sd, size=4 * n + 64))
        x = x[(x > lo) & (x < hi)]
        return x[:n]

    a = trunc_lognormal(
        priors.amplitude_median_deg,
        priors.amplitude_log_sd,
        priors.amplitude_min_deg,
        priors.amplitude_max_deg,
    )
    ts = [
        trunc_lognormal(
            priors.period_median_s, priors.period_log_sd, priors.period_min_s, priors.period_max_s
        )
        for _ in range(2 if ndim == 6 else 1)
    ]
    sc = []
    for _ in range(2):
        x = np.abs(rng.normal(0.0, priors.scatter_scale, size=4 * n + 64))
        sc.append(x[(x > priors.scatter_min) & (x < priors.scatter_max)][:n])
    if ndim == 4:
        return np.column_stack([np.log(a), np.log(ts[0]), np.log(sc[0]), np.log(sc[1])])
    t1, t2 = np.minimum(ts[0], ts[1]), np.maximum(ts[0], ts[1])
    w = rng.beta(priors.weight_beta, priors.weight_beta, size=n)
    return np.column_stack(
        [np.log(a), np.log(t1), np.log(t2), np.log(w / (1 - w)), np.log(sc[0]), np.log(sc[1])]
    )


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
    chains = _run_ensembles(
        fn, (data, priors), _init_fn(log_amp, log_per, priors, ndim), ndim, s, seedseq
    )
    nat = _to_natural(chains, model)
    diag, reasons = _diagnostics(nat, names, s)
    thin = _thin(chains, s.ndraws)
    ok = np.isfinite(log_amp) | np.isfinite(log_per)
    pll = _loglik_pointwise_unimodal if model == "unimodal" else _loglik_pointwise_two_period
    flat = thin.reshape(-1, ndim)
    ll = pll(flat, log_amp[ok], log_per[ok]).reshape(thin.shape[0], thin.shape[1], -1)
    draws = {n: _to_natural(thin, model)[..., k] for k, n in enumerate(names)}
    return draws, ll, diag, reasons


def _distinct_imu_records(records: pd.DataFrame) -> pd.DataFrame:
    """One row per IMU record: the heights of one 10-min record share the buoy's IMU
    statistics, which must count once in the motion likelihood (not once per height)."""
    from flidar_uq.data.imu import MOTION_STAT_COLUMNS

    if "timestamp" not in records:
        return records
    cols = ["timestamp", *(c for c in MOTION_STAT_COLUMNS if c in records)]
    return records.drop_duplicates(subset=cols)


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
    seedseq = _as_seedsequence(seed)
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


# ----------------------------------------------------------------------------- stage 2
_GLOBAL_NAMES = ["rho", "tau0_ms", "kappa"]


def record_sigma_z_moments(
    records, bin_fits, *, surrogate=None, ndraws=200, seed=0, scan_period_s=1.0
):
    """Posterior median and variance of sigma_Z (m/s) for every record, from its bin's fit.

    Returns
    -------
    sz_med, sz_var, u2_med : numpy.ndarray, shape (n_records,)
        Rotational sigma_Z median (m/s) and variance, and the median translation unit
        ``u^2`` (:func:`translation_unit_sq`); NaN for records whose bin has no fit.
    """
    surrogate = _default_surrogate(surrogate)
    fits = {f.bin_id: f for f in bin_fits}
    rng = np.random.default_rng(_as_seedsequence(seed))
    med = np.full(len(records), np.nan)
    var = np.full(len(records), np.nan)
    u2m = np.full(len(records), np.nan)
    bins = records["bin_id"].to_numpy()
    for b, f in fits.items():
        m = bins == b
        if not np.any(m):
            continue
        sz, u2 = f._motion_draws(
            records["hws_mean_ms"].to_numpy(dtype=float)[m],
            surrogate,
            f._draw_index(ndraws, rng),
            scan_period_s,
        )
        med[m] = np.median(sz, axis=0)
        var[m] = np.var(sz, axis=0)
        u2m[m] = np.median(u2)
    return med, var, u2m


def _per_bin_rho_loo(s, r, szm, szv, bins, tau0, kappa, rng, ndraws, priors):
    """Per-bin rho with tau0, kappa fixed at their global medians; exact 1-D grid posterior."""
    grid = np.linspace(-0.9995, 0.9995, 400)
    half = 0.5 * (grid[1] - grid[0])
    ll_all = np.zeros((ndraws, s.size))
    theta = np.column_stack(
        [grid, np.full(grid.size, np.log(tau0)), np.full(grid.size, np.log(kappa))]
    )
    for b in np.unique(bins):
        m = bins == b
        lp = _global_loglik_pointwise(theta, s[m], r[m], szm[m], szv[m]).sum(axis=1)
        p = np.exp(lp - logsumexp(lp))
        idx = rng.choice(grid.size, size=ndraws, p=p)
        rho = grid[idx] + rng.uniform(-half, half, size=ndraws)  # continuous within the cell
        th = np.column_stack([rho, np.full(ndraws, np.log(tau0)), np.full(ndraws, np.log(kappa))])
        ll_all[:, m] = _global_loglik_pointwise(th, s[m], r[m], szm[m], szv[m])
    return ll_all[None, :, :]


def _global_init_fn(s, r, szm, szv, u2, priors, ndim):
    """Overdispersed start of the global fit: a widened Laplace approximation.

    The posterior mode (Nelder-Mead on the log posterior) and the inverse of a
    central-difference Hessian there give a normal approximation; walkers start from it
    with ``_INIT_WIDENING`` times its sd (overdispersed relative to the posterior, so R-hat
    across ensembles stays meaningful, yet close enough for a short burn-in). Walkers
    outside the support, or all of them if the Hessian is not positive definite (e.g. a
    mode on the boundary ``|rho| = 1``), start from broad uniform draws instead.
    """

    def neg_lp(th):
        v = -log_prob_global(th[None, :], s, r, szm, szv, priors, u2)[0]
        return v if np.isfinite(v) else 1e300

    x0 = np.array([0.0, np.log(0.05), np.log(0.1), 2.0, 0.0][:ndim])
    mode = optimize.minimize(
        neg_lp, x0, method="Nelder-Mead", options={"xatol": 1e-5, "fatol": 1e-6, "maxiter": 4000}
    ).x
    h = 1e-4
    hess = np.empty((ndim, ndim))
    eye = np.eye(ndim) * h
    for i in range(ndim):
        for j in range(i, ndim):
            hess[i, j] = hess[j, i] = (
                neg_lp(mode + eye[i] + eye[j])
                - neg_lp(mode + eye[i] - eye[j])
                - neg_lp(mode - eye[i] + eye[j])
                + neg_lp(mode - eye[i] - eye[j])
            ) / (4 * h * h)
    try:
        chol = np.linalg.cholesky(np.linalg.inv(hess))
    except np.linalg.LinAlgError:
        chol = None

    def broad(rng, n):
        cols = [
            rng.uniform(-0.9, 0.9, n),
            np.log(rng.uniform(0.01, 0.2, n)),
            np.log(rng.uniform(0.02, 0.3, n)),
            rng.uniform(0.0, 5.0, n),
            rng.uniform(-0.3, 0.3, n),
        ]
        return np.column_stack(cols[:ndim])

    def init(rng, nwalkers):
        if chol is None or not np.all(np.isfinite(chol)):
            return broad(rng, nwalkers)
        p0 = mode + _INIT_WIDENING * rng.standard_normal((nwalkers, ndim)) @ chol.T
        # a mode on a boundary (e.g. the lever arm at 0 m when the data hold none) gives a
        # direction of (numerically) zero width: start that parameter broad
        flat = p0.std(axis=0) < 1e-6
        if flat.any():
            p0[:, flat] = broad(rng, nwalkers)[:, flat]
        bad = ~np.isfinite(log_prob_global(p0, s, r, szm, szv, priors, u2))
        p0[bad] = broad(rng, int(bad.sum()))
        # a near-singular approximation (prior-dominated, nearly collinear directions)
        # would fail emcee's check of the initial ensemble: start broad instead
        ok = walkers_independent(p0) and np.all(p0.std(axis=0) > 0)
        return p0 if ok else broad(rng, nwalkers)

    return init


def _sample_global(s, r, szm, szv, u2, settings, seedseq, priors, ndim):
    """emcee run of the global model: 3 parameters, 4 with the lever arm (``u2``), 5 with
    the motion-model scale too."""
    init = _global_init_fn(s, r, szm, szv, u2, priors, ndim)
    chains = _run_ensembles(
        log_prob_global, (s, r, szm, szv, priors, u2), init, ndim, settings, seedseq
    )
    names = (_GLOBAL_NAMES + ["lever_arm_m", "motion_scale"])[:ndim]
    logs = [k for k in (1, 2, 4) if k < ndim]  # sampled as logs, reported natural
    nat = chains.copy()
    nat[..., logs] = np.exp(chains[..., logs])
    diag, reasons = _diagnostics(nat, names, settings)
    thin = _thin(chains, settings.ndraws)
    ll = _global_loglik_pointwise(thin.reshape(-1, ndim), s, r, szm, szv, u2)
    ll = ll.reshape(thin.shape[0], thin.shape[1], -1)
    draws = {n: (np.exp(thin[..., k]) if k in logs else thin[..., k]) for k, n in enumerate(names)}
    return draws, ll, diag, reasons


# fixed order: each model's seed is its child index; the number of parameters of each
_GLOBAL_MODELS = ("rho_only", "lever_arm", "lever_arm_scale")
_GLOBAL_NDIM = {"rho_only": 3, "lever_arm": 4, "lever_arm_scale": 5}


def fit_global(
    records: pd.DataFrame,
    bin_fits,
    *,
    surrogate=None,
    settings: SamplerSettings = SamplerSettings(),
    seed,
    priors: Priors = Priors(),
    use_unconverged_bins: bool = False,
    lever_arm="auto",
    scan_period_s: float = 1.0,
) -> GlobalFit:
    """Posterior of ``rho``, ``tau0_ms``, ``kappa`` [, ``lever_arm_m``] from the records with a reference (stage 2).

    Only records of converged bins with finite ``hws_std_ms``, ``ref_hws_std_ms`` and a
    positive sigma_Z are used; the bins left out are listed in ``info["excluded_bins"]``.
    With no usable record the posterior is the prior and the fit is marked failed.

    Parameters
    ----------
    records : pandas.DataFrame
        All records with ``bin_id``, ``hws_mean_ms``, ``hws_std_ms``, ``ref_hws_std_ms``.
    bin_fits : sequence of BinFit
    surrogate : SigmaZSurrogate, optional
    settings : SamplerSettings
    seed : int or numpy.random.SeedSequence
    priors : Priors
    use_unconverged_bins : bool
        Only for simulation-based calibration (which must not condition on convergence):
        also use the records of bins that failed the convergence criteria.
    lever_arm : "auto", bool or str
        ``"auto"``: fit the three nested models -- rho only; plus an effective lever arm
        ``lever_arm_m`` (head translation, :func:`translation_unit_sq`); plus a
        motion-model scale ``motion_scale`` of the surrogate's rotational sigma_Z (the
        harmonic-motion surrogate against a broadband real sea) -- and keep the one
        :func:`select_global_model` picks (a richer model only if it converged and
        PSIS-LOO prefers it by more than ``loo_threshold_se`` se). False / True /
        ``"lever_arm_scale"`` (or a model name): fit only that model. Each model's result
        depends only on ``seed``, not on whether the others are fitted: the models run
        as separate jobs and :func:`select_global_model` give the same result as
        ``"auto"``.
    scan_period_s : float
        VAD scan duration (s) for the translation term (1 s for the ZephIR 300).

    Returns
    -------
    GlobalFit
        ``info["loo"]`` holds ``model`` (a name of ``_GLOBAL_MODELS``) and the comparison of the
        global with a per-bin rho (see docs/inference.md); with ``"auto"`` also the
        lever-arm comparison.
    """
    for c in ("bin_id", "hws_mean_ms", "hws_std_ms"):
        if c not in records:
            raise ValueError(f"fit_global: records lack column {c!r}")
    if isinstance(lever_arm, str):
        if lever_arm != "auto" and lever_arm not in _GLOBAL_MODELS:
            raise ValueError(
                f"fit_global: lever_arm={lever_arm!r} is not 'auto', True, False or one of "
                f"{_GLOBAL_MODELS}"
            )
        models = _GLOBAL_MODELS if lever_arm == "auto" else (lever_arm,)
    elif lever_arm in (True, False):
        models = ("lever_arm" if lever_arm else "rho_only",)
    else:
        raise ValueError(f"fit_global: lever_arm={lever_arm!r} is not 'auto', True or False")
    seedseq = _as_seedsequence(seed)
    ss_sz, ss_mc, ss_loo = seedseq.spawn(3)
    n_models = len(_GLOBAL_MODELS)
    mc_children, loo_children = ss_mc.spawn(n_models), ss_loo.spawn(n_models)
    bin_fits = list(bin_fits)
    good = [f for f in bin_fits if f.converged or use_unconverged_bins]
    excluded = [f.bin_id for f in bin_fits if not (f.converged or use_unconverged_bins)]
    szm, szv, u2m = record_sigma_z_moments(
        records,
        good,
        surrogate=surrogate,
        ndraws=settings.n_sz_draws,
        seed=ss_sz,
        scan_period_s=scan_period_s,
    )
    s = records["hws_std_ms"].to_numpy(dtype=float)
    r = (
        records["ref_hws_std_ms"].to_numpy(dtype=float)
        if "ref_hws_std_ms" in records
        else np.full(len(records), np.nan)
    )
    use = np.isfinite(s) & np.isfinite(r) & (s > 0) & (r > 0) & np.isfinite(szm) & (szm > 0)
    use &= np.isfinite(u2m)
    data = {
        "s": s[use],
        "r": r[use],
        "szm": szm[use],
        "szv": szv[use],
        "u2": u2m[use],
        "bins": records["bin_id"].to_numpy()[use],
    }
    f = settings.global_step_factor
    gs = SamplerSettings(
        **{
            **asdict(settings),
            "nsteps": int(round(settings.nsteps * f)),
            "nburn": int(round(settings.nburn * f)),
            "max_step_factor": settings.global_max_step_factor,
        }
    )
    fits, loos = {}, {}
    for name in models:
        k = _GLOBAL_MODELS.index(name)
        fits[name], loos[name] = _fit_global_model(
            name, data, gs, mc_children[k], loo_children[k], priors, settings.loo_threshold_se
        )
        fits[name].info.update(
            {
                "excluded_bins": excluded,
                "constant": {"record_index": np.asarray(records.index)[use]},
            }
        )
    if len(fits) == 1:
        return fits[models[0]]
    return _select_global(fits, loos, settings)


def _fit_global_model(name, data, settings, ss_mc, ss_loo, priors, loo_threshold_se):
    """One global model on prepared data; returns (GlobalFit, its PSIS-LOO dict or None)."""
    s, r, szm, szv, bins = data["s"], data["r"], data["szm"], data["szv"], data["bins"]
    u2 = None if name == "rho_only" else data["u2"]
    prior_only = s.size == 0
    draws, ll, diag, reasons = _sample_global(
        s, r, szm, szv, u2, settings, ss_mc, priors, _GLOBAL_NDIM[name]
    )
    reasons = list(reasons)
    if prior_only:
        reasons.append(
            "no record with reference std and converged bin: rho posterior equals the prior"
        )
    loo_info = {"model": name}
    lg = None if prior_only else _loo(ll)
    if name != "rho_only":  # per-bin rho comparison at the median lever arm (and scale)
        lev = float(np.median(draws["lever_arm_m"]))
        k = float(np.median(draws["motion_scale"])) if "motion_scale" in draws else 1.0
        sz_eff = np.sqrt((k * szm) ** 2 + lev**2 * u2)
        szv = k**2 * szv * (k * szm / np.maximum(sz_eff, 1e-12)) ** 2
        szm = sz_eff
    if not prior_only and np.unique(bins).size > 1:
        llb = _per_bin_rho_loo(
            s,
            r,
            szm,
            szv,
            bins,
            np.median(draws["tau0_ms"]),
            np.median(draws["kappa"]),
            np.random.default_rng(ss_loo),
            1000,
            priors,
        )
        lb = _loo(llb)
        if lg is None or lb is None:
            loo_info.update({"loo_failed": True, "preferred": "global"})
        else:
            d, se = _loo_compare(lb, lg)
            loo_info.update(
                {
                    "global_elpd": lg["elpd"],
                    "per_bin_elpd": lb["elpd"],
                    "elpd_diff": d,
                    "elpd_diff_se": se,
                    "global_pareto_k_max": float(np.max(lg["pareto_k"])),
                    "per_bin_pareto_k_max": float(np.max(lb["pareto_k"])),
                    "preferred": "per_bin" if d > loo_threshold_se * se else "global",
                }
            )
    rho = draws["rho"].ravel()
    info = {
        "n_records": int(s.size),
        "prior_only": prior_only,
        "excluded_bins": [],
        "loo": loo_info,
        "rho_mass_beyond_0p98": float(np.mean(np.abs(rho) > 0.98)),
    }
    fit = GlobalFit(draws=draws, log_lik=ll, diagnostics=diag, failure_reasons=reasons, info=info)
    return fit, lg


def select_global_model(
    fit_rho_only: GlobalFit,
    fit_lever_arm: GlobalFit,
    fit_lever_arm_scale: GlobalFit | None = None,
    *,
    settings: SamplerSettings = SamplerSettings(),
) -> GlobalFit:
    """Pick among the nested global models by PSIS-LOO (the choice of ``fit_global(lever_arm="auto")``).

    Starting from the rho-only model, each richer model (lever arm, then lever arm and
    motion-model scale) replaces the current choice if it converged and its elpd exceeds
    the current choice's by more than ``settings.loo_threshold_se`` standard errors of the
    difference. All fits must come from :func:`fit_global` on the same records (one
    model each, e.g. as parallel jobs; fits read back with :func:`load_fit` work: the
    pointwise log-likelihood is stored).

    Parameters
    ----------
    fit_rho_only, fit_lever_arm : GlobalFit
    fit_lever_arm_scale : GlobalFit, optional
        Without it the choice is between the first two.
    settings : SamplerSettings
        Only ``loo_threshold_se`` is used.

    Returns
    -------
    GlobalFit
        The chosen fit (a copy) with ``info["loo"]`` extended by ``<model>_elpd_diff``,
        ``<model>_elpd_diff_se`` (against the next simpler model) and ``<model>_pareto_k_max``.

    Raises
    ------
    ValueError
        If a fit is not the named model or the fits were not made on the same records.
    """
    fits = {"rho_only": fit_rho_only, "lever_arm": fit_lever_arm}
    if fit_lever_arm_scale is not None:
        fits["lever_arm_scale"] = fit_lever_arm_scale
    for name, f in fits.items():
        if not isinstance(f, GlobalFit) or f.info.get("loo", {}).get("model") != name:
            raise ValueError(f"select_global_model: fit_{name} is not a {name!r} GlobalFit")
    idx = [np.asarray(f.info.get("constant", {}).get("record_index", [])) for f in fits.values()]
    if any(i.shape != idx[0].shape or not np.array_equal(i, idx[0]) for i in idx[1:]):
        raise ValueError("select_global_model: the fits were not made on the same records")
    loos = {
        name: None if f.info["prior_only"] else _loo(np.asarray(f.log_lik))
        for name, f in fits.items()
    }
    return _select_global(fits, loos, settings)


def _select_global(fits, loos, settings):
    chosen = "rho_only"
    extra = {}
    names = [m for m in _GLOBAL_MODELS if m in fits]
    if all(loos.get(m) is not None for m in names):
        extra["rho_only_pareto_k_max"] = float(np.max(loos["rho_only"]["pareto_k"]))
        for simpler, richer in zip(names[:-1], names[1:], strict=True):
            d, se = _loo_compare(loos[richer], loos[simpler])
            extra.update(
                {
                    f"{richer}_elpd_diff": d,
                    f"{richer}_elpd_diff_se": se,
                    f"{richer}_pareto_k_max": float(np.max(loos[richer]["pareto_k"])),
                }
            )
            dc, sec = _loo_compare(loos[richer], loos[chosen])
            if fits[richer].converged and dc > settings.loo_threshold_se * sec:
                chosen = richer
    fit = fits[chosen]
    info = {**fit.info, "loo": {**fit.info["loo"], **extra}}
    return GlobalFit(
        draws=fit.draws,
        log_lik=fit.log_lik,
        diagnostics=fit.diagnostics,
        failure_reasons=list(fit.failure_reasons),
        info=info,
    )


# ----------------------------------------------------------------------------- prior predictive
def prior_predictive(
    hws_ms, ref_std_ms, *, surrogate=None, priors: Priors = Priors(), ndraws=2000, seed
):
    """Prior predictive draws of the floating-lidar std for given records.

    Parameters
    ----------
    hws_ms, ref_std_ms : array_like, shape (n,)
        Mean HWS and reference std (m/s) of the records.
    surrogate : SigmaZSurrogate, optional
    priors : Priors
    ndraws : int
    seed : int or SeedSequence

    Returns
    -------
    dict of numpy.ndarray
        ``amplitude_deg``, ``period_s``, ``rho``, ``tau0_ms``, ``kappa`` (ndraws,),
        ``sigma_z_ms`` and ``hws_std_ms`` (ndraws, n).
    """
    surrogate = _default_surrogate(surrogate)
    rng = np.random.default_rng(_as_seedsequence(seed))
    th = sample_motion_prior(rng, ndraws, priors, 4)
    a, t = np.exp(th[:, 0]), np.exp(th[:, 1])
    rho = rng.uniform(-1, 1, ndraws)
    tau0 = np.abs(rng.normal(0, priors.tau0_scale_ms, ndraws))
    kappa = np.abs(rng.normal(0, priors.kappa_scale, ndraws))
    h = np.asarray(hws_ms, float)[None, :]
    r = np.asarray(ref_std_ms, float)[None, :]
    sz = np.asarray(surrogate.sigma_z_ms(h, a[:, None], t[:, None]), float)
    mu = sigma_moving_pc(r, sz, rho[:, None])
    tau = np.sqrt((kappa[:, None] * mu) ** 2 + tau0[:, None] ** 2)
    s = np.abs(mu + tau * rng.standard_normal(mu.shape))
    return {
        "amplitude_deg": a,
        "period_s": t,
        "rho": rho,
        "tau0_ms": tau0,
        "kappa": kappa,
        "sigma_z_ms": sz,
        "hws_std_ms": s,
    }
