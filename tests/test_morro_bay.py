"""A real lidar buoy's day: the Morro Bay WindSentinel's WindCube v2 ``.sta`` and its wave
sensor's 20-min bursts (tests/data/morro_bay/PROVENANCE.md), converted and run end to end.

The buoy's files carry no roll or pitch statistics: the wave sensor's Hs, Tp and
direction are joined burst by burst onto the 10-min records, and the pipeline reports the
campaign uncorrected, saying why.
"""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
import yaml
from test_no_motion import _summary_text

from flidar_uq.cli import main
from flidar_uq.data.formats import read_instrument
from flidar_uq.data.formats.join import join_records, read_campaign, read_part
from flidar_uq.data.io import DataValidationError

REPO = Path(__file__).resolve().parents[1]
DATA = REPO / "tests" / "data" / "morro_bay"
STA = DATA / "lidar.z06.00.20201201.000000.sta"
WAVES = DATA / "buoy.z06.00.20201201.000000.waves.csv"
HEIGHTS_M = [40.0, 60.0, 80.0, 90.0, 100.0, 120.0, 140.0, 160.0, 180.0, 200.0, 220.0, 240.0]
#: the wave file's columns -> record columns (m, s, deg from north, deg)
WAVE_COLUMNS = {
    "DataTimeStamp": "timestamp",
    "HM0": "wave_hs_m",
    "PeakPeriod": "wave_tp_s",
    "MeanDirection": "wave_dir_deg",
    "MeanSpread": "wave_spread_deg",
}


def _raw_sta() -> pd.DataFrame:
    """The ``.sta`` table read independently of the product: latin-1, tab-separated,
    column names on line 42 (``HeaderSize=40``)."""
    return pd.read_csv(STA, sep="\t", skiprows=41, encoding="latin-1", na_values=["NaN"])


def test_sta_columns_map_to_the_record_contract_in_utc_at_the_interval_start():
    got = read_instrument(STA)
    rec, raw = got.records, _raw_sta()
    assert got.facts["format"] == "windcube_sta" and got.facts["timestamp_at"] == "end"
    assert got.facts["utc_offset_h"] == 0.0 and got.facts["scan_angle_deg"] == 28.0
    assert got.facts["serial_number"] == "WLS866-24" and got.facts["heights_m"] == HEIGHTS_M
    assert len(rec) == len(raw) * len(HEIGHTS_M) == 144 * 12
    assert str(rec["timestamp"].dt.tz) == "UTC"
    # stamps are the interval's end: the first record (2020/12/01 00:10) starts at 00:00
    ends = pd.to_datetime(raw["Timestamp (end of interval)"], format="%Y/%m/%d %H:%M")
    for h in HEIGHTS_M:
        at = rec[rec["height_m"] == h].reset_index(drop=True)
        np.testing.assert_array_equal(
            at["timestamp"].dt.tz_localize(None), ends - pd.Timedelta(minutes=10)
        )
        label = f"{h:g}m "
        for quantity, column in [
            ("Wind Speed (m/s)", "hws_mean_ms"),
            ("Wind Speed Dispersion (m/s)", "hws_std_ms"),
            ("Wind Direction (°)", "wd_mean_deg"),
            ("Data Availability (%)", "availability_pct"),
            ("CNR (dB)", "cnr_mean_db"),
        ]:
            np.testing.assert_array_equal(at[column], raw[label + quantity], err_msg=column)
    assert rec["timestamp"].iloc[0] == pd.Timestamp("2020-12-01T00:00:00Z")
    assert rec["hws_mean_ms"].isna().sum() > 0  # the file's 'NaN' kept as missing
    assert not {"roll_amplitude_deg", "pitch_amplitude_deg"} & set(rec.columns)


