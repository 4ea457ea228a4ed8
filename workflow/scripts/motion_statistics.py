"""Rule motion_statistics: per-record motion amplitude/period (data_steps.motion_statistics)."""

from flidar_uq.workflow.data_steps import motion_statistics
from flidar_uq.workflow.files import setup_logging

snakemake = globals()["snakemake"]  # injected by the script directive
setup_logging(snakemake.log[0])
motion_statistics(
    snakemake.input.records,
    snakemake.input.kept,
    snakemake.output.records,
    snakemake.output.roll_pitch,
)
