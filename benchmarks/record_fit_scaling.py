"""Benchmark: the global record fit (``fit_global_record``) at 1 month, 3 months and 1 year,
old code against new, side by side in one run (docs/performance.md).

Each case runs the pipeline's step function
:func:`flidar_uq.workflow.inference_steps.fit_global_model` (``model="record"``, the repo's
``config/config.yaml`` inference and prior settings, so the same seed and sampler budget as
``snakemake``) in a fresh ``nice -n 5`` subprocess, once with the OLD code (``--old-rev``,
extracted with ``git archive`` into the work directory and put first on ``PYTHONPATH``) and
once with the NEW code (this checkout's ``src``). Measured per case: wall time of the
subprocess, its CPU time (user + system, ``getrusage``), peak RSS (``VmHWM`` of
``/proc/self/status``) and the 1-minute load average before and after (2 cores shared with
other jobs: wall times are inflated by the load, CPU time is the comparable cost).
A watchdog polls the subprocess's ``VmRSS`` and stops it above ``--max-rss-gb`` or after
``--max-minutes`` (status ``stopped``; its peak is then the last polled RSS, a lower bound).

A second, small case per size and code (``log_prob``) measures the sampler's likelihood
alone: one call of ``log_prob_record_model`` on 64 walkers (4 ensembles x 16 walkers, the
independence move proposes all of them at once) over all records; the peak RSS above the
RSS before the call is the memory of its (walkers x records) temporaries.

Input: the default run's record table after QC and binning
(``results/bins/assignments.csv``, the file the step reads; read only) tiled in
time to the size (``scaling.tile_records``: copies shifted by the table's 60-day span). The
size's "campaign rows" are 10-min slots x 3 heights; the kept rows (after QC) are ~95 % of
them.

Results: ``benchmarks/results/record_fit_scaling.csv`` (one row per size, code and case;
rewritten after each case, so a cut-off run keeps what it finished) and
``record_fit_scaling.png`` (log-log peak RSS and CPU time against rows, old vs new, the
4 GB target dotted); the old/new ratios are printed. The written posteriors of old and new
are compared per size: the draws must be identical and the PSIS-LOO (elpd, p_loo, se,
pointwise elpd and Pareto k) equal to ``--loo-rtol`` (columns ``draws_identical``,
``loo_max_rel_diff``).

Usage: ``PYTHONPATH=src nice -n 5 python benchmarks/record_fit_scaling.py [--sizes 1m,3m,1y]``.
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import subprocess
import sys
import tarfile
import time
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pandas as pd  # noqa: E402
import yaml  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))
from scaling import HEIGHTS, RECORDS_PER_DAY, SIZES_DAYS, TARGET_1Y_MB, tile_records  # noqa: E402

REPO = Path(__file__).resolve().parents[1]
RESULTS = REPO / "benchmarks" / "results"
CSV = RESULTS / "record_fit_scaling.csv"
PNG = RESULTS / "record_fit_scaling.png"
ASSIGNMENTS = REPO / "results" / "bins" / "assignments.csv"
N_WALKERS = 64  # 4 ensembles x 16 walkers (config/config.yaml)


def _vm(field: str, pid: str = "self") -> float:
    """A ``/proc/<pid>/status`` memory field in MB (NaN once the process is gone)."""
    try:
        with open(f"/proc/{pid}/status") as f:
            for line in f:
                if line.startswith(field + ":"):
                    return int(line.split()[1]) / 1024.0
    except OSError:
        pass
    return float("nan")


def _cpu_s() -> float:
    ru = resource.getrusage(resource.RUSAGE_SELF)
    return ru.ru_utime + ru.ru_stime


# --- child processes (run with the OLD or NEW code first on PYTHONPATH) -----------------


def child_fit(assignments: Path, out_nc: Path, out_json: Path) -> None:
    """The ``fit_global_record`` step as Snakemake runs it; its CPU time and peak RSS."""
    import flidar_uq
    from flidar_uq.workflow.inference_steps import fit_global_model

    cfg = yaml.safe_load((REPO / "config" / "config.yaml").read_text())
    fit_global_model(
        [],
        assignments,
        out_nc,
        model="record",
        inference=cfg["inference"],
        priors=cfg["priors"],
        lidar=cfg["campaign"]["lidar"],
    )
    out_json.write_text(
        json.dumps({"cpu_s": _cpu_s(), "peak_rss_mb": _vm("VmHWM"), "package": flidar_uq.__file__})
    )


def child_log_prob(assignments: Path, out_json: Path) -> None:
    """Peak RSS of one sampler likelihood call on 64 walkers over all records."""
    from flidar_uq.inference.record_fit import _record_observations, log_prob_record_model

    cfg = yaml.safe_load((REPO / "config" / "config.yaml").read_text())
    rec = pd.read_csv(assignments)
    (s, r, gram), _, _ = _record_observations(rec, None, None, cfg["campaign"]["lidar"])
    rng = np.random.default_rng(0)
    centre = np.array([0.0, np.log(0.05), np.log(0.15), 2.0, 0.0, np.log(0.3), np.log(0.1)])
    theta = centre + 0.01 * rng.standard_normal((N_WALKERS, centre.size))
    log_prob_record_model(theta[:1], s, r, gram)  # warm-up: imports, small buffers
    base = _vm("VmRSS")
    t0 = time.perf_counter()
    lp = log_prob_record_model(theta, s, r, gram)
    wall = time.perf_counter() - t0
    out_json.write_text(
        json.dumps(
            {
                "call_s": wall,
                "peak_rss_mb": _vm("VmHWM"),
                "call_extra_mb": _vm("VmHWM") - base,
                "n_used": int(s.size),
                "finite": bool(np.all(np.isfinite(lp))),
            }
        )
    )


# --- parent -------------------------------------------------------------------------------


def extract_rev(rev: str, dest: Path) -> Path:
    """The package source of ``rev`` (``git archive``), for the OLD subprocesses."""
    src = dest / "src"
    if not (src / "flidar_uq").is_dir():
        dest.mkdir(parents=True, exist_ok=True)
        tar = dest / "src.tar"
        subprocess.run(["git", "-C", str(REPO), "archive", "-o", str(tar), rev, "src"], check=True)
        with tarfile.open(tar) as t:
            t.extractall(dest, filter="data")
        tar.unlink()
    return src


def run_case(args: list[str], src: Path, max_rss_mb: float, max_s: float) -> dict:
    """Run this script as a child (``nice -n 5``) with ``src`` first on PYTHONPATH; watch it."""
    env = {**os.environ, "PYTHONPATH": str(src), "OMP_NUM_THREADS": "1"}
    cmd = ["nice", "-n", "5", sys.executable, str(Path(__file__).resolve()), *args]
    load0 = os.getloadavg()[0]
    t0 = time.perf_counter()
    p = subprocess.Popen(cmd, env=env, start_new_session=True)
    polled, status = 0.0, "ok"
    while p.poll() is None:
        rss = _vm("VmRSS", str(p.pid))
        polled = max(polled, 0.0 if np.isnan(rss) else rss)
        if polled > max_rss_mb or time.perf_counter() - t0 > max_s:
            status = f"stopped (> {max_rss_mb:.0f} MB)" if polled > max_rss_mb else "stopped (time)"
            os.killpg(p.pid, 9)
            p.wait()
            break
        time.sleep(0.2)
    wall = time.perf_counter() - t0
    if status == "ok" and p.returncode != 0:
        status = f"failed (exit {p.returncode})"
    return {
        "status": status,
        "wall_s": wall,
        "polled_rss_mb": polled,
        "load1_before": load0,
        "load1_after": os.getloadavg()[0],
    }


def compare(old_nc: Path, new_nc: Path) -> dict:
    """Draws identical? Largest relative difference of the PSIS-LOO values (old vs new)."""
    from flidar_uq.inference import load_fit

    a, b = load_fit(old_nc), load_fit(new_nc)
    same = a.draws.keys() == b.draws.keys() and all(
        np.array_equal(np.asarray(a.draws[k]), np.asarray(b.draws[k])) for k in a.draws
    )
    la, lb = a.loo(), b.loo()
    rel = 0.0
    for k in la:
        x, y = np.atleast_1d(la[k]), np.atleast_1d(lb[k])
        if not np.array_equal(np.isnan(x), np.isnan(y)):
            rel = np.inf
            continue
        d = np.abs(x - y) / np.maximum(np.abs(x), 1e-300)
        rel = max(rel, float(np.nanmax(d, initial=0.0)))
    return {
        "draws_identical": bool(same),
        "loo_max_rel_diff": rel,
        "elpd": lb["elpd"],
        "p_loo": lb["p_loo"],
        "pareto_k_max": float(np.max(lb["pareto_k"])),
        "n_records_used": int(b.info["n_records"]),
    }


def plot(df: pd.DataFrame) -> None:
    fit = df[df["case"] == "fit"]
    lp = df[df["case"] == "log_prob"]
    fig, axes = plt.subplots(1, 3, figsize=(16, 5))
    for code, style in (("old", "o--"), ("new", "s-")):
        g = fit[fit["code"] == code].sort_values("campaign_rows")
        ok = g[g["status"] == "ok"]
        axes[0].loglog(
            ok["campaign_rows"],
            ok["peak_rss_mb"],
            style,
            label=f"{code} ({g['rev'].iloc[0] if len(g) else ''})",
        )
        st = g[g["status"] != "ok"]
        if not st.empty:
            axes[0].loglog(
                st["campaign_rows"],
                st["peak_rss_mb"],
                "x",
                ms=10,
                label=f"{code}: stopped (lower bound)",
            )
        axes[1].loglog(ok["campaign_rows"], ok["cpu_s"], style, label=code)
        axes[1].loglog(ok["campaign_rows"], ok["wall_s"], style, alpha=0.4, label=f"{code} wall")
        h = lp[lp["code"] == code].sort_values("campaign_rows")
        axes[2].loglog(h["campaign_rows"], h["call_extra_mb"].clip(lower=1), style, label=code)
    axes[0].axhline(TARGET_1Y_MB, color="k", ls=":", lw=1, label="4 GB target")
    axes[0].set_ylabel("peak RSS of the step (MB)")
    axes[1].set_ylabel("CPU time (s); faint: wall (shared machine)")
    axes[2].set_ylabel(f"extra peak RSS of one {N_WALKERS}-walker likelihood call (MB)")
    for ax in axes:
        ax.set_xlabel("campaign rows (10-min slots x 3 heights)")
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=8)
    fig.suptitle(
        "fit_global_record (record motion model): old vs new, nice -n 5 on 2 shared cores",
        fontsize=10,
    )
    fig.tight_layout()
    fig.savefig(PNG, dpi=110)
    plt.close(fig)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--sizes", default="1m,3m,1y")
    ap.add_argument("--old-rev", default="619c380")
    ap.add_argument("--workdir", type=Path, default=Path("/tmp/flidar_record_fit_scaling"))
    ap.add_argument("--assignments", type=Path, default=ASSIGNMENTS)
    ap.add_argument("--max-rss-gb", type=float, default=12.0)
    ap.add_argument("--max-minutes", type=float, default=15.0)
    ap.add_argument("--loo-rtol", type=float, default=1e-6)
    ap.add_argument("--child", choices=["fit", "log_prob"], help=argparse.SUPPRESS)
    ap.add_argument("--child-args", nargs="*", help=argparse.SUPPRESS)
    a = ap.parse_args()
    if a.child == "fit":
        child_fit(*(Path(x) for x in a.child_args))
        return
    if a.child == "log_prob":
        child_log_prob(*(Path(x) for x in a.child_args))
        return

    wd = a.workdir
    wd.mkdir(parents=True, exist_ok=True)
    srcs = {"old": extract_rev(a.old_rev, wd / f"old_{a.old_rev}"), "new": REPO / "src"}
    rev_new = subprocess.run(
        ["git", "-C", str(REPO), "rev-parse", "--short", "HEAD"], capture_output=True, text=True
    ).stdout.strip()
    dirty = subprocess.run(
        ["git", "-C", str(REPO), "status", "--porcelain", "src"], capture_output=True, text=True
    ).stdout.strip()
    revs = {"old": a.old_rev, "new": rev_new + ("+dirty" if dirty else "")}
    rows = []
    for size in a.sizes.split(","):
        slots = SIZES_DAYS[size] * RECORDS_PER_DAY
        table = wd / f"assignments_{size}.csv"
        if not table.exists():
            tile_records(a.assignments, table, slots)
        kept = sum(1 for _ in open(table)) - 1
        common = {"size": size, "campaign_rows": slots * HEIGHTS, "kept_rows": kept}
        ncs = {}
        for code in ("new", "old"):
            nc, js = wd / f"{size}_{code}.nc", wd / f"{size}_{code}.json"
            js.unlink(missing_ok=True)
            res = run_case(
                ["--child", "fit", "--child-args", str(table), str(nc), str(js)],
                srcs[code],
                a.max_rss_gb * 1024,
                a.max_minutes * 60,
            )
            child = json.loads(js.read_text()) if js.exists() else {}
            if not child:
                child = {"peak_rss_mb": res["polled_rss_mb"], "cpu_s": np.nan}
            rows.append({**common, "code": code, "rev": revs[code], "case": "fit", **res, **child})
            if res["status"] == "ok":
                ncs[code] = nc
            print(f"{size} {code} fit: {rows[-1]['status']}, wall {res['wall_s']:.1f} s, "
                  f"CPU {child['cpu_s']:.1f} s, peak {child['peak_rss_mb']:.0f} MB, "
                  f"load {res['load1_before']:.1f}->{res['load1_after']:.1f}", flush=True)  # fmt: skip
            pd.DataFrame(rows).to_csv(CSV, index=False)
        if len(ncs) == 2:
            cmp = compare(ncs["old"], ncs["new"])
            for row in rows[-2:]:
                row.update(cmp)
            print(f"{size}: draws identical {cmp['draws_identical']}, LOO max rel diff "
                  f"{cmp['loo_max_rel_diff']:.2e} (<= {a.loo_rtol:g}: "
                  f"{cmp['loo_max_rel_diff'] <= a.loo_rtol})", flush=True)  # fmt: skip
        for code in ("new", "old"):
            js = wd / f"{size}_{code}_lp.json"
            js.unlink(missing_ok=True)
            res = run_case(
                ["--child", "log_prob", "--child-args", str(table), str(js)],
                srcs[code],
                a.max_rss_gb * 1024,
                a.max_minutes * 60,
            )
            child = json.loads(js.read_text()) if js.exists() else {}
            rows.append(
                {**common, "code": code, "rev": revs[code], "case": "log_prob", **res, **child}
            )
            print(f"{size} {code} log_prob ({N_WALKERS} walkers): extra peak "
                  f"{child.get('call_extra_mb', np.nan):.0f} MB, call {child.get('call_s', np.nan):.2f} s",
                  flush=True)  # fmt: skip
            pd.DataFrame(rows).to_csv(CSV, index=False)
    df = pd.DataFrame(rows)
    df.to_csv(CSV, index=False)
    plot(df)
    print("\nold / new ratios (fit_global_record step):")
    for (size, case), g in df.groupby(["size", "case"], sort=False):
        o, n = g[g["code"] == "old"].iloc[0], g[g["code"] == "new"].iloc[0]
        col = "peak_rss_mb" if case == "fit" else "call_extra_mb"
        extra = "" if o["status"] == "ok" else f" (old {o['status']}: ratio is a lower bound)"
        print(f"  {size} {case}: {col} {o[col]:.0f} / {n[col]:.0f} MB = {o[col] / n[col]:.1f}x"
              + (f", CPU {o['cpu_s']:.1f} / {n['cpu_s']:.1f} s = {o['cpu_s'] / n['cpu_s']:.2f}x, "
                 f"wall {o['wall_s']:.1f} / {n['wall_s']:.1f} s" if case == "fit" else "")
              + extra)  # fmt: skip


if __name__ == "__main__":
    main()
