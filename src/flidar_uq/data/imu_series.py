"""Raw IMU and LOS series read from file in chunks, and per-record motion statistics.

A year of attitude at 20 Hz is 6.3e8 samples (about 20 GB as float64 columns), more than
a workstation holds. The readers here go through a CSV or Parquet file ``chunk_rows`` rows
at a time: every chunk is validated against the data contract
(:func:`flidar_uq.data.io.validate_imu_series`, :func:`flidar_uq.data.io.validate_los_series`;
error rows are counted from the start of the file), and the checks that span chunks (time
order, a constant sampling rate, angles that look like radians) are made on the way.
:func:`window_batches` regroups the chunks into batches of whole record windows, and
:func:`series_motion_statistics` reduces each batch to the per-record statistics of
:mod:`flidar_uq.data.imu` before the next chunk is read, so memory is bounded by a chunk
plus one window whatever the length of the series (``benchmarks/imu_series_throughput.py``).
:class:`TimeCursor` serves the rows of a second time-ordered stream window by window (the
IMU beside the LOS data).
"""

from __future__ import annotations

import gzip
import logging
import os
from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass, field
from io import StringIO
from pathlib import Path

import numpy as np
import pandas as pd

from flidar_uq.data import imu as _imu
from flidar_uq.data import io
from flidar_uq.data.formats import detect_los_format, read_los_file
from flidar_uq.data.schema import (
    HEAVE_RESPONSE_COLUMN,
    HORIZONTAL_RESPONSE_COLUMN,
    RADIAN_SUSPECT_MAX_DEG,
    RADIAN_SUSPECT_MIN_COUNT,
    TILT_SPECTRUM_COLUMNS,
)

log = logging.getLogger(__name__)

__all__ = [
    "DEFAULT_CHUNK_ROWS",
    "SERIES_MOTION_COLUMNS",
    "SeriesMotion",
    "TimeCursor",
    "iter_imu_series",
    "iter_los_series",
    "merge_series_motion",
    "record_window_offset_s",
    "series_overrides",
    "series_motion_statistics",
    "series_span",
    "window_batches",
]

#: Rows read per chunk (a 20-Hz IMU chunk of 2.5e5 rows is 3.5 h of data; ~400 bytes per row
#: of a CSV chunk at the peak, text included, so ~100 MB above the ~170 MB of the libraries).
DEFAULT_CHUNK_ROWS = 250_000

#: Record columns derived from a raw IMU series (they replace those of the record table).
SERIES_MOTION_COLUMNS: tuple[str, ...] = (
    *_imu.MOTION_STAT_COLUMNS,
    *TILT_SPECTRUM_COLUMNS,
    "heading_mean_deg",
)

#: Relative change of the median sampling interval between chunks that is an error.
_RATE_TOLERANCE = 0.01


# --------------------------------------------------------------------------- chunked reading
def _raw_chunks(path: Path, chunk_rows: int) -> Iterator[tuple[pd.DataFrame, bool]]:
    """The file's rows in chunks, unvalidated; ``(chunk, is_csv)``."""
    kind = io._kind(path)  # the suffix rule of the readers (.csv, .csv.gz, .parquet, .pq)
    if not path.exists():
        raise FileNotFoundError(f"{path}: no such file")
    if kind == "csv":
        try:
            with pd.read_csv(
                path, chunksize=chunk_rows, low_memory=False, skipinitialspace=True
            ) as reader:
                for chunk in reader:
                    yield chunk.reset_index(drop=True), True
        except (pd.errors.ParserError, UnicodeDecodeError) as exc:
            raise io.DataValidationError(
                str(path), None, None, f"malformed CSV ({exc})".replace("\n", " "), csv=True
            ) from exc
        return
    import pyarrow.parquet as pq

    # pre_buffer=False: with read-ahead, arrow kept the already-read column chunks and the
    # peak memory grew with the file (365 MB at 1 day, 1.9 GB at 30 days of 20-Hz data);
    # without it the memory follows the chunk and the file's row-group size
    pf = pq.ParquetFile(path, pre_buffer=False)
    for batch in pf.iter_batches(batch_size=chunk_rows, use_threads=False):
        yield batch.to_pandas(), False


