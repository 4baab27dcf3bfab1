"""Averaging over a fast periodic drive: the Kapitza effective potential of any system.

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
for the pendulum ε² ~ ω0²/ω² ~ A²/l².  Damping −C q̇ enters the slow equation
unchanged, M Q̈ + C Q̇ + ∂U_eff/∂Q = 0; the damping's effect on the fast
response is of relative order (γ/ω)².  The next order is available for the
vertically driven single pendulum through the Mathieu equation
(:func:`exponent_squared`, :func:`mathieu_a0`, :func:`mathieu_b1`).

Validity is reported, not hidden: every prediction carries the ratio of the
drive frequency to the slow frequencies and the size of the fast motion, and a
``valid`` flag from the thresholds :data:`MIN_FREQUENCY_RATIO` and
:data:`MAX_AMPLITUDE_RATIO` (for the vertically driven pendulum also
:data:`MAX_CORRECTION`, the size of the next-order correction, which catches the
neighbourhood of the stability limits); scalar calls outside the regime emit an
:class:`AveragingValidityWarning`, array calls only set the flags so that a sweep
can mask those points.
"""
from __future__ import annotations

import functools
import hashlib
import inspect
import itertools
import math
import re
import textwrap
import warnings
from dataclasses import dataclass

import numpy as np
import pandas as pd
import scipy.linalg
import scipy.optimize
import sympy as sp
import symengine as se

from lagrange_core import codegen
from lagrange_core.systems import System, t as t_symbol

from .results import StabilityWindow

__all__ = [
    "MIN_FREQUENCY_RATIO", "MAX_AMPLITUDE_RATIO", "MAX_CORRECTION", "AveragingValidityWarning",
    "fourier_split", "average", "AveragedSystem", "SlowModes", "SlowModeSweep",
    "AveragingPrediction",
    "pendulum_effective_potential", "pendulum_averaged", "PendulumAveraging",
    "EquilibriumPrediction", "stability_window",
    "exponent_squared", "mathieu_a0", "mathieu_b1",
    "multiple_pendulum_upright", "MultiplePendulumPrediction",
]

#: A prediction is flagged invalid when ω < MIN_FREQUENCY_RATIO × (largest slow
#: frequency or growth rate, and ω0 for the pendulum).  At ratio 5 the
#: first-order slow frequency of the pendulum is off by ≲ 3 % (next-order term).
MIN_FREQUENCY_RATIO = 5.0
#: ... or when the fast displacement per unit slow displacement (A/l for the
#: pendulum) exceeds MAX_AMPLITUDE_RATIO.  At A/l = 0.3 the first-order slow
#: frequency of the pendulum is off by up to ≈ 7 % (next-order term 25 q⁴/128).
MAX_AMPLITUDE_RATIO = 0.3
#: ... or (vertically driven pendulum) when the next-order correction changes the slow
#: frequency or growth rate by more than this fraction, or flips the stability: near the
#: Kapitza limit Ω → 0 and any fixed-order result loses its relative accuracy.  Measured
#: against exact Floquet values over 532 random valid points (A/l ≤ 0.3, 10 ≤ ω ≤ 300
#: rad/s, l = 1 m): first order within 7.4 %, second order within 1.6 %.
MAX_CORRECTION = 0.1


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
def _source_hash() -> str:
    """Hash of the code that generates the averaging kernels (not of the whole module, so
    that unrelated edits keep the disk cache)."""
    from lagrange_core import _linalg
    parts = [inspect.getsource(AveragedSystem._generate_source), inspect.getsource(_Printer),
             inspect.getsource(_function), _FIXED_SOURCE, repr(sorted(_ALLOWED)),
             codegen.source_fingerprint(_linalg)]     # the generated code calls solve_dense
    return hashlib.sha256("".join(parts).encode()).hexdigest()


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


@dataclass(frozen=True)
class SlowModes:
    """Small slow oscillations about one equilibrium of the averaged motion.

    The averaged linearisation is M δQ̈ + C δQ̇ + H δQ = 0 with H the Hessian of
    U_eff, M the (time-independent) mass matrix, C the averaged damping matrix.

    Attributes
    ----------
    about : ndarray (n,)
        The equilibrium (coordinates in SI units; angles wrapped into (−π, π]).
    omega_squared : ndarray (n,)
        Generalized eigenvalues Ω² of (H, M), ascending (rad²/s²); negative is unstable.
    frequencies : ndarray (n,)
        √Ω² (rad/s); NaN for an unstable mode.
    stable : bool
        All Ω² > 0 (linear stability of the averaged motion; with damping the
        equilibrium is then asymptotically stable).
    eigenvalues : ndarray (2n,), complex
        Roots λ of det(λ² M + λ C + H) = 0 (1/s), sorted by imaginary part
        (the damped slow dynamics; ±iΩ without damping).
    damped_frequencies : ndarray (n,)
        The non-negative imaginary parts of ``eigenvalues`` (rad/s), one per mode.
    decay_rate : float
        −max Re λ (1/s): the slowest decay rate (negative: growth).
    frequency_ratio : float
        ω / max(√|Ω²|): how much faster the drive is than the slow motion.
    amplitude_ratio : float
        Largest singular value of ∂ξ/∂q, the fast displacement amplitude per
        unit slow displacement (A/l for the pendulum).
    valid : bool
        ``frequency_ratio ≥ MIN_FREQUENCY_RATIO`` and ``amplitude_ratio ≤ MAX_AMPLITUDE_RATIO``.
    reasons : tuple of str
        Why a prediction is not valid (empty if it is).
    """

    about: np.ndarray
    omega_squared: np.ndarray
    frequencies: np.ndarray
    stable: bool
    eigenvalues: np.ndarray
    damped_frequencies: np.ndarray
    decay_rate: float
    frequency_ratio: float
    amplitude_ratio: float
    valid: bool
    reasons: tuple = ()

    def to_dataframe(self) -> pd.DataFrame:
        """One row per mode."""
        n = len(self.omega_squared)
        return pd.DataFrame({
            "about": [tuple(self.about.tolist())] * n, "mode": np.arange(n),
            "omega_squared": self.omega_squared, "frequency": self.frequencies,
            "damped_frequency": self.damped_frequencies, "stable": [self.stable] * n,
            "decay_rate": [self.decay_rate] * n, "frequency_ratio": [self.frequency_ratio] * n,
            "amplitude_ratio": [self.amplitude_ratio] * n, "valid": [self.valid] * n,
            "reasons": ["; ".join(self.reasons)] * n})


