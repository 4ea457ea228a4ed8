"""sigma_Z of a pulsed DBS lidar on a moving hull: a harmonic sum over the beams' times.

A DBS lidar (WindCube-like, :data:`flidar_uq.physics.lidar.KNOWN_LIDARS`) takes its beams one
after another, about 1 s each, and retrieves ``u`` and ``v`` from opposite beam pairs
(Yamaguchi & Ishihara 2016, Eq. 3): ``u = (V_E - V_W) / (2 sin th)``. To first order in the
motion, the radial speed of beam ``k`` at time ``t_k`` is perturbed by ``d_k . e(t_k)``
(``d_k`` its body-frame unit vector) with the apparent wind perturbation

``e = U x Omega - v_head``,

``Omega`` the small rotation vector of the tilt and ``v_head`` the head's velocity (tilt
about a lever arm, surge, sway and heave: Yamaguchi & Ishihara 2016, Eqs. 3-4). For a wave
component leaning the hull by ``phi = A exp(i omega t)`` along its direction of travel
``xi`` (the kinematics of :mod:`flidar_uq.physics.hull`):

- ``(U x Omega)_z = U cos(psi) phi``: the mean wind rotated into the body's vertical
  (``psi`` between the wave's and the wind's directions of travel);
- the heave velocity ``R_z c phi`` (``c = g / omega``) and the horizontal head velocity
  ``i omega (L - R_x g / omega^2) phi`` along ``xi``.

The retrieval is linear in the radial speeds (:func:`flidar_uq.physics.lidar.dbs_retrieval_operator`
``P``), so a component's retrieved-wind error is the phasor
``delta = sum_k P_k (d_k . E) exp(i omega t_k)``. For an opposite pair taken ``dt`` apart
the vertical part enters as ``cot(th) / 2 * E_z (exp(i omega t_E) - exp(i omega t_W))``: the
leak of vertical motion that changes between the beams, ``cos(th) / (2 sin(th))`` (0.87 at
30 deg) times the change; zero for a motion that does not change between them. The pairs
are taken at different times, so the along-wind error depends on the wind direction
relative to the beams (the buoy's heading): for the leak,
``|cos(beta) exp(i omega tau) + sin(beta)|^2 = 1 + sin(2 beta) cos(omega tau)`` for N, E,
S, W at ``tau`` a beam.

sigma_Z (std of ``Z = retrieved HWS - HWS`` over the retrievals of a record: one a cycle,
or, for a lidar with a wind after every beam (``every_beam_output``), one a beam from the
latest beam of each azimuth, whose windows start at each place in the cycle: their
variances are averaged, ``window_start`` of :func:`dbs_error_coefficients`) is then, with
``delta_par`` and ``delta_perp`` the phasors along and across the wind and the components
independent (random phases),

``sigma_Z^2 = s_a^2 + (s_b^4 / 2 - s_a^2 s_b^2 - 2 c_ab^2) / U^2``,
``s_a^2 = sum_j |delta_par,j|^2 / 2``, ``s_b^2 = sum_j |delta_perp,j|^2 / 2``,
``c_ab = sum_j Re(delta_par,j conj(delta_perp,j)) / 2``

(the HWS ``|(U + a, b)|`` to fourth order in the errors, :func:`hws_error_moments`: the
cross-wind error, as large as the along-wind one where heave leaks into both beam pairs,
lowers sigma_Z and raises the mean HWS by ``s_b^2 / (2 U)``). Checked against the LOS
replay of the scan simulator (:func:`dbs_replay_sigma_z_ms`; ``benchmarks/dbs_sigma_z.py``,
``benchmarks/dbs_sigma_z.py --study second-order``).
Where it does not hold: second-order tilt terms (``U phi^2``) are left out, which matters
only where the first-order leak cancels (a period equal to the opposite-beam lag, or a wave
follower whose heave cancels the tilt's vertical wind, ``U cos(psi) = c``); yaw within a
cycle is not modelled (compass correction per cycle). There, use the replay.
"""

from __future__ import annotations

import functools
from collections.abc import Mapping

import numpy as np
from scipy.interpolate import CubicSpline

from flidar_uq.physics.hull import get_hull, orbital_lever_arm_m, phase_speed_ms
from flidar_uq.physics.lidar import (
    LidarGeometry,
    beam_unit_vectors_body,
    dbs_retrieval_operator,
    get_lidar,
    scan_times_azimuths,
    window_beam_times_s,
)
from flidar_uq.physics.surrogate import PERIOD_RANGE_S
from flidar_uq.physics.turbulence import kaimal_psd, record_variance_share

__all__ = [
    "DBS_MECHANISMS",
    "dbs_error_coefficients",
    "direction_moments",
    "rotate_moments",
    "dbs_harmonic_sigma_z_ms",
    "dbs_record_terms",
    "dbs_tilt_lever_terms",
    "band_moments_to_wind",
    "dbs_band_terms",
    "TERM_BASIS",
    "GRAM_PARTS",
    "hws_error_moments",
    "dbs_replay_sigma_z_ms",
    "cycle_sampling_rel_var",
    "output_correlation_line_weights",
    "window_line_frequencies_hz",
    "wind_to_body_deg",
]

#: Mechanisms that :func:`dbs_harmonic_sigma_z_ms` can switch off one at a time
#: (``benchmarks/dbs_sigma_z.py --study mechanisms``): ``tilt`` (the mean wind rotated into the beams'
#: vertical), ``heave`` (the hull's vertical velocity), ``translation`` (the head's
#: horizontal velocity: lever arm and orbital surge/sway), ``beam_timing`` (beams at
#: different times; off: every beam of a cycle at the cycle's mid time), ``shear`` (the
#: tilt moving each inclined beam's range gate up or down through the wind's shear:
#: :func:`dbs_error_coefficients`, zero without a ``shear_exponent``).
DBS_MECHANISMS = ("tilt", "heave", "translation", "beam_timing", "shear")


def wind_to_body_deg(wd_deg, yaw_deg=0.0):
    """Direction the wind blows towards in the body frame, deg counter-clockwise from the
    body x axis, from the meteorological direction ``wd_deg`` (from, clockwise from north)
    and the yaw (body x axis, counter-clockwise from east; docs/conventions.md)."""
    return (270.0 - np.asarray(wd_deg, float) - np.asarray(yaw_deg, float)) % 360.0


def _beam_weights(g: LidarGeometry):
    """Times ``t_k`` (s, from the cycle start), the retrieval operator ``P`` (K, 3) and the
    body unit vectors ``d`` (K, 3) of one cycle's beams: ``delta_m = sum_k P[k, m] v_k``
    for radial speed errors ``v_k`` (``d_k . e(t_k)`` for an apparent wind ``e``)."""
    t, az = scan_times_azimuths(g)
    d = beam_unit_vectors_body(g, az)  # (K, 3)
    if g.kind == "dbs":
        p = dbs_retrieval_operator(g)  # (K, 3)
    else:  # a signed VAD: the least-squares operator
        from flidar_uq.physics.lidar import vad_pseudo_inverse

        p = vad_pseudo_inverse(d).T
    return t, p, d


