"""Checkpoint bins: bin table and batch assignment (pipeline.make_bins)."""

from flidar_uq.workflow import pipeline

snakemake = globals()["snakemake"]  # injected by the script directive
pipeline.setup_logging(snakemake.log[0])
pipeline.make_bins(
    snakemake.input[0],
    snakemake.output.assignments,
    snakemake.output.table,
    nbatches=snakemake.params.nbatches,
    **dict(snakemake.params.binning),
)
