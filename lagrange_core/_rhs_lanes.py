"""A first-order system's right-hand side on *lanes*, and its product with the Jacobian.

Why
---
The scalar ``rhs`` of :mod:`lagrange_core.codegen` is bound by libm: the damped driven
pendulum's calls ``sin θ``, ``cos θ`` and ``cos ωt`` each time (37 % of the samples of a
chaos map, benchmarks/README.md), and a call for one state cannot overlap the next.
Here the same equations are generated once more as a loop over L states (*lanes*, the
last axis of every array) whose body has no calls: sin and cos are the branch-free
polynomials of :mod:`lagrange_core._lane_math`, so LLVM vectorises the loop (as the drive
kernel's ``fast_accel_lanes`` of the RKN path).  Two entry points (the contract of
:mod:`lagrange_core._kernel_calls`, slots ``rhs_lanes`` and ``rhs_jvp_lanes``):

``rhs_lanes(t, y, p, dydt, work, L)``
    dy/dt = [q̇, q̈(q, q̇, t)] for every lane.
``rhs_jvp_lanes(t, y, v, p, dydt, jv, work, L)``
    The same and jv = J v, J = ∂(dy/dt)/∂y, for a direction v per lane: forward-mode
    derivatives of the generated formulas in the direction v (one symbolic directional
    derivative, common subexpressions shared with dy/dt: sin θ, cos ωt, ... once), so
    the tangent of Benettin's method costs a fraction of a second evaluation and is
    exact, not a difference quotient.

The formulas
------------
From the derived equations M(q, t) q̈ = F(q, q̇, t) (sympy, as the drive kernel): for one
coordinate q̈ = F/M simplified symbolically (cos² + sin² → 1), with M's value kept to
flag a lane whose M is not positive (singular); for more, M and F per lane, solved on
the lanes by :func:`lagrange_core._lane_math.lane_solve` (elimination without pivoting,
a bad pivot flagged) and, for J v, M δq̈ = δF − δM q̈ by the same factors
(:func:`lane_resolve`).

Failure and fallback: a lane whose result is not finite (an argument beyond the lane
sine's range, a state that is not finite, a division by zero) or whose M was flagged is
left: marked in ``work[0]`` and counted in the return value, it is computed again by the
system's scalar ``rhs`` (and ``jacobian`` for J v; libm, partial pivoting) in
:mod:`lagrange_core._lane_calls`, whose status (0, 1: singular) it gets; the other lanes
keep their values.  (No scalar copy is compiled into these kernels: a new system's
lanes kernels compile in 0.5–0.6 of the time they took with one; benchmarks/README.md.)

Accuracy: the same formulas as the scalar kernels up to rearrangement by the symbolic
simplification; sin/cos within 2 ulp of libm.  Results agree with ``rhs`` to a few ulps
of the terms' size (tests/test_first_order_lanes.py).

Which systems: unconstrained, at most :data:`MAX_DOF` coordinates, equations of at most
:data:`MAX_OPERATIONS` operations after common subexpressions are removed (beyond that
numba's compile time, ~3 ms per operation, outweighs the gain; the callers then use the
scalar path).  :func:`load_rhs_lanes` says which.
"""
from __future__ import annotations

import functools
import re
import sys
import textwrap

import numpy as np
import sympy as sp
from numba import njit

from ._first_calls import guard
from ._kernel_calls import RHS_JVP_LANES, RHS_LANES
from ._lane_calls import left_to_scalar_source, rhs_jvp_on_lanes, rhs_on_lanes
from .module_store import content_key, load_generated, source_fingerprint

__all__ = ["load_rhs_lanes", "evaluate_lanes", "lanes_work_rows", "MAX_DOF", "MAX_OPERATIONS"]

#: the largest number of coordinates the lanes kernels are generated for
MAX_DOF = 6
#: the largest number of operations (after CSE) of the generated formulas
MAX_OPERATIONS = 1500

_FM = {"contract", "arcp", "nsz"}
_JIT = '@njit(cache=True, error_model="numpy", fastmath={"contract", "arcp", "nsz"})'


