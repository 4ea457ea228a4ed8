"""Log-densities of the models and their pointwise log-likelihoods (vectorised over walkers).

Every log-probability here is module level (picklable) and returns ``-inf`` (never NaN)
outside the support.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from flidar_uq.inference.priors import Priors

_LOG2PI = np.log(2.0 * np.pi)


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
        # effective_sigma_z_ms written in place (this is the global fit's inner loop)
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
