"""The result-table writer (deterministic float text, round trips); the rule log's
resource line."""

from __future__ import annotations

import subprocess
import sys
import time

import numpy as np
import pandas as pd
import pytest

from flidar_uq.data.io import _write
from flidar_uq.workflow.files import job_resources, write_csv


@pytest.mark.parametrize(("float_format", "rtol"), [("%.17g", 0.0), ("%.10g", 1e-9)])
def test_write_csv_float_text_round_trips(tmp_path, float_format, rtol):
    """``%.17g`` keeps every bit of a float64 (tables that feed later steps); the same
    frame written twice gives the same bytes."""
    rng = np.random.default_rng(4)
    df = pd.DataFrame({"x": rng.standard_normal(200) * 1e3, "n": np.arange(200)})
    df.loc[3, "x"] = np.nan
    write_csv(df, tmp_path / "a.csv", float_format=float_format)
    write_csv(df, tmp_path / "b.csv", float_format=float_format)
    assert (tmp_path / "a.csv").read_bytes() == (tmp_path / "b.csv").read_bytes()
    back = pd.read_csv(tmp_path / "a.csv")
    np.testing.assert_allclose(back["x"], df["x"], rtol=rtol, atol=0)
    assert back["n"].tolist() == df["n"].tolist()


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
