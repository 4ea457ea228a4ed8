"""Statistical-mode virtual campaign: draws from the Bayesian model with known parameters."""

from __future__ import annotations

import numpy as np
import pytest

from flidar_uq.campaign.statistical_mode import draw_true_params, generate_statistical_campaign
from flidar_uq.physics.surrogate import get_surrogate
from flidar_uq.physics.variance_laws import sigma_moving_pc

CORE = [
    "timestamp",
    "height_m",
    "hws_mean_ms",
    "hws_std_ms",
    "wd_mean_deg",
    "availability_pct",
    "roll_amplitude_deg",
    "pitch_amplitude_deg",
    "roll_period_s",
    "pitch_period_s",
    "period2_s",
    "weight1",
    "ref_hws_mean_ms",
    "ref_hws_std_ms",
    "bin_id",
    "true_ti",
    "true_sigma_z_ms",
]


@pytest.fixture(scope="module")
def surrogate():
    return get_surrogate("zephir300")


def test_columns_counts_and_bit_identical_rerun(surrogate):
    a, truth = generate_statistical_campaign(3, 7, seed=5, surrogate=surrogate, two_period_bins=1)
    b, _ = generate_statistical_campaign(3, 7, seed=5, surrogate=surrogate, two_period_bins=1)
    assert set(CORE) <= set(a.columns) and len(a) == 21
    assert a.equals(b)
    assert "period1_s" in truth["bins"][2] and "period_s" in truth["bins"][0]
    assert a.loc[a.bin_id == 2, "period2_s"].notna().all()
    assert a.loc[a.bin_id == 0, "period2_s"].isna().all()


def test_records_follow_eq15_mean_and_geometric_imu_mean(surrogate):
    tp = {
        "rho": 0.5,
        "tau0_ms": 1e-4,
        "kappa": 1e-4,
        "bins": [
            {"amplitude_deg": 3.0, "period_s": 4.0, "scatter_amplitude": 0.2, "scatter_period": 0.1}
        ],
    }
    rec, _ = generate_statistical_campaign(1, 2000, tp, seed=1, surrogate=surrogate)
    mu = sigma_moving_pc(
        rec.ref_hws_std_ms, rec.true_sigma_z_ms, 0.5
    )  # Eq. (15) of Gutiérrez-Antuñano et al. (2018)
    np.testing.assert_allclose(rec.hws_std_ms, mu, rtol=2e-3, atol=1e-3)
    log_a = 0.5 * np.log(rec.roll_amplitude_deg * rec.pitch_amplitude_deg)
    assert log_a.mean() == pytest.approx(np.log(3.0), abs=0.02)
    assert log_a.std() == pytest.approx(0.2, rel=0.08)
    np.testing.assert_allclose(rec.true_sigma_z_ms, surrogate.sigma_z_ms(rec.hws_mean_ms, 3.0, 4.0))


def test_prior_draws_respect_support():
    rng = np.random.default_rng(np.random.SeedSequence(3))
    tp = draw_true_params(50, two_period_bins=25, rng=rng)
    assert -1 < tp["rho"] < 1 and tp["tau0_ms"] > 0 and tp["kappa"] > 0
    for p in tp["bins"]:
        assert 0 < p["amplitude_deg"] <= 25
        if "period1_s" in p:
            assert 1 <= p["period1_s"] < p["period2_s"] <= 20 and 0 < p["weight1"] < 1
        else:
            assert 1 <= p["period_s"] <= 20


def test_bad_arguments_raise(surrogate):
    with pytest.raises(ValueError, match=r"n_bins=0 and records_per_bin=5 must be >= 1"):
        generate_statistical_campaign(0, 5, seed=1, surrogate=surrogate)
    tp = draw_true_params(2, rng=np.random.default_rng(np.random.SeedSequence(1)))
    with pytest.raises(ValueError, match=r"true_params has 2 bins, n_bins=3"):
        generate_statistical_campaign(3, 5, tp, seed=1, surrogate=surrogate)
