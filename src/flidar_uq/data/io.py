"""Reading and writing campaign tables with validation.

Size: one reader/validator per input kind (records, IMU series, LOS) sharing the same error helpers; splitting them would scatter the one error policy (~620 lines).

The record table, the raw IMU series and LOS-level data are CSV (optionally
gzip-compressed, ``.csv.gz``) or Parquet (``.parquet``/``.pq``) files whose
columns are defined in :mod:`flidar_uq.data.schema` and documented in
``docs/data-format.md``.  Every reader validates what it reads; a problem raises
:class:`DataValidationError` (a ``ValueError``) whose message names the file, the
row (1-based data row; for CSV also the line of the file) and the column.

All checks are vectorised: the first offending row is reported together with the
number of further offending rows.
"""

from __future__ import annotations

import csv
import gzip
import io
import os
import re
import zlib
from collections.abc import Iterable, Mapping, Sequence
from pathlib import Path

import numpy as np
import pandas as pd

from flidar_uq.data.schema import (
    IMU_COLUMNS,
    IMU_RATE_RANGE_HZ,
    KMH_SUSPECT_MEDIAN_MS,
    LOS_COLUMNS,
    MOTION_COLUMNS,
    RADIAN_SUSPECT_MAX_DEG,
    RADIAN_SUSPECT_MIN_COUNT,
    RECORD_COLUMNS,
    TI_AS_STD_MAX_RATIO,
    TI_PCT_AS_STD_MIN_RATIO,
    TRUTH_PREFIX,
    UNIT_CHECK_MIN_COUNT,
    UNIT_CHECK_MIN_HWS_MS,
    Column,
    record_column,
)

#: Values of ``extra_columns`` (config ``campaign.extra_columns``).
EXTRA_COLUMNS = ("keep", "ignore", "error")

__all__ = [
    "EXTRA_COLUMNS",
    "DataValidationError",
    "HEIGHT_FIELD",
    "check_column_map",
    "read_csv",
    "read_records",
    "read_table",
    "write_csv",
    "write_table",
    "write_records",
    "validate_records",
    "read_imu_series",
    "heading_ccw_deg",
    "imu_heading_to_ccw",
    "validate_imu_series",
    "write_imu_series",
    "read_los_series",
    "validate_los_series",
    "write_los_series",
    "los_imu_match",
]

_CSV_SUFFIXES = (".csv", ".csv.gz")
_PARQUET_SUFFIXES = (".parquet", ".pq")
_ISO_FORMAT_S = "%Y-%m-%dT%H:%M:%SZ"
_ISO_FORMAT_US = "%Y-%m-%dT%H:%M:%S.%fZ"


class DataValidationError(ValueError):
    """Invalid campaign data; the message names file, row and column.

    Attributes
    ----------
    source : str
        File path (or ``"<DataFrame>"``).
    row : int or None
        1-based data row (the first row after the CSV header is row 1); None for
        problems of the header (message says ``header``), of a whole column
        (``all rows``) or of the whole file.
    column : str or None
        Offending column name (the name in the file when a column map renamed it).
    problem, csv, n_more, header
        The constructor's arguments of the same names (what is wrong, whether the source
        is a CSV file, further offending rows, a problem of the header).

    ``line`` (constructor) gives the file line of an instrument file whose table does not
    start at line 2 (a header block); the message then says ``row k (line n)``.
    """

    def __init__(
        self,
        source: str,
        row: int | None,
        column: str | None,
        problem: str,
        *,
        csv: bool = False,
        n_more: int = 0,
        header: bool = False,
        whole_file: bool = False,
        mapped_from: str | None = None,
        line: int | None = None,
    ) -> None:
        self.source, self.row, self.column = source, row, column
        # kept so that a chunked reader can re-raise with the row counted from the file start
        self.problem, self.csv, self.n_more, self.header = problem, csv, n_more, header
        self._kw = dict(csv=csv, n_more=n_more, header=header, whole_file=whole_file, line=line)
        if line is not None:  # an instrument file: its own line number
            where = f"line {line}" if row is None else f"row {row} (line {line})"
        elif whole_file:
            where = ""
        elif row is None:
            where = "header" if header or column is None else "all rows"
        else:
            where = f"row {row}" + (f" (line {row + 1})" if csv else "")
        col = ""
        if column is not None:
            col = f"column {column!r}" + (
                f" (mapped to {mapped_from!r})" if mapped_from and mapped_from != column else ""
            )
        loc = ", ".join(x for x in (where, col) if x)
        more = f" (and {n_more} more row{'s' if n_more != 1 else ''})" if n_more else ""
        super().__init__(f"{source}: {loc + ': ' if loc else ''}{problem}{more}")

    def renamed(self, file_names: Mapping[str, str]) -> DataValidationError:
        """The same error naming the file's column (``file_names``: canonical -> file name)."""
        if self.column is None or self.column not in file_names:
            return self
        return DataValidationError(
            self.source,
            self.row,
            file_names[self.column],
            self.problem,
            mapped_from=self.column,
            **self._kw,
        )


# --------------------------------------------------------------------------- helpers
def _kind(path: Path) -> str:
    name = path.name.lower()
    if name.endswith(_CSV_SUFFIXES):
        return "csv"
    if name.endswith(_PARQUET_SUFFIXES):
        return "parquet"
    hint = " (export the sheet as CSV)" if name.endswith((".xls", ".xlsx", ".ods")) else ""
    raise DataValidationError(
        str(path),
        None,
        None,
        f"unknown file type{hint}; use one of {', '.join(_CSV_SUFFIXES + _PARQUET_SUFFIXES)}",
        whole_file=True,
    )


#: CSV files up to this size are checked line by line before parsing (field counts, blank
#: lines, encoding); larger ones (raw IMU and LOS series) go to the parser directly.
_PRESCAN_MAX_BYTES = 128 * 2**20


def _csv_text(path: Path, source: str) -> str | None:
    """The decoded text of a CSV file (``None`` when too large to check line by line)."""
    gz = path.name.lower().endswith(".gz")
    if not gz and path.stat().st_size > _PRESCAN_MAX_BYTES:
        return None
    try:
        if gz:
            with gzip.open(path, "rb") as fh:
                data = fh.read(_PRESCAN_MAX_BYTES + 1)
            if len(data) > _PRESCAN_MAX_BYTES:
                return None
        else:
            data = path.read_bytes()
    except (OSError, EOFError, zlib.error) as exc:
        raise DataValidationError(
            source, None, None, f"cannot read the file ({_os_reason(exc)})", whole_file=True
        ) from None
    try:
        text = data.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        line = data[: exc.start].count(b"\n") + 1
        raise DataValidationError(
            source,
            line - 1 if line > 1 else None,
            None,
            f"not UTF-8 text (byte {data[exc.start]:#04x} at line {line}); save the file as UTF-8",
            csv=True,
            whole_file=line == 1,
        ) from None
    return text


