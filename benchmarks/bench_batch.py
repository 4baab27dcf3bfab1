"""Speed of a sweep of direct simulations: classify an (A, f) grid of the inverted pendulum.

Issue 11, point 7.  The grid: A ∈ [0.005, 0.2] m × f ∈ [5, 100] Hz (64 × 64 points,
ω = 2πf, l = 1 m, g = 9.81 m/s²); every run 500 drive periods from θ = π − 0.1 at
rest, classified "stayed up" if |θ − π| < π/2 throughout.  Every peer runs in this one
process, on the same grid, one after the other (the machine is shared and noisy: the
ratios are what to read):

* ours: ``System.simulate_grid`` (lagrange_core.batch) with the band |θ − π| < π/2 (a
  run stops when it leaves), for several methods and tolerances;
* heyoka: its batch Taylor integrator (SIMD lanes, ``recommended_simd_size``) in an
  ensemble over 2 threads, tolerance 1e-9, in the time τ = ωt (so every lane ends at
  τ = 1000π), with terminal events at θ = π/2 and 3π/2 (so it also stops at a fall);
* a straightforward numba RK4 at 50 steps per period (``prange``, stops at a fall);
* scipy's DOP853 (rtol 1e-9) on 24 points, extrapolated.

The reference classification is ours at rtol 1e-12 (adaptive RKN 12(10)), cross-checked
against heyoka's.  A peer's "mismatch" is a point it classifies otherwise.

Usage::

    python benchmarks/bench_batch.py              # the 64 × 64 grid
    python benchmarks/bench_batch.py --million    # also 10⁶ points (1000 × 1000)
"""
from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from lagrange_core import problems  # noqa: E402

L, G, PERIODS, THETA0 = 1.0, 9.81, 500, math.pi - 0.1


def grid(nA=64, nf=64):
    A = np.linspace(0.005, 0.2, nA)[:, None]
    f = np.linspace(5.0, 100.0, nf)[None, :]
    return np.broadcast_arrays(A, 2 * np.pi * f)


def ours(A, w, **kw):
    pend = problems.driven_pendulum("vertical")
    T = 2 * np.pi / w
    g = pend.simulate_grid([THETA0], [0.0], (0.0, PERIODS * T),
                           dict(m=1.0, l=L, g=G, A=A, omega=w),
                           band=([math.pi / 2], [3 * math.pi / 2]), progress=False, **kw)
    return g.status == 0, g


