"""The spatial lidar response: its limits, the probe volume, the scan disk, the prior on log g
and a simulated 3-D field."""

import numpy as np
import pandas as pd
import pytest

from flidar_uq.correction.reference import Reference
from flidar_uq.physics.lidar_response import lidar_std_ratio
from flidar_uq.physics.lidar_spatial_response import (
    SpatialTurbulence,
    lidar_spatial_std_ratio,
    lidar_std_ratio_prior,
    range_weight_nodes_m,
    simulate_spatial_std_ratio,
)
from flidar_uq.physics.turbulence import kaimal_lambda1_m


@pytest.mark.parametrize("lidar", ["zephir300", "windcube_v2"])
def test_a_point_disk_and_probe_give_the_temporal_g(lidar):
    hws, z = np.array([6.0, 14.0]), np.array([85.0, 27.0])
    point = lidar_spatial_std_ratio(hws, z, lidar, probe_scale=0.0, disk_scale=0.0, n_range=1)
    np.testing.assert_allclose(point, lidar_std_ratio(hws, z, lidar), atol=1e-3)
    # and the disk or the probe volume alone already lower it
    assert np.all(lidar_spatial_std_ratio(hws, z, lidar, n_range=3) < point - 0.02)


@pytest.mark.parametrize("lidar", ["zephir300", "windcube_v2"])
def test_the_probe_volume_lowers_g_monotonically_with_its_length(lidar):
    g = [
        lidar_spatial_std_ratio(8.0, 100.0, lidar, probe_scale=s, disk_scale=0.0, n_range=5)[()]
        for s in (0.0, 0.5, 1.0, 2.0)
    ]
    assert np.all(np.diff(g) < -0.005), g


def test_a_wider_scan_disk_lowers_g():
    g = [
        lidar_spatial_std_ratio(8.0, 100.0, "zephir300", probe_scale=0.0, disk_scale=s, n_range=1)[
            ()
        ]
        for s in (0.0, 0.5, 1.0, 2.0)
    ]
    assert np.all(np.diff(g) < -0.01), g
    # with less coherence (a faster decay) the same disk averages more out
    weak = SpatialTurbulence(coherence_decay=16.0)
    assert (
        lidar_spatial_std_ratio(8.0, 100.0, "zephir300", model=weak, probe_scale=0.0, n_range=1)
        < g[2]
    )


def test_range_weights_cw_grow_with_the_square_of_the_range_pulsed_do_not():
    s50, w = range_weight_nodes_m("zephir300", 50.0, 5)
    s100, _ = range_weight_nodes_m("zephir300", 100.0, 5)
    np.testing.assert_allclose(s100, 4.0 * s50)
    np.testing.assert_allclose(s50, -s50[::-1], atol=1e-12)
    assert w.sum() == pytest.approx(1.0)
    p50, _ = range_weight_nodes_m("windcube_v2", 50.0, 5)
    np.testing.assert_allclose(range_weight_nodes_m("windcube_v2", 150.0, 5)[0], p50)
    with pytest.raises(ValueError, match="range_weight_nodes_m: need range_m > 0"):
        range_weight_nodes_m("zephir300", 0.0)


@pytest.mark.slow
def test_the_prior_sd_is_positive_and_grows_with_height():
    # 36 spectral sums (20 s)
    z = np.array([40.0, 100.0, 150.0])
    mean, sd = lidar_std_ratio_prior(np.full(3, 8.0), z, "windcube_v2")
    assert np.all(sd > 0.01)
    assert np.all(np.diff(sd) > 0), sd
    assert np.all(mean < 0)  # the spatial averaging lowers g below the point's 1
    with pytest.raises(ValueError, match="need >= 2 models"):
        lidar_std_ratio_prior(8.0, 100.0, models=[SpatialTurbulence()])


def test_auto_prior_sd_of_g_is_zero_for_the_virtual_campaign_and_kept_for_files():
    virtual = Reference.from_config(
        {"lidar_std_ratio_log_sd": "auto"}, lidar="windcube_v2", virtual_kind="fixed_lidar"
    )
    assert virtual.lidar_std_ratio_log_sd == 0.0
    files = Reference.from_config(
        {"kind": "fixed_lidar"}, lidar="windcube_v2", record_columns=["ref_hws_std_ms"]
    )
    assert files.lidar_std_ratio_log_sd == "auto"
    assert Reference.from_config(files.to_config(), lidar="windcube_v2") == files
    rec = pd.DataFrame({"hws_mean_ms": [8.0], "height_m": [40.0]})
    assert Reference(lidar_std_ratio_log_sd=0.03).ratio_log_sd(rec) == 0.03


@pytest.mark.slow
def test_auto_prior_sd_of_g_is_the_distance_of_the_spatial_models_from_the_temporal_g():
    # 24 spectral sums (10 s)
    files = Reference(kind="fixed_lidar", lidar="windcube_v2", lidar_std_ratio_log_sd="auto")
    rec = pd.DataFrame({"hws_mean_ms": [8.0, 8.0, -1.0], "height_m": [40.0, 150.0, 100.0]})
    sd = files.ratio_log_sd(rec)
    mean, spread = lidar_std_ratio_prior(rec["hws_mean_ms"][:2], rec["height_m"][:2], "windcube_v2")
    # the distance from the temporal g: at least the models' spread and their mean's offset
    assert np.all(sd[:2] >= spread) and np.all(sd[:2] >= np.abs(mean))
    assert sd[2] == 0.0


@pytest.mark.slow
def test_g_agrees_with_a_simulated_3d_field():
    # 4 records of a PyConTurb field advected through a WindCube v2's beams (7-15 s): within
    # three standard errors of the simulation's ratio
    z, hws = 100.0, 8.0
    g_sim, se = simulate_spatial_std_ratio(hws, z, "windcube_v2", n_records=4, seed=1)
    model = SpatialTurbulence(coherence_length_per_lambda1=(340.2 / kaimal_lambda1_m(z), 0, 0))
    g = lidar_spatial_std_ratio(hws, z, "windcube_v2", model=model, n_range=3)[()]
    assert abs(np.log(g_sim / g)) < 3.0 * se, (g_sim, se, g)
    assert g < 0.9  # and the simulated field is far from the temporal g (1.03)
