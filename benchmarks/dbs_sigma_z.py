"""sigma_Z of a pulsed DBS lidar on a moving hull: the record model's description against replay.

For each DBS lidar (``windcube_v2``, ``windcube_v1``, ``windcube_v2_1``), sea (a JONSWAP
wind sea, a short wind sea, wind sea plus a swell across or against the wind, a swell alone
across the wind: a "heaving sea"), hull (``wave_follower``, ``discus_buoy``,
``rotation_only``), heading (the wind blowing towards 0, 45, ..., 315 deg from the body x
axis: along a beam or between two) and HWS (5, 10, 15 m/s), with the head 2 m above the
rotation centre, ``N_REC`` ten-minute records of the six-degree-of-freedom motion of
:func:`flidar_uq.physics.seastate.hull_motion_series`:

- ``replay``: realised sigma_Z, the motion replayed line of sight by line of sight through
  the scan simulator with the DBS geometry, each beam's radial speed the mean over its
  dwell (the pulse accumulation, as the virtual campaign and the instrument;
  :func:`flidar_uq.physics.dbs_sigma_z.dbs_replay_sigma_z_ms` with ``dwell_samples``): the
  reference;
- ``components``: the harmonic sum :func:`flidar_uq.physics.dbs_sigma_z.dbs_harmonic_sigma_z_ms`
  over the realised Fourier components (amplitude, period, direction), the first-order
  spectral sum itself;
- ``record``: what the record model computes for these records: the IMU series (roll,
  pitch, the heave velocity) reduced by the data layer to the record table's tilt bands
  (:func:`flidar_uq.data.imu.tilt_band_statistics`, :func:`~flidar_uq.data.imu.tilt_spectrum_columns`),
  then :func:`flidar_uq.inference.record_motion.motion_gram` with the lidar and the record's
  wind direction and heading, at the truth's motion scale 1, lever arm 2 m and hull
  response (1 for the wave follower, 0 for the buoy that only rotates; the discus buoy's
  period-dependent response is not the record model's, so it has no ``record`` value);
- ``record_one_node``: the same with each band at its centroid period alone (one node, not
  the three of :func:`flidar_uq.physics.motion_spectrum.sub_band_nodes`);
- ``record_no_side``: the same without the bands' measured ``<sin psi>`` (the side of the
  wind a band's waves run on);
- ``heading_avg``: the record model with the heading unknown (averaged over headings)
  against the replay's rms over the eight headings, per (lidar, sea, hull, HWS).

Ratios are ``sqrt(mean(s_method^2) / mean(s_replay^2))`` over the records of a case. The
speeds of the record model's description (records/s: 8 bands, 3 nodes each) and of the
replay (10-min records/s) are measured in the same run.

Run:  PYTHONPATH=src OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 python benchmarks/dbs_sigma_z.py
      (``--check``: exit status 1 unless every ``record`` and ``components`` ratio is within
      5 %)
Writes benchmarks/results/dbs_sigma_z.csv, dbs_sigma_z_heading_average.csv and .png.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np
import pandas as pd

from flidar_uq.data.imu import tilt_band_statistics, tilt_spectrum_columns
from flidar_uq.inference.record_motion import gram_sigma_z_ms, motion_gram
from flidar_uq.physics import dbs_sigma_z as dbs
from flidar_uq.physics.seastate import WaveSystem, hull_motion_series

OUT = Path(__file__).resolve().parent / "results"
DT_S = 0.05
RECORD_S = 600.0
N_REC = 36  # six hours a case: the replay's own sampling noise ~1.5 %
DWELL_SAMPLES = 10
LEVER_M = 2.0
LIDARS = ("windcube_v2", "windcube_v1", "windcube_v2_1")
HULL_NAMES = ("wave_follower", "discus_buoy", "rotation_only")
HULL_RESPONSE = {"wave_follower": 1.0, "rotation_only": 0.0}
HWS = (5.0, 10.0, 15.0)
WIND_BODY_DEG = tuple(45.0 * k for k in range(8))  # the wind blows towards this body direction
SEED = 20261204
METHODS = ("components", "record", "record_one_node", "record_no_side")
TOLERANCE = 0.05

# wave directions of travel relative to the wind's (0: downwind); rotated with the wind
SEAS = {
    "windsea": [WaveSystem(3.0, 4.0, 3.3, 0.0, 30.0)],
    "windsea_short": [WaveSystem(3.0, 3.0, 3.3, 0.0, 30.0)],
    "swell_across": [WaveSystem(2.4, 4.0, 3.3, 0.0, 30.0), WaveSystem(1.8, 9.0, 6.0, 90.0, 10.0)],
    "swell_against": [WaveSystem(2.4, 4.0, 3.3, 0.0, 30.0), WaveSystem(1.8, 9.0, 6.0, 180.0, 10.0)],
    "heaving_sea": [WaveSystem(2.0, 8.0, 6.0, 90.0, 10.0)],
}


def _rotated(systems, deg):
    return [
        WaveSystem(s.amplitude_deg, s.tp_s, s.gamma, s.direction_deg + deg, s.spread_deg)
        for s in systems
    ]


def record_table(roll_deg, pitch_deg, velocity_up_ms, wd_deg) -> pd.DataFrame:
    """The records' tilt bands as the data layer writes them from an IMU series (heading 0:
    the body axes are east and north), shape (n_records, n_samples) inputs."""
    spec = tilt_band_statistics(
        roll_deg, pitch_deg, 0.0, np.full(roll_deg.shape[0], wd_deg), 1.0 / DT_S,
        velocity_up_ms=velocity_up_ms,
    )  # fmt: skip
    rec = pd.DataFrame(tilt_spectrum_columns(spec))
    return rec.assign(wd_mean_deg=wd_deg, heading_mean_deg=0.0)


def _record_sigma_z(rec, hws, lidar, hull, *, heading=True, nodes=3, side=True):
    """sigma_Z (m/s) of the record model's description of ``rec`` (:func:`record_table`)."""
    rec = rec.assign(hws_mean_ms=hws)
    if not heading:
        rec = rec.assign(heading_mean_deg=np.nan)
    if not side:
        rec = rec.drop(columns=[c for c in rec if c.endswith("_sin_psi")])
    gram = motion_gram(rec, lidar=lidar, band_nodes=nodes)
    return gram_sigma_z_ms(
        gram, lever_arm_m=LEVER_M, hull_response=HULL_RESPONSE[hull], motion_scale=1.0
    )


