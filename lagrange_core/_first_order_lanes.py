"""DOP853 on *lanes*: many trajectories of a first-order system per thread, vectorised.

What it is
----------
:func:`grid_dop853_lanes` is :func:`lagrange_core._batch_kernels.grid_dop853` (the
per-point DOP853 of ``simulate_grid`` for systems that are not of the form q̈ = f(q, t):
damped, velocity-dependent) for unconstrained systems, written the way the RKN path's
:func:`~lagrange_core._batch_kernels.grid_rkn_lanes` is: a thread advances :data:`LANES`
points together, every array has the lane as its last axis, and every loop over lanes
is innermost and free of calls, so LLVM vectorises it:

* the right-hand side of all lanes is one call per stage of the system's generated
  ``rhs_lanes`` (:mod:`lagrange_core._rhs_lanes`: sin/cos by the branch-free polynomials
  of :mod:`lagrange_core._lane_math`, a lane that fails computed again by the scalar
  ``rhs``: :mod:`lagrange_core._lane_calls`);
* the stage sums, the error norm, the acceptance, the step-size control (err^(−1/8) as
  three square roots: no call), the compensated time, the time mean and the deviation
  are loops over lanes;
* what is particular to a lane — a strobe sample, a failure, the end of its run and the
  next point in its place (taken from a cursor the threads share:
  :mod:`lagrange_core._shared_cursor`) — runs for that lane alone.

Same algorithm, statuses, counts and observables as ``point_dop853`` (final state,
strobe samples, time mean of q, max deviation from a reference, sum of the local error
estimates), to rounding: sin/cos are within 2 ulp of libm, the step factor's root
differs from ``pow`` by an ulp, multiply-adds are fused, and a one-coordinate system's
q̈ = F/M is simplified symbolically.  The error estimate, a difference of nearly equal
sums, carries such rounding to ~1e-7 of a step: the steps are the same in number, their
ends up to that far apart (what is sampled at step ends — the deviation, the mean —
differs by as much; tests/test_first_order_lanes.py).  A band exit is located on the
step's cubic Hermite interpolant, as ``point_dop853`` does.  Not here (the caller runs
``grid_dop853``): constraints (projection), energy drift, the fixed-step "rk8".
``System.simulate_grid`` runs this driver for grids of
:data:`lagrange_core.batch.FIRST_ORDER_LANES_MIN_POINTS` points or more.

Why: the scalar path makes ~12 calls of ``rhs`` per step, each bound by libm's sin/cos
and unable to overlap the next; benchmarks/README.md ("The chaos room against issue
21.6's targets") measured 56–63 ns per call inside the kernel.  The shared stage helpers
below are also used by the chaos room's Lyapunov driver (kapitza.chaos._lanes), which
integrates a tangent vector beside each trajectory.

A lane's result does not depend on its neighbours: nothing is shared between lanes but
the loop, and a failed lane gets its status alone (tests/test_first_order_lanes.py).
"""
import math
import sys

import numpy as np
from numba import njit

from ._batch_kernels import DRAINED, _band_exit, _hermite, lanes_pause_now
from ._integrator_kernels import FAST_MATH, starting_step
from ._kernel_calls import RHS, call_rhs
from ._lane_calls import rhs_on_lanes
from ._shared_cursor import peek, take
from ._thread_blocks import run_draining, run_shared

__all__ = ["LANES", "grid_dop853_lanes", "sparse_tables", "stage_sum", "error_sums",
           "step_factor", "first_step"]

#: trajectories a thread advances together (a multiple of the SIMD width; 13 stages × 2n
#: rows × 128 lanes of a pendulum, 27 kB, stay in the first-level cache).  The damped
#: pendulum's 100 × 100 Lyapunov map (benchmarks/bench_chaos.py): 15.7–17.6 s with 128
#: lanes, 18.8–19.5 s with 64; 2- and 4-link chains within ±5 % either way (2026-11-28)
LANES = 128
# statuses as lagrange_core._batch_kernels (GRID_*): finished, underflow, non-finite,
# singular, step budget, not run
_FINISHED, _LEFT_BAND, _UNDERFLOW, _NON_FINITE, _SINGULAR, _MAX_STEPS, _INTERRUPTED = \
    0, 1, 2, 3, 4, 5, 7
