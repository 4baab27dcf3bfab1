"""Compile, once per installation, everything the integrators need.

The integrators (:mod:`lagrange_core._integrator_kernels`) are compiled once for every
system and cached by numba next to the package; a new system then costs only its own
kernels.  :func:`warmup` runs each driver once on small systems of the catalogue, so the
first simulation a user runs does not pay for the integrators either (about 10–20 s on a
2-core machine the first time; a fraction of a second once cached).
"""
from __future__ import annotations

import math
import time

from . import _compile_notice

__all__ = ["warmup"]

# the package's face imports this module: from here on, a first compile of the shared
# kernels says so on stderr, once per process
_compile_notice.install()


@_compile_notice.activity("lagrange_core.warmup")
def warmup(verbose: bool = False) -> float:
    """Compile (or load from numba's cache) every integrator driver; returns the seconds taken.

    Runs the pendulum with each driver (DOP853, the RKN and symplectic drivers on the
    drive kernel; events compile with them) and the Cartesian spherical
    pendulum (constraint projection).  The systems' own kernels go to the kernel store as
    usual.
    """
    from . import problems
    from .integrate import crossing
    start = time.perf_counter()
    pendulum = problems.pendulum()
    params = {p: 1.0 for p in pendulum.parameters}
    never = crossing(pendulum.coordinates[0], 10.0)       # an event that does not fire
    runs = [dict(method="dop853", events=[never]), dict(method="rkn12", events=[never]),
            dict(method="yoshida6", h=0.01)]
    for kw in runs:
        pendulum.simulate([0.1], [0.0], (0.0, 0.1), params, **kw)
        if verbose:
            print(f"warmup: pendulum {kw.get('method')}"
                  f"{' with an event' if kw.get('events') else ''} "
                  f"({time.perf_counter() - start:.1f} s)")
    spherical = problems.spherical_pendulum("cartesian")
    spherical.simulate([math.sin(0.3), 0.0, -math.cos(0.3)], [0.0, 0.5, 0.0], (0.0, 0.1),
                       {p: 1.0 for p in spherical.parameters})
    if verbose:
        print(f"warmup: constrained system ({time.perf_counter() - start:.1f} s)")
    return time.perf_counter() - start
