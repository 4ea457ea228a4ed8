"""sigma_Z of a buoy in six degrees of freedom: tilt, orbital translation and heave, by bands.

A record's sea is a sum of wave components (or of period bands of its spectrum), each a
harmonic lean of amplitude ``A_b`` (deg) along its direction of travel, at period ``T_b``
and at an angle ``psi_b`` between its direction of travel and the wind's. With the hull's
kinematics of :mod:`flidar_uq.physics.hull` the motion-induced error of the retrieved HWS of
one band has two parts, uncorrelated over the scan phase:

1. **Tilt and heave: the vertical wind that the tilted beams see** (the leak of a vertical
   wind that changes within a scan into the horizontal retrieval, ~``cot(theta)``): the
   lean rotates the mean wind ``U`` into the body's vertical by ``U cos(psi) phi`` and the
   heave adds ``-R_z c phi`` (``c = g / omega``), so the rotational sigma_Z of a
   single-axis tilt along the wind, ``s(A, T) U`` (Gutierrez-Antunano et al. 2018, Eqs.
   4-14, through :mod:`flidar_uq.physics.surrogate`), becomes
   ``s(A, T) |U cos(psi) - R_z c|``. Without heave this is the ``|cos psi|`` scaling of a
   tilt at an angle to the wind (docs/motion_spectrum.md); with heave a swell
   across the wind, harmless to a tilt-only model, contributes ``s(A, T) c``.
2. **Horizontal head velocity along the wind**: ``(L - R_x g / omega^2) dphi/dt`` along the
   direction of travel (the lever arm ``L`` against the orbital motion), of which the
   component along the wind, ``cos(psi)``, enters the HWS directly, averaged over one
   scan (:func:`translation_unit_sq`).

``sigma_Z^2 = sum_b [s(A_b, T_b)^2 |U cos psi_b - R_z c_b|^2
+ cos^2 psi_b |L - R_x g / omega_b^2|^2 u_b^2]``: the quadrature sum over bands
("What real seas add"), each band now a six-degree-of-freedom harmonic. Checked against the
scan simulator's replay of six-degree-of-freedom series
(:func:`flidar_uq.physics.motion_spectrum.replay_sigma_z` with the translation;
``benchmarks/six_dof_sigma_z.py``, docs/motion_spectrum.md).
"""

from __future__ import annotations

import numpy as np

from flidar_uq.physics.hull import get_hull, orbital_lever_arm_m, phase_speed_ms
from flidar_uq.physics.lidar import LidarGeometry

__all__ = ["six_dof_band_sigma_z_ms", "six_dof_band_terms", "translation_unit_sq"]

#: periods (s) the rotational surrogate covers; bands outside are clipped onto it
_PERIOD_RANGE_S = (1.0, 20.0)


def translation_unit_sq(amplitude_deg, period_s, scan_period_s=1.0):
    """Squared HWS error per metre of effective lever arm from the head's translation, (m/s)^2 / m^2.

    A lean ``A sin(2 pi t / T + phi)`` moves a head ``L`` (m) above the rotation centre
    horizontally at ``L A (2 pi / T) cos(...)`` along the lean; along the wind (the lean
    along the wind, random phase) its variance is ``(L A 2 pi / T)^2 / 2``. The VAD fit
    over one scan of ``scan_period_s`` averages it by ``sinc(scan / T)``. Checked against
    Check: 3 deg, 4 s, 4 m gives 0.21 m/s (sqrt(0.28^2 - 0.18^2) = 0.21).

    Parameters
    ----------
    amplitude_deg, period_s : array_like
        Lean amplitude (deg) and period (s), broadcastable.
    scan_period_s : float
        Duration of one VAD scan (s).

    Returns
    -------
    numpy.ndarray
        ``u^2`` such that ``sigma_Z,trans = L u``.
    """
    a = np.deg2rad(np.asarray(amplitude_deg, dtype=float))
    t = np.asarray(period_s, dtype=float)
    return 0.5 * (a * 2.0 * np.pi / t * np.sinc(scan_period_s / t)) ** 2


