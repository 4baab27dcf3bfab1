"""Floquet stability maps (issue 5): speed and accuracy, side by side in one process.

Run:  python benchmarks/bench_stability_map.py [--quick]

1. Inverted single pendulum, 1000 × 1000 (A, ω) map from Mathieu characteristic
   values (kapitza) vs
   * the same idea with scipy.special.mathieu_a/b once per q,
   * a per-point fixed-step RK4 on the 2 × 2 fundamental matrix (numba, one period),
   * per-point scipy.integrate.solve_ivp (DOP853), timed on a sample, extrapolated.
   Accuracy: characteristic values vs LAPACK (eigvalsh_tridiagonal, 80 rows);
   classification vs the monodromy trace at tolerance 1e-13 on a random sample and
   on points 1e-6 (relative) from both boundaries.
2. General monodromy (Taylor method on the exact Jacobian): time and actual error
   against the requested tolerance.
3. Double pendulum with a vertically driven pivot about its upright state,
   200 × 200 map vs per-point solve_ivp on a sample, extrapolated.
Timings are the best of a few repetitions after warm-up (numba caches warm);
the machine has 2 cores and is shared, so absolute numbers move with its load.
"""
from __future__ import annotations

import argparse
import math
import time

import numba
import numpy as np
import scipy.linalg
import scipy.special
import sympy as sp
from numba import njit, prange
from scipy.integrate import solve_ivp

from kapitza import floquet as fqm
from kapitza import mathieu as mm
from kapitza.pendulum import KapitzaPendulum
from lagrange_core import problems
from lagrange_core import t as t_sym

G, L = 9.81, 1.0
W0 = math.sqrt(G / L)


def best(f, repeat=5):
    out, tb = None, np.inf
    for _ in range(repeat):
        t0 = time.perf_counter()
        out = f()
        tb = min(tb, time.perf_counter() - t0)
    return tb, out


@njit(cache=True, parallel=True)
def rk4_grid_trace(a, q, N, out):
    """Per-point baseline: N RK4 steps on y″ = −(a − 2q cos 2τ) y, τ ∈ [0, π]."""
    for i in prange(q.size):
        for j in range(a.size):
            h = math.pi / N
            x1, v1, x2, v2 = 1.0, 0.0, 0.0, 1.0
            for n in range(N):
                t0 = n * h
                f0 = -(a[j] - 2 * q[i] * math.cos(2 * t0))
                fm = -(a[j] - 2 * q[i] * math.cos(2 * t0 + h))
                f1 = -(a[j] - 2 * q[i] * math.cos(2 * t0 + 2 * h))
                for col in range(2):
                    x = x1 if col == 0 else x2
                    v = v1 if col == 0 else v2
                    k1x, k1v = v, f0 * x
                    k2x, k2v = v + 0.5 * h * k1v, fm * (x + 0.5 * h * k1x)
                    k3x, k3v = v + 0.5 * h * k2v, fm * (x + 0.5 * h * k2x)
                    k4x, k4v = v + h * k3v, f1 * (x + h * k3x)
                    x += h / 6 * (k1x + 2 * k2x + 2 * k3x + k4x)
                    v += h / 6 * (k1v + 2 * k2v + 2 * k3v + k4v)
                    if col == 0:
                        x1, v1 = x, v
                    else:
                        x2, v2 = x, v
            out[i, j] = x1 + v2


def scipy_chars_map(q, a):
    a0 = scipy.special.mathieu_a(0, q)
    b1 = scipy.special.mathieu_b(1, q)
    return (a0[:, None] < a[None, :]) & (a[None, :] < b1[:, None])


def ivp_trace(a, q):
    def rhs(tau, y):
        f = -(a - 2 * q * np.cos(2 * tau))
        return [y[1], f * y[0], y[3], f * y[2]]
    s = solve_ivp(rhs, (0, np.pi), [1, 0, 0, 1], method="DOP853", rtol=1e-11, atol=1e-13)
    return s.y[0, -1] + s.y[3, -1]


