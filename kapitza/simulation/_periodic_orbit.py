"""Periodic orbits of a driven system, and their Floquet stability.

Why
---
Floquet analysis about an equilibrium needs a state that persists under the drive
(q̈ = 0 at all t, e.g. the vertically driven pendulum's θ = π).  Most driven states do
not persist: the horizontally driven pendulum's hanging and tilted states, the elliptic
pivot's states, any damped drive with two phases.  There the slow state of averaging is a
*periodic orbit* — the motion repeats with the drive's period T — and its stability is
that of the orbit's monodromy.

Method (Newton shooting, :mod:`kapitza.floquet._shooting`)
-------------------------------------------------------------
With φ_T the flow over one period (``periods`` periods for a subharmonic orbit), a
T-periodic orbit is a root of G(y0) = φ_T(y0) − y0.  Newton's step solves
(X − I) δy = −G, with X = ∂φ_T/∂y0 integrated along the trajectory from the variational
equations (:func:`lagrange_core.variational.flow`: the system's exact compiled Jacobian,
8th-order steps doubled until converged); a step that does not reduce |G|, or whose flow
fails, is halved (up to 12 times).  At convergence X *is* the monodromy matrix of the
orbit: its eigenvalues are the Floquet multipliers.

Where the drive has the half-period reflection symmetry f(S y, t + T/2) = −f(y, t),
S y = (2c − q, −q̇) about the centre c (the horizontal pivot about θ = 0 and π), and the
orbit asked for is the symmetric one, the shooting is on the half-period map instead:
S φ_{T/2}(y0) = y0, Jacobian R X_h − I (R = −I), monodromy (R X_h)².  It stays regular at
the symmetry-breaking pitchfork (the horizontal drive's hanging orbit giving way to the
tilted ones: a multiplier +1 of M, −1 of R X_h), where X − I is singular and the full map's
Newton returned a state 5e-4 rad off, or a tilted orbit.  The symmetry is tested on the
vector field, never assumed (``symmetry=``).

The start is the averaging prediction (the slow equilibrium of :func:`kapitza.average`, at
rest) unless ``about`` is given; a state that persists under the drive skips the Newton
iteration and goes to :func:`kapitza.floquet_point` (exact to its tolerance).

Accuracy: the residual |G| ≤ ``tol`` · max(1, |y0|), the flow integrated to tol/100.  The
state's error is ‖J⁻¹‖ (residual + flow error) with J the Jacobian of the equations shot:
near a multiplier +1 of the map shot (the orbit not isolated) that grows without bound; it
is reported (``error_estimate``), and above √tol · max(1, |y0|) flagged with a
``RuntimeWarning``.  The monodromy's error is the integration's plus the state's error
propagated (one difference quotient of M along the worst direction), so multipliers are
accurate to about that times the condition of their eigenproblem.  Stability: every
|λ| ≤ 1 + δ with δ = max(100 × the monodromy's error, 1e-9) (an undamped orbit's
multipliers lie on the unit circle up to rounding); the slow frequency of a stable pair
e^(±iΩT) is Ω = |arg λ| / T, which resolves Ω in [0, ω/2] (the Floquet convention of
:mod:`kapitza.floquet`).

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
import warnings

import numpy as np

from .._arguments import whole_number
from .._deprecation import renamed_keywords
from ..floquet import SYMMETRY_RTOL, shoot, symmetry_defect
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
    whole_number(periods, "periods", 1, integral_floats=True)
    return int(periods) * 2 * math.pi / w


def _start(system, params, about, frequency):
    """The first guess [q, q̇] and whether it was given at rest (coordinates only)."""
    n = system.n_dof
    if about is None:
        from ..averaging import average
        avg = average(system, frequency=frequency)
        eq = avg.equilibria(params)
        stable = [q for q in eq if avg.slow_modes(params, q, warn=False).stable]
        if len(stable) != 1:
            raise ValueError(
                f"periodic_orbit: averaging finds {len(stable)} stable slow equilibria "
                f"({[np.round(q, 6).tolist() for q in stable]}; all: "
                f"{[np.round(q, 6).tolist() for q in eq]}); pass about=... (coordinates, or the "
                "state [q, q̇] at t = 0) to choose the orbit.")
        about = stable[0]
    y = np.asarray(about, dtype=float).reshape(-1)
    at_rest = y.size == n
    if at_rest:
        y = np.concatenate([y, np.zeros(n)])
    if y.size != 2 * n or not np.all(np.isfinite(y)):
        raise ValueError(f"about must be {n} finite coordinates or the state [q, q̇] "
                         f"({2 * n} numbers), got {about!r}.")
    return y, at_rest


def _persists(system, p, y, T):
    """Whether the rest state y = [q, 0] is an equilibrium at every phase of the drive."""
    n = system.n_dof
    if np.any(y[n:] != 0.0):
        return False
    kernels = system.kernels
    W = kernels.work_array()
    scale = 0.0
    for t in np.linspace(0.0, T, 9)[:-1]:
        out = np.empty(2 * n)
        if kernels.rhs(float(t), y, p, out, W) != 0:
            return False
        scale = max(scale, float(np.max(np.abs(out[n:]))))
    return scale <= 1e-12


def _symmetry_center(system, p, y, at_rest, T, periods, symmetry):
    """The centre of the half-period symmetry to shoot with, or None (the full map).

    ``"auto"``: the guess's coordinates where the guess is at rest, the vector field has the
    symmetry about them (tested) and ``periods`` is odd; ``None``/``False``: never;
    coordinates: that centre, which must pass the test (else ValueError)."""
    n = system.n_dof
    if symmetry is None or symmetry is False:
        return None
    if isinstance(symmetry, str):
        if symmetry != "auto":
            raise ValueError(f"symmetry must be 'auto', None or the centre's {n} coordinates, "
                             f"got {symmetry!r}.")
        if not at_rest or periods % 2 == 0:
            return None
        center = y[:n].copy()
        defect = symmetry_defect(system, p, center, T)
        return center if defect <= SYMMETRY_RTOL else None
    center = np.asarray(symmetry, dtype=float).reshape(-1)
    if center.size != n or not np.all(np.isfinite(center)):
        raise ValueError(f"symmetry must be 'auto', None or the centre's {n} coordinates, "
                         f"got {symmetry!r}.")
    if periods % 2 == 0:
        raise ValueError(f"symmetry={center.tolist()}: an orbit of an even number of periods "
                         f"(periods = {periods}) cannot have the half-period symmetry "
                         "y(t + periods·T/2) = S y(t) (it would repeat after periods/2 · T); "
                         "pass symmetry=None.")
    defect = symmetry_defect(system, p, center, T)
    if not defect <= SYMMETRY_RTOL:
        raise ValueError(
            f"symmetry={center.tolist()}: the vector field does not have the half-period "
            f"reflection symmetry f(2c − q, −q̇, t + T/2) = −f(q, q̇, t) about this centre "
            f"(relative defect {defect:.3g} at random states); pass symmetry=None (or "
            "'auto') to shoot on the full period map.")
    return center


def periodic_orbit(system, params, about=None, *, frequency="omega", periods=1,
                   symmetry="auto", tol=1e-10, max_iterations=40, max_steps=1 << 16,
                   **old_keywords) -> PeriodicOrbit:
    """The T-periodic (or nT-periodic) orbit of a driven system by Newton shooting.

    Parameters
    ----------
    system : lagrange_core.System
        Unconstrained; its explicit time dependence periodic in ``params[frequency] · t``.
    params : dict
        Parameter values (scalars) by name.
    about : array_like, optional
        The orbit asked for: its coordinates q at rest (the slow state; e.g. an equilibrium
        of averaging) or the full state [q, q̇] at t = 0 near the orbit; by default the
        single stable slow equilibrium of first-order averaging.  (``guess=`` before 0.2.)
    frequency : str
        The drive's angular-frequency parameter (rad/s); T = 2π/ω.
    periods : int
        Look for an orbit of period ``periods`` · T (subharmonic).
    symmetry : "auto", None or array_like
        The half-period reflection symmetry y(t + T/2) = S y(t), S y = (2c − q, −q̇):
        ``"auto"`` shoots for the symmetric orbit about ``about`` where ``about`` is given
        at rest, ``periods`` is odd and the vector field has the symmetry about it
        (f(S y, t + T/2) = −f(y, t), tested at random states; the horizontal drive about
        θ = 0 or π); coordinates c declare the centre (an error if the field lacks the
        symmetry there; useful with a full-state ``about``); ``None`` always shoots the
        full period map (e.g. for an asymmetric orbit near a symmetric centre).
    tol : float
        Residual of the shooting equations ≤ tol · max(1, |y0|); the flow is integrated to
        tol/100.
    max_iterations : int
        Newton steps before giving up (ValueError).
    max_steps : int
        Most fixed steps of one flow over the interval shot (the step count doubles until
        two counts agree to tol/100; an orbit that smooth needs a few hundred per period).
        A trial state whose flow needs more, or diverges, is a rejected Newton step
        (halved); this bounds one flow to about a second for a one-degree-of-freedom system.

    Returns
    -------
    kapitza.results.PeriodicOrbit
        ``error_estimate`` bounds the error of the state (‖J⁻¹‖ × (residual + flow error),
        J the Jacobian of the equations shot) and of the monodromy's entries (the larger);
        ``method`` says which map was shot and, where it is ill-conditioned, by how much.

    Raises
    ------
    ValueError
        Bad input, or Newton's method failing (no orbit near the guess; a multiplier at
        +1 of the map shot, where the orbit is not isolated) — the message says which.

    Warns
    -----
    RuntimeWarning
        Where the equations shot are so ill-conditioned (a multiplier near +1 with no
        symmetric formulation) that the state's error bound exceeds √tol · max(1, |y0|).
    """
    if old_keywords:
        if "guess" in old_keywords and about is not None:
            raise TypeError("kapitza.periodic_orbit: got both about and guess= (deprecated); "
                            "pass only about.")
        old_keywords = renamed_keywords("kapitza.periodic_orbit", old_keywords,
                                        {"guess": "about"}, stacklevel=4)
        about = old_keywords.pop("about", about)
        if old_keywords:
            raise TypeError(f"periodic_orbit() got unexpected keyword arguments "
                            f"{sorted(old_keywords)}.")
    params = dict(params)
    for k, v in params.items():
        if np.ndim(v) != 0:
            raise ValueError(f"periodic_orbit takes scalar parameters; {k!r} is an array.")
    if system.n_constraints:
        raise ValueError("periodic_orbit: constrained systems are not supported; state the "
                         "system in independent coordinates.")
    T = _period(system, params, frequency, periods)
    p = system.parameter_array(params)
    y, at_rest = _start(system, params, about, frequency)
    n = system.n_dof
    if _persists(system, p, y, T):
        from ..floquet import floquet_point
        fr = floquet_point(system, params, y[:n], frequency=frequency, tol=tol)
        return _result(system, params, y, T, periods, fr.multipliers, None, 0.0,
                       float(fr.error_estimate), float(fr.error_estimate), 0,
                       "equilibrium that persists under the drive (kapitza.floquet_point)",
                       condition=math.nan, flags=tuple(fr.flags),
                       decided=(bool(fr.stable), fr.omega_slow))
    center = _symmetry_center(system, p, y, at_rest, T, int(periods), symmetry)
    shot = shoot(system, p, y, T, center=center, tol=tol, max_iterations=max_iterations,
                 max_steps=max_steps)
    y = shot.state
    if shot.symmetric:
        method = (f"Newton shooting on the half-period map for the orbit symmetric about "
                  f"q = {np.round(center, 12).tolist()} (y(t + T/2) = (2c − q, −q̇)(t))")
    else:
        method = "Newton shooting on the period map"
    flags: tuple[str, ...] = ()
    scale = max(1.0, float(np.max(np.abs(y))))
    if not shot.state_error <= math.sqrt(tol) * scale:
        kind = "half-period" if shot.symmetric else "period"
        why = (f"ill-conditioned: ‖J⁻¹‖ = {shot.condition:.3g} for the {kind} map's shooting "
               f"equations (a multiplier near +1: a bifurcation), so the state is known only "
               f"to {shot.state_error:.3g} (residual {shot.residual:.3g}, flow error "
               f"{shot.flow_error:.3g})")
        hint = ("" if shot.symmetric else
                "; if the orbit asked for is symmetric under q → 2c − q, t → t + T/2, pass "
                "symmetry=c (or about at rest) to shoot the half-period map, which stays "
                "regular at the symmetry-breaking pitchfork")
        flags = (why,)
        method += f" ({why})"
        warnings.warn(f"periodic_orbit: {why}{hint}.", RuntimeWarning, stacklevel=2)
    error = max(shot.state_error, shot.monodromy_error)
    return _result(system, params, y, T, periods, shot.multipliers, shot.monodromy,
                   shot.residual, error, shot.monodromy_error, shot.iterations, method,
                   condition=shot.condition, flags=flags)


def _result(system, params, y, T, periods, mult, M, res, err, monodromy_err, iterations,
            method, *, condition, flags, decided=None):
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
    delta = max(100.0 * monodromy_err, 1e-9)
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
        error_estimate=float(err), iterations=int(iterations), method=method,
        condition=float(condition), flags=tuple(flags))
