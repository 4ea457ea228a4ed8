"""Workflow steps of the LOS branch: LOS-level corrected TI record by record (results/los/
corrected.csv), and its agreement with the statistical (Bayesian) corrected TI
(results/los/records.csv, agreement.csv, agreement.png)."""

from __future__ import annotations

import logging
import os
from collections.abc import Sequence
from pathlib import Path

import numpy as np
import pandas as pd

from flidar_uq.workflow.files import read_csv, write_csv

log = logging.getLogger(__name__)

__all__ = ["los_agreement", "los_correction"]


def los_correction(
    *,
    records_path: str | os.PathLike,
    los_path: str | os.PathLike,
    imu_path: str | os.PathLike,
    out_path: str | os.PathLike,
    lidar: str,
    lever_arm_m: Sequence[float],
    qc_params: dict | None = None,
    chunk_rows: int = 250_000,
    allow_small_angles: bool = False,
    window_s: float = 600.0,
    utc_offset_h: float | None = None,
) -> pd.DataFrame:
    """LOS-level corrected TI of every record (Malekmohammadi et al. (2024) LS; Yamaguchi and Ishihara (2016) for a DBS lidar).

    The LOS and IMU series are streamed in chunks (:mod:`flidar_uq.data.imu_series`), record
    window by record window, through :func:`flidar_uq.correction.los_records.los_record_ti`.
    Every record row of the table appears in the output; one without LOS data is flagged
    ``no_los``. LOS rows outside every record window or (VAD) at a height without a record
    row are counted in the log.

    Parameters
    ----------
    records_path : path
        The validated record table (results/data/records.parquet): timestamps, heights,
        ``wd_mean_deg``.
    los_path, imu_path : path
        LOS series and IMU series (CSV or Parquet, docs/data-format.md; the LOS series also
        a WindCube v2 ``.rtd``, :func:`flidar_uq.data.formats.read_los_file`); the LOS rows
        sorted by time.
    out_path : path
        results/los/corrected.csv: ``timestamp`` and the columns of ``los_record_ti``
        (``translation``: the IMU series' translational velocities each record's head
        velocity took; empty for a record without LOS rows).
    lidar : str
        Lidar geometry (config ``campaign.lidar``).
    lever_arm_m : sequence of 3 float
        Lidar head from the rotation centre, body frame, m.
    qc_params : dict, optional
        The ``qc`` config section (CNR filter ``cnr``, ``cnr_min_db`` if set).
    chunk_rows : int
        Rows of each series read at a time.
    allow_small_angles : bool
        Skip the radians check of the IMU series.
    window_s : float
        Record length, s.
    utc_offset_h : float, optional
        A ``.rtd`` without ``timezone`` line: offset of its stamps from UTC, h (config
        ``campaign.utc_offset_h``).

    Returns
    -------
    pandas.DataFrame
        The table written.
    """
    from flidar_uq.correction.los_records import IMU_MARGIN_S, los_methods, los_record_ti
    from flidar_uq.data import io
    from flidar_uq.data.imu_series import (
        TimeCursor,
        iter_imu_series,
        iter_los_series,
        record_window_offset_s,
        window_batches,
    )
    from flidar_uq.data.qc import QCConfig
    from flidar_uq.physics.lidar import get_lidar

    records = io.read_records(records_path, require_motion=False, extra_columns="keep")
    qc = QCConfig(**(qc_params or {}))
    offset_s = record_window_offset_s(records, window_s)
    window = pd.Timedelta(window_s, "s")
    margin = pd.Timedelta(IMU_MARGIN_S, "s")
    by_start = {ts: g for ts, g in records.groupby("timestamp", sort=True)}
    imu = TimeCursor(
        iter_imu_series(imu_path, chunk_rows=chunk_rows, allow_small_angles=allow_small_angles)
    )
    methods = los_methods(lidar)
    rows, seen = [], set()
    series_columns: set[str] = set()  # the IMU series' columns, as read
    n_los_outside = n_los_other_height = 0
    dbs = get_lidar(lidar).kind == "dbs"
    for batch in window_batches(
        iter_los_series(los_path, chunk_rows=chunk_rows, utc_offset_h=utc_offset_h),
        window_s=window_s,
        offset_s=offset_s,
    ):
        shift = pd.Timedelta(offset_s, "s")
        starts = (batch["timestamp"] - shift).dt.floor(window) + shift
        for start, los in batch.groupby(starts, sort=True):
            rec = by_start.get(start)
            if rec is None:
                n_los_outside += len(los)
                continue
            seen.add(start)
            if not dbs:  # a DBS lidar's other heights are range gates, used for interpolation
                n_los_other_height += int((~los["height_m"].isin(rec["height_m"])).sum())
            motion = imu.take(start - margin, start + window + margin)
            series_columns.update(motion.columns)
            out = los_record_ti(
                los.reset_index(drop=True),
                motion,
                start=start,
                heights_m=rec["height_m"].to_numpy(dtype=float),
                wd_deg=rec["wd_mean_deg"].to_numpy(dtype=float),
                lidar=lidar,
                lever_arm_m=lever_arm_m,
                qc=qc,
            )
            out.insert(0, "timestamp", start)
            rows.append(out)
    columns = ["n_los", "n_scans", "n_scans_used", "los_flags", "translation"]
    columns += [
        f"{q}_{m}" for m in methods for q in ("n_hws", "hws_mean_ms", "hws_std_ms", "ti_los")
    ]
    table = records[["timestamp", "height_m"]]
    if rows:
        table = table.merge(
            pd.concat(rows, ignore_index=True), on=["timestamp", "height_m"], how="left"
        )
    table = table.reindex(columns=["timestamp", "height_m", *columns])
    table["los_flags"] = table["los_flags"].where(table["los_flags"].notna(), "no_los")
    for col in ["n_los", "n_scans", "n_scans_used", *[f"n_hws_{m}" for m in methods]]:
        table[col] = table[col].fillna(0).astype(int)
    log.info(
        "LOS branch (%s): %d record rows, %d with a Malekmohammadi et al. (2024) TI; %d record windows without "
        "LOS rows; %d LOS rows outside every record window, %d at heights without a record row; "
        "measured translation in the head velocity (record rows): %s",
        lidar,
        len(table),
        int(table["ti_los_least_squares"].notna().sum()),
        len(by_start) - len(seen),
        n_los_outside,
        n_los_other_height,
        ", ".join(f"{k} {v}" for k, v in table["translation"].value_counts().items()) or "none",
    )
    if "acceleration_up_ms2" in series_columns and "velocity_up_ms" not in series_columns:
        log.warning(
            "LOS branch: the IMU series gives the heave as an acceleration "
            "(acceleration_up_ms2), which the LOS corrections do not integrate: their head "
            "velocity leaves the heave out (the record model's tilt bands use it); give "
            "velocity_up_ms to add it"
        )
    write_csv(table, out_path)
    return table


