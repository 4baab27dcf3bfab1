"""Straight-line evaluation of symbolic terms, emitted directly as LLVM IR.

numba's front end (bytecode analysis, type inference, lowering) costs about
3 ms per arithmetic operation of generated Python source: the ~300 operations
of the 8-link pendulum's terms took 1 s to compile, and their complex-step
variant for the Jacobian 1.5 s more.  Here the terms become a flat *program*
(a tuple of instructions, plain Python data that a generated module stores as a
literal), and a numba ``@intrinsic`` writes its LLVM IR instruction by
instruction, bypassing the front end: the same 300 operations cost a few
milliseconds, plus LLVM's own optimisation.

Two evaluators are made from a program:

* :func:`value_evaluator` stores each output value;
* :func:`tangent_evaluator` also stores its derivatives with respect to every
  state component ``y[j]`` (forward-mode differentiation, exact to rounding).
  Only structurally non-zero derivatives are computed and stored, so a term of
  two coordinates costs two tangent operations, not 2n.  The rules are the
  textbook derivatives (listed in ``_TANGENT_RULES``); ``abs`` and ``sign``
  have derivative ``sign(x)`` and 0 (0 at the kink x = 0), where the complex
  step they replace failed.

Program format
--------------
Register r is the result of instruction r.  Instructions::

    ("y", i)  ("t",)  ("p", i)  ("c", value)          inputs and constants
    ("add" | "sub" | "mul" | "div" | "pow" | "atan2", a, b)
    (name, a)   name in UNARY: neg sqrt exp log sin cos tan asin acos atan
                sinh cosh tanh asinh acosh atanh abs sign

Outputs are registers; output f is stored as value number f + 1 at
``W[N0 + (f + 1) // WIDTH, (f + 1) % WIDTH]`` (value 0, the constant zero, at
``W[N0, 0]``): the value layout of :mod:`lagrange_core._core_kernels`.
"""
from __future__ import annotations

import math

import symengine as se
from llvmlite import ir
from numba import types
from numba.core import cgutils
from numba.core.typing import signature
from numba.extending import intrinsic

UNARY = ("neg", "sqrt", "exp", "log", "sin", "cos", "tan", "asin", "acos", "atan", "sinh",
         "cosh", "tanh", "asinh", "acosh", "atanh", "abs", "sign")
BINARY = ("add", "sub", "mul", "div", "pow", "atan2")
#: Function names a statement may use (symengine's names), mapped to instructions.
_FUNCTIONS = {"sin": "sin", "cos": "cos", "tan": "tan", "log": "log", "asin": "asin",
              "acos": "acos", "atan": "atan", "sinh": "sinh", "cosh": "cosh", "tanh": "tanh",
              "asinh": "asinh", "acosh": "acosh", "atanh": "atanh", "Abs": "abs",
              "sign": "sign"}
SUPPORTED = sorted({"sqrt", "exp", "atan2", "pi", "E", *_FUNCTIONS.values()})


class _ProgramBuilder:
    """Symengine expressions → instructions; identical subexpressions share a register."""

    def __init__(self, inputs):
        self.instructions = []
        self.register = {}           # instruction tuple -> register
        self.inputs = inputs         # symbol name -> input instruction
        self.memo = {}               # expression -> register

    def emit(self, instruction):
        if instruction not in self.register:
            self.register[instruction] = len(self.instructions)
            self.instructions.append(instruction)
        return self.register[instruction]

    def const(self, value):
        return self.emit(("c", float(value)))

    def power(self, base, k):
        """base**k for an integer k, by repeated squaring (exact as numba's integer power)."""
        if k == 0:
            return self.const(1.0)
        result, square, e = None, base, abs(k)
        while e:
            if e & 1:
                result = square if result is None else self.emit(("mul", result, square))
            e >>= 1
            if e:
                square = self.emit(("mul", square, square))
        return self.emit(("div", self.const(1.0), result)) if k < 0 else result

    def __call__(self, expr):
        if expr in self.memo:
            return self.memo[expr]
        kind = type(expr).__name__
        args = expr.args
        if kind == "Symbol":
            name = str(expr)
            if name not in self.inputs:
                raise ValueError(f"internal error: no input for the symbol {name!r}")
            r = self.inputs[name]
        elif expr.is_Number and not expr.is_complex:
            r = self.const(float(expr))
        elif kind == "Pi":
            r = self.const(math.pi)
        elif kind == "Exp1":
            r = self.const(math.e)
        elif kind in ("Add", "Mul"):
            op = "add" if kind == "Add" else "mul"
            # numbers first is symengine's order; fold left to right
            r = self(args[0])
            for a in args[1:]:
                r = self.emit((op, r, self(a)))
        elif kind == "Pow":
            base, e = args
            if type(base).__name__ == "Exp1":
                r = self.emit(("exp", self(e)))
            elif e.is_Integer:
                r = self.power(self(base), int(e))
            elif e == se.Rational(1, 2):
                r = self.emit(("sqrt", self(base)))
            elif e == se.Rational(-1, 2):
                r = self.emit(("div", self.const(1.0), self.emit(("sqrt", self(base)))))
            else:
                r = self.emit(("pow", self(base), self(e)))
        elif kind == "atan2":
            r = self.emit(("atan2", self(args[0]), self(args[1])))
        elif kind in _FUNCTIONS and len(args) == 1:
            r = self.emit((_FUNCTIONS[kind], self(args[0])))
        else:
            name = expr.get_name() if hasattr(expr, "get_name") else kind
            raise ValueError(
                f"cannot compile {name!r} in {str(expr)[:200]}: the kernels support + - * / **, "
                f"the numbers pi and E and the functions {SUPPORTED}. Rewrite the expression "
                "with these.")
        self.memo[expr] = r
        return r


