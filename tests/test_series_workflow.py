"""The raw IMU series and the LOS branch in the pipeline: DAG, config errors, the merge of the
series' statistics, the agreement table, the report section, and (slow) end-to-end runs: the
virtual campaign given as raw series gives the same corrected TI as given as record statistics;
the LOS branch runs and appears in the report; the user guide's example runs."""

from __future__ import annotations

import re
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
import yaml
from test_workflow import REPO, check_outputs, load_yaml, snakemake, tiny_config

from flidar_uq.correction.los_records import AGREEMENT_COLUMNS
from flidar_uq.data import io
from flidar_uq.data.imu_series import SERIES_MOTION_COLUMNS
from flidar_uq.workflow.imu_step import merge_series_motion
from flidar_uq.workflow.los_step import los_agreement
from flidar_uq.workflow.series_report import series_sections


def dry_run(workdir: Path, cfg: Path, check: bool = True):
    return snakemake(workdir, cfg, "-n", "--cores", "2", timeout=120, check=check)


def with_campaign(cfg: Path, **campaign) -> Path:
    data = load_yaml(cfg)
    data["campaign"] |= campaign
    cfg.write_text(yaml.safe_dump(data))
    return cfg


# --------------------------------------------------------------------------- DAG and config
def test_dag_has_the_series_rules_only_when_series_are_given(tmp_path):
    plain = dry_run(tmp_path, tiny_config(tmp_path)).stdout
    for rule in ("imu_statistics", "los_correction", "los_agreement"):
        assert f"rule {rule}" not in plain
    cfg = with_campaign(tiny_config(tmp_path), virtual_series="imu")
    out = dry_run(tmp_path, cfg).stdout
    assert "rule imu_statistics" in out and "rule los_correction" not in out
    cfg = with_campaign(tiny_config(tmp_path), virtual_series="imu_los")
    out = dry_run(tmp_path, cfg).stdout
    for rule in ("imu_statistics", "los_correction", "los_agreement"):
        assert f"rule {rule}" in out, rule
    assert "results/campaign/los.parquet" in out and "results/los/agreement.csv" in out


@pytest.mark.parametrize(
    ("campaign", "inference", "message"),
    [
        (
            {"imu_series": "imu.csv"},
            {},
            r"config key campaign.imu_series: only with campaign.source 'files'",
        ),
        (
            {"source": "files", "records": "r.csv", "virtual_series": "imu"},
            {},
            r"config key campaign.virtual_series: only with campaign.source 'virtual'",
        ),
        (
            {"source": "files", "records": "r.csv", "los_series": "los.csv"},
            {},
            r"config key campaign.imu_series: missing, but campaign.los_series is given",
        ),
        (
            {"source": "files", "records": "r.csv", "imu_series": "i.csv", "los_series": "l.csv"},
            {"lever_arm_m": None},
            r"config key inference.lever_arm_m: missing, but campaign.los_series is given",
        ),
        (
            {"source": "files", "records": "r.csv", "imu_series": "nowhere.parquet"},
            {},
            r"config key campaign.imu_series: no such file 'nowhere.parquet'",
        ),
    ],
)
def test_series_config_errors_name_the_key(tmp_path, campaign, inference, message):
    cfg = with_campaign(tiny_config(tmp_path), **campaign)
    data = load_yaml(cfg)
    data["inference"] |= inference
    cfg.write_text(yaml.safe_dump(data))
    proc = dry_run(tmp_path, cfg, check=False)
    out = proc.stdout + proc.stderr
    assert proc.returncode == 2, out[-2000:]  # a usage error (flidar_uq.workflow.inputs)
    assert re.search(message, out), out[-2000:]
    assert "Traceback" not in out, out[-2000:]


