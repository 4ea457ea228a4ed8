"""Virtual-campaign scenarios: the keys a scenario may set, their defaults and validation.

A scenario is a nested mapping (``flidar_uq/resources/scenarios/<name>.yaml``, shipped as
package data) merged over :data:`DEFAULT_SCENARIO`; :class:`CampaignConfig` validates it,
:func:`load_scenario` reads a shipped or user file, :func:`reference_sampling` tells the
lidar-response model how the virtual campaign samples the wind. The generator is
:mod:`flidar_uq.campaign.physics_mode`.
"""

from __future__ import annotations

import copy
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from flidar_uq.physics import lidar as _lidar
from flidar_uq.physics.hull import get_hull
from flidar_uq.resources import resource_path

__all__ = [
    "DEFAULT_SCENARIO",
    "HARMONIC_CASE_KEYS",
    "HEADING_MODES",
    "REFERENCE_INSTRUMENTS",
    "TRUTH_SAMPLE_INTERVAL_S",
    "CampaignConfig",
    "load_scenario",
    "reference_sampling",
    "scenario_dir",
    "wind_step_slots",
]

# ---------------------------------------------------------------------------
# configuration
# ---------------------------------------------------------------------------

#: The truth columns (``true_hws_*``, ``true_ti``) are statistics of the point HWS sampled
#: at this interval, s (a cup's 1-Hz series).
TRUTH_SAMPLE_INTERVAL_S = 1.0

#: Reference instruments a virtual campaign can carry (scenario key ``reference_instrument``).
REFERENCE_INSTRUMENTS = ("fixed_lidar", "cup", "sonic")

