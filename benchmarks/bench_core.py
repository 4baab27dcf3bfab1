"""Foundation benchmarks (issue 2): derivation, compilation and one right-hand side.

Run:  python benchmarks/bench_core.py [--quick]

1. Deriving the N-link pendulum: lagrange_core.derive vs sympy's LagrangesMethod,
   same process, equal equations checked at random states.
2. Statement -> compiled kernels in a cold process (empty disk cache) and a warm
   one, for N = 8 and N = 16 (each in a fresh subprocess; interpreter and
   import time reported separately; medians of 3 runs).
3. One right-hand-side evaluation of the double pendulum (mass-matrix solve
   included) in a numba loop, against a hand-written numba right-hand side.
4. The same for the 8- and 16-link pendulum, against a hand-written O(N²) numba
   right-hand side (closed-form M and F, the same dense solver).

Absolute times drift on a shared machine; the ratios are the result.
"""
from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import textwrap
import time

import numpy as np
import sympy as sp
from numba import njit
from sympy.physics.mechanics import LagrangesMethod, dynamicsymbols

import lagrange_core as lc
from lagrange_core import problems
from lagrange_core._linalg import solve_dense


def lagranges_method_n_link(n):
    """The N-link pendulum stated for sympy.physics.mechanics, derived by LagrangesMethod."""
    q = dynamicsymbols(f"theta1:{n + 1}")
    t = dynamicsymbols._t
    g = sp.Symbol("g", positive=True)
    x = y = 0
    L = 0
    for i in range(n):
        m, l = sp.symbols(f"m{i + 1} l{i + 1}", positive=True)
        x, y = x + l * sp.sin(q[i]), y - l * sp.cos(q[i])
        L += m * (x.diff(t) ** 2 + y.diff(t) ** 2) / 2 - m * g * y
    lm = LagrangesMethod(L, q)
    lm.form_lagranges_equations()
    return lm, q


def bench_derive(n, check=True):
    t0 = time.perf_counter()
    lm, qdyn = lagranges_method_n_link(n)
    M_ref, F_ref = lm.mass_matrix, lm.forcing
    t_ref = time.perf_counter() - t0

    t0 = time.perf_counter()
    system = problems.n_link_pendulum(n)
    lc.derive(system)
    t_ours = time.perf_counter() - t0

    err = float("nan")
    if check:
        rng = np.random.default_rng(0)
        sub_plain = {d.diff(dynamicsymbols._t): v for d, v in zip(qdyn, system.qdot, strict=True)}
        sub_plain.update(dict(zip(qdyn, system.q, strict=True)))
        args = [*system.q, *system.qdot, *system.parameter_symbols]
        f_ref = sp.lambdify(args, [M_ref.xreplace(sub_plain), F_ref.xreplace(sub_plain)])
        kern = system.kernels
        err = 0.0
        for _ in range(3):
            q, qd = rng.uniform(-3, 3, n), rng.uniform(-2, 2, n)
            p = rng.uniform(0.5, 2, len(system.parameters))
            Mr, Fr = (np.array(a, float) for a in f_ref(*q, *qd, *p))
            M, F = np.empty((n, n)), np.empty(n)
            kern.mass_forcing(q, qd, 0.0, p, M, F)
            err = max(err, np.abs(M - Mr).max() / np.abs(Mr).max(),
                      np.abs(F - Fr.ravel()).max() / np.abs(Fr).max())
    return t_ref, t_ours, err


_COMPILE_SCRIPT = textwrap.dedent("""
    import json, sys, time
    t0 = time.perf_counter()
    import lagrange_core as lc
    t1 = time.perf_counter()
    system = lc.problems.n_link_pendulum({n})
    kernels = system.kernels             # derive (if not cached), generate, compile or load rhs
    t2 = time.perf_counter()
    import numpy as np
    n = {n}
    kernels.jacobian(0.0, np.zeros(2 * n), np.ones(2 * n + 1), np.empty((2 * n, 2 * n)))
    t3 = time.perf_counter()
    kernels.warm(everything=True)        # the kernels compiled on first use
    t4 = time.perf_counter()
    print(json.dumps({{"import": t1 - t0, "kernels": t2 - t1, "jacobian": t3 - t2,
                      "rest": t4 - t3}}))
""")