@dataclass(frozen=True)
class AveragingPrediction:
    """Equilibria of the averaged motion with their slow modes.

    Attributes
    ----------
    params : dict
        The parameter values used.
    equilibria : tuple of SlowModes
        One entry per distinct equilibrium found.
    """

    params: dict
    equilibria: tuple

    @property
    def stable(self) -> tuple:
        """The stable equilibria (SlowModes)."""
        return tuple(e for e in self.equilibria if e.stable)

    def to_dataframe(self) -> pd.DataFrame:
        frames = [e.to_dataframe().assign(equilibrium=i) for i, e in enumerate(self.equilibria)]
        return pd.concat(frames, ignore_index=True) if frames else pd.DataFrame()


@dataclass(frozen=True)
class SlowModeSweep:
    """Slow modes about one equilibrium over a grid of parameter values.

    Attributes
    ----------
    params : dict of ndarray
        The broadcast parameter arrays.
    about : ndarray (n,)
    omega_squared : ndarray (..., n)
        Ω² of the averaged linearisation, ascending per point (rad²/s²).
    stable, valid : bool ndarray (...)
        See :class:`SlowModes`.
    """

    params: dict
    about: np.ndarray
    omega_squared: np.ndarray
    stable: np.ndarray
    valid: np.ndarray

    def to_dataframe(self) -> pd.DataFrame:
        cols = {k: np.ravel(v) for k, v in self.params.items()}
        for j in range(self.omega_squared.shape[-1]):
            cols[f"omega_squared_{j}"] = self.omega_squared[..., j].ravel()
        cols["stable"] = self.stable.ravel()
        cols["valid"] = self.valid.ravel()
        return pd.DataFrame(cols)


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
        system = self.system
        key = hashlib.sha256((system.statement_key() + "|omega=" + self.omega.name + "|"
                              + _source_hash()).encode())
        name = f"_lc_avg_{key.hexdigest()[:20]}"
        path = codegen.cache_dir() / f"{name}.py"
        if not path.exists():
            codegen.write_module(path, self._generate_source())
        return codegen.load_module(path, name)

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
        """Equilibria of the averaged motion: roots of ∂U_eff/∂q.

        Parameters
        ----------
        params : dict
            Parameter values by name.
        guesses : array (k, n), optional
            Starting points.  By default every combination of
            {0, π/2, π, −π/2} for angular coordinates (needs all coordinates to
            be angles and n ≤ 5).
        tol : float
            Accept a root when |∂U_eff/∂q| ≤ tol × (1 + max |Hessian|).

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
        K = self.kernels
        G, H = np.empty(n), np.empty((n, n))

        def fun(x):
            K.effective(x, p, G, H)
            return G.copy(), H.copy()

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

        Raises
        ------
        ValueError
            If ``about`` is not an equilibrium of U_eff.
        """
        n = self.system.n_dof
        qa = self.system.coordinate_array(about, "about")
        p = self._p(params)
        self._check_drive(p)
        K = self.kernels
        G, H = np.empty(n), np.empty((n, n))
        K.effective(qa, p, G, H)
        if np.max(np.abs(G)) > 1e-8 * (1 + np.max(np.abs(H))):
            raise ValueError(f"q={qa.tolist()} is not an equilibrium of the averaged motion "
                             f"(∂U_eff/∂q = {G.tolist()}); find them with equilibria(params).")
        M, f, fg, w = _terms(K, qa, p, n)
        C = np.zeros((n, n))
        K.damping(qa, p, C)
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
                          stable=bool(np.all(w2 > 0)), eigenvalues=lam,
                          damped_frequencies=damped, decay_rate=float(-np.max(lam.real)) + 0.0,
                          frequency_ratio=freq_ratio, amplitude_ratio=amp,
                          valid=not reasons, reasons=reasons)
        if warn and reasons:
            warnings.warn(f"averaging about {modes.about.tolist()}: " + "; ".join(reasons),
                          AveragingValidityWarning, stacklevel=2)
        return modes

    def sweep(self, params, about) -> "SlowModeSweep":
        """Slow modes about ``about`` over arrays of parameter values (no re-derivation).

        Parameters
        ----------
        params : dict
            Parameter values by name; any of them may be arrays, broadcast together.
        about : sequence
            An equilibrium for every point (e.g. the upright chain).

        Returns
        -------
        SlowModeSweep
            ``omega_squared`` of shape (..., n) and per-point ``stable``, ``valid``.
        """
        names = list(params)
        arrays = np.broadcast_arrays(*[np.asarray(params[k], float) for k in names])
        shape = arrays[0].shape
        n = self.system.n_dof
        w2 = np.empty(shape + (n,))
        stable = np.empty(shape, bool)
        valid = np.empty(shape, bool)
        for idx in np.ndindex(shape):
            modes = self.slow_modes({k: a[idx] for k, a in zip(names, arrays)}, about, warn=False)
            w2[idx], stable[idx], valid[idx] = modes.omega_squared, modes.stable, modes.valid
        return SlowModeSweep(params={k: a for k, a in zip(names, arrays)}, about=np.asarray(about, float),
                             omega_squared=w2, stable=stable, valid=valid)

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

    def predict(self, params, guesses=None, warn: bool = True) -> AveragingPrediction:
        """All equilibria (see :meth:`equilibria`) with their slow modes."""
        eqs = self.equilibria(params, guesses)
        return AveragingPrediction(params=dict(params),
                                   equilibria=tuple(self.slow_modes(params, e, warn=warn)
                                                    for e in eqs))

    def __repr__(self):
        return (f"<AveragedSystem of {self.system._label()}: drive {self.omega.name}, "
                f"{len(self.fast_forces)} fast force vector(s)>")


