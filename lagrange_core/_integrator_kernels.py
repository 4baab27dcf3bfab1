"""Kernel templates of the integrators (bound per system by ``system.kernels.bind``).

Every function here is a *template*: plain Python that calls the generated
kernels of one system by name (``rhs``, ``accelerations``, ``augmented``,
``constraint_residual``, ``energy``, ``N_DOF``, ``N_CONSTRAINTS``, ...; see
:mod:`lagrange_core.codegen`).  :meth:`Kernels.bind` compiles a copy against a
system, so the system's right-hand side is inlined into the integrator loop and
the machine code is cached on disk.  Method coefficient tables are passed in as
arrays (they are data, :mod:`lagrange_core.integrate` owns them).

The drivers integrate in *chunks*: a call advances until ``t_end``, until a step
budget is used up, until the output buffer is full or until a terminal event,
and returns a status, with the whole integrator state in the arrays it was given
(``y``, ``f``, ``tv``, ``stats``) so the next call continues exactly where this
one stopped.  Python regains control between chunks (Ctrl-C, memory).

Shared state layout
-------------------
``tv`` (float64): [t, t_end, h (next step), error sum, spare, Kahan compensation of t]
``stats`` (int64): [steps, rejected, rhs evaluations, outputs stored, stride
counter, next t_eval index, events stored, spare]

Status codes returned: see ``STATUS_*`` in :mod:`lagrange_core.integrate`
(0 done, 1 chunk budget used, 2 output buffer full, 3 terminal event,
4 singular mass matrix, 5 step size underflow / non-finite state,
6 event buffer full).

Events (``ev_int`` rows: kind, index, direction, terminal; ``ev_val`` the
value): kind 0 coordinate q_j − value, 1 velocity q̇_j − value, 2 multiplier
λ_j − value, 3 energy − value.  direction +1 only upward crossings, −1 only
downward, 0 both.
"""
import math

import numpy as np

KERNEL_IMPORTS = """
from lagrange_core._linalg import solve_augmented
try:                      # the scratch shape of the kernel contract (older kernels: the augmented block)
    _WORK_SHAPE = WORK_SHAPE
except NameError:
    _WORK_SHAPE = (N_DOF + N_CONSTRAINTS, N_DOF + N_CONSTRAINTS + 1)
"""


# -- helpers -----------------------------------------------------------------------------

def event_value(kind, idx, val, t, y, p, W, qdd, lam):
    """Value of one event function g(t, y) (see the module docstring)."""
    n = N_DOF
    if kind == 0:
        return y[idx] - val
    if kind == 1:
        return y[n + idx] - val
    if kind == 2:
        accelerations(y[:n], y[n:], t, p, qdd, lam, W)
        return lam[idx] - val
    return energy(y[:n], y[n:], t, p) - val


def project_constraints(y, t, p, W, P, res):
    """Project y = [q, q̇] back onto Φ(q, t) = 0 and Φ̇ = 0 (no-op without constraints).

    Least-squares (Euclidean) projection with Φ_q from the augmented matrix:
    Δq = −Φ_qᵀ (Φ_q Φ_qᵀ)⁻¹ Φ, three Gauss–Newton iterations for q (quadratic
    convergence from a drift of the size of the tolerance), then one exact linear
    step Δq̇ = −Φ_qᵀ (Φ_q Φ_qᵀ)⁻¹ Φ̇ (Φ̇ is linear in q̇).  ``P`` is scratch (m, m + 1).
    Returns 0, or 1 if Φ_q Φ_qᵀ is singular (redundant constraints).
    """
    n = N_DOF
    m = N_CONSTRAINTS
    if m == 0:
        return 0
    for sweep in range(4):
        constraint_residual(y[:n], y[n:], t, p, res)
        augmented(y[:n], y[n:], t, p, W)
        for a in range(m):
            for b in range(m):
                s = 0.0
                for j in range(n):
                    s += W[n + a, j] * W[n + b, j]
                P[a, b] = s
            P[a, m] = res[a] if sweep < 3 else res[m + a]
        if solve_augmented(P, m) != 0:
            return 1
        off = 0 if sweep < 3 else n
        for j in range(n):
            s = 0.0
            for a in range(m):
                s += W[n + a, j] * P[a, m]
            y[off + j] -= s
    return 0


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


