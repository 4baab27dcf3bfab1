"""The period map of a driven system as a function of the state and one parameter, and
Newton's method on it with one linear side condition (the bordered corrector).

Variables
---------
The unknowns are u = (x, p): the state x = [q, q̇] at the drive's phase zero and the value
p of the continued parameter.  Every linear-algebra step works in *scaled* variables
v = (z, s), z = D x with D = diag(1, …, 1, 1/ω_ref, …) (so q̇/ω_ref is an angle, like q),
s = (p − p_0)/p_scale with p_scale the length of the parameter interval: one radian of
state counts as much as the whole interval.  Arclength, tangents and null vectors are
measured in this norm; tolerances and results are in the original units.

The map
-------
G(v) = D (φ_T(x; p) − x − σ), with φ_T the flow over ``periods`` drive periods T = 2π/ω
(ω the frequency parameter, which may itself be the continued one) and σ = (2π k, 0) the
shift of a rotating orbit that turns k times over them (``winding``; σ = 0 otherwise).
The flow and its Jacobian M = ∂φ_T/∂x (the monodromy at a periodic orbit) come from the
variational equations (:func:`lagrange_core.variational.flow`: 8th-order steps on the exact compiled
Jacobian, step count doubled until two counts agree to ``tol``/100, at least 1e-13).
∂G/∂p is a forward difference of the flow at the same fixed step count (the discrete
flow is then smooth in p: the difference is accurate to ~1e-8 relative, and only the
corrector's speed and the tangent's direction depend on it, not where the corrector
converges).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from lagrange_core.variational import flow

__all__ = ["PeriodMap", "Evaluation", "correct", "tangent", "test_functions",
           "CorrectorFailed"]

#: Newton iterations of one correction before it is declared failed (a continuation step
#: is then retried shorter).
MAX_ITERATIONS = 8
#: Halvings of a Newton step whose residual did not decrease.
MAX_HALVINGS = 8
#: The finest tolerance asked of a flow.
FLOW_TOL_FLOOR = 1e-13
#: A flow that needs this many times the steps of the last one fails (fast): the orbit
#: has become too fast or the trial state is far off.
MAX_STEP_GROWTH = 16
#: A bordered system with a larger condition number is treated as singular.
SINGULAR_CONDITION = 1e14


class CorrectorFailed(Exception):
    """Newton's method on the bordered system did not converge (the message says why;
    ``singular``: the bordered matrix was singular; ``retry``: a step was rejected by its
    control, not by the corrector)."""

    def __init__(self, message, singular=False, retry=False):
        super().__init__(message)
        self.singular, self.retry = singular, retry


@dataclass(frozen=True, eq=False)
class Evaluation:
    """The period map at one point v = (z, s): x, p, φ_T(x), the monodromy M (unscaled),
    the flow's error estimate and step count, the scaled residual G and the shift σ of a
    rotating orbit (zero otherwise)."""

    v: np.ndarray
    x: np.ndarray
    p: float
    y1: np.ndarray
    M: np.ndarray
    error: float
    steps: int
    G: np.ndarray
    shift: np.ndarray

    @property
    def residual(self) -> float:
        """|φ_T(x) − x − σ|∞ in the original units (rad, rad/s)."""
        return float(np.max(np.abs(self.y1 - self.x - self.shift)))


class PeriodMap:
    """The ``periods``-period map of ``system`` with every parameter but ``parameter``
    fixed at its value in ``params``; scaled variables as in the module docstring."""

    def __init__(self, system, params, parameter, frequency, periods, tol, p0, p_scale,
                 omega_ref=None, winding=None):
        self.system = system
        self.n = system.n_dof
        self.d = 2 * self.n
        # a rotating orbit: q(t + periods·T) = q(t) + 2π·winding
        turns = np.zeros(self.n) if winding is None else np.asarray(winding, dtype=float)
        self.shift = np.r_[2 * math.pi * turns, np.zeros(self.n)]
        names = list(system.parameters)
        self.row = system.parameter_array(params)
        self.column = names.index(parameter)
        self.frequency_column = names.index(frequency)
        self.parameter, self.frequency = parameter, frequency
        self.periods = int(periods)
        self.tol = float(tol)
        # the flow to tol/100 (as periodic_orbit), but not below what float64 reaches over
        # a few hundred 8th-order steps (~1e-13 relative): the doublings never agree there
        self.flow_tol = max(self.tol / 100, FLOW_TOL_FLOOR)
        self.p0, self.p_scale = float(p0), float(p_scale)
        self.omega_ref = float(self.row[self.frequency_column] if omega_ref is None
                               else omega_ref)
        self.D = np.r_[np.ones(self.n), np.full(self.n, 1.0 / self.omega_ref)]
        self.steps = 32            # the last accepted step count (flows start at half)
        self.flows = 0             # flows computed (for the benchmark and the tests)

    @property
    def half(self):
        """The map over half the periods (an even number of them)."""
        if getattr(self, "_half", None) is None:
            self._half = self.with_periods(self.periods // 2)
        return self._half

    def with_periods(self, periods):
        """The same map over ``periods`` drive periods (the same scaling)."""
        other = PeriodMap.__new__(PeriodMap)
        other.__dict__.update(self.__dict__)
        other.periods = int(periods)
        other.shift = self.shift * (other.periods / self.periods)   # turns ∝ periods
        other._half = None
        other.steps = self.steps * periods // self.periods or 32
        return other

    def winding(self) -> tuple:
        """The turns of each coordinate over the orbit (``Branch.winding``; () if none)."""
        turns = self.shift[:self.n] / (2 * math.pi)
        return tuple(int(round(k)) for k in turns) if turns.any() else ()

    # -- conversions -----------------------------------------------------------------
    def scaled(self, x, p) -> np.ndarray:
        return np.r_[self.D * np.asarray(x, float), (float(p) - self.p0) / self.p_scale]

    def state(self, v) -> np.ndarray:
        return v[:-1] / self.D

    def value(self, v) -> float:
        return float(self.p0 + self.p_scale * v[-1])

    def parameters(self, p) -> np.ndarray:
        P = self.row.copy()
        P[self.column] = p
        return P

    def period(self, p) -> float:
        w = self.parameters(p)[self.frequency_column]
        if not (w > 0 and math.isfinite(w)):
            raise CorrectorFailed(f"the drive frequency {self.frequency} = {w!r} is not "
                                  "positive")
        return self.periods * 2 * math.pi / w

    # -- the map ---------------------------------------------------------------------
    def _flow(self, x, p, *, fixed=None):
        """flow() over one orbit period, or None where it fails (non-finite, not
        converged, singular mass matrix).  ``fixed``: exactly that step count."""
        try:
            T = self.period(p)
        except CorrectorFailed:
            return None
        P = self.parameters(p)
        self.flows += 1
        try:
            with np.errstate(all="ignore"):   # a diverging trial state is judged, not warned
                if fixed is not None:         # flow() returns the count 2 × steps
                    return flow(self.system, x, (0.0, T), P, tol=np.inf, steps=fixed // 2,
                                max_steps=fixed // 2)
                return flow(self.system, x, (0.0, T), P, tol=self.flow_tol,
                            steps=max(16, self.steps // 2),
                            max_steps=min(1 << 16, max(1 << 10, MAX_STEP_GROWTH * self.steps)))
        except (FloatingPointError, ValueError, OverflowError):
            return None

    def evaluate(self, v) -> Evaluation | None:
        """The map at v (None where the flow fails)."""
        x, p = self.state(v), self.value(v)
        fl = self._flow(x, p)
        if fl is None:
            return None
        self.steps = fl.steps
        return Evaluation(v=np.array(v, float), x=x, p=p, y1=fl.y1, M=fl.jacobian,
                          error=float(fl.error_estimate), steps=fl.steps,
                          G=self.D * (fl.y1 - x - self.shift), shift=self.shift)

    def jacobian_z(self, ev) -> np.ndarray:
        """∂G/∂z = D (M − I) D⁻¹."""
        return (self.D[:, None] * (ev.M - np.eye(self.d))) / self.D[None, :]

    def derivative_s(self, ev) -> np.ndarray:
        """∂G/∂s by a forward difference at the evaluation's own step count."""
        h = 2e-8 * max(abs(ev.p), self.p_scale)
        fl = self._flow(ev.x, ev.p + h, fixed=ev.steps)
        if fl is None:
            fl = self._flow(ev.x, ev.p - h, fixed=ev.steps)
            h = -h
        if fl is None:
            raise CorrectorFailed(f"the flow failed at {self.parameter} = {ev.p + h!r} "
                                  "(the parameter derivative)")
        return self.D * (fl.y1 - ev.y1) / h * self.p_scale

    def converged(self, ev) -> bool:
        return ev.residual <= self.tol * max(1.0, float(np.max(np.abs(ev.x))))


