"""End-to-end: a campaign in its instruments' files through the pipeline, no column map.

The hand-written campaign (tests/data/hand_written_campaign.csv) is written as each
instrument writes it (WindCube v2 .sta, ZephIR CSV, IEA Task 43), with the buoy's logger
(local time, end-of-interval stamps, attitude std) and a mast file as the other two files;
the pipeline must give the records of the hand-written table, with the join reported.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
import yaml

from flidar_uq.data.io import read_records

REPO = Path(__file__).resolve().parents[1]
SNAKEMAKE = str(Path(sys.executable).with_name("snakemake"))
HAND = REPO / "tests" / "data" / "hand_written_campaign.csv"


def _records() -> pd.DataFrame:
    return read_records(HAND)


def _wide(rec: pd.DataFrame):
    """(interval starts, heights, {height: that height's rows})."""
    t = pd.DatetimeIndex(rec["timestamp"].unique())
    heights = sorted(rec["height_m"].unique())
    by = {h: rec[rec["height_m"] == h].set_index("timestamp").reindex(t) for h in heights}
    return t, heights, by


def _num(x: float, comma: bool = False) -> str:
    s = "NaN" if not np.isfinite(x) else f"{x:.6g}"
    return s.replace(".", ",") if comma else s


def write_sta(rec: pd.DataFrame, path: Path) -> None:
    t, heights, by = _wide(rec)
    header = [
        "Version=1.1.13",
        "ID System=WLS7-001",
        "timezone=UTC+0",
        "********************",
        "ScanAngle (°)=28.000",
        "Altitudes (m)=\t" + "\t".join(f"{h:g}" for h in heights),
        "********************",
    ]
    q = ["Wind Speed (m/s)", "Wind Speed Dispersion (m/s)", "Wind Direction (°)", "CNR (dB)",
         "Data Availability (%)"]  # fmt: skip
    cols = ["Timestamp (end of interval)", "Vbatt (V)"]
    for h in heights:
        cols += [f"{h:g}m {x}" for x in q] + [""]
    lines = [f"HeaderSize={len(header)}", *header, "\t".join(cols)]
    for k, start in enumerate(t):
        fields = [(start + pd.Timedelta(minutes=10)).strftime("%Y/%m/%d %H:%M"), "24.1"]
        for h in heights:
            r = by[h].iloc[k]
            fields += [_num(r.hws_mean_ms), _num(r.hws_std_ms), _num(r.wd_mean_deg), "-15.0",
                       _num(r.availability_pct), ""]  # fmt: skip
        lines.append("\t".join(fields))
    path.write_bytes(("\n".join(lines) + "\n").encode("latin-1"))


def write_zephir(rec: pd.DataFrame, path: Path) -> None:
    t, heights, by = _wide(rec)
    meta = ("Unit: 317;Time sync: UTC +1,0 hrs;Time stamps indicate the beginning of the "
            "averaging period;Measurement heights: " + " ".join(f"{h:g}m" for h in heights))  # fmt: skip
    cols = ["Time and Date", "ZephIR Bearing (deg)", "Tilt (deg)"]
    for h in heights:
        cols += [f"{x} at {h:g}m" for x in ("Packets in Average", "Wind Direction (deg)",
                 "Horizontal Wind Speed (m/s)", "Horizontal Wind Speed Std. Dev. (m/s)")]  # fmt: skip
    cols.append("Checksum:abc")
    lines = [meta, ";".join(cols)]
    for k, start in enumerate(t):
        fields = [(start + pd.Timedelta(hours=1)).strftime("%d.%m.%Y %H:%M:%S"), "311,0", "1"]
        for h in heights:
            r = by[h].iloc[k]
            fields += [_num(round(r.availability_pct / 2.5), True), _num(r.wd_mean_deg, True),
                       _num(r.hws_mean_ms, True), _num(r.hws_std_ms, True)]  # fmt: skip
        fields.append("x")
        lines.append(";".join(fields))
    path.write_text("\n".join(lines) + "\n")


def write_iea43(rec: pd.DataFrame, path: Path) -> None:
    t, heights, by = _wide(rec)
    points, cols = [], ["Timestamp"]
    for h in heights:
        names = [f"WS_{h:g}_avg", f"WS_{h:g}_sd", f"Avail_{h:g}", f"WD_{h:g}_avg"]
        cols += names
        points += [
            {"name": f"Spd_{h:g}", "measurement_type_id": "wind_speed", "height_m": h,
             "logger_measurement_config": [{"column_name": [
                 {"column_name": names[0], "statistic_type_id": "avg"},
                 {"column_name": names[1], "statistic_type_id": "sd"},
                 {"column_name": names[2], "statistic_type_id": "availability"}]}]},
            {"name": f"Dir_{h:g}", "measurement_type_id": "wind_direction", "height_m": h,
             "logger_measurement_config": [{"column_name": [
                 {"column_name": names[3], "statistic_type_id": "avg"}]}]},
        ]  # fmt: skip
    meta = {"measurement_location": [{"name": "FLS", "measurement_point": points,
            "logger_main_config": [{"logger_serial_number": "42", "offset_from_utc_hrs": 0,
                                    "averaging_period_minutes": 10,
                                    "timestamp_is_end_of_period": True}]}]}  # fmt: skip
    lines = [json.dumps(meta, indent=1), ",".join(cols)]
    for k, start in enumerate(t):
        fields = [(start + pd.Timedelta(minutes=10)).strftime("%Y-%m-%d %H:%M:%S")]
        for h in heights:
            r = by[h].iloc[k]
            fields += [_num(r.hws_mean_ms), _num(r.hws_std_ms), _num(r.availability_pct),
                       _num(r.wd_mean_deg)]  # fmt: skip
        lines.append(",".join(fields))
    path.write_text("\n".join(lines) + "\n")


def write_logger(rec: pd.DataFrame, path: Path) -> dict:
    """The buoy's logger: UTC+2, stamps at the interval end, attitude std, compass heading."""
    t, heights, by = _wide(rec)
    r = by[heights[0]]
    out = pd.DataFrame(
        {
            "Time": (t + pd.Timedelta(hours=2, minutes=10)).strftime("%Y-%m-%d %H:%M:%S"),
            "RollSD": r["roll_amplitude_deg"].to_numpy() / np.sqrt(2.0),
            "PitchSD": r["pitch_amplitude_deg"].to_numpy() / np.sqrt(2.0),
            "RollT": r["roll_period_s"].to_numpy(),
            "PitchT": r["pitch_period_s"].to_numpy(),
            "T2": r["period2_s"].to_numpy(),
            "W1": r["weight1"].to_numpy(),
            "Hs": 2.5,
            "Battery_V": 12.4,
        }
    )
    out.to_csv(path, index=False, float_format="%.17g")
    return {
        "path": str(path),
        "utc_offset_h": 2,
        "timestamp_at": "end",
        "columns": {"Time": "timestamp", "RollSD": "roll_std_deg", "PitchSD": "pitch_std_deg",
                    "RollT": "roll_period_s", "PitchT": "pitch_period_s", "T2": "period2_s",
                    "W1": "weight1", "Hs": "wave_hs_m"},
    }  # fmt: skip


def write_mast(rec: pd.DataFrame, path: Path) -> dict:
    t, heights, by = _wide(rec)
    out = pd.DataFrame({"Timestamp": t.strftime("%Y-%m-%dT%H:%M:%SZ")})
    for h in heights:
        out[f"Cup{h:g}_Avg"] = by[h]["ref_hws_mean_ms"].to_numpy()
        out[f"Cup{h:g}_Std"] = by[h]["ref_hws_std_ms"].to_numpy()
    out.iloc[:-1].to_csv(path, index=False)  # the mast misses the last interval
    return {
        "path": str(path),
        "columns": {"Timestamp": "timestamp", "Cup{height}_Avg": "ref_hws_mean_ms",
                    "Cup{height}_Std": "ref_hws_std_ms"},
    }  # fmt: skip


WRITERS = {"windcube_sta": (write_sta, "lidar.sta"), "zephir_csv": (write_zephir, "z.csv"),
           "iea43": (write_iea43, "iea.csv")}  # fmt: skip


@pytest.mark.slow
@pytest.mark.parametrize("fmt", sorted(WRITERS))
def test_three_file_campaign_runs_through_the_pipeline(fmt, tmp_path):
    import subprocess

    rec = _records()
    write, name = WRITERS[fmt]
    write(rec, tmp_path / name)
    cfg = yaml.safe_load((REPO / "tests" / "data" / "user_config.yaml").read_text())
    cfg["campaign"] = {
        "source": "files",
        "lidar_file": {"path": str(tmp_path / name)},
        "motion_file": write_logger(rec, tmp_path / "logger.csv"),
        "reference_file": write_mast(rec, tmp_path / "mast.csv"),
    }
    (tmp_path / "c.yaml").write_text(yaml.safe_dump(cfg))
    cmd = [SNAKEMAKE, "-s", str(REPO / "Snakefile"), "--directory", str(tmp_path),
           "--configfile", str(tmp_path / "c.yaml"), "--cores", "2"]  # fmt: skip
    proc = subprocess.run(cmd, capture_output=True, text=True, timeout=900, cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr[-4000:]
    res = tmp_path / "results"
    join = pd.read_csv(res / "campaign" / "join.csv").set_index("role")
    assert join.loc["lidar", "intervals"] == 15
    assert tuple(join.loc["motion", ["intervals", "matched", "unmatched_file"]]) == (15, 15, 0)
    assert tuple(join.loc["reference", ["matched", "unmatched_lidar"]]) == (14, 1)
    source = json.loads((res / "campaign" / "source.json").read_text())
    assert source["header_facts"]["format"] == fmt
    out = pd.read_csv(res / "ti" / "records.csv")
    assert len(out) == len(rec)
    np.testing.assert_allclose(out["hws_mean_ms"], rec["hws_mean_ms"], rtol=1e-12)
    np.testing.assert_allclose(
        out["ti_uncorrected"], rec["hws_std_ms"] / rec["hws_mean_ms"], rtol=1e-9
    )
    assert pd.to_datetime(out["timestamp"], utc=True).tolist() == rec["timestamp"].tolist()
    assert (out["Battery_V"] == 12.4).all() and (out["wave_hs_m"] == 2.5).all()
    data = read_records(res / "data" / "records.parquet", extra_columns="keep")
    np.testing.assert_allclose(data["roll_amplitude_deg"], rec["roll_amplitude_deg"], rtol=1e-12)
    assert data["ref_hws_mean_ms"].isna().sum() == 2  # the mast's missing interval, 2 heights
    assert out["ti_corrected_median"].notna().any()
    assert (res / "qc" / "speed_bins.csv").is_file()