def _terms(K, q, p, n):
    M = np.empty((n, n))
    Mg, Mh = np.zeros((n, n, n)), np.zeros((n, n, n, n))
    K.mass_terms(q, p, M, Mg, Mh)
    nf = K.N_FAST
    w = np.zeros(nf)
    f, fg, fh = np.zeros((nf, n)), np.zeros((nf, n, n)), np.zeros((nf, n, n, n))
    K.fast_terms(q, p, w, f, fg, fh)
    return M, f, fg, w


def _reasons(freq_ratio, amp) -> tuple:
    out = []
    if not freq_ratio >= MIN_FREQUENCY_RATIO:
        out.append(f"the drive is only {freq_ratio:.3g} times faster than the slow motion "
                   f"(averaging needs ≥ {MIN_FREQUENCY_RATIO:g})")
    if not amp <= MAX_AMPLITUDE_RATIO:
        out.append(f"the fast motion is large: amplitude ratio {amp:.3g} > {MAX_AMPLITUDE_RATIO:g}")
    return tuple(out)



# -- code generation helpers (kept here so that the averaging kernels depend only on the
#    public contract of lagrange_core: System, its symbols and codegen.cache_dir) -----------

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


# ======================================================================================
# The next order for the vertically driven pendulum: Mathieu-equation series
# ======================================================================================
#
# About θ = 0 (hanging, +) and θ = π (upright, −) the vertically driven pendulum is the
# Mathieu equation y″ + (a − 2q cos 2τ) y = 0 with τ = ωt/2, a = ±4ω0²/ω², q = 2A/l
# (shared/PHYSICS.md).  Its solutions are e^{iντ} × (π-periodic), and the slow angular
# frequency of the pendulum is Ω = ν ω / 2.  Damping γ adds c y′ with c = 2γ/ω; the
# substitution y = e^{−cτ/2} z turns it *exactly* into the undamped equation with
# a′ = a − c²/4 = a − γ²/ω², the multipliers being scaled by e^{−γT/2}.


def exponent_squared(a, q, order: int = 2):
    """Characteristic exponent squared ν²(a, q) of the Mathieu equation, small a and q.

    Inverting DLMF 28.15.1 (a = ν² + q²/(2(ν² − 1)) + (5ν² + 7) q⁴/(32 (ν² − 1)³ (ν² − 4)) + …)
    in the Kapitza scaling a ~ q² ~ ε²:

    * ``order=1`` (first-order averaging): ν² = a + q²/2, error O(ε⁴);
    * ``order=2``: ν² = a + q²/2 + a q²/2 + 25 q⁴/128, error O(ε⁶).

    Both are exact at q = 0 (ν² = a), and order 2 vanishes on the series of
    a₀(q) = −q²/2 + 7q⁴/128 + O(q⁶) (the Kapitza limit).  The relative error
    of Ω = νω/2 is O(ε²) (order 1) and O(ε⁴) (order 2) away from ν = 0.

    Parameters
    ----------
    a, q : array_like
    order : {1, 2}

    Returns
    -------
    ndarray
        ν²; negative means the solutions grow as e^{√(−ν²) τ}.
    """
    a, q = np.asarray(a, float), np.asarray(q, float)
    q2 = q * q
    if order == 1:
        return a + q2 / 2
    if order == 2:
        return a + q2 / 2 + a * q2 / 2 + 25.0 * q2 * q2 / 128
    raise ValueError(f"order must be 1 or 2, got {order!r}.")


