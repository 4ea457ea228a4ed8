"""``flidar-uq run``: the log-line parser, the summary, the failure report, and (slow) a tiny
run through the console script."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pandas as pd
import pytest
import yaml

from flidar_uq.cli import main
from flidar_uq.workflow.run_console import (
    MAX_LINE_CHARS,
    RunConsole,
    failure_lines,
    run_pipeline,
    run_summary,
)

REPO = Path(__file__).resolve().parents[1]

#: Snakemake 9's log stream of a run (abridged: two rules, the checkpoint, a bin rule).
LOG = """\
Building DAG of jobs...
Job stats:
job                  count
-----------------  -------
campaign                 1
bins                     1
infer_batch             12
all                      1
total                   15

Select jobs to execute...

[Mon Dec  7 19:41:12 2026]
localrule campaign:
    input: tiny_scenario.yaml
    output: {outputs}
    log: results/logs/campaign.log
    jobid: 3
Finished jobid: 3 (Rule: campaign)
1 of 15 steps (7%) done

[Mon Dec  7 19:41:26 2026]
localcheckpoint bins:
    log: results/logs/bins.log
    jobid: 4
DAG of jobs will be updated after completion.
Finished jobid: 4 (Rule: bins)
2 of 15 steps (13%) done
Updating checkpoint dependencies.
{batches}
"""


def _batch(k: int) -> str:
    return (
        f"[Mon Dec  7 19:42:22 2026]\nlocalrule infer_batch:\n"
        f"    log: results/logs/infer_batch_{k:03d}.log\n    jobid: {10 + k}\n"
        f"    wildcards: batch={k:03d}\nFinished jobid: {10 + k} (Rule: infer_batch)\n"
        f"{3 + k} of 22 steps (50%) done\n"
    )


def _feed(text: str) -> list[str]:
    out: list[str] = []
    console = RunConsole(out.append)
    for line in text.splitlines(keepends=True):
        console.feed(line)
    console.finish()
    return out


def test_console_one_line_per_step_in_words_never_a_file_list():
    outputs = ", ".join(f"results/campaign/part_{i:05d}.csv" for i in range(3000))
    lines = _feed(LOG.format(outputs=outputs, batches="".join(_batch(k) for k in range(12))))
    assert all(len(ln) <= MAX_LINE_CHARS for ln in lines)
    assert not any("part_0" in ln for ln in lines)
    assert lines[0] == "[0 of 15 steps done] campaign: generate or read the campaign's records"
    assert lines[1].startswith("[1 of 15 steps done] binning: group the records")
    # the checkpoint's new total is said once, in words, not as a silent jump
    (grown,) = [ln for ln in lines if "checkpoint" in ln]
    assert "22 steps in all now" in grown
    jobs = [ln for ln in lines if "infer_batch" in ln or "batch of bins" in ln]
    assert jobs[0].endswith("(job 1 of 12)") and jobs[-1].endswith("(job 12 of 12)")
    assert len(jobs) == 12  # a job count of 12: every job announced


def test_console_thins_the_job_lines_of_a_rule_with_many_jobs():
    batches = "".join(_batch(k) for k in range(300))
    log = LOG.replace("infer_batch             12", "infer_batch            300")
    lines = _feed(log.format(outputs="x.csv", batches=batches))
    jobs = [ln for ln in lines if "batch of bins" in ln]
    assert jobs[0].endswith("(job 1 of 300)") and jobs[-1].endswith("(job 300 of 300)")
    assert 10 <= len(jobs) <= 12


def test_console_fleet_rules_keep_the_campaign_name():
    lines = _feed("localrule north_qc:\n    jobid: 1\n[Mon Dec  7 19:41:12 2026]\n")
    assert lines == ["[starting] [north] QC: flag records that fail the quality checks"]


def test_console_follows_the_progress_lines_of_the_running_steps_logs(tmp_path):
    """A step's log path is read from Snakemake's job block; the progress lines its log
    gains (ProgressLog's and the sampler's phases) are emitted once each, other log lines
    and a line still being written are not."""
    out = []
    console = RunConsole(out.append)
    for line in ("rule campaign:", "    output: results/campaign/records.parquet",
                 "    log: results/logs/campaign.log", "    jobid: 1", ""):  # fmt: skip
        console.feed(line)
    log = tmp_path / "results" / "logs" / "campaign.log"
    log.parent.mkdir(parents=True)
    log.write_text(
        "INFO flidar_uq.workflow: numeric environment: x\n"
        "INFO flidar_uq.campaign.physics_mode: campaign default: 4320 of 8640 records (50 %) "
        "in 40.1 s, about 40 s left\n"
        "INFO flidar_uq.inference.sampler: record fit: burn-in done, 400 steps per walker, 6"
    )
    console.follow_logs(tmp_path)
    progress = [ln for ln in out if ln.startswith("    ")]
    assert progress == [
        "    campaign default: 4320 of 8640 records (50 %) in 40.1 s, about 40 s left"
    ]
    with log.open("a") as f:
        f.write("1.2 s\n")
    console.follow_logs(tmp_path)
    console.follow_logs(tmp_path)
    progress = [ln for ln in out if ln.startswith("    ")]
    assert progress[1:] == ["    record fit: burn-in done, 400 steps per walker, 61.2 s"]


def test_failure_names_the_step_its_log_and_the_log_tail(tmp_path):
    log = tmp_path / "results" / "logs" / "qc.log"
    log.parent.mkdir(parents=True)
    log.write_text("".join(f"line {i}\n" for i in range(40)) + "ValueError: " + "x" * 500)
    console = RunConsole(lambda _: None)
    for line in [
        "localrule qc:",
        "    log: results/logs/qc.log",
        "Error in rule qc:",
        "    message: None",
        "    log: results/logs/qc.log (check log file(s) for error details)",
        "Shutting down, this might take some time.",
    ]:
        console.feed(line)
    out = failure_lines(console, tmp_path, 1)
    assert out[0].startswith("flidar-uq run: step qc failed (flag records")
    assert out[1] == f"log file: {log}"
    assert out[-1].startswith("  ValueError: xxx") and len(out[-1]) == MAX_LINE_CHARS
    assert "  line 39" in out and "  line 20" not in out


def _write_results(results: Path) -> None:
    (results / "ti").mkdir(parents=True)
    (results / "report").mkdir()
    (results / "data").mkdir()
    (results / "report" / "report.html").write_text("<html></html>")
    pd.DataFrame(
        {
            "height_m": [58.0, 58.0, 85.0],
            "hws_bin_ms": [14.0, 15.0, 15.0],
            "n": [30, 12, 3],
            "ti_rep": [0.15, 0.130, 0.12],
            "ti_rep_lo": [0.14, 0.125, 0.11],
            "ti_rep_hi": [0.16, 0.133, 0.13],
            "ti_rep_uncorrected": [0.19, 0.170, 0.16],
        }
    ).to_csv(results / "ti" / "speed_bins.csv", index=False)
    pd.DataFrame(
        {
            "reference": ["reference lidar", "reference lidar"],
            "method": ["uncorrected", "Bayesian"],
            "n": [40, 40],
            "md_ti": [0.021, -0.001],
            "rmse_ti": [0.025, 0.006],
            "coverage": [float("nan"), 0.9],
            "credible_mass": [0.9, 0.9],
        }
    ).to_csv(results / "ti" / "metrics.csv", index=False)
    (results / "data" / "validation.json").write_text(
        json.dumps({"blocking": [], "warnings": ["3 gaps longer than 1 h in the records"]})
    )


def test_summary_report_rep_ti_categories_validation_and_warnings(tmp_path):
    _write_results(tmp_path / "results")
    out = run_summary(tmp_path / "results")
    assert out[0] == f"report: {tmp_path / 'results' / 'report' / 'report.html'}"
    # 0.130 is within C (0.12 x 1.123 = 0.135), 0.170 within A (0.16 x 1.123 = 0.180)
    assert "  58 m: corrected 0.130 (0.125-0.133), category C; uncorrected 0.170, category A" in out
    assert any(ln.startswith("  85 m: none, too few records in the 15-m/s bin (3)") for ln in out)
    (val,) = [ln for ln in out if "against the reference lidar" in ln]
    assert "(40 records)" in val and "uncorrected bias +0.0210, RMSE 0.0250" in val
    assert "corrected bias -0.0010, RMSE 0.0060" in val and "90% of the 90%" in val
    assert out[-2:] == ["warnings:", "  - 3 gaps longer than 1 h in the records"]


def test_summary_without_results_says_so(tmp_path):
    assert run_summary(tmp_path / "results") == [
        f"report: none written ({tmp_path / 'results' / 'report' / 'report.html'})",
        "warnings: none",
    ]


def test_run_failure_exits_non_zero_with_the_step_and_log(tmp_path, monkeypatch, capsys):
    """A failing step of a one-rule Snakefile through ``flidar-uq run`` in-process."""
    snakefile = tmp_path / "Snakefile"
    snakefile.write_text(
        'rule boom:\n    output: "b.txt"\n    log: "logs/boom.log"\n'
        "    shell: \"echo 'bad thing happened' > {log}; exit 3\"\n"
    )
    monkeypatch.chdir(tmp_path)
    code = main(["run", "--cores", "1", "-s", str(snakefile)])
    out = capsys.readouterr().out.splitlines()
    assert code != 0
    assert "flidar-uq run: step boom failed (boom)" in out
    assert "log file: logs/boom.log" in out and out[-1] == "  bad thing happened"


def test_run_passes_other_arguments_to_snakemake_and_none_to_other_commands(capsys):
    assert main(["validate", "x.csv", "--cores", "2"]) == 2
    assert "unrecognized arguments: --cores 2" in capsys.readouterr().err
    assert run_pipeline(["--version"], emit=lambda _: None) == 0


@pytest.mark.slow
def test_flidar_uq_run_tiny_campaign_talks_and_summarises(tmp_path):
    """A tiny campaign whose records all sit in the 15-m/s bin, run by the console script."""
    sys.path.insert(0, str(Path(__file__).parent))
    from test_workflow import TINY_SCENARIO, tiny_config

    wind = {"reference_height_m": 85.0, "hws_min_ms": 14.85, "hws_max_ms": 15.35}
    scenario = TINY_SCENARIO | {"heights_m": [82.0, 85.0], "wind": wind}
    (tmp_path / "tiny_scenario.yaml").write_text(yaml.safe_dump(scenario))
    config = tiny_config(tmp_path)
    cfg = yaml.safe_load(config.read_text())
    cfg["report"]["group_min_count"] = 5
    config.write_text(yaml.safe_dump(cfg))
    exe = Path(sys.executable).with_name("flidar-uq")
    proc = subprocess.run(
        [str(exe), "run", "--cores", "1", "--configfile", str(config), "--directory",
         str(tmp_path), "-s", str(REPO / "Snakefile")],
        capture_output=True, text=True, timeout=900, cwd=tmp_path,
    )  # fmt: skip
    lines = proc.stdout.splitlines()
    assert proc.returncode == 0, proc.stdout[-3000:] + proc.stderr[-3000:]
    assert lines and all(len(ln) <= MAX_LINE_CHARS for ln in lines)
    for words in ("campaign:", "QC:", "sigma_Z:", "fit:", "propagation:", "report:"):
        assert any(words in ln and "steps done]" in ln for ln in lines), words
    assert f"report: {tmp_path / 'results' / 'report' / 'report.html'}" in lines
    reps = [ln for ln in lines if ln.startswith(("  82 m:", "  85 m:"))]
    assert len(reps) == 2
    for ln in reps:
        assert "corrected 0." in ln and "uncorrected 0." in ln
        assert ln.count("category ") == 2
    assert any(ln.startswith("  per-record TI against the truth") for ln in lines)
    # the long steps' progress, read from their logs while they run
    assert any(ln.startswith("    ") and "steps per walker" in ln for ln in lines), lines


def test_verbose_shows_snakemakes_own_output_unchanged(tmp_path, monkeypatch, capfd):
    snakefile = tmp_path / "Snakefile"
    snakefile.write_text('rule ok:\n    output: "a.txt"\n    shell: "echo ok > {output}"\n')
    monkeypatch.chdir(tmp_path)
    assert main(["run", "--cores", "1", "--verbose", "-s", str(snakefile)]) == 0
    verbose = capfd.readouterr()
    assert "localrule ok:" in verbose.err and "1 of 1 steps (100%) done" in verbose.err
    (tmp_path / "a.txt").unlink()
    assert main(["run", "--cores", "1", "-s", str(snakefile)]) == 0
    quiet = capfd.readouterr()
    assert "localrule" not in quiet.out + quiet.err
    assert quiet.out.splitlines()[0] == "[0 of 1 steps done] ok: a step of the pipeline"


def test_summary_of_a_fleet_per_campaign(tmp_path):
    _write_results(tmp_path / "results" / "north")
    out = run_summary(tmp_path / "results")
    assert out[0] == "campaign north:"
    assert out[1] == f"  report: {tmp_path / 'results' / 'north' / 'report' / 'report.html'}"
    assert any(ln.startswith("    58 m: corrected 0.130") for ln in out)
