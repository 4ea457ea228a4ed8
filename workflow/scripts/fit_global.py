"""Rule fit_global: gather the per-bin fits, fit the global rho (pipeline.fit_global)."""

from flidar_uq import pipeline

# The guard keeps the worker processes of the parallel model fits (spawn re-imports this
# module as __mp_main__) from re-running the rule body.
if __name__ == "__main__":
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
        threads=snakemake.threads,
    )
