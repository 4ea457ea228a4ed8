"""Column definitions of the campaign data tables: the single source of truth.

Three tables are defined (see ``docs/data-format.md``, which is checked against
this module by ``tests/test_schema.py``):

- :data:`RECORD_COLUMNS`: the 10-min record table (CSV or Parquet).
- :data:`IMU_COLUMNS`: the raw IMU attitude series (5-20 Hz).
- :data:`LOS_COLUMNS`: line-of-sight (LOS) level lidar data.

Each column carries its dtype, unit, whether it is required, its physical
bounds and whether NaN is allowed.  Validation lives in :mod:`flidar_uq.data.io`;
this module imports no file library.
"""

from __future__ import annotations

from dataclasses import dataclass

__all__ = [
    "Column",
    "CORRECTED_TI_COLUMNS",
    "RECORD_COLUMNS",
    "IMU_COLUMNS",
    "LOS_COLUMNS",
    "TRUTH_PREFIX",
    "MOTION_COLUMNS",
    "N_TILT_BANDS",
    "TILT_SPECTRUM_COLUMNS",
    "HEAVE_RESPONSE_COLUMN",
    "SHEAR_EXPONENT_COLUMN",
    "SHEAR_EXPONENT_RANGE",
    "HORIZONTAL_RESPONSE_COLUMN",
    "tilt_band_column_names",
    "tilt_band_cos_psi_column",
    "tilt_band_sin_psi_column",
    "tilt_band_sincos_psi_column",
    "RADIAN_SUSPECT_MAX_DEG",
    "RADIAN_SUSPECT_MIN_COUNT",
    "IMU_RATE_RANGE_HZ",
    "KMH_SUSPECT_MEDIAN_MS",
    "TI_AS_STD_MAX_RATIO",
    "TI_PCT_AS_STD_MIN_RATIO",
    "UNIT_CHECK_MIN_COUNT",
    "UNIT_CHECK_MIN_HWS_MS",
    "record_column",
    "record_columns_by_name",
    "WAVE_PERIOD_FALLBACK_COLUMN",
]

#: Record column that gives both attitude periods when the table has neither
#: roll/pitch period column nor a raw IMU series (docs/data-format.md).
WAVE_PERIOD_FALLBACK_COLUMN = "wave_tp_s"


@dataclass(frozen=True)
class Column:
    """One column of a data table.

    Parameters
    ----------
    name : str
        Column name as written in the file header.
    dtype : str
        ``"float"`` (64-bit float) or ``"datetime"`` (ISO 8601 UTC timestamp).
    unit : str
        Physical unit (``"-"`` for dimensionless, ``"UTC"`` for timestamps).
    required : bool
        Whether the column must be present.
    lower, upper : float or None
        Inclusive physical bounds; ``None`` means unbounded.
    nan_allowed : bool
        Whether a missing value (empty cell, ``NaN``) is allowed.
    description : str
        Meaning of the column (one sentence).
    lower_exclusive : bool
        If True the lower bound is exclusive (value must be > lower).
    """

    name: str
    dtype: str
    unit: str
    required: bool
    lower: float | None
    upper: float | None
    nan_allowed: bool
    description: str
    lower_exclusive: bool = False

    def bounds_text(self) -> str:
        """Human-readable bounds, e.g. ``"[0, 80]"`` or ``"(0, 60]"``."""
        if self.lower is None and self.upper is None:
            return "-"
        lo = "-inf" if self.lower is None else f"{self.lower:g}"
        hi = "inf" if self.upper is None else f"{self.upper:g}"
        left = "(" if (self.lower_exclusive or self.lower is None) else "["
        return f"{left}{lo}, {hi}]"


TRUTH_PREFIX = "true_"
"""Columns starting with this prefix are truth columns of virtual campaigns:
numeric, optional, NaN allowed, no bounds."""

#: Angles whose finite non-zero values all lie below this (in deg) look like radians.
RADIAN_SUSPECT_MAX_DEG = 0.2
#: ... provided there are at least this many such values (rule documented in data-format.md).
RADIAN_SUSPECT_MIN_COUNT = 5
#: Accepted median IMU sampling rate (Hz), inclusive; nominal 5-20 Hz with 5 % tolerance.
IMU_RATE_RANGE_HZ = (4.75, 21.0)

