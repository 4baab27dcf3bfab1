"""The old single module of figures, split by concept (``_maps``, ``_lines``,
``_verification``, ``_common``).

Kept only for the tests, studies and benchmarks that still import
``kapitza.figures._plots``; delete it once they import from :mod:`kapitza.figures`.
"""
from . import *  # noqa: F401, F403