def section_single(quick):
    print("\n== 1. inverted pendulum, 1000 x 1000 (A, omega) map ==")
    n = 1000
    p = KapitzaPendulum(l=L, g=G)
    A = np.linspace(0.0, 0.7, n)
    w = np.linspace(2.0, 400.0, n) * W0
    q = 2 * A / L
    a = -4 * W0**2 / w**2
    p.stability_map(A[:10], w[:10])
    t_ours, m = best(lambda: p.stability_map(A, w), 15)
    c0 = time.process_time()
    for _ in range(10):
        p.stability_map(A, w)
    cpu = (time.process_time() - c0) / 10
    print("kapitza (characteristic values, serial):      "
          f"{t_ours * 1e3:8.2f} ms   (CPU {cpu * 1e3:.2f} ms/map)  stable fraction "
          f"{m.stable.mean():.4f}")
    t_sc, st_sc = best(lambda: scipy_chars_map(q, a), 3)
    print(f"scipy mathieu_a/b once per q + compare:      {t_sc * 1e3:8.2f} ms   "
          f"disagreeing points {int(np.sum(st_sc != m.stable))}")
    # RK4 baseline: N = 480 steps per period gives a boundary error ≈ 1e-10 (printed below)
    N = 480
    rows = 20 if quick else 100
    out = np.empty((rows, n))
    rk4_grid_trace(a[:5], q[:2], N, np.empty((2, 5)))
    t_rk, _ = best(lambda: rk4_grid_trace(a, q[:rows], N, out), 2)
    t_rk *= n / rows
    # its accuracy: |tr error| / |d tr/da| at the a0 boundary for a few q
    qs = np.array([0.05, 0.2, 0.5, 0.8])
    a0 = mm.characteristic_value("a", 0, qs)
    tr_rk = np.empty((qs.size, 3))
    da = 1e-6 * np.maximum(np.abs(a0), 1e-8)
    rk4_grid_trace(np.array([-1.0]), qs, N, np.empty((qs.size, 1)))
    for k in range(qs.size):
        o = np.empty((1, 3))
        rk4_grid_trace(np.array([a0[k] - da[k], a0[k], a0[k] + da[k]]), qs[k:k + 1], N, o)
        tr_rk[k] = o[0]
    slope = (tr_rk[:, 2] - tr_rk[:, 0]) / (2 * da)
    bnd_err_rk = np.max(np.abs((tr_rk[:, 1] - 2) / slope / a0))
    print(f"per-point RK4, N={N}, 2x2 (numba, 2 threads): {t_rk:8.2f} s    "
          f"(extrapolated from {rows} rows; boundary error {bnd_err_rk:.1e} relative)")
    k = 20 if quick else 60
    rng = np.random.default_rng(1)
    ii, jj = rng.integers(0, n, k), rng.integers(0, n, k)
    t0 = time.perf_counter()
    for i, j in zip(ii, jj):
        ivp_trace(a[j], q[i])
    t_ivp = (time.perf_counter() - t0) / k * n * n
    print(f"per-point solve_ivp (DOP853, rtol 1e-11):    {t_ivp:8.1f} s    "
          f"(extrapolated from {k} points)")
    print(f"ratios: RK4/kapitza = {t_rk / t_ours:,.0f}x, solve_ivp/kapitza = "
          f"{t_ivp / t_ours:,.0f}x, scipy-characteristic/kapitza = {t_sc / t_ours:.1f}x")
    # accuracy of the boundaries: characteristic values vs LAPACK on 80 rows
    qq = q[1::50]
    K = 80
    ref0 = np.array([scipy.linalg.eigvalsh_tridiagonal(
        (2.0 * np.arange(K)) ** 2, np.r_[math.sqrt(2) * x, np.full(K - 2, x)])[0] for x in qq])
    d1 = lambda x: np.r_[1 - x, (2 * np.arange(1, K) + 1.0) ** 2]  # noqa: E731
    ref1 = np.array([scipy.linalg.eigvalsh_tridiagonal(d1(x), np.full(K - 1, x))[0] for x in qq])
    e0 = np.max(np.abs(mm.characteristic_value("a", 0, qq) / ref0 - 1))
    e1 = np.max(np.abs(mm.characteristic_value("b", 1, qq) / ref1 - 1))
    print(f"boundary accuracy (relative, in a): a0 {e0:.1e}, b1 {e1:.1e} (vs LAPACK)")
    # classification: random sample vs monodromy trace at tolerance 1e-13
    ns = 300 if quick else 2000
    ii, jj = rng.integers(0, n, ns), rng.integers(0, n, ns)
    tr, _, _ = mm.mathieu_monodromy_trace(a[jj], q[ii], tol=1e-13)
    wrong = int(np.sum(m.stable[ii, jj] != (np.abs(tr) < 2)))
    # points 1e-6 (relative in A) inside and outside both boundaries, for 100 omegas
    ws = w[::10]
    win = p.stability_window(ws)
    bad = 0
    for e, s_in in ((win.A_min, 1 + 1e-6), (win.A_max, 1 - 1e-6)):
        for k2, om in enumerate(ws):
            pts = np.array([e[k2] * s_in, e[k2] * (2 - s_in)])
            mk = p.stability_map(pts, [om])
            bad += int(mk.stable[:, 0].tolist() != [True, False])
    print(f"classification: {wrong} wrong of {ns} random points (vs tr M at tol 1e-13); "
          f"{bad} wrong of {4 * ws.size} points 1e-6 from a boundary")
    return t_ours


