"""Periodic orbits of a driven system, and their Floquet stability.

Why
---
Floquet analysis about an equilibrium needs a state that persists under the drive
(q̈ = 0 at all t, e.g. the vertically driven pendulum's θ = π).  Most driven states do
not persist: the horizontally driven pendulum's tilted state, the elliptic pivot's
states, any damped drive with two phases.  There the slow state of averaging is a
*periodic orbit* — the motion repeats with the drive's period T — and its stability is
that of the orbit's monodromy.

Method (Newton shooting on the period map)
------------------------------------------
With φ_T the flow over one period (``periods`` periods for a subharmonic orbit), a
T-periodic orbit is a root of F(y0) = φ_T(y0) − y0.  Newton's step solves
(X − I) δy = −F, with X = ∂φ_T/∂y0 integrated along the trajectory from the
variational equations (:func:`lagrange_core.variational.flow`: the system's exact
compiled Jacobian, 8th-order steps doubled until converged); a step that does not
reduce |F|, or whose flow fails (non-finite, or not converged by ``max_steps``), is
halved (up to 12 times).  At convergence X *is* the monodromy matrix
of the orbit: its eigenvalues are the Floquet multipliers.  The start is the averaging
prediction (the slow equilibrium of :func:`kapitza.average`, at rest) unless a guess
is given; a state that persists under the drive skips the Newton iteration and goes
to :func:`kapitza.floquet_point` (today's path, exact to its tolerance).

Accuracy: the residual |F| ≤ ``tol`` · max(1, |y0|); the monodromy's error is the
flow's ``error_estimate`` (tol/100 by default), so multipliers are accurate to about
that times the condition of their eigenproblem.  Stability: every |λ| ≤ 1 + δ with
δ = 100 × that error (an undamped orbit's multipliers lie on the unit circle up to
rounding); the slow frequency of a stable pair e^(±iΩT) is Ω = |arg λ| / T, which
resolves Ω in [0, ω/2] (the Floquet convention of :mod:`kapitza.floquet`).

Examples
--------
The horizontally driven pendulum (l = 1 m, A = 5 cm, 60 Hz) hangs tilted: averaging
says cos θ* = 2 g l/(A ω)²; the exact orbit's period mean is 9e-6 rad away:

>>> import math
>>> from lagrange_core import problems
>>> w = 2 * math.pi * 60
>>> orbit = periodic_orbit(problems.driven_pendulum("horizontal"),
...                        dict(m=1.0, l=1.0, g=9.81, A=0.05, omega=w), [1.5])
>>> print(f"{orbit.q_mean[0]:.5f} rad, averaging {math.acos(2 * 9.81 / (0.05 * w)**2):.5f} rad")
1.51556 rad, averaging 1.51555 rad
>>> orbit.stable, round(orbit.omega_slow, 3)
(True, 13.334)
"""
from __future__ import annotations

import math

import numpy as np

from lagrange_core.variational import flow

from ..results import PeriodicOrbit

__all__ = ["periodic_orbit", "PeriodicOrbit"]


def _period(system, params, frequency, periods):
    if frequency not in params:
        raise ValueError(f"periodic_orbit: params has no drive frequency {frequency!r}; name it "
                         f"with frequency=... (the parameters are {list(system.parameters)}).")
    w = float(params[frequency])
    if not (w > 0 and math.isfinite(w)):
        raise ValueError(f"periodic_orbit: the drive frequency {frequency} = {w!r} must be a "
                         "positive number (rad/s).")
    if int(periods) != periods or periods < 1:
        raise ValueError(f"periods must be a whole number ≥ 1, got {periods!r}.")
    return int(periods) * 2 * math.pi / w


def _start(system, params, guess, frequency):
    n = system.n_dof
    if guess is None:
        from ..averaging import average
        avg = average(system, frequency)
        eq = avg.equilibria(params)
        stable = [q for q in eq if avg.slow_modes(params, q, warn=False).stable]
        if len(stable) != 1:
            raise ValueError(
                f"periodic_orbit: averaging finds {len(stable)} stable slow equilibria "
                f"({[np.round(q, 6).tolist() for q in stable]}; all: "
                f"{[np.round(q, 6).tolist() for q in eq]}); pass guess=... (coordinates, or the "
                "state [q, q̇] at t = 0) to choose the orbit.")
        guess = stable[0]
    y = np.asarray(guess, dtype=float).reshape(-1)
    if y.size == n:
        y = np.concatenate([y, np.zeros(n)])
    if y.size != 2 * n or not np.all(np.isfinite(y)):
        raise ValueError(f"guess must be {n} finite coordinates or the state [q, q̇] "
                         f"({2 * n} numbers), got {guess!r}.")
    return y


