"""Spectral response of a motionless profiling lidar to turbulence: the HWS std it measures
relative to the point (cup-like) HWS std.

A VAD or DBS lidar retrieves the wind of one scan from lines of sight taken at different
times (50 over 1 s for a ZephIR 300, 4 over 4 s for a WindCube V1). Turbulence that
changes within the scan leaks into the retrieved horizontal wind: the vertical wind
``w'`` through ``cot(theta) cos(psi)`` and the horizontal components at twice the scan
frequency, while the scan average filters the highest frequencies of ``u'``. For frozen,
spatially uniform turbulence (the virtual campaign's 1-D series; for a real atmosphere it
is the temporal part of the effect) the retrieved along-wind component of one scan is a
linear functional of the wind series,

``a = sum_k [c_u,k u'(t_k) + c_v,k v'(t_k) + c_w,k w'(t_k)]``,

with ``c_k`` from the least-squares VAD operator (:func:`flidar_uq.physics.lidar.vad_pseudo_inverse`)
projected on the wind direction. For stationary independent components with one-sided
spectra ``S_j(f)`` its variance is ``sum_j int S_j(f) <|H_j(f)|^2> df`` with
``H_j(f) = sum_k c_j,k exp(2 pi i f t_k)``, averaged over the wind direction relative to
the scan (uniform; for a VAD this is the average over the scan phase). The ratio to the
point variance ``int S_u df`` is the lidar's variance ratio (Sathe et al. 2011, "Can wind
lidars measure turbulence?", J. Atmos. Oceanic Technol. 28, Eqs. 5-9, the temporal part;
the spectra are the IEC 61400-1 Kaimal spectra of :mod:`flidar_uq.physics.turbulence`).

The Bayesian correction (:mod:`flidar_uq.correction.propagation`) is calibrated against a motionless
reference lidar, so its corrected std estimates the std that lidar would measure;
dividing by :func:`lidar_std_ratio` turns it into the point std (docs/lidar-response.md).
Cross-wind fluctuations enter the HWS at second order (``v'^2 / 2U``) and are neglected.
"""

from __future__ import annotations

from functools import lru_cache
from typing import NamedTuple

import numpy as np

from flidar_uq.physics import lidar as _lidar
from flidar_uq.physics.turbulence import (
    IEC_SIGMA_RATIOS,
    KAIMAL_LENGTH_PER_LAMBDA1,
    kaimal_lambda1_m,
    kaimal_psd,
    kaimal_series,
    record_variance_share,
)
from flidar_uq.seeding import as_seedsequence

__all__ = ["lidar_pair_correlation", "lidar_point_log_sd", "lidar_std_ratio", "scan_response"]


def _time_scale_s(hws_ms, height_m):
    """``Lambda_1(z) / U`` (s) of the broadcast inputs, its finite mask and a NaN output."""
    u, z = np.broadcast_arrays(np.asarray(hws_ms, float), np.asarray(height_m, float))
    with np.errstate(invalid="ignore", divide="ignore"):
        x = kaimal_lambda1_m(z) / np.where(u > 0, u, np.nan)
    return x, np.isfinite(x), np.full(u.shape, np.nan)


#: a direction-dependent call reads 24 direction nodes and the direction average
@lru_cache(maxsize=64)
def _response_cached(lidar_name_or_geom, f_key, n_dir, beta_deg=None):
    f = np.asarray(f_key)
    g = _lidar.get_lidar(lidar_name_or_geom)
    t_s, az = _lidar.scan_times_azimuths(g, 0.0)
    d = _lidar.beam_unit_vectors_body(g, az)  # (K, 3)
    p = _lidar.vad_pseudo_inverse(d)  # (3, K)
    if beta_deg is None:  # wind direction vs body axes, uniform
        beta = 2.0 * np.pi * (np.arange(n_dir) + 0.5) / n_dir
    else:
        beta = np.deg2rad(np.atleast_1d(float(beta_deg)))
        n_dir = 1
    e_u = np.stack([np.cos(beta), np.sin(beta), np.zeros(n_dir)], -1)  # along-wind
    e_v = np.stack([-np.sin(beta), np.cos(beta), np.zeros(n_dir)], -1)  # cross-wind
    e_w = np.broadcast_to([0.0, 0.0, 1.0], (n_dir, 3))
    proj = e_u[:, :2] @ p[:2]  # (D, K): along-wind component of the retrieval
    # a DBS lidar with a wind after every beam: the mean over the windows' beam orders
    t_win = _lidar.window_beam_times_s(g) if g.kind == "dbs" else t_s[None, :]  # (S, K)
    phase = np.exp(2j * np.pi * f[None, :, None] * t_win[:, None, :])  # (S, F, K)
    # each line of sight averages the wind over its duration (boxcar)
    box = np.sinc(f * g.los_duration_s) ** 2
    out = []
    for e in (e_u, e_v, e_w):
        c = proj * (e @ d.T)  # (D, K): weight of the component at each line of sight
        out.append(np.mean(np.abs(phase @ c.T) ** 2, axis=(0, 2)) * box)
    return np.stack(out)  # (3, F)


