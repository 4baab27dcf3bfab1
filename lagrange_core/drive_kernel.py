"""A specialised kernel for q̈ = f(q, t) with a harmonic drive (the *drive kernel*).

Why
---
For the driven pendulum the cost of a Runge–Kutta–Nyström stage is the
evaluation of f: sin θ and cos ωt.  The generic kernels assemble M and F and
solve the augmented system at every stage.  Here the accelerations are
generated once more, from the same derived equations, in the form

    q̈ = f(q, t; C_k, S_k),   C_k = cos(α_k t),  S_k = sin(α_k t),

where every sin/cos whose argument is linear in t (α_k t + β) is rewritten with
the addition theorem (the α_k, β may be parameter expressions).  Inside a step
of size h the drive at t + c_i h is a *rotation* of (C_k, S_k) by α_k c_i h;
at a fixed step size the rotations are computed once, so a stage costs the
q-dependent terms only (for the pendulum: one sin θ).  For one degree of
freedom f = F/M is simplified symbolically (M = m l² (cos² + sin²) → m l²);
with more, M and F are evaluated and solved numerically.

The RKN and symplectic drivers of :mod:`lagrange_core._integrator_kernels` call it
through its C entry points (slots ``fast_accel`` and ``drive_rates`` of the system's
address table).  The generated module (source + numba machine code) lives in the one
store (:mod:`lagrange_core.module_store`), keyed by the statement and this generator's
code.

Accuracy: identical formulas; the rotation adds a relative rounding error of a
few ulps per stage (the base (C_k, S_k) is recomputed exactly at every step, so
nothing accumulates).
"""
from __future__ import annotations

import functools
import sys
import textwrap

import sympy as sp

from ._kernel_calls import FAST_ACCEL, FAST_ACCEL_LANES, MAX_DRIVE_RATES
from ._lane_calls import left_to_scalar_source
from .module_store import content_key, load_generated, source_fingerprint

__all__ = ["load_drive_kernel"]


def _linear_in_t(arg, t, qset):
    if not arg.has(t):
        return None
    alpha = sp.diff(arg, t)
    if alpha.has(t) or alpha.free_symbols & qset:
        return None
    beta = sp.expand(arg - alpha * t)
    if beta.has(t) or beta.free_symbols & qset:
        return None
    return alpha, beta


def _drive_substitution(exprs, t, qset):
    """Replace sin/cos(α t + β) by C_k, S_k; returns new exprs and the list of α_k."""
    alphas, syms, repl = [], [], {}
    for e in exprs:
        for atom in e.atoms(sp.sin, sp.cos):
            if atom in repl:
                continue
            lin = _linear_in_t(atom.args[0], t, qset)
            if lin is None:
                continue
            alpha, beta = lin
            k = next((i for i, a in enumerate(alphas) if sp.simplify(a - alpha) == 0), None)
            if k is None:
                k = len(alphas)
                alphas.append(alpha)
                syms.append((sp.Symbol(f"_C{k}"), sp.Symbol(f"_S{k}")))
            C, S = syms[k]
            if isinstance(atom, sp.cos):
                repl[atom] = C * sp.cos(beta) - S * sp.sin(beta)
            else:
                repl[atom] = S * sp.cos(beta) + C * sp.sin(beta)
    return [e.xreplace(repl) for e in exprs], alphas


# numpy error model (no zero-division branch) and fused multiply-adds; no reassociation
# (it would delete the compensated sums) and no finite-math flags,
# so the NaN/inf checks of the loop stay meaningful.
_JIT = '@njit(cache=True, error_model="numpy", fastmath={"contract", "arcp", "nsz"})'


def _print(expr):
    return sp.pycode(expr, fully_qualified_modules=True, standard="python3")


