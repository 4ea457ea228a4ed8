"""Propagation of posterior draws to corrected std and TI, with the Gutiérrez-Antuñano et al. (2018) baselines."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from flidar_uq.campaign.statistical_mode import generate_statistical_campaign
from flidar_uq.correction.propagation import (
    PointTarget,
    PropagationSettings,
    corrected_ti,
    draw_corrected_ti,
    draw_held_ti,
    record_summary,
    speed_bin_statistics,
    ti_group_statistics,
    variance_law_baselines,
)
from flidar_uq.inference import BinFit, GlobalFit, fit_bin, fit_global
from flidar_uq.physics.surrogate import get_surrogate
from flidar_uq.physics.variance_laws import corrected_std


@pytest.fixture(scope="module")
def surrogate():
    return get_surrogate("zephir300")


def _bin_fit(bin_id, amp, per, reasons=()):
    shape = (4, 50)
    return BinFit(
        draws={
            "amplitude_deg": np.full(shape, amp),
            "period_s": np.full(shape, per),
            "scatter_amplitude": np.full(shape, 0.1),
            "scatter_period": np.full(shape, 0.1),
        },
        log_lik=np.zeros((4, 50, 1)),
        diagnostics={},
        failure_reasons=list(reasons),
        info={
            "bin_id": bin_id,
            "model": "unimodal",
            "n_records": 1,
            "n_imu": 1,
            "prior_only": False,
            "loo": {},
        },
    )


def _global_fit(rho, tau0=1e-6, kappa=1e-6):
    shape = (4, 50)
    return GlobalFit(
        draws={
            "rho": np.full(shape, rho),
            "tau0_ms": np.full(shape, tau0),
            "kappa": np.full(shape, kappa),
        },
        log_lik=np.zeros((4, 50, 1)),
        diagnostics={},
        failure_reasons=[],
        info={"n_records": 1, "prior_only": False, "loo": {}},
    )


def _records(s_ms, hws=8.0, bin_id=0):
    s_ms = np.atleast_1d(s_ms)
    n = s_ms.size
    return pd.DataFrame(
        {
            "bin_id": bin_id,
            "hws_mean_ms": hws + 0.01 * np.arange(n),
            "hws_std_ms": s_ms,
            "roll_amplitude_deg": 3.0,
            "pitch_amplitude_deg": 3.0,
            "roll_period_s": 4.0,
            "pitch_period_s": 4.0,
        }
    )


def test_point_posterior_reproduces_deployment_formula(surrogate):
    rec = _records([0.6, 0.8, 1.0])
    pr, pb = corrected_ti(
        rec, [_bin_fit(0, 3.0, 4.0)], _global_fit(0.4), surrogate=surrogate, seed=1
    )
    sz = surrogate.sigma_z_ms(rec.hws_mean_ms, 3.0, 4.0)
    c, _ = corrected_std(rec.hws_std_ms, sz, 0.4)
    np.testing.assert_allclose(pr.sigma_corrected_median_ms, c, rtol=1e-4)
    np.testing.assert_allclose(pr.ti_corrected_median, c / rec.hws_mean_ms, rtol=1e-4)
    assert (pr.ti_corrected_lo <= pr.ti_corrected_median).all()
    assert (pr.ti_corrected_median <= pr.ti_corrected_hi).all()
    assert pr.converged.all() and not pr.discriminant_negative.any()
    np.testing.assert_allclose(pr.ti_uncorrected, rec.hws_std_ms / rec.hws_mean_ms)
    # the seed baselines use the bin's median IMU statistics: same sZ here; U law = rho 0
    np.testing.assert_allclose(pr.ti_u, corrected_std(rec.hws_std_ms, sz, 0.0)[0] / rec.hws_mean_ms)
    assert {"ti_c", "ti_pc", "rho_seed"} <= set(pr.columns)
    assert len(pb) == 1 and pb.n.iloc[0] == 3


def test_stability_sigma_moving_below_sigma_z_flagged(surrogate):
    """Documented: no real root -> corrected std 0, discriminant_negative True, never dropped."""
    sz = float(surrogate.sigma_z_ms(8.0, 3.0, 4.0))
    rec = _records([0.3 * sz])
    pr, _ = corrected_ti(
        rec, [_bin_fit(0, 3.0, 4.0)], _global_fit(0.0), surrogate=surrogate, seed=2
    )
    assert bool(pr.discriminant_negative.iloc[0])
    assert pr.discriminant_negative_frac.iloc[0] == 1.0
    assert pr.sigma_corrected_median_ms.iloc[0] == 0.0
    assert len(pr) == 1


def test_unconverged_bin_marked_and_excluded_from_speed_bins(surrogate):
    rec = pd.concat(
        [_records([0.6, 0.7], bin_id=0), _records([0.6, 0.7], bin_id=1)], ignore_index=True
    )
    fits = [
        _bin_fit(0, 3.0, 4.0),
        _bin_fit(1, 3.0, 4.0, reasons=["amplitude_deg: rank R-hat 1.2 >= 1.01"]),
    ]
    pr, pb = corrected_ti(rec, fits, _global_fit(0.3), surrogate=surrogate, seed=3)
    assert pr.converged.tolist() == [True, True, False, False]
    assert "R-hat" in pr.failure_reasons.iloc[2]
    assert pb.n_not_converged.sum() == 2


def test_unconverged_group_is_filled_and_said_not_converged():
    """A group whose records' fits all failed (e.g. the global fit did not converge) still
    gets its statistics, from every record with finite draws, with ``converged`` False and
    ``interval_from`` "fit not converged"; a group with enough converged records uses only
    those; a group with one finite record stays empty."""
    from flidar_uq.correction.campaign import _with_dominant_source

    rng = np.random.default_rng(21)
    n = 40
    draws = 0.1 * np.exp(0.2 * rng.standard_normal((400, 2 * n + 2)))
    draws[:, -1] = np.nan
    conv = np.r_[np.ones(n, bool), np.zeros(n, bool), False, False]
    conv[0] = False  # one failed record among the converged group: left out
    per_record = pd.DataFrame({"converged": conv, "ti_uncorrected": draws.mean(axis=0)})
    keys = pd.DataFrame({"height_m": 100.0, "hws_bin_ms": np.r_[[8.0] * n, [9.0] * n, 10, 10]})
    table = ti_group_statistics(draws, per_record, keys, seed=1)
    assert table["converged"].tolist() == [True, False, True]
    assert table["n"].tolist() == [n - 1, n, 0]
    assert table["n_not_converged"].tolist() == [1, n, 2]
    filled = table.iloc[1]
    assert np.isfinite(
        filled[["ti_mean", "ti_mean_lo", "ti_mean_hi", "ti_rep"]].astype(float)
    ).all()
    assert filled["ti_mean_lo"] < filled["ti_mean"] < filled["ti_mean_hi"]
    assert np.isnan(table["ti_mean"].iloc[2])
    empty_budget = pd.DataFrame(columns=["grouping", "height_m", "hws_bin_ms"])
    words = _with_dominant_source(table, empty_budget)["interval_from"].tolist()
    assert words == ["", "fit not converged", "too few records"]


def test_bins_whose_motion_reaches_the_measured_std_stay_finite_and_say_so():
    """Records whose sigma_Z reaches the measured std have every draw 0 (``c = 0``): a bin
    of only such records gives statistics of 0 (finite) and ``interval_from`` "motion
    reaches the measured std"; a bin where a third of the records are such keeps finite,
    ordered intervals, below the bin without them, and counts them."""
    from flidar_uq.correction.campaign import _with_dominant_source

    rng = np.random.default_rng(22)
    n = 30
    draws = 0.1 * np.exp(0.2 * rng.standard_normal((400, 3 * n)))
    draws[:, :n] = 0.0
    draws[:, n : n + 10] = 0.0
    per_record = pd.DataFrame({"converged": True, "ti_uncorrected": np.full(3 * n, 0.12)})
    keys = pd.DataFrame({"height_m": 100.0, "hws_bin_ms": np.repeat([4.0, 5.0, 6.0], n)})
    table = ti_group_statistics(draws, per_record, keys, seed=2)
    assert table["n_zero_draws"].tolist() == [n, 10, 0]
    stats = table[[f"ti_{s}{b}" for s in ("mean", "rep", "p90") for b in ("", "_lo", "_hi")]]
    assert np.isfinite(stats.to_numpy(dtype=float)).all()
    assert (stats.iloc[0] == 0.0).all()
    part = table.iloc[1]
    assert 0.0 < part["ti_mean_lo"] <= part["ti_mean"] <= part["ti_mean_hi"]
    assert part["ti_mean"] < table["ti_mean"].iloc[2]
    budget = pd.DataFrame(columns=["grouping", "height_m", "hws_bin_ms"])
    words = _with_dominant_source(table, budget)["interval_from"].tolist()
    assert words == ["motion reaches the measured std", "", ""]


def test_noise_widens_interval(surrogate):
    rec = _records([0.8])
    narrow, _ = corrected_ti(
        rec, [_bin_fit(0, 3.0, 4.0)], _global_fit(0.3), surrogate=surrogate, seed=4
    )
    wide, _ = corrected_ti(
        rec, [_bin_fit(0, 3.0, 4.0)], _global_fit(0.3, 0.05, 0.1), surrogate=surrogate, seed=4
    )
    w0 = (narrow.ti_corrected_hi - narrow.ti_corrected_lo).iloc[0]
    w1 = (wide.ti_corrected_hi - wide.ti_corrected_lo).iloc[0]
    assert w0 < 1e-3 < w1


def test_cred_mass_out_of_range_raises(surrogate):
    with pytest.raises(ValueError, match=r"credible_mass=1.5 must be in \(0, 1\)"):
        corrected_ti(
            _records([0.5]),
            [_bin_fit(0, 3, 4)],
            _global_fit(0.0),
            surrogate=surrogate,
            settings=PropagationSettings(credible_mass=1.5),
            seed=1,
        )


@pytest.mark.slow
def test_coverage_of_true_ti_statistical_mode(surrogate):
    """90% intervals cover the true TI for 85-95% of records drawn from the model."""
    rec, _ = generate_statistical_campaign(8, 40, seed=11, surrogate=surrogate, two_period_bins=2)
    fits = [fit_bin(g, seed=int(b)) for b, g in rec.groupby("bin_id")]
    gf = fit_global(rec, fits, surrogate=surrogate, seed=12)
    pr, _ = corrected_ti(rec, fits, gf, surrogate=surrogate, seed=13)
    ok = pr.converged.to_numpy()
    assert ok.mean() > 0.7
    cover = (pr.ti_corrected_lo <= rec.true_ti) & (rec.true_ti <= pr.ti_corrected_hi)
    assert 0.85 <= cover[ok].mean() <= 0.95


def test_point_target_divides_by_lidar_std_ratio_and_widens_by_its_scatter(surrogate):
    # docs/lidar-response.md: the motionless-lidar std c -> point std c exp(e) / g
    rec = _records([0.6, 0.8, 1.0])
    fits = [_bin_fit(0, 3.0, 4.0)]
    kw = dict(surrogate=surrogate, seed=3, settings=PropagationSettings(ndraws=2000))
    base, _ = corrected_ti(rec, fits, _global_fit(0.4), **kw)
    g = np.array([1.02, 1.03, 1.05])
    pr, _ = corrected_ti(rec, fits, _global_fit(0.4), target=PointTarget(g), **kw)
    np.testing.assert_allclose(
        pr["sigma_corrected_median_ms"] * g, base["sigma_corrected_median_ms"]
    )
    np.testing.assert_allclose(pr["lidar_std_ratio"], g)
    wide, _ = corrected_ti(
        rec, fits, _global_fit(0.4), target=PointTarget(g, np.full(3, 0.04)), **kw
    )
    # without other noise (tau0, kappa ~ 0) the interval is exp(+-1.645 * 0.04) about c / g
    ratio = wide["sigma_corrected_hi_ms"] / wide["sigma_corrected_lo_ms"]
    np.testing.assert_allclose(np.log(ratio), 2 * 1.645 * 0.04, rtol=0.1)
    np.testing.assert_allclose(
        wide["sigma_corrected_median_ms"], pr["sigma_corrected_median_ms"], rtol=0.01
    )
    with pytest.raises(ValueError, match="lidar_std_ratio"):
        corrected_ti(
            rec, fits, _global_fit(0.4), target=PointTarget(np.array([1.0, 0.0, 1.0])), **kw
        )
    with pytest.raises(ValueError, match="point_log_sd needs"):
        corrected_ti(
            rec, fits, _global_fit(0.4), target=PointTarget(point_log_sd=np.zeros(3)), **kw
        )


def test_record_summary_uses_the_given_gutierrez2018_baseline(surrogate):
    """The workflow computes Gutiérrez-Antuñano et al.'s (2018) baseline once and passes it to
    record_summary; the same table as corrected_ti's, the corrected values independent of it."""
    rec = pd.concat([_records([0.6, 0.8], bin_id=0), _records([0.7], bin_id=1)], ignore_index=True)
    fits = [_bin_fit(0, 3.0, 4.0), _bin_fit(1, 2.0, 5.0)]
    ref, _ = corrected_ti(rec, fits, _global_fit(0.3), surrogate=surrogate, seed=5)
    draws = draw_corrected_ti(rec, fits, _global_fit(0.3), surrogate=surrogate, seed=5)
    got = record_summary(rec, draws, variance_law_baselines(rec, surrogate))
    pd.testing.assert_frame_equal(got, ref)
    none = record_summary(rec, draws, (np.full(len(rec), np.nan), np.nan))
    assert none["ti_u"].isna().all() and none["rho_seed"].isna().all()
    pd.testing.assert_series_equal(none["ti_corrected_median"], ref["ti_corrected_median"])


