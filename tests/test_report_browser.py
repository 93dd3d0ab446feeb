"""The HTML report, opened as a reader would: headless Chromium renders an index.html
that the tests have just generated (the tiny report of conftest.py: two blocks, one
model, a short MCMC chain, a cross-impedance prediction, the limit-cycle comparison and
the thesis graphs), so what is checked is the current code's output, not a committed file.

Checks what can be checked from outside the browser: the DOM Chromium builds holds the
ranking tables and every figure of results.json as a ``data:`` PNG (each decodes as a
valid PNG), nothing points outside the file, the browser logs no page errors, and the
screenshots show content (kept in ``test-artifacts/`` for a human to look at). The page
has no script; what only the browser knows (the summary image decoded, the navigation bar
laid out and still at the top after scrolling) is read by a probe script added to a copy
of the page, whose answer ``--dump-dom`` returns. Skipped, with the reason, where Chromium
is not installed.
"""

from __future__ import annotations

import base64
import html
import io
import json
import re
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest

pytestmark = pytest.mark.browser

REPO = Path(__file__).resolve().parents[1]
ARTIFACTS = REPO / "test-artifacts"
FLAGS = [
    "--headless",
    "--no-sandbox",
    "--disable-gpu",
    "--disable-quic",
    "--no-first-run",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
]


def _chromium():
    for name in ("chromium", "chromium-browser", "/usr/bin/chromium"):
        path = shutil.which(name)
        if path:
            return path
    return None


CHROMIUM = _chromium()
needs = pytest.mark.skipif(
    CHROMIUM is None, reason="headless Chromium not installed (apt-get install chromium)"
)


@pytest.fixture(scope="module")
def report(request) -> Path:
    """index.html of the freshly generated tiny report (asked for only when Chromium is there;
    it has every kind of figure: fit, loci, residuals and corner of a block, cross-impedance,
    limit cycles, the thesis graphs)."""
    if CHROMIUM is None:
        pytest.skip("headless Chromium not installed (apt-get install chromium)")
    return request.getfixturevalue("tiny_report") / "index.html"


def _figure_paths(results: dict) -> list[str]:
    """Every figure results.json lists (each must be embedded in index.html)."""
    paths = [results["summary_figure"]] if results.get("summary_figure") else []
    paths += [p for rec in results["blocks"].values() for p in rec["figures"].values() if p]
    paths += [g["path"] for g in results["thesis_graphs"]]
    paths += [c["figure"] for c in results["cross_impedance"] if c.get("figure")]
    if results["limit_cycles"].get("figure"):
        paths.append(results["limit_cycles"]["figure"])
    return paths


def _run(tmp_path, *args, timeout=120):
    cmd = [
        CHROMIUM,
        *FLAGS,
        f"--user-data-dir={tmp_path / 'profile'}",
        "--enable-logging=stderr",
        "--v=0",
        *args,
    ]
    return subprocess.run(cmd, capture_output=True, text=True, timeout=timeout, check=False)


def _page_errors(stderr: str) -> list[str]:
    """Console errors and failed loads of the page (the browser's own dbus/gpu chatter is not the page's)."""
    return [
        ln
        for ln in stderr.splitlines()
        if re.search(r"CONSOLE|Failed to load resource|Uncaught|net::ERR_", ln)
        and "ERR_INTERNET" not in ln
    ]


@pytest.fixture(scope="module")
def results(report) -> dict:
    return json.loads((report.parent / "results.json").read_text(encoding="utf-8"))


@pytest.fixture(scope="module")
def dom(report, tmp_path_factory):
    tmp = tmp_path_factory.mktemp("chromium")
    proc = _run(tmp, "--dump-dom", report.as_uri())
    assert proc.returncode == 0, proc.stderr[-2000:]
    assert not _page_errors(proc.stderr), _page_errors(proc.stderr)
    return proc.stdout


@needs
def test_dom_has_rankings_and_embedded_figures(dom, results):
    assert "fitdf comparison report" in dom
    tables = re.findall(r"<table>.*?</table>", dom, re.S)
    rankings = [t for t in tables if "<th>RMS complex</th>" in t and "<th>AICc</th>" in t]
    assert len(rankings) >= len(results["blocks"])  # a least-squares ranking per block at least
    for rec in results["blocks"].values():
        for model in rec["order_lsq"]:
            assert model in dom
    figures = _figure_paths(results)
    assert {"fit", "loci", "residuals", "corner"} <= set(results["blocks"]["B.1"]["figures"])
    assert results["limit_cycles"].get("figure"), results["limit_cycles"]
    srcs = re.findall(r'<img src="([^"]*)"', dom)
    assert len(srcs) == len(figures)  # every figure of results.json, embedded
    for src in srcs:
        assert src.startswith("data:image/png;base64,")
        png = base64.b64decode(src.split(",", 1)[1], validate=True)
        assert png[:8] == b"\x89PNG\r\n\x1a\n" and len(png) > 5000
    assert not re.search(r"""(src|href)=["'](https?:)?//""", dom)


@needs
def test_embedded_pngs_decode(dom):
    from matplotlib import image

    srcs = re.findall(r'<img src="data:image/png;base64,([^"]*)"', dom)
    for src in srcs[:12]:
        pixels = image.imread(io.BytesIO(base64.b64decode(src)), format="png")
        assert pixels.ndim == 3 and min(pixels.shape[:2]) > 200


