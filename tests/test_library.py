"""The correction as a library: Reference.from_config per kind, correct_campaign equal to the
workflow step's files, the package's user path, and the code of docs/library.md run as is."""

from __future__ import annotations

import dataclasses
import filecmp
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from test_propagate import _bin_fit, _global_fit, _records

import flidar_uq
from flidar_uq.correction.campaign import (
    RESULT_FILES,
    BinTables,
    CorrectionSettings,
    correct_campaign,
)
from flidar_uq.correction.reference import REFERENCE_KINDS, Reference
from flidar_uq.data.io import write_table
from flidar_uq.workflow.files import write_csv
from flidar_uq.workflow.propagation_step import propagate

REPO = Path(__file__).resolve().parents[1]


@pytest.mark.parametrize("kind", REFERENCE_KINDS)
def test_reference_from_config_of_each_kind(kind):
    ref = Reference.from_config({"kind": kind, "height_m": [58.0, 85.0]}, lidar="windcube_v2")
    assert ref.kind == kind and ref.lidar == "windcube_v2"
    assert ref.sampling_correlation == 0.0  # a user's fixed lidar: its own scan schedule
    assert ref.height_m == (58.0, 85.0) and ref.height_label() == "58;85"
    # the workflow passes it as plain values and resolves it again: the same reference
    assert Reference.from_config(ref.to_config(), lidar="zephir300") == ref


def test_reference_from_config_refuses_an_unknown_kind_in_one_line():
    with pytest.raises(ValueError) as err:
        Reference.from_config({"kind": "mast"}, lidar="zephir300")
    assert str(err.value) == (
        "config key reference.kind='mast' must be one of cup, sonic, fixed_lidar, none"
    )


def test_correction_settings_from_the_config_sections():
    cfg = {
        "propagation": {
            "ndraws": 50,
            "scan_heights_in_turn": "auto",
            "scan_refocus_delay_s": [0.2, 0.6],
        },
        "report": {"sector_width_deg": 45, "group_min_count": 3},
        "inference": {"seed": 7},
        "campaign": {"lidar": "windcube_v2"},
    }
    s = CorrectionSettings.from_config(cfg)
    assert (s.ndraws, s.seed, s.lidar, s.sector_width_deg, s.min_count) == (
        50, 7, "windcube_v2", 45, 3
    )  # fmt: skip
    assert s.scan_heights_in_turn is None and s.scan_refocus_delay_s == (0.2, 0.6)


def test_correction_inputs_resolve_the_auto_keys_from_the_virtual_scenario():
    """The shipped config's "auto" scan keys and reference kind come from its virtual
    scenario; the same config on the user's files takes the data-driven defaults."""
    import yaml

    from flidar_uq.campaign.scenarios import reference_sampling
    from flidar_uq.workflow.inputs import check_config, correction_inputs, scenario_path

    cfg = check_config(yaml.safe_load((REPO / "config" / "config.yaml").read_text()))
    assert cfg["propagation"]["scan_heights_in_turn"] == "auto"
    virtual = reference_sampling(scenario_path(cfg["campaign"]))
    reference, settings = correction_inputs(cfg)
    assert reference.kind == virtual["reference_kind"]
    assert settings.scan_heights_in_turn == virtual["heights_in_turn"]
    assert settings.scan_refocus_delay_s == tuple(virtual["refocus_delay_s"])
    assert settings.turbulence_dt_s == virtual["turbulence_dt_s"]
    files = {**cfg, "campaign": {**cfg["campaign"], "source": "files"}}
    assert scenario_path(files["campaign"]) is None
    _, defaults = correction_inputs(files)
    assert defaults.scan_heights_in_turn is None and defaults.turbulence_dt_s is None
    assert defaults.scan_refocus_delay_s == CorrectionSettings().scan_refocus_delay_s