def test_record_flags_order_of_reasons():
    from flidar_uq.correction.propagation import record_flags

    fitted = pd.Series({1: True, 2: True, 3: True, 4: False})
    status = pd.Series({1: "ok", 2: "failed", 3: "error"})
    flags = record_flags(
        ["hws_range", "", "", "", "", "", ""],
        np.array([1.0, np.nan, 1.0, 2.0, 3.0, 4.0, 1.0]),
        np.array([True, False, True, True, True, True, True]),
        np.array([False, False, False, False, False, False, True]),
        fitted=fitted,
        status=status,
        global_converged=True,
    )
    assert flags == [
        "hws_range", "unbinned", "", "bin_failed", "bin_error", "bin_not_fitted",
        "discriminant_negative",
    ]  # fmt: skip
    failed = record_flags(
        ["", "qc"], np.array([1.0, 1.0]), np.array([True, True]), np.array([False, False]),
        fitted=fitted, status=status, global_converged=False,
    )  # fmt: skip
    assert failed == ["global_fit_failed", "qc;global_fit_failed"]


def test_speed_bins_use_the_package_speed_bin_rule(surrogate):
    """8.5 m/s sits on an edge: with 8.51 in the upper bin (9), not numpy's round-half-even (8)."""
    rec = _records([0.6, 0.7], hws=8.5)
    _, pb = corrected_ti(
        rec, [_bin_fit(0, 3.0, 4.0)], _global_fit(0.3), surrogate=surrogate, seed=6
    )
    assert pb["hws_bin_ms"].tolist() == [9.0]
    assert pb["n"].tolist() == [2]