def _shear_phasors(z, p, d, scale, beta):
    """The retrieved wind's error phasors (..., nc, 3 (uvw), 3 (f)) from the tilt moving
    each beam's range gate through the shear.

    A lean ``phi`` of the hull towards ``theta`` lowers beam ``k``'s unit vector's vertical
    component by ``phi (d_k,x cos theta + d_k,y sin theta)``: its range gate's height ``z``
    changes by the fraction ``x_k = -phi (d_k,x cos theta + d_k,y sin theta) / d_k,z``
    (the focus height along the tilted beam, Nassif et al. 2020, Eq. 5), and the mean wind
    there by ``U alpha x_k`` for a power-law profile ``U (z / z_0)^alpha`` (Yamaguchi and
    Ishihara 2016), which the beam sees through its horizontal projection on the wind,
    ``d_k,x cos beta + d_k,y sin beta``. Linear in ``f = (1, cos theta, sin theta)``. A
    vertical beam sees none. Opposite beams' changes cancel when they are taken at once;
    a DBS lidar takes them a beam or two apart, so a tilt that changes between them leaks
    into ``u`` and ``v``: at 28 deg with ``alpha = 0.1``, ``alpha tan^2(th)`` = 2.8 % of
    the tilt's own vertical-wind leak.

    ``z`` (..., nc, K): each beam's ``exp(i omega t_k)`` (with the dwell average);
    ``p``, ``d`` (K, 3): :func:`_beam_weights`; ``scale`` (..., nc): ``U alpha phi`` (m/s);
    ``beta`` (..., nc): the wind's direction of travel in the body frame, rad.
    """
    proj = d[:, 0] * np.cos(beta)[..., None] + d[:, 1] * np.sin(beta)[..., None]  # (..., nc, K)
    v = -scale[..., None] * proj / d[:, 2]  # each beam's radial speed change per unit f
    f_of_beam = np.stack([np.zeros(len(d)), d[:, 0], d[:, 1]], -1)  # (K, 3 (f))
    return np.einsum("...ck,km,kf->...cmf", z * v, p, f_of_beam)


def direction_moments(direction_deg, weight=None, axis=-1):
    """Direction moments ``(<cos>, <sin>, <cos^2>, <sin cos>, <sin^2>)`` of wave components.

    Parameters
    ----------
    direction_deg : array_like
        Directions of travel, deg counter-clockwise from the body x axis.
    weight : array_like, optional
        Weights (a band's components' tilt variances); None: a single direction each
        (the moments of ``direction_deg`` itself, no reduction).
    axis : int
        Axis reduced when ``weight`` is given.

    Returns
    -------
    ndarray, shape (..., 5)
    """
    th = np.deg2rad(np.asarray(direction_deg, float))
    c, s = np.cos(th), np.sin(th)
    f = np.stack([c, s, c * c, s * c, s * s], axis=-1)
    if weight is None:
        return f
    w = np.asarray(weight, float)
    w = np.moveaxis(w, axis, -1)
    f = np.moveaxis(f, axis if axis >= 0 else axis - 1, -2)
    return np.sum(f * w[..., None], axis=-2) / np.sum(w, axis=-1)[..., None]


def dbs_error_coefficients(
    amplitude_deg,
    period_s,
    *,
    hws_ms,
    wind_body_deg,
    lever_arm_m: float = 0.0,
    hull="wave_follower",
    lidar: str | LidarGeometry | Mapping = "windcube_v2",
    mechanisms=DBS_MECHANISMS,
    dwell_average: bool = False,
    shear_exponent=0.0,
    window_start=0,
):
    """The along- and across-wind error phasors per component, as linear forms in its direction.

    A component travelling along ``theta`` has the error phasor
    ``delta = a . (1, cos theta, sin theta)`` (module docstring: ``e`` is linear in the
    direction's cosine and sine), so a band of components with a spread of directions has
    ``<|delta|^2> = sum_ij Re(a_i conj(a_j)) <f_i f_j>``, ``f = (1, cos, sin)``: the band's
    first and second direction moments (:func:`direction_moments`) suffice.

    Parameters
    ----------
    amplitude_deg, period_s : array_like, shape (..., nc)
        Lean amplitude (deg) and period (s) of each component (or band).
    hws_ms, wind_body_deg : array_like, shape (...)
        Mean HWS (m/s) and the direction the wind blows towards, deg counter-clockwise from
        the body x axis (:func:`wind_to_body_deg`).
    lever_arm_m, hull, lidar, mechanisms, dwell_average, shear_exponent
        As :func:`dbs_harmonic_sigma_z_ms`.
    window_start : int or sequence of int
        Position in the cycle (beam index) at which the retrieval window starts
        (:attr:`flidar_uq.physics.lidar.LidarGeometry.window_starts`): beam ``k`` is taken
        ``((k - window_start) mod K)`` beams into the window
        (:func:`flidar_uq.physics.lidar.window_beam_times_s`); 0 (default): the cycle
        itself. A sequence of ``S`` starts adds a leading axis, one window each.

    Returns
    -------
    a_par, a_perp : ndarray, complex, shape ([S,] ..., nc, 3)
        Coefficients (m/s) of ``(1, cos theta, sin theta)``.
    """
    g = get_lidar(lidar)
    bad = set(mechanisms) - set(DBS_MECHANISMS)
    if bad:
        raise ValueError(
            f"unknown mechanism {sorted(bad)[0]!r}; known: {', '.join(DBS_MECHANISMS)}"
        )
    _, p, d = _beam_weights(g)
    t_k = window_beam_times_s(g, np.atleast_1d(window_start))  # (S, K)
    w = p[:, :, None] * d[:, None, :]  # (K, 3 (uvw), 3 (xyz))
    if "beam_timing" not in mechanisms:
        t_k = np.broadcast_to(0.5 * (t_k[:, :1] + t_k[:, -1:]), t_k.shape)
    amp = np.deg2rad(np.asarray(amplitude_deg, float))
    per = np.asarray(period_s, float)
    hws = np.asarray(hws_ms, float)[..., None]
    beta = np.deg2rad(np.asarray(wind_body_deg, float))[..., None]
    alpha = np.asarray(shear_exponent, float)[..., None]
    amp, per, hws, beta, alpha = np.broadcast_arrays(amp, per, hws, beta, alpha)
    omega = 2.0 * np.pi / per
    r_x, r_z = get_hull(hull).relative_responses(per)
    zero = np.zeros(amp.shape, complex)
    tilt_z = hws * amp if "tilt" in mechanisms else zero
    heave_z = -r_z * phase_speed_ms(per) * amp if "heave" in mechanisms else zero
    if "translation" in mechanisms:
        lever = float(lever_arm_m) - r_x * orbital_lever_arm_m(per)
        e_h = -1j * omega * lever * amp  # minus the head velocity, along the direction
    else:
        e_h = zero
    # e = sum_i f_i B_i, f = (1, cos theta, sin theta)
    b = np.stack(
        [
            np.stack([zero, zero, heave_z + zero], -1),
            np.stack([e_h, zero, tilt_z * np.cos(beta)], -1),
            np.stack([zero, e_h, tilt_z * np.sin(beta)], -1),
        ],
        axis=-2,
    )  # (..., nc, 3 (f), 3 (xyz))
    if np.ndim(window_start):  # (S, 1, ..., 1, K): a leading window axis
        t_k = t_k.reshape(t_k.shape[:1] + (1,) * omega.ndim + t_k.shape[1:])
    else:
        t_k = t_k[0]
    z = np.exp(1j * omega[..., None] * t_k)  # ([S,] ..., nc, K)
    if dwell_average:  # the mean of exp(i omega t) over a beam's dwell: sinc(dwell / T)
        z = z * np.sinc(g.los_duration_s / per)[..., None]
    gmat = np.einsum("...k,kmi->...mi", z, w)  # (..., nc, 3 (uvw), 3 (xyz))
    a = np.einsum("...mi,...fi->...mf", gmat, b)  # (..., nc, 3 (uvw), 3 (f))
    if "shear" in mechanisms and np.any(alpha != 0.0):
        a = a + _shear_phasors(z, p, d, hws * alpha * amp, beta)
    cb, sb = np.cos(beta)[..., None], np.sin(beta)[..., None]
    return cb * a[..., 0, :] + sb * a[..., 1, :], -sb * a[..., 0, :] + cb * a[..., 1, :]


