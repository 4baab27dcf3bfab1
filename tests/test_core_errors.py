"""Bad input gets an error that names the problem and the fix."""
import numpy as np
import pytest
import sympy as sp

import lagrange_core as lc
from lagrange_core import problems

m, l, g = sp.symbols("m l g", positive=True)
(theta, phi), _ = lc.coordinates("theta phi")


def test_particle_that_depends_on_no_coordinate():
    with pytest.raises(ValueError, match="depends on no coordinate.*Write its position"):
        lc.System([theta], particles=[lc.Particle(m, (l * sp.sin(theta), -l)),
                                      lc.Particle(m, (l, 2 * l), "anchor")])


def test_unknown_coordinate_in_forces():
    with pytest.raises(ValueError, match="'psi' is not a coordinate.*\\['theta'\\]"):
        lc.System([theta], particles=[lc.Particle(m, (l * sp.sin(theta), -l * sp.cos(theta)))],
                  forces={"psi": 1.0})


def test_constraint_without_coordinates():
    with pytest.raises(ValueError, match="involves none of the coordinates"):
        lc.System([theta], particles=[lc.Particle(m, (l * sp.sin(theta), -l * sp.cos(theta)))],
                  constraints=[l - 1])


def test_no_kinetic_energy():
    with pytest.raises(ValueError, match="no kinetic energy"):
        lc.System([theta], potential=theta**2)


@pytest.mark.parametrize("params, message", [
    ({"m": 1, "l": 1}, "missing value.*'g'"),
    ({"m": 1, "l": 1, "g": 9.81, "k": 2}, "unknown parameter.*'k'.*\\['g', 'l', 'm'\\]"),
    ({"m": 1, "l": float("nan"), "g": 9.81}, "'l' must be finite"),
    ({"m": 1, "l": "long", "g": 9.81}, "'l' must be a real number"),
])
def test_bad_parameter_values(params, message):
    with pytest.raises(ValueError, match=message):
        problems.pendulum().accelerations([0.1], [0.0], 0.0, params)


def test_wrong_state_size_and_unknown_coordinate_name():
    pend = problems.pendulum()
    with pytest.raises(ValueError, match="q must have 1 entries"):
        pend.accelerations([0.1, 0.2], [0.0], 0.0, dict(m=1, l=1, g=1))
    with pytest.raises(ValueError, match="unknown coordinate.*'phi'"):
        pend.accelerations({"phi": 0.1}, [0.0], 0.0, dict(m=1, l=1, g=1))


def test_singular_mass_matrix_at_the_requested_state():
    """Spherical coordinates: M = diag(m l², m l² sin²θ) is singular at the pole θ = 0."""
    r = (l * sp.sin(theta) * sp.cos(phi), l * sp.sin(theta) * sp.sin(phi), -l * sp.cos(theta))
    sph = lc.System([theta, phi], particles=[lc.Particle(m, r)], potential=m * g * r[2])
    params = dict(m=1.0, l=1.0, g=9.81)
    assert np.all(np.isfinite(sph.accelerations([0.5, 0.0], [0.1, 0.2], 0.0, params)))
    with pytest.raises(ValueError, match="singular at q=\\[0.0, 0.3\\].*regular there"):
        sph.accelerations([0.0, 0.3], [0.1, 0.2], 0.0, params)


def test_unsupported_function_is_named():
    # (Heaviside, the example here until issue 10, compiles now: tests/test_core_functions.py)
    (x,), (x_dot,) = lc.coordinates("x")
    k = sp.Symbol("k")
    with pytest.raises(ValueError, match="cannot compute gamma"):
        lc.System([x], lagrangian=x_dot**2 / 2, potential=k * sp.gamma(x) * x)


def test_bad_coordinates():
    with pytest.raises(TypeError, match="lagrange_core.coordinates"):
        lc.System([1.5], lagrangian=0)
    with pytest.raises(ValueError, match="distinct"):
        lc.System([theta, theta], lagrangian=sp.Symbol("theta_dot") ** 2)
