"""Lidar geometries as data: the named DBS lidars, custom geometry blocks, and the config.

Yamaguchi & Ishihara (2016, Eq. 3) for the beam-pair retrieval.
"""

from __future__ import annotations

import io
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import yaml
from test_bad_inputs import valid_records, write
from test_workflow import REPO, SNAKEMAKE

from flidar_uq.cli import main
from flidar_uq.physics import lidar as L
from flidar_uq.workflow.inputs import EXIT_OK, EXIT_USAGE, check_config, pipeline_preflight

NAMES = ("zephir300", "windcube_v1", "windcube_v1_5beam", "windcube_v2", "windcube_v2_1")


def test_named_geometries_are_data():
    assert tuple(L.KNOWN_LIDARS) == NAMES
    v2 = L.get_lidar("windcube_v2")
    assert (v2.kind, v2.half_cone_angle_deg, v2.n_los, v2.vertical_beam) == ("dbs", 28.0, 5, True)
    assert v2.los_duration_s == pytest.approx(1.0) and v2.cycle_s == pytest.approx(5.0)
    assert v2.pulsed and v2.retrieval == "beam_pairs" and v2.w_from_vertical_beam
    assert v2.opposite_beam_lag_s == pytest.approx(2.0)
    v21 = L.get_lidar("WindCube-v2_1")
    assert v21.los_duration_s < v2.los_duration_s  # faster sampling
    assert "ASSUMED" in v21.notes  # the timing is an assumption, said so
    z = L.get_lidar("zephir300")
    assert not z.pulsed and z.retrieval == "vad_least_squares" and z.beam_pairs_deg == ()
    assert L.get_lidar("windcube_v1").beam_pairs_deg == ((90.0, 270.0), (0.0, 180.0))


@pytest.mark.parametrize(
    "name", ["windcube_v1", "windcube_v1_5beam", "windcube_v2", "windcube_v2_1"]
)
def test_dbs_operator_is_the_pair_retrieval(name):
    g = L.get_lidar(name)
    _, az = L.scan_times_azimuths(g)
    rng = np.random.default_rng(1)
    y = rng.normal(size=(7, g.n_los))
    ret = L.retrieve_wind(g, az, y)
    uvw = y @ L.dbs_retrieval_operator(g)
    np.testing.assert_allclose(uvw, np.stack([ret.u_ms, ret.v_ms, ret.w_ms], -1), atol=1e-12)
    # u from the east-west pair: (V_E - V_W) / (2 sin theta) (Yamaguchi & Ishihara 2016, Eq. 3)
    p = L.dbs_retrieval_operator(g)
    assert p[1, 0] == pytest.approx(1.0 / (2.0 * np.sin(g.half_cone_angle_rad)))


def test_custom_geometry_block_rotated_beams_retrieve_exactly():
    g = L.get_lidar(
        {
            "kind": "dbs",
            "half_cone_angle_deg": 25.0,
            "beam_azimuths_deg": [45, 135, 225, 315],
            "los_time_s": 0.8,
            "vertical_beam": True,
            "name": "X",
        }
    )
    assert g.name == "x" and g.n_los == 5 and g.cycle_s == pytest.approx(4.0)
    assert g.pair_axis_deg == pytest.approx(45.0)
    _, az = L.scan_times_azimuths(g)
    wind = np.array([3.0, -2.0, 0.4])
    ret = L.retrieve_wind(g, az, L.beam_unit_vectors_body(g, az) @ wind)
    np.testing.assert_allclose([ret.u_ms, ret.v_ms, ret.w_ms], wind, atol=1e-12)
    # the dead time of a cycle: los_time_s below scan_period_s / n_los
    g2 = L.get_lidar(
        {
            "kind": "dbs",
            "half_cone_angle_deg": 30,
            "beam_azimuths_deg": [0, 90, 180, 270],
            "los_time_s": 0.9,
            "scan_period_s": 4.0,
        }
    )
    assert g2.los_duration_s == pytest.approx(0.9) and g2.cycle_s == pytest.approx(4.0)


