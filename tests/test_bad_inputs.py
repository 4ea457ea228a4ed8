"""Every class of bad input: one line on stderr naming the file, row and column or the config
key, and the exit status of its class (2 usage, 3 data; never 1, never a traceback), in
the command line and at the start of a pipeline run (flidar_uq.workflow.inputs)."""

from __future__ import annotations

import gzip
import io
import json
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
import yaml
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from flidar_uq.cli import main
from flidar_uq.workflow.inputs import EXIT_DATA, EXIT_OK, EXIT_USAGE, pipeline_preflight

REPO = Path(__file__).resolve().parents[1]


def valid_records(n_times: int = 12, seed: int = 3) -> pd.DataFrame:
    """A valid record table as a user writes it: two heights, 10-min records, a reference."""
    rng = np.random.default_rng(np.random.SeedSequence(seed))
    t = pd.date_range("2016-05-01T00:00:00Z", periods=n_times, freq="10min")
    n = 2 * n_times
    hws = rng.uniform(5, 14, n)
    return pd.DataFrame(
        {
            "timestamp": np.repeat(t.strftime("%Y-%m-%dT%H:%M:%SZ"), 2),
            "height_m": np.tile([80.0, 100.0], n_times),
            "hws_mean_ms": hws.round(2),
            "hws_std_ms": (hws * rng.uniform(0.05, 0.1, n)).round(3),
            "wd_mean_deg": rng.uniform(180, 300, n).round(1),
            "availability_pct": rng.uniform(90, 100, n).round(1),
            "roll_amplitude_deg": rng.uniform(1, 4, n).round(2),
            "pitch_amplitude_deg": rng.uniform(1, 4, n).round(2),
            "roll_period_s": rng.uniform(3, 6, n).round(2),
            "pitch_period_s": rng.uniform(3, 6, n).round(2),
            "ref_hws_mean_ms": (hws * 0.98).round(2),
            "ref_hws_std_ms": (hws * rng.uniform(0.04, 0.08, n)).round(3),
        }
    )


def write(tmp: Path, df: pd.DataFrame, name: str = "campaign.csv") -> Path:
    path = tmp / name
    if name.endswith(".parquet"):
        df.to_parquet(path, index=False)
    else:
        df.to_csv(path, index=False)
    return path


def write_text(tmp: Path, text: str | bytes, name: str = "campaign.csv") -> Path:
    path = tmp / name
    if isinstance(text, bytes):
        path.write_bytes(text)
    else:
        path.write_text(text)
    return path


def write_config(tmp: Path, cfg: dict | str, name: str = "my_config.yaml") -> Path:
    path = tmp / name
    path.write_text(cfg if isinstance(cfg, str) else yaml.safe_dump(cfg))
    return path


def imu_series(tmp: Path, fs_hz: float = 5.0, start: str = "2016-05-01T00:00:00Z", **over):
    t = pd.date_range(start, periods=int(120 * fs_hz), freq=pd.Timedelta(seconds=1 / fs_hz))
    w = 2 * np.pi * np.arange(len(t)) / fs_hz / 4.0
    df = pd.DataFrame(
        {
            "timestamp": t.strftime("%Y-%m-%dT%H:%M:%S.%fZ"),
            "roll_deg": 3 * np.sin(w),
            "pitch_deg": 2 * np.cos(w),
        }
    )
    for k, v in over.items():
        df[k] = v(df) if callable(v) else v
    return write(tmp, df, "imu.csv")


def los_series(tmp: Path, start: str = "2016-05-01T00:00:10Z", **over):
    t = pd.date_range(start, periods=50, freq=pd.Timedelta(seconds=0.02))
    df = pd.DataFrame(
        {
            "timestamp": t.strftime("%Y-%m-%dT%H:%M:%S.%fZ"),
            "height_m": 80.0,
            "azimuth_deg": np.linspace(0, 352.8, 50),
            "radial_speed_ms": 5.0,
            "cnr_db": -10.0,
        }
    )
    for k, v in over.items():
        df[k] = v
    return write(tmp, df, "los.csv")


# --------------------------------------------------------------------------- cases
# Each case builds its inputs in a temporary directory and returns the command line;
# expected: exit status and a regex the single stderr line must match (file, row and
# column, or config key).


def _modified(**changes):
    def build(tmp):
        df = valid_records()
        for col, fn in changes.items():
            df = fn(df, col)
        return ["validate", str(write(tmp, df))]

    return build


