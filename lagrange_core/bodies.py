"""Rigid bodies: a mass at the centre of mass plus the kinetic energy of rotation.

A rigid body of mass m, centre of mass at r(q, t), has the kinetic energy (König's
theorem)

    T = ½ m |ṙ|² + T_rot,

* planar:  T_rot = ½ I φ̇², with I (kg m²) the moment of inertia about the axis through
  the centre of mass normal to the plane and φ(q, t) (rad) the body's angle about it;
* in 3-D:  T_rot = ½ ωᵀ I_body ω, with I_body (kg m²) the inertia tensor about the centre
  of mass in body axes and ω (rad/s) the angular velocity in body axes, [ω]ₓ = Rᵀ Ṙ.
  R(q, t) is the rotation matrix that takes body components to world components:
  a point fixed in the body at b (body axes) is at r + R b.

A :class:`~lagrange_core.System` turns each body into a
:class:`~lagrange_core.Particle` at its centre of mass and adds T_rot to its
Lagrangian, so derivation needs nothing special.  Gravity is not implied: state
m g y of the centre of mass in the potential.
"""
from __future__ import annotations

import random
from collections.abc import Iterable
from dataclasses import dataclass

import sympy as sp

from .symbols import t

__all__ = ["RigidBody", "rotation_matrix"]


def rotation_matrix(axis: str, angle) -> sp.ImmutableMatrix:
    """The rotation by ``angle`` (rad, right-handed) about a world axis, as a 3 × 3 matrix.

    Parameters
    ----------
    axis : {"x", "y", "z"}
    angle : sympy expression

    Returns
    -------
    sympy.ImmutableMatrix
        R with R v the rotated vector v (an *active* rotation; sympy's
        ``rot_axis1..3`` are the transposes).  Products compose body rotations:
        ``rotation_matrix("z", psi) * rotation_matrix("x", theta) * rotation_matrix("z", phi)``
        is the orientation with z-x-z Euler angles (ψ, θ, φ).
    """
    c, s = sp.cos(angle), sp.sin(angle)
    rows = {"x": [[1, 0, 0], [0, c, -s], [0, s, c]],
            "y": [[c, 0, s], [0, 1, 0], [-s, 0, c]],
            "z": [[c, -s, 0], [s, c, 0], [0, 0, 1]]}
    if axis not in rows:
        raise ValueError(f"rotation_matrix: axis must be 'x', 'y' or 'z', got {axis!r}.")
    return sp.ImmutableMatrix(rows[axis])


def _as_matrix(value):
    """A 3 × 3 ImmutableMatrix from a sympy matrix or nested sequences, else None."""
    if isinstance(value, sp.MatrixBase):
        return sp.ImmutableMatrix(value)
    if isinstance(value, Iterable) and not isinstance(value, (str, sp.Basic)):
        rows = list(value)
        if rows and all(isinstance(r, Iterable) and not isinstance(r, (str, sp.Basic))
                        for r in rows):
            return sp.ImmutableMatrix([list(r) for r in rows])
    return None


def _sample(exprs, seed: int):
    """Numeric values of ``exprs`` at a random point of their symbols and functions of t."""
    rng = random.Random(seed)
    atoms = set()
    for e in exprs:
        atoms |= e.free_symbols | e.atoms(sp.core.function.AppliedUndef)
    point = {a: sp.Float(rng.uniform(0.3, 1.7)) for a in atoms}
    return [complex(sp.sympify(e).xreplace(point).evalf()) for e in exprs]


