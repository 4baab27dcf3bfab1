"""State a mechanical system the way a mechanics lecture does.

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
import math
from collections.abc import Iterable, Mapping
from dataclasses import dataclass

import numpy as np
import sympy as sp

from .symbols import coordinates, t, velocity_symbol

__all__ = ["t", "coordinates", "Particle", "System"]

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
        Point masses; their kinetic energy ½ m |ṙ|² enters L.
    lagrangian : sympy expression, optional
        An extra term of L(q, q̇, t) (the whole L when there are no particles).
        Velocities are the symbols ``<name>_dot``.
    potential : sympy expression, optional
        Potential energy V(q, t) (J); L gets −V.
    constraints : sequence of sympy expressions, optional
        Holonomic constraints f(q, t) = 0.
    forces : mapping coordinate -> expression, or sequence, optional
        Generalized (non-conservative) forces Q_j(q, q̇, t).
    dissipation : sympy expression, optional
        Rayleigh dissipation function D(q, q̇); adds −∂D/∂q̇_j to Q_j.
    name : str, optional
        A label for tables and messages.

    Raises
    ------
    ValueError
        With the problem and its fix, e.g. a particle whose position depends on
        no coordinate, or a constraint that involves no coordinate.

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

    def __init__(self, coordinates, *, particles=(), lagrangian=0, potential=0,
                 constraints=(), forces=None, dissipation=0, name: str = ""):
        self.name = name
        q, subs = self._normalise_coordinates(coordinates)
        self._q = q
        self._qdot = tuple(velocity_symbol(s) for s in q)
        conv = functools.partial(_as_dynamic_free, subs=subs)

        self._particles = tuple(
            Particle(conv(p.mass), tuple(conv(c) for c in p.position), p.name or f"particle {i}")
            for i, p in enumerate(particles))
        self._lagrangian = conv(lagrangian)
        self._potential = conv(potential)
        self._constraints = tuple(conv(c) for c in constraints)
        self._dissipation = conv(dissipation)
        self._forces = self._normalise_forces(forces, conv)
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
    def potential(self) -> sp.Expr:
        return self._potential

    @property
    def lagrangian_term(self) -> sp.Expr:
        """The explicitly given part of L (zero when L comes from particles only)."""
        return self._lagrangian

    @property
    def constraints(self) -> tuple[sp.Expr, ...]:
        return self._constraints

    @property
    def forces(self) -> tuple[sp.Expr, ...]:
        """Generalized forces Q_j, one per coordinate (zeros where none given)."""
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
        """Compiled numba kernels (:class:`lagrange_core.codegen.Kernels`), cached on disk."""
        from .codegen import compile_kernels
        return compile_kernels(self)

    # -- numerics ---------------------------------------------------------------
    def parameter_array(self, params: Mapping[str, float] | None) -> np.ndarray:
        """Validate a dict of parameter values and return them as a float array.

        Raises
        ------
        ValueError
            If a parameter is missing, unknown or not a finite real number.
        """
        params = {} if params is None else dict(params)
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
        values = np.empty(len(names))
        for i, n in enumerate(names):
            try:
                v = float(params[n])
            except (TypeError, ValueError):
                raise ValueError(f"parameter {n!r} must be a real number, got {params[n]!r}.") from None
            if not math.isfinite(v):
                raise ValueError(f"parameter {n!r} must be finite, got {v}.")
            values[i] = v
        return values

    def coordinate_array(self, values, what: str = "q") -> np.ndarray:
        """Coordinates (or velocities) given as a sequence or a name -> value dict, as an array."""
        n = self.n_dof
        if isinstance(values, Mapping):
            unknown = sorted(set(values) - set(self.coordinates))
            if unknown:
                raise ValueError(f"{what}: unknown coordinate(s) {unknown}; the coordinates of "
                                 f"{self._label()} are {list(self.coordinates)}.")
            values = [values.get(c, 0.0) for c in self.coordinates]
        arr = np.array(values, dtype=float).reshape(-1) if np.ndim(values) else np.full(1, float(values))
        if arr.shape != (n,):
            raise ValueError(f"{what} must have {n} entries (one per coordinate "
                             f"{list(self.coordinates)}), got {arr.size}.")
        if not np.all(np.isfinite(arr)):
            raise ValueError(f"{what} must be finite, got {arr}.")
        return arr

    def accelerations(self, q, qdot, t=0.0, params=None):
        """Generalized accelerations q̈ at one state.

        Parameters
        ----------
        q, qdot : sequence of float or dict name -> float
            Coordinates and velocities, in the order of :attr:`coordinates`.
        t : float
            Time (s).
        params : dict
            Parameter values by name.

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
        k = self.kernels
        qdd = np.empty(self.n_dof)
        lam = np.empty(self.n_constraints)
        status = k.accelerations(q, qd, float(t), p, qdd, lam, k.work_array())
        if status != 0:
            raise ValueError(
                f"the mass matrix{' augmented by the constraint Jacobian' if self.n_constraints else ''}"
                f" of {self._label()} is singular at q={q.tolist()}, t={t}: the coordinates are "
                "degenerate there (e.g. a pole of spherical coordinates) or the constraints are "
                "redundant. Choose another state or restate the system in coordinates that are "
                "regular there.")
        return (qdd, lam) if self.n_constraints else qdd

    def simulate(self, q0, qdot0, t_span, params=None, *, method=None, rtol=1e-9, t_eval=None,
                 **options):
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

        Raises
        ------
        ValueError
            Bad input, an ineligible method, or a singular mass matrix during the
            run (the message names the time and state).
        lagrange_core.integrate.SimulationInterrupted
            On Ctrl-C, carrying the part computed in ``.trajectory``.
        """
        from . import integrate
        q0 = self.coordinate_array(q0, "q0")
        qdot0 = self.coordinate_array(qdot0, "qdot0")
        p = self.parameter_array(params)
        # every argument is checked before the kernels compile (seconds, cold)
        integrate.check_options(t_span, rtol=rtol, t_eval=t_eval, **options)
        return integrate.simulate(self.kernels, q0, qdot0, t_span, p, method=method, rtol=rtol,
                                  t_eval=t_eval, label=self._label(), **options)

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
                raise TypeError(f"a coordinate must be a sympy Symbol (or dynamicsymbol), got {c!r}; "
                                "make them with lagrange_core.coordinates('theta phi').")
        names = [s.name for s in q]
        if len(set(names)) != len(names):
            raise ValueError(f"coordinate names must be distinct, got {names}.")
        if not q:
            raise ValueError("a system needs at least one generalized coordinate.")
        if sp.Symbol("t") in q or t in q:
            raise ValueError("'t' is the time symbol and cannot be a coordinate.")
        # sympy's plain Symbol('t') (no assumptions) means time too
        subs.setdefault(sp.Symbol("t"), t)
        return tuple(q), subs

    def _normalise_forces(self, forces, conv):
        n = len(self._q)
        if forces is None:
            return (sp.S.Zero,) * n
        if isinstance(forces, Mapping):
            out = [sp.S.Zero] * n
            index = {s: i for i, s in enumerate(self._q)}
            index.update({s.name: i for i, s in enumerate(self._q)})
            for key, value in forces.items():
                key = conv(key) if not isinstance(key, str) else key
                if key not in index:
                    raise ValueError(f"forces: {key!r} is not a coordinate; the coordinates are "
                                     f"{list(self.coordinates)}.")
                out[index[key]] = conv(value)
            return tuple(out)
        forces = [conv(f) for f in forces]
        if len(forces) != n:
            raise ValueError(f"forces: give one generalized force per coordinate ({n}), "
                             f"got {len(forces)}; or pass a dict coordinate -> force.")
        return tuple(forces)

    def _validate(self):
        qset, vset = set(self._q), set(self._qdot)
        if not self._particles and self._lagrangian == 0:
            raise ValueError("the system has no kinetic energy: give particles=[Particle(m, r(q, t))] "
                             "or a lagrangian=L(q, q_dot, t).")
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
                raise ValueError(f"{p.name}: the mass must not depend on coordinates or velocities.")
        for name, expr in (("potential", self._potential),):
            if expr.free_symbols & vset:
                raise ValueError(f"the {name} must not depend on velocities; put velocity-dependent "
                                 "terms in the lagrangian or the forces.")
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
        all_exprs = self._all_expressions()
        bad = [e for e in all_exprs if e.has(sp.Derivative) or any(
            isinstance(f, sp.core.function.AppliedUndef) for f in e.atoms(sp.Function))]
        if bad:
            raise ValueError(f"expression {bad[0]} contains an undefined function or derivative; "
                             "declare every coordinate in `coordinates` (q(t) is accepted) and write "
                             "velocities as <name>_dot symbols.")

    def _all_expressions(self):
        exprs = [self._lagrangian, self._potential, self._dissipation, *self._constraints, *self._forces]
        for p in self._particles:
            exprs.append(p.mass)
            exprs.extend(p.position)
        return exprs

    def _collect_parameters(self):
        known = set(self._q) | set(self._qdot) | {t}
        free = set().union(*(e.free_symbols for e in self._all_expressions())) - known
        clash = sorted(s.name for s in free if s.name in {x.name for x in known})
        if clash:
            raise ValueError(f"symbol(s) {clash} share a name with a coordinate, velocity or t but are "
                             "different symbols (different assumptions?); use the symbols returned "
                             "by lagrange_core.coordinates().")
        names = [s.name for s in free]
        if len(set(names)) != len(names):
            dup = sorted({n for n in names if names.count(n) > 1})
            raise ValueError(f"parameter symbol(s) {dup} appear with different assumptions; use one "
                             "symbol per parameter name.")
        return tuple(sorted(free, key=lambda s: s.name))
