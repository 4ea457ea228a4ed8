"""Workflow steps of the data layer: campaign, validation, QC, motion statistics, bins
(with their batch assignment) and the sigma_Z table at the bin centres."""

from __future__ import annotations

import logging
import os
import sys
from collections.abc import Sequence
from pathlib import Path

import numpy as np
import pandas as pd

from flidar_uq.data.io import read_table, write_table
from flidar_uq.workflow.files import read_csv, write_csv

log = logging.getLogger(__name__)

#: Largest virtual campaign written with its LOS series (~19,000 rows per record in memory).
MAX_VIRTUAL_LOS_RECORDS = 2000

__all__ = [
    "kept_records",
    "make_bins",
    "make_campaign",
    "motion_statistics",
    "run_qc",
    "sigma_z_table",
    "uncorrected_ti",
    "validate_records",
]


# --------------------------------------------------------------------------- campaign


def make_campaign(
    out_path: str | os.PathLike,
    *,
    source: str,
    seed: int = 0,
    scenario_path: str | os.PathLike | None = None,
    records_path: str | os.PathLike | None = None,
    threads: int = 1,
    columns: dict | None = None,
    allow_small_angles: bool = False,
    require_motion: bool = True,
    imu_out: str | os.PathLike | None = None,
    los_out: str | os.PathLike | None = None,
    conventions: dict | None = None,
    join_out: str | os.PathLike | None = None,
    source_out: str | os.PathLike | None = None,
) -> pd.DataFrame:
    """Write the campaign's 10-min record table: the virtual campaign or the user's file.

    Parameters
    ----------
    out_path : path
        Output CSV (record format of docs/data-format.md).
    source : {"virtual", "files"}
        Generate the physics-mode virtual campaign, or read the user's table.
    seed : int
        SeedSequence entropy of the virtual campaign (-).
    scenario_path : path, optional
        Scenario YAML (a shipped ``flidar_uq/resources/scenarios/<name>.yaml`` or the
        user's), required for ``source="virtual"``.
    records_path : path, optional
        The user's record table (CSV or Parquet), required for ``source="files"``.
    threads : int
        Worker processes of the virtual-campaign generator (results do not depend on it).
    columns : dict, optional
        Column map of the user's table (config ``campaign.columns``,
        :func:`flidar_uq.data.io.validate_records`).
    allow_small_angles : bool
        Accept motion amplitudes that all look like radians (config
        ``campaign.allow_small_angles``).
    require_motion : bool
        ``source="files"``: the motion columns must be in the table (False when they come
        from a raw IMU series, config ``campaign.imu_series``).
    imu_out, los_out : path, optional
        ``source="virtual"``: also write the campaign's raw IMU series / LOS series there
        (config ``campaign.virtual_series``; LOS data are ~19,000 rows per record, so at
        most :data:`MAX_VIRTUAL_LOS_RECORDS` records).
    conventions : dict, optional
        ``source="files"``: config ``campaign`` keys ``format``, ``utc_offset_h`` (h),
        ``timestamp_at``, ``heading_convention`` and ``extra_columns``
        (:func:`flidar_uq.data.formats.read_any`) and the sections ``motion_file`` and
        ``reference_file`` of a campaign in several files
        (:func:`flidar_uq.data.formats.join.read_campaign`).
    join_out, source_out : path, optional
        The join report (CSV, one row per file: intervals, matched, unmatched each side)
        and what the lidar file's header states with the derivations made (JSON, the
        report's provenance).

    Returns
    -------
    pandas.DataFrame
        The records written (every record of the file).

    Raises
    ------
    ValueError
        On an unknown ``source`` or a missing path.
    flidar_uq.data.io.DataValidationError
        On a problem of the user's file (names file, row and column).
    """
    from flidar_uq.data import io

    if source == "virtual":
        if not scenario_path:
            raise ValueError("make_campaign: source='virtual' needs scenario_path")
        from flidar_uq.campaign import physics_mode as campaign
        from flidar_uq.campaign.scenarios import CampaignConfig, load_scenario

        scenario = CampaignConfig.from_dict(load_scenario(scenario_path))
        n_records = int(scenario.settings["n_records"])
        if los_out and n_records > MAX_VIRTUAL_LOS_RECORDS:
            raise ValueError(
                f"make_campaign: a virtual LOS series of {n_records} records would hold "
                f"~{19_000 * n_records:.2g} rows in memory; use a scenario of at most "
                f"{MAX_VIRTUAL_LOS_RECORDS} records with campaign.virtual_series: imu_los"
            )
        out = campaign.generate_campaign(
            scenario,
            seed,
            n_workers=max(1, int(threads)),
            return_imu=bool(imu_out),
            return_los=bool(los_out),
        )
        records = out.records
        if imu_out:
            io.write_imu_series(out.imu, imu_out)
            log.info("campaign: IMU series, %d samples -> %s", len(out.imu), imu_out)
        if los_out:
            io.write_los_series(out.los, los_out)
            log.info("campaign: LOS series, %d rows -> %s", len(out.los), los_out)
    elif source == "files":
        if not records_path:
            raise ValueError(
                "make_campaign: source='files' needs records_path (config campaign.records)"
            )
        from flidar_uq.data.formats.join import read_campaign

        records, join, facts, notes = read_campaign(
            records_path,
            {**(conventions or {}), "columns": columns or None},
            require_motion=require_motion,
            allow_small_angles=allow_small_angles,
        )
        _write_source(join, {"header_facts": facts, "notes": notes}, join_out, source_out)
    else:
        raise ValueError(f"make_campaign: source must be 'virtual' or 'files', got {source!r}")
    if source == "virtual":
        n = int(records["timestamp"].nunique())
        join = pd.DataFrame([dict(role="lidar", path="", intervals=n, matched=n,
                                  unmatched_lidar=0, unmatched_file=0)])  # fmt: skip
        _write_source(
            join, {"header_facts": {"format": "virtual"}, "notes": []}, join_out, source_out
        )
    Path(out_path).parent.mkdir(parents=True, exist_ok=True)
    io.write_records(
        records, out_path, allow_small_angles=allow_small_angles, require_motion=require_motion
    )
    log.info("campaign: %d records (%s) -> %s", len(records), source, out_path)
    return records


