"""The tangent flow's compiled kernels: a trajectory and k tangent vectors, re-orthonormalised.

For y′ = f(t, y), y = [q, q̇] of dimension d = 2n, a tangent vector obeys the variational
equation v′ = J(t, y(t)) v, J = ∂f/∂y.  :func:`advance` integrates y and a d × k matrix V
of tangent vectors together with the DOP853 pair (Dormand & Prince 8(5,3), the
coefficient table of :data:`lagrange_core.integrate.METHODS`), J V taken at every stage's
own state, either

* ``exact``: with the system's exact compiled Jacobian (slot ``jacobian`` of
  :mod:`lagrange_core._kernel_calls`, as :mod:`lagrange_core.variational` uses), so V is
  the exact derivative of the discrete flow ("internal differentiation"); or
* not: J v by the forward difference (f(y + ε v) − f(y))/ε, ε = √eps·max(1, ‖y‖)/‖v‖,
  one evaluation of f per vector (relative error ~1e-8).  The Jacobian's forward-mode
  evaluation and solve cost about ten evaluations of f for the driven pendulum, so this
  is what a chaos map over thousands of points uses.

Benettin's method
-----------------
After every accepted step V is re-orthonormalised by modified Gram–Schmidt, V = Q R, and
log R_cc is added to column c's sum; V continues as Q (and the next step's first stage,
J Q, is the last stage's J V times R⁻¹: no evaluation).  The sums over an interval are
those of one QR of the product of the steps' tangent maps (QR of a product is the product
of the QRs), so re-orthonormalising every step gives the numbers of the textbook's once
per drive period in exact arithmetic, and in floating point more: the columns never get
time to collapse onto the most expanding direction (after one period of a strongly
damped system they would be e^(Δλ T) apart, beyond the digits of a double).  It costs
d k² operations a step, less than one of the 12 stages.

Step control is that of the batch integrator's DOP853 (its error norm over y and V: V's
columns are orthonormal at every step's start, so their tolerance is relative), with
steps shortened to land on the interval ends t_origin + stops[j] T exactly, and never
longer than T/2 (a state resting on an equilibrium sees the drive only through V).

Statuses are those of :data:`lagrange_core.batch.STATUS_NAMES`.
"""
import math
import sys

import numpy as np
from numba import njit

from lagrange_core._integrator_kernels import starting_step
from lagrange_core._kernel_calls import JACOBIAN, RHS, call_jacobian, call_rhs
from lagrange_core._thread_blocks import run_rows

#: statuses (indices into lagrange_core.batch.STATUS_NAMES)
FINISHED, UNDERFLOW, NON_FINITE, SINGULAR, MAX_STEPS, NOT_RUN = 0, 2, 3, 4, 5, 6
#: columns of the counts array: accepted steps, rejected steps, stage evaluations
STEPS, REJECTED, EVALS = 0, 1, 2
_EPS = 2.220446049250313e-16


@njit(cache=True, inline="always")
def _orthonormalise(V, R, logs):
    """V = Q R by modified Gram–Schmidt (two passes where a column lost most of its
    length, the "twice is enough" rule); V becomes Q, R (k × k, upper) is written, and
    log R_cc is added to logs[c].  Returns False if a column vanished (or is not finite)."""
    d, k = V.shape
    for c in range(k):
        before = 0.0
        for i in range(d):
            before += V[i, c] * V[i, c]
        for b in range(k):
            R[b, c] = 0.0
        for _sweep in range(2):
            for b in range(c):
                r = 0.0
                for i in range(d):
                    r += V[i, b] * V[i, c]
                R[b, c] += r
                for i in range(d):
                    V[i, c] -= r * V[i, b]
            norm2 = 0.0
            for i in range(d):
                norm2 += V[i, c] * V[i, c]
            if norm2 > 0.25 * before:
                break
            before = norm2
        norm = math.sqrt(norm2)
        if not (norm > 0.0 and math.isfinite(norm)):
            return False
        R[c, c] = norm
        logs[c] += math.log(norm)
        for i in range(d):
            V[i, c] /= norm
    return True


