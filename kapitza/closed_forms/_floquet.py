"""The vertically driven single pendulum's Floquet analysis from its Mathieu equation.

What :func:`kapitza.floquet_grid` computes about θ* = 0 or π — the verdict, the boundary
a point is beyond, the multipliers, the slow frequency Ω and its error — from the
monodromy trace of y″ + c y′ + (a − 2q cos 2τ) y = 0
(:func:`kapitza.closed_forms.mathieu_monodromy_trace`: RKN 12 to a stated tolerance)
instead of the general monodromy of the system's Jacobian.  A 2 × 2 monodromy is fixed
by its trace and its determinant, which Liouville's formula gives exactly
(det M = e^(−γT)), so nothing is lost; what is gained is time: the trace costs
microseconds per point and its kernel compiles in ~2 s, against ~20 s for the general
Floquet kernels on an empty cache (2026-11-26) — the wait of a first ``kapitza report``,
whose verification and captions use this.

Conventions (shared/PHYSICS.md; :mod:`kapitza.closed_forms._mathieu`): τ = ωt/2, so one
drive period T = 2π/ω is one τ-period π; tr M_y = e^(−γT/2) tr M_u, and with
√det M_y = e^(−γT/2) the slow frequency is Ω = arccos(tr M_u / 2) / T where
|tr M_u| ≤ 2 (the formula of :meth:`kapitza.KapitzaPendulum.floquet`).  Stable iff both
multipliers lie in the closed unit disk, |tr M_y| ≤ 1 + det M_y (Jury), i.e.
|tr M_u| ≤ 2 cosh(γT/2).
"""
from __future__ import annotations

from types import SimpleNamespace

import numpy as np

from ..results import BOUNDARIES
from ._mathieu import _monodromy_trace, mathieu_parameters

__all__ = ["pendulum_floquet", "slow_frequency_error"]


def slow_frequency_error(omega_slow, T, delta):
    """A bound on the error of Ω = arccos(c) / T (rad/s) when c = cos ΩT is known to ±δ:
    δ / (T max(|sin ΩT|, √δ)) — arccos's slope where ΩT is away from 0 and π, and √δ/T
    at those ends, where arccos is not Lipschitz; 0 where δ = 0.  The bound of Ω from
    any monodromy (:func:`pendulum_floquet`; :mod:`kapitza.verification`'s general one)."""
    with np.errstate(invalid="ignore", divide="ignore"):
        turn = np.maximum(np.abs(np.sin(omega_slow * T)), np.sqrt(delta))
        return np.where(delta > 0, delta / (T * turn), 0.0)


def pendulum_floquet(A, omega, *, l, g, damping=0.0, about="inverted", tol=1e-10):
    """Floquet analysis of the vertically driven pendulum about ``about`` on a grid.

    Parameters
    ----------
    A, omega : float or array
        Drive amplitude (m) and angular frequency (rad/s); broadcast together.
    l, g, damping : float
        Rod length (m), gravity (m/s²), viscous damping rate γ (1/s).
    about : {"inverted", "hanging"}
        θ* = π or θ* = 0.
    tol : float
        Tolerance of tr M_u relative to max(1, |tr M_u|).

    Returns
    -------
    types.SimpleNamespace
        Arrays over the broadcast shape: ``trace`` (tr M_y), ``stable``, ``label`` (0, 1,
        2) and ``boundary`` (its name in :data:`kapitza.results.BOUNDARIES`: "stable",
        "T", "2T"), ``multipliers`` (shape + (2,), complex), ``omega_slow`` (rad/s, NaN
        where unstable), ``omega_slow_error`` (a bound on its error from the trace's:
        :func:`slow_frequency_error` with δ that of tr M_u / 2, as
        :mod:`kapitza.verification` bounds the general monodromy's), ``margin`` (the
        distance of |tr M_u| from the stability limit in units of twice its error bound:
        below 1 the verdict is not certain).
    """
    A, omega = np.broadcast_arrays(np.asarray(A, dtype=float), np.asarray(omega, dtype=float))
    a, q, c = mathieu_parameters(A, omega, l, g, damping, about=about)
    trace_y, log_abs, error = _monodromy_trace(a, q, c, tol=tol)   # its error: in the bounds
    trace_y, log_abs, error = (np.asarray(x, dtype=float) for x in (trace_y, log_abs, error))
    T = 2 * np.pi / omega
    half_damp = damping * T / 2                         # γT/2 = cπ/2
    # tr M_u = e^(γT/2) tr M_y, formed from the log so that huge traces stay finite
    with np.errstate(over="ignore"):
        trace_u = np.sign(trace_y) * np.exp(np.minimum(log_abs + half_damp, 700.0))
    limit = 2.0 * np.cosh(half_damp)
    bound = np.maximum(10.0 * error, 1e-13) * np.maximum(1.0, np.abs(trace_u))
    stable = (np.abs(trace_u) <= limit) & (log_abs + half_damp < 700.0)
    label = np.where(stable, 0, np.where(trace_u > 0, 1, 2)).astype(np.int8)
    margin = np.abs(limit - np.abs(trace_u)) / (2.0 * bound)
    with np.errstate(invalid="ignore"):
        omega_slow = np.where(stable, np.arccos(np.clip(trace_u / 2, -1.0, 1.0)) / T, np.nan)
    # bound / 2: the error of cos ΩT = tr M_u / 2
    omega_slow_error = np.where(stable, slow_frequency_error(omega_slow, T, bound / 2), np.nan)
    det = np.exp(-damping * T)                          # Liouville
    root = np.sqrt((trace_y * trace_y - 4.0 * det).astype(complex))
    multipliers = np.stack([(trace_y + root) / 2, (trace_y - root) / 2], axis=-1)
    return SimpleNamespace(trace=trace_y, stable=stable, label=label,
                           boundary=np.asarray(BOUNDARIES)[label], multipliers=multipliers,
                           omega_slow=omega_slow, omega_slow_error=omega_slow_error,
                           margin=margin)
