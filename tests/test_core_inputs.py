"""Numbers at the engine's entry points (issue 10, item 10): numpy scalars, 0-d arrays and
sympy numbers are accepted; strings, booleans, complex and non-finite values are refused
with the argument's name, the value and the fix (float("0.01") and float(True) would
silently convert them)."""
import numpy as np
import pytest
import sympy as sp

from lagrange_core import problems
from lagrange_core.checks import real_array, real_number

GOOD = dict(m=1.0, l=1.0, g=9.81)


@pytest.fixture(scope="module")
def pendulum():
    return problems.pendulum()


@pytest.mark.parametrize("value", [np.int64(2), np.float32(2.0), np.array(2.0), sp.Float(2.0),
                                   sp.Integer(2), 2, 2.0])
def test_numbers_of_every_kind_are_accepted(pendulum, value):
    p = pendulum.parameter_array({**GOOD, "m": value})
    assert p[pendulum.parameters.index("m")] == 2.0 and p.dtype == float


@pytest.mark.parametrize("value,why", [("2.0", "a string"), (True, "a boolean"),
                                       (np.bool_(True), "a boolean"), (2j, "complex"),
                                       (np.ones(2), "an array of shape"), (None, "NoneType")])
def test_strings_booleans_and_others_are_refused(pendulum, value, why):
    with pytest.raises(ValueError, match=f"parameter 'm' must be a real number.*{why}.*"
                                         r"params=\{'m': 1.0\}"):
        pendulum.parameter_array({**GOOD, "m": value})


@pytest.mark.parametrize("value", [np.nan, np.inf, -np.inf])
def test_non_finite_values_are_refused(pendulum, value):
    with pytest.raises(ValueError, match="parameter 'm' must be finite"):
        pendulum.parameter_array({**GOOD, "m": value})


def test_states_refuse_strings_and_booleans(pendulum):
    with pytest.raises(ValueError, match="q0 must be real numbers.*a string"):
        pendulum.simulate(["0.1"], [0.0], (0, 1), GOOD)
    with pytest.raises(ValueError, match="qdot0 must be real numbers.*a boolean"):
        pendulum.simulate([0.1], [True], (0, 1), GOOD)
    tr = pendulum.simulate(np.float64(0.1), np.array([0.0]), (0, 0.5), GOOD)
    assert tr.q[0, 0] == 0.1


def test_the_helpers_bounds_and_messages():
    assert real_number(np.float32(0.5), "A", unit="m", minimum=0.0) == 0.5
    with pytest.raises(ValueError, match=r"A must be ≥ 0 \(m\), got -0.1"):
        real_number(-0.1, "A", unit="m", minimum=0.0)
    with pytest.raises(ValueError, match=r"omega must be > 0 \(rad/s\), got 0"):
        real_number(0, "omega", unit="rad/s", minimum=0.0, strict=True)
    np.testing.assert_array_equal(real_array([1, np.int8(2)], "x"), [1.0, 2.0])
    assert real_array([], "x").size == 0
    with pytest.raises(ValueError, match="x must be real numbers"):
        real_array(np.array(["a"]), "x")
