"""The compiled kernels of an averaged system: U_eff, its gradient and Hessian.

:func:`kernel_source` writes one numba module per system and drive-frequency name from
the averaged system's symbolic parts (M(q), U(q), the fast forces f_k(q), C(q)); it is
kept in lagrange_core's one generated-module store (:mod:`lagrange_core.module_store`),
keyed by the system's statement and by this module's code, so a fresh process loads it
without compiling.  The generator is written here rather than on top of lagrange_core's
own (private) code generator so that the averaging kernels depend only on lagrange_core's
public contract: System, its symbols and the module store.

The generated module (arrays of floats; ``q`` the coordinates, ``p`` the parameters in
``system.parameters`` order):

* ``slow_terms(q, p, U, Ug, Uh)``: U, ∂U/∂q, ∂²U/∂q² of the averaged potential;
* ``mass_terms(q, p, M, Mg, Mh)``: M and its first and second derivatives;
* ``fast_terms(q, p, w, f, fg, fh)``: per fast force k, the weight 1/(4 k² ω²), f_k and its
  first and second derivatives;
* ``damping(q, p, C)``, ``damping_gradient(q, p, Cg)``: C(q) and ∂C/∂q;

:func:`effective` evaluates U_eff with its gradient and Hessian from these terms by the
one kernel every system shares (:mod:`kapitza.averaging._kernels`), so that a new system
compiles only its own terms.
"""
from __future__ import annotations

import functools
import re
import sys
import textwrap

import numpy as np
import symengine as se

from lagrange_core import module_store

from ._kernels import effective_from_terms

__all__ = ["effective", "kernel_source", "load_kernels", "terms"]


def load_kernels(avg):
    """The compiled module of the averaged system ``avg`` (from the store when it is there)."""
    key = module_store.content_key(avg.system.statement_key(), "omega=" + avg.omega.name,
                                   _generator_fingerprint())
    module = module_store.load_generated("_lc_avg", key, functools.partial(kernel_source, avg))
    # ``effective(q, p, G, H)`` stays the module's entry point, as it was when it was
    # compiled into each module (:func:`effective`, the shared kernel, now does the work)
    module.effective = functools.partial(effective, module)
    return module


@functools.cache
def _generator_fingerprint() -> str:
    """Hash of this module's code (the generator; the generated module calls nothing
    else)."""
    return module_store.source_fingerprint(sys.modules[__name__])


def _mass_and_fast_terms(K, q, p, n):
    """M, ∂M/∂q, ∂²M/∂q², the weights 1/(4 k² ω²) and the fast forces f_k with their
    first and second derivatives at ``q``."""
    M = np.empty((n, n))
    Mg, Mh = np.zeros((n, n, n)), np.zeros((n, n, n, n))
    K.mass_terms(q, p, M, Mg, Mh)
    nf = K.N_FAST
    w = np.zeros(nf)
    f, fg, fh = np.zeros((nf, n)), np.zeros((nf, n, n)), np.zeros((nf, n, n, n))
    K.fast_terms(q, p, w, f, fg, fh)
    return M, Mg, Mh, w, f, fg, fh


def terms(K, q, p, n):
    """M, ∂M/∂q, the fast forces f_k, their gradients and weights 1/(4 k² ω²) at ``q``."""
    M, Mg, _, w, f, fg, _ = _mass_and_fast_terms(K, q, p, n)
    return M, Mg, f, fg, w


def effective(K, q, p, G, H) -> float:
    """U_eff (J) at the coordinates ``q`` for the parameters ``p`` (arrays of floats),
    filling its gradient ``G`` (n) and Hessian ``H`` (n × n): the terms of the system's
    compiled module ``K`` (:func:`load_kernels`), then the shared kernel."""
    n = K.N_DOF
    U, Ug, Uh = np.empty(1), np.empty(n), np.empty((n, n))
    K.slow_terms(q, p, U, Ug, Uh)
    return effective_from_terms(U[0], Ug, Uh, *_mass_and_fast_terms(K, q, p, n), G, H)


def kernel_source(avg) -> str:
    """The source of the compiled module of the averaged system ``avg`` (see the module
    docstring for its functions)."""
    system = avg.system
    n = system.n_dof
    q = [se.sympify(s) for s in system.q]
    pr = _Printer(system)
    K = len(avg.fast_forces)

    U = se.sympify(avg.slow_potential)
    Ug = [se.diff(U, a) for a in q]
    slow_out = [("U[0]", U)] + [(f"Ug[{a}]", Ug[a]) for a in range(n)]
    slow_out += [(f"Uh[{a}, {b}]", se.diff(Ug[a], q[b])) for a in range(n) for b in range(n)]

    M = [[se.sympify(avg.mass_matrix[i, j]) for j in range(n)] for i in range(n)]
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
    w = se.sympify(avg.omega)
    fast_out = []
    for k, (harm, _, f) in enumerate(avg.fast_forces):
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
    C = [(f"C[{i}, {j}]", se.sympify(avg.damping_matrix[i, j]))
         for i in range(n) for j in range(n) if avg.damping_matrix[i, j] != 0]
    Cg = [(f"Cg[{a}, {i}, {j}]", d) for a in range(n) for i in range(n) for j in range(n)
          for d in [se.diff(se.sympify(avg.damping_matrix[i, j]), q[a])] if d != 0]

    src = [f"# Generated by kapitza.averaging for {system.name or 'a system'!r}, drive "
           f"frequency {avg.omega.name!r}. Do not edit.\n",
           "import numpy as np\nfrom numba import njit\n"
           "from math import (sin, cos, tan, exp, log, sqrt, asin, acos, atan, atan2,\n"
           "                  sinh, cosh, tanh, asinh, acosh, atanh, pi, e as E)\n"
           "from numpy import sign\n",
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
    return "".join(src)


# -- printing --------------------------------------------------------------------------

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
