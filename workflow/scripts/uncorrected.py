"""Rule uncorrected: results/ti/ of a campaign without motion statistics, the TI as
measured (data_steps.uncorrected_ti)."""

from flidar_uq.workflow.data_steps import uncorrected_ti
from flidar_uq.workflow.files import setup_logging

snakemake = globals()["snakemake"]  # injected by the script directive
setup_logging(snakemake.log[0])
uncorrected_ti(
    snakemake.input.records,
    snakemake.input.flags,
    snakemake.output.records,
    snakemake.output.speed_bins,
    min_count=snakemake.params.min_count,
)
