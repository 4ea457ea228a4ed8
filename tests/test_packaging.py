"""Packaging: declared dependencies, package data, and a non-editable install.

- every third-party package imported by ``src/`` (and ``workflow/scripts/``) is declared in
  pyproject.toml, the optional ones in an extra and imported inside functions only;
- requirements.lock pins every declared dependency at a version its specifier allows;
- the data files the package reads at run time (config schema, scenarios, report
  templates) are package data, found with importlib.resources, never by a path relative
  to the source tree;
- (slow) ``pip install`` without ``-e`` into a fresh venv runs ``flidar-uq validate
  --config``, ``flidar-uq generate-campaign --scenario tiny`` and the default pipeline on
  the tiny scenario from a directory outside the repository.
"""

from __future__ import annotations

import ast
import fnmatch
import functools
import importlib.metadata
import json
import os
import shutil
import subprocess
import sys
import sysconfig
import time
import tomllib
from pathlib import Path

import pytest
import yaml
from packaging.requirements import Requirement
from packaging.utils import canonicalize_name
from test_workflow import TINY_BINNING, TINY_INFERENCE

REPO = Path(__file__).resolve().parents[1]
PACKAGE = REPO / "src" / "flidar_uq"
PYPROJECT = tomllib.loads((REPO / "pyproject.toml").read_text())
#: The code that runs in a user's pipeline: the package and the workflow's scripts.
CODE_DIRS = (PACKAGE, REPO / "workflow" / "scripts")


# ---- imports against the declared dependencies --------------------------------------------


def _requirements(extra: str | None = None) -> list[Requirement]:
    project = PYPROJECT["project"]
    reqs = project["dependencies"] if extra is None else project["optional-dependencies"][extra]
    return [Requirement(r) for r in reqs]


def _declared(extra: str | None = None) -> set[str]:
    return {canonicalize_name(r.name) for r in _requirements(extra)}


def third_party_imports(dirs) -> dict[str, list[tuple[Path, int, bool]]]:
    """Top-level names of the absolute imports in the ``*.py`` files under ``dirs`` that are
    neither the standard library nor flidar_uq: name -> [(file, line, at module level)]."""
    found: dict[str, list[tuple[Path, int, bool]]] = {}
    for root in dirs:
        for path in sorted(Path(root).rglob("*.py")):
            tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
            function_level = {
                id(node)
                for fn in ast.walk(tree)
                if isinstance(fn, ast.FunctionDef | ast.AsyncFunctionDef)
                for node in ast.walk(fn)
            }
            for node in ast.walk(tree):
                if isinstance(node, ast.Import):
                    names = [a.name for a in node.names]
                elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
                    names = [node.module]
                else:
                    continue
                for name in names:
                    top = name.split(".")[0]
                    if top in sys.stdlib_module_names or top in {"flidar_uq", "__future__"}:
                        continue
                    where = (path, node.lineno, id(node) not in function_level)
                    found.setdefault(top, []).append(where)
    return found


@functools.cache
def _providers() -> dict[str, list[str]]:
    return importlib.metadata.packages_distributions()


def import_problems(dirs, base: set[str], extras: dict[str, set[str]]) -> list[str]:
    """What is wrong with the third-party imports under ``dirs``: a module no installed
    distribution provides, a distribution declared nowhere, or one declared in an extra
    only but imported at module level (the package would not import without the extra)."""
    providers = _providers()
    problems = []
    for top, sites in sorted(third_party_imports(dirs).items()):
        file, line, _ = sites[0]
        dists = {canonicalize_name(d) for d in providers.get(top, [])}
        if not dists:
            problems.append(f"{file}:{line}: no installed distribution provides {top!r}")
        elif dists & base:
            continue
        elif any(dists & names for names in extras.values()):
            extra = next(e for e, names in extras.items() if dists & names)
            problems += [
                f"{f}:{n}: {top!r} (extra [{extra}] only) imported at module level"
                for f, n, module_level in sites
                if module_level
            ]
        else:
            problems.append(f"{file}:{line}: {top!r} ({', '.join(sorted(dists))}) not declared")
    return problems


def _runtime_extras() -> dict[str, set[str]]:
    """The extras a user installs for a feature (the test extra is the developers')."""
    extras = PYPROJECT["project"]["optional-dependencies"]
    return {e: _declared(e) for e in extras if e != "test"}


def test_every_imported_package_is_declared():
    assert import_problems(CODE_DIRS, _declared(), _runtime_extras()) == []


def test_an_undeclared_or_eager_optional_import_is_caught(tmp_path):
    (tmp_path / "mod.py").write_text(
        "import numpy\nimport arviz_stats\nimport pyconturb\n\n"
        "def f():\n    import pyconturb.sig_models\n"
    )
    base = _declared() - {"arviz-stats"}
    problems = import_problems([tmp_path], base, _runtime_extras())
    assert len(problems) == 2, problems
    assert "'arviz_stats' (arviz-stats) not declared" in problems[0]
    assert "mod.py:3: 'pyconturb' (extra [simulate] only) imported at module level" in problems[1]


