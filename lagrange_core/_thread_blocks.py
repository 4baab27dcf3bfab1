"""Blocks of a compiled kernel on numba's thread count, by a pool of Python threads.

The grid kernels (:mod:`lagrange_core._batch_kernels`, :mod:`lagrange_core._first_order_lanes`,
``kapitza.chaos._lanes``, ``kapitza.floquet._kernels``) split their points into blocks and
run each block with one call of a GIL-free (``nogil=True``) compiled function; the blocks
go to the threads of a pool here, each taking the next block when it finishes (dynamic
scheduling, as numba's ``prange`` with ``parallel_chunksize(1)``).

Why not ``prange``: numba's parallel lowering compiles the loop's body as a gufunc with
every kernel it calls linked into one LLVM module and optimised again — on an empty cache
that cost more than the kernels themselves (measured 2026-11-26, exclusive compile time:
``grid_rkn_lanes``'s wrapper 19 s, ``_monodromy_grid``'s 11 s, against 0.1–2 s for a
serial wrapper).  Run time is the same: the blocks are seconds-long compiled calls, a
pool's hand-off costs microseconds.

A Ctrl-C while the blocks run waits for the running blocks before it is raised: the
caller then reads results no thread is still writing — as numba's parallel region did,
which Python's signal handler could only run after.  The wait is short: the kernels that
pause long runs read :data:`lagrange_core.progress.KERNEL_STOP`, set here while waiting,
and pause their points at the next step (the others' blocks are sized to a fraction of
a second by their callers).

A kernel's first call with new argument types compiles it (tens of seconds on an empty
cache), which Ctrl-C cannot stop part-way: :func:`run_spans` first calls the work on an
empty span, which compiles the kernel and computes nothing, through
:func:`lagrange_core._first_calls.first_call` (on a thread of its own, which a Ctrl-C
does not wait for).
"""
from __future__ import annotations

import concurrent.futures
import contextvars
from collections.abc import Callable

import numba
import numpy as np

from ._first_calls import first_call
from .progress import KERNEL_STOP

__all__ = ["run_blocks", "run_spans", "first_span_call", "run_rows", "run_draining",
           "run_shared", "thread_count"]

_POOLS: dict[int, concurrent.futures.ThreadPoolExecutor] = {}


def thread_count() -> int:
    """The threads the grid kernels use: numba's (``NUMBA_NUM_THREADS``,
    ``numba.set_num_threads``)."""
    return int(numba.get_num_threads())


def _pool(threads: int) -> concurrent.futures.ThreadPoolExecutor:
    if threads not in _POOLS:
        _POOLS[threads] = concurrent.futures.ThreadPoolExecutor(
            threads, thread_name_prefix="lagrange-core-grid")
    return _POOLS[threads]


def run_blocks(work: Callable[[int], None], nblocks: int, *, stoppable: bool = False) -> None:
    """``work(b)`` for every block b in range(nblocks), on :func:`thread_count` threads
    (on the calling thread alone when that is 1 or there is one block).  ``work`` must
    call a ``nogil`` kernel: with the GIL held the threads would run one at a time.

    ``stoppable``: the kernel reads :data:`~lagrange_core.progress.KERNEL_STOP`; then even
    a single block runs on the pool, so that the calling thread only waits, sees a Ctrl-C
    at once and can set the flag (a hand-off costs tens of microseconds; such a block is
    a compiled call sized to a quarter of a second)."""
    threads = min(thread_count(), nblocks)
    if threads <= 1 and not (stoppable and nblocks > 0):
        for b in range(nblocks):
            work(b)
        return
    # each block in a copy of the caller's context: a kernel compiled on its first call
    # (in a pool thread) is announced with the caller's activity and its estimate
    # (lagrange_core._compile_notice; a context is entered by one thread at a time)
    futures = [_pool(threads).submit(contextvars.copy_context().run, work, b)
               for b in range(nblocks)]
    try:
        for future in futures:
            future.result()
    except BaseException:
        for future in futures:          # (a Ctrl-C): let the running blocks finish,
            future.cancel()
        before = KERNEL_STOP[0]
        KERNEL_STOP[0] = 1              # pausing their points at the next step
        try:
            concurrent.futures.wait(futures)
        finally:
            KERNEL_STOP[0] = before
        raise


