"""The WindCube v2's real-time files (.rtd) as LOS series (flidar_uq.data.formats.read_los_file):
the hand-written tests/data/formats/windcube_v2.rtd value by value, the conversions to the
project's conventions (radial speed positive away, Position into azimuth and elevation, UTC),
bad rows named by file, row and column, and the LOS step reading a .rtd as it reads the
documented table."""

from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from test_formats import DATA, _lines, _write

from flidar_uq.campaign.physics_mode import generate_campaign
from flidar_uq.campaign.scenarios import load_scenario
from flidar_uq.cli import main
from flidar_uq.correction.los import correct_dbs_motion
from flidar_uq.data import io
from flidar_uq.data.formats import detect_los_format, read_los_file
from flidar_uq.data.imu_series import series_span
from flidar_uq.workflow.inputs import EXIT_DATA, EXIT_OK, check_series
from flidar_uq.workflow.los_step import los_correction

RTD = DATA / "windcube_v2.rtd"
GATES = [40.0, 80.0, 120.0]


def test_detect_los_format(tmp_path):
    assert detect_los_format(RTD) == "windcube_rtd"
    table = tmp_path / "los.csv"
    io.write_los_series(read_los_file(RTD)[0], table)
    assert detect_los_format(table) == "table"
    assert read_los_file(table)[1] == {"format": "table"}
    # a WindCube header is a .rtd whatever the file's name
    assert detect_los_format(_write(tmp_path, "los.txt", _lines(RTD))) == "windcube_rtd"


def test_windcube_rtd_value_by_value():
    los, facts = read_los_file(RTD)
    assert facts["format"] == "windcube_rtd" and facts["serial_number"] == "WLS7-999"
    assert facts["scan_angle_deg"] == 28.0 and facts["direction_offset_deg"] == 0.0
    assert facts["heights_m"] == GATES and facts["utc_offset_h"] == 1.0
    assert list(los.columns) == [
        "timestamp", "height_m", "azimuth_deg", "radial_speed_ms", "cnr_db", "elevation_deg"
    ]  # fmt: skip
    assert len(los) == 10 * 3 and los["height_m"].tolist() == GATES * 10
    # line 18: "2023/01/15 01:00:00.48" at UTC+1 -> 00:00:00.48 UTC
    assert los["timestamp"].iloc[0] == pd.Timestamp("2023-01-15T00:00:00.48Z")
    assert los["timestamp"].iloc[-1] == pd.Timestamp("2023-01-15T00:00:09.49Z")
    # line 19: Position 90, "80m Radial Wind Speed (m/s)" -3.86 (towards the lidar): +3.86 away
    r = los.iloc[3 + 1]
    assert (r.azimuth_deg, r.elevation_deg, r.radial_speed_ms, r.cnr_db) == (
        90.0, 62.0, 3.86, -17.4
    )  # fmt: skip
    # line 22: the vertical beam, Position "V": elevation 90, azimuth 0; its speed -0.06 -> 0.06
    v = los.iloc[12:15]
    assert (v["elevation_deg"] == 90.0).all() and (v["azimuth_deg"] == 0.0).all()
    assert v["radial_speed_ms"].tolist() == [0.06, 0.06, 0.06]
    # line 24 at 120 m: a measurement the lidar rejected (CNR -27.4 dB), speeds NaN
    r = los.iloc[6 * 3 + 2]
    assert np.isnan(r.radial_speed_ms) and r.cnr_db == -27.4
    assert np.isfinite(los["radial_speed_ms"]).sum() == 29
    assert los["azimuth_deg"].tolist()[::3] == [0.0, 90.0, 180.0, 270.0, 0.0] * 2


def test_windcube_rtd_conventions_give_the_files_wind():
    """The file holds a wind from the west (270 deg), 8 m/s at 80 m: read with the sign and
    azimuth conversions, the level lidar's beam pairs (Yamaguchi and Ishihara, 2016, Eq. 3)
    give it back; with the WindCube's sign kept, the wind would come from the east."""
    los, _ = read_los_file(RTD)
    wide = los.pivot(index="timestamp", columns="height_m", values="radial_speed_ms")
    first = los.groupby("timestamp").first()
    az = np.radians(first["azimuth_deg"].to_numpy())
    az[first["elevation_deg"].to_numpy() == 90.0] = np.nan  # the vertical beam
    t = (wide.index - wide.index[0]).total_seconds().to_numpy()
    kw = dict(range_height_m=GATES, target_height_m=[80.0], method="none", step=5)
    est = correct_dbs_motion("windcube_v2", t, az, wide.to_numpy(), **kw)
    np.testing.assert_allclose(est.wd_deg[:, 0], 270.0, atol=1.0)
    # the file's beams deviate from it by up to 0.12 m/s: u by up to 0.24 / (2 sin 28 deg)
    np.testing.assert_allclose(est.hws_ms[:, 0], 8.0, atol=0.26)
    flipped = correct_dbs_motion("windcube_v2", t, az, -wide.to_numpy(), **kw)
    np.testing.assert_allclose(flipped.wd_deg[:, 0], 90.0, atol=1.0)


