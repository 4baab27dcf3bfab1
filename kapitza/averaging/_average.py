"""Averaging over a fast periodic drive: the Kapitza effective potential of any system.

The single pendulum's closed forms, its next order and Acheson's chain are in
:mod:`kapitza.pendulum_closed_forms`; this module is the general method for any
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
(:func:`kapitza.pendulum_closed_forms.pendulum_averaged` with ``order=2``).

Validity is reported, not hidden: every prediction carries the ratio of the
drive frequency to the slow frequencies and the size of the fast motion, and a
``valid`` flag from the thresholds :data:`MIN_FREQUENCY_RATIO` and
:data:`MAX_AMPLITUDE_RATIO` (for the vertically driven pendulum also
``MAX_CORRECTION`` of :mod:`kapitza.pendulum_closed_forms`, the size of the
next-order correction, which catches the neighbourhood of the stability limits);
scalar calls outside the regime emit an :class:`AveragingValidityWarning`, array
calls only set the flags so that a sweep can mask those points.

Compiled kernels
----------------
U_eff, its gradient and Hessian are generated as a numba module per system and drive
frequency and kept in lagrange_core's one generated-module store
(:mod:`lagrange_core.module_store`), keyed by the system's statement and the code
that generates the module; a fresh process loads them without compiling.

Examples
--------
The vertically driven pendulum (PHYSICS.md): U_eff = −m g l cos θ + m A² ω² sin² θ / 4.

>>> from lagrange_core import problems
>>> avg = average(problems.driven_pendulum("vertical"))
>>> avg.effective_potential
m*(A**2*omega**2*sin(theta)**2 - 4*g*l*cos(theta))/4
>>> modes = avg.slow_modes(dict(m=1.0, l=1.0, g=9.81, A=0.05, omega=150.0), [3.141592653589793])
>>> print(f"Ω² = {modes.omega_squared[0]:.4f} rad²/s² = A²ω²/2 − g/l = {0.05**2 * 150**2 / 2 - 9.81:.4f}")
Ω² = 18.3150 rad²/s² = A²ω²/2 − g/l = 18.3150
"""
from __future__ import annotations

import functools
import itertools
import math
import re
import textwrap
import warnings

import numpy as np
import scipy.linalg
import scipy.optimize
import sympy as sp
import symengine as se

from lagrange_core import _linalg, module_store
from lagrange_core.systems import System, t as t_symbol

from lagrange_core.progress import run_in_chunks
from ..results import (AveragingPrediction, ComputationInterrupted, SlowModes, SlowModeSweep,
                      StabilityWindow)

__all__ = ["MIN_FREQUENCY_RATIO", "MAX_AMPLITUDE_RATIO", "AveragingValidityWarning",
           "fourier_split", "average", "AveragedSystem"]

#: A prediction is flagged invalid when ω < MIN_FREQUENCY_RATIO × (largest slow
#: frequency or growth rate, and ω0 for the pendulum).  At ratio 5 the
#: first-order slow frequency of the pendulum is off by ≲ 3 % (next-order term).
MIN_FREQUENCY_RATIO = 5.0
#: ... or when the fast displacement per unit slow displacement (A/l for the
#: pendulum) exceeds MAX_AMPLITUDE_RATIO.  At A/l = 0.3 the first-order slow
#: frequency of the pendulum is off by up to ≈ 7 % (next-order term 25 q⁴/128).
MAX_AMPLITUDE_RATIO = 0.3


class AveragingValidityWarning(UserWarning):
    """A scalar averaging prediction lies outside the regime where averaging holds."""


# ======================================================================================
# Harmonic split
# ======================================================================================