def scan_response(f_hz, lidar="zephir300", *, n_dir: int = 72, wind_body_deg=None):
    """Direction-averaged power transfer ``<|H_j(f)|^2>`` of one scan for u', v', w'.

    Parameters
    ----------
    f_hz : array_like, shape (F,)
        Frequencies, Hz.
    lidar : str or LidarGeometry
        Scan geometry (:func:`flidar_uq.physics.lidar.get_lidar`).
    n_dir : int
        Wind directions relative to the scan averaged over (uniform).
    wind_body_deg : float, optional
        The one direction the wind blows towards, deg counter-clockwise from the body x
        axis (a DBS lidar's beams are fixed to its body: its transfer depends on it);
        default None, the average over ``n_dir`` directions.

    Returns
    -------
    numpy.ndarray, shape (3, F)
        Power transfer from the along-wind, cross-wind and vertical fluctuation to the
        retrieved along-wind HWS, dimensionless. At ``f -> 0`` it is ``(1, 0, 0)``.
    """
    f = tuple(np.atleast_1d(np.asarray(f_hz, dtype=float)).tolist())
    if int(n_dir) < 4:
        raise ValueError(f"scan_response: n_dir={n_dir} must be >= 4")
    beta = None if wind_body_deg is None else float(wind_body_deg)
    return _response_cached(lidar, f, int(n_dir), beta)


def _frequency_grid(lidar, record_length_s, n_per_decade=400):
    g = _lidar.get_lidar(lidar)
    f_max = 20.0 / g.los_duration_s  # boxcar of the line of sight makes the rest negligible
    f_min = 1e-3 / record_length_s  # the record-mean removal makes the rest negligible
    n = int(np.ceil(np.log10(f_max / f_min) * n_per_decade))
    return np.geomspace(f_min, f_max, n)


