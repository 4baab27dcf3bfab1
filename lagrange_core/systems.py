"""State a mechanical system the way a mechanics lecture does.

Why one module over 800 lines: ``System`` is the statement and the one object users call
(derive, simulate, simulate_grid, linearise); its methods delegate to their modules, and
most of the length is their documentation.

A :class:`System` is a *statement*: generalized coordinates, particles with
positions ``r_i(q, t)`` (or an explicit Lagrangian), a potential, holonomic
constraints, generalized forces and a Rayleigh dissipation function.  Nothing is
derived when a system is built; the statement is validated, its runtime
parameters are collected, and derivation (:mod:`lagrange_core.derive`) and
compilation (:mod:`lagrange_core.codegen`) happen once, on first use.

Conventions
-----------
* Time is the symbol :data:`t`.  A position that depends on ``t`` (a driven
  pivot) needs nothing special.
* Coordinates are plain sympy symbols; each has a velocity symbol named
  ``<name>_dot`` (see :func:`coordinates`).  ``sympy.physics.mechanics``
  dynamicsymbols are accepted too and converted.
* Every free symbol that is neither ``t``, a coordinate nor a velocity is a
  runtime parameter.  Parameters are ordered by name; numeric kernels take them
  as one float array in that order, so changing a value never re-derives or
  recompiles anything.
"""
from __future__ import annotations

import functools
from collections.abc import Iterable, Mapping
from dataclasses import dataclass

import numpy as np
import sympy as sp

from .bodies import RigidBody
from .checks import real_array, real_number
from .symbols import coordinates, t, velocity_symbol

__all__ = ["t", "coordinates", "Particle", "RigidBody", "System"]

@dataclass(frozen=True)
class Particle:
    """A point mass at position ``r(q, t)``.

    Parameters
    ----------
    mass : sympy expression or number
        Mass (kg); may be a parameter symbol such as ``m``.
    position : sequence of 1 to 3 sympy expressions
        Cartesian position (m) as a function of the coordinates, time and
        parameters.  Gravity is *not* implied: state it in the potential.
    name : str, optional
        Used in error messages.
    """

    mass: sp.Expr
    position: tuple
    name: str = ""

    def __post_init__(self):
        position = self.position
        if isinstance(position, (sp.MatrixBase,)):
            position = tuple(position)
        if not isinstance(position, Iterable) or isinstance(position, (str, sp.Expr)):
            raise TypeError(
                f"Particle {self.name!r}: position must be a sequence of 1 to 3 expressions, "
                f"e.g. (l*sin(theta), -l*cos(theta)); got {position!r}")
        position = tuple(sp.sympify(c) for c in position)
        if not 1 <= len(position) <= 3:
            raise ValueError(f"Particle {self.name!r}: position has {len(position)} components; "
                             "give 1, 2 or 3 Cartesian components.")
        object.__setattr__(self, "position", position)
        object.__setattr__(self, "mass", sp.sympify(self.mass))


def _as_dynamic_free(expr, subs):
    """sympify ``expr`` and replace dynamicsymbols q(t), q'(t) by plain symbols."""
    expr = sp.sympify(expr)
    return expr.xreplace(subs) if subs else expr


def _particle(p, conv, default_name):
    return Particle(conv(p.mass), tuple(conv(c) for c in p.position), p.name or default_name)


def _sequence(value, what):
    """``value`` as a list; one expression (or number) alone is a list of one."""
    if value is None:
        return []
    if isinstance(value, (sp.Basic, str, int, float)) and not isinstance(value, sp.MatrixBase):
        if isinstance(value, str):
            raise TypeError(f"{what}: expected a sequence of expressions, got the string "
                            f"{value!r}; write sympy expressions (sp.Symbol, sp.sympify).")
        return [value]
    if not isinstance(value, Iterable):
        raise TypeError(f"{what}: expected a sequence, got {value!r}.")
    return list(value)


def _items(values, kind, what):
    """The entries of ``particles`` or ``bodies``, each checked to be a ``kind``."""
    values = _sequence(values, what)
    for i, v in enumerate(values):
        if isinstance(v, kind):
            continue
        if isinstance(v, RigidBody):
            fix = "pass rigid bodies as bodies=[...]"
        elif isinstance(v, Particle):
            fix = "pass point masses as particles=[...]"
        else:
            fix = f"make it with lagrange_core.{kind.__name__}(...)"
        raise TypeError(f"{what}[{i}] is {v!r}, not a {kind.__name__}; {fix}.")
    return values


def _entries(x):
    """The entries of a matrix, or [x]."""
    return list(x) if isinstance(x, sp.MatrixBase) else [x]


def _scalar(expr, where):
    """Check that ``expr`` is a scalar expression (not a relation, matrix or tuple)."""
    if isinstance(expr, sp.Expr):
        return expr
    if isinstance(expr, (sp.core.relational.Relational, sp.logic.boolalg.Boolean)):
        raise ValueError(f"{where} is the relation {expr}, not an expression; write the expression "
                         "itself (only a constraint may be given as sp.Eq(lhs, rhs)).")
    raise TypeError(f"{where} must be one scalar expression, got {expr!r}.")


