"""The six-degree-of-freedom record model on the buoy that only rotates and on the wave
follower with a measured translation (regime_runs.py).
"""

from __future__ import annotations

import numpy as np
import pytest
from regime_runs import (
    SIX_DOF_SEEDS,
    check_calibrated,
    run_six_dof,
)


@pytest.mark.slow
@pytest.mark.parametrize("seed", SIX_DOF_SEEDS)
def test_rotation_only_buoy_keeps_its_calibration_and_no_hull_response(seed):
    """The buoy that only rotates (misaligned swell): the hull response goes to ~0 and the
    calibration per regime stands."""
    records, fit = run_six_dof("misaligned_swell", seed)
    assert fit.converged, fit.failure_reasons
    check_calibrated(records, f"misaligned_swell seed {seed}")
    assert np.quantile(fit.flat("hull_response"), 0.95) < 0.2


#: Seeds of the measured-translation acceptance runs, drawn once (secrets.randbelow(2**31))
#: after the record model took each record's correlation scatter, never used while
#: developing it.
MRU_SEEDS = (784494570, 2091837078)


@pytest.mark.slow
@pytest.mark.parametrize("seed", MRU_SEEDS)
def test_measured_translation_campaign_is_calibrated_in_every_regime(seed):
    """A wave follower whose motion reference unit gives the hull's surge, sway and heave
    velocity stds: each record's hull response comes from the measurement; calibrated in
    every group with intervals <= 25 % of the TI. (Not asserted, because it does not hold:
    the motion scale absorbs what the assumed directions of travel miss. On these seeds
    L = 2.12 and 2.05 m against the truth's 2 m, k 0.86 and 0.87.)"""
    records, _ = run_six_dof("wave_follower_mru", seed)
    assert records["ti_corrected_median"].notna().mean() >= 0.99
    check_calibrated(records, f"wave_follower_mru seed {seed}")
    r = records[records["ti_corrected_median"].notna() & records["ti_true"].notna()]
    assert ((r["ti_corrected_hi"] - r["ti_corrected_lo"]) / r["ti_true"]).median() <= 0.25