#: Every key a scenario may set, with its default (units in the key names).
DEFAULT_SCENARIO: dict = {
    "name": "default",
    "n_records": 8640,  # 10-min records (60 days); rows = n_records x len(heights_m)
    "start_utc": "2015-04-01T00:00:00Z",
    "record_length_s": 600.0,
    "heights_m": [27.0, 58.0, 85.0],
    "chunk_records": 16,
    "n_workers": 1,
    # the reference (ref_* columns) exists only in the first reference_days days of the
    # campaign (a short mast or fixed-lidar period before deployment); null: throughout
    "reference_days": None,
    # the reference instrument behind the ref_* columns: "fixed_lidar" (a motionless lidar
    # of the same type with the same scan schedule), "cup" or "sonic" (the point HWS
    # series at the same height sampled every TRUTH_SAMPLE_INTERVAL_S: a cup's 1-Hz series;
    # the virtual sonic is the same point series, no cup overspeeding is modelled)
    "reference_instrument": "fixed_lidar",
    "lidar": {
        "name": "zephir300",
        "refocus_delay_s": [0.3, 0.7],  # uniform range of the delay between scans
        # "prism": the scanner turns continuously, a scan starts at the azimuth the prism
        # has at that time (phase locked to time); "random": independent uniform scan
        # phase per scan (Gutiérrez-Antuñano et al., 2018, Sec. 2.3's assumption)
        "scan_phase": "prism",
        "scan_dropout_probability": 0.02,
        "record_outage_probability": 0.003,
        "lever_arm_m": [0.0, 0.0, 2.5],  # head position from the rotation centre, body frame
    },
    "wind": {
        "reference_height_m": 85.0,
        "hws_weibull_shape": 2.2,
        "hws_weibull_scale_ms": 9.5,
        "hws_min_ms": 2.0,
        "hws_max_ms": 21.0,
        "hws_lag1_correlation": 0.97,
        "wind_dt_s": 0.1,  # turbulence sampling interval (s); held constant in between
        "wd_mean_deg": 240.0,
        "wd_sd_deg": 70.0,
        "shear_exponent_mean": 0.1,
        "shear_exponent_sd": 0.04,
        "ti_model": "offshore",  # offshore | iec_ntm | constant_ti
        "ti_params": {},
        # the turbulence as a field frozen in the mean flow, sampled at each line of
        # sight's focus point and the centre (the point truth); off: one point series a
        # height that every line of sight samples (flidar_uq.physics.turbulence)
        "spatial_field": {
            "enabled": False,
            # per record uniform draws: factor on the Kaimal length scales (-) and the
            # lateral coherence decay (-; IEC 61400-1 fixes 12)
            "length_scale_factor_range": [0.6, 1.6],
            "coherence_decay_range": [8.0, 16.0],
            # field points on a VAD lidar's circle (each line of sight samples the nearest;
            # at most its n_los); a DBS lidar's beams are its points
            "azimuth_points": 8,
        },
    },
    "motion": {
        "model": "sea_state",  # sea_state | harmonic
        "sea_state": {
            # wind-sea tilt amplitude: base + slope * HWS, log-normal scatter, clipped
            "amplitude_base_deg": 1.2,
            "amplitude_per_ms_deg": 0.17,
            "amplitude_cov": 0.3,
            "amplitude_range_deg": [0.5, 6.0],
            # wind-sea peak period: base + slope * HWS, normal scatter, clipped
            "tp_base_s": 2.6,
            "tp_per_ms_s": 0.08,
            "tp_sd_s": 0.35,
            "tp_range_s": [1.8, 5.5],
            "gamma": 3.3,
            # [lo, hi]: wind-sea JONSWAP gamma drawn uniform per record (broadband 1 ..
            # narrow 7; DNV range 1-10); null: every record has `gamma`
            "wind_sea_gamma_range": None,
            "spread_deg": 35.0,
            # wind sea travels downwind (wd + 180 deg) with this normal scatter, deg
            "wind_sea_direction_sd_deg": 20.0,
            # optional swell: probability per record, period, its share of the variance
            "swell_probability": 0.35,
            "swell_tp_range_s": [5.0, 7.0],
            "swell_gamma": 6.0,
            "swell_spread_deg": 15.0,
            "swell_variance_share_range": [0.2, 0.6],
            # [lo, hi]: the swell travels at an angle uniform in [lo, hi] deg (random side)
            # to the downwind direction; null: swell direction uniform over 360 deg
            "swell_direction_offset_deg_range": None,
            # buoy heading: "fixed" (yaw = fixed_yaw_deg + drift + scatter) or
            # "weathervane" (body x axis points into the wind, plus scatter, in records
            # whose reference-height HWS >= weathervane_min_hws_ms; fixed otherwise).
            # Yaw as in docs/conventions.md: body x axis, deg counter-clockwise from east.
            "heading_mode": "fixed",
            "fixed_yaw_deg": 0.0,
            "yaw_drift_deg_per_day": 0.0,  # slow drift of the fixed heading, deg/day
            "weathervane_min_hws_ms": 0.0,
            "heading_sd_deg": 0.0,  # buoy heading scatter (yaw) per record, deg
            # the hull's response to the waves (flidar_uq.physics.hull.HULLS):
            # rotation_only (tilts about a fixed centre), wave_follower, discus_buoy, spar
            "hull": "rotation_only",
        },
        "harmonic": {
            # ranges drawn per record when no cases are given; roll and pitch share
            # amplitude and period (Gutiérrez-Antuñano et al., 2018, Sec. 2.4), phases independent uniform
            "amplitude_range_deg": [1.0, 5.0],
            "period_range_s": [2.0, 5.0],
            "cases": [],
        },
    },
    "imu": {
        "rate_hz": 5.0,
        "noise_deg": 0.05,
        "gap_probability": 0.02,
        "gap_length_range_s": [10.0, 120.0],
        "period_range_s": [1.0, 30.0],  # band searched for spectral peaks (imu.py)
        # a motion reference unit: the hull's surge, sway and heave velocity stds in the
        # records (heave_velocity_std_ms, surge_velocity_std_ms, sway_velocity_std_ms)
        "mru_translation": False,
        # the hull's vertical velocity in the IMU series (velocity_up_ms, m/s), as a wave
        # sensor or motion reference unit reports it, with white noise (m/s): the records
        # then carry each tilt band's measured direction (tilt_band{b}_cos_psi) and the
        # hull's heave response (heave_response_ratio)
        "vertical_velocity": False,
        "vertical_velocity_noise_ms": 0.02,
        # the hull's vertical acceleration instead (acceleration_up_ms2, m/s^2, gravity
        # removed), as an inertial unit without a velocity output reports it, with white
        # noise (m/s^2): the IMU step integrates it to the heave velocity
        "vertical_acceleration": False,
        "vertical_acceleration_noise_ms2": 0.01,
        # the hull's horizontal velocity in the IMU series (velocity_east_ms,
        # velocity_north_ms, m/s, earth frame), as a motion reference unit or GNSS reports
        # it, with white noise (m/s): the LOS branch adds it to the head velocity, and the
        # records carry the hull's horizontal response (horizontal_response_ratio)
        "horizontal_velocity": False,
        "horizontal_velocity_noise_ms": 0.02,
    },
}


