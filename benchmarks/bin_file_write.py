"""Benchmark: writing a bin's posterior file the old way (pointwise log-likelihood) and as it
is now (pointwise LOO), side by side in one run (docs/performance.md).

Old (``_old_save`` below, a copy of the earlier encoding): the ArviZ DataTree with the
bin's (chain, draw, record) pointwise log-likelihood in float32 (11 MB for a bin of 2,700
records before compression). Now: :func:`flidar_uq.inference.save_fit`, which keeps the
PSIS-LOO the fit computed when it chose its motion model (``elpd_i``, ``pareto_k`` per
record) instead. Bins: the ``--nbins`` most populated fitted bins of a pipeline run
(``--assignments``, ``--table``; e.g. a year's), fitted here with the shipped
``config/config.yaml``. Per bin: the best of ``--repeats`` CPU times of each writer, the
file sizes, and a check that the new file's LOO is the fit's. Writes
``benchmarks/results/bin_file_write.csv`` and ``.png``.

Usage: ``python benchmarks/bin_file_write.py --assignments <run>/results/bins/assignments.csv
--table <run>/results/bins/table.csv``
"""

from __future__ import annotations

import argparse
import dataclasses
import tempfile
import time
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pandas as pd  # noqa: E402
import yaml  # noqa: E402
from timing import best_time  # noqa: E402

from flidar_uq import inference as inf  # noqa: E402
from flidar_uq.inference import results  # noqa: E402
from flidar_uq.threads import single_threaded  # noqa: E402
from flidar_uq.workflow.files import read_csv  # noqa: E402
from flidar_uq.workflow.inference_steps import _priors, _settings, bin_seed  # noqa: E402

REPO = Path(__file__).resolve().parents[1]
OUT = REPO / "benchmarks" / "results" / "bin_file_write"


def _old_save(fit, path) -> None:
    """The earlier save_fit of a BinFit: the pointwise log-likelihood kept in float32."""
    dt = dataclasses.replace(fit, pointwise_loo=None).to_datatree()
    for node in dt.subtree:
        for a in results._VOLATILE_ATTRS:
            node.attrs.pop(a, None)
    enc = results._encoding(dt)
    enc.setdefault("/log_likelihood", {}).setdefault("obs", dict(results._COMPRESSION))
    enc["/log_likelihood"]["obs"]["dtype"] = "float32"
    dt.to_netcdf(path, engine="h5netcdf", encoding=enc)


@single_threaded
def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--assignments", type=Path, required=True)
    ap.add_argument("--table", type=Path, required=True)
    ap.add_argument("--nbins", type=int, default=12)
    ap.add_argument("--repeats", type=int, default=3)
    args = ap.parse_args()
    cfg = yaml.safe_load((REPO / "config" / "config.yaml").read_text())
    assigned, table = read_csv(args.assignments), read_csv(args.table)
    fitted = table[table["fitted"].astype(bool)].sort_values("count", ascending=False)
    # every nbins-th bin down the counts: large and small bins alike
    step = max(1, len(fitted) // args.nbins)
    bins = fitted["bin_id"].astype(int).to_numpy()[::step][: args.nbins]
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for b in bins:
            recs = assigned[assigned["bin_id"] == b]
            fit = inf.fit_bin(
                recs,
                settings=_settings(cfg["inference"]),
                seed=bin_seed(cfg["inference"]["seed"], int(b)),
                priors=_priors(cfg["priors"]),
                bin_id=int(b),
            )
            old_p, new_p = Path(tmp) / f"old_{b}.nc", Path(tmp) / f"new_{b}.nc"
            t_old = best_time(
                lambda fit=fit, p=old_p: _old_save(fit, p),
                repeats=args.repeats,
                clock=time.process_time,
            )[0]
            t_new = best_time(
                lambda fit=fit, p=new_p: inf.save_fit(fit, p),
                repeats=args.repeats,
                clock=time.process_time,
            )[0]
            back = inf.load_fit(new_p)
            same_loo = all(
                np.array_equal(np.asarray(back.loo()[k]), np.asarray(fit.loo()[k]))
                for k in fit.loo()
            )
            rows.append(
                {
                    "bin_id": int(b),
                    "n_records": len(recs),
                    "model": fit.model,
                    "log_lik_values": int(np.asarray(fit.log_lik).size),
                    "old_cpu_s": t_old,
                    "new_cpu_s": t_new,
                    "ratio_old_over_new": t_old / t_new,
                    "old_mb": old_p.stat().st_size / 1e6,
                    "new_mb": new_p.stat().st_size / 1e6,
                    "loo_equal": same_loo,
                }
            )
            r = rows[-1]
            print(
                f"bin {b:4d} ({r['n_records']:5d} records, {r['model']}): old "
                f"{t_old:.3f} s {r['old_mb']:.2f} MB, new {t_new:.3f} s {r['new_mb']:.2f} MB, "
                f"ratio {r['ratio_old_over_new']:.2f}, LOO kept exactly: {same_loo}",
                flush=True,
            )
    t = pd.DataFrame(rows)
    print(
        f"total over {len(t)} bins: old {t.old_cpu_s.sum():.2f} s CPU, {t.old_mb.sum():.1f} MB;"
        f" new {t.new_cpu_s.sum():.2f} s CPU, {t.new_mb.sum():.1f} MB; ratio "
        f"{t.old_cpu_s.sum() / t.new_cpu_s.sum():.2f} (CPU), {t.old_mb.sum() / t.new_mb.sum():.1f}"
        " (size)"
    )
    OUT.parent.mkdir(parents=True, exist_ok=True)
    t.to_csv(OUT.with_suffix(".csv"), index=False, float_format="%.6g")
    fig, axes = plt.subplots(1, 2, figsize=(9, 3.6))
    for ax, (old, new, unit) in zip(
        axes,
        [("old_cpu_s", "new_cpu_s", "CPU per file (s)"), ("old_mb", "new_mb", "file (MB)")],
        strict=True,
    ):
        ax.scatter(t.n_records, t[old], label="old (log-likelihood, float32)")
        ax.scatter(t.n_records, t[new], label="now (pointwise LOO)")
        ax.set_xlabel("records in the bin")
        ax.set_ylabel(unit)
        ax.set_yscale("log")
    axes[0].legend(fontsize=8)
    fig.suptitle("writing a bin's posterior file")
    fig.tight_layout()
    fig.savefig(OUT.with_suffix(".png"), dpi=110)


if __name__ == "__main__":
    main()
