"""The kapitza layer at the engine's speed (issue 24, point 1): ``measure_grid`` against
``simulate_grid`` under it and against heyoka, on the grid of benchmarks/bench_batch.py.

The grid: the inverted pendulum (l = 1 m, g = 9.81 m/s²), A ∈ [0.005, 0.2] m × f ∈ [5, 100]
Hz (64 × 64, ω = 2πf), 500 drive periods from θ = π − 0.1 at rest; "stayed up": |θ − π| <
π/2 throughout.  Every row runs in this one process; the timed runs are interleaved in
rounds (every row once per round, the load printed) and each row's best round is kept:
the machine is shared, the ratios are what to read.  Rows, and the API each measures:

* ``KapitzaPendulum.measure_grid(A, ω, θ0, periods=500, observables="classification")``
  at its default tolerance (rtol 1e-4, kapitza.simulation.CLASSIFICATION_RTOL) — the
  classification target, ≥ 4× heyoka with 0 of 4096 misclassified — and at rtol 1e-3;
* ``System.simulate_grid`` (the engine under it) with the band only, rtol 1e-4 and 1e-3;
* ``KapitzaPendulum.measure_grid(A, ω, θ0, periods=500)`` (every observable, Ω with its
  error, rtol 1e-9) against ``System.simulate_grid(..., strobe=T, reference=π, band=...)``
  at rtol 1e-9 (the samples it fits) — the Ω target: within 1.5× of it;
* ``System.simulate_grid`` with the band only at rtol 1e-9: what the strobe samples cost
  (the held step divides the period, so they land unshortened);
* heyoka's batch integrator (tolerance 1e-9, 2 threads; the corrected peer of
  bench_batch.py: a batch re-propagated until every lane has ended or fallen).

The misclassification count is against the reference of bench_batch.py: the per-point
RKN 12(10) path of ``simulate_grid`` (no lanes) at rtol 1e-12.

Usage::

    python benchmarks/bench_measure.py            # the 64 × 64 grid, 3 rounds
    python benchmarks/bench_measure.py --quick    # 16 × 16, one round (a smoke run)
"""
from __future__ import annotations

import argparse
import math
import os
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "benchmarks"))

from bench_batch import PERIODS, THETA0, grid, heyoka_grid, reference  # noqa: E402

from kapitza import KapitzaPendulum  # noqa: E402

PEND = KapitzaPendulum(l=1.0, g=9.81)
BAND = ([math.pi / 2], [3 * math.pi / 2])


def measure_classify(A, w, **kw):
    m = PEND.measure_grid(A, w, THETA0, periods=PERIODS, observables="classification",
                          progress=False, **kw)
    return np.asarray(m.stayed_up)


def measure_all(A, w):
    m = PEND.measure_grid(A, w, THETA0, periods=PERIODS, progress=False)
    return np.asarray(m.stayed_up)


def engine(A, w, rtol, strobe=False):
    T = 2 * np.pi / w
    extra = dict(strobe=T, reference=[math.pi]) if strobe else {}
    g = PEND.system.simulate_grid([THETA0], [0.0], (0.0, PERIODS * T), PEND.params(A, w),
                                  band=BAND, rtol=rtol, progress=False, **extra)
    return g.status == 0


ROWS = {
    "measure_grid classification (default rtol 1e-4)": measure_classify,
    "measure_grid classification, rtol 1e-3": lambda A, w: measure_classify(A, w, rtol=1e-3),
    "simulate_grid band only, rtol 1e-4": lambda A, w: engine(A, w, 1e-4),
    "simulate_grid band only, rtol 1e-3": lambda A, w: engine(A, w, 1e-3),
    "measure_grid all + Ω (default rtol 1e-9)": measure_all,
    "simulate_grid strobe + band, rtol 1e-9": lambda A, w: engine(A, w, 1e-9, strobe=True),
    "simulate_grid band only, rtol 1e-9": lambda A, w: engine(A, w, 1e-9),
    "heyoka batch, tol 1e-9, 2 thr (corrected)": heyoka_grid,
}
HEYOKA = "heyoka batch, tol 1e-9, 2 thr (corrected)"
CLASSIFY = "measure_grid classification (default rtol 1e-4)"
OMEGA, STROBE = "measure_grid all + Ω (default rtol 1e-9)", "simulate_grid strobe + band, rtol 1e-9"


def _load():
    return f"{os.getloadavg()[0]:.2f}"


def grid_and_rounds(description):
    """The command line of this script and bench_damped_grid.py: (A, ω, rounds)."""
    ap = argparse.ArgumentParser(description=description)
    ap.add_argument("--rounds", type=int, default=3, help="timed rounds (best kept)")
    ap.add_argument("--quick", action="store_true", help="16 × 16 grid, one round")
    args = ap.parse_args()
    A, w = grid(16, 16) if args.quick else grid()
    return A, w, 1 if args.quick else args.rounds


def best_of_rounds(rows, A, w, rounds):
    """Every row timed once a round, the rounds in turn (the machine's load falls on all
    rows alike); each row's best second and the result of that run."""
    best, result = {}, {}
    for r in range(rounds):
        for name, run in rows.items():
            t0 = time.perf_counter()
            out = run(A, w)
            sec = time.perf_counter() - t0
            if sec < best.get(name, math.inf):
                best[name], result[name] = sec, out
        print(f"  round {r + 1}/{rounds} done, load {_load()}")
    return best, result


def main():
    A, w, rounds = grid_and_rounds(__doc__.splitlines()[0])
    N = A.size
    for run in ROWS.values():                      # compile (or load) outside the timing
        run(A[:1, :8], w[:1, :8])
    t0 = time.perf_counter()
    up_ref, _ = reference(A, w)
    print(f"grid {A.shape}, {PERIODS} periods; reference (per-point rkn12, rtol 1e-12) "
          f"{time.perf_counter() - t0:.1f} s, stayed up {up_ref.mean():.4f}, load {_load()}")
    best, result = best_of_rounds(ROWS, A, w, rounds)
    hey = best[HEYOKA]
    print(f"\n  {'row (API)':50s} {'best s':>7s} {'points/s':>9s} {'÷ heyoka':>9s} "
          f"{'misclassified':>13s}")
    for name, sec in best.items():
        mism = int(np.sum(result[name] != up_ref))
        print(f"  {name:50s} {sec:7.3f} {N / sec:9.0f} {hey / sec:9.2f} {mism:>9d}/{N}")
    print(f"\n  target 1: {CLASSIFY}: {hey / best[CLASSIFY]:.2f} × heyoka (≥ 4), "
          f"{int(np.sum(result[CLASSIFY] != up_ref))} of {N} misclassified (0)")
    print(f"  target 2: {OMEGA} / {STROBE}: {best[OMEGA] / best[STROBE]:.2f} (≤ 1.5)")
    print(f"  load at the end {_load()}")


if __name__ == "__main__":
    main()
