"""The command-line reference, generated from the ``kapitza`` command's argparse parsers.

``.. cli-reference:: kapitza.cli._parsing.build_parser`` writes one section per command
(``kapitza predict``, ``kapitza window``, ...) holding the command's one-line summary and
its ``--help`` text exactly as the terminal prints it (usage, every option with its help
and default, the examples), at a fixed width of 90 columns.  The help texts are written
for a terminal, so they are shown as they are rather than parsed as reStructuredText.
"""

from __future__ import annotations

import argparse
import importlib
import os
from unittest import mock

from docutils import nodes
from docutils.parsers.rst import Directive
from sphinx.util.nodes import make_id

#: columns of the help text (argparse reads $COLUMNS)
WIDTH = 90


def commands(parser: argparse.ArgumentParser):
    """(name, summary, subparser) of each sub-command, in the order ``--help`` lists them."""
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            summaries = {a.dest: a.help for a in action._choices_actions}
            for name, sub in action.choices.items():
                yield name, summaries.get(name) or "", sub


def help_text(parser: argparse.ArgumentParser) -> str:
    with mock.patch.dict(os.environ, {"COLUMNS": str(WIDTH)}):
        return parser.format_help()


class CliReference(Directive):
    required_arguments = 1  # module.function that returns the parser

    def run(self):
        modname, _, funcname = self.arguments[0].rpartition(".")
        parser = getattr(importlib.import_module(modname), funcname)()
        document = self.state.document
        out = []
        top = nodes.section(
            ids=[make_id(self.state.document.settings.env, document, "cli", parser.prog)]
        )
        top += nodes.title(text=parser.prog)
        top += nodes.literal_block(text=help_text(parser), language="text")
        out.append(top)
        for name, summary, sub in commands(parser):
            section = nodes.section(
                ids=[make_id(document.settings.env, document, "cli", f"{parser.prog} {name}")]
            )
            section += nodes.title(text=f"{parser.prog} {name}")
            if summary:
                section += nodes.paragraph(text=summary[0].upper() + summary[1:] + ".")
            section += nodes.literal_block(text=help_text(sub), language="text")
            out.append(section)
        return out


def setup(app):
    app.add_directive("cli-reference", CliReference)
    return {"parallel_read_safe": True, "parallel_write_safe": True}
