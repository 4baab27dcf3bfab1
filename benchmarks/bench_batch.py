"""Speed of a sweep of direct simulations: classify an (A, f) grid of the inverted pendulum.

Issue 11, point 7.  The grid: A ∈ [0.005, 0.2] m × f ∈ [5, 100] Hz (64 × 64 points,
ω = 2πf, l = 1 m, g = 9.81 m/s²); every run 500 drive periods from θ = π − 0.1 at
rest, classified "stayed up" if |θ − π| < π/2 throughout.  Every peer runs in this one
process, on the same grid; the timed runs are interleaved in rounds (every peer once per
round) and each peer's best round is reported, because the machine is shared and
noisy: the ratios are what to read.

* ours: ``System.simulate_grid`` (lagrange_core.batch) with the band |θ − π| < π/2 (a
  run stops when it leaves), the default method ("rkn12", adaptive with a held step,
  on lanes) at several tolerances and "rkn12-fixed" (its step from a pilot);
  the headline row is the default at rtol 1e-3, the loosest tolerance tried that
  classifies every point as the reference does;
* heyoka: its batch Taylor integrator (SIMD lanes, ``recommended_simd_size``), tolerance
  1e-9, 2 threads, in the time τ = ωt (every lane ends at τ = 1000π), with terminal
  events at θ = π/2 and 3π/2.  In batch mode a terminal event in one lane stops
  *every* lane of the batch (heyoka.py 7.13: ``propagate_until`` returns with the
  others at the event's time), so the issue's version (``ensemble_propagate_until_batch``,
  one call per batch) ran the batch-mates of a fallen point only until its fall and
  counted them as fallen (202 points of this grid).  The corrected peer propagates each
  batch again until every lane has reached the end or fallen, parking a fallen lane at
  rest hanging down (θ = 0: no further events), on a pool of 2 threads.  Both are
  timed; the corrected one at tolerance 1e-9 is the peer the ratios use, and it also
  runs at 1e-6 and 1e-3 (a loose tolerance may classify as well for heyoka too);
* a straightforward numba RK4 at 50 steps per period (``prange``, stops at a fall);
* scipy's DOP853 (rtol 1e-9) on 24 points, extrapolated.

The reference classification is the per-point integrator of ``simulate_grid`` (the code
path without lanes) at rtol 1e-12, adaptive RKN 12(10), cross-checked against the
corrected heyoka.  A peer's "mismatch" is a point it classifies otherwise.

Usage::

    python benchmarks/bench_batch.py              # the 64 × 64 grid
    python benchmarks/bench_batch.py --million    # also 10⁶ points (1000 × 1000)
    python benchmarks/bench_batch.py --quick      # 16 × 16, one round (a smoke run)
"""
from __future__ import annotations

import argparse
import math
import sys
import threading
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from lagrange_core import batch, problems  # noqa: E402

L, G, PERIODS, THETA0 = 1.0, 9.81, 500, math.pi - 0.1


def grid(nA=64, nf=64):
    A = np.linspace(0.005, 0.2, nA)[:, None]
    f = np.linspace(5.0, 100.0, nf)[None, :]
    return np.broadcast_arrays(A, 2 * np.pi * f)


_PEND = []


def ours(A, w, **kw):
    if not _PEND:                       # the system is stated once, as a user would
        _PEND.append(problems.driven_pendulum("vertical"))
    pend = _PEND[0]
    T = 2 * np.pi / w
    g = pend.simulate_grid([THETA0], [0.0], (0.0, PERIODS * T),
                           dict(m=1.0, l=L, g=G, A=A, omega=w),
                           band=([math.pi / 2], [3 * math.pi / 2]), progress=False, **kw)
    return g.status == 0, g


def reference(A, w, rtol=1e-12):
    """The per-point integrator (no lanes): code independent of the fast path."""
    saved = batch._USE_LANES
    batch._USE_LANES = False
    try:
        return ours(A, w, method="rkn12", rtol=rtol)
    finally:
        batch._USE_LANES = saved


_HEYOKA = {}


