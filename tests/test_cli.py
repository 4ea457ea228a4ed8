"""Tests of the flidar-uq command line contract."""

from __future__ import annotations

import json
import subprocess
import sys

import pytest

from flidar_uq.cli import main
from flidar_uq.physics.simulator import sigma_z

BASE = ["sigma-z", "--hws-ms", "8", "--amplitude-deg", "3", "--period-s", "4"]


def _run(capsys, argv):
    code = main(argv)
    out, err = capsys.readouterr()
    return code, out, err


def test_sigma_z_prints_one_json_object(capsys):
    code, out, err = _run(capsys, BASE + ["--wd-deg", "0", "--lidar", "zephir300"])
    assert code == 0 and err == ""
    assert len(out.strip().splitlines()) == 1
    res = json.loads(out)
    assert res["sigma_z_ms"] == pytest.approx(sigma_z(8.0, 3.0, 4.0).sigma_z_ms, rel=1e-12)
    assert res["mean_z_ms"] == pytest.approx(sigma_z(8.0, 3.0, 4.0).mean_z_ms, rel=1e-12)


def test_sigma_z_two_period_option_uses_total_amplitude(capsys):
    code, out, _ = _run(capsys, BASE + ["--period2-s", "12", "--weight1", "0.6"])
    assert code == 0
    ref = sigma_z(8.0, 3.0 * 0.6**0.5, 4.0, amplitude2_deg=3.0 * 0.4**0.5, period2_s=12.0)
    assert json.loads(out)["sigma_z_ms"] == pytest.approx(ref.sigma_z_ms, rel=1e-12)


def test_sigma_z_lever_arm_and_surrogate(capsys):
    _, out, _ = _run(capsys, BASE + ["--lever-arm-m", "4"])
    assert json.loads(out)["sigma_z_ms"] == pytest.approx(
        sigma_z(8.0, 3.0, 4.0, lever_arm_m=4.0).sigma_z_ms
    )
    _, out, _ = _run(capsys, BASE + ["--surrogate"])
    assert json.loads(out)["sigma_z_ms"] == pytest.approx(
        sigma_z(8.0, 3.0, 4.0).sigma_z_ms, rel=1e-3
    )


@pytest.mark.parametrize(
    ("extra", "needle"),
    [
        (["--hws-ms", "-8"], "argument --hws-ms: must be > 0"),
        (["--hws-ms", "0"], "argument --hws-ms: must be > 0"),
        (["--hws-ms", "inf"], "argument --hws-ms: must be finite"),
        (["--hws-ms", "nan"], "argument --hws-ms: must be finite"),
        (["--period-s", "0"], "argument --period-s: must be > 0"),
        (["--period-s", "-2"], "argument --period-s: must be > 0"),
        (["--amplitude-deg", "46"], "argument --amplitude-deg: must be in [0, 45]"),
        (["--amplitude-deg", "-1"], "argument --amplitude-deg: must be in [0, 45]"),
        (["--lidar", "nosuch"], "argument --lidar: unknown lidar 'nosuch'"),
        (["--wd-deg", "north"], "argument --wd-deg: not a number: 'north'"),
        (["--period-s", "4s"], "argument --period-s: not a number: '4s'"),
        (["--weight1", "1.5", "--period2-s", "9"], "argument --weight1: must be in [0, 1]"),
        (["--period2-s", "9"], "argument --weight1: required with two-period motion"),
        (
            ["--surrogate", "--amplitude-deg", "30"],
            "argument --amplitude-deg: the surrogate covers",
        ),
    ],
)
def test_bad_input_one_line_naming_argument(capsys, extra, needle):
    code, out, err = _run(capsys, BASE + extra)
    assert code == 2 and out == ""
    assert len(err.strip().splitlines()) == 1
    assert needle in err
    assert "Traceback" not in err


def test_missing_command_and_arguments(capsys):
    code, _, err = _run(capsys, [])
    assert code == 2 and "a command is required" in err and len(err.strip().splitlines()) == 1
    code, _, err = _run(capsys, ["sigma-z", "--hws-ms", "8"])
    assert code == 2 and "required: --amplitude-deg, --period-s" in err


def test_subprocess_entry_point_contract():
    ok = subprocess.run(
        [sys.executable, "-m", "flidar_uq.cli", *BASE], capture_output=True, text=True, check=False
    )
    assert ok.returncode == 0 and set(json.loads(ok.stdout)) >= {"sigma_z_ms", "mean_z_ms"}
    bad = subprocess.run(
        [
            sys.executable,
            "-m",
            "flidar_uq.cli",
            "sigma-z",
            "--hws-ms",
            "x",
            "--amplitude-deg",
            "3",
            "--period-s",
            "4",
        ],
        capture_output=True,
        text=True,
        check=False,
    )
    assert bad.returncode == 2 and bad.stdout == ""
    assert bad.stderr.strip() == "flidar-uq sigma-z: error: argument --hws-ms: not a number: 'x'"
