"""The import contract (pyproject.toml [tool.importlinter], docs/architecture.md).

`make test` runs `lint-imports` on the package; these tests show that the contract holds
on the tree and that it fails on a wrong-way import and on an import cycle inside a
layer (so the check can fail).
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
LINT = Path(sys.executable).with_name("lint-imports")

pytestmark = pytest.mark.skipif(not LINT.exists(), reason="import-linter not installed")


def _lint(root: Path) -> subprocess.CompletedProcess:
    env = {**os.environ, "PYTHONPATH": str(root / "src")}
    return subprocess.run(
        [str(LINT), "--no-cache"], cwd=root, env=env, capture_output=True, text=True, timeout=300
    )


def _copy_tree(tmp_path: Path) -> Path:
    root = tmp_path / "repo"
    shutil.copytree(REPO / "src", root / "src", ignore=shutil.ignore_patterns("__pycache__"))
    shutil.copy(REPO / "pyproject.toml", root / "pyproject.toml")
    return root


def test_import_contract_holds_on_the_tree(tmp_path):
    res = _lint(_copy_tree(tmp_path))
    assert res.returncode == 0, res.stdout + res.stderr
    assert "0 broken" in res.stdout


@pytest.mark.parametrize(
    ("module", "wrong_import"),
    [
        ("physics/lidar.py", "from flidar_uq.data import schema as _wrong  # noqa"),
        ("data/qc.py", "from flidar_uq.inference import Priors as _wrong  # noqa"),
        ("correction/los.py", "from flidar_uq.campaign import physics_mode as _wrong  # noqa"),
        ("seeding.py", "from flidar_uq.physics import lidar as _wrong  # noqa"),
    ],
)
def test_import_contract_fails_on_a_wrong_way_import(tmp_path, module, wrong_import):
    root = _copy_tree(tmp_path)
    path = root / "src" / "flidar_uq" / module
    path.write_text(path.read_text() + "\n" + wrong_import + "\n")
    res = _lint(root)
    assert res.returncode != 0
    assert "BROKEN" in res.stdout or "broken" in res.stdout
    wrong_target = wrong_import.split()[1]
    assert wrong_target in res.stdout, res.stdout


@pytest.mark.parametrize(
    ("module", "cycle_import", "ancestor"),
    [
        # io imports schema: schema importing io closes a cycle of two data modules
        ("data/schema.py", "from flidar_uq.data import io as _cycle  # noqa", "flidar_uq.data"),
        # metrics imports binning; an import inside a function counts as well
        (
            "data/binning.py",
            "def _cycle():\n    from flidar_uq.data import metrics  # noqa",
            "flidar_uq.data",
        ),
        # join imports common, both in the subpackage of the instrument readers
        (
            "data/formats/common.py",
            "from flidar_uq.data.formats import join as _cycle  # noqa",
            "flidar_uq.data.formats",
        ),
        # seastate imports hull, in another layer
        (
            "physics/hull.py",
            "from flidar_uq.physics import seastate as _cycle  # noqa",
            "flidar_uq.physics",
        ),
    ],
)
def test_import_contract_fails_on_an_import_cycle_inside_a_layer(
    tmp_path, module, cycle_import, ancestor
):
    root = _copy_tree(tmp_path)
    path = root / "src" / "flidar_uq" / module
    path.write_text(path.read_text() + "\n\n" + cycle_import + "\n")
    res = _lint(root)
    assert res.returncode != 0
    assert "No import cycles among the modules" in res.stdout, res.stdout
    assert "BROKEN" in res.stdout, res.stdout
    assert f"No cycles are allowed in {ancestor}." in res.stdout, res.stdout


def test_interfaces_doc_is_generated_and_up_to_date():
    # docs/interfaces.md is generated from the package, never copied by hand
    res = subprocess.run(
        [sys.executable, str(REPO / "scripts" / "api-index.py"), "--check"],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert res.returncode == 0, res.stderr
