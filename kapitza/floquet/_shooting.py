"""Newton shooting for periodic orbits: on the full period map, or on the symmetry-reduced
half-period map where the drive has the half-period reflection symmetry (the engine of
:func:`kapitza.periodic_orbit` and of the maps, windows and boundaries about periodic
orbits, :mod:`kapitza.floquet._orbits`).

It lives in the Floquet room, below :mod:`kapitza.simulation`, so that both rooms use one
engine (the room order lets simulation import floquet, never the reverse); the
simulation room reaches it through ``kapitza.floquet``'s face.

Why the half-period map
-----------------------
A drive such as the horizontal pivot x_p = A cos ωt satisfies, for the first-order system
ẏ = f(y, t) with y = [q, q̇],

    f(S y, t + T/2) = R f(y, t),   S y = (2c − q, −q̇),   R = −I,

(a reflection of every coordinate about the centre c, here θ = 0 or π, combined with half a
drive period).  If y(t) is a solution, so is S y(t − T/2); an orbit that is its own image,
y(t + T/2) = S y(t), is a *symmetric* orbit (the hanging and the inverted orbit of the
horizontal drive).  With φ_h the flow over half the period and P = S ∘ φ_h, the period map
is P ∘ P, so the symmetric orbits are the fixed points of P, and the monodromy is
M = (R X_h)² with X_h = ∂φ_h/∂y.  A multiplier +1 of M comes from a multiplier ±1 of
R X_h: −1 is the symmetry-breaking pitchfork (the tilted orbits branch off), where
Newton's matrix X − I of the full period map is singular while R X_h − I, the matrix of
the half-period shooting, stays regular.  Only +1 of R X_h (a fold of the symmetric orbits
themselves) makes it singular.

The symmetry is never assumed: :func:`symmetry_defect` evaluates both sides at random
states and times and the symmetric formulation is used only where they agree to rounding.

Error of the result
-------------------
Newton stops at a residual r = |G(y)| of the shooting equations G (G = φ_T(y) − y, or
G = S φ_h(y) − y); the flow itself is known to its step-doubling difference ε.  The
state's error is then about ‖J⁻¹‖ (r + ε), J = ∂G/∂y (the infinity norm throughout): small
where J is regular, and large near a multiplier +1 of the map shot, which is what
:attr:`Shot.condition` reports.  The monodromy's error is its own integration error plus
the state's error times ∂M/∂y along the direction J⁻¹ amplifies most (one finite
difference).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from lagrange_core.variational import Flow, flow

__all__ = ["Shot", "shoot", "symmetry_defect", "flow_or_none", "MAX_HALVINGS"]

#: Halvings of a Newton step before the iteration is declared stalled.
MAX_HALVINGS = 12
#: Random states at which the half-period symmetry is tested.
SYMMETRY_POINTS = 8
#: Agreement (relative to the accelerations' size) that counts as a symmetric vector field:
#: rounding in f is ~1e-15 relative; a real asymmetry is a term of the equations.
SYMMETRY_RTOL = 1e-9


def flow_or_none(system, y, t1, p, tol, steps, max_steps) -> Flow | None:
    """The flow from (0, y) to t1, or None where it fails: a non-finite state or step
    doublings that do not converge by ``max_steps`` (FloatingPointError from flow), or a
    singular mass matrix on the way (ValueError)."""
    try:
        with np.errstate(all="ignore"):      # a diverging trial state is judged, not warned
            return flow(system, y, (0.0, t1), p, tol=tol, steps=max(8, int(steps)),
                        max_steps=max_steps)
    except (FloatingPointError, ValueError, OverflowError):
        return None


def symmetry_defect(system, p, center, T, *, seed: int = 20240521) -> float:
    """How far the vector field is from the half-period reflection symmetry about ``center``.

    max over random states y (coordinates within ±max(1, |c|)/2 of the centre, velocities
    within ±1) and times t ∈ [0, T) of |f(S y, t + T/2) + f(y, t)| / max(1, |f(y, t)|),
    with S y = (2c − q, −q̇); about 1e-15 for a symmetric system, O(1) otherwise.  NaN
    where fewer than half the states could be evaluated (a singular mass matrix).
    """
    n = system.n_dof
    kernels = system.kernels
    W = kernels.work_array()
    c = np.asarray(center, dtype=float)
    rng = np.random.default_rng(seed)
    spread = 0.5 * max(1.0, float(np.max(np.abs(c)))) if n else 0.5
    worst, counted = 0.0, 0
    for _ in range(SYMMETRY_POINTS):
        q = c + rng.uniform(-spread, spread, n)
        qd = rng.uniform(-1.0, 1.0, n)
        t = float(rng.uniform(0.0, T))
        y = np.concatenate([q, qd])
        y_image = np.concatenate([2 * c - q, -qd])
        f, f_image = np.empty(2 * n), np.empty(2 * n)
        with np.errstate(all="ignore"):
            if (kernels.rhs(t, y, p, f, W) != 0
                    or kernels.rhs(t + T / 2, y_image, p, f_image, W) != 0):
                continue
        if not (np.all(np.isfinite(f)) and np.all(np.isfinite(f_image))):
            continue
        counted += 1
        scale = max(1.0, float(np.max(np.abs(f))))
        worst = max(worst, float(np.max(np.abs(f_image + f))) / scale)
    return worst if 2 * counted >= SYMMETRY_POINTS else math.nan


@dataclass
class Shot:
    """A converged shooting: the orbit's state at t = 0 and what its accuracy rests on.

    Attributes
    ----------
    state : ndarray (2n,)
        [q, q̇] at t = 0.
    monodromy : ndarray (2n, 2n)
        ∂φ_T/∂y0 over the whole period (symmetric: (R X_h)²).
    multipliers : ndarray, complex (2n,)
        Eigenvalues of the monodromy (symmetric: the squares of R X_h's eigenvalues, which
        are better conditioned than those of the product).
    reduced : ndarray (2n, 2n) or None
        R X_h, the half-period map's Jacobian (symmetric shooting only).
    residual : float
        max |G| at the state.
    flow_error : float
        The step-doubling difference of the last flow (state and Jacobian).
    condition : float
        ‖J⁻¹‖∞ of the shooting equations at the state (inf if J is singular).
    state_error : float
        condition × (residual + flow_error): the state's error bound (max-norm).
    monodromy_error : float
        The monodromy's entries' error: the integration's plus the state's propagated.
    iterations : int
        Newton steps taken.
    symmetric : bool
        Whether the half-period map was shot.
    steps : int
        Steps of the last flow over the interval shot (a neighbouring orbit's flows can
        start from it).
    """

    state: np.ndarray
    monodromy: np.ndarray
    multipliers: np.ndarray
    reduced: np.ndarray | None
    residual: float
    flow_error: float
    condition: float
    state_error: float
    monodromy_error: float
    iterations: int
    symmetric: bool
    steps: int = 0


class _Map:
    """The shooting equations G(y) = 0 and their Jacobian: the full period map
    (G = φ_T(y) − y) or, given a centre, the half-period map (G = S φ_{T/2}(y) − y)."""

    def __init__(self, system, p, T, center, tol, max_steps):
        self.system, self.p, self.tol, self.max_steps = system, p, tol, max_steps
        self.center = None if center is None else np.asarray(center, dtype=float)
        self.t1 = T if center is None else T / 2
        self.n = system.n_dof

    def flow(self, y, steps):
        return flow_or_none(self.system, y, self.t1, self.p, self.tol, steps, self.max_steps)

    def residual(self, y, fl):
        if self.center is None:
            return fl.y1 - y
        image = np.concatenate([2 * self.center - fl.y1[:self.n], -fl.y1[self.n:]])
        return image - y

    def jacobian(self, fl):
        """∂G/∂y: X − I, or R X_h − I with R = −I."""
        d = 2 * self.n
        return (fl.jacobian if self.center is None else -fl.jacobian) - np.eye(d)

    def monodromy(self, fl):
        return fl.jacobian if self.center is None else fl.jacobian @ fl.jacobian


def _norm_inv(J):
    """‖J⁻¹‖∞ (inf for a singular J) and the unit direction J⁻¹ stretches most."""
    try:
        Jinv = np.linalg.inv(J)
    except np.linalg.LinAlgError:
        return math.inf, None
    if not np.all(np.isfinite(Jinv)):
        return math.inf, None
    _, _, vt = np.linalg.svd(J)
    return float(np.linalg.norm(Jinv, np.inf)), vt[-1]


def shoot(system, p, y, T, *, center=None, tol=1e-10, max_iterations=40,
          max_steps=1 << 16, steps=None) -> Shot:
    """Newton's method on the shooting equations from the state ``y`` (see the module
    docstring); ``center`` (coordinates) shoots the half-period map for an orbit symmetric
    about it.  ``steps``: the step count a flow over the interval shot needed before (a
    neighbouring orbit's, :attr:`Shot.steps`); the first flow starts from half of it
    instead of 32 (16 for the half period).  Raises ValueError (the message says why)
    where no orbit is reached."""
    m = _Map(system, p, T, center, tol / 100, max_steps)
    what = "half-period" if center is not None else "period"
    span = "half the period" if center is not None else "one period"
    y_start = y.copy()
    # flow() doubles its step count from ``steps`` until two counts agree, so it returns at
    # least twice the count it starts from: each call starts at half the last accepted count
    # (which converged, so it is reused, not doubled again).  Carrying the accepted count
    # forward unhalved doubled it at every Newton step: 2^20 steps per period after ~15 steps
    # and minutes per flow (issue: circular pivot, A = 0.2 l, ω/ω0 = 133, 352 s).
    fl = m.flow(y, (32 if center is None else 16) if steps is None else max(8, steps // 2))
    if fl is None:
        raise ValueError(f"periodic_orbit: the flow over {span} from the guess {y.tolist()} "
                         f"failed (non-finite or not converged by max_steps = {max_steps} "
                         "steps); try another guess, or a larger max_steps for a very fast "
                         "orbit.")
    F = m.residual(y, fl)
    res = float(np.max(np.abs(F)))
    rejected = 0
    it = 0
    for it in range(1, max_iterations + 1):
        if res <= tol * max(1.0, float(np.max(np.abs(y)))):
            it -= 1
            break
        try:
            dy = np.linalg.solve(m.jacobian(fl), -F)
        except np.linalg.LinAlgError:
            raise ValueError(
                "periodic_orbit: the shooting Jacobian is singular (a multiplier at +1 of the "
                f"{what} map): the orbit is not isolated here (a bifurcation, or a conserved "
                "quantity); move the parameters or use another guess.") from None
        lam = 1.0
        for _ in range(MAX_HALVINGS + 1):
            y_try = y + lam * dy
            # a trial state whose flow fails (non-finite, or the step doublings not
            # converging by max_steps) is a rejected step like one that raises |G|: halve
            fl_try = m.flow(y_try, fl.steps // 2)
            if fl_try is not None:
                F_try = m.residual(y_try, fl_try)
                r_try = float(np.max(np.abs(F_try)))
                if r_try < res or (lam < 1 and r_try <= res * (1 + 1e-12)):
                    break
            rejected += fl_try is None
            lam *= 0.5
        else:
            raise ValueError(f"periodic_orbit: Newton's method stalled at residual {res:.3g} "
                             f"(iteration {it}; {MAX_HALVINGS} halvings of the step, "
                             f"{rejected} trial flows failed); no periodic orbit near the guess "
                             f"{y_start.tolist()}. Try another guess (e.g. the averaged state) "
                             "or parameters inside the averaging regime.")
        y, fl, F, res = y_try, fl_try, F_try, r_try
    else:
        if res > tol * max(1.0, float(np.max(np.abs(y)))):
            raise ValueError(
                f"periodic_orbit: no convergence in {max_iterations} iterations (residual "
                f"{res:.3g} at {y.tolist()}, from the guess {y_start.tolist()}); no periodic "
                "orbit reached from this guess. Try another guess (e.g. the state [q, q̇] of a "
                "direct simulation at t = 0) or raise max_iterations.")
    return _assess(m, y, fl, res, it)


def _assess(m, y, fl, res, iterations) -> Shot:
    """The converged state's error bounds and its monodromy and multipliers."""
    eps = float(fl.error_estimate)
    J = m.jacobian(fl)
    condition, weak = _norm_inv(J)
    state_error = condition * (res + eps)
    M = m.monodromy(fl)
    if m.center is None:
        mult = np.linalg.eigvals(M)
        reduced = None
        integration = eps
    else:
        reduced = -fl.jacobian
        mult = np.linalg.eigvals(reduced) ** 2
        integration = 2 * float(np.linalg.norm(fl.jacobian, np.inf)) * eps + eps**2
    # the state's error moves the monodromy by ∂M/∂y · δy; the error lies along the
    # direction J⁻¹ stretches most, so one difference quotient along it bounds the slope
    slope = 0.0
    if weak is not None and math.isfinite(state_error):
        h = max(1e-6, min(state_error, 1e-3)) * max(1.0, float(np.max(np.abs(y))))
        fl_h = m.flow(y + h * weak, fl.steps // 2)
        if fl_h is not None:
            slope = float(np.max(np.abs(m.monodromy(fl_h) - M))) / h
    monodromy_error = integration + slope * state_error
    return Shot(state=y.copy(), monodromy=M, multipliers=mult, reduced=reduced,
                residual=float(res), flow_error=eps, condition=condition,
                state_error=float(state_error), monodromy_error=float(monodromy_error),
                iterations=int(iterations), symmetric=m.center is not None,
                steps=int(fl.steps))