def _bordered(pm, ev, Gs, row):
    return np.block([[pm.jacobian_z(ev), Gs[:, None]], [row[None, :]]])


def correct(pm, v_pred, row, Gs, *, ev=None, max_iterations=MAX_ITERATIONS,
            min_iterations=0):
    """Newton's method on [G(v); row · (v − v_pred)] = 0 from v_pred.

    ``Gs`` is ∂G/∂s from a nearby point (a chord in that one column; the state columns
    are exact at every iterate), or None: computed at every iterate (for steps off a
    branch on which ∂G/∂s vanishes, e.g. from an equilibrium that persists).  A step that
    does not reduce the residual, or whose flow fails, is halved.  Returns (Evaluation,
    iterations); raises :class:`CorrectorFailed`.  ``min_iterations``: take at least
    that many Newton steps even from a point that meets the tolerance (a probe whose
    predictor is already within it still moves its parameter to the branch).
    """
    v_pred = np.asarray(v_pred, float)
    exact = Gs is None
    ev = pm.evaluate(v_pred) if ev is None else ev
    if ev is None:
        raise CorrectorFailed(f"the flow failed at {pm.parameter} = {pm.value(v_pred):.10g}")
    for it in range(max_iterations + 1):
        if it >= min_iterations and pm.converged(ev):
            return ev, it
        if it == max_iterations:
            break
        B = _bordered(pm, ev, pm.derivative_s(ev) if exact else Gs, row)
        rhs = -np.r_[ev.G, row @ (ev.v - v_pred)]
        if not np.all(np.isfinite(B)) or np.linalg.cond(B) > SINGULAR_CONDITION:
            raise CorrectorFailed(f"the bordered Jacobian is singular at {pm.parameter} = "
                                  f"{ev.p:.10g}", singular=True)
        dv = np.linalg.solve(B, rhs)
        res = float(np.max(np.abs(ev.G)))
        lam = 1.0
        for _ in range(MAX_HALVINGS + 1):
            trial = pm.evaluate(ev.v + lam * dv)
            if trial is not None and (float(np.max(np.abs(trial.G))) < res
                                      or (it < min_iterations and pm.converged(trial))):
                break
            lam *= 0.5
        else:
            raise CorrectorFailed(f"Newton's method stalled at residual {ev.residual:.3g} "
                                  f"({pm.parameter} = {ev.p:.10g})")
        ev = trial
    raise CorrectorFailed(f"Newton's method did not converge in {max_iterations} iterations "
                          f"(residual {ev.residual:.3g} at {pm.parameter} = {ev.p:.10g})")


