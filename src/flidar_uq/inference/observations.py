"""Observations the models condition on: IMU statistics, sigma_Z moments, head translation."""

from __future__ import annotations

import numpy as np
import pandas as pd

from flidar_uq.data.schema import SHEAR_EXPONENT_COLUMN, SHEAR_EXPONENT_RANGE
from flidar_uq.physics.dbs_sigma_z import wind_to_body_deg
from flidar_uq.physics.surrogate import default_surrogate
from flidar_uq.seeding import as_seedsequence
from flidar_uq.threads import single_threaded


def effective_sigma_z_ms(sz_rot_ms, unit_sq, lever_arm_m, motion_scale=1.0, correlation=None):
    """Effective sigma_Z (m/s) of the lever-arm model: rotation plus head translation.

    ``sZ = sqrt((k sZ_rot)^2 + L^2 u^2)``: the surrogate's rotational sigma_Z scaled by the
    motion-model scale ``k``, and the translation of a head ``L`` above the centre of
    rotation, ``u^2`` from
    :func:`flidar_uq.physics.six_dof_sigma_z.translation_unit_sq` (docs/motion_spectrum.md).
    A pulsed DBS lidar's tilt leak and head translation enter through the same beam pairs
    (Yamaguchi & Ishihara 2016, Eqs. 3-4): with their correlation ``c``,
    ``sZ^2 = (k sZ_rot)^2 + 2 c k sZ_rot L u + L^2 u^2``, which is ``v^T G v`` of
    :func:`flidar_uq.physics.dbs_sigma_z.dbs_tilt_lever_terms` for ``v = (k, L)``.

    Parameters
    ----------
    sz_rot_ms : array_like
        Rotational sigma_Z (m/s).
    unit_sq : array_like
        Squared translational error per metre of lever arm ((m/s)^2 / m^2).
    lever_arm_m : float or array_like
        Effective lever arm ``L`` (m), broadcastable (e.g. one per draw).
    motion_scale : float or array_like
        Motion-model scale ``k`` (1: the surrogate as is).
    correlation : array_like, optional
        Correlation ``c`` in [-1, 1] (-) of the rotational and the translational error
        phasors (:func:`bin_motion_terms`); None: uncorrelated (a CW lidar's VAD form).

    Returns
    -------
    numpy.ndarray
    """
    sz = motion_scale * np.asarray(sz_rot_ms, dtype=float)
    if correlation is None:
        return np.sqrt(sz**2 + np.asarray(lever_arm_m, dtype=float) ** 2 * unit_sq)
    trans = np.asarray(lever_arm_m, dtype=float) * np.sqrt(unit_sq)
    return np.sqrt(np.maximum(sz**2 + 2.0 * correlation * sz * trans + trans**2, 0.0))


def bin_motion_terms(gram_kk, gram_kl, gram_ll):
    """A DBS lidar's Gram entries as the arguments of :func:`effective_sigma_z_ms`.

    From :func:`flidar_uq.physics.dbs_sigma_z.dbs_tilt_lever_terms`: the bin model's
    rotational sigma_Z ``sqrt(G_kk)`` (m/s), translation unit ``u^2 = G_LL`` ((m/s)^2 per
    m^2) and their correlation ``G_kL / sqrt(G_kk G_LL)`` (-, 0 where either part is 0).
    """
    kk, kl, ll = (np.asarray(x, dtype=float) for x in (gram_kk, gram_kl, gram_ll))
    norm = np.sqrt(kk * ll)
    with np.errstate(invalid="ignore", divide="ignore"):
        corr = np.where(norm > 0, kl / np.where(norm > 0, norm, 1.0), 0.0)
    return np.sqrt(kk), ll, np.clip(corr, -1.0, 1.0)


def records_wind_body_deg(records: pd.DataFrame) -> np.ndarray:
    """The wind's direction relative to a DBS lidar's beams per record (deg).

    :func:`flidar_uq.physics.dbs_sigma_z.wind_to_body_deg` of ``wd_mean_deg`` and
    ``heading_mean_deg`` (the heading column is the yaw it takes, docs/conventions.md); NaN
    where either is missing or NaN (the heading unknown).
    """

    def col(name):
        return (
            records[name].to_numpy(dtype=float)
            if name in records
            else np.full(len(records), np.nan)
        )

    return wind_to_body_deg(col("wd_mean_deg"), col("heading_mean_deg"))