# --------------------------------------------------------------------------- step functions
def test_merge_replaces_the_tables_motion_columns_and_counts_them(tmp_path):
    records = pd.DataFrame(
        {
            "timestamp": pd.to_datetime(["2015-04-01T00:00Z", "2015-04-01T00:10Z"], utc=True),
            "height_m": 58.0,
            "hws_mean_ms": 8.0,
            "hws_std_ms": 0.8,
            "wd_mean_deg": 240.0,
            "availability_pct": 100.0,
            "roll_amplitude_deg": [9.0, np.nan],  # the table's own value in row 1 only
        }
    )
    stats = records[["timestamp", "height_m"]].copy()
    for i, col in enumerate(SERIES_MOTION_COLUMNS):
        stats[col] = [1.0 + i, 2.0 + i]
    path = tmp_path / "statistics.csv"
    stats.to_csv(path, index=False, date_format="%Y-%m-%dT%H:%M:%SZ")
    merged, n = merge_series_motion(records, path)
    assert n == 1
    assert merged["roll_amplitude_deg"].tolist() == [1.0, 2.0]  # the series wins
    assert set(SERIES_MOTION_COLUMNS) <= set(merged.columns)
    with pytest.raises(ValueError, match="do not match the record table row by row"):
        merge_series_motion(records.iloc[:1], path)


def test_los_correction_streams_every_record_row(tmp_path):
    """The LOS step over files read in small chunks: every record row appears, a record
    without LOS rows is flagged no_los, LOS rows of a window without records are skipped;
    the IMU series' translational velocities (a wave follower's) reach the corrections, and
    the column translation says so."""
    import copy

    from flidar_uq.campaign.physics_mode import generate_campaign
    from flidar_uq.campaign.scenarios import DEFAULT_SCENARIO
    from flidar_uq.workflow.los_step import los_correction

    sc = copy.deepcopy(DEFAULT_SCENARIO)
    sc.update(name="los_step_test", n_records=5, heights_m=[58.0, 85.0])
    sc["motion"]["sea_state"]["hull"] = "wave_follower"
    sc["imu"] |= {"vertical_velocity": True, "horizontal_velocity": True}
    out = generate_campaign(sc, 4, return_imu=True, return_los=True, n_workers=1)
    starts = out.records["timestamp"].unique()
    los = out.los[(out.los["timestamp"] < starts[2]) | (out.los["timestamp"] >= starts[3])]
    records = out.records[out.records["timestamp"] != starts[4]]  # its LOS rows: no record
    io.write_records(records, tmp_path / "records.csv")
    io.write_imu_series(out.imu, tmp_path / "imu.parquet")
    io.write_los_series(los, tmp_path / "los.csv")
    table = los_correction(
        records_path=tmp_path / "records.csv",
        los_path=tmp_path / "los.csv",
        imu_path=tmp_path / "imu.parquet",
        out_path=tmp_path / "corrected.csv",
        lidar="zephir300",
        lever_arm_m=(0.0, 0.0, 2.5),
        chunk_rows=4000,  # ~ a fifth of a record: windows span chunks
    )
    assert len(table) == len(records)
    assert (table["timestamp"].to_numpy() == records["timestamp"].to_numpy()).all()
    no_los = table["timestamp"] == starts[2]
    assert (table.loc[no_los, "los_flags"] == "no_los").all()
    assert table.loc[no_los, "ti_los_least_squares"].isna().all()
    assert (table.loc[~no_los, "los_flags"] == "").all()
    assert table.loc[~no_los, "ti_los_least_squares"].notna().all()
    assert (table.loc[~no_los, "translation"] == "east+north+up").all()
    assert table.loc[no_los, "translation"].isna().all()
    # the same numbers as the record function on each whole window
    from flidar_uq.correction.los_records import los_record_ti

    start = starts[1]
    window = pd.Timedelta(600, "s")
    rec = records[records["timestamp"] == start]
    direct = los_record_ti(
        los[(los["timestamp"] >= start) & (los["timestamp"] < start + window)],
        out.imu,
        start=start,
        heights_m=rec["height_m"].to_numpy(),
        wd_deg=rec["wd_mean_deg"].to_numpy(),
        lidar="zephir300",
        lever_arm_m=(0.0, 0.0, 2.5),
    )
    np.testing.assert_allclose(
        table.loc[table["timestamp"] == start, "ti_los_least_squares"],
        direct["ti_los_least_squares"],
    )


