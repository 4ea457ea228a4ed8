"""Readers of the instruments' own files: WindCube v2 ``.sta``, ZephIR 300 / ZX300 CSV and
the IEA Wind Task 43 data model (``docs/data-format.md``, "Instrument formats"); and of
LOS series: the documented table or a WindCube v2 real-time file ``.rtd``
(:func:`read_los_file`).

:func:`read_instrument` reads such a file with no column map: the heights and
quantities come from the instrument's column names, the time conventions from its
header (UTC offset, stamps at the start or end of the interval), and the result is the
record table (UTC at the interval start, one row per interval and height) together
with what the header states (:attr:`InstrumentRecords.facts`) and the mapping used.
Errors name the file, the row and its line, and the file's column.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pandas as pd

from flidar_uq.data.formats import iea43, windcube, zephir
from flidar_uq.data.formats.common import INTERVAL_MIN, check_alignment
from flidar_uq.data.io import DataValidationError, heading_ccw_deg
from flidar_uq.data.schema import WAVE_PERIOD_FALLBACK_COLUMN

__all__ = [
    "FORMATS",
    "INSTRUMENT_FORMATS",
    "InstrumentRecords",
    "detect_format",
    "read_instrument",
    "read_any",
    "complete_motion",
    "LOS_FORMATS",
    "detect_los_format",
    "read_los_file",
    "heading_ccw_deg",
    "check_alignment",
    "INTERVAL_MIN",
]

#: Values of config ``campaign.format`` (``table``: the documented record table).
FORMATS = ("auto", "table", "windcube_sta", "zephir_csv", "iea43")
INSTRUMENT_FORMATS = {"windcube_sta": windcube, "zephir_csv": zephir, "iea43": iea43}
#: Formats of a LOS series (config ``campaign.los_series``): the documented table (CSV or
#: Parquet) or a WindCube v2 real-time file.
LOS_FORMATS = ("table", "windcube_rtd")


@dataclass
class InstrumentRecords:
    """An instrument file as a record table.

    Attributes
    ----------
    records : pandas.DataFrame
        Validated record table (``flidar_uq.data.io.validate_records``), motion columns
        not required; extra columns per ``extra_columns``.
    facts : dict
        What the header states (``utc_offset_h`` in h, ``timestamp_at``, ``heights_m``,
        ``scan_angle_deg``, ``serial_number``, ...), plus ``format``.
    mapping : dict
        The file's column -> the record column (per-height columns by their name).
    notes : list of str
        Derivations made (availability from packet counts, heading conversion).
    """

    records: pd.DataFrame
    facts: dict
    mapping: dict
    notes: list = field(default_factory=list)


def detect_format(path: str | Path) -> str:
    """The format of a file from its first line: one of :data:`FORMATS` but ``auto``.

    ``windcube_sta`` (``HeaderSize=``), ``zephir_csv`` (a ``Time sync``/``Unit:``
    metadata line), ``iea43`` (a JSON header, or a ``.json`` file of the same name that is
    recognisably Task 43 metadata, :func:`iea43.metadata_sidecar`; any other ``.json``
    beside the file changes nothing), else ``table``.
    """
    path = Path(path)
    head = _first_line(path)
    if head is None:
        return "table"
    if windcube.looks_like(head) or path.suffix.lower() == ".sta":
        return "windcube_sta"
    if iea43.looks_like(head):
        return "iea43"
    if zephir.looks_like(head):
        return "zephir_csv"
    if iea43.metadata_sidecar(path) is not None:
        return "iea43"
    return "table"


def _first_line(path: Path) -> str | None:
    """The file's first line (latin-1), or None for a binary table or an unreadable file."""
    if path.suffix.lower() in (".parquet", ".pq") or path.name.lower().endswith(".gz"):
        return None
    try:
        with open(path, "rb") as fh:
            return fh.read(4096).decode("latin-1").split("\n", 1)[0]
    except OSError:
        return None


def detect_los_format(path: str | Path) -> str:
    """The format of a LOS series, one of :data:`LOS_FORMATS`.

    ``windcube_rtd`` for a ``.rtd`` file or a WindCube header (``HeaderSize=`` on line 1),
    else ``table``.
    """
    path = Path(path)
    if path.suffix.lower() == ".rtd" or windcube.looks_like(_first_line(path) or ""):
        return "windcube_rtd"
    return "table"


