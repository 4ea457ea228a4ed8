"""The HTML report: self-contained, deterministic, and rendered by headless Chromium."""

from __future__ import annotations

import base64
import io
import os
import re
import subprocess
import tempfile
from pathlib import Path

import matplotlib.image
import numpy as np
import pandas as pd
import pytest
from conftest import require_tool

from flidar_uq.workflow import plots
from flidar_uq.workflow import report as rep

CHROMIUM_FLAGS = [
    "--headless",
    "--no-sandbox",
    "--disable-gpu",
    "--disable-quic",
    "--no-first-run",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
]

#: Appended to a copy of the report: records, for every <img>, whether it decoded.
_IMG_PROBE = (
    "<script>window.addEventListener('load',()=>{document.body.setAttribute('data-img-widths',"
    "Array.from(document.images).map(i=>i.complete?i.naturalWidth:-1).join(','));});</script>"
)


def _chromium(args: list[str], timeout: float = 90) -> subprocess.CompletedProcess:
    exe = require_tool("chromium")
    with tempfile.TemporaryDirectory() as profile:
        cmd = [exe, *CHROMIUM_FLAGS, f"--user-data-dir={profile}", *args]
        return subprocess.run(cmd, capture_output=True, text=True, timeout=timeout)


def chromium_image_widths(html_path: Path, work_dir: Path | None = None) -> list[int]:
    """naturalWidth of every <img> of the page after load, as Chromium decoded it.

    The page is copied with a probe script into ``work_dir`` (default: beside it).
    """
    probe = (work_dir or html_path.parent) / (html_path.stem + "_probe.html")
    probe.write_text(html_path.read_text().replace("</body>", _IMG_PROBE + "</body>"))
    proc = _chromium(["--virtual-time-budget=10000", "--dump-dom", probe.as_uri()])
    m = re.search(r'data-img-widths="([^"]*)"', proc.stdout)
    assert m, f"probe attribute not found; chromium stderr: {proc.stderr[-2000:]}"
    return [int(w) for w in m.group(1).split(",") if w]


#: Appended to a copy of the report: page width, viewport and where the summary ends.
_LAYOUT_PROBE = (
    "<script>window.addEventListener('load',()=>{const s=document.getElementById('summary');"
    "const r=s?s.getBoundingClientRect():{top:-1,bottom:-1};const b=document.body;"
    "b.setAttribute('data-layout',[document.documentElement.scrollWidth,window.innerWidth,"
    "window.innerHeight,Math.round(r.top),Math.round(r.bottom)].join(','));"
    "b.setAttribute('data-h2',Array.from(document.querySelectorAll('h2')).map(h=>h.textContent)"
    ".join('|'));});</script>"
)


def chromium_layout(html_path: Path, work_dir: Path, width: int = 1280, height: int = 1000):
    """Page scroll width, viewport width/height, the summary's top/bottom (px) and the h2 titles."""
    probe = work_dir / (html_path.stem + "_layout.html")
    probe.write_text(html_path.read_text().replace("</body>", _LAYOUT_PROBE + "</body>"))
    proc = _chromium(
        [f"--window-size={width},{height}", "--virtual-time-budget=10000", "--dump-dom",
         probe.as_uri()]
    )  # fmt: skip
    m = re.search(r'data-layout="([^"]*)"', proc.stdout)
    assert m, f"layout probe not found; chromium stderr: {proc.stderr[-2000:]}"
    scroll_w, view_w, view_h, top, bottom = (int(v) for v in m.group(1).split(","))
    titles = re.search(r'data-h2="([^"]*)"', proc.stdout).group(1).split("|")
    return {"scroll_width": scroll_w, "view_width": view_w, "view_height": view_h,
            "summary_top": top, "summary_bottom": bottom, "h2": titles}  # fmt: skip


def assert_report_layout(html_path: Path, tmp_path: Path, sections=()) -> None:
    """At 1280 x 1000 px: no horizontal overflow, the summary starts on the first screen
    (what must be above the fold at 1400 x 900: :func:`assert_first_screen`), and the named
    sections are there."""
    lay = chromium_layout(html_path, tmp_path)
    assert lay["scroll_width"] <= lay["view_width"], lay
    assert 0 <= lay["summary_top"] < lay["view_height"], lay
    for title in ("Summary", *sections):
        assert title in lay["h2"], (title, lay["h2"])


