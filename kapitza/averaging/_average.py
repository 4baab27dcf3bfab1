"""Averaging over a fast periodic drive: the Kapitza effective potential of any system.

The single pendulum's closed forms, its next order and Acheson's chain are in
:mod:`kapitza.closed_forms`; this module is the general method for any
:class:`lagrange_core.System`, and its results are the value types of
:mod:`kapitza.results` (:class:`~kapitza.results.SlowModes`,
:class:`~kapitza.results.AveragingPrediction`, :class:`~kapitza.results.SlowModeSweep`).

The method (Landau & Lifshitz, *Mechanics*, §30)
-------------------------------------------------
A :class:`lagrange_core.System` in the canonical form

    M(q) q̈ = F(q, q̇, t)

whose time dependence is periodic with the drive's angular frequency ω is split
into its period average and a zero-mean fast part,

    F(q, q̇, t) = ⟨F⟩(q, q̇) + Σ_k [f_ck(q) cos kωt + f_sk(q) sin kωt].

Writing q = Q + ξ with the small fast response ξ = −M⁻¹ f_k cos kωt / (kω)² + …
and averaging over one period T = 2π/ω gives the slow motion

    M(Q) Q̈ = −∂U_eff/∂Q + (velocity terms of ⟨F⟩),
    U_eff = U + Σ_k (f_ckᵀ M⁻¹ f_ck + f_skᵀ M⁻¹ f_sk) / (4 k² ω²),

where U = ⟨V − T₀ − L′(q, 0, t)⟩ is the averaged potential (T₀ = ½ Σ m_i |∂r_i/∂t|²
is the part of the kinetic energy without velocities: a rotating hoop's
centrifugal potential, a constant for a translating pivot).  For a pivot moving
as R(t) the fast force is f = −Σ m_i J_iᵀ R̈ (J_i = ∂r_i/∂q); on the pendulum with
a vertical drive A cos ωt, f = m A ω² l sin θ, M = m l², so
U_eff = −m g l cos θ + m A² ω² sin² θ / 4.

Assumptions (checked; a clear ``ValueError`` otherwise)
------------------------------------------------------
* M does not depend on t (the drive moves the system rigidly, it does not
  change its inertia).
* The fast part of F does not depend on the velocities (no fast Coriolis or
  fast friction forces).
* The time dependence is a finite sum of harmonics of ωt (``cos(omega*t)``,
  ``sin(2*omega*t + phi)``, products of those …), with ``omega`` the parameter
  the caller names.
* The slow force at rest, ⟨F⟩(q, 0), is the gradient −∂U/∂q (no slow
  non-conservative force other than ones proportional to the velocities).

Accuracy
--------
First-order averaging neglects terms of relative order ε², where ε² is of the
order of (ω_slow/ω)² and of (|ξ|/L)² (L the length scale of the potential);
for the pendulum ε² ~ ω0²/ω² ~ A²/l².

Damping −C(q) q̇ (a Rayleigh dissipation function) enters the slow equation, and
puts the fast response partly in quadrature with the drive:

    M Q̈ + C Q̇ = −∂U_eff/∂Q + D(Q),

D the mean drag force of :meth:`AveragedSystem.mean_drag`, first order in γ/ω
(γ ~ C/M): it is nonzero only for a harmonic driven in two phases (both
f_k cos kωt and g_k sin kωt, e.g. an elliptic pivot path, where it tilts the hanging
pendulum to sin θ ≈ γ ω A B / (2 g l)); for a drive in one phase (a pivot on a
line) damping changes the fast response only at relative order (γ/ω)².  D is valid
where averaging is (relative error O(ε²)) and γ ≪ ω: the next term is of relative
order (γ/ω)² (for the pendulum the exact fast response gives D/(1 + γ²/ω²)).
Because D need not be a gradient, the slow stiffness H − ∂D/∂Q is not symmetric in
general.  The next order is available for the
vertically driven single pendulum through the Mathieu equation
(:func:`kapitza.closed_forms.pendulum_averaged` with ``order=2``).

Validity is reported, not hidden: every prediction carries the ratio of the
drive frequency to the slow frequencies and the size of the fast motion, and a
``valid`` flag from the thresholds ``MIN_FREQUENCY_RATIO`` and
``MAX_AMPLITUDE_RATIO`` (:mod:`kapitza.averaging._validity`; for the vertically driven
pendulum also ``MAX_CORRECTION`` of :mod:`kapitza.closed_forms`, the size of the
next-order correction, which catches the neighbourhood of the stability limits);
scalar calls outside the regime emit an :class:`AveragingValidityWarning`, array
calls only set the flags so that a sweep can mask those points.

Compiled kernels
----------------
U_eff, its gradient and Hessian are generated as a numba module per system and drive
frequency and kept in lagrange_core's one generated-module store
(:mod:`lagrange_core.module_store`), keyed by the system's statement and the code
that generates the module (:mod:`kapitza.averaging._codegen`); a fresh process loads
them without compiling.  The averaging window per ω is :mod:`kapitza.averaging._window`.

Examples
--------
The vertically driven pendulum (PHYSICS.md): U_eff = −m g l cos θ + m A² ω² sin² θ / 4.

>>> from lagrange_core import problems
>>> avg = average(problems.driven_pendulum("vertical"))
>>> avg.effective_potential
m*(A**2*omega**2*sin(theta)**2 - 4*g*l*cos(theta))/4
>>> modes = avg.slow_modes(dict(m=1.0, l=1.0, g=9.81, A=0.05, omega=150.0), [3.141592653589793])
>>> exact = 0.05**2 * 150**2 / 2 - 9.81
>>> print(f"Ω² = {modes.omega_squared[0]:.4f} rad²/s² = A²ω²/2 − g/l = {exact:.4f}")
Ω² = 18.3150 rad²/s² = A²ω²/2 − g/l = 18.3150
"""
from __future__ import annotations