def _set(rows, value):
    def fn(df, col):
        df = df.astype({col: object}) if isinstance(value, str) else df
        df.loc[rows, col] = value
        return df

    return fn


def _scale(factor):
    def fn(df, col):
        df[col] = df[col] * factor
        return df

    return fn


def _text(build_text, name="campaign.csv"):
    def build(tmp):
        return ["validate", str(write_text(tmp, build_text(valid_records()), name))]

    return build


def _csv(df):
    return df.to_csv(index=False)


def _with_config(cfg, records=None, path_arg=True):
    def build(tmp):
        df = valid_records() if records is None else records(valid_records())
        path = write(tmp, df)
        c = cfg(path) if callable(cfg) else cfg
        argv = ["validate", "--config", str(write_config(tmp, c))]
        return argv + ([str(path)] if path_arg else [])

    return build


def _wide(df):
    """The records as a logger writes them: one row per time, one column per height."""
    wide = df[df["height_m"] == 80.0][["timestamp", "wd_mean_deg"]].reset_index(drop=True)
    for h in (80, 100):
        part = df[df["height_m"] == float(h)].reset_index(drop=True)
        wide[f"Spd{h}mN"] = part["hws_mean_ms"]
        wide[f"Std{h}mN"] = part["hws_std_ms"]
        wide[f"Avail{h}m"] = part["availability_pct"]
    part = df[df["height_m"] == 80.0].reset_index(drop=True)
    for c in ("roll_amplitude_deg", "pitch_amplitude_deg", "roll_period_s", "pitch_period_s"):
        wide[c] = part[c]
    wide["CupMean"] = part["ref_hws_mean_ms"]
    wide["CupStd"] = part["ref_hws_std_ms"]
    return wide


WIDE_MAP = {
    "Spd{height}mN": "hws_mean_ms",
    "Std{height}mN": "hws_std_ms",
    "Avail{height}m": "availability_pct",
    "CupMean": "ref_hws_mean_ms",
    "CupStd": "ref_hws_std_ms",
}


def _semicolon(df):
    return _csv(df).replace(",", ";").replace(".", ",")


def _unquoted_decimal_comma(df):
    lines = _csv(df).splitlines()
    lines[2] = lines[2].replace(".", ",")  # data row 2: every number with a decimal comma
    return "\n".join(lines) + "\n"


def _quoted_decimal_comma(df):
    df = df.astype({"hws_std_ms": object})
    df.loc[4, "hws_std_ms"] = "0,61"
    return df.to_csv(index=False)


def _ragged(df):
    lines = _csv(df).splitlines()
    lines[5] = ",".join(lines[5].split(",")[:7])  # data row 5 cut after 7 fields
    return "\n".join(lines) + "\n"


def _blank_line(df):
    lines = _csv(df).splitlines()
    lines.insert(6, "")
    return "\n".join(lines) + "\n"


def _latin1(df):
    text = _csv(df).replace("hws_std_ms", "hws_std_ms")
    lines = text.encode().splitlines()
    lines[3] = lines[3] + b"\xb0"  # a degree sign in Latin-1 at the end of line 4
    return b"\n".join(lines) + b"\n"


def _nul(df):
    data = _csv(df).encode()
    i = data.index(b"\n", data.index(b"\n") + 1)  # end of line 2
    return data[: i + 5] + b"\x00\x00" + data[i + 5 :]


def _gz_garbage(df):
    return b"\x1f\x8b\x08\x00garbage that is not deflate data" * 3


def _duplicated_column(df):
    return _csv(df).replace("sv,", "").replace("ref_hws_std_ms", "hws_std_ms", 1)


def _tz_mix(df):
    df = df.copy()
    df.loc[6:, "timestamp"] = (
        pd.to_datetime(df.loc[6:, "timestamp"])
        .dt.tz_convert("Europe/Berlin")
        .dt.strftime("%Y-%m-%dT%H:%M:%S%z")
    )
    return df


FILE = "campaign\\.csv"

