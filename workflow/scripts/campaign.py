"""Rule campaign: the virtual campaign, or the user's record table (data_steps.make_campaign)."""

from flidar_uq.workflow.data_steps import make_campaign
from flidar_uq.workflow.files import setup_logging

# The guard keeps the generator's worker processes (spawn/forkserver re-import this
# module as __mp_main__) from re-running the rule body.
if __name__ == "__main__":
    snakemake = globals()["snakemake"]  # injected by the script directive
    setup_logging(snakemake.log[0])
    make_campaign(
        snakemake.output.records,
        source=snakemake.params.source,
        seed=snakemake.params.seed,
        scenario_path=snakemake.input.scenario or None,
        records_path=snakemake.input.records or None,
        threads=snakemake.threads,
        require_motion=snakemake.params.require_motion,
        imu_out=snakemake.output.get("imu"),
        los_out=snakemake.output.get("los"),
    )
