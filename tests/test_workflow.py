"""The Snakemake workflow: config schema, dry run, lint, and (slow) tiny end-to-end runs.

Every run is hermetic: ``snakemake -s <repo>/Snakefile --directory <tmp_path>`` with a
config written into ``tmp_path``, so nothing is written into the repository's results/.
The end-to-end tests check the output contract, that a rerun does nothing, that a clean
rerun and a run killed mid-way give byte-identical result files, and the user-data run.
"""

from __future__ import annotations

import base64
import hashlib
import os
import re
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import jsonschema
import numpy as np
import pandas as pd
import pytest
import yaml

from flidar_uq.correction.campaign import RECORD_COLUMNS
from flidar_uq.data.calibration import calibration_by_group, speed_group_label
from flidar_uq.workflow.inference_steps import bin_seed
from flidar_uq.workflow.inputs import SCHEMA_PATH

REPO = Path(__file__).resolve().parents[1]
SNAKEMAKE = str(Path(sys.executable).with_name("snakemake"))
SCHEMA = SCHEMA_PATH
CONFIG = REPO / "config" / "config.yaml"

#: Small settings shared by the end-to-end configs (seconds, not minutes).
TINY_INFERENCE = {
    "nwalkers": 16,
    "nsteps": 250,
    "nburn": 50,
    "ndraws": 50,
    "nbatches": 2,
    "mixture": "never",
}
TINY_BINNING = {
    "min_count": 2,
    "hws_width_ms": 4.0,
    "amplitude_width_deg": 2.0,
    "period_width_s": 2.0,
}
TINY_SCENARIO = {
    "name": "test_tiny",
    "n_records": 24,
    "heights_m": [58.0, 85.0],
    "chunk_records": 8,
}


def load_yaml(path: Path) -> dict:
    with open(path) as fh:
        return yaml.safe_load(fh)


def tiny_config(workdir: Path, shared: Path | None = None, **campaign) -> Path:
    """Write a tiny virtual-campaign config into ``workdir``.

    The scenario file and a frozen copy of the benchmark charts live in ``shared``
    (default: ``workdir``), so that runs in different directories can share one config
    content (the report's provenance shows the config).
    """
    shared = workdir if shared is None else shared
    scenario = shared / "tiny_scenario.yaml"
    if not scenario.exists():
        scenario.write_text(yaml.safe_dump(TINY_SCENARIO))
    bench = shared / "benchmark_charts"
    if not bench.exists():
        bench.mkdir()
        for png in sorted((REPO / "benchmarks" / "results").glob("*.png"))[:3]:
            shutil.copy(png, bench / png.name)
    cfg = {
        "campaign": {"source": "virtual", "scenario": str(scenario), "seed": 7} | campaign,
        "binning": TINY_BINNING,
        "inference": TINY_INFERENCE,
        "propagation": {"ndraws": 100},
        "report": {"benchmarks_dir": str(bench)},
    }
    path = workdir / "config.yaml"
    path.write_text(yaml.safe_dump(cfg))
    return path


def snakemake(
    workdir: Path, configfile: Path, *args: str, timeout: float = 600, check: bool = True
):
    """Run the repository's workflow in ``workdir`` with the running interpreter's snakemake."""
    cmd = [
        SNAKEMAKE,
        "-s",
        str(REPO / "Snakefile"),
        "--directory",
        str(workdir),
        "--configfile",
        str(configfile),
    ]
    cmd += list(args)
    proc = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout, cwd=workdir)
    if check and proc.returncode != 0:
        raise AssertionError(
            f"snakemake {' '.join(args)} failed ({proc.returncode}):\n{proc.stderr[-4000:]}"
        )
    return proc


def result_hashes(workdir: Path) -> dict[str, str]:
    """sha256 of every result file except logs and run-time benchmarks (timings differ).

    The report's git revision line is blanked first: the lead may commit between two runs.
    """
    out = {}
    for p in sorted((workdir / "results").rglob("*")):
        rel = p.relative_to(workdir).as_posix()
        if (
            p.is_file()
            and not rel.startswith(("results/logs/", "results/benchmarks/"))
            and ".snakemake_timestamp" not in rel
        ):
            data = p.read_bytes()
            if rel.endswith(".html"):
                data = re.sub(rb"git revision: <code>[^<]*</code>", b"", data)
            out[rel] = hashlib.sha256(data).hexdigest()
    return out


# --------------------------------------------------------------------------- config schema


def _leaves(schema: dict, prefix: str = ""):
    for key, sub in schema.get("properties", {}).items():
        if sub.get("type") == "object":
            yield from _leaves(sub, f"{prefix}{key}.")
        else:
            yield f"{prefix}{key}", sub


def test_config_validates_against_closed_schema():
    schema = load_yaml(SCHEMA)
    jsonschema.Draft202012Validator.check_schema(schema)
    jsonschema.validate(load_yaml(CONFIG), schema)
    bad = load_yaml(CONFIG)
    bad["qc"]["sv_maxx"] = 0.06  # misspelt key
    with pytest.raises(jsonschema.ValidationError, match="sv_maxx"):
        jsonschema.validate(bad, schema)
    bad = load_yaml(CONFIG)
    bad["propagation"]["credible_mass"] = 1.5  # out of bounds
    with pytest.raises(jsonschema.ValidationError, match="1.5"):
        jsonschema.validate(bad, schema)