def _screenshot(tmp_path, url: str, name: str, height: int) -> Path:
    ARTIFACTS.mkdir(exist_ok=True)
    path = ARTIFACTS / name
    path.unlink(missing_ok=True)
    proc = _run(
        tmp_path, f"--screenshot={path}", f"--window-size=1280,{height}", "--hide-scrollbars", url
    )
    assert proc.returncode == 0, proc.stderr[-2000:]
    assert not _page_errors(proc.stderr), _page_errors(proc.stderr)
    assert path.exists() and path.stat().st_size > 20_000
    return path


@needs
def test_screenshots_show_the_report(report, tmp_path):
    from matplotlib import image

    top = _screenshot(tmp_path, report.as_uri(), "report_top.png", 2000)
    pixels = image.imread(top)
    assert pixels.shape[:2] == (2000, 1280)
    ink = np.mean(np.any(pixels[..., :3] < 0.9, axis=-1))
    assert ink > 0.02  # text and tables, not a blank page
    # A tall window reaches the first block's figures (headless screenshots ignore #anchors).
    tall = _screenshot(tmp_path, report.as_uri(), "report_first_block.png", 6000)
    rgb = (image.imread(tall)[2000:, :, :3] * 255).astype(int)
    colours = np.unique(rgb.reshape(-1, 3)[::7], axis=0)
    assert len(colours) > 200  # figures (colour curves, bands) were rendered


#: Appended to a copy of index.html: reports, after the page loaded, what the browser made
#: of the summary image and the navigation bar (before and after scrolling 4000 px).
_PROBE = """<script>
window.addEventListener("load", () => {
  const img = document.querySelector("img");
  const nav = document.querySelector("nav.sections");
  const top = nav.getBoundingClientRect();
  const hrefs = [...nav.querySelectorAll("a")].map((a) => a.getAttribute("href").slice(1));
  window.scrollTo(0, 4000);
  const scrolled = nav.getBoundingClientRect();
  document.body.setAttribute("data-probe", JSON.stringify({
    alt: img.alt, naturalWidth: img.naturalWidth, naturalHeight: img.naturalHeight,
    shownWidth: img.getBoundingClientRect().width,
    imgTop: img.getBoundingClientRect().top + window.scrollY,
    navTop: top.top, navHeight: top.height, navWidth: top.width,
    navTopScrolled: scrolled.top, scrollY: window.scrollY,
    position: getComputedStyle(nav).position,
    missing: hrefs.filter((id) => !document.getElementById(id)), links: hrefs.length,
  }));
});
</script></body>"""


@pytest.fixture(scope="module")
def probe(report, tmp_path_factory) -> dict:
    tmp = tmp_path_factory.mktemp("probe")
    page = tmp / "probe.html"
    page.write_text(report.read_text(encoding="utf-8").replace("</body>", _PROBE), encoding="utf-8")
    proc = _run(tmp, "--window-size=1280,900", "--dump-dom", page.as_uri())
    assert proc.returncode == 0, proc.stderr[-2000:]
    found = re.search(r'data-probe="([^"]*)"', proc.stdout)
    assert found, "the probe script did not run"
    return json.loads(html.unescape(found.group(1)))


@needs
def test_summary_figure_loads_first(probe, results):
    assert probe["alt"].startswith("summary")  # the first image of the page
    assert probe["naturalWidth"] > 300 and probe["naturalHeight"] > 200  # decoded
    assert probe["shownWidth"] > 600  # and drawn large, not a thumbnail
    assert probe["imgTop"] < 400  # right under the title and intro: no scrolling to reach it
    assert results["summary_figure"] == "figures/summary.png"


@needs
def test_nav_bar_is_visible_and_sticky(probe):
    assert probe["position"] == "sticky"
    assert probe["navHeight"] > 10 and probe["navWidth"] > 600 and probe["navTop"] < 60
    assert probe["scrollY"] > 1000 and abs(probe["navTopScrolled"]) < 1  # still at the top
    assert probe["links"] >= 8 and probe["missing"] == []


@needs
def test_screenshot_of_the_top_shows_figure_and_nav(report, tmp_path):
    """The top of the page as a reader first sees it (kept for a human to look at), and the
    page scrolled down inside a scrolling body (headless screenshots do not keep a window
    scroll): the bar must still be there."""
    from matplotlib import image

    top = _screenshot(tmp_path, report.as_uri(), "report_summary_top.png", 1000)
    rgb = (image.imread(top)[..., :3] * 255).astype(int)
    assert len(np.unique(rgb.reshape(-1, 3)[::5], axis=0)) > 200  # the colour grid is drawn
    scrolled = tmp_path / "scrolled.html"
    scrolled.write_text(
        report.read_text(encoding="utf-8").replace(
            "</body>",
            "<style>html{height:100%;overflow:hidden}body{height:100%;overflow:auto;"
            "box-sizing:border-box;padding-top:0}</style><script>window.addEventListener("
            '"load", () => { document.body.scrollTop = 5000; });</script></body>',
        ),
        encoding="utf-8",
    )
    shot = _screenshot(tmp_path, scrolled.as_uri(), "report_scrolled_nav.png", 500)
    band = image.imread(shot)[:40, :, :3]
    ink = np.any(band < 0.6, axis=-1)
    blue = (band[..., 2] > 0.6) & (band[..., 0] < 0.3)  # link colour #0b57d0
    assert ink.mean() > 0.01 and blue.sum() > 200  # the bar's links, at the top of the window
