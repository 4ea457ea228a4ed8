"""A campaign in several files joined on the 10-min interval.

A floating-lidar campaign arrives as the lidar's export (the record table or an
instrument file: one row per interval and height), the buoy's logger (attitude, MRU,
wave sensor: one row per interval) and the reference's file (a mast logger: one row per
interval, per height through ``{height}`` column-map names). Each file has its own
format, column map and time conventions (:data:`PART_KEYS`); all are turned into UTC at
the interval start, then the logger's and the reference's columns are joined onto the
lidar's records by interval (and height, where the file has heights). A logger with a
coarser cadence (a wave sensor's 20- or 30-min bursts) is joined burst by burst
(:func:`join_records`). The join is reported per file: its cadence, intervals in it,
matched with the lidar's, unmatched on each side.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from flidar_uq.data import io
from flidar_uq.data.formats.common import INTERVAL_MIN, check_alignment
from flidar_uq.data.schema import TRUTH_PREFIX, record_columns_by_name

__all__ = [
    "PART_KEYS", "JOIN_COLUMNS", "read_part", "interval_min", "join_records", "join_report"
]  # fmt: skip

#: Keys of a file section (config ``campaign.motion_file``, ``campaign.reference_file``).
PART_KEYS = ("path", "columns", "utc_offset_h", "timestamp_at", "heading_convention")
#: Columns of the join report (results/campaign/join.csv).
JOIN_COLUMNS = [
    "role", "path", "interval_min", "intervals", "matched", "unmatched_lidar", "unmatched_file"
]  # fmt: skip


def read_part(part: dict, *, extra_columns: str = "keep") -> pd.DataFrame:
    """Read a logger or reference file: its record columns validated, UTC interval start.

    Parameters
    ----------
    part : dict
        :data:`PART_KEYS`: ``path``; ``columns`` (column map to record columns, ``{height}``
        names for per-height columns); ``utc_offset_h`` (h, stamps without a zone);
        ``timestamp_at`` (``start``/``end`` of the interval: 10 min, or of a coarser
        file's bursts, :func:`interval_min`); ``heading_convention`` (``ccw``/``compass``).
    extra_columns : {"keep", "ignore", "error"}
        Columns that are not record columns.

    Returns
    -------
    pandas.DataFrame
        ``timestamp`` (UTC, interval start), ``height_m`` when the file has heights, the
        record columns (float64) and the kept extra columns.

    Raises
    ------
    flidar_uq.data.io.DataValidationError
        Naming file, row and column.
    """
    path = Path(part["path"])
    df, source, csv = io._read_table(path)
    known = record_columns_by_name()
    pieces = io._apply_column_map(df, part.get("columns") or {}, source)
    out = []
    for table, names in pieces:
        if "timestamp" not in table.columns:
            raise io.DataValidationError(
                source, None, "timestamp", "required column missing", header=True
            )
        cols = {c: known[c] for c in table.columns if c in known}
        other = [c for c in table.columns if c not in known and not c.startswith(TRUTH_PREFIX)]
        if other and extra_columns == "error":
            raise io.DataValidationError(
                source, None, other[0], "unknown column (campaign.extra_columns: error)",
                header=True,
            )  # fmt: skip
        try:
            if part.get("heading_convention") == "compass" and "heading_mean_deg" in table:
                x = pd.to_numeric(table["heading_mean_deg"], errors="coerce")
                table = table.assign(heading_mean_deg=io.heading_ccw_deg(x))
            values = io._coerce(table[list(cols)], cols, source, csv)
            for col in cols.values():
                io._check_values(values, col, source, csv)
        except io.DataValidationError as exc:
            raise exc.renamed(names) from None
        if extra_columns == "keep":
            values = pd.concat([values, table[other].reset_index(drop=True)], axis=1)
        out.append(values)
    data = pd.concat(out, ignore_index=True)
    shift = pd.Timedelta(hours=float(part.get("utc_offset_h") or 0.0))
    if part.get("timestamp_at") == "end":  # a coarser file's stamps end its bursts
        shift += pd.Timedelta(minutes=interval_min(data["timestamp"]))
    data["timestamp"] = data["timestamp"] - shift
    check_alignment(data["timestamp"], source=source, column="timestamp", first_line=None)
    keys = ["timestamp"] + (["height_m"] if "height_m" in data.columns else [])
    dup = data.duplicated(keys).to_numpy()
    if dup.any():
        k = int(np.flatnonzero(dup)[0])
        raise io.DataValidationError(
            source, k + 1, "timestamp",
            f"interval {data['timestamp'].iloc[k].isoformat()} twice in the file", csv=csv,
        )  # fmt: skip
    return data


def interval_min(timestamps) -> float:
    """The cadence of a file's stamps, min: the shortest step between them.

    The shortest, so that gaps do not lengthen it; never less than the record interval
    (:data:`INTERVAL_MIN`, also the cadence of a single stamp).
    """
    t = pd.DatetimeIndex(timestamps).unique().sort_values()
    if len(t) < 2:
        return float(INTERVAL_MIN)
    step = pd.Series(t).diff().min() / pd.Timedelta(minutes=1)
    return max(float(step), float(INTERVAL_MIN))


def _burst_of(lidar_t: pd.DatetimeIndex, part_t: pd.DatetimeIndex, cadence_min: float):
    """For each lidar interval start, the stamp of the burst covering it: the latest stamp
    at or before it and less than ``cadence_min`` (min) before it; NaT where none."""
    got = pd.merge_asof(
        pd.DataFrame({"timestamp": lidar_t.sort_values()}),
        pd.DataFrame({"timestamp": part_t.sort_values(), "burst": part_t.sort_values()}),
        on="timestamp",
        direction="backward",
        tolerance=pd.Timedelta(minutes=cadence_min) - pd.Timedelta(microseconds=1),
    )
    return pd.Series(got["burst"].array, index=pd.DatetimeIndex(got["timestamp"]))


def join_records(
    lidar: pd.DataFrame, parts: dict[str, pd.DataFrame]
) -> tuple[pd.DataFrame, list[dict]]:
    """Join each part's columns onto the lidar's records by interval (and height).

    A part without heights whose cadence (:func:`interval_min`) is coarser than the
    10-min records, e.g. a wave sensor's 20-min bursts stamped at their start, is joined
    burst by burst: each record takes the burst that covers its start, the latest stamp at
    or before it and less than one cadence before it (a record whose burst is missing gets
    NaN, not an older burst). At the 10-min cadence this is the match by interval.

    Parameters
    ----------
    lidar : pandas.DataFrame
        The lidar's records (``timestamp`` UTC interval start, ``height_m``).
    parts : dict
        Role (``motion``, ``reference``) -> :func:`read_part` table.

    Returns
    -------
    records : pandas.DataFrame
        The lidar's rows in order; a part's column replaces a lidar column of that name.
    report : list of dict
        One row per file (:data:`JOIN_COLUMNS` without ``path``).
    """
    lid_t = pd.DatetimeIndex(lidar["timestamp"]).unique()
    rows = [
        dict(role="lidar", interval_min=float(INTERVAL_MIN), intervals=len(lid_t),
             matched=len(lid_t), unmatched_lidar=0, unmatched_file=0)
    ]  # fmt: skip
    out = lidar.reset_index(drop=True)
    for role, part in parts.items():
        keys = ["timestamp"] + (["height_m"] if "height_m" in part.columns else [])
        new = [c for c in part.columns if c not in keys]
        part_t = pd.DatetimeIndex(part["timestamp"]).unique()
        cadence = interval_min(part_t) if len(keys) == 1 else float(INTERVAL_MIN)
        left = out.drop(columns=[c for c in new if c in out.columns])
        if cadence > INTERVAL_MIN:
            # one time unit on both sides: the files' stamps may be parsed at different ones
            burst = _burst_of(lid_t.as_unit("ns"), part_t.as_unit("ns"), cadence)
            start = pd.DatetimeIndex(left["timestamp"]).as_unit("ns")
            stamps = pd.DatetimeIndex(part["timestamp"]).as_unit("ns")
            merged = (
                left.assign(_burst=burst.reindex(start).array)
                .merge(part.assign(timestamp=stamps).rename(columns={"timestamp": "_burst"}),
                       on="_burst", how="left", sort=False, validate="many_to_one")
                .drop(columns="_burst")
            )  # fmt: skip
            used = pd.DatetimeIndex(burst.dropna().unique())
            matched = int(burst.notna().sum())
        else:
            merged = left.merge(part, on=keys, how="left", sort=False, validate="many_to_one")
            used = lid_t.intersection(part_t)
            matched = len(used)
        out = merged
        rows.append(
            dict(
                role=role,
                interval_min=cadence,
                intervals=len(part_t),
                matched=matched,
                unmatched_lidar=len(lid_t) - matched,
                unmatched_file=len(part_t) - len(part_t.intersection(used)),
            )
        )
    return out, rows


def join_report(rows: list[dict], paths: dict[str, str]) -> pd.DataFrame:
    """The join report as a table (:data:`JOIN_COLUMNS`); ``paths``: role -> file."""
    table = pd.DataFrame(rows)
    table.insert(1, "path", [paths.get(r, "") for r in table["role"]])
    return table[JOIN_COLUMNS]


#: Keys of config ``campaign`` that set the conventions of the records file.
CONVENTION_KEYS = ("format", "utc_offset_h", "timestamp_at", "heading_convention")


def read_campaign(
    records_path: str | Path,
    campaign: dict,
    *,
    require_motion: bool = True,
    allow_small_angles: bool = False,
) -> tuple[pd.DataFrame, pd.DataFrame, dict, list[str]]:
    """The campaign's validated records from its files, as the pipeline reads them.

    Parameters
    ----------
    records_path : str or pathlib.Path
        The lidar's file: a record table or an instrument file (config
        ``campaign.records``, or ``campaign.lidar_file.path``).
    campaign : dict
        Config ``campaign``: :data:`CONVENTION_KEYS`, ``columns``, ``extra_columns`` and
        the sections ``motion_file`` and ``reference_file`` (:data:`PART_KEYS`; an empty
        ``path``: no such file).
    require_motion, allow_small_angles : bool
        See :func:`flidar_uq.data.io.validate_records`.

    Returns
    -------
    records : pandas.DataFrame
        Validated records (absent motion columns derived,
        :func:`flidar_uq.data.formats.complete_motion`).
    join : pandas.DataFrame
        The join report (:data:`JOIN_COLUMNS`), one row per file.
    facts : dict
        What the lidar file's header states (with its ``format``).
    notes : list of str
        Derivations made.
    """
    from flidar_uq.data.formats import complete_motion, read_any

    extra = campaign.get("extra_columns", "keep")
    conv = {k: campaign[k] for k in CONVENTION_KEYS if campaign.get(k) is not None}
    got = read_any(
        records_path, conv, columns=campaign.get("columns") or None, extra_columns=extra,
        allow_small_angles=allow_small_angles,
    )  # fmt: skip
    parts, paths = {}, {"lidar": str(records_path)}
    for role in ("motion", "reference"):
        part = campaign.get(f"{role}_file") or {}
        if part.get("path"):
            parts[role] = read_part(part, extra_columns=extra)
            paths[role] = str(part["path"])
    records, rows = join_records(got.records, parts)
    records, notes = complete_motion(records)
    records = io.validate_records(
        records, " + ".join(paths.values()), require_motion=require_motion,
        allow_small_angles=allow_small_angles, extra_columns="keep",
    )  # fmt: skip
    return records, join_report(rows, paths), got.facts, got.notes + notes
