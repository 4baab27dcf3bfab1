"""Speed of the route to chaos: a Lyapunov map and a bifurcation diagram (issue 21, point 4).

1. **Lyapunov map** (issue's target: 100 × 100 points over 2000 drive periods in < 60 s,
   warm, on this 2-core machine).  The damped vertically driven pendulum (l = 1 m,
   g = 9.81 m/s², γ = 0.1 ω0) over A ∈ [0.02, 1] m × ω ∈ [0.8, 6] ω0, from θ = 0.3 at
   rest; 2000 periods per point = 200 transient + 1800 recorded.  Peers in this one run:

   * ``kapitza.chaos.lyapunov_grid`` as called by default (J v by a directional
     difference, rtol 1e-6), at rtol 1e-5, and with the exact Jacobian (rtol 1e-6);
   * the brute force: a Python loop of ``kapitza.chaos.lyapunov(..., exponents="largest")``
     over a subset of points, extrapolated to the grid — with the grid's settings (the
     same work, one point per call, one thread), and with ``lyapunov``'s defaults (exact
     Jacobian, rtol 1e-9: what a user would write first).

   The ratios are what to read (the machine is shared; its load is printed).

2. **Bifurcation diagram** (target: 400 values × 16 starts × 1000 periods in < 10 s,
   warm): ``kapitza.chaos.bifurcation_diagram`` over A ∈ [0.1, 1] m at ω = 2 ω0 (500
   transient + 500 strobe samples), for the undamped pendulum (q̈ = f(q, t): the RKN 12
   lanes of ``simulate_grid``) and the damped one (DOP853 per point); beside it, a loop of
   one ``bifurcation_diagram`` call per value on a subset, extrapolated.

Usage::

    python benchmarks/bench_chaos.py            # the issue's sizes
    python benchmarks/bench_chaos.py --quick    # small sizes (a smoke run)
"""
from __future__ import annotations

import argparse
import datetime
import math
import os
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from kapitza.chaos import bifurcation_diagram, lyapunov, lyapunov_grid  # noqa: E402
from lagrange_core import problems  # noqa: E402

G, L = 9.81, 1.0
W0 = math.sqrt(G / L)


def _params(A, omega, gamma):
    p = dict(A=A, omega=omega, g=G, l=L, m=1.0)
    if gamma is not None:
        p["gamma"] = gamma
    return p


