"""ProgressLog: the progress lines of long steps (flidar_uq.progress)."""

from __future__ import annotations

import logging

import pytest

from flidar_uq.progress import ProgressLog


class _Clock:
    def __init__(self):
        self.t = 100.0

    def __call__(self):
        return self.t


def _lines(caplog):
    return [r.getMessage() for r in caplog.records if r.name == "test.progress"]


def _logged(caplog, updates, *, seconds_each=0.0, **kw):
    """The lines a ProgressLog(**kw) logs for ``updates``, the clock advancing
    ``seconds_each`` before each update."""
    clock = _Clock()
    with caplog.at_level(logging.INFO, logger="test.progress"):
        p = ProgressLog(logging.getLogger("test.progress"), clock=clock, **kw)
        for n in updates:
            clock.t += seconds_each
            p.update(n)
    return _lines(caplog)


def test_a_line_at_every_mark_with_the_time_left(caplog):
    kw = dict(what="campaign x", total=200, unit="records", step_pct=25.0)
    lines = _logged(caplog, [1] * 200, seconds_each=0.5, **kw)  # 0.5 s a record
    assert lines == [
        "campaign x: 50 of 200 records (25 %) in 25.0 s, about 75 s left",
        "campaign x: 100 of 200 records (50 %) in 50.0 s, about 50 s left",
        "campaign x: 150 of 200 records (75 %) in 75.0 s, about 25 s left",
        "campaign x: 200 of 200 records (100 %) in 100.0 s",
    ]


def test_a_big_update_passing_several_marks_logs_once(caplog):
    # 30 %: one line, next mark 40 %; nothing; 40 %; 100 %
    lines = _logged(caplog, [3, 0, 1, 6], what="w", total=10, unit="chunks")
    assert [m.split(" (")[0] for m in lines] == [
        "w: 3 of 10 chunks",
        "w: 4 of 10 chunks",
        "w: 10 of 10 chunks",
    ]


def test_a_step_not_dividing_100_still_ends_with_the_completion_line(caplog):
    kw = dict(what="w", total=10, unit="chunks", step_pct=30.0)
    assert _logged(caplog, [1] * 10, seconds_each=0.2, **kw) == [
        "w: 3 of 10 chunks (30 %) in 0.6 s, about 1.4 s left",
        "w: 6 of 10 chunks (60 %) in 1.2 s, about 0.8 s left",
        "w: 9 of 10 chunks (90 %) in 1.8 s, about 0.2 s left",
        "w: 10 of 10 chunks (100 %) in 2.0 s",
    ]


def test_counting_past_the_total_or_by_fractions_is_an_error():
    p = ProgressLog(logging.getLogger("test.progress"), "w", 5, "records")
    p.update(4)
    with pytest.raises(ValueError, match="cannot count 2 more records"):
        p.update(2)
    with pytest.raises(ValueError, match="cannot count -1 more"):
        p.update(-1)
    with pytest.raises(TypeError):
        p.update(1.9)
    p.update(1)
    assert p.done == 5


def test_nothing_to_do_logs_nothing_and_bad_settings_raise(caplog):
    log = logging.getLogger("test.progress")
    with caplog.at_level(logging.INFO, logger="test.progress"):
        ProgressLog(log, "w", 0, "records").update(0)
    assert _lines(caplog) == []
    for kw in ({"step_pct": 0.0}, {"step_pct": 150.0}):
        with pytest.raises(ValueError, match="step_pct"):
            ProgressLog(log, "w", 5, "records", **kw)
    with pytest.raises(ValueError, match="total"):
        ProgressLog(log, "w", -1, "records")
