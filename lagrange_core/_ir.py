"""Straight-line evaluation of symbolic terms, emitted directly as LLVM IR.

numba's front end (bytecode analysis, type inference, lowering) costs about
3 ms per arithmetic operation of generated Python source: the ~300 operations
of the 8-link pendulum's terms took 1 s to compile.  Here the terms become a flat *program*
(a tuple of instructions, plain Python data that a generated module stores as a
literal), and a numba ``@intrinsic`` writes its LLVM IR instruction by
instruction, bypassing the front end: the same 300 operations cost a few
milliseconds, plus LLVM's own optimisation.

A program computes the distinct terms of a system and, from them, its
*outputs* (the entries of the augmented matrix [[M, −Φ_qᵀ, F], [Φ_q, 0, γ]]).
Two evaluators are made from it:

* :func:`value_evaluator` stores outputs at given places of an array;
* :func:`tangent_evaluator` also stores their derivatives with respect to the
  state components ``y[j]`` (forward-mode differentiation, exact to rounding).
  Only structurally non-zero derivatives are computed and stored, so a term of
  two coordinates costs two tangent operations, not 2n.  The rules are the
  textbook derivatives (``_Emitter.tangent`` and ``_Emitter.derivative``);
  ``abs`` and ``sign`` have derivatives ``sign(x)`` and 0 (0 at the kink
  x = 0).

Program format
--------------
Register r is the result of instruction r.  Instructions::

    ("y", i)  ("t",)  ("p", i)  ("c", value)          inputs and constants
    ("add" | "mul" | "div" | "pow" | "atan2" | "max" | "min", a, b)
    (name, a)   name in UNARY: sqrt exp log sin cos tan asin acos atan
                sinh cosh tanh asinh acosh atanh abs sign not
    ("heaviside", a, h0)                                 1 (a > 0), 0 (a < 0), h0 (a = 0)
    ("lt" | "le" | "eq" | "ne" | "and" | "or", a, b)    conditions: 1.0 true, 0.0 false
    ("select", c, a, b)                                  a where c is true, else b

Piecewise((e1, c1), (e2, c2), ...) becomes nested selects (NaN where no condition holds).
The derivatives of max, min and select are those of the operand they pick; steps
(sign, heaviside) and conditions have derivative 0 (everywhere but at the jump, where
the kernels, which evaluate pointwise, take 0 too).

(a − b is a + (−1)·b: LLVM folds it into one subtraction, exactly.)

A program is ``(instructions, output registers, output dependencies)``
(:func:`build_program`).
"""
from __future__ import annotations

import math

import symengine as se
from llvmlite import ir
from numba import types
from numba.core import cgutils
from numba.core.typing import signature
from numba.extending import intrinsic

UNARY = ("sqrt", "exp", "log", "sin", "cos", "tan", "asin", "acos", "atan", "sinh",
         "cosh", "tanh", "asinh", "acosh", "atanh", "abs", "sign", "not")
BINARY = ("add", "mul", "div", "pow", "atan2", "max", "min", "heaviside",
          "lt", "le", "eq", "ne", "and", "or")
#: conditions are 1.0 (true) or 0.0; ("select", c, a, b) is a where c is true, else b
TERNARY = ("select",)
#: instructions whose derivative is zero wherever it exists (steps and conditions)
_FLAT = ("sign", "heaviside", "lt", "le", "eq", "ne", "and", "or", "not")
_RELATIONS = {"StrictLessThan": "lt", "LessThan": "le", "Equality": "eq", "Unequality": "ne"}
#: Function names a statement may use (symengine's names), mapped to instructions.
_FUNCTIONS = {"sin": "sin", "cos": "cos", "tan": "tan", "log": "log", "asin": "asin",
              "acos": "acos", "atan": "atan", "sinh": "sinh", "cosh": "cosh", "tanh": "tanh",
              "asinh": "asinh", "acosh": "acosh", "atanh": "atanh", "Abs": "abs",
              "sign": "sign"}
SUPPORTED = sorted({"sqrt", "exp", "atan2", "pi", "E", "Max", "Min", "Heaviside", "Piecewise",
                    *_FUNCTIONS.values()})


class _ProgramBuilder:
    """Symengine expressions → instructions; identical subexpressions share a register."""

    def __init__(self, inputs):
        self.instructions = []
        self.register = {}           # instruction tuple -> register
        self.inputs = inputs         # symbol name -> register
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
        elif kind in ("Max", "Min"):
            op = kind.lower()
            r = self(args[0])
            for a in args[1:]:
                r = self.emit((op, r, self(a)))
        elif kind in _RELATIONS:
            r = self.emit((_RELATIONS[kind], self(args[0]), self(args[1])))
        elif kind in ("And", "Or"):
            r = self(args[0])
            for a in args[1:]:
                r = self.emit((kind.lower(), r, self(a)))
        elif kind == "Not":
            r = self.emit(("not", self(args[0])))
        elif kind in ("BooleanTrue", "BooleanFalse"):
            r = self.const(1.0 if kind == "BooleanTrue" else 0.0)
        elif kind == "Piecewise":
            # (e1, c1, e2, c2, ...): the first true condition wins; none true: NaN
            r = self.const(math.nan)
            for e, cond in reversed(list(zip(args[0::2], args[1::2]))):
                r = self.emit(("select", self(cond), self(e), r))
        elif hasattr(expr, "get_name") and expr.get_name() == "Heaviside":
            h0 = args[1] if len(args) > 1 else se.Rational(1, 2)
            r = self.emit(("heaviside", self(args[0]), self(h0)))
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


