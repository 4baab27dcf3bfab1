"""Statements the engine gets right (issue 10, items 1, 2, 11 and 12).

Each physics test checks against something independent of lagrange_core's derivation:
a closed form, sympy.physics.mechanics.LagrangesMethod, or finite differences.

1. a particle whose mass depends on t;
2. linearising about a point off the constraint surface is refused;
11. statements: parameters keyed by Symbols, sp.Eq constraints, a user's own t, undefined
    functions, functions the kernels cannot compute (refused when the system is stated);
12. Cartesian forces on particles, System.mass_forcing, rigid bodies (planar and 3-D).
"""
import numpy as np
import pytest
import sympy as sp
import sympy.physics.mechanics as me
from sympy.physics.mechanics import LagrangesMethod, dynamicsymbols

import lagrange_core as lc
from lagrange_core import problems

_t = dynamicsymbols._t
m, l, g = sp.symbols("m l g", positive=True)


# -- helpers ------------------------------------------------------------------------------

def _to_dynamic(system):
    """The system's coordinates as dynamicsymbols, and the map back to its plain symbols."""
    qs = [dynamicsymbols(name) for name in system.coordinates]
    to_dyn = {s: d for s, d in zip(system.q, qs, strict=True)}
    to_dyn.update({v: d.diff(_t) for v, d in zip(system.qdot, qs, strict=True)})
    to_dyn[lc.t] = _t
    to_plain = {d.diff(_t): v for d, v in zip(qs, system.qdot, strict=True)}
    to_plain.update({d: s for d, s in zip(qs, system.q, strict=True)})
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
            qdd = system.accelerations(q, qd, t, dict(zip(system.parameters, p, strict=True)))
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

def test_parameters_and_coordinates_keyed_by_symbols():
    pend = problems.pendulum()
    by_name = pend.accelerations([0.4], [0.1], 0.0, dict(m=1.0, l=2.0, g=9.81))
    m_, l_, g_ = pend.parameter_symbols[2], pend.parameter_symbols[1], pend.parameter_symbols[0]
    by_symbol = pend.accelerations({pend.q[0]: 0.4}, [0.1], 0.0, {m_: 1.0, l_: 2.0, g_: 9.81})
    mixed = pend.accelerations([0.4], [0.1], 0.0, {"m": 1.0, sp.Symbol("l"): 2.0, g_: 9.81})
    np.testing.assert_array_equal(by_symbol, by_name)
    np.testing.assert_array_equal(mixed, by_name)
    with pytest.raises(ValueError, match="'m' is given twice"):
        pend.accelerations([0.4], [0.1], 0.0, {"m": 1.0, m_: 1.0, "l": 2.0, "g": 9.81})
    with pytest.raises(ValueError, match=r"unknown parameter.*'k'"):
        pend.accelerations([0.4], [0.1], 0.0, {m_: 1.0, l_: 2.0, g_: 9.81, sp.Symbol("k"): 1})
    with pytest.raises(TypeError, match="params: a key must be a name or a sympy Symbol, got 2"):
        pend.accelerations([0.4], [0.1], 0.0, {2: 1.0})


def test_constraint_written_as_an_equation():
    (x, y), _ = lc.coordinates("x y")
    as_equation = lc.System([x, y], particles=[lc.Particle(m, (x, y))], potential=m * g * y,
                            constraints=[sp.Eq(x**2 + y**2, l**2)])
    assert as_equation.constraints == (x**2 + y**2 - l**2,)
    params = dict(m=1.0, l=1.1, g=9.81)
    q, qd = [1.1 * np.sin(0.3), -1.1 * np.cos(0.3)], [0.2 * np.cos(0.3), 0.2 * np.sin(0.3)]
    for a, b in zip(as_equation.accelerations(q, qd, 0.0, params),
                    _cartesian_pendulum().accelerations(q, qd, 0.0, params), strict=True):
        np.testing.assert_allclose(a, b, rtol=1e-14)
    with pytest.raises(ValueError, match="constraint 0 is True: sympy decided the equation"):
        lc.System([x], particles=[lc.Particle(m, (x,))], constraints=[sp.Eq(x, x)])
    with pytest.raises(ValueError, match=r"constraint 0 \(x < 1\) is an inequality"):
        lc.System([x], particles=[lc.Particle(m, (x,))], constraints=[x < 1])
    with pytest.raises(ValueError, match="the potential is the relation.*only a constraint"):
        lc.System([x], particles=[lc.Particle(m, (x,))], potential=sp.Eq(x, 1))