@dataclass(frozen=True)
class RigidBody:
    """A rigid body: mass, inertia about the centre of mass, centre r(q, t), orientation.

    Parameters
    ----------
    mass : sympy expression or number
        Mass m (kg); may depend on t, not on q or q̇.
    inertia : expression, or 3 × 3 matrix, or 3 principal moments
        Planar body: the moment of inertia I (kg m²) about the axis through the centre
        of mass normal to the plane.  3-D body: the inertia tensor about the centre of
        mass in body axes (kg m², symmetric), or its three principal moments when the
        body axes are principal.
    position : sequence of 1 to 3 sympy expressions
        The centre of mass r(q, t) (m), Cartesian, as for a :class:`Particle`; three
        components for a 3-D body.
    orientation : expression, or 3 × 3 matrix
        Planar body: the angle φ(q, t) (rad) of the body about the plane's normal (its
        sense does not matter to the kinetic energy).  3-D body: the rotation matrix
        R(q, t) taking body components to world components (see
        :func:`rotation_matrix`).
    name : str, optional
        Used in error messages and as the centre-of-mass particle's name.

    Examples
    --------
    A uniform rod of length L hanging from a pivot (physical pendulum):

    >>> import sympy as sp
    >>> import lagrange_core as lc
    >>> (theta,), _ = lc.coordinates("theta")
    >>> m, L, g = sp.symbols("m L g", positive=True)
    >>> rod = lc.RigidBody(m, m * L**2 / 12, (L / 2 * sp.sin(theta), -L / 2 * sp.cos(theta)),
    ...                    theta, "rod")
    >>> pendulum = lc.System([theta], bodies=[rod], potential=m * g * rod.position[1])
    >>> sp.simplify(pendulum.equations.mass_matrix)      # m L²/12 + m (L/2)²
    Matrix([[L**2*m/3]])
    """

    mass: sp.Expr
    inertia: object
    position: tuple
    orientation: object
    name: str = ""

    def __post_init__(self):
        label = f"RigidBody {self.name!r}"
        position = self.position
        if isinstance(position, sp.MatrixBase):
            position = tuple(position)
        if not isinstance(position, Iterable) or isinstance(position, (str, sp.Basic)):
            raise TypeError(f"{label}: position must be a sequence of 1 to 3 expressions (the "
                            f"centre of mass, m), got {position!r}.")
        position = tuple(sp.sympify(c) for c in position)
        if not 1 <= len(position) <= 3:
            raise ValueError(f"{label}: position has {len(position)} components; give 1, 2 or 3 "
                             "Cartesian components of the centre of mass.")
        rotation = _as_matrix(self.orientation)
        inertia = self.inertia
        if rotation is None:                                   # planar
            orientation = sp.sympify(self.orientation)
            if not isinstance(orientation, sp.Expr):
                raise TypeError(f"{label}: orientation must be an angle φ(q, t) (planar body) or "
                                f"a 3 × 3 rotation matrix R(q, t), got {self.orientation!r}.")
            if _as_matrix(inertia) is not None or (isinstance(inertia, Iterable)
                                                   and not isinstance(inertia, (str, sp.Basic))):
                raise ValueError(f"{label}: a planar body (orientation an angle) has one moment "
                                 f"of inertia about its centre of mass; got {inertia!r}. For a "
                                 "3-D body give orientation as a 3 × 3 rotation matrix.")
            inertia = sp.sympify(inertia)
        else:                                                  # 3-D
            if rotation.shape != (3, 3):
                raise ValueError(f"{label}: the rotation matrix must be 3 × 3, got shape "
                                 f"{rotation.shape}.")
            if len(position) != 3:
                raise ValueError(f"{label}: a 3-D body (orientation a rotation matrix) needs three "
                                 f"components of its centre of mass, got {len(position)}.")
            orientation = rotation
            matrix = _as_matrix(inertia)
            if matrix is None and isinstance(inertia, Iterable) and not isinstance(
                    inertia, (str, sp.Basic)):
                moments = list(inertia)
                if len(moments) != 3:
                    raise ValueError(f"{label}: give the inertia tensor as a 3 × 3 matrix or its "
                                     f"three principal moments, got {inertia!r}.")
                matrix = sp.ImmutableMatrix(sp.diag(*moments))
            if matrix is None or matrix.shape != (3, 3):
                raise ValueError(f"{label}: a 3-D body needs its inertia tensor (3 × 3, body axes, "
                                 f"about the centre of mass) or three principal moments, got "
                                 f"{inertia!r}.")
            if any(sp.simplify(matrix[i, j] - matrix[j, i]) != 0
                   for i in range(3) for j in range(i + 1, 3)):
                raise ValueError(f"{label}: the inertia tensor must be symmetric, got {matrix}.")
            inertia = matrix
            self._check_rotation(rotation, label)
        object.__setattr__(self, "mass", sp.sympify(self.mass))
        object.__setattr__(self, "inertia", inertia)
        object.__setattr__(self, "position", position)
        object.__setattr__(self, "orientation", orientation)

    @staticmethod
    def _check_rotation(R, label):
        """RᵀR = 1 and det R = 1 at two random points (a typo rarely survives both)."""
        entries = list(R.T * R - sp.eye(3)) + [R.det() - 1]
        for seed in (1, 2):
            try:
                values = _sample(entries, seed)
            except (TypeError, ValueError):
                return          # not numeric (an unusual function): derivation will tell
            worst = max(abs(v) for v in values)
            if worst > 1e-9:
                raise ValueError(
                    f"{label}: the orientation {R.tolist()} is not a rotation matrix (RᵀR = 1 and "
                    f"det R = 1 fail by {worst:.3g} at a sample point). Give R(q, t) taking body "
                    "components to world components, e.g. a product of "
                    "lagrange_core.rotation_matrix(axis, angle).")

    # -- the statement ------------------------------------------------------------------
    @property
    def planar(self) -> bool:
        """True for a planar body (orientation an angle), False for a 3-D body."""
        return not isinstance(self.orientation, sp.MatrixBase)

    def expressions(self) -> list:
        """Every expression of the body (mass, inertia, position, orientation)."""
        out = [self.mass, *self.position]
        for x in (self.inertia, self.orientation):
            out.extend(x if isinstance(x, sp.MatrixBase) else [x])
        return out

    def map(self, f) -> RigidBody:
        """The same body with ``f`` applied to each of its expressions."""
        def each(x):
            return x.applyfunc(f) if isinstance(x, sp.MatrixBase) else f(x)
        return RigidBody(f(self.mass), each(self.inertia), tuple(f(c) for c in self.position),
                         each(self.orientation), self.name)

    # -- kinematics -----------------------------------------------------------------------
    def angular_velocity(self, q, qdot):
        """The angular velocity in terms of the coordinates and their velocities (rad/s).

        Parameters
        ----------
        q, qdot : sequence of sympy.Symbol
            The coordinates and their velocity symbols.

        Returns
        -------
        sympy expression (planar: φ̇ = Σ ∂φ/∂q_j q̇_j + ∂φ/∂t) or sympy.Matrix (3 × 1,
        3-D: ω in body axes, from [ω]ₓ = Rᵀ Ṙ = Σ_j q̇_j Rᵀ ∂R/∂q_j + Rᵀ ∂R/∂t).
        """
        phi = self.orientation
        if self.planar:
            return (sp.Add(*[sp.diff(phi, qj) * vj for qj, vj in zip(q, qdot, strict=True)])
                    + sp.diff(phi, t))
        R = sp.Matrix(phi)
        omega = sp.zeros(3, 1)
        for rate, s in [*zip(qdot, q, strict=True), (sp.S.One, t)]:
            dR = R.diff(s)
            if dR.is_zero_matrix:
                continue
            W = R.T * dR                                   # skew-symmetric: [ω_j]ₓ
            omega += rate * sp.Matrix([_pythagoras(W[2, 1]), _pythagoras(W[0, 2]),
                                       _pythagoras(W[1, 0])])
        return omega

    def rotational_energy(self, q, qdot) -> sp.Expr:
        """T_rot (J): ½ I φ̇² (planar) or ½ ωᵀ I_body ω (3-D)."""
        w = self.angular_velocity(q, qdot)
        if self.planar:
            return self.inertia * w**2 / 2
        return sp.expand((w.T * sp.Matrix(self.inertia) * w)[0, 0] / 2)


def _pythagoras(expr):
    """``expr`` with sin²u + cos²u = 1 used for every argument u (expand, then reduce
    sin(u)² to 1 − cos(u)² as a polynomial): the entries of Rᵀ ∂R/∂q of a product of
    elementary rotations collapse to the textbook angular velocities."""
    expr = sp.expand(expr)
    args = sorted({f.args[0] for f in expr.atoms(sp.sin, sp.cos)}, key=sp.default_sort_key)
    if not args:
        return expr
    swap, relations = {}, []
    for u in args:
        s, c = sp.Dummy(), sp.Dummy()
        swap[sp.sin(u)], swap[sp.cos(u)] = s, c
        relations.append((s, c))
    poly = expr.xreplace(swap)
    for s, c in relations:
        if poly.has(s):
            poly = sp.rem(poly, s**2 + c**2 - 1, s)
    return sp.expand(poly).xreplace({v: k for k, v in swap.items()})
