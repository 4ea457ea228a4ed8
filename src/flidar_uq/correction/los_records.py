"""LOS-level motion-corrected TI of one 10-min record, from its LOS data and the IMU series.

The scan-by-scan corrections of :mod:`flidar_uq.correction.los` (Malekmohammadi et al., 2024, Eq. 7,
:func:`~flidar_uq.correction.los.correct_least_squares`; for a pulsed DBS lidar also
Yamaguchi and Ishihara's (2016) conventional and new algorithms, :func:`~flidar_uq.correction.los.correct_dbs_motion`)
applied to a record as a user has it: LOS rows in the format of ``docs/data-format.md``
(CNR-filtered with :func:`flidar_uq.data.qc.run_los_qc`) and the raw IMU series as a
:class:`flidar_uq.physics.motion.SampledMotion` with the lidar head's lever arm: the head
velocity is the rotation's, from the angle rates, plus the buoy's measured translation where
the series has it (:data:`TRANSLATION_COLUMNS`; Yamaguchi and Ishihara, 2016, Eqs. 3-4).
Every method retrieves the HWS of each complete scan (VAD)
or DBS cycle; the record's TI is the std over mean of those HWS, over the same scans for
every method (the uncorrected retrieval included), so the methods differ only in how they
treat the motion.

Scans are the runs of ``lidar.n_los`` lines of sight at one height without a pause longer
than 1.5 LOS durations (a DBS cycle must also hold the beams in the lidar's order, from its
first beam); a scan during which the IMU pauses for more than ``imu_max_gap_s`` is not
used (its motion is unknown), and is counted. A translation column enters a record's
correction when it has a valid sample in the record's IMU rows; a NaN sample of it is then a
missing IMU sample, like a NaN angle.
"""

from __future__ import annotations

from collections.abc import Sequence
from functools import partial

import numpy as np
import pandas as pd

from flidar_uq.correction.los import correct_dbs_motion, correct_least_squares
from flidar_uq.data.metrics import pearson_r
from flidar_uq.data.qc import QCConfig, run_los_qc
from flidar_uq.physics.lidar import LidarGeometry, beam_index, get_lidar
from flidar_uq.physics.motion import SampledMotion

__all__ = [
    "AGREEMENT_COLUMNS",
    "LOS_RECORD_REASONS",
    "TRANSLATION_COLUMNS",
    "agreement_with_bayesian",
    "los_methods",
    "los_record_ti",
    "complete_scans",
]

#: Columns of results/los/agreement.csv (:func:`agreement_with_bayesian`), one row per LOS method.
AGREEMENT_COLUMNS = [
    "method",
    "n_records",
    "bias_vs_bayesian",
    "rmse_vs_bayesian",
    "r_vs_bayesian",
    "inside_interval_pct",
    "md_vs_truth",
    "rmse_vs_truth",
]


#: Why a record height has no LOS-corrected TI (column ``los_flags``).
LOS_RECORD_REASONS = {
    "no_los": "no LOS rows in the record's window at this height",
    "imu_gap": "fewer than min_scans scans with IMU coverage",
    "few_scans": "fewer than min_scans complete scans",
}

#: The IMU series' translational velocities of the buoy's rotation centre (m/s, ENU earth
#: frame; docs/data-format.md, section 2) and the axis each one gives (column ``translation``
#: of :func:`los_record_ti`).
TRANSLATION_COLUMNS = {
    "velocity_east_ms": "east",
    "velocity_north_ms": "north",
    "velocity_up_ms": "up",
}

#: Margin of IMU samples read around a record window (head-velocity differences), s.
IMU_MARGIN_S = 5.0

#: Largest difference between a row's ``elevation_deg`` and the lidar's cone
#: (90 deg - half-cone angle) or the vertical beam (90 deg), deg.
ELEVATION_TOL_DEG = 0.5


def los_methods(lidar: str | LidarGeometry) -> tuple[str, ...]:
    """Method names of the LOS branch for a lidar: ``uncorrected``, ``least_squares`` and, for a
    pulsed DBS lidar, ``dbs_conventional`` and ``dbs_new``."""
    geom = get_lidar(lidar)
    if geom.kind == "dbs":
        return ("uncorrected", "least_squares", "dbs_conventional", "dbs_new")
    return ("uncorrected", "least_squares")


