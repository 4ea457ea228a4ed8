"""Rule propagate: corrected TI with credible intervals per record and bin (propagation_step.propagate)."""

from flidar_uq.workflow.files import setup_logging
from flidar_uq.workflow.propagation_step import propagate

snakemake = globals()["snakemake"]  # injected by the script directive
setup_logging(snakemake.log[0])
propagate(
    records_path=snakemake.input.records,
    flags_path=snakemake.input.flags,
    assignments_path=snakemake.input.assignments,
    table_path=snakemake.input.table,
    sigma_z_path=snakemake.input.sigma_z,
    bin_fits_path=snakemake.input.get("bin_fits"),
    batch_dirs=list(snakemake.input.get("batches", [])),
    global_path=snakemake.input.posterior,
    records_out=snakemake.output.records,
    speed_bins_out=snakemake.output.speed_bins,
    metrics_out=snakemake.output.metrics,
    groups_out=snakemake.output.groups,
    budget_out=snakemake.output.budget,
    sector_width_deg=snakemake.params.sector_width_deg,
    min_count=snakemake.params.group_min_count,
    seed=snakemake.params.seed,
    lidar=snakemake.params.lidar,
    reference=dict(snakemake.params.reference),
    **dict(snakemake.params.propagation),
)