def test_wave_bursts_join_onto_the_records_burst_by_burst():
    """Each 10-min record takes the 20-min burst stamped at or before its start, less
    than 20 min before it: 00:00 and 00:10 the burst of 00:00, 00:20 and 00:30 that of
    00:20."""
    rec, join, _, notes = read_campaign(
        STA, {"motion_file": {"path": str(WAVES), "columns": WAVE_COLUMNS}}, require_motion=False
    )
    waves = pd.read_csv(WAVES)
    motion = join.set_index("role").loc["motion"]
    assert motion["interval_min"] == 20.0 and motion["intervals"] == len(waves) == 72
    assert motion["matched"] == 144 and motion["unmatched_lidar"] == 0
    assert motion["unmatched_file"] == 0
    at40 = rec[rec["height_m"] == 40.0].reset_index(drop=True)
    burst = np.repeat(np.arange(len(waves)), 2)  # two records per burst
    np.testing.assert_array_equal(at40["wave_hs_m"], waves["HM0"].to_numpy()[burst])
    np.testing.assert_array_equal(at40["wave_tp_s"], waves["PeakPeriod"].to_numpy()[burst])
    np.testing.assert_array_equal(at40["wave_dir_deg"], waves["MeanDirection"].to_numpy()[burst])
    # every height of an interval takes the same burst
    assert rec.groupby("timestamp")["wave_hs_m"].nunique().eq(1).all()
    # no attitude: the periods are the wave peak period, no amplitude is made up
    np.testing.assert_array_equal(rec["roll_period_s"], rec["wave_tp_s"])
    assert "roll_amplitude_deg" not in rec.columns and any("wave_tp_s" in n for n in notes)


def test_a_missing_burst_leaves_its_records_empty_not_an_older_burst():
    t = pd.date_range("2020-12-01", periods=8, freq="10min", tz="UTC")
    lidar = pd.DataFrame({"timestamp": t, "height_m": 40.0, "hws_mean_ms": 8.0})
    stamps = pd.DatetimeIndex([t[0], t[4], t[6], t[6] + pd.Timedelta(minutes=20)])
    bursts = pd.DataFrame({"timestamp": stamps, "wave_hs_m": [1.0, 3.0, 4.0, 5.0]})
    out, rows = join_records(lidar, {"motion": bursts})  # the 00:20 burst is missing
    np.testing.assert_array_equal(out["wave_hs_m"], [1, 1, np.nan, np.nan, 3, 3, 4, 4])
    assert rows[1] == dict(role="motion", interval_min=20.0, intervals=4, matched=6,
                           unmatched_lidar=2, unmatched_file=1)  # fmt: skip
    # stamps parsed at another time unit than the lidar's join alike
    seconds = bursts.assign(timestamp=stamps.as_unit("s"))
    again, _ = join_records(lidar.assign(timestamp=t.as_unit("ns")), {"motion": seconds})
    np.testing.assert_array_equal(again["wave_hs_m"], out["wave_hs_m"])
    # at the records' own cadence the join is by interval: a gap is not filled
    ten = pd.DataFrame({"timestamp": t[[0, 1, 3]], "wave_hs_m": [1.0, 2.0, 4.0]})
    out, rows = join_records(lidar, {"motion": ten})
    np.testing.assert_array_equal(out["wave_hs_m"], [1, 2, np.nan, 4, *[np.nan] * 4])
    assert rows[1]["interval_min"] == 10.0 and rows[1]["matched"] == 3


def test_bursts_stamped_at_their_end_start_one_cadence_earlier(tmp_path):
    waves = pd.read_csv(WAVES)
    end = pd.to_datetime(waves["DataTimeStamp"]) + pd.Timedelta(minutes=20)
    waves.assign(DataTimeStamp=end.dt.strftime("%Y-%m-%d %H:%M:%S")).to_csv(
        tmp_path / "end.csv", index=False
    )
    start = read_part({"path": str(WAVES), "columns": WAVE_COLUMNS})
    ended = read_part({"path": str(tmp_path / "end.csv"), "columns": WAVE_COLUMNS,
                       "timestamp_at": "end"})  # fmt: skip
    np.testing.assert_array_equal(ended["timestamp"], start["timestamp"])
    assert ended["timestamp"].iloc[0] == pd.Timestamp("2020-12-01T00:00:00Z")


def _convert_args(out: Path) -> list[str]:
    args = ["convert", str(STA), "--output", str(out), "--motion-file", str(WAVES)]
    for name, column in WAVE_COLUMNS.items():
        args += ["--motion-column", f"{name}={column}"]
    return args


def test_convert_joins_the_wave_file_and_says_its_cadence(tmp_path, capsys):
    assert main(_convert_args(tmp_path / "records.csv")) == 0
    out = capsys.readouterr().out.splitlines()
    assert (
        f"join motion {WAVES}: every 20 min; 144 intervals took one of its 72 bursts, 0 none" in out
    )
    written = pd.read_csv(tmp_path / "records.csv")
    assert len(written) == 1728 and written["wave_hs_m"].notna().all()
    assert written["timestamp"].iloc[0] == "2020-12-01T00:00:00Z"
    assert main([*_convert_args(tmp_path / "r.csv"), "--json"]) == 0
    got = json.loads(capsys.readouterr().out)
    assert [j["role"] for j in got["join"]] == ["lidar", "motion"]