def los_agreement(
    *,
    los_path: str | os.PathLike,
    ti_records_path: str | os.PathLike,
    records_out: str | os.PathLike,
    agreement_out: str | os.PathLike,
    figure_out: str | os.PathLike,
) -> pd.DataFrame:
    """The LOS-level corrected TI beside the Bayesian one, record by record, and their agreement.

    The Bayesian TI estimates the pipeline's target (``propagation.target``: the point wind,
    or a motionless lidar); a LOS-level correction gives what a motionless lidar would have
    measured. So each LOS TI is put on the Bayesian target by dividing it by the record's
    ``lidar_std_ratio`` (1 for the motionless-lidar target; docs/lidar-response.md) before
    comparing: columns ``ti_los_<method>`` (lidar) and ``ti_los_<method>_target``.

    Agreement per method (:func:`flidar_uq.correction.los_records.agreement_with_bayesian`,
    records with both values): ``bias_vs_bayesian`` = mean of LOS
    minus Bayesian median, ``rmse_vs_bayesian``, ``r_vs_bayesian`` (Pearson),
    ``inside_interval_pct`` = share of LOS values inside the Bayesian credible interval (%);
    against the truth (virtual campaigns): ``md_vs_truth``, ``rmse_vs_truth``. A last row
    ``bayesian`` gives the Bayesian median's own MD and RMSE against the truth.

    Parameters
    ----------
    los_path : path
        results/los/corrected.csv (:func:`los_correction`).
    ti_records_path : path
        results/ti/records.csv.
    records_out, agreement_out, figure_out : path
        results/los/records.csv, results/los/agreement.csv, results/los/agreement.png.

    Returns
    -------
    pandas.DataFrame
        The agreement table.
    """
    from flidar_uq.correction.los_records import agreement_with_bayesian

    los = read_csv(los_path)
    merged, agreement, methods = agreement_with_bayesian(read_csv(ti_records_path), los)
    write_csv(merged, records_out)
    write_csv(agreement, agreement_out)
    _agreement_figure(merged, methods, figure_out)
    log.info("LOS agreement:\n%s", agreement.to_string(index=False))
    return agreement


def _agreement_figure(merged: pd.DataFrame, methods: Sequence[str], path) -> None:
    """LOS-corrected TI (on the Bayesian target) against the Bayesian median with its
    interval, one colour per LOS method, and the 1:1 line; a PNG without a date."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    med = merged["ti_corrected_median"].to_numpy(float)
    err = np.abs(
        np.stack(
            [
                med - merged["ti_corrected_lo"].to_numpy(float),
                merged["ti_corrected_hi"].to_numpy(float) - med,
            ]
        )
    )
    fig, ax = plt.subplots(figsize=(5.5, 5))
    colours = {
        "uncorrected": "0.6",
        "least_squares": "C0",
        "dbs_conventional": "C1",
        "dbs_new": "C2",
    }
    finite = [med[np.isfinite(med)]]
    for m in methods:
        x = merged[f"ti_los_{m}_target"].to_numpy(float)
        ok = np.isfinite(x) & np.isfinite(med)
        finite.append(x[ok])
        ax.errorbar(
            med[ok],
            x[ok],
            xerr=err[:, ok],
            fmt="o",
            ms=3,
            lw=0.5,
            color=colours.get(m, None),
            alpha=0.7,
            label=f"LOS {m}",
        )
    vals = np.concatenate(finite)
    hi = float(vals.max()) * 1.05 if vals.size else 1.0
    ax.plot([0, hi], [0, hi], "k--", lw=1, label="1:1")
    ax.set_xlim(0, hi)
    ax.set_ylim(0, hi)
    ax.set_xlabel("Bayesian corrected TI (median, credible interval)")
    ax.set_ylabel("LOS-level corrected TI (on the same target)")
    ax.legend(fontsize=8)
    fig.tight_layout()
    Path(path).parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=90, metadata={"Software": None})
    plt.close(fig)
