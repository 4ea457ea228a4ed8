"""Workflow step of the correction layer: corrected TI per record, bin and speed bin, the
record flags, and the MD / RMSE / coverage scores (results/ti/)."""

from __future__ import annotations

import logging
import os
from collections.abc import Sequence

import numpy as np
import pandas as pd

from flidar_uq.data.binning import bin_centre, speed_bin_ms
from flidar_uq.inference.record_motion import describe_motion
from flidar_uq.seeding import child_seed
from flidar_uq.workflow.files import read_csv, write_csv
from flidar_uq.workflow.inference_steps import load_bin_fits

log = logging.getLogger(__name__)

__all__ = ["RECORD_COLUMNS", "bin_table", "propagate", "record_groups", "resolve_reference"]

#: The reference columns whose presence makes ``reference.kind`` required.
_REFERENCE_COLUMNS = ("ref_hws_mean_ms", "ref_hws_std_ms")


def resolve_reference(
    reference: dict,
    *,
    virtual_kind: str | None,
    record_columns: Sequence[str] | None,
    lidar: str,
) -> dict:
    """The config's ``reference`` section with its kind and lidar decided, or a one-line error.

    Parameters
    ----------
    reference : dict
        ``config["reference"]``: ``kind`` (None when not set), ``lidar`` (None: the
        floating lidar's type), ``height_m``, ``separation_m``, ``lidar_std_ratio_log_sd``,
        ``sampling_correlation`` ("auto", "synchronized" or a number in [-1, 1]).
    virtual_kind : str or None
        The virtual campaign's ``reference_instrument`` (source virtual), else None.
    record_columns : sequence of str or None
        Columns of the user's record table (source files), else None.
    lidar : str
        The floating lidar's geometry name (``lidar.name``).

    Returns
    -------
    dict
        ``reference`` with ``kind`` set ("cup" | "sonic" | "fixed_lidar" | "none"),
        ``lidar`` set (the fixed lidar's geometry, or the floating lidar's) and
        ``sampling_correlation`` set: "auto" becomes "synchronized" for the virtual
        campaign's reference lidar (it scans on the floating lidar's schedule) and
        :data:`flidar_uq.correction.propagation.REFERENCE_SAMPLING_CORRELATION` (0) for a
        user's fixed lidar (its own schedule).

    Raises
    ------
    ValueError
        If the records carry ``ref_*`` columns and ``reference.kind`` is not set, if it
        contradicts the virtual campaign's reference, or is "none" with ``ref_*`` columns.
    """
    out = dict(reference)
    kind = out.get("kind")
    if virtual_kind is not None:
        if kind is not None and kind != virtual_kind:
            raise ValueError(
                f"config key reference.kind={kind!r} contradicts the virtual campaign's "
                f"reference_instrument {virtual_kind!r} (leave reference.kind unset)"
            )
        kind = virtual_kind
    elif record_columns is not None:
        has_ref = [c for c in _REFERENCE_COLUMNS if c in record_columns]
        if has_ref and kind is None:
            raise ValueError(
                f"config key reference.kind is missing: the records carry {', '.join(has_ref)}; "
                "set it to cup, sonic or fixed_lidar"
            )
        if has_ref and kind == "none":
            raise ValueError(
                f"config key reference.kind is 'none' but the records carry {', '.join(has_ref)}"
            )
        kind = kind or "none"
    out["kind"] = kind or "none"
    out["lidar"] = out.get("lidar") or lidar
    # the two lidars' sampling correlation: the virtual campaign's reference lidar scans on
    # the floating lidar's schedule; a user's fixed lidar on its own
    corr = out.get("sampling_correlation", "auto")
    if corr == "auto":
        from flidar_uq.correction.propagation import REFERENCE_SAMPLING_CORRELATION, SYNCHRONIZED

        corr = SYNCHRONIZED if virtual_kind is not None else REFERENCE_SAMPLING_CORRELATION
    out["sampling_correlation"] = corr
    from flidar_uq.physics.lidar import get_lidar

    try:
        get_lidar(out["lidar"])
    except (KeyError, ValueError):
        raise ValueError(
            f"config key reference.lidar={out['lidar']!r} is not a known lidar geometry"
        ) from None
    return out


