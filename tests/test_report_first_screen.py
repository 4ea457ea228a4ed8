"""The report's first screen: the correction's size and IEC category before and after, the
validation's sample, no model-selection statistics; every campaign answered (no reference)."""

from __future__ import annotations

import html as html_lib
import re
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
import yaml
from test_report import _chromium

from flidar_uq.workflow import plots
from flidar_uq.workflow.report_step import build_developer_report
from flidar_uq.workflow.report_summary import (
    Validation,
    category_move_words,
    correction_size_words,
    coverage_words,
    hull_model_short,
    model_selection_words,
    representative_at_15,
)

REPO = Path(__file__).resolve().parents[1]
SNAKEMAKE = str(Path(sys.executable).with_name("snakemake"))


def _bins(height_m: float, ti_rep: float, ti_rep_uncorrected: float) -> pd.DataFrame:
    """speed_bins.csv rows of one height: the 15-m/s bin and a 14-m/s one."""
    return pd.DataFrame(
        {
            "height_m": height_m, "hws_bin_ms": [14.0, 15.0], "n": [30, 30],
            "ti_mean": [0.1, 0.1], "ti_rep": [ti_rep + 0.01, ti_rep],
            "ti_rep_lo": [ti_rep, ti_rep - 0.002], "ti_rep_hi": [ti_rep + 0.02, ti_rep + 0.002],
            "ti_rep_uncorrected": [ti_rep_uncorrected + 0.01, ti_rep_uncorrected],
        }
    )  # fmt: skip


def test_correction_size_words_give_the_change_and_the_categories_before_and_after():
    # IEC 61400-1 at 15 m/s: C up to 0.12 (0.75 + 5.6/15) = 0.1348, B up to 0.1573
    rep15 = representative_at_15(pd.concat([_bins(85.0, 0.135 - 0.0052, 0.142)]))
    (row,) = rep15.itertuples()
    words = correction_size_words(row)
    assert words.startswith("At 85 m the representative TI at 15 m/s falls from 0.142 to 0.130")
    assert "(-8.6 %;" in words and "IEC category B -> C." in words
    same = next(representative_at_15(_bins(58.0, 0.100, 0.110)).itertuples())
    assert "rises" not in correction_size_words(same)
    assert correction_size_words(same).endswith("IEC category C either way.")


def test_category_move_words_only_when_every_height_moves_alike():
    heights = [_bins(h, 0.130, 0.142) for h in (27.0, 58.0, 85.0)]
    rep15 = representative_at_15(pd.concat(heights))
    assert (
        category_move_words(rep15)
        == "The correction moves all three heights from IEC category B to C."
    )
    mixed = representative_at_15(pd.concat([*heights[:2], _bins(85.0, 0.140, 0.142)]))
    assert category_move_words(mixed) == ""
    few = representative_at_15(pd.concat(heights), min_count=31)  # no value at any height
    assert category_move_words(few) == ""


def _validation(sample: str) -> Validation:
    summary = pd.DataFrame(
        {"sample": ["in sample", "held out"], "estimate": ["corrected", "corrected"],
         "n": [400, 120], "coverage": [0.91, 0.875]}
    )  # fmt: skip
    return Validation({"summary": summary}, "", sample, False)


def test_coverage_in_words_when_held_out_and_left_out_in_sample():
    words = coverage_words(_validation("held out"), 0.9)
    assert "120 held-out records" in words and "87.5 %" in words and "90% expected" in words
    assert coverage_words(_validation("in sample"), 0.9) == ""


def test_model_selection_in_words_a_reader_can_use():
    info = {
        "hull_model": "translating",
        "hull_reference": "wave_follower",
        "hull_model_comparison": {"elpd_difference": 35.0, "elpd_difference_se": 6.0},
        "hull_reference_comparison": {
            "kept": "wave_follower",
            "candidates": [
                {"hull_reference": "wave_follower"},
                {"hull_reference": "discus_buoy", "against": "wave_follower",
                 "elpd_difference": 1.5, "elpd_difference_se": 2.0},
            ],
        },
    }  # fmt: skip
    first, second = model_selection_words(info)
    assert first.startswith(
        "The data favour the hull that follows the waves over rotation only, by a clear margin"
    )
    assert "discus buoy" in second and "within the noise" in second
    short = hull_model_short(info)
    assert "follows the waves" in short
    assert not re.search(r"elpd|PSIS|wave_follower|discus_buoy", short)
    info["hull_model_comparison"]["elpd_difference"] = -3.0
    assert model_selection_words(info)[0].startswith("The data do not favour")


def test_ti_speed_bins_figure_scales_its_axis_to_a_small_correction():
    """A correction of 0.005 takes a visible part of the y-axis (not squeezed under the IEC
    curves up to 0.3)."""
    v = np.arange(4.0, 21.0)
    ti = 0.06 + 0.2 / v
    b = pd.DataFrame({"hws_bin_ms": v, "ti_mean": ti, "ti_mean_lo": ti - 0.001,
                      "ti_mean_hi": ti + 0.001, "ti_rep": ti + 0.02, "ti_rep_lo": ti + 0.019,
                      "ti_rep_hi": ti + 0.021, "ti_mean_uncorrected": ti + 0.005,
                      "ti_rep_uncorrected": ti + 0.025})  # fmt: skip
    fig = plots.ti_speed_bins_figure(b, credible_mass=0.9)
    lo, hi = fig.axes[0].get_ylim()
    assert lo <= b["ti_mean_lo"].min() and hi >= b["ti_rep_uncorrected"].max()
    assert 0.005 / (hi - lo) > 0.04, (lo, hi)


