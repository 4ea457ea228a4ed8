"""Instrument files as the instruments write them (flidar_uq.data.formats): WindCube v2
.sta, ZephIR 300 CSV, IEA Task 43; a campaign in several files; time and heading
conventions; extra columns; flidar-uq convert and validate."""

from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
import yaml

from flidar_uq.cli import main
from flidar_uq.data.formats import complete_motion, detect_format, read_any, read_instrument
from flidar_uq.data.formats.join import read_campaign
from flidar_uq.data.io import DataValidationError, read_imu_series, read_records, write_records
from flidar_uq.workflow.inputs import EXIT_DATA, check_config

DATA = Path(__file__).parent / "data" / "formats"
WINDCUBE = DATA / "windcube_v2.sta"
ZEPHIR = DATA / "zephir_10min.csv"
IEA43 = DATA / "iea43_floating_lidar.csv"
REPO = Path(__file__).resolve().parents[1]


def utc(text: str) -> pd.Timestamp:
    return pd.Timestamp(text, tz="UTC")


def row(records: pd.DataFrame, stamp: str, height: float) -> pd.Series:
    sel = records[(records["timestamp"] == utc(stamp)) & (records["height_m"] == height)]
    assert len(sel) == 1
    return sel.iloc[0]


# --------------------------------------------------------------------------- detection
@pytest.mark.parametrize(
    ("path", "fmt"),
    [(WINDCUBE, "windcube_sta"), (ZEPHIR, "zephir_csv"), (IEA43, "iea43")],
)
def test_detect_format(path, fmt):
    assert detect_format(path) == fmt
    assert detect_format(REPO / "tests" / "data" / "hand_written_campaign.csv") == "table"


# --------------------------------------------------------------------------- hand-read rows
def test_windcube_sta_value_by_value():
    got = read_instrument(WINDCUBE)
    rec = got.records
    assert got.facts["scan_angle_deg"] == 28.0
    assert got.facts["serial_number"] == "WLS7-999"
    assert got.facts["heights_m"] == [80.0, 120.0]
    assert got.facts["utc_offset_h"] == 0.0 and got.facts["timestamp_at"] == "end"
    assert len(rec) == 6 and rec["height_m"].tolist() == [80.0, 120.0] * 3
    # line 20: "2023/01/15 00:20" is the END of the interval -> starts 00:10 UTC
    r = row(rec, "2023-01-15T00:10", 80.0)
    assert (r.hws_mean_ms, r.hws_std_ms, r.wd_mean_deg) == (22.10, 2.34, 266.1)
    assert (r.availability_pct, r.cnr_mean_db) == (100.0, -14.5)
    r = row(rec, "2023-01-15T00:10", 120.0)
    assert (r.hws_mean_ms, r.hws_std_ms, r.availability_pct) == (24.40, 2.25, 97.0)
    r = row(rec, "2023-01-15T00:20", 120.0)  # NaN speeds, 0 % availability
    assert np.isnan(r.hws_mean_ms) and r.availability_pct == 0.0
    assert rec["timestamp"].min() == utc("2023-01-15T00:00")
    assert rec["Z-wind (m/s)"].iloc[0] == 0.05  # an extra column, carried per height
    assert rec["Int Temp (°C)"].iloc[1] == 21.40
    assert got.mapping["80m Wind Speed Dispersion (m/s)"] == "hws_std_ms"