def mathieu_a0(q):
    """a₀(q) from its power series (A&S 20.2.25), through q⁸.

    Absolute error ≈ 1e-10 at q = 0.2, 1e-6 at q = 0.5 (vs scipy.special.mathieu_a).
    """
    q = np.asarray(q, float)
    return -q**2 / 2 + 7 * q**4 / 128 - 29 * q**6 / 2304 + 68687 * q**8 / 18874368


def mathieu_b1(q):
    """b₁(q) from its power series (A&S 20.2.25), through q⁸.

    Absolute error < 1e-12 at q = 0.2, ≈ 3e-7 at q = 0.9 (vs scipy.special.mathieu_b);
    b₁ = 0 at q = 0.90805 (the upright pendulum's upper limit A/l = 0.4540 for ω → ∞).
    """
    q = np.asarray(q, float)
    return (1 - q - q**2 / 8 + q**3 / 64 - q**4 / 1536 - 11 * q**5 / 36864 + 49 * q**6 / 589824
            - 55 * q**7 / 9437184 - 83 * q**8 / 35389440)


def _b1_root(target):
    """q with b₁(q) = target (b₁ decreases on [0, 2.5]); vectorised bisection."""
    target = np.asarray(target, float)
    lo, hi = np.zeros_like(target), np.full_like(target, 2.5)
    for _ in range(60):
        mid = (lo + hi) / 2
        above = mathieu_b1(mid) > target
        lo, hi = np.where(above, mid, lo), np.where(above, hi, mid)
    return (lo + hi) / 2


# ======================================================================================
# The single pendulum: closed forms, vectorised over A and ω
# ======================================================================================

def _as_drive(A, omega):
    try:
        A, omega = np.broadcast_arrays(np.asarray(A, float), np.asarray(omega, float))
    except (TypeError, ValueError):
        raise ValueError(f"A and omega must be numbers or arrays of numbers that broadcast "
                         f"together, got A={A!r}, omega={omega!r}.") from None
    if not (np.all(np.isfinite(A)) and np.all(A >= 0)):
        raise ValueError("the drive amplitude A must be finite and ≥ 0 (m).")
    if not (np.all(np.isfinite(omega)) and np.all(omega > 0)):
        raise ValueError("the drive frequency omega must be finite and > 0 (rad/s).")
    return A, omega


def pendulum_effective_potential(theta, A, omega, *, l=1.0, g=9.81, drive="vertical"):
    """U_eff(θ)/m (J/kg) of the driven pendulum, first-order averaging.

    vertical:   U_eff/m = −g l cos θ + A² ω² sin² θ / 4
    horizontal: U_eff/m = −g l cos θ + A² ω² cos² θ / 4

    Relative error O(ε²), ε² ~ ω0²/ω² ~ A²/l² (see :func:`exponent_squared`).
    Broadcasts over θ (rad), A (m) and ω (rad/s).
    """
    if drive not in ("vertical", "horizontal"):
        raise ValueError(f"drive must be 'vertical' or 'horizontal', got {drive!r}.")
    A, omega = _as_drive(A, omega)
    theta = np.asarray(theta, float)
    shake = np.sin(theta) if drive == "vertical" else np.cos(theta)
    return -g * l * np.cos(theta) + (A * omega * shake) ** 2 / 4


def _item(x):
    x = np.asarray(x)
    return x.item() if x.ndim == 0 else x


@dataclass(frozen=True)
class EquilibriumPrediction:
    """The averaged prediction for one equilibrium of the driven pendulum.

    Array fields have the broadcast shape of (A, ω) (Python scalars for scalar input).

    Attributes
    ----------
    name : str
        "hanging", "inverted", "tilted+" or "tilted-".  The tilted pair is, for the
        vertical drive, the unstable maxima of U_eff at cos θ = −2 g l/(A² ω²)
        (present when the upright is stable; first order at any ``order``); for
        the horizontal drive, the stable tilted minima at cos θ* = 2 g l/(A² ω²).
    theta : array
        Angle from the downward vertical (rad); NaN where it does not exist.
    exists : bool array
    stable : bool array
        Linear stability of the averaged motion (order 2 also checks the
        parametric-resonance limit a′ < b₁(q)).
    omega_squared : array
        Ω² of the undamped averaged motion (rad²/s²); negative: unstable.
    omega_slow : array
        Ω = √Ω² (rad/s), NaN where Ω² < 0.
    damped_frequency : array
        √(Ω² − γ²/4) at order 1, (ω/2) ν(a − γ²/ω², q) at order 2 (rad/s);
        0 when overdamped, NaN when unstable.
    decay_rate : array
        The slowest decay rate of small oscillations (1/s): γ/2 when
        underdamped, γ/2 − √(γ²/4 − Ω²) when overdamped; negative: growth rate.
    overdamped : bool array
    error_estimate : array
        Vertical drive, hanging and upright: |√|Ω₂²| − √|Ω₁²|| / √|Ω₁²|, the relative
        size of the next-order correction to the slow frequency (or growth rate);
        +inf when the correction flips the stability.  It estimates the error of
        order 1 (within a factor ≈ 2, tests/test_averaging.py); the error of
        order 2 is much smaller (see :data:`MAX_CORRECTION`).  NaN for the tilted
        equilibria and the horizontal drive (no next order implemented).
    frequency_ratio : array
        ω / max(ω0, √|Ω²|, γ).
    fast_drive, small_amplitude, converged, valid : bool arrays
        ``frequency_ratio ≥ MIN_FREQUENCY_RATIO``, ``A/l ≤ MAX_AMPLITUDE_RATIO``,
        ``error_estimate ≤ MAX_CORRECTION`` (True where no estimate exists), and
        all three (False where the equilibrium does not exist).
    """

    name: str
    theta: object
    exists: object
    stable: object
    omega_squared: object
    omega_slow: object
    damped_frequency: object
    decay_rate: object
    overdamped: object
    error_estimate: object
    frequency_ratio: object
    fast_drive: object
    small_amplitude: object
    converged: object
    valid: object


