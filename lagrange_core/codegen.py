"""Compile derived equations to numba kernels, cached on disk.

Generated kernels (the contract every numerical module relies on)
-----------------------------------------------------------------
For a system with n coordinates, m constraints and k parameters, the generated
module defines these ``@njit(cache=True)`` functions.  Arrays are float64;
``p`` holds the parameter values in the order of ``System.parameters``;
``y = [q, q̇]`` is the first-order state; ``W`` is a scratch array of shape
``WORK_SHAPE`` (a module constant; ``new_work()`` or ``Kernels.work_array()``
make one) that the caller allocates once, so no kernel on the hot path
allocates.  It holds the augmented system, ``(n + m, n + m + 1)``; a
scratch array with more rows also works.

=========================================================  ====================================
``new_work() -> W``                                        a fresh scratch array
``mass_forcing(q, qd, t, p, M, F)``                        fills M (n, n) and F (n)
``augmented(q, qd, t, p, W)``                              fills W = [[M, −Φ_qᵀ, F], [Φ_q, 0, γ]]
``augmented_y(y, t, p, W)``                                the same from the state y = [q, q̇]
``solve_state(q, qd, t, p, W) -> int``                     augmented + solve; W[:N, N] = [q̈, λ]
``solve_state_y(y, t, p, W) -> int``                       the same from the state y
``accelerations(q, qd, t, p, qdd, lam, W) -> int``         q̈ (n) and λ (m)
``rhs(t, y, p, dydt, W) -> int``                           dy/dt of the first-order system
``jacobian(t, y, p, J) -> int``                            ∂(dy/dt)/∂y, (2n, 2n), exact
``energy(q, qd, t, p) -> float``                           the energy function h
``constraint_residual(q, qd, t, p, out)``                  out = [Φ, Φ̇] (2m)
``constraint_jacobian(q, t, p, out)``                      out = Φ_q (m, n)
``particle_positions(q, t, p, out)``                       out (n_particles, 3), zero-padded
=========================================================  ====================================

Integer returns are a status: 0 success, 1 singular (augmented) mass matrix.  The
``rhs`` of a constrained system leaves the solution [q̈, λ] in ``W[:n + m, n + m]``
(so the multipliers come with every right-hand side).
Module constants: ``N_DOF``, ``N_CONSTRAINTS``, ``N_PARAMETERS``, ``N_PARTICLES``,
``WORK_SHAPE``, ``BAND`` (half-bandwidth of M), ``RKN_FORM`` and ``RKN_REASON``
(whether q̈ = f(q, t), :func:`lagrange_core.forms.rkn_form`), ``ENERGY_CONSERVED``.

Code compiled once for every system (the integrators, Floquet's sampler) reaches the
kernels through their C entry points ``c_<kernel>`` (plain functions of raw pointers;
:meth:`Kernels.addresses` compiles them with ``numba.cfunc`` on first use and returns
their addresses; the contract is in :mod:`lagrange_core._kernel_calls`).

What is generated, and what is fixed: the generated code evaluates each
*distinct* symbolic term once (common subexpressions removed across all terms
at once with symengine's ``cse``): per particle its mass, Jacobian ∂r/∂q and the
q̈-free part of its acceleration b; the rest of F (potential, forces,
dissipation, explicit-Lagrangian terms); Φ_q and γ.  From these it forms the
entries M = M' + Σ m JᵀJ and F = F' − Σ m Jᵀb, grouping particles that share
Jacobian columns (``_entries``: a chain of N links costs O(N²), not O(N³)).
Then, by size:

* small systems (few particle products, n ≤ 12 unconstrained, n + m ≤ 6
  constrained): printed straight-line Python, and an unconstrained M (n ≤ 6) is
  solved by an unrolled LDLᵀ, so M
  and F never leave registers (a double pendulum's right-hand side costs what
  a hand-written one does);
* large systems: a *program* whose LLVM IR is written directly
  (:mod:`lagrange_core._ir`) stores the entries into W, bypassing numba's front
  end, which costs about 3 ms per arithmetic operation of generated source;
  solvers compiled once per installation solve it (a banded mass matrix by a
  banded LDLᵀ: a chain of beads costs O(n)).

``mass_forcing`` (``System.mass_forcing``, linearisation, normal modes), which no
integrator calls, evaluates the program for every system: a 4-link pendulum's compiles
in 0.14–0.23 s, its printed form took 0.61–0.66 s.

The hot kernels (``rhs``, ``solve_state_y``, ``accelerations``) are single
functions: each call between numba functions costs reference-count updates on
its array arguments.  The Jacobian is exact, for every system: forward-mode
derivatives of the entries from the same program
(``lagrange_core._ir.tangent_evaluator``; ``abs`` and ``sign`` included),
then two solves compiled once per installation
(``lagrange_core._core_kernels.jacobian_from_entries``).  Each kernel compiles on
its first call (or all at once by :meth:`Kernels.warm`).

The disk cache
--------------
Generated modules live in the one store of :mod:`lagrange_core.module_store`, one file
per system statement, keyed by a hash of the statement and of this generator's own
code; numba caches the machine code next to them in ``__pycache__``.  A fresh process
with a warm cache loads both instead of deriving and compiling.
"""
from __future__ import annotations

