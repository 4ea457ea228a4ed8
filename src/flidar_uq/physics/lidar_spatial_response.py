"""A motionless lidar's std ratio to the point wind in turbulence with space: the scan disk,
the probe volume, and the spread of the ratio across turbulence models.

:func:`flidar_uq.physics.lidar_response.lidar_std_ratio` takes the turbulence uniform in
space (the temporal part of Sathe et al. 2011). In the atmosphere the lines of sight
focus on points spread over the scan circle of radius ``z tan(phi)`` (or on a DBS lidar's
beam footprints), and each measures a weighted average along its beam (its probe volume).
Both average out part of the turbulence (the spatial part of Sathe et al. 2011).

The retrieved along-wind HWS of one scan is ``a = sum_p c_j,p u_j(x_p, t_p)`` over the
points ``p`` (line of sight ``k`` times a node ``m`` of its range weighting, weight
``c_j,k w_m``), with ``c_j,k`` the least-squares scan operator's coefficients
(:func:`flidar_uq.physics.lidar.vad_pseudo_inverse`) projected on the wind direction and
on component ``j`` (u', v', w'). With frozen turbulence advected along the mean wind
``U`` (Taylor), a point ``x_p`` along the wind at time ``t_p`` sees the wind of the plane
``x = 0`` at ``tau_p = t_p - x_p / U``; two points separated by ``r_pq`` across the wind
are correlated by the IEC 61400-1 (2019, Annex C) exponential coherence

``Coh_j(f, r) = exp(-a sqrt((f r / U)^2 + (0.12 r / L_c,j)^2))``, ``a = 12``,
``L_c,u = 8.1 Lambda_1``,

so the scan's power transfer is

``h_j(f) = sinc^2(f T_los) sum_pq c_j,p c_j,q Coh_j(f, r_pq) cos(2 pi f (tau_p - tau_q))``

(averaged over the wind's direction against the scan), and ``g^2`` is the spectral
integral of :func:`flidar_uq.physics.lidar_response.lidar_std_ratio` with ``h_j`` for the
temporal transfer. With the disk and the probe volume shrunk to a point it is that
temporal ``g``.

Range weighting: a CW lidar focused at slant range ``R`` weights its beam by a Lorentzian
of half-width ``Gamma = Gamma_100 (R / 100 m)^2`` (Sonnenschein and Horrigan 1971; Sathe et
al. 2011, Eq. 7; ZephIR 300-like ``Gamma_100 = 7.7 m``); a pulsed lidar by a Gaussian pulse
convolved with its range gate (Banakh and Smalikho 1997; Sathe et al. 2011, Eq. 8;
WindCube-like gate 18.75 m and pulse 24.75 m full width at half maximum). Each is
integrated by equal-probability nodes of the weighting.
"""

from __future__ import annotations

from functools import lru_cache
from typing import NamedTuple

import numpy as np
from scipy.special import erf

from flidar_uq.physics import lidar as _lidar
from flidar_uq.physics.lidar_response import _frequency_grid, _std_ratio_on_grid
from flidar_uq.physics.turbulence import IEC_SIGMA_RATIOS, kaimal_lambda1_m, pyconturb_field

__all__ = [
    "CW_HALF_WIDTH_AT_100M_M",
    "PULSE_FWHM_M",
    "RANGE_GATE_M",
    "PRIOR_SPEEDS_MS",
    "SPATIAL_MODELS",
    "SpatialTurbulence",
    "lidar_spatial_std_ratio",
    "lidar_std_ratio_prior",
    "range_weight_nodes_m",
    "simulate_spatial_std_ratio",
]

#: Half-width at half maximum of a CW lidar's Lorentzian weighting focused at 100 m, m
#: (ZephIR 300 specification, +-7.7 m at 100 m); it grows with the square of the range.
CW_HALF_WIDTH_AT_100M_M = 7.7
#: A pulsed lidar's range gate, m (WindCube-like; Sathe et al. 2011, Sec. 3).
RANGE_GATE_M = 18.75
#: Its pulse's full width at half maximum, m (WindCube-like; Sathe et al. 2011, Sec. 3).
PULSE_FWHM_M = 24.75


