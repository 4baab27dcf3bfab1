"""A system's lanes kernels called from compiled-once code, every lane answered.

A generated lanes kernel (``fast_accel_lanes`` of :mod:`lagrange_core.drive_kernel`,
``rhs_lanes`` and ``rhs_jvp_lanes`` of :mod:`lagrange_core._rhs_lanes`) computes L states
in one vectorised pass and *leaves* the lanes it cannot answer — a result that is not
finite (an argument beyond the lane sine's range, a state that is not finite) or a pivot
too small for elimination without pivoting — marked 1.0 in row 0 of ``work`` (the
others 0.0), returning how many it left.  The functions below call it and compute the
lanes it left again with the system's **scalar** kernels, by address (libm, partial
pivoting): ``fast_accel`` for ``fast_accel_lanes``; ``rhs`` for ``rhs_lanes``; ``rhs``
and ``jacobian`` (J v as the product) for ``rhs_jvp_lanes``.  Row 0 then holds each
lane's status (0, or the scalar kernel's: 1 for a singular mass matrix) and the return
value counts the lanes that failed — the contract the drivers read
(:mod:`lagrange_core._kernel_calls`).

Why here and not in each generated module: a scalar copy linked into every lanes kernel
was compiled and optimised again with it for every new system (~1 s for
``fast_accel_lanes``, 2–3 s each for ``rhs_lanes`` and ``rhs_jvp_lanes``: a new system's
first grid or chaos map; benchmarks/README.md, fifteenth session); these are compiled
once per installation, for every system, and reach the scalar kernels that
:func:`~lagrange_core.drive_kernel.load_drive_kernel` and
:func:`~lagrange_core._rhs_lanes.load_rhs_lanes` load beside the lanes kernels.  Their
results are the scalar kernels', which the per-point paths give
(tests/test_first_order_lanes.py, tests/test_batch_speedpath.py).
"""
import math
import sys

import numpy as np
from numba import njit

from ._kernel_calls import (
    FAST_ACCEL,
    FAST_ACCEL_LANES,
    JACOBIAN,
    RHS,
    RHS_JVP_LANES,
    RHS_LANES,
    call_fast_accel,
    call_fast_accel_lanes,
    call_jacobian,
    call_rhs,
    call_rhs_jvp_lanes,
    call_rhs_lanes,
)

__all__ = ["fast_accel_on_lanes", "rhs_on_lanes", "rhs_jvp_on_lanes", "left_to_scalar_source"]


def left_to_scalar_source(failed: list[str]) -> list[str]:
    """The generated end of a lanes kernel (lines of its body, after every result is
    written): return 0 when no lane failed, else mark each failed lane 1.0 in ``work[0]``
    (the others 0.0) and return their count — the lanes :func:`fast_accel_on_lanes`,
    :func:`rhs_on_lanes` and :func:`rhs_jvp_on_lanes` compute again.

    ``failed``: boolean expressions of the lane ``l``, each true where the lane failed
    (e.g. ``"(not math.isfinite(out[0, l]))"``), combined with ``|``: no branch in the
    loops, which LLVM vectorises."""
    bad = " | ".join(failed)
    return ["left = 0", "for l in range(L):", f"    left += {bad}",
            "if left == 0:", "    return 0",
            "for l in range(L):", f"    work[0, l] = 1.0 if {bad} else 0.0",
            "return left"]


@njit(cache=True)
def _lane(a, l, out):
    """out = a[:, l], lane l of an array whose lanes are its last axis (element by element:
    a slice copy would make numba compile its shape-mismatch message)."""
    for i in range(out.shape[0]):
        out[i] = a[i, l]


@njit(cache=True, no_cpython_wrapper=True)
def fast_accel_on_lanes(ka, q, tl, cs, p, out, work, L):
    """``fast_accel_lanes`` of the system whose address table is ``ka`` (arrays as its
    contract: lanes last), the lanes it leaves by the scalar ``fast_accel``.  Returns
    the number of failed lanes; their status is in ``work[0]`` (meaningful when > 0)."""
    if call_fast_accel_lanes(ka[FAST_ACCEL_LANES], q, tl, cs, p, out, work, L) == 0:
        return 0
    n = q.shape[0]
    ql = np.empty(n)
    cl = np.empty(cs.shape[0])
    pl = np.empty(p.shape[0])
    ol = np.empty(n)
    Wn = np.zeros((n, n + 1))
    failed = 0
    for l in range(L):
        if work[0, l] == 0.0:
            continue
        _lane(q, l, ql)
        _lane(cs, l, cl)
        _lane(p, l, pl)
        st = call_fast_accel(ka[FAST_ACCEL], ql, tl[l], cl, pl, ol, Wn)
        for i in range(n):
            out[i, l] = ol[i]
        work[0, l] = float(st)
        if st != 0:
            failed += 1
    return failed


@njit(cache=True)
def _rhs_again(ka, jvp, tl, y, v, p, dydt, jv, work, L):
    """The lanes marked in ``work[0]`` by the scalar ``rhs`` (and J v by ``jacobian``)."""
    d = y.shape[0]
    n = d // 2
    yl = np.empty(d)
    pl = np.empty(p.shape[0])
    fl = np.empty(d)
    Wn = np.zeros((n, n + 1))
    J = np.empty((d, d) if jvp else (0, 0))
    failed = 0
    for l in range(L):
        if work[0, l] == 0.0:
            continue
        _lane(y, l, yl)
        _lane(p, l, pl)
        st = call_rhs(ka[RHS], tl[l], yl, pl, fl, Wn)
        if jvp and st == 0:
            st = call_jacobian(ka[JACOBIAN], tl[l], yl, pl, J)
        for i in range(d):
            dydt[i, l] = fl[i] if st == 0 else math.nan
        if jvp:
            for i in range(d):
                s = 0.0
                for j in range(d):
                    s += J[i, j] * v[j, l]
                jv[i, l] = s if st == 0 else math.nan
        work[0, l] = float(st)
        if st != 0:
            failed += 1
    return failed


@njit(cache=True)
def rhs_on_lanes(ka, tl, y, p, dydt, work, L):
    """``rhs_lanes`` (arrays as its contract), the lanes it leaves by the scalar ``rhs``.
    Returns the number of failed lanes, their status in ``work[0]``."""
    if call_rhs_lanes(ka[RHS_LANES], tl, y, p, dydt, work, L) == 0:
        return 0
    # (np.bool_: a bare False or True is typed Literal[bool], and _rhs_again compiled once
    # for each of the two callers, ~0.5 s more in a first Lyapunov map)
    return _rhs_again(ka, np.bool_(False), tl, y, y, p, dydt, dydt, work, L)


@njit(cache=True)
def rhs_jvp_on_lanes(ka, tl, y, v, p, dydt, jv, work, L):
    """``rhs_jvp_lanes`` (arrays as its contract), the lanes it leaves by the scalar
    ``rhs`` and ``jacobian`` (jv = J v).  Returns the number of failed lanes, their
    status in ``work[0]``."""
    if call_rhs_jvp_lanes(ka[RHS_JVP_LANES], tl, y, v, p, dydt, jv, work, L) == 0:
        return 0
    return _rhs_again(ka, np.bool_(True), tl, y, v, p, dydt, jv, work, L)


from . import _kernel_calls  # noqa: E402
from .module_store import guard_numba_cache  # noqa: E402

guard_numba_cache(sys.modules[__name__], _kernel_calls)


# a first call on the main thread compiles where Ctrl-C need not wait for it
from ._first_calls import guard as _guard_first_calls  # noqa: E402

_guard_first_calls(__name__)
