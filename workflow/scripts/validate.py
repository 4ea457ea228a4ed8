"""Rule validate: read and validate the record table (data_steps.validate_records), with the
motion statistics of the raw IMU series when one is given."""

from flidar_uq.workflow.data_steps import validate_records
from flidar_uq.workflow.files import setup_logging

snakemake = globals()["snakemake"]  # injected by the script directive
setup_logging(snakemake.log[0])
validate_records(
    snakemake.input.records,
    snakemake.output[0],
    imu_statistics_path=snakemake.input.get("imu_statistics"),
)