class SpatialTurbulence(NamedTuple):
    """A turbulence model of :func:`lidar_spatial_std_ratio`.

    Attributes
    ----------
    coherence_decay : float
        Decay constant ``a`` of the exponential coherence (-; IEC 61400-1: 12).
    coherence_length_per_lambda1 : tuple of 3 float
        Coherence scale ``L_c,j / Lambda_1`` of u', v', w' (-). IEC 61400-1 gives 8.1 for
        u'; the default takes each of v', w' with its own Kaimal integral scale (2.7, 0.66).
        0: the component is incoherent between distinct points (PyConTurb's "iec" model
        for v', w').
    length_scale_factor : float
        Factor on ``Lambda_1`` (the spectra's and the coherence's length scales), -.
    """

    coherence_decay: float = 12.0
    coherence_length_per_lambda1: tuple[float, float, float] = (8.1, 2.7, 0.66)
    length_scale_factor: float = 1.0


#: The models whose spread of ``log g`` is the prior sd of :func:`lidar_std_ratio_prior`:
#: IEC Kaimal with its exponential coherence, the coherence decay from 8 to 16, v' and w'
#: incoherent, and the length scales halved and doubled (stable and unstable air).
SPATIAL_MODELS = (
    SpatialTurbulence(),
    SpatialTurbulence(coherence_decay=8.0),
    SpatialTurbulence(coherence_decay=16.0),
    SpatialTurbulence(coherence_length_per_lambda1=(8.1, 0.0, 0.0)),
    SpatialTurbulence(length_scale_factor=0.5),
    SpatialTurbulence(length_scale_factor=2.0),
)

#: Wind directions against a conical scan's azimuths averaged over (its many lines of
#: sight make it nearly symmetric), and against a DBS lidar's beams.
_N_DIR_VAD, _N_DIR_DBS = 3, 8
#: Frequencies per decade of the spatial integral (its transfer is smooth in log f).
_PER_DECADE = 8


def range_weight_nodes_m(lidar, range_m, n_range: int = 7, *, probe_scale: float = 1.0):
    """Equal-probability nodes of a lidar's weighting along its beam, m from the focus.

    Parameters
    ----------
    lidar : str or LidarGeometry
        The lidar: a pulsed one (:attr:`~flidar_uq.physics.lidar.LidarGeometry.pulsed`)
        weights by its Gaussian pulse convolved with its range gate, a CW one by a
        Lorentzian of half-width ``CW_HALF_WIDTH_AT_100M_M (range_m / 100 m)^2``.
    range_m : float
        Slant range of the focus or of the gate's centre, m (> 0).
    n_range : int
        Nodes (>= 1); each carries the weight ``1 / n_range``.
    probe_scale : float
        Factor on the probe length (>= 0; 0: a point).

    Returns
    -------
    numpy.ndarray, shape (n_range,)
        Offsets along the beam, m, at the weighting's quantiles ``(m + 1/2) / n_range``.

    Raises
    ------
    ValueError
        If ``range_m`` is not positive, ``n_range < 1`` or ``probe_scale < 0``.
    """
    if not range_m > 0 or int(n_range) < 1 or not probe_scale >= 0:
        raise ValueError(
            f"range_weight_nodes_m: need range_m > 0 m, n_range >= 1 and probe_scale >= 0, "
            f"got {range_m!r}, {n_range!r}, {probe_scale!r}"
        )
    x, w = np.polynomial.legendre.leggauss(int(n_range))
    q, w = (x + 1.0) / 2.0, w / 2.0  # Gauss-Legendre in the weighting's probability
    if _lidar.get_lidar(lidar).pulsed:
        r_p = PULSE_FWHM_M / (2.0 * np.sqrt(np.log(2.0)))
        half = RANGE_GATE_M / 2.0
        s = np.linspace(-half - 5.0 * r_p, half + 5.0 * r_p, 4001)
        # weighting (erf((s + dp/2) / r_p) - erf((s - dp/2) / r_p)) / (2 dp), its CDF by sums
        cdf = np.cumsum(erf((s + half) / r_p) - erf((s - half) / r_p))
        cdf = (cdf - cdf[0]) / (cdf[-1] - cdf[0])
        return probe_scale * np.interp(q, cdf, s), w
    gamma = CW_HALF_WIDTH_AT_100M_M * (float(range_m) / 100.0) ** 2
    return probe_scale * gamma * np.tan(np.pi * (q - 0.5)), w