def records_shear_exponent(records: pd.DataFrame) -> np.ndarray:
    """Each record's power-law shear exponent ``alpha`` (-) of the mean wind's profile.

    From the column ``shear_exponent`` (:data:`flidar_uq.data.schema.SHEAR_EXPONENT_COLUMN`) where the record table gives it, else fitted at each
    time stamp to the floating lidar's own mean HWS at its heights, ``log U = alpha log z
    + c`` by least squares over the rows of the same ``timestamp`` (the power law of
    Yamaguchi and Ishihara 2016; the motion's mean HWS error, a few cm/s, hardly moves it).
    NaN where a time stamp has fewer than two heights with a positive mean HWS, where the
    fit falls outside :data:`flidar_uq.data.schema.SHEAR_EXPONENT_RANGE`, or without ``timestamp`` and
    ``height_m`` columns. A DBS lidar's record model takes it for the range gates that the
    tilt moves through the shear (:func:`flidar_uq.physics.dbs_sigma_z.dbs_band_terms`);
    NaN leaves that term out.
    """
    n = len(records)
    given = (
        records[SHEAR_EXPONENT_COLUMN].to_numpy(dtype=float)
        if SHEAR_EXPONENT_COLUMN in records
        else np.full(n, np.nan)
    )
    if n == 0 or not {"timestamp", "height_m", "hws_mean_ms"} <= set(records.columns):
        return given
    z = records["height_m"].to_numpy(dtype=float)
    u = records["hws_mean_ms"].to_numpy(dtype=float)
    ok = np.isfinite(z) & np.isfinite(u) & (z > 0) & (u > 0)
    frame = pd.DataFrame(
        {
            "t": records["timestamp"].to_numpy(),
            "x": np.log(np.where(ok, z, np.nan)),
            "y": np.log(np.where(ok, u, np.nan)),
        }
    )
    frame["xx"], frame["xy"] = frame.x * frame.x, frame.x * frame.y
    sums = frame.groupby("t", sort=False)[["x", "y", "xx", "xy"]].transform("sum")
    count = frame.groupby("t", sort=False)["x"].transform("count").to_numpy(dtype=float)
    with np.errstate(divide="ignore", invalid="ignore"):
        sxx = sums.xx.to_numpy() - sums.x.to_numpy() ** 2 / count
        sxy = sums.xy.to_numpy() - sums.x.to_numpy() * sums.y.to_numpy() / count
        alpha = np.where((count >= 2) & (sxx > 1e-12), sxy / sxx, np.nan)
    lo, hi = SHEAR_EXPONENT_RANGE
    alpha = np.where((alpha >= lo) & (alpha <= hi), alpha, np.nan)
    return np.where(np.isfinite(given), given, alpha)


def with_shear_exponent(records: pd.DataFrame) -> pd.DataFrame:
    """``records`` with the column ``shear_exponent`` filled (:func:`records_shear_exponent`):
    for a table whose rows are later taken apart (the calibration records, chunks), so
    that each time stamp's exponent comes from all its heights."""
    return records.assign(**{SHEAR_EXPONENT_COLUMN: records_shear_exponent(records)})


def imu_observations(records: pd.DataFrame) -> tuple[np.ndarray, np.ndarray]:
    """Per-record log amplitude and log period from the IMU statistics.

    The record's motion amplitude (period) is the geometric mean of the roll and pitch
    amplitudes (periods); a missing axis falls back to the other; NaN if both missing.

    Parameters
    ----------
    records : pandas.DataFrame
        Core record columns ``roll_amplitude_deg``, ``pitch_amplitude_deg``,
        ``roll_period_s``, ``pitch_period_s`` (missing columns count as NaN).

    Returns
    -------
    log_amp, log_per : numpy.ndarray, shape (n_records,)
        Natural logs of deg and s; NaN where unavailable or non-positive.
    """

    def col(name):
        if name in records:
            x = records[name].to_numpy(dtype=float)
        else:
            x = np.full(len(records), np.nan)
        return np.log(np.where(x > 0, x, np.nan))

    out = []
    for a, b in (
        ("roll_amplitude_deg", "pitch_amplitude_deg"),
        ("roll_period_s", "pitch_period_s"),
    ):
        x = np.stack([col(a), col(b)])
        with np.errstate(all="ignore"):
            n = np.sum(np.isfinite(x), axis=0)
            m = np.where(
                n > 0,
                np.nansum(np.where(np.isfinite(x), x, 0.0), axis=0) / np.maximum(n, 1),
                np.nan,
            )
        out.append(m)
    return out[0], out[1]