def _moment_matrix(mom):
    """``<f f^T>`` (..., 3, 3) of ``f = (1, cos theta, sin theta)`` from direction moments
    ``mom`` (..., 5) (:func:`direction_moments`)."""
    c, s, cc, sc, ss = (np.asarray(mom, float)[..., i] for i in range(5))
    one = np.ones_like(c)
    return np.stack(
        [np.stack([one, c, s], -1), np.stack([c, cc, sc], -1), np.stack([s, sc, ss], -1)], -2
    )


def _mean_sq(a, mom):
    """``<|a . f|^2>`` for direction moments ``mom`` (..., 5) (:func:`direction_moments`)."""
    return np.einsum("...i,...ij,...j->...", a, _moment_matrix(mom), np.conj(a)).real


def dbs_harmonic_sigma_z_ms(
    amplitude_deg,
    period_s,
    direction_deg=None,
    *,
    hws_ms,
    wind_body_deg,
    direction_moments_=None,
    lever_arm_m: float = 0.0,
    hull="wave_follower",
    lidar: str | LidarGeometry | Mapping = "windcube_v2",
    mechanisms=DBS_MECHANISMS,
    cross_wind: bool = True,
    dwell_average: bool = False,
    shear_exponent=0.0,
) -> np.ndarray:
    """sigma_Z (m/s) of a DBS lidar on a hull in a sea of harmonic components (module docstring).

    Parameters
    ----------
    amplitude_deg, period_s : array_like, shape (..., nc)
        Lean amplitude along the direction of travel (deg; ``sqrt(2)`` x the std of the
        component's or band's tilt) and period (s) of each component or band.
    direction_deg : array_like, shape (..., nc), optional
        Direction of travel of each component, deg counter-clockwise from the body x axis.
    hws_ms : array_like, shape (...)
        Mean horizontal wind speed, m/s.
    wind_body_deg : array_like, shape (...)
        Direction the wind blows towards, deg counter-clockwise from the body x axis
        (:func:`wind_to_body_deg` of the wind direction and the heading).
    direction_moments_ : array_like, shape (..., nc, 5), optional
        Instead of ``direction_deg``: each band's direction moments
        (:func:`direction_moments` weighted by its components' tilt variances), for bands
        with a spread of directions.
    lever_arm_m : float
        Height of the lidar head above the hull's rotation centre, m.
    hull : str or HullResponse
        The hull's response (:data:`flidar_uq.physics.hull.HULLS`).
    lidar : str, LidarGeometry or mapping
    mechanisms : sequence of str
        The mechanisms kept (:data:`DBS_MECHANISMS`; default all).
    cross_wind : bool
        The cross-wind error's fourth-order terms in the HWS (:func:`hws_error_moments`);
        False: the along-wind error's variance alone.
    dwell_average : bool
        Each beam's radial speed is the mean over its dwell (the pulse accumulation; Desert,
        Knapp & Aubrun 2021): every component's error is multiplied by
        ``sinc(dwell / T)`` (0.96 at 6 s for a 1-s beam). Default False: each beam at one
        instant, as the LOS replay; the virtual campaign averages over the dwell.
    shear_exponent : array_like, shape (...)
        Power-law exponent ``alpha`` (-) of the mean wind's profile: the tilt moves each
        inclined beam's range gate through it (mechanism ``shear``, :func:`_shear_phasors`);
        0 (default): no shear.

    Returns
    -------
    ndarray, shape (...)
        sigma_Z, m/s.
    """
    if (direction_deg is None) == (direction_moments_ is None):
        raise ValueError("dbs_harmonic_sigma_z_ms: give direction_deg or direction_moments_")
    mom = (
        direction_moments(direction_deg)
        if direction_moments_ is None
        else np.asarray(direction_moments_, float)
    )
    g = get_lidar(lidar)
    m = _moment_matrix(mom)
    # the along- and cross-wind moments: means over the record's retrieval windows
    a_par, a_perp = dbs_error_coefficients(
        amplitude_deg,
        period_s,
        hws_ms=hws_ms,
        wind_body_deg=wind_body_deg,
        lever_arm_m=lever_arm_m,
        hull=hull,
        lidar=g,
        mechanisms=mechanisms,
        dwell_average=dwell_average,
        shear_exponent=shear_exponent,
        window_start=g.window_starts,
    )  # (S, ..., nc, 3)
    var = np.mean(0.5 * np.sum(_mean_sq(a_par, mom), axis=-1), axis=0)
    if cross_wind:  # the HWS's own nonlinearity, to fourth order (hws_error_moments)
        s_perp2 = np.mean(0.5 * np.sum(_mean_sq(a_perp, mom), axis=-1), axis=0)
        cov = np.einsum("...ci,...cij,...cj->...", a_par, m, np.conj(a_perp)).real
        cov = np.mean(0.5 * cov, axis=0)
        hws = np.asarray(hws_ms, float)
        full = hws_error_moments(var, s_perp2, cov, np.maximum(hws, 1e-9))[0]
        var = np.where(hws > 0, full, var)
    return np.sqrt(var)


def rotate_moments(mom, deg):
    """Direction moments ``mom`` (..., 5) of directions rotated by ``deg`` (deg)."""
    r = np.deg2rad(np.asarray(deg, float))
    c2, sr = np.cos(r), np.sin(r)
    c, s, cc, sc, ss = (np.asarray(mom)[..., i] for i in range(5))
    nc_ = c * c2 - s * sr
    ns_ = s * c2 + c * sr
    ncc = c2**2 * cc - 2 * c2 * sr * sc + sr**2 * ss
    nss = sr**2 * cc + 2 * c2 * sr * sc + c2**2 * ss
    nsc = c2 * sr * (cc - ss) + (c2**2 - sr**2) * sc
    return np.stack([nc_, ns_, ncc, nsc, nss], -1)