import functools
import re
import sys
import textwrap
import types

import numba
import numpy as np
import symengine as se

from . import _ir
from ._first_calls import aside
from ._kernel_calls import SIGNATURES, SLOTS
from .derive import Equations
from .forms import rkn_form
from .module_store import (cache_dir, content_key, load_generated, load_module,  # noqa: F401
                           source_fingerprint, write_module)

__all__ = ["Kernels", "compile_kernels", "cache_dir"]

_ALLOWED_NAMES = {"sin", "cos", "tan", "exp", "log", "sqrt", "asin", "acos", "atan", "atan2",
                  "sinh", "cosh", "tanh", "asinh", "acosh", "atanh", "abs", "pi", "E", "sign"}

_HEADER = '''\
# Generated by lagrange_core.codegen for {label}. Do not edit: regenerated when
# the statement or the generator changes.  Kernel contract: lagrange_core/codegen.py.
import math
from math import inf, nan       # literals of the program (a Piecewise with no true branch)
import numpy as np
from numba import carray, njit
from numpy import (sin, cos, tan, exp, log, sqrt, arcsin as asin, arccos as acos,
                   arctan as atan, arctan2 as atan2, sinh, cosh, tanh, arcsinh as asinh,
                   arccosh as acosh, arctanh as atanh, pi, e as E, sign)
from lagrange_core._core_kernels import (check_work, jacobian_from_entries, jacobian_scratch,
                                         work_matrix)
from lagrange_core._ir import value_evaluator, tangent_evaluator
from lagrange_core._linalg import solve_augmented, solve_dense, solve_banded_spd

N_DOF = {n}
N_CONSTRAINTS = {m}
N_PARAMETERS = {k}
N_PARTICLES = {n_particles}
N_VALUES = {n_values}               # distinct symbolic terms
N0 = {N}                        # rows of the augmented system
BAND = {band}                   # half-bandwidth of the mass matrix (structural)
WORK_SHAPE = ({N}, {N} + 1)
COORDINATES = {coordinates!r}
PARAMETERS = {parameters!r}
RKN_FORM = {rkn_form!r}                 # q̈ = f(q, t): lagrange_core.forms.rkn_form
RKN_REASON = {rkn_reason!r}
ENERGY_CONSERVED = {energy_conserved!r}        # h constant of the motion (Equations.energy_conserved)
'''


_WRAPPERS = '''

# -- the fixed part --------------------------------------------------------------------

@njit(cache=True)
def new_work():
    return np.zeros(WORK_SHAPE)


@njit(cache=True)
def jacobian(t, y, p, J):
    # the augmented matrix and its forward-mode derivatives (_ir), then two solves
    W, dA = jacobian_scratch(N0, N_TANGENTS)
    _evaluate_tangents(y, t, p, W, dA)
    return jacobian_from_entries(W, dA, TARGET_TABLE, TAN_PTR, TAN_J, J)


# -- C entry points (lagrange_core._kernel_calls): compiled by Kernels.addresses ------------

_NQ = (N_DOF,)
_NY = (2 * N_DOF,)
_NP = (N_PARAMETERS,)


def c_rhs(t, y, p, dydt, W):
    return rhs(t, carray(y, _NY), carray(p, _NP), carray(dydt, _NY), carray(W, WORK_SHAPE))


def c_energy(q, qd, t, p):
    return energy(carray(q, _NQ), carray(qd, _NQ), t, carray(p, _NP))


def c_constraint_residual(q, qd, t, p, out):
    constraint_residual(carray(q, _NQ), carray(qd, _NQ), t, carray(p, _NP),
                        carray(out, (2 * N_CONSTRAINTS,)))
    return 0


def c_constraint_jacobian(q, t, p, out):
    constraint_jacobian(carray(q, _NQ), t, carray(p, _NP), carray(out, (N_CONSTRAINTS, N_DOF)))
    return 0


def c_jacobian(t, y, p, J):
    return jacobian(t, carray(y, _NY), carray(p, _NP), carray(J, (2 * N_DOF, 2 * N_DOF)))
'''


@functools.cache
def _generator_fingerprint() -> str:
    from . import _core_kernels, _kernel_calls, _linalg, derive, forms
    return source_fingerprint(sys.modules[__name__], derive, forms, _ir, _linalg, _core_kernels,
                              _kernel_calls)


# -- printing -------------------------------------------------------------------------