@njit(cache=True)
def _tangent_product(ka, exact, ts, ys, f, Vs, p, J, yd, fd, W, out):
    """out = J(ts, ys) Vs (d × k): the exact Jacobian's product (``exact``), or column by
    column the forward difference (f(ys + ε v) − f(ys))/ε with f = f(ts, ys) given,
    ε = √eps·max(1, ‖ys‖)/‖v‖ (relative error ~1e-8; one evaluation of f per column).
    Returns the kernels' status (0: fine).  :func:`advance` writes the same lines out in
    its stage loop: numba compiles a called helper with its arrays' bookkeeping, which
    doubled the step's cost."""
    d, k = Vs.shape
    st = 0
    if exact:
        st = call_jacobian(ka[JACOBIAN], ts, ys, p, J)
        for i in range(d):
            for c in range(k):
                acc = 0.0
                for m in range(d):
                    acc += J[i, m] * Vs[m, c]
                out[i, c] = acc
        return st
    ynorm = 0.0
    for i in range(d):
        ynorm += ys[i] * ys[i]
    scale = 1.4901161193847656e-08 * max(1.0, math.sqrt(ynorm))
    for c in range(k):
        vnorm = 0.0
        for i in range(d):
            vnorm += Vs[i, c] * Vs[i, c]
        eps = scale / math.sqrt(vnorm) if vnorm > 0.0 else 1.0
        for i in range(d):
            yd[i] = ys[i] + eps * Vs[i, c]
        st += call_rhs(ka[RHS], ts, yd, p, fd, W)
        for i in range(d):
            out[i, c] = (fd[i] - f[i]) / eps
    return st


