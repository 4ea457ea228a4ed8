"""Pieces of the report step and the grouping of records (sectors, sea states)."""

from __future__ import annotations

import hashlib
import shutil
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from flidar_uq.correction.campaign import record_groups
from flidar_uq.workflow.report_step import (
    build_developer_report,
    file_provenance,
    loo_statement,
    reference_kind,
)

REPO = Path(__file__).resolve().parents[1]


def test_record_groups_sectors_centred_on_north_and_sea_state_from_motion():
    rec = pd.DataFrame(
        {
            "wd_mean_deg": [359.0, 14.9, 15.0, 200.0, np.nan],
            "period2_s": [np.nan, 5.0, np.nan, 6.0, np.nan],
            "tilt_along_wind_std_deg": [2.0, 1.0, 3.0, np.nan, 1.0],
            "tilt_across_wind_std_deg": [1.0, 2.0, 1.0, 1.0, 1.0],
        }
    )
    g = record_groups(rec)
    np.testing.assert_array_equal(g["sector_deg"], [0.0, 0.0, 30.0, 210.0, np.nan])
    assert g["sea_state"].tolist() == [
        "one peak, tilt along wind",
        "two peaks, tilt across wind",
        "one peak, tilt along wind",
        "two peaks",
        "one peak, tilt along wind",
    ]
    assert record_groups(rec, sector_width_deg=90)["sector_deg"].tolist()[:4] == [0, 0, 0, 180]
    bare = record_groups(pd.DataFrame({"wd_mean_deg": [10.0]}))
    assert bare["sea_state"].tolist() == ["unknown"]
    with pytest.raises(ValueError, match="sector_width_deg=25 must divide 360"):
        record_groups(rec, sector_width_deg=25)


def test_file_provenance_gives_sha256_and_rows(tmp_path):
    p = tmp_path / "a.csv"
    p.write_text("x,y\n1,2\n3,4\n")
    tab = file_provenance({"input": p, "missing": tmp_path / "nope.csv"})
    assert tab["file"].tolist() == ["input"]
    assert tab["sha256"].iloc[0] == hashlib.sha256(p.read_bytes()).hexdigest()
    assert tab["data rows"].iloc[0] == 2
    q = tmp_path / "records.parquet"  # the pipeline's record tables: rows from the footer
    pd.DataFrame({"x": [1.0, 2.0, 3.0]}).to_parquet(q)
    assert file_provenance({"validated": q})["data rows"].iloc[0] == 3


def test_loo_statement_says_per_bin_rho_in_words():
    per_bin = pd.DataFrame(
        [{"global_model": "lever_arm", "preferred_rho_model": "per_bin",
          "elpd_diff_per_bin_rho": 117.2, "elpd_diff_se": 28.4}]
    )  # fmt: skip
    text = loo_statement(per_bin)
    assert "prefers a separate rho per bin" in text and "117 +- 28" in text
    glob = per_bin.assign(preferred_rho_model="global", elpd_diff_per_bin_rho=1.0)
    assert "not preferred" in loo_statement(glob)
    assert loo_statement(pd.DataFrame()) == ""


def test_reference_kind_from_the_run_or_the_config():
    assert reference_kind({"reference": {"kind": "cup"}}).startswith("cup (cup anemometer")
    resolved = pd.DataFrame({"reference_kind": ["fixed_lidar"]})
    text = reference_kind({"reference": {"kind": None}}, resolved)
    assert text.startswith("fixed_lidar (") and "std ratio g" in text
    assert reference_kind({}).startswith("none (")


def test_developer_report_holds_the_benchmarks(tmp_path):
    bench = tmp_path / "bench"
    bench.mkdir()
    pngs = sorted((REPO / "benchmarks" / "results").glob("*.png"))[:2]
    for png in pngs:
        shutil.copy(png, bench / png.name)
    pd.DataFrame({"a": [1.0]}).to_csv(bench / "los_comparison.csv", index=False)
    html = build_developer_report(out_path=tmp_path / "dev.html", benchmarks_dir=bench)
    assert html.count("<img ") == len(pngs) and "los_comparison.csv" in html
    with pytest.raises(ValueError, match="is not a directory"):
        build_developer_report(out_path=tmp_path / "x.html", benchmarks_dir=tmp_path / "none")


def test_fitted_records_words_say_when_the_fit_was_a_subsample():
    from flidar_uq.workflow.report_step import fitted_records_words

    assert fitted_records_words(24522, 24522) == "24522 records fitted"
    words = fitted_records_words(30000, 157680)
    assert "subsample of the 157680 usable" in words
    assert "record_fit_max_records" in words