def test_speed_bins_per_height_with_the_issue_columns(surrogate):
    rec = pd.concat(
        [_records([0.6, 0.7, 0.8]).assign(height_m=h) for h in (40.0, 100.0)], ignore_index=True
    )
    _, pb = corrected_ti(
        rec, [_bin_fit(0, 3.0, 4.0)], _global_fit(0.3, 0.02, 0.05), surrogate=surrogate, seed=7
    )
    cols = "height_m, hws_bin_ms, n, ti_mean, ti_mean_lo, ti_mean_hi, ti_rep, ti_rep_lo, "
    cols += "ti_rep_hi, ti_p90, ti_p90_lo, ti_p90_hi"
    assert list(pb.columns[:12]) == cols.split(", ")
    assert {"ti_mean_uncorrected", "ti_rep_uncorrected", "ti_p90_uncorrected"} <= set(pb)
    assert pb["height_m"].tolist() == [40.0, 100.0] and pb["n"].tolist() == [3, 3]
    for s in ("ti_mean", "ti_rep", "ti_p90"):
        assert (pb[f"{s}_lo"] < pb[s]).all() and (pb[s] < pb[f"{s}_hi"]).all()


def test_bin_statistics_are_those_of_the_population_not_of_the_draws(surrogate):
    """A bin's mean TI is the mean of its records' draws (the records' own errors average
    out of it); its sd, representative TI and P90 come from the measurement-error model,
    below the draw-by-draw statistics that add every record's own noise to the spread
    (docs/inference.md, "Bin statistics"). The mean's interval is far narrower than a
    record's when the records' errors are independent."""
    rec = _records(np.linspace(0.6, 1.0, 40))
    out = draw_corrected_ti(
        rec,
        [_bin_fit(0, 3.0, 4.0)],
        _global_fit(0.3, 0.02, 0.08),
        surrogate=surrogate,
        settings=PropagationSettings(ndraws=2000),
        seed=8,
    )
    pr = record_summary(rec, out, variance_law_baselines(rec, surrogate))
    pb, draws = speed_bin_statistics(out.ti, pr, rec, seed=8), out.ti.astype(float)
    row = pb.iloc[0]
    mean_draws = draws.mean(axis=1)
    lo, med, hi = np.quantile(mean_draws, [0.05, 0.5, 0.95])
    assert abs(row.ti_mean / med - 1.0) < 0.01
    assert lo < row.ti_mean < hi
    draw_rep = np.median(mean_draws + 1.28 * draws.std(axis=1, ddof=1))
    assert row.ti_rep < draw_rep and row.ti_sd < np.median(draws.std(axis=1, ddof=1))
    avg_record_width = float((pr.ti_corrected_hi - pr.ti_corrected_lo).mean())
    assert row.ti_mean_hi - row.ti_mean_lo < 0.4 * avg_record_width
    np.testing.assert_allclose(row.ti_mean_uncorrected, pr.ti_uncorrected.mean())


