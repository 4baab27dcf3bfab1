"""RKN 12's lanes driver's callees compiled ahead, in a second process, on an empty cache.

A first grid on RKN 12's lanes (:func:`lagrange_core._batch_kernels.grid_rkn_lanes`: every
undamped ``kapitza`` measurement) compiles the driver, ``_lanes_block``, and needs its
callees (:mod:`lagrange_core._lanes_callees`), which it calls by address, once it has
compiled.  :data:`CODE`, run in a second process as the first grid starts
(:func:`start_if_cold`, from ``simulate_grid``; kapitza's ``measure`` runs it in its own
background process, ``kapitza.simulation._measurement``), compiles them into numba's disk
cache meanwhile, on the machine's other core, from the first slot on; the driver's
process, its driver compiled, takes those not yet begun from the last back and loads the
others as they land (:func:`lagrange_core._lanes_callees.addresses`).  A second process
that ends without them leaves them to the driver's process: it costs time, never a result.
"""
from __future__ import annotations

import os

from . import _background
from ._lanes_callees import AHEAD_CODE, callees

__all__ = ["CODE", "GROUP", "start_if_cold", "wanted"]

#: What the second process runs (:func:`lagrange_core._lanes_callees.compile_ahead`: the
#: callees from the first slot on, while the driver's process, its driver compiled, takes
#: them from the last back).
CODE = AHEAD_CODE
#: Its group's name (:mod:`lagrange_core._background`) when ``simulate_grid`` starts it.
GROUP = "RKN 12 lanes callees"


def start_if_cold() -> None:
    """Start :data:`CODE` in a background process, for a first grid on RKN 12's lanes:
    unless this process has the driver already, background compiles are switched off
    (:func:`lagrange_core._background.enabled`), the machine has one core, another
    background compile is running (kapitza's ``measure`` starts its own with these
    callees in it; on two cores a third process would slow this one's compile), or
    numba's cache has every callee."""
    if not _background.enabled() or (os.cpu_count() or 1) < 2 or _background.running():
        return
    if wanted():
        _background.start(GROUP, CODE)


def wanted() -> bool:
    """Whether compiling the callees ahead would save time: this process has no lanes
    driver yet (what it has needs no look at numba's cache, a file read a callee), and
    numba's cache lacks one of the callees.  :func:`start_if_cold` and kapitza's
    ``measure`` (which compiles them in its own background process) both ask this, and
    the compile notice, for its estimate (``lagrange_core._compile_notice``)."""
    return not _driver_in_process() and _background.cold(*(d for d, _ in callees()))


def _driver_in_process() -> bool:
    """Whether this process has the lanes driver (compiled or loaded)."""
    from ._batch_kernels import _lanes_block
    return bool(_lanes_block.signatures)