def lanes_work_rows(n: int) -> int:
    """Rows of the ``work`` array of the lanes kernels of an n-coordinate system: the
    status row, [M | F] and [δM | δF]."""
    return 1 + 2 * n * (n + 1)


@njit(cache=True, fastmath=_FM, error_model="numpy")
def lane_resolve(work, n, r0, L):
    """Solve M x = b in every lane with the factors :func:`lane_solve` left in ``work``.

    ``b`` is in rows r0 … r0 + n − 1 (lanes last) and is overwritten by x.  The factors:
    rows 1 + i(n + 1) + j hold the multipliers l_ij (j < i), U_ij (j > i) and 1/U_ii."""
    w = n + 1
    for k in range(n):
        for i in range(k + 1, n):
            ri = 1 + i * w
            for l in range(L):
                work[r0 + i, l] -= work[ri + k, l] * work[r0 + k, l]
    for i in range(n - 1, -1, -1):
        ri = 1 + i * w
        for j in range(i + 1, n):
            for l in range(L):
                work[r0 + i, l] -= work[ri + j, l] * work[r0 + j, l]
        for l in range(L):
            work[r0 + i, l] *= work[ri + i, l]


# -- generation ----------------------------------------------------------------------------

def _print(expr):
    return sp.pycode(expr, fully_qualified_modules=True, standard="python3")


def _lane_code(line):
    """A generated line with sin/cos on the lane functions (vectorisable; NaN beyond
    their range, which sends the lane to the scalar kernels)."""
    return line.replace("math.sin(", "lane_sin(").replace("math.cos(", "lane_cos(")


def _formulas(eq):
    """(outputs, derivatives, n, symbols): the expressions of q̈ (n = 1: [F/M, M]; else M's
    upper triangle row by row, then F) and of their directional derivatives in the
    direction (δq, δq̇), renamed to kernel locals."""
    from .symbols import t as t_sym
    system = eq.system
    n = system.n_dof
    by_name = {s.name: s for s in (*system.q, *system.qdot, *system.parameter_symbols, t_sym)}

    def back(e):
        e = sp.sympify(e)
        return e.xreplace({s: by_name[s.name] for s in e.free_symbols if s.name in by_name})

    M = [[back(eq.mass_matrix_se[i][j]) for j in range(n)] for i in range(n)]
    F = [back(eq.forcing_se[i]) for i in range(n)]
    ren = {}
    for i, s in enumerate(system.q):
        ren[s] = sp.Symbol(f"_q{i}")
    for i, s in enumerate(system.qdot):
        ren[s] = sp.Symbol(f"_v{i}")
    for i, s in enumerate(system.parameter_symbols):
        ren[s] = sp.Symbol(f"_p{i}")
    ren[t_sym] = sp.Symbol("t")
    if n == 1:
        m00 = sp.trigsimp(M[0][0])
        exprs = [sp.cancel(sp.expand(F[0]) / m00), m00]
    else:
        exprs = [sp.trigsimp(M[i][j]) if sp.count_ops(M[i][j]) < 200 else M[i][j]
                 for i in range(n) for j in range(i, n)] + F
    exprs = [e.xreplace(ren) for e in exprs]
    y = [sp.Symbol(f"_q{i}") for i in range(n)] + [sp.Symbol(f"_v{i}") for i in range(n)]
    dy = [sp.Symbol(f"_dq{i}") for i in range(n)] + [sp.Symbol(f"_dv{i}") for i in range(n)]
    # the directional derivative of what the solve needs (n = 1: q̈ itself; M's value is
    # a check, not differentiated)
    differentiated = exprs[:1] if n == 1 else exprs
    # (by the variables each expression has: a zero entry of M, or one with few of them,
    # skips the 2n differentiations that give zero — 60 beads: 227 000 diff calls, 11 s)
    derivs = []
    for e in differentiated:
        has = e.free_symbols
        derivs.append(sp.Add(*[sp.diff(e, yi) * di for yi, di in zip(y, dy, strict=True)
                               if yi in has]))
    return exprs, derivs, n


