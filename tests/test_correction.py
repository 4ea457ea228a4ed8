"""Gutiérrez-Antuñano et al. (2018) variance-combination laws (Eqs. 15-17), its rho estimate, the deployment formula."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from flidar_uq.physics.variance_laws import (
    corrected_std,
    rho_bin_correlation,
    sigma_moving_c,
    sigma_moving_pc,
    sigma_moving_u,
)


def test_gutierrez2018_eq15_hand_value():
    # r = 0.6, sZ = 0.2, rho = 0.78 (Gutiérrez-Antuñano et al., 2018, Sec. 3.2): 0.36 + 0.04 + 2*0.78*0.12 = 0.5872
    assert sigma_moving_pc(0.6, 0.2, 0.78) == pytest.approx(np.sqrt(0.5872), rel=1e-12)


def test_gutierrez2018_eq16_uncorrelated_is_pythagoras():
    assert sigma_moving_u(0.3, 0.4) == pytest.approx(0.5, rel=1e-12)


def test_gutierrez2018_eq17_correlated_is_sum():
    assert sigma_moving_c(0.3, 0.4) == pytest.approx(0.7, rel=1e-12)


def test_gutierrez2018_eq15_between_u_and_c_bounds():
    # Sec. 3.4 of Gutiérrez-Antuñano et al. (2018): U and C laws bound the PC law for 0 <= rho <= 1
    r, sz = 0.5, 0.3
    pc = sigma_moving_pc(r, sz, np.linspace(0, 1, 11))
    assert np.all(pc >= sigma_moving_u(r, sz) - 1e-15)
    assert np.all(pc <= sigma_moving_c(r, sz) + 1e-15)


def test_outside_domain_returns_nan():
    assert np.isnan(sigma_moving_pc(0.5, 0.2, 1.5))
    assert np.isnan(sigma_moving_pc(-0.5, 0.2, 0.5))
    c, neg = corrected_std(0.5, -0.1, 0.2)
    assert np.isnan(c) and not neg


def test_deployment_inverse_hand_values():
    # U: sqrt(0.5^2 - 0.3^2) = 0.4; C: 0.7 - 0.4 = 0.3
    assert corrected_std(0.5, 0.3, 0.0)[0] == pytest.approx(0.4, rel=1e-12)
    assert corrected_std(0.7, 0.4, 1.0)[0] == pytest.approx(0.3, rel=1e-12)


@settings(max_examples=200, deadline=None)
@given(
    r=st.floats(0.0, 5.0),
    sz=st.floats(0.0, 3.0),
    rho=st.floats(-0.999, 1.0),
)
def test_deployment_formula_inverts_eq15(r, sz, rho):
    """c(s(r)) == r wherever the forward law's root is the larger one (r >= -rho sZ)."""
    s = sigma_moving_pc(r, sz, rho)
    c, neg = corrected_std(s, sz, rho)
    if r + rho * sz >= 0:  # Eq. (15) has r as its larger root
        assert not neg or np.isclose(r, 0.0, atol=1e-6)
        assert c == pytest.approx(r, abs=1e-6 * (1 + sz + r))


def test_negative_discriminant_flagged_and_zero():
    # s = 0.1 < sqrt(1 - rho^2) sZ = 0.3: no real root
    c, neg = corrected_std(0.1, 0.3, 0.0)
    assert bool(neg) and c == 0.0
    # broadcasting over posterior draws: one flag per draw
    c, neg = corrected_std(0.25, 0.3, np.array([-0.9, 0.0, 0.9]))
    assert neg.tolist() == [False, True, True]
    assert c[0] == pytest.approx(0.9 * 0.3 + np.sqrt(0.25**2 - 0.19 * 0.09))


def test_rho_bin_correlation_perfect_linear_and_shape_error():
    x = np.array([4.0, 6.0, 8.0, 10.0])
    assert rho_bin_correlation(x, -0.01 * x) == pytest.approx(-1.0)
    assert np.isnan(rho_bin_correlation(x[:2], x[:2]))
    with pytest.raises(
        ValueError, match=r"bin_ref_hws_ms has shape \(4,\) but bin_mean_z_ms has \(3,\)"
    ):
        rho_bin_correlation(x, x[:3])