def _edit(tmp: Path, line: int, old: str, new: str) -> Path:
    """The .rtd with ``old`` replaced by ``new`` on file line ``line`` (1-based)."""
    lines = _lines(RTD)
    assert old in lines[line - 1]
    lines[line - 1] = lines[line - 1].replace(old, new, 1)
    return _write(tmp, "wc.rtd", lines)


BAD = {
    "text_speed": (
        lambda t: _edit(t, 20, "\t0.04\t0.33", "\tn/a\t0.33"),
        r"wc\.rtd: row 3 \(line 20\), column '80m Radial Wind Speed \(m/s\)': .*'n/a'",
    ),
    "position": (
        lambda t: _edit(t, 21, "\t270\t", "\tW\t"),
        r"wc\.rtd: row 4 \(line 21\), column 'Position': cannot read 'W' as a beam azimuth",
    ),
    "speed_bound": (
        lambda t: _edit(t, 25, "\t-0.06\t0.35", "\t-95.00\t0.35"),
        r"wc\.rtd: row 8 \(line 25\), column '120m Radial Wind Speed \(m/s\)': .*-?95",
    ),
    "time_back": (
        lambda t: _edit(t, 23, "01:00:05.48", "01:00:03.00"),
        r"wc\.rtd: row 6 \(line 23\), column 'Timestamp': ",
    ),
    "stamp": (
        lambda t: _edit(t, 19, "2023/01/15 01:00:01.47", "15.01.2023 01:00:01"),
        r"wc\.rtd: row 2 \(line 19\), column 'Timestamp': cannot read '15\.01\.2023 01:00:01'",
    ),
    "fields": (
        lambda t: _edit(t, 19, "\t-14.30\t", "\t"),
        r"wc\.rtd: row 2 \(line 19\), column .*: 30 tab-separated fields where the column "
        r"line has 31$",  # no hint of spaces: the stamp's space is no separator
    ),
    "no_scan_angle": (
        lambda t: _edit(t, 12, "ScanAngle (°)=28.000", "Comments=none"),
        r"wc\.rtd: line \d+, column 'ScanAngle \(°\)': missing from the header",
    ),
}


@pytest.mark.parametrize("case", sorted(BAD))
def test_bad_rtd_is_one_error_naming_file_row_and_column(case, tmp_path):
    build, pattern = BAD[case]
    with pytest.raises(io.DataValidationError) as info:
        read_los_file(build(tmp_path))
    assert len(str(info.value).splitlines()) == 1
    assert re.search(pattern, str(info.value)), str(info.value)


def _imu_csv(path: Path, start: str, seconds: float) -> Path:
    """A level buoy's IMU series at 5 Hz from ``start`` (UTC) for ``seconds``."""
    t = pd.Timestamp(start) + pd.to_timedelta(np.arange(0.0, seconds, 0.2), unit="s")
    imu = pd.DataFrame({"timestamp": t, "roll_deg": 1.0, "pitch_deg": -1.0, "yaw_deg": 0.0})
    io.write_imu_series(imu, path)
    return path


def test_validate_reads_a_rtd_beside_its_imu_series(tmp_path, capsys):
    imu = _imu_csv(tmp_path / "imu.csv", "2023-01-14T23:59:50Z", 30.0)
    records = DATA.parent / "hand_written_campaign.csv"
    argv = ["validate", "--json", str(records), "--imu-series", str(imu), "--los-series", str(RTD)]
    assert main(argv) == EXIT_OK
    got = json.loads(capsys.readouterr().out)["los_series"]
    assert got["format"] == "windcube_rtd" and got["n_measurements"] == 30
    assert got["share_with_imu"] == 1.0
    bad = _edit(tmp_path, 21, "\t270\t", "\tW\t")
    assert (
        main(["validate", str(records), "--imu-series", str(imu), "--los-series", str(bad)])
        == EXIT_DATA
    )
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "column 'Position'" in err[0]


