"""Derive the equations of motion of a :class:`~lagrange_core.System`.

The one canonical form
----------------------
Every system is brought to::

    M(q, t) q̈ = F(q, q̇, t) + Φ_q(q, t)ᵀ λ,     Φ_q q̈ = γ(q, q̇, t),

where Φ(q, t) = 0 are the holonomic constraints, Φ_q = ∂Φ/∂q, and
γ = −(∂Φ̇/∂q) q̇ − ∂Φ̇/∂t comes from differentiating the constraints twice
(Φ̇ = Φ_q q̇ + Φ_t).  Solving both blocks together (the *augmented* form)
gives q̈ and the multipliers λ; the generalized constraint force is Φ_qᵀ λ.

How it is derived (and why it is fast)
--------------------------------------
Differentiating one large Lagrangian is what makes
``sympy.physics.mechanics.LagrangesMethod`` slow for many links.  Here the
particle terms are formed directly from each particle's Jacobian
J_i = ∂r_i/∂q and velocity v_i = J_i q̇ + ∂r_i/∂t:

    M = Σ m_i J_iᵀ J_i,   F = Q − ∂D/∂q̇ − ∂V/∂q − Σ m_i J_iᵀ [(∂v_i/∂q) q̇ + ∂v_i/∂t],

which is Lagrange's equation for T = Σ ½ m_i |v_i|² written out (the bracket is
the part of the particle's acceleration that does not contain q̈).  An explicit
Lagrangian term L' adds its velocity Hessian to M and
∂L'/∂q − (∂²L'/∂q̇∂q) q̇ − ∂²L'/∂q̇∂t to F.  The algebra runs in symengine
(a C++ core with sympy's semantics); users only ever see sympy.
"""
from __future__ import annotations

import functools
from dataclasses import dataclass, field

import sympy as sp
import symengine as se

from .systems import System, t as t_symbol

__all__ = ["Equations", "derive"]


def _se(expr):
    return se.sympify(expr)


def _to_sympy(expr):
    return sp.sympify(expr)


def _matrix_to_sympy(rows):
    return sp.Matrix([[_to_sympy(e) for e in row] for row in rows]) if rows else sp.zeros(0, 0)


@dataclass(frozen=True, eq=False)
class Equations:
    """The derived equations of a system, in the canonical form (immutable).

    Symbolic fields are symengine expressions (``*_se``) and are offered as
    sympy objects through the properties of the same name without the suffix.

    Attributes
    ----------
    system : System
        The statement they were derived from.
    mass_matrix : sympy.Matrix, (n, n)
        M(q, t), symmetric.
    forcing : sympy.Matrix, (n, 1)
        F(q, q̇, t).
    constraint_jacobian : sympy.Matrix, (m, n)
        Φ_q.
    constraint_rhs : sympy.Matrix, (m, 1)
        γ, so that Φ_q q̈ = γ.
    lagrangian : sympy expression
        L = T − V + L'.
    energy : sympy expression
        h = Σ q̇_j ∂L/∂q̇_j − L (the energy function; equals T + V when the
        positions do not depend on t).
    """

    system: System
    mass_matrix_se: tuple            # n x n, tuple of tuples
    forcing_se: tuple                # n
    constraints_se: tuple            # m: Φ
    constraint_jacobian_se: tuple    # m x n
    constraint_velocity_se: tuple    # m: Φ̇ = Φ_q q̇ + Φ_t
    constraint_rhs_se: tuple         # m: γ
    lagrangian_se: object
    energy_se: object
    _explicit_time: bool = field(repr=False, default=False)

    # -- sympy views --------------------------------------------------------------
    @functools.cached_property
    def mass_matrix(self) -> sp.Matrix:
        return _matrix_to_sympy(self.mass_matrix_se)

    @functools.cached_property
    def forcing(self) -> sp.Matrix:
        return sp.Matrix([_to_sympy(e) for e in self.forcing_se])

    @functools.cached_property
    def constraint_jacobian(self) -> sp.Matrix:
        if not self.constraints_se:
            return sp.zeros(0, len(self.system.q))
        return _matrix_to_sympy(self.constraint_jacobian_se)

    @functools.cached_property
    def constraint_rhs(self) -> sp.Matrix:
        return sp.Matrix([_to_sympy(e) for e in self.constraint_rhs_se])

    @functools.cached_property
    def lagrangian(self) -> sp.Expr:
        return _to_sympy(self.lagrangian_se)

    @functools.cached_property
    def energy(self) -> sp.Expr:
        return _to_sympy(self.energy_se)

    # -- first integrals ---------------------------------------------------------
    @property
    def energy_conserved(self) -> bool:
        """True if h is a constant of the motion.

        That holds when L has no explicit time dependence, the constraints are
        scleronomic (no t) and there are no generalized forces or dissipation.
        """
        s = self.system
        no_forces = all(f == 0 for f in s.forces) and s.dissipation == 0
        return (not self._explicit_time) and no_forces

    @functools.cached_property
    def conserved_momenta(self) -> dict[str, sp.Expr]:
        """Momenta p_j = ∂L/∂q̇_j conserved because q_j is cyclic.

        q_j is cyclic when ∂L/∂q_j = 0, no force or dissipation acts on it and
        no constraint involves it.  Returns ``{coordinate name: p_j}``.
        """
        s = self.system
        L = self.lagrangian_se
        out = {}
        for j, (qj, vj) in enumerate(zip(s.q, s.qdot)):
            if se.diff(L, _se(qj)) != 0:
                continue
            if s.forces[j] != 0 or sp.diff(s.dissipation, vj) != 0:
                continue
            if any(c.has(qj) for c in s.constraints):
                continue
            out[qj.name] = sp.simplify(_to_sympy(se.diff(L, _se(vj))))
        return out


