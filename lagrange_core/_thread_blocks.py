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
cache), and numba's compiler cannot be stopped part-way.  So :func:`run_spans` first
calls the work on an empty span, which compiles the kernel and computes nothing, on a
thread of its own, while the calling thread waits and watches for Ctrl-C: a Ctrl-C then
returns at once (KeyboardInterrupt, as from an interrupted chunk, before anything was
written), and the compilation finishes on its thread, where the next call finds it.
Once a signature has been through, its calls skip the step.
"""
from __future__ import annotations

import concurrent.futures
import contextvars
import queue
import sys
import threading
import time
from collections.abc import Callable

import numba
from numba.core import event

from .progress import KERNEL_STOP, interrupt_requested

__all__ = ["run_blocks", "run_spans", "run_rows", "thread_count", "compiling"]

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
    call with new argument types is ``work(0, 0)`` on the compiling thread (see the
    module's notes), which a Ctrl-C does not wait for."""
    if npoints > 0:
        _compiled(work)
    run_blocks(lambda b: work(b * block, min(npoints, (b + 1) * block)), -(-npoints // block),
               stoppable=stoppable)


def run_rows(kernel, npoints: int, *args, per_thread: int = 4,
             stoppable: bool = False) -> None:
    """``kernel(*args, lo, hi)`` over the points 0 … npoints − 1 in about ``per_thread``
    contiguous blocks per thread (more when the points' costs differ, so that the pool
    balances them), by :func:`run_spans`.  ``kernel`` is a ``nogil`` kernel taking the
    block's bounds as its last two arguments."""
    step = max(1, -(-npoints // (per_thread * thread_count())))
    run_spans(lambda lo, hi: kernel(*args, lo, hi), npoints, step, stoppable=stoppable)


# -- a first call's compilation, which Ctrl-C need not wait for ----------------------------

#: the argument types (:func:`_types`) whose first call has been made in this process
_SEEN: set = set()
#: seconds a pending Ctrl-C waits for a first call that is not compiling (loading a
#: compiled kernel from numba's disk cache: a tenth of a second)
_PATIENCE = 1.0
_JOBS: queue.SimpleQueue = queue.SimpleQueue()
_COMPILER: list[threading.Thread] = []
#: numba compilations running on the compiling thread (0 or 1: nested ones count once)
_COMPILING = [0]
_START = threading.Lock()
#: whether this Ctrl-C's giving up has been said
_SAID = [False]


def _types(work) -> tuple:
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
    return (work.__code__, tuple(typ(c.cell_contents) for c in (work.__closure__ or ())))


def _compiler() -> None:
    """The compiling thread: runs each first call it is handed (a daemon: a process that
    ends need not wait for a compilation nobody waits for)."""
    while True:
        job = _JOBS.get()
        try:
            job["context"].run(job["call"])
        except BaseException as error:          # handed to the caller, if it still waits
            job["error"] = error
        finally:
            job["done"].set()


def _start_compiler() -> None:
    with _START:
        if not (_COMPILER and _COMPILER[0].is_alive()):
            _COMPILER[:] = [threading.Thread(target=_compiler, daemon=True,
                                             name="lagrange-core-compile")]
            _COMPILER[0].start()


class _Compilations(event.Listener):
    """Counts the compilations (cache misses: a load from numba's disk cache is none)
    running on the compiling thread."""

    depth = 0

    def on_start(self, ev):
        if _COMPILER and threading.current_thread() is _COMPILER[0]:
            _Compilations.depth += 1
            _COMPILING[0] = 1

    def on_end(self, ev):
        if _COMPILER and threading.current_thread() is _COMPILER[0]:
            _Compilations.depth -= 1
            _COMPILING[0] = int(_Compilations.depth > 0)


event.register("numba:compile", _Compilations())


def compiling() -> bool:
    """Whether numba compiles a first call on the compiling thread now — one a Ctrl-C
    gave up waiting for: until it ends, any first call waits for it (numba compiles, and
    loads from its cache, one function at a time)."""
    return bool(_COMPILING[0])


def _compiled(work) -> None:
    """Make ``work``'s first call with these argument types — an empty span, which only
    compiles — on the compiling thread, waiting for it unless Ctrl-C comes while numba
    compiles (a Ctrl-C that came before, whose caller is finishing its partial result,
    waits for a load from the disk cache: up to :data:`_PATIENCE`)."""
    if threading.current_thread() is not threading.main_thread():
        return          # no Ctrl-C arrives on this thread: the blocks compile as before
    try:
        key = _types(work)
    except (AttributeError, TypeError, ValueError):
        return
    if key in _SEEN:
        return
    if not interrupt_requested():
        _SAID[0] = False
    _start_compiler()
    job = {"call": lambda: work(0, 0), "context": contextvars.copy_context(),
           "done": threading.Event(), "error": None}
    _JOBS.put(job)
    start = time.perf_counter()
    try:
        while not job["done"].wait(0.02):
            # a Ctrl-C held by lagrange_core.progress.defer_ctrl_c (with Python's own
            # handler it raises KeyboardInterrupt in the wait)
            if interrupt_requested() and (
                    _COMPILING[0] or time.perf_counter() - start > _PATIENCE):
                raise KeyboardInterrupt
    except KeyboardInterrupt:
        _say_compiling_on()
        raise
    if job["error"] is not None:
        raise job["error"]
    _SEEN.add(key)


def _say_compiling_on() -> None:
    """Say so, once for a Ctrl-C (a caller that finishes its partial result may give up
    on a second first call)."""
    if _SAID[0]:
        return
    _SAID[0] = True
    try:
        print("lagrange_core: Ctrl-C while numba compiled kernels for first use: stopped "
              "before computing anything; the compilation finishes in the background of "
              "this process (a next call waits for it)", file=sys.stderr, flush=True)
    except (OSError, ValueError):
        pass