def _validated_chunks(
    path: str | Path,
    validate: Callable[..., pd.DataFrame],
    chunk_rows: int,
    *,
    strict: bool,
    what: str,
) -> Iterator[tuple[int, pd.DataFrame, bool]]:
    """Validated chunks ``(row offset, chunk, is_csv)``; timestamps increasing (``strict``)
    or non-decreasing across the whole file, the median sampling interval constant."""
    if chunk_rows < 2:
        raise ValueError(f"chunk_rows must be >= 2, got {chunk_rows}")
    path = Path(path)
    source = str(path)
    offset = 0
    last: pd.Timestamp | None = None
    dt0_ns: float | None = None
    for raw, csv in _raw_chunks(path, chunk_rows):
        if len(raw) == 0:
            continue
        try:
            df = validate(raw, source, csv=csv)
        except io.DataValidationError as exc:
            whole_file = offset == 0 and len(raw) < chunk_rows
            if exc.header or (exc.row is not None and offset == 0) or exc.column is None:
                raise
            if exc.row is None and whole_file:
                raise
            if exc.row is None:  # a problem of the chunk's rows (the rate): name them
                raise io.DataValidationError(
                    source,
                    offset + 1,
                    exc.column,
                    f"{exc.problem} (in rows {offset + 1}-{offset + len(raw)})",
                    csv=csv,
                ) from None
            raise io.DataValidationError(
                source, exc.row + offset, exc.column, exc.problem, csv=csv, n_more=exc.n_more
            ) from None
        t_ns = pd.DatetimeIndex(df["timestamp"]).as_unit("ns").asi8
        back = np.diff(t_ns) < 0
        if back.any():  # LOS: the contract orders by height; the stream needs time order
            row = offset + int(np.argmax(back)) + 2
            raise io.DataValidationError(
                source,
                row,
                "timestamp",
                f"{what} must be sorted by time for the pipeline (it is read in chunks): "
                f"{df['timestamp'].iloc[row - offset - 1].isoformat()} comes after a later "
                "timestamp; sort the file by timestamp",
                csv=csv,
            )
        if last is not None:
            first = df["timestamp"].iloc[0]
            if first < last or (strict and first == last):
                raise io.DataValidationError(
                    source,
                    offset + 1,
                    "timestamp",
                    f"timestamps not increasing: {first.isoformat()} comes after "
                    f"{last.isoformat()} (row {offset})",
                    csv=csv,
                )
        if strict and t_ns.size >= 2:
            dt_ns = float(np.median(np.diff(t_ns)))
            if dt0_ns is None:
                dt0_ns = dt_ns
            elif abs(dt_ns / dt0_ns - 1.0) > _RATE_TOLERANCE:
                raise io.DataValidationError(
                    source,
                    offset + 1,
                    "timestamp",
                    f"the sampling rate changes from {1e9 / dt0_ns:.4g} Hz to {1e9 / dt_ns:.4g} "
                    f"Hz (rows {offset + 1}-{offset + len(raw)}); split the series at the change",
                    csv=csv,
                )
        last = df["timestamp"].iloc[-1]
        yield offset, df, csv
        offset += len(raw)
    if offset == 0:
        raise io.DataValidationError(source, None, None, "the table has no data rows")


