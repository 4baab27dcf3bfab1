"""Batch integration's compiled kernels: many trajectories per call, observables only.

Why one module over 800 lines: the grid drivers of every method share the inlined stage,
observable and band-exit helpers below, and numba caches per source file; split, each
file would compile its own copy of the helpers and a change to one would not recompile
the drivers that inline it.

One call (its points in blocks on numba's thread count, each block a GIL-free compiled call
on a thread of :mod:`lagrange_core._thread_blocks`, dynamic scheduling: trajectories end
at different times; the lanes drivers' threads instead take points one at a time from a
shared cursor, :mod:`lagrange_core._shared_cursor`) integrates every grid point named in
``idx`` from its own initial state and parameters, and records only what
:func:`lagrange_core.batch.simulate_grid` asked for, computed as the steps are taken —
never the trajectory itself:

=================  =====================  ================================================
observable         array (per point i)    how
=================  =====================  ================================================
final state        ``YF[i]`` (2n)         [q, q̇] where the run stopped, at ``TF[i]``
strobe samples     ``SQ[i, k]`` (2n)      [q, q̇] at t0 + kT: the method's own solution there,
                                          not an interpolation (``OBS_STROBE``): an adaptive
                                          RKN step is the longest that divides T
                                          (:func:`_strobe_step`), so the held step lands on
                                          every sample unshortened; other steps are
                                          shortened to land on it
time mean of q     ``QM[i]`` (n)          ∫q dt / (t − t0); per step the corrected trapezoid
                                          h(q0 + q1)/2 + h²(q̇0 − q̇1)/12 (4th order; exact
                                          for a trigonometric polynomial of degree < m on m
                                          equal steps per period)
max deviation      ``DEV[i]`` (n)         max of |q − q_ref| at t0 and step ends (``OBS_REF``)
band exit          ``EXIT[i]``,           first time a coordinate leaves [lo, hi]: located in
                   ``EXITC[i]``           the step by the cubic Hermite interpolant of (q, q̇)
                                          (error O(h⁴)), refined for RKN 12 by re-stepping
                                          from the step's start (the method's own accuracy);
                                          the trajectory stops there, its final state is
                                          that point's (``OBS_BAND``)
energy drift       ``EDRIFT[i]``          max over step ends of |h(t) − h(t0)| (``OBS_ENERGY``)
counts             ``COUNTS[i]``          accepted steps, rejected steps, kernel evaluations
error estimate     ``ERR[i]``             sum of the local error estimates (as ``simulate``)
status             ``STATUS[i]``          ``GRID_*`` below
=================  =====================  ================================================

A point that fails (singular mass matrix, a non-finite state, the step size falling
below the resolution of t, its step budget used) gets its status and the state where it
stopped; the other points are not affected.

A long run *pauses*: every driver takes a per-call step ``budget``; a point that has
taken it stops after an accepted step with status GRID_INTERRUPTED, its observables so
far in place and its whole integrator state (the state and its compensation carries,
the acceleration at the step's end, the next and the held step, the held step's block
of error ratios, the drive's rotations) in its row of ``SAVE``/``SAVEI``
(:func:`save_width` floats, :data:`SAVEI_WIDTH` integers).  The next call with that row
resumes it exactly: the same steps and the same numbers as an unbroken run.  So
:func:`lagrange_core.batch.simulate_grid` cuts a long trajectory into calls of about a
quarter of a second, for progress; and on Ctrl-C every driver pauses its running points
at their next step (it reads ``stop[0]``, :data:`lagrange_core.progress.KERNEL_STOP`,
at every step).  The loops are the drivers of
:mod:`lagrange_core._integrator_kernels` rewritten per point without output buffers
(RKN 12(10) and the symplectic composition on the drive kernel, with the drive advanced
by rotations; DOP853 on the generic right-hand side, with projection onto the
constraints), compiled once per installation and reaching the system's kernels by
address (``ka``).

RKN 12(10) also runs on *lanes* (:func:`grid_rkn_lanes`, what ``simulate_grid`` uses
for "rkn12" and "rkn12-fixed"): a thread advances LANES points together, their state in
arrays with the lane as last axis, so the stage sums, the drive's rotations and the
system's accelerations (the drive kernel's ``fast_accel_lanes``, one call per stage for
every lane, sin/cos from :mod:`lagrange_core._lane_math`) are loops over lanes that LLVM
vectorises, and the lanes' independent dependency chains fill each other's latencies.
The per-step bookkeeping that is the same for every lane (accept, advance, observe) is
vectorised too; what is particular to a lane (a rejection, a band exit, a strobe
sample, an end and the next point) runs for that lane alone.  Why: a lone trajectory
waits on latencies (sin q near π ~36 ns, a call through the kernel's address ~25–47 ns,
the stage sums' chains of fused multiply-adds); on lanes an evaluation of the driven
pendulum costs about 6 ns per trajectory instead of 39 (benchmarks/README.md, "Batch
simulation").
"""
import math
import sys

import numpy as np
from numba import njit

from ._integrator_kernels import (
    DRIVE_STEP,
    FAST_MATH,
    INLINE,
    ST_BLOCK,
    STATS_SIZE,
    TV_HOLD,
    TV_HREF,
    TV_SIZE,
    drive_rates,
    held_step_record,
    project_constraints,
    rkn_combine,
    rkn_next_step,
    rkn_stages,
    rotate_drive,
    second_order_step,
    starting_step,
)
from ._kernel_calls import (
    DRIVE_RATES,
    ENERGY,
    FAST_ACCEL,
    MAX_DRIVE_RATES,
    RHS,
    call_drive_rates,
    call_energy,
    call_fast_accel,
    call_rhs,
)
from ._lanes_callees import (
    FAST_ACCEL_ON_LANES,
    LANES_BY_LANE,
    LANES_LOAD,
    LANES_RESTORE,
    LANES_SAVE,
    N_CALLEES,
    NO_CALLS,
    PILOT_STEP_QUANTILE,
    RKN_BAND_EXIT,
    SINCOS_ROWS,
    STAGE_POSITIONS,
    WEIGHTED_SUMS,
    call_fast_accel_on_lanes,
    call_lanes_by_lane,
    call_lanes_load,
    call_lanes_restore,
    call_lanes_save,
    call_pilot_step_quantile,
    call_rkn_band_exit,
    call_sincos_rows,
    call_stage_positions,
    call_weighted_sums,
)
from ._lanes_callees import addresses as lanes_callee_addresses
from ._selection import PILOT_MIN_SETTLED, PILOT_SPAN_DIVISOR, PILOT_WIDEN, pilot_step_quantile
from ._shared_cursor import peek, take
from ._thread_blocks import first_span_call, run_draining, run_rows, run_shared

#: per-point status (``GridTrajectories.status``)
GRID_FINISHED, GRID_LEFT_BAND, GRID_UNDERFLOW, GRID_NON_FINITE, GRID_SINGULAR, \
    GRID_MAX_STEPS, GRID_NOT_RUN, GRID_INTERRUPTED = range(8)
#: what to observe (bits of ``flags``)
OBS_STROBE, OBS_REF, OBS_BAND, OBS_ENERGY = 1, 2, 4, 8
#: columns of ``COUNTS``
CNT_STEPS, CNT_REJECTED, CNT_EVALS = range(3)
_EPS = 2.220446049250313e-16


# -- observing an accepted step -----------------------------------------------------------

@njit(cache=True, inline=INLINE)
def _hermite(q0, v0, q1, v1, h, x):
    """Cubic Hermite interpolant of one coordinate at step fraction x: (q, q̇)."""
    x2 = x * x
    x3 = x2 * x
    h00 = 2 * x3 - 3 * x2 + 1
    h10 = x3 - 2 * x2 + x
    h01 = -2 * x3 + 3 * x2
    h11 = x3 - x2
    q = h00 * q0 + h10 * h * v0 + h01 * q1 + h11 * h * v1
    d00 = 6 * x2 - 6 * x
    d10 = 3 * x2 - 4 * x + 1
    d01 = -6 * x2 + 6 * x
    d11 = 3 * x2 - 2 * x
    v = (d00 * q0 + d01 * q1) / h + d10 * v0 + d11 * v1
    return q, v


@njit(cache=True)
def _band_exit(q, v, qn, vn, h, lo, hi):
    """First step fraction x ∈ (0, 1] at which the Hermite interpolant of the step leaves
    [lo, hi] for a coordinate whose end value is outside, and that coordinate; (2.0, −1)
    when every end value is inside.  Illinois iteration on the cubic (a few ulps)."""
    n = q.shape[0]
    best = 2.0
    jbest = -1
    for j in range(n):
        if lo[j] <= qn[j] <= hi[j]:
            continue
        bound = hi[j] if qn[j] > hi[j] else lo[j]
        a = 0.0
        b = 1.0
        fa = q[j] - bound
        fb = qn[j] - bound
        side = 0
        for _it in range(100):
            if b - a <= 4 * _EPS:
                break
            x = (a * fb - b * fa) / (fb - fa)
            if not (a < x < b):
                x = 0.5 * (a + b)
            fx = _hermite(q[j], v[j], qn[j], vn[j], h, x)[0] - bound
            if fx == 0.0:
                a = b = x
                break
            if (fx > 0.0) == (fb > 0.0):
                if side == -1:
                    fa *= 0.5
                b, fb, side = x, fx, -1
            else:
                if side == 1:
                    fb *= 0.5
                a, fa, side = x, fx, 1
        x = b
        if x < best:
            best = x
            jbest = j
    return best, jbest


@njit(cache=True, inline=INLINE)
def _accumulate_mean(qsum, q, v, qn, vn, h):
    for j in range(q.shape[0]):
        qsum[j] += 0.5 * h * (q[j] + qn[j]) + h * h * (v[j] - vn[j]) / 12.0


@njit(cache=True)
def _observe(ka, t, h, q, v, qn, vn, p, flags, ref, lo, hi, dev, qsum, e0, drift, yf):
    """Book-keeping after an accepted step from (t, q, v) to (t + h, qn, vn).

    Returns (exit fraction, exit coordinate, energy drift): fraction 2.0 and coordinate
    −1 when the band was not left; on an exit ``yf`` holds the state there and the mean
    is accumulated up to it."""
    n = q.shape[0]
    x = 2.0
    jx = -1
    if flags & OBS_BAND:
        x, jx = _band_exit(q, v, qn, vn, h, lo, hi)
    if jx >= 0:
        for j in range(n):
            yf[j], yf[n + j] = _hermite(q[j], v[j], qn[j], vn[j], h, x)
        _accumulate_mean(qsum, q, v, yf[:n], yf[n:], x * h)
        return x, jx, drift
    _accumulate_mean(qsum, q, v, qn, vn, h)
    if flags & OBS_REF:
        for j in range(n):
            d = abs(qn[j] - ref[j])
            if d > dev[j]:
                dev[j] = d
    if flags & OBS_ENERGY:
        d = abs(call_energy(ka[ENERGY], qn, vn, t + h, p) - e0)
        if d > drift:
            drift = d
    return x, jx, drift


@njit(cache=True, inline=INLINE)
def _next_stop(t1, T, k_next, t0, flags):
    """The time the next step must not pass: t1, or the next strobe sample t0 + kT."""
    if flags & OBS_STROBE:
        ts = t0 + k_next * T
        if ts < t1:
            return ts
    return t1


# -- q̈ = f(q, t): RKN 12(10) and the symplectic composition -----------------------------

@njit(cache=True, inline=INLINE)
def _longest_step(rates):
    """The longest adaptive RKN step: DRIVE_STEP periods of the fastest drive harmonic."""
    h_max = np.inf
    for k in range(rates.shape[0]):
        if rates[k] != 0.0:
            h_max = min(h_max, DRIVE_STEP * 2.0 * np.pi / abs(rates[k]))
    return h_max


