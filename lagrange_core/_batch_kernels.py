"""Batch integration's compiled kernels: many trajectories per call, observables only.

One parallel call (numba ``prange``, dynamic scheduling: trajectories end at different
times) integrates every grid point named in ``idx`` from its own initial state and
parameters, and records only what :func:`lagrange_core.batch.simulate_grid` asked for,
computed as the steps are taken — never the trajectory itself:

=================  =====================  ================================================
observable         array (per point i)    how
=================  =====================  ================================================
final state        ``YF[i]`` (2n)         [q, q̇] where the run stopped, at ``TF[i]``
strobe samples     ``SQ[i, k]`` (2n)      [q, q̇] at t0 + kT: steps are shortened to land on
                                          each sample time exactly (``OBS_STROBE``)
time mean of q     ``QM[i]`` (n)          ∫q dt / (t − t0); per step the corrected trapezoid
                                          h(q0 + q1)/2 + h²(q̇0 − q̇1)/12 (4th order; exact
                                          for a trigonometric polynomial of degree < m on m
                                          equal steps per period)
max deviation      ``DEV[i]`` (n)         max of |q − q_ref| at t0 and step ends (``OBS_REF``)
band exit          ``EXIT[i]``,           first time a coordinate leaves [lo, hi]: located in
                   ``EXITC[i]``           the step by the cubic Hermite interpolant of (q, q̇)
                                          (error O(h⁴)); the trajectory stops there, its final
                                          state is the interpolant's (``OBS_BAND``)
energy drift       ``EDRIFT[i]``          max over step ends of |h(t) − h(t0)| (``OBS_ENERGY``)
counts             ``COUNTS[i]``          accepted steps, rejected steps, kernel evaluations
error estimate     ``ERR[i]``             sum of the local error estimates (as ``simulate``)
status             ``STATUS[i]``          ``GRID_*`` below
=================  =====================  ================================================

A point that fails (singular mass matrix, a non-finite state, the step size falling
below the resolution of t, its step budget used) gets its status and the state where it
stopped; the other points are not affected.  The loops are the drivers of
:mod:`lagrange_core._integrator_kernels` rewritten per point without output buffers
(RKN 12(10) and the symplectic composition on the drive kernel, with the drive advanced
by rotations; DOP853 on the generic right-hand side, with projection onto the
constraints), compiled once per installation and reaching the system's kernels by
address (``ka``).
"""
import math
import sys

import numpy as np
from numba import njit, prange

from ._integrator_kernels import (FAST_MATH, INLINE, drive_rates, project_constraints,
                                  starting_step)
from ._kernel_calls import ENERGY, FAST_ACCEL, RHS, call_energy, call_fast_accel, call_rhs

#: per-point status (``GridTrajectories.status``)
GRID_FINISHED, GRID_LEFT_BAND, GRID_UNDERFLOW, GRID_NON_FINITE, GRID_SINGULAR, \
    GRID_MAX_STEPS, GRID_NOT_RUN = range(7)
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
        for it in range(100):
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


# -- q̈ = f(q, t): RKN 12(10) (family 0) and the symplectic composition (family 1) ----------

