"""The compiled standard normal draws: NumPy's numbers and generator state, bit for bit."""

from __future__ import annotations

import threading

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from flidar_uq.random_draws import _MIN_COMPILED, complex_normals, standard_normals

BIT_GENERATORS = ("PCG64", "PCG64DXSM", "MT19937", "Philox", "SFC64")
#: the ziggurat's rightmost layer boundary (NumPy's ziggurat_nor_r): values beyond it come
#: from the tail branch (log1p), the rarest path of the algorithm
ZIGGURAT_R = 3.6541528853610088


def _pair(name: str, seed: int) -> tuple[np.random.Generator, np.random.Generator]:
    make = getattr(np.random, name)
    return np.random.Generator(make(seed)), np.random.Generator(make(seed))


def _same_state(a, b) -> bool:
    """Bit generator states equal (dicts of ints and, for some, arrays)."""
    if isinstance(a, dict):
        return a.keys() == b.keys() and all(_same_state(a[k], b[k]) for k in a)
    if isinstance(a, np.ndarray):
        return np.array_equal(a, b)
    return a == b


def _assert_same_draws(name, seed, shapes):
    ours, numpys = _pair(name, seed)
    got = standard_normals(ours, *shapes)
    want = [numpys.standard_normal(s) for s in shapes]
    assert len(got) == len(want)
    for g, w in zip(got, want, strict=True):
        assert g.shape == w.shape
        assert g.dtype == np.float64
        np.testing.assert_array_equal(g, w, strict=True)
    # the generator left where NumPy's method leaves it
    assert _same_state(ours.bit_generator.state, numpys.bit_generator.state)
    assert ours.random() == numpys.random()


@pytest.mark.parametrize("name", BIT_GENERATORS)
def test_same_numbers_and_state_as_numpy(name):
    # above the compiled threshold (the turbulence's coefficients, then its Nyquist bins)
    # and below it (NumPy's own method), shapes of any rank
    _assert_same_draws(name, 7, [(3, 3, 3001), (3, 3, 3001), (3, 3)])
    _assert_same_draws(name, 8, [(2, 961), 5, (1, 2, 961)])
    _assert_same_draws(name, 9, [(7,), 3])


def test_a_million_values_with_the_tail():
    """Every branch of the ziggurat: a million values hold ~260 beyond its last layer."""
    ours, numpys = _pair("PCG64", 20181122)
    (got,) = standard_normals(ours, 1_000_000)
    want = numpys.standard_normal(1_000_000)
    assert np.count_nonzero(np.abs(want) > ZIGGURAT_R) > 50  # the tail branch was taken
    np.testing.assert_array_equal(got, want)
    assert _same_state(ours.bit_generator.state, numpys.bit_generator.state)


@settings(max_examples=40, deadline=None)
@given(
    seed=st.integers(0, 2**63),
    shapes=st.lists(
        st.one_of(
            st.integers(0, 3 * _MIN_COMPILED),
            st.tuples(st.integers(0, 40), st.integers(0, 300)),
        ),
        min_size=1,
        max_size=4,
    ),
)
def test_same_numbers_property(seed, shapes):
    _assert_same_draws("PCG64", seed, shapes)


def test_another_generator_draws_with_its_own_method():
    """A legacy RandomState (not a Generator) keeps its own method and numbers."""
    ours, theirs = np.random.RandomState(3), np.random.RandomState(3)
    (got,) = standard_normals(ours, 4 * _MIN_COMPILED)
    np.testing.assert_array_equal(got, theirs.standard_normal(4 * _MIN_COMPILED))


def test_shapes_as_numpy_takes_them():
    """An int n is (n,), a list a tuple, () one value; a negative dimension is an error."""
    ours, numpys = _pair("PCG64", 12)
    got = standard_normals(ours, [40, 60], 3000, (), (0, 5))
    want = [numpys.standard_normal(s) for s in ((40, 60), 3000, (), (0, 5))]
    for g, w in zip(got, want, strict=True):
        assert g.shape == np.shape(w)
        np.testing.assert_array_equal(g, w)
    with pytest.raises(ValueError, match="negative"):
        standard_normals(ours, 4 * _MIN_COMPILED, (3, -1))


def test_the_bit_generators_lock_is_held():
    """The draws wait for the bit generator's lock, as NumPy's method does (a generator
    shared between threads)."""
    rng = np.random.default_rng(5)
    lock = rng.bit_generator.lock
    done = []
    worker = threading.Thread(target=lambda: done.append(standard_normals(rng, 4 * _MIN_COMPILED)))
    with lock:
        worker.start()
        worker.join(0.3)
        assert worker.is_alive() and not done  # waiting for the lock
    worker.join(10.0)
    assert done and not worker.is_alive()


def test_complex_normals_are_the_scaled_draws_in_order():
    """Real parts, imaginary parts, then the further arrays: NumPy's draws in that order,
    each part times the scale."""
    ours, numpys = _pair("PCG64", 21)
    scale = np.linspace(0.0, 2.0, 3 * 1001).reshape(3, 1001)
    coef, extra = complex_normals(ours, scale, (2, 7))
    re, im, want_extra = (numpys.standard_normal(s) for s in (scale.shape, scale.shape, (2, 7)))
    np.testing.assert_array_equal(coef.real, re * scale)
    np.testing.assert_array_equal(coef.imag, im * scale)
    np.testing.assert_array_equal(extra, want_extra)
    assert _same_state(ours.bit_generator.state, numpys.bit_generator.state)
