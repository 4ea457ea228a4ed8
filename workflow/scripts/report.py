"""Rule report: the self-contained HTML report (report_step.build_report)."""

from pathlib import Path

from flidar_uq.workflow.files import setup_logging
from flidar_uq.workflow.report_step import build_report, git_revision

# optional inputs of the raw IMU series and the LOS branch (SERIES_REPORT_INPUTS, common.smk)
SERIES_KEYS = ("imu_summary", "imu_gaps", "los_records", "los_agreement", "los_figure")

snakemake = globals()["snakemake"]  # injected by the script directive
setup_logging(snakemake.log[0])
# files by name only (the report names no directory of the machine); the first is the
# input record table named on the report's first screen
campaign = snakemake.input.campaign
inputs = {f"{Path(campaign).name} (input records)": campaign}
if snakemake.params.user_records:
    user = snakemake.params.user_records
    inputs = {
        f"{Path(user).name} (input records)": user,
        f"{Path(campaign).name} (as read)": campaign,
    }
inputs[f"{Path(snakemake.input.validated).name} (validated)"] = snakemake.input.validated
for key in ("imu_series", "los_series"):  # the raw series, when given
    if path := snakemake.params.config["campaign"].get(key):
        inputs[f"{Path(path).name} ({key.replace('_', ' ')})"] = path
if trial := snakemake.params.config["validation"]["trial_posterior"]:
    inputs[f"{Path(trial).name} (trial campaign's posterior)"] = trial
inputs["requirements.lock"] = snakemake.params.lock_file
build_report(
    out_path=snakemake.output[0],
    # results/ of this campaign (results/<name>/ in a fleet): above the report's directory
    results_dir=Path(snakemake.output[0]).parents[1],
    batch_dirs=list(snakemake.input.get("batches", [])),  # the bin motion model's
    config=dict(snakemake.params.config),
    git_revision=git_revision(snakemake.params.repo),
    input_files=inputs,
    series_paths={k: snakemake.input[k] for k in SERIES_KEYS if k in snakemake.input.keys()},
    motion_missing=snakemake.params.motion_missing,  # none: the campaign was corrected
)
