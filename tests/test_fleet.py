"""A fleet of campaigns (config key ``campaigns``): config merging and checks, the fleet
summary, the DAG of two campaigns (dry run, the user guide's example) and (slow) a tiny
two-campaign run whose campaign trees equal single-campaign runs byte for byte.

The SLURM run of the same fleet is in tests/test_slurm.py.
"""

from __future__ import annotations

import io
import os
import re
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
import yaml
from test_workflow import REPO, check_outputs, load_yaml, result_hashes, snakemake, tiny_config

from flidar_uq.workflow.files import write_csv
from flidar_uq.workflow.fleet import FLEET_COLUMNS, fleet_table
from flidar_uq.workflow.inputs import (
    ConfigError,
    campaign_configs,
    check_config,
    pipeline_preflight,
)

CONFIG = REPO / "config" / "config.yaml"

#: The tiny fleet of the end-to-end tests: two virtual campaigns of the tiny scenario,
#: different campaign and sampler seeds.
TINY_FLEET = {
    "buoyA": {"campaign": {"seed": 7}},
    "buoyB": {"campaign": {"seed": 8}, "inference": {"seed": 43}},
}


def fleet_config(workdir: Path, shared: Path | None = None) -> Path:
    """tiny_config of test_workflow with the two campaigns of :data:`TINY_FLEET`."""
    path = tiny_config(workdir, shared)
    cfg = load_yaml(path)
    cfg["campaigns"] = TINY_FLEET
    path.write_text(yaml.safe_dump(cfg))
    return path


def readme_fleet_example() -> dict:
    """The config of the user guide's "A fleet of buoys" section (its first YAML block)."""
    readme = (REPO / "docs" / "user-guide.md").read_text()
    section = readme.split("## A fleet of buoys", 1)[1].split("\n## ", 1)[0]
    block = re.search(r"```yaml\n(.*?)```", section, re.S)
    assert block, "docs/user-guide.md: no yaml block in 'A fleet of buoys'"
    return yaml.safe_load(block.group(1))


def full_config(**extra) -> dict:
    return load_yaml(CONFIG) | extra


# --------------------------------------------------------------------------- config


def test_campaign_configs_lay_each_campaigns_sections_over_the_shared_ones():
    cfg = check_config(
        full_config(
            campaigns={
                "B": {"campaign": {"seed": 3}, "reference": {"separation_m": 5.0}},
                "A": {"campaign": {"scenario": "cup_reference"}},
            }
        )
    )
    out = campaign_configs(cfg)
    assert list(out) == ["B", "A"]  # the config's order
    assert out["B"]["campaign"]["seed"] == 3
    assert out["B"]["campaign"]["scenario"] == cfg["campaign"]["scenario"]  # shared key kept
    assert out["B"]["reference"]["separation_m"] == 5.0
    assert out["A"]["campaign"]["seed"] == cfg["campaign"]["seed"]
    assert out["A"]["campaign"]["scenario"] == "cup_reference"
    for merged in out.values():
        assert "campaigns" not in merged
        assert set(merged) == set(cfg) - {"campaigns"}
        assert merged["inference"] == cfg["inference"]  # not overridden: shared
    # a copy: changing one campaign's config leaves the shared one alone
    out["A"]["qc"]["sv_max"] = 1.0
    assert cfg["qc"]["sv_max"] != 1.0
    assert campaign_configs(check_config(full_config())) == {}


def test_campaign_configs_replace_a_keys_value_whole():
    cfg = full_config()
    cfg["campaign"]["columns"] = {"Spd": "hws_mean_ms", "Std": "hws_std_ms"}
    cfg["campaigns"] = {"A": {"campaign": {"columns": {"WS": "hws_mean_ms"}}}}
    assert campaign_configs(cfg)["A"]["campaign"]["columns"] == {"WS": "hws_mean_ms"}


