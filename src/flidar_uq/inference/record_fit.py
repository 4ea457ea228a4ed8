"""The global observation model on per-record sigma_Z (the record motion model).

Each record's sigma_Z comes from its own measured motion
(:func:`flidar_uq.inference.record_motion.motion_gram`): a Gram matrix ``G_i`` of the
lidar's motion error, for any lidar (a CW VAD lidar's rotational part ``sZ_rot``,
head-translation unit ``u^2`` and hull terms, or a pulsed DBS lidar's beam-pair
phasors). The model (docs/inference.md):

* ``sZ_i^2 = v^T G_i v``, ``v = (k, k h, L, h)`` (for a buoy that only rotates
  ``(k sZ_rot,i)^2 + L^2 u_i^2``): ``L`` the lever arm (m) of the head above
  the buoy's rotation centre (prior from the buoy geometry when the config gives it),
  ``k`` a model-discrepancy check with a prior near 1 (``log k ~ N(0, 0.1)``), ``h`` the
  hull response (0 rotation only, 1 wave follower);
* ``s_i ~ Normal(mu_i, tau_i)``, ``mu_i^2 = r_i^2 + sZ_i^2 + 2 rho r_i sZ_i`` (Eq. (15)
  of Gutiérrez-Antuñano et al. (2018));
* ``tau_i^2 = (kappa mu_i)^2 + (kappa_z sZ_i dmu_i/dsZ_i)^2 + (s_rho (1 - rho^2) dmu_i/drho)^2
  + (p_i r_i dmu_i/dr_i)^2``:
  ``kappa`` the relative sampling noise of a 10-min std, ``kappa_z`` the relative error of
  a record's sigma_Z (the realised motion error of 10 minutes scatters about the one its
  motion spectrum predicts; a DBS lidar's record adds the known part of that scatter from
  its retrieval once a cycle to ``kappa_z^2``,
  :func:`~flidar_uq.physics.dbs_sigma_z.cycle_sampling_rel_var`), ``s_rho`` (``rho_sd``) the scatter of a record's realised
  correlation of the turbulence and the motion error about ``rho``, as the sd of its
  Fisher z (``atanh``; Fisher 1921: the sample correlation of ``N`` pairs has
  ``sd(atanh r) ~ 1 / sqrt(N - 3)``, so ``(1 - rho^2) s_rho`` on ``rho`` itself), through
  ``dmu/drho = r_i sZ_i / mu_i`` (a DBS lidar's record adds the known part of that scatter
  from where its output puts the motion error against the turbulence's spectrum to
  ``(s_rho (1 - rho^2))^2``,
  :func:`~flidar_uq.physics.dbs_sigma_z.output_correlation_line_weights`); ``p_i`` the known relative scatter of a reference lidar's std
  against the floating lidar's motionless std (``pair_log_sd``; for a cup or sonic the
  floating lidar's own sampling scatter against the point wind):
  it is a scatter of the turbulent part ``r_i`` only, so it enters through
  ``dmu/dr = (r + rho sZ) / mu``, not in proportion to ``mu`` (first-order propagation
  through Eq. (15) for these errors). The propagation draws the same
  ``exp(kappa_z N(0, 1))`` factor on each record's sigma_Z and each record's correlation as
  ``tanh(atanh(rho) + s_rho N(0, 1))`` (with a DBS lidar's known part), so ``sZ_i`` is the median of
  the realised motion error; the mean and the variance above take its mean,
  ``sZ_i exp(kappa_z^2 / 2)`` (a likelihood at the median made the fit's ``sZ`` absorb the
  log-normal's mean and the propagation then over-correct: the corrected TI was
  0.1-0.5 % low on every scenario).

A constant model-error term ``tau0`` is not needed with per-record sigma_Z: on the
default campaign its maximum-likelihood value is 0 and ``kappa_z`` is preferred by 460
log-likelihood units (docs/inference.md), so it is left out (a boundary mode at 0 only
slows the sampler).
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from flidar_uq.inference.densities import _LOG2PI, _in, _log_halfnormal_logscale, _norm_logpdf
from flidar_uq.inference.diagnostics import _diagnostics, _thin
from flidar_uq.inference.loo import _loo_chunked, _loo_compare
from flidar_uq.inference.priors import Priors, SamplerSettings
from flidar_uq.inference.record_motion import (
    CROSS_WIND_COLUMNS,
    DBS_COLUMNS,
    GRAM_COLUMNS,
    RHO_SAMPLING_COLUMNS,
    SAMPLING_COLUMN,
    describe_motion,
    gram_coefficients,
    gram_sigma_z_ms,
    motion_gram,
)
from flidar_uq.inference.results import GlobalFit
from flidar_uq.inference.sampler import _run_ensembles, laplace_init
from flidar_uq.physics.dbs_sigma_z import hws_error_moments
from flidar_uq.physics.hull import get_hull
from flidar_uq.physics.lidar import get_lidar
from flidar_uq.seeding import as_seedsequence
from flidar_uq.threads import single_threaded

__all__ = [
    "RECORD_MODEL_NAMES",
    "fit_record_model",
    "fit_subsample",
    "HULL_MODELS",
    "REFERENCE_HULL_CANDIDATES",
    "LEVER_ARM_PLAUSIBLE_MAX_M",
    "is_record_model",
    "lever_arm_check",
    "log_prob_record_model",
]

#: Parameters of the record model, in the order of its theta columns (natural scale names).
RECORD_MODEL_NAMES = (
    "rho",
    "kappa",
    "kappa_z",
    "lever_arm_m",
    "motion_scale",
    "hull_response",
    "rho_sd",
)
_LOGS = (1, 2, 4, 5, 6)  # sampled as logs, reported natural
#: lower end of the sampled log hull response: below what the data resolve its posterior
#: is the half-normal prior's exp(log h) tail (as for kappa), proper without a wall
_HULL_MIN = 1e-8


def natural_draws(theta: np.ndarray) -> dict[str, np.ndarray]:
    """The record model's parameters on their natural scale from sampler coordinates
    ``(..., 7)`` (``exp`` of the logs)."""
    return {
        n: (np.exp(theta[..., k]) if k in _LOGS else theta[..., k])
        for k, n in enumerate(RECORD_MODEL_NAMES)
    }


def is_record_model(fit) -> bool:
    """True if a global fit is the record motion model (else a bin-motion model)."""
    return getattr(fit, "info", {}).get("loo", {}).get("model") == "record"


def _record_z2_tau2(theta, s, r, gram, pair_sq):
    """``(z^2 / tau^2, tau^2)`` of the record model (module docstring), each of shape
    (n_walkers, n_obs), with ``z = s - mu``: ``-2 log p(s_i | theta) - log(2 pi)`` is
    ``z^2 / tau^2 + log tau^2``. Computed in place (eight temporaries of the output's size;
    a DBS lidar's three more).

    ``pair_sq``: the known relative variance of the two instruments' sampling (-), a
    scatter of the turbulent part ``r`` (enters through ``(dmu/dr)^2``); a scalar 0 or an
    array of ``n_obs`` values. ``gram``: each record's motion error, shape (11, n_obs): the
    entries :data:`~flidar_uq.inference.record_motion.GRAM_COLUMNS` of
    :func:`~flidar_uq.inference.record_motion.motion_gram` and the measured-translation
    flag (``h = 1`` there; 10 rows: none measured); ``sZ^2`` is one (walkers x 10) by
    (10 x records) product. A DBS lidar's 43 rows add its
    :data:`~flidar_uq.inference.record_motion.CROSS_WIND_COLUMNS` (sZ to fourth order in
    the cross-wind error, :func:`~flidar_uq.physics.dbs_sigma_z.hws_error_moments`),
    :data:`~flidar_uq.inference.record_motion.SAMPLING_COLUMN`, the variance of the
    record's ``log sZ`` from its sampling once an output interval, added to ``kappa_z^2``,
    and :data:`~flidar_uq.inference.record_motion.RHO_SAMPLING_COLUMNS`, whose quadratic
    form over the along-wind one is the variance of its realised correlation from its
    output's lines (:func:`~flidar_uq.inference.record_motion.gram_rho_sampling_var`),
    added to ``(s_rho (1 - rho^2))^2``.
    """
    rho = theta[:, 0:1]
    kappa_sq = np.exp(2.0 * theta[:, 1:2])
    kz_sq = np.exp(2.0 * theta[:, 2:3])
    if gram.shape[0] > _SAMPLING_ROW:  # a DBS lidar's record: its output's sampling
        kz_sq = kz_sq + gram[_SAMPLING_ROW]
    k = np.exp(theta[:, 4])
    h = np.exp(theta[:, 5])
    lever = theta[:, 3]
    # the scatter of a record's correlation, sd of its Fisher z times d rho / d z = 1 - rho^2
    rho_scatter_sq = (np.exp(theta[:, 6:7]) * (1.0 - rho * rho)) ** 2
    coef = gram_coefficients(k, h, lever)  # (n_walkers, 10)
    # measured translation: the response is known (h = 1)
    meas = gram[10] if gram.shape[0] > 10 and np.any(gram[10]) else None
    coef_meas = None if meas is None else gram_coefficients(k, 1.0, lever) - coef

    def form(g):  # v^T G v of one Gram part, (n_walkers, n_obs)
        q = coef @ g
        if meas is not None:
            q += coef_meas @ (g * meas)
        return q

    sz_sq = form(gram[:10])
    if gram.shape[0] > _RHO_SAMPLING_ROWS.start:  # a DBS lidar's record: its output's lines
        with np.errstate(invalid="ignore", divide="ignore"):
            line_sq = np.maximum(form(gram[_RHO_SAMPLING_ROWS]), 0.0) / sz_sq
        rho_scatter_sq = rho_scatter_sq + np.where(sz_sq > 0.0, line_sq, 0.0)
    if gram.shape[0] > 11:  # a DBS lidar's cross-wind error, to fourth order
        across, cov = np.maximum(form(gram[11:21]), 0.0), form(gram[21:31])
        sz_sq = hws_error_moments(sz_sq, across, cov, gram[31] ** -0.5)[0]
    np.maximum(sz_sq, 0.0, out=sz_sq)
    # the realised motion error is sZ exp(kappa_z N(0, 1)) (median sZ, as the propagation
    # draws it): the data's mean sees its mean, sZ exp(kappa_z^2 / 2) (module docstring)
    sz_sq *= np.exp(kz_sq)
    sz = np.sqrt(sz_sq)
    rho_r = rho * r
    mu_sq = rho_r * sz  # Eq. (15) of Gutiérrez-Antuñano et al. (2018): r^2 + sZ^2 + 2 rho r sZ
    mu_sq *= 2.0
    mu_sq += sz_sq
    mu_sq += r**2
    np.maximum(mu_sq, 1e-12, out=mu_sq)
    var = sz + rho_r  # (kappa_z sZ dmu/dsZ)^2 mu^2 = kappa_z^2 sZ^2 (sZ + rho r)^2
    var *= var
    var *= kz_sq
    var += rho_scatter_sq * r**2  # (s_rho (1 - rho^2) r sZ)^2: the correlation's scatter
    var *= sz_sq
    if np.any(pair_sq):  # the reference's sampling scatter: (p r dmu/dr)^2 mu^2
        pair_r = rho * sz
        pair_r += r
        pair_r *= pair_r
        pair_r *= pair_sq * r**2
        var += pair_r
    var /= mu_sq
    tau_sq = kappa_sq * mu_sq
    tau_sq += var
    tau_sq += 1e-8
    z = np.sqrt(mu_sq, out=mu_sq)
    np.subtract(s, z, out=z)
    z *= z
    z /= tau_sq
    return z, tau_sq


def _record_neg2_loglik(theta, s, r, gram, pair_sq):
    """``-2 log p(s_i | theta) - log(2 pi)`` of the record model, shape (n_walkers, n_obs)
    (:func:`_record_z2_tau2`)."""
    z, tau_sq = _record_z2_tau2(theta, s, r, gram, pair_sq)
    z += np.log(tau_sq, out=tau_sq)
    return z


#: records whose tau^2 are multiplied before one log in the sampler's sum: tau^2 lies in
#: [1e-8, ~1e4] (m/s)^2, so a product of 8 stays far inside float64's range
_LOG_GROUP = 8


def _sum_log_rows(x):
    """``log(x).sum(axis=1)`` for positive ``x`` (n_rows, n_cols), with one logarithm per
    ``_LOG_GROUP`` values: the logarithm (8 ns a float64 without AVX-512) was a third of
    the record fit's time; a product costs 1 ns. Equal to rounding (~1e-16 relative)."""
    k = x.shape[1] - x.shape[1] % _LOG_GROUP
    y = x[:, :k]
    while y.shape[1] > k // _LOG_GROUP:
        y = y[:, 0::2] * y[:, 1::2]
    return np.log(y).sum(axis=1) + np.log(x[:, k:]).sum(axis=1)


def _record_loglik_pointwise(theta, s, r, gram, pair_sq=0.0):
    """(n_walkers, n_obs) pointwise log-likelihood of the record model (module docstring);
    ``pair_sq``: the known relative variance of the two instruments' sampling (-), a
    scatter of the turbulent part ``r`` (enters through ``(dmu/dr)^2``); ``gram``: the
    records' motion error (:func:`_record_z2_tau2`)."""
    q = _record_neg2_loglik(theta, s, r, gram, pair_sq)
    q += _LOG2PI
    q *= -0.5
    return q


#: elements (walkers x records) of one block of the sampler's likelihood sum: its
#: temporaries stay in the CPU cache (0.5 MB each) at any campaign length
_SUM_BLOCK_ELEMENTS = 2**16


def _record_loglik_sum(theta, s, r, gram, pair_sq=0.0):
    """(n_walkers,) log-likelihood of the record model summed over the records.

    :func:`_record_z2_tau2` on blocks of records (all walkers of the call, at most
    ``_SUM_BLOCK_ELEMENTS`` values a block), summed block by block, the ``log tau^2`` by
    :func:`_sum_log_rows`: the row sums of :func:`_record_loglik_pointwise` to rounding
    (~1e-15 relative), 1.85-2x faster than on the whole (walkers x records) array, and
    the grouped logarithm faster again (measured when it was written; CHANGELOG).
    """
    n = np.size(s)
    out = np.zeros(theta.shape[0])
    b = max(1, _SUM_BLOCK_ELEMENTS // max(theta.shape[0], 1))
    for a in range(0, n, b):
        p = pair_sq[a : a + b] if np.ndim(pair_sq) else pair_sq
        z, tau_sq = _record_z2_tau2(theta, s[a : a + b], r[a : a + b], gram[:, a : a + b], p)
        out += z.sum(axis=1)
        out += _sum_log_rows(tau_sq)
    return -0.5 * (out + n * _LOG2PI)


def _log_prior(theta, priors: Priors, lever_arm_prior):
    """Log prior of the record model and its support mask, vectorised over walkers."""
    with np.errstate(all="ignore"):
        ok = np.abs(theta[:, 0]) < 1.0
        ok &= _in(theta[:, 1], np.log(priors.kappa_min), np.log(2.0))
        ok &= _in(theta[:, 2], np.log(priors.kappa_min), np.log(5.0))
        ok &= (theta[:, 3] >= 0.0) & (theta[:, 3] < priors.lever_arm_max_m)
        ok &= np.abs(theta[:, 4]) < np.log(5.0)
        ok &= _in(theta[:, 5], np.log(_HULL_MIN), np.log(priors.hull_response_max))
        ok &= _in(theta[:, 6], np.log(priors.kappa_min), np.log(2.0))
        lp = _log_halfnormal_logscale(theta[:, 1], priors.kappa_scale)
        lp = lp + _log_halfnormal_logscale(theta[:, 2], priors.kappa_z_scale)
        if lever_arm_prior is None:
            lp = lp + _norm_logpdf(theta[:, 3], 0.0, priors.lever_arm_scale_m)
        else:
            lp = lp + _norm_logpdf(theta[:, 3], lever_arm_prior[0], lever_arm_prior[1])
        lp = lp + _norm_logpdf(theta[:, 4], 0.0, priors.record_motion_scale_log_sd)
        lp = lp + _log_halfnormal_logscale(theta[:, 5], priors.hull_response_scale)
        lp = lp + _norm_logpdf(theta[:, 6], np.log(priors.rho_sd_median), priors.rho_sd_log_sd)
    return lp, ok


def log_prob_record_model(
    theta, s, r, gram, priors=Priors(), lever_arm_prior=None, pair_log_sd=None
):
    """Log posterior of the record model, vectorised over walkers.

    Parameters
    ----------
    theta : array_like, shape (n_walkers, 7)
        ``(rho, log kappa, log kappa_z, lever_arm_m, log motion_scale, log hull_response,
        log rho_sd)``.
    s, r : numpy.ndarray, shape (n_obs,)
        Floating-lidar and reference 10-min HWS std (m/s).
    gram : numpy.ndarray, shape (11 or 10, n_obs)
        Each record's motion error: the Gram entries
        :data:`~flidar_uq.inference.record_motion.GRAM_COLUMNS` of
        :func:`~flidar_uq.inference.record_motion.motion_gram` (units there) and the
        measured-translation flag (1 or 0, -; absent: none measured). Rows of a CW lidar's terms:
        :func:`~flidar_uq.inference.record_motion.gram_from_cw_terms`.
    priors : Priors
    lever_arm_prior : (float, float), optional
        Mean and sd (m) of a normal prior on the lever arm from the buoy's geometry;
        default: half-normal(``priors.lever_arm_scale_m``).
    pair_log_sd : numpy.ndarray, shape (n_obs,), optional
        Known std of ``log(s / r)`` from the two instruments' sampling alone (-): added to
        ``kappa`` in quadrature (module docstring); default None: 0.

    Returns
    -------
    numpy.ndarray, shape (n_walkers,)
        ``-inf`` outside the support, never NaN.
    """
    theta = np.atleast_2d(np.asarray(theta, dtype=float))
    lp, ok = _log_prior(theta, priors, lever_arm_prior)
    out = np.full(theta.shape[0], -np.inf)
    if np.any(ok):
        with np.errstate(all="ignore"):
            pair_sq = 0.0 if pair_log_sd is None else np.asarray(pair_log_sd) ** 2
            ll = _record_loglik_sum(theta[ok], s, r, gram, pair_sq)
        out[ok] = lp[ok] + ll
    return np.where(np.isfinite(out), out, -np.inf)


def _broad(lever_arm_prior):
    def broad(rng, n):
        lev = (
            rng.uniform(0.0, 5.0, n)
            if lever_arm_prior is None
            else np.abs(lever_arm_prior[0] + lever_arm_prior[1] * rng.uniform(-2, 2, n))
        )
        return np.column_stack(
            [
                rng.uniform(-0.5, 0.5, n),
                np.log(rng.uniform(0.01, 0.2, n)),
                np.log(rng.uniform(0.02, 0.5, n)),
                lev,
                rng.uniform(-0.2, 0.2, n),
                np.log(rng.uniform(0.01, 1.0, n)),
                np.log(rng.uniform(0.03, 0.3, n)),
            ]
        )

    return broad


def _gram_rows(cross_wind: bool) -> list[str]:
    """The rows of the observations' ``gram`` (:func:`_record_observations`), the columns
    of :func:`motion_gram` it holds: :data:`GRAM_COLUMNS` and ``translation_measured``,
    with ``cross_wind`` (a DBS lidar's) :data:`DBS_COLUMNS`."""
    dbs = DBS_COLUMNS if cross_wind else ()
    return [*GRAM_COLUMNS, "translation_measured", *dbs]


#: The rows of :data:`SAMPLING_COLUMN` and :data:`RHO_SAMPLING_COLUMNS` in a DBS lidar's
#: observations (:func:`_gram_rows`).
_SAMPLING_ROW = _gram_rows(True).index(SAMPLING_COLUMN)
_RHO_SAMPLING_ROWS = slice(
    _gram_rows(True).index(RHO_SAMPLING_COLUMNS[0]),
    _gram_rows(True).index(RHO_SAMPLING_COLUMNS[-1]) + 1,
)


@single_threaded
def _record_observations(
    records, surrogate, scan_period_s, lidar=None, hull="wave_follower", translation=True
):
    """The records the record model can use and their observations.

    Returns ``((s, r, gram), use, kinds)``: measured std ``s`` (m/s), reference std ``r``
    (m/s) and the motion error ``gram`` (11, n) (:func:`motion_gram`'s
    :data:`GRAM_COLUMNS` and ``translation_measured``; a DBS lidar's 43 rows with its
    :data:`DBS_COLUMNS`, :func:`_gram_rows`) of the usable records (all finite
    and ``s, r > 0``), the mask ``use`` over ``records`` and every record's motion
    description kind.
    """
    mot = motion_gram(
        records,
        lidar=lidar,
        surrogate=surrogate,
        scan_period_s=scan_period_s,
        hull=hull,
        translation=translation,
    )
    s = records["hws_std_ms"].to_numpy(dtype=float)
    r = (
        records["ref_hws_std_ms"].to_numpy(dtype=float)
        if "ref_hws_std_ms" in records
        else np.full(len(records), np.nan)
    )
    kinds = mot["motion_description"].to_numpy()
    # (11, n), a DBS lidar's (43, n)
    gram = mot[_gram_rows(CROSS_WIND_COLUMNS[0] in mot)].to_numpy(dtype=float).T
    use = np.isfinite(s) & np.isfinite(r) & (s > 0) & (r > 0) & np.all(np.isfinite(gram), axis=0)
    return (s[use], r[use], np.ascontiguousarray(gram[:, use])), use, kinds


def fit_subsample(records: pd.DataFrame, max_records: int) -> np.ndarray:
    """Which records a fit on at most ``max_records`` uses: a stratified subsample.

    The strata are the heights (column ``height_m``, if present) crossed with 1-m/s bins
    of ``hws_mean_ms`` (m/s). Each stratum gets its share of ``max_records`` in proportion
    to its size (largest remainder), taken evenly spaced through the stratum in the table's
    order (in time, for a campaign), so that the subsample keeps the campaign's mix of
    heights, wind speeds and seasons. Deterministic: no random numbers.

    Parameters
    ----------
    records : pandas.DataFrame
        The usable records, in time order.
    max_records : int
        Most records to keep (records).

    Returns
    -------
    numpy.ndarray of bool, shape (len(records),)
        All True when ``len(records) <= max_records``.
    """
    n = len(records)
    if n <= max_records:
        return np.ones(n, dtype=bool)
    speed = np.floor(records["hws_mean_ms"].to_numpy(dtype=float))
    height = records["height_m"].to_numpy(dtype=float) if "height_m" in records else np.zeros(n)
    strata = pd.MultiIndex.from_arrays([height, speed]).factorize()[0]
    sizes = np.bincount(strata)
    share = sizes * (max_records / n)
    quota = np.floor(share).astype(int)
    spare = max_records - int(quota.sum())
    quota[np.argsort(-(share - quota), kind="stable")[:spare]] += 1
    keep = np.zeros(n, dtype=bool)
    for k in np.flatnonzero(quota):
        members = np.flatnonzero(strata == k)
        keep[members[((np.arange(quota[k]) + 0.5) * sizes[k] / quota[k]).astype(int)]] = True
    return keep


#: Largest relative change of any record's sigma_Z between the hull response's lower end (0)
#: and its posterior's 95 % quantile below which the hull response is left out of the
#: convergence check (-): its draws then change no corrected TI by more than this share of
#: the motion term.
HULL_NEGLIGIBLE_SIGMA_Z_SHARE = 0.01


def _hull_response_negligible(nat: dict[str, np.ndarray], gram: np.ndarray) -> bool:
    """True when the hull response's posterior (95 % quantile against 0) changes no
    record's sigma_Z by more than :data:`HULL_NEGLIGIBLE_SIGMA_Z_SHARE`, at the median lever
    arm and motion scale; ``gram`` (11, n), a DBS lidar's (43, n), as
    :func:`_record_observations` returns it."""
    if not gram.shape[1]:
        return True
    g = dict(zip(_gram_rows(gram.shape[0] > 11), gram, strict=True))
    lever = float(np.median(nat["lever_arm_m"]))
    scale = float(np.median(nat["motion_scale"]))
    h95 = float(np.quantile(nat["hull_response"], 0.95))
    s0 = gram_sigma_z_ms(g, lever_arm_m=lever, hull_response=0.0, motion_scale=scale)
    s1 = gram_sigma_z_ms(g, lever_arm_m=lever, hull_response=h95, motion_scale=scale)
    with np.errstate(invalid="ignore", divide="ignore"):
        rel = np.abs(s1 - s0) / s0
    return bool(np.nanmax(np.where(s0 > 0, rel, 0.0)) <= HULL_NEGLIGIBLE_SIGMA_Z_SHARE)


def _start(lever_arm_prior):
    """Starting point of the mode search (sampler coordinates: rho, log kappa, log kappa_z,
    L, log k, log h, log rho_sd)."""
    return np.array(
        [
            0.0,
            np.log(0.05),
            np.log(0.15),
            2.0 if lever_arm_prior is None else lever_arm_prior[0],
            0.0,
            np.log(0.3),
            np.log(0.1),
        ]
    )


def fit_record_model(
    records: pd.DataFrame,
    *,
    surrogate=None,
    settings: SamplerSettings = SamplerSettings(),
    seed,
    priors: Priors = Priors(),
    lever_arm_prior: tuple[float, float] | None = None,
    scan_period_s: float | None = None,
    pair_log_sd=None,
    lidar=None,
    hull="wave_follower",
    translation: bool = True,
) -> GlobalFit:
    """Posterior of the record model's parameters (:data:`RECORD_MODEL_NAMES`).

    Every record with a finite floating-lidar std, reference std and motion description
    is used, whatever its bin (bins are for reporting; a record's sigma_Z comes from its
    own motion), up to ``settings.record_fit_max_records``: beyond, a stratified
    subsample of them (:func:`fit_subsample`).

    Parameters
    ----------
    records : pandas.DataFrame
        Records with ``hws_mean_ms``, ``hws_std_ms``, ``ref_hws_std_ms`` and the motion
        columns :func:`~flidar_uq.inference.record_motion.per_record_motion` reads.
    surrogate : SigmaZSurrogate, optional
        A CW lidar's sigma_Z surrogate (default: the lidar's).
    settings : SamplerSettings
    seed : int or numpy.random.SeedSequence
    priors : Priors
    lever_arm_prior : (float, float), optional
        Mean and sd (m) of the lever arm from the buoy's geometry (config).
    scan_period_s : float, optional
        A CW lidar's scan duration (s); default the lidar's ``scan_period_s``.
    pair_log_sd : array_like, shape (n_records,), optional
        With a reference lidar: the std of ``log(s / r)`` that the two lidars' sampling
        against each other gives alone (-), per record
        (:func:`flidar_uq.correction.propagation.reference_pair_log_sd`). It scatters the
        turbulent part ``r`` (``(p r dmu/dr)^2`` in ``tau^2``, module docstring), so that
        ``kappa`` is the floating lidar's own noise beyond it. Default None: 0 (a cup or
        sonic: ``kappa`` is the floating-lidar-vs-point scatter itself).
    lidar : str, LidarGeometry or mapping, optional
        The floating lidar (config ``campaign.lidar``), default the ZephIR 300: a DBS
        lidar's records get its own sigma_Z (:func:`~flidar_uq.inference.record_motion.motion_gram`).
    hull : str
        The reference hull whose translation the hull response scales (config
        ``inference.hull_reference``, :data:`flidar_uq.physics.hull.HULLS`; default the
        wave follower); ``info["hull_reference"]`` records it for the propagation.
    translation : bool
        False: the hull's translation left out whatever the record columns hold (the
        ``"rotation_only"`` hull model).

    Returns
    -------
    GlobalFit
        Draws of the seven parameters; ``info["n_records"]`` the records fitted and
        ``info["n_records_usable"]`` those that could have been; ``info["loo"]`` holds ``model="record"`` and the
        PSIS-LOO elpd; ``pointwise_loo`` (:meth:`~GlobalFit.loo`) the PSIS-LOO per record,
        computed in blocks of records from the thinned draws (``log_lik`` is None: the
        (draws x records) pointwise log-likelihood is never held whole, and
        :func:`~flidar_uq.inference.save_fit` would store only its LOO anyway);
        ``info["motion_scale_warning"]`` is set when the median
        ``motion_scale`` leaves [0.8, 1.25] (the per-record motion model does not explain
        the data: check the lidar type, the IMU columns and the lever arm);
        ``info["lever_arm_warning"]`` when the lever arm is implausible
        (:func:`lever_arm_check`); ``info["hull_response_identified"]`` False when no
        record has a translation the hull response scales (its draws are then its
        prior's, and it is left out of the convergence check and ``diagnostics``);
        ``info["hull_response_negligible"]`` True when its posterior, though identified,
        changes no record's sigma_Z by more than
        :data:`HULL_NEGLIGIBLE_SIGMA_Z_SHARE` (also left out of the check).
    """
    for c in ("hws_mean_ms", "hws_std_ms"):
        if c not in records:
            raise ValueError(f"fit_record_model: records lack column {c!r}")
    if lever_arm_prior is not None:
        mean, sd = (float(x) for x in lever_arm_prior)
        if not (mean >= 0 and sd > 0):
            raise ValueError(
                f"fit_record_model: lever_arm_prior=({mean}, {sd}) needs mean >= 0 m, sd > 0 m"
            )
        lever_arm_prior = (mean, sd)
    seedseq = as_seedsequence(seed)
    hull = get_hull(hull).name
    (s, r, gram), use, kinds = _record_observations(
        records, surrogate, scan_period_s, lidar, hull, translation
    )
    n_usable = int(s.size)
    keep = fit_subsample(records.loc[use], settings.record_fit_max_records)
    if not keep.all():
        s, r, gram = s[keep], r[keep], np.ascontiguousarray(gram[:, keep])
        use = use.copy()
        use[np.flatnonzero(use)[~keep]] = False
    pair = None
    if pair_log_sd is not None:
        pair_all = np.asarray(pair_log_sd, dtype=float)
        if pair_all.shape != (len(records),) or np.any(~(pair_all[use] >= 0)):
            raise ValueError(
                f"fit_record_model: pair_log_sd must be {len(records)} values >= 0 (finite "
                f"where the record has a reference), got shape {pair_all.shape}"
            )
        pair = pair_all[use]
    args = (s, r, gram, priors, lever_arm_prior, pair)
    gs = settings.for_global_fit()
    x0 = _start(lever_arm_prior)
    init = laplace_init(log_prob_record_model, args, x0, _broad(lever_arm_prior))
    ndim = len(RECORD_MODEL_NAMES)

    # the hull response acts only through records with a translation it scales: without
    # any (rotation only, or every translation measured) its draws are its prior's, and
    # waiting for the chains to mix over that prior's long log-scale tail buys nothing
    h_used = bool(np.any((gram[4] > 0) & (gram[10] == 0))) if gram.shape[1] else False
    negligible = []

    def check(ch):
        nat = natural_draws(ch)
        # a hull response whose whole posterior leaves every sigma_Z unchanged (a buoy that
        # only rotates: h at its lower end) is not waited for either
        negligible.append(h_used and _hull_response_negligible(nat, gram))
        checked = [
            n for n in RECORD_MODEL_NAMES if n != "hull_response" or (h_used and not negligible[-1])
        ]
        return _diagnostics(np.stack([nat[n] for n in checked], -1), checked, gs)

    chains, diag, reasons = _run_ensembles(
        log_prob_record_model, args, init, ndim, gs, seedseq, check, label="record model"
    )
    thin = _thin(chains, settings.ndraws)
    draws = natural_draws(thin)
    reasons = list(reasons)
    # without a reference std the posterior is the prior: an answer with the prior's
    # (wide) uncertainty, not a convergence failure (info["prior_only"] says so)
    prior_only = s.size == 0
    loo = None if prior_only else _record_loo(thin.reshape(-1, ndim), s, r, gram, pair)
    k_med = float(np.median(draws["motion_scale"]))
    info = {
        "n_records": int(s.size),
        "n_records_usable": n_usable,
        "prior_only": prior_only,
        "hull_response_identified": h_used,
        "hull_response_negligible": bool(negligible and negligible[-1]),
        "hull_reference": hull,
        "excluded_bins": [],
        "loo": {"model": "record", **({"record_elpd": loo["elpd"]} if loo else {})},
        "motion_description_counts": {
            str(k): int(v) for k, v in pd.Series(kinds[use]).value_counts().sort_index().items()
        },
        "lever_arm_prior": list(lever_arm_prior) if lever_arm_prior else None,
        # kappa is the floating lidar's noise beyond the two lidars' sampling scatter
        "pair_log_sd_median": None if pair is None or not pair.size else float(np.median(pair)),
        "rho_mass_beyond_0p98": float(np.mean(np.abs(draws["rho"]) > 0.98)),
        "constant": {"record_index": np.asarray(records.index)[use]},
    }
    if not 0.8 <= k_med <= 1.25:
        info["motion_scale_warning"] = (
            f"motion_scale {k_med:.2f} outside [0.8, 1.25]: the per-record motion model "
            "does not explain the data (check the lidar type, IMU columns and lever arm)"
        )
    lever_warning = lever_arm_check(draws["lever_arm_m"], lever_arm_prior)
    if lever_warning:
        info["lever_arm_warning"] = lever_warning
    return GlobalFit(
        draws=draws,
        log_lik=None,
        diagnostics=diag,
        failure_reasons=reasons,
        info=info,
        pointwise_loo=loo,
    )


#: Largest plausible height (m) of a floating lidar's head above its buoy's rotation centre:
#: the heads of floating-lidar buoys sit 1-4 m above the waterline and the centres of
#: rotation of their hulls near or below it, so a fitted lever arm beyond this length is
#: the fit absorbing motion the model lacks, not geometry.
LEVER_ARM_PLAUSIBLE_MAX_M = 8.0
#: Distance (m) from the configured lever arm beyond which the fit contradicts the geometry
#: (at least this much and 3 prior standard deviations): the tolerance within which the
#: physics-mode fits recover the true lever arm.
LEVER_ARM_TOLERANCE_M = 0.5


def lever_arm_check(lever_arm_draws_m, lever_arm_prior=None) -> str:
    """The lever arm's plausibility check: "" when plausible, else the reason (one line).

    Parameters
    ----------
    lever_arm_draws_m : array_like
        Posterior draws of the lever arm (m).
    lever_arm_prior : (float, float), optional
        Mean and sd (m) of the configured lever arm (the buoy's geometry). With it, a
        posterior median farther from the mean than ``max(LEVER_ARM_TOLERANCE_M, 3 sd)``
        is implausible; without it, a median beyond :data:`LEVER_ARM_PLAUSIBLE_MAX_M`.
    """
    med = float(np.median(np.asarray(lever_arm_draws_m, dtype=float)))
    if not np.isfinite(med):
        return ""
    if lever_arm_prior is not None:
        mean, sd = (float(x) for x in lever_arm_prior)
        tol = max(LEVER_ARM_TOLERANCE_M, 3.0 * sd)
        if abs(med - mean) > tol:
            return (
                f"lever_arm_m {med:.2f} m is {abs(med - mean):.2f} m from the configured "
                f"{mean:.2f} m (tolerance {tol:.2f} m): the motion model does not match the "
                "buoy (check inference.lever_arm_m, the hull and the IMU's frame)"
            )
        return ""
    if med > LEVER_ARM_PLAUSIBLE_MAX_M:
        return (
            f"lever_arm_m {med:.2f} m exceeds the {LEVER_ARM_PLAUSIBLE_MAX_M:g} m a floating "
            "lidar's head can sit above its buoy's rotation centre: the fit absorbs motion "
            "the model lacks (check the hull's translation columns and the lidar type)"
        )
    return ""


def _record_loo(theta, s, r, gram, pair):
    """PSIS-LOO of the record model over the draws ``theta`` (n_draws, 7), computed in blocks
    of records (:func:`~flidar_uq.inference.loo._loo_chunked`): the (draws x records)
    pointwise log-likelihood (1.26 GB in float64 for a year at 3 heights) is never held
    whole; the result equals PSIS-LOO on the whole matrix."""
    pair_sq = None if pair is None else pair**2

    def pointwise(sl):
        return _record_loglik_pointwise(
            theta, s[sl], r[sl], gram[:, sl], 0.0 if pair_sq is None else pair_sq[sl]
        )

    return _loo_chunked(pointwise, s.size, n_samples=theta.shape[0])


#: Hull models of the record model's selection (:func:`fit_record_model_selecting_hull`).
HULL_MODELS = ("auto", "rotation_only", "translating")

#: LOO margin: the translating hull model is kept only when its elpd exceeds the
#: rotation-only model's by more than this many standard errors of the difference (and by
#: more than :data:`HULL_ELPD_MIN`), the usual reading of a PSIS-LOO comparison (Vehtari et
#: al. 2017; Sivula et al. 2022: differences below ~4 are not distinguishable from noise).
HULL_SE_MARGIN = 2.0
HULL_ELPD_MIN = 4.0


#: Reference hulls that ``hull="auto"`` (config ``inference.hull_reference: auto``)
#: compares, simplest first: the wave follower (the surface's orbital motion at every
#: period) and a reduced response (a large discus buoy's oscillators, which respond less
#: and lag below their natural periods; :data:`flidar_uq.physics.hull.HULLS`).
REFERENCE_HULL_CANDIDATES = ("wave_follower", "discus_buoy")


def _loo_keeps(more: GlobalFit, simpler: GlobalFit) -> tuple[bool, float, float]:
    """Whether PSIS-LOO prefers ``more`` to ``simpler`` by more than ``max(HULL_ELPD_MIN,
    HULL_SE_MARGIN se)``; the elpd difference and its se (NaN without a comparison)."""
    a, b = more.pointwise_loo, simpler.pointwise_loo
    if a is None or b is None or a["elpd_i"].shape != b["elpd_i"].shape:
        return True, float("nan"), float("nan")  # no comparison possible: the fuller one
    diff, se = _loo_compare(a, b)
    return bool(diff > max(HULL_ELPD_MIN, HULL_SE_MARGIN * se)), diff, se


def fit_record_model_selecting_hull(
    records: pd.DataFrame, *, hull_model: str = "auto", hull: str = "auto", **kw
):
    """The record model with the simplest hull description the data support.

    Two nested descriptions of the buoy (docs/inference.md, "The hull"):

    * ``"rotation_only"``: the buoy rotates about a fixed centre (the hull-translation
      terms of :func:`~flidar_uq.inference.record_motion._translation_terms` are 0, so the
      hull response ``h`` keeps its prior and has no effect);
    * ``"translating"``: surge, sway and heave from the record's tilt spectrum through the
      fitted hull response ``h`` (0 rotation only, 1 the reference hull) times a reference
      hull's translation (``hull``).

    ``"auto"`` fits both on the same records and keeps the translating one only when its
    PSIS-LOO elpd is better by more than ``max(HULL_ELPD_MIN, HULL_SE_MARGIN se)``; without
    the translation columns it is the rotation-only model, unfitted twice. With
    ``hull="auto"`` the translating model's reference hull is chosen first, by the same
    rule among :data:`REFERENCE_HULL_CANDIDATES` (a later, less simple one only when it
    beats the one kept so far).

    Parameters
    ----------
    records : pandas.DataFrame
        As :func:`fit_record_model`.
    hull_model : {"auto", "rotation_only", "translating"}
    hull : str
        The reference hull (:data:`flidar_uq.physics.hull.HULLS`), or ``"auto"`` (the
        default, as config ``inference.hull_reference``).
    **kw
        Passed to :func:`fit_record_model`.

    Returns
    -------
    GlobalFit
        The kept model's fit; ``info["hull_model"]`` the kept description,
        ``info["hull_reference"]`` its reference hull; ``info["hull_model_comparison"]``
        (with ``"auto"`` and both fitted) the elpd of each, their difference and its
        standard error; ``info["hull_reference_comparison"]`` (with ``hull="auto"`` and
        translation columns) each candidate reference's elpd, the difference of each
        later one against the one kept before it, its se and the kept reference.
    """
    if hull_model not in HULL_MODELS:
        raise ValueError(
            f"fit_record_model_selecting_hull: hull_model={hull_model!r}, expected one of "
            f"{', '.join(HULL_MODELS)}"
        )
    lidar = kw.get("lidar")
    dbs = lidar is not None and get_lidar(lidar).kind == "dbs"  # its reference: the follower
    if hull == "auto":
        refs = REFERENCE_HULL_CANDIDATES[:1] if dbs else REFERENCE_HULL_CANDIDATES
    else:
        refs = (get_hull(hull).name,)
    desc = describe_motion(records, lidar=lidar)
    has_translation = bool((desc["translation_description"] != "none").any())
    # every candidate from the same random streams (common random numbers), whether
    # ``seed`` is an int or a SeedSequence whose spawns the first fit would advance
    ss = as_seedsequence(kw.pop("seed", None))
    state = {"spawn_key": ss.spawn_key, "pool_size": ss.pool_size}
    state["n_children_spawned"] = ss.n_children_spawned

    def fit(**extra):
        seed = np.random.SeedSequence(ss.entropy, **state)
        return fit_record_model(records, seed=seed, **kw, **extra)

    if hull_model == "rotation_only" or not has_translation:
        rot = fit(translation=False, hull=refs[0])
        rot.info["hull_model"] = "rotation_only"
        return rot
    full = fit(hull=refs[0])
    rows = [{"hull_reference": refs[0], "elpd": _elpd(full)}]
    for ref in refs[1:]:
        other = fit(hull=ref)
        better, diff, se = _loo_keeps(other, full)
        rows.append(
            {"hull_reference": ref, "elpd": _elpd(other), "elpd_difference": diff,
             "elpd_difference_se": se, "against": full.info["hull_reference"]}
        )  # fmt: skip
        full = other if better else full
    full.info["hull_model"] = "translating"
    if len(refs) > 1:
        full.info["hull_reference_comparison"] = {
            "candidates": rows,
            "kept": full.info["hull_reference"],
        }
    if hull_model == "translating":
        return full
    rot = fit(translation=False, hull=full.info["hull_reference"])
    rot.info["hull_model"] = "rotation_only"
    if full.pointwise_loo is None or rot.pointwise_loo is None:
        return full  # no comparison possible: the fuller description
    better, diff, se = _loo_keeps(full, rot)
    keep = full if better else rot
    keep.info["hull_model_comparison"] = {
        "translating_elpd": full.pointwise_loo["elpd"],
        "rotation_only_elpd": rot.pointwise_loo["elpd"],
        "elpd_difference": diff,
        "elpd_difference_se": se,
        "kept": keep.info["hull_model"],
    }
    if "hull_reference_comparison" in full.info:
        keep.info["hull_reference_comparison"] = full.info["hull_reference_comparison"]
    return keep


def _elpd(fit: GlobalFit) -> float:
    return float("nan") if fit.pointwise_loo is None else float(fit.pointwise_loo["elpd"])