def run_spans(work: Callable[[int, int], None], npoints: int, block: int, *,
              stoppable: bool = False) -> None:
    """``work(lo, hi)`` for the consecutive spans [lo, hi) of ``block`` points (the last
    one shorter) that cover 0 … npoints − 1, by :func:`run_blocks`.

    ``work`` must compute nothing and write nothing on an empty span (lo = hi): its first
    call with new argument types is ``work(0, 0)`` on the compiling thread
    (:func:`~lagrange_core._first_calls.first_call`), which a Ctrl-C does not wait for."""
    first_span_call(work, npoints)
    run_blocks(lambda b: work(b * block, min(npoints, (b + 1) * block)), -(-npoints // block),
               stoppable=stoppable)


def run_draining(kernel, head, middle, idx, slot, lo, hi, SAVE, SAVEI, stop, drained,
                 cursor=None, width=None):
    """``kernel(*head, idx, cursor, hi, width, *middle, slot, SAVE, SAVEI, drained)`` — a
    lanes driver's block (RKN 12's and DOP853's), its free lanes taking the points
    ``idx[cursor[0]:hi]`` one by one from ``cursor`` (by default its own, from ``lo``;
    shared: :func:`run_shared`) onto at most ``width`` lanes (by default hi − lo) — then
    the points it drained (paused with ``SAVEI[·, 0] == drained`` once few of its lanes
    still ran and every point was taken), on as many lanes as they are, until none
    drains; not after a Ctrl-C (``stop[0]``), whose paused points the next call resumes.
    The kernel runs first on any span, an empty one included: that call is what compiles
    it (:func:`first_span_call`)."""
    if cursor is None:
        cursor = np.array([lo], dtype=np.int64)
    if width is None:
        width = hi - lo
    while True:
        kernel(*head, idx, cursor, hi, width, *middle, slot, SAVE, SAVEI, drained)
        if hi <= lo or stop[0] != 0:
            return
        again = SAVEI[slot[lo:hi], 0] == drained
        if not again.any():
            return
        idx, slot = idx[lo:hi][again], slot[lo:hi][again]
        lo, hi = 0, idx.shape[0]
        cursor, width = np.zeros(1, dtype=np.int64), hi


def run_shared(work, npoints: int, lanes: int, drained: int) -> None:
    """A lanes driver's ``work(lo, hi, cursor, width, drained)`` (:func:`run_draining`)
    on every thread at once, all taking the points 0 … npoints − 1 from one shared cursor
    (:mod:`lagrange_core._shared_cursor`): a faster thread takes more points, and the
    threads run out of points together, where fixed blocks left one idle up to ~9 ms at
    the end of a call (4 % of the 64 × 64 grid on the 2-core machine, 2026-11-28).  Each
    thread runs on up to ``lanes`` lanes (fewer when the points are fewer than the threads'
    lanes) and marks the points it drains ``drained`` + its number, so that each runs
    again only its own.  ``work(0, 0)`` first, the call that compiles it
    (:func:`first_span_call`)."""
    first_span_call(work, npoints)
    threads = max(1, min(thread_count(), npoints))
    cursor = np.zeros(1, dtype=np.int64)
    width = min(lanes, -(-npoints // threads))
    run_blocks(lambda b: work(0, npoints, cursor, width, drained + b), threads if npoints else 0,
               stoppable=True)


def first_span_call(work: Callable[[int, int], None], npoints: int) -> None:
    """``work(0, 0)``, the first call with new argument types of a ``work`` that computes
    nothing on an empty span, on the compiling thread
    (:func:`~lagrange_core._first_calls.first_call`; at once when its types have been
    through): what :func:`run_spans` does first, for a caller that needs the compile
    done before it prepares the rest of the call."""
    if npoints > 0:
        first_call(lambda: work(0, 0), _types(work))


def run_rows(kernel, npoints: int, *args, per_thread: int = 4,
             stoppable: bool = False) -> None:
    """``kernel(*args, lo, hi)`` over the points 0 … npoints − 1 in about ``per_thread``
    contiguous blocks per thread (more when the points' costs differ, so that the pool
    balances them), by :func:`run_spans`.  ``kernel`` is a ``nogil`` kernel taking the
    block's bounds as its last two arguments."""
    step = max(1, -(-npoints // (per_thread * thread_count())))
    run_spans(lambda lo, hi: kernel(*args, lo, hi), npoints, step, stoppable=stoppable)


def _types(work) -> tuple | None:
    """What picks a call's compiled version, as far as a quick look tells: the code, the
    kernels it calls (``run_rows``: the kernel passed) and the Python type of everything
    it reads from its closure.  (An array's dtype and dimensions are fixed by the code
    that makes it; a call site whose arrays differ from one call to the next would only
    compile where a Ctrl-C cannot leave it, as before.)  ~5 µs for 40 arguments."""
    def typ(x):
        if callable(x):
            return id(x)                    # a kernel: numba's dispatcher of its own
        if type(x) is tuple:
            return tuple(map(typ, x))
        return type(x)
    try:
        return (work.__code__, tuple(typ(c.cell_contents) for c in (work.__closure__ or ())))
    except (AttributeError, ValueError):    # not a plain function, an empty cell
        return None
