"""Rule fit_global: pick the global model by PSIS-LOO, write the global results (pipeline.fit_global)."""

from flidar_uq.workflow import pipeline

snakemake = globals()["snakemake"]  # injected by the script directive
pipeline.setup_logging(snakemake.log[0])
pipeline.fit_global(
    list(snakemake.input.models),
    list(snakemake.input.batches),
    snakemake.output.posterior,
    snakemake.output.bin_fits,
    snakemake.output.summary,
    inference=dict(snakemake.params.inference),
)
