"""Rule motion_statistics: per-record motion amplitude/period (pipeline.motion_statistics)."""

from flidar_uq.workflow import pipeline

snakemake = globals()["snakemake"]  # injected by the script directive
pipeline.setup_logging(snakemake.log[0])
pipeline.motion_statistics(
    snakemake.input[0], snakemake.output.records, snakemake.output.roll_pitch
)