def iter_imu_series(
    path: str | Path,
    *,
    chunk_rows: int = DEFAULT_CHUNK_ROWS,
    allow_small_angles: bool = False,
    heading_convention: str = "ccw",
) -> Iterator[pd.DataFrame]:
    """Read a raw IMU series (CSV or Parquet) chunk by chunk, validated.

    Each chunk passes :func:`flidar_uq.data.io.validate_imu_series` (errors name the row
    counted from the start of the file); across chunks the timestamps must keep increasing
    and the median sampling interval must stay within 1 % of the first chunk's. The
    "angles look like radians" rule of ``docs/data-format.md`` is applied to the whole
    series, so it is raised after the last chunk.

    Parameters
    ----------
    path : str or pathlib.Path
        ``.csv``, ``.csv.gz``, ``.parquet`` or ``.pq`` file (``timestamp, roll_deg,
        pitch_deg[, yaw_deg]``).
    chunk_rows : int
        Rows per chunk (>= 2).
    allow_small_angles : bool
        Skip the radians check.
    heading_convention : {"ccw", "compass"}
        ``compass``: the file's ``yaw_deg`` is clockwise from north and is turned into the
        project's counter-clockwise yaw (:func:`flidar_uq.data.io.imu_heading_to_ccw`).

    Yields
    ------
    pandas.DataFrame
        Normalised chunks (UTC timestamps, float64 angles in deg).

    Raises
    ------
    flidar_uq.data.io.DataValidationError
        Naming file, row and column of the first problem.
    """
    count, largest = 0, 0.0
    source = str(path)
    for _, df, _ in _validated_chunks(
        path,
        lambda d, s, csv: io.validate_imu_series(d, s, allow_small_angles=True, csv=csv),
        chunk_rows,
        strict=True,
        what="the IMU series",
    ):
        if not allow_small_angles:
            vals = np.abs(df[["roll_deg", "pitch_deg"]].to_numpy(dtype=np.float64))
            use = np.isfinite(vals) & (vals > 0)
            count += int(use.sum())
            if use.any():
                largest = max(largest, float(vals[use].max()))
        yield io.imu_heading_to_ccw(df, heading_convention)
    if not allow_small_angles and count >= RADIAN_SUSPECT_MIN_COUNT:
        if largest < RADIAN_SUSPECT_MAX_DEG:
            raise io.DataValidationError(
                source,
                None,
                "roll_deg",
                f"every non-zero |angle| in ['roll_deg', 'pitch_deg'] is below "
                f"{RADIAN_SUSPECT_MAX_DEG} deg (largest {largest:.4g}): the angles look like "
                "radians, expected degrees (set allow_small_angles if the motion really is "
                "that small)",
            )


def iter_los_series(
    path: str | Path, *, chunk_rows: int = DEFAULT_CHUNK_ROWS, utc_offset_h: float | None = None
) -> Iterator[pd.DataFrame]:
    """Read LOS-level data (CSV, Parquet or WindCube ``.rtd``) chunk by chunk, in time order.

    Each chunk passes :func:`flidar_uq.data.io.validate_los_series`; the stream needs
    the rows sorted by time across heights (non-decreasing timestamps), which is stricter
    than the contract's per-height order: an unsorted file is an error that says so. A
    WindCube v2 real-time file (``.rtd``, :func:`flidar_uq.data.formats.read_los_file`: a
    day of lines of sight at most) is read whole, then served in chunks.

    Parameters
    ----------
    path : str or pathlib.Path
        ``.csv``, ``.csv.gz``, ``.parquet``, ``.pq`` or ``.rtd`` file.
    chunk_rows : int
        Rows per chunk (>= 2).
    utc_offset_h : float, optional
        A ``.rtd`` without ``timezone`` line: offset of its stamps from UTC, h.

    Yields
    ------
    pandas.DataFrame
        Normalised chunks.
    """
    if detect_los_format(path) == "windcube_rtd":
        if chunk_rows < 2:
            raise ValueError(f"chunk_rows must be >= 2, got {chunk_rows}")
        los, _ = read_los_file(path, utc_offset_h=utc_offset_h)
        for k in range(0, len(los), chunk_rows):
            yield los.iloc[k : k + chunk_rows].reset_index(drop=True)
        return
    for _, df, _ in _validated_chunks(
        path,
        lambda d, s, csv: io.validate_los_series(d, s, csv=csv),
        chunk_rows,
        strict=False,
        what="the LOS series",
    ):
        yield df


def _last_timestamp(path: Path, csv: bool, validate: Callable[..., pd.DataFrame]) -> pd.Timestamp:
    """The file's last timestamp without reading it whole: the last row of the last Parquet
    row group, or the last line of a CSV (read from the end), passed through ``validate``."""
    if not csv:
        import pyarrow.parquet as pq

        pf = pq.ParquetFile(path, pre_buffer=False)
        tail = pf.read_row_group(pf.num_row_groups - 1).to_pandas().iloc[-1:]
    else:
        if path.name.lower().endswith(".gz"):  # no seeking in a gzip stream: stream to the end
            with gzip.open(path, "rt", encoding="utf-8-sig") as fh:
                header, line = fh.readline(), ""
                for raw in fh:
                    line = raw if raw.strip() else line
        else:
            with open(path, "rb") as fh:
                header = fh.readline().decode("utf-8-sig")
                fh.seek(0, os.SEEK_END)
                fh.seek(max(0, fh.tell() - 65536))
                lines = [x for x in fh.read().decode("utf-8", "replace").splitlines() if x.strip()]
                line = lines[-1] if lines else ""
        tail = pd.read_csv(StringIO(header.rstrip("\r\n") + "\n" + line.rstrip("\r\n") + "\n"))
    return pd.Timestamp(
        validate(tail.reset_index(drop=True), f"{path} (last row)", csv=csv)["timestamp"].iloc[-1]
    )


