"""Raw IMU series as a pipeline input: peak memory and time of the per-record statistics.

A year of attitude at 20 Hz is 6.3e8 samples. ``flidar_uq.data.imu_series.
series_motion_statistics`` reads the file in chunks (the pipeline's rule imu_statistics); the
in-memory alternative reads the whole series (``io.read_imu_series``) and computes the same
statistics at once (``imu.motion_statistics``, ``imu.tilt_spectrum_statistics_by_height``).
Both run here side by side on synthetic 20-Hz series (roll, pitch and yaw: two swell/wind-sea
tones, noise, a 2-min gap per day) of growing length, Parquet and CSV, with a record table of
three heights per 10-min window (the default campaign's). Each measurement runs in a fresh
process, which reports its peak resident memory (``VmHWM``) and wall time.

Target: a year at 20 Hz processed in memory bounded by the chunk (default
2.5e5 rows), not by the series; time is reported per month of data; the 365-day case is the
year itself. Measured (2 cores, shared): the year in 1,021 s (84 s per month) at 800 MB peak,
against 352 MB for one day and 397 MB for 30 days: the series is never held; most likely (not
profiled) the growth is the per-record statistics (157,680 record rows at a year), kept
until the end and gathered as small tables run by run.

Writes benchmarks/results/imu_series_throughput.csv and .png; prints the table and the
ratios. Runtime: ~50 min on one core (series files of up to 365 days, ~20 GB on disk in a
temporary directory, removed afterwards).
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import pandas as pd

OUT = Path(__file__).parent / "results"
FS_HZ = 20.0
HEIGHTS_M = (27.0, 58.0, 85.0)
T0 = pd.Timestamp("2015-04-01T00:00:00Z")
# (format, days, method, allocator): streaming for every length; in memory up to a week (it
# grows with the series). "mmap128k" runs the same with glibc's mmap threshold fixed at
# 128 kB (MALLOC_MMAP_THRESHOLD_): the slow creep of the streamed RSS with length is heap
# fragmentation (glibc raises its threshold after large frees), not data kept, and it goes
# with the fixed threshold.
CASES = [
    ("parquet", 1, "streamed", "default"),
    ("parquet", 1, "in_memory", "default"),
    ("parquet", 7, "streamed", "default"),
    ("parquet", 7, "in_memory", "default"),
    ("parquet", 30, "streamed", "default"),
    ("parquet", 30, "streamed", "mmap128k"),
    ("csv", 1, "streamed", "default"),
    ("csv", 1, "in_memory", "default"),
    ("csv", 7, "streamed", "default"),
    ("parquet", 365, "streamed", "default"),  # the year last (the table is written per case)
]


def write_series(path: Path, days: int, seed: int = 1) -> None:
    """A synthetic 20-Hz IMU series written one day at a time (bounded memory)."""
    import pyarrow as pa
    import pyarrow.csv as pcsv
    import pyarrow.parquet as pq

    rng = np.random.default_rng(seed)
    n_day = int(86400 * FS_HZ)
    writer = None
    try:
        for d in range(days):
            t = d * 86400.0 + np.arange(n_day) / FS_HZ
            keep = ~((t % 86400.0 >= 3600.0) & (t % 86400.0 < 3720.0))  # a 2-min gap per day
            t = t[keep]
            a1, a2 = 2.0 + rng.random(), 1.0 + rng.random()
            roll = a1 * np.sin(2 * np.pi * t / 4.2) + a2 * np.sin(2 * np.pi * t / 9.0 + 1.0)
            pitch = a1 * np.sin(2 * np.pi * t / 4.5 + 0.5) + 0.5 * a2 * np.sin(2 * np.pi * t / 9.0)
            yaw = 20.0 * np.sin(2 * np.pi * t / 3600.0)
            noise = 0.05 * rng.standard_normal((3, t.size))
            ts = T0.value // 1000 + np.round(t * 1e6).astype(np.int64)
            table = pa.table(
                {
                    "timestamp": pa.array(ts, type=pa.timestamp("us", tz="UTC")),
                    "roll_deg": roll + noise[0],
                    "pitch_deg": pitch + noise[1],
                    "yaw_deg": yaw + noise[2],
                }
            )
            if path.suffix == ".parquet":
                if writer is None:
                    writer = pq.ParquetWriter(path, table.schema)
                writer.write_table(table)
            else:
                if writer is None:
                    writer = pcsv.CSVWriter(path, table.schema)
                writer.write_table(table)
    finally:
        if writer is not None:
            writer.close()


def records_table(days: int) -> pd.DataFrame:
    starts = T0 + pd.to_timedelta(np.arange(days * 144) * 600, unit="s")
    return pd.DataFrame(
        {
            "timestamp": np.repeat(starts, len(HEIGHTS_M)),
            "height_m": np.tile(HEIGHTS_M, starts.size),
            "wd_mean_deg": 240.0,
        }
    )


def child(path: str, days: int, method: str) -> None:
    """One measurement, in a fresh process: prints JSON with time and peak RSS."""
    from flidar_uq.data import imu, io
    from flidar_uq.data.imu_series import series_motion_statistics

    records = records_table(days)
    t0 = time.perf_counter()
    if method == "streamed":
        stats = series_motion_statistics(path, records).statistics
        n_ok = int(stats["tilt_along_wind_std_deg"].notna().sum())
    else:
        series = io.read_imu_series(path)
        ms = imu.motion_statistics(series)
        wd_by_height = {
            h: pd.Series(240.0, index=pd.DatetimeIndex(records.loc[sel, "timestamp"]))
            for h, sel in ((h, records["height_m"] == h) for h in HEIGHTS_M)
        }
        by_height = imu.tilt_spectrum_statistics_by_height(series, wd_by_height)
        n_ok = sum(
            int(tab["tilt_along_wind_std_deg"].notna().sum()) for tab, _ in by_height.values()
        )
        del ms
    elapsed = time.perf_counter() - t0
    # VmHWM: the peak RSS of this program's own address space (ru_maxrss would carry the
    # parent's peak over fork + exec on Linux)
    with open("/proc/self/status") as fh:
        hwm_kb = next(int(line.split()[1]) for line in fh if line.startswith("VmHWM:"))
    peak_mb = hwm_kb / 1024.0
    print(json.dumps({"time_s": elapsed, "peak_rss_mb": peak_mb, "record_rows_ok": n_ok}))


def main() -> None:
    OUT.mkdir(exist_ok=True)
    rows = []
    with tempfile.TemporaryDirectory(prefix="imu_series_bench_") as tmp:
        files = {}
        for fmt, days, method, allocator in CASES:
            path = Path(tmp) / f"imu_{days}d.{fmt}"
            if path not in files:
                t0 = time.perf_counter()
                write_series(path, days)
                files[path] = time.perf_counter() - t0
                print(f"wrote {path.name}: {path.stat().st_size / 1e6:.0f} MB", flush=True)
            env = dict(os.environ, OMP_NUM_THREADS="1", OPENBLAS_NUM_THREADS="1")
            if allocator == "mmap128k":
                env["MALLOC_MMAP_THRESHOLD_"] = "131072"
            proc = subprocess.run(
                [sys.executable, __file__, "--child", str(path), str(days), method],
                capture_output=True,
                text=True,
                env=env,
                check=True,
            )
            res = json.loads(proc.stdout.strip().splitlines()[-1])
            n_rows = int(days * 86400 * FS_HZ) - days * int(120 * FS_HZ)
            rows.append(
                {
                    "format": fmt,
                    "days": days,
                    "method": method,
                    "allocator": allocator,
                    "samples": n_rows,
                    "file_mb": path.stat().st_size / 1e6,
                    "time_s": res["time_s"],
                    "time_per_month_s": res["time_s"] * 30.0 / days,
                    "peak_rss_mb": res["peak_rss_mb"],
                    "record_rows": days * 144 * len(HEIGHTS_M),
                    "record_rows_with_statistics": res["record_rows_ok"],
                    "load_average_1min": os.getloadavg()[0],
                }
            )
            print(json.dumps(rows[-1]), flush=True)
            # written after every case: the year's run is long
            pd.DataFrame(rows).to_csv(
                OUT / "imu_series_throughput.csv", index=False, float_format="%.4g"
            )
    table = pd.DataFrame(rows)
    print()
    print(table.to_string(index=False))
    print()
    print(
        f"cores available to this process: {len(os.sched_getaffinity(0))}; "
        f"load average {os.getloadavg()}"
    )
    default = table[table["allocator"] == "default"]
    for fmt in ("parquet", "csv"):
        s = default[(default["format"] == fmt) & (default["method"] == "streamed")]
        s = s.set_index("days")
        m = default[(default["format"] == fmt) & (default["method"] == "in_memory")]
        m = m.set_index("days")
        if len(s) >= 2:
            print(
                f"{fmt}, streamed: peak RSS {s['peak_rss_mb'].iloc[-1]:.0f} MB at "
                f"{s.index[-1]} days vs {s['peak_rss_mb'].iloc[0]:.0f} MB at {s.index[0]} day "
                f"(ratio {s['peak_rss_mb'].iloc[-1] / s['peak_rss_mb'].iloc[0]:.2f}); "
                f"{s['time_per_month_s'].iloc[-1]:.0f} s per month of data -> a year in "
                f"~{12 * s['time_per_month_s'].iloc[-1] / 60:.0f} min"
            )
        for days in m.index:
            if days in s.index:
                print(
                    f"{fmt}, {days} days: in memory / streamed peak RSS "
                    f"{m.loc[days, 'peak_rss_mb'] / s.loc[days, 'peak_rss_mb']:.2f}, time "
                    f"{m.loc[days, 'time_s'] / s.loc[days, 'time_s']:.2f}"
                )
    fixed = table[table["allocator"] == "mmap128k"].set_index("days")
    if len(fixed) >= 2:
        print(
            f"parquet, streamed, mmap threshold 128 kB: peak RSS {fixed['peak_rss_mb'].iloc[-1]:.0f}"
            f" MB at {fixed.index[-1]} days vs {fixed['peak_rss_mb'].iloc[0]:.0f} MB at "
            f"{fixed.index[0]} days"
        )
    plot(table)


def plot(table: pd.DataFrame) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 2, figsize=(10, 4))
    for (fmt, method, alloc), g in table.groupby(["format", "method", "allocator"]):
        style = ("-o" if method == "streamed" else "--s") if alloc == "default" else ":^"
        label = f"{fmt}, {method}" + ("" if alloc == "default" else ", mmap threshold 128 kB")
        axes[0].plot(g["days"], g["peak_rss_mb"], style, label=label)
        axes[1].plot(g["days"], g["time_per_month_s"], style, label=label)
    axes[0].set_xlabel("length of the 20-Hz series (days)")
    axes[0].set_ylabel("peak RSS (MB)")
    axes[0].set_title("memory: bounded by the chunk when streamed")
    axes[1].set_xlabel("length of the 20-Hz series (days)")
    axes[1].set_ylabel("time per 30 days of data (s)")
    axes[1].set_title("time per month (3 heights per record)")
    for ax in axes:
        ax.set_xscale("log")
        ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(OUT / "imu_series_throughput.png", dpi=90, metadata={"Software": None})


if __name__ == "__main__":
    if len(sys.argv) > 1 and sys.argv[1] == "--child":
        child(sys.argv[2], int(sys.argv[3]), sys.argv[4])
    else:
        main()
