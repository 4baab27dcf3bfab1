"""Lyapunov exponents of driven systems: one trajectory's spectrum, and chaos maps over grids.

Method
------
The exponents λ_1 ≥ … ≥ λ_2n of a trajectory y(t) of y′ = f(t, y) are the mean growth
rates of the tangent flow v′ = J(t, y(t)) v along it.  Benettin's method (Benettin,
Galgani, Giorgilli & Strelcyn, Meccanica 15, 9 and 21, 1980): integrate y and k tangent
vectors together, re-orthonormalise them (V = QR), and average log R_cc over time.  The
compiled kernel (:mod:`kapitza.chaos._kernels`) integrates [y, V] with DOP853 under one
error control, with J the system's exact compiled Jacobian (or, with
``tangent="difference"``, J v by a directional difference of the equations), and
re-orthonormalises after every step — the same sums as once per drive period, in exact
arithmetic, without the columns collapsing in between.  ``transient`` drive periods run
first and are discarded: the trajectory settles on its attractor and the basis aligns
with the leading directions.  The record of ``periods`` drive periods is cut into
intervals (``every`` periods each; their running estimate is kept for convergence plots).

The error estimate, and what it bounds
--------------------------------------
The record is cut into B blocks (default 8); each block's exponents are an estimate of
their own, and ``error`` = 2.5 s_B/√B, with s_B the blocks' standard deviation, plus the
integration's share (rtol + atol) × steps / time (the sum of the local tolerances per
unit time: a bound on the drift of log‖v‖ if every step's error pushed the same way).

* For a chaotic trajectory this is the batch-means confidence interval of the time
  average: about 95 % (Student's t for 7 degrees of freedom is 2.36) when the blocks are
  longer than the correlation time of the finite-time exponents, which a record of
  hundreds of drive periods per block is.  The error shrinks as 1/√(record).
* For a regular trajectory (a periodic or quasi-periodic attractor, an equilibrium) the
  blocks differ only by the bounded wobble of log‖v‖ over an orbit (complex multipliers
  turn v), O(1/block time), so the spread is a bound on the error of the mean, which is
  O(1/record).  A stable periodic orbit's λ_1 is log|μ_max|/T of its Floquet
  multipliers; tests check it against :func:`kapitza.floquet_point`.
* The full spectrum's sum is the mean of tr J (the phase-space contraction rate: −γ for
  the damped pendulum, 0 for a Hamiltonian system) to the integration error; its blocks
  estimate it with the exponents' fluctuations cancelled (``sum_error``).

Not included: the bias of ``tangent="difference"`` (about √eps ≈ 1.5e-8 of the
tangent's instantaneous rates |J v|/|v|), and the fact that a finite record cannot tell a
long transient from the attractor (a trajectory that leaves a chaotic saddle after the
record ends, or a quasi-periodic exponent of 0 from a slowly decaying one).

Speed
-----
:func:`lyapunov_grid` runs each chunk of points as compiled GIL-free calls on numba's
thread count, a block of points per call (parameters, states and results as arrays; no
Python per step or point);
``benchmarks/bench_chaos.py`` measures it against a loop of :func:`lyapunov`.  For an
unconstrained system of up to six coordinates it runs on *lanes*
(:mod:`kapitza.chaos._lanes`): 64 points per thread advanced together, every loop over
them vectorised, the equations and J v evaluated for all of them by one call of the
system's generated lanes kernel (:mod:`lagrange_core._rhs_lanes`: sin and cos as
branch-free polynomials, J v by forward mode on the same formulas in the same pass —
exact, at about 1.6 times the cost of the equations alone).  There the exact J v is the
fastest tangent, and the default.  Elsewhere the points run one per thread
(:mod:`kapitza.chaos._kernels`), where the exact Jacobian (forward-mode derivatives of
the statement's entries and a solve, its scratch allocated on every call) costs about
ten evaluations of the equations: the default there is J v by a directional difference
(one evaluation per stage; relative error ~1e-8).  :func:`lyapunov` (one trajectory, k
vectors) runs per point and uses the exact Jacobian by default (the identities of the
tests hold to 1e-10).
"""
from __future__ import annotations