def six_dof_band_sigma_z_ms(
    hws_ms,
    band_amplitude_deg,
    band_period_s,
    *,
    band_cos_psi,
    band_cos_sq_psi=None,
    lever_arm_m: float = 0.0,
    hull="wave_follower",
    lidar: str | LidarGeometry = "zephir300",
    scan_period_s: float | None = None,
    surrogate=None,
) -> np.ndarray:
    """sigma_Z (m/s) of records whose sea is a sum of six-degree-of-freedom bands.

    A band holds wave components travelling at angles ``psi`` to the wind; only two moments
    of their directions enter (module docstring, expanded per band):
    ``s^2 (U^2 <cos^2 psi> - 2 U c Re(R_z) <cos psi> + |R_z|^2 c^2)
    + <cos^2 psi> |L - R_x g / omega^2|^2 u^2``, the moments weighted by the components'
    tilt variance. A single harmonic has ``<cos psi> = cos psi``, ``<cos^2 psi> = cos^2 psi``.

    Parameters
    ----------
    hws_ms : array_like, shape (n,) or scalar
        Mean horizontal wind speed, m/s.
    band_amplitude_deg : array_like, shape (n, nb) or (nb,)
        Lean amplitude of each band along its direction of travel, deg (``sqrt(2)`` times
        the std of the band's total tilt).
    band_period_s : array_like, shape (n, nb) or (nb,)
        Period of each band, s (the rotational part is evaluated within 1-20 s).
    band_cos_psi : array_like, shape (n, nb) or (nb,)
        ``<cos psi>`` (-): the variance-weighted mean cosine of the angle between the
        components' direction of travel and the wind's (downwind): 1 for a wind sea
        running with the wind, 0 across it, -1 against it.
    band_cos_sq_psi : array_like, optional
        ``<cos^2 psi>`` (-), the share of the band's tilt variance along the wind; default
        ``band_cos_psi ** 2`` (single harmonics).
    lever_arm_m : float
        Height of the lidar head above the hull's rotation centre, m.
    hull : str or HullResponse
        The hull's response (:data:`flidar_uq.physics.hull.HULLS`).
    lidar : str or LidarGeometry
        Used for the surrogate and the scan period when they are not given.
    scan_period_s : float, optional
        Duration of one scan (s); default the lidar's.
    surrogate : SigmaZSurrogate, optional
        Rotational sigma_Z of a single-axis tilt along the wind (default the lidar's).

    Returns
    -------
    numpy.ndarray, shape (n,) (or scalar for 1-D bands)
        sigma_Z, m/s; NaN where a band amplitude is outside the surrogate's 0-25 deg.
    """
    from flidar_uq.physics.lidar import get_lidar
    from flidar_uq.physics.surrogate import get_surrogate

    sur = get_surrogate(lidar) if surrogate is None else surrogate
    scan = get_lidar(lidar).scan_period_s if scan_period_s is None else float(scan_period_s)
    amp = np.asarray(band_amplitude_deg, float)
    per = np.asarray(band_period_s, float)
    c1 = np.asarray(band_cos_psi, float)
    c2 = c1**2 if band_cos_sq_psi is None else np.asarray(band_cos_sq_psi, float)
    hws = np.asarray(hws_ms, float)[..., None]
    r_x, r_z = get_hull(hull).relative_responses(per)
    s1 = sur.sigma_z_ms(1.0, amp, np.clip(per, *_PERIOD_RANGE_S))  # per m/s of vertical leak
    c = phase_speed_ms(per)
    leak_sq = s1**2 * (hws**2 * c2 - 2.0 * hws * c * r_z.real * c1 + np.abs(r_z) ** 2 * c**2)
    lever_eff_sq = np.abs(float(lever_arm_m) - r_x * orbital_lever_arm_m(per)) ** 2
    trans_sq = c2 * lever_eff_sq * translation_unit_sq(amp, per, scan)
    var = np.where(amp == 0, 0.0, np.maximum(leak_sq, 0.0) + trans_sq)
    return np.sqrt(np.sum(var, axis=-1))


