"""The buoy's hull in six degrees of freedom: tilt, horizontal orbital motion and heave.

A buoy does not only tilt about a fixed centre: it moves with the water (docs/motion_spectrum.md). For linear deep-water waves (dispersion ``k = omega^2 / g``) a wave
component of surface slope ``S`` along its direction of travel ``xi`` has, at the buoy
(complex amplitudes in the ``exp(+i omega t)`` convention of ``numpy.fft.irfft``):

- elevation ``eta = i S / k``, so heave velocity ``i omega eta = -(omega / k) S``;
- horizontal orbital displacement along ``xi`` ``x = S / k`` (``u = omega eta``, in phase
  with the elevation: forward at a crest);
- tilt: a hull that follows the surface leans along its normal, ``phi = -S`` along ``xi``
  (the head leans towards ``+xi`` on the front face of a wave, where the water rises).

In terms of the lean ``phi`` (rad) along ``xi`` that an IMU measures:

- horizontal head displacement ``(L - R_x g / omega^2) phi`` along ``xi``: the geometric
  lever arm ``L`` (head above the rotation centre) against the orbital motion, an
  *effective lever arm* of about ``-2`` m at a 3-s period, ``-9`` m at 6 s and ``-25`` m at
  10 s for ``L = 0`` (it changes sign against ``L`` and grows with the period squared);
- heave velocity ``R_z c phi``, ``c = g / omega`` the phase speed: in phase with the lean,
  so that the beams see the vertical wind ``(U cos psi - R_z c) phi`` of a mean wind ``U``
  at an angle ``psi`` between the wind's and the wave's directions of travel.

(Yamaguchi & Ishihara 2016, Eqs. 3-4, write the line-of-sight speed with the surge, sway and
heave velocities; the wave kinematics are the linear deep-water relations, e.g. Dean &
Dalrymple 1991, Water Wave Mechanics for Engineers and Scientists, Ch. 4.)

``R_x`` and ``R_z`` are the hull's horizontal and vertical responses relative to its tilt
response (complex, per period): 1 for a wave follower, 0 for a buoy that only rotates. A
real hull responds less than a perfect follower at short periods; each degree of freedom is
modelled here as a linear single-degree-of-freedom oscillator driven by the wave,
``H(T) = 1 / (1 - (T_n / T)^2 + 2 i zeta T_n / T)`` (the response amplitude operator of a
mass-spring-damper, Journee & Massie 2001, Offshore Hydromechanics, Ch. 6): 1 for waves
much longer than the natural period ``T_n``, ``-(T / T_n)^2`` for much shorter ones. The
named hulls' natural periods and damping ratios are illustrative values of their class,
not a hydrodynamic model of a particular hull.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = [
    "G_MS2",
    "HULLS",
    "DofResponse",
    "HullResponse",
    "get_hull",
    "orbital_lever_arm_m",
    "phase_speed_ms",
]

#: standard gravity, m/s^2
G_MS2 = 9.80665


@dataclass(frozen=True)
class DofResponse:
    """Response of one degree of freedom to the wave: a linear oscillator or a constant.

    Parameters
    ----------
    natural_period_s : float or None
        Natural period ``T_n`` (s) of the oscillator; None: the constant ``gain``.
    damping_ratio : float
        Damping ratio ``zeta`` (-), > 0 with a natural period.
    gain : float
        Constant response (-) when ``natural_period_s`` is None: 1 follows the wave, 0
        does not move.
    """

    natural_period_s: float | None = None
    damping_ratio: float = 0.2
    gain: float = 1.0

    def __post_init__(self) -> None:
        if self.natural_period_s is not None and not (
            self.natural_period_s > 0 and self.damping_ratio > 0
        ):
            raise ValueError(
                "DofResponse: natural_period_s and damping_ratio must be > 0, got "
                f"{self.natural_period_s!r}, {self.damping_ratio!r}"
            )

    def rao(self, period_s) -> np.ndarray:
        """Complex response ``H(T)`` (-) at wave periods ``period_s`` (s), array_like."""
        t = np.asarray(period_s, float)
        if self.natural_period_s is None:
            return np.full(t.shape, complex(self.gain))
        r = self.natural_period_s / t
        return 1.0 / (1.0 - r**2 + 2j * self.damping_ratio * r)


@dataclass(frozen=True)
class HullResponse:
    """A hull's responses to the waves in tilt, horizontal (surge/sway) and heave.

    Parameters
    ----------
    name : str
    tilt, horizontal, heave : DofResponse
        Responses of the tilt to the surface slope, of the horizontal displacement to the
        orbital displacement, and of the heave to the elevation.
    description : str
        One line for reports.
    """

    name: str
    tilt: DofResponse
    horizontal: DofResponse
    heave: DofResponse
    description: str = ""

    def relative_responses(self, period_s) -> tuple[np.ndarray, np.ndarray]:
        """``(R_x, R_z)``: horizontal and heave response relative to the tilt's (complex, -).

        The translation of a record follows from its measured tilt through these ratios
        (module docstring). Where the tilt does not respond (``H_tilt = 0``) they are 0.
        """
        h_t = self.tilt.rao(period_s)
        ok = np.abs(h_t) > 0
        safe = np.where(ok, h_t, 1.0)
        r_x = np.where(ok, self.horizontal.rao(period_s) / safe, 0.0)
        r_z = np.where(ok, self.heave.rao(period_s) / safe, 0.0)
        return r_x, r_z


_FOLLOW = DofResponse(gain=1.0)
_STILL = DofResponse(gain=0.0)

#: Named hulls: ``rotation_only`` (tilts about a fixed centre: the motion model of
#: Gutierrez-Antunano et al. 2018), ``wave_follower`` (a small buoy on the surface),
#: ``discus_buoy`` (a large moored discus: follows long waves, less the short ones),
#: ``spar`` (deep draught: natural periods far above the waves', little motion).
HULLS: dict[str, HullResponse] = {
    "rotation_only": HullResponse(
        "rotation_only", _FOLLOW, _STILL, _STILL, "tilts about a fixed centre, no translation"
    ),
    "wave_follower": HullResponse(
        "wave_follower", _FOLLOW, _FOLLOW, _FOLLOW, "follows the surface in tilt and translation"
    ),
    "discus_buoy": HullResponse(
        "discus_buoy",
        DofResponse(natural_period_s=3.5, damping_ratio=0.35),
        DofResponse(natural_period_s=2.5, damping_ratio=0.5),
        DofResponse(natural_period_s=2.0, damping_ratio=0.3),
        "large moored discus buoy: follows waves longer than ~4 s, less the shorter ones",
    ),
    "spar": HullResponse(
        "spar",
        DofResponse(natural_period_s=30.0, damping_ratio=0.1),
        DofResponse(natural_period_s=60.0, damping_ratio=0.2),
        DofResponse(natural_period_s=25.0, damping_ratio=0.1),
        "deep-draught spar: natural periods above the waves', small motion",
    ),
}


def get_hull(name_or_hull: str | HullResponse) -> HullResponse:
    """The named hull of :data:`HULLS` (a :class:`HullResponse` passes through)."""
    if isinstance(name_or_hull, HullResponse):
        return name_or_hull
    try:
        return HULLS[str(name_or_hull)]
    except KeyError:
        known = ", ".join(sorted(HULLS))
        raise ValueError(f"unknown hull {name_or_hull!r}; known hulls: {known}") from None


def phase_speed_ms(period_s) -> np.ndarray:
    """Deep-water phase speed ``c = g / omega = g T / (2 pi)`` (m/s) at periods ``period_s`` (s)."""
    return G_MS2 * np.asarray(period_s, float) / (2.0 * np.pi)


def orbital_lever_arm_m(period_s) -> np.ndarray:
    """``g / omega^2`` (m): the horizontal orbital displacement per radian of lean of a wave
    follower at periods ``period_s`` (s) (2.2 m at 3 s, 8.9 m at 6 s, 24.8 m at 10 s)."""
    w = 2.0 * np.pi / np.asarray(period_s, float)
    return G_MS2 / w**2
