"""``python -m kapitza`` runs the command line (see :mod:`kapitza.cli`)."""
import sys

from .cli import main

sys.exit(main())