@dataclass(frozen=True)
class PendulumAveraging:
    """Averaged (Kapitza) predictions for the driven pendulum over arrays of A and ω.

    Attributes
    ----------
    A, omega : array
        Drive amplitude (m) and angular frequency (rad/s), broadcast.
    l, g, damping : float
        Length (m), gravity (m/s²), damping rate γ (1/s).
    drive : str
    order : int
        1 (Kapitza/Landau averaging) or 2 (next order, vertical drive).
    equilibria : tuple of EquilibriumPrediction
    """

    A: object
    omega: object
    l: float
    g: float
    damping: float
    drive: str
    order: int
    equilibria: tuple

    def __getitem__(self, name) -> EquilibriumPrediction:
        for e in self.equilibria:
            if e.name == name:
                return e
        raise KeyError(f"no equilibrium {name!r}; have {[e.name for e in self.equilibria]}.")

    @property
    def hanging(self) -> EquilibriumPrediction:
        return self["hanging"]

    @property
    def inverted(self) -> EquilibriumPrediction:
        return self["inverted"]

    @property
    def tilted(self) -> EquilibriumPrediction:
        """The tilted equilibrium θ* > 0 (−θ* is its mirror; see EquilibriumPrediction.name)."""
        return self["tilted+"]

    @property
    def valid(self):
        """The predictions for every existing equilibrium are valid (per point)."""
        return _item(np.logical_and.reduce([np.asarray(e.valid) | ~np.asarray(e.exists)
                                            for e in self.equilibria]))

    def to_dataframe(self) -> pd.DataFrame:
        """One row per (A, ω) point and equilibrium."""
        A, w = (np.ravel(x) for x in np.broadcast_arrays(self.A, self.omega))
        rows = []
        for e in self.equilibria:
            cols = {f: np.ravel(np.broadcast_to(np.asarray(getattr(e, f)), np.shape(self.A)))
                    for f in ("theta", "exists", "stable", "omega_squared", "omega_slow",
                              "damped_frequency", "decay_rate", "overdamped", "error_estimate",
                              "frequency_ratio", "fast_drive", "small_amplitude", "converged",
                              "valid")}
            rows.append(pd.DataFrame({"A": A, "omega": w, "equilibrium": e.name, **cols}))
        return pd.concat(rows, ignore_index=True).assign(order=self.order, drive=self.drive)