@pytest.mark.parametrize(
    ("block", "pattern"),
    [
        (
            {
                "kind": "dbs",
                "half_cone_angle_deg": 30,
                "beam_azimuths_deg": [0, 90, 180, 200],
                "los_time_s": 1,
            },
            "permutation of two perpendicular opposite pairs",
        ),
        (
            {"kind": "dbs", "half_cone_angle_deg": 30, "beam_azimuths_deg": [0, 90, 180, 270]},
            "scan_period_s or los_time_s",
        ),
        (
            {
                "kind": "dbs",
                "half_cone_angle_deg": 30,
                "beam_azimuths_deg": [0, 90, 180, 270],
                "los_time_s": 2.0,
                "scan_period_s": 4.0,
            },
            "los_time_s must be",
        ),
        ({"kind": "vad", "half_cone_angle_deg": 30, "scan_period_s": 1.0}, "needs n_los"),
        (
            {
                "kind": "dbs",
                "half_cone_angle_deg": 30,
                "beam_azimuths_deg": [0, 90, 180, 270],
                "los_time_s": 0.9,
                "scan_period_s": 4.0,
                "every_beam_output": True,
            },
            "every_beam_output needs a DBS cycle without dead time",
        ),
        (
            {
                "kind": "vad",
                "half_cone_angle_deg": 30,
                "n_los": 50,
                "scan_period_s": 1.0,
                "every_beam_output": True,
            },
            "every_beam_output needs a DBS cycle",
        ),  # fmt: skip
        ({"kind": "dbs", "half_cone_angle": 30}, "unknown key"),
    ],
)
def test_bad_custom_geometry_is_one_line(block, pattern):
    with pytest.raises(ValueError, match=pattern) as exc:
        L.get_lidar(block)
    assert "\n" not in str(exc.value)


def test_a_wind_after_every_beam_windows_and_times():
    """The WindCube v2 and v2.1 retrieve a wind after every beam (their 1-s data), the v1
    entries once a cycle; a custom block says which. The windows after every beam hold the
    latest beam of each azimuth (the first cycle's own window is that cycle), and each
    window's beam times run from its start in the cycle's order."""
    assert [n for n in NAMES if L.get_lidar(n).every_beam_output] == [
        "windcube_v2",
        "windcube_v2_1",
    ]
    v2, v1 = L.get_lidar("windcube_v2"), L.get_lidar("windcube_v1")
    assert v2.window_starts == (0, 1, 2, 3, 4) and v2.output_interval_s == pytest.approx(1.0)
    assert v1.window_starts == (0,) and v1.output_interval_s == pytest.approx(4.0)
    block = {"kind": "dbs", "half_cone_angle_deg": 28, "beam_azimuths_deg": [0, 90, 180, 270],
             "los_time_s": 0.5, "every_beam_output": True}  # fmt: skip
    assert L.get_lidar(block).window_starts == (0, 1, 2, 3)
    # beam k of the window starting at place s: ((k - s) mod K) beams in
    t = L.window_beam_times_s(v2)
    np.testing.assert_allclose(t[0], [0, 1, 2, 3, 4])
    np.testing.assert_allclose(t[2], [3, 4, 0, 1, 2])
    np.testing.assert_allclose(L.window_beam_times_s(v1), [[0, 1, 2, 3]])
    # cycles of values 10 c + k: after beam j of cycle c, beams <= j of cycle c, > j of c - 1
    cycles = 10.0 * np.arange(3)[:, None] + np.arange(4)[None, :]
    w = L.every_beam_windows(cycles)
    assert w.shape == (9, 4)
    np.testing.assert_array_equal(w[0], cycles[0])  # the first wind: the first cycle
    np.testing.assert_array_equal(w[1], [10, 1, 2, 3])
    np.testing.assert_array_equal(w[3], [10, 11, 12, 3])
    np.testing.assert_array_equal(w[4], cycles[1])
    np.testing.assert_array_equal(w[8], cycles[2])
    # trailing axes ride along (a beam's dwell sub-slots)
    assert L.every_beam_windows(np.repeat(cycles[..., None], 3, -1)).shape == (9, 4, 3)
    # any window start, as the record model's coefficients take it
    np.testing.assert_allclose(L.window_beam_times_s(v2, [2]), t[2:3])


# --------------------------------------------------------------------------- config


