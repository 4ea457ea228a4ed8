"""HWS x amplitude x period binning (flidar_uq.data.binning), Gutiérrez-Antuñano et al. (2018), Sec. 3.1 and Table 1."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from flidar_uq.data.binning import (
    add_harmonic_motion,
    assign_batches,
    bin_centre,
    bin_label,
    bin_records,
    bins_for_fitting,
    speed_bin_ms,
)


def rec(hws, amp_roll, amp_pitch, per_roll, per_pitch) -> pd.DataFrame:
    return pd.DataFrame(
        {
            "hws_mean_ms": hws,
            "roll_amplitude_deg": amp_roll,
            "pitch_amplitude_deg": amp_pitch,
            "roll_period_s": per_roll,
            "pitch_period_s": per_pitch,
        }
    )


def test_gutierrez2018_edges_half_open_centred_on_integers():
    # Gutiérrez-Antuñano et al. (2018), Sec. 3.1: edges [0.5, 1.5), [1.5, 2.5), ...
    x = [0.5, 1.4999, 1.5, 2.49, 7.5, 8.49999]
    assert bin_centre(x, 1.0).tolist() == [1.0, 1.0, 2.0, 2.0, 8.0, 8.0]
    assert bin_centre([0.74, 0.76, 1.26], 0.5).tolist() == [0.5, 1.0, 1.5]
    with pytest.raises(ValueError, match="width must be > 0"):
        bin_centre([1.0], 0.0)


def test_bin_label_is_stable_text():
    assert bin_label(8, 3, 4) == "H08_A03_T04"
    assert bin_label(12.5, 0.0, 10.0) == "H12p5_A00_T10"


def test_binning_uses_roll_pitch_means_gutierrez2018_sec24():
    # amplitude (2.4 + 3.4)/2 = 2.9 -> 3 ; period (3.2 + 4.6)/2 = 3.9 -> 4
    assigned, table = bin_records(rec([8.2], [2.4], [3.4], [3.2], [4.6]))
    assert assigned["bin_id"].tolist() == ["H08_A03_T04"]
    assert table[["hws_ms", "amplitude_deg", "period_s", "count"]].iloc[0].tolist() == [
        8.0,
        3.0,
        4.0,
        1,
    ]


def test_table_sorted_by_frequency_with_table1_columns():
    # 3 records in H08_A03_T04, 2 in H05_A02_T04, 2 in H04_A02_T03, 1 in H09_A03_T04
    df = rec(
        [8.1, 7.9, 8.3, 5.0, 5.2, 4.1, 3.9, 9.0],
        [3.0, 3.1, 2.9, 2.0, 2.1, 2.0, 2.0, 3.0],
        [3.0, 3.1, 2.9, 2.0, 2.1, 2.0, 2.0, 3.0],
        [4.0, 4.1, 3.9, 4.0, 4.2, 3.0, 3.1, 4.0],
        [4.0, 4.1, 3.9, 4.0, 4.2, 3.0, 3.1, 4.0],
    )
    assigned, table = bin_records(df, min_count=2)
    assert list(table.columns) == [
        "case_no",
        "bin_id",
        "hws_ms",
        "amplitude_deg",
        "period_s",
        "count",
        "below_min_count",
    ]
    assert table["bin_id"].tolist() == [
        "H08_A03_T04",
        "H04_A02_T03",
        "H05_A02_T04",
        "H09_A03_T04",
    ]  # ties by HWS
    assert table["case_no"].tolist() == [1, 2, 3, 4]
    assert table["count"].tolist() == [3, 2, 2, 1]
    assert table["below_min_count"].tolist() == [False, False, False, True]
    assert assigned["case_no"].tolist() == [1, 1, 1, 3, 3, 2, 2, 4]
    assert assigned["below_min_count"].tolist() == [False] * 7 + [True]


def test_configurable_widths():
    df = rec([8.2, 8.4], [2.6, 2.9], [2.6, 2.9], [4.0, 4.0], [4.0, 4.0])
    _, t1 = bin_records(df)
    _, t2 = bin_records(df, hws_width_ms=0.5, amplitude_width_deg=0.5, period_width_s=2.0)
    assert len(t1) == 1 and t1["bin_id"].iloc[0] == "H08_A03_T04"
    assert t2["bin_id"].tolist() == ["H08_A02p5_T04", "H08p5_A03_T04"]


def test_records_without_motion_are_kept_unbinned_and_counted():
    df = rec(
        [8.0, 8.0, np.nan], [3.0, np.nan, 3.0], [3.0, 3.0, 3.0], [4.0, 4.0, 4.0], [4.0, 4.0, 4.0]
    )
    assigned, table = bin_records(df)
    assert len(assigned) == 3
    assert assigned["case_no"].tolist() == [1, -1, -1]
    assert assigned["bin_id"].isna().tolist() == [False, True, True]
    assert table.attrs["n_unbinned"] == 2 and table.attrs["n_binned"] == 1


@settings(max_examples=40, deadline=None)
@given(st.integers(0, 2**32 - 1), st.integers(1, 300), st.sampled_from([0.5, 1.0, 2.0]))
def test_counts_conserved_and_ids_consistent_hypothesis(seed, n, width):
    rng = np.random.default_rng(seed)
    df = rec(
        rng.uniform(0, 25, n),
        rng.uniform(0, 6, n),
        rng.uniform(0, 6, n),
        rng.uniform(1, 10, n),
        rng.uniform(1, 10, n),
    )
    assigned, table = bin_records(df, hws_width_ms=width, amplitude_width_deg=width, min_count=3)
    assert table["count"].sum() == n == len(assigned)
    assert (np.diff(table["count"]) <= 0).all()
    assert table["bin_id"].is_unique
    counts = assigned["bin_id"].value_counts()
    assert (table.set_index("bin_id")["count"] == counts.loc[table["bin_id"]].to_numpy()).all()
    # every record lies inside its bin
    assert (np.abs(assigned["hws_mean_ms"] - assigned["hws_bin_ms"]) <= width / 2 + 1e-12).all()


def test_speed_bin_ms_centred_on_multiples_upper_edge_goes_up():
    """IEC 61400-12-1: bins centred on integer multiples of the width; an edge value
    goes to the upper bin (not numpy's round-half-to-even, 2.5 -> 2)."""
    np.testing.assert_array_equal(
        speed_bin_ms([0.49, 0.5, 2.5, 3.49, 7.999, np.nan]), [0.0, 1.0, 3.0, 3.0, 8.0, np.nan]
    )
    np.testing.assert_array_equal(speed_bin_ms([0.9, 1.0, 2.99, 3.0], 2.0), [0.0, 2.0, 2.0, 4.0])


def test_one_speed_bin_rule_for_bins_speed_bins_and_plots():
    """Bin table and the per-record speed bins agree on an edge value."""
    hws = np.array([2.5, 2.5, 3.4, 4.5])
    records = pd.DataFrame(
        {"hws_mean_ms": hws, "amplitude_deg": 1.0, "period_s": 4.0, "hws_std_ms": 0.3}
    )
    _, table = bin_records(records, min_count=1)
    assert sorted(table["hws_ms"]) == sorted(set(speed_bin_ms(hws)))


def test_add_harmonic_motion_is_mean_of_roll_and_pitch_gutierrez2018_sec24():
    rec = pd.DataFrame(
        {
            "roll_amplitude_deg": [2.0, 3.0],
            "pitch_amplitude_deg": [4.0, 3.5],
            "roll_period_s": [3.0, 4.0],
            "pitch_period_s": [5.0, 4.5],
        }
    )
    out = add_harmonic_motion(rec)
    assert out["amplitude_deg"].tolist() == [3.0, 3.25]
    assert out["period_s"].tolist() == [4.0, 4.25]


def test_assign_batches_balances_counts_and_is_deterministic():
    counts = [30, 27, 10, 10, 8, 3, 2, 2, 2, 2]
    batch = assign_batches(counts, 2)
    load = np.bincount(batch, weights=np.asarray(counts) + 1.0, minlength=2)
    assert set(batch) == {0, 1}
    assert abs(load[0] - load[1]) <= max(counts) + 1  # LPT bound
    np.testing.assert_array_equal(batch, assign_batches(counts, 2))
    assert set(assign_batches(counts, 20)) <= set(range(20))
    with pytest.raises(ValueError, match="nbatches must be >= 1, got 0"):
        assign_batches(counts, 0)


def test_bins_for_fitting_integer_ids_fitted_bins_and_batches():
    # three records in H08_A02_T04, two in H10_A02_T04, one in H05_A01_T03
    r = add_harmonic_motion(
        rec(
            [8.1, 7.9, 8.2, 10.0, 10.3, 5.0],
            [2.0, 2.1, 1.9, 2.0, 2.2, 1.0],
            [2.0, 2.1, 1.9, 2.0, 2.2, 1.0],
            [4.0, 4.1, 3.9, 4.0, 4.2, 3.0],
            [4.0, 4.1, 3.9, 4.0, 4.2, 3.0],
        )
    )
    widths = dict(hws_width_ms=1.0, amplitude_width_deg=1.0, period_width_s=1.0)
    assigned, table = bins_for_fitting(r, **widths, min_count=2, nbatches=2)
    assert table["bin_id"].tolist() == [1, 2, 3]
    assert table["bin_label"].tolist() == ["H08_A02_T04", "H10_A02_T04", "H05_A01_T03"]
    assert table["count"].tolist() == [3, 2, 1]
    assert table["fitted"].tolist() == [True, True, False]
    assert table["batch"].tolist() == [0, 1, -1]
    assert sorted(assigned["bin_id"]) == [1, 1, 1, 2, 2, 3]
    assert list(assigned.index) == list(range(6))
