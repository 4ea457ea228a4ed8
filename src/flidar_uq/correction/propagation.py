"""Posterior draws -> motion-corrected std and TI with credible intervals, per record and per speed bin.

For every record ``i`` and posterior draw ``d`` (docs/inference.md, "Propagation"):

1. ``sZ_id`` from the record's bin posterior (surrogate at the record's mean HWS, times
   the global ``motion_scale_d`` and plus the head translation ``L_d^2 u^2`` if the global
   fit chose a model with them; a pulsed DBS lidar's own beam-pair terms with their cross
   term, :meth:`flidar_uq.inference.BinFit.sigma_z_draws`);
   ``rho_d, tau0_d, kappa_d[, L_d]`` from the global posterior (independent pairing: cut);
2. the record's own sampling noise, the observation model read backwards: the likelihood
   has ``s_i = mu_i (1 + kappa z)`` (relative noise, sd ``kappa mu`` about the noise-free
   std ``mu``), so given the measured ``s_i`` the noise-free std is
   ``s*_id = s_i / (1 + kappa_d z_id)`` with ``z ~ N(0, 1)`` (the exact pivot of the
   relative noise, ``1 + kappa z`` floored at 0.05); with the absolute ``tau0`` of the bin
   model, ``s_i = s* + sqrt((kappa s*)^2 + tau0^2) z`` solved for ``s*`` by fixed-point
   iteration from it. ``s_i (1 - kappa z)``, the first-order form, gave
   intervals too narrow and low by ``O(kappa^2)``: 86 % coverage of the nominal 90 % in
   the propagation's simulation-based calibration over the prior's ``kappa``;
3. the deployment formula ``c = -rho sZ + sqrt(s*^2 - (1 - rho^2) sZ^2)``
   (:func:`flidar_uq.physics.variance_laws.corrected_std`, Eq. 15 of Gutiérrez-Antuñano et al. (2018) inverted) and
   ``TI = c / m_i``. Draws with a negative discriminant give ``c = 0`` and are counted.
4. the point (cup-like) std, according to the reference the model is calibrated against
   (:meth:`flidar_uq.correction.reference.Reference.noise`): a cup or sonic -> ``c`` is the point std already (the noise
   term ``kappa`` has absorbed the floating-lidar-vs-point scatter); a fixed (motionless)
   lidar -> ``c`` is the std that lidar would measure and the point std is
   ``c exp(e_id - b_d) / g_i``, with ``g_i`` that lidar's mean std ratio to the point wind
   (:func:`flidar_uq.physics.lidar_response.lidar_std_ratio`), ``e_id ~ N(0, sd_i^2)`` its
   record-to-record scatter (:func:`flidar_uq.physics.lidar_response.lidar_point_log_sd`)
   and ``b_d ~ N(0, sd_g^2)`` one draw per posterior draw for all records: the prior of the
   ratio's own error (probe-volume averaging, stability; docs/lidar-response.md).
   ``b`` is a campaign-wide systematic error, the same in every record: the per-record
   interval is given ``g`` (``b = 0``), the ``*_total`` interval and every statistic over
   records (per speed bin, per campaign) include it (docs/inference.md, "Record intervals
   and the reference's calibration").

Baselines beside it: uncorrected TI and Gutiérrez-Antuñano et al.'s (2018) U / C / PC laws (Eqs. 15-17) with
sigma_Z from the surrogate at the bin's median IMU amplitude and period and Gutiérrez-Antuñano et al.'s (2018)
rho (correlation over bins of reference HWS and E(Z), Sec. 3.2).
"""

from __future__ import annotations

from collections.abc import Collection
from dataclasses import dataclass

import numpy as np
import pandas as pd

from flidar_uq.correction.bin_population import population_statistic_draws
from flidar_uq.data.binning import speed_bin_ms
from flidar_uq.data.metrics import REPRESENTATIVE_TI_FACTOR, representative_ti
from flidar_uq.inference import (
    effective_sigma_z_ms,
    imu_observations,
    is_record_model,
    records_wind_body_deg,
)
from flidar_uq.inference.observations import with_shear_exponent
from flidar_uq.inference.record_motion import (
    CROSS_WIND_COLUMNS,
    DBS_COLUMNS,
    GRAM_COLUMNS,
    SAMPLING_COLUMN,
    gram_hws_error_ms,
    gram_rho_sampling_var,
    motion_gram,
)
from flidar_uq.physics.lidar import get_lidar
from flidar_uq.physics.surrogate import default_surrogate, get_surrogate
from flidar_uq.physics.variance_laws import corrected_std, rho_bin_correlation
from flidar_uq.seeding import as_seedsequence

__all__ = [
    "LIDAR_STD_RATIO_LOG_SD",
    "REFERENCE_KINDS",
    "REFERENCE_SAMPLING_CORRELATION",
    "UNCERTAINTY_SOURCES",
    "CorrectedDraws",
    "PointTarget",
    "PropagationSettings",
    "corrected_ti",
    "draw_corrected_ti",
    "draw_held_ti",
    "finite_records",
    "record_summary",
    "speed_bin_keys",
    "speed_bin_statistics",
    "point_target",
    "record_flags",
    "pair_sampling_correlation",
    "reference_pair_log_sd",
    "SYNCHRONIZED",
    "split_noise",
    "ti_group_statistics",
    "variance_law_baselines",
]

#: Sources of the corrected TI's uncertainty that :func:`draw_held_ti` can hold at their
#: median: the motion description (sigma_Z: motion parameters, lever arm,
#: motion scale, record-level motion error), rho, the noise model's parameters (kappa,
#: tau0), the reference's response to turbulence (the point scatter of g and its prior), and the
#: sampling of the measured 10-min std.
UNCERTAINTY_SOURCES = ("motion", "rho", "noise_model", "reference_response", "sampling")

#: Reference instruments of config key ``reference.kind``: the model is calibrated to the
#: point wind directly (cup, sonic), to a motionless lidar (fixed_lidar), or has no
#: reference (none: it is the motionless lidar of the floating lidar's type).
REFERENCE_KINDS = ("cup", "sonic", "fixed_lidar", "none")

#: Prior sd of log g of a reference built in code, the error of the motionless lidar's std
#: ratio to the point wind beyond its temporal part (-); the config's default "auto" takes
#: it per record from the spatial model of the scan disk and the probe volume
#: (docs/lidar-response.md, "Uncertainty of g").
LIDAR_STD_RATIO_LOG_SD = 0.02

#: Default correlation (-) of a fixed reference lidar's sampling errors against the point
#: wind with the floating lidar's own (:func:`reference_pair_log_sd`): 0, two lidars that
#: scan on their own schedules
#: (:func:`flidar_uq.physics.lidar_response.lidar_pair_correlation`, ZephIR 300, 3 heights
#: in turn: 0.02; -0.07 to +0.10 at 5-16 m/s). On one schedule (the virtual campaign's
#: reference lidar) it falls from 1 at the same azimuths to 0.89 at 30 deg, 0.25-0.32 at
#: 90 deg and -0.1 at 180 deg (docs/inference.md).
REFERENCE_SAMPLING_CORRELATION = 0.0

#: Records propagated together by the record motion model (bounds the draws' memory:
#: ndraws x chunk floats per array; it fixes the order of the random numbers).
_RECORD_CHUNK = 20_000

#: Records of a chunk deployed at once after its random numbers are drawn (bounds the
#: temporaries; does not change the numbers).
_DEPLOY_BLOCK = 2_000

#: Floor of the relative-noise pivot ``1 + kappa z`` (step 2): a draw with ``kappa z`` below
#: -0.95 has no noise-free std the likelihood could have given (it would be negative).
_PIVOT_FLOOR = 0.05
#: Fixed-point iterations of the pivot with an absolute noise ``tau0`` (the bin model):
#: each shrinks the error by ``|kappa z|``, from the exact relative-noise pivot.
_PIVOT_ITERATIONS = 4