def test_zephir_csv_value_by_value():
    got = read_instrument(ZEPHIR)
    rec = got.records
    assert got.facts["serial_number"] == "555"
    assert got.facts["utc_offset_h"] == 1.0 and got.facts["timestamp_at"] == "start"
    assert got.facts["heights_m"] == [150.0, 100.0]
    # "13.12.2016 01:00:00" at UTC+1, start of the interval -> 00:00 UTC
    r = row(rec, "2016-12-13T00:00", 150.0)
    assert (r.hws_mean_ms, r.hws_std_ms, r.wd_mean_deg) == (22.039, 2.444, 219.162)
    assert r.packets_count == 36.0 and r.availability_pct == 100.0  # 36 of the file's 36
    r = row(rec, "2016-12-13T00:10", 150.0)
    assert r.availability_pct == pytest.approx(100 * 35 / 36)
    r = row(rec, "2016-12-13T00:20", 100.0)
    assert (r.hws_mean_ms, r.availability_pct) == (19.583, 50.0)  # 20 of 40 packets
    r = row(rec, "2016-12-13T00:20", 150.0)  # 9999: no value
    assert np.isnan(r.hws_mean_ms) and r.availability_pct == 0.0
    # ZephIR Bearing 311.066 deg (compass) -> counter-clockwise -48.934... wrapped: 48.934
    assert row(rec, "2016-12-13T00:00", 100.0).heading_mean_deg == pytest.approx(48.934)
    assert any("Packets in Average" in n or "packet count" in n for n in got.notes)


def test_iea43_value_by_value():
    got = read_instrument(IEA43)
    rec = got.records
    assert got.facts["utc_offset_h"] == 1.0 and got.facts["timestamp_at"] == "end"
    assert got.facts["averaging_period_min"] == 10 and got.facts["serial_number"] == "1234"
    assert got.facts["heights_m"] == [80.0, 120.0]  # the data model's height_m, not 79 m
    # "2023-01-15 01:10:00" at UTC+1, end of the interval -> 00:00 UTC start
    r = row(rec, "2023-01-15T00:00", 80.0)
    assert (r.hws_mean_ms, r.hws_std_ms, r.wd_mean_deg, r.availability_pct) == (
        21.5,
        2.2,
        250.1,
        100.0,
    )
    assert (r.wave_hs_m, r.wave_tp_s, r.wave_dir_deg) == (3.1, 8.2, 245.0)
    assert r.heading_mean_deg == -90.0  # compass 90 (east) -> 90 deg clockwise = -90 ccw
    assert row(rec, "2023-01-15T00:20", 80.0).availability_pct == 50.0
    assert row(rec, "2023-01-15T00:20", 120.0).heading_mean_deg == 90.0  # compass 270


@pytest.mark.parametrize("path", [WINDCUBE, ZEPHIR, IEA43])
def test_convert_writes_the_documented_record_table(path, tmp_path, capsys):
    out = tmp_path / "records.csv"
    assert main(["convert", str(path), "--output", str(out), "--json"]) == 0
    captured = capsys.readouterr()
    result = json.loads(captured.out)
    assert result["n_records"] == 6
    assert "hws_mean_ms" in result["mapping"].values() and captured.err == ""  # the mapping
    back = read_records(out, require_motion=False, extra_columns="keep")
    expected, _ = complete_motion(read_instrument(path).records)  # IEA 43: periods from Tp
    pd.testing.assert_frame_equal(back, expected[list(back.columns)], check_dtype=False)


# --------------------------------------------------------------------------- bad variants
def _lines(path: Path) -> list[str]:
    return path.read_bytes().decode("latin-1").split("\n")


def _write(tmp: Path, name: str, lines: list[str]) -> Path:
    p = tmp / name
    p.write_bytes("\n".join(lines).encode("latin-1"))
    return p


def _drop_field(lines: list[str], name: str, sep: str, start: int) -> list[str]:
    k = lines[start].split(sep).index(name)
    out = lines[:start]
    for ln in lines[start:]:
        fields = ln.split(sep)
        out.append(sep.join(fields[:k] + fields[k + 1 :]) if len(fields) > k else ln)
    return out


def _iea_offsets(tmp: Path) -> Path:
    text = IEA43.read_text()
    text = text.replace('"offset_from_utc_hrs": 1,', '"offset_from_utc_hrs": 0,', 1)
    p = tmp / "iea.csv"
    p.write_text(text)
    return p


def _iea_truncated(tmp: Path) -> Path:
    p = tmp / "iea.csv"
    p.write_text("\n".join(IEA43.read_text().split("\n")[:20]))
    return p


