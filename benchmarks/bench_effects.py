"""What an effect costs when a scene names it: the same motion with and without a term.

Issue 13, point 1.  The driven pendulum (l = 1 m, A = 5 cm, 60 Hz, from θ = π − 0.1 at
rest, 2000 drive periods, rtol 1e-9) built by ``lagrange_core.effects.build`` from the
pendulum rig with gravity and the vertical drive, then with a damping term and with an
air-drag term *set to zero* (γ = 0, c = 0): the motion is the same, but a named
velocity force enters the statement, so the run loses the q̈ = f(q, t) form (RKN 12
with the drive kernel) and falls back to DOP853 on the general right-hand side, and
the drag adds a square root per evaluation.  Every variant runs in this one process,
best of ``--repeat`` runs after a warm-up (compile time excluded).

Usage::

    python benchmarks/bench_effects.py [--repeat 5]
"""
from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from lagrange_core import effects as fx  # noqa: E402

W = 2 * math.pi * 60
BASE = dict(m=1.0, l=1.0, g=9.81, A=0.05, omega=W)
VARIANTS = {
    "gravity + drive": ([], {}),
    "+ damping (γ = 0)": ([fx.Damping()], {"gamma": 0.0}),
    "+ air drag (c = 0)": ([fx.AirDrag()], {"c_drag": 0.0}),
    "+ damping + air drag (both 0)": ([fx.Damping(), fx.AirDrag()],
                                       {"gamma": 0.0, "c_drag": 0.0}),
}


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=5)
    args = ap.parse_args()
    rig = fx.pendulum_rig()
    span = (0.0, 2000 * 2 * math.pi / W)
    rows = []
    ref_theta = None
    for name, (extra, params) in VARIANTS.items():
        s = fx.build(rig, [fx.Gravity(), fx.PivotDrive("vertical")] + extra)
        p = dict(BASE, **params)
        s.simulate([math.pi - 0.1], [0.0], (0.0, 0.01), p)          # compile / load
        best = float("inf")
        for _ in range(args.repeat):
            t0 = time.perf_counter()
            tr = s.simulate([math.pi - 0.1], [0.0], span, p, rtol=1e-9)
            best = min(best, time.perf_counter() - t0)
        theta = tr.q[-1, 0]
        ref_theta = theta if ref_theta is None else ref_theta
        rows.append((name, tr.method, best, tr.n_steps, abs(theta - ref_theta)))
    base = rows[0][2]
    print(f"{'variant':32s} {'method':8s} {'time':>9s} {'×':>6s} {'steps':>8s} {'|Δθ(T)|':>9s}")
    for name, method, sec, steps, d in rows:
        print(f"{name:32s} {method:8s} {sec * 1e3:7.2f} ms {sec / base:6.2f} {steps:8d} {d:9.1e}")


if __name__ == "__main__":
    main()
