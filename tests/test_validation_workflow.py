"""Out-of-sample validation end to end (slow): a hold-out run on a virtual campaign, and a
fit on a trial campaign that corrects another (the deployment).

Every run is hermetic (``snakemake --directory <tmp_path>``), as in test_workflow.py.
"""

from __future__ import annotations

import glob
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
import yaml
from test_workflow import snakemake

from flidar_uq import inference as inf
from flidar_uq.validation.reference import holdout_mask
from flidar_uq.workflow.data_steps import kept_records
from flidar_uq.workflow.inference_steps import fit_global_model, fit_input
from flidar_uq.workflow.inputs import check_config, load_config_file

#: A cup-referenced campaign at one height: 10 days (1440 records), the default sea.
SCENARIO = {
    "name": "holdout_cup",
    "n_records": 1440,
    "heights_m": [85.0],
    "reference_instrument": "cup",
    "n_workers": 2,
}

#: Sampler settings of these runs (the record fit converges on ~1000 records).
INFERENCE = {"nwalkers": 16, "nsteps": 250, "nburn": 100, "ndraws": 100, "nbatches": 2}


def campaign_config(workdir: Path, *, seed: int, validation: dict, title: str) -> Path:
    scenario = workdir / "scenario.yaml"
    scenario.write_text(yaml.safe_dump(SCENARIO))
    cfg = {
        "campaign": {"source": "virtual", "scenario": str(scenario), "seed": seed},
        "inference": INFERENCE,
        "propagation": {"ndraws": 200, "budget_ndraws": 50},
        "report": {"title": title},
        "validation": validation,
    }
    path = workdir / "config.yaml"
    path.write_text(yaml.safe_dump(cfg))
    return path


def _posterior_draws(path) -> dict:
    fit = inf.load_fit(path)
    return {k: np.asarray(v) for k, v in fit.draws.items()}


def _refit(cfg_path: Path, assignments: pd.DataFrame, out: Path, holdout: dict) -> dict:
    """The run's record fit again (the run's config with its defaults, its reference and
    correction settings as the workflow resolves them), on ``assignments``."""
    from dataclasses import asdict

    from flidar_uq.workflow.inputs import check_reference, correction_inputs

    full = check_config(load_config_file(cfg_path))
    fit_global_model(
        [],
        fit_input(assignments, holdout),
        out,
        model="record",
        inference=full["inference"],
        priors=full["priors"],
        lidar=full["campaign"]["lidar"],
        reference=check_reference(full).to_config(),
        correction=asdict(correction_inputs(full)[1]),
    )
    return _posterior_draws(out)


@pytest.mark.slow
def test_holdout_run_validates_on_records_the_fit_never_saw(tmp_path):
    from test_report import assert_first_screen, assert_no_absolute_path

    run = tmp_path / "run"
    run.mkdir()
    holdout = {"holdout": {"mode": "last_days", "days": 3}}
    cfg_path = campaign_config(run, seed=11, validation=holdout, title="Hold-out buoy, 10 days")
    snakemake(run, cfg_path, "--cores", "2", timeout=900)
    res = run / "results"
    records = pd.read_csv(res / "ti" / "records.csv")
    held = holdout_mask(records["timestamp"], mode="last_days", days=3)
    assert 0.2 < held.mean() < 0.4  # 3 of 10 days
    # the fit saw only the in-sample references: refit with one held-out reference changed
    # -> the same posterior bit for bit; one in-sample reference changed -> another one
    data = res / "data" / "records.parquet"
    assignments = kept_records(
        data, res / "motion" / "records.parquet", res / "bins" / "assignments.parquet"
    )
    hold = holdout["holdout"] | {"records": str(data)}
    base = _refit(cfg_path, assignments, tmp_path / "fit.nc", hold)
    a_held = holdout_mask(
        assignments["timestamp"], mode="last_days", days=3, end=records["timestamp"].max()
    )
    ok = assignments["ref_hws_std_ms"].notna().to_numpy()
    for in_sample, expect_same in ((False, True), (True, False)):
        k = int(np.flatnonzero(ok & (a_held != in_sample))[0])
        pert = assignments.copy()
        pert.loc[k, "ref_hws_std_ms"] *= 1.5
        draws = _refit(cfg_path, pert, tmp_path / f"fit_{in_sample}.nc", hold)
        same = all(np.array_equal(draws[p], base[p]) for p in base)
        assert same == expect_same, (in_sample, k)
    # the report validates on the held-out records and says so; in-sample beside
    html = (res / "report" / "report.html").read_text()
    assert "Held out: the reference of the last 3 days was removed from the fit" in html
    assert "Hold-out buoy, 10 days" in html
    assert ">held out<" in html and ">in sample<" in html
    assert_first_screen(res / "report" / "report.html", tmp_path, "holdout")
    assert_no_absolute_path(html, tmp_path)
    # coverage of the reference TI on the held-out records: calibrated
    v = records[held & records["ti_ref"].notna() & records["ti_corrected_median"].notna()]
    inside = (v["ti_ref"] >= v["ti_corrected_lo"]) & (v["ti_ref"] <= v["ti_corrected_hi"])
    assert len(v) > 200
    assert 0.85 <= inside.mean() <= 0.95, inside.mean()


@pytest.mark.slow
def test_fit_on_trial_campaign_corrects_the_deployment(tmp_path):
    from test_report import assert_first_screen, assert_no_absolute_path

    trial, deploy = tmp_path / "trial", tmp_path / "deploy"
    trial.mkdir()
    deploy.mkdir()
    snakemake(trial, campaign_config(trial, seed=21, validation={}, title="Trial at the mast"),
              "--cores", "2", timeout=900)  # fmt: skip
    posterior = trial / "results" / "posterior" / "global.nc"
    cfg = campaign_config(
        deploy, seed=22, validation={"trial_posterior": str(posterior)}, title="Deployment"
    )
    proc = snakemake(deploy, cfg, "--cores", "2", timeout=900)
    res = deploy / "results"
    assert not (res / "inference" / "global_record.nc").exists()  # no fit of its own
    assert "rule fit_global_model" not in proc.stdout + proc.stderr
    records = pd.read_csv(res / "ti" / "records.csv")
    assert records["ti_corrected_median"].notna().mean() > 0.8
    trial_draws = _posterior_draws(posterior)
    deploy_draws = _posterior_draws(res / "posterior" / "global.nc")
    assert all(np.array_equal(trial_draws[p], deploy_draws[p]) for p in trial_draws)
    html = (res / "report" / "report.html").read_text()
    assert "Held out: the model was fitted on a trial campaign (posterior global.nc)" in html
    assert ">in sample<" not in html.split('id="validation-headline"')[1].split("</div>")[0]
    assert "global.nc (trial campaign&#39;s posterior)" in html
    assert_first_screen(res / "report" / "report.html", tmp_path, "trial_deployment")
    assert_no_absolute_path(html, tmp_path)
    v = records[records["ti_ref"].notna() & records["ti_corrected_median"].notna()]
    inside = (v["ti_ref"] >= v["ti_corrected_lo"]) & (v["ti_ref"] <= v["ti_corrected_hi"])
    assert 0.8 <= inside.mean() <= 0.97, inside.mean()
    # the record model's deployment runs no per-bin fit (the bin model's only)
    assert not glob.glob(str(res / "inference" / "batch_*"))
