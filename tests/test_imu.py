"""IMU motion statistics (flidar_uq.data.imu) against analytic answers."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st

from flidar_uq.data import imu

FS = 5.0  # Hz, Gutiérrez-Antuñano et al.'s (2018) IMU rate
T10 = np.arange(0, 600, 1 / FS)  # one 10-min window


def sine(amplitude_deg, period_s, phase_rad=0.0, t=T10):
    return amplitude_deg * np.sin(2 * np.pi * t / period_s + phase_rad)


def imu_frame(t_s, roll, pitch, t0=1.4274e9):
    return pd.DataFrame(
        {
            "timestamp": pd.to_datetime(
                np.round((t0 + t_s) * 1e6).astype(np.int64), unit="us", utc=True
            ),
            "roll_deg": roll,
            "pitch_deg": pitch,
        }
    )


# --------------------------------------------------------------------------- pure sinusoids
@pytest.mark.parametrize(
    ("amplitude_deg", "period_s", "phase_rad"), [(3.0, 4.0, 0.0), (1.2, 2.7, 1.0), (5.0, 8.3, 2.0)]
)
def test_pure_sinusoid_amplitude_estimators(amplitude_deg, period_s, phase_rad):
    x = sine(amplitude_deg, period_s, phase_rad)
    assert imu.amplitude_std_deg(x) == pytest.approx(amplitude_deg, rel=5e-3)
    # sampled crests fall up to half a sample from the true crest: cos(pi * dt / T) bound
    lower = amplitude_deg * np.cos(np.pi / (FS * period_s))
    assert lower - 1e-9 <= imu.amplitude_zero_crossing_deg(x) <= amplitude_deg + 1e-9


@pytest.mark.parametrize("period_s", [2.0, 3.3, 4.0, 7.5, 12.0])
def test_pure_sinusoid_period_estimators(period_s):
    x = sine(2.0, period_s, 0.4)
    assert imu.period_spectral_s(x, FS) == pytest.approx(period_s, rel=5e-3)
    assert imu.period_zero_crossing_s(x, FS) == pytest.approx(period_s, rel=1e-3)


def test_std_amplitude_analytic_over_whole_periods():
    # over N whole periods the linear detrend removes the sine's projection on the ramp,
    # cov(t, A sin wt)^2 / var(t) = A^2 * 12 / (w L)^2: amplitude A sqrt(1 - 24 / (2 pi N)^2)
    n_periods = 600 / 4.0
    expected = 3.0 * np.sqrt(1 - 24 / (2 * np.pi * n_periods) ** 2)
    assert imu.amplitude_std_deg(sine(3.0, 4.0)) == pytest.approx(expected, rel=1e-6)


def test_linear_trend_is_removed():
    x = sine(2.0, 4.0) + 0.01 * T10 + 5.0
    assert imu.amplitude_std_deg(x) == pytest.approx(2.0, rel=1e-3)
    assert imu.period_zero_crossing_s(x, FS) == pytest.approx(4.0, rel=1e-3)


# --------------------------------------------------------------------------- two tones
def test_two_tone_total_amplitude_is_root_sum_square():
    # docs/conventions.md: sqrt(2)*std of A1 sin + A2 sin is sqrt(A1^2 + A2^2)
    x = sine(3.0, 3.0) + sine(2.0, 9.0, 1.0)
    assert imu.amplitude_std_deg(x) == pytest.approx(np.hypot(3.0, 2.0), rel=5e-3)


@pytest.mark.parametrize(("p1", "p2", "w1"), [(3.0, 9.0, 0.7), (4.0, 11.0, 0.3), (2.5, 5.0, 0.5)])
def test_two_tone_peaks_and_variance_split(p1, p2, w1):
    total = 3.0
    x = sine(total * np.sqrt(w1), p1) + sine(total * np.sqrt(1 - w1), p2, 0.7)
    f, p = imu.motion_spectrum(x, FS)
    q1, q2, w = imu.two_peaks(f, p)
    assert q1 == pytest.approx(p1, rel=1e-2)
    assert q2 == pytest.approx(p2, rel=1e-2)
    assert w == pytest.approx(w1, abs=0.01)


def test_two_tone_dominant_period_is_stronger_tone():
    x = sine(1.0, 3.0) + sine(2.5, 9.0)
    assert imu.period_spectral_s(x, FS) == pytest.approx(9.0, rel=1e-2)


def test_single_tone_is_not_bimodal():
    x = sine(3.0, 4.0) + 0.05 * np.random.default_rng(np.random.SeedSequence(3)).standard_normal(
        T10.size
    )
    f, p = imu.motion_spectrum(x, FS)
    assert np.isnan(imu.two_peaks(f, p)).all()


def test_weak_second_tone_below_threshold_is_ignored():
    x = sine(3.0, 4.0) + sine(0.5, 10.0)  # variance ratio 0.028 < min_peak_ratio 0.1 in PSD
    f, p = imu.motion_spectrum(x, FS)
    assert np.isnan(imu.two_peaks(f, p)[0])


# --------------------------------------------------------------------------- noise
def test_white_noise_amplitude_is_sqrt2_sigma(rng):
    sigma = 0.8
    x = sigma * rng.standard_normal((20, T10.size))
    a = imu.amplitude_std_deg(x)
    # rel. sampling sd of a std from n = 3000 samples: 1/sqrt(2n) = 1.3 %; mean of 20 windows
    assert a.mean() == pytest.approx(np.sqrt(2) * sigma, rel=0.01)


def test_white_noise_zero_crossing_period_is_four_samples(rng):
    # i.i.d. symmetric samples change sign with probability 1/2 -> one up-crossing per 4 samples
    x = rng.standard_normal((20, T10.size))
    assert imu.period_zero_crossing_s(x, FS).mean() == pytest.approx(4 / FS, rel=0.02)


def test_gaussian_narrowband_zero_crossing_amplitude_is_sqrt_pi_over_2_sigma(rng):
    # random-phase sum of many close tones ~ narrow-band Gaussian; Rayleigh mean height/2
    t = np.arange(0, 3600, 1 / FS)
    f = np.linspace(0.24, 0.26, 200)
    x = np.sum(np.sin(2 * np.pi * f[:, None] * t + rng.uniform(0, 2 * np.pi, (200, 1))), axis=0)
    sigma = x.std()
    assert imu.amplitude_zero_crossing_deg(x) == pytest.approx(np.sqrt(np.pi / 2) * sigma, rel=0.05)


def test_spectral_period_robust_to_sensor_noise_zero_crossing_is_not(rng):
    # why the spectral peak is the default period estimator
    x = sine(2.0, 5.0) + 0.6 * rng.standard_normal(T10.size)
    assert imu.period_spectral_s(x, FS) == pytest.approx(5.0, rel=0.01)
    assert imu.period_zero_crossing_s(x, FS) < 0.9 * 5.0


# --------------------------------------------------------------------------- windows and gaps
def test_motion_statistics_windows_align_to_10_min_and_report_known_values():
    t = np.arange(0, 1800, 1 / FS)  # three windows starting on a 10-min boundary
    df = imu_frame(t, sine(3.0, 4.0, 0, t), sine(2.0, 5.0, 0.3, t), t0=1.4274e9)
    out = imu.motion_statistics(df)
    assert len(out) == 3
    assert (out["timestamp"].dt.minute % 10 == 0).all() and (out["timestamp"].dt.second == 0).all()
    np.testing.assert_allclose(out["roll_amplitude_deg"], 3.0, rtol=5e-3)
    np.testing.assert_allclose(out["pitch_amplitude_deg"], 2.0, rtol=5e-3)
    np.testing.assert_allclose(out["roll_period_s"], 4.0, rtol=5e-3)
    np.testing.assert_allclose(out["pitch_period_s"], 5.0, rtol=5e-3)
    np.testing.assert_allclose(out["imu_availability_pct"], 100.0)
    # 4 s and 5 s are 1.25 apart (< min_period_ratio 1.5): unimodal
    assert out["period2_s"].isna().all()


def test_bimodal_record_columns_from_series():
    t = np.arange(0, 600, 1 / FS)
    roll = sine(2.0 * np.sqrt(0.6), 3.0, 0, t) + sine(2.0 * np.sqrt(0.4), 10.0, 1.0, t)
    pitch = sine(2.0 * np.sqrt(0.6), 3.0, 2, t) + sine(2.0 * np.sqrt(0.4), 10.0, 0.2, t)
    out = imu.motion_statistics(imu_frame(t, roll, pitch))
    row = out.iloc[0]
    assert row["period1_s"] == pytest.approx(3.0, rel=0.01)
    assert row["period2_s"] == pytest.approx(10.0, rel=0.01)
    assert row["weight1"] == pytest.approx(0.6, abs=0.01)
    assert row["roll_amplitude_deg"] == pytest.approx(2.0, rel=0.01)


def test_gaps_random_missing_samples(rng):
    t = np.arange(0, 600, 1 / FS)
    keep = rng.uniform(size=t.size) > 0.1  # 10 % of samples lost
    df = imu_frame(t[keep], sine(3.0, 4.0, 0, t[keep]), sine(2.0, 6.0, 0, t[keep]))
    row = imu.motion_statistics(df).iloc[0]
    assert row["imu_availability_pct"] == pytest.approx(100 * keep.mean())
    assert row["roll_amplitude_deg"] == pytest.approx(3.0, rel=0.01)
    assert row["roll_period_s"] == pytest.approx(4.0, rel=0.01)
    assert row["pitch_period_s"] == pytest.approx(6.0, rel=0.01)


def test_long_gap_gives_nan_statistics_but_keeps_the_window():
    t = np.arange(0, 1200, 1 / FS)
    keep = ~((t >= 700) & (t < 850))  # 150 s lost in window 2 -> 75 % coverage
    df = imu_frame(t[keep], sine(3.0, 4.0, 0, t[keep]), sine(2.0, 4.0, 0, t[keep]))
    out = imu.motion_statistics(df, min_coverage_pct=80.0)
    assert out["imu_availability_pct"].round(6).tolist() == [100.0, 75.0]
    assert np.isfinite(out.iloc[0]["roll_amplitude_deg"])
    assert out.iloc[1][["roll_amplitude_deg", "roll_period_s", "pitch_amplitude_deg"]].isna().all()


def test_motion_statistics_arrays_are_the_frame_version_and_keep_empty_windows(rng):
    # three windows, the middle one without any finite sample; the frame version drops it
    t = np.arange(0, 1800, 1 / FS)
    roll, pitch = sine(3.0, 4.0, 0, t), sine(2.0, 6.0, 0.3, t) + 0.05 * rng.standard_normal(t.size)
    roll[(t >= 600) & (t < 1200)] = np.nan
    pitch[(t >= 600) & (t < 1200)] = np.nan
    df = imu_frame(t, roll, pitch, t0=1.4274e9)
    frame = imu.motion_statistics(df, min_coverage_pct=50.0)
    t_ns = pd.DatetimeIndex(df["timestamp"]).as_unit("ns").asi8
    start_ns, cols, present = imu.motion_statistics_arrays(
        t_ns, df[["roll_deg", "pitch_deg"]].to_numpy(), min_coverage_pct=50.0
    )
    assert present.tolist() == [True, False, True]
    assert set(cols) == set(imu.MOTION_STAT_COLUMNS)
    assert (pd.to_datetime(start_ns[present], utc=True) == frame["timestamp"]).all()
    for key in imu.MOTION_STAT_COLUMNS:  # bit for bit
        assert cols[key][present].tobytes() == frame[key].to_numpy().tobytes(), key
    assert np.isnan(cols["roll_amplitude_deg"][1]) and cols["imu_availability_pct"][1] == 0.0
    with pytest.raises(ValueError, match="amplitude_method"):
        imu.motion_statistics_arrays(t_ns, df[["roll_deg", "pitch_deg"]], amplitude_method="x")


def test_detrend_without_gaps_is_the_masked_computation_bit_for_bit(rng):
    # rows without a NaN take the unmasked shortcut; beside a row with a gap they take
    # the masked computation: the same bits either way (the generator relies on it)
    x = np.cumsum(rng.standard_normal((5, 3000)), axis=-1)
    gappy = x[0].copy()
    gappy[100:200] = np.nan
    fast = imu._detrend(x)
    masked = imu._detrend(np.vstack([x, gappy]))[:5]
    assert fast.tobytes() == masked.tobytes()
    assert imu._fill(x) is x  # nothing to fill: no copy
    # strided rows longer than NumPy's pairwise-summation block (20 Hz x 600 s), as the
    # statistics pass them (one axis of a (window, sample, axis) grid)
    grid = np.cumsum(rng.standard_normal((3, 12000, 2)), axis=1)
    strided = grid[..., 1]
    assert imu._detrend(strided).tobytes() == imu._detrend(np.ascontiguousarray(strided)).tobytes()
    long_gappy = strided[0].copy()
    long_gappy[5:9] = np.nan
    masked = imu._detrend(np.vstack([np.ascontiguousarray(strided), long_gappy]))[:3]
    assert imu._detrend(strided).tobytes() == masked.tobytes()
    filled = imu._fill(np.vstack([x, gappy]))
    assert np.isfinite(filled).all() and filled[:5].tobytes() == x.tobytes()


def test_zero_crossing_methods_selectable():
    t = np.arange(0, 600, 1 / FS)
    df = imu_frame(t, sine(3.0, 4.0, 0.1, t), sine(2.0, 6.0, 0.1, t))
    out = imu.motion_statistics(df, amplitude_method="zero_crossing", period_method="zero_crossing")
    assert out.iloc[0]["roll_period_s"] == pytest.approx(4.0, rel=2e-3)
    assert out.iloc[0]["pitch_amplitude_deg"] == pytest.approx(2.0, rel=0.01)


@pytest.mark.parametrize(
    ("kw", "match"),
    [
        ({"amplitude_method": "rms"}, "amplitude_method must be one of"),
        ({"period_method": "fft"}, "period_method must be one of"),
    ],
)
def test_unknown_method_raises(kw, match):
    t = np.arange(0, 60, 1 / FS)
    with pytest.raises(ValueError, match=match):
        imu.motion_statistics(imu_frame(t, sine(1, 4, 0, t), sine(1, 4, 0, t)), **kw)


def test_bad_band_raises():
    with pytest.raises(ValueError, match="0 < period_min_s < period_max_s"):
        imu.period_spectral_s(sine(1, 4), FS, period_min_s=5.0, period_max_s=2.0)


# --------------------------------------------------------------------------- records
def test_roll_pitch_correlation_linear_and_independent(rng):
    n = 500
    a = rng.uniform(1, 5, n)
    rec = pd.DataFrame(
        {
            "roll_amplitude_deg": a,
            "pitch_amplitude_deg": 0.8 * a + 0.3,
            "roll_period_s": rng.uniform(2, 6, n),
            "pitch_period_s": rng.uniform(2, 6, n),
        }
    )
    rec.loc[3, "roll_period_s"] = np.nan
    c = imu.roll_pitch_correlation(rec)
    assert c["r_amplitude"] == pytest.approx(1.0, abs=1e-12)
    assert abs(c["r_period"]) < 4 / np.sqrt(n)  # independent: r ~ N(0, 1/n)
    assert c["n"] == n - 1


def test_close_peaks_form_one_mode_and_far_peak_is_second():
    # roll 4.2 s (var 4.5) and pitch 4.0 s (var 2) are one mode (ratio 1.05 < 1.5);
    # pitch 10 s (var 0.5) is the second: weight1 = 6.5 / 7
    t = np.arange(0, 600, 1 / FS)
    roll = sine(3.0, 4.2, 0, t)
    pitch = sine(2.0, 4.0, 0, t) + sine(1.0, 10.0, 0.5, t)
    row = imu.motion_statistics(imu_frame(t, roll, pitch)).iloc[0]
    assert row["period2_s"] == pytest.approx(10.0, rel=0.01)
    assert row["period1_s"] == pytest.approx(4.2, rel=0.01)
    assert row["weight1"] == pytest.approx(6.5 / 7.0, abs=0.01)


@settings(max_examples=30, deadline=None)
@given(st.floats(0.3, 10.0), st.floats(2.0, 15.0), st.floats(0.0, 2 * np.pi))
def test_sinusoid_estimators_hypothesis(amplitude_deg, period_s, phase_rad):
    # any amplitude, period in the band and phase: default estimators recover A and T
    x = sine(amplitude_deg, period_s, phase_rad)
    assert imu.amplitude_std_deg(x) == pytest.approx(amplitude_deg, rel=0.01)
    assert imu.period_spectral_s(x, FS) == pytest.approx(period_s, rel=0.01)
    assert imu.amplitude_std_deg(2.5 * x) == pytest.approx(
        2.5 * imu.amplitude_std_deg(x), rel=1e-12
    )


def random_sea(specs, n_windows, rng):
    """Random-phase tilt series (n_windows, 3000) at 5 Hz with a sum of JONSWAP spectra."""
    from flidar_uq.physics.seastate import jonswap_spectrum

    f = np.arange(1, 1500) / 600.0
    s = sum(jonswap_spectrum(f, hs, tp, gamma) for hs, tp, gamma in specs)
    amp = np.sqrt(2 * s * (f[1] - f[0]))
    phase = rng.uniform(0, 2 * np.pi, (n_windows, f.size))
    arg = 2 * np.pi * f[:, None] * T10
    return (amp * np.cos(phase)) @ np.sin(arg) + (amp * np.sin(phase)) @ np.cos(arg)


def test_two_peaks_on_random_sea_false_alarm_and_detection(rng):
    # single-peaked wind sea (Tp 5 s): rarely called bimodal;
    # wind sea + swell (Tp 5 s, 12 s): always bimodal, variance split ~ Hs^2 ratio 1 / (1 + 0.64)
    # (one axis; measured false-alarm rate ~1-4 % over seeds, binomial sd ~1.5 % for n = 100)
    n = 100
    f, p = imu.motion_spectrum(random_sea([(1.0, 5.0, 3.3)], n, rng), FS)
    assert np.isfinite(imu.two_peaks(f, p)[1]).mean() <= 0.07
    f, p = imu.motion_spectrum(random_sea([(1.0, 5.0, 3.3), (0.8, 12.0, 5.0)], n, rng), FS)
    p1, p2, w1 = imu.two_peaks(f, p)
    assert np.isfinite(p2).mean() >= 0.95
    assert np.nanmedian(p1) == pytest.approx(5.0, rel=0.05)
    assert np.nanmedian(p2) == pytest.approx(12.0, rel=0.05)
    assert np.nanmedian(w1) == pytest.approx(1 / 1.64, abs=0.06)


def test_float_timestamp_jitter_does_not_drift_over_a_day():
    # epoch seconds as float64 carry ~0.2 us jitter; the rate estimate must not drift a
    # sample per day (which would open a spurious 145th window and shift the grid)
    t = np.arange(0, 86400, 0.1)
    df = pd.DataFrame(
        {
            "timestamp": pd.to_datetime(1.4274e9 + t, unit="s", utc=True),
            "roll_deg": sine(2.0, 4.0, 0, t),
            "pitch_deg": sine(2.0, 4.0, 1, t),
        }
    )
    out = imu.motion_statistics(df, bimodal=False)
    assert len(out) == 144
    np.testing.assert_allclose(out["imu_availability_pct"], 100.0)


# --------------------------------------------------------------------------- wind-frame tilt spectrum
def test_heading_mean_is_circular_and_skips_missing_samples():
    # a heading swinging through north averages to north, not south
    yaw = np.array([[350.0, 10.0, 355.0, 5.0], [170.0, -170.0, np.nan, 180.0]])
    np.testing.assert_allclose(imu.heading_mean_deg(yaw), [0.0, 180.0], atol=1e-9)
    assert np.isnan(imu.heading_mean_deg([np.nan, np.nan]))
    # a yawing buoy (sine about 40 deg, +-25 deg) in a series: the mean of the record
    t = np.arange(0, 600, 1 / FS)
    frame = imu_frame(t, 0 * t, sine(3.0, 4.0, t=t))
    frame["yaw_deg"] = 40.0 + 25.0 * np.sin(2 * np.pi * t / 60.0)
    wd = pd.Series([90.0], index=pd.to_datetime([1.4274e9], unit="s", utc=True))
    table, _ = imu.tilt_spectrum_statistics_by_height(frame, {0: wd})[0]
    assert table.heading_mean_deg[0] == pytest.approx(40.0, abs=1e-6)
    # no yaw column: the heading is unknown (the tilt is still projected with heading 0)
    table, _ = imu.tilt_spectrum_statistics_by_height(frame.drop(columns="yaw_deg"), {0: wd})[0]
    assert np.isnan(table.heading_mean_deg[0])


def test_tilt_spectrum_statistics_uses_yaw_column_and_record_wind_direction():
    t = np.arange(0, 1200, 1 / FS)  # two windows
    x = sine(3.0, 4.0, t=t)
    frame = imu_frame(t, 0 * x, x)
    frame["yaw_deg"] = 0.0
    wd = pd.Series(
        [90.0, 0.0], index=pd.to_datetime([1.4274e9, 1.4274e9 + 600], unit="s", utc=True)
    )
    table, spec = imu.tilt_spectrum_statistics_by_height(frame, {0: wd})[0]
    assert list(table.columns) == ["timestamp", *imu.TILT_SPECTRUM_COLUMNS, "heading_mean_deg"]
    assert len(table) == 2 and spec.var_along_deg2.shape == (2, 8)
    np.testing.assert_allclose(table.heading_mean_deg, 0.0, atol=1e-12)
    # window 1: pitch tilts east, wind along east-west -> all along; window 2: all across
    assert table.tilt_along_wind_std_deg[0] * np.sqrt(2) == pytest.approx(3.0, rel=1e-2)
    assert table.tilt_across_wind_std_deg[0] < 1e-6
    assert table.tilt_along_wind_std_deg[1] < 1e-6
    assert table.tilt_across_wind_std_deg[1] * np.sqrt(2) == pytest.approx(3.0, rel=1e-2)
    assert table.tilt_period_zero_crossing_s[0] == pytest.approx(4.0, rel=1e-2)
    assert table.tilt_period_mean_s[0] == pytest.approx(4.0, rel=1e-2)


def test_tilt_spectrum_statistics_missing_wind_direction_gives_nan_row():
    x = sine(3.0, 4.0)
    frame = imu_frame(T10, x, x)  # no yaw column: heading 0
    table, spec = imu.tilt_spectrum_statistics_by_height(frame, {0: pd.Series(dtype=float)})[0]
    assert len(table) == 1 and table[list(imu.TILT_SPECTRUM_COLUMNS)].isna().all(axis=None)
    assert np.isnan(spec.var_along_deg2).all()


def test_tilt_statistics_of_several_heights_at_once_equal_one_call_each_bit_for_bit(rng):
    # the IMU step's streamed path grids and turns the attitude once for all heights; the
    # same tables and spectra as one call per height (gaps, a yawing buoy, a window
    # without a wind direction at one height, a callable source)
    t = np.arange(0, 1800, 1 / FS)  # three windows
    roll = sine(2.0, 5.0, 0.3, t) + 0.05 * rng.standard_normal(t.size)
    frame = imu_frame(t, roll, sine(3.0, 7.0, 0.0, t) + 0.05 * rng.standard_normal(t.size))
    frame["yaw_deg"] = 30.0 + 10.0 * np.sin(2 * np.pi * t / 300.0)
    frame.loc[(t > 700) & (t < 760), ["roll_deg", "pitch_deg"]] = np.nan
    starts = pd.to_datetime(1.4274e9 + 600.0 * np.arange(3), unit="s", utc=True)
    sources = {
        27.0: pd.Series([10.0, 200.0, 95.0], index=starts),
        58.0: pd.Series([40.0, np.nan, 300.0], index=starts),
        85.0: lambda stamps: np.full(len(stamps), 123.0),
    }
    many = imu.tilt_spectrum_statistics_by_height(frame, sources)
    assert list(many) == list(sources)
    for h, src in sources.items():
        table, spec = imu.tilt_spectrum_statistics_by_height(frame, {h: src})[h]
        pd.testing.assert_frame_equal(many[h][0], table, check_exact=True)
        for name in ("var_along_deg2", "var_across_deg2", "period_s", "m0_deg2", "tp_s"):
            assert getattr(many[h][1], name).tobytes() == getattr(spec, name).tobytes(), name
    assert many[58.0][0]["tilt_along_wind_std_deg"].isna().tolist() == [False, True, False]
    assert imu.tilt_spectrum_statistics_by_height(frame, {}) == {}


def test_optional_tilt_columns_read_and_bounds_checked(tmp_path):
    from flidar_uq.data import io

    df = pd.read_csv(Path(__file__).parent / "data" / "hand_written_campaign.csv")
    df["tilt_along_wind_std_deg"] = 1.5
    df["tilt_across_wind_std_deg"] = np.nan
    df["tilt_period_zero_crossing_s"] = 4.0
    df["tilt_period_mean_s"] = 4.2
    df["follower_heave_velocity_std_ms"] = 0.3
    df["follower_heave_period_s"] = 5.0
    df["follower_velocity_along_wind_std_ms"] = 0.25
    df["follower_heave_tilt_correlation"] = 0.9
    for b in range(1, 9):
        df[f"tilt_band{b}_period_s"] = 1.2 * 1.45**b
        df[f"tilt_band{b}_along_wind_var_deg2"] = 0.2
        df[f"tilt_band{b}_across_wind_var_deg2"] = 0.05
        df[f"tilt_band{b}_sincos_psi"] = -0.1
    df.to_csv(tmp_path / "ok.csv", index=False)
    rec = io.read_records(tmp_path / "ok.csv")
    assert set(imu.TILT_SPECTRUM_COLUMNS) <= set(rec.columns)
    df.loc[3, "tilt_period_zero_crossing_s"] = 0.0
    df.to_csv(tmp_path / "bad.csv", index=False)
    with pytest.raises(
        ValueError, match=r"row 4 .*'tilt_period_zero_crossing_s'.*outside \(0, 60\]"
    ):
        io.read_records(tmp_path / "bad.csv")


@settings(max_examples=40, deadline=None)
@given(
    n=st.integers(min_value=2, max_value=4000),
    seg=st.integers(min_value=2, max_value=1200),
    rows=st.integers(min_value=1, max_value=3),
    seed=st.integers(min_value=0, max_value=2**32 - 1),
)
def test_own_welch_is_scipy_welch(n, seg, rows, seed):
    """The generator's Welch estimate is scipy.signal.welch's (Hann, 50 % overlap, segment
    means removed, one-sided density) to rounding, for any length and segment (odd ones
    included: the Nyquist bin is only doubled then)."""
    from scipy.signal import welch

    nperseg = min(n, seg)
    x = np.random.default_rng(seed).standard_normal((rows, n)).cumsum(axis=-1)
    f0, p0 = welch(x, fs=5.0, window="hann", nperseg=nperseg, detrend="constant", axis=-1)
    f1, p1 = imu._welch_hann(x, 5.0, nperseg)
    np.testing.assert_array_equal(f1, f0)
    assert p1.shape == p0.shape
    np.testing.assert_allclose(p1, p0, rtol=0, atol=1e-12 * np.abs(p0).max())


def test_motion_spectrum_without_a_sample_per_segment_raises():
    with pytest.raises(ValueError, match="holds no sample"):
        imu.motion_spectrum(np.ones(100), 5.0, segment_s=0.05)


@settings(max_examples=200, deadline=None)
@given(
    x=st.lists(st.integers(min_value=0, max_value=4), min_size=0, max_size=40).map(
        lambda v: np.asarray(v, float)
    )
)
@example(x=np.array([0.0, 1.0, 1.0, 0.0]))  # a flat peak of two samples: its first
@example(x=np.array([0.0, 2.0, 2.0, 2.0, 3.0, 1.0]))  # a plateau that rises again
@example(x=np.array([1.0, 1.0, 0.0, 2.0, 2.0]))  # flat runs at both ends
def test_local_maxima_is_find_peaks(x):
    """two_peaks' local maxima are scipy.signal.find_peaks' (no conditions), plateaus
    (small integers: many equal neighbours) and ends included."""
    from scipy.signal import find_peaks

    np.testing.assert_array_equal(imu._local_maxima(x), find_peaks(x)[0])


@pytest.mark.parametrize("nperseg", [1, 2, 3, 8, 255, 256, 1000])
def test_hann_is_scipy_get_window_bit_for_bit(nperseg):
    from scipy.signal import get_window

    win, power = imu._hann(nperseg)
    np.testing.assert_array_equal(win, get_window("hann", nperseg))
    if nperseg >= 3:  # a periodic Hann window's squares sum to 3 N / 8
        assert power == pytest.approx(3.0 * nperseg / 8.0, rel=1e-12)
    assert not win.flags.writeable


@settings(max_examples=60, deadline=None)
@given(
    n=st.integers(min_value=1, max_value=300),
    rows=st.integers(min_value=1, max_value=4),
    nan_share=st.sampled_from([0.0, 0.1, 0.9, 1.0]),
    seed=st.integers(min_value=0, max_value=2**32 - 1),
)
def test_detrend_is_the_least_squares_line_over_finite_samples(n, rows, nan_share, seed):
    """The compiled detrend is the NaN-ignoring least-squares line removal of the NumPy
    expressions (to rounding): rows with gaps, with one finite sample (its value removed),
    without any (NaN)."""
    rng = np.random.default_rng(seed)
    x = rng.standard_normal((rows, n)).cumsum(axis=-1) + rng.uniform(-50, 50, (rows, 1))
    x[rng.random((rows, n)) < nan_share] = np.nan
    j = np.arange(n, dtype=float)
    ok = np.isfinite(x)
    cnt = ok.sum(axis=-1, keepdims=True)
    with np.errstate(invalid="ignore", divide="ignore"):
        jm = np.where(ok, j, 0.0).sum(axis=-1, keepdims=True) / cnt
        xm = np.where(ok, x, 0.0).sum(axis=-1, keepdims=True) / cnt
        dj = np.where(ok, j - jm, 0.0)
        slope = (dj * np.where(ok, x - xm, 0.0)).sum(-1, keepdims=True) / (dj**2).sum(
            -1, keepdims=True
        )
    want = x - xm - np.where(np.isfinite(slope), slope, 0.0) * (j - jm)
    got = imu._detrend(x)
    np.testing.assert_array_equal(np.isnan(got), np.isnan(want))
    scale = np.nanmax(np.abs(x), initial=1.0)
    np.testing.assert_allclose(got, want, rtol=0, atol=1e-12 * scale)


def test_follower_translation_columns_of_known_bands():
    """One band along the wind (6 s, 1 deg^2): heave and along-wind orbital velocity
    ``c sigma`` with ``c = g T / (2 pi)``, fully correlated; a band across the wind adds
    heave, not along-wind velocity, and no correlation; the heave period is the heave
    spectrum's mean period."""
    from flidar_uq.physics.hull import phase_speed_ms
    from flidar_uq.physics.motion_spectrum import TiltBandSpectrum

    def spec(var_along, var_across, period):
        z = np.zeros(1)
        return TiltBandSpectrum(
            np.array([1.0, 5.0, 20.0]),
            np.array([period]),
            np.array([var_along]),
            np.array([var_across]),
            z,
            z,
            z,
            z,
            z,
        )

    sig = np.deg2rad(1.0)
    got = imu.follower_translation_columns(spec([0.0, 1.0], [0.0, 0.0], [3.0, 6.0]))
    c6 = phase_speed_ms(6.0)
    assert got["follower_heave_velocity_std_ms"][0] == pytest.approx(c6 * sig, rel=1e-12)
    assert got["follower_velocity_along_wind_std_ms"][0] == pytest.approx(c6 * sig, rel=1e-12)
    assert got["follower_heave_tilt_correlation"][0] == pytest.approx(1.0)
    assert got["follower_heave_period_s"][0] == pytest.approx(6.0)
    across = imu.follower_translation_columns(spec([1.0, 0.0], [0.0, 3.0], [6.0, 8.0]))
    c8 = phase_speed_ms(8.0)
    heave = np.hypot(c6 * sig, c8 * sig * np.sqrt(3.0))
    assert across["follower_heave_velocity_std_ms"][0] == pytest.approx(heave)
    assert across["follower_velocity_along_wind_std_ms"][0] == pytest.approx(c6 * sig)
    # only the along band's heave correlates with the along-wind tilt
    rho = c6 * sig**2 / (heave * sig)
    assert across["follower_heave_tilt_correlation"][0] == pytest.approx(rho)
    assert 6.0 < across["follower_heave_period_s"][0] < 8.0