def _sorted_nanquantile(sorted_draws: np.ndarray, q: np.ndarray) -> np.ndarray:
    """``np.nanquantile(x, q, axis=0)`` (default linear method) from ``x`` sorted along
    axis 0 with its NaNs last (``np.sort``): the same numbers, without numpy's Python call
    per column.

    The same arithmetic as numpy's linear method on each column's ``n`` non-NaN values:
    virtual index ``(n - 1) q``, its floor and the next order statistic (the last one
    when the index reaches ``n - 1``), and the interpolation ``a + (b - a) t``, or
    ``b - (b - a) (1 - t)`` for ``t >= 0.5``. Columns without a value give NaN (numpy
    warns there).

    Parameters
    ----------
    sorted_draws : numpy.ndarray, shape (ndraws, ncols)
        Draws sorted along axis 0, NaNs last (any unit).
    q : numpy.ndarray, shape (nq,)
        Probabilities in [0, 1] (-).

    Returns
    -------
    numpy.ndarray, shape (nq, ncols)
        The quantiles (unit of ``sorted_draws``).
    """
    x = np.asarray(sorted_draws)
    q = np.asarray(q, dtype=float)
    count = x.shape[0] - np.count_nonzero(np.isnan(x), axis=0)  # (ncols,)
    last = np.maximum(count - 1, 0)
    virtual = last[None, :] * q[:, None]  # numpy: (n - 1) * q
    above = virtual >= last[None, :]
    prev = np.where(above, last[None, :], np.floor(virtual)).astype(np.intp)
    nxt = np.where(above, prev, prev + 1)
    gamma = virtual - prev  # with prev = n - 1 both neighbours are the last value
    a = np.take_along_axis(x, prev, axis=0)
    b = np.take_along_axis(x, nxt, axis=0)
    diff = b - a
    out = np.where(gamma >= 0.5, b - diff * (1 - gamma), a + diff * gamma)
    out[:, count == 0] = np.nan
    return out


