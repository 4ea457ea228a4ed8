"""Benchmark: the ``propagate`` step (corrected TI, group statistics, uncertainty budget) at
1 month, 3 months and 1 year of 3-height records, old code against new, side by side.

The step's inputs are one finished default run (``--base``, read only: the 60-day default
campaign, 25,920 record rows, with its bins, bin fits and global record-model fit); its
record tables (``data/records.csv``, ``qc/flags.csv``, ``bins/assignments.csv``) are cut or
tiled in time to the size (each copy shifted by the base's 60 days, record ids renumbered;
the fits are reused: the tiled records fall in the same bins). Every case runs
:func:`flidar_uq.workflow.propagation_step.propagate` with the shipped config's
``propagation`` settings in a fresh ``nice -n 5`` subprocess, with ``PYTHONPATH`` set to
the new source tree (this repository's ``src``) or to the old one (``git archive`` of
``--old-commit`` into a temporary directory). Measured per case: wall time of the call, CPU
time of the process (user + system, imports included), peak RSS (``VmHWM`` of the process)
and the 1-minute load average before and after (the machine may be shared).

Writes ``benchmarks/results/propagation_scaling.csv`` (one row per size and code, written
after every case) and ``propagation_scaling.png`` (CPU time and peak memory against record
rows, old and new), prints the new/old ratios and whether the outputs agree:
``ti/records.csv`` byte for byte, and the largest difference of the group tables
(``speed_bins.csv``, ``groups.csv``: float32 TI draws) and of the uncertainty budget (its
own 200-draw passes in the new code).

``--budget-mc REPS``: instead, the Monte Carlo spread of the uncertainty budget's variance
shares over REPS random streams at 200 and 1000 budget draws (1 month;
``benchmarks/results/budget_draws.csv``), the justification of ``budget_ndraws = 200``.

Usage: ``python benchmarks/propagation_scaling.py [--sizes 1m,3m,1y,3y] [--codes new,old]``
(every size of the first code, then of the next); ``--append --workdir DIR`` adds a
separate run of one code to the CSV.
"""

from __future__ import annotations

import argparse
import dataclasses
import filecmp
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import pandas as pd
import yaml

REPO = Path(__file__).resolve().parents[1]
OUT = REPO / "benchmarks" / "results"
SIZES = {"1m": 30, "3m": 91, "1y": 365, "3y": 1095}  # days
ROWS_PER_DAY = 144 * 3  # 10-min records x 3 heights

RUNNER = """
import json, os, resource, sys, time
args = json.loads(sys.argv[1])
import flidar_uq
from flidar_uq.workflow.propagation_step import propagate
assert flidar_uq.__file__.startswith(os.environ["PYTHONPATH"]), flidar_uq.__file__
t0 = time.perf_counter()
propagate(**args)
wall = time.perf_counter() - t0
ru = resource.getrusage(resource.RUSAGE_SELF)
hwm = next(int(l.split()[1]) for l in open("/proc/self/status") if l.startswith("VmHWM"))
print(json.dumps({"wall_s": wall, "cpu_s": ru.ru_utime + ru.ru_stime, "peak_rss_mb": hwm / 1024}))
"""


def _shift(ts: pd.Series, k: int, span: pd.Timedelta) -> pd.Series:
    t = pd.to_datetime(ts, utc=True) + k * span
    return t.dt.strftime("%Y-%m-%dT%H:%M:%SZ")


