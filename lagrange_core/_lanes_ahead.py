"""RKN 12's lanes driver: its callees compiled ahead, in a second process, on an empty cache.

A first grid on RKN 12's lanes (:func:`lagrange_core._batch_kernels.grid_rkn_lanes`: every
undamped ``kapitza`` measurement) compiles the driver, ``_lanes_block``, for ~27 s on an
empty cache.  numba types the driver from the top down and compiles each function it calls
when it meets the call: the ten of :data:`CALLEES`, ~9 s of those 27 (2026-11-28, the
2-core development machine), one after another, while the machine's second core idles.

:data:`CODE`, run in a second process as the first grid starts, compiles them into numba's
disk cache, each with the one signature the driver calls it with: the first two the driver
meets, then the rest from the last one met (:func:`compile_callees`); the driver's compile,
when it meets a call, loads what is there by then and compiles the rest itself.  So a
wrong or stale signature only costs time, never a result: ``tests/test_cold_start.py``
checks every one against what the driver's compile used.
kapitza's ``measure`` starts it (``kapitza.simulation._measurement``): a first undamped
``measure`` took 26.3–26.8 s against 36.1–37.1 s without it (both drives, 2026-11-28,
empty caches, ``benchmarks/bench_cold_start.py --only first-use --without-warmup``).
"""
from __future__ import annotations

import importlib

__all__ = ["CALLEES", "CODE", "signature", "callees", "compile_callees", "runs_on_lanes"]

#: The driver's callees in the order it meets their calls: (module, function, argument
#: types).  Each type is one token: ``i``/``f`` int64/float64, and a C-contiguous array
#: of ``ndim`` dimensions as ``i``, ``f`` or ``b`` (bool) followed by ``ndim``.
CALLEES = (
    ("_batch_kernels", "_lanes_restore",
     "i1 i i f1 i1 f2 f2 f2 f1 f2 f2 f2 i f2 f2 f3 f2 f2 f2 f2 i f1 f1 f1 f1 f1 f1 f1 f1 "
     "f2 f2 f2 f2 f2 f1 f1 f1 b1 i1 f2 f2 f1 f2 i2 f2 f3 f2"),
    ("_batch_kernels", "_lanes_load",
     "i1 i i i f2 f2 f2 f1 f1 f2 f2 f2 i f f f2 f2 f3 f2 f2 f2 f2 i f1 f1 f1 f1 f1 f1 f1 "
     "f1 f2 f2 f2 f2 f2 f1 f1 f1 b1 i1 i1 f2 f3 i2 f2 f2 f1 f2 i2"),
    ("_lane_math", "lane_sincos_rows", "f1 f1 f1 i"),
    ("_batch_kernels", "_stage_positions", "i f2 f1 f3 f2 f2 f1 f2 f2 i"),
    ("_lane_calls", "fast_accel_on_lanes", "i1 f2 f1 f2 f2 f2 f2 i"),
    ("_batch_kernels", "_weighted_sums", "f1 f1 f1 f1 f3 i f2 i"),
    ("_selection", "kth_smallest", "f1 i"),
    ("_batch_kernels", "_rkn_band_exit", "i1 f f f1 f1 f1 f1 f1 f1 f1 f1 f1 f2 f1 f1 f1 f1"),
    ("_selection", "pilot_step_quantile", "f1 i"),
    ("_batch_kernels", "_lanes_save",
     "i f1 i1 f2 f2 f3 f2 f2 f1 f1 f1 f1 f1 f1 f1 f1 b1 i1 f2 i2 f2 f3"),
)

#: What the second process runs.
CODE = "from lagrange_core._lanes_ahead import compile_callees\ncompile_callees()\n"


def signature(tokens: str) -> tuple:
    """The numba argument types that ``tokens`` (see :data:`CALLEES`) spell."""
    from numba.core import types
    scalar = {"i": types.int64, "f": types.float64, "b": types.boolean}
    args = []
    for token in tokens.split():
        kind, ndim = token[0], token[1:]
        args.append(types.Array(scalar[kind], int(ndim), "C") if ndim else scalar[kind])
    return tuple(args)


def callees():
    """(dispatcher, argument types) of :data:`CALLEES`, in the driver's order."""
    return [(getattr(importlib.import_module(f"lagrange_core.{module}"), name),
             signature(tokens)) for module, name, tokens in CALLEES]


def compile_callees() -> None:
    """Compile (or load) every callee with its signature: the two the driver meets first,
    then the rest from the last one it meets.  The driver's compile, running at the same
    time, spends ~3.5 s on its untyped passes before its first call; in that time this
    process compiles those two (~2.6 s), and while the driver then compiles the next
    ones itself, this one works from the other end.  Every cache empty, the first
    undamped ``measure`` of the vertical drive, alternated with the order from the last
    met alone (which left the first two to the driver): shorter in 7 of 9 pairs, by
    0.5 s on average (17.4 against 17.9 s; 2026-11-28, benchmarks/README.md)."""
    order = callees()
    for dispatcher, args in order[:2] + order[:1:-1]:
        dispatcher.compile(args)


def runs_on_lanes(kernels, method=None) -> bool:
    """Whether ``System.simulate_grid`` of these kernels with ``method`` (None: the
    default) and no fixed step ``h`` runs on RKN 12's lanes; False where it refuses the
    method (it says why)."""
    from . import batch
    try:
        _, family, sub, _ = batch._grid_method(kernels, method, False)
    except ValueError:
        return False
    return batch._runs_on_lanes(family, sub)