CASES = {
    # ---- files: missing, unreadable, malformed (exit 3)
    "missing_file": (
        lambda tmp: ["validate", str(tmp / "nope.csv")],
        EXIT_DATA,
        r"nope\.csv: no such file$",
    ),
    "directory": (
        lambda tmp: ["validate", str((tmp / "dir.csv").mkdir() or tmp / "dir.csv")],
        EXIT_DATA,
        r"dir\.csv: is a directory, not a file",
    ),
    "spreadsheet": (
        lambda tmp: ["validate", str(write_text(tmp, b"PK\x03\x04", "c.xlsx"))],
        EXIT_DATA,
        r"c\.xlsx: unknown file type \(export the sheet as CSV\)",
    ),
    "empty_file": (_text(lambda df: ""), EXIT_DATA, rf"{FILE}: the file is empty"),
    "header_only": (
        _text(lambda df: _csv(df.iloc[:0])),
        EXIT_DATA,
        rf"{FILE}: header: the table has no data rows",
    ),
    "semicolons_and_decimal_commas": (
        _text(_semicolon),
        EXIT_DATA,
        rf"{FILE}: header: the fields are separated by semicolons, expected commas \(and the "
        r"numbers use decimal commas",
    ),
    "tabs": (
        _text(lambda df: df.to_csv(index=False, sep="\t")),
        EXIT_DATA,
        rf"{FILE}: header: the fields are separated by tabs",
    ),
    "decimal_comma_unquoted": (
        _text(_unquoted_decimal_comma),
        EXIT_DATA,
        rf"{FILE}: row 2 \(line 3\): \d+ fields where the header has 12 \(decimal commas\?",
    ),
    "decimal_comma_quoted": (
        _text(_quoted_decimal_comma),
        EXIT_DATA,
        rf"{FILE}: row 5 \(line 6\), column 'hws_std_ms': cannot parse '0,61' as a number "
        r"\(a decimal comma\?",
    ),
    "ragged_row": (
        _text(_ragged),
        EXIT_DATA,
        rf"{FILE}: row 5 \(line 6\): 7 fields where the header has 12$",
    ),
    "blank_line_inside": (
        _text(_blank_line),
        EXIT_DATA,
        rf"{FILE}: row 6 \(line 7\): empty line inside the table",
    ),
    "not_utf8": (
        _text(_latin1),
        EXIT_DATA,
        rf"{FILE}: row 3 \(line 4\): not UTF-8 text \(byte 0xb0 at line 4\)",
    ),
    "nul_bytes": (_text(_nul), EXIT_DATA, rf"{FILE}: row 2 \(line 3\): NUL byte"),
    "corrupt_gzip": (
        _text(_gz_garbage, "campaign.csv.gz"),
        EXIT_DATA,
        r"campaign\.csv\.gz: cannot read the file",
    ),
    "corrupt_parquet": (
        _text(lambda df: b"PAR1 not really parquet", "campaign.parquet"),
        EXIT_DATA,
        r"campaign\.parquet: not a readable Parquet file",
    ),
    "missing_required_column": (
        _text(lambda df: _csv(df.drop(columns="availability_pct"))),
        EXIT_DATA,
        rf"{FILE}: header, column 'availability_pct': required column missing",
    ),
    "unknown_column": (
        _text(lambda df: _csv(df.rename(columns={"wd_mean_deg": "WindDir"}))),
        EXIT_DATA,
        rf"{FILE}: header, column 'wd_mean_deg': required column missing",
    ),
    "extra_unknown_column": (  # the default campaign.extra_columns: keep carries it
        _with_config(
            {"campaign": {"extra_columns": "error"}}, records=lambda df: df.assign(Battery_V=12.1)
        ),
        EXIT_DATA,
        r"campaign\.csv: header, column 'Battery_V': unknown column",
    ),
    "duplicated_column": (
        _text(_duplicated_column),
        EXIT_DATA,
        rf"{FILE}: header, column 'hws_std_ms': duplicated column name",
    ),
    "text_in_number": (
        _modified(sv=lambda df, c: _set(3, "~0.01")(df.assign(sv=0.01), c)),
        EXIT_DATA,
        rf"{FILE}: row 4 \(line 5\), column 'sv': cannot parse '~0.01' as a number",
    ),
    "negative_std": (
        _modified(hws_std_ms=_set(7, -0.3)),
        EXIT_DATA,
        rf"{FILE}: row 8 \(line 9\), column 'hws_std_ms': negative standard deviation",
    ),
    # ---- wrong units (exit 3)
    "speed_in_kmh": (
        _modified(hws_mean_ms=_scale(3.6), hws_std_ms=_scale(3.6)),
        EXIT_DATA,
        rf"{FILE}: all rows, column 'hws_mean_ms': median .* above 25 m/s.*km/h",
    ),
    "ti_instead_of_std": (
        _modified(hws_std_ms=lambda df, c: df.assign(hws_std_ms=df[c] / df["hws_mean_ms"])),
        EXIT_DATA,
        rf"{FILE}: all rows, column 'hws_std_ms': median hws_std_ms / hws_mean_ms is .* looks "
        r"like the turbulence intensity \(std / mean\)",
    ),
    "ti_percent_instead_of_std": (
        _modified(
            ref_hws_std_ms=lambda df, c: df.assign(
                ref_hws_std_ms=100 * df[c] / df["ref_hws_mean_ms"]
            )
        ),
        EXIT_DATA,
        rf"{FILE}: all rows, column 'ref_hws_std_ms': .*turbulence intensity in %",
    ),
    "amplitudes_in_radians": (
        _modified(roll_amplitude_deg=_scale(np.pi / 180), pitch_amplitude_deg=_scale(np.pi / 180)),
        EXIT_DATA,
        rf"{FILE}: row \d+ \(line \d+\), column '\w+_amplitude_deg': .*look like radians.*"
        r"campaign\.allow_small_angles",
    ),
    "direction_in_radians": (
        _modified(wd_mean_deg=_scale(np.pi / 180)),
        EXIT_DATA,
        rf"{FILE}: row \d+ \(line \d+\), column 'wd_mean_deg': .*look like radians",
    ),
    # ---- timestamps (exit 3)
    "duplicated_timestamp": (
        _modified(timestamp=lambda df, c: _set(4, df.loc[2, c])(df, c)),
        EXIT_DATA,
        rf"{FILE}: row 5 \(line 6\), column 'timestamp': duplicated timestamp .* at "
        r"height_m=80 \(first seen in row 3\)",
    ),
    "reversed_timestamps": (
        _modified(timestamp=lambda df, c: df.assign(timestamp=df[c].to_numpy()[::-1])),
        EXIT_DATA,
        rf"{FILE}: row 3 \(line 4\), column 'timestamp': timestamps not increasing",
    ),
    "mixed_time_zones": (
        _modified(timestamp=lambda df, c: _tz_mix(df)),
        EXIT_DATA,
        rf"{FILE}: row 7 \(line 8\), column 'timestamp': mixed time zones: .*\+0200' has "
        r"UTC\+02:00, row 1 has UTC",
    ),
    "epoch_seconds": (
        _modified(timestamp=lambda df, c: df.assign(timestamp=np.arange(len(df)) * 300.0)),
        EXIT_DATA,
        rf"{FILE}: row 1 \(line 2\), column 'timestamp': number 0\.0 is not an ISO 8601",
    ),
    # ---- IMU and LOS series
    "imu_wrong_rate": (
        lambda tmp: [
            "validate",
            str(write(tmp, valid_records())),
            "--imu-series",
            str(imu_series(tmp, fs_hz=1.0)),
        ],
        EXIT_DATA,
        r"imu\.csv: all rows, column 'timestamp': median sampling rate 1 Hz outside the "
        r"supported 4\.75-21 Hz",
    ),
    "imu_in_radians": (
        lambda tmp: [
            "validate",
            str(write(tmp, valid_records())),
            "--imu-series",
            str(
                imu_series(
                    tmp,
                    roll_deg=lambda d: d["roll_deg"] / 57.3,
                    pitch_deg=lambda d: d["pitch_deg"] / 57.3,
                )
            ),
        ],
        EXIT_DATA,
        r"imu\.csv: row \d+ \(line \d+\), column '(roll|pitch)_deg': .*look like radians",
    ),
    "los_without_imu": (
        lambda tmp: [
            "validate",
            str(write(tmp, valid_records())),
            "--los-series",
            str(los_series(tmp)),
        ],
        EXIT_USAGE,
        r"argument --los-series: a LOS file needs its IMU series \(--imu-series\)",
    ),
    "los_not_matching_imu": (
        lambda tmp: [
            "validate",
            str(write(tmp, valid_records())),
            "--imu-series",
            str(imu_series(tmp)),
            "--los-series",
            str(los_series(tmp, start="2016-06-01T00:00:00Z")),
        ],
        EXIT_DATA,
        r"los\.csv: row 1, column 'timestamp': no LOS measurement has an IMU sample of .*imu\.csv "
        r"within 1 s",
    ),
    "los_bad_azimuth": (
        lambda tmp: [
            "validate",
            str(write(tmp, valid_records())),
            "--imu-series",
            str(imu_series(tmp)),
            "--los-series",
            str(los_series(tmp, azimuth_deg=400.0)),
        ],
        EXIT_DATA,
        r"los\.csv: row 1 \(line 2\), column 'azimuth_deg': direction 400 deg outside 0-360",
    ),
    # ---- config (exit 2) and the column map
    "config_unknown_key": (
        _with_config({"qc": {"sv_maxx": 0.1}}),
        EXIT_USAGE,
        r"config key qc\.sv_maxx: unknown key \(did you mean qc\.sv_max\?\)$",
    ),
    "config_unknown_section": (
        _with_config({"sampler": {"nsteps": 10}}),
        EXIT_USAGE,
        r"config key sampler: unknown key \(known keys: ",
    ),
    "config_out_of_range": (
        _with_config({"propagation": {"credible_mass": 1.5}}),
        EXIT_USAGE,
        r"config key propagation\.credible_mass: 1\.5 is greater than or equal to the maximum",
    ),
    "config_wrong_type": (
        _with_config({"inference": {"nsteps": "many"}}),
        EXIT_USAGE,
        r"config key inference\.nsteps: 'many' is not of type 'integer'$",
    ),
    "config_files_without_records": (
        _with_config({"campaign": {"source": "files"}}, path_arg=False),
        EXIT_USAGE,
        r"config key campaign\.records: missing, but campaign\.source is 'files'",
    ),
    "config_inconsistent_thresholds": (
        _with_config({"qc": {"ti_hws_min_ms": 15.0, "ti_hws_max_ms": 10.0}}),
        EXIT_USAGE,
        r"config key qc\.ti_hws_min_ms: needs 0 <= ti_hws_min_ms < ti_hws_max_ms",
    ),
    "config_unknown_scenario": (
        _with_config({"campaign": {"scenario": "atlantis"}}),
        EXIT_USAGE,
        r"config key campaign\.scenario: no shipped scenario 'atlantis'",
    ),
    "config_not_yaml": (
        _with_config("campaign: [source: files\n"),
        EXIT_USAGE,
        r"config key .*my_config\.yaml: not valid YAML \(line \d+\)",
    ),
    "config_file_missing": (
        lambda tmp: [
            "validate",
            "--config",
            str(tmp / "nope.yaml"),
            str(write(tmp, valid_records())),
        ],
        EXIT_USAGE,
        r"config key .*nope\.yaml: no such config file",
    ),
    "column_map_unknown_target": (
        _with_config({"campaign": {"columns": {"WindDir": "wind_direction"}}}),
        EXIT_USAGE,
        r"config key campaign\.columns: 'WindDir' -> 'wind_direction': not a record column",
    ),
    "column_map_two_names_one_target": (
        _with_config({"campaign": {"columns": {"A": "hws_mean_ms", "B": "hws_mean_ms"}}}),
        EXIT_USAGE,
        r"config key campaign\.columns: 'A' and 'B' both map to 'hws_mean_ms'",
    ),
    "column_map_name_not_in_file": (
        _with_config({"campaign": {"columns": {"WindDir": "wd_mean_deg"}}}),
        EXIT_DATA,
        rf"{FILE}: header, column 'WindDir': in the column map \(-> 'wd_mean_deg'\) but not in "
        "the file",
    ),
    "column_map_wide_missing_height_column": (
        _with_config(
            {"campaign": {"columns": WIDE_MAP}},
            records=lambda df: _wide(df).drop(columns="Std100mN"),
        ),
        EXIT_DATA,
        rf"{FILE}: header, column 'Std100mN' \(mapped to 'hws_std_ms'\): required column missing",
    ),
    "column_map_wide_bad_value": (
        _with_config(
            {"campaign": {"columns": WIDE_MAP}},
            records=lambda df: _wide(df).assign(
                Spd100mN=lambda w: w["Spd100mN"].where(w.index != 4, 95.0)
            ),
        ),
        EXIT_DATA,
        rf"{FILE}: row 5 \(line 6\), column 'Spd100mN' \(mapped to 'hws_mean_ms'\): wind "
        r"speed 95 m/s above 80 m/s",
    ),
    "heights_not_in_file": (
        _with_config({"campaign": {"heights": [80, 120]}}),
        EXIT_USAGE,
        r"config key campaign\.heights: 120 m is not a height of .*campaign\.csv \(its "
        r"heights: 80, 100 m\)",
    ),
    "calm_site_without_allow_small_angles": (
        _with_config(
            {"campaign": {}},
            records=lambda df: df.assign(
                roll_amplitude_deg=df["roll_amplitude_deg"] / 30,
                pitch_amplitude_deg=df["pitch_amplitude_deg"] / 30,
            ),
        ),
        EXIT_DATA,
        r"look like radians, expected degrees \(if the motion really is that small, allow it: "
        r"config key campaign\.allow_small_angles",
    ),
    # ---- usage
    "validate_without_table": (
        lambda tmp: ["validate"],
        EXIT_USAGE,
        r"flidar-uq validate: error: argument path: give the record table",
    ),
}


