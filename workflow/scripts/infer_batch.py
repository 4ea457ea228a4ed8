"""Rule infer_batch: fit every bin of one batch (pipeline.infer_batch)."""

from flidar_uq.workflow import pipeline

snakemake = globals()["snakemake"]  # injected by the script directive
pipeline.setup_logging(snakemake.log[0])
pipeline.infer_batch(
    snakemake.input.assignments,
    snakemake.input.table,
    snakemake.output[0],
    batch=int(snakemake.wildcards.batch),
    inference=dict(snakemake.params.inference),
    priors=dict(snakemake.params.priors),
    lidar=snakemake.params.lidar,
)
