"""The order in which ``make test`` hands the test files to its processes
(tests/conftest.py): the files with the most slow tests first."""

from __future__ import annotations

import re
from pathlib import Path
from types import SimpleNamespace

from conftest import pytest_collection_modifyitems

REPO = Path(__file__).resolve().parents[1]


def _item(path: str, name: str, slow: bool) -> SimpleNamespace:
    return SimpleNamespace(
        path=Path(path),
        name=name,
        get_closest_marker=lambda mark: object() if slow and mark == "slow" else None,
    )


def test_files_with_the_most_slow_tests_come_first_each_in_its_own_order():
    items = [
        _item("a.py", "a1", False),
        _item("a.py", "a2", False),
        _item("b.py", "b1", True),
        _item("b.py", "b2", False),
        _item("c.py", "c1", False),
        _item("c.py", "c2", True),
        _item("c.py", "c3", True),
        _item("d.py", "d1", True),
    ]
    pytest_collection_modifyitems(None, items)
    assert [i.name for i in items] == ["c1", "c2", "c3", "b1", "b2", "d1", "a1", "a2"]


def test_make_test_keeps_that_order():
    # pytest-xdist's loadfile reorders the files by their number of tests unless told not to
    recipe = (REPO / "Makefile").read_text().split("\ntest: venv\n", 1)[1].split("\n\n", 1)[0]
    assert re.search(r"--dist loadfile\b", recipe), recipe
    assert "--no-loadscope-reorder" in recipe, recipe