def _iea_lines(tmp: Path, edit) -> Path:
    lines = IEA43.read_text().split("\n")
    start = next(i for i, ln in enumerate(lines) if ln.startswith("Timestamp"))
    p = tmp / "iea.csv"
    p.write_text("\n".join(edit(lines, start)))
    return p


BAD = {
    "windcube_truncated_header": (
        lambda t: _write(t, "wc.sta", _lines(WINDCUBE)[:12]),
        [],
        r"wc\.sta: line 18, column 'HeaderSize': truncated header",
    ),
    "windcube_separator": (
        lambda t: _write(
            t,
            "wc.sta",
            [ln if i != 19 else ln.replace("\t", ";") for i, ln in enumerate(_lines(WINDCUBE))],
        ),  # fmt: skip
        [],
        r"wc\.sta: row 2 \(line 20\), column 'Int Temp \(°C\)': 1 tab-separated fields .*';'",
    ),
    "windcube_height_column_missing": (
        lambda t: _write(
            t, "wc.sta", _drop_field(_lines(WINDCUBE), "120m Wind Speed Dispersion (m/s)", "\t", 17)
        ),
        [],
        r"wc\.sta: line 18, column '120m Wind Speed Dispersion \(m/s\)': column missing "
        r"although the header lists the height 120 m",
    ),
    "windcube_utc_offsets": (
        lambda t: _write(t, "wc.sta", _lines(WINDCUBE)),
        ["--utc-offset-h", "1"],
        r"wc\.sta: line 8, column 'timezone': inconsistent UTC offsets: the header states "
        r"UTC\+0 h, the config campaign\.utc_offset_h \+1 h",
    ),
    "zephir_truncated_header": (
        lambda t: _write(t, "z.csv", _lines(ZEPHIR)[:1]),
        [],
        r"z\.csv: line 2, column 'Time and Date': truncated header",
    ),
    "zephir_separator": (
        lambda t: _write(
            t,
            "z.csv",
            [ln if i != 3 else ln.replace(";", "\t") for i, ln in enumerate(_lines(ZEPHIR))],
        ),  # fmt: skip
        [],
        r"z\.csv: row 2 \(line 4\), column 'Time and Date': 1 ';'-separated fields",
    ),
    "zephir_height_column_missing": (
        lambda t: _write(
            t, "z.csv", _drop_field(_lines(ZEPHIR), "Horizontal Wind Speed (m/s) at 100m", ";", 1)
        ),
        [],
        r"z\.csv: line 2, column 'Horizontal Wind Speed \(m/s\) at 100m': column missing",
    ),
    "zephir_utc_offsets": (
        lambda t: _write(t, "z.csv", _lines(ZEPHIR)),
        ["--utc-offset-h", "0"],
        r"z\.csv: line 1, column 'Time sync': inconsistent UTC offsets",
    ),
    "iea43_truncated_header": (
        _iea_truncated,
        [],
        r"iea\.csv: line \d+: truncated or malformed JSON header",
    ),
    "iea43_separator": (
        lambda t: _iea_lines(
            t, lambda ls, s: [ln if i != s + 2 else ln.replace(",", ";") for i, ln in enumerate(ls)]
        ),  # fmt: skip
        [],
        r"iea\.csv: row 2 \(line \d+\), column 'Horizontal Wind Speed \(m/s\) at 79m': 1 "
        r"comma-separated fields .*';'",
    ),
    "iea43_height_column_missing": (
        lambda t: _iea_lines(
            t, lambda ls, s: _drop_field(ls, "Horizontal Wind Speed (m/s) at 119m", ",", s)
        ),
        [],
        r"iea\.csv: line \d+, column 'Horizontal Wind Speed \(m/s\) at 119m': column missing "
        r"although the metadata lists it \(hws_mean_ms at 120 m\)",
    ),
    "iea43_utc_offsets": (
        _iea_offsets,
        [],
        r"iea\.csv: header, column 'offset_from_utc_hrs': inconsistent UTC offsets: logger "
        r"'FLS1' states 0, logger 'FLS1-wave' 1",
    ),
}


