"""Workflow steps of the inference layer: the per-bin fits of one batch, one global model
on the gathered bin fits, and the PSIS-LOO choice among the global models."""

from __future__ import annotations

import logging
import os
from collections.abc import Sequence
from pathlib import Path

import numpy as np
import pandas as pd

from flidar_uq.data.io import read_table
from flidar_uq.seeding import child_seed
from flidar_uq.workflow.files import bin_file, read_csv, write_csv

log = logging.getLogger(__name__)

__all__ = [
    "bin_seed",
    "fit_global",
    "fit_global_model",
    "fit_input",
    "gather_bin_summaries",
    "infer_batch",
    "load_bin_fits",
]


def bin_seed(seed: int, bin_id: int) -> np.random.SeedSequence:
    """SeedSequence of one bin's fit: independent of the batch layout, so results are too."""
    return child_seed(seed, 1, bin_id)


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
    assigned: pd.DataFrame,
    table_path: str | os.PathLike,
    out_dir: str | os.PathLike,
    *,
    batch: int,
    inference: dict,
    priors: dict,
) -> pd.DataFrame:
    """Fit the motion posterior of every bin of one batch; a fit that raises is recorded, not fatal.

    Parameters
    ----------
    assigned : pandas.DataFrame
        The binned records with their ``bin_id`` (checkpoint ``bins``: the validated
        records joined with the stages' columns, :func:`flidar_uq.workflow.data_steps.kept_records`).
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
        :class:`~flidar_uq.inference.Priors` fields). The motion likelihood needs no
        lidar (no sigma_Z surrogate): the lidar enters later (global fit, propagation).

    Returns
    -------
    pandas.DataFrame
        The summary table.
    """
    from flidar_uq import inference as inf

    table = read_csv(table_path)
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
            inf.save_fit(fit, path)
            row = {
                "bin_id": bin_id,
                "status": "ok" if fit.converged else "failed",
                "model": fit.model,
                "n_records": len(recs),
                "message": "; ".join(fit.failure_reasons),
            } | _diagnostic_row(fit)
        except Exception as exc:  # a failing bin is reported, never fatal for the others
            log.exception("bin %d: fit raised", bin_id)
            inf.write_failed_fit(path, bin_id, f"{type(exc).__name__}: {exc}")
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
    write_csv(summary, out_dir / "summary.csv")
    return summary


def load_bin_fits(batch_dirs: Sequence[str | os.PathLike], bin_fits: pd.DataFrame) -> dict:
    """Load the BinFit of every bin whose fit ran (status ok or failed), keyed by bin id."""
    from flidar_uq import inference as inf

    ran = bin_fits.loc[bin_fits["status"] != "error", "bin_id"].astype(int)
    return {b: inf.load_fit(bin_file(batch_dirs, b)) for b in ran}