def test_schema_every_key_has_type_description_default_and_bounds():
    schema = load_yaml(SCHEMA)
    assert schema["additionalProperties"] is False
    for name, sub in schema["properties"].items():
        assert sub["additionalProperties"] is False, name
    leaves = dict(_leaves(schema))
    assert len(leaves) > 40
    for name, sub in leaves.items():
        for field in ("type", "description", "default"):
            assert field in sub, f"{name}: no {field}"
        assert "(" in sub["description"] and sub["description"].rstrip().endswith(")"), (
            f"{name}: unit missing"
        )
        if sub["type"] in ("number", "integer"):
            assert {"minimum", "exclusiveMinimum"} & set(sub), f"{name}: no lower bound"
            assert {"maximum", "exclusiveMaximum"} & set(sub), f"{name}: no upper bound"
            jsonschema.validate(sub["default"], sub)


def test_schema_defaults_equal_the_shipped_config():
    """The commented config and the schema defaults say the same thing."""
    cfg = load_yaml(CONFIG)
    for name, sub in _leaves(load_yaml(SCHEMA)):
        node = cfg
        for key in name.split("."):  # campaign.motion_file.path: three levels
            node = node[key]
        assert node == sub["default"], name


def test_config_keys_match_library_dataclasses():
    """qc / inference / priors sections are passed as keyword arguments: names must exist."""
    from flidar_uq.data.qc import QCConfig
    from flidar_uq.inference import Priors, SamplerSettings

    cfg = load_yaml(CONFIG)
    assert set(cfg["qc"]) <= set(QCConfig.__dataclass_fields__)
    assert set(cfg["priors"]) <= set(Priors.__dataclass_fields__)
    pipeline_keys = {
        "seed",
        "nbatches",
        "motion_model",
        "hull_model",
        "hull_reference",
        "lever_arm_m",
        "lever_arm_sd_m",
    }
    assert set(cfg["inference"]) - pipeline_keys <= set(SamplerSettings.__dataclass_fields__)
    QCConfig(**cfg["qc"])
    Priors(**cfg["priors"])


def test_shipped_config_defaults_equal_the_library_dataclass_defaults():
    """A key of qc / priors / inference that a library dataclass also holds has one default:
    the notebook user (dataclass) and the pipeline user (config, schema) get the same run."""
    import dataclasses

    from flidar_uq.data.qc import QCConfig
    from flidar_uq.inference import Priors, SamplerSettings

    cfg = load_yaml(CONFIG)
    for section, cls in (("qc", QCConfig), ("priors", Priors), ("inference", SamplerSettings)):
        defaults = {f.name: f.default for f in dataclasses.fields(cls)}
        differ = {
            k: (v, defaults[k])
            for k, v in cfg[section].items()
            if k in defaults and defaults[k] != v
        }
        assert not differ, f"{section}: config vs {cls.__name__} defaults {differ}"


# --------------------------------------------------------------------------- glue units


def test_bin_seed_independent_of_batch_layout_and_distinct_per_bin():
    a = bin_seed(42, 3).generate_state(4)
    np.testing.assert_array_equal(a, bin_seed(42, 3).generate_state(4))
    assert not np.array_equal(a, bin_seed(42, 4).generate_state(4))
    assert not np.array_equal(a, bin_seed(43, 3).generate_state(4))


# --------------------------------------------------------------------------- dry run, lint


def dry_run_jobs(proc) -> set[str]:
    """The rule names of a dry run's job stats table (lines "<rule> <count>")."""
    return {
        line.split()[0]
        for line in (proc.stdout + proc.stderr).splitlines()
        if line.strip() and line.split()[-1].isdigit() and len(line.split()) == 2
    }


#: The per-bin fits of the bin motion model: its jobs, and the outputs only it writes.
BIN_MODEL_RULES = {"infer_batch", "posterior_bin", "ti_bins"}


@pytest.mark.parametrize("motion_model", ["record", "bin"])
def test_dry_run_of_the_shipped_config_schedules_the_per_bin_fits_only_for_the_bin_model(
    tmp_path, motion_model
):
    """The shipped config (record motion model) builds the whole DAG without the per-bin
    fits nor results/ti/bins.csv; inference.motion_model bin brings them back."""
    cfg = CONFIG
    if motion_model == "bin":
        cfg = tmp_path / "bin.yaml"
        cfg.write_text(yaml.safe_dump({"inference": {"motion_model": "bin"}}))
    proc = snakemake(tmp_path, cfg, "-n", "--cores", "2", timeout=120)
    jobs = dry_run_jobs(proc)
    common = {"campaign", "validate", "qc", "motion_statistics", "bins", "sigma_z",
              "fit_global_model", "fit_global", "propagate", "report"}  # fmt: skip
    assert common <= jobs, jobs
    # posterior_bin comes after the bins checkpoint: not in a dry run of an empty directory
    assert jobs & BIN_MODEL_RULES == (
        {"infer_batch", "ti_bins"} if motion_model == "bin" else set()
    )
    assert ("results/ti/bins.csv" in proc.stdout) == (motion_model == "bin")
    assert not (tmp_path / "results").exists()


