"""The correction of a whole campaign in memory: corrected TI per record, speed bin and group,
the uncertainty budget, the record flags and the MD / RMSE / coverage scores
(:func:`correct_campaign`), and the files the pipeline writes of them
(:meth:`CorrectionResult.to_files`, results/ti/)."""

from __future__ import annotations

import logging
import os
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pandas as pd

from flidar_uq.correction import propagation as prop
from flidar_uq.correction.reference import Reference
from flidar_uq.correction.regime_discrepancy import (
    MIN_REGIMES,
    RegimeDiscrepancy,
    fit_regime_discrepancy,
    prior_discrepancy,
    regime_keys,
)
from flidar_uq.data.binning import bin_centre, speed_bin_ms
from flidar_uq.data.io import write_csv
from flidar_uq.data.schema import CORRECTED_TI_COLUMNS
from flidar_uq.inference.record_motion import describe_motion
from flidar_uq.seeding import child_seed
from flidar_uq.threads import single_threaded

log = logging.getLogger(__name__)

__all__ = [
    "CARRIED_RECORD_COLUMNS",
    "RECORD_COLUMNS",
    "BinTables",
    "CorrectionResult",
    "CorrectionSettings",
    "carried_columns",
    "correct_campaign",
    "pipeline_results",
    "record_groups",
]


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
    "heave_response_ratio",
    "horizontal_response_ratio",
    "gnss_speed_mean_ms",
    "wave_hs_m",
    "wave_tp_s",
    "wave_tm02_s",
    "wave_dir_deg",
    "wave_spread_deg",
)

#: The files of :meth:`CorrectionResult.to_files`: table attribute -> file name.
RESULT_FILES = {
    "records": "records.csv",
    "speed_bins": "speed_bins.csv",
    "metrics": "metrics.csv",
    "groups": "groups.csv",
    "budget": "uncertainty_budget.csv",
}


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


