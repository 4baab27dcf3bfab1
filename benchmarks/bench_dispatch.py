"""How an integrator reaches a system's right-hand side: inlined or through a pointer.

Run:  python benchmarks/bench_dispatch.py [--quick]

The integrators are kernel templates bound to each system (``Kernels.bind``): the
system's ``rhs`` is inlined into the integrator loop, and the loop is compiled per
system (the first ``simulate`` of a new system costs 5-15 s cold).  The alternative
measured here is one generic loop, compiled once per installation (numba's cache
serves it to every system), that calls the system's ``rhs`` through a ``@cfunc``
pointer, passing the arrays' raw data pointers.  (Passing ``arr.ctypes`` instead
costs about 60 ns per call: 3x slower steps for the simple pendulum.)  Same RK4
loop both ways, one process; printed: ns per step and the ratio.

Absolute times drift on a shared machine; the ratios are the result.
"""
from __future__ import annotations

import argparse
import time

import numpy as np
from numba import carray, cfunc, njit, types
from numba.extending import intrinsic

from lagrange_core import problems

RHS_SIGNATURE = types.int64(types.float64, types.CPointer(types.float64),
                            types.CPointer(types.float64), types.CPointer(types.float64),
                            types.CPointer(types.float64))


@intrinsic
def data(typingctx, arr):
    """The raw data pointer of a float64 array (no reference counting, unlike arr.ctypes)."""
    if isinstance(arr, types.Array) and arr.dtype == types.float64:
        def codegen(context, builder, sig, args):
            return context.make_array(sig.args[0])(context, builder, args[0]).data
        return types.CPointer(types.float64)(arr), codegen


@njit(cache=True)
def rk4_through_pointer(f, y, p, W, h, steps):
    """RK4 steps of y' = f(t, y): f a cfunc (t, y*, p*, dydt*, W*) -> status."""
    n2 = y.shape[0]
    k1, k2, k3, k4, yt = np.empty(n2), np.empty(n2), np.empty(n2), np.empty(n2), np.empty(n2)
    py, pp, pw, pt = data(y), data(p), data(W), data(yt)
    for _ in range(steps):
        f(0.0, py, pp, data(k1), pw)
        for i in range(n2):
            yt[i] = y[i] + 0.5 * h * k1[i]
        f(0.0, pt, pp, data(k2), pw)
        for i in range(n2):
            yt[i] = y[i] + 0.5 * h * k2[i]
        f(0.0, pt, pp, data(k3), pw)
        for i in range(n2):
            yt[i] = y[i] + h * k3[i]
        f(0.0, pt, pp, data(k4), pw)
        for i in range(n2):
            y[i] += h / 6 * (k1[i] + 2 * k2[i] + 2 * k3[i] + k4[i])
    return y


def rk4_inlined(rhs):
    """The same loop with the system's rhs inlined (what Kernels.bind does)."""
    @njit
    def loop(y, p, W, h, steps):
        n2 = y.shape[0]
        k1, k2, k3, k4, yt = np.empty(n2), np.empty(n2), np.empty(n2), np.empty(n2), np.empty(n2)
        for _ in range(steps):
            rhs(0.0, y, p, k1, W)
            for i in range(n2):
                yt[i] = y[i] + 0.5 * h * k1[i]
            rhs(0.0, yt, p, k2, W)
            for i in range(n2):
                yt[i] = y[i] + 0.5 * h * k2[i]
            rhs(0.0, yt, p, k3, W)
            for i in range(n2):
                yt[i] = y[i] + h * k3[i]
            rhs(0.0, yt, p, k4, W)
            for i in range(n2):
                y[i] += h / 6 * (k1[i] + 2 * k2[i] + 2 * k3[i] + k4[i])
        return y
    return loop


def rhs_pointer(kernels, n_parameters):
    """A cfunc that unpacks the pointers and calls the system's rhs."""
    rhs, n2, shape = kernels.rhs, 2 * kernels.n_dof, kernels.module.WORK_SHAPE

    @cfunc(RHS_SIGNATURE)
    def f(t, y, p, dydt, W):
        return rhs(t, carray(y, (n2,)), carray(p, (n_parameters,)), carray(dydt, (n2,)),
                   carray(W, shape))
    return f


def ns_per_step(run, steps):
    best = np.inf
    for _ in range(5):
        t0 = time.perf_counter()
        run(steps)
        best = min(best, time.perf_counter() - t0)
    return best / steps * 1e9


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--quick", action="store_true", help="fewer steps (a smoke run)")
    args = ap.parse_args()
    print("first call: compile (or load) everything the loop needs for this system, in s")
    print(f"{'system':>16} {'pointer ns/step':>16} {'inlined ns/step':>16} {'ratio':>6} "
          f"{'pointer 1st call':>17} {'inlined 1st call':>17}")
    for name, system in (("pendulum", problems.pendulum()), ("double pendulum", problems.double_pendulum()),
                         ("8-link pendulum", problems.n_link_pendulum(8))):
        k = system.kernels
        p = np.random.default_rng(0).uniform(0.5, 1.5, len(system.parameters))
        y0, W = np.full(2 * k.n_dof, 0.1), k.work_array()
        t0 = time.perf_counter()
        f = rhs_pointer(k, len(p))
        a = rk4_through_pointer(f, y0.copy(), p, W, 1e-3, 10)
        first_pointer = time.perf_counter() - t0
        t0 = time.perf_counter()
        inlined = rk4_inlined(k.rhs)
        b = inlined(y0.copy(), p, W, 1e-3, 10)
        first_inlined = time.perf_counter() - t0
        np.testing.assert_allclose(a, b, rtol=1e-13, atol=1e-14)
        steps = (20_000 if args.quick else 200_000) // max(1, k.n_dof // 2)
        tp = ns_per_step(lambda s: rk4_through_pointer(f, y0.copy(), p, W, 1e-3, s), steps)
        ti = ns_per_step(lambda s: inlined(y0.copy(), p, W, 1e-3, s), steps)
        print(f"{name:>16} {tp:16.0f} {ti:16.0f} {tp / ti:6.2f} {first_pointer:17.2f} "
              f"{first_inlined:17.2f}")


if __name__ == "__main__":
    main()
