"""Sea state and the buoy's narrow-band roll/pitch motion.

The buoy tilt is modelled as a linear, wave-following response whose spectrum has
the shape of the JONSWAP elevation spectrum of each wave system (wind sea and an
optional swell): a flat transfer function over the narrow band of each system, so
the tilt spectrum peaks at the sea state's peak period ``tp_s``. Roll and pitch
come from the same waves seen from two perpendicular axes: each Fourier component
travels in its own direction ``theta`` drawn around the system's mean direction
(wrapped-normal directional spreading), and a buoy that follows the surface slope
tilts by ``roll = +d(eta)/dy``, ``pitch = -d(eta)/dx`` (small angles, ``R = Rz Ry Rx``
of ``docs/conventions.md``: the body z axis is ``(pitch, -roll, 1)``). Roll and
pitch are therefore correlated but not identical; a wind sea plus a swell gives the
bimodal periods of Gutiérrez-Antuñano et al. (2018), Sec. 2.4.

Amplitudes follow the convention of ``docs/conventions.md``: a system's
``amplitude_deg`` is ``sqrt(2)`` times the expected std of its tilt, shared by roll
and pitch so that ``(A_roll^2 + A_pitch^2) / 2 = A^2``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from flidar_uq.physics.hull import G_MS2, get_hull
from flidar_uq.physics.turbulence import complex_normal_coefficients

__all__ = [
    "WIND_SEA_MAX_WAVE_AGE",
    "WaveSystem",
    "downwind_side_known",
    "jonswap_spectrum",
    "tilt_series",
    "hull_motion_series",
]


#: Largest wave age ``c / U`` (phase speed over the mean wind speed) of waves the wind still
#: drives: the fully developed sea of Pierson & Moskowitz (1964) has its peak at
#: ``c_p / U_19.5 = 1.14``, about 1.2 in the 10-m wind. Older waves are swell.
WIND_SEA_MAX_WAVE_AGE = 1.2


def downwind_side_known(period_s, hws_ms) -> np.ndarray:
    """True where waves of ``period_s`` (s) can be taken to run downwind in a wind of
    ``hws_ms`` (m/s): deep-water wave age ``c / U = g T / (2 pi U)`` at most
    :data:`WIND_SEA_MAX_WAVE_AGE` (Pierson & Moskowitz 1964). A tilt record cannot tell
    a wave running downwind from one running upwind; for wind sea the wind decides, for
    swell (older waves) neither side is known."""
    c = G_MS2 * np.asarray(period_s, float) / (2.0 * np.pi)
    u = np.asarray(hws_ms, float)
    return c <= WIND_SEA_MAX_WAVE_AGE * u


@dataclass(frozen=True)
class WaveSystem:
    """One wave system (wind sea or swell) driving the buoy tilt.

    Attributes
    ----------
    amplitude_deg : float
        Tilt amplitude of this system (deg), ``sqrt(2)`` x expected std of roll
        and of pitch averaged in quadrature.
    tp_s : float
        Peak period (s).
    gamma : float
        JONSWAP peak enhancement factor (1 = Pierson-Moskowitz; 3.3 typical wind
        sea; 5-10 swell).
    direction_deg : float
        Mean direction of travel relative to the body x axis (deg, counter-clockwise
        seen from above).
    spread_deg : float
        Std of the wrapped-normal directional spreading (deg).
    """

    amplitude_deg: float
    tp_s: float
    gamma: float = 3.3
    direction_deg: float = 0.0
    spread_deg: float = 30.0


def jonswap_spectrum(f_hz, hs_m, tp_s, gamma=3.3):
    """JONSWAP wave-elevation spectrum (one-sided, frequency form).

    ``S(f) = C(gamma) (5/16) Hs^2 fp^4 f^-5 exp(-5/4 (fp/f)^4) gamma^r``,
    ``r = exp(-(f - fp)^2 / (2 sigma^2 fp^2))``, ``sigma = 0.07 (f <= fp), 0.09``,
    with Goda's normalisation ``C(gamma) = 1 - 0.287 ln(gamma)`` (DNV-RP-C205
    Eqs. 3.5.5.1-3.5.5.4), so that ``integral S df ~= Hs^2 / 16``.

    Parameters
    ----------
    f_hz : array_like
        Frequency (Hz), broadcast with the other arguments.
    hs_m : array_like
        Significant wave height (m).
    tp_s : array_like
        Peak period (s), > 0.
    gamma : array_like
        Peak enhancement factor, 1 <= gamma <= 10 (DNV validity range of C(gamma)).

    Returns
    -------
    numpy.ndarray
        Spectral density (m^2/Hz); 0 at f <= 0; NaN for ``tp_s <= 0`` or gamma
        outside [1, 10].
    """
    f = np.asarray(f_hz, float)
    tp = np.asarray(tp_s, float)
    g = np.asarray(gamma, float)
    ok = (tp > 0) & (g >= 1.0) & (g <= 10.0)
    fp = 1.0 / np.where(ok, tp, np.nan)
    fpos = np.where(f > 0, f, np.nan)
    sigma = np.where(f <= fp, 0.07, 0.09)
    r = np.exp(-((f - fp) ** 2) / (2.0 * sigma**2 * fp**2))
    pm = (
        5.0
        / 16.0
        * np.asarray(hs_m, float) ** 2
        * fp**4
        * fpos**-5
        * np.exp(-1.25 * (fp / fpos) ** 4)
    )
    s = (1.0 - 0.287 * np.log(g)) * pm * g**r  # DNV-RP-C205 Eq. (3.5.5.1)
    return np.where(f > 0, s, 0.0)


def tilt_series(
    n_samples: int,
    dt_s: float,
    systems,
    rng: np.random.Generator,
):
    """Random roll and pitch series of a wave-following buoy (narrow-band, JONSWAP).

    Spectral synthesis per wave system: the tilt PSD is the JONSWAP shape of the
    system (:func:`jonswap_spectrum` normalised to unit area) scaled to the tilt
    variance ``amplitude_deg^2`` (sum of roll and pitch variances, each
    ``A^2 / 2`` on average). Each Fourier component gets a complex Gaussian
    coefficient and a direction ``theta`` around ``direction_deg``; roll takes
    ``sin(theta)`` of it and pitch ``-cos(theta)`` (slope of the surface along body
    y and x). Vectorised over a leading batch of records.

    Parameters
    ----------
    n_samples : int
        Samples per series (>= 8).
    dt_s : float
        Sampling interval (s), > 0; Nyquist must lie above ``2 / tp_s``.
    systems : sequence of WaveSystem, or dict of arrays
        The wave systems summed (e.g. wind sea, swell). A dict with keys
        ``amplitude_deg, tp_s, gamma, direction_deg, spread_deg`` whose values are
        arrays of shape ``(n_records, n_systems)`` gives a batch.
    rng : numpy.random.Generator
        Source of randomness.

    Returns
    -------
    roll_deg, pitch_deg : numpy.ndarray
        Tilt series (deg), shape ``(n_samples,)`` for a sequence of systems or
        ``(n_records, n_samples)`` for a batch dict.
    """
    comp = _sea_components(n_samples, dt_s, systems, rng)
    roll, pitch = _tilt_from_components(comp)
    if comp.single:
        return roll[0], pitch[0]
    return roll, pitch


@dataclass(frozen=True)
class _SeaComponents:
    """The Fourier components of a batch of records' seas (:func:`_sea_components`)."""

    n: int  # samples per series
    n_f: int  # one-sided bins of the series
    f_hz: np.ndarray  # (nb,) frequencies of the synthesised bins
    coef: np.ndarray  # (R, S, nb) complex slope coefficients, deg (x = n irfft)
    theta: np.ndarray  # (R, S, nb) directions of travel, rad, from the body x axis
    single: bool


