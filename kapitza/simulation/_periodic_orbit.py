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
----------------------------------------------------------
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

Long orbits (``periods`` ≥ 4, or where one flow over 2–3 periods fails or its Jacobian
grows beyond 1e3) are shot by multiple shooting: one segment per drive period, Newton on
the block-bordered system of all segments, the monodromy the product of the segments'
Jacobians (one flow over P periods must converge in its Jacobian too, which its rounding
floor forbids from a few dozen periods on).  A rotating orbit, q(t + P T) = q(t) + 2π k
(``winding=k``: a pendulum whirling in step with the drive), is shot with that shift.

Accuracy: the residual |G| ≤ ``tol`` · max(1, |y0|), the flows integrated to tol/100
(``tol=0``: Newton goes on until a step no longer lowers the residual, the flows at
1e-13).  ``error_estimate`` is a Newton–Kantorovich bound (:mod:`kapitza.floquet._shooting`):
β = ‖J⁻¹‖, η ≥ ‖J⁻¹ G‖ of the exact equations (the flows' step-doubling differences
carried in), K the Lipschitz constant of J measured by differences at the bound's own
scale (× 2); where h = β K η ≤ 1/2 the state is within 2η/(1 + √(1 − 2h)), else no bound
holds: ``error_estimate`` is inf, ``flags`` says why and a RuntimeWarning is raised (the
horizontal drive's hanging orbit shot on the full map at its pitchfork: h = 16, the state
5e-4 rad off, where the linear ‖J⁻¹‖ × residual read 1.9e-4).  A bound above
√tol · max(1, |y0|) is flagged likewise.  Measured on that orbit: bound / true error 1.005
at 0.5 A*, 3.7 at 0.999 A*.  The monodromy's error is its integration error plus its change
over the state's error ball; multipliers are accurate to about that times the condition of
their eigenproblem.  Stability: every |λ| ≤ 1 + δ with δ = max(100 × the monodromy's
error, 1e-9) (an undamped orbit's multipliers lie on the unit circle up to rounding; where
no bound holds, the integration error's δ, flagged); the slow frequency of a stable pair
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

from lagrange_core._compile_notice import declared

from .._arguments import whole_number
from .._deprecation import renamed_keywords
from ..floquet import SYMMETRY_RTOL, shoot, symmetry_defect
from ..results import PeriodicOrbit

__all__ = ["periodic_orbit", "PeriodicOrbit"]

SHOOTING_METHODS = ("auto", "single", "multiple")
#: ``shooting="auto"`` shoots an orbit of this many drive periods or more by multiple
#: shooting (one flow over P periods must converge in its Jacobian too, whose rounding
#: floor grows with P: 1e-11 relative over 64 periods of the damped parametric pendulum)
MULTIPLE_FROM = 4
#: ``shooting="auto"``: a single flow over 2–3 periods whose monodromy has an entry beyond
#: this is shot again by multiple shooting (an unstable orbit's Jacobian grows per period)
SINGLE_GROWTH = 1e3

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


def _winding(n, winding):
    """The winding per coordinate (integers), checked; None for no winding."""
    k = np.asarray(winding, dtype=float).reshape(-1)
    if k.size not in (1, n) or not np.all(np.isfinite(k)) or np.any(k != np.round(k)):
        raise ValueError(f"winding must be a whole number of turns (or one per coordinate, "
                         f"{n} numbers): θ(t + periods·T) = θ(t) + 2π·winding; got "
                         f"{winding!r}.")
    k = np.broadcast_to(k, (n,)).astype(int)
    return k if np.any(k) else None


def _segments(shooting, periods):
    """Segments to shoot: 1 (single) or one per drive period (multiple)."""
    if shooting not in SHOOTING_METHODS:
        raise ValueError(f"shooting must be one of {SHOOTING_METHODS}, got {shooting!r}: "
                         "'auto' (multiple shooting from periods = "
                         f"{MULTIPLE_FROM} on), 'single' (one flow over the whole orbit) or "
                         "'multiple' (one segment per drive period).")
    if shooting == "single":
        return 1
    if shooting == "multiple":
        return periods
    return periods if periods >= MULTIPLE_FROM else 1


def periodic_orbit(system, params, about=None, *, frequency="omega", periods=1,
                   symmetry="auto", winding=0, shooting="auto", tol=1e-10,
                   max_iterations=40, max_steps=1 << 16, **old_keywords) -> PeriodicOrbit:
    """The T-periodic (or nT-periodic, or rotating) orbit of a driven system by Newton
    shooting.

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
    winding : int or sequence of int
        A rotating orbit: q(t + periods·T) = q(t) + 2π·winding (rad; one integer per
        coordinate, or one for all), e.g. a pendulum whirling once per drive period:
        ``winding=1``; 0 (default) for an orbit that returns to itself.  ``about`` is
        then a full state [q, q̇] (a rotating orbit is never at rest); no half-period
        symmetry.  ``q_mean`` and ``amplitude`` are of q(t) − 2π·winding·t/(periods·T),
        the rotation removed.
    shooting : {"auto", "single", "multiple"}
        "single": one flow over the whole orbit; "multiple": one segment per drive period,
        Newton on the block-bordered system of all segments, the monodromy the product of
        the segments' Jacobians — the flow over one period stays well-conditioned where
        one over many periods of an unstable or long orbit is not.  "auto" (default):
        multiple from ``periods`` = 4 on, and where single shooting of 2 or 3 periods
        fails or its monodromy grows beyond 1e3 (an unstable orbit).
    tol : float
        Residual of the shooting equations ≤ tol · max(1, |y|); the flows are integrated
        to tol/100.
    max_iterations : int
        Newton steps before giving up (ValueError).
    max_steps : int
        Most fixed steps of one flow over one segment (the step count doubles until two
        counts agree to tol/100; an orbit that smooth needs a few hundred per period).  A
        trial state whose flow needs more, or diverges, is a rejected Newton step (halved);
        this bounds one flow to about a second for a one-degree-of-freedom system.

    Returns
    -------
    kapitza.results.PeriodicOrbit
        ``error_estimate`` bounds the error of the state and of the monodromy's entries
        (the larger; rad and rad/s mixed): the Newton–Kantorovich bound of
        :mod:`kapitza.floquet._shooting` (β = ‖J⁻¹‖, η ≥ ‖J⁻¹F‖, K the Lipschitz constant
        of J measured at the bound's own scale; error ≤ 2η/(1 + √(1 − 2βKη)) where
        βKη ≤ 1/2), integration errors included.  inf where no bound can be established
        (near a multiplier +1 of the map shot), with the reason in ``flags`` and a
        RuntimeWarning.  ``method`` says which map was shot, how, and where it is
        ill-conditioned, by how much.

    Raises
    ------
    ValueError
        Bad input, or Newton's method failing (no orbit near the guess; a multiplier at
        +1 of the map shot, where the orbit is not isolated) — the message says which.

    Warns
    -----
    RuntimeWarning
        Where no error bound can be established (``error_estimate`` inf), or the bound
        exceeds √tol · max(1, |y0|) (a multiplier near +1 with no symmetric formulation).
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
    if isinstance(tol, bool) or not isinstance(tol, (int, float)) or not 0 <= tol < 1e-2:
        raise ValueError(f"periodic_orbit: tol must be a number in [0, 1e-2) (the residual "
                         f"of the shooting equations relative to max(1, |y|); 0: as far as "
                         f"the flows' rounding allows), got {tol!r}.")
    # a first compile says how long the shooting, the orbit's check and its multipliers
    # compile (declared here, not by a wrapper: the warnings' stacklevels count frames)
    with declared("periodic orbit"):
        T = _period(system, params, frequency, periods)
        periods = int(periods)
        segments = _segments(shooting, periods)
        n = system.n_dof
        turns = _winding(n, winding)
        p = system.parameter_array(params)
        y, at_rest = _start(system, params, about, frequency)
        if turns is not None:
            if symmetry is not None and symmetry is not False and not isinstance(symmetry, str):
                raise ValueError(f"symmetry={symmetry!r} with winding={winding!r}: a rotating "
                                 "orbit has no half-period reflection symmetry; pass "
                                 "symmetry=None (or leave 'auto').")
            symmetry = None
        elif _persists(system, p, y, T):
            from ..floquet import floquet_point
            fr = floquet_point(system, params, y[:n], frequency=frequency,
                               tol=tol if tol > 0 else 1e-12)
            return _result(system, params, y, T, periods, fr.multipliers, None, 0.0,
                           float(fr.error_estimate), float(fr.error_estimate), 0,
                           "equilibrium that persists under the drive (kapitza.floquet_point)",
                           condition=math.nan, flags=tuple(fr.flags),
                           decided=(bool(fr.stable), fr.omega_slow))
        center = _symmetry_center(system, p, y, at_rest, T, periods, symmetry)
        # y(t + periods·T) = y(t) + (2π·winding, 0)
        shift = None if turns is None else np.r_[2 * math.pi * turns, np.zeros(n)]
        drive = T / periods

        def attempt(count):
            return shoot(system, p, y, T, center=center, tol=tol, max_iterations=max_iterations,
                         max_steps=max_steps, segments=count, shift=shift, drive_period=drive)

        try:
            shot = attempt(segments)
        except ValueError:
            if not (shooting == "auto" and segments == 1 and periods > 1):
                raise
            shot = attempt(periods)          # the single flow over 2–3 periods failed
        if (shooting == "auto" and shot.segments == 1 and periods > 1
                and float(np.max(np.abs(shot.monodromy))) > SINGLE_GROWTH):
            try:                             # unstable: the single flow's Jacobian grew too far
                shot = attempt(periods)
            except ValueError:
                pass
        return _report(system, params, shot, center, turns, T, periods, tol)


def _report(system, params, shot, center, turns, T, periods, tol):
    """The PeriodicOrbit of a converged shooting, with its flags and warnings."""
    y = shot.state
    if shot.symmetric:
        method = (f"Newton shooting on the half-period map for the orbit symmetric about "
                  f"q = {np.round(center, 12).tolist()} (y(t + T/2) = (2c − q, −q̇)(t))")
    else:
        method = "Newton shooting on the period map"
    if shot.segments > 1:
        method += (f", multiple shooting over {shot.segments} segments (one per drive "
                   "period; the monodromy the product of theirs)")
    if turns is not None:
        method += (f", rotating: q(t + {periods}T) = q(t) + 2π·{turns.tolist()}")
    flags: tuple[str, ...] = ()
    # the orbit is flagged where its bound exceeds √tol (tol = 0: √1e-10, the floor's
    # acceptance) relative to max(1, |y|)
    scale = max(1.0, float(np.max(np.abs(y))))
    kind = "half-period" if shot.symmetric else "period"
    hint = ("" if shot.symmetric else
            "; if the orbit asked for is symmetric under q → 2c − q, t → t + T/2, pass "
            "symmetry=c (or about at rest) to shoot the half-period map, which stays "
            "regular at the symmetry-breaking pitchfork")
    if not math.isfinite(shot.state_error):
        why = (f"no error bound: {shot.bound_note}; the state may be off by much more than "
               f"the first-order estimate ‖J⁻¹‖ (residual + flow error) = "
               f"{shot.linear_error:.3g}, which is not a bound here (error_estimate = inf; "
               f"stability read from the computed multipliers)")
        flags = (why,)
        method += f" (ill-conditioned: {why})"
        warnings.warn(f"periodic_orbit: {why}{hint}.", RuntimeWarning, stacklevel=3)
    elif not shot.state_error <= math.sqrt(tol if tol > 0 else 1e-10) * scale:
        why = (f"ill-conditioned: ‖J⁻¹‖ = {shot.condition:.3g} for the {kind} map's shooting "
               f"equations (a multiplier near +1: a bifurcation), so the state is known only "
               f"to {shot.state_error:.3g} (residual {shot.residual:.3g}, flow error "
               f"{shot.flow_error:.3g}; Newton–Kantorovich bound)")
        flags = (why,)
        method += f" ({why})"
        warnings.warn(f"periodic_orbit: {why}{hint}.", RuntimeWarning, stacklevel=3)
    error = max(shot.state_error, shot.monodromy_error)
    # the stability margin needs a number: where the monodromy's error is not bounded, its
    # integration error (the decision then rests on the computed multipliers, flagged)
    decide = (shot.monodromy_error if math.isfinite(shot.monodromy_error)
              else shot.integration_error)
    return _result(system, params, y, T, periods, shot.multipliers, shot.monodromy,
                   shot.residual, error, decide, shot.iterations, method,
                   condition=shot.condition, flags=flags, shot=shot, turns=turns,
                   center=center)


def _result(system, params, y, T, periods, mult, M, res, err, monodromy_err, iterations,
            method, *, condition, flags, decided=None, shot=None, turns=None,
            center=None):
    """The PeriodicOrbit: period mean and amplitude from the orbit sampled at 256
    equally spaced times (trapezoid over whole periods: exact for a band-limited orbit);
    after multiple shooting, 64 per segment, each segment from its own state (a long or
    unstable orbit is not followed by one simulation); a rotating orbit's q with its
    rotation 2π·winding·t/T removed.  ``decided`` = (stable, omega_slow) of an analysis that
    already decided them."""
    n = system.n_dof
    qs = _samples(system, params, y, T, shot, center)
    if turns is not None:
        t = np.arange(qs.shape[0]) * (T / qs.shape[0])
        qs = qs - 2 * math.pi * turns[None, :] * t[:, None] / T
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


def _samples(system, params, y, T, shot, center):
    """q at equally spaced times over [0, T) (see :func:`_result`)."""
    n = system.n_dof
    if shot is None or shot.segments == 1:
        ts = np.linspace(0.0, T, 257)
        tr = system.simulate(y[:n], y[n:], (0.0, T), params, t_eval=ts, rtol=1e-12,
                             method="dop853")
        return tr.q[:-1]
    # segment j starts at j τ; a symmetric orbit's segments cover half of it (τ = T/2s)
    tau = (T / 2 if shot.symmetric else T) / shot.segments
    parts = []
    for j, yj in enumerate(shot.segment_states):
        ts = j * tau + np.linspace(0.0, tau, 65)
        tr = system.simulate(yj[:n], yj[n:], (ts[0], ts[-1]), params, t_eval=ts,
                             rtol=1e-12, method="dop853")
        parts.append(tr.q[:-1])
    qs = np.concatenate(parts)
    if shot.symmetric:                  # the second half is the first's image q → 2c − q
        qs = np.concatenate([qs, 2 * np.asarray(center)[None, :] - qs])
    return qs