@dataclass(frozen=True)
class CorrectionSettings:
    """The propagation options (config ``propagation``, ``report.sector_width_deg``,
    ``report.group_min_count``, ``inference.seed``, ``campaign.lidar``).

    Attributes
    ----------
    ndraws : int
        Posterior draws per record (-).
    seed : int
        Config ``inference.seed`` (the propagation, the reference noise).
    credible_mass : float
        Probability mass of the equal-tailed credible intervals (-).
    lidar : str or mapping
        The floating lidar (config ``campaign.lidar``: a geometry name or a custom block;
        its sigma_Z surrogate, beam timing and scan period).
    budget_ndraws : int
        Draws per record of each uncertainty-budget pass (-; at most ``ndraws``).
    point_sample_interval_s : float
        Sampling interval of the point reference HWS (s).
    scan_heights_in_turn : int or None
        Heights the reference lidar scans in turn (-); None: the number of distinct
        heights in the records.
    scan_refocus_delay_s : tuple of float
        [lo, hi] of the uniform delay between consecutive scans (s).
    turbulence_dt_s : float or None
        Sampling interval of a synthetic turbulence series (s); None: the atmosphere's
        continuous spectrum.
    sector_width_deg : float
        Width of the wind-direction sectors of the group table (deg).
    min_count : int
        Fewest records for the statistics of a speed bin or group (-).
    """

    ndraws: int = 1000
    seed: int = 0
    credible_mass: float = 0.9
    lidar: str = "zephir300"
    budget_ndraws: int = 200
    point_sample_interval_s: float = 1.0
    scan_heights_in_turn: int | None = None
    scan_refocus_delay_s: tuple[float, float] = (0.3, 0.7)
    turbulence_dt_s: float | None = None
    sector_width_deg: float = 30.0
    min_count: int = 10

    @classmethod
    def from_config(cls, config: Mapping) -> CorrectionSettings:
        """The settings of a whole config (``propagation``, ``report``, ``inference``,
        ``campaign`` sections; missing keys keep their defaults). The ``propagation``
        section's "auto" scan keys must be resolved first
        (:func:`flidar_uq.workflow.inputs.correction_inputs` does it for a virtual
        campaign, from its scenario); a remaining "auto" is read as its data-driven default
        (heights counted in the records, refocus delays (0.3, 0.7) s, the continuous
        spectrum)."""
        p = dict(config.get("propagation") or {})
        defaults = cls()
        auto = {
            "scan_heights_in_turn": None,
            "scan_refocus_delay_s": defaults.scan_refocus_delay_s,
            "turbulence_dt_s": None,
        }
        for key, value in auto.items():
            if p.get(key) == "auto":
                p[key] = value
        report = config.get("report") or {}
        kw = {k: p[k] for k in cls.__dataclass_fields__ if k in p}
        if "scan_refocus_delay_s" in kw:
            kw["scan_refocus_delay_s"] = tuple(float(x) for x in kw["scan_refocus_delay_s"])
        if "sector_width_deg" in report:
            kw["sector_width_deg"] = report["sector_width_deg"]
        if "group_min_count" in report:
            kw["min_count"] = report["group_min_count"]
        if "seed" in (config.get("inference") or {}):
            kw["seed"] = config["inference"]["seed"]
        if "lidar" in (config.get("campaign") or {}):
            kw["lidar"] = config["campaign"]["lidar"]
        return cls(**kw)

    def propagation(self, ndraws: int | None = None) -> prop.PropagationSettings:
        """The options of :func:`flidar_uq.correction.propagation.draw_corrected_ti`:
        :attr:`ndraws` (or ``ndraws``, e.g. the uncertainty budget's), :attr:`credible_mass`
        and :attr:`lidar` (its scan period), 1-m/s speed bins."""
        return prop.PropagationSettings(
            ndraws=self.ndraws if ndraws is None else int(ndraws),
            credible_mass=self.credible_mass,
            lidar=self.lidar,
        )

    def heights_in_turn(self, records: pd.DataFrame) -> int:
        """Heights scanned in turn (-): :attr:`scan_heights_in_turn`, else the number of
        distinct ``height_m`` of ``records``."""
        return self.scan_heights_in_turn or int(records["height_m"].nunique())

    def reference_noise(self, records: pd.DataFrame, reference: Reference, *, heights: int):
        """:meth:`Reference.noise` with these scan settings (``heights`` heights in turn)
        and this floating lidar."""
        return reference.noise(
            records,
            heights_in_turn=heights,
            refocus_delay_s=self.scan_refocus_delay_s,
            point_sample_interval_s=self.point_sample_interval_s,
            turbulence_dt_s=self.turbulence_dt_s,
            seed=self.seed,
            lidar=self.lidar,
        )


@dataclass(frozen=True)
class BinTables:
    """The binning of a campaign and, for the bin motion model, its per-bin fits.

    Attributes
    ----------
    assignments : pandas.DataFrame
        ``record_id`` and ``bin_id`` of every binned record (results/bins/assignments.parquet).
    table : pandas.DataFrame
        ``bin_id`` and ``fitted`` per bin (results/bins/table.csv).
    sigma_z : pandas.DataFrame
        ``bin_id`` and ``sigma_z_ms`` (m/s) at each bin centre (results/bins/sigma_z.csv).
    status : pandas.DataFrame or None
        ``bin_id`` and ``status`` of each bin fit (results/inference/bin_fits.csv); needed
        by the bin motion model.
    fits : dict
        Bin id -> :class:`flidar_uq.inference.BinFit` of every bin whose fit ran.
    """

    assignments: pd.DataFrame
    table: pd.DataFrame
    sigma_z: pd.DataFrame
    status: pd.DataFrame | None = None
    fits: Mapping = field(default_factory=dict)


