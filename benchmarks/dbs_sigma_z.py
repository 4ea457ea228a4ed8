"""sigma_Z of a pulsed DBS lidar on a moving hull: the harmonic sum against LOS-level replay.

For each DBS lidar (``windcube_v2``, ``windcube_v1``, ``windcube_v2_1``), sea (a JONSWAP
wind sea, a short wind sea, wind sea plus a swell across or against the wind, a swell alone
across the wind: a "heaving sea"), hull (``wave_follower``, ``discus_buoy``,
``rotation_only``), heading (the wind blowing towards 0, 45, ..., 315 deg from the body x
axis: along a beam or between two) and HWS (5, 10, 15 m/s), with the
head 2 m above the rotation centre:

- ``replay``: realised sigma_Z, the six-degree-of-freedom series of
  :func:`flidar_uq.physics.seastate.hull_motion_series` replayed line of sight by line of
  sight through the scan simulator with the DBS geometry (every beam at its own time:
  :func:`flidar_uq.physics.dbs_sigma_z.dbs_replay_sigma_z_ms`), the reference;
- ``components``: :func:`flidar_uq.physics.dbs_sigma_z.dbs_harmonic_sigma_z_ms` over the
  realised Fourier components (amplitude, period, direction);
- ``bands_16``: the same over 16 log-spaced period bands (1-20 s) per wave system, each at
  its centroid period and the variance-weighted moments of its components' directions
  (``<cos>``, ``<sin>``, ``<cos^2>``, ``<sin cos>``, ``<sin^2>``: a directional spectral
  description);
- ``heading_avg``: the heading-averaged sum (wind direction relative to the beams unknown,
  the eight headings) against the replay's rms over them, per (lidar, sea, hull, HWS).

Ratios are ``sqrt(mean(s_method^2) / mean(s_replay^2))`` over the records of a case (the
replay's own sampling noise: ~2 % for a 60-min series of 5-s cycles, pooled over records).
The speeds of the harmonic sum (records/s, 16 bands) and of the replay (10-min records/s)
are measured in the same run.

Run:  PYTHONPATH=src OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 python benchmarks/dbs_sigma_z.py
Writes benchmarks/results/dbs_sigma_z.csv and .png.
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np
import pandas as pd

from flidar_uq.physics import dbs_sigma_z as dbs
from flidar_uq.physics.seastate import WaveSystem, hull_motion_series

OUT = Path(__file__).resolve().parent / "results"
DT_S = 0.05
DURATION_S = 3600.0
N_REC = 3
LEVER_M = 2.0
LIDARS = ("windcube_v2", "windcube_v1", "windcube_v2_1")
HULL_NAMES = ("wave_follower", "discus_buoy", "rotation_only")
HWS = (5.0, 10.0, 15.0)
WIND_BODY_DEG = tuple(45.0 * k for k in range(8))  # the wind blows towards this body direction
SEED = 20261202
N_BANDS = 16
METHODS = ("components", f"bands_{N_BANDS}")

# wave directions of travel relative to the wind's (0: downwind); rotated with the wind
SEAS = {
    "windsea": [WaveSystem(3.0, 4.0, 3.3, 0.0, 30.0)],
    "windsea_short": [WaveSystem(3.0, 3.0, 3.3, 0.0, 30.0)],
    "swell_across": [WaveSystem(2.4, 4.0, 3.3, 0.0, 30.0), WaveSystem(1.8, 9.0, 6.0, 90.0, 10.0)],
    "swell_against": [WaveSystem(2.4, 4.0, 3.3, 0.0, 30.0), WaveSystem(1.8, 9.0, 6.0, 180.0, 10.0)],
    "heaving_sea": [WaveSystem(2.0, 8.0, 6.0, 90.0, 10.0)],
}


def band_description(comp, n_bands=N_BANDS):
    """Components reduced to log-spaced period bands (1-20 s) per wave system: amplitude
    (deg), centroid period (s) and the variance-weighted direction moments (n, 5)."""
    amp, per, dire = (
        comp[k].reshape(-1, comp[k].shape[-1])
        for k in ("amplitude_deg", "period_s", "direction_deg")
    )
    edges = np.geomspace(1.0, 20.0, n_bands + 1)
    rows = []
    for a, p, d in zip(amp, per, dire, strict=True):
        var = a**2 / 2.0
        idx = np.digitize(p, edges)
        mom = dbs.direction_moments(d)
        for b in range(n_bands + 2):
            m = (idx == b) & (var > 0)
            if not m.any():
                continue
            v = var[m].sum()
            rows.append(
                (
                    np.sqrt(2.0 * v),
                    v / np.sum(var[m] / p[m]),
                    np.sum(var[m, None] * mom[m], axis=0) / v,
                )
            )
    return (
        np.array([r[0] for r in rows]),
        np.array([r[1] for r in rows]),
        np.array([r[2] for r in rows]),
    )


def _rotated(systems, deg):
    return [
        WaveSystem(s.amplitude_deg, s.tp_s, s.gamma, s.direction_deg + deg, s.spread_deg)
        for s in systems
    ]


def main() -> None:
    rng = np.random.default_rng(np.random.SeedSequence(SEED))
    n = int(DURATION_S / DT_S)
    t = np.arange(n) * DT_S
    rows = []
    t0 = time.perf_counter()
    for sea, systems in SEAS.items():
        for hull in HULL_NAMES:
            for beta in WIND_BODY_DEG:
                wd = float(dbs.wind_to_body_deg(beta))  # wind_to_body is its own inverse
                for rec in range(N_REC):
                    m = hull_motion_series(
                        n, DT_S, _rotated(systems, beta), rng, hull, return_components=True
                    )
                    comp = m["components"]
                    trans = np.column_stack([m["surge_m"], m["sway_m"], m["heave_m"]])
                    a_c = comp["amplitude_deg"].ravel()
                    keep = a_c > 1e-4 * a_c.max()
                    a_c = a_c[keep]
                    p_c = comp["period_s"].ravel()[keep]
                    d_c = comp["direction_deg"].ravel()[keep]
                    ba, bp, bd = band_description(comp)
                    for lidar in LIDARS:
                        kw = dict(lever_arm_m=LEVER_M, hull=hull, lidar=lidar)
                        for hws in HWS:
                            rep = dbs.dbs_replay_sigma_z_ms(
                                t,
                                m["roll_deg"],
                                m["pitch_deg"],
                                hws_ms=hws,
                                wd_deg=wd,
                                lever_arm_m=LEVER_M,
                                translation_m=trans,
                                lidar=lidar,
                            )
                            comp_sz = dbs.dbs_harmonic_sigma_z_ms(
                                a_c, p_c, d_c, hws_ms=hws, wind_body_deg=beta, **kw
                            )
                            band_sz = dbs.dbs_harmonic_sigma_z_ms(
                                ba, bp, hws_ms=hws, wind_body_deg=beta, direction_moments_=bd, **kw
                            )
                            avg, spread = dbs.dbs_heading_average_sigma_z_ms(
                                ba,
                                bp,
                                hws_ms=hws,
                                moments_to_wind=dbs.rotate_moments(bd, -beta),
                                n_headings=len(WIND_BODY_DEG),
                                **kw,
                            )
                            rows.append(
                                dict(
                                    lidar=lidar,
                                    sea=sea,
                                    hull=hull,
                                    wind_body_deg=beta,
                                    hws_ms=hws,
                                    record=rec,
                                    replay=rep,
                                    components=float(comp_sz),
                                    **{f"bands_{N_BANDS}": float(band_sz)},
                                    heading_avg=float(avg),
                                    heading_spread=float(spread),
                                )
                            )
        print(f"{sea}: done ({time.perf_counter() - t0:.0f} s)", flush=True)
    df = pd.DataFrame(rows)

    def pooled(g, col):
        return np.sqrt(np.mean(g[col] ** 2) / np.mean(g["replay"] ** 2))

    keys = ["lidar", "sea", "hull", "wind_body_deg", "hws_ms"]
    summary = (
        df.groupby(keys)
        .apply(
            lambda g: pd.Series(
                {c: pooled(g, c) for c in METHODS}
                | {"replay_ms": np.sqrt(np.mean(g["replay"] ** 2))}
            ),
            include_groups=False,
        )
        .reset_index()
    )
    avg = (
        df.groupby(["lidar", "sea", "hull", "hws_ms"])
        .apply(
            lambda g: pd.Series(
                {
                    "heading_avg": pooled(g, "heading_avg"),
                    "heading_spread_share": float(
                        np.mean(g["heading_spread"]) / np.sqrt(np.mean(g["replay"] ** 2))
                    ),
                    "replay_heading_cv": float(
                        g.groupby("wind_body_deg")["replay"]
                        .apply(lambda r: np.sqrt(np.mean(r**2)))
                        .std()
                        / np.sqrt(np.mean(g["replay"] ** 2))
                    ),
                }
            ),
            include_groups=False,
        )
        .reset_index()
    )
    # speeds: the harmonic sum of 1e5 records x 16 bands, the replay of a 10-min record
    n_speed = 100_000
    ra = rng.uniform(0.2, 4.0, (n_speed, N_BANDS))
    rp = np.geomspace(1.5, 16.0, N_BANDS)[None, :] * rng.uniform(0.9, 1.1, (n_speed, N_BANDS))
    rd = dbs.direction_moments(rng.uniform(-180, 180, (n_speed, N_BANDS)))
    rh = rng.uniform(3, 20, n_speed)
    rb = rng.uniform(0, 360, n_speed)
    t1 = time.perf_counter()
    dbs.dbs_harmonic_sigma_z_ms(
        ra, rp, hws_ms=rh, wind_body_deg=rb, direction_moments_=rd, lever_arm_m=LEVER_M
    )
    sum_rate = n_speed / (time.perf_counter() - t1)
    n10 = int(600.0 / DT_S)
    t1 = time.perf_counter()
    for _ in range(5):
        dbs.dbs_replay_sigma_z_ms(
            t[:n10],
            m["roll_deg"][:n10],
            m["pitch_deg"][:n10],
            hws_ms=10.0,
            wd_deg=270.0,
            lever_arm_m=LEVER_M,
            translation_m=trans[:n10],
        )
    replay_rate = 5.0 / (time.perf_counter() - t1)
    summary["sum_records_per_s"] = sum_rate
    summary["replay_records_per_s"] = replay_rate
    OUT.mkdir(exist_ok=True)
    summary.to_csv(OUT / "dbs_sigma_z.csv", index=False, float_format="%.4f")
    avg.to_csv(OUT / "dbs_sigma_z_heading_average.csv", index=False, float_format="%.4f")
    pd.set_option("display.width", 200)
    print(summary.to_string(index=False, float_format=lambda v: f"{v:.3f}"))
    for col in METHODS:
        r = summary[col]
        within = np.mean(np.abs(r - 1.0) <= 0.05)
        print(
            f"{col}: ratio to replay {r.min():.3f}-{r.max():.3f}, median {r.median():.3f}, "
            f"{100 * within:.1f} % of {r.size} cases within 5 %"
        )
        for lidar in LIDARS:
            g = summary[summary.lidar == lidar][col]
            print(f"  {lidar}: {g.min():.3f}-{g.max():.3f}")
    h = avg["heading_avg"]
    print(
        f"heading_avg: ratio to replay's rms over headings {h.min():.3f}-{h.max():.3f}; "
        f"replay's spread over headings {100 * avg['replay_heading_cv'].median():.0f} % "
        f"(median), predicted {100 * avg['heading_spread_share'].median():.0f} %"
    )
    print(
        f"harmonic sum {sum_rate:,.0f} records/s ({N_BANDS} bands), replay "
        f"{replay_rate:.1f} records/s (10 min, {DT_S} s motion): x{sum_rate / replay_rate:,.0f}"
    )
    _plot(summary)


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
            ax.scatter(x, gh["components"], marker=mk, s=14, label=f"{hull}: components")
            ax.scatter(
                x,
                gh[f"bands_{N_BANDS}"],
                marker=mk,
                s=14,
                facecolors="none",
                edgecolors="k",
                linewidths=0.5,
                label=f"{hull}: {N_BANDS} bands",
            )
        ax.axhspan(0.95, 1.05, color="0.88", zorder=0, label="+-5 %")
        ax.set_xticks(range(len(seas)), seas, rotation=30, ha="right", fontsize=8)
        ax.set_title(lidar)
    axes[0].set_ylabel("sigma_Z(harmonic sum) / sigma_Z(LOS replay)")
    axes[0].legend(fontsize=7, ncol=2)
    fig.suptitle(
        "DBS sigma_Z: harmonic sum over the beam times vs LOS-level replay "
        f"(8 headings, HWS 5-15 m/s, lever arm {LEVER_M:g} m)"
    )
    fig.tight_layout()
    fig.savefig(OUT / "dbs_sigma_z.png", dpi=110)


if __name__ == "__main__":
    main()
