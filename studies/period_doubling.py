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
period again and again, 2T → 4T → 8T → …, until chaos near A/l ≈ 0.35771.  The amplitudes
p_k where the 2^k T swing doubles to 2^(k+1) T are computed here (p_1: 2T → 4T, …,
p_8: 256T → 512T); the paper gives the scenario, not these numbers.

Method
------
Each doubling is located on the exact periodic orbit, not read off a diagram:

* **An orbit.** :func:`kapitza.periodic_orbit` (``periods=2**k``, ``symmetry=None``,
  ``tol=0``) shoots the 2^k T swing from a guess extrapolated from the two nearest solved
  amplitudes.  From 4 periods on it shoots by *multiple shooting*: one segment per drive
  period, each a flow of :func:`lagrange_core.variational.flow` converged to 1e-13, Newton
  on the block-bordered system of all segments, the monodromy M the product of the
  segments' Jacobians — one flow over P periods cannot converge in its Jacobian (its
  rounding floor grows with P: ~1e-11 relative over 64 periods, no convergence over 256).
  ``tol=0`` goes on until a Newton step no longer lowers the residual (1e-15 … 1e-14).
  An answer with a real multiplier above +1 is the half-period orbit (also a fixed point
  of the longer map): it is rejected and the step halved.
* **p_k.** The monodromy has the multiplier −1 where det(M + I) = (1 + λ1)(1 + λ2) = 0:
  marching in A brackets the sign change, ``scipy.optimize.brentq`` the root.
* **The next orbit.** Just past p_k (p_k + 0.3 × the expected gap) the 2^(k+1) T orbit is
  the attractor.  A simulation from the old orbit nudged by 1e-6 along the eigenvector of
  M for −1 settles on it (150 of its periods); shooting and the polish make it exact.

δ_k = (p_(k+1) − p_k) / (p_(k+2) − p_(k+1)).

