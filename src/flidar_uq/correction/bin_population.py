"""The true-TI population of a group of records from their noisy corrected-TI draws.

A record's corrected TI is a noisy measurement of its true TI. Its posterior draws carry two
kinds of error: one shared by every record of the group (the global parameters: the motion
scale, the lever arm, rho, the lidar's response ``g``; and the regime discrepancy), and one of
the record's own (its sampling noise, its motion error, its correlation's scatter). A
statistic taken over the records draw by draw (mean, sd) averages the record's own error out
of the mean but adds it, twice, to the spread: once through the scatter of the records'
estimates about their true values and once through each draw's scatter about the estimate
(law of total variance). The sd, the representative TI and the 90th percentile then lean
high, by more the noisier the records.

The measurement-error model here separates the two on the log scale (a record's noise is
relative, and a bin's TI is right-skewed: on the project's virtual campaigns the log of the
true TI of a height and 1-m/s bin has a median skewness of 0.01-0.05, the TI itself 0.9),
docs/inference.md, "Bin statistics":

1. Shared part. For every record ``i`` the log TI draws are regressed on the group's
   leave-one-out mean draw ``M_{-i,d}``: ``X_di = y_i + beta_i (M_{-i,d} - M_{-i}) + r_di``.
   ``y_i`` (the record's posterior mean) is its point estimate, ``beta_i`` its share of the
   group's common error and ``v_i`` the variance of its own error ``r_di``, taken from the
   central 68 % of the residuals (the log TI draws of the record model have longer tails
   than the record's actual error: their variance is 1.35 times the actual error's).
2. Population. The records' true log TI are a normal population ``N(mu, tau^2)`` and
   ``y_i ~ N(log t_i, v_i)``: the hierarchical normal model of Gelman et al. (2013, Sec.
   5.4, the "eight schools"), ``tau`` with a uniform prior on a grid, ``mu`` flat. Its
   draws of ``(tau, mu)`` and of every ``log t_i`` given them (each shrunk towards ``mu`` by
   ``v_i / (v_i + tau^2)``) are draws of the group's finite population of true TI.
   One part of ``v_i`` is not a measurement error of that kind: the point TI scatters about
   the motionless lidar's by the point target's sd ``s_i``
   (:func:`flidar_uq.physics.lidar_response.lidar_point_log_sd`), whatever the lidar's
   value. That is a Berkson error (Carroll et al. 2006, Sec. 2.2): the truth is
   the lidar's value plus it, so it widens the population instead of narrowing it. The
   model takes ``v_i - s_i^2`` as the classical error and adds ``N(0, s_i^2)`` to each
   ``log t_i`` draw. On the virtual campaigns the corrected TI's error was anti-correlated
   with the true TI by about ``s_i^2`` (covariance -0.0012 against ``s^2`` = 0.0013 on a
   wave follower), as a Berkson error is; treated as classical it took the bin's sd 2 %
   low and the representative TI 0.6 % low.
3. Statistics. To every population draw the shared error of one posterior draw is added
   (``beta_i`` times the group's mean error, with its own-noise part taken out), and the
   mean, sd, representative TI (IEC 61400-1 ed. 3: mean + 1.28 sd) and 90 % quantile (the
   representative TI of IEC 61400-1 ed. 4) of the TI are taken over the records. Every
   statistic is then scaled so that the population's mean is the records' mean TI: the
   records' own errors average out of a mean on the linear scale, where the record
   model's draws are unbiased, and a record's log-scale posterior is not exactly normal.

The target is the finite population: the statistic of the true TI of the group's own
records (what the truth columns of a virtual campaign give), not a climate's. The per-record
corrected TI that the tables publish is the record's own posterior (unshrunk).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from flidar_uq.data.metrics import REPRESENTATIVE_TI_FACTOR

__all__ = [
    "LOG_FLOOR_TI",
    "GroupErrors",
    "group_errors",
    "population_statistic_draws",
    "tau_posterior",
]

#: Normal quantiles at -1 and +1 sd.
_ONE_SIGMA = (0.15865525393145707, 0.8413447460685429)
#: Grid points of the population sd ``tau`` (its posterior is smooth and one-peaked).
_TAU_GRID = 256
#: Floor of the TI draws taken to the log scale (-): a draw of 0 (the motion's variance
#: reaching the measured one) counts as this TI, far below any atmospheric TI.
LOG_FLOOR_TI = 1e-3
#: Values (float64) held at once (bounds the temporaries of a group of a year's records).
_BLOCK_VALUES = 4_000_000


@dataclass(frozen=True)
class GroupErrors:
    """The records' point estimates and the two parts of their error (step 1).

    Attributes
    ----------
    estimate : numpy.ndarray, shape (n,)
        Posterior mean of each record's corrected TI ``y_i`` (-).
    own_var : numpy.ndarray, shape (n,)
        Variance of each record's own error ``v_i`` (-^2), not shared with the group.
    shared_loading : numpy.ndarray, shape (n,)
        ``beta_i``: the record's error per unit of the group's common error (-).
    shared_draws : numpy.ndarray, shape (ndraws,)
        The group's common error per posterior draw (-), centred, with the records' own
        errors' share of the mean draw taken out in variance.
    mean_ti : float
        The mean over draws and records of the corrected TI itself (-), on the linear scale
        whatever the scale of the rest.
    """

    estimate: np.ndarray
    own_var: np.ndarray
    shared_loading: np.ndarray
    shared_draws: np.ndarray
    mean_ti: float


def group_errors(draws, columns=None, *, log: bool = False) -> GroupErrors:
    """Split a group's corrected-TI draws into estimates, own and shared errors (step 1 of
    the module docstring).

    Parameters
    ----------
    draws : numpy.ndarray, shape (ndraws, n_records)
        Corrected TI draws (-); draw ``d`` of every record comes from the same global
        posterior draw. float32 or float64 (computed in float64, on blocks of records).
    columns : numpy.ndarray of int, optional
        The group's records (>= 2 columns of ``draws``); default all.
    log : bool
        Work on ``log(max(TI, LOG_FLOOR_TI))`` (relative errors).

    Returns
    -------
    GroupErrors
        Of the (log) TI.
    """
    draws = np.asarray(draws)
    cols = np.arange(draws.shape[1]) if columns is None else np.asarray(columns)
    ndraws, n = draws.shape[0], cols.size
    if n < 2:
        raise ValueError(f"group_errors: needs >= 2 records, got {n}")

    step = max(1, _BLOCK_VALUES // max(ndraws, 1))
    total, linear_total = np.zeros(ndraws), 0.0
    for j in range(0, n, step):
        b = np.asarray(draws[:, cols[j : j + step]], dtype=float)
        linear_total += float(b.sum())
        total += (np.log(np.maximum(b, LOG_FLOOR_TI)) if log else b).sum(axis=1)
    s_c = total - total.mean()
    dof = max(ndraws - 1, 1)
    var_s = s_c @ s_c / dof
    est, own, beta = (np.empty(n) for _ in range(3))
    for j in range(0, n, step):
        b = np.asarray(draws[:, cols[j : j + step]], dtype=float)
        if log:
            b = np.log(np.maximum(b, LOG_FLOOR_TI))
        mean = b.mean(axis=0)
        b -= mean
        var_x = np.einsum("ij,ij->j", b, b) / dof
        cov_xs = s_c @ b / dof
        # leave-one-out group sum S - X_i = (n - 1) M_-i: its variance and covariance
        var_m = np.maximum(var_s - 2.0 * cov_xs + var_x, 0.0)
        cov_xm = cov_xs - var_x
        with np.errstate(invalid="ignore", divide="ignore"):
            slope = np.where(var_m > 0.0, cov_xm / var_m, 0.0)
        est[j : j + step] = mean
        # the own error's variance from the central 68 % of the residuals (a normal's
        # +-1 sd): a record's log TI draws have longer tails than its error has
        lo, hi = np.quantile(b - slope * (s_c[:, None] - b), _ONE_SIGMA, axis=0)
        own[j : j + step] = ((hi - lo) / 2.0) ** 2
        beta[j : j + step] = slope * (n - 1)
    # the common error per draw: the mean draw, less its own-noise variance mean(v) / n
    mean_c = s_c / n
    var_mean = float(mean_c @ mean_c) / dof
    shrink = np.sqrt(max(var_mean - own.mean() / n, 0.0) / var_mean) if var_mean > 0 else 0.0
    return GroupErrors(est, own, beta, mean_c * shrink, linear_total / (ndraws * n))


def tau_posterior(y: np.ndarray, v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Grid and normalised posterior mass of the population sd ``tau`` of the hierarchical
    normal model with a uniform prior on ``tau`` and a flat one on ``mu`` (Gelman et al.
    2013, Eq. 5.21): ``p(tau | y) ∝ V_mu^(1/2) prod (v_i + tau^2)^(-1/2)
    exp(-(y_i - mu_hat)^2 / (2 (v_i + tau^2)))``."""
    spread = float(np.std(y, ddof=1)) if y.size > 1 else 0.0
    top = 1.5 * spread + 3.0 * float(np.sqrt(np.mean(v))) + 1e-12
    tau = np.linspace(0.0, top, _TAU_GRID + 1)[1:]
    w = 1.0 / (v[None, :] + tau[:, None] ** 2)
    v_mu = 1.0 / w.sum(axis=1)
    mu_hat = (w * y[None, :]).sum(axis=1) * v_mu
    log_p = 0.5 * np.log(v_mu) + 0.5 * np.log(w).sum(axis=1)
    log_p -= 0.5 * (w * (y[None, :] - mu_hat[:, None]) ** 2).sum(axis=1)
    p = np.exp(log_p - log_p.max())
    return tau, p / p.sum()