def test_tilt_band_columns_round_trip_through_the_record_table():
    """The IMU step's band columns are read back by the record model's reader: the same
    periods, the lean amplitude sqrt(2 (var_along + var_across)), the along-wind share as
    <cos^2 psi> and the wrapped-normal <cos psi>; a missing band value marks the record
    incomplete and a table without the columns gives None."""
    import pandas as pd

    from flidar_uq.data.schema import N_TILT_BANDS
    from flidar_uq.physics.motion_spectrum import TiltBandSpectrum

    rng = np.random.default_rng(3)
    n = 5
    per = np.geomspace(1.3, 17.0, N_TILT_BANDS)[None, :] * rng.uniform(0.95, 1.05, (n, 1))
    va, vc = rng.uniform(0, 2, (n, N_TILT_BANDS)), rng.uniform(0, 2, (n, N_TILT_BANDS))
    z = np.zeros(n)
    spec = TiltBandSpectrum(np.geomspace(1, 20, N_TILT_BANDS + 1), per, va, vc, z, z, z, z, z)
    rec = pd.DataFrame(imu.tilt_spectrum_columns(spec))
    rec.loc[2, "tilt_band4_along_wind_var_deg2"] = np.nan
    got = imu.tilt_bands_from_records(rec)
    np.testing.assert_array_equal(got["period_s"], per)
    np.testing.assert_allclose(got["amplitude_deg"][0], np.sqrt(2 * (va[0] + vc[0])))
    share = va / (va + vc)
    np.testing.assert_allclose(got["cos_sq_psi"][0], share[0])
    want = np.where(share > 0.5, np.abs(2 * share - 1) ** 0.25, 0.0)
    np.testing.assert_allclose(got["cos_psi"][0], want[0])
    assert got["complete"].tolist() == [True, True, False, True, True]
    assert imu.tilt_bands_from_records(rec.drop(columns="tilt_band8_period_s")) is None
    spec12 = TiltBandSpectrum(
        np.geomspace(1, 20, 13),
        per[:, :1].repeat(12, 1),
        va[:, :1].repeat(12, 1),
        vc[:, :1].repeat(12, 1),
        z,
        z,
        z,
        z,
        z,
    )
    with pytest.raises(ValueError, match="8 tilt bands, the spectrum has 12"):
        imu.tilt_spectrum_columns(spec12)
