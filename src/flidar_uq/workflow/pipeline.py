"""Glue between the Snakemake rules and the library: read inputs, call the library, write outputs.

Each public function here is what one workflow script (``workflow/scripts/*.py``) calls;
the scripts only unpack ``snakemake.input/output/params``. No Snakemake import lives here,
so every step is testable as plain Python.

Files written (the pipeline's output contract, see README):

* ``results/ti/records.csv``: one row per input record: ``timestamp, height_m, bin_id,
  hws_mean_ms, ti_uncorrected, ti_corrected_median, ti_corrected_lo, ti_corrected_hi,
  flags`` (+ ``ti_true`` when the input carries truth, + the seed 000 U/C/PC baselines).
* ``results/ti/bins.csv``: one row per bin (``bin_id`` = case no. of seed 000 Table 1)
  with the bin table, sigma_Z at the bin centre, fit status and diagnostics, and bin means
  of the uncorrected and corrected TI.
* ``results/ti/speed_bins.csv``: mean and representative TI per speed bin with intervals.
* ``results/ti/metrics.csv``: MD / RMSE of uncorrected, U, C, PC and Bayesian estimates.
* ``results/posterior/bin_<id>.nc`` (one per fitted bin) and ``results/posterior/global.nc``
  (ArviZ DataTree, NetCDF).

Reproducibility: every seed is a ``numpy.random.SeedSequence`` derived from the config
seeds and the bin id (not the batch layout); NetCDF files are written without wall-clock
attributes; CSVs with a fixed float format. A clean rerun is byte-identical.
"""

from __future__ import annotations

import logging
import os
from collections.abc import Sequence
from pathlib import Path

import numpy as np
import pandas as pd

log = logging.getLogger(__name__)

