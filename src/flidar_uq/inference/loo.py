"""Model comparison and checks: PSIS-LOO (vectorised) and the posterior predictive check of the
periods' kurtosis.
"""

from __future__ import annotations

import numpy as np


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
    suite checks it against ``arviz_stats`` to rounding error (1e-14 in ``elpd_i`` and
    ``p_loo_i``, 2e-15 in ``pareto_k``). Vectorised rather than the library call because
    the pipeline computes PSIS-LOO for every fit and ``arviz_stats``' loop over the
    observations is 6-8 times slower at the pipeline's sizes (CPU time, 1,000 draws: a
    bin's 60 records 23 ms against 3.7 ms, 400 records 156 ms against 21 ms, i.e. 16-47 %
    more per bin fit; a campaign's 24,522 records 9.1 s against 1.1 s;
    ``benchmarks/loo_speed.py``).

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
    (e.g. a degenerate, constant log-likelihood) or gives a non-finite elpd. Computed in
    blocks of :func:`_loo_chunked`'s default size: the same values as one block, and on
    a campaign's records (1,000 draws x 24,522) 1.2 s against 7.6 s for one block.
    """
    n = log_lik.shape[-1]
    flat = log_lik.reshape(-1, n)
    return _loo_chunked(lambda sl: flat[:, sl], n, n_samples=flat.shape[0])


#: elements (draws x observations) of one chunk of :func:`_loo_chunked`'s default: 16 MB
#: per float64 array, so its temporaries stay small whatever the number of observations
_LOO_CHUNK_ELEMENTS = 2**21


def _loo_chunked(pointwise, n_obs, *, n_samples=None, chunk=None):
    """PSIS-LOO of a pointwise log-likelihood that is computed one block of observations
    at a time and never held whole; returns :func:`_loo`'s dict or None.

    PSIS smooths each observation's importance ratios on their own, so the pointwise
    ``elpd_i``, ``pareto_k`` and ``p_loo_i`` of a block are those of the whole matrix
    (the same operations on the same rows); ``elpd``, ``se`` and ``p_loo`` are their sums
    over all observations, as in :func:`_loo`.

    Parameters
    ----------
    pointwise : callable
        ``pointwise(sl) -> numpy.ndarray, shape (n_samples, len(sl))``: the log-likelihood
        of the observations ``sl`` (a slice) under every posterior draw.
    n_obs : int
        Number of observations.
    n_samples : int, optional
        Number of draws; sets the default ``chunk`` so that a block holds about
        ``_LOO_CHUNK_ELEMENTS`` values.
    chunk : int, optional
        Observations per block (default from ``n_samples``).
    """
    if n_obs == 0:
        return None
    if chunk is None:
        chunk = max(1, _LOO_CHUNK_ELEMENTS // max(int(n_samples or 1), 1))
    parts = []
    try:
        for c in range(0, n_obs, chunk):
            parts.append(_psis_loo(pointwise(slice(c, min(c + chunk, n_obs)))))
    except ValueError:
        return None
    elpd_i, pareto_k, p_loo_i = (np.concatenate(x) for x in zip(*parts, strict=True))
    if not np.all(np.isfinite(elpd_i)):
        return None
    n = n_obs
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
