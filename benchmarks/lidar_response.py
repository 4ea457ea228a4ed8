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
"""

from __future__ import annotations

import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pandas as pd  # noqa: E402

from flidar_uq.campaign.physics_mode import generate_campaign, turbulence_max_frequency_hz  # noqa: E402
from flidar_uq.campaign.scenarios import load_scenario  # noqa: E402
from flidar_uq.physics.lidar_response import lidar_std_ratio  # noqa: E402

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
    f_max = turbulence_max_frequency_hz("default")
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


if __name__ == "__main__":
    main(sys.argv)