def test_los_correction_says_it_leaves_out_a_heave_given_as_an_acceleration(tmp_path, caplog):
    """An IMU series with the heave as an acceleration only (imu.vertical_acceleration):
    the LOS corrections add the measured horizontal velocities, not the heave, and the log
    says so; with the heave velocity there is no such line."""
    import copy
    import logging

    from flidar_uq.campaign.physics_mode import generate_campaign
    from flidar_uq.campaign.scenarios import DEFAULT_SCENARIO
    from flidar_uq.workflow.los_step import los_correction

    sc = copy.deepcopy(DEFAULT_SCENARIO)
    sc.update(name="los_acceleration_test", n_records=2, heights_m=[58.0])
    sc["motion"]["sea_state"]["hull"] = "wave_follower"
    sc["imu"] |= {"vertical_acceleration": True, "horizontal_velocity": True}
    out = generate_campaign(sc, 4, return_imu=True, return_los=True, n_workers=1)
    assert "acceleration_up_ms2" in out.imu and "velocity_up_ms" not in out.imu
    io.write_records(out.records, tmp_path / "records.csv")
    io.write_los_series(out.los, tmp_path / "los.csv")
    kw = dict(
        records_path=tmp_path / "records.csv",
        los_path=tmp_path / "los.csv",
        imu_path=tmp_path / "imu.csv",
        out_path=tmp_path / "corrected.csv",
        lidar="zephir300",
        lever_arm_m=(0.0, 0.0, 2.5),
    )
    io.write_imu_series(out.imu, tmp_path / "imu.csv")
    with caplog.at_level(logging.WARNING, logger="flidar_uq.workflow.los_step"):
        table = los_correction(**kw)
    assert (table["translation"] == "east+north").all()
    assert "leaves the heave out" in caplog.text
    caplog.clear()
    still = out.imu.drop(columns="acceleration_up_ms2").assign(velocity_up_ms=0.0)
    io.write_imu_series(still, tmp_path / "imu.csv")  # a measured heave velocity (of 0)
    with caplog.at_level(logging.WARNING, logger="flidar_uq.workflow.los_step"):
        table = los_correction(**kw)
    assert (table["translation"] == "east+north+up").all()
    assert "leaves the heave out" not in caplog.text


def write_agreement_inputs(tmp_path: Path) -> tuple[Path, Path]:
    ts = pd.date_range("2015-04-01", periods=4, freq="10min", tz="UTC")
    ti = pd.DataFrame(
        {
            "timestamp": ts,
            "height_m": 58.0,
            "hws_mean_ms": 8.0,
            "ti_uncorrected": 0.12,
            "ti_corrected_median": [0.10, 0.10, 0.10, np.nan],
            "ti_corrected_lo": [0.09, 0.09, 0.09, np.nan],
            "ti_corrected_hi": [0.11, 0.11, 0.11, np.nan],
            "flags": ["", "", "", "imu_gap"],
            "lidar_std_ratio": 1.05,
            "ti_true": 0.1,
        }
    )
    los = pd.DataFrame(
        {
            "timestamp": ts,
            "height_m": 58.0,
            "los_flags": "",
            "translation": ["east+north+up"] * 3 + ["rotation_only"],
            # on the target: 0.1155/1.05 = 0.110 (inside), 0.0945/1.05 = 0.09, 0.126/1.05 = 0.12
            "ti_los_uncorrected": [0.13, 0.13, 0.13, 0.13],
            "ti_los_least_squares": [0.1155, 0.0945, 0.126, 0.1],
        }
    )
    p_ti, p_los = tmp_path / "ti.csv", tmp_path / "los.csv"
    ti.to_csv(p_ti, index=False, date_format="%Y-%m-%dT%H:%M:%SZ")
    los.to_csv(p_los, index=False, date_format="%Y-%m-%dT%H:%M:%SZ")
    return p_ti, p_los