@njit(cache=True, no_cpython_wrapper=True, error_model="numpy", fastmath=FAST_MATH)
def _rkn_band_exit(ka, t, h, q, v, a0, qn, vn, p, lo, hi, c, A, b, bp, rates, y):
    """Where an RKN 12 step from (q, v) at t to (qn, vn) at t + h first leaves [lo, hi]:
    (fraction x of the step, coordinate, kernel evaluations); (2.0, −1, 0) if it does not.

    The cubic Hermite estimate (:func:`_band_exit`) starts an Illinois iteration whose
    trial points are RKN steps of size x·h from the step's start (the method's own
    solution, as ``simulate`` locates events), to a few ulps of x; ``y`` gets [q, q̇] at
    the exit.  A coordinate found outside at that point left earlier and is located in
    turn.  (Hermite's error, O(h⁴) and growing with the drive's ω⁴, reached 1e-4 s in
    exit time on a held step of 3/4 of a drive period.)"""
    x, j = _band_exit(q, v, qn, vn, h, lo, hi)
    if j < 0:
        return 2.0, -1, 0
    n = q.shape[0]
    ns = c.shape[0]
    K = np.empty((ns, n))
    qs = np.empty(n)
    css = np.empty(max(2 * rates.shape[0], 1))
    Wn = np.zeros((n, n + 1))
    yq = np.empty(n)
    yv = np.empty(n)
    w0 = np.zeros(1)
    evals = 0
    xb = 1.0
    for i in range(n):
        y[i] = qn[i]
        y[n + i] = vn[i]
    for _attempt in range(n):
        bound = hi[j] if y[j] > hi[j] else lo[j]
        xa = 0.0
        fa = q[j] - bound
        fb = y[j] - bound
        side = 0
        guess = x if 0.0 < x < xb else 0.5 * xb
        for it in range(60):
            if xb - xa <= 4 * _EPS:
                break
            xt = guess if it == 0 else (xa * fb - xb * fa) / (fb - fa)
            if not (xa < xt < xb):
                xt = 0.5 * (xa + xb)
            if second_order_step(ka, np.int64(0), t, q, v, a0, xt * h, p, c, A, b, bp, w0, K, yq,
                                 yv, qs, rates, css, Wn) != 0:
                break
            evals += ns - 1
            ft = yq[j] - bound
            if ft == 0.0 or (ft > 0.0) == (fb > 0.0):
                if side == -1:
                    fa *= 0.5
                xb, fb, side = xt, ft, -1
                for i in range(n):
                    y[i] = yq[i]
                    y[n + i] = yv[i]
                if ft == 0.0:
                    break
            else:
                if side == 1:
                    fb *= 0.5
                xa, fa, side = xt, ft, 1
        # a coordinate outside at this point left the band earlier: locate it instead
        k_out = -1
        for i in range(n):
            if i != j and not (lo[i] <= y[i] <= hi[i]):
                k_out = i
        if k_out < 0:
            break
        j = k_out
        x = 0.5 * xb
    return xb, j, evals


@njit(cache=True, inline=INLINE)
def _strobe_step(h, T):
    """The longest step ≤ h that divides the strobe period T (h itself for T ≤ 0): the
    held step then lands on every strobe time unshortened, and keeps its rotations."""
    if T > 0.0 and h > 0.0 and math.isfinite(h):
        return T / math.ceil(T / h)
    return h


# -- pausing a point: its integrator state, saved between calls ----------------------------

#: save[0] of a paused point's integer row: its state is saved (the next call resumes it);
#: DRAINED + a thread's number: saved by that thread's lanes when they drained (it runs
#: them on at once: lagrange_core._thread_blocks.run_shared)
SAVED = 0
DRAINED = 2


def save_width(n, stages, rates, hold_block):
    """Floats a paused point's state takes in ``SAVE`` (the widest of the drivers):
    q, q̇, their carries and q̈ (5n), the scalars (10), the held step's state and block,
    and the drive's rotations over the stages."""
    return 5 * n + 10 + TV_SIZE + hold_block + stages * max(2 * rates, 1) + 4 * n


#: integers a paused point's state takes in ``SAVEI``: the flag and the held step's counters
SAVEI_WIDTH = 1 + STATS_SIZE


@njit(cache=True, error_model="numpy", fastmath=FAST_MATH)
def point_second_order(ka, rkn, w, adaptive, y0, p, t0, t1, h0, T, ref, lo, hi, flags, rtol,
                       atol, max_steps, yf, sq, qsum, dev, counts, hbuf, block, budget, stop,
                       save, savei):
    """Integrate one point of a q̈ = f(q, t) system (drive kernel) from y0 at t0 to t1.

    ``rkn``, RKN 12(10)'s tables (c, A, b, b', b̂, b̂'): that method, adaptive
    (``adaptive``) or at the fixed step ``h0`` (``w`` unused);
    ``rkn`` None: the symmetric composition of velocity Verlet with weights ``w`` at ``h0``.
    Every branch between the two tests ``rkn is None`` on the argument itself: numba
    prunes such a branch when it compiles for a None argument, so the symplectic driver
    carries none of RKN 12's code (its first grid compiled in 11 s against 27 s).
    The adaptive step is controlled as by ``simulate``'s "rkn12"
    (:func:`lagrange_core._integrator_kernels.fast_rkn_chunk`): at most DRIVE_STEP periods
    of the fastest drive harmonic, and *held* (:func:`held_step_record`) once the first
    block of ``block`` is complete; an empty ``block`` gives the classic controller (the
    pilot of "rkn12-fixed").  With strobe samples the step is the longest that divides
    the strobe period (:func:`_strobe_step`).  Observables as in the module docstring.
    A non-empty ``hbuf`` records the accepted steps (a pilot run; observables off; it
    stops when ``hbuf`` is full, all a pilot uses).

    After ``budget`` steps of this call — or the next step once ``stop[0]`` is set
    (Ctrl-C, :data:`lagrange_core.progress.KERNEL_STOP`) — the point *pauses*: its
    integrator state goes to ``save``/``savei`` (``savei[SAVED]`` = 1) and the status is
    GRID_INTERRUPTED, with the observables so far in place; called again with them it
    resumes exactly where it stopped (the same steps and numbers as an unbroken run).
    Returns (status, t, exit coordinate, energy drift, error estimate, steps recorded in
    hbuf).
    """
    n = y0.shape[0] // 2
    rates = drive_rates(ka, p)
    h_max = _longest_step(rates)
    tvh = np.zeros(TV_SIZE)
    sth = np.zeros(STATS_SIZE, dtype=np.int64)
    nd = rates.shape[0]
    if rkn is None:
        ns = w.shape[0] + 1
    else:
        ns = rkn[0].shape[0]
    K = np.empty((ns, n))
    q = np.empty(n)
    v = np.empty(n)
    a0 = np.empty(n)
    qs = np.empty(n)
    qn = np.empty(n)
    vn = np.empty(n)
    an = np.empty(n)
    Wn = np.zeros((n, n + 1))
    cq = np.zeros(n)
    cv = np.zeros(n)
    cqn = np.zeros(n)
    cvn = np.zeros(n)
    rot = np.empty((ns, max(nd, 1), 2))
    cs0 = np.empty(max(2 * nd, 1))
    css = np.empty(max(2 * nd, 1))
    S = np.empty(ns)                      # the symplectic substeps' cumulative weights
    db = np.empty(ns)
    dbp = np.empty(ns)
    if rkn is None:
        acc = 0.0
        for k in range(ns - 1):
            acc += w[k]
            S[k] = acc
    else:
        b, bp, bh, bph = rkn[2], rkn[3], rkn[4], rkn[5]
        for j in range(ns):
            db[j] = b[j] - bh[j]
            dbp[j] = bp[j] - bph[j]
    strobe = (flags & OBS_STROBE) != 0 and T > 0.0
    nb = block.shape[0]
    nr = ns * max(nd, 1) * 2
    if savei[SAVED] == 1:           # resume a paused point: its state as it was saved
        for i in range(n):
            q[i] = save[i]
            v[i] = save[n + i]
            a0[i] = save[2 * n + i]
            cq[i] = save[3 * n + i]
            cv[i] = save[4 * n + i]
        o = 5 * n
        t = save[o]
        t_carry = save[o + 1]
        h = save[o + 2]
        h_rot = save[o + 3]
        err_sum = save[o + 4]
        drift = save[o + 5]
        e0 = save[o + 6]
        k_next = int(save[o + 7])
        rejected = save[o + 8] != 0.0
        o += 10
        for k in range(TV_SIZE):
            tvh[k] = save[o + k]
        o += TV_SIZE
        for k in range(nb):
            block[k] = save[o + k]
        o += nb
        rot_flat = rot.reshape(nr)
        # element by element: an array copied into a slice makes numba compile its
        # shape-mismatch message (f-strings), ~2 s in each process that compiles it
        for k in range(nr):
            rot_flat[k] = save[o + k]
        for k in range(STATS_SIZE):
            sth[k] = savei[1 + k]
        savei[SAVED] = 0
    else:
        for i in range(n):
            q[i] = y0[i]
            v[i] = y0[n + i]
            yf[i] = y0[i]
            yf[n + i] = y0[n + i]
            if flags & OBS_REF:
                dev[i] = abs(y0[i] - ref[i])
        t = t0
        for k in range(nd):
            cs0[2 * k] = np.cos(rates[k] * t)
            cs0[2 * k + 1] = np.sin(rates[k] * t)
        if call_fast_accel(ka[FAST_ACCEL], q, t, cs0, p, a0, Wn) != 0:
            return GRID_SINGULAR, t, -1, 0.0, 0.0, 0
        counts[CNT_EVALS] += 1
        for i in range(n):          # no step can start (nor a starting step be estimated)
            if not np.isfinite(a0[i]):
                return GRID_NON_FINITE, t, -1, 0.0, 0.0, 0
        e0 = call_energy(ka[ENERGY], q, v, t, p) if flags & OBS_ENERGY else 0.0
        drift = 0.0
        if flags & OBS_STROBE:
            for i in range(2 * n):
                sq[0, i] = y0[i]
        k_next = 1
        h = h0
        if rkn is not None and adaptive and h <= 0.0:
            W = np.zeros((n, n + 1))
            f = np.empty(2 * n)
            for i in range(n):
                f[i] = v[i]
                f[n + i] = a0[i]
            h = starting_step(ka, t, y0, f, p, rtol, atol, W, np.empty(2 * n),
                              np.empty(2 * n), 1.0 / 11.0)
            counts[CNT_EVALS] += 2
        if adaptive:
            h = min(h, h_max)
            if strobe:
                h = _strobe_step(h, T)
        h_rot = -1.0
        t_carry = 0.0
        err_sum = 0.0
        rejected = False
    steps0 = counts[CNT_STEPS]
    n_h = 0
    expo = -1.0 / 11.0
    status = GRID_FINISHED
    jx = -1
    # a strobe-divided step may reach its sample a rounding short: it lands all the same
    grow = 1.0 + 1e-10 if (strobe or not adaptive) else 1.0
    while True:
        if t >= t1:
            break
        if counts[CNT_STEPS] >= max_steps:
            status = GRID_MAX_STEPS
            break
        if hbuf.shape[0] > 0 and n_h >= hbuf.shape[0]:
            break                   # a pilot with all the steps it records
        taken = counts[CNT_STEPS] - steps0
        if taken >= budget or (taken > 0 and stop[0] != 0):
            # pause: save the state (a step just ended; the observables are in place)
            for i in range(n):
                save[i] = q[i]
                save[n + i] = v[i]
                save[2 * n + i] = a0[i]
                save[3 * n + i] = cq[i]
                save[4 * n + i] = cv[i]
                yf[i] = q[i]
                yf[n + i] = v[i]
            o = 5 * n
            save[o] = t
            save[o + 1] = t_carry
            save[o + 2] = h
            save[o + 3] = h_rot
            save[o + 4] = err_sum
            save[o + 5] = drift
            save[o + 6] = e0
            save[o + 7] = k_next
            save[o + 8] = 1.0 if rejected else 0.0
            o += 10
            for k in range(TV_SIZE):
                save[o + k] = tvh[k]
            o += TV_SIZE
            for k in range(nb):
                save[o + k] = block[k]
            o += nb
            rot_flat = rot.reshape(nr)
            for k in range(nr):
                save[o + k] = rot_flat[k]
            for k in range(STATS_SIZE):
                savei[1 + k] = sth[k]
            savei[SAVED] = 1
            return GRID_INTERRUPTED, t, -1, drift, err_sum, 0
        hmin = 16.0 * _EPS * max(abs(t), abs(t1))
        if adaptive and not h >= hmin:
            # the step it needs is below the rounding of t (a starting step of 0 where
            # the derivative's norm overflows, say): no step would move t
            status = GRID_UNDERFLOW
            break
        t_target = _next_stop(t1, T, k_next, t0, flags)
        for k in range(nd):
            cs0[2 * k] = np.cos(rates[k] * t)
            cs0[2 * k + 1] = np.sin(rates[k] * t)
        kst = 0
        while True:
            clipped = False
            hs = h
            if t + hs * grow >= t_target:
                hs = t_target - t
                clipped = True
            # a step shortened by rounding only (landing on a strobe time) keeps the
            # rotations: their angle error α·|hs − h_rot| is at the rounding of t itself
            if abs(hs - h_rot) > 4.0 * _EPS * max(abs(t), abs(t_target)):
                for s in range(ns):
                    if rkn is None:
                        frac = S[s] if s < ns - 1 else 1.0
                    else:
                        frac = rkn[0][s]
                    for k in range(nd):
                        rot[s, k, 0] = np.cos(rates[k] * frac * hs)
                        rot[s, k, 1] = np.sin(rates[k] * frac * hs)
                h_rot = hs
            if rkn is not None:
                kst = rkn_stages(ka, t, hs, q, v, a0, rkn[0], rkn[1], rot, cs0, css, K, qs,
                                 p, Wn)
                counts[CNT_EVALS] += ns - 1
                if kst != 0:
                    break
                err, est, finite = rkn_combine(hs, q, v, K, rkn[2], rkn[3], db, dbp, cq, cv,
                                               qn, vn, cqn, cvn, adaptive, rtol, atol)
            else:
                for i in range(n):
                    qn[i] = q[i]
                    vn[i] = v[i]
                    an[i] = a0[i]
                for s in range(ns - 1):
                    hk = w[s] * hs
                    for i in range(n):
                        vn[i] += 0.5 * hk * an[i]
                        qn[i] += hk * vn[i]
                    rotate_drive(cs0, rot, s, css)
                    kst = call_fast_accel(ka[FAST_ACCEL], qn, t + S[s] * hs, css, p, an, Wn)
                    if kst != 0:
                        break
                    for i in range(n):
                        vn[i] += 0.5 * hk * an[i]
                counts[CNT_EVALS] += ns - 1
                if kst != 0:
                    break
                err = 0.0
                est = 0.0
                finite = True
                for i in range(n):
                    if not (np.isfinite(qn[i]) and np.isfinite(vn[i])):
                        finite = False
                break               # fixed steps: the rejection below is RKN 12's alone
            if (not adaptive) or (finite and err < 1.0):
                break
            counts[CNT_REJECTED] += 1
            held_step_record(tvh, sth, block, err, hs, h_max)
            h = hs * max(0.2, 0.9 * err ** expo) if np.isfinite(err) else 0.2 * hs
            if strobe:
                h = _strobe_step(h, T)
            rejected = True
            if h < hmin:
                break
        if kst != 0:
            status = GRID_SINGULAR
            break
        if not finite:
            status = GRID_NON_FINITE
            break
        if adaptive and h < hmin and not err < 1.0:
            status = GRID_UNDERFLOW
            break
        counts[CNT_STEPS] += 1
        err_sum += est
        if n_h < hbuf.shape[0] and not clipped:
            hbuf[n_h] = hs
            n_h += 1
        if clipped:
            t_new = t_target
            t_carry = 0.0
        else:                   # compensated (Kahan) sum of the steps
            yk = hs - t_carry
            t_new = t + yk
            t_carry = (t_new - t) - yk
        if rkn is not None:     # FSAL: the drive at t + hs is the rotation of stage c = 1
            rotate_drive(cs0, rot, ns - 1, css)
            if call_fast_accel(ka[FAST_ACCEL], qn, t_new, css, p, an, Wn) != 0:
                status = GRID_SINGULAR
                break
            counts[CNT_EVALS] += 1
        if rkn is not None and (flags & OBS_BAND):    # leaving the band: where, exactly
            x, jx, ev = _rkn_band_exit(ka, t, hs, q, v, a0, qn, vn, p, lo, hi, rkn[0], rkn[1],
                                       rkn[2], rkn[3], rates, yf)
            counts[CNT_EVALS] += ev
            if jx >= 0:
                _accumulate_mean(qsum, q, v, yf[:n], yf[n:], x * hs)
                t = t + x * hs
                status = GRID_LEFT_BAND
                break
        x, jx, drift = _observe(ka, t, hs, q, v, qn, vn, p, flags, ref, lo, hi, dev, qsum, e0,
                                drift, yf)
        if jx >= 0:
            t = t + x * hs
            status = GRID_LEFT_BAND
            break
        for i in range(n):
            q[i] = qn[i]
            v[i] = vn[i]
            a0[i] = an[i]
            cq[i] = cqn[i]
            cv[i] = cvn[i]
        t = t_new
        if clipped and (flags & OBS_STROBE) and t == t0 + k_next * T:
            if k_next < sq.shape[0]:
                for i in range(n):
                    sq[k_next, i] = q[i]
                    sq[k_next, n + i] = v[i]
            k_next += 1
        if rkn is not None and adaptive:
            h = rkn_next_step(tvh, sth, block, h, hs, err, clipped, rejected, h_max)
            rejected = False
            if strobe:
                h = _strobe_step(h, T)
    if jx < 0:
        for i in range(n):
            yf[i] = q[i]
            yf[n + i] = v[i]
    return status, t, jx, drift, err_sum, n_h


