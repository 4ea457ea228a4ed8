"""Compiled loops of the IMU estimators: the linear detrend and the Welch estimate.

Used by :mod:`flidar_uq.data.imu` for a window's linear detrend and the Welch estimate's
segments and averaged power. Each replaces a chain of NumPy passes over a window of samples
with one or two compiled passes (numba, :func:`flidar_uq.compiled.compiled`): the same
arithmetic, sums in their own fixed order (running sums; four interleaved partial sums for
the segments' means), so equal to the NumPy expressions to rounding (``tests/test_imu.py``)
and the same on every CPU. The virtual campaign computes
eight Welch spectra a record (roll, pitch, and the tilt along and across the wind at each
height), the IMU step those of every 10-min window of a raw series.
"""

from __future__ import annotations

import math

import numpy as np

from flidar_uq.compiled import compiled

__all__ = ["detrend_rows", "welch_power", "welch_segments"]


@compiled
def detrend_rows(x):
    """Each row of ``x`` (m, n) minus its least-squares line through its finite samples.

    The line over the finite samples ``j`` (sample index) of a row: ``xm + slope (j - jm)``
    with ``jm``, ``xm`` their means and ``slope = sum dj dx / sum dj^2``; a row with one
    finite sample (no slope) loses its value, one without any stays NaN; NaN samples stay
    NaN. ``_detrend`` of :mod:`flidar_uq.data.imu`.
    """
    m, n = x.shape
    out = np.empty((m, n))
    for i in range(m):
        cnt = 0
        sj = 0.0
        sx = 0.0
        for j in range(n):
            v = x[i, j]
            if math.isfinite(v):
                cnt += 1
                sj += j
                sx += v
        if cnt == 0:
            out[i, :] = np.nan
            continue
        jm = sj / cnt
        xm = sx / cnt
        sdx = 0.0
        sdd = 0.0
        for j in range(n):
            v = x[i, j]
            if math.isfinite(v):
                dj = j - jm
                sdx += dj * (v - xm)
                sdd += dj * dj
        slope = sdx / sdd if sdd > 0.0 else 0.0
        if not math.isfinite(slope):
            slope = 0.0
        for j in range(n):
            out[i, j] = x[i, j] - xm - slope * (j - jm)
    return out


@compiled
def welch_segments(x, win, step, n_seg):
    """The Welch segments of the rows of ``x`` (m, n), each minus its mean and windowed.

    ``n_seg`` segments of ``win.size`` samples every ``step`` samples, each minus its mean
    and times the window ``win``; shape (m, n_seg, win.size)."""
    m = x.shape[0]
    nperseg = win.size
    n4 = nperseg - nperseg % 4
    seg = np.empty((m, n_seg, nperseg))
    for i in range(m):
        for s in range(n_seg):
            o = s * step
            s0 = s1 = s2 = s3 = 0.0
            for k in range(0, n4, 4):
                s0 += x[i, o + k]
                s1 += x[i, o + k + 1]
                s2 += x[i, o + k + 2]
                s3 += x[i, o + k + 3]
            for k in range(n4, nperseg):
                s0 += x[i, o + k]
            mean = ((s0 + s1) + (s2 + s3)) / nperseg
            for k in range(nperseg):
                seg[i, s, k] = (x[i, o + k] - mean) * win[k]
    return seg


@compiled
def welch_power(spec, scale, n_doubled):
    """One-sided Welch PSD (m, nf) from the segments' spectra ``spec`` (m, n_seg, nf).

    The mean over the segments of ``|spec|^2``, divided by ``scale`` (``fs * sum(win^2)``),
    bins ``1 .. n_doubled`` doubled (all but DC and, for an even segment, Nyquist)."""
    m, n_seg, nf = spec.shape
    p = np.zeros((m, nf))
    for i in range(m):
        for s in range(n_seg):
            for f in range(nf):
                v = spec[i, s, f]
                p[i, f] += v.real * v.real + v.imag * v.imag
        for f in range(nf):
            p[i, f] = p[i, f] / n_seg / scale
            if 1 <= f <= n_doubled:
                p[i, f] *= 2.0
    return p
