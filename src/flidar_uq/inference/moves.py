"""emcee moves of the sampler: block-wise DE and DE-snooker moves that own their parameters
and proposals (built on emcee's public ``Move.propose``, with the per-block hook names of
emcee's ``RedBlueMove``, ``setup`` / ``get_proposal``; nothing private of emcee read), and
the Student-t independence proposal.
"""

from __future__ import annotations

import emcee
import numpy as np


class BlockRedBlueMove(emcee.moves.Move):
    """A red-blue ensemble move applied within each of ``nblocks`` stacked ensembles.

    The sampler's walkers are ``nblocks`` independent ensembles of equal size, stored one
    after the other. Each block is split at random into ``nsplits`` sub-ensembles, and a
    walker's proposal uses only walkers of its own block (as
    :class:`emcee.moves.RedBlueMove` does within one ensemble), so the blocks stay
    independent Markov chains while one vectorised log-probability call serves all.

    Subclasses own their parameters and implement the hooks of emcee's ``RedBlueMove``
    (called here from :meth:`propose`): ``setup(coords)``
    (called with one block's walkers before each step) and ``get_proposal(s, c, random)``
    (one block: the moving sub-ensemble ``s``, the list ``c`` of complementary
    sub-ensembles), or, vectorised over the blocks, :meth:`get_block_proposal`.

    Parameters
    ----------
    nblocks : int
        Number of stacked ensembles.
    nsplits : int
        Sub-ensembles per block.
    """

    def __init__(self, nblocks, nsplits=2):
        self.nblocks = int(nblocks)
        self.nsplits = int(nsplits)

    def setup(self, coords):
        """emcee hook, called with one block's walkers, shape (nwalkers per block, ndim)."""

    def get_proposal(self, s, c, random):
        """emcee hook: ``(q, log_factors)`` for the sub-ensemble ``s`` of one block."""
        raise NotImplementedError("BlockRedBlueMove: a subclass implements get_proposal")

    def get_block_proposal(self, coords, sub, rest, random):
        """Proposals for the walkers ``sub`` (nblocks, ns) of all blocks.

        ``rest`` is the list of the complementary sub-ensembles' index arrays, each
        (nblocks, n_i). Default: :meth:`get_proposal` block by block. Returns ``q``
        (nblocks * ns, ndim) and the log factors (nblocks * ns,).
        """
        props = [
            self.get_proposal(coords[sub[b]], [coords[g[b]] for g in rest], random)
            for b in range(sub.shape[0])
        ]
        return np.concatenate([p[0] for p in props]), np.concatenate([p[1] for p in props])

    def propose(self, model, state):
        nwalk, _ = state.coords.shape
        nb = self.nblocks
        w = nwalk // nb
        k = self.nsplits
        self.setup(state.coords[:w])
        # a random split of every block; index arrays (nb, group size) per sub-ensemble
        perm = np.argsort(model.random.rand(nb, w), axis=1) + (w * np.arange(nb))[:, None]
        groups = [perm[:, j::k] for j in range(k)]
        accepted = np.zeros(nwalk, dtype=bool)
        for j in range(k):
            rest = [groups[i] for i in range(k) if i != j]
            q, f = self.get_block_proposal(state.coords, groups[j], rest, model.random)
            idx = groups[j].ravel()
            new_lp, _ = model.compute_log_prob_fn(q)
            acc = f + new_lp - state.log_prob[idx] > np.log(model.random.rand(idx.size))
            state.coords[idx[acc]] = q[acc]
            state.log_prob[idx[acc]] = new_lp[acc]
            accepted[idx[acc]] = True
        return state, accepted