@pytest.mark.parametrize(
    ("campaigns", "message"),
    [
        (
            {"buoyA": {"campaign": {}}, "buoyB": {"campaign": {"source": "files"}}},
            "config key campaigns.buoyB.campaign.records: missing, but campaign.source is 'files'",
        ),
        (
            {"buoyA": {"campaign": {"recordz": "x.csv"}}},
            "config key campaigns.buoyA.campaign.recordz: unknown key (did you mean "
            "campaigns.buoyA.campaign.records?)",
        ),
        ({"2nd": {"campaign": {}}}, "config key campaigns.2nd: not a campaign name"),
        ({"fleet": {"campaign": {}}}, "config key campaigns.fleet: reserved name"),
        ({"buoyA": {"reference": {}}}, "config key campaigns.buoyA: 'campaign' is a required"),
        ({}, "config key campaigns: {} should be non-empty"),
        (
            {"buoyA": {"campaign": {}, "inference": {"nbatches": 0}}},
            "config key campaigns.buoyA.inference.nbatches: 0 is less than the minimum of 1",
        ),
        (
            {"buoyA": {"campaign": {"scenario": "nowhere"}}},
            "config key campaigns.buoyA.campaign.scenario: no shipped scenario 'nowhere'",
        ),
        (
            {"buoyA": {"campaign": {}, "reference": {"kind": "cup"}}},
            "campaigns.buoyA: config key reference.kind='cup' contradicts the virtual "
            "campaign's reference_instrument",
        ),
    ],
)
def test_a_bad_campaign_is_one_line_naming_its_key(campaigns, message):
    err = io.StringIO()
    assert pipeline_preflight(full_config(campaigns=campaigns), stream=err) == 2
    line = err.getvalue()
    assert line.count("\n") == 1, line
    assert line.startswith(f"flidar-uq: error: {message}"), line


def test_a_shared_section_is_checked_in_each_campaign():
    """A problem of the shared sections that only a campaign's merge reveals names it."""
    cfg = full_config(campaigns={"A": {"campaign": {}}, "B": {"campaign": {"seed": 2}}})
    cfg["priors"]["period_min_s"] = 30.0  # above period_max_s
    with pytest.raises(ConfigError, match=r"^config key campaigns\.A\.priors\.period_min_s"):
        check_config(cfg)


# --------------------------------------------------------------------------- summary


def _campaign_dir(root: Path, *, truth: bool, kind: str) -> Path:
    ti = root / "ti"
    ti.mkdir(parents=True)
    records = pd.DataFrame(
        {
            "height_m": [40.0, 40.0, 40.0, 40.0, 90.0, 90.0],
            "ti_corrected_median": [0.10, 0.12, 0.11, np.nan, 0.08, 0.09],
            "ti_corrected_lo": [0.09, 0.11, 0.10, np.nan, 0.07, 0.08],
            "ti_corrected_hi": [0.11, 0.13, 0.12, np.nan, 0.09, 0.10],
        }
    )
    if truth:  # inside, outside, inside, (uncorrected), inside, outside
        records["ti_true"] = [0.10, 0.20, 0.115, 0.1, 0.085, 0.2]
    write_csv(records, ti / "records.csv")
    groups = pd.DataFrame(
        {
            "grouping": ["campaign", "campaign", "direction sector"],
            "height_m": [40.0, 90.0, 40.0],
            "ti_mean": [0.11, 0.085, 0.5],
            "ti_mean_lo": [0.105, 0.08, 0.4],
            "ti_mean_hi": [0.115, 0.09, 0.6],
            "ti_mean_uncorrected": [0.13, 0.1, 0.55],
        }
    )
    write_csv(groups, ti / "groups.csv")
    write_csv(pd.DataFrame({"reference_kind": [kind], "credible_mass": [0.9]}), ti / "metrics.csv")
    return root


def test_fleet_table_per_campaign_and_height(tmp_path):
    dirs = {
        "north": _campaign_dir(tmp_path / "north", truth=True, kind="cup"),
        "south": _campaign_dir(tmp_path / "south", truth=False, kind="none"),
    }
    table = fleet_table(dirs)
    assert list(table.columns) == list(FLEET_COLUMNS)
    assert list(zip(table["campaign"], table["height_m"], strict=True)) == [
        ("north", 40.0),
        ("north", 90.0),
        ("south", 40.0),
        ("south", 90.0),
    ]
    north = table[table["campaign"] == "north"].set_index("height_m")
    assert north["n_records"].tolist() == [4, 2]
    assert north["n_corrected"].tolist() == [3, 2]
    assert north["n_truth"].tolist() == [3, 2]
    np.testing.assert_allclose(north["coverage"], [2 / 3, 1 / 2])
    np.testing.assert_allclose(north["ti_mean"], [0.11, 0.085])  # campaign rows only
    np.testing.assert_allclose(north["ti_mean_hi"], [0.115, 0.09])
    south = table[table["campaign"] == "south"]
    assert south["coverage"].isna().all() and (south["n_truth"] == 0).all()
    assert set(table["reference_kind"]) == {"cup", "none"}


# --------------------------------------------------------------------------- DAG