def reference_noise(
    records: pd.DataFrame,
    reference: dict,
    *,
    heights_in_turn: int,
    refocus_delay_s: Sequence[float],
    point_sample_interval_s: float,
    turbulence_dt_s: float | None,
    seed: int,
):
    """The reference's point target and the two lidars' sampling pair term, per record.

    One function for the record fit (``fit_global_model``, model "record") and the
    propagation, so both see the same numbers for a record.

    Parameters
    ----------
    records : pandas.DataFrame
        Records with ``hws_mean_ms`` (m/s), ``height_m`` (m) and, for a synchronised
        reference lidar, ``heading_mean_deg`` (deg).
    reference : dict
        :func:`resolve_reference`'s output.
    heights_in_turn, refocus_delay_s, point_sample_interval_s, turbulence_dt_s
        The lidar's scan settings (-, s, s, s; :func:`flidar_uq.correction.propagation.point_target`).
    seed : int
        Config ``inference.seed``.

    Returns
    -------
    lidar_std_ratio, point_log_sd : numpy.ndarray or None
        :func:`flidar_uq.correction.propagation.reference_target` (None for a cup or sonic).
    correlation, pair_log_sd : numpy.ndarray or None
        For a fixed reference lidar: ``c`` of
        :func:`flidar_uq.correction.propagation.pair_sampling_correlation` (-) and the pair
        term ``sqrt(2 (1 - c)) sd`` (-) of
        :func:`flidar_uq.correction.propagation.reference_pair_log_sd`; else None.
    """
    from flidar_uq.correction import propagation as prop

    hws = records["hws_mean_ms"].to_numpy(dtype=float)
    height = records["height_m"].to_numpy(dtype=float)
    scan = {
        "heights_in_turn": int(heights_in_turn),
        "refocus_delay_s": tuple(refocus_delay_s),
        "point_sample_interval_s": point_sample_interval_s,
        "turbulence_dt_s": turbulence_dt_s,
    }
    g_ratio, log_sd = prop.reference_target(
        reference["kind"], hws, height, reference["lidar"], **scan, seed=seed
    )
    if reference["kind"] != "fixed_lidar":
        return g_ratio, log_sd, None, None
    heading = (
        records["heading_mean_deg"].to_numpy(dtype=float) if "heading_mean_deg" in records else None
    )
    corr = prop.pair_sampling_correlation(
        reference.get("sampling_correlation", prop.REFERENCE_SAMPLING_CORRELATION),
        heading,
        hws,
        height,
        reference["lidar"],
        seed=int(child_seed(seed, 3).generate_state(1)[0]),
        **scan,
    )
    return g_ratio, log_sd, corr, prop.reference_pair_log_sd(log_sd, corr)


#: Columns of results/ti/records.csv that every run writes, in order (the output contract).
RECORD_COLUMNS = [
    "timestamp",
    "height_m",
    "bin_id",
    "hws_mean_ms",
    "ti_uncorrected",
    "ti_corrected_median",
    "ti_corrected_lo",
    "ti_corrected_hi",
    "flags",
]


#: Optional record columns of the input carried into results/ti/records.csv as they are
#: (the buoy logger's and the lidar's statistics; docs/data-format.md).
CARRIED_RECORD_COLUMNS = (
    "wd_std_deg",
    "cnr_mean_db",
    "packets_count",
    "roll_std_deg",
    "pitch_std_deg",
    "surge_std_m",
    "sway_std_m",
    "heave_std_m",
    "surge_velocity_std_ms",
    "sway_velocity_std_ms",
    "heave_velocity_std_ms",
    "gnss_speed_mean_ms",
    "wave_hs_m",
    "wave_tp_s",
    "wave_tm02_s",
    "wave_dir_deg",
    "wave_spread_deg",
)


