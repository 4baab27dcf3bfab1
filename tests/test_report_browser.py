"""The report page in a real browser (issue 14, point 3), for every shipped scene (issue 22.10).

Headless Chromium opens the quick report's ``index.html`` the way a reader does and checks what
a reader would see: every ``<img>`` decoded (``complete`` and ``naturalWidth > 0``: a missing
or undecodable file is also "complete", with width 0, and logs nothing when it exists; a
truncated PNG whose first rows decode is drawn in part and passes), the GIF among them, every
local link (the data files) resolving to a file inside the report folder, no console message
at warning level or above (a failed resource load is one: Chromium logs it as a SEVERE network
entry), nothing loaded from outside the folder, no horizontal scrolling at 1280 px; then a
full-page screenshot, checked to be a real picture (``KAPITZA_SCREENSHOT_DIR`` set: a copy is
kept there). Negative tests on hand-made pages prove that each check catches what it is for.

Every shipped scene (``kapitza.scenes.example_scenes()``) gets its quick report built once per
process (tests/report_builds.py, shared with tests/test_report.py) and opened: images,
console, a page no wider than the window, no "nan"/"inf" or Python warning class where a
number should stand; the build itself lets no warning reach the terminal and cuts no
figure's title (each figure's drawn extent within it).

Browser and driver: Debian's ``chromium`` and ``chromium-driver`` (the same source version, so
they always match; ``.ci/run`` installs both when missing), driven by Selenium with the driver's
path given, so Selenium Manager never tries to download one (the machine is offline).  The test
is skipped only when no Chromium binary is on PATH (``.ci/run`` could not install it); when the
browser is there the test runs, and a missing driver is a failure that says what to install.

The page is opened as ``file://``, not served over HTTP: the report is a folder a reader opens
from disk (no JavaScript, no server), so a path that works only under a server (root-absolute
``/data/x.csv``) fails here as it would for the reader, and there is no port, server thread or
favicon request to get wrong.
"""
import base64
import dataclasses
import os
import re
import shutil
from pathlib import Path
from urllib.parse import urlsplit
from urllib.request import url2pathname

import numpy as np
import pytest
from report_builds import quick_report

#: Debian's names first; any Chromium-based browser with a matching chromedriver works
BROWSERS = ("chromium", "chromium-browser", "google-chrome", "google-chrome-stable")
#: window size of every page load (CSS px; the screenshot's width)
WIDTH, HEIGHT = 1280, 900
#: the flags that run headless as root and offline: no sandbox (root), no GPU, no background
#: network (updates, sync, QUIC), a fresh profile per run (added in the fixture)
FLAGS = ("--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
         "--disable-background-networking", "--disable-component-update", "--disable-sync",
         "--disable-dev-shm-usage", f"--window-size={WIDTH},{HEIGHT}")
#: console levels that fail the page (Chromium's log levels: ALL < DEBUG < INFO < WARNING < SEVERE)
BAD_LEVELS = ("WARNING", "SEVERE")
#: s: a page's images get this long to finish loading
LOAD_TIMEOUT = 30


def _which(names):
    return next((p for p in map(shutil.which, names) if p), None)


@dataclasses.dataclass(frozen=True)
class Page:
    """What the browser saw of one page (URLs are the browser's resolved ``file://`` URLs)."""
    url: str
    images: list        # one dict per <img>: src, complete, naturalWidth/Height, width/height, alt
    links: list         # href of every <a href>, resolved
    missing_anchors: list   # '#id' links whose id is not in the page
    resources: list     # what the page loads: [src] and <link href>, and every network load
                        # (Resource Timing lists no file:// loads, so both are needed)
    log: list           # the browser's console log: dicts with level, source, message
    scroll_width: int   # CSS px of the document
    scroll_height: int
    client_width: int   # CSS px of the viewport (the window less its frame)
    client_height: int
    overflowing: list   # the outermost elements reaching past the viewport's right edge
    body_scroll_width: int  # CSS px of the body's content (a wide table that does not
                            # scroll inside its wrapper widens it)
    text: str           # what a reader reads (innerText of the body)
    cells: list         # the text of every table cell
    screenshot: Path | None     # None: none was asked for


