"""Where a symmetric periodic orbit loses its symmetry: the symmetry-breaking pitchfork.

The horizontally driven pendulum's hanging orbit is symmetric under the half-period
reflection (θ(t + T/2) = −θ(t); :mod:`kapitza.floquet._shooting`).  It loses stability
where the tilted orbits branch off: a multiplier of the monodromy M = (R X_h)² reaches +1
from an antisymmetric direction, i.e. a multiplier μ of the half-period map R X_h reaches
−1.  The margin

    m(A) = det(I + R X_h) = det(I − X_h)       (R = −I)

is smooth in the amplitude and changes sign there (|1 + μ|² > 0 while the pair μ, μ̄ is
on the unit circle; (1 + μ₁)(1 + μ₂) < 0 once one real μ is beyond −1), and the orbit
itself stays regular: the half-period shooting's matrix R X_h − I is not singular at the
pitchfork, so every evaluation of m is an honest solve (full-period shooting is singular
exactly there).  The root is bracketed and found by :func:`scipy.optimize.brentq`, each
orbit continued from the previous one.

Accuracy: m is known to about the half-period monodromy's error ε (the flow's tolerance,
tol/100); near the root m ≈ m′ (A − A*) with m′ ∝ (ω0/ω)² for a fast drive, so A* is
known to ε/|m′| (returned as ``accuracy``): ~1e-12 relative at ω/ω0 = 120 with the
default tol.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..floquet import SYMMETRY_RTOL, shoot, symmetry_defect
from ._periodic_orbit import _period, _start

__all__ = ["SymmetryBreaking", "symmetry_breaking"]


@dataclass(frozen=True)
class SymmetryBreaking:
    """The amplitude at which a symmetric orbit undergoes the symmetry-breaking pitchfork.

    Attributes
    ----------
    amplitude : float
        The drive amplitude A* (the units of the amplitude parameter, m for the pendulum).
    accuracy : float
        Its estimated absolute error: the margin's error over its slope at the root.
    slope : float
        dm/dA at the root (m = det(I − X_h)).
    state : ndarray (2n,)
        The symmetric orbit's [q, q̇] at t = 0 at A*.
    evaluations : int
        Orbits solved.
    """

    amplitude: float
    accuracy: float
    slope: float
    state: np.ndarray
    evaluations: int


def symmetry_breaking(system, params, about, *, A_range, amplitude="A", frequency="omega",
                      tol=1e-12, max_steps=1 << 16) -> SymmetryBreaking:
    """The amplitude in ``A_range`` where the orbit symmetric about ``about`` breaks its
    symmetry (a multiplier +1 of its monodromy from an antisymmetric direction).

    Parameters
    ----------
    system : lagrange_core.System
        A drive with the half-period reflection symmetry about ``about`` (tested; the
        horizontal pivot about θ = 0 or π).
    params : dict
        Parameter values; ``params[amplitude]`` is not used (it is searched).
    about : array_like
        The centre c of the symmetry, coordinates (the hanging pendulum: [0.0]).
    A_range : (low, high)
        Amplitudes bracketing the bifurcation (the margin must change sign).
    amplitude, frequency : str
        The drive's amplitude and angular-frequency parameters.
    tol : float
        The shooting's residual tolerance (the flow is integrated to tol/100).

    Returns
    -------
    SymmetryBreaking
    """
    from scipy.optimize import brentq
    lo, hi = (float(v) for v in A_range)
    if not (0 <= lo < hi and math.isfinite(hi)):
        raise ValueError(f"A_range must be (low, high) with 0 ≤ low < high, got {A_range!r}.")
    if amplitude not in system.parameters:
        raise ValueError(f"symmetry_breaking: no amplitude parameter {amplitude!r}; name it "
                         f"with amplitude=... (the parameters are {list(system.parameters)}).")
    params = dict(params)
    T = _period(system, params, frequency, 1)
    y0, at_rest = _start(system, params, about, frequency)
    n = system.n_dof
    if not at_rest:
        raise ValueError(f"symmetry_breaking: about must be the symmetry's centre, {n} "
                         f"coordinates, got {about!r}.")
    center = y0[:n].copy()
    last = {"y": y0}
    evaluations = [0]

    def reduced(A):
        p = system.parameter_array(dict(params, **{amplitude: A}))
        defect = symmetry_defect(system, p, center, T)
        if not defect <= SYMMETRY_RTOL:
            raise ValueError(f"symmetry_breaking: at {amplitude} = {A:.6g} the vector field "
                             f"lacks the half-period reflection symmetry about "
                             f"{center.tolist()} (relative defect {defect:.3g}).")
        try:
            shot = shoot(system, p, last["y"], T, center=center, tol=tol, max_steps=max_steps)
        except ValueError:
            shot = shoot(system, p, y0, T, center=center, tol=tol, max_steps=max_steps)
        last["y"] = shot.state
        evaluations[0] += 1
        return shot

    def margin(A):
        shot = reduced(A)
        return float(np.linalg.det(np.eye(2 * n) + shot.reduced))

    m_lo, m_hi = margin(lo), margin(hi)
    if not m_lo * m_hi < 0:
        raise ValueError(f"symmetry_breaking: the margin det(I + R X_h) has the same sign at "
                         f"both ends of A_range = ({lo:.6g}, {hi:.6g}) ({m_lo:.3g}, "
                         f"{m_hi:.3g}): no symmetry-breaking bifurcation bracketed; widen it.")
    root = brentq(margin, lo, hi, xtol=1e-15 * hi, rtol=4 * np.finfo(float).eps, maxiter=200)
    shot = reduced(root)
    h = max(1e-7 * root, 1e-12)
    slope = (margin(root + h) - margin(root - h)) / (2 * h)
    # det(I + R X_h) moves by about its matrix's error times its size; the monodromy's
    # error bound (2‖X_h‖ ε plus the state's share) over-covers R X_h's own
    err_m = shot.monodromy_error * max(1.0, float(np.linalg.norm(shot.reduced, np.inf)))
    accuracy = err_m / abs(slope) if slope else math.inf
    return SymmetryBreaking(amplitude=float(root), accuracy=float(accuracy),
                            slope=float(slope), state=shot.state, evaluations=evaluations[0])
