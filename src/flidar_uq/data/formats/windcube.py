"""WindCube v2 files: 10-min statistics (``.sta``) and real-time lines of sight (``.rtd``).

The ``.sta`` becomes the record table (:func:`read`), the ``.rtd`` (one row per line of
sight) the LOS series (:func:`read_rtd`). Both have a ``key=value`` header block, then a
tab-separated table.

Layout of the ``.sta`` (as the instrument writes it): line 1 ``HeaderSize=N``; lines 2 to N+1 are
``key=value`` pairs (``ID System=WLS7-164``, ``timezone=UTC+0``, ``ScanAngle (°)=28.000``,
``Altitudes (m)=\\t40\\t58...``) and ``****`` separators; line N+2 names the columns,
``Timestamp (end of interval)`` first, then per height ``40m Wind Speed (m/s)``,
``40m Wind Speed Dispersion (m/s)``, ``40m Wind Direction (°)``, ``40m CNR (dB)``,
``40m Data Availability (%)`` ... with an empty column between heights. Stamps
``2016/11/24 00:10`` mark the end of the interval. Text is latin-1 (``°``).
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pandas as pd

from flidar_uq.data.formats.common import (
    ParsedFile,
    numeric_columns,
    parse_stamps,
    read_text,
    resolve_offset_h,
    to_utc_start,
    with_timestamp,
)
from flidar_uq.data.io import DataValidationError, validate_los_series

__all__ = ["looks_like", "read", "read_rtd"]

_TIME = "Timestamp (end of interval)"
_TIME_START = "Timestamp (start of interval)"
_FORMATS = ("%Y/%m/%d %H:%M", "%Y/%m/%d %H:%M:%S", "%Y/%m/%d %H:%M:%S.%f")
#: quantity of a height column (name without the ``40m `` prefix) -> record column
QUANTITIES = {
    "Wind Speed (m/s)": "hws_mean_ms",
    "Wind Speed Dispersion (m/s)": "hws_std_ms",
    "Wind Direction (°)": "wd_mean_deg",
    "CNR (dB)": "cnr_mean_db",
    "Data Availability (%)": "availability_pct",
}
_REQUIRED = ("Wind Speed (m/s)", "Wind Speed Dispersion (m/s)", "Data Availability (%)")
_HEIGHT_COL = re.compile(r"(\d+(?:\.\d+)?)m (.+)")
#: header keys kept as facts (key -> fact name)
_FACT_KEYS = {
    "ID System": "serial_number",
    "Version": "software_version",
    "Location": "location",
    "GPS Location": "gps_location",
    "timezone": "timezone",
}


def looks_like(head: str) -> bool:
    """Whether the first line of a text is a WindCube header (``HeaderSize=``)."""
    return bool(re.match(r"\s*Header(Size|Length)\s*=\s*\d+", head))


def _header(lines: list[str], source: str, first_column: str = _TIME) -> tuple[dict, int]:
    """The ``key=value`` pairs of the header block and the index of the column line (whose
    first column, ``first_column``, names the time stamps)."""
    m = re.fullmatch(r"\s*HeaderSize\s*=\s*(\d+)\s*", lines[0])
    if m is None:
        raise DataValidationError(
            source,
            None,
            lines[0].split("=")[0].strip(),
            "not a WindCube v2 header (expected 'HeaderSize=N' on line 1; the v1 layout "
            "'HeaderLength=' with indexed columns is not read: export the v2 statistics)",
            line=1,
        )
    n = int(m.group(1))
    col_line = n + 1  # index of the column names
    if len(lines) <= col_line or not lines[col_line].startswith("Timestamp"):
        got = "the file ends" if len(lines) <= col_line else repr(lines[col_line][:40])
        raise DataValidationError(
            source,
            None,
            "HeaderSize",
            f"truncated header: HeaderSize={n} puts the column names on line {n + 2}, "
            f"but there {got} (expected '{first_column}...')",
            line=n + 2,
        )
    pairs = {}
    for ln in lines[1:col_line]:
        if "=" in ln:
            key, _, value = ln.partition("=")
            pairs[key.strip()] = value.strip()
    return pairs, col_line


def _facts(pairs: dict) -> dict:
    facts = {name: pairs[key] for key, name in _FACT_KEYS.items() if key in pairs}
    for key, value in pairs.items():
        if key.replace(" ", "").startswith("ScanAngle"):
            facts["scan_angle_deg"] = float(value)
        if key.replace(" ", "").startswith("Altitudes"):
            facts["heights_m"] = [float(h) for h in value.split()]
        if key.replace(" ", "").lower().startswith("averagingperiod"):
            facts["averaging_period"] = value
    return facts


def _offset_h(pairs: dict) -> float | None:
    zone = pairs.get("timezone")
    if not zone:
        return None
    m = re.fullmatch(r"UTC\s*([-+]\d+(?:[.:]\d+)?)?", zone.strip())
    if m is None:
        return None
    if not m.group(1):
        return 0.0
    text = m.group(1)
    if ":" in text:
        h, mnt = text.split(":")
        return float(h) + (1 if float(h) >= 0 else -1) * float(mnt) / 60
    return float(text)


def _rows(lines: list[str], col_line: int, source: str) -> tuple[list[str], list[list[str]]]:
    header = lines[col_line].split("\t")
    rows = []
    for i, ln in enumerate(lines[col_line + 1 :]):
        if not ln.strip():
            continue
        fields = ln.split("\t")
        if len(fields) != len(header):
            k = min(len(fields), len(header) - 1)
            # a stamp holds a space: spaces are a separator only on a line without tabs
            spaces = " " if "\t" not in ln and " " in ln.strip() else None
            sep = next((s for s in (";", ",") if s in ln), spaces)
            hint = f" (fields separated by {sep!r} here? the file uses tabs)" if sep else ""
            raise DataValidationError(
                source,
                len(rows) + 1,
                header[k] or f"field {k + 1}",
                f"{len(fields)} tab-separated fields where the column line has {len(header)}{hint}",
                line=col_line + 2 + i,
            )
        rows.append(fields)
    if not rows:
        raise DataValidationError(source, None, None, "no data rows", line=col_line + 1)
    return header, rows


def read(
    path: Path, *, utc_offset_h: float | None = None, timestamp_at: str | None = None
) -> ParsedFile:
    """Read a WindCube v2 ``.sta`` file.

    Parameters
    ----------
    path : pathlib.Path
        The file.
    utc_offset_h : float, optional
        Offset of the stamps from UTC, h (config ``campaign.utc_offset_h``); the header's
        ``timezone`` wins, and the two must agree when both are given.
    timestamp_at : {"start", "end"}, optional
        Where the stamps lie in the interval; default from the column name (``end``).

    Raises
    ------
    flidar_uq.data.io.DataValidationError
        Naming the file, the row and line and the column.
    """
    source = str(path)
    lines = read_text(path).split("\n")
    pairs, col_line = _header(lines, source)
    header, rows = _rows(lines, col_line, source)
    facts = _facts(pairs)
    zone_line = next(
        (i + 1 for i, ln in enumerate(lines[:col_line]) if ln.startswith("timezone")), 1
    )
    offset = resolve_offset_h(
        _offset_h(pairs), utc_offset_h, source=source, line=zone_line, key="timezone"
    )
    at_end = header[0] != _TIME_START if timestamp_at is None else timestamp_at == "end"
    facts.update(utc_offset_h=offset, timestamp_at="end" if at_end else "start")
    first_line = col_line + 2
    names = [h if h else f"_empty_{i}" for i, h in enumerate(header)]
    table = pd.DataFrame(rows, columns=names, dtype=object)
    table = table.drop(columns=[n for n in names if n.startswith("_empty_")])
    local = parse_stamps(
        table.pop(names[0]), _FORMATS, source=source, column=header[0], first_line=first_line
    )
    table = with_timestamp(table, to_utc_start(local, utc_offset_h=offset, at_end=at_end))
    table = numeric_columns(table, decimal_comma=False)
    per_height: dict[float, dict[str, str]] = {}
    shared = {}
    for name in table.columns[1:]:
        m = _HEIGHT_COL.fullmatch(name)
        if m is None:
            shared[name] = name
            continue
        h, quantity = float(m.group(1)), m.group(2)
        per_height.setdefault(h, {})[name] = QUANTITIES.get(quantity, quantity)
    heights = facts.get("heights_m") or sorted(per_height)
    for h in heights:
        label = f"{h:g}m "
        for q in _REQUIRED:
            if label + q not in table.columns:
                raise DataValidationError(
                    source,
                    None,
                    label + q,
                    f"column missing although the header lists the height {h:g} m",
                    line=col_line + 1,
                )
    return ParsedFile(table, per_height, shared, facts, first_line, "windcube_sta")


# --------------------------------------------------------------------------- real-time data
_RTD_TIME = "Timestamp"
_RTD_FORMATS = ("%Y/%m/%d %H:%M:%S.%f", "%Y/%m/%d %H:%M:%S")
#: per-height columns of a ``.rtd`` read into the LOS series (quantity -> LOS column)
RTD_QUANTITIES = {"Radial Wind Speed (m/s)": "radial_speed_ms", "CNR (dB)": "cnr_db"}


def _rtd_positions(text: pd.Series, source: str, first_line: int) -> tuple:
    """Beam azimuths (deg in [0, 360)) and the vertical-beam mask of the ``Position`` column."""
    s = text.astype(str).str.strip()
    vertical = s.str.upper().eq("V").to_numpy()
    az = pd.to_numeric(s.where(~vertical, "0"), errors="coerce").to_numpy(dtype=float)
    bad = ~np.isfinite(az)
    if bad.any():
        k = int(np.flatnonzero(bad)[0])
        raise DataValidationError(
            source,
            k + 1,
            "Position",
            f"cannot read {s.iloc[k]!r} as a beam azimuth (deg) or 'V' (the vertical beam)",
            line=first_line + k,
            n_more=int(bad.sum()) - 1,
        )
    return az % 360.0, vertical


def read_rtd(path: Path, *, utc_offset_h: float | None = None) -> tuple[pd.DataFrame, dict]:
    """Read a WindCube v2 real-time file (``.rtd``) into the LOS series.

    Layout (as the instrument writes it): the ``.sta`` header block (``HeaderSize=N``,
    ``ScanAngle (°)=28.000``, ``DirectionOffset (°)=...``, ``Altitudes (m)=\t40\t80...``,
    ``timezone=UTC+1``), then the column names: ``Timestamp``, ``Position`` (the beam's
    azimuth in deg, ``V`` for the vertical beam), ``Temperature``, ``Wiper Count``, and per
    height ``40m CNR (dB)``, ``40m Radial Wind Speed (m/s)``, ``40m Radial Wind Speed
    Dispersion (m/s)``, ``40m Wind Speed (m/s)``, ``40m Wind Direction (°)``, ``40m X-wind
    (m/s)``, ``40m Y-wind (m/s)``, ``40m Z-wind (m/s)`` and an empty column; one row per
    line of sight, stamped ``2016/11/24 00:00:01.23``. Only ``Timestamp``, ``Position`` and
    each height's radial speed and CNR are read; ``NaN`` (or an empty cell) is a rejected
    measurement and stays NaN.

    Conversions to the project's conventions (docs/conventions.md), made here:

    * radial speed: the WindCube counts it positive towards the lidar (its Z-wind is
      positive downwards); the LOS series positive away: ``radial_speed_ms = -(Radial Wind
      Speed)``;
    * azimuth: ``Position`` runs clockwise from the lidar's 0-deg beam, as ``azimuth_deg``
      runs clockwise from the body y axis: ``azimuth_deg = Position`` (mod 360), the body
      frame being the lidar's (its y axis along the 0-deg beam), in which the IMU series
      must give the attitude. ``DirectionOffset`` (the compass bearing of the 0-deg beam,
      which the WindCube adds to its own wind directions) is kept as a fact, not applied:
      the heading is the IMU's yaw;
    * elevation: ``elevation_deg`` = 90 - ``ScanAngle`` for the inclined beams, 90 for the
      vertical beam (its ``azimuth_deg`` 0);
    * time: the stamp, in the header's ``timezone`` (else ``utc_offset_h``, else UTC),
      turned into UTC; it is taken as the line of sight's time.

    Parameters
    ----------
    path : pathlib.Path
        The file.
    utc_offset_h : float, optional
        Offset of the stamps from UTC, h (config ``campaign.utc_offset_h``); the header's
        ``timezone`` wins, and the two must agree when both are given.

    Returns
    -------
    los : pandas.DataFrame
        The validated LOS series (:func:`flidar_uq.data.io.validate_los_series`), one row
        per line of sight and height (the heights ascending), in the file's order.
    facts : dict
        What the header states: ``scan_angle_deg``, ``heights_m`` (m), ``utc_offset_h``
        (h), ``direction_offset_deg``, ``serial_number``, ...

    Raises
    ------
    flidar_uq.data.io.DataValidationError
        Naming the file, the row and its line, and the file's column.
    """
    source = str(path)
    lines = read_text(path).split("\n")
    pairs, col_line = _header(lines, source, first_column=_RTD_TIME)
    header, rows = _rows(lines, col_line, source)
    facts = _facts(pairs)
    for key, value in pairs.items():
        if key.replace(" ", "").startswith("DirectionOffset"):
            facts["direction_offset_deg"] = float(value)
    if "scan_angle_deg" not in facts:
        raise DataValidationError(
            source, None, "ScanAngle (°)", "missing from the header (the beams' half-cone "
            "angle, deg)", line=col_line + 1,
        )  # fmt: skip
    zone_line = next(
        (i + 1 for i, ln in enumerate(lines[:col_line]) if ln.startswith("timezone")), 1
    )
    offset = resolve_offset_h(
        _offset_h(pairs), utc_offset_h, source=source, line=zone_line, key="timezone"
    )
    facts["utc_offset_h"] = offset
    first_line = col_line + 2
    names = [h or f"_empty_{i}" for i, h in enumerate(header)]
    table = pd.DataFrame(rows, columns=names, dtype=object)
    found = {
        float(m.group(1))
        for name in table.columns
        if (m := _HEIGHT_COL.fullmatch(name)) and m.group(2) in RTD_QUANTITIES
    }
    heights = sorted(found | set(facts.get("heights_m", [])))
    if not heights:
        raise DataValidationError(
            source, None, None, "no radial wind speed columns ('40m Radial Wind Speed (m/s)')",
            line=col_line + 1,
        )  # fmt: skip
    for name in ("Position", *(f"{h:g}m {q}" for h in heights for q in RTD_QUANTITIES)):
        if name not in table.columns:
            raise DataValidationError(
                source, None, name, "column missing (a WindCube v2 real-time file has it)",
                line=col_line + 1,
            )  # fmt: skip
    stamps = parse_stamps(
        table[header[0]], _RTD_FORMATS, source=source, column=header[0], first_line=first_line
    )
    az, vertical = _rtd_positions(table["Position"], source, first_line)
    n, n_h = len(table), len(heights)
    elevation = np.where(vertical, 90.0, 90.0 - facts["scan_angle_deg"])
    long = pd.DataFrame(
        {
            "timestamp": pd.DatetimeIndex(
                to_utc_start(stamps, utc_offset_h=offset, at_end=False)
            ).repeat(n_h),
            "height_m": np.tile(heights, n),
            "azimuth_deg": np.repeat(az, n_h),
            "elevation_deg": np.repeat(elevation, n_h),
        }
    )
    file_column = {"timestamp": header[0], "azimuth_deg": "Position", "elevation_deg": "Position"}
    for quantity, col in RTD_QUANTITIES.items():
        cells = table[[f"{h:g}m {quantity}" for h in heights]].to_numpy(dtype=object)
        cells = pd.DataFrame({col: cells.ravel()}, dtype=object)
        long[col] = numeric_columns(cells, decimal_comma=False)[col]
    try:
        los = validate_los_series(long, source)
    except DataValidationError as exc:
        if exc.row is None:
            raise
        k = exc.row - 1
        h = long["height_m"].iloc[k]
        column = file_column.get(exc.column) or next(
            f"{h:g}m {q}" for q, c in RTD_QUANTITIES.items() if c == exc.column
        )
        raise DataValidationError(
            source, k // n_h + 1, column, exc.problem, line=first_line + k // n_h
        ) from None
    los["radial_speed_ms"] = -los["radial_speed_ms"]  # the WindCube's: positive towards it
    facts["heights_m"] = heights
    return los, facts
