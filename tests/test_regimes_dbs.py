"""The WindCube v2 record model by regime: the buoy that only tilts and the wave follower
(regime_runs.py).
"""

from __future__ import annotations

import pytest
from regime_runs import (
    calibrated_groups,
    check_calibrated,
    check_finds_the_buoy,
    check_heave_measured,
    run_dbs,
)

#: Two seeds drawn fresh (secrets.randbelow(2**31)) for the DBS record model's test after
#: the WindCube v2 took its wind after every beam (the virtual campaign, the record model and
#: the LOS branch), not chosen after the result.
DBS_SEEDS = (1831967115, 363998624)


@pytest.mark.slow
@pytest.mark.parametrize("seed", DBS_SEEDS)
def test_dbs_tilt_only_record_model_calibrated_in_every_group(seed):
    """A WindCube v2 on a buoy that only tilts (scenario ``dbs_tilt_only``): the record fit
    and the propagation with the DBS lidar's own sigma_Z (record_motion.motion_gram), the
    fit taking the two DBS lidars' sampling scatter at the buoy's heading as known
    (their beams 30 deg apart): calibrated in every group (speed, sea state, heading, wave
    period), intervals <= 30 % of the TI (the DBS acceptance)."""
    records, fit = run_dbs("dbs_tilt_only", seed)
    assert fit.converged, fit.failure_reasons
    assert records["ti_corrected_median"].notna().mean() >= 0.99
    check_calibrated(records, f"dbs_tilt_only seed {seed}")
    assert "wave_period" in set(calibrated_groups(records)["grouping"])
    r = records[records["ti_corrected_median"].notna() & records["ti_true"].notna()]
    assert ((r["ti_corrected_hi"] - r["ti_corrected_lo"]) / r["ti_true"]).median() <= 0.30


@pytest.mark.slow
@pytest.mark.parametrize("seed", DBS_SEEDS)
def test_dbs_tilt_only_fit_recovers_motion_scale_and_lever_arm(seed):
    """The DBS record fit on its tilt bands recovers the scenario's motion (``k`` = 1, the
    lever arm 2 m): ``k`` within [0.9, 1.1] and ``L`` within 0.5 m, the bounds of the
    physics-mode acceptance (measured k 1.00 and 0.98, L 2.04 and 1.82 m; on roll and pitch
    alone it was k 0.90, L 1.25 m)."""
    records, fit = run_dbs("dbs_tilt_only", seed)
    assert fit.converged, fit.failure_reasons
    counts = fit.info["motion_description_counts"]
    assert counts.get("tilt_bands", 0) >= 0.99 * sum(counts.values()), counts
    check_finds_the_buoy(fit, records)


#: Seeds of the DBS wave-follower acceptance runs, drawn once (secrets.randbelow(2**31))
#: after the WindCube v2 took its wind after every beam (the virtual campaign, the record
#: model and the LOS branch), and never used while developing.
DBS_WAVE_SEEDS = (1433736163, 2056328097)

_DBS_WAVE_RUNS = [
    (scenario, seed)
    for scenario in ("dbs_wave_follower", "dbs_wave_follower_weathervane")
    for seed in DBS_WAVE_SEEDS
]


@pytest.mark.slow
@pytest.mark.parametrize(("scenario", "seed"), _DBS_WAVE_RUNS)
def test_dbs_wave_follower_corrected_and_the_fit_finds_the_buoy(scenario, seed):
    """A WindCube v2 on a buoy that follows the waves (surge, sway and heave; a wind sea and
    in half the records a swell 45-135 deg off the wind), at a fixed heading and
    weathervaning, its IMU series with the heave velocity: >= 99 % of the records
    corrected, intervals <= 30 % of the TI (the DBS acceptance), the heave measured as a
    wave follower's in the IMU series, and the fit finds the buoy: motion scale in
    [0.9, 1.1], lever arm within 0.5 m of the scenario's 2 m (the physics-mode bounds of
    the hull's six degrees of freedom). The weathervaning buoy's arm leans long, 2.31 and
    2.43 m (2.50 and 2.48 m while the correlation's scatter took its lines' shares at no
    lever arm; docs/dbs-lidars.md, "The lever arm's lines")."""
    records, fit = run_dbs(scenario, seed)
    assert records["ti_corrected_median"].notna().mean() >= 0.99
    assert "wave_period" in set(calibrated_groups(records)["grouping"])
    r = records[records["ti_corrected_median"].notna() & records["ti_true"].notna()]
    assert ((r["ti_corrected_hi"] - r["ti_corrected_lo"]) / r["ti_true"]).median() <= 0.30
    check_heave_measured(records, "windcube_v2")
    assert fit.converged, fit.failure_reasons
    check_finds_the_buoy(fit, records)


@pytest.mark.slow
@pytest.mark.parametrize(("scenario", "seed"), _DBS_WAVE_RUNS)
def test_dbs_wave_follower_calibrated_in_every_group(scenario, seed):
    """The runs of the test before: calibrated in every group of >= 200 records (speed, sea
    state x heading, wave period) and in aggregate (the DBS acceptance). The closest to a
    bound: the weathervaning run 2056328097's 370 records at 3-6 m/s cover 0.946 (0.954,
    outside, while the correlation's scatter took its lines' shares at no lever arm)."""
    records, _ = run_dbs(scenario, seed)
    check_calibrated(records, f"{scenario} seed {seed}")
