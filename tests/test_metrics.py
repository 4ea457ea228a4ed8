"""Comparison metrics (flidar_uq.data.metrics) against hand-computed values."""

from __future__ import annotations

import numpy as np
import pytest

from flidar_uq.data import metrics


def test_md_rmse_gutierrez2018_eqs18_19_hand_computed():
    moving = [0.50, 0.70, 0.90, 0.60]
    corr = [0.40, 0.80, 0.60, 0.60]
    # differences 0.1, -0.1, 0.3, 0.0 -> MD = 0.3/4 = 0.075, RMSE = sqrt(0.11/4) = 0.16583
    assert metrics.mean_deviation(moving, corr) == pytest.approx(0.075)
    assert metrics.rmse(moving, corr) == pytest.approx(np.sqrt(0.11 / 4))


def test_removable_error_removed_hand_computed():
    """(U - C) / (U - F): a wave follower's published RMSE (uncorrected 0.0081, corrected
    0.0044, the still lidar over g 0.0037) removes 37 / 44 of its removable error, where the
    share of the uncorrected RMSE is only 0.46; down to the floor is 1, nothing 0, worse than
    uncorrected negative; no removable error is refused."""
    assert metrics.removable_error_removed(0.0081, 0.0044, 0.0037) == pytest.approx(37 / 44)
    assert metrics.removable_error_removed(0.02, 0.005, 0.005) == pytest.approx(1.0)
    assert metrics.removable_error_removed(0.02, 0.02, 0.005) == 0.0
    assert metrics.removable_error_removed(0.02, 0.026, 0.005) == pytest.approx(-0.4)
    with pytest.raises(ValueError, match="rmse_uncorrected=0.004 must be above rmse_floor"):
        metrics.removable_error_removed(0.004, 0.003, 0.004)


def test_md_sign_is_moving_minus_reference():
    # Gutiérrez-Antuñano et al. (2018): a positive MD means the floating lidar sees the larger std
    assert metrics.mean_deviation([1.0], [0.8]) == pytest.approx(0.2)


def test_md_rmse_ignore_nan_pairs_and_empty_is_nan():
    assert metrics.mean_deviation([1.0, np.nan, 3.0], [0.0, 1.0, 1.0]) == pytest.approx(1.5)
    assert np.isnan(metrics.rmse([np.nan], [1.0]))


def test_shape_mismatch_raises():
    with pytest.raises(ValueError, match=r"rmse: shapes differ, \(2,\) vs \(3,\)"):
        metrics.rmse([1, 2], [1, 2, 3])


def test_ape_malekmohammadi2024_eq11_hand_computed():
    np.testing.assert_allclose(metrics.ape_pct([10.0, 8.0, 5.0], [9.5, 8.4, 5.0]), [5.0, 5.0, 0.0])
    assert np.isnan(metrics.ape_pct(0.0, 1.0))


def test_pearson_r_hand_computed():
    # x = 1,2,3,4 ; y = 2,1,4,3: dx = -1.5,-.5,.5,1.5 ; dy = -.5,-1.5,1.5,.5
    # sum dxdy = .75+.75+.75+.75 = 3 ; sum dx^2 = sum dy^2 = 5 -> r = 0.6
    assert metrics.pearson_r([1, 2, 3, 4], [2, 1, 4, 3]) == pytest.approx(0.6)
    assert np.isnan(metrics.pearson_r([1, 1, 1], [1, 2, 3]))


def test_ti_and_representative_ti_hand_computed():
    np.testing.assert_allclose(
        metrics.turbulence_intensity([0.5, 1.0], [10.0, 0.0]), [0.05, np.nan]
    )
    # mean 0.08, sample std of (0.06, 0.08, 0.10) = 0.02 -> 0.08 + 1.28*0.02 = 0.1056
    assert metrics.representative_ti([0.06, 0.08, 0.10]) == pytest.approx(0.1056)


def test_md_rmse_counts_finite_pairs():
    md, rmse, n = metrics.md_rmse([1.0, np.nan, 3.0], [0.0, 1.0, 1.0])
    assert (md, n) == (pytest.approx(1.5), 2)
    assert rmse == pytest.approx(np.sqrt((1.0 + 4.0) / 2))


def test_interval_coverage_over_used_records_with_finite_reference():
    ref = np.array([0.10, 0.20, np.nan, 0.40])
    lo, hi = np.full(4, 0.15), np.full(4, 0.30)
    used = np.array([True, True, True, False])
    # used and finite: records 0 (outside) and 1 (inside)
    assert metrics.interval_coverage(ref, lo, hi, used) == pytest.approx(0.5)


def test_score_estimates_hand_computed():
    import pandas as pd

    rec = pd.DataFrame(
        {
            "hws_std_ms": [1.0, 1.2, 1.0],
            "ti_uncorrected": [0.10, 0.12, 0.10],
            "ti_corrected_median": [0.08, 0.10, np.nan],  # record 2 not scored
            "ti_corrected_lo": [0.07, 0.09, np.nan],
            "ti_corrected_hi": [0.09, 0.095, np.nan],
            "std_corrected_median_ms": [0.8, 1.0, np.nan],
            "lidar_std_ratio": [1.0, 1.0, 1.0],
            **{f"ti_corrected_{k}": [0.09, 0.11, 0.09] for k in ("u", "c", "pc")},
            **{f"std_corrected_{k}_ms": [0.9, 1.1, 0.9] for k in ("u", "c", "pc")},
            "true_hws_std_ms": [0.8, 1.0, 5.0],
            "true_hws_mean_ms": [10.0, 10.0, 10.0],
        }
    )
    refs = metrics.reference_values(rec)
    assert list(refs) == ["truth"]
    np.testing.assert_allclose(refs["truth"][1], [0.08, 0.10, 0.5])
    s = metrics.score_estimates(rec, refs).set_index("method")
    assert list(s.columns) == metrics.SCORE_COLUMNS[:1] + metrics.SCORE_COLUMNS[2:]
    assert s.loc["uncorrected", "n"] == 2
    assert s.loc["uncorrected", "md_std_ms"] == pytest.approx(0.2)
    assert s.loc["Bayesian", "rmse_ti"] == pytest.approx(0.0)
    assert s.loc["Bayesian", "coverage"] == pytest.approx(0.5)  # 0.08 in, 0.10 above 0.095
    assert np.isnan(s.loc["U", "coverage"])
