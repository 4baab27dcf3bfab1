"""Linearisation about an equilibrium and normal modes.

About an equilibrium q* (q̇ = 0, q̈ = 0) the motion obeys, to first order in the
displacement δq,

    M δq̈ + C δq̇ + K δq = 0,    M = M(q*),  C = −∂F/∂q̇,  K = −∂(F + Φ_qᵀλ)/∂q,

evaluated from the exact compiled Jacobian (no finite differences).  With
constraints the displacements are restricted to the null space N of Φ_q
(δq = N δu), giving the reduced matrices Nᵀ M N, Nᵀ C N, Nᵀ K N.  The
normal-mode angular frequencies are the square roots of the generalized
eigenvalues of K v = ω² M v.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.linalg

__all__ = ["Linearization", "linearize"]


@dataclass(frozen=True)
class Linearization:
    """M δq̈ + C δq̇ + K δq = 0 about ``about`` (in reduced coordinates if constrained).

    Attributes
    ----------
    about : ndarray
        The equilibrium's coordinates.
    mass, damping, stiffness : ndarray
        M, C and K (SI units of the coordinates).
    residual : float
        |q̈| at the supposed equilibrium with q̇ = 0; not ≈ 0 means ``about``
        is not an equilibrium.
    omega_squared : ndarray
        Generalized eigenvalues of (K, M), ascending; negative means unstable.
    basis : ndarray
        Columns span the admissible displacements (identity if unconstrained).
    """

    about: np.ndarray
    mass: np.ndarray
    damping: np.ndarray
    stiffness: np.ndarray
    residual: float
    omega_squared: np.ndarray
    basis: np.ndarray

    @property
    def stable(self) -> bool:
        """True if every ω² > 0 (undamped linear stability)."""
        return bool(np.all(self.omega_squared > 0))

    @property
    def frequencies(self) -> np.ndarray:
        """Angular frequencies sqrt(ω²) (rad/s); NaN marks an unstable mode."""
        w2 = self.omega_squared
        return np.where(w2 >= 0, np.sqrt(np.abs(w2)), np.nan)


def linearize(system, params=None, about=None, t=0.0) -> Linearization:
    """Linearise ``system`` about the equilibrium ``about`` at time ``t``.

    Parameters
    ----------
    system : System
    params : dict
        Parameter values by name.
    about : sequence or dict, optional
        Coordinates of the equilibrium (zeros by default).
    t : float
        Time at which explicit time dependence is frozen.

    Raises
    ------
    ValueError
        If ``about`` is not an equilibrium (|q̈| > 1e-8 relative to the
        stiffness scale) or the mass matrix is singular there.
    """
    n, m = system.n_dof, system.n_constraints
    q0 = np.zeros(n) if about is None else system.coordinate_array(about, "about")
    p = system.parameter_array(params)
    k = system.kernels
    y = np.concatenate([q0, np.zeros(n)])
    J = np.empty((2 * n, 2 * n))
    if k.jacobian(float(t), y, p, J) != 0:
        raise ValueError(f"the mass matrix is singular at q={q0.tolist()}; cannot linearise there.")
    qdd = np.empty(n)
    lam = np.empty(m)
    k.accelerations(q0, np.zeros(n), float(t), p, qdd, lam, k.work_array())
    M = np.empty((n, n))
    F = np.empty(n)
    k.mass_forcing(q0, np.zeros(n), float(t), p, M, F)
    # J's lower blocks are dq̈/dq and dq̈/dq̇ (constraint forces included), so K = −M dq̈/dq.
    K = -M @ J[n:, :n]
    C = -M @ J[n:, n:]
    basis = np.eye(n)
    if m:
        W = k.work_array()
        k.augmented(q0, np.zeros(n), float(t), p, W)
        basis = scipy.linalg.null_space(W[n:, :n])      # rows n.. of W hold Φ_q
    Mr, Cr, Kr = (basis.T @ X @ basis for X in (M, C, K))
    # |q̈| is compared with ω²·(1 rad or 1 m), the natural acceleration scale
    scale = np.max(np.abs(np.diag(Kr)) / np.abs(np.diag(Mr)))
    residual = float(np.max(np.abs(qdd)))
    if residual > 1e-8 * max(scale, 1e-300):
        raise ValueError(
            f"q={q0.tolist()} is not an equilibrium: q̈ = {qdd.tolist()} there with q̇ = 0. Pass "
            "the equilibrium's coordinates as `about`.")
    w2 = scipy.linalg.eigvals(Kr, Mr)
    if np.max(np.abs(w2.imag), initial=0.0) > 1e-9 * max(np.max(np.abs(w2)), 1e-300):
        raise ValueError("the stiffness is not symmetric about this equilibrium (circulatory "
                         f"forces?): ω² = {w2}; inspect Linearization matrices instead.")
    return Linearization(about=q0, mass=Mr, damping=Cr, stiffness=Kr, residual=residual,
                         omega_squared=np.sort(w2.real), basis=basis)