def dbs_replay_sigma_z_ms(
    time_s,
    roll_deg,
    pitch_deg,
    *,
    hws_ms: float,
    wd_deg: float,
    yaw_deg=None,
    lever_arm_m: float = 0.0,
    translation_m=None,
    lidar: str | LidarGeometry | Mapping = "windcube_v2",
    dwell_samples: int = 1,
    every_beam: bool | None = None,
) -> float:
    """sigma_Z (m/s) of a record by LOS-level replay of its motion through a DBS lidar.

    Back-to-back cycles over the series, every line of sight at its own time
    (:func:`flidar_uq.physics.motion_spectrum.replay_sigma_z` with the DBS geometry): the
    reference for :func:`dbs_harmonic_sigma_z_ms`, and the method where the harmonic sum
    does not hold (module docstring). ``dwell_samples > 1``: each beam's radial speed is
    its mean over that many instants of its dwell (the pulse accumulation; compare with
    ``dwell_average=True``); default 1, each beam at one instant. ``every_beam``: one wind
    after every beam from the latest beam of each azimuth (a WindCube v2's 1-s output)
    instead of one a cycle (``benchmarks/dbs_sigma_z.py --study output-sampling``); default None, the
    geometry's :attr:`~flidar_uq.physics.lidar.LidarGeometry.every_beam_output`, as the
    virtual campaign and the harmonic sum take it.
    """
    from flidar_uq.physics.motion_spectrum import replay_sigma_z

    g = get_lidar(lidar)
    return replay_sigma_z(
        time_s,
        roll_deg,
        pitch_deg,
        yaw_deg,
        hws_ms=hws_ms,
        wd_deg=wd_deg,
        lever_arm_m=lever_arm_m,
        lidar=g,
        translation_m=translation_m,
        dwell_samples=dwell_samples,
        every_beam=every_beam,
    ).sigma_z_ms


#: Length of a record (s) whose motion error a DBS lidar samples once a cycle
#: (:func:`cycle_sampling_rel_var`): the 10-min statistics of the record table.
RECORD_S = 600.0

#: The largest relative variance of a record's realised ``Var Z`` about its expectation
#: (:func:`cycle_sampling_rel_var`): that of one harmonic at a fixed phase against the
#: cycle, ``2 cos^2(phi)`` over a uniform ``phi`` (variance 1/2).
_MAX_SAMPLING_REL_VAR = 0.5


def cycle_sampling_rel_var(frequency_hz, power, width_hz, *, cycle_s, record_s=RECORD_S):
    """Relative variance of a record's realised motion-error variance about its expectation,
    from one retrieval a cycle.

    A DBS lidar that retrieves once a cycle ``T_c`` samples each harmonic component of its
    error ``Z_n = sum_j Re(delta_j exp(i omega_j n T_c))`` at the cycle. The record's
    ``(1/N) sum_n Z_n^2`` then holds, beside its expectation ``sum_j |delta_j|^2 / 2``, the
    terms ``Re(delta_j delta_l D_N(omega_j + omega_l)) / 2`` with
    ``D_N(x) = (1/N) sum_n exp(i x n T_c)``, which do not average out where
    ``f_j + f_l`` is near a multiple of the cycle's frequency (a swell of twice the cycle
    sampled near its Nyquist period, or of one cycle): how they add up hangs on the phase at
    which the cycles meet the waves, which no 10-min statistic holds. Over random phases,
    with ``|D_N|^2`` a Fejer kernel of area ``1 / (N T_c)`` about each multiple, the
    relative variance of the realised ``Var Z`` is

    ``(1 / T_rec) sum_{m >= 1} int S(f) S(m / T_c - f) df / (int S(f) df)^2``

    for the error's spectrum ``S`` (one-sided), capped at 1/2 (one harmonic at a fixed
    phase). ``S`` is taken as the given components' powers spread evenly over their
    widths. Checked against LOS-level replay (``benchmarks/dbs_sigma_z.py --study output-sampling``,
    ``tests/test_dbs_sigma_z.py``).

    Parameters
    ----------
    frequency_hz, power, width_hz : array_like, shape (..., nc)
        Each component's (or sub-band's) frequency (Hz, > 0), share of ``Var Z`` (any
        unit, >= 0; NaN counts as 0) and frequency width (Hz, > 0).
    cycle_s : float
        Time between retrievals, s (a DBS lidar's cycle).
    record_s : float
        Record length, s.

    Returns
    -------
    numpy.ndarray, shape (...)
        Relative variance (-), in [0, 1/2]; 0 where the powers add up to 0.
    """
    f, pw, w = np.broadcast_arrays(
        np.asarray(frequency_hz, float), np.asarray(power, float), np.asarray(width_hz, float)
    )
    pw = np.where(np.isfinite(pw) & np.isfinite(f) & np.isfinite(w), np.maximum(pw, 0.0), 0.0)
    f = np.where(pw > 0, f, 0.0)
    w = np.where(pw > 0, w, 1.0)
    density = pw / w
    lo, hi = f - 0.5 * w, f + 0.5 * w
    total = np.zeros(pw.shape[:-1])
    f_max = float(np.max(hi, initial=0.0))
    for m in range(1, int(np.ceil(2.0 * f_max * cycle_s)) + 1):
        # the overlap of component i with component j reflected about f_m / 2
        lo_j, hi_j = m / cycle_s - hi, m / cycle_s - lo
        overlap = np.minimum(hi[..., :, None], hi_j[..., None, :]) - np.maximum(
            lo[..., :, None], lo_j[..., None, :]
        )
        total += np.einsum("...i,...j,...ij->...", density, density, np.maximum(overlap, 0.0))
    sum_p = pw.sum(axis=-1)
    with np.errstate(invalid="ignore", divide="ignore"):
        rel = np.where(sum_p > 0, total / float(record_s) / sum_p**2, 0.0)
    return np.minimum(rel, _MAX_SAMPLING_REL_VAR)


#: Order of the basis of :func:`dbs_record_terms`: sigma_Z's error phasor is
#: ``k (a_tilt + h a_heave) + L a_lever + h a_orbital`` for a motion scale ``k``, a hull
#: response ``h`` (0 rotates about a fixed centre, 1 follows the waves) and a lever arm ``L``.
TERM_BASIS = ("tilt", "heave", "lever", "orbital")

#: The Gram matrices of :func:`dbs_record_terms` and :func:`dbs_band_terms` with
#: ``cross_wind``: of the error along the wind ``a``, across it ``b``, and of their
#: covariance (symmetric part), each a quadratic form in ``v = (k, k h, L, h)``:
#: ``s_a^2 = v^T G_a v``, ``s_b^2 = v^T G_b v``, ``c_ab = v^T G_ab v``
#: (:func:`hws_error_moments`).
GRAM_PARTS = ("along", "across", "covariance")


