"""Newton shooting for periodic orbits: on the full period map, on the symmetry-reduced
half-period map where the drive has the half-period reflection symmetry, single or
multiple (one segment per drive period), with an a-posteriori error bound (the engine of
:func:`kapitza.periodic_orbit` and of the maps, windows and boundaries about periodic
orbits, :mod:`kapitza.floquet._orbits`).

It lives in the Floquet room, below :mod:`kapitza.simulation`, so that both rooms use one
engine (the room order lets simulation import floquet, never the reverse); the
simulation room reaches it through ``kapitza.floquet``'s face.

The equations
-------------
The unknowns are the states Y = (y_0, …, y_(s−1)) at the starts of s segments of equal
length τ (s = 1: single shooting; the multiple shooting of long orbits takes one segment
per drive period), and with φ_j the flow over segment j (from t_j = j τ, its drive phase
taken modulo the drive period),

    F_j = φ_j(y_j) − y_(j+1)  (j < s − 1),     F_(s−1) = S φ_(s−1)(y_(s−1)) − w − y_0,

where S is the identity, or for a symmetric orbit the reflection below, and w = (2π k, 0)
the winding of a rotating orbit (θ(t + T) = θ(t) + 2π k; 0 otherwise).  Newton's matrix J
is block-bordered: X_j = ∂φ_j/∂y on the block diagonal, −I beside it (and R X_(s−1) in
the corner row for a symmetric orbit), solved densely.  At convergence the monodromy is
the product X_(s−1) ⋯ X_0 of the segments' Jacobians (each integrated over one drive
period, so an unstable or long orbit never needs one flow whose Jacobian grows like the
whole orbit's).  For s = 1 this is the classical G(y) = φ_T(y) − y, J = X − I.

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

Error of the result (Newton–Kantorovich)
----------------------------------------
Newton stops at a residual r = ‖F(Y)‖ (max-norm throughout); the flows are known to their
step-doubling difference ε (entries of the end state and of the Jacobian; ‖δJ‖∞ ≤ 2n ε).
The first-order estimate ‖J⁻¹‖ (r + ε) (:attr:`Shot.linear_error`) is not a bound: where
J is near-singular (a multiplier near +1 of the map shot) the equations are not linear
over the error's scale and it undershoots — 1.9e-4 for a true 5.3e-4 rad on the
horizontal drive's hanging orbit at its pitchfork, shot on the full map.  The bound is
Kantorovich's a-posteriori theorem: with β = ‖J⁻¹‖, η ≥ ‖J⁻¹ F‖ and K a Lipschitz
constant of J near Y (all for the exact equations: the computed ones' errors ε are
carried into β and η), if h = β K η ≤ 1/2 there is exactly one solution within

    ‖Y − Y*‖ ≤ (1 − √(1 − 2h)) / (β K) = 2η / (1 + √(1 − 2h))  (≤ 2η).

K is measured: J at Y ± ρ e_i for every coordinate direction (2 × 2n flows per segment,
ρ = 4η, at least 1e-7 · max(1, |y|) for the differences to rise above rounding), the
differences summed over the directions (the max-norm's operator norm), plus their own
integration error, × 2 for the variation of J's curvature over the ball.  That is an
estimate of K, not a proof, but at the ball's own scale, where the linear estimate's
failure lives.  Where h > 1/2 (J singular or nearly, the Newton step too long for its
curvature) no bound is established: :attr:`Shot.state_error` is inf and
:attr:`Shot.bound_note` says why.  The bound is computed when first asked for (a
continuation's trial orbits never need it).

The monodromy's error is its integration error (ε per segment carried through the
products) plus the change of the product over the state's error ball: per segment
K ‖Y − Y*‖, carried through the products likewise.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

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
#: The Lipschitz constant measured by differences at the ball's scale is multiplied by this
#: (the curvature of J varies over the ball; a safety factor, not a proof).
LIPSCHITZ_SAFETY = 2.0
#: The smallest probe distance for the Lipschitz differences, × max(1, |y|): the flows'
#: errors (~1e-12) then move a difference quotient by ~1e-5, far below a real K.
MIN_PROBE = 1e-7
#: A Newton step longer than this × max(1, |y|) is beyond a local bound.
MAX_PROBE = 0.1
#: The largest dense Newton system of multiple shooting (segments × 2n unknowns).
MAX_UNKNOWNS = 4096
#: ``tol = 0`` (to the floor): the flows' tolerance (float64 reaches ~1e-14 relative over a
#: few hundred 8th-order steps; the step doublings never agree much below), Newton going
#: on while each step lowers the residual FLOOR_GAIN-fold or it is above the flows' error,
#: and accepting a residual up to FLOOR_ACCEPT × max(1, |y|) where no step lowers it.
FLOOR_FLOW_TOL = 1e-13
FLOOR_GAIN = 10.0
FLOOR_ACCEPT = 1e-10


def flow_or_none(system, y, t1, p, tol, steps, max_steps, t0=0.0) -> Flow | None:
    """The flow from (t0, y) to t0 + t1, or None where it fails: a non-finite state or
    step doublings that do not converge by ``max_steps`` (FloatingPointError from flow),
    or a singular mass matrix on the way (ValueError)."""
    try:
        with np.errstate(all="ignore"):      # a diverging trial state is judged, not warned
            return flow(system, y, (t0, t0 + t1), p, tol=tol, steps=max(8, int(steps)),
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


@dataclass(frozen=True)
class Bound:
    """The Newton–Kantorovich bound of a converged shooting (see the module docstring).

    ``state_error`` bounds ‖Y − Y*‖∞ in raw units (rad, rad/s mixed; inf where no bound
    is established, ``why`` says why); ``monodromy_error`` bounds the monodromy's entries'
    error (inf likewise); ``beta`` = ‖J⁻¹‖, ``eta`` ≥ ‖J⁻¹F‖ of the exact equations,
    ``lipschitz`` the measured K (× the safety factor), ``h`` = β K η (a bound needs
    h ≤ 1/2), all in the max-norm ``norm`` that gave the smaller bound: of (q, q̇), or of
    the balanced (q, q̇/ω), whose bound r is converted to raw units as r / min(1, 1/ω).
    ``per_coordinate`` (2n,): the bound per coordinate in raw units (r for q, ω r for q̇
    in the balanced norm; None where there is no bound)."""

    state_error: float
    monodromy_error: float
    beta: float
    eta: float
    lipschitz: float
    h: float
    why: str = ""
    norm: str = ""
    per_coordinate: np.ndarray | None = None


@dataclass
class Shot:
    """A converged shooting: the orbit's state at t = 0 and what its accuracy rests on.

    Attributes
    ----------
    state : ndarray (2n,)
        [q, q̇] at t = 0.
    monodromy : ndarray (2n, 2n)
        ∂φ_T/∂y0 over the whole period (symmetric: (R X_h)²; multiple shooting: the
        product of the segments' Jacobians).
    multipliers : ndarray, complex (2n,)
        Eigenvalues of the monodromy (symmetric: the squares of R X_h's eigenvalues, which
        are better conditioned than those of the product).
    reduced : ndarray (2n, 2n) or None
        R X_h, the half-period map's Jacobian (symmetric shooting only).
    residual : float
        max |F| at the state.
    flow_error : float
        The largest step-doubling difference of the last flows (state and Jacobian).
    condition : float
        ‖J⁻¹‖∞ of the shooting equations at the state (inf if J is singular).
    linear_error : float
        condition × (residual + flow_error): the first-order estimate of the state's
        error, which undershoots where J is near-singular (a heuristic scale only; the
        bound is :attr:`state_error`).
    integration_error : float
        The monodromy's entries' integration error (the flows' carried through the
        segments' products), without the state's share.
    iterations : int
        Newton steps taken.
    symmetric : bool
        Whether the half-period map was shot.
    steps : int
        Steps of the last flow over one segment (a neighbouring orbit's flows can start
        from it).
    segments : int
        Segments shot (1: single shooting).
    segment_states : ndarray (segments, 2n)
        The states at the segments' starts (the first is ``state``).

    ``state_error``, ``monodromy_error``, ``bound_note`` and ``bound`` are the
    Newton–Kantorovich bound (:class:`Bound`), computed when first asked for.
    """

    state: np.ndarray
    monodromy: np.ndarray
    multipliers: np.ndarray
    reduced: np.ndarray | None
    residual: float
    flow_error: float
    condition: float
    linear_error: float
    integration_error: float
    iterations: int
    symmetric: bool
    steps: int = 0
    segments: int = 1
    segment_states: np.ndarray | None = None
    _assess: object = field(default=None, repr=False, compare=False)
    _bound: Bound | None = field(default=None, repr=False, compare=False)

    @property
    def bound(self) -> Bound:
        if self._bound is None:
            self._bound = self._assess()
        return self._bound

    @property
    def state_error(self) -> float:
        """A bound on ‖y − y*‖∞ (rad, rad/s mixed; inf: none established)."""
        return self.bound.state_error

    @property
    def monodromy_error(self) -> float:
        """A bound on the monodromy's entries' error (inf: none established)."""
        return self.bound.monodromy_error

    @property
    def bound_note(self) -> str:
        """Why no bound was established ("" where one was)."""
        return self.bound.why


class _Map:
    """The shooting equations F(Y) = 0 of the module docstring and their Jacobian: the full
    period map or, given a centre, the half-period map; ``segments`` equal segments of the
    interval shot; ``shift`` the winding w (None: 0).  ``T`` is the orbit's period,
    ``drive_period`` the drive's (the segments' start phases are taken modulo it)."""

    def __init__(self, system, p, T, center, tol, max_steps, *, segments=1, shift=None,
                 drive_period=None):
        self.system, self.p, self.tol, self.max_steps = system, p, tol, max_steps
        self.center = None if center is None else np.asarray(center, dtype=float)
        self.t1 = T if center is None else T / 2
        self.segments = int(segments)
        self.tau = self.t1 / self.segments
        self.drive = float(T if drive_period is None else drive_period)
        self.shift = None if shift is None else np.asarray(shift, dtype=float)
        self.n = system.n_dof
        self.d = 2 * self.n

    def start(self, j) -> float:
        """Segment j's start time, modulo the drive period (the drive's phase)."""
        return math.fmod(j * self.tau, self.drive)

    def flow(self, y, steps, j=0):
        """Segment j's flow from y (None where it fails)."""
        return flow_or_none(self.system, y, self.tau, self.p, self.tol, steps,
                            self.max_steps, self.start(j))

    def flows(self, Y, steps):
        """Every segment's flow (``steps`` the per-segment start counts); None if one
        fails."""
        out = []
        for j in range(self.segments):
            fl = self.flow(Y[j], steps[j], j)
            if fl is None:
                return None
            out.append(fl)
        return out

    def _close(self, y_end):
        """S y_end − w: the last segment's end mapped back onto the first's start."""
        if self.center is not None:
            y_end = np.concatenate([2 * self.center - y_end[:self.n], -y_end[self.n:]])
        return y_end if self.shift is None else y_end - self.shift

    def residual(self, Y, fls) -> np.ndarray:
        """F (segments, 2n)."""
        F = np.empty_like(Y)
        for j in range(self.segments - 1):
            F[j] = fls[j].y1 - Y[j + 1]
        F[-1] = self._close(fls[-1].y1) - Y[0]
        return F

    def residual1(self, y, fl) -> np.ndarray:
        """F of single shooting (one segment) at y with its flow fl."""
        return self._close(fl.y1) - y

    def jacobian(self, fls) -> np.ndarray:
        """∂F/∂Y, block-bordered (segments × 2n square)."""
        s, d = self.segments, self.d
        J = np.zeros((s * d, s * d))
        for j in range(s):
            X = fls[j].jacobian
            rows = slice(j * d, (j + 1) * d)
            if j == s - 1 and self.center is not None:
                X = -X
            J[rows, j * d:(j + 1) * d] += X
            k = (j + 1) % s
            J[rows, k * d:(k + 1) * d] -= np.eye(d)
        return J

    def product(self, fls) -> np.ndarray:
        """The Jacobian over the interval shot: X_(s−1) ⋯ X_0 (R applied: R X_h)."""
        P = np.eye(self.d)
        for fl in fls:
            P = fl.jacobian @ P
        return -P if self.center is not None else P

    def monodromy(self, fls) -> np.ndarray:
        P = self.product(fls)
        return P @ P if self.center is not None else P


