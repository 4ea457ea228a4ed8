"""Rule propagate: corrected TI with credible intervals per record and bin (propagation_step.propagate)."""

from pathlib import Path

from flidar_uq.workflow.files import setup_logging
from flidar_uq.workflow.propagation_step import propagate

snakemake = globals()["snakemake"]  # injected by the script directive
setup_logging(snakemake.log[0])
out_dir = Path(snakemake.output.records).parent
# to_files writes the five tables of the rule's outputs, all in one directory
assert all(Path(p).parent == out_dir for p in snakemake.output), snakemake.output
propagate(
    records_path=snakemake.input.records,
    flags_path=snakemake.input.flags,
    assignments_path=snakemake.input.assignments,
    table_path=snakemake.input.table,
    sigma_z_path=snakemake.input.sigma_z,
    bin_fits_path=snakemake.input.get("bin_fits"),
    batch_dirs=list(snakemake.input.get("batches", [])),
    global_path=snakemake.input.posterior,
    out_dir=out_dir,
    reference=dict(snakemake.params.reference),
    settings=dict(snakemake.params.settings),
)
