"""The user's config and data, checked before any expensive step.

What is checked: the config, the record table and what the pipeline will make of it.

One policy for the command line (``flidar-uq validate``) and the pipeline (checked when
the Snakefile is parsed, :func:`pipeline_preflight`, and by the ``validate`` rule):

* every bad input is one line naming the file, row and column, or the config key;
* the exit status says which class of problem it is (:data:`EXIT_CODES`):
  ``2`` a usage error (command line, config key missing, unknown or out of range),
  ``3`` bad data (a file missing, unreadable, malformed, in the wrong units or
  inconsistent), ``1`` an internal error (a bug: please report it);
* what would later make whole groups of records uncorrectable is reported as a warning
  (:func:`inspect_records`), and the pipeline refuses to start on what would make every
  record uncorrectable (a reference mean without a reference std).
"""

from __future__ import annotations

import difflib
import logging
import os
import re
import sys
from collections.abc import Iterable, Mapping
from contextlib import contextmanager
from pathlib import Path
from typing import TYPE_CHECKING

if TYPE_CHECKING:  # numpy and pandas are imported where used: `flidar-uq --help` stays fast
    import pandas as pd

from flidar_uq.resources import resource_path

log = logging.getLogger(__name__)

__all__ = [
    "EXIT_CODES",
    "EXIT_DATA",
    "EXIT_INTERNAL",
    "EXIT_OK",
    "EXIT_USAGE",
    "SCHEMA_PATH",
    "FLEET_DIR",
    "ConfigError",
    "campaign_configs",
    "check_config",
    "check_reference",
    "check_series",
    "correction_inputs",
    "exit_status",
    "inspect_records",
    "load_config_file",
    "missing_motion_columns",
    "pipeline_preflight",
    "read_campaign_records",
    "resolve_propagation",
    "scenario_path",
    "settings_from_config",
    "step_errors_exit",
]

EXIT_OK = 0
EXIT_INTERNAL = 1
EXIT_USAGE = 2
EXIT_DATA = 3
#: Exit status -> meaning, for the command line's --help and the README.
EXIT_CODES = {
    EXIT_OK: "success (warnings, if any, on stderr)",
    EXIT_INTERNAL: "internal error (a bug; please report it with the command)",
    EXIT_USAGE: "usage error: bad command-line argument or config key (missing, unknown, "
    "out of range)",
    EXIT_DATA: "bad data: an input file missing, unreadable, malformed, in wrong units or "
    "inconsistent",
}

#: The closed config schema of the pipeline (package data: ``flidar_uq/resources/``).
SCHEMA_PATH = resource_path("config.schema.yaml")

#: The fleet summary's directory under results/ (a name no campaign of ``campaigns:`` may take).
FLEET_DIR = "fleet"


class ConfigError(ValueError):
    """A config key missing, unknown or out of range; the message names the key.

    Attributes
    ----------
    key : str
        Dotted key (``"qc.sv_max"``), or the config file for a file-level problem.
    """

    def __init__(self, key: str, problem: str, *, message: str | None = None) -> None:
        self.key, self.problem, self.message = key, problem, message
        super().__init__(message or f"config key {key}: {problem}")

    def in_campaign(self, name: str) -> ConfigError:
        """The same problem in campaign ``name`` of a fleet: the key becomes
        ``campaigns.<name>.<key>``."""
        key = f"campaigns.{name}.{self.key}"
        message = f"campaigns.{name}: {self.message}" if self.message else None
        return ConfigError(key, self.problem, message=message)


# --------------------------------------------------------------------------- config


def load_config_file(path: str | os.PathLike) -> dict:
    """Read a YAML config file (the pipeline's format), without defaults.

    Raises
    ------
    ConfigError
        When the file is missing, not YAML or not a mapping (key: the file).
    """
    import yaml

    p = Path(path)
    if not p.is_file():
        raise ConfigError(str(p), "no such config file")
    try:
        with open(p, encoding="utf-8") as fh:
            data = yaml.safe_load(fh)
    except (yaml.YAMLError, UnicodeDecodeError) as exc:
        mark = getattr(exc, "problem_mark", None)
        where = f" (line {mark.line + 1})" if mark is not None else ""
        raise ConfigError(str(p), f"not valid YAML{where}") from None
    if data is None:
        return {}
    if not isinstance(data, dict):
        raise ConfigError(str(p), f"must hold a mapping of sections, got {type(data).__name__}")
    return data


