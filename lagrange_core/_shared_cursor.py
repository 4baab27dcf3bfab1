"""A cursor that several threads' compiled kernels take points from: the lanes drivers'
work sharing.

The lanes drivers (RKN 12's ``lagrange_core._batch_kernels._lanes_block`` and DOP853's
``lagrange_core._first_order_lanes._block``) run one call's points on every thread at
once.  Split into fixed blocks, the threads ended a call up to ~9 ms apart on the 2-core
machine of benchmarks/README.md (the two vCPUs do not run at the same speed, and a block
lasts as long as its slowest points): one core idle for 4 % of the 64 × 64 grid.  Instead
every thread's free lane takes the next point from one shared ``cursor`` (an int64 array
of one element, the index of the next point in the call's list), so the faster thread
takes more points and both run out of points together.

:func:`take` is an atomic fetch-and-add (LLVM's ``atomicrmw add``, "monotonic": the
cursor orders nothing else; every point's data is written by the one thread that took
it and read by the caller only after the pool's threads have joined).  :func:`peek`
reads the cursor atomically, so the compiler cannot keep it in a register across the
loop that polls it.  Both compile into their caller (numba intrinsics): cached with it,
no call.
"""
from __future__ import annotations

from numba import types
from numba.core import cgutils
from numba.extending import intrinsic

__all__ = ["take", "peek"]


def _cursor_pointer(context, builder, signature, args):
    array = context.make_array(signature.args[0])(context, builder, args[0])
    return cgutils.get_item_pointer(context, builder, signature.args[0], array,
                                    [context.get_constant(types.intp, 0)])


def _is_cursor(cursor) -> bool:
    return (isinstance(cursor, types.Array) and cursor.dtype == types.int64
            and cursor.ndim == 1)


@intrinsic
def take(typingctx, cursor):
    """``cursor[0]``, and ``cursor[0] += 1``, atomically: the index of the point the
    calling thread takes (≥ the end of the list: none is left)."""
    if not _is_cursor(cursor):
        return None

    def codegen(context, builder, signature, args):
        pointer = _cursor_pointer(context, builder, signature, args)
        return builder.atomic_rmw("add", pointer, context.get_constant(types.int64, 1),
                                  "monotonic")

    return types.int64(cursor), codegen


@intrinsic
def peek(typingctx, cursor):
    """``cursor[0]``, read atomically (another thread may be taking points)."""
    if not _is_cursor(cursor):
        return None

    def codegen(context, builder, signature, args):
        pointer = _cursor_pointer(context, builder, signature, args)
        return builder.load_atomic(pointer, "monotonic", 8)

    return types.int64(cursor), codegen
