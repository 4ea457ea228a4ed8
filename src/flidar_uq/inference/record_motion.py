"""sigma_Z of each record from its own measured motion (the per-record motion model).

Gutiérrez-Antuñano et al. (2018) computes sigma_Z for harmonic roll and pitch at one period; a real sea is
broadband and directional, and only the tilt along the wind matters to first order
(docs/motion_spectrum.md). With the record's tilt variance along the wind and its
mean period (record-table columns derived by :mod:`flidar_uq.data.imu` from the raw IMU
series), a single-axis tilt of amplitude ``A = sqrt(2) std_along`` along the wind gives
the same sigma_Z as Gutiérrez-Antuñano et al.'s (2018) roll-and-pitch case at amplitude ``A``; evaluated at the
spectral mean period it reproduces the realised sigma_Z of a broadband sea within a few
percent, against 0.6-0.95 for the harmonic value at the spectral-peak period.

When a record has only the core IMU columns (roll and pitch amplitude and period), the
seed's harmonic description is used (``motion_description = "roll_pitch"``); the global
fit's motion-error term then widens the intervals accordingly.

Every lidar's motion error is carried as one per-record Gram matrix (:func:`motion_gram`):
``sigma_Z^2 = v^T G v`` with ``v = (k, k h, L, h)`` (motion scale ``k``, hull response
``h``, lever arm ``L``). A CW VAD lidar's (the ZephIR terms above) and a pulsed DBS
lidar's (:func:`flidar_uq.physics.dbs_sigma_z.dbs_record_terms`) are the same quadratic
form, so the likelihood, the propagation and the SBC need no branch on the lidar.
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from flidar_uq.data.imu import tilt_bands_from_records
from flidar_uq.data.schema import HEAVE_RESPONSE_COLUMN, HORIZONTAL_RESPONSE_COLUMN
from flidar_uq.inference.observations import records_shear_exponent, records_wind_body_deg
from flidar_uq.physics.dbs_sigma_z import hws_error_moments
from flidar_uq.physics.hull import G_MS2, get_hull
from flidar_uq.physics.lidar import get_lidar
from flidar_uq.physics.motion_spectrum import expand_bands
from flidar_uq.physics.seastate import downwind_side_known
from flidar_uq.physics.six_dof_sigma_z import six_dof_band_terms, translation_unit_sq
from flidar_uq.physics.surrogate import default_surrogate, get_surrogate

__all__ = [
    "ALONG_WIND_COLUMNS",
    "band_cos_psi",
    "band_sin_psi",
    "band_sincos_psi",
    "GRAM_COLUMNS",
    "CROSS_WIND_COLUMNS",
    "SAMPLING_COLUMN",
    "RHO_SAMPLING_COLUMNS",
    "DBS_COLUMNS",
    "gram_hws_error_ms",
    "MEASURED_TRANSLATION_COLUMNS",
    "MOTION_DESCRIPTIONS",
    "TRANSLATION_DESCRIPTIONS",
    "describe_motion",
    "gram_coefficients",
    "gram_from_cw_terms",
    "gram_rho_sampling_var",
    "gram_sigma_z_ms",
    "measured_response",
    "motion_gram",
    "per_record_motion",
    "reference_translation_ratio",
]

#: Record-table columns of the along-wind description (tilt std along the wind, deg; its
#: spectral mean period m0/m1, s; the zero-crossing period stands in when the mean period
#: is absent). The mean period is used because the realised sigma_Z of broadband seas lies
#: between the values at the mean and the zero-crossing periods, nearer the former
#: (docs/motion_spectrum.md, docs/inference.md).
ALONG_WIND_COLUMNS = ("tilt_along_wind_std_deg", "tilt_period_mean_s")

#: Values of ``motion_description``: which description gave a record's sigma_Z, best first:
#: ``"tilt_bands"`` the record's tilt spectrum by period bands along and across the wind
#: (``tilt_band{b}_*`` columns: the six-degree-of-freedom band sum,
#: :func:`flidar_uq.physics.six_dof_sigma_z.six_dof_band_terms`), ``"along_wind"`` its
#: moments (std along the wind at the mean period), ``"roll_pitch"`` the harmonic roll and
#: pitch of Gutiérrez-Antuñano et al. (2018).
MOTION_DESCRIPTIONS = ("tilt_bands", "along_wind", "roll_pitch", "none")

#: Values of ``translation_description``: where a record's hull translation comes from,
#: best first. ``"measured"``: the record's MRU or GNSS translation stds
#: (:data:`MEASURED_TRANSLATION_COLUMNS`, :func:`measured_response`) with the reference
#: hull's phases, the hull response known; ``"imu_series"``: the heave (and the horizontal
#: velocity where given) of the record's IMU series against a wave follower's
#: (``heave_response_ratio``, ``horizontal_response_ratio``), likewise;
#: ``"tilt_spectrum"``: the translation the reference hull has with the record's tilt
#: spectrum (:data:`FOLLOWER_COLUMNS`), scaled by the fitted hull response; ``"none"``: the
#: buoy is taken to rotate about a fixed centre (the rotation-only model).
TRANSLATION_DESCRIPTIONS = ("measured", "imu_series", "tilt_spectrum", "none")


def _col(records: pd.DataFrame, name: str) -> np.ndarray:
    if name in records:
        return records[name].to_numpy(dtype=float)
    return np.full(len(records), np.nan)


def _geometric_mean(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Geometric mean of two positive columns; one missing falls back to the other."""
    x = np.stack([np.log(np.where(a > 0, a, np.nan)), np.log(np.where(b > 0, b, np.nan))])
    n = np.sum(np.isfinite(x), axis=0)
    with np.errstate(invalid="ignore"):
        s = np.nansum(np.where(np.isfinite(x), x, 0.0), axis=0) / np.maximum(n, 1)
    return np.where(n > 0, np.exp(s), np.nan)


def _tilt_description(records: pd.DataFrame):
    """Tilt amplitude (deg) and period (s) of each record, and the masks of the along-wind
    and the roll/pitch descriptions (the former wins where both are complete)."""
    std_along = _col(records, ALONG_WIND_COLUMNS[0])
    per_along = _col(records, ALONG_WIND_COLUMNS[1])
    per_along = np.where(
        np.isfinite(per_along), per_along, _col(records, "tilt_period_zero_crossing_s")
    )
    amp_rp = _geometric_mean(
        _col(records, "roll_amplitude_deg"), _col(records, "pitch_amplitude_deg")
    )
    per_rp = _geometric_mean(_col(records, "roll_period_s"), _col(records, "pitch_period_s"))
    along = np.isfinite(std_along) & (std_along >= 0) & np.isfinite(per_along) & (per_along > 0)
    rp = ~along & np.isfinite(amp_rp) & np.isfinite(per_rp)
    amp = np.where(along, np.sqrt(2.0) * std_along, np.where(rp, amp_rp, np.nan))
    per = np.where(along, per_along, np.where(rp, per_rp, np.nan))
    return amp, per, along, rp


#: Harmonics each tilt band of the record table is evaluated as (Gauss-Legendre nodes over
#: the band, weighted by a density shaped by the neighbouring bands,
#: :func:`flidar_uq.physics.motion_spectrum.sub_band_nodes`). Against LOS-level replay the
#: record model's sigma_Z of WindCube records (``benchmarks/dbs_sigma_z.py``, 720 cases) is
#: within 5 % in 95.6 % of the cases with one node a band (0.841-1.051) and in all with
#: three (0.965-1.045); of ZephIR records on broadband, two-peak, misaligned-swell and
#: heaving seas (``benchmarks/six_dof_sigma_z.py``, 54 cases with sigma_Z >= 0.05 m/s)
#: within 3 % in 90.7 % with one (0.935-1.003) and in all with three (0.974-1.004).
BAND_NODES = 3