def two_peak_observations(records: pd.DataFrame) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per-record two-peaked motion spectrum: log short and long period, variance share.

    From the optional record columns ``period1_s``, ``period2_s`` and ``weight1`` (the
    record's own spectrum, :func:`flidar_uq.data.imu.two_peaks`; docs/data-format.md). A
    record is two-peaked where ``period2_s`` and ``weight1`` are finite; ``period1_s``
    absent or NaN falls back to the geometric mean of the roll and pitch periods.

    Parameters
    ----------
    records : pandas.DataFrame

    Returns
    -------
    log_p1, log_p2 : numpy.ndarray, shape (n_records,)
        Natural logs of the short and long peak periods (s); NaN if single-peaked.
    share1 : numpy.ndarray, shape (n_records,)
        Share of the record's tilt variance in the short-period peak (-); NaN if
        single-peaked.
    """
    n = len(records)

    def col(name):
        return records[name].to_numpy(dtype=float) if name in records else np.full(n, np.nan)

    p2, w1 = col("period2_s"), col("weight1")
    p1 = col("period1_s")
    _, log_per = imu_observations(records)
    with np.errstate(invalid="ignore", divide="ignore"):
        log_p1 = np.where(p1 > 0, np.log(np.where(p1 > 0, p1, 1.0)), log_per)
        two = (p2 > 0) & (w1 >= 0) & (w1 <= 1) & np.isfinite(log_p1)
        log_p2 = np.where(two, np.log(np.where(p2 > 0, p2, 1.0)), np.nan)
    return np.where(two, log_p1, np.nan), log_p2, np.where(two, w1, np.nan)


def _distinct_imu_records(records: pd.DataFrame) -> pd.DataFrame:
    """One row per IMU record: the heights of one 10-min record share the buoy's IMU
    statistics, which must count once in the motion likelihood (not once per height)."""
    from flidar_uq.data.imu import MOTION_STAT_COLUMNS

    if "timestamp" not in records:
        return records
    cols = ["timestamp", *(c for c in MOTION_STAT_COLUMNS if c in records)]
    return records.drop_duplicates(subset=cols)


def _default_surrogate(surrogate):
    return default_surrogate(surrogate)


@single_threaded
def record_sigma_z_moments(
    records, bin_fits, *, surrogate=None, ndraws=200, seed=0, scan_period_s=1.0
):
    """Posterior median and variance of sigma_Z (m/s) for every record, from its bin's fit.

    The lidar is the surrogate's (``surrogate.lidar``): for a pulsed DBS lidar the terms
    are its own beam-pair phasors at each record's wind direction relative to the beams
    (:func:`records_wind_body_deg`; :meth:`flidar_uq.inference.BinFit.sigma_z_draws`).

    Returns
    -------
    sz_med, sz_var, u2_med : numpy.ndarray, shape (n_records,)
        Rotational sigma_Z median (m/s) and variance, and the median translation unit
        ``u^2`` (:func:`flidar_uq.physics.six_dof_sigma_z.translation_unit_sq`; a DBS
        lidar's ``G_LL``); NaN for records whose bin has no fit.
    corr_med : numpy.ndarray, shape (n_records,), or None
        A DBS lidar's median correlation of the two (:func:`bin_motion_terms`); None for a
        CW lidar (no cross term).
    """
    surrogate = _default_surrogate(surrogate)
    fits = {f.bin_id: f for f in bin_fits}
    rng = np.random.default_rng(as_seedsequence(seed))
    med = np.full(len(records), np.nan)
    var = np.full(len(records), np.nan)
    u2m = np.full(len(records), np.nan)
    dbs = surrogate.lidar.kind == "dbs"
    corr_m = np.full(len(records), np.nan) if dbs else None
    beta = records_wind_body_deg(records)
    bins = records["bin_id"].to_numpy()
    for b, f in fits.items():
        m = bins == b
        if not np.any(m):
            continue
        sz, u2, corr = f._motion_draws(
            records["hws_mean_ms"].to_numpy(dtype=float)[m],
            surrogate,
            f._draw_index(ndraws, rng),
            scan_period_s,
            beta[m],
        )
        med[m] = np.median(sz, axis=0)
        var[m] = np.var(sz, axis=0)
        if corr is None:
            u2m[m] = np.median(u2)
        else:
            u2m[m] = np.median(u2, axis=0)
            corr_m[m] = np.median(corr, axis=0)
    return med, var, u2m, corr_m
