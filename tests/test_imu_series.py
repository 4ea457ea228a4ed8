"""Raw IMU and LOS series read in chunks (flidar_uq.data.imu_series): the streamed per-record
statistics equal the whole-series ones, errors name the row of the file, gaps are reported."""

from __future__ import annotations

import copy

import numpy as np
import pandas as pd
import pytest

from flidar_uq.campaign.physics_mode import generate_campaign
from flidar_uq.campaign.scenarios import DEFAULT_SCENARIO
from flidar_uq.data import imu, io, qc
from flidar_uq.data.imu_series import (
    SERIES_MOTION_COLUMNS,
    TimeCursor,
    iter_imu_series,
    iter_los_series,
    merge_series_motion,
    record_window_offset_s,
    series_motion_statistics,
    series_overrides,
    series_span,
    window_batches,
)

T0 = pd.Timestamp("2015-04-01T00:00:00Z")


@pytest.fixture(scope="module")
def campaign():
    """A 12-record, two-height virtual campaign with IMU gaps, its raw IMU and LOS series."""
    sc = copy.deepcopy(DEFAULT_SCENARIO)
    sc.update(name="imu_series_test", n_records=12, heights_m=[58.0, 85.0])
    sc["imu"]["gap_probability"] = 0.5
    return generate_campaign(sc, 3, return_imu=True, return_los=True, n_workers=1)


def sine_series(n_s: float, fs: float = 5.0, amp: float = 2.0, start=T0) -> pd.DataFrame:
    t = np.arange(int(round(n_s * fs))) / fs
    return pd.DataFrame(
        {
            "timestamp": start + pd.to_timedelta(np.round(t * 1e6).astype(np.int64), unit="us"),
            "roll_deg": amp * np.sin(2 * np.pi * t / 4.0),
            "pitch_deg": 0.5 * amp * np.sin(2 * np.pi * t / 5.0 + 1.0),
        }
    )


def records_for(starts, heights=(58.0,), wd=240.0) -> pd.DataFrame:
    rows = [(t, h) for t in starts for h in heights]
    return pd.DataFrame(
        {
            "timestamp": pd.DatetimeIndex([r[0] for r in rows]),
            "height_m": [r[1] for r in rows],
            "wd_mean_deg": wd,
        }
    )


