"""A campaign without motion statistics: detected when the workflow is parsed, reported
uncorrected (the TI as measured per height and speed bin with its IEC category) with what
is missing and what a correction would take; a fleet refuses it."""

from __future__ import annotations

import html as html_lib
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
import yaml

from flidar_uq.data.schema import MOTION_COLUMNS
from flidar_uq.workflow.data_steps import run_qc, uncorrected_ti, validate_records
from flidar_uq.workflow.inputs import (
    EXIT_USAGE,
    check_config,
    missing_motion_columns,
    pipeline_preflight,
)
from flidar_uq.workflow.report_summary import missing_motion_words
from flidar_uq.workflow.run_console import run_summary

REPO = Path(__file__).resolve().parents[1]
HAND_WRITTEN = REPO / "tests" / "data" / "hand_written_campaign.csv"


def _config(tmp_path: Path, drop: tuple[str, ...] = MOTION_COLUMNS) -> dict:
    """The hand-written campaign (tests/data/user_config.yaml) without the ``drop``
    columns, its config checked (defaults filled)."""
    src = pd.read_csv(HAND_WRITTEN).drop(columns=list(drop))
    src.to_csv(tmp_path / "campaign.csv", index=False)
    cfg = yaml.safe_load((REPO / "tests" / "data" / "user_config.yaml").read_text())
    cfg["campaign"]["records"] = str(tmp_path / "campaign.csv")
    cfg["report"] = {"group_min_count": 2}
    return cfg


def test_missing_motion_columns_from_the_table_the_config_and_the_columns(tmp_path):
    camp = check_config(_config(tmp_path))["campaign"]
    assert missing_motion_columns(camp) == MOTION_COLUMNS  # the file as read
    assert missing_motion_columns({**camp, "imu_series": "imu.csv"}) == ()  # the series gives them
    assert missing_motion_columns({**camp, "source": "virtual"}) == ()
    cols = ["timestamp", "roll_amplitude_deg", "pitch_amplitude_deg"]
    assert missing_motion_columns(camp, cols) == ("roll_period_s", "pitch_period_s")
    with_motion = check_config(_config(tmp_path, drop=()))["campaign"]
    assert missing_motion_columns(with_motion) == ()


def test_a_fleet_refuses_a_campaign_without_motion_statistics(tmp_path, capsys):
    cfg = _config(tmp_path)
    fleet = {"campaigns": {"buoyA": {"campaign": cfg.pop("campaign")}}, **cfg}
    assert pipeline_preflight(fleet) == EXIT_USAGE
    err = capsys.readouterr().err
    assert "campaigns.buoyA.campaign.records" in err and "roll_period_s" in err
    # on its own the campaign passes (it is reported uncorrected)
    assert pipeline_preflight(_config(tmp_path)) == 0


def test_uncorrected_tables_keep_every_record_and_give_the_measured_bin_statistics(tmp_path):
    cfg = check_config(_config(tmp_path))
    validated = tmp_path / "validated.csv"
    validate_records(tmp_path / "campaign.csv", validated, require_motion=False)
    flags = run_qc(validated, tmp_path / "flags.csv", tmp_path / "kept.parquet",
                   tmp_path / "summary.csv", cfg["qc"], require_motion=False)  # fmt: skip
    out_records, out_bins = tmp_path / "ti_records.csv", tmp_path / "speed_bins.csv"
    uncorrected_ti(validated, tmp_path / "flags.csv", out_records, out_bins, min_count=2)
    records, bins = pd.read_csv(out_records), pd.read_csv(out_bins)
    src = pd.read_csv(HAND_WRITTEN)
    assert len(records) == len(src) and records["ti_corrected_median"].isna().all()
    np.testing.assert_allclose(records["ti_uncorrected"], src["hws_std_ms"] / src["hws_mean_ms"])
    kept = flags["kept"].to_numpy(dtype=bool)
    assert (records.loc[kept, "flags"] == "no_motion_description").all()
    assert (records.loc[~kept, "flags"] == flags.loc[~kept, "reasons"]).all()  # QC reasons
    # the statistics of the kept records' TI per height and 1-m/s bin, by hand
    k = records[kept]
    for (h, v), ti in k.groupby([k["height_m"], np.floor(k["hws_mean_ms"] + 0.5)])[
        "ti_uncorrected"
    ]:
        row = bins[(bins["height_m"] == h) & (bins["hws_bin_ms"] == v)].iloc[0]
        assert row["n"] == len(ti)
        assert row["ti_mean_uncorrected"] == pytest.approx(ti.mean())
        assert row["ti_rep_uncorrected"] == pytest.approx(ti.mean() + 1.28 * ti.std(ddof=1))
        assert row["ti_p90_uncorrected"] == pytest.approx(np.quantile(ti, 0.9))
    assert bins["n"].sum() == kept.sum()
    assert bins[["ti_mean", "ti_rep_lo", "ti_p90_hi", "ti_sd"]].isna().all().all()


