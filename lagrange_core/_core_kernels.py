"""The fixed part of every system's kernels: assembling M, F and the constraint rows.

A generated kernel module (:mod:`lagrange_core.codegen`) contains only what is
specific to one system:

``_values(q, qd, t, p, W)``
    Evaluates each *distinct* symbolic term once (common subexpressions removed)
    and stores value number f at ``W[N0 + f // WIDTH, f % WIDTH]``, below the
    augmented block of the scratch array (value 0 is the constant zero).
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

``assemble`` is compiled once per installation (numba's disk cache), for float
and complex values (the complex step of the Jacobian), so a large system's own
compile is only its ``_values``.  Small systems do not use these loops: the
generator unrolls their assembly into straight-line code.
"""
from __future__ import annotations

from numba import njit
from numba.extending import register_jitable


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
