"""The workflow on a real single-node SLURM cluster gives the same results as a local run.

scripts/slurm-up.sh starts munged, slurmctld and slurmd (root, Debian slurm-wlm + munge;
scripts/system-deps.sh installs them); scripts/slurm-down.sh stops them by their pid files.
The SLURM run uses the shipped profile (profiles/slurm: executor slurm, partition
``flidar``, ``--slurm-status-command squeue``). A fleet of two campaigns
(tests/test_fleet.py) runs there too: the same files as the local run, and jobs of the two
campaigns overlap in time on the cluster.
"""

from __future__ import annotations

import os
import subprocess
import time
from datetime import datetime
from pathlib import Path

import pytest
from conftest import IN_CI, require_tool
from test_fleet import TINY_FLEET, campaign_view, fleet_config, fleet_hashes
from test_workflow import REPO, check_outputs, result_hashes, snakemake, tiny_config


@pytest.fixture(scope="module")
def slurm_partition(tmp_path_factory):
    """Start the single-node cluster for this module; stop it afterwards."""
    for tool in ("munged", "slurmctld", "slurmd", "sbatch", "squeue", "sinfo"):
        require_tool(tool)
    if os.geteuid() != 0:
        msg = "starting SLURM needs root"
        if IN_CI:
            pytest.fail(msg)
        pytest.skip(msg)
    env = os.environ | {"FLIDAR_SLURM_STATE": str(tmp_path_factory.mktemp("slurm_state"))}
    up = subprocess.run(
        ["bash", str(REPO / "scripts" / "slurm-up.sh")],
        capture_output=True,
        text=True,
        env=env,
        timeout=180,
    )
    try:
        assert up.returncode == 0, up.stderr
        yield up.stdout.strip().splitlines()[-1]
    finally:
        down = slurm_down(env)
        assert down.returncode == 0, down.stderr


def slurm_down(env: dict) -> subprocess.CompletedProcess:
    """Run scripts/slurm-down.sh with ``env`` (its state dir and config path)."""
    return subprocess.run(
        ["bash", str(REPO / "scripts" / "slurm-down.sh")],
        capture_output=True,
        text=True,
        env=env,
        timeout=120,
    )


def run_on_slurm(workdir: Path, configfile: Path, partition: str, timeout: float = 900):
    """The workflow in ``workdir`` with the shipped SLURM profile."""
    return snakemake(
        workdir,
        configfile,
        "--profile",
        str(REPO / "profiles" / "slurm"),
        "--default-resources",
        f"slurm_partition={partition}",
        "mem_mb=1000",
        "runtime=30",
        "--seconds-between-status-checks",
        "3",
        timeout=timeout,
    )


def slurm_jobs() -> dict[str, dict]:
    """Every job squeue still lists (MinJobAge 600 s): id -> rule (the Snakemake SLURM
    plugin's comment ``rule_<name>[_wildcards_...]``), state, start and end times."""
    out = subprocess.run(
        ["squeue", "-h", "-t", "all", "-o", "%i|%k|%T|%S|%e"],
        capture_output=True,
        text=True,
        check=True,
    ).stdout
    jobs = {}
    for line in out.splitlines():
        job_id, comment, state, start, end = line.strip().split("|")
        jobs[job_id] = {"comment": comment, "state": state, "start": start, "end": end}
    return jobs


@pytest.mark.slow
def test_slurm_run_equals_local_run(slurm_partition, tmp_path):
    local, cluster = tmp_path / "local", tmp_path / "cluster"
    local.mkdir()
    cluster.mkdir()
    snakemake(local, tiny_config(local, tmp_path), "--cores", "2")
    run_on_slurm(cluster, tiny_config(cluster, tmp_path), slurm_partition)
    check_outputs(cluster, truth=True)
    # the jobs went through SLURM: finished jobs stay listed for MinJobAge (600 s)
    jobs = subprocess.run(
        ["squeue", "-h", "-t", "all", "-o", "%i %T"], capture_output=True, text=True
    ).stdout.split("\n")
    completed = [j for j in jobs if j.endswith("COMPLETED")]
    assert len(completed) >= 3, jobs  # campaign, the record fit, propagate
    assert result_hashes(cluster) == result_hashes(local)


@pytest.mark.slow
def test_slurm_fleet_run_equals_local_fleet_run(slurm_partition, tmp_path):
    """Two campaigns: the cluster's files equal the local run's, and the campaigns' jobs
    (independent branches of one DAG) run at the same time on the cluster."""
    local, cluster = tmp_path / "local", tmp_path / "cluster"
    local.mkdir()
    cluster.mkdir()
    snakemake(local, fleet_config(local, tmp_path), "--cores", "2", timeout=1500)
    before = set(slurm_jobs())
    t0 = time.monotonic()
    run_on_slurm(cluster, fleet_config(cluster, tmp_path), slurm_partition, timeout=1800)
    print(f"fleet of {len(TINY_FLEET)} on SLURM: {time.monotonic() - t0:.0f} s wall")
    for name in TINY_FLEET:
        check_outputs(campaign_view(cluster, name, tmp_path / "view" / name), truth=True)
    assert (cluster / "results" / "fleet" / "summary.csv").is_file()
    ran = {k: j for k, j in slurm_jobs().items() if k not in before}
    spans = {}
    for name in TINY_FLEET:
        mine = [j for j in ran.values() if j["comment"].startswith(f"rule_{name}_")]
        # campaign, the record fit, propagate (the per-bin fits run with the bin model only)
        assert sum(j["state"] == "COMPLETED" for j in mine) >= 3, (name, ran)
        spans[name] = [
            (datetime.fromisoformat(j["start"]), datetime.fromisoformat(j["end"])) for j in mine
        ]
    a, b = (spans[name] for name in TINY_FLEET)
    assert any(s1 < e2 and s2 < e1 for s1, e1 in a for s2, e2 in b), spans
    hashes = fleet_hashes(cluster)
    assert sum(k.endswith((".csv", ".parquet")) for k in hashes) >= 2 * 15 + 1
    assert hashes == fleet_hashes(local)


def test_slurm_profile_names_the_partition_and_squeue_status():
    import yaml

    profile = yaml.safe_load((REPO / "profiles" / "slurm" / "config.yaml").read_text())
    assert profile["executor"] == "slurm"
    assert profile["slurm-status-command"] == "squeue"
    assert profile["default-resources"]["slurm_partition"] == "flidar"
    assert Path(REPO / "scripts" / "slurm-up.sh").read_text().count("MinJobAge=600") == 1


def test_slurm_down_removes_only_the_config_slurm_up_wrote(tmp_path):
    """slurm-down.sh removes the slurm.conf that slurm-up.sh wrote (its mark), never another
    one: left behind, a config naming a controller that no longer runs makes every Snakemake
    start wait ~9 s (the SLURM executor plugin runs `scontrol show config` at import)."""
    up = (REPO / "scripts" / "slurm-up.sh").read_text().splitlines()
    mark = next(line.split('"')[1] for line in up if line.startswith("MARK="))
    ours, theirs = tmp_path / "ours.conf", tmp_path / "theirs.conf"
    ours.write_text(f"{mark}\nClusterName=flidar\n")
    theirs.write_text("ClusterName=site\n")
    for conf in (ours, theirs):
        env = os.environ | {
            "FLIDAR_SLURM_STATE": str(tmp_path / "state"),
            "FLIDAR_SLURM_CONF": str(conf),
        }
        down = slurm_down(env)
        assert down.returncode == 0, down.stderr
    assert not ours.exists() and theirs.exists()