import math
import time
import warnings

import numpy as np

from lagrange_core._compile_notice import activity
from lagrange_core.batch import STATUS_NAMES, _run_paused, point_rows
from lagrange_core.checks import real_number
from lagrange_core.progress import KERNEL_STOP, defer_ctrl_c, run_in_chunks

from .._arguments import check_grid_memory, whole_number
from ..results import ComputationInterrupted, LyapunovGrid, LyapunovSpectrum
from . import _kernels as _k
from . import _lanes as _lk
from ._common import (
    block_error,
    drive_frequency,
    generic_basis,
    parameters,
    record_stops,
    state,
    tolerances,
    unconstrained,
)

__all__ = ["lyapunov", "lyapunov_grid"]

_TANGENTS = ("jacobian", "difference")


def _dop853():
    from lagrange_core.integrate import METHODS
    tab = METHODS["dop853"].table
    return tab["A"], tab["B"], tab["C"], tab["E3"], tab["E5"]


def _lanes(system, jvp=False):
    """Whether the system has lanes kernels (:mod:`lagrange_core._rhs_lanes`: unconstrained,
    small enough); their slots are then in ``system.kernels``' address table (with ``jvp``
    the Jacobian–vector kernel's too)."""
    from lagrange_core._rhs_lanes import load_rhs_lanes
    return not system.n_constraints and load_rhs_lanes(system.kernels, jvp=jvp)[0]


def _addresses(system, tangent, where, lanes=False):
    if tangent not in _TANGENTS:
        allowed = list(_TANGENTS) + ([None] if where == "lyapunov_grid" else [])
        raise ValueError(f"{where}: tangent must be one of {allowed}, got {tangent!r}.")
    slots = ("rhs", "jacobian") if tangent == "jacobian" and not lanes else ("rhs",)
    return system.kernels.addresses(*slots)


def _count(exponents, d, where):
    """k, the number of exponents asked for."""
    if exponents == "all":
        return d
    if exponents == "largest":
        return 1
    k = whole_number(exponents, "exponents", 1)
    if k > d:
        raise ValueError(f"{where}: exponents={k} but the phase space has only {d} "
                         "dimensions; ask for 'all' (or fewer).")
    return k


class _Stopped(Exception):
    """The kernel stopped a run (a non-finite state, a step below resolution, ...)."""


