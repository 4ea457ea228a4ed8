"""Rule validate: validate the record table (with the motion statistics of the raw IMU
series when one is given), refuse a reference mean without a std, and write the inspection
report (data_steps.validate_records); a bad input ends the job with one line and its exit
status (flidar_uq.workflow.inputs)."""

from flidar_uq.workflow.data_steps import validate_records
from flidar_uq.workflow.files import setup_logging
from flidar_uq.workflow.inputs import step_errors_exit

snakemake = globals()["snakemake"]  # injected by the script directive
setup_logging(snakemake.log[0])
with step_errors_exit():
    validate_records(
        snakemake.input.records,
        snakemake.output.records,
        snakemake.output.report,
        allow_small_angles=snakemake.params.allow_small_angles,
        qc_params=dict(snakemake.params.qc),
        heights_m=snakemake.params.heights,
        imu_statistics_path=snakemake.input.get("imu_statistics"),
        require_motion=snakemake.params.require_motion,
    )
