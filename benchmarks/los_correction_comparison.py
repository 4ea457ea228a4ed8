"""Head-to-head: LOS-level motion corrections (Malekmohammadi et al. (2024), Yamaguchi and Ishihara (2016)) vs the statistical one (Gutiérrez-Antuñano et al., 2018).

Virtual 10-min records with LOS-level data: Kaimal turbulence (``turbulence.kaimal_series``,
IEC spectra, frozen with Taylor's hypothesis, Yamaguchi and Ishihara (2016), Eq. 2), power-law shear 0.1 on the
mean (Yamaguchi and Ishihara, 2016, Eq. 1), harmonic 6-DOF motion of a buoy whose lidar head sits 2.5 m above
the rotation centre. LOS speeds come from ``simulator.simulate_scans`` with the wind at each
beam's measurement point (head displacement + range * earth beam vector). The IMU is
perfect (the motion model itself), so the LOS-level numbers are an upper bound of what a
real IMU allows.

Part A - motion classes x speed bins, for a ZephIR-like CW VAD (50 LOS/s, one height) and a
WindCube-V1-like pulsed DBS (4 beams, 1 s each, range gates 40-200 m). Methods: uncorrected;
Malekmohammadi et al. (2024) LS (Eq. 7); Yamaguchi and Ishihara (2016) conventional and new
(DBS only); statistical (``correction.corrected_std`` with ``simulator.sigma_z`` for the
record's roll/pitch amplitude, period and lever arm, U law rho = 0 because wind and motion
are independent here).
References: the same lidar on a fixed platform (motion-induced error) and the point truth at
the cone centre (10-Hz samples).

Part C - the virtual campaign (``campaign.generate_campaign`` with LOS-level and
raw IMU output, default sea-state scenario): the LOS-level correction from the LOS and IMU
tables alone (5-Hz noisy IMU with gaps, and a noise-free 20-Hz IMU) vs the statistical one with
the record's IMU amplitude and period; references: the campaign's fixed lidar and truth.

Part B - Yamaguchi and Ishihara's (2016) own setup: pulsed DBS, pitch maxima 5, 10, 15, 20 deg from a sum of
harmonics with periods 5-8 s and fixed phases ("same phase information"), TI 8-15 %, 10 m/s at
100 m; conventional vs new compensation.

Fractions of the motion-induced error removed (uncorrected = 0, perfect = 1), against the
fixed lidar: ``frac_removed_ti`` of the mean |TI error| per record, ``frac_removed_ti_bias``
of the mean signed TI error, ``frac_removed_ts`` of the std of the HWS time-series error
(Malekmohammadi et al.'s (2024) Figs. 9-10 view; its 85 % / 82 % are compared with these in docs).

Writes benchmarks/results/los_correction_comparison.csv (the table),
los_correction_comparison_records.csv (per record) and two PNGs; prints the table.
Runtime: about a minute or two on one core.
"""

from __future__ import annotations

import copy
import time
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pandas as pd  # noqa: E402

from flidar_uq.campaign.physics_mode import generate_campaign  # noqa: E402
from flidar_uq.campaign.scenarios import DEFAULT_SCENARIO  # noqa: E402
from flidar_uq.correction.los import correct_dbs_motion, correct_least_squares  # noqa: E402
from flidar_uq.physics import lidar as L  # noqa: E402
from flidar_uq.physics import motion as M  # noqa: E402
from flidar_uq.physics.simulator import los_vectors_earth, sigma_z, simulate_scans  # noqa: E402
from flidar_uq.physics.turbulence import kaimal_series, offshore_sigma_ms, wind_enu_ms  # noqa: E402
from flidar_uq.physics.variance_laws import corrected_std  # noqa: E402

OUT = Path(__file__).parent / "results"
SEED = 20261122
DURATION_S = 600.0
DT_WIND_S = 0.1
HEIGHT_M = 100.0
GATES_M = np.arange(40.0, 201.0, 20.0)
ALPHA = 0.1  # Yamaguchi and Ishihara (2016) shear exponent
LEVER_ARM_M = (0.0, 0.0, 2.5)
H = M.Harmonic

# Part A motion classes: roll = pitch amplitude (deg) and period (s), plus translations.
CLASSES = {
    "small 2deg/4s": dict(amp=2.0, period=4.0),
    "moderate 5deg/6s+heave": dict(amp=5.0, period=6.0, heave=0.5),
    "large 10deg/7s+heave": dict(amp=10.0, period=7.0, heave=1.0),
    "5deg/5s+yaw+surge": dict(amp=5.0, period=5.0, yaw=10.0, surge=0.5),
}
SPEEDS_MS = (5.0, 9.0, 13.0)
NREP = 3


