"""The version, from one source: the installed distribution's metadata (pyproject.toml;
lagrange_core ships in the ``kapitza`` distribution)."""
from importlib.metadata import PackageNotFoundError, version

try:
    __version__ = version("kapitza")
except PackageNotFoundError:      # a source tree that was never installed
    __version__ = "0+unknown"
