"""One line on stderr when numba starts compiling the shared kernels, with an estimate.

A fresh installation (or a cleared cache) compiles the integrators, the grid kernels and
kapitza's Floquet and fitting kernels on first use: tens of seconds in which nothing
else is printed.  :func:`install` registers a numba compile listener; the first time in
a process that numba *compiles* (a cache miss, never a cache load) a function of
``lagrange_core`` or ``kapitza``, it prints once::

    lagrange_core: compiling numba kernels for first use (kapitza report), ~40 s; later
    runs load them from the cache

(one line on the terminal).

A warm run compiles nothing of these and prints nothing.  A new system's own kernels
(the generated ``_lc_*`` modules, about a second) do not trigger it: they are expected on
every new statement.

The estimate comes from :data:`ACTIVITY_SECONDS` (what the outermost running activity
compiles in all, declared by :func:`activity` or :func:`declared`: the report, the
warm-ups, each grid driver's first ``simulate_grid`` and ``measure``, a general system's
first Floquet analysis, a first periodic orbit and a first branch; for RKN 12's first
grid and measure, :data:`ALONE_SECONDS` when no second process compiles beside) or else
:data:`FAMILY_SECONDS` (the family of the first function compiled), both measured on the
2-core development machine (benchmarks/README.md; ``python benchmarks/bench_cold_start.py
--only notices`` compares each with the first use it announces), scaled by the load when
the machine has more runnable processes than cores.
The activity is a context variable: the grid kernels' pool threads run in a copy of the
caller's context (:mod:`lagrange_core._thread_blocks`), where their first call compiles.
It is a rough figure (±50 %), not a bound.

``LAGRANGE_CORE_COMPILE_NOTICE=0`` turns the line off (e.g. a test suite that compares
stderr).
"""
from __future__ import annotations

import contextlib
import contextvars
import functools
import os
import sys
import threading

__all__ = ["install", "activity", "declared", "say", "ACTIVITY_SECONDS", "ALONE_SECONDS",
           "FAMILY_SECONDS"]

#: Seconds an activity compiles on an empty cache (idle 2-core machine, numba 0.68):
#: the whole of it, so the notice at its first compile says how long the wait is.
ACTIVITY_SECONDS = {
    "kapitza report": 40,           # 38–41 s in all, 2026-11-26 (compiling most of it)
    "kapitza.warmup": 55,           # 57 s, 2026-11-26 (two processes)
    "lagrange_core.warmup": 20,
    # the first grid of each driver (lagrange_core.batch.compile_activity), the driven
    # pendulum on empty caches, 2026-11-27: RKN 12's lanes 27 s, DOP853 8–10 s; the
    # symplectic per-point driver, compiled without RKN 12's code, 10.2–11.1 s (2026-11-28;
    # 26–29 s with it); kapitza's ``measure`` compiles the strobe fit on the other core,
    # and RKN 12 lanes driver's callees there too (lagrange_core._lanes_ahead), which
    # the driver calls by address (lagrange_core._lanes_callees), and simulate_grid
    # compiles them there too on its own (lagrange_core._lanes_ahead.start_if_cold):
    # RKN 12's first grid 12.7–13.3 s (20.0–21.0 s in one process), its first measure
    # 12.2–13.5 s (2026-11-28, twenty-third session; 21.4–21.6 s and 16.3–17.4 s
    # before), 8.5–10.5 s (38 s, 15.5–17 s on one core); since the lanes driver grew
    # (drain, four stages a pass: its own compile 16–17.5 s alone, 10.3 s then) the first
    # grid 22.2 s and the first measure 20.6 s (2026-11-29, twenty-ninth session, where
    # the notice quoted ~14 s: 0.63 and 0.68 of the wait); the driver's lane-by-lane
    # section a callee, the callees shared out between the two processes and compiled
    # without Python's wrapper (thirtieth session): 12.5, 13.5 s and 15.0, 17.3 s
    "simulate_grid, RKN 12": 13,
    "simulate_grid, symplectic": 10,
    "simulate_grid, DOP853": 9,
    "measure, RKN 12": 16,
    "measure, DOP853": 10,          # (measure runs no fixed-step method: it passes no h)
    # a first damped grid of 128 points or more (DOP853's lanes, the system's rhs_lanes):
    # the damped pendulum's 16 × 16 measure_grid 12.0–12.6 s (6.7–6.8 s per point before
    # it ran on lanes), 2026-11-28 (twenty-fifth session); 19.0 s, and a first damped
    # simulate_grid of 256 points 18.7 s, 2026-11-29 (twenty-ninth session; quoted ~12 s)
    "simulate_grid, DOP853 lanes": 19,
    "measure, DOP853 lanes": 19,
    # a general system's first Floquet analysis (the sampler, the monodromy rows): a
    # 2-link chain's floquet_point, 13.5–15.5 s, 2026-11-27
    "Floquet": 15,
    # a first periodic orbit (shooting on the variational flow, the orbit's check by
    # DOP853): the horizontal drive's, 10.6–15.1 s; a first branch, the upright
    # pendulum's, 4.3–5.9 s (2026-11-27)
    "periodic orbit": 12,
    # a first Lyapunov map (lyapunov_grid: the system's lanes kernels and the chaos
    # lanes), the damped driven pendulum's: 15.3–16.4 s (2026-11-28; it had no activity,
    # and the first module compiled said ~3 s); 24.6 s, 2026-11-29 (quoted ~16 s)
    "Lyapunov map": 25,
    "continuation": 5,
    # commands whose first compile comes before any of the API's activities (the command
    # line's checks compile the closed forms first, whose family says ~3 s): their whole
    # first run on empty caches, less ~2 s of start-up, 2026-11-28
    "kapitza animate": 23,          # 25.2 s
    "kapitza continue": 8,          # 10.0 s
    "kapitza lyapunov": 11,         # 12.5 s
    "kapitza map": 5,               # 7.3 s
}

