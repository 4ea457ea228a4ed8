"""A DBS lidar's 10-min motion error, once a cycle or at every beam: its spread about the record model.

A pulsed DBS lidar can report its wind once a cycle (the four inclined beams and the
vertical one, 5 s for a WindCube v2) or at every beam, each new beam replacing the oldest
of its azimuth in the retrieval (about 1 s a value: the WindCube v2's 1-s real-time data,
and Yamaguchi & Ishihara 2016's estimates every second). The WindCube v2's geometry
(``every_beam_output``) takes the second, in the virtual campaign, the replay and the record
model (the mean over the windows' beam orders); a lidar that reports once a cycle, the
first. Sampled once a cycle, a swell near twice the cycle (10 s) is sampled
near its Nyquist period: each record's realised motion error then depends on the phase at
which the cycles meet the waves, which no 10-min statistic holds, so it strays from the
record model's expectation however well the record's tilt bands are known.

For swells of peak period 4-12 s (a heaving sea: JONSWAP gamma 6, 10 deg spread, across
the wind) on a wave-following hull with the head 2 m above its rotation centre, 8 m/s
blowing 30 deg off a beam, ``N_REC`` ten-minute records a period:

- ``cycle``: the realised ``Z = HWS - U`` variance of the record, its motion replayed line
  of sight by line of sight (each beam the mean over its dwell, as the virtual campaign;
  :func:`flidar_uq.physics.dbs_sigma_z.dbs_replay_sigma_z_ms`), one value a cycle;
- ``beam``: the same lines of sight, one value at every beam from the latest beam of each
  azimuth (``every_beam=True``);
- ``model_cycle``, ``model_beam``: the record model's sigma_Z^2 of the record (its IMU
  series reduced to the tilt bands of the record table,
  :func:`flidar_uq.inference.record_motion.motion_gram` at the truth: motion scale 1, lever
  arm 2 m, hull response 1) for the lidar once a cycle and after every beam.

Per period: the mean and the relative spread (std / mean over the records) of
``cycle / model_cycle`` and ``beam / model_beam``; the once-a-cycle spread beyond the every-beam one
at 7-8 s, far from one and two cycles (``aliasing_spread``), against the record model's
(``predicted_spread``: the rms over the records of
:func:`flidar_uq.physics.dbs_sigma_z.cycle_sampling_rel_var` of their tilt bands, which
the record fit and the propagation add to the motion error's scatter). The spread is what a
10-min record's point estimate cannot know; it enters the corrected TI most where the
motion error is several times the turbulence.

Run:  PYTHONPATH=src OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 python benchmarks/dbs_output_sampling.py
Writes benchmarks/results/dbs_output_sampling.csv and .png.
"""

from __future__ import annotations

import dataclasses
import time
from pathlib import Path

import numpy as np
import pandas as pd

from flidar_uq.data.imu import tilt_band_statistics, tilt_spectrum_columns
from flidar_uq.inference.record_motion import SAMPLING_COLUMN, gram_sigma_z_ms, motion_gram
from flidar_uq.physics import dbs_sigma_z as dbs
from flidar_uq.physics.lidar import get_lidar
from flidar_uq.physics.seastate import WaveSystem, hull_motion_series

OUT = Path(__file__).resolve().parent / "results"
DT_S = 0.05
RECORD_S = 600.0
N_REC = 96
DWELL_SAMPLES = 10
LEVER_M = 2.0
HWS_MS = 8.0
WIND_BODY_DEG = 30.0  # the wind blows towards 30 deg from the body x axis (a beam at 0)
LIDAR = "windcube_v2"
PERIODS_S = (4.0, 4.5, 5.0, 5.5, 6.0, 7.0, 8.0, 9.0, 9.5, 10.0, 10.5, 11.0, 12.0)
SEED = 20261206
BASE_PERIODS_S = (7.0, 8.0)  # far from one and two cycles


