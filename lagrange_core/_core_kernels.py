"""The fixed part of every system's kernels, compiled once per installation.

A generated kernel module (:mod:`lagrange_core.codegen`) holds what is specific
to one system: a *program* (:mod:`lagrange_core._ir`) that evaluates its
distinct symbolic terms and, from them, the entries of the augmented matrix

    W = [[M, −Φ_qᵀ, F], [Φ_q, 0, γ]]        (N = n + m rows, N + 1 columns),

and tables saying where each entry goes (``TARGET_TABLE``: rows of
(row, column, output)) and which derivatives the tangent evaluator stored
(``TAN_PTR``/``TAN_J``: for output o, the state indices j of ∂(output o)/∂y_j,
CSR style).  The functions here are the same for every system, so numba's disk
cache compiles them once and a new system's own compile is only its program
and thin wrappers.
"""
from __future__ import annotations

import numpy as np
from numba import njit

from ._linalg import solve_dense


@njit(cache=True)
def check_work(W, N):
    """Raise if the scratch array cannot hold the augmented system of N rows."""
    if W.shape[0] < N or W.shape[1] != N + 1:
        raise ValueError("the scratch array W must have shape WORK_SHAPE (use new_work())")


@njit(cache=True)
def work_matrix(N):
    """A zeroed augmented matrix, (N, N + 1)."""
    return np.zeros((N, N + 1))


@njit(cache=True)
def jacobian_scratch(N, n_tangents):
    """A zeroed augmented matrix (N, N + 1) and room for the tangents of its entries."""
    return np.zeros((N, N + 1)), np.zeros(n_tangents)


@njit(cache=True)
def jacobian_from_entries(W, dA, TARGET_TABLE, TAN_PTR, TAN_J, J):
    """∂(dy/dt)/∂y, (2n, 2n), from the augmented matrix W and its derivatives dA.

    With x = [q̈, λ] the solution at y, the residual G(y) = W[:, N] − W[:, :N] x
    vanishes along solutions, so [M −Φ_qᵀ; Φ_q 0] ∂x/∂y = ∂G/∂y, where
    ∂G_r/∂y_j = ∂W[r, N]/∂y_j − Σ_c ∂W[r, c]/∂y_j x_c.  The derivatives of the entries
    are exact forward-mode ones (:func:`lagrange_core._ir.tangent_evaluator`); ``dA``
    lists them output by output, in the order of ``TAN_PTR``/``TAN_J``.

    Returns 0, or 1 if the augmented mass matrix is singular.
    """
    N = W.shape[0]
    n = J.shape[0] // 2
    A = W.copy()
    status = solve_dense(A, N)          # A[:, N] = x
    D = np.zeros((N, N + 2 * n))        # [augmented mass matrix | ∂G/∂y]
    for r in range(N):
        for c in range(N):
            D[r, c] = W[r, c]
    for t in range(TARGET_TABLE.shape[0]):
        r, c, o = TARGET_TABLE[t, 0], TARGET_TABLE[t, 1], TARGET_TABLE[t, 2]
        factor = 1.0 if c == N else -A[c, N]
        for k in range(TAN_PTR[o], TAN_PTR[o + 1]):
            D[r, N + TAN_J[k]] += factor * dA[k]
    status = max(status, solve_dense(D, N))
    for i in range(2 * n):
        for j in range(2 * n):
            J[i, j] = 0.0
    for i in range(n):
        J[i, n + i] = 1.0
        for j in range(2 * n):
            J[n + i, j] = D[i, N + j]
    return status


# a first call on the main thread compiles where Ctrl-C need not wait for it
from ._first_calls import guard as _guard_first_calls  # noqa: E402

_guard_first_calls(__name__)