#: The same first RKN 12 grid and ``measure`` when no second process compiles the lanes
#: driver's callees beside this one (one core, ``KAPITZA_BACKGROUND_COMPILE=0``, or none
#: started) and they are not in numba's cache: all of it compiles here.  Measured on
#: empty caches with the switch off, 2026-11-28 (twenty-fourth session): the grid 21.8–
#: 21.9 s, the first measure 24.1–25.2 s (the notice had quoted ~14 s for both); the
#: lanes driver grown, 30.8 and 38.4 s, 2026-11-29 (twenty-ninth session; quoted ~20 s);
#: its lane-by-lane section a callee, the callees without Python's wrapper, 22.1, 26.3 s
#: and 27.7, 27.9 s (thirtieth session; quoted ~30 and ~40 s).
ALONE_SECONDS = {
    "simulate_grid, RKN 12": 24,
    "measure, RKN 12": 28,
}

#: Seconds a family of shared kernels compiles on an empty cache, by module of the
#: first function compiled (used when no activity is declared).
FAMILY_SECONDS = {
    "lagrange_core._integrator_kernels": 15,
    "lagrange_core._batch_kernels": 25,
    "lagrange_core._first_order_lanes": 25,
    "lagrange_core._variational_kernels": 5,
    "lagrange_core._core_kernels": 3,
    "kapitza.floquet": 15,
    "kapitza.closed_forms": 3,      # the pendulum's exact window and maps: 2.3–4.5 s
    "kapitza.simulation": 12,
    "kapitza.chaos": 20,
}
DEFAULT_SECONDS = 15

_activity: contextvars.ContextVar[str | None] = contextvars.ContextVar(
    "lagrange_core_compile_activity", default=None)
_lock = threading.Lock()
_state = {"installed": False, "said": False}


@contextlib.contextmanager
def declared(name: str):
    """Context in which ``name`` is the running activity (the outermost one counts), so
    a notice printed inside it quotes the activity's whole compile time."""
    token = _activity.set(_activity.get() or name)        # the outermost one counts
    try:
        yield
    finally:
        _activity.reset(token)


def activity(name: str):
    """Decorator: the function runs as activity ``name`` (see :func:`declared`)."""
    def wrap(func):
        @functools.wraps(func)
        def inner(*args, **kwargs):
            with declared(name):
                return func(*args, **kwargs)
        return inner
    return wrap


#: Modules whose compiles are announced: the installation's shared kernels (generated
#: system modules, ``_lc_*``, are not among them).
SHARED_PREFIXES = ("lagrange_core.", "kapitza.")


def _shared(module: str) -> bool:
    return module.startswith(SHARED_PREFIXES)


def estimate(module: str) -> int:
    """The notice's estimate (s) for a first compile in ``module``, load included."""
    name = _activity.get()
    if name in ALONE_SECONDS and _compiles_alone():
        seconds = ALONE_SECONDS[name]
    elif name in ACTIVITY_SECONDS:
        seconds = ACTIVITY_SECONDS[name]
    else:
        seconds = next((s for prefix, s in FAMILY_SECONDS.items() if module.startswith(prefix)),
                       DEFAULT_SECONDS)
    try:
        # a compile is one thread: on a machine with more runnable processes than cores it
        # gets a share of one (capped: the load average lags)
        share = os.getloadavg()[0] / (os.cpu_count() or 1)
    except OSError:
        share = 1.0
    seconds *= min(max(share, 1.0), 4.0)
    return int(round(seconds, -1)) if seconds >= 20 else max(int(round(seconds)), 1)


def _compiles_alone() -> bool:
    """Whether RKN 12's lanes callees would compile in this process: no background
    compile runs beside it (:mod:`lagrange_core._background`) and numba's cache lacks one
    of them (:func:`lagrange_core._lanes_ahead.wanted`)."""
    from . import _background, _lanes_ahead
    return not _background.running() and _lanes_ahead.wanted()


def message(module: str) -> str:
    """The one line printed."""
    name = _activity.get()
    what = f" ({name})" if name else ""
    return (f"lagrange_core: compiling numba kernels for first use{what}, ~{estimate(module)} s; "
            "later runs load them from the cache")


def _on_compile(module: str) -> None:
    if not _shared(module):
        return
    say(module)


def say(module: str) -> None:
    """Print the notice now, unless this process has printed it (for work that compiles
    in other processes, which print nothing); ``module`` picks the family's estimate."""
    if _state["said"]:
        return
    if os.environ.get("LAGRANGE_CORE_COMPILE_NOTICE", "1").strip() in ("0", "false", "no"):
        return
    with _lock:
        if _state["said"]:
            return
        _state["said"] = True
    try:
        print(message(module), file=sys.stderr, flush=True)
    except (OSError, ValueError):       # a closed stderr: the notice is a courtesy
        pass


def install() -> None:
    """Register the compile listener (once per process; cheap: numba is imported anyway)."""
    if _state["installed"]:
        return
    from numba.core import event

    class _Listener(event.Listener):
        def on_start(self, ev):
            dispatcher = (ev.data or {}).get("dispatcher")
            func = getattr(dispatcher, "py_func", None)
            _on_compile(getattr(func, "__module__", None) or "")

        def on_end(self, ev):
            pass

    event.register("numba:compile", _Listener())
    _state["installed"] = True


def reset_for_tests() -> None:
    """Forget that the notice was printed (tests only)."""
    _state["said"] = False
