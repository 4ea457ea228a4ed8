"""What the pipeline will find in a validated record table, before any expensive step.

The columns present and absent, the time span, the record spacing and the sampling gaps per
height (:func:`sampling_gaps`), the share of records with a reference mean and std, the
QC preview (:func:`flidar_uq.data.qc.run_qc`) and the records per motion description;
warnings on what would leave groups of records uncorrectable, and what leaves every record
uncorrectable (:func:`reference_problems`: a reference mean without a reference std).
The command line (``flidar-uq validate``) prints the result, the ``validate`` rule writes
it as JSON.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np
import pandas as pd

from flidar_uq.data.io import DataValidationError
from flidar_uq.data.qc import QCConfig, run_qc
from flidar_uq.data.schema import RECORD_COLUMNS, TRUTH_PREFIX

__all__ = ["inspect_records", "reference_problems", "sampling_gaps"]

#: Share of records one QC filter may flag before :func:`inspect_records` warns.
_QC_WARN_SHARE = 0.5
#: Fewest records with a reference std for rho to be learnt without a warning.
_MIN_REFERENCE_RECORDS = 10
#: Nominal record length (s).
_RECORD_S = 600.0


def reference_problems(records: pd.DataFrame, source: str) -> list:
    """What makes every record uncorrectable: a reference mean without a reference std.

    rho (and with it every corrected value) is learnt only from records with
    ``ref_hws_std_ms``; a file with the reference's mean speed but no std would run to the
    end with rho at its prior, the reference calibrating nothing.

    Parameters
    ----------
    records : pandas.DataFrame
        Validated records, with ``ref_hws_mean_ms`` and ``ref_hws_std_ms`` (m/s) if any.
    source : str
        File name for the messages.

    Returns
    -------
    list of flidar_uq.data.io.DataValidationError
        Empty when fine (the pipeline raises the first one, the command line warns).
    """
    if "ref_hws_mean_ms" not in records:
        return []
    mean = records["ref_hws_mean_ms"].to_numpy(dtype=float)
    std = (
        records["ref_hws_std_ms"].to_numpy(dtype=float)
        if "ref_hws_std_ms" in records
        else np.full(len(records), np.nan)
    )
    if np.isfinite(mean).any() and not np.isfinite(std).any():
        what = "has no value" if "ref_hws_std_ms" in records else "is missing"
        return [
            DataValidationError(
                source,
                None,
                "ref_hws_std_ms",
                f"the reference mean ref_hws_mean_ms is given but its std {what}: rho is "
                "learnt only from the reference std, so the reference would calibrate nothing "
                "(rho at its prior, wide intervals); add (or map, campaign.columns) the "
                "reference std column, "
                "or drop the mean (campaign.columns: {<its name>: null})",
            )
        ]
    return []


def sampling_gaps(records: pd.DataFrame) -> tuple[float, list[dict]]:
    """Median record spacing and the sampling gaps per height.

    A gap is a spacing of more than 1.5 times the median spacing of all heights; the
    records it misses are ``round(spacing / median) - 1``.

    Parameters
    ----------
    records : pandas.DataFrame
        Records with ``timestamp`` and ``height_m`` (m).

    Returns
    -------
    interval_s : float
        Median spacing of consecutive records at one height, s (NaN: no spacing).
    per_height : list of dict
        Per height, ascending: ``height_m`` (m), ``n_records``, ``n_gaps``,
        ``missing_records`` and ``largest_gap_h`` (the largest spacing, h, 3 decimals).
    """
    out = []
    spacings = []
    for h, grp in records.groupby("height_m", sort=True):
        t = pd.DatetimeIndex(grp["timestamp"]).as_unit("ns").asi8 * 1e-9
        dt = np.diff(np.sort(t))
        spacings.append(dt)
        out.append({"height_m": float(h), "n_records": len(grp), "dt": dt})
    alldt = np.concatenate(spacings) if spacings else np.array([])
    step = float(np.median(alldt)) if alldt.size else float("nan")
    per_height = []
    for row in out:
        dt = row.pop("dt")
        gap = dt > 1.5 * step if np.isfinite(step) else np.zeros(dt.shape, bool)
        missing = int(np.sum(np.round(dt[gap] / step) - 1)) if gap.any() else 0
        row.update(
            n_gaps=int(gap.sum()),
            missing_records=missing,
            largest_gap_h=round(float(dt.max()) / 3600.0, 3) if dt.size else 0.0,
        )
        per_height.append(row)
    return step, per_height


def inspect_records(
    records: pd.DataFrame,
    motion_description: pd.Series,
    *,
    descriptions: Sequence[str],
    source: str = "<DataFrame>",
    qc_params: Mapping | None = None,
    heights: list[float] | None = None,
    columns: Mapping | None = None,
) -> dict:
    """What the pipeline will find in a validated record table, and warnings.

    Parameters
    ----------
    records : pandas.DataFrame
        A validated record table (:func:`flidar_uq.data.io.validate_records`).
    motion_description : pandas.Series
        Per record, the motion description the record model will use (``"none"``: no
        complete description; :func:`flidar_uq.inference.record_motion.per_record_motion`).
    descriptions : sequence of str
        Every motion description, in the order of the report
        (:data:`flidar_uq.inference.record_motion.MOTION_DESCRIPTIONS`).
    source : str
        File name for the messages.
    qc_params : mapping, optional
        The config's ``qc`` section (default: the QC defaults).
    heights : list of float, optional
        The selected heights, m (config ``campaign.heights``).
    columns : mapping, optional
        The column map used to read the file (reported).

    Returns
    -------
    dict
        ``n_records``, ``heights_m`` (m); ``columns`` (``present``, ``absent_optional``,
        ``truth``, ``renamed``); ``time_span`` (``start``, ``end`` ISO 8601 UTC, ``days``);
        ``sampling`` (``interval_s`` in s, per height ``n_records``, ``n_gaps``,
        ``missing_records``, ``largest_gap_h`` in h: :func:`sampling_gaps`); ``reference``
        (shares of records with a reference mean and std, 0-1); ``motion_description``
        (records per description); ``qc_preview`` (``n_kept``, ``n_flagged`` and per
        filter the records it flags, :func:`flidar_uq.data.qc.run_qc`); ``warnings`` (one
        line each) and ``blocking`` (what the pipeline refuses, one line each:
        :func:`reference_problems`).
    """
    n = len(records)
    names = [c.name for c in RECORD_COLUMNS]
    present = [c for c in names if c in records]
    truth = [c for c in records if str(c).startswith(TRUTH_PREFIX)]
    absent = [c.name for c in RECORD_COLUMNS if not c.required and c.name not in records]
    t = pd.DatetimeIndex(records["timestamp"])
    step, per_height = sampling_gaps(records)
    share = {}
    for c in ("ref_hws_mean_ms", "ref_hws_std_ms"):
        share[c] = (
            float(np.isfinite(records[c].to_numpy(dtype=float)).mean()) if c in records else 0.0
        )
    config = QCConfig(**dict(qc_params or {}), heights_m=tuple(heights) if heights else None)
    res = run_qc(records, config)
    by_filter = {
        r: int(row["n_failed"])
        for r, row in res.counts.iterrows()
        if row["enabled"] and row["applicable"]
    }
    kinds = motion_description
    counts = {k: int((kinds == k).sum()) for k in descriptions}

    warnings: list[str] = []
    blocking = [str(e) for e in reference_problems(records, source)]
    if share["ref_hws_std_ms"] == 0.0 and not blocking:
        warnings.append(
            "no reference std (ref_hws_std_ms): rho cannot be learnt, its posterior is the "
            "prior and the corrected TI's intervals are wide"
        )
    elif 0 < share["ref_hws_std_ms"] * n < _MIN_REFERENCE_RECORDS:
        warnings.append(
            f"only {round(share['ref_hws_std_ms'] * n)} records with a reference std: rho "
            "is learnt from few records, the intervals will be wide"
        )
    kept = res.flags["kept"].to_numpy()
    none_kept = int(((kinds == "none").to_numpy() & kept).sum())
    if none_kept:
        warnings.append(
            f"{none_kept} of {int(kept.sum())} QC-kept records have neither the along-wind "
            "tilt columns nor complete roll/pitch statistics: they will be flagged "
            "no_motion_description (no corrected TI)"
        )
    for h_row in per_height:
        h = h_row["height_m"]
        at = np.isclose(records["height_m"].to_numpy(dtype=float), h)
        if kept[at].sum() == 0 and (heights is None or np.isclose(heights, h).any()):
            reasons = res.flags.loc[at, "reasons"].astype(str).str.split(";").explode()
            top = reasons.value_counts().index[0] if len(reasons) else "?"
            warnings.append(
                f"QC keeps no record at {h:g} m (most frequent reason: {top}): nothing "
                "is corrected at this height"
            )
    for reason, k in by_filter.items():
        if reason != "height_not_selected" and n and k / n > _QC_WARN_SHARE:
            thr = res.counts.loc[reason, "threshold"]
            warnings.append(
                f"QC filter {reason} ({thr}) flags {k} of {n} records ({100 * k / n:.0f} %): "
                "check the units of the column it tests or the threshold in the config's qc section"
            )
    if np.isfinite(step) and abs(step - _RECORD_S) > 1.0:
        warnings.append(
            f"the median spacing of the records at one height is {step:g} s, expected "
            f"{_RECORD_S:g} s (10-min records): the statistics must be over 10 minutes"
        )
    rename = {}
    for name, target in (columns or {}).items():
        rename[name] = target
    return {
        "n_records": n,
        "heights_m": sorted(float(h) for h in records["height_m"].unique()),
        "columns": {
            "present": present,
            "absent_optional": absent,
            "truth": truth,
            "renamed": rename,
        },
        "time_span": {
            "start": t.min().isoformat() if n else None,
            "end": t.max().isoformat() if n else None,
            "days": round((t.max() - t.min()).total_seconds() / 86400.0, 3) if n else 0.0,
        },
        "sampling": {"interval_s": step, "per_height": per_height},
        "reference": {
            "share_with_mean": round(share["ref_hws_mean_ms"], 4),
            "share_with_std": round(share["ref_hws_std_ms"], 4),
        },
        "motion_description": counts,
        "qc_preview": {
            "n_kept": int(res.n_kept),
            "n_flagged": int(res.n_flagged),
            "by_filter": by_filter,
        },
        "warnings": warnings,
        "blocking": blocking,
    }
