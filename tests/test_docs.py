"""The reference site (issue 23.1): ``docs/`` builds with warnings as errors, and it shows
what it promises.

One quick build serves every test here and the browser test (tests/docs_site.py: the
README's command into a temporary folder, notebooks rendered as stored because
tests/test_notebooks.py executes them).  Checked on the built HTML, against the packages
themselves rather than the generator's own lists: every name of every ``__all__`` (both
packages, lagrange_core's public modules, each room of kapitza) has a row on its module's
page whose link reaches an anchor that exists; an API page shows the signature and the
parameters with their units; the guide's examples ran during the build; the CLI page has
every command the parser has; the studies page has every study's figure.  Small projects
prove that the build's checks catch what they are for: a wrong example, a reference to a
name that is not documented, a formula with bars.
"""

from __future__ import annotations

import importlib
import pkgutil
import re
import sys
import warnings
from html.parser import HTMLParser
from pathlib import Path

import pytest
from docs_site import DOCS, built_site, sphinx_in_process

sys.path.insert(0, str(DOCS / "_ext"))
from absolute_values import escape_docstring  # noqa: E402  (docs/_ext is no package)

#: the first test here builds the site (tests/docs_site.py): with cold numba caches (a fresh
#: clone) the guide's examples compile their kernels, minutes on a busy machine
#: one worker builds it for this file and tests/test_docs_browser.py (tests/conftest.py's
#: groups are added after xdist has read the marks, so the group is marked here)
pytestmark = [pytest.mark.timeout(1200), pytest.mark.xdist_group("docs-site")]


@pytest.fixture(scope="session")
def site(tmp_path_factory):
    return built_site(tmp_path_factory)


@pytest.fixture(scope="session")
def html(site):
    assert site.returncode == 0, "the site does not build:\n" + site.log[-6000:]
    return site.html


class _Links(HTMLParser):
    """(href, text) of every <a> in table cells, and every id in the page."""

    def __init__(self):
        super().__init__()
        self.rows, self.ids, self._href, self._text, self._cells = [], set(), None, [], 0

    def handle_starttag(self, tag, attrs):
        attrs = dict(attrs)
        if "id" in attrs:
            self.ids.add(attrs["id"])
        if tag == "td":
            self._cells += 1
        elif tag == "a" and self._cells:
            self._href, self._text = attrs.get("href"), []

    def handle_endtag(self, tag):
        if tag == "td":
            self._cells -= 1
        elif tag == "a" and self._href is not None:
            self.rows.append((self._href, "".join(self._text).strip()))
            self._href = None

    def handle_data(self, data):
        if self._href is not None:
            self._text.append(data)


def _parse(path: Path) -> _Links:
    parser = _Links()
    parser.feed(path.read_text())
    return parser


def public_modules():
    """What the site must document, found independently of docs/_ext: each package, the
    modules its ``__all__`` lists, lagrange_core's other public modules with an
    ``__all__`` (a flat package), and kapitza's rooms."""
    found = {}
    for package in ("lagrange_core", "kapitza"):
        module = importlib.import_module(package)
        found[package] = module
        for info in pkgutil.iter_modules(module.__path__):
            if info.name.startswith("_") or (package == "kapitza" and not info.ispkg):
                continue
            sub = importlib.import_module(f"{package}.{info.name}")
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                shadowed = not info.ispkg and getattr(module, info.name) is not sub
            if hasattr(sub, "__all__") and not shadowed:
                found[sub.__name__] = sub
    return found


def test_the_site_builds_with_warnings_as_errors(site):
    assert site.returncode == 0, site.log[-6000:]
    print(f"quick build: {site.seconds:.1f} s")


def test_every_public_name_has_a_row_that_links_to_its_documentation(html):
    modules = public_modules()
    assert {
        "lagrange_core",
        "kapitza",
        "kapitza.floquet",
        "kapitza.results",
        "lagrange_core.problems",
    } <= set(modules)
    missing, dead = [], []
    anchors: dict[Path, set] = {}
    for modname, module in modules.items():
        page = html / "api" / f"{modname}.html"
        if not page.exists():
            missing.append(f"{modname}: no page")
            continue
        rows = {text: href for href, text in _parse(page).rows}
        for name in module.__all__:
            if name not in rows:
                missing.append(f"{modname}.{name}")
                continue
            target, _, anchor = rows[name].partition("#")
            path = (page.parent / target).resolve() if target else page
            if path not in anchors:
                anchors[path] = (
                    set(re.findall(r'\bid="([^"]+)"', path.read_text())) if path.exists() else set()
                )
            if anchor not in anchors[path]:
                dead.append(f"{modname}.{name} -> {rows[name]}")
    assert missing == [], "public names without a row on their module's page"
    assert dead == [], "rows whose link does not reach an anchor"