def illinois_trial(a, b, fa, fb):
    """Next trial point of the Illinois (modified regula falsi) iteration on [a, b]."""
    x = (a * fb - b * fa) / (fb - fa)
    if not (a < x < b):
        x = 0.5 * (a + b)
    return x


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


def chunk_status(step, max_steps, t, t_end, t_eval, stats, cap, n_ev, ev_cap):
    """Why a driver's chunk stops before its step number ``step`` (a ``STATUS_*`` code), or
    −1 to go on: t_end reached, step budget used, output buffer (capacity ``cap``) full
    without t_eval, event buffer (capacity ``ev_cap``) too full for ``n_ev`` more events.
    Inlined into the drivers (here and in :mod:`lagrange_core.integrator_fast`)."""
    if t >= t_end:
        return 0
    if step == max_steps:
        return 1
    if t_eval.shape[0] == 0 and stats[3] + 2 > cap:
        return 2
    if n_ev > 0 and stats[6] + n_ev > ev_cap:
        return 6
    return -1


def next_stop(t_end, t_eval, stats):
    """The time the next step must not pass: t_end, or the next requested output time."""
    if t_eval.shape[0] > 0 and stats[5] < t_eval.shape[0]:
        return min(t_end, t_eval[stats[5]])
    return t_end


def store_output(t, y, n2, t_end, t_eval, tout, yout, stats, stride, force):
    """Record the state y (n2 entries) after an accepted step to time t: at the requested
    times t_eval (steps are clipped to land on them exactly, so none lies inside a step),
    or, without t_eval, every ``stride``-th step, at t_end, and whenever ``force``.
    Inlined into the drivers (here and in :mod:`lagrange_core.integrator_fast`)."""
    if t_eval.shape[0] > 0:
        ie = stats[5]
        while ie < t_eval.shape[0] and t_eval[ie] == t:
            tout[ie] = t
            for i in range(n2):
                yout[ie, i] = y[i]
            ie += 1
        stats[5] = ie
        stats[3] = ie
    else:
        stats[4] += 1
        if stats[4] >= stride or force or t >= t_end:
            stats[4] = 0
            k = stats[3]
            tout[k] = t
            for i in range(n2):
                yout[k, i] = y[i]
            stats[3] += 1


def dop853_locate(kind, idx, val, t0, h, y0, Fd, ga, gb, p, W, qdd, lam, yt):
    """Root of one event function on the dense output of a DOP853 step.

    Illinois (modified regula falsi) on x ∈ [0, 1], bracket shrunk until it is a
    few ulps of t wide.  Returns the step fraction x of the crossing.
    """
    a = 0.0
    b = 1.0
    fa = ga
    fb = gb
    side = 0
    tol = 4.0 * 2.220446049250313e-16 * max(abs(t0), abs(t0 + h), 1e-300) / abs(h)
    for it in range(200):
        if b - a <= tol:
            break
        x = illinois_trial(a, b, fa, fb)
        dop853_dense_eval(Fd, y0, x, yt)
        fx = event_value(kind, idx, val, t0 + x * h, yt, p, W, qdd, lam)
        if fx == 0.0:
            return x
        a, b, fa, fb, side = illinois_update(x, fx, a, b, fa, fb, side)
    return 0.5 * (a + b)


def starting_step(t, y, f, p, rtol, atol, W, y1, f1, exponent):
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
    for i in range(n2):
        y1[i] = y[i] + h0 * f[i]
    rhs(t + h0, y1, p, f1, W)
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

