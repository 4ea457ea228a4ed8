"""Rule sigma_z: sigma_Z and E(Z) per bin centre (pipeline.sigma_z_table)."""

from flidar_uq.workflow import pipeline

snakemake = globals()["snakemake"]  # injected by the script directive
pipeline.setup_logging(snakemake.log[0])
pipeline.sigma_z_table(snakemake.input[0], snakemake.output[0], lidar=snakemake.params.lidar)
