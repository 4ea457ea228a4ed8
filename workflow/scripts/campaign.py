"""Rule campaign: the virtual campaign, or the user's record table (data_steps.make_campaign)."""

# Everything under the guard: the generator's spawned worker processes re-run this module
# as __mp_main__ (imports included), so that they neither re-run the rule body nor import
# the workflow layer (and pandas) they do not need.
if __name__ == "__main__":
    from flidar_uq.workflow.data_steps import make_campaign
    from flidar_uq.workflow.files import setup_logging
    from flidar_uq.workflow.inputs import step_errors_exit

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
            conventions=dict(snakemake.params.conventions),
            join_out=snakemake.output.join,
            source_out=snakemake.output.source,
            imu_out=snakemake.output.get("imu"),
            los_out=snakemake.output.get("los"),
        )