def six_dof_band_terms(
    hws_ms,
    band_amplitude_deg,
    band_period_s,
    *,
    band_cos_psi,
    band_cos_sq_psi,
    surrogate,
    scan_period_s: float,
    hull="wave_follower",
) -> dict[str, np.ndarray]:
    """The band sum of :func:`six_dof_band_sigma_z_ms` split into the terms of a hull response.

    For a hull whose translation is ``h`` (-) times that of a reference hull of responses
    ``R_x(T), R_z(T)`` (``hull``; the wave follower's are 1: ``h = 0`` rotates about a
    fixed centre, ``h = 1`` follows the waves), a lever arm ``L`` (m) and a motion scale
    ``k`` (-) on the tilt's vertical-wind leak, the band sum is a quadratic form in
    ``(k, k h, L, h)``:

    ``sZ^2 = k^2 (R^2 - 2 h X + h^2 H) + L^2 u2 - 2 L h Y + h^2 O`` with, over bands,
    ``R^2 = sum s^2 U^2 <cos^2 psi>``, ``X = sum s^2 U c Re(R_z) <cos psi>``,
    ``H = sum s^2 |R_z|^2 c^2``, ``u2 = sum <cos^2 psi> u^2``,
    ``Y = sum <cos^2 psi> Re(R_x) (g / omega^2) u^2``,
    ``O = sum <cos^2 psi> |R_x|^2 (g / omega^2)^2 u^2`` (``s = s(A_b, T_b)`` the rotational
    sigma_Z per m/s of vertical leak, ``c = g / omega`` the phase speed, ``u^2`` of
    :func:`translation_unit_sq`; module docstring). With ``h = 1`` it equals
    :func:`six_dof_band_sigma_z_ms` with the same hull, with ``h = 0`` the
    ``rotation_only`` one.

    Parameters
    ----------
    hws_ms : array_like, shape (n,)
        Mean horizontal wind speed, m/s.
    band_amplitude_deg, band_period_s, band_cos_psi, band_cos_sq_psi : array_like, shape (n, nb)
        As :func:`six_dof_band_sigma_z_ms` (deg, s, -, -).
    surrogate : SigmaZSurrogate
        Rotational sigma_Z of a single-axis tilt along the wind (the lidar's).
    scan_period_s : float
        Duration of one scan, s.
    hull : str or HullResponse
        The reference hull whose translation ``h`` scales (:data:`flidar_uq.physics.hull.HULLS`).

    Returns
    -------
    dict
        ``sigma_z_rot_ms`` (``R``, m/s), ``translation_unit_sq`` (``u2``, (m/s)^2 per m^2),
        ``heave_cross_sq`` (``X``), ``heave_leak_sq`` (``H``), ``orbital_sq`` (``O``), all
        (m/s)^2 but ``orbital_cross_sq`` (``Y``, (m/s)^2 per m); arrays of shape (n,), NaN
        where a band amplitude is outside the surrogate's range or a value is missing.
    """
    amp = np.asarray(band_amplitude_deg, float)
    per = np.asarray(band_period_s, float)
    c1 = np.asarray(band_cos_psi, float)
    c2 = np.asarray(band_cos_sq_psi, float)
    hws = np.asarray(hws_ms, float)[..., None]
    per_c = np.clip(per, *_PERIOD_RANGE_S)
    empty = amp == 0
    s1 = np.where(empty, 0.0, surrogate.sigma_z_ms(1.0, np.where(empty, 1.0, amp), per_c))
    s1_sq = s1**2
    c = phase_speed_ms(per)
    r_x, r_z = get_hull(hull).relative_responses(per)
    orb = r_x * orbital_lever_arm_m(per)  # the reference hull's orbital lever arm, m
    u_sq = np.where(empty, 0.0, translation_unit_sq(amp, per, float(scan_period_s)))
    return {
        "sigma_z_rot_ms": np.sqrt(np.sum(s1_sq * hws**2 * c2, axis=-1)),
        "translation_unit_sq": np.sum(c2 * u_sq, axis=-1),
        "heave_cross_sq": np.sum(s1_sq * hws * c * r_z.real * c1, axis=-1),
        "heave_leak_sq": np.sum(s1_sq * np.abs(r_z) ** 2 * c**2, axis=-1),
        "orbital_cross_sq": np.sum(c2 * orb.real * u_sq, axis=-1),
        "orbital_sq": np.sum(c2 * np.abs(orb) ** 2 * u_sq, axis=-1),
    }