# Unit checks of the record table (rules documented in data-format.md, "Wrong units"):
#: a median mean speed above this (m/s) over a whole campaign is implausible: km/h?
KMH_SUSPECT_MEDIAN_MS = 25.0
#: a median std / mean below this (-) means the std column holds TI as a fraction ...
TI_AS_STD_MAX_RATIO = 0.015
#: ... and above this (-) TI in percent
TI_PCT_AS_STD_MIN_RATIO = 0.5
#: the unit checks judge only records with a mean speed of at least this (m/s) ...
UNIT_CHECK_MIN_HWS_MS = 4.0
#: ... and only when there are at least this many such records
UNIT_CHECK_MIN_COUNT = 10

#: Measurement height, shared by the record and LOS tables (one definition, one bound).
_HEIGHT_M = Column(
    "height_m",
    "float",
    "m",
    True,
    0.0,
    1000.0,
    False,
    "Measurement height above the lidar.",
    lower_exclusive=True,
)

#: Period bands of the tilt spectrum in the record table (``tilt_band{b}_*`` columns,
#: b = 1 .. N_TILT_BANDS): log-spaced between 1 and 20 s, the bands the data layer reduces a
#: raw IMU series to (:func:`flidar_uq.data.imu.tilt_band_statistics`).
N_TILT_BANDS = 8

#: Optional record column: the hull's heave against a wave follower's with the record's
#: tilt spectrum, measured from the IMU series' vertical velocity or acceleration
#: (:func:`flidar_uq.data.imu.band_direction_from_heave`).
HEAVE_RESPONSE_COLUMN = "heave_response_ratio"

#: Optional record column: the same of the hull's horizontal velocity, from the IMU series'
#: east and north velocities (:func:`flidar_uq.data.imu.response_ratio`).
HORIZONTAL_RESPONSE_COLUMN = "horizontal_response_ratio"

#: Optional record column: the power-law shear exponent of the mean wind's profile at the
#: record's time (a DBS lidar's range gates move through the shear as the hull tilts),
#: and its bounds (-): outside them a profile is no power law (a low-level jet, a
#: height's mean disturbed).
SHEAR_EXPONENT_COLUMN = "shear_exponent"
SHEAR_EXPONENT_RANGE = (-0.5, 1.0)


def tilt_band_cos_psi_column(b: int) -> str:
    """Name of the optional record column of tilt band ``b`` (1-based): the signed mean
    cosine of its waves' directions of travel against the wind, from the heave."""
    return f"tilt_band{b}_cos_psi"


def tilt_band_sin_psi_column(b: int) -> str:
    """Name of the optional record column of tilt band ``b`` (1-based): the signed mean
    sine of its waves' directions of travel against the wind (+ to the left of the wind,
    counter-clockwise from above), from the heave."""
    return f"tilt_band{b}_sin_psi"


def tilt_band_sincos_psi_column(b: int) -> str:
    """Name of the optional record column of tilt band ``b`` (1-based): the mean of
    ``sin psi cos psi`` over its waves' directions of travel against the wind, from the
    co-spectrum of the along- and across-wind tilt (written with the band's variances)."""
    return f"tilt_band{b}_sincos_psi"


def tilt_band_column_names(b: int) -> tuple[str, str, str]:
    """Names of the record columns of tilt band ``b`` (1-based): period, along-wind
    variance, across-wind variance."""
    return (
        f"tilt_band{b}_period_s",
        f"tilt_band{b}_along_wind_var_deg2",
        f"tilt_band{b}_across_wind_var_deg2",
    )


