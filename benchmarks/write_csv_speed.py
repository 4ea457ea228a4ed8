"""Benchmark: the result-table writers, pandas' ``DataFrame.to_csv`` against
:func:`flidar_uq.workflow.files.write_csv` and the record writer of :mod:`flidar_uq.data.io`
(both on :mod:`flidar_uq.data.csv_text`), side by side in one run (issue 13 item 2).

The tables: the largest CSV files of a pipeline run (``--results``, e.g. a year's
``results/``), read back as the steps hold them (``read_records`` for the record tables,
so the time stamp is a UTC datetime column; ``bin_label`` categorical, as the bins step
holds it), written both ways with the pipeline's settings (``%.10g`` and ``%.17g``; no
float format, the shortest text of each float, for the validated record table that
``validate`` writes through ``data.io``). Per table and format: CPU seconds of each, their ratio,
and whether the bytes are identical. Writes ``benchmarks/results/write_csv_speed.csv`` and
``.png``.

Usage: ``python benchmarks/write_csv_speed.py --results <run>/results``
"""

from __future__ import annotations

import argparse
import filecmp
import tempfile
import time
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import pandas as pd  # noqa: E402

from flidar_uq.data.io import _ISO_FORMAT_US, _write, read_records  # noqa: E402
from flidar_uq.workflow.files import read_csv, write_csv  # noqa: E402

REPO = Path(__file__).resolve().parents[1]
OUT = REPO / "benchmarks" / "results" / "write_csv_speed"
TABLES = ("data/records.csv", "qc/kept.csv", "bins/assignments.csv", "ti/records.csv")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--results", type=Path, required=True)
    args = ap.parse_args()
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        old_path, new_path = Path(tmp) / "pandas.csv", Path(tmp) / "ours.csv"
        for name in TABLES:
            path = args.results / name
            df = read_records(path) if name == "data/records.csv" else read_csv(path)
            if "bin_label" in df:
                df["bin_label"] = df["bin_label"].astype("category")
            for fmt in ("%.10g", "%.17g", None):
                if fmt is None and name != "data/records.csv":
                    continue
                t0 = time.process_time()
                df.to_csv(
                    old_path,
                    index=False,
                    float_format=fmt,
                    lineterminator="\n",
                    date_format="%Y-%m-%dT%H:%M:%SZ" if fmt else _ISO_FORMAT_US,
                )
                t_old = time.process_time() - t0
                t0 = time.process_time()
                if fmt is None:
                    _write(df, new_path, _ISO_FORMAT_US)
                else:
                    write_csv(df, new_path, float_format=fmt)
                t_new = time.process_time() - t0
                fmt = fmt or "shortest"
                rows.append(
                    {
                        "table": name,
                        "rows": len(df),
                        "columns": df.shape[1],
                        "float_format": fmt,
                        "pandas_cpu_s": t_old,
                        "write_csv_cpu_s": t_new,
                        "ratio": t_old / t_new,
                        "identical_bytes": filecmp.cmp(old_path, new_path, shallow=False),
                    }
                )
                print(
                    f"{name} ({len(df):,} x {df.shape[1]}, {fmt}): pandas {t_old:.2f} s, "
                    f"write_csv {t_new:.2f} s, ratio {t_old / t_new:.2f}, identical "
                    f"{rows[-1]['identical_bytes']}"
                )
    table = pd.DataFrame(rows)
    OUT.parent.mkdir(parents=True, exist_ok=True)
    table.to_csv(OUT.with_suffix(".csv"), index=False, float_format="%.4g")
    fig, ax = plt.subplots(figsize=(7, 3.6))
    labels = [f"{t}\n{f}" for t, f in zip(table.table, table.float_format, strict=True)]
    x = range(len(table))
    ax.bar([i - 0.2 for i in x], table.pandas_cpu_s, 0.4, label="DataFrame.to_csv")
    ax.bar([i + 0.2 for i in x], table.write_csv_cpu_s, 0.4, label="write_csv (same bytes)")
    ax.set_xticks(list(x), labels, fontsize=6)
    ax.set_ylabel("CPU s per table")
    ax.set_title(f"writing a year's tables ({table.rows.max():,} rows)")
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(OUT.with_suffix(".png"), dpi=110)


if __name__ == "__main__":
    main()