@pytest.mark.slow
@pytest.mark.parametrize("motion_model", ["record", "bin"])
def test_the_per_bin_posteriors_are_scheduled_after_the_checkpoint_only_for_the_bin_model(
    tmp_path, motion_model
):
    """Past the bins checkpoint the DAG holds one posterior_bin job per fitted bin under the
    bin motion model, none under the record motion model."""
    cfg = tiny_config(tmp_path)
    data = load_yaml(cfg)
    data["inference"] = data["inference"] | {"motion_model": motion_model}
    cfg.write_text(yaml.safe_dump(data))
    snakemake(tmp_path, cfg, "--cores", "2", "results/bins/table.csv", timeout=300)
    table = pd.read_csv(tmp_path / "results" / "bins" / "table.csv")
    assert table["fitted"].any()
    jobs = dry_run_jobs(snakemake(tmp_path, cfg, "-n", "--cores", "2", timeout=120))
    assert "propagate" in jobs and "report" in jobs, jobs
    assert jobs & BIN_MODEL_RULES == (BIN_MODEL_RULES if motion_model == "bin" else set()), jobs


@pytest.mark.parametrize("motion_model", ["record", "bin"])
def test_the_propagation_waits_for_the_per_bin_fits_only_under_the_bin_motion_model(
    tmp_path, motion_model
):
    """The record motion model's propagation reads the record model's posterior alone; the
    bin motion model's needs every bin posterior and the chosen global model."""
    cfg = tiny_config(tmp_path)
    data = load_yaml(cfg)
    data.setdefault("inference", {})["motion_model"] = motion_model
    cfg.write_text(yaml.safe_dump(data))
    proc = snakemake(tmp_path, cfg, "-n", "--cores", "2", "results/ti/records.csv", timeout=120)
    jobs = dry_run_jobs(proc)
    assert "propagate" in jobs and "fit_global_model" in jobs, jobs
    assert ("infer_batch" in jobs) == (motion_model == "bin"), jobs
    assert ("fit_global" in jobs) == (motion_model == "bin"), jobs


@pytest.mark.slow
def test_dry_run_rejects_unknown_config_key(tmp_path):
    cfg = tiny_config(tmp_path)
    data = load_yaml(cfg)
    data["qc"] = {"sv_maxx": 0.1}
    cfg.write_text(yaml.safe_dump(data))
    proc = snakemake(tmp_path, cfg, "-n", "--cores", "1", timeout=120, check=False)
    assert proc.returncode != 0
    assert "sv_maxx" in proc.stdout + proc.stderr


@pytest.mark.slow
def test_snakemake_lint_is_clean(tmp_path):
    proc = snakemake(tmp_path, tiny_config(tmp_path), "--lint", timeout=120, check=False)
    out = proc.stdout + proc.stderr
    assert proc.returncode == 0, out[-3000:]
    assert "Lints for" not in out, out[-3000:]


# --------------------------------------------------------------------------- end to end (slow)


def check_outputs(workdir: Path, *, truth: bool, bin_model: bool = False) -> pd.DataFrame:
    """The output contract: files present, records.csv columns, one row per input record;
    the per-bin table and posteriors with the bin motion model only."""
    res = workdir / "results"
    for rel in ("ti/records.csv", "ti/metrics.csv", "posterior/global.nc", "report/report.html"):
        assert (res / rel).is_file(), rel
    table = pd.read_csv(res / "bins" / "table.csv")
    fitted = table.loc[table["fitted"], "bin_id"]
    assert len(fitted)
    for b in fitted:
        assert (res / "posterior" / f"bin_{int(b):04d}.nc").is_file() == bin_model, b
    assert (res / "ti" / "bins.csv").is_file() == bin_model
    assert (res / "inference" / "bin_fits.csv").is_file() == bin_model
    assert any((res / "inference").glob("batch_*")) == bin_model
    records = pd.read_csv(res / "ti" / "records.csv")
    assert list(records.columns[: len(RECORD_COLUMNS)]) == RECORD_COLUMNS
    assert ("ti_true" in records) == truth
    n_in = len(pd.read_parquet(res / "data" / "records.parquet"))
    assert len(records) == n_in  # every input record appears, flagged or corrected
    corrected = records["ti_corrected_median"].notna()
    assert (records.loc[~corrected, "flags"].fillna("") != "").all()  # no value => a reason
    ok = records[corrected]
    assert (ok["ti_corrected_lo"] <= ok["ti_corrected_median"]).all()
    assert (ok["ti_corrected_median"] <= ok["ti_corrected_hi"]).all()
    for log_dir in ("logs", "benchmarks"):
        assert any((res / log_dir).iterdir())
    # issue 14: TI statistics per height and speed bin with intervals of the statistic
    sb = pd.read_csv(res / "ti" / "speed_bins.csv")
    cols = "height_m, hws_bin_ms, n, ti_mean, ti_mean_lo, ti_mean_hi, ti_rep, ti_rep_lo, "
    cols += "ti_rep_hi, ti_p90, ti_p90_lo, ti_p90_hi"
    assert list(sb.columns[:12]) == cols.split(", ")
    assert set(sb["height_m"]) == set(records.loc[corrected, "height_m"])
    full = sb.dropna(subset=["ti_mean"])
    for stat in ("ti_mean", "ti_rep", "ti_p90"):
        assert (full[f"{stat}_lo"] <= full[stat]).all() and (full[stat] <= full[f"{stat}_hi"]).all()
    groups = pd.read_csv(res / "ti" / "groups.csv")
    assert {"campaign", "direction sector", "sea state"} <= set(groups["grouping"])
    budget = pd.read_csv(res / "ti" / "uncertainty_budget.csv")
    assert "campaign" in set(budget["grouping"])
    assert ("speed bin" in set(budget["grouping"])) == bool((sb["n"] >= 10).any())
    return records