def test_series_span_of_a_rtd_and_its_utc_offset(tmp_path):
    assert series_span(RTD, what="los") == (
        pd.Timestamp("2023-01-15T00:00:00.48Z"), pd.Timestamp("2023-01-15T00:00:09.49Z")
    )  # fmt: skip
    no_zone = _edit(tmp_path, 8, "timezone=UTC+1", "Comments=none")
    first, _ = series_span(no_zone, what="los", utc_offset_h=-2.0)  # local = UTC - 2 h
    assert first == pd.Timestamp("2023-01-15T03:00:00.48Z")
    with pytest.raises(io.DataValidationError, match=r"inconsistent UTC offsets"):
        read_los_file(RTD, utc_offset_h=0.0)


def test_preflight_checks_a_rtd_against_its_imu_series(tmp_path):
    """The check before any job (flidar_uq.workflow.inputs.check_series): the .rtd's span in
    UTC against the IMU series'."""
    imu = _imu_csv(tmp_path / "imu.csv", "2023-01-14T23:59:50Z", 30.0)
    check_series({"imu_series": str(imu), "los_series": str(RTD), "utc_offset_h": None})
    late = _imu_csv(tmp_path / "late.csv", "2023-01-15T00:00:30Z", 30.0)
    with pytest.raises(io.DataValidationError, match=r"windcube_v2\.rtd: .*do not overlap"):
        check_series({"imu_series": str(late), "los_series": str(RTD), "utc_offset_h": None})


def _as_rtd(los: pd.DataFrame, path: Path, *, utc_offset_h: float) -> Path:
    """A LOS series of a WindCube v2 written the way the WindCube writes its .rtd: local
    stamps, ``Position`` (``V`` for the vertical beam), radial speeds positive towards the
    lidar, a block of columns per height."""
    gates = sorted(los["height_m"].unique())
    wide = los.pivot(index="timestamp", columns="height_m")
    first = los.groupby("timestamp").first()
    local = wide.index.tz_convert(None) + pd.Timedelta(hours=utc_offset_h)
    head = ["HeaderSize=4", "ID System=WLS7-TEST", f"timezone=UTC{utc_offset_h:+g}"]
    head += ["ScanAngle (°)=28.000", "Altitudes (m)=\t" + "\t".join(f"{h:g}" for h in gates)]
    cols = ["Timestamp", "Position", "Temperature", "Wiper Count"]
    for h in gates:
        cols += [f"{h:g}m CNR (dB)", f"{h:g}m Radial Wind Speed (m/s)", ""]
    lines = head + ["\t".join(cols)]
    for k, stamp in enumerate(local):
        vertical = first["elevation_deg"].iloc[k] == 90.0
        row = [
            stamp.strftime("%Y/%m/%d %H:%M:%S.%f"),
            "V" if vertical else f"{first['azimuth_deg'].iloc[k]:g}",
        ]
        row += ["8.40", "0"]
        for h in gates:
            row += [
                repr(float(wide[("cnr_db", h)].iloc[k])),
                repr(-float(wide[("radial_speed_ms", h)].iloc[k])),
                "",
            ]
        lines.append("\t".join(row))
    path.write_bytes("\n".join(lines).encode("latin-1"))
    return path


def test_los_step_reads_a_rtd_as_it_reads_the_table(tmp_path):
    """The virtual WindCube v2's LOS series written as a .rtd (local time UTC+2) and as the
    documented table give the LOS step the same corrected TI, record by record."""
    sc = load_scenario("dbs_tilt_only")
    sc["n_records"] = 2
    out = generate_campaign(sc, 3, return_imu=True, return_los=True, n_workers=1)
    records = io.write_records(out.records, tmp_path / "records.csv")
    imu = io.write_imu_series(out.imu, tmp_path / "imu.parquet")
    table = io.write_los_series(out.los, tmp_path / "los.parquet")
    rtd = _as_rtd(out.los, tmp_path / "los.rtd", utc_offset_h=2.0)
    kw = dict(records_path=records, imu_path=imu, lidar="windcube_v2", lever_arm_m=(0, 0, 2.0))
    a = los_correction(los_path=table, out_path=tmp_path / "a.csv", **kw)
    b = los_correction(los_path=rtd, out_path=tmp_path / "b.csv", chunk_rows=1000, **kw)
    assert a["ti_los_dbs_new"].notna().sum() == 2  # the 80-m gate of both records
    pd.testing.assert_frame_equal(a, b)
