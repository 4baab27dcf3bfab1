"""The integrators' compiled kernels: compiled once per installation, for every system.

Why one module over 800 lines: the drivers of every method share the inlined step,
dense-output and event helpers below, and numba caches per source file (see
:mod:`lagrange_core._batch_kernels` for the same reason).

Every function here is an ordinary ``@njit(cache=True)`` function.  It reaches the
system's kernels (``rhs``, ``accelerations``, ``energy``, ``constraint_residual``,
``augmented``; see :mod:`lagrange_core.codegen`) through their C entry points: ``ka`` is
the system's table of kernel addresses (:meth:`lagrange_core.codegen.Kernels.addresses`,
slots named in :mod:`lagrange_core._kernel_calls`), and ``m`` its number of constraints;
n, the number of coordinates, is read off the state.  So numba's cache serves the same
machine code to every system, and a new system's first ``simulate`` compiles only the
system's own kernels.  Method coefficient tables are passed in as arrays (they are
data; :mod:`lagrange_core.integrate` owns them).

The drivers integrate in *chunks*: a call advances until ``t_end``, until a step
budget is used up, until the output buffer is full or until a terminal event,
and returns a status, with the whole integrator state in the arrays it was given
(``y``, ``f``, ``tv``, ``stats``) so the next call continues exactly where this
one stopped.  Python regains control between chunks (Ctrl-C, memory).

Reference counts: numba counts the references to every array handed to an inlined
helper, an atomic add and subtract per array per call, unless its pruning pass removes
them, which it does not in a loop as branched as a driver's.  In the RKN driver that was
~40 atomic operations per step, a third of the step's time (issue 24).  So the q̈ = f(q, t)
drivers allocate their arrays and hand them to a loop function that works on views which
own nothing (:func:`unowned`): the counting is then a check of a null pointer.  The
arrays stay owned, by the caller and by the allocating function, while the loop runs.

Shared state layout (the named slots below)
-------------------------------------------
``tv`` (float64, ``TV_SIZE``): ``TV_T`` time, ``TV_END`` end time, ``TV_H`` next step,
``TV_ERROR`` sum of local error estimates, ``TV_T_CARRY`` Kahan compensation of t,
``TV_HOLD`` the held step of the adaptive RKN (0 until the first block is complete) and
``TV_HREF`` the step its block of error ratios refers to (:func:`held_step_record`).
``stats`` (int64, ``STATS_SIZE``): ``ST_STEPS`` accepted steps, ``ST_REJECTED``,
``ST_RHS`` right-hand-side evaluations, ``ST_STORED`` output rows used, ``ST_STRIDE``
stride counter, ``ST_NEXT_EVAL`` next t_eval index, ``ST_EVENTS`` events stored,
``ST_BLOCK`` error ratios recorded in the current block of the held step.

Status codes returned (``STATUS_*``): done, chunk budget used, output buffer full,
terminal event, singular mass matrix, step size underflow / non-finite state,
event buffer full.

Events (``ev_int`` rows: kind, index, direction, terminal; ``ev_val`` the value):
kind ``EV_COORDINATE`` q_j − value, ``EV_VELOCITY`` q̇_j − value, ``EV_MULTIPLIER``
λ_j − value, ``EV_ENERGY`` energy − value.  direction +1 only upward crossings, −1
only downward, 0 both.
"""
import math
import sys

import numpy as np
from numba import njit, types
from numba.core import cgutils
from numba.extending import intrinsic

from ._kernel_calls import (
    DRIVE_RATES,
    ENERGY,
    FAST_ACCEL,
    MAX_DRIVE_RATES,
    PHI_Q,
    RESIDUAL,
    RHS,
    call_constraint_jacobian,
    call_drive_rates,
    call_energy,
    call_fast_accel,
    call_residual,
    call_rhs,
)
from ._linalg import solve_augmented
from ._selection import kth_smallest_in_place

# -- named constants (module globals are compile-time constants for numba) --------------

#: what a driver's chunk returns
STATUS_DONE, STATUS_CHUNK, STATUS_FULL, STATUS_EVENT, STATUS_SINGULAR, STATUS_UNDERFLOW, \
    STATUS_EVFULL = range(7)
#: slots of the float state ``tv``
TV_T, TV_END, TV_H, TV_ERROR, TV_HOLD, TV_T_CARRY, TV_HREF = range(7)
TV_SIZE = 7
#: slots of the integer statistics ``stats``
ST_STEPS, ST_REJECTED, ST_RHS, ST_STORED, ST_STRIDE, ST_NEXT_EVAL, ST_EVENTS, ST_BLOCK = range(8)
STATS_SIZE = 8
#: the held step of the adaptive RKN: a low quantile (HOLD_QUANTILE) of the ideal steps
#: proposed by each block of evaluated steps; it grows by at most HOLD_GROWTH per block
HOLD_QUANTILE = 0.2
HOLD_GROWTH = 5.0
#: the first block is shorter (a short run reaches the held step sooner)
HOLD_FIRST = 16
#: an adaptive RKN step spans at most this fraction of the period of the fastest drive
#: harmonic: the embedded error estimate is a truncated series in ωh and stops measuring
#: the error as ωh nears 2π (a step of one period sees the drive at the same phase at
#: both ends); on the driven pendulum longer steps broke the tolerance (rtol 1e-3: 6e-3)
DRIVE_STEP = 0.75
#: a new held step replaces the last one only when it differs by more than this ratio
HOLD_CHANGE = 1.1
#: the RKN driver recomputes the drive's cos/sin at least every DRIVE_RESYNC steps (in
#: between it rotates them: a relative rounding of ~1e-16 per step, not accumulated)
DRIVE_RESYNC = 64
#: event kinds (column 0 of ``ev_int``)
EV_COORDINATE, EV_VELOCITY, EV_MULTIPLIER, EV_ENERGY = range(4)
#: numba's error model without zero-division branches, fused multiply-adds; no
#: reassociation (it would delete the compensated sums) and no finite-math flags, so the
#: NaN/inf checks of the loops stay meaningful
FAST_MATH = {"contract", "arcp", "nsz"}
INLINE = "always"      # the per-step helpers: no call, no reference counting per step


# -- helpers -----------------------------------------------------------------------------

@intrinsic
def unowned(typingctx, arr):
    """``arr`` as a view that owns no reference to its memory (its meminfo is NULL).

    numba increments and decrements the reference count of an array (an atomic add,
    ~20 cycles and a barrier to the memory operations around it) whenever it is bound
    to a new name, e.g. the argument of an inlined helper; for a view that owns nothing
    both are a test of a null pointer.  Only for arrays that something else keeps alive
    for as long as the view is used: a driver's loop function's arguments (the caller's
    arrays live through the call).  Slices of the view own nothing either.
    """
    if not isinstance(arr, types.Array):
        return None

    def codegen(context, builder, signature, args):
        src = context.make_array(signature.args[0])(context, builder, args[0])
        view = context.make_array(signature.return_type)(context, builder)
        for name in ("parent", "nitems", "itemsize", "data", "shape", "strides"):
            setattr(view, name, getattr(src, name))
        view.meminfo = cgutils.get_null_value(view.meminfo.type)
        return view._getvalue()

    return arr(arr), codegen


@njit(cache=True)
def event_value(ka, kind, idx, val, t, y, p, W, dydt):
    """Value of one event function g(t, y) (see the module docstring); ``W`` and ``dydt``
    (2n) are scratch for a multiplier, which the right-hand side leaves in W."""
    n = y.shape[0] // 2
    if kind == EV_COORDINATE:
        return y[idx] - val
    if kind == EV_VELOCITY:
        return y[n + idx] - val
    if kind == EV_MULTIPLIER:
        call_rhs(ka[RHS], t, y, p, dydt, W)
        return W[n + idx, W.shape[1] - 1] - val
    return call_energy(ka[ENERGY], y[:n], y[n:], t, p) - val