def _constraint(c, i):
    """A constraint as f with f(q, t) = 0; sp.Eq(lhs, rhs) becomes lhs − rhs."""
    if isinstance(c, sp.Equality):
        return _scalar(c.lhs - c.rhs, f"constraint {i}")
    if isinstance(c, sp.logic.boolalg.BooleanAtom):
        raise ValueError(f"constraint {i} is {c}: sympy decided the equation before the system saw "
                         "it (e.g. Eq(x, x) or Eq(1, 2)). Write the constraint as an expression "
                         "f(q, t) that vanishes, or sp.Eq(lhs, rhs) in the coordinates.")
    if isinstance(c, sp.core.relational.Relational):
        raise ValueError(f"constraint {i} ({c}) is an inequality; only holonomic constraints "
                         "f(q, t) = 0 are supported, written f or sp.Eq(lhs, rhs).")
    return _scalar(c, f"constraint {i}")


def _by_name(mapping, what):
    """A mapping keyed by names, Symbols or dynamicsymbols, as {name: value}."""
    out = {}
    for key, value in mapping.items():
        if isinstance(key, str):
            name = key
        elif isinstance(key, sp.Symbol):
            name = key.name
        elif isinstance(key, sp.core.function.AppliedUndef):
            name = type(key).__name__
        else:
            raise TypeError(f"{what}: a key must be a name or a sympy Symbol, got {key!r} "
                            f"({type(key).__name__}).")
        if name in out:
            raise ValueError(f"{what}: {name!r} is given twice (as a name and as a Symbol?); give "
                             "each value once.")
        out[name] = value
    return out


#: Functions handed to the code generator even though it may not compile them yet: it
#: names them itself ("cannot compile ...") until it does (issue 10, item 11).
_LEFT_TO_THE_GENERATOR = frozenset({"Heaviside", "Max", "Min", "Piecewise"})
#: Rewrites to suggest for common functions the kernels lack.
_REWRITES = {"sec": "1/cos(x)", "csc": "1/sin(x)", "cot": "cos(x)/sin(x)", "sech": "1/cosh(x)",
             "csch": "1/sinh(x)", "coth": "cosh(x)/sinh(x)", "acot": "atan(1/x)",
             "asec": "acos(1/x)", "acsc": "asin(1/x)"}


def _compiled_functions() -> frozenset:
    """The names (lower case) of the functions the kernels compute (lagrange_core._ir)."""
    from ._ir import SUPPORTED
    return frozenset(SUPPORTED)


def _check_expression(where, expr):
    """Refuse, naming ``where`` and the fix, what derivation or the kernels cannot handle.

    That is: an undefined function F(t) or a derivative (velocities are symbols), a
    symbol named t that is not :data:`t`, a function the generated kernels cannot
    compute, complex or infinite numbers, and anything that is not an expression.
    """
    compiled = _compiled_functions()
    supported = ", ".join(sorted(compiled - {"pi", "E"}))
    stack = [(expr, False)]
    while stack:
        node, in_piecewise = stack.pop()
        if isinstance(node, sp.Symbol):
            if node.name == "t" and node != t:
                given = getattr(node, "_assumptions_orig", None) or node.assumptions0
                flags = ", ".join(f"{k}={v}" for k, v in sorted(given.items()))
                raise ValueError(
                    f"{where}: the symbol t in {expr} is not the time symbol: it was made with "
                    f"other assumptions ({flags}). Time is lagrange_core.t (`from lagrange_core "
                    "import t`; sympy's plain Symbol('t') is taken as time too). If this t is a "
                    "parameter, give it another name.")
            continue
        if isinstance(node, sp.core.function.AppliedUndef):
            if node.args == (t,):
                raise ValueError(
                    f"{where}: {node} in {expr} is an undefined function of time, which the engine "
                    "can neither differentiate nor evaluate. Write it as an explicit expression "
                    f"of t (lagrange_core.t), e.g. A*cos(omega*t) for a drive, or as a parameter "
                    f"symbol if it is constant. (If {type(node).__name__} is meant to be a "
                    "coordinate, list it in `coordinates`.)")
            raise ValueError(
                f"{where}: {node} in {expr} is an undefined function, which the engine can neither "
                "differentiate nor evaluate. Write it as an explicit expression of its arguments "
                f"{list(node.args)}, or as a parameter symbol if it is constant.")
        if isinstance(node, sp.Derivative):
            raise ValueError(
                f"{where}: {node} in {expr} is a derivative, which a statement cannot contain: "
                "write velocities as the symbols <name>_dot (lagrange_core.coordinates returns "
                "them) and prescribed motions as explicit expressions of t.")
        if isinstance(node, sp.Number):
            if not node.is_finite:
                raise ValueError(f"{where}: {expr} contains {node}, which is not a finite number.")
            continue
        if node is sp.I:
            raise ValueError(f"{where}: {expr} contains the imaginary unit I; the kernels compute "
                             "in real arithmetic. State the system with real expressions.")
        if isinstance(node, sp.NumberSymbol):
            if node in (sp.pi, sp.E):
                continue
            raise ValueError(f"{where}: the kernels know the constants pi and E only; write "
                             f"{node} by its value, {float(node)!r}.")
        if isinstance(node, (sp.Add, sp.Mul, sp.Pow)):
            stack.extend((a, in_piecewise) for a in node.args)
            continue
        if in_piecewise and isinstance(node, (sp.core.relational.Relational,
                                              sp.logic.boolalg.Boolean, sp.Tuple)):
            stack.extend((a, True) for a in node.args)
            continue
        if getattr(node, "is_Function", False):
            name = type(node).__name__
            if name.lower() in compiled or name in _LEFT_TO_THE_GENERATOR:
                stack.extend((a, in_piecewise or name == "Piecewise") for a in node.args)
                continue
            hint = f" (e.g. {name}(x) = {_REWRITES[name]})" if name in _REWRITES else ""
            raise ValueError(
                f"{where}: the kernels cannot compute {name} in {expr}. They compute + - * / **, "
                f"the numbers pi and E and the functions {supported}; rewrite it with these"
                f"{hint}, or replace it by a parameter if it is constant.")
        raise ValueError(f"{where}: {node} ({type(node).__name__}) in {expr} is not an expression "
                         "the kernels can compute; write it with + - * / **, numbers and the "
                         f"functions {supported}.")