def dop853_chunk(y, f, tv, stats, p, rtol, atol, A, B, C, E3, E5, D, adaptive, max_steps,
                 t_eval, stride, tout, yout, ev_int, ev_val, ev_g, ev_t, ev_k, ev_y):
    """Advance the DOP853 pair (Dormand & Prince 8(5,3)) by one chunk.

    Parameters (arrays are updated in place; see the module docstring)
    ----------
    y, f : (2n,) state [q, q̇] at tv[0] and its derivative (FSAL).
    A, B, C, E3, E5, D : the coefficient table (scipy's ``dop853_coefficients``).
    adaptive : bool
        False: fixed steps of tv[2] (the 8th-order solution, no rejection; the
        error estimate is still accumulated).
    max_steps : steps allowed in this chunk.
    t_eval : output times (empty: store every ``stride``-th accepted step).
    tout, yout : output buffers; stats[3] rows used.
    ev_* : event specification, last values g, and the event buffers.

    Step-size control is Hairer's (scipy's): the error norm is the RMS of the
    combined 5th/3rd-order estimate scaled by atol + rtol·max(|y|, |y_new|),
    new h = h·min(10, max(0.2, 0.9·err^(−1/8))), no growth right after a rejection.
    """
    n = N_DOF
    n2 = 2 * n
    m = N_CONSTRAINTS
    W = np.zeros(_WORK_SHAPE)
    P = np.zeros((max(m, 1), max(m, 1) + 1))
    res = np.zeros(max(2 * m, 1))
    K = np.empty((16, n2))
    ynew = np.empty(n2)
    ytmp = np.empty(n2)
    Fd = np.empty((7, n2))
    qdd = np.empty(n)
    lam = np.empty(max(m, 1))
    n_ev = ev_int.shape[0]
    g_new = np.empty(max(n_ev, 1))
    x_root = np.empty(max(n_ev, 1))
    use_teval = t_eval.shape[0] > 0
    cap = tout.shape[0]

    t = tv[0]
    t_end = tv[1]
    h = tv[2]
    rejected = False
    for step in range(max_steps + 1):
        status = chunk_status(step, max_steps, t, t_end, t_eval, stats, cap, n_ev, ev_t.shape[0])
        if status >= 0:
            return status
        hmin = 16.0 * 2.220446049250313e-16 * max(abs(t), abs(t_end))
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
                status = rhs(t + C[s] * hs, ytmp, p, K[s], W)
                if status != 0:
                    break
            if status != 0:
                tv[0] = t
                return 4
            for i in range(n2):
                acc = 0.0
                for j in range(12):
                    acc += B[j] * K[j, i]
                ynew[i] = y[i] + hs * acc
            status = rhs(t + hs, ynew, p, K[12], W)
            stats[2] += 12
            if status != 0:
                tv[0] = t
                return 4
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
            stats[1] += 1
            if finite:
                h = hs * max(0.2, 0.9 * err ** (-1.0 / 8.0))
            else:
                h = 0.2 * hs
            rejected = True
            if h < hmin:
                tv[0] = t
                tv[2] = h
                return 5
        if not math.isfinite(err):
            tv[0] = t
            return 5
        # accepted: FSAL derivative is K[12]
        stats[0] += 1
        tv[3] += est
        have_dense = False
        # events
        t_stop = t + hs
        x_stop = 1.0
        fired = False
        for e in range(n_ev):
            g_new[e] = event_value(ev_int[e, 0], ev_int[e, 1], ev_val[e], t + hs, ynew, p, W,
                                   qdd, lam)
            x_root[e] = -1.0
            go = ev_g[e]
            gn = g_new[e]
            cross = (go < 0.0 and gn >= 0.0) or (go > 0.0 and gn <= 0.0)
            if cross and gn != go:
                d = ev_int[e, 2]
                up = gn > go
                if d == 0 or (d > 0 and up) or (d < 0 and not up):
                    if not have_dense:
                        dop853_dense(t, hs, y, ynew, K, A, C, D, p, W, ytmp, Fd)
                        stats[2] += 3
                        have_dense = True
                    x_root[e] = dop853_locate(ev_int[e, 0], ev_int[e, 1], ev_val[e], t, hs, y,
                                              Fd, go, gn, p, W, qdd, lam, ytmp)
                    if ev_int[e, 3] != 0 and x_root[e] <= x_stop:
                        x_stop = x_root[e]
                        fired = True
        for e in range(n_ev):
            if x_root[e] >= 0.0 and x_root[e] <= x_stop:
                k = stats[6]
                ev_t[k] = t + x_root[e] * hs
                ev_k[k] = e
                dop853_dense_eval(Fd, y, x_root[e], ytmp)
                if m > 0:
                    project_constraints(ytmp, ev_t[k], p, W, P, res)
                for i in range(n2):
                    ev_y[k, i] = ytmp[i]
                stats[6] += 1
            ev_g[e] = g_new[e]
        if fired:
            t_stop = t + x_stop * hs
        # dense output at the requested times
        if use_teval:
            ie = stats[5]
            while ie < t_eval.shape[0] and t_eval[ie] <= t_stop:
                if not have_dense:
                    dop853_dense(t, hs, y, ynew, K, A, C, D, p, W, ytmp, Fd)
                    stats[2] += 3
                    have_dense = True
                if t_eval[ie] == t + hs and not fired:
                    for i in range(n2):
                        ytmp[i] = ynew[i]
                else:
                    dop853_dense_eval(Fd, y, (t_eval[ie] - t) / hs, ytmp)
                if m > 0:   # the step and its interpolant drift off Φ = 0 by ~ the tolerance
                    project_constraints(ytmp, t_eval[ie], p, W, P, res)
                for i in range(n2):
                    yout[ie, i] = ytmp[i]
                tout[ie] = t_eval[ie]
                ie += 1
            stats[5] = ie
            stats[3] = ie
        if fired:
            dop853_dense_eval(Fd, y, x_stop, ynew)
            t_new = t_stop
            tv[5] = 0.0
        else:
            # compensated (Kahan) sum of the steps: over 10⁵–10⁶ steps plain t += h loses
            # ~1e-12 s, a drive-phase error ω δt that shows at the 1e-10 level
            yk = hs - tv[5]
            t_new = t + yk
            tv[5] = (t_new - t) - yk
        if m > 0:
            if project_constraints(ynew, t_new, p, W, P, res) != 0:
                tv[0] = t
                return 4
        if fired or m > 0:
            status = rhs(t_new, ynew, p, K[12], W)
            stats[2] += 1
            # a terminal event may sit exactly on a singular state (the swinging Atwood
            # machine stopped at r = 0): the run ends there, so that is not an error
            if status != 0 and not fired:
                tv[0] = t
                return 4
        for i in range(n2):
            y[i] = ynew[i]
            f[i] = K[12, i]
        t = t_new if not last or fired else t_end
        tv[0] = t
        if not use_teval:      # (requested times were interpolated on the dense output)
            store_output(t, y, n2, t_end, t_eval, tout, yout, stats, stride, fired)
        if fired:
            return 3
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
        tv[2] = h
    return 1


