"""Benchmark: wall time and peak memory of the virtual-campaign generator (issue 4).

Runs the shipped ``default`` scenario (8640 10-min records x 3 heights, 60 days) with
1 and 2 worker processes, plus smaller campaigns to show the scaling, and writes
``benchmarks/results/campaign_generation.csv`` and ``.png``. Target: the default
campaign in <= 120 s on 2 cores.

Usage: ``python benchmarks/campaign_generation.py [--quick]`` (``--quick``: 576
records only, for a smoke run).

``--scenarios [N]``: CPU seconds per record of each shipped scenario of issue 11
(misaligned swell, weathervane/fixed heading, broadband/narrow seas, short reference,
sparse 30 days), from its first N records (default 96) in one process, and the
full scenario's estimated wall time on 1 and 2 dedicated cores; writes
``benchmarks/results/campaign_generation_scenarios.csv``.
"""

from __future__ import annotations

import os

for _k in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_k, "1")  # one BLAS thread per process (2 processes on 2 cores)

import argparse  # noqa: E402
import resource  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import matplotlib  # noqa: E402
import matplotlib.ticker  # noqa: E402

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import pandas as pd  # noqa: E402

from flidar_uq.campaign.physics_mode import generate_campaign  # noqa: E402
from flidar_uq.campaign.scenarios import load_scenario  # noqa: E402
from flidar_uq.data.io import validate_records  # noqa: E402

RESULTS = Path(__file__).resolve().parent / "results"
TARGET_S = 120.0


def _peak_mb() -> tuple[float, float]:
    """Peak resident memory (MB) of this process and of the largest child process."""
    own = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0
    child = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss / 1024.0
    return own, child


def _cpu_s() -> float:
    """User + system CPU seconds of this process and of its finished children."""
    own = resource.getrusage(resource.RUSAGE_SELF)
    ch = resource.getrusage(resource.RUSAGE_CHILDREN)
    return own.ru_utime + own.ru_stime + ch.ru_utime + ch.ru_stime


def run(n_records: int, n_workers: int, seed: int = 1) -> dict:
    sc = load_scenario("default") | {"n_records": n_records}
    load0 = os.getloadavg()[0]
    cpu0 = _cpu_s()
    t0 = time.perf_counter()
    out = generate_campaign(sc, seed, n_workers=n_workers)
    wall = time.perf_counter() - t0
    cpu = _cpu_s() - cpu0
    validate_records(out.records, "benchmark")
    own, child = _peak_mb()
    return {
        "n_records": n_records,
        "n_rows": len(out.records),
        "n_workers": n_workers,
        "wall_s": wall,
        "ms_per_record": 1e3 * wall / n_records,
        # CPU seconds of this process and its workers: robust to other jobs on the
        # machine; cpu_s / n_workers is the wall time on dedicated cores (perfect split)
        "cpu_s": cpu,
        "cpu_ms_per_record": 1e3 * cpu / n_records,
        "peak_parent_mb": own,
        "peak_worker_mb": child,
        "target_s": TARGET_S,
        # the machine is shared: the 1-min load average before/after the run puts the
        # wall time in context (2 cores: load > 2 means the run did not own them)
        "load_avg_before": load0,
        "load_avg_after": os.getloadavg()[0],
    }


SCENARIOS = (
    "misaligned_swell",
    "weathervane_broadband",
    "fixed_heading",
    "narrow_sea",
    "short_reference",
    "sparse_30day",
)


