"""The report section of the raw input series: the IMU series (statistics derived by the DAG,
the series winning over the table's motion columns, gaps) and the LOS branch beside the
Bayesian corrected TI. Rendered from ``templates/series_section.html.j2``."""

from __future__ import annotations

import os

import pandas as pd
from markupsafe import Markup

from flidar_uq.workflow import report as rep
from flidar_uq.workflow.files import read_csv

__all__ = ["series_context", "series_sections"]

#: Rows of the record-by-record LOS table shown in the report (the file has them all).
MAX_ROWS = 40


def series_context(
    *,
    imu_summary: str | os.PathLike | None = None,
    imu_gaps: str | os.PathLike | None = None,
    los_records: str | os.PathLike | None = None,
    los_agreement: str | os.PathLike | None = None,
    los_figure: str | os.PathLike | None = None,
) -> dict:
    """Context of ``series_section.html.j2`` from the result files (``None``: part absent).

    Parameters
    ----------
    imu_summary, imu_gaps : path, optional
        results/imu/summary.csv and gaps.csv (rule imu_statistics).
    los_records, los_agreement, los_figure : path, optional
        results/los/records.csv, agreement.csv and agreement.png (rule los_agreement).

    Returns
    -------
    dict
        ``imu`` and ``los`` (each a dict, or None); HTML parts are ``Markup``.
    """
    imu = los = None
    if imu_summary:
        s = read_csv(imu_summary).set_index("key")["value"]
        gaps = read_csv(imu_gaps) if imu_gaps else pd.DataFrame()
        longest = float(s["longest_gap_inside_s"])
        imu = {
            # an absolute path as its file name: the report names no directory of the machine
            "path": os.path.basename(p) if os.path.isabs(p := str(s["imu_series"])) else p,
            "rows": s["rows"],
            "rate_hz": f"{float(s['rate_hz']):.4g}",
            "first": s["first_sample"],
            "last": s["last_sample"],
            "overridden": int(s["record_rows_overridden"]),
            "table_columns": s["record_table_motion_columns"],
            "gaps": s["gaps"],
            "missing": s["missing_samples_inside"],
            "longest": f"{longest:.3g}",
            "below": s["record_rows_below_coverage"],
            "records": s["record_rows"],
            "without": s["record_rows_without_samples"],
            "gaps_table": Markup(
                rep.table_html(
                    gaps.head(MAX_ROWS),
                    caption=f"IMU gaps of at least 1 s (first {MAX_ROWS} of {len(gaps)}; "
                    "results/imu/gaps.csv)",
                )
            )
            if len(gaps)
            else "",
        }
    if los_agreement:
        agreement = read_csv(los_agreement)
        records = read_csv(los_records)
        methods = [m for m in agreement["method"] if m != "bayesian"]
        cols = ["timestamp", "height_m", "ti_corrected_median", "ti_corrected_lo"]
        cols += ["ti_corrected_hi", *[f"ti_los_{m}_target" for m in methods], "los_flags"]
        cols += [c for c in ("translation", "ti_true") if c in records]
        # the measured translation each record row's head velocity took, as counts
        kinds = records["translation"].value_counts() if "translation" in records else {}
        with open(los_figure, "rb") as fh:
            png = fh.read()
        los = {
            "methods": ", ".join(methods),
            "n": int(agreement["n_records"].max()),
            "n_flagged": int(records["los_flags"].notna().sum()),  # "" is read as NaN
            "translation": ", ".join(f"{k} in {v}" for k, v in kinds.items()),
            "agreement_table": Markup(
                rep.table_html(
                    agreement,
                    caption="agreement of the LOS-level and the Bayesian corrected TI "
                    "(results/los/agreement.csv)",
                )
            ),
            "figure": Markup(
                rep.img_html(
                    rep.png_bytes_to_data_uri(png),
                    "LOS-level corrected TI against the Bayesian median and interval",
                )
            ),
            "records_table": Markup(
                rep.table_html(
                    records[cols].head(MAX_ROWS),
                    caption=f"record by record, first {MAX_ROWS} of {len(records)} "
                    "(results/los/records.csv)",
                )
            ),
        }
    return {"imu": imu, "los": los}


def series_sections(**paths) -> list[rep.Section]:
    """The report section of the series (empty list when neither is given); keyword
    arguments as :func:`series_context`."""
    ctx = series_context(**paths)
    if ctx["imu"] is None and ctx["los"] is None:
        return []
    title = " and ".join(
        t for t, part in (("Raw IMU series", "imu"), ("LOS-level correction", "los")) if ctx[part]
    )
    body = rep.templates().get_template("series_section.html.j2").render(**ctx)
    return [rep.Section(title, body)]