def carried_columns(columns) -> list[str]:
    """The input columns that results/ti/records.csv carries unchanged: the optional
    columns of :data:`CARRIED_RECORD_COLUMNS` and every column that is no record column
    (config ``campaign.extra_columns: keep``); truth columns have their own rule."""
    from flidar_uq.data.schema import TRUTH_PREFIX, record_columns_by_name

    known = record_columns_by_name()
    return [
        c
        for c in columns
        if c in CARRIED_RECORD_COLUMNS
        or (c not in known and not str(c).startswith(TRUTH_PREFIX) and c not in ("row",))
    ]


def propagate(
    *,
    records_path: str | os.PathLike,
    flags_path: str | os.PathLike,
    assignments_path: str | os.PathLike,
    table_path: str | os.PathLike,
    sigma_z_path: str | os.PathLike,
    bin_fits_path: str | os.PathLike | None,
    batch_dirs: Sequence[str | os.PathLike],
    global_path: str | os.PathLike,
    records_out: str | os.PathLike,
    speed_bins_out: str | os.PathLike,
    metrics_out: str | os.PathLike,
    credible_mass: float,
    ndraws: int,
    seed: int,
    lidar: str = "zephir300",
    reference: dict | None = None,
    turbulence_dt_s: float | None = None,
    point_sample_interval_s: float = 1.0,
    scan_heights_in_turn: int | None = None,
    scan_refocus_delay_s: Sequence[float] = (0.3, 0.7),
    groups_out: str | os.PathLike | None = None,
    budget_out: str | os.PathLike | None = None,
    sector_width_deg: float = 30.0,
    min_count: int = 10,
    budget_ndraws: int = 200,
) -> pd.DataFrame:
    """Corrected std and TI per record and per speed bin, beside the baselines.

    Calls :func:`flidar_uq.correction.propagation.corrected_ti` on the kept, binned records with the
    converged bin fits and the global fit (posterior draws through the deployment formula;
    median and equal-tailed ``credible_mass`` interval), and Gutiérrez-Antuñano et al.'s (2018) U / C / PC laws.

    ``global_path``: the global posterior (NetCDF). The record motion model's needs nothing
    else: ``bin_fits_path`` (None) and ``batch_dirs`` (empty) are not read, so the
    propagation runs beside the per-bin fits. The bin motion model's needs the per-bin
    summaries (``bin_fits_path``, :func:`flidar_uq.workflow.inference_steps.fit_global`)
    and the batch directories of the bin posteriors. The per-bin table is
    :func:`bin_table`'s, from the records written here.

    The corrected std is always the point (cup-like) std; how it is reached follows the
    reference instrument (``reference``, :func:`resolve_reference`'s output; default: a
    fixed lidar of the floating lidar's type):
    ``kind`` "cup" or "sonic": the model is calibrated to the point wind directly (no
    ratio, no extra scatter). "fixed_lidar" (or "none": the deployment formula gives a
    motionless lidar of the floating lidar's type): divided by that lidar's std ratio
    (:func:`flidar_uq.physics.lidar_response.lidar_std_ratio` of ``reference["lidar"]``,
    at the record's HWS and height, band-limited at ``1 / (2 turbulence_dt_s)`` for a
    synthetic series; None: the atmosphere) with its prior sd
    ``reference["lidar_std_ratio_log_sd"]`` and its record-to-record scatter
    (:func:`flidar_uq.physics.lidar_response.lidar_point_log_sd`: the lidar scanning
    ``scan_heights_in_turn`` heights in turn (None: the number of distinct heights in
    the records) with ``scan_refocus_delay_s`` between scans, against the point HWS
    sampled every ``point_sample_interval_s``). ``lidar_std_ratio`` and ``point_log_sd``
    are written per record (1 and 0 for a cup or sonic).

    ``speed_bins_out``: per height and 1-m/s speed bin, the mean, representative TI,
    90th percentile and std of the corrected TI with credible intervals of the statistic
    (:func:`flidar_uq.correction.propagation.ti_group_statistics`; groups with fewer than
    ``min_count`` records keep their count only). ``groups_out``: the same per height for
    the whole campaign, per wind-direction sector (``sector_width_deg`` wide, centred on
    multiples of it from north) and per sea-state class (:func:`record_groups`).
    ``budget_out``: the uncertainty budget of the campaign mean and of each speed bin's
    mean (:func:`flidar_uq.correction.uncertainty_budget.uncertainty_budget`), from its
    own ``1 + len(UNCERTAINTY_SOURCES)`` passes at ``min(budget_ndraws, ndraws)`` draws
    per record (all its columns, ``ti_mean`` and ``width`` included; the passes share
    the seed, common random numbers). 200 draws: a variance share's Monte Carlo sd is
    at most ``0.77 / sqrt(budget_ndraws - 1)`` = 0.055 (docs/performance.md); with
    ``budget_ndraws >= ndraws`` the main pass's draws are reused, as before.

    ``metrics_out``: MD and RMSE (Gutiérrez-Antuñano et al., 2018, Eqs. 18-19) of std (m/s) and TI for the
    uncorrected, U, C, PC and Bayesian estimates against the truth (``true_*``, virtual
    campaigns) or else the reference instrument, over the records with a Bayesian value;
    and the coverage of the credible interval when the truth is known.
    """
    from flidar_uq import inference as inf
    from flidar_uq.correction import propagation as prop
    from flidar_uq.data import metrics
    from flidar_uq.physics.surrogate import get_surrogate

    flags = read_csv(flags_path)
    assigned = read_csv(assignments_path)
    table = read_csv(table_path)
    sz_table = read_csv(sigma_z_path).set_index("bin_id")
    gfit = inf.load_fit(global_path)
    record_model = inf.is_record_model(gfit)
    # the record motion model takes each record's sigma_Z from its own motion: the bin
    # posteriors (hundreds of files at a year, ~0.2 s each to open) are not read then
    if record_model:
        bin_fits, fits = None, {}
    elif bin_fits_path is None:
        raise ValueError(f"{global_path} is a bin motion model: the per-bin fits are needed")
    else:
        bin_fits = read_csv(bin_fits_path)
        fits = load_bin_fits(batch_dirs, bin_fits)
    surrogate = get_surrogate(lidar)

    rid = flags["record_id"].to_numpy()
    rec = read_csv(records_path).iloc[rid].reset_index(drop=True)  # every input record
    rec["bin_id"] = assigned.set_index("record_id")["bin_id"].reindex(rid).to_numpy()
    binned = rec["bin_id"].notna().to_numpy()
    if record_model:  # every QC-kept record, binned or not: its sigma_Z is its own
        use = flags["reasons"].fillna("").eq("").to_numpy()
        sub = rec[use]
    else:
        use = binned
        sub = rec[use].astype({"bin_id": int})
    ref = resolve_reference(
        reference or {"kind": "fixed_lidar"}, virtual_kind=None, record_columns=None, lidar=lidar
    )
    heights = scan_heights_in_turn or int(rec["height_m"].nunique())
    g_ratio, log_sd, pair_corr, _ = reference_noise(
        sub,
        ref,
        heights_in_turn=heights,
        refocus_delay_s=scan_refocus_delay_s,
        point_sample_interval_s=point_sample_interval_s,
        turbulence_dt_s=turbulence_dt_s,
        seed=seed,
    )
    g_log_sd = float(ref.get("lidar_std_ratio_log_sd", prop.LIDAR_STD_RATIO_LOG_SD))
    if g_ratio is None:
        log.info("point target: reference %s, calibrated to the point wind", ref["kind"])
        g_log_sd = 0.0
    else:
        log.info(
            "point target: lidar std ratio %.4f-%.4f, log-sd %.4f-%.4f (%d heights in turn)",
            np.nanmin(g_ratio), np.nanmax(g_ratio), np.nanmin(log_sd), np.nanmax(log_sd), heights,
        )  # fmt: skip
    if pair_corr is not None:
        log.info(
            "reference lidar sampling: correlation with the floating lidar's %s, c = %.3f-%.3f",
            ref["sampling_correlation"], np.nanmin(pair_corr), np.nanmax(pair_corr),
        )  # fmt: skip
    baseline = prop.variance_law_baselines(sub, surrogate)

    def correct(hold=(), ndraws=ndraws):
        return prop.corrected_ti(
            sub,
            [f for f in fits.values() if f.converged],
            gfit,
            surrogate=surrogate,
            lidar=lidar,
            credible_mass=credible_mass,
            ndraws=ndraws,
            lidar_std_ratio=g_ratio,
            point_log_sd=log_sd,
            lidar_std_ratio_log_sd=g_log_sd,
            reference_sampling_correlation=pair_corr,
            baseline=baseline,
            hold=hold,
            return_draws=True,
            group_statistics=False,
            seed=child_seed(seed, 2),
        )

    per_record, _, ti_draws = correct()
    sz_seed, rho_seed = baseline
    heights = sub["height_m"].to_numpy(dtype=float)
    speed_keys = pd.DataFrame(
        {"height_m": heights, "hws_bin_ms": speed_bin_ms(sub["hws_mean_ms"].to_numpy(dtype=float))}
    )
    speed_bins = prop.ti_group_statistics(
        ti_draws, per_record, speed_keys, credible_mass=credible_mass, min_count=min_count
    )
    if groups_out is not None:
        labels = record_groups(sub, sector_width_deg=sector_width_deg)
        tables = []
        for grouping, col in (
            ("campaign", None),
            ("direction sector", "sector_deg"),
            ("sea state", "sea_state"),
        ):
            group = np.full(len(sub), "all", dtype=object) if col is None else labels[col]
            keys = pd.DataFrame({"height_m": heights, "group": np.asarray(group, dtype=object)})
            t = prop.ti_group_statistics(
                ti_draws, per_record, keys, credible_mass=credible_mass, min_count=min_count
            )
            t.insert(0, "grouping", grouping)
            tables.append(t)
        write_csv(pd.concat(tables, ignore_index=True), groups_out)
    if budget_out is not None:
        from flidar_uq.correction.uncertainty_budget import uncertainty_budget

        # its own passes at budget_ndraws (common random numbers: the same seed and draws
        # for every hold), the main pass's draws when it has no more
        nb = min(int(budget_ndraws), int(ndraws))
        free = ti_draws if nb == ndraws else correct((), nb)[2]
        usable = per_record["converged"].to_numpy(dtype=bool) & np.all(np.isfinite(free), axis=0)
        budget = uncertainty_budget(
            lambda hold: free if not hold else correct(hold, nb)[2],
            {"campaign": speed_keys[["height_m"]], "speed bin": speed_keys},
            usable,
            credible_mass=credible_mass,
            min_count=min_count,
        )
        write_csv(budget, budget_out)

    out = _records_table(rec, rid, flags["timestamp"], use, per_record, sz_seed, sz_table)
    if record_model:  # which motion description gave each record's sigma_Z
        desc = describe_motion(rec, hull_model=gfit.info.get("hull_model"), lidar=lidar)
        for col in desc:
            out[col] = np.where(use, desc[col].to_numpy(), "")
    neg = _scatter(per_record["discriminant_negative"].to_numpy(dtype=bool), use, bool, False)
    described = (
        _scatter(np.isfinite(per_record["sigma_z_median_ms"].to_numpy()), use, bool, False)
        if record_model
        else None
    )
    out["flags"] = prop.record_flags(
        flags["reasons"].fillna(""),
        out["bin_id"].to_numpy(),
        binned,
        neg,
        fitted=table.set_index("bin_id")["fitted"],
        status=pd.Series(dtype=object) if record_model else bin_fits.set_index("bin_id")["status"],
        global_converged=gfit.converged,
        motion_described=described,
    )
    if "ref_hws_std_ms" in rec:
        out["ref_hws_std_ms"] = rec["ref_hws_std_ms"].to_numpy(dtype=float)
        with np.errstate(invalid="ignore", divide="ignore"):
            out["ti_ref"] = out["ref_hws_std_ms"] / rec["ref_hws_mean_ms"].to_numpy(dtype=float)
    if "true_ti" in rec:
        out["ti_true"] = rec["true_ti"].to_numpy(dtype=float)
    if "true_hws_std_ms" in rec:
        out["true_hws_std_ms"] = rec["true_hws_std_ms"].to_numpy(dtype=float)
    for col in ("true_swell_present", "true_weathervane"):  # regime truth, for the report
        if col in rec:
            out[col] = rec[col].to_numpy(dtype=float)
    for col in carried_columns(rec.columns):  # buoy-logger and extra columns, unchanged
        if col not in out.columns:
            out[col] = rec[col].to_numpy()
    out = out[RECORD_COLUMNS + [c for c in out.columns if c not in RECORD_COLUMNS]]
    write_csv(out, records_out)
    write_csv(speed_bins, speed_bins_out)

    # MD / RMSE of std and TI (Tables 2-3 style) against the truth (virtual campaigns)
    # and against the reference instrument, where present, over the same records.
    scores = metrics.score_estimates(out, metrics.reference_values(rec, kind=ref["kind"]))
    scores["rho_bin_correlation"] = rho_seed
    scores["credible_mass"] = credible_mass
    scores["reference_kind"] = ref["kind"]
    height = ref.get("height_m")
    scores["reference_height_m"] = (
        ";".join(f"{h:g}" for h in np.atleast_1d(height)) if height is not None else "lidar"
    )
    scores["reference_separation_m"] = float(ref.get("separation_m") or 0.0)
    write_csv(scores, metrics_out)
    return out


