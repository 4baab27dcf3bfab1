"""Floquet analysis (issue 5): Mathieu characteristic values, monodromy, windows, maps.

Independent references: scipy.special.mathieu_a/b, scipy.linalg.eigvalsh_tridiagonal,
the small-q series of a0 (DLMF 28.6.1), scipy.integrate.solve_ivp (DOP853, rtol 1e-12)
on the original (damped) equations (tests/helpers.py), and the first-order averaging
closed forms.
"""
import math

import numpy as np
import pytest
import scipy.linalg
import scipy.special
import sympy as sp

from kapitza import floquet as fq
from kapitza.closed_forms import _mathieu as mm
from kapitza.figures import _plots as plots
from kapitza.floquet._multipliers import _analyse
from kapitza.pendulum import KapitzaPendulum
from lagrange_core import problems
from lagrange_core import t as t_sym

from helpers import W0, G, L, jacobian_monodromy, mathieu_ivp_trace, mathieu_mpmath_trace


@pytest.fixture(scope="session")
def pendulum():
    return KapitzaPendulum(l=L, g=G)


@pytest.fixture(scope="session")
def damped():
    return KapitzaPendulum(l=L, g=G, damping=0.8)


@pytest.fixture(scope="session")
def double_pendulum():
    A, w = sp.symbols("A omega", positive=True)
    return problems.n_link_pendulum(2, pivot=(0, A * sp.cos(w * t_sym)))


DP = {"g": G, "l1": 1.0, "l2": 1.0, "m1": 1.0, "m2": 1.0}


# -- 2. Mathieu characteristic values --------------------------------------------------

def test_characteristic_values_match_scipy():
    q = np.linspace(0.0, 15.0, 61)
    for r in range(0, 5):
        ref = scipy.special.mathieu_a(r, q)
        got = mm.characteristic_value("a", r, q)
        assert np.max(np.abs(got - ref) / np.maximum(1, np.abs(ref))) < 1e-12
        if r >= 1:
            ref = scipy.special.mathieu_b(r, q)
            got = mm.characteristic_value("b", r, q)
            assert np.max(np.abs(got - ref) / np.maximum(1, np.abs(ref))) < 1e-12


def test_characteristic_values_on_threads_and_on_the_caller_s_are_the_same():
    """A few values are computed on the calling thread, many on numba's threads
    (``_SERIAL_BELOW``): the same numbers bit for bit, each matching scipy's."""
    from kapitza.closed_forms import _characteristic as cv
    for n in (cv._SERIAL_BELOW - 1, cv._SERIAL_BELOW, 300):
        q = np.linspace(0.0, 15.0, n)
        for kind, r in (("a", 0), ("b", 1), ("a", 3)):
            parallel = cv._char_values(kind == "b", r, q)
            serial = cv._char_values_serial(kind == "b", r, q)
            assert np.array_equal(parallel, serial), (n, kind, r)
            ref = (scipy.special.mathieu_b if kind == "b" else scipy.special.mathieu_a)(r, q)
            got = mm.characteristic_value(kind, r, q)
            assert np.array_equal(got, serial)
            assert np.max(np.abs(got - ref) / np.maximum(1, np.abs(ref))) < 1e-12


def test_characteristic_values_where_scipy_fails():
    # scipy.special.mathieu_a(5, 20.9) returns 15.03; the tridiagonal problem (LAPACK,
    # 80 rows) and ours give 37.3836...
    K = 80
    d = (2 * np.arange(K) + 1.0) ** 2
    d[0] += 20.9
    ref = scipy.linalg.eigvalsh_tridiagonal(d, np.full(K - 1, 20.9))[2]
    assert mm.characteristic_value("a", 5, 20.9) == pytest.approx(ref, rel=1e-13)
    assert abs(scipy.special.mathieu_a(5, 20.9) - ref) > 1.0
    for q in (40.0, 90.0):
        d = (2.0 * np.arange(K)) ** 2
        e = np.full(K - 1, q)
        e[0] *= math.sqrt(2)
        ref = scipy.linalg.eigvalsh_tridiagonal(d, e)[:3]
        got = [mm.characteristic_value("a", r, q) for r in (0, 2, 4)]
        assert np.allclose(got, ref, rtol=1e-13, atol=1e-12)