@njit(cache=True, error_model="numpy", fastmath=FAST_MATH)
def pilot_step(ka, y0, p, t0, t1, T, rtol, atol, c, A, b, bp, bh, bph, counts):
    """The fixed step of RKN 12 for one point: an adaptive pilot over the first 1/50 of
    [t0, t1] (as ``integrate``'s "rkn12-fixed"), run again over a window
    :data:`PILOT_WIDEN` times longer (at most the span) until it has taken
    :data:`PILOT_MIN_SETTLED` steps beyond its starting ramp; the 20th percentile of
    those steps (:func:`pilot_step_quantile`), shortened so that a whole number of steps
    spans the strobe period T (or the span)."""
    n = y0.shape[0] // 2
    span = t1 - t0
    hbuf = np.empty(PILOT_STEPS)
    yf = np.empty(2 * n)
    z = np.zeros(n)
    inf = np.full(n, np.inf)
    tw = t0 + span / PILOT_SPAN_DIVISOR     # the window's end
    h_done = -1.0                   # the step of the last window that finished
    while True:
        # the constants as np.int64/np.bool_: a literal argument (numba types ``0`` as
        # Literal[int](0)) would compile point_second_order a second time (10–17 s), for
        # the pilot alone, beside the grid's own specialisation
        out = point_second_order(ka, (c, A, b, bp, bh, bph), np.zeros(1), np.bool_(True), y0,
                                 p, t0, tw, 0.0, 0.0, z, -inf, inf, np.int64(0), rtol, atol,
                                 np.int64(1 << 40), yf, np.empty((1, 2 * n)), np.zeros(n),
                                 np.zeros(n), counts, hbuf,
                                 np.zeros(0), np.int64(1 << 62), np.zeros(1, dtype=np.int64),
                                 np.zeros(0), np.zeros(1, dtype=np.int64))
        m = out[5]
        h, settled = pilot_step_quantile(hbuf, m)
        if out[0] != GRID_FINISHED:
            if h_done >= 0.0:   # a widened pilot failed (a blow-up, an underflow): its
                h = h_done      # shrinking steps say nothing; the step of the last
            break               # window that finished
        if settled >= PILOT_MIN_SETTLED or m >= PILOT_STEPS or not tw < t1:
            break
        h_done = h
        tw = min(t1, t0 + PILOT_WIDEN * (tw - t0))
    if not h > 0.0:
        return span
    period = T if T > 0.0 else span
    return period / math.ceil(period / h)


def grid_second_order(ka, rkn, w, adaptive, pilot, hold_block, idx, Y0, P, TS, H, TSTR, REF,
                      LO, HI, flags, rtol, atol, max_steps, YF, TF, SQ, QM, DEV, EXIT, EXITC,
                      EDRIFT, COUNTS, ERR, STATUS, budget, stop, slot, SAVE, SAVEI):
    """Every point ``idx[k]`` with :func:`point_second_order` (``rkn``: RKN 12's tables
    (c, A, b, b', b̂, b̂'), or None for the symplectic composition with weights ``w``;
    ``pilot``: the fixed step of each point from :func:`pilot_step`; ``hold_block``: steps
    per block of the adaptive held step); a point pauses after ``budget`` steps of this
    call, its state in row ``slot[k]`` of ``SAVE``/``SAVEI``, and resumes from it when
    that row is marked saved.  Once ``stop[0]`` is set (Ctrl-C) the running points pause
    at their next step and no other point starts (their status stays as it was: not run,
    or paused earlier).

    The points go in blocks to the threads (:func:`lagrange_core._thread_blocks.run_rows`,
    16 per thread: points end at different times), each block one GIL-free call.
    """
    run_rows(_second_order_rows, idx.shape[0], ka, rkn, w, adaptive, pilot, hold_block, idx,
             Y0, P, TS, H, TSTR, REF, LO, HI, flags, rtol, atol, max_steps, YF, TF, SQ, QM,
             DEV, EXIT, EXITC, EDRIFT, COUNTS, ERR, STATUS, budget, stop, slot, SAVE, SAVEI,
             per_thread=16, stoppable=True)


@njit(cache=True, nogil=True)
def _second_order_rows(ka, rkn, w, adaptive, pilot, hold_block, idx, Y0, P, TS, H, TSTR,
                       REF, LO, HI, flags, rtol, atol, max_steps, YF, TF, SQ, QM, DEV, EXIT,
                       EXITC, EDRIFT, COUNTS, ERR, STATUS, budget, stop, slot, SAVE, SAVEI,
                       lo, hi):
    """The points idx[lo:hi] of :func:`grid_second_order`, on the calling thread."""
    nb = np.zeros(0)
    for k in range(lo, hi):
        if stop[0] != 0:            # Ctrl-C: the points not started stay as they were
            break
        i = idx[k]
        s = slot[k]
        block = np.empty(hold_block if adaptive else 0)
        h0 = H[i]
        if rkn is not None and pilot and SAVEI[s, SAVED] == 0:
            h0 = pilot_step(ka, Y0[i], P[i], TS[i, 0], TS[i, 1], TSTR[i], rtol, atol, rkn[0],
                            rkn[1], rkn[2], rkn[3], rkn[4], rkn[5], COUNTS[i])
        st, t, jx, drift, err, nh = point_second_order(
            ka, rkn, w, adaptive, Y0[i], P[i], TS[i, 0], TS[i, 1], h0, TSTR[i], REF[i], LO[i],
            HI[i], flags, rtol, atol, max_steps, YF[i], SQ[i], QM[i], DEV[i], COUNTS[i], nb,
            block, budget, stop, SAVE[s], SAVEI[s])
        STATUS[i] = st
        TF[i] = t
        EXITC[i] = jx
        EXIT[i] = t if jx >= 0 else np.nan
        EDRIFT[i] = drift
        ERR[i] = err


