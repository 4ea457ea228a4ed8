"""Calibration by regime of the Snakemake pipeline itself on a weathervaning buoy with a
fixed reference lidar (regime_runs.py checks).
"""

from __future__ import annotations

import pandas as pd
import pytest
from regime_runs import (
    SEEDS,
    check_calibrated,
)

from flidar_uq.validation.regimes import (
    regime_labels,
)


@pytest.mark.slow
@pytest.mark.parametrize("seed", SEEDS)
def test_pipeline_is_calibrated_on_a_weathervaning_buoy_with_a_fixed_reference_lidar(
    tmp_path, seed
):
    """The Snakemake pipeline itself (not only validation/regimes.py) takes the two lidars'
    sampling scatter as known: weathervane_broadband (reference lidar synchronised with the
    floating one, heading from the records' heading_mean_deg) is calibrated in every
    regime group. Without the pair term it covered 0.94-0.97 (docs/inference.md)."""
    import subprocess
    import sys
    from pathlib import Path

    import yaml

    repo = Path(__file__).resolve().parents[1]
    cfg = tmp_path / "scenario.yaml"
    cfg.write_text(
        yaml.safe_dump({"campaign": {"scenario": "weathervane_broadband", "seed": seed}})
    )
    snakemake = Path(sys.executable).with_name("snakemake")
    cmd = [str(snakemake), "-s", str(repo / "Snakefile"), "--directory", str(tmp_path),
           "--configfile", str(repo / "config" / "config.yaml"), str(cfg), "--cores", "2"]  # fmt: skip
    proc = subprocess.run(cmd, capture_output=True, text=True, timeout=2400, cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr[-3000:]
    res = tmp_path / "results"
    assert "taken as known" in (res / "logs" / "fit_global_record.log").read_text()
    ti = pd.read_csv(res / "ti" / "records.csv")
    raw = (
        pd.read_parquet(res / "data" / "records.parquet")
        .iloc[ti["record_id"]]
        .reset_index(drop=True)
    )
    kept = pd.read_csv(res / "qc" / "flags.csv").set_index("record_id")["kept"]
    use = (
        kept.reindex(ti["record_id"]).to_numpy(dtype=bool)
        & ti["hws_mean_ms"].between(3.0, 20.0, inclusive="left").to_numpy()
    )
    out = raw[use].copy()
    for c in ("ti_corrected_median", "ti_corrected_lo", "ti_corrected_hi"):
        out[c] = ti.loc[use, c].to_numpy()
    out["ti_true"] = out["true_ti"]
    assert len(out) > 2500
    assert out["ti_corrected_median"].notna().mean() >= 0.99
    check_calibrated(pd.concat([out, regime_labels(out)], axis=1), f"pipeline seed {seed}")
