"""Per-record sigma_Z from the buoy's tilt spectrum (broadband, directional seas).

Size: the band reduction, the band/moments sigma_Z and attitude replay are one method (docs/motion_spectrum.md) and test against each other (~650 lines, half of it docstrings).

Gutiérrez-Antuñano et al.'s (2018) sigma_Z assumes harmonic roll and pitch of one amplitude and period. A real
record is broadband and directional; this module computes its sigma_Z from the tilt
spectrum resolved along and across the wind (docs/motion_spectrum.md):

1. **Wind-frame tilt** (:func:`tilt_vector_en`, :func:`project_tilt_on_wind_deg`). The body z axis in the earth frame
   is ``R @ (0, 0, 1)`` with ``R = Rz(yaw) Ry(pitch) Rx(roll)`` (docs/conventions.md); its
   horizontal part is the *tilt vector* (east, north), small-angle ``Rz(yaw) (pitch, -roll)``:
   pitch tilts the head towards the body x axis, roll towards -y. "Along the wind" is the
   component on the horizontal wind axis ``e_w = (sin wd, cos wd)`` (``wd`` meteorological,
   so ``e_w`` points upwind; only variances are used, so the sign is immaterial); "across"
   is the component on ``(cos wd, -sin wd)``. Angles: ``arcsin`` of the components.
2. **Band description** (:func:`tilt_band_spectrum`): the along/across tilt PSDs reduced
   to ``n_bands`` log-spaced period bands (variance per band, deg^2, and the band's
   centroid period ``1 / (m1/m0)``), plus the spectral moments of the along-wind tilt.
3. **sigma_Z by quadrature over bands** (:func:`spectral_sigma_z_ms`):
   ``sigma_Z^2 = sum_b sigma_Z(A_b, T_b)^2``, ``A_b = sqrt(2 var_along_b)``, each band a
   single-axis tilt along the wind. Measured with the direct kernel
   (:func:`flidar_uq.physics.simulator.sigma_z`, roll-only motion): a single-axis tilt of
   amplitude A along the wind gives the paper's roll-and-pitch sigma_Z at amplitude A
   (within 0.05 % without lever arm), at angle psi to the wind ``|cos psi|`` times it
   (within 0.4 % up to 10 deg), and **exactly zero across the wind without lever arm**
   (rolling about the wind axis leaves the VAD retrieval exact). With a lever arm the
   across-wind tilt gives a small HWS-independent term (0.012 m/s at 3 deg, 4 s, 2.5 m;
   0.019 m/s at 10 deg, 6 s), a product of tilt and head velocity; it is neglected here
   (its effect on the sum is measured in ``benchmarks/spectral_sigma_z.py``).
   The translation of the head (``v = omega x r``, ``r = (0, 0, h)``) is along the tilt
   rate, i.e. along the wind for the along-wind band, and coherent with its rotation
   error; it enters through the surrogate's ``sigma_z_lever_ms`` for the same band.
   The quadrature sum itself is exact to first order in the tilt (0.08 % at
   2 deg, 1.8 % at 10 deg against the direct multi-phase integral).
4. **Moments-only fallback** (:func:`moments_sigma_z_ms`): one harmonic of amplitude
   ``sqrt(2) * std_along`` at the zero-crossing period ``Tz = sqrt(m0/m2)``.
5. **Attitude replay** (:func:`replay_sigma_z`): the measured attitude series replayed
   through the scan simulator with a constant wind (the realised sigma_Z of a record).

Method notes and measured numbers: ``docs/motion_spectrum.md``. Imports only NumPy and
:mod:`flidar_uq.physics` (physics layer rule).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from flidar_uq.physics.lidar import (
    LidarGeometry,
    dbs_retrieval_operator,
    every_beam_windows,
    get_lidar,
    scan_times_azimuths,
    wind_vector_ms,
)
from flidar_uq.physics.motion import SampledMotion
from flidar_uq.physics.simulator import simulate_scans

__all__ = [
    "TiltBandSpectrum",
    "ReplayResult",
    "tilt_vector_en",
    "project_tilt_on_wind_deg",
    "band_edges_s",
    "sub_band_nodes",
    "expand_bands",
    "tilt_band_spectrum",
    "spectral_sigma_z_ms",
    "moments_sigma_z_ms",
    "harmonic_sigma_z_ms",
    "replay_sigma_z",
]

#: Period range of the surrogate (and of the default bands), s.
PERIOD_RANGE_S = (1.0, 20.0)


def tilt_vector_en(roll_deg, pitch_deg, yaw_deg=0.0):
    """Horizontal part (east, north) of the body z axis in the earth frame, per sample.

    ``R @ (0, 0, 1)`` with ``R = Rz(yaw) Ry(pitch) Rx(roll)`` (docs/conventions.md):
    ``(cy sp cr + sy sr, sy sp cr - cy sr)``, dimensionless (sines of the tilt). The first
    half of the wind-frame tilt (:func:`project_tilt_on_wind_deg` the second), apart so that one attitude series can be projected
    on several wind directions (one per height) with its trigonometry done once.

    Parameters
    ----------
    roll_deg, pitch_deg, yaw_deg : array_like
        Roll about body x, pitch about body y, yaw about body z counter-clockwise from
        above (body y = north at 0; for a compass heading ``hdg`` pass ``-hdg``), deg;
        broadcast.

    Returns
    -------
    east, north : ndarray
    """
    r, p, y = (np.deg2rad(np.asarray(a, float)) for a in (roll_deg, pitch_deg, yaw_deg))
    cr, sr, sp, cy, sy = np.cos(r), np.sin(r), np.sin(p), np.cos(y), np.sin(y)
    east = cy * sp * cr + sy * sr  # (R @ z)_x
    north = sy * sp * cr - cy * sr  # (R @ z)_y
    return east, north


def project_tilt_on_wind_deg(east, north, wd_deg):
    """Tilt along and across the wind from the tilt vector of :func:`tilt_vector_en`.

    ``along = arcsin(east sin wd + north cos wd)``,
    ``across = arcsin(east cos wd - north sin wd)`` (deg; the wind axis
    ``e_w = (sin wd, cos wd)``); ``wd_deg`` (meteorological, deg) broadcast with the
    tilt vector.
    """
    wd = np.deg2rad(np.asarray(wd_deg, float))
    along = east * np.sin(wd) + north * np.cos(wd)
    across = east * np.cos(wd) - north * np.sin(wd)
    return np.rad2deg(np.arcsin(np.clip(along, -1, 1))), np.rad2deg(
        np.arcsin(np.clip(across, -1, 1))
    )


def band_edges_s(n_bands: int = 8, period_min_s: float = 1.0, period_max_s: float = 20.0):
    """Log-spaced period band edges, s, shape ``(n_bands + 1,)``, increasing."""
    if int(n_bands) < 1 or not 0 < period_min_s < period_max_s:
        raise ValueError(
            f"band_edges_s: need n_bands >= 1 and 0 < period_min_s < period_max_s, got "
            f"{n_bands}, {period_min_s}, {period_max_s}"
        )
    return np.geomspace(period_min_s, period_max_s, int(n_bands) + 1)


def sub_band_nodes(period_s, edges_s, n_nodes: int = 3, variance=None):
    """Quadrature nodes inside period bands: where in each band its variance lies.

    A band's sigma_Z terms change across the band, most for a DBS lidar, whose beams a
    second apart turn each component's phase by ``omega`` per second, and for a hull whose
    heave cancels the tilt's vertical wind (``U cos psi`` near the phase speed
    ``g / omega``, which changes by 45 % across a band of the record table). One period per
    band (its centroid) then misses the sum over the band's components.

    Without ``variance``, each band's variance is spread linearly in frequency over the
    band, ``p(f) ~ 1 + a (f - f_mid)``, with the slope ``a`` that gives the band's centroid
    frequency ``1 / period_s`` (the variance-weighted mean frequency,
    :func:`tilt_band_spectrum`); a centroid too near an edge for a linear density that
    stays positive takes a ramp that vanishes inside the band instead. The band's terms are
    then the ``n_nodes``-point Gauss-Legendre sum over that density (exact for terms up to
    degree ``2 n_nodes - 2`` in frequency).

    With the bands' ``variance``, the density follows the spectrum's shape across bands:
    each band's mean variance per unit ``ln f`` sits at its centroid, the density between
    two neighbouring centroids is the straight line between them in ``ln f`` (the first and
    the last band's outer halves flat), and the ``n_nodes``-point Gauss-Legendre nodes in
    ``ln f`` weigh it. Those weights, tilted by ``exp(a f)`` with the ``a`` that gives the
    band's centroid (the shares nearest the density's, in relative entropy, with that
    mean), are the shares. A steep sea's peak band then takes its variance towards the
    peak rather than spread evenly about its centroid: over JONSWAP seas (peak periods
    2-14 s, ``gamma`` 1-7) the band sum of the tilt's vertical wind on a wave follower,
    ``(U - g / omega)^2`` at 3-12 m/s, and of a DBS beam pair's phase ``cos(omega 1 s)``
    is off by 1.1 % rms instead of 1.9 % (``tests/test_motion_spectrum.py``). A band
    without variance, or whose centroid lies beyond its outer nodes, takes the linear
    density.

    Parameters
    ----------
    period_s : array_like, shape (..., nb)
        Band centroid periods, s (NaN: the band's node weights are NaN).
    edges_s : array_like, shape (nb + 1,)
        The bands' edges, s, increasing (:func:`band_edges_s`).
    n_nodes : int
        Nodes per band.
    variance : array_like, shape (..., nb), optional
        Each band's variance (any unit, e.g. deg^2).

    Returns
    -------
    node_period_s, node_weight : numpy.ndarray, shape (..., nb, n_nodes)
        The nodes' periods (s) and their shares of the band's variance (-, summing to 1).
    """
    edges = np.asarray(edges_s, float)
    if int(n_nodes) == 1:  # the centroid itself
        per = np.asarray(period_s, float)[..., None]
        return per, np.ones_like(per)
    f_hi, f_lo = 1.0 / edges[:-1], 1.0 / edges[1:]
    f_c = 1.0 / np.asarray(period_s, float)
    half = 0.5 * (f_hi - f_lo)
    # the centroid in band units, x in [-1, 1] (f = f_mid + x half)
    m = np.clip((f_c - 0.5 * (f_hi + f_lo)) / half, -1.0 + 1e-9, 1.0 - 1e-9)[..., None]
    xi, wi = np.polynomial.legendre.leggauss(int(n_nodes))
    # linear density (1 + 3 m x) / 2 on [-1, 1], positive for |m| <= 1/3
    x_lin, w_lin = xi, 0.5 * wi * (1.0 + 3.0 * m * xi)
    # beyond: the ramp 2 (y - y0) / (1 - y0)^2 on [y0, 1] (mean (2 + y0) / 3 = |m|), mirrored
    y0 = 3.0 * np.abs(m) - 2.0
    y = y0 + 0.5 * (1.0 - y0) * (xi + 1.0)
    x_ramp, w_ramp = np.sign(m) * y, 0.5 * wi * (xi + 1.0)
    ramp = np.abs(m) > 1.0 / 3.0
    x = np.where(ramp, x_ramp, x_lin)
    w = np.where(ramp, w_ramp, w_lin)
    f = 0.5 * (f_hi + f_lo)[..., None] + x * half[..., None]
    if variance is None:
        return 1.0 / f, np.broadcast_to(w, f.shape)
    f_s, w_s = _shape_nodes(f_c, np.asarray(variance, float), f_hi, f_lo, xi, wi)
    shaped = np.isfinite(w_s).all(-1, keepdims=True)
    return 1.0 / np.where(shaped, f_s, f), np.where(shaped, w_s, w)


def _shape_nodes(f_c, variance, f_hi, f_lo, xi, wi):
    """:func:`sub_band_nodes`' nodes (Hz) and shares from the density across bands; NaN
    shares where that density cannot give the band's centroid (no variance in or around
    the band, a centroid beyond the outer nodes, a NaN)."""
    lo, hi = np.log(f_lo), np.log(f_hi)
    density = variance / (hi - lo)  # per unit ln f, at each band's centroid
    xc = np.log(f_c)
    nodes = 0.5 * (lo + hi)[:, None] + 0.5 * (hi - lo)[:, None] * xi  # (nb, n) in ln f

    def slope(shift):  # towards the neighbouring centroid (band b - 1: higher frequency)
        d_n, x_n = (np.roll(a, shift, axis=-1) for a in (density, xc))
        dx = x_n - xc
        ok = np.isfinite(d_n) & np.isfinite(dx) & (np.abs(dx) > 0)
        ok[..., 0 if shift == 1 else -1] = False  # the outermost bands' outer halves: flat
        with np.errstate(invalid="ignore", divide="ignore"):
            return np.where(ok, (d_n - density) / np.where(ok, dx, 1.0), 0.0)

    dist = nodes - xc[..., None]
    p = density[..., None] + np.where(dist > 0, slope(1)[..., None], slope(-1)[..., None]) * dist
    f = np.exp(nodes)
    mid, half = 0.5 * (f_hi + f_lo)[:, None], 0.5 * (f_hi - f_lo)[:, None]
    u = (f - mid) / half  # the nodes in band units
    target = (f_c - mid[:, 0]) / half[:, 0]
    # the shares nearest (in relative entropy) to the density's that have the band's
    # centroid: the density tilted by exp(a u), a by Newton's method on the tilted mean
    # (increasing in a)
    with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
        w = wi * p / (wi * p).sum(-1, keepdims=True)
        a = np.zeros(target.shape)
        for _ in range(_TILT_ITERATIONS):
            e = w * np.exp(a[..., None] * u - np.abs(a)[..., None])
            e = e / e.sum(-1, keepdims=True)
            mean = (e * u).sum(-1)
            var = (e * (u - mean[..., None]) ** 2).sum(-1)
            step = np.where(var > 1e-12, (target - mean) / np.maximum(var, 1e-12), 0.0)
            a = np.clip(a + step, -_TILT_MAX, _TILT_MAX)
        kept = (np.abs(mean - target) < 1e-9) & (variance > 0)
    return np.broadcast_to(f, e.shape), np.where(kept[..., None], e, np.nan)


#: Newton steps and the largest exponent of the tilt in :func:`_shape_nodes`.
_TILT_ITERATIONS = 30
_TILT_MAX = 200.0


def expand_bands(amplitude_deg, period_s, edges_s, *per_band, n_nodes: int = 3):
    """Period bands as ``n_nodes`` harmonics each (:func:`sub_band_nodes`).

    Parameters
    ----------
    amplitude_deg, period_s : array_like, shape (..., nb)
        Each band's amplitude (deg; ``sqrt(2)`` x its std) and centroid period (s).
    edges_s : array_like, shape (nb + 1,)
        The bands' edges, s.
    *per_band : array_like, shape (..., nb) or (..., nb, k)
        Other per-band values (direction moments, ...), repeated for each node.
    n_nodes : int
        Nodes per band (:func:`sub_band_nodes`); 1 keeps each band at its centroid.

    Returns
    -------
    tuple
        ``(amplitude_deg, period_s, *per_band)`` with ``nb * n_nodes`` bands: each node's
        amplitude is the band's times the square root of its variance share.
    """
    amp = np.asarray(amplitude_deg, float)
    per, w = sub_band_nodes(period_s, edges_s, n_nodes, variance=0.5 * amp**2)
    lead = amp.shape[:-1]
    nb = amp.shape[-1]
    out = [
        (amp[..., None] * np.sqrt(w)).reshape(*lead, nb * n_nodes),
        per.reshape(*lead, nb * n_nodes),
    ]
    for x in per_band:
        x = np.asarray(x, float)
        axis = amp.ndim - 1  # the band axis
        out.append(np.repeat(x, int(n_nodes), axis=axis))
    return tuple(out)


@dataclass(frozen=True)
class TiltBandSpectrum:
    """Tilt spectrum of records reduced to period bands (all arrays lead with ``nrec``).

    Attributes
    ----------
    edges_s : ndarray, shape (nb + 1,)
        Band edges in period, s (increasing).
    period_s : ndarray, shape (nrec, nb)
        Band centroid period ``1 / f_c`` with ``f_c`` the variance-weighted mean frequency
        of the along + across spectrum in the band, s (geometric band centre if empty).
    var_along_deg2, var_across_deg2 : ndarray, shape (nrec, nb)
        Tilt variance per band along and across the wind, deg^2.
    var_outside_deg2 : ndarray, shape (nrec,)
        Along + across tilt variance at periods outside the bands, deg^2 (not used by
        :func:`spectral_sigma_z_ms`; reported so that a user can see what is left out).
    m0_deg2, m1_deg2_hz, m2_deg2_hz2 : ndarray, shape (nrec,)
        In-band spectral moments ``m_k = int f^k S_along(f) df`` of the along-wind tilt.
    tp_s : ndarray, shape (nrec,)
        Peak period of the along + across tilt spectrum inside the bands, s.
    cos_psi : ndarray, shape (nrec, nb), or None
        Signed mean cosine of each band's directions of travel against the wind, measured
        from the co-spectrum of the vertical velocity and the along-wind tilt
        (:func:`flidar_uq.data.imu.band_direction_from_heave`); None without a vertical
        velocity.
    sin_psi : ndarray, shape (nrec, nb), or None
        Signed mean sine of the same directions (+ to the left of the wind's direction of
        travel, counter-clockwise seen from above), from the co-spectrum of the vertical
        velocity and the across-wind tilt; None without a vertical velocity.
    sincos_psi : ndarray, shape (nrec, nb), or None
        Mean ``sin psi cos psi`` of the same directions, from the co-spectrum of the along-
        and across-wind tilt (the tilt alone: it does not change when a wave runs the
        other way); None where the co-spectrum was not taken.
    heave_response : ndarray, shape (nrec,), or None
        The hull's heave against a wave follower's with the record's tilt, over the bands'
        periods, from the vertical velocity
        (:func:`flidar_uq.data.imu.band_direction_from_heave`); None without one.
    horizontal_response : ndarray, shape (nrec,), or None
        The same of the hull's horizontal velocity (east and north together), from the
        east and north velocities (:func:`flidar_uq.data.imu.response_ratio`); None
        without them.
    """

    edges_s: np.ndarray
    period_s: np.ndarray
    var_along_deg2: np.ndarray
    var_across_deg2: np.ndarray
    var_outside_deg2: np.ndarray
    m0_deg2: np.ndarray
    m1_deg2_hz: np.ndarray
    m2_deg2_hz2: np.ndarray
    tp_s: np.ndarray
    cos_psi: np.ndarray | None = None
    sin_psi: np.ndarray | None = None
    sincos_psi: np.ndarray | None = None
    heave_response: np.ndarray | None = None
    horizontal_response: np.ndarray | None = None

    _RECORD_FIELDS = (
        "period_s",
        "var_along_deg2",
        "var_across_deg2",
        "var_outside_deg2",
        "m0_deg2",
        "m1_deg2_hz",
        "m2_deg2_hz2",
        "tp_s",
    )

    def take(self, index) -> TiltBandSpectrum:
        """The records ``index`` (integer array or boolean mask) as a new spectrum."""
        return replace(self, **{k: getattr(self, k)[index] for k in self._fields()})

    def _fields(self) -> tuple[str, ...]:
        measured = tuple(
            k
            for k in ("cos_psi", "sin_psi", "sincos_psi", "heave_response", "horizontal_response")
            if getattr(self, k) is not None
        )
        return self._RECORD_FIELDS + measured

    def masked(self, keep) -> TiltBandSpectrum:
        """A copy with NaN in every record where the boolean ``keep`` (nrec,) is False."""
        keep = np.asarray(keep, bool)
        out = {}
        for k in self._fields():
            a = np.array(getattr(self, k), dtype=float)
            a[~keep] = np.nan
            out[k] = a
        return replace(self, **out)

    @property
    def tz_s(self) -> np.ndarray:
        """Zero-crossing period of the along-wind tilt, ``sqrt(m0 / m2)``, s."""
        with np.errstate(invalid="ignore", divide="ignore"):
            return np.sqrt(self.m0_deg2 / self.m2_deg2_hz2)

    @property
    def tm01_s(self) -> np.ndarray:
        """Mean period of the along-wind tilt, ``m0 / m1``, s."""
        with np.errstate(invalid="ignore", divide="ignore"):
            return self.m0_deg2 / self.m1_deg2_hz

    @property
    def along_std_deg(self) -> np.ndarray:
        """In-band std of the along-wind tilt, deg."""
        return np.sqrt(self.var_along_deg2.sum(axis=-1))

    @property
    def across_std_deg(self) -> np.ndarray:
        """In-band std of the across-wind tilt, deg."""
        return np.sqrt(self.var_across_deg2.sum(axis=-1))

    @property
    def along_share(self) -> np.ndarray:
        """Share of the in-band tilt variance along the wind, in [0, 1]."""
        va = self.var_along_deg2.sum(axis=-1)
        with np.errstate(invalid="ignore", divide="ignore"):
            return va / (va + self.var_across_deg2.sum(axis=-1))


def tilt_band_spectrum(
    f_hz,
    psd_along,
    psd_across,
    *,
    n_bands: int = 8,
    period_min_s: float = 1.0,
    period_max_s: float = 20.0,
    cospectrum=None,
) -> TiltBandSpectrum:
    """Reduce along/across-wind tilt PSDs to period bands and spectral moments.

    Parameters
    ----------
    f_hz : array_like, shape (nf,)
        Uniform, sorted frequencies, Hz (e.g. Welch: ``flidar_uq.data.imu.motion_spectrum``).
    psd_along, psd_across : array_like, shape (nf,) or (nrec, nf)
        One-sided PSDs of the along- and across-wind tilt, deg^2/Hz
        (``psd.sum(-1) * df`` is the variance).
    n_bands, period_min_s, period_max_s : int, float, float
        Log-spaced bands between the two periods, s.
    cospectrum : array_like, shape like psd_along, optional
        Co-spectrum of the along- and across-wind tilt, deg^2/Hz: then each band's
        ``<sin psi cos psi>`` (minus its band sum over the band's tilt variance; NaN for a
        band without tilt power) is in ``sincos_psi``.

    Returns
    -------
    TiltBandSpectrum
    """
    f = np.asarray(f_hz, float)
    # C order: each row's band sums run along its own contiguous bins
    pa = np.ascontiguousarray(np.atleast_2d(np.asarray(psd_along, float)))
    pc = np.ascontiguousarray(np.atleast_2d(np.asarray(psd_across, float)))
    if pa.shape != pc.shape or pa.shape[-1] != f.size or f.size < 2:
        raise ValueError(
            f"tilt_band_spectrum: psd shapes {pa.shape}, {pc.shape} do not match f_hz {f.shape}"
        )
    df = f[1] - f[0]
    edges = band_edges_s(n_bands, period_min_s, period_max_s)
    with np.errstate(divide="ignore"):
        per = np.where(f > 0, 1.0 / f, np.inf)
    # bin k belongs to band b if edges[b] <= 1/f < edges[b+1] (last band closed)
    idx = np.searchsorted(edges, per, side="right") - 1
    idx = np.where(per == edges[-1], n_bands - 1, idx)
    inside = (idx >= 0) & (idx < n_bands)
    # a band's bins are contiguous (the period falls with the frequency): each band's sum
    # is a sum over a slice, row by row. A matrix product with a one-hot matrix gave other
    # last bits for one row (BLAS gemv) than for several (gemm), so a record's bands
    # depended on how many records were reduced with it (a campaign's chunk size).
    slices = []
    for b in range(n_bands):
        k = np.flatnonzero(idx == b)
        if k.size and k[-1] - k[0] + 1 != k.size:
            raise ValueError("tilt_band_spectrum: f_hz must be sorted (a band's bins apart)")
        slices.append(slice(int(k[0]), int(k[-1]) + 1) if k.size else slice(0, 0))

    def band_sums(x):
        out = np.zeros(x.shape[:-1] + (n_bands,))
        for b, sl in enumerate(slices):
            out[..., b] = x[..., sl].sum(axis=-1) * df
        return out

    var_a = band_sums(pa)
    var_c = band_sums(pc)
    tot = pa + pc
    v_tot = band_sums(tot)
    fm = band_sums(tot * f)
    centre = np.sqrt(edges[:-1] * edges[1:])
    with np.errstate(invalid="ignore", divide="ignore"):
        period = np.where(v_tot > 0, v_tot / fm, centre[None, :])
    outside = (tot * (~inside & (f > 0))).sum(axis=-1) * df
    pa_in = pa * inside
    m0 = pa_in.sum(axis=-1) * df
    m1 = (pa_in * f).sum(axis=-1) * df
    m2 = (pa_in * f**2).sum(axis=-1) * df
    k = np.argmax(np.where(inside, tot, -np.inf), axis=-1)
    tp = np.where(tot[np.arange(tot.shape[0]), k] > 0, 1.0 / f[k], np.nan)
    spec = TiltBandSpectrum(edges, period, var_a, var_c, outside, m0, m1, m2, tp)
    if cospectrum is None:
        return spec
    co = band_sums(np.ascontiguousarray(np.atleast_2d(np.asarray(cospectrum, float))))
    with np.errstate(invalid="ignore", divide="ignore"):
        sincos = -co / np.where(v_tot > 0, v_tot, np.nan)
    return replace(spec, sincos_psi=np.clip(sincos, -0.5, 0.5))


def _sigma_single(sur, hws, amp, per, lever_arm_m):
    if np.all(np.asarray(lever_arm_m) == 0):
        return sur.sigma_z_ms(hws, amp, per)
    return sur.sigma_z_lever_ms(hws, amp, per, lever_arm_m)


def _surrogate(surrogate, lidar):
    if surrogate is not None:
        return surrogate
    from flidar_uq.physics.surrogate import get_surrogate

    return get_surrogate(lidar)


def spectral_sigma_z_ms(
    hws_ms,
    band_var_along_deg2,
    band_period_s,
    *,
    lever_arm_m=0.0,
    lidar: str | LidarGeometry = "zephir300",
    surrogate=None,
) -> np.ndarray:
    """sigma_Z of records from their along-wind tilt bands (quadrature sum over bands).

    ``sigma_Z^2 = sum_b sigma_Z(HWS, A_b, T_b[, h])^2`` with ``A_b = sqrt(2 var_b)``
    (each band a single-axis harmonic tilt along the wind, which has the sigma_Z of the
    seed's roll-and-pitch case at the same amplitude; module docstring). sigma_Z of one
    band is the direction-averaged surrogate (``sigma_z_ms``, or ``sigma_z_lever_ms``
    with a lever arm). Across-wind tilt contributes nothing without lever arm and is
    neglected with one.

    Parameters
    ----------
    hws_ms : array_like, shape (nrec,) or scalar
        Horizontal wind speed, m/s.
    band_var_along_deg2 : array_like, shape (nrec, nb) or (nb,)
        Along-wind tilt variance per band, deg^2.
    band_period_s : array_like, shape (nrec, nb) or (nb,)
        Band period, s; clipped to the surrogate range [1, 20] s.
    lever_arm_m : float or array_like, shape (nrec,)
        Head height above the rotation centre, m (``0 <= h / HWS <= 1 s`` for the
        lever-arm table; NaN outside).
    lidar : str or LidarGeometry
        Used when ``surrogate`` is None.
    surrogate : SigmaZSurrogate, optional
        A prebuilt :func:`flidar_uq.physics.surrogate.get_surrogate`.

    Returns
    -------
    ndarray, shape (nrec,) (or scalar for 1-D bands)
        sigma_Z, m/s; 0 for zero motion; NaN where a band amplitude exceeds 25 deg or
        the lever ratio is outside the table.
    """
    var = np.asarray(band_var_along_deg2, float)
    if np.any(var < 0):
        raise ValueError("spectral_sigma_z_ms: band_var_along_deg2 must be >= 0")
    per = np.clip(np.asarray(band_period_s, float), *PERIOD_RANGE_S)
    hws = np.asarray(hws_ms, float)[..., None]
    arm = np.asarray(lever_arm_m, float)
    arm = arm[..., None] if arm.ndim else arm
    sur = _surrogate(surrogate, lidar)
    s = _sigma_single(sur, hws, np.sqrt(2.0 * var), per, arm)
    s = np.where(var == 0, 0.0, s)
    return np.sqrt(np.sum(s**2, axis=-1))


def harmonic_sigma_z_ms(
    hws_ms, amplitude_deg, period_s, *, lever_arm_m=0.0, lidar="zephir300", surrogate=None
) -> np.ndarray:
    """Gutiérrez-Antuñano et al. (2018) sigma_Z of one roll-and-pitch harmonic (surrogate), m/s; broadcasting.

    ``amplitude_deg`` (deg) is the amplitude of roll and of pitch, ``period_s`` in [1, 20]
    s (clipped), ``lever_arm_m`` as in :func:`spectral_sigma_z_ms`.
    """
    sur = _surrogate(surrogate, lidar)
    per = np.clip(np.asarray(period_s, float), *PERIOD_RANGE_S)
    return _sigma_single(
        sur,
        np.asarray(hws_ms, float),
        np.asarray(amplitude_deg, float),
        per,
        np.asarray(lever_arm_m, float),
    )


def moments_sigma_z_ms(
    hws_ms,
    tilt_along_wind_std_deg,
    tilt_period_s,
    *,
    lever_arm_m=0.0,
    lidar="zephir300",
    surrogate=None,
) -> np.ndarray:
    """Table-only fallback: one harmonic along the wind from two spectral moments.

    ``sigma_Z = sigma_Z(HWS, sqrt(2) std_along, T)`` with ``T`` the zero-crossing period
    ``Tz = sqrt(m0/m2)`` of the along-wind tilt (record column
    ``tilt_period_zero_crossing_s``; within 1-3 % for JONSWAP seas).

    Parameters
    ----------
    hws_ms : array_like
        m/s.
    tilt_along_wind_std_deg : array_like
        Std of the along-wind tilt (``sqrt(m0)``), deg.
    tilt_period_s : array_like
        Tz (or another representative period), s; clipped to [1, 20] s.
    lever_arm_m, lidar, surrogate
        As in :func:`spectral_sigma_z_ms`.

    Returns
    -------
    ndarray
        sigma_Z, m/s (broadcast shape).
    """
    return harmonic_sigma_z_ms(
        hws_ms,
        np.sqrt(2.0) * np.asarray(tilt_along_wind_std_deg, float),
        tilt_period_s,
        lever_arm_m=lever_arm_m,
        lidar=lidar,
        surrogate=surrogate,
    )


@dataclass(frozen=True)
class ReplayResult:
    """Result of :func:`replay_sigma_z`.

    Attributes
    ----------
    sigma_z_ms : float
        Std of ``Z = retrieved HWS - true HWS`` over the scans, m/s.
    mean_z_ms : float
        Mean of Z, m/s.
    z_ms : ndarray, shape (nscan,)
        Z of every scan (``every_beam``: of every line of sight from the second cycle), m/s.
    wind_ms : ndarray, shape (nscan, 2)
        The retrieved horizontal wind (east, north) of each, m/s: with the true wind,
        the motion's error along and across it.
    """

    sigma_z_ms: float
    mean_z_ms: float
    z_ms: np.ndarray
    wind_ms: np.ndarray


def replay_sigma_z(
    time_s,
    roll_deg,
    pitch_deg,
    yaw_deg=None,
    *,
    hws_ms: float,
    wd_deg: float,
    lever_arm_m=0.0,
    lidar: str | LidarGeometry = "zephir300",
    scan_interval_s: float | None = None,
    sign_ambiguity: bool = False,
    translation_m=None,
    dwell_samples: int = 1,
    every_beam: bool | None = None,
) -> ReplayResult:
    """Realised sigma_Z of a record: its attitude series replayed through the scan simulator.

    Scans start every ``scan_interval_s`` (default: back to back) over the series; each
    scan's lines of sight see the linearly interpolated attitude
    (:class:`~flidar_uq.physics.motion.SampledMotion`, rates by central differences) and a
    constant wind; the lidar retrieves with its level geometry, compass-corrected by the
    scan's mean yaw (:func:`~flidar_uq.physics.simulator.simulate_scans`), and
    ``Z = retrieved HWS - HWS`` (Gutiérrez-Antuñano et al., 2018, Eq. 1). The scan phase (azimuth of the first
    line of sight) advances by the golden angle from scan to scan, so that it is spread
    uniformly and deterministically (Gutiérrez-Antuñano et al., 2018, Sec. 2.2: the scan phase is random).

    Parameters
    ----------
    time_s : array_like, shape (m,)
        Sample times, s, strictly increasing, no NaN (fill gaps first).
    roll_deg, pitch_deg : array_like, shape (m,)
        Attitude, deg.
    yaw_deg : array_like, shape (m,), optional
        Yaw (counter-clockwise from above), deg; unwrapped here (360-deg jumps removed).
    hws_ms, wd_deg : float
        Constant true wind: speed m/s, meteorological direction deg.
    lever_arm_m : float or tuple of 3 floats
        Head height above the rotation centre, or body-frame vector, m.
    lidar : str or LidarGeometry
    scan_interval_s : float, optional
        Time between scan starts, s; default the scan period.
    sign_ambiguity : bool
        Default False: signed linear retrieval, as :func:`~flidar_uq.physics.simulator.sigma_z`.
    translation_m : array_like, shape (m, 3), optional
        Earth-frame (east, north, up) displacement of the rotation centre (surge, sway,
        heave), m: the six-degree-of-freedom replay (head velocity by central differences).
    dwell_samples : int
        Default 1: each line of sight at one instant. ``n > 1``: its radial speed is the
        mean over ``n`` instants spread evenly over the line of sight's dwell (the pulse
        accumulation of a pulsed lidar, Désert, Knapp & Aubrun 2021; what the virtual
        campaign simulates). The retrieval is linear in the radial speeds for a signed
        lidar, so the mean of the ``n`` retrieved winds is the retrieval of the mean speeds.
    every_beam : bool, optional
        False: one retrieval a scan (a DBS lidar's cycle). True (a DBS lidar only): one
        after every line of sight from the latest line of sight of each beam (a sliding
        window, as a WindCube v2 reports about once a second; Yamaguchi & Ishihara 2016
        retrieve every second), compass-corrected by the mean yaw of the window's lines of
        sight; from the second cycle on, so that every window is full. Default None: the
        geometry's ``every_beam_output``.

    Returns
    -------
    ReplayResult
    """
    g = get_lidar(lidar)
    n_dwell = int(dwell_samples)
    if n_dwell < 1 or (n_dwell > 1 and not g.signed):
        raise ValueError(
            f"replay_sigma_z: dwell_samples={dwell_samples!r} needs to be 1, or > 1 for a "
            "lidar that measures signed speeds (pulsed)"
        )
    every_beam = g.every_beam_output if every_beam is None else bool(every_beam)
    if every_beam and g.kind != "dbs":
        raise ValueError(
            f"replay_sigma_z: every_beam needs a DBS lidar (the latest line of sight of each "
            f"beam), not {g.name!r} ({g.kind})"
        )
    t = np.asarray(time_s, float)
    arm = (
        (0.0, 0.0, float(lever_arm_m))
        if np.ndim(lever_arm_m) == 0
        else tuple(map(float, lever_arm_m))
    )
    if yaw_deg is not None:  # a heading that wraps (359 -> 1 deg) must not swing through 180
        yaw_deg = np.rad2deg(np.unwrap(np.deg2rad(np.asarray(yaw_deg, float))))
    trans = (
        {}
        if translation_m is None
        else dict(
            zip(("surge_m", "sway_m", "heave_m"), np.asarray(translation_m, float).T, strict=True)
        )
    )
    motion = SampledMotion(t, roll_deg, pitch_deg, yaw_deg, lever_arm_m=arm, **trans)
    dt_scan = g.scan_period_s if scan_interval_s is None else float(scan_interval_s)
    t_los, az0 = scan_times_azimuths(g, 0.0)
    last = t[-1] - g.scan_period_s - (g.los_duration_s if n_dwell > 1 else 0.0)
    starts = np.arange(t[0], last, dt_scan)
    if starts.size < 2:
        raise ValueError("replay_sigma_z: the series is shorter than two scans")
    golden = 2.0 * np.pi * (np.sqrt(5.0) - 1.0) / 2.0
    phase = (golden * np.arange(starts.size)) % (2.0 * np.pi)
    az = az0[None, :] + (phase[:, None] if g.kind == "vad" else 0.0)
    moving = any(a != 0 for a in arm) or translation_m is not None
    # instants within a line of sight's dwell (its time is the dwell's start): midpoints
    offsets = (np.arange(n_dwell) + 0.5) / n_dwell * g.los_duration_s if n_dwell > 1 else [0.0]
    u = v = v_r = yaw_los = 0.0
    for off in offsets:
        tt = starts[:, None] + t_los[None, :] + off
        roll, pitch, yaw = motion.attitude_rad(tt)
        v_off, ret = simulate_scans(
            g,
            wind_vector_ms(hws_ms, wd_deg),
            roll,
            pitch,
            yaw_rad=yaw,
            head_velocity_ms=motion.head_velocity_ms(tt) if moving else None,
            azimuth_rad=az,
            sign_ambiguity=sign_ambiguity,
        )
        u, v = u + np.asarray(ret.u_ms), v + np.asarray(ret.v_ms)
        v_r, yaw_los = v_r + v_off, yaw_los + np.broadcast_to(yaw, v_off.shape)
    if every_beam:
        u, v = _every_beam_wind(g, v_r / len(offsets), yaw_los / len(offsets))
    else:
        u, v = u / len(offsets), v / len(offsets)
    hws = np.hypot(u, v) if every_beam or n_dwell > 1 else np.asarray(ret.hws_ms)
    z = hws - float(hws_ms)  # Eq. (1) of Gutiérrez-Antuñano et al. (2018)
    wind = np.stack(np.broadcast_arrays(u, v), axis=-1).reshape(-1, 2)
    return ReplayResult(float(np.std(z)), float(np.mean(z)), z, wind)


def _every_beam_wind(g: LidarGeometry, v_r, yaw_rad):
    """A DBS lidar's horizontal wind (east, north; m/s) after every line of sight of
    back-to-back cycles, from the latest line of sight of each beam.

    ``v_r`` and ``yaw_rad`` (rad) of shape (cycles, K) in scan order: the first cycle, then
    after line of sight ``j`` of cycle ``c`` the window of lines ``<= j`` of cycle ``c`` and
    ``> j`` of cycle ``c - 1`` (:func:`~flidar_uq.physics.lidar.every_beam_windows`). Returns
    arrays of shape (1 + (cycles - 1) K,) in time order, each window's retrieval
    (:func:`~flidar_uq.physics.lidar.dbs_retrieval_operator`) rotated by its mean yaw.
    """
    latest = every_beam_windows(v_r)  # (1 + (cycles - 1) K, K)
    yaw = every_beam_windows(yaw_rad).mean(axis=-1)
    body = latest @ dbs_retrieval_operator(g)  # (1 + (cycles - 1) K, 3)
    c, s = np.cos(yaw), np.sin(yaw)
    u = c * body[..., 0] - s * body[..., 1]
    v = s * body[..., 0] + c * body[..., 1]
    return u, v