def record_groups(records: pd.DataFrame, *, sector_width_deg: float = 30.0) -> pd.DataFrame:
    """Direction sector and sea-state class of each record, from the measured columns.

    Parameters
    ----------
    records : pandas.DataFrame
        Records with ``wd_mean_deg`` and, for the sea state, ``period2_s`` (second
        spectral peak of roll and pitch, NaN when unimodal) and the wind-frame tilt stds
        ``tilt_along_wind_std_deg`` / ``tilt_across_wind_std_deg``.
    sector_width_deg : float
        Width of the direction sectors (deg), which are centred on multiples of it from
        north (the default 30 gives the 12 sectors 0, 30, ..., 330 deg).

    Returns
    -------
    pandas.DataFrame
        ``sector_deg`` (sector centre, deg, NaN without a direction) and ``sea_state``:
        ``"one peak"`` / ``"two peaks"`` (one or two spectral peaks of roll and pitch: a
        second peak is typically a swell beside the wind sea), joined with ``"tilt along
        wind"`` / ``"tilt across wind"`` (which of the wind-frame tilt stds is larger: the
        along-wind tilt is what inflates the measured std, design notes); parts whose
        columns are absent or NaN are left out; ``"unknown"`` when nothing is known.
    """
    if not 0 < sector_width_deg <= 180 or not (360.0 / sector_width_deg).is_integer():
        raise ValueError(
            f"record_groups: sector_width_deg={sector_width_deg} must divide 360 (0 < width <= 180)"
        )
    n = len(records)
    wd = (
        records["wd_mean_deg"].to_numpy(dtype=float)
        if "wd_mean_deg" in records
        else np.full(n, np.nan)
    )
    sector = np.mod(bin_centre(np.mod(wd, 360.0), sector_width_deg), 360.0)

    def col(name):
        return records[name].to_numpy(dtype=float) if name in records else np.full(n, np.nan)

    peaks = np.where(np.isfinite(col("period2_s")), "two peaks", "one peak")
    peaks = np.where("period2_s" in records, peaks, "")
    along, across = col("tilt_along_wind_std_deg"), col("tilt_across_wind_std_deg")
    known = np.isfinite(along) & np.isfinite(across)
    tilt = np.where(~known, "", np.where(along >= across, "tilt along wind", "tilt across wind"))
    sea = [", ".join(p for p in parts if p) or "unknown" for parts in zip(peaks, tilt, strict=True)]
    return pd.DataFrame({"sector_deg": sector, "sea_state": sea}, index=records.index)


