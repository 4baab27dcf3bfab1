"""The compiled kernels of the Floquet analysis: J(t) sampled over a parameter grid, and
the monodromy of x′ = J(t) x by a Taylor series method, per grid point in parallel.

Compiled once for every system: the system's Jacobian is reached by address (its kernel
table, :mod:`lagrange_core._kernel_calls`, slot JACOBIAN), so no kernel here is compiled
per system.  The drivers (:mod:`kapitza.floquet._monodromy`) sample J with
:func:`floquet_sample_jacobian`, expand it in a trigonometric series, and integrate with
:func:`_monodromy_grid` in the balanced variables (q, dq/d(ωt)) over s = ωt ∈ [0, 2π].

How M is computed (and how accurate it is)
------------------------------------------
X′ = J(t) X is integrated over one period by a Taylor series method of order ``order``
(16): the Taylor coefficients of J follow exactly from its Fourier series, those of X from
the recurrence (m+1) X_(m+1) = Σ J_j X_(m−j), and each step is as long as the last two
series terms allow for the tolerance; their sum over the steps is the reported error
estimate (relative to max(1, ‖M‖)).  This "truncation order + step from the tolerance"
control is what makes grids fast: a handful of steps per period.  A reversible system (J
even in t with no velocity block: undamped, drive ∝ cos ωt) integrates only half a
period, M = P X(T/2)⁻¹ P X(T/2), P = diag(I, −I).  X is renormalised when it grows past
1e150 and the logarithm of the scale is kept, so multipliers of 1e100 or 1e1000 per
period are reported as log|λ| without overflow.

Every edit of this file recompiles its kernels (numba's cache is keyed by the file), and
a change of :mod:`lagrange_core._kernel_calls` flushes that cache too
(:func:`lagrange_core.module_store.guard_numba_cache`, at the end).
"""
from __future__ import annotations

import contextlib
import math
import sys

import numba
import numpy as np
from numba import njit, prange

from lagrange_core import _kernel_calls
from lagrange_core._kernel_calls import JACOBIAN, call_jacobian
from lagrange_core._linalg import solve_dense
from lagrange_core._thread_blocks import run_rows
from lagrange_core.module_store import guard_numba_cache

__all__ = ["SERIAL_BELOW", "floquet_sample_jacobian"]

# -- J(t) samples over a parameter grid (compiled once, for every system) ------------------

#: compiled calls over fewer grid points than this run on the calling thread alone.  Waking
#: numba's thread pool for a parallel loop costs 10–60 ms on a loaded machine (the loop
#: waits at its barrier for a descheduled worker) against 0.03–0.3 ms per point: that
#: wait, not the dimension, made one Floquet point of the triple pendulum cost 20–28 ms
#: and sometimes the double pendulum's too (issue 12.5; benchmarks/README.md)
SERIAL_BELOW = 256


@contextlib.contextmanager
def _threads_for(npts):
    """Run the parallel kernels called inside on one thread when ``npts`` is small."""
    if npts >= SERIAL_BELOW:
        yield
        return
    before = numba.get_num_threads()
    numba.set_num_threads(1)
    try:
        yield
    finally:
        numba.set_num_threads(before)


@njit(cache=True, parallel=True)
def floquet_sample_jacobian(ka, P, ystar, T, n_samples, out, status):
    """out[i, k] = J(k T[i] / n_samples, ystar, P[i]) for every grid point i; ``ka`` is the
    system's kernel-address table (:mod:`lagrange_core._kernel_calls`, slot JACOBIAN)."""
    npts = P.shape[0]
    d = ystar.size
    for i in prange(npts):
        J = np.empty((d, d))
        st = 0
        for k in range(n_samples):
            st = max(st, call_jacobian(ka[JACOBIAN], k * T[i] / n_samples, ystar, P[i], J))
            for r in range(d):
                for c in range(d):
                    out[i, k, r, c] = J[r, c]
        status[i] = st


# -- monodromy from the Fourier series of the lower block L(t) = [J_q, J_v] ------------