def build_program(exprs, n_dof: int, n_parameters: int, cse: bool = True):
    """Compile expressions in the kernel's local names to ``(instructions, outputs)``.

    ``exprs`` use ``_q{i}``, ``_v{i}`` (the state y = [q, q̇]), ``_p{i}`` and ``t``
    (see ``codegen._Printer``).  Returns plain tuples, printable as a literal.
    """
    inputs = {}
    builder = _ProgramBuilder(inputs)
    for i in range(n_dof):
        inputs[f"_q{i}"] = builder.emit(("y", i))
        inputs[f"_v{i}"] = builder.emit(("y", n_dof + i))
    inputs["t"] = builder.emit(("t",))
    for i in range(n_parameters):
        inputs[f"_p{i}"] = builder.emit(("p", i))
    exprs = [se.sympify(e) for e in exprs]
    replacements, reduced = se.cse(exprs) if exprs and cse else ([], exprs)
    for symbol, e in replacements:
        inputs[str(symbol)] = builder(e)
    outputs = tuple(builder(e) for e in reduced)
    return tuple(builder.instructions), outputs


# -- LLVM emission -------------------------------------------------------------------

_F8 = types.float64


class _Emitter:
    """Writes a program's instructions with an IR builder (values, optionally tangents)."""

    def __init__(self, context, builder):
        self.context = context
        self.b = builder

    def const(self, x):
        return ir.Constant(ir.DoubleType(), float(x))

    def math(self, fn, *args):
        sig = signature(_F8, *([_F8] * len(args)))
        return self.context.get_function(fn, sig)(self.b, args)

    def sign(self, x):
        b = self.b
        zero_or_nan = b.select(b.fcmp_ordered("==", x, x), self.const(0.0), x)   # NaN stays NaN
        negative = b.select(b.fcmp_ordered("<", x, self.const(0.0)), self.const(-1.0), zero_or_nan)
        return b.select(b.fcmp_ordered(">", x, self.const(0.0)), self.const(1.0), negative)

    def value(self, op, a, b):
        B = self.b
        if op == "add":
            return B.fadd(a, b)
        if op == "sub":
            return B.fsub(a, b)
        if op == "mul":
            return B.fmul(a, b)
        if op == "div":
            return B.fdiv(a, b)
        if op == "neg":
            return B.fneg(a)
        if op == "pow":
            return self.math(math.pow, a, b)
        if op == "atan2":
            return self.math(math.atan2, a, b)
        if op == "abs":
            return self.math(math.fabs, a)
        if op == "sign":
            return self.sign(a)
        return self.math(getattr(math, op), a)

    # forward-mode derivatives: tangents are {state index: llvm value}, absent = 0

    def _combine(self, da, sa, db, sb):
        """sa·da + sb·db for tangents da, db and scalars sa, sb (None means 1)."""
        B = self.b
        out = {}
        for d, s in ((da, sa), (db, sb)):
            for k, v in d.items():
                term = v if s is None else B.fmul(s, v)
                out[k] = B.fadd(out[k], term) if k in out else term
        return out

    def tangent(self, op, v, a, b, da, db):
        """Tangent of v = op(a, b) from the operands' tangents."""
        if not da and not db:
            return {}
        B, c = self.b, self.const
        if op == "add":
            return self._combine(da, None, db, None)
        if op == "sub":
            return self._combine(da, None, db, c(-1.0))
        if op == "mul":
            return self._combine(da, b, db, a)
        if op == "div":                    # (da − v db) / b
            inv = B.fdiv(c(1.0), b)
            return self._combine(da, inv, db, B.fneg(B.fmul(v, inv)))
        if op == "pow":                    # v (db log a + b da / a)
            sa = B.fmul(b, self.math(math.pow, a, B.fsub(b, c(1.0)))) if da else None
            sb = B.fmul(v, self.math(math.log, a)) if db else None
            return self._combine(da, sa, db, sb)
        if op == "atan2":                  # (b da − a db) / (a² + b²), v = atan2(a, b)
            r2 = B.fadd(B.fmul(a, a), B.fmul(b, b))
            return self._combine(da, B.fdiv(b, r2), db, B.fdiv(B.fneg(a), r2))
        return self._combine(da, self.derivative(op, v, a), {}, None)

    def derivative(self, op, v, a):
        """d op(a) / da for the unary instructions."""
        B, c = self.b, self.const
        one = c(1.0)
        if op == "neg":
            return c(-1.0)
        if op == "sqrt":
            return B.fdiv(c(0.5), v)
        if op == "exp":
            return v
        if op == "log":
            return B.fdiv(one, a)
        if op == "sin":
            return self.math(math.cos, a)
        if op == "cos":
            return B.fneg(self.math(math.sin, a))
        if op == "tan":
            return B.fadd(one, B.fmul(v, v))
        if op in ("asin", "acos"):
            d = B.fdiv(one, self.math(math.sqrt, B.fsub(one, B.fmul(a, a))))
            return d if op == "asin" else B.fneg(d)
        if op == "atan":
            return B.fdiv(one, B.fadd(one, B.fmul(a, a)))
        if op == "sinh":
            return self.math(math.cosh, a)
        if op == "cosh":
            return self.math(math.sinh, a)
        if op == "tanh":
            return B.fsub(one, B.fmul(v, v))
        if op == "asinh":
            return B.fdiv(one, self.math(math.sqrt, B.fadd(B.fmul(a, a), one)))
        if op == "acosh":
            return B.fdiv(one, self.math(math.sqrt, B.fsub(B.fmul(a, a), one)))
        if op == "atanh":
            return B.fdiv(one, B.fsub(one, B.fmul(a, a)))
        if op == "abs":
            return self.sign(a)
        if op == "sign":
            return c(0.0)
        raise ValueError(f"internal error: no derivative for {op!r}")


