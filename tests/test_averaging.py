"""Averaging (kapitza.averaging) against independent references.

References: closed forms (Landau–Lifshitz §30, Kapitza, Acheson 1993), finite
differences of the sympy U_eff, scipy.special.mathieu_a/b, and exact Floquet
multipliers from monodromy matrices integrated here with solve_ivp at tight
tolerance (the linearised equations come from PHYSICS.md for the pendulum and from
lagrange_core's compiled Jacobian for the N-link chain).
"""
import math
import warnings

import numpy as np
import pytest
import sympy as sp
from scipy.integrate import solve_ivp
from scipy.optimize import brentq
from scipy.special import mathieu_a, mathieu_b

from kapitza import averaging as av
from kapitza.closed_forms import _characteristic as ch
from kapitza.closed_forms import _pendulum as pcf
from kapitza.closed_forms import pendulum_window
from kapitza.pendulum import KapitzaPendulum
from lagrange_core import Particle, System, coordinates, problems, t

from helpers import W0, G, L, jacobian_monodromy, pendulum_monodromy

# -- exact references (and tests/helpers.py) -------------------------------------------------

def exact_slow_frequency(A, omega, sign, l=L, g=G):
    """Ω = β ω / 2 with cos(π β) = tr M / 2 (PHYSICS.md); NaN if unstable."""
    tr = np.trace(pendulum_monodromy(A, omega, sign, l=l, g=g))
    if abs(tr) >= 2:
        return math.nan
    return math.acos(tr / 2) / math.pi * omega / 2


# -- point 1: any driven system --------------------------------------------------------------

def test_fourier_split_harmonics_and_phases():
    w, x, phi = sp.symbols("omega x phi", real=True)
    expr = x * sp.cos(w * t) ** 2 + 3 * sp.sin(2 * w * t + phi) + 5
    parts = av.fourier_split(expr, w)
    assert sp.simplify(parts[0][0] - (x / 2 + 5)) == 0
    c2, s2 = parts[2]
    assert sp.simplify(c2 - (x / 2 + 3 * sp.sin(phi))) == 0
    assert sp.simplify(s2 - 3 * sp.cos(phi)) == 0
    assert set(parts) == {0, 2}
    with pytest.raises(ValueError, match="not periodic"):
        av.fourier_split(t * sp.cos(w * t), w)
    with pytest.raises(ValueError, match="whole multiple"):
        av.fourier_split(sp.cos(w * t / 2), w)


@pytest.fixture(scope="session")
def vertical():
    return av.average(problems.driven_pendulum("vertical"))


def test_pendulum_effective_potential_symbolic(vertical):
    m, l, g, A, w = (s for s in vertical.system.parameter_symbols if s.name in "mlgAomega")
    s = {x.name: x for x in vertical.system.parameter_symbols}
    th = vertical.system.q[0]
    expected = (-s["m"] * s["g"] * s["l"] * sp.cos(th)
                + s["m"] * s["A"]**2 * s["omega"]**2 * sp.sin(th)**2 / 4)
    assert sp.simplify(vertical.effective_potential - expected) == 0
    hor = av.average(problems.driven_pendulum("horizontal"))
    expected_h = expected.subs(sp.sin(th), sp.cos(th))
    assert sp.simplify(hor.effective_potential - expected_h) == 0


def _pivot_pendulum(pivot):
    (th,), _ = coordinates("theta")
    m, l, g = sp.symbols("m l g", positive=True)
    bob = Particle(m, (pivot[0] + l * sp.sin(th), pivot[1] - l * sp.cos(th)))
    return System([th], particles=[bob], potential=m * g * bob.position[1]), th, m, l, g


