"""Ctrl-C while numba compiles a kernel for its first call (a fresh installation's first
``measure`` or ``simulate``: tens of seconds in which numba's compiler cannot be stopped
safely).

``lagrange_core._first_calls`` makes a kernel's first call with new argument types compile
on a thread of its own while the calling thread waits for it watching for Ctrl-C: a kernel
called directly through the guard each kernel module puts on its dispatchers, a grid
kernel by a first call on an empty span (``_thread_blocks.run_spans``).  Checked:

* every grid kernel family writes nothing on an empty span — what makes giving up on its
  first call safe (the call runs to its end on its thread after the caller has gone on);
* a Ctrl-C during a (slowed) compilation returns within a second, nothing written, with
  the deferred Ctrl-C of the grids and with Python's own handler; the next call, which
  waits for the compilation, computes the right numbers;
* every kernel of lagrange_core and kapitza, and a system's generated ones, is guarded;
* ``kapitza measure`` on an empty cache, Ctrl-C while its kernels compile: the warning
  within a second (it was the rest of the compilation: 15–30 s on the development
  machine), exit 130, no traceback; ``System.simulate`` likewise, the interruption taken
  outside numba's compiler (where Python's handler raised it before, which could leave
  numba unable to compile: "no compiled object yet for <Library …>").
"""
import _thread
import math
import os
import signal
import subprocess
import sys
import threading
import time

import numba
import numpy as np
import pytest
from numba.core import event

from lagrange_core import _first_calls, _thread_blocks, problems
from lagrange_core.progress import defer_ctrl_c

from helpers import ctrl_c_until_said, sigint_default

W60 = 2 * math.pi * 60
T60 = 2 * math.pi / W60
PEND = dict(m=1.0, l=1.0, g=9.81, A=0.05, omega=W60)


def _arrays(x, seen):
    """The arrays in ``x`` (a closure cell's contents; tuples and functions looked into)."""
    if isinstance(x, np.ndarray):
        seen.setdefault(id(x), x)
    elif isinstance(x, tuple):
        for y in x:
            _arrays(y, seen)
    elif callable(x) and getattr(x, "__closure__", None):
        for cell in x.__closure__:
            _arrays(cell.cell_contents, seen)


def test_every_grid_kernel_writes_nothing_on_an_empty_span(monkeypatch):
    """The grid kernels' first calls, as the toolkit makes them (RKN 12 on lanes, per
    point, the symplectic and DOP853 drivers, DOP853 on lanes, the chaos room's lanes, the
    Floquet monodromy rows, the Mathieu trace, the slow-frequency fit): each called again
    on the empty span leaves every array it can reach exactly as it was."""
    from kapitza import KapitzaPendulum
    from kapitza.chaos import lyapunov_grid
    from kapitza.closed_forms import mathieu_monodromy_trace
    from kapitza.floquet import floquet_grid

    works = []
    monkeypatch.setattr(_thread_blocks, "first_call", lambda call, key: works.append(call))
    pend = problems.driven_pendulum("vertical")
    damped = problems.driven_pendulum("vertical", damping=True)
    q0, span = [np.pi - 0.1], (0.0, 4 * T60)
    pend.simulate_grid(q0, [0.0], span, PEND, strobe=T60, reference=[np.pi],
                       band=([np.pi / 2], [3 * np.pi / 2]), energy=True, progress=False)
    pend.simulate_grid(q0, [0.0], span, PEND, method="yoshida6", h=T60 / 20, energy=True,
                       progress=False)
    damped.simulate_grid(q0, [0.0], span, dict(PEND, gamma=0.1), strobe=T60, progress=False)
    lyapunov_grid(damped, dict(PEND, A=0.1, omega=2 * math.sqrt(9.81), gamma=0.3), 0.3,
                  periods=4, transient=0, blocks=2, progress=False)
    KapitzaPendulum().measure(0.05, W60, math.pi - 0.1, periods=40, progress=False)
    floquet_grid(pend, dict(PEND, A=[0.04, 0.05]), [np.pi])
    mathieu_monodromy_trace(1.3, 0.7)
    assert len(works) >= 8
    for call in works:              # call: work(0, 0)
        seen = {}
        _arrays(call, seen)
        assert seen
        before = {k: a.copy() for k, a in seen.items()}
        call()
        for k, a in seen.items():
            np.testing.assert_array_equal(a, before[k], err_msg=str(call.__closure__))


@numba.njit(nogil=True)
def _double_rows(x, out, lo, hi):
    for i in range(lo, hi):
        out[i] = 2.0 * x[i]


class _SlowCompile(event.Listener):
    """Makes the compilation of :func:`_double_rows` last ``seconds`` (it sleeps)."""

    def __init__(self, seconds):
        self.seconds = seconds

    def on_start(self, ev):
        if ev.data["dispatcher"] is _double_rows:
            time.sleep(self.seconds)

    def on_end(self, ev):
        pass


@pytest.fixture
def python_s_sigint_handler():
    """Python's own SIGINT handler for the test (a suite started as a shell's background
    job has SIGINT ignored, and ``_thread.interrupt_main`` then does nothing)."""
    old = signal.signal(signal.SIGINT, signal.default_int_handler)
    yield
    signal.signal(signal.SIGINT, old)