#: Where the browser tests keep the screenshots and PDF prints they check (a test
#: artefact: FLIDAR_TEST_ARTEFACTS, default results/test-artefacts/ of the repository).
ARTEFACTS = Path(
    os.environ.get(
        "FLIDAR_TEST_ARTEFACTS", Path(__file__).resolve().parents[1] / "results" / "test-artefacts"
    )
)

#: The first screen the analyst sees (px) and the printable width of an A4 page with the
#: report's 12-mm margins (186 mm at 96 px per inch, px).
FIRST_VIEWPORT = (1400, 900)
PRINT_WIDTH_PX = 703

#: The first screen's parts that must be above the fold (element ids; ^ = id prefix).
FIRST_SCREEN_IDS = ("rep15", "validation-headline", "^bins-")

_VIEWPORT_PROBE = (
    "<script>window.addEventListener('load',()=>{const out=[];"
    "for(const e of document.querySelectorAll('[id]')){const r=e.getBoundingClientRect();"
    "out.push([e.id,Math.round(r.top),Math.round(r.bottom),Math.round(r.right)].join(':'));}"
    "document.body.setAttribute('data-ids',out.join('|'));"
    "document.body.setAttribute('data-view',[window.innerWidth,window.innerHeight].join(','));"
    "});</script>"
)


def first_viewport(html_path: Path, work_dir: Path) -> tuple[dict, tuple[int, int]]:
    """Each element id -> (top, bottom, right) in px at the first viewport, and the viewport."""
    probe = work_dir / (html_path.stem + "_viewport.html")
    probe.write_text(html_path.read_text().replace("</body>", _VIEWPORT_PROBE + "</body>"))
    w, h = FIRST_VIEWPORT
    proc = _chromium([f"--window-size={w},{h}", "--hide-scrollbars", "--virtual-time-budget=10000",
                      "--dump-dom", probe.as_uri()])  # fmt: skip
    m = re.search(r'data-ids="([^"]*)"', proc.stdout)
    assert m, f"viewport probe not found; chromium stderr: {proc.stderr[-2000:]}"
    ids = {}
    for item in m.group(1).split("|"):
        name, top, bottom, right = item.rsplit(":", 3)
        ids[name] = (int(top), int(bottom), int(right))
    view = tuple(int(v) for v in re.search(r'data-view="([^"]*)"', proc.stdout).group(1).split(","))
    return ids, view


def assert_first_screen(html_path: Path, work_dir: Path, name: str) -> Path:
    """The per-bin TI tables, the representative TI at 15 m/s with its IEC category and the
    validation headline lie inside the first 1400 x 900 viewport; the screenshot of that
    viewport is kept under ARTEFACTS (its path returned and printed)."""
    ids, (vw, _) = first_viewport(html_path, work_dir)
    # the layout depends on the width only; the fold is 900 px down the page (in --dump-dom
    # mode the window's height includes the browser's frame, the screenshot's does not)
    vh = FIRST_VIEWPORT[1]
    assert vw == FIRST_VIEWPORT[0], vw
    for want in FIRST_SCREEN_IDS:
        hits = [k for k in ids if (k.startswith(want[1:]) if want[0] == "^" else k == want)]
        assert hits, (want, sorted(ids))
        for k in hits:
            top, bottom, right = ids[k]
            assert 0 <= top and bottom <= vh and right <= vw, (k, ids[k], (vw, vh))
    ARTEFACTS.mkdir(parents=True, exist_ok=True)
    shot = ARTEFACTS / f"{name}_first_screen.png"
    _chromium([f"--screenshot={shot}", f"--window-size={vw},{vh}", "--hide-scrollbars",
               html_path.as_uri()])  # fmt: skip
    assert shot.is_file()
    print(f"first-screen screenshot: {shot}")
    return shot


