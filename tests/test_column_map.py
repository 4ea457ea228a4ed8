"""The column map (config campaign.columns) and the height selection (campaign.heights):
files whose names differ, wide logger tables, and no record lost (docs/user-guide.md "Run on your own
data", example tests/data/logger_config.yaml)."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
import yaml

from flidar_uq.cli import main
from flidar_uq.data.io import DataValidationError, read_records, validate_records, write_records
from flidar_uq.workflow.data_steps import kept_records, run_qc
from flidar_uq.workflow.inputs import check_config, load_config_file, read_campaign_records

REPO = Path(__file__).resolve().parents[1]
DATA = REPO / "tests" / "data"
EXAMPLE = DATA / "logger_config.yaml"


def example_campaign() -> dict:
    cfg = check_config(load_config_file(EXAMPLE))
    camp = dict(cfg["campaign"])
    camp["records"] = str(REPO / camp["records"])
    return camp


def test_example_config_reads_the_logger_table_as_the_hand_written_records():
    camp = example_campaign()
    mapped = read_campaign_records(camp["records"], camp)
    expected = read_records(DATA / "hand_written_campaign.csv")
    pd.testing.assert_frame_equal(mapped, expected)


def test_validate_runs_the_example_config(monkeypatch, capsys):
    monkeypatch.chdir(REPO)  # campaign.records is relative to the working directory
    assert main(["validate", "--json", "--config", str(EXAMPLE.relative_to(REPO))]) == 0
    out, err = capsys.readouterr()
    report = json.loads(out)
    assert report["n_records"] == 30 and report["heights_m"] == [58.0, 85.0]
    assert report["columns"]["renamed"]["Spd{height}mN"] == "hws_mean_ms"
    assert report["columns"]["renamed"]["BattV"] is None
    assert report["qc_preview"]["by_filter"]["height_not_selected"] == 15
    assert err == ""


def test_plain_rename_and_drop_keep_rows_and_name_the_files_column(tmp_path):
    src = pd.read_csv(DATA / "hand_written_campaign.csv")
    names = {"hws_mean_ms": "WS_avg", "hws_std_ms": "WS_sd", "timestamp": "Date/Time"}
    df = src.rename(columns=names).assign(Logger_T=21.5)
    columns = {v: k for k, v in names.items()} | {"Logger_T": None}
    out = validate_records(df, "f.csv", columns=columns)
    pd.testing.assert_frame_equal(out, validate_records(src))
    df.loc[6, "WS_sd"] = -1.0
    with pytest.raises(
        DataValidationError,
        match=r"f\.csv: row 7, column 'WS_sd' \(mapped to 'hws_std_ms'\): negative standard",
    ):
        validate_records(df, "f.csv", columns=columns)
    with pytest.raises(DataValidationError, match=r"column 'Logger_T': unknown column"):
        validate_records(df, "f.csv", columns={v: k for k, v in names.items()})


def test_wide_table_optional_column_at_one_height_only():
    camp = example_campaign()
    raw = pd.read_csv(camp["records"]).drop(columns=["CupSpd58m", "CupSD58m"])
    out = validate_records(raw, "logger.csv", columns=camp["columns"])
    ref = out.set_index("height_m")["ref_hws_std_ms"]
    assert ref.loc[58.0].isna().all() and ref.loc[85.0].notna().all()
    assert len(out) == 2 * len(raw)


def test_selected_heights_flag_the_others_and_lose_nothing(tmp_path):
    records = read_records(DATA / "hand_written_campaign.csv")
    path = tmp_path / "records.parquet"
    write_records(records, path)
    flags = run_qc(
        path,
        tmp_path / "flags.csv",
        tmp_path / "kept.parquet",
        tmp_path / "summary.csv",
        {},
        heights_m=[85.0],
    )
    assert len(flags) == len(records)
    at58 = flags["height_m"].to_numpy() == 58.0
    assert flags.loc[at58, "fail_height_not_selected"].all()
    assert not flags.loc[~at58, "fail_height_not_selected"].any()
    assert flags.loc[at58, "reasons"].astype(str).str.contains("height_not_selected").all()
    kept = kept_records(path, tmp_path / "kept.parquet")
    assert set(kept["height_m"]) == {85.0}


def test_config_schema_takes_the_new_keys():
    cfg = check_config(load_config_file(EXAMPLE))
    assert cfg["campaign"]["heights"] == [85]
    assert cfg["campaign"]["allow_small_angles"] is False
    assert cfg["qc"]["zero_std"] is True
    defaults = check_config({})
    assert defaults["campaign"]["columns"] == {} and defaults["campaign"]["heights"] is None


@pytest.mark.slow
def test_pipeline_runs_the_example_config_and_every_record_has_its_reasons(tmp_path):
    cfg = yaml.safe_load(EXAMPLE.read_text())
    cfg["campaign"]["records"] = str(REPO / cfg["campaign"]["records"])
    path = tmp_path / "logger_config.yaml"
    path.write_text(yaml.safe_dump(cfg))
    snakemake = str(Path(sys.executable).with_name("snakemake"))
    cmd = [snakemake, "-s", str(REPO / "Snakefile"), "--directory", str(tmp_path)]
    cmd += ["--configfile", str(path), "--cores", "2", "results/ti/records.csv"]
    proc = subprocess.run(cmd, capture_output=True, text=True, timeout=1800, cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr[-3000:]
    src = read_records(DATA / "hand_written_campaign.csv")
    flags = pd.read_csv(tmp_path / "results" / "qc" / "flags.csv")
    records = pd.read_csv(tmp_path / "results" / "ti" / "records.csv")
    assert len(flags) == len(records) == len(src)
    np.testing.assert_allclose(records["hws_mean_ms"], src["hws_mean_ms"])
    at58 = records["height_m"].to_numpy() == 58.0
    assert records.loc[at58, "flags"].str.contains("height_not_selected").all()
    assert records.loc[at58, "ti_corrected_median"].isna().all()
    # every 85-m record is corrected or says why not
    at85 = records.loc[~at58]
    assert (at85["ti_corrected_median"].notna() | at85["flags"].fillna("").ne("")).all()
    assert at85["ti_corrected_median"].notna().sum() >= 5
    report = json.loads((tmp_path / "results" / "data" / "validation.json").read_text())
    assert report["qc_preview"]["by_filter"]["height_not_selected"] == 15