def series_span(
    path: str | Path,
    *,
    what: str = "imu",
    head_rows: int = 20_000,
    utc_offset_h: float | None = None,
) -> tuple[pd.Timestamp, pd.Timestamp]:
    """First and last timestamp of a series file, its head validated, in bounded time.

    The check at the start of a pipeline run (:func:`flidar_uq.workflow.inputs.
    pipeline_preflight`): the first ``head_rows`` rows pass the reader's validation
    (columns, delimiter, units, the IMU's sampling rate), and the last timestamp comes from
    the end of the file, so a year of 20-Hz data is not read for it.

    Parameters
    ----------
    path : str or pathlib.Path
        The IMU or LOS series (CSV or Parquet).
    what : {"imu", "los"}
        Which series (its validation). A LOS ``.rtd`` is read whole.
    head_rows : int
        Rows validated at the head of the file (>= 2).
    utc_offset_h : float, optional
        A ``.rtd`` without ``timezone`` line: offset of its stamps from UTC, h.

    Returns
    -------
    (pandas.Timestamp, pandas.Timestamp)
        First and last timestamp (UTC).

    Raises
    ------
    flidar_uq.data.io.DataValidationError
        On a problem of the head (names file, row and column).
    """
    if what == "imu":
        head = next(iter_imu_series(path, chunk_rows=head_rows, allow_small_angles=True))

        def validate(d, s, csv):
            return io.validate_imu_series(d, s, allow_small_angles=True, csv=csv)
    elif detect_los_format(path) == "windcube_rtd":
        los, _ = read_los_file(path, utc_offset_h=utc_offset_h)
        return pd.Timestamp(los["timestamp"].iloc[0]), pd.Timestamp(los["timestamp"].iloc[-1])
    else:
        head = next(iter_los_series(path, chunk_rows=head_rows))
        validate = io.validate_los_series
    csv = io._kind(Path(path)) == "csv"
    return pd.Timestamp(head["timestamp"].iloc[0]), _last_timestamp(Path(path), csv, validate)


# --------------------------------------------------------------------------- windows
def _ns(timestamps) -> np.ndarray:
    return pd.DatetimeIndex(timestamps).as_unit("ns").asi8