class FrozenKaimalWind:
    """Kaimal turbulence frozen in a mean flow with power-law shear (Yamaguchi and Ishihara, 2016, Eqs. 1-2)."""

    def __init__(self, hws_ms, wd_deg, sigma_u_ms, rng):
        self.hws, self.wd = float(hws_ms), float(wd_deg)
        self.n = int(round(DURATION_S / DT_WIND_S))
        self.fl = kaimal_series(self.n, DT_WIND_S, hws_ms, sigma_u_ms, HEIGHT_M, rng)  # (3, n)
        wd = np.radians(wd_deg)
        self.along = np.array([-np.sin(wd), -np.cos(wd), 0.0])

    def __call__(self, t_s, xyz_m):
        """ENU wind (m/s) at times t_s (...) and points xyz_m (..., 3)."""
        s = xyz_m @ self.along
        tau = np.mod(t_s - s / self.hws, self.n * DT_WIND_S) / DT_WIND_S  # Taylor, periodic
        i0 = np.floor(tau).astype(int) % self.n
        f = tau - np.floor(tau)
        fl = self.fl[:, i0] * (1 - f) + self.fl[:, (i0 + 1) % self.n] * f  # (3, ...)
        z = np.maximum(xyz_m[..., 2], 1.0)
        ubar = self.hws * (z / HEIGHT_M) ** ALPHA  # Yamaguchi and Ishihara (2016), Eq. (1)
        return wind_enu_ms(ubar, self.wd, np.moveaxis(fl, 0, -1)[..., None])[..., 0, :]

    def truth(self):
        """Point truth at the cone centre: 10-Hz HWS (m/s)."""
        t = np.arange(self.n) * DT_WIND_S
        w = self(t, np.broadcast_to([0.0, 0.0, HEIGHT_M], (t.size, 3)))
        return np.hypot(w[:, 0], w[:, 1])


def los_record(geom, motion, wind, gates_m):
    """LOS data of a 10-min record: t_s (n,), azimuth_rad (n,), radial speeds (n, ngate)."""
    tt, az = L.scan_times_azimuths(geom)
    nscan = int(round(DURATION_S / geom.scan_period_s))
    t = np.arange(nscan)[:, None] * geom.scan_period_s + tt[None]
    if motion is None:
        roll = pitch = yaw = np.zeros_like(t)
        vel = disp = np.zeros(t.shape + (3,))
    else:
        roll, pitch, yaw = motion.attitude_rad(t)
        vel, disp = motion.head_velocity_ms(t), motion.head_displacement_m(t)
    d = los_vectors_earth(geom, az, roll, pitch, yaw)
    cols = []
    for r in np.asarray(gates_m) / np.cos(geom.half_cone_angle_rad):
        u = wind(t, disp + r * d)
        vr, _ = simulate_scans(
            geom, u, roll, pitch, yaw_rad=yaw, head_velocity_ms=vel, azimuth_rad=az
        )
        cols.append(vr.ravel())
    return t.ravel(), np.tile(az, nscan), np.stack(cols, axis=-1)


def class_motion(spec, rng):
    ph = rng.uniform(0, 2 * np.pi, 5)
    p = spec["period"]
    return M.PlatformMotion(
        roll=(H(spec["amp"], p, ph[0]),),
        pitch=(H(spec["amp"], p, ph[1]),),
        yaw=(H(spec.get("yaw", 0.0), 20.0, ph[2]),),
        surge=(H(spec.get("surge", 0.0), 8.0, ph[3]),),
        heave=(H(spec.get("heave", 0.0), p, ph[4]),),
        lever_arm_m=LEVER_ARM_M,
    )


def _stats(hws):
    return np.nanmean(hws), np.nanstd(hws) / np.nanmean(hws)


