"""Platform motion: rotations, 6-DOF harmonic and sampled motion, tilt geometry.

Conventions (docs/conventions.md, binding): ENU earth frame; body -> earth rotation
``R = Rz(yaw) @ Ry(pitch) @ Rx(roll)``; a harmonic is ``A sin(2 pi t / T + phi)``;
the lidar head sits at ``lever_arm_m`` (body frame) from the rotation centre and moves
with ``v = d/dt (R r) + translation`` (= ``omega x R r`` + translation; Yamaguchi and Ishihara (2016)
Eqs. 3-4, Malekmohammadi et al. (2024), Eqs. 5-6). Surge, sway and heave are displacements along the
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
]


def _trig(roll_rad, pitch_rad, yaw_rad):
    """Cosines and sines ``(cr, sr, cp, sp, cy, sy)`` of the angles (rad).

    Each angle keeps its own shape (they broadcast in the products that use them): a
    yaw constant over a series costs one cosine, not one per sample. NumPy's cosine and
    sine give the same bits for a value whether it stands alone or in an array.
    """
    r, p, y = (np.asarray(a, float) for a in (roll_rad, pitch_rad, yaw_rad))
    return np.cos(r), np.sin(r), np.cos(p), np.sin(p), np.cos(y), np.sin(y)


def _rotation_entries(cr, sr, cp, sp, cy, sy, out=None):
    """The 9 entries of ``Rz(yaw) @ Ry(pitch) @ Rx(roll)``, row-major, in closed form.

    Multiplying out the elementary rotations (docs/conventions.md) entry by entry is
    exact and avoids matrix products of stacked 3x3 arrays (about 3x faster). With
    ``out`` (an array of shape ``(..., 3, 3)``) each entry is computed straight into
    ``out[..., i, j]`` (the same values, without a copy into the stacked layout: ~40 %
    faster for ~24,000 matrices) and the entries returned are views of it. The virtual
    campaign's compiled loop uses the same entries
    (:func:`flidar_uq.campaign.scan_kernel.simulate_chunk_scans`).
    """

    def at(i, j):
        return None if out is None else out[..., i, j]

    spcr, spsr = sp * cr, sp * sr
    return (
        (
            np.multiply(cy, cp, out=at(0, 0)),
            np.subtract(cy * spsr, sy * cr, out=at(0, 1)),
            np.add(cy * spcr, sy * sr, out=at(0, 2)),
        ),
        (
            np.multiply(sy, cp, out=at(1, 0)),
            np.add(sy * spsr, cy * cr, out=at(1, 1)),
            np.subtract(sy * spcr, cy * sr, out=at(1, 2)),
        ),
        (
            np.negative(sp, out=at(2, 0)),
            np.multiply(cp, sr, out=at(2, 1)),
            np.multiply(cp, cr, out=at(2, 2)),
        ),
    )


def _rotate_vector(cr, sr, cp, sp, cy, sy, v):
    """``R @ v`` for a constant body vector ``v`` (3 floats), as 3 arrays.

    Applies ``Rx(roll)``, then ``Ry(pitch)``, then ``Rz(yaw)`` to ``v`` (fewer operations
    than forming the 9 entries of ``R``).
    """
    a1, a2 = cr * v[1] - sr * v[2], sr * v[1] + cr * v[2]  # Rx(roll) v
    b0, b2 = cp * v[0] + sp * a2, cp * a2 - sp * v[0]  # Ry(pitch) Rx v
    return cy * b0 - sy * a1, sy * b0 + cy * a1, b2  # Rz(yaw) Ry Rx v


def _omega(cp, sp, cy, sy, roll_rate, pitch_rate, yaw_rate):
    """Earth-frame angular velocity of ``R = Rz Ry Rx``, rad/s, as 3 arrays.

    ``omega = yaw_rate z + pitch_rate (Rz y) + roll_rate (Rz Ry x)``: each rate turns
    about its axis as carried to the earth frame by the rotations applied after it, so
    that ``dR/dt = [omega]_x R``.
    """
    return (
        roll_rate * cy * cp - pitch_rate * sy,
        roll_rate * sy * cp + pitch_rate * cy,
        yaw_rate - roll_rate * sp,
    )


def _cross(a, b):
    """``a x b`` for vectors given as 3-tuples of arrays; returns a 3-tuple."""
    return (
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    )


def _stack_matrix(rows) -> np.ndarray:
    """3 rows of 3 arrays (broadcast to shape ``(...)``) -> contiguous array ``(..., 3, 3)``."""
    shape = np.broadcast_shapes(*(np.shape(e) for row in rows for e in row))
    out = np.empty(shape + (3, 3))
    for i, row in enumerate(rows):
        for j, e in enumerate(row):
            out[..., i, j] = e
    return out


def rotation_matrix(roll_rad, pitch_rad, yaw_rad=0.0) -> np.ndarray:
    """Body-to-earth rotation ``R = Rz(yaw) @ Ry(pitch) @ Rx(roll)``.

    Right-handed rotations about x (roll), y (pitch) and z (yaw, counter-clockwise seen
    from above); ``v_earth = R @ v_body``. Same order as Nassif et al. (2020), Eq. 1 (``V = Y P R V'``)
    and Malekmohammadi et al. (2024), Eq. 6 (after conversion of its x-south, y-west, z-down frame). The
    product is evaluated entry by entry in closed form.

    Parameters
    ----------
    roll_rad, pitch_rad, yaw_rad : array_like
        Angles, rad, broadcast together to shape ``(...)``.

    Returns
    -------
    ndarray, shape (..., 3, 3)
    """
    trig = _trig(roll_rad, pitch_rad, yaw_rad)
    out = np.empty(np.broadcast_shapes(*(np.shape(a) for a in trig)) + (3, 3))
    _rotation_entries(*trig, out=out)
    return out


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
        ``dR/dt = Rz' Ry Rx yaw_rate + Rz Ry' Rx pitch_rate + Rz Ry Rx' roll_rate``,
        evaluated as ``[omega]_x R`` (column ``j`` is ``omega x R[:, j]``) with the
        earth-frame angular velocity
        ``omega = yaw_rate z + pitch_rate Rz y + roll_rate Rz Ry x``.
    """
    r, p, y, dr, dp, dy = np.broadcast_arrays(
        *(
            np.asarray(a, float)
            for a in (roll_rad, pitch_rad, yaw_rad, roll_rate, pitch_rate, yaw_rate)
        )
    )
    cr, sr, cp, sp, cy, sy = _trig(r, p, y)
    rows = _rotation_entries(cr, sr, cp, sp, cy, sy)
    w = _omega(cp, sp, cy, sy, dr, dp, dy)
    cols = [_cross(w, tuple(row[j] for row in rows)) for j in range(3)]
    return _stack_matrix(tuple(tuple(cols[j][i] for j in range(3)) for i in range(3)))


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

        ``v = dR/dt @ r + (surge, sway, heave)'`` with ``r = lever_arm_m`` (Yamaguchi and Ishihara (2016)
        Eq. 4 differentiated), evaluated as ``omega x (R r)`` with the earth-frame
        angular velocity ``omega = yaw_rate z + pitch_rate Rz y + roll_rate Rz Ry x``.
        """
        ang, rates, v_trans = self._state(t_s)
        r = np.asarray(self.lever_arm_m, float)
        if not np.any(r != 0):
            return v_trans + 0.0
        cr, sr, cp, sp, cy, sy = _trig(*ang)
        rr = _rotate_vector(cr, sr, cp, sp, cy, sy, r)
        v_rot = _cross(_omega(cp, sp, cy, sy, *rates), rr)  # dR/dt r = omega x (R r)
        return v_trans + np.stack(np.broadcast_arrays(*v_rot), -1)

    def head_displacement_m(self, t_s) -> np.ndarray:
        """Earth-frame displacement of the lidar head from its rest position, m, ``(..., 3)``."""
        t = np.asarray(t_s, float)
        r = np.asarray(self.lever_arm_m, float)
        rr = _rotate_vector(*_trig(*self.attitude_rad(t)), r)
        return self._translation(t) + np.stack(np.broadcast_arrays(*rr), -1) - r

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
    """Gutiérrez-Antuñano et al. (2018) motion: roll and pitch of equal amplitude and period (Sec. 2.4).

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


