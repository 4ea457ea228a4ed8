# Helpers shared by the rules: config validation at parse time, input functions.
import os

from snakemake.exceptions import WorkflowError
from snakemake.utils import validate


# Closed schema; fills in defaults. Raises at parse time on unknown keys or bad values.
validate(config, schema="../schemas/config.schema.yaml")

REPO = workflow.basedir
NBATCHES = config["inference"]["nbatches"]
BATCHES = [f"{b:03d}" for b in range(NBATCHES)]
# The global model(s): the record motion model, or the nested bin-motion models
# (flidar_uq.inference.global_fit._GLOBAL_MODELS) fitted as parallel jobs.
MOTION_MODEL = config["inference"]["motion_model"]
GLOBAL_MODELS = (
    ["record"] if MOTION_MODEL == "record" else ["rho_only", "lever_arm", "lever_arm_scale"]
)


def global_model_batches(wildcards):
    """The per-bin fits a global model needs: none for the record motion model (its sigma_Z
    comes from each record's own motion, so it runs beside the per-bin fits)."""
    if wildcards.model == "record":
        return []
    return expand("results/inference/batch_{batch}", batch=BATCHES)


def scenario_file(wildcards):
    """Scenario YAML of the virtual campaign (config/scenarios/<name>.yaml)."""
    if config["campaign"]["source"] != "virtual":
        return []
    scenario = config["campaign"]["scenario"]
    if scenario.endswith((".yaml", ".yml")):
        return scenario  # a path (relative to the working directory)
    return os.path.join(REPO, "config", "scenarios", f"{scenario}.yaml")


def user_records(wildcards):
    """The user's record table when campaign.source is 'files'."""
    if config["campaign"]["source"] != "files":
        return []
    path = config["campaign"]["records"]
    if not path:
        raise ValueError("config campaign.records: empty, but campaign.source is 'files'")
    return path


def _record_columns(path):
    """Column names of the user's record table (None when it cannot be read here: the
    validate step then reports the file's error)."""
    import pandas as pd

    try:
        if str(path).lower().endswith((".parquet", ".pq")):
            import pyarrow.parquet as pq

            return list(pq.read_schema(path).names)
        return list(pd.read_csv(path, nrows=0).columns)
    except Exception:
        return None


def reference_params():
    """config["reference"] with its kind decided (flidar_uq.workflow.propagation_step.
    resolve_reference): from the virtual campaign's scenario, else required when the
    user's records carry ref_* columns (one-line error at parse time)."""
    from flidar_uq.workflow.propagation_step import resolve_reference

    virtual_kind, columns = None, None
    if config["campaign"]["source"] == "virtual":
        from flidar_uq.campaign.scenarios import reference_sampling

        virtual_kind = reference_sampling(scenario_file(None))["reference_kind"]
    elif config["campaign"]["records"]:
        columns = _record_columns(config["campaign"]["records"])
    try:
        return resolve_reference(
            dict(config["reference"]),
            virtual_kind=virtual_kind,
            record_columns=columns,
            lidar=config["campaign"]["lidar"],
        )
    except ValueError as err:
        raise WorkflowError(str(err)) from None


def bin_ids():
    """Bin ids written by checkpoint `bins` (only the fitted ones, min_count met)."""
    import pandas as pd

    table = pd.read_csv(checkpoints.bins.get().output.table)
    return [f"{int(b):04d}" for b in table.loc[table["fitted"], "bin_id"]]


def posterior_bin_files(wildcards):
    """One NetCDF posterior per fitted bin: results/posterior/bin_<id>.nc."""
    return expand("results/posterior/bin_{bin}.nc", bin=bin_ids())


def batch_of_bin(wildcards):
    """The batch directory holding the posterior of bin `wildcards.bin`."""
    import pandas as pd

    table = pd.read_csv(checkpoints.bins.get().output.table).set_index("bin_id")
    return f"results/inference/batch_{int(table.loc[int(wildcards.bin), 'batch']):03d}"


def propagation_params():
    """config["propagation"] with the "auto" sampling keys resolved: from the virtual
    campaign's scenario (source virtual), else the data-driven defaults of
    flidar_uq.workflow.propagation_step.propagate (heights counted in the records, continuous spectrum)."""
    params = dict(config["propagation"])
    sampling = {
        "scan_heights_in_turn": None,
        "scan_refocus_delay_s": [0.3, 0.7],
        "turbulence_dt_s": None,
    }
    if config["campaign"]["source"] == "virtual":
        from flidar_uq.campaign.scenarios import reference_sampling

        virtual = reference_sampling(scenario_file(None))
        sampling = {
            "scan_heights_in_turn": virtual["heights_in_turn"],
            "scan_refocus_delay_s": list(virtual["refocus_delay_s"]),
            "turbulence_dt_s": virtual["turbulence_dt_s"],
        }
    for key, value in sampling.items():
        if params[key] == "auto":
            params[key] = value
    return params
