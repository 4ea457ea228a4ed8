"""Every public function and class of the package is used by the product or is an entry point.

A public definition (top level, name without a leading underscore) of ``src/flidar_uq`` counts
as used when its name appears, in code (docstrings and comments left out), in another module
of the package, in ``workflow/`` or the ``Snakefile``, in ``scripts/`` or ``benchmarks/``, in
its own module outside its own definition, or as a console script of ``pyproject.toml``. What
only the tests call belongs in the tests (``tests/oracles.py``) or goes; the rest must be the
entry points listed in ``ENTRY_POINTS`` with the reason each is kept.
"""

from __future__ import annotations

import ast
import io
import re
import tokenize
import tomllib
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PACKAGE = ROOT / "src" / "flidar_uq"

#: Public definitions nothing in the product calls, kept on purpose: "module:name" -> reason.
ENTRY_POINTS = {
    "campaign/scan_kernel.py:attitude_trig": (
        "plain-NumPy reference of the compiled kernel's attitude trigonometry"
    ),
    "campaign/scan_kernel.py:attitude_truth": (
        "plain-NumPy reference of the compiled kernel's truth at the beam points"
    ),
    "correction/propagation.py:corrected_ti": (
        "per-record corrected TI from posterior draws, the propagation's library form"
    ),
    "correction/propagation.py:split_noise": (
        "the reference's noise split of docs/inference.md; the propagation inlines its pair form"
    ),
}

_IDENTIFIER = re.compile(r"[A-Za-z_][\w.]*")


def _docstring_nodes(tree: ast.AST) -> set[int]:
    """ids of the docstring expressions of a module and its classes and functions."""
    out = set()
    for node in ast.walk(tree):
        if isinstance(node, (ast.Module, ast.ClassDef, ast.FunctionDef, ast.AsyncFunctionDef)):
            body = node.body
            if body and isinstance(body[0], ast.Expr) and isinstance(body[0].value, ast.Constant):
                out.add(id(body[0].value))
    return out


def _all_nodes(tree: ast.AST) -> set[int]:
    """ids of the string constants of ``__all__ = [...]`` assignments."""
    out = set()
    for node in ast.walk(tree):
        if isinstance(node, (ast.Assign, ast.AugAssign, ast.AnnAssign)):
            targets = node.targets if isinstance(node, ast.Assign) else [node.target]
            if any(isinstance(t, ast.Name) and t.id == "__all__" for t in targets):
                out |= {id(c) for c in ast.walk(node) if isinstance(c, ast.Constant)}
    return out


def python_names(text: str) -> list[tuple[str, int]]:
    """Names a Python source uses in code, with their line: identifiers, attributes,
    imported names and strings that are a (dotted) identifier, e.g. a lazy export's key;
    docstrings and ``__all__`` left out."""
    tree = ast.parse(text)
    skip = _docstring_nodes(tree) | _all_nodes(tree)
    out = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Name):
            out.append((node.id, node.lineno))
        elif isinstance(node, ast.Attribute):
            out.append((node.attr, node.lineno))
        elif isinstance(node, ast.alias):
            out += [(part, node.lineno) for part in node.name.split(".")]
        elif (
            isinstance(node, ast.Constant)
            and isinstance(node.value, str)
            and id(node) not in skip
            and _IDENTIFIER.fullmatch(node.value)
        ):
            out += [(part, node.lineno) for part in node.value.split(".")]
    return out


def snakemake_names(text: str) -> set[str]:
    """Names a Snakefile or rule file uses: its name tokens and identifier strings."""
    out = set()
    for tok in tokenize.generate_tokens(io.StringIO(text).readline):
        if tok.type == tokenize.NAME:
            out.add(tok.string)
        elif tok.type == tokenize.STRING:
            body = tok.string.strip("\"'")
            if _IDENTIFIER.fullmatch(body):
                out |= set(body.split("."))
    return out


def console_script_names() -> set[str]:
    """The functions ``pyproject.toml`` installs as console scripts."""
    project = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]
    return {target.rsplit(":", 1)[-1] for target in project.get("scripts", {}).values()}


def public_definitions(path: Path) -> list[tuple[str, int, int]]:
    """(name, first line, last line) of a module's public top-level functions and classes."""
    out = []
    for node in ast.parse(path.read_text()).body:
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
            if not node.name.startswith("_"):
                first = min([node.lineno, *(d.lineno for d in node.decorator_list)])
                out.append((node.name, first, node.end_lineno))
    return out


def unused_definitions(root: Path = ROOT) -> list[str]:
    """ "module:name" of each public definition of the package used nowhere but in itself."""
    package = root / "src" / "flidar_uq"
    modules = {p: python_names(p.read_text()) for p in sorted(package.rglob("*.py"))}
    outside = set()
    for folder in ("workflow", "scripts", "benchmarks"):
        for p in sorted((root / folder).rglob("*")):
            if p.suffix == ".py":
                outside |= {name for name, _ in python_names(p.read_text())}
            elif p.suffix == ".smk":
                outside |= snakemake_names(p.read_text())
    outside |= snakemake_names((root / "Snakefile").read_text())
    outside |= console_script_names()
    other_modules = {p: {name for name, _ in names} for p, names in modules.items()}
    unused = []
    for path in modules:
        for name, first, last in public_definitions(path):
            own = any(n == name and not first <= line <= last for n, line in modules[path])
            elsewhere = any(name in names for p, names in other_modules.items() if p != path)
            if not (own or elsewhere or name in outside):
                unused.append(f"{path.relative_to(package).as_posix()}:{name}")
    return sorted(unused)


def test_python_names_skip_docstrings_all_and_messages():
    text = '''"""Module: uses_in_docstring()."""
__all__ = ["listed"]
KEYS = {"lazy_key": "pkg.mod"}


def f():
    """Calls documented_only()."""
    raise ValueError("message_only: bad")
    return g(h.attr)
'''
    names = {n for n, _ in python_names(text)}
    assert {"g", "h", "attr", "lazy_key", "pkg", "mod", "KEYS"} <= names
    assert not names & {"uses_in_docstring", "listed", "documented_only", "message_only"}


def test_a_definition_used_only_by_itself_or_the_tests_is_found(tmp_path):
    package = tmp_path / "src" / "flidar_uq"
    package.mkdir(parents=True)
    for folder in ("workflow", "scripts", "benchmarks"):
        (tmp_path / folder).mkdir()
    (tmp_path / "Snakefile").write_text('rule a:\n    run:\n        shell("x")\n')
    (tmp_path / "workflow" / "rules.smk").write_text("rule b:\n    run:\n        from_rule()\n")
    (tmp_path / "pyproject.toml").write_text('[project]\nscripts = {tool = "flidar_uq.m:main"}\n')
    (package / "m.py").write_text(
        "def main():\n    return helper()\n\n\ndef helper():\n    return 1\n\n\n"
        "def recursive(n):\n    return recursive(n - 1)\n\n\ndef from_rule():\n    pass\n\n\n"
        "class Unused:\n    pass\n"
    )
    (tmp_path / "tests").mkdir()
    (tmp_path / "tests" / "test_m.py").write_text("from flidar_uq.m import Unused, recursive\n")
    assert unused_definitions(tmp_path) == ["m.py:Unused", "m.py:recursive"]


def test_only_entry_points_are_unused_by_the_product():
    assert unused_definitions() == sorted(ENTRY_POINTS)