def hws_error_moments(var_along, var_across, cov, hws_ms):
    """Variance and mean of the HWS error ``Z = |(U + a, b)| - U`` (m/s) of Gaussian along-
    and cross-wind errors ``a, b`` of the retrieved wind, to fourth order in ``a, b / U``.

    ``Z = a + b^2 / (2 U) - a b^2 / (2 U^2) + ...``, so
    ``Var Z = s_a^2 + s_b^4 / (2 U^2) - (s_a^2 s_b^2 + 2 c_ab^2) / U^2`` and
    ``E Z = s_b^2 / (2 U)``: the cross-wind error (a DBS lidar's heave leaks into both beam
    pairs) lowers sigma_Z below ``s_a`` and raises the mean HWS. Against the LOS-level
    replay (``benchmarks/dbs_sigma_z.py --study second-order``) the fourth-order variance gives
    half of the replay's reduction (a WindCube v2 after every beam; 80 % once a cycle); the mean leaves out the along-wind error's own
    second-order mean (the tilt times the heave velocity), which brings the replay's mean
    0.1-0.2 % of U below ``s_b^2 / (2 U)`` with a swell against the wind at 10-15 m/s and
    up to 0.5 % at 5 m/s.

    Parameters
    ----------
    var_along, var_across : array_like
        ``s_a^2``, ``s_b^2``, (m/s)^2.
    cov : array_like
        ``c_ab``, (m/s)^2.
    hws_ms : array_like
        ``U``, m/s (> 0).

    Returns
    -------
    var_z, mean_z : numpy.ndarray
        (m/s)^2 (>= 0) and m/s, broadcast shape.
    """
    sa2, sb2, c = (np.asarray(x, float) for x in (var_along, var_across, cov))
    inv_u2 = 1.0 / np.asarray(hws_ms, float) ** 2
    var = sa2 + inv_u2 * (0.5 * sb2 * sb2 - sa2 * sb2 - 2.0 * c * c)
    return np.maximum(var, 0.0), 0.5 * sb2 * np.sqrt(inv_u2)


def _basis_gram(
    bands,
    hws,
    wind_body_deg,
    lidar,
    dwell_average,
    cross_wind=False,
    shear=0.0,
    per_component=False,
    window_lines=False,
):
    """Gram matrices (..., 4, 4) of the :data:`TERM_BASIS` phasors at one wind direction.

    ``bands = (amp, per, mom_body)``: lean amplitudes (deg) and periods (s) of the
    components or bands (..., nc) and their direction moments in the body frame
    (..., nc, 5); ``hws`` (...) m/s, ``wind_body_deg`` (...) deg: ``G_ij = sum_c a_i M_c a_j^* / 2`` with
    ``M_c = <f f^T>`` (:func:`dbs_error_coefficients`' linear forms in ``f``). ``shear``
    (...): the shear exponent (-), whose term (the range gates moved by the tilt) joins the
    tilt's phasor, scaled by ``k`` with it.
    ``cross_wind``: (..., 3, 4, 4), the along-wind error's, the cross-wind error's and
    their covariance's (symmetric part) Gram matrices (:data:`GRAM_PARTS`).
    ``per_component``: each component's own, (..., [3,] nc, 4, 4), which sum to them.
    ``window_lines``: a leading axis of the ``S`` spectral lines of the error over the
    retrieval windows (:func:`window_line_frequencies_hz`), which sum to them.
    """
    from flidar_uq.physics.hull import DofResponse, HullResponse

    amp, per, mom_body = bands
    one, zero = DofResponse(gain=1.0), DofResponse(gain=0.0)
    follower = HullResponse("follower", one, one, one)
    still = HullResponse("still", one, zero, zero)
    basis = (  # (mechanisms, hull, lever arm) of each basis phasor
        (("tilt", "shear", "beam_timing"), still, 0.0),
        (("heave", "beam_timing"), follower, 0.0),
        (("translation", "beam_timing"), still, 1.0),
        (("translation", "beam_timing"), follower, 0.0),
    )
    m = _moment_matrix(mom_body)  # (..., nc, 3, 3)

    spec = "...icf,...cfg,...jcg->...cij" if per_component else "...icf,...cfg,...jcg->...ij"

    def gram(x, y):
        return 0.5 * np.einsum(spec, x, m, np.conj(y)).real

    g = get_lidar(lidar)
    coef = [  # each (S, ..., nc, 3): the record's retrieval windows on a leading axis
        dbs_error_coefficients(
            amp,
            per,
            hws_ms=hws,
            wind_body_deg=wind_body_deg,
            lever_arm_m=lever,
            hull=hull,
            lidar=g,
            mechanisms=mech,
            dwell_average=dwell_average,
            shear_exponent=shear,
            window_start=g.window_starts,
        )
        for mech, hull, lever in basis
    ]
    # the phasors' discrete Fourier transform over the S windows: line m of a component at
    # f is the error's power at f + m / (S dt) (:func:`window_line_frequencies_hz`); by
    # Parseval the lines sum to the mean over the windows
    n_windows = len(g.window_starts)
    a = np.fft.fft(np.stack([c[0] for c in coef], axis=-3), axis=0) / n_windows  # along
    if not cross_wind:
        lines = gram(a, a)
    else:
        b = np.fft.fft(np.stack([c[1] for c in coef], axis=-3), axis=0) / n_windows  # across
        cov = gram(a, b)
        parts = [gram(a, a), gram(b, b), 0.5 * (cov + np.swapaxes(cov, -1, -2))]
        lines = np.stack(parts, axis=-4 if per_component else -3)
    return lines if window_lines else lines.sum(axis=0)


def window_line_frequencies_hz(frequency_hz, lidar: str | LidarGeometry | Mapping):
    """Frequencies (Hz) at which a DBS lidar's output holds a motion component's error.

    A lidar with ``S`` retrieval windows an output interval ``dt`` apart (a wind after
    every beam, :attr:`~flidar_uq.physics.lidar.LidarGeometry.window_starts`) weighs a
    component ``exp(i omega t)`` by a phasor ``delta_s`` that repeats with the window's
    place ``s`` in the cycle, so its output ``Re(delta_s exp(i omega n dt))`` is a sum of
    lines at ``f + m / (S dt)``, ``m = 0 .. S - 1``, with the powers of the discrete
    Fourier transform of ``delta_s`` (``window_lines`` of the band terms), sampled every
    ``dt``: folded into ``[0, 1 / (2 dt)]``. One window a cycle (``S = 1``): the
    component's own frequency, folded at the cycle. Returns shape ``(S,) + f.shape``.
    """
    g = get_lidar(lidar)
    n_windows, dt = len(g.window_starts), float(g.output_interval_s)
    f = np.asarray(frequency_hz, float)
    lines = f[None] + np.arange(n_windows).reshape((-1,) + (1,) * f.ndim) / (n_windows * dt)
    return np.abs((lines + 0.5 / dt) % (1.0 / dt) - 0.5 / dt)


