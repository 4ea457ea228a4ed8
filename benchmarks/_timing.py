"""The timing loop the benchmarks share: the best of a few repeats.

Benchmarks are run as scripts (``python benchmarks/<name>.py``), so this module is
imported as ``from _timing import best_time`` from the script's own directory. The best
(shortest) of several repeats is the least disturbed by other work on a shared machine.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Any


def best_time(
    fn: Callable[..., Any],
    *args: Any,
    repeats: int,
    clock: Callable[[], float] = time.perf_counter,
) -> tuple[float, Any]:
    """Call ``fn(*args)`` ``repeats`` times; return the shortest duration in seconds of
    ``clock`` (wall time by default, ``time.process_time`` for CPU time) and the last
    call's value."""
    if repeats < 1:
        raise ValueError(f"repeats must be >= 1, got {repeats}")
    best, value = float("inf"), None
    for _ in range(repeats):
        t0 = clock()
        value = fn(*args)
        best = min(best, clock() - t0)
    return best, value