def _loads(n, k, jvp):
    lines = [f"_q{i} = y[{i}, l]" for i in range(n)]
    lines += [f"_v{i} = y[{n + i}, l]" for i in range(n)]
    if jvp:
        lines += [f"_dq{i} = v[{i}, l]" for i in range(n)]
        lines += [f"_dv{i} = v[{n + i}, l]" for i in range(n)]
    lines += [f"_p{i} = p[{i}, l]" for i in range(k)]
    lines.append("t = tl[l]")
    return lines


def _used(lines, loads):
    """The loads whose locals ``lines`` use (numba compiles each indexing statement)."""
    text = "\n".join(lines)
    out = []
    for load in loads:
        name = load.split(" = ")[0]
        if name == "t" or re.search(rf"\b{name}\b", text):
            out.append(load)
    return out


def _kernel(n, exprs, derivs, jvp):
    """The body of the lanes loop: results to dydt/jv (n = 1) or to ``work`` ([M | F] in
    rows 1 … n(n + 1), δM and δF after them), solved after the loop."""
    outs = list(exprs) + (list(derivs) if jvp else [])
    reps, reduced = sp.cse(outs, symbols=sp.numbered_symbols("_x"))
    body = [_lane_code(f"{_print(s)} = {_print(e)}") for s, e in reps]
    res = [_lane_code(_print(r)) for r in reduced]
    w = n + 1
    nm = n * (n + 1) // 2
    if n == 1:
        body.append("dydt[0, l] = _v0")
        body.append(f"dydt[1, l] = {res[0]}")
        if jvp:
            body.append("jv[0, l] = _dv0")
            body.append(f"jv[1, l] = {res[2]}")
        body.append(f"work[0, l] = 0.0 if {res[1]} > 0.0 else 1.0")
        return body

    def fill(target, values):
        lines = []
        m = 0
        for i in range(n):
            for j in range(i, n):
                lines.append(f"{target(i, j)} = {values[m]}")
                if j != i:
                    lines.append(f"{target(j, i)} = {target(i, j)}")
                m += 1
        return lines

    body += fill(lambda i, j: f"work[{1 + i * w + j}, l]", res[:nm])
    body += [f"work[{1 + i * w + n}, l] = {res[nm + i]}" for i in range(n)]
    if jvp:
        d = res[nm + n:]
        body += fill(lambda i, j: f"work[{1 + n * w + i * n + j}, l]", d[:nm])
        body += [f"work[{1 + n * w + n * n + i}, l] = {d[nm + i]}" for i in range(n)]
    return body


def _lanes_function(name, n, k, exprs, derivs, jvp):
    args = "tl, y, v, p, dydt, jv, work, L" if jvp else "tl, y, p, dydt, work, L"
    body = _kernel(n, exprs, derivs, jvp)
    loop = _used(body, _loads(n, k, jvp)) + body
    lines = ["for l in range(L):", textwrap.indent("\n".join(loop), "    ")]
    w = n + 1
    if n > 1:
        lines.append(f"lane_solve(work, {n}, L)")
        lines.append("for l in range(L):")
        lines += [f"    dydt[{i}, l] = y[{n + i}, l]" for i in range(n)]
        lines += [f"    dydt[{n + i}, l] = work[{1 + i * w + n}, l]" for i in range(n)]
        if jvp:
            # δF − δM q̈ into the δF rows, then the same factors
            r0 = 1 + n * w + n * n
            lines.append("for l in range(L):")
            for i in range(n):
                sub = " - ".join([f"work[{r0 + i}, l]"]
                                 + [f"work[{1 + n * w + i * n + j}, l] * dydt[{n + j}, l]"
                                    for j in range(n)])
                lines.append(f"    _r{i} = {sub}")
            lines += [f"    work[{r0 + i}, l] = _r{i}" for i in range(n)]
            lines.append(f"lane_resolve(work, {n}, {r0}, L)")
            lines.append("for l in range(L):")
            lines += [f"    jv[{i}, l] = v[{n + i}, l]" for i in range(n)]
            lines += [f"    jv[{n + i}, l] = work[{r0 + i}, l]" for i in range(n)]
    failed = [f"(not math.isfinite(dydt[{n + i}, l]))" for i in range(n)]
    if jvp:
        failed += [f"(not math.isfinite(jv[{n + i}, l]))" for i in range(n)]
    check = left_to_scalar_source(failed + ["(work[0, l] != 0.0)"])
    return "\n".join([_JIT, f"def {name}({args}):",
                      textwrap.indent("\n".join(lines + check), "    ")])


