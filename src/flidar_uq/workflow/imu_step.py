"""Workflow step of a raw IMU series: per-record motion statistics and IMU gaps (results/imu/),
and their merge into the record table (the series wins over the table's motion columns)."""

from __future__ import annotations

import logging
import os

import pandas as pd

from flidar_uq.workflow.files import read_csv, write_csv

log = logging.getLogger(__name__)

__all__ = ["imu_statistics", "merge_series_motion"]


def imu_statistics(
    records_path: str | os.PathLike,
    imu_path: str | os.PathLike,
    statistics_out: str | os.PathLike,
    gaps_out: str | os.PathLike,
    summary_out: str | os.PathLike,
    *,
    chunk_rows: int,
    min_coverage_pct: float,
    allow_small_angles: bool = False,
    heading_convention: str = "ccw",
) -> pd.DataFrame:
    """Derive every record's motion statistics from the raw IMU series, streamed in chunks.

    Calls :func:`flidar_uq.data.imu_series.series_motion_statistics` on the record table's
    timestamps, heights and wind directions (the motion columns of the table are not
    needed). Writes the statistics (one row per record row), the IMU gaps and a summary
    (``key, value``).

    Parameters
    ----------
    records_path : path
        The campaign's record table (results/campaign/records.parquet).
    imu_path : path
        The IMU series (CSV or Parquet, docs/data-format.md).
    statistics_out, gaps_out, summary_out : path
        Outputs (CSV).
    chunk_rows : int
        Rows of the series read at a time.
    min_coverage_pct : float
        Windows with fewer IMU samples get NaN statistics (the QC threshold ``qc.
        imu_availability_min_pct``), %.
    allow_small_angles : bool
        Skip the "angles look like radians" check.
    heading_convention : {"ccw", "compass"}
        The series' ``yaw_deg`` convention (config ``campaign.heading_convention``).

    Returns
    -------
    pandas.DataFrame
        The statistics written.
    """
    from flidar_uq.data import io
    from flidar_uq.data.imu_series import series_motion_statistics, series_overrides

    records = io.read_records(
        records_path,
        require_motion=False,
        allow_small_angles=allow_small_angles,
        extra_columns="keep",
    )
    result = series_motion_statistics(
        imu_path,
        records,
        chunk_rows=chunk_rows,
        min_coverage_pct=min_coverage_pct,
        allow_small_angles=allow_small_angles,
        heading_convention=heading_convention,
    )
    own, n_overridden = series_overrides(records)
    info = result.summary | {
        "record_table_motion_columns": " ".join(own) if own else "none",
        "record_rows_overridden": n_overridden,
    }
    if own:
        log.warning(
            "the IMU series wins: its statistics replace the record table's motion columns "
            "(%d of %d record rows carried values)",
            info["record_rows_overridden"],
            len(records),
        )
    write_csv(result.statistics, statistics_out)  # every bit: they replace record columns
    gaps = result.gaps.copy()
    for col in ("start", "end"):  # sub-second times (write_csv keeps whole seconds)
        gaps[col] = gaps[col].dt.strftime("%Y-%m-%dT%H:%M:%S.%fZ")
    write_csv(gaps, gaps_out)
    summary = pd.DataFrame({"key": list(info), "value": [str(v) for v in info.values()]})
    write_csv(summary, summary_out)
    return result.statistics


def merge_series_motion(
    records: pd.DataFrame, statistics_path: str | os.PathLike
) -> tuple[pd.DataFrame, int]:
    """Replace the record table's motion columns by those derived from the IMU series.

    Parameters
    ----------
    records : pandas.DataFrame
        Validated record table (motion columns optional).
    statistics_path : path
        Output of :func:`imu_statistics` (same rows, same order); merged by
        :func:`flidar_uq.data.imu_series.merge_series_motion`.

    Returns
    -------
    merged : pandas.DataFrame
        The records with the series' motion columns (the table's own are dropped).
    n_overridden : int
        Record rows whose table carried a finite motion value that the series replaced
        (logged as a warning: the series wins).

    Raises
    ------
    ValueError
        If the statistics do not match the records row by row.
    """
    from flidar_uq.data.imu_series import merge_series_motion as merge
    from flidar_uq.data.imu_series import series_overrides

    merged = merge(records, read_csv(statistics_path), source=str(statistics_path))
    own, n_overridden = series_overrides(records)
    if own:
        log.warning(
            "the IMU series wins: its statistics replace the record table's columns %s "
            "(%d of %d record rows carried values)",
            own,
            n_overridden,
            len(records),
        )
    return merged, n_overridden
