# Helpers shared by the rules: config validation at parse time, input functions.
import os
import sys

from flidar_uq.workflow.inputs import missing_motion_columns, pipeline_preflight


# Before any job: the closed schema (package data, src/flidar_uq/resources/config.schema.yaml,
# defaults filled in), cross-key checks and, for campaign.source files, the record table read as the
# pipeline will (main process only, not in cluster jobs). A bad input stops the run here
# with one line naming the key or the file, row and column, and exit status 2 (config)
# or 3 (data); warnings are printed and the run goes on.
# In a fleet (this workflow as a module of workflow/rules/fleet.smk) the fleet checked this
# campaign's config and data already, its name in the keys: the data are not read again.
IN_FLEET = getattr(workflow.modifier, "namespace", None) is not None
_status = pipeline_preflight(config, read_data=workflow.is_main_process and not IN_FLEET)
if _status:
    sys.exit(_status)

REPO = workflow.basedir
# The motion columns the user's table lacks (no raw IMU series either): the campaign is
# then reported uncorrected, the TI as measured per height and speed bin (rule uncorrected),
# and nothing of the motion statistics, bins, fits or propagation is scheduled.
MOTION_MISSING = missing_motion_columns(config["campaign"])
NBATCHES = config["inference"]["nbatches"]
BATCHES = [f"{b:03d}" for b in range(NBATCHES)]
# The global model(s): the record motion model, or the nested bin-motion models
# (flidar_uq.inference.global_fit._GLOBAL_MODELS) fitted as parallel jobs.
MOTION_MODEL = config["inference"]["motion_model"]
GLOBAL_MODELS = (
    ["record"] if MOTION_MODEL == "record" else ["rho_only", "lever_arm", "lever_arm_scale"]
)


# What the propagation reads of the fits. The record motion model takes each record's
# sigma_Z from its own motion: it reads the record model's posterior only, and no per-bin
# fit is scheduled. The bin motion model needs the chosen global model and every
# converged bin posterior.
# validation.trial_posterior: the record-model posterior of a trial campaign (a run
# beside a reference) corrects this campaign; no global model is fitted here.
TRIAL_POSTERIOR = config["validation"]["trial_posterior"]
GLOBAL_MODEL_FILES = (
    [TRIAL_POSTERIOR]
    if TRIAL_POSTERIOR
    else expand("results/inference/global_{model}.nc", model=GLOBAL_MODELS)
)
BIN_MODEL = MOTION_MODEL == "bin" and not MOTION_MISSING
# The per-bin fits' batch directories: only the bin motion model runs them (the record
# motion model's sigma_Z comes from each record's own motion).
BIN_BATCHES = expand("results/inference/batch_{batch}", batch=BATCHES) if BIN_MODEL else []
PROPAGATION_FITS = (
    {
        "posterior": "results/posterior/global.nc",
        "bin_fits": "results/inference/bin_fits.csv",
        "batches": BIN_BATCHES,
    }
    if BIN_MODEL
    else {"posterior": GLOBAL_MODEL_FILES[0]}
)


def scenario_file(wildcards):
    """Scenario YAML of the virtual campaign (a path, or a name shipped with the package:
    flidar_uq/resources/scenarios/<name>.yaml, read from the installed package)."""
    from flidar_uq.workflow.inputs import scenario_path

    path = scenario_path(config["campaign"])
    return [] if path is None else str(path)


def user_records(wildcards):
    """The user's record table when campaign.source is 'files'."""
    if config["campaign"]["source"] != "files":
        return []
    return config["campaign"]["records"]  # non-empty: checked by pipeline_preflight


def user_part_files(wildcards):
    """The logger and reference files of a campaign in several files (source 'files')."""
    if config["campaign"]["source"] != "files":
        return []
    parts = (config["campaign"]["motion_file"], config["campaign"]["reference_file"])
    return [p["path"] for p in parts if p["path"]]


def reference_params():
    """config["reference"] resolved (flidar_uq.workflow.inputs.check_reference), as plain
    values: its kind from the virtual campaign's scenario; for the user's files the
    config's kind, checked against the records' ref_* columns by pipeline_preflight at
    parse time (one line, exit status 2)."""
    from flidar_uq.workflow.inputs import check_reference

    return check_reference(config).to_config()