@njit(cache=True, error_model="numpy", fastmath=FAST_MATH)
def point_second_order(ka, family, adaptive, y0, p, t0, t1, h0, T, ref, lo, hi, flags, rtol,
                       atol, max_steps, c, A, b, bp, bh, bph, w, yf, sq, qsum, dev, counts,
                       hbuf):
    """Integrate one point of a q̈ = f(q, t) system (drive kernel) from y0 at t0 to t1.

    family 0: RKN 12(10), adaptive (``adaptive``) or at the fixed step ``h0``;
    family 1: the symmetric composition of velocity Verlet with weights ``w`` at ``h0``.
    Observables as in the module docstring.  A non-empty ``hbuf`` records the accepted
    steps (a pilot run; observables off).  Returns (status, t, exit coordinate, energy
    drift, error estimate, steps recorded in hbuf).
    """
    n = y0.shape[0] // 2
    rates = drive_rates(ka, p)
    nd = rates.shape[0]
    ns = c.shape[0] if family == 0 else w.shape[0] + 1
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
    S = np.empty(ns)                      # family 1: cumulative substep weights
    acc = 0.0
    for k in range(ns - 1 if family == 1 else 0):
        acc += w[k]
        S[k] = acc
    db = np.empty(ns)
    dbp = np.empty(ns)
    if family == 0:
        for j in range(ns):
            db[j] = b[j] - bh[j]
            dbp[j] = bp[j] - bph[j]
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
    e0 = call_energy(ka[ENERGY], q, v, t, p) if flags & OBS_ENERGY else 0.0
    drift = 0.0
    if flags & OBS_STROBE:
        for i in range(2 * n):
            sq[0, i] = y0[i]
    k_next = 1
    h = h0
    if adaptive and h <= 0.0:
        W = np.zeros((n, n + 1))
        f = np.empty(2 * n)
        for i in range(n):
            f[i] = v[i]
            f[n + i] = a0[i]
        h = starting_step(ka, t, y0, f, p, rtol, atol, W, np.empty(2 * n), np.empty(2 * n),
                          1.0 / 11.0)
        counts[CNT_EVALS] += 2
    h_rot = -1.0
    t_carry = 0.0
    err_sum = 0.0
    n_h = 0
    rejected = False
    expo = -1.0 / 11.0
    status = GRID_FINISHED
    jx = -1
    while True:
        if t >= t1:
            break
        if counts[CNT_STEPS] >= max_steps:
            status = GRID_MAX_STEPS
            break
        hmin = 16.0 * _EPS * max(abs(t), abs(t1))
        t_target = _next_stop(t1, T, k_next, t0, flags)
        for k in range(nd):
            cs0[2 * k] = np.cos(rates[k] * t)
            cs0[2 * k + 1] = np.sin(rates[k] * t)
        kst = 0
        while True:
            clipped = False
            hs = h
            if t + hs >= t_target or (not adaptive and t + hs * (1.0 + 1e-10) >= t_target):
                hs = t_target - t
                clipped = True
            # a step shortened by rounding only (landing on a strobe time) keeps the
            # rotations: their angle error α·|hs − h_rot| is at the rounding of t itself
            if abs(hs - h_rot) > 4.0 * _EPS * max(abs(t), abs(t_target)):
                for s in range(ns):
                    frac = c[s] if family == 0 else (S[s] if s < ns - 1 else 1.0)
                    for k in range(nd):
                        rot[s, k, 0] = np.cos(rates[k] * frac * hs)
                        rot[s, k, 1] = np.sin(rates[k] * frac * hs)
                h_rot = hs
            if family == 0:
                for i in range(n):
                    K[0, i] = a0[i]
                for s in range(1, ns):
                    ch = c[s] * hs
                    for i in range(n):
                        acc = 0.0
                        for j in range(s):
                            acc += A[s, j] * K[j, i]
                        qs[i] = q[i] + ch * v[i] + hs * hs * acc
                    for k in range(nd):
                        cr = rot[s, k, 0]
                        sr = rot[s, k, 1]
                        css[2 * k] = cs0[2 * k] * cr - cs0[2 * k + 1] * sr
                        css[2 * k + 1] = cs0[2 * k + 1] * cr + cs0[2 * k] * sr
                    kst = call_fast_accel(ka[FAST_ACCEL], qs, t + ch, css, p, K[s], Wn)
                    if kst != 0:
                        break
                counts[CNT_EVALS] += ns - 1
                if kst != 0:
                    break
                e2 = 0.0
                est = 0.0
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
                    # compensated (Kahan) update, as in fast_rkn_chunk
                    yq = hs * v[i] + hs * hs * accq - cq[i]
                    qn[i] = q[i] + yq
                    cqn[i] = (qn[i] - q[i]) - yq
                    yv = hs * accv - cv[i]
                    vn[i] = v[i] + yv
                    cvn[i] = (vn[i] - v[i]) - yv
                    dq *= hs * hs
                    dv *= hs
                    if adaptive:
                        sq_ = atol + rtol * max(abs(q[i]), abs(qn[i]))
                        sv_ = atol + rtol * max(abs(v[i]), abs(vn[i]))
                        e2 += (dq / sq_) ** 2 + (dv / sv_) ** 2
                    est = max(est, abs(dq), abs(dv))
                err = np.sqrt(e2 / (2 * n))
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
                    for k in range(nd):
                        cr = rot[s, k, 0]
                        sr = rot[s, k, 1]
                        css[2 * k] = cs0[2 * k] * cr - cs0[2 * k + 1] * sr
                        css[2 * k + 1] = cs0[2 * k + 1] * cr + cs0[2 * k] * sr
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
            if (not adaptive) or (finite and err < 1.0):
                break
            counts[CNT_REJECTED] += 1
            h = hs * max(0.2, 0.9 * err ** expo) if np.isfinite(err) else 0.2 * hs
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
        if family == 0:         # FSAL: the drive at t + hs is the rotation of stage c = 1
            for k in range(nd):
                cr = rot[ns - 1, k, 0]
                sr = rot[ns - 1, k, 1]
                css[2 * k] = cs0[2 * k] * cr - cs0[2 * k + 1] * sr
                css[2 * k + 1] = cs0[2 * k + 1] * cr + cs0[2 * k] * sr
            if call_fast_accel(ka[FAST_ACCEL], qn, t_new, css, p, an, Wn) != 0:
                status = GRID_SINGULAR
                break
            counts[CNT_EVALS] += 1
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
        if adaptive:
            factor = 5.0 if err == 0.0 else min(5.0, 0.9 * err ** expo)
            if rejected:
                factor = min(1.0, factor)
            h = max(h, hs * factor) if clipped else hs * factor
            rejected = False
    if jx < 0:
        for i in range(n):
            yf[i] = q[i]
            yf[n + i] = v[i]
    return status, t, jx, drift, err_sum, n_h