def test_an_api_page_has_the_signature_parameters_and_units(html):
    page = (html / "api" / "generated" / "kapitza.floquet.window.html").read_text()
    text = re.sub(r"<[^>]+>", "", page)
    # the signature, with the keyword-only grid axis, and the numpydoc sections
    assert "window(system, params, about, *, omega" in text.replace("\n", "")
    for word in ("Parameters", "Returns", "rad/s", "StabilityWindow"):
        assert word in text, word
    # a class: its methods documented on its page
    pendulum = (html / "api" / "generated" / "kapitza.KapitzaPendulum.html").read_text()
    for method in ("floquet", "averaged", "window", "measure", "simulate"):
        assert f'id="kapitza.KapitzaPendulum.{method}"' in pendulum, method


def test_the_guide_examples_ran_during_the_build(site):
    ran = dict(re.findall(r"^(guide/[\w-]+): (\d+) example block\(s\) run", site.log, re.M))
    for page in ("first-steps", "scenes-and-sweeps", "command-line"):
        source = (DOCS / "guide" / f"{page}.md").read_text()
        blocks = len(re.findall(r"^```(pycon|console)$", source, re.M))
        assert blocks and int(ran.get(f"guide/{page}", 0)) == blocks, (page, ran)


def test_the_cli_reference_has_every_command(html):
    from kapitza.cli._parsing import build_parser

    parser = build_parser()
    commands = next(a for a in parser._actions if a.dest == "command").choices
    page = _parse(html / "cli.html")
    for name in commands:
        assert f"cli-kapitza-{name}" in page.ids, name
    text = (html / "cli.html").read_text()
    assert "--omega-over-omega0" in text and "usage: kapitza window" in text


def test_the_studies_page_has_every_study_and_its_figure(html):
    text = (html / "studies" / "index.html").read_text()
    for study in sorted((DOCS.parent / "studies").glob("[a-z]*.py")):
        assert f"{study.stem}.py" in text, study.stem
        assert f"_images/{study.stem}.png" in text, study.stem


def test_every_notebook_is_on_the_site(html):
    for notebook in DOCS.rglob("*.ipynb"):
        if "_build" in notebook.parts or "jupyter_execute" in notebook.parts:
            continue
        relative = notebook.relative_to(DOCS).with_suffix(".html")
        assert (html / relative).exists(), relative


# --- the build's checks catch what they are for (a small project) ---------------------------

BROKEN = """Broken
======

A reference to a name kapitza does not have: :func:`kapitza.no_such_function`; one to a
private helper: :func:`kapitza.floquet._window.window`; one to numpy (no intersphinx:
plain text, not an error): :func:`numpy.linspace`.

.. code-block:: pycon

   >>> 1 + 1
   3

.. code-block:: console

   $ kapitza window --help
   not what it prints
"""


@pytest.fixture(scope="session")
def broken_build(tmp_path_factory):
    src = tmp_path_factory.mktemp("broken-docs")
    (src / "conf.py").write_text(
        "import sys\n"
        f"sys.path.insert(0, {str(DOCS / '_ext')!r})\n"
        "extensions = ['api_pages', 'executed_examples']\n"
        "api_pages = False\n"
    )
    (src / "index.rst").write_text(BROKEN)
    # in this process (the checks are the extensions' code): tests/docs_site.py
    return sphinx_in_process(src, tmp_path_factory.mktemp("broken-out"))


def test_a_wrong_example_fails_the_build(broken_build):
    assert broken_build.returncode != 0
    log = broken_build.log
    assert "example does not give what the page says" in log
    assert "Expected:\n    3\nGot:\n    2" in log
    # the command ran in the build and what it printed was compared: its help, which
    # reaches the comparison as a computation's table does (cli.main, stdout, exit 0) but
    # needs none of the kernels (`kapitza window --f 60` here: 1 CPU-s to load and run them)
    assert "$ kapitza window --help" in log and "not what it prints" in log
    assert "got:\nusage: kapitza window" in log


def test_a_reference_to_nothing_documented_fails_the_build(broken_build):
    log = broken_build.log
    assert "reference to 'kapitza.no_such_function'" in log
    assert "reference to 'kapitza.floquet._window.window'" in log
    assert "numpy.linspace" not in log


def test_absolute_values_in_docstrings_stay_as_written():
    lines = [
        "Every |λ| ≤ 1 + δ and |φ(x) − x|∞ ≤ tol, not ``a|b`` nor :func:`x`.",
        "",
        "Example::",
        "",
        "    a | b",
        "",
        ">>> 1 | 2",
        "| a line block",
    ]
    escape_docstring(lines)
    assert lines[0] == (
        r"Every \|λ\| ≤ 1 + δ and \|φ(x) − x\|∞ ≤ tol, not ``a|b`` nor "
        ":func:`x`."
    )
    assert lines[4:] == ["    a | b", "", ">>> 1 | 2", "| a line block"]


def test_the_docs_extra_is_in_the_test_extra():
    import tomllib

    extras = tomllib.loads((DOCS.parent / "pyproject.toml").read_text())["project"][
        "optional-dependencies"
    ]
    names = {re.split(r"[<>=\[ ]", spec)[0] for spec in extras["docs"]}
    assert {
        "sphinx",
        "numpydoc",
        "pydata-sphinx-theme",
        "myst-nb",
        "nbclient",
        "ipykernel",
    } <= names
    assert any(spec.startswith("kapitza[docs]") for spec in extras["test"])
