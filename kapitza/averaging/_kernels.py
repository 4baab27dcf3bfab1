"""U_eff, its gradient and its Hessian from an averaged system's terms: the numba code
every averaged system shares.

The generated module of a system (:mod:`kapitza.averaging._codegen`) evaluates its own
terms — U and M with their derivatives, the fast forces f_k with theirs — and hands them
here.  Kept out of the generated module so that it compiles once per installation, not
once per system: a new system's first ``evaluate`` compiled it again for ~2 s of its ~3 s
(measured 2026-11-26).

With x = M⁻¹f and y_a = ∂f/∂q_a − (∂M/∂q_a) x:

* ∂(fᵀM⁻¹f)/∂q_a = 2 f_aᵀx − xᵀM_a x,
* ∂²(fᵀM⁻¹f)/∂q_a∂q_b = 2 f_abᵀx + 2 y_aᵀ M⁻¹ y_b − xᵀ M_ab x,

and U_eff = U + Σ_k w_k f_kᵀ M⁻¹ f_k with w_k = 1/(4 k² ω²).  M⁻¹ f is solved
numerically (Gaussian elimination with partial pivoting), never symbolically.
"""
from __future__ import annotations

import numpy as np
from numba import njit

from lagrange_core._linalg import solve_dense

__all__ = ["effective_from_terms"]


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
def effective_from_terms(U, Ug, Uh, M, Mg, Mh, w, f, fg, fh, G, H):
    """U_eff at one point from its terms; fills its gradient ``G`` (n) and Hessian ``H``
    (n × n).  ``U`` the slow potential (J), ``Ug``/``Uh`` its derivatives, ``M``/``Mg``/
    ``Mh`` the mass matrix and its derivatives (n×n, a×n×n, a×b×n×n), ``w``/``f``/``fg``/
    ``fh`` the weights and the fast forces with their derivatives (per force k)."""
    n = M.shape[0]
    value = U
    for a in range(n):
        G[a] = Ug[a]
        for b in range(n):
            H[a, b] = Uh[a, b]
    for k in range(w.shape[0]):
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


# a first call on the main thread compiles where Ctrl-C need not wait for it
from lagrange_core._first_calls import guard as _guard_first_calls  # noqa: E402

_guard_first_calls(__name__)