_SNAPSHOT_JS = """
const img = Array.from(document.images).map(i => ({
    src: i.currentSrc || i.src, complete: i.complete, naturalWidth: i.naturalWidth,
    naturalHeight: i.naturalHeight, width: i.getBoundingClientRect().width,
    height: i.getBoundingClientRect().height, alt: i.alt}));
const over = e => e.getBoundingClientRect().right > document.documentElement.clientWidth + 0.5;
const anchors = Array.from(document.querySelectorAll('a[href]'));
return {
    images: img,
    links: anchors.map(a => a.href),
    missing_anchors: anchors.map(a => a.getAttribute('href'))
        .filter(h => h.startsWith('#') && h.length > 1
                && !document.getElementById(decodeURIComponent(h.slice(1)))),
    resources: Array.from(document.querySelectorAll('[src], link[href]'))
        .map(e => e.src || e.href)
        .concat(performance.getEntriesByType('resource').map(e => e.name)),
    scroll_width: document.documentElement.scrollWidth,
    scroll_height: document.documentElement.scrollHeight,
    client_width: document.documentElement.clientWidth,
    client_height: document.documentElement.clientHeight,
    overflowing: Array.from(document.body.querySelectorAll('*'))
        .filter(e => over(e) && !(e.parentElement && over(e.parentElement)))
        .map(e => e.tagName.toLowerCase() + ' ' + Math.round(e.getBoundingClientRect().width)
             + ' px wide: ' + (e.getAttribute('src') || e.textContent).trim().slice(0, 80)),
    body_scroll_width: document.body.scrollWidth,
    text: document.body.innerText,
    cells: Array.from(document.querySelectorAll('td')).map(c => c.innerText.trim())};
"""


def open_page(driver, path, screenshot=None):
    """Open ``path`` (a local HTML file) in ``driver``, wait for its images, record what loaded
    and write a full-page PNG screenshot to ``screenshot`` (None: none taken; a full-page
    capture of a report costs Chromium ~0.5 CPU-s, spent only where a test reads it)."""
    from selenium.webdriver.support.ui import WebDriverWait

    driver.get_log("browser")           # drop what earlier pages left in the log
    driver.get(Path(path).resolve().as_uri())
    # a reader scrolls: bring every image into view (lazy images load only then), then wait
    driver.execute_script("for (const i of document.images) i.scrollIntoView();"
                          "window.scrollTo(0, 0);")
    WebDriverWait(driver, LOAD_TIMEOUT).until(lambda d: d.execute_script(
        "return document.readyState === 'complete'"
        " && Array.from(document.images).every(i => i.complete)"))
    snap = driver.execute_script(_SNAPSHOT_JS)
    if screenshot is not None:
        # the whole page, not the viewport: CDP captures beyond the viewport at the page's size
        shot = driver.execute_cdp_cmd("Page.captureScreenshot", {
            "format": "png", "captureBeyondViewport": True,
            "clip": {"x": 0, "y": 0, "width": snap["scroll_width"],
                     "height": snap["scroll_height"], "scale": 1}})
        screenshot = Path(screenshot)
        screenshot.write_bytes(base64.b64decode(shot["data"]))
    return Page(url=driver.current_url, log=driver.get_log("browser"), screenshot=screenshot,
                **snap)


def broken_images(page):
    """The <img> of ``page`` that did not decode (missing, corrupt, or never finished)."""
    return [f"{i['src']}: complete={i['complete']}, naturalWidth={i['naturalWidth']}"
            for i in page.images if not (i["complete"] and i["naturalWidth"] > 0)]


def console_problems(page):
    """Console entries at warning level or above (failed loads, errors, warnings)."""
    return [f"{e['level']} {e.get('source', '')}: {e['message']}"
            for e in page.log if e["level"] in BAD_LEVELS]


def _local_path(url):
    parts = urlsplit(url)
    return Path(url2pathname(parts.path)) if parts.scheme == "file" else None


def unresolved_links(page, root):
    """Links of ``page`` that a reader of the folder ``root`` could not follow: a local target
    that does not exist or lies outside ``root`` (breaks when the folder is moved), a '#id'
    without its id.  Links to other sites (http, mailto) are not followed."""
    root = Path(root).resolve()
    bad = [f"{href}: no element with this id" for href in page.missing_anchors]
    for href in page.links:
        path = _local_path(href)
        if path is None:
            continue
        if not path.exists():
            bad.append(f"{href}: no such file")
        elif root != path.resolve() and root not in path.resolve().parents:
            bad.append(f"{href}: outside the report folder {root}")
    return bad