def pendulum_averaged(A, omega, *, l=1.0, g=9.81, damping=0.0, drive="vertical", order=1,
                      warn=True) -> PendulumAveraging:
    """Equilibria, stability and slow frequencies of the driven pendulum by averaging.

    Parameters
    ----------
    A, omega : float or array
        Drive amplitude (m, ≥ 0) and angular frequency (rad/s, > 0); broadcast.
    l, g, damping : float
        Length (m), gravity (m/s²), viscous damping rate γ (1/s) as in
        θ̈ = −γ θ̇ − (g − A ω² cos ωt) sin θ / l.
    drive : {"vertical", "horizontal"}
    order : {1, 2}
        1: Kapitza/Landau averaging.  Vertical drive: upright stable iff
        A² ω² > 2 g l; Ω² = A² ω²/(2 l²) − g/l (upright), g/l + A² ω²/(2 l²)
        (hanging); relative error of Ω O(ε²), ε² ~ ω0²/ω² ~ A²/l².
        Horizontal drive: tilted equilibria cos θ* = 2 g l/(A² ω²) for
        A² ω² > 2 g l, Ω² = A² ω² sin² θ*/(2 l²); hanging Ω² = g/l − A² ω²/(2 l²).
        2 (vertical drive only): the next order from the Mathieu equation,
        Ω² = (ω²/4) ν²(a, q) with ν² = a + q²/2 + a q²/2 + 25 q⁴/128
        (a = ±4 g/(l ω²), q = 2A/l), i.e. for the upright
        Ω² = A²ω²/(2l²) − g/l − 2 (g/l) A²/l² + 25 A⁴ω²/(32 l⁴), relative error
        O(ε⁴); stability also requires a′ < b₁(q), which gives the upper limit
        A/l → 0.4540 at high ω that first-order averaging cannot see.
    warn : bool
        Emit :class:`AveragingValidityWarning` for a scalar point outside the
        regime (see :data:`MIN_FREQUENCY_RATIO`, :data:`MAX_AMPLITUDE_RATIO`).

    Damping
    -------
    The averaged equation is θ̈ + γ θ̇ + ∂U_eff/∂θ = 0: damping does not move the
    equilibria nor the first-order stability limit; small oscillations become
    e^{−γt/2} cos(√(Ω² − γ²/4) t), overdamped when γ > 2Ω.  For the linearised
    pendulum this is exact in form: the damped Mathieu equation equals the
    undamped one at a′ = a − γ²/ω² with multipliers scaled by e^{−γT/2}, so the
    decay rate of an underdamped slow oscillation is exactly γ/2 and order 2
    uses ν²(a′, q), whose a′q²/2 term is the damping's weakening of the fast
    response: Ω² gains −(γ/ω)² A²ω²/(2l²), so the minimum drive rises by a
    relative (γ/ω)²/2 (the exact damped limit, where a Floquet multiplier
    reaches 1, is matched to O(ε⁴)).  The upper (parametric-resonance) limit is evaluated at a′
    without the tongue's damping shift, i.e. it errs on the unstable side by
    O(γ/ω).
    """
    if drive not in ("vertical", "horizontal"):
        raise ValueError(f"drive must be 'vertical' or 'horizontal', got {drive!r}.")
    if order not in (1, 2):
        raise ValueError(f"order must be 1 or 2, got {order!r}.")
    if order == 2 and drive != "vertical":
        raise ValueError("the next-order (order=2) theory is implemented for the vertical drive "
                         "only; use order=1 for the horizontal drive.")
    for name, v in (("l", l), ("g", g), ("damping", damping)):
        if not (isinstance(v, (int, float)) and math.isfinite(v)):
            raise ValueError(f"{name} must be a finite number, got {v!r}.")
    if l <= 0 or g < 0 or damping < 0:
        raise ValueError(f"need l > 0, g ≥ 0, damping ≥ 0; got l={l}, g={g}, damping={damping}.")
    A, omega = _as_drive(A, omega)
    w02 = g / l
    gam = float(damping)
    small = A / l <= MAX_AMPLITUDE_RATIO
    eqs = []

    def finish(name, theta, exists, w2, w2_damped, stable, err):
        # w2: undamped Ω²; w2_damped: Ω² − γ²/4 (or its order-2 form)
        exists = np.asarray(exists, bool)
        stable = np.asarray(stable, bool) & exists
        root = np.sqrt(np.abs(w2_damped))
        damped = np.where(stable, np.where(w2_damped > 0, root, 0.0), np.nan)
        decay = np.where(w2_damped >= 0, gam / 2, gam / 2 - root)
        ratio = omega / np.maximum.reduce([np.full_like(omega, math.sqrt(w02)),
                                           np.sqrt(np.abs(w2)), np.full_like(omega, gam)])
        fast = ratio >= MIN_FREQUENCY_RATIO
        converged = ~(err > MAX_CORRECTION)              # NaN (no estimate) counts as converged
        nan = np.where(exists, 0.0, np.nan)
        eqs.append(EquilibriumPrediction(
            name=name, theta=_item(theta + nan), exists=_item(exists), stable=_item(stable),
            omega_squared=_item(w2 + nan), omega_slow=_item(np.where(w2 >= 0, np.sqrt(np.abs(w2)),
                                                                     np.nan) + nan),
            damped_frequency=_item(damped + nan), decay_rate=_item(decay + nan),
            overdamped=_item(stable & (w2_damped < 0)), error_estimate=_item(err + nan),
            frequency_ratio=_item(ratio), fast_drive=_item(fast), small_amplitude=_item(small),
            converged=_item(converged), valid=_item(fast & small & converged & exists)))

    vib = (A * omega) ** 2 / (2 * l * l)          # A²ω²/(2l²)
    if drive == "vertical":
        q = 2 * A / l
        shift = (gam / omega) ** 2                # a → a′ = a − γ²/ω²
        for name, theta, sign in (("hanging", 0.0, 1.0), ("inverted", math.pi, -1.0)):
            a = sign * 4 * w02 / omega**2
            w2 = {o: omega**2 / 4 * exponent_squared(a, q, o) for o in (1, 2)}
            w2d = omega**2 / 4 * exponent_squared(a - shift, q, order)
            # exact damped criterion: growth of the a′-equation must beat e^{−γt/2}
            stable = w2d > -gam**2 / 4
            if order == 2:
                stable = stable & (a - shift < mathieu_b1(q))
            with np.errstate(invalid="ignore", divide="ignore"):
                r1, r2 = np.sqrt(np.abs(w2[1])), np.sqrt(np.abs(w2[2]))
                err = np.where(np.sign(w2[1]) == np.sign(w2[2]), np.abs(r2 - r1) / r1, np.inf)
            finish(name, np.full_like(A, theta), np.ones_like(A, bool), w2[order], w2d, stable, err)
        # the maxima of U_eff between them, cos θ = −2gl/(A²ω²), exist when the upright is
        # stable (first order at any ``order``): the separatrix of the slow motion
        with np.errstate(divide="ignore", invalid="ignore"):
            c = np.where(vib > 0, -w02 / np.where(vib > 0, vib, 1.0), -np.inf)
        exists = c > -1
        ts = np.arccos(np.clip(c, -1, 1))
        w2 = -vib * np.sin(ts) ** 2
        for name, sgn in (("tilted+", 1.0), ("tilted-", -1.0)):
            finish(name, sgn * ts, exists, w2, w2 - gam**2 / 4, np.zeros_like(exists),
                   np.full_like(A, np.nan))
    else:
        nan = np.full_like(A, np.nan)
        for name, theta, w2 in (("hanging", 0.0, w02 - vib), ("inverted", math.pi, -w02 - vib)):
            finish(name, np.full_like(A, theta), np.ones_like(A, bool), w2, w2 - gam**2 / 4,
                   w2 > 0, nan)
        with np.errstate(divide="ignore", invalid="ignore"):
            c = np.where(vib > 0, w02 / np.where(vib > 0, vib, 1.0), np.inf)   # cos θ* = 2gl/(A²ω²)
        exists = c < 1
        ts = np.arccos(np.clip(c, -1, 1))
        w2 = vib * np.sin(ts) ** 2
        for name, sgn in (("tilted+", 1.0), ("tilted-", -1.0)):
            finish(name, sgn * ts, exists, w2, w2 - gam**2 / 4, exists, nan)
    out = PendulumAveraging(A=_item(A), omega=_item(omega), l=float(l), g=float(g),
                            damping=gam, drive=drive, order=order, equilibria=tuple(eqs))
    if warn and np.ndim(A) == 0:
        bad = [e.name for e in out.equilibria if e.exists and not e.valid]
        if bad:
            e = out[bad[0]]
            why = []
            if not e.small_amplitude:
                why.append(f"A/l = {A / l:.3g} > {MAX_AMPLITUDE_RATIO:g}")
            if not e.fast_drive:
                why.append(f"ω is only {e.frequency_ratio:.3g} × the slow frequencies "
                           f"(< {MIN_FREQUENCY_RATIO:g})")
            if not e.converged:
                why.append(f"the next-order correction is {e.error_estimate:.3g} of the slow "
                           f"frequency (> {MAX_CORRECTION:g}; near a stability limit?)")
            warnings.warn(f"averaging outside its regime for {', '.join(bad)}: "
                          + "; ".join(why), AveragingValidityWarning, stacklevel=2)
    return out


