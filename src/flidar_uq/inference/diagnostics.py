"""Convergence diagnostics: rank R-hat, bulk/tail ESS, autocorrelation times; thinning.

The rank R-hat and bulk ESS are those of Vehtari et al. (2021, Bayesian Analysis 16(2),
"Rank-normalization, folding, and localization: an improved R-hat"), computed as
arviz-stats computes them (``array_stats.rhat(method="rank")``, ``array_stats.ess(
method="bulk")``), with the rank-normalized draws shared between the two (arviz-stats
ranks them twice) and the average ranks from one sort; the autocorrelation times are
emcee's (``emcee.autocorr.integrated_time``, Sokal's window ``c = 5``) with the FFTs of all
walkers in one call. R-hat and bulk ESS equal arviz-stats' bit for bit, the autocorrelation
times emcee's to 1e-15 (tests/test_diagnostics.py);
``benchmarks/diagnostics_speed.py`` measures both.
"""

from __future__ import annotations

import functools

import numpy as np
from arviz_stats.base import array_stats
from scipy import special

# Blom's (1958) offset of the rank back-transformation, as arviz-stats uses it
_BLOM = 3 / 8

# Sokal's window constant of emcee's integrated_time
_SOKAL_C = 5


@functools.lru_cache(maxsize=8)
def _blom_normal_scores(n):
    """Normal scores of the ranks 1..n: ``ndtri((r - 3/8) / (n - 2 * 3/8 + 1))``."""
    scores = special.ndtri((np.arange(1, n + 1) - _BLOM) / (n - 2 * _BLOM + 1))
    scores.flags.writeable = False  # shared by every call with this n
    return scores


def _z_scale(x):
    """Rank-normalized values of each row of ``x`` (n_rows, n; finite): the normal
    quantiles of the Blom-transformed average ranks over the row (Vehtari et al. 2021,
    Eq. 14; arviz-stats ``_z_scale``, i.e. ``scipy.stats.rankdata(method="average")``
    and ``norm.ppf``, row by row). Ranks without ties take their score from a table."""
    rows, n = x.shape
    order = np.argsort(x, axis=-1)
    xs = np.take_along_axis(x, order, axis=-1)
    # runs of equal sorted values, numbered over the flattened rows (each row starts a run)
    new = np.ones(x.shape, dtype=bool)
    np.not_equal(xs[:, 1:], xs[:, :-1], out=new[:, 1:])
    new = new.ravel()
    starts = np.flatnonzero(new)
    ends = np.append(starts[1:], new.size)
    # a run at flat positions [i, j) of row r holds the ranks i+1-rn .. j-rn: mean (i+j+1)/2-rn
    rank = (starts + ends + 1) / 2.0 - (starts // n) * n
    whole = ends - starts == 1  # a single value: an integer rank, scored from the table
    score = np.empty(rank.size)
    score[whole] = _blom_normal_scores(n)[rank[whole].astype(np.intp) - 1]
    score[~whole] = special.ndtri((rank[~whole] - _BLOM) / (n - 2 * _BLOM + 1))
    z = np.empty(x.shape)
    np.put_along_axis(z, order, score[np.cumsum(new) - 1].reshape(rows, n), axis=-1)
    return z


def _rhat_of_split(z):
    """Split R-hat of z-scaled draws (n_params, n_split_chains, n_draws) (Eq. 4 of
    Vehtari et al. 2021; arviz-stats ``_rhat`` per parameter)."""
    n = z.shape[-1]
    between = n * np.var(np.mean(z, axis=-1), axis=-1, ddof=1)
    within = np.mean(np.var(z, axis=-1, ddof=1), axis=-1)
    with np.errstate(invalid="ignore", divide="ignore"):  # constant draws: NaN, a failure
        return np.sqrt((between / within + n - 1) / n)


def _rank_rhat_and_bulk_ess(pooled):
    """Rank R-hat (max of bulk and folded) and bulk ESS of ``pooled`` (n_params, n_chains,
    n_draws), every parameter finite; the rank-normalized split chains shared by both."""
    p, c, n = pooled.shape
    half = n // 2
    split = np.concatenate([pooled[..., :half], pooled[..., n - half :]], axis=1)
    flat = split.reshape(p, -1)
    z_bulk = _z_scale(flat).reshape(split.shape)
    folded = np.abs(flat - np.median(flat, axis=-1, keepdims=True))
    z_fold = _z_scale(folded).reshape(split.shape)
    rhat = np.maximum(_rhat_of_split(z_bulk), _rhat_of_split(z_fold))
    # arviz-stats' ESS of the z-scaled split chains (Geyer's initial monotone sequence)
    ess = np.array([array_stats._ess(z_bulk[k]) for k in range(p)])
    return rhat, ess


def _autocorr_times(chains):
    """Integrated autocorrelation time per ensemble and parameter, shape (nens, ndim):
    emcee's ``integrated_time(c=5)`` of each ensemble's (nsteps, nwalkers) chains (the
    walkers' normalised autocorrelation functions averaged, Sokal's adaptive window;
    Goodman & Weare 2010, Sec. 3), NaN for a constant (stuck) chain. The functions of all
    walkers and parameters come from one real FFT (emcee: one complex FFT per walker)."""
    nens, n_t, n_w, n_d = chains.shape
    nfft = 2 * (1 << max(n_t - 1, 0).bit_length())  # twice emcee's next power of two
    x = np.moveaxis(chains, 1, -1)  # (nens, n_w, n_d, n_t)
    with np.errstate(all="ignore"):  # a stuck (constant) chain gives NaN: a failure
        f = np.fft.rfft(x - x.mean(axis=-1, keepdims=True), n=nfft, axis=-1)
        acf = np.fft.irfft(f.real**2 + f.imag**2, n=nfft, axis=-1)[..., :n_t]
        acf /= acf[..., :1]
        # the walkers' functions summed one after the other, as emcee sums them
        mean_acf = np.zeros((nens, n_d, n_t))
        for k in range(n_w):
            mean_acf += acf[:, k]
        mean_acf /= n_w
        taus = 2.0 * np.cumsum(mean_acf, axis=-1) - 1.0
        inside = np.arange(n_t) < _SOKAL_C * taus
    window = np.where(inside.any(axis=-1), np.argmin(inside, axis=-1), n_t - 1)
    return np.take_along_axis(taus, window[..., None], axis=-1)[..., 0]


def _diagnostics(chains, names, settings):
    """Rank R-hat across ensembles (walkers pooled), bulk/tail ESS, autocorrelation times."""
    nens, nsteps, nwalk, ndim = chains.shape
    # each ensemble's walkers pooled into ONE chain, walker-major (walker 0's trace, then 1...)
    pooled = np.transpose(chains, (3, 0, 2, 1)).reshape(ndim, nens, nwalk * nsteps)
    rhat = np.full(ndim, np.nan)
    ess_b = np.full(ndim, np.nan)
    finite = np.all(np.isfinite(pooled), axis=(1, 2))
    if nwalk * nsteps >= 4 and finite.any():
        rhat[finite], ess_b[finite] = _rank_rhat_and_bulk_ess(pooled[finite])
    if not finite.all():  # arviz-stats' verdict (NaN) on non-finite draws
        bad = ~finite
        rhat[bad] = array_stats.rhat(pooled[bad], chain_axis=-2, draw_axis=-1, method="rank")
        ess_b[bad] = array_stats.ess(pooled[bad], chain_axis=-2, draw_axis=-1, method="bulk")
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