def derive(system: System) -> Equations:
    """Derive the Euler–Lagrange equations of ``system`` in the canonical form.

    Parameters
    ----------
    system : System

    Returns
    -------
    Equations
        Immutable; :attr:`System.equations` caches it.
    """
    q = [_se(s) for s in system.q]
    v = [_se(s) for s in system.qdot]
    t = _se(t_symbol)
    n = len(q)

    M = [[se.Integer(0)] * n for _ in range(n)]
    F = [se.Integer(0)] * n
    T = se.Integer(0)

    # Particle terms: M = Σ m JᵀJ, F -= Σ m Jᵀ (velocity-product + explicit-time part of r̈).
    for particle in system.particles:
        m = _se(particle.mass)
        r = [_se(c) for c in particle.position]
        J = [[se.diff(rk, qj) for qj in q] for rk in r]
        vel = [sum((J[k][j] * v[j] for j in range(n)), se.Integer(0)) + se.diff(r[k], t)
               for k in range(len(r))]
        bias = [sum((se.diff(vel[k], q[j]) * v[j] for j in range(n)), se.Integer(0))
                + se.diff(vel[k], t) for k in range(len(r))]
        for i in range(n):
            for j in range(i, n):
                mij = sum((J[k][i] * J[k][j] for k in range(len(r))), se.Integer(0))
                if mij != 0:
                    M[i][j] = M[i][j] + m * mij
            fi = sum((J[k][i] * bias[k] for k in range(len(r))), se.Integer(0))
            if fi != 0:
                F[i] = F[i] - m * fi
        T = T + m * sum((vk * vk for vk in vel), se.Integer(0)) / 2
    for i in range(n):
        for j in range(i):
            M[i][j] = M[j][i]

    # Explicit Lagrangian term L'(q, q̇, t) and potential V(q, t).
    L_extra = _se(system.lagrangian_term)
    V = _se(system.potential)
    if L_extra != 0:
        dL_dv = [se.diff(L_extra, vj) for vj in v]
        for i in range(n):
            for j in range(n):
                M[i][j] = M[i][j] + se.diff(dL_dv[i], v[j])
            F[i] = (F[i] + se.diff(L_extra, q[i])
                    - sum((se.diff(dL_dv[i], q[j]) * v[j] for j in range(n)), se.Integer(0))
                    - se.diff(dL_dv[i], t))
    D = _se(system.dissipation)
    for i in range(n):
        F[i] = F[i] - se.diff(V, q[i]) + _se(system.forces[i]) - se.diff(D, v[i])

    L = T - V + L_extra
    energy = sum((vj * se.diff(L, vj) for vj in v), se.Integer(0)) - L

    # Constraints: Φ_q q̈ = γ with γ = -(∂Φ̇/∂q) q̇ - ∂Φ̇/∂t.
    Phi = [_se(c) for c in system.constraints]
    Phi_q = [[se.diff(c, qj) for qj in q] for c in Phi]
    Phi_dot = [sum((row[j] * v[j] for j in range(n)), se.Integer(0)) + se.diff(c, t)
               for c, row in zip(Phi, Phi_q)]
    gamma = [-(sum((se.diff(pd, q[j]) * v[j] for j in range(n)), se.Integer(0)) + se.diff(pd, t))
             for pd in Phi_dot]

    explicit_time = (se.diff(L, t) != 0) or any(se.diff(c, t) != 0 for c in Phi)
    return Equations(
        system=system,
        mass_matrix_se=tuple(tuple(row) for row in M),
        forcing_se=tuple(F),
        constraints_se=tuple(Phi),
        constraint_jacobian_se=tuple(tuple(r) for r in Phi_q),
        constraint_velocity_se=tuple(Phi_dot),
        constraint_rhs_se=tuple(gamma),
        lagrangian_se=L,
        energy_se=energy,
        _explicit_time=bool(explicit_time),
    )
