"""Small dense linear algebra for numba kernels (no allocation, no Python objects)."""
from __future__ import annotations

from numba import njit
from numba.extending import register_jitable

#: Pivots smaller than this times the largest matrix entry count as singular.
SINGULAR_RTOL = 1e-13


def _gauss_solve(W, N):
    """Solve A X = B in place, where ``W = [A | B]`` and A is the leading N x N block.

    Gaussian elimination with partial pivoting; the solution X overwrites B
    (``W[:, N:]``) and A is destroyed.  For the few unknowns of a mechanical
    system this beats a LAPACK call, which allocates.

    Returns
    -------
    int
        0 on success, 1 if A is singular to working precision (a pivot below
        ``SINGULAR_RTOL`` times the largest entry of A).
    """
    ncol = W.shape[1]
    scale = 0.0
    for i in range(N):
        for j in range(N):
            a = abs(W[i, j])
            if a > scale:
                scale = a
    if not scale > 0.0:
        return 1
    tiny = SINGULAR_RTOL * scale
    for k in range(N):
        piv = k
        best = abs(W[k, k])
        for i in range(k + 1, N):
            a = abs(W[i, k])
            if a > best:
                best = a
                piv = i
        if not best > tiny:   # also catches NaN
            return 1
        if piv != k:
            for j in range(k, ncol):
                tmp = W[k, j]
                W[k, j] = W[piv, j]
                W[piv, j] = tmp
        inv = 1.0 / W[k, k]
        for i in range(k + 1, N):
            f = W[i, k] * inv
            if f != 0.0:
                for j in range(k + 1, ncol):
                    W[i, j] -= f * W[k, j]
    for c in range(N, ncol):
        for i in range(N - 1, -1, -1):
            s = W[i, c]
            for j in range(i + 1, N):
                s -= W[i, j] * W[j, c]
            W[i, c] = s / W[i, i]
    return 0


#: Inlined into each numba caller, where a constant N lets LLVM unroll it.
solve_augmented = register_jitable(_gauss_solve)
#: Compiled once per installation (numba's cache), for large systems: no per-system compile.
solve_dense = njit(cache=True)(_gauss_solve)


@njit(cache=True)
def solve_banded_spd(W, N, b):
    """Solve M x = F in place for a symmetric positive definite M of half-bandwidth b.

    ``W = [M | F]`` with M in the leading N x N block (only |i − j| ≤ b is read);
    LDLᵀ without pivoting (M is a mass matrix), O(N b²): a chain of beads, whose M
    is diagonal, costs O(N) instead of the O(N³) of dense elimination.  x overwrites
    F; M's lower band is destroyed.  Returns 0, or 1 if a pivot falls below
    ``SINGULAR_RTOL`` times the largest diagonal entry.
    """
    scale = 0.0
    for i in range(N):
        scale = max(scale, abs(W[i, i]))
    if not scale > 0.0:
        return 1
    tiny = SINGULAR_RTOL * scale
    for j in range(N):
        d = W[j, j]
        for k in range(max(0, j - b), j):
            d -= W[j, k] * W[j, k] * W[k, k]
        if not d > tiny:
            return 1
        W[j, j] = d
        for i in range(j + 1, min(N, j + b + 1)):
            s = W[i, j]
            for k in range(max(0, i - b), j):
                s -= W[i, k] * W[j, k] * W[k, k]
            W[i, j] = s / d
    for i in range(N):
        s = W[i, N]
        for k in range(max(0, i - b), i):
            s -= W[i, k] * W[k, N]
        W[i, N] = s
    for i in range(N - 1, -1, -1):
        s = W[i, N] / W[i, i]
        for k in range(i + 1, min(N, i + b + 1)):
            s -= W[k, i] * W[k, N]
        W[i, N] = s
    return 0


# a first call on the main thread compiles where Ctrl-C need not wait for it
from ._first_calls import guard as _guard_first_calls  # noqa: E402

_guard_first_calls(__name__)