def record_rows(lidar, motion, wind, statistical_motion, meta):
    """Retrieve with every method; one row per method with TI, mean and error statistics."""
    geom = L.get_lidar(lidar)
    dbs = geom.kind == "dbs"
    gates = GATES_M if dbs else np.array([HEIGHT_M])
    t, az, vr = los_record(geom, motion, wind, gates)
    tf, azf, vrf = los_record(geom, None, wind, gates)
    g100 = int(np.argmin(np.abs(gates - HEIGHT_M)))
    series = {}
    if dbs:
        kw = dict(range_height_m=gates, target_height_m=[HEIGHT_M])
        fixed = correct_dbs_motion(geom, tf, azf, vrf, method="none", **kw).hws_ms[:, 0]
        series["uncorrected"] = correct_dbs_motion(geom, t, az, vr, method="none", **kw).hws_ms[
            :, 0
        ]
        series["least_squares"] = correct_least_squares(
            geom, t, az, vr[:, g100], motion, step=1
        ).hws_ms
        for m in ("conventional", "new"):
            series[f"dbs_{m}"] = correct_dbs_motion(geom, t, az, vr, motion, method=m, **kw).hws_ms[
                :, 0
            ]
    else:
        fixed = correct_least_squares(geom, tf, azf, vrf[:, 0]).hws_ms
        series["uncorrected"] = correct_least_squares(geom, t, az, vr[:, 0]).hws_ms
        series["least_squares"] = correct_least_squares(geom, t, az, vr[:, 0], motion).hws_ms
    mean_f, ti_f = _stats(fixed)
    mean_t, ti_t = _stats(wind.truth())
    rows = []
    for name, hws in series.items():
        mean_m, ti_m = _stats(hws)
        rows.append(
            dict(method=name, mean_ms=mean_m, ti=ti_m, ts_err_std_ms=np.nanstd(hws - fixed))
        )
    if statistical_motion is not None:
        amp, period = statistical_motion
        mean_u = rows[0]["mean_ms"]
        s_u = rows[0]["ti"] * mean_u
        sz = sigma_z(mean_u, amp, period, wind.wd, geom, lever_arm_m=LEVER_ARM_M).sigma_z_ms
        c, flag = corrected_std(s_u, sz, 0.0)
        rows.append(
            dict(
                method="statistical U",
                mean_ms=mean_u,
                ti=float(c) / mean_u,
                ts_err_std_ms=np.nan,
                discriminant_negative=bool(flag),
            )
        )
    for r in rows:
        r.update(
            meta,
            lidar=geom.name,
            mean_fixed_ms=mean_f,
            ti_fixed=ti_f,
            mean_truth_ms=mean_t,
            ti_truth=ti_t,
        )
    return rows


def part_a(ss):
    rows = []
    for cname, spec in CLASSES.items():
        for hws in SPEEDS_MS:
            for rep in range(NREP):
                rng = np.random.default_rng(ss.spawn(1)[0])
                wind = FrozenKaimalWind(
                    hws, rng.uniform(0, 360), offshore_sigma_ms(hws, HEIGHT_M), rng
                )
                motion = class_motion(spec, rng)
                meta = dict(part="A", motion_class=cname, speed_bin_ms=hws, rep=rep)
                for lidar in ("zephir300", "windcube_v1"):
                    rows += record_rows(lidar, motion, wind, (spec["amp"], spec["period"]), meta)
    return rows


def yamaguchi2016_motion(pitch_max_deg, phases):
    """Floater motion with periods 5-8 s, fixed phases, scaled to a pitch maximum (Yamaguchi and Ishihara, 2016)."""
    periods = np.array([5.0, 6.0, 7.0, 8.0])
    t = np.arange(0.0, DURATION_S + 10.0, 0.05)
    unit = np.sin(2 * np.pi * t[:, None] / periods + phases[0]).sum(1)
    a_pitch = pitch_max_deg / np.abs(unit).max()
    unit_r = np.sin(2 * np.pi * t[:, None] / periods + phases[1]).sum(1)
    a_roll = 0.5 * pitch_max_deg / np.abs(unit_r).max()
    return M.PlatformMotion(
        pitch=tuple(H(a_pitch, p, f) for p, f in zip(periods, phases[0], strict=True)),
        roll=tuple(H(a_roll, p, f) for p, f in zip(periods, phases[1], strict=True)),
        heave=tuple(H(0.25, p, f) for p, f in zip(periods, phases[2], strict=True)),
        surge=tuple(H(0.1, p, f) for p, f in zip(periods, phases[3], strict=True)),
        lever_arm_m=(0.0, 0.0, 5.0),
    )