@pytest.mark.parametrize("case", sorted(CASES))
def test_bad_input_one_line_and_exit_status(case, tmp_path, capsys):
    build, code, pattern = CASES[case]
    argv = build(tmp_path)
    assert main(argv) == code, capsys.readouterr().err
    out, err = capsys.readouterr()
    assert out == ""
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    assert "Traceback" not in err and "internal error" not in err
    assert re.search(pattern, lines[0]), lines[0]


def test_there_are_at_least_25_cases_of_files_series_and_config():
    data = [c for c, (_, code, _) in CASES.items() if code == EXIT_DATA]
    usage = [c for c, (_, code, _) in CASES.items() if code == EXIT_USAGE]
    assert len(CASES) >= 25 and len(data) >= 15 and len(usage) >= 8
    assert sum(c.startswith(("imu", "los")) for c in CASES) >= 4


# --------------------------------------------------------------------------- warnings (exit 0)


def test_reference_mean_without_std_warns_in_validate_and_stops_the_pipeline(tmp_path, capsys):
    path = write(tmp_path, valid_records().drop(columns="ref_hws_std_ms"))
    assert main(["validate", "--json", str(path)]) == EXIT_OK
    out, err = capsys.readouterr()
    report = json.loads(out)
    assert report["reference"] == {"share_with_mean": 1.0, "share_with_std": 0.0}
    assert (
        "column 'ref_hws_std_ms': the reference mean ref_hws_mean_ms is given but its std " in err
    )
    assert "rho at its prior" in err and "(the pipeline stops on this)" in err
    stream = io.StringIO()
    config = {"campaign": {"source": "files", "records": str(path)}}
    assert pipeline_preflight(config, stream=stream) == EXIT_DATA
    line = stream.getvalue().strip()
    assert len(line.splitlines()) == 1 and "campaign.csv: all rows, column 'ref_hws_std_ms'" in line
    # dropping the mean with the column map is the documented way out
    config = {
        "campaign": {
            "source": "files",
            "records": str(path),
            "columns": {"ref_hws_mean_ms": None},
        }
    }
    stream = io.StringIO()
    assert pipeline_preflight(config, stream=stream) == EXIT_OK
    assert stream.getvalue() == ""


