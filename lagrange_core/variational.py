"""The flow map of a system and its Jacobian, from the variational equations.

For the first-order form y′ = f(t, y), y = [q, q̇], the flow φ maps y(t0) to y(t1), and
its Jacobian X = ∂φ/∂y(t0) solves

    X′ = J(t, y(t)) X,    X(t0) = I,    J = ∂f/∂y

along the trajectory, with J the system's exact compiled Jacobian.  This is what
Newton's method needs to find periodic orbits (X over one period is their monodromy),
and what sensitivity studies need.

Accuracy: y and X are integrated together by the 8th-order Runge–Kutta formula of
DOP853 at a fixed step (:mod:`lagrange_core._variational_kernels`); the number of steps
doubles until two successive results agree to ``tol`` (relative to max(1, |y|, ‖X‖)),
and the reported ``error_estimate`` is that last difference (the finer result's true
error is about 2⁻⁸ of it).  Constrained systems are not supported (their flow lives
on the constraint manifold).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from . import _variational_kernels as _vk

__all__ = ["Flow", "flow"]


@dataclass(frozen=True, eq=False)
class Flow:
    """The flow map over [t0, t1] at one state (:func:`flow`); immutable.

    Attributes
    ----------
    t0, t1 : float
        The interval (s).
    y0, y1 : ndarray (2n,)
        The state [q, q̇] at t0 and at t1.
    jacobian : ndarray (2n, 2n)
        X = ∂y(t1)/∂y(t0).
    error_estimate : float
        Max difference of y(t1) and X between the last two step counts.
    steps : int
        Steps of the accepted (finer) integration.
    """

    t0: float
    t1: float
    y0: np.ndarray
    y1: np.ndarray
    jacobian: np.ndarray
    error_estimate: float
    steps: int


def flow(system, y0, t_span, params, *, tol=1e-12, steps=16, max_steps=1 << 20) -> Flow:
    """The state at t1 and its Jacobian with respect to the state at t0.

    Parameters
    ----------
    system : lagrange_core.System
        An unconstrained system.
    y0 : array_like (2n,)
        [q, q̇] at t0.
    t_span : (t0, t1)
        Interval (s), t1 > t0.
    params : dict
        Parameter values by name (or a float array in the kernels' order).
    tol : float
        Agreement of successive step doublings (relative to max(1, |y|, ‖X‖)).
    steps : int
        First step count tried (e.g. 16 per drive period).
    max_steps : int
        Give up beyond this many steps: FloatingPointError where the doublings have not
        converged by then or the state is still non-finite (ValueError: bad input, or a
        singular mass matrix).

    Returns
    -------
    Flow
    """
    from .integrate import METHODS
    if system.n_constraints:
        raise ValueError(f"flow: {system._label()} has constraints; the variational flow is "
                         "for unconstrained systems (state it in independent coordinates).")
    kernels = system.kernels
    p = params if isinstance(params, np.ndarray) else system.parameter_array(params)
    p = np.ascontiguousarray(p, dtype=float)
    y0 = np.ascontiguousarray(y0, dtype=float).reshape(-1)
    d = 2 * system.n_dof
    if y0.shape != (d,):
        raise ValueError(f"y0 must be the state [q, q̇] with {d} entries, got {y0.size}.")
    t0, t1 = (float(v) for v in t_span)
    if not t1 > t0:
        raise ValueError(f"t_span = {t_span!r}: t1 must be after t0.")
    ka = kernels.addresses("rhs", "jacobian")
    tab = METHODS["dop853"].table
    A, B, C = tab["A"], tab["B"], tab["C"]
    k = max(1, int(steps))
    prev = None
    while True:
        y1 = np.empty(d)
        X = np.empty((d, d))
        if _vk.rk8_flow(ka, y0, p, t0, t1, k, A, B, C, y1, X) != 0:
            raise ValueError(f"flow: the mass matrix of {system._label()} became singular "
                             f"between t = {t0} and {t1} s.")
        if not (np.all(np.isfinite(y1)) and np.all(np.isfinite(X))):
            if k >= max_steps:
                raise FloatingPointError(f"flow: the state became non-finite before t1 = {t1} "
                                         "s even at the finest step.")
            prev = None
        elif prev is not None:
            scale = max(1.0, float(np.max(np.abs(y1))), float(np.max(np.abs(X))))
            err = max(float(np.max(np.abs(y1 - prev[0]))), float(np.max(np.abs(X - prev[1]))))
            if err <= tol * scale or k >= max_steps:
                if err > tol * scale:
                    raise FloatingPointError(
                        f"flow: the step doublings did not converge to tol = {tol:g} by "
                        f"{k} steps (last difference {err:.3g}); the motion may be too fast "
                        "or unstable over the interval.")
                return Flow(t0, t1, y0.copy(), y1, X, err, k)
        prev = (y1, X)
        k *= 2
        if not math.isfinite(k):
            break
