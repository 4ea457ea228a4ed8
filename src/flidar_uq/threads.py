"""BLAS thread pinning, and what else the last bits of a result depend on.

Multi-threaded BLAS may sum in a different order on machines with a different number of
cores, which changes the last bits of a matrix product and, through a Markov chain, the
whole posterior sample. The library's entry points (bin and global fits, propagation,
campaign generation) run under :func:`blas_threads` so that the thread count never
matters, whether called from Snakemake, the CLI or a notebook.

Two more things choose the last bits, both by the CPU: the OpenBLAS kernel (e.g. Haswell
or SkylakeX, whose 3x3 products fuse multiply-adds differently) and NumPy's SIMD loops
(AVX-512 and AVX2 versions of ``exp``, ``log``, ``**``, ``arctan2``, ``arcsin`` differ
in the last bit for some arguments). The virtual campaign's compiled kernel (numba, no
fast-math: no fused multiply-adds, no reordered sums) computes the same bits on every
CPU, but for the C library's ``cos`` and ``sin`` (``libm`` below). A rerun is therefore bit-identical on machines whose
:func:`numeric_environment` is the same (with the same packages, ``requirements.lock``);
across CPU types they differ in their last digits (the default run measured once under
another OpenBLAS kernel: corrected TIs within 4e-9, flags and coverage identical, no
sampler decision flipped; docs/user-guide.md, "Reproducibility across machines"). Both can be pinned for a run through
environment variables read when NumPy is imported (``OPENBLAS_CORETYPE``,
``NPY_DISABLE_CPU_FEATURES``; README, "Reproducibility across machines").

Dependency-free utility (threadpoolctl; NumPy and SciPy imported only by
:func:`numeric_environment`), importable from every layer of the package.
"""

from __future__ import annotations

import functools
import platform

from threadpoolctl import threadpool_info, threadpool_limits

__all__ = [
    "BLAS_THREADS",
    "SIMD_FUNCTIONS",
    "blas_threads",
    "single_threaded",
    "numeric_environment",
]

#: NumPy float64 loops the package calls whose implementation NumPy picks by CPU (SIMD
#: dispatch); some of them differ in the last bit between their AVX-512 and AVX2 versions.
SIMD_FUNCTIONS = (
    "exp",
    "expm1",
    "log",
    "log1p",
    "log10",
    "power",
    "sin",
    "cos",
    "tan",
    "arcsin",
    "arccos",
    "arctan2",
)

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


def numeric_environment() -> dict[str, str]:
    """What the last bits of this process's results depend on besides the code and seeds.

    Of *this* process, on *this* machine: a pipeline logs it at the start of every job
    (:func:`flidar_uq.workflow.files.setup_logging`), so a run on a cluster of mixed nodes
    shows each job's.

    Returns
    -------
    dict of str
        ``machine`` (``platform.machine()``), ``numpy_simd`` (the SIMD target NumPy
        dispatches each of :data:`SIMD_FUNCTIONS` to for float64, e.g.
        ``X86_V4: exp, log, ...``) and ``blas`` (each loaded BLAS library: its name,
        version and kernel; the library computes with :data:`BLAS_THREADS` thread
        whatever the pool's size) and ``libm`` (the C library whose ``cos`` and ``sin`` the
        compiled campaign kernel calls, :mod:`flidar_uq.campaign.scan_kernel`; its other
        arithmetic is IEEE-exact on every CPU; glibc picks an FMA or SSE2 version of them
        by CPU, and with Intel's SVML installed, not a dependency, numba would use it). Two runs with equal dictionaries (and equal
        package versions) give bit-identical results.
    """
    import scipy.linalg  # noqa: F401  (SciPy's own OpenBLAS, listed whatever was imported)
    from numpy.lib.introspect import opt_func_info

    targets: dict[str, list[str]] = {}
    for name in SIMD_FUNCTIONS:
        info = opt_func_info(func_name=f"^{name}$", signature="float64").get(name, {})
        # one float64 loop per function here (dd or ddd); its current dispatch target
        current = sorted({v["current"] for v in info.values()}) or ["unknown"]
        targets.setdefault("/".join(current), []).append(name)
    simd = "; ".join(f"{t}: {', '.join(names)}" for t, names in sorted(targets.items()))
    blas = [
        f"{lib.get('internal_api', '?')} {lib.get('version', '?')} "
        f"({lib.get('architecture', '?')} kernel)"
        for lib in threadpool_info()
        if lib.get("user_api") == "blas"
    ]
    return {
        "machine": platform.machine(),
        "numpy_simd": simd,
        # sorted: the libraries' load order differs between processes (a SLURM job and a
        # local one), their kernels do not
        "blas": "; ".join(sorted(blas)) or "none loaded",
        "libm": " ".join(platform.libc_ver()).strip() or "unknown",
    }
