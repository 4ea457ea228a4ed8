"""The other DBS lidars on the wave follower, and the WindCube v2 wave follower against a
cup (regime_runs.py).
"""

from __future__ import annotations

import pytest
from regime_runs import (
    check_calibrated,
    check_finds_the_buoy,
    check_heave_measured,
)

from flidar_uq.campaign.scenarios import load_scenario
from flidar_uq.validation.regimes import (
    scenario_records,
)

#: The other DBS lidars on the wave follower, each on a seed drawn once
#: (secrets.randbelow(2**31)) after the WindCube v2 runs above passed, and used for nothing
#: else: the WindCube v1 (one wind a 4-s cycle, no vertical beam) and the WindCube v2.1
#: (0.5-s beams, a wind after every beam), each at a fixed heading and weathervaning.
_OTHER_DBS_RUNS = [
    ("dbs_wave_follower", "windcube_v1", 529873400),
    ("dbs_wave_follower_weathervane", "windcube_v1", 203100526),
    ("dbs_wave_follower", "windcube_v2_1", 203100526),
    ("dbs_wave_follower_weathervane", "windcube_v2_1", 203100526),
]


@pytest.mark.slow
@pytest.mark.parametrize(("scenario", "lidar", "seed"), _OTHER_DBS_RUNS)
def test_other_dbs_lidars_on_the_wave_follower_corrected_and_calibrated(scenario, lidar, seed):
    """The WindCube v2's wave-follower scenarios simulated and corrected for another DBS
    lidar's geometry and timing (the virtual campaign, the record model and the
    propagation each with the configured lidar): the DBS acceptance (>= 99 % corrected,
    every group of >= 200 records calibrated, intervals <= 30 % of the TI) and the fit
    finds the buoy (motion scale in [0.9, 1.1], lever arm within 0.5 m of 2 m)."""
    cfg = dict(load_scenario(scenario))
    cfg["lidar"] = {**cfg["lidar"], "name": lidar}
    records, fit = scenario_records(cfg, seed)
    assert fit.converged, fit.failure_reasons
    assert records["ti_corrected_median"].notna().mean() >= 0.99
    r = records[records["ti_corrected_median"].notna() & records["ti_true"].notna()]
    assert ((r["ti_corrected_hi"] - r["ti_corrected_lo"]) / r["ti_true"]).median() <= 0.30
    check_heave_measured(records, lidar)
    check_calibrated(records, f"{scenario} {lidar} seed {seed}")
    check_finds_the_buoy(fit, records)


#: Seeds of the DBS wave follower with a cup reference, drawn once (secrets.randbelow(2**31))
#: after the cup's std was taken in the floating lidar's response (times its std ratio g),
#: never used while developing it.
DBS_CUP_SEEDS = (1306607408, 634216907)


@pytest.mark.slow
@pytest.mark.parametrize("seed", DBS_CUP_SEEDS)
def test_dbs_wave_follower_with_a_cup_finds_the_buoy_and_stays_calibrated(seed):
    """The WindCube v2 wave follower at a fixed heading against a cup: the record fit
    compares the floating lidar's std with the cup's times the lidar's std ratio to the
    point wind (``g``, median 1.03), so the motion terms find the buoy (motion scale in
    [0.9, 1.1], lever arm within 0.5 m of 2 m; fitted on the cup's std itself they came out
    0.91-0.95 and 2.8-3.3 m, with no warning) and the corrected point TI stays calibrated
    in every group."""
    from flidar_uq.campaign.scenarios import load_scenario

    cfg = {**load_scenario("dbs_wave_follower"), "reference_instrument": "cup"}
    records, fit = scenario_records(cfg, seed)
    assert fit.converged, fit.failure_reasons
    assert records["ti_corrected_median"].notna().mean() >= 0.99
    # the WindCube's own g per record (0.98-1.05 at its wind directions), not the point's 1
    assert records["lidar_std_ratio"].median() > 1.0 and records["lidar_std_ratio"].std() > 0
    check_finds_the_buoy(fit, records)
    check_calibrated(records, f"dbs_wave_follower with a cup seed {seed}")