def test_missing_motion_words_say_what_is_missing_and_what_it_would_take():
    words = missing_motion_words(("roll_period_s", "pitch_period_s"), has_reference=False)
    assert "no roll_period_s, pitch_period_s columns and no raw IMU series" in words
    assert "campaign.imu_series" in words and "ref_hws_std_ms" in words
    assert "reference TI will then validate" in missing_motion_words(("x",), has_reference=True)


def _summary_text(html: str) -> str:
    m = re.search(r'<section id="summary".*?</section>', html, re.S)
    assert m, "no first screen"
    return html_lib.unescape(re.sub(r"\s+", " ", re.sub(r"<[^>]+>", " ", m.group(0))))


@pytest.mark.slow
def test_campaign_without_motion_columns_runs_to_an_uncorrected_report(tmp_path):
    """The hand-written campaign without its motion columns, run by `flidar-uq run`: exit
    0, every record in results/ti/records.csv, finite uncorrected statistics per bin, a
    first screen that says what is missing, a summary that says uncorrected; no fit."""
    (tmp_path / "config.yaml").write_text(yaml.safe_dump(_config(tmp_path)))
    exe = Path(sys.executable).with_name("flidar-uq")
    proc = subprocess.run(
        [str(exe), "run", "--cores", "2", "--configfile", str(tmp_path / "config.yaml"),
         "--directory", str(tmp_path), "-s", str(REPO / "Snakefile")],
        capture_output=True, text=True, timeout=900, cwd=tmp_path,
    )  # fmt: skip
    assert proc.returncode == 0, proc.stdout[-3000:] + proc.stderr[-3000:]
    res = tmp_path / "results"
    records = pd.read_csv(res / "ti" / "records.csv")
    src = pd.read_csv(HAND_WRITTEN)
    assert len(records) == len(src)
    np.testing.assert_array_equal(records["record_id"], np.arange(len(src)))
    np.testing.assert_allclose(records["hws_mean_ms"], src["hws_mean_ms"])
    bins = pd.read_csv(res / "ti" / "speed_bins.csv")
    filled = bins[bins["n"] >= 2]
    assert len(filled) and np.isfinite(filled.filter(like="_uncorrected").to_numpy()).all()
    assert not (res / "posterior").exists() and not (res / "bins").exists()
    html = (res / "report" / "report.html").read_text()
    text = _summary_text(html)
    assert "No motion statistics" in text and "no raw IMU series" in text
    assert all(c in text for c in MOTION_COLUMNS), text
    assert "none corrected for motion" in text
    for r in filled.itertuples():
        assert f"{r.ti_mean_uncorrected:.3f} {r.ti_rep_uncorrected:.3f}" in text, text
    assert "Bayesian diagnostics" not in html and "Validation against the reference" not in html
    assert "uncorrected (no motion statistics)" in proc.stdout
    assert run_summary(res, 2)[1].endswith("uncorrected (no motion statistics):")


def test_run_summary_says_uncorrected_with_the_measured_category(tmp_path):
    """speed_bins.csv of the uncorrected rule (corrected columns NaN): the summary gives
    the uncorrected representative TI at 15 m/s and its IEC category, labelled so."""
    ti = tmp_path / "results" / "ti"
    ti.mkdir(parents=True)
    bins = pd.DataFrame({"height_m": [85.0, 85.0], "hws_bin_ms": [14.0, 15.0], "n": [12, 12],
                         "ti_rep_uncorrected": [0.16, 0.150]})  # fmt: skip
    for c in ("ti_mean", "ti_mean_lo", "ti_mean_hi", "ti_rep", "ti_rep_lo", "ti_rep_hi"):
        bins[c] = np.nan
    bins.to_csv(ti / "speed_bins.csv", index=False)
    out = run_summary(tmp_path / "results", 10)
    assert out[1].endswith("uncorrected (no motion statistics):")
    # 0.150 lies above C (0.12 x 1.123 = 0.135) and within B (0.14 x 1.123 = 0.157)
    assert "  85 m: uncorrected 0.150, category B" in out
