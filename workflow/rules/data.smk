# Campaign -> validate -> QC -> motion statistics -> bins -> sigma_Z per bin.
# The record table is written twice (Parquet): as the campaign gives it and validated.
# QC, the motion statistics and the bins write only the record ids they keep and the
# columns they add (flidar_uq.workflow.data_steps.kept_records joins them back).


rule campaign:
    input:
        scenario=scenario_file,
        records=user_records,
        parts=user_part_files,
    output:
        records="results/campaign/records.parquet",
        join="results/campaign/join.csv",
        source="results/campaign/source.json",
        **VIRTUAL_SERIES_OUTPUTS,
    params:
        source=config["campaign"]["source"],
        scenario=config["campaign"]["scenario"],
        seed=config["campaign"]["seed"],
        columns=config["campaign"]["columns"] if config["campaign"]["source"] == "files" else {},
        allow_small_angles=config["campaign"]["allow_small_angles"],
        # motion columns may be absent from the user's table when an IMU series gives them,
        # or the campaign is reported uncorrected (MOTION_MISSING)
        require_motion=not (IMU_SERIES or MOTION_MISSING),
        conventions={
            k: config["campaign"][k]
            for k in (
                "format",
                "utc_offset_h",
                "timestamp_at",
                "heading_convention",
                "extra_columns",
                "motion_file",
                "reference_file",
            )
        },
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


# Motion statistics of every record from the raw IMU series, streamed in chunks; the IMU
# gaps are reported (results/imu/gaps.csv) and flagged by QC (imu_gap) through the records'
# imu_availability_pct.
if IMU_SERIES:

    rule imu_statistics:
        input:
            records="results/campaign/records.parquet",
            imu=IMU_SERIES,
        output:
            statistics="results/imu/statistics.csv",
            gaps="results/imu/gaps.csv",
            summary="results/imu/summary.csv",
        params:
            chunk_rows=config["campaign"]["series_chunk_rows"],
            min_coverage_pct=config["qc"]["imu_availability_min_pct"],
            allow_small_angles=config["campaign"]["allow_small_angles"],
            heading_convention=config["campaign"]["heading_convention"],
        conda:
            "../envs/flidar_uq.yaml"
        log:
            "results/logs/imu_statistics.log",
        benchmark:
            "results/benchmarks/imu_statistics.tsv"
        resources:
            mem_mb=1000,
        script:
            "../scripts/imu_statistics.py"


rule validate:
    localrule: True
    input:
        records="results/campaign/records.parquet",
        # the IMU series' statistics replace the table's motion columns (the series wins)
        **({"imu_statistics": "results/imu/statistics.csv"} if IMU_SERIES else {}),
    output:
        records="results/data/records.parquet",
        report="results/data/validation.json",
    params:
        allow_small_angles=config["campaign"]["allow_small_angles"],
        qc=config["qc"],
        heights=config["campaign"]["heights"],
        require_motion=not MOTION_MISSING,
    conda:
        "../envs/flidar_uq.yaml"
    log:
        "results/logs/validate.log",
    benchmark:
        "results/benchmarks/validate.tsv"
    script:
        "../scripts/validate.py"


rule qc:
    localrule: True
    input:
        "results/data/records.parquet",
    output:
        flags="results/qc/flags.csv",
        kept="results/qc/kept.parquet",
        summary="results/qc/summary.csv",
        speed_bins="results/qc/speed_bins.csv",
    params:
        qc=config["qc"],
        hws_width_ms=config["binning"]["hws_width_ms"],
        heights=config["campaign"]["heights"],
        allow_small_angles=config["campaign"]["allow_small_angles"],
        require_motion=not MOTION_MISSING,
    conda:
        "../envs/flidar_uq.yaml"
    log:
        "results/logs/qc.log",
    benchmark:
        "results/benchmarks/qc.tsv"
    script:
        "../scripts/qc.py"


# Without motion statistics (MOTION_MISSING) the TI is reported as measured, in the tables
# of a corrected run (the corrected columns NaN); no motion statistics, bins or fits.
if MOTION_MISSING:

    rule uncorrected:
        localrule: True
        input:
            records="results/data/records.parquet",
            flags="results/qc/flags.csv",
        output:
            records=report(
                "results/ti/records.csv", caption="../report/records.rst", category="TI"
            ),
            speed_bins=report(
                "results/ti/speed_bins.csv", caption="../report/speed_bins.rst", category="TI"
            ),
        params:
            min_count=config["report"]["group_min_count"],
        conda:
            "../envs/flidar_uq.yaml"
        log:
            "results/logs/uncorrected.log",
        benchmark:
            "results/benchmarks/uncorrected.tsv"
        script:
            "../scripts/uncorrected.py"


rule motion_statistics:
    localrule: True
    input:
        records="results/data/records.parquet",
        kept="results/qc/kept.parquet",
    output:
        records="results/motion/records.parquet",
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
    localrule: True
    input:
        records="results/data/records.parquet",
        motion="results/motion/records.parquet",
    output:
        assignments="results/bins/assignments.parquet",
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
    localrule: True
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
    # one second, and the propagation needs it: run before the per-bin batches take the
    # cores (the greedy scheduler does not pass propagate's priority on to its inputs)
    priority: 10
    script:
        "../scripts/sigma_z.py"
