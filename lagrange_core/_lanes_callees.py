"""RKN 12's lanes driver's callees, called by address: their declared signatures.

RKN 12's lanes driver (``_lanes_block``, :func:`lagrange_core._batch_kernels.grid_rkn_lanes`:
every undamped ``kapitza`` measurement) calls the functions of :data:`CALLEES` through the
intrinsics below, by address (:mod:`lagrange_core._native_calls`): the driver's compile
needs only their signatures, declared here, and makes no machine code of theirs.  They
compile on their own — ahead, in a second process (:mod:`lagrange_core._lanes_ahead`), or
from numba's cache — while the driver compiles, and :func:`addresses` gives the driver
their addresses once it has compiled: the second process takes them from the first slot
on (:func:`compile_ahead`), the driver's process from the last back, each taking a slot
by creating its file in a folder of the second process's id, so that none compiles
twice; each process loads from numba's cache what the other compiled.

Linked into the driver, as numba links a callee called directly, they made ~40 % of the
LLVM IR of the driver's compile, and were compiled (or loaded) one after another as its
typing met them: the first undamped ``measure`` took 16.3–17.4 s on empty caches
(2026-11-28, benchmarks/README.md, twenty-second and twenty-third sessions).  Called by
address only, they are compiled without the wrapper through which Python would call them
(``no_cpython_wrapper``; ``pilot_step_quantile`` keeps it, Python calls it too): the ten
in 7.8–9.3 s, not 9.6–11.0 s (2026-11-29, thirtieth session).
"""
from __future__ import annotations

import atexit
import importlib
import os
import shutil
import tempfile
import time
from pathlib import Path

import numpy as np

from . import _background
from ._first_calls import aside
from ._native_calls import native_address, native_caller

__all__ = ["CALLEES", "N_CALLEES", "signature", "callees", "addresses", "NO_CALLS",
           "AHEAD_CODE", "compile_ahead",
           "LANES_BY_LANE", "LANES_RESTORE", "LANES_LOAD", "SINCOS_ROWS", "STAGE_POSITIONS",
           "FAST_ACCEL_ON_LANES", "WEIGHTED_SUMS", "RKN_BAND_EXIT", "PILOT_STEP_QUANTILE",
           "LANES_SAVE",
           "call_lanes_by_lane", "call_lanes_restore", "call_lanes_load", "call_sincos_rows",
           "call_stage_positions",
           "call_fast_accel_on_lanes", "call_weighted_sums", "call_rkn_band_exit",
           "call_pilot_step_quantile", "call_lanes_save"]

#: The driver's callees, one row per slot of :func:`addresses`: (module, function, argument
#: types, return types).  Each type is one token: ``i``/``f`` int64/float64, and a
#: C-contiguous array of ``ndim`` dimensions as ``i``, ``f`` or ``b`` (bool) followed by
#: ``ndim``; no return token is None, several are a tuple.
CALLEES = (
    ("_batch_kernels", "_lanes_by_lane",
     "i1 i1 i i i i f2 f2 f2 f1 f1 f2 f2 f2 i f f f1 f2 f1 f1 f2 f1 f3 f2 f2 f1 i1 f1 i2 f1 i1 "
     "f2 i2 i1 i1 b1 b1 b1 b1 b1 b1 b1 f1 f1 f1 f1 f1 f1 f1 f1 f1 f1 f1 f1 f1 f1 f1 f1 i1 "
     "i1 i1 i1 i1 i1 i1 f2 f2 f2 f2 f2 f2 f3 f2 f2 f2 f2 f2 f2 f2 f3 f2 i2 f2 f2 f2 f2 f1 "
     "f1 f1 f1 f1", "i i"),
    ("_batch_kernels", "_lanes_restore",
     "i1 i i f1 i1 f2 f2 f2 f1 f2 f2 f2 i f2 f2 f3 f2 f2 f2 f2 i f1 f1 f1 f1 f1 f1 f1 f1 "
     "f2 f2 f2 f2 f2 f1 f1 f1 b1 i1 f2 f2 f1 f2 i2 f2 f3 f2", ""),
    ("_batch_kernels", "_lanes_load",
     "i1 i i i f2 f2 f2 f1 f1 f2 f2 f2 i f f f2 f2 f3 f2 f2 f2 f2 i f1 f1 f1 f1 f1 f1 f1 "
     "f1 f2 f2 f2 f2 f2 f1 f1 f1 b1 i1 i1 f2 f3 i2 f2 f2 f1 f2 i2", "i"),
    ("_lane_math", "lane_sincos_rows", "f1 f1 f1 i", ""),
    ("_batch_kernels", "_stage_positions", "i f2 f1 f3 f2 f2 f1 f2 f2 i", ""),
    ("_lane_calls", "fast_accel_on_lanes", "i1 f2 f1 f2 f2 f2 f2 i", "i"),
    ("_batch_kernels", "_weighted_sums", "f1 f1 f1 f1 f3 i f2 i", ""),
    ("_batch_kernels", "_rkn_band_exit", "i1 f f f1 f1 f1 f1 f1 f1 f1 f1 f1 f2 f1 f1 f1 f1",
     "f i i"),
    ("_selection", "pilot_step_quantile", "f1 i", "f i"),
    ("_batch_kernels", "_lanes_save",
     "i f1 i1 f2 f2 f3 f2 f2 f1 f1 f1 f1 f1 f1 f1 f1 b1 i1 f2 i2 f2 f3", ""),
)
(LANES_BY_LANE, LANES_RESTORE, LANES_LOAD, SINCOS_ROWS, STAGE_POSITIONS, FAST_ACCEL_ON_LANES,
 WEIGHTED_SUMS, RKN_BAND_EXIT, PILOT_STEP_QUANTILE, LANES_SAVE) = range(len(CALLEES))