def shoot(system, p, y, T, *, center=None, tol=1e-10, max_iterations=40,
          max_steps=1 << 16, steps=None, segments=1, shift=None, drive_period=None,
          states=None) -> Shot:
    """Newton's method on the shooting equations from the state ``y`` (see the module
    docstring); ``center`` (coordinates) shoots the half-period map for an orbit symmetric
    about it; ``segments`` > 1 is multiple shooting (``T`` / ``segments`` a whole number of
    drive periods ``drive_period``, or halves of them for a symmetric orbit), the
    segments' first states from ``states`` (segments, 2n) or else the guess's own flow;
    ``shift`` the winding w of a rotating orbit.  ``steps``: the step count a flow over one
    segment needed before (a neighbouring orbit's, :attr:`Shot.steps`); the first flows
    start from half of it instead of 32 (16 for the half period).  Raises ValueError (the
    message says why) where no orbit is reached."""
    segments = int(segments)
    floor = tol == 0                      # to the flows' rounding floor
    m = _Map(system, p, T, center, FLOOR_FLOW_TOL if floor else tol / 100, max_steps,
             segments=segments, shift=shift,
             drive_period=drive_period)
    if segments * m.d > MAX_UNKNOWNS:
        raise ValueError(f"periodic_orbit: {segments} segments × {m.d} unknowns exceed the "
                         f"dense Newton system's {MAX_UNKNOWNS}; shoot fewer periods.")
    what = "half-period" if center is not None else "period"
    drive = m.drive
    periods = max(1, round(T / drive))
    span = ("half the period" if center is not None else "one period" if periods == 1
            else f"{periods} periods") if segments == 1 else f"one of the {segments} segments"
    y_start = np.asarray(y, dtype=float).copy()
    # flow() doubles its step count from ``steps`` until two counts agree, so it returns at
    # least twice the count it starts from: each call starts at half the last accepted count
    # (which converged, so it is reused, not doubled again).  Carrying the accepted count
    # forward unhalved doubled it at every Newton step: 2^20 steps per period after ~15 steps
    # and minutes per flow (issue: circular pivot, A = 0.2 l, ω/ω0 = 133, 352 s).
    first = (32 if center is None else 16) if steps is None else max(8, steps // 2)
    Y, fls = _first_states(m, y_start, first, states)
    if fls is None:
        raise ValueError(f"periodic_orbit: the flow over {span} from the guess "
                         f"{y_start.tolist()} failed (non-finite or not converged by "
                         f"max_steps = {max_steps} steps); try another guess, or a larger "
                         "max_steps for a very fast orbit.")
    F = m.residual(Y, fls)
    res = float(np.max(np.abs(F)))
    rejected = 0
    it = 0
    for it in range(1, max_iterations + 1):
        if res <= tol * max(1.0, float(np.max(np.abs(Y)))):
            it -= 1
            break
        try:
            dY = np.linalg.solve(m.jacobian(fls), -F.ravel()).reshape(Y.shape)
        except np.linalg.LinAlgError:
            raise ValueError(
                "periodic_orbit: the shooting Jacobian is singular (a multiplier at +1 of the "
                f"{what} map): the orbit is not isolated here (a bifurcation, or a conserved "
                "quantity); move the parameters or use another guess.") from None
        lam = 1.0
        counts = [max(8, fl.steps // 2) for fl in fls]
        at_floor = False
        for _ in range(MAX_HALVINGS + 1):
            Y_try = Y + lam * dY
            # a trial state whose flow fails (non-finite, or the step doublings not
            # converging by max_steps) is a rejected step like one that raises |F|: halve
            fls_try = m.flows(Y_try, counts)
            if fls_try is not None:
                F_try = m.residual(Y_try, fls_try)
                r_try = float(np.max(np.abs(F_try)))
                if r_try < res or (lam < 1 and r_try <= res * (1 + 1e-12)):
                    break
            rejected += fls_try is None
            if floor and res <= _flows_error(fls) * max(1.0, float(np.max(np.abs(Y)))):
                at_floor = True        # at the floor already: a step cannot lower it
                break
            lam *= 0.5
        else:
            if floor and res <= FLOOR_ACCEPT * max(1.0, float(np.max(np.abs(Y)))):
                break                  # no step lowers the residual: the flows' floor
            raise ValueError(f"periodic_orbit: Newton's method stalled at residual {res:.3g} "
                             f"(iteration {it}; {MAX_HALVINGS} halvings of the step, "
                             f"{rejected} trial flows failed); no periodic orbit near the guess "
                             f"{y_start.tolist()}. Try another guess (e.g. the averaged state) "
                             "or parameters inside the averaging regime.")
        if at_floor:
            break
        gain = res / max(r_try, 1e-300)
        Y, fls, F, res = Y_try, fls_try, F_try, r_try
        if floor and gain < FLOOR_GAIN and res <= _flows_error(fls) * max(
                1.0, float(np.max(np.abs(Y)))):
            break                      # at the floor: the residual no longer falls 10-fold
    else:
        if res > (FLOOR_ACCEPT if floor else tol) * max(1.0, float(np.max(np.abs(Y)))):
            raise ValueError(
                f"periodic_orbit: no convergence in {max_iterations} iterations (residual "
                f"{res:.3g} at {Y[0].tolist()}, from the guess {y_start.tolist()}); no "
                "periodic orbit reached from this guess. Try another guess (e.g. the state "
                "[q, q̇] of a direct simulation at t = 0) or raise max_iterations.")
    return _shot(m, Y, fls, F, res, it)


def _flows_error(fls) -> float:
    return max(float(fl.error_estimate) for fl in fls)


def _first_states(m, y, steps, states):
    """The segments' first states (the given ones, or the guess's own flow through the
    segments) and their flows; (Y, None) where a flow fails."""
    if states is not None:
        Y = np.array(states, dtype=float).reshape(m.segments, m.d)
        Y[0] = y
        return Y, m.flows(Y, [steps] * m.segments)
    Y = np.empty((m.segments, m.d))
    Y[0] = y
    fls = []
    for j in range(m.segments):
        fl = m.flow(Y[j], steps, j)
        if fl is None:
            return Y, None
        fls.append(fl)
        if j + 1 < m.segments:
            Y[j + 1] = fl.y1
        steps = max(8, fl.steps // 2)
    return Y, fls


def _carried(norms_pre, norms_post, per_segment):
    """Σ_j ‖X_(s−1) ⋯ X_(j+1)‖ e_j ‖X_(j−1) ⋯ X_0‖: segment errors e_j carried through
    the product of the segments' Jacobians (first order)."""
    return float(np.sum(np.asarray(norms_post) * np.asarray(per_segment)
                        * np.asarray(norms_pre)))


def _product_norms(fls):
    """‖X_(j−1) ⋯ X_0‖∞ and ‖X_(s−1) ⋯ X_(j+1)‖∞ per segment j."""
    d = fls[0].jacobian.shape[0]
    pre, P = [], np.eye(d)
    for fl in fls:
        pre.append(float(np.linalg.norm(P, np.inf)))
        P = fl.jacobian @ P
    post, Q = [0.0] * len(fls), np.eye(d)
    for j in reversed(range(len(fls))):
        post[j] = float(np.linalg.norm(Q, np.inf))
        Q = Q @ fls[j].jacobian
    return pre, post


def _shot(m, Y, fls, F, res, iterations) -> Shot:
    """The converged shooting: its monodromy and multipliers now, its bound when asked."""
    eps = max(float(fl.error_estimate) for fl in fls)
    J = m.jacobian(fls)
    try:
        Jinv = np.linalg.inv(J)
        condition = float(np.linalg.norm(Jinv, np.inf))
    except np.linalg.LinAlgError:
        Jinv, condition = None, math.inf
    if not math.isfinite(condition):
        Jinv, condition = None, math.inf
    M = m.monodromy(fls)
    pre, post = _product_norms(fls)
    # the entries' error of one flow's Jacobian is its error estimate; carried through a
    # product of several, the operator norm ‖δX‖∞ ≤ 2n × that
    per = [(1 if m.segments == 1 else m.d) * float(fl.error_estimate) for fl in fls]
    e_red = _carried(pre, post, per)
    if m.center is None:
        mult = np.linalg.eigvals(M)
        reduced = None
        integration = e_red
    else:
        reduced = m.product(fls)
        mult = np.linalg.eigvals(reduced) ** 2
        integration = 2 * float(np.linalg.norm(reduced, np.inf)) * e_red + e_red**2
    steps = max(fl.steps for fl in fls)
    shot = Shot(state=Y[0].copy(), monodromy=M, multipliers=mult, reduced=reduced,
                residual=float(res), flow_error=eps, condition=condition,
                linear_error=float(condition * (res + eps)),
                integration_error=float(integration), iterations=int(iterations),
                symmetric=m.center is not None, steps=int(steps), segments=m.segments,
                segment_states=Y.copy())
    shot._assess = lambda: _kantorovich(m, Y, fls, F, Jinv, pre, post)
    return shot


def _no_bound(why, beta=math.nan, eta=math.nan, lipschitz=math.nan, h=math.nan) -> Bound:
    return Bound(state_error=math.inf, monodromy_error=math.inf, beta=float(beta),
                 eta=float(eta), lipschitz=float(lipschitz), h=float(h), why=why)


class _Norm:
    """A weighted max-norm ‖W Y‖∞ over all segments' unknowns (W diagonal: per segment j
    the weights W_j of its coordinates) and the Kantorovich quantities of the shooting
    equations in it: β, the exact equations' η, the ball's reach per unknown (raw units).
    ``e_F`` (segments, 2n) and ``E_X`` (segments, 2n, 2n) are the componentwise integration
    errors of F and of the segments' Jacobians.  (J's block row j, F_j = φ_j(Y_j) − Y_(j+1),
    is weighted like Y_j: W J W⁻¹ has W_j X_j W_j⁻¹ on its diagonal.)"""

    def __init__(self, W, Y, F, Jinv, e_F, E_X, name):
        self.W, self.name = W, name               # (segments, 2n)
        w = W.ravel()
        self.beta = float(np.linalg.norm(w[:, None] * Jinv / w[None, :], np.inf))
        self.eps_J = max(float(np.linalg.norm(Wj[:, None] * E / Wj[None, :], np.inf))
                         for Wj, E in zip(W, E_X, strict=True))
        self.why = ""
        if not self.beta * self.eps_J < 0.5:
            self.why = (f"‖J⁻¹‖ = {self.beta:.3g} times the Jacobian's integration error "
                        f"{self.eps_J:.3g} is not small: the computed J cannot be told from "
                        "a singular one")
            self.eta = math.inf
            return
        self.beta_t = self.beta / (1 - self.beta * self.eps_J)
        f_norm = float(np.max(np.abs(w * F.ravel())))
        step = float(np.max(np.abs(w * (Jinv @ F.ravel()))))
        # ‖J⁻¹ e‖ ≤ ‖|J⁻¹| |e|‖ for F's integration error e (componentwise: tighter than
        # β ‖e‖ where J⁻¹ is far from normal), and J's own error through β β_t ε_J
        e = np.ravel(e_F)
        carried = float(np.max(w * (np.abs(Jinv) @ e)))
        self.eta = (step + carried + self.beta * self.beta_t * self.eps_J
                    * (f_norm + float(np.max(w * e))))
        scale = max(1.0, float(np.max(np.abs(w * Y.ravel()))))
        if 4 * self.eta > MAX_PROBE * scale:
            self.why = (f"the Newton step ‖J⁻¹F‖ ≈ {self.eta:.3g} is too long for a local "
                        "bound")

    def reach(self):
        """The raw extent of the ball of radius 2η along each unknown (inf: none)."""
        return np.full(self.W.shape, math.inf) if self.why else 2 * self.eta / self.W


def _componentwise_errors(m, Y, fls):
    """The step-doubling differences entry by entry: |y1 − y1_coarse| and |X − X_coarse|
    per segment, the coarse flow at half the accepted steps (what the scalar
    ``error_estimate`` is the maximum of); the scalar where the coarse flow fails."""
    e_y = np.empty((m.segments, m.d))
    E_X = np.empty((m.segments, m.d, m.d))
    for j, fl in enumerate(fls):
        c = max(1, fl.steps // 2)
        coarse = None
        try:
            with np.errstate(all="ignore"):
                # tol = inf: flow() accepts its first comparison, the count ``c``
                coarse = flow(m.system, Y[j], (m.start(j), m.start(j) + m.tau), m.p,
                              tol=np.inf, steps=max(1, c // 2), max_steps=max(1, c // 2))
        except (FloatingPointError, ValueError, OverflowError):
            coarse = None
        if coarse is None or coarse.steps != c or not np.all(np.isfinite(coarse.jacobian)):
            e_y[j] = fl.error_estimate
            E_X[j] = fl.error_estimate
            continue
        e_y[j] = np.abs(fl.y1 - coarse.y1)
        E_X[j] = np.abs(fl.jacobian - coarse.jacobian)
    return e_y, E_X


def _norms(m, Y, F, Jinv, e_F, E_X, pre):
    """The candidate norms: the max-norm of (q, q̇) and of the balanced (q, q̇/ω); for
    several segments also each with segment j weighted by 1/max(1, ‖X_(j−1) ⋯ X_0‖) (an
    error of y_0 grows along the orbit by that much: the later segments' states are known
    only that much worse, and in this norm do not swamp y_0's bound)."""
    n, s = m.n, m.segments
    omega = 2 * math.pi / m.drive
    bases = [(np.ones(m.d), "(q, q̇)")]
    if abs(omega - 1.0) > 1e-12:
        bases.append((np.r_[np.ones(n), np.full(n, 1.0 / omega)], "(q, q̇/ω)"))
    out = []
    for D, name in bases:
        out.append(_Norm(np.tile(D, (s, 1)), Y, F, Jinv, e_F, E_X, name))
        if s > 1:
            grow = 1.0 / np.maximum(1.0, np.asarray(pre))
            out.append(_Norm(grow[:, None] * D[None, :], Y, F, Jinv, e_F, E_X,
                             f"{name}, segment j weighted by 1/‖X_(j−1)⋯X_0‖"))
    return out


def _kantorovich(m, Y, fls, F, Jinv, pre, post) -> Bound:
    """The Newton–Kantorovich bound at the converged Y (module docstring) in each candidate
    norm (:func:`_norms`); the smallest bound on the returned state y_0, in raw units."""
    d = m.d
    if Jinv is None:
        return _no_bound("the shooting Jacobian is singular (a multiplier at +1 of the map "
                         "shot)")
    e_F, E_X = _componentwise_errors(m, Y, fls)
    norms = _norms(m, Y, F, Jinv, e_F, E_X, pre)
    viable = [nm for nm in norms if not nm.why]
    if not viable:
        best = min(norms, key=lambda nm: nm.beta)
        return _no_bound(best.why, beta=best.beta, eta=best.eta)
    # one set of probes serves every norm: per unknown, at the smaller ball's reach
    scale = np.maximum(1.0, np.abs(Y))
    rho = np.maximum(MIN_PROBE * scale, 2 * np.min([nm.reach() for nm in viable], axis=0))
    diffs = np.zeros((m.segments, d, len(norms)))     # max_± ‖W_j ΔX W_j⁻¹‖ per unknown
    chain = _Chain(m, fls)
    dM = np.zeros((m.segments, d))                     # max_± max |ΔM| per unknown
    for j, fl in enumerate(fls):
        for i in range(d):
            for sign in (1.0, -1.0):
                y = Y[j].copy()
                y[i] += sign * rho[j, i]
                probe = m.flow(y, max(8, fl.steps // 2), j)
                if probe is None:
                    return _no_bound(f"the flow near the orbit failed (segment {j}, "
                                     f"coordinate {i}, distance {rho[j, i]:.3g}): no "
                                     "Lipschitz constant for the Jacobian")
                dX = probe.jacobian - fl.jacobian
                err = float(probe.error_estimate) + float(fl.error_estimate)
                dM[j, i] = max(dM[j, i], float(np.max(np.abs(chain.moved(j, dX)))))
                for k, nm in enumerate(norms):
                    Wj = nm.W[j]
                    ratio = float(np.max(np.sum(Wj[:, None] / Wj[None, :], axis=1)))
                    diff = float(np.linalg.norm(Wj[:, None] * dX / Wj[None, :], np.inf))
                    diffs[j, i, k] = max(diffs[j, i, k], diff + err * ratio)
    # |∂M/∂Y_ji| (max entry, × the safety factor) from the same probes, for the monodromy
    slope_M = LIPSCHITZ_SAFETY * dM / rho
    integration = chain.integration(E_X)
    best, failed = None, None
    for k, nm in enumerate(norms):
        if nm.why:
            continue
        # K = safety × max_j Σ_i max_± ‖W_j ΔX_j W_j⁻¹‖ / (ρ_ji W_ji): the operator norm
        K = float(np.max(LIPSCHITZ_SAFETY * np.sum(diffs[:, :, k] / (rho * nm.W), axis=1)))
        h = nm.beta_t * K * nm.eta
        if not h <= 0.5:
            if failed is None or h < failed[3]:
                failed = (nm, K, None, h)
            continue
        r = 2 * nm.eta / (1 + math.sqrt(1 - 2 * h)) if h > 0 else nm.eta
        per_unknown = r / nm.W                     # |δY_ji| ≤ r / W_ji (raw units)
        monodromy_error = integration + float(np.sum(slope_M * per_unknown))
        state_error = float(np.max(per_unknown[0]))
        if best is None or state_error < best[0].state_error:
            best = (Bound(state_error=state_error, monodromy_error=float(monodromy_error),
                          beta=nm.beta, eta=float(nm.eta), lipschitz=K, h=float(h),
                          norm=nm.name, per_coordinate=per_unknown[0].copy()),
                    monodromy_error)
        else:
            best = (best[0], min(best[1], monodromy_error))
    if best is None:
        nm, K, _, h = failed
        return _no_bound(f"Kantorovich's h = ‖J⁻¹‖ K ‖J⁻¹F‖ = {h:.3g} > 1/2 in the max-norm "
                         f"of {nm.name} (‖J⁻¹‖ = {nm.beta:.3g}, K = {K:.3g}, ‖J⁻¹F‖ = "
                         f"{nm.eta:.3g}): the equations are not linear enough over the Newton "
                         "step to bound the error (a multiplier near +1 of the map shot: a "
                         "bifurcation)", beta=nm.beta, eta=nm.eta, lipschitz=K, h=h)
    bound, monodromy_error = best
    # every norm's bound is a bound: the smallest monodromy error of them
    return Bound(**{**bound.__dict__, "monodromy_error": float(monodromy_error)})


class _Chain:
    """The monodromy as a function of the segments' Jacobians: M = P (single map) or
    M = P² (symmetric, P = R X_(s−1) ⋯ X_0), with the partial products kept, so that a
    change δX_j of one segment's Jacobian moves M by the exact first-order
    post_j δX_j pre_j (and through the square), cancellations included — not by a product
    of norms, which the orbit's transient stretching inflates by orders of magnitude."""

    def __init__(self, m, fls):
        d = m.d
        self.pre, P = [], np.eye(d)
        for fl in fls:
            self.pre.append(P)
            P = fl.jacobian @ P
        self.post, Q = [None] * len(fls), np.eye(d)
        for j in reversed(range(len(fls))):
            self.post[j] = Q
            Q = Q @ fls[j].jacobian
        self.symmetric = m.center is not None
        self.P = -P if self.symmetric else P

    def moved(self, j, dX):
        """δM for δX_j = dX (first order; a product's second order is below rounding at
        the bound's scale)."""
        dP = self.post[j] @ dX @ self.pre[j]
        if self.symmetric:
            return -(dP @ self.P + self.P @ dP)        # R = −I: δ(R P)² = −(δP P + P δP)
        return dP

    def integration(self, E_X) -> float:
        """The monodromy's entries' error from the segments' componentwise integration
        errors E_j: |post_j| E_j |pre_j| summed (and through the square)."""
        total = np.zeros_like(self.P)
        for j, E in enumerate(E_X):
            total += np.abs(self.post[j]) @ E @ np.abs(self.pre[j])
        if self.symmetric:
            total = total @ np.abs(self.P) + np.abs(self.P) @ total + total @ total
        return float(np.max(total))
