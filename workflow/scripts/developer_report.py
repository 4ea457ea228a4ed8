"""Rule developer_report: the project's benchmarks and the campaign's correction methods
compared (report_step.build_developer_report)."""

from flidar_uq.workflow.files import setup_logging
from flidar_uq.workflow.report_step import build_developer_report, git_revision

snakemake = globals()["snakemake"]  # injected by the script directive
setup_logging(snakemake.log[0])
build_developer_report(
    out_path=snakemake.output[0],
    benchmarks_dir=snakemake.params.benchmarks_dir,
    git_revision=git_revision(snakemake.params.repo),
    results_dir=snakemake.params.results_dir,
)
