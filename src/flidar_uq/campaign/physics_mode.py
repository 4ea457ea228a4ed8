"""Virtual floating-lidar campaign, physics mode.

Layout: :func:`_simulate_chunk` runs a chunk of records in named stages, in the order
below: per record its wind (:func:`_wind_turbulence`), sea (:func:`_sea_motion`), lidar
schedule (:func:`_lidar_schedule`) and IMU errors (:func:`_imu_errors`), drawn from its own
generator (:func:`_record_series`), then its scans (:func:`_scan_record`) and IMU series
(:func:`_imu_series`); then the chunk's scans (:func:`_chunk_scans`), record statistics
(:func:`_record_statistics`), LOS frames and IMU statistics (:func:`_imu_statistics`).

Per 10-min record (``record_length_s``) and for every measurement height:

1. Reference wind: mean HWS drawn from a truncated Weibull with lag-1 persistence
   (Gaussian copula), direction, power-law shear (Yamaguchi and Ishihara, 2016: 0.1), a TI(HWS) draw
   (:func:`flidar_uq.physics.turbulence.draw_sigma_u_ms`, IEC NTM or offshore-like) and 1-D
   Kaimal (u, v, w) turbulence (:func:`flidar_uq.physics.turbulence.kaimal_series`) sampled
   every ``wind.wind_dt_s`` (0.1 s) and held in between, independent between heights.
   The 1-D model is enough for the motion-induced excess variance of the VAD; the
   absolute VAD-seen variance of an IEC-coherent 3-D field is lower
   (``tests/test_turbulence.py::test_vad_circle_1d_vs_3d_regime``). With
   ``wind.spatial_field.enabled`` the turbulence is instead a frozen field at the lines of
   sight's focus points and the centre (:func:`_spatial_turbulence`, docs/simulator.md).
2. Buoy motion: narrow-band random roll/pitch from a JONSWAP sea state (wind sea plus
   an optional swell; :func:`flidar_uq.physics.seastate.tilt_series`), or harmonic motion
   (6 DOF: roll, pitch, yaw, surge, sway, heave) for controlled cases (hexapod).
   The wind sea travels downwind (JONSWAP gamma fixed or drawn per record); the swell
   from anywhere or at a set angle to downwind; the buoy keeps a fixed (slowly
   drifting) heading or weathervanes, its bow into the wind (``motion.sea_state``
   keys, ``flidar_uq/resources/scenarios/README.md``); ``true_*`` regime columns record
   which.
   The lidar head sits at ``lever_arm_m`` from the rotation centre (body frame), so
   it translates with ``v = d(R r)/dt`` (docs/motion_spectrum.md).
3. ZephIR-like lidar: the prism turns continuously (one revolution per
   ``scan_period_s``); the lidar scans the heights in turn, one full revolution per
   scan, then refocuses for a random delay. With ``lidar.scan_phase: prism`` (default)
   a scan starts at the azimuth the prism has at that moment, so the scan phase is
   locked to time and random relative to the motion (Gutiérrez-Antuñano et al., 2018, Sec. 2.3).
   ``scan_phase: random`` draws an independent uniform phase per scan (the paper's
   assumption). Every line of sight is simulated with the attitude
   and head velocity at its own time: ``v_r = d_earth . (u_wind - v_head)``
   (docs/conventions.md; Yamaguchi and Ishihara (2016), Eq. 3), measured as ``|v_r|`` (CW lidar, Malekmohammadi et al. (2024)
   Eq. 4) and retrieved with the nominal body geometry (VAD least squares with the
   sign unfolding of the ``|.|`` fit); spatial variation ``sv`` is the RMS fit
   residual over HWS. Occasional scans drop out.
4. The reference instrument (scenario ``reference_instrument``): a fixed reference
   lidar with the same schedule sees the same wind without motion, or a cup / sonic
   records the point HWS series (the truth series, 1 Hz) (``ref_hws_*``; only in the
   first ``reference_days`` if set, always in ``true_ref_hws_*``); IMU roll/pitch/yaw sampled at ``imu.rate_hz`` with noise
   and gaps (and the rotation centre's translational velocity with ``imu.vertical_velocity``
   and ``imu.horizontal_velocity``, its vertical acceleration with
   ``imu.vertical_acceleration``); 10-min statistics in the record format of ``docs/data-format.md``
   plus ``true_*`` columns.

Randomness: the scenario-level draws (all records at once) use one child of the
seed's SeedSequence, and every record gets its own spawned child, so results do not
depend on the chunk size or the number of worker processes.

Retrieval: the VAD least squares of :func:`flidar_uq.physics.lidar.vad_sign_unfolding`
(:func:`flidar_uq.physics.lidar.vad_pseudo_inverse` of the nominal geometry; each scan
covers all ``n_los`` azimuth slots once, in a cyclically shifted order), with the CW sign
unfolded by the iteration :func:`flidar_uq.physics.lidar.retrieve_wind` uses with
``sign_ambiguity=True`` (fixed point of the sign pattern = stationary point of the ``|.|``
least squares), started from the signs of the simulated radial speeds.

Speed: every line of sight of a record (attitude, head velocity, wind, radial speed, scan
fit, reference lidar) and its true motion statistics are simulated in one compiled pass,
:func:`flidar_uq.campaign.scan_kernel.simulate_chunk_scans` (numba), right after the
record's series are drawn (still in cache; the long series are dropped after it); the
Gaussian draws are NumPy's ``Generator.standard_normal`` and the IMU estimators' detrend and
Welch loops are compiled too (:mod:`flidar_uq.data.imu_kernels`); the 10-min statistics are
NumPy over the chunk. The workers import neither pandas nor scipy's subpackages
(docs/performance.md).
"""

from __future__ import annotations

import contextlib
import logging
import multiprocessing as mp
import os
from collections.abc import Mapping
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass
from types import SimpleNamespace
from typing import TYPE_CHECKING

import numpy as np

from flidar_uq.campaign.scenarios import (
    TRUTH_SAMPLE_INTERVAL_S,
    CampaignConfig,
    wind_step_slots,
)
from flidar_uq.data import imu as _imu
from flidar_uq.physics import lidar as _lidar
from flidar_uq.physics.seastate import hull_motion_series, tilt_series
from flidar_uq.physics.turbulence import (
    draw_sigma_u_ms,
    frozen_field_series,
    kaimal_series,
    wind_enu_ms,
)
from flidar_uq.progress import ProgressLog
from flidar_uq.seeding import as_seedsequence
from flidar_uq.threads import BLAS_THREADS, blas_threads

if TYPE_CHECKING:  # pandas is imported where frames are built: not in the workers
    import pandas as pd

__all__ = [
    "CampaignOutput",
    "generate_campaign",
]

log = logging.getLogger(__name__)

#: CNR written for valid lines of sight of the virtual lidar (dB; above Malekmohammadi et al.'s (2024) -23 dB).
GOOD_CNR_DB = -10.0


@dataclass
class CampaignOutput:
    """Result of :func:`generate_campaign`.

    Attributes
    ----------
    records : pandas.DataFrame
        One row per record and height, columns of ``docs/data-format.md`` plus
        ``true_*`` truth columns.
    imu : pandas.DataFrame or None
        Raw IMU series (``timestamp, roll_deg, pitch_deg, yaw_deg``) if requested.
    los : pandas.DataFrame or None
        LOS-level data (``timestamp, height_m, azimuth_deg, radial_speed_ms,
        cnr_db``; a DBS lidar's also ``elevation_deg``) of the floating lidar if requested.
    config : CampaignConfig
        The validated scenario.
    """

    records: pd.DataFrame
    imu: pd.DataFrame | None
    los: pd.DataFrame | None
    config: CampaignConfig


# ---------------------------------------------------------------------------
# scenario-level draws (all records at once, one generator)
# ---------------------------------------------------------------------------


