"""A kernel's first call, compiled where Ctrl-C need not wait for numba's compiler.

A numba kernel's first call with new argument types compiles it: tens of seconds on an
empty cache (RKN 12's lanes kernel ~20 s, ``simulate``'s driver ~12 s).  Python cannot
stop that safely: a KeyboardInterrupt raised inside numba's compiler can leave it broken
for the rest of the process ("no compiled object yet for <Library …>" at the next call,
seen 2026-11-28), or land in one of its callbacks and be lost; and where
:func:`lagrange_core.progress.defer_ctrl_c` held the Ctrl-C, the wait was the rest of
the compilation.  So the compilation runs on a thread of its own, while the calling
thread waits and watches for Ctrl-C (:func:`_off_thread`):

* a kernel called directly on the main thread (``simulate``'s drivers, a Floquet point,
  a periodic orbit): :func:`guard`, at the end of each kernel module and of each
  generated one (:func:`lagrange_core.module_store.load_module`), makes its first call
  with new types compile there (no cost to a warm call); a system's C entry points
  (``numba.cfunc``, compiled when made) are made by :func:`aside`;
* a grid kernel, whose blocks run on a pool's threads: :func:`first_call`, from
  :func:`lagrange_core._thread_blocks.run_spans`, calls it first on an empty span (it
  compiles and computes nothing) there.

A Ctrl-C then returns at once (KeyboardInterrupt, before anything was computed, which
the callers turn into their interruption as from a chunk), saying so on stderr; the
compilation finishes on its thread (a daemon: a process that ends does not wait for it),
and a next call waits for it there, as numba compiles one function at a time.

While numba compiles (any compilation in the process, on any thread: numba compiles one
at a time), Python's cyclic collector is paused (:class:`_CollectorPaused`): the
compiler makes millions of short-lived objects, and the collector's passes over them and
over the ~600 000 that sympy and numba keep alive took ~10 % of a compile (a first RKN 12
grid: 35.6 s on average against 32.8 s paused, seven alternated pairs of processes,
2026-11-28, benchmarks/README.md), for ~100 MB more at the peak; it resumes, as it was,
when the outermost compilation ends.

numba's compiler makes thousands of error messages it catches itself, each within
colorama's ``init()`` … ``deinit()``, which replace ``sys.stdout`` and ``sys.stderr`` and
then set back the streams they found: on the compiling thread (or a grid pool's) that set
back a stream the main thread had replaced meanwhile, and a caller's
``contextlib.redirect_stderr`` was undone in the middle of its work (numba issue 3027;
found as a rare "exit 2 without a message" of tests/test_properties_cli.py, its command's
error line gone to the process's stderr).  So numba's calls to them do nothing here
(:func:`_numba_leaves_the_streams_alone`): the messages' text, colours included, is built
without them.
"""
from __future__ import annotations

import contextvars
import functools
import gc
import queue
import sys
import threading
import time

from numba.core import event
from numba.core.compiler_lock import global_compiler_lock
from numba.core.dispatcher import Dispatcher

from .progress import interrupt_requested

__all__ = ["first_call", "guard", "aside", "compiling"]

#: the keys whose first call has been made in this process
_SEEN: set = set()
#: seconds a pending Ctrl-C waits for a first call that is not compiling (loading a
#: compiled kernel from numba's disk cache: a tenth of a second)
_PATIENCE = 1.0
_JOBS: queue.SimpleQueue = queue.SimpleQueue()
_COMPILER: list[threading.Thread] = []
_START = threading.Lock()
#: whether this Ctrl-C's giving up has been said
_SAID = [False]