def _record_quantiles(
    sig_draws: np.ndarray, mean_hws_ms: np.ndarray, q: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Per-record quantiles of the corrected std draws and of the TI ``std / mean HWS``:
    ``np.nanquantile`` of each with non-finite draws left out, from one sort.

    ``x -> x / m`` is monotone (increasing for ``m > 0``) in floating point, so the sorted
    std draws divided by ``m`` are the sorted TI draws; they are sorted again only when
    a quotient overflows or an ``m`` is not positive. Shapes: ``sig_draws`` (ndraws, k)
    in m/s, ``mean_hws_ms`` (k,) in m/s, ``q`` (nq,); returns two (nq, k) arrays (m/s and -).
    """
    x = np.where(np.isfinite(sig_draws), sig_draws, np.nan)
    x.sort(axis=0)
    sq = _sorted_nanquantile(x, q)
    with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
        x /= mean_hws_ms[None, :]
    inf = np.isinf(x)
    if inf.any() or np.any(~(mean_hws_ms > 0)):  # overflow, m <= 0 or NaN: sort again
        x[inf] = np.nan
        x.sort(axis=0)
    return sq, _sorted_nanquantile(x, q)


def reference_pair_log_sd(point_log_sd, correlation=REFERENCE_SAMPLING_CORRELATION):
    """Std of ``log(floating-lidar std / reference-lidar std)`` from the two lidars' sampling (-).

    Both lidars (the same type) scatter about the point std by their sampling, ``e_f`` and
    ``e_r``, each with sd ``sd`` (:func:`flidar_uq.physics.lidar_response.lidar_point_log_sd`),
    correlated by ``c`` (:func:`flidar_uq.physics.lidar_response.lidar_pair_correlation`):
    ``Var(e_f - e_r) = 2 (1 - c) sd^2``. This is the part of the observed scatter of ``s``
    against ``r`` that is not the floating lidar's motion; the record fit takes it as known
    (``fit_record_model(pair_log_sd=...)``) so that ``kappa`` is the floating lidar's own
    noise beyond it (docs/inference.md, "Noise split with a reference lidar").

    Parameters
    ----------
    point_log_sd : array_like
        ``sd`` per record (-).
    correlation : array_like
        ``c`` in [-1, 1] (-), broadcast with ``point_log_sd``.

    Returns
    -------
    numpy.ndarray
        ``sqrt(2 (1 - c)) sd`` (-).

    Raises
    ------
    ValueError
        If a correlation is outside [-1, 1] or a ``sd`` is negative.
    """
    c = np.asarray(correlation, dtype=float)
    sd = np.asarray(point_log_sd, dtype=float)
    if np.any(~((c >= -1.0) & (c <= 1.0))) or np.any(~(sd >= 0.0)):
        raise ValueError(
            "reference_pair_log_sd: correlation must be in [-1, 1] and point_log_sd >= 0"
        )
    return np.sqrt(2.0 * (1.0 - c)) * sd


def split_noise(kappa, point_log_sd, correlation=REFERENCE_SAMPLING_CORRELATION):
    """The floating lidar's own share of a ``kappa`` fitted without the pair term (-).

    For a record fit that did not take the two lidars' sampling scatter as known (the bin
    model, or ``fit_record_model`` without ``pair_log_sd``), ``kappa^2`` holds it:
    ``kappa^2 = eta^2 + pair^2`` with ``pair`` of :func:`reference_pair_log_sd`. The point
    std given ``s`` is uncertain by ``eta^2 + sd^2`` (the floating lidar's own sampling
    ``sd`` is drawn as ``e`` by :func:`draw_corrected_ti`), so ``eta`` is what is propagated on
    ``s``: the reference's sampling, which the fit saw in ``kappa``, is not counted twice.
    ``eta = sqrt(max(kappa^2 - pair^2, 0))``: when the lidars scatter less against each other
    than ``c`` implies, their errors are more correlated than assumed and the floating
    lidar's own sampling is all that is left. ``sd = 0`` (a cup or sonic) leaves ``kappa``.

    Parameters
    ----------
    kappa : array_like
        Relative noise of the floating lidar's std against the reference's (-).
    point_log_sd : array_like
        ``sd`` (-), broadcast with ``kappa``.
    correlation : array_like
        ``c`` in [-1, 1] (-).

    Returns
    -------
    numpy.ndarray
        ``eta`` (-), broadcast shape.
    """
    return _own_noise(kappa, reference_pair_log_sd(point_log_sd, correlation))


def _own_noise(kappa, pair_log_sd):
    """``eta = sqrt(max(kappa^2 - pair^2, 0))`` (:func:`split_noise` for a given pair term)."""
    return np.sqrt(np.maximum(np.asarray(kappa, dtype=float) ** 2 - pair_log_sd**2, 0.0))


def variance_law_baselines(records: pd.DataFrame, surrogate) -> tuple[np.ndarray, float]:
    """Gutiérrez-Antuñano et al.'s (2018) deterministic sigma_Z per record and its single rho.

    Parameters
    ----------
    records : pandas.DataFrame
        Records with ``bin_id``, ``hws_mean_ms`` and IMU statistics; ``ref_hws_mean_ms``
        used for rho when present (else the floating-lidar mean HWS).
    surrogate : SigmaZSurrogate

    Returns
    -------
    sigma_z_ms : numpy.ndarray, shape (n_records,)
        Surrogate sigma_Z at the record's HWS and its bin's median IMU amplitude and period.
    rho : float
        Pearson correlation over bins of (mean reference HWS, E(Z)) (Sec. 3.2 of Gutiérrez-Antuñano et al. (2018)).
    """
    log_amp, log_per = imu_observations(records)
    bins = records["bin_id"].to_numpy()
    hws = records["hws_mean_ms"].to_numpy(dtype=float)
    ref = records["ref_hws_mean_ms"].to_numpy(dtype=float) if "ref_hws_mean_ms" in records else hws
    ref = np.where(np.isfinite(ref), ref, hws)
    sz = np.full(len(records), np.nan)
    bin_ref, bin_ez = [], []
    for b in pd.unique(bins):
        m = bins == b
        la, lp = log_amp[m], log_per[m]
        if not (np.any(np.isfinite(la)) and np.any(np.isfinite(lp))):
            continue
        a, t = np.exp(np.nanmedian(la)), np.exp(np.nanmedian(lp))
        sz[m] = surrogate.sigma_z_ms(hws[m], a, t)
        bin_ref.append(np.nanmean(ref[m]))
        bin_ez.append(float(surrogate.mean_z_ms(np.nanmean(hws[m]), a, t)))
    return sz, rho_bin_correlation(np.array(bin_ref), np.array(bin_ez))


def point_target(
    hws_ms,
    height_m,
    lidar: str,
    *,
    heights_in_turn: int,
    refocus_delay_s=(0.3, 0.7),
    point_sample_interval_s: float = 1.0,
    turbulence_dt_s: float | None = None,
    seed: int,
    wind_body_deg=None,
) -> tuple[np.ndarray, np.ndarray]:
    """Motionless lidar's std ratio to the point std and its log scatter, per record.

    The inputs of step 4 above (``lidar_std_ratio`` and ``point_log_sd`` of
    :class:`PointTarget`).

    Parameters
    ----------
    hws_ms, height_m : array_like, shape (n_records,)
        Record mean HWS (m/s) and measurement height (m).
    lidar : str
        Lidar geometry name.
    heights_in_turn : int
        Heights the lidar scans in turn (-).
    refocus_delay_s : pair of float
        Refocus delay between scans (s).
    point_sample_interval_s : float
        Sampling interval of the point HWS (s).
    turbulence_dt_s : float, optional
        Time step of a synthetic turbulence series (s): the ratio is band-limited at
        ``1 / (2 turbulence_dt_s)`` Hz; None: the atmosphere (continuous spectrum).
    seed : int
        Seed of :func:`flidar_uq.physics.lidar_response.lidar_point_log_sd`.
    wind_body_deg : array_like, shape (n_records,), optional
        The wind's direction against the lidar's body (deg,
        :func:`flidar_uq.physics.dbs_sigma_z.wind_to_body_deg`; NaN: unknown): a DBS
        lidar's ratio and scatter depend on it. None: averaged over directions.

    Returns
    -------
    lidar_std_ratio : numpy.ndarray, shape (n_records,)
        Motionless-lidar std over point std (-),
        :func:`flidar_uq.physics.lidar_response.lidar_std_ratio`.
    point_log_sd : numpy.ndarray, shape (n_records,)
        Std of its log, record to record (-),
        :func:`flidar_uq.physics.lidar_response.lidar_point_log_sd`.
    """
    from flidar_uq.physics import lidar_response

    g_ratio = lidar_response.lidar_std_ratio(
        hws_ms,
        height_m,
        lidar,
        turbulence_max_frequency_hz=None if turbulence_dt_s is None else 0.5 / turbulence_dt_s,
        wind_body_deg=wind_body_deg,
    )
    log_sd = lidar_response.lidar_point_log_sd(
        hws_ms,
        height_m,
        lidar,
        heights_in_turn=heights_in_turn,
        refocus_delay_s=tuple(refocus_delay_s),
        point_sample_interval_s=point_sample_interval_s,
        turbulence_dt_s=turbulence_dt_s,
        seed=int(seed),
        wind_body_deg=wind_body_deg,
    )
    return g_ratio, log_sd


#: Which uncertainty source each global parameter belongs to (``hold`` of draw_held_ti).
_GLOBAL_SOURCES = {
    "rho": "rho",
    "kappa": "noise_model",
    "tau0_ms": "noise_model",
    "lever_arm_m": "motion",
    "motion_scale": "motion",
    "kappa_z": "motion",
    "hull_response": "motion",
    "rho_sd": "rho",
}


def _held_global_draws(global_fit, g_idx: np.ndarray, hold) -> dict[str, np.ndarray]:
    """Global draws with the held sources' parameters at their posterior median and the
    others conditioned on that (Gaussian approximation of the joint posterior:
    ``x_free - C_fh C_hh^-1 (x_held - median)``), so that holding rho also moves the
    parameters that compensate it in the fit (e.g. the motion scale); {} if none is held."""
    names = [n for n in _GLOBAL_SOURCES if n in global_fit.draws]
    held = [n for n in names if _GLOBAL_SOURCES[n] in hold]
    if not held:
        return {}
    free = [n for n in names if n not in held]
    flat = np.column_stack([global_fit.flat(n) for n in names])
    med = np.median(flat, axis=0)
    x = flat[g_idx].copy()
    h = [names.index(n) for n in held]
    f = [names.index(n) for n in free]
    if f and flat.shape[0] > len(names):
        cov = np.cov(flat, rowvar=False)
        c_hh = cov[np.ix_(h, h)] + 1e-12 * np.eye(len(h))
        gain = np.linalg.solve(c_hh, cov[np.ix_(h, f)])  # (n_held, n_free)
        x[:, f] -= (x[:, h] - med[h]) @ gain
        for j in f:  # positive parameters stay positive; rho in (-1, 1)
            lo, hi = (-0.999, 0.999) if names[j] == "rho" else (0.0, np.inf)
            x[:, j] = np.clip(x[:, j], lo, hi)
    x[:, h] = med[h]
    return {n: x[:, k] for k, n in enumerate(names)}


#: ``reference.sampling_correlation`` value of a reference lidar that scans on the floating
#: lidar's own schedule (the virtual campaign's twin): ``c`` then follows the azimuth
#: offset between the two, i.e. the buoy's heading (:func:`pair_sampling_correlation`).
SYNCHRONIZED = "synchronized"


def pair_sampling_correlation(
    correlation,
    heading_deg,
    hws_ms,
    height_m,
    lidar: str,
    *,
    seed: int,
    **sampling,
) -> np.ndarray:
    """Correlation ``c`` of a reference lidar's and the floating lidar's sampling errors, per record.

    The input of :func:`reference_pair_log_sd` (the record fit's known pair term) and of
    ``PointTarget.reference_sampling_correlation``.

    Parameters
    ----------
    correlation : float or "synchronized"
        A number in [-1, 1] (-): every record's ``c`` (0, :data:`REFERENCE_SAMPLING_CORRELATION`:
        two lidars on their own scan schedules, what separate instruments have).
        :data:`SYNCHRONIZED`: the reference lidar scans on the floating lidar's schedule at
        the azimuths of a buoy heading of 0 (the virtual campaign), so ``c`` is
        :func:`flidar_uq.physics.lidar_response.lidar_pair_correlation` at the azimuth
        offset ``heading_deg`` (simulated at the records' median HWS and height).
    heading_deg : array_like, shape (n_records,), or None
        The buoy's mean heading over each record (deg, record column ``heading_mean_deg``);
        used only when synchronized. NaN or None: unknown, ``c`` =
        :data:`REFERENCE_SAMPLING_CORRELATION` for those records.
    hws_ms, height_m : array_like, shape (n_records,)
        Record mean HWS (m/s) and height (m).
    lidar : str
        Geometry name of the two lidars.
    seed : int
        Seed of the simulation (numpy SeedSequence entropy).
    **sampling
        ``heights_in_turn``, ``refocus_delay_s``, ``point_sample_interval_s``,
        ``turbulence_dt_s`` of :func:`flidar_uq.physics.lidar_response.lidar_pair_correlation`.

    Returns
    -------
    numpy.ndarray, shape (n_records,)
        ``c`` in [-1, 1] (-).

    Raises
    ------
    ValueError
        If ``correlation`` is neither a number in [-1, 1] nor :data:`SYNCHRONIZED`.
    """
    hws = np.asarray(hws_ms, dtype=float)
    if correlation != SYNCHRONIZED:
        c = float(correlation) if isinstance(correlation, int | float) else np.nan
        if not -1.0 <= c <= 1.0:
            raise ValueError(
                f"pair_sampling_correlation: correlation={correlation!r} must be a number in "
                f"[-1, 1] or {SYNCHRONIZED!r}"
            )
        return np.full(hws.shape, c)
    heading = np.full(hws.shape, np.nan) if heading_deg is None else np.asarray(heading_deg, float)
    known = np.isfinite(heading)
    out = np.full(hws.shape, REFERENCE_SAMPLING_CORRELATION)
    if known.any():
        from flidar_uq.physics.lidar_response import lidar_pair_correlation

        out[known] = lidar_pair_correlation(
            heading[known],
            lidar,
            synchronized=True,
            hws_ms=float(np.median(hws)),
            height_m=float(np.median(np.asarray(height_m, dtype=float))),
            heights_in_turn=sampling.get("heights_in_turn", 1),
            refocus_delay_s=tuple(sampling.get("refocus_delay_s", (0.0, 0.0))),
            point_sample_interval_s=sampling.get("point_sample_interval_s", 1.0),
            turbulence_dt_s=sampling.get("turbulence_dt_s"),
            seed=int(seed),
        )
    return out


def record_flags(
    qc_reasons,
    bin_id,
    binned,
    discriminant_negative,
    *,
    fitted: pd.Series,
    status: pd.Series,
    global_converged: bool,
    motion_described=None,
) -> list[str]:
    """Why a record has no (trustworthy) corrected TI: ``;``-joined reasons, "" when none.

    Parameters
    ----------
    qc_reasons : sequence of str
        QC reasons per record ("" or NaN when kept); a QC reason stands alone.
    bin_id : array_like, shape (n_records,)
        Bin id per record (NaN when unbinned).
    binned : array_like of bool, shape (n_records,)
        Record has a bin.
    discriminant_negative : array_like of bool, shape (n_records,)
        The deployment formula has no real root at the posterior medians.
    fitted, status : pandas.Series
        Per bin id: fitted (min_count met) and fit status ("ok" | "failed" | "error").
    global_converged : bool
        Global fit converged (else every record gets ``global_fit_failed``).
    motion_described : array_like of bool, shape (n_records,), optional
        Record motion model: the record has a motion description (else
        ``no_motion_description``); bins and their fits then do not matter.

    Returns
    -------
    list of str
        One flag string per record: ``unbinned``, ``bin_not_fitted``, ``bin_failed``,
        ``bin_error`` (bin motion model), ``no_motion_description`` (record motion model),
        ``discriminant_negative``, ``global_fit_failed`` or the QC reason.
    """
    reasons = [[r] if isinstance(r, str) and r else [] for r in qc_reasons]
    for i in range(len(reasons)):
        if reasons[i]:
            continue
        if motion_described is not None:
            if not motion_described[i]:
                reasons[i].append("no_motion_description")
            elif discriminant_negative[i]:
                reasons[i].append("discriminant_negative")
            continue
        if not binned[i]:
            reasons[i].append("unbinned")  # kept by QC but a binning variable is missing
            continue
        b = int(bin_id[i])
        if not bool(fitted.get(b, False)):
            reasons[i].append("bin_not_fitted")
        elif status.get(b) != "ok":
            reasons[i].append("bin_failed" if status.get(b) == "failed" else "bin_error")
        elif discriminant_negative[i]:
            reasons[i].append("discriminant_negative")
    if not global_converged:
        for r in reasons:
            r.append("global_fit_failed")
    return [";".join(r) for r in reasons]


@dataclass(frozen=True)
class PropagationSettings:
    """The scalar options of the propagation (the library default 400 draws; the pipeline's
    are :meth:`flidar_uq.correction.campaign.CorrectionSettings.propagation`).

    Attributes
    ----------
    ndraws : int
        Posterior draws propagated per record (-).
    credible_mass : float
        Equal-tailed credible mass in (0, 1) (-).
    speed_bin_width_ms : float
        Width of the speed bins of :func:`speed_bin_statistics` (m/s), centred on
        multiples of it (:func:`flidar_uq.data.binning.speed_bin_ms`).
    scan_period_s : float or None
        A CW lidar's scan duration (s), for the head-translation term (the record model,
        or a bin-motion global fit with the lever-arm model); None: the lidar's.
    lidar : str, LidarGeometry, mapping or None
        The floating lidar (config ``campaign.lidar``; None: the ZephIR 300): the record
        model's sigma_Z is that lidar's (:func:`flidar_uq.inference.record_motion.motion_gram`;
        a DBS lidar's from its beam timing and the record's heading).
    """

    ndraws: int = 400
    credible_mass: float = 0.9
    speed_bin_width_ms: float = 1.0
    scan_period_s: float | None = None
    lidar: object = None

    def quantile_levels(self) -> list[float]:
        """Lower bound, median and upper bound of the equal-tailed interval (-)."""
        if not 0.0 < self.credible_mass < 1.0:
            raise ValueError(f"credible_mass={self.credible_mass} must be in (0, 1)")
        return [(1.0 - self.credible_mass) / 2.0, 0.5, (1.0 + self.credible_mass) / 2.0]


@dataclass(frozen=True)
class PointTarget:
    """What turns the deployment formula's std into the point std (step 4 of the module
    docstring; :meth:`flidar_uq.correction.reference.Reference.noise` gives the first two).

    Attributes
    ----------
    lidar_std_ratio : array_like, shape (n_records,), or None
        Std of a motionless lidar over the point std per record (-), from
        :func:`flidar_uq.physics.lidar_response.lidar_std_ratio`. Given: the corrected std
        and TI are point values (the motionless-lidar value divided by it). None: they are
        the values a motionless lidar of this type would measure.
    point_log_sd : array_like, shape (n_records,), or None
        Std of ``log(motionless-lidar std / point std)`` per record (-), with
        ``lidar_std_ratio``: each draw is multiplied by ``exp(N(0, sd^2))`` so that the
        intervals are for the point std. None: no scatter.
    lidar_std_ratio_log_sd : float or array_like of shape (n_records,)
        Prior sd of ``log g`` (-), with ``lidar_std_ratio``: every posterior draw divides
        by ``g exp(sd z)``, ``z ~ N(0, 1)`` one number per draw shared by all records (the
        ratio's error is systematic: probe-volume averaging, stability), ``sd`` one value
        or one per record. It is in the draws, the
        group statistics and ``ti_corrected_lo_total`` / ``ti_corrected_hi_total``; the
        per-record interval ``ti_corrected_lo`` / ``ti_corrected_hi`` is given ``g``.
        0: g exact.
    reference_sampling_correlation : float, array_like of shape (n_records,), or None
        With ``point_log_sd`` (a lidar reference) and a global fit that did not take the
        two lidars' sampling scatter as known (no ``info["pair_log_sd_median"]``):
        correlation ``c`` in [-1, 1] (-) of the reference lidar's and the floating lidar's
        sampling errors against the point wind; the part ``2 (1 - c) sd^2`` of ``kappa^2``
        is not propagated (:func:`split_noise`; :data:`REFERENCE_SAMPLING_CORRELATION`
        for a lidar on its own scan schedule). None: ``kappa`` propagated whole, as
        ``c = 1`` (never narrower; the reference's sampling counted twice when the
        lidars' scans differ).
    reference_pair_log_sd : array_like of shape (n_records,), or None
        With ``reference_sampling_correlation``: the std of ``log(floating lidar's
        motionless std / reference lidar's std)`` their sampling gives (-), the part of
        ``kappa^2`` not propagated (:attr:`flidar_uq.correction.reference.ReferenceNoise.pair_log_sd`:
        ``sd_f^2 + sd_r^2 - 2 c sd_f sd_r``, for lidars of two types). None:
        :func:`reference_pair_log_sd` of ``point_log_sd`` and the correlation (two lidars
        of one type).
    """

    lidar_std_ratio: object = None
    point_log_sd: object = None
    lidar_std_ratio_log_sd: object = 0.0
    reference_sampling_correlation: object = None
    reference_pair_log_sd: object = None

    def checked(self, n: int) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
        """``(g, sd, c)`` for ``n`` records: ``g`` 1 and ``sd`` 0 when not given, ``c`` None.

        Raises
        ------
        ValueError
            If a value is out of range, has not ``n`` entries, or ``point_log_sd`` or a
            positive ``lidar_std_ratio_log_sd`` comes without ``lidar_std_ratio``.
        """
        g_ratio, log_sd, corr = np.ones(n), np.zeros(n), None
        if self.point_log_sd is not None:
            if self.lidar_std_ratio is None:
                raise ValueError("PointTarget: point_log_sd needs lidar_std_ratio")
            log_sd = np.asarray(self.point_log_sd, dtype=float)
            if log_sd.shape != (n,) or np.any(~(log_sd >= 0)):
                raise ValueError(
                    f"PointTarget: point_log_sd must be {n} values >= 0, got shape {log_sd.shape}"
                )
        g_log_sd = np.asarray(self.lidar_std_ratio_log_sd, dtype=float)
        if g_log_sd.shape not in ((), (n,)) or np.any(~(g_log_sd >= 0.0)):
            raise ValueError(
                f"PointTarget: lidar_std_ratio_log_sd={self.lidar_std_ratio_log_sd} must be >= 0 "
                f"(one value or {n} values)"
            )
        if self.reference_sampling_correlation is not None:
            c = np.asarray(self.reference_sampling_correlation, dtype=float)
            corr = np.broadcast_to(c, (n,))
            if np.any(~((corr >= -1.0) & (corr <= 1.0))):
                raise ValueError("PointTarget: reference_sampling_correlation must be in [-1, 1]")
        if self.reference_pair_log_sd is not None:
            pair = np.asarray(self.reference_pair_log_sd, dtype=float)
            if corr is None or pair.shape not in ((), (n,)) or np.any(~(pair >= 0)):
                raise ValueError(
                    f"PointTarget: reference_pair_log_sd must be {n} values >= 0, with "
                    "reference_sampling_correlation"
                )
        if np.any(g_log_sd > 0.0) and self.lidar_std_ratio is None:
            raise ValueError("PointTarget: lidar_std_ratio_log_sd needs lidar_std_ratio")
        if self.lidar_std_ratio is not None:
            g_ratio = np.asarray(self.lidar_std_ratio, dtype=float)
            if g_ratio.shape != (n,) or np.any(~(g_ratio > 0)):
                raise ValueError(
                    f"PointTarget: lidar_std_ratio must be {n} positive values, got shape "
                    f"{g_ratio.shape}"
                )
        return g_ratio, log_sd, corr


@dataclass(frozen=True)
class CorrectedDraws:
    """The corrected TI draws of :func:`draw_corrected_ti` and the per-record numbers taken
    from them before rounding (what :func:`record_summary` needs).

    Attributes
    ----------
    ti : numpy.ndarray of float32, shape (ndraws, n_records)
        The corrected TI draws (-), with the ratio's systematic error; draw ``d`` of every
        record uses the same global posterior draw, so a statistic over records per draw is
        a draw of that statistic's posterior. Stored as float32 (relative rounding 6e-8,
        far below the Monte Carlo error; half the memory: 0.63 GB for 1000 draws of a
        year's 157,680 records): they serve only statistics over records
        (:func:`ti_group_statistics`, the uncertainty budget).
    sigma_quantiles : numpy.ndarray, shape (3, n_records)
        Lower bound, median, upper bound of the corrected std per record (m/s), float64,
        computed record chunk by record chunk from the draws before rounding.
    ti_quantiles : numpy.ndarray, shape (3, n_records)
        The same of the corrected TI (-), given the reference's std ratio ``g``.
    ti_quantiles_total : numpy.ndarray, shape (3, n_records)
        The same with ``g``'s campaign-wide error (equal to ``ti_quantiles`` without it).
    discriminant_negative_frac : numpy.ndarray, shape (n_records,)
        Share of draws with a negative discriminant (-).
    sigma_z_median_ms : numpy.ndarray, shape (n_records,)
        Posterior median of sigma_Z (m/s).
    converged : numpy.ndarray of bool, shape (n_records,)
        Bin and global fit both converged.
    failure_reasons : numpy.ndarray of str, shape (n_records,)
        The fits' failure reasons, ``;``-joined.
    lidar_std_ratio, point_log_sd : numpy.ndarray, shape (n_records,)
        ``g`` (1 when not given) and ``sd`` (0 when not given) of the :class:`PointTarget` (-).
    rho_median : float
        Posterior median of rho (-).
    """

    ti: np.ndarray
    sigma_quantiles: np.ndarray
    ti_quantiles: np.ndarray
    ti_quantiles_total: np.ndarray
    discriminant_negative_frac: np.ndarray
    sigma_z_median_ms: np.ndarray
    converged: np.ndarray
    failure_reasons: np.ndarray
    lidar_std_ratio: np.ndarray
    point_log_sd: np.ndarray
    rho_median: float


class _Propagation:
    """The state of one propagation: the global draws, the random stream and the outputs
    filled record by record (:meth:`deploy`, steps 2-4 of the module docstring)."""

    def __init__(self, records, global_fit, settings, target, hold, seed):
        self.hold = frozenset(hold)
        if not self.hold <= set(UNCERTAINTY_SOURCES):
            raise ValueError(f"hold={sorted(self.hold)} must be among {list(UNCERTAINTY_SOURCES)}")
        for c in ("bin_id", "hws_mean_ms", "hws_std_ms"):
            if c not in records:
                raise ValueError(f"corrected TI: records lack column {c!r}")
        n = len(records)
        self.q = np.asarray(settings.quantile_levels(), dtype=float)
        self.g_ratio, self.log_sd, self.corr = target.checked(n)
        self.with_scatter = target.point_log_sd is not None
        self.pair = None  # the reference's share of a kappa fitted without the pair term
        if self.with_scatter and self.corr is not None:
            given = target.reference_pair_log_sd
            self.pair = (
                reference_pair_log_sd(self.log_sd, self.corr)
                if given is None
                else np.broadcast_to(np.asarray(given, dtype=float), (n,))
            )
        self.ndraws = ndraws = settings.ndraws
        self.rng = np.random.default_rng(as_seedsequence(seed))
        self.m = records["hws_mean_ms"].to_numpy(dtype=float)
        # the TI's denominator (m/s): the mean HWS less the motion's mean error where known
        self.m_ti = self.m.copy()
        self.s = records["hws_std_ms"].to_numpy(dtype=float)
        self.global_fit = global_fit
        self.g_idx = self.rng.choice(global_fit.flat("rho").size, size=ndraws, replace=True)
        self.held_globals = _held_global_draws(global_fit, self.g_idx, self.hold)
        self.rho = self.global_draws("rho")
        self.kappa = self.global_draws("kappa")
        # kappa of a fit that took the lidars' sampling scatter as known is the floating
        # lidar's own noise; otherwise the reference's share is taken out here (split_noise)
        self.pair_known = global_fit.info.get("pair_log_sd_median") is not None
        self.rho_med = float(np.median(global_fit.flat("rho")))
        # the ratio's systematic error: one factor per draw, shared by every record (drawn
        # whatever its sd, so that the other random numbers do not depend on it)
        g_log_sd = np.atleast_1d(np.asarray(target.lidar_std_ratio_log_sd, dtype=float))
        self.g_draw = np.exp(-g_log_sd[None, :] * self.rng.standard_normal((ndraws, 1)))
        self.systematic = bool(np.any(g_log_sd > 0.0)) and "reference_response" not in self.hold
        self.sq = np.full((self.q.size, n), np.nan)  # corrected std quantiles (m/s)
        self.tq = np.full((self.q.size, n), np.nan)  # and of the corrected TI (-), given g
        self.tq_total = self.tq.copy()  # and with g's systematic error
        self.ti = np.full((ndraws, n), np.nan, dtype=np.float32)  # 4 bytes per draw
        self.neg_frac = np.full(n, np.nan)
        self.sz_med = np.full(n, np.nan)
        self.conv = np.zeros(n, dtype=bool)
        self.reasons = np.full(n, "", dtype=object)
        self.global_reasons = [f"global: {r}" for r in global_fit.failure_reasons]

    def global_draws(self, name):
        """Posterior draws of a global parameter (conditioned on the held ones), (ndraws, 1)."""
        return self.held_globals.get(name, self.global_fit.flat(name)[self.g_idx])[:, None]

    def own_noise(self, cols):
        """The floating lidar's relative noise on s for the records ``cols`` (indices),
        (ndraws, cols.size) or (ndraws, 1)."""
        if self.pair_known or self.pair is None:
            return self.kappa
        return _own_noise(self.kappa, self.pair[cols][None, :])

    def deploy(self, cols, sz, tau0=0.0, rho=None):
        """Steps 2-4 of the module docstring for the records at the indices ``cols`` (sZ
        draws given; the floating lidar's relative sampling sd about its motionless-lidar std from
        :meth:`own_noise`, ``tau0`` an absolute one, m/s; ``rho`` each record's correlation
        draws (ndraws, cols.size), default the global ``rho``). The random numbers are drawn for
        all of them (z, then e: the stream does not depend on the blocks); the rest runs on
        blocks of records to bound the temporaries."""
        hold, s, m = self.hold, self.s, self.m_ti
        z = self.rng.standard_normal((self.ndraws, cols.size))
        e = self.rng.standard_normal((self.ndraws, cols.size))
        if "sampling" in hold:
            z[:] = 0.0
        tau0 = np.broadcast_to(tau0, z.shape)
        for j in range(0, cols.size, _DEPLOY_BLOCK):
            b, cb = slice(j, j + _DEPLOY_BLOCK), cols[j : j + _DEPLOY_BLOCK]
            zb, t0 = z[:, b], tau0[:, b]
            rb = np.broadcast_to(self.own_noise(cb), zb.shape)
            s_star = s[cb][None, :] / np.maximum(1.0 + rb * zb, _PIVOT_FLOOR)
            if np.any(t0):  # s = mu + sqrt((kappa mu)^2 + tau0^2) z solved for mu
                for _ in range(_PIVOT_ITERATIONS):
                    s_star = s[cb][None, :] - zb * np.sqrt((rb * s_star) ** 2 + t0**2)
            s_star = np.abs(s_star)
            szb = sz[:, b]
            if "motion" in hold:
                szb = np.broadcast_to(np.median(szb, axis=0), szb.shape)
            c, neg = corrected_std(s_star, szb, self.rho if rho is None else rho[:, b])
            # point std (g = 1, sd = 0: the reference's own std, a cup's or sonic's point std)
            ref = 0.0 if "reference_response" in hold else e[:, b]
            sig = c * (np.exp(self.log_sd[cb] * ref) / self.g_ratio[cb])
            self.sq[:, cb], self.tq[:, cb] = _record_quantiles(sig, m[cb], self.q)
            if self.systematic:  # the campaign-wide error of g: in the draws and the total
                sig = sig * (self.g_draw[:, cb] if self.g_draw.shape[1] > 1 else self.g_draw)
                self.tq_total[:, cb] = _record_quantiles(sig, m[cb], self.q)[1]
            else:
                self.tq_total[:, cb] = self.tq[:, cb]
            with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
                self.ti[:, cb] = sig / m[cb][None, :]
            self.neg_frac[cb] = np.mean(neg, axis=0)
            self.sz_med[cb] = np.median(szb, axis=0)

    def result(self) -> CorrectedDraws:
        """The filled outputs."""
        return CorrectedDraws(
            ti=self.ti,
            sigma_quantiles=self.sq,
            ti_quantiles=self.tq,
            ti_quantiles_total=self.tq_total,
            discriminant_negative_frac=self.neg_frac,
            sigma_z_median_ms=self.sz_med,
            converged=self.conv,
            failure_reasons=self.reasons,
            lidar_std_ratio=self.g_ratio,
            point_log_sd=self.log_sd,
            rho_median=self.rho_med,
        )


def _propagate_record_model(p: _Propagation, records, surrogate, lidar, scan, grams) -> None:
    """Record motion model: each record's sigma_Z from its own measured motion, with the
    global lever arm, motion scale and the record-level motion error kappa_z (with a DBS
    lidar's record's own sampling part added in quadrature, as in the record fit), and each
    record's correlation ``tanh(atanh(rho) + rho_sd N(0, 1))`` (a DBS lidar's with its
    record's known part added in quadrature, as in the record fit; the scatter of its
    realised correlation, :mod:`flidar_uq.inference.record_fit`; held with ``rho``), record
    chunk by record chunk (:data:`_RECORD_CHUNK`). ``grams``: the chunks' Gram tables
    by (description, chunk start), filled here and read where already there."""
    global_fit, n = p.global_fit, len(records)
    lever = p.global_draws("lever_arm_m")
    scale = p.global_draws("motion_scale")
    kappa_z = p.global_draws("kappa_z")
    hull = p.global_draws("hull_response")
    rho_sd = p.global_draws("rho_sd") if "rho_sd" in global_fit.draws else None
    rho_z = np.arctanh(p.rho)  # Fisher z of the campaign's correlation
    translation = global_fit.info.get("hull_model") != "rotation_only"  # the kept model
    hull_reference = global_fit.info.get("hull_reference", "wave_follower")
    cols = [*GRAM_COLUMNS, "translation_measured", *DBS_COLUMNS]
    described = np.zeros(n, dtype=bool)
    described_by = (lidar, scan, translation, hull_reference)
    for start in range(0, n, _RECORD_CHUNK):
        # each record's Gram is its own: computed chunk by chunk (bounds the temporaries
        # of the band sums, ~2.5 kB a record), once for the passes over the same records
        chunk, key = slice(start, start + _RECORD_CHUNK), (*described_by, start)
        if key not in grams:
            grams[key] = motion_gram(
                records.iloc[chunk],
                lidar=lidar,
                surrogate=surrogate,
                scan_period_s=scan,
                translation=translation,
                hull=hull_reference,
            )
            grams[key] = grams[key][[c for c in cols if c in grams[key]]]
        gram = grams[key]
        ok = np.all(np.isfinite(gram.to_numpy(dtype=float)), axis=1)
        described[chunk] = ok
        if not ok.any():
            continue
        g = {c: gram[c].to_numpy()[ok][None, :] for c in gram.columns}
        sz, mean_z = gram_hws_error_ms(g, lever_arm_m=lever, hull_response=hull, motion_scale=scale)
        err = p.rng.standard_normal((p.ndraws, int(ok.sum())))
        # a DBS lidar's record adds the spread its output's sampling makes (CW: none)
        err *= np.sqrt(kappa_z**2 + g.get(SAMPLING_COLUMN, 0.0))
        sz *= np.exp(err, out=err)  # sz exp(kappa_z N(0, 1)), in place
        del err
        rho = None
        if rho_sd is not None:  # drawn whatever is held: the other draws do not move
            rho = p.rng.standard_normal((p.ndraws, int(ok.sum())))
            # a DBS lidar's record adds the scatter its output's lines make, on rho itself
            known = (
                gram_rho_sampling_var(g, lever_arm_m=lever, hull_response=hull, motion_scale=scale)
                / (1.0 - p.rho**2) ** 2
            )
            rho *= 0.0 if "rho" in p.hold else np.sqrt(rho_sd**2 + known)
            rho = np.tanh(rho_z + rho)
        rows = start + np.flatnonzero(ok)
        if CROSS_WIND_COLUMNS[0] in g:  # a DBS lidar's mean HWS error (its posterior median)
            p.m_ti[rows] = p.m[rows] - np.median(mean_z, axis=0)
        del mean_z
        p.deploy(rows, sz, rho=rho)
    p.reasons[~described] = "no motion description (IMU columns missing)"
    p.conv[described] = global_fit.converged
    p.reasons[described] = "; ".join(p.global_reasons)


def _propagate_bin_model(p: _Propagation, records, bin_fits, surrogate, scan) -> None:
    """Bin motion model: each record's sigma_Z from its bin's posterior (surrogate at the
    record's mean HWS, times the motion scale, plus the head translation of the lever-arm
    model; a DBS lidar's own beam-pair terms at the record's wind direction relative to
    the beams, :meth:`flidar_uq.inference.BinFit.sigma_z_draws`), bin by bin in the order
    of first appearance."""
    global_fit = p.global_fit
    tau0 = p.global_draws("tau0_ms")
    lever = p.global_draws("lever_arm_m") if "lever_arm_m" in global_fit.draws else None
    scale = p.global_draws("motion_scale") if "motion_scale" in global_fit.draws else 1.0
    bins = records["bin_id"].to_numpy()
    beta = records_wind_body_deg(records)
    fits = {f.bin_id: f for f in bin_fits}
    for b in pd.unique(bins):
        mask = bins == b
        f = fits.get(b)
        if f is None:
            p.reasons[mask] = "no fit for this bin"
            continue
        nb = int(f.flat("amplitude_deg").size)
        idx = p.rng.choice(nb, size=p.ndraws, replace=p.ndraws > nb)
        sz, u2, corr = f._motion_draws(p.m[mask], surrogate, idx, scan, beta[mask])
        if lever is None:  # motion-model scale of the surrogate (1 if absent)
            sz = scale * sz
        else:  # plus the head translation of the lever-arm model
            sz = effective_sigma_z_ms(sz, u2, lever, scale, corr)
        p.deploy(np.flatnonzero(mask), sz, tau0)
        p.conv[mask] = f.converged and global_fit.converged
        p.reasons[mask] = "; ".join([*f.failure_reasons, *p.global_reasons])


def draw_corrected_ti(
    records: pd.DataFrame,
    bin_fits,
    global_fit,
    *,
    surrogate=None,
    settings: PropagationSettings = PropagationSettings(),
    target: PointTarget = PointTarget(),
    seed,
) -> CorrectedDraws:
    """Corrected std and TI as posterior draws per record (steps 1-4 of the module docstring).

    Parameters
    ----------
    records : pandas.DataFrame
        Records with ``bin_id``, ``hws_mean_ms`` (m/s), ``hws_std_ms`` (m/s) and IMU
        statistics.
    bin_fits : sequence of BinFit
        The bin fits (bin motion model; ignored by the record motion model).
    global_fit : GlobalFit
    surrogate : SigmaZSurrogate, optional
        Default ``get_surrogate(settings.lidar)``.
    settings : PropagationSettings
        Draws, credible mass, scan period, lidar.
    target : PointTarget
        The point target (default: none, the motionless lidar's std).
    seed : int or numpy.random.SeedSequence

    Returns
    -------
    CorrectedDraws
        The float32 TI draws and the per-record quantiles (float64, from the draws before
        rounding); :func:`record_summary` makes the per-record table of them.

    Raises
    ------
    ValueError
        If ``settings.credible_mass`` is not in (0, 1), a required column is missing or
        ``target`` is inconsistent (:meth:`PointTarget.checked`).
    """
    return draw_held_ti(
        records, bin_fits, global_fit, (), surrogate=surrogate, settings=settings,
        target=target, seed=seed,
    )  # fmt: skip


def draw_held_ti(
    records: pd.DataFrame,
    bin_fits,
    global_fit,
    hold: Collection[str],
    *,
    surrogate=None,
    settings: PropagationSettings = PropagationSettings(),
    target: PointTarget = PointTarget(),
    seed,
    record_grams: dict | None = None,
) -> CorrectedDraws:
    """:func:`draw_corrected_ti` with uncertainty sources held at their median (one pass of
    the uncertainty budget, :mod:`flidar_uq.correction.uncertainty_budget`).

    ``hold`` (of :data:`UNCERTAINTY_SOURCES`): ``"motion"`` (the global motion parameters,
    and each record's sigma_Z at its posterior median), ``"rho"``, ``"noise_model"``
    (``kappa``, ``tau0``); the other global parameters are then conditioned on the held
    ones (Gaussian approximation of the joint posterior), ``"reference_response"`` (the
    point scatter ``e = 0``, and no systematic error of ``g``), ``"sampling"`` (``z = 0``:
    the measured 10-min std taken as noise-free). The same random numbers are drawn
    whatever is held (common random numbers: with the same ``seed`` the passes differ only
    by the held source; an empty ``hold`` is :func:`draw_corrected_ti`). The other
    parameters and the result are those of :func:`draw_corrected_ti`.

    ``record_grams``: a dict the caller keeps over its passes of the same ``records`` and
    ``global_fit`` (unchanged): the record motion model's Gram matrices
    (:func:`~flidar_uq.inference.record_motion.motion_gram`, ~80 bytes a record) are
    computed in the first pass and read in the others. Default None: computed for this
    call alone.

    Raises
    ------
    ValueError
        As :func:`draw_corrected_ti`, or if a source of ``hold`` is not one of
        :data:`UNCERTAINTY_SOURCES`.
    """
    p = _Propagation(records, global_fit, settings, target, hold, seed)
    lidar = settings.lidar
    if surrogate is None and lidar is not None:
        surrogate = get_surrogate(lidar)
    surrogate = default_surrogate(surrogate)
    scan = settings.scan_period_s
    scan = get_lidar(lidar or "zephir300").scan_period_s if scan is None else scan
    if is_record_model(global_fit):
        grams = {} if record_grams is None else record_grams
        # each time stamp's shear from all its heights, before the records are chunked
        _propagate_record_model(p, with_shear_exponent(records), surrogate, lidar, scan, grams)
    else:
        _propagate_bin_model(p, records, bin_fits, surrogate, scan)
    return p.result()


def record_summary(
    records: pd.DataFrame, draws: CorrectedDraws, baseline: tuple[np.ndarray, float]
) -> pd.DataFrame:
    """The per-record table of the corrected std and TI, beside Gutiérrez-Antuñano et al.'s
    (2018) U / C / PC laws.

    Parameters
    ----------
    records : pandas.DataFrame
        The records of ``draws`` (``bin_id``, ``hws_mean_ms``, ``hws_std_ms``; m/s).
    draws : CorrectedDraws
        :func:`draw_corrected_ti` (or :func:`draw_held_ti`) of ``records``.
    baseline : (numpy.ndarray, float)
        :func:`variance_law_baselines` of ``records`` with the surrogate of ``draws``:
        sigma_Z per record (m/s) and rho (-); NaN for none.

    Returns
    -------
    pandas.DataFrame
        Index of ``records``; columns ``bin_id``, ``hws_mean_ms``, ``ti_uncorrected``,
        ``sigma_corrected_median_ms``, ``sigma_corrected_lo_ms``, ``sigma_corrected_hi_ms``,
        ``ti_corrected_median``, ``ti_corrected_lo``, ``ti_corrected_hi`` (given the
        reference's std ratio ``g``: the record's own uncertainty),
        ``ti_corrected_lo_total``, ``ti_corrected_hi_total`` (with ``g``'s campaign-wide
        error, ``PointTarget.lidar_std_ratio_log_sd``; equal to the former when it is 0),
        ``discriminant_negative`` (the formula at the measured std, posterior-median sZ and
        rho has no real root), ``discriminant_negative_frac`` (share of draws),
        ``sigma_z_median_ms``, ``converged`` (bin and global fit both converged),
        ``failure_reasons``, ``lidar_std_ratio`` (1 when not given), ``point_log_sd`` (0
        when not given), and the baselines ``ti_u``, ``ti_c``, ``ti_pc``, ``rho_seed``
        (Gutiérrez-Antuñano et al.'s (2018) laws, as published: they estimate the reference
        instrument's std).
    """
    m = records["hws_mean_ms"].to_numpy(dtype=float)
    s = records["hws_std_ms"].to_numpy(dtype=float)
    sz_med, sq, tq, tq_total = (
        draws.sigma_z_median_ms,
        draws.sigma_quantiles,
        draws.ti_quantiles,
        draws.ti_quantiles_total,
    )
    with np.errstate(invalid="ignore", divide="ignore"):
        sz_point = np.where(np.isfinite(sz_med), sz_med, 0.0)
        _, neg_point = corrected_std(s, sz_point, draws.rho_median)
    sz_seed, rho_seed = baseline
    with np.errstate(invalid="ignore", divide="ignore"):
        # Eqs. (16), (17) of Gutiérrez-Antuñano et al. (2018) inverted, and Eq. (15)
        ti_u = corrected_std(s, sz_seed, 0.0)[0] / m
        ti_c = corrected_std(s, sz_seed, 1.0)[0] / m
        rho_pc = rho_seed if np.isfinite(rho_seed) else np.nan
        ti_pc = corrected_std(s, sz_seed, np.clip(rho_pc, -1, 1))[0] / m
        ti_unc = s / m
    return pd.DataFrame(
        {
            "bin_id": records["bin_id"].to_numpy() if "bin_id" in records else np.nan,
            "hws_mean_ms": m,
            "ti_uncorrected": ti_unc,
            "sigma_corrected_median_ms": sq[1],
            "sigma_corrected_lo_ms": sq[0],
            "sigma_corrected_hi_ms": sq[2],
            "ti_corrected_median": tq[1],
            "ti_corrected_lo": tq[0],
            "ti_corrected_hi": tq[2],
            "ti_corrected_lo_total": tq_total[0],
            "ti_corrected_hi_total": tq_total[2],
            "discriminant_negative": neg_point & np.isfinite(sz_med),
            "discriminant_negative_frac": draws.discriminant_negative_frac,
            "sigma_z_median_ms": sz_med,
            "converged": draws.converged,
            "failure_reasons": draws.failure_reasons,
            "lidar_std_ratio": draws.lidar_std_ratio,
            "point_log_sd": draws.point_log_sd,
            "ti_u": ti_u,
            "ti_c": ti_c,
            "ti_pc": ti_pc,
            "rho_seed": rho_seed,
        },
        index=records.index,
    )


def speed_bin_keys(records: pd.DataFrame, speed_bin_width_ms: float = 1.0) -> pd.DataFrame:
    """Group keys per height and speed bin: ``height_m`` (m; 0 when the records have no
    height) and ``hws_bin_ms`` (m/s, :func:`flidar_uq.data.binning.speed_bin_ms` of the
    mean HWS at ``speed_bin_width_ms``), index of ``records``."""
    n = len(records)
    heights = records["height_m"].to_numpy(dtype=float) if "height_m" in records else np.zeros(n)
    m = records["hws_mean_ms"].to_numpy(dtype=float)
    return pd.DataFrame(
        {"height_m": heights, "hws_bin_ms": speed_bin_ms(m, speed_bin_width_ms)},
        index=records.index,
    )


def speed_bin_statistics(
    ti_draws,
    per_record: pd.DataFrame,
    records: pd.DataFrame,
    settings: PropagationSettings = PropagationSettings(),
    *,
    min_count: int = 2,
    seed=0,
) -> pd.DataFrame:
    """The TI statistics per height and speed bin (:func:`speed_bin_keys` at
    ``settings.speed_bin_width_ms``; :func:`ti_group_statistics` at
    ``settings.credible_mass``): mean, representative TI (mean + 1.28 std), 90th percentile
    and std of the corrected TI with credible intervals of the statistic, beside the
    uncorrected and Gutiérrez-Antuñano et al. (2018) values. ``ti_draws`` (ndraws,
    n_records) are :attr:`CorrectedDraws.ti` (-), ``per_record`` the
    :func:`record_summary` of ``records``; ``seed`` that of the population model."""
    keys = speed_bin_keys(records, settings.speed_bin_width_ms)
    return ti_group_statistics(
        ti_draws,
        per_record,
        keys,
        credible_mass=settings.credible_mass,
        min_count=min_count,
        seed=seed,
    )


def corrected_ti(
    records: pd.DataFrame,
    bin_fits,
    global_fit,
    *,
    surrogate=None,
    settings: PropagationSettings = PropagationSettings(),
    target: PointTarget = PointTarget(),
    seed,
) -> tuple[pd.DataFrame, pd.DataFrame]:
    """Corrected std and TI summarised per record and per speed bin: :func:`draw_corrected_ti`,
    :func:`record_summary` (baselines of :func:`variance_law_baselines` with the same
    surrogate) and :func:`speed_bin_statistics` (at least 2 records per bin).

    The parameters are those of :func:`draw_corrected_ti`.

    Returns
    -------
    per_record : pandas.DataFrame
        :func:`record_summary`.
    per_bin : pandas.DataFrame
        :func:`speed_bin_statistics`.
    """
    if surrogate is None and settings.lidar is not None:
        surrogate = get_surrogate(settings.lidar)
    surrogate = default_surrogate(surrogate)
    draws = draw_corrected_ti(
        records, bin_fits, global_fit, surrogate=surrogate, settings=settings, target=target,
        seed=seed,
    )  # fmt: skip
    per_record = record_summary(records, draws, variance_law_baselines(records, surrogate))
    bins = speed_bin_statistics(draws.ti, per_record, records, settings, seed=seed)
    return per_record, bins


def ti_group_statistics(
    ti_draws,
    per_record: pd.DataFrame,
    keys: pd.DataFrame,
    *,
    credible_mass: float = 0.9,
    min_count: int = 2,
    seed=0,
    shift=None,
) -> pd.DataFrame:
    """TI statistics per group of records (height x speed bin, sector, sea state) with
    credible intervals of the statistic itself, from the joint posterior draws.

    The statistics are those of the group's population of true TI
    (:func:`flidar_uq.correction.bin_population.population_statistic_draws`): each record's
    corrected TI is a noisy measurement of its true TI, the records' own errors are taken
    out of the population's spread by a hierarchical (measurement-error) model, and the
    error shared by the group's records (the global posterior) is carried draw by draw.
    Reported per statistic: the posterior median and equal-tailed interval of the mean, the
    sd, the representative TI ``mean + 1.28 sd`` (IEC 61400-1 ed. 3) and the 90 % quantile
    (the representative TI of IEC 61400-1 ed. 4) of the group's records' true TI. This is
    the uncertainty of the statistic over the measured records, not the sampling
    uncertainty of the site's climate.

    Parameters
    ----------
    ti_draws : numpy.ndarray, shape (ndraws, n_records)
        Corrected TI draws (-), columns in the order of ``per_record``; float32 (as
        :attr:`CorrectedDraws.ti` holds them) or float64, the statistics are computed in
        float64.
    per_record : pandas.DataFrame
        :func:`record_summary`'s per-record table: ``converged``, ``ti_uncorrected``,
        ``ti_u``, ``ti_c``, ``ti_pc`` (the last three optional).
    keys : pandas.DataFrame
        Group key columns, one row per record (same order); rows with a NaN key are left out.
    credible_mass : float
        Equal-tailed credible mass in (0, 1).
    min_count : int
        Fewest records with a corrected TI for the statistics of a group (>= 2): converged
        records first, else every record with finite draws (``converged`` False); groups
        below it keep their count and NaN statistics.
    seed : int or numpy.random.SeedSequence
        The population model's random numbers (group ``k`` of the sorted keys uses spawn
        key ``k``).
    shift : (numpy.ndarray, numpy.ndarray), optional
        The regime discrepancy's draws
        (:meth:`flidar_uq.correction.regime_discrepancy.RegimeDiscrepancy.draws`), one
        regime index per record of ``per_record``; None: none.

    Returns
    -------
    pandas.DataFrame
        One row per group (sorted by the keys): the key columns, ``n`` (records with a
        corrected TI in the statistics), ``ti_mean``, ``ti_rep``, ``ti_p90``, ``ti_sd``
        (posterior medians of the statistic) each followed by its ``_lo`` / ``_hi`` bounds,
        the same statistics of the uncorrected TI of the same records
        (``ti_mean_uncorrected``, ``ti_sd_uncorrected``, ``ti_rep_uncorrected``,
        ``ti_p90_uncorrected``), ``n_not_converged`` (records whose fit did not converge, left out unless
        ``converged`` is False),
        ``converged`` (False: the group has fewer than ``min_count`` converged records, and
        its statistics are those of every record with finite draws, converged or not),
        ``n_zero_draws`` (records of the statistics whose every draw is 0: the motion's
        variance reaches the measured one; the statistics stay finite, each such record
        counting as a TI of :data:`~flidar_uq.correction.bin_population.LOG_FLOOR_TI` on the
        log scale, and are 0 when every record is one) and Gutiérrez-Antuñano et al.'s (2018) representative TI ``ti_rep_u``, ``ti_rep_c``, ``ti_rep_pc`` where
        ``per_record`` has them.
    """
    if not 0.0 < credible_mass < 1.0:
        raise ValueError(f"ti_group_statistics: credible_mass={credible_mass} must be in (0, 1)")
    if int(min_count) < 2:
        raise ValueError(f"ti_group_statistics: min_count={min_count} must be >= 2")
    ti_draws = np.asarray(ti_draws)
    if ti_draws.dtype.kind != "f":
        ti_draws = ti_draws.astype(float)
    if ti_draws.ndim != 2 or ti_draws.shape[1] != len(per_record) or len(keys) != len(per_record):
        raise ValueError(
            f"ti_group_statistics: ti_draws shape {ti_draws.shape}, {len(per_record)} records "
            f"and {len(keys)} key rows do not match"
        )
    q = [(1.0 - credible_mass) / 2.0, 0.5, (1.0 + credible_mass) / 2.0]
    key_cols = list(keys.columns)
    conv = per_record["converged"].to_numpy(dtype=bool)
    finite = finite_records(ti_draws) if ti_draws.shape[0] else conv
    usable = conv & finite
    zero = _all_draws(ti_draws, lambda b: b <= 0.0) & (ti_draws.shape[0] > 0)
    kv = keys.reset_index(drop=True)
    valid = kv.notna().all(axis=1).to_numpy()
    stats = ("ti_mean", "ti_sd", "ti_rep", "ti_p90")
    point_log_sd = (
        per_record["point_log_sd"].to_numpy(dtype=float) if "point_log_sd" in per_record else None
    )
    rows = []
    root = as_seedsequence(seed)
    groups = kv[valid].groupby(key_cols, sort=True).indices.items()
    for g, (key, idx) in enumerate(groups):
        members = np.flatnonzero(valid)[idx]
        key = key if isinstance(key, tuple) else (key,)
        k = members[usable[members]]
        # too few converged records: the statistics of every finite one, said not converged
        from_converged = k.size >= min_count or members[finite[members]].size < min_count
        if not from_converged:
            k = members[finite[members]]
        row = dict(zip(key_cols, key, strict=True))
        row["n"] = int(k.size)
        row["n_not_converged"] = int((~conv[members]).sum())
        row["converged"] = from_converged
        row["n_zero_draws"] = int(zero[k].sum())
        enough = k.size >= min_count
        if enough:
            sub_seed = np.random.SeedSequence(root.entropy, spawn_key=(*root.spawn_key, g))
            rng = np.random.default_rng(sub_seed)
            draws = population_statistic_draws(
                ti_draws, rng, k, shift=shift, point_log_sd=point_log_sd
            )
            mean, sd, rep, p90 = draws
            for name, x in zip(stats, (mean, sd, rep, p90), strict=True):
                lo, med, hi = np.quantile(x, q)
                row.update({name: med, f"{name}_lo": lo, f"{name}_hi": hi})
        else:
            row.update({f"{n}{s}": np.nan for n in stats for s in ("", "_lo", "_hi")})
        unc = per_record["ti_uncorrected"].to_numpy(dtype=float)[k]
        unc = unc[np.isfinite(unc)]
        for name, x in zip(stats, _statistics(unc, axis=0), strict=True):
            row[f"{name}_uncorrected"] = float(x) if enough and unc.size >= 2 else np.nan
        for col, out in (("ti_u", "ti_rep_u"), ("ti_c", "ti_rep_c"), ("ti_pc", "ti_rep_pc")):
            if col in per_record:
                v = per_record[col].to_numpy(dtype=float)[k]
                row[out] = representative_ti(v) if enough else np.nan
        rows.append(row)
    cols = [*key_cols, "n"]
    cols += [
        f"{n}{s}" for n in ("ti_mean", "ti_rep", "ti_p90", "ti_sd") for s in ("", "_lo", "_hi")
    ]
    cols += [f"{n}_uncorrected" for n in stats] + ["n_not_converged", "converged", "n_zero_draws"]
    cols += [c for c in ("ti_rep_u", "ti_rep_c", "ti_rep_pc") if rows and c in rows[0]]
    return pd.DataFrame(rows, columns=cols)


#: Draw values (float64) held at once by the group statistics (bounds their memory).
_BLOCK_VALUES = 4_000_000


def finite_records(ti_draws) -> np.ndarray:
    """Records whose draws are all finite: ``np.all(np.isfinite(ti_draws), axis=0)`` for
    ``ti_draws`` of shape (ndraws, n_records), computed on blocks of records (no
    ndraws x n_records temporary); a bool array of shape (n_records,)."""
    return _all_draws(ti_draws, np.isfinite)


def _all_draws(ti_draws, test) -> np.ndarray:
    """Records (columns of ``ti_draws``, (ndraws, n_records)) whose every draw passes
    ``test`` (elementwise, to bool), computed on blocks of records."""
    ti_draws = np.asarray(ti_draws)
    out = np.empty(ti_draws.shape[1], dtype=bool)
    step = max(1, _BLOCK_VALUES // max(ti_draws.shape[0], 1))
    for j in range(0, ti_draws.shape[1], step):
        out[j : j + step] = np.all(test(ti_draws[:, j : j + step]), axis=0)
    return out


def _statistics(ti, axis: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Mean, sample std, representative TI (IEC 61400-1) and 90th percentile along ``axis``."""
    ti = np.asarray(ti, dtype=float)
    if ti.shape[axis] < 2:
        nan = np.full(np.delete(ti.shape, axis), np.nan)
        return nan, nan, nan, nan
    mean = np.mean(ti, axis=axis)
    sd = np.std(ti, axis=axis, ddof=1)
    return mean, sd, mean + REPRESENTATIVE_TI_FACTOR * sd, np.quantile(ti, 0.9, axis=axis)