@njit(cache=True, error_model="numpy", fastmath=FAST_MATH)
def pilot_step(ka, y0, p, t0, t1, T, rtol, atol, c, A, b, bp, bh, bph, counts):
    """The fixed step of RKN 12 for one point: an adaptive pilot over the first 1/50 of
    [t0, t1] (as ``integrate``'s "rkn12-fixed"), the 20th percentile of its accepted
    steps, shortened so that a whole number of steps spans the strobe period T (or
    the span)."""
    n = y0.shape[0] // 2
    span = t1 - t0
    hbuf = np.empty(4096)
    yf = np.empty(2 * n)
    z = np.zeros(n)
    inf = np.full(n, np.inf)
    out = point_second_order(ka, 0, True, y0, p, t0, t0 + span / 50.0, 0.0, 0.0, z, -inf, inf,
                             0, rtol, atol, 1 << 40, c, A, b, bp, bh, bph, np.zeros(1), yf,
                             np.empty((1, 2 * n)), np.zeros(n), np.zeros(n), counts, hbuf)
    m = out[5]
    if m == 0:
        return span
    steps = np.sort(hbuf[:m])
    h = steps[int(0.2 * (m - 1))]
    period = T if T > 0.0 else span
    return period / math.ceil(period / h)


@njit(cache=True, parallel=True)
def grid_second_order(ka, family, adaptive, pilot, idx, Y0, P, TS, H, TSTR, REF, LO, HI, flags,
                      rtol, atol, max_steps, c, A, b, bp, bh, bph, w, YF, TF, SQ, QM, DEV, EXIT,
                      EXITC, EDRIFT, COUNTS, ERR, STATUS):
    """Every point ``idx[k]`` with :func:`point_second_order` (``pilot``: the fixed step of
    each point from :func:`pilot_step`)."""
    nb = np.zeros(0)
    for k in prange(idx.shape[0]):
        i = idx[k]
        h0 = H[i]
        if pilot:
            h0 = pilot_step(ka, Y0[i], P[i], TS[i, 0], TS[i, 1], TSTR[i], rtol, atol, c, A, b,
                            bp, bh, bph, COUNTS[i])
        st, t, jx, drift, err, nh = point_second_order(
            ka, family, adaptive, Y0[i], P[i], TS[i, 0], TS[i, 1], h0, TSTR[i], REF[i], LO[i],
            HI[i], flags, rtol, atol, max_steps, c, A, b, bp, bh, bph, w, YF[i], SQ[i], QM[i],
            DEV[i], COUNTS[i], nb)
        STATUS[i] = st
        TF[i] = t
        EXITC[i] = jx
        EXIT[i] = t if jx >= 0 else np.nan
        EDRIFT[i] = drift
        ERR[i] = err