def tile_inputs(base: Path, out: Path, n_rows: int) -> None:
    """``n_rows`` record rows: the base's record tables cut or repeated in time."""
    rec = pd.read_csv(base / "data" / "records.csv")
    flags = pd.read_csv(base / "qc" / "flags.csv")
    assign = pd.read_csv(base / "bins" / "assignments.csv")
    n = len(rec)
    assert (flags["record_id"].to_numpy() == np.arange(n)).all(), "flags not one row per record"
    t = pd.to_datetime(rec["timestamp"], utc=True)
    span = (t.max() - t.min()) + pd.Timedelta(minutes=10)
    parts = {"data/records.csv": [], "qc/flags.csv": [], "bins/assignments.csv": []}
    for k in range(-(-n_rows // n)):
        r, f, a = rec.copy(), flags.copy(), assign.copy()
        for d in (r, f, a):
            d["timestamp"] = _shift(d["timestamp"], k, span)
        if "true_record" in r:
            r["true_record"] += k * n
        f["record_id"] += k * n
        f["row"] += k * n
        a["record_id"] += k * n
        parts["data/records.csv"].append(r)
        parts["qc/flags.csv"].append(f)
        parts["bins/assignments.csv"].append(a)
    for name, p in parts.items():
        d = pd.concat(p, ignore_index=True)
        d = d.iloc[:n_rows] if name == "data/records.csv" else d[d["record_id"] < n_rows]
        (out / name).parent.mkdir(parents=True, exist_ok=True)
        d.to_csv(out / name, index=False)


def step_args(base: Path, inp: Path, res: Path, new: bool) -> dict:
    """propagate()'s keyword arguments as the pipeline gives them (config/config.yaml)."""
    sys.path.insert(0, str(REPO / "src"))
    from flidar_uq.campaign.scenarios import reference_sampling
    from flidar_uq.correction.campaign import CorrectionSettings
    from flidar_uq.correction.reference import Reference

    cfg = yaml.safe_load((REPO / "config" / "config.yaml").read_text())
    virtual = reference_sampling("default")  # the shipped default scenario
    prop = dict(cfg["propagation"])
    prop.update(
        scan_heights_in_turn=virtual["heights_in_turn"],
        scan_refocus_delay_s=list(virtual["refocus_delay_s"]),
        turbulence_dt_s=virtual["turbulence_dt_s"],
    )
    ref = Reference.from_config(
        cfg["reference"], lidar=cfg["campaign"]["lidar"], virtual_kind=virtual["reference_kind"]
    ).to_config()
    batches = sorted(str(p) for p in (base / "inference").glob("batch_*"))
    res.mkdir(parents=True, exist_ok=True)
    inputs = dict(
        records_path=str(inp / "data" / "records.csv"),
        flags_path=str(inp / "qc" / "flags.csv"),
        assignments_path=str(inp / "bins" / "assignments.csv"),
        table_path=str(base / "bins" / "table.csv"),
        sigma_z_path=str(base / "bins" / "sigma_z.csv"),
        bin_fits_path=str(base / "inference" / "bin_fits.csv"),
        batch_dirs=batches,
        global_path=str(base / "posterior" / "global.nc"),
        reference=ref,
    )
    if new:  # the library's settings, built from the config as the workflow does
        settings = CorrectionSettings.from_config(cfg | {"propagation": prop})
        return inputs | {"out_dir": str(res), "settings": dataclasses.asdict(settings)}
    # the step's signature before the library API (one keyword per option)
    prop.pop("budget_ndraws", None)
    return dict(
        **inputs,
        bins_out=str(res / "bins.csv"),
        records_out=str(res / "records.csv"),
        speed_bins_out=str(res / "speed_bins.csv"),
        metrics_out=str(res / "metrics.csv"),
        groups_out=str(res / "groups.csv"),
        budget_out=str(res / "uncertainty_budget.csv"),
        sector_width_deg=cfg["report"]["sector_width_deg"],
        min_count=cfg["report"]["group_min_count"],
        seed=cfg["inference"]["seed"],
        lidar=cfg["campaign"]["lidar"],
        **prop,
    )


def run_case(src: Path, args: dict) -> dict:
    """One propagate() call in a fresh nice'd subprocess: its measurements."""
    env = dict(os.environ, PYTHONPATH=str(src))
    load_before = os.getloadavg()[0]
    t0 = time.perf_counter()
    proc = subprocess.run(
        ["nice", "-n", "5", sys.executable, "-c", RUNNER, json.dumps(args)],
        env=env,
        capture_output=True,
        text=True,
        check=False,
    )
    total = time.perf_counter() - t0
    if proc.returncode != 0:
        print(proc.stderr[-3000:], file=sys.stderr)
        return {"ok": False, "process_wall_s": total, "load1_before": load_before}
    m = json.loads(proc.stdout.strip().splitlines()[-1])
    m.update(ok=True, process_wall_s=total, load1_before=load_before)
    m["load1_after"] = os.getloadavg()[0]
    return m


def compare(new: Path, old: Path) -> dict:
    """Do the outputs of the two codes agree? records.csv byte for byte, tables by value."""
    out = {"records_identical": filecmp.cmp(new / "records.csv", old / "records.csv", False)}
    for name in ("speed_bins", "groups", "uncertainty_budget"):
        a, b = pd.read_csv(new / f"{name}.csv"), pd.read_csv(old / f"{name}.csv")
        num = [c for c in a.columns if c in b and pd.api.types.is_float_dtype(a[c])]
        diff = (a[num] - b[num]).abs().to_numpy() if len(a) == len(b) else np.array([np.nan])
        out[f"{name}_max_abs_diff"] = float(np.nanmax(diff)) if diff.size else 0.0
        if name == "uncertainty_budget" and len(a) == len(b):
            shares = [c for c in num if c.startswith("share_")]
            d = (a[shares] - b[shares]).abs().to_numpy()
            out["budget_share_max_abs_diff"] = float(np.nanmax(d))
            out["budget_share_median_abs_diff"] = float(np.nanmedian(d))
    return out


BUDGET_MC_RUNNER = """
import json, sys
import numpy as np
import flidar_uq.correction.campaign as lib
import flidar_uq.workflow.propagation_step as step
args, rep = json.loads(sys.argv[1]), int(sys.argv[2])
# only the propagation's random numbers change with rep (the point target keeps its seed)
lib.child_seed = lambda seed, *key: np.random.SeedSequence(int(seed), spawn_key=(*key, rep))
step.propagate(**args)
"""


def budget_mc(base: Path, work: Path, size: str, reps: int, draws: list[int]) -> pd.DataFrame:
    """Monte Carlo spread of the budget's variance shares: ``reps`` independent random
    streams at each number of budget draws (the main pass at max(draws) so that the
    largest reuses it, as ``budget_ndraws >= ndraws`` does); one row per draws, grouping
    row and source with the shares' sd over the streams and the bound
    ``0.77 / sqrt(draws - 1)``."""
    inp = work / size / "inputs"
    if not (inp / "data" / "records.csv").exists():
        tile_inputs(base, inp, SIZES[size] * ROWS_PER_DAY)
    tabs = []
    for nb in draws:
        for rep in range(reps):
            res = work / size / f"budget_{nb}_{rep}"
            args = step_args(base, inp, res, new=True)
            args["settings"].update(ndraws=max(draws), budget_ndraws=nb)
            env = dict(os.environ, PYTHONPATH=str(REPO / "src"))
            subprocess.run(
                ["nice", "-n", "5", sys.executable, "-c", BUDGET_MC_RUNNER, json.dumps(args),
                 str(rep + 1)],
                env=env, check=True, capture_output=True,
            )  # fmt: skip
            t = pd.read_csv(res / "uncertainty_budget.csv").assign(draws=nb, rep=rep)
            tabs.append(t.reset_index(names="row"))
    t = pd.concat(tabs, ignore_index=True)
    shares = [c for c in t.columns if c.startswith("share_")]
    long = t.melt(["draws", "rep", "row", "grouping"], shares, "source", "share")
    out = long.groupby(["draws", "grouping", "row", "source"])["share"].agg(["mean", "std"])
    out = out.reset_index()
    out["bound_sd"] = 0.77 / np.sqrt(out["draws"] - 1)
    out.to_csv(OUT / "budget_draws.csv", index=False)
    for (nb, grouping), g in out.groupby(["draws", "grouping"]):
        print(
            f"budget {nb} draws, {grouping}: share sd over {reps} streams median "
            f"{g['std'].median():.3f}, max {g['std'].max():.3f} (bound {0.77 / np.sqrt(nb - 1):.3f})"
        )
    return out


def plot(df: pd.DataFrame) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 2, figsize=(10, 4))
    for code, style in (("old", "o--"), ("new", "s-")):
        d = df[(df["code"] == code) & df["ok"]].sort_values("n_rows")
        axes[0].loglog(d["n_rows"], d["cpu_s"], style, label=f"{code} CPU")
        axes[0].loglog(d["n_rows"], d["wall_s"], style, alpha=0.4, label=f"{code} wall")
        axes[1].loglog(d["n_rows"], d["peak_rss_mb"] / 1024, style, label=code)
    axes[0].axhline(300, color="grey", lw=0.8)
    axes[0].set(xlabel="record rows", ylabel="s", title="propagate: time (5 min line)")
    axes[1].axhline(4, color="grey", lw=0.8)
    axes[1].set(xlabel="record rows", ylabel="GB", title="propagate: peak RSS (4 GB line)")
    for ax in axes:
        ax.legend()
        ax.grid(True, which="both", alpha=0.3)
    loads = ", ".join(f"{x:.1f}" for x in df["load1_before"])
    fig.suptitle(f"old = 619c380, new = this branch; 1-min load before each case: {loads}")
    fig.tight_layout()
    fig.savefig(OUT / "propagation_scaling.png", dpi=110)


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--base", type=Path, default=Path("results"))
    p.add_argument("--sizes", default="1m,3m,1y")
    p.add_argument("--codes", default="new,old")
    p.add_argument("--old-commit", default="619c380")
    p.add_argument(
        "--old-settings",
        action="store_true",
        help="the old code's propagate() takes the library settings too (an --old-commit "
        "after the library API); default: one keyword per option",
    )
    p.add_argument("--workdir", type=Path, default=None)
    p.add_argument("--csv", default="propagation_scaling.csv", help="file name of the table")
    p.add_argument(
        "--merge",
        nargs="+",
        default=None,
        metavar="CSV",
        help="only merge these tables of separate runs (benchmarks/results/ names, the same "
        "--workdir) into propagation_scaling.csv/png",
    )
    p.add_argument(
        "--append",
        action="store_true",
        help="keep the other (size, code) rows of an existing CSV (codes run separately, "
        "the same --workdir)",
    )
    p.add_argument(
        "--budget-mc",
        type=int,
        default=0,
        metavar="REPS",
        help="instead: the budget shares' Monte Carlo sd over REPS streams at 1 month, "
        "200 and 1000 budget draws (benchmarks/results/budget_draws.csv)",
    )
    a = p.parse_args()
    work = Path(a.workdir or tempfile.mkdtemp(prefix="propagation_scaling_"))
    if a.budget_mc:
        budget_mc(a.base, work, "1m", a.budget_mc, [200, 1000])
        return
    old_src = work / "old"
    if not (old_src / "src").exists():
        old_src.mkdir(parents=True, exist_ok=True)
        archive = subprocess.run(
            ["git", "-C", str(REPO), "archive", a.old_commit, "src"],
            capture_output=True,
            check=True,
        ).stdout
        subprocess.run(["tar", "-x", "-C", str(old_src)], input=archive, check=True)
    srcs = {"new": REPO / "src", "old": old_src / "src"}
    OUT.mkdir(parents=True, exist_ok=True)
    csv = OUT / a.csv
    if a.merge:  # rows of separate runs (same --workdir): merged, compared, plotted
        df = pd.concat([pd.read_csv(OUT / f) for f in a.merge], ignore_index=True)
        df = df.drop_duplicates(["size", "code"], keep="last").reset_index(drop=True)
        for i, r in df.iterrows():
            if r["code"] == "old" and r["ok"] and (work / r["size"] / "new").exists():
                for k, v in compare(work / r["size"] / "new", work / r["size"] / "old").items():
                    df.loc[i, k] = v
        df.to_csv(OUT / "propagation_scaling.csv", index=False)
        report(df)
        return
    rows = pd.read_csv(csv).to_dict("records") if a.append and csv.exists() else []
    for code in a.codes.split(","):
        for size in a.sizes.split(","):
            n_rows = SIZES[size] * ROWS_PER_DAY
            inp = work / size / "inputs"
            if not (inp / "bins" / "assignments.csv").exists():
                tile_inputs(a.base, inp, n_rows)
            res = work / size / code
            new_api = code == "new" or a.old_settings
            m = run_case(srcs[code], step_args(a.base, inp, res, new=new_api))
            m.update(size=size, n_rows=n_rows, code=code)
            if m["ok"] and all((work / size / c / "records.csv").exists() for c in srcs):
                m.update(compare(work / size / "new", work / size / "old"))
            rows = [r for r in rows if (r["size"], r["code"]) != (size, code)] + [m]
            print(json.dumps(m), flush=True)
            pd.DataFrame(rows).to_csv(csv, index=False)
    report(pd.DataFrame(rows))


def report(df: pd.DataFrame) -> None:
    """The chart and the new/old ratios per size."""
    plot(df)
    for size, g in df.groupby("size", sort=False):
        g = g.set_index("code")
        if {"new", "old"} <= set(g.index) and g["ok"].all():
            print(
                f"{size}: CPU {g.loc['old', 'cpu_s']:.0f} -> {g.loc['new', 'cpu_s']:.0f} s "
                f"({g.loc['old', 'cpu_s'] / g.loc['new', 'cpu_s']:.1f}x), peak RSS "
                f"{g.loc['old', 'peak_rss_mb']:.0f} -> {g.loc['new', 'peak_rss_mb']:.0f} MB "
                f"({g.loc['old', 'peak_rss_mb'] / g.loc['new', 'peak_rss_mb']:.1f}x)"
            )


if __name__ == "__main__":
    main()