#: SAVEI[·, _SAVED] = 1: the row holds a paused point's state (as _batch_kernels.SAVED);
#: DRAINED (2) + a thread's number: paused by that thread's lanes when they drained, run
#: on at once (:func:`_grid`)
_SAVED = 0
# columns of COUNTS, bits of flags (as _batch_kernels)
_STEPS, _REJECTED, _EVALS = 0, 1, 2
_OBS_STROBE, _OBS_REF, _OBS_BAND = 1, 2, 4
_EPS = 2.220446049250313e-16


@njit(cache=True)
def sparse_tables(A, B, E5, E3):
    """DOP853's coefficients as short lists of their nonzero terms, padded to pairs.

    Returns (idx, coef, pairs): row s = 1 … 11 of ``idx``/``coef`` lists the stages m < s
    with A[s, m] ≠ 0 and their coefficients, row 12 those of B (the 8th-order solution),
    row 0 those of E5 (coef) and E3 (``coef[13]``) — one list for both error estimates;
    a pair's padding is stage 0 with coefficient 0 (K[0] is always finite, so it adds an
    exact zero).  ``pairs[s]`` is the number of pairs.  Summing the nonzero terms in
    registers, pair by pair, is ~3× cheaper than an accumulator in memory over every m."""
    idx = np.zeros((13, 12), dtype=np.int64)
    coef = np.zeros((14, 12))
    pairs = np.zeros(13, dtype=np.int64)
    for s in range(13):
        c = 0
        for m in range(13 if s == 0 else s):
            a = (E5[m] if s == 0 else (B[m] if s == 12 else A[s, m]))
            a3 = E3[m] if s == 0 else 0.0
            if a != 0.0 or a3 != 0.0:
                idx[s, c] = m
                coef[s, c] = a
                if s == 0:
                    coef[13, c] = a3
                c += 1
        pairs[s] = (c + 1) // 2
    return idx, coef, pairs


@njit(cache=True, fastmath=FAST_MATH, error_model="numpy")
def stage_sum(idx, coef, pairs, K, y, hs, out, L):
    """out = y + hs Σ coef[k] K[idx[k]] for every row and lane: a stage's state (``idx``,
    ``coef``, ``pairs`` a row of :func:`sparse_tables`), the sum in registers over the
    nonzero terms in their order (up to 12)."""
    d = y.shape[0]
    m0, m1, m2, m3, m4, m5 = idx[0], idx[1], idx[2], idx[3], idx[4], idx[5]
    m6, m7, m8, m9, m10, m11 = idx[6], idx[7], idx[8], idx[9], idx[10], idx[11]
    c0, c1, c2, c3, c4, c5 = coef[0], coef[1], coef[2], coef[3], coef[4], coef[5]
    c6, c7, c8, c9, c10, c11 = coef[6], coef[7], coef[8], coef[9], coef[10], coef[11]
    for i in range(d):
        if pairs == 1:
            for l in range(L):
                x = c0 * K[m0, i, l] + c1 * K[m1, i, l]
                out[i, l] = y[i, l] + hs[l] * x
        elif pairs == 2:
            for l in range(L):
                x = c0 * K[m0, i, l] + c1 * K[m1, i, l]
                x += c2 * K[m2, i, l]
                x += c3 * K[m3, i, l]
                out[i, l] = y[i, l] + hs[l] * x
        elif pairs == 3:
            for l in range(L):
                x = c0 * K[m0, i, l] + c1 * K[m1, i, l]
                x += c2 * K[m2, i, l]
                x += c3 * K[m3, i, l]
                x += c4 * K[m4, i, l]
                x += c5 * K[m5, i, l]
                out[i, l] = y[i, l] + hs[l] * x
        elif pairs == 4:
            for l in range(L):
                x = c0 * K[m0, i, l] + c1 * K[m1, i, l]
                x += c2 * K[m2, i, l]
                x += c3 * K[m3, i, l]
                x += c4 * K[m4, i, l]
                x += c5 * K[m5, i, l]
                x += c6 * K[m6, i, l]
                x += c7 * K[m7, i, l]
                out[i, l] = y[i, l] + hs[l] * x
        elif pairs == 5:
            for l in range(L):
                x = c0 * K[m0, i, l] + c1 * K[m1, i, l]
                x += c2 * K[m2, i, l]
                x += c3 * K[m3, i, l]
                x += c4 * K[m4, i, l]
                x += c5 * K[m5, i, l]
                x += c6 * K[m6, i, l]
                x += c7 * K[m7, i, l]
                x += c8 * K[m8, i, l]
                x += c9 * K[m9, i, l]
                out[i, l] = y[i, l] + hs[l] * x
        else:
            for l in range(L):
                x = c0 * K[m0, i, l] + c1 * K[m1, i, l]
                x += c2 * K[m2, i, l]
                x += c3 * K[m3, i, l]
                x += c4 * K[m4, i, l]
                x += c5 * K[m5, i, l]
                x += c6 * K[m6, i, l]
                x += c7 * K[m7, i, l]
                x += c8 * K[m8, i, l]
                x += c9 * K[m9, i, l]
                x += c10 * K[m10, i, l]
                x += c11 * K[m11, i, l]
                out[i, l] = y[i, l] + hs[l] * x