@pytest.mark.parametrize("case", sorted(BAD))
def test_bad_variant_one_line_naming_file_row_and_column(case, tmp_path, capsys):
    build, extra, pattern = BAD[case]
    path = build(tmp_path)
    argv = ["convert", str(path), "--output", str(tmp_path / "out.csv"), *extra]
    assert main(argv) == EXIT_DATA
    out, err = capsys.readouterr()
    assert out == ""
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    assert re.search(pattern, lines[0]), lines[0]
    assert not (tmp_path / "out.csv").exists()


# --------------------------------------------------------------------------- time conventions
def _table(tmp: Path, stamps: list[str]) -> Path:
    df = read_records(REPO / "tests" / "data" / "hand_written_campaign.csv")
    df = df[df["height_m"] == 58.0].head(len(stamps)).copy()
    df["timestamp"] = stamps
    p = tmp / "t.csv"
    df.to_csv(p, index=False)
    return p


def test_table_time_conventions_give_utc_at_interval_start(tmp_path):
    p = _table(tmp_path, ["2020-06-01 01:10:00", "2020-06-01 01:20:00"])
    got = read_any(p, {"format": "table", "utc_offset_h": 1, "timestamp_at": "end"})
    assert got.records["timestamp"].tolist() == [
        utc("2020-06-01T00:00"),
        utc("2020-06-01T00:10"),
    ]
    assert read_any(p, {"format": "table"}).records["timestamp"].iloc[0] == utc("2020-06-01T01:10")


def test_table_off_the_10_min_grid_names_the_row(tmp_path):
    p = _table(tmp_path, ["2020-06-01 00:00:00", "2020-06-01 00:10:00", "2020-06-01 00:25:00"])
    with pytest.raises(DataValidationError, match=r"t\.csv: row 3 \(line 4\), column "
                       r"'timestamp': time stamp 2020-06-01T00:25:00\+00:00 is not on the "
                       r"10-min grid"):  # fmt: skip
        read_any(p, {"format": "table"})


def test_table_mixing_utc_offsets_names_the_row(tmp_path):
    p = _table(tmp_path, ["2020-06-01T00:00:00+01:00", "2020-06-01T00:10:00+02:00"])
    with pytest.raises(DataValidationError, match=r"row 2 \(line 3\), column 'timestamp': "
                       "mixed time zones"):  # fmt: skip
        read_any(p, {"format": "table"})


# --------------------------------------------------------------------------- headings
def test_compass_and_ccw_heading_series_give_the_same_along_wind_tilt(tmp_path):
    from flidar_uq.data.imu import tilt_spectrum_statistics_by_height

    fs, n = 10.0, 12_000  # 20 min at 10 Hz
    t = np.arange(n) / fs
    rng = np.random.default_rng(5)
    base = pd.DataFrame(
        {
            "timestamp": pd.Timestamp("2021-03-01", tz="UTC") + pd.to_timedelta(t, unit="s"),
            "roll_deg": 3.0 * np.sin(2 * np.pi * t / 4.0) + 0.1 * rng.standard_normal(n),
            "pitch_deg": 1.0 * np.sin(2 * np.pi * t / 6.0) + 0.1 * rng.standard_normal(n),
        }
    )
    yaw_ccw = 60.0 + 5.0 * np.sin(2 * np.pi * t / 300.0)  # counter-clockwise from north
    compass = np.mod(-yaw_ccw, 360.0)  # the same heading as a compass bearing: 300 deg
    write = lambda df, name: (df.to_csv(tmp_path / name, index=False), tmp_path / name)[1]  # noqa: E731
    ccw_path = write(base.assign(yaw_deg=yaw_ccw), "ccw.csv")
    compass_path = write(base.assign(yaw_deg=compass), "compass.csv")
    ccw = read_imu_series(ccw_path)
    from_compass = read_imu_series(compass_path, heading_convention="compass")
    np.testing.assert_allclose(np.cos(np.radians(from_compass["yaw_deg"] - ccw["yaw_deg"])), 1.0)
    wd = pd.Series(315.0, index=pd.DatetimeIndex([utc("2021-03-01"), utc("2021-03-01T00:10")]))
    a, _ = tilt_spectrum_statistics_by_height(ccw, {0: wd})[0]
    b, _ = tilt_spectrum_statistics_by_height(from_compass, {0: wd})[0]
    np.testing.assert_allclose(b["tilt_along_wind_std_deg"], a["tilt_along_wind_std_deg"])
    np.testing.assert_allclose(b["tilt_across_wind_std_deg"], a["tilt_across_wind_std_deg"])
    # read as if it were counter-clockwise, the compass series would tilt differently
    c, _ = tilt_spectrum_statistics_by_height(read_imu_series(compass_path), {0: wd})[0]
    assert not np.allclose(c["tilt_along_wind_std_deg"], a["tilt_along_wind_std_deg"], rtol=0.05)


