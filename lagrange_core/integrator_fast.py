"""A specialised kernel for q̈ = f(q, t) with a harmonic drive, and the RKN loop that uses it.

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

The generated module (source + numba machine code) is cached on disk next to
the system's kernels, keyed by the statement and this file's source.

Accuracy: identical formulas; the rotation adds a relative rounding error of a
few ulps per stage (the base (C_k, S_k) is recomputed exactly at every step, so
nothing accumulates).
"""
from __future__ import annotations

import functools
import hashlib
import inspect
import sys
import textwrap

import numpy as np
import sympy as sp

from .codegen import load_module, source_fingerprint, write_module

__all__ = ["fast_model", "FastModel"]


class FastModel:
    """The loaded specialised module of one system (``module.fast_rkn_chunk`` etc.)."""

    def __init__(self, module, n_drive, has_t):
        self.module = module
        self.n_drive = n_drive
        self.has_t = has_t


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


def _generated_source(system) -> tuple[str, int, bool]:
    from .systems import t as t_sym
    eq = system.equations
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
    has_t = any(e.has(t_sym) for e in exprs)
    ren = {}
    loads = []
    for i, s in enumerate(system.q):
        ren[s] = sp.Symbol(f"_q{i}")
        loads.append(f"_q{i} = q[{i}]")
    for i, s in enumerate(system.parameter_symbols):
        ren[s] = sp.Symbol(f"_p{i}")
        loads.append(f"_p{i} = p[{i}]")
    for k in range(len(alphas)):
        loads.append(f"_C{k} = cs[{2 * k}]")
        loads.append(f"_S{k} = cs[{2 * k + 1}]")
    ren[t_sym] = sp.Symbol("t")
    exprs = [e.xreplace(ren) for e in exprs]
    reps, reduced = sp.cse(exprs, symbols=sp.numbered_symbols("_x"))
    body = list(loads) + [f"{_print(s)} = {_print(e)}" for s, e in reps]
    if n == 1:
        body.append(f"out[0] = {_print(reduced[0])}")
    else:
        k = 0
        for i in range(n):
            for j in range(i, n):
                body.append(f"Wn[{i}, {j}] = {_print(reduced[k])}")
                if j != i:
                    body.append(f"Wn[{j}, {i}] = Wn[{i}, {j}]")
                k += 1
        for i in range(n):
            body.append(f"Wn[{i}, {n}] = {_print(reduced[k + i])}")
        body.append(f"status = solve_augmented(Wn, {n})")
        body += [f"out[{i}] = Wn[{i}, {n}]" for i in range(n)]
        body.append("return status")
    if n == 1:
        body.append("return 0")
    src = [f"N_DOF = {n}", f"N_DRIVE = {len(alphas)}", "", "",
           _JIT, "def fast_accel(q, t, cs, p, out, Wn):",
           textwrap.indent("\n".join(body), "    "), "", "",
           "@njit(cache=True)", "def drive_rates(p, out):"]
    rl = [f"_p{i} = p[{i}]" for i in range(len(system.parameter_symbols))]
    rl += [f"out[{k}] = {_print(a.xreplace(ren))}" for k, a in enumerate(alphas)]
    rl.append("return 0")
    src.append(textwrap.indent("\n".join(rl), "    "))
    return "\n".join(src) + "\n", len(alphas), has_t


# -- templates (compiled inside the generated module) -----------------------------------

