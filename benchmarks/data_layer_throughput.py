"""Data-layer throughput: validation + QC + binning of 1e4..1e6 records on one core.

Acceptance: 1 million records in <= 10 s on one core, peak memory stated.
Also measured: IMU motion statistics (flidar_uq.data.imu.motion_statistics) per 10-min
window for one day of a bimodal roll/pitch series at 5, 10 and 20 Hz.
Times are measured without tracing; peak memory in a second run under tracemalloc
(Python + numpy allocations; pandas/arrow buffers outside the Python allocator are
not all seen, so the process max RSS is reported too).

Run:  .venv/bin/python benchmarks/data_layer_throughput.py [--max 1000000]
Writes benchmarks/results/data_layer_throughput.csv, data_layer_imu.csv and
data_layer_throughput.png.
"""

from __future__ import annotations

import argparse
import os
import resource
import time
import tracemalloc
from pathlib import Path

os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import matplotlib  # noqa: E402

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pandas as pd  # noqa: E402

from flidar_uq.data.binning import bin_records  # noqa: E402
from flidar_uq.data.imu import motion_statistics  # noqa: E402
from flidar_uq.data.io import validate_records  # noqa: E402
from flidar_uq.data.qc import run_qc  # noqa: E402

RESULTS = Path(__file__).parent / "results"
BUDGET_S = 10.0


