"""The fixed part of every system's kernels: assembling M, F and the constraint rows.

A generated kernel module (:mod:`lagrange_core.codegen`) contains only what is
specific to one system:

``PROGRAM`` (evaluated by ``_evaluate(y, t, p, W)``, see :mod:`lagrange_core._ir`)
    Evaluates each *distinct* symbolic term once (common subexpressions removed)
    and stores value number f at ``W[N0 + f // WIDTH, f % WIDTH]``, below the
    augmented block of the scratch array (value 0 is the constant zero);
    ``_evaluate_tangents`` also stores their derivatives with respect to the state.
Index tables of value numbers (0 for an identically zero term)
    ``P_MASS`` (particles), ``P_PTR``/``P_COL`` (per particle, the columns where
    its Jacobian is not identically zero, CSR style), ``P_JAC`` (per stored
    column, the 3 Cartesian components of J), ``P_BIAS`` (per particle, the 3
    components of the q̈-free part of its acceleration),
    ``F_REST`` (n), ``M_REST`` (n, n), ``PHI_Q`` (m, n), ``GAMMA`` (m).

Structure is data: each distinct expression is generated once and the loops
below assemble M = M' + Σ m JᵀJ and F = F' − Σ m Jᵀ·bias.  Generated code, and
with it numba's compile time, grows with the number of distinct terms rather
than with n² matrix entries of n terms each.

``assemble`` and ``jacobian_from_values`` are compiled once per installation
(numba's disk cache), so a large system's own compile is only the evaluation of
its values and thin wrappers.  Small systems unroll their assembly into
straight-line code instead, but share ``jacobian_from_values``.
"""
from __future__ import annotations

import numpy as np
from numba import njit
from numba.extending import register_jitable

from ._linalg import solve_dense


@register_jitable
def value(W, N0, WIDTH, f):
    """Value number f, stored below the augmented block of W."""
    return W[N0 + f // WIDTH, f % WIDTH]


@njit(cache=True)
def assemble(W, N0, WIDTH, BAND, P_MASS, P_PTR, P_COL, P_JAC, P_BIAS, F_REST, M_REST, PHI_Q,
             GAMMA):
    """Fill W[:N, :N+1] = [[M, −Φ_qᵀ, F], [Φ_q, 0, γ]] (N = n + m) from the stored values.

    Only the band |i − j| ≤ BAND of M is written (M is zero outside it by construction).
    """
    n = F_REST.shape[0]
    m = GAMMA.shape[0]
    last = n + m
    for i in range(n):
        W[i, last] = value(W, N0, WIDTH, F_REST[i])
        for j in range(max(0, i - BAND), min(n, i + BAND + 1)):
            W[i, j] = value(W, N0, WIDTH, M_REST[i, j])
    for k in range(P_MASS.shape[0]):
        mk = value(W, N0, WIDTH, P_MASS[k])
        b0 = value(W, N0, WIDTH, P_BIAS[k, 0])
        b1 = value(W, N0, WIDTH, P_BIAS[k, 1])
        b2 = value(W, N0, WIDTH, P_BIAS[k, 2])
        for a in range(P_PTR[k], P_PTR[k + 1]):
            i = P_COL[a]
            ja0 = value(W, N0, WIDTH, P_JAC[a, 0])
            ja1 = value(W, N0, WIDTH, P_JAC[a, 1])
            ja2 = value(W, N0, WIDTH, P_JAC[a, 2])
            W[i, last] -= mk * (ja0 * b0 + ja1 * b1 + ja2 * b2)
            for b in range(a, P_PTR[k + 1]):
                j = P_COL[b]
                s = mk * (ja0 * value(W, N0, WIDTH, P_JAC[b, 0])
                          + ja1 * value(W, N0, WIDTH, P_JAC[b, 1])
                          + ja2 * value(W, N0, WIDTH, P_JAC[b, 2]))
                W[i, j] += s
                if j != i:
                    W[j, i] += s
    for c in range(m):
        W[n + c, last] = value(W, N0, WIDTH, GAMMA[c])
        for j in range(n):
            W[n + c, j] = value(W, N0, WIDTH, PHI_Q[c, j])
            W[j, n + c] = -value(W, N0, WIDTH, PHI_Q[c, j])
        for d in range(m):
            W[n + c, n + d] = 0.0


#: Complex step of the assembly (below): exact, since M, F, Φ_q and γ are polynomials
#: (sums of products) of the stored values, and h² underflows to zero.
_ASSEMBLY_STEP = 1e-200


@njit(cache=True)
def jacobian_from_values(W, dV, P_MASS, P_PTR, P_COL, P_JAC, P_BIAS, F_REST, M_REST, PHI_Q,
                         GAMMA, J):
    """∂(dy/dt)/∂y, (2n, 2n), from the values in W and their derivatives dV[f, j] = ∂v_f/∂y_j.

    With x = [q̈, λ] the solution at y, the residual G(y) = W[:, N] − W[:, :N] x of the
    augmented system vanishes along solutions, so [M −Φ_qᵀ; Φ_q 0] ∂x/∂y = ∂G/∂y.
    ∂G/∂y_j comes from the assembly fed with the values' derivatives; the derivatives of
    the values themselves are exact forward-mode ones (:mod:`lagrange_core._ir`).

    Returns 0, or 1 if the augmented mass matrix is singular.
    """
    n = F_REST.shape[0]
    N = n + GAMMA.shape[0]
    WIDTH = N + 1
    n_state = 2 * n
    assemble(W, N, WIDTH, n - 1, P_MASS, P_PTR, P_COL, P_JAC, P_BIAS, F_REST, M_REST, PHI_Q,
             GAMMA)
    D = np.empty((N, N + n_state))       # [A | ∂G/∂y], A the augmented mass matrix
    A = np.empty((N, N + 1))             # [A | F], solved for x
    for r in range(N):
        for c in range(N + 1):
            A[r, c] = W[r, c]
        for c in range(N):
            D[r, c] = W[r, c]
    status = solve_dense(A, N)
    Wc = np.zeros(W.shape, dtype=np.complex128)
    for j in range(n_state):
        for f in range(dV.shape[0]):
            r, c = N + f // WIDTH, f % WIDTH
            Wc[r, c] = complex(W[r, c], _ASSEMBLY_STEP * dV[f, j])
        # M is assembled densely (BAND = n − 1): every entry of the top block is rewritten
        assemble(Wc, N, WIDTH, n - 1, P_MASS, P_PTR, P_COL, P_JAC, P_BIAS, F_REST, M_REST,
                 PHI_Q, GAMMA)
        for r in range(N):
            s = Wc[r, N].imag
            for c in range(N):
                s -= Wc[r, c].imag * A[c, N]
            D[r, N + j] = s / _ASSEMBLY_STEP
    status = max(status, solve_dense(D, N))
    for i in range(n_state):
        for j in range(n_state):
            J[i, j] = 0.0
    for i in range(n):
        J[i, n + i] = 1.0
        for j in range(n_state):
            J[n + i, j] = D[i, N + j]
    return status
