"""A point of a branch while it is being traced: the evaluation of the period map there,
∂G/∂s, the tangent, the test functions and the stability — and, at the end, the orbit's
period mean and amplitude."""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ._shooting import Evaluation, test_functions

__all__ = ["Point", "make_point", "orbit_statistics", "unstable_count"]


@dataclass(eq=False)
class Point:
    """One point: ``ev`` (the period map there), ``Gs`` (∂G/∂s), ``t`` (unit tangent,
    scaled), ``sigma`` (arclength), ``psi``/``psi_error`` (the three test functions and
    their error bounds), ``multipliers`` (by decreasing modulus), ``stable``,
    ``unstable`` (count of |λ| > 1 + δ), ``label``; on a branch of an even number n of
    drive periods ``half`` = D (φ_{nT/2}(x) − x) (scaled; zero where the orbit has half
    the period) and ``half_error`` (its flow's error estimate), else None and 0."""

    ev: Evaluation
    Gs: np.ndarray | None
    t: np.ndarray | None
    sigma: float
    psi: np.ndarray
    psi_error: np.ndarray
    multipliers: np.ndarray
    stable: bool
    unstable: int
    label: str = ""
    half: np.ndarray | None = None
    half_error: float = 0.0
    iterations: int = 0

    @property
    def v(self):
        return self.ev.v

    @property
    def p(self):
        return self.ev.p


def stability_margin(error) -> float:
    """δ of ``|λ| ≤ 1 + δ`` (as :func:`kapitza.periodic_orbit`): 100 × the monodromy's
    error estimate, at least 1e-9 (an undamped orbit's multipliers lie on the circle up to
    rounding)."""
    return max(100.0 * float(error), 1e-9)


def unstable_count(multipliers, error) -> int:
    return int(np.sum(np.abs(multipliers) > 1.0 + stability_margin(error)))


def make_point(pm, ev, Gs, t, sigma, *, conservative, label="") -> Point:
    mult = np.linalg.eigvals(ev.M).astype(complex)
    mult = mult[np.argsort(-np.abs(mult), kind="stable")]
    psi, err = test_functions(ev.M, ev.error, conservative=conservative)
    k = unstable_count(mult, ev.error)
    half, half_error = None, 0.0
    if pm.periods % 2 == 0:
        e = pm.half.evaluate(ev.v)
        if e is not None:
            half, half_error = e.G, e.error
    return Point(ev=ev, Gs=Gs, t=t, sigma=float(sigma), psi=psi, psi_error=err,
                 multipliers=mult, stable=k == 0, unstable=k, label=label, half=half,
                 half_error=half_error)


def _persists(system, P, x, T) -> bool:
    """Whether the state x is (to rounding) a rest state that persists under the drive:
    |q̇| and |q̈| at 8 phases of the drive so small that q moves by less than 1e-12 over
    a period."""
    n = system.n_dof
    if float(np.max(np.abs(x[n:]))) * T > 1e-12:
        return False
    kernels = system.kernels
    W = kernels.work_array()
    out = np.empty(2 * n)
    for tt in np.linspace(0.0, T, 9)[:-1]:
        if kernels.rhs(float(tt), x, P, out, W) != 0:
            return False
        if float(np.max(np.abs(out[n:]))) * T * T > 1e-12:
            return False
    return True


def orbit_statistics(pm, x, p):
    """(q_mean, amplitude) of the orbit from x at parameter p: the mean of q and half its
    peak-to-peak range over the orbit's period, from 64 samples per drive period (the
    trapezoid rule over whole periods: exact for a band-limited orbit) of a DOP853 run at
    rtol 1e-10; a rest state that persists under the drive is its own mean, amplitude 0.
    A rotating orbit's are those of q(t) − 2π·winding·t/(periods·T), the uniform rotation
    removed (as :func:`kapitza.periodic_orbit`'s)."""
    system, n = pm.system, pm.n
    P = pm.parameters(p)
    T = pm.period(p)
    rotation = pm.shift[:n]
    if not rotation.any() and _persists(system, P, x, T):
        return x[:n].copy(), np.zeros(n)
    params = dict(zip(system.parameters, P.tolist(), strict=True))
    m = 64 * pm.periods
    times = np.linspace(0.0, T, m + 1)
    try:
        tr = system.simulate(x[:n], x[n:], (0.0, T), params, t_eval=times, rtol=1e-10,
                             method="dop853")
        qs = np.asarray(tr.q)[:-1] - rotation * (times[:-1, None] / T)
    except (ValueError, FloatingPointError, ArithmeticError):
        return np.full(n, math.nan), np.full(n, math.nan)
    return qs.mean(axis=0), 0.5 * (qs.max(axis=0) - qs.min(axis=0))
