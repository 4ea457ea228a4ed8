"""Progress of long loops as log lines (a rule's log file shows how far a step is).

A pipeline step that runs for minutes (the virtual campaign, the uncertainty budget of a
year of records) logs how much is done, the time taken and an estimate of the time left,
at every ``step_pct`` per cent of the work, through :mod:`logging` at INFO: in a rule's
log (``workflow.files.setup_logging``) it can be followed with ``tail -f``; a library user
who has not configured logging sees nothing. Log lines only: results never depend on it.

Dependency-free utility (standard library only), importable from every layer of the package.
"""

from __future__ import annotations

import logging
import math
import operator
import time
from collections.abc import Callable

__all__ = ["ProgressLog"]


class ProgressLog:
    """Log ``done of total unit (pct %) in t s, about r s left`` at every ``step_pct`` %,
    and always when the work is complete.

    Parameters
    ----------
    logger : logging.Logger
        Where the lines go (INFO).
    what : str
        What is being done, the start of each line (e.g. ``"campaign default"``).
    total : int
        Units of work in all (>= 0; 0 logs nothing).
    unit : str
        Name of a unit, plural (e.g. ``"records"``).
    step_pct : float
        Per cent of ``total`` between two lines, in (0, 100].
    clock : callable
        Monotonic clock in seconds (a parameter for tests).
    """

    def __init__(
        self,
        logger: logging.Logger,
        what: str,
        total: int,
        unit: str,
        *,
        step_pct: float = 10.0,
        clock: Callable[[], float] = time.monotonic,
    ):
        if not 0.0 < step_pct <= 100.0:
            raise ValueError(f"ProgressLog: step_pct must be in (0, 100], got {step_pct!r}")
        if int(total) < 0:
            raise ValueError(f"ProgressLog: total must be >= 0, got {total!r}")
        self.logger, self.what, self.unit = logger, what, unit
        self.total = int(total)
        self.step_pct = float(step_pct)
        self.clock = clock
        self.start_s = clock()
        self.done = 0
        self._next_pct = self.step_pct

    def update(self, n: int = 1) -> None:
        """Count ``n`` (an integer >= 0) more units done; log a line when a ``step_pct``
        mark is passed or the work is complete.

        Raises
        ------
        ValueError
            If ``n`` is negative or the count would exceed ``total`` (a caller's bug).
        """
        n = operator.index(n)  # 1.9 units is a bug, not 1
        if n < 0 or self.done + n > self.total:
            raise ValueError(
                f"ProgressLog {self.what!r}: cannot count {n} more {self.unit} "
                f"({self.done} of {self.total} done)"
            )
        self.done += n
        if self.total == 0:
            return
        pct = 100.0 * self.done / self.total
        complete = self.done == self.total
        if pct < self._next_pct and not complete:
            return
        # the next mark above the current share (several marks passed at once: one line);
        # a step that does not divide 100 still ends with the completion line
        self._next_pct = (math.floor(pct / self.step_pct) + 1) * self.step_pct
        if complete:
            self._next_pct = math.inf
        elapsed = self.clock() - self.start_s
        if complete:
            tail = ""
        else:
            left = elapsed * (self.total - self.done) / self.done
            tail = f", about {left:.0f} s left" if left >= 10 else f", about {left:.1f} s left"
        self.logger.info(
            "%s: %d of %d %s (%.0f %%) in %.1f s%s",
            self.what,
            self.done,
            self.total,
            self.unit,
            pct,
            elapsed,
            tail,
        )