def _scatter(values, mask: np.ndarray, dtype=float, fill=np.nan) -> np.ndarray:
    """``values`` of the binned records spread to every record (``fill`` elsewhere)."""
    full = np.full(mask.size, fill, dtype=dtype)
    full[mask] = values
    return full


def _records_table(
    rec: pd.DataFrame,
    rid: np.ndarray,
    timestamp: pd.Series,
    use: np.ndarray,
    per_record: pd.DataFrame,
    sz_seed: np.ndarray,
    sz_table: pd.DataFrame,
) -> pd.DataFrame:
    """results/ti/records.csv without flags and references: one row per input record, the
    corrected values of :func:`~flidar_uq.correction.propagation.corrected_ti` where ``use``."""
    m = rec["hws_mean_ms"].to_numpy(dtype=float)
    s = rec["hws_std_ms"].to_numpy(dtype=float)
    out = pd.DataFrame({"record_id": rid, "timestamp": timestamp, "height_m": rec["height_m"]})
    out["bin_id"] = rec["bin_id"].to_numpy()
    out["hws_mean_ms"] = m
    out["hws_std_ms"] = s
    with np.errstate(invalid="ignore", divide="ignore"):
        out["ti_uncorrected"] = s / m
    for col in (
        "ti_corrected_median",
        "ti_corrected_lo",
        "ti_corrected_hi",
        "ti_corrected_lo_total",
        "ti_corrected_hi_total",
    ):
        out[col] = _scatter(per_record[col].to_numpy(), use)
    for col, src in (
        ("std_corrected_median_ms", "sigma_corrected_median_ms"),
        ("std_corrected_lo_ms", "sigma_corrected_lo_ms"),
        ("std_corrected_hi_ms", "sigma_corrected_hi_ms"),
        ("sigma_z_median_ms", "sigma_z_median_ms"),
        ("lidar_std_ratio", "lidar_std_ratio"),
        ("point_log_sd", "point_log_sd"),
        ("p_discriminant_negative", "discriminant_negative_frac"),
        ("ti_corrected_u", "ti_u"),
        ("ti_corrected_c", "ti_c"),
        ("ti_corrected_pc", "ti_pc"),
    ):
        out[col] = _scatter(per_record[src].to_numpy(), use)
    out["sigma_z_baseline_ms"] = _scatter(sz_seed, use)
    for law in ("u", "c", "pc"):
        out[f"std_corrected_{law}_ms"] = out[f"ti_corrected_{law}"] * m
    out["sigma_z_bin_ms"] = sz_table["sigma_z_ms"].reindex(out["bin_id"]).to_numpy(dtype=float)
    return out