@njit(cache=True, fastmath=FAST_MATH, error_model="numpy")
def error_sums(idx, coef, K, y, ynew, hs, rtol, atol, e5, e3, est, fin, L):
    """Add the rows of ``y``'s error to DOP853's norms: e5 += Σ (hs E5·K / sc)², e3 likewise,
    sc = atol + rtol max(|y|, |ynew|); ``est`` gets the largest local error estimate
    (as ``point_dop853``: a5²/√(a5² + a3²/100)); ``fin`` &= ynew finite.  ``idx``, ``coef``
    are row 0 of :func:`sparse_tables` (``coef`` rows 0 and 13: E5 and E3; 8 terms)."""
    d = y.shape[0]
    m0, m1, m2, m3, m4, m5, m6, m7 = (idx[0], idx[1], idx[2], idx[3], idx[4], idx[5], idx[6],
                                      idx[7])
    a0, a1, a2, a3, a4, a5, a6, a7 = (coef[0, 0], coef[0, 1], coef[0, 2], coef[0, 3],
                                      coef[0, 4], coef[0, 5], coef[0, 6], coef[0, 7])
    b0, b1, b2, b3, b4, b5, b6, b7 = (coef[13, 0], coef[13, 1], coef[13, 2], coef[13, 3],
                                      coef[13, 4], coef[13, 5], coef[13, 6], coef[13, 7])
    for i in range(d):
        for l in range(L):
            k0 = K[m0, i, l]
            k1 = K[m1, i, l]
            k2 = K[m2, i, l]
            k3 = K[m3, i, l]
            k4 = K[m4, i, l]
            k5 = K[m5, i, l]
            k6 = K[m6, i, l]
            k7 = K[m7, i, l]
            x5 = a0 * k0 + a1 * k1
            x5 += a2 * k2
            x5 += a3 * k3
            x5 += a4 * k4
            x5 += a5 * k5
            x5 += a6 * k6
            x5 += a7 * k7
            x3 = b0 * k0 + b1 * k1
            x3 += b2 * k2
            x3 += b3 * k3
            x3 += b4 * k4
            x3 += b5 * k5
            x3 += b6 * k6
            x3 += b7 * k7
            x5 *= hs[l]
            x3 *= hs[l]
            sc = atol + rtol * max(abs(y[i, l]), abs(ynew[i, l]))
            e5[l] += (x5 / sc) ** 2
            e3[l] += (x3 / sc) ** 2
            den = x5 * x5 + 0.01 * x3 * x3
            est[l] = max(est[l], x5 * x5 / math.sqrt(den)) if den > 0.0 else est[l]
            fin[l] = fin[l] & math.isfinite(ynew[i, l])


@njit(cache=True)
def first_step(ka, t0, y0, f, p, rtol, atol, W, y1, f1):
    """Hairer's starting step (:func:`~lagrange_core._integrator_kernels.starting_step`, as
    the per-point drivers), or −1.0 when there is none: a state or derivative so large that
    its scaled norm overflows (starting_step would divide by zero), or a step that is not
    positive and finite (a derivative that is not finite a little way on; a zero step
    would never advance)."""
    d0 = 0.0
    d1 = 0.0
    for i in range(y0.shape[0]):
        sc = atol + abs(y0[i]) * rtol
        d0 += (y0[i] / sc) ** 2
        d1 += (f[i] / sc) ** 2
    if not (math.isfinite(d0) and math.isfinite(d1)):
        return -1.0
    h = starting_step(ka, t0, y0, f, p, rtol, atol, W, y1, f1, 1.0 / 8.0)
    return h if (h > 0.0 and math.isfinite(h)) else -1.0


