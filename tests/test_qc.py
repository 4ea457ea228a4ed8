"""QC filters (flidar_uq.data.qc): hand-computed verdicts, switches, conservation of counts."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from flidar_uq.data.io import read_records
from flidar_uq.data.qc import (
    LOS_REASONS,
    MAD_SCALE,
    RECORD_REASONS,
    QCConfig,
    rolling_mad_outliers,
    run_los_qc,
    run_qc,
    std_pattern_outliers,
    summarise,
)

DATA = Path(__file__).parent / "data"


def records(n: int = 6, **cols) -> pd.DataFrame:
    """Records passing every default filter unless overridden by ``cols``."""
    base = {
        "timestamp": pd.date_range("2015-04-01", periods=n, freq="10min", tz="UTC"),
        "height_m": 85.0,
        "hws_mean_ms": 8.0,
        "hws_std_ms": 0.6,
        "wd_mean_deg": 240.0,
        "availability_pct": 95.0,
        "roll_amplitude_deg": 3.0,
        "pitch_amplitude_deg": 3.0,
        "roll_period_s": 4.0,
        "pitch_period_s": 4.0,
    }
    base.update(cols)
    return pd.DataFrame(base)


def failed(result, reason: str) -> list[int]:
    """1-based rows failing ``reason``."""
    return result.flags.loc[result.flags[f"fail_{reason}"], "row"].tolist()


# --------------------------------------------------------------------------- one filter each
def test_hws_nonphysical_malekmohammadi2024_20ms():
    r = run_qc(records(hws_mean_ms=[8.0, 20.0, 20.01, 25.0, 8.0, 8.0]), QCConfig(hws_max_ms=20.0))
    assert failed(r, "hws_nonphysical") == [3, 4]  # 20 m/s itself is physical


def test_default_qc_keeps_20_to_25_ms_records_at_offshore_heights():
    speeds = [20.5, 21.0, 22.0, 23.5, 24.0, 25.0]
    for h in (80.0, 150.0):
        r = run_qc(records(hws_mean_ms=speeds).assign(height_m=h), QCConfig(mad=False))
        assert failed(r, "hws_nonphysical") == []
        assert failed(r, "hws_out_of_ti_range") == []
        assert r.n_kept == len(speeds)
    r = run_qc(records(hws_mean_ms=[8.0, 40.0, 40.5, 8.0, 8.0, 8.0]), QCConfig(mad=False))
    assert failed(r, "hws_nonphysical") == [3]


def test_hws_range_for_ti_gutierrez2018_3_to_20():
    r = run_qc(
        records(hws_mean_ms=[2.99, 3.0, 12.0, 20.0, 20.5, 8.0]),
        QCConfig(mad=False, ti_hws_max_ms=20.0),
    )
    assert failed(r, "hws_out_of_ti_range") == [1, 5]


def test_spatial_variation_gutierrez2018_006():
    r = run_qc(records(sv=[0.01, 0.06, 0.0601, np.nan, 0.2, 0.03]))
    assert failed(r, "sv_high") == [3, 5]
    assert r.counts.loc["sv_high", "applicable"]


def test_zero_std_of_the_lidar_or_the_reference_is_flagged_not_dropped():
    r = run_qc(
        records(
            hws_std_ms=[0.6, 0.0, 0.6, 0.6, 0.6, 0.6],
            ref_hws_std_ms=[0.5, 0.5, 0.5, 0.0, np.nan, 0.5],
        ),
        QCConfig(mad=False),
    )
    assert failed(r, "zero_std") == [2, 4]  # a missing reference std is not a zero one
    assert r.n_in == 6 and len(r.flags) == 6
    off = run_qc(records(hws_std_ms=[0.0] * 6), QCConfig(mad=False, zero_std=False))
    assert off.n_kept == 6


def test_height_selection_flags_the_other_heights():
    df = records(height_m=[58.0, 85.0, 100.0, 58.0, 85.0, 100.0])
    r = run_qc(df, QCConfig(mad=False, heights_m=[85, 100.0000001]))
    assert failed(r, "height_not_selected") == [1, 4]
    assert r.counts.loc["height_not_selected", "threshold"] == "not in 85, 100 m"
    assert not run_qc(df, QCConfig(mad=False)).counts.loc["height_not_selected", "applicable"]
    with pytest.raises(ValueError, match="heights_m must be positive heights"):
        QCConfig(heights_m=[-5.0])


def test_sv_filter_not_applicable_without_column():
    r = run_qc(records())
    assert not r.counts.loc["sv_high", "applicable"]
    assert r.counts.loc["sv_high", "n_failed"] == 0


def test_relative_sigma_malekmohammadi2024_eq9_70pct():
    # Eq. (9): sigma_ref / sigma_moving - 1 > 0.70 fails: 1.0/0.6 - 1 = 0.667 passes,
    # 1.03/0.6 - 1 = 0.717 fails; a missing reference cannot fail
    ref = [0.6, 1.0, 1.03, 0.3, np.nan, 2.0]
    r = run_qc(records(ref_hws_std_ms=ref, hws_std_ms=[0.6] * 6))
    assert failed(r, "relative_sigma") == [3, 6]


def test_availability_malekmohammadi2024_50pct():
    r = run_qc(records(availability_pct=[49.99, 50.0, 100.0, 0.0, 75.0, 50.01]))
    assert failed(r, "low_availability") == [1, 4]


def test_imu_gap_missing_motion_or_low_coverage():
    r = run_qc(
        records(
            roll_period_s=[4.0, np.nan, 4.0, 4.0, 4.0, 4.0],
            pitch_amplitude_deg=[3.0, 3.0, np.nan, 3.0, 3.0, 3.0],
            imu_availability_pct=[100.0, 100.0, 100.0, 79.9, 80.0, np.nan],
        )
    )
    assert failed(r, "imu_gap") == [2, 3, 4]


def test_missing_wind():
    r = run_qc(
        records(hws_mean_ms=[8.0, np.nan, 8.0, 8.0, 8.0, 8.0], hws_std_ms=[0.6] * 5 + [np.nan])
    )
    assert failed(r, "missing_wind") == [2, 6]


def test_mad_eq8_hand_computed():
    # median 10; |x - M| = 0,2,2,1,1,20,0,8.8,9 -> MAD 2 -> threshold 3*2/0.6745 = 8.8955
    x = np.array([10, 12, 8, 11, 9, 30, 10, 18.8, 1.0])
    out = rolling_mad_outliers(x, np.arange(9) * 600.0, window_s=1e6, k=3.0, min_count=5)
    assert 3 * 2 / MAD_SCALE == pytest.approx(8.8955, abs=1e-4)
    assert np.flatnonzero(out).tolist() == [5, 8]


def test_mad_is_local_rolling_median_not_global():
    # a ramp 5 -> 15 m/s with a +3 m/s spike: the rolling median sees it, a global one would not
    n = 200
    x = np.linspace(5, 15, n) + 0.3 * np.sin(2.3 * np.arange(n))  # bounded "turbulence"
    x[120] += 3.0
    t = np.arange(n) * 600.0
    local = rolling_mad_outliers(x, t, window_s=6 * 3600.0)
    assert np.flatnonzero(local).tolist() == [120]
    glob = rolling_mad_outliers(x, t, window_s=1e9)
    assert not glob.any()


def test_mad_windows_do_not_cross_heights():
    n, m = 40, 8  # 8 records at 85 m at 16 m/s among 40 at 58 m at 8 m/s
    x = np.r_[
        np.full(n, 8.0) + 0.1 * np.cos(np.arange(n)), np.full(m, 16.0) + 0.1 * np.sin(np.arange(m))
    ]
    t = np.r_[np.arange(n), np.arange(m)] * 600.0
    h = np.r_[np.full(n, 58.0), np.full(m, 85.0)]
    assert not rolling_mad_outliers(x, t, h, window_s=6 * 3600.0).any()
    assert rolling_mad_outliers(x, t, None, window_s=6 * 3600.0).any()  # mixed heights would


def test_mad_needs_min_count():
    x = np.array([10.0, 10.1, 30.0])
    assert not rolling_mad_outliers(x, np.arange(3) * 600.0, window_s=1e6, min_count=5).any()


def test_cnr_malekmohammadi2024_minus23db_on_los():
    los = pd.DataFrame(
        {
            "timestamp": pd.date_range("2011-08-17", periods=6, freq="100s", tz="UTC"),
            "height_m": 85.0,
            "azimuth_deg": 0.0,
            "radial_speed_ms": 5.0,
            "cnr_db": [-10.0, -23.0, -23.01, np.nan, -30.0, 0.0],
        }
    )
    r = run_los_qc(los)
    assert failed(r, "cnr_low") == [3, 4, 5]
    assert tuple(r.counts.index) == LOS_REASONS  # the documented vocabulary
    assert run_los_qc(los, QCConfig(cnr=False)).n_kept == 6


#: Rows (1-based) of the hand-written campaign whose std column gets TI in percent.
PERCENT_ROWS = list(range(2, 31, 3))


def ti_percent_in_std(rec: pd.DataFrame, rows=PERCENT_ROWS) -> pd.DataFrame:
    """``rec`` with TI in percent (100 std / mean) in the std column of ``rows`` (1-based)."""
    out = rec.copy()
    idx = out.index[np.asarray(rows) - 1]
    out.loc[idx, "hws_std_ms"] = 100.0 * out.loc[idx, "hws_std_ms"] / out.loc[idx, "hws_mean_ms"]
    return out


def test_std_pattern_flags_exactly_the_rows_with_ti_in_percent():
    rec = read_records(DATA / "hand_written_campaign.csv")
    assert run_qc(rec).counts.loc["std_pattern", "n_failed"] == 0
    r = run_qc(ti_percent_in_std(rec))
    assert failed(r, "std_pattern") == PERCENT_ROWS
    assert (
        not run_qc(ti_percent_in_std(rec), QCConfig(std_pattern=False))
        .flags["fail_std_pattern"]
        .any()
    )


def test_std_pattern_hand_computed_threshold():
    """log ratios 0 (x9), 0.1, 1.0, 1.2 -> median 0, MAD 0 -> threshold log(3) = 1.0986:
    only the last; with min_factor 2 (log 2 = 0.693) the last two."""
    mean = np.full(12, 10.0)
    std = 10.0 * np.exp([0.0] * 9 + [0.1, 1.0, 1.2])
    assert np.flatnonzero(std_pattern_outliers(mean, std)).tolist() == [11]
    assert np.flatnonzero(std_pattern_outliers(mean, std, min_factor=2.0)).tolist() == [10, 11]
    # the MAD term: half the ratios spread by +-0.5 -> MAD 0.5, 5 scaled MADs = 3.71
    wide = 10.0 * np.exp([0.0, 0.5, -0.5] * 4 + [3.0, 4.0])
    assert np.flatnonzero(std_pattern_outliers(np.full(14, 10.0), wide)).tolist() == [13]


def test_std_pattern_needs_ten_finite_ratios():
    mean = np.array([8.0] * 9 + [np.nan])
    std = np.array([0.6] * 8 + [60.0, 0.6])
    assert not std_pattern_outliers(mean, std).any()
    assert std_pattern_outliers(np.full(10, 8.0), np.array([0.6] * 9 + [60.0]))[-1]


# --------------------------------------------------------------------------- table and switches
def test_hand_written_campaign_reasons():
    rec = read_records(DATA / "hand_written_campaign.csv")
    r = run_qc(rec, QCConfig(hws_max_ms=20.0, ti_hws_max_ms=20.0))  # the hexapod study's
    assert run_qc(rec).flags.loc[21, "reasons"] == "mad_outlier"  # default: 40 m/s
    reasons = dict(zip(r.flags["row"], r.flags["reasons"], strict=True))
    assert reasons[9] == "mad_outlier"  # 17.9 m/s among ~8 m/s at 58 m
    assert reasons[11] == reasons[12] == "low_availability"
    assert reasons[13] == reasons[14] == "imu_gap"
    assert reasons[15] == reasons[16] == "sv_high"
    assert reasons[17] == "relative_sigma"  # 1.35 / 0.59 - 1 = 1.29
    assert reasons[22] == "hws_nonphysical;hws_out_of_ti_range;mad_outlier"
    assert reasons[25] == "hws_out_of_ti_range;sv_high;mad_outlier"
    assert (r.n_in, r.n_kept, r.n_flagged) == (30, 19, 11)
    assert r.counts.loc["sv_high", "n_failed_only"] == 2


def test_a_record_can_fail_several_filters():
    r = run_qc(records(hws_mean_ms=[45.0] + [8.0] * 5, availability_pct=[10.0] + [90.0] * 5))
    assert r.flags["n_failed"].iloc[0] == 4
    assert (
        r.flags["reasons"].iloc[0]
        == "hws_nonphysical;hws_out_of_ti_range;mad_outlier;low_availability"
    )
    assert r.flags["n_failed"].iloc[1:].eq(0).all()


@pytest.mark.parametrize("switch", ["hws_nonphysical", "ti_range", "availability"])
def test_every_filter_can_be_switched_off(switch):
    df = records(hws_mean_ms=[45.0] + [8.0] * 5, availability_pct=[10.0] + [90.0] * 5)
    on = run_qc(df, QCConfig(mad=False))
    off = run_qc(df, QCConfig(mad=False, **{switch: False}))
    reason = {"ti_range": "hws_out_of_ti_range", "availability": "low_availability"}.get(
        switch, switch
    )
    assert on.counts.loc[reason, "n_failed"] == 1
    assert off.counts.loc[reason, "n_failed"] == 0
    assert not off.counts.loc[reason, "enabled"]


def test_thresholds_are_configurable():
    df = records(availability_pct=[60.0, 70.0, 80.0, 90.0, 95.0, 99.0])
    assert failed(run_qc(df, QCConfig(availability_min_pct=85.0)), "low_availability") == [1, 2, 3]


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"sv_max": -0.1}, "QCConfig.sv_max must be a positive number"),
        ({"ti_hws_min_ms": 45.0}, "ti_hws_min_ms < ti_hws_max_ms"),
        ({"availability_min_pct": 120.0}, r"availability_min_pct must lie in \[0, 100\]"),
        ({"mad_min_records": 0}, "mad_min_records must be >= 1"),
        ({"std_pattern_min_factor": 1.0}, "std_pattern_min_factor must be > 1"),
        ({"std_pattern_k": 0.0}, "QCConfig.std_pattern_k must be a positive number"),
    ],
)
def test_bad_config_raises(kwargs, match):
    with pytest.raises(ValueError, match=match):
        QCConfig(**kwargs)


def test_missing_column_raises():
    with pytest.raises(
        ValueError, match=r"run_qc: record table lacks column\(s\) \['availability_pct'\]"
    ):
        run_qc(records().drop(columns="availability_pct"))


def test_qc_flags_and_summarise_conserve_counts():
    rec = read_records(DATA / "hand_written_campaign.csv")
    flags = run_qc(rec, QCConfig(hws_max_ms=20.0, sv_max=0.06)).flags
    assert len(flags) == len(rec)
    assert (flags["reasons"] == "").sum() == 19
    s = summarise(flags).set_index("reason")["n_failed"]
    assert s["all"] + s["kept"] == len(rec)
    assert s["sv_high"] == 4


# --------------------------------------------------------------------------- conservation
@st.composite
def random_records(draw):
    n = draw(st.integers(1, 60))
    seed = draw(st.integers(0, 2**32 - 1))
    rng = np.random.default_rng(seed)

    def col(lo, hi, p_nan=0.1):
        x = rng.uniform(lo, hi, n)
        x[rng.uniform(size=n) < p_nan] = np.nan
        return x

    t = pd.Timestamp("2015-04-01", tz="UTC") + pd.to_timedelta(
        np.sort(rng.choice(5000, n, replace=False)) * 10, unit="min"
    )
    df = pd.DataFrame(
        {
            "timestamp": t,
            "height_m": rng.choice([58.0, 85.0], n),
            "hws_mean_ms": col(0, 30),
            "hws_std_ms": col(0, 3),
            "wd_mean_deg": col(0, 360),
            "availability_pct": col(0, 100, 0.0),
            "roll_amplitude_deg": col(0, 6),
            "pitch_amplitude_deg": col(0, 6),
            "roll_period_s": col(1, 10),
            "pitch_period_s": col(1, 10),
        }
    )
    if draw(st.booleans()):
        df["sv"] = col(0, 0.2)
    if draw(st.booleans()):
        df["ref_hws_std_ms"] = col(0, 3)
    switches = {
        k: draw(st.booleans()) for k in ("mad", "sv", "relative_sigma", "imu_gap", "ti_range")
    }
    config = QCConfig(
        sv_max=draw(st.floats(0.01, 0.2)),
        availability_min_pct=draw(st.floats(0, 100)),
        mad_min_records=draw(st.integers(1, 10)),
        **switches,
    )
    return df, config, rng


@settings(max_examples=60, deadline=None)
@given(random_records())
def test_conservation_of_counts_hypothesis(case):
    df, config, _ = case
    r = run_qc(df, config)
    assert r.n_in == len(df) == r.n_kept + r.n_flagged
    assert len(r.flags) == len(df)
    assert list(r.flags.index) == list(df.index)
    assert r.flags["kept"].sum() == len(r.kept) == r.n_kept
    assert (r.flags["n_failed"] > 0).sum() == r.n_flagged
    for reason in RECORD_REASONS:
        assert r.counts.loc[reason, "n_failed"] == r.flags[f"fail_{reason}"].sum()
    assert ((r.flags["reasons"] == "") == r.flags["kept"]).all()
    pd.testing.assert_frame_equal(r.kept, df.loc[r.flags["kept"].to_numpy()])


@settings(max_examples=30, deadline=None)
@given(random_records())
def test_verdicts_do_not_depend_on_row_order_hypothesis(case):
    df, config, rng = case
    perm = rng.permutation(len(df))
    a = run_qc(df, config).flags
    b = run_qc(df.iloc[perm], config).flags.loc[df.index]
    fail = [f"fail_{r}" for r in RECORD_REASONS]
    pd.testing.assert_frame_equal(a[fail], b[fail])


def test_speed_bin_summary_says_what_each_filter_removed_per_bin():
    from flidar_uq.data.qc import speed_bin_summary

    rec = records(
        hws_mean_ms=[8.2, 7.9, 8.1, 45.0, 21.6, 22.4], availability_pct=[90.0] * 5 + [10.0]
    )
    r = run_qc(rec, QCConfig(mad=False))
    table = speed_bin_summary(rec, r.flags, hws_width_ms=1.0).set_index("hws_bin_ms")
    assert table.loc[8.0, "n_in"] == 3 and table.loc[8.0, "n_kept"] == 3
    assert table.loc[45.0, "hws_nonphysical"] == 1 and table.loc[45.0, "n_kept"] == 0
    assert table.loc[22.0, ["n_in", "n_kept", "low_availability"]].tolist() == [2, 1, 1]
    assert table["n_in"].sum() == len(rec) and table["n_kept"].sum() == r.n_kept
