"""Every repository path the user documentation names exists.

README.md, docs/*.md and config/README.md name files and directories of the repository in
inline code (`config/config.yaml`) and as link targets ([...](docs/inference.md)). A path
that starts with one of the repository's top-level directories must exist (results/ is
not checked: it is written by a run). A glob (``*``), a placeholder (``<rule>``) or a
brace list (``{csv,png}``) must match at least one file; ``::test`` and ``#anchor``
suffixes are ignored.
"""

from __future__ import annotations

import itertools
import re
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
DOCS = [REPO / "README.md", REPO / "config" / "README.md", *sorted((REPO / "docs").glob("*.md"))]
TOP_DIRS = ("src", "docs", "config", "workflow", "tests", "benchmarks", "scripts", "profiles")

_FENCE = re.compile(r"^```.*?^```", re.M | re.S)
_CODE = re.compile(r"`([^`\s]+)`")
_LINK = re.compile(r"\]\(([^)\s]+)\)")


def _candidates(text: str, doc: Path) -> set[str]:
    """Repository-relative paths named by a Markdown text (fenced blocks skipped)."""
    text = _FENCE.sub("", text)
    out = set(_CODE.findall(text))
    for target in _LINK.findall(text):
        if "://" in target or target.startswith(("#", "mailto:")):
            continue
        resolved = (doc.parent / target.split("#")[0]).resolve()
        if resolved.is_relative_to(REPO):
            out.add(resolved.relative_to(REPO).as_posix())
    paths = set()
    for item in out:
        item = item.split("::")[0].split("#")[0].rstrip(".,;:")
        if item.split("/")[0] in TOP_DIRS and "/" in item:
            paths.add(item)
    return paths


def _expand_braces(path: str) -> list[str]:
    """`a.{csv,png}` -> [`a.csv`, `a.png`] (every brace list, all combinations)."""
    parts = re.split(r"\{([^{}]*)\}", path)
    choices = [[p] if i % 2 == 0 else p.split(",") for i, p in enumerate(parts)]
    return ["".join(c) for c in itertools.product(*choices)]


def _exists(path: str) -> bool:
    """The path exists; a glob or a <placeholder> matches at least one file."""
    for p in _expand_braces(path):
        pattern = re.sub(r"<[^<>/]+>", "*", p).rstrip("/")
        found = any(REPO.glob(pattern)) if "*" in pattern else (REPO / pattern).exists()
        if not found:
            return False
    return True


def missing_paths(doc: Path) -> list[str]:
    """The repository paths named in ``doc`` that do not exist."""
    return sorted(p for p in _candidates(doc.read_text(encoding="utf-8"), doc) if not _exists(p))


@pytest.mark.parametrize("doc", DOCS, ids=lambda p: p.relative_to(REPO).as_posix())
def test_every_repository_path_the_docs_name_exists(doc):
    missing = missing_paths(doc)
    assert not missing, f"{doc.relative_to(REPO)} names paths that do not exist: {missing}"


def test_the_path_check_finds_a_missing_file_and_accepts_globs_and_suffixes():
    doc = REPO / "docs" / "example.md"  # read from text below, never written
    text = (
        "`config/config.yaml`, `workflow/rules/*.smk`, `workflow/scripts/<rule>.py`, "
        "`tests/test_doc_paths.py::test_every_repository_path_the_docs_name_exists`, "
        "[guide](user-guide.md#outputs), `results/ti/records.csv`, `flidar_uq/x.py`, "
        "`workflow/schemas/config.schema.yaml`, [x](../config/scenarios/README.md), "
        "`benchmarks/results/nothing.{csv,png}`\n```\n`docs/in_a_fence.md`\n```\n"
    )
    found = sorted(p for p in _candidates(text, doc) if not _exists(p))
    assert found == [
        "benchmarks/results/nothing.{csv,png}",
        "config/scenarios/README.md",
        "workflow/schemas/config.schema.yaml",
    ]