# -- RKN 12 at a fixed step, several trajectories interleaved per thread --------------------

#: trajectories a thread advances together in :func:`grid_rkn_lanes`
LANES = 8


@njit(cache=True)
def _lane_start(ka, l, i, Y0, P, TS, H, TSTR, REF, DEV, flags, pilot, rtol, atol, c, A, b, bp,
                bh, bph, q, v, a0, cq, cv, t, h, hrot, tcar, kn, e0, drift, err, rates, nrates,
                cs, Wn, YF, SQ, COUNTS):
    """Load point i into lane l: state, drive rates, acceleration, step (given or from a
    pilot); returns 0, or the point's status when it cannot start (singular at t0)."""
    n = q.shape[1]
    p = P[i]
    if pilot:
        h[l] = pilot_step(ka, Y0[i], p, TS[i, 0], TS[i, 1], TSTR[i], rtol, atol, c, A, b, bp,
                          bh, bph, COUNTS[i])
    else:
        h[l] = H[i]
    r = drive_rates(ka, p)
    nrates[l] = r.shape[0]
    for k in range(r.shape[0]):
        rates[l, k] = r[k]
    t[l] = TS[i, 0]
    for j in range(n):
        q[l, j] = Y0[i, j]
        v[l, j] = Y0[i, n + j]
        cq[l, j] = 0.0
        cv[l, j] = 0.0
        YF[i, j] = Y0[i, j]
        YF[i, n + j] = Y0[i, n + j]
        if flags & OBS_REF:
            DEV[i, j] = abs(Y0[i, j] - REF[i, j])
    for k in range(nrates[l]):
        cs[2 * k] = np.cos(rates[l, k] * t[l])
        cs[2 * k + 1] = np.sin(rates[l, k] * t[l])
    if call_fast_accel(ka[FAST_ACCEL], q[l], t[l], cs, p, a0[l], Wn) != 0:
        return GRID_SINGULAR
    COUNTS[i, CNT_EVALS] += 1
    e0[l] = call_energy(ka[ENERGY], q[l], v[l], t[l], p) if flags & OBS_ENERGY else 0.0
    drift[l] = 0.0
    err[l] = 0.0
    if flags & OBS_STROBE:
        for j in range(2 * n):
            SQ[i, 0, j] = Y0[i, j]
    kn[l] = 1
    hrot[l] = -1.0
    tcar[l] = 0.0
    return 0


