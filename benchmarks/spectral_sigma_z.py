"""Per-record sigma_Z on directional broadband seas: spectral band sum vs attitude replay.

For each synthetic sea (physics.seastate JONSWAP wind sea +- swell, directional spreading,
fixed or weathervaning heading) and each HWS (5, 10, 15 m/s) and lever arm (0, 2.5 m):

- ``replay``: realised sigma_Z, the 10-min attitude series replayed through the scan
  simulator (``motion_spectrum.replay_sigma_z``), the reference;
- ``spectral``: the quadrature sum over 8 log-spaced period bands of the along-wind tilt
  (``data.imu.tilt_band_statistics`` + ``motion_spectrum.spectral_sigma_z_ms``);
- ``moments``: table-only fallback, one harmonic at sqrt(2) std_along and Tz;
- ``harmonic``: the old value, Gutiérrez-Antuñano et al. (2018) harmonic at the mean of the sqrt(2)-std roll and
  pitch amplitudes and the mean spectral-peak period (``record_motion``).

Ratios are pooled over the records of a case: ``sqrt(mean(s_method^2) / mean(s_replay^2))``;
the per-record ratio range is reported too. Speeds (records/s) are measured side by side.

Run:  PYTHONPATH=src OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 python benchmarks/spectral_sigma_z.py
Writes benchmarks/results/spectral_sigma_z.csv and .png, and spectral_sigma_z_long.csv
(60-min records, where the replay's own sampling noise is smaller).
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np
import pandas as pd

from flidar_uq.data.imu import amplitude_std_deg, period_spectral_s, tilt_band_statistics
from flidar_uq.physics import motion_spectrum as ms
from flidar_uq.physics.seastate import WaveSystem, tilt_series
from flidar_uq.physics.surrogate import get_surrogate

OUT = Path(__file__).resolve().parent / "results"
FS_HZ = 10.0
N_SAMPLES = 6000  # 10 min
N_REC = 8
WD_DEG = 270.0  # wind from the west: wind sea travels east (direction 0 deg from east, CCW)
HWS = (5.0, 10.0, 15.0)
LEVER = (0.0, 2.5)
SEED = 20261128


def _heading(kind: str, rng, t):
    """Yaw (deg, CCW from above) series of the buoy for a heading option."""
    if kind == "fixed":
        return np.full_like(t, rng.uniform(0, 360))
    # weathervaning: body x points downwind (east, yaw 0) with a slow +-15 deg swing
    return 15.0 * np.sin(2 * np.pi * t / 90.0 + rng.uniform(0, 2 * np.pi))


CASES = {
    # name: (systems, heading)
    "windsea_gamma1": ([WaveSystem(3.0, 4.0, 1.0, 0.0, 30.0)], "fixed"),
    "windsea_gamma3.3": ([WaveSystem(3.0, 4.0, 3.3, 0.0, 30.0)], "fixed"),
    "windsea_gamma7": ([WaveSystem(3.0, 4.0, 7.0, 0.0, 30.0)], "fixed"),
    "narrow_gamma10_spread5": ([WaveSystem(3.0, 5.0, 10.0, 0.0, 5.0)], "fixed"),
    "windsea_8deg": ([WaveSystem(8.0, 5.0, 3.3, 0.0, 30.0)], "fixed"),
    "two_peak_aligned": (
        [WaveSystem(2.5, 3.5, 3.3, 0.0, 30.0), WaveSystem(2.0, 9.0, 7.0, 0.0, 15.0)],
        "fixed",
    ),
    "swell_45deg": (
        [WaveSystem(2.5, 3.5, 3.3, 0.0, 30.0), WaveSystem(2.0, 9.0, 7.0, 45.0, 15.0)],
        "fixed",
    ),
    "swell_90deg": (
        [WaveSystem(2.5, 3.5, 3.3, 0.0, 30.0), WaveSystem(2.0, 9.0, 7.0, 90.0, 15.0)],
        "fixed",
    ),
    "swell_90deg_weathervane": (
        [WaveSystem(2.5, 3.5, 3.3, 0.0, 30.0), WaveSystem(2.0, 9.0, 7.0, 90.0, 15.0)],
        "weathervane",
    ),
    "windsea_weathervane": ([WaveSystem(3.0, 4.0, 3.3, 0.0, 30.0)], "weathervane"),
    "across_wind_only": ([WaveSystem(3.0, 4.0, 3.3, 90.0, 20.0)], "fixed"),
}


def make_records(systems, heading, rng):
    """Body-frame roll, pitch, yaw series (N_REC, n): earth-frame tilt rotated by -yaw."""
    t = np.arange(N_SAMPLES) / FS_HZ
    out = []
    for _ in range(N_REC):
        roll_e, pitch_e = tilt_series(N_SAMPLES, 1.0 / FS_HZ, systems, rng)  # yaw 0: earth frame
        yaw = _heading(heading, rng, t)
        y = np.deg2rad(yaw)
        te, tn = pitch_e, -roll_e  # tilt vector (east, north), small angle
        pitch_b = np.cos(y) * te + np.sin(y) * tn  # Rz(-yaw) (te, tn)
        roll_b = -(-np.sin(y) * te + np.cos(y) * tn)
        out.append((roll_b, pitch_b, yaw))
    return t, np.array(out)  # (N_REC, 3, n)


def main() -> pd.DataFrame:
    OUT.mkdir(parents=True, exist_ok=True)
    rng = np.random.default_rng(SEED)
    sur = get_surrogate()
    sur.sigma_z_lever_ms(10.0, 3.0, 4.0, 2.5)  # build the lever table before timing
    rows = []
    timing = {"replay": 0.0, "imu_to_bands": 0.0, "spectral": 0.0, "moments": 0.0, "harmonic": 0.0}
    n_replay = n_eval = n_imu = 0
    for name, (systems, heading) in CASES.items():
        t, rec = make_records(systems, heading, rng)
        roll, pitch, yaw = rec[:, 0], rec[:, 1], rec[:, 2]
        t0 = time.perf_counter()
        spec = tilt_band_statistics(roll, pitch, yaw, np.full(N_REC, WD_DEG), FS_HZ)
        timing["imu_to_bands"] += time.perf_counter() - t0
        n_imu += N_REC
        amp_h = 0.5 * (amplitude_std_deg(roll) + amplitude_std_deg(pitch))
        per_h = 0.5 * (
            period_spectral_s(roll, FS_HZ, period_max_s=20.0)
            + period_spectral_s(pitch, FS_HZ, period_max_s=20.0)
        )
        for hws in HWS:
            for lever in LEVER:
                t0 = time.perf_counter()
                rep = np.array(
                    [
                        ms.replay_sigma_z(
                            t,
                            roll[i],
                            pitch[i],
                            yaw[i],
                            hws_ms=hws,
                            wd_deg=WD_DEG,
                            lever_arm_m=lever,
                        ).sigma_z_ms
                        for i in range(N_REC)
                    ]
                )
                timing["replay"] += time.perf_counter() - t0
                n_replay += N_REC
                # noise floor of the reference: the same record replayed with the scans
                # started half a scan later
                rep_shift = np.array(
                    [
                        ms.replay_sigma_z(
                            t[5:],
                            roll[i, 5:],
                            pitch[i, 5:],
                            yaw[i, 5:],
                            hws_ms=hws,
                            wd_deg=WD_DEG,
                            lever_arm_m=lever,
                        ).sigma_z_ms
                        for i in range(N_REC)
                    ]
                )
                t0 = time.perf_counter()
                s_sp = ms.spectral_sigma_z_ms(
                    hws, spec.var_along_deg2, spec.period_s, lever_arm_m=lever, surrogate=sur
                )
                t1 = time.perf_counter()
                s_mo = ms.moments_sigma_z_ms(
                    hws, spec.along_std_deg, spec.tz_s, lever_arm_m=lever, surrogate=sur
                )
                t2 = time.perf_counter()
                s_ha = ms.harmonic_sigma_z_ms(hws, amp_h, per_h, lever_arm_m=lever, surrogate=sur)
                t3 = time.perf_counter()
                timing["spectral"] += t1 - t0
                timing["moments"] += t2 - t1
                timing["harmonic"] += t3 - t2
                n_eval += N_REC
                row = {
                    "case": name,
                    "hws_ms": hws,
                    "lever_arm_m": lever,
                    "n_records": N_REC,
                    "along_share": float(np.mean(spec.along_share)),
                    "tz_s": float(np.mean(spec.tz_s)),
                    "tp_s": float(np.mean(spec.tp_s)),
                    "replay_sigma_z_ms": float(np.sqrt(np.mean(rep**2))),
                }
                r = rep_shift / rep
                row["ratio_replay_shift_min"], row["ratio_replay_shift_max"] = r.min(), r.max()
                for key, s in (("spectral", s_sp), ("moments", s_mo), ("harmonic", s_ha)):
                    row[f"{key}_sigma_z_ms"] = float(np.sqrt(np.mean(s**2)))
                    row[f"ratio_{key}"] = row[f"{key}_sigma_z_ms"] / row["replay_sigma_z_ms"]
                    r = s / rep
                    row[f"ratio_{key}_min"], row[f"ratio_{key}_max"] = (
                        float(r.min()),
                        float(r.max()),
                    )
                rows.append(row)
        print(f"{name:26s} done", flush=True)
    df = pd.DataFrame(rows)
    # Speed in the same run: records per second; the sigma evaluations are vectorised over
    # the N_REC records of a case (in the inference they would be over all records at once).
    speed = {
        "replay": n_replay / timing["replay"],
        "imu_to_bands": n_imu / timing["imu_to_bands"],
        "spectral": n_eval / timing["spectral"],
        "moments": n_eval / timing["moments"],
        "harmonic": n_eval / timing["harmonic"],
    }
    big = 20000
    hb = np.full(big, 10.0)
    vb = np.tile(spec.var_along_deg2, (big // N_REC + 1, 1))[:big]
    pb = np.tile(spec.period_s, (big // N_REC + 1, 1))[:big]
    t0 = time.perf_counter()
    ms.spectral_sigma_z_ms(hb, vb, pb, surrogate=sur)
    speed["spectral_batch20000"] = big / (time.perf_counter() - t0)
    t0 = time.perf_counter()
    ms.spectral_sigma_z_ms(hb, vb, pb, lever_arm_m=2.5, surrogate=sur)
    speed["spectral_lever_batch20000"] = big / (time.perf_counter() - t0)
    for k, v in speed.items():
        df[f"speed_{k}_rec_per_s"] = v
    df.to_csv(OUT / "spectral_sigma_z.csv", index=False)
    long = _long_records(rng, sur)
    _plot(df)
    pd.set_option("display.width", 200)
    cols = [
        "case",
        "hws_ms",
        "lever_arm_m",
        "along_share",
        "replay_sigma_z_ms",
        "ratio_spectral",
        "ratio_spectral_min",
        "ratio_spectral_max",
        "ratio_replay_shift_min",
        "ratio_replay_shift_max",
        "ratio_moments",
        "ratio_harmonic",
    ]
    print(df[cols].to_string(index=False, float_format=lambda x: f"{x:.3f}"))
    print("worst |spectral/replay - 1| (pooled):", f"{np.max(np.abs(df.ratio_spectral - 1)):.3%}")
    print(
        "per record: spectral/replay",
        f"{df.ratio_spectral_min.min():.3f}-{df.ratio_spectral_max.max():.3f};",
        "replay noise floor (same record, scans shifted by half a scan)",
        f"{df.ratio_replay_shift_min.min():.3f}-{df.ratio_replay_shift_max.max():.3f}",
    )
    print("worst |moments/replay - 1| (pooled):", f"{np.max(np.abs(df.ratio_moments - 1)):.3%}")
    print("harmonic/replay range:", f"{df.ratio_harmonic.min():.3f}-{df.ratio_harmonic.max():.3f}")
    print("speed, records/s:", {k: f"{v:.3g}" for k, v in speed.items()})
    print("60-min records (replay noise smaller):")
    print(long.to_string(index=False, float_format=lambda x: f"{x:.3f}"))
    return df


def _long_records(rng, sur, n_rec: int = 4, minutes: int = 60) -> pd.DataFrame:
    """Spectral sum vs replay on 60-min records: separates model error from replay noise."""
    n = int(minutes * 60 * FS_HZ)
    t = np.arange(n) / FS_HZ
    rows = []
    for name in ("windsea_gamma3.3", "swell_90deg", "two_peak_aligned"):
        systems, _ = CASES[name]
        recs = [tilt_series(n, 1.0 / FS_HZ, systems, rng) for _ in range(n_rec)]
        for lever in LEVER:
            rep, sp = [], []
            for roll, pitch in recs:
                rep.append(
                    ms.replay_sigma_z(
                        t, roll, pitch, hws_ms=10.0, wd_deg=WD_DEG, lever_arm_m=lever
                    ).sigma_z_ms
                )
                spec = tilt_band_statistics(roll, pitch, 0.0, WD_DEG, FS_HZ)
                sp.append(
                    ms.spectral_sigma_z_ms(
                        10.0, spec.var_along_deg2, spec.period_s, lever_arm_m=lever, surrogate=sur
                    )[0]
                )
            r = np.array(sp) / np.array(rep)
            rows.append(
                {
                    "case": name,
                    "minutes": minutes,
                    "hws_ms": 10.0,
                    "lever_arm_m": lever,
                    "ratio_spectral": float(
                        np.sqrt(np.mean(np.square(sp)) / np.mean(np.square(rep)))
                    ),
                    "ratio_spectral_min": r.min(),
                    "ratio_spectral_max": r.max(),
                }
            )
    out = pd.DataFrame(rows)
    out.to_csv(OUT / "spectral_sigma_z_long.csv", index=False)
    return out


def _plot(df: pd.DataFrame) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    cases = list(CASES)
    fig, axes = plt.subplots(1, 2, figsize=(13, 6), sharey=True)
    for ax, lever in zip(axes, LEVER, strict=True):
        sub = df[df.lever_arm_m == lever]
        for j, (key, mk) in enumerate((("spectral", "o"), ("moments", "s"), ("harmonic", "^"))):
            for k, hws in enumerate(HWS):
                s = sub[sub.hws_ms == hws].set_index("case").loc[cases]
                y = np.arange(len(cases)) + 0.12 * (3 * j + k - 4)
                ax.plot(
                    s[f"ratio_{key}"],
                    y,
                    mk,
                    ms=4,
                    color=f"C{j}",
                    alpha=0.5 + 0.25 * k,
                    label=f"{key}, {hws:g} m/s",
                )
        ax.axvspan(0.97, 1.03, color="0.9")
        ax.axvline(1.0, color="k", lw=0.8)
        ax.set_yticks(np.arange(len(cases)), cases)
        ax.set_xlabel("sigma_Z / replayed sigma_Z (pooled over records)")
        ax.set_title(f"lever arm {lever:g} m")
    axes[0].legend(fontsize=7, loc="lower right")
    fig.tight_layout()
    fig.savefig(OUT / "spectral_sigma_z.png", dpi=120)


if __name__ == "__main__":
    main()
