"""sigma_Z of a DBS lidar on a wave follower: what the first-order harmonic sum leaves out.

The first-order harmonic sum of the along-wind error
(:func:`flidar_uq.physics.dbs_sigma_z.dbs_harmonic_sigma_z_ms`, ``cross_wind=False``)
against the LOS-level replay: how much of the difference is the HWS's nonlinearity in the
cross-wind error (in the record model to fourth order,
:func:`flidar_uq.physics.dbs_sigma_z.hws_error_moments`) and how much the rest. The
LOS-level replay (:func:`flidar_uq.physics.motion_spectrum.replay_sigma_z` with the DBS geometry, as
:func:`flidar_uq.physics.dbs_sigma_z.dbs_replay_sigma_z_ms`, each beam the mean over its
dwell) holds every order. This benchmark separates the two differences
on the seas of ``benchmarks/dbs_sigma_z.py`` (a wave follower, head 2 m above the rotation
centre, 8 headings, 5 / 10 / 15 m/s, ``N_REC`` ten-minute records a case):

- ``linear_ratio``: first-order sum over replay with the motion scaled by 0.1 (the replay
  then linear in it): the first-order description itself, with the replay's sampling of a
  finite record;
- ``nonlinear_drift``: the same ratio at the true motion over the ratio at 0.1 of it: how
  much the replay's sigma_Z grows less (> 1) or more (< 1) than linearly;
- ``hws_factor``: the replay's sigma_Z over the std of its along-wind error ``a`` at the
  true motion, the HWS's own nonlinearity: ``Z = |U + a, b| - U``;
- ``hws_factor_4th``: its fourth-order value from the replay's ``a`` and cross-wind ``b``
  (:func:`flidar_uq.physics.dbs_sigma_z.hws_error_moments`:
  ``sqrt(1 + (s_b^4 / 2 - s_a^2 s_b^2 - 2 c_ab^2) / (U^2 s_a^2))``);
- ``along_drift``: the growth of ``s_a`` itself over linear (second-order along-wind terms:
  tilt times heave, tilt squared times U);
- ``mean_z_rel``: the replay's mean Z over U (the motion's bias of the mean HWS, in the TI's
  denominator), and ``mean_z_cross_rel``, its cross-wind part ``s_b^2 / (2 U^2)`` (the
  record model's).

Run:  PYTHONPATH=src OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 python benchmarks/dbs_sigma_z_second_order.py
Writes benchmarks/results/dbs_sigma_z_second_order.csv and .png.
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np
import pandas as pd

from flidar_uq.physics import dbs_sigma_z as dbs
from flidar_uq.physics.lidar import get_lidar
from flidar_uq.physics.motion_spectrum import replay_sigma_z
from flidar_uq.physics.seastate import WaveSystem, hull_motion_series

OUT = Path(__file__).resolve().parent / "results"
DT_S = 0.05
N_SAMPLES = 12_000  # ten minutes
N_REC = 12
DWELL_SAMPLES = 10
LEVER_M = 2.0
SMALL = 0.1  # the motion scale at which the replay is linear in the motion
LIDARS = ("windcube_v2", "windcube_v1", "windcube_v2_1")
HWS = (5.0, 10.0, 15.0)
WIND_BODY_DEG = tuple(45.0 * k for k in range(8))
SEED = 20261205
# directions of travel relative to the wind's (0: downwind), as benchmarks/dbs_sigma_z.py
SEAS = {
    "windsea": [WaveSystem(3.0, 4.0, 3.3, 0.0, 30.0)],
    "swell_across": [WaveSystem(2.4, 4.0, 3.3, 0.0, 30.0), WaveSystem(1.8, 9.0, 6.0, 90.0, 10.0)],
    "swell_against": [WaveSystem(2.4, 4.0, 3.3, 0.0, 30.0), WaveSystem(1.8, 9.0, 6.0, 180.0, 10.0)],
    "heaving_sea": [WaveSystem(2.0, 8.0, 6.0, 90.0, 10.0)],
}


def _first_order(comp, scale, hws, beta, lidar) -> float:
    """The first-order along-wind sum (m/s) over the realised components."""
    return float(
        dbs.dbs_harmonic_sigma_z_ms(
            scale * comp[0],
            comp[1],
            comp[2],
            hws_ms=hws,
            wind_body_deg=beta,
            lever_arm_m=LEVER_M,
            hull="wave_follower",
            lidar=lidar,
            dwell_average=True,
            cross_wind=False,
        )  # fmt: skip
    )


def _replay(m, scale, hws, wd, beta, lidar) -> dict:
    """Pooled replay statistics of the records of ``m`` with the motion scaled."""
    t = np.arange(N_SAMPLES) * DT_S
    trans = scale * np.column_stack([m["surge_m"], m["sway_m"], m["heave_m"]])
    # heading 0: the body axes are east and north, the wind blows towards beta from east
    e_par = np.array([np.cos(np.deg2rad(beta)), np.sin(np.deg2rad(beta))])
    e_perp = np.array([-e_par[1], e_par[0]])
    z2, a2, b2, ab, mz = [], [], [], [], []
    for i in range(N_REC):
        sl = slice(i * N_SAMPLES, (i + 1) * N_SAMPLES)
        res = replay_sigma_z(
            t, scale * m["roll_deg"][sl], scale * m["pitch_deg"][sl], hws_ms=hws, wd_deg=wd,
            lever_arm_m=LEVER_M, translation_m=trans[sl], lidar=get_lidar(lidar),
            dwell_samples=DWELL_SAMPLES,
        )  # fmt: skip
        a = res.wind_ms @ e_par
        b = res.wind_ms @ e_perp
        a, b = a - a.mean(), b - b.mean()
        z2.append(res.sigma_z_ms**2)
        a2.append(np.mean(a * a))
        b2.append(np.mean(b * b))
        ab.append(np.mean(a * b))
        mz.append(res.mean_z_ms)
    return {
        k: float(np.mean(v))
        for k, v in zip(("z2", "a2", "b2", "ab", "mz"), (z2, a2, b2, ab, mz), strict=True)
    }


def _cases(rng) -> pd.DataFrame:
    rows = []
    for sea, systems in SEAS.items():
        for beta in WIND_BODY_DEG:
            turned = [
                WaveSystem(s.amplitude_deg, s.tp_s, s.gamma, s.direction_deg + beta, s.spread_deg)
                for s in systems
            ]
            m = hull_motion_series(
                N_SAMPLES * N_REC, DT_S, turned, rng, "wave_follower", return_components=True
            )
            c = m["components"]
            amp = c["amplitude_deg"].ravel()
            keep = amp > 1e-4 * amp.max()
            comp = (amp[keep], c["period_s"].ravel()[keep], c["direction_deg"].ravel()[keep])
            wd = float(dbs.wind_to_body_deg(beta))  # its own inverse at yaw 0
            for lidar in LIDARS:
                for hws in HWS:
                    lo, hi = (_replay(m, s, hws, wd, beta, lidar) for s in (SMALL, 1.0))
                    f_lo, f_hi = (_first_order(comp, s, hws, beta, lidar) for s in (SMALL, 1.0))
                    sa2, sb2 = hi["a2"], hi["b2"]
                    var4, mean4 = dbs.hws_error_moments(sa2, sb2, hi["ab"], hws)
                    rows.append(
                        dict(
                            lidar=lidar,
                            sea=sea,
                            wind_body_deg=beta,
                            hws_ms=hws,
                            replay_ms=np.sqrt(hi["z2"]),
                            linear_ratio=f_lo / np.sqrt(lo["z2"]),
                            nonlinear_drift=(f_hi / np.sqrt(hi["z2"])) / (f_lo / np.sqrt(lo["z2"])),
                            hws_factor=np.sqrt(hi["z2"] / sa2),
                            hws_factor_4th=np.sqrt(var4 / sa2),
                            along_drift=np.sqrt(sa2 / lo["a2"]) * SMALL,
                            cross_over_u=np.sqrt(sb2) / hws,
                            mean_z_rel=hi["mz"] / hws,
                            mean_z_cross_rel=mean4 / hws,
                        )  # fmt: skip
                    )
        print(f"{sea}: done", flush=True)
    return pd.DataFrame(rows)


def _plot(df: pd.DataFrame, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(1, 3, figsize=(15, 4.6))
    for sea, g in df.groupby("sea"):
        ax[0].scatter(g["cross_over_u"], g["nonlinear_drift"], s=12, label=sea)
        ax[1].scatter(g["hws_factor_4th"], g["hws_factor"], s=12, label=sea)
        ax[2].scatter(g["mean_z_cross_rel"] * 100, g["mean_z_rel"] * 100, s=12, label=sea)
    ax[0].axhline(1.0, color="k", lw=0.8)
    ax[0].set(xlabel="cross-wind error std / U (-)", ylabel="first-order / replay, true over 0.1 x motion",
              title="the replay's nonlinearity (> 1: the sum over)")  # fmt: skip
    lim = [min(df["hws_factor"].min(), df["hws_factor_4th"].min()), 1.005]
    ax[1].plot(lim, lim, "k", lw=0.8)
    ax[1].set(xlabel="4th-order HWS factor (from the replay's a, b)", ylabel="replay sigma_Z / std(a)",
              title="the HWS's own nonlinearity")  # fmt: skip
    hi = max(df["mean_z_cross_rel"].max(), df["mean_z_rel"].max()) * 100
    ax[2].plot([0, hi], [0, hi], "k", lw=0.8)
    ax[2].set(xlabel="cross-wind part s_b^2 / (2 U^2), %", ylabel="replay mean Z / U, %",
              title="the motion's bias of the mean HWS")  # fmt: skip
    ax[0].legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=110)


def main() -> int:
    t0 = time.perf_counter()
    df = _cases(np.random.default_rng(np.random.SeedSequence(SEED)))
    OUT.mkdir(exist_ok=True)
    df.to_csv(OUT / "dbs_sigma_z_second_order.csv", index=False, float_format="%.5f")
    _plot(df, OUT / "dbs_sigma_z_second_order.png")
    cols = ["linear_ratio", "nonlinear_drift", "hws_factor", "hws_factor_4th", "along_drift",
            "mean_z_rel", "mean_z_cross_rel"]  # fmt: skip
    pd.set_option("display.width", 200)
    print(df.groupby(["lidar", "sea", "hws_ms"])[cols].mean().round(4).to_string())
    err4 = (df["hws_factor_4th"] - 1) / (df["hws_factor"] - 1)
    big = df["hws_factor"] < 0.995
    print(
        f"the 4th-order HWS factor's reduction over the replay's, where it is > 0.5 %: "
        f"median {err4[big].median():.2f} ({int(big.sum())} of {len(df)} cases)"
    )
    print(f"{len(df)} cases in {time.perf_counter() - t0:.0f} s")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