@dataclass(frozen=True)
class CorrectionResult:
    """The corrected campaign (:func:`correct_campaign`).

    Attributes
    ----------
    records : pandas.DataFrame
        One row per input record: :data:`RECORD_COLUMNS`, then the corrected std (m/s),
        the U / C / PC baselines, sigma_Z (m/s), the reference's std ratio and scatter,
        the truth and reference where known and the carried input columns.
    speed_bins : pandas.DataFrame
        Per height and 1-m/s speed bin: the corrected-TI statistics with credible
        intervals (:func:`flidar_uq.correction.propagation.ti_group_statistics`).
    groups : pandas.DataFrame
        The same per height for the campaign, each direction sector and sea-state class.
    budget : pandas.DataFrame
        :func:`flidar_uq.correction.uncertainty_budget.uncertainty_budget` of the
        campaign mean and each speed bin's mean.
    metrics : pandas.DataFrame
        MD and RMSE (Gutiérrez-Antuñano et al., 2018, Eqs. 18-19) of std (m/s) and TI of
        the uncorrected, U, C, PC and Bayesian estimates, coverage when the truth is known.
    """

    records: pd.DataFrame
    speed_bins: pd.DataFrame
    groups: pd.DataFrame
    budget: pd.DataFrame
    metrics: pd.DataFrame

    def to_files(self, directory: str | os.PathLike, *, overwrite: bool = False) -> dict[str, Path]:
        """Write the tables as the pipeline's propagation does (results/ti/): records.csv,
        speed_bins.csv, metrics.csv, groups.csv and uncertainty_budget.csv in
        ``directory`` (created); returns the paths by table name.

        Raises
        ------
        ValueError
            When ``directory`` lies in the ``results/`` of a pipeline run (a ``results``
            folder beside Snakemake's ``.snakemake``), unless ``overwrite``: the pipeline's
            files would no longer be what its inputs give.
        """
        owner = pipeline_results(directory)
        if owner is not None and not overwrite:
            raise ValueError(
                f"CorrectionResult.to_files: {directory} lies in {owner}, the results of a "
                "pipeline run; write to another folder, or pass overwrite=True to replace "
                "the pipeline's files"
            )
        paths = {name: Path(directory) / file for name, file in RESULT_FILES.items()}
        for name, path in paths.items():
            write_csv(getattr(self, name), path)
        return paths


def pipeline_results(directory: str | os.PathLike) -> Path | None:
    """The ``results`` folder of a pipeline run that holds ``directory`` (itself or one of
    its parents, beside the ``.snakemake`` folder Snakemake keeps in its working
    directory); None when ``directory`` belongs to no pipeline run."""
    path = Path(directory).resolve()
    for folder in (path, *path.parents):
        if folder.name == "results" and (folder.parent / ".snakemake").is_dir():
            return folder
    return None