def test_general_drives_direction_ellipse_harmonics():
    A, B, w, phi, dx, dy = sp.symbols("A B omega phi d_x d_y", positive=True)
    # pivot along an arbitrary direction d: U_eff = −mgl cos θ + m A²ω² (d·(cos θ, sin θ))²/4
    sys_, th, m, l, g = _pivot_pendulum((dx * A * sp.cos(w * t), dy * A * sp.cos(w * t)))
    ueff = av.average(sys_).effective_potential
    ref = -m * g * l * sp.cos(th) + m * A**2 * w**2 * (dx * sp.cos(th) + dy * sp.sin(th))**2 / 4
    assert sp.simplify(ueff - ref) == 0
    # elliptic pivot path (A cos ωt, B sin ωt)
    sys_, th, m, l, g = _pivot_pendulum((A * sp.cos(w * t), B * sp.sin(w * t)))
    ueff = av.average(sys_).effective_potential
    ref = -m * g * l * sp.cos(th) + m * w**2 * (A**2 * sp.cos(th)**2 + B**2 * sp.sin(th)**2) / 4
    assert sp.simplify(ueff - ref) == 0
    # two harmonics with a phase: A cos ωt + B cos(2ωt + φ) vertically; each harmonic adds
    # (k²ω² amplitude)² sin²θ / (4 k²ω²), the phase drops out
    sys_, th, m, l, g = _pivot_pendulum((0, A * sp.cos(w * t) + B * sp.cos(2 * w * t + phi)))
    ueff = av.average(sys_).effective_potential
    ref = -m * g * l * sp.cos(th) + m * w**2 * sp.sin(th)**2 * (A**2 + 4 * B**2) / 4
    assert sp.simplify(ueff - ref) == 0


def test_rotating_hoop_centrifugal_potential():
    # bead on a hoop spinning about the vertical: T₀ gives U = −mgR cos θ − ½ m R² ω² sin² θ,
    # equilibria cos θ* = g/(R ω²) when ω² > g/R (a classic, no fast force at all)
    (th,), _ = coordinates("theta")
    m, R, g, w = sp.symbols("m R g omega", positive=True)
    pos = (R * sp.sin(th) * sp.cos(w * t), R * sp.sin(th) * sp.sin(w * t), -R * sp.cos(th))
    hoop = av.average(System([th], particles=[Particle(m, pos)], potential=m * g * pos[2]))
    ref = -m * g * R * sp.cos(th) - m * R**2 * w**2 * sp.sin(th)**2 / 2
    assert sp.simplify(hoop.effective_potential - ref) == 0
    eqs = hoop.equilibria({"m": 1.0, "R": 0.5, "g": G, "omega": 10.0})
    tilted = eqs[(eqs[:, 0] > 0.1) & (eqs[:, 0] < 3)][0, 0]
    assert tilted == pytest.approx(math.acos(G / (0.5 * 100.0)), rel=1e-10)


def test_assumptions_are_checked():
    (th,), (thd,) = coordinates("theta")
    m, l, g, A, w, c = sp.symbols("m l g A omega c", positive=True)
    # length changing with time: M depends on t
    r = (l * (1 + A * sp.cos(w * t)) * sp.sin(th), -l * (1 + A * sp.cos(w * t)) * sp.cos(th))
    with pytest.raises(ValueError, match="mass matrix .* depends on t"):
        av.average(System([th], particles=[Particle(m, r)], potential=m * g * r[1]))
    bob = Particle(m, (l * sp.sin(th), -l * sp.cos(th)))
    with pytest.raises(ValueError, match="velocit"):
        av.average(System([th], particles=[bob], forces={th: c * thd * sp.cos(w * t)}))
    with pytest.raises(ValueError, match="not a parameter"):
        av.average(problems.driven_pendulum("vertical"), frequency="Omega")
    with pytest.raises(ValueError, match="not the gradient"):
        av.average(System([th], particles=[bob], forces={th: c + A * sp.cos(w * t)}))