def lidar_std_ratio(
    hws_ms,
    height_m,
    lidar="zephir300",
    *,
    sigma_ratios=IEC_SIGMA_RATIOS,
    record_length_s: float = 600.0,
    turbulence_max_frequency_hz: float | None = None,
    wind_body_deg=None,
):
    """HWS std measured by a motionless lidar over the point HWS std (>= 0, typically ~1.03).

    ``g^2 = sum_j (sigma_j / sigma_u)^2 int S_j <|H_j|^2> df / int S_j df`` with the
    IEC Kaimal spectral shapes (Eq. B.1 of IEC 61400-1 Ed. 3) weighted by
    ``1 - sinc^2(f T)`` (the expected sample variance of a record of length ``T``), each
    scaled to its 10-min variance ``sigma_j^2``, and the scan transfer of :func:`scan_response`
    (Sathe et al. 2011, temporal part). ``g`` depends on the wind only through ``Lambda_1(z) / U`` and on the
    component std ratios (not on sigma_u itself), so it is computed on a grid of that
    time scale and interpolated.

    Parameters
    ----------
    hws_ms : array_like
        Mean horizontal wind speed, m/s (> 0).
    height_m : array_like
        Measurement height above the surface, m (> 0); broadcast with ``hws_ms``.
    lidar : str or LidarGeometry
        Scan geometry of the lidar (default the ZephIR 300-like CW VAD).
    sigma_ratios : tuple of 3 float
        ``sigma_v / sigma_u`` and ``sigma_w / sigma_u`` as ``(1, r_v, r_w)`` (IEC: 1, 0.8, 0.5).
    record_length_s : float
        Record length, s (the lowest frequency resolved by a 10-min std).
    turbulence_max_frequency_hz : float, optional
        Highest frequency of the turbulence, Hz: for a band-limited synthetic series (its
        Nyquist frequency) whose spectrum is scaled to ``sigma_j^2`` below it. Default
        None: the continuous spectrum of the atmosphere.
    wind_body_deg : array_like, optional
        The direction the wind blows towards relative to the lidar's body, deg
        counter-clockwise from its x axis (:func:`flidar_uq.physics.dbs_sigma_z.wind_to_body_deg`),
        broadcast with ``hws_ms``. A DBS lidar's beams are fixed to its body: its ``g``
        then depends on it (a half-turn periodic function, :func:`_direction_nodes`:
        for the WindCube v2 at 8 m/s and 80 m, with turbulence up to 2 Hz, 1.008 with the
        wind blowing between its second and third beams to 1.071 between its first and
        second, 1.040 averaged over directions; 0.998 to 1.058, 1.028 averaged, for the
        continuous spectrum); NaN (the heading unknown) or None: the average. A conical scan's ``g``
        does not depend on it.

    Returns
    -------
    numpy.ndarray
        Ratio ``g`` of the broadcast shape; NaN where ``hws_ms <= 0``, ``height_m <= 0``
        or an input is not finite.

    Raises
    ------
    ValueError
        If ``record_length_s`` is not positive or ``sigma_ratios`` is not 3 non-negative
        numbers with a positive first one.
    """
    if not record_length_s > 0:
        raise ValueError(f"lidar_std_ratio: record_length_s={record_length_s!r} must be > 0")
    if turbulence_max_frequency_hz is not None and not turbulence_max_frequency_hz > 0:
        raise ValueError(
            f"lidar_std_ratio: turbulence_max_frequency_hz={turbulence_max_frequency_hz!r} "
            "must be > 0 or None"
        )
    r = np.asarray(sigma_ratios, dtype=float)
    if r.shape != (3,) or np.any(~np.isfinite(r)) or np.any(r < 0) or r[0] <= 0:
        raise ValueError(f"lidar_std_ratio: sigma_ratios={sigma_ratios!r} must be 3 values >= 0")
    x, ok, out = _time_scale_s(hws_ms, height_m)
    if not ok.any():
        return out
    f = _frequency_grid(lidar, record_length_s)
    lo, hi = np.log(np.min(x[ok])), np.log(np.max(x[ok]))
    grid = np.exp(np.linspace(lo, hi, 2 if hi - lo < 1e-12 else 96))
    kw = dict(r=r, record_length_s=record_length_s, f_max=turbulence_max_frequency_hz)
    beta = _body_directions(lidar, wind_body_deg, x.shape)
    ratio = _std_ratio_on_grid(f, scan_response(f, lidar), grid, **kw)
    out[ok] = np.interp(np.log(x[ok]), np.log(grid), ratio)
    if beta is not None:  # a DBS lidar at known wind directions
        nodes = _direction_nodes(7.5)
        at = np.stack(
            [
                _std_ratio_on_grid(f, scan_response(f, lidar, wind_body_deg=b), grid, **kw)
                for b in nodes
            ]
        )  # (B, G)
        sel = ok & np.isfinite(beta)
        per_node = np.stack([np.interp(np.log(x[sel]), np.log(grid), a) for a in at])
        out[sel] = _periodic_interp(beta[sel], nodes, per_node)
    return out


#: Period (deg) of a DBS lidar's responses in the wind's direction relative to its body:
#: a wind turned by half a turn is the same wind for the retrieval (opposite beams swap
#: roles, the HWS is even in the fluctuations' sign), while a quarter turn changes which
#: beam pair, taken at which instants, sees the along-wind component (tested).
DIRECTION_PERIOD_DEG = 180.0