import functools
import itertools
import math
import warnings

import numpy as np
import sympy as sp

from lagrange_core.checks import real_array
from lagrange_core.progress import run_in_chunks
from lagrange_core.systems import System
from lagrange_core.systems import t as t_symbol

from .. import _arguments as arguments
from .._deprecation import keyword_options, warn_deprecated
from ..results import (
    AveragingPrediction,
    ComputationInterrupted,
    SlowModes,
    SlowModeSweep,
    StabilityWindow,
)
from ._codegen import effective, load_kernels, terms
from ._fourier import fourier_split
from ._legacy import params_first
from ._validity import AveragingValidityWarning, reasons
from ._window import amplitude_range, averaged_system_window

__all__ = ["average", "AveragedSystem"]


@keyword_options("kapitza.average", 1, ("frequency",), renames={"omega": "frequency"})
def average(system: System, *, frequency: str = "omega") -> AveragedSystem:
    """Average ``system`` over its fast periodic drive (first order, Landau–Lifshitz §30).

    Parameters
    ----------
    system : lagrange_core.System
        A system whose explicit time dependence is periodic in ``omega * t``
        (a pivot moving as A d cos ωt, a sum of harmonics, an elliptic path …).
    frequency : str
        Name of the parameter that is the drive's angular frequency (rad/s).  Before
        kapitza 0.2 ``omega=`` (or by position; both still work and warn).

    Returns
    -------
    AveragedSystem

    Raises
    ------
    ValueError
        If ``frequency`` is not a parameter of the system, or an assumption of the
        method fails (see the module docstring).
    """
    if not isinstance(system, System):
        raise TypeError(f"average() needs a lagrange_core.System, got {type(system).__name__}.")
    return _average_cached(system, str(frequency))


@functools.lru_cache(maxsize=64)
def _average_cached(system, omega):
    return AveragedSystem(system, omega)