RECORD_COLUMNS: tuple[Column, ...] = (
    Column(
        "timestamp",
        "datetime",
        "UTC",
        True,
        None,
        None,
        False,
        "Start of the 10-min record, ISO 8601 (naive values are taken as UTC).",
    ),
    _HEIGHT_M,
    Column(
        "hws_mean_ms",
        "float",
        "m/s",
        True,
        0.0,
        80.0,
        True,
        "Floating-lidar 10-min mean horizontal wind speed (NaN: no lidar data).",
    ),
    Column(
        "hws_std_ms",
        "float",
        "m/s",
        True,
        0.0,
        30.0,
        True,
        "Floating-lidar 10-min HWS standard deviation, sigma_moving.",
    ),
    Column(
        "wd_mean_deg",
        "float",
        "deg",
        True,
        0.0,
        360.0,
        True,
        "Floating-lidar mean wind direction, from, clockwise from north.",
    ),
    Column(
        "availability_pct",
        "float",
        "%",
        True,
        0.0,
        100.0,
        False,
        "Share of valid scans in the record.",
    ),
    Column(
        "roll_amplitude_deg",
        "float",
        "deg",
        True,
        0.0,
        45.0,
        True,
        "Roll amplitude, sqrt(2)*std of the detrended 10-min IMU roll (NaN: IMU gap).",
    ),
    Column(
        "pitch_amplitude_deg",
        "float",
        "deg",
        True,
        0.0,
        45.0,
        True,
        "Pitch amplitude, sqrt(2)*std of the detrended 10-min IMU pitch (NaN: IMU gap).",
    ),
    Column(
        "roll_period_s",
        "float",
        "s",
        True,
        0.0,
        60.0,
        True,
        "Dominant roll period, spectral peak (NaN: IMU gap).",
        lower_exclusive=True,
    ),
    Column(
        "pitch_period_s",
        "float",
        "s",
        True,
        0.0,
        60.0,
        True,
        "Dominant pitch period, spectral peak (NaN: IMU gap).",
        lower_exclusive=True,
    ),
    Column(
        "period1_s",
        "float",
        "s",
        False,
        0.0,
        60.0,
        True,
        "Shorter period of a bimodal record (NaN if unimodal); if the column is absent, "
        "consumers take the mean of roll_period_s and pitch_period_s.",
        lower_exclusive=True,
    ),
    Column(
        "period2_s",
        "float",
        "s",
        False,
        0.0,
        60.0,
        True,
        "Second spectral peak, the longer period of a bimodal record (NaN if unimodal).",
        lower_exclusive=True,
    ),
    Column(
        "weight1",
        "float",
        "-",
        False,
        0.0,
        1.0,
        True,
        "Share of the roll+pitch variance in the shorter-period peak (NaN if unimodal).",
    ),
    Column(
        "tilt_along_wind_std_deg",
        "float",
        "deg",
        False,
        0.0,
        45.0,
        True,
        "Std of the tilt component along the mean wind direction (heading-corrected), "
        "1-20 s band (NaN: IMU gap or no wind direction).",
    ),
    Column(
        "tilt_across_wind_std_deg",
        "float",
        "deg",
        False,
        0.0,
        45.0,
        True,
        "Std of the tilt component across the mean wind direction, 1-20 s band.",
    ),
    Column(
        "tilt_period_zero_crossing_s",
        "float",
        "s",
        False,
        0.0,
        60.0,
        True,
        "Zero-crossing period sqrt(m0/m2) of the along-wind tilt spectrum, 1-20 s band.",
        lower_exclusive=True,
    ),
    Column(
        "tilt_period_mean_s",
        "float",
        "s",
        False,
        0.0,
        60.0,
        True,
        "Mean period m0/m1 of the along-wind tilt spectrum, 1-20 s band.",
        lower_exclusive=True,
    ),
    Column(
        "follower_heave_velocity_std_ms",
        "float",
        "m/s",
        False,
        0.0,
        20.0,
        True,
        "Heave velocity std of a hull that follows the waves with the record's tilt "
        "spectrum, g sqrt(sum_b var_b / omega_b^2) over the along + across tilt bands "
        "(1-20 s, var in rad^2): the heave of a wave follower (flidar_uq.physics.hull).",
    ),
    Column(
        "follower_heave_period_s",
        "float",
        "s",
        False,
        0.0,
        60.0,
        True,
        "Mean period m0/m1 of that heave velocity's spectrum (band sums), s.",
        lower_exclusive=True,
    ),
    Column(
        "follower_velocity_along_wind_std_ms",
        "float",
        "m/s",
        False,
        0.0,
        20.0,
        True,
        "Horizontal orbital velocity std along the wind of a wave follower with the "
        "record's along-wind tilt spectrum, g sqrt(sum_b var_along_b / omega_b^2).",
    ),
    Column(
        "follower_heave_tilt_correlation",
        "float",
        "-",
        False,
        -1.0,
        1.0,
        True,
        "Correlation of a wave follower's heave velocity with its along-wind tilt, band by "
        "band, each band's waves taken to run downwind with a wrapped-normal spread "
        "(<cos psi> = (2 <cos^2 psi> - 1)^(1/4), 0 for a band mostly across the wind).",
    ),
    *(
        col
        for b in range(1, N_TILT_BANDS + 1)
        for col in (
            Column(
                f"tilt_band{b}_period_s",
                "float",
                "s",
                False,
                0.0,
                60.0,
                True,
                (
                    f"Tilt spectrum band 1 of {N_TILT_BANDS} (log-spaced 1-20 s bands, shortest "
                    "first): its centroid period 1/f_c, f_c the variance-weighted mean "
                    "frequency of the along + across tilt spectrum in the band."
                    if b == 1
                    else f"As tilt_band1_period_s, for band {b} of {N_TILT_BANDS}."
                ),
                lower_exclusive=True,
            ),
            Column(
                f"tilt_band{b}_along_wind_var_deg2",
                "float",
                "deg^2",
                False,
                0.0,
                2025.0,
                True,
                f"Variance of the tilt along the mean wind in band {b}.",
            ),
            Column(
                f"tilt_band{b}_across_wind_var_deg2",
                "float",
                "deg^2",
                False,
                0.0,
                2025.0,
                True,
                f"Variance of the tilt across the mean wind in band {b}.",
            ),
            Column(
                f"tilt_band{b}_cos_psi",
                "float",
                "-",
                False,
                -1.0,
                1.0,
                True,
                (
                    "Signed mean cosine of the directions of travel of band 1's waves against "
                    "the wind (+1 downwind, -1 upwind), from the co-spectrum of the IMU "
                    "series' vertical velocity and the along-wind tilt (Longuet-Higgins et "
                    "al., 1963); absent without a vertical velocity: then wind sea is taken "
                    "to run downwind and swell to have no known side."
                    if b == 1
                    else f"As tilt_band1_cos_psi, for band {b}."
                ),
            ),
            Column(
                f"tilt_band{b}_sin_psi",
                "float",
                "-",
                False,
                -1.0,
                1.0,
                True,
                (
                    "Signed mean sine of the directions of travel of band 1's waves against "
                    "the wind (+1 to the left of the wind's direction of travel, seen from "
                    "above; -1 to the right), from the co-spectrum of the IMU series' "
                    "vertical velocity and the across-wind tilt (Longuet-Higgins et al., "
                    "1963); absent without a vertical velocity: then either side is taken "
                    "alike (0). A DBS lidar's beams tell the sides apart; a conical scan does "
                    "not use it."
                    if b == 1
                    else f"As tilt_band1_sin_psi, for band {b}."
                ),
            ),
            Column(
                f"tilt_band{b}_sincos_psi",
                "float",
                "-",
                False,
                -0.5,
                0.5,
                True,
                (
                    "Mean of sin(psi) cos(psi) over the directions of travel of band 1's "
                    "waves against the wind (psi as in tilt_band1_sin_psi), from the "
                    "co-spectrum of the along- and across-wind tilt (Longuet-Higgins et al., "
                    "1963; the tilt alone gives it, whichever way the waves run): with the "
                    "along-wind share it sets the band's mean axis, on which a wind sea is "
                    "taken to run downwind where the side is not measured; with the measured "
                    "side a DBS lidar's beams see a band oblique to the wind through it. "
                    "Absent: 0 (a spread symmetric about the wind's axes)."
                    if b == 1
                    else f"As tilt_band1_sincos_psi, for band {b}."
                ),
            ),
        )
    ),
    Column(
        HEAVE_RESPONSE_COLUMN,
        "float",
        "-",
        False,
        0.0,
        10.0,
        True,
        "The hull's heave velocity against a wave follower's with the record's tilt "
        "spectrum, sqrt(sum_f P_w(f) / sum_f (g / omega)^2 P_tilt(f)) over the tilt bands' "
        "periods (1-20 s, tilt in rad), from the IMU series' vertical velocity or "
        "acceleration: 1 follows the waves, 0 only rotates. The record model takes it as "
        "a measured translation (the horizontal motion with the same ratio) where no "
        "MRU or GNSS translation std is given; absent: the translation's size is the "
        "fitted hull response's.",
    ),
    Column(
        HORIZONTAL_RESPONSE_COLUMN,
        "float",
        "-",
        False,
        0.0,
        10.0,
        True,
        "The hull's horizontal velocity (east and north together) against a wave "
        "follower's orbital velocity with the record's tilt spectrum, over the tilt bands' "
        "periods (1-20 s), from the IMU series' velocity_east_ms and velocity_north_ms: 1 "
        "follows the waves (deep-water orbits are circular), 0 only rotates. Taken as the "
        "measured horizontal translation with heave_response_ratio; absent: the "
        "horizontal motion takes the heave's ratio.",
    ),
    Column(
        SHEAR_EXPONENT_COLUMN,
        "float",
        "-",
        False,
        SHEAR_EXPONENT_RANGE[0],
        SHEAR_EXPONENT_RANGE[1],
        True,
        "Power-law exponent alpha of the mean wind's profile U (z / z0)^alpha at the "
        "record's time (the same on every height's row). A DBS lidar's record model takes "
        "it for the range gates that the hull's tilt moves up and down through the shear; "
        "absent or NaN: fitted to the floating lidar's own mean HWS at the heights of the "
        "same timestamp (at least two), else that term is left out. A conical scan does "
        "not use it.",
    ),
    Column(
        "heading_mean_deg",
        "float",
        "deg",
        False,
        -180.0,
        180.0,
        True,
        "Buoy heading over the record: circular mean of the IMU yaw (counter-clockwise "
        "from above, as yaw_deg). Used only with a fixed reference lidar on the "
        "floating lidar's scan schedule (reference.sampling_correlation auto on a "
        "virtual campaign); NaN or absent: unknown, the two lidars' sampling errors are "
        "then taken as independent.",
    ),
    Column(
        "imu_availability_pct",
        "float",
        "%",
        False,
        0.0,
        100.0,
        True,
        "Share of the nominal IMU samples present in the 10-min window.",
    ),
    Column(
        "sv",
        "float",
        "-",
        False,
        0.0,
        10.0,
        True,
        "Spatial variation: VAD fit residual divided by HWS.",
    ),
    Column(
        "ref_hws_mean_ms",
        "float",
        "m/s",
        False,
        0.0,
        80.0,
        True,
        "Reference instrument (fixed lidar, mast cup or sonic) 10-min mean HWS.",
    ),
    Column(
        "ref_hws_std_ms",
        "float",
        "m/s",
        False,
        0.0,
        30.0,
        True,
        "Reference instrument 10-min HWS standard deviation, sigma_ref.",
    ),
    Column(
        "wd_std_deg",
        "float",
        "deg",
        False,
        0.0,
        180.0,
        True,
        "Floating-lidar 10-min wind direction standard deviation.",
    ),
    Column(
        "cnr_mean_db",
        "float",
        "dB",
        False,
        -60.0,
        60.0,
        True,
        "Floating-lidar 10-min mean carrier-to-noise ratio at the height (QC).",
    ),
    Column(
        "packets_count",
        "float",
        "-",
        False,
        0.0,
        None,
        True,
        "Number of scans (packets) in the 10-min average (QC; a ZephIR's availability).",
    ),
    Column(
        "roll_std_deg",
        "float",
        "deg",
        False,
        0.0,
        45.0,
        True,
        "Std of the 10-min roll; without roll_amplitude_deg the amplitude is sqrt(2) times it.",
    ),
    Column(
        "pitch_std_deg",
        "float",
        "deg",
        False,
        0.0,
        45.0,
        True,
        "Std of the 10-min pitch; without pitch_amplitude_deg the amplitude is sqrt(2) times it.",
    ),
    Column(
        "surge_std_m",
        "float",
        "m",
        False,
        0.0,
        50.0,
        True,
        "Std of the 10-min surge displacement, along the body x axis.",
    ),
    Column(
        "sway_std_m",
        "float",
        "m",
        False,
        0.0,
        50.0,
        True,
        "Std of the 10-min sway displacement, along the body y axis.",
    ),
    Column(
        "heave_std_m",
        "float",
        "m",
        False,
        0.0,
        50.0,
        True,
        "Std of the 10-min heave displacement, positive up.",
    ),
    Column(
        "surge_velocity_std_ms",
        "float",
        "m/s",
        False,
        0.0,
        20.0,
        True,
        "Std of the 10-min surge velocity, along the body x axis.",
    ),
    Column(
        "sway_velocity_std_ms",
        "float",
        "m/s",
        False,
        0.0,
        20.0,
        True,
        "Std of the 10-min sway velocity, along the body y axis.",
    ),
    Column(
        "heave_velocity_std_ms",
        "float",
        "m/s",
        False,
        0.0,
        20.0,
        True,
        "Std of the 10-min heave velocity, positive up.",
    ),
    Column(
        "gnss_speed_mean_ms",
        "float",
        "m/s",
        False,
        0.0,
        30.0,
        True,
        "10-min mean GNSS speed over ground of the buoy.",
    ),
    Column(
        "wave_hs_m",
        "float",
        "m",
        False,
        0.0,
        30.0,
        True,
        "Significant wave height.",
    ),
    Column(
        "wave_tp_s",
        "float",
        "s",
        False,
        0.0,
        40.0,
        True,
        "Wave peak period; without roll_period_s and pitch_period_s (and no raw IMU series) both are taken as it.",
        lower_exclusive=True,
    ),
    Column(
        "wave_tm02_s",
        "float",
        "s",
        False,
        0.0,
        40.0,
        True,
        "Mean zero-crossing wave period Tm02.",
        lower_exclusive=True,
    ),
    Column(
        "wave_dir_deg",
        "float",
        "deg",
        False,
        0.0,
        360.0,
        True,
        "Mean wave direction, where the waves come from, clockwise from north.",
    ),
    Column(
        "wave_spread_deg",
        "float",
        "deg",
        False,
        0.0,
        180.0,
        True,
        "Directional spread of the waves.",
    ),
)