def test_compiled_gradient_hessian_match_sympy():
    A, w = sp.symbols("A omega", positive=True)
    sys_ = problems.n_link_pendulum(2, pivot=(A * sp.cos(w * t) / 3, A * sp.cos(w * t)))
    avg = av.average(sys_)
    params = {"A": 0.07, "omega": 40.0, "g": G, "l1": 1.0, "l2": 0.6, "m1": 1.0, "m2": 0.4}
    syms = [*sys_.q, *sys_.parameter_symbols]
    U = sp.lambdify(syms, avg.effective_potential, "numpy")
    pv = [params[s.name] for s in sys_.parameter_symbols]
    q0 = np.array([0.4, -1.1])
    val, grad, hess = avg.evaluate(params, q0)
    assert val == pytest.approx(U(*q0, *pv), rel=1e-12)
    h = 1e-5
    for a in range(2):
        e = np.eye(2)[a] * h
        fd = (U(*(q0 + e), *pv) - U(*(q0 - e), *pv)) / (2 * h)
        assert grad[a] == pytest.approx(fd, rel=1e-7)
        ga = avg.evaluate(params, q0 + e)[1] - avg.evaluate(params, q0 - e)[1]
        np.testing.assert_allclose(hess[a], ga / (2 * h), rtol=1e-6)


# -- point 2: the single pendulum ------------------------------------------------------------

def test_kapitza_pendulum_closed_forms_and_general_code(vertical):
    p = KapitzaPendulum()
    A, w = 0.05, 150.0
    theta = np.linspace(-3, 3, 7)
    np.testing.assert_allclose(p.effective_potential(A, w, theta=theta),
                               -G * L * np.cos(theta) + A**2 * w**2 * np.sin(theta)**2 / 4)
    r = p.averaged(A, w)
    assert r.inverted.stable == ((A * w) ** 2 > 2 * G * L)
    assert r.inverted.omega_slow**2 == pytest.approx(A**2 * w**2 / 2 - G)
    assert r.hanging.omega_slow**2 == pytest.approx(G + A**2 * w**2 / 2)
    # the general machinery on problems.driven_pendulum gives the same (M = m l², m = 1)
    pred = vertical.predict(p.params(A, w))
    got = {round(float(e.about[0]), 6): e for e in pred.equilibria}
    # hanging, upright, and the two unstable maxima cos θ = −2gl/(A²ω²) between them
    ts = round(math.acos(-2 * G * L / (A * w) ** 2), 6)
    assert set(got) == {0.0, round(math.pi, 6), ts, -ts}
    assert r.tilted.theta == pytest.approx(ts, abs=1e-6) and not r.tilted.stable
    assert got[ts].omega_squared[0] == pytest.approx(r.tilted.omega_squared, rel=1e-10)
    df = pred.to_dataframe()
    assert len(df) == 4 and df.valid.all() and df.stable.sum() == 2
    assert got[0.0].omega_squared[0] == pytest.approx(r.hanging.omega_squared, rel=1e-12)
    assert got[round(math.pi, 6)].omega_squared[0] == pytest.approx(r.inverted.omega_squared,
                                                                     rel=1e-12)


def test_arrays_match_scalars_and_kapitza_criterion():
    p = KapitzaPendulum(l=0.5, g=9.81)
    A = np.linspace(0.001, 0.1, 41)[:, None]
    w = np.geomspace(20, 400, 37)[None, :]
    r = p.averaged(A, w)
    assert r.inverted.stable.shape == (41, 37)
    np.testing.assert_array_equal(r.inverted.stable, (A * w) ** 2 > 2 * 9.81 * 0.5)
    i, j = 17, 23
    s = p.averaged(float(A[i, 0]), float(w[0, j]), warn=False)
    assert s.inverted.omega_squared == pytest.approx(r.inverted.omega_squared[i, j], rel=1e-14)
    assert r.hanging.omega_slow[i, j] == pytest.approx(s.hanging.omega_slow, rel=1e-14)
    df = r.to_dataframe()
    assert len(df) == 4 * 41 * 37 and {"valid", "omega_slow", "stable"} <= set(df.columns)


