"""The product's text: no development-log wording, no paper file keys, no references to
files outside the repository, in README.md, docs/, src/, workflow/, config/ and Snakefile.

CHANGELOG.md (history) and benchmarks/ are exempt. The word "seed" alone is legitimate
(random seeds); only the papers' text-file keys ("seed 000" .. "seed 003", ``seed001_ls``,
``001_<hash>.txt``) are banned: cite a paper by author and year (docs/references.md).
"""

from __future__ import annotations

import re
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]

#: What the product's text must not contain, each with the reason printed on a failure.
BANNED = {
    "development log ('session')": re.compile(r"\bsessions?\b", re.IGNORECASE),
    "issue number ('issue <n>')": re.compile(r"\bissues?\s*#?\s*\d+", re.IGNORECASE),
    "paper file key ('seed 000'..'seed 003')": re.compile(
        r"(?<![0-9A-Za-z])seeds?(?:[_-]|\s*)00[0-3](?![0-9])", re.IGNORECASE
    ),
    "paper text file name ('00x_<hash>')": re.compile(r"(?<![0-9A-Za-z])00[0-3]_[0-9a-f]{6,}"),
    "file outside the repository (design.md)": re.compile(r"\bdesign\.md\b"),
    "file outside the repository (../shared)": re.compile(r"\.\./shared|\bshared/seeds\b"),
}

PRODUCT_PATHS = ("README.md", "Snakefile", "docs", "src", "workflow", "config")
SKIP_PARTS = {"__pycache__", ".ipynb_checkpoints"}
BINARY_SUFFIXES = {".png", ".jpg", ".jpeg", ".gif", ".pdf", ".nc", ".parquet", ".so", ".pyc"}


def product_files() -> list[Path]:
    """Every text file of the product paths (README, docs, src, workflow, config, Snakefile)."""
    out = []
    for name in PRODUCT_PATHS:
        path = REPO / name
        candidates = [path] if path.is_file() else sorted(p for p in path.rglob("*") if p.is_file())
        for p in candidates:
            rel = p.relative_to(REPO)
            if SKIP_PARTS & set(rel.parts) or any(part.endswith(".egg-info") for part in rel.parts):
                continue
            if p.suffix.lower() in BINARY_SUFFIXES:
                continue
            out.append(p)
    return out


def violations(text: str) -> list[str]:
    """The banned patterns found in ``text``, as ``"reason: 'match'"`` strings."""
    return [f"{reason}: {m.group(0)!r}" for reason, rx in BANNED.items() for m in rx.finditer(text)]


@pytest.mark.parametrize(
    "text",
    [
        "as measured in session 13",
        "Sessions 5-6 made it faster",
        "issue 13 asks for <= 25 s",
        "(owned by issue #3)",
        "Eq. 15 of seed 000",
        "Seed 001's least squares",
        "the seed-002 algorithm",
        "the conventional algorithm of seed\n    002 (a line break inside the key)",
        "seeds 001, 002",
        "column rho_seed000",
        "method seed001_ls",
        "the text 001_598710d490b3a7b7.txt",
        "see design.md, 'What real seas add'",
        "in ../shared/seeds/",
    ],
)
def test_banned_patterns_are_found(text):
    assert violations(text), text


@pytest.mark.parametrize(
    "text",
    [
        "seed: 42",
        "--seed 1",
        "slow, seeds 1 and 2",
        "numpy SeedSequence entropy 20181122",
        "Gutiérrez-Antuñano et al. (2018), Eq. 15",
        "least_squares, dbs_conventional, dbs_new",
        "gutierrez2018, malekmohammadi2024",
        "record 1001_a is fine",
        "docs/inference.md",
        "the issue is the grid",
    ],
)
def test_product_text_is_allowed(text):
    assert violations(text) == [], text


def test_product_files_are_found():
    files = {p.relative_to(REPO).as_posix() for p in product_files()}
    assert "README.md" in files and "Snakefile" in files and "config/config.yaml" in files
    assert any(f.startswith("docs/") for f in files) and any(f.startswith("src/") for f in files)
    assert not any(f.startswith(("benchmarks/", "tests/")) or f == "CHANGELOG.md" for f in files)


def test_no_banned_words_in_the_product():
    found = []
    for path in product_files():
        try:
            text = path.read_text(encoding="utf-8")
        except UnicodeDecodeError:
            continue
        for reason, rx in BANNED.items():  # the whole text: a key may span a line break
            for m in rx.finditer(text):
                lineno = text.count("\n", 0, m.start()) + 1
                found.append(f"{path.relative_to(REPO)}:{lineno}: {reason}: {m.group(0)!r}")
    assert not found, "product text to rephrase:\n" + "\n".join(found)


def test_citation_file_and_license():
    import tomllib

    import yaml

    cff = yaml.safe_load((REPO / "CITATION.cff").read_text(encoding="utf-8"))
    version = tomllib.loads((REPO / "pyproject.toml").read_text())["project"]["version"]
    assert cff["cff-version"] == "1.2.0"
    assert cff["title"] == "flidar_uq" and str(cff["version"]) == version
    assert cff["message"] and cff["authors"] and cff["license"] == "MIT"
    assert all(ref["title"] and ref["authors"] and ref["year"] for ref in cff["references"])
    licence = (REPO / "LICENSE").read_text()
    assert licence.startswith("MIT License") and "the flidar_uq authors" in licence


def test_readme_is_a_front_page():
    readme = (REPO / "README.md").read_text(encoding="utf-8")
    assert len(readme.split()) <= 1200
    assert "make run" in readme and "make test" in readme
    for link in re.findall(r"\]\(([^)#]+)", readme):
        assert (REPO / link).exists(), link