def _persists(system, p, y, T):
    """Whether the rest state y = [q, 0] is an equilibrium at every phase of the drive."""
    n = system.n_dof
    if np.any(y[n:] != 0.0):
        return False
    kernels = system.kernels
    qdd = np.empty(n)
    W = kernels.work_array()
    scale = 0.0
    for t in np.linspace(0.0, T, 9)[:-1]:
        out = np.empty(2 * n)
        if kernels.rhs(float(t), y, p, out, W) != 0:
            return False
        qdd = out[n:]
        scale = max(scale, float(np.max(np.abs(qdd))))
    return scale <= 1e-12


#: Halvings of a Newton step before the iteration is declared stalled.
MAX_HALVINGS = 12


def _flow(system, y, T, p, tol, steps, max_steps):
    """The flow over one period, or None where it fails: a non-finite state or step
    doublings that do not converge by ``max_steps`` (FloatingPointError from flow), or a
    singular mass matrix on the way (ValueError)."""
    try:
        with np.errstate(all="ignore"):      # a diverging trial state is judged, not warned
            return flow(system, y, (0.0, T), p, tol=tol, steps=max(16, int(steps)),
                        max_steps=max_steps)
    except (FloatingPointError, ValueError, OverflowError):
        return None


def periodic_orbit(system, params, guess=None, *, frequency="omega", periods=1, tol=1e-10,
                   max_iterations=40, max_steps=1 << 16) -> PeriodicOrbit:
    """The T-periodic (or nT-periodic) orbit of a driven system by Newton shooting.

    Parameters
    ----------
    system : lagrange_core.System
        Unconstrained; its explicit time dependence periodic in ``params[frequency] · t``.
    params : dict
        Parameter values (scalars) by name.
    guess : array_like, optional
        Coordinates q (at rest) or the full state [q, q̇] at t = 0 near the orbit; by
        default the single stable slow equilibrium of first-order averaging.
    frequency : str
        The drive's angular-frequency parameter (rad/s); T = 2π/ω.
    periods : int
        Look for an orbit of period ``periods`` · T (subharmonic).
    tol : float
        Residual |φ_T(y0) − y0| ≤ tol · max(1, |y0|); the flow is integrated to tol/100.
    max_iterations : int
        Newton steps before giving up (ValueError).
    max_steps : int
        Most fixed steps of one flow over ``periods`` · T (the step count doubles until two
        counts agree to tol/100; an orbit that smooth needs a few hundred per period).  A
        trial state whose flow needs more, or diverges, is a rejected Newton step (halved);
        this bounds one flow to about a second for a one-degree-of-freedom system.

    Returns
    -------
    kapitza.results.PeriodicOrbit

    Raises
    ------
    ValueError
        Bad input, or Newton's method failing (no orbit near the guess; a multiplier at
        +1, where the orbit is not isolated) — the message says which.
    """
    params = dict(params)
    for k, v in params.items():
        if np.ndim(v) != 0:
            raise ValueError(f"periodic_orbit takes scalar parameters; {k!r} is an array.")
    if system.n_constraints:
        raise ValueError("periodic_orbit: constrained systems are not supported; state the "
                         "system in independent coordinates.")
    T = _period(system, params, frequency, periods)
    p = system.parameter_array(params)
    y = _start(system, params, guess, frequency)
    n = system.n_dof
    if _persists(system, p, y, T):
        from ..floquet import floquet_point
        fr = floquet_point(system, params, y[:n], frequency=frequency, tol=tol)
        M = None
        return _result(system, params, y, T, periods, fr.multipliers, M, 0.0,
                       float(fr.error_estimate), 0, "equilibrium that persists under the drive "
                       "(kapitza.floquet_point)", decided=(bool(fr.stable), fr.omega_slow))
    ftol = tol / 100
    y_start = y.copy()
    # flow() doubles its step count from ``steps`` until two counts agree, so it returns at
    # least twice the count it starts from: each call starts at half the last accepted count
    # (which converged, so it is reused, not doubled again).  Carrying the accepted count
    # forward unhalved doubled it at every Newton step: 2^20 steps per period after ~15 steps
    # and minutes per flow (issue: circular pivot, A = 0.2 l, ω/ω0 = 133, 352 s).
    fl = _flow(system, y, T, p, ftol, 32, max_steps)
    if fl is None:
        raise ValueError(f"periodic_orbit: the flow over one period from the guess {y.tolist()} "
                         f"failed (non-finite or not converged by max_steps = {max_steps} "
                         "steps); try another guess, or a larger max_steps for a very fast "
                         "orbit.")
    F = fl.y1 - y
    res = float(np.max(np.abs(F)))
    d = 2 * n
    rejected = 0
    for it in range(1, max_iterations + 1):
        if res <= tol * max(1.0, float(np.max(np.abs(y)))):
            break
        D = fl.jacobian - np.eye(d)
        try:
            dy = np.linalg.solve(D, -F)
        except np.linalg.LinAlgError:
            raise ValueError("periodic_orbit: the period map's Jacobian X − I is singular (a "
                             "multiplier at +1): the orbit is not isolated here (a T boundary, "
                             "or a conserved quantity); move the parameters or use another "
                             "guess.") from None
        lam = 1.0
        for _ in range(MAX_HALVINGS + 1):
            y_try = y + lam * dy
            # a trial state whose flow fails (non-finite, or the step doublings not
            # converging by max_steps) is a rejected step like one that raises |F|: halve
            fl_try = _flow(system, y_try, T, p, ftol, fl.steps // 2, max_steps)
            if fl_try is not None:
                F_try = fl_try.y1 - y_try
                r_try = float(np.max(np.abs(F_try)))
                if r_try < res or (lam < 1 and r_try <= res * (1 + 1e-12)):
                    break
            rejected += fl_try is None
            lam *= 0.5
        else:
            raise ValueError(f"periodic_orbit: Newton's method stalled at residual {res:.3g} "
                             f"(iteration {it}; {MAX_HALVINGS} halvings of the step, "
                             f"{rejected} trial flows failed); no periodic orbit near the guess "
                             f"{y.tolist()}. Try another guess (e.g. the averaged state) or "
                             "parameters inside the averaging regime.")
        y, fl, F, res = y_try, fl_try, F_try, r_try
    else:
        raise ValueError(f"periodic_orbit: no convergence in {max_iterations} iterations "
                         f"(residual {res:.3g} at {y.tolist()}, from the guess "
                         f"{y_start.tolist()}); no periodic orbit reached from this guess. Try "
                         "another guess (e.g. the state [q, q̇] of a direct simulation at t = 0) "
                         "or raise max_iterations.")
    mult = np.linalg.eigvals(fl.jacobian)
    return _result(system, params, y, T, periods, mult, fl.jacobian, res,
                   float(fl.error_estimate), it, "Newton shooting on the period map")


def _result(system, params, y, T, periods, mult, M, res, err, iterations, method,
            decided=None):
    """The PeriodicOrbit: period mean and amplitude from the orbit sampled at 256
    equally spaced times (trapezoid over whole periods: exact for a band-limited orbit);
    ``decided`` = (stable, omega_slow) of an analysis that already decided them."""
    n = system.n_dof
    ts = np.linspace(0.0, T, 257)
    tr = system.simulate(y[:n], y[n:], (0.0, T), params, t_eval=ts, rtol=1e-12,
                         method="dop853")
    qs = tr.q[:-1]
    q_mean = qs.mean(axis=0)
    amplitude = 0.5 * (qs.max(axis=0) - qs.min(axis=0))
    mult = np.asarray(mult, dtype=complex)
    order = np.argsort(-np.abs(mult))
    mult = mult[order]
    delta = max(100.0 * err, 1e-9)
    stable = bool(np.max(np.abs(mult)) <= 1.0 + delta)
    up = mult[(mult.imag > 0) | ((mult.imag == 0) & (mult.real < 0))]
    slow = np.sort(np.abs(np.angle(up)) / T) if stable else np.full(0, np.nan)
    if stable and slow.size < n:
        slow = np.concatenate([slow, np.full(n - slow.size, np.nan)])
    slow = slow[:n] if stable else np.full(n, np.nan)
    if decided is not None:
        stable, slow = decided[0], np.atleast_1d(np.asarray(decided[1], dtype=float))
    return PeriodicOrbit(
        coordinates=tuple(system.coordinates), params=dict(params), period=float(T),
        periods=int(periods), state=y.copy(), q_mean=q_mean, amplitude=amplitude,
        multipliers=mult, monodromy=M, stable=stable,
        omega_slow=float(slow[0]) if n == 1 else slow, residual=float(res),
        error_estimate=float(err), iterations=int(iterations), method=method)
