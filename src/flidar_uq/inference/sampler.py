"""Ensemble sampling: independent ensembles as blocks of one emcee sampler, burn-in,
proposal fitting and the adaptive extension of the main phase.
"""

from __future__ import annotations

import logging
import time

import emcee
import numpy as np
from emcee.ensemble import walkers_independent
from scipy import optimize, stats

from flidar_uq.inference.moves import BlockDEMove, BlockDESnookerMove, StudentTIndependenceProposal

log = logging.getLogger(__name__)

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

# a walker whose log-prob lies more than chi2_ndim(1 - _STRAGGLER_TAIL) / 2 below its
# ensemble's best at the end of a burn-in phase is a straggler (a normal posterior holds
# this share of its mass there)
_STRAGGLER_TAIL = 1e-6

# burn-in rounds (nburn steps each) added at most while the independence move's expected
# acceptance stays below _INDEPENDENCE_FULL_ACCEPTANCE
_ADAPT_ROUNDS = 3


# central-difference step of the Laplace Hessian (sampler coordinates): its stencil
# reaches 2 steps from the mode
_HESSIAN_STEP = 1e-4


def _fit_proposal(sampler, nens, start_frac):
    """Student-t proposal per ensemble block from a burn-in phase's samples.

    Uses the steps from ``start_frac`` of the phase on, and only samples inside the 99.9 %
    highest-density region of a normal approximation (log-prob within
    ``chi2_ndim(0.999) / 2`` of the block's best), so that a few walkers still far from the
    bulk do not inflate the proposal (:func:`_reset_stragglers` then moves them).
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


def _reset_stragglers(state, nens) -> int:
    """Move the walkers that a burn-in phase left far in the tail onto their ensemble's best.

    A walker whose log-prob lies more than ``chi2_ndim(1 - _STRAGGLER_TAIL) / 2`` below the
    best of its own ensemble takes the position and log-prob of that ensemble's ``k``-th
    best walker (the ``k``-th straggler, best first; no random numbers, so a burn-in
    without stragglers is left as it was). Neither main move brings such a walker back: the
    independence move's weight ``p / q`` is huge where the Student-t's tail is thin, so
    its proposals are refused, and the DE steps are the bulk's size. On a DBS campaign two
    walkers of one ensemble sat at ``kappa_z`` ~ 1e-6 (log-prob 25 below the bulk's best)
    for 12,000 steps, halving the tail ESS. Only the main phase's start changes, so its
    chain is still a valid one. ``state``: emcee's State, changed in place. Returns the
    number of walkers moved.
    """
    coords, lp = state.coords, state.log_prob
    nw = len(lp) // nens
    cut = 0.5 * stats.chi2.isf(_STRAGGLER_TAIL, coords.shape[1])
    moved = 0
    for b in range(nens):
        idx = np.arange(b * nw, (b + 1) * nw)
        finite = np.where(np.isfinite(lp[idx]), lp[idx], -np.inf)
        order = idx[np.argsort(-finite, kind="stable")]
        bad = idx[~(finite >= finite.max() - cut)]
        for k, i in enumerate(bad):
            j = order[k % max(nw - len(bad), 1)]
            coords[i], lp[i] = coords[j], lp[j]
            if state.blobs is not None:
                state.blobs[i] = state.blobs[j]
        moved += len(bad)
    return moved


def _sampler(log_prob, args, ndim, nwalk, moves, random_state):
    sm = emcee.EnsembleSampler(nwalk, ndim, log_prob, args=args, moves=moves, vectorize=True)
    sm.random_state = random_state
    return sm


def _run_ensembles(log_prob, args, init_fn, ndim, settings, seedseq, check, *, label=None):
    """Run ``settings.nensembles`` independent ensembles as blocks of one emcee sampler.

    Each ensemble's initial positions come from its own child of ``seedseq`` (``init_fn``:
    overdispersed relative to the posterior); its moves use only its own walkers
    (:class:`~flidar_uq.inference.moves.BlockDEMove`, a per-block Student-t), so the ensembles are independent
    chains. Burn-in, first half: DE + DE-snooker moves; second half: the main kernel with
    a Student-t fitted to the first half; at the end of each burn-in phase the walkers
    left far in the tail are moved onto their ensemble's best (:func:`_reset_stragglers`).
    Main phase (a
    fixed kernel): DE + the independence Student-t Metropolis move refitted to the second
    half, its weight ``independence_weight`` scaled down when the Student-t fits the
    posterior poorly (:func:`_independence_acceptance` below
    ``_INDEPENDENCE_FULL_ACCEPTANCE``; all adaptation ends with the burn-in).

    The main phase is extended (all ensembles equally, :func:`_extension_target`) and ALL
    convergence criteria re-checked with ``check`` after every extension, until they pass
    with the chain longer than ``1.1 n_autocorr`` autocorrelation times, or the chain
    reaches ``max_step_factor * nsteps``; only then does a missed criterion stand.

    Parameters
    ----------
    check : callable
        ``check(chains) -> (diagnostics, failure_reasons)`` on chains of shape
        (nensembles, nsteps', nwalkers, ndim): the final convergence verdict
        (:func:`~flidar_uq.inference.diagnostics._diagnostics` in the reported
        coordinates), with a ``"tau"`` per parameter in ``diagnostics``.
    label : str, optional
        If given, each phase's end (steps so far, seconds since the start) is logged at
        INFO under this name: the progress of a long single fit (the record model).

    Returns
    -------
    chains, diagnostics, failure_reasons
        The chains, shape (nensembles, nsteps', nwalkers, ndim), and ``check`` of them.
    """
    nens, nw = settings.nensembles, settings.nwalkers
    t0 = time.monotonic()

    def phase_done(what, steps):
        if label is not None:
            log.info(
                "%s: %s, %d steps per walker, %.1f s", label, what, steps, time.monotonic() - t0
            )

    *children, ss_mcmc, ss_check = seedseq.spawn(nens + 2)
    p0 = np.concatenate([init_fn(np.random.default_rng(c), nw) for c in children])
    random_state = np.random.RandomState(ss_mcmc.generate_state(4, np.uint32)).get_state()
    burn_moves = [
        (BlockDEMove(nens), 1.0 - settings.snooker_weight),
        (BlockDESnookerMove(nens), settings.snooker_weight),
    ]
    burn = _sampler(log_prob, args, ndim, nens * nw, burn_moves, random_state)
    nburn = max(settings.nburn, 4)
    state = burn.run_mcmc(p0, nburn // 2, progress=False)
    phase_done("burn-in, first half", nburn // 2)
    random_state = burn.random_state

    def main_moves(prop, weight):
        moves = [(BlockDEMove(nens), 1.0 - weight)]
        if weight > 0:
            moves.append((emcee.moves.MHMove(prop), weight))
        return moves

    # second half of the burn-in with the main kernel fitted to the first half, then the
    # stragglers moved, so the final fit sees the bulk only
    # (a collapsed ensemble is left to fail the diagnostics rather than raise here)
    w_ind = settings.independence_weight
    prop = _fit_proposal(burn, nens, _FIT_FRAC) if w_ind > 0 else None
    burn2 = _sampler(log_prob, args, ndim, nens * nw, main_moves(prop, w_ind), random_state)
    state = burn2.run_mcmc(state, nburn - nburn // 2, skip_initial_state_check=True)
    stragglers = _reset_stragglers(state, nens)
    phase_done("burn-in done", nburn)
    last, burned = burn2, nburn
    if w_ind > 0:
        prop = _fit_proposal(burn2, nens, 0.0)
        # the independence move's share follows how well the fitted Student-t matches the
        # posterior (its expected acceptance rate, worst ensemble): a non-Gaussian posterior
        # (a boundary, a banana) is left mostly to DE
        acc = _independence_acceptance(prop, state, log_prob, args, nens, ss_check)
        # a slowly mixing burn-in leaves a Student-t fitted to walkers that have not yet
        # spread over the posterior: more burn-in rounds with the main kernel, each refitting
        # the Student-t to the round before, while its acceptance falls short (all adaptation
        # still ends before the main phase)
        for ss_round in ss_check.spawn(_ADAPT_ROUNDS):
            if acc >= _INDEPENDENCE_FULL_ACCEPTANCE:
                break
            w_round = w_ind * min(1.0, acc / _INDEPENDENCE_FULL_ACCEPTANCE)
            last = _sampler(
                log_prob, args, ndim, nens * nw, main_moves(prop, w_round), last.random_state
            )
            state = last.run_mcmc(state, nburn, skip_initial_state_check=True)
            stragglers += _reset_stragglers(state, nens)
            burned += nburn
            prop = _fit_proposal(last, nens, 0.0)
            acc = _independence_acceptance(prop, state, log_prob, args, nens, ss_round)
            phase_done(f"burn-in extended (independence acceptance {acc:.2f})", burned)
        w_ind *= min(1.0, acc / _INDEPENDENCE_FULL_ACCEPTANCE)
    if stragglers:
        log.info(
            "%s%d walker(s) left in the tail by the burn-in moved onto their ensemble's best",
            f"{label}: " if label is not None else "",
            stragglers,
        )
    main = _sampler(log_prob, args, ndim, nens * nw, main_moves(prop, w_ind), last.random_state)
    main.run_mcmc(state, settings.nsteps, skip_initial_state_check=True)
    phase_done("main phase", burned + settings.nsteps)

    def chains():
        return np.moveaxis(main.get_chain().reshape(-1, nens, nw, ndim), 1, 0)

    # adaptive length (emcee practice): extend ALL ensembles equally and re-check every
    # criterion (the final verdict's own diagnostics) after each extension, until all pass
    # with n_autocorr (+10 %) autocorrelation times, up to max_step_factor * nsteps
    nsteps = settings.nsteps
    cap = int(settings.max_step_factor * settings.nsteps)
    ch = chains()
    diag, reasons = check(ch)
    while nsteps < cap:
        need = _extension_target(nsteps, diag, reasons, settings)
        if need <= nsteps:
            break
        extra = min(need, cap) - nsteps
        why = "; ".join(reasons) or f"chain < {1.1 * settings.n_autocorr:g} tau"
        main.run_mcmc(None, extra, skip_initial_state_check=True)
        nsteps += extra
        phase_done(f"main phase extended ({why})", burned + nsteps)
        ch = chains()
        diag, reasons = check(ch)
    return ch, diag, reasons


def _extension_target(nsteps, diag, reasons, settings):
    """Chain length (steps) to extend the main phase to; ``nsteps`` or less: stop.

    Met criteria and a chain longer than ``1.1 n_autocorr`` autocorrelation times (the
    largest over parameters and ensembles): stop. Otherwise the longest of: ``1.1
    n_autocorr tau`` steps, twice the length if tau is not finite, ``1.1 ess_min /
    ESS`` times the length for a bulk/tail ESS miss (ESS grows with the length), and
    1.5 times the length for any other miss (R-hat), so a near miss is always extended.
    """
    taus = [d["tau"] for d in diag.values()]
    tau = max(taus) if taus and all(np.isfinite(taus)) else float("nan")
    need = int(np.ceil(1.1 * settings.n_autocorr * tau)) if np.isfinite(tau) else 2 * nsteps
    if not reasons:
        return need
    ess = [min(d["ess_bulk"], d["ess_tail"]) for d in diag.values()]
    ess_min = min(ess) if ess else float("nan")
    if np.isfinite(ess_min) and 0 < ess_min < settings.ess_min:
        need = max(need, int(np.ceil(1.1 * nsteps * settings.ess_min / ess_min)))
    return max(need, int(np.ceil(1.5 * nsteps)))


#: restarts of the Nelder-Mead mode search from its own result (at most)
_MODE_RESTARTS = 8


def laplace_approximation(log_prob, args, x0) -> tuple[np.ndarray, np.ndarray]:
    """Posterior mode and the Hessian of the negative log posterior there (Laplace).

    The mode comes from Nelder-Mead on ``-log_prob(theta[None], *args)`` started at
    ``x0`` and restarted from its result while that improves (non-finite values count as
    1e300); the Hessian from central differences
    with step ``_HESSIAN_STEP`` (1e-4) in the sampler's coordinates. ``N(mode, inv(hessian))`` is the normal
    (Laplace) approximation of the posterior; it is exact for a Gaussian posterior and
    breaks where the posterior is skewed or its mode sits on (or near) the edge of the
    support (docs/inference.md, "Method frontier").

    Parameters
    ----------
    log_prob : callable
        Vectorised log posterior, ``log_prob(theta (n, ndim), *args) -> (n,)``.
    args : tuple
        Extra arguments of ``log_prob``.
    x0 : array_like, shape (ndim,)
        Starting point of the mode search (sampler coordinates).

    Returns
    -------
    mode : numpy.ndarray, shape (ndim,)
    hessian : numpy.ndarray, shape (ndim, ndim)
        Of ``-log_prob`` at ``mode`` (not necessarily positive definite).
    """
    x0 = np.asarray(x0, dtype=float)
    ndim = x0.size

    def neg_lp(th):
        v = -log_prob(th[None, :], *args)[0]
        return v if np.isfinite(v) else 1e300

    opts = {"xatol": 1e-5, "fatol": 1e-6, "maxiter": 4000}
    res = optimize.minimize(neg_lp, x0, method="Nelder-Mead", options=opts)
    # restarted from its own result until it stops improving: a simplex that collapsed in
    # a valley of several parameters (lever arm, motion scale, hull response) stalls short
    # of the mode
    for _ in range(_MODE_RESTARTS):
        again = optimize.minimize(neg_lp, res.x, method="Nelder-Mead", options=opts)
        if not again.fun < res.fun - 1e-6:
            break
        res = again
    mode = res.x
    h = _HESSIAN_STEP
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
    return mode, hess


def laplace_init(log_prob, args, x0, broad):
    """Overdispersed starting positions from a widened Laplace approximation.

    The posterior mode and Hessian of :func:`laplace_approximation` give a normal
    approximation; walkers start from it with ``_INIT_WIDENING`` times its sd
    (overdispersed relative to
    the posterior, so R-hat across ensembles stays meaningful, yet close enough for a
    short burn-in). Walkers outside the support, a parameter whose mode sits on the edge
    of the support (zero width), or all walkers when the Hessian is not positive definite
    or the ensemble would be degenerate, start from ``broad(rng, n)`` draws instead.

    Returns
    -------
    callable
        ``init(rng, nwalkers) -> (nwalkers, ndim)`` for :func:`_run_ensembles`.
    """
    mode, hess = laplace_approximation(log_prob, args, x0)
    ndim = mode.size
    try:
        chol = np.linalg.cholesky(np.linalg.inv(hess))
    except np.linalg.LinAlgError:
        chol = None

    def init(rng, nwalkers):
        if chol is None or not np.all(np.isfinite(chol)):
            return broad(rng, nwalkers)
        p0 = mode + _INIT_WIDENING * rng.standard_normal((nwalkers, ndim)) @ chol.T
        # a mode on a boundary (e.g. the lever arm at 0 m when the data hold none) gives a
        # direction of (numerically) zero width: start that parameter broad
        flat = p0.std(axis=0) < 1e-6
        if flat.any():
            p0[:, flat] = broad(rng, nwalkers)[:, flat]
        bad = ~np.isfinite(log_prob(p0, *args))
        p0[bad] = broad(rng, int(bad.sum()))
        # a near-singular approximation (prior-dominated, nearly collinear directions)
        # would fail emcee's check of the initial ensemble: start broad instead
        ok = walkers_independent(p0) and np.all(p0.std(axis=0) > 0)
        return p0 if ok else broad(rng, nwalkers)

    return init