def test_a0_small_q_keeps_relative_accuracy():
    q = np.array([1e-6, 1e-4, 1e-3, 1e-2])
    series = -q**2 / 2 + 7 * q**4 / 128 - 29 * q**6 / 2304     # DLMF 28.6.1
    got = mm.characteristic_value("a", 0, q)
    assert np.all(np.abs(got / series - 1) < 1e-13)


def test_characteristic_curves_are_floquet_boundaries():
    # tr M = +2 on a0 (period π = T), −2 on b1, a1 (period 2π = 2T)
    for q in (0.3, 2.0, 6.0):
        for kind, r, target in (("a", 0, 2.0), ("b", 1, -2.0), ("a", 1, -2.0), ("b", 2, 2.0)):
            a = mm.characteristic_value(kind, r, q)
            assert mm.mathieu_trace(a, q) == pytest.approx(target, abs=1e-9)


def test_mathieu_trace_error_bounds_its_error_against_mpmath():
    """The trace's reported error (relative to max(1, |tr|)) bounds its error against a
    20-digit reference, and meets the tolerance asked for: inside a window, on a tongue,
    deep in one (|tr| ~ 1e5), at a higher a, and where the solutions swing to ~50 within
    the period (there the float π/2 at which the steps ended moved the trace by 6e-14
    relative, under a reported 4e-15: the run now ends at π/2 exactly; measured 7e-15)."""
    for a, q in ((1.3, 0.7), (25.0, 3.0), (-4.0, 1.0), (-17.4, 16.0),
                 (-0.7729394600516883, 8.47555926021747)):
        ref = mathieu_mpmath_trace(a, q)
        for tol in (1e-8, 1e-12):
            tr, _, err = mm.mathieu_monodromy_trace(a, q, tol=tol)
            assert err <= tol, (a, q, tol, err)
            assert abs(tr - ref) / max(1.0, abs(ref)) <= err, (a, q, tol, tr, ref, err)


@pytest.mark.parametrize("max_steps", [16, 1 << 20])
def test_a_trace_short_of_its_tolerance_warns_and_its_error_still_bounds_it(max_steps):
    """tol 1e-15 lies below the trace's rounding floor (1.6e-14): the refinement stops at
    the step limit (16 steps: the first pair of runs) or where the difference stops
    shrinking.  The trace is returned with its error, which bounds the error against the
    20-digit reference, and a RuntimeWarning says so (it returned silently before)."""
    a, q = 25.0, 3.0
    ref = mathieu_mpmath_trace(a, q)
    with pytest.warns(RuntimeWarning, match=r"1 of 1 traces did not reach tol=1e-15.*"
                                            rf"max_steps={max_steps}"):
        tr, _, err = mm.mathieu_monodromy_trace(a, q, tol=1e-15, max_steps=max_steps)
    assert err > 1e-15
    assert abs(tr - ref) / max(1.0, abs(ref)) <= err, (tr, ref, err)


def test_mathieu_trace_with_damping_against_solve_ivp():
    # the library removes damping by y = e^(−cτ/2) u; the reference keeps c y′
    for a, q, c in ((-0.2, 0.6, 0.0), (0.7, 1.3, 0.3), (-1.0, 3.0, 1.5), (2.5, 0.4, 0.05)):
        assert mm.mathieu_trace(a, q, c) == pytest.approx(mathieu_ivp_trace(a, q, c),
                                                          rel=1e-9, abs=1e-10)


def test_mapping_to_mathieu(pendulum, damped):
    # the general monodromy of the system's Jacobian equals the Mathieu trace of the mapping
    for p in (pendulum, damped):
        for about, A, w in (("inverted", 0.1, 60.0), ("inverted", 0.5, 40.0),
                            ("hanging", 0.3, 7.0), ("hanging", 0.05, 6.2)):
            r = p.floquet(A, w, about=about, tol=1e-11)
            a, q, c = mm.mathieu_parameters(A, w, p.l, p.g, p.damping, about)
            assert r.trace == pytest.approx(mm.mathieu_trace(a, q, c), rel=1e-8, abs=1e-9)
            assert r.flags == ()


