"""The reference site in a real browser (issue 23.1).

Headless Chromium opens the quick build's index, an API page, a module's page and the
studies page from disk (``file://``, as a reader of a downloaded build would) and checks
what the reader would see: every image decoded (``naturalWidth > 0``), every local link
reaching a file inside the site (and every ``#id`` its element), no console message at
warning level or above, no sideways scrolling at 1280 px.  The browser, its set-up, the
skip rule (no Chromium on PATH: skipped with the reason; Chromium without chromedriver: a
failure saying what to install) and the checks themselves are those of the report's
browser test (tests/test_report_browser.py), which also proves each check on hand-made
pages; the site is built once for this file and tests/test_docs.py (tests/docs_site.py).
"""

from __future__ import annotations

import pytest
import test_report_browser as report_browser
from docs_site import built_site
from test_report_browser import (
    broken_images,
    console_problems,
    layout_problems,
    open_page,
    unresolved_links,
)

#: one headless Chromium for this file: the report test's fixture (skip rule included)
browser = report_browser.browser

#: the site may be built by the first test here (tests/docs_site.py): minutes when cold
pytestmark = [pytest.mark.timeout(1200), pytest.mark.xdist_group("docs-site")]

#: the pages opened, and how many images each must show at least
PAGES = {
    "index.html": 1,
    "api/generated/kapitza.floquet.window.html": 0,
    "api/kapitza.floquet.html": 0,
    "studies/index.html": 9,
    "guide/report.html": 6,
}


@pytest.fixture(scope="session")
def site_html(tmp_path_factory):
    site = built_site(tmp_path_factory)
    assert site.returncode == 0, "the site does not build:\n" + site.log[-6000:]
    return site.html


@pytest.mark.parametrize("page", list(PAGES))
def test_page_images_links_and_console(browser, site_html, page):
    # no screenshot: nothing here reads one (the report's browser test checks the capture)
    seen = open_page(browser, site_html / page)
    assert len(seen.images) >= PAGES[page]
    assert broken_images(seen) == []
    assert unresolved_links(seen, site_html) == []
    assert console_problems(seen) == []
    assert layout_problems(seen) == []
    # the page links on to the rest of the site (navigation, the API's rows)
    assert sum(link.startswith("file://") for link in seen.links) >= 10
