"""The driven pendulum's arguments, checked once for every kapitza function that takes them.

Each check raises ``ValueError`` that names the argument, the value received and what
is expected (SI units and conventions of shared/PHYSICS.md), and returns the value in
the form the caller computes with.
"""
from __future__ import annotations

import math

import numpy as np

from lagrange_core.checks import real_array, real_number

__all__ = ["ABOUT", "DRIVES", "real_number", "pendulum_constants", "amplitude", "frequency",
           "drive", "grid_axis", "about_sign",
           "about_angle", "drive_direction", "averaging_order"]

#: The pendulum's equilibria that persist under a vertical drive: name → (θ (rad), sign of
#: the Mathieu parameter a = ±4ω0²/ω²).
ABOUT = {"inverted": (math.pi, -1.0), "hanging": (0.0, 1.0)}
#: Directions of the pivot's oscillation A cos ωt.
DRIVES = ("vertical", "horizontal")


def _show(value) -> str:
    try:
        return np.array2string(np.asarray(value), threshold=8) if np.ndim(value) else repr(value)
    except (TypeError, ValueError):
        return repr(value)


def pendulum_constants(l, g, damping=0.0, *, where: str = "",
                       names=("l", "g", "damping")) -> tuple[float, float, float]:
    """(l, g, damping) as floats after checking l > 0 (m), g ≥ 0 (m/s²), damping ≥ 0 (1/s).

    ``where`` prefixes the message (e.g. ``"KapitzaPendulum: "``); ``names`` are the
    caller's names of the three arguments.
    """
    out = []
    for name, v, unit, strict in zip(names, (l, g, damping), ("m", "m/s²", "1/s"),
                                     (True, False, False), strict=True):
        try:    # numbers of every kind (numpy scalars, 0-d arrays); no strings or booleans
            out.append(real_number(v, name, unit=unit, minimum=0.0, strict=strict))
        except ValueError:
            raise ValueError(f"{where}{name} must be a finite number {'>' if strict else '≥'} 0 "
                             f"({unit}), got {v!r}.") from None
    return tuple(out)


def _floats(name, value, where):
    try:    # refuses strings and booleans (np.asarray would convert them silently)
        return real_array(value, name)
    except ValueError:
        raise ValueError(f"{where}{name} must be a number or an array of numbers, got "
                         f"{_show(value)}.") from None


def amplitude(A, *, where: str = "") -> np.ndarray:
    """The drive amplitude A (m), finite and ≥ 0, as a float array of its own shape."""
    A = _floats("A", A, where)
    if not (np.all(np.isfinite(A)) and np.all(A >= 0)):
        raise ValueError(f"{where}the drive amplitude A must be finite and ≥ 0 (m), got "
                         f"{_show(A)}.")
    return A


def frequency(omega, *, where: str = "") -> np.ndarray:
    """The drive's angular frequency ω (rad/s), finite and > 0, as a float array of its own
    shape."""
    omega = _floats("omega", omega, where)
    if not (np.all(np.isfinite(omega)) and np.all(omega > 0)):
        raise ValueError(f"{where}the drive frequency omega must be finite and > 0 (rad/s), got "
                         f"{_show(omega)}; pass the angular frequency ω = 2π f.")
    return omega


def drive(A, omega, *, where: str = "") -> tuple[np.ndarray, np.ndarray]:
    """Drive amplitude A (m, finite ≥ 0) and angular frequency ω (rad/s, finite > 0),
    broadcast together as float arrays."""
    A, omega = amplitude(A, where=where), frequency(omega, where=where)
    try:
        return tuple(np.broadcast_arrays(A, omega))
    except ValueError:
        raise ValueError(f"{where}A and omega must broadcast together, got shapes {A.shape} "
                         f"and {omega.shape}.") from None


def grid_axis(name: str, values, unit: str | None, *, positive: bool | None) -> np.ndarray:
    """A grid axis as a 1-d float array: finite values, > 0 (``positive=True``), ≥ 0
    (``False``) or of any sign (``None``); ``unit`` only names the unit in the message.
    An empty axis is allowed (an empty map).  Strings and booleans are refused."""
    need = {True: " > 0", False: " ≥ 0", None: ""}[positive]
    try:
        arr = np.atleast_1d(real_array(values, name))
    except ValueError:
        arr = None
    ok = (arr is not None and arr.ndim == 1
          and (positive is None or bool(np.all(arr > 0 if positive else arr >= 0))))
    if not ok:
        raise ValueError(f"{name} must be a number or a 1-d array (a grid axis) of finite "
                         f"values{need}{f' ({unit})' if unit else ''}, got {_show(values)}.")
    return arr


def about_sign(about) -> float:
    """The sign of a = ±4ω0²/ω² for the equilibrium ``about`` ("hanging" +1, "inverted" −1)."""
    return _about(about)[1]


def about_angle(about) -> float:
    """θ of the equilibrium ``about`` (rad): π for "inverted", 0 for "hanging"."""
    return _about(about)[0]


def _about(about):
    try:
        return ABOUT[about]
    except (KeyError, TypeError):
        raise ValueError("about must be 'inverted' (θ = π) or 'hanging' (θ = 0), got "
                         f"{about!r}.") from None


def drive_direction(direction, *, where: str = "") -> str:
    """The drive's direction, one of :data:`DRIVES`."""
    if direction not in DRIVES:
        raise ValueError(f"{where}drive must be one of {DRIVES}, got {direction!r}.")
    return direction


def averaging_order(order) -> int:
    """The order of an averaging result: 1 (Kapitza/Landau) or 2 (next order)."""
    if order not in (1, 2) or isinstance(order, bool):
        raise ValueError(f"order must be 1 (first-order averaging) or 2 (next order), got "
                         f"{order!r}.")
    return int(order)


def whole_number(value, name: str, minimum: int, *, integral_floats: bool = False) -> int:
    """``value`` as an int ≥ ``minimum``; booleans and strings are refused, and floats
    too unless ``integral_floats`` (then 3.0 is 3, 2.5 refused) — a count of periods,
    blocks, starts: 2.5 of them is a mistake, not a rounding."""
    whole = isinstance(value, (int, np.integer)) or (
        integral_floats and isinstance(value, (float, np.floating)) and math.isfinite(value)
        and int(value) == value)
    if isinstance(value, bool) or not whole or value < minimum:
        raise ValueError(f"{name} must be a whole number ≥ {minimum}, got {value!r}.")
    return int(value)