def stability_window(omega, *, l=1.0, g=9.81, damping=0.0, order=2) -> StabilityWindow:
    """The drive amplitudes that keep the vertically driven pendulum upright, at each ω.

    Order 1: A_min = √(2 g l)/ω, A_max = +inf (first order cannot see the upper
    limit).  Order 2: A_min from ν²(a′, q) = −γ²/ω², i.e. (undamped)
    A²ω²(1 − 7A²/(16 l²)) ≈ 2 g l, relative error O(ε⁴); A_max from the parametric
    resonance a′ = b₁(2A/l), → 0.4540 l as ω → ∞.  The exact window is
    :func:`kapitza.mathieu.pendulum_stability_window`.

    Returns
    -------
    kapitza.results.StabilityWindow
        ``method="averaging"``, fields of ``omega``'s shape (floats for a scalar).
    """
    _, omega = _as_drive(0.0, omega)
    if order not in (1, 2):
        raise ValueError(f"order must be 1 or 2, got {order!r}.")
    window = functools.partial(StabilityWindow, method="averaging", about="inverted", order=order,
                               l=float(l), g=float(g), damping=float(damping), omega=_item(omega))
    if order == 1:
        return window(A_min=_item(np.sqrt(2 * g * l) / omega),
                      A_max=_item(np.full_like(omega, np.inf)))
    a = -4 * g / (l * omega**2)
    s = (damping / omega) ** 2
    ap = a - s
    # ν²(a′, x = q²) = a′ + x/2 + a′x/2 + 25x²/128 = −s  →  quadratic in x
    c2, c1, c0 = 25 / 128, (1 + ap) / 2, a
    x = (-c1 + np.sqrt(c1 * c1 - 4 * c2 * c0)) / (2 * c2)
    A_min = l * np.sqrt(x) / 2
    A_max = l * _b1_root(ap) / 2
    return window(A_min=_item(A_min), A_max=_item(A_max))


# ======================================================================================
# The N-link pendulum on a vertically vibrating pivot (Acheson's theorem)
# ======================================================================================

