"""Grids that cannot fit in memory: refused before any work, with the estimate and the fix.

A grid function (``System.simulate_grid``, and kapitza's maps, measurements and sweeps)
allocates arrays for every point before it computes the first one.  A grid of 10¹² points
would otherwise fail inside numpy's allocation with a ``MemoryError`` that names no
argument — or, smaller, take the machine into swap.  Each grid function estimates its peak
memory as points × bytes per point (measured with tracemalloc, rounded up by ≥ 25 %) and
:func:`check_grid_memory` refuses it when that exceeds :func:`memory_limit`: half the
machine's memory (a container's limit where smaller) or ``KAPITZA_MEMORY_LIMIT_GIB``.
"""
from __future__ import annotations

import math
import os

import numpy as np

__all__ = ["GridTooLargeError", "GRID_MEMORY_FRACTION", "MEMORY_LIMIT_VARIABLE",
           "memory_limit", "grid_shape", "check_grid_memory", "PARTS_FIX"]


class GridTooLargeError(ValueError):
    """A grid whose arrays would not fit in memory, refused before any work.

    The message names the argument, the estimate and the limit (GiB) and the fix; the
    numbers are attributes too: ``argument``, ``shape``, ``needed`` and ``limit`` (bytes).
    A ValueError, so the command line reports it in one line and exits 2.
    """

    def __init__(self, message, *, argument, shape, needed, limit):
        super().__init__(message)
        self.argument, self.shape, self.needed, self.limit = argument, shape, needed, limit


#: The share of the machine's memory one grid's arrays may take.  The rest is for the
#: operating system, other programs, and the copies made after the computation (a table,
#: a figure, a file): half, so a refused grid is one that would surely swap or fail.
GRID_MEMORY_FRACTION = 0.5
#: Environment variable that sets the limit itself, in GiB (for a machine shared by jobs
#: or a batch system whose memory the operating system does not report).
MEMORY_LIMIT_VARIABLE = "KAPITZA_MEMORY_LIMIT_GIB"

_GIB = float(1 << 30)


def _physical_memory() -> int | None:
    """The machine's memory (bytes), or a container's cgroup limit where smaller; None
    where the operating system does not say (then no grid is refused)."""
    try:
        total = os.sysconf("SC_PHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
    except (AttributeError, ValueError, OSError):      # Windows: no sysconf
        return None
    for cgroup in ("/sys/fs/cgroup/memory.max",                     # cgroup v2
                   "/sys/fs/cgroup/memory/memory.limit_in_bytes"):  # cgroup v1
        try:
            with open(cgroup) as f:
                text = f.read().strip()
        except OSError:
            continue
        if text.isdigit():
            total = min(total, int(text))
    return int(total) if total > 0 else None


def memory_limit() -> tuple[float | None, str]:
    """(The most one grid's arrays may take (bytes), what the limit is) — the
    environment's ``KAPITZA_MEMORY_LIMIT_GIB`` if set, else :data:`GRID_MEMORY_FRACTION`
    of the machine's physical memory (``os.sysconf``; a container's cgroup limit where
    smaller).  (None, reason) where neither is known: no grid is refused."""
    text = os.environ.get(MEMORY_LIMIT_VARIABLE)
    if text:
        try:
            gib = float(text)
        except ValueError:
            gib = math.nan
        if not (math.isfinite(gib) and gib > 0):
            raise ValueError(f"the environment variable {MEMORY_LIMIT_VARIABLE} must be a "
                             f"number of GiB > 0, got {text!r}.")
        return gib * _GIB, f"{MEMORY_LIMIT_VARIABLE}={text}"
    total = _physical_memory()
    if total is None:
        return None, "the machine's memory is unknown"
    return (GRID_MEMORY_FRACTION * total,
            f"{GRID_MEMORY_FRACTION:.0%} of this machine's {total / _GIB:.1f} GiB")


def grid_shape(*arrays) -> tuple | None:
    """The broadcast shape of ``arrays`` (numbers, arrays, or anything ``np.shape`` takes),
    or None where they do not broadcast (the caller's own check says so)."""
    try:
        return tuple(np.broadcast_shapes(*(np.shape(a) for a in arrays)))
    except ValueError:
        return None


#: The fix offered for a grid that is too large, unless the caller offers its own.
PARTS_FIX = ("use fewer points, or compute the grid in parts (slices of its axes), one call "
             "each")


def _gib(n: float) -> str:
    """Bytes as GiB in plain digits: 3 significant, whole numbers from 1000 on."""
    x = n / _GIB
    return f"{x:.3g}" if x < 1000 else f"{x:,.0f}"


def check_grid_memory(argument: str, shape, bytes_per_point: float, *, where: str = "",
                      fix: str | None = None) -> None:
    """Refuse, before any work, a grid whose arrays would not fit in memory.

    Parameters
    ----------
    argument : str
        What sets the grid, as the caller names it ("A × omega", "[analyses]
        stability_map: A × omega").
    shape : tuple of int or None
        The grid's shape (None: not known, nothing checked).
    bytes_per_point : float
        The caller's peak memory per grid point (bytes): its arrays and their temporaries,
        measured (tracemalloc) and rounded up where the constant is defined.
    where : str
        Prefix of the message (the function's name).
    fix : str, optional
        The way out the message offers (default :data:`PARTS_FIX`: fewer points, or the
        grid in parts; kapitza offers a scene sweep, which writes its tiles to disk).

    Raises
    ------
    GridTooLargeError
        The estimate exceeds :func:`memory_limit`.
    """
    if shape is None:
        return
    points = math.prod(int(n) for n in shape)
    needed = float(points) * float(bytes_per_point)
    limit, what = memory_limit()
    if limit is None or needed <= limit:
        return
    if fix is None:
        fix = PARTS_FIX
    dims = " × ".join(str(int(n)) for n in shape)
    size = f"{dims} = {points:.3g} points" if len(shape) else "one point"
    raise GridTooLargeError(
        f"{where}the grid {argument} of {size} needs about "
        f"{_gib(needed)} GiB ({bytes_per_point:.0f} bytes per point), more than the "
        f"limit of {_gib(limit)} GiB ({what}); {fix}.",
        argument=argument, shape=tuple(int(n) for n in shape), needed=needed, limit=limit)