def _record_parameters(cfg: CampaignConfig, rng: np.random.Generator) -> dict:
    """Record-level parameters for all records (arrays of length n_records)."""
    from scipy.special import ndtr  # the standard normal CDF (scipy.stats.norm.cdf's values)

    s = cfg.settings
    n = int(s["n_records"])
    w = s["wind"]
    # HWS at the reference height: Gaussian copula AR(1) -> truncated Weibull
    rho = float(w["hws_lag1_correlation"])
    eps = rng.standard_normal(n)
    z = np.empty(n)
    z[0] = eps[0]
    for i in range(1, n):  # cheap serial recursion (n ~ 1e4)
        z[i] = rho * z[i - 1] + np.sqrt(1.0 - rho**2) * eps[i]
    k, lam = float(w["hws_weibull_shape"]), float(w["hws_weibull_scale_ms"])
    cdf = lambda u: 1.0 - np.exp(-((u / lam) ** k))  # noqa: E731
    lo, hi = cdf(float(w["hws_min_ms"])), cdf(float(w["hws_max_ms"]))
    q = lo + (hi - lo) * ndtr(z)
    hws_ref = lam * (-np.log1p(-q)) ** (1.0 / k)  # truncated Weibull quantile
    wd = (float(w["wd_mean_deg"]) + float(w["wd_sd_deg"]) * rng.standard_normal(n)) % 360.0
    alpha = float(w["shear_exponent_mean"]) + float(w["shear_exponent_sd"]) * rng.standard_normal(n)
    z_ref = float(w["reference_height_m"])
    sigma_u = draw_sigma_u_ms(hws_ref, z_ref, rng, model=w["ti_model"], **w["ti_params"])
    out = {"hws_ref_ms": hws_ref, "wd_deg": wd, "shear_exponent": alpha, "sigma_u_ms": sigma_u}

    m = s["motion"]
    if m["model"] == "sea_state":
        ss = m["sea_state"]
        a_mean = float(ss["amplitude_base_deg"]) + float(ss["amplitude_per_ms_deg"]) * hws_ref
        s2 = np.log1p(float(ss["amplitude_cov"]) ** 2)
        amp = a_mean * np.exp(-0.5 * s2 + np.sqrt(s2) * rng.standard_normal(n))
        amp = np.clip(amp, *ss["amplitude_range_deg"])
        tp = float(ss["tp_base_s"]) + float(ss["tp_per_ms_s"]) * hws_ref
        tp = np.clip(tp + float(ss["tp_sd_s"]) * rng.standard_normal(n), *ss["tp_range_s"])
        has_swell = rng.random(n) < float(ss["swell_probability"])
        tp2 = rng.uniform(*ss["swell_tp_range_s"], size=n)
        share2 = np.where(has_swell, rng.uniform(*ss["swell_variance_share_range"], size=n), 0.0)
        out.update(
            amplitude_deg=amp,
            tp1_s=tp,
            tp2_s=np.where(has_swell, tp2, np.nan),
            weight1=1.0 - share2,
            # waves travel downwind
            dir1_deg=wd + 180.0 + float(ss["wind_sea_direction_sd_deg"]) * rng.standard_normal(n),
            dir2_deg=rng.uniform(0.0, 360.0, n),
            heading_deg=float(ss["heading_sd_deg"]) * rng.standard_normal(n),
        )
        # options, drawn after the draws above so that scenarios without them
        # keep their numbers
        g_range = ss["wind_sea_gamma_range"]
        if g_range is None:
            gamma1 = np.full(n, float(ss["gamma"]))
        else:
            gamma1 = rng.uniform(float(g_range[0]), float(g_range[1]), size=n)
        off_range = ss["swell_direction_offset_deg_range"]
        if off_range is not None:
            off = rng.uniform(float(off_range[0]), float(off_range[1]), size=n)
            side = np.where(rng.random(n) < 0.5, -1.0, 1.0)
            out["dir2_deg"] = (wd + 180.0 + side * off) % 360.0
        t_days = np.arange(n) * float(s["record_length_s"]) / 86400.0
        scatter = out["heading_deg"]
        yaw_fixed = float(ss["fixed_yaw_deg"]) + float(ss["yaw_drift_deg_per_day"]) * t_days
        vane = (ss["heading_mode"] == "weathervane") & (
            hws_ref >= float(ss["weathervane_min_hws_ms"])
        )
        # weathervaning: body x axis into the wind, ENU angle 90 - wd (docs/conventions.md)
        yaw = np.where(vane, 90.0 - wd, yaw_fixed) + scatter
        out.update(
            heading_deg=np.where(np.abs(yaw) < 180.0, yaw, _wrap180(yaw)),
            weathervane=vane.astype(float),
            gamma1=gamma1,
        )
    else:
        h = m["harmonic"]
        cases = h["cases"]
        if cases:
            rows, case_idx = [], []
            for k, case in enumerate(cases):
                rows += [case] * int(case.get("n_records", 1))
                case_idx += [k] * int(case.get("n_records", 1))
            out["case"] = np.array(case_idx, float)

            def col(key, default=0.0):
                return np.array([float(c.get(key, default)) for c in rows])

            period = col("period_s", 4.0)
            out.update(
                roll_amplitude_deg=col("roll_amplitude_deg"),
                pitch_amplitude_deg=col("pitch_amplitude_deg"),
                yaw_amplitude_deg=col("yaw_amplitude_deg"),
                surge_amplitude_m=col("surge_amplitude_m"),
                sway_amplitude_m=col("sway_amplitude_m"),
                heave_amplitude_m=col("heave_amplitude_m"),
                period_s=period,
                yaw_period_s=np.array(
                    [float(c.get("yaw_period_s", c.get("period_s", 4.0))) for c in rows]
                ),
                translation_period_s=np.array(
                    [float(c.get("translation_period_s", c.get("period_s", 4.0))) for c in rows]
                ),
            )
        else:
            amp = rng.uniform(*h["amplitude_range_deg"], size=n)
            zero = np.zeros(n)
            period = rng.uniform(*h["period_range_s"], size=n)
            out.update(
                roll_amplitude_deg=amp,
                pitch_amplitude_deg=amp,
                yaw_amplitude_deg=zero,
                surge_amplitude_m=zero,
                sway_amplitude_m=zero,
                heave_amplitude_m=zero,
                period_s=period,
                yaw_period_s=period,
                translation_period_s=period,
            )
        out["heading_deg"] = np.zeros(n)
        out["weathervane"] = np.zeros(n)
    return out


def _body_to_enu(surge_m, sway_m, heave_m, yaw_deg):
    """Displacements along the body x and y axes of a constant heading ``yaw_deg`` (deg,
    counter-clockwise from east) and up, as (east, north, up), shape (N, 3), m."""
    y = np.deg2rad(yaw_deg)
    east = surge_m * np.cos(y) - sway_m * np.sin(y)
    north = surge_m * np.sin(y) + sway_m * np.cos(y)
    return np.stack([east, north, heave_m], axis=-1)


def _translation_truth(trans, dt_s, e_wind, yaw_deg):
    """Std of the heave (m), of the heave velocity, of the horizontal velocity along the
    wind, along the body x axis (surge) and along the body y axis (sway) (m/s) of a record's
    translation (N, 3, east-north-up) on the LOS clock, the heading ``yaw_deg`` (deg,
    counter-clockwise from east; (N,) or (1,)); NaN without translation."""
    if trans is None:
        return (np.nan,) * 5
    vel = np.diff(trans, axis=0) / dt_s
    y = np.deg2rad(np.asarray(yaw_deg, float))
    y = y[:-1] if y.size == trans.shape[0] else y
    surge = vel[:, 0] * np.cos(y) + vel[:, 1] * np.sin(y)
    sway = -vel[:, 0] * np.sin(y) + vel[:, 1] * np.cos(y)
    return (
        float(np.std(trans[:, 2])),
        float(np.std(vel[:, 2])),
        float(np.std(vel[:, :2] @ e_wind)),
        float(np.std(surge)),
        float(np.std(sway)),
    )


def _wrap180(deg):
    """Angle wrapped into [-180, 180) deg."""
    return (np.asarray(deg, float) + 180.0) % 360.0 - 180.0


# ---------------------------------------------------------------------------
# per-record random series (own generator per record): wind, sea, lidar schedule and
# IMU errors, drawn in this order
# ---------------------------------------------------------------------------


def _scan_schedule(rng, n_los, delay_slots, j_max):
    """Start slots of ``j_max`` consecutive scans separated by random refocusing delays."""
    delays = rng.integers(delay_slots[0], delay_slots[1] + 1, size=j_max)
    starts = np.concatenate([[0], np.cumsum(n_los + delays[:-1])])
    return starts


def _scan_layout(geo) -> SimpleNamespace:
    """The scan kernel's view of a lidar: its slots, their beam vectors and retrieval.

    A VAD lidar: one slot a line of sight (``n_los`` azimuth slots of the prism, the VAD
    least squares). A DBS lidar: each beam's dwell split into ``m`` sub-slots of about
    :data:`flidar_uq.campaign.scenarios.DBS_CLOCK_S` (the motion changes within a beam),
    the beam's radial speed their mean (pulse accumulation), retrieved by the beam pairs
    (:func:`flidar_uq.physics.lidar.dbs_retrieval_operator`, each beam's row over its
    sub-slots divided by ``m``); ``dead_slots`` of a cycle's dead time follow the beams.
    """
    from flidar_uq.campaign.scenarios import campaign_clock_s

    if geo.kind == "vad":
        az = 2.0 * np.pi * np.arange(geo.n_los) / geo.n_los
        d = _lidar.beam_unit_vectors_body(geo, az)
        return SimpleNamespace(
            dbs=False,
            n_los=geo.n_los,
            los_duration_s=geo.los_duration_s,
            az_slots=az,
            d_body=d,
            pinv_t=_lidar.vad_pseudo_inverse(d).T,
            dead_slots=0,
        )
    dt = campaign_clock_s(geo)
    m = int(round(geo.los_duration_s / dt))
    _, az = _lidar.scan_times_azimuths(geo)
    az_sub = np.repeat(az, m)
    dead = int(round((geo.cycle_s - geo.n_los * geo.los_duration_s) / dt))
    return SimpleNamespace(
        dbs=True,
        n_los=geo.n_los * m,
        los_duration_s=dt,
        az_slots=az_sub,
        d_body=_lidar.beam_unit_vectors_body(geo, az_sub),
        pinv_t=np.repeat(_lidar.dbs_retrieval_operator(geo), m, axis=0) / m,
        dead_slots=dead,
    )


