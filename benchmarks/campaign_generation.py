"""Benchmark: wall time, CPU time and peak memory of the virtual-campaign generator.

Target: the shipped ``default`` scenario (8640 10-min records x 3 heights,
60 days) in <= 25 s on 2 cores, results unchanged. Three generators run side by side,
alternating, on the same records, each in a fresh subprocess with its own source tree on
``PYTHONPATH`` (old trees extracted from the git history into a temporary directory, so
no old code lives in ``src``): the reference of :data:`REFERENCE_COMMIT` (before the
speed work), the previous round of :data:`PREVIOUS_COMMIT`, and the current ``src``.
1 worker on ``--small`` records (CPU per record, robust to other jobs) and 2 workers on
the whole default campaign (the wall time of the pipeline's ``campaign`` rule,
``threads: 2``). Each old generator's output is compared with the current one column by
column (max absolute and relative difference, byte identity). Writes
``benchmarks/results/campaign_generation.csv``, ``campaign_generation_diff.csv`` and
``campaign_generation.png``.

Usage: ``python benchmarks/campaign_generation.py [--quick] [--small N] [--full-impls LIST]``
(``--quick``: 144 and 576 records only, for a smoke run; ``--full-impls``: the
implementations of the whole-campaign run, default all three).

``--step N``: the pipeline's ``campaign`` step itself (generation on 2 workers and the
record table written as CSV, :func:`flidar_uq.workflow.data_steps.make_campaign`, from a
fresh Python process as the rule runs it), N times for the previous and the current tree,
alternating; the wall times and whether the two CSV files are the same bytes go to
``benchmarks/results/campaign_generation_step.csv``.

``--scenarios [N]``: CPU seconds per record of each shipped scenario
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
import pickle  # noqa: E402
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
TARGET_S = 25.0  # target: the default campaign generated in 25 s on 2 cores
#: The generator before the speed work (the reference of "results unchanged").
REFERENCE_COMMIT = "38465224c0a642f774a011f0cd7d14cf413d6d04"
#: The generator before the latest round (the one that added compiled normal draws and
#: moved a record's kernel call right after its series; the rounds before it: 997d9ac,
#: e1e35a3, 619c380, cb8877e).
PREVIOUS_COMMIT = "b01d024fdc3a82542b2358130bc46b02d05b8f6e"
IMPLEMENTATIONS = ("reference", "previous", "current")
SEED = 20181122  # config/config.yaml campaign.seed


def _source_tree(commit: str) -> Path:
    """``src`` of ``commit`` (and the ``config`` its scenarios load from), extracted from the
    git history into a temporary directory."""
    tmp = Path(tempfile.mkdtemp(prefix=f"campaign_{commit[:7]}_"))
    tar = subprocess.run(
        ["git", "-C", str(REPO), "archive", commit, "src", "config"],
        check=True,
        capture_output=True,
    ).stdout
    subprocess.run(["tar", "-x", "-C", str(tmp)], input=tar, check=True)
    return tmp / "src"


def _run_in_subprocess(src: Path, n_records: int, n_workers: int) -> tuple[dict, pd.DataFrame]:
    """:func:`run` of the generator under ``src`` in a fresh Python process."""
    with tempfile.TemporaryDirectory(prefix="campaign_bench_") as tmp:
        out = Path(tmp) / "out.pkl"
        env = os.environ | {"PYTHONPATH": str(src)}
        subprocess.run(
            [sys.executable, __file__, "--child", str(n_records), str(n_workers), str(out)],
            check=True,
            env=env,
        )
        with out.open("rb") as fh:
            row, records = pickle.load(fh)
    if not row["source"].startswith(str(src.resolve())):
        raise RuntimeError(f"the subprocess imported {row['source']}, not the tree {src}")
    return row, records


_STEP = """
import sys
from flidar_uq.workflow.data_steps import make_campaign
make_campaign(sys.argv[1], source="virtual", seed=int(sys.argv[2]), scenario_path=sys.argv[3],
              threads=2)
