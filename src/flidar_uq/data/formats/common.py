"""Shared pieces of the instrument readers: the parsed file, text, numbers and time.

Every reader turns its file into a :class:`ParsedFile`: the file's table (one row per
10-min interval, the file's own column names, numbers parsed, ``timestamp`` in UTC at
the start of the interval), which of its columns hold which record column at which
height, the facts its header states and the file line of its first data row (for
messages).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pandas as pd

from flidar_uq.data.io import DataValidationError

__all__ = [
    "INTERVAL_MIN",
    "ParsedFile",
    "read_text",
    "numeric_columns",
    "parse_stamps",
    "to_utc_start",
    "with_timestamp",
    "check_alignment",
    "resolve_offset_h",
    "availability_from_packets",
]

#: Length of a record interval, min (the record table's 10-min statistics).
INTERVAL_MIN = 10


@dataclass
class ParsedFile:
    """An instrument file read into the shape the record validation takes.

    Attributes
    ----------
    table : pandas.DataFrame
        One row per interval; ``timestamp`` (UTC, interval start) and the file's columns.
    per_height : dict
        Height (m) -> {file column: record column or extra-column name}.
    shared : dict
        {file column: record column or extra-column name} shared by every height.
    facts : dict
        What the header states (scan angle, UTC offset, heights in m, serial number, ...).
    first_line : int
        File line of the first data row (row k is line ``first_line + k - 1``).
    fmt : str
        The format's name (``windcube_sta``, ``zephir_csv``, ``iea43``).
    notes : list of str
        Derivations the reader made (e.g. availability from packet counts).
    """

    table: pd.DataFrame
    per_height: dict
    shared: dict
    facts: dict
    first_line: int
    fmt: str
    notes: list = field(default_factory=list)


def read_text(path: Path) -> str:
    """The file's text: UTF-8 (a byte-order mark accepted), else latin-1 (instrument PCs)."""
    source = str(path)
    if not path.exists():
        raise DataValidationError(source, None, None, "no such file", whole_file=True)
    data = path.read_bytes()
    if b"\x00" in data:
        line = data[: data.index(b"\x00")].count(b"\n") + 1
        raise DataValidationError(
            source, None, None, "NUL byte in the file (binary data?)", line=line
        )
    try:
        text = data.decode("utf-8-sig")
    except UnicodeDecodeError:
        text = data.decode("latin-1")
    return text.replace("\r\n", "\n").replace("\r", "\n")


_NUMBER = r"\s*[-+]?(\d+(\.\d*)?|\.\d+)([eE][-+]?\d+)?\s*"


def numeric_columns(
    table: pd.DataFrame, *, decimal_comma: bool, missing: tuple[float, ...] = ()
) -> pd.DataFrame:
    """Columns whose every non-empty cell is a number (``NaN`` accepted) as float64.

    ``decimal_comma``: ``3,14`` is 3.14. ``missing``: values meaning no value (e.g. a
    ZephIR's ``9999``, written ``9999,000``), NaN after reading. Other columns stay text:
    the validation reports text in a mapped column by row, and text in an extra column is
    carried as it is.
    """
    out = {}
    for name in table.columns:
        s = table[name]
        if name == "timestamp" or not pd.api.types.is_object_dtype(s.dtype):
            out[name] = s
            continue
        txt = s.astype(str).str.strip()
        empty = s.isna() | txt.isin(("", "NaN", "nan"))
        if decimal_comma:
            txt = txt.str.replace(",", ".", regex=False)
        ok = empty | txt.str.fullmatch(_NUMBER).fillna(False)
        if bool(ok.all()):
            x = pd.to_numeric(txt.where(~empty), errors="coerce").astype(np.float64)
            out[name] = x.where(~x.isin(missing)) if missing else x
        else:
            out[name] = s.where(~empty) if decimal_comma else s
    return pd.DataFrame(out, index=table.index)


def with_timestamp(table: pd.DataFrame, timestamp: pd.Series) -> pd.DataFrame:
    """``table`` with ``timestamp`` (UTC) as its first column, in one concatenation (an
    ``insert`` into a wide file's frame fragments it and makes pandas warn)."""
    stamps = pd.DataFrame({"timestamp": timestamp.array}, index=table.index)
    return pd.concat([stamps, table], axis=1)


