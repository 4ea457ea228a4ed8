"""Rule report: the self-contained HTML report (pipeline.build_report)."""

from flidar_uq.workflow import pipeline

snakemake = globals()["snakemake"]  # injected by the script directive
pipeline.setup_logging(snakemake.log[0])
pipeline.build_report(
    out_path=snakemake.output[0],
    results_dir="results",
    batch_dirs=list(snakemake.input.batches),
    config=dict(snakemake.params.config),
    benchmarks_dir=snakemake.params.benchmarks_dir,
    git_revision=pipeline.git_revision(snakemake.params.repo),
)
