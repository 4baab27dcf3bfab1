"""The LLVM-IR evaluator of symbolic terms (lagrange_core._ir): values and forward-mode
derivatives against symengine's own evaluation and differentiation."""
import numpy as np
import pytest
import symengine as se
import sympy as sp
from numba import njit

import lagrange_core as lc
from lagrange_core import _ir

q0, q1, v0, v1, p0, t = se.symbols("_q0 _q1 _v0 _v1 _p0 t")
STATE = (q0, q1, v0, v1)
# every instruction and both power forms; the point keeps every function real
EXPRS = [
    p0 * se.sin(q0 - q1) * v0**2 - se.cos(q1) / v1,
    se.sqrt(q0**2 + 1) / (v1 - 3) + (q0**2 + 2) ** se.Rational(-1, 2),
    se.atan2(q1, q0) * se.exp(t * v0) + se.log(q0 + 2) ** se.Rational(1, 3),
    se.tan(q0) + se.asin(q1 / 3) + se.acos(q0 / 2) + se.atan(v0 * q1),
    se.sinh(q0) * se.cosh(v1) + se.tanh(q1) + se.asinh(v0) + se.acosh(2 + q0**2)
    + se.atanh(q1 / 2),
    q0**v1 + q0**-3 + se.pi * se.E * q1**5,
]
U = [se.Symbol(f"_u{f}") for f in range(1, len(EXPRS) + 1)]


def _evaluators(values, outputs, n_dof=2):
    """njit functions storing output o at W[o, 0] (and its derivatives in dA)."""
    program = _ir.build_program(values, outputs, n_dof, 1)
    targets = tuple((o, 0, o) for o in range(len(outputs)))
    value, tangent = _ir.value_evaluator(program, targets), _ir.tangent_evaluator(program, targets)

    @njit
    def values_at(y, t, p, W):
        value(y, t, p, W)

    @njit
    def tangents_at(y, t, p, W, dA):
        tangent(y, t, p, W, dA)

    return program, values_at, tangents_at


def _dense_tangents(program, dA, n_state):
    """dA (output by output, over each output's dependencies) as a dense (outputs, n_state)."""
    out = np.zeros((len(program[1]), n_state))
    k = 0
    for o, deps in enumerate(program[2]):
        for j in deps:
            out[o, j] = dA[k]
            k += 1
    assert k == dA.shape[0]
    return out


def test_values_and_derivatives_against_symengine():
    # outputs built from the terms, as the codegen's entries are: _u symbols and the state
    outputs = U + [U[0] * U[1] - q0, se.Integer(0), -U[2]]
    program, values_at, tangents_at = _evaluators(EXPRS, outputs)
    n_tan = sum(len(d) for d in program[2])
    assert program[2][len(EXPRS) + 1] == ()                # the constant has no derivative
    y, p, tt = np.array([0.7, -0.4, 1.3, 0.2]), np.array([1.7]), 0.3
    at = dict(zip(STATE, y, strict=True)) | {p0: p[0], t: tt}
    W = np.full((len(outputs), 1), np.nan)
    values_at(y, tt, p, W)
    W2, dA = np.zeros((len(outputs), 1)), np.zeros(n_tan)
    tangents_at(y, tt, p, W2, dA)
    np.testing.assert_array_equal(W, W2)
    dW = _dense_tangents(program, dA, 4)
    reference = EXPRS + [EXPRS[0] * EXPRS[1] - q0, se.Integer(0), -EXPRS[2]]
    for o, e in enumerate(reference):
        assert W[o, 0] == pytest.approx(float(e.subs(at)), rel=1e-14, abs=1e-15)
        for j, s in enumerate(STATE):
            d = float(e.diff(s).subs(at))
            assert dW[o, j] == pytest.approx(d, rel=1e-13, abs=1e-14), (e, s)


def test_abs_and_sign_are_differentiated_where_the_complex_step_failed():
    program, _, tangents_at = _evaluators([se.Abs(q0) * v0 + se.sign(q1) * q0], U[:1])
    for x, sign in ((-0.5, -1.0), (0.5, 1.0)):
        dA = np.zeros(sum(len(d) for d in program[2]))
        tangents_at(np.array([x, -2.0, 3.0, 0.0]), 0.0, np.ones(1), np.zeros((1, 1)), dA)
        # d/dq0 = sign(q0) v0 + sign(q1); d/dv0 = |q0|; d/dq1 = 0 (sign is flat)
        np.testing.assert_allclose(_dense_tangents(program, dA, 4)[0],
                                   [sign * 3.0 - 1.0, 0.0, abs(x), 0.0], rtol=1e-15)


def test_unsupported_terms_are_named():
    # (Heaviside, the example here until issue 10, compiles now: tests/test_core_functions.py)
    with pytest.raises(ValueError, match="cannot compile 'gamma'.*Rewrite"):
        _ir.build_program([se.sympify(sp.gamma(sp.Symbol("_q0")))], [], 1, 0)
    with pytest.raises(ValueError, match="cannot compile"):
        _ir.build_program([se.I * q0], [], 1, 0)


def test_jacobian_with_quadratic_drag_against_finite_differences():
    """Quadratic air drag Q = −c q̇|q̇| (abs is not analytic: the complex step got it wrong)."""
    (x, y), (xd, yd) = lc.coordinates("x y")
    k, c, b = sp.symbols("k c b")
    system = lc.System([x, y], lagrangian=(xd**2 + yd**2) / 2 + b * x * yd,
                       potential=k * (x**2 + y**2) / 2 + x**3,
                       forces={x: -c * xd * sp.Abs(xd), y: -c * yd * sp.Abs(yd)})
    kern = system.kernels
    p = system.parameter_array({"k": 2.0, "c": 0.3, "b": 0.7})
    J = np.empty((4, 4))
    for state in ([0.4, -0.3, 0.2, -0.1], [-0.4, 0.3, -0.2, 0.5]):
        s = np.array(state)
        assert kern.jacobian(0.0, s, p, J) == 0
        h = 1e-6
        for j in range(4):
            a, b_ = np.empty(4), np.empty(4)
            e = np.zeros(4)
            e[j] = h
            kern.rhs(0.0, s + e, p, a, kern.work_array())
            kern.rhs(0.0, s - e, p, b_, kern.work_array())
            np.testing.assert_allclose(J[:, j], (a - b_) / (2 * h), rtol=1e-7, atol=1e-9)