_PRINT_PROBE = (
    "<script>window.addEventListener('load',()=>{const W=document.documentElement.clientWidth;"
    "const bad=[];for(const t of document.querySelectorAll('table')){const r=t.getBoundingClientRect();"
    "if(r.right>W+1||t.scrollWidth>t.parentElement.clientWidth+1)"
    "bad.push((t.caption?t.caption.textContent:'table').slice(0,60)+' '+Math.round(r.right));}"
    "document.body.setAttribute('data-wide',bad.join('|'));"
    "document.body.setAttribute('data-width',[W,document.documentElement.scrollWidth,"
    "document.querySelectorAll('table').length].join(','));});</script>"
)


def assert_prints_without_cut_tables(html_path: Path, work_dir: Path, name: str) -> Path:
    """Under the report's print style at the printable width of an A4 page, no table is
    wider than the page (nothing would be cut off); the PDF print is kept under ARTEFACTS."""
    text = html_path.read_text()
    assert "@media print{" in text
    probe = work_dir / (html_path.stem + "_print.html")
    probe.write_text(
        text.replace("@media print{", "@media all{").replace("</body>", _PRINT_PROBE + "</body>")
    )
    proc = _chromium([f"--window-size={PRINT_WIDTH_PX},1200", "--hide-scrollbars",
                      "--virtual-time-budget=10000", "--dump-dom", probe.as_uri()])  # fmt: skip
    m = re.search(r'data-wide="([^"]*)"', proc.stdout)
    assert m, f"print probe not found; chromium stderr: {proc.stderr[-2000:]}"
    width, scroll, n_tables = (
        int(v) for v in re.search(r'data-width="([^"]*)"', proc.stdout).group(1).split(",")
    )
    assert n_tables > 0 and width <= PRINT_WIDTH_PX
    assert m.group(1) == "", f"tables wider than the page ({width} px): {m.group(1)}"
    assert scroll <= width + 1, (scroll, width)
    ARTEFACTS.mkdir(parents=True, exist_ok=True)
    pdf = ARTEFACTS / f"{name}.pdf"
    _chromium([f"--print-to-pdf={pdf}", "--no-pdf-header-footer", html_path.as_uri()], timeout=180)
    assert pdf.is_file() and pdf.read_bytes()[:5] == b"%PDF-"
    print(f"PDF print: {pdf}")
    return pdf


#: Absolute paths of a machine (POSIX home, temporary and system directories; Windows drives).
_ABSOLUTE_PATH = re.compile(
    r"(?<![\w.:/+=])(/(home|tmp|work|root|Users|var|opt|usr|mnt|srv)/|(?<![\w+/])[A-Z]:\\(?=\w))"
)


def assert_no_absolute_path(html: str, *dirs: Path) -> None:
    """No absolute path of the machine in the report (the files are named, not located)."""
    for d in dirs:
        assert str(d) not in html, d
    m = _ABSOLUTE_PATH.search(html)
    assert m is None, html[max(0, m.start() - 80) : m.end() + 80]


def chromium_screenshot(html_path: Path, png_path: Path) -> np.ndarray:
    """Screenshot of the page as an RGB(A) float array in [0, 1]."""
    proc = _chromium([f"--screenshot={png_path}", "--window-size=1200,2400", html_path.as_uri()])
    assert png_path.is_file(), proc.stderr[-2000:]
    return matplotlib.image.imread(png_path)


def assert_report_renders(html_path: Path, tmp_path: Path) -> None:
    """Every embedded figure decodes (naturalWidth > 0) and the page is not blank."""
    n_img = html_path.read_text().count("<img ")
    widths = chromium_image_widths(html_path, tmp_path)
    assert len(widths) == n_img > 0
    assert min(widths) > 0, widths
    shot = chromium_screenshot(html_path, tmp_path / "shot.png")
    rgb = shot[..., :3]
    not_white = np.mean(rgb.min(axis=-1) < 0.9)
    assert not_white > 0.02, f"screenshot almost blank ({not_white:.3%} non-white pixels)"
    assert np.std(rgb) > 0.05


def synthetic_records(rng: np.random.Generator, n: int = 200) -> pd.DataFrame:
    hws = rng.uniform(3, 20, n)
    ti_true = 0.05 + 0.3 / hws
    ti_med = ti_true * rng.normal(1, 0.05, n)
    return pd.DataFrame(
        {
            "hws_mean_ms": hws,
            "ti_true": ti_true,
            "ti_uncorrected": ti_true + 0.02,
            "ti_corrected_median": ti_med,
            "ti_corrected_lo": ti_med - 0.01,
            "ti_corrected_hi": ti_med + 0.01,
        }
    )


