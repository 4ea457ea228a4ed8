"""Shared file helpers of the workflow steps: deterministic CSV read/write, rule logging
(with the job's CPU time and peak memory at exit), and the lookup of a bin's posterior file
among the batch directories."""

from __future__ import annotations

import atexit
import logging
import os
import re
import sys
import time
from collections.abc import Sequence
from pathlib import Path
from typing import NamedTuple

from flidar_uq.data.io import read_csv, write_csv
from flidar_uq.threads import numeric_environment

__all__ = ["JobResources", "bin_file", "job_resources", "read_csv", "setup_logging", "write_csv"]

#: the line the exit hook of :func:`setup_logging` writes last in a rule's log
_RESOURCES = "job resources: cpu_s={cpu:.3f} max_rss_mb={rss:.1f} end_unix={end:.3f}"
_RESOURCES_RE = re.compile(
    r"job resources: cpu_s=([0-9.]+) max_rss_mb=([0-9.]+)(?: end_unix=([0-9.]+))?"
)


class JobResources(NamedTuple):
    """What a rule's job logged at its exit (:func:`setup_logging`)."""

    cpu_s: float  #: CPU time, user + system, its finished child processes included, s
    max_rss_mb: float  #: peak resident memory of the job's own process, MB
    end_unix: float | None  #: wall-clock time of the exit, s since the Unix epoch


def _peak_rss_mb() -> float:
    """Peak resident memory of this process's own address space, MB (2^20 bytes).

    On Linux ``VmHWM`` of ``/proc/self/status``: ``getrusage``'s ``ru_maxrss`` also keeps
    the high-water mark of the address space the process had before its ``exec``, which
    for a process started by ``vfork`` (Python's ``subprocess``, Snakemake's jobs) is its
    parent's, so a small job of a large parent would report the parent's peak. Elsewhere
    ``ru_maxrss`` (bytes on macOS, KiB on other systems)."""
    try:
        with open("/proc/self/status") as f:
            for line in f:
                if line.startswith("VmHWM:"):
                    return int(line.split()[1]) / 1024  # kB
    except (OSError, ValueError, IndexError):
        pass
    import resource

    rss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    return rss / 2**20 if sys.platform == "darwin" else rss / 1024


def _log_job_resources() -> None:
    """Log this process's CPU time (user + system, its finished child processes included,
    e.g. the campaign's workers), its own peak resident memory (:func:`_peak_rss_mb`) and
    the wall-clock time of its exit."""
    import resource

    own = resource.getrusage(resource.RUSAGE_SELF)
    children = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = own.ru_utime + own.ru_stime + children.ru_utime + children.ru_stime
    logging.getLogger("flidar_uq.workflow").info(
        _RESOURCES.format(cpu=cpu, rss=_peak_rss_mb(), end=time.time())
    )


def setup_logging(log_path: str | os.PathLike) -> None:
    """Send INFO and above of every logger (and warnings) to ``log_path``, a rule's log file,
    starting with the job's numeric environment
    (:func:`flidar_uq.threads.numeric_environment`), and, at the process's exit, a last line with its CPU time and peak memory
    (:func:`job_resources` reads it back; Snakemake's ``benchmark:`` samples a job only
    every 30 s after its first 30, so it misses up to 30 s of CPU and short memory peaks)."""
    logging.basicConfig(
        filename=str(log_path),
        filemode="w",
        level=logging.INFO,
        format="%(levelname)s %(name)s: %(message)s",
        force=True,
    )
    logging.captureWarnings(True)
    # arviz announces its backends at INFO on import: not the step's news
    logging.getLogger("arviz").setLevel(logging.WARNING)
    # what the last bits of this job's results depend on besides the code and the seeds
    env = numeric_environment()
    logging.getLogger("flidar_uq.workflow").info(
        "numeric environment: %s", "; ".join(f"{k}: {v}" for k, v in env.items())
    )
    if os.name == "posix":  # getrusage; registered once however often this is called
        atexit.unregister(_log_job_resources)
        atexit.register(_log_job_resources)


def job_resources(log_path: str | os.PathLike) -> JobResources | None:
    """CPU time, peak resident memory and exit time a rule's job logged at its exit
    (:func:`setup_logging`), or None when its log holds no such line."""
    try:
        text = Path(log_path).read_text(errors="replace")
    except FileNotFoundError:
        return None
    found = _RESOURCES_RE.findall(text)
    if not found:
        return None
    cpu, rss, end = found[-1]
    return JobResources(float(cpu), float(rss), float(end) if end else None)


def bin_file(batch_dirs: Sequence[str | os.PathLike], bin_id: int) -> Path:
    """The posterior file ``bin_<id>.nc`` of one bin, found among the batch directories."""
    for d in batch_dirs:
        p = Path(d) / f"bin_{bin_id:04d}.nc"
        if p.exists():
            return p
    raise ValueError(f"no posterior file for bin {bin_id} in {list(map(str, batch_dirs))}")
