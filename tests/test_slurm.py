"""The workflow on a real single-node SLURM cluster gives the same results as a local run.

scripts/slurm-up.sh starts munged, slurmctld and slurmd (root, Debian slurm-wlm + munge;
scripts/system-deps.sh installs them); scripts/slurm-down.sh stops them by their pid files.
The SLURM run uses the shipped profile (profiles/slurm: executor slurm, partition
``flidar``, ``--slurm-status-command squeue``).
"""

from __future__ import annotations

import os
import subprocess
from pathlib import Path

import pytest
from conftest import IN_CI, require_tool
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
        down = subprocess.run(
            ["bash", str(REPO / "scripts" / "slurm-down.sh")],
            capture_output=True,
            text=True,
            env=env,
            timeout=120,
        )
        assert down.returncode == 0, down.stderr


@pytest.mark.slow
def test_slurm_run_equals_local_run(slurm_partition, tmp_path):
    local, cluster = tmp_path / "local", tmp_path / "cluster"
    local.mkdir()
    cluster.mkdir()
    snakemake(local, tiny_config(local, tmp_path), "--cores", "2")
    snakemake(
        cluster,
        tiny_config(cluster, tmp_path),
        "--profile",
        str(REPO / "profiles" / "slurm"),
        "--default-resources",
        f"slurm_partition={slurm_partition}",
        "mem_mb=1000",
        "runtime=30",
        "--seconds-between-status-checks",
        "3",
        timeout=900,
    )
    check_outputs(cluster, truth=True)
    # the jobs went through SLURM: finished jobs stay listed for MinJobAge (600 s)
    jobs = subprocess.run(
        ["squeue", "-h", "-t", "all", "-o", "%i %T"], capture_output=True, text=True
    ).stdout.split("\n")
    completed = [j for j in jobs if j.endswith("COMPLETED")]
    assert len(completed) >= 5, jobs  # campaign, 2 inference batches, global fit, propagate
    assert result_hashes(cluster) == result_hashes(local)


def test_slurm_profile_names_the_partition_and_squeue_status():
    import yaml

    profile = yaml.safe_load((REPO / "profiles" / "slurm" / "config.yaml").read_text())
    assert profile["executor"] == "slurm"
    assert profile["slurm-status-command"] == "squeue"
    assert profile["default-resources"]["slurm_partition"] == "flidar"
    assert Path(REPO / "scripts" / "slurm-up.sh").read_text().count("MinJobAge=600") == 1
