"""The self-contained HTML report: figures embedded as base64 PNG, tables as HTML.

The report is deterministic for given inputs (no wall-clock time in it; PNGs written
without a date), so a clean rerun reproduces it byte for byte.
"""

from __future__ import annotations

import base64
import html
import importlib.metadata
import io as _io
import platform
from collections.abc import Iterable, Sequence
from dataclasses import dataclass

import pandas as pd
import yaml

__all__ = [
    "Section",
    "figure_to_data_uri",
    "img_html",
    "package_versions",
    "provenance_html",
    "png_bytes_to_data_uri",
    "render_html",
    "table_html",
]

#: Packages whose versions go into the provenance section.
PROVENANCE_PACKAGES = (
    "flidar_uq",
    "numpy",
    "scipy",
    "pandas",
    "emcee",
    "arviz",
    "xarray",
    "matplotlib",
    "snakemake",
)


@dataclass(frozen=True)
class Section:
    """One report section: a title and its HTML body."""

    title: str
    body_html: str


def png_bytes_to_data_uri(png: bytes) -> str:
    """``data:image/png;base64,...`` URI of PNG bytes."""
    return "data:image/png;base64," + base64.b64encode(png).decode("ascii")


def figure_to_data_uri(fig, *, dpi: int = 90) -> str:
    """Render a matplotlib Figure to a PNG data URI (no date metadata) and close it."""
    import matplotlib.pyplot as plt

    buf = _io.BytesIO()
    fig.savefig(buf, format="png", dpi=dpi, metadata={"Software": None})
    plt.close(fig)
    return png_bytes_to_data_uri(buf.getvalue())


def img_html(data_uri: str, alt: str) -> str:
    """An <img> element for a data URI."""
    return f'<figure><img src="{data_uri}" alt="{html.escape(alt)}"><figcaption>{html.escape(alt)}</figcaption></figure>'


def table_html(df: pd.DataFrame, *, float_format: str = "{:.4g}", caption: str = "") -> str:
    """An HTML table of a DataFrame (floats formatted, NaN shown as an en dash)."""

    def fmt(v):
        if isinstance(v, float):
            return "&ndash;" if v != v else float_format.format(v)
        return html.escape(str(v))

    head = "".join(f"<th>{html.escape(str(c))}</th>" for c in df.columns)
    rows = "".join(
        "<tr>" + "".join(f"<td>{fmt(v)}</td>" for v in row) + "</tr>"
        for row in df.itertuples(index=False)
    )
    cap = f"<caption>{html.escape(caption)}</caption>" if caption else ""
    return f'<div class="tw"><table>{cap}<thead><tr>{head}</tr></thead><tbody>{rows}</tbody></table></div>'


def package_versions(packages: Iterable[str] = PROVENANCE_PACKAGES) -> dict[str, str]:
    """Installed versions of ``packages`` (``"not installed"`` when absent), plus Python."""
    out = {"python": platform.python_version()}
    for name in packages:
        try:
            out[name] = importlib.metadata.version(name)
        except importlib.metadata.PackageNotFoundError:
            out[name] = "not installed"
    return out


def provenance_html(config: dict, git_revision: str, versions: dict[str, str]) -> str:
    """Provenance section: git revision, seeds, package versions and the full config."""
    seeds = {
        "campaign.seed": config.get("campaign", {}).get("seed"),
        "inference.seed": config.get("inference", {}).get("seed"),
    }
    ver = pd.DataFrame(sorted(versions.items()), columns=["package", "version"])
    cfg = yaml.safe_dump(config, sort_keys=True)
    return (
        f"<p>git revision: <code>{html.escape(git_revision or 'unknown (not a git checkout)')}</code></p>"
        + table_html(pd.DataFrame(list(seeds.items()), columns=["seed", "value"]), caption="seeds")
        + table_html(ver, caption="package versions")
        + f"<h3>configuration</h3><pre>{html.escape(cfg)}</pre>"
    )


_CSS = """
body{font-family:sans-serif;max-width:1100px;margin:2em auto;color:#222}
table{border-collapse:collapse;margin:0.5em 0 1.5em;font-size:0.85em}
th,td{border:1px solid #bbb;padding:2px 6px;text-align:right}
th{background:#eee} caption{font-weight:bold;text-align:left;padding:4px 0}
figure{margin:1em 0} img{max-width:100%} figcaption{font-size:0.85em;color:#555}
pre{background:#f6f6f6;padding:0.5em;font-size:0.8em;overflow-x:auto}
.tw{overflow-x:auto}
"""


def render_html(title: str, sections: Sequence[Section], *, intro_html: str = "") -> str:
    """The complete, self-contained HTML document (inline CSS, no external resources)."""
    toc = "".join(
        f'<li><a href="#s{i}">{html.escape(s.title)}</a></li>' for i, s in enumerate(sections)
    )
    body = "".join(
        f'<section id="s{i}"><h2>{html.escape(s.title)}</h2>{s.body_html}</section>'
        for i, s in enumerate(sections)
    )
    return (
        '<!DOCTYPE html>\n<html lang="en"><head><meta charset="utf-8">'
        f"<title>{html.escape(title)}</title><style>{_CSS}</style></head><body>"
        f"<h1>{html.escape(title)}</h1>{intro_html}<ol>{toc}</ol>{body}</body></html>\n"
    )