def test_ince_strutt_chart_renders():
    from matplotlib.figure import Figure
    fig = plots.ince_strutt_figure(mm.ince_strutt_chart(q_max=10, a_range=(-10, 20), n=60))
    assert isinstance(fig, Figure) and len(fig.axes[0].lines) == 11      # a0..a5, b1..b5


# -- 1. general Floquet: guards, slow frequency, accuracy control ------------------------

def test_liouville_det_equals_exp_minus_gamma_T(damped):
    r = damped.floquet(0.2, 50.0)
    T = 2 * np.pi / 50.0
    assert np.prod(r.multipliers).real == pytest.approx(math.exp(-damped.damping * T), rel=1e-9)
    assert r.liouville_residual < 1e-9 and r.flags == ()
    assert math.isnan(r.pairing_residual)            # damped: no λ, 1/λ symmetry


def test_pairs_and_broken_monodromy_is_flagged():
    # a symplectic 4 × 4 monodromy passes; a perturbed one (det ≠ 1, no pairs) is flagged
    rng = np.random.default_rng(5)
    H = rng.normal(size=(4, 4))
    Jst = np.block([[np.zeros((2, 2)), np.eye(2)], [-np.eye(2), np.zeros((2, 2))]])
    M = scipy.linalg.expm(Jst @ (H + H.T) * 0.3)
    T = np.array([1.0, 1.0])
    Ms = np.stack([M, M + 1e-5 * rng.normal(size=(4, 4))])
    res = _analyse(Ms, np.zeros(2), T, np.zeros(2), np.full(2, 1e-12), 1e-8)
    assert res["flags"][0] == ()
    assert res["pairing"][0] < 1e-12
    assert any("Liouville" in f for f in res["flags"][1])
    assert any("pairs" in f for f in res["flags"][1])


def test_omega_slow_exact_and_against_averaging(pendulum):
    w = 200 * W0
    A = 0.05
    r = pendulum.floquet(A, w)
    assert r.stable
    # exact: cos(πβ) = tr M / 2, Ω = β ω / 2 (independent trace from the Mathieu integrator)
    a, q, _ = mm.mathieu_parameters(A, w, L, G, 0.0, "inverted")
    beta = math.acos(mm.mathieu_trace(a, q) / 2) / math.pi
    assert r.omega_slow == pytest.approx(beta * w / 2, rel=1e-9)
    # first-order averaging: Ω² = A²ω²/(2l²) − g/l, to O((A/l)², (ω0/ω)²)
    Omega_av = math.sqrt(A**2 * w**2 / (2 * L**2) - G / L)
    assert r.omega_slow == pytest.approx(Omega_av, rel=3e-3)


@pytest.mark.parametrize("tol", [1e-6, 1e-9, 1e-12])
def test_tolerance_is_met_and_reported(pendulum, tol):
    A, w = 0.3, 30.0
    r = pendulum.floquet(A, w, tol=tol)
    a, q, _ = mm.mathieu_parameters(A, w, L, G, 0.0, "inverted")
    exact = mathieu_ivp_trace(a, q)
    assert abs(r.trace - exact) <= max(2 * r.error_estimate * max(1, abs(exact)), 2e-12)
    assert r.error_estimate <= 20 * tol


# -- 3. KapitzaPendulum entry points ----------------------------------------------------

def test_stability_window_against_scipy_characteristic_values(pendulum):
    from scipy.optimize import brentq
    w = np.array([8.0, 15.0, 40.0, 120.0]) * W0
    win = pendulum.window(w, tol=1e-10)
    for i, om in enumerate(w):
        a = -4 * W0**2 / om**2
        q0 = brentq(lambda q, a=a: scipy.special.mathieu_a(0, q) - a, 1e-9, 3, xtol=1e-15)
        q1 = brentq(lambda q, a=a: scipy.special.mathieu_b(1, q) - a, 1e-9, 3, xtol=1e-15)
        assert win.A_min[i] == pytest.approx(q0 * L / 2, rel=1e-9)
        assert win.A_max[i] == pytest.approx(q1 * L / 2, rel=1e-9)
    assert np.all(win.accuracy <= 1e-10)
    assert list(win.to_dataframe().columns) == ["omega", "A_min", "A_max", "accuracy"]


