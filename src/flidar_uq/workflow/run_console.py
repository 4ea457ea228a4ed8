"""``flidar-uq run``: the pipeline under Snakemake, told in plain words.

:func:`run_pipeline` runs Snakemake as a subprocess of the running interpreter. With
``verbose`` its output passes through unchanged; otherwise :class:`RunConsole` reads its log
stream line by line and prints one short line per step (what the step does, how many steps
are done, the job count of steps that run many jobs), and :func:`run_summary` ends with the
report's path, the representative TI at 15 m/s per height corrected and uncorrected with
their IEC 61400-1 categories, the validation headline and the warnings. On a failure it
prints the failing step, its log file and the last lines of that log.
"""

from __future__ import annotations

import functools
import json
import queue
import re
import subprocess
import sys
import threading
from collections import deque
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pandas as pd

__all__ = [
    "MAX_LINE_CHARS",
    "STEP_WORDS",
    "RunConsole",
    "run_pipeline",
    "run_summary",
    "clip_line",
    "failure_lines",
    "snakemake_command",
]

#: The longest line the console prints (characters); longer ones are cut with "...".
MAX_LINE_CHARS = 300

#: What each step (Snakemake rule) does, in plain words.
STEP_WORDS = {
    "campaign": "campaign: generate or read the campaign's records",
    "imu_statistics": "motion: per-record statistics of the raw IMU series",
    "validate": "validation: check the record table (columns, units, time span, heights)",
    "qc": "QC: flag records that fail the quality checks",
    "motion_statistics": "motion statistics: roll and pitch amplitude and period per record",
    "bins": "binning: group the records by wind speed and motion (decides the later jobs)",
    "sigma_z": "sigma_Z: motion-induced wind-speed error per bin (Gutiérrez-Antuñano et al. 2018)",
    "infer_batch": "fit: Bayesian fit of a batch of bins (emcee)",
    "posterior_bin": "fit: one bin's posterior",
    "fit_global_model": "fit: the Bayesian record fit of the whole campaign (emcee)",
    "fit_global": "fit: the global model from the fits",
    "propagate": "propagation: corrected TI with credible intervals per record",
    "ti_bins": "TI per bin: corrected and uncorrected TI per height and wind-speed bin",
    "uncorrected": "uncorrected TI per height and wind-speed bin (no motion statistics)",
    "los_correction": "LOS correction: line-of-sight motion correction of the raw series",
    "los_agreement": "LOS agreement: LOS-level against Bayesian corrected TI",
    "report": "report: write the HTML report",
    "developer_report": "developer report: benchmarks, correction methods compared",
    "fleet_summary": "fleet: summary of the campaigns",
    "all": "done: every result is in place",
}

_START = re.compile(r"^\s*(?:local)?(?:rule|checkpoint) (\w+):\s*$")
_LOG = re.compile(r"^\s+log: (.+?)(?: \(check log file\(s\) for error details\))?\s*$")
_WILDCARDS = re.compile(r"^\s+wildcards: (.+)$")
_PROGRESS = re.compile(r"^(\d+) of (\d+) steps \(\S+\) done")
_ERROR = re.compile(r"^Error in rule (\w+):")
#: Progress lines of a step's log: :class:`flidar_uq.progress.ProgressLog`'s ("campaign
#: default: 4320 of 8640 records (50 %) in 40.1 s, about 40 s left") and the sampler's
#: phases ("record fit: burn-in done, 400 steps per walker, 61.2 s").
_LOG_PROGRESS = re.compile(
    r"^INFO \S+: (.+?(?: \d+ of \d+ \w+ \(\d+ %\) in .+| \d+ steps per walker, .+ s))$"
)
#: Seconds between two looks at the running steps' logs.
_LOG_POLL_S = 2.0
_STATS = re.compile(r"^(\w+)\s+(\d+)$")


def clip_line(text: str, limit: int = MAX_LINE_CHARS) -> str:
    """``text`` on one line of at most ``limit`` characters (cut with "...")."""
    text = text.rstrip("\n")
    return text if len(text) <= limit else text[: limit - 3] + "..."


def _step_name(rule: str) -> str:
    """The rule without a fleet campaign's prefix (``north_qc`` -> ``qc``)."""
    if rule in STEP_WORDS:
        return rule
    return next((r for r in STEP_WORDS if rule.endswith("_" + r)), rule)