def part_b(ss):
    rows = []
    phases = np.random.default_rng(ss.spawn(1)[0]).uniform(0, 2 * np.pi, (4, 4))
    for ti in (0.08, 0.10, 0.12, 0.15):
        for rep in range(2):
            rng = np.random.default_rng(ss.spawn(1)[0])
            wind = FrozenKaimalWind(10.0, rng.uniform(0, 360), ti * 10.0, rng)
            for pmax in (5.0, 10.0, 15.0, 20.0):
                meta = dict(
                    part="B",
                    motion_class=f"yamaguchi2016 pitch max {pmax:.0f} deg",
                    speed_bin_ms=10.0,
                    rep=rep,
                    ti_input=ti,
                    pitch_max_deg=pmax,
                )
                rows += record_rows(
                    "windcube_v1", yamaguchi2016_motion(pmax, phases), wind, None, meta
                )
    return rows


NREC_C = 36
IMU_VARIANTS = {
    "campaign IMU 5 Hz, 0.05 deg noise, gaps": {},
    "ideal IMU 20 Hz": dict(rate_hz=20.0, noise_deg=0.0, gap_probability=0.0),
}


def part_c(ss):
    """The virtual campaign with its LOS-level and raw IMU output.

    Default scenario (sea-state roll/pitch, periods ~2-6 s, ZephIR scanning 27, 58, 85 m in
    turn, head 2.5 m above the rotation centre). The LOS-level correction uses only what a
    user has: the LOS table and the IMU table (``motion.SampledMotion``; head velocity from
    the IMU angle rates and the lever arm). References: the campaign's fixed lidar
    (``ref_hws_*``) and truth (``true_hws_*``).
    """
    rows = []
    seed = ss.spawn(1)[0]
    for imu_label, imu_cfg in IMU_VARIANTS.items():
        sc = copy.deepcopy(DEFAULT_SCENARIO)
        sc.update(name="los_correction_comparison", n_records=NREC_C)
        sc["imu"].update(imu_cfg)
        out = generate_campaign(sc, seed, return_imu=True, return_los=True, n_workers=1)
        lever = tuple(sc["lidar"]["lever_arm_m"])
        origin = out.records.timestamp.min()
        los = out.los.sort_values("timestamp")
        t_los = (los.timestamp - origin).dt.total_seconds().to_numpy()
        imu = out.imu.dropna().sort_values("timestamp")
        t_imu = (imu.timestamp - origin).dt.total_seconds().to_numpy()
        for rec in out.records.itertuples():
            t0 = (rec.timestamp - origin).total_seconds()
            sel_i = (t_imu >= t0 - 5.0) & (t_imu <= t0 + sc["record_length_s"] + 5.0)
            if sel_i.sum() < 10 or not np.isfinite(rec.hws_std_ms):
                continue
            motion = M.SampledMotion(
                t_imu[sel_i],
                imu.roll_deg.to_numpy()[sel_i],
                imu.pitch_deg.to_numpy()[sel_i],
                imu.yaw_deg.to_numpy()[sel_i],
                lever_arm_m=lever,
            )
            sel = (t_los >= t0) & (t_los < t0 + sc["record_length_s"])
            sel &= los.height_m.to_numpy() == rec.height_m
            n = int(sel.sum()) // 50 * 50
            t = t_los[sel][:n]
            az = np.radians(los.azimuth_deg.to_numpy()[sel][:n])
            vr = los.radial_speed_ms.to_numpy()[sel][:n]
            series = {
                "uncorrected": correct_least_squares("zephir300", t, az, vr).hws_ms,
                "least_squares": correct_least_squares("zephir300", t, az, vr, motion).hws_ms,
            }
            out_rows = [
                dict(method=k, mean_ms=np.nanmean(h), ti=np.nanstd(h) / np.nanmean(h))
                for k, h in series.items()
            ]
            amp = 0.5 * (rec.roll_amplitude_deg + rec.pitch_amplitude_deg)
            period = 0.5 * (rec.roll_period_s + rec.pitch_period_s)
            sz = sigma_z(
                rec.hws_mean_ms, amp, period, rec.wd_mean_deg, "zephir300", lever_arm_m=lever
            ).sigma_z_ms
            c, flag = corrected_std(rec.hws_std_ms, sz, 0.0)
            out_rows.append(
                dict(
                    method="statistical U",
                    mean_ms=rec.hws_mean_ms,
                    ti=float(c) / rec.hws_mean_ms,
                    discriminant_negative=bool(flag),
                )
            )
            ref = rec.ref_hws_mean_ms
            for r in out_rows:
                r.update(
                    part="C",
                    lidar="zephir300",
                    motion_class=imu_label,
                    speed_bin_ms="<6" if ref < 6 else ("6-10" if ref < 10 else ">=10"),
                    rep=int(rec.true_record),
                    height_m=rec.height_m,
                    ts_err_std_ms=np.nan,
                    mean_fixed_ms=ref,
                    ti_fixed=rec.ref_hws_std_ms / ref,
                    mean_truth_ms=rec.true_hws_mean_ms,
                    ti_truth=rec.true_hws_std_ms / rec.true_hws_mean_ms,
                    campaign_hws_std_ms=rec.hws_std_ms,
                    campaign_imu_amplitude_deg=amp,
                    campaign_imu_period_s=period,
                )
            rows += out_rows
    return rows


