"""Speed of the LOS-level motion correction on a 10-min record of 50-Hz LOS data.

Target: correcting a 10-min record of 50-Hz LOS data (30,000 LOS, ZephIR-like
CW VAD, 600 scans) in <= 50 ms on one core. Timed: the whole call of
``correct_least_squares`` (IMU interpolation at the LOS times, rotations, CW sign
resolution, least squares), for a 20-Hz sampled IMU and for harmonic motion; the
uncorrected retrieval and the Yamaguchi and Ishihara (2016) DBS algorithms for scale.

Run: ``OPENBLAS_NUM_THREADS=1 taskset -c 0 .venv/bin/python
benchmarks/los_correction_speed.py | tee benchmarks/results/los_correction_speed_stdout.txt``
(one core, one BLAS thread: the figure quoted in docs/los-correction.md).
Writes ``benchmarks/results/los_correction_speed.csv`` and ``.png``; the printed table
(with the machine's load average, since the CPU times are measured on a shared machine) is
kept as ``los_correction_speed_stdout.txt`` (``... | tee``).
"""

from __future__ import annotations

import os
import time
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pandas as pd  # noqa: E402

from flidar_uq.correction.los import (  # noqa: E402
    correct_dbs_motion,
    correct_least_squares,
    imu_rotation_velocity,
)
from flidar_uq.physics import lidar as L  # noqa: E402
from flidar_uq.physics import motion as M  # noqa: E402

OUT = Path(__file__).parent / "results"
TARGET_MS = 50.0
H = M.Harmonic


def _timeit(fn, repeat=15):
    """Median and minimum CPU time of this process per call (ms).

    CPU time (``time.process_time``) rather than wall time: the machine is shared, and
    the figure asked for is the cost on one core; run with BLAS threads = 1.
    """
    fn()  # warm-up
    times = []
    for _ in range(repeat):
        t0 = time.process_time()
        fn()
        times.append(1e3 * (time.process_time() - t0))
    return float(np.median(times)), float(np.min(times))


def _record(geom, duration_s, motion, wind, gates_m=None):
    tt, az = L.scan_times_azimuths(geom)
    nscan = int(round(duration_s / geom.scan_period_s))
    t = (np.arange(nscan)[:, None] * geom.scan_period_s + tt[None]).ravel()
    az = np.tile(az, nscan)
    d = np.einsum("nij,nj->ni", motion.rotation(t), L.beam_unit_vectors_body(geom, az))
    rel = wind[None] - motion.head_velocity_ms(t)
    if gates_m is None:
        vr = np.einsum("ni,ni->n", d, rel)
        return t, az, (vr if geom.signed else np.abs(vr))
    return t, az, np.einsum("ni,ni->n", d, rel)[:, None] * np.ones(len(gates_m))


def main() -> pd.DataFrame:
    OUT.mkdir(parents=True, exist_ok=True)
    harmonic = M.PlatformMotion(
        roll=(H(6.0, 5.0, 0.3),),
        pitch=(H(9.0, 6.5, 1.1),),
        yaw=(H(2.0, 30.0),),
        heave=(H(0.8, 7.0),),
        lever_arm_m=(0.0, 0.0, 2.5),
    )
    t_imu = np.arange(-1.0, 602.0, 0.05)  # 20-Hz IMU
    roll, pitch, yaw = (np.degrees(a) for a in harmonic.attitude_rad(t_imu))
    heave = np.stack([h.value(t_imu) for h in harmonic.heave]).sum(0)
    sampled = M.SampledMotion(t_imu, roll, pitch, yaw, heave_m=heave, lever_arm_m=(0.0, 0.0, 2.5))
    wind = L.wind_vector_ms(9.0, 240.0, 0.2)

    t, az, vr = _record(L.ZEPHIR300, 600.0, harmonic, wind)
    assert t.size == 30_000
    rot, vel = imu_rotation_velocity(sampled, t)
    rows = []
    cases = {
        "least_squares, CW VAD, given per-LOS R and v_head": lambda: correct_least_squares(
            "zephir300", t, az, vr, rotation=rot, head_velocity_ms=vel
        ),
        "IMU evaluation only (motion.py, 20-Hz sampled)": lambda: imu_rotation_velocity(sampled, t),
        "least_squares, CW VAD, 20-Hz sampled IMU": lambda: correct_least_squares(
            "zephir300", t, az, vr, sampled
        ),
        "least_squares, CW VAD, harmonic motion": lambda: correct_least_squares(
            "zephir300", t, az, vr, harmonic
        ),
        "uncorrected CW VAD (same solver, no IMU)": lambda: correct_least_squares(
            "zephir300", t, az, vr
        ),
    }
    for name, fn in cases.items():
        med, best = _timeit(fn)
        rows.append(dict(case=name, lidar="zephir300", n_los=t.size, median_ms=med, min_ms=best))
    # pulsed DBS: a 10-min record is only 600 LOS at 1 Hz; 9 range gates
    gates = np.arange(40.0, 201.0, 20.0)
    td, azd, vrd = _record(L.WINDCUBE_V1, 600.0, harmonic, wind, gates)
    for method in ("new", "conventional"):
        med, best = _timeit(
            lambda m=method: correct_dbs_motion(
                "windcube_v1", td, azd, vrd, sampled, range_height_m=gates, method=m
            )
        )
        rows.append(
            dict(
                case=f"dbs_{method}, DBS, 9 gates, sliding",
                lidar="windcube_v1",
                n_los=td.size,
                median_ms=med,
                min_ms=best,
            )
        )
    med, best = _timeit(
        lambda: correct_least_squares("windcube_v1", td, azd, vrd[:, 0], sampled, step=1)
    )
    rows.append(
        dict(
            case="least_squares, DBS, sliding",
            lidar="windcube_v1",
            n_los=td.size,
            median_ms=med,
            min_ms=best,
        )
    )
    df = pd.DataFrame(rows)
    df["target_ms"] = np.where(df.lidar == "zephir300", TARGET_MS, np.nan)
    df["ratio_to_target"] = df.median_ms / df.target_ms
    df.to_csv(OUT / "los_correction_speed.csv", index=False, float_format="%.3f")

    fig, ax = plt.subplots(figsize=(9, 4.2))
    ax.barh(df.case, df.median_ms, color=["C2", "C7"] + ["C0"] * 3 + ["C1"] * 3)
    ax.axvline(TARGET_MS, color="k", ls="--", label=f"target {TARGET_MS:.0f} ms (30,000 LOS)")
    ax.set_xlabel("median CPU time per 10-min record (ms, one thread)")
    ax.set_title(
        f"LOS-level correction speed (cpu affinity: {len(os.sched_getaffinity(0))} core(s))"
    )
    ax.invert_yaxis()
    ax.legend(loc="lower right")
    fig.tight_layout()
    fig.savefig(OUT / "los_correction_speed.png", dpi=110)
    plt.close(fig)

    print(f"cores available to this process: {len(os.sched_getaffinity(0))}")
    print("machine load average (1, 5, 15 min): {:.2f} {:.2f} {:.2f}".format(*os.getloadavg()))
    print(
        f"{'case':48s} {'n_los':>6s} {'median ms':>10s} {'min ms':>8s} {'target':>7s} {'ratio':>6s}"
    )
    for r in df.itertuples():
        print(
            f"{r.case:48s} {r.n_los:6d} {r.median_ms:10.1f} {r.min_ms:8.1f} "
            f"{r.target_ms:7.0f} {r.ratio_to_target:6.2f}"
        )
    return df


if __name__ == "__main__":
    main()