class _Printer:
    """Renames a system's symbols to kernel locals and prints symengine expressions."""

    def __init__(self, system, cse=True):
        self.cse = cse
        self.subs = {}
        self.loads = {}
        groups = [("q", "_q", system.q), ("qd", "_v", system.qdot),
                  ("p", "_p", system.parameter_symbols)]
        for array, prefix, symbols in groups:
            lines = []
            for i, s in enumerate(symbols):
                local = f"{prefix}{i}"
                self.subs[se.sympify(s)] = se.Symbol(local)
                lines.append(f"{local} = {array}[{i}]")
            self.loads[array] = lines
        n = len(system.q)
        self.loads["y"] = ([f"_q{i} = y[{i}]" for i in range(n)]
                           + [f"_v{i} = y[{n + i}]" for i in range(n)])
        from .symbols import t
        self.subs[se.sympify(t)] = se.Symbol("t")

    def rename(self, expr):
        """``expr`` in the kernel's local names (``_q0``, ``_v0``, ``_p0``, ``t``)."""
        expr = se.sympify(expr)
        # symengine converts the whole mapping on every call, so a number (most entries
        # of a large system's matrices: 40 000 zeros for a 200-bead string) skips it and a
        # term gets only its own symbols: renaming had taken 14 of the 18 s that the
        # 200-bead string's kernels took to write
        if expr.is_Number:
            return expr
        return expr.subs({s: self.subs[s] for s in expr.free_symbols if s in self.subs})

    @staticmethod
    def code(expr) -> str:
        # x**2 -> (x*x): numba compiles an integer power as a subroutine (slow to compile)
        text = re.sub(r"(?<![\w.])([A-Za-z_]\w*)\*\*2(?![\d.])", r"(\1*\1)", str(expr))
        for name in set(re.findall(r"(?<![\w.])([A-Za-z_]\w*)", text)):
            if name == "t" or name.startswith("_") or re.fullmatch(r"x\d+", name):
                continue    # time (a kernel argument), a kernel local or a CSE temporary
            if name not in _ALLOWED_NAMES:
                raise ValueError(
                    f"cannot compile the function or constant {name!r} in {text[:200]}: the kernels "
                    f"support {sorted(_ALLOWED_NAMES)}. Rewrite the expression with these.")
        return text

    def body(self, outputs, arrays, renamed=False):
        """Kernel body: loads of the named input arrays, CSE'd temporaries, output stores.

        ``outputs`` is a list of (target string, expression)."""
        exprs = [e if renamed else self.rename(e) for _, e in outputs]
        replacements, reduced = se.cse(exprs) if exprs and self.cse else ([], exprs)
        lines = [f"{s} = {self.code(e)}" for s, e in replacements]
        lines += [f"{target} = {self.code(e)}" for (target, _), e in zip(outputs, reduced)]
        return self.used_loads(arrays, lines) + lines

    def used_loads(self, arrays, lines):
        """The loads from the named input arrays of the locals that ``lines`` use (numba
        spends ~6 ms compiling each indexing statement, used or not)."""
        used = set(re.findall(r"\b_[qvp]\d+\b", "\n".join(lines)))
        return [load for a in arrays for load in self.loads.get(a, [])
                if load.split(" = ")[0] in used]


def _function(name, args, lines, ret=None):
    body = lines + ([f"return {ret}"] if ret is not None else [])
    if not body:
        body = ["pass"]
    # error_model="numpy": a division by zero gives inf/nan (caught by the callers' status
    # checks) instead of a per-division branch, which also keeps compile times down.
    return "\n\n@njit(cache=True, error_model=\"numpy\")\ndef {}({}):\n{}\n".format(
        name, ", ".join(args), textwrap.indent("\n".join(body), "    "))


class _ValueTable:
    """Distinct expressions, each stored once; index 0 is the constant zero."""

    def __init__(self, printer):
        self.printer = printer
        self.index = {}
        self.exprs = []

    def __call__(self, expr) -> int:
        expr = self.printer.rename(expr)
        if expr == 0:
            return 0
        if expr not in self.index:
            self.exprs.append(expr)
            self.index[expr] = len(self.exprs)
        return self.index[expr]


def _table(name, rows, width=None) -> str:
    arr = np.asarray(rows, dtype=np.int64)
    if width is not None:
        arr = arr.reshape(-1, width)
    return f"{name} = np.array({arr.ravel().tolist()!r}, dtype=np.int64).reshape({arr.shape!r})\n"


#: Up to this many particle products (Σ over particles of nnz(J)·(nnz(J)+3)/2) the hot
#: kernels are printed as straight-line Python (fastest to run; a double pendulum's
#: right-hand side costs about as much as a hand-written one).  Beyond it, numba's front
#: end would be slow to compile them: the program (_ir) is written as LLVM IR instead.
UNROLL_LIMIT = 32