def _case_rows(rng, sea, hull, beta, lidar_rows):
    n10 = int(RECORD_S / DT_S)
    wd = float(dbs.wind_to_body_deg(beta))  # wind_to_body is its own inverse at yaw 0
    m = hull_motion_series(
        n10 * N_REC, DT_S, _rotated(SEAS[sea], beta), rng, hull, return_components=True
    )
    comp = m["components"]
    a_c = comp["amplitude_deg"].ravel()
    keep = a_c > 1e-4 * a_c.max()
    a_c, p_c, d_c = a_c[keep], comp["period_s"].ravel()[keep], comp["direction_deg"].ravel()[keep]
    trans = np.column_stack([m["surge_m"], m["sway_m"], m["heave_m"]])
    t = np.arange(n10) * DT_S
    roll, pitch = (m[k].reshape(N_REC, n10) for k in ("roll_deg", "pitch_deg"))
    rec = record_table(roll, pitch, np.gradient(m["heave_m"], DT_S).reshape(N_REC, n10), wd)
    for lidar in LIDARS:
        for hws in HWS:
            rep = np.array(
                [
                    dbs.dbs_replay_sigma_z_ms(
                        t,
                        roll[i],
                        pitch[i],
                        hws_ms=hws,
                        wd_deg=wd,
                        lever_arm_m=LEVER_M,
                        translation_m=trans[i * n10 : (i + 1) * n10],
                        lidar=lidar,
                        dwell_samples=DWELL_SAMPLES,
                    )  # fmt: skip
                    for i in range(N_REC)
                ]
            )
            row = dict(lidar=lidar, sea=sea, hull=hull, wind_body_deg=beta, hws_ms=hws)
            row["replay_ms"] = float(np.sqrt(np.mean(rep**2)))
            row["components"] = float(
                dbs.dbs_harmonic_sigma_z_ms(
                    a_c,
                    p_c,
                    d_c,
                    hws_ms=hws,
                    wind_body_deg=beta,
                    lever_arm_m=LEVER_M,
                    hull=hull,
                    lidar=lidar,
                    dwell_average=True,
                )  # fmt: skip
            )
            if hull in HULL_RESPONSE:
                for col, kw in (
                    ("record", {}),
                    ("record_one_node", {"nodes": 1}),
                    ("record_no_side", {"side": False}),
                    ("heading_unknown", {"heading": False}),
                ):
                    row[col] = float(
                        np.sqrt(np.mean(_record_sigma_z(rec, hws, lidar, hull, **kw) ** 2))
                    )
            lidar_rows.append(row)


