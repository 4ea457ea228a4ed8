"""Rule fit_global: pick the global model by PSIS-LOO, write the global results (inference_steps.fit_global)."""

from flidar_uq.workflow.files import setup_logging
from flidar_uq.workflow.inference_steps import fit_global

snakemake = globals()["snakemake"]  # injected by the script directive
setup_logging(snakemake.log[0])
fit_global(
    list(snakemake.input.models),
    list(snakemake.input.batches),  # none under the record motion model
    snakemake.output.posterior,
    snakemake.output.get("bin_fits"),
    snakemake.output.summary,
    inference=dict(snakemake.params.inference),
)
