"""schema.py is the single source of truth; docs/data-format.md must agree with it."""

from __future__ import annotations

from pathlib import Path

import pytest

from flidar_uq.data.schema import (
    IMU_COLUMNS,
    LOS_COLUMNS,
    MOTION_COLUMNS,
    RECORD_COLUMNS,
    Column,
    record_column,
)

DOC = Path(__file__).resolve().parents[1] / "docs" / "data-format.md"


def doc_row(text: str, section: str, name: str) -> list[str]:
    """Cells of the table row for column ``name`` in the doc section starting with ``section``."""
    part = text.split(section, 1)[1].split("\n## ", 1)[0]
    rows = [line for line in part.splitlines() if line.startswith(f"| `{name}` |")]
    assert len(rows) == 1, f"{name}: {len(rows)} rows in section {section!r}"
    return [c.strip() for c in rows[0].strip("|").split("|")]


@pytest.mark.parametrize(
    ("section", "columns"),
    [
        ("## 1. Record table", RECORD_COLUMNS),
        ("## 2. Raw IMU series", IMU_COLUMNS),
        ("## 3. LOS-level data", LOS_COLUMNS),
    ],
)
def test_every_schema_column_documented_with_unit_bounds_and_nan_policy(section, columns):
    text = DOC.read_text()
    for col in columns:
        name, dtype, unit, required, bounds, nan, meaning = doc_row(text, section, col.name)
        assert dtype == col.dtype, col.name
        assert unit == col.unit, col.name
        expected_req = "yes*" if col.name in MOTION_COLUMNS else ("yes" if col.required else "no")
        assert required == expected_req, col.name
        assert bounds == col.bounds_text(), col.name
        assert nan == ("allowed" if col.nan_allowed else "not allowed"), col.name
        assert meaning == col.description, col.name


def test_doc_has_no_column_missing_from_schema():
    text = DOC.read_text()
    for section, columns in (
        ("## 1. Record table", RECORD_COLUMNS),
        ("## 2. Raw IMU series", IMU_COLUMNS),
        ("## 3. LOS-level data", LOS_COLUMNS),
    ):
        part = text.split(section, 1)[1].split("\n## ", 1)[0]
        names = {line.split("`")[1] for line in part.splitlines() if line.startswith("| `")}
        assert names == {c.name for c in columns}, section


def test_truth_columns_documented():
    text = DOC.read_text()
    for name in (
        "true_hws_mean_ms",
        "true_hws_std_ms",
        "true_ti",
        "true_amplitude_deg",
        "true_period_s",
        "true_sigma_z_ms",
    ):
        assert f"`{name}`" in text
    assert record_column("true_anything").nan_allowed


def test_unknown_column_lookup_raises():
    with pytest.raises(ValueError, match="unknown record column 'bin_id'"):
        record_column("bin_id")


def test_bounds_text():
    assert (
        Column("x", "float", "s", True, 0.0, 60.0, True, "", lower_exclusive=True).bounds_text()
        == "(0, 60]"
    )
    assert Column("x", "float", "-", True, None, None, True, "").bounds_text() == "-"
