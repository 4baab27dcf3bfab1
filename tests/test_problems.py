"""The catalogue of the lecture's problems, each against its closed form.

Every test states the closed form it checks (the problems' docstrings derive or
cite them) and uses parameter values chosen so that no factor is 1.
"""
import math

import numpy as np
import pytest
import scipy.optimize
import scipy.special
import sympy as sp

from lagrange_core import problems
from lagrange_core.fields import Field1D, field_symbols
from lagrange_core.fields import x as x_sym
from lagrange_core.integrate import crossing, turning_point
from lagrange_core.systems import t as t_sym

# -- systems built once per session ---------------------------------------------------------

@pytest.fixture(scope="module")
def kepler():
    return problems.central_force()


@pytest.fixture(scope="module")
def spherical():
    return problems.spherical_pendulum()


@pytest.fixture(scope="module")
def spherical_xyz():
    return problems.spherical_pendulum(form="cartesian")


@pytest.fixture(scope="module")
def wedge():
    return problems.block_on_wedge()


@pytest.fixture(scope="module")
def wedge_n():
    return problems.block_on_wedge(normal_coordinate=True)


@pytest.fixture(scope="module")
def atwood():
    return problems.swinging_atwood()


def sym(name):
    return sp.Symbol(name, real=True)


def pos(name):
    return sp.Symbol(name, positive=True)


# -- central force --------------------------------------------------------------------------

KEPLER = dict(m=2.0, k=3.0)


def kepler_orbit(a, e, m=KEPLER["m"], k=KEPLER["k"]):
    """Start at perihelion: (q0, qdot0), period, energy, angular momentum (closed form)."""
    rp = a * (1 - e)
    L = math.sqrt(m * k * a * (1 - e**2))
    return [rp, 0.0], [0.0, L / (m * rp**2)], 2 * math.pi * math.sqrt(m * a**3 / k), -k / (2 * a), L


def test_central_force_statement(kepler):
    assert kepler.coordinates == ("r", "phi")
    assert kepler.parameters == ("k", "m")
    r, phi_dot, m = sym("r"), sym("phi_dot"), pos("m")
    p_phi = kepler.equations.conserved_momenta
    assert set(p_phi) == {"phi"}
    assert sp.simplify(p_phi["phi"] - m * r**2 * phi_dot) == 0


def test_kepler_period_and_turning_points(kepler):
    a, e = 1.3, 0.6
    q0, qd0, T, E, L = kepler_orbit(a, e)
    tr = kepler.simulate(q0, qd0, (0.0, 3 * T), KEPLER, rtol=1e-11,
                         events=[turning_point("r")])
    assert tr.status == "success"
    # turning points alternate aphelion (T/2, 3T/2, ...) and perihelion (T, 2T, ...)
    times = tr.event_times()
    np.testing.assert_allclose(times, T * np.arange(1, 6) / 2, rtol=1e-9)
    radii = np.array([ev.q[0] for ev in tr.events])
    expect = np.where(np.arange(1, 6) % 2 == 1, a * (1 + e), a * (1 - e))
    np.testing.assert_allclose(radii, expect, rtol=1e-9)
    # the polar angle advances by exactly π between turning points (closed orbit)
    np.testing.assert_allclose([ev.q[1] for ev in tr.events], np.pi * np.arange(1, 6), rtol=1e-9)
    # energy and angular momentum
    np.testing.assert_allclose(tr.energy, E, rtol=1e-9)
    np.testing.assert_allclose(KEPLER["m"] * tr.q[:, 0]**2 * tr.qdot[:, 1], L, rtol=1e-9)


def test_kepler_turning_points_from_energy_and_angular_momentum(kepler):
    """Turning points solve E = L²/(2 m r²) − k/r, a quadratic: E r² + k r − L²/(2m) = 0."""
    m, k = KEPLER["m"], KEPLER["k"]
    q0, qd0 = [2.0, 0.3], [0.4, 0.5]           # a generic bound state
    E = 0.5 * m * (qd0[0]**2 + (q0[0] * qd0[1])**2) - k / q0[0]
    L = m * q0[0]**2 * qd0[1]
    assert E < 0
    roots = np.sort(np.roots([E, k, -L**2 / (2 * m)]).real)
    h = kepler.kernels.energy(np.array(q0), np.array(qd0), 0.0, kepler.parameter_array(KEPLER))
    assert h == pytest.approx(E, rel=1e-14)
    T = 2 * math.pi * math.sqrt(m * (-k / (2 * E))**3 / k)
    tr = kepler.simulate(q0, qd0, (0.0, 2 * T), KEPLER, rtol=1e-11, events=[turning_point("r")])
    r_turn = np.array([ev.q[0] for ev in tr.events])
    assert len(r_turn) >= 3
    np.testing.assert_allclose(np.sort(r_turn)[[0, -1]], roots, rtol=1e-9)