def parse_stamps(
    text: pd.Series, formats: tuple[str, ...], *, source: str, column: str, first_line: int
) -> pd.Series:
    """Naive timestamps of ``text`` in the first of ``formats`` (strptime) that reads them.

    Raises naming the row, its line and ``column`` when a stamp fits none of them.
    """
    s = text.astype(str).str.strip()
    best = None
    for fmt in formats:
        t = pd.to_datetime(s, format=fmt, errors="coerce")
        if best is None or t.notna().sum() > best.notna().sum():
            best = t
        if t.notna().all():
            return t
    bad = best.isna().to_numpy()
    k = int(np.flatnonzero(bad)[0])
    raise DataValidationError(
        source,
        k + 1,
        column,
        f"cannot read {s.iloc[k]!r} as a time stamp (expected the format {formats[0]})",
        line=first_line + k,
        n_more=int(bad.sum()) - 1,
    )


def resolve_offset_h(
    header_h: float | None, config_h: float | None, *, source: str, line: int, key: str
) -> float:
    """The UTC offset of a file, h: its header's, the config's, or 0; both must agree."""
    if header_h is not None and config_h is not None and abs(header_h - config_h) > 1e-9:
        raise DataValidationError(
            source,
            None,
            key,
            f"inconsistent UTC offsets: the header states UTC{header_h:+g} h, the config "
            f"campaign.utc_offset_h {config_h:+g} h (remove the key or correct it)",
            line=line,
        )
    if header_h is not None:
        return float(header_h)
    return float(config_h) if config_h is not None else 0.0


def to_utc_start(
    local: pd.Series, *, utc_offset_h: float, at_end: bool, interval_min: int = INTERVAL_MIN
) -> pd.Series:
    """UTC stamps at the interval start from local stamps (offset in h, stamp at end?)."""
    shift = pd.Timedelta(hours=float(utc_offset_h))
    if at_end:
        shift += pd.Timedelta(minutes=interval_min)
    out = pd.to_datetime(local) - shift
    return out.dt.tz_localize("UTC")


def check_alignment(
    stamps: pd.Series,
    *,
    source: str,
    column: str,
    first_line: int | None,
    interval_min: int = INTERVAL_MIN,
) -> None:
    """Stamps must fall on the interval grid (whole multiples of ``interval_min`` min)."""
    t = pd.DatetimeIndex(stamps).as_unit("ns").asi8
    step = interval_min * 60 * 10**9
    bad = (t % step) != 0
    if not bad.any():
        return
    k = int(np.flatnonzero(bad)[0])
    raise DataValidationError(
        source,
        k + 1,
        column,
        f"time stamp {pd.Timestamp(t[k], tz='UTC').isoformat()} is not on the "
        f"{interval_min}-min grid (records are {interval_min}-min statistics)",
        line=None if first_line is None else first_line + k,
        csv=first_line is None,
        n_more=int(bad.sum()) - 1,
    )


def availability_from_packets(table: pd.DataFrame, per_height: dict) -> list[str]:
    """Add ``availability_pct`` (%) at the heights that have packet counts but no
    availability: 100 * count / the file's largest count at the height. Returns the note."""
    done = []
    for h, cols in per_height.items():
        if "availability_pct" in cols.values():
            continue
        packets = next((c for c, t in cols.items() if t == "packets_count"), None)
        if packets is None or not pd.api.types.is_float_dtype(table[packets].dtype):
            continue
        n = table[packets].to_numpy()
        top = np.nanmax(n) if np.isfinite(n).any() else 0.0
        name = f"availability from packets at {h:g}m"
        pct = 100.0 * n / top if top > 0 else np.zeros_like(n)
        table[name] = np.where(np.isfinite(pct), pct, 0.0)
        cols[name] = "availability_pct"
        done.append(h)
    if not done:
        return []
    return [
        "availability_pct = 100 * packet count / the file's largest count at the height "
        f"(heights {', '.join(f'{h:g}' for h in sorted(done))} m)"
    ]