def _speeds(rng) -> tuple[float, float]:
    """Records/s of the record model's DBS description (8 bands x 3 nodes, heading known)
    and of the replay of a 10-min record."""
    n10 = int(RECORD_S / DT_S)
    m = hull_motion_series(n10 * 20, DT_S, SEAS["swell_across"], rng, "wave_follower")
    roll, pitch = (m[k].reshape(20, n10) for k in ("roll_deg", "pitch_deg"))
    rec = record_table(roll, pitch, np.gradient(m["heave_m"], DT_S).reshape(20, n10), 270.0)
    rec = pd.concat([rec] * 500, ignore_index=True).assign(hws_mean_ms=10.0)
    motion_gram(rec.iloc[:20], lidar="windcube_v2")
    t1 = time.perf_counter()
    motion_gram(rec, lidar="windcube_v2")
    gram_rate = len(rec) / (time.perf_counter() - t1)
    trans = np.column_stack([m["surge_m"], m["sway_m"], m["heave_m"]])[:n10]
    t = np.arange(n10) * DT_S
    t1 = time.perf_counter()
    for _ in range(3):
        dbs.dbs_replay_sigma_z_ms(
            t, roll[0], pitch[0], hws_ms=10.0, wd_deg=270.0, lever_arm_m=LEVER_M,
            translation_m=trans, dwell_samples=DWELL_SAMPLES,
        )  # fmt: skip
    return gram_rate, 3.0 / (time.perf_counter() - t1)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--check", action="store_true", help="exit 1 unless within 5 %%")
    args = ap.parse_args(argv)
    rng = np.random.default_rng(np.random.SeedSequence(SEED))
    rows: list[dict] = []
    t0 = time.perf_counter()
    for sea in SEAS:
        for hull in HULL_NAMES:
            for beta in WIND_BODY_DEG:
                _case_rows(rng, sea, hull, beta, rows)
        print(f"{sea}: done ({time.perf_counter() - t0:.0f} s)", flush=True)
    df = pd.DataFrame(rows)
    summary = df.copy()
    for c in (*METHODS, "heading_unknown"):
        summary[c] = df[c] / df["replay_ms"]
    avg = (
        df[df.hull.isin(list(HULL_RESPONSE))]
        .groupby(["lidar", "sea", "hull", "hws_ms"])
        .apply(
            lambda g: pd.Series(
                {
                    "heading_avg": float(
                        np.sqrt(np.mean(g["heading_unknown"] ** 2) / np.mean(g["replay_ms"] ** 2))
                    ),
                    "replay_heading_cv": float(g["replay_ms"].std() / g["replay_ms"].mean()),
                }
            ),
            include_groups=False,
        )
        .reset_index()
    )
    gram_rate, replay_rate = _speeds(rng)
    summary["record_per_s"] = gram_rate
    summary["replay_records_per_s"] = replay_rate
    OUT.mkdir(exist_ok=True)
    summary.drop(columns=["heading_unknown"]).to_csv(
        OUT / "dbs_sigma_z.csv", index=False, float_format="%.4f"
    )
    avg.to_csv(OUT / "dbs_sigma_z_heading_average.csv", index=False, float_format="%.4f")
    ok = True
    for col in METHODS:
        r = summary[col].dropna()
        within = np.mean(np.abs(r - 1.0) <= TOLERANCE)
        print(
            f"{col}: ratio to replay {r.min():.3f}-{r.max():.3f}, median {r.median():.3f}, "
            f"{100 * within:.1f} % of {r.size} cases within 5 %"
        )
        for lidar in LIDARS:
            g = summary[summary.lidar == lidar][col].dropna()
            print(f"  {lidar}: {g.min():.3f}-{g.max():.3f}")
        if col in ("components", "record"):
            ok &= bool(within == 1.0)
    worst = summary.assign(err=(summary["record"] - 1.0).abs()).nlargest(8, "err")
    print(worst[["lidar", "sea", "hull", "wind_body_deg", "hws_ms", "replay_ms", *METHODS]])
    h = avg["heading_avg"]
    print(
        f"heading unknown: ratio to the replay's rms over headings {h.min():.3f}-{h.max():.3f}; "
        f"the replay's spread over headings {100 * avg['replay_heading_cv'].median():.0f} % "
        "(median)"
    )
    print(
        f"record model's description {gram_rate:,.0f} records/s (8 bands x 3 nodes), replay "
        f"{replay_rate:.1f} records/s (10 min, {DT_S} s motion, {DWELL_SAMPLES} instants a "
        f"beam): x{gram_rate / replay_rate:,.0f}"
    )
    _plot(summary)
    return 0 if ok or not args.check else 1


