"""Calibration of the corrected TI by regime on virtual campaigns with truth.

A virtual scenario (``flidar_uq/resources/scenarios/*.yaml``) is generated, QC-filtered,
calibrated with the record motion model on the records that carry a reference, and every
QC-kept record is corrected to the point TI, exactly as the pipeline does (without the per-bin
fits, which only serve the bin table); or, with ``motion_model="bin"``, binned and fitted
bin by bin and globally as the pipeline's bin motion model does (Gutiérrez-Antuñano et al.
2018), every record of a converged bin corrected. The corrected TI is then scored against the
campaign's truth per regime: wind-speed group (3 m/s), sea state (wind sea only / with
swell), heading (weathervaning / fixed), and their crossings
(:func:`flidar_uq.data.calibration.calibration_by_group`).
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pandas as pd

from flidar_uq.campaign.physics_mode import generate_campaign
from flidar_uq.campaign.scenarios import load_scenario, reference_sampling
from flidar_uq.correction.propagation import (
    LIDAR_STD_RATIO_LOG_SD,
    REFERENCE_SAMPLING_CORRELATION,
    SYNCHRONIZED,
    PointTarget,
    PropagationSettings,
    draw_corrected_ti,
    record_summary,
)
from flidar_uq.correction.reference import Reference
from flidar_uq.data.binning import add_harmonic_motion, bins_for_fitting
from flidar_uq.data.calibration import calibration_by_group, speed_group_label
from flidar_uq.data.qc import QCConfig, run_qc
from flidar_uq.data.schema import CORRECTED_TI_COLUMNS
from flidar_uq.inference import (
    SamplerSettings,
    fit_bin,
    fit_global,
    fit_record_model_selecting_hull,
)
from flidar_uq.inference.observations import with_shear_exponent
from flidar_uq.physics.lidar import get_lidar
from flidar_uq.physics.surrogate import get_surrogate
from flidar_uq.seeding import as_seedsequence
from flidar_uq.threads import single_threaded

__all__ = [
    "DEFAULT_BINNING",
    "REGIME_COLUMNS",
    "bin_model_fit",
    "regime_labels",
    "scenario_calibration",
    "scenario_records",
]

#: Grouping columns of :func:`scenario_calibration`'s tables.
REGIME_COLUMNS = ("speed_group", "sea_state", "heading", "sea_state_heading", "wave_period")

#: The bins of :func:`bin_model_fit`: the config's ``binning`` defaults (m/s, deg, s and
#: records; Gutiérrez-Antuñano et al., 2018, Sec. 3.1).
DEFAULT_BINNING = {
    "hws_width_ms": 1.0,
    "amplitude_width_deg": 1.0,
    "period_width_s": 1.0,
    "min_count": 30,
}

#: Edges of the wave-period groups (s, the record's dominant sea period): a short wind
#: sea below 4 s, whose orbital translation is smaller than the lever arm's; a long swell
#: above 7 s, whose translation is several times larger (``g T^2 / (4 pi^2)`` 2.5 m
#: against 12 m).
WAVE_PERIOD_EDGES_S = (4.0, 7.0)


def regime_labels(records: pd.DataFrame) -> pd.DataFrame:
    """Regime labels of each record from the campaign's truth columns.

    Returns
    -------
    pandas.DataFrame
        ``speed_group`` (3-m/s groups from 3 m/s, on the measured mean HWS), ``sea_state``
        (``"swell"`` if the record's sea has a swell, else ``"wind sea"``), ``heading``
        (``"weathervaning"`` / ``"fixed heading"``), their crossing ``sea_state_heading``
        and ``wave_period`` (the dominant sea period ``true_period_s`` in the groups of
        :data:`WAVE_PERIOD_EDGES_S`; ``""`` without one).
    """
    out = pd.DataFrame(index=records.index)
    out["speed_group"] = speed_group_label(records["hws_mean_ms"].to_numpy(dtype=float))
    swell = records.get("true_swell_present", pd.Series(0.0, index=records.index))
    vane = records.get("true_weathervane", pd.Series(0.0, index=records.index))
    out["sea_state"] = np.where(swell.to_numpy(dtype=float) > 0.5, "swell", "wind sea")
    out["heading"] = np.where(vane.to_numpy(dtype=float) > 0.5, "weathervaning", "fixed heading")
    out["sea_state_heading"] = out["sea_state"] + " / " + out["heading"]
    period = records.get("true_period_s", pd.Series(np.nan, index=records.index))
    p = period.to_numpy(dtype=float)
    lo, hi = WAVE_PERIOD_EDGES_S
    out["wave_period"] = np.select(
        [p < lo, p <= hi, p > hi], [f"< {lo:g} s", f"{lo:g}-{hi:g} s", f"> {hi:g} s"], ""
    )
    return out


def _scenario_lidar(cfg: Mapping, lidar: str | None) -> str:
    """The scenario's lidar name; ``lidar`` must be it (ValueError otherwise)."""
    simulated = get_lidar((cfg.get("lidar") or {}).get("name", "zephir300")).name
    if lidar is not None and get_lidar(lidar).name != simulated:
        raise ValueError(
            f"scenario_records: lidar {lidar!r}, but the scenario {cfg.get('name', '')!r} "
            f"simulates {simulated!r}: pass lidar={simulated!r} or leave it out"
        )
    return simulated


def _scenario_config(scenario, n_records: int | None, n_workers: int | None) -> dict:
    """The scenario's settings with the record count and worker overrides."""
    cfg = dict(load_scenario(scenario)) if not isinstance(scenario, Mapping) else dict(scenario)
    if n_records is not None:
        cfg["n_records"] = int(n_records)
    if n_workers is not None:
        cfg["n_workers"] = int(n_workers)
    return cfg


def _scenario_campaign(cfg: dict, ss_camp, ss_point, lidar: str, reference_pair: bool):
    """Generate the scenario and take the pipeline's validate and QC steps: the QC-kept
    records in 3-20 m/s, the reference as the pipeline builds it for the virtual campaign
    and the point target's noise (:meth:`Reference.noise`)."""
    sampling = reference_sampling(cfg)
    kind = sampling["reference_kind"]
    synchronized = kind == "fixed_lidar" and reference_pair
    generated = generate_campaign(cfg, ss_camp)
    # each time stamp's shear exponent from all its heights (the pipeline's validate step)
    kept = run_qc(with_shear_exponent(generated.records), QCConfig()).kept
    hws = kept["hws_mean_ms"].to_numpy(dtype=float)
    kept = kept[(hws >= 3.0) & (hws < 20.0)].copy()
    kept["bin_id"] = np.nan
    scan = {
        "heights_in_turn": sampling["heights_in_turn"],
        "refocus_delay_s": sampling["refocus_delay_s"],
        "point_sample_interval_s": sampling["point_sample_interval_s"],
        "turbulence_dt_s": sampling["turbulence_dt_s"],
    }
    # the pipeline's reference: the virtual reference lidar (the floating lidar's twin at
    # the beams of a buoy heading of 0, on its scan schedule), a cup or sonic
    reference = Reference.from_config(
        {"sampling_correlation": SYNCHRONIZED if synchronized else REFERENCE_SAMPLING_CORRELATION},
        lidar=lidar,
        virtual_kind=kind,
    )
    noise = reference.noise(kept, **scan, seed=int(ss_point.generate_state(1)[0]), lidar=lidar)
    return SimpleNamespace(
        kept=kept,
        kind=kind,
        sampling=sampling,
        reference=reference,
        noise=noise,
        # the record fit takes the pair term of a synchronised reference lidar, a cup or a sonic
        pair=synchronized or kind in ("cup", "sonic"),
    )


@single_threaded
def scenario_records(
    scenario: str | Path | Mapping,
    seed: int,
    *,
    lidar: str | None = None,
    settings: SamplerSettings = SamplerSettings(),
    credible_mass: float = 0.9,
    ndraws: int = 400,
    lever_arm_prior: tuple[float, float] | None = None,
    n_records: int | None = None,
    n_workers: int | None = None,
    calibrate_on_sea_state: str | None = None,
    lidar_std_ratio_log_sd: float = LIDAR_STD_RATIO_LOG_SD,
    reference_pair: bool = True,
    hull_model: str = "translating",
    hull_reference: str = "wave_follower",
    motion_model: str = "record",
    return_draws: bool = False,
):
    """Generate a scenario and correct every QC-kept record in 3-20 m/s (the pipeline's steps).

    Parameters
    ----------
    scenario : str, path or mapping
        Scenario name (``flidar_uq/resources/scenarios/<name>.yaml``), path or settings.
    seed : int
        Root seed: campaign, fit, point target and propagation get its spawned children.
    lidar : str, optional
        The lidar the records are corrected for: the scenario's own (its ``lidar.name``)
        when None; another name is refused (sigma_Z would be that of the wrong geometry,
        as the pipeline refuses a ``campaign.lidar`` that is not the scenario's).
    settings : SamplerSettings
    credible_mass : float
        Credible mass of the intervals, in (0, 1).
    ndraws : int
        Posterior draws propagated per record.
    lever_arm_prior : (float, float), optional
        Lever arm mean and sd (m) from the buoy geometry.
    n_records, n_workers : int, optional
        Override the scenario's number of 10-min records and worker processes.
    calibrate_on_sea_state : {"wind sea", "swell"}, optional
        Blocked cross-validation by sea-state class: only the references of this class
        enter the fit (the others are corrected as deployment records).
    lidar_std_ratio_log_sd : float
        Prior sd of log g (-) when the scenario's reference is a fixed lidar (a cup or
        sonic calibrates g: 0).
    reference_pair : bool
        With a fixed reference lidar: the record fit takes the two lidars' sampling scatter
        against each other as known (``fit_record_model(pair_log_sd=...)``). The virtual
        reference lidar scans on the floating lidar's schedule at the azimuths of a buoy
        heading of 0 (campaign generator, step 4), so each record's correlation is
        :func:`~flidar_uq.physics.lidar_response.lidar_pair_correlation` (synchronised) at
        the buoy's mean heading over the record (record column ``heading_mean_deg``, from
        the IMU yaw), as the pipeline does
        (:func:`~flidar_uq.correction.propagation.pair_sampling_correlation`). False: the fit
        without it, and the propagation splits ``kappa`` with ``c = 0``
        (:func:`~flidar_uq.correction.propagation.split_noise`).
    hull_model : {"translating", "auto", "rotation_only"}
        The record model's hull description (config ``inference.hull_model``,
        :func:`~flidar_uq.inference.fit_record_model_selecting_hull`); default the
        translating one alone (one fit).
    hull_reference : str
        The hull whose translation the hull response scales (config
        ``inference.hull_reference``), or ``"auto"`` (the pipeline's default: the wave
        follower or the discus buoy, whichever PSIS-LOO keeps).
    motion_model : {"record", "bin"}
        Config ``inference.motion_model``: the record model, or the bin model
        (:func:`bin_model_fit`: the config's default bins, the per-bin fits and the global
        model PSIS-LOO picks; records outside a converged bin are not corrected). The bin
        model's fit has no pair term: with ``reference_pair`` the propagation takes the
        reference lidar's share out of ``kappa`` with the synchronised correlation above
        (the pipeline's ``reference.sampling_correlation: auto``), else with ``c = 0``.
    return_draws : bool
        Also return the corrected TI draws (float32, (ndraws, n_records), columns in the
        order of ``records``), e.g. for statistics over records.

    The point target follows the scenario's ``reference_instrument`` as the pipeline's
    ``reference.kind`` does, through the pipeline's
    :meth:`flidar_uq.correction.reference.Reference.noise` (each lidar's response at the
    wind's direction against its beams; the record fit on the reference std in the
    floating lidar's response, :meth:`~flidar_uq.correction.reference.ReferenceNoise.floating_reference`).

    Returns
    -------
    records : pandas.DataFrame
        The QC-kept records in 3-20 m/s with the truth columns, the corrected TI
        (``ti_corrected_median``, ``ti_corrected_lo``, ``ti_corrected_hi``; with the
        reference's campaign-wide ``g`` error ``ti_corrected_lo_total``,
        ``ti_corrected_hi_total``), ``ti_true``, the point target's ratio of the floating
        lidar's motionless std to the point wind's (``lidar_std_ratio``, -)
        and the regime labels of :func:`regime_labels`.
    fit : GlobalFit
        The record model's (or the bin model's) global posterior.
    ti_draws : numpy.ndarray
        With ``return_draws`` only.
    """
    if motion_model not in ("record", "bin"):
        raise ValueError(
            f"scenario_records: motion_model={motion_model!r} is not 'record' or 'bin'"
        )
    cfg = _scenario_config(scenario, n_records, n_workers)
    lidar = _scenario_lidar(cfg, lidar)
    ss_camp, ss_fit, ss_point, ss_prop = as_seedsequence(seed).spawn(4)
    camp = _scenario_campaign(cfg, ss_camp, ss_point, lidar, reference_pair)
    kept, kind, noise, pair = camp.kept, camp.kind, camp.noise, camp.pair
    surrogate = get_surrogate(lidar)
    g, sd = noise.lidar_std_ratio, noise.point_log_sd
    pair_log_sd, corr = (noise.pair_log_sd, noise.correlation) if pair else (None, None)
    pair_all = pair_log_sd  # every kept record's (the fit's is the calibration records')
    calib = noise.floating_reference(kept)  # the reference std in the floating lidar's response
    if calibrate_on_sea_state is not None:
        if calibrate_on_sea_state not in ("wind sea", "swell"):
            raise ValueError(
                f"scenario_records: calibrate_on_sea_state={calibrate_on_sea_state!r} is not "
                "'wind sea' or 'swell'"
            )
        in_calib = (regime_labels(kept)["sea_state"] == calibrate_on_sea_state).to_numpy()
        calib = calib[in_calib]
        if pair_log_sd is not None:
            pair_log_sd = pair_log_sd[in_calib]
    bin_fits, correlation = [], REFERENCE_SAMPLING_CORRELATION
    if motion_model == "bin":
        kept["bin_id"], bin_fits, fit = bin_model_fit(calib, kept, surrogate, settings, ss_fit)
        correlation = corr if pair else REFERENCE_SAMPLING_CORRELATION
    else:
        fit = fit_record_model_selecting_hull(
            calib,
            hull_model=hull_model,
            hull=hull_reference,
            surrogate=surrogate,
            lidar=lidar,
            settings=settings,
            seed=ss_fit,
            lever_arm_prior=lever_arm_prior,
            pair_log_sd=pair_log_sd,
        )
    target = PointTarget(
        lidar_std_ratio=g,
        point_log_sd=sd,
        lidar_std_ratio_log_sd=lidar_std_ratio_log_sd if kind == "fixed_lidar" else 0.0,
        reference_sampling_correlation=correlation,
        reference_pair_log_sd=pair_all if motion_model == "bin" else None,
    )
    draws = draw_corrected_ti(
        kept,
        bin_fits,
        fit,
        surrogate=surrogate,
        settings=PropagationSettings(ndraws=ndraws, credible_mass=credible_mass, lidar=lidar),
        target=target,
        seed=ss_prop,
    )
    per_record = record_summary(kept, draws, (np.full(len(kept), np.nan), np.nan))
    out = kept.copy()
    for c in (*CORRECTED_TI_COLUMNS, "ti_uncorrected"):
        out[c] = per_record[c].to_numpy()
    out["ti_true"] = kept["true_ti"].to_numpy(dtype=float)
    out["lidar_std_ratio"] = np.asarray(g, dtype=float)
    out["has_reference"] = np.isfinite(kept["ref_hws_std_ms"].to_numpy(dtype=float))
    out["in_calibration"] = out["has_reference"] & kept.index.isin(calib.index)
    out = pd.concat([out, regime_labels(out)], axis=1)
    return (out, fit, draws.ti) if return_draws else (out, fit)


def bin_model_fit(
    calibration: pd.DataFrame, records: pd.DataFrame, surrogate, settings: SamplerSettings, seed
) -> tuple[np.ndarray, list, object]:
    """The bin motion model on a scenario's records, as the pipeline runs it.

    The records are binned with the config's defaults (:data:`DEFAULT_BINNING`: 1 m/s x 1
    deg x 1 s, at least 30 records a fitted bin;
    :func:`flidar_uq.data.binning.bins_for_fitting`), every fitted bin
    is fitted (:func:`flidar_uq.inference.fit_bin`, seeded by its bin id) and the global
    model PSIS-LOO picks among rho only, lever arm and lever arm with the motion scale
    (:func:`flidar_uq.inference.fit_global`) on the calibration records of converged
    bins.

    Parameters
    ----------
    calibration : pandas.DataFrame
        The records whose reference enters the global fit (a subset of ``records``).
    records : pandas.DataFrame
        Every record to correct (``hws_mean_ms`` and the IMU statistics).
    surrogate : SigmaZSurrogate
        The lidar's surrogate (its ``lidar`` chooses the sigma_Z terms).
    settings : SamplerSettings
    seed : numpy.random.SeedSequence
        Its first child seeds the global fit, its second the bins (child ``bin_id``).

    Returns
    -------
    bin_id : numpy.ndarray, shape (len(records),)
        Each record's bin (NaN: not binned).
    bin_fits : list of BinFit
        The converged bins' fits.
    fit : GlobalFit
    """
    ss_global, ss_bins = seed.spawn(2)
    binned = add_harmonic_motion(records.reset_index(drop=True)).assign(row=np.arange(len(records)))
    assigned, table = bins_for_fitting(binned, **DEFAULT_BINNING, nbatches=1)
    bin_id = np.full(len(records), np.nan)
    bin_id[assigned["row"].to_numpy()] = assigned["bin_id"].to_numpy(dtype=float)
    fitted = assigned[assigned["bin_id"].isin(table.loc[table["fitted"], "bin_id"])]
    fits = [
        fit_bin(
            group,
            settings=settings,
            seed=np.random.SeedSequence(ss_bins.entropy, spawn_key=(*ss_bins.spawn_key, int(b))),
            bin_id=int(b),
        )
        for b, group in fitted.groupby("bin_id")
    ]
    converged = [f for f in fits if f.converged]
    # the calibration records as given (their reference std in the floating lidar's
    # response), with their bins
    calib = calibration.assign(
        bin_id=pd.Series(bin_id, index=records.index).reindex(calibration.index).to_numpy()
    )
    calib = calib[calib["bin_id"].isin([f.bin_id for f in converged])]
    fit = fit_global(
        calib,
        converged,
        surrogate=surrogate,
        settings=settings,
        seed=ss_global,
        scan_period_s=surrogate.lidar.scan_period_s,
    )
    return bin_id, converged, fit


def scenario_calibration(records: pd.DataFrame, *, min_count: int = 1) -> pd.DataFrame:
    """Calibration table per regime of :func:`scenario_records`' output.

    Returns
    -------
    pandas.DataFrame
        One row per group of every grouping in :data:`REGIME_COLUMNS` plus the whole
        campaign (``grouping = "all"``): the columns of
        :func:`~flidar_uq.data.calibration.calibration_by_group` with ``grouping`` and
        ``group``. A grouping that splits the records exactly as an earlier one does is
        left out, so that no group is counted twice: at a fixed heading, ``heading`` (one
        group, all the records) and ``sea_state_heading`` (the ``sea_state`` groups).
    """
    rec = records.assign(all="all")
    tables, partitions = [], set()
    for by in ("all", *REGIME_COLUMNS):
        keep = (rec[by] != "").to_numpy()
        codes, _ = pd.factorize(rec.loc[keep, by])  # labelled in order of first appearance
        partition = (np.flatnonzero(keep).tobytes(), codes.tobytes())
        if partition in partitions:
            continue
        partitions.add(partition)
        t = calibration_by_group(rec[keep], by, min_count=min_count)
        tables.append(t.rename(columns={by: "group"}).assign(grouping=by))
    out = pd.concat(tables, ignore_index=True)
    return out[["grouping", "group", *[c for c in out.columns if c not in ("grouping", "group")]]]
