"""Floquet analysis of a lagrange_core system linearised about a driven equilibrium.

The linear time-periodic system
-------------------------------
Let y* = [q*, 0] be a state that persists under the drive (q̈ = 0 with q̇ = 0 at
all t, e.g. the inverted pendulum θ = π).  Small deviations obey

    x′ = J(t) x,    J(t) = ∂(dy/dt)/∂y at (t, y*),    J(t + T) = J(t),

with J from the system's exact compiled ``jacobian`` kernel (no finite
differences) and T = 2π/ω the drive period.  For a mechanical system J has the
block form [[0, I], [J_q(t), J_v(t)]]; the monodromy M = X(T) (X′ = J X,
X(0) = I, 2n × 2n) decides stability: the equilibrium is (linearly,
asymptotically) stable when every multiplier λ (eigenvalue of M) has |λ| < 1,
and, for an undamped system, when all lie on the unit circle.

How M is computed (and how accurate it is)
------------------------------------------
1. J is sampled at equally spaced times of one period with the system's kernel
   (reached by address from a loop over the parameter grid compiled once for
   every system) and expanded in a trigonometric series.  The harmonic content is
   probed at a few grid points with 16, 32, ... samples until the upper half
   of the spectrum is at rounding level; every point is then sampled with the
   fewest samples that carry it (4 for a pivot drive A cos ωt, where J is
   exactly affine in cos ωt) and its Nyquist harmonic re-checked.
2. X′ = J(t) X is integrated over one period by a Taylor series method of
   order ``order`` (16): the Taylor coefficients of J follow exactly from its
   Fourier series, those of X from the recurrence (m+1) X_(m+1) = Σ J_j X_(m−j),
   and each step is as long as the last two series terms allow for the
   tolerance; their sum over the steps is the reported error estimate
   (relative to max(1, ‖M‖) in the balanced variables (q, dq/d(ωt)), in which
   the integration runs over s = ωt ∈ [0, 2π]).  This "truncation order + step from the
   tolerance" control is what makes grids fast: a handful of steps per period.
   A reversible system (J even in t with no velocity block: undamped, drive
   ∝ cos ωt) integrates only half a period, M = P X(T/2)⁻¹ P X(T/2),
   P = diag(I, −I).
3. X is renormalised when it grows past 1e150 and the logarithm of the scale
   is kept, so multipliers of 1e100 or 1e1000 per period are reported as
   log|λ| without overflow.

Accuracy guards
---------------
* Liouville: det M = exp(∮ tr J dt) (tr J = −γ for the damped pendulum, so
  det M = e^(−γT)); ∮ tr J dt is exact from the Fourier mean of J.
* Undamped (∮ tr J dt = 0) Lagrangian systems have a symplectic monodromy: the
  characteristic polynomial is palindromic (multipliers in pairs λ, 1/λ).
A result whose residual exceeds ``guard_tol`` (or, for very large growth, the
rounding floor ≈ 1e-13·max|λ|/min|λ|) is flagged in ``FloquetResult.flags``.
A point that would need more than ``MAX_STEPS_PER_PERIOD`` Taylor steps (ω → 0, a
huge amplitude against a slow drive) is not integrated: it is reported unstable with
the frozen-time estimate log|λ| ≈ ∮ max(0, max Re eig J(t)) dt and a flag (stability
"undecided" when that estimate is small), so one such point never aborts a grid.

Entry points and results
------------------------
:func:`floquet_point` (one parameter set → :class:`~kapitza.results.FloquetResult`),
:func:`floquet_grid` (a broadcast grid → :class:`~kapitza.results.FloquetGrid`),
:func:`stability_map` (an (A, ω) grid → :class:`~kapitza.results.StabilityMap`) and
:func:`monodromy_data` (the matrices only → :class:`~kapitza.results.MonodromyData`).
Where stability changes, exactly (:mod:`kapitza.floquet_boundaries`: roots of smooth
margins such as det(M ∓ I), not bisection on the flag): :func:`window` (the stabilising
amplitudes per ω, certified edges → :class:`~kapitza.results.StabilityWindow`),
:func:`boundaries` (the curves A_k(ω) by continuation →
:class:`~kapitza.results.BoundaryCurves`) and :func:`adaptive_map` (a map refined only
where the classification changes → :class:`~kapitza.results.AdaptiveMap`).
Grids of fewer than :data:`SERIAL_BELOW` points run on the calling thread.
The single pendulum's maps and windows go through the Mathieu equation instead
(:mod:`kapitza.mathieu`), which is faster and exact to rounding.

Examples
--------
The inverted pendulum (l = 1 m) shaken vertically with A = 5 cm at 60 Hz is stable;
its exact slow frequency is within 0.2 % of the averaging value √(A²ω²/2 − g/l):

>>> import math
>>> from lagrange_core import problems
>>> w = 2 * math.pi * 60
>>> r = floquet_point(problems.driven_pendulum("vertical"),
...                   dict(m=1.0, l=1.0, g=9.81, A=0.05, omega=w), [math.pi])
>>> r.stable, r.boundary, r.flags
(True, 'stable', ())
>>> print(f"Ω = {r.omega_slow:.2f} rad/s, averaging {math.sqrt((0.05 * w)**2 / 2 - 9.81):.2f} rad/s")
Ω = 12.98 rad/s, averaging 12.96 rad/s
"""
from __future__ import annotations

import contextlib
import math
import sys
import time
from collections.abc import Mapping

import numba
import numpy as np
from numba import njit, prange

from lagrange_core import _kernel_calls
from lagrange_core._kernel_calls import JACOBIAN, call_jacobian
from lagrange_core.module_store import guard_numba_cache
from lagrange_core.progress import ProgressLine as _ProgressLine  # noqa: F401
from lagrange_core.progress import _SIGINT, run_in_chunks  # noqa: F401
from lagrange_core.progress import defer_ctrl_c as _defer_ctrl_c

from .. import _arguments as arguments
from ._boundaries import KINDS, first_window, refine_map, trace_curves
from ._boundaries import poly_eval as _poly_eval
from ._boundaries import reduced_polynomial as _reduced_polynomial
from ..results import (AdaptiveMap, BoundaryCurves, ComputationInterrupted, FloquetGrid,
                      FloquetResult, MonodromyData, StabilityMap, StabilityWindow)

__all__ = ["floquet_point", "floquet_grid", "stability_map", "monodromy_data", "window",
           "boundaries", "adaptive_map", "FloquetResult", "FloquetGrid", "MonodromyData",
           "StabilityMap", "StabilityWindow", "BoundaryCurves", "AdaptiveMap",
           "ComputationInterrupted"]

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
        ls, err, ns = _taylor_period(C, S, K, omega, 0.5 * T, tol, order, X, work, coef, True)
        nx = 0.0
        for r in range(d):
            for c in range(d):
                nx = max(nx, abs(X[r, c]))
        # det X = 1 here, so ‖X‖‖X⁻¹‖ ≥ ‖X‖/d: a large X is ill-conditioned, and inverting a
        # numerically singular one raised LinAlgError from inside the compiled loop
        if ls == 0.0 and nx < 1e3:
            PX = X.copy()
            for r in range(n, d):
                for c in range(d):
                    PX[r, c] = -PX[r, c]
            Xinv = np.linalg.inv(X)
            ni = 0.0
            for r in range(d):
                for c in range(d):
                    ni = max(ni, abs(Xinv[r, c]))
            if nx * ni < 1e3:
                Y = Xinv @ PX
                for r in range(d):
                    for c in range(d):
                        X[r, c] = -Y[r, c] if r >= n else Y[r, c]
                # M = P X⁻¹ P X: relative errors of X enter twice, amplified by the condition
                return 0.0, 2.0 * err * max(1.0, nx * ni), 2 * ns
        # strong growth: X(T/2) too ill-conditioned to invert, integrate the full period
    return _taylor_period(C, S, K, omega, T, tol, order, X, work, coef, False)


@njit(cache=True, parallel=True)
def _monodromy_grid(C, S, K, omega, T, tol, order, half, M, logscale, error, steps):
    """Monodromy to tolerance for every grid point (Taylor method, see _taylor_period)."""
    npts = C.shape[0]
    d = M.shape[1]
    for i in prange(npts):
        work = np.empty((order + 1, d, d))
        coef = np.empty((K + 1, order + 1, 2))
        X = np.empty((d, d))
        ls, err, ns = _period_map(C[i], S[i], K, omega[i], T[i], tol, order, X, work, coef, half)
        M[i] = X
        logscale[i] = ls
        error[i] = err
        steps[i] = ns


# -- drivers ---------------------------------------------------------------------------

def _check_system(system):
    if system.n_constraints:
        raise ValueError(
            f"Floquet analysis needs independent coordinates; {system!r} has "
            f"{system.n_constraints} constraint(s). State it in minimal coordinates.")


def _equilibrium_state(system, about):
    if about is None:
        raise ValueError("pass the driven equilibrium as `about` (coordinates, e.g. "
                         "{'theta': np.pi}); velocities are zero.")
    q = system.coordinate_array(about, "about")
    return np.concatenate([q, np.zeros(system.n_dof)])


