"""The guide's examples run when the site builds: a wrong example fails the build.

Two kinds of block are run, in page order, when a page is read:

- ```` ```pycon ```` blocks (``>>>`` prompts, doctest style): run by :mod:`doctest` with one
  namespace per page, so a later block uses what an earlier one made; what each line prints
  must equal the lines below it, exactly as in a doctest.
- ```` ```console ```` blocks: each ``$ kapitza …`` line runs :func:`kapitza.cli.main` in this
  process; it must exit 0 and print on stdout the lines below it (trailing blanks aside;
  messages and progress go to stderr and are not compared).  Other ``$`` lines are shown
  only.

A failure is a Sphinx warning at the block's line, with the doctest's report; the build runs
with ``-W`` so the warning fails it.  The old spellings of the API (a ``DeprecationWarning``
naming kapitza) are errors inside examples, as they are in the test suite.  API pages are
not run here: their docstring examples are doctests of the test suite
(``--doctest-modules``).
"""

from __future__ import annotations

import contextlib
import doctest
import io
import shlex
import time
import warnings

from docutils import nodes
from sphinx.util import logging

logger = logging.getLogger(__name__)

#: documents whose blocks are not run (generated API pages: their examples are doctests)
SKIP_PREFIXES = ("api/",)


def _run_pycon(block: str, globs: dict, name: str, lineno: int) -> str | None:
    """Run one doctest block; its failure report, or None when it passed."""
    test = doctest.DocTestParser().get_doctest(block, globs, name, name, lineno)
    report = io.StringIO()
    runner = doctest.DocTestRunner(optionflags=0)
    with warnings.catch_warnings():
        warnings.filterwarnings(
            "error", message=".*is deprecated since kapitza", category=DeprecationWarning
        )
        runner.run(test, out=report.write, clear_globs=False)
    globs.update(test.globs)  # the next block of the page sees these names
    return report.getvalue() if runner.failures else None


def _console_examples(block: str):
    command, expected = None, []
    for line in block.splitlines():
        if line.startswith("$ "):
            if command is not None:
                yield command, "\n".join(expected)
            command, expected = line[2:], []
        elif command is not None:
            expected.append(line.rstrip())
    if command is not None:
        yield command, "\n".join(expected)


def _run_console(block: str) -> str | None:
    """Run the ``$ kapitza`` lines of one console block; the first mismatch, or None."""
    from kapitza import cli

    for command, expected in _console_examples(block):
        argv = shlex.split(command)
        if not argv or argv[0] != "kapitza":
            continue
        out, err = io.StringIO(), io.StringIO()
        with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
            code = cli.main(argv[1:])
        printed = "\n".join(line.rstrip() for line in out.getvalue().strip("\n").splitlines())
        if code != 0:
            return f"$ {command}\nexited {code}; stderr:\n{err.getvalue()}"
        if printed != expected.strip("\n"):
            return f"$ {command}\nexpected:\n{expected.strip()}\ngot:\n{printed}"
    return None


def run_examples(app, doctree) -> None:
    docname = app.env.docname
    if docname.startswith(SKIP_PREFIXES):
        return
    globs: dict = {"__name__": docname}
    start = time.perf_counter()
    count = 0
    for block in doctree.findall(nodes.literal_block):
        language = block.get("language", "")
        text = block.astext()
        if language == "pycon" or (
            language in ("python", "default") and text.lstrip().startswith(">>>")
        ):
            problem = _run_pycon(text, globs, docname, block.line or 0)
        elif language == "console" and "$ kapitza" in text:
            problem = _run_console(text)
        else:
            continue
        count += 1
        if problem:
            logger.warning(
                "example does not give what the page says:\n%s",
                problem,
                location=block,
                type="kapitza",
                subtype="example",
            )
    if count:
        logger.info(
            "%s: %d example block(s) run in %.1f s", docname, count, time.perf_counter() - start
        )


def setup(app):
    app.connect("doctree-read", run_examples)
    return {"parallel_read_safe": True, "parallel_write_safe": True}
