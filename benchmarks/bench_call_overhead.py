"""The fixed cost of one ``simulate`` call: what a short run pays on every call (issue 11, point 8).

Run:  python benchmarks/bench_call_overhead.py [--quick]

Problem: the driven pendulum of ``bench_work_precision.py`` (A = 0.05 m, l = 1 m, 60 Hz,
from θ = π − 0.1 at rest) for 10 drive periods, rtol = atol = 1e-9, the default method,
many calls in a row (compile time excluded by a warm-up call).  Printed, per call (best
of several rounds of ``--calls`` calls):

* ``System.simulate`` as a user calls it (names -> arrays, checks, integration, Trajectory);
* its split: the argument checks (``System.simulate`` minus
  ``integrate.simulate_checked`` on ready arrays and options), the compiled calls (every
  numba function of ``lagrange_core._integrator_kernels`` that the call makes, timed by
  wrapping them: the integration, its start, the energy along the output), and the rest
  (Python in ``integrate``: set-up, buffers, the frozen Trajectory);
* the *fixed cost* = per call minus the compiled integration, and the same for a run of
  one step (``t_span`` = 1 ms);
* peers in the same process on the same 10 periods: heyoka's ``taylor_adaptive`` (state
  reset, ``propagate_until``; tol 1e-9) and scipy's ``solve_ivp`` (DOP853, rtol = atol =
  1e-9, the compiled right-hand side), with the ratios ours / peer.

Absolute times drift on a shared machine; compare figures from one run.
"""
from __future__ import annotations

import argparse
import functools
import math
import sys
import time
from collections import defaultdict
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "benchmarks"))

from lagrange_core import _integrator_kernels as kern  # noqa: E402
from lagrange_core import integrate, problems  # noqa: E402

from bench_work_precision import OMEGA, PARAMS, THETA0, have_heyoka, heyoka_integrator  # noqa: E402

PERIODS = 10
RTOL = 1e-9


#: the clock (``--cpu``: this process's CPU time, less disturbed on a busy shared machine)
CLOCK = {"clock": time.perf_counter}


def per_call(fn, calls, rounds):
    """Best over ``rounds`` of the mean time of ``calls`` calls (s)."""
    return per_call_each([fn], calls, rounds)[0]


def per_call_each(fns, calls, rounds):
    """:func:`per_call` of several functions, their rounds interleaved (so that a busy
    spell of the machine does not fall on one of them only)."""
    best = [float("inf")] * len(fns)
    clock = CLOCK["clock"]
    for _ in range(rounds):
        for i, fn in enumerate(fns):
            t0 = clock()
            for _ in range(calls):
                fn()
            best[i] = min(best[i], (clock() - t0) / calls)
    return best


class CompiledClock:
    """Wraps every numba function of the integrators' kernel module, summing the time
    spent inside them per name (the wrapper's own ~0.1 µs per call counts as compiled)."""

    def __init__(self):
        self.seconds = defaultdict(float)
        self.calls = defaultdict(int)
        self._saved = {}

    def __enter__(self):
        for name in dir(kern):
            obj = getattr(kern, name)
            if hasattr(obj, "py_func"):          # a numba Dispatcher
                self._saved[name] = obj
                setattr(kern, name, self._wrap(name, obj))
        return self

    def _wrap(self, name, fn):
        @functools.wraps(fn.py_func)
        def timed(*args):
            clock = CLOCK["clock"]
            t0 = clock()
            try:
                return fn(*args)
            finally:
                self.seconds[name] += clock() - t0
                self.calls[name] += 1
        return timed

    def __exit__(self, *exc):
        for name, obj in self._saved.items():
            setattr(kern, name, obj)


