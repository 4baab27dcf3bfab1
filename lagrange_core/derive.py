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
import random
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import sympy as sp
import symengine as se

from .symbols import t as t_symbol

if TYPE_CHECKING:     # typing only: the statement sits above its derivation
    from .systems import System

__all__ = ["Equations", "ParticleTerms", "derive"]

#: the sympy view of M is simplified for systems of up to this many coordinates
SIMPLIFY_DOF = 3


def _se(expr):
    return se.sympify(expr)


def _is_zero(expr) -> bool:
    """Whether an expression vanishes identically (cheap symengine expansion, then sympy)."""
    expr = se.expand(expr)
    if expr == 0:
        return True
    # a value clearly away from zero at a random point settles it without simplification
    rng = random.Random(len(str(expr)))
    for _ in range(3):
        point = {s: rng.uniform(0.3, 1.7) for s in expr.free_symbols}
        try:
            value = complex(expr.subs(point))
        except (TypeError, ValueError, RuntimeError):
            break
        if abs(value) > 1e-9:
            return False
    return sp.simplify(sp.sympify(expr)) == 0


def _symbol_map(system):
    """symengine drops sympy's assumptions: map plain names back to the system's symbols."""
    symbols = [*system.q, *system.qdot, *system.parameter_symbols, t_symbol]
    return {sp.Symbol(s.name): s for s in symbols}


#: Functions whose symengine derivative is left unevaluated (Derivative(abs(x), x)) or
#: is not a function symengine knows: expressions with them are differentiated by sympy.
_NONSMOOTH = (sp.Abs, sp.sign, sp.Heaviside, sp.Max, sp.Min, sp.Piecewise)


def _differentiator(system):
    """``diff(expr, symbol)`` for the statement's symengine expressions.

    symengine differentiates everything smooth, fast, but leaves the derivatives of
    ``abs``, ``sign``, ``Max`` and ``Min`` unevaluated.  Where it does, in a statement
    that uses such functions, sympy differentiates instead, on the statement's real
    symbols, with the derivatives of the kinks taken almost everywhere: d|u| = sign(u) du,
    d sign(u) = dH(u) = 0 (sympy's DiracDelta is dropped: the kernels evaluate functions
    pointwise).  sympy's Heaviside, which symengine only wraps, differentiates to 0 there
    too.
    """
    exprs = [system.lagrangian_term, system.potential, system.dissipation,
             *system.constraints, *system.forces]
    for p in system.particles:
        exprs += [p.mass, *p.position]
    if not any(e.has(*_NONSMOOTH) for e in exprs):
        return se.diff
    symbols = _symbol_map(system)

    def diff(expr, s):
        d = se.diff(expr, s)
        if not d.atoms(se.Derivative, se.Subs):
            return d
        e = sp.sympify(expr).xreplace(symbols)
        d = sp.diff(e, sp.sympify(s).xreplace(symbols))
        return _se(d.replace(sp.DiracDelta, lambda *args: sp.S.Zero))

    return diff