@njit(cache=True)
def _taylor_period(C, S, K, omega, t_end, tol, order, X, work, coef, reversible):
    """X = fundamental matrix at t_end by a Taylor series method.

    Returns (log scale, error estimate, steps).  At each step t0 the Taylor
    coefficients of L(t0 + τ) = C0 + Σ_k C_k cos kω(t0+τ) + S_k sin kω(t0+τ) are
    exact, and those of X follow from (m+1) X_(m+1) = Σ_j J_j X_(m−j); the
    harmonic sums are formed first (Y_k = Σ_j c_jk X_(m−j)) so each order costs
    one small product per harmonic.  The step h is chosen from the last two
    coefficients so that their terms ‖X_m‖ h^m stay below tol/10 relative to
    ‖X(t0)‖ (Jorba & Zou, Exp. Math. 14 (2005) 99); the sum of these tail terms
    over the steps is the returned error estimate.  ``reversible``: no sine
    terms and no velocity block (only the position rows of X enter).
    """
    d = X.shape[0]
    n = d // 2
    p = order
    nc = n if reversible else d          # columns of L that can be non-zero
    Y = np.empty((nc, d))
    L0 = np.empty((n, d))
    for r in range(d):
        for c in range(d):
            X[r, c] = 1.0 if r == c else 0.0
    logscale = 0.0
    err = 0.0
    t0 = 0.0
    nsteps = 0
    while t0 < t_end * (1.0 - 1e-15):
        nsteps += 1
        # coef[k, m, 0/1]: Taylor coefficient m of cos / sin (kω(t0 + τ)); L0 = L(t0)
        for r in range(n):
            for c in range(d):
                L0[r, c] = C[0, r, c]
        for k in range(1, K + 1):
            u = k * omega
            cph = math.cos(u * t0)
            sph = math.sin(u * t0)
            f = 1.0
            for m in range(p + 1):
                if m > 0:
                    f *= u / m
                q = m % 4
                # d^m/dτ^m of cos and sin cycle with period 4 in m
                cm = cph if q == 0 else (-sph if q == 1 else (-cph if q == 2 else sph))
                sm = sph if q == 0 else (cph if q == 1 else (-sph if q == 2 else -cph))
                coef[k, m, 0] = f * cm
                coef[k, m, 1] = f * sm
            for r in range(n):
                for c in range(d):
                    L0[r, c] += C[k, r, c] * cph + S[k, r, c] * sph
        for r in range(d):
            for c in range(d):
                work[0, r, c] = X[r, c]
        for m in range(p):
            inv = 1.0 / (m + 1)
            for r in range(n):
                for c in range(d):
                    work[m + 1, r, c] = work[m, n + r, c] * inv
                    s = 0.0
                    for k2 in range(nc):
                        s += L0[r, k2] * work[m, k2, c]
                    work[m + 1, n + r, c] = s
            for k in range(1, K + 1):
                for part in range(1 if reversible else 2):
                    for r in range(nc):
                        for c in range(d):
                            Y[r, c] = 0.0
                    for j in range(1, m + 1):
                        cj = coef[k, j, part]
                        for r in range(nc):
                            for c in range(d):
                                Y[r, c] += cj * work[m - j, r, c]
                    for r in range(n):
                        for c in range(d):
                            s = 0.0
                            for k2 in range(nc):
                                s += (C[k, r, k2] if part == 0 else S[k, r, k2]) * Y[k2, c]
                            work[m + 1, n + r, c] += s
            for r in range(n):
                for c in range(d):
                    work[m + 1, n + r, c] *= inv
        ref = 0.0
        a1 = 0.0
        a2 = 0.0
        for r in range(d):
            for c in range(d):
                ref = max(ref, abs(X[r, c]))
                a1 = max(a1, abs(work[p - 1, r, c]))
                a2 = max(a2, abs(work[p, r, c]))
        target = 0.1 * tol * ref
        h = t_end - t0
        if a1 > 0.0:
            h = min(h, (target / a1) ** (1.0 / (p - 1)))
        if a2 > 0.0:
            h = min(h, (target / a2) ** (1.0 / p))
        # Horner: X(t0 + h) = Σ X_m h^m
        for r in range(d):
            for c in range(d):
                s = work[p, r, c]
                for m in range(p - 1, -1, -1):
                    s = s * h + work[m, r, c]
                X[r, c] = s
        err += (a1 * h ** (p - 1) + a2 * h ** p) / max(ref, 1e-300)
        t0 += h
        big = 0.0
        for r in range(d):
            for c in range(d):
                big = max(big, abs(X[r, c]))
        if big > 1e150:
            for r in range(d):
                for c in range(d):
                    X[r, c] /= big
            logscale += math.log(big)
    return logscale, err, nsteps