def test_ctrl_c_while_a_kernel_compiles_returns_at_once_and_the_next_call_waits(
        python_s_sigint_handler):
    """A Ctrl-C 0.2 s into a first call whose compilation lasts 1.5 s: KeyboardInterrupt
    within a second, nothing written; the compilation goes on (``compiling()``), and the
    next call waits for it and doubles the numbers."""
    listener = _SlowCompile(1.5)
    event.register("numba:compile", listener)
    x = np.arange(5.0)
    out = np.zeros(5)
    try:
        timer = threading.Timer(0.2, _thread.interrupt_main)    # Ctrl-C, as Python sees it
        start = time.perf_counter()
        with pytest.raises(KeyboardInterrupt), defer_ctrl_c():
            timer.start()
            _thread_blocks.run_rows(_double_rows, 5, x, out)
        took = time.perf_counter() - start
        assert took < 1.3, took
        assert _first_calls.compiling()
        np.testing.assert_array_equal(out, 0.0)
        _thread_blocks.run_rows(_double_rows, 5, x, out)
        assert time.perf_counter() - start > 1.2       # it waited for the compilation
        np.testing.assert_array_equal(out, 2.0 * x)
        assert not _first_calls.compiling()
    finally:
        event.unregister("numba:compile", listener)


@numba.njit
def _triple(x):
    return 3.0 * x


_first_calls.guard(__name__)        # as a kernel module does


class _SlowTriple(_SlowCompile):
    def on_start(self, ev):
        if ev.data["dispatcher"] is _triple:
            time.sleep(self.seconds)


def test_python_s_own_ctrl_c_leaves_a_direct_kernel_s_compilation_alone(
        python_s_sigint_handler):
    """A guarded kernel called directly (as ``simulate`` calls its drivers) with Python's own
    SIGINT handler: the KeyboardInterrupt comes in the wait within a second, not inside
    numba's compiler; the compilation ends on its thread, and the kernel then works."""
    listener = _SlowTriple(1.5)
    event.register("numba:compile", listener)
    try:
        timer = threading.Timer(0.2, _thread.interrupt_main)
        start = time.perf_counter()
        with pytest.raises(KeyboardInterrupt):
            timer.start()
            _triple(2.0)
        assert time.perf_counter() - start < 1.0
        assert _first_calls.compiling()
        assert _triple(2.0) == 6.0                  # waits for the compilation
        assert time.perf_counter() - start > 1.2
        assert not _first_calls.compiling()
        assert _triple(2.5) == 7.5                  # the warm call: numba's own dispatch
    finally:
        event.unregister("numba:compile", listener)


def test_every_kernel_module_guards_its_first_calls():
    """Every numba kernel of lagrange_core and kapitza (every module imported) has its
    first call guarded, and a system's generated kernels too."""
    import importlib
    import pkgutil

    from numba.core.dispatcher import Dispatcher

    import kapitza
    import lagrange_core
    for package in (lagrange_core, kapitza):
        for info in pkgutil.walk_packages(package.__path__, package.__name__ + "."):
            if not info.name.endswith("__main__"):
                importlib.import_module(info.name)
    assert problems.driven_pendulum("vertical").kernels.module      # generated, loaded
    kernels = [(name, key) for name, module in list(sys.modules.items())
               if name.startswith(("lagrange_core", "kapitza", "_lc"))
               for key, value in vars(module).items()
               if isinstance(value, Dispatcher) and value.py_func.__module__ == name]
    assert len(kernels) > 100 and any(name.startswith("_lc_") for name, _ in kernels)
    unguarded = [f"{name}.{key}" for name, key in kernels
                 if "_compile_for_args" not in vars(vars(sys.modules[name])[key])]
    assert not unguarded


#: A child's lines that say "driver compiling" on stdout, once, when numba starts compiling
#: the function named DRIVER (on the compiling thread: a second line would stand where
#: the test reads what follows).
SAYS_DRIVER = r'''
from numba.core import event


class Driver(event.Listener):
    said = False

    def on_start(self, ev):
        function = getattr(ev.data.get("dispatcher"), "py_func", None)
        if getattr(function, "__name__", "") == DRIVER and not self.said:
            self.said = True
            print("driver compiling", flush=True)

    def on_end(self, ev):
        pass


event.register("numba:compile", Driver())
'''


COLD_MEASURE = r'''
import sys
from kapitza.cli import main
DRIVER = "_lanes_block"         # RKN 12's lanes driver
''' + SAYS_DRIVER + r'''
sys.exit(main(["measure", "--A", "0.05", "--f", "60", "--theta0", "3.0"]))
'''