def outside_resources(page, root):
    """What the page loaded from outside the folder ``root`` (the report must be
    self-contained: the reader may be offline); data: URIs are inside the page itself."""
    root = Path(root).resolve()
    return sorted({u for u in page.resources if urlsplit(u).scheme != "data"
                   and ((p := _local_path(u)) is None or root not in p.resolve().parents)})


def layout_problems(page):
    """Why a reader of ``page`` has to scroll sideways in a WIDTH px window (empty: no need)."""
    if page.scroll_width <= page.client_width:
        return []
    return [f"{page.scroll_width} px wide for a {page.client_width} px viewport, because of: "
            + "; ".join(page.overflowing)]


def screenshot_problems(page):
    """Why ``page.screenshot`` is not a real picture of the page (empty list: it is): the PNG
    must decode, be the document's size (the full page, not just the viewport), at least the
    viewport's, and show more than a few colours."""
    from PIL import Image

    with Image.open(page.screenshot) as im:
        pixels = np.asarray(im.convert("RGB"))
    h, w, _ = pixels.shape
    bad = []
    if w != page.scroll_width or h != page.scroll_height:
        bad.append(f"{w}x{h} px, the document is {page.scroll_width}x{page.scroll_height}")
    if w < page.client_width or h < page.client_height:
        bad.append(f"{w}x{h} px, smaller than the viewport "
                   f"{page.client_width}x{page.client_height}")
    rgb = pixels.reshape(-1, 3).astype(np.uint32)    # one integer per colour: a fast unique
    colours = np.unique(rgb[:, 0] << 16 | rgb[:, 1] << 8 | rgb[:, 2])
    if len(colours) < 16:
        bad.append(f"{len(colours)} colour(s): a blank page")
    return bad


@pytest.fixture(scope="module")
def browser(tmp_path_factory):
    """One headless Chromium (fresh profile) for the module, console captured at every level."""
    binary = _which(BROWSERS)
    if binary is None:
        pytest.skip(f"no Chromium on PATH (looked for {', '.join(BROWSERS)}): .ci/run installs "
                    "Debian's chromium and chromium-driver where it can; by hand: "
                    "apt-get install chromium chromium-driver")
    driver_path = shutil.which("chromedriver")
    if driver_path is None:
        pytest.fail(f"Chromium is installed ({binary}) but chromedriver is not on PATH: "
                    "apt-get install chromium-driver (Debian's driver matches its chromium)")
    try:
        from selenium import webdriver
        from selenium.webdriver.chrome.service import Service
    except ImportError:
        pytest.fail(f"Chromium is installed ({binary}) but selenium is not: "
                    'python -m pip install -e ".[test]"')

    options = webdriver.ChromeOptions()
    options.binary_location = binary
    for flag in FLAGS:
        options.add_argument(flag)
    options.add_argument(f"--user-data-dir={tmp_path_factory.mktemp('chromium-profile')}")
    options.set_capability("goog:loggingPrefs", {"browser": "ALL"})
    driver = webdriver.Chrome(service=Service(driver_path), options=options)
    driver.set_page_load_timeout(LOAD_TIMEOUT)
    yield driver
    driver.quit()


# --- the report of every shipped scene -------------------------------------------------------

#: Every shipped scene (kapitza.scenes.example_scenes()), the default "report" among them.
SCENES = ("report", "double_pendulum", "elliptic_damped", "horizontal_drive", "kapitza_pendulum",
          "kapitza_pendulum_map", "period_doubling")


@pytest.fixture(scope="module")
def scene_report(tmp_path_factory):
    """``scene_report(name)``: the scene's quick report, built once per process, on the first
    test that asks for it (tests/report_builds.py: shared with tests/test_report.py)."""
    return lambda name: quick_report(name, tmp_path_factory)


# --- the default report ----------------------------------------------------------------------

@pytest.fixture(scope="module")
def report(browser, scene_report):
    """The default scene's quick report (after the browser: no build where the test is
    skipped)."""
    return scene_report("report").report


@pytest.fixture(scope="module")
def report_dir(report):
    return Path(report.out)


@pytest.fixture(scope="module")
def report_page(browser, report_dir, tmp_path_factory):
    page = open_page(browser, report_dir / "index.html",
                     tmp_path_factory.mktemp("screenshot") / "report-quick.png")
    keep = os.environ.get("KAPITZA_SCREENSHOT_DIR")
    if keep:
        Path(keep).mkdir(parents=True, exist_ok=True)
        shutil.copy2(page.screenshot, Path(keep) / page.screenshot.name)
    return page


