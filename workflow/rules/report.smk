# The self-contained HTML report of the user's campaign, and (on demand) the developer
# report of the project's own benchmarks: `snakemake results/report/developer.html`.
import glob


rule report:
    localrule: True
    input:
        records="results/ti/records.csv",
        metrics="results/ti/metrics.csv",
        speed_bins="results/ti/speed_bins.csv",
        groups="results/ti/groups.csv",
        budget="results/ti/uncertainty_budget.csv",
        table="results/bins/table.csv",
        sigma_z="results/bins/sigma_z.csv",
        qc_summary="results/qc/summary.csv",
        roll_pitch="results/motion/roll_pitch.csv",
        global_summary="results/inference/global.csv",
        posterior="results/posterior/global.nc",
        campaign="results/campaign/records.csv",
        validated="results/data/records.csv",
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
    conda:
        "../envs/flidar_uq.yaml"
    log:
        "results/logs/report.log",
    benchmark:
        "results/benchmarks/report.tsv"
    script:
        "../scripts/report.py"


rule developer_report:
    input:
        # the charts themselves, so that a new benchmark chart reruns the developer report
        charts=sorted(glob.glob(os.path.join(REPO, config["report"]["benchmarks_dir"], "*.png"))),
    output:
        "results/report/developer.html",
    params:
        # functions: directories of the repository, not prefixes of the rule's files
        benchmarks_dir=lambda w: os.path.join(REPO, config["report"]["benchmarks_dir"]),
        repo=lambda w: REPO,
    conda:
        "../envs/flidar_uq.yaml"
    log:
        "results/logs/developer_report.log",
    script:
        "../scripts/developer_report.py"
