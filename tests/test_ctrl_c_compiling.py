"""Ctrl-C while numba compiles a kernel for its first call (a fresh installation's first
``measure``: tens of seconds in which numba's compiler cannot be stopped).

``lagrange_core._thread_blocks.run_spans`` makes a grid kernel's first call with new
argument types on an empty span (which compiles it and computes nothing) on a thread of
its own, and the calling thread waits for it watching for Ctrl-C.  Checked here:

* every grid kernel family writes nothing on an empty span — what makes giving up on its
  first call safe (the call runs to its end on its thread after the caller has gone on);
* a Ctrl-C during a (slowed) compilation returns within a second, nothing written, and
  the next call, which waits for the compilation, computes the right numbers;
* ``kapitza measure`` on an empty cache, Ctrl-C while its kernels compile: the warning
  within a second (it was the rest of the compilation: 15–22 s on the development
  machine), exit 130, no traceback.
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

from lagrange_core import _thread_blocks, problems
from lagrange_core.progress import defer_ctrl_c

from helpers import sigint_default

W60 = 2 * math.pi * 60
T60 = 2 * math.pi / W60
PEND = dict(m=1.0, l=1.0, g=9.81, A=0.05, omega=W60)


def _arrays(x, seen):
    """The arrays in ``x`` (a closure cell's contents; tuples looked into)."""
    if isinstance(x, np.ndarray):
        if id(x) not in seen:
            seen[id(x)] = x
    elif isinstance(x, tuple):
        for y in x:
            _arrays(y, seen)


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
    monkeypatch.setattr(_thread_blocks, "_compiled", works.append)
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
    for work in works:
        seen = {}
        for cell in work.__closure__ or ():
            _arrays(cell.cell_contents, seen)
        before = {k: a.copy() for k, a in seen.items()}
        work(0, 0)
        for k, a in seen.items():
            np.testing.assert_array_equal(a, before[k], err_msg=str(work.__code__))


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


def test_ctrl_c_while_a_kernel_compiles_returns_at_once_and_the_next_call_waits():
    """A Ctrl-C 0.3 s into a first call whose compilation lasts 2.5 s: KeyboardInterrupt
    within a second, nothing written; the compilation goes on (``compiling()``), and the
    next call waits for it and doubles the numbers."""
    listener = _SlowCompile(2.5)
    event.register("numba:compile", listener)
    x = np.arange(5.0)
    out = np.zeros(5)
    try:
        timer = threading.Timer(0.3, _thread.interrupt_main)    # Ctrl-C, as Python sees it
        start = time.perf_counter()
        with pytest.raises(KeyboardInterrupt), defer_ctrl_c():
            timer.start()
            _thread_blocks.run_rows(_double_rows, 5, x, out)
        took = time.perf_counter() - start
        assert took < 1.3, took
        assert _thread_blocks.compiling()
        np.testing.assert_array_equal(out, 0.0)
        _thread_blocks.run_rows(_double_rows, 5, x, out)
        assert time.perf_counter() - start > 2.0       # it waited for the compilation
        np.testing.assert_array_equal(out, 2.0 * x)
        assert not _thread_blocks.compiling()
    finally:
        event.unregister("numba:compile", listener)


COLD_MEASURE = r'''
import sys
from kapitza.cli import main
sys.exit(main(["measure", "--A", "0.05", "--f", "60", "--theta0", "3.0"]))
'''


def test_ctrl_c_while_the_first_measure_compiles_stops_within_a_second(tmp_path):
    """``kapitza measure`` on empty caches; Ctrl-C 1.5 s after the compile notice (RKN 12's
    lanes kernel compiling, ~20 s): the interruption is said within a second, exit 130,
    no traceback."""
    env = dict(os.environ, PYTHONUNBUFFERED="1", NUMBA_CACHE_DIR=str(tmp_path / "numba"),
               LAGRANGE_CORE_CACHE=str(tmp_path / "lc"), KAPITZA_BACKGROUND_COMPILE="0",
               LAGRANGE_CORE_COMPILE_NOTICE="1")
    proc = subprocess.Popen([sys.executable, "-c", COLD_MEASURE], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, env=env,
                            preexec_fn=sigint_default)
    try:
        lines = [proc.stderr.readline()]
        assert "compiling numba kernels for first use" in lines[0], proc.communicate()
        time.sleep(1.5)
        assert proc.poll() is None, proc.communicate()
        sent = time.time()
        proc.send_signal(signal.SIGINT)
        while not any("interrupted" in line for line in lines):
            lines.append(proc.stderr.readline())      # the warning, as soon as it is said
            assert lines[-1], "stderr closed without saying it was interrupted"
        took = time.time() - sent
        out, err = proc.communicate(timeout=60)
    finally:
        if proc.poll() is None:
            proc.kill()
    err = "".join(lines) + err
    assert proc.returncode == 130, (out, err)
    assert took < 1.0, err
    assert "Traceback" not in err and "Ctrl-C while numba compiled kernels" in err, err