def dop853_dense(t, h, y, ynew, K, A, C, D, p, W, ytmp, Fd):
    """The three extra stages and the coefficients Fd of DOP853's dense output."""
    n2 = y.shape[0]
    for s in range(13, 16):
        for i in range(n2):
            acc = 0.0
            for j in range(s):
                acc += A[s, j] * K[j, i]
            ytmp[i] = y[i] + h * acc
        rhs(t + C[s] * h, ytmp, p, K[s], W)
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


def derivative_start(t, y, p, f):
    """f = dy/dt at (t, y); returns the kernel status."""
    n = N_DOF
    m = N_CONSTRAINTS
    W = np.zeros(_WORK_SHAPE)
    return rhs(t, y, p, f, W)


def project_start(t, y, p):
    """Project an initial state onto the constraints (returns the status)."""
    n = N_DOF
    m = N_CONSTRAINTS
    W = np.zeros(_WORK_SHAPE)
    P = np.zeros((max(m, 1), max(m, 1) + 1))
    res = np.zeros(max(2 * m, 1))
    return project_constraints(y, t, p, W, P, res)


def initial_step(t, y, f, p, rtol, atol):
    n = N_DOF
    m = N_CONSTRAINTS
    W = np.zeros(_WORK_SHAPE)
    return starting_step(t, y, f, p, rtol, atol, W, np.empty_like(y), np.empty_like(y), 1.0 / 8.0)


