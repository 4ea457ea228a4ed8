"""Log-densities of the models and their pointwise log-likelihoods (vectorised over walkers).

Every log-probability here is module level (picklable) and returns ``-inf`` (never NaN)
outside the support.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.special import gammaln

from flidar_uq.inference.priors import Priors

_LOG2PI = np.log(2.0 * np.pi)
#: A record's variance share is clipped to [clip, 1 - clip] in the Beta likelihood.
_SHARE_CLIP = 1e-3


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


def _two_period_terms(theta):
    """Unpack a two-period theta (n_walkers, 7): log A, log T1, log T2, log w, log(1 - w),
    log s_a, log s_T, shape parameters a = w c and b = (1 - w) c of the records' shares."""
    logit_w, log_c = theta[:, 3], theta[:, 6]
    log_w = -np.logaddexp(0.0, -logit_w)
    log_1mw = -np.logaddexp(0.0, logit_w)
    c = np.exp(log_c)
    return log_w, log_1mw, np.exp(log_w) * c, np.exp(log_1mw) * c, c


def _beta_logpdf(log_x, log_1mx, a, b):
    return (a - 1.0) * log_x + (b - 1.0) * log_1mx + gammaln(a + b) - gammaln(a) - gammaln(b)


def _loglik_pointwise_two_period(theta, log_amp, log_per, log_p1, log_p2, share1):
    """(n_walkers, n_obs) pointwise log-likelihood of the two-period model.

    A record with a two-peaked spectrum of its own (``log_p1``, ``log_p2``, ``share1``
    finite) contributes ``N(log p1; log T1, s_T) N(log p2; log T2, s_T) Beta(share1; w c,
    (1 - w) c)``; a single-peaked record (its period ``log_per``) is the limit of a share 1
    or 0 and contributes ``w N(log p; log T1, s_T) + (1 - w) N(log p; log T2, s_T)``: in
    both, ``w`` is the expected share of a record's tilt variance in the short-period peak.
    NaN observations contribute 0.
    """
    log_a, log_t1, log_t2 = (theta[:, k : k + 1] for k in range(3))
    sa, st = np.exp(theta[:, 4:5]), np.exp(theta[:, 5:6])
    log_w, log_1mw, a, b, _ = (x[:, None] for x in _two_period_terms(theta))
    two = np.isfinite(log_p1) & np.isfinite(log_p2) & np.isfinite(share1)
    sh = np.clip(np.where(two, share1, 0.5), _SHARE_CLIP, 1.0 - _SHARE_CLIP)
    with np.errstate(invalid="ignore"):
        la = _norm_logpdf(log_amp[None, :], log_a, sa)
        l_two = (
            _norm_logpdf(np.where(two, log_p1, 0.0)[None, :], log_t1, st)
            + _norm_logpdf(np.where(two, log_p2, 0.0)[None, :], log_t2, st)
            + _beta_logpdf(np.log(sh)[None, :], np.log1p(-sh)[None, :], a, b)
        )
        l_one = np.logaddexp(
            log_w + _norm_logpdf(log_per[None, :], log_t1, st),
            log_1mw + _norm_logpdf(log_per[None, :], log_t2, st),
        )
    lt = np.where(two[None, :], l_two, np.where(np.isfinite(l_one), l_one, 0.0))
    return np.where(np.isfinite(la), la, 0.0) + lt