def lyapunov_map(n, periods, transient, subset):
    s = problems.driven_pendulum("vertical", damping=True)
    A = np.linspace(0.02, 1.0, n)
    omega = W0 * np.linspace(0.8, 6.0, n)
    P = _params(A[:, None], omega[None, :], 0.1 * W0)
    total = n * n * (periods + transient)
    # warm: every kernel compiled (or loaded from numba's cache) before timing
    lyapunov_grid(s, _params(A[:2, None], omega[None, :2], 0.1 * W0), 0.3, periods=8,
                  transient=0, blocks=2, progress=False)
    lyapunov_grid(s, _params(A[:2, None], omega[None, :2], 0.1 * W0), 0.3, periods=8,
                  transient=0, blocks=2, tangent="jacobian", progress=False)
    lyapunov(s, _params(0.5, 2 * W0, 0.1 * W0), 0.3, periods=8, transient=0, blocks=2,
             exponents="largest", progress=False)
    rows = []
    maps = {}
    # the exact Jacobian costs ~4× more: on every `every`-th point of each axis, extrapolated
    every = max(1, n // 20)
    sub = _params(A[::every, None], omega[None, ::every], 0.1 * W0)
    for label, kw, grid in (
            ("lyapunov_grid (default: difference, rtol 1e-6)", {}, P),
            ("lyapunov_grid, rtol 1e-5", dict(rtol=1e-5), P),
            (f"lyapunov_grid, exact Jacobian, rtol 1e-6 ({n // every}² sub-grid, extrapolated)",
             dict(tangent="jacobian"), sub)):
        t0 = time.perf_counter()
        g = lyapunov_grid(s, grid, 0.3, periods=periods, transient=transient, progress=False,
                          **kw)
        dt = time.perf_counter() - t0
        maps[label] = g
        rows.append((label, dt, dt * n * n / g.exponent.size, int(g.chaotic.sum())))
    # the brute force: a Python loop of lyapunov on `subset` points spread over the grid
    rng = np.random.default_rng(1)
    pick = rng.choice(n * n, size=subset, replace=False)
    for label, kw in (("loop of lyapunov, same settings", dict(tangent="difference", rtol=1e-6)),
                      ("loop of lyapunov, its defaults (Jacobian, rtol 1e-9)", {})):
        t0 = time.perf_counter()
        for k in pick:
            i, j = divmod(int(k), n)
            lyapunov(s, _params(A[i], omega[j], 0.1 * W0), 0.3, periods=periods,
                     transient=transient, exponents="largest", progress=False, **kw)
        dt = time.perf_counter() - t0
        rows.append((label + f" ({subset} points, extrapolated)", dt, dt * n * n / subset, None))
    base = rows[0][2]
    print(f"\n1. Lyapunov map: {n} × {n} points × {periods + transient} periods "
          f"({transient} transient) = {total:.3g} point-periods")
    print(f"   {'peer':<84} {'seconds':>8} {'µs/pt-period':>13} {'× default':>10}  chaotic")
    for label, _, full, chaotic in rows:
        print(f"   {label:<84} {full:8.1f} {full / total * 1e6:13.2f} {full / base:10.2f}  "
              f"{'' if chaotic is None else chaotic}")
    a, b = maps[rows[0][0]], maps[rows[2][0]]
    agree = np.mean(a.chaotic[::every, ::every] == b.chaotic)
    print(f"   difference vs exact Jacobian: same chaotic/regular call at {agree:.1%} of the "
          f"common points; steps per period {a.steps.mean() / (periods + transient):.2f}")
    return rows, maps[rows[0][0]]


def bifurcation(values, starts, periods, transient, subset):
    rows = []
    A = np.linspace(0.1, 1.0, values)
    q0 = np.linspace(-2.5, 2.5, starts)
    for name, gamma in (("undamped (RKN 12 lanes)", None), ("damped γ = 0.1 ω0 (DOP853)",
                                                            0.1 * W0)):
        s = problems.driven_pendulum("vertical", damping=gamma is not None)
        P = _params(0.0, 2 * W0, gamma)
        kw = dict(parameter="A", q0=q0, periods=periods, transient=transient, angles="theta",
                  progress=False)
        bifurcation_diagram(s, P, values=A[:2], **dict(kw, periods=4, transient=4))
        t0 = time.perf_counter()
        d = bifurcation_diagram(s, P, values=A, **kw)
        dt = time.perf_counter() - t0
        t1 = time.perf_counter()
        for a in A[:: max(1, values // subset)][:subset]:
            bifurcation_diagram(s, P, values=[a], **kw)
        loop = (time.perf_counter() - t1) * values / min(subset, len(A[:: max(1, values //
                                                                               subset)]))
        rows.append((name, dt, loop, d.method))
    total = values * starts * (periods + transient)
    print(f"\n2. Bifurcation diagram: {values} values × {starts} starts × "
          f"{periods + transient} periods ({transient} transient) = {total:.3g} point-periods")
    print(f"   {'system':<30} {'method':>8} {'seconds':>9} {'µs/pt-period':>13} "
          f"{'loop per value (extrapolated)':>30} {'ratio':>6}")
    for name, dt, loop, method in rows:
        print(f"   {name:<30} {method:>8} {dt:9.1f} {dt / total * 1e6:13.2f} {loop:30.1f} "
              f"{loop / dt:6.1f}")
    return rows


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--quick", action="store_true", help="small sizes (a smoke run)")
    ap.add_argument("--save", metavar="PNG", help="save the default map's figure there")
    args = ap.parse_args()
    print(f"bench_chaos: {datetime.date.today()}, {os.cpu_count()} cores, load average "
          f"{os.getloadavg()[0]:.1f} at the start")
    if args.quick:
        _, chaos_map = lyapunov_map(12, 180, 20, subset=4)
        bifurcation(40, 4, 50, 50, subset=4)
    else:
        _, chaos_map = lyapunov_map(100, 1800, 200, subset=12)
        bifurcation(400, 16, 500, 500, subset=8)
    if args.save:
        chaos_map.figure().savefig(args.save, dpi=110)
        print(f"the map: {args.save}")
    print(f"\nload average at the end {os.getloadavg()[0]:.1f}")


if __name__ == "__main__":
    main()