def fast_rkn_chunk(y, f, tv, stats, p, c, A, b, bp, bh, bph, adaptive, rtol, atol, max_steps,
                   t_eval, stride, tout, yout):
    """RKN 12(10) on the specialised kernel; fixed step tv[2] or adaptive.

    Same state layout and statuses as the generic drivers in
    :mod:`lagrange_core._integrator_kernels` (no events here: the caller uses the
    generic driver when events are requested).  Output at ``t_eval`` by landing
    steps on the requested times.
    """
    n = N_DOF
    nd = N_DRIVE
    n2 = 2 * n
    ns = c.shape[0]
    K = np.empty((ns, n))
    qs = np.empty(n)
    qn = np.empty(n)
    vn = np.empty(n)
    Wn = np.zeros((n, n + 1))
    cq = np.zeros(n)
    cv = np.zeros(n)
    cqn = np.zeros(n)
    cvn = np.zeros(n)
    rates = np.empty(max(nd, 1))
    drive_rates(p, rates)
    rot = np.empty((ns, max(nd, 1), 2))
    cs0 = np.empty(max(2 * nd, 1))
    css = np.empty(max(2 * nd, 1))
    db = np.empty(ns)
    dbp = np.empty(ns)
    for j in range(ns):
        db[j] = b[j] - bh[j]
        dbp[j] = bp[j] - bph[j]
    cap = tout.shape[0]
    q = y[:n]
    v = y[n:]
    a0 = f[n:]
    t = tv[0]
    t_end = tv[1]
    h = tv[2]
    h_rot = -1.0
    rejected = False
    expo = -1.0 / 11.0
    for step in range(max_steps + 1):
        status = chunk_status(step, max_steps, t, t_end, t_eval, stats, cap, 0, 0)   # no events
        if status >= 0:
            return status
        hmin = 16.0 * 2.220446049250313e-16 * max(abs(t), abs(t_end))
        t_target = next_stop(t_end, t_eval, stats)
        for k in range(nd):
            cs0[2 * k] = np.cos(rates[k] * t)
            cs0[2 * k + 1] = np.sin(rates[k] * t)
        while True:
            clipped = False
            hs = h
            if t + hs >= t_target or (not adaptive and t + hs * (1.0 + 1e-10) >= t_target):
                hs = t_target - t
                clipped = True
            if hs != h_rot:
                for s in range(ns):
                    for k in range(nd):
                        rot[s, k, 0] = np.cos(rates[k] * c[s] * hs)
                        rot[s, k, 1] = np.sin(rates[k] * c[s] * hs)
                h_rot = hs
            for i in range(n):
                K[0, i] = a0[i]
            status = 0
            for s in range(1, ns):
                ch = c[s] * hs
                for i in range(n):
                    acc = 0.0
                    for j in range(s):
                        acc += A[s, j] * K[j, i]
                    qs[i] = q[i] + ch * v[i] + hs * hs * acc
                for k in range(nd):
                    cr = rot[s, k, 0]
                    sr = rot[s, k, 1]
                    css[2 * k] = cs0[2 * k] * cr - cs0[2 * k + 1] * sr
                    css[2 * k + 1] = cs0[2 * k + 1] * cr + cs0[2 * k] * sr
                status = fast_accel(qs, t + ch, css, p, K[s], Wn)
                if status != 0:
                    break
            stats[2] += ns - 1
            if status != 0:
                tv[0] = t
                return 4
            e2 = 0.0
            est = 0.0
            finite = True
            for i in range(n):
                accq = 0.0
                accv = 0.0
                dq = 0.0
                dv = 0.0
                for j in range(ns):
                    kj = K[j, i]
                    accq += b[j] * kj
                    accv += bp[j] * kj
                    dq += db[j] * kj
                    dv += dbp[j] * kj
                # compensated (Kahan) update: over 10⁵ fixed steps plain q += Δq loses
                # ~1e-11 to rounding, more than the method's error at tight tolerances
                yq = hs * v[i] + hs * hs * accq - cq[i]
                qn[i] = q[i] + yq
                cqn[i] = (qn[i] - q[i]) - yq
                yv = hs * accv - cv[i]
                vn[i] = v[i] + yv
                cvn[i] = (vn[i] - v[i]) - yv
                dq *= hs * hs
                dv *= hs
                if not (np.isfinite(qn[i]) and np.isfinite(vn[i])):
                    finite = False
                if adaptive:
                    sq = atol + rtol * max(abs(q[i]), abs(qn[i]))
                    sv = atol + rtol * max(abs(v[i]), abs(vn[i]))
                    e2 += (dq / sq) ** 2 + (dv / sv) ** 2
                est = max(est, abs(dq), abs(dv))
            err = np.sqrt(e2 / n2)
            if (not adaptive) or (finite and err < 1.0):
                if not finite:
                    tv[0] = t
                    return 5
                break
            stats[1] += 1
            h = hs * max(0.2, 0.9 * err ** expo) if finite else 0.2 * hs
            rejected = True
            if h < hmin:
                tv[0] = t
                tv[2] = h
                return 5
        stats[0] += 1
        tv[3] += est
        if clipped:
            t_new = t_target
            tv[5] = 0.0
        else:       # compensated (Kahan) sum of the steps, see _integrator_kernels.dop853_chunk
            yk = hs - tv[5]
            t_new = t + yk
            tv[5] = (t_new - t) - yk
        # FSAL: f at the new state; the drive at t + hs is the rotation of stage c = 1
        for k in range(nd):
            cr = rot[ns - 1, k, 0]
            sr = rot[ns - 1, k, 1]
            css[2 * k] = cs0[2 * k] * cr - cs0[2 * k + 1] * sr
            css[2 * k + 1] = cs0[2 * k + 1] * cr + cs0[2 * k] * sr
        status = fast_accel(qn, t_new, css, p, a0, Wn)
        stats[2] += 1
        if status != 0:
            tv[0] = t
            return 4
        for i in range(n):
            q[i] = qn[i]
            v[i] = vn[i]
            f[i] = vn[i]
            cq[i] = cqn[i]
            cv[i] = cvn[i]
        t = t_new
        tv[0] = t
        store_output(t, y, n2, t_end, t_eval, tout, yout, stats, stride, False)
        if adaptive:
            factor = 5.0 if err == 0.0 else min(5.0, 0.9 * err ** expo)
            if rejected:
                factor = min(1.0, factor)
            h = max(h, hs * factor) if clipped else hs * factor
            rejected = False
        tv[2] = h
    return 1