def test_time_symbol():
    """Plain Symbol('t') is time (sympy.physics.mechanics' convention); a t with other
    assumptions is refused with a message naming lagrange_core.t."""
    (theta,), _ = lc.coordinates("theta")
    A, w = sp.symbols("A omega", positive=True)

    def driven(time):
        bob = lc.Particle(m, (l * sp.sin(theta), A * sp.cos(w * time) - l * sp.cos(theta)))
        return lc.System([theta], particles=[bob], potential=m * g * bob.position[1])

    plain = driven(sp.Symbol("t"))
    assert plain.parameters == ("A", "g", "l", "m", "omega")
    assert plain.statement_key() == driven(lc.t).statement_key()
    with pytest.raises(ValueError, match=r"the potential: the symbol t .* not the "
                                         r"time symbol.*positive=True.*lagrange_core\.t.*another "
                                         "name"):
        driven(sp.Symbol("t", positive=True))
    with pytest.raises(ValueError, match=r"time symbol \(lagrange_core\.t\) and cannot be a "
                                         "coordinate"):
        lc.System([sp.Symbol("t")], lagrangian=sp.Symbol("t_dot") ** 2)


def test_undefined_function_of_time():
    (theta,), _ = lc.coordinates("theta")
    F = sp.Function("F")
    bob = lc.Particle(m, (l * sp.sin(theta), F(lc.t) - l * sp.cos(theta)), "bob")
    with pytest.raises(ValueError, match=r"the position of bob: F\(t\) .* undefined function of "
                                         r"time.*explicit expression of t.*A\*cos\(omega\*t\).*"
                                         "parameter") as info:
        lc.System([theta], particles=[bob])
    assert "declare every coordinate" not in str(info.value)
    with pytest.raises(ValueError, match=r"the potential: F\(theta\) .* undefined function"):
        lc.System([theta], particles=[lc.Particle(m, (theta,))], potential=F(theta))
    th = dynamicsymbols("th")
    with pytest.raises(ValueError, match="the lagrangian: Derivative.*<name>_dot"):
        lc.System([theta], lagrangian=th.diff(_t) ** 2)


@pytest.mark.parametrize("expr, message", [
    (sp.besselj(0, sp.Symbol("x", real=True)), "cannot compute besselj"),
    (sp.sec(sp.Symbol("x", real=True)), r"cannot compute sec.*sec\(x\) = 1/cos\(x\)"),
    (sp.floor(sp.Symbol("x", real=True)), "cannot compute floor"),
    (sp.erf(sp.Symbol("x", real=True)), "cannot compute erf"),
    (sp.I * sp.Symbol("x", real=True) ** 2, "imaginary unit"),
    (sp.oo * sp.Symbol("x", real=True), "not a finite number"),
    (sp.EulerGamma * sp.Symbol("x", real=True), "constants pi and E only.*0.577"),
])
def test_uncompilable_statement_is_refused_when_stated(expr, message):
    (x,), (x_dot,) = lc.coordinates("x")
    with pytest.raises(ValueError, match="the potential: .*" + message):
        lc.System([x], lagrangian=x_dot**2 / 2, potential=expr)


def test_every_accepted_function_compiles_and_differentiates():
    """The functions a statement may use, derived and compiled: F = −dV/dx against sympy."""
    (x,), (x_dot,) = lc.coordinates("x")
    k = sp.Symbol("k", positive=True)
    u = x / 3
    V = k * (sp.sin(x) + sp.cos(x) + sp.tan(u) + sp.exp(u) + sp.log(2 + x) + sp.sqrt(2 + x)
             + sp.asin(u) + sp.acos(u) + sp.atan(x) + sp.atan2(x, 2) + sp.sinh(u) + sp.cosh(u)
             + sp.tanh(x) + sp.asinh(x) + sp.acosh(2 + x) + sp.atanh(u) + x * sp.Abs(x - 1)
             + sp.sign(x - 1) * x**2 + sp.pi * sp.E * x + x ** sp.Rational(3, 2))
    system = lc.System([x], lagrangian=x_dot**2 / 2, potential=V)
    # sympy: d|u|/du = sign(u), d sign(u)/du = 0 away from the kink
    force = -sp.diff(V, x).replace(sp.DiracDelta, lambda *a: 0)
    for value in (0.3, 0.5, 1.4):
        expected = float(force.subs({x: value, k: 1.7}))
        np.testing.assert_allclose(system.accelerations([value], [0.0], 0.0, {"k": 1.7}),
                                   [expected], rtol=1e-13)


