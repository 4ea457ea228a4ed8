"""The virtual scenarios' acceptance runs and checks shared by the tests/test_regimes*.py
files (validation/regimes.py): each run is cached per process, so that the tests that
score the same run share its fit.

Each scenario is generated and run through the pipeline's steps; the corrected point TI
is scored against the truth in every 3-m/s speed group, sea-state class and heading class
with >= 200 records.
"""

from __future__ import annotations

import functools

import numpy as np
import pandas as pd
import pytest

from flidar_uq.campaign.scenarios import load_scenario
from flidar_uq.validation.regimes import scenario_calibration, scenario_records

MIN_GROUP = 200
SEEDS = (1, 2)

#: Seeds of the six-degree-of-freedom acceptance runs, drawn once (secrets.randbelow(2**31))
#: after the record model took each record's correlation scatter (rho_sd), never used
#: while developing it.
SIX_DOF_SEEDS = (505516003, 809183192)


@functools.cache
def run_scenario(scenario: str, seed: int):
    """The scenario's record fit and corrected records (the fixed-heading default hull)."""
    return scenario_records(scenario, seed)


@functools.cache
def run_six_dof(scenario: str, seed: int):
    """The scenario with the pipeline's default: the reference hull chosen by PSIS-LOO
    (inference.hull_reference)."""
    return scenario_records(scenario, seed, hull_reference="auto")


@functools.cache
def run_discus(seed: int, mru: bool = False, heave: bool = False):
    """The discus buoy with the reference hull chosen by PSIS-LOO (inference.hull_reference:
    auto): with the wave follower's translation the corrected TI is as well calibrated on
    the acceptance seeds (0.88-0.92 by group) but the lever arm comes out 7.1-7.3 m against
    3 m (docs/inference.md); ``mru``: the hull's translation stds measured
    (imu.mru_translation); ``heave``: the heave velocity in the IMU series
    (imu.vertical_velocity)."""
    sc = load_scenario("discus_buoy")
    sc["imu"] = sc.get("imu", {}) | {"mru_translation": mru, "vertical_velocity": heave}
    return scenario_records(sc, seed, hull_reference="auto")


@functools.cache
def run_heave(scenario: str, heave: str, seed: int):
    """The scenario with the heave in its IMU series: ``heave`` is ``"vertical_velocity"``
    or ``"vertical_acceleration"`` (the scenario's ``imu`` option)."""
    sc = load_scenario(scenario)
    sc["imu"] = sc.get("imu", {}) | {heave: True}
    return scenario_records(sc, seed)


@functools.cache
def run_dbs(scenario: str, seed: int):
    """The scenario corrected for the WindCube v2."""
    return scenario_records(scenario, seed, lidar="windcube_v2")


def calibrated_groups(records: pd.DataFrame) -> pd.DataFrame:
    """The regime groups (not the aggregate) of >= MIN_GROUP records."""
    tab = scenario_calibration(records)
    return tab[(tab["grouping"] != "all") & (tab["n"] >= MIN_GROUP)]


def check_calibrated(records: pd.DataFrame, what: str) -> None:
    """Every group of >= MIN_GROUP records within the acceptance's bounds, and the
    aggregate."""
    tab = scenario_calibration(records)
    overall = tab[tab["grouping"] == "all"].iloc[0]
    groups = calibrated_groups(records)
    assert len(groups) >= 3, f"{what}: too few groups with >= {MIN_GROUP} records"
    shown = groups[
        ["grouping", "group", "n", "coverage", "mean_rel_error", "mean_rel_error_se"]
    ].to_string()
    assert groups["coverage"].between(0.85, 0.95).all(), f"{what}: coverage\n{shown}"
    assert (groups["mean_rel_error"].abs() <= 0.015).all(), f"{what}: error\n{shown}"
    assert abs(overall["mean_rel_error"]) <= 0.01, f"{what}: aggregate error {overall}"


def check_finds_the_buoy(fit, records: pd.DataFrame, *, lean: str | None = None) -> None:
    """The physics-mode fit finds the scenario's buoy: the motion scale's posterior median
    in [0.9, 1.1] and the lever arm's within 0.5 m of the truth (``true_lever_arm_m``),
    with no discrepancy warning. ``lean``: a known lean of the lever arm, reported as an
    expected failure where it leaves the bound."""
    k = float(np.median(fit.flat("motion_scale")))
    lever = float(np.median(fit.flat("lever_arm_m")))
    assert 0.9 <= k <= 1.1, k
    off = abs(lever - float(records["true_lever_arm_m"].iloc[0]))
    if off > 0.5 and lean is not None:
        pytest.xfail(f"{lean}; here {lever:.2f} m")
    assert off <= 0.5, lever
    assert "motion_scale_warning" not in fit.info, fit.info["motion_scale_warning"]
    assert "lever_arm_warning" not in fit.info, fit.info["lever_arm_warning"]


def check_heave_measured(records: pd.DataFrame, lidar: str = "zephir300") -> None:
    """Every corrected record of a wave follower with the heave in its IMU series takes its
    translation from that heave, measured as a wave follower's (median within [0.9, 1.1])."""
    from flidar_uq.inference.record_motion import describe_motion

    corrected = records[records["ti_corrected_median"].notna()]
    desc = describe_motion(corrected, lidar=lidar)
    assert desc["translation_description"].eq("imu_series").all()
    assert 0.9 <= corrected["heave_response_ratio"].median() <= 1.1