def fast_symplectic_chunk(y, f, tv, stats, p, w, max_steps, t_eval, stride, tout, yout):
    """Symmetric composition of velocity Verlet (weights w) at a fixed step, on the
    specialised kernel.  Time advances with the drifts (kick at the current time,
    drift q and t together), which keeps every substep symmetric for a
    time-dependent f; the drive at each drift end is a fixed rotation of its value
    at the step start.  Same state layout and outputs as :func:`fast_rkn_chunk`.
    """
    n = N_DOF
    nd = N_DRIVE
    n2 = 2 * n
    nw = w.shape[0]
    Wn = np.zeros((n, n + 1))
    qn = np.empty(n)
    vn = np.empty(n)
    a = np.empty(n)
    S = np.empty(nw)
    acc = 0.0
    for k in range(nw):
        acc += w[k]
        S[k] = acc
    rates = np.empty(max(nd, 1))
    drive_rates(p, rates)
    rot = np.empty((nw, max(nd, 1), 2))
    cs0 = np.empty(max(2 * nd, 1))
    css = np.empty(max(2 * nd, 1))
    cap = tout.shape[0]
    q = y[:n]
    v = y[n:]
    a0 = f[n:]
    t = tv[0]
    t_end = tv[1]
    h = tv[2]
    h_rot = -1.0
    for step in range(max_steps + 1):
        status = chunk_status(step, max_steps, t, t_end, t_eval, stats, cap, 0, 0)   # no events
        if status >= 0:
            return status
        t_target = next_stop(t_end, t_eval, stats)
        clipped = False
        hs = h
        if t + hs * (1.0 + 1e-10) >= t_target:
            hs = t_target - t
            clipped = True
        if hs != h_rot:
            for k in range(nw):
                for d in range(nd):
                    rot[k, d, 0] = np.cos(rates[d] * S[k] * hs)
                    rot[k, d, 1] = np.sin(rates[d] * S[k] * hs)
            h_rot = hs
        for d in range(nd):
            cs0[2 * d] = np.cos(rates[d] * t)
            cs0[2 * d + 1] = np.sin(rates[d] * t)
        for i in range(n):
            qn[i] = q[i]
            vn[i] = v[i]
            a[i] = a0[i]
        status = 0
        for k in range(nw):
            hk = w[k] * hs
            for i in range(n):
                vn[i] += 0.5 * hk * a[i]
                qn[i] += hk * vn[i]
            for d in range(nd):
                cr = rot[k, d, 0]
                sr = rot[k, d, 1]
                css[2 * d] = cs0[2 * d] * cr - cs0[2 * d + 1] * sr
                css[2 * d + 1] = cs0[2 * d + 1] * cr + cs0[2 * d] * sr
            status = fast_accel(qn, t + S[k] * hs, css, p, a, Wn)
            if status != 0:
                break
            for i in range(n):
                vn[i] += 0.5 * hk * a[i]
        stats[2] += nw
        if status != 0:
            tv[0] = t
            return 4
        for i in range(n):
            if not (np.isfinite(qn[i]) and np.isfinite(vn[i])):
                tv[0] = t
                return 5
        stats[0] += 1
        if clipped:
            t_new = t_target
            tv[5] = 0.0
        else:
            yk = hs - tv[5]
            t_new = t + yk
            tv[5] = (t_new - t) - yk
        for i in range(n):
            q[i] = qn[i]
            v[i] = vn[i]
            a0[i] = a[i]
            f[i] = vn[i]
        t = t_new
        tv[0] = t
        store_output(t, y, n2, t_end, t_eval, tout, yout, stats, stride, False)
    return 1