def synthetic_speed_bins(recs: pd.DataFrame) -> pd.DataFrame:
    """speed_bins.csv-like rows of one height from synthetic records (narrow bin intervals)."""
    from flidar_uq.data.binning import speed_bin_ms

    g = recs.assign(hws_bin_ms=speed_bin_ms(recs["hws_mean_ms"])).groupby("hws_bin_ms")
    b = pd.DataFrame(
        {
            "ti_mean": g["ti_corrected_median"].mean(),
            "ti_rep": g["ti_corrected_median"].mean() + 1.28 * g["ti_corrected_median"].std(),
            "ti_mean_uncorrected": g["ti_uncorrected"].mean(),
        }
    ).reset_index()
    b["ti_rep_uncorrected"] = b["ti_rep"] + 0.02
    for c in ("ti_mean", "ti_rep"):
        b[f"{c}_lo"], b[f"{c}_hi"] = b[c] - 0.002, b[c] + 0.002
    return b


def synthetic_first_screen(rng: np.random.Generator, heights=(27.0, 58.0, 85.0)) -> str:
    """The first screen of a 3-height campaign with a reference, every bin 3-20 m/s filled."""
    from flidar_uq.validation.reference import validation_tables
    from flidar_uq.workflow.report_summary import (
        FirstScreen,
        Validation,
        bin_tables,
        first_screen_html,
        reference_speed_bins,
        representative_at_15,
    )

    recs = []
    for h in heights:
        r = synthetic_records(rng, 600).assign(height_m=h)
        r["hws_mean_ms"] = np.tile(np.arange(3.0, 21.0), 34)[:600] + rng.uniform(-0.4, 0.4, 600)
        r["ti_ref"] = r["ti_true"] * rng.normal(1, 0.03, 600)
        recs.append(r)
    recs = pd.concat(recs, ignore_index=True)
    recs["timestamp"] = pd.date_range("2026-01-05", periods=len(recs), freq="10min", tz="UTC")
    bins = pd.concat(
        [synthetic_speed_bins(recs[recs["height_m"] == h]).assign(height_m=h) for h in heights]
    )
    bins["n"] = 33
    held = np.arange(len(recs)) % 2 == 1
    tables = validation_tables(recs, held)
    screen = FirstScreen(
        title="test campaign",
        facts=[("campaign", "test campaign"), ("input", "records.csv (SHA-256 0123456789ab…)")],
        rep15=representative_at_15(bins),
        bin_tables=bin_tables(bins, reference_speed_bins(recs), 10),
        validation=Validation(tables, "Held out: every other record.", "held out", False),
        warnings=["The buoy's measured motion explains the extra variance only when scaled."],
        mass=0.9,
    )
    return first_screen_html(screen)


def small_report(rng: np.random.Generator) -> str:
    recs = synthetic_records(rng)
    fig = plots.ti_speed_bins_figure(synthetic_speed_bins(recs), recs, credible_mass=0.9)
    table = pd.DataFrame({"method": ["uncorrected", "Bayesian"], "md_ti": [0.02, np.nan]})
    wide = pd.DataFrame(rng.normal(size=(3, 40)), columns=[f"column_{k}" for k in range(40)])
    sections = [
        rep.Section("figure", rep.img_html(rep.figure_to_data_uri(fig), "TI against HWS")),
        rep.Section("wide table", rep.table_html(wide, caption="40 columns scroll in their box")),
        rep.Section("table", rep.table_html(table, caption="MD")),
        rep.Section(
            "provenance",
            rep.provenance_html({"campaign": {"seed": 1}}, "abc123", rep.package_versions()),
        ),
    ]
    return rep.render_html("test report", sections, intro_html=synthetic_first_screen(rng))


