"""Workflow step of a fleet of campaigns (config key ``campaigns``): the fleet summary.

Each campaign of a fleet writes its own ``results/<name>/`` tree (the output contract of a
single campaign's ``results/``); :func:`fleet_summary` compares them per campaign and height
(``results/fleet/summary.csv``, ``summary.html``, ``summary.png``).
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from pathlib import Path

import numpy as np
import pandas as pd

from flidar_uq.data.calibration import HEIGHT_SUMMARY_COLUMNS, height_summary
from flidar_uq.workflow.files import read_csv, write_csv

__all__ = ["FLEET_COLUMNS", "fleet_summary", "fleet_table"]

#: Columns of results/fleet/summary.csv, one row per campaign and height.
FLEET_COLUMNS = ("campaign", *HEIGHT_SUMMARY_COLUMNS)


def fleet_table(campaign_dirs: Mapping[str, str | os.PathLike]) -> pd.DataFrame:
    """The fleet's campaigns side by side, one row per campaign and height.

    Parameters
    ----------
    campaign_dirs : mapping of str -> path
        Campaign name -> its results directory (``results/<name>``: ``ti/records.csv``,
        ``ti/groups.csv``, ``ti/metrics.csv``), in the order of the rows.

    Returns
    -------
    pandas.DataFrame
        :data:`FLEET_COLUMNS`: ``n_records`` (records at the height, -), ``n_corrected``
        (with a Bayesian corrected TI, -), ``ti_mean`` with its interval ``ti_mean_lo``,
        ``ti_mean_hi`` (the campaign row of ``groups.csv``: mean corrected TI and the
        credible interval of that mean, -) and ``ti_mean_uncorrected`` (-); ``n_truth``
        (corrected records with a true TI, -) and ``coverage`` (share of their credible
        intervals holding the true TI, -; NaN without truth), ``credible_mass`` (-) and
        ``reference_kind`` (metrics.csv): :func:`flidar_uq.data.calibration.height_summary`.
    """
    rows = []
    for name, directory in campaign_dirs.items():
        ti = Path(directory) / "ti"
        summary = height_summary(
            read_csv(ti / "records.csv"), read_csv(ti / "groups.csv"), read_csv(ti / "metrics.csv")
        )
        rows.extend({"campaign": name, **row} for row in summary.to_dict("records"))
    return pd.DataFrame(rows, columns=list(FLEET_COLUMNS))


def _figure(table: pd.DataFrame):
    """Mean corrected TI with its interval against height, one series per campaign."""
    from matplotlib.figure import Figure

    fig = Figure(figsize=(6.0, 4.0))
    ax = fig.add_subplot()
    names = list(dict.fromkeys(table["campaign"]))
    for k, name in enumerate(names):
        t = table[(table["campaign"] == name) & np.isfinite(table["ti_mean"])]
        # small vertical offsets keep the campaigns' bars apart at a shared height
        dy = (k - (len(names) - 1) / 2) * 0.8
        ax.errorbar(
            t["ti_mean"],
            t["height_m"] + dy,
            xerr=[t["ti_mean"] - t["ti_mean_lo"], t["ti_mean_hi"] - t["ti_mean"]],
            fmt="o",
            capsize=3,
            label=name,
        )
    ax.set_xlabel("mean corrected TI (-), credible interval of the mean")
    ax.set_ylabel("height (m)")
    ax.set_title("fleet: mean corrected TI per campaign and height")
    ax.legend(fontsize="small")
    fig.tight_layout()
    return fig


def fleet_summary(
    campaign_dirs: Mapping[str, str | os.PathLike],
    *,
    table_out: str | os.PathLike,
    html_out: str | os.PathLike,
    figure_out: str | os.PathLike,
) -> pd.DataFrame:
    """Write the fleet summary: :func:`fleet_table` as CSV, a figure and a small HTML page.

    Parameters
    ----------
    campaign_dirs : mapping of str -> path
        Campaign name -> its results directory (``results/<name>``).
    table_out, html_out, figure_out : path
        ``results/fleet/summary.csv``, ``summary.html`` (the table, the figure and links to
        each campaign's report, relative to the page) and ``summary.png``.

    Returns
    -------
    pandas.DataFrame
        The table written.
    """
    from markupsafe import escape

    from flidar_uq.workflow import report as rep

    table = fleet_table(campaign_dirs)
    write_csv(table, table_out)
    _figure(table).savefig(figure_out, dpi=90, metadata={"Software": None})
    page_dir = Path(html_out).parent
    links = "".join(
        f'<li><a href="{escape(os.path.relpath(Path(d) / "report" / "report.html", page_dir))}">'
        f"{escape(name)}</a></li>"
        for name, d in campaign_dirs.items()
    )
    sections = [
        rep.Section(
            "Campaigns side by side",
            rep.table_html(
                table,
                caption="per campaign and height: records, records with a corrected TI, mean "
                "corrected TI with the credible interval of the mean, coverage of the records' "
                "credible intervals of the true TI (virtual campaigns), reference kind",
            )
            + rep.img_html(
                rep.png_bytes_to_data_uri(Path(figure_out).read_bytes()), "fleet mean TI"
            ),
        ),
        rep.Section("Campaign reports", f"<ul>{links}</ul>"),
    ]
    Path(html_out).write_text(
        rep.render_html("flidar_uq fleet summary", sections), encoding="utf-8"
    )
    return table