_ENTRY_POINTS = '''

# -- C entry points (lagrange_core._kernel_calls) ---------------------------------------

def c_rhs_lanes(t, y, p, dydt, work, L):
    return rhs_lanes(carray(t, (L,)), carray(y, (2 * N_DOF, L)),
                     carray(p, (max(N_PARAMETERS, 1), L)), carray(dydt, (2 * N_DOF, L)),
                     carray(work, (WORK_ROWS, L)), L)


def c_rhs_jvp_lanes(t, y, v, p, dydt, jv, work, L):
    return rhs_jvp_lanes(carray(t, (L,)), carray(y, (2 * N_DOF, L)), carray(v, (2 * N_DOF, L)),
                         carray(p, (max(N_PARAMETERS, 1), L)), carray(dydt, (2 * N_DOF, L)),
                         carray(jv, (2 * N_DOF, L)), carray(work, (WORK_ROWS, L)), L)
'''

_HEADER = """\
# Generated by lagrange_core._rhs_lanes for {label}. Do not edit.
import math
import numpy as np
from numba import carray, njit
from lagrange_core._lane_math import lane_cos, lane_sin, lane_solve
from lagrange_core._rhs_lanes import lane_resolve

N_DOF = {n}
N_PARAMETERS = {k}
WORK_ROWS = {rows}
LANES_OK = {ok!r}
LANES_REASON = {reason!r}
"""


def _generated_source(eq, label) -> str:
    system = eq.system
    n, m, k = system.n_dof, len(eq.constraints_se), len(system.parameter_symbols)
    head = dict(label=repr(label), n=n, k=k, rows=lanes_work_rows(n))
    if m:
        return _HEADER.format(ok=False, reason="it has constraints", **head)
    if n > MAX_DOF:
        return _HEADER.format(ok=False, reason=f"it has {n} coordinates (lanes: at most "
                              f"{MAX_DOF})", **head)
    exprs, derivs, n = _formulas(eq)
    reps, reduced = sp.cse(list(exprs) + list(derivs))
    size = sum(sp.count_ops(e) for _, e in reps) + sum(sp.count_ops(e) for e in reduced)
    if size > MAX_OPERATIONS:
        return _HEADER.format(ok=False, reason=f"its equations have {size} operations (lanes: "
                              f"at most {MAX_OPERATIONS})", **head)
    src = [_HEADER.format(ok=True, reason="", **head), "",
           _lanes_function("rhs_lanes", n, k, exprs, derivs, False), "", "",
           _lanes_function("rhs_jvp_lanes", n, k, exprs, derivs, True), _ENTRY_POINTS]
    return "\n".join(src)


@functools.cache
def _generator_fingerprint() -> str:
    from . import _kernel_calls, _lane_calls, _lane_math
    return source_fingerprint(sys.modules[__name__], _lane_math, _kernel_calls, _lane_calls)