@dataclass
class RunConsole:
    """Snakemake's log stream in, short plain-words lines out (:meth:`feed`).

    Attributes
    ----------
    emit : callable
        Receives each output line (at most :data:`MAX_LINE_CHARS` characters).
    """

    emit: Callable[[str], None]
    done: int = 0
    total: int = 0
    failed_rule: str | None = None
    failed_logs: list = field(default_factory=list)
    #: log file -> characters already read, of every step started (:meth:`follow_logs`)
    step_logs: dict = field(default_factory=dict)
    tail: deque = field(default_factory=lambda: deque(maxlen=15))
    _planned: dict = field(default_factory=dict)
    _started: dict = field(default_factory=dict)
    _pending: str | None = None
    _in_stats: bool = False
    _in_error: bool = False

    def feed(self, line: str) -> None:
        """Read one line of Snakemake's output."""
        line = line.rstrip("\n")
        if line.strip():
            self.tail.append(line)
        if self._in_error:
            m = _LOG.match(line)
            if m:
                self.failed_logs += [p.strip() for p in m.group(1).split(",")]
            elif not line.startswith(" "):
                self._in_error = False
        elif (m := _LOG.match(line)) and not line.strip().startswith("log: .snakemake"):
            for path in m.group(1).split(","):
                self.step_logs.setdefault(path.strip(), 0)
        if line.startswith("Job stats:"):
            self._in_stats = True
            return
        if self._in_stats:
            m = _STATS.match(line.strip())
            if m and m.group(1) != "total":
                self._planned[m.group(1)] = int(m.group(2))
            elif m:  # the table's last row
                self.total = self.total or int(m.group(2))
                self._in_stats = False
            return
        if m := _START.match(line):
            self._flush()
            self._pending = m.group(1)
        elif self._pending and (m := _WILDCARDS.match(line)):
            self._flush(m.group(1))
        elif self._pending and not line.startswith(" "):
            self._flush()
        if m := _PROGRESS.match(line):
            done, total = int(m.group(1)), int(m.group(2))
            if self.total and total > self.total:
                self.emit(
                    f"(the binning checkpoint fixed the bins: {total} steps in all now, "
                    f"{done} done)"
                )
            self.done, self.total = done, total
        elif m := _ERROR.match(line):
            self._flush()
            self.failed_rule = self.failed_rule or m.group(1)
            self._in_error = True

    def _flush(self, wildcards: str = "") -> None:
        """Announce the step whose start was read (with its wildcards when it has some)."""
        rule, self._pending = self._pending, None
        if rule is None:
            return
        k = self._started[rule] = self._started.get(rule, 0) + 1
        n = self._planned.get(rule)
        if n is not None and k > n:
            n = None  # the checkpoint added jobs of this rule: the plan no longer holds
        words = STEP_WORDS.get(_step_name(rule), f"{rule}: a step of the pipeline")
        if rule != _step_name(rule):
            words = f"[{rule.removesuffix('_' + _step_name(rule))}] {words}"
        if (n or 0) > 1 or k > 1 or (n is None and wildcards):
            every = max(1, (n or 100) // 10)
            if k != 1 and k != n and k % every:
                return
            words += f" (job {k}" + (f" of {n})" if n else ")")
        count = f"{self.done} of {self.total} steps done" if self.total else "starting"
        self.emit(clip_line(f"[{count}] {words}"))

    def finish(self) -> None:
        """Announce a step whose start was the last line read."""
        self._flush()

    def follow_logs(self, workdir: Path) -> None:
        """Emit the progress lines written since the last look to the logs of the steps
        started so far (paths relative to ``workdir``): how far a long step (the campaign,
        the record fit, the uncertainty budget) is, while it runs."""
        for path, seen in self.step_logs.items():
            try:
                with open(workdir / path, "rb") as f:
                    f.seek(seen)
                    data = f.read()
            except OSError:
                continue
            complete = data[: data.rfind(b"\n") + 1]  # a line still being written waits
            self.step_logs[path] = seen + len(complete)
            for line in complete.decode(errors="replace").splitlines():
                if m := _LOG_PROGRESS.match(line):
                    self.emit(clip_line(f"    {m.group(1)}"))


def _log_tail(path: Path, n_lines: int = 15) -> list[str]:
    try:
        text = path.read_text(errors="replace").splitlines()
    except OSError:
        return []
    return [ln for ln in text if ln.strip()][-n_lines:]


def failure_lines(console: RunConsole, workdir: Path, returncode: int) -> list[str]:
    """What the user needs after a failed run: the step, its log file and its last lines.

    Parameters
    ----------
    console : RunConsole
        The console that read the run's output.
    workdir : Path
        The run's working directory (log paths are relative to it).
    returncode : int
        Snakemake's exit status.
    """
    rule = console.failed_rule
    if rule is None:
        out = [f"flidar-uq run: the pipeline stopped (exit status {returncode}); its last lines:"]
        return out + [clip_line("  " + ln) for ln in console.tail]
    words = STEP_WORDS.get(_step_name(rule), rule).split(":", 1)[-1].strip()
    out = [f"flidar-uq run: step {rule} failed ({words})"]
    for log in console.failed_logs:
        path = workdir / log
        out.append(clip_line(f"log file: {path}"))
        tail = _log_tail(path)
        if tail:
            out.append("last lines of the log:")
            out += [clip_line("  " + ln) for ln in tail]
    if not console.failed_logs:
        out.append("Snakemake's last lines:")
        out += [clip_line("  " + ln) for ln in console.tail]
    return out


# ---- the summary -----------------------------------------------------------------------------


def _rep15_lines(speed_bins: pd.DataFrame, min_count: int) -> list[str]:
    """Per height: representative TI at 15 m/s, corrected against uncorrected, with IEC
    categories."""
    from flidar_uq.validation.reference import iec_category
    from flidar_uq.workflow.report_summary import (
        IEC_REFERENCE_SPEED_MS,
        representative_at_15,
        uncorrected_at_15,
    )

    # results/ti/ of the uncorrected rule: no corrected statistic, some uncorrected ones
    if speed_bins["ti_rep"].isna().all() and speed_bins["ti_rep_uncorrected"].notna().any():
        rep = uncorrected_at_15(speed_bins, min_count=min_count)
        out = [
            f"representative TI at {IEC_REFERENCE_SPEED_MS:g} m/s (IEC 61400-1 category), "
            "uncorrected (no motion statistics):"
        ]
        for r in rep.itertuples():
            out.append(
                f"  {r.height_m:g} m: uncorrected {r.ti_rep:.3f}, category {r.category}"
                if np.isfinite(r.ti_rep)
                else f"  {r.height_m:g} m: none, {r.note}"
            )
        return out
    rep = representative_at_15(speed_bins, min_count=min_count)
    out = [f"representative TI at {IEC_REFERENCE_SPEED_MS:g} m/s (IEC 61400-1 category):"]
    for r in rep.itertuples():
        if not np.isfinite(r.ti_rep):
            out.append(f"  {r.height_m:g} m: none, {r.note}")
            continue
        b = speed_bins[
            np.isclose(speed_bins["height_m"], r.height_m)
            & np.isclose(speed_bins["hws_bin_ms"], IEC_REFERENCE_SPEED_MS)
        ]
        raw = float(b["ti_rep_uncorrected"].iloc[0])
        out.append(
            f"  {r.height_m:g} m: corrected {r.ti_rep:.3f} ({r.ti_rep_lo:.3f}-{r.ti_rep_hi:.3f}), "
            f"category {r.category}; uncorrected {raw:.3f}, category {iec_category(raw) or '-'}"
        )
    return out


def _validation_lines(metrics: pd.DataFrame) -> list[str]:
    """The validation headline: the Bayesian corrected against the uncorrected TI."""
    out = []
    for ref, m in metrics.groupby("reference", sort=False):
        by = m.set_index("method")
        if not {"uncorrected", "Bayesian"} <= set(by.index):
            continue
        u, b = by.loc["uncorrected"], by.loc["Bayesian"]
        cov = (
            f"; {b['coverage']:.0%} of the {b['credible_mass']:.0%} credible intervals hold it"
            if np.isfinite(b["coverage"])
            else ""
        )
        out.append(
            f"  per-record TI against the {ref} ({int(b['n'])} records): uncorrected bias "
            f"{u['md_ti']:+.4f}, RMSE {u['rmse_ti']:.4f}; corrected bias {b['md_ti']:+.4f}, "
            f"RMSE {b['rmse_ti']:.4f}{cov}"
        )
    if not out:
        return []
    return ["validation (corrected and uncorrected TI against the reference):", *out[:3]]


def _warning_lines(results: Path) -> list[str]:
    """The data's and the fits' warnings, from the files that state them in words."""
    words = []
    validation = results / "data" / "validation.json"
    if validation.is_file():
        v = json.loads(validation.read_text())
        words += list(v.get("blocking", [])) + list(v.get("warnings", []))
    fits = results / "inference" / "bin_fits.csv"
    if fits.is_file():
        f = pd.read_csv(fits)
        bad = f[~f["status"].isin(["ok"])]
        if len(bad):
            why = "; ".join(dict.fromkeys(bad["message"].dropna().astype(str)))[:120]
            words.append(f"{len(bad)} bins could not be fitted" + (f" ({why})" if why else ""))
    fit = results / "inference" / "global.csv"
    if fit.is_file():
        g = pd.read_csv(fit)
        if "converged" in g and not g["converged"].astype(bool).all():
            why = "; ".join(dict.fromkeys(g["failure_reasons"].dropna().astype(str)))
            words.append(f"the global fit did not converge ({why})")
    if not words:
        return ["warnings: none"]
    return ["warnings:"] + [f"  - {w}" for w in words]


def run_summary(results: str | Path, min_count: int = 10) -> list[str]:
    """The closing summary of a run, read from its result files.

    Parameters
    ----------
    results : str or Path
        The run's results directory (``results/``).
    min_count : int
        Fewest records for the 15-m/s bin's representative TI (the report's
        ``report.group_min_count``).

    Returns
    -------
    list of str
        Lines of at most :data:`MAX_LINE_CHARS` characters: the report's path, per height
        the representative TI at 15 m/s corrected and uncorrected with their IEC 61400-1
        categories (``results/ti/speed_bins.csv``), the validation headline
        (``results/ti/metrics.csv``, when present) and the warnings; for a fleet (no
        ``results/report/``) the same per campaign, from ``results/<name>/``.
    """
    results = Path(results)
    report = results / "report" / "report.html"
    fleet = sorted(results.glob("*/report/report.html"))
    if not report.is_file() and fleet:  # a fleet: one results/<name>/ per campaign
        out = []
        for r in fleet:
            campaign = r.parent.parent  # results/<name>/report/report.html
            out += [f"campaign {campaign.name}:"]
            out += ["  " + ln for ln in run_summary(campaign, min_count)]
        return [clip_line(ln) for ln in out]
    out = [f"report: {report}" if report.is_file() else f"report: none written ({report})"]
    bins = results / "ti" / "speed_bins.csv"
    if bins.is_file():
        out += _rep15_lines(pd.read_csv(bins), min_count)
    metrics = results / "ti" / "metrics.csv"
    if metrics.is_file():
        out += _validation_lines(pd.read_csv(metrics))
    out += _warning_lines(results)
    return [clip_line(ln) for ln in out]


# ---- the run ---------------------------------------------------------------------------------


def _read_lines(stream, lines: queue.Queue) -> None:
    """Put every line of ``stream`` on ``lines``, then None."""
    for line in stream:
        lines.put(line)
    lines.put(None)


def snakemake_command(snakemake_args: Sequence[str]) -> list[str]:
    """Snakemake of the running interpreter with ``snakemake_args``."""
    return [sys.executable, "-m", "snakemake", *snakemake_args]


def run_pipeline(
    snakemake_args: Sequence[str],
    workdir: str | Path = ".",
    verbose: bool = False,
    emit: Callable[[str], None] | None = None,
    min_count: int = 10,
) -> int:
    """Run the pipeline and tell the user what happens; returns Snakemake's exit status.

    Parameters
    ----------
    snakemake_args : sequence of str
        Snakemake's arguments (``--cores``, ``--configfile``, ...).
    workdir : str or Path
        The run's working directory (where ``results/`` is written; Snakemake's
        ``--directory`` when one is among ``snakemake_args``). Snakemake itself starts in
        the current directory, so relative paths of its arguments hold.
    verbose : bool
        Pass Snakemake's own output through unchanged instead of the step lines.
    emit : callable, optional
        Receives each output line (default: printed on stdout at once, so that a pipe shows
        each step when it starts).
    min_count : int
        Fewest records for the summary's 15-m/s representative TI.
    """
    emit = emit or functools.partial(print, flush=True)
    workdir = Path(workdir)
    cmd = snakemake_command(snakemake_args)
    console = None
    if verbose:
        code = subprocess.run(cmd).returncode
    else:
        proc = subprocess.Popen(
            cmd,
            stdout=subprocess.PIPE,
            stderr=subprocess.STDOUT,
            text=True,
            errors="replace",
        )
        console = RunConsole(emit)
        lines: queue.Queue = queue.Queue()
        reader = threading.Thread(target=_read_lines, args=(proc.stdout, lines), daemon=True)
        reader.start()
        while True:
            try:
                line = lines.get(timeout=_LOG_POLL_S)
            except queue.Empty:
                console.follow_logs(workdir)
                continue
            if line is None:
                break
            console.feed(line)
        console.finish()
        console.follow_logs(workdir)
        code = proc.wait()
    if code != 0:
        for ln in failure_lines(console, workdir, code) if console else []:
            emit(ln)
        return code
    if "--dry-run" in snakemake_args or "-n" in snakemake_args:
        return code
    for ln in run_summary(workdir / "results", min_count=min_count):
        emit(ln)
    return code