def _load_schema() -> dict:
    import yaml

    with open(SCHEMA_PATH, encoding="utf-8") as fh:
        return yaml.safe_load(fh)


def _fill_defaults(config: dict, schema: dict) -> None:
    for key, sub in schema.get("properties", {}).items():
        if key not in config and "default" in sub:
            default = sub["default"]
            config[key] = dict(default) if isinstance(default, dict) else default
        if sub.get("type") == "object" and isinstance(config.get(key), dict):
            _fill_defaults(config[key], sub)


def _schema_error(err, schema: dict) -> ConfigError:
    """One line for a jsonschema error: the dotted key and the problem."""
    path = [str(p) for p in err.absolute_path]
    if (
        err.validator == "additionalProperties"
        and isinstance(err.instance, dict)
        and "patternProperties" in err.schema
    ):  # a name of the campaigns: mapping
        pattern = next(iter(err.schema["patternProperties"]))
        bad = sorted(str(k) for k in err.instance if not re.search(pattern, str(k)))
        name = bad[0] if bad else "?"
        return ConfigError(
            ".".join([*path, name]),
            "not a campaign name (a letter, then letters, digits or '_'; at most 40 characters)",
        )
    if err.validator == "additionalProperties" and isinstance(err.instance, dict):
        known = sorted(err.schema.get("properties", {}))
        extra = sorted(k for k in err.instance if k not in known)
        name = str(extra[0]) if extra else "?"
        key = ".".join([*path, name])
        close = difflib.get_close_matches(name, known, n=1)
        hint = (
            f"did you mean {'.'.join([*path, close[0]])}?"
            if close
            else (f"known keys{' of ' + '.'.join(path) if path else ''}: {', '.join(known)}")
        )
        return ConfigError(key, f"unknown key ({hint})")
    if err.validator == "anyOf" and err.context:  # a lidar: a name or a geometry block
        if isinstance(err.instance, str):
            enum = next((e for e in err.context if e.validator == "enum"), None)
            if enum is not None:
                known = ", ".join(map(str, enum.validator_value))
                return ConfigError(
                    ".".join(path), f"unknown name {err.instance!r}; known names: {known}"
                )
        own = [e for e in err.context if e.validator not in ("type", "enum")] or list(err.context)
        deepest = max(own, key=lambda e: len(e.absolute_path))
        return _schema_error(deepest, schema)
    key = ".".join(path) if path else "(top level)"
    problem = err.message
    if len(problem) > 200:
        problem = problem[:197] + "..."
    desc = err.schema.get("description") if isinstance(err.schema, dict) else None
    if desc and len(desc) < 160 and err.validator != "type":
        problem += f" [{desc}]"
    return ConfigError(key, problem)


def check_config(config: dict, *, schema: dict | None = None) -> dict:
    """Validate a pipeline config: closed schema, defaults, cross-key conditions.

    What the schema cannot say is checked too (cross-key conditions, the library's own
    limits). With ``campaigns:`` (a fleet) those checks run on each campaign's config
    (:func:`campaign_configs`) and a problem's key names the campaign
    (``campaigns.buoyB.campaign.records``).

    Parameters
    ----------
    config : dict
        The config as Snakemake loaded it, or a user file (:func:`load_config_file`);
        completed in place with the schema defaults.
    schema : dict, optional
        The schema (default: :data:`SCHEMA_PATH`).

    Returns
    -------
    dict
        ``config``, completed.

    Raises
    ------
    ConfigError
        On the first problem, naming the dotted key.
    """
    import jsonschema

    schema = _load_schema() if schema is None else schema
    if not isinstance(config, dict):
        raise ConfigError("(top level)", f"must be a mapping of sections, got {config!r}")
    validator = jsonschema.Draft202012Validator(schema)
    errors = list(validator.iter_errors(config))
    if errors:
        # the error deepest in the config first: it names the most precise key
        errors.sort(key=lambda e: (-len(e.absolute_path), [str(p) for p in e.absolute_path]))
        raise _schema_error(errors[0], schema)
    _fill_defaults(config, schema)
    if "campaigns" not in config:
        _check_semantics(config)
        return config
    # a fleet: each campaign's sections laid over the shared ones, checked as one config
    for name, merged in campaign_configs(config).items():
        if name == FLEET_DIR:
            raise ConfigError(
                f"campaigns.{name}",
                f"reserved name (results/{FLEET_DIR}/ holds the fleet summary); choose another",
            )
        try:
            _check_semantics(merged)
        except ConfigError as exc:
            raise exc.in_campaign(name) from None
    return config