def clocked(fn, calls, rounds):
    """Per call, in the round of ``calls`` calls that took least: the time, the seconds
    inside each compiled function, and how often each was called."""
    best = (float("inf"), {}, {})
    for _ in range(rounds):
        with CompiledClock() as clock:
            t = per_call(fn, calls, 1)
        if t < best[0]:
            best = (t, {k: v / calls for k, v in clock.seconds.items()},
                    {k: v // calls for k, v in clock.calls.items()})
    return best


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="fewer calls and rounds")
    ap.add_argument("--calls", type=int, default=None)
    ap.add_argument("--cpu", action="store_true",
                    help="time with the process's CPU time instead of the wall clock")
    args = ap.parse_args(argv)
    CLOCK["clock"] = time.process_time if args.cpu else time.perf_counter
    calls = args.calls or (300 if args.quick else 2000)
    rounds = 3 if args.quick else 7
    T = PERIODS * 2 * math.pi / OMEGA
    system = problems.driven_pendulum()
    kernels = system.kernels
    p = system.parameter_array(PARAMS)
    q0, v0 = np.array([THETA0]), np.array([0.0])

    def user(t1=T):
        return system.simulate([THETA0], [0.0], (0.0, t1), PARAMS, rtol=RTOL)

    if hasattr(integrate, "simulate_checked"):
        opts = integrate.check_options((0.0, T), rtol=RTOL)

        def ready():
            return integrate.simulate_checked(kernels, q0, v0, p, opts)
    else:                           # before issue 11.8: the options were checked twice
        def ready():
            return integrate.simulate(kernels, q0, v0, (0.0, T), p, rtol=RTOL)

    tr = user()                                    # compile / load everything once
    user(1e-3)
    ready()
    t_user, t_ready, t_one = per_call_each([user, ready, lambda: user(1e-3)], calls, rounds)
    t_clocked, compiled, counts = clocked(user, calls // 4, rounds)
    t_compiled = sum(compiled.values())
    t_one_compiled = sum(clocked(lambda: user(1e-3), calls // 4, rounds)[1].values())
    one = user(1e-3)

    print(f"driven pendulum, {PERIODS} drive periods, rtol = atol = {RTOL:g}, method "
          f"{tr.method!r} ({tr.n_steps} steps, {tr.n_rejected} rejected, {len(tr)} rows); "
          f"best of {rounds} rounds of {calls} calls, {'CPU' if args.cpu else 'wall-clock'} time")
    print(f"  System.simulate per call             {t_user * 1e6:8.1f} µs")
    print(f"    argument checks (names -> arrays)  {(t_user - t_ready) * 1e6:8.1f} µs")
    print(f"    compiled calls (clocked run: {t_clocked * 1e6:.1f} µs per call)")
    for name, sec in sorted(compiled.items(), key=lambda kv: -kv[1]):
        print(f"      {name:<30} {sec * 1e6:8.1f} µs  ({counts[name]} per call)")
    print(f"    Python in integrate (set-up, Trajectory)  "
          f"{(t_ready - t_compiled) * 1e6:8.1f} µs")
    print(f"  fixed cost (per call - compiled)     {(t_user - t_compiled) * 1e6:8.1f} µs")
    print(f"  a run of {one.n_steps} step(s) (1 ms): per call {t_one * 1e6:.1f} µs, "
          f"fixed cost {(t_one - t_one_compiled) * 1e6:.1f} µs")

    peers = {}
    if have_heyoka():
        ta = heyoka_integrator(RTOL)

        def heyoka_call():
            ta.time = 0.0
            ta.state[:] = [THETA0, 0.0]
            return ta.propagate_until(T)
        heyoka_call()
        peers["heyoka taylor_adaptive"] = per_call(heyoka_call, calls, rounds)
    else:
        print("  heyoka not installed: skipped (pip install 'kapitza[bench]')")
    from scipy.integrate import solve_ivp
    W = kernels.work_array()

    def f(t, y):
        out = np.empty(2)
        kernels.rhs(t, y, p, out, W)
        return out

    def scipy_call():
        return solve_ivp(f, (0.0, T), [THETA0, 0.0], method="DOP853", rtol=RTOL, atol=RTOL)
    scipy_call()
    peers["scipy solve_ivp DOP853"] = per_call(scipy_call, max(calls // 20, 10), rounds)
    print("  peers, same run, per call (ratio ours / peer):")
    for name, sec in peers.items():
        print(f"    {name:<28} {sec * 1e6:10.1f} µs   {t_user / sec:6.2f}")
    return t_user, t_user - t_compiled


if __name__ == "__main__":
    main()
