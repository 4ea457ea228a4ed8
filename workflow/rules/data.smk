# Campaign -> validate -> QC -> motion statistics -> bins -> sigma_Z per bin.


rule campaign:
    input:
        scenario=scenario_file,
        records=user_records,
    output:
        "results/campaign/records.csv",
    params:
        source=config["campaign"]["source"],
        scenario=config["campaign"]["scenario"],
        seed=config["campaign"]["seed"],
        columns=config["campaign"]["columns"] if config["campaign"]["source"] == "files" else {},
        allow_small_angles=config["campaign"]["allow_small_angles"],
    conda:
        "../envs/flidar_uq.yaml"
    log:
        "results/logs/campaign.log",
    benchmark:
        "results/benchmarks/campaign.tsv"
    threads: 2
    resources:
        mem_mb=2000,
    script:
        "../scripts/campaign.py"


rule validate:
    input:
        "results/campaign/records.csv",
    output:
        records="results/data/records.csv",
        report="results/data/validation.json",
    params:
        allow_small_angles=config["campaign"]["allow_small_angles"],
        qc=config["qc"],
        heights=config["campaign"]["heights"],
    conda:
        "../envs/flidar_uq.yaml"
    log:
        "results/logs/validate.log",
    benchmark:
        "results/benchmarks/validate.tsv"
    script:
        "../scripts/validate.py"


rule qc:
    input:
        "results/data/records.csv",
    output:
        flags="results/qc/flags.csv",
        kept="results/qc/kept.csv",
        summary="results/qc/summary.csv",
    params:
        qc=config["qc"],
        heights=config["campaign"]["heights"],
        allow_small_angles=config["campaign"]["allow_small_angles"],
    conda:
        "../envs/flidar_uq.yaml"
    log:
        "results/logs/qc.log",
    benchmark:
        "results/benchmarks/qc.tsv"
    script:
        "../scripts/qc.py"


rule motion_statistics:
    input:
        "results/qc/kept.csv",
    output:
        records="results/motion/records.csv",
        roll_pitch="results/motion/roll_pitch.csv",
    conda:
        "../envs/flidar_uq.yaml"
    log:
        "results/logs/motion_statistics.log",
    benchmark:
        "results/benchmarks/motion_statistics.tsv"
    script:
        "../scripts/motion_statistics.py"


checkpoint bins:
    input:
        "results/motion/records.csv",
    output:
        assignments="results/bins/assignments.csv",
        table="results/bins/table.csv",
    params:
        binning=config["binning"],
        nbatches=NBATCHES,
    conda:
        "../envs/flidar_uq.yaml"
    log:
        "results/logs/bins.log",
    benchmark:
        "results/benchmarks/bins.tsv"
    script:
        "../scripts/bins.py"


rule sigma_z:
    input:
        "results/bins/table.csv",
    output:
        "results/bins/sigma_z.csv",
    params:
        lidar=config["campaign"]["lidar"],
    conda:
        "../envs/flidar_uq.yaml"
    log:
        "results/logs/sigma_z.log",
    benchmark:
        "results/benchmarks/sigma_z.tsv"
    script:
        "../scripts/sigma_z.py"