def _wind_turbulence(settings, par, i, rng, dt_s, n_slots):
    """Wind: record ``i``'s mean HWS at each height and its turbulence.

    Mean HWS by the power law ``U(z) = U_ref (z / z_ref)**alpha`` (m/s; docs/conventions.md,
    Yamaguchi and Ishihara, 2016), ``U_ref`` (m/s at ``wind.reference_height_m``) and the
    shear exponent ``alpha`` (dimensionless) the record's draws. Turbulence: the 1-D Kaimal
    (u, v, w) fluctuations of IEC 61400-1 ed. 4 (2019), Annex C
    (:func:`flidar_uq.physics.turbulence.kaimal_series`; m/s, wind frame), ``sigma_u``
    (m/s) constant with height, independent between heights, sampled every
    ``wind.wind_dt_s`` (a whole number of LOS slots of ``dt_s``, s) and held in between.

    Returns ``hws_h`` (H,), m/s, and ``fluct_uvw`` (H, 1, 3, Nw), m/s (one point a height),
    over the record's ``n_slots`` LOS slots; with ``wind.spatial_field.enabled`` no
    turbulence here (None): :func:`_spatial_turbulence` draws it after the record's other
    series.
    """
    heights = np.asarray(settings["heights_m"], float)
    z_ref = float(settings["wind"]["reference_height_m"])
    alpha = par["shear_exponent"][i]
    hws_h = par["hws_ref_ms"][i] * (heights / z_ref) ** alpha  # power law (conventions.md)
    if settings["wind"]["spatial_field"]["enabled"]:
        return hws_h, None
    # 1-D Kaimal turbulence, sigma_u constant with height (IEC 61400-1)
    # turbulence on its own clock (wind_dt_s, a multiple of the LOS time), held between samples
    step = wind_step_slots(settings, dt_s)
    n_wind = -(-n_slots // step)
    fluct = kaimal_series(n_wind, dt_s * step, hws_h, par["sigma_u_ms"][i], heights, rng)
    return hws_h, fluct[:, None]  # (H,), (H,1,3,Nw)


def _focus_points(lay, yaw_deg, n_azimuths):
    """The points a record's lines of sight sample in a spatial wind field, per m of height.

    Point 0 is the centre above the lidar (the point truth, the cup; a vertical beam's
    focus); then the floating lidar's focus points at the heading ``yaw_deg`` (deg,
    counter-clockwise from east: its record's mean heading, the tilt and heading changes
    within the record not followed), each ``z tan(phi)`` from the centre along its
    azimuth: a DBS lidar's inclined beams; a VAD lidar's circle at ``n_azimuths`` equally
    spaced azimuths (``min(n_azimuths, n_los)``), each line of sight sampling the nearest
    one. Then the fixed reference lidar's (heading 0) that no floating point serves: a VAD
    reference line of sight takes the floating point nearest in azimuth (within half
    their spacing), a DBS beam the floating beam at its azimuth (to 1e-6 rad), else its
    own point.

    Returns the points' east and north offsets per m of height (P, 2), and the point of
    each azimuth slot's line of sight of the floating lidar and of the reference lidar
    (L,) int.
    """
    # the lines of sight's directions: a VAD lidar's slots, a DBS lidar's beams
    dirs, dir_of_slot = np.unique(lay.d_body, axis=0, return_inverse=True)
    tan_dirs = dirs[:, :2] / dirs[:, 2:]  # horizontal offset per m of height, body frame
    inclined = np.hypot(tan_dirs[:, 0], tan_dirs[:, 1]) > 0.0
    if lay.dbs:  # the points: the beams (a vertical one the centre)
        tan_pts, pt_of_dir, tol = tan_dirs[inclined], np.cumsum(inclined) - 1, 1e-6
    else:  # the points: the circle at n_pt azimuths (clockwise from the body y axis)
        n_pt = min(int(n_azimuths), lay.n_los)
        az = 2.0 * np.pi * np.arange(n_pt) / n_pt
        tan_pts = np.hypot(*tan_dirs[0]) * np.stack([np.sin(az), np.cos(az)], -1)
        az_dirs = np.arctan2(tan_dirs[:, 0], tan_dirs[:, 1])
        pt_of_dir = np.rint(az_dirs * n_pt / (2.0 * np.pi)).astype(np.int64) % n_pt
        tol = np.pi / n_pt * (1.0 + 1e-9)
    cy, sy = np.cos(np.deg2rad(yaw_deg)), np.sin(np.deg2rad(yaw_deg))
    off_f = tan_pts @ np.array([[cy, sy], [-sy, cy]])  # turned by the heading: east, north
    points = [np.zeros(2), *off_f]
    pt_f = np.where(inclined, pt_of_dir + 1, 0)
    # the reference lidar's directions (heading 0: body = earth) against the floating points
    ang_r = np.arctan2(tan_dirs[:, 1], tan_dirs[:, 0])
    ang_f = np.arctan2(off_f[:, 1], off_f[:, 0])
    diff = np.abs(np.deg2rad(_wrap180(np.rad2deg(ang_r[:, None] - ang_f[None, :]))))
    near = np.argmin(diff, axis=1)
    shared = diff[np.arange(near.size), near] <= tol
    own = inclined & ~shared  # a reference beam off every floating point: its own point
    pt_r = np.where(inclined & shared, near + 1, 0)
    pt_r[own] = len(points) + np.arange(own.sum())
    points += list(tan_dirs[own])
    return np.array(points), pt_f[dir_of_slot], pt_r[dir_of_slot]


def _spatial_turbulence(settings, par, i, rng, lay, hws_h, yaw_deg, n_slots):
    """Record ``i``'s turbulence as a frozen field at its focus points
    (``wind.spatial_field.enabled``), drawn after the record's other series.

    The record draws a factor on the Kaimal length scales and a lateral coherence decay,
    uniform in ``wind.spatial_field.length_scale_factor_range`` and
    ``coherence_decay_range`` (the generator's turbulence is not the response model's),
    then :func:`flidar_uq.physics.turbulence.frozen_field_series` at the points of
    :func:`_focus_points` (the heading: the circular mean of the record's yaw series
    ``yaw_deg``, deg; ``wind.spatial_field.azimuth_points`` on a VAD circle), on the
    wind clock of :func:`_wind_turbulence`. Returns ``fluct_uvw`` (H, P, 3, Nw), m/s, and
    the point of each azimuth slot of the floating and of the reference lidar (L,) int.
    """
    sf = settings["wind"]["spatial_field"]
    factor = rng.uniform(*sf["length_scale_factor_range"])
    decay = rng.uniform(*sf["coherence_decay_range"])
    heights = np.asarray(settings["heights_m"], float)
    yaw_mean = _circ_mean_deg(yaw_deg, True, -1)
    points, pt_f, pt_r = _focus_points(lay, yaw_mean, sf["azimuth_points"])
    wd = np.deg2rad(par["wd_deg"][i])
    e = np.array([-np.sin(wd), -np.cos(wd)])  # along the wind (east, north)
    along = heights[:, None] * (points @ e)  # (H,P), m
    lateral = heights[:, None] * (points @ np.array([-e[1], e[0]]))  # to its left, m
    step = wind_step_slots(settings, lay.los_duration_s)
    fluct = frozen_field_series(
        -(-n_slots // step),
        lay.los_duration_s * step,
        hws_h,
        par["sigma_u_ms"][i],
        heights,
        along,
        lateral,
        rng,
        length_scale_factor=factor,
        coherence_decay=decay,
    )
    return fluct, pt_f, pt_r


def _sea_motion(settings, par, i, rng, dt_s, n_slots):
    """Sea: the buoy's attitude and translation over record ``i``, on the LOS clock.

    A random sea state (:func:`_sea_state_motion`) or harmonic six-degree-of-freedom
    motion (:func:`_harmonic_motion`), by ``motion.model``. Returns ``roll, pitch`` (N,),
    deg; ``yaw`` (N,), or (1,) for a constant heading, deg counter-clockwise from east
    (docs/conventions.md); the translation of the rotation centre (N, 3), m, east-north-up,
    or None for a hull that only rotates. ``N = n_slots`` slots of ``dt_s`` (s).
    """
    m = settings["motion"]
    if m["model"] == "sea_state":
        return _sea_state_motion(m["sea_state"], par, i, rng, dt_s, n_slots)
    return _harmonic_motion(par, i, rng, dt_s, n_slots)


def _sea_state_motion(sea, par, i, rng, dt_s, n_slots):
    """Roll, pitch (deg), constant heading (deg) and translation (m) in a JONSWAP sea.

    The wind sea and an optional swell (Hasselmann et al., 1973), tilt variance
    ``amplitude_deg**2`` split between them by ``weight1``, each with its peak period (s),
    peak enhancement ``gamma``, direction of travel relative to the body x axis (deg; ENU
    angle minus the heading) and spread (deg): :func:`flidar_uq.physics.seastate.tilt_series`
    for a hull that only rotates, or the six degrees of freedom of
    :func:`flidar_uq.physics.seastate.hull_motion_series` (the same draws, the same tilt;
    surge, sway, heave of linear deep-water waves, m), turned into east-north-up by
    :func:`_body_to_enu`. Returns as :func:`_sea_motion`.
    """
    rel = par["heading_deg"][i]
    w1 = par["weight1"][i]
    amp = par["amplitude_deg"][i]
    systems = {
        "amplitude_deg": [[amp * np.sqrt(w1), amp * np.sqrt(max(1.0 - w1, 0.0))]],
        "tp_s": [[par["tp1_s"][i], np.nan_to_num(par["tp2_s"][i], nan=6.0)]],
        "gamma": [[par["gamma1"][i], float(sea["swell_gamma"])]],
        # direction of travel relative to the body x axis (ENU angle minus heading)
        "direction_deg": [[90.0 - par["dir1_deg"][i] - rel, 90.0 - par["dir2_deg"][i] - rel]],
        "spread_deg": [[float(sea["spread_deg"]), float(sea["swell_spread_deg"])]],
    }
    yaw = np.array([rel])  # a constant heading: one value (broadcast over the slots)
    if sea["hull"] == "rotation_only":
        roll, pitch = tilt_series(n_slots, dt_s, systems, rng)
        return roll[0], pitch[0], yaw, None
    # six degrees of freedom: the same draws, the tilt unchanged
    hull = hull_motion_series(n_slots, dt_s, systems, rng, sea["hull"])
    trans = _body_to_enu(hull["surge_m"][0], hull["sway_m"][0], hull["heave_m"][0], rel)
    return hull["roll_deg"][0], hull["pitch_deg"][0], yaw, trans


def _harmonic_motion(par, i, rng, dt_s, n_slots):
    """Harmonic six-degree-of-freedom motion (a motion platform; Malekmohammadi et al., 2024).

    ``x(t) = A sin(2 pi t / T + phi)`` for roll, pitch and yaw about the heading (deg) and
    for surge, sway, heave (m, east-north-up of a zero heading), amplitudes ``A`` and
    periods ``T`` (s) the record's, phases ``phi`` (rad) uniform on [0, 2 pi), at
    ``t = k dt_s`` (s). Returns as :func:`_sea_motion`.
    """
    t = np.arange(n_slots) * dt_s
    ph = rng.uniform(0.0, 2.0 * np.pi, size=6)
    w_ = 2.0 * np.pi / par["period_s"][i]
    roll = par["roll_amplitude_deg"][i] * np.sin(w_ * t + ph[0])
    pitch = par["pitch_amplitude_deg"][i] * np.sin(w_ * t + ph[1])
    yaw = par["heading_deg"][i] + par["yaw_amplitude_deg"][i] * np.sin(
        2.0 * np.pi / par["yaw_period_s"][i] * t + ph[2]
    )
    wt = 2.0 * np.pi / par["translation_period_s"][i]
    trans = np.stack(
        [
            par["surge_amplitude_m"][i] * np.sin(wt * t + ph[3]),
            par["sway_amplitude_m"][i] * np.sin(wt * t + ph[4]),
            par["heave_amplitude_m"][i] * np.sin(wt * t + ph[5]),
        ],
        axis=-1,
    )
    return roll, pitch, yaw, trans


def _lidar_schedule(settings, rng, lay, n_slots, n_heights):
    """Scan schedule of a record: prism phase, scan starts, dropouts, outage.

    A CW VAD lidar (ZephIR-like) scans the heights in turn, one prism revolution of
    ``n_los`` slots a scan, then refocuses for a uniform random delay
    (``lidar.refocus_delay_s``, s); the prism's azimuth slot at the record's first slot
    ``k0`` is uniform, and a scan starts at the prism's azimuth then (``scan_phase: prism``;
    Gutiérrez-Antuñano et al., 2018, Sec. 2.3) or at a uniform one (``random``). A pulsed
    DBS lidar runs back-to-back cycles from the first beam (cycle ``n_los + dead_slots``
    slots), every height from the same beams. A scan drops out with probability
    ``lidar.scan_dropout_probability``, the whole record with
    ``lidar.record_outage_probability``.

    Returns ``k0``; ``phase_slots`` and ``starts`` (J,), slots; ``dropped`` (J,) bool;
    ``outage`` bool.
    """
    if lay.dbs:
        # a pulsed DBS lidar: back-to-back cycles from the first beam, every height from
        # the same beams (range gates), so each cycle is a scan of every height
        cycle = lay.n_los + lay.dead_slots
        starts = np.repeat(np.arange(n_slots // cycle + 1) * cycle, n_heights)
        j_max = starts.size
        k0 = 0
        phase_slots = (-starts) % lay.n_los  # the kernel's slot index starts at beam 0
    else:
        dt = lay.los_duration_s
        lo, hi = settings["lidar"]["refocus_delay_s"]
        delay_slots = (int(round(lo / dt)), int(round(hi / dt)))
        j_max = int(np.ceil(n_slots / (lay.n_los + delay_slots[0]))) + 1
        k0 = int(rng.integers(0, lay.n_los))
        starts = _scan_schedule(rng, lay.n_los, delay_slots, j_max)
        if settings["lidar"]["scan_phase"] == "random":
            phase_slots = rng.integers(0, lay.n_los, size=j_max)
        else:
            phase_slots = np.zeros(j_max, dtype=int)
    dropped = rng.random(j_max) < float(settings["lidar"]["scan_dropout_probability"])
    outage = rng.random() < float(settings["lidar"]["record_outage_probability"])
    return k0, phase_slots, starts, dropped, outage


def _imu_errors(imu, rng, t_len_s):
    """IMU errors of a record: white noise of ``imu.noise_deg`` (deg) on roll, pitch and yaw
    at each of the ``floor(t_len_s * imu.rate_hz)`` samples, and with probability
    ``imu.gap_probability`` one gap of uniform length (``imu.gap_length_range_s``, s) at a
    uniform start. Returns the noise (3, n_imu), deg, and the gap ``(start, end)`` in s from
    the record's start, or None."""
    rate = float(imu["rate_hz"])
    n_imu = int(np.floor(t_len_s * rate + 1e-9))
    noise = float(imu["noise_deg"]) * rng.standard_normal((3, n_imu))
    gap = None
    if rng.random() < float(imu["gap_probability"]):
        g_len = rng.uniform(*imu["gap_length_range_s"])
        g0 = rng.uniform(0.0, max(t_len_s - g_len, 0.0))
        gap = (g0, g0 + g_len)
    return noise, gap


def _record_series(settings: dict, par: dict, i: int, ss: np.random.SeedSequence, lay) -> dict:
    """Random series of record ``i``, drawn from its own generator in a fixed order: wind,
    sea, lidar schedule, IMU errors, then a spatial wind field (``wind.spatial_field``;
    ``lay``: :func:`_scan_layout`)."""
    rng = np.random.default_rng(ss)
    t_len = float(settings["record_length_s"])
    dt = lay.los_duration_s
    n_slots = int(round(t_len / dt))
    hws_h, fluct = _wind_turbulence(settings, par, i, rng, dt, n_slots)
    roll, pitch, yaw, trans = _sea_motion(settings, par, i, rng, dt, n_slots)
    n_h = len(settings["heights_m"])
    k0, phase_slots, starts, dropped, outage = _lidar_schedule(settings, rng, lay, n_slots, n_h)
    noise, gap = _imu_errors(settings["imu"], rng, t_len)
    # the translational velocities' noise (m/s), drawn last: the rest unchanged
    w_noise = h_noise = None
    if settings["imu"].get("vertical_velocity") and trans is not None:
        w_noise = float(settings["imu"]["vertical_velocity_noise_ms"]) * rng.standard_normal(
            noise.shape[1]
        )
    if settings["imu"].get("horizontal_velocity") and trans is not None:
        h_noise = float(settings["imu"]["horizontal_velocity_noise_ms"]) * rng.standard_normal(
            (2, noise.shape[1])
        )
    a_noise = None  # the vertical acceleration's noise (m/s^2), drawn after them
    if settings["imu"].get("vertical_acceleration") and trans is not None:
        a_noise = float(settings["imu"]["vertical_acceleration_noise_ms2"]) * rng.standard_normal(
            noise.shape[1]
        )
    pt_f = pt_r = np.zeros(lay.n_los, np.int64)  # a uniform wind: one point a height
    if fluct is None:  # the spatial field, drawn last: the rest as drawn without it
        fluct, pt_f, pt_r = _spatial_turbulence(settings, par, i, rng, lay, hws_h, yaw, n_slots)
    return dict(
        hws_h=hws_h,
        fluct_uvw=fluct,
        point_float=pt_f,
        point_ref=pt_r,
        roll=roll,
        pitch=pitch,
        yaw=yaw,
        trans=trans,
        k0=k0,
        phase_slots=phase_slots,
        starts=starts,
        dropped=dropped,
        outage=outage,
        imu_noise=noise,
        imu_w_noise=w_noise,
        imu_h_noise=h_noise,
        imu_a_noise=a_noise,
        imu_gap=gap,
    )


# ---------------------------------------------------------------------------
# a chunk of records, stage by stage: scans, IMU, record statistics
# ---------------------------------------------------------------------------


def _regime_truth(settings, par, truth) -> dict[str, np.ndarray]:
    """Truth columns of the records' sea-state and heading regime, one value a
    record.

    ``truth``: the rows of :func:`flidar_uq.campaign.scan_kernel.attitude_truth` (tilt
    along / across the wind, ``sqrt(2)`` x its std, deg, the amplitude convention of
    docs/conventions.md, and the mean heading, deg). Directions of travel are compass
    (clockwise from north); the swell offset is signed, swell minus downwind, in
    (-180, 180].
    """
    _, _, along_amp, across_amp, yaw_mean = truth
    wd = np.asarray(par["wd_deg"], float)
    nan = np.full(wd.size, np.nan)
    out = {
        "true_yaw_deg": yaw_mean,
        "true_yaw_minus_upwind_deg": _wrap180(yaw_mean - (90.0 - wd)),
        "true_weathervane": np.asarray(par["weathervane"], float),
        "true_tilt_along_wind_amplitude_deg": along_amp,
        "true_tilt_across_wind_amplitude_deg": across_amp,
        "true_swell_present": nan,
        "true_wind_sea_gamma": nan,
        "true_wind_sea_direction_deg": nan,
        "true_swell_direction_deg": nan,
        "true_swell_direction_offset_deg": nan,
    }
    if settings["motion"]["model"] == "sea_state":
        swell = np.isfinite(par["tp2_s"])
        d2 = np.asarray(par["dir2_deg"], float) % 360.0
        off = -_wrap180(-(d2 - wd - 180.0))  # (-180, 180]
        out.update(
            true_swell_present=swell.astype(float),
            true_wind_sea_gamma=np.asarray(par["gamma1"], float),
            true_wind_sea_direction_deg=np.asarray(par["dir1_deg"], float) % 360.0,
            true_swell_direction_deg=np.where(swell, d2, np.nan),
            true_swell_direction_offset_deg=np.where(swell, off, np.nan),
        )
    return out


def _on_imu_clock(x, n_imu: int, rate_hz: float, dt_s: float) -> np.ndarray:
    """Series ``x`` on the LOS clock (step ``dt_s``, s) at the IMU's ``n_imu`` sample times
    ``k / rate_hz``: every k-th slot when the LOS rate is a whole multiple of the IMU's
    (5 Hz and 50 Hz by default; the same values as interpolating, to rounding of the
    times), else linear interpolation."""
    k = 1.0 / (rate_hz * dt_s)
    every = round(k)
    if abs(k - every) < 1e-9 and every >= 1 and (n_imu - 1) * every < x.size:
        return x[::every][:n_imu]
    return np.interp(np.arange(n_imu) / rate_hz, np.arange(x.size) * dt_s, x)


def _masked_mean_std(x, mask):
    """Count, mean and std (``ddof=1``) of ``x`` where ``mask`` over the last axis
    (``x`` broadcast to ``mask``); NaN where too few samples."""
    n = mask.sum(axis=-1)
    with np.errstate(invalid="ignore", divide="ignore"):
        mean = np.where(mask, x, 0.0).sum(axis=-1) / n  # NaN for n = 0
        dev = np.where(mask, x - mean[..., None], 0.0)
        # NaN for n < 2 (n = 0 would give sqrt(0 / -1) = -0.0)
        std = np.sqrt((dev * dev).sum(axis=-1) / np.where(n >= 2, n - 1, np.nan))
    return n, mean, std


def _circ_mean_deg(deg, mask, axis):
    r = np.deg2rad(deg)
    c = np.where(mask, np.cos(r), 0.0).sum(axis)
    s = np.where(mask, np.sin(r), 0.0).sum(axis)
    return np.rad2deg(np.arctan2(s, c)) % 360.0


def _utc_ns(ts_ns: int, t_s: np.ndarray) -> np.ndarray:
    """Integer nanoseconds since the epoch of ``ts_ns`` (ns since the epoch) + ``t_s`` (s)."""
    return ts_ns + np.round(np.asarray(t_s) * 1e9).astype(np.int64)


def _utc_index(ns: np.ndarray) -> pd.DatetimeIndex:
    """UTC timestamps of integer nanoseconds since the epoch."""
    import pandas as pd

    # a datetime64 view: pd.to_datetime of an int64 array takes an object path (~30x slower)
    return pd.DatetimeIndex(np.asarray(ns, np.int64).view("M8[ns]"), tz="UTC")


def _record_starts_ns(start_utc: str, record_length_s: float, n_records: int) -> np.ndarray:
    """Start of each record, integer ns since the epoch (``start_utc + i record_length_s``,
    as pandas adds a Timedelta of seconds)."""
    import pandas as pd

    start = pd.Timestamp(start_utc)
    return np.array(
        [(start + pd.Timedelta(seconds=i * record_length_s)).value for i in range(n_records)],
        dtype=np.int64,
    )


def _concat_frames(frames: list) -> pd.DataFrame | None:
    """The frames one after another (a new index), or None for none."""
    if not frames:
        return None
    import pandas as pd

    return pd.concat(frames, ignore_index=True)


def _simulate_chunk(settings, par, rec_idx, seeds, want_imu, want_los):
    """One chunk of records (``rec_idx``, their ``par`` and ``seeds``), stage by stage.

    Per record: its random series (wind, sea, lidar schedule, IMU errors;
    :func:`_record_series`), its scans (:func:`_scan_record`), its IMU series
    (:func:`_imu_series`) and its truth samples; then the chunk's scans
    (:func:`_chunk_scans`), 10-min statistics (:func:`_record_statistics`), LOS frames and
    IMU statistics (:func:`_imu_statistics`). Returns the record columns (a dict of arrays,
    one row per record and height), the IMU frame and the LOS frame (or None).
    """
    geo = _lidar.get_lidar(settings["lidar"]["name"])
    lay = _scan_layout(geo)
    clk = _chunk_clocks(settings, lay)
    # the radial speeds are kept for the LOS output and the windows after every beam
    keep = want_los or geo.every_beam_output
    wd = np.deg2rad(par["wd_deg"])
    e_wind = np.stack([-np.sin(wd), -np.cos(wd), np.zeros_like(wd)], -1)  # (C,3)
    starts_ns = np.asarray(par["record_start_ns"], np.int64)  # from the parent (pandas)
    series, scans, imu_att, imu_ns, fl_truth, trans_truth = [], [], [], [], [], []
    for c, (ss, ts) in enumerate(zip(seeds, starts_ns.tolist(), strict=True)):
        s = _record_series(settings, par, c, ss, lay)
        yaw_c = s["yaw"][None]  # (1,N), or (1,1): a constant heading
        if yaw_c.shape[1] > 1 and (yaw_c == yaw_c[:, :1]).all():
            yaw_c = np.ascontiguousarray(yaw_c[:, :1])  # contiguous: the kernel's compiled type
        v_r_c, uvw_c, uvw0_c, resid_c, truth_c, v_r0_c, uvws_c, v_rs_c = _scan_record(
            s, yaw_c, settings, par, c, e_wind, geo, lay, clk
        )
        every = geo.every_beam_output
        scans.append(
            (
                v_r_c if keep else None,
                uvw_c,
                uvw0_c,
                resid_c,
                truth_c,
                v_r0_c if every else None,
                uvws_c,
                v_rs_c if every else None,
            )
        )
        att, ns = _imu_series(s, yaw_c, ts, clk)
        imu_att.append(att)
        imu_ns.append(ns)
        # the centre point's 1-Hz samples
        fl_truth.append(s["fluct_uvw"][:, 0, :, :: clk.k_truth].copy())
        trans_truth.append(_translation_truth(s["trans"], clk.dt_s, e_wind[c, :2], yaw_c[0]))
        for key in (
            "roll",
            "pitch",
            "fluct_uvw",
            "trans",
            "imu_noise",
            "imu_w_noise",
            "imu_h_noise",
            "imu_a_noise",
        ):
            del s[key]  # the record's long series: done with
        series.append(s)
    sc = _chunk_scans(series, scans, par, lay.n_los, clk.n_slots, keep)
    # the 10-min statistics: of the cycles, or of the windows after every beam
    st_sc = (
        _every_beam_scans(sc, scans, series, par, lay, geo, clk.n_slots)
        if geo.every_beam_output
        else sc
    )
    cols, wd_mean = _record_statistics(
        settings, par, rec_idx, starts_ns, st_sc, fl_truth, trans_truth, e_wind
    )
    los = _los_frames(sc, settings, starts_ns, geo, lay, clk) if want_los else None
    att = _imu_statistics(cols, settings, imu_att, imu_ns, wd_mean, clk)
    imu_df = _imu_frame(att, imu_ns) if want_imu else None
    return cols, imu_df, los


def _chunk_clocks(settings, lay) -> SimpleNamespace:
    """The clocks of a chunk's records: the LOS slot ``dt_s`` (s) and the record's
    ``n_slots``, the wind's step (``wind_step`` LOS slots), the 0.1-s stride of the
    attitude truth, the 1-Hz step of the truth series (``k_truth`` wind samples), the
    record length ``t_len_s`` (s) and the IMU rate ``imu_rate_hz`` (Hz)."""
    dt = lay.los_duration_s
    t_len = float(settings["record_length_s"])
    n_slots = int(round(t_len / dt))
    step = wind_step_slots(settings, dt)
    return SimpleNamespace(
        dt_s=dt,
        t_len_s=t_len,
        n_slots=n_slots,
        wind_step=step,
        # the tilt along and across the wind and the heading on a 0.1-s clock: the attitude
        # varies on seconds, and the full LOS clock (0.02 s) would cost a fifth of the
        # record's time
        truth_stride=max(int(round(0.1 / (t_len / n_slots))), 1),
        k_truth=max(int(round(TRUTH_SAMPLE_INTERVAL_S / (dt * step))), 1),  # 1-Hz truth
        imu_rate_hz=float(settings["imu"]["rate_hz"]),
    )


def _scan_record(s, yaw_c, settings, par, c, e_wind, geo, lay, clk):
    """Scans: every line of sight of record ``c`` and its scan fits, in one compiled pass.

    :func:`flidar_uq.campaign.scan_kernel.simulate_chunk_scans`: each line of sight with
    the attitude (deg) and head velocity (m/s; the lever arm ``lidar.lever_arm_m``, m,
    turned and translated, ``v = d(R r)/dt``, docs/motion_spectrum.md) at its own time;
    radial speed ``v_r = d_earth . (u_wind - v_head)`` (m/s; Yamaguchi and Ishihara, 2016,
    Eq. 3), measured as ``|v_r|`` by a CW lidar (Malekmohammadi et al., 2024, Eq. 4);
    retrieved with the nominal body geometry (``lay.pinv_t``: the VAD least squares with
    the sign unfolding of the ``|.|`` fit, or a DBS lidar's beam pairs); the motionless
    lidar's fit of the same wind; the record's true motion statistics. ``yaw_c`` (1, N)
    or (1, 1), deg. Returns the kernel's radial speeds (1, J, L), m/s, then its fits.
    """
    # imported here: numba's import (~0.2 s) only in processes that simulate a campaign
    from flidar_uq.campaign.scan_kernel import simulate_chunk_scans

    # the record's series are still in cache (records are independent: one call a record
    # gives the numbers of one call a chunk)
    return simulate_chunk_scans(
        s["roll"][None],
        s["pitch"][None],
        yaw_c,
        s["trans"][None] if s["trans"] is not None else np.empty((1, 0, 3)),
        s["starts"][None],
        np.array([s["k0"]]),
        s["phase_slots"][None],
        lay.d_body,
        lay.pinv_t,
        s["fluct_uvw"][None],  # (1,H,P,3,Nw), wind frame
        s["point_float"][None],
        s["point_ref"][None],
        s["hws_h"][None],
        e_wind[c : c + 1],
        np.asarray(par["shear_exponent"], float)[c : c + 1],
        np.asarray(settings["lidar"]["lever_arm_m"], float),
        clk.dt_s,
        clk.wind_step,
        np.cos(geo.half_cone_angle_rad),
        0 if geo.signed else 1,
        np.asarray(par["wd_deg"], float)[c : c + 1],
        clk.truth_stride,
        # the heading of the lidar held still: the record's circular mean yaw
        np.atleast_1d(_circ_mean_deg(yaw_c[0], True, -1)),
    )


def _imu_series(s, yaw_c, ts_ns, clk):
    """IMU: the record's roll, pitch and yaw (deg) as its IMU reports them.

    The true attitude at the IMU's sample times ``k / imu_rate_hz`` (s;
    :func:`_on_imu_clock`), plus the record's white noise (deg), NaN within its gap. With
    ``imu.horizontal_velocity`` and ``imu.vertical_velocity``, the rotation centre's
    translational velocity (m/s, east-north-up: the central difference of its
    translation on the LOS clock, the one the lines of sight are simulated with) plus white
    noise of ``imu.horizontal_velocity_noise_ms`` and ``imu.vertical_velocity_noise_ms``,
    as a motion reference unit or GNSS reports it. With ``imu.vertical_acceleration``, its
    vertical acceleration (m/s^2: the second central difference on the LOS clock) plus white
    noise of ``imu.vertical_acceleration_noise_ms2``. Returns the series (n_imu,) by column
    name of the IMU data contract, in its order, and their times, integer ns since the
    epoch (``ts_ns``: the record's start, ns).
    """
    rate, dt = clk.imu_rate_hz, clk.dt_s
    n_imu = s["imu_noise"].shape[1]
    t_imu = np.arange(n_imu) / rate
    att = [_on_imu_clock(s[k], n_imu, rate, dt) for k in ("roll", "pitch")]
    att.append(
        _on_imu_clock(yaw_c[0], n_imu, rate, dt)
        if yaw_c.shape[1] > 1
        else np.full(n_imu, yaw_c[0, 0])
    )
    names = ["roll_deg", "pitch_deg", "yaw_deg"]
    out = {k: a + nz for k, a, nz in zip(names, att, s["imu_noise"], strict=True)}
    if s["imu_h_noise"] is not None:  # the horizontal velocity of the rotation centre, m/s
        for j, name in enumerate(("velocity_east_ms", "velocity_north_ms")):
            v = np.gradient(s["trans"][:, j], dt)
            out[name] = _on_imu_clock(v, n_imu, rate, dt) + s["imu_h_noise"][j]
    if s["imu_w_noise"] is not None:  # the vertical velocity of the rotation centre, m/s
        w = np.gradient(s["trans"][:, 2], dt)
        out["velocity_up_ms"] = _on_imu_clock(w, n_imu, rate, dt) + s["imu_w_noise"]
    if s["imu_a_noise"] is not None:  # the vertical acceleration of the rotation centre
        acc = np.gradient(np.gradient(s["trans"][:, 2], dt), dt)  # m/s^2
        out["acceleration_up_ms2"] = _on_imu_clock(acc, n_imu, rate, dt) + s["imu_a_noise"]
    if s["imu_gap"] is not None:
        g = (t_imu >= s["imu_gap"][0]) & (t_imu < s["imu_gap"][1])
        for a in out.values():
            a[g] = np.nan
    return out, _utc_ns(ts_ns, t_imu)


def _chunk_scans(series, scans, par, n_los, n_slots, want_los) -> SimpleNamespace:
    """The chunk's scans (C records x J scans): each one's wind and whether it counts.

    Each scan's HWS ``sqrt(u**2 + v**2)`` (m/s) of the floating lidar and of the motionless
    one, and its wind direction (compass, deg; the body frame turned by the heading at the
    scan's middle slot), a CW lidar's on the 180-deg branch closest to the true direction
    (a met-station vane). A scan counts (``ok``) if it ends within the record (``valid``),
    did not drop out and its record is not out. ``n_los`` slots a scan, ``n_slots`` a record;
    ``want_los``: keep the radial speeds (the LOS output, and the windows of a lidar with a
    wind after every beam).
    """
    n_h = series[0]["hws_h"].size
    j_max = series[0]["starts"].size
    starts = np.stack([s["starts"] for s in series])  # (C,J)
    valid = starts + n_los <= n_slots
    uvw, uvw0, resid, uvws = (np.concatenate([o[k] for o in scans]) for k in (1, 2, 3, 6))
    wd_scan = _scan_wind_direction(series, uvw, starts, n_los, n_slots, par["wd_deg"])
    dropped = np.stack([s["dropped"] for s in series])
    outage = np.array([s["outage"] for s in series])
    return SimpleNamespace(
        starts=starts,
        valid=valid,
        ok=valid & ~dropped & ~outage[:, None],
        k0=np.array([s["k0"] for s in series]),
        phase_slots=np.stack([s["phase_slots"] for s in series]),  # (C,J)
        h_idx=np.broadcast_to(np.arange(j_max) % n_h, starts.shape),  # heights in turn
        hws_h=np.stack([s["hws_h"] for s in series]),  # (C,H)
        v_r=np.concatenate([o[0] for o in scans]) if want_los else None,  # (C,J,L)
        hws_scan=np.hypot(uvw[..., 0], uvw[..., 1]),  # (C,J)
        hws0=np.hypot(uvw0[..., 0], uvw0[..., 1]),
        hws_still=np.hypot(uvws[..., 0], uvws[..., 1]),
        resid=resid,
        wd_scan=wd_scan,
        attitude=np.concatenate([o[4] for o in scans], axis=1),  # (5,C)
    )


def _scan_wind_direction(series, uvw, starts, n_los, n_slots, wd_deg):
    """Each scan's wind direction (compass, deg): its body-frame wind (C, J, 3) turned by
    the heading at the scan's middle slot (``starts`` (C, J), ``n_los`` slots a scan,
    ``n_slots`` a record), a CW lidar's on the 180-deg branch closest to the true direction
    ``wd_deg`` (C,) (a met-station vane)."""
    yaw = np.stack([s["yaw"] for s in series])  # (C,N), or (C,1): a constant heading
    mid = np.minimum(starts + n_los // 2, n_slots - 1)  # (C,J): each scan's middle slot
    yaw_mid = yaw[np.arange(len(series))[:, None], np.minimum(mid, yaw.shape[1] - 1)]
    wd_scan = _lidar.wind_direction_deg(uvw[..., 0], uvw[..., 1]) - yaw_mid  # compass
    off = np.abs((wd_scan - np.asarray(wd_deg, float)[:, None] + 180.0) % 360.0 - 180.0) > 90.0
    return (wd_scan + 180.0 * off) % 360.0


def _every_beam_scans(sc, scans, series, par, lay, geo, n_slots) -> SimpleNamespace:
    """The chunk's retrieval windows of a DBS lidar with a wind after every beam
    (:attr:`flidar_uq.physics.lidar.LidarGeometry.every_beam_output`), as
    :func:`_chunk_scans` gives its cycles.

    The first cycle, then after each beam of every later cycle, at each height, the window
    of the latest beam of each azimuth (:func:`flidar_uq.physics.lidar.every_beam_windows`; each beam
    its dwell's ``m`` sub-slots) is retrieved by the beam pairs (``lay.pinv_t``), for the
    floating lidar (``sc.v_r``) and the motionless one (``scans``' last item); its RMS fit
    residual over the sub-slots, its wind direction at its middle slot. A window counts if
    the cycles of its inclined beams (the beam pairs' HWS does not read the vertical beam)
    are complete (``valid``) and counted. Returns the fields of
    :func:`_chunk_scans` that the record statistics read, windows (W heights in turn)
    along J.
    """
    n_c, j_max, n_sub = sc.v_r.shape
    n_h = sc.hws_h.shape[1]
    n_beam = geo.n_los
    m = n_sub // n_beam
    n_cyc = j_max // n_h
    v_r0 = np.concatenate([o[5] for o in scans])  # (C,J,L)
    v_rs = np.concatenate([o[7] for o in scans])

    def windows(x):  # (C, J, ...) per cycle and height -> (C, W x H, K, ...) per window
        y = x.reshape((n_c, n_cyc, n_h) + x.shape[2:])  # (C,cycles,H,K,...)
        y = np.moveaxis(y, (1, 3), (0, 1))  # (cycles,K,C,H,...)
        # (W,K,C,H,...): the first cycle's own window, then one after every beam
        out = np.moveaxis(_lidar.every_beam_windows(y), (0, 1), (1, 3))  # (C,W,H,K,...)
        return out.reshape((n_c, -1) + out.shape[3:])

    def per_beam(flag):  # a cycle's flag (C, J) on each of its beams
        return np.repeat(flag[..., None], n_beam, axis=-1)

    v_w = windows(sc.v_r.reshape(n_c, j_max, n_beam, m)).reshape(n_c, -1, n_sub)
    v0_w = windows(v_r0.reshape(n_c, j_max, n_beam, m)).reshape(n_c, -1, n_sub)
    vs_w = windows(v_rs.reshape(n_c, j_max, n_beam, m)).reshape(n_c, -1, n_sub)
    uvw, uvw0, uvws = v_w @ lay.pinv_t, v0_w @ lay.pinv_t, vs_w @ lay.pinv_t  # (C,J',3)
    resid = np.sqrt(np.mean((v_w - uvw @ lay.d_body.T) ** 2, axis=-1))
    inclined = ~np.isnan(_lidar.scan_times_azimuths(geo)[1])  # the pairs' beams
    valid = windows(per_beam(sc.valid))[..., inclined].all(axis=-1)
    ok = windows(per_beam(sc.ok))[..., inclined].all(axis=-1)
    # each window's first slot: the cycle's start plus (beam + 1) dwells, less a cycle
    cyc_start = windows(per_beam(sc.starts))[..., 0]  # the newest cycle's start
    end_beam = np.repeat(np.r_[n_beam - 1, np.tile(np.arange(n_beam), n_cyc - 1)], n_h)
    starts = cyc_start + (end_beam + 1) * m - n_sub
    wd_scan = _scan_wind_direction(series, uvw, starts, n_sub, n_slots, par["wd_deg"])
    return SimpleNamespace(
        starts=starts,
        valid=valid,
        ok=ok,
        h_idx=np.broadcast_to(np.arange(starts.shape[1]) % n_h, starts.shape),
        hws_h=sc.hws_h,
        hws_scan=np.hypot(uvw[..., 0], uvw[..., 1]),
        hws0=np.hypot(uvw0[..., 0], uvw0[..., 1]),
        hws_still=np.hypot(uvws[..., 0], uvws[..., 1]),
        resid=resid,
        wd_scan=wd_scan,
        attitude=sc.attitude,
    )


def _scan_statistics(sc, n_h) -> SimpleNamespace:
    """10-min statistics of every (record, height) at once: its scans are a mask over J.

    Counted scans ``n``, mean and std (``ddof=1``) of the scans' HWS (m/s), of their error
    ``Z`` (m/s) against the floating lidar held still at its record's mean heading (the
    motion's error alone; against the fixed reference lidar, at a heading of 0, it would
    hold the two headings' sampling of the turbulence) and of that still lidar's HWS (m/s),
    the spatial variation ``sv`` (RMS fit
    residual over HWS, dimensionless), the circular mean direction (deg), NaN below two
    scans; availability (%, counted over complete scans).
    """
    at_h = sc.h_idx[:, None, :] == np.arange(n_h)[:, None]  # (C,H,J)
    sel = sc.ok[:, None, :] & at_h
    sel_ref = sc.valid[:, None, :] & at_h
    n_sel, hs_mean, hs_std = _masked_mean_std(sc.hws_scan[:, None, :], sel)
    _, z_mean, z_std = _masked_mean_std((sc.hws_scan - sc.hws_still)[:, None, :], sel)
    _, still_mean, still_std = _masked_mean_std(sc.hws_still[:, None, :], sel)
    with np.errstate(invalid="ignore", divide="ignore"):
        _, sv, _ = _masked_mean_std((sc.resid / sc.hws_scan)[:, None, :], sel)
    wd_mean = _circ_mean_deg(sc.wd_scan[:, None, :], sel, -1)
    enough = n_sel >= 2
    hs_mean, hs_std, z_mean, z_std, still_mean, still_std, sv, wd_mean = (
        np.where(enough, v, np.nan)
        for v in (hs_mean, hs_std, z_mean, z_std, still_mean, still_std, sv, wd_mean)
    )
    return SimpleNamespace(
        n_sel=n_sel,
        hs_mean=hs_mean,
        hs_std=hs_std,
        z_mean=z_mean,
        z_std=z_std,
        still_mean=still_mean,
        still_std=still_std,
        sv=sv,
        wd_mean=wd_mean,
        sel_ref=sel_ref,
        availability=100.0 * n_sel / np.maximum(sel_ref.sum(axis=-1), 1),
    )


def _reference_wind(settings, par, sc, st, fl_truth, e_wind):
    """The true HWS series (1 Hz) at each height, mean and std (m/s), and what the
    reference instrument measures: a motionless lidar's scans (``fixed_lidar``), or the
    point series (cup, sonic). ``fl_truth``: the records' (H, 3, T) 1-Hz fluctuations,
    m/s; ``e_wind`` (C, 3): the unit vector the wind blows along (ENU)."""
    fl = np.stack(fl_truth)  # (C,H,3,T)
    truth = wind_enu_ms(0.0, par["wd_deg"][:, None], fl)[..., :2]  # (C,H,T,2)
    truth += sc.hws_h[..., None, None] * e_wind[:, None, None, :2]
    true_hws = np.hypot(truth[..., 0], truth[..., 1])  # (C,H,T)
    t_mean, t_std = true_hws.mean(axis=-1), true_hws.std(axis=-1, ddof=1)
    if settings["reference_instrument"] != "fixed_lidar":
        return t_mean, t_std, t_mean, t_std
    _, h0_mean, h0_std = _masked_mean_std(sc.hws0[:, None, :], st.sel_ref)
    return t_mean, t_std, h0_mean, h0_std


def _motion_truth(settings, par, n_c):
    """The records' true dominant period (s), the periods of the wind sea and swell (s;
    NaN without one) and the wind sea's share of the tilt variance (dimensionless)."""
    if settings["motion"]["model"] == "sea_state":
        w1_true = np.asarray(par["weight1"], float)
        t1, t2 = np.asarray(par["tp1_s"], float), np.asarray(par["tp2_s"], float)
        return np.where(w1_true >= 0.5, t1, t2), t1, t2, w1_true
    tilted = (par["roll_amplitude_deg"] > 0) | (par["pitch_amplitude_deg"] > 0)
    w1_true, t2 = np.ones(n_c), np.full(n_c, np.nan)
    t1 = np.where(tilted, par["period_s"], np.nan)
    return t1, t1, t2, w1_true


def _record_statistics(settings, par, rec_idx, starts_ns, sc, fl_truth, trans_truth, e_wind):
    """Record statistics: the chunk's rows (a record's heights in turn) as columns of
    ``docs/data-format.md`` plus ``true_*`` truths. Returns them and the mean wind
    direction (deg) of each (record, height), (C, H)."""
    heights = np.asarray(settings["heights_m"], float)
    n_h, n_c = heights.size, len(rec_idx)
    st = _scan_statistics(sc, n_h)
    t_mean, t_std, h0_mean, h0_std = _reference_wind(settings, par, sc, st, fl_truth, e_wind)
    roll_amp, pitch_amp = sc.attitude[0], sc.attitude[1]
    true_amp = np.sqrt(0.5 * (roll_amp**2 + pitch_amp**2))
    true_period, t1, t2, w1_true = _motion_truth(settings, par, n_c)
    ref_days = settings["reference_days"]
    rec_start_s = np.asarray(rec_idx) * float(settings["record_length_s"])
    has_ref = (np.ones(n_c, bool) if ref_days is None else rec_start_s < float(ref_days) * 86400.0)[
        :, None
    ]
    lever_norm = float(np.linalg.norm(np.asarray(settings["lidar"]["lever_arm_m"], float)))

    def per_record(v):  # one value a record -> one a row (a record's heights in turn)
        return np.repeat(np.asarray(v), n_h)

    def per_translation(j):  # the j-th translation truth of each record
        return per_record(np.array([t[j] for t in trans_truth]))

    # the chunk's rows as columns; (C,H) arrays flatten to the same row order
    cols = {
        "timestamp": per_record(starts_ns),  # ns since the epoch
        "height_m": np.tile(heights, n_c),
        "hws_mean_ms": st.hs_mean.ravel(),
        "hws_std_ms": st.hs_std.ravel(),
        "wd_mean_deg": st.wd_mean.ravel(),
        "availability_pct": st.availability.ravel(),
        "sv": st.sv.ravel(),
        "ref_hws_mean_ms": np.where(has_ref, h0_mean, np.nan).ravel(),
        "ref_hws_std_ms": np.where(has_ref, h0_std, np.nan).ravel(),
        "true_hws_mean_ms": t_mean.ravel(),
        "true_hws_std_ms": t_std.ravel(),
        "true_ti": (t_std / t_mean).ravel(),
        "true_wd_deg": per_record(par["wd_deg"]),
        "true_sigma_u_ms": per_record(par["sigma_u_ms"]),
        "true_shear_exponent": per_record(par["shear_exponent"]),
        "true_amplitude_deg": per_record(true_amp),
        "true_roll_amplitude_deg": per_record(roll_amp),
        "true_pitch_amplitude_deg": per_record(pitch_amp),
        "true_period_s": per_record(true_period),
        "true_period1_s": per_record(t1),
        "true_period2_s": per_record(t2),
        "true_weight1": per_record(w1_true),
        "true_lever_arm_m": per_record(np.full(n_c, lever_norm)),
        "true_heave_std_m": per_translation(0),
        "true_heave_velocity_std_ms": per_translation(1),
        "true_velocity_along_wind_std_ms": per_translation(2),
        "true_sigma_z_ms": st.z_std.ravel(),
        "true_mean_z_ms": st.z_mean.ravel(),
        # the floating lidar held still at its heading, on its counted scans
        "true_still_hws_mean_ms": st.still_mean.ravel(),
        "true_still_hws_std_ms": st.still_std.ravel(),
        "true_n_scans": st.n_sel.ravel().astype(float),
        "true_record": per_record(np.asarray(rec_idx, float)),
        "true_case": per_record(par["case"] if "case" in par else np.full(n_c, np.nan)),
        # what the reference would measure, also where it is absent
        "true_ref_hws_mean_ms": h0_mean.ravel(),
        "true_ref_hws_std_ms": h0_std.ravel(),
    } | {k: per_record(v) for k, v in _regime_truth(settings, par, sc.attitude).items()}
    if settings["imu"].get("mru_translation"):  # the buoy's motion reference unit
        for j, col in ((1, "heave_velocity_std_ms"), (3, "surge_velocity_std_ms"),
                       (4, "sway_velocity_std_ms")):  # fmt: skip
            cols[col] = per_translation(j)
    return cols, st.wd_mean


def _los_frames(sc, settings, starts_ns, geo, lay, clk):
    """The floating lidar's lines of sight of the chunk's complete scans (one frame):
    time, height (m), azimuth (deg), radial speed (m/s; ``|v_r|`` for a CW lidar, NaN for
    a scan not counted) and CNR (dB); a DBS lidar's: :func:`_dbs_los_frames`."""
    if lay.dbs:
        return _dbs_los_frames(sc, settings, starts_ns, geo, lay, clk)
    import pandas as pd  # the series' frames (the records go back as arrays)

    heights = np.asarray(settings["heights_m"], float)
    n_los, dt, n_slots = lay.n_los, clk.dt_s, clk.n_slots
    frames = []
    for c, ts in enumerate(starts_ns.tolist()):
        idx = np.minimum(sc.starts[c][:, None] + np.arange(n_los), n_slots - 1)  # (J,L)
        jj = np.nonzero(sc.valid[c])[0]
        a_c = (idx[jj] + sc.k0[c] + sc.phase_slots[c][jj][:, None]) % n_los  # azimuth slots
        t_los = (idx[jj] * dt).ravel()
        vr = np.abs(sc.v_r[c][jj]) if not geo.signed else sc.v_r[c][jj]
        vr = np.where((~sc.ok[c][jj])[:, None], np.nan, vr)
        frames.append(
            pd.DataFrame(
                {
                    "timestamp": _utc_index(_utc_ns(ts, t_los)),
                    "height_m": np.repeat(heights[sc.h_idx[c][jj]], n_los),
                    "azimuth_deg": np.rad2deg(lay.az_slots[a_c]).ravel(),
                    "radial_speed_ms": vr.ravel(),
                    # a valid CW measurement reports a good CNR; dropped scans
                    # carry NaN speed and CNR (flagged by qc.run_los_qc)
                    "cnr_db": np.where(np.isfinite(vr.ravel()), GOOD_CNR_DB, np.nan),
                }
            )
        )
    return _concat_frames(frames)


def _dbs_los_frames(sc, settings, starts_ns, geo, lay, clk):
    """A pulsed DBS lidar's lines of sight of the chunk's complete cycles (one frame).

    One row per beam and range gate (every height of a cycle from the same beams, all at
    the beam's time): the beam's radial speed (m/s, signed) is the mean of its dwell's
    sub-slots (the pulse accumulation of :func:`_scan_layout`), written at the mean time of
    those sub-slots, ``t_cycle + t_beam + (m - 1) dt_s / 2`` (s; ``t_beam`` from
    :func:`flidar_uq.physics.lidar.scan_times_azimuths`, ``m`` sub-slots of ``dt_s``);
    ``azimuth_deg`` is the beam's body-frame azimuth (deg, clockwise from the body y axis)
    and ``elevation_deg`` 90 deg minus the half-cone angle, or 90 deg (azimuth 0) for the
    vertical beam. A (cycle, height) not counted (dropout, outage) has NaN speed and CNR.
    Rows in time order, a beam's gates by increasing height.
    """
    import pandas as pd  # the series' frames (the records go back as arrays)

    heights = np.asarray(settings["heights_m"], float)
    n_h, n_beam = heights.size, geo.n_los
    m = lay.n_los // n_beam  # sub-slots a beam
    t_beam, az = _lidar.scan_times_azimuths(geo)
    t_beam = t_beam + 0.5 * (m - 1) * clk.dt_s  # the mean time of the beam's sub-slots
    vertical = np.isnan(az)
    az_deg = np.where(vertical, 0.0, np.rad2deg(np.nan_to_num(az)) % 360.0)
    elev = np.where(vertical, 90.0, 90.0 - geo.half_cone_angle_deg)
    frames = []
    for c, ts in enumerate(starts_ns.tolist()):
        jj = np.nonzero(sc.valid[c])[0]  # whole cycles: a cycle's heights share its start
        n_cyc = jj.size // n_h
        vr = sc.v_r[c][jj].reshape(n_cyc, n_h, n_beam, m).mean(axis=-1)  # pulse accumulation
        vr = np.where(sc.ok[c][jj].reshape(n_cyc, n_h, 1), vr, np.nan).transpose(0, 2, 1)
        t = (sc.starts[c][jj[::n_h]] * clk.dt_s)[:, None] + t_beam[None, :]  # (cycles, beams)
        vr = vr.ravel()  # (cycle, beam, height) order: time order
        frames.append(
            pd.DataFrame(
                {
                    "timestamp": _utc_index(np.repeat(_utc_ns(ts, t.ravel()), n_h)),
                    "height_m": np.tile(heights, n_cyc * n_beam),
                    "azimuth_deg": np.tile(np.repeat(az_deg, n_h), n_cyc),
                    "radial_speed_ms": vr,
                    "cnr_db": np.where(np.isfinite(vr), GOOD_CNR_DB, np.nan),
                    "elevation_deg": np.tile(np.repeat(elev, n_h), n_cyc),
                }
            )
        )
    return _concat_frames(frames)


def _imu_statistics(cols, settings, imu_att, imu_ns, wd_mean, clk):
    """IMU statistics: the data layer's estimators on the records' IMU series, one window
    a record, added to ``cols``.

    The motion statistics of :func:`flidar_uq.data.imu.motion_statistics_arrays` (spectral
    peaks in ``imu.period_range_s``, s); the tilt along and across each row's measured wind
    direction ``wd_mean`` (deg) and its spectral moments and periods
    (:func:`flidar_uq.data.imu.tilt_band_statistics`); the mean heading (deg) as a compass
    reports it. Returns the chunk's IMU series (C, n_imu) by column name: roll, pitch and
    yaw (deg) and the velocities (m/s) where the IMU has them.
    """
    n_h = len(settings["heights_m"])
    rate = clk.imu_rate_hz
    # roll, pitch, yaw (C, n), deg, and the velocities (m/s) where the IMU has them
    att = {k: np.stack([a[k] for a in imu_att]) for k in imu_att[0]}
    roll, pitch, yaw = att["roll_deg"], att["pitch_deg"], att["yaw_deg"]
    p_lo, p_hi = settings["imu"]["period_range_s"]
    start_ns, stats, present = _imu.motion_statistics_arrays(
        np.concatenate(imu_ns),
        np.stack([roll.ravel(), pitch.ravel()], axis=-1),
        window_s=clk.t_len_s,
        period_min_s=float(p_lo),
        period_max_s=float(p_hi),
        fs_hz=_imu.grid_rate_hz(1.0 / rate),  # given: no median of the chunk's intervals
    )
    # each row's window: every record has IMU sample times, so every window exists (a
    # window without a finite sample has no statistics)
    row_ns = cols["timestamp"]
    win = np.searchsorted(start_ns, row_ns)
    if not np.array_equal(start_ns[np.minimum(win, start_ns.size - 1)], row_ns):
        raise RuntimeError("campaign: a record without its IMU window")  # a bug, not input
    for key, col in stats.items():
        cols[key] = np.where(present, col, np.nan)[win]
    # tilt along and across the wind (each row's own measured wind direction), its
    # spectral moments and periods: the per-record motion description (docs/data-format.md);
    # the attitude's trigonometry once per record for all its heights
    spec = _imu.tilt_band_statistics(
        roll,
        pitch,
        yaw,
        wd_mean,
        rate,
        velocity_up_ms=att.get("velocity_up_ms"),
        acceleration_up_ms2=att.get("acceleration_up_ms2"),
        velocity_east_ms=att.get("velocity_east_ms"),
        velocity_north_ms=att.get("velocity_north_ms"),
    )
    for key, col in _imu.tilt_spectrum_columns(spec).items():
        cols[key] = np.asarray(col, float)
    # the buoy's mean heading over each record, as a compass would report it
    cols["heading_mean_deg"] = np.repeat(_imu.heading_mean_deg(yaw), n_h).astype(float)
    return att


def _imu_frame(att, imu_ns):
    """The chunk's raw IMU series as a frame: time, roll, pitch, yaw (deg) and, where
    the IMU has them, the translational velocities (m/s); ``att``: the series (C, n) by
    column name."""
    import pandas as pd

    return pd.DataFrame(
        {"timestamp": _utc_index(np.concatenate(imu_ns))}
        | {name: a.ravel() for name, a in att.items()}
    )


_BLAS_ENV = ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS")
#: glibc's malloc in the workers: keep freed memory for reuse (no trimming of the heap, no
#: mmap below 32 MB). By default a chunk's arrays of a few MB are returned to the kernel
#: when freed and faulted in again page by page at the next chunk: ~0.8 ms of system time a
#: record, ~10 % of the generator (measured when it was set; CHANGELOG). No effect on results;
#: ignored by other C libraries.
_MALLOC_TUNABLES = (
    "glibc.malloc.mmap_threshold=33554432:glibc.malloc.trim_threshold=1073741824:"
    "glibc.malloc.top_pad=67108864"
)


@contextlib.contextmanager
def _spawned_workers_env():
    """Environment of spawned worker processes: BLAS pinned to :data:`BLAS_THREADS`, and
    :data:`_MALLOC_TUNABLES` (unless ``GLIBC_TUNABLES`` is set already).

    :func:`flidar_uq.threads.blas_threads` limits the thread pools of the libraries loaded
    in *this* process; a spawned worker imports NumPy and SciPy afresh, and OpenBLAS reads
    these variables when it is loaded (glibc when the process starts). The workers start at
    the first submitted task (not when the pool is made), so the variables must hold for
    the pool's whole life.
    """
    env = {k: str(BLAS_THREADS) for k in _BLAS_ENV}
    if "GLIBC_TUNABLES" not in os.environ:
        env["GLIBC_TUNABLES"] = _MALLOC_TUNABLES
    saved = {k: os.environ.get(k) for k in env}
    os.environ.update(env)
    try:
        yield
    finally:
        for k, v in saved.items():
            if v is None:
                os.environ.pop(k, None)
            else:
                os.environ[k] = v


def _run_chunk(args):
    return _simulate_chunk(*args)


def generate_campaign(
    scenario: Mapping | CampaignConfig,
    seed: int | np.random.SeedSequence,
    *,
    progress: bool = False,
    return_imu: bool = False,
    return_los: bool = False,
    n_workers: int | None = None,
    chunk_records: int | None = None,
) -> CampaignOutput:
    """Generate a virtual campaign in physics mode.

    Parameters
    ----------
    scenario : mapping or CampaignConfig
        Scenario (keys of :data:`flidar_uq.campaign.scenarios.DEFAULT_SCENARIO`; e.g. from
        :func:`flidar_uq.campaign.scenarios.load_scenario`).
    seed : int or numpy.random.SeedSequence
        Root seed (:func:`flidar_uq.seeding.as_seedsequence`). Record ``i`` uses child ``i``
        of a spawned SeedSequence, so the output is identical for any ``chunk_records`` and
        ``n_workers``. BLAS runs single-threaded (:mod:`flidar_uq.threads`), in-process and
        in the workers.
    progress : bool
        Show a tqdm progress bar over chunks. Whatever its value, the records done, the
        time taken and the time left are logged at INFO every 10 %
        (:class:`flidar_uq.progress.ProgressLog`; a rule's log shows them).
    return_imu, return_los : bool
        Also return the raw IMU series / the floating lidar's LOS-level data
        (LOS data are large: ~19,000 rows per record of a CW VAD lidar at 3 heights, one
        row per beam and height of a DBS lidar, 1,800 for a WindCube v2 at 3 heights; use for
        small scenarios).
    n_workers : int, optional
        Worker processes (default: scenario ``n_workers``); 1 runs in-process.
    chunk_records : int, optional
        Records simulated together (peak memory ~1 MB per record of a chunk); default
        from the scenario.

    Returns
    -------
    CampaignOutput
        ``records`` (rows sorted by timestamp then height), optional ``imu``, ``los``.
    """
    import pandas as pd

    cfg = scenario if isinstance(scenario, CampaignConfig) else CampaignConfig.from_dict(scenario)
    s = cfg.settings
    root = as_seedsequence(seed)
    ss_params, ss_records = root.spawn(2)
    n = int(s["n_records"])
    par = _record_parameters(cfg, np.random.default_rng(ss_params))
    par["record_start_ns"] = _record_starts_ns(s["start_utc"], float(s["record_length_s"]), n)
    rec_seeds = ss_records.spawn(n)
    chunk = int(chunk_records or s["chunk_records"])
    workers = int(n_workers or s["n_workers"])
    if chunk < 1 or workers < 1:
        raise ValueError(
            f"generate_campaign: chunk_records and n_workers must be >= 1, got {chunk}, {workers}"
        )
    jobs = [
        (
            s,
            {k: v[a : a + chunk] for k, v in par.items()},
            np.arange(a, min(a + chunk, n)),
            rec_seeds[a : a + chunk],
            return_imu,
            return_los,
        )
        for a in range(0, n, chunk)
    ]
    bar = None
    if progress:
        from tqdm.auto import tqdm

        bar = tqdm(total=n, desc=f"campaign {s['name']}", unit="rec")
    done = ProgressLog(log, f"campaign {s['name']}", n, "records")
    results = []
    with contextlib.ExitStack() as stack:
        if workers == 1:
            stack.enter_context(blas_threads())
            chunks = map(_run_chunk, jobs)  # lazy: each chunk runs under the BLAS limit
        else:
            # spawned workers with single-threaded BLAS: threads of several processes would
            # compete for the same cores (the VAD pseudo-inverse, any NumPy linear algebra)
            stack.enter_context(_spawned_workers_env())
            pool = ProcessPoolExecutor(max_workers=workers, mp_context=mp.get_context("spawn"))
            # once every chunk is in (or one failed), without waiting for the workers to
            # exit (their interpreters take ~0.25 s to finish, in parallel with what follows);
            # chunks not started yet are cancelled
            stack.callback(pool.shutdown, wait=False, cancel_futures=True)
            chunks = pool.map(_run_chunk, jobs)
        for job, res in zip(jobs, chunks, strict=True):
            results.append(res)
            done.update(len(job[2]))
            if bar is not None:
                bar.update(len(job[2]))
    if bar is not None:
        bar.close()
    records = pd.DataFrame(
        {k: np.concatenate([res[0][k] for res in results]) for k in results[0][0]}
    )
    # the resolution pandas gives the records' timestamps (start + a record length)
    unit = (pd.Timestamp(s["start_utc"]) + pd.Timedelta(seconds=float(s["record_length_s"]))).unit
    records["timestamp"] = _utc_index(records["timestamp"].to_numpy()).as_unit(unit)
    imu = pd.concat([r[1] for r in results], ignore_index=True) if return_imu else None
    los = pd.concat([r[2] for r in results], ignore_index=True) if return_los else None
    if imu is not None:
        imu["timestamp"] = pd.to_datetime(imu["timestamp"], utc=True)
    if los is not None:
        los["timestamp"] = pd.to_datetime(los["timestamp"], utc=True)
    return CampaignOutput(records=records, imu=imu, los=los, config=cfg)
