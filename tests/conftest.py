"""Shared pytest configuration.

Markers: ``slow`` (statistical, end-to-end and cluster tests; excluded by default,
run by ``make test`` / ``.ci/run``). Under ``CI=true`` a test that needs an external
tool (SLURM, Chromium) must not skip: use :func:`require_tool`. Hypothesis runs
derandomized (profile ``deterministic``).
"""

from __future__ import annotations

import os
import shutil
from collections import Counter

import numpy as np
import pytest
from hypothesis import settings

IN_CI = os.environ.get("CI", "").lower() in {"1", "true", "yes"}

# Property tests draw their examples deterministically (the same examples on every machine
# and rerun, no example database): a failure is reproducible, never a new random draw.
settings.register_profile("deterministic", derandomize=True, database=None)
settings.load_profile("deterministic")


def pytest_collection_modifyitems(config, items):
    """Order the test files by their number of slow tests, most first (a stable sort: each
    file's tests keep their order). ``make test`` hands whole files to its processes in
    this order (``--dist loadfile --no-loadscope-reorder``): the long files start first
    and the short ones fill the end, so that the processes finish together."""
    slow = Counter(item.path for item in items if item.get_closest_marker("slow"))
    items.sort(key=lambda item: -slow[item.path])


def require_tool(name: str) -> str:
    """Return the path of executable ``name``; skip locally, fail under CI, if absent."""
    path = shutil.which(name)
    if path is None:
        msg = f"{name} not installed (scripts/system-deps.sh installs it)"
        if IN_CI:
            pytest.fail(msg)
        pytest.skip(msg)
    return path


@pytest.fixture
def rng() -> np.random.Generator:
    """A deterministic generator; tests never touch the global numpy seed."""
    return np.random.default_rng(np.random.SeedSequence(20181122))


@pytest.fixture
def constant_fit():
    """A factory of global fits whose draws hold constant values:
    ``constant_fit(rho=0.2, lever_arm_m=2.0, record=True, shape=(2, 50))``. ``record``: the
    record model's (its LOO and hull model in ``info``), else the bin model's global fit."""
    from flidar_uq.inference.results import GlobalFit

    def make(*, record: bool = False, shape: tuple[int, int] = (4, 50), **values) -> GlobalFit:
        draws = {k: np.full(shape, float(v)) for k, v in values.items()}
        if record:
            info = {"loo": {"model": "record"}, "hull_model": "translating", "n_records": 1}
            return GlobalFit(
                draws=draws, log_lik=None, diagnostics={}, failure_reasons=[], info=info
            )
        info = {"n_records": 1, "prior_only": False, "loo": {}}
        return GlobalFit(
            draws=draws,
            log_lik=np.zeros((*shape, 1)),
            diagnostics={},
            failure_reasons=[],
            info=info,
        )

    return make