def _os_reason(exc: BaseException) -> str:
    return getattr(exc, "strerror", None) or str(exc) or type(exc).__name__


def _check_csv_lines(text: str, source: str) -> list[str]:
    """Header names of a CSV text; raise on a wrong delimiter, NUL bytes, blank lines inside
    the table or rows whose number of fields differs from the header's."""
    lines = text.split("\n")
    if lines and lines[-1] == "":
        lines.pop()
    lines = [ln[:-1] if ln.endswith("\r") else ln for ln in lines]
    while lines and not lines[-1].strip():  # trailing blank lines are harmless
        lines.pop()
    if not lines:
        raise DataValidationError(source, None, None, "the file is empty", whole_file=True)
    head = lines[0]
    if "," not in head:
        for sep, name in ((";", "semicolons"), ("\t", "tabs"), ("|", "'|'")):
            if sep in head:
                decimal = any(re.search(r"\d,\d", ln) for ln in lines[1:50])
                raise DataValidationError(
                    source,
                    None,
                    None,
                    f"the fields are separated by {name}, expected commas"
                    + (" (and the numbers use decimal commas, expected '.')" if decimal else "")
                    + ": export the table as CSV with ',' between fields and '.' in numbers",
                    header=True,
                )
    nul = text.find("\x00")
    if nul >= 0:
        line = text.count("\n", 0, nul) + 1
        raise DataValidationError(
            source, line - 1 or None, None, "NUL byte in the file (binary data?)", csv=True,
            header=line == 1,
        )  # fmt: skip
    if '"' in text:  # quoted fields (may span lines): the csv module counts the fields
        reader = csv.reader(lines)
        parsed = []
        try:
            for fields in reader:
                parsed.append((reader.line_num, fields))
        except csv.Error as exc:
            raise DataValidationError(
                source, reader.line_num - 1 or None, None, f"malformed CSV ({exc})", csv=True,
                header=reader.line_num <= 1,
            ) from None  # fmt: skip
    else:
        parsed = [(i + 1, ln.split(",")) for i, ln in enumerate(lines)]
    header = [c.strip().strip('"') for c in parsed[0][1]]
    n = len(header)
    for line, fields in parsed[1:]:
        if not fields or (len(fields) == 1 and not fields[0].strip()):
            raise DataValidationError(
                source, line - 1, None, "empty line inside the table", csv=True
            )
        if len(fields) != n:
            hint = ""
            text_line = lines[line - 1]
            if len(fields) > n and "." not in text_line and re.search(r"\d,\d", text_line):
                hint = " (decimal commas? numbers must use '.')"
            raise DataValidationError(
                source, line - 1, None, f"{len(fields)} fields where the header has {n}{hint}",
                csv=True,
            )  # fmt: skip
    return header


def _read_table(path: str | Path) -> tuple[pd.DataFrame, str, bool]:
    path = Path(path)
    source = str(path)
    kind = _kind(path)
    if not path.exists():
        raise DataValidationError(source, None, None, "no such file", whole_file=True)
    if path.is_dir():
        raise DataValidationError(source, None, None, "is a directory, not a file", whole_file=True)
    if kind == "parquet":
        try:
            df = pd.read_parquet(path)
            for c in df.columns:  # text is decoded lazily: invalid UTF-8 surfaces here
                if pd.api.types.is_string_dtype(df[c].dtype):
                    df[c] = df[c].astype(object)
            return df, source, False
        except MemoryError:
            raise
        except Exception as exc:  # noqa: BLE001 - pyarrow and pandas metadata errors vary
            reason = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
            raise DataValidationError(
                source, None, None, f"not a readable Parquet file ({reason})", whole_file=True
            ) from None
    text = _csv_text(path, source)
    if text is not None:
        header = _check_csv_lines(text, source)
    else:
        opener = gzip.open if path.name.lower().endswith(".gz") else open
        with opener(path, "rt", encoding="utf-8-sig") as fh:
            header = [c.strip().strip('"') for c in fh.readline().rstrip("\r\n").split(",")]
    seen: set[str] = set()
    for name in header:
        if name in seen:
            raise DataValidationError(source, None, name, "duplicated column name", header=True)
        seen.add(name)
    # pandas infers numbers; text left in a numeric column is reported by _coerce.
    # low_memory=False gives one dtype per column
    try:
        df = pd.read_csv(
            io.StringIO(text) if text is not None else path,
            low_memory=False,
            skipinitialspace=True,
            encoding="utf-8-sig",
        )
    except (
        pd.errors.ParserError,
        pd.errors.EmptyDataError,
        UnicodeError,
        ValueError,
        OverflowError,
        OSError,
        EOFError,
        zlib.error,
    ) as exc:
        m = re.search(r"line (\d+)", str(exc))
        row = int(m.group(1)) - 1 if m else None
        raise DataValidationError(
            source,
            row if row else None,
            None,
            f"malformed CSV ({exc})".replace("\n", " "),
            csv=True,
            whole_file=not row,
        ) from None
    return df, source, True


def _first(mask: np.ndarray) -> tuple[int, int]:
    """Return (1-based row of the first True, number of further True)."""
    idx = np.flatnonzero(mask)
    return int(idx[0]) + 1, int(idx.size - 1)


def _plain(value):
    """A numpy scalar as the Python value (for messages)."""
    return value.item() if isinstance(value, np.generic) else value


def _parse_datetime(s: pd.Series, name: str, source: str, csv: bool) -> pd.Series:
    if isinstance(s.dtype, pd.DatetimeTZDtype):
        out = s.dt.tz_convert("UTC")
    elif pd.api.types.is_datetime64_dtype(s.dtype):
        out = s.dt.tz_localize("UTC")
    else:
        if pd.api.types.is_numeric_dtype(s.dtype) and s.notna().any():
            row, more = _first(s.notna().to_numpy())
            raise DataValidationError(
                source,
                row,
                name,
                f"number {_plain(s.iloc[row - 1])!r} is not an ISO 8601 timestamp",
                csv=csv,
                n_more=more,
            )
        try:
            out = pd.to_datetime(s, utc=True, format="ISO8601", errors="coerce")
        except (ValueError, TypeError, OverflowError):  # e.g. mixed types in a Parquet column
            out = pd.Series(
                [pd.to_datetime(v, utc=True, format="ISO8601", errors="coerce") for v in s],
                index=s.index,
                dtype="datetime64[ns, UTC]",
            )
        bad = (out.isna() & s.notna()).to_numpy()
        if bad.any():
            row, more = _first(bad)
            raise DataValidationError(
                source,
                row,
                name,
                f"cannot parse {s.iloc[row - 1]!r} as an ISO 8601 timestamp",
                csv=csv,
                n_more=more,
            )
        _check_time_zones(s, name, source, csv)
    lo, hi = pd.Timestamp.min.tz_localize("UTC"), pd.Timestamp.max.tz_localize("UTC")
    outside = ((out < lo) | (out > hi)).to_numpy()
    if outside.any():
        row, more = _first(outside)
        raise DataValidationError(
            source,
            row,
            name,
            f"timestamp {s.iloc[row - 1]!s} outside the supported years 1678-2261",
            csv=csv,
            n_more=more,
        )
    return out.astype("datetime64[ns, UTC]")


