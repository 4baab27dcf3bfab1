"""Docstrings write absolute values and norms as a physicist does: ``|θ − π|``, ``|λ| ≤ 1``,
``|φ(x) − x|∞``.  In reStructuredText ``|name|`` is a substitution, so these would be
errors or vanish; this step escapes every bar of a docstring's running text before it is
parsed (after numpydoc has turned the sections into reStructuredText), so the page shows
the formula as written.

Left alone: inline literals (````…````, where a backslash would show), interpreted text
(```…```), doctest lines (``>>>``, ``...``), literal blocks (after ``::``) and lines that
start with a bar and a blank or with ``+-``/``+=`` (line blocks, grid tables).
"""

from __future__ import annotations

import re

#: ``literal`` spans and (role-prefixed) `interpreted text`, kept as they are
_PROTECTED = re.compile(r"``.+?``|(?::[\w:.-]+:)?`[^`]+`_{0,2}")
#: a line block or a grid table's row: a bar followed by a blank (``|θ|`` is a formula)
_LINE_BLOCK = re.compile(r"\|(\s|$)")


def escape_bars(line: str) -> str:
    """``line`` with each bar of its running text escaped (``\\|``)."""
    out, pos = [], 0
    for match in _PROTECTED.finditer(line):
        out.append(line[pos : match.start()].replace("|", r"\|"))
        out.append(match.group())
        pos = match.end()
    out.append(line[pos:].replace("|", r"\|"))
    return "".join(out)


def escape_docstring(lines: list[str]) -> None:
    """Escape the bars of a docstring's lines in place."""
    literal_indent = None  # the indent of the paragraph that ended with '::'
    for k, line in enumerate(lines):
        stripped = line.lstrip()
        indent = len(line) - len(stripped)
        if literal_indent is not None:
            if not stripped or indent > literal_indent:
                continue
            literal_indent = None
        if stripped.startswith((">>>", "...", "+-", "+=")) or _LINE_BLOCK.match(stripped):
            continue
        lines[k] = escape_bars(line)
        if stripped.endswith("::"):
            literal_indent = indent


def _process(app, what, name, obj, options, lines):
    escape_docstring(lines)


def setup(app):
    # after numpydoc (priority 500), which turns the numpy sections into reST
    app.connect("autodoc-process-docstring", _process, priority=600)
    return {"parallel_read_safe": True, "parallel_write_safe": True}
