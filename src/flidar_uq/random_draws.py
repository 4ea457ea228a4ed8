"""Standard normal draws of a :class:`numpy.random.Generator`, compiled: the same numbers.

``Generator.standard_normal`` costs ~10.5 ns a value with NumPy 2.5 here (NumPy's 2.0
documentation times the same call at ~4.5 ns); numba's port of the same ziggurat, reading
the same bit generator through its ctypes interface, ~3.6 ns (both alone, in a loop over a
reused buffer; ~7.7 ns inside the virtual campaign's loop, whose caches hold other data).
The campaign draws ~72,000 normals a record (its turbulence, sea state and IMU noise); with
this and one other change its CPU fell by ~0.44 ms a record (docs/performance.md,
session 15).

The numbers are NumPy's, bit for bit, and the generator is left in the state NumPy's method
leaves it in: numba's ``random_standard_normal`` is NumPy's algorithm and tables line for
line, the tail and wedge tests with the C library's ``log1p`` and ``exp`` as NumPy's C code
calls them (``tests/test_random_draws.py`` compares both for several bit generators,
shapes and a million values, tail included). A generator that is not a
:class:`numpy.random.Generator` draws with its own method. The bit generator's lock is held
during the draws, as NumPy's method holds it.

Compiled with numba (:func:`flidar_uq.compiled.compiled`); callers import this module where
they draw, so that processes without draws do not import numba (~0.25 s).
"""

from __future__ import annotations

import math

import numpy as np

from flidar_uq.compiled import compiled

__all__ = ["complex_normals", "standard_normals"]

#: below this many values NumPy's method is faster (numba unboxes a Generator in ~9 us)
_MIN_COMPILED = 2048


@compiled
def _fill_standard_normal(rng, out):
    for i in range(out.size):
        out[i] = rng.standard_normal()


def standard_normals(rng: np.random.Generator, *shapes) -> list[np.ndarray]:
    """Arrays of standard normal values of ``shapes``, drawn one after another.

    Equal to ``[rng.standard_normal(s) for s in shapes]`` value for value (float64), with
    ``rng`` left in the same state; one compiled call for all of them.

    Parameters
    ----------
    rng : numpy.random.Generator
        The generator (any bit generator); advanced by the draws.
    *shapes : int or tuple of int
        Shape of each array (dimensionless values, mean 0, std 1); an int n is ``(n,)``.

    Returns
    -------
    list of numpy.ndarray
    """
    shapes = [tuple(s) if isinstance(s, (tuple, list)) else (int(s),) for s in shapes]
    sizes = [math.prod(s) for s in shapes]
    if any(d < 0 for s in shapes for d in s):
        raise ValueError(f"standard_normals: negative dimensions are not allowed: {shapes}")
    total = sum(sizes)
    if total < _MIN_COMPILED or type(rng) is not np.random.Generator:
        flat = rng.standard_normal(total)
    else:
        flat = np.empty(total)
        with rng.bit_generator.lock:
            _fill_standard_normal(rng, flat)
    ends = np.cumsum(sizes).tolist()
    return [
        flat[end - size : end].reshape(shape)
        for shape, size, end in zip(shapes, sizes, ends, strict=True)
    ]


def complex_normals(rng: np.random.Generator, scale, *shapes) -> list[np.ndarray]:
    """Complex Gaussian coefficients ``scale * (a + 1j b)``, then arrays of ``shapes``.

    ``a`` and ``b`` are standard normal arrays of ``scale``'s shape, all real parts drawn
    first, then all imaginary parts, then the arrays of ``shapes``
    (:func:`standard_normals`); each part multiplied by ``scale`` on its own (the values of
    ``(a + 1j b) * scale``). The spectral synthesis of the turbulence and of the sea state.

    Parameters
    ----------
    rng : numpy.random.Generator
        The generator; advanced by the draws.
    scale : array_like
        Real factor of each coefficient (in the unit of the coefficients).
    *shapes : int or tuple of int
        Shapes of standard normal arrays drawn after the coefficients.

    Returns
    -------
    list of numpy.ndarray
        The complex coefficients, then one array per shape.
    """
    scale = np.asarray(scale, float)
    re, im, *more = standard_normals(rng, scale.shape, scale.shape, *shapes)
    coef = np.empty(scale.shape, complex)
    np.multiply(re, scale, out=coef.real)
    np.multiply(im, scale, out=coef.imag)
    return [coef, *more]