def campaign_configs(config: Mapping) -> dict[str, dict]:
    """The config of each campaign of a fleet (config key ``campaigns``).

    A campaign's config is the top-level config (the sections the campaigns share) with the
    campaign's own sections laid over it key by key: ``campaigns: {B: {campaign: {seed:
    3}}}`` gives campaign B the shared ``campaign`` section with seed 3; a key's value is
    replaced whole (``campaign.columns`` is not merged). The result is what a single-campaign
    run of that campaign would read, so a fleet's campaign gives the files of that run.

    Parameters
    ----------
    config : mapping
        The pipeline config, completed with the schema defaults (:func:`check_config`).

    Returns
    -------
    dict of str -> dict
        Campaign name -> its config (without ``campaigns``), in the config's order; empty
        when ``config`` has no ``campaigns`` key (a single campaign).
    """
    import copy

    shared = {k: v for k, v in config.items() if k != "campaigns"}
    out = {}
    for name, own in (config.get("campaigns") or {}).items():
        merged = copy.deepcopy(shared)
        for section, values in (own or {}).items():
            merged[section] = {**merged.get(section, {}), **copy.deepcopy(values)}
        out[str(name)] = merged
    return out


def _lidar_file_as_records(camp: dict) -> None:
    """``campaign.lidar_file`` (a campaign in several files) in place of ``records``: its
    path and its format, column map and time keys become the campaign's (in place)."""
    lidar = camp.get("lidar_file") or {}
    if not lidar.get("path"):
        return
    if camp.get("records") and camp["records"] != lidar["path"]:
        raise ConfigError(
            "campaign.lidar_file.path",
            f"{lidar['path']!r} and campaign.records {camp['records']!r}: give one of them",
        )
    camp["records"] = lidar["path"]
    for key in ("format", "columns", "utc_offset_h", "timestamp_at", "heading_convention"):
        if lidar.get(key) not in (None, {}, "auto", "ccw") or key not in camp:
            camp[key] = lidar.get(key, camp.get(key))


def _check_semantics(config: dict) -> None:
    from flidar_uq.data.io import check_column_map
    from flidar_uq.data.qc import QCConfig

    camp = config["campaign"]
    _lidar_file_as_records(camp)
    if camp["source"] == "files" and not camp["records"]:
        raise ConfigError(
            "campaign.records",
            "missing, but campaign.source is 'files': give the path of your record table "
            "(CSV or Parquet, docs/data-format.md)",
        )
    _check_lidars(config)
    if camp["source"] == "virtual":
        _check_scenario(camp["scenario"])
        _check_scenario_lidar(camp)
    _check_series_keys(config)
    _check_trial_posterior(config)
    try:
        check_column_map(camp["columns"])
    except ValueError as exc:
        raise ConfigError("campaign.columns", str(exc).removeprefix("column map: ")) from None
    try:
        QCConfig(**config["qc"])
    except ValueError as exc:
        m = re.search(r"QCConfig\.(\w+)", str(exc))
        names = re.findall(r"\b(ti_hws_\w+)\b", str(exc))
        key = f"qc.{m.group(1)}" if m else ("qc." + names[0] if names else "qc")
        raise ConfigError(key, re.sub(r"QCConfig\.?\w* ?", "", str(exc)).strip()) from None
    pri = config["priors"]
    for lo, hi in (
        ("amplitude_min_deg", "amplitude_max_deg"),
        ("period_min_s", "period_max_s"),
    ):
        if not pri[lo] < pri[hi]:
            raise ConfigError(f"priors.{lo}", f"{pri[lo]} must be below priors.{hi} = {pri[hi]}")


