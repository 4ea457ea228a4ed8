"""The per-record quantiles of the propagation: a sort-based quantile equal to np.nanquantile."""

from __future__ import annotations

import warnings

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

from flidar_uq.correction.propagation import _record_quantiles, _sorted_nanquantile

_values = st.one_of(
    st.floats(-1e6, 1e6, allow_nan=False, allow_subnormal=False, width=64),
    st.just(np.nan),
    st.just(0.0),
    st.just(1.0),  # ties
)
_draws = hnp.arrays(np.float64, st.tuples(st.integers(1, 40), st.integers(1, 12)), elements=_values)
_probs = st.lists(st.floats(0.0, 1.0, width=64), min_size=1, max_size=5)


def _nanquantile(x, q):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # all-NaN columns
        return np.nanquantile(x, q, axis=0)


@settings(max_examples=400, deadline=None)
@given(x=_draws, q=_probs, all_nan=st.integers(-1, 11))
def test_sorted_quantile_equals_nanquantile(x, q, all_nan):
    """Bit for bit equal to numpy's default (linear) nanquantile, with NaNs, ties, a single
    value and columns of NaN only."""
    if all_nan < x.shape[1]:
        x[:, max(all_nan, 0)] = np.nan
    got = _sorted_nanquantile(np.sort(x, axis=0), np.asarray(q))
    want = _nanquantile(x, q)
    np.testing.assert_array_equal(got, want)


def test_sorted_quantile_of_the_propagation_probabilities():
    """The corrected-TI probabilities (0.05, 0.5, 0.95 of a 0.9 interval, as computed in
    corrected_ti) on long columns: equal, and an all-NaN column gives NaN."""
    rng = np.random.default_rng(0)
    x = rng.lognormal(-2.0, 0.3, (1000, 50))
    x[rng.random(x.shape) < 0.1] = np.nan
    x[:, 7] = np.nan
    q = np.array([(1.0 - 0.9) / 2.0, 0.5, (1.0 + 0.9) / 2.0])
    got = _sorted_nanquantile(np.sort(x, axis=0), q)
    np.testing.assert_array_equal(got, _nanquantile(x, q))
    assert np.isnan(got[:, 7]).all() and np.isfinite(np.delete(got, 7, axis=1)).all()


@settings(max_examples=200, deadline=None)
@given(
    x=hnp.arrays(
        np.float64,
        st.tuples(st.integers(1, 30), st.just(6)),
        elements=st.one_of(
            st.floats(0.0, 1e3, width=64), st.just(np.nan), st.just(np.inf), st.just(1e308)
        ),
    ),
    q=_probs,
)
def test_record_quantiles_equal_nanquantile_of_std_and_ti(x, q):
    """Std and TI quantiles from one sort equal np.nanquantile of each with the non-finite
    draws left out (as corrected_ti computed them before), for positive, tiny (overflow),
    zero, negative and NaN mean speeds."""
    m = np.array([8.0, 1e-300, 0.0, -3.0, np.nan, 0.5])
    sq, tq = _record_quantiles(x, m, np.asarray(q))
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        ti = x / m[None, :]
    np.testing.assert_array_equal(sq, _nanquantile(np.where(np.isfinite(x), x, np.nan), q))
    np.testing.assert_array_equal(tq, _nanquantile(np.where(np.isfinite(ti), ti, np.nan), q))