# --------------------------------------------------------------------------- statistics
@pytest.mark.parametrize("suffix", ["csv", "parquet"])
@pytest.mark.parametrize("chunk_rows", [7777, 1_000_000])
def test_streamed_statistics_equal_the_campaigns_whole_series_ones(
    campaign, tmp_path, suffix, chunk_rows
):
    """The virtual campaign derives its record columns from the same series with the data
    layer's estimators; streaming in chunks of any size gives the same numbers."""
    path = tmp_path / f"imu.{suffix}"
    io.write_imu_series(campaign.imu, path)
    result = series_motion_statistics(path, campaign.records, chunk_rows=chunk_rows)
    got = result.statistics[list(SERIES_MOTION_COLUMNS)].to_numpy()
    want = campaign.records[list(SERIES_MOTION_COLUMNS)].to_numpy()
    low = campaign.records["imu_availability_pct"].to_numpy() < 80.0
    # the campaign keeps tilt statistics of low-coverage records (flagged by QC anyway)
    np.testing.assert_allclose(got[~low], want[~low], rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(
        result.statistics["imu_availability_pct"], campaign.records["imu_availability_pct"]
    )
    assert result.summary["rows"] == len(campaign.imu)
    assert result.summary["record_rows"] == len(campaign.records)
    assert (result.statistics["timestamp"] == campaign.records["timestamp"]).all()


def test_windows_follow_records_off_the_10_min_grid(tmp_path):
    """Records starting at :05 get windows starting at :05 (not the UTC 10-min grid)."""
    start = T0 + pd.Timedelta(minutes=5)
    series = sine_series(3 * 600.0, start=T0)
    path = tmp_path / "imu.csv"
    io.write_imu_series(series, path)
    recs = records_for([start, start + pd.Timedelta(minutes=10)])
    assert record_window_offset_s(recs) == pytest.approx(300.0)
    got = series_motion_statistics(path, recs, chunk_rows=1000).statistics
    shifted = series.assign(timestamp=series["timestamp"] - pd.Timedelta(minutes=5))
    want = imu.motion_statistics(shifted).iloc[1:3]  # windows from :05 and :15
    for col in imu.MOTION_STAT_COLUMNS:
        np.testing.assert_allclose(got[col], want[col], rtol=1e-12, err_msg=col)
    off_grid = records_for([start, start + pd.Timedelta(minutes=12)])
    with pytest.raises(ValueError, match=r"not on one 600-s grid: record row 2"):
        series_motion_statistics(path, off_grid)


def test_gaps_are_listed_and_records_without_samples_flagged_by_qc(tmp_path):
    series = sine_series(4 * 600.0)
    t = (series["timestamp"] - T0).dt.total_seconds()
    # a 120-s pause in record 1 (rows absent) and NaN angles over the whole of record 4
    series = series[~((t >= 100.0) & (t < 220.0))].copy()
    t = (series["timestamp"] - T0).dt.total_seconds()
    series.loc[(t >= 1800.0) & (t < 2400.0), ["roll_deg", "pitch_deg"]] = np.nan
    path = tmp_path / "imu.parquet"
    io.write_imu_series(series, path)
    starts = [T0 + pd.Timedelta(minutes=10 * k) for k in range(5)]  # record 5: after the series
    result = series_motion_statistics(path, records_for(starts), chunk_rows=500)
    gaps = result.gaps.set_index("kind")
    assert list(gaps.index) == ["inside", "after_last_sample"]
    assert gaps.loc["inside", "start"] == T0 + pd.Timedelta(seconds=99.8)
    assert gaps.loc["inside", "end"] == T0 + pd.Timedelta(seconds=220.0)
    assert gaps.loc["inside", "missing_samples"] == 600  # 120 s at 5 Hz
    assert gaps.loc["inside", "duration_s"] == pytest.approx(120.0)
    # the NaN tail and the record after the series: from the last valid sample to the end
    assert gaps.loc["after_last_sample", "start"] == T0 + pd.Timedelta(seconds=1799.8)
    assert gaps.loc["after_last_sample", "end"] == T0 + pd.Timedelta(minutes=50)
    avail = result.statistics["imu_availability_pct"].to_numpy()
    np.testing.assert_allclose(avail, [80.0, 100.0, 100.0, 0.0, 0.0])
    assert result.summary["record_rows_without_samples"] == 2
    assert result.summary["missing_samples_inside"] == 600
    # QC turns the coverage into imu_gap flags (records 4 and 5; record 1 is at 80 %)
    recs = result.statistics.assign(
        hws_mean_ms=8.0, hws_std_ms=0.8, wd_mean_deg=240.0, availability_pct=100.0
    )
    flags = qc.run_qc(recs, qc.QCConfig(mad=False)).flags
    assert flags["reasons"].fillna("").str.contains("imu_gap").tolist() == [
        False,
        False,
        False,
        True,
        True,
    ]


def test_two_heights_get_their_own_wind_direction(tmp_path):
    """The tilt along the wind uses each record row's own wd_mean_deg: a pure roll tilts the
    body z axis north-south with yaw 0 (docs/data-format.md: ``(pitch, -roll)`` east and
    north), so it is along a wind from 0 deg and across one from 90 deg."""
    series = sine_series(600.0).assign(pitch_deg=0.0)
    path = tmp_path / "imu.csv"
    io.write_imu_series(series, path)
    recs = pd.concat([records_for([T0], (58.0,), 0.0), records_for([T0], (85.0,), 90.0)])
    stats = series_motion_statistics(path, recs.reset_index(drop=True)).statistics
    along, across = stats["tilt_along_wind_std_deg"], stats["tilt_across_wind_std_deg"]
    assert along[0] > 1.3 and across[0] < 0.01  # roll std 2 / sqrt(2) = 1.41 deg
    assert along[1] < 0.01 and across[1] > 1.3


# --------------------------------------------------------------------------- reading errors
def write_csv_text(path, df):
    df.to_csv(path, index=False, date_format="%Y-%m-%dT%H:%M:%S.%fZ")


def test_error_rows_are_counted_from_the_file_start(tmp_path):
    series = sine_series(600.0)
    series.loc[2345, "roll_deg"] = 120.0  # row 2346 of the file (1-based data row)
    path = tmp_path / "imu.csv"
    write_csv_text(path, series)
    with pytest.raises(
        io.DataValidationError, match=r"row 2346 \(line 2347\), column 'roll_deg'.*outside"
    ):
        list(iter_imu_series(path, chunk_rows=1000))


def test_time_going_back_across_a_chunk_boundary_names_the_row(tmp_path):
    series = sine_series(600.0)
    series.loc[1000, "timestamp"] = series.loc[998, "timestamp"]  # first row of chunk 2
    path = tmp_path / "imu.csv"
    write_csv_text(path, series)
    with pytest.raises(
        io.DataValidationError, match=r"row 1001 \(line 1002\), column 'timestamp'.*not increasing"
    ):
        list(iter_imu_series(path, chunk_rows=1000))


def test_a_sampling_rate_change_is_an_error(tmp_path):
    a = sine_series(300.0, fs=5.0)
    b = sine_series(300.0, fs=20.0, start=T0 + pd.Timedelta(seconds=300))
    path = tmp_path / "imu.csv"
    write_csv_text(path, pd.concat([a, b], ignore_index=True))
    with pytest.raises(io.DataValidationError, match=r"sampling rate changes from 5 Hz to 20 Hz"):
        list(iter_imu_series(path, chunk_rows=1000))


def test_rate_outside_5_20_hz_names_the_rows_of_the_chunk(tmp_path):
    path = tmp_path / "imu.csv"
    write_csv_text(path, sine_series(600.0, fs=2.0))
    with pytest.raises(
        io.DataValidationError, match=r"row 1 .*median sampling rate 2 Hz.*\(in rows 1-500\)"
    ):
        list(iter_imu_series(path, chunk_rows=500))
    with pytest.raises(io.DataValidationError, match=r"all rows.*median sampling rate 2 Hz"):
        list(iter_imu_series(path, chunk_rows=5000))  # the whole file in one chunk
    missing = tmp_path / "no_pitch.csv"
    write_csv_text(missing, sine_series(600.0).drop(columns="pitch_deg"))
    with pytest.raises(io.DataValidationError, match=r"header, column 'pitch_deg': required"):
        list(iter_imu_series(missing, chunk_rows=500))


def test_radians_rule_applies_to_the_whole_series(tmp_path):
    path = tmp_path / "imu.csv"
    write_csv_text(path, sine_series(600.0, amp=0.05))  # 0.05 "deg": radians?
    with pytest.raises(io.DataValidationError, match="look like radians"):
        list(iter_imu_series(path, chunk_rows=1000))
    assert sum(len(c) for c in iter_imu_series(path, chunk_rows=1000, allow_small_angles=True))
    # a calm first chunk followed by real motion is fine
    calm = sine_series(300.0, amp=0.05)
    moving = sine_series(300.0, amp=2.0, start=T0 + pd.Timedelta(seconds=300))
    write_csv_text(path, pd.concat([calm, moving], ignore_index=True))
    assert sum(len(c) for c in iter_imu_series(path, chunk_rows=1000)) == 3000


@pytest.mark.parametrize("suffix", ["csv", "csv.gz", "parquet"])
def test_series_span_reads_the_head_and_the_end_only(tmp_path, suffix):
    # 2 h at 5 Hz: the head validated (2,000 rows) and the last timestamp from the file's
    # end (the last Parquet row group, the last CSV line) equal those of the whole series
    series = sine_series(7200.0)
    path = tmp_path / f"imu.{suffix}"
    if suffix == "parquet":
        series.to_parquet(path, index=False, row_group_size=5000)
    else:
        series.to_csv(path, index=False, date_format="%Y-%m-%dT%H:%M:%S.%fZ")
    first, last = series_span(path, head_rows=2000)
    assert first == series["timestamp"].iloc[0]
    assert last == series["timestamp"].iloc[-1]
    # a bad value in the head is refused with its row
    series.loc[100, "roll_deg"] = 120.0
    write_csv_text(tmp_path / "bad.csv", series)
    with pytest.raises(io.DataValidationError, match=r"row 101 \(line 102\), column 'roll_deg'"):
        series_span(tmp_path / "bad.csv", head_rows=2000)


def test_missing_file_and_empty_file(tmp_path):
    with pytest.raises(FileNotFoundError, match="no such file"):
        list(iter_imu_series(tmp_path / "absent.csv"))
    path = tmp_path / "empty.csv"
    path.write_text("timestamp,roll_deg,pitch_deg\n")
    with pytest.raises(io.DataValidationError, match="no data rows"):
        list(iter_imu_series(path))


def test_los_stream_needs_time_order_across_heights(campaign, tmp_path):
    los = campaign.los.iloc[:5000]
    path = tmp_path / "los.parquet"
    io.write_los_series(los, path)
    assert sum(len(c) for c in iter_los_series(path, chunk_rows=999)) == 5000
    by_height = los.sort_values(["height_m", "timestamp"], kind="stable")  # valid per contract
    io.write_los_series(by_height, path)
    with pytest.raises(io.DataValidationError, match="must be sorted by time"):
        list(iter_los_series(path, chunk_rows=999))


# --------------------------------------------------------------------------- building blocks
def test_window_batches_end_on_boundaries_and_keep_every_row():
    series = sine_series(3 * 600.0 + 77.0)
    chunks = [series.iloc[a : a + 1234] for a in range(0, len(series), 1234)]
    batches = list(window_batches(chunks, window_s=600.0))
    assert pd.concat(batches, ignore_index=True).equals(series.reset_index(drop=True))
    for b in batches[:-1]:
        nxt = b["timestamp"].iloc[-1] + pd.Timedelta(seconds=0.2)
        assert (nxt - T0).total_seconds() % 600.0 == pytest.approx(0.0)


def test_time_cursor_serves_overlapping_ranges_in_order():
    series = sine_series(1000.0)
    cursor = TimeCursor(series.iloc[a : a + 333] for a in range(0, len(series), 333))
    for start_s in (0.0, 100.0, 150.0, 700.0):
        lo, hi = T0 + pd.Timedelta(seconds=start_s), T0 + pd.Timedelta(seconds=start_s + 200)
        got = cursor.take(lo, hi)
        want = series[(series["timestamp"] >= lo) & (series["timestamp"] < hi)]
        assert got["timestamp"].tolist() == want["timestamp"].tolist()
    assert len(cursor.take(T0 + pd.Timedelta(seconds=2000), T0 + pd.Timedelta(seconds=2100))) == 0


@pytest.mark.parametrize(
    ("option", "column"),
    [("vertical_velocity", "velocity_up_ms"), ("vertical_acceleration", "acceleration_up_ms2")],
)
def test_vertical_velocity_gives_the_bands_measured_direction_as_in_the_campaign(
    tmp_path, option, column
):
    """A wave follower's IMU series with the vertical velocity (imu.vertical_velocity), or
    with the vertical acceleration of an inertial unit without a velocity output
    (imu.vertical_acceleration), and the horizontal velocities (imu.horizontal_velocity):
    the streamed statistics carry tilt_band{b}_cos_psi and the hull's heave and horizontal
    responses, equal to the campaign's own (a wave follower's: 1 within 0.05), and a
    series without the heave column gives none of the former."""
    from flidar_uq.campaign.scenarios import load_scenario

    sc = load_scenario("wave_follower") | {"n_records": 6, "heights_m": [58.0]}
    sc["imu"] = sc.get("imu", {}) | {
        option: True,
        "horizontal_velocity": True,
        "gap_probability": 0.0,
    }
    camp = generate_campaign(sc, 5, return_imu=True, n_workers=1)
    assert column in camp.imu
    responses = ["heave_response_ratio", "horizontal_response_ratio"]
    np.testing.assert_allclose(camp.records[responses], 1.0, atol=0.05)
    cols = [f"tilt_band{b}_cos_psi" for b in range(1, 9)] + responses
    path = tmp_path / "imu.csv"
    io.write_imu_series(camp.imu, path)
    got = series_motion_statistics(path, camp.records, chunk_rows=4000).statistics
    np.testing.assert_allclose(got[cols], camp.records[cols], rtol=1e-9, atol=1e-9)
    assert np.isfinite(got[cols].to_numpy()).any()
    io.write_imu_series(camp.imu.drop(columns=column), path)
    without = series_motion_statistics(path, camp.records, chunk_rows=4000).statistics
    assert not set(cols[:-1]) & set(without.columns)


def test_a_velocity_that_covers_too_little_of_a_window_measures_nothing(tmp_path):
    """A separate MRU's velocity with its own gaps: in a window where the heave velocity
    covers less than the tilt must (80 %), its linear fill would lose band power, so the
    window gets no heave response and no measured directions (the record model then fits
    the translation's size); the other windows keep theirs, unchanged."""
    from flidar_uq.campaign.scenarios import load_scenario

    sc = load_scenario("wave_follower") | {"n_records": 3, "heights_m": [58.0]}
    sc["imu"] = sc.get("imu", {}) | {"vertical_velocity": True, "gap_probability": 0.0}
    camp = generate_campaign(sc, 5, return_imu=True, n_workers=1)
    path = tmp_path / "imu.csv"
    io.write_imu_series(camp.imu, path)
    full = series_motion_statistics(path, camp.records).statistics
    sparse = camp.imu.copy()
    first = sparse["timestamp"] < camp.records["timestamp"].iloc[0] + pd.Timedelta(600, "s")
    gap = first & (np.arange(len(sparse)) % 3 != 0)  # a third of the first window left
    sparse.loc[gap, "velocity_up_ms"] = np.nan
    io.write_imu_series(sparse, path)
    got = series_motion_statistics(path, camp.records).statistics
    cols = ["heave_response_ratio", *[f"tilt_band{b}_cos_psi" for b in range(1, 9)]]
    assert got.loc[0, cols].isna().all()
    assert np.isfinite(full.loc[0, cols].to_numpy(dtype=float)).any()
    pd.testing.assert_frame_equal(got.loc[1:, cols], full.loc[1:, cols])


def test_merge_series_motion_the_series_wins_row_by_row():
    t = pd.to_datetime(["2016-05-01T00:00:00Z", "2016-05-01T00:10:00Z"], utc=True)
    records = pd.DataFrame(
        {"timestamp": t, "height_m": 58.0, "roll_amplitude_deg": [9.0, np.nan], "x": [1, 2]}
    )
    stats = pd.DataFrame({"timestamp": t.strftime("%Y-%m-%dT%H:%M:%SZ")})
    for i, col in enumerate(SERIES_MOTION_COLUMNS):
        stats[col] = [1.0 + i, 2.0 + i]
    assert series_overrides(records) == (["roll_amplitude_deg"], 1)
    assert series_overrides(records.drop(columns="roll_amplitude_deg")) == ([], 0)
    merged = merge_series_motion(records, stats)
    assert merged["roll_amplitude_deg"].tolist() == [1.0, 2.0]
    assert merged["x"].tolist() == [1, 2]
    assert list(merged.columns) == ["timestamp", "height_m", "x", *SERIES_MOTION_COLUMNS]
    with pytest.raises(ValueError, match="s.csv: IMU statistics do not match"):
        merge_series_motion(records.iloc[:1], stats, source="s.csv")
    with pytest.raises(ValueError, match="row by row"):
        merge_series_motion(records, stats.iloc[::-1].reset_index(drop=True))
