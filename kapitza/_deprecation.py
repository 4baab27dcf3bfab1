"""Old spellings of the public API that still work in 0.2, with a ``DeprecationWarning``.

One message format for every renamed function, argument and argument order
(``docs/api-conventions.md`` §5): what was called, since when, and the new call. The
warning points at the user's line (``stacklevel``), so ``-W error::DeprecationWarning``
finds every old call in a script.
"""
from __future__ import annotations

import functools
import warnings
from collections.abc import Callable
from typing import Any

__all__ = ["SINCE", "REMOVED_IN", "warn_deprecated", "deprecated_alias",
           "renamed_keywords", "keyword_options", "state_was_first"]

SINCE = "0.2.0"
REMOVED_IN = "0.3"


def warn_deprecated(old: str, new: str, *, stacklevel: int = 3) -> None:
    """Warn that the call spelled ``old`` is deprecated; ``new`` is the call to make.

    ``stacklevel=3`` points at the caller of the function that calls this one.
    """
    warnings.warn(f"{old} is deprecated since kapitza {SINCE} (removed in {REMOVED_IN}); "
                  f"call {new}.", DeprecationWarning, stacklevel=stacklevel)


def deprecated_alias(function: Callable, old: str, new: str) -> Callable:
    """``function`` under an old name: same arguments and result, warns on every call.

    Parameters
    ----------
    function : callable
        The function (or class) under its new name.
    old, new : str
        The old and the new call as a user writes them, e.g.
        ``"kapitza.averaging_window(omega)"`` and
        ``"kapitza.pendulum_window(omega, method='averaging')"``.
    """
    @functools.wraps(function)
    def alias(*args: Any, **kwargs: Any) -> Any:
        warn_deprecated(old, new)
        return function(*args, **kwargs)

    alias.__doc__ = (f"Deprecated since kapitza {SINCE}: {old} → {new}.\n\n"
                     + (function.__doc__ or ""))
    alias.__deprecated__ = new  # type: ignore[attr-defined]  # the mark tests/test_api.py reads
    return alias


def renamed_keywords(where: str, kwargs: dict, renames: dict[str, str],
                     *, stacklevel: int = 4) -> dict:
    """``kwargs`` with old keyword names replaced by new ones, warning once per old name.

    ``renames`` maps old → new. Giving both the old and the new name is an error (the
    call is ambiguous). Returns a new dict; ``kwargs`` is not changed.
    """
    out = dict(kwargs)
    for old, new in renames.items():
        if old in out:
            if new in out:
                raise TypeError(f"{where}: got both {old}= (deprecated) and {new}=; "
                                f"pass only {new}=.")
            warn_deprecated(f"{where}({old}=...)", f"{where}({new}=...)",
                            stacklevel=stacklevel)
            out[new] = out.pop(old)
    return out


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


def state_was_first(where: str, *, method: bool = False) -> Callable:
    """Decorate ``where(A, omega, *, theta)`` whose 0.1 spelling was ``(theta, A, omega)``:
    a call with three positional arguments (after ``self`` for a ``method``) is that order;
    it still works and warns. Giving ``theta`` both ways is an error."""
    skip = 1 if method else 0

    def decorate(function: Callable) -> Callable:
        @functools.wraps(function)
        def wrapper(*args: Any, **kwargs: Any) -> Any:
            head, rest = args[:skip], args[skip:]
            if len(rest) == 3:
                if "theta" in kwargs:
                    raise TypeError(f"{where}() got theta twice; call "
                                    f"{where}(A, omega, theta=theta).")
                warn_deprecated(f"{where}(theta, A, omega)", f"{where}(A, omega, theta=theta)")
                theta, A, omega = rest
                args, kwargs = (*head, A, omega), dict(kwargs, theta=theta)
            return function(*args, **kwargs)

        return wrapper

    return decorate
