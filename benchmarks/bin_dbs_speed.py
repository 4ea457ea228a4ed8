"""Benchmark: the bin motion model's sigma_Z for a pulsed DBS lidar against a CW lidar's, side by side in one run.

The bin model evaluates sigma_Z over posterior draws in three places; each is timed with
the ZephIR 300 (``cw``: the surrogate's rotational sigma_Z plus the VAD form of the head
translation) and the WindCube v2 (``dbs``: its beam-pair terms,
:func:`flidar_uq.physics.dbs_sigma_z.dbs_tilt_lever_terms`, at each record's wind
direction relative to the beams; ``dbs_heading_unknown``: averaged over headings):

- ``moments``: :func:`flidar_uq.inference.record_sigma_z_moments` (the global fit's input,
  200 draws a bin);
- ``likelihood``: one :func:`flidar_uq.inference.log_prob_global` call of the lever-arm +
  motion-scale model at 64 walkers (the cross term for the DBS lidar);
- ``propagation``: :func:`flidar_uq.correction.propagation.draw_corrected_ti` with the
  lever-arm + motion-scale model (the config's 1000 draws a record).

Bins of the default campaign's size (141 bins, 64 of them two-period, 22,300 records) and
a small campaign (20 bins, 2,000 records); the bins' posterior draws are synthetic
(4 x 250 draws about each bin's amplitude and period), the records' wind speeds and
directions uniform, the heading fixed at 30 deg with a 5-deg scatter. The best of
``--repeats`` wall times per case and the ratio DBS / CW; beside them the one-off build
of the DBS lidar's table over the period (``table_build``). Writes
``benchmarks/results/bin_dbs_speed.csv`` and ``.png``.

Usage: ``PYTHONPATH=src python benchmarks/bin_dbs_speed.py [--repeats 3]``
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
from _timing import best_time  # noqa: E402

from flidar_uq.correction.propagation import PropagationSettings, draw_corrected_ti  # noqa: E402
from flidar_uq.inference import (  # noqa: E402
    BinFit,
    GlobalFit,
    log_prob_global,
    record_sigma_z_moments,
)
from flidar_uq.physics import dbs_sigma_z as dbs  # noqa: E402
from flidar_uq.physics.surrogate import get_surrogate  # noqa: E402
from flidar_uq.threads import single_threaded  # noqa: E402

REPO = Path(__file__).resolve().parents[1]
OUT = REPO / "benchmarks" / "results" / "bin_dbs_speed"
SHAPE = (4, 250)
CASES = {"cw": "zephir300", "dbs": "windcube_v2", "dbs_heading_unknown": "windcube_v2"}


def _bin_fit(bin_id, rng, two_period):
    """Synthetic posterior draws of one bin about a random amplitude (deg) and period (s)."""

    def around(centre, sd):
        return centre * np.exp(sd * rng.standard_normal(SHAPE))

    amp, per = rng.uniform(1.0, 6.0), rng.uniform(2.5, 8.0)
    draws = {
        "amplitude_deg": around(amp, 0.05),
        "scatter_amplitude": np.full(SHAPE, 0.1),
        "scatter_period": np.full(SHAPE, 0.1),
    }
    if two_period:
        draws |= {
            "period1_s": around(per, 0.03),
            "period2_s": around(per + rng.uniform(3.0, 6.0), 0.03),
            "weight1": np.clip(rng.normal(0.6, 0.05, SHAPE), 0.05, 0.95),
            "weight_concentration": np.full(SHAPE, 10.0),
        }
    else:
        draws["period_s"] = around(per, 0.03)
    info = {"bin_id": bin_id, "model": "two_period" if two_period else "unimodal",
            "n_records": 1, "n_imu": 1, "prior_only": False, "loo": {}}  # fmt: skip
    return BinFit(draws, np.zeros(SHAPE + (1,)), {}, [], info)


def _campaign(n_bins, n_two, n_records, seed):
    rng = np.random.default_rng(np.random.SeedSequence(seed))
    fits = [_bin_fit(b, rng, b < n_two) for b in range(n_bins)]
    hws = rng.uniform(3.0, 20.0, n_records)
    records = pd.DataFrame(
        {
            "bin_id": rng.integers(0, n_bins, n_records),
            "hws_mean_ms": hws,
            "hws_std_ms": 0.1 * hws * (1.0 + 0.3 * rng.random(n_records)),
            "ref_hws_std_ms": 0.1 * hws,
            "wd_mean_deg": rng.uniform(0.0, 360.0, n_records),
            "heading_mean_deg": 30.0 + rng.normal(0.0, 5.0, n_records),
        }
    )
    fields = ("rho", "tau0_ms", "kappa", "lever_arm_m", "motion_scale")
    centre = (0.02, 0.02, 0.05, 2.0, 1.0)
    gf = GlobalFit(
        draws={n: c * np.exp(0.02 * rng.standard_normal(SHAPE)) for n, c in zip(fields, centre, strict=True)},
        log_lik=None, diagnostics={}, failure_reasons=[],
        info={"n_records": n_records, "prior_only": False, "loo": {}},
    )  # fmt: skip
    return fits, records, gf


def _steps(fits, records, gf, lidar):
    """The three timed calls of one lidar, as closures."""
    sur = get_surrogate(lidar)
    walkers = np.column_stack(
        [np.full(64, 0.02), np.full(64, np.log(0.02)), np.full(64, np.log(0.05)),
         np.linspace(1.5, 2.5, 64), np.zeros(64)]
    )  # fmt: skip
    szm, szv, u2, corr = record_sigma_z_moments(records, fits, surrogate=sur, seed=1)
    s, r = records["hws_std_ms"].to_numpy(), records["ref_hws_std_ms"].to_numpy()
    settings = PropagationSettings(ndraws=1000, lidar=lidar)
    return {
        "moments": lambda: record_sigma_z_moments(records, fits, surrogate=sur, seed=1),
        "likelihood": lambda: log_prob_global(walkers, s, r, szm, szv, u2=u2, corr=corr),
        "propagation": lambda: draw_corrected_ti(
            records, fits, gf, surrogate=sur, settings=settings, seed=2
        ),
    }


@single_threaded
def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=3)
    args = ap.parse_args()
    for lidar in set(CASES.values()):
        get_surrogate(lidar)  # built once, not timed
    dbs._tilt_lever_table.cache_clear()
    t0 = time.perf_counter()
    dbs.dbs_tilt_lever_terms(8.0, 3.0, 4.0, lidar=CASES["dbs"])
    build = time.perf_counter() - t0
    print(f"DBS table of {dbs._TABLE_PERIODS} periods built once per lidar in {build:.2f} s")
    rows = [{"campaign": "any", "step": "table_build", "dbs_s": build}]
    for name, (n_bins, n_two, n_records) in {
        "default campaign": (141, 64, 22_300),
        "small campaign": (20, 6, 2_000),
    }.items():
        fits, records, gf = _campaign(n_bins, n_two, n_records, seed=7)
        times = {}
        for case, lidar in CASES.items():
            rec = records.assign(heading_mean_deg=np.nan) if case.endswith("unknown") else records
            for step, fn in _steps(fits, rec, gf, lidar).items():
                times[case, step] = best_time(fn, repeats=args.repeats)[0]
        for step in ("moments", "likelihood", "propagation"):
            row = {"campaign": name, "n_bins": n_bins, "n_records": n_records, "step": step}
            row |= {f"{case}_s": times[case, step] for case in CASES}
            row |= {f"ratio_{case}_over_cw": times[case, step] / times["cw", step]
                    for case in CASES if case != "cw"}  # fmt: skip
            rows.append(row)
            print(
                f"{name:16s} {step:11s}: cw {row['cw_s']:7.3f} s, dbs {row['dbs_s']:7.3f} s "
                f"(x{row['ratio_dbs_over_cw']:.2f}), heading unknown "
                f"{row['dbs_heading_unknown_s']:7.3f} s (x{row['ratio_dbs_heading_unknown_over_cw']:.2f})"
            )
    table = pd.DataFrame(rows)
    OUT.parent.mkdir(parents=True, exist_ok=True)
    table.to_csv(OUT.with_suffix(".csv"), index=False, float_format="%.6g")
    fig, axes = plt.subplots(1, 2, figsize=(9.0, 3.6), sharey=True)
    steps = table[table["step"] != "table_build"]
    for ax, (name, t) in zip(axes, steps.groupby("campaign", sort=False), strict=True):
        x = np.arange(len(t))
        for k, case in enumerate(CASES):
            ax.bar(x + (k - 1) * 0.27, t[f"{case}_s"], 0.27, label=case.replace("_", " "))
        ax.set_xticks(x, t["step"])
        ax.set_yscale("log")
        ax.set_title(
            f"{name}: {int(t['n_bins'].iloc[0])} bins, {int(t['n_records'].iloc[0]):,} records"
        )
    axes[0].set_ylabel("wall time (s, best of repeats)")
    axes[0].legend(fontsize=8)
    fig.suptitle("bin motion model: sigma_Z of a DBS lidar (beam-pair terms) vs a CW lidar")
    fig.tight_layout()
    fig.savefig(OUT.with_suffix(".png"), dpi=110)


if __name__ == "__main__":
    main()