#: Sub-points of a line's width over which the turbulence's spectrum is averaged
#: (:func:`output_correlation_line_weights`).
_LINE_SUBPOINTS = 16


@functools.cache
def _kaimal_record_table():
    """``log(T U / L)`` nodes and, at each, the share of a Kaimal spectrum's variance within a
    record of ``T`` (its mean removed: ``1 - sinc^2(f T)``) and that record variance's
    relative variance times ``T U / L`` (:func:`_kaimal_record_moments`)."""
    log_x = np.linspace(np.log(0.1), np.log(1e5), 241)
    g = np.geomspace(1e-7, 1e3, 6000)  # f L / U
    dg = np.diff(g)
    # the Kaimal density per unit f L / U; f T = (f L / U) (T U / L)
    dens = 4.0 / (1.0 + 6.0 * g) ** (5.0 / 3.0) * record_variance_share(g, np.exp(log_x)[:, None])
    var = np.sum(0.5 * (dens[:, 1:] + dens[:, :-1]) * dg, axis=-1)
    sq = np.sum(0.5 * (dens[:, 1:] ** 2 + dens[:, :-1] ** 2) * dg, axis=-1)
    return log_x, var, sq / var**2


def _kaimal_record_moments(record_over_tau):
    """Share (-) of a Kaimal spectrum's variance within a record (the record's mean removed)
    and the relative variance (-) of that record variance for a Gaussian process,
    ``(1 / T) int S^2 df / (int S df)^2``, at ``T U / L`` (-)."""
    log_x, var, sq = _kaimal_record_table()
    x = np.log(np.clip(np.asarray(record_over_tau, float), np.exp(log_x[0]), np.exp(log_x[-1])))
    return np.interp(x, log_x, var), np.interp(x, log_x, sq) / np.exp(x)


def output_correlation_line_weights(
    line_hz, width_hz, *, hws_ms, length_scale_m, record_s=RECORD_S
):
    """Each output line's weight (-) in the variance of the motion-turbulence correlation.

    The variance one line alone gives a record's realised correlation of the motion error
    with the turbulence: ``S_u(f) (1 + CV^2) / (2 T sigma_u^2)``, the Kaimal
    spectrum within the record averaged over the line's width. The sample correlation over
    ``T`` of two uncorrelated processes scatters with ``Var r = (1 / (2 T)) int S_Z(f) S_u(f)
    df`` (Bartlett 1946; Box & Jenkins 1976, Eq. 11.1.7), the one-sided spectra normalised to
    the variance within a record (the record's mean removed: a factor ``1 - sinc^2(f T)``
    on each), times ``1 + CV^2`` with ``CV^2 = (1 / T) int S_u^2 df`` the relative variance
    of the record's own variance for a Gaussian process; these weights' mean over the
    lines' powers is that ``Var r`` (against Monte Carlo 0.94-0.97 of the realised variance,
    ``tests/test_dbs_sigma_z.py``). Each line's share of ``Var Z`` weighted by it gives a quadratic form in the motion's
    parameters whose ratio to ``Var Z`` is the correlation's variance.

    Parameters
    ----------
    line_hz : array_like, shape (S, ..., nc)
        The lines (Hz, :func:`window_line_frequencies_hz`).
    width_hz : array_like, shape (nc,) or broadcastable
        Each line's width (Hz, > 0).
    hws_ms, length_scale_m : array_like, shape (...)
        Mean wind speed (m/s) and the Kaimal length scale of ``u`` (m).
    record_s : float
        Record length, s.

    Returns
    -------
    numpy.ndarray, shape of ``line_hz``
    """
    f = np.asarray(line_hz, float)
    w = np.broadcast_to(np.asarray(width_hz, float), f.shape)
    u = np.asarray(hws_ms, float)
    length = np.asarray(length_scale_m, float)
    record = float(record_s)

    def within_record(f_hz, uu, ll):  # the Kaimal spectrum less what the record's mean takes
        return kaimal_psd(f_hz, uu, 1.0, ll) * record_variance_share(f_hz, record)

    spectrum = 0.0
    for x in (np.arange(_LINE_SUBPOINTS) + 0.5) / _LINE_SUBPOINTS - 0.5:
        spectrum = spectrum + within_record(np.abs(f + x * w), u[..., None], length[..., None])
    spectrum /= _LINE_SUBPOINTS
    # normalised by the turbulence's variance within a record, times 1 + CV^2
    with np.errstate(invalid="ignore", divide="ignore"):
        var_u, cv_sq = _kaimal_record_moments(record * u / length)
    return spectrum * ((1.0 + cv_sq) / var_u / (2.0 * record))[..., None]


def _heading_grid(n_headings: int) -> np.ndarray:
    """Wind directions relative to the body (deg) averaged over where the heading is unknown."""
    return np.arange(int(n_headings)) * 360.0 / int(n_headings)


def dbs_record_terms(
    hws_ms,
    roll_amplitude_deg,
    pitch_amplitude_deg,
    period_s,
    *,
    wind_body_deg=None,
    roll_period_s=None,
    lidar: str | LidarGeometry | Mapping = "windcube_v2",
    n_headings: int = 24,
    dwell_average: bool = True,
    cross_wind: bool = False,
    shear_exponent=None,
) -> np.ndarray:
    """Per-record Gram matrix of a DBS lidar's error phasors: sigma_Z for any lever arm,
    hull response and motion scale by a 4 x 4 quadratic form.

    Each record's motion is a roll harmonic (about the body x axis: the hull leans along the
    body y axis) and a pitch harmonic (leans along the body x axis), independent, with their
    amplitudes (``sqrt(2)`` x std, deg) and periods.
    The phasor of the along-wind error is linear in ``(k, k h, L, h)`` (:data:`TERM_BASIS`),
    so ``sigma_Z^2 = v^T G v`` with ``G_ij = sum_components Re(a_i conj(a_j)) / 2`` (averaged
    over ``n_headings`` headings when ``wind_body_deg`` is None). The cross-wind
    second-order term is left out (below 1 % of sigma_Z^2 on the benchmark seas). The
    harmonics' directions of travel are the body axes, +y and +x: a record of roll and
    pitch amplitudes does not say on which side its waves run, which for a hull that heaves
    sets the sign of the heave-tilt cross term (:func:`dbs_band_terms`, from a record's
    tilt bands, knows it).

    Parameters
    ----------
    hws_ms, roll_amplitude_deg, pitch_amplitude_deg, period_s : array_like, shape (n,)
    wind_body_deg : array_like, shape (n,), optional
        The wind's direction relative to the body (:func:`wind_to_body_deg` of the record's
        wind direction and heading); None: unknown, averaged.
    roll_period_s : array_like, shape (n,), optional
        The roll's period, s (default: ``period_s``, the pitch's).
    lidar, dwell_average
        As :func:`dbs_harmonic_sigma_z_ms`.
    cross_wind : bool
        Also the cross-wind error's Gram matrix and the covariance's (:data:`GRAM_PARTS`).
    shear_exponent : array_like, shape (n,), optional
        Each record's power-law shear exponent (-; NaN or None: no shear term), as
        :func:`dbs_harmonic_sigma_z_ms`.

    Returns
    -------
    ndarray, shape (n, 4, 4), or (n, 3, 4, 4) with ``cross_wind``
        ``G`` in (m/s)^2 (per m and m^2 for the lever-arm rows).
    """
    hws = np.asarray(hws_ms, float)
    shear = _shear_or_zero(shear_exponent, hws.shape)
    p_pitch = np.asarray(period_s, float)
    p_roll = p_pitch if roll_period_s is None else np.asarray(roll_period_s, float)
    amp = np.stack(np.broadcast_arrays(roll_amplitude_deg, pitch_amplitude_deg), -1)
    per = np.stack(np.broadcast_arrays(p_roll, p_pitch), -1)
    amp, per = np.broadcast_arrays(amp, per)
    mom = np.broadcast_to(direction_moments(np.array([90.0, 0.0])), amp.shape + (5,))
    betas = (
        [np.asarray(wind_body_deg, float)]
        if wind_body_deg is not None
        else [np.full(hws.shape, b) for b in _heading_grid(n_headings)]
    )
    gram = sum(
        _basis_gram((amp, per, mom), hws, b, lidar, dwell_average, cross_wind, shear) for b in betas
    )
    return gram / len(betas)


