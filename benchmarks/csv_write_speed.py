"""Benchmark: writing a result table the old way (pandas, per-value ``"%.10g"`` float text)
and as it is now (:func:`flidar_uq.data.io.write_csv`, Arrow's CSV writer, every float's
shortest exact text), side by side in one run (docs/performance.md).

The table: a pipeline run's QC-kept record table (``--table``, e.g. a year's
``results/qc/kept.csv``: ~150,000 rows, ~100 float columns) or, without it, a synthetic one
of the same shape (100 float columns of mixed magnitudes, an integer id, a UTC stamp and a
text column). Rows: the first 1 %, 10 %, 35 % and all of it. Per size and writer: the best
of ``--repeats`` wall times, the file size, and a check that the new file reads back bit
for bit (the old one keeps 10 digits: its largest relative error is reported). Writes
``benchmarks/results/csv_write_speed.csv`` and ``.png`` and prints the ratios.

Usage: ``python benchmarks/csv_write_speed.py [--table <run>/results/qc/kept.csv]``
"""

from __future__ import annotations

import argparse
import tempfile
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pandas as pd  # noqa: E402
from _timing import best_time  # noqa: E402

from flidar_uq.data.io import write_csv  # noqa: E402

REPO = Path(__file__).resolve().parents[1]
OUT = REPO / "benchmarks" / "results" / "csv_write_speed"


def _old_write(df: pd.DataFrame, path: Path) -> None:
    """The earlier writer: pandas with a ``"%.10g"`` float format."""
    df.to_csv(path, index=False, float_format="%.10g", lineterminator="\n",
              date_format="%Y-%m-%dT%H:%M:%SZ")  # fmt: skip


def _synthetic(n_rows: int, seed: int = 11) -> pd.DataFrame:
    rng = np.random.default_rng(seed)
    cols = {"record_id": np.arange(n_rows),
            "timestamp": pd.date_range("2020-01-01", periods=n_rows, freq="10min", tz="UTC")}  # fmt: skip
    for j in range(100):
        cols[f"x{j:03d}"] = rng.standard_normal(n_rows) * 10.0 ** rng.integers(-3, 4)
    cols["reasons"] = np.where(rng.random(n_rows) < 0.05, "low availability", "")
    return pd.DataFrame(cols)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--table", type=Path, default=None)
    ap.add_argument("--rows", type=int, default=150_000, help="synthetic table's rows")
    ap.add_argument("--repeats", type=int, default=2)
    args = ap.parse_args()
    full = pd.read_csv(args.table) if args.table else _synthetic(args.rows)
    if "timestamp" in full:
        full["timestamp"] = pd.to_datetime(full["timestamp"], utc=True)
    # the run's own path (results/<step>/<table>.csv), not the machine's
    source = "/".join(args.table.parts[-3:]) if args.table else "synthetic"
    floats = full.select_dtypes("float64").columns
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        old_p, new_p = Path(tmp) / "old.csv", Path(tmp) / "new.csv"
        for share in (0.01, 0.10, 0.35, 1.0):
            df = full.iloc[: max(1, int(round(share * len(full))))]
            t_old = best_time(lambda df=df: _old_write(df, old_p), repeats=args.repeats)[0]
            t_new = best_time(lambda df=df: write_csv(df, new_p), repeats=args.repeats)[0]
            back_new = pd.read_csv(new_p)[floats].to_numpy()
            back_old = pd.read_csv(old_p)[floats].to_numpy()
            x = df[floats].to_numpy()
            exact = bool(np.array_equal(back_new, x, equal_nan=True))
            with np.errstate(divide="ignore", invalid="ignore"):
                rel = np.abs(back_old - x) / np.abs(x)
            rows.append({
                "source": source, "rows": len(df), "columns": df.shape[1],
                "old_s": t_old, "new_s": t_new, "speedup": t_old / t_new,
                "old_mb": old_p.stat().st_size / 1e6, "new_mb": new_p.stat().st_size / 1e6,
                "new_exact": exact, "old_max_rel_error": float(np.nanmax(rel[np.isfinite(rel)])),
            })  # fmt: skip
            r = rows[-1]
            print(f"{r['rows']:>7} rows: old {r['old_s']:.2f} s, new {r['new_s']:.2f} s "
                  f"({r['speedup']:.1f}x); {r['old_mb']:.0f} vs {r['new_mb']:.0f} MB; "
                  f"new exact {exact}, old max rel error {r['old_max_rel_error']:.1e}")  # fmt: skip
    tab = pd.DataFrame(rows)
    OUT.parent.mkdir(parents=True, exist_ok=True)
    tab.to_csv(OUT.with_suffix(".csv"), index=False, float_format="%.6g")
    fig, ax = plt.subplots(1, 2, figsize=(10, 4))
    ax[0].loglog(tab["rows"], tab["old_s"], "o-", label='pandas, "%.10g" (old)')
    ax[0].loglog(tab["rows"], tab["new_s"], "s-", label="Arrow, exact floats (now)")
    ax[0].set(xlabel="rows", ylabel="write time (s)", title=f"{tab['columns'].iloc[-1]} columns")
    ax[0].legend()
    ax[1].semilogx(tab["rows"], tab["speedup"], "o-")
    ax[1].set(xlabel="rows", ylabel="speed-up (old / new)", ylim=(0, None))
    fig.suptitle(f"Result-table CSV writer ({source})")
    fig.tight_layout()
    fig.savefig(OUT.with_suffix(".png"), dpi=110)


if __name__ == "__main__":
    main()