# -- RKN 12(10) on lanes: many trajectories per thread, vectorised across them ------------

#: trajectories a thread advances together in :func:`grid_rkn_lanes` (a multiple of the
#: SIMD width; enough independent vectors to hide the latency of the sine's polynomial).
#: On the inverted pendulum's 64 × 64 grid at rtol 1e-4 (benchmarks/bench_measure.py's),
#: one thread: 32 lanes 0.52 s, 64 lanes 0.37 s, 128 lanes 0.33 s, 256 lanes 0.35–0.36 s
#: (2026-11-28, twenty-third session, callees called by address)
LANES = 128
#: A thread's last points end at scattered times, and every step costs all its lanes: once
#: every point of the call has been taken and at most this share of its lanes still run,
#: they pause (saved, as on Ctrl-C) and run on again on as many lanes as they are (from
#: DRAIN_MIN_LANES lanes).  The same steps and numbers; on the 64 × 64 grid at rtol
#: 1e-4 (benchmarks/bench_measure.py's, 2 threads) see benchmarks/README.md.
DRAIN_FRACTION = 0.75
DRAIN_MIN_LANES = 16


@njit(cache=True, inline="always")
def lanes_pause_now(budget, stop, started, cursor, end, paused, L, active):
    """Whether a lanes driver's thread pauses its running points now (RKN 12's and
    DOP853's): on Ctrl-C (``stop[0]``), or to drain — every point of the call taken
    (``started``, or the shared ``cursor`` past ``end``), none paused by the step budget
    (a long run), and at most :data:`DRAIN_FRACTION` of its ``L`` lanes (at least
    :data:`DRAIN_MIN_LANES`) still running.  Never once ``budget`` is 0 (it has paused)."""
    return budget > 0 and (stop[0] != 0 or ((started or peek(cursor) >= end) and paused == 0
                                            and L >= DRAIN_MIN_LANES
                                            and active <= DRAIN_FRACTION * L))
#: accepted steps a pilot records (as :func:`pilot_step`)
PILOT_STEPS = 4096
#: grid_rkn_lanes modes
LANES_ADAPTIVE, LANES_FIXED, LANES_PILOT = range(3)
# what a lane is doing
_IDLE, _PILOT, _ADAPTIVE, _FIXED = range(4)


@njit(cache=True, no_cpython_wrapper=True, fastmath=FAST_MATH, error_model="numpy")
def _lanes_load(ka, l, i, phase, Y0, P, TS, H, TSTR, REF, LO, HI, flags, rtol, atol, q, v, K,
                cq, cv, Pl, R, nd, t, tc, h, hrot, t0l, t1l, Tl, kn, QMl, DEVl, REFl, LOl, HIl,
                e0, drift, errsum, rejected, nh, ph, YF, SQ, COUNTS, scr, Wn, hmax, tvh, sth):
    """Start point i in lane l in ``phase`` (_PILOT: the pilot over the first 1/50 of the
    span, observing nothing; the caller widens that window, as :func:`pilot_step`;
    _ADAPTIVE or _FIXED: the run itself, with ``h[l]`` set by the caller for _FIXED).
    ``scr`` (7, ≥ max(2n, MAX_DRIVE_RATES)) and ``Wn`` (n, n + 1) are scratch.  Returns 0,
    or the point's status when it cannot start: GRID_SINGULAR (the acceleration at the
    start cannot be evaluated), GRID_NON_FINITE (it is not finite)."""
    n = q.shape[0]
    p = P[i]
    qv = scr[0, :n]
    a0 = scr[1, :n]
    cs = scr[2, :max(2 * nd, 1)]
    r = scr[3]
    f = scr[4, :2 * n]
    y1 = scr[5, :2 * n]
    f1 = scr[6, :2 * n]
    for k in range(p.shape[0]):
        Pl[k, l] = p[k]
    call_drive_rates(ka[DRIVE_RATES], p, r)
    for k in range(nd):
        R[k, l] = r[k]
    hmax[l] = _longest_step(r[:nd])
    tvh[l, :] = 0.0
    sth[l, :] = 0
    t0 = TS[i, 0]
    t[l] = t0
    for j in range(n):
        qv[j] = Y0[i, j]
        q[j, l] = Y0[i, j]
        v[j, l] = Y0[i, n + j]
        cq[j, l] = 0.0
        cv[j, l] = 0.0
        QMl[j, l] = 0.0
        DEVl[j, l] = 0.0
        REFl[j, l] = REF[i, j] if (flags & OBS_REF) and phase != _PILOT else q[j, l]
        LOl[j, l] = LO[i, j] if (flags & OBS_BAND) and phase != _PILOT else -np.inf
        HIl[j, l] = HI[i, j] if (flags & OBS_BAND) and phase != _PILOT else np.inf
    for k in range(nd):
        cs[2 * k] = np.cos(r[k] * t0)
        cs[2 * k + 1] = np.sin(r[k] * t0)
    if call_fast_accel(ka[FAST_ACCEL], qv, t0, cs, p, a0, Wn) != 0:
        return GRID_SINGULAR
    COUNTS[i, CNT_EVALS] += 1
    for j in range(n):
        if not math.isfinite(a0[j]):
            return GRID_NON_FINITE
    for j in range(n):
        K[0, j, l] = a0[j]
        for m in range(1, K.shape[0]):
            K[m, j, l] = 0.0
    tc[l] = 0.0
    hrot[l] = -1.0
    t0l[l] = t0
    kn[l] = 1.0
    drift[l] = 0.0
    errsum[l] = 0.0
    rejected[l] = False
    nh[l] = 0
    ph[l] = phase
    if phase == _PILOT:
        t1l[l] = t0 + (TS[i, 1] - t0) / PILOT_SPAN_DIVISOR
        Tl[l] = 0.0
    else:
        t1l[l] = TS[i, 1]
        Tl[l] = TSTR[i] if flags & OBS_STROBE else 0.0
        for j in range(2 * n):
            YF[i, j] = Y0[i, j]
            if flags & OBS_STROBE:
                SQ[i, 0, j] = Y0[i, j]
        if flags & OBS_REF:
            for j in range(n):
                DEVl[j, l] = abs(Y0[i, j] - REF[i, j])
        e0[l] = call_energy(ka[ENERGY], qv, Y0[i, n:], t0, p) if flags & OBS_ENERGY else 0.0
    if phase == _PILOT or (phase == _ADAPTIVE and not H[i] > 0.0):
        for j in range(n):
            f[j] = Y0[i, n + j]
            f[n + j] = a0[j]
        h[l] = starting_step(ka, t0, Y0[i], f, p, rtol, atol, Wn, y1, f1, 1.0 / 11.0)
        COUNTS[i, CNT_EVALS] += 2
    elif phase == _ADAPTIVE:
        h[l] = H[i]
    if phase != _FIXED:
        h[l] = min(h[l], hmax[l])
    if phase == _ADAPTIVE:
        h[l] = _strobe_step(h[l], Tl[l])
    if phase != _FIXED and not h[l] >= 16.0 * _EPS * max(abs(t0), abs(t1l[l])):
        return GRID_UNDERFLOW       # no step would move t (as point_second_order)
    return 0


@njit(cache=True, no_cpython_wrapper=True, fastmath=FAST_MATH, error_model="numpy")
def _lanes_restore(ka, l, i, save, savei, Y0, P, TS, TSTR, REF, LO, HI, flags, q, v, K, cq, cv,
                   Pl, R, nd, t, tc, h, hrot, t0l, t1l, Tl, kn, QMl, DEVl, REFl, LOl, HIl, e0,
                   drift, errsum, rejected, ph, QM, DEV, hmax, tvh, sth, blk, rot, scr):
    """Resume the paused point i in lane l: its inputs from the grid's arrays, its
    integrator state from ``save``/``savei`` (as :func:`_lanes_save` wrote it), its time
    mean and deviation so far from QM and DEV, so that it goes on exactly as an unbroken
    run.  (The stages K[1:] are cleared: a step reads only the ones it computed, and the
    zero coefficients of the others multiply finite values.)"""
    n = q.shape[0]
    p = P[i]
    r = scr[3]
    for k in range(p.shape[0]):
        Pl[k, l] = p[k]
    call_drive_rates(ka[DRIVE_RATES], p, r)
    for k in range(nd):
        R[k, l] = r[k]
    hmax[l] = _longest_step(r[:nd])
    t0l[l] = TS[i, 0]
    t1l[l] = TS[i, 1]
    Tl[l] = TSTR[i] if flags & OBS_STROBE else 0.0
    for j in range(n):
        q[j, l] = save[j]
        v[j, l] = save[n + j]
        cq[j, l] = save[2 * n + j]
        cv[j, l] = save[3 * n + j]
        K[0, j, l] = save[4 * n + j]
        for m in range(1, K.shape[0]):
            K[m, j, l] = 0.0
        QMl[j, l] = QM[i, j]
        DEVl[j, l] = DEV[i, j]
        REFl[j, l] = REF[i, j] if flags & OBS_REF else Y0[i, j]
        LOl[j, l] = LO[i, j] if flags & OBS_BAND else -np.inf
        HIl[j, l] = HI[i, j] if flags & OBS_BAND else np.inf
    o = 5 * n
    t[l] = save[o]
    tc[l] = save[o + 1]
    h[l] = save[o + 2]
    hrot[l] = save[o + 3]
    kn[l] = save[o + 4]
    e0[l] = save[o + 5]
    drift[l] = save[o + 6]
    errsum[l] = save[o + 7]
    rejected[l] = save[o + 8] != 0.0
    ph[l] = int(save[o + 9])
    o += 10
    for k in range(TV_SIZE):
        tvh[l, k] = save[o + k]
    o += TV_SIZE
    nb = blk.shape[1]
    for k in range(nb):
        blk[l, k] = save[o + k]
    o += nb
    for s in range(rot.shape[0]):
        for k in range(rot.shape[1]):
            rot[s, k, l] = save[o]
            o += 1
    for k in range(STATS_SIZE):
        sth[l, k] = savei[1 + k]
    savei[SAVED] = 0


@njit(cache=True, no_cpython_wrapper=True, fastmath=FAST_MATH, error_model="numpy")
def _lanes_save(l, save, savei, q, v, K, cq, cv, t, tc, h, hrot, kn, e0, drift, errsum, rejected,
                ph, tvh, sth, blk, rot):
    """Save the state of the point in lane l, paused after an accepted step (the layout
    :func:`_lanes_restore` reads)."""
    n = q.shape[0]
    for j in range(n):
        save[j] = q[j, l]
        save[n + j] = v[j, l]
        save[2 * n + j] = cq[j, l]
        save[3 * n + j] = cv[j, l]
        save[4 * n + j] = K[0, j, l]
    o = 5 * n
    save[o] = t[l]
    save[o + 1] = tc[l]
    save[o + 2] = h[l]
    save[o + 3] = hrot[l]
    save[o + 4] = kn[l]
    save[o + 5] = e0[l]
    save[o + 6] = drift[l]
    save[o + 7] = errsum[l]
    save[o + 8] = 1.0 if rejected[l] else 0.0
    save[o + 9] = ph[l]
    o += 10
    for k in range(TV_SIZE):
        save[o + k] = tvh[l, k]
    o += TV_SIZE
    nb = blk.shape[1]
    for k in range(nb):
        save[o + k] = blk[l, k]
    o += nb
    for s in range(rot.shape[0]):
        for k in range(rot.shape[1]):
            save[o] = rot[s, k, l]
            o += 1
    for k in range(STATS_SIZE):
        savei[1 + k] = sth[l, k]
    savei[SAVED] = 1


@njit(cache=True, inline="always", fastmath=FAST_MATH, error_model="numpy")
def _acc4(x, a, K, m, j, l):
    x += a[m] * K[m, j, l]
    x += a[m + 1] * K[m + 1, j, l]
    x += a[m + 2] * K[m + 2, j, l]
    x += a[m + 3] * K[m + 3, j, l]
    return x