def test_agreement_statistics_by_hand(tmp_path):
    p_ti, p_los = write_agreement_inputs(tmp_path)
    out = {k: tmp_path / f"out_{k}" for k in ("records.csv", "agreement.csv", "agreement.png")}
    agreement = los_agreement(
        los_path=p_los,
        ti_records_path=p_ti,
        records_out=out["records.csv"],
        agreement_out=out["agreement.csv"],
        figure_out=out["agreement.png"],
    ).set_index("method")
    assert list(agreement.reset_index().columns) == AGREEMENT_COLUMNS
    ls = agreement.loc["least_squares"]
    d = np.array([0.11, 0.09, 0.12]) - 0.10  # LOS on the target minus Bayesian median
    assert ls["n_records"] == 3  # the record without a Bayesian value is not compared
    assert ls["bias_vs_bayesian"] == pytest.approx(d.mean())
    assert ls["rmse_vs_bayesian"] == pytest.approx(np.sqrt(np.mean(d**2)))
    assert ls["inside_interval_pct"] == pytest.approx(200.0 / 3.0)  # 0.11 and 0.09 are inside
    assert ls["md_vs_truth"] == pytest.approx(d.mean())
    assert agreement.loc["uncorrected", "inside_interval_pct"] == 0.0
    assert agreement.loc["bayesian", "md_vs_truth"] == pytest.approx(0.0)
    records = pd.read_csv(out["records.csv"])
    assert len(records) == 4
    np.testing.assert_allclose(
        records["ti_los_least_squares_target"], [0.11, 0.09, 0.12, 0.1 / 1.05]
    )
    assert out["agreement.png"].read_bytes()[:4] == b"\x89PNG"


def test_report_section_shows_the_override_gaps_and_agreement(tmp_path):
    p_ti, p_los = write_agreement_inputs(tmp_path)
    paths = {
        "los_records": tmp_path / "records.csv",
        "los_agreement": tmp_path / "agreement.csv",
        "los_figure": tmp_path / "agreement.png",
    }
    los_agreement(
        los_path=p_los,
        ti_records_path=p_ti,
        records_out=paths["los_records"],
        agreement_out=paths["los_agreement"],
        figure_out=paths["los_figure"],
    )
    summary = {
        "imu_series": "data/<buoy>.csv",
        "rows": 7200,
        "rate_hz": 5.0,
        "first_sample": "2015-04-01T00:00:00",
        "last_sample": "2015-04-01T00:39:59.8",
        "gaps": 1,
        "missing_samples_inside": 600,
        "longest_gap_inside_s": 120.0,
        "record_rows": 4,
        "record_rows_below_coverage": 1,
        "record_rows_without_samples": 0,
        "record_table_motion_columns": "roll_amplitude_deg pitch_amplitude_deg",
        "record_rows_overridden": 4,
    }
    pd.DataFrame({"key": list(summary), "value": list(summary.values())}).to_csv(
        tmp_path / "summary.csv", index=False
    )
    pd.DataFrame(
        {
            "kind": ["inside"],
            "start": ["a"],
            "end": ["b"],
            "duration_s": [120.0],
            "missing_samples": [600],
        }
    ).to_csv(tmp_path / "gaps.csv", index=False)
    (section,) = series_sections(
        imu_summary=tmp_path / "summary.csv", imu_gaps=tmp_path / "gaps.csv", **paths
    )
    assert section.title == "Raw IMU series and LOS-level correction"
    html = section.body_html
    assert "The series wins" in html and "replaced in 4 record rows" in html
    assert "data/&lt;buoy&gt;.csv" in html  # text escaped, tables and figure not
    assert "<table>" in html and "&lt;table" not in html and "data:image/png;base64," in html
    assert "least_squares" in html and "1 of 4 record rows" in html
    assert "rows: east+north+up in 3, rotation_only in 1" in html
    assert series_sections() == []


