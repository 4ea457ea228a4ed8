"""Platform motion: rotations, 6-DOF harmonic and sampled motion, tilt geometry.

Conventions (docs/conventions.md, binding): ENU earth frame; body -> earth rotation
``R = Rz(yaw) @ Ry(pitch) @ Rx(roll)``; a harmonic is ``A sin(2 pi t / T + phi)``;
the lidar head sits at ``lever_arm_m`` (body frame) from the rotation centre and moves
with ``v = d/dt (R r) + translation`` (= ``omega x R r`` + translation; seed 002
Eqs. 3-4, seed 001 Eqs. 5-6). Surge, sway and heave are displacements along the
earth x (east), y (north) and z (up) axes.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

__all__ = [
    "rotation_matrix",
    "rotation_matrix_derivatives",
    "Harmonic",
    "PlatformMotion",
    "SampledMotion",
    "harmonic_motion",
    "total_tilt_deg",
    "tilted_scan_heights",
]


def _rx(c: np.ndarray, s: np.ndarray) -> np.ndarray:
    o, z = np.ones_like(c), np.zeros_like(c)
    return np.stack(
        [np.stack([o, z, z], -1), np.stack([z, c, -s], -1), np.stack([z, s, c], -1)], -2
    )


def _ry(c: np.ndarray, s: np.ndarray) -> np.ndarray:
    o, z = np.ones_like(c), np.zeros_like(c)
    return np.stack(
        [np.stack([c, z, s], -1), np.stack([z, o, z], -1), np.stack([-s, z, c], -1)], -2
    )


def _rz(c: np.ndarray, s: np.ndarray) -> np.ndarray:
    o, z = np.ones_like(c), np.zeros_like(c)
    return np.stack(
        [np.stack([c, -s, z], -1), np.stack([s, c, z], -1), np.stack([z, z, o], -1)], -2
    )


def rotation_matrix(roll_rad, pitch_rad, yaw_rad=0.0) -> np.ndarray:
    """Body-to-earth rotation ``R = Rz(yaw) @ Ry(pitch) @ Rx(roll)``.

    Right-handed rotations about x (roll), y (pitch) and z (yaw, counter-clockwise seen
    from above); ``v_earth = R @ v_body``. Same order as seed 003 Eq. 1 (``V = Y P R V'``)
    and seed 001 Eq. 6 (after conversion of its x-south, y-west, z-down frame).

    Parameters
    ----------
    roll_rad, pitch_rad, yaw_rad : array_like
        Angles, rad, broadcast together to shape ``(...)``.

    Returns
    -------
    ndarray, shape (..., 3, 3)
    """
    r, p, y = np.broadcast_arrays(
        np.asarray(roll_rad, float), np.asarray(pitch_rad, float), np.asarray(yaw_rad, float)
    )
    return _rz(np.cos(y), np.sin(y)) @ _ry(np.cos(p), np.sin(p)) @ _rx(np.cos(r), np.sin(r))


def rotation_matrix_derivatives(roll_rad, pitch_rad, yaw_rad, roll_rate, pitch_rate, yaw_rate):
    """Time derivative ``dR/dt`` of :func:`rotation_matrix`.

    Parameters
    ----------
    roll_rad, pitch_rad, yaw_rad : array_like
        Angles, rad.
    roll_rate, pitch_rate, yaw_rate : array_like
        Their time derivatives, rad/s.

    Returns
    -------
    ndarray, shape (..., 3, 3)
        ``dR/dt = Rz' Ry Rx yaw_rate + Rz Ry' Rx pitch_rate + Rz Ry Rx' roll_rate``.
    """
    r, p, y, dr, dp, dy = np.broadcast_arrays(
        *(
            np.asarray(a, float)
            for a in (roll_rad, pitch_rad, yaw_rad, roll_rate, pitch_rate, yaw_rate)
        )
    )
    cr, sr, cp, sp, cy, sy = np.cos(r), np.sin(r), np.cos(p), np.sin(p), np.cos(y), np.sin(y)
    rx, ry, rz = _rx(cr, sr), _ry(cp, sp), _rz(cy, sy)
    # d/da of the rotation with (cos a, sin a) is the same matrix with (-sin a, cos a), minus the
    # constant unit entry.
    e = np.zeros(r.shape + (3, 3))
    drx, dry, drz = e.copy(), e.copy(), e.copy()
    drx[..., 1:, 1:] = _rx(-sr, cr)[..., 1:, 1:]
    dry[..., 0::2, 0::2] = _ry(-sp, cp)[..., 0::2, 0::2]
    drz[..., :2, :2] = _rz(-sy, cy)[..., :2, :2]
    return (
        (drz @ ry @ rx) * dy[..., None, None]
        + (rz @ dry @ rx) * dp[..., None, None]
        + (rz @ ry @ drx) * dr[..., None, None]
    )


@dataclass(frozen=True)
class Harmonic:
    """One harmonic component ``amplitude * sin(2 pi t / period_s + phase_rad)``.

    Parameters
    ----------
    amplitude : float
        Amplitude, deg for angles (roll, pitch, yaw) or m for translations.
    period_s : float
        Period, s (> 0).
    phase_rad : float
        Phase at ``t = 0``, rad.
    """

    amplitude: float
    period_s: float
    phase_rad: float = 0.0

    def __post_init__(self) -> None:
        if not (np.isfinite(self.period_s) and self.period_s > 0):
            raise ValueError(f"Harmonic: period_s must be finite and > 0, got {self.period_s!r}")
        if not np.isfinite(self.amplitude):
            raise ValueError(f"Harmonic: amplitude must be finite, got {self.amplitude!r}")

    def value(self, t_s) -> np.ndarray:
        """Value at times ``t_s`` (unit of ``amplitude``)."""
        w = 2.0 * np.pi / self.period_s
        return self.amplitude * np.sin(w * np.asarray(t_s, float) + self.phase_rad)

    def rate(self, t_s) -> np.ndarray:
        """Time derivative at ``t_s`` (unit of ``amplitude`` per s)."""
        w = 2.0 * np.pi / self.period_s
        return self.amplitude * w * np.cos(w * np.asarray(t_s, float) + self.phase_rad)


def _sum(components: tuple[Harmonic, ...], t, attr: str) -> np.ndarray:
    out = np.zeros_like(np.asarray(t, float))
    for h in components:
        out = out + getattr(h, attr)(t)
    return out


class _MotionMethods:
    """Shared methods; subclasses provide ``_state(t)`` returning angles, rates, translation velocity."""

    lever_arm_m: tuple[float, float, float]

    def _state(self, t_s):  # pragma: no cover - abstract
        raise NotImplementedError

    def attitude_rad(self, t_s) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Roll, pitch, yaw at times ``t_s``, rad (arrays shaped like ``t_s``)."""
        ang, _, _ = self._state(t_s)
        return ang

    def rotation(self, t_s) -> np.ndarray:
        """Body-to-earth rotation matrices at ``t_s``, shape ``(..., 3, 3)``."""
        return rotation_matrix(*self.attitude_rad(t_s))

    def head_velocity_ms(self, t_s) -> np.ndarray:
        """Earth-frame velocity of the lidar head, m/s, shape ``(..., 3)``.

        ``v = dR/dt @ r + (surge, sway, heave)'`` with ``r = lever_arm_m`` (seed 002
        Eq. 4 differentiated; ``dR/dt r = omega x (R r)``).
        """
        ang, rates, v_trans = self._state(t_s)
        r = np.asarray(self.lever_arm_m, float)
        if np.any(r != 0):
            v_rot = rotation_matrix_derivatives(*ang, *rates) @ r
        else:
            v_rot = 0.0
        return v_trans + v_rot

    def head_displacement_m(self, t_s) -> np.ndarray:
        """Earth-frame displacement of the lidar head from its rest position, m, ``(..., 3)``."""
        t = np.asarray(t_s, float)
        r = np.asarray(self.lever_arm_m, float)
        return self._translation(t) + rotation_matrix(*self.attitude_rad(t)) @ r - r

    def _translation(self, t_s):  # pragma: no cover - abstract
        raise NotImplementedError


@dataclass(frozen=True)
class PlatformMotion(_MotionMethods):
    """6-DOF platform motion as sums of harmonics.

    Parameters
    ----------
    roll, pitch, yaw : tuple of Harmonic
        Angular components, amplitudes in deg.
    surge, sway, heave : tuple of Harmonic
        Translations along earth x, y, z, amplitudes in m.
    lever_arm_m : tuple of 3 floats
        Lidar head position relative to the rotation centre, body frame, m.
    """

    roll: tuple[Harmonic, ...] = ()
    pitch: tuple[Harmonic, ...] = ()
    yaw: tuple[Harmonic, ...] = ()
    surge: tuple[Harmonic, ...] = ()
    sway: tuple[Harmonic, ...] = ()
    heave: tuple[Harmonic, ...] = ()
    lever_arm_m: tuple[float, float, float] = (0.0, 0.0, 0.0)

    def __post_init__(self) -> None:
        if len(self.lever_arm_m) != 3:
            raise ValueError(
                f"PlatformMotion: lever_arm_m must have 3 entries, got {self.lever_arm_m!r}"
            )
        for name in ("roll", "pitch", "yaw", "surge", "sway", "heave"):
            comps = getattr(self, name)
            if isinstance(comps, Harmonic):
                object.__setattr__(self, name, (comps,))
            elif not all(isinstance(c, Harmonic) for c in comps):
                raise ValueError(
                    f"PlatformMotion: {name} must be a tuple of Harmonic, got {comps!r}"
                )

    def _state(self, t_s):
        t = np.asarray(t_s, float)
        ang = tuple(
            np.deg2rad(_sum(getattr(self, n), t, "value")) for n in ("roll", "pitch", "yaw")
        )
        rates = tuple(
            np.deg2rad(_sum(getattr(self, n), t, "rate")) for n in ("roll", "pitch", "yaw")
        )
        v_trans = np.stack(
            [_sum(getattr(self, n), t, "rate") for n in ("surge", "sway", "heave")], -1
        )
        return ang, rates, v_trans

    def _translation(self, t_s):
        t = np.asarray(t_s, float)
        return np.stack(
            [_sum(getattr(self, n), t, "value") for n in ("surge", "sway", "heave")], -1
        )


def harmonic_motion(
    amplitude_deg: float,
    period_s: float,
    roll_phase_rad: float = 0.0,
    pitch_phase_rad: float = 0.0,
    *,
    lever_arm_m: float | tuple[float, float, float] = 0.0,
) -> PlatformMotion:
    """Seed 000 motion: roll and pitch of equal amplitude and period (Sec. 2.4).

    Parameters
    ----------
    amplitude_deg : float
        Roll and pitch amplitude, deg.
    period_s : float
        Roll and pitch period, s.
    roll_phase_rad, pitch_phase_rad : float
        Phases, rad.
    lever_arm_m : float or tuple of 3 floats
        Head height above the rotation centre (body vector ``(0, 0, h)``), or a vector, m.

    Returns
    -------
    PlatformMotion
    """
    arm = (
        (0.0, 0.0, float(lever_arm_m))
        if np.ndim(lever_arm_m) == 0
        else tuple(map(float, lever_arm_m))
    )
    return PlatformMotion(
        roll=(Harmonic(amplitude_deg, period_s, roll_phase_rad),),
        pitch=(Harmonic(amplitude_deg, period_s, pitch_phase_rad),),
        lever_arm_m=arm,
    )


@dataclass(frozen=True)
class SampledMotion(_MotionMethods):
    """Motion given as sampled series (e.g. an IMU record), linearly interpolated.

    Parameters
    ----------
    time_s : ndarray, shape (m,)
        Strictly increasing sample times, s.
    roll_deg, pitch_deg : ndarray, shape (m,)
        Angles, deg.
    yaw_deg : ndarray, shape (m,), optional
        Yaw, deg (zero if omitted).
    surge_m, sway_m, heave_m : ndarray, shape (m,), optional
        Earth-frame displacements, m (zero if omitted).
    lever_arm_m : tuple of 3 floats
        Lidar head position relative to the rotation centre, body frame, m.

    Notes
    -----
    Rates (for the head velocity) are ``numpy.gradient`` of the series (second-order
    central differences), interpolated linearly. Outside ``time_s`` the series are
    held at their end values (``numpy.interp``).
    """

    time_s: np.ndarray
    roll_deg: np.ndarray
    pitch_deg: np.ndarray
    yaw_deg: np.ndarray | None = None
    surge_m: np.ndarray | None = None
    sway_m: np.ndarray | None = None
    heave_m: np.ndarray | None = None
    lever_arm_m: tuple[float, float, float] = (0.0, 0.0, 0.0)
    _rates: dict = field(default_factory=dict, init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        t = np.asarray(self.time_s, float)
        if t.ndim != 1 or t.size < 2 or not np.all(np.diff(t) > 0):
            raise ValueError("SampledMotion: time_s must be 1-D, strictly increasing, >= 2 samples")
        for name in ("roll_deg", "pitch_deg", "yaw_deg", "surge_m", "sway_m", "heave_m"):
            val = getattr(self, name)
            arr = np.zeros_like(t) if val is None else np.asarray(val, float)
            if arr.shape != t.shape:
                raise ValueError(
                    f"SampledMotion: {name} has shape {arr.shape}, expected {t.shape} like time_s"
                )
            object.__setattr__(self, name, arr)
            self._rates[name] = np.gradient(arr, t)
        object.__setattr__(self, "time_s", t)

    def _interp(self, t, name, rate=False):
        return np.interp(t, self.time_s, self._rates[name] if rate else getattr(self, name))

    def _state(self, t_s):
        t = np.asarray(t_s, float)
        names = ("roll_deg", "pitch_deg", "yaw_deg")
        ang = tuple(np.deg2rad(self._interp(t, n)) for n in names)
        rates = tuple(np.deg2rad(self._interp(t, n, True)) for n in names)
        v_trans = np.stack([self._interp(t, n, True) for n in ("surge_m", "sway_m", "heave_m")], -1)
        return ang, rates, v_trans

    def _translation(self, t_s):
        t = np.asarray(t_s, float)
        return np.stack([self._interp(t, n) for n in ("surge_m", "sway_m", "heave_m")], -1)


def total_tilt_deg(roll_deg, pitch_deg) -> np.ndarray:
    """Total tilt of the body z axis, ``delta = acos(cos(pitch) cos(roll))`` (seed 003 Eq. 8).

    Exact for ``R = Rz Ry Rx``: the earth z component of the body z axis is
    ``cos(pitch) cos(roll)``.

    Parameters
    ----------
    roll_deg, pitch_deg : array_like
        Angles, deg.

    Returns
    -------
    ndarray
        Tilt, deg in [0, 180].
    """
    c = np.cos(np.deg2rad(pitch_deg)) * np.cos(np.deg2rad(roll_deg))
    return np.rad2deg(np.arccos(np.clip(c, -1.0, 1.0)))  # Eq. (8) of seed 003


def tilted_scan_heights(height_m, tilt_deg, half_cone_angle_deg: float = 30.0):
    """Heights of a tilted VAD cone (seed 003 Eqs. 5-7, Table 3).

    Parameters
    ----------
    height_m : array_like
        Target height ``z`` (cone centre height when level), m.
    tilt_deg : array_like
        Total tilt ``delta``, deg.
    half_cone_angle_deg : float
        Half-cone angle, deg (30 in seed 003).

    Returns
    -------
    z_prime_m, z_min_m, z_max_m, dz_m : ndarray
        Height of the cone centre, lowest and highest scanned heights and their
        difference, m. NaN where the lowest beam is not above the lidar
        (``tilt + half cone >= 90 deg``) or the tilt is negative.
    """
    z = np.asarray(height_m, float)
    d = np.deg2rad(np.asarray(tilt_deg, float))
    th = np.deg2rad(half_cone_angle_deg)
    valid = (d >= 0) & (d + th < np.pi / 2)
    z_prime = z * np.cos(d)  # Eq. (5) of seed 003
    z_max = z * np.cos(th - d) / np.cos(th)  # Eq. (6) of seed 003
    z_min = z * np.cos(th + d) / np.cos(th)  # Eq. (7) of seed 003
    out = [np.where(valid, a, np.nan) for a in (z_prime, z_min, z_max, z_max - z_min)]
    return tuple(out)