def test_figure_png_is_deterministic_and_decodes(rng):
    recs = synthetic_records(rng)
    bins = synthetic_speed_bins(recs)
    a = rep.figure_to_data_uri(plots.ti_speed_bins_figure(bins, recs, credible_mass=0.9))
    b = rep.figure_to_data_uri(plots.ti_speed_bins_figure(bins, recs, credible_mass=0.9))
    assert a == b
    png = base64.b64decode(a.split(",", 1)[1])
    img = matplotlib.image.imread(io.BytesIO(png), format="png")
    assert img.shape[0] > 100 and img.shape[1] > 100
    assert b"tIME" not in png  # no timestamp chunk


def test_table_html_escapes_and_shows_nan_as_dash():
    html = rep.table_html(pd.DataFrame({"a<b": ["x&y"], "v": [float("nan")]}), caption="c>d")
    assert "a&lt;b" in html and "x&amp;y" in html and "c&gt;d" in html
    assert "&ndash;" in html


def test_render_html_is_self_contained(rng):
    html = small_report(rng)
    assert html.startswith("<!DOCTYPE html>")
    assert "<script" not in html
    assert not re.search(r'(src|href)="(https?:)?//', html)  # no external resource
    assert html.count("data:image/png;base64,") == 1
    assert "abc123" in html and "numpy" in html


def test_provenance_shows_the_numeric_environment_when_given():
    numerics = {"machine": "x86_64", "numpy_simd": "X86_V4: exp", "blas": "openblas (K kernel)"}
    html = rep.provenance_html({}, "abc", {"numpy": "2"}, numerics)
    assert "numeric environment" in html
    assert all(v in html for v in numerics.values())
    assert "numeric environment" not in rep.provenance_html({}, "abc", {"numpy": "2"})


def test_package_versions_names_numpy_and_missing_packages():
    v = rep.package_versions(["numpy", "surely_not_a_package_xyz"])
    assert v["numpy"] == np.__version__
    assert v["surely_not_a_package_xyz"] == "not installed"
    assert "python" in v


def test_report_rendered_by_headless_chromium(rng, tmp_path):
    path = tmp_path / "report.html"
    path.write_text(small_report(rng))
    assert_report_renders(path, tmp_path)
    assert_report_layout(path, tmp_path, sections=("figure", "wide table", "provenance"))


def test_first_screen_fits_the_first_viewport_and_prints_without_cut_tables(rng, tmp_path):
    """Three heights of 18 bins each, the representative TI at 15 m/s with its category and
    the validation headline inside 1400 x 900 px; a 40-column table fits an A4 page in print."""
    path = tmp_path / "report.html"
    html = small_report(rng)
    path.write_text(html)
    for h in ("27", "58", "85"):
        assert f'id="bins-{h}"' in html
    assert "IEC category" in html and 'id="validation-headline"' in html
    shot = assert_first_screen(path, tmp_path, "synthetic")
    img = matplotlib.image.imread(shot)
    assert img.shape[:2] == (900, 1400)
    assert_prints_without_cut_tables(path, tmp_path, "synthetic")
    assert_no_absolute_path(html, tmp_path)


def test_viewport_and_print_probes_can_fail(tmp_path):
    """The checks fail: a headline below 900 px, and a table wider than the page in print."""
    path = tmp_path / "bad.html"
    path.write_text(
        "<!DOCTYPE html><html><head><style>@media print{td{padding:1px}}</style></head><body>"
        '<div style="height:1200px">x</div><div id="rep15">r</div><div id="validation-headline">'
        'v</div><table id="bins-85"><tr><td style="white-space:nowrap">'
        + "wide " * 300
        + "</td></tr></table></body></html>"
    )
    with pytest.raises(AssertionError, match="rep15"):
        assert_first_screen(path, tmp_path, "bad")
    with pytest.raises(AssertionError, match="wider than the page"):
        assert_prints_without_cut_tables(path, tmp_path, "bad")
    with pytest.raises(AssertionError):
        assert_no_absolute_path("<p>/home/user/data/records.csv</p>")
    assert_no_absolute_path('<img src="data:image/png;base64,ab+/tmp/cd">')  # base64, not a path