__all__ = [
    "assign_batches",
    "bin_seed",
    "build_report",
    "fit_global",
    "git_revision",
    "infer_batch",
    "make_bins",
    "make_campaign",
    "motion_statistics",
    "propagate",
    "run_qc",
    "setup_logging",
    "sigma_z_table",
    "validate_records",
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


def setup_logging(log_path: str | os.PathLike) -> None:
    """Send INFO and above of every logger (and warnings) to ``log_path``, a rule's log file."""
    logging.basicConfig(
        filename=str(log_path),
        filemode="w",
        level=logging.INFO,
        format="%(levelname)s %(name)s: %(message)s",
        force=True,
    )
    logging.captureWarnings(True)


def _write_csv(df: pd.DataFrame, path: str | os.PathLike) -> None:
    """Write a result table deterministically (fixed float format, no index)."""
    Path(path).parent.mkdir(parents=True, exist_ok=True)
    df.to_csv(
        path,
        index=False,
        float_format="%.10g",
        lineterminator="\n",
        date_format="%Y-%m-%dT%H:%M:%SZ",
    )


def _read_csv(path: str | os.PathLike) -> pd.DataFrame:
    return pd.read_csv(path, keep_default_na=True)


# --------------------------------------------------------------------------- campaign


def make_campaign(
    out_path: str | os.PathLike,
    *,
    source: str,
    seed: int = 0,
    scenario_path: str | os.PathLike | None = None,
    records_path: str | os.PathLike | None = None,
    threads: int = 1,
) -> pd.DataFrame:
    """Write the campaign's 10-min record table: the virtual campaign or the user's file.

    Parameters
    ----------
    out_path : path
        Output CSV (record format of docs/data-format.md).
    source : {"virtual", "files"}
        Generate the physics-mode virtual campaign, or read the user's table.
    seed : int
        SeedSequence entropy of the virtual campaign (-).
    scenario_path : path, optional
        Scenario YAML (config/scenarios/<name>.yaml), required for ``source="virtual"``.
    records_path : path, optional
        The user's record table (CSV or Parquet), required for ``source="files"``.
    threads : int
        Worker processes of the virtual-campaign generator (results do not depend on it).

    Returns
    -------
    pandas.DataFrame
        The records written.

    Raises
    ------
    ValueError
        On an unknown ``source`` or a missing path.
    """
    from flidar_uq.data import io

    if source == "virtual":
        if not scenario_path:
            raise ValueError("make_campaign: source='virtual' needs scenario_path")
        from flidar_uq.campaign import physics_mode as campaign
        from flidar_uq.campaign.scenarios import load_scenario

        scenario = load_scenario(scenario_path)
        records = campaign.generate_campaign(scenario, seed, n_workers=max(1, int(threads))).records
    elif source == "files":
        if not records_path:
            raise ValueError(
                "make_campaign: source='files' needs records_path (config campaign.records)"
            )
        records = io.read_records(records_path)
    else:
        raise ValueError(f"make_campaign: source must be 'virtual' or 'files', got {source!r}")
    Path(out_path).parent.mkdir(parents=True, exist_ok=True)
    io.write_records(records, out_path)
    log.info("campaign: %d records (%s) -> %s", len(records), source, out_path)
    return records


def validate_records(in_path: str | os.PathLike, out_path: str | os.PathLike) -> pd.DataFrame:
    """Validate a record table (io.read_records raises naming file, row and column) and copy it."""
    from flidar_uq.data import io

    records = io.read_records(in_path)
    Path(out_path).parent.mkdir(parents=True, exist_ok=True)
    io.write_records(records, out_path)
    log.info("validate: %d records valid", len(records))
    return records


# --------------------------------------------------------------------------- QC, motion, bins


def run_qc(
    in_path: str | os.PathLike,
    flags_path: str | os.PathLike,
    kept_path: str | os.PathLike,
    summary_path: str | os.PathLike,
    qc_params: dict,
) -> pd.DataFrame:
    """Apply the QC filters; write every record with its reasons, the kept records, and counts.

    Parameters
    ----------
    in_path : path
        Validated record table.
    flags_path, kept_path, summary_path : path
        Outputs: the flags table (one row per input record: ``record_id``, ``reasons``,
        ``kept``, one ``fail_<reason>`` column per filter), the kept records (with
        ``record_id``), and the per-filter counts.
    qc_params : dict
        The ``qc`` section of the config: :class:`flidar_uq.data.qc.QCConfig` fields.

    Returns
    -------
    pandas.DataFrame
        The flags table.
    """
    from flidar_uq.data import io, qc

    records = io.read_records(in_path)
    result = qc.run_qc(records, qc.QCConfig(**qc_params))
    flags = result.flags.copy()
    flags.insert(0, "record_id", np.arange(len(flags)))
    kept = result.kept.copy()
    kept.insert(0, "record_id", kept.index.to_numpy())
    counts = result.counts.reset_index().rename(columns={"index": "reason"})
    _write_csv(flags, flags_path)
    _write_csv(kept, kept_path)
    _write_csv(counts, summary_path)
    log.info("%s", result.summary())
    return flags


def motion_statistics(
    in_path: str | os.PathLike, out_path: str | os.PathLike, roll_pitch_path: str | os.PathLike
) -> pd.DataFrame:
    """Per-record motion amplitude and period, and the roll-pitch correlation (seed 000 Sec. 2.4).

    Adds ``amplitude_deg`` and ``period_s`` (the roll/pitch averages, seed 000 Sec. 2.4) to
    each kept record; writes the roll-pitch correlation of amplitude and period.
    """
    from flidar_uq.data import imu

    records = _read_csv(in_path)
    out = imu.record_motion(records)
    corr = imu.roll_pitch_correlation(records)
    _write_csv(out, out_path)
    _write_csv(pd.DataFrame([corr]), roll_pitch_path)
    return out


def assign_batches(counts: Sequence[int], nbatches: int) -> np.ndarray:
    """Spread bins over ``nbatches`` batch jobs, balancing record counts (greedy, deterministic).

    Parameters
    ----------
    counts : sequence of int, shape (n_bins,)
        Records per bin (the cost proxy of a fit).
    nbatches : int
        Number of batch jobs (>= 1).

    Returns
    -------
    numpy.ndarray of int, shape (n_bins,)
        Batch index of each bin, in ``[0, nbatches)``.

    Raises
    ------
    ValueError
        If ``nbatches < 1``.
    """
    if nbatches < 1:
        raise ValueError(f"assign_batches: nbatches must be >= 1, got {nbatches}")
    counts = np.asarray(counts, dtype=float)
    load = np.zeros(nbatches)
    batch = np.zeros(counts.size, dtype=int)
    # longest-processing-time first; stable sort so ties keep bin order
    for i in np.argsort(-counts, kind="stable"):
        b = int(np.argmin(load))
        batch[i] = b
        load[b] += counts[i] + 1.0  # +1: fixed per-fit overhead
    return batch


def make_bins(
    in_path: str | os.PathLike,
    assignments_path: str | os.PathLike,
    table_path: str | os.PathLike,
    *,
    hws_width_ms: float,
    amplitude_width_deg: float,
    period_width_s: float,
    min_count: int,
    nbatches: int,
) -> pd.DataFrame:
    """Bin the kept records (HWS x amplitude x period) and write the bin table with batches.

    The bin table (seed 000 Table 1 style) is sorted by decreasing count; ``bin_id`` is the
    case number (1 = most frequent). Bins with at least ``min_count`` records are
    ``fitted`` and assigned a batch.
    """
    from flidar_uq.data import binning

    records = _read_csv(in_path)
    assigned, table = binning.bin_records(
        records,
        hws_width_ms=hws_width_ms,
        amplitude_width_deg=amplitude_width_deg,
        period_width_s=period_width_s,
        min_count=min_count,
    )
    # integer case number as the pipeline's bin id (file names, seeds); text label kept
    table = table.rename(columns={"bin_id": "bin_label", "case_no": "bin_id"}).reset_index(
        drop=True
    )
    assigned = assigned.rename(columns={"bin_id": "bin_label", "case_no": "bin_id"})
    assigned = assigned[assigned["bin_id"] > 0].reset_index(drop=True)
    table["fitted"] = ~table["below_min_count"].astype(bool)
    table["batch"] = -1
    fitted = table["fitted"].to_numpy()
    table.loc[fitted, "batch"] = assign_batches(table.loc[fitted, "count"].to_numpy(), nbatches)
    _write_csv(assigned, assignments_path)
    _write_csv(table, table_path)
    log.info(
        "bins: %d bins, %d fitted, %d records unbinned",
        len(table),
        int(fitted.sum()),
        len(records) - len(assigned),
    )
    return table


def sigma_z_table(
    table_path: str | os.PathLike, out_path: str | os.PathLike, *, lidar: str
) -> pd.DataFrame:
    """sigma_Z and E(Z) at each bin centre through the surrogate (seed 000 Eqs. 4-14)."""
    from flidar_uq.physics.surrogate import get_surrogate

    table = _read_csv(table_path)
    sur = get_surrogate(lidar)
    args = (
        table["hws_ms"].to_numpy(),
        table["amplitude_deg"].to_numpy(),
        table["period_s"].to_numpy(),
    )
    out = table[["bin_id", "hws_ms", "amplitude_deg", "period_s", "count"]].copy()
    out["sigma_z_ms"] = sur.sigma_z_ms(*args)
    out["mean_z_ms"] = sur.mean_z_ms(*args)
    _write_csv(out, out_path)
    return out


# --------------------------------------------------------------------------- inference


def bin_seed(seed: int, bin_id: int) -> np.random.SeedSequence:
    """SeedSequence of one bin's fit: independent of the batch layout, so results are too."""
    return np.random.SeedSequence(entropy=int(seed), spawn_key=(1, int(bin_id)))


def _settings(inference: dict):
    from flidar_uq.inference import SamplerSettings

    fields = SamplerSettings.__dataclass_fields__
    return SamplerSettings(**{k: v for k, v in inference.items() if k in fields})


def _priors(priors: dict):
    from flidar_uq.inference import Priors

    return Priors(**priors)


def _diagnostic_row(fit) -> dict:
    """Worst-case convergence diagnostics of a fit, over its parameters."""
    diag = fit.diagnostics
    if not diag:
        return {}
    return {
        "rhat_max": max(d["rhat"] for d in diag.values()),
        "ess_bulk_min": min(d["ess_bulk"] for d in diag.values()),
        "ess_tail_min": min(d["ess_tail"] for d in diag.values()),
        "nsteps_over_tau_min": min(d["nsteps_over_tau"] for d in diag.values()),
    }


def infer_batch(
    assignments_path: str | os.PathLike,
    table_path: str | os.PathLike,
    out_dir: str | os.PathLike,
    *,
    batch: int,
    inference: dict,
    priors: dict,
    lidar: str = "zephir300",
) -> pd.DataFrame:
    """Fit the motion posterior of every bin of one batch; a fit that raises is recorded, not fatal.

    Parameters
    ----------
    assignments_path : path
        Kept records with their ``bin_id`` (checkpoint ``bins``).
    table_path : path
        Bin table with ``bin_id``, ``fitted`` and ``batch``.
    out_dir : path
        Written: ``bin_<id>.nc`` for every bin of the batch (ArviZ DataTree; for a fit
        that raised, an empty dataset with ``status="error"`` and the message in its
        attributes) and ``summary.csv`` (one row per bin: ``bin_id, status`` =
        "ok" | "failed" (convergence criteria missed) | "error" (raised), ``model``,
        ``message`` and the worst-case diagnostics).
    batch : int
        Batch index (the ``batch`` column of the bin table).
    inference, priors : dict
        Config sections (:class:`~flidar_uq.inference.SamplerSettings` fields + ``seed``,
        :class:`~flidar_uq.inference.Priors` fields).
    lidar : str
        Lidar geometry name (for the sigma_Z surrogate).

    Returns
    -------
    pandas.DataFrame
        The summary table.
    """
    from flidar_uq import inference as inf

    assigned = _read_csv(assignments_path)
    table = _read_csv(table_path)
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    settings, prior = _settings(inference), _priors(priors)
    rows = []
    for bin_id in table.loc[table["batch"] == batch, "bin_id"].astype(int):
        path = out_dir / f"bin_{bin_id:04d}.nc"
        recs = assigned[assigned["bin_id"] == bin_id]
        try:
            fit = inf.fit_bin(
                recs,
                settings=settings,
                seed=bin_seed(inference["seed"], bin_id),
                priors=prior,
                bin_id=bin_id,
            )
            _save_fit(fit, path)
            row = {
                "bin_id": bin_id,
                "status": "ok" if fit.converged else "failed",
                "model": fit.model,
                "n_records": len(recs),
                "message": "; ".join(fit.failure_reasons),
            } | _diagnostic_row(fit)
        except Exception as exc:  # a failing bin is reported, never fatal for the others
            log.exception("bin %d: fit raised", bin_id)
            _write_failed_posterior(path, bin_id, exc)
            row = {
                "bin_id": bin_id,
                "status": "error",
                "n_records": len(recs),
                "message": f"{type(exc).__name__}: {exc}",
            }
        log.info("bin %d: %s %s", bin_id, row["status"], row["message"])
        rows.append(row)
    summary = pd.DataFrame(
        rows, columns=["bin_id", "status", "model", "n_records", "message"] if not rows else None
    )
    _write_csv(summary, out_dir / "summary.csv")
    return summary


def _save_fit(fit, path: str | os.PathLike) -> None:
    """Write a fit's ArviZ DataTree to NetCDF without wall-clock attributes (reruns are bit-identical)."""
    dt = fit.to_datatree()
    for node in dt.subtree:
        node.attrs.pop("created_at", None)
        node.attrs.pop("creation_library_version", None)
    dt.to_netcdf(path, engine="h5netcdf")


def _write_failed_posterior(path: Path, bin_id: int, exc: BaseException) -> None:
    import xarray as xr

    attrs = {
        "flidar_uq_kind": "failed",
        "bin_id": bin_id,
        "status": "error",
        "message": f"{type(exc).__name__}: {exc}",
    }
    xr.Dataset(attrs=attrs).to_netcdf(path, engine="h5netcdf")


def _load_bin_fits(batch_dirs: Sequence[str | os.PathLike], bin_fits: pd.DataFrame) -> dict:
    """Load the BinFit of every bin whose fit ran (status ok or failed), keyed by bin id."""
    from flidar_uq import inference as inf

    ran = bin_fits.loc[bin_fits["status"] != "error", "bin_id"].astype(int)
    return {b: inf.load_fit(_bin_file(batch_dirs, b)) for b in ran}


def fit_global_model(
    batch_dirs: Sequence[str | os.PathLike],
    assignments_path: str | os.PathLike,
    out_path: str | os.PathLike,
    *,
    model: str,
    inference: dict,
    priors: dict,
) -> None:
    """Fit one global model (rho only / lever arm / lever arm + motion scale) on the gathered
    per-bin fits and write its posterior (NetCDF) to ``out_path``.

    The three models run as parallel jobs; :func:`fit_global` then picks one by PSIS-LOO.
    Each model's draws depend only on the seed (``inference.fit_global`` seeds each model
    with its own child), so the result equals ``fit_global(..., lever_arm="auto")``.
    """
    from flidar_uq import inference as inf

    bin_fits = _gather_bin_summaries(batch_dirs)
    assigned = _read_csv(assignments_path)
    fits = _load_bin_fits(batch_dirs, bin_fits)
    fit = inf.fit_global(
        assigned[assigned["bin_id"].isin(list(fits))].reset_index(drop=True),
        list(fits.values()),
        settings=_settings(inference),
        seed=np.random.SeedSequence(entropy=int(inference["seed"]), spawn_key=(0,)),
        priors=_priors(priors),
        lever_arm=model,
    )
    Path(out_path).parent.mkdir(parents=True, exist_ok=True)
    _save_fit(fit, out_path)
    log.info(
        "global model %s: converged=%s %s", model, fit.converged, "; ".join(fit.failure_reasons)
    )


def _gather_bin_summaries(batch_dirs: Sequence[str | os.PathLike]) -> pd.DataFrame:
    bin_fits = pd.concat(
        [_read_csv(Path(d) / "summary.csv") for d in batch_dirs], ignore_index=True
    )
    return bin_fits.sort_values("bin_id", kind="stable").reset_index(drop=True)


def fit_global(
    model_paths: Sequence[str | os.PathLike],
    batch_dirs: Sequence[str | os.PathLike],
    posterior_path: str | os.PathLike,
    bin_fits_path: str | os.PathLike,
    summary_path: str | os.PathLike,
    *,
    inference: dict,
) -> pd.DataFrame:
    """Pick the global model by PSIS-LOO (the gather step) and write the global results.

    ``model_paths``: the posteriors of :func:`fit_global_model` in the order rho only,
    lever arm, lever arm + motion scale (:func:`flidar_uq.inference.select_global_model`).
    Writes the chosen global posterior (NetCDF), the concatenated per-bin summaries
    (``bin_fits_path``) and the global parameter summary (``summary_path``, one row per
    parameter with diagnostics, ``converged``, ``failure_reasons`` and the LOO
    comparisons). Bins that failed or raised were excluded from the global fit.
    """
    from flidar_uq import inference as inf

    fit = inf.select_global_model(
        *(inf.load_fit(p) for p in model_paths), settings=_settings(inference)
    )
    Path(posterior_path).parent.mkdir(parents=True, exist_ok=True)
    _save_fit(fit, posterior_path)
    _write_csv(_gather_bin_summaries(batch_dirs), bin_fits_path)
    _write_csv(fit.summary(), summary_path)
    log.info(
        "global fit: model %s, converged=%s %s",
        fit.info["loo"].get("model"),
        fit.converged,
        "; ".join(fit.failure_reasons),
    )
    return fit.summary()


def _bin_file(batch_dirs: Sequence[str | os.PathLike], bin_id: int) -> Path:
    for d in batch_dirs:
        p = Path(d) / f"bin_{bin_id:04d}.nc"
        if p.exists():
            return p
    raise ValueError(f"no posterior file for bin {bin_id} in {list(map(str, batch_dirs))}")


# --------------------------------------------------------------------------- propagation


def _md_rmse(x: np.ndarray, ref: np.ndarray) -> tuple[float, float, int]:
    """MD and RMSE of x against ref (seed 000 Eqs. 18-19) and the number of finite pairs."""
    from flidar_uq.data import metrics

    n = int(np.sum(np.isfinite(x) & np.isfinite(ref)))
    return metrics.mean_deviation(x, ref), metrics.rmse(x, ref), n


def propagate(
    *,
    records_path: str | os.PathLike,
    flags_path: str | os.PathLike,
    assignments_path: str | os.PathLike,
    table_path: str | os.PathLike,
    sigma_z_path: str | os.PathLike,
    bin_fits_path: str | os.PathLike,
    batch_dirs: Sequence[str | os.PathLike],
    global_path: str | os.PathLike,
    records_out: str | os.PathLike,
    bins_out: str | os.PathLike,
    speed_bins_out: str | os.PathLike,
    metrics_out: str | os.PathLike,
    credible_mass: float,
    ndraws: int,
    seed: int,
    lidar: str = "zephir300",
    target: str = "point",
    turbulence_dt_s: float | None = None,
    point_sample_interval_s: float = 1.0,
    scan_heights_in_turn: int | None = None,
    scan_refocus_delay_s: Sequence[float] = (0.3, 0.7),
) -> pd.DataFrame:
    """Corrected std and TI per record, per bin and per speed bin, beside the baselines.

    Calls :func:`flidar_uq.correction.propagation.corrected_ti` on the kept, binned records with the
    converged bin fits and the global fit (posterior draws through the deployment formula;
    median and equal-tailed ``credible_mass`` interval), and seed 000's U / C / PC laws.

    ``target="point"`` turns the corrected std into the point (cup-like) std: divided by
    the motionless lidar's std ratio (:func:`flidar_uq.physics.lidar_response.lidar_std_ratio`,
    at the record's HWS and height, band-limited at ``1 / (2 turbulence_dt_s)`` for a
    synthetic series; None: the atmosphere) with its record-to-record scatter
    (:func:`flidar_uq.physics.lidar_response.lidar_point_log_sd`: the lidar scanning
    ``scan_heights_in_turn`` heights in turn (None: the number of distinct heights in
    the records) with ``scan_refocus_delay_s`` between scans, against the point HWS
    sampled every ``point_sample_interval_s``). ``"motionless_lidar"`` keeps the std a
    motionless lidar would measure (the reference the model is calibrated against).
    ``lidar_std_ratio`` and ``point_log_sd`` are written per record.

    ``metrics_out``: MD and RMSE (seed 000 Eqs. 18-19) of std (m/s) and TI for the
    uncorrected, U, C, PC and Bayesian estimates against the truth (``true_*``, virtual
    campaigns) or else the reference instrument, over the records with a Bayesian value;
    and the coverage of the credible interval when the truth is known.
    """
    from flidar_uq import inference as inf
    from flidar_uq.correction import propagation as prop
    from flidar_uq.physics.surrogate import get_surrogate

    flags = _read_csv(flags_path)
    assigned = _read_csv(assignments_path)
    table = _read_csv(table_path)
    sz_table = _read_csv(sigma_z_path).set_index("bin_id")
    bin_fits = _read_csv(bin_fits_path)
    gfit = inf.load_fit(global_path)
    fits = _load_bin_fits(batch_dirs, bin_fits)
    surrogate = get_surrogate(lidar)

    rid = flags["record_id"].to_numpy()
    rec = _read_csv(records_path).iloc[rid].reset_index(drop=True)  # every input record
    rec["bin_id"] = assigned.set_index("record_id")["bin_id"].reindex(rid).to_numpy()
    binned = rec["bin_id"].notna().to_numpy()
    sub = rec[binned].astype({"bin_id": int})
    if target not in ("point", "motionless_lidar"):
        raise ValueError(f"propagate: target={target!r} must be 'point' or 'motionless_lidar'")
    g_ratio, log_sd = np.ones(len(sub)), np.zeros(len(sub))
    if target == "point":
        from flidar_uq.physics import lidar_response

        hws_sub = sub["hws_mean_ms"].to_numpy(dtype=float)
        z_sub = sub["height_m"].to_numpy(dtype=float)
        g_ratio = lidar_response.lidar_std_ratio(
            hws_sub,
            z_sub,
            lidar,
            turbulence_max_frequency_hz=None if turbulence_dt_s is None else 0.5 / turbulence_dt_s,
        )
        heights = scan_heights_in_turn or int(rec["height_m"].nunique())
        log_sd = lidar_response.lidar_point_log_sd(
            hws_sub,
            z_sub,
            lidar,
            heights_in_turn=heights,
            refocus_delay_s=tuple(scan_refocus_delay_s),
            point_sample_interval_s=point_sample_interval_s,
            turbulence_dt_s=turbulence_dt_s,
            seed=int(seed),
        )
        log.info(
            "point target: lidar std ratio %.4f-%.4f, log-sd %.4f-%.4f (%d heights in turn)",
            np.nanmin(g_ratio), np.nanmax(g_ratio), np.nanmin(log_sd), np.nanmax(log_sd), heights,
        )  # fmt: skip
    per_record, speed_bins = prop.corrected_ti(
        sub,
        [f for f in fits.values() if f.converged],
        gfit,
        surrogate=surrogate,
        cred_mass=credible_mass,
        ndraws=ndraws,
        lidar_std_ratio=g_ratio,
        point_log_sd=log_sd,
        seed=np.random.SeedSequence(entropy=int(seed), spawn_key=(2,)),
    )
    sz_seed, rho_seed = prop.seed000_baseline(sub, surrogate)

    n = len(rec)
    m = rec["hws_mean_ms"].to_numpy(dtype=float)
    s = rec["hws_std_ms"].to_numpy(dtype=float)
    out = pd.DataFrame(
        {"record_id": rid, "timestamp": flags["timestamp"], "height_m": rec["height_m"]}
    )
    out["bin_id"] = rec["bin_id"].to_numpy()
    out["hws_mean_ms"] = m
    out["hws_std_ms"] = s
    with np.errstate(invalid="ignore", divide="ignore"):
        out["ti_uncorrected"] = s / m

    def put(values, dtype=float, fill=np.nan):
        full = np.full(n, fill, dtype=dtype)
        full[binned] = values
        return full

    for col in ("ti_corrected_median", "ti_corrected_lo", "ti_corrected_hi"):
        out[col] = put(per_record[col].to_numpy())
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
        out[col] = put(per_record[src].to_numpy())
    out["sigma_z_seed000_ms"] = put(sz_seed)
    for law in ("u", "c", "pc"):
        out[f"std_corrected_{law}_ms"] = out[f"ti_corrected_{law}"] * m
    out["sigma_z_bin_ms"] = sz_table["sigma_z_ms"].reindex(out["bin_id"]).to_numpy(dtype=float)

    reasons = [[r] if isinstance(r, str) and r else [] for r in flags["reasons"].fillna("")]
    status = bin_fits.set_index("bin_id")["status"]
    fitted = table.set_index("bin_id")["fitted"]
    neg = put(per_record["discriminant_negative"].to_numpy(dtype=bool), dtype=bool, fill=False)
    for i in range(n):
        if reasons[i]:
            continue
        if not binned[i]:
            reasons[i].append("unbinned")  # kept by QC but a binning variable is missing
            continue
        b = int(out["bin_id"].iat[i])
        if not bool(fitted.get(b, False)):
            reasons[i].append("bin_not_fitted")
        elif status.get(b) != "ok":
            reasons[i].append("bin_failed" if status.get(b) == "failed" else "bin_error")
        elif neg[i]:
            reasons[i].append("discriminant_negative")
    if not gfit.converged:
        for r in reasons:
            r.append("global_fit_failed")
    out["flags"] = [";".join(r) for r in reasons]

    if "ref_hws_std_ms" in rec:
        out["ref_hws_std_ms"] = rec["ref_hws_std_ms"].to_numpy(dtype=float)
        with np.errstate(invalid="ignore", divide="ignore"):
            out["ti_ref"] = out["ref_hws_std_ms"] / rec["ref_hws_mean_ms"].to_numpy(dtype=float)
    if "true_ti" in rec:
        out["ti_true"] = rec["true_ti"].to_numpy(dtype=float)
    if "true_hws_std_ms" in rec:
        out["true_hws_std_ms"] = rec["true_hws_std_ms"].to_numpy(dtype=float)
    out = out[RECORD_COLUMNS + [c for c in out.columns if c not in RECORD_COLUMNS]]
    _write_csv(out, records_out)
    _write_csv(speed_bins, speed_bins_out)

    # per-bin table: bin table + sigma_Z at the centre + fit status/diagnostics + TI means
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
    _write_csv(bins.merge(means, on="bin_id", how="left"), bins_out)

    # MD / RMSE of std and TI (Tables 2-3 style) against the truth (virtual campaigns)
    # and against the reference instrument, where present, over the same records. The
    # Bayesian estimate is compared in the reference's own terms: its point value against
    # the truth, times lidar_std_ratio (the motionless-lidar value) against the reference
    # lidar. Seed 000's laws estimate the reference instrument's std, as published.
    used = np.isfinite(out["ti_corrected_median"].to_numpy())  # same records for every method
    g_all = out["lidar_std_ratio"].to_numpy(dtype=float)
    estimates = {
        "uncorrected": ("hws_std_ms", "ti_uncorrected"),
        "U": ("std_corrected_u_ms", "ti_corrected_u"),
        "C": ("std_corrected_c_ms", "ti_corrected_c"),
        "PC": ("std_corrected_pc_ms", "ti_corrected_pc"),
        "Bayesian": ("std_corrected_median_ms", "ti_corrected_median"),
    }
    rows = []
    for ref_name, (ref_std, ref_ti) in _references(rec).items():
        lo_hi = (out["ti_corrected_lo"].to_numpy(), out["ti_corrected_hi"].to_numpy())
        for name, (scol, tcol) in estimates.items():
            scale = g_all if (name == "Bayesian" and ref_name != "truth") else 1.0
            std = np.where(used, out[scol].to_numpy(dtype=float) * scale, np.nan)
            ti = np.where(used, out[tcol].to_numpy(dtype=float) * scale, np.nan)
            md_s, rmse_s, n_s = _md_rmse(std, ref_std)
            md_t, rmse_t, _ = _md_rmse(ti, ref_ti)
            with np.errstate(all="ignore"):
                rel = ti / ref_ti - 1.0
                mean_rel = float(np.nanmean(rel)) if n_s else float("nan")
                mean_abs_rel = float(np.nanmean(np.abs(rel))) if n_s else float("nan")
            coverage = float("nan")
            if name == "Bayesian" and n_s:
                ok = used & np.isfinite(ref_ti)
                inside = (ref_ti >= lo_hi[0] * scale) & (ref_ti <= lo_hi[1] * scale)
                coverage = float(inside[ok].mean())
            rows.append(
                {
                    "reference": ref_name,
                    "method": name,
                    "n": n_s,
                    "md_std_ms": md_s,
                    "rmse_std_ms": rmse_s,
                    "md_ti": md_t,
                    "rmse_ti": rmse_t,
                    "mean_rel_ti_error": mean_rel,
                    "mean_abs_rel_ti_error": mean_abs_rel,
                    "coverage": coverage,
                }
            )
    metrics = pd.DataFrame(
        rows,
        columns=[
            "reference", "method", "n", "md_std_ms", "rmse_std_ms", "md_ti", "rmse_ti",
            "mean_rel_ti_error", "mean_abs_rel_ti_error", "coverage",
        ],
    )  # fmt: skip
    metrics["rho_seed000"] = rho_seed
    metrics["credible_mass"] = credible_mass
    metrics["target"] = target
    _write_csv(metrics, metrics_out)
    return out


def _references(rec: pd.DataFrame) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """Std (m/s) and TI the estimates are scored against: the truth and/or the reference."""
    out = {}
    if "true_hws_std_ms" in rec:
        std = rec["true_hws_std_ms"].to_numpy(dtype=float)
        ti = (
            rec["true_ti"].to_numpy(dtype=float)
            if "true_ti" in rec
            else std / rec["true_hws_mean_ms"].to_numpy(dtype=float)
        )
        out["truth"] = (std, ti)
    if "ref_hws_std_ms" in rec:
        std = rec["ref_hws_std_ms"].to_numpy(dtype=float)
        out["reference instrument"] = (std, std / rec["ref_hws_mean_ms"].to_numpy(dtype=float))
    return out


def git_revision(repo_dir: str | os.PathLike) -> str:
    """Git revision (HEAD) of ``repo_dir``, "" outside a git checkout or without git.

    Read when the report is written (not a rule parameter, so a commit alone does not
    rerun the report).
    """
    import subprocess

    try:
        out = subprocess.run(
            ["git", "-C", str(repo_dir), "rev-parse", "HEAD"],
            capture_output=True,
            text=True,
            check=True,
        )
    except (OSError, subprocess.CalledProcessError):
        return ""
    return out.stdout.strip()


def _capped_table(rep, df: pd.DataFrame, name: str, max_rows: int = 40) -> str:
    caption = name if len(df) <= max_rows else f"{name}: first {max_rows} of {len(df)} rows"
    return rep.table_html(df.head(max_rows), caption=caption)


def build_report(
    *,
    out_path: str | os.PathLike,
    results_dir: str | os.PathLike,
    batch_dirs: Sequence[str | os.PathLike],
    config: dict,
    benchmarks_dir: str | os.PathLike | None = None,
    git_revision: str = "",
) -> str:
    """Write the self-contained HTML report from the pipeline's result files.

    Parameters
    ----------
    out_path : path
        The HTML file.
    results_dir : path
        The pipeline's ``results/`` directory (ti/, bins/, qc/, motion/, inference/, posterior/).
    batch_dirs : sequence of path
        The per-bin inference batch directories.
    config : dict
        The run's configuration (provenance; thresholds of the convergence plot).
    benchmarks_dir : path, optional
        Directory of benchmark PNG charts (and ``los_*.csv`` comparison tables); skipped if absent.
    git_revision : str
        Revision of the workflow's repository.

    Returns
    -------
    str
        The HTML text written.
    """
    from flidar_uq.physics import variance_laws as correction
    from flidar_uq.workflow import plots
    from flidar_uq import inference as inf
    from flidar_uq.workflow import report as rep

    res = Path(results_dir)
    records = _read_csv(res / "ti" / "records.csv")
    bins = _read_csv(res / "ti" / "bins.csv")
    metrics = _read_csv(res / "ti" / "metrics.csv")
    qc_counts = _read_csv(res / "qc" / "summary.csv")
    roll_pitch = _read_csv(res / "motion" / "roll_pitch.csv")
    bin_fits = _read_csv(res / "inference" / "bin_fits.csv")
    global_summary = _read_csv(res / "inference" / "global.csv")
    gfit = inf.load_fit(res / "posterior" / "global.nc")
    mass = float(config["propagation"]["credible_mass"])
    sections = []

    n_in = len(records)
    kept = records["flags"].fillna("").eq("") | records["ti_corrected_median"].notna()
    status_counts = bins["status"].value_counts()
    overview = pd.DataFrame(
        [
            ("input records", n_in),
            ("records with a corrected TI", int(records["ti_corrected_median"].notna().sum())),
            ("records flagged (any reason)", int((records["flags"].fillna("") != "").sum())),
            ("bins", len(bins)),
            ("bins fitted and converged (ok)", int(status_counts.get("ok", 0))),
            ("bins failed (convergence missed)", int(status_counts.get("failed", 0))),
            ("bins whose fit raised (error)", int(status_counts.get("error", 0))),
            ("bins not fitted (too few records)", int(status_counts.get("not_fitted", 0))),
            ("global fit converged", bool(gfit.converged)),
        ],
        columns=["quantity", "value"],
    )
    del kept
    sections.append(rep.Section("Overview", rep.table_html(overview)))

    sections.append(
        rep.Section(
            "Quality control",
            rep.table_html(
                qc_counts, caption="records failing each filter (a record can fail several)"
            )
            + rep.table_html(
                roll_pitch,
                caption="roll-pitch correlation of amplitude and period (seed 000 Sec. 2.4)",
            ),
        )
    )

    cols = [
        c
        for c in (
            "bin_id",
            "hws_ms",
            "amplitude_deg",
            "period_s",
            "count",
            "sigma_z_ms",
            "mean_z_ms",
            "status",
            "model",
            "ti_uncorrected_mean",
            "ti_corrected_median_mean",
            "ti_corrected_lo_mean",
            "ti_corrected_hi_mean",
            "ti_true_mean",
        )
        if c in bins
    ]
    shown = bins["status"] != "not_fitted"
    table1 = bins.loc[shown, cols].rename(
        columns={
            "bin_id": "case no.",
            "hws_ms": "HWS (m/s)",
            "amplitude_deg": "AA (deg)",
            "period_s": "T (s)",
            "count": "count no.",
            "sigma_z_ms": "sigma_Z (m/s)",
        }
    )
    sections.append(
        rep.Section(
            "Bin table (seed 000 Table 1 style)",
            rep.table_html(
                table1,
                caption=f"bins by decreasing count; sigma_Z at the bin centre; bin means of the "
                f"records' uncorrected TI, corrected TI (median and {mass:.0%} interval bounds) and truth; "
                f"{int((~shown).sum())} bins below min_count not shown (results/ti/bins.csv)",
            ),
        )
    )

    rho_med = float(np.median(gfit.flat("rho")))
    rho_seed = float(metrics["rho_seed000"].iloc[0]) if len(metrics) else float("nan")
    ref_col = next((c for c in ("ref_hws_std_ms", "true_hws_std_ms") if c in records), None)
    if ref_col is not None:
        ok = records["ti_corrected_median"].notna()
        r = records[ok]
        ref = r[ref_col].to_numpy(dtype=float)
        # seed 000's rho needs >= 3 bins; otherwise the PC curve uses the posterior median
        rho_pc, rho_src = (
            (rho_seed, "seed 000") if np.isfinite(rho_seed) else (rho_med, "posterior median")
        )
        szb = r["sigma_z_seed000_ms"].to_numpy(dtype=float)
        corr = {
            "U": correction.sigma_moving_u(ref, szb),
            "C": correction.sigma_moving_c(ref, szb),
            "PC": correction.sigma_moving_pc(ref, szb, rho_pc),
            "Bayesian": correction.sigma_moving_pc(
                ref, r["sigma_z_median_ms"].to_numpy(dtype=float), rho_med
            ),
        }
        label = "reference" if ref_col == "ref_hws_std_ms" else "truth"
        body = rep.img_html(
            rep.figure_to_data_uri(
                plots.sigma_scatter_figure(r["hws_std_ms"].to_numpy(), ref, corr, ref_label=label)
            ),
            f"whole campaign: sigma_moving against sigma_ref ({label}) and the motion-corrected sigma_corr "
            f"(Eqs. 15-17 of seed 000; PC with rho = {rho_pc:.3g} ({rho_src}), Bayesian with the posterior medians)",
        )
        top = bins.loc[bins["status"] == "ok", "bin_id"].head(3).tolist()
        for bid in top:
            sel = (r["bin_id"] == bid).to_numpy()
            sub = {k: v[sel] for k, v in corr.items() if k in ("PC", "Bayesian")}
            body += rep.img_html(
                rep.figure_to_data_uri(
                    plots.sigma_scatter_figure(
                        r["hws_std_ms"].to_numpy()[sel], ref[sel], sub, ref_label=label
                    )
                ),
                f"case no. {bid} (seed 000 Fig. 4 style)",
            )
        sections.append(
            rep.Section(
                "sigma_moving against sigma_ref and sigma_corr (seed 000 Figs. 4-5 style)", body
            )
        )

    sections.append(
        rep.Section(
            "MD and RMSE by correction method (seed 000 Tables 2-3 style)",
            rep.table_html(
                metrics,
                caption="MD = mean(estimate - reference), RMSE (Eqs. 18-19 of seed 000) over the "
                "records with a Bayesian corrected value, against the truth and/or the reference "
                "instrument; against the reference lidar the Bayesian value is its motionless-lidar "
                "equivalent (times lidar_std_ratio); seed 000's U / C / PC laws estimate the "
                "reference instrument's std (as published); coverage = share of the reference TI "
                "inside the credible interval",
            ),
        )
    )
    refs = {}
    if "ti_true" in records:
        refs["truth"] = records["ti_true"].to_numpy(dtype=float)
    if "ti_ref" in records:
        refs["reference lidar (interval x lidar_std_ratio)"] = (
            records["ti_ref"].to_numpy(dtype=float),
            records["lidar_std_ratio"].to_numpy(dtype=float),
        )
    if refs:
        sections.append(
            rep.Section(
                "Calibration of the credible intervals by wind speed",
                rep.img_html(
                    rep.figure_to_data_uri(
                        plots.calibration_figure(
                            records["hws_mean_ms"].to_numpy(dtype=float),
                            records["ti_corrected_median"].to_numpy(dtype=float),
                            records["ti_corrected_lo"].to_numpy(dtype=float),
                            records["ti_corrected_hi"].to_numpy(dtype=float),
                            refs,
                            credible_mass=mass,
                        )
                    ),
                    f"share of the reference TI inside the {mass:.0%} interval per 2-m/s bin "
                    "(binomial 95 % error bars) and the mean relative error of the median",
                ),
            )
        )
    sections.append(
        rep.Section(
            "TI against HWS with credible bands (seed 000 Fig. 8 style)",
            rep.img_html(
                rep.figure_to_data_uri(plots.ti_vs_hws_figure(records, credible_mass=mass)),
                f"TI against HWS: moving lidar, corrected (median, {mass:.0%} band of the bin means), truth",
            ),
        )
    )

    post = rep.img_html(
        rep.figure_to_data_uri(
            plots.posterior_figure(
                {k: np.asarray(v) for k, v in gfit.draws.items()},
                title="global posterior, one line per ensemble",
            )
        ),
        "posterior of the global parameters (rho, tau0, kappa), per ensemble",
    )
    post += rep.table_html(global_summary, caption="global fit: posterior summary and diagnostics")
    ok_bins = bin_fits.loc[bin_fits["status"] == "ok", "bin_id"].astype(int).head(1).tolist()
    for bid in ok_bins:
        bfit = inf.load_fit(_bin_file(batch_dirs, bid))
        post += rep.img_html(
            rep.figure_to_data_uri(
                plots.posterior_figure(
                    {k: np.asarray(v) for k, v in bfit.draws.items()},
                    title=f"case no. {bid}: motion posterior",
                )
            ),
            f"posterior of the motion parameters of case no. {bid}, per ensemble",
        )
    post += rep.img_html(
        rep.figure_to_data_uri(
            plots.convergence_figure(
                bin_fits,
                rhat_max=config["inference"]["rhat_max"],
                ess_min=config["inference"]["ess_min"],
            )
        ),
        "per-bin convergence: worst rank R-hat and smallest ESS against the thresholds",
    )
    post += rep.table_html(
        bin_fits, caption="per-bin fits: status (ok / failed / error) and reasons"
    )
    sections.append(rep.Section("Posteriors and convergence", post))

    if benchmarks_dir is not None and Path(benchmarks_dir).is_dir():
        bdir = Path(benchmarks_dir)
        los = sorted(bdir.glob("los*comparison.csv"))
        if los:
            sections.append(
                rep.Section(
                    "LOS-level correction compared with the statistical correction",
                    "".join(_capped_table(rep, _read_csv(p), p.name) for p in los),
                )
            )
        pngs = sorted(bdir.glob("*.png"))
        if pngs:
            sections.append(
                rep.Section(
                    "Speed-accuracy charts (benchmarks/results)",
                    "".join(
                        rep.img_html(rep.png_bytes_to_data_uri(p.read_bytes()), p.name)
                        for p in pngs
                    ),
                )
            )

    sections.append(
        rep.Section("Provenance", rep.provenance_html(config, git_revision, rep.package_versions()))
    )
    text = rep.render_html("flidar_uq report: motion-corrected turbulence intensity", sections)
    Path(out_path).parent.mkdir(parents=True, exist_ok=True)
    Path(out_path).write_text(text, encoding="utf-8")
    return text
