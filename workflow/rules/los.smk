# The LOS branch (campaign.los_series + campaign.imu_series, or virtual_series: imu_los):
# LOS-level motion correction record by record (Malekmohammadi et al. (2024) least squares; Yamaguchi and Ishihara (2016) for a DBS
# lidar), beside the inference, then its agreement with the Bayesian corrected TI.

LOS_OUTPUTS = (
    ["results/los/records.csv", "results/los/agreement.csv", "results/los/agreement.png"]
    if LOS_SERIES
    else []
)

if LOS_SERIES:

    rule los_correction:
        input:
            records="results/data/records.parquet",
            los=LOS_SERIES,
            imu=IMU_SERIES,
        output:
            "results/los/corrected.csv",
        params:
            lidar=config["campaign"]["lidar"],
            lever_arm_m=los_lever_arm_m(),
            qc=config["qc"],
            chunk_rows=config["campaign"]["series_chunk_rows"],
            allow_small_angles=config["campaign"]["allow_small_angles"],
            utc_offset_h=config["campaign"]["utc_offset_h"],
        conda:
            "../envs/flidar_uq.yaml"
        log:
            "results/logs/los_correction.log",
        benchmark:
            "results/benchmarks/los_correction.tsv"
        resources:
            mem_mb=1500,
            runtime=60,
        script:
            "../scripts/los_correction.py"

    rule los_agreement:
        localrule: True
        input:
            los="results/los/corrected.csv",
            ti="results/ti/records.csv",
        output:
            records="results/los/records.csv",
            agreement=report(
                "results/los/agreement.csv", caption="../report/los_agreement.rst", category="LOS branch"
            ),
            figure="results/los/agreement.png",
        conda:
            "../envs/flidar_uq.yaml"
        log:
            "results/logs/los_agreement.log",
        benchmark:
            "results/benchmarks/los_agreement.tsv"
        script:
            "../scripts/los_agreement.py"
