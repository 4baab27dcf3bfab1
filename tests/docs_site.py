"""The reference site (``docs/``), built once per test process for tests/test_docs.py and
tests/test_docs_browser.py (tests/conftest.py puts both files in one xdist group).

The build is the README's command with three differences: it goes to a temporary folder;
the notebooks are rendered as stored (``nb_execution_mode=off``: stripped of outputs)
because tests/test_notebooks.py executes each of them on its own; and it reads and writes
in one process (``-j 1``): the suite's workers already use every core, and ``-j auto``'s
processes only add their cost (forking, pickling each page back: 37.6 CPU-s against 30.6,
two builds of each alone on the 2-core machine, 2026-11-28; 27 s of wall time against
31 s when the cores are free).  Everything else is as a reader's build: warnings are
errors, the guide's examples run, the API pages are written from the packages'
``__all__``.  It runs as a subprocess: a fresh interpreter as on the command line.
"""

from __future__ import annotations

import contextlib
import io
import os
import subprocess
import sys
import time
from dataclasses import dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
DOCS = ROOT / "docs"
#: s: a build that takes longer has hung (a full one takes ~1 min on two idle cores)
BUILD_TIMEOUT = 900


@dataclass(frozen=True)
class Site:
    """A finished build: the HTML folder, the command's output, its exit code and time."""

    html: Path
    log: str
    returncode: int
    seconds: float


def sphinx(source: Path, out: Path, *options: str, timeout: float = BUILD_TIMEOUT):
    """Run ``python -m sphinx -W --keep-going -b html`` on ``source`` into ``out/html``."""
    command = [
        sys.executable,
        "-m",
        "sphinx",
        "-W",
        "--keep-going",
        "-b",
        "html",
        *options,
        str(source),
        str(out / "html"),
        "-d",
        str(out / "doctrees"),
    ]
    env = dict(os.environ, MPLBACKEND="Agg")
    start = time.perf_counter()
    run = subprocess.run(
        command, cwd=ROOT, capture_output=True, text=True, timeout=timeout, env=env
    )
    return Site(out / "html", run.stdout + run.stderr, run.returncode, time.perf_counter() - start)


def sphinx_in_process(source: Path, out: Path, *options: str) -> Site:
    """:func:`sphinx`'s command run in this process, its output captured.

    For the small projects of tests/test_docs.py: what they prove is the extensions' own
    code (docs/_ext), which needs no fresh interpreter, and a subprocess starts one and
    imports Sphinx, kapitza and numba again (4.2-4.7 CPU-s against 1.7 for the same build
    here, 2026-11-29).  ``build_main`` is what ``python -m sphinx`` runs;
    it keeps docutils' registries to the build (``docutils_namespace``), and this process's
    ``sys.path``, which a project's conf.py extends, is restored afterwards.
    """
    from sphinx.cmd.build import build_main

    argv = ["-W", "--keep-going", "-b", "html", *options, str(source), str(out / "html")]
    argv += ["-d", str(out / "doctrees")]
    path = list(sys.path)
    log = io.StringIO()
    start = time.perf_counter()
    try:
        with contextlib.redirect_stdout(log), contextlib.redirect_stderr(log):
            returncode = build_main(argv)
    finally:
        sys.path[:] = path
    return Site(out / "html", log.getvalue(), returncode, time.perf_counter() - start)


_BUILT: dict[str, Site] = {}


def built_site(tmp_path_factory) -> Site:
    """The quick build of ``docs/``, made on first use in this process."""
    if "site" not in _BUILT:
        out = tmp_path_factory.mktemp("docs-site")
        _BUILT["site"] = sphinx(DOCS, out, "-j", "1", "-D", "nb_execution_mode=off")
    return _BUILT["site"]