def test_layout_probe_detects_overflow_and_a_summary_below_the_fold(tmp_path):
    """The layout check can fail: a 3000-px-wide element and a summary after 2000 px."""
    path = tmp_path / "bad.html"
    path.write_text(
        '<!DOCTYPE html><html><body><div style="height:2000px;width:3000px">x</div>'
        '<section id="summary"><h2>Summary</h2></section></body></html>'
    )
    lay = chromium_layout(path, tmp_path)
    assert lay["scroll_width"] > lay["view_width"] == 1280
    assert lay["summary_top"] > lay["view_height"]


def test_chromium_probe_detects_a_broken_image(tmp_path):
    """The render check can fail: a corrupt data URI gives naturalWidth 0."""
    path = tmp_path / "broken.html"
    path.write_text(
        '<!DOCTYPE html><html><body><img src="data:image/png;base64,AAAA"></body></html>'
    )
    assert chromium_image_widths(path) == [0]


@pytest.mark.parametrize("credible_mass", [0.5, 0.9])
def test_ti_speed_bins_figure_draws_the_interval_of_the_bin_mean(credible_mass):
    """The shaded band of the bin mean is the speed_bins interval (what the legend says),
    not an average of the records' intervals; the IEC curves follow I_ref (0.75 + 5.6/V)."""
    recs = synthetic_records(np.random.default_rng(1), 300)
    bins = synthetic_speed_bins(recs)
    fig = plots.ti_speed_bins_figure(bins, recs, credible_mass=credible_mass)
    ax = fig.axes[0]
    band = ax.collections[0].get_paths()[0].vertices
    inside = band[(band[:, 0] > 5) & (band[:, 0] < 15)]
    half = np.ptp(inside[:, 1].reshape(-1)) if len(inside) else 1.0
    assert half < 0.2  # the band spans the bin means +-0.002, not the records' spread
    ys = np.unique(np.round(band[:, 1], 6))
    expected = np.round(np.r_[bins["ti_mean_lo"], bins["ti_mean_hi"]], 6)
    assert np.isin(ys, expected).all()
    labels = [t.get_text() for t in ax.get_legend().get_texts()]
    assert f"corrected bin mean, {credible_mass:.0%} interval of the mean" in labels
    np.testing.assert_allclose(plots.iec_representative_ti(15.0, 0.16), 0.16 * (0.75 + 5.6 / 15))
    assert ax.get_xlabel() == "HWS bin [m/s]"


def test_ti_speed_bins_figure_handles_an_empty_height():
    empty = synthetic_speed_bins(synthetic_records(np.random.default_rng(1), 5)).iloc[:0]
    fig = plots.ti_speed_bins_figure(empty, None, credible_mass=0.9)
    assert fig.axes[0].get_ylabel() == "TI [-]"


def test_calibration_figure_reports_the_coverage_it_draws(rng):
    # 200 records per 2-m/s bin; intervals that contain the reference in exactly 90 % of
    # the records of the first bin and 50 % of the second: the plotted points say so
    hws = np.repeat([4.0, 8.0], 200)
    ref = np.full(hws.size, 0.1)
    est = np.full(hws.size, 0.1)
    inside = np.r_[np.arange(200) < 180, np.arange(200) < 100]
    lo = np.where(inside, 0.09, 0.11)
    hi = np.where(inside, 0.11, 0.12)
    fig = plots.calibration_figure(
        hws, est, lo, hi, {"truth": ref, "scaled": (ref, np.full(hws.size, 2.0))}, credible_mass=0.9
    )
    ax_c, ax_e = fig.axes
    pts = [c for c in ax_c.containers]  # one errorbar container per reference
    y_truth = np.asarray(pts[0].lines[0].get_ydata(), float)
    np.testing.assert_allclose(y_truth, [0.9, 0.5])
    y_scaled = np.asarray(
        pts[1].lines[0].get_ydata(), float
    )  # interval x 2 no longer holds the reference
    np.testing.assert_allclose(y_scaled, [0.0, 0.0])
    np.testing.assert_allclose(
        np.asarray(ax_e.lines[0].get_ydata(), float), [0.0, 0.0], atol=1e-12
    )  # est == ref
    np.testing.assert_allclose(
        np.asarray(ax_e.lines[1].get_ydata(), float), [100.0, 100.0]
    )  # 2 x est