def _sea_components(n_samples, dt_s, systems, rng) -> _SeaComponents:
    """Draw the complex slope coefficient and the direction of every Fourier component."""
    n = int(n_samples)
    if n < 8:
        raise ValueError(f"tilt_series: n_samples must be >= 8, got {n_samples!r}")
    if not dt_s > 0:
        raise ValueError(f"tilt_series: dt_s must be > 0, got {dt_s!r}")
    single = not isinstance(systems, dict)
    if single:
        if len(systems) == 0:
            raise ValueError("tilt_series: need at least one WaveSystem")
        keys = ("amplitude_deg", "tp_s", "gamma", "direction_deg", "spread_deg")
        par = {k: np.array([[getattr(s, k) for s in systems]], float) for k in keys}
    else:
        par = {k: np.atleast_2d(np.asarray(v, float)) for k, v in systems.items()}
    amp = par["amplitude_deg"]  # (R, S)
    n_f = n // 2 + 1  # one-sided bins
    df = 1.0 / (n * dt_s)  # numpy.fft.rfftfreq's frequencies, k * df
    # JONSWAP above 8 f_p holds < 1e-4 of the variance: synthesise only the bins below
    tp_min = np.nanmin(np.where(amp > 0, par["tp_s"], np.inf))
    n_b = n_f if not np.isfinite(tp_min) else min(n_f, int(8.0 / tp_min / df) + 2)
    f = np.arange(n_b) * df
    shape = jonswap_spectrum(f, 1.0, par["tp_s"][..., None], par["gamma"][..., None])
    if not np.isfinite(shape).all():
        shape = np.nan_to_num(shape)  # (R, S, nb)
    area = shape.sum(axis=-1, keepdims=True) * df
    var_bins = amp[..., None] ** 2 * shape * df / np.where(area > 0, area, np.inf)
    # complex coefficient per (record, system, bin); x = n irfft(C): E power 4 s^2
    # the complex coefficients, then the components' directions
    coef = complex_normal_coefficients(rng, 0.5 * np.sqrt(var_bins))
    z_dir = rng.standard_normal(var_bins.shape)
    coef[..., 0] = 0.0
    if n % 2 == 0 and n_b == n_f:
        coef[..., -1] = 0.0
    # a normal direction about the mean, taken modulo 2 pi by the sine and cosine
    theta = (
        np.deg2rad(par["direction_deg"])[..., None]
        + np.deg2rad(par["spread_deg"])[..., None] * z_dir
    )
    return _SeaComponents(n, n_f, f, coef, theta, single)


