"""Workflow step of the correction layer: corrected TI per record, bin and speed bin, the
record flags, and the MD / RMSE / coverage scores (results/ti/)."""

from __future__ import annotations

import logging
import os
from collections.abc import Sequence

import numpy as np
import pandas as pd

from flidar_uq.workflow.files import read_csv, write_csv
from flidar_uq.workflow.inference_steps import load_bin_fits

log = logging.getLogger(__name__)

__all__ = ["RECORD_COLUMNS", "propagate"]

#: Columns of results/ti/records.csv that every run writes, in order (the output contract).
RECORD_COLUMNS = [
    "timestamp",
    "height_m",
    "bin_id",
    "hws_mean_ms",
    "ti_uncorrected",
    "ti_corrected_median",
    "ti_corrected_lo",
    "ti_corrected_hi",
    "flags",
]


def _md_rmse(x: np.ndarray, ref: np.ndarray) -> tuple[float, float, int]:
    """MD and RMSE of x against ref (seed 000 Eqs. 18-19) and the number of finite pairs."""
    from flidar_uq.data import metrics

    n = int(np.sum(np.isfinite(x) & np.isfinite(ref)))
    return metrics.mean_deviation(x, ref), metrics.rmse(x, ref), n


def propagate(
    *,
    records_path: str | os.PathLike,
    flags_path: str | os.PathLike,
    assignments_path: str | os.PathLike,
    table_path: str | os.PathLike,
    sigma_z_path: str | os.PathLike,
    bin_fits_path: str | os.PathLike,
    batch_dirs: Sequence[str | os.PathLike],
    global_path: str | os.PathLike,
    records_out: str | os.PathLike,
    bins_out: str | os.PathLike,
    speed_bins_out: str | os.PathLike,
    metrics_out: str | os.PathLike,
    credible_mass: float,
    ndraws: int,
    seed: int,
    lidar: str = "zephir300",
    target: str = "point",
    turbulence_dt_s: float | None = None,
    point_sample_interval_s: float = 1.0,
    scan_heights_in_turn: int | None = None,
    scan_refocus_delay_s: Sequence[float] = (0.3, 0.7),
) -> pd.DataFrame:
    """Corrected std and TI per record, per bin and per speed bin, beside the baselines.

    Calls :func:`flidar_uq.correction.propagation.corrected_ti` on the kept, binned records with the
    converged bin fits and the global fit (posterior draws through the deployment formula;
    median and equal-tailed ``credible_mass`` interval), and seed 000's U / C / PC laws.

    ``target="point"`` turns the corrected std into the point (cup-like) std: divided by
    the motionless lidar's std ratio (:func:`flidar_uq.physics.lidar_response.lidar_std_ratio`,
    at the record's HWS and height, band-limited at ``1 / (2 turbulence_dt_s)`` for a
    synthetic series; None: the atmosphere) with its record-to-record scatter
    (:func:`flidar_uq.physics.lidar_response.lidar_point_log_sd`: the lidar scanning
    ``scan_heights_in_turn`` heights in turn (None: the number of distinct heights in
    the records) with ``scan_refocus_delay_s`` between scans, against the point HWS
    sampled every ``point_sample_interval_s``). ``"motionless_lidar"`` keeps the std a
    motionless lidar would measure (the reference the model is calibrated against).
    ``lidar_std_ratio`` and ``point_log_sd`` are written per record.

    ``metrics_out``: MD and RMSE (seed 000 Eqs. 18-19) of std (m/s) and TI for the
    uncorrected, U, C, PC and Bayesian estimates against the truth (``true_*``, virtual
    campaigns) or else the reference instrument, over the records with a Bayesian value;
    and the coverage of the credible interval when the truth is known.
    """
    from flidar_uq import inference as inf
    from flidar_uq.correction import propagation as prop
    from flidar_uq.physics.surrogate import get_surrogate

    flags = read_csv(flags_path)
    assigned = read_csv(assignments_path)
    table = read_csv(table_path)
    sz_table = read_csv(sigma_z_path).set_index("bin_id")
    bin_fits = read_csv(bin_fits_path)
    gfit = inf.load_fit(global_path)
    fits = load_bin_fits(batch_dirs, bin_fits)
    surrogate = get_surrogate(lidar)

    rid = flags["record_id"].to_numpy()
    rec = read_csv(records_path).iloc[rid].reset_index(drop=True)  # every input record
    rec["bin_id"] = assigned.set_index("record_id")["bin_id"].reindex(rid).to_numpy()
    binned = rec["bin_id"].notna().to_numpy()
    sub = rec[binned].astype({"bin_id": int})
    if target not in ("point", "motionless_lidar"):
        raise ValueError(f"propagate: target={target!r} must be 'point' or 'motionless_lidar'")
    g_ratio, log_sd = np.ones(len(sub)), np.zeros(len(sub))
    if target == "point":
        from flidar_uq.physics import lidar_response

        hws_sub = sub["hws_mean_ms"].to_numpy(dtype=float)
        z_sub = sub["height_m"].to_numpy(dtype=float)
        g_ratio = lidar_response.lidar_std_ratio(
            hws_sub,
            z_sub,
            lidar,
            turbulence_max_frequency_hz=None if turbulence_dt_s is None else 0.5 / turbulence_dt_s,
        )
        heights = scan_heights_in_turn or int(rec["height_m"].nunique())
        log_sd = lidar_response.lidar_point_log_sd(
            hws_sub,
            z_sub,
            lidar,
            heights_in_turn=heights,
            refocus_delay_s=tuple(scan_refocus_delay_s),
            point_sample_interval_s=point_sample_interval_s,
            turbulence_dt_s=turbulence_dt_s,
            seed=int(seed),
        )
        log.info(
            "point target: lidar std ratio %.4f-%.4f, log-sd %.4f-%.4f (%d heights in turn)",
            np.nanmin(g_ratio), np.nanmax(g_ratio), np.nanmin(log_sd), np.nanmax(log_sd), heights,
        )  # fmt: skip
    per_record, speed_bins = prop.corrected_ti(
        sub,
        [f for f in fits.values() if f.converged],
        gfit,
        surrogate=surrogate,
        cred_mass=credible_mass,
        ndraws=ndraws,
        lidar_std_ratio=g_ratio,
        point_log_sd=log_sd,
        seed=np.random.SeedSequence(entropy=int(seed), spawn_key=(2,)),
    )
    sz_seed, rho_seed = prop.seed000_baseline(sub, surrogate)

    n = len(rec)
    m = rec["hws_mean_ms"].to_numpy(dtype=float)
    s = rec["hws_std_ms"].to_numpy(dtype=float)
    out = pd.DataFrame(
        {"record_id": rid, "timestamp": flags["timestamp"], "height_m": rec["height_m"]}
    )
    out["bin_id"] = rec["bin_id"].to_numpy()
    out["hws_mean_ms"] = m
    out["hws_std_ms"] = s
    with np.errstate(invalid="ignore", divide="ignore"):
        out["ti_uncorrected"] = s / m

    def put(values, dtype=float, fill=np.nan):
        full = np.full(n, fill, dtype=dtype)
        full[binned] = values
        return full

    for col in ("ti_corrected_median", "ti_corrected_lo", "ti_corrected_hi"):
        out[col] = put(per_record[col].to_numpy())
    for col, src in (
        ("std_corrected_median_ms", "sigma_corrected_median_ms"),
        ("std_corrected_lo_ms", "sigma_corrected_lo_ms"),
        ("std_corrected_hi_ms", "sigma_corrected_hi_ms"),
        ("sigma_z_median_ms", "sigma_z_median_ms"),
        ("lidar_std_ratio", "lidar_std_ratio"),
        ("point_log_sd", "point_log_sd"),
        ("p_discriminant_negative", "discriminant_negative_frac"),
        ("ti_corrected_u", "ti_u"),
        ("ti_corrected_c", "ti_c"),
        ("ti_corrected_pc", "ti_pc"),
    ):
        out[col] = put(per_record[src].to_numpy())
    out["sigma_z_seed000_ms"] = put(sz_seed)
    for law in ("u", "c", "pc"):
        out[f"std_corrected_{law}_ms"] = out[f"ti_corrected_{law}"] * m
    out["sigma_z_bin_ms"] = sz_table["sigma_z_ms"].reindex(out["bin_id"]).to_numpy(dtype=float)

    reasons = [[r] if isinstance(r, str) and r else [] for r in flags["reasons"].fillna("")]
    status = bin_fits.set_index("bin_id")["status"]
    fitted = table.set_index("bin_id")["fitted"]
    neg = put(per_record["discriminant_negative"].to_numpy(dtype=bool), dtype=bool, fill=False)
    for i in range(n):
        if reasons[i]:
            continue
        if not binned[i]:
            reasons[i].append("unbinned")  # kept by QC but a binning variable is missing
            continue
        b = int(out["bin_id"].iat[i])
        if not bool(fitted.get(b, False)):
            reasons[i].append("bin_not_fitted")
        elif status.get(b) != "ok":
            reasons[i].append("bin_failed" if status.get(b) == "failed" else "bin_error")
        elif neg[i]:
            reasons[i].append("discriminant_negative")
    if not gfit.converged:
        for r in reasons:
            r.append("global_fit_failed")
    out["flags"] = [";".join(r) for r in reasons]

    if "ref_hws_std_ms" in rec:
        out["ref_hws_std_ms"] = rec["ref_hws_std_ms"].to_numpy(dtype=float)
        with np.errstate(invalid="ignore", divide="ignore"):
            out["ti_ref"] = out["ref_hws_std_ms"] / rec["ref_hws_mean_ms"].to_numpy(dtype=float)
    if "true_ti" in rec:
        out["ti_true"] = rec["true_ti"].to_numpy(dtype=float)
    if "true_hws_std_ms" in rec:
        out["true_hws_std_ms"] = rec["true_hws_std_ms"].to_numpy(dtype=float)
    out = out[RECORD_COLUMNS + [c for c in out.columns if c not in RECORD_COLUMNS]]
    write_csv(out, records_out)
    write_csv(speed_bins, speed_bins_out)

    # per-bin table: bin table + sigma_Z at the centre + fit status/diagnostics + TI means
    bins = table.merge(sz_table[["sigma_z_ms", "mean_z_ms"]].reset_index(), on="bin_id", how="left")
    bins = bins.merge(
        bin_fits.drop(columns=[c for c in ("n_records",) if c in bin_fits]), on="bin_id", how="left"
    )
    bins["status"] = bins["status"].where(bins["fitted"], "not_fitted")
    agg = {
        "ti_uncorrected": "mean",
        "ti_corrected_median": "mean",
        "ti_corrected_lo": "mean",
        "ti_corrected_hi": "mean",
    }
    if "ti_true" in out:
        agg["ti_true"] = "mean"
    means = out.groupby("bin_id").agg(agg).add_suffix("_mean").reset_index()
    write_csv(bins.merge(means, on="bin_id", how="left"), bins_out)

    # MD / RMSE of std and TI (Tables 2-3 style) against the truth (virtual campaigns)
    # and against the reference instrument, where present, over the same records. The
    # Bayesian estimate is compared in the reference's own terms: its point value against
    # the truth, times lidar_std_ratio (the motionless-lidar value) against the reference
    # lidar. Seed 000's laws estimate the reference instrument's std, as published.
    used = np.isfinite(out["ti_corrected_median"].to_numpy())  # same records for every method
    g_all = out["lidar_std_ratio"].to_numpy(dtype=float)
    estimates = {
        "uncorrected": ("hws_std_ms", "ti_uncorrected"),
        "U": ("std_corrected_u_ms", "ti_corrected_u"),
        "C": ("std_corrected_c_ms", "ti_corrected_c"),
        "PC": ("std_corrected_pc_ms", "ti_corrected_pc"),
        "Bayesian": ("std_corrected_median_ms", "ti_corrected_median"),
    }
    rows = []
    for ref_name, (ref_std, ref_ti) in _references(rec).items():
        lo_hi = (out["ti_corrected_lo"].to_numpy(), out["ti_corrected_hi"].to_numpy())
        for name, (scol, tcol) in estimates.items():
            scale = g_all if (name == "Bayesian" and ref_name != "truth") else 1.0
            std = np.where(used, out[scol].to_numpy(dtype=float) * scale, np.nan)
            ti = np.where(used, out[tcol].to_numpy(dtype=float) * scale, np.nan)
            md_s, rmse_s, n_s = _md_rmse(std, ref_std)
            md_t, rmse_t, _ = _md_rmse(ti, ref_ti)
            with np.errstate(all="ignore"):
                rel = ti / ref_ti - 1.0
                mean_rel = float(np.nanmean(rel)) if n_s else float("nan")
                mean_abs_rel = float(np.nanmean(np.abs(rel))) if n_s else float("nan")
            coverage = float("nan")
            if name == "Bayesian" and n_s:
                ok = used & np.isfinite(ref_ti)
                inside = (ref_ti >= lo_hi[0] * scale) & (ref_ti <= lo_hi[1] * scale)
                coverage = float(inside[ok].mean())
            rows.append(
                {
                    "reference": ref_name,
                    "method": name,
                    "n": n_s,
                    "md_std_ms": md_s,
                    "rmse_std_ms": rmse_s,
                    "md_ti": md_t,
                    "rmse_ti": rmse_t,
                    "mean_rel_ti_error": mean_rel,
                    "mean_abs_rel_ti_error": mean_abs_rel,
                    "coverage": coverage,
                }
            )
    metrics = pd.DataFrame(
        rows,
        columns=[
            "reference", "method", "n", "md_std_ms", "rmse_std_ms", "md_ti", "rmse_ti",
            "mean_rel_ti_error", "mean_abs_rel_ti_error", "coverage",
        ],
    )  # fmt: skip
    metrics["rho_seed000"] = rho_seed
    metrics["credible_mass"] = credible_mass
    metrics["target"] = target
    write_csv(metrics, metrics_out)
    return out


def _references(rec: pd.DataFrame) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """Std (m/s) and TI the estimates are scored against: the truth and/or the reference."""
    out = {}
    if "true_hws_std_ms" in rec:
        std = rec["true_hws_std_ms"].to_numpy(dtype=float)
        ti = (
            rec["true_ti"].to_numpy(dtype=float)
            if "true_ti" in rec
            else std / rec["true_hws_mean_ms"].to_numpy(dtype=float)
        )
        out["truth"] = (std, ti)
    if "ref_hws_std_ms" in rec:
        std = rec["ref_hws_std_ms"].to_numpy(dtype=float)
        out["reference instrument"] = (std, std / rec["ref_hws_mean_ms"].to_numpy(dtype=float))
    return out