def _without_hull_phase(measured, period_s, hull) -> np.ndarray:
    """A measured direction moment of heave against tilt with the reference hull's heave
    phase divided out (the hull's response applies it again); as it is for the wave
    follower, whose heave is in phase with its tilt."""
    ref = get_hull(hull)
    if ref.name == "wave_follower" or not np.isfinite(measured).any():
        return measured
    _, r_z = ref.relative_responses(np.clip(period_s, 1.0, 20.0))
    phase = np.cos(np.angle(r_z))
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(np.abs(phase) > 0.1, np.clip(measured / phase, -1.0, 1.0), measured)


def band_cos_psi(bands: dict, hws_ms, use, hull="wave_follower") -> np.ndarray:
    """Each tilt band's signed ``<cos psi>`` (-, + downwind) the record model uses.

    The measured one where the record has it (``tilt_band{b}_cos_psi``,
    :func:`flidar_uq.data.imu.band_direction_from_heave`), else that of waves running
    downwind (:func:`flidar_uq.data.imu.band_direction_moments`) where the band's wave age
    says wind sea (:func:`flidar_uq.physics.seastate.downwind_side_known`), else 0 (a swell
    of unknown side: its mean cosine to the wind is 0 whatever its along-wind share).

    Parameters
    ----------
    bands : dict
        :func:`flidar_uq.data.imu.tilt_bands_from_records` of the records.
    hws_ms : array_like, shape (n,)
        Mean HWS of every record, m/s.
    use : array_like of bool, shape (n,)
        The records wanted.
    hull : str or HullResponse
        The reference hull: where it is not the wave follower, the measured value (which
        holds the cosine of the hull's heave phase against its tilt) is divided by that
        phase's cosine, which the hull's response applies again.

    Returns
    -------
    numpy.ndarray, shape (use.sum(), n_bands)
    """
    hws = np.asarray(hws_ms, float)
    wind_sea = downwind_side_known(bands["period_s"][use], hws[use, None])
    assumed = np.where(wind_sea, bands["cos_psi"][use], 0.0)
    measured = _without_hull_phase(bands["cos_psi_measured"][use], bands["period_s"][use], hull)
    return np.where(np.isfinite(measured), measured, assumed)


def band_sin_psi(bands: dict, use, hull="wave_follower") -> np.ndarray:
    """Each tilt band's signed ``<sin psi>`` (-, + to the left of the wind's direction of
    travel) the record model uses: the measured one where the record has it
    (``tilt_band{b}_sin_psi``, :func:`flidar_uq.data.imu.band_direction_from_heave`; the
    reference hull's heave phase divided out as in :func:`band_cos_psi`), else 0 (either
    side alike). Arguments as :func:`band_cos_psi`; shape (use.sum(), n_bands)."""
    measured = _without_hull_phase(bands["sin_psi_measured"][use], bands["period_s"][use], hull)
    return np.where(np.isfinite(measured), measured, 0.0)


def band_sincos_psi(bands: dict, use) -> np.ndarray:
    """Each tilt band's ``<sin psi cos psi>`` (-) the record model uses: the measured one
    (``tilt_band{b}_sincos_psi``, :func:`flidar_uq.data.imu.band_direction_from_heave`;
    from the tilt alone, so no hull phase to divide out) where the record also has the
    band's side (:func:`band_sin_psi`), else 0 (a spread symmetric about the wind's axes,
    as either side alike makes it). Arguments as :func:`band_cos_psi`; shape
    (use.sum(), n_bands)."""
    measured = bands["sincos_psi_measured"][use]
    side = np.isfinite(bands["sin_psi_measured"][use])
    return np.where(side & np.isfinite(measured), measured, 0.0)


#: Records whose band sums are evaluated at once: bounds the temporaries of the nodes'
#: surrogate evaluations (about 25 kB a record) whatever the table's length.
_BAND_CHUNK = 20_000


def _row_chunks(n: int) -> list[slice]:
    """Consecutive slices of at most :data:`_BAND_CHUNK` of ``n`` rows (none for 0)."""
    return [slice(a, a + _BAND_CHUNK) for a in range(0, n, _BAND_CHUNK)]


def _band_terms(
    records: pd.DataFrame, surrogate, scan_period_s: float, hull="wave_follower", nodes=None
):
    """Mask of the records described by tilt bands (all band values finite, a finite mean
    speed, every band inside the surrogate's range) and their band-sum terms
    (:func:`flidar_uq.physics.six_dof_sigma_z.six_dof_band_terms`, the wave follower's
    translation scaled by the hull response; each band as ``nodes`` harmonics spread over
    it, :data:`BAND_NODES` by default), and the bands themselves
    (:func:`flidar_uq.data.imu.tilt_bands_from_records`, None without band columns); each
    band's ``<cos psi>`` from :func:`band_cos_psi`."""
    bands = tilt_bands_from_records(records)
    if bands is None:
        return np.zeros(len(records), dtype=bool), None, None
    hws = _col(records, "hws_mean_ms")
    use = bands["complete"] & np.isfinite(hws)
    cos1 = band_cos_psi(bands, hws, use, hull)

    def chunk_terms(sel):  # the band sums of the used records ``sel``
        amp, per, c1, c2 = expand_bands(
            bands["amplitude_deg"][use][sel],
            bands["period_s"][use][sel],
            bands["edges_s"],
            cos1[sel],
            bands["cos_sq_psi"][use][sel],
            n_nodes=BAND_NODES if nodes is None else nodes,
        )
        return six_dof_band_terms(
            hws[use][sel],
            amp,
            per,
            band_cos_psi=c1,
            band_cos_sq_psi=c2,
            surrogate=surrogate,
            scan_period_s=scan_period_s,
            hull=hull,
        )

    # no record described: the terms of none (their keys), as a chunk of no rows
    parts = [chunk_terms(sel) for sel in _row_chunks(int(use.sum()))] or [chunk_terms(slice(0))]
    terms = {k: np.concatenate([t[k] for t in parts]) for k in parts[0]}
    finite = np.all(np.stack([np.isfinite(v) for v in terms.values()]), axis=0)
    use[use] = finite
    return use, {k: v[finite] for k, v in terms.items()}, bands


def per_record_motion(
    records: pd.DataFrame, *, surrogate=None, scan_period_s: float = 1.0
) -> pd.DataFrame:
    """Per-record motion amplitude, period, rotational sigma_Z and translation unit.

    Parameters
    ----------
    records : pandas.DataFrame
        Records with ``hws_mean_ms`` and, best first, the tilt-band columns
        (``tilt_band{b}_*``, :func:`flidar_uq.data.imu.tilt_bands_from_records`: the
        six-degree-of-freedom band sum of :mod:`flidar_uq.physics.six_dof_sigma_z`), the
        along-wind columns (:data:`ALONG_WIND_COLUMNS`) or the core IMU columns
        ``roll_amplitude_deg``, ``pitch_amplitude_deg``, ``roll_period_s``,
        ``pitch_period_s``.
    surrogate : SigmaZSurrogate, optional
        sigma_Z surrogate of the lidar (default: the ZephIR 300's).
    scan_period_s : float
        VAD scan duration (s), for the head-translation term.

    Returns
    -------
    pandas.DataFrame
        Index of ``records``; ``motion_amplitude_deg`` (single-axis tilt amplitude along
        the wind, deg), ``motion_period_s`` (s), ``sigma_z_rot_ms`` (rotational sigma_Z at
        unit motion scale, m/s), ``translation_unit_sq`` ((m/s)^2 per m^2 of lever arm,
        :func:`flidar_uq.inference.translation_unit_sq`), ``motion_description`` (one of
        :data:`MOTION_DESCRIPTIONS`; ``"none"`` where neither description is complete:
        sigma_Z is NaN there).
    """
    return _motion_and_bands(records, default_surrogate(surrogate), scan_period_s)[0]