@pytest.mark.slow
def test_tiny_end_to_end_rerun_nothing_clean_rerun_identical(tmp_path):
    a, b = tmp_path / "a", tmp_path / "b"
    a.mkdir()
    b.mkdir()
    cfg_a, cfg_b = tiny_config(a, tmp_path), tiny_config(b, tmp_path)
    snakemake(a, cfg_a, "--cores", "2")
    check_outputs(a, truth=True)
    from test_report import (
        assert_first_screen,
        assert_no_absolute_path,
        assert_prints_without_cut_tables,
        assert_report_layout,
        assert_report_renders,
    )

    report_html = a / "results" / "report" / "report.html"
    assert_report_renders(report_html, tmp_path)
    sections = (
        "Turbulence intensity per height and wind-speed bin",
        "Validation against the reference",
        "Direction sectors and sea states",
        "Motion of the buoy",
        "Appendix A. Bayesian diagnostics",
        "Appendix B. Per-bin motion fits",
        "Appendix C. Uncertainty budget",
        "How to cite",
        "Provenance and how to rerun",
    )
    assert_report_layout(report_html, tmp_path, sections)
    # the first screen (1400 x 900) answers; the print cuts no table; files by name only
    assert_first_screen(report_html, tmp_path, "tiny")
    assert_prints_without_cut_tables(report_html, tmp_path, "tiny")
    html = report_html.read_text()
    assert_no_absolute_path(html, tmp_path, REPO)
    assert (
        not re.search(r"seed[ _-]?00[0-3]", html, re.I)
        and "Full table" not in html
        and 'href="../' not in html
    )
    # a day of records: the 15-m/s bin says why it has no value; the validation is in sample
    assert "Representative TI at 15 m/s" in html
    assert "category <b" in html or "too few records in the 15-m/s bin" in html
    assert "In sample: the model was fitted on these same" in html
    # the record motion model (the default) ran no per-bin fit: the report says so in a line
    assert "The bin motion model was not run" in html and "case no." not in html
    # no development benchmark in the user's report; they are in the developer one
    charts = sorted((tmp_path / "benchmark_charts").glob("*.png"))
    chart_uris = {
        base64.b64encode(p.read_bytes()).decode("ascii")[:2000] for p in (*charts,
        REPO / "benchmarks" / "results" / "method_frontier.png") if p.is_file()
    }  # fmt: skip
    for png in charts:
        assert png.name not in html
    assert not any(uri in html for uri in chart_uris)
    assert "Speed-accuracy" not in html and "Method frontier" not in html
    assert "sha256" in html and "requirements.lock" in html
    sb = pd.read_csv(a / "results" / "ti" / "speed_bins.csv")
    assert set(sb["height_m"]) == set(TINY_SCENARIO["heights_m"])
    snakemake(a, cfg_a, "--cores", "1", "results/report/developer.html")
    dev = (a / "results" / "report" / "developer.html").read_text()
    charts_part = dev.split("Speed-accuracy charts")[-1].split("Provenance")[0]
    assert charts_part.count("<img ") == len(list((tmp_path / "benchmark_charts").glob("*.png")))
    assert "Correction methods compared on results/" in dev  # and the methods section
    (a / "results" / "report" / "developer.html").unlink()  # on demand: not in run b
    assert (
        "data:image/png;base64," in html
        and "<script" not in html
        and "http" not in html.split("Provenance")[0]
    )
    # a rerun with the same config does nothing
    proc = snakemake(a, cfg_a, "-n", "--cores", "2")
    assert "Nothing to be done" in proc.stdout + proc.stderr
    # snakemake's own report: the main outputs with their captions (workflow/report/*.rst)
    snakemake(a, cfg_a, "--report", str(tmp_path / "snakemake_report.html"))
    smk_report = (tmp_path / "snakemake_report.html").read_text()
    assert "credible mass" in smk_report and "metrics.csv" in smk_report
    assert "speed_bins.csv" in smk_report and "uncertainty_budget.csv" in smk_report
    # a clean rerun elsewhere gives byte-identical results
    snakemake(b, cfg_b, "--cores", "2")
    ha, hb = result_hashes(a), result_hashes(b)
    assert ha.keys() == hb.keys()
    assert [k for k in ha if ha[k] != hb[k]] == []
    # changing the inference seed reruns inference and downstream, not the campaign or QC
    data = load_yaml(cfg_a)
    data["inference"]["seed"] = 43
    cfg_a.write_text(yaml.safe_dump(data))
    out = snakemake(a, cfg_a, "-n", "--cores", "2").stdout
    assert "rule fit_global_model" in out and "rule propagate" in out
    for rule in ("rule campaign", "rule validate", "rule qc", "rule bins", "rule infer_batch"):
        assert rule not in out, rule


