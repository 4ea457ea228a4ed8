"""The self-contained HTML report: figures embedded as base64 PNG, tables as HTML.

The HTML lives in Jinja2 templates shipped with the package
(``flidar_uq/workflow/templates/*.html.j2``, the style sheet ``report.css``) and the
report's captions in ``templates/captions/*.txt.j2`` (plain text, escaped where used).
The report is deterministic for given inputs (no wall-clock time in it; PNGs written
without a date), so a clean rerun reproduces it byte for byte.
"""

from __future__ import annotations

import base64
import functools
import importlib.metadata
import io as _io
import platform
from collections.abc import Iterable, Sequence
from dataclasses import dataclass

import jinja2
import pandas as pd
import yaml
from markupsafe import Markup

__all__ = [
    "Section",
    "caption",
    "figure_to_data_uri",
    "img_html",
    "package_versions",
    "provenance_html",
    "png_bytes_to_data_uri",
    "render_html",
    "table_html",
    "templates",
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
    "numba",
    "llvmlite",
)


@dataclass(frozen=True)
class Section:
    """One report section: a title and its HTML body."""

    title: str
    body_html: str


@functools.cache
def templates() -> jinja2.Environment:
    """The Jinja2 environment of the package's report templates (HTML autoescaped)."""
    env = jinja2.Environment(
        loader=jinja2.PackageLoader("flidar_uq.workflow", "templates"),
        autoescape=jinja2.select_autoescape(enabled_extensions=("html.j2",)),
        keep_trailing_newline=True,
        undefined=jinja2.StrictUndefined,
    )
    env.filters["fmt"] = format  # {{ x|fmt(".3g") }}: Python format spec
    return env


def caption(name: str, **values) -> str:
    """A report caption (plain text) from ``templates/captions/<name>.txt.j2``."""
    return templates().get_template(f"captions/{name}.txt.j2").render(**values).strip()


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
    return templates().get_template("figure.html.j2").render(data_uri=data_uri, alt=alt)


def table_html(df: pd.DataFrame, *, float_format: str = "{:.4g}", caption: str = "") -> str:
    """An HTML table of a DataFrame (floats formatted, NaN shown as an en dash, booleans
    as yes / no)."""

    def fmt(v):
        if isinstance(v, bool) or type(v).__name__ == "bool_":  # no Python repr: yes / no
            return "yes" if v else "no"
        if isinstance(v, float):
            return None if v != v else float_format.format(v)  # None: shown as &ndash;
        return str(v)

    return (
        templates()
        .get_template("table.html.j2")
        .render(
            columns=[str(c) for c in df.columns],
            rows=[[fmt(v) for v in row] for row in df.itertuples(index=False)],
            caption=caption,
        )
    )


def package_versions(packages: Iterable[str] = PROVENANCE_PACKAGES) -> dict[str, str]:
    """Installed versions of ``packages`` (``"not installed"`` when absent), plus Python."""
    out = {"python": platform.python_version()}
    for name in packages:
        try:
            out[name] = importlib.metadata.version(name)
        except importlib.metadata.PackageNotFoundError:
            out[name] = "not installed"
    return out


def provenance_html(
    config: dict,
    git_revision: str,
    versions: dict[str, str],
    numerics: dict[str, str] | None = None,
) -> str:
    """Provenance section: git revision, seeds, package versions, numeric environment.

    The numeric environment (:func:`flidar_uq.threads.numeric_environment`, what the last
    bits depend on) is shown when given; the full config closes the section.
    """
    seeds = {
        "campaign.seed": config.get("campaign", {}).get("seed"),
        "inference.seed": config.get("inference", {}).get("seed"),
    }
    ver = pd.DataFrame(sorted(versions.items()), columns=["package", "version"])
    return (
        templates()
        .get_template("provenance.html.j2")
        .render(
            git_revision=git_revision,
            seeds_table=Markup(
                table_html(
                    pd.DataFrame(list(seeds.items()), columns=["seed", "value"]), caption="seeds"
                )
            ),
            versions_table=Markup(table_html(ver, caption="package versions")),
            numerics_table=Markup(
                table_html(
                    pd.DataFrame(sorted((numerics or {}).items()), columns=["item", "value"]),
                    caption="numeric environment of the process that wrote this report (each "
                    "job's is the first line of its log): a rerun is bit-identical where it, "
                    "the package versions and the seeds are the same (elsewhere they differ in "
                    "their last digits: README, 'Reproducibility across machines')",
                )
            )
            if numerics
            else "",
            config_yaml=_with_units(yaml.safe_dump(config, sort_keys=True)),
        )
    )


#: Units of the config keys by suffix, written beside the shown config's values.
KEY_UNITS = {"_ms": "m/s", "_s": "s", "_m": "m", "_deg": "deg", "_pct": "%", "_h": "h"}


def _with_units(config_yaml: str) -> str:
    """The config's YAML with each unit-suffixed scalar key's unit as a comment
    (``tau0_scale_ms: 0.1  # m/s``: the suffix _ms is metres per second, not milliseconds)."""
    import re

    out = []
    for line in config_yaml.splitlines():
        m = re.match(r"^\s*([A-Za-z0-9_]+): (\S.*)$", line)
        unit = next((u for k, u in KEY_UNITS.items() if m and m.group(1).endswith(k)), None)
        out.append(f"{line}  # {unit}" if unit and not m.group(2).startswith(("{", "[")) else line)
    return "\n".join(out) + "\n"


def render_html(title: str, sections: Sequence[Section], *, intro_html: str = "") -> str:
    """The complete, self-contained HTML document (inline CSS, no external resources)."""
    return (
        templates()
        .get_template("report.html.j2")
        .render(
            title=title,
            intro_html=Markup(intro_html),
            sections=[{"title": s.title, "body_html": Markup(s.body_html)} for s in sections],
        )
    )