@single_threaded
def correct_campaign(
    records: pd.DataFrame,
    fit,
    reference: Reference,
    settings: CorrectionSettings,
    *,
    flags: pd.DataFrame | None = None,
    bins: BinTables | None = None,
) -> CorrectionResult:
    """Corrected std and TI per record, speed bin and group, beside the baselines.

    Calls :func:`flidar_uq.correction.propagation.draw_corrected_ti` (and
    :func:`~flidar_uq.correction.propagation.record_summary`) on the QC-kept records
    (record motion model) or the kept, binned records with the converged bin fits (bin
    motion model): posterior draws through the deployment formula; median and
    equal-tailed ``settings.credible_mass`` interval; and Gutiérrez-Antuñano et al.'s
    (2018) U / C / PC laws.

    The corrected std is always the point (cup-like) std. The deployment formula gives the
    std a motionless lidar of the floating lidar's type would measure, which is divided by
    its std ratio to the point wind (:func:`flidar_uq.physics.lidar_response.lidar_std_ratio`,
    at the record's HWS, height and wind direction against the beams, band-limited at
    ``1 / (2 turbulence_dt_s)`` for a synthetic series) with its record-to-record scatter
    (:func:`flidar_uq.physics.lidar_response.lidar_point_log_sd`); the reference instrument
    (:meth:`flidar_uq.correction.reference.Reference.noise`) decides the ratio's
    campaign-wide error: none for a cup or sonic (the fit calibrates it), the prior sd
    ``reference.lidar_std_ratio_log_sd`` for a fixed lidar or none.

    The speed-bin table is per height and 1-m/s speed bin
    (:func:`flidar_uq.correction.propagation.ti_group_statistics`; groups with fewer
    than ``settings.min_count`` records keep their count only); the group table the same
    per height for the campaign, per direction sector and per sea-state class
    (:func:`record_groups`). The uncertainty budget
    (:func:`flidar_uq.correction.uncertainty_budget.uncertainty_budget`) comes from its
    own ``1 + len(UNCERTAINTY_SOURCES)`` passes at ``min(budget_ndraws, ndraws)`` draws
    per record (common random numbers; with ``budget_ndraws >= ndraws`` the main pass's
    draws are reused). The scores: MD and RMSE (Gutiérrez-Antuñano et al., 2018,
    Eqs. 18-19) against the truth (``true_*``, virtual campaigns) or else the reference
    instrument, over the records with a Bayesian value.

    Parameters
    ----------
    records : pandas.DataFrame
        Every input record, in order (the validated record table: ``hws_mean_ms`` (m/s),
        ``hws_std_ms`` (m/s), ``height_m`` (m), the motion statistics, ``timestamp``).
    fit : flidar_uq.inference.GlobalFit
        The global posterior (record or bin motion model).
    reference : Reference
        The reference instrument (:meth:`Reference.from_config`).
    settings : CorrectionSettings
        The propagation options.
    flags : pandas.DataFrame, optional
        The QC flags, one row per record (:attr:`flidar_uq.data.qc.QCResult.flags`:
        ``timestamp`` and ``reasons``, "" when kept). None: every record kept.
    bins : BinTables, optional
        The binning (and, for the bin motion model, the bin fits). None: no record is
        binned (the record motion model needs no bins; required for the bin motion model).

    Returns
    -------
    CorrectionResult
    """
    from flidar_uq.physics.surrogate import get_surrogate

    c = _CorrectedSubset.of(records, fit, flags, bins)
    sub = c.rec[c.use] if c.record_model else c.rec[c.use].astype({"bin_id": int})
    surrogate = get_surrogate(settings.lidar)
    target = _point_target(sub, c.rec, reference, settings)
    baseline = prop.variance_law_baselines(sub, surrogate)
    converged_fits = [f for f in c.fits.values() if f.converged]
    grams: dict = {}  # the record model's Gram matrices, computed once for every pass

    def correct(hold=(), ndraws=settings.ndraws):
        return prop.draw_held_ti(
            sub,
            converged_fits,
            fit,
            hold,
            surrogate=surrogate,
            settings=settings.propagation(ndraws),
            target=target,
            seed=child_seed(settings.seed, 2),
            record_grams=grams,
        )

    main = correct()
    per_record = prop.record_summary(sub, main, baseline)
    discrepancy = _regime_discrepancy(sub, per_record, target, reference)
    rng = np.random.default_rng(child_seed(settings.seed, 6))
    shift = discrepancy.draws(regime_keys(sub), settings.ndraws, rng)
    speed_keys, speed_bins, groups = _group_tables(main.ti, per_record, sub, settings, shift)
    # its own passes at budget_ndraws (common random numbers: the same seed and draws
    # for every hold), the main pass's draws when it has no more
    nb = min(int(settings.budget_ndraws), int(settings.ndraws))
    if nb == settings.ndraws:
        free = main.ti
    else:  # the main pass's draws are done with: freed before the budget's passes
        del main
        free = correct((), nb).ti
    budget = _budget(correct, free, nb, per_record, speed_keys, settings, shift)
    speed_bins = _with_dominant_source(speed_bins, budget)
    out = _output_records(c, fit, per_record, baseline[0], settings)
    return CorrectionResult(
        records=out,
        speed_bins=speed_bins,
        groups=groups,
        budget=budget,
        metrics=_scores(out, c.rec, reference, baseline[1], settings.credible_mass),
    )


