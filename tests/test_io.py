"""Reading, writing and validating campaign tables (flidar_uq.data.io): every bad-input class."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from flidar_uq.data import io as fio
from flidar_uq.data.io import (
    DataValidationError,
    read_imu_series,
    read_los_series,
    read_records,
    validate_records,
    write_imu_series,
    write_los_series,
    write_records,
)

DATA = Path(__file__).parent / "data"


def make_records(n: int = 12, rng: np.random.Generator | None = None) -> pd.DataFrame:
    """A small valid record table: two heights, 10-min steps, written as a user would."""
    rng = np.random.default_rng(np.random.SeedSequence(7)) if rng is None else rng
    nt = n // 2
    t = pd.date_range("2015-04-01T00:00:00Z", periods=nt, freq="10min")
    return pd.DataFrame(
        {
            "timestamp": np.repeat(t.strftime("%Y-%m-%dT%H:%M:%SZ"), 2),
            "height_m": np.tile([58.0, 85.0], nt),
            "hws_mean_ms": rng.uniform(4, 15, 2 * nt),
            "hws_std_ms": rng.uniform(0.3, 1.5, 2 * nt),
            "wd_mean_deg": rng.uniform(0, 360, 2 * nt),
            "availability_pct": rng.uniform(60, 100, 2 * nt),
            "roll_amplitude_deg": rng.uniform(1, 5, 2 * nt),
            "pitch_amplitude_deg": rng.uniform(1, 5, 2 * nt),
            "roll_period_s": rng.uniform(2, 6, 2 * nt),
            "pitch_period_s": rng.uniform(2, 6, 2 * nt),
            "period2_s": np.nan,
            "weight1": np.nan,
            "sv": rng.uniform(0, 0.05, 2 * nt),
            "ref_hws_mean_ms": rng.uniform(4, 15, 2 * nt),
            "ref_hws_std_ms": rng.uniform(0.3, 1.5, 2 * nt),
            "true_ti": rng.uniform(0.03, 0.1, 2 * nt),
        }
    )


def write_csv(df: pd.DataFrame, tmp_path: Path, name: str = "campaign.csv") -> Path:
    path = tmp_path / name
    df.to_csv(path, index=False)
    return path


def expect(path: Path, row: int | None, column: str, words: str) -> None:
    """read_records must raise naming the file, the row and the column."""
    where = "header" if row is None else f"row {row} (line {row + 1})"
    pattern = rf"{re.escape(str(path))}: {re.escape(where)}, column '{column}': .*{words}"
    with pytest.raises(DataValidationError, match=pattern):
        read_records(path)


# --------------------------------------------------------------------------- good input
def test_valid_csv_roundtrip_keeps_values(tmp_path):
    df = make_records()
    path = write_csv(df, tmp_path)
    rec = read_records(path)
    assert str(rec["timestamp"].dtype) == "datetime64[ns, UTC]"
    np.testing.assert_allclose(rec["hws_mean_ms"], df["hws_mean_ms"])
    out = write_records(rec, tmp_path / "out.csv")
    again = read_records(out)
    pd.testing.assert_frame_equal(again, rec, check_exact=False, rtol=1e-9)
    assert out.read_text().splitlines()[1].startswith("2015-04-01T00:00:00Z,")


def test_parquet_roundtrip_is_exact(tmp_path):
    rec = validate_records(make_records())
    out = write_records(rec, tmp_path / "c.parquet")
    pd.testing.assert_frame_equal(read_records(out), rec)


def test_hand_written_campaign_is_valid():
    rec = read_records(DATA / "hand_written_campaign.csv")
    assert 20 <= len(rec) <= 40
    assert {"ref_hws_mean_ms", "ref_hws_std_ms", "sv"} <= set(rec.columns)


def test_offset_and_naive_timestamps_become_utc(tmp_path):
    df = make_records(4)
    df["timestamp"] = ["2015-04-01T02:00:00+02:00"] * 2 + ["2015-04-01T02:10:00+02:00"] * 2
    rec = read_records(write_csv(df, tmp_path))
    assert rec["timestamp"].iloc[0] == pd.Timestamp("2015-04-01T00:00:00Z")
    assert rec["timestamp"].iloc[2] == pd.Timestamp("2015-04-01T00:10:00Z")
    df["timestamp"] = ["2015-04-01T00:00:00"] * 2 + ["2015-04-01 00:10"] * 2
    rec = read_records(write_csv(df, tmp_path))
    assert rec["timestamp"].iloc[2] == pd.Timestamp("2015-04-01T00:10:00Z")


@pytest.mark.parametrize(
    "stamps",
    [
        ["2015-04-01T02:00:00+02:00", "2015-04-01T00:10:00"],  # zone and no zone
        ["2015-04-01T02:00:00+02:00", "2015-04-01T01:10:00+01:00"],  # daylight saving
        ["2015-04-01T00:00:00Z", "2015-04-01T00:10:00"],
    ],
)
def test_bad_mixed_time_zones(tmp_path, stamps):
    df = make_records(4)
    df["timestamp"] = [stamps[0]] * 2 + [stamps[1]] * 2
    expect(write_csv(df, tmp_path), 3, "timestamp", "mixed time zones")


def test_same_zone_written_differently_is_one_zone(tmp_path):
    df = make_records(4)
    df["timestamp"] = ["2015-04-01T00:00:00Z"] * 2 + ["2015-04-01T00:10:00+00:00"] * 2
    assert len(read_records(write_csv(df, tmp_path))) == 4


def test_motion_columns_optional_when_imu_series_given():
    df = make_records().drop(columns=["roll_amplitude_deg", "roll_period_s"])
    with pytest.raises(DataValidationError, match="'roll_amplitude_deg': required column missing"):
        validate_records(df)
    assert "roll_period_s" not in validate_records(df, require_motion=False).columns


# --------------------------------------------------------------------------- bad input classes
def test_bad_missing_required_column(tmp_path):
    path = write_csv(make_records().drop(columns=["hws_std_ms"]), tmp_path)
    expect(path, None, "hws_std_ms", "required column missing")


def test_bad_unknown_column(tmp_path):
    df = make_records()
    df["bin_id"] = 1
    expect(write_csv(df, tmp_path), None, "bin_id", "unknown column")


def test_bad_duplicated_column_name(tmp_path):
    df = make_records()
    path = tmp_path / "dup.csv"
    text = df.to_csv(index=False).splitlines()
    text = [line + ",1.0" for line in text]
    text[0] = text[0].rsplit(",", 1)[0] + ",sv"
    path.write_text("\n".join(text) + "\n")
    expect(path, None, "sv", "duplicated column name")


def test_bad_unparsable_number(tmp_path):
    df = make_records().astype({"hws_mean_ms": object})
    df.loc[4, "hws_mean_ms"] = "8,3 m/s"
    expect(write_csv(df, tmp_path), 5, "hws_mean_ms", "cannot parse '8,3 m/s' as a number")


def test_bad_unparsable_timestamp(tmp_path):
    df = make_records()
    df.loc[2, "timestamp"] = "01/04/2015 00:10"
    expect(write_csv(df, tmp_path), 3, "timestamp", "ISO 8601")


def test_bad_negative_std(tmp_path):
    df = make_records()
    df.loc[6, "hws_std_ms"] = -0.2
    expect(write_csv(df, tmp_path), 7, "hws_std_ms", "negative standard deviation")


def test_bad_negative_reference_std(tmp_path):
    df = make_records()
    df.loc[0, "ref_hws_std_ms"] = -1.0
    expect(write_csv(df, tmp_path), 1, "ref_hws_std_ms", "negative standard deviation")


def test_bad_speed_above_80(tmp_path):
    df = make_records()
    df.loc[3, "hws_mean_ms"] = 95.0
    expect(write_csv(df, tmp_path), 4, "hws_mean_ms", "wind speed 95 m/s above 80 m/s")


def test_bad_amplitudes_look_like_radians(tmp_path):
    df = make_records()
    df["roll_amplitude_deg"] = np.deg2rad(df["roll_amplitude_deg"])
    df["pitch_amplitude_deg"] = np.deg2rad(df["pitch_amplitude_deg"])
    path = write_csv(df, tmp_path)
    with pytest.raises(DataValidationError, match=r"campaign\.csv: row \d+ .*look like radians"):
        read_records(path)
    assert len(read_records(path, allow_small_angles=True)) == len(df)


def test_bad_direction_looks_like_radians(tmp_path):
    df = make_records(20)
    df["wd_mean_deg"] = np.deg2rad(df["wd_mean_deg"])
    row = int(np.argmax(df["wd_mean_deg"].to_numpy())) + 1
    expect(write_csv(df, tmp_path), row, "wd_mean_deg", "look\\s+like radians")


def test_bad_duplicated_timestamp_per_height(tmp_path):
    df = make_records()
    df.loc[5, "timestamp"] = df.loc[3, "timestamp"]  # both at 85 m
    expect(
        write_csv(df, tmp_path), 6, "timestamp", r"duplicated timestamp .*\(first seen in row 4\)"
    )


def test_same_timestamp_at_two_heights_is_fine(tmp_path):
    df = make_records()
    assert df["timestamp"].iloc[0] == df["timestamp"].iloc[1]
    assert len(read_records(write_csv(df, tmp_path))) == len(df)


def test_bad_non_monotonic_timestamps(tmp_path):
    df = make_records()
    df.loc[[2, 4], "timestamp"] = df.loc[[4, 2], "timestamp"].to_numpy()  # 58 m swapped
    expect(write_csv(df, tmp_path), 5, "timestamp", "not increasing at height_m=58")


def test_bad_nan_in_required_column(tmp_path):
    df = make_records()
    df.loc[8, "availability_pct"] = np.nan
    expect(write_csv(df, tmp_path), 9, "availability_pct", r"missing value \(NaN\)")


def test_bad_missing_timestamp(tmp_path):
    df = make_records()
    df.loc[1, "timestamp"] = None
    expect(write_csv(df, tmp_path), 2, "timestamp", "missing timestamp")


def test_bad_direction_outside_0_360(tmp_path):
    df = make_records()
    df.loc[10, "wd_mean_deg"] = 365.0
    expect(write_csv(df, tmp_path), 11, "wd_mean_deg", "direction 365 deg outside 0-360")


def test_bad_availability_outside_0_100(tmp_path):
    df = make_records()
    df.loc[0, "availability_pct"] = 101.0
    expect(write_csv(df, tmp_path), 1, "availability_pct", "percentage 101 outside 0-100")


def test_bad_weight1_outside_unit_interval(tmp_path):
    df = make_records()
    df.loc[2, ["period2_s", "weight1"]] = [9.0, 1.3]
    expect(write_csv(df, tmp_path), 3, "weight1", r"outside \[0, 1\]")


def test_bad_period2_without_weight1(tmp_path):
    df = make_records()
    df.loc[2, "period2_s"] = 9.0
    expect(write_csv(df, tmp_path), 3, "weight1", "both be given")


def test_bad_zero_period(tmp_path):
    df = make_records()
    df.loc[1, "roll_period_s"] = 0.0
    expect(write_csv(df, tmp_path), 2, "roll_period_s", r"outside \(0, 60\]")


def test_bad_infinite_value(tmp_path):
    df = make_records()
    df.loc[3, "sv"] = np.inf
    expect(write_csv(df, tmp_path), 4, "sv", "infinite value")


def test_bad_empty_table(tmp_path):
    path = write_csv(make_records().iloc[:0], tmp_path)
    with pytest.raises(
        DataValidationError, match=r"campaign\.csv: header: the table has no data rows"
    ):
        read_records(path)


def test_bad_truth_column_text(tmp_path):
    df = make_records().astype({"true_ti": object})
    df.loc[0, "true_ti"] = "high"
    expect(write_csv(df, tmp_path), 1, "true_ti", "cannot parse 'high'")


def test_error_counts_further_offending_rows(tmp_path):
    df = make_records()
    df.loc[[1, 4, 7], "hws_std_ms"] = -1.0
    expect(write_csv(df, tmp_path), 2, "hws_std_ms", r"\(and 2 more rows\)")


def test_parquet_errors_name_row_without_line(tmp_path):
    df = validate_records(make_records())
    df.loc[3, "hws_std_ms"] = -1.0
    path = tmp_path / "c.parquet"
    df.to_parquet(path)
    with pytest.raises(DataValidationError, match=r"c\.parquet: row 4, column 'hws_std_ms'"):
        read_records(path)


def test_write_refuses_invalid_table(tmp_path):
    df = make_records()
    df.loc[0, "wd_mean_deg"] = -5.0
    with pytest.raises(DataValidationError, match="row 1, column 'wd_mean_deg'"):
        write_records(df, tmp_path / "x.csv")
    assert not (tmp_path / "x.csv").exists()


def test_unknown_suffix_is_refused(tmp_path):
    with pytest.raises(DataValidationError, match=r"x\.xlsx: unknown file type \(export"):
        read_records(tmp_path / "x.xlsx")


def test_error_is_a_value_error():
    assert issubclass(DataValidationError, ValueError)


# --------------------------------------------------------------------------- IMU and LOS
def make_imu(fs_hz: float = 5.0, duration_s: float = 60.0) -> pd.DataFrame:
    t = np.arange(0, duration_s, 1 / fs_hz)
    return pd.DataFrame(
        {
            "timestamp": pd.to_datetime(1.43e9 + t, unit="s", utc=True),
            "roll_deg": 3 * np.sin(2 * np.pi * t / 4),
            "pitch_deg": 2 * np.cos(2 * np.pi * t / 4),
            "yaw_deg": 10.0,
        }
    )


def test_imu_roundtrip(tmp_path):
    imu = make_imu()
    path = write_imu_series(imu, tmp_path / "imu.csv")
    back = read_imu_series(path)
    # CSV keeps microseconds (docs/data-format.md)
    assert (back["timestamp"] - imu["timestamp"]).abs().max() < pd.Timedelta("1us")
    np.testing.assert_allclose(back["roll_deg"], imu["roll_deg"], rtol=1e-9)


def test_imu_bad_rate(tmp_path):
    imu = make_imu(fs_hz=1.0)
    imu.to_csv(tmp_path / "imu.csv", index=False)
    with pytest.raises(
        DataValidationError,
        match=r"imu\.csv: all rows, column 'timestamp': median sampling rate 1 Hz",
    ):
        read_imu_series(tmp_path / "imu.csv")


def test_imu_bad_radians(tmp_path):
    imu = make_imu()
    imu[["roll_deg", "pitch_deg"]] = np.deg2rad(imu[["roll_deg", "pitch_deg"]])
    imu.to_parquet(tmp_path / "imu.parquet")
    with pytest.raises(
        DataValidationError, match=r"imu\.parquet: row \d+, column '(roll|pitch)_deg'.*radians"
    ):
        read_imu_series(tmp_path / "imu.parquet")


def test_imu_bad_time_order(tmp_path):
    imu = make_imu()
    imu.loc[10, "timestamp"] = imu.loc[9, "timestamp"]
    imu.to_csv(tmp_path / "imu.csv", index=False)
    with pytest.raises(
        DataValidationError, match=r"row 11 \(line 12\), column 'timestamp': duplicated"
    ):
        read_imu_series(tmp_path / "imu.csv")


def make_los() -> pd.DataFrame:
    t = pd.date_range("2011-08-17T00:00:00Z", periods=50, freq="20ms")
    return pd.DataFrame(
        {
            "timestamp": t,
            "height_m": 85.0,
            "azimuth_deg": np.linspace(0, 352.8, 50),
            "radial_speed_ms": 5.0,
            "cnr_db": -15.0,
        }
    )


def test_los_roundtrip_and_bad_cnr_type(tmp_path):
    path = write_los_series(make_los(), tmp_path / "los.parquet")
    assert len(read_los_series(path)) == 50
    los = make_los().astype({"cnr_db": object})
    los.loc[7, "cnr_db"] = "low"
    los.to_csv(tmp_path / "los.csv", index=False)
    with pytest.raises(
        DataValidationError, match=r"los\.csv: row 8 \(line 9\), column 'cnr_db': cannot parse"
    ):
        read_los_series(tmp_path / "los.csv")


def test_los_bad_azimuth(tmp_path):
    los = make_los()
    los.loc[3, "azimuth_deg"] = 400.0
    los.to_csv(tmp_path / "los.csv", index=False)
    with pytest.raises(
        DataValidationError, match="row 4 .*'azimuth_deg': direction 400 deg outside 0-360"
    ):
        read_los_series(tmp_path / "los.csv")


def test_bad_period1_not_shorter_than_period2(tmp_path):
    df = make_records()
    df["period1_s"] = np.nan
    df.loc[4, ["period1_s", "period2_s", "weight1"]] = [9.0, 8.0, 0.5]
    expect(write_csv(df, tmp_path), 5, "period2_s", r"must be longer than period1_s \(9 s\)")


def test_bad_numeric_timestamp(tmp_path):
    df = make_records()
    df["timestamp"] = np.arange(len(df), dtype=float) * 600.0
    expect(write_csv(df, tmp_path), 1, "timestamp", "is not an ISO 8601 timestamp")


@settings(max_examples=25, deadline=None)
@given(st.integers(0, 2**32 - 1), st.integers(2, 40), st.sampled_from(["csv", "parquet"]))
def test_write_read_roundtrip_hypothesis(tmp_path_factory, seed, n, fmt):
    rng = np.random.default_rng(seed)
    df = make_records(2 * n, rng)
    df.loc[rng.uniform(size=len(df)) < 0.2, "roll_period_s"] = np.nan
    rec = validate_records(df)
    path = write_records(rec, tmp_path_factory.mktemp("rt") / f"c.{fmt}")
    back = read_records(path)
    pd.testing.assert_frame_equal(back, rec)  # exact: floats are written in repr


def test_bad_malformed_csv_line(tmp_path):
    path = write_csv(make_records(), tmp_path)
    lines = path.read_text().splitlines()
    lines[4] += ",1.0,2.0"  # data row 4 has two extra fields
    path.write_text("\n".join(lines) + "\n")
    with pytest.raises(
        DataValidationError,
        match=r"campaign\.csv: row 4 \(line 5\): 18 fields where the header has 16$",
    ):
        read_records(path)


@pytest.mark.slow
def test_virtual_campaign_passes_validation_qc_and_binning(tmp_path):
    # issue #3 acceptance: the data layer works on the schema the virtual campaign writes
    import yaml

    from flidar_uq.campaign import physics_mode as campaign
    from flidar_uq.campaign.scenarios import scenario_dir
    from flidar_uq.data.binning import bin_records
    from flidar_uq.data.qc import run_qc

    scenario = yaml.safe_load((scenario_dir() / "tiny.yaml").read_text())
    records = campaign.generate_campaign(scenario, 1).records
    path = write_records(records, tmp_path / "virtual.csv")
    rec = read_records(path)
    assert len(rec) == len(records)
    qc = run_qc(rec)
    assert qc.n_in == qc.n_kept + qc.n_flagged == len(rec)
    _, table = bin_records(qc.kept)
    assert table["count"].sum() + table.attrs["n_unbinned"] == qc.n_kept


def test_result_table_read_in_chunks_equals_one_pass(tmp_path):
    """read_csv(chunk_rows=): the types of one pass, whatever a chunk holds (an integer
    column missing in a later chunk, a text column empty in the first, booleans), and
    only the asked columns."""
    df = pd.DataFrame(
        {
            "i": [1, 2, 3, 4, 5, 6, 7, 8, np.nan, 10],
            "s": [None] * 5 + ["a", "b", None, "c", "d"],
            "t": ["x"] * 5 + [None] * 5,
            "b": [True, False] * 5,
            "f": np.linspace(0.0, 1.0, 10),
        }
    )
    path = tmp_path / "t.csv"
    fio.write_csv(df, path)
    one = fio.read_csv(path)
    for rows in (1, 3, 5, 100):
        pd.testing.assert_frame_equal(fio.read_csv(path, chunk_rows=rows), one)
    pd.testing.assert_frame_equal(fio.read_csv(path, ["s", "f"], chunk_rows=4), one[["s", "f"]])


def test_write_table_keeps_every_bit_and_dtype_and_rewrites_the_same_bytes(tmp_path):
    """The pipeline's intermediate Parquet tables: float64 bit for bit (NaN, -0.0, a
    subnormal, the last bit), UTC time stamps with their zone, ints, bools and text as
    written; a second write of the same frame gives the same bytes; only .parquet."""
    df = pd.DataFrame(
        {
            "timestamp": pd.date_range("2015-04-01", periods=5, freq="10min", tz="UTC"),
            "x": [np.nan, -0.0, 5e-324, 0.1 + 0.2, np.nextafter(1.0, 2.0)],
            "record_id": np.arange(5, dtype=np.int64),
            "kept": [True, False, True, True, False],
            "reasons": ["", "mad;availability_low", "", "", "x"],
        }
    )
    a, b = tmp_path / "a.parquet", tmp_path / "b.parquet"
    fio.write_table(df, a)
    fio.write_table(df, b)
    assert a.read_bytes() == b.read_bytes()
    back = fio.read_table(a)
    assert isinstance(back["timestamp"].dtype, pd.DatetimeTZDtype)
    assert (back["timestamp"] == df["timestamp"]).all()
    assert (
        back["x"].to_numpy().view(np.int64).tolist() == df["x"].to_numpy().view(np.int64).tolist()
    )
    assert back["record_id"].dtype == np.int64 and back["kept"].dtype == bool
    assert back["reasons"].tolist() == df["reasons"].tolist()
    assert fio.read_table(a, ["x"]).columns.tolist() == ["x"]
    with pytest.raises(ValueError, match=r"a\.csv is not a \.parquet file"):
        fio.write_table(df, tmp_path / "a.csv")