@njit(cache=True)
def project_constraints(ka, m, y, t, p, G, P, res):
    """Project y = [q, q̇] back onto Φ(q, t) = 0 and Φ̇ = 0 (no-op without constraints).

    Least-squares (Euclidean) projection with Φ_q (into ``G``, (m, n)):
    Δq = −Φ_qᵀ (Φ_q Φ_qᵀ)⁻¹ Φ, three Gauss–Newton iterations for q (quadratic
    convergence from a drift of the size of the tolerance), then one exact linear
    step Δq̇ = −Φ_qᵀ (Φ_q Φ_qᵀ)⁻¹ Φ̇ (Φ̇ is linear in q̇).  ``P`` is scratch (m, m + 1).
    Returns 0, or 1 if Φ_q Φ_qᵀ is singular (redundant constraints).
    """
    n = y.shape[0] // 2
    if m == 0:
        return 0
    for sweep in range(4):
        call_residual(ka[RESIDUAL], y[:n], y[n:], t, p, res)
        call_constraint_jacobian(ka[PHI_Q], y[:n], t, p, G)
        for a in range(m):
            for b in range(m):
                s = 0.0
                for j in range(n):
                    s += G[a, j] * G[b, j]
                P[a, b] = s
            P[a, m] = res[a] if sweep < 3 else res[m + a]
        if solve_augmented(P, m) != 0:
            return 1
        off = 0 if sweep < 3 else n
        for j in range(n):
            s = 0.0
            for a in range(m):
                s += G[a, j] * P[a, m]
            y[off + j] -= s
    return 0


@njit(cache=True)
def dop853_dense_eval(Fd, y0, x, out):
    """DOP853 dense output at fraction x of the step (7th-order polynomial, Hairer's form)."""
    n2 = y0.shape[0]
    for i in range(n2):
        acc = 0.0
        for r in range(6, -1, -1):
            acc += Fd[r, i]
            if (6 - r) % 2 == 0:
                acc *= x
            else:
                acc *= 1.0 - x
        out[i] = acc + y0[i]


@njit(cache=True)
def illinois_trial(a, b, fa, fb):
    """Next trial point of the Illinois (modified regula falsi) iteration on [a, b]."""
    x = (a * fb - b * fa) / (fb - fa)
    if not (a < x < b):
        x = 0.5 * (a + b)
    return x


@njit(cache=True)
def illinois_update(x, fx, a, b, fa, fb, side):
    """Shrink the bracket [a, b] with the value fx at x; halve the stale end's value
    when the same end is kept twice (what makes regula falsi converge superlinearly).
    Returns (a, b, fa, fb, side)."""
    if (fx > 0.0) == (fb > 0.0):
        if side == -1:
            fa *= 0.5
        return a, x, fa, fx, -1
    if side == 1:
        fb *= 0.5
    return x, b, fx, fb, 1


@njit(cache=True, inline=INLINE)
def chunk_status(step, max_steps, t, t_end, t_eval, stats, cap, n_ev, ev_cap):
    """Why a driver's chunk stops before its step number ``step`` (a ``STATUS_*`` code), or
    −1 to go on: t_end reached, step budget used, output buffer (capacity ``cap``) full
    without t_eval, event buffer (capacity ``ev_cap``) too full for ``n_ev`` more events.
    Inlined into every driver."""
    if t >= t_end:
        return STATUS_DONE
    if step == max_steps:
        return STATUS_CHUNK
    if t_eval.shape[0] == 0 and stats[ST_STORED] + 2 > cap:
        return STATUS_FULL
    if n_ev > 0 and stats[ST_EVENTS] + n_ev > ev_cap:
        return STATUS_EVFULL
    return -1


@njit(cache=True, inline=INLINE)
def next_stop(t_end, t_eval, stats):
    """The time the next step must not pass: t_end, or the next requested output time."""
    if t_eval.shape[0] > 0 and stats[ST_NEXT_EVAL] < t_eval.shape[0]:
        return min(t_end, t_eval[stats[ST_NEXT_EVAL]])
    return t_end


@njit(cache=True, inline=INLINE)
def store_output(t, y, n2, t_end, t_eval, tout, yout, stats, stride, force):
    """Record the state y (n2 entries) after an accepted step to time t: at the requested
    times t_eval (steps are clipped to land on them exactly, so none lies inside a step),
    or, without t_eval, every ``stride``-th step, at t_end, and whenever ``force``.
    Inlined into every driver."""
    if t_eval.shape[0] > 0:
        ie = stats[ST_NEXT_EVAL]
        while ie < t_eval.shape[0] and t_eval[ie] == t:
            tout[ie] = t
            for i in range(n2):
                yout[ie, i] = y[i]
            ie += 1
        stats[ST_NEXT_EVAL] = ie
        stats[ST_STORED] = ie
    else:
        stats[ST_STRIDE] += 1
        if stats[ST_STRIDE] >= stride or force or t >= t_end:
            stats[ST_STRIDE] = 0
            k = stats[ST_STORED]
            tout[k] = t
            for i in range(n2):
                yout[k, i] = y[i]
            stats[ST_STORED] += 1


@njit(cache=True)
def dop853_locate(ka, kind, idx, val, t0, h, y0, Fd, ga, gb, p, W, dydt, yt):
    """Root of one event function on the dense output of a DOP853 step.

    Illinois (modified regula falsi) on x ∈ [0, 1], bracket shrunk until it is a
    few ulps of t wide.  Returns the step fraction x of the crossing.
    """
    a = 0.0
    b = 1.0
    fa = ga
    fb = gb
    side = np.int64(0)      # (np.int64: a literal 0 would compile illinois_update twice)
    tol = 4.0 * 2.220446049250313e-16 * max(abs(t0), abs(t0 + h), 1e-300) / abs(h)
    for _it in range(200):
        if b - a <= tol:
            break
        x = illinois_trial(a, b, fa, fb)
        dop853_dense_eval(Fd, y0, x, yt)
        fx = event_value(ka, kind, idx, val, t0 + x * h, yt, p, W, dydt)
        if fx == 0.0:
            return x
        a, b, fa, fb, side = illinois_update(x, fx, a, b, fa, fb, side)
    return 0.5 * (a + b)


@njit(cache=True)
def starting_step(ka, t, y, f, p, rtol, atol, W, y1, f1, exponent):
    """Hairer's starting step size (as scipy's ``select_initial_step``); ``exponent`` is
    1/(q + 1) for an error estimate of order q (DOP853: 1/8, RKN 12(10): 1/11)."""
    n2 = y.shape[0]
    d0 = 0.0
    d1 = 0.0
    for i in range(n2):
        sc = atol + abs(y[i]) * rtol
        d0 += (y[i] / sc) ** 2
        d1 += (f[i] / sc) ** 2
    d0 = math.sqrt(d0 / n2)
    d1 = math.sqrt(d1 / n2)
    if d0 < 1e-5 or d1 < 1e-5:
        h0 = 1e-6
    else:
        h0 = 0.01 * d0 / d1
    if not h0 > 0.0:
        # the derivative's norm overflowed (a drive of 1e300 m): no representable step;
        # 0 makes the integrators report an underflow at once
        return 0.0
    for i in range(n2):
        y1[i] = y[i] + h0 * f[i]
    call_rhs(ka[RHS], t + h0, y1, p, f1, W)
    d2 = 0.0
    for i in range(n2):
        sc = atol + abs(y[i]) * rtol
        d2 += ((f1[i] - f[i]) / sc) ** 2
    d2 = math.sqrt(d2 / n2) / h0
    if d1 <= 1e-15 and d2 <= 1e-15:
        h1 = max(1e-6, h0 * 1e-3)
    else:
        h1 = (0.01 / max(d1, d2)) ** exponent
    return min(100.0 * h0, h1)


# -- DOP853 (adaptive, or fixed step) --------------------------------------------------