def build_program(values, outputs, n_dof: int, n_parameters: int, cse: bool = True,
                  definitions=()):
    """Compile the distinct terms and the outputs built from them into a program.

    Parameters
    ----------
    values : list of symengine expressions
        The distinct terms, in the kernel's local names: ``_q{i}``, ``_v{i}`` (the state
        y = [q, q̇]), ``_p{i}`` and ``t`` (see ``codegen._Printer``).  Common
        subexpressions are removed across all of them; term f (from 1) is then the
        symbol ``_u{f}``.
    outputs : list of symengine expressions
        In the symbols ``_u{f}`` and ``definitions`` (and the locals above).
    definitions : sequence of (symbol, expression)
        Intermediate results shared between outputs, in evaluation order.

    Returns
    -------
    (instructions, output registers, output dependencies)
        Plain tuples, printable as a literal.  The dependencies of an output are the
        state indices j its derivative ∂/∂y[j] is structurally non-zero for: the
        tangent evaluator stores exactly these, in this order.
    """
    inputs = {}
    builder = _ProgramBuilder(inputs)
    for i in range(n_dof):
        inputs[f"_q{i}"] = builder.emit(("y", i))
        inputs[f"_v{i}"] = builder.emit(("y", n_dof + i))
    inputs["t"] = builder.emit(("t",))
    for i in range(n_parameters):
        inputs[f"_p{i}"] = builder.emit(("p", i))
    values = [se.sympify(e) for e in values]
    replacements, reduced = se.cse(values) if values and cse else ([], values)
    for symbol, e in replacements:
        inputs[str(symbol)] = builder(e)
    for f, e in enumerate(reduced, start=1):
        inputs[f"_u{f}"] = builder(e)
    for symbol, e in definitions:
        inputs[str(symbol)] = builder(se.sympify(e))
    registers = tuple(builder(se.sympify(e)) for e in outputs)
    instructions = tuple(builder.instructions)
    deps = []
    for ins in instructions:
        if ins[0] == "y":
            deps.append(frozenset([ins[1]]))
        elif ins[0] in ("t", "p", "c", *_FLAT):
            deps.append(frozenset())
        elif ins[0] == "select":                 # the condition carries no derivative
            deps.append(deps[ins[2]] | deps[ins[3]])
        else:
            deps.append(frozenset().union(*(deps[a] for a in ins[1:])))
    return instructions, registers, tuple(tuple(sorted(deps[r])) for r in registers)


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

    def truth(self, x):
        """An LLVM i1: condition value x (1.0 or 0.0) is true."""
        return self.b.fcmp_unordered("!=", x, self.const(0.0))

    def boolean(self, bit):
        return self.b.uitofp(bit, ir.DoubleType())

    def value(self, op, a, b, c=None):
        B = self.b
        if op == "select":
            return B.select(self.truth(a), b, c)
        if op in ("max", "min"):
            # NaN in, NaN out (a + b is NaN then); else the larger / smaller
            pick = B.select(B.fcmp_ordered(">=" if op == "max" else "<=", a, b), a, b)
            return B.select(B.fcmp_unordered("uno", a, b), B.fadd(a, b), pick)
        if op in ("lt", "le", "eq", "ne"):
            cmp = {"lt": "<", "le": "<=", "eq": "==", "ne": "!="}[op]
            bit = (B.fcmp_unordered(cmp, a, b) if op == "ne" else B.fcmp_ordered(cmp, a, b))
            return self.boolean(bit)
        if op in ("and", "or"):
            bit = (B.and_ if op == "and" else B.or_)(self.truth(a), self.truth(b))
            return self.boolean(bit)
        if op == "not":
            return self.boolean(B.not_(self.truth(a)))
        if op == "heaviside":              # 1 for a > 0, 0 for a < 0, b at 0, NaN stays NaN
            at_zero = B.select(B.fcmp_ordered("==", a, a), b, a)
            below = B.select(B.fcmp_ordered("<", a, self.const(0.0)), self.const(0.0), at_zero)
            return B.select(B.fcmp_ordered(">", a, self.const(0.0)), self.const(1.0), below)
        if op == "add":
            return B.fadd(a, b)
        if op == "mul":
            return B.fmul(a, b)
        if op == "div":
            return B.fdiv(a, b)
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

    def _choose(self, bit, da, db):
        """The tangent da where ``bit`` is true, else db (per state index)."""
        zero = self.const(0.0)
        return {k: self.b.select(bit, da.get(k, zero), db.get(k, zero)) for k in {*da, *db}}

    def tangent(self, op, v, a, b, da, db, cond=None):
        """Tangent of v = op(a, b) from the operands' tangents (``select``: v = a or b by
        the value ``cond``; max and min: the tangent of the operand they pick)."""
        if (not da and not db) or op in _FLAT:
            return {}
        B, c = self.b, self.const
        if op == "select":
            return self._choose(self.truth(cond), da, db)
        if op in ("max", "min"):
            return self._choose(B.fcmp_ordered(">=" if op == "max" else "<=", a, b), da, db)
        if op == "add":
            return self._combine(da, None, db, None)
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
        elif op in TERNARY:                 # select(c, a, b)
            cond, a, b = (values[i] for i in ins[1:])
            v = em.value(op, cond, a, b)
            if tangents:
                d = em.tangent(op, v, a, b, dvalues[ins[2]], dvalues[ins[3]], cond)
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