@dataclass(frozen=True)
class ParticleTerms:
    """One particle's share of the equations (symengine expressions).

    M gets m JᵀJ and F gets −m Jᵀ·bias, where J = ∂r/∂q (d × n) and bias is
    the part of r̈ without q̈: (∂v/∂q) q̇ + ∂v/∂t with v = J q̇ + ∂r/∂t.
    """

    mass: object
    jacobian: tuple     # d x n
    bias: tuple         # d
    r_t: tuple          # d: ∂r/∂t


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
    particle_terms: tuple            # ParticleTerms, one per particle
    mass_rest_se: tuple              # n x n: velocity Hessian of the explicit L'
    forcing_rest_se: tuple           # n: F without the particle inertia terms
    energy_rest_se: object           # h − ½ q̇ᵀ M q̇
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
    def _to_sympy(self, expr):
        return sp.sympify(expr).xreplace(self._symbols)

    @functools.cached_property
    def _symbols(self):
        return _symbol_map(self.system)

    @functools.cached_property
    def mass_matrix(self) -> sp.Matrix:
        """M(q, t) as sympy.  For up to ``SIMPLIFY_DOF`` coordinates its entries are
        simplified with ``trigsimp`` (m (l² sin²θ + l² cos²θ) → l² m; ~30 ms an entry, so
        larger systems keep them as derived).  The kernels never use this view."""
        n = len(self.system.q)
        entries = [self._to_sympy(e) for row in self.mass_matrix_se for e in row]
        if n <= SIMPLIFY_DOF:
            entries = [sp.trigsimp(e) for e in entries]
        return sp.Matrix(n, n, entries)

    @functools.cached_property
    def forcing(self) -> sp.Matrix:
        return sp.Matrix([self._to_sympy(e) for e in self.forcing_se])

    @functools.cached_property
    def constraint_jacobian(self) -> sp.Matrix:
        m, n = len(self.constraints_se), len(self.system.q)
        return sp.Matrix(m, n, [self._to_sympy(e) for row in self.constraint_jacobian_se
                                for e in row])

    @functools.cached_property
    def constraint_rhs(self) -> sp.Matrix:
        return sp.Matrix([self._to_sympy(e) for e in self.constraint_rhs_se])

    @functools.cached_property
    def lagrangian(self) -> sp.Expr:
        return self._to_sympy(self.lagrangian_se)

    @functools.cached_property
    def energy(self) -> sp.Expr:
        return self._to_sympy(self.energy_se)

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
        diff = _differentiator(s)
        out = {}
        for j, (qj, vj) in enumerate(zip(s.q, s.qdot)):
            if not _is_zero(diff(L, _se(qj))):
                continue
            if s.forces[j] != 0 or sp.diff(s.dissipation, vj) != 0:
                continue
            if any(c.has(qj) for c in s.constraints):
                continue
            out[qj.name] = sp.simplify(self._to_sympy(diff(L, _se(vj))))
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

    zero = se.Integer(0)
    diff = _differentiator(system)
    mass_rate = []      # (ṁ, J, v, moving columns) of the particles whose mass depends on t

    # Particle terms: each particle's mass, Jacobian J = ∂r/∂q, the q̈-free part of its
    # acceleration ("bias" (∂v/∂q) q̇ + ∂v/∂t) and ∂r/∂t.  The compiled kernels assemble
    # M and F from these numerically; here they are also assembled symbolically.
    particle_terms = []
    for particle in system.particles:
        m = _se(particle.mass)
        r = [_se(c) for c in particle.position]
        # only the coordinates the particle moves with: O(Σ nnz²) work, not O(n_particles n²)
        moves = [j for j, qj in enumerate(q) if any(rk.has(qj) for rk in r)]
        J = [[diff(rk, qj) if j in moves else zero for j, qj in enumerate(q)] for rk in r]
        r_t = [diff(rk, t) for rk in r]
        vel = [sum((J[k][j] * v[j] for j in moves), zero) + r_t[k] for k in range(len(r))]
        bias = [sum((diff(vel[k], q[j]) * v[j] for j in moves), zero) + diff(vel[k], t)
                for k in range(len(r))]
        particle_terms.append(ParticleTerms(m, tuple(map(tuple, J)), tuple(bias), tuple(r_t)))
        # a mass that changes with time: d/dt ∂T/∂q̇ = d/dt (m Jᵀv) also contains ṁ Jᵀv
        m_t = diff(m, t)
        if m_t != 0:
            mass_rate.append((m_t, J, vel, moves))

    # Explicit Lagrangian term L'(q, q̇, t), potential V(q, t), forces and dissipation.
    L_extra = _se(system.lagrangian_term)
    V = _se(system.potential)
    D = _se(system.dissipation)
    dL_dv = [diff(L_extra, vj) for vj in v]
    M_rest = [[diff(dL_dv[i], v[j]) if dL_dv[i] != 0 else zero for j in range(n)]
              for i in range(n)]
    F_rest = [- diff(V, q[i]) + _se(system.forces[i]) - diff(D, v[i]) for i in range(n)]
    if L_extra != 0:
        F_rest = [F_rest[i] + diff(L_extra, q[i])
                  - sum((diff(dL_dv[i], q[j]) * v[j] for j in range(n)), zero)
                  - diff(dL_dv[i], t) for i in range(n)]
    for m_t, J, vel, moves in mass_rate:
        for j in moves:
            F_rest[j] = F_rest[j] - m_t * sum((J[k][j] * vel[k] for k in range(len(vel))), zero)

    # Assembled: M = M' + Σ m JᵀJ,  F = F' − Σ m Jᵀ bias.
    M = [row[:] for row in M_rest]
    F = F_rest[:]
    T = zero
    for pt in particle_terms:
        d = len(pt.bias)
        cols = [j for j in range(n) if any(pt.jacobian[k][j] != 0 for k in range(d))]
        for a, i in enumerate(cols):
            for j in cols[a:]:
                mij = sum((pt.jacobian[k][i] * pt.jacobian[k][j] for k in range(d)), zero)
                if mij != 0:
                    M[i][j] = M[i][j] + pt.mass * mij
            fi = sum((pt.jacobian[k][i] * pt.bias[k] for k in range(d)), zero)
            if fi != 0:
                F[i] = F[i] - pt.mass * fi
        vel = [sum((pt.jacobian[k][j] * v[j] for j in cols), zero) + pt.r_t[k] for k in range(d)]
        T = T + pt.mass * sum((vk * vk for vk in vel), zero) / 2
    for i in range(n):
        for j in range(i):
            M[i][j] = M[j][i]

    L = T - V + L_extra
    energy = sum((vj * diff(L, vj) for vj in v), zero) - L
    # h = ½ q̇ᵀ M q̇ + [V − Σ ½ m |∂r/∂t|² + h(L') − ½ q̇ᵀ M' q̇]: the kernels evaluate the
    # quadratic form from the assembled M and this bracket symbolically
    energy_rest = (V - sum((pt.mass * sum((c * c for c in pt.r_t), zero) / 2
                            for pt in particle_terms), zero)
                   + sum((vj * dl for vj, dl in zip(v, dL_dv)), zero) - L_extra
                   - sum((v[i] * M_rest[i][j] * v[j] for i in range(n) for j in range(n)
                          if M_rest[i][j] != 0), zero) / 2)

    # Constraints: Φ_q q̈ = γ with γ = -(∂Φ̇/∂q) q̇ - ∂Φ̇/∂t.
    Phi = [_se(c) for c in system.constraints]
    Phi_q = [[diff(c, qj) for qj in q] for c in Phi]
    Phi_dot = [sum((row[j] * v[j] for j in range(n)), se.Integer(0)) + diff(c, t)
               for c, row in zip(Phi, Phi_q)]
    gamma = [-(sum((diff(pd, q[j]) * v[j] for j in range(n)), se.Integer(0)) + diff(pd, t))
             for pd in Phi_dot]

    explicit_time = not _is_zero(diff(L, t)) or not all(_is_zero(diff(c, t)) for c in Phi)
    return Equations(
        system=system,
        particle_terms=tuple(particle_terms),
        mass_rest_se=tuple(tuple(row) for row in M_rest),
        forcing_rest_se=tuple(F_rest),
        energy_rest_se=energy_rest,
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