def test_ctrl_c_while_the_first_measure_compiles_stops_within_a_second(tmp_path):
    """``kapitza measure`` on empty caches; Ctrl-C 0.3 s into the compile of RKN 12's lanes
    driver (~7 s; the notice is said as the first of lagrange_core's kernels starts
    compiling, the driver's rates, 0.5–1 s before it): the interruption is said within a
    second, exit 130, no traceback.  (The driver's start is waited for, not a fixed time
    after the notice: 0.3 s after it landed between two compiles on a loaded machine —
    "interrupted before the run started" — and more is a second of compiling each.)"""
    env = dict(os.environ, PYTHONUNBUFFERED="1", NUMBA_CACHE_DIR=str(tmp_path / "numba"),
               LAGRANGE_CORE_CACHE=str(tmp_path / "lc"), KAPITZA_BACKGROUND_COMPILE="0",
               LAGRANGE_CORE_COMPILE_NOTICE="1")
    proc = subprocess.Popen([sys.executable, "-c", COLD_MEASURE], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, env=env,
                            preexec_fn=sigint_default)
    try:
        notice = proc.stderr.readline()
        assert "compiling numba kernels for first use" in notice, proc.communicate()
        assert proc.stdout.readline().strip() == "driver compiling", proc.communicate()
        time.sleep(0.3)
        assert proc.poll() is None, proc.communicate()
        took, out, err = ctrl_c_until_said(proc, [notice])
    finally:
        if proc.poll() is None:
            proc.kill()
    assert proc.returncode == 130, (out, err)
    assert took < 1.0, err
    assert "Traceback" not in err and "Ctrl-C while numba compiled a kernel" in err, err


COLD_SIMULATE = r'''
import json, math, sys, time
from lagrange_core import problems
from lagrange_core.integrate import SimulationInterrupted
DRIVER = "fast_rkn_chunk"       # RKN 12's chunk driver
''' + SAYS_DRIVER + r'''
pend = problems.driven_pendulum("vertical")
P = dict(m=1.0, l=1.0, g=9.81, A=0.05, omega=2 * math.pi * 60)
print("ready", flush=True)
try:
    pend.simulate([math.pi - 0.1], [0.0], (0.0, 0.2), P)
    outcome = "finished"
except SimulationInterrupted as stop:
    outcome = "interrupted: " + stop.trajectory.message
except KeyboardInterrupt:
    outcome = "KeyboardInterrupt"
print(outcome, flush=True)
'''


def test_ctrl_c_while_the_first_simulate_compiles_stops_within_a_second(tmp_path):
    """``System.simulate`` on empty caches, Ctrl-C 0.3 s into the compile of RKN 12's chunk
    driver (~12 s, after ~1.5 s of smaller kernels): interrupted within a
    second, the interruption taken in the wait (said so), not inside numba's compiler —
    where Python's handler raised it before, as quickly, but leaving numba unable to
    compile in 1 of 6 probes ("no compiled object yet for <Library …>" at the next call)
    — and the process ends without waiting for the compilation (the next call's wait
    for it: the tests above)."""
    env = dict(os.environ, PYTHONUNBUFFERED="1", NUMBA_CACHE_DIR=str(tmp_path / "numba"),
               LAGRANGE_CORE_CACHE=str(tmp_path / "lc"), LAGRANGE_CORE_COMPILE_NOTICE="1")
    proc = subprocess.Popen([sys.executable, "-c", COLD_SIMULATE], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, env=env,
                            preexec_fn=sigint_default)
    try:
        assert proc.stdout.readline().strip() == "ready", proc.communicate()
        notice = proc.stderr.readline()
        assert "compiling numba kernels for first use" in notice, proc.communicate()
        # the driver's compile under way (a fixed wait after the notice, 3 s, sometimes
        # landed in the smaller kernels' compile on a loaded machine: Ctrl-C there stops
        # the call before its run exists, a plain KeyboardInterrupt)
        assert proc.stdout.readline().strip() == "driver compiling", proc.communicate()
        time.sleep(0.3)                 # well inside the driver's compile, however loaded
        assert proc.poll() is None, proc.communicate()
        sent = time.time()
        proc.send_signal(signal.SIGINT)
        outcome = proc.stdout.readline().strip()
        took = time.time() - sent
        out, err = proc.communicate(timeout=120)
        ended = time.time() - sent
    finally:
        if proc.poll() is None:
            proc.kill()
    assert proc.returncode == 0, (outcome, out, err)
    assert outcome.startswith("interrupted: interrupted (Ctrl-C) at t = 0 s"), (outcome, err)
    assert took < 1.0, (took, outcome)
    assert ended < 2.0, ended
    assert "Ctrl-C while numba compiled a kernel" in err, err


def test_the_collector_is_paused_while_numba_compiles_and_left_as_it_was():
    """While numba compiles, Python's cyclic collector is off (10 % of a compile's time,
    lagrange_core._first_calls), seen from inside numba's typing of a fresh function; after
    it, the collector is as it was before: on, or off where the caller had turned it off."""
    import gc

    from numba import njit
    from numba.extending import overload

    seen = []
    for before in (True, False):
        def probe():
            pass

        @overload(probe)
        def _probe():
            seen.append(gc.isenabled())    # numba types the call here, while it compiles
            return lambda: None

        (gc.enable if before else gc.disable)()
        try:
            @njit(cache=False)
            def fresh():
                probe()
            fresh()
            assert gc.isenabled() is before
        finally:
            gc.enable()
    assert seen == [False, False]
