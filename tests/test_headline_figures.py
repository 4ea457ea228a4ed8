"""The README's headline table is the method-frontier benchmark's CSV
(benchmarks/results/method_frontier.csv), row by row, so that the two cannot disagree; the
user guide points at it instead of keeping a copy."""

from __future__ import annotations

from pathlib import Path

import pandas as pd

REPO = Path(__file__).resolve().parent.parent


def _headline_rows() -> list[str]:
    """The README table's rows from the benchmark CSV (campaign-wide rows)."""
    d = pd.read_csv(REPO / "benchmarks" / "results" / "method_frontier.csv")
    d = d[d["speed_group_ms"] == "all"].set_index("method")

    def pct(x):
        return f"{100 * x:.1f} %"

    laws = [m for m in d.index if m.startswith(("U (", "C (", "PC ("))]
    bayes, laplace = d.loc["Bayes default (adaptive)"], d.loc["Laplace"]
    los, los_unc = d.loc["LOS least squares"], d.loc["uncorrected (LOS campaign)"]
    law_errors = " / ".join(f"{100 * d.loc[m, 'mean_abs_rel_err']:.1f}" for m in laws)
    return [
        f"| uncorrected | {pct(d.loc['uncorrected', 'mean_abs_rel_err'])} | - | ~0 |",
        f"| Gutiérrez-Antuñano et al. (2018) U / C / PC laws | {law_errors} % | - | "
        f"{d.loc[laws[0], 'wall_s']:.1f} s |",
        f"| Bayesian record model (default) | {pct(bayes['mean_abs_rel_err'])} | "
        f"{pct(bayes['coverage_90'])} | {bayes['wall_s']:.0f} s |",
        f"| Laplace approximation of it | {pct(laplace['mean_abs_rel_err'])} | "
        f"{pct(laplace['coverage_90'])} | {laplace['wall_s']:.1f} s |",
        f"| LOS-level least squares (LOS campaign) | {pct(los['mean_abs_rel_err'])} (uncorrected "
        f"{pct(los_unc['mean_abs_rel_err'])}) | - | ~{1000 * los['wall_s_per_record']:.0f} ms per "
        "record |",
    ]


def test_readme_headline_table_is_the_benchmark_csv():
    readme = (REPO / "README.md").read_text(encoding="utf-8")
    missing = [row for row in _headline_rows() if row not in readme]
    assert missing == [], "README.md's table differs from method_frontier.csv: " + repr(missing)


def test_user_guide_keeps_no_copy_of_the_headline_figures():
    guide = (REPO / "docs" / "user-guide.md").read_text(encoding="utf-8")
    assert "| uncorrected |" not in guide
