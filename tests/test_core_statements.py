"""Statements the engine gets right (issue 10).

Each physics test checks against something independent of lagrange_core's derivation:
a closed form, sympy.physics.mechanics.LagrangesMethod, or finite differences.

1. a particle whose mass depends on t;
2. linearising about a point off the constraint surface is refused;
11. Abs and sign in a statement are differentiated.
"""
import numpy as np
import pytest
import sympy as sp
from sympy.physics.mechanics import LagrangesMethod, dynamicsymbols

import lagrange_core as lc

_t = dynamicsymbols._t
m, l, g = sp.symbols("m l g", positive=True)


# -- helpers ------------------------------------------------------------------------------

def _to_dynamic(system):
    """The system's coordinates as dynamicsymbols, and the map back to its plain symbols."""
    qs = [dynamicsymbols(name) for name in system.coordinates]
    to_dyn = {s: d for s, d in zip(system.q, qs)}
    to_dyn.update({v: d.diff(_t) for v, d in zip(system.qdot, qs)})
    to_dyn[lc.t] = _t
    to_plain = {d.diff(_t): v for d, v in zip(qs, system.qdot)}
    to_plain.update({d: s for d, s in zip(qs, system.q)})
    return qs, to_dyn, to_plain


def _lagranges_method(system, L):
    """LagrangesMethod on the Lagrangian L (in the system's plain symbols): M, F as functions."""
    qs, to_dyn, to_plain = _to_dynamic(system)
    lm = LagrangesMethod(L.xreplace(to_dyn), qs)
    lm.form_lagranges_equations()
    return _numeric(lm.mass_matrix, system, to_plain), _numeric(lm.forcing, system, to_plain)


def _numeric(matrix, system, to_plain):
    plain = matrix.xreplace(to_plain).xreplace({_t: lc.t})
    args = [*system.q, *system.qdot, lc.t, *system.parameter_symbols]
    f = sp.lambdify(args, plain, "numpy")
    return lambda q, qd, t, p: np.array(f(*q, *qd, t, *p), dtype=float)


def _particle_lagrangian(system):
    """T − V from the system's particles and potential, written out independently."""
    L = -system.potential
    for p in system.particles:
        qs, to_dyn, to_plain = _to_dynamic(system)
        r = [c.xreplace(to_dyn) for c in p.position]
        L += (p.mass * sum(c.diff(_t) ** 2 for c in r) / 2).xreplace(to_dyn)
    _, _, to_plain = _to_dynamic(system)
    return L.xreplace(to_plain).xreplace({_t: lc.t})


def _random_state(system, rng, q_range=(-np.pi, np.pi)):
    n = system.n_dof
    return (rng.uniform(*q_range, n), rng.uniform(-2, 2, n), float(rng.uniform(0, 3)),
            rng.uniform(0.5, 2.0, len(system.parameters)))


def _assert_same_equations(system, M_ref, F_ref, rng, points=5, q_range=(-np.pi, np.pi)):
    """Kernels and the sympy view against reference M, F at random states."""
    n = system.n_dof
    for _ in range(points):
        q, qd, t, p = _random_state(system, rng, q_range)
        M, F = np.empty((n, n)), np.empty(n)
        system.kernels.mass_forcing(q, qd, t, p, M, F)
        M_expected, F_expected = M_ref(q, qd, t, p), F_ref(q, qd, t, p).ravel()
        scale = max(np.abs(M_expected).max(), 1.0)
        np.testing.assert_allclose(M, M_expected, rtol=1e-11, atol=1e-12 * scale)
        np.testing.assert_allclose(F, F_expected, rtol=1e-10,
                                   atol=1e-11 * max(np.abs(F_expected).max(), 1.0))


# -- item 1: a mass that depends on time ------------------------------------------------------

def test_time_dependent_mass_closed_form():
    """m(t) = m0 (1 + a t): d/dt (m ẋ) = 0 gives ẍ = −a ẋ / (1 + a t)."""
    (x,), (x_dot,) = lc.coordinates("x")
    m0, a = sp.symbols("m0 a", positive=True)
    particle = lc.System([x], particles=[lc.Particle(m0 * (1 + a * lc.t), (x,))])
    written_out = lc.System([x], lagrangian=m0 * (1 + a * lc.t) * x_dot**2 / 2)
    params = dict(m0=1.3, a=0.5)
    expected = -0.5 * 2.0 / (1 + 0.5 * 0.3)                 # -0.8696
    for system in (particle, written_out):
        np.testing.assert_allclose(system.accelerations([0.7], [2.0], 0.3, params), [expected],
                                   rtol=1e-14)
    assert expected == pytest.approx(-0.8696, abs=1e-4)
    assert sp.simplify(particle.equations.forcing[0] + a * m0 * x_dot) == 0
    assert not particle.equations.energy_conserved


