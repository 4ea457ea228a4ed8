"""Seeds: one rule for turning a config seed into a :class:`numpy.random.SeedSequence`.

Dependency-free utility (NumPy only), importable from every layer of the package.
"""

from __future__ import annotations

import numpy as np

__all__ = ["as_seedsequence"]


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