@njit(cache=True)
def advance(ka, exact, p, T, t_origin, stops, j0, j1, y, V, tv, rtol, atol, max_steps, A, B, C,
            E3, E5, logs, counts):
    """Advance the state ``y`` (d) and the orthonormal tangent basis ``V`` (d × k) from
    t = tv[0] over the intervals j0 … j1 − 1, interval j ending at t_origin + stops[j] T.

    ``tv`` = [t, h]: the time and the next step's size (0: choose a starting step),
    updated in place with ``y`` and ``V``, so a long run goes in several calls.
    ``logs[j, c]`` receives Σ log R_cc over interval j (the growth of column c, each
    step's QR); ``counts`` (3) accumulates accepted and rejected steps and evaluations.
    Returns the status (0: every interval done; else where it stopped in ``tv``).
    """
    d = y.shape[0]
    n = d // 2
    k = V.shape[1]
    W = np.zeros((n, n + 1))
    Ky = np.empty((13, d))
    KV = np.empty((13, d, k))
    J = np.empty((d, d))
    ys = np.empty(d)
    Vs = np.empty((d, k))
    ynew = np.empty(d)
    Vnew = np.empty((d, k))
    yd = np.empty(d)
    fd = np.empty(d)
    R = np.zeros((k, k))
    t = tv[0]
    h = tv[1]
    if call_rhs(ka[RHS], t, y, p, Ky[0], W) != 0:
        return SINGULAR
    if _tangent_product(ka, exact, t, y, Ky[0], V, p, J, yd, fd, W, KV[0]) != 0:
        return SINGULAR
    counts[EVALS] += 1 if exact else k + 1
    if h <= 0.0:
        h = starting_step(ka, t, y, Ky[0], p, rtol, atol, W, ys, ynew, 1.0 / 8.0)
        counts[EVALS] += 2
    h = min(h, 0.5 * T)
    ncomp = d * (k + 1)
    t_carry = 0.0
    for j in range(j0, j1):
        t_target = t_origin + stops[j] * T
        while t < t_target:
            if counts[STEPS] >= max_steps:
                tv[0] = t
                tv[1] = h
                return MAX_STEPS
            hmin = 16.0 * _EPS * max(abs(t), abs(t_target))
            rejected = False
            while True:
                clipped = False
                hs = h
                if t + hs >= t_target:
                    hs = t_target - t
                    clipped = True
                for s in range(1, 13):
                    if s < 12:
                        for i in range(d):
                            acc = 0.0
                            for m in range(s):
                                acc += A[s, m] * Ky[m, i]
                            ys[i] = y[i] + hs * acc
                        for i in range(d):
                            for c in range(k):
                                acc = 0.0
                                for m in range(s):
                                    acc += A[s, m] * KV[m, i, c]
                                Vs[i, c] = V[i, c] + hs * acc
                        ts = t + C[s] * hs
                    else:
                        for i in range(d):
                            acc = 0.0
                            for m in range(12):
                                acc += B[m] * Ky[m, i]
                            ynew[i] = y[i] + hs * acc
                            ys[i] = ynew[i]
                        for i in range(d):
                            for c in range(k):
                                acc = 0.0
                                for m in range(12):
                                    acc += B[m] * KV[m, i, c]
                                Vnew[i, c] = V[i, c] + hs * acc
                                Vs[i, c] = Vnew[i, c]
                        ts = t + hs
                    if call_rhs(ka[RHS], ts, ys, p, Ky[s], W) != 0:
                        tv[0] = t
                        tv[1] = h
                        return SINGULAR
                    # KV[s] = J(ts, ys) Vs: _tangent_product written out (see there)
                    st = 0
                    if exact:
                        st = call_jacobian(ka[JACOBIAN], ts, ys, p, J)
                        for i in range(d):
                            for c in range(k):
                                acc = 0.0
                                for m in range(d):
                                    acc += J[i, m] * Vs[m, c]
                                KV[s, i, c] = acc
                    else:
                        ynorm = 0.0
                        for i in range(d):
                            ynorm += ys[i] * ys[i]
                        scale = 1.4901161193847656e-08 * max(1.0, math.sqrt(ynorm))
                        for c in range(k):
                            vnorm = 0.0
                            for i in range(d):
                                vnorm += Vs[i, c] * Vs[i, c]
                            eps = scale / math.sqrt(vnorm) if vnorm > 0.0 else 1.0
                            for i in range(d):
                                yd[i] = ys[i] + eps * Vs[i, c]
                            st += call_rhs(ka[RHS], ts, yd, p, fd, W)
                            for i in range(d):
                                KV[s, i, c] = (fd[i] - Ky[s, i]) / eps
                    if st != 0:
                        tv[0] = t
                        tv[1] = h
                        return SINGULAR
                counts[EVALS] += 12 if exact else 12 * (k + 1)
                # the error of the 8th-order solution: DOP853's 5th- and 3rd-order
                # estimates over every component of y and V
                e5n = 0.0
                e3n = 0.0
                finite = True
                for i in range(d):
                    a5 = 0.0
                    a3 = 0.0
                    for m in range(13):
                        a5 += E5[m] * Ky[m, i]
                        a3 += E3[m] * Ky[m, i]
                    sc = atol + rtol * max(abs(y[i]), abs(ynew[i]))
                    e5n += (hs * a5 / sc) ** 2
                    e3n += (hs * a3 / sc) ** 2
                    if not math.isfinite(ynew[i]):
                        finite = False
                    for c in range(k):
                        a5 = 0.0
                        a3 = 0.0
                        for m in range(13):
                            a5 += E5[m] * KV[m, i, c]
                            a3 += E3[m] * KV[m, i, c]
                        sc = atol + rtol * max(abs(V[i, c]), abs(Vnew[i, c]))
                        e5n += (hs * a5 / sc) ** 2
                        e3n += (hs * a3 / sc) ** 2
                        if not math.isfinite(Vnew[i, c]):
                            finite = False
                if e5n == 0.0 and e3n == 0.0:
                    err = 0.0
                else:
                    err = e5n / math.sqrt((e5n + 0.01 * e3n) * ncomp)
                if not math.isfinite(err):
                    finite = False
                if finite and err < 1.0:
                    break
                counts[REJECTED] += 1
                h = hs * max(0.2, 0.9 * err ** (-1.0 / 8.0)) if finite else 0.2 * hs
                rejected = True
                if h < hmin:
                    tv[0] = t
                    tv[1] = h
                    return UNDERFLOW if finite else NON_FINITE
            counts[STEPS] += 1
            if not _orthonormalise(Vnew, R, logs[j]):
                tv[0] = t
                tv[1] = h
                return NON_FINITE
            # the next step's first stage (FSAL): f at the new state, and J Q = (J Vnew) R⁻¹
            # from the last stage's J Vnew (forward substitution over the columns)
            for i in range(d):
                y[i] = ynew[i]
                Ky[0, i] = Ky[12, i]
                for c in range(k):
                    V[i, c] = Vnew[i, c]
                    acc = KV[12, i, c]
                    for b in range(c):
                        acc -= KV[0, i, b] * R[b, c]
                    KV[0, i, c] = acc / R[c, c]
            if clipped:
                t = t_target
                t_carry = 0.0
            else:
                step = hs - t_carry
                t_new = t + step
                t_carry = (t_new - t) - step
                t = t_new
            factor = 10.0 if err == 0.0 else min(10.0, 0.9 * err ** (-1.0 / 8.0))
            if rejected:
                factor = min(1.0, factor)
            h = max(h, hs * factor) if clipped else hs * factor
            h = min(h, 0.5 * T)
    tv[0] = t
    tv[1] = h
    return FINISHED