#: The corrected TI of a record (-) in results/ti/records.csv: posterior median, the
#: equal-tailed interval given the reference's std ratio, and that interval with the ratio's
#: campaign-wide error (``_total``; docs/data-format.md).
CORRECTED_TI_COLUMNS = (
    "ti_corrected_median",
    "ti_corrected_lo",
    "ti_corrected_hi",
    "ti_corrected_lo_total",
    "ti_corrected_hi_total",
)

#: Motion columns that are required unless the motion statistics come from a raw IMU series.
MOTION_COLUMNS = (
    "roll_amplitude_deg",
    "pitch_amplitude_deg",
    "roll_period_s",
    "pitch_period_s",
)

#: Optional wind-frame tilt columns (docs/data-format.md "Wind-frame tilt"); when they are
#: absent, sigma_Z falls back to the roll/pitch amplitude and period columns.
TILT_SPECTRUM_COLUMNS = (
    "tilt_along_wind_std_deg",
    "tilt_across_wind_std_deg",
    "tilt_period_zero_crossing_s",
    "tilt_period_mean_s",
    "follower_heave_velocity_std_ms",
    "follower_heave_period_s",
    "follower_velocity_along_wind_std_ms",
    "follower_heave_tilt_correlation",
    *(
        c
        for b in range(1, N_TILT_BANDS + 1)
        for c in (*tilt_band_column_names(b), tilt_band_sincos_psi_column(b))
    ),
)