def bench_compile(n, repeat=3):
    """Cold (empty cache) and warm statement -> kernels times, in fresh processes; the
    median of ``repeat`` cold/warm pairs (each a new empty cache), per column."""
    runs = {"cold": [], "warm": []}
    for _ in range(repeat):
        with tempfile.TemporaryDirectory() as cache:
            env = {**os.environ, "LAGRANGE_CORE_CACHE": cache}
            for label in ("cold", "warm"):
                res = subprocess.run([sys.executable, "-c", _COMPILE_SCRIPT.format(n=n)], env=env,
                                     capture_output=True, text=True, check=True)
                runs[label].append(json.loads(res.stdout.strip().splitlines()[-1]))
    return {label: {key: float(np.median([r[key] for r in rs])) for key in rs[0]}
            for label, rs in runs.items()}


@njit(cache=True)
def _hand_rhs(t, y, p, dydt):
    """Double pendulum written by hand (p = g, l1, l2, m1, m2), 2x2 solve by Cramer's rule."""
    g, l1, l2, m1, m2 = p[0], p[1], p[2], p[3], p[4]
    th1, th2, w1, w2 = y[0], y[1], y[2], y[3]
    c = np.cos(th1 - th2)
    s = np.sin(th1 - th2)
    a11 = (m1 + m2) * l1 * l1
    a12 = m2 * l1 * l2 * c
    a22 = m2 * l2 * l2
    f1 = -m2 * l1 * l2 * s * w2 * w2 - (m1 + m2) * g * l1 * np.sin(th1)
    f2 = m2 * l1 * l2 * s * w1 * w1 - m2 * g * l2 * np.sin(th2)
    det = a11 * a22 - a12 * a12
    dydt[0] = w1
    dydt[1] = w2
    dydt[2] = (a22 * f1 - a12 * f2) / det
    dydt[3] = (a11 * f2 - a12 * f1) / det


def _make_loop(rhs, with_work):
    if with_work:
        @njit
        def loop(y, p, W, n):
            out = np.empty(y.shape[0])
            acc = 0.0
            for i in range(n):
                y[0] = 0.1 + 1e-7 * i    # a new state each time: no loop-invariant hoisting
                rhs(0.0, y, p, out, W)
                acc += out[2]
            return acc
    else:
        @njit
        def loop(y, p, W, n):
            out = np.empty(y.shape[0])
            acc = 0.0
            for i in range(n):
                y[0] = 0.1 + 1e-7 * i
                rhs(0.0, y, p, out)
                acc += out[2]
            return acc
    return loop


def bench_rhs(n_calls):
    system = problems.double_pendulum()
    k = system.kernels
    p = system.parameter_array(dict(g=9.81, l1=1.0, l2=0.8, m1=1.0, m2=1.3))
    y = np.array([0.1, 0.2, 0.3, 0.4])
    ours = _make_loop(k.rhs, True)
    hand = _make_loop(_hand_rhs, False)
    W = k.work_array()
    a, b = ours(y.copy(), p, W, 10), hand(y.copy(), p, W, 10)
    assert abs(a - b) < 1e-9 * abs(b), (a, b)
    return {"lagrange_core": _ns_per_call(ours, y, p, W, n_calls),
            "hand-written": _ns_per_call(hand, y, p, W, n_calls)}


def _ns_per_call(loop, y, p, W, n_calls):
    """Best of 5 timed runs of a compiled loop, in ns per right-hand side."""
    loop(y.copy(), p, W, 10)
    best = np.inf
    for _ in range(5):
        t0 = time.perf_counter()
        loop(y.copy(), p, W, n_calls)
        best = min(best, time.perf_counter() - t0)
    return best / n_calls * 1e9