@dataclass
class _CorrectedSubset:
    """The records of :func:`correct_campaign` and which of them are corrected: every
    QC-kept record (record motion model) or the binned ones (bin motion model)."""

    rec: pd.DataFrame
    timestamp: pd.Series
    reasons: pd.Series
    use: np.ndarray
    binned: np.ndarray
    record_model: bool
    fitted: pd.Series
    sz_table: pd.DataFrame
    fits: dict
    bins: BinTables | None

    @classmethod
    def of(cls, records, fit, flags, bins) -> _CorrectedSubset:
        from flidar_uq import inference as inf

        rec = records.reset_index(drop=True)  # a new frame (copy on write)
        n = len(rec)
        if flags is None:
            reasons = pd.Series([""] * n)
            timestamp = rec["timestamp"] if "timestamp" in rec else pd.Series(np.arange(n))
        else:
            # object first: a flags file without any reason reads as an all-NaN float column
            reasons = flags["reasons"].astype(object).fillna("").reset_index(drop=True)
            timestamp = flags["timestamp"].reset_index(drop=True)
        record_model = inf.is_record_model(fit)
        if not record_model and (bins is None or bins.status is None):
            raise ValueError(
                "correct_campaign: a bin motion model needs the bins and their fits "
                "(bins=BinTables(..., status=, fits=))"
            )
        if bins is None:
            rec["bin_id"] = np.nan
            fitted = pd.Series(dtype=bool)
            sz_table = pd.DataFrame({"sigma_z_ms": pd.Series(dtype=float)})
        else:
            assigned = bins.assignments.set_index("record_id")["bin_id"]
            rec["bin_id"] = assigned.reindex(np.arange(n)).to_numpy()
            fitted = bins.table.set_index("bin_id")["fitted"]
            sz_table = bins.sigma_z.set_index("bin_id")
        fits = {} if record_model or bins is None else dict(bins.fits)
        binned = rec["bin_id"].notna().to_numpy()
        # record model: every QC-kept record, binned or not (its sigma_Z is its own)
        use = reasons.eq("").to_numpy() if record_model else binned
        return cls(rec, timestamp, reasons, use, binned, record_model, fitted, sz_table, fits, bins)


def _point_target(sub, rec, reference: Reference, settings: CorrectionSettings):
    """The point target of the corrected records (:class:`~flidar_uq.correction.
    propagation.PointTarget`): the reference lidar's std ratio, its scatter and sampling
    correlation (:meth:`CorrectionSettings.reference_noise`), logged."""
    heights = settings.heights_in_turn(rec)
    noise = settings.reference_noise(sub, reference, heights=heights)
    g_ratio, log_sd, pair_corr = noise.lidar_std_ratio, noise.point_log_sd, noise.correlation
    # a point reference calibrates g itself: an error of g is taken up by the record fit's
    # motion terms and divided out again, so it is no campaign-wide error of the point TI
    point_reference = reference.kind in ("cup", "sonic")
    g_log_sd = 0.0 if point_reference else reference.ratio_log_sd(sub, lidar=settings.lidar)
    log.info(
        "point target: lidar std ratio %.4f-%.4f, log-sd %.4f-%.4f (%d heights in turn)%s",
        np.nanmin(g_ratio), np.nanmax(g_ratio), np.nanmin(log_sd), np.nanmax(log_sd), heights,
        f"; calibrated by the {reference.kind}" if point_reference
        else f"; prior sd of log g {np.min(g_log_sd):.3f}-{np.max(g_log_sd):.3f}",
    )  # fmt: skip
    if pair_corr is not None:
        log.info(
            "reference lidar sampling: correlation with the floating lidar's %s, c = %.3f-%.3f",
            reference.sampling_correlation, np.nanmin(pair_corr), np.nanmax(pair_corr),
        )  # fmt: skip
    return prop.PointTarget(g_ratio, log_sd, g_log_sd, pair_corr, noise.pair_log_sd)


def _regime_discrepancy(sub, per_record, target, reference: Reference) -> RegimeDiscrepancy:
    """The regime discrepancy of the corrected records against the reference's point TI
    (a fixed lidar's divided by the lidar's std ratio ``g``), by whole UTC days; without a
    reference, or with too few regimes covered, the prior
    (:func:`~flidar_uq.correction.regime_discrepancy.prior_discrepancy` at
    ``reference.regime_discrepancy_prior_sd``)."""
    if reference.kind == "none":
        return prior_discrepancy(reference.regime_discrepancy_prior_sd, "no reference")
    ti_ref = np.full(len(sub), np.nan)
    if "ref_hws_std_ms" in sub and "ref_hws_mean_ms" in sub:
        with np.errstate(invalid="ignore", divide="ignore"):
            ti_ref = sub["ref_hws_std_ms"].to_numpy(float) / sub["ref_hws_mean_ms"].to_numpy(float)
            if reference.kind == "fixed_lidar" and target.lidar_std_ratio is not None:
                ti_ref = ti_ref / np.asarray(target.lidar_std_ratio, dtype=float)
    day = pd.to_datetime(sub["timestamp"], utc=True).dt.floor("D").to_numpy()
    corrected = per_record["ti_corrected_median"].to_numpy(float)
    learnt = fit_regime_discrepancy(corrected, ti_ref, regime_keys(sub), day)
    if len(learnt.regimes) < MIN_REGIMES:
        return prior_discrepancy(reference.regime_discrepancy_prior_sd, learnt.reason)
    return learnt


