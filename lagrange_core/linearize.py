"""Linearisation about an equilibrium and normal modes.

About an equilibrium q* (q̇ = 0, q̈ = 0) the motion obeys, to first order in the
displacement δq,

    M δq̈ + C δq̇ + K δq = 0,    M = M(q*),  C = −∂F/∂q̇,  K = −∂(F + Φ_qᵀλ)/∂q,

evaluated from the exact compiled Jacobian (no finite differences).  With
constraints the displacements are restricted to the null space N of Φ_q
(δq = N δu), giving the reduced matrices Nᵀ M N, Nᵀ C N, Nᵀ K N; ``about`` must lie on the
constraint surface (a point with Φ(q*, t) ≠ 0 is refused with the residual: the
matrices there would describe another system, e.g. a pendulum of another length).  The
normal-mode angular frequencies are the square roots of the generalized
eigenvalues of K v = ω² M v.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

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
        If ``about`` violates a constraint (|Φ_i|/|∂Φ_i/∂q| > 1e-8 max(1, |q|)), is
        not an equilibrium (|q̈| > 1e-8 relative to the stiffness scale) or the
        mass matrix is singular there.
    """
    import scipy.linalg  # here, not at import: it costs `import lagrange_core` 0.5 s
    n, m = system.n_dof, system.n_constraints
    q0 = np.zeros(n) if about is None else system.coordinate_array(about, "about")
    p = system.parameter_array(params)
    k = system.kernels
    if m:
        _check_constraints(system, q0, float(t), p)
    y = np.concatenate([q0, np.zeros(n)])
    J = np.empty((2 * n, 2 * n))
    if k.jacobian(float(t), y, p, J) != 0:
        raise ValueError(f"the mass matrix is singular at q={q0.tolist()}; cannot linearise there.")
    M = np.empty((n, n))
    F = np.empty(n)
    k.mass_forcing(q0, np.zeros(n), float(t), p, M, F)
    # J's lower blocks are dq̈/dq and dq̈/dq̇ (constraint forces included), so K = −M dq̈/dq.
    K = -M @ J[n:, :n]
    C = -M @ J[n:, n:]
    basis = np.eye(n)
    # q̈ at q̇ = 0 (is this an equilibrium?) solved here from M and F (or the augmented
    # system): neither ``accelerations`` nor ``rhs`` is compiled for one state
    if m:
        W = k.work_array()
        k.augmented(q0, np.zeros(n), float(t), p, W)
        basis = scipy.linalg.null_space(W[n:, :n])      # rows n.. of W hold Φ_q
        qdd = np.linalg.solve(W[:, :n + m], W[:, n + m])[:n]
    else:
        qdd = np.linalg.solve(M, F)
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


#: A constraint residual |Φ_i| / |∇Φ_i| (≈ the distance to the constraint surface in
#: coordinate units) above this, relative to max(1, |q|), is a violation.
CONSTRAINT_TOLERANCE = 1e-8


def _constraint_violation(system, q, t, p) -> tuple[np.ndarray, np.ndarray]:
    """The constraint residuals Φ(q, t) and the distances they stand for.

    Parameters
    ----------
    system : System
    q : ndarray
        Coordinates.
    t : float
        Time (s).
    p : ndarray
        Parameter values (``System.parameter_array``).

    Returns
    -------
    residual, distance : ndarray, shape (m,)
        Φ_i (in the constraint's own units) and the first-order distance of q from
        the surface Φ_i = 0, |Φ_i| / |∂Φ_i/∂q| (units of the coordinates; |Φ_i| where
        the gradient vanishes).
    """
    n, m = system.n_dof, system.n_constraints
    k = system.kernels
    out = np.empty(2 * m)
    k.constraint_residual(q, np.zeros(n), t, p, out)
    W = k.work_array()
    k.augmented(q, np.zeros(n), t, p, W)
    grad = W[n:n + m, :n]                               # Φ_q
    norm = np.linalg.norm(grad, axis=1)
    residual = out[:m]
    distance = np.abs(residual) / np.where(norm > 0, norm, 1.0)
    return residual, distance


def _check_constraints(system, q0, t, p):
    residual, distance = _constraint_violation(system, q0, t, p)
    bad = np.flatnonzero(~(distance <= CONSTRAINT_TOLERANCE * max(1.0, np.max(np.abs(q0)))))
    if bad.size:
        lines = "; ".join(f"constraint {i} ({system.constraints[i]} = 0): Φ = {residual[i]:.6g}, "
                          f"about {distance[i]:.3g} away" for i in bad)
        raise ValueError(
            f"about={q0.tolist()} violates the constraints of {system._label()} at t={t}: "
            f"{lines}. An equilibrium of a constrained system lies on its constraint surface; "
            "pass coordinates that satisfy every constraint (the linearisation would otherwise "
            "describe a different system).")