def test_every_image_loads(report, report_page, report_dir):
    assert report.failed == ()      # a failed section has no figure on the page
    assert broken_images(report_page) == []
    shown = {_local_path(i["src"]).resolve() for i in report_page.images}
    # every section's figure, and every image file in the folder, is on the page, the GIF too
    figures = {Path(p).resolve() for p in report.figures.values()}
    written = {p.resolve() for ext in ("*.png", "*.gif") for p in report_dir.rglob(ext)}
    assert figures - shown == set(), "section figures not shown on the page"
    assert written - shown == set(), "image files written but not shown on the page"
    # the default scene has a figure in every section it runs (7; the bifurcation section
    # runs only when a scene asks for it, and says so): none may be missing from the page
    ran = {sec.name for sec in report.sections if sec.status != "skipped"}
    assert set(report.figures) == ran and "bifurcations" not in ran
    assert len(report.figures) >= 7 and report.figures["animation"].suffix == ".gif"
    # each is drawn at a visible size and fits the window
    for i in report_page.images:
        assert 0 < i["width"] <= report_page.client_width and i["height"] > 0, i


def test_every_link_resolves_and_every_data_file_is_linked(report, report_page, report_dir):
    assert unresolved_links(report_page, report_dir) == []
    linked = {p.resolve() for p in map(_local_path, report_page.links) if p is not None}
    # every table in both formats, and every file of the data folder
    tables = {Path(p).resolve() for pair in report.tables.values() for p in pair}
    data = {p.resolve() for p in (report_dir / "data").rglob("*") if p.is_file()}
    assert tables and {p.suffix for p in tables} == {".parquet", ".csv"}
    assert (tables | data) - linked == set(), "data files the page does not link"


def test_console_clean_and_nothing_loaded_from_outside(report_page, report_dir):
    assert console_problems(report_page) == []
    assert outside_resources(report_page, report_dir) == []


def test_layout_fits_the_window(report_page):
    assert layout_problems(report_page) == []


def test_full_page_screenshot(report_page):
    assert screenshot_problems(report_page) == []
    # the report is longer than one screen, so the capture beyond the viewport is exercised
    assert report_page.scroll_height > report_page.client_height


# --- every shipped scene: built cleanly, and read in the browser -------------------------------

def test_every_shipped_scene_is_listed():
    from kapitza.scenes import example_scenes
    assert set(SCENES) == set(example_scenes())


#: Words that stand where a number should ("nan", "inf", a Python warning's class).
_NOT_A_NUMBER = re.compile(r"\b(nan|NaN|inf|-inf|Infinity|RuntimeWarning)\b")


@pytest.mark.parametrize("name", SCENES)
def test_scene_report_builds_cleanly(scene_report, name):
    """No section fails; no warning reaches the terminal (each section's warnings are notes
    on the page), nothing but the cold-cache compile notice is written on stderr (and the
    progress lines, for the scene built by the command: report_builds.VIA_CLI); no numpy
    floating-point warning (an overflow, an invalid value) among the notes — those are
    handled where they arise; every figure's drawn extent (titles, legends) lies within the
    figure: nothing cut."""
    built = scene_report(name)
    report = built.report
    assert report.failed == (), [(s.name, s.reason) for s in report.sections]
    assert [f"{w.category.__name__}: {w.message}" for w in built.escaped] == []
    # stderr: at most lagrange_core's one-line notice that it compiles on a cold cache
    assert [line for line in built.stderr.splitlines()
            if not line.startswith("lagrange_core: compiling")] == []
    notes = [n for s in report.sections for n in s.notes]
    assert not [n for n in notes if "encountered in" in n], notes
    for fname, tight, frame in built.figures:
        assert (tight.x0 >= frame.x0 - 0.01 and tight.y0 >= frame.y0 - 0.01
                and tight.x1 <= frame.x1 + 0.01 and tight.y1 <= frame.y1 + 0.01), \
            f"{fname}: drawn over {tight}, the figure is {frame}"
    assert len(built.figures) == sum(s.figure is not None and s.figure.suffix == ".png"
                                     for s in report.sections)


