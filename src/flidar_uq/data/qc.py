"""Quality-control filters with reason flags; counts are conserved.

Every filter is evaluated independently on the full input, so a record can
fail several filters and the flags do not depend on the order of the filters.
Nothing is dropped silently: :func:`run_qc` returns the kept records *and* a
flags table with one row per input record, and checks
``n_in == n_kept + n_flagged``.

Record-level filters (reason codes):

========================  ====================================================  ============
reason                    rule (flagged if ...)                                  source
========================  ====================================================  ============
``missing_wind``          ``hws_mean_ms`` or ``hws_std_ms`` is NaN               data contract
``hws_nonphysical``       ``hws_mean_ms > hws_max_ms`` (40 m/s)                  offshore range
``hws_out_of_ti_range``   ``hws_mean_ms`` outside [3, 40] m/s                    Gutiérrez-Antuñano et al. (2018), Sec. 3.5
``sv_high``               ``sv > sv_max`` (0.06)                                 Gutiérrez-Antuñano et al. (2018), Sec. 3.4
``mad_outlier``           ``|X - M| > 3 MAD / 0.6745`` on a rolling median       Malekmohammadi et al. (2024), Eq. (8)
``relative_sigma``        ``ref_std / moving_std - 1 > 0.70``                    Malekmohammadi et al. (2024), Eq. (9)
``low_availability``      ``availability_pct < 50``                              Malekmohammadi et al. (2024), Sec. 4.2
``imu_gap``               a motion statistic NaN, or ``imu_availability_pct``    data contract
                          below its minimum (80 %)
``zero_std``              ``hws_std_ms`` or ``ref_hws_std_ms`` exactly 0 (a      data contract
                          frozen sensor; such a record cannot enter the fit)
``height_not_selected``   ``height_m`` not among the selected heights           config
                          (``heights_m``, config ``campaign.heights``)
``std_pattern``           ``log(hws_std_ms / hws_mean_ms)`` farther from its     robust statistics
                          column's median than 5 scaled MADs and than a factor
                          3 (e.g. TI in percent in the std column)
========================  ====================================================  ============

LOS-level filter (:func:`run_los_qc`): ``cnr_low``, CNR below -23 dB or missing
(Malekmohammadi et al., 2024, Sec. 4.2).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd

__all__ = [
    "QCConfig",
    "QCResult",
    "RECORD_REASONS",
    "LOS_REASONS",
    "MAD_SCALE",
    "run_qc",
    "run_los_qc",
    "rolling_mad_outliers",
    "std_pattern_outliers",
    "STD_PATTERN_MIN_RECORDS",
    "summarise",
    "speed_bin_summary",
]

RECORD_REASONS = (
    "missing_wind",
    "hws_nonphysical",
    "hws_out_of_ti_range",
    "sv_high",
    "mad_outlier",
    "relative_sigma",
    "low_availability",
    "imu_gap",
    "zero_std",
    "height_not_selected",
    "std_pattern",
)
LOS_REASONS = ("cnr_low",)

#: Consistency constant of the MAD for a normal distribution (Malekmohammadi et al., 2024, Eq. 8).
MAD_SCALE = 0.6745

_MOTION = ("roll_amplitude_deg", "pitch_amplitude_deg", "roll_period_s", "pitch_period_s")


@dataclass(frozen=True)
class QCConfig:
    """Switches and thresholds of the QC filters (defaults from Gutiérrez-Antuñano et al. (2018) and Malekmohammadi et al. (2024)).

    Parameters
    ----------
    missing_wind : bool
        Flag records whose ``hws_mean_ms`` or ``hws_std_ms`` is NaN.
    hws_nonphysical : bool
        Flag ``hws_mean_ms > hws_max_ms`` (Malekmohammadi et al., 2024, Sec. 4.2).
    hws_max_ms : float
        Nonphysical wind speed threshold, m/s (40: 20-25 m/s is ordinary winter wind at
        80-150 m offshore; Malekmohammadi et al. (2024) used 20 on a hexapod).
    ti_range : bool
        Flag records outside the HWS range used for TI (Gutiérrez-Antuñano et al., 2018, Sec. 3.5).
    ti_hws_min_ms, ti_hws_max_ms : float
        Inclusive HWS range for TI, m/s (3, 40; the bins' minimum record count then ends
        the statistics at the highest bin with enough records).
    sv : bool
        Flag records with spatial variation above ``sv_max`` (Gutiérrez-Antuñano et al., 2018, Sec. 3.4).
    sv_max : float
        Spatial-variation threshold, dimensionless (0.06).
    mad : bool
        Flag MAD outliers about a rolling median (Malekmohammadi et al., 2024, Eq. 8).
    mad_column : str
        Record column tested for outliers (``hws_mean_ms``).
    mad_k : float
        Multiplier of the scaled MAD, dimensionless (3).
    mad_window_h : float
        Width of the centred rolling window, hours (6), per height.
    mad_min_records : int
        Fewest finite values in a window for the test to apply (5); records with
        fewer are not judged (not flagged).
    relative_sigma : bool
        Flag inconsistent reference std (Malekmohammadi et al., 2024, Eq. 9) when ``ref_hws_std_ms`` exists.
    relative_sigma_max : float
        Largest accepted ``sigma_ref / sigma_moving - 1``, dimensionless (0.70).
    availability : bool
        Flag records with ``availability_pct < availability_min_pct``.
    availability_min_pct : float
        Minimum availability, % (50; Malekmohammadi et al. (2024), Sec. 4.2).
    imu_gap : bool
        Flag records with missing motion statistics or low IMU coverage.
    imu_availability_min_pct : float
        Minimum ``imu_availability_pct``, % (80), when that column exists.
    zero_std : bool
        Flag records whose ``hws_std_ms`` or ``ref_hws_std_ms`` is exactly 0 m/s.
    heights_m : tuple of float, optional
        Selected measurement heights, m; records at other heights are flagged
        ``height_not_selected`` (None: every height).
    std_pattern : bool
        Flag records whose std-to-mean ratio breaks its column's pattern
        (:func:`std_pattern_outliers`).
    std_pattern_k : float
        Multiplier of the scaled MAD of ``log(hws_std_ms / hws_mean_ms)``, dimensionless (5).
    std_pattern_min_factor : float
        Smallest ratio to the column's median std-to-mean ratio (or its inverse) that is
        flagged, dimensionless (3; TI in percent in the std column is ``100 / hws_mean_ms``
        times the true ratio).
    cnr : bool
        Flag LOS measurements with CNR below ``cnr_min_db`` (LOS data only).
    cnr_min_db : float
        CNR threshold, dB (-23; Malekmohammadi et al. (2024), Sec. 4.2).
    """

    missing_wind: bool = True
    hws_nonphysical: bool = True
    hws_max_ms: float = 40.0
    ti_range: bool = True
    ti_hws_min_ms: float = 3.0
    ti_hws_max_ms: float = 40.0
    sv: bool = True
    sv_max: float = 0.06
    mad: bool = True
    mad_column: str = "hws_mean_ms"
    mad_k: float = 3.0
    mad_window_h: float = 6.0
    mad_min_records: int = 5
    relative_sigma: bool = True
    relative_sigma_max: float = 0.70
    availability: bool = True
    availability_min_pct: float = 50.0
    imu_gap: bool = True
    imu_availability_min_pct: float = 80.0
    zero_std: bool = True
    heights_m: tuple[float, ...] | None = None
    std_pattern: bool = True
    std_pattern_k: float = 5.0
    std_pattern_min_factor: float = 3.0
    cnr: bool = True
    cnr_min_db: float = -23.0

    def __post_init__(self) -> None:
        if self.heights_m is not None:
            heights = tuple(float(h) for h in self.heights_m)
            if not heights or not all(np.isfinite(h) and h > 0 for h in heights):
                raise ValueError(
                    f"QCConfig.heights_m must be positive heights in m, got {self.heights_m!r}"
                )
            object.__setattr__(self, "heights_m", heights)
        positive = {
            "hws_max_ms": self.hws_max_ms,
            "sv_max": self.sv_max,
            "mad_k": self.mad_k,
            "mad_window_h": self.mad_window_h,
            "relative_sigma_max": self.relative_sigma_max,
            "std_pattern_k": self.std_pattern_k,
        }
        for name, value in positive.items():
            if not np.isfinite(value) or value <= 0:
                raise ValueError(f"QCConfig.{name} must be a positive number, got {value!r}")
        if not 0 <= self.ti_hws_min_ms < self.ti_hws_max_ms:
            raise ValueError(
                "QCConfig needs 0 <= ti_hws_min_ms < ti_hws_max_ms, got "
                f"{self.ti_hws_min_ms!r}, {self.ti_hws_max_ms!r}"
            )
        for name in ("availability_min_pct", "imu_availability_min_pct"):
            value = getattr(self, name)
            if not 0 <= value <= 100:
                raise ValueError(f"QCConfig.{name} must lie in [0, 100] %, got {value!r}")
        if not self.std_pattern_min_factor > 1:
            raise ValueError(
                f"QCConfig.std_pattern_min_factor must be > 1, got {self.std_pattern_min_factor!r}"
            )
        if int(self.mad_min_records) < 1:
            raise ValueError(f"QCConfig.mad_min_records must be >= 1, got {self.mad_min_records!r}")


@dataclass(frozen=True)
class QCResult:
    """Outcome of a QC run.

    Attributes
    ----------
    kept : pandas.DataFrame
        Input rows that passed every enabled filter (original index kept).
    flags : pandas.DataFrame
        One row per input row, same index and order as the input: ``row``
        (1-based), ``timestamp`` and ``height_m`` (when present), one boolean
        ``fail_<reason>`` column per reason, ``n_failed``, ``reasons``
        (semicolon-separated, empty if kept) and ``kept``.
    counts : pandas.DataFrame
        Indexed by reason: ``enabled``, ``applicable`` (needed columns present),
        ``threshold`` (text with units), ``n_failed`` (records failing it) and
        ``n_failed_only`` (failing it and nothing else).
    n_in, n_kept, n_flagged : int
        Record counts; ``n_in == n_kept + n_flagged``.
    """

    kept: pd.DataFrame
    flags: pd.DataFrame
    counts: pd.DataFrame
    n_in: int
    n_kept: int
    n_flagged: int

    def summary(self) -> str:
        """One line per reason plus the totals, for logs."""
        lines = [f"QC: n_in={self.n_in} n_kept={self.n_kept} n_flagged={self.n_flagged}"]
        for reason, row in self.counts.iterrows():
            state = "on" if row["enabled"] and row["applicable"] else "off"
            lines.append(
                f"  {reason:<20} {state:<3} {row['threshold']:<28} failed={row['n_failed']}"
                f" only={row['n_failed_only']}"
            )
        return "\n".join(lines)


def rolling_mad_outliers(
    values: np.ndarray,
    time_s: np.ndarray,
    groups: np.ndarray | None = None,
    *,
    window_s: float,
    k: float = 3.0,
    min_count: int = 5,
) -> np.ndarray:
    """Outliers about a rolling median, Malekmohammadi et al. (2024), Eq. (8).

    A value ``X`` is an outlier if ``|X - M| > k * MAD / 0.6745`` where ``M`` is
    the rolling median and ``MAD`` the rolling median of ``|X - M|``, both over a
    centred window of ``window_s`` (closed on both sides) within its group.

    Parameters
    ----------
    values : numpy.ndarray, shape (n,)
        Tested values (NaN values are ignored and never flagged).
    time_s : numpy.ndarray, shape (n,)
        Times, s (any origin); need not be sorted.
    groups : numpy.ndarray, shape (n,), optional
        Group labels (e.g. height); windows do not cross groups.
    window_s : float
        Window width, s.
    k : float
        Multiplier (3 in Malekmohammadi et al. (2024)).
    min_count : int
        Fewest finite values in a window for a verdict; otherwise not flagged.

    Returns
    -------
    numpy.ndarray of bool, shape (n,)
        True for outliers, in the input order.
    """
    values = np.asarray(values, dtype=np.float64)
    time_s = np.asarray(time_s, dtype=np.float64)
    n = values.size
    if time_s.shape != values.shape:
        raise ValueError(
            f"rolling_mad_outliers: time_s shape {time_s.shape} != values shape {values.shape}"
        )
    if groups is None:
        codes = np.zeros(n, dtype=np.int64)
    else:
        codes = pd.factorize(np.asarray(groups))[0]
    order = np.lexsort((time_s, codes))
    out_sorted = np.zeros(n, dtype=bool)
    bounds = np.flatnonzero(np.diff(codes[order])) + 1
    window = pd.Timedelta(seconds=float(window_s))
    for sl in np.split(np.arange(n), bounds):
        if sl.size == 0:
            continue
        idx = order[sl]
        s = pd.Series(values[idx], index=pd.to_datetime(time_s[idx], unit="s"))
        roll = s.rolling(window, center=True, min_periods=int(min_count), closed="both")
        med = roll.median()  # M of Malekmohammadi et al. (2024), Eq. (8)
        dev = (s - med).abs()
        mad = dev.rolling(window, center=True, min_periods=int(min_count), closed="both").median()
        with np.errstate(invalid="ignore"):
            flag = (
                dev.to_numpy() > k * mad.to_numpy() / MAD_SCALE
            )  # Eq. (8) of Malekmohammadi et al. (2024)
        out_sorted[sl] = flag
    out = np.empty(n, dtype=bool)
    out[order] = out_sorted
    return out


#: Fewest finite std-to-mean ratios for :func:`std_pattern_outliers` to judge (-).
STD_PATTERN_MIN_RECORDS = 10


def std_pattern_outliers(
    hws_mean_ms: np.ndarray,
    hws_std_ms: np.ndarray,
    *,
    k: float = 5.0,
    min_factor: float = 3.0,
) -> np.ndarray:
    """Records whose std breaks the pattern of its column: its ratio to the mean speed far
    outside the column's robust distribution.

    With ``x = log(hws_std_ms / hws_mean_ms)`` (the log TI), a record is flagged when
    ``|x - median(x)| > max(k * MAD / 0.6745, log(min_factor))`` over the column's finite
    values. The median and MAD stand up to nearly half the rows being wrong, e.g. TI in
    percent in the std column (``100 / hws_mean_ms`` times the true ratio, ~10 at 10 m/s);
    the factor floor keeps a column of nearly equal ratios (small MAD) from flagging the
    ordinary spread of TI with wind speed.

    Parameters
    ----------
    hws_mean_ms, hws_std_ms : numpy.ndarray, shape (n,)
        Mean and std of the HWS (m/s); NaN, zero or negative values are never flagged.
    k : float
        Multiplier of the scaled MAD, dimensionless.
    min_factor : float
        Smallest ratio to the median ratio (or its inverse) that is flagged (-, > 1).

    Returns
    -------
    numpy.ndarray of bool, shape (n,)
        True for the records that break the pattern; none when fewer than
        :data:`STD_PATTERN_MIN_RECORDS` ratios are finite.
    """
    mean = np.asarray(hws_mean_ms, dtype=np.float64)
    std = np.asarray(hws_std_ms, dtype=np.float64)
    with np.errstate(invalid="ignore", divide="ignore"):
        x = np.log(std / mean)
    ok = np.isfinite(x)
    out = np.zeros(x.shape, dtype=bool)
    if ok.sum() < STD_PATTERN_MIN_RECORDS:
        return out
    med = np.median(x[ok])
    mad = np.median(np.abs(x[ok] - med))
    out[ok] = np.abs(x[ok] - med) > max(k * mad / MAD_SCALE, np.log(min_factor))
    return out


def _threshold_texts(config: QCConfig) -> dict[str, str]:
    c = config
    return {
        "missing_wind": "hws_mean/std NaN",
        "hws_nonphysical": f"> {c.hws_max_ms:g} m/s",
        "hws_out_of_ti_range": f"outside [{c.ti_hws_min_ms:g}, {c.ti_hws_max_ms:g}] m/s",
        "sv_high": f"sv > {c.sv_max:g}",
        "mad_outlier": f"{c.mad_column}: {c.mad_k:g} MAD, {c.mad_window_h:g} h",
        "relative_sigma": f"ref/moving std - 1 > {c.relative_sigma_max:g}",
        "low_availability": f"< {c.availability_min_pct:g} %",
        "imu_gap": f"motion NaN or IMU < {c.imu_availability_min_pct:g} %",
        "zero_std": "hws_std or ref_hws_std = 0 m/s",
        "height_not_selected": (
            "all heights"
            if c.heights_m is None
            else "not in " + ", ".join(f"{h:g}" for h in c.heights_m) + " m"
        ),
        "std_pattern": (
            f"log(std/mean) beyond {c.std_pattern_k:g} MAD and x{c.std_pattern_min_factor:g} "
            "of its median"
        ),
        "cnr_low": f"CNR < {c.cnr_min_db:g} dB or NaN",
    }


def _col(df: pd.DataFrame, name: str) -> np.ndarray:
    return df[name].to_numpy(dtype=np.float64)


def _record_masks(records: pd.DataFrame, c: QCConfig) -> dict[str, tuple[bool, bool, np.ndarray]]:
    """Return reason -> (enabled, applicable, failed mask)."""
    n = len(records)
    none = np.zeros(n, dtype=bool)
    cols = records.columns
    out: dict[str, tuple[bool, bool, np.ndarray]] = {}
    hws = _col(records, "hws_mean_ms")
    std = _col(records, "hws_std_ms")
    with np.errstate(invalid="ignore", divide="ignore"):
        out["missing_wind"] = (c.missing_wind, True, np.isnan(hws) | np.isnan(std))
        out["hws_nonphysical"] = (c.hws_nonphysical, True, hws > c.hws_max_ms)
        out["hws_out_of_ti_range"] = (
            c.ti_range,
            True,
            (hws < c.ti_hws_min_ms) | (hws > c.ti_hws_max_ms),
        )
        has_sv = "sv" in cols
        out["sv_high"] = (c.sv, has_sv, _col(records, "sv") > c.sv_max if has_sv else none)
        has_mad = c.mad_column in cols
        if c.mad and has_mad:
            t_s = pd.DatetimeIndex(records["timestamp"]).as_unit("ns").asi8 * 1e-9
            groups = records["height_m"].to_numpy() if "height_m" in cols else None
            mad = rolling_mad_outliers(
                _col(records, c.mad_column),
                t_s,
                groups,
                window_s=c.mad_window_h * 3600.0,
                k=c.mad_k,
                min_count=c.mad_min_records,
            )
        else:
            mad = none
        out["mad_outlier"] = (c.mad, has_mad, mad)
        has_ref = "ref_hws_std_ms" in cols
        if has_ref:
            rel = (
                _col(records, "ref_hws_std_ms") / std - 1.0
            )  # Eq. (9) of Malekmohammadi et al. (2024)
            rel_fail = rel > c.relative_sigma_max
        else:
            rel_fail = none
        out["relative_sigma"] = (c.relative_sigma, has_ref, rel_fail)
        out["low_availability"] = (
            c.availability,
            True,
            _col(records, "availability_pct") < c.availability_min_pct,
        )
        motion = [m for m in _MOTION if m in cols]
        imu = np.isnan(records[motion].to_numpy(dtype=np.float64)).any(axis=1) if motion else none
        if "imu_availability_pct" in cols:
            imu = imu | (_col(records, "imu_availability_pct") < c.imu_availability_min_pct)
        out["imu_gap"] = (c.imu_gap, bool(motion) or "imu_availability_pct" in cols, imu)
        zero = std == 0
        if "ref_hws_std_ms" in cols:
            zero = zero | (_col(records, "ref_hws_std_ms") == 0)
        out["zero_std"] = (c.zero_std, True, zero)
        if c.heights_m is None:
            other = none
        else:
            h = _col(records, "height_m")
            other = ~np.isclose(h[:, None], np.asarray(c.heights_m)[None, :], atol=1e-6).any(axis=1)
        out["height_not_selected"] = (True, c.heights_m is not None, other)
        pattern = std_pattern_outliers(
            hws, std, k=c.std_pattern_k, min_factor=c.std_pattern_min_factor
        )
        out["std_pattern"] = (c.std_pattern, True, pattern)
    return out


def _assemble(
    table: pd.DataFrame, masks: dict[str, tuple[bool, bool, np.ndarray]], config: QCConfig
) -> QCResult:
    n = len(table)
    reasons = list(masks)
    active = np.zeros((n, len(reasons)), dtype=bool)
    rows = []
    thresholds = _threshold_texts(config)
    for j, r in enumerate(reasons):
        enabled, applicable, mask = masks[r]
        if enabled and applicable:
            active[:, j] = mask
    n_failed = active.sum(axis=1)
    for j, r in enumerate(reasons):
        enabled, applicable, _ = masks[r]
        rows.append(
            {
                "reason": r,
                "enabled": enabled,
                "applicable": applicable,
                "threshold": thresholds[r],
                "n_failed": int(active[:, j].sum()),
                "n_failed_only": int((active[:, j] & (n_failed == 1)).sum()),
            }
        )
    counts = pd.DataFrame(rows).set_index("reason")
    # reason strings through the few distinct bit patterns (no per-row Python loop)
    bits = active.astype(np.int64) @ (1 << np.arange(len(reasons), dtype=np.int64))
    uniq, inverse = np.unique(bits, return_inverse=True)
    labels = [";".join(r for j, r in enumerate(reasons) if b >> j & 1) for b in uniq]
    kept_mask = n_failed == 0
    flags = pd.DataFrame(index=table.index)
    flags["row"] = np.arange(1, n + 1)
    for key in ("timestamp", "height_m"):
        if key in table.columns:
            flags[key] = table[key].array
    for j, r in enumerate(reasons):
        flags[f"fail_{r}"] = active[:, j]
    flags["n_failed"] = n_failed
    flags["reasons"] = pd.Categorical.from_codes(inverse.ravel(), categories=labels)
    flags["kept"] = kept_mask
    kept = table.loc[kept_mask]
    n_kept = int(kept_mask.sum())
    n_flagged = int((~kept_mask).sum())
    if n_kept + n_flagged != n or len(flags) != n:  # conservation of counts
        raise RuntimeError(f"QC lost records: n_in={n}, n_kept={n_kept}, n_flagged={n_flagged}")
    return QCResult(kept, flags, counts, n, n_kept, n_flagged)


def run_qc(records: pd.DataFrame, config: QCConfig | None = None) -> QCResult:
    """Apply the record-level QC filters.

    Parameters
    ----------
    records : pandas.DataFrame
        Validated record table (:func:`flidar_uq.data.io.validate_records`); needs at
        least ``timestamp``, ``height_m``, ``hws_mean_ms``, ``hws_std_ms`` and
        ``availability_pct``.  Optional columns enable further filters.
    config : QCConfig, optional
        Switches and thresholds; defaults follow Gutiérrez-Antuñano et al. (2018) and Malekmohammadi et al. (2024).

    Returns
    -------
    QCResult
        Kept records, the flags table (every input record) and per-filter counts.

    Raises
    ------
    ValueError
        If a needed column is missing.
    """
    config = QCConfig() if config is None else config
    needed = ["timestamp", "height_m", "hws_mean_ms", "hws_std_ms", "availability_pct"]
    missing = [c for c in needed if c not in records.columns]
    if missing:
        raise ValueError(f"run_qc: record table lacks column(s) {missing}")
    return _assemble(records, _record_masks(records, config), config)


def run_los_qc(los: pd.DataFrame, config: QCConfig | None = None) -> QCResult:
    """Apply the LOS-level CNR filter (Malekmohammadi et al., 2024, Sec. 4.2).

    Parameters
    ----------
    los : pandas.DataFrame
        Validated LOS table (:func:`flidar_uq.data.io.validate_los_series`), with ``cnr_db``.
    config : QCConfig, optional
        Uses ``cnr`` and ``cnr_min_db`` (dB).

    Returns
    -------
    QCResult
        As :func:`run_qc`, with the single reason ``cnr_low`` (CNR below the
        threshold, or missing).
    """
    config = QCConfig() if config is None else config
    if "cnr_db" not in los.columns:
        raise ValueError("run_los_qc: LOS table lacks column 'cnr_db'")
    cnr = _col(los, "cnr_db")
    with np.errstate(invalid="ignore"):
        fail = ~(cnr >= config.cnr_min_db)  # NaN CNR fails too
    return _assemble(los, {"cnr_low": (config.cnr, True, fail)}, config)


def summarise(flags: pd.DataFrame) -> pd.DataFrame:
    """Per-reason counts of a flags table (``QCResult.flags``).

    Returns
    -------
    pandas.DataFrame
        Rows per reason plus ``all`` (records flagged for any reason) and
        ``kept``: columns ``reason``, ``n_failed``, ``n_failed_only``; the
        ``n_failed`` of ``all`` and ``kept`` add up to the number of records.
    """
    fail = [c for c in flags.columns if c.startswith("fail_")]
    a = flags[fail].to_numpy(dtype=bool)
    n_failed = a.sum(axis=1)
    rows = [
        {
            "reason": c.removeprefix("fail_"),
            "n_failed": int(a[:, j].sum()),
            "n_failed_only": int((a[:, j] & (n_failed == 1)).sum()),
        }
        for j, c in enumerate(fail)
    ]
    rows.append({"reason": "all", "n_failed": int((n_failed > 0).sum()), "n_failed_only": 0})
    rows.append({"reason": "kept", "n_failed": int((n_failed == 0).sum()), "n_failed_only": 0})
    return pd.DataFrame(rows)


def speed_bin_summary(
    records: pd.DataFrame, flags: pd.DataFrame, *, hws_width_ms: float = 1.0
) -> pd.DataFrame:
    """What each filter removed per height and mean-speed bin.

    Parameters
    ----------
    records : pandas.DataFrame
        The QC input (``height_m``, ``hws_mean_ms`` in m/s), in the order of ``flags``.
    flags : pandas.DataFrame
        ``QCResult.flags`` (one ``fail_<reason>`` column per filter and ``kept``).
    hws_width_ms : float
        Bin width, m/s; bins centred on integer multiples of it (``hws_bin_ms``, NaN for
        records without a mean speed).

    Returns
    -------
    pandas.DataFrame
        One row per height and bin: ``height_m``, ``hws_bin_ms``, ``n_in``, ``n_kept``
        and, per filter, ``<reason>`` = the records of the bin failing it (a record can
        fail several).
    """
    hws = records["hws_mean_ms"].to_numpy(dtype=float)
    table = pd.DataFrame(
        {
            "height_m": records["height_m"].to_numpy(dtype=float),
            "hws_bin_ms": np.round(hws / hws_width_ms) * hws_width_ms,
            "n_in": 1,
            "n_kept": flags["kept"].to_numpy(dtype=int),
        }
    )
    fail = [c for c in flags.columns if c.startswith("fail_")]
    for c in fail:
        table[c.removeprefix("fail_")] = flags[c].to_numpy(dtype=int)
    out = table.groupby(["height_m", "hws_bin_ms"], dropna=False, sort=True).sum()
    return out.reset_index()
