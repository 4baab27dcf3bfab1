"""Continuation benchmark (issue 21): a 200-point branch against a loop of periodic_orbit.

Run:  python benchmarks/bench_continuation.py [--quick]

Side by side in one process, warm (every kernel compiled by a first run), best of a few:

1. the upright pendulum (vertical drive, ω = 20 ω0) continued in A over [0.02, 0.6] m:
   an equilibrium that persists under the drive, 200 points, both bifurcations located
   (the Kapitza limit's pitchfork and the period doubling at the window's top);
2. the horizontally driven pendulum's tilted orbit (ω = 20 ω0) continued in A from
   0.08 m: a genuine periodic orbit, 200 points;

each against the brute-force alternative: ``kapitza.periodic_orbit`` called at the same
200 parameter values (each from the previous orbit's state, the best guess a loop has),
which gives the orbits and multipliers but no bifurcations.  Target: a 200-point branch in
< 1 s warm.  Absolute times drift on a shared machine; the ratios are the result.
"""
from __future__ import annotations

import argparse
import math
import time
import warnings

import numpy as np

from kapitza.continuation import continuation
from kapitza.simulation import periodic_orbit
from lagrange_core import problems


def best_of(fn, repeat):
    best, out = math.inf, None
    for _ in range(repeat):
        t0 = time.perf_counter()
        out = fn()
        best = min(best, time.perf_counter() - t0)
    return best, out


def brute_force(system, params, values, first):
    """periodic_orbit at each value, from the previous orbit's state."""
    state, out = first, []
    for A in values:
        orbit = periodic_orbit(system, dict(params, A=float(A)), state)
        state = orbit.state
        out.append(orbit)
    return out


def case(name, system, params, about, stop, points, repeat):
    A0 = params["A"]
    step = abs(stop - A0) / (points - 1)
    run = lambda: continuation(system, params, about, parameter="A", stop=stop, step=step,  # noqa: E731
                               max_step=step, max_points=points, progress=False)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)    # max_points before stop: wanted
        run()                                              # warm
        t_branch, branch = best_of(run, repeat)
    values = branch.points.parameter
    brute = lambda: brute_force(system, params, values, branch.points.state[0])  # noqa: E731
    brute()
    t_brute, orbits = best_of(brute, repeat)
    gap = max(float(np.max(np.abs(o.state - s))) for o, s in zip(orbits, branch.points.state,
                                                                 strict=True))
    print(f"\n{name}")
    print(f"  continuation : {len(branch.points):4d} points in {t_branch:.3f} s "
          f"({1e3 * t_branch / len(branch.points):.2f} ms/point, {branch.flows} flows), "
          f"A {values[0]:.4g} → {values[-1]:.4g} m; bifurcations: "
          f"{', '.join(str(b) for b in branch.bifurcations) or 'none'}")
    print(f"  periodic_orbit loop at the same {values.size} values: {t_brute:.3f} s "
          f"(largest state difference {gap:.1e})")
    print(f"  ratio brute force / continuation: {t_brute / t_branch:.2f}   "
          f"target < 1 s: {'met' if t_branch < 1.0 else 'MISSED'}")
    return t_branch, t_brute


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--quick", action="store_true", help="fewer repeats (a few seconds)")
    args = ap.parse_args()
    repeat = 1 if args.quick else 3
    g, l = 9.81, 1.0
    w = 20 * math.sqrt(g / l)
    print("kapitza.continuation: a 200-point branch, warm (best of "
          f"{repeat}); ω = 20 ω0 = {w:.3f} rad/s, l = 1 m")
    case("upright pendulum, vertical drive, A from 0.02 to 0.6 m (persisting equilibrium)",
         problems.driven_pendulum("vertical"), dict(m=1.0, l=l, g=g, A=0.02, omega=w),
         [math.pi], 0.6, 200, repeat)
    horizontal = problems.driven_pendulum("horizontal")
    p = dict(m=1.0, l=l, g=g, A=0.08, omega=w)
    tilted = periodic_orbit(horizontal, p, [math.acos(2 * g * l / (p["A"] * w) ** 2)])
    case("tilted orbit, horizontal drive, A from 0.08 m (a genuine periodic orbit)",
         horizontal, p, tilted.state, 0.2, 200, repeat)


if __name__ == "__main__":
    main()