_ZONE = re.compile(r"\d{2}:\d{2}(?::\d{2}(?:[.,]\d+)?)?\s*(Z|[+-]\d{2}(?::?\d{2})?)?\s*$")


def _zone_minutes(text: str) -> float:
    """UTC offset of an ISO 8601 timestamp text, minutes; NaN without a zone ('' if no time)."""
    m = _ZONE.search(text)
    if m is None or m.group(1) is None:
        return np.nan
    z = m.group(1)
    if z == "Z":
        return 0.0
    digits = z[1:].replace(":", "")
    minutes = int(digits[:2]) * 60 + (int(digits[2:4]) if len(digits) > 2 else 0)
    return float(minutes if z[0] == "+" else -minutes)


def _check_time_zones(s: pd.Series, name: str, source: str, csv: bool) -> None:
    """All timestamp texts must carry the same UTC offset, or all none (naive = UTC)."""
    txt = s[s.notna()].astype(str)
    if txt.empty:
        return
    tail = txt.str[-24:]  # the zone is at the end: evaluate each distinct tail once
    uniq, inverse = np.unique(tail.to_numpy(dtype=str), return_inverse=True)
    zones = np.array([_zone_minutes(t) for t in uniq])[inverse.ravel()]
    first = zones[0]
    differs = ~np.isnan(zones) if np.isnan(first) else (zones != first)
    if differs.any():
        k = int(np.argmax(differs))
        row = int(np.flatnonzero(s.notna().to_numpy())[k]) + 1
        first_row = int(np.flatnonzero(s.notna().to_numpy())[0]) + 1

        def label(z: float) -> str:
            if np.isnan(z):
                return "no time zone"
            return (
                "UTC"
                if z == 0
                else f"UTC{'+' if z > 0 else '-'}{abs(z) // 60:02.0f}:{abs(z) % 60:02.0f}"
            )

        raise DataValidationError(
            source,
            row,
            name,
            f"mixed time zones: {txt.iloc[k]!r} has {label(zones[k])}, row {first_row} has "
            f"{label(first)}; write every timestamp in one zone, preferably UTC",
            csv=csv,
            n_more=int(differs.sum()) - 1,
        )


def _parse_float(s: pd.Series, name: str, source: str, csv: bool) -> pd.Series:
    if pd.api.types.is_bool_dtype(s.dtype):
        raise DataValidationError(
            source, 1, name, "boolean values where a number is expected", csv=csv, n_more=len(s) - 1
        )
    if pd.api.types.is_numeric_dtype(s.dtype):
        if pd.api.types.is_complex_dtype(s.dtype):
            raise DataValidationError(
                source, 1, name, "complex numbers where a real number is expected", csv=csv
            )
        return s.astype(np.float64)
    try:
        out = pd.to_numeric(s, errors="coerce")
    except (TypeError, ValueError):  # e.g. lists in a Parquet column
        out = pd.Series([_to_float(v) for v in s], index=s.index, dtype=np.float64)
    bad = (out.isna() & s.notna()).to_numpy()
    if bad.any():
        row, more = _first(bad)
        value = _plain(s.iloc[row - 1])
        hint = ""
        if isinstance(value, str) and re.fullmatch(r"\s*[-+]?\d+,\d+\s*", value):
            hint = " (a decimal comma? numbers must use '.')"
        raise DataValidationError(
            source,
            row,
            name,
            f"cannot parse {value!r} as a number{hint}",
            csv=csv,
            n_more=more,
        )
    return out.astype(np.float64)


def _to_float(value) -> float:
    try:
        return float(value)
    except (TypeError, ValueError, OverflowError):
        return np.nan


def _bounds_problem(col: Column, value: float) -> str:
    """Explain a bound violation in the user's terms."""
    n = col.name
    if n.endswith("_std_ms") and value < 0:
        return f"negative standard deviation {value:g} m/s"
    if n.endswith("hws_mean_ms") and col.upper is not None and value > col.upper:
        return f"wind speed {value:g} m/s above {col.upper:g} m/s (impossible)"
    if n in ("wd_mean_deg", "wave_dir_deg") or n.startswith("azimuth"):
        return f"direction {value:g} deg outside 0-360 deg"
    if n.endswith("_pct"):
        return f"percentage {value:g} outside 0-100 %"
    return f"value {value:g} {col.unit} outside {col.bounds_text()}"


def _check_values(df: pd.DataFrame, col: Column, source: str, csv: bool) -> None:
    if col.dtype == "datetime":
        if not col.nan_allowed:
            bad = df[col.name].isna().to_numpy()
            if bad.any():
                row, more = _first(bad)
                raise DataValidationError(
                    source, row, col.name, "missing timestamp", csv=csv, n_more=more
                )
        return
    x = df[col.name].to_numpy(dtype=np.float64)
    isnan = np.isnan(x)
    if not col.nan_allowed and isnan.any():
        row, more = _first(isnan)
        raise DataValidationError(
            source,
            row,
            col.name,
            "missing value (NaN) in a column that must be complete",
            csv=csv,
            n_more=more,
        )
    isinf = np.isinf(x)
    if isinf.any():
        row, more = _first(isinf)
        raise DataValidationError(source, row, col.name, "infinite value", csv=csv, n_more=more)
    with np.errstate(invalid="ignore"):
        bad = np.zeros(x.shape, dtype=bool)
        if col.lower is not None:
            bad |= (x <= col.lower) if col.lower_exclusive else (x < col.lower)
        if col.upper is not None:
            bad |= x > col.upper
    if bad.any():
        row, more = _first(bad)
        raise DataValidationError(
            source, row, col.name, _bounds_problem(col, float(x[row - 1])), csv=csv, n_more=more
        )


