"""The ``kapitza`` command (entry point ``kapitza.cli:main``; ``python -m kapitza`` too).

``kapitza --help`` lists the commands, ``kapitza COMMAND --help`` shows each one's options
and examples.  :func:`main` runs a command line in-process and returns its exit code (0
success, 1 a verification found disagreement beyond tolerance or a catalogue problem
failed, 2 a usage or scene error, 130 interrupted); :func:`catalogue_summary` is the
default command's table.
"""
from ._catalogue import catalogue_summary
from ._main import main

__all__ = ["main", "catalogue_summary"]
