"""Rule sigma_z: sigma_Z and E(Z) per bin centre (data_steps.sigma_z_table)."""

from flidar_uq.workflow.data_steps import sigma_z_table
from flidar_uq.workflow.files import setup_logging

snakemake = globals()["snakemake"]  # injected by the script directive
setup_logging(snakemake.log[0])
sigma_z_table(snakemake.input[0], snakemake.output[0], lidar=snakemake.params.lidar)