def test_hold_removes_a_source_and_only_that_source(surrogate):
    """Common random numbers: holding the sampling noise leaves only rho's spread (zero
    here), holding rho (constant) changes nothing; an unknown source is an error."""
    rec = _records([0.7, 0.8])
    fits, g = [_bin_fit(0, 3.0, 4.0)], _global_fit(0.3, 0.02, 0.08)
    full = draw_corrected_ti(rec, fits, g, surrogate=surrogate, seed=9).ti
    rho = draw_held_ti(rec, fits, g, {"rho"}, surrogate=surrogate, seed=9).ti
    both = draw_held_ti(rec, fits, g, {"sampling", "noise_model"}, surrogate=surrogate, seed=9).ti
    none = draw_held_ti(rec, fits, g, (), surrogate=surrogate, seed=9).ti
    np.testing.assert_array_equal(full, rho)
    np.testing.assert_array_equal(full, none)
    assert np.ptp(both, axis=0).max() < 1e-9 < np.ptp(full, axis=0).min()
    with pytest.raises(ValueError, match=r"hold=\['wind'\] must be among"):
        draw_held_ti(rec, fits, g, {"wind"}, surrogate=surrogate, seed=9)


def test_per_record_quantiles_are_those_of_the_returned_draws(surrogate):
    """The per-record median and interval (computed bin by bin from the float64 draws)
    are the quantiles of the returned float32 TI draws, record by record (float32
    rounding apart); records of a bin without a fit have NaN in both. corrected_ti's
    per-record table and speed bins are those of the draws."""
    rec = pd.concat([_records(np.linspace(0.6, 1.0, 9)), _records([0.7, 0.8], bin_id=1)])
    rec = rec.reset_index(drop=True)
    kw = dict(surrogate=surrogate, settings=PropagationSettings(ndraws=300), seed=4)
    args = (rec, [_bin_fit(0, 3.0, 4.0)], _global_fit(0.3, 0.02, 0.05))
    out = draw_corrected_ti(*args, **kw)
    pr, draws = record_summary(rec, out, variance_law_baselines(rec, surrogate)), out.ti
    assert draws.dtype == np.float32 and draws.shape == (300, 11)
    assert np.isnan(draws[:, 9:]).all() and pr.loc[9:, "ti_corrected_median"].isna().all()
    want = np.quantile(draws[:, :9].astype(float), [0.05, 0.5, 0.95], axis=0)
    got = pr.loc[:8, ["ti_corrected_lo", "ti_corrected_median", "ti_corrected_hi"]]
    np.testing.assert_allclose(got.to_numpy().T, want, rtol=1e-6)
    pr2, pb2 = corrected_ti(*args, **kw)
    pd.testing.assert_frame_equal(pr2, pr)
    pd.testing.assert_frame_equal(pb2, speed_bin_statistics(draws, pr, rec, seed=4))
    assert len(pb2) == 1