#: Keys of one harmonic case (amplitudes in deg or m, periods in s, n_records per case).
HARMONIC_CASE_KEYS = (
    "label",
    "n_records",
    "roll_amplitude_deg",
    "pitch_amplitude_deg",
    "yaw_amplitude_deg",
    "surge_amplitude_m",
    "sway_amplitude_m",
    "heave_amplitude_m",
    "period_s",
    "yaw_period_s",
    "translation_period_s",
)


def scenario_dir() -> Path:
    """Directory of the shipped scenario files (package data, ``flidar_uq/resources/scenarios``)."""
    return resource_path("scenarios")


def _merge_checked(defaults: Mapping, given: Mapping, where: str) -> dict:
    out = copy.deepcopy(dict(defaults))
    for key, val in given.items():
        if key not in defaults:
            raise ValueError(
                f"scenario: unknown key '{where}{key}'; known keys: {', '.join(sorted(defaults))}"
            )
        if isinstance(defaults[key], dict) and defaults[key] and key != "ti_params":
            if not isinstance(val, Mapping):
                raise ValueError(f"scenario: {where}{key!r} must be a mapping, got {val!r}")
            out[key] = _merge_checked(defaults[key], val, f"{where}{key}.")
        else:
            out[key] = copy.deepcopy(val)
    return out