@njit(cache=True)
def dop853_chunk(ka, m, y, f, tv, stats, p, rtol, atol, A, B, C, E3, E5, D, adaptive, max_steps,
                 t_eval, stride, tout, yout, ev_int, ev_val, ev_g, ev_t, ev_k, ev_y):
    """Advance the DOP853 pair (Dormand & Prince 8(5,3)) by one chunk.

    Parameters (arrays are updated in place; see the module docstring)
    ----------
    y, f : (2n,) state [q, q̇] at tv[TV_T] and its derivative (FSAL).
    A, B, C, E3, E5, D : the coefficient table (scipy's ``dop853_coefficients``).
    adaptive : bool
        False: fixed steps of tv[TV_H] (the 8th-order solution, no rejection; the
        error estimate is still accumulated).
    max_steps : steps allowed in this chunk.
    t_eval : output times (empty: store every ``stride``-th accepted step).
    tout, yout : output buffers; stats[ST_STORED] rows used.
    ev_* : event specification, last values g, and the event buffers.

    Step-size control is Hairer's (scipy's): the error norm is the RMS of the
    combined 5th/3rd-order estimate scaled by atol + rtol·max(|y|, |y_new|),
    new h = h·min(10, max(0.2, 0.9·err^(−1/8))), no growth right after a rejection.
    """
    n = y.shape[0] // 2
    n2 = 2 * n
    W = np.zeros((n + m, n + m + 1))
    G = np.zeros((m, n))                  # Φ_q, for the projection
    P = np.zeros((max(m, 1), max(m, 1) + 1))
    res = np.zeros(max(2 * m, 1))
    K = np.empty((16, n2))
    ynew = np.empty(n2)
    ytmp = np.empty(n2)
    Fd = np.empty((7, n2))
    dydt = np.empty(n2)                   # event_value's scratch
    n_ev = ev_int.shape[0]
    g_new = np.empty(max(n_ev, 1))
    x_root = np.empty(max(n_ev, 1))
    use_teval = t_eval.shape[0] > 0
    cap = tout.shape[0]

    t = tv[TV_T]
    t_end = tv[TV_END]
    h = tv[TV_H]
    rejected = False
    for step in range(max_steps + 1):
        status = chunk_status(step, max_steps, t, t_end, t_eval, stats, cap, n_ev, ev_t.shape[0])
        if status >= 0:
            return status
        hmin = 16.0 * 2.220446049250313e-16 * max(abs(t), abs(t_end))
        if adaptive and not h >= hmin:
            # the step it needs is below the rounding of t (a starting step of 0 where the
            # derivative's norm overflows, say): accepted, it would never move t
            tv[TV_T] = t
            return STATUS_UNDERFLOW
        while True:
            last = False
            hs = h
            if t + hs >= t_end or (not adaptive and t + hs * (1.0 + 1e-10) >= t_end):
                hs = t_end - t
                last = True
            # stages
            for i in range(n2):
                K[0, i] = f[i]
            status = 0
            for s in range(1, 12):
                for i in range(n2):
                    acc = 0.0
                    for j in range(s):
                        acc += A[s, j] * K[j, i]
                    ytmp[i] = y[i] + hs * acc
                status = call_rhs(ka[RHS], t + C[s] * hs, ytmp, p, K[s], W)
                if status != 0:
                    break
            if status != 0:
                tv[TV_T] = t
                return STATUS_SINGULAR
            for i in range(n2):
                acc = 0.0
                for j in range(12):
                    acc += B[j] * K[j, i]
                ynew[i] = y[i] + hs * acc
            status = call_rhs(ka[RHS], t + hs, ynew, p, K[12], W)
            stats[ST_RHS] += 12
            if status != 0:
                tv[TV_T] = t
                return STATUS_SINGULAR
            # error estimate (Hairer's combination of the 5th- and 3rd-order estimates)
            e5n = 0.0
            e3n = 0.0
            est = 0.0
            for i in range(n2):
                a5 = 0.0
                a3 = 0.0
                for j in range(13):
                    a5 += E5[j] * K[j, i]
                    a3 += E3[j] * K[j, i]
                a5 *= hs
                a3 *= hs
                sc = atol + rtol * max(abs(y[i]), abs(ynew[i]))
                e5n += (a5 / sc) ** 2
                e3n += (a3 / sc) ** 2
                den = a5 * a5 + 0.01 * a3 * a3
                if den > 0.0:
                    ei = a5 * a5 / math.sqrt(den)
                    if ei > est:
                        est = ei
            if e5n == 0.0 and e3n == 0.0:
                err = 0.0
            else:
                err = e5n / math.sqrt((e5n + 0.01 * e3n) * n2)
            finite = math.isfinite(err)
            if (not adaptive) or (finite and err < 1.0):
                break
            stats[ST_REJECTED] += 1
            if finite:
                h = hs * max(0.2, 0.9 * err ** (-1.0 / 8.0))
            else:
                h = 0.2 * hs
            rejected = True
            if h < hmin:
                tv[TV_T] = t
                tv[TV_H] = h
                return STATUS_UNDERFLOW
        if not math.isfinite(err):
            tv[TV_T] = t
            return STATUS_UNDERFLOW
        # accepted: FSAL derivative is K[12]
        stats[ST_STEPS] += 1
        tv[TV_ERROR] += est
        have_dense = False
        # events
        t_stop = t + hs
        x_stop = 1.0
        fired = False
        for e in range(n_ev):
            g_new[e] = event_value(ka, ev_int[e, 0], ev_int[e, 1], ev_val[e], t + hs, ynew, p, W,
                                   dydt)
            x_root[e] = -1.0
            go = ev_g[e]
            gn = g_new[e]
            cross = (go < 0.0 and gn >= 0.0) or (go > 0.0 and gn <= 0.0)
            if cross and gn != go:
                d = ev_int[e, 2]
                up = gn > go
                if d == 0 or (d > 0 and up) or (d < 0 and not up):
                    if not have_dense:
                        dop853_dense(ka, t, hs, y, ynew, K, A, C, D, p, W, ytmp, Fd)
                        stats[ST_RHS] += 3
                        have_dense = True
                    x_root[e] = dop853_locate(ka, ev_int[e, 0], ev_int[e, 1], ev_val[e], t, hs, y,
                                              Fd, go, gn, p, W, dydt, ytmp)
                    if ev_int[e, 3] != 0 and x_root[e] <= x_stop:
                        x_stop = x_root[e]
                        fired = True
        for e in range(n_ev):
            if x_root[e] >= 0.0 and x_root[e] <= x_stop:
                k = stats[ST_EVENTS]
                ev_t[k] = t + x_root[e] * hs
                ev_k[k] = e
                dop853_dense_eval(Fd, y, x_root[e], ytmp)
                if m > 0:
                    project_constraints(ka, m, ytmp, ev_t[k], p, G, P, res)
                for i in range(n2):
                    ev_y[k, i] = ytmp[i]
                stats[ST_EVENTS] += 1
            ev_g[e] = g_new[e]
        if fired:
            t_stop = t + x_stop * hs
        # dense output at the requested times
        if use_teval:
            ie = stats[ST_NEXT_EVAL]
            while ie < t_eval.shape[0] and t_eval[ie] <= t_stop:
                if not have_dense:
                    dop853_dense(ka, t, hs, y, ynew, K, A, C, D, p, W, ytmp, Fd)
                    stats[ST_RHS] += 3
                    have_dense = True
                if t_eval[ie] == t + hs and not fired:
                    for i in range(n2):
                        ytmp[i] = ynew[i]
                else:
                    dop853_dense_eval(Fd, y, (t_eval[ie] - t) / hs, ytmp)
                if m > 0:   # the step and its interpolant drift off Φ = 0 by ~ the tolerance
                    project_constraints(ka, m, ytmp, t_eval[ie], p, G, P, res)
                for i in range(n2):
                    yout[ie, i] = ytmp[i]
                tout[ie] = t_eval[ie]
                ie += 1
            stats[ST_NEXT_EVAL] = ie
            stats[ST_STORED] = ie
        if fired:
            dop853_dense_eval(Fd, y, x_stop, ynew)
            t_new = t_stop
            tv[TV_T_CARRY] = 0.0
        else:
            # compensated (Kahan) sum of the steps: over 10⁵–10⁶ steps plain t += h loses
            # ~1e-12 s, a drive-phase error ω δt that shows at the 1e-10 level
            yk = hs - tv[TV_T_CARRY]
            t_new = t + yk
            tv[TV_T_CARRY] = (t_new - t) - yk
        if m > 0:
            if project_constraints(ka, m, ynew, t_new, p, G, P, res) != 0:
                tv[TV_T] = t
                return STATUS_SINGULAR
        if fired or m > 0:
            status = call_rhs(ka[RHS], t_new, ynew, p, K[12], W)
            stats[ST_RHS] += 1
            # a terminal event may sit exactly on a singular state (the swinging Atwood
            # machine stopped at r = 0): the run ends there, so that is not an error
            if status != 0 and not fired:
                tv[TV_T] = t
                return STATUS_SINGULAR
        for i in range(n2):
            y[i] = ynew[i]
            f[i] = K[12, i]
        t = t_new if not last or fired else t_end
        tv[TV_T] = t
        if not use_teval:      # (requested times were interpolated on the dense output)
            store_output(t, y, n2, t_end, t_eval, tout, yout, stats, stride, fired)
        if fired:
            return STATUS_EVENT
        # next step size
        if adaptive:
            if err == 0.0:
                factor = 10.0
            else:
                factor = min(10.0, 0.9 * err ** (-1.0 / 8.0))
            if rejected:
                factor = min(1.0, factor)
            h = hs * factor if not last else max(h, hs)
            rejected = False
        tv[TV_H] = h
    return STATUS_CHUNK


