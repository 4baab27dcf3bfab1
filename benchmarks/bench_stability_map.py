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
4. Exact windows and boundaries (issue 12), Acheson's chains, upright:
   * cost of one Floquet point, double vs triple pendulum, with small grids on the
     calling thread (today) and through numba's thread pool (before), interleaved;
   * the triple pendulum's window at ω = 100 rad/s: kapitza.floquet.window vs bisection
     on floquet_point(...).stable; errors against the modal decoupling (Mathieu
     characteristic values of each mode, no monodromy);
   * the double pendulum's boundaries at 200 frequencies vs the uniform 200 × 200 map,
     both timed here; errors against the modal decoupling;
   * adaptive maps vs uniform maps of the same grid: monodromies, time, disagreements.
5. The damped pendulum's exact window (``--only-damped-window``): the Mathieu monodromy
   trace per call at tolerance 1e-12 (and its error against a 20-digit mpmath reference),
   and ``exact_window`` with γ = 0.5 s⁻¹ over the 24 frequencies of a report map from 1.5
   to 20 rad/s (windows up to 8 m).  Run it with ``PYTHONPATH=<an older tree>`` too: the
   section uses only functions both trees have.
Timings are the best of a few repetitions after warm-up (numba caches warm);
the machine has 2 cores and is shared, so absolute numbers move with its load.
"""
from __future__ import annotations

import argparse
import math
import os
import sys
import time

import numba
import numpy as np
import scipy.linalg
import scipy.special
import sympy as sp
from numba import njit, prange
from scipy.integrate import solve_ivp

from kapitza import floquet as fqm
from kapitza.closed_forms import _mathieu as mm
from kapitza.closed_forms import multiple_pendulum_upright, pendulum_window
from kapitza.figures import _plots as plots
from kapitza.floquet import _kernels
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
    for i, j in zip(ii, jj, strict=True):
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
    win = p.window(ws)
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
        tt, g = best(lambda tol=tol: fqm.floquet_grid(sysm, params, [math.pi], tol=tol), 2)
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
    fqm.stability_map(dp, base, up, A=A[:4], omega=w[:4], tol=1e-8)
    for tol in (1e-6, 1e-8):
        tt, m = best(lambda tol=tol: fqm.stability_map(dp, base, up, A=A, omega=w, tol=tol),
                     2)
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
    for i, j in zip(ii, jj, strict=True):
        P = dp.parameter_array(dict(base, A=A[i], omega=w[j]))

        def rhs(t, x, P=P):
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


def chain(n):
    Asym, wsym = sp.symbols("A omega", positive=True)
    params = {"g": G}
    for k in range(1, n + 1):
        params[f"l{k}"], params[f"m{k}"] = 1.0, 1.0
    return problems.n_link_pendulum(n, pivot=(0, Asym * sp.cos(wsym * t_sym))), params


def modal_window(omega, n):
    """The equal n-link chain's exact window: the intersection of its modes' Mathieu
    windows (Acheson's decoupling; characteristic values, no monodromy)."""
    lam = multiple_pendulum_upright([1.0] * n, [1.0] * n, g=G).effective_lengths
    modes = [pendulum_window(omega, l=lk, g=G, tol=1e-14) for lk in lam]
    return (np.max([m.A_min for m in modes], axis=0), np.min([m.A_max for m in modes], axis=0))


def bisect_window(system, params, up, omega, brackets, rtol=1e-10):
    """Today's user recipe: bisection on floquet_point(...).stable for each edge."""
    calls, edges = 0, []
    for lo, hi, stable_low in brackets:
        while hi - lo > rtol * hi:
            mid = 0.5 * (lo + hi)
            calls += 1
            st = fqm.floquet_point(system, dict(params, A=mid, omega=omega), up).stable
            lo, hi = (mid, hi) if st == stable_low else (lo, mid)
        edges.append(0.5 * (lo + hi))
    return edges, calls


def section_boundaries(quick, figure=None):
    print("\n== 4. exact windows and boundaries (issue 12): upright chains ==")
    dp, dpar = chain(2)
    tp, tpar = chain(3)
    up2, up3 = [math.pi] * 2, [math.pi] * 3
    # 4a. one Floquet point: thread pool (before) vs calling thread (today), interleaved
    cases = ((dp, dpar, up2), (tp, tpar, up3))
    for s_, p_, u_ in cases:
        fqm.floquet_point(s_, dict(p_, A=0.07, omega=100.0), u_)
    serial = _kernels.SERIAL_BELOW
    reps = 10 if quick else 30
    cost = {}
    for _ in range(3):
        for mode, below in (("pool", 0), ("thread", serial)):
            _kernels.SERIAL_BELOW = below
            for s_, p_, u_ in cases:
                t, _ = best(lambda s_=s_, p_=p_, u_=u_:
                            fqm.floquet_point(s_, dict(p_, A=0.07, omega=100.0), u_), reps)
                key = (mode, s_.n_dof)
                cost[key] = min(cost.get(key, np.inf), t)
    _kernels.SERIAL_BELOW = serial
    for mode in ("pool", "thread"):
        print(f"one Floquet point, {mode:6s}: 4-dim {cost[(mode, 2)] * 1e3:6.2f} ms, 6-dim "
              f"{cost[(mode, 3)] * 1e3:6.2f} ms, ratio {cost[(mode, 3)] / cost[(mode, 2)]:.2f}")
    # 4b. the triple pendulum's window at one ω
    w0 = 100.0
    lo, hi = modal_window(w0, 3)
    fqm.window(tp, tpar, up3, omega=w0)
    t_win, win = best(lambda: fqm.window(tp, tpar, up3, omega=w0), 5)
    e_win = max(abs(win.A_min / lo - 1), abs(win.A_max / hi - 1))
    print(f"triple pendulum window, omega = {w0:g}: kapitza.floquet.window {t_win * 1e3:.0f} ms, "
          f"error {e_win:.1e} (certified {win.accuracy:.1e}); A = [{win.A_min:.12f}, "
          f"{win.A_max:.12f}] m")
    t0 = time.perf_counter()
    (b_lo, b_hi), calls = bisect_window(tp, tpar, up3, w0, [(0.05, 0.0705, False),
                                                             (0.0705, 0.1, True)])
    t_bis = time.perf_counter() - t0
    e_bis = max(abs(b_lo / lo - 1), abs(b_hi / hi - 1))
    print(f"bisection on floquet_point(...).stable to 1e-10: {t_bis * 1e3:.0f} ms, {calls} "
          f"calls, error {e_bis:.1e}; ratio {t_bis / t_win:.1f}x")
    # 4c. the double pendulum's boundaries at 200 ω vs the uniform 200 x 200 map
    n = 200
    A = np.linspace(0.0, 0.3, n)
    w = np.linspace(10.0, 150.0, n)
    fqm.boundaries(dp, dpar, up2, omega=w[:20], A_range=(0.0, 0.3), tol=1e-9)
    rows = {}
    for _ in range(2 if quick else 3):
        for name, f in (("map 1e-6", lambda: fqm.stability_map(dp, dpar, up2, A=A, omega=w,
                                                                tol=1e-6, progress=False)),
                        ("boundaries", lambda: fqm.boundaries(dp, dpar, up2, omega=w,
                                                              A_range=(0.0, 0.3), tol=1e-9))):
            t, out = best(f, 1)
            if t < rows.get(name, (np.inf,))[0]:
                rows[name] = (t, out)
    t_map, m = rows["map 1e-6"]
    t_b, curves = rows["boundaries"]
    ref_lo, ref_hi = modal_window(w, 2)
    err = max(np.nanmax(np.abs(curves.A[0] / ref_lo - 1)),
              np.nanmax(np.abs(curves.A[1] / ref_hi - 1)))
    print(f"double pendulum, 200 frequencies: boundaries {t_b:.2f} s ({curves.monodromies} "
          f"monodromies, kinds {curves.kind}), uniform 200 x 200 map at tol 1e-6 {t_map:.2f} s "
          f"(40000); ratio map/boundaries {t_map / t_b:.1f}x")
    print(f"  boundary error vs modal decoupling {err:.1e} (certified "
          f"{np.nanmax(curves.accuracy):.1e}); the map resolves A to {A[1] - A[0]:.1e} m")
    # 4d. adaptive vs uniform maps
    for N in ((129, 257) if quick else (257, 513)):
        A = np.linspace(0.0, 0.3, N)
        w = np.linspace(10.0, 150.0, N)
        t_u, uni = best(lambda A=A, w=w: fqm.stability_map(dp, dpar, up2, A=A, omega=w,
                                                           progress=False), 1)
        t_a, ada = best(lambda A=A, w=w: fqm.adaptive_map(dp, dpar, up2, A=A, omega=w,
                                                          coarse_step=16), 2)
        print(f"adaptive map {N} x {N}: {ada.monodromies} monodromies vs {N * N} "
              f"({N * N / ada.monodromies:.0f}x fewer), {t_a:.2f} s vs {t_u:.2f} s "
              f"({t_u / t_a:.1f}x), {int(np.sum(ada.label != uni.label))} labels differ")
    if figure:
        fig = plots.stability_map_figure(ada, overlays=[curves])
        fig.savefig(figure, dpi=120)
        print(f"figure: {figure}")


def section_damped_window(quick):
    # the tests' 20-digit reference (tests/helpers.py: numpy, scipy and mpmath only)
    sys.path.insert(0, os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))),
                                    "tests"))
    from helpers import mathieu_mpmath_trace
    print(f"\n== 5. the damped pendulum's exact window ({mm.__file__}) ==")
    print(f"{'a':>9} {'q':>8} {'ms per trace':>13} {'reported error':>15} "
          f"{'error vs mpmath':>16}   [mathieu_monodromy_trace, tol 1e-12]")
    for a, q in ((1.3, 0.7), (-4.0, 1.0), (-17.4, 16.0), (-40.0, 100.0), (-400.0, 1000.0)):
        t, (tr, _, err) = best(lambda a=a, q=q: mm.mathieu_monodromy_trace(a, q, tol=1e-12), 3)
        actual = (abs(float(tr) - mathieu_mpmath_trace(a, q)) / max(1.0, abs(float(tr)))
                  if abs(q) <= 100 else float("nan"))     # (mpmath's Taylor: minutes beyond)
        print(f"{a:9.1f} {q:8.1f} {t * 1e3:13.3f} {float(err):15.1e} {actual:16.1e}")
    w = np.geomspace(1.5, 20.0, 24)
    t, win = best(lambda: mm.exact_window(w, l=L, g=G, damping=0.5), 1 if quick else 2)
    print(f"exact_window, γ = 0.5 s⁻¹, 24 ω in [1.5, 20] rad/s: {t:.2f} s "
          f"(largest certified accuracy {np.nanmax(win.accuracy):.1e}; "
          f"A_max at ω = 1.5: {float(win.A_max[0]):.6f} m)")


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="smaller samples")
    ap.add_argument("--only-boundaries", action="store_true", help="section 4 only")
    ap.add_argument("--figure", help="save the adaptive map with the exact boundaries (PNG)")
    ap.add_argument("--only-damped-window", action="store_true", help="section 5 only")
    args = ap.parse_args()
    print(f"numba threads: {numba.get_num_threads()}")
    if args.only_damped_window:
        section_damped_window(args.quick)
        return
    if not args.only_boundaries:
        section_single(args.quick)
        section_tolerance(args.quick)
        section_double(args.quick)
    section_boundaries(args.quick, args.figure)


if __name__ == "__main__":
    main()