def test_the_generator_and_the_tests_extra_is_simulate():
    """PyConTurb (3-D fields, used by tests only) is the simulate extra, not a base
    dependency; the test extra pulls it in (`make test` installs .[test])."""
    assert "pyconturb" in _declared("simulate")
    assert "pyconturb" not in _declared()
    assert any(r.name == "flidar_uq" and "simulate" in r.extras for r in _requirements("test"))


def test_the_lock_pins_every_declared_dependency():
    """requirements.lock (scripts/lock.sh) satisfies every specifier of pyproject.toml."""
    pins = {}
    for line in (REPO / "requirements.lock").read_text().splitlines():
        if line.strip() and not line.startswith("#"):
            name, _, version = line.partition("==")
            pins[canonicalize_name(name)] = version.strip()
    extras = PYPROJECT["project"]["optional-dependencies"]
    reqs = _requirements() + [r for e in extras for r in _requirements(e)]
    bad = [
        f"{r} (lock: {pins.get(canonicalize_name(r.name), 'absent')})"
        for r in reqs
        if r.name != "flidar_uq"
        and not r.specifier.contains(pins.get(canonicalize_name(r.name), "0.dev0"), True)
    ]
    assert bad == []


# ---- package data --------------------------------------------------------------------------


def test_run_time_files_are_package_data():
    """Every file under resources/ and workflow/templates/ matches a package-data pattern,
    so a wheel ships it."""
    patterns = PYPROJECT["tool"]["setuptools"]["package-data"]["flidar_uq"]
    files = [
        p.relative_to(PACKAGE).as_posix()
        for sub in ("resources", "workflow/templates")
        for p in (PACKAGE / sub).rglob("*")
        if p.is_file() and "__pycache__" not in p.parts and p.suffix != ".py"
    ]
    assert len(files) > 20
    missed = [f for f in files if not any(fnmatch.fnmatchcase(f, pat) for pat in patterns)]
    assert missed == []


def test_no_path_into_the_source_tree():
    """The package finds its files with importlib.resources, not ``Path(__file__).parents``
    (which points into the repository only in an editable install)."""
    offenders = [
        f"{p.relative_to(REPO)}:{n}"
        for p in sorted(PACKAGE.rglob("*.py"))
        for n, line in enumerate(p.read_text(encoding="utf-8").splitlines(), 1)
        if "__file__" in line or ".parents[" in line
    ]
    assert offenders == []


def test_the_schema_and_scenarios_are_found_as_resources():
    from flidar_uq.campaign.scenarios import load_scenario, scenario_dir
    from flidar_uq.resources import resource_path
    from flidar_uq.workflow.inputs import SCHEMA_PATH

    assert SCHEMA_PATH == resource_path("config.schema.yaml")
    assert yaml.safe_load(SCHEMA_PATH.read_text())["type"] == "object"
    names = {p.stem for p in scenario_dir().glob("*.yaml")}
    assert {"default", "tiny"} <= names
    assert load_scenario("tiny")["name"] == "tiny"
    with pytest.raises(FileNotFoundError, match="resource 'no/such.yaml' missing"):
        resource_path("no", "such.yaml")


# ---- a non-editable install (slow) ---------------------------------------------------------

#: Small sampler and binning settings of the pipeline on the tiny scenario (as the
#: end-to-end tests of test_workflow.py).
_TINY_RUN = {
    "campaign": {"source": "virtual", "scenario": "tiny", "seed": 7},
    "binning": TINY_BINNING,
    "inference": TINY_INFERENCE,
    "propagation": {"ndraws": 100},
}


def _fresh_venv(tmp_path: Path) -> tuple[Path, Path]:
    """A new venv with flidar_uq installed from a copy of the sources without ``-e``; its
    dependencies are those of the running venv, seen through a .pth file (no download of
    the dependencies; the build backend is fetched as by ``make venv``)."""
    venv = tmp_path / "venv"
    subprocess.run([sys.executable, "-m", "venv", "--without-pip", str(venv)], check=True)
    python = venv / "bin" / "python"
    site = Path(
        subprocess.run(
            [str(python), "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])"],
            check=True,
            capture_output=True,
            text=True,
        ).stdout.strip()
    )
    # a plain path line: the running venv's distributions, not its .pth files (so not the
    # editable finder of flidar_uq pointing at src/)
    (site / "zz_running_venv.pth").write_text(sysconfig.get_paths()["purelib"] + "\n")
    src = tmp_path / "sdist"
    src.mkdir()
    for name in ("pyproject.toml", "README.md", *[p.name for p in REPO.glob("LICENSE*")]):
        shutil.copy(REPO / name, src / name)
    shutil.copytree(
        REPO / "src",
        src / "src",
        ignore=shutil.ignore_patterns("__pycache__", "*.egg-info", "*.nbi", "*.nbc"),
    )
    pip = [sys.executable, "-m", "pip", "--python", str(python), "install", "-q", "--no-deps"]
    res = subprocess.run([*pip, str(src)], capture_output=True, text=True, timeout=600)
    assert res.returncode == 0, res.stderr[-3000:]
    shutil.rmtree(src)  # nothing left to read but the installed copy
    return python, site


