"""The command-line examples of the README and of the guide's command-line page
(docs/guide/command-line.md), run and compared with their printed output.

The Python examples of the README are doctests (``--doctest-glob=README.md``); the shell
examples are ```` ```console ```` blocks: each ``$ kapitza …`` line is run through
:func:`kapitza.cli.main` in this process, and what it prints on stdout must equal the lines
below it, number for number (messages and progress go to stderr and are not compared).
"""
from __future__ import annotations

import re
import shlex
from pathlib import Path

import pytest

from kapitza import cli

README = Path(__file__).resolve().parent.parent / "README.md"
#: the command line's page of the site's guide, where the README's examples moved (issue 23)
GUIDE = README.parent / "docs" / "guide" / "command-line.md"


def console_examples(text: str):
    """(command, expected stdout) for each ``$ kapitza`` line of the console blocks."""
    examples = []
    for block in re.findall(r"```console\n(.*?)```", text, flags=re.S):
        command, expected = None, []
        for line in block.splitlines():
            if line.startswith("$ "):
                if command is not None:
                    examples.append((command, "\n".join(expected)))
                command, expected = line[2:], []
            elif command is not None:
                expected.append(line.rstrip())
        if command is not None:
            examples.append((command, "\n".join(expected)))
    return examples


EXAMPLES = console_examples(README.read_text() + GUIDE.read_text())


def test_the_readme_has_command_line_examples():
    assert len(EXAMPLES) >= 2
    assert all(c.startswith("kapitza ") for c, _ in EXAMPLES)


@pytest.mark.parametrize("command,expected", EXAMPLES, ids=[c for c, _ in EXAMPLES])
def test_readme_command_prints_what_the_readme_says(command, expected, capsys):
    argv = shlex.split(command)[1:]
    assert cli.main(argv) == 0
    out = "\n".join(line.rstrip() for line in capsys.readouterr().out.strip("\n").splitlines())
    assert out == expected.strip("\n")