def _campaign_files(tmp_path: Path) -> dict:
    """A two-bin campaign of the bin motion model written as the pipeline's inputs of the
    propagation (one record flagged by QC, one unbinned), the fits kept in memory."""
    rec = pd.concat(
        [_records([0.6, 0.7, 0.8], bin_id=1), _records([0.5, 0.9], hws=11.0, bin_id=2)],
        ignore_index=True,
    )
    n = len(rec)
    rec = rec.drop(columns="bin_id").assign(
        timestamp=[f"2015-04-01T0{i}:00:00Z" for i in range(n)],
        height_m=[58.0, 85.0, 58.0, 85.0, 58.0],
        ref_hws_mean_ms=rec["hws_mean_ms"] * 0.98,
        ref_hws_std_ms=rec["hws_std_ms"] * 0.8,
        wd_mean_deg=[10.0, 40.0, 200.0, 250.0, 355.0],
    )
    flags = pd.DataFrame(
        {"record_id": np.arange(n), "timestamp": rec["timestamp"],
         "reasons": ["", "", "availability_low", "", ""]}
    )  # fmt: skip
    assignments = pd.DataFrame({"record_id": [0, 1, 3, 4], "bin_id": [1, 1, 2, 2]})
    table = pd.DataFrame({"bin_id": [1, 2], "fitted": [True, True]})
    sigma_z = pd.DataFrame({"bin_id": [1, 2], "sigma_z_ms": [0.2, 0.25]})
    status = pd.DataFrame({"bin_id": [1, 2], "status": ["ok", "ok"]})
    paths = {}
    for name, df in (("flags", flags), ("table", table), ("sigma_z", sigma_z),
                     ("bin_fits", status)):  # fmt: skip
        paths[name] = tmp_path / f"{name}.csv"
        write_csv(df, paths[name])
    for name, df in (("records", rec), ("assignments", assignments)):  # the pipeline's Parquet
        paths[name] = tmp_path / f"{name}.parquet"
        write_table(df, paths[name])
    fits = {1: _bin_fit(1, 3.0, 4.0), 2: _bin_fit(2, 2.5, 5.0)}
    bins = BinTables(assignments, table, sigma_z, status=status, fits=fits)
    return {"paths": paths, "records": rec, "flags": flags, "bins": bins, "fits": fits}


def test_correct_campaign_writes_the_workflow_steps_files(tmp_path, monkeypatch):
    from flidar_uq import inference
    from flidar_uq.workflow import propagation_step

    camp = _campaign_files(tmp_path)
    gfit = _global_fit(0.3, 0.02, 0.05)
    monkeypatch.setattr(inference, "load_fit", lambda path: gfit)
    monkeypatch.setattr(propagation_step, "load_bin_fits", lambda dirs, status: camp["fits"])
    reference = Reference.from_config(
        {"kind": "cup", "height_m": 70.0, "separation_m": 60.0}, lidar="zephir300"
    )
    settings = CorrectionSettings(ndraws=60, budget_ndraws=30, seed=5, min_count=2)
    p = camp["paths"]
    propagate(
        records_path=p["records"], flags_path=p["flags"], assignments_path=p["assignments"],
        table_path=p["table"], sigma_z_path=p["sigma_z"], bin_fits_path=p["bin_fits"],
        batch_dirs=[], global_path=tmp_path / "global.nc", out_dir=tmp_path / "step",
        reference=reference.to_config(), settings=dataclasses.asdict(settings),
    )  # fmt: skip
    result = correct_campaign(
        camp["records"], gfit, reference, settings, flags=camp["flags"], bins=camp["bins"]
    )
    written = result.to_files(tmp_path / "library")
    assert sorted(f.name for f in written.values()) == sorted(RESULT_FILES.values())
    for name, path in written.items():
        assert filecmp.cmp(path, tmp_path / "step" / path.name, shallow=False), name
    out = result.records
    assert out["flags"].tolist()[2] == "availability_low"
    assert out["ti_corrected_median"].notna().sum() == 4  # the four binned records
    assert set(result.groups["grouping"]) == {"campaign", "direction sector", "sea state"}
    assert result.metrics["reference_height_m"].iloc[0] == "70"


@pytest.mark.slow  # ~1 min on a loaded machine: two corrections of 4 records with budgets
def test_without_a_reference_the_regime_prior_widens_the_bins_and_the_budget_names_it(tmp_path):
    """No reference (kind none): the regime discrepancy's prior
    (``reference.regime_discrepancy_prior_sd``, one log-normal factor shared by the
    records) is carried into every group statistic: the campaign mean's 90 % interval
    widens, in quadrature, by about what a 2 % log-sd adds (``(2 x 1.645 x 0.02)^2``), and
    the uncertainty budget names it with a share of its own; with a prior sd of 0 nothing
    is added and the budget gives it no share. 8000 draws: the groups hold two records, their
    intervals are 17 % of TI wide, and at 1000 draws the Monte Carlo error of the two widths'
    difference was a third of the 2 % term's (1.31 and 1.73 where 0.97-1.08 at 8000)."""
    camp = _campaign_files(tmp_path)
    settings = CorrectionSettings(ndraws=8000, budget_ndraws=1000, seed=5, min_count=2)
    width, budgets = {}, {}
    for prior_sd in (0.0, 0.02):
        # g's prior held at 0: the regime prior alone widens the intervals
        ref = Reference(
            kind="none", lidar_std_ratio_log_sd=0.0, regime_discrepancy_prior_sd=prior_sd
        )
        res = correct_campaign(
            camp["records"], _global_fit(0.3, 0.02, 0.05), ref, settings,
            flags=camp["flags"], bins=camp["bins"],
        )  # fmt: skip
        g = res.groups[res.groups["grouping"] == "campaign"]
        width[prior_sd] = ((g["ti_mean_hi"] - g["ti_mean_lo"]) / g["ti_mean"]).to_numpy()
        budgets[prior_sd] = res.budget
    added = (width[0.02] ** 2 - width[0.0] ** 2) / (2 * 1.645 * 0.02) ** 2
    assert np.all((added > 0.5) & (added < 1.5)), added
    assert not np.any(budgets[0.0]["share_regime_discrepancy"] > 0.0)
    share = budgets[0.02].loc[budgets[0.02]["grouping"] == "campaign", "share_regime_discrepancy"]
    assert np.all(share > 0.03), share