def test_horizontal_drive_tilted_equilibria():
    p = KapitzaPendulum(drive="horizontal")
    A, w = 0.05, 120.0
    r = p.averaged(A, w)
    cos_star = 2 * G * L / (A * w) ** 2
    assert r.tilted.exists and r.tilted.stable
    assert math.cos(r.tilted.theta) == pytest.approx(cos_star, rel=1e-12)
    assert r.tilted.omega_slow**2 == pytest.approx((A * w) ** 2 / 2 * (1 - cos_star**2), rel=1e-12)
    assert not r.hanging.stable and not r.inverted.stable
    below = p.averaged(A, 0.5 * math.sqrt(2 * G * L) / A, warn=False)
    assert not below.tilted.exists and below.hanging.stable
    # general code on the same system finds ±θ* with the same slow frequency
    gen = av.average(p.system).predict(p.params(A, w))
    tilted = [e for e in gen.equilibria if 0.1 < abs(e.about[0]) < 3.0]
    assert len(tilted) == 2
    for e in tilted:
        assert abs(e.about[0]) == pytest.approx(r.tilted.theta, rel=1e-10)
        assert e.frequencies[0] == pytest.approx(r.tilted.omega_slow, rel=1e-10)
    # direct simulation of the full equation (PHYSICS.md): started on the averaged
    # equilibrium with Landau's fast response ξ = −(A/l) cos θ* cos ωt, the motion stays
    # centred on θ* (time average over many drive periods)
    th = r.tilted.theta

    def rhs(tt, y):
        return [y[1], -(G * math.sin(y[0]) - A * w**2 * math.cos(w * tt) * math.cos(y[0])) / L]
    T = 2 * math.pi / w
    y0 = [th - A / L * math.cos(th), 0.0]
    sol = solve_ivp(rhs, (0, 40 * T), y0, method="DOP853", rtol=1e-9, atol=1e-12,
                    t_eval=np.linspace(0, 40 * T, 4001))
    assert abs(sol.y[0].mean() - th) < 3e-3
    assert np.ptp(sol.y[0]) < 3 * A / L


# -- point 3: the next order -----------------------------------------------------------------

@pytest.mark.parametrize("sign", [-1, +1], ids=["inverted", "hanging"])
def test_next_order_convergence_against_floquet(sign):
    """Scale A/l ∝ s and ω0/ω ∝ s: first-order error in Ω ∝ s², corrected ∝ s⁴."""
    errs = {1: [], 2: []}
    for s in (1.0, 0.5, 0.25):
        A, w = 0.1 * s, 20 * W0 / s
        exact = exact_slow_frequency(A, w, sign)
        for order in (1, 2):
            r = pcf.pendulum_averaged(A, w, order=order, warn=False)
            eq = r.inverted if sign < 0 else r.hanging
            errs[order].append(abs(eq.omega_slow / exact - 1))
    e1, e2 = np.array(errs[1]), np.array(errs[2])
    if sign < 0:
        assert e1[0] == pytest.approx(0.0057, abs=0.0003)     # the "about 0.6 %"
    np.testing.assert_allclose(e1[:-1] / e1[1:], 4.0, rtol=0.08)    # O(ε²)
    np.testing.assert_allclose(e2[:-1] / e2[1:], 16.0, rtol=0.15)   # O(ε⁴)
    assert np.all(e2 < e1 / 20)
    # the order-1 error estimate predicts the actual error
    r = pcf.pendulum_averaged(0.1, 20 * W0, order=1, warn=False)
    est = (r.inverted if sign < 0 else r.hanging).error_estimate
    assert est == pytest.approx(e1[0], rel=0.05)


def test_corrected_more_accurate_across_regime():
    rng = np.random.default_rng(3)
    for _ in range(6):
        A, w = rng.uniform(0.03, 0.2), W0 * rng.uniform(12, 40)
        if (A * w) ** 2 < 2.6 * G * L:        # stay clear of the Kapitza limit (Ω → 0)
            continue
        exact = exact_slow_frequency(A, w, -1)
        o1 = pcf.pendulum_averaged(A, w, order=1, warn=False).inverted.omega_slow
        o2 = pcf.pendulum_averaged(A, w, order=2, warn=False).inverted.omega_slow
        assert abs(o2 - exact) < abs(o1 - exact) / 5


