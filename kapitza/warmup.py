"""Compile, once per installation, the numba code that kapitza's analyses share.

:func:`lagrange_core.warmup` compiles the integrators; this adds Floquet's sampler and
monodromy kernels, the Mathieu characteristic values and monodromy trace of the
pendulum's exact maps (undamped and damped), the grid kernels and the slow-frequency fit
that ``measure`` runs, and the pendulum's own kernels for both drives, damped and
undamped, and DOP853's lanes that a damped grid runs on.  After it, a first ``measure``
of any drive only loads machine code (≈ 1 s instead of tens of seconds).

On an empty cache the work is split into independent *groups* (:data:`GROUPS`) that
compile in separate processes, one per core: numba's disk cache is shared, so each
process writes what it compiled and the others (and every later process) load it.  The
groups run the public API on small cases, so they compile exactly the specialisations a
user's call needs.  :func:`start_background` runs groups in one background process
while the caller works (``kapitza report`` compiles its later sections' kernels there
while it computes its first sections).
"""
from __future__ import annotations

import math
import os
import subprocess
import sys
import time
from concurrent.futures import ThreadPoolExecutor

from lagrange_core import _background

__all__ = ["warmup"]

_OMEGA = 2 * math.pi * 60       # rad/s: a fast drive, so the runs below are short


def _pendulums():
    from .pendulum import KapitzaPendulum
    for drive in ("vertical", "horizontal"):
        for damping in (0.0, 0.5):
            yield KapitzaPendulum(l=1.0, g=9.81, damping=damping, drive=drive)


def _start(pend, A):
    """A release near the state ``measure`` is about by default (inverted; tilted)."""
    if pend.drive == "vertical":
        return math.pi - 0.1
    return math.acos(2 * pend.g * pend.l / (A * _OMEGA) ** 2) + 0.05


def _measure(method):
    """``measure`` for every drive, with and without the slow-frequency fit."""
    A = 0.05
    for pend in _pendulums():
        if method != "default" and (pend.damping or pend.drive != "vertical"):
            continue            # the report's grids (its default scene); the damped drives
            #                     run DOP853 by default, in the group "measure"
        kw = {} if method == "default" else {"method": method}
        theta0 = _start(pend, A)
        pend.measure(A, _OMEGA, theta0, periods=60, **kw)
        pend.measure(A, _OMEGA, theta0, periods=60, observables="classification", **kw)


def _integrators():
    import lagrange_core
    lagrange_core.warmup()
    for pend in _pendulums():       # the drives' own kernels (rhs, drive kernel)
        pend.simulate(0.05, _OMEGA, _start(pend, 0.05), 0.0, (0.0, 0.05))


def _report_integrators():
    """The single runs of the report's default scene: its work–precision diagram (RKN 12
    and DOP853) and its animation (RKN 12 with output times)."""
    import numpy as np

    from lagrange_core.accuracy_cost import work_precision

    from .pendulum import KapitzaPendulum
    pend = KapitzaPendulum(l=1.0, g=9.81)
    A, theta0, T = 0.05, math.pi - 0.1, 2 * math.pi / _OMEGA
    work_precision(pend.system, [theta0], [0.0], (0.0, 2 * T), pend.params(A, _OMEGA),
                   rtols=(1e-6,), repeat=1)
    pend.simulate(A, _OMEGA, theta0, 0.0, (0.0, 2 * T), rtol=1e-9,
                  t_eval=np.linspace(0.0, 2 * T, 9))


def _damped_grids():
    """A grid of 256 points of each damped drive: DOP853 on lanes (from
    ``lagrange_core.batch.FIRST_ORDER_LANES_MIN_POINTS`` points), its driver and each
    damped pendulum's lanes kernels (``rhs_lanes``)."""
    import numpy as np
    A, omega = np.meshgrid(np.linspace(0.02, 0.05, 16), _OMEGA * np.linspace(1.0, 2.0, 16),
                           indexing="ij")
    for pend in _pendulums():
        if pend.damping:
            pend.measure_grid(A, omega, _start(pend, 0.05), periods=20,
                              observables="classification", progress=False)


def _floquet():
    from .pendulum import KapitzaPendulum
    pendulum = KapitzaPendulum(l=1.0, g=9.81)
    pendulum.stability_map(A=[0.02, 0.05], omega=[_OMEGA, 2 * _OMEGA])   # characteristic values
    pendulum.window(_OMEGA)                                               # certified window
    pendulum.floquet(0.05, _OMEGA, about="inverted")                     # general monodromy
    damped = KapitzaPendulum(l=1.0, g=9.81, damping=0.5)
    damped.stability_map(A=[0.02, 0.05], omega=[_OMEGA, 2 * _OMEGA])      # the Mathieu trace