def _shear_or_zero(shear_exponent, shape) -> np.ndarray:
    """A record's shear exponent (-) broadcast to ``shape``, 0 where it is None or NaN."""
    if shear_exponent is None:
        return np.zeros(shape)
    return np.broadcast_to(np.nan_to_num(np.asarray(shear_exponent, float), nan=0.0), shape)


#: Highest harmonic of the wind's direction relative to the body, ``beta``, in a Gram matrix
#: of :func:`dbs_record_terms`: the tilt's phasor along the wind is quadratic in
#: ``(cos beta, sin beta)`` (the mean wind rotated into the beams' vertical, ``U cos(beta -
#: theta)``, projected on the wind) and the lever arm's linear, so their products hold
#: harmonics up to 4, and ``2 * 4 + 1`` wind directions determine the Gram matrix at every
#: other (tested against :func:`dbs_record_terms`).
_BETA_HARMONICS = 4


def _beta_basis(wind_body_deg) -> np.ndarray:
    """Fourier basis ``(1, cos b, sin b, ..., cos 4b, sin 4b)`` (..., 9) of the wind's body
    direction (deg); where it is NaN (the heading unknown) ``(1, 0, ..., 0)``: the mean
    over headings."""
    b = np.deg2rad(np.asarray(wind_body_deg, float))
    known = np.isfinite(b)
    b = np.where(known, b, 0.0)
    cols = [np.ones(b.shape)]
    for m in range(1, _BETA_HARMONICS + 1):
        cols += [np.where(known, np.cos(m * b), 0.0), np.where(known, np.sin(m * b), 0.0)]
    return np.stack(cols, -1)