def test_series_against_scipy_characteristic_values():
    q = np.array([0.1, 0.3, 0.6, 0.9])
    np.testing.assert_allclose(ch.mathieu_b1(q), mathieu_b(1, q), atol=5e-7)
    np.testing.assert_allclose(ch.mathieu_a0(q[:3]), mathieu_a(0, q[:3]), atol=2e-5)


def test_averaging_window_against_exact_boundaries():
    w = np.array([15.0, 30.0, 60.0, 200.0]) * W0
    win2 = pendulum_window(w, method="averaging", order=2)
    win1 = pendulum_window(w, method="averaging", order=1)
    for i, om in enumerate(w):
        a = -4 * W0**2 / om**2
        q_lo = brentq(lambda q, a=a: mathieu_a(0, q) - a, 1e-6, 0.9)
        q_hi = brentq(lambda q, a=a: mathieu_b(1, q) - a, 0.5, 2.0)
        A_lo, A_hi = q_lo * L / 2, q_hi * L / 2
        assert abs(win2.A_min[i] / A_lo - 1) < abs(win1.A_min[i] / A_lo - 1) / 20
        assert win2.A_max[i] == pytest.approx(A_hi, rel=1e-5)
        assert np.isinf(win1.A_max[i])
    assert pendulum_window(1e6 * W0, method="averaging").A_max == pytest.approx(0.4540,
                                                                                abs=1e-4)
    assert list(win2.to_dataframe().columns) == ["omega", "A_min", "A_max", "order"]
    # the order-2 stability flag sees the upper limit, order 1 does not
    w0 = 100 * W0
    above = pcf.pendulum_averaged(0.47, w0, order=2, warn=False).inverted
    assert not above.stable
    assert pcf.pendulum_averaged(0.47, w0, order=1, warn=False).inverted.stable
    assert abs(np.trace(pendulum_monodromy(0.47, w0, -1))) > 2      # exact: unstable
    assert abs(np.trace(pendulum_monodromy(0.44, w0, -1))) < 2
    assert pcf.pendulum_averaged(0.44, w0, order=2, warn=False).inverted.stable


# -- point 5: damping ------------------------------------------------------------------------

@pytest.mark.parametrize("gamma", [0.5, 3.0])
def test_damped_slow_oscillation_against_damped_floquet(gamma):
    A, w = 0.06, 40 * W0
    T = 2 * math.pi / w
    mono = pendulum_monodromy(A, w, -1, gamma=gamma)
    mu = np.linalg.eigvals(mono)
    assert np.prod(mu).real == pytest.approx(math.exp(-gamma * T), rel=1e-9)
    np.testing.assert_allclose(np.abs(mu), math.exp(-gamma * T / 2), rtol=1e-9)
    exact_wd = abs(np.angle(mu[0])) / T
    p = KapitzaPendulum(damping=gamma)
    for order, tol in ((1, 0.02), (2, 5e-4)):
        r = p.averaged(A, w, order=order).inverted
        assert r.decay_rate == pytest.approx(gamma / 2, rel=1e-12)
        assert r.damped_frequency == pytest.approx(exact_wd, rel=tol)
        assert r.damped_frequency**2 == pytest.approx(r.omega_squared - gamma**2 / 4, rel=5e-3)
    # stability limit unchanged by damping (first order)
    und = KapitzaPendulum().averaged(A, w)
    assert p.averaged(A, w).inverted.stable == und.inverted.stable


def test_overdamped_against_damped_floquet():
    A, w, gamma = 0.06, 40 * W0, 12.0       # γ > 2Ω: overdamped, still γ ≪ ω
    mu = np.abs(np.linalg.eigvals(pendulum_monodromy(A, w, -1, gamma=gamma)))
    exact_rate = -math.log(mu.max()) / (2 * math.pi / w)
    for order, tol in ((1, 0.02), (2, 1e-4)):
        r = KapitzaPendulum(damping=gamma).averaged(A, w, order=order).inverted
        assert r.overdamped and r.stable and r.damped_frequency == 0.0 and r.valid
        # the slow decay rate γ/2 − √(γ²/4 − Ω²) ≈ Ω²/γ: order 2 carries the O(γ²/ω²) damping
        # correction of the fast response (a → a − γ²/ω²), order 1 does not
        assert r.decay_rate == pytest.approx(exact_rate, rel=tol)
    r1 = KapitzaPendulum(damping=gamma).averaged(A, w).inverted
    assert r1.decay_rate == pytest.approx(
        gamma / 2 - math.sqrt(gamma**2 / 4 - r1.omega_squared), rel=1e-12)