def population_statistic_draws(
    draws, rng: np.random.Generator, columns=None, *, shift=None, point_log_sd=None
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Posterior draws of a group's population statistics of the true TI (steps 1-3 of the
    module docstring).

    Parameters
    ----------
    draws : numpy.ndarray, shape (ndraws, n_records)
        Corrected TI draws (-) (as :func:`group_errors`; floored at :data:`LOG_FLOOR_TI`
        on the log scale).
    rng : numpy.random.Generator
        The population's random numbers (``ndraws x n`` standard normals and the grid draws).
    columns : numpy.ndarray of int, optional
        The group's ``n >= 2`` records (columns of ``draws``); default all.
    shift : (numpy.ndarray, numpy.ndarray), optional
        A systematic error on log TI shared within regimes
        (:meth:`flidar_uq.correction.regime_discrepancy.RegimeDiscrepancy.draws`): each
        record's regime (index per column of ``draws``) and the regimes' draws ``delta``
        (ndraws, n_regimes); each population draw is divided by ``exp(delta)`` of its
        record's regime.
    point_log_sd : numpy.ndarray, shape (n_records,), optional
        The sd (-) of each record's log point TI about its motionless lidar's, one per
        column of ``draws`` (the point target's scatter,
        :func:`flidar_uq.physics.lidar_response.lidar_point_log_sd`), when the draws carry
        it: a Berkson error (step 2), taken out of the own error and added to the
        population's draws.

    Returns
    -------
    mean, sd, rep, p90 : numpy.ndarray, shape (ndraws,)
        The records' mean true TI, its sample sd, the representative TI ``mean + 1.28 sd``
        (IEC 61400-1 ed. 3) and the 90 % quantile (IEC 61400-1 ed. 4's representative TI),
        each (-).
    """
    e = group_errors(draws, columns, log=True)
    ndraws, n = np.shape(draws)[0], e.estimate.size
    cols = np.arange(np.shape(draws)[1]) if columns is None else np.asarray(columns)
    y, v = e.estimate, e.own_var
    v_point = np.zeros(n)
    if point_log_sd is not None:
        sd_point = np.asarray(point_log_sd, dtype=float)[cols]
        v_point = np.minimum(np.where(np.isfinite(sd_point), sd_point, 0.0) ** 2, v)
        v = v - v_point  # the classical part: the floating lidar's own error
    tau_grid, mass = tau_posterior(y, np.maximum(v, 1e-18))
    cell = tau_grid[0]
    tau = tau_grid[rng.choice(tau_grid.size, size=ndraws, p=mass)]
    tau = np.maximum(tau - cell * rng.random(ndraws), 1e-12)[:, None]  # uniform in its cell
    w = 1.0 / (v[None, :] + tau**2)
    v_mu = 1.0 / w.sum(axis=1, keepdims=True)
    mu = (w * y[None, :]).sum(axis=1, keepdims=True) * v_mu
    mu = mu + np.sqrt(v_mu) * rng.standard_normal((ndraws, 1))
    out = [np.empty(ndraws) for _ in range(4)]
    unshifted_mean = np.empty(ndraws)
    if shift is not None:
        regime, delta = np.asarray(shift[0])[cols], np.asarray(shift[1], dtype=float)
    step = max(1, _BLOCK_VALUES // max(n, 1))
    for j in range(0, ndraws, step):
        d = slice(j, j + step)
        # t_i | mu, tau: precision-weighted between the record's estimate and mu
        prec = 1.0 / np.maximum(v[None, :], 1e-18) + 1.0 / tau[d] ** 2
        t_hat = (y[None, :] / np.maximum(v[None, :], 1e-18) + mu[d] / tau[d] ** 2) / prec
        t = t_hat + rng.standard_normal(t_hat.shape) / np.sqrt(prec)
        t += e.shared_loading[None, :] * e.shared_draws[d, None]
        t += np.sqrt(v_point)[None, :] * rng.standard_normal(t.shape)  # the point's own scatter
        t = np.exp(t)
        unshifted_mean[d] = t.mean(axis=1)
        if shift is not None:
            t *= np.exp(-delta[d][:, regime])
        mean = t.mean(axis=1)
        sd = t.std(axis=1, ddof=1)
        out[0][d], out[1][d] = mean, sd
        out[2][d] = mean + REPRESENTATIVE_TI_FACTOR * sd
        out[3][d] = np.quantile(t, 0.9, axis=1)
    # the population's mean is the records' mean TI (step 3); every statistic scales with it
    ratio = e.mean_ti / float(np.mean(unshifted_mean))
    return tuple(x * ratio for x in out)