def test_abs_and_sign_are_differentiated():
    """V = k |x| (a V-shaped well): F = −k sign(x); was a Derivative the kernels refused."""
    (x,), (x_dot,) = lc.coordinates("x")
    k = sp.Symbol("k", positive=True)
    system = lc.System([x], lagrangian=x_dot**2 / 2 + sp.Abs(x_dot) * x, potential=k * sp.Abs(x))
    assert sp.simplify(system.equations.forcing[0] - (-k * sp.sign(x))) == 0
    np.testing.assert_allclose(system.accelerations([-0.4], [0.3], 0.0, {"k": 2.0}), [2.0])


# -- item 12: Cartesian forces, mass_forcing, rigid bodies ---------------------------------------

def test_cartesian_gravity_equals_the_potential(rng):
    """Gravity as forces (0, −m g) on both bobs of a double pendulum, projected by virtual
    work, against the same pendulum with the potential m g y."""
    reference = problems.double_pendulum()
    bobs = reference.particles
    forced = lc.System(reference.q, particles=bobs,
                       forces=[(b, (0, -b.mass * sp.Symbol("g", positive=True))) for b in bobs])
    assert forced.parameters == reference.parameters
    def reference_part(i):
        names = reference.parameters
        return lambda q, qd, t, p: reference.mass_forcing(q, qd, t,
                                                          dict(zip(names, p, strict=True)))[i]

    _assert_same_equations(forced, reference_part(0), reference_part(1), rng)


def test_cartesian_drag_equals_rayleigh_dissipation(rng):
    """Linear drag F = −c ṙ on a pendulum bob is the dissipation D = ½ c |ṙ|² = ½ c l² θ̇²."""
    (theta,), (theta_dot,) = lc.coordinates("theta")
    c = sp.Symbol("c", positive=True)
    bob = lc.Particle(m, (l * sp.sin(theta), -l * sp.cos(theta)), "bob")
    velocity = [sp.diff(r, theta) * theta_dot for r in bob.position]
    dragged = lc.System([theta], particles=[bob], potential=m * g * bob.position[1],
                        forces={bob: [-c * v for v in velocity]})
    damped = lc.System([theta], particles=[bob], potential=m * g * bob.position[1],
                       dissipation=c * l**2 * theta_dot**2 / 2)
    for _ in range(3):
        q, qd, t, p = _random_state(dragged, rng)
        params = dict(zip(dragged.parameters, p, strict=True))
        np.testing.assert_allclose(dragged.accelerations(q, qd, t, params),
                                   damped.accelerations(q, qd, t, params), rtol=1e-13)
    # and the closed form θ̈ = −(g/l) sin θ − (c/m) θ̇ (plus a horizontal push F0 l cos θ)
    F0 = sp.Symbol("F0")
    pushed = lc.System([theta], particles=[bob], potential=m * g * bob.position[1],
                       forces={theta: -c * l**2 * theta_dot, bob: (F0, 0)})
    params = dict(m=1.5, l=0.8, g=9.81, c=0.3, F0=2.0)
    expected = (-9.81 / 0.8 * np.sin(0.6) - 0.3 / 1.5 * 0.5
                + 2.0 * 0.8 * np.cos(0.6) / (1.5 * 0.8**2))
    np.testing.assert_allclose(pushed.accelerations([0.6], [0.5], 0.0, params), [expected],
                               rtol=1e-13)


def test_cartesian_force_errors():
    (theta,), _ = lc.coordinates("theta")
    bob = lc.Particle(m, (l * sp.sin(theta), -l * sp.cos(theta)), "bob")
    with pytest.raises(ValueError, match=r"the force on bob has 3 component.*has 2"):
        lc.System([theta], particles=[bob], forces=[(bob, (0, 0, 1))])
    with pytest.raises(ValueError, match="not both"):
        lc.System([theta, sp.Symbol("x", real=True)], particles=[bob], forces=[(bob, (0, 1)), 0])


