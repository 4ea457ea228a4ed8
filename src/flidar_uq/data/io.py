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

import gzip
import re
from collections.abc import Iterable, Mapping
from pathlib import Path

import numpy as np
import pandas as pd

from flidar_uq.data.schema import (
    IMU_COLUMNS,
    IMU_RATE_RANGE_HZ,
    LOS_COLUMNS,
    MOTION_COLUMNS,
    RADIAN_SUSPECT_MAX_DEG,
    RADIAN_SUSPECT_MIN_COUNT,
    RECORD_COLUMNS,
    TRUTH_PREFIX,
    Column,
    record_column,
)

__all__ = [
    "DataValidationError",
    "read_records",
    "write_records",
    "validate_records",
    "read_imu_series",
    "validate_imu_series",
    "write_imu_series",
    "read_los_series",
    "validate_los_series",
    "write_los_series",
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
        problems of the header (message says ``header``) or of a whole column
        (``all rows``).
    column : str or None
        Offending column name.
    problem, csv, n_more, header
        The constructor's arguments of the same names (what is wrong, whether the source
        is a CSV file, further offending rows, a problem of the header).
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
    ) -> None:
        self.source, self.row, self.column = source, row, column
        # kept so that a chunked reader can re-raise with the row counted from the file start
        self.problem, self.csv, self.n_more, self.header = problem, csv, n_more, header
        if row is None:
            where = "header" if header or column is None else "all rows"
        else:
            where = f"row {row}" + (f" (line {row + 1})" if csv else "")
        col = "" if column is None else f", column {column!r}"
        more = f" (and {n_more} more row{'s' if n_more != 1 else ''})" if n_more else ""
        super().__init__(f"{source}: {where}{col}: {problem}{more}")


# --------------------------------------------------------------------------- helpers
def _kind(path: Path) -> str:
    name = path.name.lower()
    if name.endswith(_CSV_SUFFIXES):
        return "csv"
    if name.endswith(_PARQUET_SUFFIXES):
        return "parquet"
    raise ValueError(f"{path}: unknown file type; use one of {_CSV_SUFFIXES + _PARQUET_SUFFIXES}")


def _csv_header(path: Path) -> list[str]:
    opener = gzip.open if path.name.lower().endswith(".gz") else open
    with opener(path, "rt", encoding="utf-8") as fh:
        line = fh.readline()
    return [c.strip().strip('"') for c in line.rstrip("\r\n").split(",")]


def _read_table(path: str | Path) -> tuple[pd.DataFrame, str, bool]:
    path = Path(path)
    kind = _kind(path)
    source = str(path)
    if not path.exists():
        raise FileNotFoundError(f"{source}: no such file")
    if kind == "csv":
        header = _csv_header(path)
        seen: set[str] = set()
        for name in header:
            if name in seen:
                raise DataValidationError(source, None, name, "duplicated column name", header=True)
            seen.add(name)
        # pandas infers numbers; text left in a numeric column is reported by _coerce.
        # low_memory=False gives one dtype per column
        try:
            df = pd.read_csv(path, low_memory=False, skipinitialspace=True)
        except (pd.errors.ParserError, UnicodeDecodeError) as exc:
            m = re.search(r"line (\d+)", str(exc))
            row = int(m.group(1)) - 1 if m else None
            raise DataValidationError(
                source, row, None, f"malformed CSV ({exc})".replace("\n", " "), csv=True
            ) from exc
        return df, source, True
    return pd.read_parquet(path), source, False


def _first(mask: np.ndarray) -> tuple[int, int]:
    """Return (1-based row of the first True, number of further True)."""
    idx = np.flatnonzero(mask)
    return int(idx[0]) + 1, int(idx.size - 1)


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
                f"number {s.iloc[row - 1]!r} is not an ISO 8601 timestamp",
                csv=csv,
                n_more=more,
            )
        out = pd.to_datetime(s, utc=True, format="ISO8601", errors="coerce")
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
    return out.astype("datetime64[ns, UTC]")


def _parse_float(s: pd.Series, name: str, source: str, csv: bool) -> pd.Series:
    if pd.api.types.is_bool_dtype(s.dtype):
        raise DataValidationError(
            source, 1, name, "boolean values where a number is expected", csv=csv, n_more=len(s) - 1
        )
    if pd.api.types.is_numeric_dtype(s.dtype):
        return s.astype(np.float64)
    out = pd.to_numeric(s, errors="coerce")
    bad = (out.isna() & s.notna()).to_numpy()
    if bad.any():
        row, more = _first(bad)
        raise DataValidationError(
            source,
            row,
            name,
            f"cannot parse {s.iloc[row - 1]!r} as a number",
            csv=csv,
            n_more=more,
        )
    return out.astype(np.float64)