def _generated_source(eq) -> str:
    from .symbols import t as t_sym
    system = eq.system
    n = system.n_dof
    # symengine -> sympy loses assumptions: map every symbol back by name
    by_name = {s.name: s for s in (*system.q, *system.parameter_symbols, t_sym)}
    by_name.update({v.name: sp.S.Zero for v in system.qdot})

    def back(e):
        e = sp.sympify(e)
        return e.xreplace({s: by_name[s.name] for s in e.free_symbols if s.name in by_name})

    M = [[back(eq.mass_matrix_se[i][j]) for j in range(n)] for i in range(n)]
    F = [back(eq.forcing_se[i]) for i in range(n)]
    qset = set(system.q)
    if n == 1:
        m00 = sp.trigsimp(M[0][0])
        exprs = [sp.cancel(sp.expand(F[0]) / m00)]
    else:
        exprs = [sp.trigsimp(M[i][j]) if sp.count_ops(M[i][j]) < 200 else M[i][j]
                 for i in range(n) for j in range(i, n)] + F
    exprs, alphas = _drive_substitution(exprs, t_sym, qset)
    if len(alphas) > MAX_DRIVE_RATES:
        raise ValueError(f"the drive of {system._label()} has {len(alphas)} distinct harmonic "
                         f"rates; the RKN drivers take at most {MAX_DRIVE_RATES}. Use "
                         "method='dop853'.")
    ren = {}
    loads = []
    lane_loads = []
    for i, s in enumerate(system.q):
        ren[s] = sp.Symbol(f"_q{i}")
        loads.append(f"_q{i} = q[{i}]")
        lane_loads.append(f"_q{i} = q[{i}, l]")
    for i, s in enumerate(system.parameter_symbols):
        ren[s] = sp.Symbol(f"_p{i}")
        loads.append(f"_p{i} = p[{i}]")
        lane_loads.append(f"_p{i} = p[{i}, l]")
    for k in range(len(alphas)):
        loads.append(f"_C{k} = cs[{2 * k}]")
        loads.append(f"_S{k} = cs[{2 * k + 1}]")
        lane_loads.append(f"_C{k} = cs[{2 * k}, l]")
        lane_loads.append(f"_S{k} = cs[{2 * k + 1}, l]")
    lane_loads.append("t = tl[l]")
    ren[t_sym] = sp.Symbol("t")
    exprs = [e.xreplace(ren) for e in exprs]
    reps, reduced = sp.cse(exprs, symbols=sp.numbered_symbols("_x"))
    terms = [f"{_print(s)} = {_print(e)}" for s, e in reps]
    results = [_print(r) for r in reduced]
    # a sparse [M | F] (a string of beads: 380 of 420 entries zero) is zeroed by a loop and
    # only its other entries are written: each statement costs numba ~6 ms to compile
    sparse = n > 1 and sum(r == "0" for r in results) > 2 * n
    body = list(loads) + terms
    if n == 1:
        body.append(f"out[0] = {results[0]}")
    else:
        if sparse:
            body += [f"for _i in range({n}):", f"    for _j in range({n + 1}):",
                     "        Wn[_i, _j] = 0.0"]
        body += _augmented_entries(n, results, lambda i, j: f"Wn[{i}, {j}]", sparse)
        body.append(f"status = solve_augmented(Wn, {n})")
        body += [f"out[{i}] = Wn[{i}, {n}]" for i in range(n)]
        body.append("return status")
    if n == 1:
        body.append("return 0")
    src = [f"N_DOF = {n}", f"N_DRIVE = {len(alphas)}",
           f"N_PARAMETERS = {len(system.parameter_symbols)}", f"WORK_ROWS = {1 + n * (n + 1)}",
           "", "", _JIT, "def fast_accel(q, t, cs, p, out, Wn):",
           textwrap.indent("\n".join(body), "    "), "", "",
           "@njit(cache=True)", "def drive_rates(p, out):"]
    rl = [f"_p{i} = p[{i}]" for i in range(len(system.parameter_symbols))]
    rl += [f"out[{k}] = {_print(a.xreplace(ren))}" for k, a in enumerate(alphas)]
    rl.append("return 0")
    src.append(textwrap.indent("\n".join(rl), "    "))
    src += ["", "", _lanes_source(n, lane_loads, terms, results, sparse)]
    return "\n".join(src) + "\n"


def _augmented_entries(n, results, cell, skip_zeros=False):
    """Lines that fill [M | F] (n > 1) from ``results`` (M's upper triangle row by row, then
    F), mirroring M; ``cell(i, j)`` names entry (i, j) of the target.  ``skip_zeros``: no
    line for an entry that is zero (the caller has zeroed the target)."""
    lines = []
    k = 0
    for i in range(n):
        for j in range(i, n):
            if not (skip_zeros and results[k] == "0"):
                lines.append(f"{cell(i, j)} = {results[k]}")
                if j != i:
                    lines.append(f"{cell(j, i)} = {cell(i, j)}")
            k += 1
    lines += [f"{cell(i, n)} = {results[k + i]}" for i in range(n)
              if not (skip_zeros and results[k + i] == "0")]
    return lines


def _lane_code(line):
    """A generated line with sin/cos on the lane functions (vectorisable; NaN beyond
    their range, which sends the lane to the scalar kernel)."""
    return line.replace("math.sin(", "lane_sin(").replace("math.cos(", "lane_cos(")