def test_mass_forcing_returns_numbers():
    system = problems.double_pendulum()
    params = dict(m1=1.0, m2=2.0, l1=0.5, l2=0.7, g=9.81)
    q, qd = np.array([0.3, -0.2]), np.array([0.1, 0.4])
    M, F = system.mass_forcing(q, qd, 0.0, params)
    sub = {**dict(zip(system.q, q, strict=True)), **dict(zip(system.qdot, qd, strict=True)),
           **{s: params[s.name] for s in system.parameter_symbols}}
    np.testing.assert_allclose(M, np.array(system.equations.mass_matrix.xreplace(sub), float),
                               rtol=1e-14)
    np.testing.assert_allclose(F, np.array(system.equations.forcing.xreplace(sub), float).ravel(),
                               rtol=1e-13)
    np.testing.assert_allclose(np.linalg.solve(M, F), system.accelerations(q, qd, 0.0, params),
                               rtol=1e-13)


def test_physical_pendulum_closed_form():
    """(I_c + m d²) θ̈ = −m d (g + ÿ_p) sin θ; ω² = m g d / (I_c + m d²) (PHYSICS.md)."""
    params = dict(m=2.0, I_c=0.3, d=0.4, g=9.81)
    I = 0.3 + 2.0 * 0.4**2
    pend = problems.physical_pendulum()
    np.testing.assert_allclose(pend.accelerations([1.1], [0.7], 0.0, params),
                               [-2.0 * 9.81 * 0.4 * np.sin(1.1) / I], rtol=1e-14)
    np.testing.assert_allclose(pend.normal_modes(params), [np.sqrt(2.0 * 9.81 * 0.4 / I)],
                               rtol=1e-13)
    h = pend.kernels.energy(np.array([1.1]), np.array([0.7]), 0.0,
                            pend.parameter_array(params))
    assert h == pytest.approx(I * 0.7**2 / 2 - 2.0 * 9.81 * 0.4 * np.cos(1.1), rel=1e-14)
    driven = problems.physical_pendulum(driven=True)
    params.update(A=0.05, omega=40.0)
    t = 0.37
    y_pp = -0.05 * 40.0**2 * np.cos(40.0 * t)
    np.testing.assert_allclose(driven.accelerations([1.1], [0.7], t, params),
                               [-2.0 * 0.4 * (9.81 + y_pp) * np.sin(1.1) / I], rtol=1e-13)
    # a uniform rod: l_eq = 2L/3
    L = 1.2
    rod = dict(m=1.0, I_c=L**2 / 12, d=L / 2, g=9.81)
    np.testing.assert_allclose(pend.normal_modes(rod), [np.sqrt(9.81 / (2 * L / 3))], rtol=1e-13)


@pytest.mark.parametrize("constrained", [False, True])
def test_rolling_disc_closed_form(constrained):
    """s̈ = g sin α / (1 + I/(m R²)); with the constraint s = Rφ the multiplier is the
    friction force λ = −I s̈ / R²."""
    system = problems.rolling_disc(constrained)
    params = dict(m=1.5, R=0.2, I=0.5 * 1.5 * 0.2**2, alpha=0.35, g=9.81)   # uniform disc
    a = 9.81 * np.sin(0.35) / 1.5
    n = system.n_dof
    result = system.accelerations([0.3, 1.5][:n], [0.4, 2.0][:n], 0.0, params)
    if constrained:
        qdd, lam = result
        np.testing.assert_allclose(qdd, [a, a / 0.2], rtol=1e-13)
        np.testing.assert_allclose(lam, [-params["I"] * a / 0.2**2], rtol=1e-13)
    else:
        np.testing.assert_allclose(result, [a], rtol=1e-13)
    assert system.equations.energy_conserved


def test_atwood_machine_with_massive_pulley():
    params = dict(m1=3.0, m2=2.0, M=1.2, R=0.1, g=9.81)
    a = (3.0 - 2.0) * 9.81 / (3.0 + 2.0 + 1.2 / 2)
    system = problems.atwood_machine()
    np.testing.assert_allclose(system.accelerations([0.2], [0.3], 0.0, params), [a], rtol=1e-14)
    assert system.n_dof == 1 and len(system.particles) == 2      # the pulley's centre is fixed
    h = system.kernels.energy(np.array([0.2]), np.array([0.3]), 0.0,
                              system.parameter_array(params))
    T = (3.0 + 2.0 + 1.2 / 2) * 0.3**2 / 2
    assert h == pytest.approx(T + 9.81 * (-3.0 * 0.2 + 2.0 * 0.2), rel=1e-14)


