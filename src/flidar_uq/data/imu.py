"""Motion statistics from raw IMU attitude series, per 10-min window.

Size: the classic motion statistics (amplitude, period, two peaks) and the wind-frame tilt spectrum share the windowing, gap filling and Welch spectra (~730 lines, half of it docstrings).

Estimators (``docs/conventions.md``; a harmonic is ``A sin(2 pi t / T + phi)``):

Amplitude, deg
    ``"std"`` (default): ``sqrt(2) * std`` of the linearly detrended window,
    exact for a pure sinusoid and ``sqrt(A1^2 + A2^2)`` for two tones (the total
    amplitude of the two-period model).  ``"spectral"``: ``sqrt(2 m0)`` with
    ``m0`` the Welch variance inside the motion band (``period_min_s`` to
    ``period_max_s``), which ignores sensor noise outside the band.
    ``"zero_crossing"``: mean over zero-up-crossing waves of half the
    crest-to-trough height (``sqrt(pi/2) sigma`` for narrow-band Gaussian motion).
Period, s
    ``"spectral"`` (default): peak of the Welch spectrum within the motion band,
    refined by Gaussian (log-parabolic) interpolation.  It is the default because
    the sigma_Z model needs the *dominant* harmonic: the peak is insensitive to
    white sensor noise and to a second, weaker component, whereas the
    zero-crossing period is pulled towards ``sqrt(m0/m2)`` (Rice), i.e. shortened
    by noise and averaged between the two periods of bimodal motion; the
    spectrum also gives the two-peak description directly.
    ``"zero_crossing"``: mean interval between zero up-crossings.

Bimodal motion: two peaks in the summed roll + pitch spectrum (Gutiérrez-Antuñano et al., 2018, Sec. 2.4
reports two coexisting periods) give ``period1_s < period2_s`` and ``weight1``,
the share of the in-band variance on the short-period side of the spectral
minimum between them (``docs/conventions.md``: ``A1 = A sqrt(w)``).

Gaps: samples are placed on the nominal uniform grid; a window whose coverage is
below ``min_coverage_pct`` yields NaN statistics (its ``imu_availability_pct`` is
still reported, so QC flags it).  The std estimator uses only measured samples;
spectral and zero-crossing estimators see gaps filled by linear interpolation.
"""

from __future__ import annotations

import functools
from collections.abc import Mapping
from dataclasses import replace
from typing import TYPE_CHECKING

import numpy as np
from numpy import fft as _fft

from flidar_uq.data.schema import (
    HEAVE_RESPONSE_COLUMN,
    HORIZONTAL_RESPONSE_COLUMN,
    N_TILT_BANDS,
    TILT_SPECTRUM_COLUMNS,
    tilt_band_column_names,
    tilt_band_cos_psi_column,
    tilt_band_sin_psi_column,
    tilt_band_sincos_psi_column,
)
from flidar_uq.physics.hull import G_MS2
from flidar_uq.physics.motion_spectrum import (
    PERIOD_RANGE_S,
    TiltBandSpectrum,
    band_edges_s,
    project_tilt_on_wind_deg,
    tilt_band_spectrum,
    tilt_vector_en,
)

if TYPE_CHECKING:  # pandas is imported where a function builds or reads a DataFrame
    import pandas as pd

__all__ = [
    "AMPLITUDE_METHODS",
    "band_direction_from_heave",
    "response_ratio",
    "RESPONSE_RATIO_MAX",
    "grid_rate_hz",
    "PERIOD_METHODS",
    "amplitude_std_deg",
    "amplitude_zero_crossing_deg",
    "period_spectral_s",
    "period_zero_crossing_s",
    "motion_spectrum",
    "two_peaks",
    "window_series",
    "motion_statistics",
    "motion_statistics_arrays",
    "roll_pitch_correlation",
    "heading_mean_deg",
    "tilt_band_statistics",
    "TILT_SPECTRUM_COLUMNS",
    "band_direction_moments",
    "follower_translation_columns",
    "tilt_bands_from_records",
    "tilt_spectrum_columns",
    "tilt_spectrum_statistics_by_height",
]

AMPLITUDE_METHODS = ("std", "spectral", "zero_crossing")
PERIOD_METHODS = ("spectral", "zero_crossing")
#: Record columns filled by :func:`motion_statistics` (besides ``imu_availability_pct``).
STATISTIC_COLUMNS = (
    "roll_amplitude_deg",
    "pitch_amplitude_deg",
    "roll_period_s",
    "pitch_period_s",
    "period1_s",
    "period2_s",
    "weight1",
)
#: All record columns written by :func:`motion_statistics`, availability included.
MOTION_STAT_COLUMNS = (*STATISTIC_COLUMNS, "imu_availability_pct")


# --------------------------------------------------------------------------- basics
def _as_2d(x) -> tuple[np.ndarray, bool]:
    x = np.asarray(x, dtype=np.float64)
    if x.ndim == 1:
        return x[None, :], True
    if x.ndim != 2:
        raise ValueError(f"expected a series of shape (n,) or (nwin, n), got shape {x.shape}")
    return x, False


def _detrend(x: np.ndarray) -> np.ndarray:
    """Remove a least-squares line from each row (shape (m, n)), ignoring NaN samples;
    shape kept (:func:`flidar_uq.data.imu_kernels.detrend_rows`, compiled)."""
    from flidar_uq.data import imu_kernels  # numba: imported where an estimator runs

    return imu_kernels.detrend_rows(np.ascontiguousarray(x, dtype=np.float64))


def _fill(x: np.ndarray) -> np.ndarray:
    """Linear interpolation over NaN samples along each row (edge values held); ``x``
    itself when it has no NaN (callers do not write into the result)."""
    if np.isfinite(x).all():
        return x
    out = x.copy()
    for i in np.flatnonzero(~np.isfinite(x).all(axis=-1)):
        row = out[i]
        ok = np.isfinite(row)
        if ok.sum() >= 2:
            j = np.arange(row.size)
            row[~ok] = np.interp(j[~ok], j[ok], row[ok])
    return out


def amplitude_std_deg(angle_deg) -> np.ndarray:
    """Amplitude as ``sqrt(2) * std`` of the linearly detrended series (default estimator).

    Parameters
    ----------
    angle_deg : array_like, shape (n,) or (nwin, n)
        Uniformly sampled angle, deg; NaN samples are ignored.

    Returns
    -------
    numpy.ndarray, shape () or (nwin,)
        Amplitude, deg (NaN for fewer than 3 finite samples).  Exact for
        ``A sin(2 pi t / T)`` over whole periods.
    """
    x, squeeze = _as_2d(angle_deg)
    r = _detrend(x)
    n = np.isfinite(r).sum(axis=-1)
    with np.errstate(invalid="ignore", divide="ignore"):
        var = np.nansum(r**2, axis=-1) / n
    a = np.where(n >= 3, np.sqrt(2.0 * var), np.nan)
    return a[0] if squeeze else a


def motion_spectrum(
    angle_deg, fs_hz: float, *, segment_s: float = 200.0
) -> tuple[np.ndarray, np.ndarray]:
    """One-sided Welch power spectral density of the detrended, gap-filled series.

    Parameters
    ----------
    angle_deg : array_like, shape (n,) or (nwin, n)
        Uniformly sampled angle, deg (NaN gaps are linearly interpolated).
    fs_hz : float
        Sampling rate, Hz.
    segment_s : float
        Welch segment length, s (Hann window, 50 % overlap); resolution 1/segment_s Hz.

    Returns
    -------
    f_hz : numpy.ndarray, shape (nf,)
        Frequencies, Hz.
    psd : numpy.ndarray, shape (nf,) or (nwin, nf)
        PSD, deg^2/Hz; ``psd.sum(-1) * df`` is the variance.
    """
    x, squeeze = _as_2d(angle_deg)
    if fs_hz <= 0 or segment_s <= 0:
        raise ValueError(
            f"motion_spectrum: need fs_hz > 0 and segment_s > 0, got {fs_hz}, {segment_s}"
        )
    nperseg = int(min(x.shape[-1], round(segment_s * fs_hz)))
    if nperseg < 1:
        raise ValueError(
            f"motion_spectrum: a Welch segment of {segment_s} s at {fs_hz} Hz on "
            f"{x.shape[-1]} samples holds no sample"
        )
    # the window is detrended once as a whole; each Welch segment only loses its mean
    r = _detrend(_fill(x))
    f, p = _welch_hann(r, fs_hz, nperseg)
    return f, (p[0] if squeeze else p)