def summarise(rec):
    rec = rec.assign(
        ti_err_fixed_pp=100 * (rec.ti - rec.ti_fixed),
        ti_err_truth_pp=100 * (rec.ti - rec.ti_truth),
        ape_pct=100 * np.abs(rec.mean_ms - rec.mean_fixed_ms) / rec.mean_fixed_ms,
    )
    rec["abs_ti_err_fixed_pp"] = rec.ti_err_fixed_pp.abs()

    def agg(df, keys):
        g = df.groupby(keys, sort=False)
        out = g.agg(
            n_records=("ti", "size"),
            ti_mean=("ti", "mean"),
            ti_fixed_mean=("ti_fixed", "mean"),
            ti_truth_mean=("ti_truth", "mean"),
            ti_err_vs_fixed_pp=("ti_err_fixed_pp", "mean"),
            abs_ti_err_vs_fixed_pp=("abs_ti_err_fixed_pp", "mean"),
            ti_err_vs_truth_pp=("ti_err_truth_pp", "mean"),
            mean_speed_ape_pct=("ape_pct", "mean"),
            ts_err_std_ms=("ts_err_std_ms", "mean"),
        ).reset_index()
        unc = out[out.method == "uncorrected"].set_index([k for k in keys if k != "method"])
        ref = unc.reindex(out.set_index([k for k in keys if k != "method"]).index)
        out["frac_removed_ti"] = (
            1 - out.abs_ti_err_vs_fixed_pp.values / ref.abs_ti_err_vs_fixed_pp.values
        )
        out["frac_removed_ti_bias"] = (
            1 - out.ti_err_vs_fixed_pp.values / ref.ti_err_vs_fixed_pp.values
        )
        out["frac_removed_ts"] = 1 - out.ts_err_std_ms.values / ref.ts_err_std_ms.values
        return out

    base = ["part", "lidar", "method"]
    tables = [
        agg(rec, base + ["motion_class", "speed_bin_ms"]),
        agg(rec.assign(speed_bin_ms="all"), base + ["motion_class", "speed_bin_ms"]),
    ]
    ab = rec[rec.part != "C"]  # part C's classes are IMU variants of the same records
    tables += [
        agg(ab.assign(motion_class="all"), base + ["motion_class", "speed_bin_ms"]),
        agg(
            ab.assign(motion_class="all", speed_bin_ms="all"),
            base + ["motion_class", "speed_bin_ms"],
        ),
    ]
    table = pd.concat(tables, ignore_index=True)
    table["speed_bin_ms"] = [x if isinstance(x, str) else f"{x:g}" for x in table.speed_bin_ms]
    return rec, table