@njit(cache=True, inline="always", fastmath=FAST_MATH, error_model="numpy")
def step_factor(err):
    """0.9 err^(−1/8), the DOP853 controller's factor before its limits, by three square
    roots (vectorised; ``pow`` is a libm call): inf for err = 0, 0 for err = inf."""
    return 0.9 / math.sqrt(math.sqrt(math.sqrt(err)))


@njit(cache=True, error_model="numpy")
def _load(ka, l, i, sv, svi, Y0, P, TS, H, TSTR, REF, LO, HI, flags, rtol, atol, y, K, Pl,
          t, tc, h, t0l, t1l, Tl, kn, QMl, DEVl, REFl, LOl, HIl, errsum, rejected, base, YF,
          SQ, QM, DEV, COUNTS, f, W, y1, f1):
    """Start point i in lane l — or resume it from its saved row ``sv``/``svi`` (a point
    paused by an earlier call: ``svi[0]`` = 1, the layout of ``point_dop853``'s) — its
    state, parameters, observables, f at the start (K[0], by the scalar ``rhs``, as
    ``point_dop853``) and its first step.  Returns 0, or the point's status when it
    cannot start (singular, or a derivative that is not finite)."""
    d = y.shape[0]
    n = d // 2
    p = P[i]
    for k in range(p.shape[0]):
        Pl[k, l] = p[k]
    t0 = TS[i, 0]
    t0l[l] = t0
    t1l[l] = TS[i, 1]
    Tl[l] = TSTR[i] if flags & _OBS_STROBE else 0.0
    base[l] = COUNTS[i, _STEPS]
    for j in range(n):
        REFl[j, l] = REF[i, j] if flags & _OBS_REF else 0.0
        LOl[j, l] = LO[i, j] if flags & _OBS_BAND else -np.inf
        HIl[j, l] = HI[i, j] if flags & _OBS_BAND else np.inf
    if svi[_SAVED] != 0:
        for j in range(d):
            y[j, l] = sv[j]
            K[0, j, l] = sv[d + j]
        o = 2 * d
        t[l] = sv[o]
        tc[l] = sv[o + 1]
        h[l] = sv[o + 2]
        errsum[l] = sv[o + 3]
        kn[l] = sv[o + 6]
        rejected[l] = sv[o + 7] != 0.0
        for j in range(n):
            QMl[j, l] = QM[i, j]
            DEVl[j, l] = DEV[i, j]
        svi[_SAVED] = 0
        return 0
    if call_rhs(ka[RHS], t0, Y0[i], p, f, W) != 0:
        return _SINGULAR
    COUNTS[i, _EVALS] += 1
    for j in range(d):
        if not math.isfinite(f[j]):
            return _NON_FINITE
    for j in range(d):
        y[j, l] = Y0[i, j]
        YF[i, j] = Y0[i, j]
        K[0, j, l] = f[j]
        if flags & _OBS_STROBE:
            SQ[i, 0, j] = Y0[i, j]
    for j in range(n):
        QMl[j, l] = 0.0
        DEVl[j, l] = abs(Y0[i, j] - REF[i, j]) if flags & _OBS_REF else 0.0
    t[l] = t0
    tc[l] = 0.0
    kn[l] = 1.0
    errsum[l] = 0.0
    rejected[l] = False
    if H[i] > 0.0:
        h[l] = H[i]
    else:
        h[l] = first_step(ka, t0, Y0[i], f, p, rtol, atol, W, y1, f1)
        COUNTS[i, _EVALS] += 2
        if h[l] < 0.0:
            return _NON_FINITE
    return 0


@njit(cache=True, error_model="numpy")
def _left_band(l, y, ynew, h, LOl, HIl, QMl, q0, q1, ye, lo, hi):
    """Where lane ``l``'s accepted step of length ``h`` left the band, as ``point_dop853``'s
    ``_observe``: the step fraction x and the coordinate of the first crossing of the step's
    cubic Hermite interpolant; the state there goes into ``y[:, l]`` and the time mean up
    to it into ``QMl[:, l]`` (``q0``, ``q1``, ``ye``, ``lo``, ``hi``: scratch).  Apart from
    the block's loop: written into it, this code made every step of the chaos room's strobe
    runs 3 % slower (2026-11-28)."""
    d = y.shape[0]
    n = d // 2
    for j in range(d):
        q0[j] = y[j, l]
        q1[j] = ynew[j, l]
    for j in range(n):
        lo[j] = LOl[j, l]
        hi[j] = HIl[j, l]
    x, jx = _band_exit(q0[:n], q0[n:], q1[:n], q1[n:], h, lo, hi)
    for j in range(n):
        ye[j], ye[n + j] = _hermite(q0[j], q0[n + j], q1[j], q1[n + j], h, x)
    xh = x * h
    for j in range(n):
        QMl[j, l] += 0.5 * xh * (q0[j] + ye[j]) + xh * xh * (q0[n + j] - ye[n + j]) / 12.0
    for j in range(d):
        y[j, l] = ye[j]
    return x, jx


