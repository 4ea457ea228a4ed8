"""Rule validate: validate the record table, refuse a reference mean without a std, and
write the inspection report (data_steps.validate_records); a bad input ends the job with
one line and its exit status (flidar_uq.workflow.inputs)."""

from flidar_uq.workflow.data_steps import validate_records
from flidar_uq.workflow.files import setup_logging
from flidar_uq.workflow.inputs import step_errors_exit

snakemake = globals()["snakemake"]  # injected by the script directive
setup_logging(snakemake.log[0])
with step_errors_exit():
    validate_records(
        snakemake.input[0],
        snakemake.output.records,
        snakemake.output.report,
        allow_small_angles=snakemake.params.allow_small_angles,
        qc_params=dict(snakemake.params.qc),
        heights_m=snakemake.params.heights,
    )
