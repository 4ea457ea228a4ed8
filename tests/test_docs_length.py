"""The hand-written documentation stays readable: docs/*.md at most 45,000 words.

docs/interfaces.md is generated from the package's docstrings (scripts/api-index.py) and is
outside the budget (docs/architecture.md).
"""

from __future__ import annotations

from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
MAX_WORDS = 45_000
GENERATED = {"interfaces.md"}


def doc_words(docs: Path) -> dict[str, int]:
    """``{file name: words}`` of the hand-written ``*.md`` pages in ``docs``."""
    return {
        p.name: len(p.read_text(encoding="utf-8").split())
        for p in sorted(docs.glob("*.md"))
        if p.name not in GENERATED
    }


def test_hand_written_docs_within_the_word_budget():
    words = doc_words(REPO / "docs")
    assert "inference.md" in words and "interfaces.md" not in words
    total = sum(words.values())
    largest = sorted(words.items(), key=lambda kv: -kv[1])[:3]
    assert total <= MAX_WORDS, f"docs/*.md: {total} words > {MAX_WORDS}; largest {largest}"


def test_word_count_skips_the_generated_page(tmp_path):
    (tmp_path / "a.md").write_text("one two three\n")
    (tmp_path / "interfaces.md").write_text("generated " * 100)
    (tmp_path / "b.txt").write_text("not a page")
    assert doc_words(tmp_path) == {"a.md": 3}