def test_general_damped_system():
    # the general code with a dissipation function: λ = −γ/2 ± i√(Ω² − γ²/4)
    A, w = 0.06, 40 * W0
    p = KapitzaPendulum(damping=2.0)
    gen = av.average(p.system)
    modes = gen.slow_modes(p.params(A, w), [math.pi])
    ref = p.averaged(A, w).inverted
    assert modes.decay_rate == pytest.approx(1.0, rel=1e-10)
    assert modes.damped_frequencies[0] == pytest.approx(ref.damped_frequency, rel=1e-10)


# -- point 4: the N-link pendulum (Acheson) ---------------------------------------------------

@pytest.fixture(scope="session")
def chain2():
    A, w = sp.symbols("A omega", positive=True)
    return problems.n_link_pendulum(2, pivot=(0, A * sp.cos(w * t)))


def test_double_pendulum_closed_form(chain2):
    mp = pcf.multiple_pendulum_upright([1.0, 1.0], [L, L], g=G)
    assert mp.minimum_drive**2 == pytest.approx((2 + math.sqrt(2)) * G * L, rel=1e-12)
    assert mp.minimum_drive / math.sqrt(G * L) == pytest.approx(1.848, abs=1e-3)
    np.testing.assert_allclose(mp.hanging_frequencies**2,
                               G / L * np.array([2 - 2**0.5, 2 + 2**0.5]))
    # slow modes from the general U_eff Hessian: Ω² = A²ω²/(2λ²) − g/λ, λ = l/(2 ∓ √2)
    A, w = 0.04, 200.0
    modes = av.average(chain2).slow_modes(
        {"A": A, "omega": w, "g": G, "l1": L, "l2": L, "m1": 1.0, "m2": 1.0}, [math.pi, math.pi])
    lam = L / np.array([2 - 2**0.5, 2 + 2**0.5])
    closed = np.sort((A * w) ** 2 / (2 * lam**2) - G / lam)
    np.testing.assert_allclose(modes.omega_squared, closed, rtol=1e-10)
    np.testing.assert_allclose(pcf.multiple_pendulum_upright([1, 1], [L, L], A=A, omega=w)
                               .omega_squared, closed, rtol=1e-10)
    # a sweep over drive arrays with the general code: stable exactly above the minimum drive
    amps = np.array([0.4, 0.9, 1.1, 2.0])[:, None] * math.sqrt((2 + math.sqrt(2)) * G * L) / w
    sw = av.average(chain2).sweep({"A": amps, "omega": np.array([w, 2 * w]), "g": G, "l1": L,
                                   "l2": L, "m1": 1.0, "m2": 1.0}, [math.pi, math.pi])
    assert sw.omega_squared.shape == (4, 2, 2)
    np.testing.assert_array_equal(sw.stable[:, 0], [False, False, True, True])
    np.testing.assert_array_equal(sw.stable[:, 1], [False, True, True, True])   # A ω doubled
    assert len(sw.to_dataframe()) == 8
    # the minimum drive found by the general code: A ω = √((2 + √2) g l)
    A_min = av.average(chain2).minimum_amplitude(
        {"omega": w, "g": G, "l1": L, "l2": L, "m1": 1.0, "m2": 1.0}, [math.pi, math.pi])
    assert A_min * w == pytest.approx(math.sqrt((2 + math.sqrt(2)) * G * L), rel=1e-9)