def test_central_force_user_potential():
    """A user V(r) = κ r⁴/4 brings its own parameter; turning points by root finding."""
    kappa = pos("kappa")
    system = problems.central_force(kappa * sp.Symbol("r")**4 / 4)
    assert system.parameters == ("kappa", "m")
    params = dict(m=0.7, kappa=2.5)
    q0, qd0 = [1.1, 0.0], [0.3, 0.9]
    m, kap = params["m"], params["kappa"]
    L = m * q0[0]**2 * qd0[1]
    E = 0.5 * m * (qd0[0]**2 + (q0[0] * qd0[1])**2) + kap * q0[0]**4 / 4
    def U(r):
        return L**2 / (2 * m * r**2) + kap * r**4 / 4 - E

    r_min = scipy.optimize.brentq(U, 1e-3, q0[0])
    r_max = scipy.optimize.brentq(U, q0[0], 10.0)
    tr = system.simulate(q0, qd0, (0.0, 6.0), params, rtol=1e-11, events=[turning_point("r")])
    r_turn = np.array([ev.q[0] for ev in tr.events])
    assert np.any(np.isclose(r_turn, r_min, rtol=1e-8))
    assert np.any(np.isclose(r_turn, r_max, rtol=1e-8))
    assert np.all(np.isclose(r_turn, r_min, rtol=1e-8) | np.isclose(r_turn, r_max, rtol=1e-8))
    np.testing.assert_allclose(m * tr.q[:, 0]**2 * tr.qdot[:, 1], L, rtol=1e-9)
    # the callable form states the same system
    same = problems.central_force(lambda r: kappa * r**4 / 4)
    assert same.statement_key() == system.statement_key()


def test_central_force_rejects_non_central_potential():
    with pytest.raises(ValueError, match="depend on r only"):
        problems.central_force(sym("r") * sp.cos(sym("phi")))
    with pytest.raises(TypeError, match="sympy expression"):
        problems.central_force(lambda r: "not an expression")


# -- spherical pendulum --------------------------------------------------------------------

SPH = dict(m=0.8, l=1.7, g=9.81)


def test_spherical_pendulum_statement(spherical):
    assert spherical.coordinates == ("theta", "phi")
    th, phd, m, l = sym("theta"), sym("phi_dot"), pos("m"), pos("l")
    p = spherical.equations.conserved_momenta
    assert set(p) == {"phi"}
    assert sp.simplify(p["phi"] - m * l**2 * sp.sin(th)**2 * phd) == 0


@pytest.mark.parametrize("theta0", [0.3, 1.0, 1.4])
def test_conical_motion_and_its_small_oscillations(spherical, theta0):
    """φ̇² = g/(l cos θ0) is steady; small oscillations have ω² = φ̇² (1 + 3 cos² θ0)."""
    g, l = SPH["g"], SPH["l"]
    w = math.sqrt(g / (l * math.cos(theta0)))
    qdd = spherical.accelerations([theta0, 0.4], [0.0, w], params=SPH)
    np.testing.assert_allclose(qdd, 0.0, atol=1e-12 * g / l)
    # the first-order system's Jacobian there has eigenvalues 0, 0, ±iω
    J = np.empty((4, 4))
    assert spherical.kernels.jacobian(0.0, np.array([theta0, 0.4, 0.0, w]),
                                      spherical.parameter_array(SPH), J) == 0
    eig = np.linalg.eigvals(J)
    omega = w * math.sqrt(1 + 3 * math.cos(theta0)**2)
    assert np.max(np.abs(eig.imag)) == pytest.approx(omega, rel=1e-10)
    np.testing.assert_allclose(eig.real, 0.0, atol=1e-8 * omega)
    # and by integration: a 1e-5 rad nudge at the same p_φ (so about the same cone)
    # oscillates with period 2π/ω, to O(amplitude²)
    T = 2 * math.pi / omega
    th1 = theta0 + 1e-5
    w1 = w * math.sin(theta0)**2 / math.sin(th1)**2
    tr = spherical.simulate([th1, 0.0], [0.0, w1], (0.0, 3.2 * T), SPH, rtol=1e-12,
                            events=[turning_point("theta", direction=1)])
    periods = np.diff(tr.event_times())
    assert len(periods) >= 2
    np.testing.assert_allclose(periods, T, rtol=1e-6)