def _check_units(df: pd.DataFrame, source: str, csv: bool) -> None:
    """Reject speeds that look like km/h and std columns that look like TI (data-format.md)."""
    for mean_col, std_col in (("hws_mean_ms", "hws_std_ms"), ("ref_hws_mean_ms", "ref_hws_std_ms")):
        if mean_col not in df.columns:
            continue
        m = df[mean_col].to_numpy(dtype=np.float64)
        fin = np.isfinite(m)
        if fin.sum() >= UNIT_CHECK_MIN_COUNT and np.median(m[fin]) > KMH_SUSPECT_MEDIAN_MS:
            raise DataValidationError(
                source,
                None,
                mean_col,
                f"median {np.median(m[fin]):.3g} over {int(fin.sum())} records is above "
                f"{KMH_SUSPECT_MEDIAN_MS:g} m/s, implausible for a campaign: speeds in km/h? "
                "(divide by 3.6)",
            )
        if std_col not in df.columns:
            continue
        s = df[std_col].to_numpy(dtype=np.float64)
        use = fin & np.isfinite(s) & (s > 0) & (m >= UNIT_CHECK_MIN_HWS_MS)
        if use.sum() < UNIT_CHECK_MIN_COUNT:
            continue
        ratio = float(np.median(s[use] / m[use]))
        if ratio < TI_AS_STD_MAX_RATIO:
            what = "the turbulence intensity (std / mean)"
        elif ratio > TI_PCT_AS_STD_MIN_RATIO:
            what = "the turbulence intensity in %"
        else:
            continue
        raise DataValidationError(
            source,
            None,
            std_col,
            f"median {std_col} / {mean_col} is {ratio:.3g} over {int(use.sum())} records "
            f"(expected {TI_AS_STD_MAX_RATIO:g}-{TI_PCT_AS_STD_MIN_RATIO:g}): the column looks "
            f"like {what}, expected the standard deviation in m/s",
        )


_SMALL_ANGLES_HINT = (
    "if the motion really is that small, allow it: config key campaign.allow_small_angles, "
    "flidar-uq validate --allow-small-angles, allow_small_angles=True in Python"
)


def _check_radians(
    df: pd.DataFrame, names: Iterable[str], source: str, csv: bool, *, absolute: bool
) -> None:
    """Reject angle columns that look like radians (documented rule in data-format.md)."""
    names = [n for n in names if n in df.columns]
    if not names:
        return
    vals = np.abs(df[names].to_numpy(dtype=np.float64))
    use = np.isfinite(vals) & (vals > 0)
    if use.sum() < RADIAN_SUSPECT_MIN_COUNT:
        return
    vmax = np.where(use, vals, -np.inf)
    if vmax.max() < RADIAN_SUSPECT_MAX_DEG:
        r, c = np.unravel_index(np.argmax(vmax), vmax.shape)
        kind = "|angle|" if absolute else "amplitude"
        raise DataValidationError(
            source,
            int(r) + 1,
            names[c],
            f"every non-zero {kind} in {names} is below {RADIAN_SUSPECT_MAX_DEG} deg "
            f"(largest {vmax.max():.4g} here): the angles look like radians, expected degrees "
            f"({_SMALL_ANGLES_HINT})",
            csv=csv,
        )


def _check_time_order(
    df: pd.DataFrame, source: str, csv: bool, *, by: str | None, strict: bool
) -> None:
    """Timestamps must increase within each group (each height)."""
    t = df["timestamp"]
    if strict:
        keys = ["timestamp"] if by is None else [by, "timestamp"]
        dup = df.duplicated(keys, keep="first").to_numpy()
        if dup.any():
            row, more = _first(dup)
            key = tuple(df.iloc[row - 1][k] for k in keys)
            same = (df[keys] == pd.Series(dict(zip(keys, key, strict=True)))).all(axis=1)
            first_row = int(np.flatnonzero(same.to_numpy())[0]) + 1
            at = "" if by is None else f" at {by}={key[0]:g}"
            raise DataValidationError(
                source,
                row,
                "timestamp",
                f"duplicated timestamp {t.iloc[row - 1].isoformat()}{at} (first seen in row "
                f"{first_row})",
                csv=csv,
                n_more=more,
            )
    dt = t.diff() if by is None else t.groupby(df[by], sort=False).diff()
    back = (dt < pd.Timedelta(0)).to_numpy()
    if back.any():
        row, more = _first(back)
        at = "" if by is None else f" at {by}={df[by].iloc[row - 1]:g}"
        raise DataValidationError(
            source,
            row,
            "timestamp",
            f"timestamps not increasing{at}: {t.iloc[row - 1].isoformat()} comes after a later one",
            csv=csv,
            n_more=more,
        )


def _coerce(
    df: pd.DataFrame, columns: Mapping[str, Column], source: str, csv: bool
) -> pd.DataFrame:
    out = {}
    df = df.reset_index(drop=True)  # rows by position (a filtered frame keeps its labels)
    for name in df.columns:
        col = columns[name]
        parse = _parse_datetime if col.dtype == "datetime" else _parse_float
        out[name] = parse(df[name], name, source, csv)
    return pd.DataFrame(out, index=pd.RangeIndex(len(df)))


def _check_columns(
    df: pd.DataFrame,
    required: Iterable[str],
    known: Mapping[str, Column],
    source: str,
    *,
    allow_truth: bool,
) -> None:
    missing = [c for c in required if c not in df.columns]
    if missing:
        raise DataValidationError(
            source,
            None,
            missing[0],
            f"required column missing (all missing: {missing})",
            header=True,
        )
    for name in df.columns:
        if not isinstance(name, str):
            raise DataValidationError(
                source, None, str(name), "column names must be text", header=True
            )
        if name in known or (allow_truth and name.startswith(TRUTH_PREFIX)):
            continue
        hint = ""
        if re.fullmatch(r".+\.\d+", name):
            hint = " (a duplicated column name?)"
        raise DataValidationError(
            source,
            None,
            name,
            f"unknown column{hint}; allowed: {sorted(known)}"
            + (" and truth columns 'true_*'" if allow_truth else ""),
            header=True,
        )
    if len(df) == 0:
        raise DataValidationError(source, None, None, "the table has no data rows")


# --------------------------------------------------------------------------- records
HEIGHT_FIELD = "{height}"
"""Placeholder in a column-map name for the height of a wide table (``"Spd{height}mN"``)."""


