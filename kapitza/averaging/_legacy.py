"""Old argument positions that still work in 0.2 (``docs/api-conventions.md`` §1, §5).

Options became keyword-only in kapitza 0.2; :func:`keyword_options` lets a call that
still passes them by position work, with a ``DeprecationWarning`` naming the keyword
call.  The decorated function keeps its own signature for ``inspect.signature`` (through
``__wrapped__``), so the documentation and the API test see the new one.

Exported from :mod:`kapitza.averaging` (not in ``__all__``) for the rooms above it.
"""
from __future__ import annotations

import functools
from collections.abc import Callable, Mapping
from typing import Any

from .._deprecation import warn_deprecated

__all__ = ["keyword_options", "params_first"]


def keyword_options(where: str, positional: int, options: tuple[str, ...] = (),
                    renames: dict | None = None) -> Callable:
    """Decorate a function whose ``options`` were positional, or named otherwise, before 0.2.

    Parameters
    ----------
    where : str
        The call as a user writes it, without arguments (``"AveragedSystem.slow_modes"``).
    positional : int
        How many arguments are positional now (``self`` included for a method).
    options : tuple of str
        The arguments that followed them in their old positional order (old names allowed:
        they are then renamed as below).
    renames : dict, optional
        Old keyword → new keyword, or → ``(new keyword, convert, shown)`` where the value
        changes too (``convert(old value)`` is the new value, ``shown`` the new spelling,
        e.g. ``"A_range=(0.0, upper)"``).
    """
    renames = dict(renames or {})

    def decorate(function: Callable) -> Callable:
        @functools.wraps(function)
        def wrapper(*args: Any, **kwargs: Any) -> Any:
            extra = args[positional:]
            if extra:
                if len(extra) > len(options):
                    raise TypeError(f"{where}() takes at most {positional + len(options)} "
                                    f"positional arguments ({len(args)} given).")
                names = options[:len(extra)]
                for name in names:
                    if name in kwargs:
                        raise TypeError(f"{where}() got {name} both by position (deprecated) "
                                        f"and as {name}=; pass only {name}=.")
                shown = ", ".join(f"{name}=..." for name in names)
                warn_deprecated(f"{where}(...) with {', '.join(names)} by position",
                                f"{where}(..., {shown})")
                kwargs.update(zip(names, extra, strict=True))
                args = args[:positional]
            for old, rule in renames.items():
                if old not in kwargs:
                    continue
                new, convert, shown = ((rule, None, f"{rule}=...") if isinstance(rule, str)
                                       else rule)
                if new in kwargs:
                    raise TypeError(f"{where}: got both {old}= (deprecated) and {new}=; pass "
                                    f"only {new}=.")
                warn_deprecated(f"{where}({old}=...)", f"{where}({shown})")
                value = kwargs.pop(old)
                kwargs[new] = value if convert is None else convert(value)
            return function(*args, **kwargs)

        return wrapper

    return decorate


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
