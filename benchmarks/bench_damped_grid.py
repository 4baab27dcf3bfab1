"""Damped grids on DOP853's lanes: ``measure_grid`` of the damped inverted pendulum, the lanes
(the default from FIRST_ORDER_LANES_MIN_POINTS points) against the per-point DOP853 (the
path before), in one process.

The grid of benchmarks/bench_measure.py (l = 1 m, g = 9.81 m/s², A ∈ [0.005, 0.2] m × f ∈
[5, 100] Hz, 64 × 64, 500 drive periods from θ = π − 0.1 at rest) with viscous damping
γ = 0.5 1/s: no longer q̈ = f(q, t), so ``simulate_grid`` runs DOP853, not RKN 12.  The
timed runs are interleaved in rounds and each row's best round is kept.  Rows, and the API
each measures:

* ``KapitzaPendulum(damping=0.5).measure_grid(A, ω, θ0, periods=500,
  observables="classification")`` at its default tolerance (rtol 1e-6,
  kapitza.simulation.CLASSIFICATION_RTOL_OTHER), on lanes and per point
  (``lagrange_core.batch._USE_FIRST_ORDER_LANES = False``);
* the same with every observable (Ω by the strobe fit, rtol 1e-9), on lanes and per point;
* heyoka's batch integrator on the damped pendulum (tolerance 1e-9 and 1e-6, 2 threads;
  bench_batch.py's corrected peer with the damping term);
* the classification on lanes at rtol 1e-3, 1e-4, 1e-5: how many points each
  misclassifies (is the default's margin still there on the lanes?).

"Misclassified" counts the points classified otherwise than by the per-point DOP853 at
rtol 1e-11 (computed once).

Usage::

    python benchmarks/bench_damped_grid.py            # the 64 × 64 grid, 3 rounds
    python benchmarks/bench_damped_grid.py --quick    # 16 × 16, one round (a smoke run)
"""
from __future__ import annotations

import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_batch import PERIODS, THETA0, grid, heyoka_grid  # noqa: E402
from bench_measure import _load as load  # noqa: E402
from bench_measure import best_of_rounds, grid_and_rounds  # noqa: E402

from kapitza import KapitzaPendulum  # noqa: E402
from lagrange_core import batch  # noqa: E402

GAMMA = 0.5
PEND = KapitzaPendulum(l=1.0, g=9.81, damping=GAMMA)


def measure(A, w, lanes=True, **kw):
    saved = batch._USE_FIRST_ORDER_LANES
    batch._USE_FIRST_ORDER_LANES = lanes
    try:
        m = PEND.measure_grid(A, w, THETA0, periods=PERIODS, progress=False, **kw)
    finally:
        batch._USE_FIRST_ORDER_LANES = saved
    return np.asarray(m.stayed_up)


CLASSIFY = "measure_grid classification, default rtol (1e-6), lanes"
ROWS = {
    CLASSIFY: lambda A, w: measure(A, w, observables="classification"),
    "measure_grid classification, default rtol, per point": lambda A, w: measure(
        A, w, False, observables="classification"),
    "measure_grid every observable (rtol 1e-9), lanes": lambda A, w: measure(A, w),
    "measure_grid every observable (rtol 1e-9), per point": lambda A, w: measure(A, w, False),
}
HEYOKA = "heyoka batch, tol 1e-9, 2 thr"
try:
    import heyoka  # noqa: F401
    ROWS[HEYOKA] = lambda A, w: heyoka_grid(A, w, 1e-9, gamma=GAMMA)
    ROWS["heyoka batch, tol 1e-6, 2 thr"] = lambda A, w: heyoka_grid(A, w, 1e-6, gamma=GAMMA)
except ImportError:
    print("heyoka is not installed: its rows are left out", file=sys.stderr)
LOOSER = {f"classification on lanes, rtol {r:.0e}": r for r in (1e-3, 1e-4, 1e-5)}


def main():
    A, w, rounds = grid_and_rounds(__doc__.splitlines()[0])
    N = A.size
    for run in ROWS.values():                      # compile (or load) outside the timing:
        run(*grid(16, 16))                         # 256 points, on the lanes too
    t0 = time.perf_counter()
    up_ref = measure(A, w, False, observables="classification", rtol=1e-11)
    print(f"grid {A.shape}, {PERIODS} periods, γ = {GAMMA} 1/s; reference (per-point "
          f"DOP853, rtol 1e-11) {time.perf_counter() - t0:.1f} s, stayed up "
          f"{up_ref.mean():.4f}, load {load()}")
    best, result = best_of_rounds(ROWS, A, w, rounds)
    print(f"\n  {'row (API)':55s} {'best s':>7s} {'points/s':>9s} {'misclassified':>13s}")
    for name, sec in best.items():
        mism = int(np.sum(result[name] != up_ref))
        print(f"  {name:55s} {sec:7.3f} {N / sec:9.0f} {mism:>9d}/{N}")
    per_point = best["measure_grid classification, default rtol, per point"]
    print(f"\n  classification: lanes {per_point / best[CLASSIFY]:.2f}× the per-point path", end="")
    print(f", {best[HEYOKA] / best[CLASSIFY]:.2f}× heyoka (tol 1e-9)" if HEYOKA in best else "")
    every = [v for k, v in best.items() if "every" in k]
    print(f"  every observable: lanes {every[1] / every[0]:.2f}× the per-point path")
    for name, rtol in LOOSER.items():
        t0 = time.perf_counter()
        up = measure(A, w, observables="classification", rtol=rtol)
        print(f"  {name}: {time.perf_counter() - t0:.3f} s, "
              f"{int(np.sum(up != up_ref))} of {N} misclassified")
    print(f"  load at the end {load()}")


if __name__ == "__main__":
    main()