def test_validate_warns_about_groups_that_will_stay_uncorrected(tmp_path, capsys):
    df = valid_records()
    at100 = df["height_m"] == 100.0
    df.loc[at100, "availability_pct"] = 20.0  # every record at 100 m fails low_availability
    cfg = write_config(tmp_path, {"qc": {"imu_gap": False}})
    df.loc[[0, 2], ["roll_period_s", "pitch_period_s"]] = np.nan  # no motion description
    assert main(["validate", "--json", "--config", str(cfg), str(write(tmp_path, df))]) == EXIT_OK
    out, err = capsys.readouterr()
    report = json.loads(out)
    assert report["qc_preview"]["by_filter"]["low_availability"] == int(at100.sum())
    assert "QC keeps no record at 100 m (most frequent reason: low_availability)" in err
    assert "2 of 12 QC-kept records have neither" in err and "no_motion_description" in err
    assert report["motion_description"]["none"] == 2


def test_validate_names_the_rows_whose_std_holds_ti_in_percent(tmp_path, capsys):
    """10 of the hand-written campaign's 30 rows with TI in percent in the std column:
    validate counts them under the QC flag std_pattern and names the first rows."""
    from test_qc import PERCENT_ROWS, ti_percent_in_std

    from flidar_uq.data.io import read_records

    rec = read_records(Path(__file__).parent / "data" / "hand_written_campaign.csv")
    path = tmp_path / "percent.csv"
    ti_percent_in_std(rec).to_csv(path, index=False)
    assert main(["validate", "--json", str(path)]) == EXIT_OK
    out, err = capsys.readouterr()
    assert json.loads(out)["qc_preview"]["by_filter"]["std_pattern"] == 10
    first = ", ".join(str(r) for r in PERCENT_ROWS[:5])
    assert f"10 record(s) (rows {first}, ...) have hws_std_ms / hws_mean_ms far" in err
    assert (
        main(
            [
                "validate",
                "--json",
                str(Path(__file__).parent / "data" / "hand_written_campaign.csv"),
            ]
        )
        == 0
    )
    assert "std_pattern" not in capsys.readouterr().err