def fast_start(y, f, t, p):
    """f = [q̇, q̈] at (t, y) with the specialised kernel; returns the status."""
    n = N_DOF
    nd = N_DRIVE
    rates = np.empty(max(nd, 1))
    drive_rates(p, rates)
    cs = np.empty(max(2 * nd, 1))
    for k in range(nd):
        cs[2 * k] = np.cos(rates[k] * t)
        cs[2 * k + 1] = np.sin(rates[k] * t)
    Wn = np.zeros((n, n + 1))
    a = np.empty(n)
    status = fast_accel(y[:n], t, cs, p, a, Wn)
    for i in range(n):
        f[i] = y[n + i]
        f[n + i] = a[i]
    return status


FAST_TEMPLATES = [fast_rkn_chunk, fast_symplectic_chunk, fast_start]

_HEADER = """\
# Generated by lagrange_core.integrator_fast for {label}. Do not edit.
import math
import numpy as np
from numba import njit
from lagrange_core._linalg import solve_augmented

"""


@functools.cache
def _this_source_hash() -> str:
    from . import _integrator_kernels, _linalg
    return source_fingerprint(sys.modules[__name__], _linalg, _integrator_kernels)


_LOADED: dict[str, FastModel] = {}


def fast_model(system) -> FastModel | None:
    """The specialised module of an RKN-eligible ``system`` (None if not eligible)."""
    from .integrate import rkn_eligibility
    from .codegen import cache_dir
    cached = system.__dict__.get("_lc_fast_model")
    if cached is not None:
        return cached
    ok, _ = rkn_eligibility(system)
    if not ok:
        return None
    model = _fast_model(system, cache_dir)
    system.__dict__["_lc_fast_model"] = model
    return model


def _fast_model(system, cache_dir):
    key = hashlib.sha256((_this_source_hash() + system.statement_key()).encode()).hexdigest()[:20]
    if key in _LOADED:
        return _LOADED[key]
    name = f"_lcfast_{key}"
    path = cache_dir() / f"{name}.py"
    meta = cache_dir() / f"{name}.meta"
    if not path.exists() or not meta.exists():
        gen, nd, has_t = _generated_source(system)
        parts = [_HEADER.format(label=repr(system.name or "a system")), gen]
        from ._integrator_kernels import SHARED_STEPS
        for fn in (*SHARED_STEPS, *FAST_TEMPLATES):
            src = textwrap.dedent(inspect.getsource(fn))
            jit = _JIT[:-1] + ', inline="always")' if fn in SHARED_STEPS else _JIT
            parts.append(f"\n\n{jit}\n{src}")
        write_module(path, "".join(parts))
        write_module(meta, f"{nd} {int(has_t)}")
    nd, has_t = (int(x) for x in meta.read_text().split())
    model = FastModel(load_module(path, name), nd, bool(has_t))
    _LOADED[key] = model
    return model