def _run(cmd, cwd: Path, env: dict, timeout: float = 600) -> subprocess.CompletedProcess:
    res = subprocess.run(cmd, cwd=cwd, env=env, capture_output=True, text=True, timeout=timeout)
    assert res.returncode == 0, f"{cmd} failed ({res.returncode}):\n{res.stderr[-4000:]}"
    return res


@pytest.mark.slow
def test_non_editable_install_runs_the_cli_and_the_pipeline(tmp_path):
    t0 = time.perf_counter()
    python, site = _fresh_venv(tmp_path)
    bindir = python.parent
    env = {k: v for k, v in os.environ.items() if k not in {"PYTHONPATH", "VIRTUAL_ENV"}}
    env |= {"PATH": f"{bindir}{os.pathsep}{env.get('PATH', '')}", "VIRTUAL_ENV": str(bindir.parent)}
    work = tmp_path / "run"
    work.mkdir()

    # the installed copy, not the source tree: module, schema, scenarios, templates
    where = _run(
        [
            str(python),
            "-c",
            "import json, importlib.resources, flidar_uq\n"
            "from flidar_uq.workflow.inputs import SCHEMA_PATH\n"
            "from flidar_uq.campaign.scenarios import scenario_dir\n"
            "print(json.dumps([flidar_uq.__file__, str(SCHEMA_PATH), str(scenario_dir()),"
            " str(importlib.resources.files('flidar_uq.workflow') / 'templates')]))",
        ],
        work,
        env,
    )
    for path in json.loads(where.stdout):
        assert Path(path).resolve().is_relative_to(site.resolve()), path
        assert Path(path).exists(), path
    direct_url = importlib.metadata.Distribution.at(next(site.glob("flidar_uq-*.dist-info")))
    assert not json.loads(direct_url.read_text("direct_url.json"))["dir_info"].get("editable")

    # the CLI: a campaign from the shipped scenario, then a user config (the schema) on it
    cli = str(bindir / "flidar-uq")
    cmd = [cli, "generate-campaign", "--scenario", "tiny", "--seed", "1", "--output", "t.csv"]
    assert json.loads(_run(cmd, work, env).stdout)["n_records"] == 144 * 3
    user = work / "user.yaml"
    user.write_text(yaml.safe_dump({"campaign": {"source": "files", "records": "t.csv"}}))
    out = json.loads(_run([cli, "validate", "--json", "--config", str(user)], work, env).stdout)
    assert out["valid"] and out["n_records"] == 144 * 3, out
    bad = work / "bad.yaml"
    bad.write_text(yaml.safe_dump({"campaign": {"source": "files", "records": "t.csv", "x": 1}}))
    res = subprocess.run(
        [cli, "validate", "--config", str(bad)], cwd=work, env=env, capture_output=True, text=True
    )
    assert res.returncode == 2 and "campaign.x" in res.stderr, res.stderr
    t_cli = time.perf_counter() - t0

    # the pipeline: the workflow definition of the checkout, the installed package's code
    # and data (scenario tiny is read from site-packages), run outside the repository
    smk = [str(python), "-m", "snakemake", "-s", str(REPO / "Snakefile"), "--directory", str(work)]
    config = work / "config.yaml"
    config.write_text(yaml.safe_dump(_TINY_RUN))
    smk += ["--configfile", str(config), "--cores", "2"]
    dry = _run([*smk, "--dry-run"], work, env).stdout
    assert str(site / "flidar_uq" / "resources" / "scenarios" / "tiny.yaml") in dry, dry[-3000:]
    _run(smk, work, env, timeout=1200)
    for out_file in ("ti/records.csv", "posterior/global.nc", "report/report.html"):
        assert (work / "results" / out_file).stat().st_size > 0, out_file
    print(f"non-editable install + CLI {t_cli:.0f} s, total {time.perf_counter() - t0:.0f} s")


def test_license_is_an_spdx_string_and_setuptools_reads_it():
    """A license table is deprecated by setuptools (>= 77 reads the SPDX string): no
    deprecation warning on install."""
    assert PYPROJECT["project"]["license"] == "MIT"
    assert (REPO / PYPROJECT["project"]["license-files"][0]).is_file()
    (req,) = [r for r in PYPROJECT["build-system"]["requires"] if r.startswith("setuptools")]
    assert Requirement(req).specifier.contains("77") and not Requirement(req).specifier.contains(
        "76.9"
    )