def grid_largest(ka, exact, idx, Y0, P, T, T0, stops, v0, rtol, atol, max_steps, A, B, C, E3, E5,
                 LOGS, YF, TF, COUNTS, STATUS):
    """Every point ``idx[m]``: its trajectory from Y0[i] at T0[i] with one tangent vector
    (starting as the unit vector ``v0``) over the intervals ending at T0[i] + stops[j] T[i];
    LOGS[i, j] is the tangent's log growth over interval j (the largest exponent's sum),
    YF[i], TF[i] the state and time where it stopped, STATUS[i] how.

    On numba's thread count: the points in blocks, each block one GIL-free call of
    :func:`_grid_largest_rows` on a thread (:func:`lagrange_core._thread_blocks.run_rows`;
    a ``prange`` loop here cost 19 s of a fresh clone's suite in numba's parallel
    lowering, 2026-11-28)."""
    run_rows(_grid_largest_rows, idx.shape[0], ka, exact, idx, Y0, P, T, T0, stops, v0, rtol,
             atol, max_steps, A, B, C, E3, E5, LOGS, YF, TF, COUNTS, STATUS)


@njit(cache=True, nogil=True)
def _grid_largest_rows(ka, exact, idx, Y0, P, T, T0, stops, v0, rtol, atol, max_steps, A, B, C,
                       E3, E5, LOGS, YF, TF, COUNTS, STATUS, lo, hi):
    """The points idx[lo:hi] of :func:`grid_largest`, on the calling thread."""
    d = Y0.shape[1]
    nj = stops.shape[0]
    for m in range(lo, hi):
        i = idx[m]
        y = Y0[i].copy()
        V = np.empty((d, 1))
        for r in range(d):
            V[r, 0] = v0[r]
        tv = np.zeros(2)
        tv[0] = T0[i]
        STATUS[i] = advance(ka, exact, P[i], T[i], T0[i], stops, 0, nj, y, V, tv, rtol, atol,
                            max_steps, A, B, C, E3, E5, LOGS[i].reshape((nj, 1)), COUNTS[i])
        for r in range(d):
            YF[i, r] = y[r]
        TF[i] = tv[0]


# numba's cache does not notice changes to the slots and the starting step these call
from lagrange_core import _integrator_kernels, _kernel_calls  # noqa: E402
from lagrange_core.module_store import guard_numba_cache  # noqa: E402

guard_numba_cache(sys.modules[__name__], _integrator_kernels, _kernel_calls)


# a first call on the main thread compiles where Ctrl-C need not wait for it
from lagrange_core._first_calls import guard as _guard_first_calls  # noqa: E402

_guard_first_calls(__name__)