def bin_ids():
    """Bin ids written by checkpoint `bins` (only the fitted ones, min_count met)."""
    import pandas as pd

    table = pd.read_csv(checkpoints.bins.get().output.table)
    return [f"{int(b):04d}" for b in table.loc[table["fitted"], "bin_id"]]


def posterior_bin_files(wildcards):
    """One NetCDF posterior per fitted bin: results/posterior/bin_<id>.nc."""
    return expand("results/posterior/bin_{bin}.nc", bin=bin_ids())


# The bin motion model's own outputs: the per-bin TI table and the per-bin posteriors
# (rule all), and what the report reads of the per-bin fits (rule report).
BIN_MODEL_OUTPUTS = ["results/ti/bins.csv", posterior_bin_files] if BIN_MODEL else []
BIN_MODEL_REPORT_INPUTS = (
    {
        "bins": "results/ti/bins.csv",
        "bin_fits": "results/inference/bin_fits.csv",
        "batches": BIN_BATCHES,
        # the per-bin posterior files (links): the report is the last step of a campaign,
        # so its results tree is complete when the report is (a fleet asks for the reports)
        "posterior_bins": posterior_bin_files,
    }
    if BIN_MODEL
    else {}
)


def batch_of_bin(wildcards):
    """The batch directory holding the posterior of bin `wildcards.bin`."""
    import pandas as pd

    table = pd.read_csv(checkpoints.bins.get().output.table).set_index("bin_id")
    return f"results/inference/batch_{int(table.loc[int(wildcards.bin), 'batch']):03d}"


def correction_settings():
    """The propagation's options (flidar_uq.correction.campaign.CorrectionSettings of the
    config, "auto" keys resolved: flidar_uq.workflow.inputs.correction_inputs), as plain
    values."""
    from dataclasses import asdict

    from flidar_uq.workflow.inputs import correction_inputs

    return asdict(correction_inputs(config)[1])


def _series_paths():
    """(IMU series, LOS series) of the run, '' when absent: the user's files (source files)
    or the virtual campaign's (campaign.virtual_series); the keys were checked together by
    pipeline_preflight."""
    c = config["campaign"]
    if c["source"] == "virtual":
        return (
            "results/campaign/imu.parquet" if c["virtual_series"] != "none" else "",
            "results/campaign/los.parquet" if c["virtual_series"] == "imu_los" else "",
        )
    return c["imu_series"], c["los_series"]


# The raw series of the run ('' = none): the imu_statistics rule and the LOS branch run
# only when they are given.
IMU_SERIES, LOS_SERIES = _series_paths()
# Written by the campaign step beside the records when the virtual campaign gives its series.
VIRTUAL_SERIES_OUTPUTS = {
    k: v
    for k, v in (("imu", IMU_SERIES), ("los", LOS_SERIES))
    if v and config["campaign"]["source"] == "virtual"
}
# Optional inputs of the report (the IMU summary and gaps, the LOS agreement).
SERIES_REPORT_INPUTS = (
    {"imu_summary": "results/imu/summary.csv", "imu_gaps": "results/imu/gaps.csv"}
    if IMU_SERIES
    else {}
) | (
    {
        "los_records": "results/los/records.csv",
        "los_agreement": "results/los/agreement.csv",
        "los_figure": "results/los/agreement.png",
    }
    if LOS_SERIES
    else {}
)


def los_lever_arm_m():
    """Lidar head from the buoy's rotation centre (body frame, m) for the LOS correction:
    (0, 0, inference.lever_arm_m) when given (required with the user's LOS series, checked
    by pipeline_preflight), else the virtual campaign's scenario value."""
    if config["inference"]["lever_arm_m"] is not None:
        return [0.0, 0.0, float(config["inference"]["lever_arm_m"])]
    from flidar_uq.campaign.scenarios import CampaignConfig, load_scenario

    settings = CampaignConfig.from_dict(load_scenario(scenario_file(None))).settings
    return [float(x) for x in settings["lidar"]["lever_arm_m"]]