def test_calm_site_passes_with_allow_small_angles(tmp_path, capsys):
    df = valid_records()
    for c in ("roll_amplitude_deg", "pitch_amplitude_deg"):
        df[c] = df[c] / 30.0  # 0.03-0.13 deg
    path = write(tmp_path, df)
    assert main(["validate", str(path)]) == EXIT_DATA
    capsys.readouterr()
    cfg = write_config(tmp_path, {"campaign": {"allow_small_angles": True}})
    assert main(["validate", "--config", str(cfg), str(path)]) == EXIT_OK
    assert main(["validate", "--allow-small-angles", str(path)]) == EXIT_OK


# --------------------------------------------------------------------------- pipeline start


@pytest.mark.parametrize(
    ("config", "records", "code", "pattern"),
    [
        ({"campaign": {"source": "files"}}, None, EXIT_USAGE, r"config key campaign\.records"),
        ({"qc": {"sv_maxx": 1}}, None, EXIT_USAGE, r"config key qc\.sv_maxx: unknown key"),
        ({"campaign": {"source": "files", "records": "nope.csv"}}, None, EXIT_DATA, "no such file"),
        ({}, _semicolon, EXIT_DATA, "separated by semicolons"),
        ({}, lambda df: _csv(df.assign(hws_mean_ms=df["hws_mean_ms"] * 3.6)), EXIT_DATA, "km/h"),
        ({"campaign": {"heights": [60]}}, _csv, EXIT_USAGE, r"config key campaign\.heights"),
    ],
)
def test_pipeline_preflight_one_line_and_exit_status(tmp_path, config, records, code, pattern):
    config = yaml.safe_load(yaml.safe_dump(config))
    if records is not None:
        path = write_text(tmp_path, records(valid_records()))
        config.setdefault("campaign", {}).update(source="files", records=str(path))
    stream = io.StringIO()
    assert pipeline_preflight(config, stream=stream) == code
    lines = stream.getvalue().strip().splitlines()
    assert len(lines) == 1 and re.search(pattern, lines[0]), lines