def test_rigid_body_3d_heavy_top_matches_lagranges_method(rng):
    """A heavy asymmetric top (tip fixed at the origin, centre of mass at distance d along
    its body z axis), z-x-z Euler angles: M and F against LagrangesMethod with
    sympy.physics.mechanics.RigidBody."""
    (psi, theta, phi), _ = lc.coordinates("psi theta phi")
    I1, I2, I3, d = sp.symbols("I1 I2 I3 d", positive=True)
    R = (lc.rotation_matrix("z", psi) * lc.rotation_matrix("x", theta)
         * lc.rotation_matrix("z", phi))
    centre = R * sp.Matrix([0, 0, d])
    top = lc.RigidBody(m, (I1, I2, I3), tuple(centre), R, "top")
    system = lc.System([psi, theta, phi], bodies=[top], potential=m * g * centre[2])

    qs = dynamicsymbols("psi theta phi")
    N = me.ReferenceFrame("N")
    B = N.orientnew("B", "Body", qs, "ZXZ")
    to_dyn = dict(zip(system.q, qs, strict=True))
    assert sp.simplify(N.dcm(B) - R.xreplace(to_dyn)) == sp.zeros(3, 3)   # same convention
    O = me.Point("O")
    O.set_vel(N, 0)
    P = O.locatenew("P", d * B.z)
    P.v2pt_theory(O, N, B)
    body = me.RigidBody("top", P, B, m, (me.inertia(B, I1, I2, I3), P))
    body.potential_energy = m * g * P.pos_from(O).dot(N.z)
    lm = LagrangesMethod(me.Lagrangian(N, body), qs)
    lm.form_lagranges_equations()
    _, _, to_plain = _to_dynamic(system)
    _assert_same_equations(system, _numeric(lm.mass_matrix, system, to_plain),
                           _numeric(lm.forcing, system, to_plain), rng, q_range=(0.3, 2.8))
    assert system.equations.energy_conserved
    assert set(system.equations.conserved_momenta) == {"psi"}


def test_rigid_body_planar_matches_lagranges_method(rng):
    """A rod whose end slides on a driven horizontal rail (x, θ), time-varying mass, against
    LagrangesMethod on T = ½ m |ṙ|² + ½ I θ̇² − V written out."""
    (x, theta), (x_dot, theta_dot) = lc.coordinates("x theta")
    k, A, w, L = sp.symbols("k A omega L", positive=True)
    mass = m * (1 + k * lc.t)
    centre = (x + L / 2 * sp.sin(theta), A * sp.sin(w * lc.t) - L / 2 * sp.cos(theta))
    rod = lc.RigidBody(mass, mass * L**2 / 12, centre, theta, "rod")
    system = lc.System([x, theta], bodies=[rod], potential=mass * g * centre[1])
    qs, to_dyn, _ = _to_dynamic(system)
    r = [c.xreplace(to_dyn) for c in centre]
    T = (mass * (r[0].diff(_t) ** 2 + r[1].diff(_t) ** 2) / 2
         + mass * L**2 / 12 * qs[1].diff(_t) ** 2 / 2).xreplace({lc.t: _t})
    _, _, to_plain = _to_dynamic(system)
    L_plain = (T - (mass * g * centre[1]).xreplace(to_dyn).xreplace({lc.t: _t}))
    M_ref, F_ref = _lagranges_method(system, L_plain.xreplace(to_plain).xreplace({_t: lc.t}))
    _assert_same_equations(system, M_ref, F_ref, rng)


def test_rigid_body_errors():
    (theta,), _ = lc.coordinates("theta")
    with pytest.raises(ValueError, match="not a rotation matrix"):
        lc.RigidBody(m, (1, 1, 1), (0, 0, 0), 2 * lc.rotation_matrix("z", theta))
    with pytest.raises(ValueError, match="planar body .* one moment of inertia"):
        lc.RigidBody(m, (1, 1, 1), (0, 0), theta)
    with pytest.raises(ValueError, match="three components of its centre of mass"):
        lc.RigidBody(m, (1, 1, 1), (0, 0), lc.rotation_matrix("z", theta))
    with pytest.raises(TypeError, match="pass rigid bodies as bodies="):
        lc.System([theta], particles=[lc.RigidBody(m, 1, (0, 0), theta)])
    with pytest.raises(ValueError, match="neither its centre of mass .* nor its orientation"):
        lc.System([theta], particles=[lc.Particle(m, (theta,))],
                  bodies=[lc.RigidBody(m, 1, (0, 0), lc.t)])
