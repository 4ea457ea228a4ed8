"""Shared file helpers of the workflow steps: deterministic CSV read/write, rule logging,
and the lookup of a bin's posterior file among the batch directories."""

from __future__ import annotations

import logging
import os
from collections.abc import Sequence
from pathlib import Path

import pandas as pd

from flidar_uq.data.csv_text import csv_text

__all__ = ["bin_file", "read_csv", "setup_logging", "write_csv"]


def setup_logging(log_path: str | os.PathLike) -> None:
    """Send INFO and above of every logger (and warnings) to ``log_path``, a rule's log file."""
    logging.basicConfig(
        filename=str(log_path),
        filemode="w",
        level=logging.INFO,
        format="%(levelname)s %(name)s: %(message)s",
        force=True,
    )
    logging.captureWarnings(True)


#: how every result table writes a time stamp (UTC)
_DATE_FORMAT = "%Y-%m-%dT%H:%M:%SZ"


def write_csv(df: pd.DataFrame, path: str | os.PathLike, *, float_format: str = "%.10g") -> None:
    """Write a result table deterministically (fixed float format, no index; ``"%.17g"``
    keeps every bit of a float64, for tables that feed later steps exactly); the bytes of
    ``DataFrame.to_csv`` with these settings, about 3x faster for numeric tables."""
    Path(path).parent.mkdir(parents=True, exist_ok=True)
    text = csv_text(df, float_format=float_format, date_format=_DATE_FORMAT)
    if text is None:
        df.to_csv(
            path,
            index=False,
            float_format=float_format,
            lineterminator="\n",
            date_format=_DATE_FORMAT,
        )
        return
    with open(path, "w", encoding="utf-8", newline="") as f:
        f.write(text)


def read_csv(path: str | os.PathLike) -> pd.DataFrame:
    """Read a result table written by :func:`write_csv`."""
    return pd.read_csv(path, keep_default_na=True)


def bin_file(batch_dirs: Sequence[str | os.PathLike], bin_id: int) -> Path:
    """The posterior file ``bin_<id>.nc`` of one bin, found among the batch directories."""
    for d in batch_dirs:
        p = Path(d) / f"bin_{bin_id:04d}.nc"
        if p.exists():
            return p
    raise ValueError(f"no posterior file for bin {bin_id} in {list(map(str, batch_dirs))}")
