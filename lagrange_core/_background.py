"""Compile kernels in a background process while this one works: both cores on a cold cache.

A *group* is a few lines of Python run by ``python -c`` in a process of its own; what it
compiles goes to numba's disk cache, from which this process loads it when it gets there
(:func:`wait` first, so that it is not compiled twice at once).  Background processes run
only where they help: the kernels' cache is cold (:func:`cold`) and
``KAPITZA_BACKGROUND_COMPILE`` is not ``0`` — a test suite sets it, its workers already
use every core; the processes started here inherit ``0``, so that they start none of
their own.  They are ended when this process exits (numba writes its cache files
atomically, so an ended one leaves nothing half-written).

Users: ``System.simulate_grid``'s first grid on RKN 12's lanes (the driver's callees,
:func:`lagrange_core._lanes_ahead.start_if_cold`); kapitza's ``report`` (its later
sections' groups, :func:`kapitza.warmup.start_background`) and ``measure`` (the lanes
driver's callees and the slow-frequency fit beside the grid,
``kapitza.simulation._measurement._compile_in_background``).  The switch keeps kapitza's
name, which the test suite and users set (the module moved here from kapitza on
2026-11-28, so that the engine's own first grid can use it).
"""
from __future__ import annotations

import atexit
import os
import subprocess
import sys
import time

__all__ = ["enabled", "cold", "start", "running", "wait", "end", "RUNNING"]

#: this process's background compiles, by group name
RUNNING: dict[str, subprocess.Popen] = {}

_SWITCH = "KAPITZA_BACKGROUND_COMPILE"


def enabled() -> bool:
    """Whether background compiles are allowed (``KAPITZA_BACKGROUND_COMPILE`` not 0)."""
    return os.environ.get(_SWITCH, "1").strip() not in ("0", "false", "no")


def cold(*dispatchers) -> bool:
    """Whether numba's cache lacks the machine code of any of ``dispatchers`` (the index
    of its cache file has no entry).  False for a numba whose cache this cannot read:
    then nothing is started, and the kernels compile where they are called."""
    for dispatcher in dispatchers:
        try:
            # an index with no entry: importing the module writes an empty one (the
            # guard against stale callees flushes numba's cache)
            if not dispatcher._cache._cache_file._load_index():
                return True
        except AttributeError:
            return False
    return False


def start(name: str, code: str) -> subprocess.Popen | None:
    """Run ``code`` in a background process for the group ``name`` (once: a group already
    started is not started again) and return the process; None where no process can be
    started (the system's limit): the kernels then compile where they are called, as on
    one core — a background compile only saves time, it is never needed."""
    if name in RUNNING:
        return RUNNING[name]
    env = dict(os.environ, **{_SWITCH: "0"})
    try:
        proc = subprocess.Popen([sys.executable, "-c", code], stdout=subprocess.DEVNULL,
                                stderr=subprocess.DEVNULL, env=env)
    except OSError:
        return None
    RUNNING[name] = proc
    atexit.register(end, proc)
    return proc


def running() -> bool:
    """Whether a background compile this process started is still running."""
    return any(proc.poll() is None for proc in RUNNING.values())


def wait(names) -> float:
    """Wait until the background processes of the groups ``names`` have ended (at once for
    a group with none); Ctrl-C ends the wait (KeyboardInterrupt).  Returns the seconds
    waited."""
    begun = time.perf_counter()
    for name in names:
        proc = RUNNING.get(name)
        if proc is not None:
            proc.wait()         # (a signal's handler raising ends the blocking wait)
    return time.perf_counter() - begun


def end(proc) -> None:
    """End a background process still running (5 s to go, then killed): at exit, for every
    one started here."""
    if proc.poll() is None:
        proc.terminate()
    try:
        proc.wait(timeout=5)
    except subprocess.TimeoutExpired:
        proc.kill()
