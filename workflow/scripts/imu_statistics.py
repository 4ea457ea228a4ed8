"""Rule imu_statistics: per-record motion statistics of the raw IMU series (imu_step.imu_statistics)."""

from flidar_uq.workflow.files import setup_logging
from flidar_uq.workflow.imu_step import imu_statistics
from flidar_uq.workflow.inputs import step_errors_exit

snakemake = globals()["snakemake"]  # injected by the script directive
setup_logging(snakemake.log[0])
with step_errors_exit():
    imu_statistics(
        snakemake.input.records,
        snakemake.input.imu,
        snakemake.output.statistics,
        snakemake.output.gaps,
        snakemake.output.summary,
        chunk_rows=snakemake.params.chunk_rows,
        min_coverage_pct=snakemake.params.min_coverage_pct,
        allow_small_angles=snakemake.params.allow_small_angles,
        heading_convention=snakemake.params.heading_convention,
    )