def test_templates_and_captions_ship_with_the_package():
    """The report's HTML and captions are package data (pyproject package-data), found by
    the Jinja2 PackageLoader; every caption renders to non-empty plain text."""
    import importlib.resources

    root = importlib.resources.files("flidar_uq.workflow") / "templates"
    names = {p.name for p in root.iterdir()}
    assert {"report.html.j2", "table.html.j2", "figure.html.j2", "provenance.html.j2"} <= names
    captions = [p.name.removesuffix(".txt.j2") for p in (root / "captions").iterdir()]
    assert "metrics" in captions and "bin_table" in captions
    values = {
        "mass": 0.9,
        "n_hidden": 3,
        "label": "truth",
        "rho_pc": 0.78,
        "rho_src": "Gutiérrez-Antuñano et al. 2018",
    }
    values |= {"height": "85", "min_count": 10, "names": "rho, kappa", "sample": "held out"}
    for name in captions:
        text = rep.caption(name, bin_id=7, **values)
        assert text and "{" not in text and "\n" not in text, name
    assert "90%" in rep.caption("ti_speed_bins", mass=0.9, height="85")
    assert "(rho, kappa, kappa_z)" in rep.caption("global_posterior", names="rho, kappa, kappa_z")
    assert "rho = 0.78 (Gutiérrez-Antuñano et al. 2018)" in rep.caption("sigma_scatter", **values)


def test_provenance_config_reads_units_from_the_key_names():
    """tau0_scale_ms is metres per second, not milliseconds: the shown config says so."""
    html = rep.provenance_html({"priors": {"tau0_scale_ms": 0.1, "period_min_s": 1.0}}, "abc", {})
    assert "tau0_scale_ms: 0.1  # m/s" in html and "period_min_s: 1.0  # s" in html
    assert "never milliseconds" in html


def test_public_config_names_files_without_their_directories():
    from flidar_uq.workflow.report_step import public_config

    cfg = {"campaign": {"records": "/data/site/buoy.csv", "scenario": "default"}, "x": ["/a/b.nc"]}
    assert public_config(cfg) == {"campaign": {"records": "buoy.csv", "scenario": "default"},
                                  "x": ["b.nc"]}  # fmt: skip


def test_table_html_shows_booleans_in_words():
    html = rep.table_html(pd.DataFrame({"on": [True, False], "np": np.array([True, False])}))
    assert "True" not in html and "False" not in html
    assert html.count(">yes<") == 2 and html.count(">no<") == 2


def test_first_screen_says_which_motion_description_each_record_got():
    from flidar_uq.workflow.report_summary import motion_description_summary

    rec = pd.DataFrame(
        {
            "motion_description": ["along_wind"] * 3 + ["roll_pitch", ""],
            "translation_description": ["tilt_spectrum"] * 2 + ["none", "none", ""],
        }
    )
    txt = motion_description_summary(rec)
    parts = txt.split(" · ")
    assert parts[0].startswith("2 records: tilt along the wind")
    assert "surge and heave from the tilt spectrum" in parts[0]
    assert sorted(parts[1:]) == sorted(
        [
            "1 records: tilt along the wind from the IMU spectrum; no translation (rotation "
            "about a fixed centre)",
            "1 records: roll and pitch amplitude and period only; no translation (rotation "
            "about a fixed centre)",
        ]
    )
    assert motion_description_summary(rec.drop(columns="translation_description")) == ""
    # tilt bands: whether each band's direction of travel was measured from the heave
    bands = pd.DataFrame(
        {
            "motion_description": ["tilt_bands"] * 4,
            "translation_description": ["tilt_spectrum"] * 3 + ["none"],
            "wave_direction_description": ["measured", "measured", "assumed", ""],
        }
    )
    parts = motion_description_summary(bands).split(" · ")
    assert len(parts) == 3
    assert parts[0].startswith("2 records: tilt spectrum by period bands")
    assert parts[0].endswith("each wave band's direction of travel measured from the heave")
    rest = sorted(parts[1:], key=lambda p: "assumed" not in p)
    assert rest[0].startswith("1 records") and "directions of travel assumed" in rest[0]
    assert rest[1].endswith("no translation (rotation about a fixed centre)")
