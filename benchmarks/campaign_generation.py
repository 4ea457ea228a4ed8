"""Benchmark: wall time, CPU time and peak memory of the virtual-campaign generator.

Issue 13 item 7: the shipped ``default`` scenario (8640 10-min records x 3 heights,
60 days) in <= 25 s on 2 cores, results unchanged. The current generator and the
reference generator of commit :data:`REFERENCE_COMMIT` (before the issue-13 work, read
from the git history into a temporary module, so no old code lives in ``src``) run side
by side in one process, alternating, on the same records: 1 worker on
``--small`` records (CPU per record, robust to other jobs) and 2 workers on the whole
default campaign (the wall time of the pipeline's ``campaign`` rule, ``threads: 2``).
Each pair's outputs are compared column by column (max absolute and relative
difference, byte identity). Writes ``benchmarks/results/campaign_generation.csv``,
``campaign_generation_diff.csv`` and ``campaign_generation.png``.

Usage: ``python benchmarks/campaign_generation.py [--quick] [--small N]``
(``--quick``: 144 and 576 records only, for a smoke run).

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
import importlib  # noqa: E402
import resource  # noqa: E402
import subprocess  # noqa: E402
import sys  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import matplotlib  # noqa: E402

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pandas as pd  # noqa: E402

from flidar_uq.campaign.physics_mode import generate_campaign  # noqa: E402
from flidar_uq.campaign.scenarios import load_scenario  # noqa: E402
from flidar_uq.data.io import validate_records  # noqa: E402

RESULTS = Path(__file__).resolve().parent / "results"
REPO = Path(__file__).resolve().parents[1]
TARGET_S = 25.0  # issue 13 item 7: the default campaign on 2 cores
#: The generator before the issue-13 speed work (the reference of "results unchanged").
REFERENCE_COMMIT = "38465224c0a642f774a011f0cd7d14cf413d6d04"
SEED = 20181122  # config/config.yaml campaign.seed


def _reference_generator():
    """``generate_campaign`` of :data:`REFERENCE_COMMIT`, imported from a temporary file.

    The file is a module on ``sys.path`` (spawned worker processes inherit the path and
    import it by name, as they import the current generator).
    """
    src = subprocess.run(
        [
            "git",
            "-C",
            str(REPO),
            "show",
            f"{REFERENCE_COMMIT}:src/flidar_uq/campaign/physics_mode.py",
        ],
        check=True,
        capture_output=True,
        text=True,
    ).stdout
    tmp = Path(tempfile.mkdtemp(prefix="campaign_reference_"))
    (tmp / "_campaign_reference.py").write_text(src)
    sys.path.insert(0, str(tmp))
    return importlib.import_module("_campaign_reference").generate_campaign


def _peak_mb() -> tuple[float, float]:
    """Peak resident memory (MB) of this process and of the largest child process so far."""
    own = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0
    child = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss / 1024.0
    return own, child


def _cpu_s() -> float:
    """User + system CPU seconds of this process and of its finished children."""
    own = resource.getrusage(resource.RUSAGE_SELF)
    ch = resource.getrusage(resource.RUSAGE_CHILDREN)
    return own.ru_utime + own.ru_stime + ch.ru_utime + ch.ru_stime


def run(gen, impl: str, n_records: int, n_workers: int) -> tuple[dict, pd.DataFrame]:
    """Time ``gen`` on the first ``n_records`` of the default scenario."""
    sc = load_scenario("default") | {"n_records": n_records}
    load0 = os.getloadavg()[0]
    cpu0 = _cpu_s()
    t0 = time.perf_counter()
    out = gen(sc, SEED, n_workers=n_workers)
    wall = time.perf_counter() - t0
    cpu = _cpu_s() - cpu0
    validate_records(out.records, "benchmark")
    own, child = _peak_mb()
    return {
        "implementation": impl,
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
    }, out.records


def compare(ref: pd.DataFrame, new: pd.DataFrame, n_records: int) -> pd.DataFrame:
    """Max absolute / relative difference of every column of two campaigns."""
    if list(ref.columns) != list(new.columns) or len(ref) != len(new):
        raise RuntimeError(
            f"campaigns differ in shape: {ref.shape} vs {new.shape}, "
            f"columns {sorted(set(ref.columns) ^ set(new.columns))}"
        )
    rows = []
    for c in ref.columns:
        a, b = ref[c], new[c]
        if a.dtype.kind == "f":
            x, y = a.to_numpy(), b.to_numpy()
            nan_mismatch = int((np.isnan(x) != np.isnan(y)).sum())
            ok = np.isfinite(x) & np.isfinite(y)
            d = np.abs(x[ok] - y[ok])
            rel = d / np.maximum(np.abs(x[ok]), np.finfo(float).tiny)
            rows.append(
                {
                    "n_records": n_records,
                    "column": c,
                    "identical": bool(np.array_equal(x, y, equal_nan=True) and a.dtype == b.dtype),
                    "max_abs_diff": float(d.max()) if d.size else 0.0,
                    "max_rel_diff": float(rel.max()) if rel.size else 0.0,
                    "nan_mismatch": nan_mismatch,
                }
            )
        else:
            same = bool(a.equals(b))
            rows.append(
                {
                    "n_records": n_records,
                    "column": c,
                    "identical": same,
                    "max_abs_diff": np.nan,
                    "max_rel_diff": np.nan,
                    "nan_mismatch": 0 if same else -1,
                }
            )
    return pd.DataFrame(rows)


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
    ap.add_argument("--small", type=int, default=576, help="records of the 1-worker runs")
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
    plan = [(144, 1), (576, 2)] if args.quick else [(args.small, 1), (full, 2)]
    suffix = "_quick" if args.quick else ""
    csv, diff_csv = (RESULTS / f"campaign_generation{s}{suffix}.csv" for s in ("", "_diff"))
    RESULTS.mkdir(parents=True, exist_ok=True)
    if args.plot_only:
        df = pd.read_csv(csv)
    else:
        gens = {"reference": _reference_generator(), "current": generate_campaign}
        for g in gens.values():  # warm-up: imports, caches
            g(load_scenario("default") | {"n_records": 2}, SEED, n_workers=1)
        rows, diffs = [], []
        for n, w in plan:
            outs = {}
            for impl, g in gens.items():
                r, outs[impl] = run(g, impl, n, w)
                rows.append(r)
                print(
                    f"{impl:9s} n_records={n:5d} workers={w}: {r['wall_s']:7.1f} s wall, "
                    f"CPU {r['cpu_s']:.1f} s ({r['cpu_ms_per_record']:.1f} ms/record); "
                    f"peak parent {r['peak_parent_mb']:.0f} MB, largest worker "
                    f"{r['peak_worker_mb']:.0f} MB; load average "
                    f"{r['load_avg_before']:.1f} -> {r['load_avg_after']:.1f}",
                    flush=True,
                )
            d = compare(outs["reference"], outs["current"], n)
            diffs.append(d)
            worst = d.sort_values("max_rel_diff", ascending=False).iloc[0]
            print(
                f"  outputs: {int(d['identical'].sum())}/{len(d)} columns byte-identical"
                + (
                    ""
                    if d["identical"].all()
                    else f"; largest relative difference "
                    f"{worst['max_rel_diff']:.2g} ({worst['column']})"
                ),
                flush=True,
            )
        df = pd.DataFrame(rows)
        df.to_csv(csv, index=False)
        pd.concat(diffs, ignore_index=True).to_csv(diff_csv, index=False)

    fig, ax = plt.subplots(1, 2, figsize=(9, 3.6))
    impls = ["reference", "current"]
    for k, (n, g) in enumerate(df.groupby("n_records", sort=True)):
        g = g.set_index("implementation").loc[impls]
        w = int(g["n_workers"].iloc[0])
        x = np.arange(2) + 3 * k
        ax[0].bar(x, g["wall_s"], color=["0.6", "C0"])
        ax[0].plot(x, g["cpu_s"] / w, "k_", ms=14, mew=2)
        for xi, v in zip(x, g["wall_s"], strict=True):
            ax[0].text(xi, v, f"{v:.1f}", ha="center", va="bottom", fontsize=8)
        ax[0].text(x.mean(), 0, f"{n} rec.\n{w} worker(s)", ha="center", va="top", fontsize=8)
        ax[1].bar(x, g["cpu_ms_per_record"], color=["0.6", "C0"])
    ax[0].axhline(
        TARGET_S, color="r", ls="--", lw=0.8, label=f"target {TARGET_S:.0f} s (full, 2 cores)"
    )
    ax[0].plot([], [], "k_", ms=10, mew=2, label="CPU s / workers")
    ax[0].bar([0], [0], color="0.6", label=f"reference ({REFERENCE_COMMIT[:7]})")
    ax[0].bar([0], [0], color="C0", label="current")
    ax[0].set(ylabel="wall time (s)", xticks=[])
    ax[1].set(ylabel="CPU ms per record", xticks=[])
    ax[0].legend(fontsize=7)
    load = df["load_avg_before"].max()
    fig.suptitle(
        f"Virtual campaign generation, default scenario (max 1-min load average {load:.1f} on 2 cores)",
        fontsize=9,
    )
    fig.tight_layout()
    fig.savefig(RESULTS / f"campaign_generation{suffix}.png", dpi=110)

    # the measured figures side by side
    for n, g in df.groupby("n_records", sort=True):
        g = g.set_index("implementation")
        w = int(g.loc["current", "n_workers"])
        print(
            f"\n{n} records, {w} worker(s): wall {g.loc['reference', 'wall_s']:.1f} s -> "
            f"{g.loc['current', 'wall_s']:.1f} s (x{g.loc['reference', 'wall_s'] / g.loc['current', 'wall_s']:.2f}); "
            f"CPU {g.loc['reference', 'cpu_ms_per_record']:.1f} -> "
            f"{g.loc['current', 'cpu_ms_per_record']:.1f} ms/record "
            f"(x{g.loc['reference', 'cpu_s'] / g.loc['current', 'cpu_s']:.2f}); "
            f"CPU / {w} = {g.loc['current', 'cpu_s'] / w:.1f} s vs target {TARGET_S:.0f} s "
            f"(load average {g['load_avg_before'].max():.1f})"
        )


if __name__ == "__main__":
    main()