def _write_source(join: pd.DataFrame, source: dict, join_out, source_out) -> None:
    """Write the join report (CSV) and the source's facts (JSON) where asked."""
    import json

    for row in join.itertuples():
        log.info(
            "campaign: join %s %s: %d intervals, %d matched, %d lidar unmatched, %d file "
            "unmatched", row.role, row.path, row.intervals, row.matched, row.unmatched_lidar,
            row.unmatched_file,
        )  # fmt: skip
    if join_out is not None:
        Path(join_out).parent.mkdir(parents=True, exist_ok=True)
        join.to_csv(join_out, index=False, lineterminator="\n")
    if source_out is not None:
        Path(source_out).parent.mkdir(parents=True, exist_ok=True)
        text = json.dumps(source, indent=1, sort_keys=True, default=str)
        Path(source_out).write_text(text + "\n")


def validate_records(
    in_path: str | os.PathLike,
    out_path: str | os.PathLike,
    report_path: str | os.PathLike | None = None,
    *,
    allow_small_angles: bool = False,
    qc_params: dict | None = None,
    heights_m: Sequence[float] | None = None,
    imu_statistics_path: str | os.PathLike | None = None,
    require_motion: bool = True,
) -> pd.DataFrame:
    """Validate the record table, refuse what leaves every record uncorrectable, report.

    Writes the validated table and the inspection report; warnings are logged and
    printed on stderr.

    Parameters
    ----------
    in_path, out_path : path
        The campaign's record table and its validated copy.
    report_path : path, optional
        JSON report of :func:`flidar_uq.workflow.inputs.inspect_records` (columns, time
        span, heights, gaps, reference share, QC preview, warnings).
    allow_small_angles : bool
        Config ``campaign.allow_small_angles``.
    qc_params : dict, optional
        The config's ``qc`` section, for the QC preview.
    heights_m : sequence of float, optional
        Selected heights, m (config ``campaign.heights``).
    imu_statistics_path : path, optional
        Per-record motion statistics of a raw IMU series (rule imu_statistics, config
        ``campaign.imu_series``): they replace the table's own motion columns (the series
        wins; logged).
    require_motion : bool
        The motion columns must be in the table (False for a campaign reported
        uncorrected, :func:`flidar_uq.workflow.inputs.missing_motion_columns`).

    Raises
    ------
    flidar_uq.data.io.DataValidationError
        On a bad record (names file, row and column) or a reference mean without a std.
    """
    import json

    from flidar_uq.data import io
    from flidar_uq.data.inspection import reference_problems
    from flidar_uq.inference.observations import with_shear_exponent
    from flidar_uq.workflow.inputs import inspect_records

    if imu_statistics_path:
        from flidar_uq.workflow.imu_step import merge_series_motion

        records, _ = merge_series_motion(
            io.read_records(
                in_path,
                require_motion=False,
                allow_small_angles=allow_small_angles,
                extra_columns="keep",
            ),
            imu_statistics_path,
        )
        records = io.validate_records(
            records,
            f"{in_path} + {imu_statistics_path}",
            allow_small_angles=allow_small_angles,
            extra_columns="keep",
        )
    else:
        records = io.read_records(
            in_path,
            allow_small_angles=allow_small_angles,
            extra_columns="keep",
            require_motion=require_motion,
        )
    problems = reference_problems(records, str(in_path))
    if problems:
        raise problems[0]
    # each time stamp's shear exponent from all its heights, before QC and the fits take
    # the records apart (flidar_uq.inference.observations.records_shear_exponent)
    records = with_shear_exponent(records)
    report = inspect_records(
        records,
        source=str(in_path),
        qc_params=qc_params,
        heights=list(heights_m) if heights_m else None,
    )
    for w in report["warnings"]:
        log.warning("%s", w)
        print(f"flidar-uq: warning: {w}", file=sys.stderr)
    Path(out_path).parent.mkdir(parents=True, exist_ok=True)
    io.write_records(
        records, out_path, allow_small_angles=allow_small_angles, require_motion=require_motion
    )
    if report_path is not None:
        Path(report_path).write_text(json.dumps(report, indent=1, sort_keys=True) + "\n")
    log.info("validate: %d records valid", len(records))
    return records


