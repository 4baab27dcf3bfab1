"""``python -m kapitza`` runs the command line (see :mod:`kapitza.cli`)."""
from .cli._main import program

program()
