"""The result-table writer: the bytes of pandas' ``to_csv`` with the same settings; the
rule log's resource line."""

from __future__ import annotations

import subprocess
import sys
import time

import numpy as np
import pandas as pd
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from flidar_uq.data.csv_text import csv_text
from flidar_uq.data.io import _write
from flidar_uq.workflow.files import job_resources, write_csv

_DATES = "%Y-%m-%dT%H:%M:%SZ"


def _pandas_bytes(df, path, float_format):
    df.to_csv(
        path,
        index=False,
        float_format=float_format,
        lineterminator="\n",
        date_format=_DATES,
    )
    return path.read_bytes()


def _tricky_frame():
    return pd.DataFrame(
        {
            "text": ["x,y", 'q"z', "two\nlines", "cr\rx", "", None, "plain", " padded "],
            "hws_mean_ms": [1.0, np.nan, np.inf, -0.0, 1e-20, 1 / 3, -np.inf, 12345678901.5],
            "flag": [True, False] * 4,
            "count": np.arange(8) - 3,
            "ti": np.float32([0.1, 0.2, np.nan, 1e-7, 3, 4, 5, 6]),
            "a,b": [0.5] * 8,
            "timestamp": pd.date_range("2015-04-01", periods=8, freq="10min", tz="UTC"),
            "naive": pd.to_datetime(["2020-01-01T00:10:00", None] * 4),
            "bin_label": pd.Categorical(["H05_A01", "a,b", None, "H05_A01"] * 2),
        }
    )


@pytest.mark.parametrize("float_format", ["%.10g", "%.17g", "%.3f"])
def test_write_csv_writes_the_bytes_pandas_writes(tmp_path, float_format):
    df = _tricky_frame()
    assert csv_text(df, float_format=float_format, date_format=_DATES) is not None  # fast path
    write_csv(df, tmp_path / "ours.csv", float_format=float_format)
    expected = _pandas_bytes(df, tmp_path / "pandas.csv", float_format)
    assert (tmp_path / "ours.csv").read_bytes() == expected
    assert b'"x,y"' in expected and b'"a,b"' in expected  # quoting was exercised


@pytest.mark.parametrize(
    "df",
    [
        pd.DataFrame({"n": pd.array([1, None], dtype="Int64"), "x": [1.5, 2.0]}),
        pd.DataFrame({"x": [1.5, np.nan]}),
        pd.DataFrame({"mixed": [1, "a"], "x": [1.5, 2.0]}),
        pd.DataFrame({"x": [], "y": []}),
    ],
    ids=["nullable-int", "one-column", "mixed-object", "empty"],
)
def test_write_csv_leaves_other_tables_to_pandas_with_the_same_bytes(tmp_path, df):
    write_csv(df, tmp_path / "ours.csv")
    assert (tmp_path / "ours.csv").read_bytes() == _pandas_bytes(df, tmp_path / "p.csv", "%.10g")


@settings(max_examples=60, deadline=None)
@given(
    st.lists(
        st.tuples(
            st.floats(allow_nan=True, allow_infinity=True),
            st.text(alphabet=st.sampled_from(list('ab ,"\n\r-0.')), max_size=6),
            st.integers(-(2**62), 2**62),
        ),
        min_size=1,
        max_size=30,
    )
)
def test_write_csv_matches_pandas_on_any_floats_and_text(tmp_path_factory, rows):
    tmp = tmp_path_factory.mktemp("csv")
    x, s, n = zip(*rows, strict=True)
    df = pd.DataFrame({"x": np.array(x, dtype=float), "s": list(s), "n": np.array(n)})
    write_csv(df, tmp / "ours.csv", float_format="%.17g")
    assert (tmp / "ours.csv").read_bytes() == _pandas_bytes(df, tmp / "p.csv", "%.17g")


def test_record_writer_writes_the_bytes_of_pandas_shortest_float_text(tmp_path):
    """``data.io`` writes record tables without a float format (every float64 as its
    shortest text): the fast path gives pandas' bytes; float32 (numpy's shortest float32
    text is not repr's) and compressed files are left to pandas, with the same bytes."""
    df = _tricky_frame()
    date_format = "%Y-%m-%dT%H:%M:%S.%fZ"
    fast = df.drop(columns="ti")
    assert csv_text(fast, float_format=None, date_format=date_format) is not None
    assert csv_text(df, float_format=None, date_format=date_format) is None  # float32
    for frame in (fast, df):
        _write(frame, tmp_path / "ours.csv", date_format)
        frame.to_csv(tmp_path / "p.csv", index=False, date_format=date_format)
        assert (tmp_path / "ours.csv").read_bytes() == (tmp_path / "p.csv").read_bytes()


@settings(max_examples=60, deadline=None)
@given(st.lists(st.floats(allow_nan=True, allow_infinity=True), min_size=1, max_size=40))
def test_shortest_float_text_matches_numpy_for_any_float64(tmp_path_factory, xs):
    tmp = tmp_path_factory.mktemp("csv")
    df = pd.DataFrame({"x": np.array(xs, dtype=float), "y": np.array(xs[::-1], dtype=float)})
    _write(df, tmp / "ours.csv")
    df.to_csv(tmp / "p.csv", index=False)
    assert (tmp / "ours.csv").read_bytes() == (tmp / "p.csv").read_bytes()


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


@settings(max_examples=60, deadline=None)
@given(
    st.lists(
        st.tuples(
            st.sampled_from([0.0, -0.0, np.nan, np.inf, 1 / 3, 2.5, -1e-300]),
            st.integers(min_value=1, max_value=4),
        ),
        min_size=1,
        max_size=12,
    ),
    st.sampled_from([None, "%.10g"]),
)
def test_runs_of_repeated_floats_are_written_as_pandas_writes_them(tmp_path_factory, runs, fmt):
    """A column repeating each value over a few rows (a record over its heights) is
    formatted once a run: the same bytes as pandas, -0.0 next to 0.0 and NaN runs
    included."""
    tmp = tmp_path_factory.mktemp("csv")
    x = np.concatenate([np.full(k, v) for v, k in runs])
    df = pd.DataFrame({"x": x, "y": x[::-1].astype(np.float32)})
    text = csv_text(df, float_format=fmt or "%.17g", date_format=_DATES)
    assert text is not None
    (tmp / "ours.csv").write_text(text)
    assert (tmp / "ours.csv").read_bytes() == _pandas_bytes(df, tmp / "p.csv", fmt or "%.17g")
    plain = df[["x"]].assign(z=x)
    _write(plain, tmp / "plain.csv", _DATES)
    plain.to_csv(tmp / "pp.csv", index=False, date_format=_DATES)
    assert (tmp / "plain.csv").read_bytes() == (tmp / "pp.csv").read_bytes()


def test_long_double_floats_are_written_as_pandas_writes_them(tmp_path):
    """A float type without an integer of its width (long double) skips the run
    comparison: its values formatted one by one, pandas' bytes."""
    x = np.array([1.5, 1.5, np.nan, 1 / 3, 1 / 3], dtype=np.longdouble)
    df = pd.DataFrame({"x": x, "n": np.arange(5)})
    text = csv_text(df, float_format="%.10g", date_format=_DATES)
    assert text is not None
    (tmp_path / "ours.csv").write_text(text)
    assert (tmp_path / "ours.csv").read_bytes() == _pandas_bytes(df, tmp_path / "p.csv", "%.10g")
