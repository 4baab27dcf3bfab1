"""Derived equations against an independent method: sympy.physics.mechanics.LagrangesMethod.

LagrangesMethod differentiates the whole Lagrangian; lagrange_core assembles M
and F from the particles' Jacobians.  Both are evaluated at random states and
parameter values and must agree to rounding error.
"""
import numpy as np
import pytest
import sympy as sp
from sympy.physics.mechanics import LagrangesMethod, dynamicsymbols

import lagrange_core as lc
from lagrange_core import problems

_t = dynamicsymbols._t


def _reference(system, hol_coneqs=()):
    """LagrangesMethod on the same statement, with q(t) dynamicsymbols.

    Returns (lm, subs_to_plain) where subs_to_plain maps q(t), q'(t) and t to the
    system's plain symbols.
    """
    qs = [dynamicsymbols(name) for name in system.coordinates]
    to_dyn = {s: d for s, d in zip(system.q, qs, strict=True)}
    to_dyn[lc.t] = _t
    L = -system.potential.xreplace(to_dyn)
    for p in system.particles:
        r = [c.xreplace(to_dyn) for c in p.position]
        L += p.mass * sum(c.diff(_t) ** 2 for c in r) / 2
    lm = LagrangesMethod(L, qs, hol_coneqs=[c.xreplace(to_dyn) for c in hol_coneqs])
    lm.form_lagranges_equations()
    to_plain = {d.diff(_t): v for d, v in zip(qs, system.qdot, strict=True)}
    to_plain.update({d: s for d, s in zip(qs, system.q, strict=True)})
    return lm, to_plain


def _random_point(system, rng):
    n = system.n_dof
    q = rng.uniform(-np.pi, np.pi, n)
    qd = rng.uniform(-2, 2, n)
    params = {name: rng.uniform(0.5, 2.0) for name in system.parameters}
    return q, qd, float(rng.uniform(0, 3)), params


def _numeric(expr_matrix, system, to_plain):
    plain = expr_matrix.xreplace(to_plain).xreplace({_t: lc.t})
    args = [*system.q, *system.qdot, lc.t, *system.parameter_symbols]
    return sp.lambdify(args, plain, "numpy")


def _evaluate(f, system, q, qd, t, params):
    return np.array(f(*q, *qd, t, *[params[n] for n in system.parameters]), dtype=float)


CASES = {
    "pendulum": problems.pendulum,
    "double pendulum": problems.double_pendulum,
    "4-link pendulum": lambda: problems.n_link_pendulum(4),
    "vertically driven pendulum": problems.driven_pendulum,
    "horizontally driven pendulum": lambda: problems.driven_pendulum("horizontal"),
}


@pytest.mark.parametrize("name", CASES)
def test_mass_matrix_and_forcing_match_lagranges_method(name, rng):
    system = CASES[name]()
    lm, to_plain = _reference(system)
    M_ref = _numeric(lm.mass_matrix, system, to_plain)
    F_ref = _numeric(lm.forcing, system, to_plain)
    n = system.n_dof
    for _ in range(5):
        q, qd, t, params = _random_point(system, rng)
        M = np.empty((n, n))
        F = np.empty(n)
        system.kernels.mass_forcing(q, qd, t, system.parameter_array(params), M, F)
        M_expected = _evaluate(M_ref, system, q, qd, t, params)
        F_expected = _evaluate(F_ref, system, q, qd, t, params).ravel()
        scale = max(np.abs(M_expected).max(), 1.0)
        np.testing.assert_allclose(M, M_expected, rtol=1e-12, atol=1e-12 * scale)
        np.testing.assert_allclose(F, F_expected, rtol=1e-11, atol=1e-11 * np.abs(F_expected).max())
        # the symbolic result agrees too (it is what users read)
        sub = {**dict(zip(system.q, q, strict=True)), **dict(zip(system.qdot, qd, strict=True)),
               lc.t: t, **{s: params[s.name] for s in system.parameter_symbols}}
        np.testing.assert_allclose(np.array(system.equations.mass_matrix.xreplace(sub), float), M,
                                   rtol=1e-12, atol=1e-12 * scale)


def test_constrained_cartesian_pendulum_matches_lagranges_method(rng):
    """Pendulum stated in x, y with x² + y² = l²: accelerations and the multiplier."""
    (x, y), _ = lc.coordinates("x y")
    m, l, g = sp.symbols("m l g", positive=True)
    system = lc.System([x, y], particles=[lc.Particle(m, (x, y))], potential=m * g * y,
                       constraints=[x**2 + y**2 - l**2])
    lm, to_plain = _reference(system, hol_coneqs=system.constraints)
    MM = _numeric(lm.mass_matrix_full, system, to_plain)
    FF = _numeric(lm.forcing_full, system, to_plain)
    for _ in range(5):
        params = {"m": rng.uniform(0.5, 2), "l": rng.uniform(0.5, 2), "g": 9.81}
        theta, w = rng.uniform(-3, 3), rng.uniform(-2, 2)
        L = params["l"]
        q = np.array([L * np.sin(theta), -L * np.cos(theta)])
        qd = w * np.array([L * np.cos(theta), L * np.sin(theta)])
        qdd, lam = system.accelerations(q, qd, 0.0, params)
        sol = np.linalg.solve(_evaluate(MM, system, q, qd, 0.0, params),
                              _evaluate(FF, system, q, qd, 0.0, params).ravel())
        np.testing.assert_allclose(qdd, sol[2:4], rtol=1e-12, atol=1e-12)
        np.testing.assert_allclose(lam, sol[4:], rtol=1e-12)
        # closed form: the rod tension T = m (g cos θ + l θ̇²) pulls the bob towards the pivot;
        # the constraint force Φ_qᵀλ = 2λ (x, y) has magnitude 2|λ| l.
        tension = params["m"] * (params["g"] * np.cos(theta) + L * w**2)
        np.testing.assert_allclose(-2 * lam[0] * L, tension, rtol=1e-12)