def complete_scans(t_s: np.ndarray, azimuth_rad: np.ndarray, lidar) -> np.ndarray:
    """Indices of the complete scans in a time-ordered LOS sequence of one height.

    Parameters
    ----------
    t_s : numpy.ndarray, shape (n,)
        LOS times, s, strictly increasing.
    azimuth_rad : numpy.ndarray, shape (n,)
        Body-frame beam azimuths, rad; ``NaN`` marks a DBS lidar's vertical beam.
    lidar : str or LidarGeometry
        VAD: a scan is ``n_los`` consecutive LOS without a pause (longer runs are cut into
        scans of ``n_los``); DBS: ``n_los`` consecutive LOS holding the beams in the
        lidar's scan order, starting with its first beam.

    Returns
    -------
    numpy.ndarray of int, shape (nscan, n_los)
        Row indices of each complete scan.
    """
    geom = get_lidar(lidar)
    n = geom.n_los
    t = np.asarray(t_s, float)
    if t.size < n:
        return np.empty((0, n), dtype=int)
    brk = np.flatnonzero(np.diff(t) > 1.5 * geom.los_duration_s) + 1
    if geom.kind == "dbs":
        ids = beam_index(geom, azimuth_rad, tol_rad=1e-3)
        start = np.flatnonzero(ids[: t.size - n + 1] == 0)
        idx = start[:, None] + np.arange(n)
        ok = (ids[idx] == np.arange(n)).all(axis=1)
        ok &= (np.diff(t[idx], axis=1) <= 1.5 * geom.los_duration_s).all(axis=1)
        return idx[ok]
    scans = []
    for a, b in zip(np.r_[0, brk], np.r_[brk, t.size], strict=True):
        k = (b - a) // n
        if k:
            scans.append(a + np.arange(k * n).reshape(k, n))
    return np.concatenate(scans) if scans else np.empty((0, n), dtype=int)


def _los_azimuth_rad(los: pd.DataFrame, lidar: str | LidarGeometry) -> np.ndarray:
    """Body-frame azimuth of each LOS row, rad, ``NaN`` for a DBS lidar's vertical beam.

    Rows with ``elevation_deg`` = 90 are the vertical beam (their ``azimuth_deg`` is not
    used); every other row must lie on the lidar's cone (elevation 90 deg - half-cone angle,
    within :data:`ELEVATION_TOL_DEG`). Without the column every row is on the cone.

    Parameters
    ----------
    los : pandas.DataFrame
        Validated LOS rows (``azimuth_deg``, deg; optional ``elevation_deg``, deg).
    lidar : str or LidarGeometry
        The lidar that wrote them.

    Returns
    -------
    numpy.ndarray, shape (len(los),)
        Azimuth clockwise from the body y axis, rad.

    Raises
    ------
    ValueError
        A row off the cone; vertical-beam rows for a lidar without vertical beam; or a
        lidar with a vertical beam and no ``elevation_deg`` column to mark it.
    """
    geom = get_lidar(lidar)
    az = np.radians(los["azimuth_deg"].to_numpy(dtype=float))
    if "elevation_deg" not in los.columns:
        if geom.kind == "dbs" and geom.vertical_beam and len(los):
            raise ValueError(
                f"LOS series: {geom.name!r} has a vertical beam, but the LOS rows have no "
                "elevation_deg column to mark it (90 deg: the vertical beam)"
            )
        return az
    elev = los["elevation_deg"].to_numpy(dtype=float)
    vertical = np.abs(elev - 90.0) <= ELEVATION_TOL_DEG
    cone = 90.0 - geom.half_cone_angle_deg
    off = ~vertical & (np.abs(elev - cone) > ELEVATION_TOL_DEG)
    if off.any() or (vertical.any() and not (geom.kind == "dbs" and geom.vertical_beam)):
        i = int(np.argmax(off)) if off.any() else int(np.argmax(vertical))
        what = (
            f"on neither the cone of {geom.name!r} ({cone:g} deg) nor the vertical beam (90 deg)"
            if off.any()
            else f"the vertical beam, which {geom.name!r} does not have"
        )
        raise ValueError(
            f"LOS series: elevation_deg {elev[i]:g} at {los['timestamp'].iloc[i].isoformat()} "
            f"is {what}"
        )
    return np.where(vertical, np.nan, az)