@pytest.mark.parametrize(
    ("imu", "los", "code", "pattern"),
    [
        ({}, {}, EXIT_OK, None),
        ({"fs_hz": 1.0}, None, EXIT_DATA, r"imu\.csv: .*median sampling rate 1 Hz outside"),
        (
            {},
            {"start": "2016-06-01T00:00:00Z"},
            EXIT_DATA,
            r"los\.csv: row 1 \(line 2\), column 'timestamp': the LOS series \(2016-06-01.*do "
            r"not overlap: the IMU series of this LOS file is missing",
        ),
        ({}, {"azimuth_deg": 400.0}, EXIT_DATA, r"los\.csv: row 1 .*'azimuth_deg': direction 400"),
        (
            {"roll_deg": lambda d: d["roll_deg"].map(lambda x: f"{x:.3f}".replace(".", ","))},
            None,
            EXIT_DATA,
            r"imu\.csv: row 1 \(line 2\), column 'roll_deg'",
        ),
    ],
)
def test_pipeline_preflight_checks_the_raw_series(tmp_path, imu, los, code, pattern):
    # the head of each series and the overlap of their spans (read from the files' ends),
    # before any step of the run
    records = write_text(tmp_path, _csv(valid_records()))
    campaign = {
        "source": "files",
        "records": str(records),
        "imu_series": str(imu_series(tmp_path, **imu)),
    }
    if los is not None:
        campaign["los_series"] = str(los_series(tmp_path, **los))
    config = {
        "campaign": campaign,
        "reference": {"kind": "cup"},
        "inference": {"lever_arm_m": 2.0},
    }
    stream = io.StringIO()
    assert pipeline_preflight(config, stream=stream) == code, stream.getvalue()
    if pattern is not None:
        lines = stream.getvalue().strip().splitlines()
        assert len(lines) == 1 and re.search(pattern, lines[0]), lines


