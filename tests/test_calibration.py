"""Calibration by regime (data/calibration.py): hand-computed groups and Wilson intervals."""

import numpy as np
import pandas as pd
import pytest

from flidar_uq.data.calibration import (
    HEIGHT_SUMMARY_COLUMNS,
    calibration_by_group,
    height_summary,
    speed_group_label,
    wilson_interval,
)


def test_wilson_interval_hand_value_and_edges():
    # Wilson (1927): k = 8 of n = 10 at 95 %: (0.4902, 0.9433)
    lo, hi = wilson_interval(8, 10)
    assert lo == pytest.approx(0.4902, abs=1e-4)
    assert hi == pytest.approx(0.9433, abs=1e-4)
    lo, hi = wilson_interval(0, 0)
    assert np.isnan(lo) and np.isnan(hi)
    lo, hi = wilson_interval(10, 10)
    assert hi == pytest.approx(1.0) and lo < 1.0


def test_speed_group_labels_half_open():
    lab = speed_group_label([2.9, 3.0, 5.99, 6.0, np.nan, 19.9])
    assert list(lab) == ["", "3-6 m/s", "3-6 m/s", "6-9 m/s", "", "18-21 m/s"]


def test_calibration_by_group_hand_computed():
    recs = pd.DataFrame(
        {
            "g": ["a", "a", "a", "b", "b"],
            "ti_true": [0.10, 0.10, 0.10, 0.05, 0.05],
            "ti_corrected_median": [0.11, 0.09, np.nan, 0.05, 0.06],
            "ti_corrected_lo": [0.105, 0.08, np.nan, 0.04, 0.055],
            "ti_corrected_hi": [0.12, 0.11, np.nan, 0.06, 0.07],
        }
    )
    out = calibration_by_group(recs, "g").set_index("g")
    assert out.loc["a", "n"] == 3 and out.loc["a", "n_answered"] == 2
    assert out.loc["a", "answered_share"] == pytest.approx(2 / 3)
    assert out.loc["a", "coverage"] == pytest.approx(0.5)  # 0.10 outside [0.105, 0.12]
    assert out.loc["a", "mean_rel_error"] == pytest.approx(0.0)
    assert out.loc["b", "coverage"] == pytest.approx(0.5)
    assert out.loc["b", "mean_rel_error"] == pytest.approx(0.1)
    # errors (0.1, -0.1) and (0.0, 0.2): sample sd 0.1414 over sqrt(2) = 0.1
    assert out.loc["a", "mean_rel_error_se"] == pytest.approx(0.1)
    assert out.loc["b", "mean_rel_error_se"] == pytest.approx(0.1)
    assert out.loc["b", "median_rel_width"] == pytest.approx(np.median([0.4, 0.25]))


def test_mean_error_standard_error_shrinks_as_one_over_root_n_and_needs_two_records():
    rng = np.random.default_rng(7)
    n = 400
    err = rng.normal(0.0, 0.1, n)
    recs = pd.DataFrame(
        {
            "g": ["big"] * n + ["one"],
            "ti_true": np.full(n + 1, 0.1),
            "ti_corrected_median": 0.1 * (1.0 + np.append(err, 0.05)),
            "ti_corrected_lo": np.full(n + 1, 0.05),
            "ti_corrected_hi": np.full(n + 1, 0.2),
        }
    )
    out = calibration_by_group(recs, "g").set_index("g")
    assert out.loc["big", "mean_rel_error_se"] == pytest.approx(err.std(ddof=1) / 20.0)
    assert 0.004 < out.loc["big", "mean_rel_error_se"] < 0.006  # 0.1 / sqrt(400) = 0.005
    assert np.isnan(out.loc["one", "mean_rel_error_se"])


def test_calibration_by_group_names_missing_column():
    with pytest.raises(ValueError, match="lack column 'ti_true'"):
        calibration_by_group(pd.DataFrame({"g": [1]}), "g")


def test_height_summary_counts_campaign_means_and_coverage_by_hand():
    nan = np.nan
    records = pd.DataFrame(
        {
            "height_m": [40.0, 40.0, 40.0, 90.0, 90.0],
            "ti_corrected_median": [0.10, 0.12, nan, 0.08, 0.09],
            "ti_corrected_lo": [0.09, 0.11, nan, 0.07, 0.08],
            "ti_corrected_hi": [0.11, 0.13, nan, 0.09, 0.10],
            "ti_true": [0.105, 0.20, 0.1, nan, 0.085],
        }
    )
    groups = pd.DataFrame(
        {
            "grouping": ["campaign", "speed_bin", "campaign"],
            "height_m": [40.0, 40.0, 90.0],
            "ti_mean": [0.11, 0.5, 0.085],
            "ti_mean_lo": [0.10, 0.4, 0.08],
            "ti_mean_hi": [0.12, 0.6, 0.09],
            "ti_mean_uncorrected": [0.13, 0.7, 0.10],
        }
    )
    metrics = pd.DataFrame({"reference_kind": ["cup"], "credible_mass": [0.9]})
    got = height_summary(records, groups, metrics)
    assert list(got.columns) == list(HEIGHT_SUMMARY_COLUMNS)
    assert got["height_m"].tolist() == [40.0, 90.0]
    assert got["n_records"].tolist() == [3, 2]
    assert got["n_corrected"].tolist() == [2, 2]
    assert got["n_truth"].tolist() == [2, 1]
    np.testing.assert_allclose(got["coverage"], [1 / 2, 1.0])  # 0.20 outside [0.11, 0.13]
    np.testing.assert_allclose(got["ti_mean"], [0.11, 0.085])  # the campaign rows only
    assert got["reference_kind"].tolist() == ["cup", "cup"]
    assert got["credible_mass"].tolist() == [0.9, 0.9]
    without_truth = height_summary(records.drop(columns="ti_true"), groups, metrics.iloc[:0])
    assert without_truth["coverage"].isna().all() and (without_truth["n_truth"] == 0).all()
    assert without_truth["reference_kind"].tolist() == ["", ""]
