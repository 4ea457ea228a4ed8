"""PSIS-LOO computed one block of observations at a time (loo._loo_chunked)."""

import numpy as np
import pytest

from flidar_uq.inference import loo as loo_mod
from flidar_uq.inference.loo import _loo, _loo_chunked


def _log_lik(n_s=400, n_obs=37, seed=11):
    rng = np.random.default_rng(np.random.SeedSequence(seed))
    return np.concatenate(
        [
            rng.standard_normal((n_s, n_obs - 7)) * rng.uniform(0.1, 3.0, n_obs - 7) - 1.0,
            rng.standard_t(2, (n_s, 7)) * 3.0,  # heavy tails: large Pareto k
        ],
        axis=1,
    )


@pytest.mark.parametrize("chunk", [1, 5, 36, 37, 100])
def test_loo_in_blocks_equals_loo_of_the_whole_matrix(chunk):
    # PSIS smooths each observation on its own: the same operations on the same rows, so
    # the blocks give the whole matrix's values (tolerance: 1e-12 relative, rounding only)
    ll = _log_lik()
    whole = _loo(ll.reshape(2, 200, -1))
    assert np.max(whole["pareto_k"]) > 0.7  # the smoothing and its tail fit are exercised
    got = _loo_chunked(lambda sl: ll[:, sl], ll.shape[1], chunk=chunk)
    assert got.keys() == whole.keys()
    for k in ("elpd", "se", "p_loo", "elpd_i", "pareto_k"):
        np.testing.assert_allclose(got[k], whole[k], rtol=1e-12, atol=0)


def test_default_block_size_follows_the_number_of_draws(monkeypatch):
    ll = _log_lik()
    monkeypatch.setattr(loo_mod, "_LOO_CHUNK_ELEMENTS", 400 * 8)  # 8 observations a block
    seen = []

    def pointwise(sl):
        seen.append((sl.start, sl.stop))
        return ll[:, sl]

    got = _loo_chunked(pointwise, ll.shape[1], n_samples=400)
    assert seen == [(c, min(c + 8, 37)) for c in range(0, 37, 8)]  # each record once
    np.testing.assert_allclose(got["elpd_i"], _loo(ll)["elpd_i"], rtol=1e-12, atol=0)


def test_loo_in_blocks_is_none_where_the_whole_matrix_fails():
    ll = _log_lik()
    ll[:, 30] = -1.0  # a constant log-likelihood in the last block: PSIS cannot fit it
    assert _loo(ll) is None
    assert _loo_chunked(lambda sl: ll[:, sl], ll.shape[1], chunk=8) is None
    assert _loo_chunked(lambda sl: ll[:, sl], 0, chunk=8) is None


def test_loo_of_a_whole_matrix_runs_in_blocks_of_the_default_size(monkeypatch):
    ll = _log_lik()
    whole = _loo(ll)  # 400 x 37 values: one block at the default size
    monkeypatch.setattr(loo_mod, "_LOO_CHUNK_ELEMENTS", 400 * 8)  # 8 observations a block
    shapes = []
    psis = loo_mod._psis_loo

    def spy(x):
        shapes.append(x.shape)
        return psis(x)

    monkeypatch.setattr(loo_mod, "_psis_loo", spy)
    got = _loo(ll.reshape(2, 200, -1))
    assert shapes == [(400, 8)] * 4 + [(400, 5)]
    for k in ("elpd", "se", "p_loo", "elpd_i", "pareto_k"):
        np.testing.assert_array_equal(got[k], whole[k])
