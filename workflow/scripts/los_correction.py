"""Rule los_correction: LOS-level corrected TI record by record (los_step.los_correction)."""

from flidar_uq.workflow.files import setup_logging
from flidar_uq.workflow.inputs import step_errors_exit
from flidar_uq.workflow.los_step import los_correction

snakemake = globals()["snakemake"]  # injected by the script directive
setup_logging(snakemake.log[0])
with step_errors_exit():
    los_correction(
        records_path=snakemake.input.records,
        los_path=snakemake.input.los,
        imu_path=snakemake.input.imu,
        out_path=snakemake.output[0],
        lidar=snakemake.params.lidar,
        lever_arm_m=snakemake.params.lever_arm_m,
        qc_params=dict(snakemake.params.qc),
        chunk_rows=snakemake.params.chunk_rows,
        allow_small_angles=snakemake.params.allow_small_angles,
        utc_offset_h=snakemake.params.utc_offset_h,
    )
