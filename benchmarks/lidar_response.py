"""Benchmark: the motionless lidar's std over the point std, theory against the virtual campaign.

The virtual campaign's reference lidar (motionless ZephIR-like VAD) measures a 10-min HWS
std above the point truth (in-scan leakage of w' and of u', v' at twice the scan
frequency, partly offset by the scan average). ``flidar_uq.physics.lidar_response.lidar_std_ratio``
predicts it from the Kaimal spectra and the scan geometry, without using the campaign's
truth. This script compares, per height and 2-m/s speed bin, the campaign's
``sqrt(mean(ref_std^2) / mean(true_std^2))`` with the prediction for the campaign's
band-limited turbulence (Nyquist 5 Hz, the pipeline's ``auto``) and for the continuous
atmospheric spectrum; writes ``benchmarks/results/lidar_response.csv`` and ``.png`` and
prints the ratios side by side.

Usage: ``python benchmarks/lidar_response.py [records.csv]`` (default: the pipeline's
``results/campaign/records.parquet``; without it, a 1500-record default campaign is generated).

``python benchmarks/lidar_response.py --study spatial``: the spatial model
(``flidar_uq.physics.lidar_spatial_response``: scan disk and probe volume in coherent
turbulence) per lidar, height and wind speed beside the temporal ratio, the prior on
``log g`` across turbulence models, and a PyConTurb field advected through the WindCube
v2's beams (3 records each); writes ``benchmarks/results/lidar_spatial_response.csv`` and
``.png`` (about 3 minutes on 2 cores).
"""

from __future__ import annotations

import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pandas as pd  # noqa: E402

from flidar_uq.campaign.physics_mode import generate_campaign  # noqa: E402
from flidar_uq.campaign.scenarios import load_scenario, reference_sampling  # noqa: E402
from flidar_uq.physics.lidar_response import lidar_std_ratio  # noqa: E402
from flidar_uq.physics.lidar_spatial_response import (  # noqa: E402
    SpatialTurbulence,
    lidar_spatial_std_ratio,
    lidar_std_ratio_prior,
    simulate_spatial_std_ratio,
)
from flidar_uq.physics.turbulence import kaimal_lambda1_m  # noqa: E402

RESULTS = Path(__file__).resolve().parent / "results"
REPO = Path(__file__).resolve().parents[1]


def _records(argv) -> pd.DataFrame:
    path = Path(argv[1]) if len(argv) > 1 else REPO / "results" / "campaign" / "records.parquet"
    if path.is_file():
        print(f"records: {path}")
        return pd.read_parquet(path) if path.suffix == ".parquet" else pd.read_csv(path)
    print("records: generating a 1500-record default campaign (seed 20181122)")
    scen = load_scenario("default") | {"n_records": 1500}
    return generate_campaign(scen, 20181122, n_workers=2).records


def main(argv) -> pd.DataFrame:
    d = _records(argv)
    d = d[(d["ref_hws_mean_ms"] > 3) & (d["ref_hws_mean_ms"] < 20)].copy()
    d["speed_bin_ms"] = (d["ref_hws_mean_ms"] / 2).round() * 2
    f_max = 0.5 / reference_sampling("default")["turbulence_dt_s"]
    rows = []
    for (z, u), g in d.groupby(["height_m", "speed_bin_ms"]):
        if len(g) < 20:
            continue
        emp = np.sqrt((g["ref_hws_std_ms"] ** 2).mean() / (g["true_hws_std_ms"] ** 2).mean())
        hws = g["ref_hws_mean_ms"].to_numpy()
        band = lidar_std_ratio(hws, z, turbulence_max_frequency_hz=f_max)
        cont = lidar_std_ratio(hws, z)
        rows.append(
            {
                "height_m": z,
                "speed_bin_ms": u,
                "n_records": len(g),
                "campaign_ratio": emp,
                "theory_band_limited": float(np.sqrt(np.mean(band**2))),
                "theory_continuous": float(np.sqrt(np.mean(cont**2))),
            }
        )
    out = pd.DataFrame(rows)
    out["band_limited_minus_campaign"] = out["theory_band_limited"] - out["campaign_ratio"]
    RESULTS.mkdir(exist_ok=True)
    out.to_csv(RESULTS / "lidar_response.csv", index=False)
    fig, axes = plt.subplots(1, out["height_m"].nunique(), figsize=(11, 3.6), sharey=True)
    for ax, (z, g) in zip(np.atleast_1d(axes), out.groupby("height_m"), strict=True):
        ax.plot(g["speed_bin_ms"], g["campaign_ratio"], "ko", label="campaign: ref / truth")
        ax.plot(
            g["speed_bin_ms"], g["theory_band_limited"], "C0-", label=f"theory, {f_max:g} Hz band"
        )
        ax.plot(g["speed_bin_ms"], g["theory_continuous"], "C1--", label="theory, continuous")
        ax.set_title(f"z = {z:g} m")
        ax.set_xlabel("HWS (m/s)")
        ax.grid(alpha=0.3)
    np.atleast_1d(axes)[0].set_ylabel("std ratio, motionless lidar / point (-)")
    np.atleast_1d(axes)[0].legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(RESULTS / "lidar_response.png", dpi=110)
    with pd.option_context("display.width", 160):
        print(out.round(4).to_string(index=False))
    err = out["band_limited_minus_campaign"]
    print(
        f"band-limited theory minus campaign: mean {err.mean():+.4f}, "
        f"max |.| {err.abs().max():.4f} (std ratio)"
    )
    return out