def replay_both(t, roll, pitch, trans, wd_deg):
    """Realised ``Var Z`` (m/s)^2 of one record, one value a cycle and one at every beam."""
    return tuple(
        dbs.dbs_replay_sigma_z_ms(
            t, roll, pitch, hws_ms=HWS_MS, wd_deg=wd_deg, lever_arm_m=LEVER_M,
            translation_m=trans, lidar=LIDAR, dwell_samples=DWELL_SAMPLES, every_beam=beam,
        ) ** 2
        for beam in (False, True)
    )  # fmt: skip


def model_var(roll, pitch, heave_velocity, wd_deg, g):
    """The record model's sigma_Z^2 (m/s)^2 of records (n_records, n_samples) at the truth
    for the lidar ``g``, and its relative variance of the realised Var Z from the
    retrieval once an output interval (four times the Gram's ``SAMPLING_COLUMN``)."""
    spec = tilt_band_statistics(
        roll, pitch, 0.0, np.full(roll.shape[0], wd_deg), 1.0 / DT_S,
        velocity_up_ms=heave_velocity,
    )  # fmt: skip
    rec = pd.DataFrame(tilt_spectrum_columns(spec)).assign(
        wd_mean_deg=wd_deg, heading_mean_deg=0.0, hws_mean_ms=HWS_MS
    )
    gram = motion_gram(rec, lidar=g)
    var = gram_sigma_z_ms(gram, lever_arm_m=LEVER_M, hull_response=1.0, motion_scale=1.0) ** 2
    return var, 4.0 * gram[SAMPLING_COLUMN].to_numpy()