def scenario_speeds(n_records: int = 96, seed: int = 1) -> pd.DataFrame:
    """CPU s per record of each scenario of :data:`SCENARIOS` (first ``n_records``)."""
    rows = []
    for name in SCENARIOS:
        sc = load_scenario(name)
        full = int(sc["n_records"])
        short = sc | {"n_records": min(n_records, full)}
        generate_campaign(short | {"n_records": 2}, seed, n_workers=1)  # warm-up
        cpu0 = _cpu_s()
        out = generate_campaign(short, seed, n_workers=1)
        cpu = (_cpu_s() - cpu0) / short["n_records"]
        validate_records(out.records, name)
        rows.append(
            {
                "scenario": name,
                "n_records_full": full,
                "n_heights": len(sc["heights_m"]),
                "cpu_s_per_record": cpu,
                "est_wall_s_1_core": cpu * full,
                "est_wall_s_2_cores": cpu * full / 2.0,
            }
        )
        print(
            f"{name:22s} {cpu * 1e3:5.1f} ms/record (CPU); {full} records: "
            f"~{cpu * full:5.1f} s on 1 core, ~{cpu * full / 2:5.1f} s on 2"
        )
    df = pd.DataFrame(rows)
    RESULTS.mkdir(parents=True, exist_ok=True)
    df.to_csv(RESULTS / "campaign_generation_scenarios.csv", index=False)
    return df


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--quick", action="store_true", help="small campaigns only")
    ap.add_argument("--plot-only", action="store_true", help="redraw the PNG from the CSV")
    ap.add_argument(
        "--scenarios",
        nargs="?",
        type=int,
        const=96,
        default=None,
        metavar="N",
        help="speed of the issue-11 scenarios from their first N records (default 96)",
    )
    args = ap.parse_args()
    if args.scenarios is not None:
        scenario_speeds(args.scenarios)
        return
    full = int(load_scenario("default")["n_records"])
    plan = (
        [(144, 1), (576, 1), (576, 2)] if args.quick else [(576, 1), (576, 2), (2304, 2), (full, 2)]
    )
    rows = []
    suffix = "_quick" if args.quick else ""
    if args.plot_only:
        plan = []
        rows = pd.read_csv(RESULTS / f"campaign_generation{suffix}.csv").to_dict("records")
    for n, w in plan:
        r = run(n, w)
        rows.append(r)
        print(
            f"n_records={n:5d} workers={w}: {r['wall_s']:7.1f} s  "
            f"({r['ms_per_record']:.1f} ms/record; CPU {r['cpu_s']:.1f} s)  peak parent {r['peak_parent_mb']:.0f} MB, "
            f"largest worker {r['peak_worker_mb']:.0f} MB; load average "
            f"{r['load_avg_before']:.1f} -> {r['load_avg_after']:.1f}"
        )
    df = pd.DataFrame(rows)
    RESULTS.mkdir(parents=True, exist_ok=True)
    df.to_csv(RESULTS / f"campaign_generation{suffix}.csv", index=False)

    fig, ax = plt.subplots(1, 2, figsize=(9, 3.5))
    for w, g in df.groupby("n_workers"):
        ax[0].plot(g["n_records"], g["wall_s"], "o-", label=f"{w} worker(s), wall")
        ax[0].plot(g["n_records"], g["cpu_s"] / w, "s--", ms=4, label=f"{w} worker(s), CPU / {w}")
        ax[1].plot(g["n_records"], g["ms_per_record"], "o-", label=f"{w} worker(s)")
    ax[0].axhline(TARGET_S, color="k", ls="--", lw=0.8, label="target 120 s")
    ax[0].axvline(full, color="grey", ls=":", lw=0.8)
    ax[0].set(
        xlabel="10-min records (3 heights)", ylabel="wall time (s)", xscale="log", yscale="log"
    )
    ax[1].set(xlabel="10-min records (3 heights)", ylabel="ms per record", xscale="log")
    for a in ax:
        a.xaxis.set_major_formatter(matplotlib.ticker.ScalarFormatter())
        a.xaxis.set_minor_formatter(matplotlib.ticker.NullFormatter())
        a.set_xticks(sorted(df["n_records"].unique()))
    ax[0].legend(fontsize=8)
    ax[1].legend(fontsize=8)
    fig.suptitle("Virtual campaign generation (physics mode, ZephIR, 50 LOS per scan)")
    fig.tight_layout()
    fig.savefig(RESULTS / f"campaign_generation{suffix}.png", dpi=110)

    # the measured figures side by side
    last = df.iloc[-1]
    est = last["ms_per_record"] * full / 1e3
    est_cpu = last["cpu_ms_per_record"] * full / 1e3 / last["n_workers"]
    print(
        f"\ndefault campaign ({full} records x 3 heights), {int(last['n_workers'])} workers: "
        f"{'measured' if last['n_records'] == full else 'extrapolated'} wall {est:.1f} s "
        f"(load average {last['load_avg_before']:.1f}) vs target {TARGET_S:.0f} s "
        f"(ratio {est / TARGET_S:.2f}); CPU-time estimate on {int(last['n_workers'])} dedicated "
        f"cores {est_cpu:.1f} s (ratio {est_cpu / TARGET_S:.2f}); peak memory parent "
        f"{df['peak_parent_mb'].max():.0f} MB + {int(last['n_workers'])} x worker <= "
        f"{df['peak_worker_mb'].max():.0f} MB"
    )


if __name__ == "__main__":
    main()