def load_rhs_lanes(kernels, *, jvp: bool = False) -> tuple[bool, str]:
    """Generate (or load from the store) the lanes kernels of a system and put their C
    entry points into ``kernels``' address table: slot ``rhs_lanes``, and ``rhs_jvp_lanes``
    with ``jvp``.

    Parameters
    ----------
    kernels : lagrange_core.codegen.Kernels
        The equations are derived (``kernels.equations()``) only when the store has no
        lanes module for the statement.
    jvp : bool
        Also the Jacobian–vector kernel (Lyapunov's tangents).  Each is compiled only when
        asked for (cold, 1–7 s each): the strobe runs of a bifurcation diagram, a section
        or a basin never wait for the tangent kernel they do not call.

    Returns
    -------
    (ok, reason)
        ``ok`` False (and why, e.g. "it has constraints") when the system gets no lanes
        kernels: callers then take the scalar path.  Nothing is compiled twice: the
        answer and the machine code are cached with the module.
    """
    table = kernels.addresses()
    if table[RHS_LANES] and (table[RHS_JVP_LANES] or not jvp):
        return True, ""
    # the cheap refusals first: no derivation, no module
    if kernels.n_constraints:
        return False, "it has constraints"
    if kernels.n_dof > MAX_DOF:
        return False, f"it has {kernels.n_dof} coordinates (lanes: at most {MAX_DOF})"
    key = content_key(_generator_fingerprint(), kernels.statement_key)
    module = load_generated("_lclanes", key,
                            lambda: _generated_source(kernels.equations(), kernels.label))
    if not module.LANES_OK:
        return False, module.LANES_REASON
    # the scalar kernels that compute a lane the lanes kernels leave (lagrange_core._lane_calls)
    kernels.addresses("rhs", *(("jacobian",) if jvp else ()))
    wanted = [("rhs_lanes", RHS_LANES)] + ([("rhs_jvp_lanes", RHS_JVP_LANES)] if jvp else [])
    kernels.load_entry_points(module, [name for name, slot in wanted if not table[slot]])
    return True, ""


@njit(cache=True)
def _evaluate(ka, jvp, t, y, v, p, dydt, jv, work):
    L = t.shape[0]
    if jvp:
        return rhs_jvp_on_lanes(ka, t, y, v, p, dydt, jv, work, L)
    return rhs_on_lanes(ka, t, y, p, dydt, work, L)


def evaluate_lanes(kernels, t, y, p, v=None):
    """The lanes kernels called from Python (for tests and checks): dy/dt and, given
    directions ``v``, J v for L states at once.

    Parameters
    ----------
    kernels : lagrange_core.codegen.Kernels
        Of a system with lanes kernels (:func:`load_rhs_lanes` is called).
    t : array_like (L,)
    y : array_like (2n, L)
        States, lanes last.
    p : array_like (N_PARAMETERS, L)
    v : array_like (2n, L), optional

    Returns
    -------
    dydt, jv, status : ndarray (2n, L), (2n, L) or None, (L,)
        ``status`` 0, or 1 for a lane whose mass matrix is singular (its values NaN).
    """
    ok, why = load_rhs_lanes(kernels, jvp=v is not None)
    if not ok:
        raise ValueError(f"{kernels.label} has no lanes kernels: {why}.")
    t = np.ascontiguousarray(t, dtype=float)
    L = t.shape[0]
    n = kernels.n_dof
    y = np.ascontiguousarray(np.broadcast_to(np.asarray(y, dtype=float), (2 * n, L)))
    p = np.ascontiguousarray(np.broadcast_to(np.asarray(p, dtype=float),
                                             (max(len(kernels.parameters), 1), L)))
    vv = y if v is None else np.ascontiguousarray(
        np.broadcast_to(np.asarray(v, dtype=float), (2 * n, L)))
    dydt = np.zeros((2 * n, L))
    jv = np.zeros((2 * n, L))
    work = np.zeros((lanes_work_rows(n), L))
    failed = _evaluate(kernels.addresses(), v is not None, t, y, vv, p, dydt, jv, work)
    status = work[0].astype(np.int64) if failed else np.zeros(L, dtype=np.int64)
    return dydt, (jv if v is not None else None), status


from . import _kernel_calls, _lane_calls  # noqa: E402
from .module_store import guard_numba_cache  # noqa: E402

guard_numba_cache(sys.modules[__name__], _kernel_calls, _lane_calls)


# a first call on the main thread compiles where Ctrl-C need not wait for it
guard(__name__)