@dataclass(frozen=True)
class CampaignConfig:
    """A validated scenario (nested mapping with the keys of :data:`DEFAULT_SCENARIO`).

    Build with :meth:`from_dict`; ``settings`` holds the merged mapping.
    """

    settings: dict = field(default_factory=lambda: copy.deepcopy(DEFAULT_SCENARIO))

    @classmethod
    def from_dict(cls, scenario: Mapping) -> CampaignConfig:
        """Merge ``scenario`` over :data:`DEFAULT_SCENARIO` and validate it.

        Raises
        ------
        ValueError
            Unknown key (message names the key path), or a value out of range.
        """
        s = _merge_checked(DEFAULT_SCENARIO, scenario, "")
        cases = s["motion"]["harmonic"]["cases"]
        for i, case in enumerate(cases):
            bad = set(case) - set(HARMONIC_CASE_KEYS)
            if bad:
                raise ValueError(
                    f"scenario: motion.harmonic.cases[{i}] has unknown keys {sorted(bad)}; "
                    f"known: {', '.join(HARMONIC_CASE_KEYS)}"
                )
        if s["motion"]["model"] == "harmonic" and cases:
            s["n_records"] = int(sum(int(c.get("n_records", 1)) for c in cases))
        _check_positive(s, "n_records", s["n_records"], integer=True)
        _check_positive(s, "record_length_s", s["record_length_s"])
        if len(s["heights_m"]) == 0 or min(s["heights_m"]) <= 0:
            raise ValueError(f"scenario: heights_m must be non-empty and > 0, got {s['heights_m']}")
        if s["motion"]["model"] not in ("sea_state", "harmonic"):
            raise ValueError(
                f"scenario: motion.model must be 'sea_state' or 'harmonic', got {s['motion']['model']!r}"
            )
        import pandas as pd  # here: the campaign's workers import this module

        start = pd.Timestamp(s["start_utc"])
        if start.tzinfo is None or (start.value // 10**9) % int(s["record_length_s"]) != 0:
            raise ValueError(
                f"scenario: start_utc must be a UTC time on a record boundary (a multiple of "
                f"record_length_s = {s['record_length_s']} s), got {s['start_utc']!r}"
            )
        rate = float(s["imu"]["rate_hz"])
        if not 5.0 <= rate <= 20.0:
            raise ValueError(f"scenario: imu.rate_hz must be in [5, 20] Hz, got {rate}")
        lo, hi = s["lidar"]["refocus_delay_s"]
        if not 0.0 <= lo <= hi:
            raise ValueError(f"scenario: lidar.refocus_delay_s must be 0 <= lo <= hi, got {lo, hi}")
        _check_sea_state(s)
        _check_spatial_field(s["wind"]["spatial_field"])
        if s["reference_days"] is not None:
            _check_positive(s, "reference_days", s["reference_days"])
        if s["reference_instrument"] not in REFERENCE_INSTRUMENTS:
            raise ValueError(
                f"scenario: reference_instrument must be one of {REFERENCE_INSTRUMENTS}, got "
                f"{s['reference_instrument']!r}"
            )
        if s["lidar"]["scan_phase"] not in ("prism", "random"):
            raise ValueError(
                f"scenario: lidar.scan_phase must be 'prism' or 'random', got {s['lidar']['scan_phase']!r}"
            )
        try:
            _lidar.get_lidar(s["lidar"]["name"])
        except ValueError as exc:
            raise ValueError(f"scenario: lidar.name: {exc}") from None
        return cls(settings=s)

    def __getitem__(self, key):
        return self.settings[key]


def reference_sampling(scenario: str | Path | Mapping) -> dict:
    """How a virtual campaign samples the wind: what :mod:`flidar_uq.physics.lidar_response` needs.

    Parameters
    ----------
    scenario : str, Path or mapping
        Scenario name or path (:func:`load_scenario`) or a scenario mapping.

    Returns
    -------
    dict
        ``heights_in_turn`` (heights scanned in turn, one scan each), ``refocus_delay_s``
        ((lo, hi) uniform delay between scans, s), ``turbulence_dt_s`` (the 1-D Kaimal
        series are synthesised at this interval, rounded to a multiple of the
        line-of-sight time, and held in between: no variance above ``1 / (2 dt)``), and
        ``point_sample_interval_s`` (the truth columns are the std of the point HWS
        sampled every second), ``reference_kind`` (the scenario's
        ``reference_instrument``: "fixed_lidar", "cup" or "sonic"), ``lidar`` (its
        lidar's name) and ``spatial_field`` (whether the turbulence varies across the scan
        disk, ``wind.spatial_field.enabled``: the motionless lidar's std ratio to the point
        wind is then not the temporal model's).
    """
    data = scenario if isinstance(scenario, Mapping) else load_scenario(scenario)
    settings = CampaignConfig.from_dict(data).settings
    geo = _lidar.get_lidar(settings["lidar"]["name"])
    dt = campaign_clock_s(geo)
    lo, hi = settings["lidar"]["refocus_delay_s"]
    if geo.kind == "dbs":  # a pulsed lidar: every height from the same beams, no refocusing
        lo = hi = geo.cycle_s - geo.n_los * geo.los_duration_s
    return {
        "heights_in_turn": len(settings["heights_m"]) if geo.kind == "vad" else 1,
        "refocus_delay_s": (float(lo), float(hi)),
        "turbulence_dt_s": wind_step_slots(settings, dt) * dt,
        "point_sample_interval_s": TRUTH_SAMPLE_INTERVAL_S,
        "reference_kind": settings["reference_instrument"],
        "spatial_field": bool(settings["wind"]["spatial_field"]["enabled"]),
        "lidar": geo.name
        if isinstance(settings["lidar"]["name"], Mapping)
        else settings["lidar"]["name"],
    }


#: Allowed values of ``motion.sea_state.heading_mode``.
HEADING_MODES = ("fixed", "weathervane")


def _check_range(key, rng, lo, hi):
    """A [lo, hi] pair with lo <= hi inside [lo_allowed, hi_allowed] (or None)."""
    if rng is None:
        return
    ok = isinstance(rng, (list, tuple)) and len(rng) == 2
    if not ok or not (lo <= float(rng[0]) <= float(rng[1]) <= hi):
        raise ValueError(
            f"scenario: {key} must be null or [lo, hi] with {lo} <= lo <= hi <= {hi}, got {rng!r}"
        )


def _check_sea_state(s):
    ss = s["motion"]["sea_state"]
    _check_range("motion.sea_state.wind_sea_gamma_range", ss["wind_sea_gamma_range"], 1.0, 10.0)
    _check_range(
        "motion.sea_state.swell_direction_offset_deg_range",
        ss["swell_direction_offset_deg_range"],
        0.0,
        180.0,
    )
    if ss["heading_mode"] not in HEADING_MODES:
        raise ValueError(
            f"scenario: motion.sea_state.heading_mode must be one of {HEADING_MODES}, "
            f"got {ss['heading_mode']!r}"
        )
    try:
        get_hull(ss["hull"])
    except ValueError as err:
        raise ValueError(f"scenario: motion.sea_state.hull: {err}") from None
    for key in ("wind_sea_direction_sd_deg", "heading_sd_deg", "weathervane_min_hws_ms"):
        if not float(ss[key]) >= 0:
            raise ValueError(f"scenario: motion.sea_state.{key} must be >= 0, got {ss[key]!r}")


def _check_spatial_field(sf):
    if not isinstance(sf["enabled"], bool):
        raise ValueError(
            f"scenario: wind.spatial_field.enabled must be true or false, got {sf['enabled']!r}"
        )
    for key, lo, hi in (
        ("length_scale_factor_range", 0.1, 10.0),
        ("coherence_decay_range", 0.0, 100.0),
    ):
        if sf[key] is None:
            raise ValueError(f"scenario: wind.spatial_field.{key} must be [lo, hi], got null")
        _check_range(f"wind.spatial_field.{key}", sf[key], lo, hi)
    n_az = sf["azimuth_points"]
    if isinstance(n_az, bool) or not isinstance(n_az, int) or n_az < 3:
        raise ValueError(
            f"scenario: wind.spatial_field.azimuth_points must be an integer >= 3, got {n_az!r}"
        )


def _check_positive(s, key, val, integer=False):
    if not (np.isfinite(val) and val > 0) or (integer and int(val) != val):
        raise ValueError(
            f"scenario: {key} must be a positive {'integer' if integer else 'number'}, got {val!r}"
        )


def load_scenario(name_or_path: str | Path) -> dict:
    """Read a scenario YAML file (``flidar_uq/resources/scenarios/<name>.yaml`` or a path).

    Parameters
    ----------
    name_or_path : str or Path
        A shipped scenario name (``default``, ``tiny``, ``ijmuiden_60day``,
        ``hexapod_catalogue``, ``reservoir``) or a path to a YAML file.

    Returns
    -------
    dict
        The scenario mapping (validated by :meth:`CampaignConfig.from_dict`).
    """
    import yaml

    p = Path(name_or_path)
    if not p.suffix:
        p = scenario_dir() / f"{name_or_path}.yaml"
    if not p.is_file():
        known = sorted(q.stem for q in scenario_dir().glob("*.yaml"))
        raise ValueError(f"load_scenario: no scenario file {str(p)!r}; shipped scenarios: {known}")
    with open(p) as fh:
        data = yaml.safe_load(fh) or {}
    if not isinstance(data, Mapping):
        raise ValueError(f"load_scenario: {p} must hold a mapping, got {type(data).__name__}")
    CampaignConfig.from_dict(data)
    return dict(data)


#: Motion clock of a virtual DBS campaign, s: each beam's dwell is split into sub-slots of
#: about this length, and the beam's radial speed is their mean (the pulse accumulation
#: over the dwell; Desert, Knapp & Aubrun 2021 name it among the DBS mechanisms).
DBS_CLOCK_S = 0.05


def campaign_clock_s(lidar) -> float:
    """The virtual campaign's slot length (s) for a lidar: its line-of-sight time for a VAD
    lidar, the beam's dwell split into sub-slots of about :data:`DBS_CLOCK_S` for a DBS one."""
    g = _lidar.get_lidar(lidar)
    if g.kind == "vad":
        return g.los_duration_s
    return g.los_duration_s / max(int(round(g.los_duration_s / DBS_CLOCK_S)), 1)


def wind_step_slots(settings, dt):
    """Turbulence sampling interval in LOS slots (>= 1)."""
    return max(int(round(float(settings["wind"]["wind_dt_s"]) / dt)), 1)