def check_column_map(columns: Mapping[str, str | None]) -> None:
    """Check a column map (see :func:`validate_records`) without a file.

    Raises
    ------
    ValueError
        Naming the entry whose target is not a record column, repeats another entry's
        target, or whose name holds :data:`HEIGHT_FIELD` more than once.
    """
    if not isinstance(columns, Mapping):
        raise ValueError(f"column map: must be a mapping of names, got {columns!r}")
    known = {c.name for c in RECORD_COLUMNS}
    seen: dict[str, str] = {}
    for name, target in columns.items():
        if not isinstance(name, str) or not name:
            raise ValueError(f"column map: file column names must be text, got {name!r}")
        if name.count(HEIGHT_FIELD) > 1:
            raise ValueError(f"column map: {name!r} has {HEIGHT_FIELD} more than once")
        if target is None:
            continue
        if not isinstance(target, str) or not (target in known or target.startswith(TRUTH_PREFIX)):
            raise ValueError(
                f"column map: {name!r} -> {target!r}: not a record column "
                "(docs/data-format.md; null drops the column)"
            )
        if target == "height_m" and HEIGHT_FIELD in name:
            raise ValueError(
                f"column map: {name!r} -> 'height_m': heights come from {HEIGHT_FIELD}"
            )
        if target in seen:
            raise ValueError(f"column map: {seen[target]!r} and {name!r} both map to {target!r}")
        seen[target] = name


def _apply_column_map(
    df: pd.DataFrame, columns: Mapping[str, str | None], source: str
) -> list[tuple[pd.DataFrame, dict[str, str]]]:
    """Rename (and for a wide table, split per height) the file's columns.

    Returns one ``(table, canonical -> file column)`` pair per height of a wide table
    (names with :data:`HEIGHT_FIELD`), else a single pair; each table keeps the file's
    rows in order, so row numbers in messages stay those of the file.
    """
    check_column_map(columns)
    templates = {k: v for k, v in columns.items() if HEIGHT_FIELD in k}
    plain = {k: v for k, v in columns.items() if HEIGHT_FIELD not in k}
    for name, target in plain.items():
        if name not in df.columns:
            to = "dropped" if target is None else f"-> {target!r}"
            raise DataValidationError(
                source, None, name, f"in the column map ({to}) but not in the file", header=True
            )
    rename = {k: v for k, v in plain.items() if v is not None}
    for name, target in rename.items():
        if target in df.columns and target not in rename:
            raise DataValidationError(
                source,
                None,
                target,
                f"the file has this column and the column map also maps {name!r} to it",
                header=True,
            )
    back = {v: k for k, v in rename.items()}
    if not templates:
        drop = [k for k, v in plain.items() if v is None]
        return [(df.drop(columns=drop).rename(columns=rename), back)]
    patterns = {}
    for k in templates:
        pre, post = k.split(HEIGHT_FIELD)
        patterns[k] = re.compile(re.escape(pre) + r"(\d+(?:\.\d+)?)" + re.escape(post))
    labels: dict[float, str] = {}
    matched: dict[tuple[str, float], str] = {}
    for col in df.columns:
        if not isinstance(col, str) or col in plain:
            continue
        for k, rx in patterns.items():
            m = rx.fullmatch(col)
            if m:
                h = float(m.group(1))
                labels.setdefault(h, m.group(1))
                matched[(k, h)] = col
    if not labels:
        raise DataValidationError(
            source,
            None,
            None,
            f"no column matches the per-height names {sorted(templates)} of the column map",
            header=True,
        )
    if "height_m" in df.columns or "height_m" in rename.values():
        raise DataValidationError(
            source,
            None,
            back.get("height_m", "height_m"),
            f"a per-height column map ({HEIGHT_FIELD} in a name) takes the heights from the "
            "column names: the table must not have a height column",
            header=True,
        )
    drop = [k for k, v in plain.items() if v is None] + sorted(set(matched.values()))
    shared = df.drop(columns=drop).rename(columns=rename)
    parts = []
    for h in sorted(labels):
        part = shared.copy()
        part["height_m"] = h
        names = dict(back)
        for k, target in templates.items():
            if target is None:
                continue
            col = matched.get((k, h))
            names[target] = col or k.replace(HEIGHT_FIELD, labels[h])
            if col is not None:
                part[target] = df[col].to_numpy()
        parts.append((part, names))
    return parts


def validate_records(
    df: pd.DataFrame,
    source: str = "<DataFrame>",
    *,
    require_motion: bool = True,
    allow_small_angles: bool = False,
    csv: bool = False,
    columns: Mapping[str, str | None] | None = None,
    extra_columns: str = "error",
) -> pd.DataFrame:
    """Validate a record table and return it normalised.

    Parameters
    ----------
    df : pandas.DataFrame
        Record table, one row per 10-min record and height (columns in
        ``docs/data-format.md``), or, with a per-height ``columns`` map, one row per
        10-min record with one column per quantity and height.
    source : str
        Name used in error messages (the file path).
    columns : mapping of str to str or None, optional
        Column map, the file's name -> the record column (``docs/data-format.md``);
        ``None`` drops a column. A name containing :data:`HEIGHT_FIELD`
        (``"Spd{height}mN": "hws_mean_ms"``) marks a wide table: each height found in
        the names becomes one record per row (``height_m`` from the name), and the
        columns not mapped per height are shared by all heights. Messages name the
        file's columns. Records come out per row in file order, heights ascending.
    require_motion : bool
        If False the IMU motion columns may be absent (they will be derived from
        a raw IMU series with :func:`flidar_uq.data.imu.motion_statistics`).
    allow_small_angles : bool
        Skip the "angles look like radians" check (documented rule).
    csv : bool
        If True, messages also give the file line (header is line 1).
    extra_columns : {"error", "keep", "ignore"}
        A column that is neither a record column nor a truth column: an error, carried
        unchanged after the record columns (config ``campaign.extra_columns``, default
        ``keep`` there) or dropped.

    Returns
    -------
    pandas.DataFrame
        Columns in schema order then truth columns (then kept extra columns, as read); ``timestamp`` as
        ``datetime64[ns, UTC]``, all other columns float64; RangeIndex.

    Raises
    ------
    DataValidationError
        On the first problem found, naming file, row and column.
    ValueError
        On a column map whose targets are not record columns or repeat.
    """
    if extra_columns not in EXTRA_COLUMNS:
        raise ValueError(f"extra_columns must be one of {EXTRA_COLUMNS}, got {extra_columns!r}")
    kw = dict(
        require_motion=require_motion,
        allow_small_angles=allow_small_angles,
        csv=csv,
        extra_columns=extra_columns,
    )
    if not columns:
        return _validate_records(df, source, **kw)
    parts = []
    for part, names in _apply_column_map(df, columns, source):
        try:
            parts.append(_validate_records(part, source, **kw))
        except DataValidationError as exc:
            raise exc.renamed(names) from None
    if len(parts) == 1:
        return parts[0]
    n = len(df)
    out = pd.concat(parts, ignore_index=True)
    order = np.lexsort((np.repeat(np.arange(len(parts)), n), np.tile(np.arange(n), len(parts))))
    out = out.iloc[order].reset_index(drop=True)
    names = [c.name for c in RECORD_COLUMNS if c.name in out.columns]
    truth = [c for c in out.columns if c not in names and c.startswith(TRUTH_PREFIX)]
    return out[names + truth + [c for c in out.columns if c not in names and c not in truth]]