def section_tolerance(quick):
    print("\n== 2. general monodromy: tolerance vs time (Taylor method, exact Jacobian) ==")
    p = KapitzaPendulum(l=L, g=G, damping=0.3)
    sysm = p.system
    n = 60 if quick else 200
    A = np.linspace(0.0, 0.6, n)
    w = np.linspace(3.0, 100.0, n) * W0
    params = dict(p.params(0.0, 1.0), A=A[:, None], omega=w[None, :])
    a, q, c = np.broadcast_arrays(*mm.mathieu_parameters(A[:, None], w[None, :], L, G,
                                                          p.damping, "inverted"))
    rng = np.random.default_rng(2)
    ii, jj = rng.integers(0, n, 200), rng.integers(0, n, 200)
    ref, _, _ = mm.mathieu_monodromy_trace(a[ii, jj], q[ii, jj], c[ii, jj], tol=1e-13)
    fqm.floquet_grid(sysm, dict(p.params(0.1, 30.0)), [math.pi], tol=1e-6)
    print(f"{'tol':>8} {'time (s)':>9} {'steps/period (max)':>19} {'max estimate':>13} "
          f"{'max actual error (trace)':>25}   [{n}x{n} damped pendulum grid]")
    rows = []
    for tol in (1e-4, 1e-6, 1e-8, 1e-10, 1e-12):
        tt, g = best(lambda: fqm.floquet_grid(sysm, params, [math.pi], tol=tol), 2)
        err = np.max(np.abs(g.trace[ii, jj] - ref) / np.maximum(1, np.abs(ref)))
        rows.append((tol, tt, int(g.steps.max()), float(g.error_estimate.max()), err))
        print(f"{tol:8.0e} {tt:9.3f} {rows[-1][2]:19d} {rows[-1][3]:13.1e} {err:25.1e}")
    return rows


def section_double(quick):
    print("\n== 3. double pendulum, vertically driven pivot, upright: 200 x 200 map ==")
    Asym, wsym = sp.symbols("A omega", positive=True)
    dp = problems.n_link_pendulum(2, pivot=(0, Asym * sp.cos(wsym * t_sym)))
    base = {"g": G, "l1": 1.0, "l2": 1.0, "m1": 1.0, "m2": 1.0}
    n = 200
    A = np.linspace(0.0, 0.3, n)
    w = np.linspace(10.0, 150.0, n)
    up = [math.pi, math.pi]
    fqm.stability_map(dp, A[:4], w[:4], base, up, tol=1e-8)
    for tol in (1e-6, 1e-8):
        tt, m = best(lambda: fqm.stability_map(dp, A, w, base, up, tol=tol), 2)
        print(f"kapitza tol {tol:.0e}: {tt:6.2f} s  stable fraction {m.stable.mean():.4f}, "
              f"refined {m.refined_points}, uncertified {m.uncertified_points}, "
              f"flagged {m.flagged_points}, max error estimate {m.error_estimate:.1e}")
    t_ours = tt
    k = dp.kernels
    ystar = np.array(up + [0.0, 0.0])
    J = np.empty((4, 4))
    rng = np.random.default_rng(3)
    npts = 5 if quick else 15
    ii, jj = rng.integers(0, n, npts), rng.integers(0, n, npts)
    t0 = time.perf_counter()
    agree = 0
    for i, j in zip(ii, jj):
        P = dp.parameter_array(dict(base, A=A[i], omega=w[j]))

        def rhs(t, x):
            k.jacobian(t, ystar, P, J)
            return J @ x
        M = np.empty((4, 4))
        for col in range(4):
            y0 = np.zeros(4)
            y0[col] = 1
            M[:, col] = solve_ivp(rhs, (0, 2 * np.pi / w[j]), y0, method="DOP853",
                                  rtol=1e-10, atol=1e-12).y[:, -1]
        agree += int(m.stable[i, j] == (np.max(np.abs(np.linalg.eigvals(M))) < 1 + 1e-6))
    t_ivp = (time.perf_counter() - t0) / npts * n * n
    print(f"per-point solve_ivp (DOP853, rtol 1e-10, 4 columns): {t_ivp:8.1f} s "
          f"(extrapolated from {npts} points; classification agrees on {agree}/{npts})")
    print(f"ratio: solve_ivp/kapitza = {t_ivp / t_ours:,.0f}x")


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="smaller samples")
    args = ap.parse_args()
    print(f"numba threads: {numba.get_num_threads()}")
    section_single(args.quick)
    section_tolerance(args.quick)
    section_double(args.quick)


if __name__ == "__main__":
    main()