@lru_cache(maxsize=256)
def _spatial_transfer(lidar, hws_ms, height_m, model, probe_scale, disk_scale, n_range, f_key):
    """``h_j(f)`` (3, F) of the module docstring at one wind speed (m/s) and height (m)."""
    f = np.asarray(f_key)
    g = _lidar.get_lidar(lidar)
    t_s, az = _lidar.scan_times_azimuths(g, 0.0)
    d = _lidar.beam_unit_vectors_body(g, az)  # (K, 3)
    p = _lidar.vad_pseudo_inverse(d)  # (3, K)
    slant = height_m / d[:, 2]  # (K,) slant range of each focus, m
    nodes, weights = np.stack(
        [range_weight_nodes_m(g, r, n_range, probe_scale=probe_scale) for r in slant], axis=1
    )  # (K, M) offsets along the beam, m, and their weights
    pos = (slant[:, None, None] + nodes[..., None]) * d[:, None, :]  # (K, M, 3), m
    pos[..., :2] *= disk_scale
    t_win = _lidar.window_beam_times_s(g) if g.kind == "dbs" else t_s[None, :]  # (S, K)
    n_dir = _N_DIR_DBS if g.kind == "dbs" else _N_DIR_VAD
    lam = float(kaimal_lambda1_m(height_m)) * model.length_scale_factor
    l_c = np.asarray(model.coherence_length_per_lambda1, float) * lam  # (3,), m
    box = np.sinc(f * g.los_duration_s) ** 2
    out = np.zeros((3, f.size))
    for beta in 2.0 * np.pi * (np.arange(n_dir) + 0.5) / n_dir:
        e_u = np.array([np.cos(beta), np.sin(beta), 0.0])
        e_v = np.array([-np.sin(beta), np.cos(beta), 0.0])
        along = (pos @ e_u).ravel()  # (P,), m
        across = np.stack([(pos @ e_v).ravel(), pos[..., 2].ravel()], -1)  # (P, 2), m
        r = np.linalg.norm(across[:, None] - across[None, :], axis=-1)  # (P, P), m
        proj = e_u[:2] @ p[:2]  # (K,) along-wind row of the retrieval
        c = [((proj * (d @ e))[:, None] * weights).ravel() for e in (e_u, e_v, [0, 0, 1])]
        r2 = r**2
        # the frequency-free part of each component's coherence exponent (None: incoherent)
        fixed = [(0.12 / lc) ** 2 * r2 if lc > 0 else None for lc in l_c]
        for t_k in t_win:
            tau = np.repeat(t_k, nodes.shape[1]) - along / hws_ms  # (P,), s
            dtau = tau[:, None] - tau[None, :]
            for i, fi in enumerate(f):
                phase = np.cos(2.0 * np.pi * fi * dtau)
                moving = (fi / hws_ms) ** 2 * r2
                for j in range(3):
                    if fixed[j] is None:
                        coh = r < 1e-9
                    else:
                        coh = np.exp(-model.coherence_decay * np.sqrt(moving + fixed[j]))
                    out[j, i] += c[j] @ (coh * phase) @ c[j]
    return out * box / (n_dir * t_win.shape[0])


