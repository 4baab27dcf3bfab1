"""The averaged system's old argument order that still works in 0.2 (``(q, params)`` →
``(params, q)``; ``docs/api-conventions.md`` §5). Old positional options are
:func:`kapitza._deprecation.keyword_options`.
"""
from __future__ import annotations

from collections.abc import Mapping

from .._deprecation import warn_deprecated

__all__ = ["params_first"]


def params_first(system, first, second, where: str) -> tuple:
    """``(params, state)`` from a call written ``(params, state)`` or, before 0.2,
    ``(state, params)`` (which warns).

    The parameters are a mapping by parameter name; a state is a sequence, an array or a
    mapping by coordinate name, so the two are told apart by type and keys.
    """
    def is_params(x):
        return isinstance(x, Mapping) and not set(x) <= set(system.coordinates)

    if not is_params(first) and is_params(second):
        warn_deprecated(f"{where}(q, params)", f"{where}(params, q)", stacklevel=4)
        return second, first
    return first, second
