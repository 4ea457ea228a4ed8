"""Checkpoint bins: bin table and batch assignment (data_steps.make_bins)."""

from flidar_uq.workflow.data_steps import make_bins
from flidar_uq.workflow.files import setup_logging

snakemake = globals()["snakemake"]  # injected by the script directive
setup_logging(snakemake.log[0])
make_bins(
    [snakemake.input.records, snakemake.input.motion],
    snakemake.output.assignments,
    snakemake.output.table,
    nbatches=snakemake.params.nbatches,
    **dict(snakemake.params.binning),
)