@njit(cache=True)
def dop853_dense(ka, t, h, y, ynew, K, A, C, D, p, W, ytmp, Fd):
    """The three extra stages and the coefficients Fd of DOP853's dense output."""
    n2 = y.shape[0]
    for s in range(13, 16):
        for i in range(n2):
            acc = 0.0
            for j in range(s):
                acc += A[s, j] * K[j, i]
            ytmp[i] = y[i] + h * acc
        call_rhs(ka[RHS], t + C[s] * h, ytmp, p, K[s], W)
    for i in range(n2):
        dy = ynew[i] - y[i]
        Fd[0, i] = dy
        Fd[1, i] = h * K[0, i] - dy
        Fd[2, i] = 2.0 * dy - h * (K[12, i] + K[0, i])
        for r in range(4):
            acc = 0.0
            for j in range(16):
                acc += D[r, j] * K[j, i]
            Fd[3 + r, i] = h * acc


@njit(cache=True)
def derivative_start(ka, m, t, y, p, f):
    """f = dy/dt at (t, y); returns the kernel status."""
    n = y.shape[0] // 2
    W = np.zeros((n + m, n + m + 1))
    return call_rhs(ka[RHS], t, y, p, f, W)


@njit(cache=True)
def project_start(ka, m, t, y, p):
    """Project an initial state onto the constraints (returns the status)."""
    n = y.shape[0] // 2
    P = np.zeros((max(m, 1), max(m, 1) + 1))
    res = np.zeros(max(2 * m, 1))
    return project_constraints(ka, m, y, t, p, np.zeros((m, n)), P, res)


@njit(cache=True)
def initial_step(ka, m, t, y, f, p, rtol, atol, exponent):
    """:func:`starting_step` with its own scratch (DOP853: exponent 1/8; RKN 12(10): 1/11)."""
    n = y.shape[0] // 2
    W = np.zeros((n + m, n + m + 1))
    return starting_step(ka, t, y, f, p, rtol, atol, W, np.empty_like(y), np.empty_like(y),
                         exponent)


@njit(cache=True)
def along(ka, m, T, Y, p, E, LAM, RES):
    """Energy, multipliers and constraint residual max(|Φ|, |Φ̇|) along a trajectory."""
    n = Y.shape[1] // 2
    W = np.zeros((n + m, n + m + 1))
    dydt = np.empty(2 * n)
    res = np.empty(max(2 * m, 1))
    for k in range(T.shape[0]):
        q = Y[k, :n]
        qd = Y[k, n:]
        E[k] = call_energy(ka[ENERGY], q, qd, T[k], p)
        if m > 0:
            # the right-hand side of a constrained system leaves [q̈, λ] in W[:, n + m]
            call_rhs(ka[RHS], T[k], Y[k], p, dydt, W)
            call_residual(ka[RESIDUAL], q, qd, T[k], p, res)
            r = 0.0
            for a in range(m):
                LAM[k, a] = W[n + a, n + m]
                r = max(r, abs(res[a]), abs(res[m + a]))
            RES[k] = r



# -- q̈ = f(q, t): one step of RKN 12(10) or the symplectic composition, and events -----

@njit(cache=True)
def accel_only(ka, q, t, p, out, rates, cs, Wn):
    """q̈ = f(q, t) into ``out`` from the drive kernel (:mod:`lagrange_core.drive_kernel`):
    the drive's cos/sin (``rates`` from ``drive_rates``) are evaluated at t here."""
    for d in range(rates.shape[0]):
        cs[2 * d] = math.cos(rates[d] * t)
        cs[2 * d + 1] = math.sin(rates[d] * t)
    return call_fast_accel(ka[FAST_ACCEL], q, t, cs, p, out, Wn)


@njit(cache=True, inline=INLINE)
def rkn_stage_position(q, v, K, A, s, ch, h, qs):
    """The position of RKN stage s into ``qs``: q + c_s h v + h² Σ_{j<s} A_sj K_j
    (``ch`` = c_s h)."""
    for i in range(q.shape[0]):
        acc = 0.0
        for j in range(s):
            acc += A[s, j] * K[j, i]
        qs[i] = q[i] + ch * v[i] + h * h * acc


