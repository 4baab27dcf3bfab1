"""The catalogue summary, ``kapitza summary`` (the default command): every problem of
lagrange_core's catalogue derived, compiled and integrated once, with its timings and
energy drift."""
from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numpy as np

__all__ = ["catalogue_summary"]


@dataclass(frozen=True)
class Case:
    """One catalogue problem with parameter values and an initial state."""

    label: str
    make: object            # () -> System
    params: dict
    q0: list
    qdot0: list
    t_end: float            # s


def _cases():
    from lagrange_core import problems as P
    g = 9.81
    return [
        Case("pendulum", P.pendulum, dict(m=1.0, l=1.0, g=g), [2.0], [0.0], 20.0),
        Case("double pendulum (chaotic)", P.double_pendulum,
             dict(m1=1.0, m2=1.0, l1=1.0, l2=1.0, g=g), [2.0, 2.5], [0.0, 0.0], 20.0),
        Case("8-link pendulum", lambda: P.n_link_pendulum(8),
             {**{f"m{i}": 1.0 for i in range(1, 9)}, **{f"l{i}": 0.25 for i in range(1, 9)},
              "g": g}, [0.3] * 8, [0.0] * 8, 5.0),
        Case("Kapitza pendulum (inverted)", P.driven_pendulum,
             dict(m=1.0, l=1.0, g=g, A=0.05, omega=2 * math.pi * 60), [math.pi - 0.1], [0.0], 5.0),
        Case("central force (Kepler, e = 0.5)", P.central_force, dict(m=1.0, k=1.0),
             [1.0, 0.0], [0.0, math.sqrt(1.5)], 30.0),
        Case("spherical pendulum", P.spherical_pendulum, dict(m=1.0, l=1.0, g=g),
             [1.0, 0.0], [0.0, 2.0], 20.0),
        Case("block on a sliding wedge", P.block_on_wedge,
             dict(m=1.0, M=3.0, alpha=math.radians(30), g=g), [0.0, 0.0], [0.0, 0.0], 1.0),
        Case("swinging Atwood machine", P.swinging_atwood, dict(m=1.0, g=g),
             [1.0, 0.5], [0.0, 0.0], 2.0),
        Case("string of 20 beads", lambda: P.bead_string(20), dict(F=100.0, l=1.0, mu=0.01),
             [0.001 * math.sin(math.pi * (i + 1) / 21) for i in range(20)], [0.0] * 20, 0.05),
    ]


def catalogue_summary(rtol: float = 1e-10, progress=None):
    """Derive, compile and integrate each catalogue problem; a pandas DataFrame, one row each.

    Columns: problem, dof, constraints, derive_s, compile_s, integrate_s, method, steps,
    energy_drift_J (max |h − h0| in J where the energy function h is conserved, else NaN),
    error_estimate, status.
    """
    import pandas as pd

    rows = []
    cases = _cases()
    for i, case in enumerate(cases):
        if progress:
            progress(f"[{i + 1}/{len(cases)}] {case.label}")
        row = {"problem": case.label}
        try:
            t0 = time.perf_counter()
            system = case.make()
            eq = system.equations
            t1 = time.perf_counter()
            _ = system.kernels                  # compiles them (a cached property)
            t2 = time.perf_counter()
            traj = system.simulate(case.q0, case.qdot0, (0.0, case.t_end), case.params, rtol=rtol)
            t3 = time.perf_counter()
            drift = float(np.max(np.abs(traj.energy - traj.energy[0]))) \
                if eq.energy_conserved else float("nan")
            row.update(dof=system.n_dof, constraints=system.n_constraints, derive_s=t1 - t0,
                       compile_s=t2 - t1, integrate_s=t3 - t2, method=traj.method,
                       steps=traj.n_steps, energy_drift_J=drift,
                       error_estimate=traj.error_estimate, status=traj.status)
        except Exception as exc:      # one failing problem must not hide the others
            row.update(status=f"error: {exc}")
        rows.append(row)
    return pd.DataFrame(rows)