def _check_lidars(config: dict) -> None:
    """``campaign.lidar`` and ``reference.lidar``: a custom geometry block must make a
    consistent geometry (:func:`flidar_uq.physics.lidar.get_lidar`)."""
    from flidar_uq.physics.lidar import get_lidar

    for section in ("campaign", "reference"):
        value = (config.get(section) or {}).get("lidar")
        if value is None:
            continue
        try:
            get_lidar(value)
        except ValueError as exc:
            raise ConfigError(f"{section}.lidar", str(exc)) from None


def _lidar_label(value) -> str:
    from flidar_uq.physics.lidar import get_lidar

    return get_lidar(value).name


def _check_scenario_lidar(camp: dict) -> None:
    """A virtual campaign's ``campaign.lidar`` must be the lidar its scenario simulates
    (the scenario's ``lidar.name``): one line when they disagree. The default
    ``campaign.lidar`` (zephir300) with a scenario of another lidar is a disagreement too:
    sigma_Z would be computed for the wrong geometry."""
    from flidar_uq.campaign.scenarios import CampaignConfig, load_scenario

    try:
        scen = CampaignConfig.from_dict(load_scenario(camp["scenario"])).settings
    except (ValueError, OSError):
        return  # reported by the campaign step with its own message
    simulated = scen["lidar"]["name"]
    try:
        same = _lidar_label(simulated) == _lidar_label(camp["lidar"])
        if same and isinstance(camp["lidar"], Mapping):
            from flidar_uq.physics.lidar import get_lidar

            same = get_lidar(simulated) == get_lidar(camp["lidar"])
    except ValueError:
        return
    if not same:
        raise ConfigError(
            "campaign.lidar",
            f"{_lidar_label(camp['lidar'])!r}, but the virtual scenario {camp['scenario']!r} "
            f"simulates {_lidar_label(simulated)!r}: set campaign.lidar: {_lidar_label(simulated)}",
        )


def _check_trial_posterior(config: dict) -> None:
    """``validation.trial_posterior``: an existing file, with the record motion model (its
    global parameters are campaign-independent; a bin model's posteriors are per bin)."""
    trial = (config.get("validation") or {}).get("trial_posterior")
    if not trial:
        return
    if config["inference"]["motion_model"] != "record":
        raise ConfigError(
            "validation.trial_posterior",
            "needs inference.motion_model 'record' (the bin model's posteriors belong to "
            "the trial campaign's bins)",
        )
    if not Path(trial).is_file():
        raise ConfigError(
            "validation.trial_posterior",
            f"no such file {trial!r}: run the trial campaign first (its "
            "results/posterior/global.nc)",
        )


def _check_series_keys(config: dict) -> None:
    """The raw-series keys go together: the user's series with source files (LOS needs the
    IMU series and, for its correction, the lever arm); a virtual campaign's with
    ``virtual_series``; a given series file must exist."""
    camp = config["campaign"]
    if camp["source"] == "virtual":
        for key in ("imu_series", "los_series"):
            if camp[key]:
                raise ConfigError(
                    f"campaign.{key}",
                    "only with campaign.source 'files'; a virtual campaign writes its own "
                    "series with campaign.virtual_series",
                )
        return
    if camp["virtual_series"] != "none":
        raise ConfigError("campaign.virtual_series", "only with campaign.source 'virtual'")
    if camp["los_series"] and not camp["imu_series"]:
        raise ConfigError(
            "campaign.imu_series",
            "missing, but campaign.los_series is given: the LOS correction needs the "
            "buoy's motion (a raw IMU series, docs/data-format.md)",
        )
    if camp["los_series"] and config["inference"]["lever_arm_m"] is None:
        raise ConfigError(
            "inference.lever_arm_m",
            "missing, but campaign.los_series is given: the LOS correction needs the lidar "
            "head's height above the buoy's rotation centre (m)",
        )
    for key in ("imu_series", "los_series"):
        if camp[key] and not Path(camp[key]).is_file():
            raise ConfigError(f"campaign.{key}", f"no such file {camp[key]!r}")