def plot(rec, table):
    fig, axes = plt.subplots(1, 3, figsize=(17, 4.4), gridspec_kw=dict(width_ratios=[4, 4, 2]))
    panels = [("A", "zephir300"), ("A", "windcube_v1"), ("C", "zephir300")]
    for ax, (part, lidar) in zip(axes, panels, strict=True):
        t = table[
            (table.part == part)
            & (table.lidar == lidar)
            & (table.speed_bin_ms == "all")
            & (table.motion_class != "all")
        ]
        methods = list(dict.fromkeys(t.method))
        classes = list(dict.fromkeys(t.motion_class))
        w = 0.8 / len(methods)
        for i, m in enumerate(methods):
            v = t[t.method == m].set_index("motion_class").reindex(classes).ti_err_vs_fixed_pp
            ax.bar(np.arange(len(classes)) + i * w, v, w, label=m)
        ax.axhline(0, color="k", lw=0.8)
        ax.set_xticks(np.arange(len(classes)) + 0.4 - w / 2, classes, rotation=12, fontsize=7)
        ax.set_ylabel("TI error vs fixed lidar (percentage points)")
        title = "campaign" if part == "C" else "harmonic classes, mean over speeds"
        ax.set_title(f"{lidar}, {title}", fontsize=9)
        ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(OUT / "los_correction_comparison.png", dpi=110)
    plt.close(fig)

    b = rec[rec.part == "B"]
    fig, axes = plt.subplots(1, 2, figsize=(11, 4.2))
    for m, mk in (
        ("uncorrected", "x"),
        ("dbs_conventional", "o"),
        ("dbs_new", "s"),
        ("least_squares", "+"),
    ):
        s = b[b.method == m].groupby("pitch_max_deg")
        axes[0].plot(s.ti.mean().index, 100 * (s.ti.mean() - s.ti_truth.mean()), marker=mk, label=m)
        bm = b[b.method == m]
        axes[1].scatter(100 * bm.ti_truth, 100 * bm.ti, marker=mk, s=18, label=m)
    s = b[b.method == "uncorrected"].groupby("pitch_max_deg")
    axes[0].plot(
        s.ti.mean().index, 100 * (s.ti_fixed.mean() - s.ti_truth.mean()), "k--", label="fixed lidar"
    )
    axes[0].set_xlabel("maximum pitch (deg)")
    axes[0].set_ylabel("TI bias vs point truth (percentage points)")
    axes[0].set_title("Yamaguchi and Ishihara (2016) setup: TI bias vs pitch maximum")
    axes[0].legend(fontsize=8)
    lim = [5, 30]
    axes[1].plot(lim, lim, "k:", lw=0.8)
    axes[1].set_xlabel("reference TI (point truth, %)")
    axes[1].set_ylabel("estimated TI (%)")
    axes[1].set_title("Yamaguchi and Ishihara (2016) setup (cf. its Fig. 8)")
    axes[1].legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(OUT / "los_correction_comparison_yamaguchi2016.png", dpi=110)
    plt.close(fig)


def main():
    OUT.mkdir(parents=True, exist_ok=True)
    t0 = time.perf_counter()
    ss = np.random.SeedSequence(SEED)
    ss_a, ss_b, ss_c = ss.spawn(3)
    rec = pd.DataFrame(part_a(ss_a) + part_b(ss_b) + part_c(ss_c))
    rec, table = summarise(rec)
    keep = [
        "part",
        "lidar",
        "method",
        "motion_class",
        "speed_bin_ms",
        "rep",
        "height_m",
        "pitch_max_deg",
        "ti_input",
        "ti",
        "ti_fixed",
        "ti_truth",
        "mean_ms",
        "mean_fixed_ms",
        "mean_truth_ms",
        "ts_err_std_ms",
    ]
    rec[keep].to_csv(
        OUT / "los_correction_comparison_records.csv", index=False, float_format="%.4g"
    )
    table.to_csv(OUT / "los_correction_comparison.csv", index=False, float_format="%.4g")
    plot(rec, table)
    pd.set_option("display.width", 200)
    pd.set_option("display.max_columns", 20)
    cols = [
        "lidar",
        "method",
        "motion_class",
        "speed_bin_ms",
        "n_records",
        "ti_err_vs_fixed_pp",
        "ti_err_vs_truth_pp",
        "mean_speed_ape_pct",
        "ts_err_std_ms",
        "frac_removed_ti",
        "frac_removed_ti_bias",
        "frac_removed_ts",
    ]
    print(
        "Part A, all classes, by speed bin and overall "
        "(Malekmohammadi et al. (2024) reports 85 % (WindCube) / 82 % (ZephIR) removed):"
    )
    print(
        table[(table.part == "A") & (table.motion_class == "all")][cols].to_string(
            index=False, float_format="%.3f"
        )
    )
    print("\nPart A by motion class (all speeds):")
    print(
        table[(table.part == "A") & (table.speed_bin_ms == "all") & (table.motion_class != "all")][
            cols
        ].to_string(index=False, float_format="%.3f")
    )
    print("\nPart B, Yamaguchi and Ishihara (2016) setup (pulsed DBS, TI 8-15 %, 10 m/s):")
    print(
        table[(table.part == "B") & (table.speed_bin_ms == "all") & (table.motion_class != "all")][
            cols
        ].to_string(index=False, float_format="%.3f")
    )
    print("\nPart C, virtual campaign LOS + IMU output, ZephIR, 27/58/85 m:")
    print(table[(table.part == "C")][cols].to_string(index=False, float_format="%.3f"))
    print(
        f"\nrecords: {rec[['part', 'lidar', 'motion_class', 'speed_bin_ms', 'rep']].drop_duplicates().shape[0]}"
        f", wall time {time.perf_counter() - t0:.0f} s"
    )


if __name__ == "__main__":
    main()