def test_convert_refuses_a_motion_column_without_its_record_name(tmp_path, capsys):
    args = ["convert", str(STA), "--output", str(tmp_path / "r.csv"), "--motion-column", "HM0"]
    assert main(args) != 0
    assert "expected NAME=COLUMN, got 'HM0'" in capsys.readouterr().err


def test_a_malformed_sta_is_refused_naming_its_line(tmp_path):
    lines = STA.read_bytes().decode("latin-1").split("\n")
    cut = tmp_path / "cut.sta"
    cut.write_bytes("\n".join(lines[:30]).encode("latin-1"))  # header cut short
    with pytest.raises(ValueError, match=r"truncated header: HeaderSize=40 puts the column"):
        read_instrument(cut)
    bad = tmp_path / "semicolons.sta"
    lines[44] = lines[44].replace("\t", ";")  # the third data row
    bad.write_bytes("\n".join(lines).encode("latin-1"))
    with pytest.raises(DataValidationError, match=r"row 3 \(line 45\).*the file uses tabs"):
        read_instrument(bad)


@pytest.mark.slow
def test_morro_bay_day_converts_and_runs_to_a_report(tmp_path):
    """Convert the day with its wave file (the console script), run the pipeline with no
    reference: every record answered, the uncorrected path taken and said so, with the
    reason, and per-bin tables filled."""
    exe = Path(sys.executable).parent / "flidar-uq"
    records = tmp_path / "records.csv"
    conv = subprocess.run([str(exe), *_convert_args(records)], capture_output=True, text=True,
                          timeout=300, cwd=tmp_path)  # fmt: skip
    assert conv.returncode == 0, conv.stderr[-3000:]
    cfg = {
        "campaign": {"source": "files", "records": str(records), "lidar": "windcube_v2"},
        "reference": {"kind": "none"},
    }
    (tmp_path / "config.yaml").write_text(yaml.safe_dump(cfg))
    proc = subprocess.run(
        [str(exe), "run", "--cores", "2", "--configfile", str(tmp_path / "config.yaml"),
         "--directory", str(tmp_path), "-s", str(REPO / "Snakefile")],
        capture_output=True, text=True, timeout=900, cwd=tmp_path,
    )  # fmt: skip
    assert proc.returncode == 0, proc.stdout[-3000:] + proc.stderr[-3000:]
    res = tmp_path / "results"
    out = pd.read_csv(res / "ti" / "records.csv")
    flags = pd.read_csv(res / "qc" / "flags.csv")
    assert len(out) == len(flags) == 1728
    kept = flags["kept"].to_numpy(dtype=bool)
    assert kept.sum() > 1000
    # every QC-kept record answered: a corrected TI, or uncorrected with its reason
    corrected = np.isfinite(out["ti_corrected_median"].to_numpy())
    reason = out["flags"].fillna("").str.len().to_numpy() > 0
    assert (corrected | reason)[kept].all()
    assert np.isfinite(out.loc[kept, "ti_uncorrected"]).all()
    width = out["ti_corrected_hi"] - out["ti_corrected_lo"]
    above = out["ti_corrected_median"] - out["ti_uncorrected"]
    assert (above[corrected] <= width[corrected]).all()
    # no roll/pitch statistics: the uncorrected path, record by record and in words
    assert not corrected.any() and (out.loc[kept, "flags"] == "no_motion_description").all()
    assert out.loc[kept, "wave_hs_m"].notna().all()
    bins = pd.read_csv(res / "ti" / "speed_bins.csv")
    filled = bins[bins["n"] >= 10]  # report.group_min_count
    assert len(filled) >= 20
    assert np.isfinite(filled.filter(like="_uncorrected").to_numpy()).all()
    assert bins["n"].sum() == kept.sum()
    text = _summary_text((res / "report" / "report.html").read_text())
    assert "none corrected for motion" in text and "Not corrected for the buoy's motion" in text
    assert "no roll_amplitude_deg, pitch_amplitude_deg columns and no raw IMU series" in text
    for r in filled.itertuples():
        assert f"{r.ti_mean_uncorrected:.3f} {r.ti_rep_uncorrected:.3f}" in text
    assert "uncorrected (no motion statistics)" in proc.stdout
