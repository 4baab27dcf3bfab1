"""The old single module of results, split by concept (``_base``, ``_floquet``, ``_maps``,
``_averaging``, ``_simulation``, ``_verification``).

Kept only for the tests that still import ``kapitza.results._results``; delete it once
they import from :mod:`kapitza.results`.
"""
from ._averaging import *  # noqa: F401, F403
from ._base import *  # noqa: F401, F403
from ._floquet import *  # noqa: F401, F403
from ._maps import *  # noqa: F401, F403
from ._simulation import *  # noqa: F401, F403
from ._verification import *  # noqa: F401, F403