def _codegen(program, targets, tangents, n_dof=None):
    """The intrinsic's code: arguments (y, t, p, W[, dA]), or (q, qd, t, p, W) if n_dof."""
    instructions, registers, deps = program

    def codegen(context, builder, sig, args):
        if n_dof is None:
            names = ("y", "t", "p", "W", "dA")
        else:
            names = ("q", "qd", "t", "p", "W")
        arrays = {name: (ty, context.make_array(ty)(context, builder, val))
                  for name, ty, val in zip(names, sig.args, args) if name != "t"}
        it = names.index("t")
        t_value = context.cast(builder, args[it], sig.args[it], _F8)
        intp = context.get_value_type(types.intp)
        strides = {name: cgutils.unpack_tuple(builder, arr.strides, ty.ndim)
                   for name, (ty, arr) in arrays.items()}
        base = {name: builder.bitcast(arr.data, ir.IntType(8).as_pointer())
                for name, (ty, arr) in arrays.items()}

        def pointer(name, *index):
            # byte offset Σ index·stride: valid for any layout, and constant-folded by LLVM
            offset = None
            for i, stride in zip(index, strides[name]):
                term = builder.mul(ir.Constant(intp, i), stride)
                offset = term if offset is None else builder.add(offset, term)
            return builder.bitcast(builder.gep(base[name], [offset]), ir.DoubleType().as_pointer())

        def load(ins):
            if ins[0] == "t":
                return t_value
            if ins[0] == "y" and n_dof is not None:      # y = [q, q̇]
                i = ins[1]
                return builder.load(pointer("q", i) if i < n_dof else pointer("qd", i - n_dof))
            return builder.load(pointer(ins[0], ins[1]))

        values, dvalues = _run(context, builder, instructions, load, tangents)
        for row, col, out in targets:
            builder.store(values[registers[out]], pointer("W", row, col))
        if tangents:
            zero = ir.Constant(ir.DoubleType(), 0.0)
            k = 0
            for r, js in zip(registers, deps):
                for j in js:
                    builder.store(dvalues[r].get(j, zero), pointer("dA", k))
                    k += 1
        return context.get_dummy_value()

    return codegen


def _valid(y, t, p, W):
    return (_is_float_array(y, 1) and isinstance(t, (types.Float, types.Integer))
            and _is_float_array(p, 1) and _is_float_array(W, 2) and W.mutable)


def value_evaluator(program, targets, n_dof=None):
    """An intrinsic ``evaluate(y, t, p, W)`` that stores ``W[row, col]`` = output ``out``
    for each ``(row, col, out)`` of ``targets``; with ``n_dof``, ``evaluate(q, qd, t, p, W)``
    taking the state as its two halves."""
    codegen = _codegen(program, targets, False, n_dof)
    if n_dof is None:
        @intrinsic
        def evaluate(typingctx, y, t, p, W):
            if _valid(y, t, p, W):
                return types.void(y, t, p, W), codegen
    else:
        @intrinsic
        def evaluate(typingctx, q, qd, t, p, W):
            if _valid(q, t, p, W) and _is_float_array(qd, 1):
                return types.void(q, qd, t, p, W), codegen
    return evaluate


def tangent_evaluator(program, targets):
    """An intrinsic ``evaluate(y, t, p, W, dA)``: W as :func:`value_evaluator`, and in
    ``dA`` (1-D) the derivatives ∂(output o)/∂y[j] for o in order and j in the output's
    dependencies (``program[2][o]``)."""
    codegen = _codegen(program, targets, True)

    @intrinsic
    def evaluate(typingctx, y, t, p, W, dA):
        if _valid(y, t, p, W) and _is_float_array(dA, 1) and dA.mutable:
            return types.void(y, t, p, W, dA), codegen

    return evaluate