def test_driven_pendulum_matches_the_conventions_of_physics_md(rng):
    """θ̈ = −γ θ̇ − (g − A ω² cos ωt) sin θ / l (shared/PHYSICS.md)."""
    system = problems.driven_pendulum(damping=True)
    for _ in range(5):
        q, qd, t, params = _random_point(system, rng)
        expected = (-params["gamma"] * qd[0] - (params["g"] - params["A"] * params["omega"] ** 2
                    * np.cos(params["omega"] * t)) * np.sin(q[0]) / params["l"])
        np.testing.assert_allclose(system.accelerations(q, qd, t, params), [expected], rtol=1e-12)


def test_energy_function_and_first_integrals():
    (r, phi), (r_dot, phi_dot) = lc.coordinates("r phi")
    m, k = sp.symbols("m k", positive=True)
    kepler = lc.System([r, phi], particles=[lc.Particle(m, (r * sp.cos(phi), r * sp.sin(phi)))],
                       potential=-k / r)
    eq = kepler.equations
    assert eq.energy_conserved
    assert set(eq.conserved_momenta) == {"phi"}
    assert sp.simplify(eq.conserved_momenta["phi"] - m * r**2 * phi_dot) == 0
    assert sp.simplify(eq.energy - (m * (r_dot**2 + r**2 * phi_dot**2) / 2 - k / r)) == 0

    assert problems.pendulum().equations.energy_conserved
    assert not problems.driven_pendulum().equations.energy_conserved      # explicit t
    assert not problems.driven_pendulum("vertical", damping=True).equations.energy_conserved
    # the driven pendulum's energy function is h = T - V minus the pivot's ½ m |ṙ_p|² term
    theta, = problems.driven_pendulum().q
    assert problems.driven_pendulum().equations.conserved_momenta == {}


def test_explicit_lagrangian_harmonic_oscillator():
    (x,), (x_dot,) = lc.coordinates("x")
    m, k = sp.symbols("m k", positive=True)
    osc = lc.System([x], lagrangian=m * x_dot**2 / 2 - k * x**2 / 2)
    assert osc.parameters == ("k", "m")
    np.testing.assert_allclose(osc.accelerations([0.3], [1.0], 0.0, {"m": 2.0, "k": 8.0}), [-1.2])
    np.testing.assert_allclose(osc.normal_modes({"m": 2.0, "k": 8.0}), [2.0])
    h = osc.kernels.energy(np.array([0.3]), np.array([1.0]), 0.0, np.array([8.0, 2.0]))
    assert h == pytest.approx(0.5 * 2.0 * 1.0 + 0.5 * 8.0 * 0.09, rel=1e-14)


def test_dynamicsymbols_are_accepted():
    th = dynamicsymbols("theta")
    m, l, g = sp.symbols("m l g", positive=True)
    system = lc.System([th], particles=[lc.Particle(m, (l * sp.sin(th), -l * sp.cos(th)))],
                       potential=-m * g * l * sp.cos(th),
                       dissipation=sp.Symbol("c") * th.diff(_t) ** 2 / 2)
    assert system.coordinates == ("theta",)
    assert system.parameters == ("c", "g", "l", "m")
    qdd = system.accelerations([0.5], [1.0], 0.0, dict(m=1.0, l=2.0, g=9.81, c=0.4))
    np.testing.assert_allclose(qdd, [-9.81 / 2 * np.sin(0.5) - 0.4 * 1.0 / 4.0], rtol=1e-13)


class TestNormalModes:
    def test_pendulum(self):
        np.testing.assert_allclose(problems.pendulum().normal_modes(dict(m=1, l=2.0, g=9.81)),
                                   [np.sqrt(9.81 / 2.0)], rtol=1e-13)

    def test_double_pendulum_equal_masses_and_lengths(self):
        g, l = 9.81, 0.7
        w = problems.double_pendulum().normal_modes(dict(m1=1.5, m2=1.5, l1=l, l2=l, g=g))
        np.testing.assert_allclose(w**2, [g / l * (2 - np.sqrt(2)), g / l * (2 + np.sqrt(2))],
                                   rtol=1e-12)

    def test_inverted_pendulum_is_unstable(self):
        system = problems.pendulum()
        lin = system.linearize(dict(m=1, l=1, g=9.81), about=[np.pi])
        np.testing.assert_allclose(lin.omega_squared, [-9.81], rtol=1e-12)
        assert not lin.stable
        with pytest.raises(ValueError, match="unstable"):
            system.normal_modes(dict(m=1, l=1, g=9.81), about=[np.pi])

    def test_constrained_form_gives_the_pendulum_frequency(self):
        (x, y), _ = lc.coordinates("x y")
        m, l, g = sp.symbols("m l g", positive=True)
        system = lc.System([x, y], particles=[lc.Particle(m, (x, y))], potential=m * g * y,
                           constraints=[x**2 + y**2 - l**2])
        w = system.normal_modes(dict(m=1.0, l=2.0, g=9.81), about={"y": -2.0})
        np.testing.assert_allclose(w, [np.sqrt(9.81 / 2.0)], rtol=1e-12)

    def test_not_an_equilibrium(self):
        with pytest.raises(ValueError, match="not an equilibrium"):
            problems.pendulum().linearize(dict(m=1, l=1, g=9.81), about=[0.3])
