"""Speed of the route to chaos: a Lyapunov map and a bifurcation diagram (issue 21, point 6).

1. **Lyapunov map** (issue's target: 100 × 100 points over 2000 drive periods in < 60 s,
   warm, on this 2-core machine).  The damped vertically driven pendulum (l = 1 m,
   g = 9.81 m/s², γ = 0.1 ω0) over A ∈ [0.02, 1] m × ω ∈ [0.8, 6] ω0, from θ = 0.3 at
   rest; 2000 periods per point = 200 transient + 1800 recorded.

   a. ``kapitza.chaos.lyapunov_grid`` as called by default on the whole grid (the
      absolute number the target is about): on lanes, J v exact by forward mode;
   b. the peers on a regular 10 × 10 sub-grid of it, in interleaved rounds (best of 2):
      the default; on lanes with J v by a directional difference; the per-point kernel
      (the path before lanes; the default there: the difference) and with the exact
      Jacobian; and the brute force, a Python loop of
      ``kapitza.chaos.lyapunov(..., exponents="largest")`` over the same points, with the
      grid's settings (the same work, one point per call, one thread) and with
      ``lyapunov``'s defaults (exact Jacobian, rtol 1e-9: what a user writes first).  And
      how far the default's exponents are from the per-point kernel's, in units of their
      stated errors.

2. **Bifurcation diagram** (target: 400 values × 16 starts × 1000 periods in < 10 s,
   warm): ``kapitza.chaos.bifurcation_diagram`` over A ∈ [0.1, 1] m at ω = 2 ω0 (500
   transient + 500 strobe samples), for the undamped pendulum (q̈ = f(q, t): the RKN 12
   lanes of ``simulate_grid``) and the damped one (DOP853 on lanes); beside them the
   damped one by the per-point DOP853 of ``simulate_grid`` (the path before lanes) and
   the diagram by hand — a loop of ``System.simulate`` per (value, start) with
   ``t_eval`` at the strobe times — on a subset, extrapolated.

Absolute times move with the machine's load: every timing is printed with the 1-minute
load average at its end and the process's CPU time (all threads; CPU ÷ wall near the
thread count means the threads ran in parallel, near 1 or below that they waited on a
loaded machine).  The ratios, and CPU per point-period, are what to read on a loaded
machine.

Usage::

    python benchmarks/bench_chaos.py                 # the issue's sizes
    python benchmarks/bench_chaos.py --no-full-map   # without 1a (the longest part)
    python benchmarks/bench_chaos.py --only-targets  # 1a and the two diagrams only
    python benchmarks/bench_chaos.py --quick         # small sizes (a smoke run)
"""
from __future__ import annotations

import argparse
import contextlib
import datetime
import math
import os
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from kapitza.chaos import (  # noqa: E402
    _lyapunov,
    _sections,
    bifurcation_diagram,
    lyapunov,
    lyapunov_grid,
)
from lagrange_core import problems  # noqa: E402

G, L = 9.81, 1.0
W0 = math.sqrt(G / L)


def _timed(run, *args, **kwargs):
    """run(*args, **kwargs): (result, wall s, CPU s of the process's threads, 1-minute
    load at the end)."""
    w0, c0 = time.perf_counter(), time.process_time()
    out = run(*args, **kwargs)
    return out, time.perf_counter() - w0, time.process_time() - c0, os.getloadavg()[0]


@contextlib.contextmanager
def per_point():
    """The chaos room's paths as they were before lanes: the per-point kernels."""
    lanes, strobe = _lyapunov._lanes, _sections.lanes_apply
    _lyapunov._lanes = lambda system, jvp=False: False
    _sections.lanes_apply = lambda system, method: False
    try:
        yield
    finally:
        _lyapunov._lanes, _sections.lanes_apply = lanes, strobe


def _params(A, omega, gamma):
    p = dict(A=A, omega=omega, g=G, l=L, m=1.0)
    if gamma is not None:
        p["gamma"] = gamma
    return p