def _check_scenario(scenario: str) -> None:
    from flidar_uq.campaign.scenarios import scenario_dir

    if scenario.endswith((".yaml", ".yml")):
        if not Path(scenario).is_file():
            raise ConfigError("campaign.scenario", f"no such scenario file {scenario!r}")
        return
    shipped = sorted(p.stem for p in scenario_dir().glob("*.yaml"))
    if scenario not in shipped:
        raise ConfigError(
            "campaign.scenario",
            f"no shipped scenario {scenario!r}; shipped: {', '.join(shipped)} "
            "(or a path ending in .yaml)",
        )


# --------------------------------------------------------------------------- records


def read_campaign_records(
    path: str | os.PathLike,
    campaign: Mapping | None = None,
    *,
    allow_small_angles: bool | None = None,
) -> pd.DataFrame:
    """Read and validate the user's record table as the pipeline does.

    Parameters
    ----------
    path : path
        The record table (CSV or Parquet).
    campaign : mapping, optional
        The config's ``campaign`` section: ``columns`` (column map), ``heights``
        (selected heights, m: each must occur in the file) and ``allow_small_angles``.
        The motion columns are optional: a raw IMU series (``imu_series``) may give them,
        and without either the pipeline reports the uncorrected TI
        (:func:`missing_motion_columns`).
    allow_small_angles : bool, optional
        Overrides ``campaign["allow_small_angles"]`` when given.

    Returns
    -------
    pandas.DataFrame
        Every record of the file (heights not selected included: QC flags them).

    Raises
    ------
    flidar_uq.data.io.DataValidationError
        On a problem of the file (names file, row and column).
    ConfigError
        When a selected height does not occur in the file.
    """
    import numpy as np

    from flidar_uq.data.formats.join import read_campaign

    campaign = dict(campaign or {})
    if allow_small_angles is None:
        allow_small_angles = bool(campaign.get("allow_small_angles", False))
    conventions = {
        k: campaign[k]
        for k in (
            "format",
            "utc_offset_h",
            "timestamp_at",
            "heading_convention",
            "motion_file",
            "reference_file",
        )
        if k in campaign
    }
    records = read_campaign(
        path,
        {
            **conventions,
            "columns": campaign.get("columns") or None,
            "extra_columns": campaign.get("extra_columns", "keep"),
        },
        # the motion columns may be absent: a raw IMU series gives them, or the campaign
        # is reported uncorrected (missing_motion_columns)
        require_motion=False,
        allow_small_angles=allow_small_angles,
    )[0]
    heights = campaign.get("heights")
    if heights:
        present = np.unique(records["height_m"].to_numpy(dtype=float))
        for h in heights:
            if not np.isclose(present, float(h), atol=1e-6).any():
                raise ConfigError(
                    "campaign.heights",
                    f"{h:g} m is not a height of {path} (its heights: "
                    f"{', '.join(f'{x:g}' for x in present)} m)",
                )
    return records


def missing_motion_columns(
    campaign: Mapping, record_columns: Iterable[str] | None = None
) -> tuple[str, ...]:
    """The motion columns the campaign's records lack (roll and pitch amplitude and period,
    :data:`flidar_uq.data.schema.MOTION_COLUMNS`): without them the TI cannot be corrected
    and the pipeline reports the uncorrected TI per height and speed bin.

    Parameters
    ----------
    campaign : mapping
        The checked config's ``campaign`` section (``source``, ``records``, ``imu_series``
        and the keys of :func:`read_campaign_records`).
    record_columns : iterable of str, optional
        The columns of the records as read (:func:`read_campaign_records`, which derives
        the amplitudes from ``roll_std_deg`` / ``pitch_std_deg``); None reads
        ``campaign["records"]``.

    Returns
    -------
    tuple of str
        The missing motion columns in schema order; empty for the virtual campaign, with a
        raw IMU series (``campaign.imu_series`` gives them) or when the table has them all.
    """
    from flidar_uq.data.schema import MOTION_COLUMNS

    if campaign["source"] != "files" or campaign.get("imu_series"):
        return ()
    if record_columns is None:
        record_columns = read_campaign_records(campaign["records"], campaign).columns
    present = set(record_columns)
    return tuple(c for c in MOTION_COLUMNS if c not in present)


