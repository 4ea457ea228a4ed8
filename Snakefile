# flidar_uq: floating-lidar motion -> turbulence-intensity uncertainty.
#
#   campaign -> validate -> qc -> motion statistics -> bins (checkpoint) -> sigma_Z per bin
#   -> inference per bin (batched fan-out) -> global rho (gather) -> propagation -> report
#
# Run: `.venv/bin/snakemake --cores all` (config/config.yaml); see README.md for own data
# and SLURM (profiles/slurm).

from snakemake.utils import min_version

min_version("9.0")


configfile: os.path.join(workflow.basedir, "config", "config.yaml")


include: "workflow/rules/common.smk"
include: "workflow/rules/data.smk"
include: "workflow/rules/inference.smk"
include: "workflow/rules/report.smk"


rule all:
    input:
        "results/ti/records.csv",
        "results/ti/bins.csv",
        "results/posterior/global.nc",
        posterior_bin_files,
        "results/report/report.html",
    default_target: True