def along(T, Y, p, E, LAM, RES):
    """Energy, multipliers and constraint residual max(|Φ|, |Φ̇|) along a trajectory."""
    n = N_DOF
    m = N_CONSTRAINTS
    W = np.zeros(_WORK_SHAPE)
    qdd = np.empty(n)
    lam = np.empty(max(m, 1))
    res = np.empty(max(2 * m, 1))
    for k in range(T.shape[0]):
        q = Y[k, :n]
        qd = Y[k, n:]
        E[k] = energy(q, qd, T[k], p)
        if m > 0:
            accelerations(q, qd, T[k], p, qdd, lam, W)
            constraint_residual(q, qd, T[k], p, res)
            r = 0.0
            for a in range(m):
                LAM[k, a] = lam[a]
                r = max(r, abs(res[a]), abs(res[m + a]))
            RES[k] = r



# -- q̈ = f(q, t): RKN 12(10) and the symplectic composition ------------------------------

def accel_only(q, t, p, out, zero, qdd, lam, W):
    """q̈ = f(q, t) into ``out`` (velocities passed as zeros: F does not depend on them)."""
    status = accelerations(q, zero, t, p, qdd, lam, W)
    for i in range(q.shape[0]):
        out[i] = qdd[i]
    return status


def second_order_step(family, t, q, v, a0, h, p, c, A, b, bp, w, K, qn, vn, qs, zero, qdd,
                      lam, W):
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
            for i in range(n):
                acc = 0.0
                for j in range(s):
                    acc += A[s, j] * K[j, i]
                qs[i] = q[i] + ch * v[i] + h * h * acc
            status = accel_only(qs, t + ch, p, K[s], zero, qdd, lam, W)
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
        status = accel_only(qn, tt, p, K[0], zero, qdd, lam, W)
        if status != 0:
            return status
        for i in range(n):
            vn[i] += 0.5 * hk * K[0, i]
    return 0


def _partial_sum(w, k):
    s = 0.0
    for j in range(k + 1):
        s += w[j]
    return s