def test_compass_heading_of_a_table_is_converted(tmp_path):
    df = read_records(REPO / "tests" / "data" / "hand_written_campaign.csv")
    df["heading_mean_deg"] = 270.0  # west, as a compass bearing: outside [-180, 180]
    p = tmp_path / "h.csv"
    df.to_csv(p, index=False)
    got = read_any(p, {"format": "table", "heading_convention": "compass"})
    assert (got.records["heading_mean_deg"] == 90.0).all()  # west = 90 deg ccw from north
    with pytest.raises(DataValidationError, match="heading_mean_deg"):
        read_any(p, {"format": "table"})


# --------------------------------------------------------------------------- extra columns
def test_extra_columns_keep_ignore_error(tmp_path):
    df = pd.read_csv(REPO / "tests" / "data" / "hand_written_campaign.csv")
    df["Battery_V"] = 12.5
    df["Logger_note"] = "ok"
    p = tmp_path / "x.csv"
    df.to_csv(p, index=False)
    kept = read_records(p, extra_columns="keep")
    assert list(kept.columns[-2:]) == ["Battery_V", "Logger_note"]
    assert (kept["Logger_note"] == "ok").all() and (kept["Battery_V"] == 12.5).all()
    assert "Battery_V" not in read_records(p, extra_columns="ignore").columns
    with pytest.raises(DataValidationError, match="column 'Battery_V': unknown column"):
        read_records(p)
    out = write_records(kept, tmp_path / "back.csv")
    assert pd.read_csv(out)["Logger_note"].eq("ok").all()


# --------------------------------------------------------------------------- motion columns
def test_complete_motion_amplitude_from_std_and_period_from_waves():
    rec = pd.DataFrame({"roll_std_deg": [2.0], "pitch_std_deg": [1.0], "wave_tp_s": [9.0]})
    out, notes = complete_motion(rec)
    assert out["roll_amplitude_deg"].iloc[0] == pytest.approx(2.0 * np.sqrt(2.0))
    assert out["pitch_amplitude_deg"].iloc[0] == pytest.approx(np.sqrt(2.0))
    assert out["roll_period_s"].iloc[0] == out["pitch_period_s"].iloc[0] == 9.0
    assert len(notes) == 3 and "sqrt(2)" in notes[0]
    given = rec.assign(roll_amplitude_deg=5.0, roll_period_s=4.0)
    out, _ = complete_motion(given)
    assert out["roll_amplitude_deg"].iloc[0] == 5.0 and "pitch_period_s" not in out


# --------------------------------------------------------------------------- three files
def three_file_campaign() -> dict:
    data = yaml.safe_load((DATA / "three_file_config.yaml").read_text())
    camp = data["campaign"]
    for key in ("lidar_file", "motion_file", "reference_file"):
        camp[key]["path"] = str(REPO / camp[key]["path"])
    return data


