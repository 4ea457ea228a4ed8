"""WindCube v2 10-min statistics (``.sta``): a ``key=value`` header block, then a
tab-separated table.

Layout (as the instrument writes it): line 1 ``HeaderSize=N``; lines 2 to N+1 are
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

import pandas as pd

from flidar_uq.data.formats.common import (
    ParsedFile,
    numeric_columns,
    parse_stamps,
    read_text,
    resolve_offset_h,
    to_utc_start,
)
from flidar_uq.data.io import DataValidationError

__all__ = ["looks_like", "read"]

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


def _header(lines: list[str], source: str) -> tuple[dict, int]:
    """The ``key=value`` pairs of the header block and the index of the column line."""
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
            f"but there {got} (expected 'Timestamp (end of interval)...')",
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
            sep = next((s for s in (";", ",", " ") if s in ln.strip()), None)
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
    table.insert(0, "timestamp", to_utc_start(local, utc_offset_h=offset, at_end=at_end))
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