def _group_tables(ti_draws, per_record, sub, settings: CorrectionSettings, shift=None):
    """Speed-bin keys, the speed-bin table (height x 1-m/s bin) and the group table
    (campaign, direction sector, sea state) of the corrected records; ``shift`` the regime
    discrepancy's draws (:meth:`RegimeDiscrepancy.draws`) or None."""
    credible_mass, min_count = settings.credible_mass, settings.min_count
    sub_heights = sub["height_m"].to_numpy(dtype=float)
    speed_keys = pd.DataFrame(
        {
            "height_m": sub_heights,
            "hws_bin_ms": speed_bin_ms(sub["hws_mean_ms"].to_numpy(dtype=float)),
        }
    )
    speed_bins = prop.ti_group_statistics(
        ti_draws,
        per_record,
        speed_keys,
        credible_mass=credible_mass,
        min_count=min_count,
        seed=child_seed(settings.seed, 5, 0),
        shift=shift,
    )
    labels = record_groups(sub, sector_width_deg=settings.sector_width_deg)
    tables = []
    for k, (grouping, col) in enumerate(
        (("campaign", None), ("direction sector", "sector_deg"), ("sea state", "sea_state")),
        start=1,
    ):
        group = np.full(len(sub), "all", dtype=object) if col is None else labels[col]
        keys = pd.DataFrame({"height_m": sub_heights, "group": np.asarray(group, dtype=object)})
        t = prop.ti_group_statistics(
            ti_draws,
            per_record,
            keys,
            credible_mass=credible_mass,
            min_count=min_count,
            seed=child_seed(settings.seed, 5, k),
            shift=shift,
        )
        t.insert(0, "grouping", grouping)
        tables.append(t)
    return speed_keys, speed_bins, pd.concat(tables, ignore_index=True)


#: What a bin's interval comes from, in words, by budget source (shares of one label add).
DOMINANT_SOURCE_WORDS = {
    "motion": "the motion description",
    "rho": "the correlation rho",
    "noise_model": "the records' noise",
    "sampling": "the records' noise",
    "reference_response": "the lidar's response g",
    "regime_discrepancy": "the regime discrepancy",
}
#: Fewest records of a bin below which its interval is said to come from too few records.
FEW_RECORDS = 30


def _with_dominant_source(speed_bins: pd.DataFrame, budget: pd.DataFrame) -> pd.DataFrame:
    """``speed_bins`` with ``interval_from``: in words, what the bin mean's interval comes
    from (the largest of the budget's variance shares, :data:`DOMINANT_SOURCE_WORDS`),
    "fit not converged" where the bin's statistics come from records whose fit did not
    converge, "motion reaches the measured std" where every record's draws are 0, or "too
    few records" below :data:`FEW_RECORDS`; "" where the budget has no row."""
    sb = budget[budget["grouping"] == "speed bin"]
    words = {}
    for _, row in sb.iterrows():
        shares: dict[str, float] = {}
        for source, label in DOMINANT_SOURCE_WORDS.items():
            if f"share_{source}" in row and np.isfinite(row[f"share_{source}"]):
                shares[label] = shares.get(label, 0.0) + float(row[f"share_{source}"])
        if shares:
            words[(row["height_m"], row["hws_bin_ms"])] = max(shares, key=shares.get)
    keys = zip(speed_bins["height_m"], speed_bins["hws_bin_ms"], strict=True)
    label = [words.get(k, "") for k in keys]
    n = speed_bins["n"].to_numpy()
    label = np.where(n < FEW_RECORDS, "too few records", label)
    all_zero = (n > 0) & (speed_bins["n_zero_draws"].to_numpy() == n)
    label = np.where(all_zero, "motion reaches the measured std", label)
    unconverged = ~speed_bins["converged"].to_numpy(dtype=bool)
    return speed_bins.assign(interval_from=np.where(unconverged, "fit not converged", label))


