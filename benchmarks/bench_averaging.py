"""Averaging benchmarks (issue 4): what a prediction costs, and what it saves.

Run:  python benchmarks/bench_averaging.py [--quick]

Side by side in one process, per (A, ω) point of a stability sweep of the
vertically driven pendulum:

1. ``pendulum_averaged`` on a whole grid (closed forms, numpy, order 1 and 2);
2. the general machinery, ``average(system).slow_modes`` (compiled U_eff
   Hessian + a 1x1 generalized eigenproblem), point by point;
3. the exact reference: one monodromy matrix of the linearised equation by
   scipy's solve_ivp (DOP853, rtol 1e-10), point by point — what a Floquet
   sweep without averaging costs in plain scipy.

And for the double pendulum (Acheson): ``multiple_pendulum_upright`` on a grid
against ``average(chain).slow_modes`` per point.

Absolute times drift on a shared machine; the ratios are the result.
"""
from __future__ import annotations

import argparse
import math
import time

import numpy as np
import sympy as sp
from scipy.integrate import solve_ivp

from kapitza.averaging import average
from kapitza.closed_forms import multiple_pendulum_upright
from kapitza.pendulum import KapitzaPendulum
from lagrange_core import problems, t


def best_of(fn, repeat):
    best = math.inf
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - t0)
    return best


def monodromy_trace(A, w, g=9.81, l=1.0):
    def f(tt, y):
        k = -(g - A * w * w * math.cos(w * tt)) / l
        return [y[1], -k * y[0], y[3], -k * y[2]]
    s = solve_ivp(f, (0, 2 * math.pi / w), [1, 0, 0, 1], method="DOP853", rtol=1e-10, atol=1e-12)
    return s.y[0, -1] + s.y[3, -1]


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--quick", action="store_true", help="small sizes (a few seconds)")
    args = ap.parse_args()
    n_grid = 200 if args.quick else 1000            # grid is n_grid x n_grid
    n_point = 50 if args.quick else 300             # per-point methods
    rep = 2 if args.quick else 5

    p = KapitzaPendulum()
    A = np.linspace(0.005, 0.2, n_grid)[:, None]
    w = np.geomspace(20, 500, n_grid)[None, :]
    rng = np.random.default_rng(1)
    pts = np.column_stack([rng.uniform(0.005, 0.2, n_point), rng.uniform(20, 500, n_point)])

    gen = average(p.system)
    gen.slow_modes(p.params(0.1, 200.0), [math.pi], warn=False)     # compile / load
    rows = []
    for order in (1, 2):
        dt = best_of(lambda order=order: p.averaged(A, w, order=order), rep)
        rows.append((f"pendulum_averaged order {order} (grid)", dt / (A.size * w.size)))
    dt = best_of(lambda: [gen.slow_modes(p.params(a, om), [math.pi], warn=False)
                          for a, om in pts], rep)
    rows.append(("average(system).slow_modes (per point)", dt / n_point))
    m = max(n_point // 5, 5)
    dt = best_of(lambda: [monodromy_trace(a, om) for a, om in pts[:m]], 1)
    rows.append(("exact monodromy, solve_ivp (per point)", dt / m))

    Asym, wsym = sp.symbols("A omega", positive=True)
    chain = problems.n_link_pendulum(2, pivot=(0, Asym * sp.cos(wsym * t)))
    cav = average(chain)
    base = {"g": 9.81, "l1": 1.0, "l2": 1.0, "m1": 1.0, "m2": 1.0}
    cav.slow_modes({**base, "A": 0.02, "omega": 400.0}, [math.pi] * 2, warn=False)
    dt = best_of(lambda: multiple_pendulum_upright([1, 1], [1, 1], A=A, omega=w, warn=False),
                 rep)
    rows.append(("multiple_pendulum_upright N=2 (grid)", dt / (A.size * w.size)))
    dt = best_of(lambda: [cav.slow_modes({**base, "A": a, "omega": om}, [math.pi] * 2, warn=False)
                          for a, om in pts], rep)
    rows.append(("average(chain N=2).slow_modes (per point)", dt / n_point))

    ref = rows[0][1]
    print(f"{'method':48s} {'time per point':>16s} {'ratio':>10s}")
    for name, dt in rows:
        print(f"{name:48s} {dt * 1e6:13.3f} µs {dt / ref:10.1f}")


if __name__ == "__main__":
    main()
