"""Rule qc: QC filters with reason flags (pipeline.run_qc)."""

from flidar_uq.workflow import pipeline

snakemake = globals()["snakemake"]  # injected by the script directive
pipeline.setup_logging(snakemake.log[0])
pipeline.run_qc(
    snakemake.input[0],
    snakemake.output.flags,
    snakemake.output.kept,
    snakemake.output.summary,
    dict(snakemake.params.qc),
)
