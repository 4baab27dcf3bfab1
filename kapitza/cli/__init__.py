"""The ``kapitza`` command (entry point ``kapitza.cli._main:program``, which runs
:func:`main` and exits with its code; ``python -m kapitza`` too).

``kapitza --help`` lists the commands, ``kapitza COMMAND --help`` shows each one's options
and examples.  :func:`main` runs a command line in-process and returns its exit code:

* 0 success;
* 1 methods that both claim validity at a point disagree beyond their tolerances
  (``verify``; points outside a method's validity are reported, not failed), a report
  section or a catalogue problem failed;
* 2 a usage, input or scene error: one line on stderr naming the option, the value and
  the fix (an option the command does not take, a path that cannot be written, a value
  the API refuses);
* 70 an internal error, i.e. a bug: one line, and Python's traceback with
  ``--traceback`` or ``KAPITZA_DEBUG=1``;
* 130 interrupted (Ctrl-C): what finished is kept.

``--json`` writes ∞, −∞ and NaN as the strings "inf", "-inf" and "nan", the tokens the
text prints.  :func:`catalogue_summary` is the default command's table.
"""
from ._catalogue import catalogue_summary
from ._main import main

__all__ = ["main", "catalogue_summary"]