def fourier_split(expr, omega, time=t_symbol) -> dict[int, tuple[sp.Expr, sp.Expr]]:
    """Split an expression periodic in ``omega*time`` into its harmonics.

    Parameters
    ----------
    expr : sympy expression
        A finite trigonometric polynomial in ωt (coefficients may depend on
        anything else).
    omega : sympy.Symbol
        The drive's angular frequency.
    time : sympy.Symbol
        The time symbol (default :data:`lagrange_core.t`).

    Returns
    -------
    dict
        ``{k: (c_k, s_k)}`` with expr = c_0 + Σ_k (c_k cos kωt + s_k sin kωt);
        ``s_0`` is 0.  Only non-zero harmonics are listed (k = 0 always is).

    Raises
    ------
    ValueError
        If the time dependence is not a finite sum of integer harmonics of ωt.
    """
    phase = sp.Dummy("phase", real=True)
    e = sp.sympify(expr).xreplace({time: phase / omega})
    if e.has(time):
        raise ValueError(f"{expr} depends on t other than through {omega}*t; averaging needs a "
                         f"drive periodic in {omega}*t.")
    trig = (sp.sin, sp.cos, sp.tan, sp.cot, sp.sec, sp.csc)
    e = e.replace(lambda x: isinstance(x, trig) and x.has(phase), lambda x: x.rewrite(sp.exp))
    e = sp.expand(e, power_exp=True, mul=True, multinomial=True, power_base=False, log=False)
    coeffs: dict[int, sp.Expr] = {}
    for term in sp.Add.make_args(e):
        if term == 0:
            continue
        coef, dep = term.as_independent(phase, as_Add=False)
        exponent = sp.S.Zero
        for factor in sp.Mul.make_args(dep):
            base, power = factor.as_base_exp()
            if factor == 1:
                continue
            if base is not sp.E:
                raise ValueError(
                    f"the time dependence of {expr} is not periodic in {omega}*t (found the factor "
                    f"{factor.xreplace({phase: omega * time})}); averaging needs a drive that is a "
                    "finite sum of harmonics cos(k*omega*t), sin(k*omega*t).")
            exponent += power
        exponent = sp.expand(exponent)
        slope = sp.diff(exponent, phase)
        k = sp.nsimplify(slope / sp.I)
        if slope.has(phase) or not k.is_Integer:
            raise ValueError(
                f"the time dependence of {expr} contains the frequency {slope / sp.I}*{omega}, not a "
                f"whole multiple of {omega}; write the drive in harmonics of the fundamental "
                "frequency and name that one as omega.")
        rest = sp.expand(exponent - slope * phase)
        coeffs[int(k)] = coeffs.get(int(k), sp.S.Zero) + coef * sp.exp(rest)

    def real(x):
        x = sp.expand(x)
        if not x.has(sp.I):
            return x
        # phases such as exp(I*phi): every symbol is a real quantity, so say so to sympy
        to_real = {s: sp.Dummy(s.name, real=True) for s in x.free_symbols if not s.is_real}
        back = {d: s for s, d in to_real.items()}
        x = sp.expand(sp.expand_complex(x.xreplace(to_real)))
        if x.has(sp.I):
            x = sp.simplify(x)
        return x.xreplace(back)

    out = {0: (real(coeffs.get(0, sp.S.Zero)), sp.S.Zero)}
    for k in sorted({abs(k) for k in coeffs if k != 0}):
        cp, cm = coeffs.get(k, sp.S.Zero), coeffs.get(-k, sp.S.Zero)
        c, s = real(cp + cm), real(sp.I * (cp - cm))
        if c != 0 or s != 0:
            out[k] = (c, s)
    return out


# ======================================================================================
# General averaging
# ======================================================================================

@functools.cache
def _generator_fingerprint() -> str:
    """Hash of the code that generates the averaging kernels and of the code they call
    (not of this whole module, so that unrelated edits keep the store)."""
    return module_store.content_key(
        module_store.source_fingerprint(AveragedSystem._generate_source, _Printer, _function,
                                        _linalg),     # the generated code calls solve_dense
        _FIXED_SOURCE, repr(sorted(_ALLOWED)))