class AveragedSystem:
    """The slow (averaged) description of a periodically driven system.

    Built by :func:`average`; immutable.  Symbolic results are sympy
    expressions in the system's coordinates and parameters; numeric methods take
    parameters by name (``params`` dict, as everywhere in lagrange_core) and run
    compiled numba kernels (cached on disk, parameters passed as an array, so
    changing a value never recompiles).

    Attributes
    ----------
    system : System
    omega : sympy.Symbol
        The drive frequency's parameter (named by ``average(system, frequency=...)``).
    mass_matrix : sympy.Matrix
        M(q), independent of t.
    slow_potential : sympy expression
        U(q) = ⟨V − T₀ − L′(q, 0, t)⟩, up to an additive constant.
    fast_forces : tuple of (k, kind, sympy.Matrix)
        The fast generalized forces f_ck ("cos") and f_sk ("sin") of harmonic k.
    damping_matrix : sympy.Matrix
        C(q) = −∂⟨F⟩/∂q̇ at q̇ = 0.
    """

    def __init__(self, system: System, omega: str):
        self.system = system
        params = {s.name: s for s in system.parameter_symbols}
        if omega not in params:
            raise ValueError(
                f"{omega!r} is not a parameter of {system._label()}; its parameters are "
                f"{list(system.parameters)}. Pass the name of the drive's angular frequency as "
                "average(system, frequency='...').")
        self.omega = params[omega]
        eq = system.equations
        q, qd = system.q, system.qdot
        n = system.n_dof
        if system.n_constraints:
            raise ValueError("averaging needs an unconstrained system (independent coordinates); "
                             f"{system._label()} has {system.n_constraints} constraint(s). Restate "
                             "it in coordinates that satisfy the constraints.")
        # the sympy views of derived equations carry plain symbols (no assumptions):
        # map them back to the system's own symbols so that q, q̇ and t are recognised
        own = {sp.Symbol(x.name): x for x in (*q, *qd, *system.parameter_symbols, t_symbol)}
        M = eq.mass_matrix.xreplace(own)
        forcing = eq.forcing.xreplace(own)
        for entry in M:
            if entry.has(t_symbol) and sp.simplify(sp.diff(entry, t_symbol)) != 0:
                raise ValueError(
                    f"the mass matrix of {system._label()} depends on t ({entry}); averaging "
                    "assumes a time-independent M(q) (the drive may move the system, not change "
                    "its inertia).")
        self.mass_matrix = M.applyfunc(sp.trigsimp)
        slow = []
        fast: dict[tuple[int, str], list] = {}
        for i, Fi in enumerate(forcing):
            parts = fourier_split(Fi, self.omega)
            slow.append(parts[0][0])
            for k, (c, s) in parts.items():
                if k == 0:
                    continue
                for kind, coef in (("cos", c), ("sin", s)):
                    if coef == 0:
                        continue
                    if any(sp.simplify(sp.diff(coef, v)) != 0 for v in coef.free_symbols & set(qd)):
                        raise ValueError(
                            f"the fast part of the generalized force on {q[i].name} depends on "
                            f"the velocities ({coef} × {kind} {k}ωt); Landau–Lifshitz averaging "
                            "assumes a velocity-independent fast force (no fast Coriolis or "
                            "friction forces).")
                    # velocity terms that cancel (checked above) are dropped
                    coef = coef.xreplace({v: 0 for v in qd})
                    fast.setdefault((k, kind), [sp.S.Zero] * n)[i] = coef
        self.fast_forces = tuple((k, kind, sp.Matrix(vec))
                                 for (k, kind), vec in sorted(fast.items()))
        zero_v = {v: 0 for v in qd}
        self._slow_force_at_rest = sp.Matrix([s.xreplace(zero_v) for s in slow])
        self.damping_matrix = sp.Matrix(n, n,
                                        lambda i, j: -sp.diff(slow[i], qd[j]).xreplace(zero_v))
        # harmonics driven in two phases (cos and sin) on a damped system leave a mean drag
        index = {(k, kind): i for i, (k, kind, _) in enumerate(self.fast_forces)}
        self._drag_pairs = () if all(c == 0 for c in self.damping_matrix) else tuple(
            (index[k, "cos"], index[k, "sin"]) for k, kind, _ in self.fast_forces
            if kind == "cos" and (k, "sin") in index)
        # U = <V - T0 - L'(q, 0, t)>: the part of the Lagrangian without velocities, averaged
        T0 = sum((p.mass * sum(sp.diff(c, t_symbol) ** 2 for c in p.position) / 2
                  for p in system.particles), sp.S.Zero)
        U = system.potential - T0 - system.lagrangian_term.xreplace(zero_v)
        U = fourier_split(U, self.omega)[0][0]
        U = sp.Add(*[term for term in sp.Add.make_args(sp.expand(U)) if term.free_symbols & set(q)])
        self.slow_potential = U
        self._check_conservative()

    # -- symbolic ------------------------------------------------------------------------
    @functools.cached_property
    def effective_potential(self) -> sp.Expr:
        """U_eff(q) = U + Σ_k (f_ckᵀ M⁻¹ f_ck + f_skᵀ M⁻¹ f_sk) / (4 k² ω²) (sympy).

        Accuracy: first-order averaging (relative error O(ε²), see the module
        docstring).  For many coordinates the symbolic M⁻¹ makes this large;
        the numeric methods do not need it.
        """
        M = self.mass_matrix
        total = self.slow_potential
        for k, _, f in self.fast_forces:
            x = M.LUsolve(f)
            total += (f.T * x)[0] / (4 * k ** 2 * self.omega ** 2)
        # simplification pays for one coordinate; for more it costs seconds and rarely helps
        return sp.simplify(total) if self.system.n_dof == 1 else total

    def _check_conservative(self):
        """⟨F⟩(q, 0) must equal −∂U/∂q (checked at random points, exact arithmetic not needed)."""
        q = self.system.q
        syms = list(q) + list(self.system.parameter_symbols)
        resid = self._slow_force_at_rest + sp.Matrix([sp.diff(self.slow_potential, s) for s in q])
        fn = sp.lambdify(syms, resid, "numpy")
        rng = np.random.default_rng(12345)
        for _ in range(3):
            vals = np.concatenate([rng.uniform(-3, 3, len(q)),
                                   rng.uniform(0.5, 2.0, len(self.system.parameter_symbols))])
            r = np.asarray(fn(*vals), dtype=float)
            if np.max(np.abs(r)) > 1e-8 * (1 + np.max(np.abs(vals)) ** 4):
                raise ValueError(
                    f"the averaged force at rest of {self.system._label()} is not the gradient of "
                    f"the averaged potential U = {self.slow_potential} (residual {r.ravel()}); "
                    "averaging into an effective potential needs a conservative slow force at "
                    "rest (non-conservative generalized forces must vanish when q̇ = 0).")

    # -- numeric kernels -----------------------------------------------------------------
    @functools.cached_property
    def kernels(self):
        """The compiled module (:mod:`kapitza.averaging._codegen`): ``effective(q, p, G, H)
        -> U_eff`` (fills gradient G and Hessian H; the kernel every system shares),
        ``slow_terms``, ``mass_terms``, ``fast_terms``,
        ``damping(q, p, C)``, ...; loaded from the store when a process made it before."""
        return load_kernels(self)

    # -- numeric API -----------------------------------------------------------------------
    def _p(self, params):
        return self.system.parameter_array(params)

    def evaluate(self, params, q):
        """U_eff, its gradient and Hessian at ``q`` (J, J/unit, J/unit²).

        ``params`` by name, ``q`` the coordinates (a sequence, or a dict by coordinate).
        Before kapitza 0.2 the order was ``evaluate(q, params)``; it still works and warns.

        Returns
        -------
        value : float
        gradient : ndarray (n,)
        hessian : ndarray (n, n)
        """
        params, q = params_first(self.system, params, q, "AveragedSystem.evaluate")
        qa = self.system.coordinate_array(q, "q")
        p = self._p(params)
        self._check_drive(p)
        n = self.system.n_dof
        G, H = np.empty(n), np.empty((n, n))
        value = effective(self.kernels, qa, p, G, H)
        return float(value), G, H

    def _check_drive(self, p):
        self._check_frequency(float(p[self.system.parameters.index(self.omega.name)]))

    def _check_frequency(self, w: float):
        if not w > 0:
            raise ValueError(f"the drive frequency {self.omega.name} must be > 0 (rad/s), got {w}.")
        with np.errstate(over="ignore"):    # the slow terms carry ω²: it must be a float
            square = w * w
        if not np.isfinite(square):
            raise ValueError(f"the drive frequency {self.omega.name} = {w!r} rad/s: ω² "
                             "overflows a float; give ω below 1e150 rad/s.")

    def mean_drag(self, params, q) -> np.ndarray:
        """The mean drag force D(q) of a damped two-phase drive (see ``_drag``), in the
        units of the generalized forces; zeros when there is none.

        Before kapitza 0.2 the order was ``mean_drag(q, params)``; it still works and warns.

        The averaged motion is M Q̈ + C Q̇ = −∂U_eff/∂Q + D(Q): the equilibria are the roots
        of ∂U_eff/∂Q − D (:meth:`equilibria`), their stiffness H − ∂D/∂Q (:meth:`slow_modes`).
        """
        params, q = params_first(self.system, params, q, "AveragedSystem.mean_drag")
        qa = self.system.coordinate_array(q, "q")
        p = self._p(params)
        self._check_drive(p)
        return self._drag(qa, p)

    def _drag(self, q, p) -> np.ndarray:
        """D(q), first order in C/ω, for the fast force Σ_k f_k cos kωt + g_k sin kωt.

        Derivation: the fast response to the drive, M ξ̈ + C ξ̇ = f cos ωt + g sin ωt,
        is ξ = Re[X e^(−iωt)] with X = −(ω² M + iω C)⁻¹ (f + i g)
        = −M⁻¹(f + ig)/ω² + i M⁻¹C M⁻¹(f + ig)/ω³ + O(C²/ω⁴).  Averaging the slow
        equation to second order in ξ gives, besides −∂U_eff/∂Q (the C⁰ part), a mean
        force of first order in C/ω: with u = M⁻¹f, v = M⁻¹g, p = M⁻¹C u, s = M⁻¹C v,

            D_i = [ Σ_a (∂_a g_i p_a − ∂_a f_i s_a)              ⟨(∂F_fast/∂q) ξ⟩
                    + uᵀ(∂_i M) s − vᵀ(∂_i M) p                  ⟨kinetic terms in ξ̇⟩
                    + Σ_aj ∂_a C_ij (v_a u_j − u_a v_j) ] / (2ω³)  ⟨(∂C/∂q)[ξ] ξ̇⟩

        (harmonic k: ω → kω; different harmonics do not mix).  It vanishes for a drive
        in one phase (g = 0) and for C = 0.  Elliptic pivot x = A cos ωt, y = B sin ωt
        on the pendulum (f = m l ω² A cos θ, g = m l ω² B sin θ, C = m l² γ):
        D = m γ ω A B / 2, which the exact 1-DOF response gives as
        m γ ω A B / (2 (1 + γ²/ω²)).
        """
        n = self.system.n_dof
        D = np.zeros(n)
        if not self._drag_pairs:
            return D
        K = self.kernels
        M, Mg, f, fg, w = terms(K, q, p, n)
        C, Cg = np.zeros((n, n)), np.zeros((n, n, n))
        K.damping(q, p, C)
        K.damping_gradient(q, p, Cg)
        Minv = np.linalg.inv(M)
        for ic, js in self._drag_pairs:
            om = 0.5 / math.sqrt(w[ic])                  # w = 1/(4 k² ω²)
            u, v = Minv @ f[ic], Minv @ f[js]
            pu, sv = Minv @ (C @ u), Minv @ (C @ v)
            D += (fg[js] @ pu - fg[ic] @ sv
                  + np.einsum("ijk,j,k->i", Mg, u, sv) - np.einsum("ijk,j,k->i", Mg, v, pu)
                  + np.einsum("aij,a,j->i", Cg, v, u) - np.einsum("aij,a,j->i", Cg, u, v)
                  ) / (2 * om**3)
        return D

    def _slow_force(self, q, p):
        """−∂U_eff/∂q + D and its Jacobian (the negative stiffness); D's by central
        differences (D is itself a first-order correction)."""
        n = self.system.n_dof
        G, H = np.empty(n), np.empty((n, n))
        effective(self.kernels, q, p, G, H)
        F, J = -G, -H
        if self._drag_pairs:
            F = F + self._drag(q, p)
            for a in range(n):
                h = 1e-6 * max(1.0, abs(q[a]))
                qp, qm = q.copy(), q.copy()
                qp[a] += h
                qm[a] -= h
                J[:, a] += (self._drag(qp, p) - self._drag(qm, p)) / (2 * h)
        return F, J

    @functools.cached_property
    def _angular(self) -> np.ndarray:
        """Which coordinates are angles (U_eff and M 2π-periodic in them), tested numerically."""
        n = self.system.n_dof
        rng = np.random.default_rng(7)
        p = rng.uniform(0.5, 2.0, len(self.system.parameters))
        q0 = rng.uniform(-1, 1, n)
        out = np.zeros(n, bool)
        K = self.kernels
        G, H = np.empty(n), np.empty((n, n))
        M0, M1 = np.empty((n, n)), np.empty((n, n))
        Mg, Mh = np.zeros((n, n, n)), np.zeros((n, n, n, n))
        v0 = effective(K, q0, p, G, H)
        K.mass_terms(q0, p, M0, Mg, Mh)
        for j in range(n):
            q1 = q0.copy()
            q1[j] += 2 * math.pi
            v1 = effective(K, q1, p, G, H)
            K.mass_terms(q1, p, M1, Mg, Mh)
            out[j] = abs(v1 - v0) <= 1e-10 * (1 + abs(v0)) and np.allclose(M0, M1, rtol=1e-10)
        return out

    def _wrap(self, qv):
        qv = np.array(qv, float)
        ang = self._angular
        qv[ang] = qv[ang] - 2 * np.pi * np.ceil((qv[ang] - np.pi) / (2 * np.pi) - 1e-12)
        qv[np.abs(qv) < 1e-12] = 0.0
        return qv

    @keyword_options("AveragedSystem.equilibria", 3, ("tol",))
    def equilibria(self, params, guesses=None, *, tol: float = 1e-10) -> np.ndarray:
        """Equilibria of the averaged motion: roots of ∂U_eff/∂q − D(q) (D the mean drag of a
        damped two-phase drive, :meth:`mean_drag`; zero otherwise).

        Parameters
        ----------
        params : dict
            Parameter values by name.
        guesses : array (k, n), optional
            Starting points.  By default every combination of
            {0, π/2, π, −π/2} for angular coordinates (needs all coordinates to
            be angles and n ≤ 5).
        tol : float
            Accept a root when |∂U_eff/∂q − D| ≤ tol × (1 + max |Hessian|).

        Returns
        -------
        ndarray (m, n)
            Distinct equilibria, angles wrapped into (−π, π], sorted.
        """
        n = self.system.n_dof
        p = self._p(params)
        self._check_drive(p)
        if guesses is None:
            if not self._angular.all() or n > 5:
                raise ValueError("equilibria(): pass guesses=[[...], ...] (starting points); the "
                                 "default grid is only for systems whose coordinates are all "
                                 "angles and n ≤ 5.")
            guesses = np.array(list(itertools.product((0.0, np.pi / 2, np.pi, -np.pi / 2),
                                                      repeat=n)))
        guesses = np.atleast_2d(np.asarray(guesses, float))
        if guesses.shape[1] != n:
            raise ValueError(f"guesses must have {n} columns (one per coordinate "
                             f"{list(self.system.coordinates)}), got shape {guesses.shape}.")
        def fun(x):
            F, J = self._slow_force(x, p)
            return -F, -J

        import scipy.optimize  # not at import: scipy costs ~0.4 s

        found = []
        for g0 in guesses:
            sol = scipy.optimize.root(fun, g0, jac=True, method="hybr", options={"xtol": 1e-13})
            x = sol.x
            g, h = fun(x)
            if not np.all(np.isfinite(g)) or np.max(np.abs(g)) > tol * (1 + np.max(np.abs(h))):
                continue
            x = self._wrap(x)
            if not any(np.allclose(x, y, atol=1e-7) for y in found):
                found.append(x)
        found.sort(key=lambda v: tuple(np.round(v, 9)))
        return np.array(found).reshape(-1, n)

    @keyword_options("AveragedSystem.slow_modes", 3, ("warn",))
    def slow_modes(self, params, about, *, warn: bool = True) -> SlowModes:
        """Slow modes about the equilibrium ``about`` (see :class:`SlowModes`).

        With a mean drag D (:meth:`mean_drag`) the stiffness is H − ∂D/∂q, not symmetric
        in general: ``omega_squared`` are then the real parts of its generalized
        eigenvalues and ``stable`` also requires every root λ to decay (Re λ < 0).

        Raises
        ------
        ValueError
            If ``about`` is not an equilibrium of the averaged motion.
        """
        n = self.system.n_dof
        qa = self.system.coordinate_array(about, "about")
        p = self._p(params)
        self._check_drive(p)
        K = self.kernels
        F, J = self._slow_force(qa, p)
        H = -J
        if not (np.all(np.isfinite(F)) and np.all(np.isfinite(H))):
            named = dict(zip(self.system.parameters, p.tolist(), strict=True))
            raise ValueError(f"the averaged force or its gradient at q={qa.tolist()} overflows "
                             f"a float with params={named}"
                             "; a parameter is far out of range (the drive's A ω beyond ~1e150?).")
        if np.max(np.abs(F)) > 1e-8 * (1 + np.max(np.abs(H))):
            raise ValueError(f"q={qa.tolist()} is not an equilibrium of the averaged motion "
                             f"(∂U_eff/∂q − D = {(-F).tolist()}); find them with "
                             "equilibria(params).")
        M, _, f, fg, w = terms(K, qa, p, n)
        C = np.zeros((n, n))
        K.damping(qa, p, C)
        import scipy.linalg  # not at import: scipy costs ~0.4 s

        if self._drag_pairs:
            w2 = np.sort(scipy.linalg.eigvals(H, M).real)
        else:
            H = (H + H.T) / 2
            w2 = np.sort(scipy.linalg.eigh(H, M, eigvals_only=True))
        freqs = np.where(w2 >= 0, np.sqrt(np.abs(w2)), np.nan)
        # the damped slow dynamics: first-order form of M x'' + C x' + H x = 0
        Minv = np.linalg.inv(M)
        Amat = np.block([[np.zeros((n, n)), np.eye(n)], [-Minv @ H, -Minv @ C]])
        lam = np.linalg.eigvals(Amat)
        lam = lam[np.lexsort((lam.real, lam.imag))]
        # one non-negative imaginary part per mode: a pair ±iΩ_d, or 0 for an overdamped mode
        tiny = 1e-12 * max(np.max(np.abs(lam)), 1e-300)
        positive = np.sort(lam.imag[lam.imag > tiny])
        damped = np.concatenate([np.zeros(n - len(positive)), positive])
        omega = p[self.system.parameters.index(self.omega.name)]
        rate = max(np.max(np.sqrt(np.abs(w2))), np.max(np.abs(lam)), 1e-300)
        freq_ratio = float(omega / rate)
        # fast displacement amplitude per unit slow displacement: |M⁻¹ ∂f_k/∂q| / (kω)² = 4 w_k |…|
        amp = 0.0
        for k in range(len(w)):
            J = np.linalg.solve(M, fg[k]) * 4 * w[k]
            amp = max(amp, float(np.linalg.norm(J, 2)))
        why = reasons(freq_ratio, amp)
        modes = SlowModes(about=self._wrap(qa), omega_squared=w2, frequencies=freqs,
                          stable=bool(np.all(w2 > 0) and not (self._drag_pairs
                                                              and np.max(lam.real) >= 0)),
                          eigenvalues=lam,
                          damped_frequencies=damped, decay_rate=float(-np.max(lam.real)) + 0.0,
                          frequency_ratio=freq_ratio, amplitude_ratio=amp,
                          valid=not why, reasons=why)
        if warn and why:
            warnings.warn(f"averaging about {modes.about.tolist()}: " + "; ".join(why),
                          AveragingValidityWarning, stacklevel=2)
        return modes

    @keyword_options("AveragedSystem.sweep", 3, ("progress",))
    def sweep(self, params, about, *, progress=None) -> SlowModeSweep:
        """Slow modes about ``about`` over arrays of parameter values (no re-derivation).

        Parameters
        ----------
        params : dict
            Parameter values by name; any of them may be arrays, broadcast together.
        about : sequence
            An equilibrium for every point (e.g. the upright chain).
        progress : None, bool or callable
            The points run in chunks of about 0.25 s
            (:func:`lagrange_core.progress.run_in_chunks`): a progress line on stderr for
            sweeps longer than 0.5 s when stderr is a terminal (None), always (True), never
            (False), or ``progress(done, total)`` after every chunk.

        Returns
        -------
        SlowModeSweep
            ``omega_squared`` of shape (..., n) and per-point ``stable``, ``valid``.

        Raises
        ------
        kapitza.results.ComputationInterrupted
            On Ctrl-C (within a chunk's time): a KeyboardInterrupt whose ``.result`` is
            the SlowModeSweep with the finished points filled (the others NaN, not
            stable, not valid) and ``.computed`` marks them.
        """
        names = list(params)
        values = [real_array(params[k], f"params[{k!r}]") for k in names]
        try:
            arrays = np.broadcast_arrays(*values)
        except ValueError:
            raise ValueError("AveragedSystem.sweep: the parameters must broadcast together, got "
                             "shapes " + ", ".join(f"{k} {v.shape}" for k, v in zip(
                                 names, values, strict=True)) + ".") from None
        shape = arrays[0].shape
        if self.omega.name in names:        # checked up front, an empty grid's too
            for w in np.unique(values[names.index(self.omega.name)]):
                self._check_frequency(float(w))
        n = self.system.n_dof
        arguments.check_grid_memory("params (broadcast)", shape,
                                    arguments.averaging_bytes_per_point(n),
                                    where="AveragedSystem.sweep: ")
        w2 = np.full(shape + (n,), np.nan)
        stable = np.zeros(shape, bool)
        valid = np.zeros(shape, bool)
        size = int(np.prod(shape))

        def work(start, stop):
            for i in range(start, stop):
                idx = np.unravel_index(i, shape)
                modes = self.slow_modes({k: a[idx] for k, a in zip(names, arrays, strict=True)},
                                        about, warn=False)
                w2[idx], stable[idx], valid[idx] = modes.omega_squared, modes.stable, modes.valid

        done, interrupted = run_in_chunks(work, size, progress=progress, label="averaging sweep")
        if interrupted:                       # a chunk cut short: its points count as not done
            w2.reshape(size, n)[done:] = np.nan
            stable.reshape(size)[done:] = False
            valid.reshape(size)[done:] = False
        result = SlowModeSweep(params={k: a for k, a in zip(names, arrays, strict=True)},
                               about=np.asarray(about, float), omega_squared=w2, stable=stable,
                               valid=valid)
        if interrupted:
            raise ComputationInterrupted(result, (np.arange(size) < done).reshape(shape))
        return result

    @keyword_options("AveragedSystem.minimum_amplitude", 3, ("amplitude", "upper"),
                     renames={"upper": ("A_range", lambda upper: None if upper is None
                                        else (0.0, upper), "A_range=(0.0, upper)")})
    def minimum_amplitude(self, params, about, *, amplitude: str = "A",
                          A_range=None) -> float:
        """The smallest value of the parameter ``amplitude`` that makes ``about`` stable.

        Bisects (brentq) the smallest Ω² of the averaged linearisation about
        ``about`` in the parameter named ``amplitude`` at the other values in
        ``params``; ``about`` must be an equilibrium for every amplitude (e.g.
        the upright chain).  First-order averaging, so the value has a relative
        error O(ε²) (see the module docstring); for the N-link pendulum on a
        vertical pivot it is √2 g / (ω ω_min)
        (:func:`kapitza.closed_forms.multiple_pendulum_upright`).  Per ω over arrays:
        :meth:`window` (its ``A_min``).

        Parameters
        ----------
        params : dict
            Parameter values by name (the value of ``amplitude`` is ignored).
        about : sequence or dict
            An equilibrium of the averaged motion for every amplitude.
        amplitude : str
            Name of the drive amplitude parameter.
        A_range : (low, high), optional
            The amplitudes searched (m): ``low`` is returned if ``about`` is already
            stable there, an error is raised if it is not stable at ``high``.  Default
            (0, …): doubled from 1e-6 until stable, at most 60 times.  Before kapitza 0.2
            ``upper=high`` (it still works and warns; it is ``A_range=(0.0, high)``).

        Raises
        ------
        ValueError
            If ``amplitude`` is not a parameter or no stabilising value is found.

        Examples
        --------
        The single pendulum's Kapitza limit A ω = √(2 g l) at ω = 100 rad/s:

        >>> import math
        >>> from lagrange_core import problems
        >>> avg = average(problems.driven_pendulum("vertical"))
        >>> A = avg.minimum_amplitude(dict(m=1.0, l=1.0, g=9.81, omega=100.0), [math.pi])
        >>> print(f"{A * 100:.9f} = {math.sqrt(2 * 9.81):.9f}")
        4.429446918 = 4.429446918
        """
        where = "AveragedSystem.minimum_amplitude"
        if amplitude not in self.system.parameters:
            raise ValueError(f"{where}: amplitude={amplitude!r} is not a parameter; the "
                             f"parameters are {list(self.system.parameters)}.")
        low, high = amplitude_range(A_range, where)
        base = dict(params)

        def lowest(x):
            base[amplitude] = x
            return float(self.slow_modes(base, about, warn=False).omega_squared[0])

        lo = low
        if lowest(lo) > 0:
            return lo
        if math.isfinite(high):
            hi = high if lowest(high) > 0 else None
        else:
            hi = max(2 * low, 1e-6)
            for _ in range(60):
                if lowest(hi) > 0:
                    break
                lo, hi = hi, 2 * hi
            else:
                hi = None
        if hi is None:
            limit = f"{high:g}" if math.isfinite(high) else "the search limit"
            raise ValueError(f"{where}: no value of {amplitude!r} up to {limit} makes "
                             f"{list(np.atleast_1d(about))} stable in first-order averaging; "
                             "widen A_range=(low, high).")
        import scipy.optimize  # not at import: scipy costs ~0.4 s

        return float(scipy.optimize.brentq(lowest, lo, hi, xtol=1e-14, rtol=1e-12))

    def window(self, params, about, *, omega, amplitude: str = "A",
               A_range=None) -> StabilityWindow:
        """The amplitudes that hold the equilibrium ``about``, per drive frequency (order 1).

        The averaging window: per ω, ``A_min`` is the smallest value of the parameter
        ``amplitude`` at which every eigenvalue of the averaged stiffness about ``about``
        is positive (every slow mode real, Ω² > 0); ``A_max`` the largest, +inf where
        first-order averaging sees no upper edge (it does not see the parametric
        resonance that bounds the exact window, :func:`kapitza.floquet.window`).  Exact
        roots of the averaged stiffness by Newton's method on its concave margin, all ω at
        once, when the amplitude only scales the fast forces (a pivot moving as
        A d cos ωt); root-finding within ``A_range`` otherwise
        (:mod:`kapitza.averaging._window`).

        Accuracy: first-order averaging, relative error of the edge O(ω_s²/ω²), ω_s
        the slow scale (ω0 = √(g/l) for the pendulum, where the exact relative error
        of A_min is ≈ (7/16) ω0²/ω²); ``error_estimate`` reports (ω_s/ω)².  The roots
        themselves are solved to rounding (≈ 1e-15 relative): the single pendulum gives
        A_min ω = √(2 g l), the N-link chain √2 g / ω_min (Acheson).

        Parameters
        ----------
        params : dict
            The other parameters by name (values for ``amplitude`` and the drive
            frequency, if present, are ignored).
        about : sequence or dict
            An equilibrium of the averaged motion for every amplitude (e.g. the upright
            chain [π, π]).
        omega : float or array
            Drive angular frequencies (rad/s, > 0), values of this system's drive
            frequency parameter.
        amplitude : str
            Name of the drive amplitude parameter.
        A_range : (low, high), optional
            The amplitudes considered (m; default (0, inf)): where the window does not
            meet [low, high] both edges are NaN; the edges themselves are not clipped.
            Needed (with a finite ``high``) when the amplitude does more than scale the
            fast forces; the upper edge is then not searched (+inf).

        Returns
        -------
        kapitza.results.StabilityWindow
            ``method="averaging"``, ``order=1``, ``about`` the coordinates as text;
            ``A_min``, ``A_max`` (NaN where no amplitude in ``A_range`` holds
            ``about``), ``exists``, ``frequency_ratio`` (ω / fastest slow rate at A = 0
            and at A_min), ``error_estimate`` = frequency_ratio⁻², ``fast_drive``,
            ``small_amplitude`` (fast displacement per slow displacement at A_min ≤
            MAX_AMPLITUDE_RATIO), ``valid`` (both, and ``exists``; ``fast_drive``
            implies error_estimate ≤ 1/25), ``converged`` None (no next order is
            computed).  Arrays shaped like ``omega``.

        Raises
        ------
        ValueError
            Unknown ``amplitude``, ω ≤ 0, ``about`` not an equilibrium, a damped
            two-phase drive (its mean drag moves the equilibrium with A), a bad
            ``A_range``, or the root-finding case without a finite ``A_range``.

        Examples
        --------
        >>> import math
        >>> from lagrange_core import problems
        >>> avg = average(problems.driven_pendulum("vertical"))
        >>> win = avg.window(dict(m=1.0, l=1.0, g=9.81), [math.pi], omega=[50.0, 100.0])
        >>> print(win.A_min * win.omega, math.sqrt(2 * 9.81))     # doctest: +ELLIPSIS
        [4.429... 4.429...] 4.429...
        """
        return averaged_system_window(self, params, about, omega, amplitude=amplitude,
                                      A_range=A_range)

    def stability_window(self, omega, about, *, params, amplitude: str = "A",
                         A_max: float | None = None) -> StabilityWindow:
        """Deprecated since kapitza 0.2.0: :meth:`window`, ``A_max=x`` → ``A_range=(0.0, x)``.

        ``avg.stability_window(omega, about, params=p)`` is
        ``avg.window(p, about, omega=omega)``.
        """
        warn_deprecated("AveragedSystem.stability_window(omega, about, params=params, "
                        "A_max=A_max)", "AveragedSystem.window(params, about, omega=omega, "
                        "A_range=(0.0, A_max))")
        if A_max is not None and not (np.ndim(A_max) == 0 and float(A_max) > 0):
            raise ValueError(f"AveragedSystem.stability_window: A_max must be a positive number "
                             f"(the largest amplitude considered), got {A_max!r}.")
        return self.window(params, about, omega=omega, amplitude=amplitude,
                           A_range=None if A_max is None else (0.0, float(A_max)))

    stability_window.__deprecated__ = "AveragedSystem.window(params, about, omega=...)"

    @keyword_options("AveragedSystem.predict", 3, ("warn",))
    def predict(self, params, guesses=None, *, warn: bool = True) -> AveragingPrediction:
        """All equilibria (see :meth:`equilibria`) with their slow modes."""
        eqs = self.equilibria(params, guesses)
        return AveragingPrediction(params=dict(params),
                                   equilibria=tuple(self.slow_modes(params, e, warn=warn)
                                                    for e in eqs))

    def __repr__(self):
        return (f"<AveragedSystem of {self.system._label()}: drive {self.omega.name}, "
                f"{len(self.fast_forces)} fast force vector(s)>")