def window_batches(
    chunks: Iterable[pd.DataFrame], *, window_s: float = 600.0, offset_s: float = 0.0
) -> Iterator[pd.DataFrame]:
    """Regroup time-ordered chunks into batches that hold whole windows only.

    Windows start at ``offset_s`` plus multiples of ``window_s`` since the Unix epoch. The
    rows of a window that continues into the next chunk are carried over, so a batch holds
    at most one chunk plus one window.

    Parameters
    ----------
    chunks : iterable of pandas.DataFrame
        Chunks with a ``timestamp`` column (UTC), non-decreasing across chunks.
    window_s : float
        Window length, s.
    offset_s : float
        Start of the windows after the epoch's multiples of ``window_s``, s.

    Yields
    ------
    pandas.DataFrame
        Batches (RangeIndex), each ending at a window boundary except the last.
    """
    window_ns = int(round(window_s * 1e9))
    offset_ns = int(round(offset_s * 1e9))
    carry: pd.DataFrame | None = None
    for chunk in chunks:
        df = chunk if carry is None else pd.concat([carry, chunk], ignore_index=True)
        t = _ns(df["timestamp"])
        if t.size == 0:
            continue
        boundary = ((int(t[-1]) - offset_ns) // window_ns) * window_ns + offset_ns
        cut = int(np.searchsorted(t, boundary, side="left"))
        if cut > 0:
            yield df.iloc[:cut].reset_index(drop=True)
        carry = df.iloc[cut:].reset_index(drop=True)
    if carry is not None and len(carry):
        yield carry


@dataclass
class TimeCursor:
    """Rows of a time-ordered chunk stream served by increasing time ranges.

    :meth:`take` returns the rows in ``[start, end)`` and forgets the rows before
    ``start``; ranges must be requested with non-decreasing starts (they may overlap).
    Memory: the rows between the current start and the furthest end asked, plus a chunk.
    """

    chunks: Iterable[pd.DataFrame]
    _it: Iterator[pd.DataFrame] | None = field(default=None, init=False, repr=False)
    _buf: pd.DataFrame | None = field(default=None, init=False, repr=False)
    _done: bool = field(default=False, init=False, repr=False)

    def take(self, start: pd.Timestamp, end: pd.Timestamp) -> pd.DataFrame:
        """Rows with ``start <= timestamp < end`` (a copy; may be empty)."""
        if self._it is None:
            self._it = iter(self.chunks)
        start_ns, end_ns = pd.Timestamp(start).value, pd.Timestamp(end).value
        while not self._done and (
            self._buf is None or len(self._buf) == 0 or _ns(self._buf["timestamp"])[-1] < end_ns
        ):
            nxt = next(self._it, None)
            if nxt is None:
                self._done = True
            elif len(nxt):
                self._buf = (
                    nxt if self._buf is None else pd.concat([self._buf, nxt], ignore_index=True)
                )
                drop = int(np.searchsorted(_ns(self._buf["timestamp"]), start_ns, side="left"))
                self._buf = self._buf.iloc[drop:].reset_index(drop=True)
        if self._buf is None or len(self._buf) == 0:
            return pd.DataFrame(columns=["timestamp"])
        t = _ns(self._buf["timestamp"])
        lo = int(np.searchsorted(t, start_ns, side="left"))
        hi = int(np.searchsorted(t, end_ns, side="left"))
        self._buf = self._buf.iloc[lo:].reset_index(drop=True)
        return self._buf.iloc[: hi - lo].copy()


# --------------------------------------------------------------------------- statistics
@dataclass
class SeriesMotion:
    """Result of :func:`series_motion_statistics`.

    Attributes
    ----------
    statistics : pandas.DataFrame
        One row per record row (same order): ``timestamp``, ``height_m`` and the columns
        of :data:`SERIES_MOTION_COLUMNS` (``imu_availability_pct`` 0 where the series has
        no sample in the record's window).
    gaps : pandas.DataFrame
        Gaps of at least ``gap_min_s`` without a valid sample (absent rows or NaN angles):
        ``kind`` (``inside``, ``before_first_sample``, ``after_last_sample``), ``start``
        (last valid sample before, or the first record's start), ``end`` (next valid
        sample, or the last record's end), ``duration_s`` (s without samples beyond the
        nominal interval), ``missing_samples``.
    summary : dict
        Counts for the log and the report (rows, valid samples, rate, span, gaps, records
        with statistics, below the coverage threshold, without samples).
    """

    statistics: pd.DataFrame
    gaps: pd.DataFrame
    summary: dict


def record_window_offset_s(records: pd.DataFrame, window_s: float = 600.0) -> float:
    """Start of the records' windows after the epoch's multiples of ``window_s``, s.

    Parameters
    ----------
    records : pandas.DataFrame
        Records with ``timestamp`` (UTC window starts).
    window_s : float
        Record length, s.

    Returns
    -------
    float
        The common offset, s, in ``[0, window_s)``.

    Raises
    ------
    ValueError
        If the records are not on one grid of ``window_s`` (naming the first record off it).
    """
    window_ns = int(round(window_s * 1e9))
    t = _ns(records["timestamp"])
    off = np.mod(t, window_ns)
    bad = off != off[0]
    if bad.any():
        i = int(np.argmax(bad))
        raise ValueError(
            f"record timestamps are not on one {window_s:g}-s grid: record row {i + 1} "
            f"({records['timestamp'].iloc[i].isoformat()}) is offset from row 1 "
            f"({records['timestamp'].iloc[0].isoformat()}); the series' windows follow the "
            "records"
        )
    return float(off[0]) * 1e-9


def _runs(window_index: np.ndarray, max_windows: int) -> list[slice]:
    """Row slices of consecutive windows, at most ``max_windows`` windows each (the window
    grid of :func:`flidar_uq.data.imu.window_series` spans every window of a run)."""
    starts = [0]
    first = window_index[0]
    for j in np.flatnonzero(np.diff(window_index) > 0) + 1:
        if window_index[j] - window_index[j - 1] > 1 or window_index[j] - first >= max_windows:
            starts.append(int(j))
            first = window_index[j]
    bounds = [*starts, window_index.size]
    return [slice(a, b) for a, b in zip(bounds[:-1], bounds[1:], strict=True)]


def series_motion_statistics(
    path: str | Path,
    records: pd.DataFrame,
    *,
    window_s: float = 600.0,
    chunk_rows: int = DEFAULT_CHUNK_ROWS,
    min_coverage_pct: float = 80.0,
    allow_small_angles: bool = False,
    gap_min_s: float = 1.0,
    heading_convention: str = "ccw",
) -> SeriesMotion:
    """Per-record motion statistics of a raw IMU series file, streamed in chunks.

    For every record window (``window_s`` from each record's ``timestamp``; the records
    must lie on one grid), the roll/pitch amplitude, period and two-peak statistics
    (:func:`flidar_uq.data.imu.motion_statistics`) and the tilt along and across the
    record's own wind direction ``wd_mean_deg``, per height
    (:func:`flidar_uq.data.imu.tilt_spectrum_statistics_by_height`: the attitude gridded and
    turned once for all heights), with their default estimators:
    the same numbers as on the whole series at once. The sample grid uses the rate of the
    first chunk (median interval rounded to 1 microsecond).

    Parameters
    ----------
    path : str or pathlib.Path
        The IMU series (CSV or Parquet, ``docs/data-format.md``).
    records : pandas.DataFrame
        Record rows: ``timestamp`` (UTC window start), ``height_m``, ``wd_mean_deg`` (deg).
    window_s : float
        Record length, s.
    chunk_rows : int
        Rows read at a time (memory ~ 400 bytes per row of a CSV chunk at the peak).
    min_coverage_pct : float
        Windows with fewer nominal samples present get NaN statistics, %.
    allow_small_angles : bool
        Skip the "angles look like radians" check.
    gap_min_s : float
        Shortest gap listed in :attr:`SeriesMotion.gaps`, s (all gaps are counted).
    heading_convention : {"ccw", "compass"}
        The series' ``yaw_deg`` convention (:func:`iter_imu_series`).

    Returns
    -------
    SeriesMotion
    """
    window_ns = int(round(window_s * 1e9))
    offset_ns = int(round(record_window_offset_s(records, window_s) * 1e9))
    rec_t = _ns(records["timestamp"]) - offset_ns
    rec_keys = pd.DataFrame(
        {"timestamp": pd.to_datetime(rec_t, utc=True), "height_m": records["height_m"].to_numpy()}
    )
    wd_by_height = {
        h: pd.Series(
            records.loc[sel, "wd_mean_deg"].to_numpy(dtype=float),
            index=pd.to_datetime(rec_t[sel.to_numpy()], utc=True),
        )
        for h, sel in ((h, records["height_m"] == h) for h in records["height_m"].unique())
    }
    wanted = set(rec_t.tolist())
    motion_rows, tilt_rows = [], []
    fs: float | None = None
    n_rows = 0
    gaps = _GapLog(gap_min_s)
    shifted = (
        c.assign(timestamp=c["timestamp"] - pd.Timedelta(offset_ns, "ns")) if offset_ns else c
        for c in iter_imu_series(
            path,
            chunk_rows=chunk_rows,
            allow_small_angles=allow_small_angles,
            heading_convention=heading_convention,
        )
    )
    for batch in window_batches(shifted, window_s=window_s):
        t = _ns(batch["timestamp"])
        n_rows += t.size
        if fs is None:
            if t.size < 2:
                raise ValueError(f"{path}: the IMU series needs at least 2 samples")
            fs = 1.0 / (round(float(np.median(np.diff(t))) * 1e-3) * 1e-6)
        ok = np.isfinite(batch[["roll_deg", "pitch_deg"]].to_numpy(dtype=float)).all(axis=1)
        gaps.add(t[ok], fs)
        # statistics, run by run of consecutive windows
        win = t // window_ns
        m = int(round(window_s * fs))
        for sl in _runs(win, max(1, chunk_rows // m)):
            if not any(int(w) * window_ns in wanted for w in np.unique(win[sl])):
                continue
            part = batch.iloc[sl]
            ms = _imu.motion_statistics(
                part, window_s=window_s, min_coverage_pct=min_coverage_pct, fs_hz=fs
            )
            motion_rows.append(ms[ms["timestamp"].isin(rec_keys["timestamp"])])
            by_height = _imu.tilt_spectrum_statistics_by_height(
                part, wd_by_height, window_s=window_s, min_coverage_pct=min_coverage_pct, fs_hz=fs
            )
            for h, (tab, _) in by_height.items():
                tab = tab[tab["timestamp"].isin(wd_by_height[h].index)]
                tilt_rows.append(tab.assign(height_m=h))
    out = _record_table(records, rec_keys, motion_rows, tilt_rows)
    gap_table = gaps.table(int(rec_t.min()), int(rec_t.max()) + window_ns, fs, offset_ns)
    stats_ok = np.isfinite(out["roll_amplitude_deg"].to_numpy())
    avail = out["imu_availability_pct"].to_numpy()
    inside = gap_table["kind"] == "inside"
    summary = {
        "imu_series": str(path),
        "rows": n_rows,
        "valid_samples": gaps.n_valid,
        "rate_hz": fs,
        "first_sample": _iso(gaps.first_valid, offset_ns),
        "last_sample": _iso(gaps.last_valid, offset_ns),
        "gaps": gaps.n_gaps,
        "missing_samples_inside": gaps.n_missing,
        f"gaps_listed_ge_{gap_min_s:g}_s": int(inside.sum()),
        "longest_gap_inside_s": float(gap_table.loc[inside, "duration_s"].max())
        if inside.any()
        else 0.0,
        "record_rows": len(out),
        "record_rows_with_statistics": int(stats_ok.sum()),
        "record_rows_below_coverage": int((avail < min_coverage_pct).sum()),
        "record_rows_without_samples": int((avail == 0).sum()),
    }
    log.info("IMU series %s: %s", path, summary)
    return SeriesMotion(out, gap_table, summary)


def _iso(t_ns, offset_ns: int) -> str | None:
    """ISO-8601 UTC time of a shifted sample time (ns), None for None."""
    return None if t_ns is None else pd.Timestamp(t_ns + offset_ns, tz="UTC").isoformat()


def _record_table(records, rec_keys, motion_rows, tilt_rows) -> pd.DataFrame:
    """The per-record statistics of :func:`series_motion_statistics`, one row per record
    (NaN where no window of the series matched), at the records' own times."""
    out = rec_keys.copy()
    if motion_rows:
        out = out.merge(pd.concat(motion_rows, ignore_index=True), on="timestamp", how="left")
    else:
        out = out.assign(**{c: np.nan for c in _imu.MOTION_STAT_COLUMNS})
    if tilt_rows:
        tl = pd.concat(tilt_rows, ignore_index=True)
        out = out.merge(tl, on=["timestamp", "height_m"], how="left")
    else:
        out = out.assign(**{c: np.nan for c in (*TILT_SPECTRUM_COLUMNS, "heading_mean_deg")})
    out["imu_availability_pct"] = out["imu_availability_pct"].fillna(0.0)
    out["timestamp"] = records["timestamp"].to_numpy()  # back to the records' own times
    measured = _measured_heave_columns(out)
    return out[["timestamp", "height_m", *SERIES_MOTION_COLUMNS, *measured]]


class _GapLog:
    """Gaps of a series read chunk by chunk: intervals between valid samples longer than
    1.5 nominal intervals (all counted, those of at least ``gap_min_s`` listed), and the
    first and last valid sample times (ns)."""

    def __init__(self, gap_min_s: float) -> None:
        self.gap_min_s = gap_min_s
        self.n_valid = self.n_gaps = self.n_missing = 0
        self.first_valid = self.last_valid = None
        self.rows: list[tuple] = []

    def add(self, tv: np.ndarray, fs: float) -> None:
        """The valid sample times ``tv`` (ns, increasing) of the next chunk, at ``fs`` (Hz)."""
        self.n_valid += tv.size
        if not tv.size:
            return
        edges = tv if self.last_valid is None else np.r_[self.last_valid, tv]
        dt = np.diff(edges)
        big = dt > 1.5e9 / fs
        missing = np.rint(dt[big] * fs * 1e-9).astype(np.int64) - 1
        self.n_gaps += int(big.sum())
        self.n_missing += int(missing.sum())
        for a, b, k in zip(edges[:-1][big], edges[1:][big], missing, strict=True):
            if (b - a) * 1e-9 - 1.0 / fs >= self.gap_min_s:
                self.rows.append(("inside", a, b, (b - a) * 1e-9 - 1.0 / fs, int(k)))
        self.first_valid = tv[0] if self.first_valid is None else self.first_valid
        self.last_valid = tv[-1]

    def table(self, span_lo: int, span_hi: int, fs: float, offset_ns: int) -> pd.DataFrame:
        """The listed gaps with those before the first and after the last valid sample
        within the records' span ``[span_lo, span_hi)`` (ns), times back at ``offset_ns``."""
        rows = list(self.rows)
        first, last = self.first_valid, self.last_valid
        if first is None:
            rows.append(("no_valid_sample", span_lo, span_hi, (span_hi - span_lo) * 1e-9, 0))
        else:
            if first > span_lo:
                rows.append(("before_first_sample", span_lo, first, (first - span_lo) * 1e-9, 0))
            if last < span_hi - 1e9 / fs:
                rows.append(("after_last_sample", last, span_hi, (span_hi - last) * 1e-9, 0))
        table = pd.DataFrame(
            rows, columns=["kind", "start", "end", "duration_s", "missing_samples"]
        )
        for col in ("start", "end"):
            table[col] = pd.to_datetime(table[col].astype(np.int64) + offset_ns, utc=True)
        return table


def series_overrides(records: pd.DataFrame) -> tuple[list[str], int]:
    """The motion columns of a record table that a raw IMU series replaces.

    Parameters
    ----------
    records : pandas.DataFrame
        Record table (motion columns optional).

    Returns
    -------
    columns : list of str
        The :data:`SERIES_MOTION_COLUMNS` the table itself carries.
    n_rows : int
        Record rows with a value in one of them (the series wins over it).
    """
    own = [c for c in SERIES_MOTION_COLUMNS if c in records.columns]
    own += _measured_heave_columns(records)
    return own, int(records[own].notna().any(axis=1).sum()) if own else 0


def _measured_heave_columns(table: pd.DataFrame) -> list[str]:
    """What the heave of an IMU series measured that a table carries: the bands' sides
    (``tilt_band{b}_cos_psi``, ``tilt_band{b}_sin_psi``; the bands'
    ``tilt_band{b}_sincos_psi`` is the tilt's own, :data:`SERIES_MOTION_COLUMNS`) and the
    hull's responses (``heave_response_ratio``, ``horizontal_response_ratio``)."""
    ends = ("_cos_psi", "_sin_psi")
    return [
        c
        for c in table
        if (c.startswith("tilt_band") and c.endswith(ends))
        or c in (HEAVE_RESPONSE_COLUMN, HORIZONTAL_RESPONSE_COLUMN)
    ]


def merge_series_motion(
    records: pd.DataFrame, statistics: pd.DataFrame, *, source: str = "<statistics>"
) -> pd.DataFrame:
    """Replace the record table's motion columns by those derived from the IMU series.

    Parameters
    ----------
    records : pandas.DataFrame
        Validated record table (motion columns optional).
    statistics : pandas.DataFrame
        :attr:`SeriesMotion.statistics` of the records (same rows, same order): timestamps
        and the :data:`SERIES_MOTION_COLUMNS` (deg, s, ...; see :func:`series_motion_statistics`).
    source : str
        The statistics' file, for the message.

    Returns
    -------
    pandas.DataFrame
        The records with the series' motion columns (the table's own dropped,
        :func:`series_overrides`).

    Raises
    ------
    ValueError
        If the statistics do not match the records row by row.
    """
    if (
        len(statistics) != len(records)
        or not (
            pd.to_datetime(statistics["timestamp"], utc=True).to_numpy()
            == records["timestamp"].to_numpy()
        ).all()
    ):
        raise ValueError(
            f"{source}: IMU statistics do not match the record table row by row "
            f"({len(statistics)} vs {len(records)} rows); rerun the imu_statistics step"
        )
    merged = records.drop(columns=series_overrides(records)[0])
    # with what the heave measured (the bands' directions, the heave response) where the
    # series had a vertical velocity or acceleration
    for col in (*SERIES_MOTION_COLUMNS, *_measured_heave_columns(statistics)):
        merged[col] = statistics[col].to_numpy(dtype=float)
    return merged