IMU_COLUMNS: tuple[Column, ...] = (
    Column(
        "timestamp",
        "datetime",
        "UTC",
        True,
        None,
        None,
        False,
        "Sample time, ISO 8601 UTC, strictly increasing; nominal rate 5-20 Hz.",
    ),
    Column(
        "roll_deg",
        "float",
        "deg",
        True,
        -90.0,
        90.0,
        True,
        "Roll angle about the body x axis (NaN: missing sample).",
    ),
    Column(
        "pitch_deg",
        "float",
        "deg",
        True,
        -90.0,
        90.0,
        True,
        "Pitch angle about the body y axis (NaN: missing sample).",
    ),
    Column(
        "yaw_deg",
        "float",
        "deg",
        False,
        -360.0,
        360.0,
        True,
        "Yaw (heading) angle about the body z axis, counter-clockwise from above.",
    ),
    Column(
        "velocity_east_ms",
        "float",
        "m/s",
        False,
        -20.0,
        20.0,
        True,
        "Translational velocity of the buoy towards east at its rotation centre, the point the "
        "lever arm is measured from (ENU earth frame; NaN: missing sample); the LOS-level "
        "corrections add it to the head velocity of the rotation.",
    ),
    Column(
        "velocity_north_ms",
        "float",
        "m/s",
        False,
        -20.0,
        20.0,
        True,
        "Translational velocity of the buoy towards north at its rotation centre (ENU earth "
        "frame).",
    ),
    Column(
        "velocity_up_ms",
        "float",
        "m/s",
        False,
        -20.0,
        20.0,
        True,
        "Vertical (heave) velocity of the buoy at its rotation centre, positive up (ENU earth "
        "frame); with it the record table gets each tilt band's measured directions of travel "
        "(tilt_band{b}_cos_psi, tilt_band{b}_sin_psi, tilt_band{b}_sincos_psi) and the "
        "hull's heave response (heave_response_ratio).",
    ),
    Column(
        "acceleration_up_ms2",
        "float",
        "m/s^2",
        False,
        -30.0,
        30.0,
        True,
        "Vertical (heave) acceleration of the buoy at its rotation centre, positive up, "
        "gravity removed (ENU earth frame: an inertial unit's free acceleration); without "
        "velocity_up_ms it gives the same measured directions, integrated to the heave "
        "velocity frequency by frequency.",
    ),
)