@pytest.mark.slow
@pytest.mark.parametrize(
    ("campaign", "code", "needle"),
    [
        ({"source": "files"}, EXIT_USAGE, "config key campaign.records: missing"),
        ({"source": "files", "records": "missing.csv"}, EXIT_DATA, "missing.csv: no such file"),
    ],
)
def test_snakemake_stops_at_parse_time_with_the_exit_status(tmp_path, campaign, code, needle):
    cfg = write_config(tmp_path, {"campaign": campaign})
    snakemake = str(Path(sys.executable).with_name("snakemake"))
    cmd = [snakemake, "-s", str(REPO / "Snakefile"), "--directory", str(tmp_path)]
    cmd += ["--configfile", str(cfg), "-n", "--cores", "1"]
    proc = subprocess.run(cmd, capture_output=True, text=True, timeout=300, cwd=tmp_path)
    assert proc.returncode == code, proc.stderr[-2000:]
    assert f"flidar-uq: error: {needle}" in proc.stderr
    assert "Traceback" not in proc.stderr
    assert not (tmp_path / "results").exists()


# --------------------------------------------------------------------------- fuzzing


def _corrupt(data: bytes, ops) -> bytes:
    b = bytearray(data)
    for kind, pos, val in ops:
        if not b:
            break
        i = pos % len(b)
        if kind == "flip":
            b[i] = val
        elif kind == "delete":
            del b[i : i + 1 + val % 8]
        elif kind == "insert":
            b[i:i] = bytes([val]) * (1 + val % 3)
        elif kind == "truncate":
            del b[i:]
        elif kind == "duplicate_line":
            start = b.rfind(b"\n", 0, i) + 1
            end = b.find(b"\n", i)
            end = len(b) if end < 0 else end + 1
            b[end:end] = b[start:end]
        elif kind == "swap_lines":
            lines = bytes(b).split(b"\n")
            j, k = pos % len(lines), val % len(lines)
            lines[j], lines[k] = lines[k], lines[j]
            b = bytearray(b"\n".join(lines))
    return bytes(b)


_OPS = st.lists(
    st.tuples(
        st.sampled_from(["flip", "delete", "insert", "truncate", "duplicate_line", "swap_lines"]),
        st.integers(0, 10**6),
        st.sampled_from([0, 9, 10, 13, 34, 44, 45, 46, 48, 57, 59, 69, 101, 0x80, 0xB0, 0xFF]),
    ),
    min_size=1,
    max_size=4,
)
_VALID_CSV = _csv(valid_records()).encode()


@settings(
    max_examples=150,
    deadline=None,
    suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow],
)
@given(ops=_OPS, gz=st.booleans())
def test_random_corruption_never_gives_a_traceback(tmp_path, capsys, ops, gz):
    data = _corrupt(_VALID_CSV, ops)
    name = "fuzz.csv.gz" if gz else "fuzz.csv"
    path = tmp_path / name
    path.write_bytes(gzip.compress(data, mtime=0) if gz else data)
    code = main(["validate", "--json", str(path)])
    out, err = capsys.readouterr()
    assert code in (EXIT_OK, EXIT_DATA), err
    if code == EXIT_DATA:
        assert out == "" and len(err.strip().splitlines()) == 1, err
        assert err.startswith(f"flidar-uq: error: {path}"), err
    else:
        assert json.loads(out)["valid"] is True


@settings(
    max_examples=40,
    deadline=None,
    suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow],
)
@given(ops=_OPS)
def test_random_corruption_of_a_parquet_file_never_gives_a_traceback(tmp_path, capsys, ops):
    buf = io.BytesIO()
    valid_records().to_parquet(buf, index=False)
    path = tmp_path / "fuzz.parquet"
    path.write_bytes(_corrupt(buf.getvalue(), ops))
    code = main(["validate", str(path)])
    out, err = capsys.readouterr()
    assert code in (EXIT_OK, EXIT_DATA), err
    if code == EXIT_DATA:
        assert len(err.strip().splitlines()) == 1 and str(path) in err, err