# --------------------------------------------------------------------------- QC, motion, bins


def run_qc(
    in_path: str | os.PathLike,
    flags_path: str | os.PathLike,
    kept_path: str | os.PathLike,
    summary_path: str | os.PathLike,
    qc_params: dict,
    *,
    heights_m: Sequence[float] | None = None,
    allow_small_angles: bool = False,
    speed_bins_path: str | os.PathLike | None = None,
    hws_width_ms: float = 1.0,
    require_motion: bool = True,
) -> pd.DataFrame:
    """Apply the QC filters; write every record with its reasons, the kept records, and counts.

    Parameters
    ----------
    in_path : path
        Validated record table.
    flags_path, kept_path, summary_path : path
        Outputs: the flags table (one row per input record: ``record_id``, ``reasons``,
        ``kept``, one ``fail_<reason>`` column per filter), the ``record_id`` of the kept
        records (Parquet, :func:`kept_records`), and the per-filter counts.
    qc_params : dict
        The ``qc`` section of the config: :class:`flidar_uq.data.qc.QCConfig` fields.
    heights_m : sequence of float, optional
        Selected heights, m (config ``campaign.heights``): records at other heights are
        flagged ``height_not_selected``.
    allow_small_angles : bool
        Config ``campaign.allow_small_angles``.
    speed_bins_path : path, optional
        Output: what each filter removed per height and mean-speed bin
        (:func:`flidar_uq.data.qc.speed_bin_summary`, bins ``hws_width_ms`` m/s wide).
    require_motion : bool
        The motion columns must be in the table (False for a campaign reported
        uncorrected).

    Returns
    -------
    pandas.DataFrame
        The flags table.
    """
    from flidar_uq.data import io, qc

    records = io.read_records(
        in_path,
        allow_small_angles=allow_small_angles,
        extra_columns="keep",
        require_motion=require_motion,
    )
    heights = tuple(heights_m) if heights_m else None
    result = qc.run_qc(records, qc.QCConfig(**qc_params, heights_m=heights))
    flags = result.flags.copy()
    flags.insert(0, "record_id", np.arange(len(flags)))
    kept = pd.DataFrame({"record_id": result.kept.index.to_numpy()})
    counts = result.counts.reset_index().rename(columns={"index": "reason"})
    write_csv(flags, flags_path)
    write_table(kept, kept_path)
    write_csv(counts, summary_path)
    if speed_bins_path is not None:
        write_csv(qc.speed_bin_summary(records, result.flags, hws_width_ms=hws_width_ms),
                  speed_bins_path)  # fmt: skip
    log.info("%s", result.summary())
    return flags