def test_acheson_theorem_general_chain_matches_general_code():
    A, w = sp.symbols("A omega", positive=True)
    chain = problems.n_link_pendulum(3, pivot=(0, A * sp.cos(w * t)))
    m, ls = [1.0, 0.5, 0.8], [0.7, 1.0, 0.4]
    params = {"A": 0.02, "omega": 300.0, "g": G, **{f"m{i + 1}": m[i] for i in range(3)},
              **{f"l{i + 1}": ls[i] for i in range(3)}}
    # hanging normal modes from lagrange_core's own linearisation (independent of averaging)
    still = problems.n_link_pendulum(3)
    wk = still.normal_modes({k: v for k, v in params.items() if k not in ("A", "omega")})
    mp = pcf.multiple_pendulum_upright(m, ls, g=G, A=params["A"], omega=params["omega"])
    np.testing.assert_allclose(mp.hanging_frequencies, wk, rtol=1e-10)
    modes = av.average(chain).slow_modes(params, [math.pi] * 3, warn=False)
    theorem = (params["A"] * params["omega"]) ** 2 * wk**4 / (2 * G**2) - wk**2
    np.testing.assert_allclose(modes.omega_squared, np.sort(theorem), rtol=1e-9)
    np.testing.assert_allclose(np.sort(mp.omega_squared), np.sort(theorem), rtol=1e-9)
    assert mp.minimum_drive == pytest.approx(math.sqrt(2) * G / wk[0], rel=1e-12)


def _chain_monodromy(chain, params):
    return jacobian_monodromy(chain, params, [math.pi] * chain.n_dof, rtol=1e-10)


def test_double_pendulum_floquet(chain2):
    """Exact multipliers of the linearised time-periodic chain (lagrange_core's Jacobian)."""
    base = {"g": G, "l1": L, "l2": L, "m1": 1.0, "m2": 1.0}
    A = 0.02
    drive_min = pcf.multiple_pendulum_upright([1, 1], [L, L], g=G).minimum_drive
    results = {}
    for factor in (0.9, 1.3):
        w = factor * drive_min / A
        mu = np.linalg.eigvals(_chain_monodromy(chain2, {**base, "A": A, "omega": w}))
        results[factor] = (w, mu)
    assert np.max(np.abs(results[0.9][1])) > 1.01                  # below the minimum: falls
    w, mu = results[1.3]
    np.testing.assert_allclose(np.abs(mu), 1.0, atol=1e-7)          # above: upright holds
    exact = np.sort(np.abs(np.angle(mu)))[::2] / (2 * math.pi / w)  # slow Ω_k from the multipliers
    for order, tol in ((1, 0.03), (2, 2e-3)):
        pred = pcf.multiple_pendulum_upright([1, 1], [L, L], g=G, A=A, omega=w, order=order)
        np.testing.assert_allclose(np.sqrt(np.sort(pred.omega_squared)), exact, rtol=tol)
    # the upper limit: A < 0.4540 g/ω_max² (fastest hanging mode) at high ω
    mp = pcf.multiple_pendulum_upright([1, 1], [L, L], g=G)
    A_max = 0.4540 * G / mp.hanging_frequencies[-1] ** 2
    w = 60 * mp.hanging_frequencies[-1]
    for factor, stable in ((0.95, True), (1.05, False)):
        mu = np.linalg.eigvals(_chain_monodromy(chain2, {**base, "A": factor * A_max, "omega": w}))
        assert (np.max(np.abs(mu)) < 1 + 1e-6) == stable
        pred = pcf.multiple_pendulum_upright([1, 1], [L, L], g=G, A=factor * A_max, omega=w,
                                            order=2, warn=False)
        assert bool(pred.stable) == stable
    assert len(pred.to_dataframe()) == 2 and len(mp.to_dataframe()) == 2


# -- point 6: validity -----------------------------------------------------------------------