def fit_global_model(
    batch_dirs: Sequence[str | os.PathLike],
    assignments_path: str | os.PathLike | pd.DataFrame,
    out_path: str | os.PathLike,
    *,
    model: str,
    inference: dict,
    priors: dict,
    lidar: str,
    reference: dict | None = None,
    correction: dict | None = None,
) -> None:
    """Fit one global model (rho only / lever arm / lever arm + motion scale) on the gathered
    per-bin fits and write its posterior (NetCDF) to ``out_path``.

    ``lidar`` (config ``campaign.lidar``) picks the sigma_Z surrogate, the same one
    :func:`flidar_uq.correction.campaign.correct_campaign` uses.

    ``reference`` (:meth:`flidar_uq.correction.reference.Reference.to_config` of the
    resolved reference) and ``correction`` (the fields of
    :class:`flidar_uq.correction.campaign.CorrectionSettings`: the workflow's
    ``correction_settings``, the very values the ``propagate`` step gets): with a
    reference (a fixed lidar, a cup or a sonic), the record model takes the sampling
    scatter of the floating lidar's motionless std against the reference's as known
    (``fit_record_model(pair_log_sd=...)``, the pair term of
    :meth:`flidar_uq.correction.reference.Reference.noise` with those settings, the same
    numbers the propagation uses), so that ``kappa`` is the floating lidar's own noise.
    None: no pair term (``kappa`` holds both instruments' sampling). Every model, record
    or bin, is fitted on the reference std divided by the reference's std over the
    floating lidar's motionless std
    (:meth:`~flidar_uq.correction.reference.ReferenceNoise.floating_reference`), the
    target the propagation corrects to.

    The three models run as parallel jobs; :func:`fit_global` then picks one by PSIS-LOO.
    Each model's draws depend only on the seed (``inference.fit_global`` seeds each model
    with its own child), so the result equals ``fit_global(..., lever_arm="auto")``.

    ``assignments_path``: the binned records, a CSV table or the table itself
    (:func:`fit_input`: the binned records without the held-out records' reference, so
    that the fit never sees it).
    """
    from flidar_uq import inference as inf
    from flidar_uq.physics.lidar import get_lidar
    from flidar_uq.physics.surrogate import get_surrogate

    seed = child_seed(inference["seed"], 0)
    assigned = (
        assignments_path
        if isinstance(assignments_path, pd.DataFrame)
        else read_csv(assignments_path)
    )
    noise = _reference_noise(assigned, reference, correction)
    # the reference std in the floating lidar's response (a DBS lidar's depends on the
    # wind's direction against its beams): the r of every global model
    assigned = assigned if noise is None else noise.floating_reference(assigned)
    if model == "record":
        lever = inference.get("lever_arm_m")
        pair_log_sd = None if noise is None else noise.pair_log_sd
        fit = inf.fit_record_model_selecting_hull(
            assigned,
            hull_model=inference.get("hull_model", "auto"),
            hull=inference.get("hull_reference", "auto"),
            surrogate=get_surrogate(lidar),
            lidar=lidar,
            settings=_settings(inference),
            seed=seed,
            priors=_priors(priors),
            lever_arm_prior=None
            if lever is None
            else (float(lever), float(inference.get("lever_arm_sd_m", 0.3))),
            pair_log_sd=pair_log_sd,
        )
        Path(out_path).parent.mkdir(parents=True, exist_ok=True)
        inf.save_fit(fit, out_path)
        log.info("record model: converged=%s %s", fit.converged, "; ".join(fit.failure_reasons))
        cmp = fit.info.get("hull_model_comparison")
        log.info(
            "record model: hull %s%s", fit.info["hull_model"],
            "" if not cmp else f" (PSIS-LOO elpd translating - rotation only "
            f"{cmp['elpd_difference']:+.1f} +- {cmp['elpd_difference_se']:.1f})",
        )  # fmt: skip
        for key in ("motion_scale_warning", "lever_arm_warning"):
            if key in fit.info:
                log.warning(fit.info[key])
        return
    bin_fits = gather_bin_summaries(batch_dirs)
    fits = load_bin_fits(batch_dirs, bin_fits)
    fit = inf.fit_global(
        assigned[assigned["bin_id"].isin(list(fits))].reset_index(drop=True),
        list(fits.values()),
        surrogate=get_surrogate(lidar),
        settings=_settings(inference),
        seed=seed,
        priors=_priors(priors),
        lever_arm=model,
        scan_period_s=get_lidar(lidar).scan_period_s,
    )
    Path(out_path).parent.mkdir(parents=True, exist_ok=True)
    inf.save_fit(fit, out_path)
    log.info(
        "global model %s: converged=%s %s", model, fit.converged, "; ".join(fit.failure_reasons)
    )


def _reference_noise(assigned, reference, correction):
    """:meth:`flidar_uq.correction.reference.Reference.noise` of the fit's records with a
    reference (``correction``: the fields of
    :class:`flidar_uq.correction.campaign.CorrectionSettings`, the ones the propagation
    gets); None without one (``reference`` None or kind "none")."""
    if reference is None or reference["kind"] == "none":
        return None
    if correction is None:
        raise ValueError(
            f"fit_global_model: a {reference['kind']} reference needs the correction settings "
            "(correction=, the fields of CorrectionSettings the propagation uses)"
        )
    from flidar_uq.correction.campaign import CorrectionSettings
    from flidar_uq.correction.reference import Reference

    ref = Reference.from_config(reference, lidar=reference["lidar"])
    settings = CorrectionSettings(**correction)
    noise = settings.reference_noise(assigned, ref, heights=settings.heights_in_turn(assigned))
    log.info(
        "reference %s: sampling correlation with the floating lidar's %.3f-%.3f, pair log-sd "
        "%.4f-%.4f taken as known; its std over the floating lidar's motionless std %.4f-%.4f",
        ref.kind, np.nanmin(noise.correlation), np.nanmax(noise.correlation),
        np.nanmin(noise.pair_log_sd), np.nanmax(noise.pair_log_sd),
        np.nanmin(noise.reference_std_ratio), np.nanmax(noise.reference_std_ratio),
    )  # fmt: skip
    return noise