def spatial_study() -> pd.DataFrame:
    """The spatial model against the temporal ratio and a simulated 3-D field."""
    rows = []
    for lidar in ("zephir300", "windcube_v2"):
        for z in (40.0, 100.0, 150.0):
            speeds = np.array([5.0, 10.0, 15.0])
            mean, sd = lidar_std_ratio_prior(speeds, z, lidar)
            # PyConTurb's coherence: u' only, L_c = 340.2 m at every height
            sim_model = SpatialTurbulence(
                coherence_length_per_lambda1=(340.2 / kaimal_lambda1_m(z), 0.0, 0.0)
            )
            for k, u in enumerate(speeds):
                row = {
                    "lidar": lidar,
                    "height_m": z,
                    "hws_ms": u,
                    "temporal": lidar_std_ratio(u, z, lidar)[()],
                    "spatial_iec": lidar_spatial_std_ratio(u, z, lidar)[()],
                    "spatial_probe_only": lidar_spatial_std_ratio(u, z, lidar, disk_scale=0.0)[()],
                    "spatial_disk_only": lidar_spatial_std_ratio(
                        u, z, lidar, probe_scale=0.0, n_range=1
                    )[()],
                    "prior_g": float(np.exp(mean[k])),
                    "prior_log_sd": float(sd[k]),
                    "model_as_simulated": np.nan,
                    "simulated": np.nan,
                    "simulated_se": np.nan,
                }
                # a ZephIR's 50 focus points make the PyConTurb field too slow to simulate here
                if lidar == "windcube_v2":
                    row["model_as_simulated"] = lidar_spatial_std_ratio(
                        u, z, lidar, model=sim_model, n_range=3
                    )[()]
                    row["simulated"], row["simulated_se"] = simulate_spatial_std_ratio(
                        u, z, lidar, n_records=3, seed=int(10 * z + u)
                    )
                rows.append(row)
                print({k2: round(v, 4) if isinstance(v, float) else v for k2, v in row.items()})
    out = pd.DataFrame(rows)
    RESULTS.mkdir(exist_ok=True)
    out.to_csv(RESULTS / "lidar_spatial_response.csv", index=False)
    fig, axes = plt.subplots(1, 2, figsize=(11, 3.8), sharey=True)
    for ax, (lidar, g) in zip(axes, out.groupby("lidar", sort=False), strict=True):
        for i, (z, gz) in enumerate(g.groupby("height_m")):
            ax.plot(gz["hws_ms"], gz["temporal"], f"C{i}:", label=f"{z:g} m temporal")
            ax.plot(gz["hws_ms"], gz["spatial_iec"], f"C{i}-", label=f"{z:g} m spatial (IEC)")
            ax.fill_between(
                gz["hws_ms"],
                gz["prior_g"] * np.exp(-gz["prior_log_sd"]),
                gz["prior_g"] * np.exp(gz["prior_log_sd"]),
                color=f"C{i}",
                alpha=0.15,
            )
            if gz["simulated"].notna().any():
                ax.errorbar(
                    gz["hws_ms"], gz["simulated"], yerr=gz["simulated_se"] * gz["simulated"],
                    fmt=f"C{i}o", label=f"{z:g} m PyConTurb",
                )  # fmt: skip
                ax.plot(gz["hws_ms"], gz["model_as_simulated"], f"C{i}x")
        ax.set_title(lidar)
        ax.set_xlabel("HWS (m/s)")
        ax.grid(alpha=0.3)
    axes[0].set_ylabel("std ratio, motionless lidar / point (-)")
    axes[1].legend(fontsize=7, ncol=2)
    fig.tight_layout()
    fig.savefig(RESULTS / "lidar_spatial_response.png", dpi=110)
    with pd.option_context("display.width", 200):
        print(out.round(4).to_string(index=False))
    return out


if __name__ == "__main__":
    if "--study" in sys.argv and sys.argv[sys.argv.index("--study") + 1] == "spatial":
        spatial_study()
    else:
        main(sys.argv)
