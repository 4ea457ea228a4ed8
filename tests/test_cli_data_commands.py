"""The `validate` and `generate-campaign` subcommands of flidar-uq (in-process)."""

from __future__ import annotations

import json
from pathlib import Path

import pandas as pd
import pytest

from flidar_uq.cli import main
from flidar_uq.data.io import read_records

HAND_WRITTEN = Path(__file__).parent / "data" / "hand_written_campaign.csv"


def test_validate_accepts_the_hand_written_campaign(capsys):
    assert main(["validate", "--json", str(HAND_WRITTEN)]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["valid"] is True
    assert out["n_records"] == len(pd.read_csv(HAND_WRITTEN))


def test_validate_names_file_row_and_column_on_one_line(tmp_path, capsys):
    df = pd.read_csv(HAND_WRITTEN)
    df.loc[3, "hws_std_ms"] = -0.5
    bad = tmp_path / "bad.csv"
    df.to_csv(bad, index=False)
    assert main(["validate", str(bad)]) == 3  # bad data
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1
    assert "bad.csv" in err and "hws_std_ms" in err and "row" in err


def test_validate_missing_file_is_a_clear_error(tmp_path, capsys):
    assert main(["validate", str(tmp_path / "nope.csv")]) == 3
    err = capsys.readouterr().err
    assert "nope.csv: no such file" in err and "Traceback" not in err


@pytest.mark.parametrize("bad_seed", ["-1", "one"])
def test_generate_campaign_rejects_bad_seed(bad_seed, tmp_path, capsys):
    assert main(["generate-campaign", "--seed", bad_seed, "--output", str(tmp_path / "x.csv")]) == 2
    assert "--seed" in capsys.readouterr().err


@pytest.mark.slow
def test_generate_campaign_writes_a_valid_deterministic_table(tmp_path, capsys):
    paths = []
    for k in range(2):
        path = tmp_path / f"tiny{k}.csv"
        argv = ["generate-campaign", "--scenario", "tiny", "--seed", "7", "--output", str(path)]
        assert main([*argv, "--no-progress", "--workers", "1"]) == 0
        paths.append(path)
    out = json.loads(capsys.readouterr().out.splitlines()[-1])
    assert out["n_records"] > 0
    records = read_records(paths[0])  # passes the data layer's validation unchanged
    assert len(records) == out["n_records"]
    assert paths[0].read_bytes() == paths[1].read_bytes()


# ---- the summaries for people (the default; --json for machines) ----------------------------

FORMATS = Path(__file__).parent / "data" / "formats"


def test_validate_prints_a_short_summary_by_default(capsys):
    assert main(["validate", str(HAND_WRITTEN)]) == 0
    out, err = capsys.readouterr()
    lines = out.splitlines()
    assert err == "" and 4 <= len(lines) <= 12
    assert lines[:2] == [f"{HAND_WRITTEN}: valid", "format: table"]
    n = len(pd.read_csv(HAND_WRITTEN))
    assert lines[2].startswith(f"records: {n} at heights ")
    assert lines[3].startswith("period: ") and " to " in lines[3]
    assert any(ln.startswith("QC would keep ") and f" of {n}" in ln for ln in lines)


def test_convert_summary_says_format_and_sidecar_and_counts_the_mapping(tmp_path, capsys):
    text = (FORMATS / "iea43_floating_lidar.csv").read_text()
    meta, end = json.JSONDecoder().raw_decode(text)
    (tmp_path / "fls.json").write_text(json.dumps(meta))
    (tmp_path / "fls.csv").write_text(text[end:].lstrip("\n"))
    assert main(["convert", str(tmp_path / "fls.csv"), "--output", str(tmp_path / "r.csv")]) == 0
    out, err = capsys.readouterr()
    assert err == "" and "->" not in out and len(out.splitlines()) <= 12
    assert "format: iea43 (metadata: fls.json, beside the file)" in out.splitlines()
    assert "15 columns mapped; --json lists them" in out.splitlines()
    assert "records: 6 at heights 80, 120 m" in out.splitlines()
    assert main(["convert", str(tmp_path / "fls.csv"), "--output", str(tmp_path / "r.csv"),
                 "--json"]) == 0  # fmt: skip
    got = json.loads(capsys.readouterr().out)
    assert got["header_facts"]["metadata"] == "fls.json" and len(got["mapping"]) == 15
    assert got["qc_preview"]["n_kept"] == 6 and got["heights_m"] == [80.0, 120.0]