def lidar_spatial_std_ratio(
    hws_ms,
    height_m,
    lidar="zephir300",
    *,
    model: SpatialTurbulence = SPATIAL_MODELS[0],
    probe_scale: float = 1.0,
    disk_scale: float = 1.0,
    record_length_s: float = 600.0,
    n_range: int = 7,
):
    """HWS std of a motionless lidar over the point HWS std, with the scan disk and the
    probe volume in coherent turbulence (module docstring).

    Parameters
    ----------
    hws_ms : array_like
        Mean horizontal wind speed, m/s (> 0).
    height_m : array_like
        Measurement height, m (> 0); broadcast with ``hws_ms``.
    lidar : str or LidarGeometry
        Scan geometry (:func:`flidar_uq.physics.lidar.get_lidar`).
    model : SpatialTurbulence
        Coherence and length scales (default IEC 61400-1 Kaimal with its coherence).
    probe_scale : float
        Factor on the probe length (>= 0; 0: each line of sight a point).
    disk_scale : float
        Factor on the horizontal spread of the focus points (>= 0; 0: all at the scan's
        centre, the temporal ``g`` of :func:`~flidar_uq.physics.lidar_response.lidar_std_ratio`
        when ``probe_scale`` is 0 too).
    record_length_s : float
        Record length, s.
    n_range : int
        Nodes of the range weighting (:func:`range_weight_nodes_m`).

    Returns
    -------
    numpy.ndarray
        Ratio ``g`` (-) of the broadcast shape; NaN where an input is not positive.

    Raises
    ------
    ValueError
        If ``probe_scale`` or ``disk_scale`` is negative, ``record_length_s`` not
        positive or ``n_range < 1``.
    """
    if not (probe_scale >= 0 and disk_scale >= 0 and record_length_s > 0 and n_range >= 1):
        raise ValueError(
            f"lidar_spatial_std_ratio: need probe_scale >= 0, disk_scale >= 0, "
            f"record_length_s > 0 s and n_range >= 1, got {probe_scale!r}, {disk_scale!r}, "
            f"{record_length_s!r}, {n_range!r}"
        )
    u, z = np.broadcast_arrays(np.asarray(hws_ms, float), np.asarray(height_m, float))
    out = np.full(u.shape, np.nan)
    ok = np.isfinite(u) & np.isfinite(z) & (u > 0) & (z > 0)
    f = _frequency_grid(lidar, record_length_s, _PER_DECADE)
    r = np.asarray(IEC_SIGMA_RATIOS, float)
    for hws, z_m in {(float(a), float(b)) for a, b in zip(u[ok], z[ok], strict=True)}:
        h = _spatial_transfer(
            lidar, hws, z_m, model, float(probe_scale), float(disk_scale), int(n_range), tuple(f)
        )
        x = np.array([float(kaimal_lambda1_m(z_m)) * model.length_scale_factor / hws])
        ratio = _std_ratio_on_grid(f, h, x, r=r, record_length_s=record_length_s, f_max=None)
        out[ok & (u == hws) & (z == z_m)] = ratio[0]
    return out


#: Wind speeds (m/s) on which :func:`lidar_std_ratio_prior` computes the models, linear in
#: ``log U`` between them and held beyond.
PRIOR_SPEEDS_MS = (4.0, 16.0)