class System:
    """A mechanical system stated by its Lagrangian ingredients.

    The equations of motion have one canonical form, produced by
    :func:`lagrange_core.derive` and consumed by the code generator::

        M(q, t) q̈ = F(q, q̇, t) + Φ_q(q, t)ᵀ λ        (n equations)
        Φ(q, t) = 0                                  (m holonomic constraints)

    with F containing the velocity terms, −∂V/∂q, the generalized forces Q and
    −∂D/∂q̇ of the dissipation function D.  The constraint forces in
    generalized coordinates are Φ_qᵀ λ; λ are the Lagrange multipliers.

    Parameters
    ----------
    coordinates : sequence of sympy.Symbol
        Generalized coordinates q, in order (see :func:`coordinates`).
    particles : sequence of Particle, optional
        Point masses; their kinetic energy ½ m |ṙ|² enters L.  A mass may depend
        on t (then d/dt ∂T/∂q̇ contains ṁ: the mass gained or lost is at rest).
    bodies : sequence of RigidBody, optional
        Rigid bodies, planar or 3-D (:class:`lagrange_core.RigidBody`).  Each
        becomes a particle at its centre of mass plus its rotational kinetic
        energy, a term of L.
    lagrangian : sympy expression, optional
        An extra term of L(q, q̇, t) (the whole L when there are no particles).
        Velocities are the symbols ``<name>_dot``.
    potential : sympy expression, optional
        Potential energy V(q, t) (J); L gets −V.
    constraints : sequence of sympy expressions or equations, optional
        Holonomic constraints f(q, t) = 0, written as f or as ``sp.Eq(lhs, rhs)``.
    forces : mapping, or sequence, optional
        Non-conservative forces, as

        * generalized forces Q_j(q, q̇, t): a mapping coordinate (symbol or name)
          -> Q_j, or a sequence of one Q_j per coordinate;
        * Cartesian forces on points: ``[(particle, (F_x, F_y)), ...]`` or
          mapping entries ``particle: (F_x, F_y)`` (N), the components in the
          axes of the particle's position.  A RigidBody as the point means its
          centre of mass.  They enter through virtual work,
          Q_j = Σ F · ∂r/∂q_j.

        Both kinds may be mixed in one mapping.
    dissipation : sympy expression, optional
        Rayleigh dissipation function D(q, q̇); adds −∂D/∂q̇_j to Q_j.
    name : str, optional
        A label for tables and messages.

    Every expression may use + − × / **, the numbers π and e and the functions
    the kernels compile (sin, cos, tan, exp, log, sqrt, their inverses, the
    hyperbolic functions, atan2, Abs and sign); time is :data:`t` (sympy's
    plain ``Symbol('t')`` is taken as time too).

    Raises
    ------
    ValueError
        With the problem and its fix, e.g. a particle whose position depends on
        no coordinate, a constraint that involves no coordinate, a function the
        kernels cannot compute or an undefined function F(t).
    TypeError
        If an argument has the wrong kind (a body among the particles, ...).

    Examples
    --------
    The pendulum, θ from the downward vertical:

    >>> import sympy as sp
    >>> from lagrange_core import System, Particle, coordinates
    >>> (theta,), _ = coordinates("theta")
    >>> m, l, g = sp.symbols("m l g", positive=True)
    >>> pendulum = System([theta],
    ...     particles=[Particle(m, (l*sp.sin(theta), -l*sp.cos(theta)))],
    ...     potential=-m*g*l*sp.cos(theta))
    >>> pendulum.parameters
    ('g', 'l', 'm')
    """

    def __init__(self, coordinates, *, particles=(), bodies=(), lagrangian=0, potential=0,
                 constraints=(), forces=None, dissipation=0, name: str = ""):
        self.name = name
        q, subs = self._normalise_coordinates(coordinates)
        self._q = q
        self._qdot = tuple(velocity_symbol(s) for s in q)
        conv = functools.partial(_as_dynamic_free, subs=subs)

        particles = [_particle(p, conv, f"particle {i}")
                     for i, p in enumerate(_items(particles, Particle, "particles"))]
        bodies = [b.map(conv) for b in _items(bodies, RigidBody, "bodies")]
        lagrangian, potential, dissipation = (
            _scalar(conv(x), what) for x, what in ((lagrangian, "the lagrangian"),
                                                   (potential, "the potential"),
                                                   (dissipation, "the dissipation function")))
        constraints = [_constraint(conv(c), i) for i, c in enumerate(_sequence(constraints,
                                                                                "constraints"))]
        generalized, point_forces = self._split_forces(forces, conv)

        # what the user wrote, each with the words that name it in a message
        stated = [("the lagrangian", lagrangian), ("the potential", potential),
                  ("the dissipation function", dissipation)]
        stated += [(f"constraint {i}", c) for i, c in enumerate(constraints)]
        stated += [(f"the force on {qj.name}", f)
                   for qj, f in zip(self._q, generalized, strict=True)]
        stated += [(f"the force on {label}", c) for label, _, vector in point_forces
                   for c in vector]
        for p in particles:
            stated += [(f"the {what} of {p.name}", e) for what, e in (
                ("mass", p.mass), *(("position", c) for c in p.position))]
        for i, b in enumerate(bodies):
            label = f"body {b.name!r}" if b.name else f"body {i}"
            stated += [(f"the {what} of {label}", e) for what, e in (
                ("mass", b.mass), *(("position", c) for c in b.position),
                *(("inertia", e) for e in _entries(b.inertia)),
                *(("orientation", e) for e in _entries(b.orientation)))]
        for where, expr in stated:
            _check_expression(where, expr)

        # bodies: a particle at the centre of mass and ½ I φ̇² (½ ωᵀ I ω) in L
        for i, b in enumerate(bodies):
            label = b.name or f"body {i}"
            self._check_body_moves(b, label)
            T_rot = b.rotational_energy(self._q, self._qdot)
            if set().union(*(c.free_symbols for c in b.position)) & set(self._q):
                particles.append(Particle(b.mass, b.position, label))
            else:       # a fixed (or driven) centre of mass: only its ½ m |∂r/∂t|² remains
                T_rot += b.mass * sp.Add(*[sp.diff(c, t) ** 2 for c in b.position]) / 2
            lagrangian = lagrangian + T_rot
        self._particles = tuple(particles)
        self._bodies = tuple(bodies)
        self._lagrangian = lagrangian
        self._potential = potential
        self._constraints = tuple(constraints)
        self._dissipation = dissipation
        self._forces = self._project_forces(generalized, point_forces)
        self._validate()
        self._parameters = self._collect_parameters()

    # -- statement --------------------------------------------------------------
    @property
    def coordinates(self) -> tuple[str, ...]:
        """Names of the generalized coordinates, in order."""
        return tuple(s.name for s in self._q)

    @property
    def q(self) -> tuple[sp.Symbol, ...]:
        """The coordinate symbols."""
        return self._q

    @property
    def qdot(self) -> tuple[sp.Symbol, ...]:
        """The velocity symbols (``<name>_dot``)."""
        return self._qdot

    @property
    def parameters(self) -> tuple[str, ...]:
        """Names of the runtime parameters, sorted; kernels take them in this order."""
        return tuple(s.name for s in self._parameters)

    @property
    def parameter_symbols(self) -> tuple[sp.Symbol, ...]:
        return self._parameters

    @property
    def particles(self) -> tuple[Particle, ...]:
        return self._particles

    @property
    def bodies(self) -> tuple[RigidBody, ...]:
        """The rigid bodies as stated (each is also a centre-of-mass particle, unless that
        point is fixed, and a rotational term of :attr:`lagrangian_term`)."""
        return self._bodies

    @property
    def potential(self) -> sp.Expr:
        return self._potential

    @property
    def lagrangian_term(self) -> sp.Expr:
        """The part of L not from particles: the given ``lagrangian`` plus the bodies'
        rotational kinetic energies (zero when L comes from particles only)."""
        return self._lagrangian

    @property
    def constraints(self) -> tuple[sp.Expr, ...]:
        return self._constraints

    @property
    def forces(self) -> tuple[sp.Expr, ...]:
        """Generalized forces Q_j, one per coordinate (zeros where none given); Cartesian
        forces on points are included, projected as Q_j = Σ F · ∂r/∂q_j."""
        return self._forces

    @property
    def dissipation(self) -> sp.Expr:
        return self._dissipation

    @property
    def n_dof(self) -> int:
        return len(self._q)

    @property
    def n_constraints(self) -> int:
        return len(self._constraints)

    def statement_key(self) -> str:
        """A string that identifies the statement (used to key the disk cache)."""
        parts = [
            "q=" + ",".join(self.coordinates),
            "particles=" + ";".join(f"{sp.srepr(p.mass)}|{[sp.srepr(c) for c in p.position]}"
                                    for p in self._particles),
            "L=" + sp.srepr(self._lagrangian),
            "V=" + sp.srepr(self._potential),
            "C=" + ";".join(sp.srepr(c) for c in self._constraints),
            "Q=" + ";".join(sp.srepr(f) for f in self._forces),
            "D=" + sp.srepr(self._dissipation),
        ]
        return "\n".join(parts)

    def __repr__(self):
        label = f" {self.name!r}" if self.name else ""
        return (f"<System{label}: coordinates {self.coordinates}, parameters {self.parameters}, "
                f"{len(self._particles)} particles, {self.n_constraints} constraints>")

    # -- derived objects (computed once, on first use) --------------------------
    @functools.cached_property
    def equations(self):
        """The derived equations (:class:`lagrange_core.derive.Equations`)."""
        from .derive import derive
        return derive(self)

    @functools.cached_property
    def kernels(self):
        """The numba kernels (:class:`lagrange_core.codegen.Kernels`), cached on disk; each
        compiles, or loads from the cache, on its first call."""
        from .codegen import compile_kernels
        return compile_kernels(self)

    # -- numerics ---------------------------------------------------------------
    def parameter_array(self, params: Mapping[str, float] | None) -> np.ndarray:
        """Validate a dict of parameter values and return them as a float array.

        Parameters
        ----------
        params : mapping
            Values by parameter name or by the parameter's sympy Symbol.

        Raises
        ------
        ValueError
            If a parameter is missing, unknown, given twice or not a finite real number.
        TypeError
            If a key is neither a name nor a sympy Symbol.
        """
        params = {} if params is None else _by_name(params, "params")
        names = self.parameters
        unknown = sorted(set(params) - set(names))
        if unknown:
            raise ValueError(
                f"unknown parameter(s) {unknown} for {self._label()}; its parameters are "
                f"{list(names)}.")
        missing = [n for n in names if n not in params]
        if missing:
            raise ValueError(
                f"missing value(s) for parameter(s) {missing} of {self._label()}; pass them in "
                f"params, e.g. params={{{', '.join(repr(n) + ': ...' for n in missing)}}}.")
        return np.array([real_number(params[n], f"parameter {n!r}",
                                     example=f"params={{{n!r}: 1.0}}")
                         for n in names], dtype=float)

    def coordinate_array(self, values, what: str = "q") -> np.ndarray:
        """Coordinates (or velocities) given as a sequence or a dict keyed by coordinate
        name or symbol (missing coordinates are 0), as an array."""
        n = self.n_dof
        if isinstance(values, Mapping):
            values = _by_name(values, what)
            unknown = sorted(set(values) - set(self.coordinates))
            if unknown:
                raise ValueError(f"{what}: unknown coordinate(s) {unknown}; the coordinates of "
                                 f"{self._label()} are {list(self.coordinates)}.")
            values = [values.get(c, 0.0) for c in self.coordinates]
        arr = real_array(values, what).reshape(-1)
        if arr.shape != (n,):
            raise ValueError(f"{what} must have {n} entries (one per coordinate "
                             f"{list(self.coordinates)}), got {arr.size}.")
        return arr

    def mass_forcing(self, q, qdot, t=0.0, params=None) -> tuple[np.ndarray, np.ndarray]:
        """The mass matrix M and the forcing F of M q̈ = F + Φ_qᵀλ at one state, as numbers.

        Parameters
        ----------
        q, qdot, t, params
            The state, time (s) and parameter values, as for :meth:`accelerations`.

        Returns
        -------
        M : ndarray, shape (n, n)
            The mass matrix M(q, t) (symmetric; kg, kg m, kg m² by the coordinates' units).
        F : ndarray, shape (n,)
            F(q, q̇, t): velocity terms, −∂V/∂q, the generalized forces and −∂D/∂q̇.
            Constraint forces are not included (see :meth:`accelerations`).
        """
        q = self.coordinate_array(q, "q")
        qd = self.coordinate_array(qdot, "qdot")
        p = self.parameter_array(params)
        n = self.n_dof
        M, F = np.empty((n, n)), np.empty(n)
        self.kernels.mass_forcing(q, qd, float(t), p, M, F)
        return M, F

    def accelerations(self, q, qdot, t=0.0, params=None):
        """Generalized accelerations q̈ at one state.

        Parameters
        ----------
        q, qdot : sequence of float or dict name -> float
            Coordinates and velocities, in the order of :attr:`coordinates`.
        t : float
            Time (s).
        params : dict
            Parameter values by name or by Symbol.

        Returns
        -------
        qddot : ndarray, shape (n,)
            For a constrained system, ``(qddot, multipliers)``; the generalized
            constraint force is Φ_qᵀ λ.

        Raises
        ------
        ValueError
            If the mass matrix (augmented with the constraint Jacobian) is
            singular at this state.
        """
        q = self.coordinate_array(q, "q")
        qd = self.coordinate_array(qdot, "qdot")
        p = self.parameter_array(params)
        qdd, lam, status = self.kernels.accelerations_at(q, qd, float(t), p)
        if status != 0:
            augmented = " augmented by the constraint Jacobian" if self.n_constraints else ""
            raise ValueError(
                f"the mass matrix{augmented}"
                f" of {self._label()} is singular at q={q.tolist()}, t={t}: the coordinates are "
                "degenerate there (e.g. a pole of spherical coordinates) or the constraints are "
                "redundant. Choose another state or restate the system in coordinates that are "
                "regular there.")
        return (qdd, lam) if self.n_constraints else qdd

    def simulate(self, q0, qdot0, t_span, params=None, *, method=None, rtol=1e-9, t_eval=None,
                 progress=None, **options):
        """Integrate the equations of motion; returns a frozen :class:`Trajectory`.

        Parameters
        ----------
        q0, qdot0 : sequence of float or dict name -> float
            Initial coordinates and velocities (order of :attr:`coordinates`).
        t_span : (t0, t1)
            Start and end time (s), t1 > t0.
        params : dict
            Parameter values by name.
        method : str, optional
            A name from ``lagrange_core.integrate.METHODS`` ("dop853", "rk8",
            "rkn12", "rkn12-fixed", "yoshida6", "scipy:DOP853", "scipy:LSODA",
            "scipy:Radau", ...).  None: "rkn12" if the equations have the form
            q̈ = f(q, t) (no velocity dependence, no constraints), else "dop853".
        rtol : float
            Relative tolerance (atol defaults to rtol).
        t_eval : array, optional
            Store only these times (dense output); else every accepted step.
        **options
            ``atol``, ``events`` (list of :class:`lagrange_core.integrate.Event`),
            ``max_steps``, ``h`` (fixed-step methods), ``stride`` (store every
            k-th step), ``max_points`` (memory bound on stored rows, default 10⁶),
            ``error_check`` (rerun at rtol/1000 to estimate the error),
            ``chunk_steps``.  See :mod:`lagrange_core.integrate`.
        progress : None, bool or callable
            A run of more than one chunk (see below) that takes over half a second shows
            a line on stderr — the share of ``t_span`` reached and the time left — when
            stderr is a terminal (None), always (True) or never (False); a callable gets
            ``progress(share, 1)``.

        The run is integrated in chunks (compiled calls): DOP853's of about a quarter of
        a second (it goes on exactly across them), the other methods' ``chunk_steps``
        steps (default 20 000: milliseconds for a pendulum).  Ctrl-C stops at the end of
        the running chunk.

        Raises
        ------
        ValueError
            Bad input, an ineligible method, or a singular mass matrix during the
            run (the message names the time and state).
        lagrange_core.integrate.SimulationInterrupted
            On Ctrl-C, carrying the part computed in ``.trajectory`` (status
            "interrupted"; its message and the trajectory's last time say how far it
            got).
        """
        from . import integrate
        q0, qdot0, p = self._simulate_arrays(q0, qdot0, params)
        # every argument is checked before the kernels compile (seconds, cold), once
        checked = integrate.check_options(t_span, rtol=rtol, t_eval=t_eval, **options)
        return integrate.simulate_checked(
            self.kernels, q0, qdot0, p, checked, method=method, events=options.get("events", ()),
            error_check=options.get("error_check", False), label=self._label(),
            progress=progress)

    def _simulate_arrays(self, q0, qdot0, params):
        """(q0, q̇0, p) as float arrays for :meth:`simulate`.  The common call (lists or
        tuples of plain finite numbers; a dict of them by parameter name) is checked here
        in a few microseconds, since short runs pay it on every call; anything else goes
        through :meth:`coordinate_array` and :meth:`parameter_array` (same values, and
        their messages)."""
        n, names = self.n_dof, self.parameters
        plain = (float, int, np.float64)    # (v − v == 0: finite; inf − inf and NaN are NaN)
        arrays = []
        for values, what in ((q0, "q0"), (qdot0, "qdot0")):
            if type(values) in (list, tuple) and len(values) == n and all(
                    type(v) in plain and v - v == 0 for v in values):
                arrays.append(np.array(values, dtype=float))
            else:
                arrays.append(self.coordinate_array(values, what))
        if type(params) is dict and len(params) == len(names) and all(
                type(params.get(k)) in plain and params[k] - params[k] == 0 for k in names):
            arrays.append(np.array([params[k] for k in names], dtype=float))
        else:
            arrays.append(self.parameter_array(params))
        return arrays

    def simulate_grid(self, q0, qdot0, t_span, params=None, *, method=None, rtol=1e-9,
                      atol=None, h=None, strobe=None, reference=None, band=None, energy=False,
                      max_steps=None, progress=None):
        """Integrate a whole grid of parameter sets and initial states in one compiled,
        parallel call; returns a frozen :class:`~lagrange_core.batch.GridTrajectories` of
        observables (final state, strobe samples, max deviation, band exit, energy drift,
        counts and a status per point).

        Everything per point (``q0``, ``qdot0``, the ends of ``t_span``, every value in
        ``params``, ``h``, ``strobe``, ``reference``, ``band``) broadcasts numpy-style:
        ``params={"A": A[:, None], "omega": omega[None, :], ...}`` is an (A, ω) grid.
        See :func:`lagrange_core.batch.simulate_grid` for the arguments and
        :mod:`lagrange_core.batch` for what is observed and how.

        Examples
        --------
        The driven pendulum upright at four amplitudes for 200 drive periods: the two
        weak drives let it fall (status "left_band"), the two strong ones hold it.

        >>> import numpy as np
        >>> from lagrange_core import problems
        >>> pend = problems.driven_pendulum("vertical")
        >>> w = 2 * np.pi * 60
        >>> A = np.array([0.002, 0.008, 0.03, 0.06])
        >>> g = pend.simulate_grid([np.pi - 0.1], [0.0], (0.0, 200 * 2 * np.pi / w),
        ...                        dict(m=1.0, l=1.0, g=9.81, A=A, omega=w),
        ...                        band=([np.pi / 2], [3 * np.pi / 2]))
        >>> g.status_name.tolist()
        ['left_band', 'left_band', 'finished', 'finished']
        """
        from .batch import simulate_grid
        return simulate_grid(self, q0, qdot0, t_span, params, method=method, rtol=rtol,
                             atol=atol, h=h, strobe=strobe, reference=reference, band=band,
                             energy=energy, max_steps=max_steps, progress=progress)

    def linearize(self, params=None, about=None, t=0.0):
        """Linearise about an equilibrium: M δq̈ + C δq̇ + K δq = 0.

        See :func:`lagrange_core.linearize.linearize`.
        """
        from .linearize import linearize
        return linearize(self, params, about, t)

    def normal_modes(self, params=None, about=None, t=0.0) -> np.ndarray:
        """Normal-mode angular frequencies (rad/s) about an equilibrium, ascending.

        Parameters
        ----------
        params : dict
            Parameter values by name.
        about : sequence or dict, optional
            The equilibrium's coordinates; all zero by default.
        t : float
            Time at which a time-dependent system is frozen (default 0).

        Raises
        ------
        ValueError
            If the equilibrium is unstable (a negative ω²); use :meth:`linearize`
            to inspect ``omega_squared``.
        """
        lin = self.linearize(params, about, t)
        if np.any(lin.omega_squared < 0):
            raise ValueError(
                f"{self._label()} is unstable about {lin.about.tolist()}: ω² = "
                f"{lin.omega_squared.tolist()} has negative entries, so there are no normal-mode "
                "frequencies. Use System.linearize(...).omega_squared to inspect the modes.")
        return np.sqrt(lin.omega_squared)

    # -- helpers ----------------------------------------------------------------
    def _label(self) -> str:
        return f"system {self.name!r}" if self.name else "the system"

    @staticmethod
    def _normalise_coordinates(coords):
        if isinstance(coords, (sp.Basic, str)):
            coords = [coords]
        q, subs = [], {}
        for c in coords:
            if isinstance(c, str):
                c = sp.Symbol(c, real=True)
            if isinstance(c, sp.Symbol):
                q.append(c if c.is_real else sp.Symbol(c.name, real=True))
                if not c.is_real:
                    subs[c] = q[-1]
            elif isinstance(c, sp.Function) or (isinstance(c, sp.Basic) and c.is_Function):
                # a dynamicsymbol q(t): replace q(t) and q'(t) by plain symbols
                if c.args != (sp.Symbol("t"),) and c.args != (t,):
                    raise ValueError(f"coordinate {c} must be a function of t only.")
                s = sp.Symbol(type(c).__name__, real=True)
                q.append(s)
                subs[sp.Derivative(c, c.args[0])] = velocity_symbol(s)
                subs[c] = s
            else:
                raise TypeError(f"a coordinate must be a sympy Symbol (or dynamicsymbol), got "
                                f"{c!r}; make them with lagrange_core.coordinates('theta phi').")
        names = [s.name for s in q]
        if len(set(names)) != len(names):
            raise ValueError(f"coordinate names must be distinct, got {names}.")
        if not q:
            raise ValueError("a system needs at least one generalized coordinate.")
        if sp.Symbol("t") in q or t in q:
            raise ValueError("'t' is the time symbol (lagrange_core.t) and cannot be a coordinate; "
                             "give the coordinate another name.")
        # sympy's plain Symbol('t') (no assumptions; sympy.physics.mechanics' time) means time
        subs.setdefault(sp.Symbol("t"), t)
        return tuple(q), subs

    def _split_forces(self, forces, conv):
        """The ``forces`` argument as (Q_j per coordinate, [(label, point, F vector)])."""
        n = len(self._q)
        generalized = [sp.S.Zero] * n
        points: list[tuple] = []
        if forces is None:
            return generalized, points

        def point_force(point, vector):
            label = point.name or f"the point at {tuple(point.position)}"
            if isinstance(point, RigidBody):
                label = f"the centre of mass of {point.name or 'a body'}"
            position = tuple(conv(c) for c in point.position)
            if isinstance(vector, sp.MatrixBase):
                vector = tuple(vector)
            if not isinstance(vector, Iterable) or isinstance(vector, (str, sp.Basic)):
                vector = (vector,)
            vector = tuple(_scalar(conv(c), f"the force on {label}") for c in vector)
            if len(vector) != len(position):
                raise ValueError(
                    f"forces: the force on {label} has {len(vector)} component(s) {vector} but its "
                    f"position {position} has {len(position)}; give one Cartesian component per "
                    "axis of the position.")
            points.append((label, position, vector))

        if isinstance(forces, Mapping):
            index = {s: i for i, s in enumerate(self._q)}
            index.update({s.name: i for i, s in enumerate(self._q)})
            for key, value in forces.items():
                if isinstance(key, (Particle, RigidBody)):
                    point_force(key, value)
                    continue
                key = conv(key) if not isinstance(key, str) else key
                if key not in index:
                    raise ValueError(f"forces: {key!r} is not a coordinate; the coordinates are "
                                     f"{list(self.coordinates)} (a Cartesian force is keyed by "
                                     "its Particle or RigidBody).")
                generalized[index[key]] = _scalar(conv(value), f"the force on {key}")
            return generalized, points
        if isinstance(forces, tuple) and len(forces) == 2 and isinstance(
                forces[0], (Particle, RigidBody)):
            forces = [forces]                      # one (particle, force) pair
        forces = _sequence(forces, "forces")
        is_point = [isinstance(f, tuple) and len(f) == 2 and isinstance(f[0], (Particle, RigidBody))
                    for f in forces]
        if forces and all(is_point):
            for point, vector in forces:
                point_force(point, vector)
            return generalized, points
        if any(is_point):
            raise ValueError("forces: a sequence is either one generalized force per coordinate or "
                             "(particle, (F_x, F_y, ...)) pairs, not both; mix them in a dict "
                             "{coordinate: Q, particle: (F_x, F_y)}.")
        if len(forces) != n:
            raise ValueError(f"forces: give one generalized force per coordinate ({n}), "
                             f"got {len(forces)}; or pass a dict coordinate -> force, or "
                             "(particle, (F_x, F_y)) pairs.")
        return [_scalar(conv(f), f"the force on {q.name}")
                for f, q in zip(forces, self._q, strict=True)], points

    def _project_forces(self, generalized, points):
        """Q_j plus the virtual work of the Cartesian forces, Σ F · ∂r/∂q_j."""
        Q = list(generalized)
        for _, position, vector in points:
            for j, qj in enumerate(self._q):
                Q[j] += sp.Add(*[F * sp.diff(r, qj) for F, r in zip(vector, position, strict=True)])
        return tuple(Q)

    def _check_body_moves(self, body, label):
        qset = set(self._q)
        moves = set().union(*(e.free_symbols
                              for e in (*body.position, *_entries(body.orientation))))
        if not moves & qset:
            raise ValueError(
                f"{label}: neither its centre of mass {body.position} nor its orientation depends "
                f"on a coordinate of {list(self.coordinates)}, so it cannot move with the system. "
                "Write them in terms of the coordinates, or drop the body.")
        for what, exprs in (("mass", [body.mass]), ("inertia", _entries(body.inertia))):
            if set().union(*(e.free_symbols for e in exprs)) & (qset | set(self._qdot)):
                raise ValueError(f"{label}: the {what} must not depend on coordinates or "
                                 "velocities (it may depend on t).")
        if moves & set(self._qdot):
            raise ValueError(f"{label}: its position and orientation cannot depend on velocities.")

    def _validate(self):
        qset, vset = set(self._q), set(self._qdot)
        if not self._particles and self._lagrangian == 0:
            raise ValueError("the system has no kinetic energy: give "
                             "particles=[Particle(m, r(q, t))] or a lagrangian=L(q, q_dot, t).")
        for p in self._particles:
            free = set().union(*(c.free_symbols for c in p.position))
            if not free & qset:
                raise ValueError(
                    f"{p.name}: its position {p.position} depends on no coordinate of "
                    f"{list(self.coordinates)}, so it cannot move with the system. Write its "
                    "position in terms of the coordinates, or drop it (a prescribed motion "
                    "contributes nothing to the equations).")
            if free & vset:
                raise ValueError(f"{p.name}: a position cannot depend on velocities "
                                 f"({sorted(s.name for s in free & vset)}).")
            if p.mass.free_symbols & (qset | vset):
                raise ValueError(f"{p.name}: the mass must not depend on coordinates or "
                                 "velocities.")
        for name, expr in (("potential", self._potential),):
            if expr.free_symbols & vset:
                raise ValueError(f"the {name} must not depend on velocities; put "
                                 "velocity-dependent terms in the lagrangian or the forces.")
        for i, c in enumerate(self._constraints):
            if not c.free_symbols & qset:
                raise ValueError(
                    f"constraint {i} ({c} = 0) involves none of the coordinates "
                    f"{list(self.coordinates)}; a holonomic constraint must be an equation "
                    "f(q, t) = 0 in the coordinates. Remove it or fix the coordinate names.")
            if c.free_symbols & vset:
                raise ValueError(f"constraint {i} ({c} = 0) depends on velocities; only holonomic "
                                 "constraints f(q, t) = 0 are supported.")
        if self._dissipation.free_symbols & vset == set() and self._dissipation != 0:
            raise ValueError("the dissipation function D must depend on the velocities "
                             f"{[s.name for s in self._qdot]} (e.g. D = gamma*theta_dot**2/2).")

    def _all_expressions(self):
        exprs = [self._lagrangian, self._potential, self._dissipation, *self._constraints,
                 *self._forces]
        for p in self._particles:
            exprs.append(p.mass)
            exprs.extend(p.position)
        return exprs

    def _collect_parameters(self):
        known = set(self._q) | set(self._qdot) | {t}
        free = set().union(*(e.free_symbols for e in self._all_expressions())) - known
        clash = sorted(s.name for s in free if s.name in {x.name for x in known})
        if clash:
            raise ValueError(f"symbol(s) {clash} share a name with a coordinate or velocity but "
                             "are different symbols (different assumptions?); use the symbols "
                             "returned by lagrange_core.coordinates().")
        names = [s.name for s in free]
        if len(set(names)) != len(names):
            dup = sorted({n for n in names if names.count(n) > 1})
            raise ValueError(f"parameter symbol(s) {dup} appear with different assumptions; use "
                             "one symbol per parameter name.")
        return tuple(sorted(free, key=lambda s: s.name))
