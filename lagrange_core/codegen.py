"""Compile derived equations to numba kernels, cached on disk.

Generated kernels (the contract every numerical module relies on)
-----------------------------------------------------------------
For a system with n coordinates, m constraints and k parameters, the generated
module defines these ``@njit(cache=True)`` functions.  Arrays are float64;
``p`` holds the parameter values in the order of ``System.parameters``;
``y = [q, q̇]`` is the first-order state; ``W`` is a scratch array of shape
``WORK_SHAPE`` (a module constant; ``new_work()`` or ``Kernels.work_array()``
make one) that the caller allocates once, so no kernel on the hot path
allocates.  Its leading ``(n + m, n + m + 1)`` block holds the augmented
system; the rows below hold the values of the symbolic terms.

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
``particle_positions(q, t, p, out)``                       out (n_particles, 3), zero-padded
=========================================================  ====================================

Integer returns are a status: 0 success, 1 singular (augmented) mass matrix.
Module constants: ``N_DOF``, ``N_CONSTRAINTS``, ``N_PARAMETERS``, ``N_PARTICLES``,
``WORK_SHAPE``, ``BAND`` (half-bandwidth of M).

What is generated, and what is fixed: the generated code evaluates each
*distinct* symbolic term once (common subexpressions removed across all terms
at once with symengine's ``cse``): per particle its mass, Jacobian ∂r/∂q and the
q̈-free part of its acceleration; the rest of F (potential, forces,
dissipation, explicit-Lagrangian terms); Φ_q and γ.  Then, by size:

* small systems (few particle products, n + m ≤ 12): M = Σ m JᵀJ + M' and F
  are assembled in straight-line code, and an unconstrained M (n ≤ 6) is
  solved by an unrolled LDLᵀ, so M and F never leave registers (a double
  pendulum's right-hand side costs what a hand-written one does);
* large systems: index tables say where each term goes, and loops compiled
  once per installation (:mod:`lagrange_core._core_kernels`) assemble M and F;
  a banded mass matrix is solved by a banded LDLᵀ (a chain of beads: O(n)).
  The distinct terms are evaluated by a program whose LLVM IR is written
  directly (:mod:`lagrange_core._ir`), bypassing numba's front end, which costs
  about 3 ms per arithmetic operation of generated source.  Compile time grows
  with the number of distinct terms rather than with n² matrix entries.

The hot kernels (``rhs``, ``solve_state_y``, ``accelerations``) are single
functions: each call between numba functions costs reference-count updates on
its array arguments.  The Jacobian is exact: forward-mode derivatives of the
distinct terms (:func:`lagrange_core._ir.tangent_evaluator`, so ``abs`` and
``sign`` are fine), then of the assembly (``_core_kernels.jacobian_from_values``).
Only ``rhs`` is compiled when the kernels are made; the others compile on first
use (:meth:`Kernels.warm`).

Kernel templates
----------------
Generic numerical algorithms (integrators, Floquet monodromy, ...) are written
once as plain Python functions that call the kernels above by name.
:meth:`Kernels.bind` compiles a copy of such a template module against one
system, so the system's kernels are inlined into the algorithm's loop and the
result is cached on disk like the kernels themselves (numba cannot cache a
function that receives another jitted function as an argument).  A template
module lists its templates in ``KERNEL_TEMPLATES`` and the import lines they
need in ``KERNEL_IMPORTS``; optionally ``KERNEL_JIT_OPTIONS`` maps a template's
name to extra njit options (e.g. ``"parallel=True"`` for a grid loop over ``prange``).

The disk cache
--------------
Generated sources go to ``$LAGRANGE_CORE_CACHE`` (default
``~/.cache/lagrange_core``), one file per system statement, named by a hash of
the statement and of this generator's own source; numba caches the machine
code next to them in ``__pycache__``.  A fresh process with a warm cache loads
both instead of deriving and compiling.
"""
from __future__ import annotations

import ast
import functools
import hashlib
import importlib.util
import inspect
import os
import re
import sys
import tempfile
import textwrap
import types
from pathlib import Path

import numba
import numpy as np
import symengine as se

from . import _ir

__all__ = ["Kernels", "compile_kernels", "cache_dir"]