def test_validity_flags_and_warnings():
    p = KapitzaPendulum()
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        ok = p.averaged(0.05, 200.0)                          # deep in the regime: silent
    assert ok.valid
    with pytest.warns(av.AveragingValidityWarning, match="A/l"):
        big = p.averaged(0.45, 200.0)
    assert not big.inverted.small_amplitude and not big.inverted.valid
    with pytest.warns(av.AveragingValidityWarning, match="slow frequencies"):
        slow = p.averaged(0.2, 12.0)
    assert not slow.hanging.fast_drive
    A = np.linspace(0.01, 0.5, 50)[:, None]
    w = np.geomspace(5, 500, 60)[None, :]
    with warnings.catch_warnings():
        warnings.simplefilter("error")                        # arrays: flags, no warning
        grid = p.averaged(A, w)
    v = grid.inverted.valid
    assert v.shape == (50, 60) and v.any() and not v.all()
    ratio = w / np.maximum(W0, np.sqrt(np.abs(grid.inverted.omega_squared)))
    np.testing.assert_array_equal(v, (A / L <= av.MAX_AMPLITUDE_RATIO)
                                  & (ratio >= av.MIN_FREQUENCY_RATIO)
                                  & (grid.inverted.error_estimate <= pcf.MAX_CORRECTION))
    # near the Kapitza limit Ω → 0: fast drive and small A, but flagged (not converged)
    w_k = math.sqrt(2 * G * L) / 0.1
    with pytest.warns(av.AveragingValidityWarning, match="next-order correction"):
        near = p.averaged(0.1, 1.003 * w_k)
    assert near.inverted.fast_drive and near.inverted.small_amplitude
    assert not near.inverted.converged and not near.inverted.valid
    # where flagged valid, order 1 is within 7.5 % and order 2 within 1.6 % of exact Floquet
    rng = np.random.default_rng(11)
    checked = 0
    for A1, w1 in zip(rng.uniform(0.01, 0.3, 40),
                      np.exp(rng.uniform(math.log(10), math.log(300), 40)), strict=True):
        for order, tol in ((1, 0.075), (2, 0.016)):
            r = p.averaged(A1, w1, order=order, warn=False).inverted
            if r.valid and r.stable:
                ex = exact_slow_frequency(A1, w1, -1)
                assert abs(r.omega_slow / ex - 1) < tol
                checked += 1
    assert checked > 10
    # general code: flags on SlowModes and a warning
    gen = av.average(p.system)
    with pytest.warns(av.AveragingValidityWarning):
        modes = gen.slow_modes(p.params(0.4, 20.0), [math.pi])
    assert not modes.valid and modes.reasons


def test_bad_input_messages():
    with pytest.raises(ValueError, match="omega must be finite and > 0"):
        pcf.pendulum_averaged(0.1, -3.0)
    with pytest.raises(ValueError, match="order=2"):
        pcf.pendulum_averaged(0.1, 100.0, drive="horizontal", order=2)
    with pytest.raises(ValueError, match="not an equilibrium"):
        av.average(problems.driven_pendulum("vertical")).slow_modes(
            KapitzaPendulum().params(0.1, 100.0), [1.0])
    with pytest.raises(ValueError, match="same length"):
        pcf.multiple_pendulum_upright([1, 1], [1])


def test_damped_kapitza_limit_against_damped_floquet():
    """With damping the exact lower limit is where a multiplier reaches 1 (|μ|max = 1)."""
    w = 30 * W0
    gamma = 0.1 * w
    def growth(A):
        return np.max(np.abs(np.linalg.eigvals(pendulum_monodromy(A, w, -1, gamma=gamma)))) - 1
    exact = brentq(growth, 0.5 * math.sqrt(2 * G * L) / w, 2 * math.sqrt(2 * G * L) / w, xtol=1e-12)
    first = pendulum_window(w, method="averaging", damping=gamma, order=1)
    second = pendulum_window(w, method="averaging", damping=gamma, order=2)
    # order 1: damping does not move the limit, error O(ε²) + O(γ²/ω²);
    # order 2: includes the (γ/ω)² weakening of the fast response, error O(ε⁴)
    assert first.A_min == pytest.approx(math.sqrt(2 * G * L) / w)
    assert abs(second.A_min / exact - 1) < abs(first.A_min / exact - 1) / 10
    assert second.A_min == pytest.approx(exact, rel=2e-4)