def plane_pendulum_period(theta_max, g, l):
    """T = 4 K(m) √(l/g), m = sin²(θ_max/2) (scipy's ellipk takes the parameter m)."""
    return 4 * scipy.special.ellipk(math.sin(theta_max / 2)**2) * math.sqrt(l / g)


def test_cartesian_form_passes_through_the_pole(spherical_xyz):
    """Swinging in a vertical plane goes through θ = 0 (x = y = 0), where the spherical chart
    is singular; the constrained Cartesian form integrates it: period, crossing times and rod
    tension T = m g (3 cos θ − 2 cos θ_max) against the plane pendulum's closed forms."""
    m, l, g = SPH["m"], SPH["l"], SPH["g"]
    th_max = 2.0
    T = plane_pendulum_period(th_max, g, l)
    q0 = [l * math.sin(th_max), 0.0, -l * math.cos(th_max)]
    tr = spherical_xyz.simulate(q0, [0, 0, 0], (0.0, 2 * T), SPH, rtol=1e-11,
                                events=[crossing("x")])
    # crosses the pole (x = 0) at T/4, 3T/4, 5T/4, 7T/4
    np.testing.assert_allclose(tr.event_times(), T * np.array([0.25, 0.75, 1.25, 1.75]), rtol=1e-8)
    for ev in tr.events:
        np.testing.assert_allclose(ev.q, [0.0, 0.0, -l], atol=1e-8 * l)
    np.testing.assert_allclose(tr.q[-1], q0, atol=1e-7 * l)
    assert np.max(tr.constraint_residual) < 1e-9
    np.testing.assert_allclose(tr.energy, -m * g * l * math.cos(th_max), rtol=1e-9)
    cos_theta = -tr.q[:, 2] / l
    tension = -2 * tr.multipliers[:, 0] * l
    np.testing.assert_allclose(tension, m * g * (3 * cos_theta - 2 * math.cos(th_max)),
                               atol=1e-7 * m * g)


def test_near_the_pole_spherical_and_cartesian_agree(spherical, spherical_xyz):
    """A tiny azimuthal velocity makes the bob pass 1e-4 rad from the pole; in spherical
    coordinates φ̇ ~ 10⁴ rad/s there.  Both forms give the same bob positions."""
    l = SPH["l"]
    th0, phd0 = 0.5, 1e-3
    t_end = 1.2 * plane_pendulum_period(th0, SPH["g"], l)
    t_eval = np.linspace(0.0, t_end, 61)
    a = spherical.simulate([th0, 0.0], [0.0, phd0], (0.0, t_end), SPH, rtol=1e-12, t_eval=t_eval,
                           events=[turning_point("theta", direction=1)])
    # closest approach: θ̇ = 0 where E = p_φ²/(2 m l² sin² θ) − m g l cos θ
    m, g = SPH["m"], SPH["g"]
    p_phi = m * l**2 * math.sin(th0)**2 * phd0
    E = -m * g * l * math.cos(th0)
    th_min = scipy.optimize.brentq(
        lambda th: p_phi**2 / (2 * m * l**2 * math.sin(th)**2) - m * g * l * math.cos(th) - E,
        1e-8, 0.1)
    assert th_min < 2e-4                      # it does pass close to the pole
    assert len(a.events) == 2                 # twice per plane-pendulum period
    np.testing.assert_allclose([ev.q[0] for ev in a.events], th_min, rtol=1e-6)
    xa = l * np.column_stack([np.sin(a.q[:, 0]) * np.cos(a.q[:, 1]),
                              np.sin(a.q[:, 0]) * np.sin(a.q[:, 1]), -np.cos(a.q[:, 0])])
    q0 = [l * math.sin(th0), 0.0, -l * math.cos(th0)]
    v0 = [0.0, l * math.sin(th0) * phd0, 0.0]
    b = spherical_xyz.simulate(q0, v0, (0.0, t_end), SPH, rtol=1e-12, t_eval=t_eval)
    np.testing.assert_allclose(b.q, xa, atol=1e-7 * l)
    np.testing.assert_allclose(b.energy, a.energy, rtol=1e-9)