def _imu_motion(
    imu: pd.DataFrame, t0: pd.Timestamp, lever_arm_m: Sequence[float]
) -> tuple[SampledMotion | None, np.ndarray, str]:
    """The IMU samples as a motion model, times in s from ``t0``, and the translation used.

    The translation columns (:data:`TRANSLATION_COLUMNS`) with a finite sample in ``imu``
    give the rotation centre's velocity on their axes; the samples kept are those with
    valid angles and valid used translation. The third value names the measured axes
    (``"east+north+up"``, ``"up"``, ...), or ``"rotation_only"``: the head velocity from
    the attitude rates and the lever arm alone.
    """
    used = [
        c
        for c in TRANSLATION_COLUMNS
        if c in imu.columns and np.isfinite(imu[c].to_numpy(dtype=float)).any()
    ]
    translation = "+".join(TRANSLATION_COLUMNS[c] for c in used) or "rotation_only"
    if len(imu) == 0:
        return None, np.empty(0), translation
    ang = ["roll_deg", "pitch_deg"] + (["yaw_deg"] if "yaw_deg" in imu.columns else [])
    ok = np.isfinite(imu[ang + used].to_numpy(dtype=float)).all(axis=1)
    sub = imu.loc[ok]
    t = (sub["timestamp"] - t0).dt.total_seconds().to_numpy()
    if t.size < 2:
        return None, t, translation
    yaw = None
    if "yaw_deg" in sub.columns:  # a heading crossing +-180 deg must not look like a fast turn
        yaw = np.degrees(np.unwrap(np.radians(sub["yaw_deg"].to_numpy(dtype=float))))
    motion = SampledMotion(
        t,
        sub["roll_deg"].to_numpy(dtype=float),
        sub["pitch_deg"].to_numpy(dtype=float),
        yaw,
        lever_arm_m=tuple(float(x) for x in lever_arm_m),
        **{c: sub[c].to_numpy(dtype=float) for c in used},
    )
    return motion, t, translation


def _imu_covered(t_imu: np.ndarray, t_start: np.ndarray, t_end: np.ndarray, max_gap_s: float):
    """Scans ``[t_start, t_end]`` inside the IMU span without a pause > ``max_gap_s``."""
    if t_imu.size < 2:
        return np.zeros(t_start.shape, dtype=bool)
    inside = (t_start >= t_imu[0]) & (t_end <= t_imu[-1])
    gap = np.flatnonzero(np.diff(t_imu) > max_gap_s)
    if gap.size == 0:
        return inside
    g0, g1 = t_imu[gap], t_imu[gap + 1]
    # a scan overlaps gap k iff g0 < t_end and g1 > t_start; gaps are disjoint and ordered
    k = np.searchsorted(g0, t_end, side="left") - 1  # last gap starting before the scan end
    overlap = (k >= 0) & (g1[np.clip(k, 0, None)] > t_start)
    return inside & ~overlap


def _ti(hws: np.ndarray | None, min_scans: int) -> tuple[int, float, float, float]:
    """Scans with a finite HWS, their mean and std (m/s) and TI (-); NaN statistics from
    fewer than ``min_scans`` (at least 2) of them."""
    h = np.empty(0) if hws is None else hws[np.isfinite(hws)]
    if h.size < max(min_scans, 2):
        return h.size, np.nan, np.nan, np.nan
    m, s = float(h.mean()), float(h.std(ddof=1))
    return h.size, m, s, s / m


