"""Rule validate: read and validate the record table (data_steps.validate_records)."""

from flidar_uq.workflow.data_steps import validate_records
from flidar_uq.workflow.files import setup_logging

snakemake = globals()["snakemake"]  # injected by the script directive
setup_logging(snakemake.log[0])
validate_records(snakemake.input[0], snakemake.output[0])