def test_spherical_pendulum_rejects_unknown_form():
    with pytest.raises(ValueError, match="form must be"):
        problems.spherical_pendulum(form="polar")


# -- double and n-link pendulum ------------------------------------------------------------

def test_double_pendulum_normal_modes():
    g, l, m = 9.81, 0.7, 1.3
    w = problems.double_pendulum().normal_modes(dict(g=g, l1=l, l2=l, m1=m, m2=m))
    np.testing.assert_allclose(w**2, (g / l) * np.array([2 - math.sqrt(2), 2 + math.sqrt(2)]),
                               rtol=1e-12)


def test_double_pendulum_unequal_normal_modes():
    """General masses and lengths: ω² are the roots of
    m1 l1 l2 ω⁴ − (m1 + m2) g (l1 + l2) ω² + (m1 + m2) g² = 0."""
    g, l1, l2, m1, m2 = 9.81, 0.7, 1.9, 1.3, 0.4
    w = problems.double_pendulum().normal_modes(dict(g=g, l1=l1, l2=l2, m1=m1, m2=m2))
    expect = np.sort(np.roots([m1 * l1 * l2, -(m1 + m2) * g * (l1 + l2), (m1 + m2) * g**2]))
    np.testing.assert_allclose(w**2, expect, rtol=1e-12)


def test_n_link_pendulum_equal_links_low_mode():
    """Three equal links (g = l = m = 1): M_ij = 3 − max(i, j) + 1, K = diag(3, 2, 1), so the
    ω² are the roots of det(K − ω² M) = −ω⁶ + 9ω⁴ − 18ω² + 6."""
    w = problems.n_link_pendulum(3).normal_modes(dict(g=1.0, l1=1.0, l2=1.0, l3=1.0, m1=1.0,
                                                      m2=1.0, m3=1.0))
    np.testing.assert_allclose(w**2, np.sort(np.roots([1, -9, 18, -6])), rtol=1e-12)


# -- the guitar string: field and beads ----------------------------------------------------

def test_guitar_string_field_equation():
    string = problems.guitar_string()
    assert isinstance(string, Field1D) and string.parameters == ("F", "mu")
    y = string.function
    mu, F = pos("mu"), pos("F")
    expect = (mu * y.diff(t_sym, 2)
              - F * y.diff(x_sym, 2) / (1 + y.diff(x_sym)**2)**sp.Rational(3, 2))
    assert sp.simplify(string.field_equation - expect) == 0


def test_guitar_string_small_slope_is_the_wave_equation():
    string = problems.guitar_string().small_amplitude()
    y = string.function
    mu, F, l = pos("mu"), pos("F"), pos("l")
    assert sp.simplify(string.field_equation - (mu * y.diff(t_sym, 2) - F * y.diff(x_sym, 2))) == 0
    c = string.wave_speed()
    assert sp.simplify(c - sp.sqrt(F / mu)) == 0
    n = sp.Symbol("n", positive=True, integer=True)
    assert sp.simplify(string.fixed_end_frequencies(l, n) - n * sp.sqrt(F / mu) / (2 * l)) == 0
    # a standing wave with the fixed-end wavenumber solves it (d'Alembert)
    k = n * sp.pi / l
    standing = sp.sin(k * x_sym) * sp.cos(c * k * t_sym)
    assert sp.simplify(string.field_equation.subs(y, standing).doit()) == 0


def test_field_rejects_density_without_kinetic_term():
    u, u_t, u_x = field_symbols()
    with pytest.raises(ValueError, match="kinetic"):
        Field1D(u_x**2)
    with pytest.raises(ValueError, match="not of the form"):
        Field1D(u_t**2 / 2 - u_x**2 / 2 - u**4).wave_speed()


