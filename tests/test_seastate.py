"""Tests of flidar_uq.physics.seastate: JONSWAP spectrum and narrow-band buoy tilt series."""

from __future__ import annotations

import numpy as np
import pytest

from flidar_uq.physics.seastate import WaveSystem, jonswap_spectrum, tilt_series

DT_S = 0.1
N = 6000  # 600 s


def _mean_periodogram(x, dt_s):
    f = np.fft.rfftfreq(x.shape[-1], dt_s)
    p = (np.abs(np.fft.rfft(x - x.mean(-1, keepdims=True), axis=-1)) ** 2).mean(0)
    return f, p


def _peak_period(f, p, smooth_bins=5):
    """Period of the maximum of a running-mean-smoothed spectrum."""
    ps = np.convolve(p, np.ones(smooth_bins) / smooth_bins, mode="same")
    return 1.0 / f[np.argmax(ps)]


@pytest.mark.parametrize("gamma", [1.0, 2.0, 3.3, 5.0, 7.0])
def test_jonswap_dnv_goda_normalisation_gives_hs2_over_16(gamma):
    # DNV-RP-C205 Eq. 3.5.5.4 normalisation: integral = Hs^2/16 (Goda's fit, ~2 % up to 7)
    f = np.linspace(1e-4, 5.0, 200001)
    m0 = jonswap_spectrum(f, 2.0, 6.0, gamma).sum() * (f[1] - f[0])
    assert m0 == pytest.approx(2.0**2 / 16.0, rel=0.025)


def test_jonswap_peak_at_tp_and_nan_outside_domain():
    f = np.linspace(0.01, 2.0, 20000)
    s = jonswap_spectrum(f, 1.0, 4.0, 3.3)
    assert 1.0 / f[np.argmax(s)] == pytest.approx(4.0, rel=2e-3)
    assert np.isnan(jonswap_spectrum(0.3, 1.0, -1.0, 3.3))
    assert np.isnan(jonswap_spectrum(0.3, 1.0, 4.0, 12.0))
    assert jonswap_spectrum(0.0, 1.0, 4.0, 3.3) == 0.0


@pytest.mark.parametrize("tp_s", [2.5, 4.0])
def test_tilt_dominant_period_matches_sea_state_tp_within_3pct(tp_s):
    rng = np.random.default_rng(11)
    n_rec = 200
    sys_ = {
        "amplitude_deg": np.full((n_rec, 1), 3.0),
        "tp_s": np.full((n_rec, 1), tp_s),
        "gamma": np.full((n_rec, 1), 3.3),
        "direction_deg": np.full((n_rec, 1), 30.0),
        "spread_deg": np.full((n_rec, 1), 30.0),
    }
    roll, pitch = tilt_series(N, DT_S, sys_, rng)
    f, p = _mean_periodogram(np.concatenate([roll, pitch]), DT_S)
    assert _peak_period(f, p) == pytest.approx(tp_s, rel=0.03)


def test_wind_sea_plus_swell_gives_two_peaks_at_both_tp():
    rng = np.random.default_rng(12)
    n_rec = 200
    sys_ = {
        "amplitude_deg": np.tile([[2.0, 2.0]], (n_rec, 1)),
        "tp_s": np.tile([[3.0, 7.0]], (n_rec, 1)),
        "gamma": np.tile([[3.3, 6.0]], (n_rec, 1)),
        "direction_deg": np.tile([[0.0, 60.0]], (n_rec, 1)),
        "spread_deg": np.tile([[30.0, 15.0]], (n_rec, 1)),
    }
    roll, pitch = tilt_series(N, DT_S, sys_, rng)
    f, p = _mean_periodogram(np.concatenate([roll, pitch]), DT_S)
    short = (f > 1 / 5.0) & (f < 1 / 2.0)
    long_ = (f > 1 / 10.0) & (f <= 1 / 5.0)
    assert _peak_period(f[short], p[short]) == pytest.approx(3.0, rel=0.03)
    assert _peak_period(f[long_], p[long_]) == pytest.approx(7.0, rel=0.03)


def test_tilt_amplitude_convention_sqrt2_std_in_quadrature():
    # (A_roll^2 + A_pitch^2) / 2 = A^2 in expectation, A_x = sqrt(2) std (conventions.md)
    rng = np.random.default_rng(13)
    n_rec = 400
    sys_ = {
        "amplitude_deg": np.full((n_rec, 1), 2.5),
        "tp_s": np.full((n_rec, 1), 4.0),
        "gamma": np.full((n_rec, 1), 3.3),
        "direction_deg": np.full((n_rec, 1), 20.0),
        "spread_deg": np.full((n_rec, 1), 35.0),
    }
    roll, pitch = tilt_series(N, DT_S, sys_, rng)
    a2 = 0.5 * (2 * roll.var(-1) + 2 * pitch.var(-1))
    se = a2.std() / np.sqrt(n_rec)
    assert abs(a2.mean() - 2.5**2) < 4 * se


def test_roll_pitch_correlated_but_not_identical():
    rng = np.random.default_rng(14)
    roll, pitch = tilt_series(N, DT_S, [WaveSystem(3.0, 4.0, 3.3, 45.0, 30.0)], rng)
    r = np.corrcoef(roll, pitch)[0, 1]
    # waves travelling at 45 deg: roll = sin(theta) s, pitch = -cos(theta) s -> r near -1
    # but spreading decorrelates: strongly correlated, not identical
    assert -0.98 < r < -0.3
    # waves travelling along body x only tilt about y (pitch): roll much smaller
    roll_x, pitch_x = tilt_series(N, DT_S, [WaveSystem(3.0, 4.0, 3.3, 0.0, 10.0)], rng)
    assert roll_x.std() < 0.3 * pitch_x.std()


def test_tilt_series_deterministic_for_a_seed():
    a = tilt_series(N, DT_S, [WaveSystem(2.0, 4.0)], np.random.default_rng(5))
    b = tilt_series(N, DT_S, [WaveSystem(2.0, 4.0)], np.random.default_rng(5))
    np.testing.assert_array_equal(a[0], b[0])
    np.testing.assert_array_equal(a[1], b[1])


def test_tilt_series_misuse_raises():
    rng = np.random.default_rng(0)
    with pytest.raises(ValueError, match="n_samples must be >= 8"):
        tilt_series(4, 0.1, [WaveSystem(1.0, 4.0)], rng)
    with pytest.raises(ValueError, match="dt_s must be > 0"):
        tilt_series(100, 0.0, [WaveSystem(1.0, 4.0)], rng)
    with pytest.raises(ValueError, match="at least one WaveSystem"):
        tilt_series(100, 0.1, [], rng)