def test_correct_campaign_refuses_a_bin_model_without_its_bins():
    with pytest.raises(ValueError, match="bin motion model needs the bins"):
        correct_campaign(_records([0.6]), _global_fit(0.3), Reference(), CorrectionSettings())


def test_the_package_exports_the_user_path_lazily():
    code = (
        "import sys, flidar_uq; assert 'flidar_uq.correction' not in sys.modules; "
        "flidar_uq.correct_campaign; assert 'flidar_uq.correction.campaign' in sys.modules"
    )
    subprocess.run([sys.executable, "-c", code], check=True)
    for name in flidar_uq.__all__:
        assert getattr(flidar_uq, name) is not None, name
    with pytest.raises(AttributeError, match="no attribute 'nope'"):
        flidar_uq.nope  # noqa: B018


def _doc_code() -> str:
    text = (REPO / "docs" / "library.md").read_text()
    (block,) = re.findall(r"```python\n(.*?)```", text, flags=re.S)
    return block


def test_the_shipped_example_is_the_tests_hand_written_campaign():
    from flidar_uq.resources import resource_path

    shipped = resource_path("examples", "hand_written_campaign.csv")
    assert (
        shipped.read_bytes() == (REPO / "tests" / "data" / "hand_written_campaign.csv").read_bytes()
    )


@pytest.mark.slow  # ~40 s: a short record fit of 30 records
def test_the_library_page_runs_end_to_end(tmp_path, monkeypatch):
    """The doc's code as it is, from a working directory outside the repository."""
    monkeypatch.chdir(tmp_path)
    exec(compile(_doc_code(), "docs/library.md", "exec"), {})
    records = pd.read_csv(tmp_path / "library_ti" / "records.csv")
    assert len(records) == 30 and records["ti_corrected_median"].notna().any()
    written = sorted(p.name for p in (tmp_path / "library_ti").iterdir())
    assert written == sorted(RESULT_FILES.values())


def test_settings_from_config_are_the_propagate_rules(tmp_path):
    """None: the shipped config's reference and settings, the very values the workflow's
    correction_settings() passes to propagate; a user file is laid over the defaults."""
    import yaml

    from flidar_uq.workflow.inputs import ConfigError, check_config, correction_inputs

    shipped = check_config(yaml.safe_load((REPO / "config" / "config.yaml").read_text()))
    reference, settings = correction_inputs(shipped)
    assert flidar_uq.settings_from_config() == {"reference": reference, "settings": settings}
    user = tmp_path / "user.yaml"
    user.write_text(
        yaml.safe_dump(
            {
                "campaign": {"source": "files", "records": "r.csv"},
                "reference": {"kind": "cup", "height_m": [58.0, 85.0], "separation_m": 60.0},
                "propagation": {"ndraws": 100},
                "inference": {"seed": 11},
            }
        )
    )
    got = flidar_uq.settings_from_config(user)
    assert got["reference"].kind == "cup" and got["reference"].separation_m == 60.0
    s = got["settings"]
    assert (s.ndraws, s.seed, s.budget_ndraws) == (100, 11, settings.budget_ndraws)
    assert s.scan_heights_in_turn is None  # the user's files: counted in the records
    with pytest.raises(ConfigError, match="no such config file"):
        flidar_uq.settings_from_config(tmp_path / "nope.yaml")