def make_campaign(n: int, rng: np.random.Generator) -> pd.DataFrame:
    """A raw (as read from CSV: ISO text timestamps) record table, 3 heights, ~10 % QC-failing."""
    heights = np.array([27.0, 58.0, 85.0])
    nt = -(-n // heights.size)
    t = pd.date_range("2015-04-01T00:00:00Z", periods=nt, freq="10min").strftime(
        "%Y-%m-%dT%H:%M:%SZ"
    )
    hws = rng.weibull(2.2, n) * 9.0
    amp = rng.gamma(6.0, 0.5, n)
    per = rng.uniform(2.5, 6.0, n)
    df = pd.DataFrame(
        {
            "timestamp": np.repeat(np.asarray(t), heights.size)[:n],
            "height_m": np.tile(heights, nt)[:n],
            "hws_mean_ms": hws,
            "hws_std_ms": hws * rng.gamma(8.0, 0.01, n),
            "wd_mean_deg": rng.uniform(0, 360, n),
            "availability_pct": np.clip(rng.normal(92, 12, n), 0, 100),
            "roll_amplitude_deg": amp * rng.uniform(0.9, 1.1, n),
            "pitch_amplitude_deg": amp * rng.uniform(0.9, 1.1, n),
            "roll_period_s": per * rng.uniform(0.9, 1.1, n),
            "pitch_period_s": per * rng.uniform(0.9, 1.1, n),
            "sv": rng.gamma(2.0, 0.012, n),
            "ref_hws_mean_ms": hws * rng.normal(1.0, 0.02, n),
            "ref_hws_std_ms": hws * rng.gamma(8.0, 0.009, n),
            "true_ti": rng.gamma(8.0, 0.009, n),
        }
    )
    gaps = rng.uniform(size=n) < 0.01
    df.loc[gaps, ["roll_amplitude_deg", "roll_period_s"]] = np.nan
    return df


def pipeline(raw: pd.DataFrame) -> tuple[dict[str, float], int, int]:
    t0 = time.perf_counter()
    rec = validate_records(raw, "benchmark")
    t1 = time.perf_counter()
    qc = run_qc(rec)
    t2 = time.perf_counter()
    _, table = bin_records(qc.kept)
    t3 = time.perf_counter()
    return (
        {"validate_s": t1 - t0, "qc_s": t2 - t1, "binning_s": t3 - t2, "total_s": t3 - t0},
        qc.n_kept,
        len(table),
    )


def imu_day(fs_hz: float, rng: np.random.Generator) -> pd.DataFrame:
    """One day of bimodal roll/pitch (4 s wind sea + 10 s swell) with noise and 1 % gaps."""
    t = np.arange(0.0, 86400.0, 1.0 / fs_hz)
    roll = 2.0 * np.sin(2 * np.pi * t / 4.0) + 1.0 * np.sin(2 * np.pi * t / 10.0 + 1.0)
    pitch = 2.2 * np.sin(2 * np.pi * t / 4.2 + 0.5) + 0.8 * np.sin(2 * np.pi * t / 10.0)
    keep = rng.uniform(size=t.size) > 0.01
    noise = 0.05 * rng.standard_normal((2, t.size))
    return pd.DataFrame(
        {
            "timestamp": pd.to_datetime(1.4274e9 + t[keep], unit="s", utc=True),
            "roll_deg": (roll + noise[0])[keep],
            "pitch_deg": (pitch + noise[1])[keep],
        }
    )


def imu_benchmark(rng: np.random.Generator) -> pd.DataFrame:
    rows = []
    for fs in (5.0, 10.0, 20.0):
        series = imu_day(fs, rng)
        t0 = time.perf_counter()
        out = motion_statistics(series)
        dt = time.perf_counter() - t0
        rows.append(
            {
                "fs_hz": fs,
                "n_samples": len(series),
                "n_windows": len(out),
                "time_s": round(dt, 4),
                "ms_per_window": round(1e3 * dt / len(out), 3),
                "bimodal_share": round(float(out["period2_s"].notna().mean()), 3),
                "median_period2_s": round(float(out["period2_s"].median()), 3),
            }
        )
        print(rows[-1], flush=True)
    return pd.DataFrame(rows)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--max", type=int, default=1_000_000, help="largest number of records")
    ap.add_argument("--repeats", type=int, default=3, help="timing repeats (best is kept)")
    args = ap.parse_args()
    if hasattr(os, "sched_setaffinity"):
        os.sched_setaffinity(0, {sorted(os.sched_getaffinity(0))[0]})  # one core
    rng = np.random.default_rng(np.random.SeedSequence(20181122))
    sizes = [n for n in (10_000, 30_000, 100_000, 300_000, 1_000_000) if n <= args.max]
    rows = []
    for n in sizes:
        raw = make_campaign(n, rng)
        best = None
        for _ in range(args.repeats if n < 1_000_000 else 2):
            times, n_kept, n_bins = pipeline(raw)
            if best is None or times["total_s"] < best["total_s"]:
                best = times
        tracemalloc.start()
        pipeline(raw)
        _, peak = tracemalloc.get_traced_memory()
        tracemalloc.stop()
        maxrss_mb = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0
        rows.append(
            {
                "n_records": n,
                **{k: round(v, 4) for k, v in best.items()},
                "records_per_s": round(n / best["total_s"]),
                "peak_traced_mb": round(peak / 2**20, 1),
                "max_rss_mb": round(maxrss_mb, 1),
                "n_kept": n_kept,
                "n_bins": n_bins,
            }
        )
        print(rows[-1], flush=True)
    df = pd.DataFrame(rows)
    imu_df = imu_benchmark(rng)
    RESULTS.mkdir(parents=True, exist_ok=True)
    df.to_csv(RESULTS / "data_layer_throughput.csv", index=False)
    imu_df.to_csv(RESULTS / "data_layer_imu.csv", index=False)

    fig, (ax1, ax2, ax3) = plt.subplots(1, 3, figsize=(14, 4))
    for col in ("validate_s", "qc_s", "binning_s", "total_s"):
        ax1.loglog(df["n_records"], df[col], "o-", label=col.removesuffix("_s"))
    ax1.axhline(BUDGET_S, color="k", ls="--", lw=1, label="budget 10 s @ 1e6")
    ax1.set(xlabel="records", ylabel="wall time on one core (s)", title="validation + QC + binning")
    ax1.legend(fontsize=8)
    ax2.loglog(df["n_records"], df["peak_traced_mb"], "o-", label="peak traced (tracemalloc)")
    ax2.loglog(df["n_records"], df["max_rss_mb"], "s-", label="process max RSS")
    ax2.set(xlabel="records", ylabel="memory (MB)", title="peak memory")
    ax2.legend(fontsize=8)
    ax3.bar([f"{f:g} Hz" for f in imu_df["fs_hz"]], imu_df["ms_per_window"])
    ax3.set(ylabel="ms per 10-min window", title="IMU motion statistics (one core)")
    fig.tight_layout()
    fig.savefig(RESULTS / "data_layer_throughput.png", dpi=90)

    print()
    print(df.to_string(index=False))
    print()
    print(imu_df.to_string(index=False))
    last = df.iloc[-1]
    print(
        f"\n{int(last['n_records']):,} records: {last['total_s']:.2f} s measured vs {BUDGET_S:.0f} s budget "
        f"(ratio {last['total_s'] / BUDGET_S:.2f}); peak traced {last['peak_traced_mb']:.0f} MB, "
        f"max RSS {last['max_rss_mb']:.0f} MB"
    )


if __name__ == "__main__":
    main()
