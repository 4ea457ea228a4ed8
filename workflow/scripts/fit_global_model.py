"""Rule fit_global_model: one global model on the gathered per-bin fits (pipeline.fit_global_model)."""

from flidar_uq.workflow import pipeline

snakemake = globals()["snakemake"]  # injected by the script directive
pipeline.setup_logging(snakemake.log[0])
pipeline.fit_global_model(
    list(snakemake.input.batches),
    snakemake.input.assignments,
    snakemake.output[0],
    model=snakemake.wildcards.model,
    inference=dict(snakemake.params.inference),
    priors=dict(snakemake.params.priors),
)