class BlockDEMove(BlockRedBlueMove):
    """Differential-evolution move (Nelson et al. 2013, as :class:`emcee.moves.DEMove`)
    within each stacked ensemble, vectorised over the blocks.

    Walker ``sub[b, i]`` moves along the difference of two distinct walkers drawn from its
    own block's complementary set, scaled by ``gamma0 (1 + sigma N(0, 1))``.

    Parameters
    ----------
    nblocks : int
    sigma : float
        Relative sd of the stretch factor (emcee's default 1e-5).
    gamma0 : float, optional
        Mean stretch factor; default ``2.38 / sqrt(2 ndim)`` (ter Braak 2006).
    """

    def __init__(self, nblocks, sigma=1.0e-5, gamma0=None):
        super().__init__(nblocks, nsplits=2)
        self.sigma = float(sigma)
        self.gamma0 = gamma0
        self._g0 = gamma0

    def setup(self, coords):
        ndim = coords.shape[1]
        self._g0 = 2.38 / np.sqrt(2 * ndim) if self.gamma0 is None else self.gamma0

    def get_block_proposal(self, coords, sub, rest, random):
        rest = np.concatenate(rest, axis=1)
        nb, ns = sub.shape
        nc = rest.shape[1]
        i = random.randint(nc, size=(nb, ns))
        j = (i + random.randint(1, nc, size=(nb, ns))) % nc  # uniform over ordered pairs
        rows = np.arange(nb)[:, None]
        diffs = coords[rest[rows, j]] - coords[rest[rows, i]]
        gamma = self._g0 * (1.0 + self.sigma * random.randn(nb, ns, 1))
        q = (coords[sub] + gamma * diffs).reshape(nb * ns, -1)
        return q, np.zeros(nb * ns)


class BlockDESnookerMove(BlockRedBlueMove):
    """Differential-evolution snooker move (ter Braak & Vrugt 2008) within each stacked
    ensemble, block by block (4 sub-ensembles, as :class:`emcee.moves.DESnookerMove`).

    The proposal is owned here so that the results do not depend on the installed emcee.
    ``legacy_scaling=True`` (default) reproduces emcee 3.1's proposal bit for bit: the
    projection direction ``u = (x - z) / sqrt(|x - z|)`` and the factor
    ``(ndim - 1) / 2 log(|q - z| / |x - z|)``; emcee after 3.1.6 (dfm/emcee#531) uses the
    unit vector and ``(ndim - 1) log(...)`` (``legacy_scaling=False``). The sampler uses
    this move only in the first half of the burn-in, whose draws are discarded.

    Parameters
    ----------
    nblocks : int
    gammas : float
        Mean stretch factor (emcee's default 1.7).
    legacy_scaling : bool
        emcee 3.1's scaling (see above).
    """

    def __init__(self, nblocks, gammas=1.7, legacy_scaling=True):
        super().__init__(nblocks, nsplits=4)
        self.gammas = float(gammas)
        self.legacy_scaling = bool(legacy_scaling)

    def get_proposal(self, s, c, random):
        ns, ndim = s.shape
        nc = [len(x) for x in c]
        q = np.empty_like(s)
        metropolis = np.empty(ns, dtype=np.float64)
        for i in range(ns):
            w = np.array([c[j][random.randint(nc[j])] for j in range(3)])
            random.shuffle(w)
            z, z1, z2 = w
            delta = s[i] - z
            norm = np.linalg.norm(delta)
            u = delta / (np.sqrt(norm) if self.legacy_scaling else norm)
            q[i] = s[i] + u * self.gammas * (np.dot(u, z1) - np.dot(u, z2))
            metropolis[i] = np.log(np.linalg.norm(q[i] - z)) - np.log(norm)
        factor = 0.5 * (ndim - 1.0) if self.legacy_scaling else ndim - 1.0
        return q, factor * metropolis


class StudentTIndependenceProposal:
    """Independence proposal for :class:`emcee.moves.MHMove`: multivariate Student-t.

    One Student-t per ensemble block (the sampler's walkers are ``nblocks`` stacked
    ensembles of equal size, see :class:`BlockRedBlueMove`), fitted to that block's
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