def _series(comp: _SeaComponents, spectra: list[np.ndarray]) -> np.ndarray:
    """Series ``n irfft`` of one-sided spectra over the synthesised bins, shape
    ``(len(spectra), R, n)``; the bins above are zero (padded here, as irfft would pad
    them: numpy's irfft pads a batch row by row)."""
    spec = np.zeros((len(spectra), comp.coef.shape[0], comp.n_f), complex)
    for k, s in enumerate(spectra):
        spec[k, :, : comp.f_hz.size] = s
    return np.fft.irfft(spec, n=comp.n, axis=-1) * comp.n


def _tilt_from_components(comp: _SeaComponents):
    coef, theta = comp.coef, comp.theta
    roll = (coef * np.sin(theta)).sum(axis=1)  # roll = +d(eta)/dy (module docstring)
    pitch = (-coef * np.cos(theta)).sum(axis=1)  # pitch = -d(eta)/dx
    return _series(comp, [roll, pitch])


def hull_motion_series(
    n_samples: int,
    dt_s: float,
    systems,
    rng: np.random.Generator,
    hull,
    *,
    return_components: bool = False,
):
    """Roll, pitch, and the translation of a hull in a directional sea (six degrees of freedom).

    The tilt is :func:`tilt_series`'s (the same draws, the same numbers); each Fourier
    component of slope ``S`` (the hull's tilt response applied) moves the hull horizontally
    by ``R_x S / k`` along its direction of travel and vertically by ``R_z i S / k``
    (linear deep-water waves, ``k = (2 pi f)^2 / g``; ``R_x, R_z`` the hull's responses
    relative to its tilt, :meth:`flidar_uq.physics.hull.HullResponse.relative_responses`;
    :mod:`flidar_uq.physics.hull`). Tilt and translation of one component are coherent.

    Parameters
    ----------
    n_samples, dt_s, systems, rng
        As :func:`tilt_series`.
    hull : str or HullResponse
        The hull (:data:`flidar_uq.physics.hull.HULLS`).
    return_components : bool
        Also return ``components``: the realised Fourier components, ``amplitude_deg``
        (lean amplitude along the direction of travel, ``2 |C|``, deg), ``period_s`` (s) and
        ``direction_deg`` (of travel, from the body x axis, counter-clockwise, deg), each of
        shape ``(n_records, n_systems, n_bins)`` (the spectral description of the record).

    Returns
    -------
    dict
        ``roll_deg``, ``pitch_deg`` (deg), ``surge_m``, ``sway_m`` (horizontal displacement
        along the body x and y axes of a constant heading, m) and ``heave_m`` (up, m), each
        of shape ``(n_samples,)`` for a sequence of systems or ``(n_records, n_samples)``.
    """
    comp = _sea_components(n_samples, dt_s, systems, rng)
    roll, pitch = _tilt_from_components(comp)
    h = get_hull(hull)
    f = comp.f_hz
    with np.errstate(divide="ignore", invalid="ignore"):
        inv_k = np.where(f > 0, G_MS2 / (2.0 * np.pi * np.where(f > 0, f, 1.0)) ** 2, 0.0)
        period = np.where(f > 0, 1.0 / np.where(f > 0, f, 1.0), np.inf)
    r_x, r_z = h.relative_responses(period)
    slope_m = np.deg2rad(1.0) * comp.coef * inv_k  # S / k, m, per component
    along = r_x * slope_m
    surge = (along * np.cos(comp.theta)).sum(axis=1)
    sway = (along * np.sin(comp.theta)).sum(axis=1)
    heave = (1j * r_z * slope_m).sum(axis=1)
    surge, sway, heave = _series(comp, [surge, sway, heave])
    out = dict(roll_deg=roll, pitch_deg=pitch, surge_m=surge, sway_m=sway, heave_m=heave)
    if comp.single:
        out = {k: v[0] for k, v in out.items()}
    if return_components:
        out["components"] = dict(
            amplitude_deg=2.0 * np.abs(comp.coef),
            period_s=np.broadcast_to(period, comp.coef.shape),
            direction_deg=np.rad2deg(comp.theta),
        )
    return out