@njit(cache=True, no_cpython_wrapper=True, fastmath=FAST_MATH, error_model="numpy")
def _weighted_sums(b, bp, db, dbp, K, j, acc, L):
    """acc[0..3, l] = Σ_m (b, b', b − b̂, b' − b̂')[m] K[m, j, l]: the step's increments and
    error estimates, summed in point_second_order's order.  Four stages a pass, the four
    sums in registers: a pass a stage loaded and stored the four sums for each term.
    Written out: with :func:`_acc4` for each sum, K and the weights are loaded again for
    each (2–3 % slower in all, 2026-11-28).  (Unrolled over all 17 stages into registers
    it measured slower: four chains of 17 exceed the registers.)"""
    for l in range(L):
        acc[0, l] = 0.0
        acc[1, l] = 0.0
        acc[2, l] = 0.0
        acc[3, l] = 0.0
    ns = K.shape[0]
    m = 0
    while m + 4 <= ns:
        b0, b1, b2, b3 = b[m], b[m + 1], b[m + 2], b[m + 3]
        p0, p1, p2, p3 = bp[m], bp[m + 1], bp[m + 2], bp[m + 3]
        d0, d1, d2, d3 = db[m], db[m + 1], db[m + 2], db[m + 3]
        e0, e1, e2, e3 = dbp[m], dbp[m + 1], dbp[m + 2], dbp[m + 3]
        for l in range(L):
            k0 = K[m, j, l]
            k1 = K[m + 1, j, l]
            k2 = K[m + 2, j, l]
            k3 = K[m + 3, j, l]
            x = acc[0, l]
            x += b0 * k0
            x += b1 * k1
            x += b2 * k2
            x += b3 * k3
            acc[0, l] = x
            x = acc[1, l]
            x += p0 * k0
            x += p1 * k1
            x += p2 * k2
            x += p3 * k3
            acc[1, l] = x
            x = acc[2, l]
            x += d0 * k0
            x += d1 * k1
            x += d2 * k2
            x += d3 * k3
            acc[2, l] = x
            x = acc[3, l]
            x += e0 * k0
            x += e1 * k1
            x += e2 * k2
            x += e3 * k3
            acc[3, l] = x
        m += 4
    while m < ns:
        bm = b[m]
        bpm = bp[m]
        dbm = db[m]
        dbpm = dbp[m]
        for l in range(L):
            km = K[m, j, l]
            acc[0, l] += bm * km
            acc[1, l] += bpm * km
            acc[2, l] += dbm * km
            acc[3, l] += dbpm * km
        m += 1


@njit(cache=True, no_cpython_wrapper=True, fastmath=FAST_MATH, error_model="numpy")
def _stage_positions(s, A, c, K, q, v, hs, qs, acc, L):
    """qs = q + c_s h v + h² Σ_{m<s} A[s, m] K[m] for every lane.

    Up to 16 earlier stages (RKN 12(10) has 17 stages) the sum runs in registers over
    whole blocks of four: A is strictly lower triangular, so the terms m ≥ s add
    fma(0, K[m], x) = x exactly (the lanes keep K finite: a lane's K is cleared when a
    step of it was not finite and when it takes a new point); the order of the sum is
    point_second_order's, so the rounding is too.  Beyond 16, partial sums in ``acc``."""
    n = q.shape[0]
    a = A[s]
    cs_ = c[s]
    nb = (s + 3) // 4
    for j in range(n):
        if nb == 1:
            for l in range(L):
                hh = hs[l]
                qs[j, l] = q[j, l] + cs_ * hh * v[j, l] + hh * hh * _acc4(0.0, a, K, 0, j, l)
        elif nb == 2:
            for l in range(L):
                hh = hs[l]
                x = _acc4(_acc4(0.0, a, K, 0, j, l), a, K, 4, j, l)
                qs[j, l] = q[j, l] + cs_ * hh * v[j, l] + hh * hh * x
        elif nb == 3:
            for l in range(L):
                hh = hs[l]
                x = _acc4(_acc4(_acc4(0.0, a, K, 0, j, l), a, K, 4, j, l), a, K, 8, j, l)
                qs[j, l] = q[j, l] + cs_ * hh * v[j, l] + hh * hh * x
        elif nb == 4:
            for l in range(L):
                hh = hs[l]
                x = _acc4(_acc4(_acc4(_acc4(0.0, a, K, 0, j, l), a, K, 4, j, l), a, K, 8, j, l),
                          a, K, 12, j, l)
                qs[j, l] = q[j, l] + cs_ * hh * v[j, l] + hh * hh * x
        else:
            for l in range(L):
                acc[0, l] = 0.0
            for m in range(s):
                am = a[m]
                for l in range(L):
                    acc[0, l] += am * K[m, j, l]
            for l in range(L):
                hh = hs[l]
                qs[j, l] = q[j, l] + cs_ * hh * v[j, l] + hh * hh * acc[0, l]


def grid_rkn_lanes(ka, mode, hold_block, idx, Y0, P, TS, H, TSTR, REF, LO, HI, flags, rtol,
                   atol, max_steps, c, A, b, bp, bh, bph, YF, TF, SQ, QM, DEV, EXIT, EXITC,
                   EDRIFT, COUNTS, ERR, STATUS, budget, stop, slot, SAVE, SAVEI):
    """RKN 12(10) over the points ``idx`` on *lanes*: every thread advances up to
    :data:`LANES` of them together, refilling a lane with the next point not yet taken
    by any thread when its trajectory ends (:func:`lagrange_core._thread_blocks.run_shared`).

    ``mode``: LANES_ADAPTIVE ("rkn12": the step control of :func:`point_second_order`,
    held in blocks of ``hold_block`` steps), LANES_FIXED (the step ``H``), LANES_PILOT (the
    step of each point from an adaptive pilot over the first 1/50 of its span, widened
    until it has steps beyond its starting ramp, as :func:`pilot_step`; the pilot runs
    on the lanes too).  Same algorithm, statuses, counts and observables as
    :func:`point_second_order` (and :func:`pilot_step`), to rounding: the arithmetic is
    the same except that sin and cos are the lane polynomials of
    :mod:`lagrange_core._lane_math` (within 2 ulp).

    Why lanes: one trajectory is a chain of dependent evaluations (each stage needs the
    last one's sin q), so alone it waits on latencies, and a call through the kernel's
    address costs more than its arithmetic.  Here every array has the lane as its last
    axis and every loop over lanes is innermost: the stage sums, the drive rotations
    and the kernel itself (``fast_accel_lanes``, one call for all lanes) vectorise, and
    the lanes' independent chains fill each other's latencies.  A lane that fails
    (singular, non-finite) gets its status alone; an idle lane keeps a finite state.

    Pausing, as :func:`grid_second_order`: a point that has taken ``budget`` steps in this
    call (after its pilot) pauses with status GRID_INTERRUPTED, its observables so far
    written and its state in row ``slot[k]`` of ``SAVE``/``SAVEI``; a point whose row is
    marked saved resumes from it.  Once ``stop[0]`` is set (Ctrl-C) every running point
    pauses at its next step and no other point starts.  A thread whose last points run on
    few of its lanes, every point taken, pauses them the same way and runs them again at
    once, on fewer lanes (:data:`DRAIN_FRACTION`).
    """
    if idx.shape[0] == 0:
        return
    calls = NO_CALLS

    def work(lo, hi, cursor=None, width=None, drained=DRAINED):
        # (reads ``calls`` when it runs: set below, after its compile)
        run_draining(_lanes_block, (ka, calls, mode, hold_block), (
            Y0, P, TS, H, TSTR, REF, LO, HI, flags, rtol, atol, max_steps, c, A, b, bp, bh,
            bph, YF, TF, SQ, QM, DEV, EXIT, EXITC, EDRIFT, COUNTS, ERR, STATUS, budget, stop),
            idx, slot, lo, hi, SAVE, SAVEI, stop, drained, cursor, width)

    # the driver's first call (an empty span, which calls no callee) compiles it; then its
    # callees' addresses: compiled meanwhile in another process (simulate_grid starts it:
    # lagrange_core._lanes_ahead), loaded from numba's cache, or compiled now
    first_span_call(work, idx.shape[0])
    calls = lanes_callee_addresses()
    run_shared(work, idx.shape[0], LANES, DRAINED)


