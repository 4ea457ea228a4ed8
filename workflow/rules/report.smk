# The self-contained HTML report of the user's campaign, and (on demand) the developer
# report of the project's own benchmarks and of the campaign's correction methods compared:
# `snakemake results/report/developer.html`.
import glob

# What the report reads of the correction (none for a campaign reported uncorrected).
CORRECTION_REPORT_INPUTS = (
    {}
    if MOTION_MISSING
    else {
        "metrics": "results/ti/metrics.csv",
        "groups": "results/ti/groups.csv",
        "budget": "results/ti/uncertainty_budget.csv",
        "table": "results/bins/table.csv",
        "sigma_z": "results/bins/sigma_z.csv",
        "roll_pitch": "results/motion/roll_pitch.csv",
        "global_summary": "results/inference/global.csv",
        "posterior": "results/posterior/global.nc",
    }
)


rule report:
    localrule: True
    input:
        records="results/ti/records.csv",
        speed_bins="results/ti/speed_bins.csv",
        qc_summary="results/qc/summary.csv",
        campaign="results/campaign/records.parquet",
        validated="results/data/records.parquet",
        **CORRECTION_REPORT_INPUTS,
        # the per-bin fits' table and diagnostics (bin motion model)
        **BIN_MODEL_REPORT_INPUTS,
        # the IMU series and LOS branch sections, when those inputs are given
        **SERIES_REPORT_INPUTS,
    output:
        report(
            "results/report/report.html", caption="../report/report_html.rst", category="Report"
        ),
    params:
        config=config,
        repo=REPO,
        user_records=config["campaign"]["records"] if config["campaign"]["source"] == "files" else "",
        lock_file=os.path.join(REPO, "requirements.lock"),
        motion_missing=list(MOTION_MISSING),
    conda:
        "../envs/flidar_uq.yaml"
    log:
        "results/logs/report.log",
    benchmark:
        "results/benchmarks/report.tsv"
    script:
        "../scripts/report.py"


# The corrected campaign's tables the developer report compares the correction methods on,
# when a run has written them (the developer report does not start the pipeline).
DEVELOPER_CAMPAIGN_INPUTS = {
    k: v
    for k, v in (("metrics", "results/ti/metrics.csv"), ("posterior", "results/posterior/global.nc"))
    if not MOTION_MISSING and os.path.exists(v)
}


rule developer_report:
    input:
        # the charts themselves, so that a new benchmark chart reruns the developer report
        charts=sorted(glob.glob(os.path.join(REPO, config["report"]["benchmarks_dir"], "*.png"))),
        **DEVELOPER_CAMPAIGN_INPUTS,
    output:
        "results/report/developer.html",
    params:
        # functions: directories of the repository, not prefixes of the rule's files
        benchmarks_dir=lambda w: os.path.join(REPO, config["report"]["benchmarks_dir"]),
        repo=lambda w: REPO,
        # results/ of this campaign (results/<name>/ in a fleet): above the report's directory
        results_dir=lambda w, output: os.path.dirname(os.path.dirname(output[0])),
    conda:
        "../envs/flidar_uq.yaml"
    log:
        "results/logs/developer_report.log",
    script:
        "../scripts/developer_report.py"
