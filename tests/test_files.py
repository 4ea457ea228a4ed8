"""The result-table writer (deterministic float text, round trips); the rule log's
resource line."""

from __future__ import annotations

import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from flidar_uq.data.io import _write
from flidar_uq.workflow.files import job_resources, write_csv


def test_write_csv_keeps_every_float_bit_and_gives_the_same_bytes(tmp_path):
    """Every float64 reads back bit for bit (tables feed later steps), at every magnitude;
    missing values, booleans, integers, UTC stamps and text with a comma survive; the same
    frame written twice gives the same bytes."""
    rng = np.random.default_rng(4)
    n = 2000
    df = pd.DataFrame(
        {
            "x": rng.standard_normal(n) * 10.0 ** rng.integers(-300, 300, n),
            "u": rng.random(n),
            "n": np.arange(n),
            "ok": rng.random(n) < 0.5,
            "timestamp": pd.date_range("2015-04-01", periods=n, freq="10min", tz="UTC"),
            "why": np.where(rng.random(n) < 0.5, "gust, then calm", "calm"),
        }
    )
    df.loc[3, "x"] = np.nan
    df.loc[5, "why"] = None
    write_csv(df, tmp_path / "a.csv")
    write_csv(df, tmp_path / "b.csv")
    assert (tmp_path / "a.csv").read_bytes() == (tmp_path / "b.csv").read_bytes()
    text = (tmp_path / "a.csv").read_text()
    assert text.splitlines()[0] == "x,u,n,ok,timestamp,why"
    assert "2015-04-01T00:10:00Z" in text and '"gust, then calm"' in text
    back = pd.read_csv(tmp_path / "a.csv")
    np.testing.assert_array_equal(back["x"].to_numpy(), df["x"].to_numpy())
    np.testing.assert_array_equal(back["u"].to_numpy(), df["u"].to_numpy())
    assert back["n"].tolist() == df["n"].tolist()
    assert back["ok"].tolist() == df["ok"].tolist()
    assert pd.isna(back.loc[5, "why"]) and back.loc[0, "why"] == df.loc[0, "why"]
    stamps = pd.to_datetime(back["timestamp"], utc=True)
    assert (stamps == df["timestamp"]).all()


def test_write_csv_of_a_column_arrow_cannot_hold_goes_through_pandas(tmp_path):
    """A column of mixed Python objects still writes (the pandas path), values unchanged."""
    df = pd.DataFrame({"mixed": [1, "a", 2.5], "x": [0.1, 0.2, 1 / 3]})
    write_csv(df, tmp_path / "m.csv")
    back = pd.read_csv(tmp_path / "m.csv")
    assert back["mixed"].astype(str).tolist() == ["1", "a", "2.5"]
    np.testing.assert_array_equal(back["x"].to_numpy(), df["x"].to_numpy())


def test_record_writer_keeps_every_float_bit_and_utc_stamps(tmp_path):
    df = pd.DataFrame(
        {
            "timestamp": pd.date_range("2015-04-01", periods=3, freq="10min", tz="UTC"),
            "x": [1 / 3, 2.5, -1e-300],
        }
    )
    text = _write(df, tmp_path / "r.csv").read_text()
    assert "2015-04-01T00:10:00" in text
    back = pd.read_csv(tmp_path / "r.csv")
    np.testing.assert_array_equal(back["x"].to_numpy(), df["x"].to_numpy())


def test_a_rule_log_ends_with_the_jobs_cpu_time_and_peak_memory(tmp_path):
    """The exit line of setup_logging counts the CPU of the process and of its finished
    children (the campaign's workers) and the process's peak memory, once."""
    log = tmp_path / "rule.log"
    code = (
        "import subprocess, sys, numpy as np\n"
        "from flidar_uq.workflow.files import setup_logging\n"
        f"setup_logging({str(log)!r}); setup_logging({str(log)!r})\n"
        "import arviz\n"
        "a = np.ones(40_000_000)  # 305 MiB resident\n"
        "subprocess.run([sys.executable, '-c', 'import time; t = time.process_time()\\n"
        "while time.process_time() - t < 1.5: pass'], check=True)\n"
    )
    before = time.time()
    subprocess.run([sys.executable, "-c", code], check=True)
    assert log.read_text().count("job resources:") == 1
    cpu_s, rss_mb, end_unix = job_resources(log)
    assert before < end_unix <= time.time()
    assert cpu_s >= 1.5  # the child's 1.5 s of CPU at least (the parent alone: < 1 s)
    assert 305 <= rss_mb < 2000
    assert job_resources(tmp_path / "missing.log") is None
    # arviz's import-time backend notes (INFO) stay out of the rule logs
    assert "arviz" not in log.read_text()


@pytest.mark.skipif(not Path("/proc/self/status").exists(), reason="Linux /proc only")
def test_a_rule_logs_its_own_peak_memory_not_its_large_parents(tmp_path):
    """A job started by a parent with a large resident set (Snakemake, or a test worker
    that ran big fits) logs its own peak: getrusage's ru_maxrss would report the parent's,
    inherited through vfork and exec."""
    log = tmp_path / "rule.log"
    job = (
        "import numpy as np\n"
        "from flidar_uq.workflow.files import setup_logging\n"
        f"setup_logging({str(log)!r})\n"
        "a = np.ones(10_000_000)  # 76 MiB\n"
    )
    parent = (
        "import subprocess, sys, numpy as np\n"
        "big = np.ones(200_000_000)  # 1.5 GiB resident in the parent\n"
        f"subprocess.run([sys.executable, '-c', {job!r}], check=True)\n"
    )
    subprocess.run([sys.executable, "-c", parent], check=True)
    _, rss_mb, _ = job_resources(log)
    assert 76 <= rss_mb < 800, rss_mb