@pytest.mark.slow
def test_killed_run_completes_on_rerun_with_identical_results(tmp_path):
    ref, killed = tmp_path / "ref", tmp_path / "killed"
    ref.mkdir()
    killed.mkdir()
    snakemake(ref, tiny_config(ref, tmp_path), "--cores", "2")
    cfg = tiny_config(killed, tmp_path)
    cmd = [
        SNAKEMAKE,
        "-s",
        str(REPO / "Snakefile"),
        "--directory",
        str(killed),
        "--configfile",
        str(cfg),
        "--cores",
        "2",
    ]
    proc = subprocess.Popen(
        cmd,
        cwd=killed,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
        start_new_session=True,
    )
    deadline = time.monotonic() + 300
    while not (killed / "results" / "bins" / "table.csv").exists() and time.monotonic() < deadline:
        if proc.poll() is not None:
            break
        time.sleep(0.2)
    assert proc.poll() is None, "run finished before it could be killed"
    os.killpg(proc.pid, signal.SIGKILL)  # the whole process group: snakemake and its jobs
    proc.wait(timeout=60)
    assert not (killed / "results" / "ti" / "records.csv").exists()
    snakemake(killed, cfg, "--unlock")  # a killed run leaves its lock behind
    snakemake(killed, cfg, "--cores", "2", "--rerun-incomplete")
    check_outputs(killed, truth=True)
    assert result_hashes(killed) == result_hashes(ref)


def write_user_config(tmp_path: Path) -> Path:
    """tests/data/user_config.yaml with the records path made absolute."""
    data = load_yaml(REPO / "tests" / "data" / "user_config.yaml")
    data["campaign"]["records"] = str(REPO / data["campaign"]["records"])
    path = tmp_path / "user_config.yaml"
    path.write_text(yaml.safe_dump(data))
    return path


@pytest.mark.slow
def test_user_data_run_on_hand_written_campaign(tmp_path):
    """The user-data example under inference.motion_model bin: the per-bin fits, their
    table, posteriors and report sections (the end-to-end test of the bin model)."""
    config = write_user_config(tmp_path)
    data = load_yaml(config)
    data["inference"]["motion_model"] = "bin"
    config.write_text(yaml.safe_dump(data))
    snakemake(tmp_path, config, "--cores", "2")
    records = check_outputs(tmp_path, truth=False, bin_model=True)
    src = pd.read_csv(REPO / "tests" / "data" / "hand_written_campaign.csv")
    assert len(records) == len(src)
    np.testing.assert_allclose(records["hws_mean_ms"], src["hws_mean_ms"])
    np.testing.assert_allclose(
        records["ti_uncorrected"], src["hws_std_ms"] / src["hws_mean_ms"], rtol=1e-9
    )
    # the most frequent bin converges with the example's chains; against the reference
    # instrument its corrected std is less biased than the uncorrected one (motion inflates it)
    assert records["ti_corrected_median"].notna().any()
    metrics = pd.read_csv(tmp_path / "results" / "ti" / "metrics.csv").set_index("method")
    assert metrics.loc["Bayesian", "reference"] == "reference cup"  # reference.kind: cup
    assert abs(metrics.loc["Bayesian", "md_std_ms"]) < abs(metrics.loc["uncorrected", "md_std_ms"])
    # the report names the input file and its hash, never the directory it came from
    from test_report import assert_no_absolute_path

    html = (tmp_path / "results" / "report" / "report.html").read_text()
    assert "hand_written_campaign.csv (SHA-256" in html
    assert_no_absolute_path(html, tmp_path, REPO)
    # the bin model's sections: the per-bin table and the per-bin convergence
    bins = pd.read_csv(tmp_path / "results" / "ti" / "bins.csv")
    assert "Per-bin motion fits (they feed the corrected TI: bin model)" in html
    assert "case no." in html and len(bins) and "The bin motion model was not run" not in html
    # changing the inference seed refits the bins; changing the reference refits the
    # global models and propagates again, not the bin fits
    data["inference"]["seed"] = 43
    config.write_text(yaml.safe_dump(data))
    out = snakemake(tmp_path, config, "-n", "--cores", "2").stdout
    assert "rule infer_batch" in out and "rule fit_global_model" in out
    assert "rule bins" not in out and "rule validate" not in out
    del data["inference"]["seed"]  # back to the run's inference seed
    data["reference"]["separation_m"] = 80.0
    config.write_text(yaml.safe_dump(data))
    out = snakemake(tmp_path, config, "-n", "--cores", "2").stdout
    assert "rule fit_global_model" in out and "rule propagate" in out
    assert "rule infer_batch" not in out