def test_klein_gordon_field_equation():
    """A second density, to check the derivation is not tuned to the string:
    ℒ = ½ u_t² − ½ c² u_x² − ½ m² u² gives u_tt − c² u_xx + m² u = 0."""
    u, u_t, u_x = field_symbols("u")
    c, m = pos("c"), pos("m")
    f = Field1D(u_t**2 / 2 - c**2 * u_x**2 / 2 - m**2 * u**2 / 2)
    U = f.function
    klein_gordon = U.diff(t_sym, 2) - c**2 * U.diff(x_sym, 2) + m**2 * U
    assert sp.simplify(f.field_equation - klein_gordon) == 0


def bead_modes(N, F, mu, l):
    h = l / (N + 1)
    return 2 * np.sqrt(F / (mu * h**2)) * np.sin(np.arange(1, N + 1) * np.pi / (2 * (N + 1)))


@pytest.mark.parametrize("small_slope", [False, True])
def test_bead_string_normal_modes(small_slope):
    N, params = 7, dict(F=80.0, mu=0.005, l=0.65)
    system = problems.bead_string(N, small_slope=small_slope)
    assert system.parameters == ("F", "l", "mu")
    w = system.normal_modes(params)
    np.testing.assert_allclose(w, bead_modes(N, **params), rtol=1e-11)


def test_bead_string_energy_is_tension_times_stretch():
    N, params = 4, dict(F=80.0, mu=0.005, l=0.65)
    system = problems.bead_string(N)
    rng = np.random.default_rng(3)
    y, v = rng.normal(0, 0.05, N), rng.normal(0, 1.0, N)
    h = params["l"] / (N + 1)
    ends = np.concatenate([[0.0], y, [0.0]])
    V = params["F"] * np.sum(np.hypot(h, np.diff(ends)) - h)
    E = 0.5 * params["mu"] * h * np.sum(v**2) + V
    energy = system.kernels.energy(y, v, 0.0, system.parameter_array(params))
    assert energy == pytest.approx(E, rel=1e-13)


def test_bead_string_rejects_bad_n():
    with pytest.raises(ValueError, match="whole number"):
        problems.bead_string(0)


# -- block on a wedge ----------------------------------------------------------------------

def wedge_closed_form(m, M, alpha, g):
    D = M + m * math.sin(alpha)**2
    return (-m * g * math.sin(alpha) * math.cos(alpha) / D, (M + m) * g * math.sin(alpha) / D,
            M * m * g * math.cos(alpha) / D)


WEDGE = dict(m=0.6, M=2.3, alpha=0.45, g=9.81)


def test_wedge_accelerations_and_normal_force(wedge, wedge_n):
    Xdd, sdd, N = wedge_closed_form(**WEDGE)
    a = wedge.accelerations([0.3, 0.2], [0.5, -0.1], params=WEDGE)
    np.testing.assert_allclose(a, [Xdd, sdd], rtol=1e-13)
    a, lam = wedge_n.accelerations([0.3, 0.2, 0.0], [0.5, -0.1, 0.0], params=WEDGE)
    np.testing.assert_allclose(a, [Xdd, sdd, 0.0], rtol=1e-13, atol=1e-13)
    assert lam[0] == pytest.approx(N, rel=1e-13)


def test_wedge_horizontal_momentum_is_conserved(wedge):
    m, M, al = pos("m"), pos("M"), pos("alpha")
    p = wedge.equations.conserved_momenta
    assert set(p) == {"X"}
    assert sp.simplify(p["X"] - ((M + m) * sym("X_dot") + m * sp.cos(al) * sym("s_dot"))) == 0


def test_wedge_motion(wedge_n):
    """From rest the block slides with constant accelerations: X = Ẍ t²/2, s = s̈ t²/2, and
    the normal force stays N."""
    Xdd, sdd, N = wedge_closed_form(**WEDGE)
    t_eval = np.linspace(0.0, 1.5, 16)
    tr = wedge_n.simulate([0, 0, 0], [0, 0, 0], (0.0, 1.5), WEDGE, t_eval=t_eval)
    np.testing.assert_allclose(tr.q[:, 0], Xdd * t_eval**2 / 2, atol=1e-10)
    np.testing.assert_allclose(tr.q[:, 1], sdd * t_eval**2 / 2, atol=1e-10)
    np.testing.assert_allclose(tr.multipliers[:, 0], N, rtol=1e-10)
    np.testing.assert_allclose(tr.energy, 0.0, atol=1e-9)