def _summary_text(html_path: Path) -> str:
    """The text of the first screen (#summary) as headless Chromium renders the page."""
    proc = _chromium(["--virtual-time-budget=10000", "--dump-dom", html_path.as_uri()])
    m = re.search(r'<section id="summary".*?</section>', proc.stdout, re.S)
    assert m, f"no summary in the rendered page; chromium stderr: {proc.stderr[-2000:]}"
    return html_lib.unescape(re.sub(r"\s+", " ", re.sub(r"<[^>]+>", " ", m.group(0))))


def _run(workdir: Path, *, scale_hws: float, reference: bool) -> Path:
    """The hand-written test campaign (tests/data/user_config.yaml), wind speeds times
    ``scale_hws`` (TI unchanged), without the reference columns unless ``reference``;
    every 1-m/s bin with 2 records gets its statistics. Returns the results directory."""
    import subprocess

    src = pd.read_csv(REPO / "tests" / "data" / "hand_written_campaign.csv")
    for c in ("hws_mean_ms", "hws_std_ms", "ref_hws_mean_ms", "ref_hws_std_ms"):
        src[c] = src[c] * scale_hws
    if not reference:
        src = src.drop(columns=[c for c in src if c.startswith("ref_")])
    src.to_csv(workdir / "campaign.csv", index=False)
    cfg = yaml.safe_load((REPO / "tests" / "data" / "user_config.yaml").read_text())
    cfg["campaign"]["records"] = str(workdir / "campaign.csv")
    if not reference:
        cfg["reference"] = {"kind": "none"}
    cfg["report"] = {"group_min_count": 2}
    (workdir / "config.yaml").write_text(yaml.safe_dump(cfg))
    cmd = [SNAKEMAKE, "-s", str(REPO / "Snakefile"), "--directory", str(workdir),
           "--configfile", str(workdir / "config.yaml"), "--cores", "2"]  # fmt: skip
    proc = subprocess.run(cmd, capture_output=True, text=True, timeout=900, cwd=workdir)
    assert proc.returncode == 0, proc.stderr[-4000:]
    return workdir / "results"


@pytest.mark.slow
def test_first_screen_says_the_correction_size_and_the_validation_sample(tmp_path):
    """Headless Chromium renders the first screen of a campaign around 15 m/s: per height
    the representative TI at 15 m/s before -> after with its IEC categories (the numbers
    of speed_bins.csv), the validation labelled in sample, no model-selection statistics."""
    res = _run(tmp_path, scale_hws=15.0 / 8.5, reference=True)
    text = _summary_text(res / "report" / "report.html")
    rep15 = representative_at_15(pd.read_csv(res / "ti" / "speed_bins.csv"), 2)
    rep15 = rep15[np.isfinite(rep15["ti_rep"])]
    assert len(rep15), "no height with a 15-m/s bin"
    for r in rep15.itertuples():
        words = correction_size_words(r)
        assert words and words in text, (words, text)
        assert f"from {r.ti_rep_uncorrected:.3f} to {r.ti_rep:.3f}" in words
        assert re.search(r"IEC category (A\+|A|B|C)( -> (A\+|A|B|C)| either way)", words)
    assert "Validation against the reference, in sample" in text
    assert "coverage" not in text.lower()  # in sample: its coverage is not a validation
    assert not re.search(r"elpd|PSIS|wave_follower|discus_buoy|rotation_only", text), text
    # the paper's methods comparison is developer material: in the developer report only
    html = (res / "report" / "report.html").read_text()
    assert "Tables 2-3" not in html and "MD std (m/s)" not in html
    dev = build_developer_report(
        out_path=tmp_path / "developer.html",
        benchmarks_dir=REPO / "benchmarks" / "results",
        results_dir=res,
    )
    assert "Correction methods compared on results/" in dev and "MD std (m/s)" in dev


@pytest.mark.slow
def test_campaign_without_reference_fills_the_per_bin_tables(tmp_path):
    """reference: kind none: the corrected TI per bin with the prior's intervals in
    speed_bins.csv and the report's per-bin tables; the warning names the missing reference,
    not the sampler."""
    res = _run(tmp_path, scale_hws=1.0, reference=False)
    records = pd.read_csv(res / "ti" / "records.csv")
    kept = records["flags"].isna()
    assert kept.any() and records.loc[kept, "ti_corrected_median"].notna().all()
    bins = pd.read_csv(res / "ti" / "speed_bins.csv")
    filled = bins[bins["n"] >= 2]
    assert len(filled) and filled["ti_mean"].notna().all(), bins
    assert (filled["ti_mean_lo"] < filled["ti_mean"]).all()
    assert (filled["ti_mean"] < filled["ti_mean_hi"]).all()
    text = _summary_text(res / "report" / "report.html")
    for r in filled.itertuples():
        assert f"{r.ti_mean:.3f} {r.ti_mean_lo:.3f}–{r.ti_mean_hi:.3f}" in text, text
    assert "rho between the motion error and the turbulence stays at its prior" in text
    assert "sampler" not in text and "did not converge" not in text
    # what each bin's interval comes from, in words, in the table and the report
    words = {"the lidar's response g", "the regime discrepancy", "the motion description",
             "the correlation rho", "the records' noise", "too few records"}  # fmt: skip
    assert set(filled["interval_from"]) <= words and (filled["n"] < 30).any()
    assert (filled.loc[filled["n"] < 30, "interval_from"] == "too few records").all()
    html = (res / "report" / "report.html").read_text()
    assert "the interval comes from" in html and "too few records" in html