@njit(cache=True, nogil=True, error_model="numpy", fastmath=FAST_MATH)
def _lanes_block(ka, calls, mode, hold_block, idx, cursor, hi_b, width, Y0, P, TS, H, TSTR, REF,
                 LO, HI, flags, rtol, atol, max_steps, c, A, b, bp, bh, bph, YF, TF, SQ, QM,
                 DEV, EXIT, EXITC, EDRIFT, COUNTS, ERR, STATUS, budget, stop, slot, SAVE, SAVEI,
                 drained_flag):
    """The points idx[cursor[0]:hi_b] of :func:`grid_rkn_lanes` on up to ``width`` lanes of
    one thread, each free lane taking the next point from ``cursor``, which other threads
    may share (:mod:`lagrange_core._shared_cursor`); a point it drains is saved with
    ``SAVEI[·, SAVED] = drained_flag``.  Its callees are called by their addresses in
    ``calls`` (:func:`lagrange_core._lanes_callees.addresses`; none is called on an empty
    span): their code is not compiled into it."""
    L = min(LANES, width, max(hi_b - peek(cursor), 0))
    # a zero or missing address would be a call to nowhere (a crash, not an error)
    if L > 0 and (calls.shape[0] != N_CALLEES or np.any(calls == 0)):
        raise RuntimeError("RKN 12's lanes driver needs its callees' addresses "
                           "(lagrange_core._lanes_callees.addresses)")
    ns = c.shape[0]
    n = Y0.shape[1] // 2
    npar = P.shape[1]
    nd = drive_rates(ka, P[idx[0]]).shape[0]        # the same for every point
    ncs = max(2 * nd, 1)
    energy = (flags & OBS_ENERGY) != 0
    db = b - bh
    dbp = bp - bph
    # (every array by np.zeros, filled after where it starts elsewhere: each other
    # allocation function, or type, is one more compile of numba's own, ~0.1 s each)
    pt = np.zeros(L, dtype=np.int64)        # the lane's point, or -1
    # the lane's phase; a lane without a point that is not _IDLE is free: it takes the
    # block's next point at the top of the loop (every lane, the first time round)
    ph = np.zeros(L, dtype=np.int64)
    q = np.zeros((n, L))
    v = np.zeros((n, L))
    cq = np.zeros((n, L))
    cv = np.zeros((n, L))
    qn = np.zeros((n, L))
    vn = np.zeros((n, L))
    cqn = np.zeros((n, L))
    cvn = np.zeros((n, L))
    qs = np.zeros((n, L))
    an = np.zeros((n, L))
    K = np.zeros((ns, n, L))
    QMl = np.zeros((n, L))
    DEVl = np.zeros((n, L))
    REFl = np.zeros((n, L))
    LOl = np.zeros((n, L))
    HIl = np.zeros((n, L))
    Pl = np.zeros((max(npar, 1), L))
    R = np.zeros((max(nd, 1), L))
    rot = np.zeros((ns, ncs, L))
    cs0 = np.zeros((ncs, L))
    css = np.zeros((ncs, L))
    work = np.zeros((1 + n * (n + 1), L))
    acc = np.zeros((4, L))
    x = np.zeros(L)
    sx = np.zeros(L)
    cx = np.zeros(L)
    t = np.zeros(L)
    tc = np.zeros(L)
    h = np.zeros(L)
    hs = np.zeros(L)
    hrot = np.zeros(L)
    tar = np.zeros(L)
    tnew = np.zeros(L)
    tcn = np.zeros(L)
    ts = np.zeros(L)
    t0l = np.zeros(L)
    t1l = np.zeros(L)
    Tl = np.zeros(L)
    kn = np.zeros(L)
    e2 = np.zeros(L)
    est = np.zeros(L)
    e0 = np.zeros(L)
    drift = np.zeros(L)
    errsum = np.zeros(L)
    clip = np.zeros(L, dtype=np.bool_)
    rr = np.zeros(L, dtype=np.bool_)
    fin = np.zeros(L, dtype=np.bool_)
    sing = np.zeros(L, dtype=np.bool_)
    rejected = np.zeros(L, dtype=np.bool_)
    inside = np.zeros(L, dtype=np.bool_)
    good = np.zeros(L, dtype=np.bool_)
    upd = np.zeros(L, dtype=np.bool_)
    special = np.zeros(L, dtype=np.bool_)
    errl = np.zeros(L)
    nh = np.zeros(L, dtype=np.int64)
    sl = np.zeros(L, dtype=np.int64)        # the lane's point's row of SAVE
    mx = np.zeros(L, dtype=np.int64)        # the steps its max_steps leaves it
    lim = np.zeros(L, dtype=np.int64)       # the steps it may take in this call
    nst = np.zeros(L, dtype=np.int64)
    nrej = np.zeros(L, dtype=np.int64)
    nev = np.zeros(L, dtype=np.int64)
    ridx = np.zeros(L, dtype=np.int64)
    hmax = np.zeros(L)
    tvh = np.zeros((L, TV_SIZE))
    sth = np.zeros((L, STATS_SIZE), dtype=np.int64)
    blk = np.zeros((L, hold_block if mode == LANES_ADAPTIVE else 0))
    hbuf = np.zeros((L, PILOT_STEPS if mode == LANES_PILOT else 0))
    hpl = np.zeros(L)           # a pilot's step from its last window that finished
    scr = np.zeros((7, max(2 * n, MAX_DRIVE_RATES)))
    Wn = np.zeros((n, n + 1))
    q1 = np.zeros(n)
    v1 = np.zeros(n)
    a1 = np.zeros(n)
    q2 = np.zeros(n)
    v2 = np.zeros(n)
    for l in range(L):
        pt[l] = -1
        ph[l] = _FIXED
        for j in range(n):
            LOl[j, l] = -np.inf
            HIl[j, l] = np.inf
        for k in range(Pl.shape[0]):
            Pl[k, l] = 1.0
    first = _PILOT if mode == LANES_PILOT else (_FIXED if mode == LANES_FIXED else _ADAPTIVE)
    started = False             # every point has been taken (by this thread or another)
    active = 0
    drained = False
    paused = 0                  # points paused by the budget (a long run: no drain)
    while True:
        for l in range(L):          # free lanes take the next points
            if pt[l] >= 0 or ph[l] == _IDLE:
                continue
            while not started and pt[l] < 0:
                k = take(cursor)
                if k >= hi_b:
                    started = True
                    break
                i = idx[k]
                s_ = slot[k]
                sl[l] = s_
                mx[l] = max_steps - COUNTS[i, CNT_STEPS]
                lim[l] = min(budget, mx[l])
                if SAVEI[s_, SAVED] != 0:
                    call_lanes_restore(calls[LANES_RESTORE], ka, l, i, SAVE[s_], SAVEI[s_], Y0,
                                       P, TS, TSTR, REF, LO, HI, flags, q, v, K, cq, cv, Pl, R,
                                       nd, t, tc, h, hrot, t0l, t1l, Tl, kn, QMl, DEVl, REFl,
                                       LOl, HIl, e0, drift, errsum, rejected, ph, QM, DEV,
                                       hmax, tvh, sth, blk, rot, scr)
                    pt[l] = i
                    active += 1
                    continue
                h[l] = H[i]
                st = call_lanes_load(calls[LANES_LOAD], ka, l, i, first, Y0, P, TS, H, TSTR,
                                     REF, LO, HI, flags, rtol, atol, q, v, K, cq, cv, Pl, R,
                                     nd, t, tc, h, hrot, t0l, t1l, Tl, kn, QMl, DEVl, REFl,
                                     LOl, HIl, e0, drift, errsum, rejected, nh, ph, YF, SQ,
                                     COUNTS, scr, Wn, hmax, tvh, sth)
                if st != 0:
                    STATUS[i] = st
                    TF[i] = TS[i, 0]
                    # element by element: an array copied into a slice makes numba compile
                    # its shape-mismatch message (f-strings), ~2 s in each process that
                    # compiles it
                    for k in range(Y0.shape[1]):
                        YF[i, k] = Y0[i, k]
                    EDRIFT[i] = 0.0
                    ERR[i] = 0.0
                else:
                    pt[l] = i
                    active += 1
            if pt[l] < 0:           # idle: a finite state that no longer moves
                ph[l] = _IDLE
                h[l] = 0.0
                hrot[l] = 0.0
                for j in range(n):
                    if not (math.isfinite(q[j, l]) and math.isfinite(v[j, l])):
                        q[j, l] = 0.0
                        v[j, l] = 0.0
                    cq[j, l] = 0.0
                    cv[j, l] = 0.0
                    for m in range(ns):
                        K[m, j, l] = 0.0
        if active == 0:
            break
        # Ctrl-C, or the thread drains (every point taken, few lanes still run): every
        # running point pauses at its next step and no other point starts; drained, they
        # run on at once on fewer lanes (grid_rkn_lanes)
        if lanes_pause_now(budget, stop, started, cursor, hi_b, paused, L, active):
            drained = stop[0] == 0
            budget = 0
            started = True
            for l in range(L):
                lim[l] = min(lim[l], nst[l])
        # the step of every lane: its length (shortened to land on t1 or a strobe time)
        any_adaptive = False
        for l in range(L):
            any_adaptive |= ph[l] == _PILOT or ph[l] == _ADAPTIVE
            tt = t[l]
            tg = t1l[l]
            ts_k = t0l[l] + kn[l] * Tl[l]
            tg = ts_k if (Tl[l] > 0.0 and ts_k < tg) else tg
            tar[l] = tg
            hh = h[l]
            # (a fixed or strobe-divided step a rounding short of its target lands on it)
            grow = 1.0 + 1e-10 if (ph[l] == _FIXED or Tl[l] > 0.0) else 1.0
            cl = tt + hh * grow >= tg
            hh = tg - tt if cl else hh
            hh = 0.0 if ph[l] == _IDLE else hh
            clip[l] = cl
            hs[l] = hh
            # a step shortened by rounding only keeps its rotations (as point_second_order)
            rr[l] = abs(hh - hrot[l]) > 4.0 * _EPS * max(abs(tt), abs(tg))
        nr = 0
        for l in range(L):
            if rr[l]:
                ridx[nr] = l
                nr += 1
        if nr > 0:                  # the drive's rotations over the stages of new steps
            for s in range(ns):
                for k in range(nd):
                    for u in range(nr):
                        x[u] = R[k, ridx[u]] * c[s] * hs[ridx[u]]
                    call_sincos_rows(calls[SINCOS_ROWS], x, sx, cx, nr)
                    for u in range(nr):
                        rot[s, 2 * k, ridx[u]] = cx[u]
                        rot[s, 2 * k + 1, ridx[u]] = sx[u]
            for u in range(nr):
                hrot[ridx[u]] = hs[ridx[u]]
        for k in range(nd):         # the drive at the step's start, exactly
            for l in range(L):
                x[l] = R[k, l] * t[l]
            call_sincos_rows(calls[SINCOS_ROWS], x, sx, cx, L)
            for l in range(L):
                cs0[2 * k, l] = cx[l]
                cs0[2 * k + 1, l] = sx[l]
        for l in range(L):
            sing[l] = False
        # the stages: q + c h v + h² Σ A K, the drive rotated, one call for all lanes
        for s in range(1, ns):
            cs_ = c[s]
            call_stage_positions(calls[STAGE_POSITIONS], s, A, c, K, q, v, hs, qs, acc, L)
            for k in range(nd):
                for l in range(L):
                    cr = rot[s, 2 * k, l]
                    sr = rot[s, 2 * k + 1, l]
                    css[2 * k, l] = cs0[2 * k, l] * cr - cs0[2 * k + 1, l] * sr
                    css[2 * k + 1, l] = cs0[2 * k + 1, l] * cr + cs0[2 * k, l] * sr
            for l in range(L):
                ts[l] = t[l] + cs_ * hs[l]
            if call_fast_accel_on_lanes(calls[FAST_ACCEL_ON_LANES], ka, qs, ts, css, Pl, K[s],
                                        work, L) > 0:
                for l in range(L):
                    if work[0, l] != 0.0:
                        sing[l] = True
        # the new state (compensated sums), the error estimate, finiteness, the band
        for l in range(L):
            e2[l] = 0.0
            est[l] = 0.0
            fin[l] = True
            inside[l] = True
        for j in range(n):
            call_weighted_sums(calls[WEIGHTED_SUMS], b, bp, db, dbp, K, j, acc, L)
            for l in range(L):
                hh = hs[l]
                q_ = q[j, l]
                v_ = v[j, l]
                yq = hh * v_ + hh * hh * acc[0, l] - cq[j, l]
                qn_ = q_ + yq
                qn[j, l] = qn_
                cqn[j, l] = (qn_ - q_) - yq
                yv = hh * acc[1, l] - cv[j, l]
                vn_ = v_ + yv
                vn[j, l] = vn_
                cvn[j, l] = (vn_ - v_) - yv
                dq = acc[2, l] * hh * hh
                dv = acc[3, l] * hh
                est[l] = max(est[l], abs(dq), abs(dv))
                fin[l] = fin[l] & math.isfinite(qn_) & math.isfinite(vn_)
                inside[l] = inside[l] & (LOl[j, l] <= qn_) & (qn_ <= HIl[j, l])
                acc[2, l] = dq
                acc[3, l] = dv
            if any_adaptive:        # the scaled error norm (the fixed step needs none)
                for l in range(L):
                    dq = acc[2, l]
                    dv = acc[3, l]
                    sq_ = atol + rtol * max(abs(q[j, l]), abs(qn[j, l]))
                    sv_ = atol + rtol * max(abs(v[j, l]), abs(vn[j, l]))
                    e2[l] += (dq / sq_) ** 2 + (dv / sv_) ** 2
        # FSAL: the acceleration at the step's end (every lane; kept where accepted)
        for l in range(L):
            yk = hs[l] - tc[l]
            tk = t[l] + yk
            tnew[l] = tar[l] if clip[l] else tk
            tcn[l] = 0.0 if clip[l] else (tk - t[l]) - yk
        for k in range(nd):
            for l in range(L):
                cr = rot[ns - 1, 2 * k, l]
                sr = rot[ns - 1, 2 * k + 1, l]
                css[2 * k, l] = cs0[2 * k, l] * cr - cs0[2 * k + 1, l] * sr
                css[2 * k + 1, l] = cs0[2 * k + 1, l] * cr + cs0[2 * k, l] * sr
        if call_fast_accel_on_lanes(calls[FAST_ACCEL_ON_LANES], ka, qn, tnew, css, Pl, an,
                                    work, L) == 0:
            for l in range(L):
                work[0, l] = 0.0
        # the common case for every lane at once: an accepted step that stays in the band
        for l in range(L):
            err = math.sqrt(e2[l] / (2 * n))
            errl[l] = err
            ok = (fin[l] & (not sing[l]) & (work[0, l] == 0.0) & (ph[l] != _IDLE)
                  & ((ph[l] == _FIXED) | (err < 1.0)))
            good[l] = ok
            upd[l] = ok & inside[l]
        for j in range(n):
            for l in range(L):
                u = upd[l]
                hh = hs[l]
                q_ = q[j, l]
                qn_ = qn[j, l]
                mean = 0.5 * hh * (q_ + qn_) + hh * hh * (v[j, l] - vn[j, l]) / 12.0
                QMl[j, l] += mean if u else 0.0
                d = abs(qn_ - REFl[j, l])
                DEVl[j, l] = d if (u and d > DEVl[j, l]) else DEVl[j, l]
                q[j, l] = qn_ if u else q_
                v[j, l] = vn[j, l] if u else v[j, l]
                cq[j, l] = cqn[j, l] if u else cq[j, l]
                cv[j, l] = cvn[j, l] if u else cv[j, l]
                K[0, j, l] = an[j, l] if u else K[0, j, l]
        for l in range(L):
            u = upd[l]
            t[l] = tnew[l] if u else t[l]
            tc[l] = tcn[l] if u else tc[l]
            nst[l] += 1 if good[l] else 0
            nev[l] += ns if good[l] else ns - 1
            errsum[l] += est[l] if good[l] else 0.0
            special[l] = (pt[l] >= 0) & ((not u) | clip[l] | (t[l] >= t1l[l])
                                         | (ph[l] != _FIXED) | (nst[l] >= lim[l])
                                         | energy)
        if mode == LANES_ADAPTIVE:  # a held step that stays held needs no lane-by-lane
            for l in range(L):      # work: record its error ratio (held_step_record)
                hold = tvh[l, TV_HOLD]
                k_ = sth[l, ST_BLOCK]
                hh_hold = _strobe_step(hold, Tl[l])
                # (only where rkn_next_step would leave the step as it is: the held step,
                # not a step retaken after a rejection, which it sets back to the held one)
                if (special[l] and upd[l] and ph[l] == _ADAPTIVE and hold > 0.0
                        and hs[l] >= hh_hold and h[l] == hh_hold and not rejected[l]
                        and not clip[l] and k_ + 1 < hold_block and t[l] < t1l[l]
                        and nst[l] < lim[l] and not energy):
                    xr = tvh[l, TV_HREF] / hs[l]
                    x2 = xr * xr
                    x4 = x2 * x2
                    blk[l, k_] = errl[l] * (x4 * x4 * x2 * xr)
                    sth[l, ST_BLOCK] = k_ + 1
                    special[l] = False
        # the rest, lane by lane (_lanes_by_lane): rejections, failures, band exits,
        # strobe samples, step-size control, ends (an ended lane is free: the loop's top
        # gives it the next point)
        nsp = 0
        for l in range(L):
            nsp += 1 if special[l] else 0
        if nsp > 0:
            # (no conditional expression among the arguments: numba cannot read a call of
            # this many arguments with control flow inside it)
            drained_now = 1 if drained else 0
            ended, now_paused = call_lanes_by_lane(
                calls[LANES_BY_LANE], ka, calls, nd, budget, drained_now,
                drained_flag, Y0, P, TS, H, TSTR, REF, LO, HI, flags, rtol, atol, c, A, b, bp,
                YF, TF, SQ, QM, DEV, EXIT, EXITC, EDRIFT, COUNTS, ERR, STATUS, SAVE, SAVEI, pt,
                ph, special, good, fin, sing, upd, clip, rejected, hs, errl, est, t, tc, h,
                hrot, t0l, t1l, Tl, kn, e0, drift, errsum, hmax, hpl, nst, nrej, nev, nh, mx,
                lim, sl, q, v, qn, vn, cq, cv, K, QMl, DEVl, REFl, LOl, HIl, Pl, R, rot, tvh,
                sth, blk, hbuf, scr, Wn, q1, v1, a1, q2, v2)
            active -= ended
            paused += now_paused


