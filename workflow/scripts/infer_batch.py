"""Rule infer_batch: fit every bin of one batch (inference_steps.infer_batch)."""

from flidar_uq.workflow.data_steps import kept_records
from flidar_uq.workflow.files import setup_logging
from flidar_uq.workflow.inference_steps import infer_batch

snakemake = globals()["snakemake"]  # injected by the script directive
setup_logging(snakemake.log[0])
infer_batch(
    kept_records(snakemake.input.records, snakemake.input.motion, snakemake.input.assignments),
    snakemake.input.table,
    snakemake.output[0],
    batch=int(snakemake.wildcards.batch),
    inference=dict(snakemake.params.inference),
    priors=dict(snakemake.params.priors),
)
