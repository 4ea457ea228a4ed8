# flidar_uq: floating-lidar motion -> turbulence-intensity uncertainty.
#
#   campaign -> validate -> qc -> motion statistics -> bins (checkpoint) -> sigma_Z per bin
#   -> global fit (the record motion model; with inference.motion_model bin: inference per
#   bin, batched fan-out, and the global models on them) -> propagation -> report
#   (a table without motion statistics: campaign -> validate -> qc -> uncorrected -> report)
#
# Run: `.venv/bin/snakemake --cores all` (config/config.yaml); see README.md for own data,
# a fleet of campaigns (config key campaigns) and SLURM (profiles/slurm).

from snakemake.utils import min_version

min_version("9.0")


configfile: os.path.join(workflow.basedir, "config", "config.yaml")


# `snakemake --report report.html` (after a run): this description and the captions of the
# main outputs (workflow/report/*.rst, attached with report(...) in the rules).
report: "workflow/report/workflow.rst"


# Bit-identical results on every executor (local, SLURM) of the same CPU type:
# single-threaded BLAS/OpenMP in every job, so floating-point sums do not depend on the
# cores a job happens to get (the CPU's BLAS kernel and SIMD loops do: README,
# "Reproducibility across machines").
# Parallelism comes from concurrent jobs and the campaign generator's worker processes.
for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ[_var] = "1"


if "campaigns" in config:

    # A fleet: every campaign of `campaigns:` is this same workflow as a module writing
    # results/<name>/, plus the fleet summary (results/fleet/); workflow/rules/fleet.smk.
    include: "workflow/rules/fleet.smk"

    # (here, not in fleet.smk: an included file's default target is not kept)
    rule all:
        input:
            f"{FLEET_SUMMARY}.csv",
            f"{FLEET_SUMMARY}.html",
            f"{FLEET_SUMMARY}.png",
        default_target: True
        localrule: True

else:

    # One campaign: results/ (the output contract of README.md). Light steps (rules marked
    # `localrule: True`) run on the submitting host under a cluster executor; campaign
    # generation, the global models, the propagation and (bin motion model) the per-bin
    # inference batches go to the cluster.
    include: "workflow/rules/common.smk"
    include: "workflow/rules/data.smk"

    # without motion statistics: no fit and no propagation (rule uncorrected, data.smk)
    if not MOTION_MISSING:

        include: "workflow/rules/inference.smk"

    include: "workflow/rules/report.smk"
    include: "workflow/rules/los.smk"

    rule all:
        input:
            "results/ti/records.csv",
            [] if MOTION_MISSING else "results/posterior/global.nc",
            "results/report/report.html",
            LOS_OUTPUTS,
            BIN_MODEL_OUTPUTS,
        default_target: True
        localrule: True