def lyapunov(system, params, q0, qdot0=0.0, *, periods=1000, transient=100, exponents="all",
             every=1, blocks=8, frequency="omega", t0=0.0, tangent="jacobian", rtol=1e-9,
             atol=None, max_steps=None, progress=None) -> LyapunovSpectrum:
    """The Lyapunov exponents of one trajectory of a driven system, with their error.

    Parameters
    ----------
    system : lagrange_core.System
        Unconstrained, driven with angular frequency ``params[frequency]`` (T = 2π/ω).
    params : dict
        Every parameter (scalars, SI).
    q0, qdot0 : array_like (n,), float or dict coordinate -> value
        The initial state at ``t0``.
    periods : int
        Drive periods of the record the exponents average over.
    transient : int
        Drive periods run first and discarded (settling on the attractor, aligning the
        tangent basis).
    exponents : "all", "largest" or int
        How many: all 2n (the full spectrum: small systems), the largest (large ones), or
        the k largest.
    every : int
        Drive periods per recorded interval of the running estimate (``running``).
    blocks : int
        B ≥ 2 blocks of the record whose spread is the error estimate.
    frequency : str or float
        The drive's angular-frequency parameter, or ω (rad/s).
    t0 : float
        Start time (s): the drive's phase at the start.
    tangent : {"jacobian", "difference"}
        J v from the exact compiled Jacobian, or a directional difference of the
        equations (faster; relative error ~1e-8).
    rtol, atol : float
        DOP853's tolerances on the trajectory and the (orthonormal) tangent vectors.
    max_steps : int, optional
        Step budget.
    progress : None, bool or callable
        As :func:`lagrange_core.progress.run_in_chunks` (a line on stderr when it is a
        terminal).

    Returns
    -------
    kapitza.results.LyapunovSpectrum
        Exponents (1/s) with ``error`` (the module docstring says how it bounds), the
        block estimates and the running estimate.

    Raises
    ------
    ValueError
        Bad input, a constrained system.
    FloatingPointError
        The run failed before the record began (a non-finite state, a step size below
        resolution, a singular mass matrix, the step budget); a failure later is warned
        about and the exponents are those of the record so far (``status``).
    kapitza.results.ComputationInterrupted
        On Ctrl-C, with the exponents of the record so far in ``.result``.

    Examples
    --------
    The damped driven pendulum θ̈ + θ̇/Q + sin θ = F cos ω_d t at Q = 2, F = 1.5,
    ω_d = 2/3 (units of ω0 = 1) is chaotic: λ_1 > 0, and λ_1 + λ_2 = −1/Q exactly.

    >>> import sympy as sp
    >>> from lagrange_core import System, coordinates, t
    >>> (th,), (thd,) = coordinates("theta")
    >>> Q, F, w = sp.symbols("Q F omega", positive=True)
    >>> ddp = System([th], lagrangian=thd**2 / 2 + sp.cos(th), dissipation=thd**2 / (2 * Q),
    ...              forces={th: F * sp.cos(w * t)})
    >>> s = lyapunov(ddp, dict(Q=2.0, F=1.5, omega=2 / 3), 0.2, periods=500, progress=False)
    >>> bool(s.exponents[0] > 0), round(float(s.exponents.sum()), 9)
    (True, -0.5)
    """
    where = "lyapunov"
    start_clock = time.perf_counter()
    unconstrained(system, where)
    pv = parameters(system, params, where, scalar=True)
    omega = float(drive_frequency(system, pv, frequency, where))
    T = 2 * math.pi / omega
    n = system.n_dof
    d = 2 * n
    y = np.concatenate([state(system, q0, "q0", single=True),
                        state(system, qdot0, "qdot0", single=True)])
    k = _count(exponents, d, where)
    periods = whole_number(periods, "periods", 1)
    transient = whole_number(transient, "transient", 0)
    every = whole_number(every, "every", 1)
    blocks = whole_number(blocks, "blocks", 2)
    t0 = real_number(t0, "t0", unit="s")
    rtol, atol = tolerances(rtol, atol)
    budget = (1 << 62) if max_steps is None else whole_number(max_steps, "max_steps", 1)
    intervals = -(-periods // every)
    if intervals < blocks:
        raise ValueError(f"{where}: {periods} periods in intervals of every={every} give "
                         f"{intervals} intervals, fewer than blocks={blocks}; lengthen the "
                         "record or shorten every.")
    ka = _addresses(system, tangent, where)
    p = system.parameter_array({name: float(v) for name, v in pv.items()})
    stops = record_stops(transient, periods, intervals)
    first = 1 if transient else 0
    V = generic_basis(d, k)
    logs = np.zeros((stops.size, k))
    counts = np.zeros(3, dtype=np.int64)
    tv = np.array([t0, 0.0])
    status = np.array([_k.FINISHED])
    y_start = y.copy()
    tables = _dop853()

    def work(a, b):
        status[0] = _k.advance(ka, tangent == "jacobian", p, T, t0, stops, a, b, y, V, tv,
                               rtol, atol, budget, *tables, logs, counts)
        if status[0] != _k.FINISHED:
            raise _Stopped

    stopped = False
    with defer_ctrl_c():
        try:
            done, interrupted = run_in_chunks(work, stops.size, progress=progress,
                                              label=where, unit="intervals", first=4)
        except _Stopped:
            stopped, interrupted = True, False
            done = int(np.searchsorted(stops, (tv[0] - t0) / T * (1 + 1e-12), side="right"))
    recorded = max(0, done - first)
    if recorded == 0 and not interrupted:
        raise FloatingPointError(
            f"{where}: the run stopped ({STATUS_NAMES[status[0]]}) at t = {tv[0]:.6g} s, before "
            f"the record began (after {transient} transient periods); check the parameters and "
            "the initial state, or raise max_steps.")
    rec = slice(first, first + recorded)
    lengths = np.diff(np.concatenate([[0.0], stops]))[rec] * T
    result = _spectrum(system, pv, y_start, y, t0, float(tv[0]), T, logs[rec], lengths,
                       transient, every, blocks, k == d, tangent, rtol, atol, counts,
                       STATUS_NAMES[status[0]], start_clock)
    if interrupted:
        raise ComputationInterrupted(result, np.array(recorded > 0))
    if stopped:
        warnings.warn(f"{where}: the run stopped ({result.status}) at t = {tv[0]:.6g} s; the "
                      f"exponents are those of the first {result.periods} of {periods} record "
                      "periods.", RuntimeWarning, stacklevel=2)
    return result


def _spectrum(system, pv, y_start, y, t0, t_final, T, logs, lengths, transient, every, blocks,
              complete, tangent, rtol, atol, counts, status, start_clock) -> LyapunovSpectrum:
    """The spectrum of the record's intervals ``logs`` (m, k) of ``lengths`` (m,) seconds."""
    n = system.n_dof
    k = logs.shape[1]
    if logs.shape[0]:
        lam, err, per_block, sum_err = block_error(logs, lengths, blocks)
        # the integration's share: the local tolerances summed per unit time
        drift = (rtol + atol) * counts[_k.STEPS] / max(t_final - t0, 1e-300)
        err, sum_err = err + drift, sum_err + k * drift
        times = np.cumsum(lengths)
        running = np.cumsum(logs, axis=0) / times[:, None]
    else:
        lam = err = np.full(k, np.nan)
        per_block = np.zeros((0, k))
        sum_err = math.nan
        times = np.zeros(0)
        running = np.zeros((0, k))
    return LyapunovSpectrum(
        exponents=lam, error=err, sum_error=float(sum_err), complete=complete, period=T,
        periods=int(round(float(lengths.sum()) / T)), transient=transient, every=every,
        blocks=per_block.shape[0], block_exponents=per_block, times=times, running=running,
        coordinates=tuple(system.coordinates), params={name: float(v) for name, v in pv.items()},
        q0=y_start[:n].copy(), qdot0=y_start[n:].copy(), q=y[:n].copy(), qdot=y[n:].copy(),
        t0=t0, t_final=t_final, tangent=tangent, rtol=rtol, atol=atol,
        steps=int(counts[_k.STEPS]), rejected=int(counts[_k.REJECTED]), status=status,
        wall_time=time.perf_counter() - start_clock)


@activity("Lyapunov map")     # a first compile says how long the whole map compiles
def lyapunov_grid(system, params, q0, qdot0=0.0, *, periods=2000, transient=200, blocks=8,
                  frequency="omega", t0=0.0, tangent=None, rtol=1e-6, atol=None,
                  max_steps=None, progress=None) -> LyapunovGrid:
    """The largest Lyapunov exponent over a broadcast grid of parameters and initial states:
    a chaos map, in compiled parallel code.

    Parameters
    ----------
    system : lagrange_core.System
        Unconstrained, driven with angular frequency ``params[frequency]``.
    params : dict
        Every parameter: scalars or arrays that broadcast with each other and with ``q0``
        and ``qdot0`` (``A=A[:, None], omega=omega[None, :]`` for an (A, ω) map).
    q0, qdot0 : array_like (..., n), float or dict coordinate -> value(s)
        Initial states at ``t0`` (for a system of one coordinate any array).
    periods, transient : int
        Drive periods of the record (per point, its own T), and before it (discarded).
    blocks : int
        B ≥ 2: the record is run as B intervals whose spread is the error estimate.
    frequency, t0, rtol, atol, max_steps, progress
        As :func:`lyapunov` (``max_steps`` per point); rtol defaults to 1e-6 here (the
        exponent of a chaotic point is a statistical quantity: its error over 2000 periods
        is far above the integration's).
    tangent : {None, "jacobian", "difference"}
        J v exactly ("jacobian") or by a directional difference of the equations
        ("difference"; relative error ~1e-8, far below a map's statistical error).  None
        (default): the fastest — exact on lanes (the module docstring: systems of up to six
        coordinates without constraints), the difference per point elsewhere (where the
        exact Jacobian costs three to four times as much).  The result's ``tangent`` says
        which ran.

    Returns
    -------
    kapitza.results.LyapunovGrid
        λ_max and its error per point (NaN where a run failed: ``status``); ``figure()``
        draws the map.

    Raises
    ------
    ValueError
        Bad input.
    kapitza.results.ComputationInterrupted
        On Ctrl-C: ``.result`` holds the finished points, ``.computed`` marks them.

    Notes
    -----
    Where it runs: a system without constraints, of at most six coordinates, whose
    equations have lanes kernels (:mod:`lagrange_core._rhs_lanes`: at most 1500
    operations) runs on lanes (:mod:`kapitza.chaos._lanes`, 64 points per thread
    vectorised; on the damped pendulum's 100 × 100 map ~5× less CPU time than per point,
    benchmarks/README.md; a grid of fewer points than a few hundred leaves lanes empty and
    gains less); its calls last ~0.25 s, a long run paused after a step budget
    and resumed in the next call (the same steps as unbroken), so Ctrl-C stops within
    about a second whatever ``periods``.  Any other system runs one point per thread
    (:mod:`kapitza.chaos._kernels`) in chunks sized to ~0.25 s, where a point's run is
    not cut: Ctrl-C waits for the points running.  :func:`lyapunov` (one trajectory)
    always runs per point: lanes pay only across many trajectories.
    """
    where = "lyapunov_grid"
    start_clock = time.perf_counter()
    unconstrained(system, where)
    pv = parameters(system, params, where, scalar=False)
    omega = drive_frequency(system, pv, frequency, where)
    Q0 = state(system, q0, "q0")
    V0 = state(system, qdot0, "qdot0")
    periods = whole_number(periods, "periods", 1)
    transient = whole_number(transient, "transient", 0)
    blocks = whole_number(blocks, "blocks", 2)
    if periods < blocks:
        raise ValueError(f"{where}: periods={periods} must be at least blocks={blocks}.")
    t0 = real_number(t0, "t0", unit="s")
    rtol, atol = tolerances(rtol, atol)
    budget = (1 << 62) if max_steps is None else whole_number(max_steps, "max_steps", 1)
    shapes = [v.shape for v in pv.values()] + [omega.shape, Q0.shape[:-1], V0.shape[:-1]]
    try:
        S = np.broadcast_shapes(*shapes)
    except ValueError:
        raise ValueError(f"{where}: the parameters and initial states do not broadcast "
                         f"together (shapes {shapes}); give each axis its own dimension, e.g. "
                         "A[:, None] and omega[None, :].") from None
    N = int(np.prod(S, dtype=np.int64))
    n = system.n_dof
    d = 2 * n
    # refused before any work where its arrays cannot fit: per point the state, tangent,
    # logs and results (measured 353 bytes with tracemalloc for n = 1, blocks = 8)
    check_grid_memory("params, q0, qdot0 (broadcast)", S, 8.0 * (24 * n + blocks + 40),
                      where=f"{where}: ", fix="use a coarser grid, or compute it in parts "
                      "(a few rows of A at a time) and join them")
    # the exact tangent (the default on lanes) needs the Jacobian–vector lanes kernel too
    lanes = _lanes(system, jvp=tangent in (None, "jacobian"))
    if tangent is None:
        tangent = "jacobian" if lanes else "difference"
    ka = _addresses(system, tangent, where, lanes)
    names = system.parameters

    def flat(a, tail=()):
        return point_rows(a, S, tail)       # (a writable copy: see point_rows)

    Y0 = np.hstack([flat(Q0, (n,)), flat(V0, (n,))])
    P = np.stack([flat(pv[name]) for name in names], axis=1) if names else np.zeros((N, 0))
    P = np.ascontiguousarray(P.reshape(N, len(names)))
    T = 2 * np.pi / flat(omega)
    T0 = np.full(N, t0)
    stops = record_stops(transient, periods, blocks)
    first = 1 if transient else 0
    LOGS = np.zeros((N, stops.size))
    YF = np.full((N, d), np.nan)
    TF = np.full(N, np.nan)
    COUNTS = np.zeros((N, 3), dtype=np.int64)
    STATUS = np.full(N, _k.NOT_RUN, dtype=np.int64)
    v0 = np.ascontiguousarray(generic_basis(d, 1)[:, 0])
    tables = _dop853()
    exact = tangent == "jacobian"

    mode = _lk.JVP if exact else _lk.DIFFERENCE

    def work(a, b):
        _k.grid_largest(ka, exact, np.arange(a, b, dtype=np.int64), Y0, P, T, T0, stops, v0,
                        rtol, atol, budget, *tables, LOGS, YF, TF, COUNTS, STATUS)

    def call(idx, steps, slot, save, savei):
        _lk.grid_largest_lanes(ka, mode, idx, Y0, P, T, T0, stops, v0, rtol, atol, budget,
                               *tables, LOGS, YF, TF, COUNTS, STATUS, steps, KERNEL_STOP, slot,
                               save, savei)

    import numba
    with defer_ctrl_c():
        if lanes:
            # as simulate_grid: calls of ~0.25 s, a long run paused after a step budget and
            # resumed, so Ctrl-C stops within a second whatever the periods
            TS = np.column_stack([T0, T0 + stops[-1] * T])
            done, interrupted = _run_paused(call, N, TS, TF, STATUS, _lk.save_width(n),
                                            progress, _lk.call_points(), label=where)
            if interrupted:             # a paused point is not finished: as never run
                paused = STATUS == _lk.INTERRUPTED
                STATUS[paused] = _k.NOT_RUN
                LOGS[paused] = 0.0
                YF[paused] = np.nan
                TF[paused] = np.nan
                COUNTS[paused] = 0
        else:
            done, interrupted = run_in_chunks(work, N, progress=progress, label=where,
                                              first=4 * numba.get_num_threads())
    ok = STATUS == _k.FINISHED
    lengths = np.diff(np.concatenate([[0.0], stops]))[first:]          # periods per block
    per_block = LOGS[:, first:] / (lengths[None, :] * T[:, None])
    with np.errstate(invalid="ignore", divide="ignore"):
        lam = LOGS[:, first:].sum(axis=1) / (periods * T)
        err = 2.5 * per_block.std(axis=1, ddof=1) / math.sqrt(blocks) \
            + (rtol + atol) * COUNTS[:, _k.STEPS] / (TF - T0)
    lam[~ok] = np.nan
    err[~ok] = np.nan
    per_block[~ok] = np.nan
    result = LyapunovGrid(
        shape=S, params={name: np.broadcast_to(v, S) for name, v in pv.items()},
        coordinates=tuple(system.coordinates), exponent=lam.reshape(S), error=err.reshape(S),
        period=T.reshape(S), periods=periods, transient=transient, blocks=blocks,
        block_exponents=per_block.reshape(S + (blocks,)), q0=Y0[:, :n].reshape(S + (n,)),
        qdot0=Y0[:, n:].reshape(S + (n,)), q=YF[:, :n].reshape(S + (n,)),
        qdot=YF[:, n:].reshape(S + (n,)),
        status=np.asarray(STATUS_NAMES, dtype=object)[STATUS].reshape(S),
        steps=COUNTS[:, _k.STEPS].reshape(S), tangent=tangent, rtol=rtol, atol=atol,
        wall_time=time.perf_counter() - start_clock)
    if interrupted:
        raise ComputationInterrupted(result, (STATUS != _k.NOT_RUN).reshape(S))
    failed = ~ok & (STATUS != _k.NOT_RUN)
    if failed.any():
        counts = {STATUS_NAMES[c]: int(np.sum(STATUS == c)) for c in np.unique(STATUS[failed])}
        warnings.warn(f"{where}: {int(failed.sum())} of {N} runs failed ({counts}); their "
                      "exponents are NaN (status says why).", RuntimeWarning, stacklevel=2)
    return result
