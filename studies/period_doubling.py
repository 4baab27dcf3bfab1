"""Period doubling: Feigenbaum's δ from the damped, vertically shaken pendulum.

Question
--------
Does the swinging pendulum on a vertically shaken pivot go to chaos through the same
period-doubling cascade as the logistic map — its doubling amplitudes p_k closing in
geometrically with Feigenbaum's universal ratio δ = 4.669201609… — and how well can the
exact periodic orbits measure δ?

System and path
---------------
The damped pendulum with the pivot driven as y_p = A cos ωt (shared/PHYSICS.md),

    θ̈ = −γ θ̇ − (g − A ω² cos ωt) sin θ / l,

``lagrange_core.problems.driven_pendulum("vertical", damping=True)``, at ω0/ω = 1/2
(ω = 2√(g/l), the principal parametric resonance) and γ/ω = 0.1, with the amplitude A/l
rising.  In the dimensionless form of Kim & Lee, ẍ + 2πγ ẋ + 2π(ω0² − A cos 2πt) sin 2πx = 0
(S.-Y. Kim and K. Lee, "Multiple transitions to chaos in a damped parametrically forced
pendulum", Phys. Rev. E 53, 1579 (1996), arXiv:chao-dyn/9510003; x = θ/2π, time in drive
periods), this is γ_KL = γ/ω = 0.1, ω0,KL = ω0/ω = 0.5, A_KL = A/l.  They describe the
scenario this path follows, which McLaughlin found first (J. B. McLaughlin, "Period-doubling
bifurcations and chaotic motion for a parametrically forced pendulum", J. Stat. Phys. 24,
375 (1981)).  The hanging state loses stability by a period doubling (A/l ≈ 0.1) to a
symmetric swing of period 2T, θ(t + T) = −θ(t). That swing breaks its symmetry (a pitchfork,
A/l ≈ 0.335; a left- and a right-leaning swing). The asymmetric swing then doubles its
period again and again, 2T → 4T → 8T → …, until chaos near A/l ≈ 0.3577.  The amplitudes
p_k where the 2^k T swing doubles to 2^(k+1) T are computed here (p_1: 2T → 4T, …,
p_6: 64T → 128T); the paper gives the scenario, not these numbers.

Method
------
Each doubling is located on the exact periodic orbit, not read off a diagram:

* **Following an orbit.** The 2^k T swing is followed in A by Newton shooting
  (:func:`kapitza.periodic_orbit` with ``periods=2**k``, ``symmetry=None``). The first
  guess at each A is extrapolated from the two nearest solved amplitudes. An answer with a
  multiplier above +1 is the half-period orbit, which is also a fixed point of the longer
  map; it is rejected, and the step is halved.
* **Locating p_k.** The orbit's monodromy M has its multiplier −1 where
  det(M + I) = (1 + λ1)(1 + λ2) = 0. Marching in A brackets the sign change, and
  ``scipy.optimize.brentq`` finds the root.
* **Switching to the 2^(k+1) T orbit.** Just past p_k, at p_k + 0.3 × (the expected gap),
  shooting with ``periods=2**(k+1)`` starts from the old orbit ± ε·v (v the eigenvector of M
  for −1). The first ε whose answer differs from the old orbit and is stable is taken. The
  march for p_(k+1) starts there.

δ_k = (p_(k+1) − p_k) / (p_(k+2) − p_(k+1)), k = 1 … (levels − 2).

Accuracy
--------
The variational flow over 2^k periods has a rounding floor that grows with the orbit's
length (the Jacobian over 64 periods agrees between step doublings only to ~3e-11).  So
the shooting tolerance is 1e-11 · P^1.5 for an orbit of P periods, loosened ×4 where a flow
still does not converge.  The error of each p_k adds:

* the root's bracket;
* the noise in det(M + I) divided by its slope in A. The noise is
  2‖adj(M + I)‖_F × the monodromy's error bound (:attr:`PeriodicOrbit.error_estimate`);
  the slope is the secant across the march's bracket.

The errors of the gaps and ratios follow linearly.  The full run also repeats the
cascade at a 10× looser shooting tolerance and reports the largest shift of any p_k.
That is a measured check of the error bound.

Independent checks (``check``)
------------------------------
1. Direct simulation of the original equation (:meth:`lagrange_core.System.simulate_grid`,
   adaptive DOP853, no shooting). Halfway below each p_k, a start near the 2^k T orbit
   settles to a strobe sequence of period 2^k. Halfway above, it settles to period 2^(k+1).
2. The ratios approach δ within the distance the cascade allows. For the logistic map
   δ_k − δ falls by about δ per level (Feigenbaum 1978).
3. At each p_k the other multiplier is inside the unit circle, and just below p_k the orbit
   is stable: the doublings are the supercritical ones of a stable branch.  The other
   multiplier is also checked against Liouville's formula: det M = e^(−γ P T) for an orbit
   of P periods (the flow's divergence is −γ), so λ2 = −e^(−γ P T) at λ1 = −1.

Figure: the brute-force strobe bifurcation diagram (:func:`kapitza.chaos.bifurcation_diagram`)
over the cascade with the located p_k marked, a zoom on the last doublings, log(p_(k+1) − p_k)
against k (slope −ln δ), and δ_k with its error against Feigenbaum's δ.
"""
from __future__ import annotations