@functools.lru_cache(maxsize=8)
def _hann(nperseg: int) -> tuple[np.ndarray, float]:
    """Periodic Hann window of ``nperseg`` samples (read-only) and the sum of its squares.

    ``scipy.signal.get_window("hann", nperseg)`` computed as scipy computes it (the same
    bits, ``tests/test_imu.py``), without importing ``scipy.signal`` (~0.45 s in every
    process of the campaign generator)."""
    if nperseg == 1:
        win = np.ones(1)
    else:
        fac = np.linspace(-np.pi, np.pi, nperseg + 1)  # one more sample: periodic (DFT-even)
        win = np.zeros(nperseg + 1)
        for k, a in enumerate((0.5, 0.5)):  # general cosine window, a = (alpha, 1 - alpha)
            win += a * np.cos(k * fac)
        win = win[:-1]
    win.flags.writeable = False
    return win, float((win * win).sum())


def _welch_hann(x: np.ndarray, fs_hz: float, nperseg: int) -> tuple[np.ndarray, np.ndarray]:
    """Welch PSD of the rows of ``x``: ``scipy.signal.welch(x, fs_hz, "hann", nperseg)``.

    The same estimate (periodic Hann window, 50 % overlap, each segment's mean removed,
    one-sided density, mean over the segments) without ``welch``'s per-call set-up, which
    cost ~5x the FFTs for the generator's 3000-sample records; equal to ``welch`` to
    rounding (``tests/test_imu.py``).
    """
    from flidar_uq.data import imu_kernels  # numba: imported where an estimator runs

    n = x.shape[-1]
    step = nperseg - nperseg // 2
    n_seg = (n - nperseg) // step + 1
    win, win_power = _hann(nperseg)
    # the segments minus their means, windowed; their spectra; the mean power, one-sided
    seg = imu_kernels.welch_segments(np.ascontiguousarray(x, dtype=np.float64), win, step, n_seg)
    spec = _fft.rfft(seg, axis=-1)
    n_doubled = spec.shape[-1] - 1 - (0 if nperseg % 2 else 1)  # all but DC and Nyquist
    p = imu_kernels.welch_power(spec, fs_hz * win_power, n_doubled)
    return _fft.rfftfreq(nperseg, 1.0 / fs_hz), p