def _motion_and_bands(records: pd.DataFrame, surrogate, scan_period_s: float, nodes=None):
    """:func:`per_record_motion` and the wave follower's band terms it used
    (:func:`_band_terms`, ``nodes`` per band), for :func:`_translation_terms` not to
    compute them again."""
    amp, per, along, rp = _tilt_description(records)
    hws = _col(records, "hws_mean_ms")
    ok = np.isfinite(amp) & np.isfinite(per) & np.isfinite(hws)
    sz = np.full(len(records), np.nan)
    u2 = np.full(len(records), np.nan)
    if np.any(ok):
        sz[ok] = surrogate.sigma_z_ms(hws[ok], amp[ok], per[ok])
        u2[ok] = translation_unit_sq(amp[ok], per[ok], scan_period_s)
    kind = np.where(along & ok, "along_wind", np.where(rp & ok, "roll_pitch", "none"))
    band_terms = _band_terms(records, surrogate, scan_period_s, nodes=nodes)
    banded, terms, bands = band_terms
    if banded.any():
        sz[banded] = terms["sigma_z_rot_ms"]
        u2[banded] = terms["translation_unit_sq"]
        kind = np.where(banded, "tilt_bands", kind)
        # the bands' along-wind amplitude and mean period where the moments are absent
        va = 0.5 * bands["amplitude_deg"] ** 2 * bands["cos_sq_psi"]
        with np.errstate(invalid="ignore", divide="ignore"):
            per_b = np.sum(va, axis=-1) / np.sum(va / bands["period_s"], axis=-1)
        fill = banded & ~ok
        amp = np.where(fill, np.sqrt(2.0 * np.sum(va, axis=-1)), amp)
        per = np.where(fill, per_b, per)
    motion = pd.DataFrame(
        {
            "motion_amplitude_deg": amp,
            "motion_period_s": per,
            "sigma_z_rot_ms": sz,
            "translation_unit_sq": u2,
            "motion_description": kind,
        },
        index=records.index,
    )
    return motion, band_terms


#: Record columns of a wave follower's translation implied by the tilt spectrum
#: (:func:`flidar_uq.data.imu.follower_translation_columns`).
FOLLOWER_COLUMNS = (
    "follower_heave_velocity_std_ms",
    "follower_heave_period_s",
    "follower_velocity_along_wind_std_ms",
    "follower_heave_tilt_correlation",
)


#: Record columns of a measured translation (MRU or GNSS, m/s and m): the velocity stds,
#: else the displacement stds (turned into velocities at the wave follower's heave mean
#: period). Heave positive up, surge and sway along the body x and y axes.
MEASURED_TRANSLATION_COLUMNS = (
    "heave_velocity_std_ms",
    "surge_velocity_std_ms",
    "sway_velocity_std_ms",
    "heave_std_m",
    "surge_std_m",
    "sway_std_m",
)


