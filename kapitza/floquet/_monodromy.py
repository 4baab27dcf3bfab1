"""Monodromies over a parameter grid: validation, J's Fourier series, the integration.

For a state y* = [q*, 0] that persists under the drive, small deviations obey x′ = J(t) x
with J(t + T) = J(t), J from the system's exact compiled ``jacobian`` kernel (no finite
differences), T = 2π/ω; for a mechanical system J = [[0, I], [J_q(t), J_v(t)]], and the
monodromy M = X(T) (X′ = J X, X(0) = I) decides stability.

1. :func:`_prepare` checks the system, the parameters and the equilibrium (q̈ = 0 through
   the period), broadcasts the parameter grid, and samples J's lower block L = [J_q, J_v]
   at equally spaced times of one period
   (:func:`~kapitza.floquet._kernels.floquet_sample_jacobian`), expanded in a
   trigonometric series.  The harmonic content
   is probed at a few grid points with 16, 32, ... samples until the upper half of the
   spectrum is at rounding level; every point is then sampled with the fewest samples
   that carry it (4 for a pivot drive A cos ωt, where J is exactly affine in cos ωt) and
   its Nyquist harmonic re-checked.
2. :func:`_integrate` integrates the monodromies to a tolerance by the Taylor method of
   :mod:`kapitza.floquet._kernels`, in the balanced variables (q, dq/d(ωt)).  A point that
   would need more than :data:`MAX_STEPS_PER_PERIOD` Taylor steps (ω → 0, a huge amplitude
   against a slow drive) is not integrated: :func:`_frozen_growth` estimates its growth.

Both stages run in chunks (:func:`lagrange_core.progress.run_in_chunks`: a progress line,
Ctrl-C within a chunk).
"""
from __future__ import annotations

import math

import numpy as np

from lagrange_core.progress import run_in_chunks

from ._kernels import _monodromy_grid, _threads_for, floquet_sample_jacobian

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


def _persistence_defect(system, p, ystar, T):
    """None where the rest state y* = [q*, 0] persists under the drive (q̈ = 0 at eight
    phases of the period, to 1e-9 of the Jacobian's size), else (t, q̈) where it does not.
    ``p``: one parameter row."""
    n = system.n_dof
    kernels = system.kernels
    dydt = np.empty(2 * n)
    W = kernels.work_array()
    J = np.empty((2 * n, 2 * n))
    for k in range(8):
        t = k * T / 8
        kernels.rhs(t, ystar, p, dydt, W)
        kernels.jacobian(t, ystar, p, J)
        scale = max(1.0, float(np.max(np.abs(J))))
        if not np.all(np.abs(dydt) <= 1e-9 * scale):
            return t, dydt[n:].tolist()
    return None


def _check_persists(system, kernels, P, ystar, T, idx):
    """Raise unless q̈ = 0 at y* through the period (checked at a few grid points)."""
    n = system.n_dof
    for i in idx:
        bad = _persistence_defect(system, P[i], ystar, T[i])
        if bad is not None:
            t, qdd = bad
            raise ValueError(
                f"the state q = {ystar[:n].tolist()} does not persist under the drive: q̈ = "
                f"{qdd} at t = {t:.4g} s. Floquet analysis here needs an "
                "equilibrium of the driven system (e.g. the inverted pendulum θ = π for a "
                "vertical drive); for a state that moves with the drive (a horizontal or "
                "elliptic pivot) use kapitza.periodic_orbit(system, params, guess), which "
                "finds the periodic orbit and its multipliers, or kapitza.stability_map, "
                "window and boundaries, which follow that orbit over their grids.")


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
    grid_params = dict(zip(names, arrays, strict=True))
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