def test_three_files_joined_on_the_interval_and_reported():
    camp = check_config(three_file_campaign())["campaign"]
    assert camp["records"].endswith("windcube_v2.sta")
    rec, join, facts, notes = read_campaign(camp["records"], camp)
    assert facts["format"] == "windcube_sta"
    j = join.set_index("role")
    assert j.loc["lidar", "intervals"] == 3
    # the logger: 01:10-01:40 at UTC+1, end of interval -> 00:00-00:30 UTC start
    assert tuple(
        j.loc["motion", ["intervals", "matched", "unmatched_lidar", "unmatched_file"]]
    ) == (
        4,
        3,
        0,
        1,
    )
    assert tuple(j.loc["reference", ["intervals", "matched", "unmatched_lidar"]]) == (2, 2, 1)
    r = row(rec, "2023-01-15T00:00", 80.0)
    assert r.roll_std_deg == 2.12 and r.roll_amplitude_deg == pytest.approx(2.12 * np.sqrt(2))
    assert r.roll_period_s == 8.2  # wave_tp_s: the logger writes no attitude period
    assert r.heading_mean_deg == 10.0  # compass 350 -> ccw 10
    assert np.isnan(r.ref_hws_mean_ms)  # the mast starts at 00:10
    r = row(rec, "2023-01-15T00:10", 120.0)
    assert (r.ref_hws_mean_ms, r.ref_hws_std_ms, r.wave_hs_m) == (24.10, 1.85, 3.30)
    assert rec["Battery_V"].eq(12.6).sum() == 4  # an extra column of the logger, kept
    assert any("sqrt(2)" in n for n in notes)


def test_validate_prints_the_format_header_facts_and_join(tmp_path, capsys):
    cfg = tmp_path / "c.yaml"
    cfg.write_text(yaml.safe_dump(three_file_campaign()))
    assert main(["validate", "--json", "--config", str(cfg)]) == 0
    captured = capsys.readouterr()
    out = json.loads(captured.out)
    assert out["format"] == "windcube_sta"
    assert out["header_facts"]["scan_angle_deg"] == 28.0
    assert [r["role"] for r in out["join"]] == ["lidar", "motion", "reference"]
    assert "windcube_sta: " in captured.err and "scan_angle_deg=28.0" in captured.err
    assert "join motion" in captured.err


def test_imu_velocity_columns_validated():
    from flidar_uq.data.io import validate_imu_series

    t = pd.Timestamp("2021-03-01", tz="UTC") + pd.to_timedelta(np.arange(50) / 10.0, unit="s")
    imu = pd.DataFrame({"timestamp": t, "roll_deg": 2.0, "pitch_deg": 1.0})
    imu["velocity_east_ms"] = 0.3
    imu["velocity_north_ms"] = np.nan  # allowed: a missing sample
    imu["velocity_up_ms"] = -0.5
    out = validate_imu_series(imu)
    assert list(out.columns[-3:]) == ["velocity_east_ms", "velocity_north_ms", "velocity_up_ms"]
    imu.loc[7, "velocity_up_ms"] = 25.0
    with pytest.raises(DataValidationError, match=r"row 8, column 'velocity_up_ms': value 25"):
        validate_imu_series(imu)


@pytest.mark.parametrize(
    ("path", "fmt", "fact"),
    [
        (WINDCUBE, "windcube_sta", "scan_angle_deg=28.0"),
        (ZEPHIR, "zephir_csv", "serial_number=555"),
        (IEA43, "iea43", "averaging_period_min=10"),
    ],
)
def test_each_sample_validates_without_a_column_map(path, fmt, fact, tmp_path, capsys):
    stamps = read_instrument(path).records["timestamp"].unique()
    logger = pd.DataFrame(
        {
            "timestamp": pd.DatetimeIndex(stamps).strftime("%Y-%m-%dT%H:%M:%SZ"),
            "roll_std_deg": 2.0,
            "pitch_std_deg": 1.5,
            "wave_tp_s": 7.5,
        }
    )
    logger.to_csv(tmp_path / "logger.csv", index=False)
    cfg = {
        "campaign": {
            "source": "files",
            "records": str(path),
            "motion_file": {"path": str(tmp_path / "logger.csv")},
        }
    }
    (tmp_path / "c.yaml").write_text(yaml.safe_dump(cfg))
    assert main(["validate", "--json", "--config", str(tmp_path / "c.yaml")]) == 0
    captured = capsys.readouterr()
    out = json.loads(captured.out)
    assert out["format"] == fmt and out["n_records"] == 6
    assert f"flidar-uq validate: {fmt}: " in captured.err and fact in captured.err
    assert out["join"][1]["matched"] == 3
    assert any("sqrt(2)" in n for n in out["notes"])


