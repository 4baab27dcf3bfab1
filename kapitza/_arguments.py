"""The driven pendulum's arguments, checked once for every kapitza function that takes them.

Each check raises ``ValueError`` that names the argument, the value received and what
is expected (SI units and conventions of shared/PHYSICS.md), and returns the value in
the form the caller computes with.
"""
from __future__ import annotations

import math

import numpy as np

from lagrange_core.batch import grid_bytes_per_point
from lagrange_core.checks import real_array, real_number
from lagrange_core.memory import GRID_MEMORY_FRACTION, GridTooLargeError, grid_shape, memory_limit
from lagrange_core.memory import check_grid_memory as _check_grid_memory

__all__ = ["ABOUT", "DRIVES", "real_number", "pendulum_constants", "amplitude", "frequency",
           "drive", "grid_axis", "about_sign",
           "about_angle", "drive_direction", "averaging_order", "GridTooLargeError",
           "GRID_MEMORY_FRACTION", "memory_limit", "check_grid_memory", "grid_shape",
           "measure_bytes_per_point", "monodromy_bytes_per_point", "MATHIEU_MAP_BYTES",
           "MATHIEU_TRACE_MAP_BYTES", "ADAPTIVE_MAP_BYTES", "averaging_bytes_per_point",
           "SWEEP_FIX"]

#: The pendulum's equilibria that persist under a vertical drive: name → (θ (rad), sign of
#: the Mathieu parameter a = ±4ω0²/ω²).
ABOUT = {"inverted": (math.pi, -1.0), "hanging": (0.0, 1.0)}
#: Directions of the pivot's oscillation A cos ωt.
DRIVES = ("vertical", "horizontal")


def _show(value) -> str:
    """``value`` as a message shows it: plain numbers (``-1.0``, not ``array(-1.)`` or
    ``np.float64(-1.0)``), arrays shortened, anything else as its repr."""
    try:
        if np.ndim(value):
            return np.array2string(np.asarray(value), threshold=8)
        if isinstance(value, np.ndarray | np.generic):
            return repr(value.item())
    except (TypeError, ValueError):
        pass
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
                             f"({unit}), got {_show(v)}.") from None
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
        raise ValueError(f"{name} must be a whole number ≥ {minimum}, got {_show(value)}.")
    return int(value)


# -- grids that cannot fit in memory: lagrange_core.memory, with kapitza's fix --------------

# Peak memory per grid point (bytes) of the grid functions: measured with tracemalloc as the
# difference of the peaks of two grid sizes over their difference in points (the single
# pendulum; the double pendulum for the n-dependence), then rounded up by ≥ 25 %.
#: The exact Mathieu map, undamped (characteristic values: a boolean and a label per
#: point; measured 2.0).
MATHIEU_MAP_BYTES = 4
#: The Mathieu map by monodromy traces (damped, or ``trace=True``; measured 109).
MATHIEU_TRACE_MAP_BYTES = 160
#: :func:`kapitza.floquet.adaptive_map` (label, stability, margin, computed; measured 24).
ADAPTIVE_MAP_BYTES = 48
#: The fix offered for a grid that is too large.
SWEEP_FIX = ("use a coarser grid, or compute it in tiles written to disk: a scene whose "
             "[sweep] runs floquet (or measure) over these axes, with `kapitza sweep`")


def monodromy_bytes_per_point(n_dof) -> float:
    """A monodromy map's point (:func:`kapitza.floquet.stability_map`): its results, the
    monodromy (2n)² and its flags (measured 618 for n = 1, 1580 for n = 2)."""
    n = int(n_dof) if isinstance(n_dof, (int, np.integer)) and n_dof > 0 else 1
    return 400.0 + 100.0 * (2 * n) ** 2


def averaging_bytes_per_point(n_dof) -> float:
    """A point of :meth:`kapitza.averaging.AveragedSystem.sweep`: ω² per mode, stable,
    valid, and the broadcast parameters' index (measured 18 for n = 1)."""
    n = int(n_dof) if isinstance(n_dof, (int, np.integer)) and n_dof > 0 else 1
    return 16.0 + 16.0 * n


def measure_bytes_per_point(n_dof: int, periods) -> float:
    """A point of a measured grid (:func:`kapitza.measure_grid`) keeping ``periods``
    strobe samples (0: a classification, none kept): the grid's own
    (:func:`lagrange_core.batch.grid_bytes_per_point`, the samples' 2n floats each
    included) and 5n floats a sample more for the fit's records.  Measured with
    tracemalloc (2026-11-28, the difference of two grid sizes, 500 and 1500 points or
    1000 and 3000): a classification 250–1240 bytes; with Ω, 17–42 n bytes a sample for
    the pendulum (the more for the smaller grids) and 37–38 n for 2- and 3-link chains
    (3500–109 900 bytes a point at 200 and 1000 periods); this is 33–270 % above each (it
    was 8·14n bytes a sample before 2026-11-28: 2.7–6.7 times the pendulum's).
    ``tests/test_properties_grids.py`` checks that it bounds what a grid takes."""
    try:
        periods = float(periods)
    except (TypeError, ValueError):
        periods = 0.0                  # the caller's own check names a bad count
    if not math.isfinite(periods) or periods < 0:
        periods = 0.0
    n = int(n_dof) if isinstance(n_dof, (int, np.integer)) and n_dof > 0 else 1
    return grid_bytes_per_point(n, periods) + 40.0 * n * (periods + 1)


def check_grid_memory(argument: str, shape, bytes_per_point: float, *, where: str = "",
                      fix: str | None = None) -> None:
    """:func:`lagrange_core.memory.check_grid_memory`, offering :data:`SWEEP_FIX` unless
    ``fix`` is given: a coarser grid, or a scene sweep (tiles written to disk)."""
    _check_grid_memory(argument, shape, bytes_per_point, where=where,
                       fix=SWEEP_FIX if fix is None else fix)