def _entries(equations, value):
    """The augmented matrix as expressions in the distinct terms (symbols ``_u{f}``).

    M = M' + Σ_k m_k J_kᵀJ_k and F = F' − Σ_k m_k J_kᵀb_k, with J_k = ∂r_k/∂q and b_k
    the q̈-free part of particle k's acceleration; ``value`` numbers each distinct term.
    Particles whose Jacobian columns are the same terms are grouped: their masses are
    summed before the product with J_iᵀJ_j, and their m_k b_k are summed before the dot
    with J_i, by running sums shared between nested groups.  A chain of N links (where
    links k ≥ i share column i) then costs O(N²) operations instead of O(N³).

    Returns
    -------
    M, F, Φ_q, γ, definitions, n_products
        M[i][j] for j ≥ i (lists of lists), F[i], Φ_q[c][j], γ[c]; the running sums as
        (symbol ``_s{k}``, expression), in evaluation order; the number of particle
        products Σ_k nnz(J_k)(nnz(J_k) + 3)/2 (the size of the assembly, ungrouped).
    """
    n = equations.system.n_dof

    def u(expr):
        f = value(expr)
        return se.Symbol(f"_u{f}") if f else se.Integer(0)

    def dot(a, b):
        return se.Add(*[x * y for x, y in zip(a, b)])

    M = [[u(equations.mass_rest_se[i][j]) for j in range(n)] for i in range(n)]
    F = [u(e) for e in equations.forcing_rest_se]
    pair_masses = {}        # (i, j, J_i, J_j) -> masses of the particles with these columns
    column_terms = {}       # (i, J_i) -> [(particle, mass, bias)]
    n_products = 0
    for k, pt in enumerate(equations.particle_terms):
        mass = u(pt.mass)
        dims = range(len(pt.bias))
        cols = [j for j in range(n) if any(pt.jacobian[c][j] != 0 for c in dims)]
        jac = {j: tuple(u(pt.jacobian[c][j]) for c in dims) for j in cols}
        bias = [u(b) for b in pt.bias]
        n_products += len(cols) * (len(cols) + 3) // 2
        for a, i in enumerate(cols):
            column_terms.setdefault((i, jac[i]), []).append((k, mass, bias))
            for j in cols[a:]:
                pair_masses.setdefault((i, j, jac[i], jac[j]), []).append(mass)
    for (i, j, jac_i, jac_j), masses in pair_masses.items():
        M[i][j] += se.Add(*masses) * dot(jac_i, jac_j)

    definitions, sums = [], {}

    def running_sum(members):
        """Σ m_k b_k over members (by descending k), as sums over members[:1], [:2], ...,
        each the previous one plus one term: nested groups share their running sums."""
        total = None
        for end in range(1, len(members) + 1):
            key = tuple(k for k, _, _ in members[:end])
            if key not in sums:
                _, mass, bias = members[end - 1]
                sums[key] = []
                for c, b in enumerate(bias):
                    e = mass * b + (total[c] if total else 0)
                    if e != 0 and end > 1:
                        symbol = se.Symbol(f"_s{len(definitions)}")
                        definitions.append((symbol, e))
                        e = symbol
                    sums[key].append(e)
            total = sums[key]
        return total

    for (i, jac_i), members in column_terms.items():
        F[i] -= dot(jac_i, running_sum(sorted(members, key=lambda x: -x[0])))
    phi_q = [[u(e) for e in row] for row in equations.constraint_jacobian_se]
    gamma = [u(e) for e in equations.constraint_rhs_se]
    return M, F, phi_q, gamma, definitions, n_products


def _unrolled_assembly(pr, exprs, M, F, phi_q, gamma, definitions):
    """Straight-line assembly: (lines computing the distinct values ``_u{f}``, the running
    sums ``_s{k}`` and the locals ``_M{i}_{j}`` (i ≤ j), ``_F{i}``; lines storing M, F, Φ_q
    and γ into W)."""
    n, m = len(F), len(gamma)
    lines = pr.body([(f"_u{f}", e) for f, e in enumerate(exprs, start=1)], [], renamed=True)
    lines += [f"{symbol} = {pr.code(e)}" for symbol, e in definitions]
    for i in range(n):
        lines.append(f"_F{i} = {pr.code(F[i])}")
        for j in range(i, n):
            lines.append(f"_M{i}_{j} = {pr.code(M[i][j])}")
    N = n + m
    store = []
    for i in range(n):
        store.append(f"W[{i}, {N}] = _F{i}")
        for j in range(i, n):
            store.append(f"W[{i}, {j}] = _M{i}_{j}")
            if j > i:
                store.append(f"W[{j}, {i}] = _M{i}_{j}")
    for c in range(m):
        store.append(f"W[{n + c}, {N}] = {pr.code(gamma[c])}")
        for j in range(n):
            store.append(f"W[{n + c}, {j}] = {pr.code(phi_q[c][j])}")
            store.append(f"W[{j}, {n + c}] = -W[{n + c}, {j}]")
        for d in range(m):
            store.append(f"W[{n + c}, {n + d}] = 0.0")
    return lines, store


def _uses_piecewise(exprs) -> bool:
    """Whether terms use Max, Min, Heaviside or Piecewise: those compile only as a
    program (:mod:`lagrange_core._ir`), not as printed Python."""
    pattern = re.compile(r"\b(max|min|Heaviside|Piecewise)\(")
    return any(pattern.search(str(e)) for e in exprs)


#: Unconstrained systems up to this many coordinates solve M q̈ = F by an unrolled LDLᵀ
#: factorisation (M is symmetric positive definite); others by Gaussian elimination.
CHOLESKY_UNROLL_LIMIT = 6