def _bounds_problem(col: Column, value: float) -> str:
    """Explain a bound violation in the user's terms."""
    n = col.name
    if n.endswith("_std_ms") and value < 0:
        return f"negative standard deviation {value:g} m/s"
    if n.endswith("hws_mean_ms") and col.upper is not None and value > col.upper:
        return f"wind speed {value:g} m/s above {col.upper:g} m/s (impossible)"
    if n.startswith("wd_") or n.startswith("azimuth"):
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
            "(pass allow_small_angles=True if the motion really is that small)",
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
def validate_records(
    df: pd.DataFrame,
    source: str = "<DataFrame>",
    *,
    require_motion: bool = True,
    allow_small_angles: bool = False,
    csv: bool = False,
) -> pd.DataFrame:
    """Validate a record table and return it normalised.

    Parameters
    ----------
    df : pandas.DataFrame
        Record table, one row per 10-min record and height (columns in
        ``docs/data-format.md``).
    source : str
        Name used in error messages (the file path).
    require_motion : bool
        If False the IMU motion columns may be absent (they will be derived from
        a raw IMU series with :func:`flidar_uq.data.imu.motion_statistics`).
    allow_small_angles : bool
        Skip the "angles look like radians" check (documented rule).
    csv : bool
        If True, messages also give the file line (header is line 1).

    Returns
    -------
    pandas.DataFrame
        Columns in schema order then truth columns; ``timestamp`` as
        ``datetime64[ns, UTC]``, all other columns float64; RangeIndex.

    Raises
    ------
    DataValidationError
        On the first problem found, naming file, row and column.
    """
    known = {c.name: c for c in RECORD_COLUMNS}
    required = [
        c.name
        for c in RECORD_COLUMNS
        if c.required and (require_motion or c.name not in MOTION_COLUMNS)
    ]
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
                "like radians, expected degrees (pass allow_small_angles=True to accept)",
                csv=csv,
            )
    _check_time_order(out, source, csv, by="height_m", strict=True)
    order = [c.name for c in RECORD_COLUMNS if c.name in out.columns]
    order += [c for c in out.columns if c not in order]
    return out[order]


def read_records(
    path: str | Path, *, require_motion: bool = True, allow_small_angles: bool = False
) -> pd.DataFrame:
    """Read and validate a record table (CSV or Parquet).

    Parameters
    ----------
    path : str or pathlib.Path
        ``.csv``, ``.csv.gz``, ``.parquet`` or ``.pq`` file.
    require_motion, allow_small_angles : bool
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
        df, source, require_motion=require_motion, allow_small_angles=allow_small_angles, csv=csv
    )


def _write(df: pd.DataFrame, path: str | Path, date_format: str = _ISO_FORMAT_US) -> Path:
    path = Path(path)
    kind = _kind(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    if kind == "csv":
        df.to_csv(path, index=False, date_format=date_format)
    else:
        df.to_parquet(path, index=False)
    return path


def write_records(
    df: pd.DataFrame,
    path: str | Path,
    *,
    require_motion: bool = True,
    allow_small_angles: bool = False,
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
                f"median sampling rate {rate_hz:.3g} Hz outside the supported {lo:g}-{hi:g} Hz",
            )
    if not allow_small_angles:
        _check_radians(out, ["roll_deg", "pitch_deg"], source, csv, absolute=True)
    order = [c.name for c in IMU_COLUMNS if c.name in out.columns]
    return out[order]


def read_imu_series(path: str | Path, *, allow_small_angles: bool = False) -> pd.DataFrame:
    """Read and validate a raw IMU series (CSV or Parquet); see :func:`validate_imu_series`."""
    df, source, csv = _read_table(path)
    return validate_imu_series(df, source, allow_small_angles=allow_small_angles, csv=csv)


def write_imu_series(df: pd.DataFrame, path: str | Path) -> Path:
    """Validate and write a raw IMU series; the format follows the file suffix."""
    return _write(validate_imu_series(df, f"<DataFrame for {path}>"), path)


# --------------------------------------------------------------------------- LOS data
def validate_los_series(
    df: pd.DataFrame, source: str = "<DataFrame>", *, csv: bool = False
) -> pd.DataFrame:
    """Validate LOS-level data (``timestamp, height_m, azimuth_deg, radial_speed_ms, cnr_db``).

    Timestamps must be non-decreasing within each height.

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
    return out[[c.name for c in LOS_COLUMNS]]


def read_los_series(path: str | Path) -> pd.DataFrame:
    """Read and validate LOS-level data (CSV or Parquet); see :func:`validate_los_series`."""
    df, source, csv = _read_table(path)
    return validate_los_series(df, source, csv=csv)


def write_los_series(df: pd.DataFrame, path: str | Path) -> Path:
    """Validate and write LOS-level data; the format follows the file suffix."""
    return _write(validate_los_series(df, f"<DataFrame for {path}>"), path)