def _lanes_source(n, lane_loads, terms, results, sparse=False):
    """``fast_accel_lanes``: the same formulas in a loop over lanes (the contract in
    :mod:`lagrange_core._kernel_calls`).  One system of L lanes per call; the loop body has
    no calls, so LLVM vectorises it.  n > 1: M and F go to ``work`` and
    :func:`lagrange_core._lane_math.lane_solve` solves every lane at once.  A lane whose
    result is not finite (an argument beyond the lane sine's range, a pivot too small
    for elimination without pivoting, a state that is not finite) is left to the scalar
    ``fast_accel``: marked 1.0 in ``work[0]`` and counted in the return value
    (:mod:`lagrange_core._lane_calls` computes it again; no scalar copy is compiled into
    this kernel)."""
    w = n + 1
    loop = list(lane_loads) + [_lane_code(line) for line in terms]
    zero = []
    if n == 1:
        loop.append(f"out[0, l] = {_lane_code(results[0])}")
        solve = []
    else:
        loop += _augmented_entries(n, [_lane_code(r) for r in results],
                                   lambda i, j: f"work[{1 + i * w + j}, l]", sparse)
        if sparse:
            zero = [f"for _r in range(1, {1 + n * w}):", "    for l in range(L):",
                    "        work[_r, l] = 0.0"]
        solve = [f"lane_solve(work, {n}, L)", "for l in range(L):"]
        solve += [f"    out[{i}, l] = work[{1 + i * w + n}, l]" for i in range(n)]
    # a lane not answered: a result not finite, or (n > 1) lane_solve's flag
    failed = [f"(not math.isfinite(out[{i}, l]))" for i in range(n)]
    check = left_to_scalar_source(failed + (["(work[0, l] != 0.0)"] if n > 1 else []))
    body = zero + ["for l in range(L):", textwrap.indent("\n".join(loop), "    ")] + solve \
        + check
    return "\n".join([_JIT, "def fast_accel_lanes(q, tl, cs, p, out, work, L):",
                      textwrap.indent("\n".join(body), "    ")])


_HEADER = """\
# Generated by lagrange_core.drive_kernel for {label}. Do not edit.
import math
import numpy as np
from numba import carray, njit
from lagrange_core._lane_math import lane_cos, lane_sin, lane_solve
from lagrange_core._linalg import solve_augmented

"""

_ENTRY_POINTS = """

# -- C entry points (lagrange_core._kernel_calls) ---------------------------------------

def c_fast_accel(q, t, cs, p, out, Wn):
    return fast_accel(carray(q, (N_DOF,)), t, carray(cs, (max(2 * N_DRIVE, 1),)),
                      carray(p, (N_PARAMETERS,)), carray(out, (N_DOF,)),
                      carray(Wn, (N_DOF, N_DOF + 1)))


def c_drive_rates(p, out):
    drive_rates(carray(p, (N_PARAMETERS,)), carray(out, (max(N_DRIVE, 1),)))
    return N_DRIVE


def c_fast_accel_lanes(q, t, cs, p, out, work, L):
    return fast_accel_lanes(carray(q, (N_DOF, L)), carray(t, (L,)),
                            carray(cs, (max(2 * N_DRIVE, 1), L)), carray(p, (N_PARAMETERS, L)),
                            carray(out, (N_DOF, L)), carray(work, (WORK_ROWS, L)), L)
"""


@functools.cache
def _generator_fingerprint() -> str:
    from . import _lane_calls, _lane_math, _linalg
    return source_fingerprint(sys.modules[__name__], _linalg, _lane_math, _lane_calls)


def load_drive_kernel(kernels, *, lanes: bool = False) -> None:
    """Generate (or load from the store) the drive kernel of an RKN-form system and put its
    C entry points into ``kernels``' address table (slots ``fast_accel``, ``drive_rates``,
    and with ``lanes`` also ``fast_accel_lanes``, which compiles only when asked for).

    Parameters
    ----------
    kernels : lagrange_core.codegen.Kernels
        Of a system with ``kernels.rkn_form`` true; the equations are derived (by
        ``kernels.equations()``) only when the store has no drive kernel for the statement.
    lanes : bool
        Also the entry point for many trajectories per call (the batch integrator's).

    Raises
    ------
    ValueError
        If the system is not of the form q̈ = f(q, t), or its drive has more than
        ``MAX_DRIVE_RATES`` distinct harmonic rates.
    """
    if not kernels.rkn_form:
        raise ValueError(f"{kernels.label} is not of the form q̈ = f(q, t): "
                         f"{kernels.rkn_reason}.")
    table = kernels.addresses()
    names = [name for name, slot in (("fast_accel", FAST_ACCEL), ("drive_rates", FAST_ACCEL),
                                     ("fast_accel_lanes", FAST_ACCEL_LANES))
             if not table[slot] and (lanes or slot != FAST_ACCEL_LANES)]
    if not names:
        return
    key = content_key(_generator_fingerprint(), kernels.statement_key)
    module = load_generated("_lcdrive", key, lambda: _HEADER.format(label=repr(kernels.label))
                            + _generated_source(kernels.equations()) + _ENTRY_POINTS)
    kernels.load_entry_points(module, names)   # together: fast_accel's slot says drive_rates
