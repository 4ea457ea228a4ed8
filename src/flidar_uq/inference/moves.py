"""emcee moves of the sampler: the block-wise red-blue move and the Student-t independence proposal."""

from __future__ import annotations

import emcee
import numpy as np


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