# -- swinging Atwood machine ---------------------------------------------------------------

ATWOOD = dict(m=0.9, g=9.81)


def test_swinging_atwood_equations(atwood, rng):
    """2 r̈ = r θ̇² − g (1 − cos θ), r θ̈ = −2 ṙ θ̇ − g sin θ;
    E = m ṙ² + ½ m r² θ̇² + m g r (1 − cos θ)."""
    g, m = ATWOOD["g"], ATWOOD["m"]
    p = atwood.parameter_array(ATWOOD)
    for _ in range(5):
        r, th = rng.uniform(0.2, 2.0), rng.uniform(-3, 3)
        rd, thd = rng.normal(size=2)
        a = atwood.accelerations([r, th], [rd, thd], params=ATWOOD)
        np.testing.assert_allclose(a, [(r * thd**2 - g * (1 - math.cos(th))) / 2,
                                       (-2 * rd * thd - g * math.sin(th)) / r],
                                   rtol=1e-12, atol=1e-12)
        E = m * rd**2 + 0.5 * m * r**2 * thd**2 + m * g * r * (1 - math.cos(th))
        energy = atwood.kernels.energy(np.array([r, th]), np.array([rd, thd]), 0.0, p)
        assert energy == pytest.approx(E, rel=1e-13)


@pytest.mark.parametrize("r_min", [0.01, 0.0])
def test_swinging_atwood_stops_at_the_pulley(atwood, r_min):
    """With θ = θ̇ = 0 the masses balance and r moves uniformly: r = r_min at
    t = (r0 − r_min)/|ṙ0|.  The run stops there and says why instead of integrating into
    the singular chart (r = 0) and beyond."""
    tr = atwood.simulate([1.2, 0.0], [-0.8, 0.0], (0.0, 5.0), ATWOOD,
                         events=[problems.swinging_atwood_stop(r_min)])
    assert tr.status == "event"
    assert tr.t[-1] == pytest.approx((1.2 - r_min) / 0.8, rel=1e-10)
    assert tr.q[-1, 0] == pytest.approx(r_min, abs=1e-10)
    assert "leaves the model" in tr.events[-1].name


def test_swinging_atwood_stop_rejects_negative_radius():
    with pytest.raises(ValueError, match="r_min"):
        problems.swinging_atwood_stop(-1.0)


def test_swinging_atwood_conserves_energy(atwood):
    q0, qd0 = [1.0, 1.2], [0.0, 0.0]
    tr = atwood.simulate(q0, qd0, (0.0, 20.0), ATWOOD, rtol=1e-11,
                         events=[problems.swinging_atwood_stop(1e-3)])
    E0 = ATWOOD["m"] * ATWOOD["g"] * q0[0] * (1 - math.cos(q0[1]))
    np.testing.assert_allclose(tr.energy, E0, rtol=1e-8)


# -- driven pendulum -----------------------------------------------------------------------

@pytest.mark.parametrize("direction", ["vertical", "horizontal"])
def test_driven_pendulum_equation(direction, rng):
    """θ̈ = −γ θ̇ − (g − A ω² cos ωt) sin θ / l (vertical),
    θ̈ = −γ θ̇ − (g sin θ − A ω² cos ωt cos θ) / l (horizontal)."""
    system = problems.driven_pendulum(direction, damping=True)
    P = dict(m=0.3, l=0.8, g=9.81, A=0.05, omega=70.0, gamma=0.4)
    for _ in range(5):
        th, thd, tt = rng.uniform(-3, 3), rng.normal(), rng.uniform(0, 1)
        a = system.accelerations([th], [thd], tt, params=P)[0]
        drive = P["A"] * P["omega"]**2 * math.cos(P["omega"] * tt)
        if direction == "vertical":
            expect = -P["gamma"] * thd - (P["g"] - drive) * math.sin(th) / P["l"]
        else:
            expect = -P["gamma"] * thd - (P["g"] * math.sin(th) - drive * math.cos(th)) / P["l"]
        assert a == pytest.approx(expect, rel=1e-12, abs=1e-12)
