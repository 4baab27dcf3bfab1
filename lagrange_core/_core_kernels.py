"""The fixed part of every system's kernels, compiled once for all systems.

A generated kernel module (:mod:`lagrange_core.codegen`) contains only what is
specific to one system:

``_values(q, qd, t, p, u)``
    Fills ``u`` with the distinct values of the system's symbolic terms
    (common subexpressions removed); ``u[0]`` is always 0.
Index tables into ``u`` (0 stands for an identically zero term), packed in the
tuple ``TABLES`` in this order:
    ``P_MASS`` (particles), ``P_PTR``/``P_COL`` (per particle, the columns where
    its Jacobian is not identically zero, CSR style), ``P_JAC`` (per stored
    column, the 3 Cartesian components of J), ``P_BIAS`` and ``P_RT`` (per
    particle, 3 components of the q̈-free acceleration and of ∂r/∂t),
    ``F_REST`` (n), ``M_REST`` (n, n), ``PHI_Q`` (m, n), ``GAMMA`` (m).

and thin wrappers that evaluate ``_values`` and hand ``u`` and the tables to
the functions below.  Structure is data: each distinct expression is generated
once, and these loops assemble M = M' + Σ m JᵀJ and F = F' − Σ m Jᵀ·bias.  The
generated code, and with it numba's compile time, grows with the number of
distinct terms, and the loops are compiled once per installation (numba's
cache), not once per system.
"""
from __future__ import annotations

import numpy as np
from numba import njit

from ._linalg import solve_augmented


@njit(cache=True)
def assemble(u, W, P_MASS, P_PTR, P_COL, P_JAC, P_BIAS, F_REST, M_REST, PHI_Q, GAMMA):
    """Fill W[:N, :N+1] = [[M, −Φ_qᵀ, F], [Φ_q, 0, γ]] (N = n + m) from the values u."""
    # sizes come from the tables, not from arguments: a literal n would make numba
    # compile one specialisation per system instead of one for all
    n = F_REST.shape[0]
    m = GAMMA.shape[0]
    last = n + m
    for i in range(n):
        W[i, last] = u[F_REST[i]]
        for j in range(n):
            W[i, j] = u[M_REST[i, j]]
    for k in range(P_MASS.shape[0]):
        mk = u[P_MASS[k]]
        b0 = u[P_BIAS[k, 0]]
        b1 = u[P_BIAS[k, 1]]
        b2 = u[P_BIAS[k, 2]]
        for a in range(P_PTR[k], P_PTR[k + 1]):
            i = P_COL[a]
            ja0 = u[P_JAC[a, 0]]
            ja1 = u[P_JAC[a, 1]]
            ja2 = u[P_JAC[a, 2]]
            W[i, last] -= mk * (ja0 * b0 + ja1 * b1 + ja2 * b2)
            for b in range(a, P_PTR[k + 1]):
                j = P_COL[b]
                s = mk * (ja0 * u[P_JAC[b, 0]] + ja1 * u[P_JAC[b, 1]] + ja2 * u[P_JAC[b, 2]])
                W[i, j] += s
                if j != i:
                    W[j, i] += s
    for c in range(m):
        W[n + c, last] = u[GAMMA[c]]
        for j in range(n):
            W[n + c, j] = u[PHI_Q[c, j]]
            W[j, n + c] = -u[PHI_Q[c, j]]
        for d in range(m):
            W[n + c, n + d] = 0.0


@njit(cache=True)
def solve(W, F_REST, GAMMA):
    """Solve the assembled system in place: W[:, n+m] becomes [q̈, λ]. Returns the status."""
    return solve_augmented(W, F_REST.shape[0] + GAMMA.shape[0])


@njit(cache=True)
def jacobian_from_columns(W, cols, x, J, h):
    """Finish the complex-step Jacobian.

    ``W[:N, :N]`` holds the (real) augmented matrix, ``x = [q̈, λ]`` the solution,
    and ``cols[j]`` the augmented system (N, N+1) evaluated at y + i h e_j.  With x held fixed, G = W[:, N] − W[:, :N] x vanishes
    along solutions, so [M −Φ_qᵀ; Φ_q 0] ∂x/∂y = ∂G/∂y.
    """
    n = J.shape[0] // 2
    N = x.shape[0]
    B = np.empty((N, N + 2 * n))
    for r in range(N):
        for c in range(N):
            B[r, c] = W[r, c]
    for j in range(2 * n):
        for r in range(N):
            s = cols[j, r, N].imag
            for c in range(N):
                s -= cols[j, r, c].imag * x[c]
            B[r, N + j] = s / h
    status = solve_augmented(B, N)
    for i in range(2 * n):
        for j in range(2 * n):
            J[i, j] = 0.0
    for i in range(n):
        J[i, n + i] = 1.0
        for j in range(2 * n):
            J[n + i, j] = B[i, N + j]
    return status


@njit(cache=True)
def particle_energy(u, qd, P_MASS, P_PTR, P_COL, P_JAC, P_RT):
    """The particles' part of the energy function, Σ ½ m (|J q̇|² − |∂r/∂t|²)."""
    h = 0.0
    for k in range(P_MASS.shape[0]):
        v0 = u[P_RT[k, 0]]
        v1 = u[P_RT[k, 1]]
        v2 = u[P_RT[k, 2]]
        w0 = 0.0
        w1 = 0.0
        w2 = 0.0
        for a in range(P_PTR[k], P_PTR[k + 1]):
            qa = qd[P_COL[a]]
            w0 += u[P_JAC[a, 0]] * qa
            w1 += u[P_JAC[a, 1]] * qa
            w2 += u[P_JAC[a, 2]] * qa
        h += 0.5 * u[P_MASS[k]] * (w0 * w0 + w1 * w1 + w2 * w2 - v0 * v0 - v1 * v1 - v2 * v2)
    return h