def _unrolled_ldlt(n):
    """Straight-line LDLᵀ solve of M x = F from the locals _M{i}_{j}, _F{i}; x in locals _x{i}.

    Returns status 1 from the kernel if a pivot is below 1e-13 of the largest diagonal entry.
    """
    M = lambda i, j: f"_M{min(i, j)}_{max(i, j)}"      # noqa: E731  (upper triangle only)
    lines = [f"_scale = max({', '.join(f'abs({M(i, i)})' for i in range(n))})"
             if n > 1 else f"_scale = abs({M(0, 0)})",
             "_tiny = 1e-13 * _scale"]
    for j in range(n):
        d = " - ".join([M(j, j)] + [f"_L{j}_{k}*_L{j}_{k}*_d{k}" for k in range(j)])
        lines += [f"_d{j} = {d}", f"if not _d{j} > _tiny:", "    return 1"]
        for i in range(j + 1, n):
            num = " - ".join([M(i, j)] + [f"_L{i}_{k}*_L{j}_{k}*_d{k}" for k in range(j)])
            lines.append(f"_L{i}_{j} = ({num}) / _d{j}")
    for i in range(n):
        z = " - ".join([f"_F{i}"] + [f"_L{i}_{k}*_z{k}" for k in range(i)])
        lines.append(f"_z{i} = {z}")
    for i in reversed(range(n)):
        x = " - ".join([f"_z{i} / _d{i}"] + [f"_L{k}_{i}*_x{k}" for k in range(i + 1, n)])
        lines.append(f"_x{i} = {x}")
    return lines