@pytest.mark.parametrize("name", SCENES)
def test_scene_page_in_the_browser(browser, scene_report, name, request):
    """The page of each scene as a reader sees it: every image loads, the console is clean,
    no table makes the page wider than the window (they scroll in their wrappers), and no
    "nan", "inf" or Python warning class stands where a number should.  No screenshot is
    checked here (test_full_page_screenshot checks the capture on the default page): one is
    taken only to be kept, where ``KAPITZA_SCREENSHOT_DIR`` is set.  The default scene's
    page is the one the tests above opened (``report_page``), read again."""
    report = scene_report(name).report
    keep = os.environ.get("KAPITZA_SCREENSHOT_DIR")
    if name == "report":
        page = request.getfixturevalue("report_page")
        assert _local_path(page.url).resolve() == report.index.resolve()
    else:
        if keep:
            Path(keep).mkdir(parents=True, exist_ok=True)
        page = open_page(browser, report.index,
                         Path(keep) / f"scene-{name}-quick.png" if keep else None)
    assert broken_images(page) == []
    assert console_problems(page) == []
    assert layout_problems(page) == []
    assert page.body_scroll_width <= page.client_width, page.overflowing
    assert unresolved_links(page, report.out) == []
    assert not _NOT_A_NUMBER.findall(page.text), [
        line for line in page.text.splitlines() if _NOT_A_NUMBER.search(line)]
    assert not [c for c in page.cells if c in ("∞", "−∞", "nan", "inf")]
    assert len(page.images) == len(report.figures)


def test_double_pendulum_scene_says_why_sections_are_skipped(scene_report):
    """(Was in test_report.py: the same quick build, shared.)"""
    import html

    import pandas as pd

    import kapitza
    report = scene_report("double_pendulum").report
    status = {s.name: s.status for s in report.sections}
    assert status == {"potential": "skipped", "map": "done", "spots": "done", "slow": "done",
                      "verification": "done", "bifurcations": "skipped",
                      "work_precision": "done", "animation": "done"}
    # the chain's own animation: held up at the scene's drive, as Floquet says (independently)
    sc = kapitza.Scene.example("double_pendulum")
    assert kapitza.floquet_point(sc.system, sc.params, [np.pi, np.pi]).stable
    anim = report.section("animation")
    assert anim.figure.suffix == ".gif" and "stays within π/2" in anim.caption
    assert "calls the upright state stable" in anim.caption
    page = report.index.read_text(encoding="utf-8")
    for s in report.sections:
        if s.status == "skipped":
            assert len(s.reason) > 30 and html.escape(s.reason) in page
    # the slow frequencies of both modes: simulation against Floquet
    slow = pd.read_parquet(report.tables["slow_frequency"][0])
    for k in (0, 1):
        assert np.allclose(slow[f"omega_slow_simulation_{k}"], slow[f"omega_slow_floquet_{k}"],
                           rtol=2e-3)


# --- the checks catch what they are for (hand-made pages) -------------------------------------