def grid_dop853_lanes(ka, m, adaptive, idx, Y0, P, TS, H, TSTR, REF, LO, HI, flags, rtol, atol,
                      max_steps, A, B, C, E3, E5, YF, TF, SQ, QM, DEV, EXIT, EXITC, EDRIFT,
                      COUNTS, ERR, STATUS, budget, stop, slot, SAVE, SAVEI):
    """Adaptive DOP853 over the points ``idx`` on lanes, with the arguments and results of
    :func:`lagrange_core._batch_kernels.grid_dop853` (``simulate_grid`` calls this one from
    :data:`lagrange_core.batch.FIRST_ORDER_LANES_MIN_POINTS` points): ``m`` must be 0 and
    ``adaptive`` true, and ``flags`` must not ask for the energy (``EDRIFT`` is not
    touched); ``ka`` must hold the slots ``rhs`` and ``rhs_lanes``.  A point that leaves
    its band [LO, HI] ends where the step's cubic Hermite interpolant first crosses it, as
    in ``point_dop853`` (status GRID_LEFT_BAND = 1, ``EXIT``, ``EXITC``; the other points'
    ``EXIT`` and ``EXITC`` are not touched: NaN and −1 from the caller).  A point pauses
    after ``budget`` accepted steps in this call (status GRID_INTERRUPTED = 7, its
    integrator state in ``SAVE[slot[k]]``, ``SAVEI[slot[k], 0]`` = 1, in
    ``point_dop853``'s layout: 4n + 8 floats) and a later call resumes it.  Once
    ``stop[0]`` is set (Ctrl-C, :data:`lagrange_core.progress.KERNEL_STOP`) every running
    point pauses at its next step and no other point starts.

    Every thread advances up to :data:`LANES` points together, refilling a lane with the
    next point not yet taken by any thread when its point ends
    (:func:`lagrange_core._thread_blocks.run_shared`); once every point has been taken and
    at most ``DRAIN_FRACTION`` of a thread's lanes still run (of at least
    ``DRAIN_MIN_LANES``: lagrange_core._batch_kernels), they pause and run on at once on
    fewer lanes, with the same steps and numbers."""
    if m != 0 or not adaptive or flags & ~(_OBS_STROBE | _OBS_REF | _OBS_BAND):
        raise ValueError("grid_dop853_lanes runs adaptive DOP853 on unconstrained systems "
                         "observing strobe samples, deviations and bands only; use "
                         "grid_dop853.")
    _grid(ka, idx, Y0, P, TS, H, TSTR, REF, LO, HI, flags, rtol, atol, max_steps, A, B,
          C, E3, E5, YF, TF, SQ, QM, DEV, EXIT, EXITC, COUNTS, ERR, STATUS, budget, stop, slot,
          SAVE, SAVEI)


def _grid(ka, idx, Y0, P, TS, H, TSTR, REF, LO, HI, flags, rtol, atol, max_steps, A, B, C, E3,
          E5, YF, TF, SQ, QM, DEV, EXIT, EXITC, COUNTS, ERR, STATUS, budget, stop, slot, SAVE,
          SAVEI):
    """:func:`grid_dop853_lanes` on the threads of
    :func:`lagrange_core._thread_blocks.run_shared`; the points a thread drained run on at
    once, on as many lanes as they are (not after a Ctrl-C)."""
    def work(lo, hi, cursor=None, width=None, drained=DRAINED):
        run_draining(_block, (ka,), (
            Y0, P, TS, H, TSTR, REF, LO, HI, flags, rtol, atol, max_steps, A, B, C, E3, E5, YF,
            TF, SQ, QM, DEV, EXIT, EXITC, COUNTS, ERR, STATUS, budget, stop),
            idx, slot, lo, hi, SAVE, SAVEI, stop, drained, cursor, width)
    run_shared(work, idx.shape[0], LANES, DRAINED)


