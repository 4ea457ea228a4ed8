"""sigma_Z of a buoy in six degrees of freedom: the band sum against the scan simulator's replay.

For each sea (JONSWAP wind sea +- swell, directional spreading; a swell aligned with the
wind, across it, against it, and a swell alone across the wind: a "heaving sea" whose tilt
is harmless to a tilt-only model), each hull (``wave_follower``, ``discus_buoy``,
``rotation_only``), HWS (5, 10, 15 m/s) and lever arm (0, 3 m):

- ``replay``: realised sigma_Z, the six-degree-of-freedom series (tilt, surge, sway, heave of
  :func:`flidar_uq.physics.seastate.hull_motion_series`) replayed through the scan simulator
  (``motion_spectrum.replay_sigma_z`` with ``translation_m``), the reference;
- ``components``: the band sum of :func:`flidar_uq.physics.six_dof_sigma_z.six_dof_band_sigma_z_ms`
  over the realised Fourier components (their amplitudes, periods and directions: the
  spectral description with the wave direction known);
- ``bands_8``, ``bands_16``, ``bands_32``: the same over 8, 16 or 32 log-spaced period bands
  (1-20 s) per wave system, each band with its centroid period and the variance-weighted
  ``<cos psi>`` and ``<cos^2 psi>`` of its components (a directional description);
- ``tilt_only``: the rotation-only model of the same components (what the model without
  translation predicts on that sea);
- ``record_model``: what the record model computes for these records: the series cut into
  10-min records, reduced by the data layer to the record table's 8 tilt bands with each
  band's measured ``<cos psi>`` (the IMU series' heave velocity,
  :func:`flidar_uq.data.imu.tilt_band_statistics`), and
  :func:`flidar_uq.inference.record_motion.motion_gram` at the truth's motion scale 1,
  lever arm and hull response (1 for the wave follower, 0 for the buoy that only rotates;
  the discus buoy's period-dependent response is not the record model's, so it has no
  ``record_model`` value); ``record_model_one_node`` the same with each band at its centroid period
  alone.

Ratios are ``sqrt(mean(s_method^2) / mean(s_replay^2))`` over the records of a case. The band
sum's speed (records/s, 8 bands) and the record model's (8 bands x 3 nodes, from the
record table) are measured in the same run. ``--check``: exit status 1 unless every
``record_model`` ratio of the wind seas, the two-peak sea and the swells (broadband,
misaligned, heaving) is within 3 % where sigma_Z is at least 0.05 m/s.

Run:  PYTHONPATH=src OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 python benchmarks/six_dof_sigma_z.py
Writes benchmarks/results/six_dof_sigma_z.csv and .png.
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np
import pandas as pd

from flidar_uq.data.imu import tilt_band_statistics, tilt_spectrum_columns
from flidar_uq.inference.record_motion import gram_sigma_z_ms, motion_gram
from flidar_uq.physics import motion_spectrum as ms
from flidar_uq.physics.seastate import WaveSystem, hull_motion_series
from flidar_uq.physics.six_dof_sigma_z import six_dof_band_sigma_z_ms
from flidar_uq.physics.surrogate import get_surrogate

OUT = Path(__file__).resolve().parent / "results"
DT_S = 0.05
DURATION_S = 1800.0  # 30-min series: the replay's own sampling noise ~1 %
N_REC = 3
WD_DEG = 270.0  # wind from the west, blowing east: downwind is the body x axis (yaw 0)
HWS = (5.0, 10.0, 15.0)
LEVER = (0.0, 3.0)
HULL_NAMES = ("wave_follower", "discus_buoy", "rotation_only")
SEED = 20261201
N_BANDS = (8, 16, 32)  # period bands over 1-20 s
METHODS = (
    "components",
    *(f"bands_{nb}" for nb in N_BANDS),
    "tilt_only",
    "record_model",
    "record_model_one_node",
)
HULL_RESPONSE = {"wave_follower": 1.0, "rotation_only": 0.0}
RECORD_S = 600.0
#: ``--check`` tolerance, and the sigma_Z (m/s) below which a ratio is not judged (a buoy
#: that only rotates in a swell across the wind: a few mm/s, second-order terms)
TOLERANCE, SIGMA_Z_FLOOR_MS = 0.03, 0.05

SEAS = {
    "windsea_broadband": [WaveSystem(3.0, 5.0, 1.0, 0.0, 30.0)],
    "windsea_short": [WaveSystem(3.0, 3.0, 3.3, 0.0, 30.0)],
    "two_peak_aligned": [
        WaveSystem(2.4, 4.0, 3.3, 0.0, 30.0),
        WaveSystem(1.8, 10.0, 6.0, 0.0, 10.0),
    ],
    "swell_across": [WaveSystem(2.4, 4.0, 3.3, 0.0, 30.0), WaveSystem(1.8, 9.0, 6.0, 90.0, 10.0)],
    "swell_against": [WaveSystem(2.4, 4.0, 3.3, 0.0, 30.0), WaveSystem(1.8, 9.0, 6.0, 180.0, 10.0)],
    "heaving_sea": [WaveSystem(2.0, 8.0, 6.0, 90.0, 10.0)],
}


def _band_description(comp, n_bands):
    """Components reduced to log-spaced period bands (1-20 s) per wave system: amplitude
    (deg), centroid period (s), and the variance-weighted <cos psi> and <cos^2 psi>."""
    amp, per, dire = (
        comp[k].reshape(-1, comp[k].shape[-1])
        for k in ("amplitude_deg", "period_s", "direction_deg")
    )
    edges = np.geomspace(1.0, 20.0, n_bands + 1)
    rows = []
    for a, p, d in zip(amp, per, dire, strict=True):  # one wave system
        var = a**2 / 2.0
        idx = np.digitize(p, edges)
        cos = np.cos(np.deg2rad(d))
        for b in range(0, n_bands + 2):
            m = (idx == b) & (var > 0)
            if not m.any():
                continue
            v = var[m].sum()
            f_c = np.sum(var[m] / p[m]) / v  # centroid frequency
            rows.append(
                (
                    np.sqrt(2.0 * v),
                    1.0 / f_c,
                    np.sum(var[m] * cos[m]) / v,
                    np.sum(var[m] * cos[m] ** 2) / v,
                )
            )
    return np.array(rows).T


def record_table(m, dt_s) -> pd.DataFrame:
    """A motion series cut into 10-min records and reduced to the record table's tilt bands
    by the data layer (heading 0, wind from the west as ``WD_DEG``), with the heave
    velocity's measured directions."""
    n10 = int(RECORD_S / dt_s)
    k = m["roll_deg"].size // n10
    cut = {key: m[key][: k * n10].reshape(k, n10) for key in ("roll_deg", "pitch_deg", "heave_m")}
    spec = tilt_band_statistics(
        cut["roll_deg"], cut["pitch_deg"], 0.0, np.full(k, WD_DEG), 1.0 / dt_s,
        velocity_up_ms=np.gradient(cut["heave_m"], dt_s, axis=-1),
    )  # fmt: skip
    return pd.DataFrame(tilt_spectrum_columns(spec)).assign(wd_mean_deg=WD_DEG)


