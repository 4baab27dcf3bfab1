"""A numba-compiled function called by the address of its native entry point.

numba links every function a compiled function calls into the caller's LLVM module and
makes machine code for the whole: the caller's compile makes its callees' machine code
again, and it compiles (or loads) each callee when its typing meets the call, one after
another.  Of the LLVM IR that RKN 12's lanes driver compiled, ~40 % was its callees'
(benchmarks/README.md, twenty-third session).  A call by address keeps the callee
out: the caller's compile needs only the callee's signature, declared beside it; the
callee compiles on its own (in another process, or from numba's disk cache) and is
reached at run time through an ``int64`` address, as a system's kernels are
(:mod:`lagrange_core._kernel_calls`), but by numba's own calling convention, so that
the callee stays an ordinary ``@njit`` function (arrays, tuples, its status).

* :func:`native_caller` makes the intrinsic a caller uses: ``call(address, *args)``;
* :func:`native_address` compiles (or loads) the callee for its declared signature and
  returns the address, refusing a callee whose compiled signature is not the declared
  one (a caller would read its results wrongly).
"""
from __future__ import annotations

from numba import types
from numba.core import cgutils
from numba.core.errors import TypingError

from ._kernel_calls import address_intrinsic

__all__ = ["native_caller", "native_address"]


def _same_layout(got, want) -> bool:
    """Whether a value of type ``got`` is passed as ``want`` is: the same data model."""
    if isinstance(want, types.Array):
        return (isinstance(got, types.Array) and got.dtype == want.dtype
                and got.ndim == want.ndim and got.layout == want.layout)
    return isinstance(got, (types.Integer, types.Float, types.Boolean))


def native_caller(name: str, signature):
    """An intrinsic ``call(address, *args)`` calling, at ``address``, the native entry of
    the numba function ``name`` compiled for ``signature`` (a numba signature: return
    type and argument types).

    An array argument must have the declared dtype, dimensions and layout (a typing error
    names the argument otherwise: a different layout would be read wrongly); a scalar is
    cast to the declared type.  The callee's status (an error it raises) reaches the
    caller as from a direct call."""
    def typing(address, args):
        if not isinstance(address, types.Integer):
            return None
        if len(args) != len(signature.args):
            raise TypingError(f"{name} by address: {len(args)} arguments, its declared "
                              f"signature has {len(signature.args)}")
        for k, (got, want) in enumerate(zip(args, signature.args, strict=True)):
            if not _same_layout(got, want):
                raise TypingError(f"{name} by address: argument {k} is {got}, its declared "
                                  f"signature says {want}; pass that, or change the "
                                  "declaration (and the callee) together")

        def codegen(context, builder, sig, llargs):
            fnty = context.call_conv.get_function_type(signature.return_type, signature.args)
            callee = builder.inttoptr(llargs[0], fnty.as_pointer())
            values = [value if isinstance(want, types.Array)
                      else context.cast(builder, value, got, want)
                      for value, got, want in zip(llargs[1:], sig.args[1:], signature.args,
                                                  strict=True)]
            status, result = context.call_conv.call_function(
                builder, callee, signature.return_type, signature.args, values)
            with cgutils.if_unlikely(builder, status.is_error):
                context.call_conv.return_status_propagate(builder, status)
            return result

        return signature.return_type(address, *args), codegen

    return address_intrinsic(f"call_{name}", len(signature.args), typing)


def native_address(dispatcher, signature) -> int:
    """The address of ``dispatcher``'s native entry for ``signature`` (a numba signature),
    compiled now or loaded from numba's cache if it has none yet.

    Raises
    ------
    RuntimeError
        The function compiled for those argument types returns another type than the
        declared one: the declaration (beside the caller) no longer matches the function.
    """
    args = tuple(signature.args)
    if args not in dispatcher.overloads:
        dispatcher.compile(args)
    compiled = dispatcher.overloads[args]
    if compiled.signature.return_type != signature.return_type:
        raise RuntimeError(
            f"{dispatcher.py_func.__qualname__} returns {compiled.signature.return_type}, "
            f"declared {signature.return_type}: change the declaration with the function")
    return compiled.library.get_pointer_to_function(compiled.fndesc.llvm_func_name)