def generate_source(equations, cse: bool = True, unroll: bool | None = None) -> str:
    """Python source of the kernel module for ``equations`` (see the module docstring).

    ``cse=False`` prints every term in full (for checking that CSE changes nothing);
    ``unroll`` forces the straight-line Python assembly (True) or the LLVM program
    (False) for the hot kernels instead of choosing by size (``UNROLL_LIMIT``).
    """
    system = equations.system
    n, m = system.n_dof, system.n_constraints
    N = n + m
    pr = _Printer(system, cse)
    value = _ValueTable(pr)
    M, F, phi_q, gamma, definitions, n_products = _entries(equations, value)
    # straight-line code writes every entry of M: bound n too.  A constrained system
    # writes the whole augmented matrix into W (numba: ~6 ms per indexing statement), so
    # beyond N = 6 the program compiles faster (rigid triangle, N = 12: 0.7 s, not 2.5 s)
    if unroll is None:
        unroll = (n_products <= UNROLL_LIMIT and N <= (12 if m == 0 else CHOLESKY_UNROLL_LIMIT)
                  and not _uses_piecewise(value.exprs))
    unrolled = unroll
    # half-bandwidth of M (structurally): dense elimination becomes a banded LDLᵀ
    band = max([j - i for i in range(n) for j in range(i, n) if M[i][j] != 0] + [0])
    if m:
        band = n - 1    # the augmented system is solved densely: write all of M
    # Where each entry of [[M, −Φ_qᵀ, F], [Φ_q, 0, γ]] goes: every entry a solver reads
    # (M within the band), since the solvers overwrite W.
    outputs, out_index, targets = [], {}, []

    def target(row, col, expr):
        if expr not in out_index:
            out_index[expr] = len(outputs)
            outputs.append(expr)
        targets.append((row, col, out_index[expr]))

    for i in range(n):
        target(i, N, F[i])
        for j in range(max(0, i - band), min(n, i + band + 1)):
            target(i, j, M[min(i, j)][max(i, j)])
    for c in range(m):
        target(n + c, N, gamma[c])
        for j in range(n):
            target(n + c, j, phi_q[c][j])
            target(j, n + c, -phi_q[c][j])
        for d in range(m):
            target(n + c, n + d, se.Integer(0))
    # The distinct terms and the entries as a program whose LLVM IR is written directly
    # (_ir): numba's front end would take ~3 ms per operation.  Every system's Jacobian
    # differentiates it; large systems also evaluate it in their hot kernels.
    program = _ir.build_program(value.exprs, outputs, n, len(system.parameters), cse,
                                definitions)
    tan_ptr = np.cumsum([0] + [len(d) for d in program[2]])
    tan_j = [j for d in program[2] for j in d]
    rkn = rkn_form(equations)
    src = [_HEADER.format(label=repr(system.name or "a system"), n=n, m=m,
                          k=len(system.parameters), n_particles=len(system.particles),
                          n_values=len(value.exprs), N=N, band=band,
                          coordinates=system.coordinates, parameters=system.parameters,
                          rkn_form=rkn[0], rkn_reason=rkn[1],
                          energy_conserved=bool(equations.energy_conserved)),
           f"\nPROGRAM = {program!r}\nTARGETS = {tuple(targets)!r}\n",
           _table("TARGET_TABLE", targets, 3), _table("TAN_PTR", tan_ptr), _table("TAN_J", tan_j),
           "N_TANGENTS = TAN_J.shape[0]\n"
           "_evaluate = value_evaluator(PROGRAM, TARGETS)\n"
           "_evaluate_q = value_evaluator(PROGRAM, TARGETS, N_DOF)\n"
           "_evaluate_tangents = tangent_evaluator(PROGRAM, TARGETS)\n"]
    # Every kernel is a single function: each call between numba functions costs
    # reference-count updates on its array arguments (~10-40 ns), and each compiled entry
    # point re-optimises everything it calls (so wrappers of wrappers compile slowly).
    # assemble[source]: fill W (or, unrolled, locals) from the state y or from (q, q̇).
    if unrolled:
        lines, store = _unrolled_assembly(pr, value.exprs, M, F, phi_q, gamma, definitions)
        tail = lines + store + _unrolled_ldlt(n)
        assemble = {"y": pr.used_loads(["y", "p"], tail) + lines,
                    "q": pr.used_loads(["q", "qd", "p"], tail) + lines}
    else:
        store = []
        assemble = {"y": ["check_work(W, N0)", "_evaluate(y, t, p, W)"],
                    "q": ["check_work(W, N0)", "_evaluate_q(q, qd, t, p, W)"]}
    # solve: from the assembly to the solution (in ``result``); solved: the same, leaving
    # [q̈, λ] in W[:, N] as solve_state promises
    if unrolled and m == 0 and n <= CHOLESKY_UNROLL_LIMIT:
        # M and F stay in registers; W is not touched on the hot path
        solve = _unrolled_ldlt(n)
        result = [f"_x{i}" for i in range(n)]
        solved = store + solve + [f"W[{i}, {N}] = _x{i}" for i in range(n)]
    else:
        # unrolled systems inline the elimination (constant N); the others share one
        # compiled copy (W.shape[1] - 1 is N, and not a literal numba would specialise on)
        if unrolled:
            solve = [f"_status = solve_augmented(W, {N})"]
        elif m == 0 and band < n - 1:
            solve = ["_status = solve_banded_spd(W, W.shape[1] - 1, BAND)"]
        else:
            solve = ["_status = solve_dense(W, W.shape[1] - 1)"]
        solve = store + solve + ["if _status != 0:", "    return _status"]
        result = [f"W[{i}, {N}]" for i in range(n)]
        solved = solve
    if unrolled:
        copy = [f"dydt[{i}] = y[{n + i}]" for i in range(n)]
        copy += [f"dydt[{n + i}] = {r}" for i, r in enumerate(result)]
    else:   # a loop: numba lowers each indexing statement separately (~6 ms each)
        copy = ["for _i in range(N_DOF):", "    dydt[_i] = y[N_DOF + _i]",
                "    dydt[N_DOF + _i] = W[_i, N0]"]
    state_q = ["q", "qd", "t", "p"]
    src.append(_function("augmented_y", ["y", "t", "p", "W"], assemble["y"] + store))
    src.append(_function("augmented", [*state_q, "W"], assemble["q"] + store))
    src.append(_function("solve_state_y", ["y", "t", "p", "W"], assemble["y"] + solved, ret="0"))
    src.append(_function("solve_state", [*state_q, "W"], assemble["q"] + solved, ret="0"))
    src.append(_function("rhs", ["t", "y", "p", "dydt", "W"], assemble["y"] + solve + copy,
                         ret="0"))
    src.append(_function("accelerations", [*state_q, "qdd", "lam", "W"],
                         assemble["q"] + solve + [f"qdd[{i}] = {r}" for i, r in enumerate(result)]
                         + [f"lam[{c}] = W[{n + c}, {N}]" for c in range(m)], ret="0"))
    filled = ["W = work_matrix(N0)"] + assemble["q"] + store
    # M and F from the program for every system, printed or not: mass_forcing is no hot
    # kernel (linearisation, normal modes, checks), and numba's front end took 0.61-0.66 s
    # to compile a 4-link pendulum's printed assembly (the program: 0.14-0.23 s)
    src.append(_function("mass_forcing", [*state_q, "M", "F"], [
        "W = work_matrix(N0)", "_evaluate_q(q, qd, t, p, W)",
        "for _i in range(N_DOF):", "    F[_i] = W[_i, N0]", "    for _j in range(N_DOF):",
        "        M[_i, _j] = W[_i, _j]"]))
    res = [(f"out[{k}]", c) for k, c in enumerate(equations.constraints_se)]
    res += [(f"out[{m + k}]", c) for k, c in enumerate(equations.constraint_velocity_se)]
    src.append(_function("constraint_residual", [*state_q, "out"],
                         pr.body(res, ["q", "qd", "p"])))
    # Φ_q alone (the constraint projection needs nothing else of the augmented matrix)
    phi_q = [(f"out[{c}, {j}]", e) for c, row in enumerate(equations.constraint_jacobian_se)
             for j, e in enumerate(row) if e != 0]
    src.append(_function("constraint_jacobian", ["q", "t", "p", "out"], [
        "for _c in range(out.shape[0]):", "    for _j in range(out.shape[1]):",
        "        out[_c, _j] = 0.0"] + pr.body(phi_q, ["q", "p"])))
    positions = [((i, c), comp) for i, particle in enumerate(system.particles)
                 for c, comp in enumerate(particle.position)]
    clear = ["for _i in range(out.shape[0]):", "    for _c in range(out.shape[1]):",
             "        out[_i, _c] = 0.0"]
    quadratic = ["for _i in range(N_DOF):", "    for _j in range(N_DOF):",
                 "        _h += 0.5 * qd[_i] * W[_i, _j] * qd[_j]"]
    if unrolled:
        # small systems: h printed whole (CSE'd), not through the assembly of M and F,
        # which would cost the energy kernel the whole assembly's compile time again
        src.append(_function("energy", state_q,
                             pr.body([("_h", equations.energy_se)], ["q", "qd", "p"]), ret="_h"))
        src.append(_function("particle_positions", ["q", "t", "p", "out"], clear + pr.body(
            [(f"out[{i}, {c}]", comp) for (i, c), comp in positions], ["q", "p"])))
    else:
        # the rest of h and the positions as programs too (large sums: slow for numba)
        def program_of(exprs):
            renamed = [pr.rename(e) for e in exprs]
            return _ir.build_program(renamed, [se.Symbol(f"_u{f}") for f in
                                               range(1, len(exprs) + 1)], n,
                                     len(system.parameters), cse)

        slots = [(i, c, k) for k, ((i, c), _) in enumerate(positions)]
        src.append(f"ENERGY_PROGRAM = {program_of([equations.energy_rest_se])!r}\n"
                   "_evaluate_energy_rest = value_evaluator(ENERGY_PROGRAM, ((0, 0, 0),), N_DOF)\n"
                   f"POSITIONS_PROGRAM = {program_of([e for _, e in positions])!r}\n"
                   f"_evaluate_positions = value_evaluator(POSITIONS_PROGRAM, {tuple(slots)!r}, "
                   "N_DOF)\n")
        src.append(_function("energy", state_q, filled + [
            "_rest = work_matrix(1)", "_evaluate_energy_rest(q, qd, t, p, _rest)",
            "_h = _rest[0, 0]"] + quadratic, ret="_h"))
        src.append(_function("particle_positions", ["q", "t", "p", "out"],
                             clear + ["_evaluate_positions(q, q, t, p, out)"]))
    src.append(_WRAPPERS)
    return "".join(src)