def _validate_records(
    df: pd.DataFrame,
    source: str,
    *,
    require_motion: bool,
    allow_small_angles: bool,
    csv: bool,
    extra_columns: str = "error",
) -> pd.DataFrame:
    known = {c.name: c for c in RECORD_COLUMNS}
    required = [
        c.name
        for c in RECORD_COLUMNS
        if c.required and (require_motion or c.name not in MOTION_COLUMNS)
    ]
    extras = pd.DataFrame(index=pd.RangeIndex(len(df)))
    if extra_columns != "error":
        unknown = [
            n for n in df.columns
            if isinstance(n, str) and n not in known and not n.startswith(TRUTH_PREFIX)
        ]  # fmt: skip
        if extra_columns == "keep":
            extras = df[unknown].reset_index(drop=True)
        df = df.drop(columns=unknown)
    _check_columns(df, required, known, source, allow_truth=True)
    columns = {n: record_column(n) for n in df.columns}
    out = _coerce(df, columns, source, csv)
    for name in out.columns:
        _check_values(out, columns[name], source, csv)
    # paired optional columns of the two-period description
    pair = [c for c in ("period2_s", "weight1") if c in out.columns]
    if len(pair) == 1:
        other = "weight1" if pair[0] == "period2_s" else "period2_s"
        raise DataValidationError(
            source, None, other, f"column missing although {pair[0]!r} is given", header=True
        )
    if pair:
        mismatch = np.isnan(out["period2_s"].to_numpy()) != np.isnan(out["weight1"].to_numpy())
        if mismatch.any():
            row, more = _first(mismatch)
            raise DataValidationError(
                source,
                row,
                "weight1",
                "period2_s and weight1 must both be given (bimodal) or both be NaN (unimodal)",
                csv=csv,
                n_more=more,
            )
        if "period1_s" in out.columns:
            with np.errstate(invalid="ignore"):
                order = (out["period1_s"] >= out["period2_s"]).to_numpy()
            if order.any():
                row, more = _first(order)
                raise DataValidationError(
                    source,
                    row,
                    "period2_s",
                    f"period2_s ({out['period2_s'].iloc[row - 1]:g} s) must be longer than "
                    f"period1_s ({out['period1_s'].iloc[row - 1]:g} s)",
                    csv=csv,
                    n_more=more,
                )
    _check_units(out, source, csv)
    if not allow_small_angles:
        _check_radians(
            out, ["roll_amplitude_deg", "pitch_amplitude_deg"], source, csv, absolute=False
        )
        wd = out["wd_mean_deg"].to_numpy()
        fin = wd[np.isfinite(wd)]
        if fin.size >= 10 and fin.max() <= 2 * np.pi:
            row = int(np.nanargmax(wd)) + 1
            raise DataValidationError(
                source,
                row,
                "wd_mean_deg",
                f"all {fin.size} wind directions are <= 2*pi (largest {fin.max():.4g}): they look "
                f"like radians, expected degrees ({_SMALL_ANGLES_HINT})",
                csv=csv,
            )
    _check_time_order(out, source, csv, by="height_m", strict=True)
    order = [c.name for c in RECORD_COLUMNS if c.name in out.columns]
    order += [c for c in out.columns if c not in order]
    out = out[order]
    if len(extras.columns):
        out = pd.concat([out, extras.set_axis(out.index)], axis=1)
    return out


def read_records(
    path: str | Path,
    *,
    require_motion: bool = True,
    allow_small_angles: bool = False,
    columns: Mapping[str, str | None] | None = None,
    extra_columns: str = "error",
) -> pd.DataFrame:
    """Read and validate a record table (CSV or Parquet).

    Parameters
    ----------
    path : str or pathlib.Path
        ``.csv``, ``.csv.gz``, ``.parquet`` or ``.pq`` file (an instrument's own file, or
        a table under the campaign's time and heading conventions:
        :func:`flidar_uq.data.formats.join.read_campaign`).
    require_motion, allow_small_angles : bool
        See :func:`validate_records`.
    columns : mapping, optional
        Column map of a file whose names differ, see :func:`validate_records`.
    extra_columns : {"error", "keep", "ignore"}
        See :func:`validate_records`.

    Returns
    -------
    pandas.DataFrame
        The validated, normalised table (see :func:`validate_records`).

    Raises
    ------
    DataValidationError
        Naming file, row and column of the first problem.
    """
    df, source, csv = _read_table(path)
    return validate_records(
        df,
        source,
        require_motion=require_motion,
        allow_small_angles=allow_small_angles,
        csv=csv,
        columns=columns,
        extra_columns=extra_columns,
    )


