"""Validation statistics against a reference, checked on small tables by hand."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from flidar_uq.validation.reference import (
    agreement,
    agreement_by_speed_bin,
    holdout_mask,
    iec_category,
    iec_representative_ti,
    validation_summary,
    withhold_reference,
)

REF = np.array([0.10, 0.12, 0.14, 0.16])
EST = np.array([0.11, 0.12, 0.16, 0.17])


def test_agreement_matches_hand_computed_values():
    # d = [0.01, 0, 0.02, 0.01]; reference deviations [-3, -1, 1, 3] e-2, estimate's
    # [-3, -2, 2, 3] e-2: sxx = 20e-4, sxy = 22e-4, syy = 26e-4
    a = agreement(EST, REF)
    assert a.n == 4
    assert a.bias == pytest.approx(0.01)
    assert a.bias_rel == pytest.approx(0.01 / 0.13)
    assert a.rmse == pytest.approx(np.sqrt(6e-4 / 4))
    assert a.slope == pytest.approx(1.1)
    assert a.offset == pytest.approx(0.14 - 1.1 * 0.13)
    assert a.r2 == pytest.approx(22**2 / (20 * 26))


def test_agreement_ignores_nan_pairs_and_is_nan_without_pairs():
    a = agreement(np.r_[EST, np.nan, 0.3], np.r_[REF, 0.2, np.nan])
    assert a == agreement(EST, REF)
    empty = agreement([np.nan], [0.1])
    assert empty.n == 0 and np.isnan(empty.bias) and np.isnan(empty.r2)
    flat = agreement([0.1, 0.2], [0.1, 0.1])
    assert flat.n == 2 and np.isnan(flat.slope) and flat.bias == pytest.approx(0.05)
    with pytest.raises(ValueError, match="shapes differ"):
        agreement([0.1], [0.1, 0.2])


def test_agreement_by_speed_bin_and_representative_ti_error_by_hand():
    # bin 8 m/s: the four pairs above; bin 10 m/s: one pair (below min_count)
    hws = np.r_[7.6, 8.0, 8.2, 8.4, 10.1]
    tab = agreement_by_speed_bin(hws, np.r_[EST, 0.2], np.r_[REF, 0.1], min_count=3)
    assert tab["hws_bin_ms"].tolist() == [8.0, 10.0]
    assert tab["n"].tolist() == [4, 1]
    row = tab.iloc[0]
    rep_ref = 0.13 + 1.28 * np.sqrt(20e-4 / 3)  # mean + 1.28 sample std
    rep_est = 0.14 + 1.28 * np.sqrt(26e-4 / 3)
    assert row["ti_rep_reference"] == pytest.approx(rep_ref)
    assert row["ti_rep_estimate"] == pytest.approx(rep_est)
    assert row["ti_rep_error"] == pytest.approx(rep_est - rep_ref)
    assert row["ti_rep_error_rel"] == pytest.approx((rep_est - rep_ref) / rep_ref)
    assert row["slope"] == pytest.approx(1.1) and row["rmse"] == pytest.approx(np.sqrt(1.5e-4))
    assert np.isnan(tab.iloc[1]["bias"]) and np.isnan(tab.iloc[1]["ti_rep_error"])


def test_iec_category_at_15_ms():
    # the category curves at 15 m/s: I_ref (0.75 + 5.6 / 15) = 1.12333 I_ref
    np.testing.assert_allclose(iec_representative_ti(15.0, 0.12), 0.12 * (0.75 + 5.6 / 15))
    assert iec_category(0.10) == "C"
    assert iec_category(0.12 * 1.1233) == "C"
    assert iec_category(0.12 * 1.1234) == "B"
    assert iec_category(0.17) == "A"
    assert iec_category(0.19) == "A+"
    assert iec_category(0.25) == "above A+"
    assert iec_category(np.nan) == ""


def test_holdout_mask_alternate_weeks_and_last_days():
    t = pd.date_range("2026-01-12", periods=28, freq="D", tz="UTC")  # Monday, 4 weeks
    held = holdout_mask(t, mode="alternate_weeks")
    week = np.arange(28) // 7
    # 2026-01-12 starts week 2923 after Monday 1970-01-05 (20461 days): odd, held out
    assert (t[0] - pd.Timestamp("1970-01-05", tz="UTC")).days == 20461 == 7 * 2923
    np.testing.assert_array_equal(held, week % 2 == 0)
    # a subset of the records is split the same way
    np.testing.assert_array_equal(holdout_mask(t[5:20], mode="alternate_weeks"), held[5:20])
    last = holdout_mask(t, mode="last_days", days=3)
    np.testing.assert_array_equal(last, np.arange(28) >= 25)
    sub = holdout_mask(t[:20], mode="last_days", days=3, end=t[-1])
    assert not sub.any()
    assert not holdout_mask(t, mode="none").any()
    with pytest.raises(ValueError, match="mode='weekly'"):
        holdout_mask(t, mode="weekly")


def test_withhold_reference_blanks_only_the_held_out_reference():
    rec = pd.DataFrame({"hws_std_ms": [1.0, 2.0], "ref_hws_std_ms": [1.1, 2.1],
                        "ref_hws_mean_ms": [8.0, 9.0]})  # fmt: skip
    out = withhold_reference(rec, [False, True])
    assert out["ref_hws_std_ms"].tolist()[0] == 1.1 and np.isnan(out["ref_hws_std_ms"].iloc[1])
    assert np.isnan(out["ref_hws_mean_ms"].iloc[1]) and out["hws_std_ms"].tolist() == [1.0, 2.0]
    assert rec["ref_hws_std_ms"].tolist() == [1.1, 2.1]  # a copy


def test_validation_summary_splits_held_out_and_in_sample():
    rec = pd.DataFrame(
        {
            "ti_ref": np.r_[REF, REF],
            "ti_corrected_median": np.r_[EST, REF],
            "ti_corrected_lo": np.r_[EST, REF] - 0.005,
            "ti_corrected_hi": np.r_[EST, REF] + 0.005,
            "ti_uncorrected": np.r_[EST, REF] + 0.02,
        }
    )
    held = np.r_[[True] * 4, [False] * 4]
    tab = validation_summary(rec, held).set_index(["sample", "estimate"])
    ho = tab.loc[("held out", "corrected")]
    assert ho["n"] == 4 and ho["slope"] == pytest.approx(1.1) and ho["bias"] == pytest.approx(0.01)
    assert ho["coverage"] == pytest.approx(0.25)  # only the equal pair lies within 0.005
    ins = tab.loc[("in sample", "corrected")]
    assert ins["bias"] == pytest.approx(0.0) and ins["coverage"] == 1.0
    assert tab.loc[("in sample", "uncorrected")]["bias"] == pytest.approx(0.02)
    assert np.isnan(tab.loc[("in sample", "uncorrected")]["coverage"])
    # a fixed reference lidar: the point value times g; everything held out (trial fit)
    scaled = validation_summary(rec, held, reference_scale=np.full(8, 2.0), all_held_out=True)
    assert scaled["sample"].unique().tolist() == ["held out"]
    row = scaled.set_index("estimate").loc["corrected"]
    assert row["n"] == 8 and row["bias"] == pytest.approx(np.mean(np.r_[EST, REF]) * 2 - 0.13)