def _fake_bin_fit(bin_id: int, rng: np.random.Generator):
    from flidar_uq.inference import BinFit

    draws = {
        "amplitude_deg": rng.normal(3.0, 0.1, (4, 25)),
        "period_s": rng.normal(4.0, 0.1, (4, 25)),
    }
    return BinFit(
        draws=draws,
        log_lik=rng.normal(size=(4, 25, 3)),
        diagnostics={
            n: {
                "rhat": 1.001,
                "ess_bulk": 900.0,
                "ess_tail": 800.0,
                "tau": 5.0,
                "nsteps_over_tau": 100.0,
            }
            for n in draws
        },
        failure_reasons=[],
        info={
            "bin_id": bin_id,
            "model": "unimodal",
            "n_records": 3,
            "n_imu": 3,
            "prior_only": False,
            "loo": {},
            "constant": {"hws_mean_ms": np.ones(3)},
        },
    )


def test_infer_batch_reports_a_raising_bin_and_fits_the_others(tmp_path, monkeypatch):
    from flidar_uq import inference
    from flidar_uq.workflow import inference_steps

    def fake_fit_bin(records, *, settings, seed, priors, bin_id):
        if bin_id == 2:
            raise RuntimeError("sampler exploded")
        return _fake_bin_fit(bin_id, np.random.default_rng(seed))

    monkeypatch.setattr(inference, "fit_bin", fake_fit_bin)
    assigned = pd.DataFrame(
        {"record_id": range(6), "bin_id": [1, 1, 1, 2, 2, 2], "hws_mean_ms": 8.0}
    )
    pd.DataFrame({"bin_id": [1, 2, 3], "fitted": [True, True, False], "batch": [0, 0, -1]}).to_csv(
        tmp_path / "table.csv", index=False
    )
    cfg = load_yaml(CONFIG)
    runs = []
    for name in ("a", "b"):
        summary = inference_steps.infer_batch(
            assigned,
            tmp_path / "table.csv",
            tmp_path / name,
            batch=0,
            inference=cfg["inference"],
            priors=cfg["priors"],
        )
        runs.append(tmp_path / name)
    assert summary["bin_id"].tolist() == [1, 2]
    assert summary["status"].tolist() == ["ok", "error"]
    assert summary["message"].iloc[1] == "RuntimeError: sampler exploded"
    fit = inference.load_fit(runs[0] / "bin_0001.nc")
    np.testing.assert_allclose(fit.flat("period_s").mean(), 4.0, atol=0.1)
    import xarray as xr

    with xr.open_dataset(runs[0] / "bin_0002.nc", engine="h5netcdf") as failed:
        assert failed.attrs["status"] == "error"
    # no wall-clock attribute: the same fit written twice is byte-identical
    assert (runs[0] / "bin_0001.nc").read_bytes() == (runs[1] / "bin_0001.nc").read_bytes()
    assert not (runs[0] / "bin_0003.nc").exists()  # not fitted, not in this batch


def _rule_text(name: str) -> str:
    """The text of rule ``name`` in workflow/rules/*.smk (up to the next rule)."""
    text = "".join(p.read_text() for p in sorted((REPO / "workflow" / "rules").glob("*.smk")))
    m = re.search(
        rf"^(rule|checkpoint) {name}:\n(.*?)(?=^(rule|checkpoint) |\Z)", text, re.M | re.S
    )
    assert m, name
    return m.group(2)


def test_infer_batch_does_not_depend_on_the_lidar():
    """The motion likelihood has no sigma_Z: changing campaign.lidar must not rerun every
    per-bin fit, so neither the rule's params nor the step take the lidar."""
    import inspect

    from flidar_uq.workflow.inference_steps import infer_batch

    assert "lidar" not in inspect.signature(infer_batch).parameters
    assert not re.search(r"\blidar\b", _rule_text("infer_batch"))
    assert not re.search(r"\blidar\b", (REPO / "workflow/scripts/infer_batch.py").read_text())