@njit(cache=True, nogil=True, error_model="numpy", fastmath=FAST_MATH)
def _block(ka, idx, cursor, hi_b, width, Y0, P, TS, H, TSTR, REF, LO, HI, flags, rtol, atol,
           max_steps, A, B, C, E3, E5, YF, TF, SQ, QM, DEV, EXIT, EXITC, COUNTS, ERR, STATUS,
           budget, stop, slot, SAVE, SAVEI, drained_flag):
    """The points idx[cursor[0]:hi_b] of :func:`grid_dop853_lanes` on up to ``width`` lanes
    of one thread, each free lane taking the next point from ``cursor``, which other
    threads may share (:mod:`lagrange_core._shared_cursor`); a point it drains is saved
    with ``SAVEI[·, 0] = drained_flag``."""
    d = Y0.shape[1]
    n = d // 2
    npar = P.shape[1]
    L = min(LANES, width, max(hi_b - peek(cursor), 0))
    ref = (flags & _OBS_REF) != 0
    band = (flags & _OBS_BAND) != 0
    sidx, scoef, spairs = sparse_tables(A, B, E5, E3)
    pt = np.full(L, -1, dtype=np.int64)
    pk = np.zeros(L, dtype=np.int64)
    y = np.zeros((d, L))
    ys = np.zeros((d, L))
    ynew = np.zeros((d, L))
    K = np.zeros((13, d, L))
    Pl = np.ones((max(npar, 1), L))
    work = np.zeros((1 + 2 * n * (n + 1), L))
    QMl = np.zeros((n, L))
    DEVl = np.zeros((n, L))
    REFl = np.zeros((n, L))
    LOl = np.full((n, L), -np.inf)
    HIl = np.full((n, L), np.inf)
    t = np.zeros(L)
    tc = np.zeros(L)
    h = np.zeros(L)
    hs = np.zeros(L)
    ts = np.zeros(L)
    tar = np.zeros(L)
    tnew = np.zeros(L)
    tcn = np.zeros(L)
    t0l = np.zeros(L)
    t1l = np.zeros(L)
    Tl = np.zeros(L)
    kn = np.zeros(L)
    e5 = np.zeros(L)
    e3 = np.zeros(L)
    est = np.zeros(L)
    errsum = np.zeros(L)
    clip = np.zeros(L, dtype=np.bool_)
    fin = np.zeros(L, dtype=np.bool_)
    sing = np.zeros(L, dtype=np.bool_)
    good = np.zeros(L, dtype=np.bool_)
    special = np.zeros(L, dtype=np.bool_)
    rejected = np.zeros(L, dtype=np.bool_)
    live = np.zeros(L, dtype=np.bool_)
    out = np.zeros(L, dtype=np.bool_)       # accepted, but the step left the band
    adv = np.zeros(L, dtype=np.bool_)       # accepted and inside (with a band)
    base = np.zeros(L, dtype=np.int64)
    nst = np.zeros(L, dtype=np.int64)
    nrej = np.zeros(L, dtype=np.int64)
    nev = np.zeros(L, dtype=np.int64)
    f = np.empty(d)
    W = np.zeros((n, n + 1))
    y1 = np.empty(d)
    f1 = np.empty(d)
    ye = np.empty(d)                        # a lane's state where it leaves its band
    lo1 = np.empty(n)
    hi1 = np.empty(n)
    started = False             # every point has been taken (by this thread or another)
    active = 0
    drained = False
    paused = 0                  # points paused by the budget (a long run: no drain)
    for l in range(L):
        while not started and pt[l] < 0:
            k = take(cursor)
            if k >= hi_b:
                started = True
                break
            i = idx[k]
            sl = slot[k]
            st = _load(ka, l, i, SAVE[sl], SAVEI[sl], Y0, P, TS, H, TSTR, REF, LO, HI, flags,
                       rtol, atol, y, K, Pl, t, tc, h, t0l, t1l, Tl, kn, QMl, DEVl, REFl, LOl,
                       HIl, errsum, rejected, base, YF, SQ, QM, DEV, COUNTS, f, W, y1, f1)
            if st != 0:
                STATUS[i] = st
                TF[i] = TS[i, 0]
            else:
                pt[l] = i
                pk[l] = k
                live[l] = True
                active += 1
    while active > 0:
        # Ctrl-C, or the thread drains (every point taken, few lanes still run): every
        # running point pauses at its next step and no other point starts; drained, they
        # run on at once on fewer lanes (_grid), as RKN 12's lanes do
        if lanes_pause_now(budget, stop, started, cursor, hi_b, paused, L, active):
            drained = stop[0] == 0
            budget = 0
            started = True
        # each lane's step: shortened to land on its end or its next strobe time
        for l in range(L):
            tt = t[l]
            tg = t1l[l]
            tsk = t0l[l] + kn[l] * Tl[l]
            tg = tsk if (Tl[l] > 0.0 and tsk < tg) else tg
            tar[l] = tg
            cl = tt + h[l] >= tg
            hh = tg - tt if cl else h[l]
            clip[l] = cl
            hs[l] = hh if live[l] else 0.0
            sing[l] = False
        for s in range(1, 12):
            stage_sum(sidx[s], scoef[s], spairs[s], K, y, hs, ys, L)
            for l in range(L):
                ts[l] = t[l] + C[s] * hs[l]
            if rhs_on_lanes(ka, ts, ys, Pl, K[s], work, L) > 0:
                for l in range(L):
                    sing[l] |= work[0, l] != 0.0
        stage_sum(sidx[12], scoef[12], spairs[12], K, y, hs, ynew, L)
        for l in range(L):
            ts[l] = t[l] + hs[l]
        if rhs_on_lanes(ka, ts, ynew, Pl, K[12], work, L) > 0:
            for l in range(L):
                sing[l] |= work[0, l] != 0.0
        for l in range(L):
            e5[l] = 0.0
            e3[l] = 0.0
            est[l] = 0.0
            fin[l] = True
        error_sums(sidx[0], scoef, K, y, ynew, hs, rtol, atol, e5, e3, est, fin, L)
        # accept or reject, every lane at once; the controller of point_dop853
        for l in range(L):
            z = (e5[l] == 0.0) & (e3[l] == 0.0)
            err = 0.0 if z else e5[l] / math.sqrt((e5[l] + 0.01 * e3[l]) * d)
            fe = math.isfinite(err)
            fin[l] = fin[l] & fe
            lv = live[l]
            ok = lv & (not sing[l]) & fin[l] & (err < 1.0)
            rej = lv & (not sing[l]) & (not ok)
            good[l] = ok
            hh = hs[l]
            fac = step_factor(err)
            hr = hh * max(0.2, fac) if fe else 0.2 * hh
            fa = min(10.0, fac)
            fa = min(1.0, fa) if rejected[l] else fa
            ha = max(h[l], hh * fa) if clip[l] else hh * fa
            h[l] = ha if ok else (hr if rej else h[l])
            rejected[l] = False if ok else (True if rej else rejected[l])
            yk = hh - tc[l]
            tk = t[l] + yk
            tnew[l] = tar[l] if clip[l] else tk
            tcn[l] = 0.0 if clip[l] else (tk - t[l]) - yk
            nrej[l] += 1 if rej else 0
            nst[l] += 1 if ok else 0
            nev[l] += 12 if lv else 0
            errsum[l] += est[l] if ok else 0.0
            hmin = 16.0 * _EPS * max(abs(t[l]), abs(t1l[l]))
            special[l] = lv & (sing[l] | (rej & (hr < hmin))
                               | (ok & (clip[l] | (tnew[l] >= t1l[l]) | (nst[l] >= budget)
                                        | (base[l] + nst[l] >= max_steps))))
        moves = good                # the lanes whose accepted step moves them on
        if band:                    # an accepted step whose end is outside the band ends
            for l in range(L):      # its point (below, lane by lane); the others move on
                out[l] = False
            for j in range(n):
                for l in range(L):
                    yn = ynew[j, l]
                    out[l] |= good[l] & ((yn < LOl[j, l]) | (yn > HIl[j, l]))
            for l in range(L):
                adv[l] = good[l] & (not out[l])
                special[l] |= out[l]
            moves = adv
        for j in range(n):          # the time mean and the deviation of accepted steps
            for l in range(L):
                hh = hs[l]
                mean = (0.5 * hh * (y[j, l] + ynew[j, l])
                        + hh * hh * (y[n + j, l] - ynew[n + j, l]) / 12.0)
                QMl[j, l] += mean if moves[l] else 0.0
            if ref:
                for l in range(L):
                    dv = abs(ynew[j, l] - REFl[j, l])
                    DEVl[j, l] = dv if (moves[l] & (dv > DEVl[j, l])) else DEVl[j, l]
        for j in range(d):
            for l in range(L):
                u = moves[l]
                y[j, l] = ynew[j, l] if u else y[j, l]
                K[0, j, l] = K[12, j, l] if u else K[0, j, l]
        for l in range(L):
            u = moves[l]
            t[l] = tnew[l] if u else t[l]
            tc[l] = tcn[l] if u else tc[l]
        # the rest, lane by lane: strobe samples, failures, ends (and the next point)
        for l in range(L):
            if not special[l]:
                continue
            i = pt[l]
            st = -1
            if sing[l]:
                st = _SINGULAR
            elif not good[l]:       # rejected with a step below the resolution of t
                st = _UNDERFLOW if fin[l] else _NON_FINITE
            elif out[l]:            # left the band: where the step's interpolant crosses it
                x, jx = _left_band(l, y, ynew, hs[l], LOl, HIl, QMl, y1, f1, ye, lo1, hi1)
                t[l] = t[l] + x * hs[l]
                EXIT[i] = t[l]
                EXITC[i] = jx
                st = _LEFT_BAND
            else:
                if clip[l] and Tl[l] > 0.0 and t[l] == t0l[l] + kn[l] * Tl[l]:
                    k_ = int(kn[l])
                    if k_ < SQ.shape[1]:
                        for j in range(d):
                            SQ[i, k_, j] = y[j, l]
                    kn[l] += 1.0
                if t[l] >= t1l[l]:
                    st = _FINISHED
                elif base[l] + nst[l] >= max_steps:
                    st = _MAX_STEPS
                elif nst[l] >= budget:          # pause: the state saved, resumed next call
                    st = _INTERRUPTED
                    sv = SAVE[slot[pk[l]]]
                    for j in range(d):
                        sv[j] = y[j, l]
                        sv[d + j] = K[0, j, l]
                    o = 2 * d
                    sv[o] = t[l]
                    sv[o + 1] = tc[l]
                    sv[o + 2] = h[l]
                    sv[o + 3] = errsum[l]
                    sv[o + 4] = 0.0
                    sv[o + 5] = 0.0
                    sv[o + 6] = kn[l]
                    sv[o + 7] = 1.0 if rejected[l] else 0.0
                    SAVEI[slot[pk[l]], _SAVED] = drained_flag if drained else 1
                    paused += 0 if drained else 1
            if st < 0:
                continue
            STATUS[i] = st
            TF[i] = t[l]
            ERR[i] = errsum[l]
            COUNTS[i, _STEPS] += nst[l]
            COUNTS[i, _REJECTED] += nrej[l]
            COUNTS[i, _EVALS] += nev[l]
            for j in range(d):
                YF[i, j] = y[j, l]
            for j in range(n):
                QM[i, j] = QMl[j, l]
                DEV[i, j] = DEVl[j, l]
            pt[l] = -1
            live[l] = False
            active -= 1
            nst[l] = 0
            nrej[l] = 0
            nev[l] = 0
            while not started and pt[l] < 0:
                k = take(cursor)
                if k >= hi_b:
                    started = True
                    break
                i2 = idx[k]
                sl = slot[k]
                st2 = _load(ka, l, i2, SAVE[sl], SAVEI[sl], Y0, P, TS, H, TSTR, REF, LO, HI,
                            flags, rtol, atol, y, K, Pl, t, tc, h, t0l, t1l, Tl, kn, QMl, DEVl,
                            REFl, LOl, HIl, errsum, rejected, base, YF, SQ, QM, DEV, COUNTS, f,
                            W, y1, f1)
                if st2 != 0:
                    STATUS[i2] = st2
                    TF[i2] = TS[i2, 0]
                else:
                    pt[l] = i2
                    pk[l] = k
                    live[l] = True
                    active += 1
            if pt[l] < 0:           # idle: a finite state that no longer moves
                for j in range(d):
                    if not math.isfinite(y[j, l]):
                        y[j, l] = 0.0
                    for m in range(13):
                        K[m, j, l] = 0.0


# numba's cache does not notice changes to the kernels these call
from . import _batch_kernels, _integrator_kernels, _kernel_calls, _lane_calls  # noqa: E402
from .module_store import guard_numba_cache  # noqa: E402

guard_numba_cache(sys.modules[__name__], _batch_kernels, _integrator_kernels, _kernel_calls,
                  _lane_calls)


# a first call on the main thread compiles where Ctrl-C need not wait for it
from ._first_calls import guard as _guard_first_calls  # noqa: E402

_guard_first_calls(__name__)
