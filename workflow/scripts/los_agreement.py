"""Rule los_agreement: LOS-level beside Bayesian corrected TI (los_step.los_agreement)."""

from flidar_uq.workflow.files import setup_logging
from flidar_uq.workflow.inputs import step_errors_exit
from flidar_uq.workflow.los_step import los_agreement

snakemake = globals()["snakemake"]  # injected by the script directive
setup_logging(snakemake.log[0])
with step_errors_exit():
    los_agreement(
        los_path=snakemake.input.los,
        ti_records_path=snakemake.input.ti,
        records_out=snakemake.output.records,
        agreement_out=snakemake.output.agreement,
        figure_out=snakemake.output.figure,
    )
