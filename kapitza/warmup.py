"""Compile, once per installation, the numba code that kapitza's analyses share.

:func:`lagrange_core.warmup` compiles the integrators; this adds Floquet's sampler and
monodromy kernels (the general path, compiled once for every system) and the Mathieu
characteristic values of the pendulum's exact maps.  Kernels that belong to one system
(its right-hand side, its averaging kernels) still compile on that system's first use.
"""
from __future__ import annotations

import math
import time

__all__ = ["warmup"]


def warmup(verbose: bool = False) -> float:
    """Compile (or load from numba's cache) what every kapitza analysis needs; seconds taken."""
    import lagrange_core

    from .pendulum import KapitzaPendulum
    start = time.perf_counter()
    lagrange_core.warmup(verbose)
    pendulum = KapitzaPendulum(l=1.0, g=9.81)
    omega = 2 * math.pi * 60
    pendulum.stability_map(A=[0.02, 0.05], omega=[omega, 2 * omega])     # characteristic values
    pendulum.window(omega)                                               # certified window
    pendulum.floquet(0.05, omega, about="inverted")                     # general monodromy
    if verbose:
        print(f"warmup: kapitza's Floquet and Mathieu kernels "
              f"({time.perf_counter() - start:.1f} s)")
    return time.perf_counter() - start
