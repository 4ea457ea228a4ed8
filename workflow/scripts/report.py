"""Rule report: the self-contained HTML report (report_step.build_report)."""

from flidar_uq.workflow.files import setup_logging
from flidar_uq.workflow.report_step import build_report, git_revision

snakemake = globals()["snakemake"]  # injected by the script directive
setup_logging(snakemake.log[0])
build_report(
    out_path=snakemake.output[0],
    results_dir="results",
    batch_dirs=list(snakemake.input.batches),
    config=dict(snakemake.params.config),
    benchmarks_dir=snakemake.params.benchmarks_dir,
    git_revision=git_revision(snakemake.params.repo),
)