@pytest.mark.parametrize("lidar", ["zephir300", "windcube_v1"])
def test_fit_global_model_uses_the_configured_lidars_surrogate(tmp_path, monkeypatch, lidar):
    """The global fit and the propagation use the same sigma_Z surrogate: the one of
    config campaign.lidar (the rule passes it, as it does to propagate)."""
    from flidar_uq import inference
    from flidar_uq.physics.surrogate import get_surrogate
    from flidar_uq.workflow import inference_steps

    seen = {}

    class _Fit:
        converged, failure_reasons = True, []

    def fake_fit_global(records, bin_fits, *, surrogate=None, **kwargs):
        seen["surrogate"] = surrogate
        return _Fit()

    monkeypatch.setattr(inference, "fit_global", fake_fit_global)
    # the NetCDF writer: the step's own now, flidar_uq.inference.save_fit after the split
    monkeypatch.setattr(inference_steps, "_save_fit", lambda fit, path: None, raising=False)
    monkeypatch.setattr(inference, "save_fit", lambda fit, path: None, raising=False)
    batch = tmp_path / "batch_000"
    batch.mkdir()
    pd.DataFrame({"bin_id": [1], "status": ["error"]}).to_csv(batch / "summary.csv", index=False)
    pd.DataFrame({"record_id": [0], "bin_id": [1]}).to_csv(tmp_path / "assign.csv", index=False)
    cfg = load_yaml(CONFIG)
    inference_steps.fit_global_model(
        [batch],
        tmp_path / "assign.csv",
        tmp_path / "global.nc",
        model="rho_only",
        inference=cfg["inference"],
        priors=cfg["priors"],
        lidar=lidar,
    )
    assert seen["surrogate"] is get_surrogate(lidar)
    assert re.search(r'lidar=config\["campaign"\]\["lidar"\]', _rule_text("fit_global_model"))
    # the fit's reference noise and the propagation are computed with the same settings
    assert "correction=correction_settings()" in _rule_text("fit_global_model")
    assert "settings=correction_settings()" in _rule_text("propagate")
    script = (REPO / "workflow/scripts/fit_global_model.py").read_text()
    assert "lidar=snakemake.params.lidar" in script


def test_snakemake_report_captions_exist_next_to_the_workflow():
    """The main outputs carry report(...) captions from workflow/report/*.rst (style item 17)."""
    text = "".join(p.read_text() for p in sorted((REPO / "workflow" / "rules").glob("*.smk")))
    captions = re.findall(r'caption="\.\./report/([\w.]+\.rst)"', text)
    assert {"records.rst", "bins.rst", "metrics.rst", "report_html.rst"} <= set(captions)
    for name in captions:
        assert (REPO / "workflow" / "report" / name).is_file(), name
    assert 'report: "workflow/report/workflow.rst"' in (REPO / "Snakefile").read_text()


def test_schema_point_target_sampling_keys():
    """The "auto"-or-value keys of the point target accept "auto" or a bounded value only."""
    schema = load_yaml(SCHEMA)
    for key, good, bad in (
        ("scan_heights_in_turn", [3, "auto"], [0, "automatic", 2.5]),
        ("scan_refocus_delay_s", [[0.3, 0.7], "auto"], [[0.3], [-1.0, 0.5], "x"]),
        ("turbulence_dt_s", [0.1, None, "auto"], [0.0, "none"]),
    ):
        for value in good:
            cfg = load_yaml(CONFIG)
            cfg["propagation"][key] = value
            jsonschema.validate(cfg, schema)
        for value in bad:
            cfg = load_yaml(CONFIG)
            cfg["propagation"][key] = value
            with pytest.raises(jsonschema.ValidationError):
                jsonschema.validate(cfg, schema)


@pytest.mark.slow
def test_default_campaign_meets_the_corrected_ti_acceptance(tmp_path):
    """Issue 5 acceptance on the main job: the default physics-mode virtual campaign with
    the shipped config. The 90 % intervals of corrected TI cover the truth for 85-95 % of
    the kept records (3-20 m/s) and the mean relative TI error is <= 2 %, with the
    uncorrected error beside it (it must show the motion effect the correction removes)."""
    snakemake(tmp_path, CONFIG, "--cores", "2", timeout=2400)
    check_outputs(tmp_path, truth=True)
    # the record table is written twice (Parquet: as given, validated); the later steps
    # write their record ids and new columns only: results/ stays under 100 MB
    files = [p for p in (tmp_path / "results").rglob("*") if p.is_file() and not p.is_symlink()]
    assert sum(p.stat().st_size for p in files) <= 100e6
    m = pd.read_csv(tmp_path / "results" / "ti" / "metrics.csv")
    truth = m[m["reference"] == "truth"].set_index("method")
    assert truth.loc["Bayesian", "n"] > 20000
    assert 0.85 <= truth.loc["Bayesian", "coverage"] <= 0.95
    assert abs(truth.loc["Bayesian", "mean_rel_ti_error"]) <= 0.02
    assert truth.loc["uncorrected", "mean_rel_ti_error"] > 0.05
    rec = pd.read_csv(tmp_path / "results" / "ti" / "records.csv")
    kept = rec["ti_corrected_median"].notna()
    # corrected records lie in the QC range for TI (3-40 m/s: offshore winter wind included)
    assert rec.loc[kept, "hws_mean_ms"].between(3.0, 40.0).all()
    # issue 11: every QC-kept record in 3-20 m/s has a corrected TI with an interval, and
    # the calibration holds in every 3-m/s speed group (not only in aggregate)
    qc_flags = pd.read_csv(tmp_path / "results" / "qc" / "flags.csv").set_index("record_id")
    qc_kept = qc_flags["kept"].reindex(rec["record_id"]).to_numpy(dtype=bool)
    in_range = rec["hws_mean_ms"].between(3.0, 20.0, inclusive="left").to_numpy()
    pool = rec[qc_kept & in_range]
    answered = pool[["ti_corrected_median", "ti_corrected_lo", "ti_corrected_hi"]].notna()
    assert answered.all(axis=1).mean() >= 0.99
    pool = pool.assign(speed_group=speed_group_label(pool["hws_mean_ms"]))
    groups = calibration_by_group(pool, "speed_group", min_count=200)
    groups = groups[groups["n"] >= 200]
    assert len(groups) >= 4
    assert groups["coverage"].between(0.85, 0.95).all(), groups.to_string()
    assert (groups["mean_rel_error"].abs() <= 0.015).all(), groups.to_string()
    overall = calibration_by_group(pool.assign(all="all"), "all").iloc[0]
    assert abs(overall["mean_rel_error"]) <= 0.01, overall.to_string()
    # the calibration is not bought with wider intervals: median width <= 1.2 x the bin
    # model's 20 % of TI
    assert (groups["median_rel_width"] <= 0.24).all(), groups.to_string()
    # the campaign's IMU series has the heave velocity: every corrected record's wave bands
    # have their directions of travel measured, its translation's size is the measured
    # heave's, and the report's first screen says so
    assert rec.loc[kept, "wave_direction_description"].eq("measured").all()
    assert rec.loc[kept, "translation_description"].eq("imu_series").all()
    html = (tmp_path / "results" / "report" / "report.html").read_text()
    assert "direction of travel measured from the heave" in html
    assert "translation measured in the IMU series" in html
    _library_path_gives_the_pipelines_tables(tmp_path)


