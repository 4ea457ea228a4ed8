"""ZephIR 300 / ZX300 10-min CSV: a metadata line, then a ``;``-separated table with
decimal commas.

Layout (as the instrument writes it): line 1 holds ``;``-separated facts
(``Unit: 317``, ``Time sync: UTC +1,0 hrs``, ``Time stamps indicate the beginning of the
averaging period``, ``Measurement heights: 297m 247m ...``); line 2 names the columns
(``Time and Date`` as ``13.12.2016 00:00:00``, ``ZephIR Bearing (deg)``, ``Tilt (deg)``,
per height ``Horizontal Wind Speed (m/s) at 297m``, ``Horizontal Wind Speed Std. Dev.
(m/s) at 297m``, ``Wind Direction (deg) at 297m``, ``Packets in Average at 297m`` ...,
then a ``Checksum`` column). ``9999`` and ``9998`` mean no value.

There is no availability in %: ``availability_pct`` is the packet count over the
largest count of the file at that height (said so in the notes).
"""

from __future__ import annotations

import re
from pathlib import Path

import pandas as pd

from flidar_uq.data.formats.common import (
    ParsedFile,
    availability_from_packets,
    numeric_columns,
    parse_stamps,
    read_text,
    resolve_offset_h,
    to_utc_start,
    with_timestamp,
)
from flidar_uq.data.io import DataValidationError, heading_ccw_deg

__all__ = ["looks_like", "read"]

_TIME = "Time and Date"
_FORMATS = ("%d.%m.%Y %H:%M:%S", "%d.%m.%Y %H:%M", "%d/%m/%Y %H:%M:%S", "%Y-%m-%d %H:%M:%S")
QUANTITIES = {
    "Horizontal Wind Speed (m/s)": "hws_mean_ms",
    "Horizontal Wind Speed Std. Dev. (m/s)": "hws_std_ms",
    "Wind Direction (deg)": "wd_mean_deg",
    "Packets in Average": "packets_count",
}
_REQUIRED = ("Horizontal Wind Speed (m/s)", "Horizontal Wind Speed Std. Dev. (m/s)")
_HEIGHT_COL = re.compile(r"(.+) at (\d+(?:\.\d+)?)m")
_MISSING = (9999.0, 9998.0)


def looks_like(head: str) -> bool:
    """Whether a first line is a ZephIR metadata line."""
    return "Time sync" in head or ("ZephIR" in head and ";" in head) or "Unit:" in head


def _facts(meta: str, source: str, utc_offset_h: float | None) -> dict:
    facts: dict = {}
    header_offset = None
    for item in meta.split(";"):
        key, _, value = item.partition(":")
        key, value = key.strip(), value.strip()
        low = item.lower()
        if key == "Unit":
            facts["serial_number"] = value
        elif key == "Time sync":
            facts["time_sync"] = value
            m = re.search(r"UTC\s*([-+]?\s*\d+(?:[.,]\d+)?)", value)
            if m is None:
                raise DataValidationError(
                    source, None, "Time sync", f"cannot read the UTC offset in {value!r}", line=1
                )
            header_offset = float(m.group(1).replace(",", ".").replace(" ", ""))
        elif key == "Measurement heights":
            facts["heights_m"] = [float(h) for h in re.findall(r"(\d+(?:[.,]\d+)?)m", value)]
        elif "time stamps indicate the beginning" in low:
            facts["timestamp_at"] = "start"
        elif "time stamps indicate the end" in low:
            facts["timestamp_at"] = "end"
        elif "window height" in low:
            facts["window_height"] = value
        elif "fixed reference measurement" in low:
            facts["reference_height"] = item.strip()
    facts["utc_offset_h"] = resolve_offset_h(
        header_offset, utc_offset_h, source=source, line=1, key="Time sync"
    )
    return facts


def _table(lines: list[str], source: str) -> tuple[list[str], pd.DataFrame]:
    if len(lines) < 2 or ";" not in lines[1] or _TIME not in lines[1]:
        raise DataValidationError(
            source,
            None,
            _TIME,
            f"truncated header: line 2 must name the columns (';'-separated, with '{_TIME}')",
            line=2,
        )
    header = [h.strip() for h in lines[1].split(";")]
    rows = []
    for i, ln in enumerate(lines[2:]):
        if not ln.strip():
            continue
        fields = ln.split(";")
        if len(fields) != len(header):
            k = min(len(fields), len(header) - 1)
            sep = next((s for s in ("\t", "|") if s in ln), None)
            hint = f" (fields separated by {sep!r} here? the file uses ';')" if sep else ""
            raise DataValidationError(
                source,
                len(rows) + 1,
                header[k],
                f"{len(fields)} ';'-separated fields where the column line has {len(header)}{hint}",
                line=3 + i,
            )
        rows.append(fields)
    if not rows:
        raise DataValidationError(source, None, None, "no data rows", line=2)
    keep = [i for i, h in enumerate(header) if h and not h.startswith("Checksum")]
    names = [header[i] for i in keep]
    return header, pd.DataFrame([[r[i] for i in keep] for r in rows], columns=names, dtype=object)


def read(
    path: Path, *, utc_offset_h: float | None = None, timestamp_at: str | None = None
) -> ParsedFile:
    """Read a ZephIR 10-min CSV file (parameters as :func:`windcube.read`).

    The header's ``Time sync`` and time-stamp sentence win over the config; an offset
    given in both must agree.
    """
    source = str(path)
    lines = read_text(path).split("\n")
    facts = _facts(lines[0], source, utc_offset_h)
    at = facts.get("timestamp_at") or timestamp_at or "start"
    facts["timestamp_at"] = at
    header, table = _table(lines, source)
    local = parse_stamps(table.pop(_TIME), _FORMATS, source=source, column=_TIME, first_line=3)
    table = with_timestamp(
        table, to_utc_start(local, utc_offset_h=facts["utc_offset_h"], at_end=at == "end")
    )
    table = numeric_columns(table, decimal_comma=True, missing=_MISSING)
    per_height: dict[float, dict[str, str]] = {}
    shared = {}
    for name in table.columns[1:]:
        m = _HEIGHT_COL.fullmatch(name)
        if m is None:
            shared[name] = name
            continue
        h, quantity = float(m.group(2)), m.group(1)
        per_height.setdefault(h, {})[name] = QUANTITIES.get(quantity, quantity)
    notes = []
    bearing = "ZephIR Bearing (deg)"
    if bearing in table.columns and pd.api.types.is_float_dtype(table[bearing].dtype):
        table[bearing] = heading_ccw_deg(table[bearing].to_numpy())
        shared[bearing] = "heading_mean_deg"
        notes.append(
            f"heading_mean_deg from {bearing!r}, a compass bearing turned counter-clockwise"
        )
    for h in facts.get("heights_m") or sorted(per_height):
        for q in _REQUIRED:
            name = f"{q} at {h:g}m"
            if name not in table.columns:
                raise DataValidationError(
                    source,
                    None,
                    name,
                    f"column missing although the header lists the height {h:g} m",
                    line=2,
                )
    notes += availability_from_packets(table, per_height)
    return ParsedFile(table, per_height, shared, facts, 3, "zephir_csv", notes)