_ALLOWED_NAMES = {"sin", "cos", "tan", "exp", "log", "sqrt", "asin", "acos", "atan", "atan2",
                  "sinh", "cosh", "tanh", "asinh", "acosh", "atanh", "abs", "pi", "E", "sign"}

_HEADER = '''\
# Generated by lagrange_core.codegen for {label}. Do not edit: regenerated when
# the statement or the generator changes.  Kernel contract: lagrange_core/codegen.py.
import math
import numpy as np
from numba import njit
from numpy import (sin, cos, tan, exp, log, sqrt, arcsin as asin, arccos as acos,
                   arctan as atan, arctan2 as atan2, sinh, cosh, tanh, arcsinh as asinh,
                   arccosh as acosh, arctanh as atanh, pi, e as E, sign)
from lagrange_core._core_kernels import assemble, jacobian_from_values
from lagrange_core._ir import value_evaluator, tangent_evaluator
from lagrange_core._linalg import solve_augmented, solve_dense, solve_banded_spd

N_DOF = {n}
N_CONSTRAINTS = {m}
N_PARAMETERS = {k}
N_PARTICLES = {n_particles}
N_VALUES = {n_values}
N0 = {N}                        # rows of the augmented system; the values start below
WIDTH = {N} + 1
BAND = {band}                   # half-bandwidth of the mass matrix (structural)
WORK_SHAPE = {work_shape!r}
VALUE_WORK_SHAPE = {value_work_shape!r}      # W with the value rows (the Jacobian's scratch)
COORDINATES = {coordinates!r}
PARAMETERS = {parameters!r}
'''


_WRAPPERS = '''

# -- the fixed part --------------------------------------------------------------------

@njit(cache=True)
def new_work():
    return np.zeros(WORK_SHAPE)


# (explicit loops throughout: numba compiles slice assignments slowly)
@njit(cache=True)
def _state(q, qd):
    y = np.empty(2 * N_DOF, dtype=q.dtype)
    for i in range(N_DOF):
        y[i] = q[i]
        y[N_DOF + i] = qd[i]
    return y


@njit(cache=True)
def augmented(q, qd, t, p, W):
    augmented_y(_state(q, qd), t, p, W)


@njit(cache=True)
def solve_state(q, qd, t, p, W):
    return solve_state_y(_state(q, qd), t, p, W)


@njit(cache=True)
def mass_forcing(q, qd, t, p, M, F):
    W = new_work()
    augmented(q, qd, t, p, W)
    for i in range(N_DOF):
        F[i] = W[i, N0]
        for j in range(N_DOF):
            M[i, j] = W[i, j]


@njit(cache=True)
def jacobian(t, y, p, J):
    # forward-mode derivatives of the distinct terms (_ir), then of the assembly
    W = np.zeros(VALUE_WORK_SHAPE)
    dV = np.zeros((N_VALUES, 2 * N_DOF))
    _evaluate_tangents(y, t, p, W, dV)
    return jacobian_from_values(W, dV, P_MASS, P_PTR, P_COL, P_JAC, P_BIAS, F_REST, M_REST,
                                PHI_Q, GAMMA, J)


@njit(cache=True)
def energy(q, qd, t, p):
    W = new_work()
    augmented(q, qd, t, p, W)
    h = _energy_rest(q, qd, t, p)
    for i in range(N_DOF):
        for j in range(N_DOF):
            h += 0.5 * qd[i] * W[i, j] * qd[j]
    return h
'''


def cache_dir() -> Path:
    """Directory of generated kernel modules (``$LAGRANGE_CORE_CACHE`` or ``~/.cache/lagrange_core``)."""
    root = os.environ.get("LAGRANGE_CORE_CACHE") or os.path.join(
        os.environ.get("XDG_CACHE_HOME") or os.path.expanduser("~/.cache"), "lagrange_core")
    path = Path(root) / f"py{sys.version_info.major}{sys.version_info.minor}-numba{numba.__version__}"
    path.mkdir(parents=True, exist_ok=True)
    return path