def _unit_tilt_lever_series(period_s, lidar, dwell_average) -> np.ndarray:
    """Fourier coefficients over the wind's body direction (:func:`_beta_basis`) of the
    ``(k, k)``, ``(k, L)`` and ``(L, L)`` entries of :func:`dbs_record_terms` for roll and
    pitch of 1 deg at ``period_s`` (n,) and a wind of 1 m/s: shape (n, 3, 9)."""
    n_beta = 2 * _BETA_HARMONICS + 1
    nodes = np.arange(n_beta) * 360.0 / n_beta
    per = np.repeat(np.asarray(period_s, float), n_beta)
    ones = np.ones(per.shape)
    gram = dbs_record_terms(
        ones,
        ones,
        ones,
        per,
        wind_body_deg=np.tile(nodes, per.size // n_beta),
        lidar=lidar,
        dwell_average=dwell_average,
    )
    entries = np.stack([gram[:, 0, 0], gram[:, 0, 2], gram[:, 2, 2]], -1)  # (n * 9, 3)
    values = entries.reshape(-1, n_beta, 3)
    return np.einsum("fj,njc->ncf", np.linalg.inv(_beta_basis(nodes)), values)


#: Log-spaced periods of the table of :func:`dbs_tilt_lever_terms` on the surrogate's
#: range (:data:`flidar_uq.physics.surrogate.PERIOD_RANGE_S`), a cubic spline in ``log T``
#: through the direct sum. Measured against it (3000 random periods, winds, lever arms and
#: directions; WindCube v1, v2, v2.1): 3200 nodes keep sigma_Z within 3e-5 of it (the
#: worst next to the zeros at periods of 1 and 2 beam dwells; 1e-8 where sigma_Z is above
#: 1 % of its largest value), 1600 within 8e-4, 800 within 1.2e-2. Built once per lidar in
#: about 0.4 s (once a cycle) or 1.9 s (a wind after every beam: five windows).
_TABLE_PERIODS = 3200


@functools.lru_cache(maxsize=8)
def _tilt_lever_table(lidar: LidarGeometry, dwell_average: bool) -> CubicSpline:
    """Cubic spline in ``log T`` of :func:`_unit_tilt_lever_series` (27 values a period)."""
    log_t = np.linspace(*np.log(PERIOD_RANGE_S), _TABLE_PERIODS)
    series = _unit_tilt_lever_series(np.exp(log_t), lidar, dwell_average)
    return CubicSpline(log_t, series.reshape(log_t.size, -1), axis=0)


def dbs_tilt_lever_terms(
    hws_ms,
    amplitude_deg,
    period_s,
    *,
    wind_body_deg=None,
    lidar: str | LidarGeometry | Mapping = "windcube_v2",
    dwell_average: bool = True,
):
    """A DBS lidar's tilt and lever-arm Gram entries for the bin model's roll and pitch.

    The ``(k, k)``, ``(k, L)`` and ``(L, L)`` entries of :func:`dbs_record_terms` for the
    bin motion model's harmonic roll and pitch of equal amplitude and period
    (Gutiérrez-Antuñano et al. 2018, Sec. 2.4), fast over posterior draws x records.
    The bin model has no hull response (``h = 0``), so its sigma_Z is
    ``sqrt(k^2 G_kk + 2 k L G_kL + L^2 G_LL)`` (:data:`TERM_BASIS`; the beam-pair phasors of
    Yamaguchi & Ishihara 2016, Eqs. 3-4). The phasors are linear in the amplitude and the
    tilt's also in the wind speed, so ``G_kk = U^2 A^2 g_kk``, ``G_kL = U A^2 g_kL`` and
    ``G_LL = A^2 g_LL`` with ``g`` a function of the period and of the wind's direction
    relative to the beams only, a trigonometric polynomial of degree 4 in it
    (:data:`_BETA_HARMONICS`): its 9 Fourier coefficients come from
    :func:`dbs_record_terms` at 9 directions, tabulated once per lidar over the period
    (:data:`_TABLE_PERIODS`), and are evaluated at each record's direction. Where the
    direction is unknown it is the mean over headings, the average
    :func:`dbs_record_terms` takes.

    Parameters
    ----------
    hws_ms : array_like
        Mean HWS ``U``, m/s.
    amplitude_deg : array_like
        Roll and pitch amplitude ``A`` (each), deg.
    period_s : array_like
        Roll and pitch period, s.
    wind_body_deg : array_like, optional
        The wind's direction relative to the body (:func:`wind_to_body_deg`), deg; NaN or
        None: unknown, averaged over headings.
    lidar : str, LidarGeometry or mapping
    dwell_average : bool
        As :func:`dbs_record_terms` (on: the pulse accumulation over each beam).

    Returns
    -------
    gram_kk, gram_kl, gram_ll : numpy.ndarray
        The broadcast shape of the arguments: (m/s)^2, (m/s)^2 per m and (m/s)^2 per m^2;
        NaN where the wind speed or the amplitude is negative or the period outside the
        table (:data:`flidar_uq.physics.surrogate.PERIOD_RANGE_S`, 1-20 s).
    """
    table = _tilt_lever_table(get_lidar(lidar), bool(dwell_average))
    hws = np.asarray(hws_ms, float)
    amp = np.asarray(amplitude_deg, float)
    per = np.asarray(period_s, float)
    beta = np.full(hws.shape, np.nan) if wind_body_deg is None else wind_body_deg
    basis = _beta_basis(beta)
    with np.errstate(invalid="ignore"):
        ok = (per >= PERIOD_RANGE_S[0]) & (per <= PERIOD_RANGE_S[1])
    coef = table(np.log(np.where(ok, per, 1.0))).reshape(per.shape + (3, -1))
    unit = np.einsum("...cf,...f->...c", coef, basis, optimize=True)
    with np.errstate(invalid="ignore"):
        valid = ok & (hws >= 0) & (amp >= 0)
    amp_sq = np.where(valid, amp**2, np.nan)
    return unit[..., 0] * hws**2 * amp_sq, unit[..., 1] * hws * amp_sq, unit[..., 2] * amp_sq


def band_moments_to_wind(cos_psi, cos_sq_psi, sin_psi=0.0, sincos_psi=0.0) -> np.ndarray:
    """Direction moments (..., 5) of tilt bands relative to the wind's direction of travel.

    A band's ``<cos psi>`` (signed: + downwind), ``<cos^2 psi>`` (its along-wind share of
    the tilt variance), ``<sin psi>`` (signed: + to the left of the wind's direction of
    travel, counter-clockwise) and ``<sin psi cos psi>``
    (:func:`flidar_uq.data.imu.tilt_bands_from_records`). The heave tells the side a band's
    waves run on (``<sin psi>``, :func:`flidar_uq.data.imu.band_direction_from_heave`); a
    record's tilt alone does not, and then ``sin_psi = 0`` and ``sincos_psi = 0`` (either
    side alike: a spread symmetric about the wind's axes). With the side, a band running
    obliquely to the wind needs its measured ``<sin psi cos psi>``: moments of directions
    with a cross moment of 0 have ``<cos>^2 / <cos^2> + <sin>^2 / <sin^2> <= 1`` (their
    matrix positive semi-definite), and a narrow band at 45 deg has 2, so with 0 there its
    Gram matrix is not positive semi-definite (the record model takes a negative
    cross-wind variance as 0, :func:`flidar_uq.inference.record_motion.gram_hws_error_ms`).
    """
    c, cc, s, sc = np.broadcast_arrays(
        np.asarray(cos_psi, float),
        np.asarray(cos_sq_psi, float),
        np.asarray(sin_psi, float),
        np.asarray(sincos_psi, float),
    )
    return np.stack([c, s, cc, sc, 1.0 - cc], -1)


def dbs_band_terms(
    hws_ms,
    amplitude_deg,
    period_s,
    moments_to_wind,
    *,
    wind_body_deg=None,
    lidar: str | LidarGeometry | Mapping = "windcube_v2",
    n_headings: int = 24,
    dwell_average: bool = True,
    cross_wind: bool = False,
    shear_exponent=None,
    per_band: bool = False,
    window_lines: bool = False,
) -> np.ndarray:
    """Per-record Gram matrix of a DBS lidar's error phasors from the record's tilt bands.

    As :func:`dbs_record_terms`, with each band of the tilt spectrum a component of the
    harmonic sum (the six-degree-of-freedom band sum of
    :mod:`flidar_uq.physics.six_dof_sigma_z` for a CW lidar; Yamaguchi & Ishihara 2016,
    Eqs. 3-4, for the beams): its lean amplitude along its direction of travel, its period
    and its direction moments relative to the wind (:func:`band_moments_to_wind`), turned
    into the body frame by the wind's direction relative to the beams
    (:func:`rotate_moments`). A band's signed ``<cos psi>`` sets the sign of the heave-tilt
    cross term, ``(U cos psi - c)`` for a wave follower. Where the heading is unknown the
    sea turns with the wind over ``n_headings`` directions.

    Parameters
    ----------
    hws_ms : array_like, shape (n,)
        Mean HWS, m/s.
    amplitude_deg, period_s : array_like, shape (n, nb)
        Each band's lean amplitude (deg, ``sqrt(2)`` x its tilt std) and period (s).
    moments_to_wind : array_like, shape (n, nb, 5)
        Each band's direction moments relative to the wind's direction of travel.
    wind_body_deg : array_like, shape (n,), optional
        The wind's direction relative to the body (:func:`wind_to_body_deg`), deg; None:
        unknown, averaged.
    lidar, n_headings, dwell_average, cross_wind, shear_exponent
        As :func:`dbs_record_terms`.
    per_band : bool
        Each band's own Gram matrix (its share), an axis ``nb`` before the last two.

    Returns
    -------
    ndarray, shape (n, 4, 4), or (n, 3, 4, 4) with ``cross_wind``
        ``G`` in (m/s)^2 (per m and m^2 for the lever-arm rows); with ``per_band``
        (n, nb, 4, 4) or (n, 3, nb, 4, 4), which sum over ``nb`` to it; with
        ``window_lines`` a leading axis of the output's ``S`` lines
        (:func:`window_line_frequencies_hz`), which sum to it.
    """
    hws = np.asarray(hws_ms, float)
    shear = _shear_or_zero(shear_exponent, hws.shape)
    amp, per = np.broadcast_arrays(np.asarray(amplitude_deg, float), np.asarray(period_s, float))
    mom = np.asarray(moments_to_wind, float)
    betas = (
        [np.asarray(wind_body_deg, float)]
        if wind_body_deg is not None
        else [np.full(hws.shape, b) for b in _heading_grid(n_headings)]
    )
    gram = sum(
        _basis_gram(
            (amp, per, rotate_moments(mom, b[..., None])),
            hws,
            b,
            lidar,
            dwell_average,
            cross_wind,
            shear,
            per_band,
            window_lines,
        )
        for b in betas
    )
    return gram / len(betas)
