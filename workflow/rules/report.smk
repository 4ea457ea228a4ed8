# The self-contained HTML report.


rule report:
    input:
        records="results/ti/records.csv",
        bins="results/ti/bins.csv",
        metrics="results/ti/metrics.csv",
        speed_bins="results/ti/speed_bins.csv",
        table="results/bins/table.csv",
        sigma_z="results/bins/sigma_z.csv",
        qc_summary="results/qc/summary.csv",
        roll_pitch="results/motion/roll_pitch.csv",
        bin_fits="results/inference/bin_fits.csv",
        global_summary="results/inference/global.csv",
        posterior="results/posterior/global.nc",
        batches=expand("results/inference/batch_{batch}", batch=BATCHES),
        # the IMU series and LOS branch sections, when those inputs are given
        **SERIES_REPORT_INPUTS,
    output:
        report(
            "results/report/report.html", caption="../report/report_html.rst", category="Report"
        ),
    params:
        config=config,
        benchmarks_dir=os.path.join(REPO, config["report"]["benchmarks_dir"]),
        repo=REPO,
    conda:
        "../envs/flidar_uq.yaml"
    log:
        "results/logs/report.log",
    benchmark:
        "results/benchmarks/report.tsv"
    script:
        "../scripts/report.py"