def test_to_files_refuses_a_pipeline_runs_results_unless_overwrite(tmp_path):
    from flidar_uq.correction.campaign import CorrectionResult, pipeline_results

    empty = pd.DataFrame({"a": [1.0]})
    result = CorrectionResult(empty, empty, empty, empty, empty)
    run = tmp_path / "run"
    (run / "results" / "ti").mkdir(parents=True)
    assert pipeline_results(run / "results" / "ti") is None  # no pipeline ran here
    result.to_files(run / "results" / "ti")
    (run / ".snakemake").mkdir()
    assert pipeline_results(run / "results" / "ti") == (run / "results").resolve()
    before = (run / "results" / "ti" / "records.csv").stat().st_mtime_ns
    with pytest.raises(ValueError, match=r"results of a pipeline run.*overwrite=True") as err:
        result.to_files(run / "results" / "ti")
    assert str(run / "results" / "ti") in str(err.value)
    assert (run / "results" / "ti" / "records.csv").stat().st_mtime_ns == before
    result.to_files(run / "results" / "ti", overwrite=True)
    result.to_files(run / "library")  # beside results/: not the pipeline's
    assert sorted(p.name for p in (run / "library").iterdir()) == sorted(RESULT_FILES.values())


@pytest.mark.slow  # ~2 min: the tiny virtual campaign through the pipeline's record fit
def test_the_library_gives_the_pipelines_speed_bins(tmp_path):
    """The pipeline on the tests' tiny virtual campaign, then correct_campaign on its
    records, QC flags and record fit with settings_from_config of the same config: the
    same speed_bins.csv byte for byte (the propagation draws from the config's seed, so no
    Monte Carlo error separates them). The fit is the pipeline's record fit: the library
    reads it with load_fit."""
    from test_workflow import snakemake, tiny_config

    from flidar_uq.workflow.files import read_csv

    cfg = tiny_config(tmp_path)
    snakemake(tmp_path, cfg, "--cores", "2", "results/ti/speed_bins.csv")
    res = tmp_path / "results"
    records = flidar_uq.read_records(res / "data" / "records.parquet")
    flags = read_csv(res / "qc" / "flags.csv")
    assert not flags["fail_std_pattern"].any()  # a virtual campaign's stds keep their pattern
    # the record motion model's fit, the propagate rule's input
    fit = flidar_uq.load_fit(res / "inference" / "global_record.nc")
    result = flidar_uq.correct_campaign(
        records, fit, **flidar_uq.settings_from_config(cfg), flags=flags
    )
    with pytest.raises(ValueError, match="results of a pipeline run"):
        result.to_files(res / "ti")
    written = result.to_files(tmp_path / "library")
    assert len(result.speed_bins) > 1
    assert written["speed_bins"].read_bytes() == (res / "ti" / "speed_bins.csv").read_bytes()


@pytest.mark.slow  # ~1 min: two short record fits of 30 records
def test_ti_in_percent_rows_are_flagged_and_leave_the_clean_rows_corrected_ti():
    """10 of the hand-written campaign's 30 rows with TI in percent in the std column: QC
    flags exactly those (std_pattern), and the corrected TI of the other rows moves by
    less than their 90 % interval's half-width against the clean table's (both fitted and
    corrected from the same seeds; the two fits differ by the records they see)."""
    from test_qc import PERCENT_ROWS, ti_percent_in_std

    from flidar_uq.resources import resource_path

    clean = flidar_uq.read_records(resource_path("examples", "hand_written_campaign.csv"))
    reference = Reference.from_config(
        {"kind": "cup", "height_m": [58.0, 85.0], "separation_m": 60.0}, lidar="zephir300"
    )
    sampler = flidar_uq.SamplerSettings(nwalkers=16, nsteps=300, nburn=100, ndraws=100)
    settings = CorrectionSettings(ndraws=100, budget_ndraws=100, seed=1)

    def corrected(records):
        qc = flidar_uq.run_qc(records)
        fit = flidar_uq.fit_record_model(qc.kept, settings=sampler, seed=1)
        return qc, correct_campaign(records, fit, reference, settings, flags=qc.flags).records

    _, a = corrected(clean)
    qc, b = corrected(ti_percent_in_std(clean))
    assert qc.flags.loc[qc.flags["fail_std_pattern"], "row"].tolist() == PERCENT_ROWS
    assert b["ti_corrected_median"].iloc[np.asarray(PERCENT_ROWS) - 1].isna().all()
    others = ~np.isin(np.arange(1, 31), PERCENT_ROWS) & a["ti_corrected_median"].notna()
    assert others.sum() >= 10
    half_width = (a["ti_corrected_hi"] - a["ti_corrected_lo"])[others] / 2
    moved = (b["ti_corrected_median"] - a["ti_corrected_median"])[others].abs()
    assert (moved < half_width).all(), pd.DataFrame({"moved": moved, "half": half_width})