def lidar_std_ratio_prior(hws_ms, height_m, lidar="zephir300", *, models=SPATIAL_MODELS, n_range=5):
    """Mean and sd of ``log g`` across turbulence models, per wind speed and height.

    ``g`` of :func:`lidar_spatial_std_ratio` for each of ``models`` (default
    :data:`SPATIAL_MODELS`: the coherence decay from 8 to 16, v' and w' coherent or not,
    the length scales halved and doubled), at each distinct height and at
    :data:`PRIOR_SPEEDS_MS`, interpolated linearly in ``log U``.

    Parameters
    ----------
    hws_ms : array_like
        Mean horizontal wind speed, m/s (> 0).
    height_m : array_like
        Measurement height, m (> 0); broadcast with ``hws_ms``.
    lidar : str or LidarGeometry
        Scan geometry.
    models : sequence of SpatialTurbulence
        The turbulence models (>= 2).
    n_range : int
        Nodes of the range weighting (:func:`range_weight_nodes_m`).

    Returns
    -------
    log_mean, log_sd : numpy.ndarray
        Mean and sd (ddof 0) of ``log g`` over the models (-), of the broadcast shape;
        NaN where an input is not positive.

    Raises
    ------
    ValueError
        If fewer than 2 models are given.
    """
    if len(models) < 2:
        raise ValueError(f"lidar_std_ratio_prior: need >= 2 models, got {len(models)}")
    u, z = np.broadcast_arrays(np.asarray(hws_ms, float), np.asarray(height_m, float))
    mean, sd = np.full(u.shape, np.nan), np.full(u.shape, np.nan)
    ok = np.isfinite(u) & np.isfinite(z) & (u > 0) & (z > 0)
    speeds = np.asarray(PRIOR_SPEEDS_MS)
    lu = np.log(np.clip(u[ok], speeds[0], speeds[-1]))
    for z_m in np.unique(z[ok]):
        log_g = np.log(
            [lidar_spatial_std_ratio(speeds, z_m, lidar, model=m, n_range=n_range) for m in models]
        )  # (models, speeds)
        at = z[ok] == z_m
        mean[np.flatnonzero(ok)[at]] = np.interp(lu[at], np.log(speeds), log_g.mean(0))
        sd[np.flatnonzero(ok)[at]] = np.interp(lu[at], np.log(speeds), log_g.std(0))
    return mean, sd