@njit(cache=True)
def _hand_rhs_chain(t, y, p, dydt, W):
    """N-link pendulum by hand (p = g, l1..lN, m1..mN): M_ij = μ_ij l_i l_j cos(θ_i − θ_j),
    F_i = −Σ_j μ_ij l_i l_j sin(θ_i − θ_j) ω_j² − μ_ii g l_i sin θ_i,
    μ_ij = Σ_{k ≥ max(i,j)} m_k."""
    n = y.shape[0] // 2
    g = p[0]
    mu = np.empty(n)                   # mu[i] = Σ_{k ≥ i} m_k
    s = 0.0
    for i in range(n - 1, -1, -1):
        s += p[1 + n + i]
        mu[i] = s
    for i in range(n):
        li = p[1 + i]
        f = -mu[i] * g * li * np.sin(y[i])
        for j in range(n):
            c = mu[max(i, j)] * li * p[1 + j]
            W[i, j] = c * np.cos(y[i] - y[j])
            f -= c * np.sin(y[i] - y[j]) * y[n + j] * y[n + j]
        W[i, n] = f
    status = solve_dense(W, n)
    for i in range(n):
        dydt[i] = y[n + i]
        dydt[n + i] = W[i, n]
    return status


def bench_chain_rhs(n, n_calls):
    system = problems.n_link_pendulum(n)
    k = system.kernels
    rng = np.random.default_rng(1)
    values = {name: rng.uniform(0.5, 1.5) for name in system.parameters}
    p = system.parameter_array(values)       # sorted by name: g, l1, l10, l11, ...
    p_hand = np.array([values["g"]] + [values[f"{c}{i + 1}"] for c in "lm" for i in range(n)])
    y = rng.uniform(-1, 1, 2 * n)
    ours, hand = _make_loop(k.rhs, True), _make_loop(_hand_rhs_chain, True)
    a, b = np.empty(2 * n), np.empty(2 * n)
    k.rhs(0.0, y, p, a, k.work_array())
    _hand_rhs_chain(0.0, y, p_hand, b, np.zeros((n, n + 1)))
    np.testing.assert_allclose(a, b, rtol=1e-10, atol=1e-10)
    return {"lagrange_core": _ns_per_call(ours, y, p, k.work_array(), n_calls),
            "hand-written": _ns_per_call(hand, y, p_hand, np.zeros((n, n + 1)), n_calls)}


def main():
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--quick", action="store_true", help="smaller sizes (a smoke run)")
    args = ap.parse_args()

    print("1. derivation of the N-link pendulum (s)")
    print(f"{'N':>4} {'LagrangesMethod':>16} {'lagrange_core':>14} {'ratio':>8} "
          f"{'max rel diff':>13}")
    for n in ((3,) if args.quick else (4, 8)):
        t_ref, t_ours, err = bench_derive(n)
        print(f"{n:>4} {t_ref:16.3f} {t_ours:14.4f} {t_ref / t_ours:8.0f} {err:13.1e}")
    for n in (() if args.quick else (16,)):
        t0 = time.perf_counter()
        lc.derive(problems.n_link_pendulum(n))
        print(f"{n:>4} {'(not run)':>16} {time.perf_counter() - t0:14.4f}")

    print("\n2. statement -> compiled kernels, fresh process (s; import of the package separate)")
    print("   rhs: derive, generate, compile M, F and the solve; total = rhs + Jacobian;")
    print("   rest: every other kernel (compiled on first use); medians of 3 runs")
    print(f"{'N':>4} {'cache':>6} {'import':>7} {'rhs':>6} {'+jacobian':>10} {'total':>6} "
          f"{'rest':>6}")
    for n in ((2,) if args.quick else (8, 16)):
        res = bench_compile(n, 1 if args.quick else 3)
        for label, r in res.items():
            print(f"{n:>4} {label:>6} {r['import']:7.2f} {r['kernels']:6.2f} {r['jacobian']:10.2f} "
                  f"{r['kernels'] + r['jacobian']:6.2f} {r['rest']:6.2f}")

    print("\n3. one right-hand side of the double pendulum in a numba loop (ns per call)")
    t = bench_rhs(200_000 if args.quick else 5_000_000)
    for name, ns in t.items():
        print(f"   {name:>14}: {ns:6.1f} ns")
    print(f"   ratio lagrange_core / hand-written: {t['lagrange_core'] / t['hand-written']:.2f}")

    print("\n4. one right-hand side of the N-link pendulum in a numba loop (ns per call)")
    for n in ((4,) if args.quick else (8, 16)):
        t = bench_chain_rhs(n, 20_000 if args.quick else 200_000)
        print(f"   N = {n:>2}: lagrange_core {t['lagrange_core']:8.0f}   hand-written "
              f"{t['hand-written']:8.0f}   ratio {t['lagrange_core'] / t['hand-written']:.2f}")


if __name__ == "__main__":
    main()
