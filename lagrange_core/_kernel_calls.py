"""Calling a system's kernels from code compiled once per installation.

Why
---
The integrators (and other generic loops, e.g. Floquet's sampler) are compiled once and
cached by numba for every system.  They cannot name a system's kernels: each system's
are different functions.  So every system exports C entry points of its kernels
(``numba.cfunc``, built by :meth:`lagrange_core.codegen.Kernels.addresses`), and the generic
code receives their *addresses* as a plain ``int64`` array and calls them through the
intrinsics below, which cast the address to the known C signature (``inttoptr``) and
call it.  Typed as ``int64``, the addresses give every system the same machine code
(numba's cache serves it to all), and a call from Python costs no typing of function
objects (numba's first-class function types cost ~1 ms per call to type).

The contract (one row per kernel slot; arrays are C-contiguous float64, passed as their
data pointers; shapes are those of the kernel contract in :mod:`lagrange_core.codegen`)
------------------------------------------------------------------------------------------

====================  =========================================================  ========
slot                  C signature                                                returns
====================  =========================================================  ========
``RHS``               ``rhs(t, y*, p*, dydt*, W*)``                              status
``ENERGY``            ``energy(q*, qd*, t, p*)``                                 h (J)
``RESIDUAL``          ``constraint_residual(q*, qd*, t, p*, out*)``              0
``PHI_Q``             ``constraint_jacobian(q*, t, p*, out*)``                   0
``JACOBIAN``          ``jacobian(t, y*, p*, J*)``                                status
``FAST_ACCEL``        ``fast_accel(q*, t, cs*, p*, out*, Wn*)`` (drive kernel)   status
``DRIVE_RATES``       ``drive_rates(p*, out*)`` (drive kernel)                   count
``FAST_ACCEL_LANES``  ``fast_accel_lanes(q*, t*, cs*, p*, out*, work*, L)``      failures
====================  =========================================================  ========

``fast_accel_lanes`` is ``fast_accel`` for L trajectories in one call (the *lanes* of
:func:`lagrange_core._batch_kernels.grid_rkn_lanes`): every array has the lane as its
last axis — q (n, L), t (L), cs (max(2 N_DRIVE, 1), L), p (N_PARAMETERS, L), out (n, L)
— and ``work`` (1 + n(n + 1), L) is scratch whose row 0 returns each lane's status
(0, or 1: singular mass matrix); the call returns how many lanes failed (row 0 is
meaningful only when that is > 0).  L is an int64.

A slot a caller does not need holds 0 (its cfunc is never compiled).  The wrappers
in the generated modules build arrays of the module's own shapes around the pointers, so
the scratch ``W`` must have exactly the shape ``WORK_SHAPE``.
"""
from __future__ import annotations

from llvmlite import ir
from numba import types
from numba.extending import intrinsic

__all__ = ["SLOTS", "SIGNATURES", "RHS", "ENERGY", "RESIDUAL", "PHI_Q", "JACOBIAN",
           "FAST_ACCEL", "DRIVE_RATES", "FAST_ACCEL_LANES", "MAX_DRIVE_RATES", "call_rhs",
           "call_energy", "call_residual", "call_constraint_jacobian", "call_jacobian",
           "call_fast_accel", "call_drive_rates", "call_fast_accel_lanes"]

#: Kernel slots of the address table, in order.
SLOTS = ("rhs", "energy", "constraint_residual", "constraint_jacobian", "jacobian",
         "fast_accel", "drive_rates", "fast_accel_lanes")
RHS, ENERGY, RESIDUAL, PHI_Q, JACOBIAN, FAST_ACCEL, DRIVE_RATES, FAST_ACCEL_LANES = range(8)
#: how many harmonic rates a drive kernel may have (``drive_rates`` writes that many at most)
MAX_DRIVE_RATES = 64

_P = types.CPointer(types.float64)
_F = types.float64
#: numba signatures of the C entry points, by slot name (the table in the docstring).
SIGNATURES = {
    "rhs": types.int64(_F, _P, _P, _P, _P),
    "energy": types.float64(_P, _P, _F, _P),
    "constraint_residual": types.int64(_P, _P, _F, _P, _P),
    "constraint_jacobian": types.int64(_P, _F, _P, _P),
    "jacobian": types.int64(_F, _P, _P, _P),
    "fast_accel": types.int64(_P, _F, _P, _P, _P, _P),
    "drive_rates": types.int64(_P, _P),
    "fast_accel_lanes": types.int64(_P, _P, _P, _P, _P, _P, types.int64),
}


def _caller(slot_name):
    """An intrinsic ``call(address, *args)`` for the C signature of ``slot_name``.

    Arguments are converted as the signature says: an array becomes its data pointer,
    a scalar is cast to the signature's type (float64, or int64 for a count).
    """
    sig = SIGNATURES[slot_name]

    def typing(address, args):
        if not isinstance(address, types.Integer):
            return None
        for want, got in zip(sig.args, args):
            if isinstance(want, types.CPointer):
                if not (isinstance(got, types.Array) and got.dtype == types.float64):
                    return None
            elif not isinstance(got, (types.Float, types.Integer)):
                return None

        def codegen(context, builder, signature, llargs):
            ll = [context.get_value_type(a) for a in sig.args]
            fnty = ir.FunctionType(context.get_value_type(sig.return_type), ll)
            fn = builder.inttoptr(llargs[0], fnty.as_pointer())
            values = []
            for want, got, value in zip(sig.args, signature.args[1:], llargs[1:]):
                if isinstance(want, types.CPointer):
                    values.append(context.make_array(got)(context, builder, value).data)
                else:
                    values.append(context.cast(builder, value, got, want))
            return builder.call(fn, values)

        return sig.return_type(address, *args), codegen

    # numba's intrinsics need named parameters (no *args): write the typer for this arity
    names = ", ".join(f"a{i}" for i in range(len(sig.args)))
    namespace = {}
    exec(f"def call_{slot_name}(typingctx, address, {names}):\n"
         f"    return typing(address, ({names},))\n", {"typing": typing}, namespace)
    return intrinsic(namespace[f"call_{slot_name}"])


call_rhs = _caller("rhs")
call_energy = _caller("energy")
call_residual = _caller("constraint_residual")
call_constraint_jacobian = _caller("constraint_jacobian")
call_jacobian = _caller("jacobian")
call_fast_accel = _caller("fast_accel")
call_drive_rates = _caller("drive_rates")
call_fast_accel_lanes = _caller("fast_accel_lanes")