@njit(cache=True, parallel=True, error_model="numpy", fastmath=FAST_MATH)
def grid_rkn_lanes(ka, pilot, idx, block, Y0, P, TS, H, TSTR, REF, LO, HI, flags, rtol, atol,
                   max_steps, c, A, b, bp, bh, bph, YF, TF, SQ, QM, DEV, EXIT, EXITC, EDRIFT,
                   COUNTS, ERR, STATUS):
    """RKN 12 at a fixed step over the points ``idx``: each thread takes blocks of ``block``
    points and advances :data:`LANES` of them together, stage by stage, refilling a lane
    from its block when its trajectory ends.

    Why: one trajectory's stages form a chain (each needs the last one's sin θ), so a
    lone trajectory waits on latencies; independent lanes fill those waits (the CPU
    overlaps them), about doubling the throughput.  Same results as
    :func:`point_second_order` at the same step (the arithmetic per lane is the same).
    """
    N = idx.shape[0]
    nblocks = (N + block - 1) // block
    ns = c.shape[0]
    n = Y0.shape[1] // 2
    for blk in prange(nblocks):
        lo_b = blk * block
        hi_b = min(N, lo_b + block)
        L = LANES
        ndm = max(drive_rates(ka, P[idx[lo_b]]).shape[0], 1)   # the same for every point
        pt = np.full(L, -1, dtype=np.int64)
        q = np.empty((L, n))
        v = np.empty((L, n))
        a0 = np.empty((L, n))
        qn = np.empty((L, n))
        vn = np.empty((L, n))
        cq = np.zeros((L, n))
        cv = np.zeros((L, n))
        cqn = np.zeros((L, n))
        cvn = np.zeros((L, n))
        K = np.empty((L, ns, n))
        qs = np.empty(n)
        Wn = np.zeros((n, n + 1))
        t = np.zeros(L)
        h = np.zeros(L)
        hs = np.zeros(L)
        hrot = np.zeros(L)
        tcar = np.zeros(L)
        ttar = np.zeros(L)
        clip = np.zeros(L, dtype=np.bool_)
        kn = np.zeros(L, dtype=np.int64)
        e0 = np.zeros(L)
        drift = np.zeros(L)
        err = np.zeros(L)
        rates = np.zeros((L, ndm))
        nrates = np.zeros(L, dtype=np.int64)
        rot = np.empty((L, ns, ndm, 2))
        cs0 = np.empty((L, 2 * ndm))
        css = np.empty(2 * ndm)
        nxt = lo_b
        active = 0
        for l in range(L):
            while nxt < hi_b and pt[l] < 0:
                i = idx[nxt]
                nxt += 1
                st = _lane_start(ka, l, i, Y0, P, TS, H, TSTR, REF, DEV, flags, pilot, rtol,
                                 atol, c, A, b, bp, bh, bph, q, v, a0, cq, cv, t, h, hrot, tcar,
                                 kn, e0, drift, err, rates, nrates, css, Wn, YF, SQ, COUNTS)
                if st != 0:
                    STATUS[i] = st
                    TF[i] = TS[i, 0]
                else:
                    pt[l] = i
                    active += 1
        while active > 0:
            # the step of every lane: its length, its drive rotations, the first stage
            for l in range(L):
                i = pt[l]
                if i < 0:
                    continue
                tt = t[l]
                tar = _next_stop(TS[i, 1], TSTR[i], kn[l], TS[i, 0], flags)
                ttar[l] = tar
                hh = h[l]
                clip[l] = False
                if tt + hh * (1.0 + 1e-10) >= tar:
                    hh = tar - tt
                    clip[l] = True
                hs[l] = hh
                nd = nrates[l]
                if abs(hh - hrot[l]) > 4.0 * _EPS * max(abs(tt), abs(tar)):
                    for s in range(ns):
                        for k in range(nd):
                            rot[l, s, k, 0] = np.cos(rates[l, k] * c[s] * hh)
                            rot[l, s, k, 1] = np.sin(rates[l, k] * c[s] * hh)
                    hrot[l] = hh
                for k in range(nd):
                    cs0[l, 2 * k] = np.cos(rates[l, k] * tt)
                    cs0[l, 2 * k + 1] = np.sin(rates[l, k] * tt)
                for j in range(n):
                    K[l, 0, j] = a0[l, j]
            # the stages, lane by lane (independent chains: their latencies overlap)
            for s in range(1, ns):
                for l in range(L):
                    i = pt[l]
                    if i < 0:
                        continue
                    hh = hs[l]
                    ch = c[s] * hh
                    for j in range(n):
                        acc0 = 0.0
                        acc1 = 0.0
                        for m in range(0, s - 1, 2):
                            acc0 += A[s, m] * K[l, m, j]
                            acc1 += A[s, m + 1] * K[l, m + 1, j]
                        if s % 2 == 1:
                            acc0 += A[s, s - 1] * K[l, s - 1, j]
                        qs[j] = q[l, j] + ch * v[l, j] + hh * hh * (acc0 + acc1)
                    for k in range(nrates[l]):
                        cr = rot[l, s, k, 0]
                        sr = rot[l, s, k, 1]
                        css[2 * k] = cs0[l, 2 * k] * cr - cs0[l, 2 * k + 1] * sr
                        css[2 * k + 1] = cs0[l, 2 * k + 1] * cr + cs0[l, 2 * k] * sr
                    if call_fast_accel(ka[FAST_ACCEL], qs, t[l] + ch, css, P[i], K[l, s],
                                       Wn) != 0:
                        STATUS[i] = GRID_SINGULAR      # finished below
            # the new state of every lane; end, or go on
            for l in range(L):
                i = pt[l]
                if i < 0:
                    continue
                COUNTS[i, CNT_EVALS] += ns - 1
                hh = hs[l]
                st = -1
                if STATUS[i] == GRID_SINGULAR:
                    st = GRID_SINGULAR
                est = 0.0
                finite = True
                for j in range(n):
                    accq = 0.0
                    accv = 0.0
                    dq = 0.0
                    dv = 0.0
                    for m in range(ns):
                        km = K[l, m, j]
                        accq += b[m] * km
                        accv += bp[m] * km
                        dq += (b[m] - bh[m]) * km
                        dv += (bp[m] - bph[m]) * km
                    yq = hh * v[l, j] + hh * hh * accq - cq[l, j]
                    qn[l, j] = q[l, j] + yq
                    cqn[l, j] = (qn[l, j] - q[l, j]) - yq
                    yv = hh * accv - cv[l, j]
                    vn[l, j] = v[l, j] + yv
                    cvn[l, j] = (vn[l, j] - v[l, j]) - yv
                    est = max(est, abs(dq * hh * hh), abs(dv * hh))
                    if not (np.isfinite(qn[l, j]) and np.isfinite(vn[l, j])):
                        finite = False
                tt = t[l]
                if st < 0 and not finite:
                    st = GRID_NON_FINITE
                if st < 0:
                    COUNTS[i, CNT_STEPS] += 1
                    err[l] += est
                    if clip[l]:
                        t_new = ttar[l]
                        tcar[l] = 0.0
                    else:
                        yk = hh - tcar[l]
                        t_new = tt + yk
                        tcar[l] = (t_new - tt) - yk
                    for k in range(nrates[l]):
                        cr = rot[l, ns - 1, k, 0]
                        sr = rot[l, ns - 1, k, 1]
                        css[2 * k] = cs0[l, 2 * k] * cr - cs0[l, 2 * k + 1] * sr
                        css[2 * k + 1] = cs0[l, 2 * k + 1] * cr + cs0[l, 2 * k] * sr
                    if call_fast_accel(ka[FAST_ACCEL], qn[l], t_new, css, P[i], a0[l], Wn) != 0:
                        st = GRID_SINGULAR
                    else:
                        COUNTS[i, CNT_EVALS] += 1
                        x, jx, dr = _observe(ka, tt, hh, q[l], v[l], qn[l], vn[l], P[i], flags,
                                             REF[i], LO[i], HI[i], DEV[i], QM[i], e0[l],
                                             drift[l], YF[i])
                        drift[l] = dr
                        if jx >= 0:
                            st = GRID_LEFT_BAND
                            t[l] = tt + x * hh
                            EXITC[i] = jx
                            EXIT[i] = t[l]
                        else:
                            for j in range(n):
                                q[l, j] = qn[l, j]
                                v[l, j] = vn[l, j]
                                cq[l, j] = cqn[l, j]
                                cv[l, j] = cvn[l, j]
                            t[l] = t_new
                            if clip[l] and (flags & OBS_STROBE) and \
                                    t_new == TS[i, 0] + kn[l] * TSTR[i]:
                                if kn[l] < SQ.shape[1]:
                                    for j in range(n):
                                        SQ[i, kn[l], j] = q[l, j]
                                        SQ[i, kn[l], n + j] = v[l, j]
                                kn[l] += 1
                            if t_new >= TS[i, 1]:
                                st = GRID_FINISHED
                            elif COUNTS[i, CNT_STEPS] >= max_steps:
                                st = GRID_MAX_STEPS
                if st < 0:
                    continue
                # the lane's point ends: record it, load the next point of the block
                STATUS[i] = st
                TF[i] = t[l]
                EDRIFT[i] = drift[l]
                ERR[i] = err[l]
                if st != GRID_LEFT_BAND:
                    for j in range(n):
                        YF[i, j] = q[l, j]
                        YF[i, n + j] = v[l, j]
                pt[l] = -1
                active -= 1
                while nxt < hi_b and pt[l] < 0:
                    i2 = idx[nxt]
                    nxt += 1
                    st2 = _lane_start(ka, l, i2, Y0, P, TS, H, TSTR, REF, DEV, flags, pilot,
                                      rtol, atol, c, A, b, bp, bh, bph, q, v, a0, cq, cv, t, h,
                                      hrot, tcar, kn, e0, drift, err, rates, nrates, css, Wn, YF,
                                      SQ, COUNTS)
                    if st2 != 0:
                        STATUS[i2] = st2
                        TF[i2] = TS[i2, 0]
                    else:
                        pt[l] = i2
                        active += 1


