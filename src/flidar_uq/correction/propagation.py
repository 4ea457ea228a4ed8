"""Posterior draws -> motion-corrected std and TI with credible intervals, per record and per speed bin.

For every record ``i`` and posterior draw ``d`` (docs/inference.md, "Propagation"):

1. ``sZ_id`` from the record's bin posterior (surrogate at the record's mean HWS, times
   the global ``motion_scale_d`` and plus the head translation ``L_d^2 u^2`` if the global
   fit chose a model with them);
   ``rho_d, tau0_d, kappa_d[, L_d]`` from the global posterior (independent pairing: cut);
2. the record's own sampling noise: ``s*_id = s_i + tau_id z_id`` with
   ``tau_id^2 = (kappa_d s_i)^2 + tau0_d^2`` and ``z ~ N(0, 1)`` (the observation model
   read backwards: given the measured ``s_i`` the noise-free std is uncertain by ``tau``);
3. the deployment formula ``c = -rho sZ + sqrt(s*^2 - (1 - rho^2) sZ^2)``
   (:func:`flidar_uq.physics.variance_laws.corrected_std`, Eq. 15 of seed 000 inverted) and
   ``TI = c / m_i``. Draws with a negative discriminant give ``c = 0`` and are counted.
4. the point (cup-like) std, according to the reference the model is calibrated against
   (:func:`reference_target`): a cup or sonic -> ``c`` is the point std already (the noise
   term ``kappa`` has absorbed the floating-lidar-vs-point scatter); a fixed (motionless)
   lidar -> ``c`` is the std that lidar would measure and the point std is
   ``c exp(e_id - b_d) / g_i``, with ``g_i`` that lidar's mean std ratio to the point wind
   (:func:`flidar_uq.physics.lidar_response.lidar_std_ratio`), ``e_id ~ N(0, sd_i^2)`` its
   record-to-record scatter (:func:`flidar_uq.physics.lidar_response.lidar_point_log_sd`)
   and ``b_d ~ N(0, sd_g^2)`` one draw per posterior draw for all records: the prior of the
   ratio's own error (probe-volume averaging, stability; docs/lidar-response.md).

Baselines beside it: uncorrected TI and seed 000's U / C / PC laws (Eqs. 15-17) with
sigma_Z from the surrogate at the bin's median IMU amplitude and period and seed 000's
rho (correlation over bins of reference HWS and E(Z), Sec. 3.2).
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from flidar_uq.data.binning import speed_bin_ms
from flidar_uq.data.metrics import representative_ti
from flidar_uq.inference import effective_sigma_z_ms, imu_observations, is_record_model
from flidar_uq.inference.record_motion import record_motion
from flidar_uq.physics.surrogate import default_surrogate
from flidar_uq.physics.variance_laws import corrected_std, rho_bin_correlation
from flidar_uq.seeding import as_seedsequence

__all__ = [
    "LIDAR_STD_RATIO_LOG_SD",
    "REFERENCE_KINDS",
    "corrected_ti",
    "point_target",
    "record_flags",
    "reference_target",
    "variance_law_baselines",
]

#: Reference instruments of config key ``reference.kind``: the model is calibrated to the
#: point wind directly (cup, sonic), to a motionless lidar (fixed_lidar), or has no
#: reference (none: it is the motionless lidar of the floating lidar's type).
REFERENCE_KINDS = ("cup", "sonic", "fixed_lidar", "none")

#: Default prior sd of log g, the error of the motionless lidar's std ratio to the point
#: wind beyond its temporal part (-): probe-volume and scan-disk averaging (-1 to -3 %
#: at 1-4 m probe lengths and 30-90 m heights, Sathe et al. 2011) and stability
#: (docs/lidar-response.md, "Uncertainty of g").
LIDAR_STD_RATIO_LOG_SD = 0.02

#: Records propagated together by the record motion model (bounds the draws' memory:
#: ndraws x chunk floats per array).
_RECORD_CHUNK = 20_000


def variance_law_baselines(records: pd.DataFrame, surrogate) -> tuple[np.ndarray, float]:
    """Seed 000's deterministic sigma_Z per record and its single rho.

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
        Pearson correlation over bins of (mean reference HWS, E(Z)) (Sec. 3.2 of seed 000).
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
) -> tuple[np.ndarray, np.ndarray]:
    """Motionless lidar's std ratio to the point std and its log scatter, per record.

    The inputs of step 4 above (``lidar_std_ratio`` and ``point_log_sd`` of
    :func:`corrected_ti`).

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
    )
    return g_ratio, log_sd


def reference_target(
    kind: str,
    hws_ms,
    height_m,
    lidar: str,
    **sampling,
) -> tuple[np.ndarray | None, np.ndarray | None]:
    """The point-target inputs of :func:`corrected_ti` for a reference instrument.

    Parameters
    ----------
    kind : {"cup", "sonic", "fixed_lidar", "none"}
        The reference the model is calibrated against (:data:`REFERENCE_KINDS`).
    hws_ms, height_m : array_like, shape (n_records,)
        Record mean HWS (m/s) and measurement height (m).
    lidar : str
        Geometry name of the lidar whose std is turned into the point std: the fixed
        reference lidar (``fixed_lidar``) or the floating lidar itself (``none``: the
        deployment formula then gives the std a motionless lidar of its type measures).
    **sampling
        Keyword arguments of :func:`point_target` (``heights_in_turn``,
        ``refocus_delay_s``, ``point_sample_interval_s``, ``turbulence_dt_s``, ``seed``).

    Returns
    -------
    lidar_std_ratio, point_log_sd : numpy.ndarray or None
        None for a cup or sonic (the corrected std is the point std already, and the noise
        term kappa has absorbed the floating-lidar-vs-point scatter); else :func:`point_target`.

    Raises
    ------
    ValueError
        If ``kind`` is not one of :data:`REFERENCE_KINDS`.
    """
    if kind not in REFERENCE_KINDS:
        raise ValueError(f"reference_target: kind={kind!r} must be one of {REFERENCE_KINDS}")
    if kind in ("cup", "sonic"):
        return None, None
    return point_target(hws_ms, height_m, lidar, **sampling)


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


def corrected_ti(
    records: pd.DataFrame,
    bin_fits,
    global_fit,
    *,
    surrogate=None,
    credible_mass: float = 0.9,
    ndraws: int = 400,
    speed_bin_width_ms: float = 1.0,
    scan_period_s: float = 1.0,
    lidar_std_ratio=None,
    point_log_sd=None,
    lidar_std_ratio_log_sd: float = 0.0,
    baseline: tuple[np.ndarray, float] | None = None,
    seed,
) -> tuple[pd.DataFrame, pd.DataFrame]:
    """Corrected std and TI as posterior draws, summarised per record and per speed bin.

    Parameters
    ----------
    records : pandas.DataFrame
        Records with ``bin_id``, ``hws_mean_ms``, ``hws_std_ms`` and IMU statistics.
    bin_fits : sequence of BinFit
    global_fit : GlobalFit
    surrogate : SigmaZSurrogate, optional
        Default ``get_surrogate()``.
    credible_mass : float
        Equal-tailed credible mass in (0, 1) (default 0.9).
    ndraws : int
        Posterior draws propagated per record.
    speed_bin_width_ms : float
        Width of the speed bins of the per-bin table (m/s), centred on multiples of it
        (:func:`flidar_uq.data.binning.speed_bin_ms`).
    scan_period_s : float
        VAD scan duration (s), for the head-translation term when the global fit chose
        the lever-arm model (its ``lever_arm_m`` draws are then propagated too).
    lidar_std_ratio : array_like, shape (n_records,), optional
        Std of a motionless lidar over the point std per record (-), from
        :func:`flidar_uq.physics.lidar_response.lidar_std_ratio`. Given: the corrected std and TI
        are point values (the motionless-lidar value divided by it). Default None: they
        are the values a motionless lidar of this type would measure.
    point_log_sd : array_like, shape (n_records,), optional
        Std of ``log(motionless-lidar std / point std)`` per record (-), with
        ``lidar_std_ratio``: each draw is multiplied by ``exp(N(0, sd^2))`` so that the
        intervals are for the point std. Default None: no scatter.
    lidar_std_ratio_log_sd : float
        Prior sd of ``log g`` (-), with ``lidar_std_ratio``: every posterior draw divides
        by ``g exp(N(0, sd^2))``, one factor per draw shared by all records (the ratio's
        error is systematic: probe-volume averaging, stability). Default 0: g exact.
    baseline : (numpy.ndarray, float), optional
        :func:`variance_law_baselines` of ``records`` with the same surrogate, when the caller
        has it already (computed here otherwise).
    seed : int or numpy.random.SeedSequence

    Returns
    -------
    per_record : pandas.DataFrame
        Index of ``records``; columns ``bin_id``, ``hws_mean_ms``, ``ti_uncorrected``,
        ``sigma_corrected_median_ms``, ``sigma_corrected_lo_ms``, ``sigma_corrected_hi_ms``,
        ``ti_corrected_median``, ``ti_corrected_lo``, ``ti_corrected_hi``,
        ``discriminant_negative`` (the formula at the measured std, posterior-median sZ and
        rho has no real root), ``discriminant_negative_frac`` (share of draws),
        ``sigma_z_median_ms``, ``converged`` (bin and global fit both converged),
        ``failure_reasons``, ``lidar_std_ratio`` (1 when not given), ``point_log_sd`` (0 when
        not given), and the baselines
        ``ti_u``, ``ti_c``, ``ti_pc``, ``rho_seed`` (seed 000's laws, as published: they
        estimate the reference instrument's std).
    per_bin : pandas.DataFrame
        One row per speed bin: ``speed_bin_ms``, ``n_records``, ``n_not_converged``
        (excluded), ``ti_mean_{median,lo,hi}``, ``ti_rep_{median,lo,hi}`` (representative
        TI, mean + 1.28 std), ``ti_rep_uncorrected``, ``ti_rep_u``, ``ti_rep_c``, ``ti_rep_pc``.

    Raises
    ------
    ValueError
        If ``credible_mass`` is not in (0, 1) or a required column is missing.
    """
    if not 0.0 < credible_mass < 1.0:
        raise ValueError(f"corrected_ti: credible_mass={credible_mass} must be in (0, 1)")
    for c in ("bin_id", "hws_mean_ms", "hws_std_ms"):
        if c not in records:
            raise ValueError(f"corrected_ti: records lack column {c!r}")
    g_ratio = np.ones(len(records))
    log_sd = np.zeros(len(records))
    if point_log_sd is not None:
        if lidar_std_ratio is None:
            raise ValueError("corrected_ti: point_log_sd needs lidar_std_ratio")
        log_sd = np.asarray(point_log_sd, dtype=float)
        if log_sd.shape != (len(records),) or np.any(~(log_sd >= 0)):
            raise ValueError(
                f"corrected_ti: point_log_sd must be {len(records)} values >= 0, got shape "
                f"{log_sd.shape}"
            )
    if not lidar_std_ratio_log_sd >= 0.0:
        raise ValueError(
            f"corrected_ti: lidar_std_ratio_log_sd={lidar_std_ratio_log_sd} must be >= 0"
        )
    if lidar_std_ratio_log_sd > 0.0 and lidar_std_ratio is None:
        raise ValueError("corrected_ti: lidar_std_ratio_log_sd needs lidar_std_ratio")
    if lidar_std_ratio is not None:
        g_ratio = np.asarray(lidar_std_ratio, dtype=float)
        if g_ratio.shape != (len(records),) or np.any(~(g_ratio > 0)):
            raise ValueError(
                f"corrected_ti: lidar_std_ratio must be {len(records)} positive values, got "
                f"shape {g_ratio.shape}"
            )
    surrogate = default_surrogate(surrogate)
    rng = np.random.default_rng(as_seedsequence(seed))
    q = [(1.0 - credible_mass) / 2.0, 0.5, (1.0 + credible_mass) / 2.0]
    n = len(records)
    m = records["hws_mean_ms"].to_numpy(dtype=float)
    s = records["hws_std_ms"].to_numpy(dtype=float)
    g_idx = rng.choice(global_fit.flat("rho").size, size=ndraws, replace=True)
    rho = global_fit.flat("rho")[g_idx][:, None]
    kappa = global_fit.flat("kappa")[g_idx][:, None]
    rho_med = float(np.median(global_fit.flat("rho")))
    # the ratio's systematic error: one factor per draw, shared by every record
    g_draw = (
        np.exp(-lidar_std_ratio_log_sd * rng.standard_normal((ndraws, 1)))
        if lidar_std_ratio_log_sd > 0.0
        else 1.0
    )

    sig = np.full((ndraws, n), np.nan)
    neg_frac = np.full(n, np.nan)
    sz_med = np.full(n, np.nan)
    conv = np.zeros(n, dtype=bool)
    reasons = np.full(n, "", dtype=object)
    global_reasons = [f"global: {r}" for r in global_fit.failure_reasons]

    def deploy(mask, sz, tau):
        """Steps 2-4 of the module docstring for the records of ``mask`` (sZ draws given)."""
        s_star = np.abs(s[mask][None, :] + tau * rng.standard_normal((ndraws, int(mask.sum()))))
        c, neg = corrected_std(s_star, sz, rho)
        # point std (g = 1, sd = 0: the reference's own std, a cup's or sonic's point std)
        point = g_draw * np.exp(log_sd[mask] * rng.standard_normal(c.shape)) / g_ratio[mask]
        sig[:, mask] = c * point
        neg_frac[mask] = np.mean(neg, axis=0)
        sz_med[mask] = np.median(sz, axis=0)

    if is_record_model(global_fit):
        # record motion model: each record's sigma_Z from its own measured motion, with the
        # global lever arm, motion scale and the record-level motion error kappa_z
        lever = global_fit.flat("lever_arm_m")[g_idx][:, None]
        scale = global_fit.flat("motion_scale")[g_idx][:, None]
        kappa_z = global_fit.flat("kappa_z")[g_idx][:, None]
        mot = record_motion(records, surrogate=surrogate, scan_period_s=scan_period_s)
        szr = mot["sigma_z_rot_ms"].to_numpy()
        u2 = mot["translation_unit_sq"].to_numpy()
        described = np.isfinite(szr) & np.isfinite(u2)
        reasons[~described] = "no motion description (IMU columns missing)"
        for start in range(0, n, _RECORD_CHUNK):
            mask = np.zeros(n, dtype=bool)
            mask[start : start + _RECORD_CHUNK] = True
            mask &= described
            if not mask.any():
                continue
            k = int(mask.sum())
            sz = effective_sigma_z_ms(szr[mask][None, :], u2[mask][None, :], lever, scale)
            sz = sz * np.exp(kappa_z * rng.standard_normal((ndraws, k)))
            deploy(mask, sz, kappa * s[mask][None, :])
        conv[described] = global_fit.converged
        reasons[described] = "; ".join(global_reasons)
    else:
        tau0 = global_fit.flat("tau0_ms")[g_idx][:, None]
        lever = (
            global_fit.flat("lever_arm_m")[g_idx][:, None]
            if "lever_arm_m" in global_fit.draws
            else None
        )
        scale = (
            global_fit.flat("motion_scale")[g_idx][:, None]
            if "motion_scale" in global_fit.draws
            else 1.0
        )
        bins = records["bin_id"].to_numpy()
        fits = {f.bin_id: f for f in bin_fits}
        for b in pd.unique(bins):
            mask = bins == b
            f = fits.get(b)
            if f is None:
                reasons[mask] = "no fit for this bin"
                continue
            nb = int(f.flat("amplitude_deg").size)
            idx = rng.choice(nb, size=ndraws, replace=ndraws > nb)
            sz, u2 = f._motion_draws(m[mask], surrogate, idx, scan_period_s)
            if lever is None:  # motion-model scale of the surrogate (1 if absent)
                sz = scale * sz
            else:  # plus the head translation of the lever-arm model
                sz = effective_sigma_z_ms(sz, u2, lever, scale)
            deploy(mask, sz, np.sqrt((kappa * s[mask][None, :]) ** 2 + tau0**2))
            conv[mask] = f.converged and global_fit.converged
            reasons[mask] = "; ".join([*f.failure_reasons, *global_reasons])

    with np.errstate(invalid="ignore", divide="ignore"):
        ti = sig / m[None, :]
        _, neg_point = corrected_std(s, np.where(np.isfinite(sz_med), sz_med, 0.0), rho_med)
        sq = (
            np.nanquantile(np.where(np.isfinite(sig), sig, np.nan), q, axis=0)
            if n
            else np.zeros((3, 0))
        )
        tq = (
            np.nanquantile(np.where(np.isfinite(ti), ti, np.nan), q, axis=0)
            if n
            else np.zeros((3, 0))
        )

    sz_seed, rho_seed = (
        baseline if baseline is not None else variance_law_baselines(records, surrogate)
    )
    with np.errstate(invalid="ignore", divide="ignore"):
        ti_u = corrected_std(s, sz_seed, 0.0)[0] / m  # Eq. (16) of seed 000 inverted
        ti_c = corrected_std(s, sz_seed, 1.0)[0] / m  # Eq. (17) of seed 000 inverted
        rho_pc = rho_seed if np.isfinite(rho_seed) else np.nan
        ti_pc = corrected_std(s, sz_seed, np.clip(rho_pc, -1, 1))[0] / m  # Eq. (15) of seed 000
        ti_unc = s / m

    per_record = pd.DataFrame(
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
            "discriminant_negative": neg_point & np.isfinite(sz_med),
            "discriminant_negative_frac": neg_frac,
            "sigma_z_median_ms": sz_med,
            "converged": conv,
            "failure_reasons": reasons,
            "lidar_std_ratio": g_ratio,
            "point_log_sd": log_sd,
            "ti_u": ti_u,
            "ti_c": ti_c,
            "ti_pc": ti_pc,
            "rho_seed": rho_seed,
        },
        index=records.index,
    )
    per_bin = _speed_bins(per_record, ti, speed_bin_width_ms, q)
    return per_record, per_bin


def _speed_bins(per_record, ti_draws, width, q):
    centre = speed_bin_ms(per_record["hws_mean_ms"].to_numpy(), width)
    conv = per_record["converged"].to_numpy()
    rows = []
    for c in np.unique(centre[np.isfinite(centre)]):
        m = centre == c
        k = m & conv
        row = {
            "speed_bin_ms": c,
            "n_records": int(m.sum()),
            "n_not_converged": int((m & ~conv).sum()),
        }
        if k.sum() >= 2:
            draws = ti_draws[:, k]
            mean_d = np.nanmean(draws, axis=1)
            rep_d = np.array([representative_ti(d) for d in draws])
            for name, x in (("ti_mean", mean_d), ("ti_rep", rep_d)):
                qq = np.nanquantile(x, q)
                row.update({f"{name}_lo": qq[0], f"{name}_median": qq[1], f"{name}_hi": qq[2]})
        for col, out in (
            ("ti_uncorrected", "ti_rep_uncorrected"),
            ("ti_u", "ti_rep_u"),
            ("ti_c", "ti_rep_c"),
            ("ti_pc", "ti_rep_pc"),
        ):
            row[out] = (
                float(representative_ti(per_record[col].to_numpy()[k])) if k.sum() >= 2 else np.nan
            )
        rows.append(row)
    return pd.DataFrame(rows)
