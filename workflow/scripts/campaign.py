"""Rule campaign: the virtual campaign, or the user's record table (data_steps.make_campaign)."""

from flidar_uq.workflow.data_steps import make_campaign
from flidar_uq.workflow.files import setup_logging
from flidar_uq.workflow.inputs import step_errors_exit

# The guard keeps the generator's worker processes (spawn/forkserver re-import this
# module as __mp_main__) from re-running the rule body.
if __name__ == "__main__":
    snakemake = globals()["snakemake"]  # injected by the script directive
    setup_logging(snakemake.log[0])
    with step_errors_exit():
        make_campaign(
            snakemake.output.records,
            source=snakemake.params.source,
            seed=snakemake.params.seed,
            scenario_path=snakemake.input.scenario or None,
            records_path=snakemake.input.records or None,
            threads=snakemake.threads,
            columns=snakemake.params.columns,
            allow_small_angles=snakemake.params.allow_small_angles,
            require_motion=snakemake.params.require_motion,
            imu_out=snakemake.output.get("imu"),
            los_out=snakemake.output.get("los"),
        )