@pytest.fixture(scope="module")
def handmade(browser, tmp_path_factory):
    """A folder of small pages: one good (PNG, GIF, a data link), and one per failure."""
    from PIL import Image, ImageDraw

    root = tmp_path_factory.mktemp("handmade")
    png = Image.new("RGB", (320, 200), "white")
    draw = ImageDraw.Draw(png)
    for k in range(0, 320, 20):     # enough colours for a non-blank screenshot
        draw.rectangle((k, 40, k + 19, 160), fill=(k * 255 // 320, 80, 255 - k * 255 // 320))
    png.save(root / "good.png")
    frames = [Image.new("RGB", (60, 40), c) for c in ("red", "blue")]
    frames[0].save(root / "anim.gif", save_all=True, append_images=frames[1:], duration=200,
                   loop=0)
    # a PNG's signature and header (so it has a size) followed by zeros: it cannot be decoded
    (root / "corrupt.png").write_bytes((root / "good.png").read_bytes()[:33] + bytes(500))
    (root / "data.csv").write_text("A,omega\n0.05,377\n")
    head = '<!doctype html><html><head><meta charset="utf-8"><title>t</title></head><body>'
    pages = {
        "good": '<h1>Report</h1><img src="good.png" alt="map"><img src="anim.gif" alt="gif">'
                '<a href="data.csv">data</a> <a href="#top">top</a><p id="top">text</p>',
        "missing_image": '<img src="good.png" alt="map"><img src="missing.png" alt="gone">',
        "corrupt_image": '<img src="good.png" alt="map"><img src="corrupt.png" alt="bad">',
        "console_error": "<img src=\"good.png\" alt=\"map\"><script>console.error('x')</script>",
        "console_warning": "<img src=\"good.png\" alt=\"map\"><script>console.warn('w')</script>",
        "broken_links": '<img src="good.png" alt="map"><a href="data/missing.csv">gone</a>'
                        '<a href="/data.csv">root-absolute</a><a href="#nowhere">anchor</a>'
                        '<a href="../outside.csv">outside</a>',
        "wide_table": '<p>text</p><table><tr>' + "<td>a_long_column_name</td>" * 80
                      + "</tr></table>",
        "outside": '<link rel="stylesheet" href="http://127.0.0.1:9/s.css">'   # port 9: Chromium
                   '<img src="good.png" alt="map"><img src="../outside.png" alt="out">',  # no call
        "blank": "",
    }
    (root.parent / "outside.csv").write_text("x\n1\n")
    shutil.copy(root / "good.png", root.parent / "outside.png")
    for name, body in pages.items():
        (root / f"{name}.html").write_text(head + body + "</body></html>")
    return root


def _open(browser, root, name, screenshot=False):
    """Open the hand-made page ``name``; its screenshot taken where the test checks it."""
    shots = root / "screenshots"        # not beside the pages: good.png is one of their images
    shots.mkdir(exist_ok=True)
    return open_page(browser, root / f"{name}.html",
                     shots / f"{name}.png" if screenshot else None)


def test_the_checks_pass_a_good_page(browser, handmade):
    page = _open(browser, handmade, "good", screenshot=True)
    assert len(page.images) == 2 and broken_images(page) == []
    assert console_problems(page) == [] and unresolved_links(page, handmade) == []
    assert outside_resources(page, handmade) == [] and layout_problems(page) == []
    assert screenshot_problems(page) == []


def test_a_missing_image_is_caught_by_the_image_and_the_console_check(browser, handmade):
    page = _open(browser, handmade, "missing_image")
    bad = broken_images(page)
    assert len(bad) == 1 and "missing.png" in bad[0] and "naturalWidth=0" in bad[0]
    # the failed load is a SEVERE network entry in the console
    problems = console_problems(page)
    assert len(problems) == 1 and "missing.png" in problems[0] and "SEVERE" in problems[0]


def test_a_corrupt_image_is_caught(browser, handmade):
    # the file exists (a link check passes it) and Chromium logs nothing: only the image
    # check sees that it does not decode
    page = _open(browser, handmade, "corrupt_image")
    bad = broken_images(page)
    assert len(bad) == 1 and "corrupt.png" in bad[0] and "naturalWidth=0" in bad[0]
    assert console_problems(page) == []


@pytest.mark.parametrize("name, level, text", [("console_error", "SEVERE", '"x"'),
                                                ("console_warning", "WARNING", '"w"')])
def test_console_messages_are_caught(browser, handmade, name, level, text):
    page = _open(browser, handmade, name)
    assert broken_images(page) == []
    problems = console_problems(page)
    assert len(problems) == 1 and problems[0].startswith(level) and text in problems[0]


def test_broken_links_are_caught(browser, handmade):
    page = _open(browser, handmade, "broken_links")
    bad = unresolved_links(page, handmade)
    assert len(bad) == 4, bad
    assert any("data/missing.csv: no such file" in b for b in bad)
    assert any(b.startswith("file:///data.csv") for b in bad)      # root-absolute: not found
    assert any("#nowhere: no element" in b for b in bad)
    assert any("outside.csv: outside the report folder" in b for b in bad)


def test_a_page_wider_than_the_window_is_caught(browser, handmade):
    page = _open(browser, handmade, "wide_table")
    bad = layout_problems(page)
    assert len(bad) == 1 and "because of: table" in bad[0], bad


def test_loads_from_outside_the_folder_are_caught(browser, handmade):
    # a stylesheet from a server (Chromium refuses port 9 without connecting) and an image
    # from the folder's parent: both load for the author, neither for the reader of a copy
    page = _open(browser, handmade, "outside")
    assert outside_resources(page, handmade) == sorted(
        ["http://127.0.0.1:9/s.css", (handmade.parent / "outside.png").as_uri()])
    assert broken_images(page) == []


def test_a_blank_screenshot_is_caught(browser, handmade):
    page = _open(browser, handmade, "blank", screenshot=True)
    bad = screenshot_problems(page)
    assert any("a blank page" in b for b in bad), bad