def _budget(correct, free, nb, per_record, speed_keys, settings: CorrectionSettings, shift):
    """The uncertainty budget per campaign and speed bin from the passes at ``nb`` draws
    (``free``: the pass that holds nothing; ``correct(hold, nb)``: one that holds), with
    the regime discrepancy's first ``nb`` draws ``shift`` (None: none) as a source of its
    own, held at its posterior mean."""
    from flidar_uq.correction.uncertainty_budget import BUDGET_SOURCES, uncertainty_budget

    def draws_for(hold):
        base = tuple(h for h in hold if h != "regime_discrepancy")
        d = free if not base else correct(base, nb).ti
        if shift is None:
            return d
        at, delta = shift[0], shift[1][:nb]
        if "regime_discrepancy" in hold:
            delta = delta.mean(axis=0, keepdims=True)
        return (d * np.exp(-delta[:, at])).astype(np.float32)

    usable = per_record["converged"].to_numpy(dtype=bool) & prop.finite_records(free)
    return uncertainty_budget(
        draws_for,
        {"campaign": speed_keys[["height_m"]], "speed bin": speed_keys},
        usable,
        sources=BUDGET_SOURCES,
        credible_mass=settings.credible_mass,
        min_count=settings.min_count,
    )


def _output_records(c: _CorrectedSubset, fit, per_record, sz_seed, settings) -> pd.DataFrame:
    """One row per input record: the corrected values, flags, references, truth and the
    carried columns (:data:`RECORD_COLUMNS` first)."""
    rec, use = c.rec, c.use
    out = _records_table(
        rec, np.arange(len(rec)), c.timestamp, use, per_record, sz_seed, c.sz_table
    )
    if c.record_model:  # which motion description gave each record's sigma_Z
        desc = describe_motion(rec, hull_model=fit.info.get("hull_model"), lidar=settings.lidar)
        for col in desc:
            out[col] = np.where(use, desc[col].to_numpy(), "")
    neg = _scatter(per_record["discriminant_negative"].to_numpy(dtype=bool), use, bool, False)
    described = (
        _scatter(np.isfinite(per_record["sigma_z_median_ms"].to_numpy()), use, bool, False)
        if c.record_model
        else None
    )
    out["flags"] = prop.record_flags(
        c.reasons,
        out["bin_id"].to_numpy(),
        c.binned,
        neg,
        fitted=c.fitted,
        status=pd.Series(dtype=object)
        if c.record_model
        else c.bins.status.set_index("bin_id")["status"],
        global_converged=fit.converged,
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
    for col in ("true_swell_present", "true_weathervane", "true_period_s"):  # regime truth
        if col in rec:
            out[col] = rec[col].to_numpy(dtype=float)
    for col in carried_columns(rec.columns):  # buoy-logger and extra columns, unchanged
        if col not in out.columns:
            out[col] = rec[col].to_numpy()
    return out[RECORD_COLUMNS + [c for c in out.columns if c not in RECORD_COLUMNS]]


def _scores(out, rec, reference: Reference, rho_seed, credible_mass) -> pd.DataFrame:
    """MD / RMSE of std and TI (Gutiérrez-Antuñano et al., 2018, Tables 2-3 style) against
    the truth (virtual campaigns) and against the reference instrument, where present,
    over the same records."""
    from flidar_uq.data import metrics

    scores = metrics.score_estimates(out, metrics.reference_values(rec, kind=reference.kind))
    scores["rho_bin_correlation"] = rho_seed
    scores["credible_mass"] = credible_mass
    scores["reference_kind"] = reference.kind
    scores["reference_height_m"] = reference.height_label()
    scores["reference_separation_m"] = float(reference.separation_m)
    return scores


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
    """``values`` of the used records spread to every record (``fill`` elsewhere)."""
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
    corrected values of :func:`~flidar_uq.correction.propagation.record_summary` where ``use``."""
    m = rec["hws_mean_ms"].to_numpy(dtype=float)
    s = rec["hws_std_ms"].to_numpy(dtype=float)
    out = pd.DataFrame({"record_id": rid, "timestamp": timestamp, "height_m": rec["height_m"]})
    out["bin_id"] = rec["bin_id"].to_numpy()
    out["hws_mean_ms"] = m
    out["hws_std_ms"] = s
    with np.errstate(invalid="ignore", divide="ignore"):
        out["ti_uncorrected"] = s / m
    for col in CORRECTED_TI_COLUMNS:
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
