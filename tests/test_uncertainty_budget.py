"""The uncertainty budget: variance shares from reruns with one source held at its median."""

from __future__ import annotations

import logging

import numpy as np
import pandas as pd
import pytest
from test_propagate import _bin_fit, _records

from flidar_uq.correction.propagation import (
    UNCERTAINTY_SOURCES,
    PropagationSettings,
    draw_held_ti,
)
from flidar_uq.correction.uncertainty_budget import uncertainty_budget
from flidar_uq.inference import GlobalFit
from flidar_uq.physics.surrogate import get_surrogate


def test_additive_sources_give_their_analytic_shares(rng, caplog):
    """Y = A (shared by all records) + B_i (independent per record): the group mean has
    Var = var(A) + var(B) / n, and holding either source removes exactly its part."""
    nd, n = 20000, 25
    a = rng.normal(0.10, 0.004, nd)
    b = rng.normal(0.0, 0.01, (nd, n))
    draws = {(): a[:, None] + b, ("rho",): np.median(a) + b, ("sampling",): a[:, None] + 0 * b}
    keys = {"campaign": pd.DataFrame({"height_m": np.full(n, 80.0)})}
    with caplog.at_level(logging.INFO, logger="flidar_uq.correction.uncertainty_budget"):
        tab = uncertainty_budget(draws.get, keys, np.ones(n, bool), sources=("rho", "sampling"))
    # a progress line per pass: every source drawn, then each held
    passes = [r.getMessage().split(" (")[0] for r in caplog.records]
    assert passes == [f"uncertainty budget: {k} of 3 passes" for k in (1, 2, 3)]
    var_a, var_b = 0.004**2, 0.01**2 / n
    row = tab.iloc[0]
    assert row.n == n
    np.testing.assert_allclose(row.share_rho, var_a / (var_a + var_b), atol=0.02)
    np.testing.assert_allclose(row.share_sampling, var_b / (var_a + var_b), atol=0.02)
    assert abs(row.remainder) < 0.03
    np.testing.assert_allclose(row.sd, np.sqrt(var_a + var_b), rtol=0.02)
    assert row.width_sampling < row.width < 2 * 1.645 * np.sqrt(var_a + var_b) * 1.05


def test_budget_of_the_propagation_finds_the_dominant_source():
    """rho uncertain (sd 0.1), sampling noise small: rho dominates the campaign mean; for
    a single record the sampling share grows."""
    rng = np.random.default_rng(5)
    shape = (4, 250)
    gfit = GlobalFit(
        draws={
            "rho": np.clip(rng.normal(0.3, 0.1, shape), -0.99, 0.99),
            "tau0_ms": np.full(shape, 1e-3),
            "kappa": np.full(shape, 0.03),
        },
        log_lik=np.zeros((*shape, 1)),
        diagnostics={},
        failure_reasons=[],
        info={"n_records": 1, "prior_only": False, "loo": {}},
    )
    rec = _records(np.linspace(0.6, 1.0, 60)).assign(height_m=np.repeat([50.0, 90.0], 30))
    fits, sur = [_bin_fit(0, 3.0, 4.0)], get_surrogate("zephir300")
    draws = {}
    for hold in ((), *((k,) for k in UNCERTAINTY_SOURCES)):
        out = draw_held_ti(
            rec, fits, gfit, hold, surrogate=sur, settings=PropagationSettings(ndraws=2000), seed=3
        )
        draws[hold] = out.ti
    conv = out.converged
    keys = {"campaign": rec[["height_m"]], "speed bin": rec[["height_m"]].assign(b=8.0)}
    tab = uncertainty_budget(draws.get, keys, conv)
    assert tab["grouping"].tolist() == ["campaign"] * 2 + ["speed bin"] * 2
    tab = tab[tab["grouping"] == "campaign"]
    assert tab["height_m"].tolist() == [50.0, 90.0]
    assert (tab["share_rho"] > 0.8).all()
    assert (tab["share_sampling"] < 0.15).all()
    # motion is exact in this fit: holding it changes nothing
    np.testing.assert_allclose(tab["share_motion"], 0.0, atol=1e-9)
    one = uncertainty_budget(
        lambda hold: draws[hold][:, :1], {"one": rec[["height_m"]].iloc[:1]}, [True], min_count=1
    )
    assert one["share_sampling"].iloc[0] > tab["share_sampling"].max()


def test_budget_rejects_unknown_sources_and_wrong_shapes():
    keys = {"c": pd.DataFrame({"h": [1.0]})}
    with pytest.raises(ValueError, match=r"unknown sources \['wind'\]"):
        uncertainty_budget(lambda hold: np.zeros((3, 1)), keys, [True], sources=("wind",))
    with pytest.raises(ValueError, match=r"have shape \(3, 2\), expected \(ndraws, 1\)"):
        uncertainty_budget(lambda hold: np.zeros((3, 2)), keys, [True])


def test_holding_a_source_conditions_the_correlated_global_parameters(rng):
    """kappa = 0.1 + 0.5 (rho - 0.3) + small noise in the posterior: holding rho leaves
    kappa only its conditional spread (the small noise), around its conditional mean."""
    from flidar_uq.correction.propagation import _held_global_draws

    shape = (4, 2000)
    rho = rng.normal(0.3, 0.05, shape)
    kappa = 0.1 + 0.5 * (rho - 0.3) + rng.normal(0, 0.002, shape)
    gfit = GlobalFit(
        draws={"rho": rho, "kappa": kappa, "tau0_ms": np.full(shape, 1e-3)},
        log_lik=np.zeros((*shape, 1)), diagnostics={}, failure_reasons=[],
        info={"n_records": 1, "prior_only": False, "loo": {}},
    )  # fmt: skip
    idx = rng.choice(rho.size, 4000)
    held = _held_global_draws(gfit, idx, {"rho"})
    assert np.ptp(held["rho"]) == 0 and np.isclose(held["rho"][0], np.median(rho))
    np.testing.assert_allclose(np.std(held["kappa"]), 0.002, rtol=0.1)
    np.testing.assert_allclose(np.mean(held["kappa"]), 0.1, atol=1e-3)
    assert _held_global_draws(gfit, idx, {"sampling"}) == {}