#: The groups, longest first (each alone on an empty cache, 2026-11-26: measure 54 s,
#: floquet 20 s, grids (dop853) 20 s, report integrators 24 s): each compiles a disjoint
#: family of kernels, so two processes rarely compile the same one.
GROUPS = {
    "measure": lambda: _measure("default"),     # RKN 12 lanes + the fit (undamped), DOP853
    "floquet": _floquet,
    "integrators": _integrators,
    "grids (dop853)": lambda: _measure("dop853"),   # the report's grid integrator
    "report integrators": _report_integrators,      # (within "integrators" but for the
    #                                                  report's own call types)
    "damped grids": _damped_grids,                  # DOP853's lanes
}


def run_group(name: str) -> None:
    """Run one group in this process (what a worker process does)."""
    import warnings
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")         # the small cases may warn (short records)
        GROUPS[name]()


def _command(names) -> list:
    # (``import kapitza.warmup`` would give the function the package exports)
    code = ("import sys\nfrom kapitza.warmup import run_group\n"
            "for name in sys.argv[1:]:\n"
            "    run_group(name)\n")
    return [sys.executable, "-c", code, *names]


def cold() -> bool:
    """Whether numba's cache lacks the shared kernels (a probe of a few of them)."""
    from lagrange_core import _batch_kernels, _integrator_kernels
    return _background.cold(_integrator_kernels.fast_rkn_chunk, _integrator_kernels.dop853_chunk,
                            _batch_kernels._dop853_rows, _batch_kernels._lanes_block)


def _parallel(names, processes, verbose, start):
    """Run ``names`` in ``processes`` worker processes; failures are left to the
    in-process pass (which raises them with a traceback of its own)."""
    # (a worker starts no background compile of its own: it is one)
    env = dict(os.environ, KAPITZA_BACKGROUND_COMPILE="0")

    def one(name):
        out = subprocess.run(_command([name]), capture_output=True, text=True, check=False,
                             env=env)
        if verbose:
            print(f"warmup: {name} compiled in a worker ({time.perf_counter() - start:.1f} s"
                  f"{', failed' if out.returncode else ''})")
    with ThreadPoolExecutor(max_workers=processes) as pool:
        list(pool.map(one, names))


def warmup(verbose: bool = False, *, processes: int | None = None) -> float:
    """Compile (or load from numba's cache) what every kapitza analysis needs; seconds taken.

    Parameters
    ----------
    verbose : bool
        Print each part's progress.
    processes : int or None
        Worker processes that compile in parallel on an empty cache (None: the number of
        CPUs, at most 4; 1: everything in this process).  A warm cache skips them.

    Returns
    -------
    float
        Wall time (s): about 60–90 s on an empty cache on 2 cores, ≈ 2 s when cached.
    """
    from lagrange_core import _compile_notice
    start = time.perf_counter()
    processes = min(os.cpu_count() or 1, 4) if processes is None else int(processes)
    with _compile_notice.declared("kapitza.warmup"):
        if processes > 1 and cold():
            _compile_notice.say("lagrange_core._integrator_kernels")  # the workers are silent
            _parallel(list(GROUPS), processes, verbose, start)
        for name in GROUPS:          # loads what the workers compiled; compiles the rest
            run_group(name)
            if verbose:
                print(f"warmup: {name} ({time.perf_counter() - start:.1f} s)")
    return time.perf_counter() - start


def wait_for(names) -> float:
    """Wait until the background processes compiling the groups ``names`` have ended
    (:func:`start_background`; at once when none runs), so that the kernels they compile
    are loaded from the cache rather than compiled a second time on the same cores: in a
    cold ``kapitza report`` the work–precision section compiled RKN 12's driver itself
    (14 s) while the background process was compiling it.  Ctrl-C ends the wait
    (KeyboardInterrupt).  Returns the seconds waited."""
    return _background.wait(names)


def start_background(names=("grids (dop853)", "report integrators")):
    """Compile the groups ``names`` on an empty cache, each in a background process of its
    own (the list of processes, None for one that could not start; None if the cache is
    warm); they are ended when this process exits.  The caller goes on with its own
    work, and loads what the background
    processes have written by the time it needs it: with one process for both groups the
    report reached its work–precision section before the integrators were compiled and
    compiled them itself as well (cold report 69.6 s, against 61.3 s with one process per
    group, 2026-11-26).  ``KAPITZA_BACKGROUND_COMPILE=0`` turns it off (a test suite,
    whose workers already use every core)."""
    if not _background.enabled() or not cold():
        return None
    return [_background.start(name, f"from kapitza.warmup import run_group\nrun_group({name!r})")
            for name in names]