def measured_response(
    records: pd.DataFrame, *, hull="wave_follower", nodes: int | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """The hull's measured vertical and horizontal responses relative to a reference hull.

    A wave follower with the record's tilt spectrum heaves with the velocity std
    ``sigma_h`` (``follower_heave_velocity_std_ms``) and, deep-water orbital motion being
    circular, moves horizontally with the same total std. A measured translation gives the
    ratios ``R_z = sigma_heave / sigma_h`` and ``R_x = sqrt(sigma_surge^2 + sigma_sway^2) /
    sigma_h`` (velocity stds; a displacement std times ``2 pi / T_h``, ``T_h`` the
    follower's heave mean period). Where the record has no such std of the heave (of the
    horizontal motion), the response its IMU series measured is ``R_z`` (``R_x``):
    ``heave_response_ratio`` (``horizontal_response_ratio``,
    :func:`flidar_uq.data.imu.response_ratio`: the same ratio taken frequency by frequency
    over the tilt bands). With only the heave, or only the horizontal motion, measured
    the other ratio is taken equal to it. For another
    reference hull (``hull``) the ratios are to its translation with the same tilt,
    ``R_z / q_z`` and ``R_x / q_x``
    (:func:`reference_translation_ratio`): the record's translation then keeps the
    reference hull's response per band, phases included, at the measured size. The wave
    follower's phases are right for a hull well above its natural periods (in phase with
    the waves); a large buoy's lag near them.

    Parameters
    ----------
    records : pandas.DataFrame
        Records with :data:`FOLLOWER_COLUMNS` and any of
        :data:`MEASURED_TRANSLATION_COLUMNS` or ``heave_response_ratio`` and
        ``horizontal_response_ratio``.
    hull : str or HullResponse
        The reference hull (:data:`flidar_uq.physics.hull.HULLS`; default the wave
        follower).
    nodes : int, optional
        Harmonics per tilt band (:func:`reference_translation_ratio`).

    Returns
    -------
    (numpy.ndarray, numpy.ndarray)
        ``R_z``, ``R_x`` (-), NaN where the translation is not measured.
    """
    sig_h = _col(records, FOLLOWER_COLUMNS[0])
    omega_h = 2.0 * np.pi / np.clip(_col(records, FOLLOWER_COLUMNS[1]), 1.0, 20.0)

    def velocity(v_col, x_col):
        v = _col(records, v_col)
        return np.where(np.isfinite(v), v, _col(records, x_col) * omega_h)

    heave = velocity("heave_velocity_std_ms", "heave_std_m")
    surge = velocity("surge_velocity_std_ms", "surge_std_m")
    sway = velocity("sway_velocity_std_ms", "sway_std_m")
    horiz = np.sqrt(surge**2 + sway**2)
    with np.errstate(invalid="ignore", divide="ignore"):
        r_z = np.where(sig_h > 0, heave / sig_h, np.nan)
        r_x = np.where(sig_h > 0, horiz / sig_h, np.nan)
    # the IMU series' heave and horizontal velocity against the follower's, frequency by
    # frequency, where the MRU's or the GNSS's std of the same motion is not given
    r_z = np.where(np.isfinite(r_z), r_z, _col(records, HEAVE_RESPONSE_COLUMN))
    r_x = np.where(np.isfinite(r_x), r_x, _col(records, HORIZONTAL_RESPONSE_COLUMN))
    with np.errstate(invalid="ignore", divide="ignore"):
        if get_hull(hull).name != "wave_follower":
            q_z, q_x = reference_translation_ratio(records, hull, nodes=nodes)
            r_z, r_x = r_z / q_z, r_x / q_x
    r_z, r_x = np.where(np.isfinite(r_z), r_z, r_x), np.where(np.isfinite(r_x), r_x, r_z)
    return r_z, r_x


def reference_translation_ratio(
    records: pd.DataFrame, hull, *, nodes: int | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """How much a reference hull translates relative to a wave follower with the same tilt.

    A wave follower whose tilt has the variance ``var_b`` (rad^2) at the period ``T_b``
    heaves and moves horizontally with the velocity variance ``var_b c_b^2`` (``c_b = g /
    omega_b``; :func:`flidar_uq.data.imu.follower_translation_columns`); a hull of relative
    responses ``R_x(T), R_z(T)`` (:meth:`flidar_uq.physics.hull.HullResponse.relative_responses`)
    with ``|R_z(T_b)|^2 var_b c_b^2`` and ``|R_x(T_b)|^2 var_b c_b^2``. Over the record's
    tilt bands (each as ``nodes`` harmonics, :data:`BAND_NODES` by default), else at the
    follower's heave mean period (``follower_heave_period_s``):

    ``q_z = sqrt(sum_b |R_z(T_b)|^2 var_b c_b^2 / sum_b var_b c_b^2)``, ``q_x`` alike.

    A measured translation's ratios to the wave follower (:func:`measured_response`)
    divided by these are its ratios to the reference hull, which then keeps its own
    response per band (phases included) at the measured size.

    Parameters
    ----------
    records : pandas.DataFrame
        Records with the tilt bands (``tilt_band{b}_*``) or ``follower_heave_period_s``.
    hull : str or HullResponse
        The reference hull (:data:`flidar_uq.physics.hull.HULLS`).
    nodes : int, optional
        Harmonics per band.

    Returns
    -------
    (numpy.ndarray, numpy.ndarray)
        ``q_z``, ``q_x`` (-), NaN where neither the bands nor the heave period are given.
    """
    ref = get_hull(hull)
    per_h = _col(records, FOLLOWER_COLUMNS[1])
    fin = np.isfinite(per_h)
    rx, rz = ref.relative_responses(np.clip(np.where(fin, per_h, 1.0), 1.0, 20.0))
    q_z = np.where(fin, np.abs(rz), np.nan)
    q_x = np.where(fin, np.abs(rx), np.nan)
    bands = tilt_bands_from_records(records)
    if bands is not None and bands["complete"].any():
        use = bands["complete"]
        amp, per = expand_bands(
            bands["amplitude_deg"][use],
            bands["period_s"][use],
            bands["edges_s"],
            n_nodes=BAND_NODES if nodes is None else nodes,
        )
        w = amp**2 * per**2  # var_b c_b^2 up to a constant
        rx, rz = ref.relative_responses(per)
        with np.errstate(invalid="ignore", divide="ignore"):
            q_z[use] = np.sqrt(np.sum(w * np.abs(rz) ** 2, axis=-1) / np.sum(w, axis=-1))
            q_x[use] = np.sqrt(np.sum(w * np.abs(rx) ** 2, axis=-1) / np.sum(w, axis=-1))
    return q_z, q_x


def _translation_terms(records, motion, surrogate, scan_period_s, hull, band_terms, nodes=None):
    """Per-record terms of the hull's translation in sigma_Z.

    Where the record's tilt bands are given (``tilt_band{b}_*``), the terms of the
    six-degree-of-freedom band sum itself
    (:func:`flidar_uq.physics.six_dof_sigma_z.six_dof_band_terms`). Else the band sum with
    the record's moments instead of its bands: the tilt's vertical-wind leak ``sZ_rot``
    (:func:`per_record_motion`), the heave's ``hl = Lambda(A, T_h) sqrt(2) sigma_h`` with
    ``Lambda = sZ(1 m/s, A, T) / A`` of the surrogate at the total tilt amplitude and the
    heave's mean period, correlated by ``rho_h``; the orbital velocity along the wind
    ``sigma_u`` against the lever arm's ``L dphi/dt`` (covariance ``-g sigma_along^2`` per
    metre, exact for linear waves). For a hull response ``h`` (0 rotation only, 1 wave
    follower; :func:`gram_sigma_z_ms` of :func:`motion_gram`):

    ``sZ^2 = k^2 (sZ_rot^2 - 2 h heave_cross_sq + h^2 heave_leak_sq)
    + L^2 u^2 - 2 L h orbital_cross_sq + h^2 orbital_sq``.

    Where the record's translation is measured (:func:`measured_response`, its ratios to
    the reference hull's), the reference hull's heave terms are scaled by ``R_z`` (the
    cross term) and ``R_z^2``, the orbital ones by ``R_x`` and ``R_x^2``, and
    ``translation_measured`` is 1: the hull response is known there, ``h = 1`` in
    :func:`gram_sigma_z_ms` and the likelihood.

    Parameters
    ----------
    records : pandas.DataFrame
        Records with the along-wind and :data:`FOLLOWER_COLUMNS` columns.
    motion : pandas.DataFrame
        :func:`per_record_motion` of the same records.
    surrogate
        The sigma_Z surrogate (:func:`default_surrogate`).
    scan_period_s
        As :func:`per_record_motion`.
    hull : str or HullResponse
        The reference hull whose translation the hull response ``h`` scales
        (:data:`flidar_uq.physics.hull.HULLS`). With tilt bands each band takes the hull's response at its period, with moments the response at
        the heave's mean period; a measured translation sets its size.
    band_terms
        :func:`_band_terms` of the same records.
    nodes : int, optional
        Harmonics per tilt band (as :func:`_band_terms`).

    Returns
    -------
    pandas.DataFrame
        ``heave_cross_sq``, ``heave_leak_sq`` ((m/s)^2), ``orbital_cross_sq`` ((m/s)^2 per
        m of lever arm), ``orbital_sq`` ((m/s)^2); 0 where the follower columns are absent
        (the rotation-only model); ``translation_measured`` (1 or 0, -).
    """
    sig_h, per_h, sig_u, rho_h = (_col(records, c) for c in FOLLOWER_COLUMNS)
    follower = _follower_complete(records)
    std_a = _col(records, ALONG_WIND_COLUMNS[0])
    std_c = _col(records, "tilt_across_wind_std_deg")
    per_m = motion["motion_period_s"].to_numpy(dtype=float)
    sz_rot = motion["sigma_z_rot_ms"].to_numpy(dtype=float)
    amp_tot = np.sqrt(2.0 * (std_a**2 + np.nan_to_num(std_c) ** 2))
    ok = follower & np.isfinite(amp_tot) & (amp_tot > 0) & np.isfinite(sz_rot) & np.isfinite(per_m)
    out = {k: np.zeros(len(records)) for k in ("heave_cross_sq", "heave_leak_sq")}
    out |= {k: np.zeros(len(records)) for k in ("orbital_cross_sq", "orbital_sq")}
    if np.any(ok):
        a, th = amp_tot[ok], np.clip(per_h[ok], 1.0, 20.0)
        lam = surrogate.sigma_z_ms(1.0, a, th) / np.deg2rad(a)  # per m/s of vertical wind, per rad
        hl = lam * np.sqrt(2.0) * sig_h[ok]
        out["heave_cross_sq"][ok] = rho_h[ok] * sz_rot[ok] * hl
        out["heave_leak_sq"][ok] = hl**2
        sinc_m = np.sinc(scan_period_s / per_m[ok])
        sinc_h = np.sinc(scan_period_s / th)
        out["orbital_cross_sq"][ok] = G_MS2 * np.deg2rad(std_a[ok]) ** 2 * sinc_m**2
        out["orbital_sq"][ok] = (sig_u[ok] * sinc_h) ** 2
    banded, bt, _ = band_terms
    if banded.any():  # the band sum where the record's tilt bands are given
        ok = ok | banded
        for key in ("heave_cross_sq", "heave_leak_sq", "orbital_cross_sq", "orbital_sq"):
            out[key][banded] = bt[key]
    ref = get_hull(hull)
    # a measured translation relative to the reference hull's with the same tilt
    r_z, r_x = measured_response(records, hull=ref, nodes=nodes)
    meas = ok & np.isfinite(r_z) & np.isfinite(r_x)
    if ref.name != "wave_follower":  # the reference hull's response, each band's own
        sel = ok & ~banded  # moments: the responses at the heave's mean period
        if np.any(sel):
            rx, rz = ref.relative_responses(np.clip(per_h[sel], 1.0, 20.0))
            out["heave_cross_sq"][sel] *= rz.real
            out["heave_leak_sq"][sel] *= np.abs(rz) ** 2
            out["orbital_cross_sq"][sel] *= rx.real
            out["orbital_sq"][sel] *= np.abs(rx) ** 2
        sel = np.flatnonzero(banded)
        if sel.size:  # bands: each band's own response
            hb, ht, _ = _band_terms(
                records.iloc[sel], surrogate, scan_period_s, hull=ref, nodes=nodes
            )
            for key in ("heave_cross_sq", "heave_leak_sq", "orbital_cross_sq", "orbital_sq"):
                out[key][sel[hb]] = ht[key]
    out["heave_cross_sq"][meas] *= r_z[meas]
    out["heave_leak_sq"][meas] *= r_z[meas] ** 2
    out["orbital_cross_sq"][meas] *= r_x[meas]
    out["orbital_sq"][meas] *= r_x[meas] ** 2
    out["translation_measured"] = meas.astype(float)
    return pd.DataFrame(out, index=records.index)


def _follower_complete(records: pd.DataFrame) -> np.ndarray:
    """Records whose :data:`FOLLOWER_COLUMNS` are all finite."""
    ok = np.ones(len(records), dtype=bool)
    for c in FOLLOWER_COLUMNS:
        ok &= np.isfinite(_col(records, c))
    return ok


def describe_motion(
    records: pd.DataFrame, *, hull_model: str | None = None, lidar=None
) -> pd.DataFrame:
    """Which motion description each record gets in the record model, without evaluating it.

    Parameters
    ----------
    records : pandas.DataFrame
        Record table (the columns :func:`motion_gram` reads).
    hull_model : str, optional
        The fit's kept hull model (``GlobalFit.info["hull_model"]``): ``"rotation_only"``
        describes no record's translation, whatever its columns.
    lidar : str, LidarGeometry or mapping, optional
        The floating lidar (config ``campaign.lidar``; default the ZephIR 300). A DBS
        lidar's tilt is its tilt bands where complete, else its roll and pitch
        (:func:`motion_gram`).

    Returns
    -------
    pandas.DataFrame
        Index of ``records``; ``motion_description`` (the tilt's, one of
        :data:`MOTION_DESCRIPTIONS`, as :func:`motion_gram` gives it) and
        ``translation_description`` (one of :data:`TRANSLATION_DESCRIPTIONS`;
        ``"tilt_spectrum"`` only where the tilt is described along the wind (by bands or
        moments), or for a DBS lidar by its bands or its roll and pitch with the follower
        columns; ``"measured"`` from the MRU's or GNSS's stds, ``"imu_series"`` from the IMU
        series' velocities, :func:`measured_response`); ``wave_direction_description``: for tilt
        bands with a translation, ``"measured"`` where the record has the bands' directions of
        travel from the heave (``tilt_band{b}_cos_psi``), else ``"assumed"``
        (:func:`band_cos_psi`); ``""`` where they do not enter.
    """
    amp, per, along, rp = _tilt_description(records)
    hws_ok = np.isfinite(_col(records, "hws_mean_ms"))
    bands = tilt_bands_from_records(records)
    if _is_dbs(lidar):
        ok = _dbs_motion(records)[-1] & hws_ok
        banded = _dbs_banded(records, _col(records, "hws_mean_ms"))[0]
        tilt = np.where(banded, "tilt_bands", np.where(ok, "roll_pitch", "none"))
        follower = banded | (ok & _follower_complete(records))
    else:
        ok = np.isfinite(amp) & np.isfinite(per) & hws_ok
        tilt = np.where(along & ok, "along_wind", np.where(rp & ok, "roll_pitch", "none"))
        follower = along & ok & _follower_complete(records)
        if bands is not None:
            banded = bands["complete"] & hws_ok
            tilt = np.where(banded, "tilt_bands", tilt)
            follower = follower | banded
    r_z, r_x = measured_response(records)
    measured = follower & np.isfinite(r_z) & np.isfinite(r_x)
    series = [HEAVE_RESPONSE_COLUMN, HORIZONTAL_RESPONSE_COLUMN]
    stds = np.isfinite(measured_response(records.drop(columns=series, errors="ignore"))[0])
    trans = np.where(
        measured,
        np.where(stds, "measured", "imu_series"),
        np.where(follower, "tilt_spectrum", "none"),
    )
    if hull_model == "rotation_only":
        trans = np.full(len(records), "none")
    on_bands = (tilt == "tilt_bands") & (trans != "none")
    heave = (
        np.isfinite(bands["cos_psi_measured"]).any(axis=-1)
        if bands is not None
        else np.zeros(len(records), bool)
    )
    directions = np.where(on_bands, np.where(heave, "measured", "assumed"), "")
    return pd.DataFrame(
        {
            "motion_description": tilt,
            "translation_description": trans,
            "wave_direction_description": directions,
        },
        index=records.index,
    )


#: The 10 unique entries of a record's Gram matrix ``G`` (:func:`motion_gram`), upper
#: triangle row by row in the basis ``v = (k, k h, L, h)``: ``sigma_Z^2 = sum_ii G_ii v_i^2
#: + 2 sum_i<j G_ij v_i v_j``. Units: (m/s)^2 for the entries without ``L``
#: (``gram_kk, gram_k_kh, gram_k_h, gram_kh_kh, gram_kh_h, gram_hh``), (m/s)^2 per m for
#: those with one (``gram_k_l, gram_kh_l, gram_l_h``), (m/s)^2 per m^2 for ``gram_ll``.
GRAM_COLUMNS = (
    "gram_kk",
    "gram_k_kh",
    "gram_k_l",
    "gram_k_h",
    "gram_kh_kh",
    "gram_kh_l",
    "gram_kh_h",
    "gram_ll",
    "gram_l_h",
    "gram_hh",
)
#: A DBS lidar's further columns (:func:`motion_gram`): the Gram entries of its cross-wind
#: error (``gram_across_*``) and of the along-/cross-wind covariance (``gram_cov_*``), same
#: units as :data:`GRAM_COLUMNS`, and ``gram_inv_hws_sq``, ``1 / U^2`` (s^2/m^2): sigma_Z
#: and the mean of Z to fourth order (:func:`flidar_uq.physics.dbs_sigma_z.hws_error_moments`).
CROSS_WIND_COLUMNS = (
    *(c.replace("gram_", "gram_across_") for c in GRAM_COLUMNS),
    *(c.replace("gram_", "gram_cov_") for c in GRAM_COLUMNS),
    "gram_inv_hws_sq",
)
#: A DBS lidar's record: the variance (-) of ``log sigma_Z`` of the record's realised motion
#: error about the model's from its retrieval once an output interval
#: (:func:`flidar_uq.physics.dbs_sigma_z.cycle_sampling_rel_var` / 4, at
#: :attr:`~flidar_uq.physics.lidar.LidarGeometry.output_interval_s`): it adds to
#: ``kappa_z^2`` in the record fit and the propagation. 0 for a record without tilt bands,
#: or whose bands stay below half the output rate (a wind after every beam).
SAMPLING_COLUMN = "sigma_z_sampling_log_var"
#: A DBS lidar's record: the along-wind Gram matrix's entries (as :data:`GRAM_COLUMNS`) with
#: each of the output's lines weighted by the variance (-) it gives the record's realised
#: correlation of the motion error with the turbulence
#: (:func:`flidar_uq.physics.dbs_sigma_z.output_correlation_line_weights`): the scatter of
#: that correlation about the campaign's is ``v^T G_rho v / v^T G v``
#: (:func:`gram_rho_sampling_var`) for the fit's motion scale, hull response and lever arm,
#: whose terms put the error at lines of their own. It adds to ``(rho_sd (1 - rho^2))^2``
#: in the record fit and the propagation. 0 for a record without tilt bands.
RHO_SAMPLING_COLUMNS = tuple(c.replace("gram_", "gram_rho_sampling_") for c in GRAM_COLUMNS)
#: A DBS lidar's columns beside :data:`GRAM_COLUMNS`, in :func:`motion_gram`'s order.
DBS_COLUMNS = (*CROSS_WIND_COLUMNS, SAMPLING_COLUMN, *RHO_SAMPLING_COLUMNS)
_GRAM_IJ = tuple((i, j) for i in range(4) for j in range(i, 4))
#: entries of GRAM_COLUMNS that carry the hull response (a row or column 1 or 3)
_HULL_ENTRIES = tuple(n for n, (i, j) in enumerate(_GRAM_IJ) if {i, j} & {1, 3})


def gram_from_cw_terms(
    sigma_z_rot_ms,
    translation_unit_sq,
    heave_cross_sq=0.0,
    heave_leak_sq=0.0,
    orbital_cross_sq=0.0,
    orbital_sq=0.0,
) -> np.ndarray:
    """The Gram entries (:data:`GRAM_COLUMNS`, shape (10, n)) of a CW VAD lidar's terms.

    ``sZ^2 = k^2 sZ_rot^2 - 2 k^2 h X + k^2 h^2 H + L^2 u^2 - 2 L h Y + h^2 O``
    (:func:`_translation_terms`) is ``v^T G v`` with ``G_kk = sZ_rot^2`` (m/s)^2,
    ``G_k,kh = -X``, ``G_kh,kh = H``, ``G_ll = u^2`` ((m/s)^2 per m^2), ``G_l,h = -Y``
    ((m/s)^2 per m), ``G_hh = O`` ((m/s)^2), the others 0. Arguments as
    :func:`per_record_motion` and :func:`_translation_terms` return them (scalars broadcast).
    """
    sz = np.asarray(sigma_z_rot_ms, float)
    u2, x, h_, y, o = np.broadcast_arrays(
        translation_unit_sq, heave_cross_sq, heave_leak_sq, orbital_cross_sq, orbital_sq, sz
    )[:5]
    out = np.zeros((10,) + sz.shape)
    out[0], out[1], out[4] = sz**2, -np.asarray(x, float), h_
    out[7], out[8], out[9] = u2, -np.asarray(y, float), o
    return out


def _gram_entries(gram4: np.ndarray) -> np.ndarray:
    """(10, n) entries of :data:`GRAM_COLUMNS` from Gram matrices (n, 4, 4); (30, n) of
    the along-wind, cross-wind and covariance parts from (n, 3, 4, 4)."""
    if gram4.ndim == 4:
        return np.concatenate([_gram_entries(gram4[:, p]) for p in range(gram4.shape[1])])
    return np.stack([gram4[..., i, j] for i, j in _GRAM_IJ])


def _is_dbs(lidar) -> bool:
    return lidar is not None and get_lidar(lidar).kind == "dbs"


def _dbs_motion(records: pd.DataFrame):
    """Roll and pitch amplitudes (deg) and periods (s) of each record (the core IMU
    columns), and the mask of records where all four are finite."""
    cols = [
        _col(records, c)
        for c in ("roll_amplitude_deg", "pitch_amplitude_deg", "roll_period_s", "pitch_period_s")
    ]
    ok = np.ones(len(records), dtype=bool)
    for c in cols:
        ok &= np.isfinite(c)
    ok &= (cols[2] > 0) & (cols[3] > 0)
    return (*cols, ok)


def _dbs_banded(records: pd.DataFrame, hws_ms):
    """Records a DBS lidar's record model describes by their tilt bands (every band value
    and the mean speed finite), and the bands (:func:`tilt_bands_from_records`)."""
    bands = tilt_bands_from_records(records)
    if bands is None:
        return np.zeros(len(records), dtype=bool), None
    return bands["complete"] & np.isfinite(np.asarray(hws_ms, float)), bands


def _rho_sampling_gram(lines_along, frequency_hz, width_hz, lidar, hws_ms, length_scale_m):
    """(10, n) entries of :data:`RHO_SAMPLING_COLUMNS`: the along-wind Gram matrices of the
    output's lines of each band node (S, n, nodes, 4, 4), the nodes at ``frequency_hz``
    (n, nodes) and ``width_hz`` wide, weighted by
    :func:`flidar_uq.physics.dbs_sigma_z.output_correlation_line_weights` at the records'
    mean HWS (m/s) and Kaimal length scale of ``u`` (m)."""
    from flidar_uq.physics.dbs_sigma_z import (
        output_correlation_line_weights,
        window_line_frequencies_hz,
    )

    weight = output_correlation_line_weights(
        window_line_frequencies_hz(frequency_hz, lidar),
        width_hz,
        hws_ms=hws_ms,
        length_scale_m=length_scale_m,
    )  # (S, n, nodes)
    return _gram_entries(np.einsum("sncij,snc->nij", lines_along, weight))


def _dbs_gram(records, g, n_headings, translation, nodes):
    """(42, n) Gram entries (:data:`GRAM_COLUMNS` and :data:`DBS_COLUMNS`), measured flag
    and description of a DBS lidar (:func:`motion_gram`)."""
    from flidar_uq.physics.dbs_sigma_z import (
        band_moments_to_wind,
        cycle_sampling_rel_var,
        dbs_band_terms,
        dbs_record_terms,
    )
    from flidar_uq.physics.turbulence import kaimal_length_scales_m

    a_r, a_p, t_r, t_p, ok = _dbs_motion(records)
    hws = _col(records, "hws_mean_ms")
    ok &= np.isfinite(hws)
    banded, bands = _dbs_banded(records, hws)
    beta = records_wind_body_deg(records)
    known = np.isfinite(beta)
    shear = records_shear_exponent(records)
    r_z, r_x = measured_response(records)
    # the turbulence's Kaimal length scale at the record's height (without heights: above
    # 60 m, IEC 61400-1's Lambda_1 = 42 m)
    length_u = kaimal_length_scales_m(_col(records, "height_m"))[:, 0]
    length_u = np.where(np.isfinite(length_u), length_u, kaimal_length_scales_m(60.0)[0])
    out = np.full((32 + len(RHO_SAMPLING_COLUMNS), len(records)), np.nan)
    if np.any(banded):
        mom = band_moments_to_wind(
            band_cos_psi(bands, hws, banded),
            bands["cos_sq_psi"][banded],
            band_sin_psi(bands, banded),
            band_sincos_psi(bands, banded),
        )
        # each band as three harmonics spread over it (a DBS lidar's beam-time phases and
        # a heave that cancels the tilt's vertical wind change across a band)
        amp, per, mom = expand_bands(
            bands["amplitude_deg"][banded],
            bands["period_s"][banded],
            bands["edges_s"],
            mom,
            n_nodes=nodes,
        )
        # the sampling of the motion error once an output interval: each node's share of
        # Var Z (its own Gram matrix) at the truth's scale (k = 1), the hull's translation as
        # described (a wave follower's, scaled by a measured response) and no lever arm,
        # spread over its share of its band's frequencies
        edges_hz = 1.0 / np.asarray(bands["edges_s"], float)
        width_hz = np.repeat(np.abs(np.diff(edges_hz)) / nodes, nodes)
        h = float(translation)
        coef = np.stack(
            [
                np.ones(len(records)),
                np.where(np.isfinite(r_z), r_z, 1.0) * h,
                np.zeros(len(records)),
                np.where(np.isfinite(r_x), r_x, 1.0) * h,
            ],
            -1,
        )
        for sel, wb in ((known[banded], beta[banded]), (~known[banded], None)):
            idx = np.flatnonzero(sel)
            for part in _row_chunks(idx.size):
                i = idx[part]
                rows = np.flatnonzero(banded)[i]
                lines = dbs_band_terms(
                    hws[rows],
                    amp[i],
                    per[i],
                    mom[i],
                    wind_body_deg=None if wb is None else wb[i],
                    lidar=g,
                    n_headings=n_headings,
                    cross_wind=True,
                    shear_exponent=shear[rows],
                    per_band=True,
                    window_lines=True,
                )  # (S, n, 3, nodes, 4, 4): the output's lines of each node
                per_node = lines.sum(axis=0)
                out[:30, rows] = _gram_entries(per_node.sum(axis=2))
                power = np.einsum("ni,sncij,nj->snc", coef[rows], lines[:, :, 0], coef[rows])
                # Var(log sigma_Z) = Var(Var Z / E Var Z) / 4 to first order
                out[31, rows] = 0.25 * cycle_sampling_rel_var(
                    1.0 / per[i], power.sum(axis=0), width_hz, cycle_s=g.output_interval_s
                )
                out[32:, rows] = _rho_sampling_gram(
                    lines[:, :, 0], 1.0 / per[i], width_hz, g, hws[rows], length_u[rows]
                )
    rp = ok & ~banded
    for sel, wb in ((rp & known, beta), (rp & ~known, None)):
        if np.any(sel):
            out[:30, sel] = _gram_entries(
                dbs_record_terms(
                    hws[sel],
                    a_r[sel],
                    a_p[sel],
                    t_p[sel],
                    wind_body_deg=None if wb is None else wb[sel],
                    roll_period_s=t_r[sel],
                    lidar=g,
                    n_headings=n_headings,
                    cross_wind=True,
                    shear_exponent=shear[sel],
                )
            )
    ok |= banded
    with np.errstate(divide="ignore"):
        out[30, ok] = 1.0 / hws[ok] ** 2
    out[31:, ok & ~banded] = 0.0  # a harmonic's spread is not known without the bands
    # a record described by its tilt bands has the wave follower's translation through them
    follower = ok & (_follower_complete(records) | banded) & translation
    parts = (0, 10, 20, 32)  # the Gram matrices: along, across, covariance, rho sampling
    hull = [n + part for part in parts for n in _HULL_ENTRIES]
    out[np.ix_(hull, ok & ~follower)] = 0.0  # rotation only: no heave, no orbital motion
    meas = follower & np.isfinite(r_z) & np.isfinite(r_x)
    if np.any(meas):  # the heave phasor scales with R_z, the orbital one with R_x
        scale = np.stack([np.ones(len(records)), r_z, np.ones(len(records)), r_x])
        for n, (i, j) in enumerate(_GRAM_IJ):
            for part in parts:
                out[n + part, meas] *= scale[i, meas] * scale[j, meas]
    return out, meas, np.where(banded, "tilt_bands", np.where(ok, "roll_pitch", "none"))


def motion_gram(
    records: pd.DataFrame,
    *,
    lidar=None,
    surrogate=None,
    scan_period_s: float | None = None,
    n_headings: int = 24,
    translation: bool = True,
    hull="wave_follower",
    band_nodes: int = BAND_NODES,
) -> pd.DataFrame:
    """Each record's motion error as the Gram matrix of ``v = (k, k h, L, h)``.

    ``sigma_Z^2 = v^T G v`` for a motion scale ``k`` (-), a hull response ``h`` (-: 0 rotates
    about a fixed centre, 1 follows the waves) and a lever arm ``L`` (m)
    (:func:`gram_sigma_z_ms`).

    * A CW VAD lidar (the ZephIR 300): :func:`per_record_motion` and :func:`_translation_terms`
      (Gutiérrez-Antuñano et al. 2018 and the six-degree-of-freedom terms) through
      :func:`gram_from_cw_terms`: the same sigma_Z as those terms. A conical scan is
      azimuth symmetric: the heading does not enter.
    * A pulsed DBS lidar (``kind == "dbs"``): the beam-pair retrieval of Yamaguchi &
      Ishihara 2016, Eqs. 3-4, with the record's tilt bands where complete
      (:func:`flidar_uq.physics.dbs_sigma_z.dbs_band_terms`: each band's amplitude,
      period and direction moments relative to the wind, its signed ``<cos psi>`` from
      :func:`band_cos_psi`), else its roll and pitch amplitudes and periods
      (:func:`flidar_uq.physics.dbs_sigma_z.dbs_record_terms`, the core IMU columns; the
      along-wind description drops the cross-wind tilt, whose heave and translation a DBS
      lidar sees), the lidar's own beam timing and the wind's direction relative to the
      beams,
      ``wind_to_body_deg(wd_mean_deg, heading_mean_deg)`` (the heading column is the yaw of
      docs/conventions.md, the convention ``wind_to_body_deg`` takes). Where the heading or
      the wind direction is NaN or absent: averaged over ``n_headings`` headings. The
      hull's heave and orbital phasors are those of a wave follower with the record's
      bands, or its roll and pitch where the record has the follower columns
      (:data:`FOLLOWER_COLUMNS`, as for a CW lidar; else rotation only). A measured
      translation (:func:`measured_response`) scales the heave phasor by ``R_z`` and the
      orbital one by ``R_x``, with ``h = 1`` (``translation_measured``), as for a CW lidar.

    Parameters
    ----------
    records : pandas.DataFrame
        Record table (``hws_mean_ms``, the motion columns; for a DBS lidar ``wd_mean_deg``
        (deg, from, clockwise from north) and ``heading_mean_deg`` (deg) when known).
    lidar : str, LidarGeometry or mapping, optional
        The floating lidar (config ``campaign.lidar``: a name or a custom block); default
        the ZephIR 300.
    surrogate : SigmaZSurrogate, optional
        A CW lidar's sigma_Z surrogate (default: ``get_surrogate(lidar)``).
    scan_period_s : float, optional
        A CW lidar's scan duration (s), for the head-translation terms; default the
        lidar's ``scan_period_s``. A DBS lidar uses its own beam timing.
    n_headings : int
        Headings averaged over where the heading is unknown (DBS only).
    translation : bool
        False: the hull's translation left out (the ``"rotation_only"`` hull model).
    hull : str or HullResponse
        A CW lidar's reference hull, whose translation ``h`` scales (:func:`_translation_terms`);
        a DBS lidar's is the wave follower.
    band_nodes : int
        Harmonics each tilt band is evaluated as, spread over the band
        (:func:`flidar_uq.physics.motion_spectrum.sub_band_nodes`); 1: each band at its
        centroid period alone.

    Returns
    -------
    pandas.DataFrame
        Index of ``records``; :data:`GRAM_COLUMNS` (units there; NaN where the record has
        no motion description; a DBS lidar's also :data:`DBS_COLUMNS`),
        ``translation_measured`` (1 or 0, -) and
        ``motion_description`` (:data:`MOTION_DESCRIPTIONS`).
    """
    g = get_lidar("zephir300" if lidar is None else lidar)
    if g.kind == "dbs":
        gram, meas, kind = _dbs_gram(records, g, n_headings, translation, band_nodes)
    else:
        sur = get_surrogate(g) if surrogate is None and lidar is not None else surrogate
        scan = g.scan_period_s if scan_period_s is None else float(scan_period_s)
        sur = default_surrogate(sur)
        mot, band_terms = _motion_and_bands(records, sur, scan, band_nodes)
        terms = _translation_terms(records, mot, sur, scan, hull, band_terms, band_nodes)
        if not translation:
            terms = terms * 0.0
        gram = gram_from_cw_terms(
            mot["sigma_z_rot_ms"].to_numpy(),
            mot["translation_unit_sq"].to_numpy(),
            *(terms[c].to_numpy() for c in terms.columns[:4]),
        )
        meas, kind = terms["translation_measured"].to_numpy() > 0, mot["motion_description"]
    names = GRAM_COLUMNS if len(gram) == len(GRAM_COLUMNS) else (*GRAM_COLUMNS, *DBS_COLUMNS)
    out = pd.DataFrame(dict(zip(names, gram, strict=True)), index=records.index)
    out["translation_measured"] = np.asarray(meas, float)
    out["motion_description"] = np.asarray(kind)
    return out


def gram_coefficients(motion_scale, hull_response, lever_arm_m):
    """Weights of :data:`GRAM_COLUMNS` in ``sigma_Z^2`` (the off-diagonal entries twice):
    shape ``(..., 10)`` for arrays ``k`` (-), ``h`` (-), ``L`` (m) broadcast together."""
    k, h, lev = np.broadcast_arrays(
        np.asarray(motion_scale, float), np.asarray(hull_response, float), lever_arm_m
    )
    v = (k, k * h, np.asarray(lev, float), h)
    return np.stack([v[i] * v[j] * (1.0 if i == j else 2.0) for i, j in _GRAM_IJ], -1)


def _form(gram, lever_arm_m, hull_response, motion_scale):
    """``columns -> v^T G v`` of the Gram part in ``columns`` (in :data:`GRAM_COLUMNS`'s
    order) of ``gram`` (:func:`gram_sigma_z_ms`), ``h = 1`` where the translation is
    measured."""
    h = np.asarray(hull_response, float)
    if "translation_measured" in gram:  # measured translation: the response is known
        meas = np.asarray(gram["translation_measured"], float)
        h = h + meas * (1.0 - h)
    coef = gram_coefficients(motion_scale, h, np.asarray(lever_arm_m, float))

    def form(columns):
        var = 0.0
        for n, c in enumerate(columns):
            var = var + coef[..., n] * np.asarray(gram[c], float)
        return var

    return form


def _quadratic_forms(gram, lever_arm_m, hull_response, motion_scale):
    """``v^T G v`` of each Gram part of ``gram`` (:func:`gram_sigma_z_ms`): the along-wind
    one, and with :data:`CROSS_WIND_COLUMNS` the cross-wind and covariance ones (else None)."""
    form = _form(gram, lever_arm_m, hull_response, motion_scale)
    if CROSS_WIND_COLUMNS[0] not in gram:
        return form(GRAM_COLUMNS), None, None
    return form(GRAM_COLUMNS), form(CROSS_WIND_COLUMNS[:10]), form(CROSS_WIND_COLUMNS[10:20])


def gram_rho_sampling_var(gram, *, lever_arm_m, hull_response, motion_scale=1.0):
    """Variance (-) of a DBS record's realised correlation of motion error and turbulence.

    From where the lidar's output puts the error (:data:`RHO_SAMPLING_COLUMNS`):
    ``v^T G_rho v / v^T G v`` with the along-wind Gram ``G``, for the arguments of
    :func:`gram_sigma_z_ms` (broadcast the same way); 0 where the Gram has no such columns
    (a CW lidar) or the motion error is 0."""
    if RHO_SAMPLING_COLUMNS[0] not in gram:
        args = (lever_arm_m, hull_response, motion_scale, gram[GRAM_COLUMNS[0]])
        return np.zeros(np.broadcast_shapes(*(np.shape(x) for x in args)))
    form = _form(gram, lever_arm_m, hull_response, motion_scale)
    along, weighted = form(GRAM_COLUMNS), form(RHO_SAMPLING_COLUMNS)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(along > 0.0, np.maximum(weighted, 0.0) / along, 0.0)


def gram_sigma_z_ms(gram, *, lever_arm_m, hull_response, motion_scale=1.0):
    """sigma_Z (m/s) of records from :func:`motion_gram` for a lever arm ``L`` (m), a hull
    response ``h`` (-: 0 rotates about a fixed centre, 1 follows the waves) and a motion
    scale ``k`` (-): ``sqrt(v^T G v)``, ``v = (k, k h, L, h)``, ``h = 1`` where the
    translation is measured; a DBS lidar's with its cross-wind error to fourth order
    (:data:`CROSS_WIND_COLUMNS`, :func:`flidar_uq.physics.dbs_sigma_z.hws_error_moments`).
    Broadcasts over draws of ``L, h, k`` given as arrays of shape (n_draws, 1); ``gram`` a
    DataFrame or mapping of :data:`GRAM_COLUMNS` (and optionally ``translation_measured``
    and :data:`CROSS_WIND_COLUMNS`) with arrays of shape (n,) or (1, n)."""
    return gram_hws_error_ms(
        gram, lever_arm_m=lever_arm_m, hull_response=hull_response, motion_scale=motion_scale
    )[0]


def gram_hws_error_ms(gram, *, lever_arm_m, hull_response, motion_scale=1.0):
    """sigma_Z and the mean HWS error ``E Z`` (both m/s) of records from
    :func:`motion_gram`, arguments as :func:`gram_sigma_z_ms`, from one evaluation of the
    quadratic forms: ``E Z`` is a DBS lidar's cross-wind error's ``s_b^2 / (2 U)``
    (:func:`flidar_uq.physics.dbs_sigma_z.hws_error_moments`), 0 where the Gram has no
    cross-wind part (a CW lidar). ``s_b^2`` is taken as at least 0, as the likelihood
    takes it: it can come out negative where the record table's band direction moments
    are not those of any spread of directions
    (:func:`flidar_uq.physics.dbs_sigma_z.band_moments_to_wind`)."""
    along, across, cov = _quadratic_forms(gram, lever_arm_m, hull_response, motion_scale)
    if across is None:
        return np.sqrt(np.maximum(along, 0.0)), np.broadcast_to(0.0, np.shape(along))
    hws = np.asarray(gram["gram_inv_hws_sq"], float) ** -0.5
    var, mean = hws_error_moments(along, np.maximum(across, 0.0), cov, hws)
    return np.sqrt(var), mean
