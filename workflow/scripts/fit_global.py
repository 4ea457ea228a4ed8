"""Rule fit_global: gather the per-bin fits, fit the global rho (pipeline.fit_global)."""

from flidar_uq import pipeline

snakemake = globals()["snakemake"]  # injected by the script directive
pipeline.setup_logging(snakemake.log[0])
pipeline.fit_global(
    list(snakemake.input.batches),
    snakemake.input.assignments,
    snakemake.input.table,
    snakemake.output.posterior,
    snakemake.output.bin_fits,
    snakemake.output.summary,
    inference=dict(snakemake.params.inference),
    priors=dict(snakemake.params.priors),
    lidar=snakemake.params.lidar,
)
