"""Long compiled work in chunks: a progress line, and Ctrl-C that keeps what finished.

Compiled (numba) code cannot be interrupted: Python sees Ctrl-C only when a compiled
call returns.  So every long computation of the toolkit (grids of simulations, Floquet
maps, sweeps) is cut into chunks of about a quarter of a second by :func:`run_in_chunks`,
which shows progress between chunks and stops at the next boundary on Ctrl-C; the
caller then returns or raises what finished.  :func:`defer_ctrl_c` keeps a Ctrl-C
from cutting the NumPy glue between chunked stages in the middle.  The grid kernels
that pause long runs need not wait for a boundary: they read :data:`KERNEL_STOP`, which
Ctrl-C sets, at every step.
"""
from __future__ import annotations

import contextlib
import signal
import sys
import threading
import time

import numpy as np

__all__ = ["ProgressLine", "defer_ctrl_c", "run_in_chunks", "interrupt_requested",
           "KERNEL_STOP"]

#: seconds of work before a progress line appears (shorter work shows none)
SHOW_AFTER = 0.5


class ProgressLine:
    """A progress line on stderr (after 0.5 s, at most 10 updates per second), or a callback.

    ``progress``: None (a line when stderr is a terminal), False (quiet), True (a line),
    or a callable ``progress(done, total)`` called after every chunk.  ``done`` may be
    fractional (a long run part-way: the share of its span reached); the line shows the
    whole units done, the percentage and an estimate of the time left (from the rate so
    far), or with ``fraction`` the percentage only ("simulate: 53 % of t_span, ...").
    """

    def __init__(self, progress, total, label, unit, *, fraction=False):
        if not (progress is None or isinstance(progress, bool) or callable(progress)):
            raise ValueError(f"progress must be None, True, False or a callable "
                             f"progress(done, total); got {progress!r}.")
        self.callback = progress if callable(progress) and not isinstance(progress, bool) \
            else None
        tty = getattr(sys.stderr, "isatty", lambda: False)()
        self.show = progress is True or (progress is None and tty)
        self.total, self.label, self.unit, self.fraction = total, label, unit, fraction
        self.t0 = self.last = time.perf_counter()
        self.shown = False

    def update(self, done):
        if self.show:
            now = time.perf_counter()
            el = now - self.t0
            if el > SHOW_AFTER and (now - self.last > 0.1 or done == self.total):
                self.last = now
                left = (f"~{el * (self.total - done) / done:.0f} s left" if done > 0
                        else "time left not yet known")
                share = f"{100 * done / max(self.total, 1):.0f} %"
                count = (f"{share} {self.unit}" if self.fraction else
                         f"{int(done)}/{self.total} {self.unit} ({share})")
                sys.stderr.write(f"\r{self.label}: {count}, {el:.1f} s, {left} ")
                sys.stderr.flush()
                self.shown = True
        if self.callback is not None:
            self.callback(done, self.total)

    def close(self):
        if self.shown:
            sys.stderr.write("\n")
            sys.stderr.flush()


#: Ctrl-C while :func:`defer_ctrl_c` is active: "hit" is set instead of raising in NumPy glue
_SIGINT = {"active": False, "hit": False}

#: Ctrl-C for the compiled calls in flight.  The grid kernels that pause long runs (the
#: drivers of ``lagrange_core._batch_kernels`` and ``lagrange_core._first_order_lanes``,
#: ``kapitza.chaos._lanes``) take this one-element array as their argument ``stop`` and
#: read it at every step: once it is 1 their running points pause at their next accepted
#: step (status "interrupted", as when a call's step budget is used) and the points not
#: yet started stay unstarted.  Why: a call is sized to ~0.25 s from the calls before it,
#: but on a loaded machine one can run several times longer, and Python sees Ctrl-C only
#: when it returns.  Set by Ctrl-C while :func:`defer_ctrl_c` is active (and by
#: ``lagrange_core._thread_blocks.run_blocks`` on a KeyboardInterrupt); 0 again when
#: the outermost :func:`defer_ctrl_c` is entered or left.
KERNEL_STOP = np.zeros(1, dtype=np.int64)


@contextlib.contextmanager
def defer_ctrl_c():
    """While active (main thread, Python's own SIGINT handler installed), Ctrl-C only sets
    ``_SIGINT["hit"]`` (and :data:`KERNEL_STOP`); :func:`run_in_chunks` stops at the next
    chunk boundary, the grid kernels' running points pause at their next step, and the
    NumPy code between the chunked stages is never cut in the middle (its result would be
    lost with a plain KeyboardInterrupt).  Re-entrant: nested calls do nothing."""
    if (_SIGINT["active"] or threading.current_thread() is not threading.main_thread()
            or signal.getsignal(signal.SIGINT) is not signal.default_int_handler):
        yield
        return

    def handler(signum, frame):
        _SIGINT["hit"] = True
        KERNEL_STOP[0] = 1

    _SIGINT.update(active=True, hit=False)
    KERNEL_STOP[0] = 0
    old = signal.signal(signal.SIGINT, handler)
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, old)
        _SIGINT.update(active=False, hit=False)
        KERNEL_STOP[0] = 0


def run_in_chunks(work, total, *, progress=None, label="", unit="points", first=64,
                  target=0.25):
    """Call ``work(start, stop)`` over consecutive chunks of range(total).

    Each chunk is one compiled call sized to take about ``target`` seconds (the
    first has ``first`` items; each next one is sized from the rate measured,
    at most 8× the last), so Ctrl-C — which Python sees only between compiled
    calls — stops the loop within a chunk's time.  A ``work`` whose kernel reads
    :data:`KERNEL_STOP` (the caller inside :func:`defer_ctrl_c`) may stop in the middle
    of its chunk and return how many of its first items it finished (None: all); the
    loop then stops there.  Returns (items finished,
    interrupted); the caller turns an interruption into
    :class:`~kapitza.results.ComputationInterrupted` with its partial result (whole, when
    the Ctrl-C came during the last chunk: it is raised all the same, not dropped).
    """
    bar = ProgressLine(progress, total, label, unit)
    done = 0
    size = max(1, min(first, total))
    try:
        while done < total:
            if _SIGINT["hit"]:
                raise KeyboardInterrupt
            start, stop = done, min(total, done + size)
            t0 = time.perf_counter()
            finished = work(start, stop)
            dt = time.perf_counter() - t0
            # a call that reads KERNEL_STOP may stop early and say how many it finished
            done = stop if finished is None else start + int(finished)
            bar.update(done)
            if done < stop:
                raise KeyboardInterrupt
            size = int(min(max(1.0, (stop - start) / max(dt, 1e-6) * target), 8 * size))
    except KeyboardInterrupt:
        bar.close()
        return done, True
    bar.close()
    # a Ctrl-C during the last chunk is not dropped: the caller raises its interruption,
    # with the whole result in it
    return done, _SIGINT["hit"]



def interrupt_requested() -> bool:
    """Whether Ctrl-C was pressed while :func:`defer_ctrl_c` was active (and not yet acted on)."""
    return _SIGINT["hit"]