def inspect_records(
    records: pd.DataFrame,
    *,
    source: str = "<DataFrame>",
    qc_params: Mapping | None = None,
    heights: list[float] | None = None,
    columns: Mapping | None = None,
) -> dict:
    """What the pipeline will find in a validated record table, and warnings.

    :func:`flidar_uq.data.inspection.inspect_records` with the records' motion
    descriptions (:func:`flidar_uq.inference.record_motion.per_record_motion`).

    Parameters
    ----------
    records : pandas.DataFrame
        A validated record table (:func:`read_campaign_records`).
    source : str
        File name for the messages.
    qc_params : mapping, optional
        The config's ``qc`` section (default: the QC defaults).
    heights : list of float, optional
        The selected heights, m (config ``campaign.heights``).
    columns : mapping, optional
        The column map used to read the file (reported).

    Returns
    -------
    dict
        See :func:`flidar_uq.data.inspection.inspect_records`.
    """
    from flidar_uq.data import inspection
    from flidar_uq.inference.record_motion import MOTION_DESCRIPTIONS, per_record_motion

    report = inspection.inspect_records(
        records,
        per_record_motion(records)["motion_description"],
        descriptions=MOTION_DESCRIPTIONS,
        source=source,
        qc_params=qc_params,
        heights=heights,
        columns=columns,
    )
    pattern = _std_pattern_warning(records, qc_params)
    if pattern:
        report["warnings"].append(pattern)
    return report


#: Rows named by the std-pattern warning of :func:`inspect_records` before "...".
_ROWS_NAMED = 5


def _std_pattern_warning(records: pd.DataFrame, qc_params: Mapping | None) -> str:
    """The warning naming the rows whose std breaks its column's pattern
    (:func:`flidar_uq.data.qc.std_pattern_outliers`, QC flag ``std_pattern``); "" when none
    or the filter is switched off."""
    import numpy as np

    from flidar_uq.data.qc import QCConfig, std_pattern_outliers

    c = QCConfig(**dict(qc_params or {}))
    if not c.std_pattern:
        return ""
    rows = (
        np.flatnonzero(
            std_pattern_outliers(
                records["hws_mean_ms"].to_numpy(dtype=float),
                records["hws_std_ms"].to_numpy(dtype=float),
                k=c.std_pattern_k,
                min_factor=c.std_pattern_min_factor,
            )
        )
        + 1
    )
    if not rows.size:
        return ""
    named = ", ".join(str(r) for r in rows[:_ROWS_NAMED]) + (
        ", ..." if rows.size > _ROWS_NAMED else ""
    )
    return (
        f"{rows.size} record(s) (rows {named}) have hws_std_ms / hws_mean_ms far from the "
        "rest of the column (QC flag std_pattern, e.g. TI in percent in the std column): "
        "check that column's units"
    )


# --------------------------------------------------------------------------- exit status


def exit_status(exc: BaseException) -> int | None:
    """The exit status of a bad-input exception (None: not a bad input, an internal error)."""
    from flidar_uq.data.io import DataValidationError

    if isinstance(exc, ConfigError):
        return EXIT_USAGE
    if isinstance(exc, DataValidationError):
        return EXIT_DATA
    return None


def scenario_path(campaign: Mapping) -> Path | None:
    """The virtual campaign's scenario YAML (``campaign.scenario``: a path ending in .yaml,
    or the name of one shipped with the package), ``None`` when ``campaign.source`` is not
    ``virtual``."""
    if campaign["source"] != "virtual":
        return None
    from flidar_uq.campaign.scenarios import scenario_dir

    scenario = campaign["scenario"]
    if scenario.endswith((".yaml", ".yml")):
        return Path(scenario)  # relative to the working directory
    return scenario_dir() / f"{scenario}.yaml"


def _virtual_sampling(campaign: Mapping) -> dict | None:
    """How the virtual campaign's lidar and reference sample the wind
    (:func:`flidar_uq.campaign.scenarios.reference_sampling`), ``None`` for the user's files."""
    path = scenario_path(campaign)
    if path is None:
        return None
    from flidar_uq.campaign.scenarios import reference_sampling

    return reference_sampling(path)