def _direction_nodes(step_deg: float) -> np.ndarray:
    """Wind directions relative to a DBS lidar's body (deg) on which its direction-dependent
    responses are computed: a half turn (:data:`DIRECTION_PERIOD_DEG`) in ``step_deg``."""
    return np.arange(0.0, DIRECTION_PERIOD_DEG, float(step_deg))


def _body_directions(lidar, wind_body_deg, shape):
    """The wind's body directions folded into a half turn (deg, NaN where unknown),
    broadcast to ``shape``; None when they do not matter (not given, or a conical scan)."""
    if wind_body_deg is None or _lidar.get_lidar(lidar).kind != "dbs":
        return None
    return np.broadcast_to(np.asarray(wind_body_deg, float) % DIRECTION_PERIOD_DEG, shape)


def _periodic_interp(beta_deg, nodes_deg, values):
    """Linear interpolation over a half turn of ``values`` (B, n) given at ``nodes_deg``
    (B,) for each of the n points at ``beta_deg`` (n,) (deg in [0, 180))."""
    period = DIRECTION_PERIOD_DEG
    xp = np.concatenate([nodes_deg, [nodes_deg[0] + period]])
    vals = np.concatenate([values, values[:1]], axis=0)
    k = np.clip(np.searchsorted(xp, beta_deg, side="right") - 1, 0, len(nodes_deg) - 1)
    w = (beta_deg - xp[k]) / (xp[k + 1] - xp[k])
    col = np.arange(values.shape[1])
    return (1.0 - w) * vals[k, col] + w * vals[k + 1, col]


def _std_ratio_on_grid(f, h, grid, *, r, record_length_s, f_max):
    """``g`` (G,) on a grid of ``Lambda_1 / U`` (s) for the scan transfer ``h`` (3, F) at the
    frequencies ``f`` (Hz); the integrals of :func:`lidar_std_ratio`."""
    tau = grid[:, None] * KAIMAL_LENGTH_PER_LAMBDA1[None, :]  # (G, 3) L_j / U, s
    # E[sample variance of a record of length T] = int S(f) (1 - sinc^2(f T)) df (the
    # record mean removed), for the point series and, to the same approximation, for the
    # scan series. Each component's spectrum is scaled to that 10-min variance sigma_j^2
    # (the IEC sigma_k is a 10-min std; the virtual campaign and PyConTurb do the same).
    # int over f as int over ln f: the integrand times f.
    spec = kaimal_psd(f[None, None, :], 1.0, 1.0, tau[..., None])  # (G, 3, F) shapes
    w = record_variance_share(f, record_length_s) * f
    if f_max is not None:
        w = np.where(f <= f_max, w, 0.0)
    lnf = np.log(f)
    band = np.trapezoid(spec * w, lnf, axis=-1)  # (G, 3)
    through = np.trapezoid(spec * h[None] * w, lnf, axis=-1)  # (G, 3)
    num = (r**2 * through / band).sum(axis=-1)
    return np.sqrt(num)  # the point variance of u' over the band is sigma_u^2