def second_order_chunk(family, y, f, tv, stats, p, rtol, atol, c, A, b, bp, bh, bph, w,
                       adaptive, max_steps, t_eval, stride, tout, yout, ev_int, ev_val, ev_g,
                       ev_t, ev_k, ev_y):
    """Advance an RKN (family 0) or symplectic (family 1) method by one chunk.

    Same state layout, statuses and outputs as :func:`dop853_chunk`.  Output at
    ``t_eval`` is exact: steps are shortened to land on each requested time (so
    many closely spaced outputs cost extra steps).  Events are located by
    Illinois iteration on x where every trial evaluates g after a step of x·h from
    the step start (the method's own accuracy, no interpolant).

    Step-size control (adaptive RKN): err = RMS of the difference of the 12th- and
    10th-order solutions [Δq, Δv] scaled by atol + rtol·max(|y|, |y_new|);
    new h = h·min(5, max(0.2, 0.9·err^(−1/11))), no growth right after a rejection.
    """
    n = N_DOF
    n2 = 2 * n
    m = N_CONSTRAINTS
    W = np.zeros(_WORK_SHAPE)
    ns = max(c.shape[0], 1)
    K = np.empty((ns, n))
    qn = np.empty(n)
    vn = np.empty(n)
    qs = np.empty(n)
    zero = np.zeros(n)
    qdd = np.empty(n)
    lam = np.empty(max(m, 1))
    ytmp = np.empty(n2)
    anew = np.empty(n)
    n_ev = ev_int.shape[0]
    g_new = np.empty(max(n_ev, 1))
    x_root = np.empty(max(n_ev, 1))
    cap = tout.shape[0]
    evals = (ns - 1) if family == 0 else w.shape[0]
    expo = -1.0 / 11.0

    q = y[:n]
    v = y[n:]
    a0 = f[n:]
    t = tv[0]
    t_end = tv[1]
    h = tv[2]
    rejected = False
    for step in range(max_steps + 1):
        status = chunk_status(step, max_steps, t, t_end, t_eval, stats, cap, n_ev, ev_t.shape[0])
        if status >= 0:
            return status
        hmin = 16.0 * 2.220446049250313e-16 * max(abs(t), abs(t_end))
        t_target = next_stop(t_end, t_eval, stats)
        while True:
            clipped = False
            hs = h
            if t + hs >= t_target or (not adaptive and t + hs * (1.0 + 1e-10) >= t_target):
                hs = t_target - t
                clipped = True
            status = second_order_step(family, t, q, v, a0, hs, p, c, A, b, bp, w, K, qn, vn,
                                       qs, zero, qdd, lam, W)
            stats[2] += evals
            if status != 0:
                tv[0] = t
                return 4
            err = 0.0
            est = 0.0
            if family == 0:
                e2 = 0.0
                for i in range(n):
                    dq = 0.0
                    dv = 0.0
                    for j in range(ns):
                        dq += (b[j] - bh[j]) * K[j, i]
                        dv += (bp[j] - bph[j]) * K[j, i]
                    dq *= hs * hs
                    dv *= hs
                    sq = atol + rtol * max(abs(q[i]), abs(qn[i]))
                    sv = atol + rtol * max(abs(v[i]), abs(vn[i]))
                    e2 += (dq / sq) ** 2 + (dv / sv) ** 2
                    est = max(est, abs(dq), abs(dv))
                err = math.sqrt(e2 / n2)
            finite = math.isfinite(err)
            for i in range(n):
                if not (math.isfinite(qn[i]) and math.isfinite(vn[i])):
                    finite = False
            if (not adaptive) or (finite and err < 1.0):
                if not finite:
                    tv[0] = t
                    return 5
                break
            stats[1] += 1
            if finite:
                h = hs * max(0.2, 0.9 * err ** expo)
            else:
                h = 0.2 * hs
            rejected = True
            if h < hmin:
                tv[0] = t
                tv[2] = h
                return 5
        # accepted
        stats[0] += 1
        tv[3] += est
        if clipped:
            t_new = t_target
            tv[5] = 0.0
        else:       # compensated (Kahan) sum of the steps, see dop853_chunk
            yk = hs - tv[5]
            t_new = t + yk
            tv[5] = (t_new - t) - yk
        if family == 0:
            status = accel_only(qn, t_new, p, anew, zero, qdd, lam, W)
            stats[2] += 1
            if status != 0:
                tv[0] = t
                return 4
        else:
            for i in range(n):
                anew[i] = K[0, i]
        # events: Illinois on the step fraction, each trial a fresh step from t
        x_stop = 1.0
        fired = False
        for i in range(n):
            ytmp[i] = qn[i]
            ytmp[n + i] = vn[i]
        for e in range(n_ev):
            g_new[e] = event_value(ev_int[e, 0], ev_int[e, 1], ev_val[e], t_new, ytmp, p, W,
                                   qdd, lam)
        for e in range(n_ev):
            x_root[e] = -1.0
            go = ev_g[e]
            gn = g_new[e]
            cross = (go < 0.0 and gn >= 0.0) or (go > 0.0 and gn <= 0.0)
            if cross and gn != go:
                d = ev_int[e, 2]
                up = gn > go
                if d == 0 or (d > 0 and up) or (d < 0 and not up):
                    x_root[e] = second_order_locate(family, e, ev_int, ev_val, t, q, v, a0, hs,
                                                    go, gn, p, c, A, b, bp, w, K, ytmp, qs,
                                                    zero, qdd, lam, W, stats, evals)
                    if ev_int[e, 3] != 0 and x_root[e] <= x_stop:
                        x_stop = x_root[e]
                        fired = True
        for e in range(n_ev):
            if x_root[e] >= 0.0 and x_root[e] <= x_stop:
                k = stats[6]
                ev_t[k] = t + x_root[e] * hs
                ev_k[k] = e
                second_order_step(family, t, q, v, a0, x_root[e] * hs, p, c, A, b, bp, w, K,
                                  ytmp[:n], ytmp[n:], qs, zero, qdd, lam, W)
                stats[2] += evals
                for i in range(n2):
                    ev_y[k, i] = ytmp[i]
                stats[6] += 1
            ev_g[e] = g_new[e]
        if fired:
            t_new = t + x_stop * hs
            second_order_step(family, t, q, v, a0, x_stop * hs, p, c, A, b, bp, w, K, qn, vn,
                              qs, zero, qdd, lam, W)
            accel_only(qn, t_new, p, anew, zero, qdd, lam, W)
            stats[2] += evals + 1
        for i in range(n):
            q[i] = qn[i]
            v[i] = vn[i]
            a0[i] = anew[i]
            f[i] = vn[i]
        t = t_new
        tv[0] = t
        store_output(t, y, n2, t_end, t_eval, tout, yout, stats, stride, fired)
        if fired:
            return 3
        if adaptive:
            if err == 0.0:
                factor = 5.0
            else:
                factor = min(5.0, 0.9 * err ** expo)
            if rejected:
                factor = min(1.0, factor)
            if clipped:
                h = max(h, hs * factor)
            else:
                h = hs * factor
            rejected = False
        tv[2] = h
    return 1