def heyoka_grid(A, w, tol=1e-9, threads=2):
    import heyoka as hy
    th, v = hy.make_vars("th", "v")
    # τ = ωt: θ'' = −(g/(l ω²) − (A/l) cos τ) sin θ
    rhs = -(hy.par[0] - hy.par[1] * hy.cos(hy.time)) * hy.sin(th)
    B = hy.recommended_simd_size()
    evs = [hy.t_event_batch(th - math.pi / 2), hy.t_event_batch(th - 3 * math.pi / 2)]
    ta = hy.taylor_adaptive_batch([(th, v), (v, rhs)], np.zeros((2, B)), tol=tol,
                                  pars=np.zeros((2, B)), t_events=evs)
    a = A.ravel()
    om = w.ravel()
    N = a.size
    n_iter = -(-N // B)
    pad = n_iter * B - N
    a = np.r_[a, np.full(pad, a[-1])]
    om = np.r_[om, np.full(pad, om[-1])]

    def gen(t, i):
        s = slice(i * B, (i + 1) * B)
        t.set_time(0.0)
        t.state[0, :] = THETA0
        t.state[1, :] = 0.0
        t.pars[0, :] = G / (L * om[s] ** 2)
        t.pars[1, :] = a[s] / L
        return t

    res = hy.ensemble_propagate_until_batch(ta, 2 * math.pi * PERIODS, n_iter, gen,
                                            algorithm="thread", max_workers=threads)
    up = np.empty(n_iter * B, dtype=bool)
    for i, r in enumerate(res):
        t_i = r[0]
        up[i * B:(i + 1) * B] = np.asarray(t_i.time) >= 2 * math.pi * PERIODS * (1 - 1e-12)
    return up[:N].reshape(A.shape)


def rk4_grid(A, w, steps_per_period=50):
    from numba import njit, prange

    @njit(parallel=True, cache=True)
    def run(Af, wf, out):
        for i in prange(Af.shape[0]):
            a, om = Af[i], wf[i]
            h = 2 * np.pi / om / steps_per_period
            th, v, t = THETA0, 0.0, 0.0
            ok = True
            for k in range(PERIODS * steps_per_period):
                def acc(x, tt):
                    return -(G - a * om * om * np.cos(om * tt)) * np.sin(x) / L
                k1x, k1v = v, acc(th, t)
                k2x, k2v = v + 0.5 * h * k1v, acc(th + 0.5 * h * k1x, t + 0.5 * h)
                k3x, k3v = v + 0.5 * h * k2v, acc(th + 0.5 * h * k2x, t + 0.5 * h)
                k4x, k4v = v + h * k3v, acc(th + h * k3x, t + h)
                th += h * (k1x + 2 * k2x + 2 * k3x + k4x) / 6
                v += h * (k1v + 2 * k2v + 2 * k3v + k4v) / 6
                t = (k + 1) * h
                if abs(th - np.pi) >= np.pi / 2:
                    ok = False
                    break
            out[i] = ok
    Af, wf = A.ravel().copy(), w.ravel().copy()
    out = np.zeros(Af.size, dtype=np.bool_)
    run(Af[:4], wf[:4], out[:4])        # compile outside the timing
    t0 = time.perf_counter()
    run(Af, wf, out)
    return time.perf_counter() - t0, out.reshape(A.shape)


def scipy_sample(A, w, k=24):
    from scipy.integrate import solve_ivp
    rng = np.random.default_rng(1)
    idx = rng.choice(A.size, k, replace=False)
    out = {}
    t0 = time.perf_counter()
    for i in idx:
        a, om = A.ravel()[i], w.ravel()[i]

        def f(t, y):
            return [y[1], -(G - a * om * om * np.cos(om * t)) * np.sin(y[0]) / L]

        def fall(t, y):
            return abs(y[0] - np.pi) - np.pi / 2
        fall.terminal = True
        s = solve_ivp(f, (0, PERIODS * 2 * np.pi / om), [THETA0, 0.0], method="DOP853",
                      rtol=1e-9, atol=1e-9, events=fall)
        out[int(i)] = s.status == 0
    return (time.perf_counter() - t0) / k, out


def timed(fn, *a, repeat=2, **kw):
    best, out = float("inf"), None
    for _ in range(repeat):
        t0 = time.perf_counter()
        out = fn(*a, **kw)
        best = min(best, time.perf_counter() - t0)
    return best, out


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--million", action="store_true", help="also classify 10⁶ points")
    ap.add_argument("--repeat", type=int, default=2)
    args = ap.parse_args()
    A, w = grid()
    N = A.size
    ours(A[:2, :2], w[:2, :2])                  # compile (or load) outside the timing
    ours(A[:2, :2], w[:2, :2], method="rkn12-fixed", rtol=1e-3)
    t_ref, (up_ref, g_ref) = timed(ours, A, w, rtol=1e-12, repeat=1)
    print(f"grid {A.shape}, {PERIODS} periods; reference (ours, rkn12 rtol 1e-12) {t_ref:.2f} s, "
          f"stayed up: {up_ref.mean():.4f}")
    rows = []

    def row(name, sec, up, extra=""):
        mism = int(np.sum(up != up_ref)) if up is not None else -1
        rows.append((name, sec, N / sec, mism, extra))
        print(f"  {name:40s} {sec:8.3f} s {N / sec:10.0f} points/s  mismatches {mism}  {extra}")

    try:
        import heyoka  # noqa: F401
        have_heyoka = True
    except ImportError:
        have_heyoka = False
    if have_heyoka:
        heyoka_grid(A[:1, :8], w[:1, :8])       # JIT outside the timing
        sec, up = timed(heyoka_grid, A, w, repeat=args.repeat)
        row("heyoka batch ensemble, tol 1e-9, 2 thr", sec, up)
        hey = sec
    else:
        print("  heyoka not installed: skipped (pip install 'kapitza[bench]')")
        hey = float("nan")
    for name, kw in [("ours rkn12-fixed rtol 1e-3", dict(method="rkn12-fixed", rtol=1e-3)),
                     ("ours rkn12-fixed rtol 1e-6", dict(method="rkn12-fixed", rtol=1e-6)),
                     ("ours rkn12 (adaptive) rtol 1e-3", dict(rtol=1e-3)),
                     ("ours rkn12 (adaptive) rtol 1e-6", dict(rtol=1e-6)),
                     ("ours default (rtol 1e-9)", dict())]:
        sec, (up, g) = timed(ours, A, w, repeat=args.repeat, **kw)
        row(name, sec, up, f"steps/point {g.n_steps.mean():.0f}; heyoka/ours "
            f"{hey / sec:.2f}")
    sec, up = rk4_grid(A, w)
    row("numba RK4, 50 steps/period", sec, up)
    per, sample = scipy_sample(A, w)
    mism = sum(int(sample[i] != up_ref.ravel()[i]) for i in sample)
    rows.append(("scipy DOP853 rtol 1e-9 (24 points)", per * N, 1 / per, mism, ""))
    print(f"  {'scipy DOP853 rtol 1e-9 (24 points)':40s} {per * N:8.1f} s {1 / per:10.1f} points/s"
          f"  mismatches {mism}/24 (extrapolated)")
    if args.million:
        A6, w6 = grid(1000, 1000)
        sec, (up6, g6) = timed(ours, A6, w6, repeat=1, method="rkn12-fixed", rtol=1e-3)
        print(f"  10⁶ points, ours rkn12-fixed rtol 1e-3: {sec:.1f} s "
              f"({1e6 / sec:.0f} points/s), stayed up {up6.mean():.4f}")


if __name__ == "__main__":
    main()
