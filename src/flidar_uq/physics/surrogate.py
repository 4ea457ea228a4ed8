"""Fast vectorised sigma_Z(HWS, amplitude, period) for the sampler.

Design (measured numbers in ``docs/simulator.md``):

- Exact scaling with HWS: without lever arm the VAD retrieval is linear in the wind and
  HWS is homogeneous of degree 1, so ``sigma_Z = HWS * s(A, T, WD)`` and
  ``E(Z) = HWS * m(A, T, WD)`` exactly (tested); tabulated at HWS = 1 m/s.
- Wind direction: with equal roll and pitch amplitude ``sigma_Z^2`` and ``E(Z)`` are even,
  180-deg periodic functions of WD (cosine series in ``2 WD``); the direction dependence
  is < 1 % for small amplitudes (Gutiérrez-Antuñano et al., 2018, Fig. 3) but reaches tens of percent at 25 deg and
  20 s. Five direction nodes (0-90 deg) resolve it; ``wd_deg=None`` (default) gives the
  RMS over uniformly distributed directions (Gutiérrez-Antuñano et al., 2018, Sec. 2.5 "WD exclusion").
- ``s(A, T) / A`` and ``m(A, T) / A^2`` are smooth (analytic) in ``A`` and ``log T``; they are
  represented by a tensor-product Chebyshev interpolant on ``A in [0, 25] deg`` and
  ``T in [1, 20] s`` (log scale), from ``NODES[kind]`` direct integrals; the variance
  ``(sigma_Z / A)^2`` is interpolated (smooth where sigma_Z itself has V-shaped zeros).
- Two-period motion: variances of the two components add,
  ``sigma^2 = s(A sqrt(w), T1)^2 + s(A sqrt(1-w), T2)^2`` (docs/conventions.md), validated
  against the direct 5-phase integral (tests/test_surrogate.py).

Outside the table (amplitude > 25 deg, period outside [1, 20] s, negative or non-finite
HWS, weight outside [0, 1]) the surrogate returns NaN.
"""

from __future__ import annotations

import functools

import numpy as np
from numpy.polynomial import chebyshev

from flidar_uq.physics.lidar import LidarGeometry, get_lidar
from flidar_uq.physics.simulator import sigma_z_direction_average, sigma_z_grid
from flidar_uq.threads import single_threaded

__all__ = [
    "SigmaZSurrogate",
    "default_surrogate",
    "get_surrogate",
    "AMPLITUDE_RANGE_DEG",
    "PERIOD_RANGE_S",
    "LEVER_RATIO_RANGE_S",
]

AMPLITUDE_RANGE_DEG = (0.0, 25.0)
PERIOD_RANGE_S = (1.0, 20.0)
# Chebyshev nodes per axis, chosen by measurement (coefficients and test errors in
# docs/simulator.md); quadrature points per phase of the node integrals.
# (amplitude nodes, log-period nodes, quadrature points) per scan kind; the DBS needs more
# period nodes: its sigma_Z has sharp minima where the period is a multiple of the 1-s dwell.
NODES = {"vad": (8, 16, 16), "dbs": (8, 40, 12)}
# Wind-direction nodes (deg): sigma_Z^2 and E(Z) are even, 180-deg periodic cosine series in
# the direction; harmonics cos(2 k wd), k <= 4, are resolved exactly.
WD_NODES_DEG = np.array([0.0, 22.5, 45.0, 67.5, 90.0])
# Lever-arm variant (direction-averaged): ratio lever_arm_m / hws_ms in s, and its table sizes.
LEVER_RATIO_RANGE_S = (0.0, 1.0)
N_LEVER = (8, 16, 10)  # amplitude, log-period, ratio nodes
LEVER_NPHASE, LEVER_N_WD = 12, 16


def _cheb_nodes(n: int) -> np.ndarray:
    return np.cos(np.pi * (np.arange(n) + 0.5) / n)