def test_time_dependent_mass_matches_lagranges_method(rng):
    """A driven double pendulum whose bobs lose mass: M and F against LagrangesMethod."""
    (th1, th2), _ = lc.coordinates("theta1 theta2")
    k, A, w, l1, l2, m1, m2 = sp.symbols("k A omega l1 l2 m1 m2", positive=True)
    x1, y1 = l1 * sp.sin(th1), A * sp.cos(w * lc.t) - l1 * sp.cos(th1)
    x2, y2 = x1 + l2 * sp.sin(th2), y1 - l2 * sp.cos(th2)
    bobs = [lc.Particle(m1 * sp.exp(-k * lc.t), (x1, y1)),
            lc.Particle(m2 / (1 + k * lc.t), (x2, y2))]
    system = lc.System([th1, th2], particles=bobs,
                       potential=g * (bobs[0].mass * y1 + bobs[1].mass * y2))
    M_ref, F_ref = _lagranges_method(system, _particle_lagrangian(system))
    _assert_same_equations(system, M_ref, F_ref, rng)


def test_time_dependent_mass_energy_function(rng):
    """h = Σ q̇ ∂L/∂q̇ − L (kernel) against sympy, and dh/dt = −∂L/∂t along the motion
    (finite differences of the energy kernel with the compiled accelerations)."""
    (th,), (th_dot,) = lc.coordinates("theta")
    k, A, w = sp.symbols("k A omega", positive=True)
    r = (l * sp.sin(th), A * sp.cos(w * lc.t) - l * sp.cos(th))
    mass = m * (1 + k * lc.t)
    system = lc.System([th], particles=[lc.Particle(mass, r)], potential=mass * g * r[1])
    L = _particle_lagrangian(system)
    h_ref = sp.lambdify([th, th_dot, lc.t, *system.parameter_symbols],
                        th_dot * L.diff(th_dot) - L)
    dL_dt = sp.lambdify([th, th_dot, lc.t, *system.parameter_symbols], L.diff(lc.t))
    k_ = system.kernels
    for _ in range(3):
        q, qd, t, p = _random_state(system, rng)
        assert k_.energy(q, qd, t, p) == pytest.approx(h_ref(*q, *qd, t, *p), rel=1e-12)
        eps = 1e-5
        h = []
        for s in (-eps, eps):       # h along the exact motion to second order in s
            qdd = system.accelerations(q, qd, t, dict(zip(system.parameters, p)))
            qs = q + s * qd + s**2 / 2 * qdd
            qds = qd + s * qdd
            h.append(k_.energy(qs, qds, t + s, p))
        # the O(s²) error of the states cancels in the central difference's leading term
        assert (h[1] - h[0]) / (2 * eps) == pytest.approx(-dL_dt(*q, *qd, t, *p), rel=1e-5)


# -- item 2: linearising off the constraint surface --------------------------------------------

def _cartesian_pendulum():
    (x, y), _ = lc.coordinates("x y")
    return lc.System([x, y], particles=[lc.Particle(m, (x, y))], potential=m * g * y,
                     constraints=[x**2 + y**2 - l**2])


@pytest.mark.parametrize("about", [[0.0, -1.0], [1.0, 0.0]])
def test_linearize_about_a_point_that_violates_the_constraints(about):
    """Length 1.1: Φ = x² + y² − l² = 1 − 1.21 = −0.21 at both points."""
    system = _cartesian_pendulum()
    params = dict(m=1.0, l=1.1, g=9.81)
    for method in (system.linearize, system.normal_modes):
        with pytest.raises(ValueError, match=r"violates the constraints.*constraint 0.*"
                                             r"Φ = -0\.21.*satisfy every constraint"):
            method(params, about=about)
    # on the surface it is the pendulum of length 1.1 (closed form √(g/l))
    np.testing.assert_allclose(system.normal_modes(params, about=[0.0, -1.1]),
                               [np.sqrt(9.81 / 1.1)], rtol=1e-12)


def test_linearize_accepts_a_point_on_the_surface_to_rounding():
    system = _cartesian_pendulum()
    theta = 1e-3
    about = [1.1 * np.sin(theta), -1.1 * np.cos(theta)]     # Φ ~ 1e-16, not an equilibrium
    with pytest.raises(ValueError, match="not an equilibrium"):
        system.linearize(dict(m=1.0, l=1.1, g=9.81), about=about)


# -- item 11: statements ---------------------------------------------------------------------

def test_abs_and_sign_are_differentiated():
    """V = k |x| (a V-shaped well): F = −k sign(x); was a Derivative the kernels refused."""
    (x,), (x_dot,) = lc.coordinates("x")
    k = sp.Symbol("k", positive=True)
    system = lc.System([x], lagrangian=x_dot**2 / 2 + sp.Abs(x_dot) * x, potential=k * sp.Abs(x))
    assert sp.simplify(system.equations.forcing[0] - (-k * sp.sign(x))) == 0
    np.testing.assert_allclose(system.accelerations([-0.4], [0.3], 0.0, {"k": 2.0}), [2.0])