# --------------------------------------------------------------------------- end to end (slow)
@pytest.mark.slow
def test_virtual_campaign_as_raw_series_gives_the_same_corrected_ti_and_runs_the_los_branch(
    tmp_path,
):
    """Acceptance (issue 12, items 2-3): the tiny virtual campaign run from its record
    statistics and run from its raw IMU series (the DAG derives the statistics, streamed in
    chunks smaller than the series) give the same corrected TI within the posterior noise;
    the LOS branch runs on the campaign's LOS series and appears in the report."""
    stats_dir, series_dir = tmp_path / "statistics", tmp_path / "series"
    stats_dir.mkdir()
    series_dir.mkdir()
    snakemake(stats_dir, tiny_config(stats_dir, tmp_path), "--cores", "2")
    cfg = with_campaign(
        tiny_config(series_dir, tmp_path), virtual_series="imu_los", series_chunk_rows=5000
    )
    snakemake(series_dir, cfg, "--cores", "2")
    a = check_outputs(stats_dir, truth=True)
    b = check_outputs(series_dir, truth=True)
    assert a["flags"].equals(b["flags"])
    both = a["ti_corrected_median"].notna()
    assert both.sum() > 0.8 * len(a)
    width = (a["ti_corrected_hi"] - a["ti_corrected_lo"])[both]
    for col in ("ti_corrected_median", "ti_corrected_lo", "ti_corrected_hi"):
        assert ((a[col] - b[col]).abs()[both] <= 0.1 * width).all(), col
    # the series won over the campaign table's own motion columns, and the log says so
    res = series_dir / "results"
    summary = pd.read_csv(res / "imu" / "summary.csv").set_index("key")["value"]
    assert int(summary["record_rows_overridden"]) == len(b)
    assert "the IMU series wins" in (res / "logs" / "validate.log").read_text()
    # the LOS branch: every record row, Malekmohammadi et al. (2024) closer to the fixed reference lidar than the
    # uncorrected LOS retrieval, and in the report
    los = pd.read_csv(res / "los" / "records.csv")
    assert len(los) == len(b) and los["los_flags"].isna().all()  # "" is read as NaN
    ti_ref = pd.read_csv(res / "ti" / "records.csv")["ti_ref"]
    err = {m: (los[f"ti_los_{m}"] - ti_ref).abs().mean() for m in ("uncorrected", "least_squares")}
    assert err["least_squares"] < 0.3 * err["uncorrected"]
    agreement = pd.read_csv(res / "los" / "agreement.csv").set_index("method")
    assert agreement.loc["least_squares", "n_records"] == both.sum()
    html = (res / "report" / "report.html").read_text()
    assert "LOS-level correction beside the Bayesian one" in html and "The series wins" in html