def bin_table(
    *,
    table_path: str | os.PathLike,
    sigma_z_path: str | os.PathLike,
    bin_fits_path: str | os.PathLike,
    records_path: str | os.PathLike,
    out_path: str | os.PathLike,
) -> pd.DataFrame:
    """results/ti/bins.csv: per bin (Gutiérrez-Antuñano et al., 2018, Table 1 style), the bin table, sigma_Z and E(Z)
    at the bin centre (m/s), the bin fit's status and diagnostics, and the means over its
    records of the uncorrected and corrected TI (median, interval bounds) and of the true
    TI where known, from the records :func:`propagate` wrote (``records_path``)."""
    table = read_csv(table_path)
    sz_table = read_csv(sigma_z_path).set_index("bin_id")
    bins = _bins_table(table, sz_table, read_csv(bin_fits_path), read_csv(records_path))
    write_csv(bins, out_path)
    return bins


def _bins_table(
    table: pd.DataFrame, sz_table: pd.DataFrame, bin_fits: pd.DataFrame, out: pd.DataFrame
) -> pd.DataFrame:
    """results/ti/bins.csv: bin table + sigma_Z at the centre + fit status/diagnostics + TI means."""
    bins = table.merge(sz_table[["sigma_z_ms", "mean_z_ms"]].reset_index(), on="bin_id", how="left")
    bins = bins.merge(
        bin_fits.drop(columns=[c for c in ("n_records",) if c in bin_fits]), on="bin_id", how="left"
    )
    bins["status"] = bins["status"].where(bins["fitted"], "not_fitted")
    agg = {
        "ti_uncorrected": "mean",
        "ti_corrected_median": "mean",
        "ti_corrected_lo": "mean",
        "ti_corrected_hi": "mean",
    }
    if "ti_true" in out:
        agg["ti_true"] = "mean"
    means = out.groupby("bin_id").agg(agg).add_suffix("_mean").reset_index()
    return bins.merge(means, on="bin_id", how="left")