def _write(df: pd.DataFrame, path: str | Path, date_format: str = _ISO_FORMAT_US) -> Path:
    path = Path(path)
    kind = _kind(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    if kind == "csv":
        _write_csv_text(df, path, date_format=date_format)
    else:
        _write_parquet(df, path)
    return path


def _write_parquet(df: pd.DataFrame, path: Path) -> None:
    """Write ``df`` as Parquet, the same bytes for the same frame: zstd, no index, no time
    of writing in the metadata; float columns byte-stream split (their bytes grouped by
    significance, a third smaller after zstd), the other columns dictionary-encoded. Every
    dtype reads back as written (float64 bit for bit, time stamps with their zone)."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    table = pa.Table.from_pandas(df, preserve_index=False)
    floats = [f.name for f in table.schema if pa.types.is_floating(f.type)]
    pq.write_table(
        table,
        path,
        compression="zstd",
        use_dictionary=[f.name for f in table.schema if f.name not in floats],
        use_byte_stream_split=floats or False,
    )


def write_table(df: pd.DataFrame, path: str | os.PathLike) -> None:
    """Write an intermediate table of the pipeline as Parquet (:func:`read_table` reads it).

    Parameters
    ----------
    df : pandas.DataFrame
        The table (no index is written).
    path : path
        Destination, ``.parquet``; parents are created.

    Raises
    ------
    ValueError
        When ``path`` is not a ``.parquet`` file.
    """
    path = Path(path)
    if not path.name.endswith(".parquet"):
        raise ValueError(f"write_table: {path} is not a .parquet file")
    path.parent.mkdir(parents=True, exist_ok=True)
    _write_parquet(df, path)


def read_table(path: str | os.PathLike, columns: Sequence[str] | None = None) -> pd.DataFrame:
    """Read a table written by :func:`write_table` or :func:`write_records` to Parquet (only
    ``columns``, when given), every column in the dtype it was written with."""
    return pd.read_parquet(path, columns=None if columns is None else list(columns))


def write_records(
    df: pd.DataFrame,
    path: str | Path,
    *,
    require_motion: bool = True,
    allow_small_angles: bool = False,
    extra_columns: str = "keep",
) -> Path:
    """Validate and write a record table; the format follows the file suffix.

    Parameters
    ----------
    df : pandas.DataFrame
        Record table (``docs/data-format.md``).
    path : str or pathlib.Path
        Destination (``.csv``, ``.csv.gz``, ``.parquet``, ``.pq``); parents are created.
    require_motion, allow_small_angles : bool
        See :func:`validate_records`.
    extra_columns : {"keep", "ignore", "error"}
        See :func:`validate_records` (default: written unchanged after the record columns).

    Returns
    -------
    pathlib.Path
        The written path.
    """
    valid = validate_records(
        df,
        f"<DataFrame for {path}>",
        require_motion=require_motion,
        allow_small_angles=allow_small_angles,
        extra_columns=extra_columns,
    )
    t = valid["timestamp"]
    whole_s = bool((t.dt.microsecond == 0).all() and (t.dt.nanosecond == 0).all())
    return _write(valid, path, _ISO_FORMAT_S if whole_s else _ISO_FORMAT_US)


# --------------------------------------------------------------------------- IMU series
def validate_imu_series(
    df: pd.DataFrame,
    source: str = "<DataFrame>",
    *,
    allow_small_angles: bool = False,
    csv: bool = False,
) -> pd.DataFrame:
    """Validate a raw IMU attitude series (``timestamp, roll_deg, pitch_deg[, yaw_deg]``).

    Checks column names and types, bounds, strictly increasing timestamps, a
    median sampling rate within :data:`flidar_uq.data.schema.IMU_RATE_RANGE_HZ` and
    angles that look like radians.

    Returns
    -------
    pandas.DataFrame
        Normalised series (UTC timestamps, float64 angles in deg).
    """
    known = {c.name: c for c in IMU_COLUMNS}
    _check_columns(
        df, [c.name for c in IMU_COLUMNS if c.required], known, source, allow_truth=False
    )
    out = _coerce(df, known, source, csv)
    for name in out.columns:
        _check_values(out, known[name], source, csv)
    _check_time_order(out, source, csv, by=None, strict=True)
    if len(out) >= 2:
        dt_s = np.diff(pd.DatetimeIndex(out["timestamp"]).as_unit("ns").asi8) * 1e-9
        rate_hz = 1.0 / float(np.median(dt_s))
        lo, hi = IMU_RATE_RANGE_HZ
        if not lo <= rate_hz <= hi:
            raise DataValidationError(
                source,
                None,
                "timestamp",
                f"median sampling rate {rate_hz:.3g} Hz outside the supported {lo:g}-{hi:g} Hz "
                "(resample the series to 5-20 Hz)",
            )
    if not allow_small_angles:
        _check_radians(out, ["roll_deg", "pitch_deg"], source, csv, absolute=True)
    order = [c.name for c in IMU_COLUMNS if c.name in out.columns]
    return out[order]


def read_imu_series(
    path: str | Path, *, allow_small_angles: bool = False, heading_convention: str = "ccw"
) -> pd.DataFrame:
    """Read and validate a raw IMU series (CSV or Parquet); see :func:`validate_imu_series`.

    ``heading_convention="compass"``: the file's ``yaw_deg`` is a compass heading
    (clockwise from north, deg), turned into the project's counter-clockwise yaw
    (:func:`heading_ccw_deg`, config ``campaign.heading_convention``).
    """
    df, source, csv = _read_table(path)
    out = validate_imu_series(df, source, allow_small_angles=allow_small_angles, csv=csv)
    return imu_heading_to_ccw(out, heading_convention)


def heading_ccw_deg(compass_deg) -> np.ndarray:
    """The project's heading of a compass bearing: ``-compass`` wrapped to [-180, 180).

    Parameters
    ----------
    compass_deg : array_like
        Compass bearing, clockwise from north, deg.

    Returns
    -------
    numpy.ndarray
        Heading, counter-clockwise from above (0 = body y north), deg, in [-180, 180).
    """
    c = np.asarray(compass_deg, dtype=np.float64)
    return (180.0 - c) % 360.0 - 180.0


def imu_heading_to_ccw(imu: pd.DataFrame, heading_convention: str) -> pd.DataFrame:
    """The validated IMU series with ``yaw_deg`` in the project's convention (``ccw``:
    unchanged; ``compass``: clockwise from north turned counter-clockwise, deg)."""
    if heading_convention not in ("ccw", "compass"):
        raise ValueError(
            f"heading_convention must be 'ccw' or 'compass', got {heading_convention!r}"
        )
    if heading_convention == "ccw" or "yaw_deg" not in imu.columns:
        return imu
    out = imu.copy()
    out["yaw_deg"] = heading_ccw_deg(out["yaw_deg"].to_numpy())
    return out


def write_imu_series(df: pd.DataFrame, path: str | Path) -> Path:
    """Validate and write a raw IMU series; the format follows the file suffix."""
    return _write(validate_imu_series(df, f"<DataFrame for {path}>"), path)


# --------------------------------------------------------------------------- LOS data
def validate_los_series(
    df: pd.DataFrame, source: str = "<DataFrame>", *, csv: bool = False
) -> pd.DataFrame:
    """Validate LOS-level data (``timestamp, height_m, azimuth_deg, radial_speed_ms, cnr_db``).

    The optional ``elevation_deg`` (deg) marks a DBS lidar's vertical beam. Timestamps must be non-decreasing within each height.

    Returns
    -------
    pandas.DataFrame
        Normalised table (UTC timestamps, float64 values).
    """
    known = {c.name: c for c in LOS_COLUMNS}
    _check_columns(
        df, [c.name for c in LOS_COLUMNS if c.required], known, source, allow_truth=False
    )
    out = _coerce(df, known, source, csv)
    for name in out.columns:
        _check_values(out, known[name], source, csv)
    _check_time_order(out, source, csv, by="height_m", strict=False)
    return out[[c.name for c in LOS_COLUMNS if c.name in out.columns]]


def read_los_series(path: str | Path) -> pd.DataFrame:
    """Read and validate LOS-level data (CSV or Parquet); see :func:`validate_los_series`."""
    df, source, csv = _read_table(path)
    return validate_los_series(df, source, csv=csv)


def write_los_series(df: pd.DataFrame, path: str | Path) -> Path:
    """Validate and write LOS-level data; the format follows the file suffix."""
    return _write(validate_los_series(df, f"<DataFrame for {path}>"), path)


def los_imu_match(
    los: pd.DataFrame,
    imu: pd.DataFrame,
    *,
    max_gap_s: float = 1.0,
    los_source: str = "<LOS>",
    imu_source: str = "<IMU>",
) -> np.ndarray:
    """Which LOS measurements have an IMU sample within ``max_gap_s``.

    Parameters
    ----------
    los, imu : pandas.DataFrame
        Validated LOS table and IMU series (:func:`validate_los_series`,
        :func:`validate_imu_series`).
    max_gap_s : float
        Largest distance (s) from a LOS measurement to the nearest IMU sample.
    los_source, imu_source : str
        File names for the message.

    Returns
    -------
    numpy.ndarray of bool, shape (len(los),)
        True where the attitude is known (callers flag the others).

    Raises
    ------
    DataValidationError
        When no LOS measurement has a matching IMU sample (a LOS file without its IMU
        series), naming the LOS file, its first row and both time spans.
    """
    t_los = pd.DatetimeIndex(los["timestamp"]).as_unit("ns").asi8
    t_imu = np.sort(pd.DatetimeIndex(imu["timestamp"]).as_unit("ns").asi8)
    if t_imu.size == 0:
        raise DataValidationError(
            imu_source, None, None, "the IMU series is empty", whole_file=True
        )
    k = np.clip(np.searchsorted(t_imu, t_los), 1, t_imu.size - 1) if t_imu.size > 1 else None
    if k is None:
        dist = np.abs(t_los - t_imu[0])
    else:
        dist = np.minimum(np.abs(t_los - t_imu[k - 1]), np.abs(t_los - t_imu[k]))
    ok = dist <= max_gap_s * 1e9
    if t_los.size and not ok.any():

        def span(t: np.ndarray) -> str:
            a, b = pd.to_datetime([t.min(), t.max()], utc=True)
            return f"{a.isoformat()} to {b.isoformat()}"

        raise DataValidationError(
            los_source,
            1,
            "timestamp",
            f"no LOS measurement has an IMU sample of {imu_source} within {max_gap_s:g} s "
            f"(LOS {span(t_los)}, IMU {span(t_imu)}): the IMU series of this LOS file is missing",
            n_more=t_los.size - 1,
        )
    return ok


#: how every result table writes a time stamp (UTC)
_DATE_FORMAT = "%Y-%m-%dT%H:%M:%SZ"


def _write_csv_text(df: pd.DataFrame, path: Path, *, date_format: str) -> None:
    """Write ``df`` as CSV text, the same bytes for the same frame on any machine.

    Every float is written as its shortest text that reads back to the same float64 (every
    bit kept, so a later step sees exactly what an earlier one computed); time stamps in
    ``date_format``; booleans ``True``/``False``; missing values empty; text quoted only when
    it holds a comma, a quote or a line break. The columns go through Arrow's CSV writer
    (a year's 157,680-row, 108-column record table in 2.4 s, against 21 s for pandas' per-value
    float formatting, docs/performance.md); a gzip target, duplicate column
    names or a column Arrow cannot hold go through pandas (every float exact there too).
    """
    import pyarrow as pa
    import pyarrow.csv as pa_csv

    def through_pandas() -> None:
        df.to_csv(path, index=False, date_format=date_format, lineterminator="\n")

    if str(path).endswith(".gz") or df.columns.has_duplicates or df.shape[1] == 0:
        through_pandas()
        return
    cols = {}
    for name, col in df.items():
        if isinstance(col.dtype, pd.DatetimeTZDtype) or col.dtype.kind == "M":
            cols[name] = col.dt.strftime(date_format)
        elif col.dtype == bool:
            cols[name] = np.where(col.to_numpy(), "True", "False")
        else:
            cols[name] = col
    try:
        table = pa.Table.from_pandas(pd.DataFrame(cols), preserve_index=False)
    except (pa.ArrowException, TypeError, ValueError):
        through_pandas()
        return
    header = io.StringIO()
    csv.writer(header, lineterminator="\n").writerow([str(c) for c in df.columns])
    for quoting in ("none", "needed"):  # "none" refuses a value that needs quotes
        try:
            with open(path, "wb") as fh:
                fh.write(header.getvalue().encode())
                pa_csv.write_csv(
                    table,
                    fh,
                    write_options=pa_csv.WriteOptions(include_header=False, quoting_style=quoting),
                )
            return
        except pa.ArrowInvalid:
            continue
        except (pa.ArrowException, TypeError):
            break
    through_pandas()


def write_csv(df: pd.DataFrame, path: str | os.PathLike) -> None:
    """Write a result table deterministically (no index, UTC stamps ``YYYY-MM-DDTHH:MM:SSZ``;
    every float as its shortest exact text, so tables that feed later steps lose no bit)."""
    Path(path).parent.mkdir(parents=True, exist_ok=True)
    _write_csv_text(df, Path(path), date_format=_DATE_FORMAT)


def read_csv(
    path: str | os.PathLike,
    columns: Sequence[str] | None = None,
    *,
    chunk_rows: int | None = None,
) -> pd.DataFrame:
    """Read a result table written by :func:`write_csv` (only ``columns``, when given).

    ``chunk_rows``: parse that many rows at a time and concatenate, for a long campaign's
    record table (the parser's buffers of a 3-year, 92-column table reach 3 GB at once;
    a chunk's are a few tens of MB). A column's type is inferred per chunk; the
    concatenation gives the types of one pass (integers with a missing value in another
    chunk become floats; a text column that is empty in a chunk stays text).
    """
    usecols = None if columns is None else list(columns)
    if chunk_rows is None:
        return pd.read_csv(path, keep_default_na=True, usecols=usecols)
    chunks = list(
        pd.read_csv(path, keep_default_na=True, usecols=usecols, chunksize=int(chunk_rows))
    )
    text = {
        c: ch[c].dtype
        for ch in chunks
        for c in ch.columns
        if isinstance(ch[c].dtype, pd.StringDtype)
    }
    out = pd.concat(chunks, ignore_index=True)
    for col, dtype in text.items():  # text + an all-missing (float) chunk concatenate to object
        if out[col].dtype == object:
            out[col] = out[col].astype(dtype)
    return out
