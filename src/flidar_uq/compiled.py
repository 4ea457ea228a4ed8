"""The decorator of the package's compiled loops (numba): machine code cached on disk.

Used by :mod:`flidar_uq.campaign.scan_kernel` and :mod:`flidar_uq.data.imu_kernels`. The
loops add in a fixed order without fast-math flags, so their results are the same on every
CPU (NumPy's and BLAS's reductions may group sums by the SIMD width they find).
"""

from __future__ import annotations

import numba

__all__ = ["compiled"]


def compiled(func):
    """``numba.njit`` with the machine code cached on disk.

    The cache lives in the package's ``__pycache__``, else numba's user cache directory, or
    ``NUMBA_CACHE_DIR``; the first call compiles, a few seconds once per machine. Without a
    writable cache directory (numba raises at decoration) the function compiles in every
    process instead."""
    try:
        return numba.njit(cache=True, nogil=True)(func)
    except RuntimeError:  # "cannot cache function ...: no locator available"
        return numba.njit(cache=False, nogil=True)(func)