#: how many (the length of the address table)
N_CALLEES = len(CALLEES)

#: The address table of a call that calls no callee (the driver's first call, on an empty
#: span, which compiles it before :func:`addresses` is asked).
NO_CALLS = np.zeros(N_CALLEES, dtype=np.int64)


def _types(tokens: str) -> list:
    from numba.core import types
    scalar = {"i": types.int64, "f": types.float64, "b": types.boolean}
    out = []
    for token in tokens.split():
        kind, ndim = token[0], token[1:]
        out.append(types.Array(scalar[kind], int(ndim), "C") if ndim else scalar[kind])
    return out


def signature(args: str, returns: str = ""):
    """The numba signature that ``args`` and ``returns`` (see :data:`CALLEES`) spell."""
    from numba.core import types
    out = _types(returns)
    result = types.none if not out else (out[0] if len(out) == 1 else types.Tuple(out))
    return result(*_types(args))


def callees():
    """(dispatcher, signature) of :data:`CALLEES`, in slot order."""
    return [(getattr(importlib.import_module(f"lagrange_core.{module}"), name),
             signature(args, returns)) for module, name, args, returns in CALLEES]


#: What a second process runs to compile the callees ahead (:mod:`lagrange_core._lanes_ahead`).
AHEAD_CODE = "from lagrange_core._lanes_callees import compile_ahead\ncompile_ahead()\n"


def _claims(pid: int) -> Path:
    """The folder in which the second process ``pid`` (running :data:`AHEAD_CODE`) and the
    process that started it share out the callees: one empty file per slot taken."""
    return Path(tempfile.gettempdir()) / f"lagrange-core-lanes-callees-{pid}"


def _take(folder: Path, slot: int) -> bool:
    """Whether this process takes ``slot`` (False: the other process took it first)."""
    try:
        folder.mkdir(exist_ok=True)
        os.close(os.open(folder / str(slot), os.O_CREAT | os.O_EXCL | os.O_WRONLY))
    except FileExistsError:
        return False
    except OSError:             # nowhere to share them out: compile it here
        return True
    return True


def compile_ahead() -> None:
    """In the second process: compile (or load) every callee not yet taken, from the first
    slot on; the process that started it takes them from the last back once its driver has
    compiled (:func:`addresses`), and the two meet in the middle."""
    folder = _claims(os.getpid())
    try:
        for slot, (dispatcher, sig) in enumerate(callees()):
            if _take(folder, slot):
                dispatcher.compile(tuple(sig.args))
    finally:
        shutil.rmtree(folder, ignore_errors=True)


def _ahead_process():
    """The running second process this one started to compile the callees, or None."""
    for proc in _background.RUNNING.values():
        if proc.poll() is None and AHEAD_CODE in proc.args[-1]:
            return proc
    return None


def _end_and_remove(partner, folder: Path) -> None:
    """End the second process (if it runs still), then remove its folder of claims."""
    _background.end(partner)
    shutil.rmtree(folder, ignore_errors=True)


def _compiled_addresses() -> np.ndarray:
    """Every callee's address, compiled or loaded here; with a second process compiling them
    ahead (:func:`compile_ahead`), those it has taken are waited for and loaded from numba's
    cache (compiled here after all if it ends without them): each compiles once."""
    pairs = callees()
    partner = _ahead_process()
    if partner is None:
        return np.array([native_address(d, sig) for d, sig in pairs], dtype=np.int64)
    folder = _claims(partner.pid)
    # at exit (a Ctrl-C while they compile: the second process is ended, and this
    # process's compiling thread with it) no folder is left behind
    atexit.register(_end_and_remove, partner, folder)
    found = [0] * len(pairs)
    theirs = []
    for slot in reversed(range(len(pairs))):
        if _take(folder, slot):
            found[slot] = native_address(*pairs[slot])
        else:
            theirs.append(slot)
    for slot in theirs:
        while partner.poll() is None and _background.cold(pairs[slot][0]):
            time.sleep(0.02)
        found[slot] = native_address(*pairs[slot])
    shutil.rmtree(folder, ignore_errors=True)
    return np.array(found, dtype=np.int64)


#: the table :func:`addresses` made (the addresses hold for the process's life)
_ADDRESSES: list = []


def addresses() -> np.ndarray:
    """The callees' addresses (int64, in slot order), each compiled or loaded the first time
    in the process (on the compiling thread, where a Ctrl-C need not wait for it:
    :func:`lagrange_core._first_calls.aside`), shared out with a second process compiling
    them ahead (:func:`compile_ahead`)."""
    if not _ADDRESSES:
        _ADDRESSES[:] = [aside(_compiled_addresses)]
    return _ADDRESSES[0]


def _caller(slot: int):
    module, name, args, returns = CALLEES[slot]
    return native_caller(name.lstrip("_"), signature(args, returns))


call_lanes_by_lane = _caller(LANES_BY_LANE)
call_lanes_restore = _caller(LANES_RESTORE)
call_lanes_load = _caller(LANES_LOAD)
call_sincos_rows = _caller(SINCOS_ROWS)
call_stage_positions = _caller(STAGE_POSITIONS)
call_fast_accel_on_lanes = _caller(FAST_ACCEL_ON_LANES)
call_weighted_sums = _caller(WEIGHTED_SUMS)
call_rkn_band_exit = _caller(RKN_BAND_EXIT)
call_pilot_step_quantile = _caller(PILOT_STEP_QUANTILE)
call_lanes_save = _caller(LANES_SAVE)