def source_fingerprint(*modules) -> str:
    """Hash of the code of ``modules``, docstrings and comments excluded.

    Generated modules are cached under a key that includes this hash of the code
    that generates them *and* of the numba functions they call (numba's own cache
    does not notice a change in a callee from another module).  Editing prose
    keeps the cache.
    """
    h = hashlib.sha256()
    for module in modules:
        tree = ast.parse(inspect.getsource(module))
        for node in ast.walk(tree):
            body = getattr(node, "body", None)
            if (isinstance(node, (ast.Module, ast.FunctionDef, ast.ClassDef)) and body
                    and isinstance(body[0], ast.Expr) and isinstance(body[0].value, ast.Constant)
                    and isinstance(body[0].value.value, str)):
                node.body = body[1:] or [ast.Pass()]
        h.update(ast.dump(tree).encode())
    return h.hexdigest()


@functools.cache
def _generator_fingerprint() -> str:
    from . import _core_kernels, _linalg, derive
    return source_fingerprint(sys.modules[__name__], derive, _ir, _linalg, _core_kernels)


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
        from .systems import t
        self.subs[se.sympify(t)] = se.Symbol("t")

    def rename(self, expr):
        return se.sympify(expr).subs(self.subs)

    @staticmethod
    def code(expr) -> str:
        text = str(expr)
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
        lines = []
        for a in arrays:
            lines.extend(self.loads.get(a, []))
        lines += [f"{s} = {self.code(e)}" for s, e in replacements]
        lines += [f"{target} = {self.code(e)}" for (target, _), e in zip(outputs, reduced)]
        return lines


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


#: Up to this many particle products (Σ over particles of nnz(J)·(nnz(J)+3)/2) the assembly
#: of M and F is unrolled into straight-line code (fastest to run; a double pendulum's
#: right-hand side costs about as much as a hand-written one).  Beyond it, fixed loops read
#: index tables, so compile time grows with the number of distinct terms only.
UNROLL_LIMIT = 32

_ACCELERATIONS_FROM_STATE = '''

@njit(cache=True, error_model="numpy")
def accelerations(q, qd, t, p, qdd, lam, W):
    status = solve_state(q, qd, t, p, W)
    for i in range(N_DOF):
        qdd[i] = W[i, N0]
    for i in range(N_CONSTRAINTS):
        lam[i] = W[N_DOF + i, N0]
    return status
'''

_TABLE_CHECK = '''

@njit(cache=True)
def _check_work(W):
    if W.shape[0] < WORK_SHAPE[0] or W.shape[1] != WORK_SHAPE[1]:
        raise ValueError("the scratch array W must have shape WORK_SHAPE (use new_work())")
'''