def band_direction_from_heave(
    velocity_up_ms,
    along_deg,
    across_deg,
    fs_hz: float,
    *,
    acceleration_up_ms2=None,
    segment_s: float = 200.0,
    n_bands: int = 8,
    period_min_s: float = 1.0,
    period_max_s: float = 20.0,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Signed mean cosine and sine, and the mean of their product, of each band's
    directions of travel against the wind.

    A buoy that follows a wave ``eta = a cos(k x cos psi + k y sin psi - omega t)`` (``x``
    downwind, ``y`` to its left) rises with the vertical velocity ``w = a omega sin(.)``
    while its mast leans with the surface normal, towards the waves' direction of travel by
    ``a k sin(.)``: upwind by ``-a k cos psi sin(.)`` and to the left of the wind by
    ``a k sin psi sin(.)``, both in phase with ``w``. At each frequency, minus the
    co-spectrum of ``w`` and the along-wind tilt (positive where the mast leans upwind,
    :func:`flidar_uq.physics.motion_spectrum.project_tilt_on_wind_deg`) times
    ``sqrt(P_tilt / P_w)`` (the tilt's power, along + across, over that of ``w``: ``k /
    omega`` for a follower, whatever the directions) is the tilt power of its waves
    weighted by ``cos psi``; summed over the band and divided by the band's tilt power it
    is the band's ``<cos psi>``, weighted as the band's variance is. The co-spectrum with
    the across-wind tilt (positive to the left of the wind's direction of travel) likewise
    gives ``<sin psi>``. (The band's co-spectrum over ``sqrt`` of its summed powers
    instead falls short by the Cauchy-Schwarz ratio of ``omega^3`` to ``omega^2`` and
    ``omega^4`` over the band, 1 % at 60 deg for two waves 1.4 apart in frequency, and
    that 1 % is an error of sigma_Z of up to 5 % where the heave cancels most of the
    tilt's vertical wind.) These are the first
    directional moments a pitch-roll buoy measures (Longuet-Higgins, Cartwright and Smith,
    1963): ``<cos psi>`` +1 for waves running downwind, -1 upwind; ``<sin psi>`` +1 for
    waves running to the left of the wind, -1 to its right; both 0 for a sea split evenly
    between opposite directions. Minus the co-spectrum of the along- and across-wind tilt,
    normalised by the band's tilt power, is the second moment ``<sin psi cos psi>`` (the
    same authors' ``b2 / 2``); with the first ones and ``<cos^2 psi>`` from the same
    spectra it makes a moment matrix of ``(1, cos psi, sin psi)`` that is positive
    semi-definite, as that of any spread of directions is. A hull that responds less than
    a follower, in phase, gives the same ratios. Welch estimate as :func:`motion_spectrum`
    (gaps linearly filled, detrended, periodic Hann segments with 50 % overlap).

    The same spectra give the heave's size: a wave follower's heave velocity has ``(g /
    omega)^2`` times its tilt's power at each frequency (:mod:`flidar_uq.physics.hull`),
    so the ratio of the measured heave velocity's power to that, summed over the bands'
    frequencies, is the hull's heave response relative to a wave follower's with the
    record's own tilt (:func:`response_ratio`; a measured translation,
    :func:`flidar_uq.inference.record_motion.measured_response`).

    An inertial unit without a velocity output gives the heave acceleration instead: each
    segment's transform of it divided by ``i omega`` is that of the velocity, as wave
    buoys integrate their heave (Tucker and Pitt, 2001, Sec. 7.3), only at the bands'
    frequencies (no high-pass needed below them). Integrated per frequency, a gap filled
    linearly costs the spectra what it costs the tilt's; integrated in time, the lost
    velocity change across it would offset the rest of the window.

    Parameters
    ----------
    velocity_up_ms : array_like, shape (nwin, n), or None
        Vertical velocity of the buoy, positive up, m/s (NaN: missing sample); None with
        ``acceleration_up_ms2``.
    along_deg, across_deg : array_like, shape (nwin, n)
        Tilt along and across the mean wind (:func:`tilt_band_statistics`'s projection),
        deg.
    fs_hz : float
        Sampling rate, Hz.
    acceleration_up_ms2 : array_like, shape (nwin, n), optional
        Vertical acceleration of the buoy, positive up, gravity removed, m/s^2 (NaN:
        missing sample): the heave when ``velocity_up_ms`` is None.
    segment_s, n_bands, period_min_s, period_max_s
        Welch segment (s) and the period bands (s), those of :func:`tilt_band_statistics`.

    Returns
    -------
    cos_psi, sin_psi : numpy.ndarray, shape (nwin, n_bands)
        ``<cos psi>`` and ``<sin psi>`` per band (-, in [-1, 1]); NaN for a band without
        heave or tilt power or a window without a finite vertical velocity.
    sincos_psi : numpy.ndarray, shape (nwin, n_bands)
        ``<sin psi cos psi>`` per band (-, in [-1/2, 1/2]), NaN where ``sin_psi`` is.
    heave_response : numpy.ndarray, shape (nwin,)
        The hull's measured heave against a wave follower's with the same tilt, over the
        bands' periods: ``sqrt(sum_f P_w(f) / sum_f (g / omega)^2 P_tilt(f))`` (-, tilt in
        rad; 1 for a hull that follows the waves, 0 for one that only rotates); NaN
        without heave or tilt power.
    """
    from flidar_uq.data import imu_kernels  # numba: imported where an estimator runs

    from_acc = velocity_up_ms is None
    if from_acc and acceleration_up_ms2 is None:
        raise ValueError("band_direction_from_heave: give velocity_up_ms or acceleration_up_ms2")
    heave = acceleration_up_ms2 if from_acc else velocity_up_ms
    rows = [_as_2d(a)[0] for a in (heave, along_deg, across_deg)]
    n = rows[0].shape[-1]
    nperseg = int(min(n, round(segment_s * fs_hz)))
    step = nperseg - nperseg // 2
    n_seg = (n - nperseg) // step + 1
    win, _ = _hann(nperseg)
    no_heave = ~np.isfinite(rows[0]).any(axis=-1)
    spectra = [
        _fft.rfft(
            imu_kernels.welch_segments(
                np.ascontiguousarray(_detrend(_fill(np.where(no_heave[:, None], 0.0, x)))),
                win,
                step,
                n_seg,
            ),
            axis=-1,
        )
        for x in rows
    ]
    w, a, c = spectra
    f = _fft.rfftfreq(nperseg, 1.0 / fs_hz)
    if from_acc:  # the velocity's transform: the acceleration's over i omega (0 at f = 0)
        w = w / np.where(f > 0, 2j * np.pi * f, np.inf)
    # (nwin, nf): co-spectra of the heave with the along- and across-wind tilt; the common
    # scale cancels below
    co_along = np.mean((np.conj(w) * a).real, axis=1)
    co_across = np.mean((np.conj(w) * c).real, axis=1)
    co_tilt = np.mean((np.conj(a) * c).real, axis=1)
    p_w = np.mean(np.abs(w) ** 2, axis=1)
    p_tilt = np.mean(np.abs(a) ** 2 + np.abs(c) ** 2, axis=1)
    with np.errstate(divide="ignore"):
        per = np.where(f > 0, 1.0 / f, np.inf)
    edges = band_edges_s(n_bands, period_min_s, period_max_s)
    idx = np.searchsorted(edges, per, side="right") - 1
    idx = np.where(per == edges[-1], n_bands - 1, idx)
    cos_psi = np.full((co_along.shape[0], n_bands), np.nan)
    sin_psi = np.full_like(cos_psi, np.nan)
    sincos_psi = np.full_like(cos_psi, np.nan)
    for b in range(n_bands):
        # a band's bins are contiguous: sums over a slice view, row by row (a boolean
        # index's contiguous copy is reduced with other last bits for one row than for
        # several, and a record's value would depend on its chunk)
        k = np.flatnonzero(idx == b)
        sl = slice(int(k[0]), int(k[-1]) + 1) if k.size else slice(0, 0)
        pw, pt = p_w[:, sl], p_tilt[:, sl]
        tb = np.where(pw > 0, pt, 0.0).sum(-1)
        ok = tb > 0
        with np.errstate(invalid="ignore", divide="ignore"):
            r = np.where(pw > 0, np.sqrt(pt / np.where(pw > 0, pw, 1.0)), 0.0)
            norm = np.where(ok, tb, np.nan)
            cos_psi[:, b] = -(co_along[:, sl] * r).sum(-1) / norm
            sin_psi[:, b] = (co_across[:, sl] * r).sum(-1) / norm
            sincos_psi[:, b] = -co_tilt[:, sl].sum(-1) / np.where(ok, pt.sum(-1), np.nan)
    heave_response = response_ratio(f, p_w, p_tilt, period_min_s, period_max_s)
    for x in (cos_psi, sin_psi, sincos_psi, heave_response):
        x[no_heave] = np.nan
    return (
        np.clip(cos_psi, -1.0, 1.0),
        np.clip(sin_psi, -1.0, 1.0),
        np.clip(sincos_psi, -0.5, 0.5),
        heave_response,
    )


def _band(f: np.ndarray, period_min_s: float, period_max_s: float) -> np.ndarray:
    if not 0 < period_min_s < period_max_s:
        raise ValueError(
            f"need 0 < period_min_s < period_max_s, got {period_min_s}, {period_max_s}"
        )
    return (f >= 1.0 / period_max_s) & (f <= 1.0 / period_min_s)


#: Largest hull response against a wave follower's that :func:`response_ratio` reports (-):
#: the record columns' bound (``heave_response_ratio``, ``horizontal_response_ratio``).
RESPONSE_RATIO_MAX = 10.0


def response_ratio(f_hz, velocity_psd, tilt_psd_deg2, period_min_s, period_max_s) -> np.ndarray:
    """A hull's translation against a wave follower's with the same tilt, over a period band.

    A wave follower's heave velocity, and its horizontal orbital velocity (deep-water
    orbits are circular), have ``(g / omega)^2`` times its tilt's power at each frequency
    (:mod:`flidar_uq.physics.hull`), whatever the waves' directions. So

    ``R = sqrt(sum_f P_v(f) / sum_f (g / omega)^2 P_tilt(f))``

    over the frequencies of ``[period_min_s, period_max_s]`` is 1 for a hull that follows
    the waves, less for one that moves less, 0 for one that only rotates (a velocity
    outside the band, a mooring's slow drift, does not count).

    Parameters
    ----------
    f_hz : numpy.ndarray, shape (nf,)
        Frequencies, Hz.
    velocity_psd : numpy.ndarray, shape (nwin, nf)
        Power of the measured velocity (heave, or east + north), (m/s)^2 per unit of the
        tilt's scale.
    tilt_psd_deg2 : numpy.ndarray, shape (nwin, nf)
        Power of the tilt (along + across), deg^2 in the same scale.
    period_min_s, period_max_s : float
        The band, s.

    Returns
    -------
    numpy.ndarray, shape (nwin,)
        ``R`` (-); NaN without tilt power in the band, or above
        :data:`RESPONSE_RATIO_MAX` (a velocity in other units than m/s, or a window
        almost without tilt: the record model then fits the translation's size instead).
    """
    f = np.asarray(f_hz, float)
    inside = _band(f, period_min_s, period_max_s) & (f > 0)
    c2 = np.zeros_like(f)
    c2[inside] = (G_MS2 / (2.0 * np.pi * f[inside])) ** 2
    follower = (np.asarray(tilt_psd_deg2, float) * np.deg2rad(1.0) ** 2 * c2).sum(-1)
    measured = np.where(inside, np.asarray(velocity_psd, float), 0.0).sum(-1)
    with np.errstate(invalid="ignore", divide="ignore"):
        ratio = np.sqrt(measured / np.where(follower > 0, follower, np.nan))
    return np.where(ratio <= RESPONSE_RATIO_MAX, ratio, np.nan)


def _refine(f: np.ndarray, p: np.ndarray, k: np.ndarray) -> np.ndarray:
    """Gaussian (log-parabolic) interpolation of peak bins ``k`` (rows of ``p``)."""
    rows = np.arange(p.shape[0])
    km = np.clip(k - 1, 0, p.shape[1] - 1)
    kp = np.clip(k + 1, 0, p.shape[1] - 1)
    tiny = np.finfo(float).tiny
    a, b, c = (np.log(np.maximum(p[rows, i], tiny)) for i in (km, k, kp))
    den = a - 2.0 * b + c
    with np.errstate(invalid="ignore", divide="ignore"):
        delta = np.where((den < 0) & (km < k) & (kp > k), 0.5 * (a - c) / den, 0.0)
    return f[k] + np.clip(delta, -0.5, 0.5) * (f[1] - f[0])


def period_spectral_s(
    angle_deg,
    fs_hz: float,
    *,
    segment_s: float = 200.0,
    period_min_s: float = 1.0,
    period_max_s: float = 30.0,
) -> np.ndarray:
    """Dominant period: the Welch spectral peak inside the motion band (default estimator).

    Parameters
    ----------
    angle_deg : array_like, shape (n,) or (nwin, n)
        Uniformly sampled angle, deg.
    fs_hz : float
        Sampling rate, Hz.
    segment_s : float
        Welch segment length, s.
    period_min_s, period_max_s : float
        Motion band, s.

    Returns
    -------
    numpy.ndarray, shape () or (nwin,)
        Period, s (NaN for an all-NaN or flat window).
    """
    x, squeeze = _as_2d(angle_deg)
    f, p = motion_spectrum(x, fs_hz, segment_s=segment_s)
    per = _peak_period_s(f, p, _band(f, period_min_s, period_max_s))
    return per[0] if squeeze else per


def _peak_period_s(f: np.ndarray, p: np.ndarray, band: np.ndarray) -> np.ndarray:
    """Period (s) of the refined in-band PSD maximum of each row of ``p``."""
    k = np.argmax(np.where(band, p, -np.inf), axis=-1)
    fpk = _refine(f, p, k)
    ok = np.isfinite(p).all(axis=-1) & (p[np.arange(p.shape[0]), k] > 0) & band.any()
    return np.where(ok, 1.0 / fpk, np.nan)


def _band_amplitude_deg(f: np.ndarray, p: np.ndarray, band: np.ndarray) -> np.ndarray:
    """``sqrt(2 m0)`` with ``m0`` the in-band variance of each row of ``p``."""
    return np.sqrt(2.0 * (p * band).sum(axis=-1) * (f[1] - f[0]))


def _upcrossings(x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Mask of up-crossings between samples j, j+1 and their interpolated positions."""
    up = (x[:, :-1] < 0) & (x[:, 1:] >= 0)
    with np.errstate(invalid="ignore", divide="ignore"):
        pos = np.arange(x.shape[1] - 1) + x[:, :-1] / (x[:, :-1] - x[:, 1:])
    return up, pos


def period_zero_crossing_s(angle_deg, fs_hz: float) -> np.ndarray:
    """Mean zero-up-crossing period of the detrended, gap-filled series.

    ``(t_last - t_first) / (n_up - 1)`` with linearly interpolated crossing times.

    Parameters
    ----------
    angle_deg : array_like, shape (n,) or (nwin, n)
        Uniformly sampled angle, deg.
    fs_hz : float
        Sampling rate, Hz.

    Returns
    -------
    numpy.ndarray, shape () or (nwin,)
        Period, s (NaN with fewer than two up-crossings).
    """
    x, squeeze = _as_2d(angle_deg)
    r = _detrend(_fill(x))
    up, pos = _upcrossings(r)
    n_up = up.sum(axis=-1)
    last = up.shape[1] - 1 - np.argmax(up[:, ::-1], axis=-1)
    first = np.argmax(up, axis=-1)
    rows = np.arange(r.shape[0])
    with np.errstate(invalid="ignore", divide="ignore"):
        per = (pos[rows, last] - pos[rows, first]) / (n_up - 1) / fs_hz
    per = np.where(n_up >= 2, per, np.nan)
    return per[0] if squeeze else per


def amplitude_zero_crossing_deg(angle_deg) -> np.ndarray:
    """Mean half crest-to-trough height of the zero-up-crossing waves.

    Parameters
    ----------
    angle_deg : array_like, shape (n,) or (nwin, n)
        Uniformly sampled angle, deg (detrended and gap-filled here).

    Returns
    -------
    numpy.ndarray, shape () or (nwin,)
        Amplitude, deg (NaN without a complete wave).  ``A`` for a pure
        sinusoid; ``sqrt(pi/2) sigma`` for narrow-band Gaussian motion.
    """
    x, squeeze = _as_2d(angle_deg)
    r = _detrend(_fill(x))
    up, _ = _upcrossings(r)
    out = np.full(r.shape[0], np.nan)
    for i in range(r.shape[0]):  # one iteration per window; samples handled by reduceat
        idx = np.flatnonzero(up[i]) + 1
        if idx.size < 2:
            continue
        hi = np.maximum.reduceat(r[i, idx[0] : idx[-1]], idx[:-1] - idx[0])
        lo = np.minimum.reduceat(r[i, idx[0] : idx[-1]], idx[:-1] - idx[0])
        out[i] = np.mean(hi - lo) / 2.0
    return out[0] if squeeze else out


# --------------------------------------------------------------------------- two peaks
def two_peaks(
    f_hz: np.ndarray,
    psd,
    *,
    period_min_s: float = 1.0,
    period_max_s: float = 30.0,
    min_peak_ratio: float = 0.1,
    min_period_ratio: float = 1.5,
    max_valley_ratio: float = 0.35,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Detect bimodal motion: two separated peaks in a motion spectrum.

    The highest local maximum inside the band and the highest other maximum
    whose period differs from it by a factor >= ``min_period_ratio`` are
    accepted as two modes if the second is at least ``min_peak_ratio`` of the
    first and the spectral minimum between them is at most ``max_valley_ratio``
    of the lower peak.  Closer maxima are treated as one mode.

    The defaults were chosen on random-phase JONSWAP seas (10-min windows at
    5 Hz, Welch segments of 200 s, ``tests/test_imu.py``): a single-peaked wind
    sea (Tp 5 s) is called bimodal in about 1 % of windows for one axis and
    roll + pitch summed (about 12 % with 1.3 / 0.5), while wind sea + swell
    with period ratios from 1.6 to 2.4 is detected in about 99 % of windows.

    Parameters
    ----------
    f_hz : numpy.ndarray, shape (nf,)
        Frequencies, Hz (uniform).
    psd : array_like, shape (nf,) or (nwin, nf)
        PSD, deg^2/Hz (for roll and pitch together, pass their sum).
    period_min_s, period_max_s : float
        Motion band, s.
    min_peak_ratio, min_period_ratio, max_valley_ratio : float
        Detection criteria, dimensionless.

    Returns
    -------
    period1_s, period2_s : numpy.ndarray, shape () or (nwin,)
        Shorter and longer period, s; NaN if unimodal.
    weight1 : numpy.ndarray, shape () or (nwin,)
        Share of the in-band variance on the short-period side of the minimum
        between the peaks, dimensionless; NaN if unimodal.
    """
    p2, squeeze = _as_2d(psd)
    band = _band(f_hz, period_min_s, period_max_s)
    nwin = p2.shape[0]
    p1 = np.full(nwin, np.nan)
    q2 = np.full(nwin, np.nan)
    w1 = np.full(nwin, np.nan)
    lo_k = int(np.argmax(band))
    hi_k = int(band.size - np.argmax(band[::-1]))
    found = []  # (window, bin of the longer-period peak, of the shorter)
    for i in range(nwin):  # one iteration per window
        p = p2[i, lo_k:hi_k]
        if not np.all(np.isfinite(p)) or p.max() <= 0:
            continue
        pk = _local_maxima(np.concatenate(([0.0], p, [0.0]))) - 1
        if pk.size < 2:
            continue
        pk = pk[np.argsort(p[pk])[::-1]]  # by decreasing height
        main = pk[0]
        ratio = f_hz[lo_k + pk[1:]] / f_hz[lo_k + main]
        far = pk[1:][(ratio >= min_period_ratio) | (ratio <= 1.0 / min_period_ratio)]
        if far.size == 0:
            continue
        a, b = sorted((main, far[0]))  # a: lower frequency (longer period)
        low = min(p[a], p[b])
        valley = a + int(np.argmin(p[a : b + 1]))
        if low < min_peak_ratio * p[main] or p[valley] > max_valley_ratio * low:
            continue
        var_short = p[valley + 1 :].sum() + 0.5 * p[valley]
        var_long = p[:valley].sum() + 0.5 * p[valley]
        w1[i] = var_short / (var_short + var_long)
        found.append((i, lo_k + a, lo_k + b))
    if found:  # the peaks' frequencies refined for all windows at once
        rows, ka, kb = np.array(found).T
        fa = _refine(f_hz, p2[rows], ka)
        fb = _refine(f_hz, p2[rows], kb)
        p1[rows], q2[rows] = 1.0 / fb, 1.0 / fa
    if squeeze:
        return p1[0], q2[0], w1[0]
    return p1, q2, w1


def _local_maxima(x: np.ndarray) -> np.ndarray:
    """Indices of the local maxima of ``x`` (1-D): ``scipy.signal.find_peaks(x)[0]``
    without conditions (a flat peak at its middle sample, ``(first + last) // 2``; none at
    either end), without importing ``scipy.signal``.

    Runs of equal values are the units: a run is a peak when both neighbouring runs are
    lower (``tests/test_imu.py`` checks it against ``find_peaks``).
    """
    n = x.size
    if n < 3:
        return np.zeros(0, np.intp)
    new_run = np.flatnonzero(x[1:] != x[:-1]) + 1
    first = np.concatenate(([0], new_run))
    last = np.concatenate((new_run - 1, [n - 1]))
    v = x[first]
    peak = np.zeros(first.size, bool)
    peak[1:-1] = (v[:-2] < v[1:-1]) & (v[2:] < v[1:-1])
    return (first[peak] + last[peak]) // 2


# --------------------------------------------------------------------------- windows
def grid_rate_hz(interval_s: float) -> float:
    """The sampling rate (Hz) of the uniform grid for samples every ``interval_s`` (s): the
    interval rounded to 1 us (:func:`window_series` infers it from the median interval).

    Float timestamps carry sub-us jitter that would otherwise accumulate over a long series
    (0.1 us per step is 0.9 samples per day).
    """
    return 1.0 / (round(interval_s * 1e6) * 1e-6)


def window_series(
    time_s, values, *, window_s: float = 600.0, fs_hz: float | None = None
) -> tuple[np.ndarray, np.ndarray, float]:
    """Place samples on the nominal uniform grid and cut it into aligned windows.

    Parameters
    ----------
    time_s : array_like, shape (n,)
        Sample times, s since the Unix epoch (UTC), increasing.
    values : array_like, shape (n,) or (n, k)
        Samples (NaN allowed).
    window_s : float
        Window length, s; windows start at multiples of ``window_s`` since the epoch
        (10-min UTC boundaries for 600 s).
    fs_hz : float, optional
        Nominal rate, Hz; default ``1 / median(diff(time_s))`` with the interval
        rounded to 1 microsecond.

    Returns
    -------
    start_s : numpy.ndarray, shape (nwin,)
        Window starts, s since the epoch.
    grid : numpy.ndarray, shape (nwin, m) or (nwin, m, k)
        Gridded samples (NaN where missing), ``m = round(window_s * fs_hz)``.
    fs_hz : float
        Rate used, Hz.
    """
    t = np.asarray(time_s, dtype=np.float64)
    v = np.asarray(values, dtype=np.float64)
    if t.ndim != 1 or v.shape[0] != t.size or t.size < 2:
        raise ValueError(
            f"window_series: need time_s (n >= 2,) and values (n, ...), got {t.shape}, {v.shape}"
        )
    if fs_hz is None:
        fs_hz = grid_rate_hz(float(np.median(np.diff(t))))
    m = int(round(window_s * fs_hz))
    if m < 8:
        raise ValueError(f"window_series: window of {window_s} s at {fs_hz} Hz has < 8 samples")
    t0 = np.floor(t[0] / window_s) * window_s
    k = np.rint((t - t0) * fs_hz).astype(np.int64)
    nwin = int(k[-1] // m) + 1
    grid = np.full((nwin * m,) + v.shape[1:], np.nan)
    grid[k] = v
    return t0 + window_s * np.arange(nwin), grid.reshape((nwin, m) + v.shape[1:]), float(fs_hz)


def motion_statistics(
    imu: pd.DataFrame,
    *,
    window_s: float = 600.0,
    amplitude_method: str = "std",
    period_method: str = "spectral",
    segment_s: float = 200.0,
    period_min_s: float = 1.0,
    period_max_s: float = 30.0,
    min_coverage_pct: float = 80.0,
    bimodal: bool = True,
    fs_hz: float | None = None,
) -> pd.DataFrame:
    """Per-window motion statistics of a raw IMU series, as record columns.

    Parameters
    ----------
    imu : pandas.DataFrame
        Validated IMU series (:func:`flidar_uq.data.io.validate_imu_series`):
        ``timestamp`` (UTC), ``roll_deg``, ``pitch_deg``.
    window_s : float
        Record length, s (600).
    amplitude_method : {"std", "spectral", "zero_crossing"}
        Amplitude estimator (module docstring).
    period_method : {"spectral", "zero_crossing"}
        Period estimator (module docstring).
    segment_s : float
        Welch segment length, s.
    period_min_s, period_max_s : float
        Motion band, s.
    min_coverage_pct : float
        Windows with fewer nominal samples present get NaN statistics, %.
    bimodal : bool
        Detect two spectral peaks (``period1_s``, ``period2_s``, ``weight1``).
    fs_hz : float, optional
        Nominal sampling rate, Hz; default from the median sampling interval
        (:func:`window_series`). Give it when the series is processed in pieces, so that
        every piece uses the same sample grid.

    Returns
    -------
    pandas.DataFrame
        One row per window with at least one sample: ``timestamp`` (window start,
        UTC), ``roll_amplitude_deg``, ``pitch_amplitude_deg``, ``roll_period_s``,
        ``pitch_period_s``, ``period1_s``, ``period2_s``, ``weight1``,
        ``imu_availability_pct``.
    """
    import pandas as pd

    t_ns = pd.DatetimeIndex(imu["timestamp"]).as_unit("ns").asi8
    vals = imu[["roll_deg", "pitch_deg"]].to_numpy(dtype=np.float64)
    start_ns, cols, present = motion_statistics_arrays(
        t_ns,
        vals,
        window_s=window_s,
        amplitude_method=amplitude_method,
        period_method=period_method,
        segment_s=segment_s,
        period_min_s=period_min_s,
        period_max_s=period_max_s,
        min_coverage_pct=min_coverage_pct,
        bimodal=bimodal,
        fs_hz=fs_hz,
    )
    out = pd.DataFrame({"timestamp": pd.to_datetime(start_ns, utc=True)} | cols)
    return out.loc[present].reset_index(drop=True)


def motion_statistics_arrays(
    time_ns,
    roll_pitch_deg,
    *,
    window_s: float = 600.0,
    amplitude_method: str = "std",
    period_method: str = "spectral",
    segment_s: float = 200.0,
    period_min_s: float = 1.0,
    period_max_s: float = 30.0,
    min_coverage_pct: float = 80.0,
    bimodal: bool = True,
    fs_hz: float | None = None,
) -> tuple[np.ndarray, dict[str, np.ndarray], np.ndarray]:
    """:func:`motion_statistics` on arrays (no DataFrame in or out), every window kept.

    Parameters
    ----------
    time_ns : array_like of int, shape (n,)
        Sample times, integer ns since the Unix epoch (UTC), increasing.
    roll_pitch_deg : array_like, shape (n, 2)
        Roll and pitch, deg (NaN: missing sample).
    window_s, amplitude_method, period_method, segment_s, period_min_s, period_max_s
        As in :func:`motion_statistics` (s, names, s, s, s).
    min_coverage_pct, bimodal, fs_hz
        As in :func:`motion_statistics` (%, flag, Hz).

    Returns
    -------
    start_ns : numpy.ndarray of int64, shape (nwin,)
        Window starts, ns since the epoch, from the window holding the first sample on.
    columns : dict of numpy.ndarray, shape (nwin,)
        The columns of :data:`MOTION_STAT_COLUMNS` (units in their names).
    present : numpy.ndarray of bool, shape (nwin,)
        Windows with at least one sample (:func:`motion_statistics` returns only these).
    """
    if amplitude_method not in AMPLITUDE_METHODS:
        raise ValueError(
            f"amplitude_method must be one of {AMPLITUDE_METHODS}, got {amplitude_method!r}"
        )
    if period_method not in PERIOD_METHODS:
        raise ValueError(f"period_method must be one of {PERIOD_METHODS}, got {period_method!r}")
    t_ns = np.asarray(time_ns, np.int64)
    roll_pitch_deg = np.asarray(roll_pitch_deg, np.float64)
    if roll_pitch_deg.shape != (t_ns.size, 2):
        raise ValueError(
            f"motion_statistics_arrays: roll_pitch_deg must have shape ({t_ns.size}, 2) "
            f"(one roll and one pitch per sample time), got {roll_pitch_deg.shape}"
        )
    # times relative to the window boundary before the first sample keep float precision
    window_ns = int(round(window_s * 1e9))
    t0_ns = (int(t_ns[0]) // window_ns) * window_ns
    start_s, grid, fs = window_series(
        (t_ns - t0_ns) * 1e-9, roll_pitch_deg, window_s=window_s, fs_hz=fs_hz
    )
    coverage = 100.0 * np.isfinite(grid).all(axis=-1).mean(axis=-1)
    present = np.isfinite(grid).any(axis=(1, 2))
    good = present & (coverage >= min_coverage_pct)
    nwin = grid.shape[0]
    cols = {k: np.full(nwin, np.nan) for k in STATISTIC_COLUMNS}
    if good.any():
        g = grid[good]
        psd = []
        for j, axis in enumerate(("roll", "pitch")):
            x = g[..., j]
            f, p = motion_spectrum(x, fs, segment_s=segment_s)  # once per axis, reused
            band = _band(f, period_min_s, period_max_s)
            psd.append(p)
            if amplitude_method == "std":
                amp = amplitude_std_deg(x)
            elif amplitude_method == "spectral":
                amp = _band_amplitude_deg(f, p, band)
            else:
                amp = amplitude_zero_crossing_deg(x)
            if period_method == "spectral":
                per = _peak_period_s(f, p, band)
            else:
                per = period_zero_crossing_s(x, fs)
            cols[f"{axis}_amplitude_deg"][good] = amp
            cols[f"{axis}_period_s"][good] = per
        if bimodal:
            p1, p2, w1 = two_peaks(
                f, psd[0] + psd[1], period_min_s=period_min_s, period_max_s=period_max_s
            )
            cols["period1_s"][good], cols["period2_s"][good], cols["weight1"][good] = p1, p2, w1
    start_ns = t0_ns + np.rint(start_s * 1e9).astype(np.int64)
    return start_ns, cols | {"imu_availability_pct": coverage}, present


def roll_pitch_correlation(records: pd.DataFrame) -> dict[str, float]:
    """Pearson correlation of roll vs pitch amplitude and period across records.

    Gutiérrez-Antuñano et al. (2018), Sec. 2.4 / Fig. 2 reports 0.88 (amplitude) and 0.54 (period) at
    IJmuiden and uses it to justify one amplitude and one period per record.

    Parameters
    ----------
    records : pandas.DataFrame
        Records or :func:`motion_statistics` output.

    Returns
    -------
    dict
        ``r_amplitude``, ``r_period`` (dimensionless) and ``n`` (records with
        all four values finite).
    """
    from flidar_uq.data.metrics import pearson_r  # with pandas: not in the campaign's workers

    cols = ["roll_amplitude_deg", "pitch_amplitude_deg", "roll_period_s", "pitch_period_s"]
    x = records[cols].to_numpy(dtype=np.float64)
    ok = np.isfinite(x).all(axis=1)
    return {
        "r_amplitude": float(pearson_r(x[ok, 0], x[ok, 1])),
        "r_period": float(pearson_r(x[ok, 2], x[ok, 3])),
        "n": int(ok.sum()),
    }


# --------------------------------------------------------------------------- wind-frame tilt spectrum


def heading_mean_deg(yaw_deg) -> np.ndarray:
    """Buoy heading over each record: the circular mean of the yaw samples, deg.

    ``atan2(mean sin(yaw), mean cos(yaw))`` over the last axis, NaN samples left out (record
    column ``heading_mean_deg``). A heading that turns through north averages correctly
    (350 and 10 deg give 0, not 180).

    Parameters
    ----------
    yaw_deg : array_like, shape (n,) or (nwin, n)
        Yaw samples (counter-clockwise from above), deg; NaN: missing.

    Returns
    -------
    numpy.ndarray, shape () or (nwin,)
        Mean heading in [-180, 180] deg; NaN for a window without a finite sample.
    """
    y = np.deg2rad(np.asarray(yaw_deg, dtype=np.float64))
    ok = np.isfinite(y)
    with np.errstate(invalid="ignore"):
        c = np.where(ok, np.cos(y), 0.0).sum(axis=-1)
        s = np.where(ok, np.sin(y), 0.0).sum(axis=-1)
    return np.where(ok.any(axis=-1), np.rad2deg(np.arctan2(s, c)), np.nan)


def tilt_band_statistics(
    roll_deg,
    pitch_deg,
    yaw_deg,
    wd_deg,
    fs_hz: float,
    *,
    segment_s: float = 200.0,
    n_bands: int = 8,
    period_min_s: float = 1.0,
    period_max_s: float = 20.0,
    velocity_up_ms=None,
    acceleration_up_ms2=None,
    velocity_east_ms=None,
    velocity_north_ms=None,
) -> TiltBandSpectrum:
    """Per-record tilt spectrum along and across the wind, reduced to period bands.

    Each sample's (roll, pitch) is turned into the earth-frame tilt vector with the
    sample's yaw and projected on the record's wind axis
    (:func:`flidar_uq.physics.motion_spectrum.tilt_vector_en` and
    :func:`~flidar_uq.physics.motion_spectrum.project_tilt_on_wind_deg`); the Welch PSDs of the
    two components (:func:`motion_spectrum`, gaps linearly filled) are reduced to
    ``n_bands`` log-spaced bands (:func:`flidar_uq.physics.motion_spectrum.tilt_band_spectrum`).

    Parameters
    ----------
    roll_deg, pitch_deg : array_like, shape (n,) or (nwin, n)
        Uniformly sampled attitude, deg (NaN: missing sample).
    yaw_deg : array_like, shape like roll_deg, or scalar
        Yaw (counter-clockwise from above), deg; 0 if the heading is unknown (then the
        wind direction must be given in the body frame). NaN yaw samples are filled
        linearly (unwrap angles first if they jump by 360 deg).
    wd_deg : array_like, shape () or (nwin,) or (nwin, k)
        Mean wind direction of each record (record column ``wd_mean_deg``), deg. Shape
        ``(nwin, k)``: ``k`` directions per series (e.g. one per measurement height), the
        attitude's trigonometry done once per series; the result's rows are then
        ``(series, direction)`` in row-major order (``nwin * k`` rows).
    fs_hz : float
        Sampling rate, Hz.
    segment_s, n_bands, period_min_s, period_max_s
        Welch segment length (s) and the bands.
    velocity_up_ms : array_like, shape like roll_deg, optional
        Vertical velocity of the buoy, positive up, m/s: then each band's signed
        ``<cos psi>`` and ``<sin psi>`` and its ``<sin psi cos psi>``
        (:func:`band_direction_from_heave`) are in ``cos_psi``, ``sin_psi`` and
        ``sincos_psi``.
    acceleration_up_ms2 : array_like, shape like roll_deg, optional
        Vertical acceleration of the buoy, positive up, gravity removed, m/s^2: without
        ``velocity_up_ms``, the heave (:func:`band_direction_from_heave`).
    velocity_east_ms, velocity_north_ms : array_like, shape like roll_deg, optional
        Horizontal velocity of the buoy towards east and north, m/s: with both, the hull's
        horizontal response (:func:`response_ratio`) is in ``horizontal_response``.

    Returns
    -------
    TiltBandSpectrum
        Arrays of shape ``(nwin, ...)`` (``nwin = 1`` for a single series), or
        ``(nwin * k, ...)``.
    """
    east, north = _tilt_vector(roll_deg, pitch_deg, yaw_deg)  # (nwin, n)
    velocities = {}  # the heave (its velocity, else its acceleration), the horizontal velocity
    if velocity_up_ms is not None:
        velocities["velocity_up_ms"] = _as_2d(velocity_up_ms)[0]
    elif acceleration_up_ms2 is not None:
        velocities["acceleration_up_ms2"] = _as_2d(acceleration_up_ms2)[0]
    if velocity_east_ms is not None and velocity_north_ms is not None:
        velocities["velocity_east_ms"] = _as_2d(velocity_east_ms)[0]
        velocities["velocity_north_ms"] = _as_2d(velocity_north_ms)[0]
    if np.ndim(wd_deg) == 2:  # k directions per series: rows (series, direction)
        wd = np.asarray(wd_deg, np.float64)
        if wd.shape[0] != east.shape[0]:
            raise ValueError(
                f"tilt_band_statistics: wd_deg of shape {wd.shape} needs one row per series "
                f"({east.shape[0]})"
            )
        # each series projected on its k directions by broadcasting (rows: series, direction)
        east, north, wd = east[:, None, :], north[:, None, :], wd[:, :, None]
        velocities = {k: np.repeat(v, wd.shape[1], axis=0) for k, v in velocities.items()}
    else:
        wd = np.asarray(wd_deg, np.float64).reshape(-1, 1) if np.ndim(wd_deg) else float(wd_deg)
    return _projected_band_spectrum(
        east,
        north,
        wd,
        fs_hz,
        segment_s=segment_s,
        n_bands=n_bands,
        period_min_s=period_min_s,
        period_max_s=period_max_s,
        **velocities,
    )


def _tilt_vector(roll_deg, pitch_deg, yaw_deg) -> tuple[np.ndarray, np.ndarray]:
    """Tilt vector (east, north), shape (nwin, n), of the series; NaN yaw samples filled."""
    r, _ = _as_2d(roll_deg)
    p, _ = _as_2d(pitch_deg)
    y = np.broadcast_to(np.asarray(yaw_deg, np.float64), r.shape)
    y = _fill(np.array(y)) if y.ndim == 2 else y
    return tilt_vector_en(r, p, y)


def _projected_band_spectrum(
    east,
    north,
    wd_deg,
    fs_hz,
    *,
    segment_s,
    n_bands,
    period_min_s,
    period_max_s,
    velocity_up_ms=None,
    acceleration_up_ms2=None,
    velocity_east_ms=None,
    velocity_north_ms=None,
) -> TiltBandSpectrum:
    """Band spectrum of the tilt vector projected on the wind (``wd_deg`` broadcast; s, Hz),
    with each band's ``<cos psi>`` from the vertical velocity (m/s) or acceleration
    (m/s^2) where one is given, and the horizontal response (:func:`response_ratio`) from
    the east and north velocities (m/s) where both are."""
    along, across = project_tilt_on_wind_deg(east, north, wd_deg)
    if along.ndim == 3:  # (series, direction, sample): one row a (series, direction)
        along, across = (a.reshape(-1, a.shape[-1]) for a in (along, across))
    f, pa = motion_spectrum(along, fs_hz, segment_s=segment_s)
    _, pc = motion_spectrum(across, fs_hz, segment_s=segment_s)
    # the co-spectrum of the two from the PSD of their sum: |A + C|^2 = |A|^2 + |C|^2 +
    # 2 Re(A* C), segment by segment (the same windows, gaps and trends in all three)
    _, ps = motion_spectrum(along + across, fs_hz, segment_s=segment_s)
    bands = dict(n_bands=n_bands, period_min_s=period_min_s, period_max_s=period_max_s)
    spec = tilt_band_spectrum(f, pa, pc, cospectrum=0.5 * (ps - pa - pc), **bands)
    if velocity_east_ms is not None and velocity_north_ms is not None:
        vel = [_as_2d(v)[0] for v in (velocity_east_ms, velocity_north_ms)]
        none = ~(np.isfinite(vel[0]).any(-1) & np.isfinite(vel[1]).any(-1))
        p_h = sum(
            motion_spectrum(np.where(none[:, None], 0.0, v), fs_hz, segment_s=segment_s)[1]
            for v in vel
        )
        ratio = response_ratio(f, p_h, pa + pc, period_min_s, period_max_s)
        spec = replace(spec, horizontal_response=np.where(none, np.nan, ratio))
    if velocity_up_ms is None and acceleration_up_ms2 is None:
        return spec
    cos_psi, sin_psi, sincos_psi, heave_response = band_direction_from_heave(
        velocity_up_ms,
        along,
        across,
        fs_hz,
        acceleration_up_ms2=acceleration_up_ms2,
        segment_s=segment_s,
        **bands,
    )
    return replace(
        spec,
        cos_psi=cos_psi,
        sin_psi=sin_psi,
        # the same co-spectrum's, taken with the heave's (NaN where the heave is)
        sincos_psi=np.where(np.isfinite(sincos_psi), sincos_psi, spec.sincos_psi),
        heave_response=heave_response,
    )


def tilt_spectrum_columns(spec: TiltBandSpectrum) -> dict[str, np.ndarray]:
    """The optional record columns of :data:`TILT_SPECTRUM_COLUMNS` from a band spectrum.

    ``tilt_along_wind_std_deg`` = ``sqrt(m0)`` of the along-wind tilt in the bands,
    ``tilt_across_wind_std_deg`` likewise across, ``tilt_period_zero_crossing_s`` =
    ``sqrt(m0/m2)`` (along), ``tilt_period_mean_s`` = ``m0/m1`` (along); deg and s.
    """
    if spec.period_s.shape[-1] != N_TILT_BANDS:
        raise ValueError(
            f"tilt_spectrum_columns: the record table holds {N_TILT_BANDS} tilt bands, the "
            f"spectrum has {spec.period_s.shape[-1]}"
        )
    bands = {}
    for b in range(N_TILT_BANDS):
        per, along, across = tilt_band_column_names(b + 1)
        bands[per] = np.asarray(spec.period_s[:, b], float)
        bands[along] = np.asarray(spec.var_along_deg2[:, b], float)
        bands[across] = np.asarray(spec.var_across_deg2[:, b], float)
        if spec.cos_psi is not None:
            bands[tilt_band_cos_psi_column(b + 1)] = np.asarray(spec.cos_psi[:, b], float)
        if spec.sin_psi is not None:
            bands[tilt_band_sin_psi_column(b + 1)] = np.asarray(spec.sin_psi[:, b], float)
        if spec.sincos_psi is not None:
            bands[tilt_band_sincos_psi_column(b + 1)] = np.asarray(spec.sincos_psi[:, b], float)
    if spec.heave_response is not None:
        bands[HEAVE_RESPONSE_COLUMN] = np.asarray(spec.heave_response, float)
    if spec.horizontal_response is not None:
        bands[HORIZONTAL_RESPONSE_COLUMN] = np.asarray(spec.horizontal_response, float)
    return (
        {
            "tilt_along_wind_std_deg": spec.along_std_deg,
            "tilt_across_wind_std_deg": spec.across_std_deg,
            "tilt_period_zero_crossing_s": spec.tz_s,
            "tilt_period_mean_s": spec.tm01_s,
        }
        | follower_translation_columns(spec)
        | bands
    )


def band_direction_moments(var_along, var_across, sincos_psi=None) -> tuple[np.ndarray, np.ndarray]:
    """``<cos^2 psi>`` and ``<cos psi>`` of each band's directions of travel against the wind.

    ``<cos^2 psi>`` is the band's along-wind share of the tilt variance. With the band's
    ``<sin psi cos psi>`` (the along-across tilt co-spectrum's share) the tilt gives the
    second directional moments ``a2 = <cos 2 psi> = 2 <cos^2 psi> - 1`` and ``b2 = <sin 2
    psi> = 2 <sin psi cos psi>``, whose angle is twice the band's mean axis ``theta2`` and
    whose length ``r2`` is ``exp(-2 s^2)`` for a wrapped-normal spread ``s`` (Kuik, van
    Vledder and Holthuijsen, 1988). The tilt cannot tell a wave running downwind from one
    running upwind, so ``<cos psi>`` is taken as for waves running along that axis on its
    downwind side: ``<cos psi> = r1 |cos theta2|`` with ``r1 = exp(-s^2 / 2) = r2^(1/4)``;
    0 for a band across the wind (a swell whose side the tilt cannot tell). Without
    ``sincos_psi`` the axis is taken on the wind's (``b2 = 0``): ``(2 <cos^2 psi> -
    1)^(1/4)`` where the band is mostly along the wind, else 0; a wind sea running at an
    angle to the wind then takes too small a ``<cos psi>`` (0.97 of it at 30 deg, 0.84
    at 40 deg, none from 45 deg).

    Parameters
    ----------
    var_along, var_across : array_like
        Tilt variance along and across the wind per band (any one unit, e.g. deg^2).
    sincos_psi : array_like, optional
        Each band's ``<sin psi cos psi>`` (-, record column ``tilt_band{b}_sincos_psi``);
        NaN or absent: 0.

    Returns
    -------
    (numpy.ndarray, numpy.ndarray)
        ``<cos^2 psi>`` and ``<cos psi>`` (-), 0 for an empty band.
    """
    va = np.asarray(var_along, float)
    vt = va + np.asarray(var_across, float)
    with np.errstate(invalid="ignore", divide="ignore"):
        share = np.where(vt > 0, va / np.where(vt > 0, vt, 1.0), 0.0)
    a2 = 2.0 * share - 1.0
    b2 = 0.0 if sincos_psi is None else np.nan_to_num(2.0 * np.asarray(sincos_psi, float))
    r2 = np.minimum(np.hypot(a2, b2), 1.0)
    with np.errstate(invalid="ignore", divide="ignore"):
        cos_axis_sq = 0.5 * (1.0 + np.where(r2 > 0, a2 / np.where(r2 > 0, r2, 1.0), -1.0))
    cos_mean = r2**0.25 * np.sqrt(np.clip(cos_axis_sq, 0.0, 1.0))
    return share, cos_mean


def tilt_bands_from_records(records: pd.DataFrame):
    """The tilt bands of a record table (:data:`N_TILT_BANDS` bands, ``tilt_band{b}_*``).

    Returns
    -------
    dict or None
        ``amplitude_deg`` (the lean amplitude of each band along its direction of travel,
        ``sqrt(2 (var_along + var_across))``, deg), ``period_s`` (s), ``cos_sq_psi`` and
        ``cos_psi`` (-, :func:`band_direction_moments`), ``cos_psi_measured`` and
        ``sin_psi_measured`` and ``sincos_psi_measured`` (-, the optional
        ``tilt_band{b}_cos_psi``, ``tilt_band{b}_sin_psi`` and ``tilt_band{b}_sincos_psi``
        columns of :func:`band_direction_from_heave`, NaN where absent), each of shape
        (n_records, n_bands), ``edges_s`` (the bands' edges, s, shape (n_bands + 1,):
        log-spaced over 1-20 s) and ``complete`` (n_records,) True where every band value
        is finite; None when the table lacks a band column.
    """
    names = [tilt_band_column_names(b + 1) for b in range(N_TILT_BANDS)]
    if any(c not in records for cols in names for c in cols):
        return None

    def stack(i):
        return np.stack([records[cols[i]].to_numpy(dtype=float) for cols in names], axis=-1)

    per, va, vc = stack(0), stack(1), stack(2)
    complete = np.all(np.isfinite(per) & np.isfinite(va) & np.isfinite(vc), axis=-1)

    def measured(column):
        out = np.full(per.shape, np.nan)
        for b in range(N_TILT_BANDS):
            if column(b + 1) in records:
                out[:, b] = records[column(b + 1)].to_numpy(dtype=float)
        return out

    sincos = measured(tilt_band_sincos_psi_column)
    cos_sq, cos_mean = band_direction_moments(va, vc, sincos)
    return {
        "amplitude_deg": np.sqrt(2.0 * (va + vc)),
        "period_s": per,
        "cos_sq_psi": cos_sq,
        "cos_psi": cos_mean,
        "cos_psi_measured": measured(tilt_band_cos_psi_column),
        "sin_psi_measured": measured(tilt_band_sin_psi_column),
        "sincos_psi_measured": sincos,
        "edges_s": band_edges_s(N_TILT_BANDS, *PERIOD_RANGE_S),
        "complete": complete,
    }


def follower_translation_columns(spec: TiltBandSpectrum) -> dict[str, np.ndarray]:
    """What a hull that follows the waves with a record's tilt spectrum would translate.

    Per band ``b`` of tilt variance ``var_b`` (rad^2) at period ``T_b``, a wave follower's
    heave velocity and horizontal orbital velocity have variance ``var_b (g / omega_b)^2``
    (linear deep-water waves: ``c = g / omega`` per radian of lean,
    :mod:`flidar_uq.physics.hull`); heave from the along + across tilt, the horizontal
    velocity along the wind from the along-wind tilt. The heave is correlated with the
    along-wind tilt through ``<cos psi>`` of the band's directions of travel
    (:func:`band_direction_moments`).

    Returns
    -------
    dict
        ``follower_heave_velocity_std_ms``, ``follower_heave_period_s`` (mean period m0/m1
        of the heave velocity's band variances), ``follower_velocity_along_wind_std_ms``
        (m/s, s) and ``follower_heave_tilt_correlation`` (-); NaN where the tilt is.
    """
    to_rad2 = np.deg2rad(1.0) ** 2
    va = np.asarray(spec.var_along_deg2, float) * to_rad2
    vt = va + np.asarray(spec.var_across_deg2, float) * to_rad2
    c = G_MS2 * np.asarray(spec.period_s, float) / (2.0 * np.pi)  # phase speed, m/s
    heave_var = np.sum(vt * c**2, axis=-1)
    along_var = np.sum(va * c**2, axis=-1)
    _, cos_mean = band_direction_moments(va, vt - va, spec.sincos_psi)
    if spec.cos_psi is not None:  # measured from the heave where it is
        cos_mean = np.where(np.isfinite(spec.cos_psi), spec.cos_psi, cos_mean)
    with np.errstate(invalid="ignore", divide="ignore"):
        cov = np.sum(c * cos_mean * vt, axis=-1)  # cov(heave velocity, along-wind lean)
        corr = cov / np.sqrt(heave_var * np.sum(va, axis=-1))
        inv_per = np.sum(vt * c**2 / np.asarray(spec.period_s, float), axis=-1) / heave_var
    return {
        "follower_heave_velocity_std_ms": np.sqrt(heave_var),
        "follower_heave_period_s": 1.0 / inv_per,
        "follower_velocity_along_wind_std_ms": np.sqrt(along_var),
        "follower_heave_tilt_correlation": np.clip(corr, -1.0, 1.0),
    }


def tilt_spectrum_statistics_by_height(
    imu: pd.DataFrame,
    wd_by_height: Mapping,
    *,
    window_s: float = 600.0,
    segment_s: float = 200.0,
    n_bands: int = 8,
    min_coverage_pct: float = 80.0,
    fs_hz: float | None = None,
) -> dict:
    """Wind-frame tilt statistics of a raw IMU series, per 10-min window, for each height.

    The attitude is gridded, turned into the tilt vector (its trigonometry) and averaged
    into the heading once (not once per height), then projected on each height's wind
    directions: the same values as one call per height (3 days of a 20-Hz series at three
    heights through the IMU step: 7.5 -> 5.2 s CPU).

    Parameters
    ----------
    imu : pandas.DataFrame
        Validated IMU series: ``timestamp``, ``roll_deg``, ``pitch_deg`` and optionally
        ``yaw_deg`` (without it the heading is taken as 0, i.e. body y = north).
    wd_by_height : mapping
        Height (m) -> mean wind direction per window, deg: a Series indexed by the window
        start (UTC timestamps, e.g. ``records.groupby("timestamp")["wd_mean_deg"].mean()``
        of the height's records) or a function of the window-start timestamps returning an
        array.
    window_s, segment_s, n_bands, min_coverage_pct
        Window length (s), Welch segment (s), number of bands, coverage threshold (%).
    fs_hz : float, optional
        Nominal sampling rate, Hz (default: from the median interval, as in
        :func:`motion_statistics`).

    Returns
    -------
    dict
        Height -> ``(table, spectrum)``, in the mapping's order. ``table``: one row per
        window with a sample: ``timestamp`` (window start), the columns of
        :data:`TILT_SPECTRUM_COLUMNS` (NaN for windows below the coverage threshold or
        without a wind direction) and ``heading_mean_deg`` (:func:`heading_mean_deg`; NaN
        without a yaw column or below the coverage threshold). ``spectrum``: the
        :class:`TiltBandSpectrum` of the same rows (NaN rows for the NaN windows).
    """
    heights = list(wd_by_height)
    if not heights:
        return {}
    out = _tilt_spectrum_windows(
        imu,
        [wd_by_height[h] for h in heights],
        window_s=window_s,
        segment_s=segment_s,
        n_bands=n_bands,
        min_coverage_pct=min_coverage_pct,
        fs_hz=fs_hz,
    )
    return dict(zip(heights, out, strict=True))


def _tilt_spectrum_windows(
    imu, wd_sources, *, window_s, segment_s, n_bands, min_coverage_pct, fs_hz
) -> list[tuple[pd.DataFrame, TiltBandSpectrum]]:
    """The windows' grid, coverage, tilt vector and heading once; one ``(table, spectrum)``
    of :func:`tilt_spectrum_statistics_by_height` per source of wind directions."""
    import pandas as pd

    t_ns = pd.DatetimeIndex(imu["timestamp"]).as_unit("ns").asi8
    window_ns = int(round(window_s * 1e9))
    t0_ns = (int(t_ns[0]) // window_ns) * window_ns
    names = ["roll_deg", "pitch_deg"] + (["yaw_deg"] if "yaw_deg" in imu.columns else [])
    # the heave: its velocity, else its acceleration (band_direction_from_heave divides its
    # spectra by i omega)
    heave = next((c for c in ("velocity_up_ms", "acceleration_up_ms2") if c in imu.columns), None)
    names += [heave] if heave else []
    # the horizontal velocity: its east and north components (response_ratio)
    horizontal = [c for c in ("velocity_east_ms", "velocity_north_ms") if c in imu.columns]
    horizontal = horizontal if len(horizontal) == 2 else []
    names += horizontal
    vals = imu[names].to_numpy(dtype=np.float64)
    start_s, grid, fs = window_series((t_ns - t0_ns) * 1e-9, vals, window_s=window_s, fs_hz=fs_hz)
    stamps = pd.to_datetime(t0_ns + np.rint(start_s * 1e9).astype(np.int64), utc=True)
    wd = np.stack(
        [
            np.asarray(src(stamps), np.float64)
            if callable(src)
            else pd.Series(src).reindex(stamps).to_numpy(dtype=np.float64)
            for src in wd_sources
        ],
        axis=-1,
    )  # (nwin, k)
    coverage = 100.0 * np.isfinite(grid[..., :2]).all(axis=-1).mean(axis=-1)
    present = np.isfinite(grid[..., :2]).any(axis=(1, 2))
    covered = present & (coverage >= min_coverage_pct)
    good = covered[:, None] & np.isfinite(wd)
    has_yaw = "yaw_deg" in names
    yaw = grid[..., 2] if has_yaw else 0.0
    east, north = _tilt_vector(grid[..., 0], grid[..., 1], yaw)  # once for every source
    heading = (
        np.where(covered, heading_mean_deg(yaw), np.nan)
        if has_yaw
        else np.full(len(stamps), np.nan)
    )
    col = {name: grid[..., i] for i, name in enumerate(names)}
    # a velocity counts in a window only where it covers it as the tilt must (a separate
    # MRU's or GNSS's gaps: filled linearly, a sparse velocity would lose band power)
    velocity_series = {}
    for group in ([heave] if heave else [], horizontal):
        if group:
            both = np.all([np.isfinite(col[c]) for c in group], axis=0)
            thin = 100.0 * both.mean(axis=-1) < min_coverage_pct
            velocity_series |= {c: np.where(thin[:, None], np.nan, col[c]) for c in group}
    keep = np.flatnonzero(present)
    out = []
    for j in range(wd.shape[1]):
        # one source's windows at a time (its spectra, then its table)
        spec = _projected_band_spectrum(
            east,
            north,
            np.where(good[:, j], wd[:, j], 0.0)[:, None],
            fs,
            segment_s=segment_s,
            n_bands=n_bands,
            period_min_s=PERIOD_RANGE_S[0],
            period_max_s=PERIOD_RANGE_S[1],
            **velocity_series,
        ).masked(good[:, j])
        table = pd.DataFrame(
            {"timestamp": stamps} | tilt_spectrum_columns(spec) | {"heading_mean_deg": heading}
        )
        out.append((table.iloc[keep].reset_index(drop=True), spec.take(keep)))
    return out