@pytest.mark.slow
def test_virtual_dbs_campaign_runs_the_los_branch(tmp_path):
    """The LOS branch on a virtual WindCube v2 (dbs_tilt_only, 24 records at 40, 80 and 120
    m): the campaign writes its DBS LOS series (the vertical beam marked by elevation_deg),
    the uncorrected LOS TI is the record's own, and at the interior gate the new algorithm
    of Yamaguchi and Ishihara (2016) removes most of the motion error against the fixed
    reference lidar (why half: test_los_records.py, the round trip of the same series)."""
    from flidar_uq.campaign.scenarios import load_scenario

    scenario = load_scenario("dbs_tilt_only")
    scenario.update(name="tiny_dbs", n_records=24, chunk_records=8)
    path = tmp_path / "tiny_dbs.yaml"
    path.write_text(yaml.safe_dump(scenario))
    cfg = with_campaign(
        tiny_config(tmp_path), scenario=str(path), lidar="windcube_v2", virtual_series="imu_los"
    )
    snakemake(tmp_path, cfg, "--cores", "2")
    records = check_outputs(tmp_path, truth=True)
    res = tmp_path / "results"
    series = io.read_los_series(res / "campaign" / "los.parquet")
    assert (series["elevation_deg"] == 90.0).mean() == pytest.approx(1 / 5)
    los = pd.read_csv(res / "los" / "records.csv")
    assert len(los) == len(records) and los["los_flags"].isna().all()  # "" is read as NaN
    corrected = pd.read_csv(res / "los" / "corrected.csv")
    whole = corrected["n_scans_used"] == corrected["n_scans"]
    np.testing.assert_allclose(
        los.loc[whole, "ti_los_uncorrected"], los.loc[whole, "ti_uncorrected"], rtol=1e-6
    )
    mid = los["height_m"] == 80.0
    assert los.loc[~mid, "ti_los_dbs_new"].isna().all()  # edge gates: nothing to interpolate
    ti_ref = pd.read_csv(res / "ti" / "records.csv")["ti_ref"][mid]
    err = {
        m: (los.loc[mid, f"ti_los_{m}"] - ti_ref).abs().mean() for m in ("uncorrected", "dbs_new")
    }
    assert err["dbs_new"] < 0.5 * err["uncorrected"]
    agreement = pd.read_csv(res / "los" / "agreement.csv").set_index("method")
    both = los["ti_los_dbs_new"].notna() & los["ti_corrected_median"].notna()
    assert agreement.loc["dbs_new", "n_records"] == both.sum() > 0.8 * mid.sum()
    assert (
        "LOS-level correction beside the Bayesian one"
        in (res / "report" / "report.html").read_text()
    )


@pytest.mark.slow
def test_readme_series_example_runs(tmp_path):
    """docs/user-guide.md, "Run on your own data": the example files and tests/data/user_series_config.yaml."""
    readme = (REPO / "docs" / "user-guide.md").read_text()
    assert "scripts/series-example.py example" in readme
    assert "tests/data/user_series_config.yaml" in readme
    subprocess.run(
        [sys.executable, str(REPO / "scripts" / "series-example.py"), "example"],
        cwd=tmp_path,
        check=True,
        capture_output=True,
        timeout=300,
    )
    shutil.copy(REPO / "tests" / "data" / "user_series_config.yaml", tmp_path / "config.yaml")
    snakemake(tmp_path, tmp_path / "config.yaml", "--cores", "2")
    records = check_outputs(tmp_path, truth=False)
    src = io.read_records(tmp_path / "example" / "records.csv", require_motion=False)
    assert len(records) == len(src)
    data = pd.read_parquet(tmp_path / "results" / "data" / "records.parquet")
    assert data["tilt_along_wind_std_deg"].notna().all()  # derived from the IMU series
    los = pd.read_csv(tmp_path / "results" / "los" / "agreement.csv").set_index("method")
    assert los.loc["least_squares", "n_records"] > 0.8 * len(records)
    assert "LOS-level correction" in (tmp_path / "results" / "report" / "report.html").read_text()


def test_merge_takes_the_series_measured_band_directions(tmp_path):
    """With a vertical velocity in the series, its tilt_band{b}_cos_psi replace the table's."""
    records = pd.DataFrame(
        {
            "timestamp": pd.to_datetime(["2015-04-01T00:00Z"], utc=True),
            "height_m": 58.0,
            "tilt_band3_cos_psi": [0.1],
        }
    )
    stats = records[["timestamp", "height_m"]].copy()
    for col in SERIES_MOTION_COLUMNS:
        stats[col] = 1.0
    stats["tilt_band3_cos_psi"] = -0.7
    path = tmp_path / "statistics.csv"
    stats.to_csv(path, index=False, date_format="%Y-%m-%dT%H:%M:%SZ")
    merged, n = merge_series_motion(records, path)
    assert merged["tilt_band3_cos_psi"].tolist() == [-0.7]
    assert n == 1  # the table's own direction counted as replaced