def _unrolled_assembly(pr, exprs, tables, n, m):
    """Straight-line assembly: (lines computing locals _M{i}_{j} (i ≤ j) and _F{i} from the
    distinct values, lines storing M, F, Φ_q and γ into W)."""
    def u(f):
        return f"_u{f}"

    lines = pr.body([(u(i + 1), e) for i, e in enumerate(exprs)], [], renamed=True)
    M = [[[] for _ in range(n)] for _ in range(n)]
    F = [[] for _ in range(n)]
    for i in range(n):
        if tables["F_REST"][i]:
            F[i].append(u(tables["F_REST"][i]))
        for j in range(n):
            if tables["M_REST"][i][j]:
                M[i][j].append(u(tables["M_REST"][i][j]))
    ptr, col, jac = tables["P_PTR"], tables["P_COL"], tables["P_JAC"]

    def dot(a, b):
        terms = [f"{u(x)}*{u(y)}" for x, y in zip(a, b) if x and y]
        return " + ".join(terms)

    for k, mass in enumerate(tables["P_MASS"]):
        for a in range(ptr[k], ptr[k + 1]):
            i = col[a]
            d = dot(jac[a], tables["P_BIAS"][k])
            if d:
                F[i].append(f"-{u(mass)}*({d})")
            for b in range(a, ptr[k + 1]):
                j = col[b]
                d = dot(jac[a], jac[b])
                if d:
                    M[i][j].append(f"{u(mass)}*({d})")      # j ≥ i: columns ascend
    N = n + m
    for i in range(n):
        lines.append(f"_F{i} = {' + '.join(F[i]) or '0.0'}")
        for j in range(i, n):
            lines.append(f"_M{i}_{j} = {' + '.join(M[i][j]) or '0.0'}")
    store = []
    for i in range(n):
        store.append(f"W[{i}, {N}] = _F{i}")
        for j in range(i, n):
            store.append(f"W[{i}, {j}] = _M{i}_{j}")
            if j > i:
                store.append(f"W[{j}, {i}] = _M{i}_{j}")
    for c in range(m):
        store.append(f"W[{n + c}, {N}] = {u(tables['GAMMA'][c]) if tables['GAMMA'][c] else '0.0'}")
        for j in range(n):
            f = tables["PHI_Q"][c][j]
            store.append(f"W[{n + c}, {j}] = {u(f) if f else '0.0'}")
            store.append(f"W[{j}, {n + c}] = -W[{n + c}, {j}]")
        for d in range(m):
            store.append(f"W[{n + c}, {n + d}] = 0.0")
    return lines, store


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
    ``unroll`` forces straight-line (True) or table-driven (False) assembly instead of
    choosing by size (``UNROLL_LIMIT``).
    """
    system = equations.system
    n, m = system.n_dof, system.n_constraints
    pr = _Printer(system, cse)
    value = _ValueTable(pr)

    def pad3(vec):
        return [value(c) for c in vec] + [0] * (3 - len(vec))

    p_mass, p_ptr, p_col, p_jac, p_bias = [], [0], [], [], []
    for pt in equations.particle_terms:
        p_mass.append(value(pt.mass))
        for j in range(n):
            column = [pt.jacobian[c][j] for c in range(len(pt.bias))]
            if any(e != 0 for e in column):
                p_col.append(j)
                p_jac.append(pad3(column))
        p_ptr.append(len(p_col))
        p_bias.append(pad3(pt.bias))
    m_rest = [[value(e) for e in row] for row in equations.mass_rest_se]
    f_rest = [value(e) for e in equations.forcing_rest_se]
    phi_q = [[value(e) for e in row] for row in equations.constraint_jacobian_se]
    gamma = [value(e) for e in equations.constraint_rhs_se]

    N = n + m
    n_values = len(value.exprs) + 1
    n_products = sum((p_ptr[k + 1] - p_ptr[k]) * (p_ptr[k + 1] - p_ptr[k] + 3) // 2
                     for k in range(len(p_mass)))
    # straight-line code writes every entry of M: bound n too
    unrolled = (n_products <= UNROLL_LIMIT and N <= 12) if unroll is None else unroll
    # half-bandwidth of M (structurally): dense elimination becomes a banded LDLᵀ
    band = max([abs(p_col[a] - p_col[b]) for k in range(len(p_mass))
                for a in range(p_ptr[k], p_ptr[k + 1]) for b in range(a, p_ptr[k + 1])]
               + [abs(i - j) for i in range(n) for j in range(n) if m_rest[i][j]] + [0])
    if m:
        band = n - 1    # the augmented system is solved densely: write all of M
    value_work_shape = (N + -(-n_values // (N + 1)), N + 1)     # N rows, then the values
    work_shape = (N, N + 1) if unrolled else value_work_shape
    src = [_HEADER.format(label=repr(system.name or "a system"), n=n, m=m,
                          k=len(system.parameters), n_particles=len(system.particles),
                          n_values=n_values, work_shape=work_shape, N=N, band=band,
                          value_work_shape=value_work_shape,
                          coordinates=system.coordinates, parameters=system.parameters)]
    tables = dict(P_MASS=p_mass, P_PTR=p_ptr, P_COL=p_col, P_JAC=p_jac, P_BIAS=p_bias,
                  F_REST=f_rest, M_REST=m_rest, PHI_Q=phi_q, GAMMA=gamma)
    src.append("".join(_table(name, rows, {"P_JAC": 3, "P_BIAS": 3, "M_REST": n,
                                             "PHI_Q": n}.get(name))
                       for name, rows in tables.items()))
    # The distinct terms as a program whose LLVM IR is written directly (_ir): numba's
    # front end would take ~3 ms per operation.  Every system's Jacobian differentiates
    # it; large systems also evaluate their values with it.
    program = _ir.build_program(value.exprs, n, len(system.parameters), cse)
    src.append(f"\nPROGRAM = {program!r}\n"
               "_evaluate = value_evaluator(PROGRAM, N0, WIDTH)\n"
               "_evaluate_tangents = tangent_evaluator(PROGRAM, N0, WIDTH)\n")
    if unrolled:
        assembly, store = _unrolled_assembly(pr, value.exprs, tables, n, m)
    else:
        assembly = ["_check_work(W)", "_evaluate(y, t, p, W)",
                    "assemble(W, N0, WIDTH, BAND, P_MASS, P_PTR, P_COL, P_JAC, P_BIAS, F_REST, M_REST, "
                    "PHI_Q, GAMMA)"]
        store = []
        src.append(_TABLE_CHECK)
    # The hot kernels are single straight-line functions: every call between numba
    # functions costs reference-count updates on its array arguments (~10-40 ns).
    from_y = pr.loads["y"] + pr.loads["p"] if unrolled else []
    from_q = pr.loads["q"] + pr.loads["qd"] + pr.loads["p"]
    src.append(_function("augmented_y", ["y", "t", "p", "W"], from_y + assembly + store))
    if unrolled and m == 0 and n <= CHOLESKY_UNROLL_LIMIT:
        # M and F stay in registers; W is not touched on the hot path
        solve = _unrolled_ldlt(n)
        result = [f"_x{i}" for i in range(n)]
        src.append(_function("solve_state_y", ["y", "t", "p", "W"], from_y + assembly + store
                             + solve + [f"W[{i}, {N}] = _x{i}" for i in range(n)], ret="0"))
    else:
        # unrolled systems inline the elimination (constant N); table-driven ones share
        # one compiled copy (W.shape[1] - 1 is N, and not a literal numba would specialise on)
        if unrolled:
            solve = [f"_status = solve_augmented(W, {N})"]
        elif m == 0 and band < n - 1:
            solve = ["_status = solve_banded_spd(W, W.shape[1] - 1, BAND)"]
        else:
            solve = ["_status = solve_dense(W, W.shape[1] - 1)"]
        solve += ["if _status != 0:", "    return _status"]
        result = [f"W[{i}, {N}]" for i in range(n)]
        assembly = assembly + store
        src.append(_function("solve_state_y", ["y", "t", "p", "W"], from_y + assembly + solve,
                             ret="0"))
    if unrolled:
        copy = [f"dydt[{i}] = y[{n + i}]" for i in range(n)]
        copy += [f"dydt[{n + i}] = {r}" for i, r in enumerate(result)]
    else:   # a loop: numba lowers each indexing statement separately (~6 ms each)
        copy = ["for _i in range(N_DOF):", "    dydt[_i] = y[N_DOF + _i]",
                "    dydt[N_DOF + _i] = W[_i, N0]"]
    src.append(_function("rhs", ["t", "y", "p", "dydt", "W"], from_y + assembly + solve + copy,
                         ret="0"))
    if unrolled:
        lam = [f"lam[{c}] = W[{n + c}, {N}]" for c in range(m)]
        src.append(_function("accelerations", ["q", "qd", "t", "p", "qdd", "lam", "W"],
                             from_q + assembly + solve
                             + [f"qdd[{i}] = {r}" for i, r in enumerate(result)] + lam, ret="0"))
    else:
        src.append(_ACCELERATIONS_FROM_STATE)
    src.append(_function("_energy_rest", ["q", "qd", "t", "p"],
                         pr.body([("_h", equations.energy_rest_se)], ["q", "qd", "p"]), ret="_h"))
    res = [(f"out[{k}]", c) for k, c in enumerate(equations.constraints_se)]
    res += [(f"out[{m + k}]", c) for k, c in enumerate(equations.constraint_velocity_se)]
    src.append(_function("constraint_residual", ["q", "qd", "t", "p", "out"],
                         pr.body(res, ["q", "qd", "p"])))
    positions = [(f"out[{i}, {c}]", comp) for i, particle in enumerate(system.particles)
                 for c, comp in enumerate(particle.position)]
    src.append(_function("particle_positions", ["q", "t", "p", "out"],
                         ["for _i in range(out.shape[0]):", "    for _c in range(out.shape[1]):",
                          "        out[_i, _c] = 0.0"] + pr.body(positions, ["q", "p"])))
    src.append(_WRAPPERS)
    return "".join(src)


# -- loading --------------------------------------------------------------------------

def write_module(path: Path, text: str) -> None:
    """Write a generated module atomically (concurrent processes never see half a file)."""
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=".tmp-", suffix=".py")
    with os.fdopen(fd, "w") as fh:
        fh.write(text)
    os.replace(tmp, path)


def load_module(path: Path, name: str) -> types.ModuleType:
    """Import a generated module file under ``name`` (once per process)."""
    if name in sys.modules:
        return sys.modules[name]
    spec = importlib.util.spec_from_file_location(name, path)
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module
    try:
        spec.loader.exec_module(module)
    except BaseException:
        del sys.modules[name]
        raise
    return module


_KERNEL_NAMES = ("new_work", "mass_forcing", "augmented", "solve_state", "accelerations", "rhs", "jacobian",
                 "energy", "constraint_residual", "particle_positions")


class Kernels:
    """The compiled kernels of one system (see the module docstring for the contract).

    Attributes are numba dispatchers, callable from Python and from other
    numba code: ``mass_forcing``, ``augmented``, ``solve_state``,
    ``accelerations``, ``rhs``, ``jacobian``, ``energy``,
    ``constraint_residual``, ``particle_positions``.
    """

    def __init__(self, module: types.ModuleType, path: Path):
        self.module = module
        self.path = path
        self.n_dof = module.N_DOF
        self.n_constraints = module.N_CONSTRAINTS
        self.n_particles = module.N_PARTICLES
        self.parameters = module.PARAMETERS
        self.coordinates = module.COORDINATES
        for name in _KERNEL_NAMES:
            setattr(self, name, getattr(module, name))
        self._bound = {}

    def work_array(self) -> np.ndarray:
        """A fresh scratch array ``W`` of the shape the kernels expect."""
        return np.zeros(self.module.WORK_SHAPE)

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
            self.particle_positions(q, 0.0, p, np.zeros((self.n_particles, 3)))
        return self

    def bind(self, template_module: types.ModuleType) -> types.ModuleType:
        """Compile the kernel templates of ``template_module`` against this system.

        Returns a module whose functions are the templates as ``@njit(cache=True)``
        kernels that call this system's kernels; the generated file is cached on
        disk next to the system's own.
        """
        key = template_module.__name__
        if key not in self._bound:
            self._bound[key] = _bind(self, template_module)
        return self._bound[key]


def _template_source(template_module) -> str:
    parts = [f"# templates from {template_module.__name__}\n",
             textwrap.dedent(getattr(template_module, "KERNEL_IMPORTS", "")), "\n"]
    # optional extra njit options per template, e.g. {"grid_kernel": "parallel=True"}
    options = getattr(template_module, "KERNEL_JIT_OPTIONS", {})
    for fn in template_module.KERNEL_TEMPLATES:
        src = textwrap.dedent(inspect.getsource(fn))
        src = "\n".join(line for line in src.splitlines() if not line.startswith("@"))
        extra = options.get(fn.__name__, "")
        parts.append(f"\n\n@njit(cache=True{', ' + extra if extra else ''})\n{src}\n")
    return "".join(parts)


def _bind(kernels: Kernels, template_module) -> types.ModuleType:
    core_name = kernels.module.__name__
    body = _template_source(template_module)
    header = (f"# Generated by lagrange_core.codegen: {template_module.__name__} bound to "
              f"{core_name}. Do not edit.\nimport math\nimport numpy as np\n"
              f"from numba import njit\nfrom {core_name} import *\n"
              f"")
    text = header + body
    digest = hashlib.sha256(text.encode()).hexdigest()[:16]
    name = f"{core_name}__{template_module.__name__.replace('.', '_')}_{digest}"
    path = kernels.path.parent / f"{name}.py"
    if not path.exists():
        write_module(path, text)
    return load_module(path, name)


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
        With ``rhs`` compiled for float64 arrays; the other kernels compile on
        first use (:meth:`Kernels.warm`).
    """
    from .derive import Equations
    if isinstance(system, Equations):
        equations, system = system, system.system
    else:
        equations = None
    key = hashlib.sha256((_generator_fingerprint() + system.statement_key()).encode()).hexdigest()
    name = f"_lc_{key[:20]}"
    path = cache_dir() / f"{name}.py"
    if not path.exists():
        equations = equations if equations is not None else system.equations
        write_module(path, generate_source(equations))
    return Kernels(load_module(path, name), path).warm()