def average(system: System, omega: str = "omega") -> "AveragedSystem":
    """Average ``system`` over its fast periodic drive (first order, Landau–Lifshitz §30).

    Parameters
    ----------
    system : lagrange_core.System
        A system whose explicit time dependence is periodic in ``omega * t``
        (a pivot moving as A d cos ωt, a sum of harmonics, an elliptic path …).
    omega : str
        Name of the parameter that is the drive's angular frequency (rad/s).

    Returns
    -------
    AveragedSystem

    Raises
    ------
    ValueError
        If ``omega`` is not a parameter of the system, or an assumption of the
        method fails (see the module docstring).
    """
    if not isinstance(system, System):
        raise TypeError(f"average() needs a lagrange_core.System, got {type(system).__name__}.")
    return _average_cached(system, str(omega))


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
        The drive frequency.
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
                "average(system, omega='...').")
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
                            f"the fast part of the generalized force on {q[i].name} depends on the "
                            f"velocities ({coef} × {kind} {k}ωt); Landau–Lifshitz averaging assumes "
                            "a velocity-independent fast force (no fast Coriolis or friction "
                            "forces).")
                    # velocity terms that cancel (checked above) are dropped
                    coef = coef.xreplace({v: 0 for v in qd})
                    fast.setdefault((k, kind), [sp.S.Zero] * n)[i] = coef
        self.fast_forces = tuple((k, kind, sp.Matrix(vec)) for (k, kind), vec in sorted(fast.items()))
        zero_v = {v: 0 for v in qd}
        self._slow_force_at_rest = sp.Matrix([s.xreplace(zero_v) for s in slow])
        self.damping_matrix = sp.Matrix(n, n, lambda i, j: -sp.diff(slow[i], qd[j]).xreplace(zero_v))
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
        """The compiled module: ``effective(q, p, G, H) -> U_eff`` (fills gradient G and
        Hessian H), ``terms(q, p, M, f, fg, w)``, ``damping(q, p, C)``."""
        key = module_store.content_key(self.system.statement_key(), "omega=" + self.omega.name,
                                       _generator_fingerprint())
        return module_store.load_generated("_lc_avg", key, self._generate_source)

    def _generate_source(self) -> str:
        system = self.system
        n = system.n_dof
        q = [se.sympify(s) for s in system.q]
        pr = _Printer(system)
        K = len(self.fast_forces)

        U = se.sympify(self.slow_potential)
        Ug = [se.diff(U, a) for a in q]
        slow_out = [("U[0]", U)] + [(f"Ug[{a}]", Ug[a]) for a in range(n)]
        slow_out += [(f"Uh[{a}, {b}]", se.diff(Ug[a], q[b])) for a in range(n) for b in range(n)]

        M = [[se.sympify(self.mass_matrix[i, j]) for j in range(n)] for i in range(n)]
        mass_out = [(f"M[{i}, {j}]", M[i][j]) for i in range(n) for j in range(n)]
        for a in range(n):
            for i in range(n):
                for j in range(n):
                    d = se.diff(M[i][j], q[a])
                    if d != 0:
                        mass_out.append((f"Mg[{a}, {i}, {j}]", d))
                        for b in range(n):
                            d2 = se.diff(d, q[b])
                            if d2 != 0:
                                mass_out.append((f"Mh[{a}, {b}, {i}, {j}]", d2))
        w = se.sympify(self.omega)
        fast_out = []
        for k, (harm, _, f) in enumerate(self.fast_forces):
            fast_out.append((f"w[{k}]", 1 / (4 * harm ** 2 * w ** 2)))
            for i in range(n):
                fi = se.sympify(f[i])
                if fi == 0:
                    continue
                fast_out.append((f"f[{k}, {i}]", fi))
                for a in range(n):
                    d = se.diff(fi, q[a])
                    if d != 0:
                        fast_out.append((f"fg[{k}, {i}, {a}]", d))
                        for b in range(n):
                            d2 = se.diff(d, q[b])
                            if d2 != 0:
                                fast_out.append((f"fh[{k}, {i}, {a}, {b}]", d2))
        C = [(f"C[{i}, {j}]", se.sympify(self.damping_matrix[i, j]))
             for i in range(n) for j in range(n) if self.damping_matrix[i, j] != 0]
        Cg = [(f"Cg[{a}, {i}, {j}]", d) for a in range(n) for i in range(n) for j in range(n)
              for d in [se.diff(se.sympify(self.damping_matrix[i, j]), q[a])] if d != 0]

        src = [f"# Generated by kapitza.averaging for {system.name or 'a system'!r}, drive "
               f"frequency {self.omega.name!r}. Do not edit.\n",
               "import numpy as np\nfrom numba import njit\n"
               "from math import (sin, cos, tan, exp, log, sqrt, asin, acos, atan, atan2,\n"
               "                  sinh, cosh, tanh, asinh, acosh, atanh, pi, e as E)\n"
               "from numpy import sign\n"
               "from lagrange_core._linalg import solve_dense\n",
               f"N_DOF = {n}\nN_FAST = {K}\nPARAMETERS = {system.parameters!r}\n"]
        src.append(_function("slow_terms", ["q", "p", "U", "Ug", "Uh"],
                                     pr.body(slow_out, ["q", "p"])))
        src.append(_function("mass_terms", ["q", "p", "M", "Mg", "Mh"],
                                     pr.body(mass_out, ["q", "p"])))
        src.append(_function("fast_terms", ["q", "p", "w", "f", "fg", "fh"],
                                     pr.body(fast_out, ["q", "p"]) if fast_out else []))
        src.append(_function("damping", ["q", "p", "C"],
                                     ["C[:, :] = 0.0"] + (pr.body(C, ["q", "p"]) if C else [])))
        src.append(_function("damping_gradient", ["q", "p", "Cg"],
                             ["Cg[:, :, :] = 0.0"] + (pr.body(Cg, ["q", "p"]) if Cg else [])))
        src.append(_FIXED_SOURCE)
        return "".join(src)

    # -- numeric API -----------------------------------------------------------------------
    def _p(self, params):
        return self.system.parameter_array(params)

    def evaluate(self, q, params):
        """U_eff, its gradient and Hessian at ``q`` (J, J/unit, J/unit²).

        Returns
        -------
        value : float
        gradient : ndarray (n,)
        hessian : ndarray (n, n)
        """
        qa = self.system.coordinate_array(q, "q")
        p = self._p(params)
        self._check_drive(p)
        n = self.system.n_dof
        G, H = np.empty(n), np.empty((n, n))
        value = self.kernels.effective(qa, p, G, H)
        return float(value), G, H

    def _check_drive(self, p):
        w = p[self.system.parameters.index(self.omega.name)]
        if not w > 0:
            raise ValueError(f"the drive frequency {self.omega.name} must be > 0 (rad/s), got {w}.")

    def mean_drag(self, q, params) -> np.ndarray:
        """The mean drag force D(q) of a damped two-phase drive (see :meth:`_drag`), in the
        units of the generalized forces; zeros when there is none.

        The averaged motion is M Q̈ + C Q̇ = −∂U_eff/∂Q + D(Q): the equilibria are the roots
        of ∂U_eff/∂Q − D (:meth:`equilibria`), their stiffness H − ∂D/∂Q (:meth:`slow_modes`).
        """
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
        M, Mg, f, fg, w = _terms(K, q, p, n)
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
        self.kernels.effective(q, p, G, H)
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
        v0 = K.effective(q0, p, G, H)
        K.mass_terms(q0, p, M0, Mg, Mh)
        for j in range(n):
            q1 = q0.copy()
            q1[j] += 2 * math.pi
            v1 = K.effective(q1, p, G, H)
            K.mass_terms(q1, p, M1, Mg, Mh)
            out[j] = abs(v1 - v0) <= 1e-10 * (1 + abs(v0)) and np.allclose(M0, M1, rtol=1e-10)
        return out

    def _wrap(self, qv):
        qv = np.array(qv, float)
        ang = self._angular
        qv[ang] = qv[ang] - 2 * np.pi * np.ceil((qv[ang] - np.pi) / (2 * np.pi) - 1e-12)
        qv[np.abs(qv) < 1e-12] = 0.0
        return qv

    def equilibria(self, params, guesses=None, tol: float = 1e-10) -> np.ndarray:
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
            guesses = np.array(list(itertools.product((0.0, np.pi / 2, np.pi, -np.pi / 2), repeat=n)))
        guesses = np.atleast_2d(np.asarray(guesses, float))
        if guesses.shape[1] != n:
            raise ValueError(f"guesses must have {n} columns (one per coordinate "
                             f"{list(self.system.coordinates)}), got shape {guesses.shape}.")
        def fun(x):
            F, J = self._slow_force(x, p)
            return -F, -J

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

    def slow_modes(self, params, about, warn: bool = True) -> SlowModes:
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
        if np.max(np.abs(F)) > 1e-8 * (1 + np.max(np.abs(H))):
            raise ValueError(f"q={qa.tolist()} is not an equilibrium of the averaged motion "
                             f"(∂U_eff/∂q − D = {(-F).tolist()}); find them with "
                             "equilibria(params).")
        M, _, f, fg, w = _terms(K, qa, p, n)
        C = np.zeros((n, n))
        K.damping(qa, p, C)
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
        reasons = _reasons(freq_ratio, amp)
        modes = SlowModes(about=self._wrap(qa), omega_squared=w2, frequencies=freqs,
                          stable=bool(np.all(w2 > 0) and not (self._drag_pairs
                                                              and np.max(lam.real) >= 0)),
                          eigenvalues=lam,
                          damped_frequencies=damped, decay_rate=float(-np.max(lam.real)) + 0.0,
                          frequency_ratio=freq_ratio, amplitude_ratio=amp,
                          valid=not reasons, reasons=reasons)
        if warn and reasons:
            warnings.warn(f"averaging about {modes.about.tolist()}: " + "; ".join(reasons),
                          AveragingValidityWarning, stacklevel=2)
        return modes

    def sweep(self, params, about, progress=None) -> "SlowModeSweep":
        """Slow modes about ``about`` over arrays of parameter values (no re-derivation).

        Parameters
        ----------
        params : dict
            Parameter values by name; any of them may be arrays, broadcast together.
        about : sequence
            An equilibrium for every point (e.g. the upright chain).
        progress : None, bool or callable
            The points run in chunks of about 0.25 s (:func:`kapitza.floquet.run_in_chunks`):
            a progress line on stderr for sweeps longer than 0.5 s when stderr is a
            terminal (None), always (True), never (False), or ``progress(done, total)``
            after every chunk.

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
        arrays = np.broadcast_arrays(*[np.asarray(params[k], float) for k in names])
        shape = arrays[0].shape
        n = self.system.n_dof
        w2 = np.full(shape + (n,), np.nan)
        stable = np.zeros(shape, bool)
        valid = np.zeros(shape, bool)
        size = int(np.prod(shape))

        def work(start, stop):
            for i in range(start, stop):
                idx = np.unravel_index(i, shape)
                modes = self.slow_modes({k: a[idx] for k, a in zip(names, arrays)}, about,
                                        warn=False)
                w2[idx], stable[idx], valid[idx] = modes.omega_squared, modes.stable, modes.valid

        done, interrupted = run_in_chunks(work, size, progress=progress, label="averaging sweep")
        if interrupted:                       # a chunk cut short: its points count as not done
            w2.reshape(size, n)[done:] = np.nan
            stable.reshape(size)[done:] = False
            valid.reshape(size)[done:] = False
        result = SlowModeSweep(params={k: a for k, a in zip(names, arrays)},
                               about=np.asarray(about, float), omega_squared=w2, stable=stable,
                               valid=valid)
        if interrupted:
            raise ComputationInterrupted(result, (np.arange(size) < done).reshape(shape))
        return result

    def minimum_amplitude(self, params, about, amplitude: str = "A", upper: float = None) -> float:
        """The smallest value of the parameter ``amplitude`` that makes ``about`` stable.

        Bisects (brentq) the smallest Ω² of the averaged linearisation about
        ``about`` in the parameter named ``amplitude`` at the other values in
        ``params``; ``about`` must be an equilibrium for every amplitude (e.g.
        the upright chain).  First-order averaging, so the value has a relative
        error O(ε²) (see the module docstring); for the N-link pendulum on a
        vertical pivot it is √2 g / (ω ω_min) (:func:`multiple_pendulum_upright`).

        Parameters
        ----------
        upper : float, optional
            Upper end of the search (default: doubled from 1e-6 × the other
            lengths until stable, at most 60 times).

        Raises
        ------
        ValueError
            If ``amplitude`` is not a parameter or no stabilising value is found.
        """
        if amplitude not in self.system.parameters:
            raise ValueError(f"{amplitude!r} is not a parameter; the parameters are "
                             f"{list(self.system.parameters)}.")
        base = dict(params)

        def lowest(x):
            base[amplitude] = x
            return float(self.slow_modes(base, about, warn=False).omega_squared[0])

        lo = 0.0
        if lowest(lo) > 0:
            return 0.0
        hi = upper if upper is not None else 1e-6
        for _ in range(60):
            if lowest(hi) > 0:
                break
            if upper is not None:
                hi = None
                break
            lo, hi = hi, 2 * hi
        else:
            hi = None
        if hi is None:
            raise ValueError(f"no value of {amplitude!r} up to the search limit makes "
                             f"{list(np.atleast_1d(about))} stable in first-order averaging.")
        return float(scipy.optimize.brentq(lowest, lo, hi, xtol=1e-14, rtol=1e-12))

    def stability_window(self, omega, about, *, params, amplitude: str = "A",
                         A_max: float | None = None) -> StabilityWindow:
        """The amplitudes that hold the equilibrium ``about``, per drive frequency (order 1).

        The averaging overlay for any system's stability map
        (:func:`kapitza.floquet.stability_map`, drawn by
        :func:`kapitza.plots.stability_map_figure`): per ω, ``A_min`` is the smallest value
        of the parameter ``amplitude`` at which every eigenvalue of the averaged stiffness
        about ``about`` is positive (every slow mode real, Ω² > 0).

        Method.  When the amplitude only scales the fast forces (f = A g(q), a pivot
        moving as A d cos ωt; checked symbolically), the averaged stiffness is exactly
        H(A) = H₀ + A² H₂, so with the margin m(s) = λ_min(L⁻¹(H₀ + s H₂)L⁻ᵀ)
        (M = L Lᵀ, s = A²) the edges are the roots of m.  m is the smallest eigenvalue
        of an affine family of symmetric matrices, hence concave in s, so Newton's
        method (slope vᵀ L⁻¹H₂L⁻ᵀ v from the lowest eigenvector v) started at s = 0
        climbs to the lower root monotonically, for all ω at once (batched eigh).
        m → −∞ only if H₂ has a negative direction; then an upper edge exists (found
        the same way from above), otherwise ``A_max = inf`` (first-order averaging
        does not see the parametric resonance that bounds the exact window).  Other
        amplitude dependences fall back to ``brentq`` on m(A) per ω within
        ``[0, A_max]`` (``A_max`` needed; the upper edge is then not searched, +inf).

        Accuracy: first-order averaging, relative error of the edge O(ω_s²/ω²), ω_s
        the slow scale (ω0 = √(g/l) for the pendulum, where the exact relative error
        of A_min is ≈ (7/16) ω0²/ω²); ``error_estimate`` reports (ω_s/ω)².  The roots
        themselves are solved to rounding (≈ 1e-15 relative): the single pendulum gives
        A_min ω = √(2 g l), the N-link chain √2 g / ω_min (Acheson).

        Parameters
        ----------
        omega : float or array
            Drive angular frequencies (rad/s, > 0), values of this system's drive
            frequency parameter.
        about : sequence
            An equilibrium of the averaged motion for every amplitude (e.g. the upright
            chain [π, π]).
        params : dict
            The other parameters by name (values for ``amplitude`` and the drive
            frequency, if present, are ignored).
        amplitude : str
            Name of the drive amplitude parameter.
        A_max : float, optional
            The largest amplitude considered: where A_min > A_max the window is NaN.

        Returns
        -------
        kapitza.results.StabilityWindow
            ``method="averaging"``, ``order=1``, ``about`` the coordinates as text;
            ``A_min``, ``A_max`` (NaN where no amplitude up to ``A_max`` holds
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
            two-phase drive (its mean drag moves the equilibrium with A), or the fallback
            without ``A_max``.

        Examples
        --------
        >>> import math
        >>> from lagrange_core import problems
        >>> avg = average(problems.driven_pendulum("vertical"))
        >>> win = avg.stability_window([50.0, 100.0], [math.pi],
        ...                            params=dict(m=1.0, l=1.0, g=9.81))
        >>> print(win.A_min * win.omega, math.sqrt(2 * 9.81))     # doctest: +ELLIPSIS
        [4.429... 4.429...] 4.429...
        """
        names = self.system.parameters
        if not isinstance(amplitude, str) or amplitude not in names:
            raise ValueError(f"amplitude={amplitude!r} is not a parameter; the parameters are "
                             f"{list(names)}.")
        if amplitude == self.omega.name:
            raise ValueError(f"amplitude={amplitude!r} is the drive frequency; name the drive "
                             "amplitude parameter.")
        if self._drag_pairs:
            raise ValueError("stability_window: this damped drive has two phases, whose mean "
                             "drag moves the equilibrium with the amplitude; use slow_modes or "
                             "sweep at each amplitude instead.")
        w_in = np.asarray(omega, float)
        ws = np.atleast_1d(w_in).ravel()
        if not np.all(np.isfinite(ws) & (ws > 0)):
            raise ValueError(f"the drive frequencies omega must be finite and > 0 (rad/s), got "
                             f"{w_in}.")
        if A_max is not None and not (np.ndim(A_max) == 0 and float(A_max) > 0):
            raise ValueError(f"A_max must be a positive number (the largest amplitude "
                             f"considered), got {A_max!r}.")
        limit = math.inf if A_max is None else float(A_max)
        n = self.system.n_dof
        qa = self.system.coordinate_array(about, "about")
        base = {k: v for k, v in dict(params).items() if k not in (amplitude, self.omega.name)}
        base[amplitude], base[self.omega.name] = 0.0, 1.0
        p = self._p(base)
        ia, iw = names.index(amplitude), names.index(self.omega.name)
        K = self.kernels
        k_w = len(ws)

        def stiffness(a, w):
            p[ia], p[iw] = a, w
            G, H = np.empty(n), np.empty((n, n))
            K.effective(qa, p, G, H)
            if np.max(np.abs(G)) > 1e-8 * (1 + np.max(np.abs(H))):
                raise ValueError(
                    f"q={qa.tolist()} is not an equilibrium of the averaged motion at "
                    f"{amplitude}={a:g}, {self.omega.name}={w:g} (∂U_eff/∂q = {G.tolist()}); "
                    "stability_window needs an equilibrium for every amplitude.")
            return (H + H.T) / 2

        # M = L Lᵀ and C at A = 0 (M, C do not depend on the drive when the structure holds)
        Ls = np.empty((k_w, n, n))
        Cs = np.zeros((k_w, n, n))
        S0 = np.empty((k_w, n, n))
        for j, w in enumerate(ws):
            H0 = stiffness(0.0, w)
            M = _terms(K, qa, p, n)[0]
            Ls[j] = np.linalg.inv(np.linalg.cholesky(M))
            K.damping(qa, p, Cs[j])
            S0[j] = Ls[j] @ H0 @ Ls[j].T
        slow0 = np.max(np.abs(np.linalg.eigvalsh(S0)), axis=-1)
        rates = np.max(np.abs(np.linalg.eigvals(Ls @ Cs @ np.swapaxes(Ls, 1, 2))), axis=-1)

        if self._amplitude_scales_fast_forces(amplitude):
            # H₂ from one evaluation at a reference amplitude where A² H₂ is as large as H₀
            # (so that H(A_ref) − H₀ loses no digits)
            S2 = np.empty_like(S0)
            for j, w in enumerate(ws):
                a_ref = 1.0
                for _ in range(2):
                    S1 = Ls[j] @ stiffness(a_ref, w) @ Ls[j].T
                    S2[j] = (S1 - S0[j]) / a_ref**2
                    big = np.max(np.abs(S2[j]))
                    if big == 0:
                        break
                    a_ref = math.sqrt(max(np.max(np.abs(S0[j])), 1e-300) / big)
            s_lo, s_hi = _concave_roots(S0, S2, limit**2)
            A_lo, A_hi = np.sqrt(s_lo), np.sqrt(s_hi)
            amp_at = None
        else:
            if A_max is None:
                raise ValueError(f"stability_window: {amplitude!r} does not only scale the fast "
                                 "forces, so the window is searched by root-finding in [0, A_max]; "
                                 "pass A_max=... (the largest amplitude to consider).")
            A_lo, A_hi = np.full(k_w, np.nan), np.full(k_w, np.nan)
            for j, w in enumerate(ws):
                def margin(a, w=w):
                    S = Ls[j] @ stiffness(a, w) @ Ls[j].T
                    return float(np.linalg.eigvalsh(S)[0])
                if margin(0.0) >= 0:
                    A_lo[j] = 0.0
                elif margin(limit) > 0:
                    A_lo[j] = scipy.optimize.brentq(margin, 0.0, limit, xtol=1e-15 * limit,
                                                    rtol=4 * np.finfo(float).eps)
                A_hi[j] = math.inf if np.isfinite(A_lo[j]) else math.nan
            S2 = None
        exists = np.isfinite(A_lo)
        # validity: the slow scale (A = 0 and at the lower edge) and the fast displacement
        slow_edge = np.zeros(k_w)
        amp = np.full(k_w, np.nan)
        for j, w in enumerate(ws):
            if not exists[j]:
                continue
            if S2 is not None:
                S_edge = S0[j] + A_lo[j] ** 2 * S2[j]
            else:
                S_edge = Ls[j] @ stiffness(A_lo[j], w) @ Ls[j].T
            slow_edge[j] = np.max(np.abs(np.linalg.eigvalsh(S_edge)))
            p[ia], p[iw] = A_lo[j], w
            M, _, f, fg, wk = _terms(K, qa, p, n)
            amp[j] = max([float(np.linalg.norm(np.linalg.solve(M, fg[k]) * 4 * wk[k], 2))
                          for k in range(len(wk))] + [0.0])
        rate = np.maximum(np.sqrt(np.maximum(slow0, slow_edge)), rates)
        with np.errstate(divide="ignore"):
            ratio = np.where(rate > 0, ws / np.where(rate > 0, rate, 1.0), np.inf)
        error = 1.0 / ratio**2
        fast = ratio >= MIN_FREQUENCY_RATIO
        small = exists & (amp <= MAX_AMPLITUDE_RATIO)
        valid = exists & fast & small
        shape = w_in.shape

        def out(x):
            x = np.asarray(x).reshape(shape)
            return x[()] if x.ndim == 0 else x

        return StabilityWindow(
            omega=out(ws), A_min=out(A_lo), A_max=out(A_hi), method="averaging",
            about=str(self._wrap(qa).tolist()), order=1, exists=out(exists),
            frequency_ratio=out(ratio), error_estimate=out(error), fast_drive=out(fast),
            small_amplitude=out(small), valid=out(valid))

    def _amplitude_scales_fast_forces(self, amplitude: str) -> bool:
        """True when the parameter ``amplitude`` enters only the fast forces, linearly and
        homogeneously (f = A g(q)): then the averaged stiffness is H₀ + A² H₂ exactly."""
        cache = self.__dict__.setdefault("_scales_cache", {})
        if amplitude not in cache:
            a = next(s for s in self.system.parameter_symbols if s.name == amplitude)
            elsewhere = any(a in expr.free_symbols for expr in (
                self.mass_matrix, self.slow_potential, self.damping_matrix))
            linear = all(
                all(sp.simplify(e.xreplace({a: 0})) == 0 and sp.simplify(sp.diff(e, a, 2)) == 0
                    for e in f)
                for _, _, f in self.fast_forces)
            cache[amplitude] = bool(not elsewhere and linear and self.fast_forces)
        return cache[amplitude]

    def predict(self, params, guesses=None, warn: bool = True) -> AveragingPrediction:
        """All equilibria (see :meth:`equilibria`) with their slow modes."""
        eqs = self.equilibria(params, guesses)
        return AveragingPrediction(params=dict(params),
                                   equilibria=tuple(self.slow_modes(params, e, warn=warn)
                                                    for e in eqs))

    def __repr__(self):
        return (f"<AveragedSystem of {self.system._label()}: drive {self.omega.name}, "
                f"{len(self.fast_forces)} fast force vector(s)>")


def _concave_roots(S0, S2, s_limit):
    """Edges (s_lo, s_hi) of {s ≥ 0: λ_min(S0 + s S2) > 0} for a stack of symmetric pencils.

    m(s) = λ_min(S0 + s S2) is concave (the minimum of the linear functions vᵀ(S0 + s S2)v),
    so Newton's method with the slope vᵀ S2 v of the lowest eigenvector converges to the
    lower root monotonically from s = 0 and to the upper root monotonically from any s
    beyond it.  NaN where there is no root in [0, s_limit]; s_hi = inf where S2 ≥ 0 (m
    never falls again).
    """
    k = len(S0)
    eps = np.finfo(float).eps

    def margin(idx, s):
        lam, V = np.linalg.eigh(S0[idx] + s[:, None, None] * S2[idx])
        v = V[..., 0]
        return lam[:, 0], np.einsum("ki,kij,kj->k", v, S2[idx], v)

    def newton(idx, s, direction):
        """Newton from s (m(s) ≤ 0 on the side ``direction`` of the root) for the points idx."""
        root = np.full(len(idx), np.nan)
        active = np.arange(len(idx))
        for _ in range(200):
            if not len(active):
                break
            m, d = margin(idx[active], s[active])
            ok = (d * direction > 0) & np.isfinite(m)
            step = np.where(ok, -m / np.where(ok, d, 1.0), 0.0)
            new = s[active] + step
            # converged: the step is at rounding level, or m has crossed (a rounding-level
            # overshoot; the exact iteration never crosses the root of a concave m)
            done = ok & ((step * direction <= 0) | (np.abs(step) <= 16 * eps * np.abs(new)))
            new = np.where(done & (step * direction <= 0), s[active], new)
            root[active[done]] = new[done]
            alive = ok & ~done & (new >= 0) & (new <= max(s_limit, 0) * 1e6 + 1e-300
                                                if np.isfinite(s_limit) else new < 1e300)
            s[active] = np.where(ok, new, s[active])
            active = active[alive]
        return root

    idx = np.arange(k)
    m0, _ = margin(idx, np.zeros(k))
    s_lo = np.where(m0 >= 0, 0.0, np.nan)
    climb = idx[m0 < 0]
    if len(climb):
        s_lo[climb] = newton(climb, np.zeros(len(climb)), +1)
    s_lo[s_lo > s_limit] = np.nan
    s_hi = np.where(np.isfinite(s_lo), np.inf, np.nan)
    # an upper edge only where S2 has a negative direction (m → −∞)
    scale = np.max(np.abs(S2), axis=(1, 2))
    falls = idx[np.isfinite(s_lo) & (np.linalg.eigvalsh(S2)[:, 0] < -1e-12 * scale)]
    if len(falls):
        s = np.maximum(2 * s_lo[falls], 1e-300)
        for _ in range(2100):                       # double until beyond the upper root
            m, _ = margin(falls, s)
            if np.all(m < 0):
                break
            s = np.where(m < 0, s, 2 * s)
        s_hi[falls] = newton(falls, s, -1)
    return s_lo, s_hi


def _terms(K, q, p, n):
    M = np.empty((n, n))
    Mg, Mh = np.zeros((n, n, n)), np.zeros((n, n, n, n))
    K.mass_terms(q, p, M, Mg, Mh)
    nf = K.N_FAST
    w = np.zeros(nf)
    f, fg, fh = np.zeros((nf, n)), np.zeros((nf, n, n)), np.zeros((nf, n, n, n))
    K.fast_terms(q, p, w, f, fg, fh)
    return M, Mg, f, fg, w


def _reasons(freq_ratio, amp) -> tuple:
    out = []
    if not freq_ratio >= MIN_FREQUENCY_RATIO:
        out.append(f"the drive is only {freq_ratio:.3g} times faster than the slow motion "
                   f"(averaging needs ≥ {MIN_FREQUENCY_RATIO:g})")
    if not amp <= MAX_AMPLITUDE_RATIO:
        out.append(f"the fast motion is large: amplitude ratio {amp:.3g} > {MAX_AMPLITUDE_RATIO:g}")
    return tuple(out)



# -- code generation helpers (kept here so that the averaging kernels depend only on the
#    public contract of lagrange_core: System, its symbols and the module store) ------------

_ALLOWED = {"sin", "cos", "tan", "exp", "log", "sqrt", "asin", "acos", "atan", "atan2", "sinh",
            "cosh", "tanh", "asinh", "acosh", "atanh", "pi", "E", "sign"}


class _Printer:
    """Renames q and parameters to kernel locals, removes common subexpressions, prints."""

    def __init__(self, system):
        self.subs, self.loads = {}, {}
        for array, prefix, symbols in (("q", "_q", system.q), ("p", "_p", system.parameter_symbols)):
            self.loads[array] = []
            for i, s in enumerate(symbols):
                self.subs[se.sympify(s)] = se.Symbol(f"{prefix}{i}")
                self.loads[array].append(f"{prefix}{i} = {array}[{i}]")

    @staticmethod
    def code(expr) -> str:
        text = str(expr)
        for name in set(re.findall(r"(?<![\w.])([A-Za-z_]\w*)", text)):
            if not (name.startswith("_") or re.fullmatch(r"x\d+", name) or name in _ALLOWED):
                raise ValueError(f"cannot compile {name!r} in {text[:200]}; the averaging kernels "
                                 f"support {sorted(_ALLOWED)}.")
        return text

    def body(self, outputs, arrays):
        exprs = [se.sympify(e).subs(self.subs) for _, e in outputs]
        replacements, reduced = se.cse(exprs) if exprs else ([], [])
        lines = [line for a in arrays for line in self.loads[a]]
        lines += [f"{s} = {self.code(e)}" for s, e in replacements]
        lines += [f"{target} = {self.code(e)}" for (target, _), e in zip(outputs, reduced)]
        return lines


def _function(name, args, lines):
    return "\n\n@njit(cache=True)\ndef {}({}):\n{}\n".format(
        name, ", ".join(args), textwrap.indent("\n".join(lines or ["pass"]), "    "))


# The fixed part of the generated module: U_eff, gradient and Hessian from the terms.
# With x = M⁻¹f and y_a = ∂f/∂q_a − (∂M/∂q_a) x:
#   ∂(fᵀM⁻¹f)/∂q_a = 2 f_aᵀx − xᵀM_a x,
#   ∂²(fᵀM⁻¹f)/∂q_a∂q_b = 2 f_abᵀx + 2 y_aᵀ M⁻¹ y_b − xᵀ M_ab x.
_FIXED_SOURCE = '''

@njit(cache=True)
def _solve(M, B):
    # X = M⁻¹ B (a few unknowns): Gaussian elimination on the augmented copy [M | B]
    n = M.shape[0]
    W = np.empty((n, n + B.shape[1]))
    for i in range(n):
        for j in range(n):
            W[i, j] = M[i, j]
        for j in range(B.shape[1]):
            W[i, n + j] = B[i, j]
    solve_dense(W, n)
    return W[:, n:].copy()


@njit(cache=True)
def effective(q, p, G, H):
    n = N_DOF
    U = np.empty(1)
    Ug = np.empty(n)
    Uh = np.empty((n, n))
    slow_terms(q, p, U, Ug, Uh)
    M = np.empty((n, n))
    Mg = np.zeros((n, n, n))
    Mh = np.zeros((n, n, n, n))
    mass_terms(q, p, M, Mg, Mh)
    w = np.zeros(N_FAST)
    f = np.zeros((N_FAST, n))
    fg = np.zeros((N_FAST, n, n))
    fh = np.zeros((N_FAST, n, n, n))
    fast_terms(q, p, w, f, fg, fh)
    value = U[0]
    for a in range(n):
        G[a] = Ug[a]
        for b in range(n):
            H[a, b] = Uh[a, b]
    for k in range(N_FAST):
        x = _solve(M, f[k].reshape(n, 1))[:, 0]
        fx = 0.0
        for i in range(n):
            fx += f[k, i] * x[i]
        value += w[k] * fx
        Y = np.empty((n, n))
        for a in range(n):
            # y_a = f_a − M_a x;  gradient term 2 f_a·x − x·M_a x
            g = 0.0
            for i in range(n):
                Mx = 0.0
                for j in range(n):
                    Mx += Mg[a, i, j] * x[j]
                g += 2.0 * fg[k, i, a] * x[i] - x[i] * Mx
                Y[i, a] = fg[k, i, a] - Mx
            G[a] += w[k] * g
        Z = _solve(M, Y)
        for a in range(n):
            for b in range(n):
                s = 0.0
                for i in range(n):
                    s += 2.0 * fh[k, i, a, b] * x[i] + 2.0 * Y[i, a] * Z[i, b]
                    for j in range(n):
                        s -= x[i] * Mh[a, b, i, j] * x[j]
                H[a, b] += w[k] * s
    return value
'''