def los_record_ti(
    los: pd.DataFrame,
    imu: pd.DataFrame,
    *,
    start: pd.Timestamp,
    heights_m: Sequence[float],
    wd_deg: Sequence[float],
    lidar: str | LidarGeometry,
    lever_arm_m: Sequence[float],
    qc: QCConfig | None = None,
    imu_max_gap_s: float = 1.0,
    min_scans: int = 30,
) -> pd.DataFrame:
    """LOS-level corrected HWS statistics and TI of one record, per height and method.

    Parameters
    ----------
    los : pandas.DataFrame
        The record window's LOS rows (validated LOS format, time-ordered): ``timestamp,
        height_m, azimuth_deg, radial_speed_ms, cnr_db`` and, for a lidar with a vertical
        beam, ``elevation_deg`` (deg; :func:`_los_azimuth_rad`). A DBS lidar writes one row
        per range gate (``height_m``) and LOS time.
    imu : pandas.DataFrame
        IMU rows covering the window (with :data:`IMU_MARGIN_S` on both sides):
        ``timestamp``, ``roll_deg``, ``pitch_deg`` and optionally ``yaw_deg`` (deg) and the
        rotation centre's translational velocity (:data:`TRANSLATION_COLUMNS`, m/s, ENU),
        which every correction adds to the head velocity of the lever arm's rotation.
    start : pandas.Timestamp
        Start of the record window (UTC).
    heights_m : sequence of float
        The record's heights, m.
    wd_deg : sequence of float
        The record's mean wind direction per height (``wd_mean_deg``), deg: chooses the
        180-deg branch of a CW lidar's scans (``reference_wd_deg`` of
        :func:`~flidar_uq.correction.los.correct_least_squares`); NaN: the method's default.
    lidar : str or LidarGeometry
        ``"zephir300"`` (CW VAD) or a pulsed DBS lidar (``"windcube_v1"``, or
        ``"windcube_v2"`` with its vertical beam, carried and not used by the corrections of
        Yamaguchi and Ishihara, 2016).
    lever_arm_m : sequence of 3 float
        Lidar head position from the buoy's rotation centre, body frame, m.
    qc : QCConfig, optional
        CNR filter settings (``cnr``, ``cnr_min_db``); default :class:`QCConfig`.
    imu_max_gap_s : float
        Longest IMU pause tolerated during a scan, s.
    min_scans : int
        Fewer usable scans give NaN, and so do fewer retrieved HWS of a method (a 10-min
        std from 30 scans has a relative sampling error of about 1 / sqrt(2 * 30) = 13 %);
        of a DBS lidar's windows after every beam, fewer than ``min_scans`` cycles' worth.

    Returns
    -------
    pandas.DataFrame
        One row per height: ``height_m``, ``n_los``, ``n_scans`` (complete), ``n_scans_used``
        (with IMU), ``los_flags`` (:data:`LOS_RECORD_REASONS`, ``;``-separated),
        ``translation`` (the measured axes in the head velocity, e.g. ``east+north+up`` or
        ``up``, or ``rotation_only``: :func:`_imu_motion`), and per
        method ``m`` of :func:`los_methods`: ``n_hws_<m>`` (scans with a retrieved HWS, or
        a DBS lidar's windows after every beam with ``every_beam_output``; a
        Yamaguchi and Ishihara (2016) target whose point on a tilted beam lies beyond the
        lowest or highest gate, or a singular scan, gives none), ``hws_mean_ms_<m>``,
        ``hws_std_ms_<m>`` (m/s, over those scans' HWS) and ``ti_los_<m>`` (-), NaN from
        fewer than ``min_scans`` HWS.

    Raises
    ------
    ValueError
        A CW lidar with negative radial speeds, or rows whose ``elevation_deg`` does not
        fit the lidar (:func:`_los_azimuth_rad`).
    """
    geom = get_lidar(lidar)
    methods = los_methods(geom)
    az_all = _los_azimuth_rad(los, geom)
    vr_all = los["radial_speed_ms"].to_numpy(dtype=float).copy()
    if len(los):
        vr_all[~run_los_qc(los, qc).flags["kept"].to_numpy(dtype=bool)] = np.nan
    if not geom.signed and np.any(vr_all[np.isfinite(vr_all)] < 0):
        bad = los["timestamp"].iloc[int(np.argmax(np.nan_to_num(vr_all) < 0))]
        raise ValueError(
            f"LOS series: negative radial speed at {bad.isoformat()} for the CW lidar "
            f"{geom.name!r}, which reports |v_r|"
        )
    t_los = (los["timestamp"] - start).dt.total_seconds().to_numpy() if len(los) else np.empty(0)
    motion, t_imu, translation = _imu_motion(imu, start, lever_arm_m)
    rows = []
    if geom.kind == "dbs":
        # one row per LOS time, one column per range gate
        gates = np.sort(los["height_m"].unique()) if len(los) else np.empty(0)
        wide = (
            pd.DataFrame({"t": t_los, "h": los["height_m"].to_numpy(), "vr": vr_all})
            .pivot_table(index="t", columns="h", values="vr", aggfunc="first", dropna=False)
            .reindex(columns=gates)
        )
        az_t = pd.Series(az_all, index=t_los).groupby(level=0).first()
        t_d = wide.index.to_numpy(dtype=float)
        az_d = az_t.reindex(wide.index).to_numpy(dtype=float)
        vr_d = wide.to_numpy(dtype=float)
    for h, wd in zip(heights_m, wd_deg, strict=True):
        row: dict = {"height_m": float(h)}
        if geom.kind == "dbs":
            t, az = t_d, az_d
            n_here = int((los["height_m"] == h).sum()) if len(los) else 0
        else:
            sel = los["height_m"].to_numpy() == h if len(los) else np.zeros(0, bool)
            t, az, vr = t_los[sel], az_all[sel], vr_all[sel]
            n_here = int(sel.sum())
        scans = complete_scans(t, az, geom) if n_here else np.empty((0, geom.n_los), int)
        covered = _imu_covered(t_imu, t[scans[:, 0]], t[scans[:, -1]], imu_max_gap_s)
        used = scans[covered]
        row.update(n_los=n_here, n_scans=len(scans), n_scans_used=len(used))
        flags = []
        if n_here == 0:
            flags.append("no_los")
        elif len(scans) < min_scans:
            flags.append("few_scans")
        elif len(used) < min_scans:
            flags.append("imu_gap")
        row["los_flags"] = ";".join(flags)
        row["translation"] = translation
        hws = dict.fromkeys(methods)
        if not flags:
            li = used.ravel()
            ref = float(wd) if np.isfinite(wd) else None
            if geom.kind == "dbs":
                kw = dict(range_height_m=gates, target_height_m=[h])
                for m, key in (("none", "uncorrected"), ("conventional", "dbs_conventional"),
                               ("new", "dbs_new")):  # fmt: skip
                    pairs = partial(_pairs_hws, geom=geom, motion=motion, method=m, kw=kw)
                    hws[key] = _dbs_window_hws(geom, used, pairs, t, az, vr_d)
                if h in gates:
                    g = int(np.flatnonzero(gates == h)[0])
                    at_gate = partial(_gate_ls_hws, geom=geom, motion=motion)
                    hws["least_squares"] = _dbs_window_hws(geom, used, at_gate, t, az, vr_d[:, g])
            else:
                hws["uncorrected"] = correct_least_squares(
                    geom, t[li], az[li], vr[li], reference_wd_deg=ref
                ).hws_ms
                hws["least_squares"] = correct_least_squares(
                    geom, t[li], az[li], vr[li], motion, reference_wd_deg=ref
                ).hws_ms
        for m in methods:
            # a DBS lidar's windows after every beam: min_scans cycles' worth of them
            n, mean, std, ti = _ti(hws[m], min_scans * len(geom.window_starts))
            row.update(
                {
                    f"n_hws_{m}": n,
                    f"hws_mean_ms_{m}": mean,
                    f"hws_std_ms_{m}": std,
                    f"ti_los_{m}": ti,
                }
            )
        rows.append(row)
    return pd.DataFrame(rows)