def lyapunov_map(n, periods, transient, sub, rounds, full, peers_too=True):
    s = problems.driven_pendulum("vertical", damping=True)
    A = np.linspace(0.02, 1.0, n)
    omega = W0 * np.linspace(0.8, 6.0, n)
    P = _params(A[:, None], omega[None, :], 0.1 * W0)
    per_point_periods = periods + transient
    # warm: every kernel compiled (or loaded from numba's cache) before timing
    small = _params(A[:2, None], omega[None, :2], 0.1 * W0)
    for tangent in ("difference", "jacobian"):
        for where in (contextlib.nullcontext(), per_point()):
            with where:
                lyapunov_grid(s, small, 0.3, periods=8, transient=0, blocks=2, tangent=tangent,
                              progress=False)
        lyapunov(s, _params(0.5, 2 * W0, 0.1 * W0), 0.3, periods=8, transient=0, blocks=2,
                 exponents="largest", tangent=tangent, progress=False)
    chaos_map = None
    if full:
        # the progress reports' times: Ctrl-C is seen between calls, so the longest gap
        # between reports is how long Ctrl-C may wait
        stamps = []
        chaos_map, dt, cpu, load = _timed(lambda: lyapunov_grid(
            s, P, 0.3, periods=periods, transient=transient,
            progress=lambda done, total: stamps.append(time.perf_counter())))
        gaps = np.diff(stamps) if len(stamps) > 1 else np.array([dt])
        total = n * n * per_point_periods
        print(f"\n1a. Lyapunov map, lyapunov_grid as called by default (tangent "
              f"{chaos_map.tangent!r}): {n} × {n} points × {per_point_periods} periods "
              f"({transient} transient) = {total:.3g} point-periods: {dt:.1f} s wall, "
              f"{cpu:.1f} s CPU, load {load:.1f} ({dt / total * 1e6:.2f} µs wall and "
              f"{cpu / total * 1e6:.2f} µs CPU per point-period, "
              f"{chaos_map.steps.mean() / per_point_periods:.2f} steps per period), "
              f"{int(chaos_map.chaotic.sum())} points chaotic; {len(stamps)} progress "
              f"reports, at most {gaps.max():.2f} s apart (Ctrl-C waits at most that)",
              flush=True)
    if not peers_too:
        return chaos_map
    # the peers on the same regular sub-grid (every `every`-th value of each axis), in
    # interleaved rounds (the machine is shared): each peer's best round
    every = max(1, n // sub)
    idx = np.arange(0, n, every)
    Ps = _params(A[idx, None], omega[None, idx], 0.1 * W0)
    points = [(A[i], omega[j]) for i in idx for j in idx]

    def grid(**kw):
        return lyapunov_grid(s, Ps, 0.3, periods=periods, transient=transient, progress=False,
                             **kw)

    def grid_per_point(**kw):
        with per_point():
            return grid(**kw)

    def loop(**kw):
        return [lyapunov(s, _params(a, w, 0.1 * W0), 0.3, periods=periods,
                         transient=transient, exponents="largest", progress=False,
                         **kw).exponents[0] for a, w in points]

    peers = [("lyapunov_grid (default: lanes, J v exact, rtol 1e-6)", lambda: grid()),
             ("lyapunov_grid, lanes, J v by difference", lambda: grid(tangent="difference")),
             ("lyapunov_grid per point, J v by difference (before lanes)",
              lambda: grid_per_point(tangent="difference")),
             ("lyapunov_grid per point, exact Jacobian", lambda: grid_per_point(
                 tangent="jacobian")),
             ("loop of lyapunov, the grid's settings (difference, rtol 1e-6)",
              lambda: loop(tangent="difference", rtol=1e-6)),
             ("loop of lyapunov, its defaults (exact Jacobian, rtol 1e-9)", lambda: loop())]
    best = {label: (math.inf, math.nan, math.nan) for label, _ in peers}
    results = {}
    for _ in range(rounds):
        for label, run in peers:
            out, dt, cpu, load = _timed(run)
            results[label] = out
            if dt < best[label][0]:
                best[label] = (dt, cpu, load)
    m = len(points)
    base = best[peers[0][0]][0]
    print(f"\n1b. The peers on a {idx.size} × {idx.size} sub-grid of it ({m} points × "
          f"{per_point_periods} periods), best of {rounds} interleaved rounds:")
    print(f"   {'peer':<66} {'seconds':>8} {'CPU s':>7} {'load':>5} {'µs CPU/pt-period':>17} "
          f"{'÷ default':>10}")
    for label, _ in peers:
        dt, cpu, load = best[label]
        print(f"   {label:<66} {dt:8.2f} {cpu:7.2f} {load:5.1f} "
              f"{cpu / (m * per_point_periods) * 1e6:17.2f} {dt / base:10.2f}")
    lanes, old = results[peers[0][0]], results[peers[2][0]]
    gap = np.abs(lanes.exponent - old.exponent) / (lanes.error + old.error)
    neither = ~old.chaotic & ~lanes.chaotic
    quiet = np.nanmax(np.abs(lanes.exponent - old.exponent)[neither]) if neither.any() else 0.0
    print(f"   default against the per-point path: |Δλ| ≤ {np.nanmax(gap):.2f} × (the sum of "
          f"their stated errors); {int(np.sum(gap > 1))} of {m} points beyond it; points "
          f"chaotic in neither: |Δλ| ≤ {quiet:.1e} 1/s; chaotic: {int(lanes.chaotic.sum())} "
          f"and {int(old.chaotic.sum())}", flush=True)
    return chaos_map


def bifurcation(values, starts, periods, transient, subset, old_share):
    rows = []
    A = np.linspace(0.1, 1.0, values)
    q0 = np.linspace(-2.5, 2.5, starts)
    total = values * starts * (periods + transient)
    for name, gamma, old in (("undamped (RKN 12 lanes)", None, False),
                             ("damped γ = 0.1 ω0 (DOP853 lanes)", 0.1 * W0, False),
                             ("damped, DOP853 per point (before)", 0.1 * W0, True)):
        s = problems.driven_pendulum("vertical", damping=gamma is not None)
        P = _params(0.0, 2 * W0, gamma)
        kw = dict(parameter="A", q0=q0, periods=periods, transient=transient, angles="theta",
                  progress=False)
        where = per_point() if old else contextlib.nullcontext()
        # the per-point path on every old_share-th value, extrapolated
        vals = A[::old_share] if old else A
        with where:
            bifurcation_diagram(s, P, values=A[:2], **dict(kw, periods=4, transient=4))
            d, dt, cpu, load = _timed(bifurcation_diagram, s, P, values=vals, **kw)
        scale = A.size / vals.size
        dt, cpu = dt * scale, cpu * scale
        # by hand: one System.simulate per (value, start), sampled at the strobe times
        T = 2 * math.pi / (2 * W0)
        times = (transient + np.arange(periods)) * T
        rng = np.random.default_rng(2)
        pairs = [(A[rng.integers(values)], q0[rng.integers(starts)]) for _ in range(subset)]
        s.simulate([0.1], [0.0], (0.0, 2 * T), dict(P, A=0.5), t_eval=np.array([T]))   # warm
        t1 = time.perf_counter()
        for a, start in pairs:
            s.simulate([start], [0.0], (0.0, times[-1]), dict(P, A=a), rtol=d.rtol,
                       t_eval=times)
        loop = (time.perf_counter() - t1) * values * starts / subset
        rows.append((name + (f" (1/{old_share}, ×{scale:.0f})" if old else ""), dt, cpu, load,
                      loop, d.method))
    print(f"\n2. Bifurcation diagram: {values} values × {starts} starts × "
          f"{periods + transient} periods ({transient} transient) = {total:.3g} point-periods")
    print(f"   {'system':<46} {'method':>7} {'seconds':>8} {'CPU s':>7} {'load':>5} "
          f"{'µs CPU/pt-period':>17} {'loop of simulate (extrapolated)':>32} {'ratio':>6}")
    for name, dt, cpu, load, loop, method in rows:
        print(f"   {name:<46} {method:>7} {dt:8.1f} {cpu:7.1f} {load:5.1f} "
              f"{cpu / total * 1e6:17.2f} {loop:32.1f} {loop / dt:6.1f}", flush=True)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--quick", action="store_true", help="small sizes (a smoke run)")
    ap.add_argument("--save", metavar="PNG", help="save the default map's figure there")
    ap.add_argument("--no-full-map", action="store_true",
                    help="skip 1a, the full map (the longest part)")
    ap.add_argument("--only-targets", action="store_true",
                    help="1a and the diagrams only (no peers on the sub-grid)")
    args = ap.parse_args()
    print(f"bench_chaos: {datetime.datetime.now():%Y-%m-%d %H:%M}, {os.cpu_count()} cores, "
          f"load average {os.getloadavg()[0]:.1f} at the start", flush=True)
    full = not args.no_full_map
    if args.quick:
        chaos_map = lyapunov_map(12, 180, 20, sub=4, rounds=1, full=full,
                                 peers_too=not args.only_targets)
        bifurcation(40, 4, 50, 50, subset=4, old_share=4)
    else:
        chaos_map = lyapunov_map(100, 1800, 200, sub=10, rounds=2, full=full,
                                 peers_too=not args.only_targets)
        bifurcation(400, 16, 500, 500, subset=16, old_share=10)
    if args.save and chaos_map is not None:
        chaos_map.figure().savefig(args.save, dpi=110)
        print(f"the map: {args.save}")
    print(f"\nload average at the end {os.getloadavg()[0]:.1f}")


if __name__ == "__main__":
    main()