def resolve_propagation(config: Mapping) -> dict:
    """``config["propagation"]`` with its "auto" scan keys resolved: from the virtual
    campaign's scenario (heights scanned in turn, refocus delays in s, the turbulence time
    step in s), else the data-driven defaults of
    :class:`flidar_uq.correction.campaign.CorrectionSettings` (heights counted in the
    records, refocus delays (0.3, 0.7) s, the continuous spectrum)."""
    params = dict(config["propagation"])
    virtual = _virtual_sampling(config["campaign"])
    sampling = {
        "scan_heights_in_turn": None,
        "scan_refocus_delay_s": [0.3, 0.7],
        "turbulence_dt_s": None,
    }
    if virtual is not None:
        sampling = {
            "scan_heights_in_turn": virtual["heights_in_turn"],
            "scan_refocus_delay_s": list(virtual["refocus_delay_s"]),
            "turbulence_dt_s": virtual["turbulence_dt_s"],
        }
    for key, value in sampling.items():
        if params.get(key) == "auto":
            params[key] = value
    return params


def check_reference(config: dict, record_columns=None):
    """``config["reference"]`` resolved for the user's records (``record_columns``: their
    columns after the column map) or the virtual campaign's scenario:
    :meth:`flidar_uq.correction.reference.Reference.from_config`, whose one-line error
    becomes a :class:`ConfigError` naming the key (exit status 2)."""
    from flidar_uq.correction.reference import Reference

    camp = config["campaign"]
    virtual = _virtual_sampling(camp)
    try:
        return Reference.from_config(
            config.get("reference"),
            lidar=camp["lidar"],
            virtual_kind=None if virtual is None else virtual["reference_kind"],
            virtual_spatial=virtual is not None and virtual["spatial_field"],
            record_columns=record_columns,
        )
    except ValueError as err:
        raise ConfigError("reference", str(err), message=str(err)) from None


def correction_inputs(config: dict, record_columns=None):
    """The reference and the propagation's settings of a whole (checked) config, as the
    pipeline's ``propagate`` step gets them: ``(Reference, CorrectionSettings)`` for
    :func:`flidar_uq.correct_campaign`, "auto" keys resolved (:func:`check_reference`,
    :func:`resolve_propagation`)."""
    from flidar_uq.correction.campaign import CorrectionSettings

    reference = check_reference(config, record_columns)
    settings = CorrectionSettings.from_config(
        {**config, "propagation": resolve_propagation(config)}
    )
    return reference, settings


def settings_from_config(path: str | os.PathLike | None = None) -> dict:
    """The keyword settings with which :func:`flidar_uq.correct_campaign` does what the
    pipeline's ``propagate`` step does under a config.

    Parameters
    ----------
    path : path, optional
        A config file (relative paths in it are read from the working directory), laid
        over the defaults as the pipeline lays a ``--configfile`` over the shipped
        config/config.yaml (whose values are the schema's defaults). None: the shipped
        config.

    Returns
    -------
    dict
        ``reference`` (:class:`flidar_uq.Reference`) and ``settings``
        (:class:`flidar_uq.CorrectionSettings`), "auto" keys resolved as the pipeline
        resolves them (:func:`correction_inputs`): ``correct_campaign(records, fit,
        **settings_from_config(path), flags=...)``.

    Raises
    ------
    ConfigError
        (a ValueError) naming the key of the first problem of the config.
    """
    config = check_config({} if path is None else load_config_file(path))
    if "campaigns" in config:
        raise ConfigError(
            "campaigns", "a fleet config: settings_from_config reads one campaign's config"
        )
    reference, settings = correction_inputs(config)
    return {"reference": reference, "settings": settings}