def simulate_spatial_std_ratio(
    hws_ms: float,
    height_m: float,
    lidar="zephir300",
    *,
    n_records: int = 3,
    n_range: int = 3,
    dt_s: float = 0.25,
    seed: int = 0,
):
    """``g`` of a motionless lidar in a simulated 3-D field, to check :func:`lidar_spatial_std_ratio`.

    Each 10-min record: a PyConTurb field (:func:`flidar_uq.physics.turbulence.pyconturb_field`:
    IEC Kaimal spectra, the IEC exponential coherence of u' with ``L_c = 340.2 m``, v' and
    w' incoherent) at the beams' range nodes (:func:`range_weight_nodes_m`) and at the scan
    centre, frozen and advected along the mean wind (``u(x, t) = u(0, t - x / U)``), the
    wind at a random direction against the lidar; scans with a random gap of up to half a
    line of sight's duration between them, each scan's radial speeds weighted over the
    range nodes, its least-squares wind and HWS; the point HWS at the scan centre every
    ``dt_s``. Compare with ``lidar_spatial_std_ratio(..., model=SpatialTurbulence(
    coherence_length_per_lambda1=(340.2 / Lambda_1, 0, 0)), n_range=n_range)``.

    Parameters
    ----------
    hws_ms : float
        Mean horizontal wind speed, m/s (> 0).
    height_m : float
        Measurement height, m (> 0).
    lidar : str or LidarGeometry
        Scan geometry.
    n_records : int
        Simulated 10-min records (>= 2).
    n_range : int
        Nodes of the range weighting.
    dt_s : float
        Time step of the field, s (> 0).
    seed : int
        Seed (numpy SeedSequence entropy): the result is deterministic.

    Returns
    -------
    g : float
        ``sqrt(sum of the lidar's record variances / sum of the point's)`` (-).
    g_se : float
        Its standard error from the records' log ratios (-).

    Raises
    ------
    ValueError
        If an input is out of range.
    """
    if not (hws_ms > 0 and height_m > 0 and dt_s > 0 and int(n_records) >= 2):
        raise ValueError(
            f"simulate_spatial_std_ratio: need hws_ms > 0 m/s, height_m > 0 m, dt_s > 0 s and "
            f"n_records >= 2, got {hws_ms!r}, {height_m!r}, {dt_s!r}, {n_records!r}"
        )
    g = _lidar.get_lidar(lidar)
    t_s, az = _lidar.scan_times_azimuths(g, 0.0)
    d = _lidar.beam_unit_vectors_body(g, az)  # (K, 3)
    p = _lidar.vad_pseudo_inverse(d)  # (3, K)
    slant = height_m / d[:, 2]
    nodes, weights = np.stack([range_weight_nodes_m(g, r, n_range) for r in slant], axis=1)
    pos = (slant[:, None, None] + nodes[..., None]) * d[:, None, :]  # (K, M, 3), m
    t_win = _lidar.window_beam_times_s(g) if g.kind == "dbs" else t_s[None, :]  # (S, K)
    record_s = 600.0
    margin_s = float(np.max(np.abs(pos[..., :2]))) / hws_ms + 2.0 * g.scan_period_s
    rng = np.random.default_rng(np.random.SeedSequence(seed))
    var_l, var_p = [], []
    for _ in range(int(n_records)):
        beta = rng.uniform(0.0, 2.0 * np.pi)
        e_u = np.array([np.cos(beta), np.sin(beta), 0.0])
        e_v = np.array([-np.sin(beta), np.cos(beta), 0.0])
        along, across = pos @ e_u, pos @ e_v  # (K, M), m
        field = pyconturb_field(
            np.append(across.ravel(), 0.0),
            np.append(pos[..., 2].ravel(), height_m),
            hws_ms,
            1.0,
            duration_s=record_s + 2.0 * margin_s,
            dt_s=dt_s,
            seed=int(rng.integers(2**31)),
        )  # (P + 1, 3, nt), wind-aligned
        gaps = g.scan_period_s + rng.uniform(0.0, 0.5 * g.los_duration_s, size=int(record_s))
        starts = margin_s + np.cumsum(gaps)
        starts = starts[starts < margin_s + record_s - g.scan_period_s]
        t = starts[:, None] + t_win[np.arange(starts.size) % t_win.shape[0]]  # (J, K), s
        # each line of sight averages over its duration: n_sub instants in it
        n_sub = int(np.ceil(2.0 * g.los_duration_s / dt_s))
        t = t[..., None] + g.los_duration_s * (np.arange(n_sub) + 0.5) / n_sub  # (J, K, N)
        lag = t[:, :, None, :] - along[None, :, :, None] / hws_ms  # (J, K, M, N), s
        i = np.clip(lag / dt_s, 0, field.shape[-1] - 1.001)
        i0, frac = i.astype(int), (i - i.astype(int))[..., None]
        pt = np.broadcast_to(np.arange(along.size).reshape(along.shape)[None, ..., None], i0.shape)
        uvw = field[pt, :, i0] * (1 - frac) + field[pt, :, i0 + 1] * frac  # (J, K, M, N, 3)
        wind = hws_ms * e_u + uvw @ np.stack([e_u, e_v, [0.0, 0.0, 1.0]])  # body frame, m/s
        v_r = np.einsum("jkmnc,kc,km->jk", wind, d, weights) / n_sub
        ret = v_r @ p.T  # (J, 3)
        var_l.append(np.var(np.hypot(ret[:, 0], ret[:, 1]), ddof=1))
        n0 = int(margin_s / dt_s)
        c = field[-1, :, n0 : n0 + int(record_s / dt_s)]
        var_p.append(np.var(np.hypot(hws_ms + c[0], c[1]), ddof=1))
    log_r = 0.5 * np.log(np.asarray(var_l) / np.asarray(var_p))
    return float(np.sqrt(np.sum(var_l) / np.sum(var_p))), float(
        np.std(log_r, ddof=1) / np.sqrt(len(log_r))
    )