@dataclass(frozen=True)
class MultiplePendulumPrediction:
    """Upright N-link pendulum on a pivot shaken vertically as A cos ωt.

    About the upright state the linearised equations M θ̈ = (g − A ω² cos ωt) L θ
    (M_ij = l_i l_j μ_max(i,j), L = diag(l_i μ_i), μ_i = Σ_{j≥i} m_j) decouple in
    the eigenvectors of M⁻¹L into N Mathieu equations, each a single pendulum of
    effective length λ_k = g / ω_k², ω_k the normal-mode frequencies of the
    *hanging* chain (Acheson 1993, "A pendulum theorem").  First-order
    averaging (the Hessian of U_eff) gives

        Ω_k² = A² ω² ω_k⁴ / (2 g²) − ω_k²,

    so all links stay upright iff A ω > √2 g / ω_min (the slowest hanging mode;
    (2 + √2) g l for the equal double pendulum), and at order 2 each mode obeys
    the single-pendulum limits with l → λ_k, the upper one
    A < 0.4540 g / ω_max² at high ω (the fastest hanging mode).

    Attributes
    ----------
    masses, lengths : ndarray (N,)
    g : float
    hanging_frequencies : ndarray (N,)
        ω_k of the undriven hanging chain (rad/s), ascending.
    effective_lengths : ndarray (N,)
        λ_k = g/ω_k² (m), descending.
    minimum_drive : float
        (A ω)_min = √2 g / ω_1 (m/s), first order.
    A, omega : array or None
        The drive, if given; then the fields below have its broadcast shape (+ (N,)).
    omega_squared : ndarray (..., N) or None
        Slow Ω_k² about the upright, in the order of ``hanging_frequencies``.
    stable : bool array or None
    mode_predictions : tuple of PendulumAveraging or None
        The single-pendulum prediction of each mode (``inverted`` holds the
        upright result); carries the validity flags.
    order : int
    """

    masses: np.ndarray
    lengths: np.ndarray
    g: float
    hanging_frequencies: np.ndarray
    effective_lengths: np.ndarray
    minimum_drive: float
    A: object = None
    omega: object = None
    omega_squared: object = None
    stable: object = None
    valid: object = None
    mode_predictions: tuple = None
    order: int = 1

    def to_dataframe(self) -> pd.DataFrame:
        """One row per mode (and drive point, if given)."""
        if self.mode_predictions is None:
            return pd.DataFrame({"mode": np.arange(len(self.masses)),
                                 "hanging_frequency": self.hanging_frequencies,
                                 "effective_length": self.effective_lengths})
        frames = []
        for k, pred in enumerate(self.mode_predictions):
            df = pred.to_dataframe()
            df = df[df.equilibrium == "inverted"].drop(columns="equilibrium")
            frames.append(df.assign(mode=k, hanging_frequency=self.hanging_frequencies[k],
                                    effective_length=self.effective_lengths[k]))
        return pd.concat(frames, ignore_index=True)


def multiple_pendulum_upright(masses, lengths, *, g=9.81, A=None, omega=None, order=1,
                              warn=True) -> MultiplePendulumPrediction:
    """Acheson's multiple inverted pendulum: minimum drive and slow modes of the upright chain.

    Parameters
    ----------
    masses, lengths : sequence of float (N,)
        Bob masses (kg) and rod lengths (m), from the pivot outwards.
    g : float
        Gravity (m/s²).
    A, omega : float or array, optional
        Vertical drive amplitude (m) and frequency (rad/s); with them, the slow
        frequencies and stability are computed (broadcast, no re-derivation).
    order : {1, 2}
        Per-mode accuracy as in :func:`pendulum_averaged`.

    Returns
    -------
    MultiplePendulumPrediction
    """
    m = np.asarray(masses, float).ravel()
    ls = np.asarray(lengths, float).ravel()
    if m.shape != ls.shape or m.size == 0:
        raise ValueError(f"masses and lengths need the same length N ≥ 1, got {m.size} and {ls.size}.")
    if not (np.all(m > 0) and np.all(ls > 0) and np.all(np.isfinite(m)) and np.all(np.isfinite(ls))):
        raise ValueError("masses and lengths must be finite and > 0.")
    if not g > 0:
        raise ValueError(f"g must be > 0 (m/s²), got {g}.")
    n = m.size
    mu = np.cumsum(m[::-1])[::-1]                        # μ_i = Σ_{j≥i} m_j
    idx = np.maximum.outer(np.arange(n), np.arange(n))
    M = np.outer(ls, ls) * mu[idx]
    L = np.diag(ls * mu)
    w2 = np.sort(scipy.linalg.eigh(g * L, M, eigvals_only=True))
    wk = np.sqrt(w2)
    lam = g / w2
    out = dict(masses=m, lengths=ls, g=float(g), hanging_frequencies=wk, effective_lengths=lam,
               minimum_drive=float(math.sqrt(2) * g / wk[0]), order=order)
    if A is None and omega is None:
        return MultiplePendulumPrediction(**out)
    if A is None or omega is None:
        raise ValueError("give both A and omega (or neither).")
    A, omega = _as_drive(A, omega)
    preds = tuple(pendulum_averaged(A, omega, l=float(lk), g=float(g), order=order, warn=False)
                  for lk in lam)
    W2 = np.stack([np.asarray(p.inverted.omega_squared, float) for p in preds], axis=-1)
    stable = np.logical_and.reduce([np.asarray(p.inverted.stable) for p in preds])
    valid = np.logical_and.reduce([np.asarray(p.inverted.valid) for p in preds])
    if warn and np.ndim(A) == 0 and not valid:
        warnings.warn(f"averaging outside its regime for the {n}-link pendulum (a mode has "
                      f"A/λ_k > {MAX_AMPLITUDE_RATIO:g} or ω < {MIN_FREQUENCY_RATIO:g} × its slow "
                      "frequency)", AveragingValidityWarning, stacklevel=2)
    return MultiplePendulumPrediction(**out, A=_item(A), omega=_item(omega), omega_squared=W2,
                                      stable=_item(stable), valid=_item(valid),
                                      mode_predictions=preds)