def main() -> None:
    t0 = time.perf_counter()
    g = get_lidar(LIDAR)
    g_once = dataclasses.replace(g, every_beam_output=False)
    rng = np.random.default_rng(np.random.SeedSequence(SEED))
    n10 = int(RECORD_S / DT_S)
    t = np.arange(n10) * DT_S
    wd = float(dbs.wind_to_body_deg(WIND_BODY_DEG))
    rows = []
    for tp in PERIODS_S:
        sea = [WaveSystem(2.0, tp, 6.0, WIND_BODY_DEG + 90.0, 10.0)]
        m = hull_motion_series(n10 * N_REC, DT_S, sea, rng, "wave_follower")
        roll, pitch = (m[c].reshape(N_REC, n10) for c in ("roll_deg", "pitch_deg"))
        trans = np.column_stack([m["surge_m"], m["sway_m"], m["heave_m"]]).reshape(N_REC, n10, 3)
        w_up = np.gradient(m["heave_m"], DT_S).reshape(N_REC, n10)
        model_cycle, rel_var = model_var(roll, pitch, w_up, wd, g_once)
        model_beam = model_var(roll, pitch, w_up, wd, g)[0]
        for i in range(N_REC):
            cyc, beam = replay_both(t, roll[i], pitch[i], trans[i], wd)
            rows.append(
                dict(
                    period_s=tp,
                    record=i,
                    model_cycle=model_cycle[i],
                    model_beam=model_beam[i],
                    rel_var=rel_var[i],
                    cycle=cyc,
                    beam=beam,
                )
            )
    df = pd.DataFrame(rows)
    df["cycle_ratio"] = df["cycle"] / df["model_cycle"]
    df["beam_ratio"] = df["beam"] / df["model_beam"]
    summary = df.groupby("period_s").agg(
        cycle_mean=("cycle_ratio", "mean"),
        cycle_spread=("cycle_ratio", lambda x: x.std() / x.mean()),
        beam_mean=("beam_ratio", "mean"),
        beam_spread=("beam_ratio", lambda x: x.std() / x.mean()),
        predicted_rel_var=("rel_var", "mean"),
    )
    summary["spread_ratio_cycle_to_beam"] = summary["cycle_spread"] / summary["beam_spread"]
    # the once-a-cycle spread beyond that of the periods that neither cycle aliases
    # (every beam at 7-8 s), against the record model's
    base = summary.loc[list(BASE_PERIODS_S), "beam_spread"].mean()
    summary["aliasing_spread"] = np.sqrt(np.maximum(summary["cycle_spread"] ** 2 - base**2, 0.0))
    summary["predicted_spread"] = np.sqrt(summary.pop("predicted_rel_var"))
    OUT.mkdir(exist_ok=True)
    summary.reset_index().to_csv(OUT / "dbs_output_sampling.csv", index=False, float_format="%.4f")
    print(summary.to_string(float_format=lambda v: f"{v:.3f}"))
    near = summary.loc[[9.5, 10.0, 10.5]]
    away = summary.loc[[6.0, 7.0, 8.0]]
    print(
        f"\nrealised / model Var Z, relative spread over {N_REC} records a period: once a cycle "
        f"{near.cycle_spread.mean():.3f} at 9.5-10.5 s vs {away.cycle_spread.mean():.3f} at "
        f"6-8 s; at every beam {near.beam_spread.mean():.3f} vs {away.beam_spread.mean():.3f} "
        f"(near 10 s once a cycle / every beam: {near.cycle_spread.mean() / near.beam_spread.mean():.2f}x)"
    )
    one = summary.loc[[4.5, 5.0, 5.5]]
    print(
        "spread beyond the every-beam one at 7-8 s, measured vs the record model's "
        f"(cycle_sampling_rel_var): 9.5-10.5 s {near.aliasing_spread.mean():.3f} vs "
        f"{near.predicted_spread.mean():.3f}; 4.5-5.5 s {one.aliasing_spread.mean():.3f} vs "
        f"{one.predicted_spread.mean():.3f}; 7-8 s "
        f"{summary.loc[list(BASE_PERIODS_S), 'predicted_spread'].mean():.3f} predicted"
    )
    print(
        "mean realised / model Var Z over the periods (each against its own record model): "
        f"once a cycle {summary.cycle_mean.min():.3f}-{summary.cycle_mean.max():.3f}, after "
        f"every beam {summary.beam_mean.min():.3f}-{summary.beam_mean.max():.3f}"
    )
    print(f"wall {time.perf_counter() - t0:.0f} s")
    _plot(summary)


def _plot(summary: pd.DataFrame) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 2, figsize=(11, 4.2))
    p = summary.index.to_numpy()
    for col, label in (("cycle", "once a cycle (5 s)"), ("beam", "at every beam (1 s)")):
        axes[0].plot(p, summary[f"{col}_spread"], "o-", label=label)
        axes[1].plot(p, summary[f"{col}_mean"], "o-", label=label)
    base = summary.loc[list(BASE_PERIODS_S), "beam_spread"].mean()
    axes[0].plot(
        p,
        np.sqrt(base**2 + summary["predicted_spread"] ** 2),
        "k--",
        label="record model once a cycle (its sampling term over the 7-8 s spread)",
    )
    for ax in axes:
        ax.axvline(2 * get_lidar(LIDAR).scan_period_s, color="0.6", ls=":", lw=1)
        ax.axvline(get_lidar(LIDAR).scan_period_s, color="0.6", ls=":", lw=1)
        ax.set_xlabel("swell peak period (s)")
        ax.legend(fontsize=8)
    axes[0].set_ylabel("std / mean of realised / model Var Z over records (-)")
    axes[1].set_ylabel("mean realised / model Var Z (-)")
    fig.suptitle(
        f"WindCube v2 on a wave follower, {HWS_MS:g} m/s, heaving swell across the wind, "
        f"{N_REC} ten-minute records a period (dotted: one and two cycles)",
        fontsize=9,
    )
    fig.tight_layout()
    fig.savefig(OUT / "dbs_output_sampling.png", dpi=110)


if __name__ == "__main__":
    main()