@njit(cache=True)
def _period_map(C, S, K, omega, T, tol, order, X, work, coef, half):
    """Monodromy into X by the Taylor method; returns (log scale, error estimate).

    ``half``: J is even in t and has no velocity block (a reversible undamped
    system), so X(−t) = P X(t) P with P = diag(I, −I) and M = P X(T/2)⁻¹ P X(T/2):
    half the integration (not used when X(T/2) is ill-conditioned, ‖X‖‖X⁻¹‖ > 1e3,
    where the error bound 2·err·‖X‖‖X⁻¹‖ would spoil the estimate).
    """
    d = X.shape[0]
    n = d // 2
    if half:
        # (np.bool_, not a bare True/False: numba types a constant argument as a literal,
        # and compiled _taylor_period twice, once for each, 2.5 s each on an empty cache)
        ls, err, ns = _taylor_period(C, S, K, omega, 0.5 * T, tol, order, X, work, coef,
                                     np.bool_(True))
        nx = 0.0
        for r in range(d):
            for c in range(d):
                nx = max(nx, abs(X[r, c]))
        # det X = 1 here, so ‖X‖‖X⁻¹‖ ≥ ‖X‖/d: a large X is ill-conditioned, and inverting a
        # numerically singular one raised LinAlgError from inside the compiled loop
        if ls == 0.0 and nx < 1e3:
            # [X | I | P X] → [· | X⁻¹ | X⁻¹ P X] by elimination with partial pivoting, no
            # LAPACK call (numba's np.linalg.inv and @ cost 1.2 s of the first compile); a
            # singular X says so (1) and the full period is integrated instead
            W = np.zeros((d, 3 * d))
            for r in range(d):
                for c in range(d):
                    W[r, c] = X[r, c]
                    W[r, 2 * d + c] = -X[r, c] if r >= n else X[r, c]
                W[r, d + r] = 1.0
            if solve_dense(W, d) == 0:
                ni = 0.0
                for r in range(d):
                    for c in range(d):
                        ni = max(ni, abs(W[r, d + c]))
                if nx * ni < 1e3:
                    for r in range(d):
                        for c in range(d):
                            X[r, c] = -W[r, 2 * d + c] if r >= n else W[r, 2 * d + c]
                    # M = P X⁻¹ P X: relative errors of X enter twice, amplified by the
                    # condition
                    return 0.0, 2.0 * err * max(1.0, nx * ni), 2 * ns
        # strong growth: X(T/2) too ill-conditioned to invert, integrate the full period
    return _taylor_period(C, S, K, omega, T, tol, order, X, work, coef, np.bool_(False))


@njit(cache=True, nogil=True)
def _monodromy_rows(C, S, K, omega, T, tol, order, half, M, logscale, error, steps, lo, hi):
    """Monodromy to tolerance for the grid points lo … hi − 1 (Taylor method, see
    _taylor_period), on the calling thread, without the GIL."""
    d = M.shape[1]
    work = np.empty((order + 1, d, d))
    coef = np.empty((K + 1, order + 1, 2))
    X = np.empty((d, d))
    for i in range(lo, hi):
        ls, err, ns = _period_map(C[i], S[i], K, omega[i], T[i], tol, order, X, work, coef, half)
        # element by element: an array copied into a slice makes numba compile its
        # shape-mismatch message (f-strings), ~2 s in each process that compiles it
        for r in range(d):
            for c in range(d):
                M[i, r, c] = X[r, c]
        logscale[i] = ls
        error[i] = err
        steps[i] = ns


def _monodromy_grid(C, S, K, omega, T, tol, order, half, M, logscale, error, steps):
    """Monodromy to tolerance for every grid point, on numba's thread count: the points in
    blocks, each block one GIL-free call of :func:`_monodromy_rows` on a thread
    (:func:`lagrange_core._thread_blocks.run_rows`; a ``prange`` loop here cost 11 s
    of the cold compile in numba's parallel lowering)."""
    # 4 blocks per thread: the points' costs differ (steps per period), the pool balances
    run_rows(_monodromy_rows, C.shape[0], C, S, K, omega, T, tol, order, half, M, logscale,
             error, steps)


# numba's cache does not notice a change of the kernel slots the sampler calls
guard_numba_cache(sys.modules[__name__], _kernel_calls)


# a first call on the main thread compiles where Ctrl-C need not wait for it
from lagrange_core._first_calls import guard as _guard_first_calls  # noqa: E402

_guard_first_calls(__name__)
