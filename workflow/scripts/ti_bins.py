"""Rule ti_bins: the per-bin table of corrected TI with the bins' fit status (propagation_step.bin_table)."""

from flidar_uq.workflow.files import setup_logging
from flidar_uq.workflow.propagation_step import bin_table

snakemake = globals()["snakemake"]  # injected by the script directive
setup_logging(snakemake.log[0])
bin_table(
    table_path=snakemake.input.table,
    sigma_z_path=snakemake.input.sigma_z,
    bin_fits_path=snakemake.input.bin_fits,
    records_path=snakemake.input.records,
    out_path=snakemake.output[0],
)