def read_los_file(
    path: str | Path, *, utc_offset_h: float | None = None
) -> tuple[pd.DataFrame, dict]:
    """Read a LOS series in any of :data:`LOS_FORMATS` (:func:`detect_los_format`).

    Parameters
    ----------
    path : str or pathlib.Path
        The documented LOS table (CSV or Parquet, docs/data-format.md) or a WindCube v2
        ``.rtd`` (:func:`flidar_uq.data.formats.windcube.read_rtd`: speeds turned positive
        away from the lidar, ``Position`` into ``azimuth_deg`` and ``elevation_deg``, stamps
        into UTC).
    utc_offset_h : float, optional
        A ``.rtd`` without ``timezone`` line: offset of its stamps from UTC, h (config
        ``campaign.utc_offset_h``). A table's stamps carry their zone.

    Returns
    -------
    los : pandas.DataFrame
        The validated LOS series.
    facts : dict
        ``format`` and what a ``.rtd``'s header states (scan angle, heights, UTC offset).

    Raises
    ------
    flidar_uq.data.io.DataValidationError
        Naming the file, the row and the column.
    """
    from flidar_uq.data import io

    path = Path(path)
    if detect_los_format(path) == "table":
        return io.read_los_series(path), {"format": "table"}
    los, facts = windcube.read_rtd(path, utc_offset_h=utc_offset_h)
    return los, {"format": "windcube_rtd", **facts}


def _long(parsed, source: str) -> tuple[pd.DataFrame, np.ndarray, list[dict]]:
    """One row per interval and height (file order, heights ascending), the file row of
    each and, per row, record column -> file column (for messages)."""
    t = parsed.table
    shared = {c: n for c, n in parsed.shared.items() if n != "timestamp"}
    parts, names = [], []
    heights = sorted(parsed.per_height)
    if not heights:
        raise DataValidationError(
            source, None, None, "no measurement-height columns found", header=True
        )
    for h in heights:
        cols = parsed.per_height[h]
        # one constructor, not a column at a time: a wide file would fragment the frame
        columns = {n: t[c].to_numpy() for c, n in (*shared.items(), *cols.items())}
        parts.append(
            pd.DataFrame({"timestamp": t["timestamp"].to_numpy(), "height_m": h, **columns})
        )
        names.append({n: c for c, n in {**shared, **cols}.items()})
    n = len(t)
    out = pd.concat(parts, ignore_index=True)
    order = np.lexsort((np.repeat(np.arange(len(parts)), n), np.tile(np.arange(n), len(parts))))
    out = out.iloc[order].reset_index(drop=True)
    file_row = np.tile(np.arange(n), len(parts))[order] + 1
    which = np.repeat(np.arange(len(parts)), n)[order]
    return out, file_row, [names[k] for k in which]


def read_instrument(
    path: str | Path,
    fmt: str = "auto",
    *,
    utc_offset_h: float | None = None,
    timestamp_at: str | None = None,
    extra_columns: str = "keep",
    allow_small_angles: bool = False,
) -> InstrumentRecords:
    """Read an instrument file into the record table.

    Parameters
    ----------
    path : str or pathlib.Path
        The file.
    fmt : str
        One of :data:`INSTRUMENT_FORMATS` or ``auto`` (:func:`detect_format`).
    utc_offset_h : float, optional
        Offset of the file's stamps from UTC, h (config ``campaign.utc_offset_h``); a
        header that states it wins, and both must agree.
    timestamp_at : {"start", "end"}, optional
        Where the stamps lie in the interval when the header does not say it.
    extra_columns : {"keep", "ignore", "error"}
        What to do with the file's columns that are not record columns.
    allow_small_angles : bool
        See :func:`flidar_uq.data.io.validate_records`.

    Raises
    ------
    flidar_uq.data.io.DataValidationError
        One line naming the file, row (and line) and the file's column.
    ValueError
        On an unknown format.
    """
    from flidar_uq.data import io

    path = Path(path)
    if fmt == "auto":
        fmt = detect_format(path)
    if fmt not in INSTRUMENT_FORMATS:
        raise ValueError(f"read_instrument: format must be one of {sorted(INSTRUMENT_FORMATS)}")
    parsed = INSTRUMENT_FORMATS[fmt].read(
        path, utc_offset_h=utc_offset_h, timestamp_at=timestamp_at
    )
    check_alignment(
        parsed.table["timestamp"], source=str(path), column="timestamp",
        first_line=parsed.first_line,
    )  # fmt: skip
    long, file_row, names = _long(parsed, str(path))
    try:
        records = io.validate_records(
            long,
            str(path),
            require_motion=False,
            allow_small_angles=allow_small_angles,
            extra_columns=extra_columns,
        )
    except DataValidationError as exc:
        if exc.row is None:
            raise exc.renamed(names[0]) from None
        k = exc.row - 1
        raise DataValidationError(
            str(path),
            int(file_row[k]),
            names[k].get(exc.column, exc.column),
            exc.problem,
            line=parsed.first_line + int(file_row[k]) - 1,
            mapped_from=exc.column,
        ) from None
    mapping = {}
    for cols in [parsed.shared, *parsed.per_height.values()]:
        mapping.update({c: n for c, n in cols.items() if n in records.columns or c != n})
    facts = {"format": fmt, **parsed.facts}
    return InstrumentRecords(records, facts, mapping, list(parsed.notes))