def _dbs_window_hws(geom, cycles, retrieve, t, az, vr) -> np.ndarray:
    """A DBS lidar's retrieved HWS (m/s) of a record's complete ``cycles`` (n, K) of LOS
    indices into ``t``, ``az``, ``vr``: one a cycle, or, for a lidar with a wind after every
    beam (``every_beam_output``), one after every beam within each run of back-to-back
    cycles (a window never spans a gap). ``retrieve(t, az, vr, step)`` gives the HWS of the
    windows of ``K`` lines of sight ``step`` apart."""
    if not geom.every_beam_output:
        li = cycles.ravel()
        return retrieve(t[li], az[li], vr[li], geom.n_los)
    breaks = np.flatnonzero(cycles[1:, 0] != cycles[:-1, -1] + 1) + 1
    runs = [run.ravel() for run in np.split(cycles, breaks) if len(run)]
    out = [retrieve(t[li], az[li], vr[li], 1) for li in runs]
    return np.concatenate(out) if out else np.empty(0)


def _pairs_hws(t, az, vr, step, *, geom, motion, method, kw) -> np.ndarray:
    """HWS (m/s) of the beam pairs (:func:`~flidar_uq.correction.los.correct_dbs_motion`)."""
    return correct_dbs_motion(geom, t, az, vr, motion, method=method, step=step, **kw).hws_ms[:, 0]


def _gate_ls_hws(t, az, vr, step, *, geom, motion) -> np.ndarray:
    """HWS (m/s) of the least squares at a gate (:func:`~flidar_uq.correction.los.correct_least_squares`)."""
    return correct_least_squares(geom, t, az, vr, motion, step=step).hws_ms


