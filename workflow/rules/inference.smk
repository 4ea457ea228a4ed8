# The global fit (the record motion model), propagation, and with inference.motion_model
# bin: per-bin inference (fan-out over a fixed number of batch jobs, each fitting several
# bins), the per-bin posterior files, the three global models (gather, in parallel), the
# choice among them by PSIS-LOO, and the per-bin TI table. Under the record motion model
# no rule asks for the per-bin fits, so none is scheduled.


rule infer_batch:
    input:
        records="results/data/records.parquet",
        motion="results/motion/records.parquet",
        assignments="results/bins/assignments.parquet",
        table="results/bins/table.csv",
    output:
        directory("results/inference/batch_{batch}"),
    params:
        inference=config["inference"],
        priors=config["priors"],
    conda:
        "../envs/flidar_uq.yaml"
    log:
        "results/logs/infer_batch_{batch}.log",
    benchmark:
        "results/benchmarks/infer_batch_{batch}.tsv"
    resources:
        mem_mb=1000,
        runtime=30,
    script:
        "../scripts/infer_batch.py"


rule posterior_bin:
    localrule: True
    input:
        batch_of_bin,
    output:
        "results/posterior/bin_{bin}.nc",
    params:
        # relative link target (portable: BSD ln has no -r)
        target=lambda wildcards, input, output: os.path.relpath(
            os.path.join(input[0], f"bin_{wildcards.bin}.nc"), os.path.dirname(output[0])
        ),
    conda:
        "../envs/flidar_uq.yaml"
    log:
        "results/logs/posterior_bin_{bin}.log",
    # a relative symbolic link to the batch's file, not a copy (output size); the
    # link itself is new, so its own time stamp (which Snakemake reads) follows the batch.
    # No benchmark: a year has ~300 bins, and monitoring each cost CPU that the fits
    # running beside these jobs lost
    shell:
        "ln -sf {params.target} {output} 2> {log}"


rule fit_global_model:
    input:
        batches=BIN_BATCHES,
        records="results/data/records.parquet",
        motion="results/motion/records.parquet",
        assignments="results/bins/assignments.parquet",
    output:
        "results/inference/global_{model}.nc",
    wildcard_constraints:
        model="|".join(GLOBAL_MODELS),
    params:
        inference=config["inference"],
        priors=config["priors"],
        lidar=config["campaign"]["lidar"],
        reference=reference_params(),
        # the propagate rule's settings: the reference noise of the fit is the propagation's
        correction=correction_settings(),
        # validation.holdout: the reference of the held-out records is not fitted
        holdout=config["validation"]["holdout"],
    conda:
        "../envs/flidar_uq.yaml"
    log:
        "results/logs/fit_global_{model}.log",
    benchmark:
        "results/benchmarks/fit_global_{model}.tsv"
    # the longest single job of the fits: started first, so that the other jobs (with the
    # bin motion model, the per-bin batches) fill the other cores beside it instead of
    # leaving it to run alone at the end
    priority: 10
    resources:
        mem_mb=1500,
        runtime=30,
    script:
        "../scripts/fit_global_model.py"


rule fit_global:
    localrule: True
    input:
        models=GLOBAL_MODEL_FILES,
        batches=BIN_BATCHES,
    output:
        posterior="results/posterior/global.nc",
        summary=report(
            "results/inference/global.csv", caption="../report/global.rst", category="Inference"
        ),
        # the per-bin fits' summaries (bin motion model)
        **({"bin_fits": "results/inference/bin_fits.csv"} if BIN_MODEL else {}),
    params:
        inference=config["inference"],
    conda:
        "../envs/flidar_uq.yaml"
    log:
        "results/logs/fit_global.log",
    benchmark:
        "results/benchmarks/fit_global.tsv"
    script:
        "../scripts/fit_global.py"


rule propagate:
    input:
        records="results/data/records.parquet",
        assignments="results/bins/assignments.parquet",
        table="results/bins/table.csv",
        sigma_z="results/bins/sigma_z.csv",
        flags="results/qc/flags.csv",
        **PROPAGATION_FITS,
    output:
        records=report(
            "results/ti/records.csv", caption="../report/records.rst", category="Corrected TI"
        ),
        speed_bins=report(
            "results/ti/speed_bins.csv", caption="../report/speed_bins.rst", category="Corrected TI"
        ),
        metrics=report(
            "results/ti/metrics.csv", caption="../report/metrics.rst", category="Corrected TI"
        ),
        groups=report(
            "results/ti/groups.csv", caption="../report/groups.rst", category="Corrected TI"
        ),
        budget=report(
            "results/ti/uncertainty_budget.csv",
            caption="../report/uncertainty_budget.rst",
            category="Corrected TI",
        ),
    params:
        settings=correction_settings(),
        reference=reference_params(),
        qc=config["qc"],
    conda:
        "../envs/flidar_uq.yaml"
    log:
        "results/logs/propagate.log",
    benchmark:
        "results/benchmarks/propagate.tsv"
    # the second link of the longest chain (global fit -> propagation): started as soon as
    # the fit ends
    priority: 5
    script:
        "../scripts/propagate.py"


rule ti_bins:
    localrule: True
    input:
        table="results/bins/table.csv",
        sigma_z="results/bins/sigma_z.csv",
        bin_fits="results/inference/bin_fits.csv",
        records="results/ti/records.csv",
    output:
        report("results/ti/bins.csv", caption="../report/bins.rst", category="Corrected TI"),
    conda:
        "../envs/flidar_uq.yaml"
    log:
        "results/logs/ti_bins.log",
    benchmark:
        "results/benchmarks/ti_bins.tsv"
    script:
        "../scripts/ti_bins.py"
