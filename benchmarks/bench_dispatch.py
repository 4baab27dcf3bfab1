"""How an integrator reaches a system's right-hand side: inlined or by address.

Run:  python benchmarks/bench_dispatch.py [--quick]

Until issue 9 the integrators were kernel templates bound to each system: the system's
``rhs`` was inlined into the integrator loop, and the loop compiled per system (the
first ``simulate`` of a new system cost 5-15 s cold).  Now one loop, compiled once per
installation, calls the system's ``rhs`` by address (``Kernels.addresses`` and the
intrinsics of ``lagrange_core._kernel_calls``: an ``int64`` address cast to the C
signature, the arrays' raw data pointers).  This measures what that costs per call, with
the same RK4 loop both ways, in one process; printed: ns per step and the ratio.  (An
earlier variant passed ``@cfunc`` objects, typed ``FunctionType``: ~1 ms per Python call
to type them; passing ``arr.ctypes`` instead of raw pointers cost ~60 ns per call.)

Absolute times drift on a shared machine; the ratios are the result.
"""
from __future__ import annotations

import argparse
import time

import numpy as np
from numba import njit

from lagrange_core import problems
from lagrange_core._kernel_calls import RHS, call_rhs


@njit(cache=True)
def rk4_by_address(ka, y, p, W, h, steps):
    """RK4 steps of y' = f(t, y), f the system's rhs reached by address (slot RHS of ka)."""
    n2 = y.shape[0]
    k1, k2, k3, k4, yt = np.empty(n2), np.empty(n2), np.empty(n2), np.empty(n2), np.empty(n2)
    a = ka[RHS]
    for _ in range(steps):
        call_rhs(a, 0.0, y, p, k1, W)
        for i in range(n2):
            yt[i] = y[i] + 0.5 * h * k1[i]
        call_rhs(a, 0.0, yt, p, k2, W)
        for i in range(n2):
            yt[i] = y[i] + 0.5 * h * k2[i]
        call_rhs(a, 0.0, yt, p, k3, W)
        for i in range(n2):
            yt[i] = y[i] + h * k3[i]
        call_rhs(a, 0.0, yt, p, k4, W)
        for i in range(n2):
            y[i] += h / 6 * (k1[i] + 2 * k2[i] + 2 * k3[i] + k4[i])
    return y


def rk4_inlined(rhs):
    """The same loop with the system's rhs inlined (what the per-system templates did)."""
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


def ns_per_step(run, steps):
    best = np.inf
    for _ in range(5):
        t0 = time.perf_counter()
        run(steps)
        best = min(best, time.perf_counter() - t0)
    return best / steps * 1e9


def main():
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--quick", action="store_true", help="fewer steps (a smoke run)")
    args = ap.parse_args()
    print("first call: compile (or load) everything the loop needs for this system, in s")
    print(f"{'system':>16} {'address ns/step':>16} {'inlined ns/step':>16} {'ratio':>6} "
          f"{'address 1st call':>17} {'inlined 1st call':>17}")
    for name, system in (("pendulum", problems.pendulum()),
                         ("double pendulum", problems.double_pendulum()),
                         ("8-link pendulum", problems.n_link_pendulum(8))):
        k = system.kernels
        p = np.random.default_rng(0).uniform(0.5, 1.5, len(system.parameters))
        y0, W = np.full(2 * k.n_dof, 0.1), k.work_array()
        t0 = time.perf_counter()
        ka = k.addresses("rhs")
        a = rk4_by_address(ka, y0.copy(), p, W, 1e-3, 10)
        first_address = time.perf_counter() - t0
        t0 = time.perf_counter()
        inlined = rk4_inlined(k.rhs)
        b = inlined(y0.copy(), p, W, 1e-3, 10)
        first_inlined = time.perf_counter() - t0
        np.testing.assert_allclose(a, b, rtol=1e-13, atol=1e-14)
        steps = (20_000 if args.quick else 200_000) // max(1, k.n_dof // 2)
        tp = ns_per_step(lambda s, ka=ka, y0=y0, p=p, W=W:
                         rk4_by_address(ka, y0.copy(), p, W, 1e-3, s), steps)
        ti = ns_per_step(lambda s, inlined=inlined, y0=y0, p=p, W=W:
                         inlined(y0.copy(), p, W, 1e-3, s), steps)
        print(f"{name:>16} {tp:16.0f} {ti:16.0f} {tp / ti:6.2f} {first_address:17.2f} "
              f"{first_inlined:17.2f}")


if __name__ == "__main__":
    main()
