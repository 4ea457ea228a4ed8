"""Benchmark: how much of a floating lidar's per-record TI error a motion correction can remove.

A 10-min TI from a lidar scatters about the wind's own TI even on a fixed platform (its
sampling of the scan and of the probe volume in 10 minutes), and its std is a few per
cent above the point wind's (its response to turbulence). No correction that works from
the floating lidar's 10-min statistics can take that scatter out of one record. This
script measures, on the virtual campaigns' acceptance seeds (the same runs as
``tests/test_regimes*.py``, through ``validation.regimes.scenario_records``), the
per-record RMSE of the TI against the point truth (``ti_true``) of:

* the uncorrected floating lidar (``ti_uncorrected``);
* the floating lidar held still at its heading (``true_still_hws_std_ms /
  true_still_hws_mean_ms``, on its counted scans: the virtual campaign's lidar without its
  motion), as it is and with the campaign's median ratio of its TI to the truth divided
  out (its std ratio ``g``, which the correction's point target divides out too): the
  floor of any motion correction;
* the corrected TI (``ti_corrected_median``);
* each record's realised motion error variance subtracted (``true_sigma_z_ms``, against
  the same still lidar, known only in a virtual campaign) without the motion error's
  correlation with the wind, and the median ``g`` divided out: what knowing the realised
  sigma_Z alone would give.

and the share of the removable error each removes, ``(RMSE_uncorrected - RMSE) /
(RMSE_uncorrected - RMSE_floor)`` with the still lidar over ``g`` as the floor
(:func:`flidar_uq.data.metrics.removable_error_removed`; columns ``removable_removed_*``),
with the bias (mean deviation) of the uncorrected and the corrected TI beside it
(``md_*``, ``bias_removed`` = ``1 - |MD_corrected| / |MD_uncorrected|``). It also measures the motion's own
share (columns ``*_vs_motionless``): the per-record RMSE against the still lidar's TI of
the uncorrected TI and of the corrected TI brought back to the lidar's response (times the
point target's ``lidar_std_ratio``), the error that a motion correction is answerable for.
(The fixed reference lidar, ``true_ref_hws_*``, scans at a heading of 0: at a buoy's other
heading its TI differs from the still floating lidar's by the sampling of the turbulence
along other beams, not by the motion.)

Writes benchmarks/results/record_error_floor.csv and record_error_floor.png.

Usage: python benchmarks/record_error_floor.py [--workers W]
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pandas as pd  # noqa: E402
from _acceptance_runs import SCENARIO_OPTIONS, run_campaigns  # noqa: E402

from flidar_uq.data.metrics import mean_deviation, removable_error_removed  # noqa: E402
from flidar_uq.threads import single_threaded  # noqa: E402
from flidar_uq.validation.regimes import scenario_records  # noqa: E402

OUT = Path(__file__).parent / "results" / "record_error_floor"
#: The acceptance runs of tests/test_regimes*.py: scenario and seed.
RUNS = [
    *[
        (scenario, seed)
        for scenario in ("wave_follower", "wave_follower_weathervane")
        for seed in (505516003, 809183192)
    ],
    *[("discus_buoy", seed) for seed in (1572108785, 93494952)],
]
ESTIMATES = ("uncorrected", "motionless", "motionless_over_g", "realised_sigma_z", "corrected")
#: The estimates whose share of the removable error is reported (the floor's is 1).
REMOVING = ("motionless", "realised_sigma_z", "corrected")


@single_threaded
def one_run(scenario: str, seed: int) -> dict:
    """The per-record RMSE of each estimate on one campaign."""
    t0 = time.perf_counter()
    records, _ = scenario_records(scenario, seed, n_workers=1, **SCENARIO_OPTIONS[scenario])
    r = records[records["ti_corrected_median"].notna() & records["ti_true"].notna()]
    truth = r["ti_true"].to_numpy(dtype=float)
    still = (r["true_still_hws_std_ms"] / r["true_still_hws_mean_ms"]).to_numpy(dtype=float)
    g = float(np.median(still / truth))
    s, m = r["hws_std_ms"].to_numpy(dtype=float), r["hws_mean_ms"].to_numpy(dtype=float)
    sz = r["true_sigma_z_ms"].to_numpy(dtype=float)
    est = {
        "uncorrected": r["ti_uncorrected"].to_numpy(dtype=float),
        "motionless": still,
        "motionless_over_g": still / g,
        "realised_sigma_z": np.sqrt(np.clip(s**2 - sz**2, 0.0, None)) / m / g,
        "corrected": r["ti_corrected_median"].to_numpy(dtype=float),
    }
    with np.errstate(invalid="ignore"):
        rmse = {k: float(np.sqrt(np.mean((v - truth) ** 2))) for k, v in est.items()}
    row = {"scenario": scenario, "seed": seed, "records": len(r), "motionless_g": g}
    row |= {f"rmse_{k}": v for k, v in rmse.items()}
    floor = rmse["motionless_over_g"]
    row |= {
        f"removable_removed_{k}": removable_error_removed(rmse["uncorrected"], rmse[k], floor)
        for k in REMOVING
    }
    for k in ("uncorrected", "corrected"):
        row[f"md_{k}"] = mean_deviation(est[k], truth)
    row["bias_removed"] = 1.0 - abs(row["md_corrected"]) / abs(row["md_uncorrected"])
    # the motion's own share: against the motionless lidar, the corrected TI in its response
    lidar_level = est["corrected"] * r["lidar_std_ratio"].to_numpy(dtype=float)
    for k, v in (("uncorrected", est["uncorrected"]), ("corrected", lidar_level)):
        row[f"rmse_{k}_vs_motionless"] = float(np.sqrt(np.mean((v - still) ** 2)))
    row["removed_motion_error"] = 1.0 - (
        row["rmse_corrected_vs_motionless"] / row["rmse_uncorrected_vs_motionless"]
    )
    row["wall_s"] = time.perf_counter() - t0
    return row


def plot(tab: pd.DataFrame, path: Path) -> None:
    fig, ax = plt.subplots(figsize=(10, 4.5))
    labels = [f"{s}\n{seed}" for s, seed in zip(tab["scenario"], tab["seed"], strict=True)]
    x = np.arange(len(tab))
    width = 0.8 / len(REMOVING)
    for j, k in enumerate(REMOVING):
        v = 100 * tab[f"removable_removed_{k}"]
        ax.bar(x + (j - 1) * width, v, width, label=k.replace("_", " "))
    ax.axhline(100, color="k", ls="--", lw=0.8, label="the floor")
    ax.set_xticks(x, labels, fontsize=7)
    ax.set_ylabel("share of the removable per-record error removed, %")
    ax.set_title("per-record TI error removed; the floor: the floating lidar held still, over g")
    ax.legend(fontsize=7, ncol=3)
    fig.tight_layout()
    fig.savefig(path, dpi=90, metadata={"Software": None})
    plt.close(fig)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--workers", type=int, default=2, help="processes")
    args = ap.parse_args()
    OUT.parent.mkdir(exist_ok=True)
    t0 = time.perf_counter()

    def report(i: int, n: int, r: dict) -> None:
        print(
            f"[{i}/{n}] {r['scenario']} seed {r['seed']}: removed "
            + ", ".join(f"{k} {100 * r[f'removable_removed_{k}']:.0f} %" for k in REMOVING)
            + f" of the removable error; bias {r['md_uncorrected']:+.5f} -> "
            + f"{r['md_corrected']:+.5f}; of the motion's own error {100 * r['removed_motion_error']:.0f} %"
            + f" ({r['wall_s']:.0f} s)",
            flush=True,
        )

    tab = pd.DataFrame(run_campaigns(one_run, RUNS, workers=args.workers, report=report))
    tab.to_csv(f"{OUT}.csv", index=False)
    plot(tab, Path(f"{OUT}.png"))
    cols = ["scenario", "seed", *[f"rmse_{k}" for k in ESTIMATES]]
    cols += ["rmse_uncorrected_vs_motionless", "rmse_corrected_vs_motionless"]
    with pd.option_context("display.width", 200, "display.max_columns", 20):
        print(tab[cols].round(5).to_string(index=False))
    print(f"{time.perf_counter() - t0:.0f} s wall")


if __name__ == "__main__":
    main()
