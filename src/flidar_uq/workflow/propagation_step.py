"""Workflow step of the correction layer: the inputs read from results/, corrected by
:func:`flidar_uq.correction.campaign.correct_campaign`, written to results/ti/; and the
per-bin table results/ti/bins.csv."""

from __future__ import annotations

import os
from collections.abc import Mapping, Sequence
from pathlib import Path

import pandas as pd

from flidar_uq.data.io import read_table
from flidar_uq.workflow.files import read_csv, write_csv
from flidar_uq.workflow.inference_steps import load_bin_fits

__all__ = ["bin_table", "propagate"]


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
    out_dir: str | os.PathLike,
    reference: Mapping,
    settings: Mapping,
) -> pd.DataFrame:
    """Read the propagation's inputs, :func:`~flidar_uq.correction.campaign.correct_campaign`,
    and write its tables to ``out_dir`` (:meth:`~flidar_uq.correction.campaign.CorrectionResult.to_files`:
    records.csv, speed_bins.csv, metrics.csv, groups.csv, uncertainty_budget.csv).

    ``records_path`` (the validated records) and ``assignments_path`` (the bins' record
    ids) are Parquet (:func:`flidar_uq.data.io.write_table`); ``global_path``: the global
    posterior (NetCDF). The record motion model's needs nothing
    else: ``bin_fits_path`` (None) and ``batch_dirs`` (empty) are not read, so the
    propagation runs beside the per-bin fits (the bin posteriors, hundreds of files at a
    year, ~0.2 s each to open, are not read then). The bin motion model's needs the
    per-bin summaries (``bin_fits_path``, :func:`flidar_uq.workflow.inference_steps.fit_global`)
    and the batch directories of the bin posteriors.

    ``reference``: :meth:`flidar_uq.correction.reference.Reference.to_config` of the
    resolved reference; ``settings``: the fields of
    :class:`flidar_uq.correction.campaign.CorrectionSettings` (the workflow's
    ``correction_settings``). Returns the records table.
    """
    from flidar_uq import inference as inf
    from flidar_uq.correction.campaign import BinTables, CorrectionSettings, correct_campaign
    from flidar_uq.correction.reference import Reference

    flags = read_csv(flags_path, ["record_id", "timestamp", "reasons"])
    fit = inf.load_fit(global_path)
    if inf.is_record_model(fit):
        status, fits = None, {}
    elif bin_fits_path is None:
        raise ValueError(f"{global_path} is a bin motion model: the per-bin fits are needed")
    else:
        status = read_csv(bin_fits_path)
        fits = load_bin_fits(batch_dirs, status)
    bins = BinTables(
        assignments=read_table(assignments_path, ["record_id", "bin_id"]),
        table=read_csv(table_path),
        sigma_z=read_csv(sigma_z_path),
        status=status,
        fits=fits,
    )
    records = read_table(records_path).iloc[flags["record_id"].to_numpy()]
    result = correct_campaign(
        records,
        fit,
        Reference.from_config(reference, lidar=reference["lidar"]),
        CorrectionSettings(**settings),
        flags=flags,
        bins=bins,
    )
    result.to_files(Path(out_dir), overwrite=True)  # the pipeline writes its own results/ti
    return result.records


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