def record_sigma_z(rec, hws, lever, hull, sur, nodes=3) -> float:
    """rms sigma_Z (m/s) of the record model's description of the records ``rec``."""
    gram = motion_gram(rec.assign(hws_mean_ms=hws), surrogate=sur, band_nodes=nodes)
    s = gram_sigma_z_ms(gram, lever_arm_m=lever, hull_response=HULL_RESPONSE[hull])
    return float(np.sqrt(np.mean(s**2)))


def main(argv=None) -> int:
    import argparse
    import sys

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--check", action="store_true", help="exit 1 unless within 3 %%")
    args = ap.parse_args(sys.argv[1:] if argv is None else argv)
    sur = get_surrogate("zephir300")
    rng = np.random.default_rng(np.random.SeedSequence(SEED))
    n = int(DURATION_S / DT_S)
    t = np.arange(n) * DT_S
    rows = []
    t0 = time.perf_counter()
    for sea, systems in SEAS.items():
        for hull in HULL_NAMES:
            for rec in range(N_REC):
                m = hull_motion_series(n, DT_S, systems, rng, hull, return_components=True)
                comp = m["components"]
                trans = np.column_stack([m["surge_m"], m["sway_m"], m["heave_m"]])  # yaw 0: ENU
                psi_c = comp["direction_deg"].ravel()  # downwind = body x = 0 deg
                bands = {nb: _band_description(comp, nb) for nb in N_BANDS}
                rec_table = record_table(m, DT_S)
                for hws in HWS:
                    for lever in LEVER:
                        rep = ms.replay_sigma_z(
                            t,
                            m["roll_deg"],
                            m["pitch_deg"],
                            hws_ms=hws,
                            wd_deg=WD_DEG,
                            lever_arm_m=lever,
                            translation_m=trans,
                        ).sigma_z_ms
                        kw = dict(lever_arm_m=lever, surrogate=sur)
                        a_c, p_c = comp["amplitude_deg"].ravel(), comp["period_s"].ravel()
                        keep = a_c > 1e-4 * a_c.max()
                        cos_c = np.cos(np.deg2rad(psi_c[keep]))
                        comp_sz = six_dof_band_sigma_z_ms(
                            hws, a_c[keep], p_c[keep], band_cos_psi=cos_c, hull=hull, **kw
                        )
                        tilt_sz = six_dof_band_sigma_z_ms(
                            hws,
                            a_c[keep],
                            p_c[keep],
                            band_cos_psi=cos_c,
                            hull="rotation_only",
                            **kw,
                        )
                        row = dict(
                            sea=sea,
                            hull=hull,
                            record=rec,
                            hws_ms=hws,
                            lever_arm_m=lever,
                            replay=rep,
                            components=float(comp_sz),
                            tilt_only=float(tilt_sz),
                        )
                        if hull in HULL_RESPONSE:
                            row["record_model"] = record_sigma_z(rec_table, hws, lever, hull, sur)
                            row["record_model_one_node"] = record_sigma_z(
                                rec_table, hws, lever, hull, sur, nodes=1
                            )
                        for nb, (ba, bp, bc1, bc2) in bands.items():
                            row[f"bands_{nb}"] = float(
                                six_dof_band_sigma_z_ms(
                                    hws,
                                    ba,
                                    bp,
                                    band_cos_psi=bc1,
                                    band_cos_sq_psi=bc2,
                                    hull=hull,
                                    **kw,
                                )
                            )
                        rows.append(row)
        print(f"{sea}: done ({time.perf_counter() - t0:.0f} s)", flush=True)
    df = pd.DataFrame(rows)

    def pooled(g, col):
        return np.sqrt(np.mean(g[col] ** 2) / np.mean(g["replay"] ** 2))

    summary = (
        df.groupby(["sea", "hull", "hws_ms", "lever_arm_m"])
        .apply(
            lambda g: pd.Series(
                {c: pooled(g, c) if g[c].notna().all() else np.nan for c in METHODS}
                | {"replay_ms": np.sqrt(np.mean(g["replay"] ** 2))}
            ),
            include_groups=False,
        )
        .reset_index()
    )
    # speed of the band sum: 8 bands a record, 1e5 records, against the replay's
    n_speed = 100_000
    ra = rng.uniform(0.2, 4.0, (n_speed, 8))
    rp = np.geomspace(1.5, 16.0, 8)[None, :] * rng.uniform(0.9, 1.1, (n_speed, 8))
    rd = np.cos(np.deg2rad(rng.uniform(-180, 180, (n_speed, 8))))
    rh = rng.uniform(3, 20, n_speed)
    six_dof_band_sigma_z_ms(
        rh[:10], ra[:10], rp[:10], band_cos_psi=rd[:10], lever_arm_m=2.0, surrogate=sur
    )
    t1 = time.perf_counter()
    six_dof_band_sigma_z_ms(rh, ra, rp, band_cos_psi=rd, lever_arm_m=2.0, surrogate=sur)
    band_rate = n_speed / (time.perf_counter() - t1)
    big = pd.concat([rec_table.assign(hws_mean_ms=10.0)] * (20_000 // len(rec_table) + 1))
    motion_gram(big.iloc[:10], surrogate=sur)
    t1 = time.perf_counter()
    motion_gram(big, surrogate=sur)
    record_rate = len(big) / (time.perf_counter() - t1)
    t1 = time.perf_counter()
    ms.replay_sigma_z(
        t[:12000],
        m["roll_deg"][:12000],
        m["pitch_deg"][:12000],
        hws_ms=10.0,
        wd_deg=WD_DEG,
        translation_m=trans[:12000],
    )
    replay_rate = 1.0 / (time.perf_counter() - t1)
    summary["band_sum_records_per_s"] = band_rate
    summary["record_records_per_s"] = record_rate
    summary["replay_records_per_s"] = replay_rate
    OUT.mkdir(exist_ok=True)
    summary.to_csv(OUT / "six_dof_sigma_z.csv", index=False, float_format="%.4f")
    six = summary[summary.hull != "rotation_only"]
    print(summary.to_string(index=False, float_format=lambda v: f"{v:.3f}"))
    for col in METHODS:
        r = summary[col]
        print(
            f"{col}: ratio to replay {r.min():.3f}-{r.max():.3f} (all hulls), "
            f"{six[col].min():.3f}-{six[col].max():.3f} (translating hulls)"
        )
    judged = summary[(summary.sea != "windsea_short") & (summary.replay_ms >= SIGMA_Z_FLOOR_MS)]
    rec = judged["record_model"].dropna()
    within = float(np.mean(np.abs(rec - 1.0) <= TOLERANCE))
    print(
        f"record model, judged cases (sigma_Z >= {SIGMA_Z_FLOOR_MS} m/s, no short wind sea): "
        f"{rec.min():.3f}-{rec.max():.3f}, {100 * within:.1f} % of {rec.size} within 3 %"
    )
    print(
        f"band sum {band_rate:,.0f} records/s (8 bands), the record model's description "
        f"{record_rate:,.0f} records/s (8 bands x 3 nodes, from the record table), replay "
        f"{replay_rate:.2f} records/s (10 min): x{band_rate / replay_rate:,.0f}"
    )
    _plot(summary)
    return 0 if within == 1.0 or not args.check else 1


def _plot(summary: pd.DataFrame) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 3, figsize=(15, 4.8), sharey=True)
    seas = list(SEAS)
    for ax, hull in zip(axes, HULL_NAMES, strict=True):
        g = summary[summary.hull == hull]
        for k, (col, mk) in enumerate(zip(METHODS, "osdvx*+", strict=True)):
            x = np.array([seas.index(s) for s in g.sea]) + 0.11 * (k - 3)
            ax.scatter(x, g[col], marker=mk, s=18, label=col)
        ax.axhspan(0.97, 1.03, color="0.85", zorder=0, label="+-3 %")
        ax.set_xticks(range(len(seas)), seas, rotation=35, ha="right", fontsize=8)
        ax.set_title(f"hull: {hull}")
        ax.set_yscale("log")
    axes[0].set_ylabel("sigma_Z(method) / sigma_Z(6-DOF replay)")
    axes[0].legend(fontsize=8)
    fig.suptitle(
        "sigma_Z of a buoy in six degrees of freedom: band sum vs scan-simulator replay "
        "(ZephIR 300, HWS 5-15 m/s, lever arm 0 and 3 m)"
    )
    fig.tight_layout()
    fig.savefig(OUT / "six_dof_sigma_z.png", dpi=110)


if __name__ == "__main__":
    raise SystemExit(main())