#: The measured translational velocities of :class:`SampledMotion`, east, north, up (m/s).
_VELOCITY_NAMES = ("velocity_east_ms", "velocity_north_ms", "velocity_up_ms")


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
    velocity_east_ms, velocity_north_ms, velocity_up_ms : ndarray, shape (m,), optional
        Measured translational velocity of the rotation centre, m/s, east, north and up
        (ENU earth frame; e.g. from a motion reference unit or GNSS). An axis given here
        takes it for the head velocity, ``v = omega x (R r) + v_trans`` (Yamaguchi and
        Ishihara, 2016, Eq. 4 differentiated), instead of the rate of its displacement.

    Notes
    -----
    Rates (for the head velocity) are ``numpy.gradient`` of the series (second-order
    central differences), interpolated linearly; measured velocities are interpolated
    linearly. Outside ``time_s`` the series are held at their end values
    (``numpy.interp``). A NaN sample gives NaN between its neighbours.
    """

    time_s: np.ndarray
    roll_deg: np.ndarray
    pitch_deg: np.ndarray
    yaw_deg: np.ndarray | None = None
    surge_m: np.ndarray | None = None
    sway_m: np.ndarray | None = None
    heave_m: np.ndarray | None = None
    lever_arm_m: tuple[float, float, float] = (0.0, 0.0, 0.0)
    velocity_east_ms: np.ndarray | None = None
    velocity_north_ms: np.ndarray | None = None
    velocity_up_ms: np.ndarray | None = None
    _rates: dict = field(default_factory=dict, init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        t = np.asarray(self.time_s, float)
        if t.ndim != 1 or t.size < 2 or not np.all(np.diff(t) > 0):
            raise ValueError("SampledMotion: time_s must be 1-D, strictly increasing, >= 2 samples")
        for name in ("roll_deg", "pitch_deg", "yaw_deg", "surge_m", "sway_m", "heave_m"):
            arr = self._checked(name, t, np.zeros_like(t))
            object.__setattr__(self, name, arr)
            self._rates[name] = np.gradient(arr, t)
        # the translation's rate on each axis: measured, else that of the displacement
        for disp, vel in zip(("surge_m", "sway_m", "heave_m"), _VELOCITY_NAMES, strict=True):
            arr = self._checked(vel, t, None)
            object.__setattr__(self, vel, arr)
            if arr is not None:
                self._rates[disp] = arr
        object.__setattr__(self, "time_s", t)

    def _checked(self, name, t, default):
        """The series ``name`` as floats shaped like ``t`` (``default`` if omitted)."""
        val = getattr(self, name)
        if val is None:
            return default
        arr = np.asarray(val, float)
        if arr.shape != t.shape:
            raise ValueError(
                f"SampledMotion: {name} has shape {arr.shape}, expected {t.shape} like time_s"
            )
        return arr

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
