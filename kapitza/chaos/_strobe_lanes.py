"""Strobe runs of first-order systems on lanes: the fast path of bifurcation diagrams.

:func:`strobe_runs_lanes` does what ``_sections._strobe_runs`` does with
:meth:`lagrange_core.System.simulate_grid` — ``transient`` drive periods unobserved, then
``periods`` strobe samples [q, q̇](start + kT) on the integrator's own steps — with
DOP853 on lanes (:func:`lagrange_core._first_order_lanes.grid_dop853_lanes`: the same
method, step control and statuses as ``simulate_grid``'s "dop853", 64 trajectories per
thread vectorised, the system's generated ``rhs_lanes``).  :func:`lanes_apply` says when
it applies: a system that is not of the form q̈ = f(q, t) (those run RKN 12 on lanes in
``simulate_grid`` already) or ``method="dop853"``, unconstrained, with lanes kernels.

``simulate_grid`` runs the same driver for grids of
``lagrange_core.batch.FIRST_ORDER_LANES_MIN_POINTS`` points or more; the chaos room calls it
here for any number of points (a diagram of a few values still fills the lanes with its
starts).  The samples equal ``simulate_grid``'s per-point DOP853 to rounding
(tests/test_first_order_lanes.py).
"""
from __future__ import annotations

import numpy as np

from lagrange_core import _first_order_lanes as _fl
from lagrange_core.batch import STATUS_NAMES, point_rows
from lagrange_core.progress import KERNEL_STOP, defer_ctrl_c

from .._arguments import whole_number
from ._lanes import call_points

__all__ = ["lanes_apply", "strobe_runs_lanes"]

_NOT_RUN, _FINISHED = 6, 0
_NEVER = 1 << 62


def lanes_apply(system, method) -> bool:
    """Whether the strobe runs of ``system`` with ``method`` go on lanes (module docstring)."""
    if method not in (None, "dop853") or system.n_constraints:
        return False
    if method is None and system.kernels.rkn_form:
        return False
    from lagrange_core._rhs_lanes import load_rhs_lanes
    return load_rhs_lanes(system.kernels)[0]


def _dop853():
    from lagrange_core.integrate import METHODS
    tab = METHODS["dop853"].table
    return tab["A"], tab["B"], tab["C"], tab["E3"], tab["E5"]


def _run(ka, Y0, P, t_start, t_end, T, K, rtol, atol, max_steps, progress, tables):
    """One lanes run of every row of Y0 over [t_start, t_end], with K strobe samples of
    period T (K = 0: none).  Returns (final states, samples, status, interrupted).

    Called as ``simulate_grid`` calls its kernels (``lagrange_core.batch._run_paused``):
    calls of about a quarter of a second, a point that has taken the call's step budget
    pauses (its integrator state saved, status "interrupted") and goes on in the next
    call, so Ctrl-C stops a run of any length within a second and keeps every sample
    taken so far.  A call takes :func:`kapitza.chaos._lanes.call_points` points at least."""
    from lagrange_core.batch import _run_paused
    N, d = Y0.shape
    n = d // 2
    TS = np.ascontiguousarray(np.column_stack([t_start, t_end]))
    H = np.zeros(N)
    REF = np.zeros((N, n))
    YF = np.full((N, d), np.nan)
    TF = np.full(N, np.nan)
    SQ = np.full((N, max(K, 1), d), np.nan)
    QM = np.zeros((N, n))
    DEV = np.zeros((N, n))
    nan = np.full(N, np.nan)
    EXITC = np.full(N, -1, dtype=np.int64)
    COUNTS = np.zeros((N, 3), dtype=np.int64)
    ERR = np.zeros(N)
    STATUS = np.full(N, _NOT_RUN, dtype=np.int64)
    flags = 1 if K else 0

    def call(idx, budget, slot, save, savei):
        _fl.grid_dop853_lanes(ka, 0, True, idx, Y0, P, TS, H, T, REF, REF, REF, flags, rtol,
                              atol, max_steps, *tables, YF, TF, SQ, QM, DEV, nan, EXITC, nan,
                              COUNTS, ERR, STATUS, budget, KERNEL_STOP, slot, save, savei)

    with defer_ctrl_c():
        _, interrupted = _run_paused(call, N, TS, TF, STATUS, _save_width(n), progress,
                                     call_points())
    return YF, SQ, STATUS, interrupted


def _save_width(n):
    """Floats of a paused point's saved state in grid_dop853_lanes (point_dop853's layout:
    y, f(y), t, its compensation, h, the error sum, two unused, the next sample's index,
    the rejected flag)."""
    return 4 * n + 8


def strobe_runs_lanes(system, params, Q0, V0, T, t0, transient, periods, rtol, atol,
                      max_steps, progress):
    """As ``_sections._strobe_runs`` (same arguments but ``method``, same returns), on
    lanes.  A point that failed in the transient keeps that status and NaN samples."""
    n = system.n_dof
    names = system.parameters
    pv = {k: np.asarray(params[k], dtype=float) for k in names}
    T = np.asarray(T, dtype=float)
    S = np.broadcast_shapes(Q0.shape[:-1], V0.shape[:-1], T.shape,
                            *(v.shape for v in pv.values()))
    N = int(np.prod(S, dtype=np.int64))

    def flat(a, tail=()):
        return point_rows(a, S, tail)       # (a writable copy: see point_rows)

    Y = np.hstack([flat(Q0, (n,)), flat(V0, (n,))])
    P = np.ascontiguousarray(np.stack([flat(pv[k]) for k in names], axis=1).reshape(N, -1))
    Tf = flat(T)
    ka = system.kernels.addresses("rhs")
    tables = _dop853()
    # checked as simulate_grid checks it (the scalar path's)
    max_steps = _NEVER if max_steps is None else whole_number(max_steps, "max_steps", 1)
    t_begin = np.full(N, float(t0))
    q = np.full((N, periods, n), np.nan)
    qdot = np.full((N, periods, n), np.nan)
    status = np.full(N, _NOT_RUN, dtype=np.int64)
    start = t_begin
    pending = np.arange(N, dtype=np.int64)
    if transient:
        start = t_begin + transient * Tf
        Y, _, status, interrupted = _run(ka, Y, P, t_begin, start, Tf, 0, rtol, atol,
                                         max_steps, progress, tables)
        if interrupted:
            # no sample taken yet: nothing to keep (as _strobe_runs)
            names_ = np.full(S, "not_run", dtype=object)
            return (q.reshape(S + (periods, n)), qdot.reshape(S + (periods, n)), names_,
                    "dop853", True)
        pending = pending[status == _FINISHED]
    # a span of (periods − 1) T gives samples k = 0 … periods − 1; a single sample needs a
    # span: run a tenth of a period past it (as _strobe_runs).  Only the points that
    # finished their transient run on (the others keep its status and NaN samples).
    span = (periods - 1) * Tf if periods > 1 else 0.1 * Tf
    _, SQ, st2, interrupted = _run(ka, np.ascontiguousarray(Y[pending]),
                                   np.ascontiguousarray(P[pending]), start[pending],
                                   (start + span)[pending], Tf[pending], periods, rtol, atol,
                                   max_steps, progress, tables)
    status[pending] = st2
    q[pending] = SQ[:, :periods, :n]
    qdot[pending] = SQ[:, :periods, n:]
    names_ = np.asarray(STATUS_NAMES, dtype=object)[status].reshape(S)
    return (q.reshape(S + (periods, n)), qdot.reshape(S + (periods, n)), names_, "dop853",
            interrupted)
