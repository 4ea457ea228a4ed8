"""What makes a DBS lidar's sigma_Z on a buoy: each mechanism's share on typical seas.

The harmonic sum of :func:`flidar_uq.physics.dbs_sigma_z.dbs_harmonic_sigma_z_ms` (within
5 % of LOS-level replay, ``benchmarks/dbs_sigma_z.py``) over the realised wave components of
typical seas (a 4-s wind sea; with a 9-s swell across or against the wind), for the
WindCube v2 (and v1, v2.1) with the head 2 m above the rotation centre, on a wave-following
hull and on a hull that only tilts, at 5, 10 and 15 m/s, averaged over the heading (the wind
direction relative to the beams uniform):

- ``geometry``: sigma_Z of the same cone with every beam of a cycle taken at once, as a
  share of the full sigma_Z (what the cone's geometry with the relative velocity gives
  alone; Desert, Knapp & Aubrun 2021 name it first);
- ``beam_timing``, ``tilt``, ``heave``, ``translation``, ``shear``: the share of sigma_Z^2 that goes
  when the mechanism is switched off, ``1 - sigma_Z,without^2 / sigma_Z^2`` (negative: the
  mechanism reduces sigma_Z; heave partly cancels the tilt's apparent vertical wind, so the
  shares need not add to one; ``shear``: the range gates that the tilt moves through a
  power-law profile of exponent 0.1, Yamaguchi and Ishihara 2016's offshore value);
- ``heading``: the std of sigma_Z over headings as a share of its rms (how much knowing the
  heading matters).

Run:  PYTHONPATH=src OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 python benchmarks/dbs_mechanisms.py
Writes benchmarks/results/dbs_mechanisms.csv and .png.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from flidar_uq.physics import dbs_sigma_z as dbs
from flidar_uq.physics.seastate import WaveSystem, hull_motion_series

OUT = Path(__file__).resolve().parent / "results"
DT_S = 0.05
DURATION_S = 1800.0
LEVER_M = 2.0
SEED = 20261203
N_HEADINGS = 24
LIDARS = ("windcube_v2", "windcube_v1", "windcube_v2_1")
HULL_NAMES = ("wave_follower", "rotation_only")
HWS = (5.0, 10.0, 15.0)
SHEAR_EXPONENT = 0.1
SEAS = {  # directions of travel relative to the wind's
    "windsea_4s": [WaveSystem(3.0, 4.0, 3.3, 0.0, 30.0)],
    "windsea+swell_across": [
        WaveSystem(2.4, 4.0, 3.3, 0.0, 30.0),
        WaveSystem(1.8, 9.0, 6.0, 90.0, 10.0),
    ],
    "windsea+swell_against": [
        WaveSystem(2.4, 4.0, 3.3, 0.0, 30.0),
        WaveSystem(1.8, 9.0, 6.0, 180.0, 10.0),
    ],
}
SWITCHED = ("beam_timing", "tilt", "heave", "translation", "shear")
COLUMNS = ("geometry", *SWITCHED, "heading")


def _per_heading(a, p, d_wind, hws, lidar, hull, mechanisms):
    """sigma_Z over the headings (the sea turns with the wind), shape (N_HEADINGS,)."""
    beta = (np.arange(N_HEADINGS) + 0.5) * 360.0 / N_HEADINGS
    return np.array(
        [
            float(
                dbs.dbs_harmonic_sigma_z_ms(
                    a,
                    p,
                    d_wind + b,
                    hws_ms=hws,
                    wind_body_deg=b,
                    lever_arm_m=LEVER_M,
                    hull=hull,
                    lidar=lidar,
                    mechanisms=mechanisms,
                    shear_exponent=SHEAR_EXPONENT,
                )
            )
            for b in beta
        ]
    )


def main() -> None:
    rng = np.random.default_rng(np.random.SeedSequence(SEED))
    n = int(DURATION_S / DT_S)
    rows = []
    for sea, systems in SEAS.items():
        for hull in HULL_NAMES:
            comp = hull_motion_series(n, DT_S, systems, rng, hull, return_components=True)[
                "components"
            ]
            a = comp["amplitude_deg"].ravel()
            keep = a > 1e-4 * a.max()
            a, p = a[keep], comp["period_s"].ravel()[keep]
            d = comp["direction_deg"].ravel()[keep]  # relative to the wind (downwind = 0)
            for lidar in LIDARS:
                for hws in HWS:
                    full = _per_heading(a, p, d, hws, lidar, hull, dbs.DBS_MECHANISMS)
                    rms = np.sqrt(np.mean(full**2))
                    row = dict(lidar=lidar, sea=sea, hull=hull, hws_ms=hws, sigma_z_ms=rms)
                    for mech in SWITCHED:
                        kept = tuple(m for m in dbs.DBS_MECHANISMS if m != mech)
                        s = _per_heading(a, p, d, hws, lidar, hull, kept)
                        row[mech] = 1.0 - np.mean(s**2) / rms**2
                    no_timing = tuple(m for m in dbs.DBS_MECHANISMS if m != "beam_timing")
                    s = _per_heading(a, p, d, hws, lidar, hull, no_timing)
                    row["geometry"] = np.sqrt(np.mean(s**2)) / rms
                    row["heading"] = np.std(full) / rms
                    rows.append(row)
    df = pd.DataFrame(rows)
    OUT.mkdir(exist_ok=True)
    df.to_csv(OUT / "dbs_mechanisms.csv", index=False, float_format="%.4f")
    pd.set_option("display.width", 200)
    print(df.to_string(index=False, float_format=lambda v: f"{v:.3f}"))
    g = df[(df.lidar == "windcube_v2") & (df.hws_ms == 10.0)]
    print(
        "\nWindCube v2, 10 m/s, heading-averaged (shares of sigma_Z^2; geometry, heading: of sigma_Z):"
    )
    print(
        g[["sea", "hull", "sigma_z_ms", *COLUMNS]].to_string(
            index=False, float_format=lambda v: f"{v:.2f}"
        )
    )
    _plot(df)


def _plot(df: pd.DataFrame) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    g0 = df[(df.lidar == "windcube_v2") & (df.hws_ms == 10.0)]
    fig, axes = plt.subplots(1, len(HULL_NAMES), figsize=(13, 4.8), sharey=True)
    seas = list(SEAS)
    width = 0.8 / len(COLUMNS)
    for ax, hull in zip(axes, HULL_NAMES, strict=True):
        g = g0[g0.hull == hull].set_index("sea").loc[seas]
        for k, col in enumerate(COLUMNS):
            ax.bar(
                np.arange(len(seas)) + (k - 0.5 * (len(COLUMNS) - 1)) * width,
                g[col],
                width,
                label=col,
            )
        ax.axhline(0.0, color="k", lw=0.6)
        ax.set_xticks(range(len(seas)), seas, fontsize=8)
        ax.set_title(f"{hull} (sigma_Z {', '.join(f'{v:.2f}' for v in g.sigma_z_ms)} m/s)")
    axes[0].set_ylabel("share")
    axes[0].legend(fontsize=8)
    fig.suptitle(
        "WindCube v2 on a buoy, 10 m/s, heading-averaged: share of sigma_Z^2 lost when a "
        "mechanism is off; geometry = simultaneous beams / full; heading = std / rms over headings",
        fontsize=9,
    )
    fig.tight_layout()
    fig.savefig(OUT / "dbs_mechanisms.png", dpi=110)


if __name__ == "__main__":
    main()
