"""Record inspection (flidar_uq.data.inspection): sampling gaps, reference problems and the
report of what the pipeline will find in a record table, against hand-computed answers."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from flidar_uq.data import io
from flidar_uq.data.inspection import inspect_records, reference_problems, sampling_gaps

DESCRIPTIONS = ("tilt_bands", "along_wind", "roll_pitch", "none")


def records(n_times: int = 12, drop=(), reference_std: bool = True) -> pd.DataFrame:
    """Validated 10-min records at 80 and 100 m; ``drop``: time indices missing at 80 m."""
    rng = np.random.default_rng(np.random.SeedSequence(11))
    t = pd.date_range("2016-05-01T00:00:00Z", periods=n_times, freq="10min")
    n = 2 * n_times
    hws = rng.uniform(5, 14, n)
    df = pd.DataFrame(
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
    if not reference_std:
        df = df.drop(columns="ref_hws_std_ms")
    gone = [2 * i for i in drop]  # the 80 m row of time index i
    df = df.drop(index=gone).reset_index(drop=True)
    return io.validate_records(df, "<test>")


def test_sampling_gaps_median_spacing_and_missing_records_hand_counted():
    # 80 m misses indices 3, 4 (one gap of 3 intervals, 2 records) and 8 (1 record)
    step, per_height = sampling_gaps(records(12, drop=(3, 4, 8)))
    assert step == 600.0
    at80, at100 = per_height
    assert at80 == {
        "height_m": 80.0,
        "n_records": 9,
        "n_gaps": 2,
        "missing_records": 3,
        "largest_gap_h": 0.5,
    }
    assert at100 == {
        "height_m": 100.0,
        "n_records": 12,
        "n_gaps": 0,
        "missing_records": 0,
        "largest_gap_h": round(600.0 / 3600.0, 3),
    }


def test_sampling_gaps_of_no_records_is_nan_spacing():
    step, per_height = sampling_gaps(records(3).iloc[:0])
    assert np.isnan(step) and per_height == []


def test_reference_problems_a_mean_without_a_std_blocks():
    assert reference_problems(records(4), "f.csv") == []
    (problem,) = reference_problems(records(4, reference_std=False), "f.csv")
    assert isinstance(problem, io.DataValidationError)
    assert "ref_hws_std_ms" in str(problem) and "is missing" in str(problem)
    assert reference_problems(records(4).drop(columns="ref_hws_mean_ms"), "f.csv") == []


def test_inspect_records_counts_gaps_reference_motion_and_qc():
    rec = records(12, drop=(3,))
    kinds = pd.Series(["roll_pitch"] * (len(rec) - 2) + ["none"] * 2, index=rec.index)
    got = inspect_records(rec, kinds, descriptions=DESCRIPTIONS, source="f.csv")
    assert got["n_records"] == 23
    assert got["heights_m"] == [80.0, 100.0]
    assert got["sampling"]["interval_s"] == 600.0
    assert got["sampling"]["per_height"][0]["missing_records"] == 1
    assert got["time_span"]["days"] == pytest.approx(round(11 * 600 / 86400, 3))
    assert got["reference"] == {"share_with_mean": 1.0, "share_with_std": 1.0}
    assert got["motion_description"] == {
        "tilt_bands": 0,
        "along_wind": 0,
        "roll_pitch": 21,
        "none": 2,
    }
    qc = got["qc_preview"]
    assert qc["n_kept"] + qc["n_flagged"] == 23
    assert got["blocking"] == []
    assert any("no_motion_description" in w for w in got["warnings"])
    assert "ref_hws_std_ms" in got["columns"]["present"]


def test_inspect_records_warns_on_few_reference_records_and_blocks_without_std():
    rec = records(3)
    kinds = pd.Series("roll_pitch", index=rec.index)
    got = inspect_records(rec, kinds, descriptions=DESCRIPTIONS)
    assert any("only 6 records with a reference std" in w for w in got["warnings"])
    rec = records(3, reference_std=False)
    got = inspect_records(rec, kinds, descriptions=DESCRIPTIONS, source="f.csv")
    assert len(got["blocking"]) == 1 and "ref_hws_std_ms" in got["blocking"][0]