def _check_persists(system, kernels, P, ystar, T, idx):
    """Raise unless q̈ = 0 at y* through the period (checked at a few grid points)."""
    n = system.n_dof
    dydt = np.empty(2 * n)
    W = kernels.work_array()
    J = np.empty((2 * n, 2 * n))
    for i in idx:
        for k in range(8):
            t = k * T[i] / 8
            kernels.rhs(t, ystar, P[i], dydt, W)
            kernels.jacobian(t, ystar, P[i], J)
            scale = max(1.0, float(np.max(np.abs(J))))
            if not np.all(np.abs(dydt) <= 1e-9 * scale):
                raise ValueError(
                    f"the state q = {ystar[:n].tolist()} does not persist under the drive: q̈ = "
                    f"{dydt[n:].tolist()} at t = {t:.4g} s. Floquet analysis here needs an "
                    "equilibrium of the driven system (e.g. the inverted pendulum θ = π for a "
                    "vertical drive); for a state that moves with the drive (a horizontal or "
                    "elliptic pivot) use kapitza.periodic_orbit(system, params, guess), which "
                    "finds the periodic orbit and its multipliers.")


class _Stopped(Exception):
    """Ctrl-C while J(t) was sampled: no grid point is finished."""


def _sample(ka, P, ystar, T, M, progress=False):
    """FFT over one period of M samples of J's lower block, its scale, and its tail.

    Runs in chunks (:func:`run_in_chunks`; sampling and FFT per chunk); raises
    :class:`_Stopped` after Ctrl-C."""
    npts = P.shape[0]
    d = ystar.size
    n = d // 2
    F = np.empty((npts, M // 2 + 1, n, d), dtype=complex)
    scale = np.empty(npts)
    tail = np.empty(npts)

    def work(a, b):
        out = np.empty((b - a, M, d, d))
        status = np.zeros(b - a, dtype=np.int64)
        with _threads_for(b - a):
            floquet_sample_jacobian(ka, P[a:b], ystar, T[a:b], M, out, status)
        if np.any(status != 0):
            bad = a + int(np.argmax(status != 0))
            raise ValueError(f"the mass matrix is singular at the equilibrium for parameters "
                             f"{P[bad].tolist()}; cannot linearise there.")
        top = out[:, :, :n, :]
        if not (np.all(top[:, :, :, :n] == 0.0) and np.all(top[:, :, :, n:] == np.eye(n))):
            raise ValueError("the Jacobian does not have the mechanical block form "
                             "[[0, I], ...].")
        L = out[:, :, n:, :]
        F[a:b] = np.fft.rfft(L, axis=1) / M
        scale[a:b] = np.maximum(np.max(np.abs(L), axis=(1, 2, 3)), 1e-300)
        # harmonics above M/4 (with the Nyquist one) measure the aliasing of what lies beyond
        tail[a:b] = np.max(np.abs(F[a:b, M // 4 + 1:]), axis=(1, 2, 3)) / scale[a:b]

    _, stopped = run_in_chunks(work, npts, progress=progress,
                               label="Floquet grid: sampling J(t)")
    if stopped:
        raise _Stopped
    return F, scale, tail


def _sample_fourier(ka, P, ystar, T, tol, max_samples=256, progress=False, samples=None):
    """Fourier coefficients (C, S) of J's lower block L(t) for every grid point.

    ``samples``: the samples per period to start from (a plan made for the same system
    on another grid); without it a few probe points decide."""
    npts = P.shape[0]
    thr = max(tol, 1e-13) * 1e-2
    if samples is None:
        probe = np.array(sorted({0, npts // 3, npts // 2, (2 * npts) // 3, npts - 1}))
        M = 16
        while True:
            F, scale, tail = _sample(ka, P[probe], ystar, T[probe], M)
            if np.all(tail <= thr) or M >= max_samples:
                break
            M *= 2
        mags = np.max(np.abs(F[:, 1:]), axis=(0, 2, 3)) / np.max(scale)
        keep = np.nonzero(mags > 1e-15)[0]
        K = int(keep[-1]) + 1 if keep.size else 0
        M = max(4, 1 << int(math.ceil(math.log2(2 * K + 2))))
    else:
        M = samples
    while True:
        F, scale, tail = _sample(ka, P, ystar, T, M, progress)
        if np.all(tail <= thr) or M >= max_samples:
            break
        M *= 2
    K = max(1, M // 4)
    n, d = F.shape[2], F.shape[3]
    C = np.empty((npts, K + 1, n, d))
    S = np.empty((npts, K + 1, n, d))
    C[:, 0] = F[:, 0].real
    S[:, 0] = 0.0
    C[:, 1:] = 2.0 * F[:, 1:K + 1].real
    S[:, 1:] = -2.0 * F[:, 1:K + 1].imag
    return np.ascontiguousarray(C), np.ascontiguousarray(S), K, M, float(np.max(tail))


def _prepare(system, params, about, frequency, tol, progress=False, *, samples=None):
    """Validate, broadcast the parameter grid, and sample J's Fourier series.

    ``samples``: a sampling plan from an earlier grid of the same system and
    equilibrium, whose persistence was checked then (:class:`_Probe`).
    After Ctrl-C during the sampling, the dict has ``stopped`` True and no series."""
    _check_system(system)
    if isinstance(tol, bool) or not isinstance(tol, (int, float)) or not (1e-15 <= tol < 1):
        raise ValueError(f"tol must be a number in [1e-15, 1), got {tol!r}.")
    if frequency not in system.parameters:
        raise ValueError(f"the drive frequency parameter {frequency!r} is not a parameter of "
                         f"{system!r}; pass frequency=<name>.")
    names = system.parameters
    unknown = sorted(set(params) - set(names))
    missing = [n for n in names if n not in params]
    if unknown or missing:
        raise ValueError(f"the parameters of {system!r} are {list(names)}; unknown {unknown}, "
                         f"missing {missing}.")
    arrays = np.broadcast_arrays(*[np.asarray(params[n], dtype=float) for n in names])
    shape = arrays[0].shape
    grid_params = dict(zip(names, arrays))
    P = np.ascontiguousarray(np.stack([a.ravel() for a in arrays], axis=1))
    if not np.all(np.isfinite(P)):
        raise ValueError("parameter values must be finite.")
    omega = P[:, names.index(frequency)].copy()
    if np.any(omega <= 0):
        raise ValueError(f"the drive frequency {frequency!r} must be > 0 (rad/s).")
    T = 2 * np.pi / omega
    ystar = _equilibrium_state(system, about)
    return _series(system, P, ystar, omega, T, shape, grid_params, tol, progress, samples)


def _series(system, P, ystar, omega, T, shape, grid_params, tol, progress=False,
            samples=None):
    """:func:`_prepare` after the validation: J's Fourier series over the rows of P."""
    kernels = system.kernels
    npts = P.shape[0]
    n = system.n_dof
    if npts == 0:
        # an empty grid: nothing to sample (the results have the empty broadcast shape)
        C = np.zeros((0, 2, n, 2 * n))
        S, K, samples, alias = C.copy(), 1, 0, 0.0
    else:
        if samples is None:
            _check_persists(system, kernels, P, ystar, T, sorted({0, npts // 2, npts - 1}))
        try:
            C, S, K, samples, alias = _sample_fourier(kernels.addresses("jacobian"), P, ystar,
                                                      T, tol, progress=progress,
                                                      samples=samples)
        except _Stopped:
            return dict(omega=omega, T=T, shape=shape, n=n, params=grid_params, samples=0,
                        liouville=np.full(npts, np.nan), stopped=True)
    # reversible: J even in t (no sine terms) and no velocity block, to rounding of the FFT
    big = np.max(np.abs(C), axis=(1, 2, 3))[:, None, None, None]
    half = bool(np.all(np.abs(S) <= 1e-13 * big) and np.all(np.abs(C[:, :, :, n:]) <= 1e-13 * big))
    if half:
        S = np.zeros_like(S)
        C[:, :, :, n:] = 0.0
    return dict(C=C, S=S, K=K, samples=samples, alias=alias, omega=omega, T=T, shape=shape,
                n=n, half=half, params=grid_params, stopped=False,
                # ∮ tr J dt = T · tr(mean of J_v): the harmonics integrate to zero
                liouville=T * np.trace(C[:, 0, :, n:], axis1=1, axis2=2))


#: Taylor steps per period ≈ 4 √‖J_b‖ (balanced variables, see _integrate); beyond this many
#: (slow drives of a stiff system, huge amplitudes, ω → 0) a point is not integrated: its
#: growth is the frozen-time estimate of :func:`_frozen_growth`, and it is flagged
MAX_STEPS_PER_PERIOD = 200_000


def _balanced(prep, idx):
    """J's lower block in the balanced variables (q, dq/ds), s = ωt: [L_q/ω², L_v/ω]."""
    n = prep["n"]
    om = prep["omega"][idx]
    C = prep["C"][idx].copy()
    S = prep["S"][idx].copy()
    with np.errstate(over="ignore", divide="ignore", invalid="ignore"):
        for X in (C, S):
            X[:, :, :, :n] /= om[:, None, None, None] ** 2
            X[:, :, :, n:] /= om[:, None, None, None]
    return C, S


def _step_count(C, S):
    """The Taylor steps one period would take, ≈ 4 √(Σ_k ‖C_k‖ + ‖S_k‖) (inf if not finite)."""
    norm = np.sum(np.max(np.abs(C), axis=(2, 3)) + np.max(np.abs(S), axis=(2, 3)), axis=1)
    with np.errstate(invalid="ignore"):
        return np.where(np.isfinite(norm), 4.0 * np.sqrt(norm) + 4.0, np.inf)


def _frozen_growth(prep, idx, samples=256):
    """Frozen-time (adiabatic, WKB-order) estimate of log|λ|max per period, and whether the
    dominant frozen eigenvalue is real.

    log|λ| ≈ ∫₀ᵀ max(0, max Re eig J(t)) dt, with J(t) from its Fourier series at
    ``samples`` times: exact to leading order when J changes slowly against its own
    rates (slow drives) or the growth is large (huge amplitudes, WKB); its relative
    error is O(1/log|λ|), so it decides instability only when it is large.
    """
    n = prep["n"]
    C, S, T = prep["C"][idx], prep["S"][idx], prep["T"][idx]
    K = C.shape[1] - 1
    ph = 2 * np.pi * np.arange(samples) / samples
    k = np.arange(K + 1)
    cos_, sin_ = np.cos(np.outer(ph, k)), np.sin(np.outer(ph, k))
    L = np.einsum("jk,ikrc->ijrc", cos_, C) + np.einsum("jk,ikrc->ijrc", sin_, S)
    J = np.zeros(L.shape[:2] + (2 * n, 2 * n))
    J[:, :, :n, n:] = np.eye(n)
    J[:, :, n:, :] = L
    with np.errstate(over="ignore", invalid="ignore"):
        ev = np.linalg.eigvals(np.where(np.isfinite(J), J, 0.0))
        top = np.argmax(ev.real, axis=2)
        lead = np.take_along_axis(ev, top[:, :, None], axis=2)[:, :, 0]
        rate = np.maximum(lead.real, 0.0)
        growth = T * np.mean(rate, axis=1)
        real = np.abs(lead.imag[np.arange(len(idx)), np.argmax(rate, axis=1)]) == 0.0
    return growth, real


def _integrate(prep, idx, tol, order, progress=False):
    """Monodromies of the grid points ``idx`` (flat indices) to ``tol``.

    Returns (M scaled, log scale, error estimate, steps, skipped, finished, stopped): points
    that would need more than :data:`MAX_STEPS_PER_PERIOD` Taylor steps are not
    integrated (skipped; M = NaN, error = inf, steps = 0); the points run in chunks
    (:func:`run_in_chunks`, ``progress``), and after Ctrl-C ``finished`` marks those
    done (the others as skipped, with ``finished`` False).
    """
    d = 2 * prep["n"]
    n = prep["n"]
    m = idx.size
    # balanced variables (q, dq/ds), s = ωt: J_b = [[0, I], [L_q/ω², L_v/ω]], period 2π;
    # then M = D⁻¹ M_b D with D = diag(I, I/ω), and errors are relative to a balanced norm
    om = prep["omega"][idx]
    C, S = _balanced(prep, idx)
    skipped = ~(_step_count(C, S) <= MAX_STEPS_PER_PERIOD)
    finished = np.ones(m, dtype=bool)
    Mout = np.full((m, d, d), np.nan)
    logscale = np.zeros(m)
    err = np.full(m, np.inf)
    steps = np.zeros(m, dtype=np.int64)
    run = np.nonzero(~skipped)[0]
    stopped = False
    if run.size:
        Cr, Sr = np.ascontiguousarray(C[run]), np.ascontiguousarray(S[run])
        Mr = np.full((run.size, d, d), np.nan)
        lr = np.zeros(run.size)
        er = np.full(run.size, np.inf)
        sr = np.zeros(run.size, dtype=np.int64)
        one, two_pi = np.ones(run.size), np.full(run.size, 2 * np.pi)

        def work(a, b):
            # reversible (J even in t, no velocity block): integrate half a period
            with _threads_for(b - a):
                _monodromy_grid(Cr[a:b], Sr[a:b], prep["K"], one[a:b], two_pi[a:b],
                                float(tol), int(order), prep["half"], Mr[a:b], lr[a:b],
                                er[a:b], sr[a:b])

        done, stopped = run_in_chunks(work, run.size, progress=progress,
                                      label="Floquet grid")
        finished[run[done:]] = False
        skipped[run[done:]] = True
        Mr[done:] = np.nan
        Mr[:, n:, :] *= om[run, None, None]
        Mr[:, :, n:] /= om[run, None, None]
        Mout[run], logscale[run], err[run], steps[run] = Mr, lr, np.maximum(er, prep["alias"]), sr
        err[run[done:]] = np.inf
        steps[run[done:]] = 0
    return Mout, logscale, err, steps, skipped, finished, stopped


def _monodromy_fields(prep, Ms, ls, err, steps) -> dict:
    """The :class:`~kapitza.results.MonodromyData` fields, reshaped to the grid."""
    shape = prep["shape"]
    return dict(params=prep["params"], monodromy_scaled=Ms.reshape(shape + Ms.shape[1:]),
                log_scale=ls.reshape(shape), error_estimate=err.reshape(shape),
                steps=steps.reshape(shape), samples=int(prep["samples"]),
                period=prep["T"].reshape(shape),
                liouville_exponent=prep["liouville"].reshape(shape))


def monodromy_data(system, params, about, *, frequency="omega", tol=1e-10,
                   order=16, progress=None) -> MonodromyData:
    """Monodromy matrices for a broadcast grid of parameter sets.

    Parameters
    ----------
    system : lagrange_core.System
        Unconstrained; its drive has angular frequency ``params[frequency]``.
    params : dict
        Parameter values by name; scalars or arrays (broadcast together).
    about : sequence or dict
        The equilibrium's coordinates q* (velocities zero).
    tol : float
        Target error of M relative to max(1, ‖M‖).
    progress : None, bool or callable
        As for :func:`floquet_grid` (points not reached before Ctrl-C, and points
        that would need more than ``MAX_STEPS_PER_PERIOD`` Taylor steps, have M = NaN
        and error_estimate = inf).

    Returns
    -------
    kapitza.results.MonodromyData
        ``monodromy_scaled`` (M = e^log_scale · this, grid shape + (2n, 2n)),
        ``log_scale``, ``error_estimate``, ``steps``, ``samples``, ``period``,
        ``liouville_exponent`` (∮ tr J dt); ``.monodromy``, ``.shape``.

    Examples
    --------
    Liouville's formula for the damped pendulum: det M = e^(−γT).

    >>> import math
    >>> import numpy as np
    >>> from lagrange_core import problems
    >>> data = monodromy_data(problems.driven_pendulum("vertical", damping=True),
    ...                       dict(m=1.0, l=1.0, g=9.81, A=0.1, omega=[40.0, 60.0], gamma=0.5),
    ...                       [math.pi])
    >>> data.shape
    (2,)
    >>> bool(np.allclose(np.linalg.det(data.monodromy), np.exp(-0.5 * data.period), rtol=1e-9))
    True
    """
    with _defer_ctrl_c():
        prep = _prepare(system, params, about, frequency, tol, progress)
        if prep["stopped"]:
            data = MonodromyData(**_monodromy_fields(prep, *_nothing(prep)))
            raise ComputationInterrupted(data, np.zeros(prep["shape"], dtype=bool))
        Mout, ls, err, steps, _, fin, stopped = _integrate(prep, np.arange(prep["T"].size), tol,
                                                           order, progress)
        data = MonodromyData(**_monodromy_fields(prep, Mout, ls, err, steps))
        if stopped or _SIGINT["hit"] or not fin.all():
            raise ComputationInterrupted(data, fin.reshape(prep["shape"]))
        return data


#: seconds spent analysing the integrated points after Ctrl-C stopped the integration (the
#: others keep their monodromy in the result but count as not computed)
_AFTER_CTRL_C = 0.5


def _nothing(prep):
    """Monodromy fields (M, log scale, error, steps) of a grid of which nothing was
    computed (Ctrl-C while J was sampled): NaN, 0, inf, 0."""
    m, d = prep["T"].size, 2 * prep["n"]
    return (np.full((m, d, d), np.nan), np.zeros(m), np.full(m, np.inf),
            np.zeros(m, dtype=np.int64))


def _reduced_decision(qc, x, rel_err, norm):
    """Stability and its margin from the reduced polynomial Q(x) (:func:`_reduced_polynomial`).

    Stable iff every root x is real (LAPACK returns real eigenvalues of a real matrix
    with zero imaginary part) and |x| ≤ 2.  Each root's uncertainty is Q's error over
    |Q′| (a simple root) or 2√(error/|Q″|) (near a collision), the smaller; Q's error is
    2n × rel_err × max(1, ‖M‖) times Σ|q_k||x|^k.  ``margin`` (> 1 certifies), in units
    of that uncertainty: stable, the smallest over the roots of 2 − |x| and half the gap
    to the nearest other root (where a collision could leave the real axis); unstable,
    the largest distance of a root from the segment [−2, 2].
    """
    npts, n = x.shape
    real = x.imag == 0.0
    stable = np.all(real & (np.abs(x.real) <= 2.0), axis=1)
    k = np.arange(n + 1)
    with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
        dq = (2 * n * rel_err * np.maximum(1.0, norm))[:, None] * np.sum(
            np.abs(qc)[:, None, :] * np.abs(x)[:, :, None] ** k[None, None, :], axis=2)
        d1 = np.abs(_poly_eval(qc, x, 1))
        d2 = np.abs(_poly_eval(qc, x, 2))
        e = np.minimum(dq / d1, 2.0 * np.sqrt(dq / d2))
        e = np.where(np.isfinite(e), e, np.inf)
        gap = np.abs(x[:, :, None] - x[:, None, :])
        gap[:, np.arange(n), np.arange(n)] = np.inf
        gap = np.where(real[:, :, None] & real[:, None, :], gap, np.inf)
        # stable: every root must stay real and inside; unstable: one root outside suffices
        inside = np.minimum(2.0 - np.abs(x.real), 0.5 * np.min(gap, axis=2))
        outside = np.abs(x - np.clip(x.real, -2.0, 2.0))      # distance to [−2, 2]
        margin = np.where(stable, np.min(inside / e, axis=1), np.max(outside / e, axis=1))
    return stable, np.where(np.isnan(margin), 0.0, margin)


def _analyse(Ms, ls, T, liou, err, guard_tol):
    """Multipliers, stability, labels, margins and guards for a stack of scaled monodromies.

    ``margin`` is the distance of the stability test from its threshold in the
    units of the error estimate's quantity; ``margin > 10 · err`` certifies the
    classification.
    """
    npts, d, _ = Ms.shape
    n = d // 2
    undamped = np.abs(liou) <= 1e-12 * np.maximum(1.0, T)
    symplectic4 = d == 4 and bool(np.all(undamped))
    if d == 2:
        # λ = (tr ± √(tr² − 4 det))/2 in the scaled frame (det̃ = det e^(−2 ls))
        tr_ = np.trace(Ms, axis1=1, axis2=2).astype(complex)
        det_ = np.linalg.det(Ms)
        sq_ = np.sqrt(tr_ * tr_ - 4 * det_)
        lam = np.stack([0.5 * (tr_ + sq_), 0.5 * (tr_ - sq_)], axis=1)
    elif symplectic4:
        lam = None         # from the reduced quadratic below
    else:
        lam = np.linalg.eigvals(Ms)
    if lam is None:
        with np.errstate(over="ignore", invalid="ignore"):
            t1 = np.trace(Ms, axis1=1, axis2=2)
            t2 = np.trace(Ms @ Ms, axis1=1, axis2=2)
            e2 = 0.5 * (t1 * t1 - t2)                      # scaled: s2 e^(−2 ls)
            # x̃ = x e^(−ls): x̃² − t1 x̃ + (e2 − 2 e^(−2ls)) = 0
            c0 = e2 - 2.0 * np.exp(-2.0 * np.minimum(ls, 300))
            sqd = np.sqrt((t1 * t1 - 4.0 * c0).astype(complex))
            xs = np.stack([0.5 * (t1 + sqd), 0.5 * (t1 - sqd)], axis=1)
            # λ̃ (scaled by e^(−ls)): λ̃² − x̃ λ̃ + e^(−2 ls) = 0
            w = np.sqrt(xs * xs - 4.0 * np.exp(-2.0 * np.minimum(ls, 300))[:, None])
            lam = np.concatenate([0.5 * (xs + w), 0.5 * (xs - w)], axis=1)
    reduce = None
    if d > 2 and not symplectic4:
        # undamped: decide on the best estimate of the symplectic monodromy (the reduced
        # polynomial in x = λ + 1/λ), as the 2 × 2 and 4 × 4 paths do
        reduce = np.nonzero(undamped & (ls == 0.0) & np.all(np.isfinite(Ms), axis=(1, 2)))[0]
        if reduce.size:
            qc, xr = _reduced_polynomial(lam[reduce], n)
            root = np.sqrt(xr * xr - 4.0)
            lam = lam.astype(complex)        # eigvals is real when every λ of M̃ is real
            lam[reduce] = np.concatenate([0.5 * (xr + root), 0.5 * (xr - root)], axis=1)
    with np.errstate(divide="ignore"):
        logabs = np.log(np.abs(lam)) + ls[:, None]
    order = np.argsort(-logabs, axis=1)
    lam = np.take_along_axis(lam, order, axis=1)
    logabs = np.take_along_axis(logabs, order, axis=1)
    trace_s = np.trace(Ms, axis1=1, axis2=2)
    with np.errstate(over="ignore", invalid="ignore"):
        trace = np.where(ls > 700, np.sign(trace_s) * np.inf,
                         trace_s * np.exp(np.minimum(ls, 700)))
    det_exact = np.exp(liou)
    with np.errstate(over="ignore"):
        scale_m = np.maximum(1.0, np.max(np.abs(Ms), axis=(1, 2)) * np.exp(np.minimum(ls, 700)))
    tol_abs = np.maximum(10.0 * err, 1e-13) * scale_m     # absolute error bound on entries
    stable = np.empty(npts, dtype=bool)
    label = np.zeros(npts, dtype=np.int8)
    slow = np.full((npts, n), np.nan)
    if d == 2:
        # Jury: both multipliers in the closed unit disk iff |tr| ≤ 1 + det (det ≤ 1)
        # in the scaled frame (M = e^ls Ms), so that astronomically large traces compare
        down = np.exp(-np.minimum(ls, 700))
        tol_s = np.maximum(10.0 * err, 1e-13) * np.maximum(down, np.max(np.abs(Ms), axis=(1, 2)))
        gap = (1.0 + det_exact) * down - np.abs(trace_s)
        # decided on the best estimate (no bias either way); `margin` says how sure
        stable[:] = (gap >= 0.0) & (ls < 700)
        margin = np.abs(gap) / (2 * tol_s)
        label[:] = np.where(stable, 0, np.where(trace > 0, 1, 2))
        with np.errstate(invalid="ignore"):
            c = trace / (2.0 * np.sqrt(det_exact))
        slow[:, 0] = np.where(stable, np.arccos(np.clip(c, -1, 1)) / T, np.nan)
    elif symplectic4:
        # symplectic 4 × 4: x = λ + 1/λ solves x² − s1 x + (s2 − 2) = 0
        with np.errstate(over="ignore", invalid="ignore"):
            tr2 = np.trace(Ms @ Ms, axis1=1, axis2=2) * np.exp(np.minimum(2 * ls, 1400))
            s1 = trace
            s2 = 0.5 * (s1 * s1 - tr2)
            disc = s1 * s1 - 4.0 * (s2 - 2.0)
            sq = np.sqrt(np.maximum(disc, 0.0))
            x1 = 0.5 * (s1 + sq)
            x2 = 0.5 * (s1 - sq)
            # error bounds: tr errors ≤ 4 tol_abs, tr M² ≤ 32 tol_abs ‖M‖; x by first order
            e_s1 = 4 * tol_abs
            e_disc = 16 * tol_abs * scale_m * 4
            e_x = e_s1 + np.where(sq > 0, e_disc / np.maximum(sq, 1e-300), np.sqrt(e_disc))
        # decided on the best estimate (no bias either way); `margin` says how sure
        real = disc >= 0.0
        inside = (np.abs(x1) <= 2.0) & (np.abs(x2) <= 2.0)
        stable[:] = real & inside & (ls < 700)
        with np.errstate(invalid="ignore", divide="ignore"):
            margin = np.minimum(np.abs(disc) / e_disc,
                                np.minimum(np.abs(np.abs(x1) - 2), np.abs(np.abs(x2) - 2)) / e_x)
        margin = np.where(ls >= 700, np.inf, margin)
        label[:] = np.where(stable, 0, np.where(~real, 3, np.where(x1 > -x2, 1, 2)))
        slow[:, 0] = np.where(stable, np.arccos(np.clip(x1 / 2, -1, 1)) / T, np.nan)
        slow[:, 1] = np.where(stable, np.arccos(np.clip(x2 / 2, -1, 1)) / T, np.nan)
    else:
        top = logabs[:, 0]
        e_log = np.sqrt(tol_abs / scale_m)       # eigenvalues near a collision: √ε sensitivity
        # damped: all |λ| < 1; undamped with huge growth (scaled M): unstable
        stable[:] = ~undamped & (top < 0.0)
        margin = np.where(undamped, np.inf, np.abs(top) / e_log)
        if reduce.size:
            st, mg = _reduced_decision(qc, xr, tol_abs[reduce] / scale_m[reduce],
                                       scale_m[reduce])
            stable[reduce] = st
            margin[reduce] = mg
        ang = np.abs(np.angle(lam[:, 0]))
        label[:] = np.where(stable, 0, np.where(ang < 1e-6, 1, np.where(np.pi - ang < 1e-6,
                                                                         2, 3)))
        args = np.sort(np.abs(np.angle(lam)), axis=1)[:, ::2][:, :n]
        slow[:] = np.where(stable[:, None], args / T[:, None], np.nan)
    # guards
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        sign, logdet = np.linalg.slogdet(Ms)
        liou_res = np.abs(sign * np.exp(logdet + d * ls - liou) - 1.0)
        spread = logabs[:, 0] - logabs[:, -1]
        floor = 1e-13 * np.exp(np.minimum(spread, 700))
    pair = np.full(npts, np.nan)
    if np.any(undamped) and d > 2:
        # palindromic characteristic polynomial: power sums → coefficients (Newton)
        Mk = np.broadcast_to(np.eye(d), Ms.shape).copy()
        p = np.zeros((npts, d + 1))
        for k in range(1, d + 1):
            Mk = Mk @ Ms
            p[:, k] = np.trace(Mk, axis1=1, axis2=2)
        e = np.zeros((npts, d + 1))
        e[:, 0] = 1.0
        for k in range(1, d + 1):
            acc = np.zeros(npts)
            for i in range(1, k + 1):
                acc += (-1) ** (i - 1) * e[:, k - i] * p[:, i]
            e[:, k] = acc / k
        with np.errstate(over="ignore", invalid="ignore"):
            # e_k of the scaled matrix carries e^(−k ls)
            ek = e * np.exp(np.arange(d + 1)[None, :] * np.minimum(ls, 50)[:, None])
            scale = np.maximum(1.0, np.max(np.abs(ek), axis=1))
            pr = np.max(np.abs(ek - ek[:, ::-1]), axis=1) / scale
        pair = np.where(undamped & (ls < 50), pr, np.nan)
    elif d == 2:
        pair = np.where(undamped, liou_res, np.nan)      # λ1 λ2 = 1 is the pairing for 2 × 2
    # a guard fails when its residual exceeds what the error estimate allows (×10)
    lim = np.maximum(np.maximum(guard_tol, 10.0 * err), floor)
    checkable = floor < 1e-2
    bad_l = checkable & ~(liou_res <= lim)
    bad_p = checkable & undamped & np.isfinite(pair) & ~(pair <= lim)
    bad_e = err > 1e-3
    flags = [()] * npts
    for i in np.nonzero(bad_l | bad_p | bad_e)[0]:
        f = []
        if bad_l[i]:
            f.append(f"Liouville: |det M/exp(∮tr J) − 1| = {liou_res[i]:.2e} > {lim[i]:.1e}")
        if bad_p[i]:
            f.append(f"multipliers not in pairs λ, 1/λ: residual {pair[i]:.2e} > {lim[i]:.1e}")
        if bad_e[i]:
            f.append(f"monodromy error estimate {err[i]:.1e} (rounding-limited?)")
        flags[i] = tuple(f)
    with np.errstate(over="ignore", invalid="ignore"):
        mult = lam * np.where(ls > 700, np.inf, np.exp(np.minimum(ls, 700)))[:, None]
        expo = (logabs + 1j * np.angle(lam)) / T[:, None]
    return dict(multipliers=mult, logabs=logabs, trace=trace, stable=stable, label=label,
                slow=slow, exponents=expo, liouville=liou_res, pairing=pair, margin=margin,
                flags=flags)


def _analyse_points(prep, idx, Ms, ls, err, skip, finished, guard_tol):
    """:func:`_analyse` for the grid points ``idx``; the points that were not integrated
    (``skip``, see :func:`_integrate`) get the frozen-time growth estimate and a flag,
    those not reached before Ctrl-C (``~finished``) NaN and a flag."""
    T, liou = prep["T"][idx], prep["liouville"][idx]
    d = Ms.shape[1]
    res = _analyse(np.where(skip[:, None, None], np.eye(d), Ms), np.where(skip, 0.0, ls), T,
                   liou, np.where(skip, 0.0, err), guard_tol)
    where = np.nonzero(skip & finished)[0]
    _not_computed(res, np.nonzero(~finished)[0])
    if where.size == 0:
        return res
    growth, real = _frozen_growth(prep, idx[where])
    with np.errstate(invalid="ignore"):
        need = _step_count(*_balanced(prep, idx[where]))
    decided = growth > 30.0           # unstable even if the estimate were off by a factor 2
    for k in ("multipliers", "exponents"):
        res[k][where] = np.nan
    for k in ("logabs", "slow"):
        res[k][where] = np.nan
    res["logabs"][where, 0] = growth
    with np.errstate(over="ignore", invalid="ignore"):
        res["exponents"][where, 0] = growth / T[where]
    res["trace"][where] = np.nan
    res["stable"][where] = False
    res["label"][where] = np.where(real, 1, 3)
    res["liouville"][where] = np.nan
    res["pairing"][where] = np.nan
    res["margin"][where] = np.where(decided, np.inf, 0.0)
    for j, i in enumerate(where):
        res["flags"][i] = (
            f"not integrated: ~{need[j]:.1e} Taylor steps per period needed (more than "
            f"{MAX_STEPS_PER_PERIOD}; a slow drive or a huge amplitude); log|λ| ≈ {growth[j]:.4g}"
            " per period is the frozen-time (adiabatic) estimate"
            + ("" if decided[j] else "; stability undecided (reported unstable)"),)
    return res


def _blank(m, n):
    """An :func:`_analyse` result for ``m`` points that were not computed (Ctrl-C)."""
    d = 2 * n
    res = dict(multipliers=np.full((m, d), np.nan, dtype=complex), logabs=np.full((m, d), np.nan),
               trace=np.full(m, np.nan), stable=np.zeros(m, dtype=bool),
               label=np.full(m, 3, dtype=np.int8), slow=np.full((m, n), np.nan),
               exponents=np.full((m, d), np.nan, dtype=complex), liouville=np.full(m, np.nan),
               pairing=np.full(m, np.nan), margin=np.zeros(m), flags=[()] * m)
    _not_computed(res, np.arange(m))
    return res


def _analyse_chunked(prep, idx, Ms, ls, err, skip, finished, guard_tol, progress,
                     budget=None):
    """:func:`_analyse_points` in chunks (:func:`run_in_chunks`) up to the last finished
    point.  Returns (result, analysed, stopped): after Ctrl-C, or when ``budget`` seconds
    have passed (after an interrupted integration), the points not analysed are marked not
    computed."""
    m = idx.size
    last = np.flatnonzero(finished)
    limit = int(last[-1]) + 1 if last.size else 0
    parts = []
    t0 = time.perf_counter()

    def work(a, b):
        if budget is not None and time.perf_counter() - t0 > budget:
            raise KeyboardInterrupt
        parts.append(_analyse_points(prep, idx[a:b], Ms[a:b], ls[a:b], err[a:b], skip[a:b],
                                     finished[a:b], guard_tol))

    _, stopped = run_in_chunks(work, limit, progress=progress, label="Floquet grid: analysis",
                               first=4096, target=0.25 if budget is None else 0.1)
    stopped = stopped or limit < m
    done = sum(p["trace"].size for p in parts)
    parts.append(_blank(m - done, prep["n"]))
    if len(parts) == 2 and done == m:
        res = parts[0]
    else:
        res = {k: np.concatenate([p[k] for p in parts]) for k in parts[0] if k != "flags"}
        res["flags"] = [f for p in parts for f in p["flags"]]
    analysed = np.zeros(m, dtype=bool)
    analysed[:done] = True
    return res, analysed, stopped


def _not_computed(res, where):
    """Mark the points ``where`` of an :func:`_analyse` result as not computed (Ctrl-C)."""
    for k in ("multipliers", "exponents", "logabs", "slow", "trace", "liouville", "pairing"):
        res[k][where] = np.nan
    res["stable"][where] = False
    res["label"][where] = 3
    res["margin"][where] = 0.0
    for i in where:
        res["flags"][i] = ("not computed: interrupted (Ctrl-C)",)


def floquet_grid(system, params, about, *, frequency="omega", tol=1e-10, guard_tol=1e-8,
                 order=16, certify=False, coarse_tol=1e-4, progress=None) -> FloquetGrid:
    """Floquet analysis for every parameter set of a broadcast grid.

    Parameters
    ----------
    system, about, frequency, tol, guard_tol, order
        As for :func:`floquet_point`.
    params : dict
        Parameter values by name; scalars or arrays, broadcast together.
    certify : bool
        Classification mode for maps: integrate every point to ``coarse_tol``
        first, then again to ``tol`` only where the stability test is within 10×
        the error estimate of its threshold.  Far from boundaries the reported
        trace is then accurate to ``coarse_tol`` (see the "error" array), and
        every classification is certified by its margin.
    progress : None, bool or callable
        The grid runs in three stages — sampling J(t), integration, analysis — each in
        chunks of about 0.25 s; a progress line on stderr when it is a terminal (None),
        always (True), never (False), or ``progress(done, total)`` called after each
        chunk (each stage counts its own points from 0 to ``total``).  Ctrl-C stops
        any stage within a chunk (it is held back during the NumPy code between the
        chunks) and raises :class:`~kapitza.results.ComputationInterrupted` (a
        KeyboardInterrupt) whose ``.result`` is this grid with the finished points
        filled (the others NaN, unstable, label 3, flagged "not computed") and
        ``.computed`` marks them: none during the sampling; after the integration,
        the integrated points analysed within 0.5 s (the rest keep their monodromy).

    Returns
    -------
    kapitza.results.FloquetGrid
        Arrays over the grid's shape: ``stable``, ``label`` / ``boundary``, ``trace``,
        ``log_growth``, ``multipliers``, ``omega_slow``, ``error_estimate``,
        ``steps``, ``margin``, ``flags`` (flat order), ...; ``point(index)`` gives
        one point's :class:`~kapitza.results.FloquetResult`.

    Examples
    --------
    The upright pendulum over three amplitudes at ω = 60 rad/s (the exact window is
    7.4 cm < A < 43 cm, :func:`kapitza.mathieu.pendulum_stability_window`):

    >>> import math
    >>> from lagrange_core import problems
    >>> grid = floquet_grid(problems.driven_pendulum("vertical"),
    ...                     dict(m=1.0, l=1.0, g=9.81, A=[0.05, 0.2, 0.5], omega=60.0), [math.pi])
    >>> grid.boundary.tolist()
    ['T', 'stable', '2T']
    >>> grid.point(1).stable
    True
    """
    with _defer_ctrl_c():
        return _floquet_grid(system, params, about, frequency, tol, guard_tol, order, certify,
                             coarse_tol, progress)


def _floquet_grid(system, params, about, frequency, tol, guard_tol, order, certify,
                  coarse_tol, progress) -> FloquetGrid:
    # three chunked stages (sampling J, integration, analysis): Ctrl-C stops any of them at
    # a chunk's end; the integrated points are still analysed (a second Ctrl-C stops that)
    prep = _prepare(system, params, about, frequency, tol, progress)
    shape = prep["shape"]
    npts = prep["T"].size
    if prep["stopped"]:
        grid = _grid(prep, *_nothing(prep), _blank(npts, prep["n"]), 0)
        raise ComputationInterrupted(grid, np.zeros(shape, dtype=bool))
    idx = np.arange(npts)
    first = max(tol, coarse_tol) if certify else tol
    Ms, ls, err, steps, skip, fin, res, interrupted = _pass(prep, idx, first, order, guard_tol,
                                                           progress)
    refined = 0
    if certify and first > tol and not interrupted:
        redo = np.nonzero(~(res["margin"] > 1.0) & ~skip)[0]
        if redo.size:
            M2, l2, e2, s2, _, f2, r2, interrupted = _pass(prep, redo, tol, order, guard_tol,
                                                           progress)
            # after Ctrl-C the points not refined keep their coarse result
            keep = np.nonzero(f2)[0]
            redo = redo[keep]
            refined = redo.size
            Ms[redo], ls[redo], err[redo], steps[redo] = M2[keep], l2[keep], e2[keep], s2[keep]
            for k, v in r2.items():
                if k == "flags":
                    for j, i in zip(keep, redo):
                        res["flags"][i] = v[j]
                else:
                    res[k][redo] = v[keep]
    grid = _grid(prep, Ms, ls, err, steps, res, refined)
    if interrupted or _SIGINT["hit"]:
        raise ComputationInterrupted(grid, fin.reshape(shape))
    return grid


def _pass(prep, idx, tol, order, guard_tol, progress):
    """Integrate and analyse the grid points ``idx`` at ``tol``: (monodromies, log scales,
    error estimates, steps, skipped, finished, analysis, interrupted).  After a Ctrl-C in
    the integration the points integrated are still analysed, for at most _AFTER_CTRL_C."""
    Ms, ls, err, steps, skip, fin, stopped = _integrate(prep, idx, tol, order, progress)
    stopped = stopped or _SIGINT["hit"]
    _SIGINT["hit"] = False
    res, analysed, analysis_stopped = _analyse_chunked(prep, idx, Ms, ls, err, skip, fin,
                                                       guard_tol, progress,
                                                       _AFTER_CTRL_C if stopped else None)
    fin &= analysed
    return Ms, ls, err, steps, skip, fin, res, stopped or analysis_stopped or not fin.all()


def _grid(prep, Ms, ls, err, steps, res, refined) -> FloquetGrid:
    shape = prep["shape"]
    out = {k: v.reshape(shape + v.shape[1:]) for k, v in res.items() if k != "flags"}
    return FloquetGrid(**_monodromy_fields(prep, Ms, ls, err, steps),
                       multipliers=out["multipliers"], log_abs_multipliers=out["logabs"],
                       exponents=out["exponents"], trace=out["trace"], stable=out["stable"],
                       label=out["label"], omega_slow=out["slow"],
                       liouville_residual=out["liouville"], pairing_residual=out["pairing"],
                       margin=out["margin"], flags=tuple(res["flags"]), refined_points=refined)


def floquet_point(system, params, about, *, frequency="omega", tol=1e-10, guard_tol=1e-8,
                  order=16) -> FloquetResult:
    """Floquet analysis of ``system`` linearised about the driven equilibrium ``about``.

    Parameters
    ----------
    system : lagrange_core.System
        Unconstrained, driven with angular frequency ``params[frequency]``
        (period T = 2π/ω).
    params : dict
        Parameter values (scalars).
    about : sequence or dict
        Coordinates of a state that persists under the drive (velocities zero).
    tol : float
        Target error of the monodromy relative to max(1, ‖M‖); the Taylor
        steps are chosen to meet it and the estimate is reported.
    order : int
        Taylor order (steps get longer with the order; 12–24 are sensible).
    guard_tol : float
        Liouville / pairing residual above which the result is flagged.

    Returns
    -------
    kapitza.results.FloquetResult

    Examples
    --------
    See the module docstring.
    """
    for k, v in params.items():
        if np.ndim(v) != 0:
            raise ValueError(f"floquet_point takes scalar parameters; {k!r} is an array. Use "
                             "floquet_grid or stability_map for grids.")
    return floquet_grid(system, params, about, frequency=frequency, tol=tol, guard_tol=guard_tol,
                        order=order, progress=False).point()


def stability_map(system, A, omega, params, about, *, amplitude="A", frequency="omega",
                  tol=1e-8, coarse_tol=None, guard_tol=1e-6,
                  order=16, progress=None) -> StabilityMap:
    """Stability map of a driven equilibrium over an (A, ω) grid by monodromy integration.

    Every point is integrated to ``tol``; ``uncertified_points`` of the result counts
    those whose stability test lies within 10× its error estimate of the
    threshold.  With ``coarse_tol`` the grid is first integrated to that
    tolerance and only the uncertified points again to ``tol`` (worth it when
    boundaries are far apart on the grid; for near-identity monodromies — slow
    motion, ω ≫ ω0 — nearly every point needs ``tol`` anyway).

    The axes come first, in the order of :meth:`kapitza.KapitzaPendulum.stability_map`
    ``(A, omega, about=...)``: ``stability_map(system, A, omega, params, about)``.

    Parameters
    ----------
    system : lagrange_core.System
    A, omega : 1-d arrays
        Grid axes for the parameters named ``amplitude`` and ``frequency``.
    params : dict
        The other parameters (scalars).
    about : sequence or dict
        The equilibrium's coordinates.
    tol : float
        Target error of the monodromy near boundaries (relative to max(1, ‖M‖)).
    progress : None, bool or callable
        Progress line and Ctrl-C, as for :func:`floquet_grid`; the
        :class:`~kapitza.results.ComputationInterrupted` raised carries this map
        with the finished points filled.

    Returns
    -------
    kapitza.results.StabilityMap
        Arrays of shape (len(A), len(omega)); ``about`` is the equilibrium's
        coordinates as text, ``params`` the fixed parameters, with timing, the
        numbers of refined, uncertified and flagged points; ``l``, ``g``,
        ``damping`` are None (they name the single pendulum's constants).

    Examples
    --------
    The double pendulum on a vertically driven pivot: no drive, no upright (Acheson).

    >>> import math
    >>> import sympy as sp
    >>> from lagrange_core import problems, t
    >>> A, w = sp.symbols("A omega", positive=True)
    >>> chain = problems.n_link_pendulum(2, pivot=(0, A * sp.cos(w * t)))
    >>> m = stability_map(chain, [0.0, 0.1], [100.0],
    ...                   dict(g=9.81, l1=1.0, l2=1.0, m1=1.0, m2=1.0), [math.pi, math.pi],
    ...                   tol=1e-8)
    >>> m.stable[:, 0].tolist(), m.flagged_points
    ([False, True], 0)
    """
    if isinstance(A, Mapping) or isinstance(omega, Mapping) or not isinstance(params, Mapping):
        raise TypeError(
            "stability_map takes the grid axes first: stability_map(system, A, omega, params, "
            "about, ...) (as KapitzaPendulum.stability_map(A, omega, about=...)); got a "
            f"{type(A).__name__} for A, a {type(omega).__name__} for omega and a "
            f"{type(params).__name__} for params (the old order was system, params, about, A, "
            "omega).")
    A = arguments.grid_axis(amplitude, A, None, positive=None)
    omega = arguments.grid_axis(frequency, omega, "rad/s", positive=True)
    fixed = {k: v for k, v in params.items() if k not in (amplitude, frequency)}
    p = dict(fixed)
    p[amplitude] = A[:, None]
    p[frequency] = omega[None, :]
    t0 = time.perf_counter()
    with _defer_ctrl_c():
        try:
            g = floquet_grid(system, p, about, frequency=frequency, tol=tol,
                             guard_tol=guard_tol, order=order, certify=coarse_tol is not None,
                             coarse_tol=coarse_tol if coarse_tol is not None else tol,
                             progress=progress)
        except ComputationInterrupted as e:
            partial = _map_from_grid(e.result, A, omega, about, fixed, t0)
            raise ComputationInterrupted(partial, e.computed) from None
        result = _map_from_grid(g, A, omega, about, fixed, t0)
        if _SIGINT["hit"]:             # Ctrl-C after the last chunk: everything is computed
            raise ComputationInterrupted(result, np.ones(result.stable.shape, dtype=bool))
        return result


def _map_from_grid(g, A, omega, about, fixed, t0) -> StabilityMap:
    flagged = [f for f in g.flags if f]
    return StabilityMap(A=A, omega=omega, stable=g.stable, label=g.label, trace=g.trace,
                        log_growth=g.log_growth, error_estimate=_largest_finite(g.error_estimate),
                        about=str(about), method="monodromy", params=fixed,
                        seconds=time.perf_counter() - t0, refined_points=g.refined_points,
                        uncertified_points=int(np.sum(~(g.margin > 1.0))),
                        flagged_points=len(flagged), flags_example=flagged[0] if flagged else (),
                        max_steps_per_period=int(np.max(g.steps, initial=0)),
                        samples=g.samples)


def _largest_finite(x):
    """The largest finite entry (0 if none): the error estimate over the integrated points."""
    x = np.asarray(x)[np.isfinite(x)]
    return float(np.max(x)) if x.size else 0.0


# -- exact windows, boundary curves and adaptive maps (issue 12) --------------------------

class _Probe:
    """Monodromies of one system about one equilibrium at any (amplitude, ω) points, the
    other parameters fixed: the ``evaluate(A, omega, analyse)`` of
    :mod:`kapitza.floquet_boundaries`.  Margins (``analyse`` False) are evaluated at
    ``tol`` (with ``paired``, their entries' error measured against a second monodromy),
    classifications (``analyse`` True) at ``classify_tol``.  The parameters and the
    persistence of the equilibrium are checked, and J's sampling plan made, on the first
    call; ``count`` counts the monodromies computed.  Ctrl-C raises KeyboardInterrupt."""

    def __init__(self, system, params, about, amplitude, frequency, tol, order, guard_tol,
                 paired=False, classify_tol=None):
        _check_system(system)
        for name in (amplitude, frequency):
            if name not in system.parameters:
                raise ValueError(f"{name!r} is not a parameter of {system!r}; its parameters "
                                 f"are {list(system.parameters)} (pass amplitude=<name>, "
                                 "frequency=<name>).")
        if amplitude == frequency:
            raise ValueError("the amplitude and the frequency must be different parameters.")
        self.fixed = {k: v for k, v in params.items() if k not in (amplitude, frequency)}
        for k, v in self.fixed.items():
            if np.ndim(v) != 0:
                raise ValueError(f"the fixed parameters must be scalars; {k!r} is an array.")
        self.system, self.about = system, about
        self.amplitude, self.frequency = amplitude, frequency
        self.tol, self.order, self.guard_tol = tol, order, guard_tol
        self.paired = paired
        self.classify_tol = tol if classify_tol is None else classify_tol
        self.samples = None
        self.count = 0

    def prepare(self, A, omega, tol=None):
        A = np.asarray(A, float).ravel()
        w = np.asarray(omega, float).ravel()
        tol = self.tol if tol is None else tol
        if self.samples is None:        # the first call checks everything
            p = dict(self.fixed)
            p[self.amplitude], p[self.frequency] = A, w
            prep = _prepare(self.system, p, self.about, self.frequency, tol)
            if prep["T"].size and not prep["stopped"]:
                self.samples = prep["samples"]
                names = self.system.parameters
                self.row = np.array([self.fixed.get(k, 0.0) for k in names], dtype=float)
                self.columns = (names.index(self.amplitude), names.index(self.frequency))
                self.ystar = _equilibrium_state(self.system, self.about)
        else:                           # then only the two axes change
            P = np.repeat(self.row[None, :], A.size, axis=0)
            P[:, self.columns[0]], P[:, self.columns[1]] = A, w
            prep = _series(self.system, P, self.ystar, w, 2 * np.pi / w, A.shape,
                           {self.amplitude: A, self.frequency: w}, tol, samples=self.samples)
        if prep["stopped"]:
            raise KeyboardInterrupt
        return prep

    def __call__(self, A, omega, analyse=False):
        tol = self.classify_tol if analyse else self.tol
        prep = self.prepare(A, omega, tol)
        n, idx = prep["n"], np.arange(prep["T"].size)
        Ms, ls, err, _, skip, fin, stopped = _integrate(prep, idx, tol, self.order)
        if stopped or not fin.all():
            raise KeyboardInterrupt
        self.count += idx.size
        Mb = self._balanced(Ms, prep)
        out = dict(Mb=Mb, ls=ls, err=err,
                   undamped=np.abs(prep["liouville"]) <= 1e-12 * np.maximum(1.0, prep["T"]))
        if self.paired and not analyse:
            # the entries' error, for the margins: against a second monodromy at 100× the
            # tolerance (what the coarser one gets wrong bounds the finer one's error);
            # the Taylor estimate runs 100–1000× above the actual error
            M2, ls2, *_ = _integrate(prep, idx, min(1e-6, 1e2 * self.tol), self.order)
            with np.errstate(invalid="ignore"):
                gap = np.max(np.abs(Mb - self._balanced(M2, prep)), axis=(1, 2))
                size = np.maximum(1.0, np.max(np.abs(Mb), axis=(1, 2)))
                out["delta"] = np.where((ls2 == ls) & np.isfinite(gap),
                                        np.maximum(gap, 16 * np.finfo(float).eps * size),
                                        err * size)
        if analyse:
            res = _analyse_points(prep, idx, Ms, ls, err, skip, fin, self.guard_tol)
            out.update(stable=res["stable"], label=res["label"])
        return out

    @staticmethod
    def _balanced(Ms, prep):
        """Monodromies in the balanced variables (q, dq/d(ωt)): rows of dq/dt ÷ ω,
        columns × ω (their determinants and eigenvalues are those of M)."""
        n, om = prep["n"], prep["omega"][:, None, None]
        Mb = Ms.copy()
        Mb[:, n:, :] /= om
        Mb[:, :, n:] *= om
        return Mb

    def amplitude_scale(self, omega):
        """Per ω, the amplitude at which the drive's modulation of J, in the balanced
        variables, reaches 2 (the single pendulum: A = 2 l, Mathieu q = 4, well past its
        first window's A = 0.454 l)."""
        w = np.atleast_1d(np.asarray(omega, float))
        h = []
        for a in (0.0, 1.0):
            prep = self.prepare(np.full(w.size, a), w)
            C, S = _balanced(prep, np.arange(w.size))
            h.append(np.sum(np.max(np.abs(C[:, 1:]), axis=(2, 3))
                            + np.max(np.abs(S[:, 1:]), axis=(2, 3)), axis=1))
        slope = np.abs(h[1] - h[0])
        if not np.all(slope > 0):
            raise ValueError(f"the parameter {self.amplitude!r} does not modulate the "
                             "linearised drive; pass A_limit= (or A_range=) explicitly.")
        return 2.0 / slope


#: the monodromies' tolerance of the classification scans and side checks of windows and
#: boundaries (their brackets are then solved on margins at the edges' own tolerance)
CLASSIFY_TOL = 1e-8


def _margin_tol(tol):
    """The monodromies' tolerance for edges wanted to ``tol`` (relative, in A): 1e-5 tol,
    at least 1e-15 (each factor 100 costs about 30 % more Taylor steps)."""
    return float(min(1e-8, max(1e-15, 1e-5 * tol)))


def _scan_grid(lo, hi, points):
    """Ascending amplitudes from lo to hi: ``points`` evenly spaced plus a third as many
    spaced geometrically towards lo (edges near lo, e.g. at fast drives, are resolved)."""
    u = np.unique(np.r_[0.0, np.geomspace(1e-4, 1.0, max(2, points // 3)),
                        np.linspace(0.0, 1.0, points + 1)])
    return lo + (hi - lo) * u


def window(system, params, about, omega, *, amplitude="A", frequency="omega", tol=1e-10,
           A_limit=None, scan=96, order=16, guard_tol=1e-8) -> StabilityWindow:
    """The exact window of drive amplitudes A_min < A < A_max that stabilises ``about``,
    per ω, with certified edges.

    At each ω the amplitudes 0 … ``A_limit`` are classified (``scan`` points, plus
    geometric ones towards 0) to find the lowest stable interval; each of its edges is
    then the root of the smooth margin of the boundary's kind — det(M − I) where a
    multiplier reaches +1 ("T"), det(M + I) at −1 ("2T"), the reduced polynomial's
    discriminant or the leading log|λ| where a complex pair leaves the circle — found by
    the Anderson–Björck method in the scan's bracket, with the monodromies integrated to
    1e-5 tol and their error measured against a second monodromy at 100× that
    tolerance (:mod:`kapitza.floquet_boundaries`).  Not bisection on the flag "stable":
    after the scan, each edge takes six or seven margin evaluations.

    Parameters
    ----------
    system : lagrange_core.System
    params : dict
        The other parameters (scalars); values of ``amplitude`` and ``frequency`` in
        it are ignored.
    about : sequence or dict
        The driven equilibrium's coordinates (velocities zero).
    omega : float or 1-d array
        Drive angular frequencies (rad/s); a scalar gives a window of scalar fields.
    amplitude, frequency : str
        The names of the drive's amplitude and angular frequency parameters.
    tol : float
        Requested relative accuracy of the edges.
    A_limit : float, optional
        The largest amplitude scanned; default, per ω, where the drive's modulation of
        the linearised equations reaches 2 in the balanced variables (2 l for a pendulum
        of length l: Mathieu q = 4).
    scan : int
        Evenly spaced scan points; a window narrower than A_limit/scan can be missed.

    Returns
    -------
    kapitza.results.StabilityWindow
        ``method="floquet"``: A_min, A_max per ω; NaN where no scanned amplitude is
        stable; A_min = 0 where the undriven state is already stable (the hanging
        chain); A_max = inf where the scan ends stable.  ``accuracy``: the larger
        certified relative accuracy of the two edges.  ``l``, ``g`` are None.

    Warns
    -----
    RuntimeWarning
        Where the certified ``accuracy`` is coarser than ``tol``: at fast drives the
        monodromy is near the identity and float64 fixes the margins' sign only to about
        ε_mach (ω/ω0)² (so 1e-10 is out of reach from ~100–300 ω0 on; ask for 1e-8 there).
        Where a solved edge fails its check on both sides (A(1 ∓ η) classified on the fine
        monodromies), or a stable amplitude was scanned but an edge not found, both edges
        of that ω are NaN and the warning names the frequencies: never a wrong window.

    Examples
    --------
    The upright pendulum's window at ω = 60 rad/s agrees with the Mathieu equation's
    characteristic values (:func:`kapitza.mathieu.pendulum_stability_window`):

    >>> import math
    >>> from lagrange_core import problems
    >>> from kapitza.mathieu import pendulum_stability_window
    >>> win = window(problems.driven_pendulum("vertical"), dict(m=1.0, l=1.0, g=9.81),
    ...              [math.pi], 60.0)
    >>> ref = pendulum_stability_window(60.0, l=1.0, g=9.81)
    >>> print(f"{win.A_min:.10f} {win.A_max:.10f}")
    0.0739120532 0.4585959178
    >>> bool(abs(win.A_min / ref.A_min - 1) < 1e-10 and win.accuracy <= 1e-10)
    True
    """
    scalar = np.ndim(omega) == 0
    w = arguments.grid_axis(frequency, omega, "rad/s", positive=True)
    _check_tol(tol)
    probe = _Probe(system, params, about, amplitude, frequency, _margin_tol(tol), order,
                   guard_tol, paired=True, classify_tol=CLASSIFY_TOL)
    if w.size == 0:
        edges = dict(A_min=np.zeros(0), A_max=np.zeros(0), accuracy=np.zeros(0))
    else:
        limit = probe.amplitude_scale(w) if A_limit is None else np.full(
            w.size, float(arguments.grid_axis("A_limit", A_limit, None, positive=True)[0]))
        grid = np.stack([_scan_grid(0.0, hi, scan) for hi in limit])
        edges = first_window(probe, w, grid, tol)
    pick = (lambda x: float(x[0])) if scalar else (lambda x: x)
    return StabilityWindow(omega=pick(w), A_min=pick(edges["A_min"]),
                           A_max=pick(edges["A_max"]), method="floquet", about=str(about),
                           accuracy=pick(edges["accuracy"]), tol=tol)


def _check_tol(tol):
    if isinstance(tol, bool) or not isinstance(tol, (int, float)) or not (1e-13 <= tol < 1e-2):
        raise ValueError(f"tol must be a number in [1e-13, 1e-2) (relative, in A), got {tol!r}.")


def boundaries(system, params, about, omega, *, A_range=None, amplitude="A",
               frequency="omega", tol=1e-10, seed_every=10, scan=64, side=1e-6, order=16,
               guard_tol=1e-8) -> BoundaryCurves:
    """The stability boundaries A_k(ω) of ``about`` over a frequency grid, by continuation.

    Every ``seed_every``-th frequency (and the last) is scanned over ``A_range`` for
    changes between stable and unstable; each is solved to ``tol`` on the smooth margin
    of its kind ("T", "2T", "complex"; see :func:`window`), and followed through the
    frequencies in between by predictor–corrector continuation (a few monodromies per
    point), all curves together; finally every point is classified at A(1 ∓ ``side``)
    and kept only where exactly its stable side is stable
    (:func:`kapitza.floquet_boundaries.trace_curves`).

    Parameters
    ----------
    system, params, about, amplitude, frequency, tol, order, guard_tol
        As for :func:`window`.
    omega : 1-d array
        Drive angular frequencies (rad/s), ascending; the finer, the shorter each
        continuation step.
    A_range : (float, float), optional
        Amplitudes searched; default from 0 to the largest scan limit of :func:`window`.
    seed_every, scan : int
        Seed frequencies' spacing (in grid points) and their scans' evenly spaced
        points (a boundary inside a stable or unstable sliver thinner than the scan's
        spacing at every seed frequency is not found).
    side : float
        Relative offset of the side checks.

    Returns
    -------
    kapitza.results.BoundaryCurves
        ``A`` (curves × ω; NaN where a curve does not bound the stable region),
        ``accuracy``, ``kind``, ``stable_below``; draw them over a map with
        ``kapitza.plots.stability_map_figure(map, overlays=[curves])``.

    Examples
    --------
    The upright pendulum: the Kapitza limit (a multiplier at +1, stable above) and the
    first parametric resonance (at −1, stable below), as the Mathieu equation has them:

    >>> import math
    >>> import numpy as np
    >>> from lagrange_core import problems
    >>> from kapitza.mathieu import pendulum_stability_window
    >>> w = np.linspace(30.0, 60.0, 7)
    >>> curves = boundaries(problems.driven_pendulum("vertical"),
    ...                     dict(m=1.0, l=1.0, g=9.81), [math.pi], w, A_range=(0.0, 0.6))
    >>> curves.kind, curves.stable_below.tolist()
    (('T', '2T'), [False, True])
    >>> ref = pendulum_stability_window(w, l=1.0, g=9.81)
    >>> bool(np.allclose(curves.A, [ref.A_min, ref.A_max], rtol=1e-9))
    True
    """
    t0 = time.perf_counter()
    w = arguments.grid_axis(frequency, omega, "rad/s", positive=True)
    if w.size < 2 or not np.all(np.diff(w) > 0):
        raise ValueError(f"{frequency} must be an ascending grid of at least 2 frequencies.")
    _check_tol(tol)
    probe = _Probe(system, params, about, amplitude, frequency, _margin_tol(tol), order,
                   guard_tol, paired=True, classify_tol=CLASSIFY_TOL)
    if A_range is None:
        A_range = (0.0, float(np.max(probe.amplitude_scale(w[[0, -1]]))))
    lo, hi = (float(x) for x in A_range)
    if not (0.0 <= lo < hi and math.isfinite(hi)):
        raise ValueError(f"A_range must be (low, high) with 0 ≤ low < high, got {A_range!r}.")
    found = trace_curves(probe, w, _scan_grid(lo, hi, scan), tol, seed_every=seed_every,
                         side=side)
    return BoundaryCurves(omega=w, A=found["A"], accuracy=found["accuracy"],
                          kind=tuple(KINDS[int(k)] for k in found["kind"]),
                          stable_below=found["stable_below"], about=str(about),
                          params=dict(probe.fixed), A_range=(lo, hi), tol=tol,
                          seconds=time.perf_counter() - t0, monodromies=probe.count)


def adaptive_map(system, A, omega, params, about, *, amplitude="A", frequency="omega",
                 coarse_step=16, tol=1e-8, guard=0.25, order=16,
                 guard_tol=1e-6) -> AdaptiveMap:
    """A stability map over the (A, ω) grid that computes monodromies only where the
    classification changes.

    Every ``coarse_step``-th row and column are computed first; then each cell whose
    corners disagree — in label, in the sign of a continuous stability margin, or with
    a margin closer to zero than ``guard`` × the corners' spread — is split in four,
    level by level, down to the grid's own spacing
    (:func:`kapitza.floquet_boundaries.refine_map`).  The labels match a uniform
    :func:`stability_map` of the same grid wherever no stable or unstable region is
    thinner than the coarse cells, at a fraction of the monodromies; the margin's zero
    contour draws the boundaries smoothly.

    Parameters
    ----------
    system, params, about, amplitude, frequency, order, guard_tol
        As for :func:`stability_map`.
    A, omega : 1-d arrays
        The full grid's axes.
    coarse_step : int
        The coarse grid's spacing in grid points (a power of 2 splits evenly).
    tol : float
        Target error of each monodromy.

    Returns
    -------
    kapitza.results.AdaptiveMap
        A :class:`~kapitza.results.StabilityMap` (``trace`` and ``log_growth`` None)
        with ``margin``, ``computed``, ``monodromies``, ``levels``.

    Examples
    --------
    >>> import math
    >>> import numpy as np
    >>> from lagrange_core import problems
    >>> m = adaptive_map(problems.driven_pendulum("vertical"), np.linspace(0, 0.6, 129),
    ...                  np.linspace(20.0, 120.0, 129), dict(m=1.0, l=1.0, g=9.81), [math.pi])
    >>> bool(m.monodromies < 129 * 129 / 5), m.stable.shape
    (True, (129, 129))
    """
    t0 = time.perf_counter()
    A = arguments.grid_axis(amplitude, A, None, positive=None)
    w = arguments.grid_axis(frequency, omega, "rad/s", positive=True)
    if isinstance(coarse_step, bool) or not isinstance(coarse_step, int) or coarse_step < 1:
        raise ValueError(f"coarse_step must be an integer ≥ 1, got {coarse_step!r}.")
    probe = _Probe(system, params, about, amplitude, frequency, tol, order, guard_tol)
    out = refine_map(probe, A, w, coarse_step, guard=guard)
    return AdaptiveMap(A=A, omega=w, stable=out["stable"], label=out["label"], trace=None,
                       log_growth=None, error_estimate=tol, about=str(about),
                       method="adaptive monodromy", params=dict(probe.fixed),
                       seconds=time.perf_counter() - t0, samples=int(probe.samples or 0),
                       margin=out["margin"], computed=out["computed"],
                       monodromies=probe.count, levels=out["levels"], coarse_step=coarse_step)


# numba's cache does not notice a change of the kernel slots the sampler calls
guard_numba_cache(sys.modules[__name__], _kernel_calls)