def _to_unit(x, lo, hi):
    return 2.0 * (x - lo) / (hi - lo) - 1.0


def _cheb_basis(x: np.ndarray, n: int) -> np.ndarray:
    """Chebyshev polynomials T_0..T_{n-1} at ``x``, shape ``x.shape + (n,)``."""
    out = np.empty(x.shape + (n,))
    out[..., 0] = 1.0
    if n > 1:
        out[..., 1] = x
    for k in range(2, n):
        out[..., k] = 2.0 * x * out[..., k - 1] - out[..., k - 2]
    return out


class SigmaZSurrogate:
    """Chebyshev surrogate of sigma_Z and E(Z) for one lidar geometry (no lever arm).

    Use :func:`get_surrogate` (cached) rather than the constructor.

    Parameters
    ----------
    lidar : LidarGeometry
    n_amplitude, n_period : int
        Chebyshev nodes in amplitude and log-period.
    nphase : int
        Quadrature points per phase for the node integrals.
    """

    def __init__(
        self,
        lidar: LidarGeometry,
        n_amplitude: int | None = None,
        n_period: int | None = None,
        nphase: int | None = None,
    ) -> None:
        self.lidar = lidar
        d_a, d_t, d_n = NODES[lidar.kind]
        n_amplitude = d_a if n_amplitude is None else n_amplitude
        n_period = d_t if n_period is None else n_period
        nphase = d_n if nphase is None else nphase
        self._lt = (np.log(PERIOD_RANGE_S[0]), np.log(PERIOD_RANGE_S[1]))
        xa, xt = _cheb_nodes(n_amplitude), _cheb_nodes(n_period)
        amp = (xa + 1.0) / 2.0 * AMPLITUDE_RANGE_DEG[1]
        per = np.exp(self._lt[0] + (xt + 1.0) / 2.0 * (self._lt[1] - self._lt[0]))
        vals = np.array(
            [
                [[sigma_z_grid(1.0, a, p, wd, lidar, nphase=nphase) for p in per] for a in amp]
                for wd in WD_NODES_DEG
            ]
        )  # (nwd, na, nt, 2): sigma, mean at HWS = 1 m/s
        a_rad = np.deg2rad(amp)[:, None]
        # sigma^2(wd) and E(Z)(wd) are even and 180-deg periodic in wd: cos(2 k wd), k = 0..4,
        # interpolated exactly through the 5 nodes 0, 22.5, ..., 90 deg.
        k = np.arange(WD_NODES_DEG.size)
        self._wd_inv = np.linalg.inv(np.cos(2.0 * np.deg2rad(WD_NODES_DEG)[:, None] * k[None, :]))
        wd_mean_w = self._wd_inv[0]  # the k = 0 coefficient is the average over directions
        # The variance is interpolated (smooth even where sigma_Z has a V-shaped zero).
        self._coef_var = [self._fit((v[..., 0] / a_rad) ** 2, xa, xt) for v in vals]
        self._coef_mean = [self._fit(v[..., 1] / a_rad**2, xa, xt) for v in vals]
        var_avg = np.einsum("j,jat->at", wd_mean_w, vals[..., 0] ** 2)
        mean_avg = np.einsum("j,jat->at", wd_mean_w, vals[..., 1])
        self._coef_var_avg = self._fit(var_avg / a_rad**2, xa, xt)
        self._coef_mean_avg = self._fit(mean_avg / a_rad**2, xa, xt)

    @staticmethod
    def _fit(values: np.ndarray, xa: np.ndarray, xt: np.ndarray) -> np.ndarray:
        va = chebyshev.chebvander(xa, xa.size - 1)
        vt = chebyshev.chebvander(xt, xt.size - 1)
        return np.linalg.solve(va, np.linalg.solve(vt, values.T).T)

    @functools.cached_property
    def _lever_coefs(self) -> tuple[np.ndarray, np.ndarray]:
        """3-D Chebyshev tables (amplitude, log-period, lever ratio), built on first use."""
        na, nt, nr = N_LEVER
        xa, xt, xr = _cheb_nodes(na), _cheb_nodes(nt), _cheb_nodes(nr)
        amp = (xa + 1.0) / 2.0 * AMPLITUDE_RANGE_DEG[1]
        per = np.exp(self._lt[0] + (xt + 1.0) / 2.0 * (self._lt[1] - self._lt[0]))
        ratio = LEVER_RATIO_RANGE_S[0] + (xr + 1.0) / 2.0 * np.diff(LEVER_RATIO_RANGE_S)[0]
        vals = np.array(
            [
                [
                    [
                        sigma_z_direction_average(
                            1.0,
                            a,
                            p,
                            self.lidar,
                            lever_arm_m=r,
                            nphase=LEVER_NPHASE,
                            n_wd=LEVER_N_WD,
                        )
                        for r in ratio
                    ]
                    for p in per
                ]
                for a in amp
            ]
        )  # (na, nt, nr, 2) at HWS = 1 m/s and lever arm = ratio * 1 m/s
        a_rad = np.deg2rad(amp)[:, None, None]
        inv = [np.linalg.inv(chebyshev.chebvander(x, x.size - 1)) for x in (xa, xt, xr)]

        def fit(v):
            return np.einsum("ai,tj,rk,ijk->atr", *inv, v)

        return fit(vals[..., 0] / a_rad), fit(vals[..., 1] / a_rad**2)

    def _eval_lever(self, which: int, hws_ms, amplitude_deg, period_s, lever_arm_m, amp_power):
        coef = self._lever_coefs[which]
        h, a, t, arm = np.broadcast_arrays(
            self._hws(hws_ms),
            np.asarray(amplitude_deg, float),
            np.asarray(period_s, float),
            np.asarray(lever_arm_m, float),
        )
        with np.errstate(divide="ignore", invalid="ignore"):
            ratio = np.where(h > 0, arm / np.where(h > 0, h, 1.0), np.nan)
        ok_r = (
            np.isfinite(ratio)
            & (ratio >= LEVER_RATIO_RANGE_S[0])
            & (ratio <= LEVER_RATIO_RANGE_S[1])
        )
        _, a_rad, ok = self._eval(np.zeros((1, 1)), a, t)  # domain mask of amplitude and period
        ok = ok & ok_r
        xa = _to_unit(np.where(ok, a, 0.0), *AMPLITUDE_RANGE_DEG).ravel()
        xt = _to_unit(np.log(np.where(ok, t, 1.0)), *self._lt).ravel()
        xr = _to_unit(np.where(ok, ratio, 0.0), *LEVER_RATIO_RANGE_S).ravel()
        out = np.empty(xa.size)
        chunk = 8192
        for i in range(0, xa.size, chunk):
            sl = slice(i, i + chunk)
            ba = _cheb_basis(xa[sl], coef.shape[0])
            bt = _cheb_basis(xt[sl], coef.shape[1])
            br = _cheb_basis(xr[sl], coef.shape[2])
            tmp = (ba @ coef.reshape(coef.shape[0], -1)).reshape(-1, *coef.shape[1:])
            out[sl] = np.einsum("nk,nk->n", np.einsum("njk,nj->nk", tmp, bt), br)
        val = out.reshape(a.shape) * a_rad**amp_power * h
        return np.where(ok, val, np.nan)

    def sigma_z_lever_ms(self, hws_ms, amplitude_deg, period_s, lever_arm_m) -> np.ndarray:
        """Direction-averaged sigma_Z with the lidar head ``lever_arm_m`` above the rotation centre.

        With a lever arm the head velocity ``omega x r`` adds a part that does not scale with
        HWS; ``sigma_Z / HWS`` then depends on the ratio ``lever_arm_m / hws_ms`` (s), which is
        tabulated on [0, 1] s (a 3-D Chebyshev table built on first use, a few seconds).

        Parameters
        ----------
        hws_ms : array_like
            Horizontal wind speed, m/s (> 0).
        amplitude_deg, period_s : array_like
            As in :meth:`sigma_z_ms`.
        lever_arm_m : array_like
            Head height above the rotation centre (body vector ``(0, 0, h)``), m, with
            ``0 <= lever_arm_m / hws_ms <= 1 s``.

        Returns
        -------
        ndarray
            RMS over uniformly distributed wind directions of sigma_Z, m/s; NaN outside the
            domain.
        """
        return np.maximum(self._eval_lever(0, hws_ms, amplitude_deg, period_s, lever_arm_m, 1), 0.0)

    def mean_z_lever_ms(self, hws_ms, amplitude_deg, period_s, lever_arm_m) -> np.ndarray:
        """Direction-averaged E(Z) with a lever arm; arguments as :meth:`sigma_z_lever_ms`."""
        return self._eval_lever(1, hws_ms, amplitude_deg, period_s, lever_arm_m, 2)

    def _wd_weights(self, wd_deg) -> np.ndarray:
        """Interpolation weights of the direction nodes at ``wd_deg``, shape ``(..., nwd)``."""
        k = np.arange(WD_NODES_DEG.size)
        cosk = np.cos(2.0 * np.deg2rad(np.asarray(wd_deg, float))[..., None] * k)
        return cosk @ self._wd_inv

    def _eval(self, coef, amplitude_deg, period_s):
        a = np.asarray(amplitude_deg, float)
        t = np.asarray(period_s, float)
        a, t = np.broadcast_arrays(a, t)
        ok = (
            np.isfinite(a)
            & np.isfinite(t)
            & (a >= AMPLITUDE_RANGE_DEG[0])
            & (a <= AMPLITUDE_RANGE_DEG[1])
            & (t >= PERIOD_RANGE_S[0])
            & (t <= PERIOD_RANGE_S[1])
        )
        a0 = np.where(ok, a, 0.0)
        t0 = np.where(ok, t, 1.0)
        xa = _to_unit(a0, *AMPLITUDE_RANGE_DEG)
        xt = _to_unit(np.log(t0), *self._lt)
        ba = _cheb_basis(xa.ravel(), coef.shape[0])
        bt = _cheb_basis(xt.ravel(), coef.shape[1])
        val = np.einsum("ni,ni->n", ba @ coef, bt).reshape(a.shape)
        return np.where(ok, val, np.nan), np.deg2rad(a0), ok

    @staticmethod
    def _hws(hws_ms):
        h = np.asarray(hws_ms, float)
        return np.where(np.isfinite(h) & (h >= 0), h, np.nan)

    def _per_direction(self, coefs, amplitude_deg, period_s, wd_deg):
        """Interpolated ``g A^2`` at the direction nodes combined with the cos-series weights."""
        a, t, wd = np.broadcast_arrays(
            np.asarray(amplitude_deg, float), np.asarray(period_s, float), np.asarray(wd_deg, float)
        )
        w = self._wd_weights(np.where(np.isfinite(wd), wd, 0.0))
        out = np.zeros(a.shape)
        for j, coef in enumerate(coefs):
            g, a_rad, _ = self._eval(coef, a, t)
            out = out + w[..., j] * g * a_rad**2
        return np.where(np.isfinite(wd), out, np.nan)

    def sigma_z_ms(self, hws_ms, amplitude_deg, period_s, wd_deg=None) -> np.ndarray:
        """sigma_Z, m/s; numpy broadcasting over all arguments.

        Parameters
        ----------
        hws_ms : array_like
            Horizontal wind speed, m/s (>= 0).
        amplitude_deg : array_like
            Roll and pitch amplitude, deg, in [0, 25].
        period_s : array_like
            Roll and pitch period, s, in [1, 20].
        wd_deg : array_like, optional
            Wind direction, deg. Default None: the RMS over uniformly distributed
            directions, ``sqrt(mean_wd sigma_Z(wd)^2)`` (Gutiérrez-Antuñano et al., 2018, Sec. 2.5 excludes the
            direction; the spread is < 1 % for small amplitudes, see docs/simulator.md).

        Returns
        -------
        ndarray
            Broadcast shape; NaN outside the domain.
        """
        if wd_deg is None:
            g, a_rad, _ = self._eval(self._coef_var_avg, amplitude_deg, period_s)
            var1 = g * a_rad**2
        else:
            var1 = self._per_direction(self._coef_var, amplitude_deg, period_s, wd_deg)
        return self._hws(hws_ms) * np.sqrt(np.maximum(var1, 0.0))

    def mean_z_ms(self, hws_ms, amplitude_deg, period_s, wd_deg=None) -> np.ndarray:
        """E(Z), m/s; same arguments and broadcasting as :meth:`sigma_z_ms` (default: the
        average over uniformly distributed directions)."""
        if wd_deg is None:
            g, a_rad, _ = self._eval(self._coef_mean_avg, amplitude_deg, period_s)
            return self._hws(hws_ms) * g * a_rad**2
        return self._hws(hws_ms) * self._per_direction(
            self._coef_mean, amplitude_deg, period_s, wd_deg
        )

    def sigma_z_two_period_ms(
        self, hws_ms, amplitude_deg, period1_s, period2_s, weight1, wd_deg=None
    ) -> np.ndarray:
        """sigma_Z for two-period motion by adding the component variances.

        Parameters
        ----------
        hws_ms : array_like
            Horizontal wind speed, m/s.
        amplitude_deg : array_like
            Total amplitude ``A`` (``sqrt(A1^2 + A2^2)``), deg.
        period1_s, period2_s : array_like
            Component periods, s, each in [1, 20].
        weight1 : array_like
            Share of the angular variance in component 1, in [0, 1]:
            ``A1 = A sqrt(w)``, ``A2 = A sqrt(1 - w)`` (docs/conventions.md).
        wd_deg : array_like, optional
            Wind direction, deg; default None as in :meth:`sigma_z_ms`.

        Returns
        -------
        ndarray
            ``sqrt(sigma(A1, T1)^2 + sigma(A2, T2)^2)``; NaN outside the domain.
        """
        w = np.asarray(weight1, float)
        w = np.where(np.isfinite(w) & (w >= 0) & (w <= 1), w, np.nan)
        a = np.asarray(amplitude_deg, float)
        s1 = self.sigma_z_ms(hws_ms, a * np.sqrt(w), period1_s, wd_deg)
        s2 = self.sigma_z_ms(hws_ms, a * np.sqrt(1.0 - w), period2_s, wd_deg)
        return np.sqrt(s1**2 + s2**2)


@functools.lru_cache(maxsize=8)
@single_threaded  # its fits' last bits follow the BLAS thread count; cached once per process
def _build(lidar: LidarGeometry) -> SigmaZSurrogate:
    return SigmaZSurrogate(lidar)


def get_surrogate(lidar: str | LidarGeometry = "zephir300") -> SigmaZSurrogate:
    """Surrogate for a lidar geometry, built once per geometry and cached in memory.

    Parameters
    ----------
    lidar : str or LidarGeometry

    Returns
    -------
    SigmaZSurrogate
    """
    return _build(get_lidar(lidar))


def default_surrogate(surrogate: SigmaZSurrogate | None = None) -> SigmaZSurrogate:
    """``surrogate`` itself, or the default lidar's (ZephIR 300) surrogate when None.

    The one place where library functions with an optional ``surrogate`` argument
    resolve it.
    """
    return get_surrogate() if surrogate is None else surrogate