def kept_records(records_path: str | os.PathLike, *stage_paths: str | os.PathLike) -> pd.DataFrame:
    """The validated records a stage kept, with the columns the stages added.

    Each stage after validation writes only its key and its new columns (Parquet):
    results/qc/kept.parquet the ``record_id`` of the QC-kept records,
    results/motion/records.parquet the motion amplitude and period,
    results/bins/assignments.parquet the bins. This joins them back on ``record_id`` (the
    row of the validated table).

    Parameters
    ----------
    records_path : path
        The validated record table (results/data/records.parquet).
    *stage_paths : path
        Stage tables with ``record_id``, each holding a subset of the previous one's
        records; the last one gives the rows (in its order).

    Returns
    -------
    pandas.DataFrame
        ``record_id``, the validated columns, then each stage's columns; index reset.

    Raises
    ------
    ValueError
        When no stage table is given, or a stage names a record that an earlier one (or the
        validated table) lacks.
    """
    if not stage_paths:
        raise ValueError(f"kept_records: no stage table to join to {records_path}")
    records = read_table(records_path)
    stages = [read_table(p).set_index("record_id") for p in stage_paths]
    ids = stages[-1].index.to_numpy()
    outside = ids[(ids < 0) | (ids >= len(records))]
    if outside.size:
        raise ValueError(
            f"kept_records: {stage_paths[-1]} has record_id {int(outside[0])}, which "
            f"{records_path} ({len(records)} records) lacks"
        )
    for path, stage in zip(stage_paths, stages, strict=True):
        missing = np.setdiff1d(ids, stage.index.to_numpy())
        if missing.size:
            raise ValueError(
                f"kept_records: {stage_paths[-1]} has record_id {int(missing[0])}, which "
                f"{path} lacks"
            )
    out = records.iloc[ids].reset_index(drop=True)
    out.insert(0, "record_id", ids)
    for stage in stages:
        new = [c for c in stage.columns if c not in out.columns]
        out[new] = stage.loc[ids, new].reset_index(drop=True)
    return out


