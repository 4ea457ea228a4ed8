"""What the benchmarks that rerun the acceptance scenarios share: how the acceptance tests
run each scenario, the campaign seeds, and a process pool over the campaigns.

Benchmarks are run as scripts (``python benchmarks/<name>.py``), so this module is
imported as ``from _acceptance_runs import ...`` from the script's own directory.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from concurrent.futures import ProcessPoolExecutor
from typing import Any

import numpy as np

#: How the acceptance tests (tests/test_regimes*.py) run each scenario: the options of
#: ``validation.regimes.scenario_records`` (the lidar of the surrogate, the hull the
#: analyst names).
SCENARIO_OPTIONS: dict[str, dict] = {
    "wave_follower": {"hull_reference": "auto"},
    "wave_follower_weathervane": {"hull_reference": "auto"},
    "discus_buoy": {"hull_reference": "auto"},
    "dbs_wave_follower": {"lidar": "windcube_v2"},
    "dbs_wave_follower_weathervane": {"lidar": "windcube_v2"},
    "dbs_tilt_only": {"lidar": "windcube_v2"},
}


def scenario_lidar(scenario: str) -> str:
    """The floating lidar the acceptance tests give a scenario's surrogate."""
    return SCENARIO_OPTIONS[scenario].get("lidar", "zephir300")


def campaign_seeds(root: int, n: int) -> list[int]:
    """``n`` campaign seeds (31-bit) spawned from ``SeedSequence(root)``."""
    return [
        int(c.generate_state(1, dtype=np.uint32)[0] >> 1)
        for c in np.random.SeedSequence(root).spawn(n)
    ]


def run_campaigns(
    fn: Callable[..., Any],
    jobs: Sequence[tuple],
    *,
    workers: int = 2,
    report: Callable[[int, int, Any], None] | None = None,
) -> list[Any]:
    """``fn(*job)`` for every job in ``workers`` processes; the results in the jobs' order.
    ``report(i, n, result)`` is called for each result in that order as it is ready (the
    progress lines of a run of many minutes)."""
    with ProcessPoolExecutor(max_workers=workers) as pool:
        futures = [pool.submit(fn, *job) for job in jobs]
        out = []
        for i, f in enumerate(futures, 1):
            out.append(f.result())
            if report is not None:
                report(i, len(jobs), out[-1])
    return out