def _files_config(tmp_path, lidar) -> dict:
    path = write(tmp_path, valid_records())
    return {
        "campaign": {"source": "files", "records": str(path), "lidar": lidar},
        "reference": {"kind": "cup"},
    }


@pytest.mark.parametrize("name", NAMES)
def test_every_name_is_accepted_by_validate_and_the_pipeline(tmp_path, name, capsys):
    config = _files_config(tmp_path, name)
    assert pipeline_preflight(yaml.safe_load(yaml.safe_dump(config)), stream=io.StringIO()) == 0
    config["reference"] = {"kind": "fixed_lidar", "lidar": name}  # a fixed lidar of any type
    check_config(yaml.safe_load(yaml.safe_dump(config)))
    cfg = tmp_path / "c.yaml"
    cfg.write_text(yaml.safe_dump(_files_config(tmp_path, name)))
    assert main(["validate", "--config", str(cfg)]) == EXIT_OK
    capsys.readouterr()


def test_custom_block_is_accepted_and_checked(tmp_path):
    block = {
        "kind": "dbs",
        "half_cone_angle_deg": 25.0,
        "beam_azimuths_deg": [0, 90, 180, 270],
        "los_time_s": 0.7,
        "vertical_beam": True,
    }
    assert pipeline_preflight(_files_config(tmp_path, block), stream=io.StringIO()) == EXIT_OK
    bad = dict(block, beam_azimuths_deg=[0, 90, 180, 200])
    stream = io.StringIO()
    assert pipeline_preflight(_files_config(tmp_path, bad), stream=stream) == EXIT_USAGE
    lines = stream.getvalue().strip().splitlines()
    assert len(lines) == 1 and "campaign.lidar" in lines[0]
    typo = dict(block, beam_azimuth_deg=[0, 90, 180, 270])
    stream = io.StringIO()
    assert pipeline_preflight(_files_config(tmp_path, typo), stream=stream) == EXIT_USAGE
    assert "did you mean campaign.lidar.beam_azimuths_deg" in stream.getvalue()


def _unknown_name_line(text: str) -> None:
    lines = [ln for ln in text.strip().splitlines() if "flidar-uq" in ln and "error" in ln]
    assert len(lines) == 1, text[-2000:]
    assert re.search(
        r"campaign\.lidar: unknown name 'windcube_v3'; known names: " + ", ".join(NAMES), lines[0]
    ), lines[0]


def test_unknown_name_one_line_exit_2_in_validate_and_pipeline(tmp_path):
    cfg = tmp_path / "c.yaml"
    cfg.write_text(yaml.safe_dump(_files_config(tmp_path, "windcube_v3")))
    cli = subprocess.run(
        [str(Path(sys.executable).with_name("flidar-uq")), "validate", "--config", str(cfg)],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert cli.returncode == EXIT_USAGE
    _unknown_name_line(cli.stderr)
    snake = subprocess.run(
        [
            SNAKEMAKE,
            "-s",
            str(REPO / "Snakefile"),
            "--directory",
            str(tmp_path),
            "--configfile",
            str(cfg),
            "-n",
            "--cores",
            "1",
        ],
        capture_output=True,
        text=True,
        timeout=300,
        cwd=tmp_path,
    )
    assert snake.returncode == EXIT_USAGE, snake.stderr[-2000:]
    _unknown_name_line(snake.stdout + snake.stderr)


def test_virtual_scenario_and_campaign_lidar_that_disagree_are_one_line():
    from flidar_uq.workflow.inputs import ConfigError, check_config

    cfg = yaml.safe_load((REPO / "config" / "config.yaml").read_text())
    cfg["campaign"]["source"], cfg["campaign"]["scenario"] = "virtual", "tiny"
    cfg["campaign"]["lidar"] = "windcube_v1"  # the tiny scenario simulates a ZephIR 300
    with pytest.raises(ConfigError) as err:
        check_config(cfg)
    msg = str(err.value)
    assert "campaign.lidar" in msg and "simulates 'zephir300'" in msg and "\n" not in msg
    cfg["campaign"]["lidar"] = "zephir300"
    check_config(cfg)  # agreeing: accepted