import math
import sys
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd
from _common import main, save_figure, write_table
from scipy.optimize import brentq

import kapitza
from lagrange_core import problems
from lagrange_core.variational import flow

QUESTION = ("Does the damped pendulum on a vertically shaken pivot reach chaos through a "
            "period-doubling cascade whose doubling amplitudes close in with Feigenbaum's "
            "universal ratio δ = 4.6692…, and how precisely do its exact periodic orbits "
            "measure δ?")

#: Doublings located: full size and the tests' reduced size.
LEVELS_FULL, LEVELS_QUICK = 7, 3

#: Feigenbaum's δ for maps with a quadratic maximum (Feigenbaum, J. Stat. Phys. 19, 25
#: (1978); digits from K. Briggs, Math. Comp. 57, 435 (1991)).
FEIGENBAUM_DELTA = 4.669201609102990

L, G = 1.0, 9.81
W0 = math.sqrt(G / L)
OMEGA = 2.0 * W0                   # ω0/ω = 1/2: the principal parametric resonance
GAMMA = 0.1 * OMEGA                # γ/ω = 0.1 (1/s)
T = 2 * math.pi / OMEGA
#: The asymmetric 2T swing is followed from here (A/l; its symmetry broke near 0.335).
A_START = 0.345
#: A start that settles on the asymmetric swing at A_START (θ rad, θ̇ rad/s, at t = 0).
START_STATE = (0.36, 4.5)
#: periodic_orbit's tolerance per period of the orbit shot (× P^1.5, see the module
#: docstring): what its single flow over P periods can meet.
TOL_PER_PERIOD = 2e-9
#: The polish's one-period flows converge to this (step doublings; rounding is ~1e-14).
FLOW_TOL = 1e-13


def _log(msg):
    print(f"period_doubling: {msg}", file=sys.stderr, flush=True)


def pendulum():
    """The damped, vertically driven pendulum (lagrange_core.problems)."""
    return problems.driven_pendulum("vertical", damping=True)


def params(A):
    """The parameters at amplitude A (m; l = 1 m, so A = A/l)."""
    return dict(m=1.0, l=L, g=G, omega=OMEGA, gamma=GAMMA, A=float(A))


# -- the periodic orbits --------------------------------------------------------------------

def shoot(system, A, guess, periods, tol_scale=1.0):
    """:func:`kapitza.periodic_orbit` for the orbit of ``periods`` drive periods near
    ``guess`` at amplitude A, at the tolerance its single flow over P periods can meet
    (TOL_PER_PERIOD · P^1.5), loosened ×4 (up to 3 times) where the flow's step doublings
    still do not converge.  Returns (orbit, tol used)."""
    tol = TOL_PER_PERIOD * tol_scale * periods**1.5
    err = None
    for _ in range(4):
        try:
            orbit = kapitza.periodic_orbit(system, params(A), np.asarray(guess, dtype=float),
                                           periods=periods, symmetry=None, tol=tol)
            return orbit, tol
        except ValueError as e:          # the flow's doublings hit rounding: loosen
            err = e
            if "flow" not in str(e):
                break
            tol *= 4.0
    raise err