def _library_path_gives_the_pipelines_tables(run_dir: Path) -> None:
    """flidar_uq.correct_campaign on the default run's records, QC flags, bins and record
    fit, with the reference and settings built from the shipped config by the library,
    writes the pipeline's records.csv, speed_bins.csv and groups.csv byte for byte."""
    import filecmp

    import flidar_uq as fu
    from flidar_uq.data.io import read_csv, read_table
    from flidar_uq.workflow.inputs import check_config, correction_inputs

    cfg = check_config(yaml.safe_load(CONFIG.read_text()))
    res = run_dir / "results"
    reference, settings = correction_inputs(cfg)
    flags = read_csv(res / "qc" / "flags.csv")
    records = read_table(res / "data" / "records.parquet").iloc[flags["record_id"].to_numpy()]
    bins = fu.BinTables(
        assignments=read_table(res / "bins" / "assignments.parquet"),
        table=read_csv(res / "bins" / "table.csv"),
        sigma_z=read_csv(res / "bins" / "sigma_z.csv"),
    )
    fit = fu.load_fit(res / "posterior" / "global.nc")
    result = fu.correct_campaign(records, fit, reference, settings, flags=flags, bins=bins)
    written = result.to_files(run_dir / "library")
    for name in ("records.csv", "speed_bins.csv", "groups.csv"):
        assert filecmp.cmp(run_dir / "library" / name, res / "ti" / name, shallow=False), name
    assert len(written) == 5


def test_qc_motion_and_bins_write_their_record_ids_and_new_columns_only(tmp_path):
    """After validation each stage writes the record ids it keeps and the columns it adds
    (Parquet); kept_records joins them into the table the stages saw in memory, the same
    values and dtypes, and refuses a record id the validated table lacks."""
    from flidar_uq.data import binning, io
    from flidar_uq.data import qc as qc_lib
    from flidar_uq.workflow import data_steps as ds

    data = tmp_path / "data.parquet"
    records = ds.validate_records(REPO / "tests" / "data" / "hand_written_campaign.csv", data)
    kept, motion, assign = (tmp_path / f"{n}.parquet" for n in ("kept", "motion", "assign"))
    ds.run_qc(data, tmp_path / "flags.csv", kept, tmp_path / "summary.csv", {})
    ds.motion_statistics(data, kept, motion, tmp_path / "roll_pitch.csv")
    widths = dict(hws_width_ms=2.0, amplitude_width_deg=2.0, period_width_s=2.0)
    ds.make_bins([data, motion], assign, tmp_path / "table.csv", min_count=2, nbatches=2, **widths)
    assert io.read_table(kept).columns.tolist() == ["record_id"]
    assert io.read_table(motion).columns.tolist() == ["record_id", "amplitude_deg", "period_s"]
    new = io.read_table(assign).columns.tolist()
    assert new[:2] == ["record_id", "hws_bin_ms"] and "bin_id" in new and "hws_mean_ms" not in new
    # what the stages computed in memory, from the validated records
    qc = qc_lib.run_qc(io.read_table(data), qc_lib.QCConfig())
    full = qc.kept.copy()
    full.insert(0, "record_id", full.index.to_numpy())
    want, _ = binning.bins_for_fitting(
        binning.add_harmonic_motion(full.reset_index(drop=True)), min_count=2, nbatches=2, **widths
    )
    got = ds.kept_records(data, motion, assign)
    assert len(got) > 0 and len(got) < len(records)
    pd.testing.assert_frame_equal(got, want, check_exact=True)
    io.write_table(pd.DataFrame({"record_id": [len(records)]}), tmp_path / "bad.parquet")
    with pytest.raises(ValueError, match=r"record_id \d+, which .*data\.parquet"):
        ds.kept_records(data, tmp_path / "bad.parquet")