def complete_motion(records: pd.DataFrame) -> tuple[pd.DataFrame, list[str]]:
    """Derive absent motion columns from what a buoy logger writes.

    ``roll_amplitude_deg = sqrt(2) * roll_std_deg`` (likewise pitch) when the amplitude
    column is absent; ``roll_period_s`` and ``pitch_period_s`` = ``wave_tp_s`` (s) when
    neither period column is there. Returns the table and one note per derivation.
    """
    out = records.copy()
    notes = []
    for axis in ("roll", "pitch"):
        amp, std = f"{axis}_amplitude_deg", f"{axis}_std_deg"
        if amp not in out.columns and std in out.columns:
            out[amp] = np.sqrt(2.0) * pd.to_numeric(out[std], errors="coerce")
            notes.append(f"{amp} = sqrt(2) * {std} (a sinusoid's amplitude from its std)")
    periods = ("roll_period_s", "pitch_period_s")
    if not any(p in out.columns for p in periods) and WAVE_PERIOD_FALLBACK_COLUMN in out.columns:
        for p in periods:
            out[p] = out[WAVE_PERIOD_FALLBACK_COLUMN]
        notes.append(
            f"roll_period_s and pitch_period_s = {WAVE_PERIOD_FALLBACK_COLUMN} (no attitude "
            "period and no raw IMU series: the buoy taken to move at the wave peak period)"
        )
    return out, notes


def read_any(
    path: str | Path,
    conventions=None,
    *,
    columns=None,
    extra_columns: str = "keep",
    allow_small_angles: bool = False,
) -> InstrumentRecords:
    """Read a record table or an instrument file under the campaign's conventions.

    Parameters
    ----------
    path : str or pathlib.Path
        The file.
    conventions : mapping, optional
        Config ``campaign`` keys ``format`` (:data:`FORMATS`, default ``auto``),
        ``utc_offset_h`` (h), ``timestamp_at`` (``start``/``end``) and
        ``heading_convention`` (``ccw``/``compass``; of a table's ``heading_mean_deg``:
        the instrument formats state their own, a ZephIR's bearing and an IEA 43
        ``compass_direction`` are compass headings).
    columns : mapping, optional
        Column map of a ``table`` (:func:`flidar_uq.data.io.validate_records`).
    extra_columns, allow_small_angles
        See :func:`read_instrument`.

    Returns
    -------
    InstrumentRecords
        Records validated without requiring the motion columns (the caller validates
        the complete table), facts, mapping and notes.
    """
    from flidar_uq.data import io

    conv = dict(conventions or {})
    fmt = conv.get("format") or "auto"
    if fmt == "auto":
        fmt = "table" if columns else detect_format(path)
    offset = conv.get("utc_offset_h")
    at = conv.get("timestamp_at")
    compass = conv.get("heading_convention", "ccw") == "compass"
    if fmt != "table":
        got = read_instrument(
            path, fmt, utc_offset_h=offset, timestamp_at=at, extra_columns=extra_columns,
            allow_small_angles=allow_small_angles,
        )  # fmt: skip
        return got
    df, source, csv = io._read_table(path)
    notes = []
    if compass:
        back = {v: k for k, v in (columns or {}).items() if v}
        col = back.get("heading_mean_deg", "heading_mean_deg")
        if col in df.columns:
            x = pd.to_numeric(df[col], errors="coerce")
            df[col] = df[col].where(x.isna(), pd.Series(heading_ccw_deg(x), index=df.index))
            notes.append(f"heading_mean_deg from {col!r}, a compass bearing turned ccw")
    records = io.validate_records(
        df, source, require_motion=False, allow_small_angles=allow_small_angles, csv=csv,
        columns=columns, extra_columns=extra_columns,
    )  # fmt: skip
    shift = pd.Timedelta(hours=float(offset or 0.0))
    if at == "end":
        shift += pd.Timedelta(minutes=INTERVAL_MIN)
    if shift:
        records["timestamp"] = records["timestamp"] - shift
    check_alignment(records["timestamp"], source=source, column="timestamp", first_line=None)
    facts = {
        "format": "table",
        "utc_offset_h": float(offset or 0.0),
        "timestamp_at": at or "start",
    }
    mapping = {k: v for k, v in (columns or {}).items() if v}
    return InstrumentRecords(records, facts, mapping, notes)