def test_iea43_metadata_in_a_json_file_of_the_same_name(tmp_path):
    text = IEA43.read_text()
    meta, end = json.JSONDecoder().raw_decode(text)
    (tmp_path / "fls.json").write_text(json.dumps(meta))
    (tmp_path / "fls.csv").write_text(text[end:].lstrip("\n"))
    assert detect_format(tmp_path / "fls.csv") == "iea43"
    got = read_instrument(tmp_path / "fls.csv")
    assert got.facts["metadata"] == "fls.json"
    pd.testing.assert_frame_equal(got.records, read_instrument(IEA43).records)
    (tmp_path / "fls.json").unlink()
    with pytest.raises(DataValidationError, match="no IEA Task 43 metadata"):
        read_instrument(tmp_path / "fls.csv", "iea43")


def test_windcube_v1_layout_is_named(tmp_path):
    p = tmp_path / "v1.sta"
    p.write_bytes(b"HeaderLength=55\nVersion=3.1.66\n")
    with pytest.raises(DataValidationError, match=r"v1\.sta: line 1, column 'HeaderLength': "
                       r"not a WindCube v2 header"):  # fmt: skip
        read_instrument(p)


def test_a_json_beside_a_table_that_is_not_task43_metadata_switches_nothing(tmp_path):
    """Only recognisable Task 43 metadata next to a file makes it an IEA Task 43 file."""
    text = IEA43.read_text()
    meta, end = json.JSONDecoder().raw_decode(text)
    (tmp_path / "fls.csv").write_text(text[end:].lstrip("\n"))
    (tmp_path / "fls.json").write_text(json.dumps({"exported_by": "logger", "rows": 6}))
    assert detect_format(tmp_path / "fls.csv") == "table"
    with pytest.raises(DataValidationError, match=r"fls\.json.*not IEA Task 43 metadata"):
        read_instrument(tmp_path / "fls.csv", "iea43")
    (tmp_path / "fls.json").write_text("[1, 2")  # not even JSON
    assert detect_format(tmp_path / "fls.csv") == "table"
    (tmp_path / "fls.json").write_text(json.dumps(meta))
    assert detect_format(tmp_path / "fls.csv") == "iea43"


def test_a_wide_instrument_file_reads_without_a_pandas_performance_warning(tmp_path):
    """150 extra logger columns: the frame is built at once, never column by column."""
    import warnings

    text = WINDCUBE.read_bytes().decode("latin-1").split("\n")
    n = int(text[0].split("=")[1])
    head, table = text[: n + 1], text[n + 1 :]
    wide = [table[0] + "".join(f"\tlogger_{k}" for k in range(150))]
    wide += [ln + "".join(f"\t{k}" for k in range(150)) if ln.strip() else ln for ln in table[1:]]
    path = tmp_path / "wide.sta"
    path.write_bytes("\n".join(head + wide).encode("latin-1"))
    with warnings.catch_warnings():
        warnings.simplefilter("error", pd.errors.PerformanceWarning)
        got = read_instrument(path)
    narrow = read_instrument(WINDCUBE).records
    assert got.records["logger_149"].eq(149).all()
    pd.testing.assert_frame_equal(got.records[narrow.columns], narrow)