def _compiler() -> None:
    """The compiling thread: runs each first call it is handed (a daemon: a process that
    ends need not wait for a compilation nobody waits for)."""
    while True:
        job = _JOBS.get()
        try:
            job["result"] = job["context"].run(job["call"])
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
    running on the compiling thread, nested ones included."""

    depth = 0

    def on_start(self, ev):
        if _COMPILER and threading.current_thread() is _COMPILER[0]:
            _Compilations.depth += 1

    def on_end(self, ev):
        if _COMPILER and threading.current_thread() is _COMPILER[0]:
            _Compilations.depth -= 1


event.register("numba:compile", _Compilations())


class _CollectorPaused(event.Listener):
    """Pauses Python's cyclic collector from the start of an outermost compilation to its
    end (a load from numba's disk cache is none), then leaves it as it found it.  numba
    compiles under its global lock, one compilation at a time (nested ones on the same
    thread), so one count serves every thread."""

    depth = 0
    resume = False

    def on_start(self, ev):
        if _CollectorPaused.depth == 0:
            _CollectorPaused.resume = gc.isenabled()
            gc.disable()
        _CollectorPaused.depth += 1

    def on_end(self, ev):           # (numba sends it on an error too)
        _CollectorPaused.depth -= 1
        if _CollectorPaused.depth == 0 and _CollectorPaused.resume:
            gc.enable()


event.register("numba:compile", _CollectorPaused())


def _numba_leaves_the_streams_alone() -> None:
    """numba's calls to colorama's ``init``, ``reinit`` and ``deinit`` (its error messages,
    made on whichever thread compiles) do nothing, for this process: their only effect is
    to replace ``sys.stdout`` and ``sys.stderr`` and set back the streams they found
    (module docstring).  colorama itself is left as it is (another library's ``init`` is
    its own); on Windows, numba's coloured messages (``NUMBA_COLOR_SCHEME``, off by
    default) are then not translated for an old console."""
    from numba.core import errors
    if hasattr(errors, "ColorShell"):       # colorama installed: numba's highlighting on
        errors.init = errors.reinit = errors.deinit = _streams_unchanged


def _streams_unchanged(*args, **kwargs) -> None:
    """colorama's ``init``, ``reinit`` and ``deinit`` as numba's errors module calls them."""


_numba_leaves_the_streams_alone()


def compiling() -> bool:
    """Whether numba compiles a first call on the compiling thread now — one a Ctrl-C
    gave up waiting for: until it ends, any first call waits for it (numba compiles, and
    loads from its cache, one function at a time)."""
    return _Compilations.depth > 0


def first_call(call, key) -> None:
    """Run ``call`` — a kernel's first call with new argument types, made so that it
    computes nothing: it compiles — by :func:`_off_thread`, unless its ``key`` has been
    through (then at once, ~5 µs) or is None (then not at all: the caller's own first call
    compiles)."""
    if key is None or _here() or key in _SEEN:
        return
    _off_thread(call)
    _SEEN.add(key)


def aside(call):
    """``call()`` — work that compiles numba code, such as a system's C entry points
    (``numba.cfunc`` compiles when it is made) — by :func:`_off_thread` when made on the
    main thread; here otherwise."""
    return call() if _here() else _off_thread(call)


def guard(name: str) -> None:
    """Make the first call of each numba kernel that the module ``name`` defines, when it is
    made on the main thread, compile on the compiling thread (:func:`_off_thread`); called
    at the end of each kernel module (``guard(__name__)``).  numba's dispatcher, on a call
    it has no compiled version for, calls its ``_compile_for_args`` (which compiles and
    returns the version, which the dispatcher then calls); this sets that attribute on
    each dispatcher, so a warm call never comes here."""
    for obj in list(vars(sys.modules[name]).values()):
        if (isinstance(obj, Dispatcher) and obj.py_func.__module__ == name
                and "_compile_for_args" not in vars(obj)
                and hasattr(type(obj), "_compile_for_args")):
            obj._compile_for_args = _first_call_of(obj)


def _first_call_of(dispatcher):
    compile_for_args = type(dispatcher)._compile_for_args.__get__(dispatcher)

    @functools.wraps(compile_for_args)
    def first_call_compiled_aside(*args, **kws):
        if _here():
            return compile_for_args(*args, **kws)
        return _off_thread(lambda: compile_for_args(*args, **kws))
    return first_call_compiled_aside


def _here() -> bool:
    """Whether a first call is made where it is: off the main thread (no Ctrl-C arrives
    there), or on it inside numba's compiler (which the compiling thread would wait for)."""
    return (threading.current_thread() is not threading.main_thread()
            or global_compiler_lock.is_locked())


def _off_thread(call):
    """``call()`` on the compiling thread, the calling thread waiting for it unless Ctrl-C
    comes while numba compiles: then KeyboardInterrupt at once, ``call`` going on where it
    is.  A Ctrl-C that came before (its caller finishing a partial result) waits for a load
    from numba's disk cache, up to :data:`_PATIENCE`."""
    if not interrupt_requested():
        _SAID[0] = False
    _start_compiler()
    job = {"call": call, "context": contextvars.copy_context(), "done": threading.Event(),
           "error": None, "result": None}
    _JOBS.put(job)
    start = time.perf_counter()
    try:
        while not job["done"].wait(0.02):
            # a Ctrl-C held by lagrange_core.progress.defer_ctrl_c (with Python's own
            # handler it raises KeyboardInterrupt in the wait)
            if interrupt_requested() and (
                    compiling() or time.perf_counter() - start > _PATIENCE):
                raise KeyboardInterrupt
    except KeyboardInterrupt:
        _say_compiling_on()
        raise
    if job["error"] is not None:
        raise job["error"]
    return job["result"]


def _say_compiling_on() -> None:
    """Say so, once for a Ctrl-C (a caller that finishes its partial result may give up
    on a second first call)."""
    if _SAID[0]:
        return
    _SAID[0] = True
    try:
        print("lagrange_core: Ctrl-C while numba compiled a kernel for its first call: "
              "stopped without waiting for it; the compilation finishes in the background "
              "of this process (a next call waits for it)", file=sys.stderr, flush=True)
    except (OSError, ValueError):
        pass
