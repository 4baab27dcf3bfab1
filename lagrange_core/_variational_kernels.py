"""The flow and its Jacobian (the variational equations), compiled once for every system.

For y′ = f(t, y) the sensitivity X(t) = ∂y(t)/∂y(t0) obeys X′ = J(t, y(t)) X, X(t0) = I,
with J = ∂f/∂y the system's exact compiled Jacobian (slot ``jacobian`` of
:mod:`lagrange_core._kernel_calls`; no finite differences).  :func:`rk8_flow` integrates
y and X together with the 8th-order formula of DOP853 at a fixed step ("internal
differentiation": X is the exact derivative of the *discrete* flow, so Newton's method
on it converges quadratically); :mod:`lagrange_core.variational` picks the step count
by doubling until the flow and X agree to the tolerance.  Unconstrained systems only.
"""
import sys

import numpy as np
from numba import njit

from ._kernel_calls import JACOBIAN, RHS, call_jacobian, call_rhs


@njit(cache=True)
def rk8_flow(ka, y0, p, t0, t1, nsteps, A, B, C, y_out, X_out):
    """y(t1) into ``y_out`` and X(t1) = ∂y(t1)/∂y0 into ``X_out`` (d × d) by ``nsteps``
    equal steps of the 8th-order DOP853 formula (coefficients A, B, C) applied to
    [y, X].  Returns 0, or 1 if the mass matrix was singular somewhere."""
    d = y0.shape[0]
    n = d // 2
    h = (t1 - t0) / nsteps
    W = np.zeros((n, n + 1))
    J = np.empty((d, d))
    Ky = np.empty((12, d))
    KX = np.empty((12, d, d))
    ys = np.empty(d)
    Xs = np.empty((d, d))
    y = y0.copy()
    X = np.eye(d)
    for k in range(nsteps):
        t = t0 + k * h
        for s in range(12):
            for i in range(d):
                acc = 0.0
                for j in range(s):
                    acc += A[s, j] * Ky[j, i]
                ys[i] = y[i] + h * acc
            for i in range(d):
                for c in range(d):
                    acc = 0.0
                    for j in range(s):
                        acc += A[s, j] * KX[j, i, c]
                    Xs[i, c] = X[i, c] + h * acc
            ts = t + C[s] * h
            if call_rhs(ka[RHS], ts, ys, p, Ky[s], W) != 0:
                return 1
            if call_jacobian(ka[JACOBIAN], ts, ys, p, J) != 0:
                return 1
            for i in range(d):
                for c in range(d):
                    acc = 0.0
                    for j in range(d):
                        acc += J[i, j] * Xs[j, c]
                    KX[s, i, c] = acc
        for i in range(d):
            acc = 0.0
            for s in range(12):
                acc += B[s] * Ky[s, i]
            y[i] += h * acc
            for c in range(d):
                acc = 0.0
                for s in range(12):
                    acc += B[s] * KX[s, i, c]
                X[i, c] += h * acc
    for i in range(d):
        y_out[i] = y[i]
        for c in range(d):
            X_out[i, c] = X[i, c]
    return 0


# numba's cache does not notice changes to the slots these call
from . import _kernel_calls  # noqa: E402
from .module_store import guard_numba_cache  # noqa: E402

guard_numba_cache(sys.modules[__name__], _kernel_calls)


# a first call on the main thread compiles where Ctrl-C need not wait for it
from ._first_calls import guard as _guard_first_calls  # noqa: E402

_guard_first_calls(__name__)
