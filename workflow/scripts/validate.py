"""Rule validate: read and validate the record table (pipeline.validate_records)."""

from flidar_uq.workflow import pipeline

snakemake = globals()["snakemake"]  # injected by the script directive
pipeline.setup_logging(snakemake.log[0])
pipeline.validate_records(snakemake.input[0], snakemake.output[0])
