"""The benchmark scripts and the docs that cite them agree.

At most ``MAX_SCRIPTS`` scripts in ``benchmarks/*.py`` (helpers the scripts share start with
``_`` and are not counted); each is cited as ``benchmarks/<name>.py`` by README.md or a page
of docs/ and has one row in the index table of docs/performance.md; every
``benchmarks/<name>.py`` the docs name, and every script the index names, exists.
"""

from __future__ import annotations

import re
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
MAX_SCRIPTS = 20
CITED = re.compile(r"benchmarks/([A-Za-z0-9_]+\.py)")
#: A row of the index table in docs/performance.md: its first cell is a script's name.
INDEX_ROW = re.compile(r"^\| `([A-Za-z0-9_]+\.py)` \|", re.MULTILINE)


def scripts() -> set[str]:
    """Benchmark scripts by file name, the shared helpers (``_*.py``) left out."""
    return {p.name for p in (REPO / "benchmarks").glob("*.py") if not p.name.startswith("_")}


def docs_text() -> dict[str, str]:
    """README.md and every docs/*.md page, by path relative to the repository."""
    paths = [REPO / "README.md", *sorted((REPO / "docs").glob("*.md"))]
    return {p.relative_to(REPO).as_posix(): p.read_text(encoding="utf-8") for p in paths}


def cited(texts: dict[str, str]) -> dict[str, set[str]]:
    """Script name -> the files that cite it as ``benchmarks/<name>.py``."""
    out: dict[str, set[str]] = {}
    for path, text in texts.items():
        for name in CITED.findall(text):
            out.setdefault(name, set()).add(path)
    return out


def test_scripts_are_found():
    names = scripts()
    assert "scaling.py" in names and "sbc.py" in names
    assert not any(n.startswith("_") for n in names)


def test_at_most_twenty_scripts():
    names = scripts()
    assert len(names) <= MAX_SCRIPTS, f"{len(names)} benchmark scripts: {sorted(names)}"


def test_every_script_is_cited_by_the_docs():
    by_name = cited(docs_text())
    missing = sorted(scripts() - set(by_name))
    assert missing == [], f"benchmark scripts no README.md or docs/*.md cites: {missing}"


def test_every_cited_script_exists():
    dangling = {
        name: sorted(paths) for name, paths in cited(docs_text()).items() if name not in scripts()
    }
    assert dangling == {}, f"docs cite benchmark scripts that do not exist: {dangling}"


def test_performance_index_has_one_row_per_script():
    rows = INDEX_ROW.findall((REPO / "docs" / "performance.md").read_text(encoding="utf-8"))
    assert sorted(rows) == sorted(scripts()), (
        "docs/performance.md's benchmark index and benchmarks/*.py differ: "
        f"not indexed {sorted(scripts() - set(rows))}, indexed but absent "
        f"{sorted(set(rows) - scripts())}, indexed twice "
        f"{sorted({r for r in rows if rows.count(r) > 1})}"
    )


def test_the_checks_catch_a_dangling_citation():
    texts = {"docs/x.md": "see `benchmarks/no_such_script.py` and `benchmarks/results/a.csv`"}
    assert cited(texts) == {"no_such_script.py": {"docs/x.md"}}