def second_order_locate(family, e, ev_int, ev_val, t, q, v, a0, h, ga, gb, p, c, A, b, bp, w,
                        K, ytmp, qs, zero, qdd, lam, W, stats, evals):
    """Step fraction x of an event crossing: Illinois iteration, each trial a step of x·h."""
    n = q.shape[0]
    a = 0.0
    bb = 1.0
    fa = ga
    fb = gb
    side = 0
    tol = 4.0 * 2.220446049250313e-16 * max(abs(t), abs(t + h), 1e-300) / abs(h)
    for it in range(100):
        if bb - a <= tol:
            break
        x = illinois_trial(a, bb, fa, fb)
        second_order_step(family, t, q, v, a0, x * h, p, c, A, b, bp, w, K, ytmp[:n], ytmp[n:],
                          qs, zero, qdd, lam, W)
        stats[2] += evals
        fx = event_value(ev_int[e, 0], ev_int[e, 1], ev_val[e], t + x * h, ytmp, p, W, qdd, lam)
        if fx == 0.0:
            return x
        a, bb, fa, fb, side = illinois_update(x, fx, a, bb, fa, fb, side)
    return 0.5 * (a + bb)


def rkn_initial_step(t, y, f, p, rtol, atol):
    """Starting step for RKN 12(10): Hairer's estimate with exponent 1/11."""
    W = np.zeros(_WORK_SHAPE)
    return starting_step(t, y, f, p, rtol, atol, W, np.empty_like(y), np.empty_like(y),
                         1.0 / 11.0)


KERNEL_TEMPLATES = [event_value, project_constraints, dop853_dense_eval, illinois_trial,
                    illinois_update, chunk_status, next_stop, store_output, dop853_locate,
                    starting_step, dop853_chunk, dop853_dense, derivative_start,
                    project_start, initial_step, along, accel_only,
                    second_order_step, _partial_sum, second_order_chunk,
                    second_order_locate, rkn_initial_step]
#: inlined by numba (no call, so no reference-count traffic, on the per-step path)
KERNEL_JIT_OPTIONS = {name: 'inline="always"' for name in ("chunk_status", "next_stop",
                                                            "store_output")}
#: the drivers' shared steps, also inlined into integrator_fast's drivers
SHARED_STEPS = [chunk_status, next_stop, store_output]
