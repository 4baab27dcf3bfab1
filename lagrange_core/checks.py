"""Checking numbers a user passes: one place, one message style, for every entry point.

A number is a Python or numpy real scalar, a 0-d array, or a sympy number.  Strings and
booleans are refused (``float("0.01")`` and ``float(True)`` would silently convert them),
and so are complex, NaN and infinite values.  Each error names the argument, the value
and the fix.
"""
from __future__ import annotations

import math
import numbers

import numpy as np

__all__ = ["real_number", "real_array"]


def _plain(value) -> str:
    """``value`` as a message shows it: a numpy scalar or 0-d array as the plain number
    (``0.0``, not ``np.float64(0.0)`` or ``array(0.)``), anything else as its repr."""
    if isinstance(value, np.ndarray | np.generic) and np.ndim(value) == 0:
        try:
            return repr(value.item())
        except (TypeError, ValueError):
            pass
    return repr(value)


def _refused(value) -> str | None:
    """Why ``value`` is not a real number, or None."""
    if isinstance(value, (str, bytes, np.str_, np.bytes_)):
        return "a string"
    if isinstance(value, (bool, np.bool_)):
        return "a boolean"
    if isinstance(value, np.ndarray) and value.dtype.kind in "bUSO":
        return f"an array of {value.dtype}"
    if isinstance(value, (complex, np.complexfloating)) or (
            isinstance(value, np.ndarray) and value.dtype.kind == "c"):
        return "complex"
    return None


def real_number(value, name: str, *, unit: str = "", minimum: float | None = None,
                strict: bool = False, example: str | None = None) -> float:
    """``value`` as a finite float, or a ValueError naming ``name``.

    Parameters
    ----------
    value : number
    name : str
        The argument's name, for the message.
    unit : str
        Its unit, for the message (e.g. "m").
    minimum : float, optional
        Smallest allowed value (excluded when ``strict``).
    example : str, optional
        How a right call looks, for the message (default ``<name>=1.0``).
    """
    what = _refused(value)
    unit_text = f" ({unit})" if unit else ""
    if what is None:
        if isinstance(value, np.ndarray):
            if value.ndim != 0:
                what = f"an array of shape {value.shape}"
            else:
                value = value[()]
        if what is None:
            try:
                number = float(value) if isinstance(value, numbers.Real) or hasattr(
                    value, "__float__") else None
            except (TypeError, ValueError):
                number = None
            if number is None:
                what = f"a {type(value).__name__}"
    if what is not None:
        raise ValueError(f"{name} must be a real number{unit_text}, got {_plain(value)} ({what}); "
                         f"pass a number, e.g. {example or name + '=1.0'}.")
    if not math.isfinite(number):
        raise ValueError(f"{name} must be finite{unit_text}, got {number}.")
    if minimum is not None and (number <= minimum if strict else number < minimum):
        relation = ">" if strict else "≥"
        raise ValueError(f"{name} must be {relation} {minimum:g}{unit_text}, got {number:g}.")
    return number


def real_array(value, name: str, *, unit: str = "") -> np.ndarray:
    """``value`` (a number or a sequence of numbers) as a float array of finite values."""
    what = _refused(value)
    if what is None and not isinstance(value, np.ndarray):
        flat = value if isinstance(value, (list, tuple)) else [value]
        for item in flat:
            what = _refused(item) if not isinstance(item, (list, tuple)) else None
            if what is not None:
                break
    unit_text = f" ({unit})" if unit else ""
    if what is None:
        try:
            arr = np.asarray(value, dtype=float)
        except (TypeError, ValueError):
            what = f"a {type(value).__name__} that is not numbers"
    if what is not None:
        raise ValueError(f"{name} must be real numbers{unit_text}, got {_plain(value)} "
                         f"({what}).")
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{name} must be finite{unit_text}, got {arr}.")
    return arr