def check_series(campaign: Mapping) -> None:
    """The raw series of a run, checked before any expensive step.

    The head of the IMU and the LOS series is validated (columns, delimiter, units, the
    IMU's sampling rate) and their time spans are compared, from the ends of the files
    (:func:`flidar_uq.data.imu_series.series_span`): a LOS file whose span no IMU sample
    overlaps is refused. The whole series are validated again as they are read.

    Parameters
    ----------
    campaign : mapping
        The config's ``campaign`` section (``imu_series``, ``los_series``).

    Raises
    ------
    flidar_uq.data.io.DataValidationError
        Naming the file, row and column of the problem.
    """
    from flidar_uq.data.imu_series import series_span
    from flidar_uq.data.io import DataValidationError

    if not campaign.get("imu_series"):
        return
    imu = series_span(campaign["imu_series"], what="imu")
    if not campaign.get("los_series"):
        return
    los = series_span(campaign["los_series"], what="los", utc_offset_h=campaign.get("utc_offset_h"))
    if los[1] < imu[0] or los[0] > imu[1]:
        raise DataValidationError(
            str(campaign["los_series"]),
            1,
            "timestamp",
            f"the LOS series ({los[0].isoformat()} to {los[1].isoformat()}) and the IMU "
            f"series {campaign['imu_series']} ({imu[0].isoformat()} to {imu[1].isoformat()}) "
            "do not overlap: the IMU series of this LOS file is missing",
            csv=str(campaign["los_series"]).lower().endswith((".csv", ".csv.gz")),
        )


def pipeline_preflight(config: dict, *, read_data: bool = True, stream=None) -> int:
    """The checks at the start of a pipeline run (the Snakefile calls this when parsed).

    Validates the config (:func:`check_config`, defaults filled in place) and, for
    ``campaign.source: files`` with ``read_data``, reads the record table as the pipeline
    will (:func:`read_campaign_records`), refuses what would make every record
    uncorrectable (:func:`flidar_uq.data.inspection.reference_problems`), a reference kind missing for records
    with a reference (:func:`check_reference`) and bad raw series (:func:`check_series`).
    The warnings of :func:`inspect_records` come from the ``validate`` rule (they need the
    inference layer, slow to import). A fleet (``campaigns:``) is checked campaign by
    campaign (:func:`campaign_configs`), a problem's key naming the campaign
    (``campaigns.buoyB.campaign.records``).

    Returns
    -------
    int
        :data:`EXIT_OK`, or the exit status of the problem, whose one-line message was
        printed on ``stream`` (default stderr).
    """
    stream = sys.stderr if stream is None else stream
    try:
        check_config(config)
        if "campaigns" not in config:
            _preflight_data(config, read_data)
        for name, merged in campaign_configs(config).items():
            try:
                _preflight_data(merged, read_data, fleet=True)
            except ConfigError as exc:
                raise exc.in_campaign(name) from None
    except Exception as exc:  # noqa: BLE001 - classified below, re-raised if not bad input
        code = exit_status(exc)
        if code is None:
            raise
        print(f"flidar-uq: error: {exc}", file=stream)
        return code
    return EXIT_OK


def _preflight_data(config: dict, read_data: bool, *, fleet: bool = False) -> None:
    """The data checks of :func:`pipeline_preflight` for one campaign's checked config
    (``fleet``: a campaign of a fleet, which compares corrected campaigns: its motion
    columns are required)."""
    camp = config["campaign"]
    if read_data and camp["source"] == "files":
        from flidar_uq.data.inspection import reference_problems

        records = read_campaign_records(camp["records"], camp)
        problems = reference_problems(records, str(camp["records"]))
        if problems:
            raise problems[0]
        missing = missing_motion_columns(camp, records.columns) if fleet else ()
        if missing:
            raise ConfigError(
                "campaign.records",
                f"{camp['records']} has no {', '.join(missing)} column and no raw IMU series "
                "(campaign.imu_series): a fleet compares motion-corrected campaigns; run this "
                "campaign on its own for its uncorrected TI",
            )
        check_reference(config, list(records.columns))
        check_series(camp)
    elif camp["source"] == "virtual":
        check_reference(config)


@contextmanager
def step_errors_exit():
    """In a workflow script: a bad input ends the job with one line and its exit status.

    The line goes to stderr and the log; the status is that of :data:`EXIT_CODES`, no
    traceback."""
    try:
        yield
    except Exception as exc:  # noqa: BLE001 - classified below, re-raised if not bad input
        code = exit_status(exc)
        if code is None:
            raise
        log.error("%s", exc)
        print(f"flidar-uq: error: {exc}", file=sys.stderr)
        sys.exit(code)