def tangent(pm, ev, Gs, previous) -> np.ndarray:
    """The unit tangent of the branch at ``ev`` in the scaled variables, oriented along
    ``previous`` (the bordered system [G_z G_s; previous] t = e_last)."""
    B = _bordered(pm, ev, Gs, np.asarray(previous, float))
    e = np.zeros(pm.d + 1)
    e[-1] = 1.0
    with np.errstate(all="ignore"):
        t = np.linalg.lstsq(B, e, rcond=None)[0] if np.linalg.cond(B) > SINGULAR_CONDITION \
            else np.linalg.solve(B, e)
    norm = float(np.linalg.norm(t))
    if not (norm > 0 and math.isfinite(norm)):
        raise CorrectorFailed("no tangent: the bordered Jacobian is singular", singular=True)
    return t / norm


def null_directions(pm, ev, Gs, count=2) -> np.ndarray:
    """The ``count`` right singular vectors of [G_z G_s] with the smallest singular values
    (rows), in the scaled variables: at a branch point they span the two branches'
    tangents."""
    J = np.c_[pm.jacobian_z(ev), Gs]
    return np.linalg.svd(J)[2][-count:]


def _adjugate_norm(A) -> float:
    """‖adj A‖_F computed stably from the singular values (A near-singular included)."""
    s = np.linalg.svd(A, compute_uv=False)
    prods = np.array([np.prod(np.delete(s, i)) for i in range(s.size)])
    return float(np.sqrt(np.sum(prods ** 2)))


def test_functions(M, error, *, conservative):
    """The bifurcation test functions of a monodromy and their error bounds.

    Returns (values, errors), three each: det(M − I) (multiplier +1: fold or branch
    point), det(M + I) (−1: period doubling), and Π_{i<j}(λ_i λ_j − 1) (the bialternate
    product's determinant: a complex pair on the unit circle, Neimark–Sacker; NaN for a
    conservative system, whose multipliers pair as λ, 1/λ so that it vanishes
    identically).  An error bound is ‖adj(M ∓ I)‖_F · ‖δM‖_F with ‖δM‖_F = 2n × the
    flow's error estimate (max abs of its entries).
    """
    d = M.shape[0]
    eye = np.eye(d)
    dM = d * max(float(error), 16 * np.finfo(float).eps * max(1.0, float(np.max(np.abs(M)))))
    vals, errs = [], []
    for sign in (-1.0, 1.0):
        A = M + sign * eye
        vals.append(float(np.linalg.det(A)))
        errs.append(_adjugate_norm(A) * dM)
    if conservative:
        vals.append(math.nan)
        errs.append(math.nan)
    else:
        lam = np.linalg.eigvals(M)
        i, j = np.triu_indices(d, 1)
        prod = lam[i] * lam[j] - 1.0
        vals.append(float(np.prod(prod).real))
        # each factor's error ≈ (|λ_i| + |λ_j|) δλ with δλ ≈ δM (well-conditioned pairs)
        rel = np.sum((np.abs(lam[i]) + np.abs(lam[j])) * dM / np.maximum(np.abs(prod), 1e-300))
        errs.append(float(abs(vals[-1]) * rel) if np.isfinite(rel) else math.inf)
    return np.array(vals), np.array(errs)