def test_readme_example_builds_both_trees_and_the_fleet_summary(tmp_path):
    example = readme_fleet_example()
    assert len(example["campaigns"]) == 2
    path = tmp_path / "fleet.yaml"
    path.write_text(yaml.safe_dump(example))
    plan = snakemake(tmp_path, path, "-n", "--cores", "2", timeout=300).stdout
    for name in example["campaigns"]:  # the job stats: every step once per campaign
        for rule in ("campaign", "validate", "bins", "fit_global_model", "propagate", "report"):
            assert re.search(rf"^{name}_{rule}\s+\d+$", plan, re.M), f"{name}_{rule}\n{plan}"
        # the record motion model (the default): no per-bin fit in any campaign
        assert not re.search(rf"^{name}_(infer_batch|ti_bins)\s+\d+$", plan, re.M), plan
    assert re.search(r"^fleet_summary\s+1$", plan, re.M), plan
    # the files of each tree (dry run: the jobs' outputs up to the checkpoint, and after)
    for name in example["campaigns"]:
        for rel in ("campaign/records.parquet", "ti/records.csv", "report/report.html"):
            assert f"results/{name}/{rel}" in plan, f"results/{name}/{rel}"
    assert "results/fleet/summary.csv" in plan and "results/fleet/summary.html" in plan
    assert "results/ti/records.csv" not in plan  # no single-campaign tree beside them
    assert not (tmp_path / "results").exists()


# --------------------------------------------------------------------------- end to end


def campaign_view(workdir: Path, name: str, where: Path) -> Path:
    """A directory whose results/ is campaign ``name``'s tree (for check_outputs and
    result_hashes of test_workflow, which read <dir>/results)."""
    where.mkdir(parents=True)
    os.symlink(workdir / "results" / name, where / "results", target_is_directory=True)
    return where


def fleet_hashes(workdir: Path) -> dict[str, str]:
    """result_hashes of a fleet's results/, without each campaign's (and the fleet summary's)
    logs and run-time benchmarks."""
    return {
        k: v
        for k, v in result_hashes(workdir).items()
        if not re.match(r"results/[^/]+/(logs|benchmarks)/", k)
    }


def tree_hashes(workdir: Path) -> dict[str, str]:
    """result_hashes without the HTML report (its provenance names the results paths)."""
    return {k: v for k, v in result_hashes(workdir).items() if not k.endswith(".html")}


@pytest.mark.slow
def test_tiny_fleet_trees_equal_single_campaign_runs(tmp_path):
    fleet, single = tmp_path / "fleet", tmp_path / "single"
    fleet.mkdir()
    single.mkdir()
    snakemake(fleet, fleet_config(fleet, tmp_path), "--cores", "2", timeout=1500)
    assert sorted(p.name for p in (fleet / "results").iterdir()) == ["buoyA", "buoyB", "fleet"]
    views = {}
    for name in TINY_FLEET:
        views[name] = campaign_view(fleet, name, tmp_path / "view" / name)
        check_outputs(views[name], truth=True)
    # campaign A of the fleet = a single-campaign run of A, byte for byte
    snakemake(single, tiny_config(single, tmp_path, seed=7), "--cores", "2", timeout=1500)
    a = tree_hashes(views["buoyA"])
    assert len([k for k in a if k.endswith((".csv", ".parquet"))]) >= 15
    assert a == tree_hashes(single)
    assert a != tree_hashes(views["buoyB"])  # the other campaign is another campaign
    # the fleet summary: both campaigns at both heights, from their own trees
    summary = pd.read_csv(fleet / "results" / "fleet" / "summary.csv")
    assert list(summary.columns) == list(FLEET_COLUMNS)
    assert len(summary) == 2 * 2
    for name in TINY_FLEET:
        rows = summary[summary["campaign"] == name]
        records = pd.read_csv(fleet / "results" / name / "ti" / "records.csv")
        assert rows["n_records"].sum() == len(records)
        assert rows["n_corrected"].sum() == records["ti_corrected_median"].notna().sum()
        assert rows["coverage"].between(0, 1).all()  # the truth is known
        assert (rows["reference_kind"] == "fixed_lidar").all()
    html = (fleet / "results" / "fleet" / "summary.html").read_text()
    assert 'href="../buoyA/report/report.html"' in html and "data:image/png" in html
    # a rerun does nothing
    out = snakemake(fleet, fleet / "config.yaml", "-n", "--cores", "2").stdout
    assert "Nothing to be done" in out
