"""Arithmetic for *lanes*: many independent trajectories side by side, one per SIMD slot.

The batch integrator (:func:`lagrange_core._batch_kernels.grid_rkn_lanes`) keeps L
trajectories in arrays whose last axis is the lane, and every loop over lanes is the
innermost loop.  LLVM vectorises such a loop only if its body has no calls and no
branches it cannot turn into selects.  ``math.sin``/``math.cos`` are calls into libm
(numba has no vector math library here), so the kernels of lanes use the functions
below instead: branch-free, inlined, and vectorised with the rest of the loop.

:func:`lane_sin`, :func:`lane_cos`
    Cody–Waite reduction by π in three parts (π split into 32 + 32 + 53 bits, so each
    product k·P is exact for |k| < 2²⁰), x = r + kπ with |r| ≤ π/2 (cos:
    x = r + (k + ½)π), then the Taylor polynomial of sin r to degree 21 (truncation below
    1.3e-18) and the sign (−1)^k: 20 floating-point operations, no branch, no table.
    Within 2 ulp of glibc's sin and cos (measured over |x| < 10⁶ and at multiples of π/2:
    at most 2 ulp, 0.3 on average; zeros of sin and cos keep their relative accuracy,
    since r is accurate).  For |x| > :data:`BIG_ARGUMENT` (and NaN, ±inf) they return NaN: the
    caller computes that lane again with libm, so every argument gets a correct value
    and none pays a branch in the vector loop.
:func:`lane_solve`
    M X = F for every lane at once (Gaussian elimination without pivoting, the lane
    innermost).  Mass matrices are symmetric positive definite, for which elimination
    without pivoting is stable; a lane with a pivot below ``SINGULAR_RTOL`` times its
    largest |M| entry (or a non-finite one) is flagged, and the caller solves it again
    with pivoting (the scalar kernel), which also decides whether it is singular.
"""
import math

import numpy as np
from numba import njit

from ._linalg import SINGULAR_RTOL

#: |x| above which lane_sin/lane_cos return NaN (the caller falls back to libm)
BIG_ARGUMENT = 1.0e6

_INV_PI = 0.3183098861837907
_PI_1 = 3.1415926534682512              # the first 32 bits of π
_PI_2 = 1.2154201012607932e-10          # the next 32 bits
_PI_3 = 4.044532497591901e-21           # the rest, to double precision
# (−1)^k / (2k + 1)!, k = 1 … 10
_S1 = -0.16666666666666666
_S2 = 0.008333333333333333
_S3 = -0.0001984126984126984
_S4 = 2.7557319223985893e-06
_S5 = -2.505210838544172e-08
_S6 = 1.6059043836821613e-10
_S7 = -7.647163731819816e-13
_S8 = 2.8114572543455206e-15
_S9 = -8.22063524662433e-18
_S10 = 1.9572941063391263e-20

_FM = {"contract", "arcp", "nsz"}


@njit(cache=True, inline="always", fastmath=_FM, error_model="numpy")
def _sin_reduced(x, k):
    """(−1)^k sin(x − kπ) for a whole (or, for cos, half-odd) k; NaN for |x| beyond
    BIG_ARGUMENT."""
    r = ((x - k * _PI_1) - k * _PI_2) - k * _PI_3
    z = r * r
    p = _S9 + z * _S10
    p = _S8 + z * p
    p = _S7 + z * p
    p = _S6 + z * p
    p = _S5 + z * p
    p = _S4 + z * p
    p = _S3 + z * p
    p = _S2 + z * p
    p = _S1 + z * p
    s = r + (r * z) * p
    kw = np.floor(k)
    s = -s if kw - 2.0 * np.floor(0.5 * kw) != 0.0 else s
    return s if abs(x) <= BIG_ARGUMENT else np.nan


@njit(cache=True, inline="always", fastmath=_FM, error_model="numpy")
def lane_sin(x):
    """sin x, branch-free (module docstring); NaN for |x| > BIG_ARGUMENT."""
    return _sin_reduced(x, np.floor(x * _INV_PI + 0.5))


@njit(cache=True, inline="always", fastmath=_FM, error_model="numpy")
def lane_cos(x):
    """cos x = −(−1)^k sin(x − (k + ½)π), branch-free; NaN for |x| > BIG_ARGUMENT."""
    return -_sin_reduced(x, np.floor(x * _INV_PI) + 0.5)


@njit(cache=True, inline="always", fastmath=_FM, error_model="numpy")
def lane_sincos(x):
    """(sin x, cos x); NaN for |x| > BIG_ARGUMENT."""
    return lane_sin(x), lane_cos(x)


@njit(cache=True, no_cpython_wrapper=True, fastmath=_FM, error_model="numpy")
def lane_sincos_rows(x, s, c, L):
    """s[l], c[l] = sin x[l], cos x[l] for l < L, libm where the polynomial gives NaN."""
    for l in range(L):
        s[l], c[l] = lane_sincos(x[l])
    for l in range(L):
        if not (math.isfinite(s[l]) and math.isfinite(c[l])):
            s[l] = math.sin(x[l])
            c[l] = math.cos(x[l])


@njit(cache=True, fastmath=_FM, error_model="numpy")
def lane_solve(work, n, L):
    """Solve M X = F in every lane, in place, without pivoting.

    ``work`` rows 1 + i(n + 1) + j hold M[i, j] (j < n) and F[i] (j = n) of every lane
    (lanes along the last axis); on return the F rows hold X.  Row 0 gets 1.0 for a
    lane whose elimination met a pivot below ``SINGULAR_RTOL`` times the largest |M|
    entry (or a non-finite one): that lane's result is not to be used (the caller
    solves it again with pivoting); 0.0 otherwise.
    """
    w = n + 1
    for l in range(L):                       # row 0: the largest |M| entry of each lane
        work[0, l] = 0.0
    for i in range(n):
        for j in range(n):
            r = 1 + i * w + j
            for l in range(L):
                work[0, l] = max(work[0, l], abs(work[r, l]))
    for k in range(n):
        rk = 1 + k * w
        for l in range(L):                   # the pivot's inverse (NaN: unusable)
            piv = work[rk + k, l]
            work[rk + k, l] = 1.0 / piv if abs(piv) > SINGULAR_RTOL * work[0, l] else np.nan
        for i in range(k + 1, n):
            ri = 1 + i * w
            for l in range(L):
                work[ri + k, l] *= work[rk + k, l]
            for j in range(k + 1, w):
                for l in range(L):
                    work[ri + j, l] -= work[ri + k, l] * work[rk + j, l]
    for i in range(n - 1, -1, -1):
        ri = 1 + i * w
        for j in range(i + 1, n):
            rj = 1 + j * w + n
            for l in range(L):
                work[ri + n, l] -= work[ri + j, l] * work[rj, l]
        for l in range(L):
            work[ri + n, l] *= work[ri + i, l]
    for l in range(L):
        work[0, l] = 0.0
    for i in range(n):
        r = 1 + i * w + i
        for l in range(L):
            if not math.isfinite(work[r, l]):
                work[0, l] = 1.0


# a first call on the main thread compiles where Ctrl-C need not wait for it
from ._first_calls import guard as _guard_first_calls  # noqa: E402

_guard_first_calls(__name__)
