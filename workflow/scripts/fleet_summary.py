"""Rule fleet_summary: the campaigns of a fleet side by side (fleet.fleet_summary)."""

from pathlib import Path

from flidar_uq.workflow.files import setup_logging
from flidar_uq.workflow.fleet import fleet_summary

snakemake = globals()["snakemake"]  # injected by the script directive
setup_logging(snakemake.log[0])
fleet_summary(
    # results/<name>/ of each campaign: above its ti/records.csv
    {
        name: Path(path).parents[1]
        for name, path in zip(snakemake.params.campaigns, snakemake.input.records, strict=True)
    },
    table_out=snakemake.output.table,
    html_out=snakemake.output.html,
    figure_out=snakemake.output.figure,
)