def test_stability_window_high_frequency_limits(pendulum):
    # ω/ω0 = 1e4: A_min from the a0 series, A_max → 0.4540 l (first parametric resonance)
    w = 1e4 * W0
    win = pendulum.window(w)
    a = -4 * W0**2 / w**2
    q = math.sqrt(-2 * a)
    for _ in range(5):                       # a = −q²/2 + 7q⁴/128 solved for q
        q = math.sqrt(2 * (-a + 7 * q**4 / 128))
    assert win.A_min == pytest.approx(q * L / 2, rel=1e-10)
    assert win.A_max == pytest.approx(0.4540, abs=1e-4)


def test_damped_window_is_the_floquet_condition(damped):
    w = np.array([10.0, 30.0]) * W0
    win = damped.window(w, tol=1e-9)
    for i, om in enumerate(w):
        T = 2 * np.pi / om
        thr = 1 + math.exp(-damped.damping * T)
        for A in (win.A_min[i], win.A_max[i]):
            a, q, c = mm.mathieu_parameters(A, om, L, G, damped.damping, "inverted")
            assert abs(mathieu_ivp_trace(a, q, c)) == pytest.approx(thr, rel=1e-8)
    # damping shrinks the period-2T resonance tongue above the window
    und = KapitzaPendulum(l=L, g=G).window(w)
    assert np.all(win.A_max > und.A_max)


def test_map_sample_against_monodromy_and_boundary_points(pendulum, rng):
    A = np.linspace(0.0, 0.7, 1000)
    w = np.linspace(2.0, 400.0, 1000) * W0
    m = pendulum.stability_map(A, w)
    assert m.stable.shape == (1000, 1000) and m.method == "characteristic values"
    # random sample: classification and label against the monodromy trace (tight tolerance)
    i = rng.integers(0, 1000, 150)
    j = rng.integers(0, 1000, 150)
    a, q, _ = mm.mathieu_parameters(A[i], w[j], L, G, 0.0, "inverted")
    tr, _, _ = mm.mathieu_monodromy_trace(a, q, tol=1e-13)
    assert np.array_equal(m.stable[i, j], np.abs(tr) < 2)
    unstable = ~m.stable[i, j]
    assert np.array_equal(m.label[i, j][unstable], np.where(tr[unstable] > 0, 1, 2))
    # points within 1e-6 (relative) of both boundaries, on either side
    ws = np.array([3.0, 20.0, 150.0, 1e4]) * W0
    win = pendulum.window(ws)
    for k, om in enumerate(ws):
        for edge, inside in ((win.A_min[k], 1 + 1e-6), (win.A_max[k], 1 - 1e-6)):
            pts = np.array([edge * inside, edge * (2 - inside)])
            mk = pendulum.stability_map(pts, [om])
            assert mk.stable[:, 0].tolist() == [True, False]
            a, q, _ = mm.mathieu_parameters(pts, om, L, G, 0.0, "inverted")
            tr, _, _ = mm.mathieu_monodromy_trace(a, q, tol=2e-14)   # (the floor: 1.6e-14)
            assert (np.abs(tr) < 2).tolist() == [True, False]


def test_map_dataframe_and_figure(pendulum, tmp_path):
    from matplotlib.figure import Figure
    m = pendulum.stability_map(np.linspace(0, 0.6, 40), np.linspace(3, 200, 50))
    df = m.to_dataframe()
    assert len(df) == 2000 and set(df.boundary) <= {"stable", "T", "2T"}
    averaging = pendulum.window(np.linspace(3, 200, 400), method="averaging", order=1)
    fig = plots.stability_map_figure(m, overlays=[averaging])
    assert isinstance(fig, Figure)
    assert any("averaging" in (ln.get_label() or "") for ln in fig.axes[0].lines)
    fig.savefig(tmp_path / "map.png")