LOS_COLUMNS: tuple[Column, ...] = (
    Column(
        "timestamp",
        "datetime",
        "UTC",
        True,
        None,
        None,
        False,
        "Time of the line-of-sight measurement, ISO 8601 UTC, non-decreasing per height.",
    ),
    _HEIGHT_M,
    Column(
        "azimuth_deg",
        "float",
        "deg",
        True,
        0.0,
        360.0,
        False,
        "Beam azimuth, clockwise from the body y axis.",
    ),
    Column(
        "radial_speed_ms",
        "float",
        "m/s",
        True,
        -80.0,
        80.0,
        True,
        "Radial speed, positive away from the lidar (abs(v_r) for CW lidars).",
    ),
    Column(
        "cnr_db",
        "float",
        "dB",
        True,
        -60.0,
        60.0,
        True,
        "Carrier-to-noise ratio of the LOS measurement.",
    ),
    Column(
        "elevation_deg",
        "float",
        "deg",
        False,
        0.0,
        90.0,
        False,
        "Beam elevation above the body x-y plane: 90 marks the vertical beam of a DBS lidar "
        "(its azimuth_deg is not used); absent: every beam on the lidar's cone.",
    ),
)


def record_columns_by_name() -> dict[str, Column]:
    """Return the record columns keyed by name."""
    return {c.name: c for c in RECORD_COLUMNS}


def record_column(name: str) -> Column:
    """Return the record :class:`Column` called ``name``.

    Truth columns (``true_*``) get a generic numeric definition.

    Raises
    ------
    ValueError
        If ``name`` is not a record column.
    """
    cols = record_columns_by_name()
    if name in cols:
        return cols[name]
    if name.startswith(TRUTH_PREFIX):
        return Column(
            name, "float", "various", False, None, None, True, "Truth column of a virtual campaign."
        )
    raise ValueError(f"unknown record column {name!r}; known: {sorted(cols)} and 'true_*'")
