"""Rule qc: QC filters with reason flags (data_steps.run_qc)."""

from flidar_uq.workflow.data_steps import run_qc
from flidar_uq.workflow.files import setup_logging

snakemake = globals()["snakemake"]  # injected by the script directive
setup_logging(snakemake.log[0])
run_qc(
    snakemake.input[0],
    snakemake.output.flags,
    snakemake.output.kept,
    snakemake.output.summary,
    dict(snakemake.params.qc),
    heights_m=snakemake.params.heights,
    allow_small_angles=snakemake.params.allow_small_angles,
    speed_bins_path=snakemake.output.speed_bins,
    hws_width_ms=snakemake.params.hws_width_ms,
    require_motion=snakemake.params.require_motion,
)