def test_trace_map_matches_pointwise(pendulum):
    A = np.array([0.05, 0.3, 0.6])
    w = np.array([20.0, 80.0])
    m = pendulum.stability_map(A, w, trace=True)
    for i, Ai in enumerate(A):
        for j, wj in enumerate(w):
            assert m.trace[i, j] == pytest.approx(pendulum.floquet(Ai, wj).trace, rel=1e-8)
    assert np.array_equal(m.stable, np.abs(m.trace) < 2)


# -- 5. hard cases ---------------------------------------------------------------------

def test_deep_tongue_growth_in_log_form(pendulum):
    # q = 2A/l = 400: the multiplier is ~1e30 per period here and e^(hundreds) further in
    A, w = 200.0, 20.0
    r = pendulum.floquet(A, w, tol=1e-10)
    a, q, _ = mm.mathieu_parameters(A, w, L, G, 0.0, "inverted")
    tr, log_tr, _ = mm.mathieu_monodromy_trace(a, q, tol=1e-12)
    assert not r.stable and math.isfinite(r.log_growth)
    assert r.log_growth == pytest.approx(float(log_tr), rel=1e-9)     # |λ| ≈ |tr| when huge
    # far deeper: |λ| ~ e^1500 (1e658), beyond float range; no overflow, two methods agree
    A2 = 4e5
    r2 = pendulum.floquet(A2, w, tol=1e-10)
    _, log2, _ = mm.mathieu_monodromy_trace(*mm.mathieu_parameters(A2, w, L, G, 0.0,
                                                                    "inverted")[:2], tol=1e-12)
    assert r2.log_growth > 1000 and r2.log_growth == pytest.approx(float(log2), rel=1e-9)
    assert np.isinf(r2.trace) and not r2.stable and r2.boundary in ("T", "2T")
    m = pendulum.stability_map([A2], [w], trace=True)
    assert m.log_growth[0, 0] == pytest.approx(r2.log_growth, rel=1e-9)


def test_heavy_damping(rng):
    # γ = 3 ω0: check the general path, the Mathieu path and the ODE as written
    p = KapitzaPendulum(l=L, g=G, damping=3 * W0)
    for A, w in ((0.2, 25.0), (0.02, 30.0), (0.7, 40.0)):
        r = p.floquet(A, w)
        a, q, c = mm.mathieu_parameters(A, w, L, G, p.damping, "inverted")
        ref = mathieu_ivp_trace(a, q, c)
        assert r.trace == pytest.approx(ref, rel=1e-8, abs=1e-10)
        assert r.stable == (abs(ref) < 1 + math.exp(-p.damping * 2 * np.pi / w))
        assert r.liouville_residual < 1e-9
    m = p.stability_map(np.linspace(0.0, 0.8, 7), np.linspace(20, 60, 5))
    for i, A in enumerate(m.A):
        for j, w in enumerate(m.omega):
            assert m.stable[i, j] == p.floquet(A, w).stable


# -- 6. general systems: the double pendulum ---------------------------------------------

def double_ivp_monodromy(system, params):
    return jacobian_monodromy(system, params, [np.pi, np.pi], rtol=1e-11)


def test_double_pendulum_monodromy_against_solve_ivp(double_pendulum):
    for A, w in ((0.05, 150.0), (0.15, 60.0), (0.3, 40.0)):
        p = dict(DP, A=A, omega=w)
        r = fq.floquet_point(double_pendulum, p, [np.pi, np.pi], tol=1e-10)
        M = double_ivp_monodromy(double_pendulum, p)
        assert np.allclose(r.monodromy, M, rtol=1e-7, atol=1e-7 * np.max(np.abs(M)))
        lam = np.linalg.eigvals(M)
        assert r.stable == bool(np.max(np.abs(lam)) < 1 + 1e-6)
        assert r.pairing_residual < 1e-8 and r.flags == ()