def compose(system, A, y0, periods, flow_tol, steps=64):
    """The map over ``periods`` drive periods as the composition of one-period flows
    (:func:`lagrange_core.variational.flow`, each converged to ``flow_tol``).

    Returns (y_end, M, e_y, e_M, steps): the end state, the product M of the one-period
    Jacobians, and the flows' errors carried to the end: e_y = Σ_j ‖X_(P−1)⋯X_(j+1)‖ e_j for
    the state and e_M = Σ_j ‖X_(P−1)⋯X_(j+1)‖ e_j ‖X_(j−1)⋯X_0‖ for M (∞-norms; e_j the
    step-doubling difference of flow j, which bounds both its state and its Jacobian)."""
    p = system.parameter_array(params(A))
    y = np.asarray(y0, dtype=float).copy()
    d = y.size
    Xs, errs, pre_norms = [], [], []
    M = np.eye(d)
    for _ in range(periods):
        fl = flow(system, y, (0.0, T), p, tol=flow_tol, steps=steps)
        steps = max(8, fl.steps // 2)        # the next flow starts one doubling below
        pre_norms.append(float(np.linalg.norm(M, np.inf)))
        Xs.append(fl.jacobian)
        errs.append(fl.error_estimate)
        M = fl.jacobian @ M
        y = fl.y1
    post = np.eye(d)
    e_y = e_M = 0.0
    for j in reversed(range(periods)):
        n_post = float(np.linalg.norm(post, np.inf))
        e_y += n_post * errs[j]
        e_M += n_post * errs[j] * pre_norms[j]
        post = post @ Xs[j]
    return y, M, e_y, e_M, steps


@dataclass(frozen=True)
class Orbit:
    """A periodic orbit of P drive periods at amplitude A, polished: the state at t = 0,
    the monodromy M (the product of the one-period Jacobians), the residual
    |φ_PT(y) − y|∞ and the composed flows' errors (see :func:`compose`)."""

    A: float
    periods: int
    state: np.ndarray
    monodromy: np.ndarray
    residual: float
    flow_error: float
    monodromy_flow_error: float
    shooting_tol: float

    @property
    def multipliers(self) -> np.ndarray:
        lam = np.linalg.eigvals(self.monodromy)
        return lam[np.argsort(-np.abs(lam))]

    @property
    def stable(self) -> bool:
        return bool(np.max(np.abs(self.multipliers)) < 1.0)

    def margin(self) -> float:
        """det(M + I) = (1 + λ1)(1 + λ2): positive while both multipliers are inside,
        zero at the multiplier −1."""
        return float(np.linalg.det(self.monodromy + np.eye(self.monodromy.shape[0])))


def polish(system, A, y0, periods, flow_tol=FLOW_TOL, shooting_tol=math.nan):
    """Newton's method on the composed one-period maps from ``y0`` (an orbit from
    :func:`kapitza.periodic_orbit`), a step halved (up to 6 times) where it does not lower
    the residual, until the residual is below the flows' own error or stops falling: the
    orbit to the rounding floor of its flows, which one flow over P periods cannot reach
    (its Jacobian must converge to tol/100 too).  Returns an :class:`Orbit`; ValueError
    where the residual stays above 1e-8 (no orbit near y0)."""
    state = {"steps": 64}

    def evaluate(y):
        y1, M, e_y, e_M, state["steps"] = compose(system, A, y, periods, flow_tol,
                                                  state["steps"])
        return (Orbit(float(A), int(periods), y.copy(), M, float(np.max(np.abs(y1 - y))), e_y,
                      e_M, shooting_tol), y1 - y)

    best, G = evaluate(np.asarray(y0, dtype=float).copy())
    for _ in range(12):
        dy = -np.linalg.solve(best.monodromy - np.eye(G.size), G)
        lam = 1.0
        for _ in range(7):
            cand, cand_G = evaluate(best.state + lam * dy)
            if cand.residual < best.residual:
                break
            if best.residual <= best.flow_error:
                cand = None                  # at the floor already
                break
            lam *= 0.5
        else:
            cand = None
        if cand is None or not cand.residual < best.residual:
            break
        improvement = best.residual / max(cand.residual, 1e-300)
        best, G = cand, cand_G
        if best.residual <= best.flow_error and improvement < 10.0:
            break                            # at the floor: no more progress to be had
    if not best.residual <= 1e-8:
        raise ValueError(f"period_doubling: the polish of the {periods}T orbit at A = {A!r} "
                         f"stalled at residual {best.residual:.3g}.")
    return best


def orbit_errors(system, orbit, flow_tol=FLOW_TOL):
    """(state error, monodromy error) of a polished orbit: the state's is
    ‖(M − I)⁻¹‖ (residual + e_y); the monodromy's is e_M plus the state's error times
    ‖∂M/∂y‖ (central differences along each coordinate, h = 1e-6)."""
    d = orbit.state.size
    J = orbit.monodromy - np.eye(d)
    state_error = float(np.linalg.norm(np.linalg.inv(J), np.inf)) * (orbit.residual
                                                                      + orbit.flow_error)
    h = 1e-6
    dM = 0.0
    for i in range(d):
        e = np.zeros(d)
        e[i] = h
        Mp = compose(system, orbit.A, orbit.state + e, orbit.periods, flow_tol)[1]
        Mm = compose(system, orbit.A, orbit.state - e, orbit.periods, flow_tol)[1]
        dM = max(dM, float(np.max(np.abs(Mp - Mm))) / (2 * h))
    return state_error, orbit.monodromy_flow_error + state_error * dM


def _real_multiplier_above_one(lam):
    """Whether a real multiplier exceeds +1: the half-period orbit past its own doubling,
    seen on the longer map (λ = μ², μ < −1)."""
    real = np.abs(lam.imag) <= 1e-9 * np.maximum(1.0, np.abs(lam))
    return bool(np.any(real & (lam.real > 1.0 + 1e-6)))


class Branch:
    """The 2^k T swing followed in A: every solved amplitude's polished orbit is kept, and
    the next guess is extrapolated from the two nearest."""

    def __init__(self, system, periods, orbit, tol_scale=1.0, flow_tol=FLOW_TOL):
        self.system, self.periods = system, int(periods)
        self.tol_scale, self.flow_tol = tol_scale, flow_tol
        self.points = {orbit.A: orbit}

    def _guess(self, A):
        near = sorted(self.points, key=lambda a: abs(a - A))[:2]
        if len(near) < 2:
            return self.points[near[0]].state
        a0, a1 = near
        y0, y1 = self.points[a0].state, self.points[a1].state
        return y0 + (y1 - y0) * (A - a0) / (a1 - a0)

    def solve(self, A, guess):
        """periodic_orbit from ``guess``, then the polish."""
        po, tol = shoot(self.system, A, guess, self.periods, self.tol_scale)
        return polish(self.system, A, po.state, self.periods, self.flow_tol, tol)

    def orbit(self, A, depth=0):
        A = float(A)
        if A in self.points:
            return self.points[A]
        orbit = self.solve(A, self._guess(A))
        if _real_multiplier_above_one(orbit.multipliers):
            # landed on the half-period orbit: come closer from the nearest solved point
            if depth >= 8:
                raise RuntimeError(f"period_doubling: the {self.periods}T orbit could not be "
                                   f"followed to A = {A!r} (Newton falls onto the "
                                   f"{self.periods // 2}T orbit).")
            nearest = min(self.points, key=lambda a: abs(a - A))
            self.orbit(0.5 * (nearest + A), depth + 1)
            return self.orbit(A, depth + 1)
        self.points[A] = orbit
        return orbit

    def margin(self, A):
        return self.orbit(A).margin()

    @property
    def tols(self):
        return [o.shooting_tol for o in self.points.values() if math.isfinite(o.shooting_tol)]


def _margin_noise(orbit, monodromy_error):
    """The error of det(M + I) from the monodromy's: d det = tr(adj(M + I) dM), bounded by
    ‖adj(M + I)‖_F ‖dM‖_F ≤ ‖adj(M + I)‖_F · 2 · (the entries' error) for 2 × 2."""
    B = orbit.monodromy + np.eye(2)
    adj = np.array([[B[1, 1], -B[0, 1]], [-B[1, 0], B[0, 0]]])
    return 2.0 * float(np.linalg.norm(adj)) * monodromy_error


def locate_doubling(branch, A_from, step, xtol):
    """The amplitude p where the branch's multiplier reaches −1, marching up from
    ``A_from`` by ``step`` to bracket det(M + I) = 0, then brentq.  Returns a dict with
    p, its error (bracket + noise/slope), the orbit at p and at the bracket's lower end."""
    a, fa = A_from, branch.margin(A_from)
    if not fa > 0:
        raise RuntimeError(f"period_doubling: the {branch.periods}T orbit at A = {a} is not "
                           f"stable (det(M + I) = {fa:.3g}); nothing to march from.")
    marched = 0
    while True:
        b = a + step
        fb = branch.margin(b)
        marched += 1
        if fb < 0:
            break
        if marched > 200:
            raise RuntimeError(f"period_doubling: no multiplier −1 on the {branch.periods}T "
                               f"orbit between {A_from} and {b}.")
        a, fa = b, fb
    slope = (fb - fa) / (b - a)
    p, res = brentq(branch.margin, a, b, xtol=xtol, rtol=4 * np.finfo(float).eps,
                    full_output=True)
    orbit = branch.orbit(p)
    state_error, monodromy_error = orbit_errors(branch.system, orbit, branch.flow_tol)
    noise = _margin_noise(orbit, monodromy_error)
    error = xtol + 4 * np.finfo(float).eps * p + noise / abs(slope)
    return dict(p=p, error=error, orbit=orbit, below=branch.orbit(a), bracket=(a, b),
                slope=slope, noise=noise, state_error=state_error,
                monodromy_error=monodromy_error, iterations=res.iterations, marched=marched)


def loose_shift(system, d):
    """How far p moves when its orbit is recomputed 10× looser in periodic_orbit and 100×
    in the polish's flows: one Newton step on det(M + I) at p with the bracket's slope (the
    function is linear at this scale)."""
    orbit = d["orbit"]
    po, _ = shoot(system, d["p"], orbit.state, orbit.periods, 10.0)
    loose = polish(system, d["p"], po.state, orbit.periods, 100 * FLOW_TOL)
    return -loose.margin() / d["slope"]


def switch(branch, p, orbit_at_p, A_new):
    """The orbit of twice the branch's period born at p, solved at A_new (just past p) from
    the old orbit ± ε v, v the eigenvector of M for −1; the first ε whose answer is stable
    and not the old orbit.  Returns (new Branch, split = max |y_new − y_old|, ε)."""
    system = branch.system
    old = branch.orbit(A_new)
    lam, V = np.linalg.eig(orbit_at_p.monodromy)
    v = np.real(V[:, int(np.argmin(np.abs(lam + 1.0)))])
    v = v / np.max(np.abs(v))
    scale = max(1.0, float(np.max(np.abs(old.state))))
    doubled = Branch(system, 2 * branch.periods, old, branch.tol_scale, branch.flow_tol)
    for eps in np.geomspace(1e-4, 0.3, 15):
        for sign in (1.0, -1.0):
            try:
                new = doubled.solve(A_new, old.state + sign * eps * v)
            except ValueError:
                continue
            split = float(np.max(np.abs(new.state - old.state)))
            if (split > 1e-6 * scale and new.stable
                    and not _real_multiplier_above_one(new.multipliers)):
                return Branch(system, 2 * branch.periods, new, branch.tol_scale,
                              branch.flow_tol), split, eps
    raise RuntimeError(f"period_doubling: no {2 * branch.periods}T orbit found next to the "
                       f"{branch.periods}T orbit at A = {A_new}.")


def first_orbit(system, tol_scale=1.0, flow_tol=FLOW_TOL):
    """The asymmetric 2T swing at A_START: a direct simulation from START_STATE settles on
    it (800 periods), periodic_orbit and the polish make it exact."""
    tr = system.simulate([START_STATE[0]], [START_STATE[1]], (0.0, 800 * T), params(A_START),
                         t_eval=[800 * T], rtol=1e-11, method="dop853")
    y = np.array([tr.q[-1, 0], tr.qdot[-1, 0]])
    po, tol = shoot(system, A_START, y, 2, tol_scale)
    return polish(system, A_START, po.state, 2, flow_tol, tol)


def cascade(system, levels, tol_scale=1.0, flow_tol=FLOW_TOL, log=True):
    """p_1 … p_levels: p_k is where the 2^k T swing doubles to 2^(k+1) T.  Returns one dict
    per doubling (see :func:`locate_doubling`, plus periods, tolerances, the new orbit's
    split, the loose-tolerance shift and times)."""
    branch = Branch(system, 2, first_orbit(system, tol_scale, flow_tol), tol_scale, flow_tol)
    found = []
    A_from = A_START
    gap = (0.3541 - A_START) / FEIGENBAUM_DELTA     # a first scale (the march adapts)
    step = 0.4 * (0.3541 - A_START)
    for k in range(1, levels + 1):
        clock = time.perf_counter()
        xtol = max(1e-15, 1e-10 * gap)
        d = locate_doubling(branch, A_from, step, xtol)
        d.update(k=k, periods=branch.periods, tol_min=min(branch.tols),
                 tol_max=max(branch.tols), evaluations=len(branch.points))
        d["loose_shift"] = loose_shift(system, d)
        if found:
            gap = (d["p"] - found[-1]["p"]) / FEIGENBAUM_DELTA
        found.append(d)
        if k < levels:
            A_from = d["p"] + 0.3 * gap
            branch, split, eps = switch(branch, d["p"], d["orbit"], A_from)
            d.update(next_start=A_from, next_split=split, next_eps=eps)
            step = 0.2 * gap
        d["seconds"] = time.perf_counter() - clock
        if log:
            lam = d["orbit"].multipliers
            _log(f"p_{k} = {d['p']:.15f} ± {d['error']:.1e} ({d['periods']}T orbit, "
                 f"residual {d['orbit'].residual:.0e}, λ = {lam[0].real:+.12f}, "
                 f"{lam[1].real:+.3e}; loose shift {d['loose_shift']:+.1e}; "
                 f"{d['evaluations']} orbits, {d['seconds']:.1f} s)")
    return found


def ratios(p, err):
    """Gaps g_k = p_(k+1) − p_k and ratios δ_k = g_k / g_(k+1), with errors added linearly
    (the p_k's errors are independent bounds)."""
    p, err = np.asarray(p), np.asarray(err)
    g = np.diff(p)
    g_err = err[1:] + err[:-1]
    d = g[:-1] / g[1:]
    d_err = d * (g_err[:-1] / g[:-1] + g_err[1:] / g[1:])
    return g, g_err, d, d_err


def aitken(x):
    """Aitken's Δ² extrapolation of the last three terms of a geometrically converging
    sequence (NaN with fewer than three)."""
    if len(x) < 3:
        return math.nan
    a, b, c = x[-3:]
    den = c - 2 * b + a
    return float(c - (c - b) ** 2 / den) if den != 0 else float(c)


# -- direct simulation ----------------------------------------------------------------------

def strobe_period(system, A, y0, transient, samples, max_period):
    """Simulate from states y0 (V, 2) at amplitudes A (V,) (adaptive DOP853 on the original
    equation, rtol 1e-11), discard ``transient`` drive periods, and return per point the
    least period p ∈ {1, 2, 4, …, max_period} of the strobe sequence (0 if none), the
    sequence's spread at that period and at half of it (rad; θ̇ scaled by T/2π)."""
    A = np.asarray(A, dtype=float)
    y0 = np.asarray(y0, dtype=float)
    pv = {k: v for k, v in params(0.0).items() if k != "A"}
    pv["A"] = A
    kw = dict(method="dop853", rtol=1e-11)
    pre = system.simulate_grid(y0[:, :1], y0[:, 1:], (0.0, transient * T), pv, **kw)
    run = system.simulate_grid(pre.q, pre.qdot, (transient * T, (transient + samples - 1) * T),
                               pv, strobe=T, **kw)
    x = np.concatenate([run.strobe_q, run.strobe_qdot * T / (2 * math.pi)], axis=-1)
    periods, spread, spread_half = [], [], []
    for i in range(A.size):
        xi = x[i]
        found, s, s_half = 0, math.nan, math.nan
        q = 1
        while q <= max_period:
            dq = float(np.max(np.abs(xi[q:] - xi[:-q])))
            if dq < 1e-7:
                found, s = q, dq
                s_half = (float(np.max(np.abs(xi[q // 2:] - xi[:-(q // 2)])))
                          if q > 1 else math.nan)
                break
            q *= 2
        periods.append(found)
        spread.append(s)
        spread_half.append(s_half)
    return np.array(periods), np.array(spread), np.array(spread_half)


# -- the study ------------------------------------------------------------------------------

def run(out: Path, quick: bool = False) -> dict:
    t_start = time.perf_counter()
    system = pendulum()
    levels = LEVELS_QUICK if quick else LEVELS_FULL
    f = {}
    _log(f"cascade: {levels} doublings of the asymmetric swing (ω0/ω = 0.5, γ/ω = 0.1)")
    t0 = time.perf_counter()
    found = cascade(system, levels)
    f["cascade_seconds"] = round(time.perf_counter() - t0, 1)
    p = np.array([d["p"] for d in found])
    p_err = np.array([d["error"] for d in found])
    g, g_err, delta, delta_err = ratios(p, p_err)
    # the measured size of p_k's error: its shift under 10×/100× looser tolerances
    shifts = np.array([d["loose_shift"] for d in found])
    f["loose_tolerance_max_shift_of_p"] = float(np.max(np.abs(shifts)))
    f["loose_tolerance_max_shift_over_error"] = float(np.max(np.abs(shifts) / p_err))

    # direct simulation halfway below and above every p_k
    n = len(found)
    below = np.empty(n)
    above = np.empty(n)
    y_below, y_above = [], []
    for i, d in enumerate(found):
        lower_gap = g[i - 1] if i > 0 else (p[0] - A_START)
        upper_gap = g[i] if i < n - 1 else g[-1] / FEIGENBAUM_DELTA
        below[i] = p[i] - 0.5 * lower_gap
        above[i] = p[i] + 0.5 * upper_gap
        # the 2^k T orbit at both amplitudes (the one below is stable, the one above
        # not), nudged off it along θ
        ob, _ = shoot(system, below[i], d["below"].state, d["periods"])
        oa, _ = shoot(system, above[i], d["orbit"].state, d["periods"])
        y_below.append(ob.state + np.array([1e-3, 0.0]))
        y_above.append(oa.state + np.array([1e-3, 0.0]))
    top = 2 * int(found[-1]["periods"])
    transient = 60 * top if quick else 100 * top
    samples = 4 * top + 1
    t0 = time.perf_counter()
    per, spread, spread_half = strobe_period(
        system, np.concatenate([below, above]), np.array(y_below + y_above), transient,
        samples, 2 * top)
    f["simulation_seconds"] = round(time.perf_counter() - t0, 1)
    per_below, per_above = per[:n], per[n:]

    rows = []
    for i, d in enumerate(found):
        lam = d["orbit"].multipliers
        lam_below = d["below"].multipliers
        rows.append(dict(
            k=d["k"], orbit_periods=d["periods"], p=d["p"], p_error=d["error"],
            gap_to_next=g[i] if i < n - 1 else math.nan,
            gap_error=g_err[i] if i < n - 1 else math.nan,
            delta=delta[i] if i < n - 2 else math.nan,
            delta_error=delta_err[i] if i < n - 2 else math.nan,
            multiplier_at_p=float(lam[np.argmin(np.abs(lam + 1))].real),
            other_multiplier=float(lam[np.argmax(np.abs(lam + 1))].real),
            other_multiplier_abs=float(np.min(np.abs(lam))),
            liouville_other_multiplier=-math.exp(-GAMMA * d["periods"] * T),
            max_abs_multiplier_below=float(np.max(np.abs(lam_below))),
            A_below_bracket=d["bracket"][0], slope_det_M_plus_I=d["slope"],
            det_noise=d["noise"], state_error=d["state_error"],
            monodromy_error=d["monodromy_error"], residual=d["orbit"].residual,
            loose_shift=d["loose_shift"],
            shooting_tol_min=d["tol_min"], shooting_tol_max=d["tol_max"],
            orbits_solved=d["evaluations"], brentq_iterations=d["iterations"],
            seconds=d["seconds"],
            state_theta=float(d["orbit"].state[0]), state_theta_dot=float(d["orbit"].state[1]),
            next_orbit_split=d.get("next_split", math.nan),
            A_sim_below=below[i], sim_period_below=int(per_below[i]),
            sim_spread_below=spread[i],
            A_sim_above=above[i], sim_period_above=int(per_above[i]),
            sim_spread_above=spread[n + i], sim_half_spread_above=spread_half[n + i]))
    table = pd.DataFrame(rows)
    write_table(table, out, "period_doubling")

    f["omega0_over_omega"] = W0 / OMEGA
    f["gamma_over_omega"] = GAMMA / OMEGA
    f["doublings"] = n
    for i, d in enumerate(found):
        k = d["k"]
        f[f"p{k}"] = float(d["p"])
        f[f"p{k}_error"] = float(d["error"])
        f[f"p{k}_orbit_periods"] = int(d["periods"])
        f[f"p{k}_other_multiplier_abs"] = rows[i]["other_multiplier_abs"]
        f[f"p{k}_other_multiplier_minus_liouville"] = (rows[i]["other_multiplier"]
                                                       - rows[i]["liouville_other_multiplier"])
        f[f"p{k}_max_abs_multiplier_below"] = rows[i]["max_abs_multiplier_below"]
        f[f"p{k}_sim_period_below"] = int(per_below[i])
        f[f"p{k}_sim_period_above"] = int(per_above[i])
    for i in range(len(delta)):
        f[f"delta{i + 1}"] = float(delta[i])
        f[f"delta{i + 1}_error"] = float(delta_err[i])
    f["last_delta"] = float(delta[-1])
    f["last_delta_error"] = float(delta_err[-1])
    f["last_delta_minus_feigenbaum"] = float(delta[-1] - FEIGENBAUM_DELTA)
    f["feigenbaum_delta"] = FEIGENBAUM_DELTA
    if len(delta) >= 3:
        f["delta_aitken"] = aitken(delta)
        f["delta_aitken_minus_feigenbaum"] = f["delta_aitken"] - FEIGENBAUM_DELTA
    if len(delta) >= 2:
        dev = np.abs(delta - FEIGENBAUM_DELTA)
        f["delta_deviation_ratios"] = ", ".join(f"{r:.2f}" for r in dev[:-1] / dev[1:])
    # the accumulation point: p_∞ = p_n + g_(n−1) / (δ − 1) with the last ratio
    f["p_infinity_estimate"] = float(p[-1] + g[-1] / (delta[-1] - 1.0))
    f["slope_log_gap"] = float(np.polyfit(np.arange(1, len(g) + 1), np.log(g), 1)[0])
    f["minus_ln_feigenbaum"] = -math.log(FEIGENBAUM_DELTA)
    f["max_p_error"] = float(np.max(p_err))

    t0 = time.perf_counter()
    diagram = brute_force_diagram(system, p, quick)
    f["diagram_seconds"] = round(time.perf_counter() - t0, 1)
    save_figure(figure(diagram, table, p, p_err, g, g_err, delta, delta_err, f), out,
                "period_doubling")
    f["wall_seconds"] = round(time.perf_counter() - t_start, 1)
    return f


def brute_force_diagram(system, p, quick):
    """The strobe diagram by brute force over the cascade (kapitza.chaos): starts on the
    asymmetric swing and its mirror image, transient discarded."""
    from kapitza.chaos import bifurcation_diagram as diagram
    hi = p[-1] + 2.0 * (p[-1] - p[-2]) if len(p) > 1 else p[-1] + 0.001
    values = np.linspace(0.3505, max(hi, 0.3580), 80 if quick else 700)
    y = np.array(START_STATE)
    q0 = np.array([[y[0]], [-y[0]], [y[0] + 0.1]])
    v0 = np.array([[y[1]], [-y[1]], [y[1]]])
    _log(f"bifurcation diagram: {values.size} amplitudes × {len(q0)} starts")
    return diagram(system, {k: v for k, v in params(0.0).items() if k != "A"},
                   parameter="A", values=values, q0=q0, qdot0=v0,
                   periods=32 if quick else 128, transient=300 if quick else 1500,
                   angles=True, rtol=1e-9)


def figure(diagram, table, p, p_err, g, g_err, delta, delta_err, f):
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(2, 2, figsize=(13, 9))
    fig.suptitle("Period doubling of the damped, vertically shaken pendulum "
                 "(ω0/ω = 0.5, γ/ω = 0.1): the swing's cascade to chaos")
    A = diagram.values
    q = diagram.q_wrapped[..., 0]                      # (V, S, K)
    # keep swings only (a run that goes over the top winds; draw it faintly)
    wind = np.abs(diagram.q[..., -1, 0] - diagram.q[..., 0, 0]) > math.pi
    for zoom, a in ((False, ax[0, 0]), (True, ax[0, 1])):
        for s in range(q.shape[1]):
            swing = ~wind[:, s]
            AA = np.repeat(A[:, None], q.shape[2], axis=1)
            a.plot(AA[swing].ravel(), q[swing, s].ravel(), ",", color="k", alpha=0.5)
        for k, pk in enumerate(p, start=1):
            a.axvline(pk, color="C3", lw=0.7, alpha=0.8)
            if not zoom or k >= 3:
                a.text(pk, 1.0, f" p{k}", transform=a.get_xaxis_transform(), color="C3",
                       fontsize=8, va="bottom", ha="center")
        a.set_xlabel("A / l")
        a.set_ylabel("θ at t = nT (rad)")
    ax[0, 0].set_title("strobe samples after the transient (3 starts); red: located p_k",
                       fontsize=10)
    lo = p[1] - 0.3 * (p[1] - p[0]) if len(p) > 1 else p[0] - 1e-3
    hi = p[-1] + 2.5 * (p[-1] - p[-2]) if len(p) > 1 else p[0] + 1e-3
    ax[0, 1].set_xlim(lo, hi)
    sel = (A >= lo) & (A <= hi)
    qs = q[sel][~wind[sel]]
    if qs.size:
        ax[0, 1].set_ylim(np.nanmin(qs) - 0.02, np.nanmax(qs) + 0.02)
    ax[0, 1].set_title("zoom on the last doublings", fontsize=10)
    ax[0, 0].set_xlim(A[0], A[-1])

    k = np.arange(1, len(g) + 1)
    a = ax[1, 0]
    a.errorbar(k, g, yerr=g_err, fmt="o", color="C0", label="p_(k+1) − p_k (exact orbits)")
    a.set_yscale("log")
    line = g[0] * FEIGENBAUM_DELTA ** -(k - 1.0)
    a.plot(k, line, "--", color="C3", lw=1, label="slope −ln δ (Feigenbaum)")
    a.set_xlabel("k")
    a.set_ylabel("p_(k+1) − p_k (A / l)")
    a.set_xticks(k)
    a.legend(fontsize=9)
    a.set_title(f"gaps shrink by δ: fitted slope {f['slope_log_gap']:.4f}, "
                f"−ln δ = {-math.log(FEIGENBAUM_DELTA):.4f}", fontsize=10)

    a = ax[1, 1]
    kd = np.arange(1, len(delta) + 1)
    a.errorbar(kd, delta, yerr=delta_err, fmt="o", color="C0", capsize=3,
               label="δ_k = (p_(k+1) − p_k)/(p_(k+2) − p_(k+1))")
    a.axhline(FEIGENBAUM_DELTA, color="C3", lw=1, label=f"δ = {FEIGENBAUM_DELTA:.6f}")
    if "delta_aitken" in f:
        a.plot([kd[-1] + 0.5], [f["delta_aitken"]], "s", color="C2",
               label=f"Aitken Δ² of the last three: {f['delta_aitken']:.5f}")
    a.set_xlabel("k")
    a.set_ylabel("δ_k")
    a.set_xticks(kd)
    a.legend(fontsize=9)
    a.set_title(f"last ratio {delta[-1]:.5f} ± {delta_err[-1]:.1e}", fontsize=10)
    fig.tight_layout()
    return fig


def check(findings: dict, quick: bool) -> None:
    f = findings
    n = f["doublings"]
    assert n == (LEVELS_QUICK if quick else LEVELS_FULL)
    for k in range(1, n + 1):
        # (3) a supercritical doubling of a stable orbit: stable just below p_k, and at p_k
        # the other multiplier well inside, equal to Liouville's −e^(−γ P T) (det M over P
        # periods; λ1 = −1) to the monodromy's accuracy
        assert f[f"p{k}_max_abs_multiplier_below"] < 1.0, k
        assert f[f"p{k}_other_multiplier_abs"] < 0.5, k
        assert abs(f[f"p{k}_other_multiplier_minus_liouville"]) < 1e-6, k
        # (1) direct simulation, no shooting: period 2^(k−1) below p_k, 2^k above
        assert f[f"p{k}_sim_period_below"] == 2 ** k, k
        assert f[f"p{k}_sim_period_above"] == 2 ** (k + 1), k
        # the p_k are known far better than the gaps between them
        assert f[f"p{k}_error"] < 1e-6, k
    # the doublings come in order, closing in
    ps = [f[f"p{k}"] for k in range(1, n + 1)]
    assert all(b > a for a, b in zip(ps, ps[1:]))
    # (2) the ratios approach Feigenbaum's δ.  The first ratio of a cascade is not yet
    # universal (logistic map: 4.23, 4.55, 4.65, 4.664, 4.668 …, errors falling ~δ×
    # per level); the bounds are the measured distance with a margin, and each ratio's
    # own error is far smaller than its distance from δ.
    d1 = f["delta1"]
    assert abs(d1 - FEIGENBAUM_DELTA) < 0.6, d1
    if not quick:
        ds = [f[f"delta{i}"] for i in range(1, n - 1)]
        dev = [abs(d - FEIGENBAUM_DELTA) for d in ds]
        assert dev[-1] < dev[0] / 10, dev
        assert abs(f["last_delta"] - FEIGENBAUM_DELTA) < 0.02, f["last_delta"]
        assert f["last_delta_error"] < 1e-3, f["last_delta_error"]
        assert abs(f["slope_log_gap"] + math.log(FEIGENBAUM_DELTA)) < 0.1
    # the error bound of p_k holds against 10×/100× looser tolerances
    assert f["loose_tolerance_max_shift_over_error"] < 1.0


if __name__ == "__main__":
    sys.exit(main(Path(__file__).stem, run))     # __name__ is "__main__" here
