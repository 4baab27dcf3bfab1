"""The ``kapitza`` command (entry point ``kapitza.cli:main``)."""
from ._cli import main

__all__ = ["main"]