def test_double_pendulum_map(double_pendulum):
    A = np.linspace(0.0, 0.3, 10)
    w = np.linspace(20.0, 150.0, 8)
    m = fq.stability_map(double_pendulum, DP, [np.pi, np.pi], A=A, omega=w, tol=1e-9)
    assert m.stable.shape == (10, 8) and m.flagged_points == 0
    assert not m.stable[0].any()                  # no drive: the upright state falls
    assert m.stable.any()                         # Acheson: a window exists
    # classification against solve_ivp at a few points, stable and unstable
    for i, j in ((3, 5), (5, 7), (9, 0), (1, 2)):
        M = double_ivp_monodromy(double_pendulum, dict(DP, A=A[i], omega=w[j]))
        assert m.stable[i, j] == bool(np.max(np.abs(np.linalg.eigvals(M))) < 1 + 1e-6)
    assert set(m.to_dataframe().columns) >= {"A", "omega", "stable", "boundary", "trace"}


# -- errors ----------------------------------------------------------------------------

def test_bad_input_is_explained(pendulum, double_pendulum):
    with pytest.raises(ValueError, match="about"):
        pendulum.floquet(0.1, 50.0, about="sideways")
    # the horizontal drive's states are periodic orbits (kapitza.periodic_orbit): the
    # upright one is unstable, an unknown state is refused naming those that exist
    assert not KapitzaPendulum(drive="horizontal").floquet(0.1, 50.0).stable
    with pytest.raises(ValueError, match="'tilted', 'tilted-', 'hanging' or 'inverted'"):
        KapitzaPendulum(drive="horizontal").floquet(0.1, 50.0, about="sideways")
    with pytest.raises(ValueError, match="does not persist"):
        fq.floquet_point(pendulum.system, pendulum.params(0.1, 50.0), [1.0])
    with pytest.raises(ValueError, match="tol"):
        pendulum.floquet(0.1, 50.0, tol=0.0)
    with pytest.raises(ValueError, match="omega"):
        pendulum.stability_map([0.1], [-3.0])
    with pytest.raises(ValueError, match="missing"):
        fq.floquet_point(double_pendulum, {"A": 0.1, "omega": 50.0}, [np.pi, np.pi])
    with pytest.raises(ValueError, match="kind"):
        mm.characteristic_value("c", 0, 1.0)


def test_hanging_map_tongues(pendulum, rng):
    # parametric resonance of the hanging pendulum: tongues at ω = 2ω0/r, period 2T for odd r
    A = np.linspace(0.0, 3.0, 300)
    w = np.linspace(0.5, 12.0, 300)
    m = pendulum.stability_map(A, w, about="hanging")
    i, j = rng.integers(0, 300, 300), rng.integers(0, 300, 300)
    a, q, _ = mm.mathieu_parameters(A[i], w[j], L, G, 0.0, "hanging")
    tr, _, _ = mm.mathieu_monodromy_trace(a, q, tol=1e-13)
    assert np.array_equal(m.stable[i, j], np.abs(tr) < 2)
    unstable = ~m.stable[i, j]
    assert np.array_equal(m.label[i, j][unstable], np.where(tr[unstable] > 0, 1, 2))
    # at ω = 2ω0 (a = 1) and ω = ω0 (a = 4) small drives sit inside the tongues
    # (b1 < 1 < a1, b2 = 4 − q²/12 < 4 < a2 = 4 + 5q²/12); the r = 3 tongue is shifted by q²/16
    small = pendulum.stability_map([0.05], [2 * W0, W0, 2 * W0 / 3], about="hanging")
    assert small.label[0].tolist() == [2, 1, 0]


def test_general_path_at_high_frequency_ratio(pendulum):
    # ω/ω0 = 1e3, A = 2 A_min: the monodromy is within 1e-5 of the identity
    w = 1e3 * W0
    A = 2 * pendulum.window(w).A_min
    r = pendulum.floquet(A, w, tol=1e-12)
    a, q, _ = mm.mathieu_parameters(A, w, L, G, 0.0, "inverted")
    assert r.trace == pytest.approx(mm.mathieu_trace(a, q, tol=2e-14), abs=1e-11)
    assert r.stable and r.boundary == "stable"
    Omega_av = math.sqrt(A**2 * w**2 / (2 * L**2) - G / L)
    assert r.omega_slow == pytest.approx(Omega_av, rel=1e-3)
    df = r.to_dataframe()
    assert len(df) == 2 and np.allclose(df["abs"], 1.0, atol=1e-9)