@njit(cache=True, no_cpython_wrapper=True, error_model="numpy", fastmath=FAST_MATH)
def _lanes_by_lane(ka, calls, nd, budget, drained, drained_flag, Y0, P, TS, H, TSTR, REF, LO,
                   HI, flags, rtol, atol, c, A, b, bp, YF, TF, SQ, QM, DEV, EXIT, EXITC, EDRIFT,
                   COUNTS, ERR, STATUS, SAVE, SAVEI, pt, ph, special, good, fin, sing, upd, clip,
                   rejected, hs, errl, est, t, tc, h, hrot, t0l, t1l, Tl, kn, e0, drift, errsum,
                   hmax, hpl, nst, nrej, nev, nh, mx, lim, sl, q, v, qn, vn, cq, cv, K, QMl,
                   DEVl, REFl, LOl, HIl, Pl, R, rot, tvh, sth, blk, hbuf, scr, Wn, q1, v1, a1,
                   q2, v2):
    """The lanes of :func:`_lanes_block` whose step needs work lane by lane (``special``):
    rejections, failures, band exits, strobe samples, energy, step-size control, a pilot's
    end, a point's end (recorded; its lane freed: ``pt[l] = -1``, the block's loop gives
    it the next point).  Returns (points ended, of them paused by the budget).

    Called by the driver by address (:mod:`lagrange_core._lanes_callees`), its code not
    compiled into the driver's: these ~160 lines, with the step control inlined, made the
    driver's own compile 11.7–12.8 s, 7.3–8.0 s without them (every callee cached, two
    runs each, 2026-11-29; benchmarks/README.md, thirtieth session).  Here they compile
    on their own (~4 s), ahead in a second process or from numba's cache."""
    L = pt.shape[0]
    n = q.shape[0]
    ns = K.shape[0]
    expo = -1.0 / 11.0
    energy = (flags & OBS_ENERGY) != 0
    ended = 0
    paused = 0
    for l in range(L):
        if not special[l]:
            continue
        i = pt[l]
        phase = ph[l]
        adaptive = phase != _FIXED
        observe = phase != _PILOT
        hh = hs[l]
        tt = t[l]
        st = -1
        jx = -1
        if not good[l]:
            if not fin[l]:      # a non-finite stage must not reach the next sums
                for j in range(n):
                    for m in range(1, ns):
                        K[m, j, l] = 0.0
            if sing[l]:
                st = GRID_SINGULAR
            elif adaptive and not (fin[l] and errl[l] < 1.0):
                err = errl[l]
                nrej[l] += 1
                held_step_record(tvh[l], sth[l], blk[l] if phase == _ADAPTIVE
                                 else blk[l, :0], err, hh, hmax[l])
                h[l] = hh * max(0.2, 0.9 * err ** expo) if math.isfinite(err) else 0.2 * hh
                h[l] = _strobe_step(h[l], Tl[l])
                rejected[l] = True
                if h[l] < 16.0 * _EPS * max(abs(tt), abs(t1l[l])):
                    st = GRID_NON_FINITE if not fin[l] else GRID_UNDERFLOW
                else:
                    continue
            elif not fin[l]:
                st = GRID_NON_FINITE
            else:               # the acceleration at the step's end failed
                nst[l] += 1
                errsum[l] += est[l]
                if phase == _PILOT and nh[l] < PILOT_STEPS and not clip[l]:
                    hbuf[l, nh[l]] = hh
                    nh[l] += 1
                st = GRID_SINGULAR
        else:
            if phase == _PILOT and nh[l] < PILOT_STEPS and not clip[l]:
                hbuf[l, nh[l]] = hh
                nh[l] += 1
            if not upd[l]:      # left the band inside the step: stop there
                for j in range(n):
                    q1[j] = q[j, l]
                    v1[j] = v[j, l]
                    q2[j] = qn[j, l]
                    v2[j] = vn[j, l]
                    a1[j] = K[0, j, l]
                xf, jx, ev = call_rkn_band_exit(calls[RKN_BAND_EXIT], ka, tt, hh, q1, v1,
                                                a1, q2, v2, P[i], LO[i], HI[i], c, A, b,
                                                bp, R[:nd, l].copy(), YF[i])
                nev[l] += ev
                for j in range(n):
                    QMl[j, l] += (0.5 * xf * hh * (q1[j] + YF[i, j]) + xf * hh * xf
                                  * hh * (v1[j] - YF[i, n + j]) / 12.0)
                t[l] = tt + xf * hh
                st = GRID_LEFT_BAND
            else:
                if observe and energy:
                    for j in range(n):
                        q1[j] = q[j, l]
                        v1[j] = v[j, l]
                    d = abs(call_energy(ka[ENERGY], q1, v1, t[l], P[i]) - e0[l])
                    if d > drift[l]:
                        drift[l] = d
                if clip[l] and Tl[l] > 0.0 and t[l] == t0l[l] + kn[l] * Tl[l]:
                    k_ = int(kn[l])
                    if k_ < SQ.shape[1]:
                        for j in range(n):
                            SQ[i, k_, j] = q[j, l]
                            SQ[i, k_, n + j] = v[j, l]
                    kn[l] += 1.0
                if t[l] >= t1l[l] or (phase == _PILOT and nh[l] >= PILOT_STEPS):
                    st = GRID_FINISHED      # (a pilot with all the steps it records)
                elif observe and nst[l] >= mx[l]:
                    st = GRID_MAX_STEPS
                else:
                    if adaptive:
                        h[l] = rkn_next_step(tvh[l], sth[l], blk[l] if phase == _ADAPTIVE
                                             else blk[l, :0], h[l], hh, errl[l], clip[l],
                                             rejected[l], hmax[l])
                        h[l] = _strobe_step(h[l], Tl[l])
                        rejected[l] = False
                        if not h[l] >= 16.0 * _EPS * max(abs(t[l]), abs(t1l[l])):
                            st = GRID_UNDERFLOW
                    if st < 0 and observe and nst[l] >= lim[l]:
                        st = GRID_INTERRUPTED   # pause: saved below, resumed next call
        if st < 0:
            continue
        if phase == _PILOT:     # the pilot ends (however): the run itself begins
            m_ = nh[l]
            span = TS[i, 1] - TS[i, 0]
            tw = t1l[l]
            hq, settled = call_pilot_step_quantile(calls[PILOT_STEP_QUANTILE], hbuf[l], m_)
            if st != GRID_FINISHED and tw > TS[i, 0] + span / PILOT_SPAN_DIVISOR:
                # a widened pilot failed (a blow-up, an underflow): its shrinking steps
                # say nothing; the step of the last window that finished (as pilot_step)
                hq = hpl[l]
            elif (st == GRID_FINISHED and settled < PILOT_MIN_SETTLED
                    and m_ < PILOT_STEPS and tw < TS[i, 1]):
                hpl[l] = hq
                # too few steps beyond the starting ramp: the pilot again, over a
                # longer window (as pilot_step)
                st = call_lanes_load(calls[LANES_LOAD], ka, l, i, _PILOT, Y0, P,
                                     TS, H, TSTR, REF, LO, HI, flags, rtol, atol, q, v, K,
                                     cq, cv, Pl, R, nd, t, tc, h, hrot, t0l, t1l, Tl, kn,
                                     QMl, DEVl, REFl, LOl, HIl, e0, drift, errsum,
                                     rejected, nh, ph, YF, SQ, COUNTS, scr, Wn, hmax, tvh,
                                     sth)
                t1l[l] = min(TS[i, 1], TS[i, 0] + PILOT_WIDEN * (tw - TS[i, 0]))
                if st == 0:
                    continue
            hf = span
            if hq > 0.0:
                period = TSTR[i] if TSTR[i] > 0.0 else span
                hf = period / math.ceil(period / hq)
            h[l] = hf
            st = call_lanes_load(calls[LANES_LOAD], ka, l, i, _FIXED, Y0, P, TS,
                                 H, TSTR, REF, LO, HI, flags, rtol, atol, q, v, K, cq, cv,
                                 Pl, R, nd, t, tc, h, hrot, t0l, t1l, Tl, kn, QMl, DEVl,
                                 REFl, LOl, HIl, e0, drift, errsum, rejected, nh, ph, YF,
                                 SQ, COUNTS, scr, Wn, hmax, tvh, sth)
            lim[l] = min(nst[l] + budget, mx[l])
            if st == 0 and nst[l] < mx[l]:
                continue
            if st == 0:         # the pilot used the whole step budget
                st = GRID_MAX_STEPS
        # the point ends: record it; the lane is free for the next point
        STATUS[i] = st
        TF[i] = t[l]
        EDRIFT[i] = drift[l]
        ERR[i] = errsum[l]
        EXITC[i] = jx
        EXIT[i] = t[l] if jx >= 0 else np.nan
        COUNTS[i, CNT_STEPS] += nst[l]
        COUNTS[i, CNT_REJECTED] += nrej[l]
        COUNTS[i, CNT_EVALS] += nev[l]
        for j in range(n):
            QM[i, j] = QMl[j, l]
            DEV[i, j] = DEVl[j, l]
            if jx < 0:
                YF[i, j] = q[j, l]
                YF[i, n + j] = v[j, l]
        if st == GRID_INTERRUPTED:
            call_lanes_save(calls[LANES_SAVE], l, SAVE[sl[l]], SAVEI[sl[l]], q, v, K, cq,
                            cv, t, tc, h, hrot, kn, e0, drift, errsum, rejected, ph, tvh,
                            sth, blk, rot)
            if drained:
                SAVEI[sl[l], SAVED] = drained_flag
            else:
                paused += 1
        pt[l] = -1
        ended += 1
        nst[l] = 0
        nrej[l] = 0
        nev[l] = 0
    return ended, paused