def agreement_with_bayesian(
    ti: pd.DataFrame, los: pd.DataFrame
) -> tuple[pd.DataFrame, pd.DataFrame, list[str]]:
    """The LOS-level corrected TI beside the Bayesian one, record by record, and their agreement.

    Each LOS TI is put on the Bayesian target by dividing it by the record's
    ``lidar_std_ratio`` (1 for the motionless-lidar target; docs/lidar-response.md):
    columns ``ti_los_<method>`` (lidar) and ``ti_los_<method>_target``.

    Parameters
    ----------
    ti : pandas.DataFrame
        The corrected records (``results/ti/records.csv``): ``timestamp``, ``height_m``
        (m), ``hws_mean_ms`` (m/s), ``ti_uncorrected``, ``ti_corrected_median``,
        ``ti_corrected_lo``, ``ti_corrected_hi`` (-), ``flags``, and optionally
        ``lidar_std_ratio`` and ``ti_true`` (-).
    los : pandas.DataFrame
        The LOS-level TI per record (``results/los/corrected.csv``): ``timestamp``,
        ``height_m`` and one ``ti_los_<method>`` column (-) per method, ``least_squares``
        among them.

    Returns
    -------
    merged : pandas.DataFrame
        The records of ``ti`` with the LOS columns and ``ti_los_<method>_target``.
    agreement : pandas.DataFrame
        :data:`AGREEMENT_COLUMNS`, one row per method (records with both values):
        ``bias_vs_bayesian`` = mean of LOS minus Bayesian median, ``rmse_vs_bayesian`` (-),
        ``r_vs_bayesian`` (Pearson, more than 2 records), ``inside_interval_pct`` = share
        of LOS values inside the Bayesian credible interval (%); against the truth
        (``ti_true``): ``md_vs_truth``, ``rmse_vs_truth`` (-, NaN without truth). A last
        row ``bayesian`` gives the Bayesian median's own MD and RMSE against the truth,
        over the records with a least-squares LOS value.
    methods : list of str
        The LOS methods, in the order of ``los``'s columns.
    """
    methods = [c[len("ti_los_") :] for c in los.columns if c.startswith("ti_los_")]
    keep = ["timestamp", "height_m", "hws_mean_ms", "ti_uncorrected", "ti_corrected_median"]
    keep += ["ti_corrected_lo", "ti_corrected_hi", "flags"]
    keep += [c for c in ("lidar_std_ratio", "ti_true") if c in ti.columns]
    merged = ti[keep].merge(los, on=["timestamp", "height_m"], how="left", validate="1:1")
    g = merged["lidar_std_ratio"].to_numpy(float) if "lidar_std_ratio" in merged else 1.0
    g = np.where(np.isfinite(g), g, np.nan)
    for m in methods:
        merged[f"ti_los_{m}_target"] = merged[f"ti_los_{m}"].to_numpy(float) / g
    med = merged["ti_corrected_median"].to_numpy(float)
    lo = merged["ti_corrected_lo"].to_numpy(float)
    hi = merged["ti_corrected_hi"].to_numpy(float)
    truth = merged["ti_true"].to_numpy(float) if "ti_true" in merged else None
    rows = []
    for m in methods:
        x = merged[f"ti_los_{m}_target"].to_numpy(float)
        both = np.isfinite(x) & np.isfinite(med)
        d = x[both] - med[both]
        row = {
            "method": m,
            "n_records": int(both.sum()),
            "bias_vs_bayesian": float(d.mean()) if d.size else np.nan,
            "rmse_vs_bayesian": float(np.sqrt(np.mean(d**2))) if d.size else np.nan,
            "r_vs_bayesian": float(pearson_r(x[both], med[both])) if d.size > 2 else np.nan,
            "inside_interval_pct": float(
                100.0 * np.mean((x[both] >= lo[both]) & (x[both] <= hi[both]))
            )
            if d.size
            else np.nan,
        }
        row |= _vs_truth(x, truth, both)
        rows.append(row)
    # the Bayesian median's own errors, over the records compared with Malekmohammadi et al. (2024)
    both = np.isfinite(med) & np.isfinite(merged["ti_los_least_squares_target"].to_numpy(float))
    rows.append({"method": "bayesian", "n_records": int(both.sum())} | _vs_truth(med, truth, both))
    agreement = pd.DataFrame(rows).reindex(columns=AGREEMENT_COLUMNS)
    return merged, agreement, methods


def _vs_truth(x: np.ndarray, truth: np.ndarray | None, use: np.ndarray) -> dict:
    """MD and RMSE of ``x`` against the truth over ``use`` (NaN without truth)."""
    if truth is None:
        return {"md_vs_truth": np.nan, "rmse_vs_truth": np.nan}
    ok = use & np.isfinite(truth)
    d = x[ok] - truth[ok]
    if d.size == 0:
        return {"md_vs_truth": np.nan, "rmse_vs_truth": np.nan}
    return {"md_vs_truth": float(d.mean()), "rmse_vs_truth": float(np.sqrt(np.mean(d**2)))}