def motion_statistics(
    records_path: str | os.PathLike,
    kept_path: str | os.PathLike,
    out_path: str | os.PathLike,
    roll_pitch_path: str | os.PathLike,
) -> pd.DataFrame:
    """Per-record motion amplitude and period, and the roll-pitch correlation (Gutiérrez-Antuñano et al., 2018, Sec. 2.4).

    Computes ``amplitude_deg`` and ``period_s`` (the roll/pitch averages, Gutiérrez-Antuñano et al. (2018), Sec. 2.4) of
    each kept record (``records_path``: the validated table, ``kept_path``: the QC-kept
    ``record_id``, :func:`kept_records`) and writes them with ``record_id`` to ``out_path``
    (Parquet), and the roll-pitch correlation of amplitude and period (CSV).
    """
    from flidar_uq.data import binning, imu

    records = kept_records(records_path, kept_path)
    out = binning.add_harmonic_motion(records)
    corr = imu.roll_pitch_correlation(records)
    write_table(out[["record_id"] + [c for c in out.columns if c not in records.columns]], out_path)
    write_csv(pd.DataFrame([corr]), roll_pitch_path)
    return out


def make_bins(
    in_paths: Sequence[str | os.PathLike],
    assignments_path: str | os.PathLike,
    table_path: str | os.PathLike,
    *,
    hws_width_ms: float,
    amplitude_width_deg: float,
    period_width_s: float,
    min_count: int,
    nbatches: int,
) -> pd.DataFrame:
    """Bin the kept records (HWS x amplitude x period) and write the bin table with batches.

    The bin table (Gutiérrez-Antuñano et al., 2018, Table 1 style) is sorted by decreasing count; ``bin_id`` is the
    case number (1 = most frequent). Bins with at least ``min_count`` records are
    ``fitted`` and assigned a batch. The records (``in_paths``: the validated table and
    the motion statistics of the kept ones) are joined by :func:`kept_records`; the assignments (Parquet) hold the
    ``record_id`` of every binned record with its bin columns only.
    """
    from flidar_uq.data import binning

    records = kept_records(*in_paths)
    assigned, table = binning.bins_for_fitting(
        records,
        hws_width_ms=hws_width_ms,
        amplitude_width_deg=amplitude_width_deg,
        period_width_s=period_width_s,
        min_count=min_count,
        nbatches=nbatches,
    )
    added = [c for c in assigned.columns if c not in records.columns]
    write_table(assigned[["record_id"] + added], assignments_path)
    write_csv(table, table_path)
    log.info(
        "bins: %d bins, %d fitted, %d records unbinned",
        len(table),
        int(table["fitted"].sum()),
        len(records) - len(assigned),
    )
    return table


def sigma_z_table(
    table_path: str | os.PathLike, out_path: str | os.PathLike, *, lidar: str
) -> pd.DataFrame:
    """sigma_Z and E(Z) at each bin centre through the surrogate (Gutiérrez-Antuñano et al., 2018, Eqs. 4-14)."""
    from flidar_uq.physics.surrogate import get_surrogate

    table = read_csv(table_path)
    sur = get_surrogate(lidar)
    args = (
        table["hws_ms"].to_numpy(),
        table["amplitude_deg"].to_numpy(),
        table["period_s"].to_numpy(),
    )
    out = table[["bin_id", "hws_ms", "amplitude_deg", "period_s", "count"]].copy()
    out["sigma_z_ms"] = sur.sigma_z_ms(*args)
    out["mean_z_ms"] = sur.mean_z_ms(*args)
    write_csv(out, out_path)
    return out


# --------------------------------------------------------------------------- no motion statistics