@njit(cache=True, inline=INLINE)
def rotate_drive(cs0, rot, s, css):
    """The drive's cos/sin pairs ``cs0`` at t rotated by ``rot[s]`` (the cos/sin of
    α_k x_s h) into ``css``: the drive at t + x_s h without calling cos or sin."""
    for k in range(cs0.shape[0] // 2):
        cr = rot[s, k, 0]
        sr = rot[s, k, 1]
        css[2 * k] = cs0[2 * k] * cr - cs0[2 * k + 1] * sr
        css[2 * k + 1] = cs0[2 * k + 1] * cr + cs0[2 * k] * sr


@njit(cache=True)
def second_order_step(ka, family, t, q, v, a0, h, p, c, A, b, bp, w, K, qn, vn, qs, rates, cs,
                      Wn):
    """One step of a method for q̈ = f(q, t) from (t, q, v) with q̈(t) = a0.

    family 0: RKN (c, A, b, bp; stages K[s]); family 1: the symmetric composition
    of velocity Verlet with substep weights w (time advances with the drifts,
    which keeps the composition symmetric for a time-dependent f).
    On return qn, vn hold the new state and K[0] holds f at (t + h, qn) for
    family 1.  Returns the kernel status.
    """
    n = q.shape[0]
    status = 0
    if family == 0:
        for i in range(n):
            K[0, i] = a0[i]
        ns = c.shape[0]
        for s in range(1, ns):
            ch = c[s] * h
            rkn_stage_position(q, v, K, A, s, ch, h, qs)
            status = accel_only(ka, qs, t + ch, p, K[s], rates, cs, Wn)
            if status != 0:
                return status
        for i in range(n):
            accq = 0.0
            accv = 0.0
            for j in range(ns):
                accq += b[j] * K[j, i]
                accv += bp[j] * K[j, i]
            qn[i] = q[i] + h * v[i] + h * h * accq
            vn[i] = v[i] + h * accv
        return 0
    for i in range(n):
        qn[i] = q[i]
        vn[i] = v[i]
        K[0, i] = a0[i]
    tt = t
    for k in range(w.shape[0]):
        hk = w[k] * h
        for i in range(n):
            vn[i] += 0.5 * hk * K[0, i]
            qn[i] += hk * vn[i]
        tt = t + h * _partial_sum(w, k)
        status = accel_only(ka, qn, tt, p, K[0], rates, cs, Wn)
        if status != 0:
            return status
        for i in range(n):
            vn[i] += 0.5 * hk * K[0, i]
    return 0


@njit(cache=True)
def _partial_sum(w, k):
    s = 0.0
    for j in range(k + 1):
        s += w[j]
    return s


@njit(cache=True)
def second_order_locate(ka, family, e, ev_int, ev_val, t, q, v, a0, h, ga, gb, p, c, A, b, bp, w,
                        K, ytmp, qs, rates, cs, Wn, W, dydt, stats, evals):
    """Step fraction x of an event crossing: Illinois iteration, each trial a step of x·h."""
    n = q.shape[0]
    a = 0.0
    bb = 1.0
    fa = ga
    fb = gb
    side = np.int64(0)      # (np.int64: a literal 0 would compile illinois_update twice)
    tol = 4.0 * 2.220446049250313e-16 * max(abs(t), abs(t + h), 1e-300) / abs(h)
    for _it in range(100):
        if bb - a <= tol:
            break
        x = illinois_trial(a, bb, fa, fb)
        second_order_step(ka, family, t, q, v, a0, x * h, p, c, A, b, bp, w, K, ytmp[:n], ytmp[n:],
                          qs, rates, cs, Wn)
        stats[ST_RHS] += evals
        fx = event_value(ka, ev_int[e, 0], ev_int[e, 1], ev_val[e], t + x * h, ytmp, p, W,
                         dydt)
        if fx == 0.0:
            return x
        a, bb, fa, fb, side = illinois_update(x, fx, a, bb, fa, fb, side)
    return 0.5 * (a + bb)


@njit(cache=True)
def second_order_events(ka, family, t, hs, q, v, a0, qn, vn, p, c, A, b, bp, w, K, qs, rates,
                        cs, Wn, W, dydt, ytmp, ev_int, ev_val, ev_g, g_new, x_root, ev_t, ev_k,
                        ev_y, stats):
    """Events of an accepted step of a q̈ = f(q, t) driver from (t, q, v) to (t + hs, qn, vn).

    Every event function is evaluated at the step's end; each crossing in the asked
    direction is located by :func:`second_order_locate` (Illinois iteration, each trial
    a fresh step of x·hs from the step start, the method's own accuracy) and recorded
    with its state.  Returns the step fraction at which a terminal event stops the run,
    or 2.0 when none does.
    """
    n = q.shape[0]
    n_ev = ev_int.shape[0]
    evals = (c.shape[0] - 1) if family == 0 else w.shape[0]
    for i in range(n):
        ytmp[i] = qn[i]
        ytmp[n + i] = vn[i]
    for e in range(n_ev):
        g_new[e] = event_value(ka, ev_int[e, 0], ev_int[e, 1], ev_val[e], t + hs, ytmp, p, W,
                               dydt)
    x_stop = 2.0
    for e in range(n_ev):
        x_root[e] = -1.0
        go = ev_g[e]
        gn = g_new[e]
        cross = (go < 0.0 and gn >= 0.0) or (go > 0.0 and gn <= 0.0)
        if cross and gn != go:
            d = ev_int[e, 2]
            up = gn > go
            if d == 0 or (d > 0 and up) or (d < 0 and not up):
                x_root[e] = second_order_locate(ka, family, e, ev_int, ev_val, t, q, v, a0, hs,
                                                go, gn, p, c, A, b, bp, w, K, ytmp, qs, rates,
                                                cs, Wn, W, dydt, stats, evals)
                if ev_int[e, 3] != 0 and x_root[e] < x_stop:
                    x_stop = x_root[e]
    for e in range(n_ev):
        if x_root[e] >= 0.0 and x_root[e] <= x_stop:
            k = stats[ST_EVENTS]
            ev_t[k] = t + x_root[e] * hs
            ev_k[k] = e
            second_order_step(ka, family, t, q, v, a0, x_root[e] * hs, p, c, A, b, bp, w, K,
                              ytmp[:n], ytmp[n:], qs, rates, cs, Wn)
            stats[ST_RHS] += evals
            for i in range(2 * n):
                ev_y[k, i] = ytmp[i]
            stats[ST_EVENTS] += 1
        ev_g[e] = g_new[e]
    return x_stop


@njit(cache=True)
def second_order_stop(ka, family, t, x, hs, q, v, a0, qn, vn, anew, p, c, A, b, bp, w, K, qs,
                      rates, cs, Wn, stats):
    """The state at a terminal event: a fresh step of x·hs from the step start into
    (qn, vn), its acceleration into ``anew``; returns the kernel status."""
    second_order_step(ka, family, t, q, v, a0, x * hs, p, c, A, b, bp, w, K, qn, vn, qs, rates,
                      cs, Wn)
    stats[ST_RHS] += ((c.shape[0] - 1) if family == 0 else w.shape[0]) + 1
    return accel_only(ka, qn, t + x * hs, p, anew, rates, cs, Wn)


# -- the drivers for q̈ = f(q, t): rotations for the drive ------------------------------

@njit(cache=True, inline=INLINE)
def held_step_record(tv, stats, block, err, hs, h_max):
    """Record one evaluated step (size hs, scaled error err of the 10th-order estimate,
    so err ∝ hs¹¹) in the block of the held step; at the block's end set the new held step.

    The block stores r = err·(h_ref/hs)¹¹ with h_ref = ``tv[TV_HREF]``: the error the
    step would have had at h_ref, so the ideal step of a step is 0.9·h_ref·r^(−1/11)
    (what the classic controller would propose) whatever size it was taken at.  When
    the block is full (``len(block)`` steps; the first block, before any held step,
    ``HOLD_FIRST``) the new held step is the ``HOLD_QUANTILE`` quantile of those ideal
    steps (one power per block: the (1 − q) quantile of r), at most ``HOLD_GROWTH``
    times the last one and at most ``h_max``; it replaces the last one only if they
    differ by more than ``HOLD_CHANGE``.  Returns the new held step, or 0.0 when it is
    unchanged (or the block not yet full).
    """
    nb = block.shape[0]
    if nb == 0 or not math.isfinite(err):
        return 0.0
    if tv[TV_HOLD] == 0.0:
        nb = min(nb, HOLD_FIRST)
    href = tv[TV_HREF]
    if href == 0.0:
        href = hs
        tv[TV_HREF] = hs
    x = href / hs
    x2 = x * x
    x4 = x2 * x2
    block[stats[ST_BLOCK]] = err * (x4 * x4 * x2 * x)
    stats[ST_BLOCK] += 1
    if stats[ST_BLOCK] < nb:
        return 0.0
    k = int((1.0 - HOLD_QUANTILE) * (nb - 1) + 0.5)
    r = kth_smallest_in_place(block[:nb], k)        # (the block is refilled from 0)
    hold = HOLD_GROWTH * href if r == 0.0 else 0.9 * href * r ** (-1.0 / 11.0)
    stats[ST_BLOCK] = 0
    if not hold > 0.0:          # r overflowed: steps far below h_ref; start the block anew
        tv[TV_HREF] = hs
        return 0.0
    old = tv[TV_HOLD]
    if old > 0.0:
        if old / HOLD_CHANGE <= hold <= old * HOLD_CHANGE:
            return 0.0          # the same within HOLD_CHANGE: keep it (and its rotations)
        hold = min(hold, HOLD_GROWTH * old)
    hold = min(hold, h_max)
    if hold == old:
        return 0.0
    tv[TV_HOLD] = hold
    tv[TV_HREF] = hold
    return hold


@njit(cache=True, inline=INLINE)
def _event_scratch(n, n_ev):
    """Scratch of the events of a q̈ = f(q, t) driver: W, dydt, a state, g values, roots,
    and an unused weight array (the RKN's stand-in for the symplectic weights)."""
    return (np.zeros((n, n + 1)), np.empty(2 * n), np.empty(2 * n), np.empty(max(n_ev, 1)),
            np.empty(max(n_ev, 1)), np.zeros(1))


@njit(cache=True)
def drive_rates(ka, p):
    """The rates α_k of the drive harmonics cos(α_k t + β) of the drive kernel."""
    rates = np.empty(MAX_DRIVE_RATES)
    nd = call_drive_rates(ka[DRIVE_RATES], p, rates)
    return rates[:nd]


@njit(cache=True, inline=INLINE)
def rkn_stages(ka, t, hs, q, v, a0, c, A, rot, cs0, css, K, qs, p, Wn):
    """The stages of one RKN step of size hs from (t, q, v) with q̈(t) = a0: K[s] for
    s = 1 … ns − 1 at q + c_s hs v + hs² Σ_j A_sj K_j, the drive at t + c_s hs rotated from
    its value ``cs0`` at t by ``rot[s]`` (the cos/sin of α_k c_s hs).  Returns the drive
    kernel's status (0, or the first nonzero one: a singular mass matrix)."""
    for i in range(q.shape[0]):
        K[0, i] = a0[i]
    for s in range(1, c.shape[0]):
        ch = c[s] * hs
        rkn_stage_position(q, v, K, A, s, ch, hs, qs)
        rotate_drive(cs0, rot, s, css)
        status = call_fast_accel(ka[FAST_ACCEL], qs, t + ch, css, p, K[s], Wn)
        if status != 0:
            return status
    return 0


@njit(cache=True, inline=INLINE)
def rkn_combine(hs, q, v, K, b, bp, db, dbp, cq, cv, qn, vn, cqn, cvn, adaptive, rtol, atol):
    """The new state (qn, vn) of an RKN step from its stages K, with compensated (Kahan)
    updates (carries cq, cv in; cqn, cvn out): over 10⁵ fixed steps plain q += Δq loses
    ~1e-11 to rounding, more than the method's error at tight tolerances.  The embedded
    difference (db = b − b̂, dbp = b′ − b̂′) gives the error.  Returns (err, est, finite):
    err the RMS of the difference scaled by atol + rtol·max(|y|, |y_new|) (0 unless
    ``adaptive``), est its largest unscaled component, finite whether qn, vn are."""
    n = q.shape[0]
    ns = K.shape[0]
    e2 = 0.0
    est = 0.0
    finite = True
    for i in range(n):
        accq = 0.0
        accv = 0.0
        dq = 0.0
        dv = 0.0
        for j in range(ns):
            kj = K[j, i]
            accq += b[j] * kj
            accv += bp[j] * kj
            dq += db[j] * kj
            dv += dbp[j] * kj
        yq = hs * v[i] + hs * hs * accq - cq[i]
        qn[i] = q[i] + yq
        cqn[i] = (qn[i] - q[i]) - yq
        yv = hs * accv - cv[i]
        vn[i] = v[i] + yv
        cvn[i] = (vn[i] - v[i]) - yv
        dq *= hs * hs
        dv *= hs
        if not (np.isfinite(qn[i]) and np.isfinite(vn[i])):
            finite = False
        if adaptive:
            sq = atol + rtol * max(abs(q[i]), abs(qn[i]))
            sv = atol + rtol * max(abs(v[i]), abs(vn[i]))
            e2 += (dq / sq) ** 2 + (dv / sv) ** 2
        est = max(est, abs(dq), abs(dv))
    return np.sqrt(e2 / (2 * n)), est, finite


@njit(cache=True, inline=INLINE)
def rkn_next_step(tv, stats, block, h, hs, err, clipped, rejected, h_max):
    """The step after an accepted RKN 12(10) step of size hs with error ratio err: the
    classic controller h·min(5, 0.9·err^(−1/11)) (no growth right after a rejection)
    until the held step exists; then the held step tv[TV_HOLD] while steps pass, grown
    back to (by the classic factor, at least 1) after a rejection, never further down;
    set anew every ``len(block)`` steps by :func:`held_step_record`.  A step clipped to
    land on an output time keeps the step before it."""
    hold = tv[TV_HOLD]
    if hold == 0.0 or hs < hold:
        factor = 5.0 if err == 0.0 else min(5.0, 0.9 * err ** (-1.0 / 11.0))
        if rejected:
            factor = min(1.0, factor)
        if hold == 0.0:        # the first block: the classic controller
            h = min(h_max, max(h, hs * factor) if clipped else hs * factor)
        elif not clipped:      # below the held step: back to it, never further down
            h = min(hold, hs * max(1.0, factor)) if not rejected else hs
    elif not clipped:
        h = hold
    new_hold = held_step_record(tv, stats, block, err, hs, h_max)
    if new_hold > 0.0 and (h >= hold or h > new_hold):
        h = new_hold
    return h


@njit(cache=True, error_model="numpy", fastmath=FAST_MATH)
def fast_rkn_chunk(ka, y, f, tv, stats, p, c, A, b, bp, bh, bph, adaptive, rtol, atol, max_steps,
                   t_eval, stride, tout, yout, ev_int, ev_val, ev_g, ev_t, ev_k, ev_y, block):
    """RKN 12(10) on the drive kernel; fixed step tv[TV_H] or adaptive.

    Same state layout, statuses and outputs as :func:`dop853_chunk`.  Output at
    ``t_eval`` is exact: steps are shortened to land on each requested time (so many
    closely spaced outputs cost extra steps).  Events: :func:`second_order_events`.

    Step-size control (adaptive): err = RMS of the difference of the 12th- and
    10th-order solutions [Δq, Δv] scaled by atol + rtol·max(|y|, |y_new|); a step
    with err ≥ 1 is rejected and retaken at h·max(0.2, 0.9·err^(−1/11)).
    After an accepted step, for the first ``HOLD_FIRST`` evaluated steps (all of
    them if ``block`` is empty) the classic controller: new h = h·min(5,
    0.9·err^(−1/11)), no growth right after a rejection.  From then on the step is
    *held*: it stays at the held step tv[TV_HOLD] while the steps pass, and after a
    rejection grows back to it (by the classic factor, at least 1); every
    ``len(block)`` evaluated steps the held step is set anew from their errors
    (:func:`held_step_record`).  So the step does not chase the drive's phase, the
    drive's rotations are computed once per step size, and rejections are rare.
    No adaptive step spans more than ``DRIVE_STEP`` periods of the fastest drive
    harmonic.

    This function allocates the scratch; the steps are :func:`_rkn_chunk_loop`'s, on
    views that own nothing (the module docstring: reference counts).
    """
    n = y.shape[0] // 2
    rates = drive_rates(ka, p)
    nd = rates.shape[0]
    ns = c.shape[0]
    K = np.empty((ns, n))
    qs = np.empty(n)
    qn = np.empty(n)
    vn = np.empty(n)
    Wn = np.zeros((n, n + 1))
    cq = np.zeros(n)
    cv = np.zeros(n)
    cqn = np.zeros(n)
    cvn = np.zeros(n)
    rot = np.empty((ns, max(nd, 1), 2))
    cs0 = np.empty(max(2 * nd, 1))
    css = np.empty(max(2 * nd, 1))
    db = np.empty(ns)
    dbp = np.empty(ns)
    for j in range(ns):
        db[j] = b[j] - bh[j]
        dbp[j] = bp[j] - bph[j]
    n_ev = ev_int.shape[0]
    W, dydt, ytmp, g_new, x_root, w0 = _event_scratch(n, n_ev)
    return _rkn_chunk_loop(ka, y, f, tv, stats, p, c, A, b, bp, adaptive, rtol, atol,
                           max_steps, t_eval, stride, tout, yout, ev_int, ev_val, ev_g, ev_t,
                           ev_k, ev_y, block, rates, K, qs, qn, vn, Wn, cq, cv, cqn, cvn, rot,
                           cs0, css, db, dbp, W, dydt, ytmp, g_new, x_root, w0)


@njit(cache=True, error_model="numpy", fastmath=FAST_MATH)
def _rkn_chunk_loop(ka, y, f, tv, stats, p, c, A, b, bp, adaptive, rtol, atol, max_steps,
                    t_eval, stride, tout, yout, ev_int, ev_val, ev_g, ev_t, ev_k, ev_y, block,
                    rates, K, qs, qn, vn, Wn, cq, cv, cqn, cvn, rot, cs0, css, db, dbp, W, dydt,
                    ytmp, g_new, x_root, w0):
    """The steps of :func:`fast_rkn_chunk` (its arguments, then its scratch)."""
    ka, y, f, tv, stats, p = unowned(ka), unowned(y), unowned(f), unowned(tv), \
        unowned(stats), unowned(p)
    c, A, b, bp, t_eval, tout = unowned(c), unowned(A), unowned(b), unowned(bp), \
        unowned(t_eval), unowned(tout)
    yout, ev_int, ev_val, ev_g, ev_t, ev_k = unowned(yout), unowned(ev_int), \
        unowned(ev_val), unowned(ev_g), unowned(ev_t), unowned(ev_k)
    ev_y, block, rates, K, qs, qn, vn = unowned(ev_y), unowned(block), unowned(rates), \
        unowned(K), unowned(qs), unowned(qn), unowned(vn)
    Wn, cq, cv, cqn, cvn, rot, cs0 = unowned(Wn), unowned(cq), unowned(cv), unowned(cqn), \
        unowned(cvn), unowned(rot), unowned(cs0)
    css, db, dbp, W, dydt, ytmp = unowned(css), unowned(db), unowned(dbp), unowned(W), \
        unowned(dydt), unowned(ytmp)
    g_new, x_root, w0 = unowned(g_new), unowned(x_root), unowned(w0)
    n = y.shape[0] // 2
    nd = rates.shape[0]
    n2 = 2 * n
    ns = c.shape[0]
    n_ev = ev_int.shape[0]
    cap = tout.shape[0]
    q = y[:n]
    v = y[n:]
    a0 = f[n:]
    t = tv[TV_T]
    t_end = tv[TV_END]
    h = tv[TV_H]
    # adaptive: no step longer than DRIVE_STEP periods of the fastest drive harmonic
    h_max = np.inf
    for k in range(nd):
        if rates[k] != 0.0:
            h_max = min(h_max, DRIVE_STEP * 2.0 * np.pi / abs(rates[k]))
    if adaptive:
        h = min(h, h_max)
    h_rot = -1.0
    rejected = False
    expo = -1.0 / 11.0
    exact_drive = True
    for step in range(max_steps + 1):
        status = chunk_status(step, max_steps, t, t_end, t_eval, stats, cap, n_ev,
                              ev_t.shape[0])
        if status >= 0:
            return status
        hmin = 16.0 * 2.220446049250313e-16 * max(abs(t), abs(t_end))
        if adaptive and not h >= hmin:      # as dop853_chunk
            tv[TV_T] = t
            return STATUS_UNDERFLOW
        t_target = next_stop(t_end, t_eval, stats)
        # the drive at t: from the cos/sin (every DRIVE_RESYNC steps, after a shortened
        # step or an event), else the rotation by the last step computed for its FSAL stage
        if exact_drive or stats[ST_STEPS] % DRIVE_RESYNC == 0:
            for k in range(nd):
                cs0[2 * k] = np.cos(rates[k] * t)
                cs0[2 * k + 1] = np.sin(rates[k] * t)
        else:
            for k in range(2 * nd):
                cs0[k] = css[k]
        exact_drive = False
        while True:
            clipped = False
            hs = h
            if t + hs >= t_target or (not adaptive and t + hs * (1.0 + 1e-10) >= t_target):
                hs = t_target - t
                clipped = True
            if hs != h_rot:
                for s in range(ns):
                    for k in range(nd):
                        rot[s, k, 0] = np.cos(rates[k] * c[s] * hs)
                        rot[s, k, 1] = np.sin(rates[k] * c[s] * hs)
                h_rot = hs
            status = rkn_stages(ka, t, hs, q, v, a0, c, A, rot, cs0, css, K, qs, p, Wn)
            stats[ST_RHS] += ns - 1
            if status != 0:
                tv[TV_T] = t
                return STATUS_SINGULAR
            err, est, finite = rkn_combine(hs, q, v, K, b, bp, db, dbp, cq, cv, qn, vn,
                                           cqn, cvn, adaptive, rtol, atol)
            if (not adaptive) or (finite and err < 1.0):
                if not finite:
                    tv[TV_T] = t
                    return STATUS_UNDERFLOW
                break
            stats[ST_REJECTED] += 1
            held_step_record(tv, stats, block, err, hs, h_max)
            h = hs * max(0.2, 0.9 * err ** expo) if finite else 0.2 * hs
            rejected = True
            if h < hmin:
                tv[TV_T] = t
                tv[TV_H] = h
                return STATUS_UNDERFLOW
        stats[ST_STEPS] += 1
        tv[TV_ERROR] += est
        if clipped:
            t_new = t_target
            tv[TV_T_CARRY] = 0.0
        else:       # compensated (Kahan) sum of the steps, see dop853_chunk
            yk = hs - tv[TV_T_CARRY]
            t_new = t + yk
            tv[TV_T_CARRY] = (t_new - t) - yk
        fired = False
        if n_ev > 0:
            # (the family as np.int64: a bare 0 or 1 is typed Literal[int], and the event
            # functions compiled once for RKN 12 and again for the symplectic driver, 4 s)
            x_stop = second_order_events(ka, np.int64(0), t, hs, q, v, a0, qn, vn, p, c, A, b,
                                         bp, w0, K, qs, rates, css, Wn, W, dydt, ytmp, ev_int,
                                         ev_val, ev_g, g_new, x_root, ev_t, ev_k, ev_y, stats)
            fired = x_stop <= 1.0
        if fired:   # stop at the event: a fresh step there (its accelerations into a0)
            status = second_order_stop(ka, np.int64(0), t, x_stop, hs, q, v, a0, qn, vn, a0, p,
                                       c, A, b, bp, w0, K, qs, rates, css, Wn, stats)
            t_new = t + x_stop * hs
            tv[TV_T_CARRY] = 0.0
            exact_drive = True
            for i in range(n):
                cqn[i] = 0.0
                cvn[i] = 0.0
        else:
            exact_drive = clipped
            # FSAL: f at the new state; the drive at t + hs is the rotation of stage c = 1
            rotate_drive(cs0, rot, ns - 1, css)
            status = call_fast_accel(ka[FAST_ACCEL], qn, t_new, css, p, a0, Wn)
            stats[ST_RHS] += 1
        # a terminal event may sit exactly on a singular state: the run ends there
        if status != 0 and not fired:
            tv[TV_T] = t
            return STATUS_SINGULAR
        for i in range(n):
            q[i] = qn[i]
            v[i] = vn[i]
            f[i] = vn[i]
            cq[i] = cqn[i]
            cv[i] = cvn[i]
        t = t_new
        tv[TV_T] = t
        store_output(t, y, n2, t_end, t_eval, tout, yout, stats, stride, fired)
        if fired:
            return STATUS_EVENT
        if adaptive:
            h = rkn_next_step(tv, stats, block, h, hs, err, clipped, rejected, h_max)
            rejected = False
        tv[TV_H] = h
    return STATUS_CHUNK


@njit(cache=True, error_model="numpy", fastmath=FAST_MATH)
def fast_symplectic_chunk(ka, y, f, tv, stats, p, w, max_steps, t_eval, stride, tout, yout,
                          ev_int, ev_val, ev_g, ev_t, ev_k, ev_y):
    """Symmetric composition of velocity Verlet (weights w) at a fixed step, on the
    drive kernel.  Time advances with the drifts (kick at the current time,
    drift q and t together), which keeps every substep symmetric for a
    time-dependent f; the drive at each drift end is a fixed rotation of its value
    at the step start.  Same state layout, outputs and events as :func:`fast_rkn_chunk`;
    the steps are :func:`_symplectic_chunk_loop`'s, on views that own nothing.
    """
    n = y.shape[0] // 2
    rates = drive_rates(ka, p)
    nd = rates.shape[0]
    nw = w.shape[0]
    Wn = np.zeros((n, n + 1))
    qn = np.empty(n)
    vn = np.empty(n)
    a = np.empty(n)
    S = np.empty(nw)
    acc = 0.0
    for k in range(nw):
        acc += w[k]
        S[k] = acc
    rot = np.empty((nw, max(nd, 1), 2))
    cs0 = np.empty(max(2 * nd, 1))
    css = np.empty(max(2 * nd, 1))
    n_ev = ev_int.shape[0]
    W, dydt, ytmp, g_new, x_root, z = _event_scratch(n, n_ev)
    K = np.empty((1, n))             # the trial steps' scratch (family 1 uses row 0)
    qs = np.empty(n)
    z2 = np.zeros((1, 1))
    return _symplectic_chunk_loop(ka, y, f, tv, stats, p, w, max_steps, t_eval, stride, tout,
                                  yout, ev_int, ev_val, ev_g, ev_t, ev_k, ev_y, rates, Wn, qn,
                                  vn, a, S, rot, cs0, css, W, dydt, ytmp, g_new, x_root, z, K,
                                  qs, z2)


@njit(cache=True, error_model="numpy", fastmath=FAST_MATH)
def _symplectic_chunk_loop(ka, y, f, tv, stats, p, w, max_steps, t_eval, stride, tout, yout,
                           ev_int, ev_val, ev_g, ev_t, ev_k, ev_y, rates, Wn, qn, vn, a, S,
                           rot, cs0, css, W, dydt, ytmp, g_new, x_root, z, K, qs, z2):
    """The steps of :func:`fast_symplectic_chunk` (its arguments, then its scratch)."""
    ka, y, f, tv, stats, p, w = unowned(ka), unowned(y), unowned(f), unowned(tv), \
        unowned(stats), unowned(p), unowned(w)
    t_eval, tout, yout, ev_int, ev_val, ev_g = unowned(t_eval), unowned(tout), \
        unowned(yout), unowned(ev_int), unowned(ev_val), unowned(ev_g)
    ev_t, ev_k, ev_y, rates, Wn, qn, vn = unowned(ev_t), unowned(ev_k), unowned(ev_y), \
        unowned(rates), unowned(Wn), unowned(qn), unowned(vn)
    a, S, rot, cs0, css, W, dydt = unowned(a), unowned(S), unowned(rot), unowned(cs0), \
        unowned(css), unowned(W), unowned(dydt)
    ytmp, g_new, x_root, z, K, qs, z2 = unowned(ytmp), unowned(g_new), unowned(x_root), \
        unowned(z), unowned(K), unowned(qs), unowned(z2)
    n = y.shape[0] // 2
    nd = rates.shape[0]
    n2 = 2 * n
    nw = w.shape[0]
    n_ev = ev_int.shape[0]
    cap = tout.shape[0]
    q = y[:n]
    v = y[n:]
    a0 = f[n:]
    t = tv[TV_T]
    t_end = tv[TV_END]
    h = tv[TV_H]
    h_rot = -1.0
    for step in range(max_steps + 1):
        status = chunk_status(step, max_steps, t, t_end, t_eval, stats, cap, n_ev,
                              ev_t.shape[0])
        if status >= 0:
            return status
        t_target = next_stop(t_end, t_eval, stats)
        clipped = False
        hs = h
        if t + hs * (1.0 + 1e-10) >= t_target:
            hs = t_target - t
            clipped = True
        if hs != h_rot:
            for k in range(nw):
                for d in range(nd):
                    rot[k, d, 0] = np.cos(rates[d] * S[k] * hs)
                    rot[k, d, 1] = np.sin(rates[d] * S[k] * hs)
            h_rot = hs
        for d in range(nd):
            cs0[2 * d] = np.cos(rates[d] * t)
            cs0[2 * d + 1] = np.sin(rates[d] * t)
        for i in range(n):
            qn[i] = q[i]
            vn[i] = v[i]
            a[i] = a0[i]
        status = 0
        for k in range(nw):
            hk = w[k] * hs
            for i in range(n):
                vn[i] += 0.5 * hk * a[i]
                qn[i] += hk * vn[i]
            for d in range(nd):
                cr = rot[k, d, 0]
                sr = rot[k, d, 1]
                css[2 * d] = cs0[2 * d] * cr - cs0[2 * d + 1] * sr
                css[2 * d + 1] = cs0[2 * d + 1] * cr + cs0[2 * d] * sr
            status = call_fast_accel(ka[FAST_ACCEL], qn, t + S[k] * hs, css, p, a, Wn)
            if status != 0:
                break
            for i in range(n):
                vn[i] += 0.5 * hk * a[i]
        stats[ST_RHS] += nw
        if status != 0:
            tv[TV_T] = t
            return STATUS_SINGULAR
        for i in range(n):
            if not (np.isfinite(qn[i]) and np.isfinite(vn[i])):
                tv[TV_T] = t
                return STATUS_UNDERFLOW
        stats[ST_STEPS] += 1
        if clipped:
            t_new = t_target
            tv[TV_T_CARRY] = 0.0
        else:
            yk = hs - tv[TV_T_CARRY]
            t_new = t + yk
            tv[TV_T_CARRY] = (t_new - t) - yk
        fired = False
        if n_ev > 0:
            x_stop = second_order_events(ka, np.int64(1), t, hs, q, v, a0, qn, vn, p, z, z2, z,
                                         z, w, K, qs, rates, css, Wn, W, dydt, ytmp, ev_int,
                                         ev_val, ev_g, g_new, x_root, ev_t, ev_k, ev_y, stats)
            fired = x_stop <= 1.0
        if fired:   # stop at the event: a fresh step there
            second_order_stop(ka, np.int64(1), t, x_stop, hs, q, v, a0, qn, vn, a, p, z, z2, z,
                              z, w, K, qs, rates, css, Wn, stats)
            t_new = t + x_stop * hs
            tv[TV_T_CARRY] = 0.0
        for i in range(n):
            q[i] = qn[i]
            v[i] = vn[i]
            a0[i] = a[i]
            f[i] = vn[i]
        t = t_new
        tv[TV_T] = t
        store_output(t, y, n2, t_end, t_eval, tout, yout, stats, stride, fired)
        if fired:
            return STATUS_EVENT
    return STATUS_CHUNK


@njit(cache=True, error_model="numpy", fastmath=FAST_MATH)
def fast_start(ka, y, f, t, p):
    """f = [q̇, q̈] at (t, y) with the specialised kernel; returns the status."""
    n = y.shape[0] // 2
    rates = drive_rates(ka, p)
    nd = rates.shape[0]
    cs = np.empty(max(2 * nd, 1))
    for k in range(nd):
        cs[2 * k] = np.cos(rates[k] * t)
        cs[2 * k + 1] = np.sin(rates[k] * t)
    Wn = np.zeros((n, n + 1))
    a = np.empty(n)
    status = call_fast_accel(ka[FAST_ACCEL], y[:n], t, cs, p, a, Wn)
    for i in range(n):
        f[i] = y[n + i]
        f[n + i] = a[i]
    return status


# numba's cache does not notice changes to the slots and solvers these drivers call
from . import _kernel_calls, _linalg, _selection  # noqa: E402
from .module_store import guard_numba_cache  # noqa: E402

guard_numba_cache(sys.modules[__name__], _kernel_calls, _linalg, _selection)


# a first call on the main thread compiles where Ctrl-C need not wait for it
from ._first_calls import guard as _guard_first_calls  # noqa: E402

_guard_first_calls(__name__)