def _plot(summary: pd.DataFrame) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, len(LIDARS), figsize=(16, 5), sharey=True)
    seas = list(SEAS)
    for ax, lidar in zip(axes, LIDARS, strict=True):
        g = summary[summary.lidar == lidar]
        for k, (hull, mk) in enumerate(zip(HULL_NAMES, "osd", strict=True)):
            gh = g[g.hull == hull]
            x = np.array([seas.index(s) for s in gh.sea]) + 0.2 * (k - 1)
            x = x + 0.02 * (gh.wind_body_deg.to_numpy() / 45.0 - 3.5)
            ax.scatter(x, gh["components"], marker=mk, s=12, alpha=0.5, label=f"{hull}: components")
            if hull in HULL_RESPONSE:
                ax.scatter(
                    x, gh["record"], marker=mk, s=16, facecolors="none", edgecolors="k",
                    linewidths=0.6, label=f"{hull}: record model",
                )  # fmt: skip
        ax.axhspan(1 - TOLERANCE, 1 + TOLERANCE, color="0.88", zorder=0, label="+-5 %")
        ax.set_xticks(range(len(seas)), seas, rotation=30, ha="right", fontsize=8)
        ax.set_title(lidar)
    axes[0].set_ylabel("sigma_Z / sigma_Z(LOS replay, dwell-averaged beams)")
    axes[0].legend(fontsize=7, ncol=2)
    fig.suptitle(
        "DBS sigma_Z: the spectral sum and the record model's tilt bands vs LOS-level replay "
        f"(8 headings, HWS 5-15 m/s, lever arm {LEVER_M:g} m)"
    )
    fig.tight_layout()
    fig.savefig(OUT / "dbs_sigma_z.png", dpi=110)


if __name__ == "__main__":
    sys.exit(main())