def fit_input(assigned: pd.DataFrame, holdout: dict | None = None) -> pd.DataFrame:
    """The records a global model is fitted on: the binned records, with the reference of
    the held-out ones removed (:func:`flidar_uq.validation.reference.withhold_reference`).

    Parameters
    ----------
    assigned : pandas.DataFrame
        The binned records (``timestamp`` and the ``ref_*`` columns,
        :func:`flidar_uq.workflow.data_steps.kept_records`).
    holdout : dict, optional
        ``mode`` and ``days`` (config ``validation.holdout``: day) and ``records``, the
        validated record table (its latest ``timestamp`` ends the campaign, for
        ``last_days``). None or mode "none": the records as they are.

    Returns
    -------
    pandas.DataFrame
    """
    from flidar_uq.validation.reference import holdout_mask, withhold_reference

    if not holdout or holdout.get("mode", "none") == "none":
        return assigned
    end = None
    if holdout.get("records"):
        end = pd.to_datetime(
            read_table(holdout["records"], ["timestamp"])["timestamp"], utc=True
        ).max()
    held = holdout_mask(
        assigned["timestamp"], mode=holdout["mode"], days=float(holdout["days"]), end=end
    )
    log.info("hold-out %s: reference of %d of %d records removed from the fit",
             holdout["mode"], int(held.sum()), len(held))  # fmt: skip
    return withhold_reference(assigned, held)


def gather_bin_summaries(batch_dirs: Sequence[str | os.PathLike]) -> pd.DataFrame:
    """The batches' per-bin summary tables, concatenated and sorted by bin id."""
    bin_fits = pd.concat([read_csv(Path(d) / "summary.csv") for d in batch_dirs], ignore_index=True)
    return bin_fits.sort_values("bin_id", kind="stable").reset_index(drop=True)


def fit_global(
    model_paths: Sequence[str | os.PathLike],
    batch_dirs: Sequence[str | os.PathLike],
    posterior_path: str | os.PathLike,
    bin_fits_path: str | os.PathLike | None,
    summary_path: str | os.PathLike,
    *,
    inference: dict,
) -> pd.DataFrame:
    """Pick the global model by PSIS-LOO (the gather step) and write the global results.

    ``model_paths``: the posteriors of :func:`fit_global_model` in the order rho only,
    lever arm, lever arm + motion scale (:func:`flidar_uq.inference.select_global_model`).
    Writes the chosen global posterior (NetCDF), the concatenated per-bin summaries
    (``bin_fits_path``; None under the record motion model, which runs no per-bin fit:
    ``batch_dirs`` is then empty) and the global parameter summary (``summary_path``, one row per
    parameter with diagnostics, ``converged``, ``failure_reasons`` and the LOO
    comparisons). Bins that failed or raised were excluded from the global fit.
    """
    from flidar_uq import inference as inf

    fits = [inf.load_fit(p) for p in model_paths]
    if len(fits) == 1 and inf.is_record_model(fits[0]):
        fit = fits[0]  # the record motion model: one model, nothing to choose
    else:
        fit = inf.select_global_model(*fits, settings=_settings(inference))
    Path(posterior_path).parent.mkdir(parents=True, exist_ok=True)
    inf.save_fit(fit, posterior_path)
    if bin_fits_path is not None:
        write_csv(gather_bin_summaries(batch_dirs), bin_fits_path)
    write_csv(fit.summary(), summary_path)
    log.info(
        "global fit: model %s, converged=%s %s",
        fit.info["loo"].get("model"),
        fit.converged,
        "; ".join(fit.failure_reasons),
    )
    return fit.summary()