@dataclass(frozen=True)
class _MotionData:
    """Sufficient statistics of a bin's IMU observations for the unimodal model.

    ``n``, ``mean``, ``ss`` (sum of squared deviations) of the finite log amplitudes and
    log periods: the normal likelihood depends on the data only through them.
    """

    n_amp: int
    mean_amp: float
    ss_amp: float
    n_per: int
    mean_per: float
    ss_per: float

    @classmethod
    def from_observations(cls, log_amp, log_per):
        la = np.asarray(log_amp, dtype=float)
        lt = np.asarray(log_per, dtype=float)
        la, lt = la[np.isfinite(la)], lt[np.isfinite(lt)]
        ma = float(la.mean()) if la.size else 0.0
        mt = float(lt.mean()) if lt.size else 0.0
        return cls(
            la.size,
            ma,
            float(np.sum((la - ma) ** 2)),
            lt.size,
            mt,
            float(np.sum((lt - mt) ** 2)),
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


@dataclass(frozen=True)
class _TwoPeriodData:
    """Sufficient statistics of a bin's IMU observations for the two-period model.

    Amplitudes as :class:`_MotionData`; the two-peaked records' log periods ``p1``, ``p2``
    (count, mean, sum of squared deviations) and ``sum log share1``, ``sum log(1 -
    share1)``; the single-peaked records' distinct log periods with their counts.
    """

    n_amp: int
    mean_amp: float
    ss_amp: float
    n_two: int
    mean_p1: float
    ss_p1: float
    mean_p2: float
    ss_p2: float
    sum_log_share: float
    sum_log_1mshare: float
    per_values: np.ndarray
    per_counts: np.ndarray

    @classmethod
    def from_observations(cls, log_amp, log_per, log_p1, log_p2, share1):
        la = np.asarray(log_amp, dtype=float)
        la = la[np.isfinite(la)]
        p1, p2, sh = (np.asarray(x, dtype=float) for x in (log_p1, log_p2, share1))
        two = np.isfinite(p1) & np.isfinite(p2) & np.isfinite(sh)
        lt = np.asarray(log_per, dtype=float)
        lt = lt[~two & np.isfinite(lt)]
        p1, p2 = p1[two], p2[two]
        sh = np.clip(sh[two], _SHARE_CLIP, 1.0 - _SHARE_CLIP)
        values, counts = np.unique(lt, return_counts=True)

        def moments(x):
            m = float(x.mean()) if x.size else 0.0
            return m, float(np.sum((x - m) ** 2))

        ma, ssa = moments(la)
        m1, ss1 = moments(p1)
        m2, ss2 = moments(p2)
        return cls(
            la.size,
            ma,
            ssa,
            int(two.sum()),
            m1,
            ss1,
            m2,
            ss2,
            float(np.log(sh).sum()),
            float(np.log1p(-sh).sum()),
            values,
            counts.astype(float),
        )


def _log_prob_two_period(theta, data, priors):
    """:func:`log_prob_two_period` on :class:`_TwoPeriodData` (the sampler's target)."""
    theta = np.atleast_2d(np.asarray(theta, dtype=float))
    with np.errstate(all="ignore"):
        lp, ok = _log_prior_motion(
            theta[:, 0], [theta[:, 1], theta[:, 2]], theta[:, 4], theta[:, 5], priors
        )
        ok &= (theta[:, 1] < theta[:, 2]) & (np.abs(theta[:, 3]) < 12.0)
        ok &= _in(
            theta[:, 6],
            np.log(priors.weight_concentration_min),
            np.log(priors.weight_concentration_max),
        )
        log_w, log_1mw, a, b, c = _two_period_terms(theta)
        # Beta(b, b) on w plus the logit Jacobian w (1 - w); log 2: two orderings
        lp = lp + priors.weight_beta * (log_w + log_1mw) + np.log(2.0)
        lp = lp + _norm_logpdf(
            theta[:, 6],
            np.log(priors.weight_concentration_median),
            priors.weight_concentration_log_sd,
        )
        ll = _normal_loglik(data.n_amp, data.mean_amp, data.ss_amp, theta[:, 0], theta[:, 4])
        # two-peaked records: both periods about T1, T2 and the variance share about w
        ll = ll + _normal_loglik(data.n_two, data.mean_p1, data.ss_p1, theta[:, 1], theta[:, 5])
        ll = ll + _normal_loglik(data.n_two, data.mean_p2, data.ss_p2, theta[:, 2], theta[:, 5])
        ll = ll + (
            (a - 1.0) * data.sum_log_share
            + (b - 1.0) * data.sum_log_1mshare
            + data.n_two * (gammaln(c) - gammaln(a) - gammaln(b))
        )
        # single-peaked records: all variance at T1 (probability w) or at T2
        inv_sd = np.exp(-theta[:, 5:6])
        x = data.per_values[None, :]
        mix = np.logaddexp(
            log_w[:, None] - 0.5 * ((x - theta[:, 1:2]) * inv_sd) ** 2,
            log_1mw[:, None] - 0.5 * ((x - theta[:, 2:3]) * inv_sd) ** 2,
        )
        n_one = float(data.per_counts.sum())
        ll = ll + mix @ data.per_counts - n_one * (theta[:, 5] + 0.5 * _LOG2PI)
        out = lp + ll
    return np.where(ok & np.isfinite(out), out, -np.inf)


def log_prob_two_period(theta, log_amp, log_per, log_p1, log_p2, share1, priors=Priors()):
    """Log posterior of the two-period per-bin model, vectorised over walkers.

    The records' own spectra carry the two periods: see
    :func:`_loglik_pointwise_two_period` for the likelihood (``w`` is the expected share
    of a record's tilt variance in the short-period peak, the meaning it has in
    :meth:`flidar_uq.physics.surrogate.SigmaZSurrogate.sigma_z_two_period_ms`).

    Parameters
    ----------
    theta : array_like, shape (n_walkers, 7) or (7,)
        ``(log A_deg, log T1_s, log T2_s, logit w, log s_a, log s_T, log c)``, ``T1 < T2``;
        ``c`` the concentration of the records' variance shares about ``w`` (-).
    log_amp, log_per : numpy.ndarray, shape (n_obs,)
        Log of the records' IMU amplitude (deg) and period (s); NaN = missing.
    log_p1, log_p2 : numpy.ndarray, shape (n_obs,)
        Log of the records' short and long spectral peak periods (s); NaN = single-peaked.
    share1 : numpy.ndarray, shape (n_obs,)
        The records' share of tilt variance in the short-period peak (-); NaN =
        single-peaked.
    priors : Priors

    Returns
    -------
    numpy.ndarray, shape (n_walkers,)
        ``-inf`` outside the support (incl. ``T1 >= T2``), never NaN.
    """
    return _log_prob_two_period(
        theta, _TwoPeriodData.from_observations(log_amp, log_per, log_p1, log_p2, share1), priors
    )


def _global_loglik_pointwise(theta, s, r, sz_med, sz_var, u2=None, corr=None):
    """(n_walkers, n_obs) pointwise log-likelihood of the observation model.

    ``s_i ~ N(mu_i, tau_i)``, ``mu_i^2 = r_i^2 + sZ_i^2 + 2 rho r_i sZ_i`` (Gutiérrez-Antuñano
    et al., 2018, Eq. 15), ``tau_i^2 = kappa^2 mu_i^2 + tau0^2 + (dmu_i/dsZ_i)^2
    Var(sZ_i)`` with ``dmu/dsZ = (sZ + rho r) / mu``. With a 4th column (lever arm ``L``)
    and ``u2``: ``sZ^2 = sZ_rot^2 + L^2 u^2`` and ``Var(sZ)`` scaled by ``(sZ_rot / sZ)^2``;
    with a 5th column ``log k`` the surrogate's rotational sigma_Z is scaled first,
    ``sZ_rot = k sZ``. With ``corr`` (a DBS lidar's correlation ``c`` of the tilt leak and
    the head translation, :func:`flidar_uq.inference.observations.bin_motion_terms`):
    ``sZ^2 = sZ_rot^2 + 2 c sZ_rot L u + L^2 u^2`` and ``Var(sZ)`` scaled by
    ``((sZ_rot + c L u) / sZ)^2``, the derivative through the rotational part as above.
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
        if corr is None:
            sz = np.sqrt(sz_sq)
            sz_var = sz_var * sz_rot_sq / np.maximum(sz_sq, 1e-24)
        else:  # the DBS cross term 2 c sZ_rot L u
            sz_rot = np.sqrt(sz_rot_sq)
            cross = corr * np.sqrt(u2) * theta[:, 3:4]
            sz_sq += 2.0 * sz_rot * cross
            np.maximum(sz_sq, 0.0, out=sz_sq)
            sz = np.sqrt(sz_sq)
            cross += sz_rot
            sz_var = sz_var * cross**2 / np.maximum(sz_sq, 1e-24)
        var = rho * r * sz
        var *= 2.0
        var += sz_sq
        var += r**2
    else:
        sz = sz_med
        var = rho * (2.0 * r * sz)
        var += r**2 + sz**2
    np.maximum(var, 1e-12, out=var)  # mu^2, Eq. (15) of Gutiérrez-Antuñano et al. (2018)
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


def log_prob_global(theta, s, r, sz_med, sz_var, priors=Priors(), u2=None, corr=None):
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
    corr : numpy.ndarray, shape (n_obs,), optional
        A pulsed DBS lidar's correlation (-) of the tilt leak and the head translation per
        record (:func:`flidar_uq.inference.record_sigma_z_moments`); None: 0 (a CW lidar).

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
            ll = _global_loglik_pointwise(theta[ok], s, r, sz_med, sz_var, u2, corr).sum(axis=1)
            out[ok] = lp[ok] + ll
    return np.where(np.isfinite(out), out, -np.inf)