# -- loading --------------------------------------------------------------------------

_KERNEL_NAMES = ("new_work", "mass_forcing", "augmented", "solve_state", "accelerations", "rhs", "jacobian",
                 "energy", "constraint_residual", "constraint_jacobian", "particle_positions")


class Kernels:
    """The compiled kernels of one system (see the module docstring for the contract).

    Attributes are numba dispatchers, callable from Python and from other
    numba code: ``mass_forcing``, ``augmented``, ``solve_state``,
    ``accelerations``, ``rhs``, ``jacobian``, ``energy``,
    ``constraint_residual``, ``constraint_jacobian``, ``particle_positions``; and the
    statement's facts:
    ``n_dof``, ``n_constraints``, ``n_particles``, ``coordinates``, ``parameters``,
    ``rkn_form`` (q̈ = f(q, t)) with ``rkn_reason`` (why not), ``energy_conserved``
    (the energy function h is a constant of the motion), ``label`` (for messages),
    ``statement_key`` (keys other generators' modules in the store) and ``equations()``
    (the derived equations, derived on the first call: generators of further kernels
    need them only when the store lacks their module).
    """

    def __init__(self, module: types.ModuleType, label: str = "the system",
                 statement_key: str = "", equations=None):
        self.module = module
        self.label = label
        self.statement_key = statement_key
        self._equations = equations
        self.n_dof = module.N_DOF
        self.n_constraints = module.N_CONSTRAINTS
        self.n_particles = module.N_PARTICLES
        self.parameters = module.PARAMETERS
        self.coordinates = module.COORDINATES
        self.rkn_form = module.RKN_FORM
        self.rkn_reason = module.RKN_REASON
        self.energy_conserved = module.ENERGY_CONSERVED
        for name in _KERNEL_NAMES:
            setattr(self, name, getattr(module, name))
        self._addresses = np.zeros(len(SLOTS), dtype=np.int64)
        self._cfuncs = {}

    def equations(self):
        """The derived :class:`~lagrange_core.derive.Equations` (derived on first use)."""
        if self._equations is None:
            raise ValueError(f"the kernels of {self.label} were loaded without their statement, "
                             "so nothing more can be generated for them.")
        return self._equations()

    def work_array(self) -> np.ndarray:
        """A fresh scratch array ``W`` of the shape the kernels expect."""
        return np.zeros(self.module.WORK_SHAPE)

    def accelerations_at(self, q, qd, t: float, p) -> tuple[np.ndarray, np.ndarray, int]:
        """q̈ (n), the multipliers λ (m) and the status (0, or 1: singular) at one state.

        Computed by ``rhs`` (it leaves [q̈, λ] in ``W``), which every integration of the
        system compiles (``simulate``, ``simulate_grid``: its entry point), rather than by the
        ``accelerations`` kernel, which solves the same system and would compile for a
        Python caller's one state (``System.accelerations``, an event on a multiplier):
        cold, ``accelerations`` after ``rhs`` took 0.2 s for a double pendulum, 5.2 s for a
        string of 200 beads, whose ``rhs`` compiles in 1.8–2.2 s."""
        n, m = self.n_dof, self.n_constraints
        y = np.concatenate([np.asarray(q, dtype=float), np.asarray(qd, dtype=float)])
        dydt = np.empty(2 * n)
        W = self.work_array()
        status = int(self.rhs(float(t), y, p, dydt, W))
        return dydt[n:].copy(), W[n:n + m, n + m].copy(), status

    def warm(self, *, jacobian: bool = False, everything: bool = False) -> "Kernels":
        """Compile (or load from the disk cache) kernels for float64 arrays now.

        By default only ``rhs`` (what an integrator needs: M, F and the solve);
        ``jacobian=True`` adds the Jacobian and ``everything=True`` every kernel.
        Kernels not compiled here compile on first use (about 0.3–1 s each, cold).
        """
        n, m = self.n_dof, self.n_constraints
        q = np.zeros(n)
        y = np.zeros(2 * n)
        p = np.ones(len(self.parameters))
        W = self.work_array()
        self.rhs(0.0, y, p, np.zeros(2 * n), W)
        if jacobian or everything:
            self.jacobian(0.0, y, p, np.zeros((2 * n, 2 * n)))
        if everything:
            self.mass_forcing(q, q, 0.0, p, np.zeros((n, n)), np.zeros(n))
            self.accelerations(q, q, 0.0, p, np.zeros(n), np.zeros(m), W)
            self.energy(q, q, 0.0, p)
            self.constraint_residual(q, q, 0.0, p, np.zeros(2 * m))
            self.constraint_jacobian(q, 0.0, p, np.zeros((m, n)))
            self.particle_positions(q, 0.0, p, np.zeros((self.n_particles, 3)))
        return self

    def addresses(self, *slots: str) -> np.ndarray:
        """The table of C entry-point addresses for compiled-once code.

        Parameters
        ----------
        *slots : str
            Kernel names from ``lagrange_core._kernel_calls.SLOTS`` that the caller
            will call; their ``c_<name>`` entry points are compiled (or loaded from
            numba's cache) on first request.  Slots not requested hold 0.

        Returns
        -------
        ndarray of int64, shape (len(SLOTS),)
            The same array object on every call (slots only ever get filled).
        """
        missing = [name for name in dict.fromkeys(slots) if name not in self._cfuncs]
        for name in missing:
            if not hasattr(self.module, f"c_{name}"):
                raise ValueError(f"{self.label} has no kernel {name!r} with a C entry point; "
                                 f"those of the kernel module are "
                                 f"{[n for n in SLOTS if hasattr(self.module, 'c_' + n)]}.")
        self.load_entry_points(self.module, missing)
        return self._addresses

    def load_entry_points(self, module, names) -> None:
        """Compile (or load from numba's cache) the C entry points ``c_<name>`` of
        ``module`` for ``names`` and put them into this system's address table, all of
        them together (one slot filled may say that another is: the drive kernel's
        ``fast_accel`` for ``drive_rates``).  Compiled by
        ``lagrange_core._first_calls.aside``: Ctrl-C need not wait for numba."""
        if not names:
            return
        entries = aside(lambda: [numba.cfunc(SIGNATURES[name], cache=True)(
            getattr(module, f"c_{name}")) for name in names])
        for name, entry in zip(names, entries, strict=True):
            self.set_address(name, entry)

    def set_address(self, name: str, cfunc) -> None:
        """Put the C entry point ``cfunc`` of kernel ``name`` into this system's address
        table (:meth:`load_entry_points` compiles them)."""
        self._cfuncs[name] = cfunc
        self._addresses[SLOTS.index(name)] = cfunc.address


def compile_kernels(system) -> Kernels:
    """Generate, cache and load the numba kernels of ``system``.

    With a warm disk cache nothing is derived: the statement's hash finds the
    generated module, and numba loads its machine code.

    Parameters
    ----------
    system : System or Equations

    Returns
    -------
    Kernels
        Nothing compiled yet: each kernel compiles (or loads from numba's disk cache)
        on its first call, or all at once by :meth:`Kernels.warm`.  Only what a caller
        uses is compiled: a check of the mass matrix, or ``normal_modes`` (the
        Jacobian), never waits for ``rhs`` (0.3–2 s cold).
    """
    if isinstance(system, Equations):     # derived already: use them, do not re-derive
        equations, system = system, system.system
    else:
        equations = None
    statement = system.statement_key()

    def derived():
        return equations if equations is not None else system.equations

    module = load_generated("_lc", content_key(_generator_fingerprint(), statement),
                            lambda: generate_source(derived()))
    return Kernels(module, system._label(), statement, derived)