class _ScanSimulation(NamedTuple):
    """Checked settings of the lidar-vs-point simulations and their shared steps.

    One simulated record: IEC Kaimal ``u', v', w'`` held between turbulence samples, the
    wind turned to a random direction in the lidar's body frame, scans on a schedule of
    refocus delays with heights taken in turn, each scan's least-squares wind, and the log
    of the lidar's 10-min HWS std over the point sensor's.
    """

    geometry: _lidar.LidarGeometry
    delay_slots: tuple[int, int]  # refocus delay range, LOS durations
    heights_in_turn: int
    n: int  # LOS slots per record
    step: int  # LOS slots per turbulence sample
    every: int  # LOS slots per point sample
    lag: np.ndarray  # slot of each line of sight within a scan
    az0: np.ndarray  # nominal azimuth of each line of sight, rad

    def held_turbulence(self, rng, n_records, hws_ms, height_m):
        """``(n_records, 3, n)`` Kaimal fluctuations (TI 0.1, m/s), held between samples."""
        dt = self.geometry.los_duration_s
        hws = np.full(int(n_records), float(hws_ms))
        x_t = kaimal_series(
            -(-self.n // self.step), dt * self.step, hws, 0.1 * hws_ms, float(height_m), rng
        )
        return np.repeat(x_t, self.step, axis=-1)[..., : self.n]

    @staticmethod
    def wind(hws_ms, fluct, beta_rad):
        """Wind ``(n, 3)`` in the body frame, m/s: mean ``hws_ms`` plus ``fluct`` (3, n),
        the wind direction at ``beta_rad`` from the body x axis."""
        c, s = np.cos(beta_rad), np.sin(beta_rad)
        rot = np.array([[c, s, 0.0], [-s, c, 0.0], [0, 0, 1.0]])
        return hws_ms * rot[0] + fluct.T @ rot

    def point_std(self, wind):
        """10-min std of the point HWS sampled every ``every`` slots, m/s."""
        return np.hypot(wind[:: self.every, 0], wind[:: self.every, 1]).std(ddof=1)

    def schedule(self, rng):
        """Scan start slots of one height and each scan's random azimuth phase (rad); a DBS
        lidar with a wind after every beam: a window at every slot."""
        if self.geometry.every_beam_output:
            starts = np.arange(self.n - self.geometry.n_los + 1)
            return starts, np.zeros((starts.size, 1))
        gaps = self.geometry.n_los + rng.integers(
            self.delay_slots[0], self.delay_slots[1] + 1, size=self.n // self.geometry.n_los + 1
        )
        starts = np.cumsum(gaps) - gaps[0]
        starts = starts[starts + self.geometry.n_los <= self.n]
        starts = starts[rng.integers(self.heights_in_turn) :: self.heights_in_turn]
        return starts, rng.uniform(0.0, 2.0 * np.pi, size=(starts.size, 1))

    def log_ratio(self, wind, starts, phase, point_std, heading_rad=0.0):
        """``log(lidar 10-min HWS std / point_std)`` of the scans at ``starts``, the lidar
        turned by ``heading_rad`` in the body frame (rad). A VAD scan starts at its random
        azimuth ``phase`` (rad); a DBS lidar's beams are fixed to its body, so only the
        heading turns them (with a wind after every beam, the beam at each slot is its
        place in the cycle)."""
        g = self.geometry
        if g.every_beam_output:
            az = self.az0[(starts[:, None] + self.lag[None, :]) % g.n_los] + heading_rad
        elif g.kind == "dbs":
            az = np.broadcast_to(self.az0 + heading_rad, (starts.size, self.lag.size))
        else:
            az = self.az0[None, :] + (phase + heading_rad)
        d = _lidar.beam_unit_vectors_body(g, az)  # (J, K, 3)
        v_r = np.einsum("jkc,jkc->jk", d, wind[starts[:, None] + self.lag[None, :]])
        uvw = np.einsum("jck,jk->jc", _lidar.vad_pseudo_inverse(d), v_r)
        return np.log(np.hypot(uvw[:, 0], uvw[:, 1]).std(ddof=1) / point_std)


def _scan_settings(
    caller,
    lidar,
    heights_in_turn,
    refocus_delay_s,
    turbulence_dt_s,
    point_sample_interval_s,
    record_length_s,
) -> _ScanSimulation:
    """Checked scan settings of the lidar-vs-point simulations; messages name ``caller``."""
    g = _lidar.get_lidar(lidar)
    lo_d, hi_d = (float(v) for v in refocus_delay_s)
    dt = g.los_duration_s
    t_dt = dt if turbulence_dt_s is None else float(turbulence_dt_s)
    if int(heights_in_turn) < 1 or not 0.0 <= lo_d <= hi_d:
        raise ValueError(
            f"{caller}: need heights_in_turn >= 1 and 0 <= refocus_delay_s[0] <= [1], got "
            f"{heights_in_turn!r}, {refocus_delay_s!r}"
        )
    if not (point_sample_interval_s > 0 and t_dt > 0 and record_length_s > 0):
        raise ValueError(
            f"{caller}: point_sample_interval_s, turbulence_dt_s and record_length_s must be "
            f"> 0, got {point_sample_interval_s!r}, {turbulence_dt_s!r}, {record_length_s!r}"
        )
    t_s, az0 = _lidar.scan_times_azimuths(g, 0.0)
    return _ScanSimulation(
        geometry=g,
        delay_slots=(int(round(lo_d / dt)), int(round(hi_d / dt))),
        heights_in_turn=int(heights_in_turn),
        n=int(round(record_length_s / dt)),
        step=max(int(round(t_dt / dt)), 1),
        every=max(int(round(point_sample_interval_s / dt)), 1),
        lag=np.rint(t_s / dt).astype(int),
        az0=az0,
    )


def lidar_point_log_sd(
    hws_ms,
    height_m,
    lidar="zephir300",
    *,
    heights_in_turn: int = 1,
    refocus_delay_s: tuple[float, float] = (0.0, 0.0),
    point_sample_interval_s: float = 1.0,
    turbulence_dt_s: float | None = None,
    record_length_s: float = 600.0,
    n_records: int = 96,
    seed: int = 0,
    wind_body_deg=None,
):
    """Record-to-record std of ``log(lidar 10-min std / point 10-min std)``, by simulation.

    Even a motionless lidar's 10-min HWS std differs from a point sensor's std of the same
    wind at random, record by record: the scans sample the record at other instants than
    the point sensor, and the in-scan leakage of :func:`lidar_std_ratio` is itself a
    random series whose sample variance and covariance with ``u'`` scatter. The mean
    ratio is :func:`lidar_std_ratio`; this is the scatter about it, for intervals of
    the point std. Simulated with IEC Kaimal series (``u', v', w'``, TI 0.1) and the
    least-squares scan of ``lidar`` (linear fit, random scan phase and wind direction),
    scanning ``heights_in_turn`` heights in turn with a uniform refocus delay between
    scans, against the point HWS sampled every ``point_sample_interval_s``. It depends on
    the wind only through ``Lambda_1(z) / U``: simulated on a few values of it
    (``n_records`` each, seeded) and fitted by a straight line in ``log(Lambda_1 / U)``.

    Parameters
    ----------
    hws_ms, height_m : array_like
        Mean HWS (m/s, > 0) and height (m, > 0), broadcast together.
    lidar : str or LidarGeometry
        Scan geometry.
    heights_in_turn : int
        Heights the lidar scans in turn (one scan each), >= 1.
    refocus_delay_s : (float, float)
        Uniform range of the delay between consecutive scans, s.
    point_sample_interval_s : float
        Sampling interval of the point reference (e.g. 1 s for a cup's 1-Hz series), s.
    turbulence_dt_s : float, optional
        Sampling interval of a synthetic turbulence series held between samples (the
        virtual campaign's ``wind.wind_dt_s``), s; default None: the line-of-sight rate
        (the atmosphere up to its Nyquist frequency).
    record_length_s : float
        Record length, s.
    n_records : int
        Simulated records per value of ``Lambda_1 / U``.
    seed : int
        Seed of the simulation (numpy SeedSequence entropy): the result is deterministic.
    wind_body_deg : array_like, optional
        The direction the wind blows towards relative to the lidar's body (deg, as
        :func:`lidar_std_ratio`), broadcast with ``hws_ms``: a DBS lidar's scatter depends
        on it (WindCube v2 at 5 m/s: 0.036 with the wind between its second and third
        beams, 0.046 between its first and second); it is then simulated at every 15 deg
        of a half turn (twice ``n_records`` each) and smoothed over the directions by the
        least-squares cosine series of order 2 in the half-turn angle
        (:func:`_direction_series`). NaN or None: the wind at random directions. A conical
        scan does not depend on it.

    Returns
    -------
    numpy.ndarray
        Std of the log ratio (-), broadcast shape; NaN where the inputs are invalid.

    Raises
    ------
    ValueError
        For a non-positive interval, delay range, record length, or fewer than 8 records.
    """
    sim = _scan_settings(
        "lidar_point_log_sd",
        lidar,
        heights_in_turn,
        refocus_delay_s,
        turbulence_dt_s,
        point_sample_interval_s,
        record_length_s,
    )
    if int(n_records) < 8:
        raise ValueError(f"lidar_point_log_sd: n_records={n_records!r} must be >= 8")
    x, ok, out = _time_scale_s(hws_ms, height_m)
    if not ok.any():
        return out
    lo, hi = np.log(np.min(x[ok])), np.log(np.max(x[ok]))
    grid = np.linspace(lo, hi, 5) if hi - lo > 1e-6 else np.array([lo])
    lx = np.clip(np.log(x[ok]), grid[0], grid[-1])
    out[ok] = _point_log_sd_fit(sim, grid, int(n_records), seed, None)(lx)
    beta = _body_directions(lidar, wind_body_deg, x.shape)
    if beta is not None:  # a DBS lidar at known wind directions
        nodes = _direction_nodes(15.0)
        sel = ok & np.isfinite(beta)
        lx = np.clip(np.log(x[sel]), grid[0], grid[-1])
        per_node = np.stack(
            [
                _point_log_sd_fit(sim, grid, 2 * int(n_records), child, np.deg2rad(b))(lx)
                for b, child in zip(nodes, as_seedsequence(seed).spawn(nodes.size), strict=True)
            ]
        )
        basis = _direction_series(nodes)  # (B, 5)
        coef = np.linalg.lstsq(basis, per_node, rcond=None)[0]  # (5, n)
        out[sel] = np.einsum("nk,kn->n", _direction_series(beta[sel]), coef)
    return out


def _direction_series(beta_deg) -> np.ndarray:
    """``(1, cos 2b, sin 2b, cos 4b, sin 4b)`` (..., 5) of wind directions ``b`` (deg): the
    half-turn periodic series of order 2 (:data:`DIRECTION_PERIOD_DEG`)."""
    b = np.deg2rad(np.asarray(beta_deg, float))
    return np.stack(
        [np.ones_like(b), np.cos(2 * b), np.sin(2 * b), np.cos(4 * b), np.sin(4 * b)], -1
    )


def _point_log_sd_fit(sim, grid, n_records, seed, beta_rad):
    """The simulated sd of :func:`lidar_point_log_sd` on the ``log(Lambda_1 / U)`` grid,
    smoothed by a straight line in it; the wind at ``beta_rad`` from the body x axis, or at
    random directions (None). Returns the line as a function of ``log(Lambda_1 / U)``."""
    sds = []
    for k, child in enumerate(as_seedsequence(seed).spawn(grid.size)):
        rng = np.random.default_rng(child)
        hws = 42.0 / np.exp(grid[k])  # Lambda_1 = 42 m (z > 60 m): Lambda_1 / U = x
        x_t = sim.held_turbulence(rng, n_records, hws, 85.0)
        logs = []
        for r in range(n_records):
            starts, phase = sim.schedule(rng)
            direction = rng.uniform(0.0, 2.0 * np.pi)
            wind = sim.wind(hws, x_t[r], direction if beta_rad is None else beta_rad)
            logs.append(sim.log_ratio(wind, starts, phase, sim.point_std(wind)))
        sds.append(np.std(logs, ddof=1))
    sds = np.asarray(sds)
    if grid.size >= 3:
        slope, icpt = np.polyfit(grid, sds, 1)  # smooths the simulation noise of the sds
        return lambda lx: icpt + slope * lx
    return lambda lx: np.full(np.shape(lx), sds.mean())


def lidar_pair_correlation(
    azimuth_offset_deg,
    lidar="zephir300",
    *,
    synchronized: bool = True,
    hws_ms: float = 10.0,
    height_m: float = 85.0,
    heights_in_turn: int = 1,
    refocus_delay_s: tuple[float, float] = (0.0, 0.0),
    point_sample_interval_s: float = 1.0,
    turbulence_dt_s: float | None = None,
    record_length_s: float = 600.0,
    n_records: int = 300,
    seed: int = 0,
):
    """Correlation of two motionless lidars' sampling errors against the point std, by simulation.

    Two lidars of the same type measure the same wind: the record-to-record errors
    ``e_1, e_2 = log(lidar 10-min std / point 10-min std)`` of
    :func:`lidar_point_log_sd` are correlated as far as they sample the wind at the same
    instants along the same azimuths. The scatter of one lidar's std against the other's
    is then ``Var(e_1 - e_2) = 2 (1 - c) sd^2`` (each with sd ``sd``): the part of an
    observed floating-lidar-vs-reference-lidar scatter that is the two lidars' sampling,
    not the motion (docs/inference.md, "Noise split with a reference lidar").

    ``synchronized``: both lidars scan on one schedule (the same scan start times and
    line-of-sight instants), the second one's azimuths turned by ``azimuth_offset_deg``
    (a buoy heading different from a co-located reference's, as in the virtual campaign);
    else each lidar has its own refocus delays and scan phase (two separate lidars; the
    offset does not matter). Simulated as :func:`lidar_point_log_sd` (IEC Kaimal ``u', v',
    w'``, TI 0.1, least-squares scans, random wind direction) at one ``Lambda_1(z) / U``;
    the synchronized correlation is computed at offsets 0-180 deg every 30 deg and smoothed
    by a cosine series of order 3 in the offset (``c(-d) = c(d)``); for a DBS lidar, whose
    beams are fixed to its body and turn with the offset (the VAD's random scan phase does
    not), every 15 deg and order 6.

    Parameters
    ----------
    azimuth_offset_deg : array_like
        Azimuth of the second lidar's scan relative to the first's (deg).
    lidar : str or LidarGeometry
        Scan geometry of both lidars.
    synchronized : bool
        One scan schedule for both (True) or independent schedules (False).
    hws_ms, height_m : float
        Mean HWS (m/s, > 0) and height (m, > 0) of the simulated records.
    heights_in_turn, refocus_delay_s, point_sample_interval_s, turbulence_dt_s, record_length_s
        As for :func:`lidar_point_log_sd` (-, s, s, s, s).
    n_records : int
        Simulated records (>= 8).
    seed : int
        Seed (numpy SeedSequence entropy): the result is deterministic.

    Returns
    -------
    numpy.ndarray
        Correlation ``c`` (-) in [-1, 1], shape of ``azimuth_offset_deg``.

    Raises
    ------
    ValueError
        For invalid scan settings, a non-positive HWS or height, or fewer than 8 records.
    """
    sim = _scan_settings(
        "lidar_pair_correlation",
        lidar,
        heights_in_turn,
        refocus_delay_s,
        turbulence_dt_s,
        point_sample_interval_s,
        record_length_s,
    )
    if not (hws_ms > 0 and height_m > 0) or int(n_records) < 8:
        raise ValueError(
            f"lidar_pair_correlation: need hws_ms > 0 m/s, height_m > 0 m and n_records >= 8, "
            f"got {hws_ms!r}, {height_m!r}, {n_records!r}"
        )
    offsets = np.asarray(azimuth_offset_deg, dtype=float)
    # a DBS lidar's beams are fixed to its body and taken one after the other: its
    # correlation changes faster with the offset than a VAD scan's (cosine order 6)
    dbs = sim.geometry.kind == "dbs"
    step_deg, order = (15.0, 6) if dbs else (30.0, 3)
    grid = np.arange(0.0, 180.0 + step_deg / 2, step_deg) if synchronized else np.array([0.0])
    rng = np.random.default_rng(as_seedsequence(seed))
    x_t = sim.held_turbulence(rng, n_records, hws_ms, height_m)
    e1 = np.empty(int(n_records))
    e2 = np.empty((grid.size, int(n_records)))
    for r in range(int(n_records)):
        wind = sim.wind(hws_ms, x_t[r], rng.uniform(0.0, 2.0 * np.pi))
        point_std = sim.point_std(wind)
        starts, phase = sim.schedule(rng)
        e1[r] = sim.log_ratio(wind, starts, phase, point_std)
        if not synchronized:
            starts, phase = sim.schedule(rng)
        for k, d in enumerate(grid):
            e2[k, r] = sim.log_ratio(wind, starts, phase, point_std, np.deg2rad(d))
    c = np.array([np.corrcoef(e1, e2[k])[0, 1] for k in range(grid.size)])
    if not synchronized:
        return np.full(offsets.shape, float(c[0]))
    basis = np.cos(np.deg2rad(grid)[:, None] * np.arange(order + 1)[None, :])
    coef = np.linalg.lstsq(basis, c, rcond=None)[0]
    out = np.cos(np.deg2rad(offsets)[..., None] * np.arange(order + 1)) @ coef
    return np.clip(out, -1.0, 1.0)
