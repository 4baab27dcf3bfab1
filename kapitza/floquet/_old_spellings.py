"""The kapitza 0.1 spellings of the Floquet grid functions, still accepted in 0.2 with a
``DeprecationWarning`` that names the new call (``docs/api-conventions.md`` §5).

The grid's axes became keywords named by the parameter they vary, after
``(system, params, about)``:

* ``stability_map(system, A, omega, params, about)`` and
  ``adaptive_map(system, A, omega, params, about)`` →
  ``stability_map(system, params, about, A=A, omega=omega)`` (the same for
  ``adaptive_map``): told apart by the second argument, which is a parameter dict
  (a Mapping) in the new order and an amplitude axis in the old one;
* ``window(system, params, about, omega)`` and ``boundaries(system, params, about,
  omega)`` → ``omega=omega``: told apart by a fourth positional argument;
* ``window(..., A_limit=x)`` → ``window(..., A_range=(0, x))``.

The decorators translate an old call into the new one and call the function with it, so
the numbers are the same.  They keep the function's name, docstring and signature
(``functools.wraps``: ``inspect.signature`` shows the new one), and the warning points at
the caller's line.
"""
from __future__ import annotations

import functools
from collections.abc import Callable, Mapping
from typing import Any

from .._deprecation import warn_deprecated

__all__ = ["axes_as_keywords", "frequency_as_keyword"]

#: warnings.warn in warn_deprecated (1) ← the translation (2) ← the wrapper (3) ← the caller
_CALLER = 4


def axes_as_keywords(function: Callable) -> Callable:
    """``function(system, params, about, *, A, omega, ...)`` that also accepts the old
    order ``function(system, A, omega, params, about, ...)`` with a DeprecationWarning."""
    name = function.__name__

    @functools.wraps(function)
    def accept(*args: Any, **kwargs: Any) -> Any:
        if (len(args) >= 2 and not isinstance(args[1], Mapping)
                and "A" not in kwargs and "omega" not in kwargs):
            args, kwargs = _axes_first(name, args, kwargs)
        elif len(args) > 3:
            raise TypeError(
                f"{name}() takes 3 positional arguments (system, params, about); the grid's "
                f"axes are keywords: call kapitza.{name}(system, params, about, A=A, "
                "omega=omega).")
        return function(*args, **kwargs)

    return accept


def _axes_first(name, args, kwargs):
    """The new call for ``name(system, A, omega, params, about, ...)`` (kapitza 0.1)."""
    old = ("A", "omega", "params", "about")
    given = args[1:]
    if len(given) > len(old):
        raise TypeError(f"{name}() got {len(args)} positional arguments; call "
                        f"kapitza.{name}(system, params, about, A=A, omega=omega).")
    kwargs = dict(kwargs)
    for key, value in zip(old, given, strict=False):
        if key in kwargs:
            raise TypeError(f"{name}() got {key} both by position (the deprecated order "
                            f"system, A, omega, params, about) and as {key}=; call "
                            f"kapitza.{name}(system, params, about, A=A, omega=omega).")
        kwargs[key] = value
    missing = [key for key in ("params", "about") if key not in kwargs]
    if missing:
        raise TypeError(f"{name}() missing {' and '.join(missing)}; call "
                        f"kapitza.{name}(system, params, about, A=A, omega=omega).")
    warn_deprecated(f"kapitza.{name}(system, A, omega, params, about)",
                    f"kapitza.{name}(system, params, about, A=A, omega=omega)",
                    stacklevel=_CALLER)
    return (args[0], kwargs.pop("params"), kwargs.pop("about")), kwargs


def frequency_as_keyword(function: Callable) -> Callable:
    """``function(system, params, about, *, omega, ...)`` that also accepts ``omega`` as a
    fourth positional argument, and (``window``) ``A_limit=x`` for ``A_range=(0, x)``, each
    with a DeprecationWarning."""
    name = function.__name__

    @functools.wraps(function)
    def accept(*args: Any, **kwargs: Any) -> Any:
        if len(args) == 4:
            args, kwargs = _frequency_fourth(name, args, kwargs)
        if name == "window" and "A_limit" in kwargs:
            kwargs = _limit_as_range(kwargs)
        return function(*args, **kwargs)

    return accept


def _frequency_fourth(name, args, kwargs):
    """The new call for ``name(system, params, about, omega, ...)`` (kapitza 0.1)."""
    if "omega" in kwargs:
        raise TypeError(f"{name}() got omega both as the fourth positional argument "
                        "(deprecated) and as omega=; pass only omega=.")
    warn_deprecated(f"kapitza.{name}(system, params, about, omega)",
                    f"kapitza.{name}(system, params, about, omega=omega)", stacklevel=_CALLER)
    return args[:3], dict(kwargs, omega=args[3])


def _limit_as_range(kwargs):
    """``A_limit=x`` (kapitza 0.1: scan 0 … x) as ``A_range=(0, x)``."""
    kwargs = dict(kwargs)
    limit = kwargs.pop("A_limit")
    if "A_range" in kwargs:
        raise TypeError("window() got both A_limit= (deprecated) and A_range=; pass only "
                        "A_range=(0, high).")
    warn_deprecated(f"kapitza.window(..., A_limit={limit!r})",
                    f"kapitza.window(..., A_range=(0, {limit!r}))", stacklevel=_CALLER)
    kwargs["A_range"] = None if limit is None else (0.0, limit)
    return kwargs