def _heyoka_integrator(tol, damped=False):
    """The batch integrator, built (JIT-compiled) once per tolerance outside the timing;
    each run works on a copy."""
    if (tol, damped) not in _HEYOKA:
        _HEYOKA[tol, damped] = _build_heyoka(tol, damped)
    return _HEYOKA[tol, damped]


def _build_heyoka(tol, damped=False):
    import heyoka as hy
    th, v = hy.make_vars("th", "v")
    # τ = ωt: θ'' = −(g/(l ω²) − (A/l) cos τ) sin θ [− (γ/ω) θ']
    rhs = -(hy.par[0] - hy.par[1] * hy.cos(hy.time)) * hy.sin(th)
    if damped:
        rhs = rhs - hy.par[2] * v
    B = hy.recommended_simd_size()
    evs = [hy.t_event_batch(th - math.pi / 2), hy.t_event_batch(th - 3 * math.pi / 2)]
    ta = hy.taylor_adaptive_batch([(th, v), (v, rhs)], np.zeros((2, B)), tol=tol,
                                  pars=np.zeros((3 if damped else 2, B)), t_events=evs)
    return ta, B


def _padded(A, w, B):
    a, om = A.ravel(), w.ravel()
    N = a.size
    n_iter = -(-N // B)
    pad = n_iter * B - N
    return np.r_[a, np.full(pad, a[-1])], np.r_[om, np.full(pad, om[-1])], N, n_iter


def _start_batch(ta, s, a, om, gamma=0.0):
    """Batch ``s`` of the padded grid into the integrator: t = 0, θ = π − 0.1 at rest (the
    damping rate γ (1/s) when the integrator has it)."""
    ta.set_time(0.0)
    ta.state[0, :] = THETA0
    ta.state[1, :] = 0.0
    ta.pars[0, :] = G / (L * om[s] ** 2)
    ta.pars[1, :] = a[s] / L
    if ta.pars.shape[0] > 2:
        ta.pars[2, :] = gamma / om[s]


def heyoka_as_issue(A, w, tol=1e-9, threads=2):
    """The issue's peer: one ``propagate_until`` per batch (misclassifies the batch-mates of
    a fallen point: see the module docstring)."""
    import copy

    import heyoka as hy
    ta, B = _heyoka_integrator(tol)
    ta = copy.deepcopy(ta)
    a, om, N, n_iter = _padded(A, w, B)

    def gen(t, i):
        _start_batch(t, slice(i * B, (i + 1) * B), a, om)
        return t

    res = hy.ensemble_propagate_until_batch(ta, 2 * math.pi * PERIODS, n_iter, gen,
                                            algorithm="thread", max_workers=threads)
    up = np.empty(n_iter * B, dtype=bool)
    for i, r in enumerate(res):
        up[i * B:(i + 1) * B] = np.asarray(r[0].time) >= 2 * math.pi * PERIODS * (1 - 1e-12)
    return up[:N].reshape(A.shape)


def heyoka_grid(A, w, tol=1e-9, threads=2, gamma=0.0):
    """heyoka, corrected: each batch propagated until every lane has reached the end or
    fallen (a fallen lane parked at θ = 0, at rest); batches shared by ``threads``
    threads (heyoka releases the GIL while it integrates).  ``gamma`` > 0: the damped
    pendulum (viscous damping rate γ, 1/s)."""
    import copy

    import heyoka as hy
    ta0, B = _heyoka_integrator(tol, gamma > 0)
    a, om, N, n_iter = _padded(A, w, B)
    end = 2 * math.pi * PERIODS
    up = np.ones(n_iter * B, dtype=bool)
    done = (hy.taylor_outcome.time_limit, hy.taylor_outcome.success)
    lock = threading.Lock()
    counter = iter(range(n_iter))

    def work():
        ta = copy.deepcopy(ta0)
        while True:
            with lock:
                i = next(counter, None)
            if i is None:
                return
            s = slice(i * B, (i + 1) * B)
            _start_batch(ta, s, a, om, gamma)
            fallen = np.zeros(B, dtype=bool)
            while True:
                ta.propagate_until(end)
                for b, res in enumerate(ta.propagate_res):
                    if res[0] not in done:          # a terminal event: this lane fell
                        fallen[b] = True
                        ta.state[:, b] = 0.0
                if np.all(np.asarray(ta.time) >= end):
                    break
            up[s] = ~fallen

    pool = [threading.Thread(target=work) for _ in range(threads)]
    for th in pool:
        th.start()
    for th in pool:
        th.join()
    return up[:N].reshape(A.shape)


_RK4 = {}


def rk4_grid(A, w, steps_per_period=50):
    """A straightforward numba RK4 at a fixed number of steps per drive period."""
    if steps_per_period not in _RK4:
        from numba import njit, prange

        @njit(parallel=True)
        def run(Af, wf, out):
            def acc(x, tt, a, om):
                return -(G - a * om * om * np.cos(om * tt)) * np.sin(x) / L
            for i in prange(Af.shape[0]):
                a, om = Af[i], wf[i]
                h = 2 * np.pi / om / steps_per_period
                th, v, t = THETA0, 0.0, 0.0
                ok = True
                for k in range(PERIODS * steps_per_period):
                    k1x, k1v = v, acc(th, t, a, om)
                    k2x, k2v = v + 0.5 * h * k1v, acc(th + 0.5 * h * k1x, t + 0.5 * h, a, om)
                    k3x, k3v = v + 0.5 * h * k2v, acc(th + 0.5 * h * k2x, t + 0.5 * h, a, om)
                    k4x, k4v = v + h * k3v, acc(th + h * k3x, t + h, a, om)
                    th += h * (k1x + 2 * k2x + 2 * k3x + k4x) / 6
                    v += h * (k1v + 2 * k2v + 2 * k3v + k4v) / 6
                    t = (k + 1) * h
                    if abs(th - np.pi) >= np.pi / 2:
                        ok = False
                        break
                out[i] = ok
        _RK4[steps_per_period] = run
    Af, wf = A.ravel().copy(), w.ravel().copy()
    out = np.zeros(Af.size, dtype=np.bool_)
    _RK4[steps_per_period](Af, wf, out)
    return out.reshape(A.shape)


def scipy_sample(A, w, k=24):
    from scipy.integrate import solve_ivp
    rng = np.random.default_rng(1)
    idx = rng.choice(A.size, k, replace=False)
    out = {}
    t0 = time.perf_counter()
    for i in idx:
        a, om = A.ravel()[i], w.ravel()[i]

        def f(t, y, a=a, om=om):
            return [y[1], -(G - a * om * om * np.cos(om * t)) * np.sin(y[0]) / L]

        def fall(t, y):
            return abs(y[0] - np.pi) - np.pi / 2
        fall.terminal = True
        s = solve_ivp(f, (0, PERIODS * 2 * np.pi / om), [THETA0, 0.0], method="DOP853",
                      rtol=1e-9, atol=1e-9, events=fall)
        out[int(i)] = s.status == 0
    return (time.perf_counter() - t0) / k, out


#: our rows: (label, simulate_grid keywords)
OURS = [("ours default (rkn12) rtol 1e-3", dict(rtol=1e-3)),
        ("ours default (rkn12) rtol 1e-6", dict(rtol=1e-6)),
        ("ours default (rkn12) rtol 1e-9", dict()),
        ("ours rkn12-fixed rtol 1e-3", dict(method="rkn12-fixed", rtol=1e-3)),
        ("ours rkn12-fixed rtol 1e-9", dict(method="rkn12-fixed", rtol=1e-9))]
HEADLINE = "ours default (rkn12) rtol 1e-3"
#: heyoka at looser tolerances too: is a loose tolerance enough for it as well?
HEYOKA_LOOSE = (1e-6, 1e-3)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--million", action="store_true", help="also classify 10⁶ points")
    ap.add_argument("--rounds", type=int, default=3, help="timed rounds (best kept)")
    ap.add_argument("--quick", action="store_true", help="16 × 16 grid, one round")
    args = ap.parse_args()
    A, w = grid(16, 16) if args.quick else grid()
    rounds = 1 if args.quick else args.rounds
    N = A.size
    try:
        import heyoka  # noqa: F401
        have_heyoka = True
    except ImportError:
        have_heyoka = False
        print("heyoka not installed: skipped (pip install 'kapitza[bench]')")

    # compile (or load) everything outside the timing
    for _, kw in OURS:
        ours(A[:2, :2], w[:2, :2], **kw)
    reference(A[:2, :2], w[:2, :2])
    if have_heyoka:
        heyoka_grid(A[:1, :8], w[:1, :8])
        heyoka_as_issue(A[:1, :8], w[:1, :8])
        for tol in HEYOKA_LOOSE:
            heyoka_grid(A[:1, :8], w[:1, :8], tol=tol)
    rk4_grid(A[:1, :4], w[:1, :4])

    t0 = time.perf_counter()
    up_ref, g_ref = reference(A, w)
    t_ref = time.perf_counter() - t0
    print(f"grid {A.shape}, {PERIODS} periods, machine load {_load()}; reference (per-point "
          f"rkn12, rtol 1e-12) {t_ref:.2f} s, stayed up: {up_ref.mean():.4f}")

    peers = {name: (lambda kw=kw: ours(A, w, **kw)) for name, kw in OURS}
    if have_heyoka:
        peers["heyoka batch, tol 1e-9, 2 thr (corrected)"] = lambda: heyoka_grid(A, w)
        peers["heyoka ensemble as in the issue"] = lambda: heyoka_as_issue(A, w)
        for tol in HEYOKA_LOOSE:
            peers[f"heyoka batch, tol {tol:.0e}, 2 thr (corrected)"] = \
                lambda tol=tol: heyoka_grid(A, w, tol=tol)
    peers["numba RK4, 50 steps/period"] = lambda: rk4_grid(A, w)
    best, result = {}, {}
    for r in range(rounds):
        for name, run in peers.items():
            t0 = time.perf_counter()
            out = run()
            sec = time.perf_counter() - t0
            if sec < best.get(name, float("inf")):
                best[name], result[name] = sec, out
        print(f"  round {r + 1}/{rounds} done, load {_load()}")

    hey = best.get("heyoka batch, tol 1e-9, 2 thr (corrected)", float("nan"))
    print(f"\n  {'peer':44s} {'best s':>8s} {'points/s':>10s} {'÷ heyoka':>9s} "
          f"{'mismatches':>10s}  notes")
    for name, sec in best.items():
        out = result[name]
        up, g = out if isinstance(out, tuple) else (out, None)
        mism = int(np.sum(up != up_ref))
        note = f"steps/point {g.n_steps.mean():.0f}" if g is not None else ""
        print(f"  {name:44s} {sec:8.3f} {N / sec:10.0f} {hey / sec:9.2f} {mism:10d}  {note}")
    if have_heyoka:
        up_h = result["heyoka batch, tol 1e-9, 2 thr (corrected)"]
        print(f"  reference vs corrected heyoka: {int(np.sum(up_h != up_ref))} points differ")
    per, sample = scipy_sample(A, w, k=6 if args.quick else 24)
    mism = sum(int(sample[i] != up_ref.ravel()[i]) for i in sample)
    print(f"  {'scipy DOP853 rtol 1e-9 (sample)':44s} {per * N:8.1f} {1 / per:10.1f} "
          f"{hey / (per * N):9.4f} {mism:>7d}/{len(sample)}  (extrapolated)")
    print(f"  headline: {HEADLINE}: {hey / best[HEADLINE]:.2f} × heyoka's throughput")

    if args.million:
        A6, w6 = grid(1000, 1000)
        for name, kw in OURS[:1]:
            t0 = time.perf_counter()
            up6, g6 = ours(A6, w6, **kw)
            sec = time.perf_counter() - t0
            print(f"  10⁶ points, {name}: {sec:.1f} s ({1e6 / sec:.0f} points/s), stayed up "
                  f"{up6.mean():.4f}, load {_load()}")
        # a random sample of the million against the reference
        rng = np.random.default_rng(7)
        pick = rng.choice(10**6, 2000, replace=False)
        Ap, wp = A6.ravel()[pick], w6.ravel()[pick]
        up_p, _ = reference(Ap, wp)
        print(f"  2000 random points of the million against the reference: "
              f"{int(np.sum(up_p != up6.ravel()[pick]))} mismatches")


def _load():
    try:
        return open("/proc/loadavg").read().split()[0]
    except OSError:
        return "?"


if __name__ == "__main__":
    main()