# -- any system: DOP853 on the right-hand side, with projection onto the constraints -----

@njit(cache=True)
def point_dop853(ka, m, adaptive, y0, p, t0, t1, h0, T, ref, lo, hi, flags, rtol, atol,
                 max_steps, A, B, C, E3, E5, yf, sq, qsum, dev, counts):
    """Integrate one point with DOP853 (adaptive, or the fixed 8th-order step ``h0``) on
    the system's ``rhs``; constrained states are projected onto Φ = 0, Φ̇ = 0 after every
    step.  Observables and returns as :func:`point_second_order`."""
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
        hmin = 16.0 * _EPS * max(abs(t), abs(t1))
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


@njit(cache=True, parallel=True)
def grid_dop853(ka, m, adaptive, idx, Y0, P, TS, H, TSTR, REF, LO, HI, flags, rtol, atol,
                max_steps, A, B, C, E3, E5, YF, TF, SQ, QM, DEV, EXIT, EXITC, EDRIFT, COUNTS, ERR,
                STATUS):
    """Every point ``idx[k]`` with :func:`point_dop853`."""
    for k in prange(idx.shape[0]):
        i = idx[k]
        st, t, jx, drift, err, nh = point_dop853(
            ka, m, adaptive, Y0[i], P[i], TS[i, 0], TS[i, 1], H[i], TSTR[i], REF[i], LO[i],
            HI[i], flags, rtol, atol, max_steps, A, B, C, E3, E5, YF[i], SQ[i], QM[i], DEV[i],
            COUNTS[i])
        STATUS[i] = st
        TF[i] = t
        EXITC[i] = jx
        EXIT[i] = t if jx >= 0 else np.nan
        EDRIFT[i] = drift
        ERR[i] = err


# numba's cache does not notice changes to the kernels these call
from . import _integrator_kernels, _kernel_calls, _linalg  # noqa: E402
from .module_store import guard_numba_cache  # noqa: E402

guard_numba_cache(sys.modules[__name__], _integrator_kernels, _kernel_calls, _linalg)
