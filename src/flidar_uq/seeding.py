"""Seeds: one rule for turning a config seed into a :class:`numpy.random.SeedSequence`.

Dependency-free utility (NumPy only), importable from every layer of the package.
"""

from __future__ import annotations

import numpy as np

__all__ = ["as_seedsequence", "child_seed"]


def as_seedsequence(seed) -> np.random.SeedSequence:
    """Return ``seed`` as a :class:`numpy.random.SeedSequence`.

    Parameters
    ----------
    seed : int or numpy.random.SeedSequence
        A non-negative integer from the config, or a SeedSequence (returned as is).

    Raises
    ------
    ValueError
        If ``seed`` is None: every random step of flidar_uq takes its seed from the
        config, never from global state.
    """
    if isinstance(seed, np.random.SeedSequence):
        return seed
    if seed is None:
        raise ValueError("seed is required (int or numpy.random.SeedSequence from config)")
    return np.random.SeedSequence(int(seed))


def child_seed(seed: int, *key: int) -> np.random.SeedSequence:
    """The SeedSequence of one pipeline step or bin: config ``seed`` as entropy, ``key`` as
    spawn key (e.g. ``(1, bin_id)``), so a step's draws depend on the config seed and its
    own key only, never on the batch layout or the order the jobs run in."""
    return np.random.SeedSequence(entropy=int(seed), spawn_key=tuple(int(k) for k in key))
