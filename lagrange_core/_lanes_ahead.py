"""RKN 12's lanes driver's callees compiled ahead, in a second process, on an empty cache.

A first grid on RKN 12's lanes (:func:`lagrange_core._batch_kernels.grid_rkn_lanes`: every
undamped ``kapitza`` measurement) compiles the driver, ``_lanes_block``, and needs its
callees (:mod:`lagrange_core._lanes_callees`), which it calls by address, once it has
compiled.  :data:`CODE`, run in a second process as the first grid starts (kapitza's
``measure`` starts it: ``kapitza.simulation._measurement``), compiles them into numba's
disk cache meanwhile, on the machine's other core; the driver's process then loads them.
A callee the second process has not finished compiles in the driver's process too: it
costs time, never a result.
"""
from __future__ import annotations

from ._lanes_callees import callees

__all__ = ["CODE", "compile_callees", "runs_on_lanes"]

#: What the second process runs.
CODE = "from lagrange_core._lanes_ahead import compile_callees\ncompile_callees()\n"


def compile_callees() -> None:
    """Compile (or load) every callee with its declared signature, in slot order (the
    order :func:`lagrange_core._lanes_callees.addresses` asks for them)."""
    for dispatcher, sig in callees():
        dispatcher.compile(tuple(sig.args))


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