Accuracy
--------
* **The measured error of p_k**: the bracket plus the largest shift of p_k when its orbit is
  computed with three other discretizations: the orbit polished on the composition of P
  one-period flows at 100, 192 and 256 fixed steps per period (the study's own Newton,
  :func:`polish`, independent of the library's multiple shooting) instead of the
  adaptive 128.  Every rounding and the orbit's Newton path change.  δ_k's error follows
  linearly.
* **The propagated bound**: the bracket plus the noise of det(M + I) over its slope.  The
  noise is 2‖adj(M + I)‖_F times the monodromy's error, which is the one-period flows'
  errors carried through the products plus the state's error ‖(M − I)⁻¹‖ (residual + flow
  error) times ‖∂M/∂y‖ (the composition of one-period flows from the orbit's state).  It
  multiplies worst cases and grows with P: it no longer bounds the gaps from p_7 on.  It
  is tabulated beside the measured error.

Independent checks (``check``)
------------------------------
1. Direct simulation of the original equation (:meth:`lagrange_core.System.simulate_grid`,
   adaptive DOP853, no shooting). Halfway below each p_k, a start near the 2^k T orbit
   settles to a strobe sequence of period 2^k. Halfway above, it settles to period 2^(k+1).
2. The ratios approach δ, and their distance from δ shrinks by about δ per level in the
   last ones, as the renormalization theory says (Feigenbaum 1978).
3. At each p_k the other multiplier is inside the unit circle, and just below p_k the orbit
   is stable: the doublings are the supercritical ones of a stable branch.  The other
   multiplier is also checked against Liouville's formula: det M = e^(−γ P T) for an orbit
   of P periods (the flow's divergence is −γ), so λ2 = −e^(−γ P T) at λ1 = −1.

Figure: the brute-force strobe bifurcation diagrams (:func:`kapitza.chaos.bifurcation_diagram`)
over the cascade and zoomed on its last doublings, with the located p_k; p_(k+1) − p_k
against k (slope −ln δ); |δ_k − δ| against k.
"""
from __future__ import annotations

import math
import sys
import time
from pathlib import Path

import numpy as np
import pandas as pd
from scipy.optimize import brentq

import kapitza
from lagrange_core import problems
from lagrange_core.variational import flow

from _common import layout, main, save_figure, write_table

QUESTION = ("Does the damped pendulum on a vertically shaken pivot reach chaos through a "
            "period-doubling cascade whose doubling amplitudes close in with Feigenbaum's "
            "universal ratio δ = 4.6692…, and how precisely do its exact periodic orbits "
            "measure δ?")

#: Doublings located: full size and the tests' reduced size.
LEVELS_FULL, LEVELS_QUICK = 8, 3

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
#: The composed one-period flows (the error analysis) converge to this (step doublings;
#: rounding is ~1e-14), as the library's segments do with ``tol=0``.
FLOW_TOL = 1e-13
#: Fixed steps per period of the other discretizations that measure p_k's error.
DISCRETIZATIONS = (100, 192, 256)
#: A strobe sequence repeats after q samples when every sample does to this (rad).
SIM_REPEAT = 1e-5


def _log(msg):
    print(f"period_doubling: {msg}", file=sys.stderr, flush=True)


def pendulum():
    """The damped, vertically driven pendulum (lagrange_core.problems)."""
    return problems.driven_pendulum("vertical", damping=True)


def params(A):
    """The parameters at amplitude A (m; l = 1 m, so A = A/l)."""
    return dict(m=1.0, l=L, g=G, omega=OMEGA, gamma=GAMMA, A=float(A))


# -- the periodic orbits --------------------------------------------------------------------

def shoot(system, A, guess, periods):
    """:func:`kapitza.periodic_orbit` for the orbit of ``periods`` drive periods near
    ``guess`` at amplitude A, to the floor of its flows (``tol=0``; multiple shooting from
    4 periods on).  Returns an :class:`Orbit`; ValueError where it fails."""
    orbit = kapitza.periodic_orbit(system, params(A), np.asarray(guess, dtype=float),
                                   periods=periods, symmetry=None, tol=0)
    return Orbit(float(A), int(periods), orbit.state.copy(), orbit.monodromy,
                 float(orbit.residual), math.nan, math.nan, orbit.method)


def compose(system, A, y0, periods, steps=64, fixed=None):
    """The map over ``periods`` drive periods as the composition of one-period flows
    (:func:`lagrange_core.variational.flow`, each converged to FLOW_TOL; or, with
    ``fixed``, each at that fixed number of 8th-order steps, for a second discretization).

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
        if fixed is None:
            fl = flow(system, y, (0.0, T), p, tol=FLOW_TOL, steps=steps)
        else:                                # tol = 1: the first doubling is accepted
            fl = flow(system, y, (0.0, T), p, tol=1.0, steps=fixed // 2)
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


class Orbit:
    """A periodic orbit of P drive periods at amplitude A: the state at t = 0, the
    monodromy M (the product of the one-period Jacobians), the residual of the equations
    shot, the composed flows' errors (see :func:`compose`; NaN for an orbit from
    :func:`shoot`, whose errors :func:`orbit_errors` composes where they are needed) and
    how it was found.  (A plain class: tests/test_studies.py loads the study without
    registering it in sys.modules, which a dataclass needs.)"""

    __slots__ = ("A", "periods", "state", "monodromy", "residual", "flow_error",
                 "monodromy_flow_error", "method")

    def __init__(self, A, periods, state, monodromy, residual, flow_error,
                 monodromy_flow_error, method):
        self.A, self.periods, self.state, self.monodromy = A, periods, state, monodromy
        self.residual, self.flow_error = residual, flow_error
        self.monodromy_flow_error, self.method = monodromy_flow_error, method

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


def polish(system, A, y0, periods, fixed=None):
    """The study's own Newton, for the error check of other discretizations (the orbits
    themselves come from :func:`shoot`): Newton's method on the composed one-period maps
    from ``y0``, a step halved (up to 6 times) where it does not lower the residual, until
    the residual is below the flows' own error or stops falling.  ``fixed``: that many
    steps per period (:func:`compose`).  Returns an :class:`Orbit`; ValueError where the
    residual stays above 1e-8 (no orbit near y0)."""
    state = {"steps": 64}

    def evaluate(y):
        y1, M, e_y, e_M, state["steps"] = compose(system, A, y, periods, state["steps"],
                                                  fixed)
        return (Orbit(float(A), int(periods), y.copy(), M, float(np.max(np.abs(y1 - y))), e_y,
                      e_M, "composed one-period flows"), y1 - y)

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


def orbit_errors(system, orbit):
    """(state error, monodromy error) of an orbit, from the composition of its one-period
    flows from its state (:func:`compose`): the state's is ‖(M − I)⁻¹‖ (|φ_PT(y) − y| +
    e_y); the monodromy's is e_M, plus the gap between the orbit's M and the composed one,
    plus the state's error times ‖∂M/∂y‖ (central differences along each coordinate,
    h = 1e-6)."""
    d = orbit.state.size
    y1, M_c, e_y, e_M, _ = compose(system, orbit.A, orbit.state, orbit.periods)
    residual = float(np.max(np.abs(y1 - orbit.state)))
    J = orbit.monodromy - np.eye(d)
    state_error = float(np.linalg.norm(np.linalg.inv(J), np.inf)) * (residual + e_y)
    e_M += float(np.max(np.abs(M_c - orbit.monodromy)))
    h = 1e-6
    dM = 0.0
    for i in range(d):
        e = np.zeros(d)
        e[i] = h
        Mp = compose(system, orbit.A, orbit.state + e, orbit.periods)[1]
        Mm = compose(system, orbit.A, orbit.state - e, orbit.periods)[1]
        dM = max(dM, float(np.max(np.abs(Mp - Mm))) / (2 * h))
    return state_error, e_M + state_error * dM


def _real_multiplier_above_one(lam):
    """Whether a real multiplier exceeds +1: the half-period orbit past its own doubling,
    seen on the longer map (λ = μ², μ < −1)."""
    real = np.abs(lam.imag) <= 1e-9 * np.maximum(1.0, np.abs(lam))
    return bool(np.any(real & (lam.real > 1.0 + 1e-6)))


class Branch:
    """The 2^k T swing followed in A: every solved amplitude's polished orbit is kept, and
    the next guess is extrapolated from the two nearest."""

    def __init__(self, system, periods, orbit):
        self.system, self.periods = system, int(periods)
        self.points = {orbit.A: orbit}

    def _guess(self, A):
        near = sorted(self.points, key=lambda a: abs(a - A))[:2]
        if len(near) < 2:
            return self.points[near[0]].state
        a0, a1 = near
        y0, y1 = self.points[a0].state, self.points[a1].state
        return y0 + (y1 - y0) * (A - a0) / (a1 - a0)

    def solve(self, A, guess):
        """The orbit near ``guess`` at A (:func:`shoot`: the library's multiple shooting)."""
        return shoot(self.system, A, guess, self.periods)

    def orbit(self, A, depth=0):
        A = float(A)
        if A in self.points:
            return self.points[A]
        try:
            orbit = self.solve(A, self._guess(A))
            jumped = _real_multiplier_above_one(orbit.multipliers)
        except ValueError:
            orbit, jumped = None, True
        if jumped:
            # no orbit from this guess, or the half-period orbit (a fixed point of the
            # longer map too): come closer from the nearest solved amplitude
            if depth >= 8:
                raise RuntimeError(f"period_doubling: the {self.periods}T orbit could not be "
                                   f"followed to A = {A!r}.")
            nearest = min(self.points, key=lambda a: abs(a - A))
            self.orbit(0.5 * (nearest + A), depth + 1)
            return self.orbit(A, depth + 1)
        self.points[A] = orbit
        return orbit

    def margin(self, A):
        return self.orbit(A).margin()

    @property
    def residuals(self):
        return [o.residual for o in self.points.values()]


def _margin_noise(orbit, monodromy_error):
    """The error of det(M + I) from the monodromy's: d det = tr(adj(M + I) dM), bounded by
    ‖adj(M + I)‖_F ‖dM‖_F ≤ ‖adj(M + I)‖_F · 2 · (the entries' error) for 2 × 2."""
    B = orbit.monodromy + np.eye(2)
    adj = np.array([[B[1, 1], -B[0, 1]], [-B[1, 0], B[0, 0]]])
    return 2.0 * float(np.linalg.norm(adj)) * monodromy_error


def locate_doubling(branch, A_from, step, xtol):
    """The amplitude p where the branch's multiplier reaches −1, marching up from
    ``A_from`` by ``step`` to bracket det(M + I) = 0, then brentq.  Returns a dict with
    p, its propagated error bound (bracket + noise/slope), the orbit at p and at the
    bracket's lower end."""
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
    state_error, monodromy_error = orbit_errors(branch.system, orbit)
    noise = _margin_noise(orbit, monodromy_error)
    bound = xtol + 4 * np.finfo(float).eps * p + noise / abs(slope)
    return dict(p=p, error_bound=bound, xtol=xtol + 4 * np.finfo(float).eps * p, orbit=orbit,
                below=branch.orbit(a), bracket=(a, b), slope=slope, noise=noise,
                state_error=state_error, monodromy_error=monodromy_error,
                iterations=res.iterations, marched=marched)


def discretization_shifts(system, d):
    """How far p moves when its orbit is computed with other discretizations: the polish
    with a fixed DISCRETIZATIONS steps per period (the root's computation uses the adaptive
    count, 128 here), then one Newton step on det(M + I) with the bracket's slope (linear at
    this scale).  Every number changes: the steps, the rounding, the orbit's Newton path.
    Returns the shifts (one per discretization)."""
    orbit = d["orbit"]
    shifts = []
    for steps in DISCRETIZATIONS:
        other = polish(system, d["p"], orbit.state, orbit.periods, fixed=steps)
        shifts.append(-other.margin() / d["slope"])
    return np.array(shifts)


def switch(branch, p, orbit_at_p, A_new):
    """The orbit of twice the branch's period born at p, at A_new just past p, where it is
    the attractor: a direct simulation from the old orbit nudged by 1e-6 v (v the
    eigenvector of M for −1) leaves the old orbit, now unstable, and settles on the new
    one (150 of its periods); shooting makes it exact.  Returns (new Branch,
    split = max |y_new − y_old|)."""
    system = branch.system
    old = branch.orbit(A_new)
    lam, V = np.linalg.eig(orbit_at_p.monodromy)
    v = np.real(V[:, int(np.argmin(np.abs(lam + 1.0)))])
    v = v / np.max(np.abs(v))
    periods = 2 * branch.periods
    t_end = 150 * periods * T
    y = old.state + 1e-6 * v
    tr = system.simulate([y[0]], [y[1]], (0.0, t_end), params(A_new), t_eval=[t_end],
                         rtol=1e-12, method="dop853")
    settled = np.array([tr.q[-1, 0], tr.qdot[-1, 0]])
    doubled = Branch(system, periods, old)
    new = doubled.solve(A_new, settled)
    split = float(np.max(np.abs(new.state - old.state)))
    scale = max(1.0, float(np.max(np.abs(old.state))))
    if not (split > 1e-6 * scale and new.stable
            and not _real_multiplier_above_one(new.multipliers)):
        raise RuntimeError(f"period_doubling: the simulation from the {branch.periods}T orbit "
                           f"at A = {A_new} did not settle on a stable {periods}T orbit "
                           f"(split {split:.3g}, multipliers {new.multipliers}).")
    return Branch(system, periods, new), split


def first_orbit(system):
    """The asymmetric 2T swing at A_START: a direct simulation from START_STATE settles on
    it (800 periods), periodic_orbit makes it exact."""
    tr = system.simulate([START_STATE[0]], [START_STATE[1]], (0.0, 800 * T), params(A_START),
                         t_eval=[800 * T], rtol=1e-11, method="dop853")
    y = np.array([tr.q[-1, 0], tr.qdot[-1, 0]])
    return shoot(system, A_START, y, 2)


def cascade(system, levels):
    """p_1 … p_levels: p_k is where the 2^k T swing doubles to 2^(k+1) T.  Returns one dict
    per doubling (see :func:`locate_doubling`, plus periods, tolerances, the new orbit's
    split, the shifts under other discretizations and times)."""
    branch = Branch(system, 2, first_orbit(system))
    found = []
    A_from = A_START
    # a first scale from p_1 ≈ 0.3541 in the brute-force diagram (the march adapts)
    gap = (0.3541 - A_START) / FEIGENBAUM_DELTA
    step = 0.4 * (0.3541 - A_START)
    for k in range(1, levels + 1):
        clock = time.perf_counter()
        xtol = max(1e-16, 1e-12 * gap)
        d = locate_doubling(branch, A_from, step, xtol)
        res = branch.residuals      # periodic_orbit's, to the floor of its flows
        d.update(k=k, periods=branch.periods, residual_max=max(res),
                 evaluations=len(branch.points), method=d["orbit"].method)
        d["shifts"] = discretization_shifts(system, d)
        d["error"] = d["xtol"] + float(np.max(np.abs(d["shifts"])))
        if found:
            gap = (d["p"] - found[-1]["p"]) / FEIGENBAUM_DELTA
        found.append(d)
        if k < levels:
            A_from = d["p"] + 0.3 * gap
            branch, split = switch(branch, d["p"], d["orbit"], A_from)
            d.update(next_start=A_from, next_split=split)
            step = 0.2 * gap
        d["seconds"] = time.perf_counter() - clock
        lam = d["orbit"].multipliers
        _log(f"p_{k} = {d['p']:.15f} ± {d['error']:.1e} ({d['periods']}T orbit, residual "
             f"{d['orbit'].residual:.0e}, λ = {lam[0].real:+.12f}, {lam[1].real:+.3e}; "
             f"bound {d['error_bound']:.0e}; {d['evaluations']} orbits, {d['seconds']:.1f} s)")
    return found


def ratios(p, err):
    """Gaps g_k = p_(k+1) − p_k and ratios δ_k = g_k / g_(k+1), with the p_k's errors
    carried linearly (added, not in quadrature: the worst case)."""
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
    equation, rtol 1e-11; no shooting), discard ``transient`` drive periods, and return per
    point the least period q ∈ {1, 2, 4, …, max_period} with every strobe sample repeating
    after q samples to SIM_REPEAT (0 if none), and the spreads max |x_(j+q) − x_j| at q and
    at q/2 (x = (θ, θ̇ T/2π), rad).

    The repeat is not to rounding: the adaptive steps differ from period to period, and
    the error of each is carried along the long orbit (measured floor ~1e-7 rad for the
    256T orbit, against a half-period spread ≥ 1e-4)."""
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
    for xi in x:
        found, s, s_half = 0, math.nan, math.nan
        q = 1
        while q <= max_period and 2 * q < len(xi):
            dq = float(np.max(np.abs(xi[q:] - xi[:-q])))
            if dq < SIM_REPEAT:
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
    n = len(found)
    p = np.array([d["p"] for d in found])
    p_err = np.array([d["error"] for d in found])
    p_bound = np.array([d["error_bound"] for d in found])
    g, g_err, delta, delta_err = ratios(p, p_err)
    _, g_bound, _, delta_bound = ratios(p, p_bound)

    # direct simulation halfway below and above every p_k
    below, above = np.empty(n), np.empty(n)
    starts = []
    for i in range(n):
        below[i] = p[i] - 0.5 * (g[i - 1] if i > 0 else p[0] - A_START)
        above[i] = p[i] + 0.5 * (g[i] if i < n - 1 else g[-1] / FEIGENBAUM_DELTA)
    for which in ("below", "orbit"):
        # the 2^k T orbit near there (at the bracket's lower end, at p_k), nudged along θ
        starts += [d[which].state + np.array([1e-5, 0.0]) for d in found]
    top = 2 * int(found[-1]["periods"])
    t0 = time.perf_counter()
    per, spread, spread_half = strobe_period(
        system, np.concatenate([below, above]), np.array(starts),
        60 * top, 4 * top + 1, 2 * top)
    f["simulation_seconds"] = round(time.perf_counter() - t0, 1)

    rows = []
    for i, d in enumerate(found):
        lam, lam_below = d["orbit"].multipliers, d["below"].multipliers
        rows.append(dict(
            k=d["k"], orbit_periods=d["periods"], p=d["p"], p_error=d["error"],
            p_error_bound=d["error_bound"],
            gap_to_next=g[i] if i < n - 1 else math.nan,
            gap_error=g_err[i] if i < n - 1 else math.nan,
            delta=delta[i] if i < n - 2 else math.nan,
            delta_error=delta_err[i] if i < n - 2 else math.nan,
            delta_error_bound=delta_bound[i] if i < n - 2 else math.nan,
            multiplier_at_p=float(lam[np.argmin(np.abs(lam + 1))].real),
            other_multiplier=float(lam[np.argmax(np.abs(lam + 1))].real),
            liouville_other_multiplier=-math.exp(-GAMMA * d["periods"] * T),
            max_abs_multiplier_below=float(np.max(np.abs(lam_below))),
            A_below_bracket=d["bracket"][0], A_above_bracket=d["bracket"][1],
            slope_det_M_plus_I=d["slope"], residual=d["orbit"].residual,
            state_error_bound=d["state_error"], monodromy_error_bound=d["monodromy_error"],
            det_noise_bound=d["noise"],
            **{f"shift_{s}_steps": float(v) for s, v in zip(DISCRETIZATIONS, d["shifts"],
                                                                strict=True)},
            largest_residual_on_branch=d["residual_max"], orbit_method=d["method"],
            orbits_solved=d["evaluations"],
            brentq_iterations=d["iterations"],
            seconds=d["seconds"],
            state_theta=float(d["orbit"].state[0]), state_theta_dot=float(d["orbit"].state[1]),
            next_orbit_split=d.get("next_split", math.nan),
            A_sim_below=below[i], sim_period_below=int(per[i]), sim_spread_below=spread[i],
            sim_half_spread_below=spread_half[i],
            A_sim_above=above[i], sim_period_above=int(per[n + i]),
            sim_spread_above=spread[n + i], sim_half_spread_above=spread_half[n + i]))
    table = pd.DataFrame(rows)
    write_table(table, out, "period_doubling")

    f["omega0_over_omega"] = W0 / OMEGA
    f["gamma_over_omega"] = GAMMA / OMEGA
    f["doublings"] = n
    for r in rows:
        k = r["k"]
        f[f"p{k}"] = r["p"]
        f[f"p{k}_error"] = r["p_error"]
        f[f"p{k}_error_bound"] = r["p_error_bound"]
        f[f"p{k}_orbit_periods"] = r["orbit_periods"]
        f[f"p{k}_multiplier_plus_one"] = r["multiplier_at_p"] + 1.0
        f[f"p{k}_other_multiplier"] = r["other_multiplier"]
        f[f"p{k}_other_multiplier_minus_liouville"] = (r["other_multiplier"]
                                                       - r["liouville_other_multiplier"])
        f[f"p{k}_max_abs_multiplier_below"] = r["max_abs_multiplier_below"]
        f[f"p{k}_sim_period_below"] = r["sim_period_below"]
        f[f"p{k}_sim_period_above"] = r["sim_period_above"]
    f["sim_worst_repeat"] = float(np.nanmax(spread))
    f["sim_smallest_half_period_spread"] = float(np.nanmin(spread_half))
    for i in range(len(delta)):
        f[f"delta{i + 1}"] = float(delta[i])
        f[f"delta{i + 1}_error"] = float(delta_err[i])
        f[f"delta{i + 1}_error_bound"] = float(delta_bound[i])
        f[f"delta{i + 1}_minus_feigenbaum"] = float(delta[i] - FEIGENBAUM_DELTA)
    f["last_delta"] = float(delta[-1])
    f["last_delta_error"] = float(delta_err[-1])
    f["last_delta_error_bound"] = float(delta_bound[-1])
    f["last_delta_minus_feigenbaum"] = float(delta[-1] - FEIGENBAUM_DELTA)
    f["feigenbaum_delta"] = FEIGENBAUM_DELTA
    if len(delta) >= 2:
        dev = np.abs(delta - FEIGENBAUM_DELTA)
        f["delta_deviation_ratios"] = ", ".join(f"{r:.2f}" for r in dev[:-1] / dev[1:])
    if len(delta) >= 3:
        f["delta_aitken"] = aitken(delta)
        f["delta_aitken_minus_feigenbaum"] = f["delta_aitken"] - FEIGENBAUM_DELTA
    # the accumulation point if the gaps go on shrinking by the last ratio
    f["p_infinity_estimate"] = float(p[-1] + g[-1] / (delta[-1] - 1.0))
    f["slope_log_gap"] = float(np.polyfit(np.arange(1, len(g) + 1), np.log(g), 1)[0])
    f["slope_log_gap_last_three"] = float(np.polyfit(np.arange(1, len(g) + 1)[-3:],
                                                     np.log(g[-3:]), 1)[0])
    f["minus_ln_feigenbaum"] = -math.log(FEIGENBAUM_DELTA)
    f["max_p_error"] = float(np.max(p_err))
    f["max_p_error_bound"] = float(np.max(p_bound))

    t0 = time.perf_counter()
    diagrams = brute_force_diagrams(system, p, found[min(2, n - 1)]["orbit"].state, quick)
    f["diagram_seconds"] = round(time.perf_counter() - t0, 1)
    save_figure(figure(diagrams, p, g, g_err, delta, delta_err, f, quick), out, "period_doubling",
                quick=quick)
    f["study_seconds"] = round(time.perf_counter() - t_start, 1)
    return f


def brute_force_diagrams(system, p, start, quick):
    """The strobe diagrams by brute force (:func:`kapitza.chaos.bifurcation_diagram`,
    transient discarded): over the whole cascade from START_STATE (the asymmetric swing)
    and its mirror image (the other swing), and a zoom on the last doublings from
    ``start`` (a state on the 8T orbit)."""
    from kapitza.chaos import bifurcation_diagram
    fixed = {k: v for k, v in params(0.0).items() if k != "A"}
    y = np.array(START_STATE)
    p_inf = p[-1] + (p[-1] - p[-2]) / (FEIGENBAUM_DELTA - 1)
    whole = np.linspace(0.3505, max(p_inf + 0.25 * (p_inf - p[1]), 0.3579),
                        80 if quick else 500)
    lo = p[1] + 0.5 * (p[2] - p[1])
    zoom = np.linspace(lo, p_inf + 0.6 * (p_inf - lo), 60 if quick else 400)
    _log(f"bifurcation diagrams: {whole.size} amplitudes × 2 starts, {zoom.size} × 1")
    kw = dict(parameter="A", angles=True, rtol=1e-9)
    overview = bifurcation_diagram(system, fixed, values=whole, q0=np.array([[y[0]], [-y[0]]]),
                                   qdot0=np.array([[y[1]], [-y[1]]]),
                                   periods=32 if quick else 128,
                                   transient=300 if quick else 1500, **kw)
    detail = bifurcation_diagram(system, fixed, values=zoom, q0=[start[0]], qdot0=[start[1]],
                                 periods=64 if quick else 256,
                                 transient=300 if quick else 2000, **kw)
    return overview, detail


def _mark(ax, p, lo, hi):
    """The located p_k as vertical lines; lines closer than 4 % of the axis are labelled
    as one group ("p4–p8")."""
    shown = [(k, pk) for k, pk in enumerate(p, start=1) if lo <= pk <= hi]
    groups = []
    for k, pk in shown:
        ax.axvline(pk, color="C3", lw=0.7, alpha=0.8)
        if groups and pk - groups[-1][-1][1] < 0.04 * (hi - lo):
            groups[-1].append((k, pk))
        else:
            groups.append([(k, pk)])
    for group in groups:
        label = f"p{group[0][0]}" + (f"–p{group[-1][0]}" if len(group) > 1 else "")
        ax.text(group[0][1], 1.0, label, transform=ax.get_xaxis_transform(), color="C3",
                fontsize=8, va="bottom", ha="left" if len(group) > 1 else "center")


def figure(diagrams, p, g, g_err, delta, delta_err, f, quick=False):
    import matplotlib.pyplot as plt
    overview, detail = diagrams
    fig, ax = plt.subplots(2, 2, figsize=(13, 9.5))
    fig.suptitle("Period doubling of the damped, vertically shaken pendulum "
                 "(ω0/ω = 0.5, γ/ω = 0.1): the asymmetric swing's cascade to chaos", y=0.995)

    a = ax[0, 0]
    q = overview.q_wrapped[..., 0]
    swing = np.abs(overview.q[..., -1, 0] - overview.q[..., 0, 0]) < math.pi
    for s_, color in ((0, "k"), (1, "0.6")):
        A = np.repeat(overview.values[swing[:, s_], None], q.shape[2], axis=1)
        a.plot(A.ravel(), q[swing[:, s_], s_].ravel(), ",", color=color)
    _mark(a, p, overview.values[0], overview.values[-1])
    a.set_xlim(overview.values[0], overview.values[-1])
    a.set_xlabel("A / l")
    a.set_ylabel("θ at t = nT (rad)")
    a.set_title(f"strobe samples after {overview.transient} periods: the swing (black) and its "
                "mirror (grey);\nred lines: the located p_k; blank: rotating runs", fontsize=9,
                pad=14)

    a = ax[0, 1]
    q = detail.q_wrapped[:, 0, :, 0]
    swing = np.abs(detail.q[:, 0, -1, 0] - detail.q[:, 0, 0, 0]) < math.pi
    A = np.repeat(detail.values[swing, None], q.shape[1], axis=1)
    qs = q[swing]
    # the band of the largest swing angle, where the splitting is widest
    sign = 1.0 if np.nanmax(qs) > -np.nanmin(qs) else -1.0
    band = sign * qs > 0.3
    a.plot(A[band], qs[band], ",", color="k")
    _mark(a, p, detail.values[0], detail.values[-1])
    a.set_xlim(detail.values[0], detail.values[-1])
    if band.any():
        span = np.nanmax(qs[band]) - np.nanmin(qs[band])
        a.set_ylim(np.nanmin(qs[band]) - 0.05 * span, np.nanmax(qs[band]) + 0.05 * span)
    a.set_xlabel("A / l")
    a.set_ylabel("θ at t = nT (rad)")
    a.set_title(f"zoom on the band of the largest angle, started on the 8T orbit\n"
                f"({detail.transient}-period transient)", fontsize=9, pad=14)

    k = np.arange(1, len(g) + 1)
    a = ax[1, 0]
    a.errorbar(k, g, yerr=g_err, fmt="o", color="C0", label="p_(k+1) − p_k (exact orbits)")
    a.set_yscale("log")
    a.plot(k, g[-1] * FEIGENBAUM_DELTA ** (len(g) - k), "--", color="C3", lw=1,
           label="∝ δ^(−k), δ = 4.6692 (Feigenbaum)")
    a.set_xlabel("k")
    a.set_ylabel("p_(k+1) − p_k (A / l)")
    a.set_xticks(k)
    a.legend(fontsize=9)
    a.set_title(f"the gaps shrink by δ: slope of the last three {f['slope_log_gap_last_three']:.4f}"
                f", −ln δ = {-math.log(FEIGENBAUM_DELTA):.4f}", fontsize=9)

    a = ax[1, 1]
    kd = np.arange(1, len(delta) + 1)
    dev = delta - FEIGENBAUM_DELTA
    a.errorbar(kd[dev > 0], dev[dev > 0], yerr=delta_err[dev > 0], fmt="o", color="C0",
               label="δ_k − δ > 0")
    a.errorbar(kd[dev < 0], -dev[dev < 0], yerr=delta_err[dev < 0], fmt="o", mfc="none",
               color="C0", label="δ − δ_k > 0")
    a.plot(kd, abs(dev[-1]) * FEIGENBAUM_DELTA ** (len(delta) - kd), "--", color="C3", lw=1,
           label="∝ δ^(−k)")
    if "delta_aitken" in f:
        a.plot([kd[-1] + 0.5], [abs(f["delta_aitken_minus_feigenbaum"])], "s", color="C2",
               label=f"Aitken Δ² of the last three: {f['delta_aitken']:.6f}")
    a.set_yscale("log")
    a.set_xlabel("k")
    a.set_ylabel("|δ_k − δ|")
    a.set_xticks(kd)
    a.legend(fontsize=8)
    a.set_title(f"δ_k = (p_(k+1) − p_k)/(p_(k+2) − p_(k+1)) → δ = {FEIGENBAUM_DELTA:.6f};\n"
                f"last δ_{len(delta)} = {delta[-1]:.6f} ± {delta_err[-1]:.1e}", fontsize=9)
    layout(fig, quick)
    return fig


def check(findings: dict, quick: bool) -> None:
    f = findings
    n = f["doublings"]
    assert n == (LEVELS_QUICK if quick else LEVELS_FULL)
    for k in range(1, n + 1):
        P = f[f"p{k}_orbit_periods"]
        assert P == 2**k, k
        # (3) a supercritical doubling of a stable orbit: stable just below p_k; at p_k one
        # multiplier is −1 and the other is Liouville's −e^(−γ P T) (det M over P periods),
        # inside the unit circle, to the monodromy's accuracy (~1e-13 absolute)
        assert f[f"p{k}_max_abs_multiplier_below"] < 1.0, k
        assert abs(f[f"p{k}_multiplier_plus_one"]) < 1e-6, k
        assert abs(f[f"p{k}_other_multiplier"]) < 0.5, k
        assert abs(f[f"p{k}_other_multiplier_minus_liouville"]) < 1e-11, k
        # (1) direct simulation of the original equation, no shooting: halfway below p_k
        # the strobe sequence has period 2^k, halfway above 2^(k+1)
        assert f[f"p{k}_sim_period_below"] == P, k
        assert f[f"p{k}_sim_period_above"] == 2 * P, k
        # p_k is reproduced by three other discretizations to ~1e-14 (measured), inside
        # the propagated bound
        assert f[f"p{k}_error"] < 1e-12, k
        assert f[f"p{k}_error"] <= f[f"p{k}_error_bound"], k
    # the simulated periods are clear: the sequences repeat to ≤ 1.2e-6 rad (the adaptive
    # steps' error carried along the orbit), their half periods differ by ≥ 1e-4
    assert f["sim_smallest_half_period_spread"] > 30 * f["sim_worst_repeat"]
    ps = [f[f"p{k}"] for k in range(1, n + 1)]
    assert all(b > a for a, b in zip(ps, ps[1:], strict=False))
    # (2) the ratios approach Feigenbaum's δ.  The first ratio of a cascade is not yet
    # universal (the logistic map's are 4.23, 4.55, 4.65, 4.664, 4.668, …); this one's
    # is 5.29 (+13 %).  Each ratio's numerical error (≤ 1.6e-6) is far below its distance
    # from δ, so the bounds are on that distance: measured with a margin of ~3.
    assert abs(f["delta1"] / FEIGENBAUM_DELTA - 1) < 0.15, f["delta1"]
    if not quick:
        dev = [abs(f[f"delta{i}_minus_feigenbaum"]) for i in range(1, n - 1)]
        assert dev[-1] < dev[0] / 1000 and dev[-1] < dev[1] / 50, dev
        # the last distances shrink by about δ per level (measured 3.99, 4.47)
        assert 3 < dev[-3] / dev[-2] < 6.5 and 3 < dev[-2] / dev[-1] < 6.5, dev
        assert abs(f["last_delta_minus_feigenbaum"]) < 5e-4, f["last_delta"]
        assert f["last_delta_error"] < 1e-5, f["last_delta_error"]
        # ... so Aitken's extrapolation of the last three improves on the last ratio
        assert abs(f["delta_aitken_minus_feigenbaum"]) < abs(f["last_delta_minus_feigenbaum"])
        assert abs(f["slope_log_gap_last_three"] + math.log(FEIGENBAUM_DELTA)) < 2e-3

if __name__ == "__main__":
    sys.exit(main(Path(__file__).stem, run))     # __name__ is "__main__" here