# -- any system: DOP853 on the right-hand side, with projection onto the constraints -----

@njit(cache=True)
def point_dop853(ka, m, adaptive, y0, p, t0, t1, h0, T, ref, lo, hi, flags, rtol, atol,
                 max_steps, A, B, C, E3, E5, yf, sq, qsum, dev, counts, budget, stop, save,
                 savei):
    """Integrate one point with DOP853 (adaptive, or the fixed 8th-order step ``h0``) on
    the system's ``rhs``; constrained states are projected onto Φ = 0, Φ̇ = 0 after every
    step.  Observables, pausing (``budget``, ``stop``, ``save``, ``savei``) and returns as
    :func:`point_second_order`."""
    n = y0.shape[0] // 2
    n2 = 2 * n
    W = np.zeros((n + m, n + m + 1))
    G = np.zeros((m, n))
    P = np.zeros((max(m, 1), max(m, 1) + 1))
    res = np.zeros(max(2 * m, 1))
    Kst = np.empty((13, n2))
    y = y0.copy()
    ynew = np.empty(n2)
    ytmp = np.empty(n2)
    if savei[SAVED] == 1:           # resume a paused point
        for i in range(n2):
            y[i] = save[i]
            Kst[0, i] = save[n2 + i]
        o = 2 * n2
        t = save[o]
        t_carry = save[o + 1]
        h = save[o + 2]
        err_sum = save[o + 3]
        drift = save[o + 4]
        e0 = save[o + 5]
        k_next = int(save[o + 6])
        rejected = save[o + 7] != 0.0
        savei[SAVED] = 0
    else:
        for i in range(n2):
            yf[i] = y[i]
        if flags & OBS_REF:
            for i in range(n):
                dev[i] = abs(y[i] - ref[i])
        t = t0
        if m > 0 and project_constraints(ka, m, y, t, p, G, P, res) != 0:
            return GRID_SINGULAR, t, -1, 0.0, 0.0, 0
        if call_rhs(ka[RHS], t, y, p, Kst[0], W) != 0:
            return GRID_SINGULAR, t, -1, 0.0, 0.0, 0
        counts[CNT_EVALS] += 1
        e0 = call_energy(ka[ENERGY], y[:n], y[n:], t, p) if flags & OBS_ENERGY else 0.0
        drift = 0.0
        if flags & OBS_STROBE:
            for i in range(n2):
                sq[0, i] = y[i]
        k_next = 1
        h = h0
        if adaptive and h <= 0.0:
            h = starting_step(ka, t, y, Kst[0], p, rtol, atol, W, np.empty(n2), np.empty(n2),
                              1.0 / 8.0)
            counts[CNT_EVALS] += 2
        t_carry = 0.0
        err_sum = 0.0
        rejected = False
    steps0 = counts[CNT_STEPS]
    status = GRID_FINISHED
    jx = -1
    kst = 0
    finite = True
    while True:
        if t >= t1:
            break
        if counts[CNT_STEPS] >= max_steps:
            status = GRID_MAX_STEPS
            break
        taken = counts[CNT_STEPS] - steps0
        if taken >= budget or (taken > 0 and stop[0] != 0):   # pause (as point_second_order)
            for i in range(n2):
                save[i] = y[i]
                save[n2 + i] = Kst[0, i]
                yf[i] = y[i]
            o = 2 * n2
            save[o] = t
            save[o + 1] = t_carry
            save[o + 2] = h
            save[o + 3] = err_sum
            save[o + 4] = drift
            save[o + 5] = e0
            save[o + 6] = k_next
            save[o + 7] = 1.0 if rejected else 0.0
            savei[SAVED] = 1
            return GRID_INTERRUPTED, t, -1, drift, err_sum, 0
        hmin = 16.0 * _EPS * max(abs(t), abs(t1))
        if adaptive and not h >= hmin:      # as point_second_order
            status = GRID_UNDERFLOW
            break
        t_target = _next_stop(t1, T, k_next, t0, flags)
        while True:
            clipped = False
            hs = h
            if t + hs >= t_target or (not adaptive and t + hs * (1.0 + 1e-10) >= t_target):
                hs = t_target - t
                clipped = True
            for s in range(1, 12):
                for i in range(n2):
                    acc = 0.0
                    for j in range(s):
                        acc += A[s, j] * Kst[j, i]
                    ytmp[i] = y[i] + hs * acc
                kst = call_rhs(ka[RHS], t + C[s] * hs, ytmp, p, Kst[s], W)
                if kst != 0:
                    break
            if kst != 0:
                break
            for i in range(n2):
                acc = 0.0
                for j in range(12):
                    acc += B[j] * Kst[j, i]
                ynew[i] = y[i] + hs * acc
            kst = call_rhs(ka[RHS], t + hs, ynew, p, Kst[12], W)
            counts[CNT_EVALS] += 12
            if kst != 0:
                break
            e5n = 0.0
            e3n = 0.0
            est = 0.0
            for i in range(n2):
                a5 = 0.0
                a3 = 0.0
                for j in range(13):
                    a5 += E5[j] * Kst[j, i]
                    a3 += E3[j] * Kst[j, i]
                a5 *= hs
                a3 *= hs
                sc = atol + rtol * max(abs(y[i]), abs(ynew[i]))
                e5n += (a5 / sc) ** 2
                e3n += (a3 / sc) ** 2
                den = a5 * a5 + 0.01 * a3 * a3
                if den > 0.0:
                    est = max(est, a5 * a5 / math.sqrt(den))
            err = 0.0 if (e5n == 0.0 and e3n == 0.0) else e5n / math.sqrt((e5n + 0.01 * e3n) * n2)
            finite = math.isfinite(err)
            for i in range(n2):
                if not math.isfinite(ynew[i]):
                    finite = False
            if (not adaptive) or (finite and err < 1.0):
                break
            counts[CNT_REJECTED] += 1
            h = hs * max(0.2, 0.9 * err ** (-1.0 / 8.0)) if math.isfinite(err) else 0.2 * hs
            rejected = True
            if h < hmin:
                break
        if kst != 0:
            status = GRID_SINGULAR
            break
        if not finite:
            status = GRID_NON_FINITE
            break
        if adaptive and not err < 1.0:
            status = GRID_UNDERFLOW
            break
        counts[CNT_STEPS] += 1
        err_sum += est
        if clipped:
            t_new = t_target
            t_carry = 0.0
        else:
            yk = hs - t_carry
            t_new = t + yk
            t_carry = (t_new - t) - yk
        if m > 0:
            if project_constraints(ka, m, ynew, t_new, p, G, P, res) != 0:
                status = GRID_SINGULAR
                break
            if call_rhs(ka[RHS], t_new, ynew, p, Kst[12], W) != 0:
                status = GRID_SINGULAR
                break
            counts[CNT_EVALS] += 1
        x, jx, drift = _observe(ka, t, hs, y[:n], y[n:], ynew[:n], ynew[n:], p, flags, ref, lo,
                                hi, dev, qsum, e0, drift, yf)
        if jx >= 0:
            t = t + x * hs
            status = GRID_LEFT_BAND
            break
        for i in range(n2):
            y[i] = ynew[i]
            Kst[0, i] = Kst[12, i]
        t = t_new
        if clipped and (flags & OBS_STROBE) and t == t0 + k_next * T:
            if k_next < sq.shape[0]:
                for i in range(n2):
                    sq[k_next, i] = y[i]
            k_next += 1
        if adaptive:
            factor = 10.0 if err == 0.0 else min(10.0, 0.9 * err ** (-1.0 / 8.0))
            if rejected:
                factor = min(1.0, factor)
            h = max(h, hs * factor) if clipped else hs * factor
            rejected = False
    if jx < 0:
        for i in range(n2):
            yf[i] = y[i]
    return status, t, jx, drift, err_sum, 0


def grid_dop853(ka, m, adaptive, idx, Y0, P, TS, H, TSTR, REF, LO, HI, flags, rtol, atol,
                max_steps, A, B, C, E3, E5, YF, TF, SQ, QM, DEV, EXIT, EXITC, EDRIFT,
                COUNTS, ERR, STATUS, budget, stop, slot, SAVE, SAVEI):
    """Every point ``idx[k]`` with :func:`point_dop853` (pausing and stopping as
    :func:`grid_second_order`).

    The points go in blocks to the threads, as :func:`grid_second_order`'s.
    """
    run_rows(_dop853_rows, idx.shape[0], ka, m, adaptive, idx, Y0, P, TS, H, TSTR, REF, LO,
             HI, flags, rtol, atol, max_steps, A, B, C, E3, E5, YF, TF, SQ, QM, DEV, EXIT,
             EXITC, EDRIFT, COUNTS, ERR, STATUS, budget, stop, slot, SAVE, SAVEI,
             per_thread=16, stoppable=True)


@njit(cache=True, nogil=True)
def _dop853_rows(ka, m, adaptive, idx, Y0, P, TS, H, TSTR, REF, LO, HI, flags, rtol, atol,
                 max_steps, A, B, C, E3, E5, YF, TF, SQ, QM, DEV, EXIT, EXITC, EDRIFT,
                 COUNTS, ERR, STATUS, budget, stop, slot, SAVE, SAVEI, lo, hi):
    """The points idx[lo:hi] of :func:`grid_dop853`, on the calling thread."""
    for k in range(lo, hi):
        if stop[0] != 0:            # Ctrl-C: the points not started stay as they were
            break
        i = idx[k]
        s = slot[k]
        st, t, jx, drift, err, nh = point_dop853(
            ka, m, adaptive, Y0[i], P[i], TS[i, 0], TS[i, 1], H[i], TSTR[i], REF[i], LO[i],
            HI[i], flags, rtol, atol, max_steps, A, B, C, E3, E5, YF[i], SQ[i], QM[i], DEV[i],
            COUNTS[i], budget, stop, SAVE[s], SAVEI[s])
        STATUS[i] = st
        TF[i] = t
        EXITC[i] = jx
        EXIT[i] = t if jx >= 0 else np.nan
        EDRIFT[i] = drift
        ERR[i] = err


# numba's cache does not notice changes to the kernels these call
# (nor to the signatures its lanes driver declares for the callees it calls by address)
from . import (  # noqa: E402
    _integrator_kernels,
    _kernel_calls,
    _lanes_callees,
    _linalg,
    _native_calls,
    _selection,
)
from .module_store import guard_numba_cache  # noqa: E402

guard_numba_cache(sys.modules[__name__], _integrator_kernels, _kernel_calls, _lanes_callees,
                  _linalg, _native_calls, _selection)


# a first call on the main thread compiles where Ctrl-C need not wait for it
from ._first_calls import guard as _guard_first_calls  # noqa: E402

_guard_first_calls(__name__)