def _is_float_array(ty, ndim):
    return isinstance(ty, types.Array) and ty.ndim == ndim and ty.dtype == _F8


def _run(context, builder, instructions, load, tangents):
    """Registers' values (and tangents, if ``tangents``) for the whole program."""
    em = _Emitter(context, builder)
    values, dvalues = [], []
    for ins in instructions:
        op = ins[0]
        d = {}
        if op == "c":
            v = em.const(ins[1])
        elif op in ("y", "t", "p"):
            v = load(ins)
            if op == "y" and tangents:
                d = {ins[1]: em.const(1.0)}
        else:
            a = values[ins[1]]
            b = values[ins[2]] if op in BINARY else None
            v = em.value(op, a, b)
            if tangents:
                da = dvalues[ins[1]]
                db = dvalues[ins[2]] if op in BINARY else {}
                d = em.tangent(op, v, a, b, da, db)
        values.append(v)
        dvalues.append(d)
    return values, dvalues


def _codegen(instructions, outputs, n0, width, tangents):
    def codegen(context, builder, sig, args):
        names = ("y", "t", "p", "W", "dV")
        arrays = {name: (ty, context.make_array(ty)(context, builder, val))
                  for name, ty, val in zip(names, sig.args, args) if name != "t"}
        t_value = context.cast(builder, args[1], sig.args[1], _F8)

        def pointer(name, *index):
            ty, arr = arrays[name]
            return cgutils.get_item_pointer(
                context, builder, ty, arr, [context.get_constant(types.intp, i) for i in index])

        def load(ins):
            return t_value if ins[0] == "t" else builder.load(pointer(ins[0], ins[1]))

        values, dvalues = _run(context, builder, instructions, load, tangents)
        builder.store(ir.Constant(ir.DoubleType(), 0.0), pointer("W", n0, 0))
        for f, r in enumerate(outputs, start=1):
            builder.store(values[r], pointer("W", n0 + f // width, f % width))
            for j, dv in dvalues[r].items():
                builder.store(dv, pointer("dV", f, j))
        return context.get_dummy_value()

    return codegen


def _valid(y, t, p, W):
    return (_is_float_array(y, 1) and isinstance(t, (types.Float, types.Integer))
            and _is_float_array(p, 1) and _is_float_array(W, 2))


def value_evaluator(program, n0: int, width: int):
    """An intrinsic ``evaluate(y, t, p, W)`` storing the program's outputs as values in W."""
    codegen = _codegen(*program, n0, width, tangents=False)

    @intrinsic
    def evaluate(typingctx, y, t, p, W):
        if _valid(y, t, p, W):
            return types.void(y, t, p, W), codegen

    return evaluate


def tangent_evaluator(program, n0: int, width: int):
    """An intrinsic ``evaluate(y, t, p, W, dV)``: the values as :func:`value_evaluator`, and
    ``dV[f, j] = ∂(value f)/∂y[j]`` for the structurally non-zero entries (dV is not
    cleared: pass zeros)."""
    codegen = _codegen(*program, n0, width, tangents=True)

    @intrinsic
    def evaluate(typingctx, y, t, p, W, dV):
        if _valid(y, t, p, W) and _is_float_array(dV, 2):
            return types.void(y, t, p, W, dV), codegen

    return evaluate
