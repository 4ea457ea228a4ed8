"""Rule fit_global_model: one global model on the gathered per-bin fits (inference_steps.fit_global_model)."""

from flidar_uq.workflow.data_steps import kept_records
from flidar_uq.workflow.files import setup_logging
from flidar_uq.workflow.inference_steps import fit_global_model, fit_input

snakemake = globals()["snakemake"]  # injected by the script directive
setup_logging(snakemake.log[0])
fit_global_model(
    list(snakemake.input.batches),
    # validation.holdout: the held-out records' reference removed from the fit input
    fit_input(
        kept_records(snakemake.input.records, snakemake.input.motion, snakemake.input.assignments),
        dict(snakemake.params.holdout) | {"records": snakemake.input.records},
    ),
    snakemake.output[0],
    model=snakemake.wildcards.model,
    inference=dict(snakemake.params.inference),
    priors=dict(snakemake.params.priors),
    lidar=snakemake.params.lidar,
    reference=dict(snakemake.params.reference),
    correction=dict(snakemake.params.correction),
)