def uncorrected_ti(
    records_path: str | os.PathLike,
    flags_path: str | os.PathLike,
    records_out: str | os.PathLike,
    speed_bins_out: str | os.PathLike,
    *,
    min_count: int = 10,
) -> pd.DataFrame:
    """results/ti/ of a campaign without motion statistics: the floating lidar's TI as
    measured, not corrected for the buoy's motion.

    Writes the two tables of a corrected run in its schema, the corrected columns NaN:
    records.csv (every input record, its QC reasons or ``no_motion_description``) and
    speed_bins.csv (per height and 1-m/s bin over the QC-kept records: ``n`` and the
    uncorrected mean, sd, representative TI ``mean + 1.28 sd`` and 90 % quantile of
    :func:`flidar_uq.correction.propagation.ti_group_statistics`, given the measured TI as
    its one draw).

    Parameters
    ----------
    records_path : path
        Validated record table (rule validate).
    flags_path : path
        QC flags, one row per record of ``records_path`` (:func:`run_qc`).
    records_out, speed_bins_out : path
        Outputs: results/ti/records.csv and results/ti/speed_bins.csv.
    min_count : int
        Fewest records for a bin's statistics (config ``report.group_min_count``, >= 2);
        bins below it keep their count and NaN statistics.

    Returns
    -------
    pandas.DataFrame
        The records table written.
    """
    from flidar_uq.correction import propagation as prop
    from flidar_uq.correction.campaign import RECORD_COLUMNS, carried_columns
    from flidar_uq.data import io
    from flidar_uq.data.binning import speed_bin_ms
    from flidar_uq.data.metrics import turbulence_intensity
    from flidar_uq.data.schema import CORRECTED_TI_COLUMNS

    rec = io.read_records(records_path, require_motion=False, extra_columns="keep")
    flags = read_csv(flags_path, ["record_id", "timestamp", "reasons"])
    if len(flags) != len(rec):
        raise ValueError(
            f"uncorrected_ti: {flags_path} has {len(flags)} rows, {records_path} {len(rec)} records"
        )
    reasons = flags["reasons"].astype(object).fillna("").reset_index(drop=True)
    n = len(rec)
    mean_ms = rec["hws_mean_ms"].to_numpy(dtype=float)
    ti = turbulence_intensity(rec["hws_std_ms"], mean_ms)
    out = pd.DataFrame({"record_id": flags["record_id"], "timestamp": flags["timestamp"]})
    out["height_m"] = rec["height_m"].to_numpy(dtype=float)
    out["bin_id"] = np.nan
    out["hws_mean_ms"] = mean_ms
    out["hws_std_ms"] = rec["hws_std_ms"].to_numpy(dtype=float)
    out["ti_uncorrected"] = ti
    for col in CORRECTED_TI_COLUMNS:
        out[col] = np.nan
    out["flags"] = prop.record_flags(
        reasons,
        np.full(n, np.nan),
        np.zeros(n, dtype=bool),
        np.zeros(n, dtype=bool),
        fitted=pd.Series(dtype=bool),
        status=pd.Series(dtype=object),
        global_converged=True,
        motion_described=np.zeros(n, dtype=bool),
    )
    if "ref_hws_std_ms" in rec:
        out["ref_hws_std_ms"] = rec["ref_hws_std_ms"].to_numpy(dtype=float)
        out["ti_ref"] = turbulence_intensity(rec["ref_hws_std_ms"], rec["ref_hws_mean_ms"])
    for col in carried_columns(rec.columns):
        if col not in out.columns:
            out[col] = rec[col].to_numpy()
    out = out[RECORD_COLUMNS + [c for c in out.columns if c not in RECORD_COLUMNS]]
    kept = reasons.eq("").to_numpy() & np.isfinite(ti)
    keys = pd.DataFrame(
        {"height_m": out["height_m"][kept], "hws_bin_ms": speed_bin_ms(mean_ms[kept])}
    )
    bins = prop.ti_group_statistics(
        ti[None, kept],  # the measured TI, one draw: no posterior to propagate
        pd.DataFrame({"converged": np.ones(int(kept.sum()), bool), "ti_uncorrected": ti[kept]}),
        keys,
        min_count=min_count,
    )
    corrected = [c for c in bins.columns if c.startswith("ti_") and "uncorrected" not in c]
    bins[corrected] = np.nan
    write_csv(out, records_out)
    write_csv(bins, speed_bins_out)
    log.info(
        "uncorrected: %d records (%d kept by QC), %d height x speed bins -> %s",
        n, int(kept.sum()), len(bins), speed_bins_out,
    )  # fmt: skip
    return out