"""
#: a few records on 2 workers: the tree's compiled kernels into its numba cache, untimed
_WARM = """
import sys
from flidar_uq.campaign.physics_mode import generate_campaign
from flidar_uq.campaign.scenarios import load_scenario
if __name__ == "__main__":
    generate_campaign(load_scenario("default") | {"n_records": 4}, int(sys.argv[1]), n_workers=2)
"""


def _default_scenario_file(src: Path) -> Path:
    """The ``default`` scenario's file of the tree ``src``: package data
    (``flidar_uq/resources/scenarios``) or, in older trees, ``config/scenarios``."""
    packaged = src / "flidar_uq" / "resources" / "scenarios" / "default.yaml"
    return packaged if packaged.is_file() else src.parent / "config" / "scenarios" / "default.yaml"


def step_runs(n_runs: int) -> pd.DataFrame:
    """Wall time of the ``campaign`` step (generation + CSV) from a fresh process, previous
    and current tree alternating, each tree's compiled kernels cached first (an extracted
    tree would compile them in its first run, ~4 s once a machine); the two trees' CSV
    files compared byte for byte."""
    trees = {"previous": _source_tree(PREVIOUS_COMMIT), "current": REPO / "src"}
    rows = []
    with tempfile.TemporaryDirectory(prefix="campaign_step_") as tmp:
        outs = {impl: Path(tmp) / f"{impl}.csv" for impl in trees}
        for src in trees.values():
            warm = Path(tmp) / "warm.py"  # a file: spawned workers re-import the main module
            warm.write_text(_WARM)
            env = os.environ | {"PYTHONPATH": str(src)}
            subprocess.run([sys.executable, str(warm), str(SEED)], check=True, env=env)
        for k in range(n_runs):
            for impl, src in trees.items():
                scenario = _default_scenario_file(src)
                cmd = [sys.executable, "-c", _STEP, str(outs[impl]), str(SEED), str(scenario)]
                load0 = os.getloadavg()[0]
                t0 = time.perf_counter()
                subprocess.run(cmd, check=True, env=os.environ | {"PYTHONPATH": str(src)})
                wall = time.perf_counter() - t0
                rows.append(
                    {
                        "implementation": impl,
                        "run": k,
                        "step_wall_s": wall,
                        "load_avg_before": load0,
                        "target_s": TARGET_S,
                    }  # fmt: skip
                )
                print(f"step {impl:8s} run {k}: {wall:5.1f} s (load {load0:.1f})", flush=True)
        same = outs["previous"].read_bytes() == outs["current"].read_bytes()
    df = pd.DataFrame(rows).assign(csv_bytes_identical=same)
    df.to_csv(RESULTS / "campaign_generation_step.csv", index=False)
    med = df.groupby("implementation")["step_wall_s"].median()
    print(
        f"campaign step, median of {n_runs}: previous {med['previous']:.1f} s -> current "
        f"{med['current']:.1f} s (x{med['previous'] / med['current']:.2f}); target "
        f"{TARGET_S:.0f} s; records.csv byte-identical: {same}"
    )
    return df


def _child(n_records: int, n_workers: int, out: str) -> None:
    """Subprocess side: warm up, time one run, pickle the timing row and the records."""
    import flidar_uq

    generate_campaign(load_scenario("default") | {"n_records": 2}, SEED, n_workers=1)
    row, records = run(generate_campaign, "", n_records, n_workers)
    row["source"] = str(Path(flidar_uq.__file__).resolve().parents[1])
    with open(out, "wb") as fh:
        pickle.dump((row, records), fh)


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


def compare(ref: pd.DataFrame, new: pd.DataFrame, n_records: int, baseline: str) -> pd.DataFrame:
    """Max absolute / relative difference of every column the two campaigns share.

    Columns added since ``ref`` (e.g. ``heading_mean_deg``) are not compared;
    the printout names them.
    """
    if len(ref) != len(new):
        raise RuntimeError(f"campaigns differ in rows: {len(ref)} vs {len(new)}")
    shared = [c for c in ref.columns if c in new.columns]
    if len(shared) < len(ref.columns):
        raise RuntimeError(f"columns lost since {baseline}: {sorted(set(ref) - set(new))}")
    added = sorted(set(new.columns) - set(shared))
    if added:
        print(f"  columns added since {baseline} (not compared): {added}")
    rows = []
    for c in shared:
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
                    "baseline": baseline,
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
                    "baseline": baseline,
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


def _plot(df: pd.DataFrame, suffix: str) -> None:
    impls = [i for i in IMPLEMENTATIONS if i in set(df["implementation"])]
    colors = {"reference": "0.75", "previous": "0.5", "current": "C0"}
    fig, ax = plt.subplots(1, 2, figsize=(10, 3.8))
    x0 = 0
    for n, g in df.groupby("n_records", sort=True):
        g = g.set_index("implementation")
        g = g.loc[[i for i in impls if i in g.index]]
        w = int(g["n_workers"].iloc[0])
        x = np.arange(len(g)) + x0
        x0 += len(g) + 1
        ax[0].bar(x, g["wall_s"], color=[colors[i] for i in g.index])
        ax[0].plot(x, g["cpu_s"] / w, "k_", ms=14, mew=2)
        for xi, v in zip(x, g["wall_s"], strict=True):
            ax[0].text(xi, v, f"{v:.0f}", ha="center", va="bottom", fontsize=8)
        ax[0].text(x.mean(), 0, f"{n} rec.\n{w} worker(s)", ha="center", va="top", fontsize=8)
        ax[1].bar(x, g["cpu_ms_per_record"], color=[colors[i] for i in g.index])
        for xi, v in zip(x, g["cpu_ms_per_record"], strict=True):
            ax[1].text(xi, v, f"{v:.1f}", ha="center", va="bottom", fontsize=8)
    ax[0].axhline(
        TARGET_S, color="r", ls="--", lw=0.8, label=f"target {TARGET_S:.0f} s (full, 2 cores)"
    )
    ax[0].plot([], [], "k_", ms=10, mew=2, label="CPU s / workers")
    labels = {
        "reference": f"reference ({REFERENCE_COMMIT[:7]})",
        "previous": f"previous ({PREVIOUS_COMMIT[:7]})",
        "current": "current",
    }
    for i in impls:
        ax[0].bar([0], [0], color=colors[i], label=labels[i])
    ax[0].set(ylabel="wall time (s)", xticks=[])
    ax[1].set(ylabel="CPU ms per record", xticks=[])
    ax[0].legend(fontsize=7)
    load = df["load_avg_before"].max()
    fig.suptitle(
        f"Virtual campaign generation, default scenario (max 1-min load average {load:.1f} "
        "on 2 cores)",
        fontsize=9,
    )
    fig.tight_layout()
    fig.savefig(RESULTS / f"campaign_generation{suffix}.png", dpi=110)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--quick", action="store_true", help="small campaigns only")
    ap.add_argument("--small", type=int, default=576, help="records of the 1-worker runs")
    ap.add_argument(
        "--full-impls",
        default=",".join(IMPLEMENTATIONS),
        help="implementations timed on the whole campaign (comma-separated)",
    )
    ap.add_argument("--plot-only", action="store_true", help="redraw the PNG from the CSV")
    ap.add_argument("--child", nargs=3, metavar=("N", "WORKERS", "OUT"), help=argparse.SUPPRESS)
    ap.add_argument(
        "--scenarios",
        nargs="?",
        type=int,
        const=96,
        default=None,
        metavar="N",
        help="speed of the shipped scenarios from their first N records (default 96)",
    )
    ap.add_argument(
        "--step",
        type=int,
        default=None,
        metavar="N",
        help="time the whole campaign step (generation + CSV) N times, previous vs current",
    )
    args = ap.parse_args()
    if args.child:
        _child(int(args.child[0]), int(args.child[1]), args.child[2])
        return
    if args.scenarios is not None:
        scenario_speeds(args.scenarios)
        return
    if args.step is not None:
        RESULTS.mkdir(parents=True, exist_ok=True)
        step_runs(args.step)
        return
    full = int(load_scenario("default")["n_records"])
    full_impls = [i for i in IMPLEMENTATIONS if i in args.full_impls.split(",")]
    plan = (
        [(144, 1, IMPLEMENTATIONS), (576, 2, IMPLEMENTATIONS)]
        if args.quick
        else [(args.small, 1, IMPLEMENTATIONS), (full, 2, full_impls)]
    )
    suffix = "_quick" if args.quick else ""
    csv, diff_csv = (RESULTS / f"campaign_generation{s}{suffix}.csv" for s in ("", "_diff"))
    RESULTS.mkdir(parents=True, exist_ok=True)
    if args.plot_only:
        _plot(pd.read_csv(csv), suffix)
        return
    trees = {
        "reference": _source_tree(REFERENCE_COMMIT),
        "previous": _source_tree(PREVIOUS_COMMIT),
        "current": REPO / "src",
    }
    rows, diffs = [], []
    for n, w, impls in plan:
        outs = {}
        for impl in impls:
            r, outs[impl] = _run_in_subprocess(trees[impl], n, w)
            r["implementation"] = impl
            rows.append(r)
            print(
                f"{impl:9s} n_records={n:5d} workers={w}: {r['wall_s']:7.1f} s wall, "
                f"CPU {r['cpu_s']:.1f} s ({r['cpu_ms_per_record']:.1f} ms/record); "
                f"peak largest worker {r['peak_worker_mb']:.0f} MB; load average "
                f"{r['load_avg_before']:.1f} -> {r['load_avg_after']:.1f}",
                flush=True,
            )
        for base in (i for i in impls if i != "current"):
            d = compare(outs[base], outs["current"], n, base)
            diffs.append(d)
            worst = d.sort_values("max_rel_diff", ascending=False).iloc[0]
            print(
                f"  {base} vs current: {int(d['identical'].sum())}/{len(d)} columns "
                "byte-identical"
                + (
                    ""
                    if d["identical"].all()
                    else f"; largest relative difference "
                    f"{worst['max_rel_diff']:.2g} ({worst['column']})"
                ),
                flush=True,
            )
    df = pd.DataFrame(rows).drop(columns="source")
    df.to_csv(csv, index=False)
    pd.concat(diffs, ignore_index=True).to_csv(diff_csv, index=False)
    _plot(df, suffix)

    # the measured figures side by side
    for n, g in df.groupby("n_records", sort=True):
        g = g.set_index("implementation")
        w = int(g.loc["current", "n_workers"])
        cur = g.loc["current"]
        for base in (i for i in IMPLEMENTATIONS if i in g.index and i != "current"):
            b = g.loc[base]
            print(
                f"\n{n} records, {w} worker(s), {base} -> current: wall {b['wall_s']:.1f} s -> "
                f"{cur['wall_s']:.1f} s (x{b['wall_s'] / cur['wall_s']:.2f}); CPU "
                f"{b['cpu_ms_per_record']:.1f} -> {cur['cpu_ms_per_record']:.1f} ms/record "
                f"(x{b['cpu_s'] / cur['cpu_s']:.2f})"
            )
        print(
            f"CPU / {w} = {cur['cpu_s'] / w:.1f} s vs target {TARGET_S:.0f} s "
            f"(load average {g['load_avg_before'].max():.1f})"
        )


if __name__ == "__main__":
    main()
