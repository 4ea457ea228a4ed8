"""BLAS thread pinning: results with the same seed must not depend on the thread count.

Multi-threaded BLAS may sum in a different order on machines with a different number of
cores, which changes the last bits of a matrix product and, through a Markov chain, the
whole posterior sample. The library's entry points (bin and global fits, propagation,
campaign generation) run under :func:`blas_threads` so that a rerun gives identical
outputs on any machine, whether called from Snakemake, the CLI or a notebook.

Dependency-free utility (threadpoolctl only), importable from every layer of the package.
"""

from __future__ import annotations

import functools

from threadpoolctl import threadpool_limits

__all__ = ["BLAS_THREADS", "blas_threads", "single_threaded"]

#: Number of BLAS threads the library computes with (1: bit-reproducible everywhere).
BLAS_THREADS = 1


def blas_threads(limit: int = BLAS_THREADS):
    """Context manager limiting the BLAS/OpenMP thread pools to ``limit`` threads."""
    return threadpool_limits(limits=int(limit))


def single_threaded(func):
    """Decorator: run ``func`` with the BLAS thread pools pinned to :data:`BLAS_THREADS`."""

    @functools.wraps(func)
    def wrapper(*args, **kwargs):
        with blas_threads():
            return func(*args, **kwargs)

    return wrapper
