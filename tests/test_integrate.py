"""Integrators and System.simulate against closed forms, scipy and each other.

Problems with exact solutions come first (harmonic oscillator, pendulum period
from the complete elliptic integral), with one ``compute_error`` helper; the
method tests are parametrized over the registry.
"""
from __future__ import annotations

import math
import signal
from fractions import Fraction

import numpy as np
import pytest
import sympy as sp
from scipy.integrate import solve_ivp
from scipy.special import ellipk

from lagrange_core import Particle, System, coordinates, problems
from lagrange_core.integrate import (
    METHODS,
    SimulationInterrupted,
    crossing,
    multiplier_zero,
    rkn_eligibility,
    turning_point,
)
from lagrange_core.integrator_tables import rkn12_table

# -- problems with exact solutions --------------------------------------------------------

HO = dict(m=2.0, k=8.0)            # ω = 2 rad/s
HO_Q0, HO_V0 = 0.7, -0.3
PEND = dict(g=9.81, l=1.3, m=0.5)
PEND_THETA0 = 2.0                  # large amplitude: far from the harmonic limit


def harmonic_oscillator():
    (x,), (x_dot,) = coordinates("x")
    m, k = sp.symbols("m k", positive=True)
    return System([x], lagrangian=m * x_dot**2 / 2 - k * x**2 / 2, name="harmonic oscillator")


def ho_exact(t):
    w = math.sqrt(HO["k"] / HO["m"])
    q = HO_Q0 * np.cos(w * t) + HO_V0 / w * np.sin(w * t)
    v = -HO_Q0 * w * np.sin(w * t) + HO_V0 * np.cos(w * t)
    return q[:, None], v[:, None]


def pendulum_period(theta0=PEND_THETA0):
    """T = 4 K(k²) / ω0 with k = sin(θ0/2) (scipy's ellipk takes m = k²)."""
    return 4 * ellipk(math.sin(theta0 / 2) ** 2) / math.sqrt(PEND["g"] / PEND["l"])


def compute_error(traj, exact):
    """Largest deviation of q and q̇ from ``exact(t) -> (q, qdot)`` over the stored times."""
    q, v = exact(traj.t)
    return max(np.max(np.abs(traj.q - q)), np.max(np.abs(traj.qdot - v)))


def cartesian_pendulum():
    """The pendulum stated in x, y with the constraint x² + y² − l² = 0."""
    x, y = sp.symbols("x y", real=True)
    m, g, l = sp.symbols("m g l", positive=True)
    return System([x, y], particles=[Particle(m, (x, y))], potential=m * g * y,
                  constraints=[x**2 + y**2 - l**2], name="cartesian pendulum")


def polar_free_particle():
    """A free particle in polar coordinates: M = diag(m, m r²) is singular at r = 0."""
    (r, phi), _ = coordinates("r phi")
    m = sp.Symbol("m", positive=True)
    return System([r, phi], particles=[Particle(m, (r * sp.cos(phi), r * sp.sin(phi)))],
                  name="polar particle")


@pytest.fixture(scope="session")
def systems():
    """Compile (or load from the disk cache) every system and integrator used here, once."""
    s = {"ho": harmonic_oscillator(), "pendulum": problems.pendulum(),
         "driven": problems.driven_pendulum(), "cart": cartesian_pendulum(),
         "double": problems.double_pendulum(), "polar": polar_free_particle()}
    warm = {"ho": (HO, ["dop853", "rkn12", "rkn12-fixed", "yoshida6", "rk8"]),
            "pendulum": (PEND, ["dop853", "rkn12", "rkn12-fixed", "yoshida6"]),
            "cart": (dict(PEND), ["dop853"]), "double": (None, ["dop853"]),
            "driven": (DRIVEN, ["rkn12-fixed", "yoshida6"])}
    for key, (params, methods) in warm.items():
        sys_ = s[key]
        if params is None:
            params = dict(g=9.81, l1=1.0, l2=1.0, m1=1.0, m2=1.0)
        q0 = [0.6, 0.8] if key == "cart" else [0.1] * sys_.n_dof
        for meth in methods:
            sys_.simulate(q0, [0.0] * sys_.n_dof, (0.0, 0.01), params, method=meth, h=1e-3,
                          events=[turning_point(sys_.coordinates[0])])
            if meth.startswith("rkn"):
                sys_.simulate(q0, [0.0] * sys_.n_dof, (0.0, 0.01), params, method=meth, h=1e-3)
    return s


# -- the RKN 12(10) table (exact arithmetic) ---------------------------------------------

def test_rkn12_table_satisfies_its_order_conditions():
    tab = rkn12_table(exact=True)
    c, A = tab["c"], tab["A"]
    for i in range(17):
        assert abs(sum(A[i]) - c[i] ** 2 / 2) < Fraction(1, 10**40), f"row {i + 1}"
    # quadrature conditions: position weights order 12 (10), velocity weights order 12 (10)
    for k in range(11):
        assert (sum(b * ci**k for b, ci in zip(tab["b"], c, strict=True))
                == Fraction(1, (k + 1) * (k + 2)))
    for k in range(12):
        assert sum(b * ci**k for b, ci in zip(tab["bp"], c, strict=True)) == Fraction(1, k + 1)
    for k in range(9):
        assert (sum(b * ci**k for b, ci in zip(tab["bh"], c, strict=True))
                == Fraction(1, (k + 1) * (k + 2)))
    for k in range(10):
        assert sum(b * ci**k for b, ci in zip(tab["bph"], c, strict=True)) == Fraction(1, k + 1)
    # and the embedded pair really differs (an error estimate that is not identically zero)
    assert sum(abs(b - bh) for b, bh in zip(tab["b"], tab["bh"], strict=True)) > 0


def test_dop853_table_read_from_scipys_file_is_scipys(monkeypatch):
    """DOP853's table is read from scipy's module file (not importing scipy.integrate's
    package): the same arrays, to the bit, as the module imported by name, contiguous
    float64; and the same where the file cannot be read (the import by name then)."""
    from scipy.integrate._ivp import dop853_coefficients as by_name

    from lagrange_core import integrate
    names = ("A", "B", "C", "E3", "E5", "D")
    read = integrate._dop853_coefficients()
    assert read["A"].shape == (16, 16) and read["D"].shape == (4, 16)
    for name in names:
        np.testing.assert_array_equal(read[name], getattr(by_name, name), err_msg=name)
        assert read[name].dtype == np.float64 and read[name].flags.c_contiguous
    assert integrate._scipy_file_module("integrate/_ivp/no_such_module.py") is None
    monkeypatch.setattr(integrate, "_scipy_file_module", lambda relative: None)
    imported = integrate._dop853_coefficients()
    for name in names:
        np.testing.assert_array_equal(imported[name], read[name], err_msg=name)


def test_the_controllers_quantile_equals_numpys_sort():
    """The k-th smallest step (the pilot's and the held step's quantile, in the kernels)
    equals ``np.sort(x)[k]``: random, tied, sorted and reversed values, every k of small
    arrays and a full pilot buffer (4096); the input is left as it was."""
    from lagrange_core._selection import kth_smallest
    rng = np.random.default_rng(7)
    for trial in range(400):
        n = int(rng.integers(1, 40))
        x = [rng.standard_normal(n), rng.integers(0, 4, n).astype(float),
             np.sort(rng.uniform(1e-4, 1e-2, n)), np.sort(rng.standard_normal(n))[::-1].copy()
             ][trial % 4]
        kept = x.copy()
        assert [kth_smallest(x, k) for k in range(n)] == np.sort(x).tolist()
        assert np.array_equal(x, kept)
    x = rng.lognormal(-5.0, 1.0, 4096)
    assert all(kth_smallest(x, k) == np.sort(x)[k] for k in (0, 819, 2048, 4095))


def test_the_held_steps_in_place_quantile_equals_numpys_sort():
    """The held step's selection, in place and without branches, equals ``np.sort(x)[k]``
    for every k: random, tied (all equal, a few values, one outlier among equals), sorted
    and reversed values, on arrays of 1 to 70 (its block has 64) and 4096; it keeps the
    values (a permutation of them)."""
    from lagrange_core._selection import kth_smallest_in_place
    rng = np.random.default_rng(8)
    for trial in range(600):
        n = int(rng.integers(1, 71))
        ties = np.full(n, 0.75)
        ties[int(rng.integers(0, n))] = 0.5 if trial % 2 else 1.0
        x = [rng.standard_normal(n), rng.integers(0, 4, n).astype(float),
             np.sort(rng.uniform(1e-4, 1e-2, n)), np.sort(rng.standard_normal(n))[::-1].copy(),
             np.full(n, 2.5), ties][trial % 6]
        want = np.sort(x)
        for k in range(n):
            a = x.copy()
            assert kth_smallest_in_place(a, k) == want[k], (x, k)
            assert np.array_equal(np.sort(a), want)
    x = rng.lognormal(-5.0, 1.0, 4096)
    assert all(kth_smallest_in_place(x.copy(), k) == np.sort(x)[k]
               for k in (0, 819, 2048, 4095))


# -- methods against the closed forms -------------------------------------------------------

ADAPTIVE = ["dop853", "rkn12", "scipy:DOP853", "scipy:Radau", "scipy:LSODA"]


@pytest.mark.parametrize("method", ADAPTIVE)
def test_adaptive_methods_on_harmonic_oscillator(systems, method):
    rtol = 1e-10
    t_eval = np.linspace(0.0, 10.0, 41)
    tr = systems["ho"].simulate([HO_Q0], [HO_V0], (0.0, 10.0), HO, method=method, rtol=rtol,
                                atol=rtol, t_eval=t_eval)
    assert tr.status == "success" and np.array_equal(tr.t, t_eval)
    err = compute_error(tr, ho_exact)
    # global error over ~3 periods: a few hundred local tolerances at most
    bound = {"scipy:LSODA": 1e-6, "scipy:Radau": 1e-7}.get(method, 1e-8)
    assert err < bound, (method, err)
    # the energy function is conserved to the same order
    assert np.ptp(tr.energy) < 10 * bound * HO["k"]


@pytest.mark.parametrize("method", ["dop853", "rkn12", "scipy:DOP853"])
def test_pendulum_returns_after_one_period(systems, method):
    T = pendulum_period()
    tr = systems["pendulum"].simulate([PEND_THETA0], [0.0], (0.0, 3 * T), PEND, method=method,
                                      rtol=1e-12, atol=1e-12, t_eval=[T, 1.5 * T, 2 * T, 3 * T])
    assert np.allclose(tr.q[:, 0], [PEND_THETA0, -PEND_THETA0, PEND_THETA0, PEND_THETA0],
                       atol=1e-9, rtol=0)
    assert np.allclose(tr.qdot[:, 0], 0.0, atol=1e-8)


@pytest.mark.parametrize("method,order,h", [("rk8", 8, 0.4), ("rkn12-fixed", 12, 1.0),
                                            ("yoshida6", 6, 0.1)])
def test_fixed_step_methods_converge_at_their_order(systems, method, order, h):
    """Halving h divides the error by 2^order (to within a factor 1.6 either way)."""
    errs = []
    for hh in (h, h / 2):
        tr = systems["ho"].simulate([HO_Q0], [HO_V0], (0.0, 20.0), HO, method=method, h=hh)
        errs.append(compute_error(tr, ho_exact))
        assert tr.n_steps == math.ceil(20.0 / hh - 1e-9)
    ratio = errs[0] / errs[1]
    assert 2**order / 1.6 < ratio < 2**order * 1.6, (method, errs, math.log2(ratio))


def test_rkn12_fixed_step_chosen_from_tolerance(systems):
    errs = []
    for rtol in (1e-6, 1e-10):
        tr = systems["pendulum"].simulate([PEND_THETA0], [0.0], (0.0, 20.0), PEND,
                                          method="rkn12-fixed", rtol=rtol, atol=rtol)
        T = pendulum_period()
        ref = systems["pendulum"].simulate([PEND_THETA0], [0.0], (0.0, 20.0), PEND,
                                           method="dop853", rtol=1e-13, atol=1e-13, t_eval=[20.0])
        errs.append(abs(tr.q[-1, 0] - ref.q[-1, 0]))
        assert T > 0 and tr.n_steps > 0
    assert errs[1] < 1e-8 and errs[1] < errs[0]


# -- error estimate ------------------------------------------------------------------------

@pytest.mark.parametrize("method,kw", [("dop853", {}), ("rkn12", {}), ("rk8", {"h": 0.2}),
                                       ("rkn12-fixed", {"h": 0.5})])
@pytest.mark.parametrize("rtol", [1e-6, 1e-9])
def test_error_estimate_bounds_true_error(systems, method, kw, rtol):
    tr = systems["ho"].simulate([HO_Q0], [HO_V0], (0.0, 30.0), HO, method=method, rtol=rtol,
                                atol=rtol, **kw)
    true = compute_error(tr, ho_exact)
    assert tr.error_estimate_kind == "sum of local error estimates"
    assert true <= tr.error_estimate, (true, tr.error_estimate)
    if not kw:  # and it is not absurdly pessimistic for the adaptive pairs
        assert tr.error_estimate < 1e4 * max(true, 1e-15)


@pytest.mark.parametrize("method", ["dop853", "rkn12"])
def test_error_check_rerun_estimates_true_error(systems, method):
    tr = systems["pendulum"].simulate([PEND_THETA0], [0.0], (0.0, 20.0), PEND, method=method,
                                      rtol=1e-7, atol=1e-7, error_check=True)
    T = pendulum_period()
    k = np.arange(1, int(20.0 / T) + 1) * T
    ref = systems["pendulum"].simulate([PEND_THETA0], [0.0], (0.0, 20.0), PEND, method="dop853",
                                       rtol=1e-13, atol=1e-13, t_eval=tr.t)
    true = max(np.max(np.abs(ref.q - tr.q)), np.max(np.abs(ref.qdot - tr.qdot)))
    assert tr.error_estimate_kind.startswith("difference from a rerun")
    assert 0.5 * true <= tr.error_estimate <= 2.0 * true, (true, tr.error_estimate)
    assert len(k) > 2


# -- symplectic: energy bounded over long times ----------------------------------------------

#: Steps per period of the energy-envelope checks: incommensurate with the period, so the
#: samples sweep the phase of the bounded, periodic energy error densely.  At exactly 20 the
#: samples visit about 20 phases that drift slowly with the numerical period, and the sampled
#: maxima of two windows differ by up to 8 % with no change in the physics (measured 1.08 for
#: the last tenth over the first of 1000 periods, the old bound 1.1).
ENVELOPE_STEPS_PER_PERIOD = 20.37
#: A secular drift ∝ t makes the last tenth's envelope 10× the first tenth's (growth 9); a
#: bounded error leaves it where it was, up to how densely the phases are sampled.
ENVELOPE_BOUNDED = 1e-4


def energy_envelope_growth(system, method, n_periods, **step):
    """How much the energy error's envelope grows over a run: max |ΔE|/|E| over its last
    tenth divided by that over its first tenth, minus 1 (every step sampled); and the
    max |ΔE|/|E| of the whole run."""
    T = pendulum_period()
    tr = system.simulate([PEND_THETA0], [0.0], (0.0, n_periods * T), PEND, method=method,
                         **step)
    dE = np.abs(tr.energy - tr.energy[0]) / abs(tr.energy[0])
    tenth = len(dE) // 10
    return dE[-tenth:].max() / dE[:tenth].max() - 1.0, dE.max()


def test_symplectic_energy_error_bounded_not_drifting(systems):
    """Yoshida 6 conserves a modified energy H̃ = H + O(h⁶) (up to exponentially small
    terms), so the error of H is a function of the phase on the orbit of H̃: bounded, and
    periodic with the numerical period.  Over 10⁴ periods the envelope of the last tenth
    equals the first tenth's to 1e-4 (measured 1.6e-6: what 2×10⁴ samples per window
    leave of the phase; bound ×60 over it), where a secular drift gives 9 — the companion
    test below shows rk8 at the same step and DOP853 at a loose tolerance fail the same
    check by 5 orders of magnitude.  Max |ΔE|/|E| measured 1.2e-4 at h = T/20.37."""
    T = pendulum_period()
    growth, worst = energy_envelope_growth(systems["pendulum"], "yoshida6", 10_000,
                                           h=T / ENVELOPE_STEPS_PER_PERIOD)
    assert worst < 1e-3
    assert abs(growth) < ENVELOPE_BOUNDED, growth


@pytest.mark.parametrize("method, step", [
    ("rk8", "fixed"),                                   # max |ΔE|/|E| 3.5e-4, growth 9.0
    ("dop853", {"rtol": 1e-6, "atol": 1e-9}),           # 1.5e-2, growth 8.9
])
def test_non_symplectic_energy_error_drifts_and_fails_the_same_check(systems, method, step):
    """The check of the test above detects a drift: a non-symplectic method, at the same
    fixed step (an energy error of the same size, 3.5e-4 against 1.2e-4) or with step
    control at a loose tolerance, drifts linearly (the energy error of every step adds
    up), and its envelope grows ×10 from the first tenth of 10⁴ periods to the last."""
    T = pendulum_period()
    if step == "fixed":
        step = {"h": T / ENVELOPE_STEPS_PER_PERIOD}
    growth, _ = energy_envelope_growth(systems["pendulum"], method, 10_000, **step)
    assert abs(growth) >= ENVELOPE_BOUNDED, growth      # fails the check above …
    assert growth > 5.0, growth        # … by far: measured 9.0 and 8.9 (a drift ∝ t: 9)


# -- events -------------------------------------------------------------------------------

@pytest.mark.parametrize("method", ["dop853", "rkn12", "yoshida6", "scipy:DOP853"])
def test_turning_points_at_half_periods(systems, method):
    T = pendulum_period()
    kw = {"h": T / 200} if method == "yoshida6" else {"rtol": 1e-12, "atol": 1e-12}
    tr = systems["pendulum"].simulate([PEND_THETA0], [0.0], (0.0, 2.6 * T), PEND, method=method,
                                      events=[turning_point("theta")], **kw)
    times = tr.event_times()
    assert len(times) == 5
    tol = {"yoshida6": 1e-8, "scipy:DOP853": 1e-9}.get(method, 1e-11)
    assert np.allclose(times, np.arange(1, 6) * T / 2, rtol=0, atol=tol * T), times / (T / 2)
    assert all(abs(abs(e.q[0]) - PEND_THETA0) < 1e-8 for e in tr.events)


@pytest.mark.parametrize("method", ["dop853", "rkn12"])
def test_terminal_crossing_stops_at_quarter_period(systems, method):
    T = pendulum_period()
    tr = systems["pendulum"].simulate([PEND_THETA0], [0.0], (0.0, 10.0), PEND, method=method,
                                      rtol=1e-12, atol=1e-12,
                                      events=[crossing("theta", 0.0, direction=-1, terminal=True)])
    assert tr.status == "event"
    assert abs(tr.t[-1] - T / 4) < 1e-11 * T
    assert abs(tr.q[-1, 0]) < 1e-12
    assert tr.events[0].t == tr.t[-1]


# -- constrained system: Cartesian pendulum --------------------------------------------------

def test_cartesian_pendulum_matches_angle_form_and_tension(systems):
    th0, l, m, g = 1.2, PEND["l"], PEND["m"], PEND["g"]
    t_eval = np.linspace(0.0, 8.0, 81)
    tr = systems["cart"].simulate([l * math.sin(th0), -l * math.cos(th0)], [0.0, 0.0], (0.0, 8.0),
                                  PEND, method="dop853", rtol=1e-11, atol=1e-11, t_eval=t_eval)
    ref = systems["pendulum"].simulate([th0], [0.0], (0.0, 8.0), PEND, method="dop853",
                                       rtol=1e-12, atol=1e-12, t_eval=t_eval)
    x, y = tr.q[:, 0], tr.q[:, 1]
    theta = np.arctan2(x, -y)
    assert np.max(np.abs(theta - ref.q[:, 0])) < 1e-8
    # Φ and Φ̇ are projected to zero after every step, so what is left is rounding: 2e-14 is
    # ~100 ulps of l² = 1.69 m² (and ~10 of 2 l |v| ≈ 10 m²/s for Φ̇); measured 8.9e-16, ×22
    assert np.max(tr.constraint_residual) < 2e-14
    # Φ_q = (2x, 2y): the constraint force λ(2x, 2y) is the tension −T r/l, so T = −2 l λ;
    # closed form T = m (g cos θ + l θ̇²)
    tension = -2 * l * tr.multipliers[:, 0]
    expected = m * (g * np.cos(ref.q[:, 0]) + l * ref.qdot[:, 0] ** 2)
    assert np.max(np.abs(tension - expected)) < 1e-7 * m * g
    df = tr.to_dataframe()
    assert list(df.columns) == ["x", "y", "x_dot", "y_dot", "energy", "lambda0",
                                "constraint_residual"]


def test_multiplier_zero_event_where_the_rod_goes_slack(systems):
    """From the bottom with v0² = 3 g l the tension m(v0²/l − 2g + 3g cos θ) vanishes at
    cos θ = −1/3."""
    l, g = PEND["l"], PEND["g"]
    v0 = math.sqrt(3 * g * l)
    tr = systems["cart"].simulate([0.0, -l], [v0, 0.0], (0.0, 5.0), PEND, method="dop853",
                                  rtol=1e-12, atol=1e-12,
                                  events=[multiplier_zero(0, terminal=True)])
    assert tr.status == "event"
    x, y = tr.events[0].q
    assert abs(-y / l - (-1.0 / 3.0)) < 1e-9


# -- the specialised q̈ = f(q, t) kernel (drive by rotations) against the generic one ---------

DRIVEN = dict(A=0.05, g=9.81, l=1.0, m=1.0, omega=2 * math.pi * 60)


@pytest.mark.parametrize("method", ["rkn12-fixed", "yoshida6"])
def test_specialised_kernel_matches_generic_kernels(systems, method):
    """Without events the RKN/symplectic loops use the generated f(q, t; cos ωt, sin ωt)
    kernel; an event that never fires forces the generic kernels.  Same steps, same answer."""
    s = systems["driven"]
    T = 50 * 2 * math.pi / DRIVEN["omega"]
    h = T / (50 * 40)
    t_eval = np.linspace(0.0, T, 6)
    fast = s.simulate([math.pi - 0.1], [0.0], (0.0, T), DRIVEN, method=method, h=h, t_eval=t_eval)
    slow = s.simulate([math.pi - 0.1], [0.0], (0.0, T), DRIVEN, method=method, h=h, t_eval=t_eval,
                      events=[crossing("theta", 100.0)])
    assert fast.n_steps == slow.n_steps
    assert np.max(np.abs(fast.y - slow.y)) < 1e-11
    # and both follow scipy's DOP853 on the generic right-hand side (independent integrator)
    k = s.kernels
    p = s.parameter_array(DRIVEN)
    W = k.work_array()

    def f(t, y):
        out = np.empty(2)
        k.rhs(t, y, p, out, W)
        return out
    sol = solve_ivp(f, (0.0, T), [math.pi - 0.1, 0.0], method="DOP853", rtol=1e-12, atol=1e-12,
                    t_eval=t_eval)
    tol = 1e-9 if method == "rkn12-fixed" else 1e-5
    assert np.max(np.abs(sol.y.T - fast.y)) < tol


# -- comparison with scipy on a velocity-dependent system -----------------------------------

def test_double_pendulum_agrees_with_solve_ivp(systems):
    sysd = systems["double"]
    params = dict(g=9.81, l1=1.0, l2=0.7, m1=1.0, m2=0.5)
    assert not rkn_eligibility(sysd)[0]
    q0, v0 = [1.0, -0.5], [0.0, 0.3]
    t_eval = np.linspace(0, 5, 11)
    tr = sysd.simulate(q0, v0, (0.0, 5.0), params, rtol=1e-12, atol=1e-12, t_eval=t_eval)
    assert tr.method == "dop853"
    k = sysd.kernels
    p = sysd.parameter_array(params)
    W = k.work_array()

    def f(t, y):
        out = np.empty(4)
        k.rhs(t, y, p, out, W)
        return out
    sol = solve_ivp(f, (0, 5), q0 + v0, method="DOP853", rtol=1e-12, atol=1e-12, t_eval=t_eval)
    assert np.max(np.abs(sol.y.T - tr.y)) < 1e-8


# -- method choice, bad input, singularities, interruption, memory ---------------------------

def test_default_method_and_eligibility_messages(systems):
    assert rkn_eligibility(systems["driven"]) == (True, "")
    tr = systems["pendulum"].simulate([0.3], [0.0], (0.0, 0.1), PEND)
    assert tr.method == "rkn12"
    damped = problems.driven_pendulum(damping=True)
    ok, why = rkn_eligibility(damped)
    assert not ok and "theta_dot" in why
    with pytest.raises(ValueError, match="constraint"):
        systems["cart"].simulate([0.0, -1.3], [0.0, 0.0], (0, 1), PEND, method="rkn12")
    with pytest.raises(ValueError, match="depends on the velocity"):
        systems["double"].simulate([0.1, 0.1], [0, 0], (0, 1),
                                   dict(g=9.81, l1=1.0, l2=0.7, m1=1.0, m2=0.5), method="yoshida6",
                                   h=0.01)


@pytest.mark.parametrize("kw,match", [
    (dict(t_span=(1.0, 0.0)), "end time must be after"),
    (dict(t_span=(0.0, np.inf)), "finite"),
    (dict(rtol=0.0), "rtol must be a positive"),
    (dict(rtol=-1e-6), "rtol must be a positive"),
    (dict(method="rk45"), "valid names: .*dop853.*scipy:Radau"),
    (dict(method="rk8"), "fixed step: pass h"),
    (dict(t_eval=[0.5, 2.0]), "within t_span"),
    (dict(t_eval=[0.5, 0.2]), "sorted"),
    (dict(stride=0), "stride"),
])
def test_bad_input_is_rejected_clearly(systems, kw, match):
    args = dict(t_span=(0.0, 1.0))
    args.update(kw)
    t_span = args.pop("t_span")
    with pytest.raises(ValueError, match=match):
        systems["ho"].simulate([0.1], [0.0], t_span, HO, **args)


def test_singular_mass_matrix_stops_with_time_and_state(systems):
    """Free particle aimed 1e-8 m past the origin of polar coordinates (M = diag(m, m r²))."""
    b = 1e-8
    with pytest.raises(ValueError, match=r"singular") as info:
        systems["polar"].simulate([1.0, 0.0], [-1.0, b], (0.0, 2.0), dict(m=1.0), method="dop853")
    msg = str(info.value)
    assert "t = " in msg and "q = " in msg
    t_stop = float(msg.split("t = ")[1].split()[0])
    assert abs(t_stop - 1.0) < 1e-5


@pytest.mark.parametrize("t_eval", [False, True])
def test_a_ctrl_c_at_any_line_of_the_drain_keeps_a_whole_trajectory(systems, t_eval):
    """A Ctrl-C is a KeyboardInterrupt at any bytecode, and in the first chunk nothing
    defers it: raised at every line of the loop's ``drain`` in turn (a trace function, on
    its second call, so that rows are kept already), the partial trajectory is whole —
    as many times as rows, strictly increasing, within its error estimate.  CI once saw
    1426 times against 1421 rows (t and y were kept by two appends); with random alarms
    the code before the fix left 3 of 300 and 4 of 200 runs so."""
    import sys

    def run(tracer):
        kw = dict(t_eval=np.linspace(0.0, 40.0, 4001)) if t_eval else dict(stride=3)
        sys.settrace(tracer)
        try:
            return systems["ho"].simulate([HO_Q0], [HO_V0], (0.0, 40.0), HO, method="dop853",
                                          rtol=1e-10, chunk_steps=16, **kw)
        finally:
            sys.settrace(None)

    lines = set()

    def collect(frame, event, arg):
        if frame.f_code.co_name == "drain":
            lines.add(frame.f_lineno)
            return collect
        return None if event == "call" else collect
    run(collect)
    lines.discard(min(lines))               # the def line (the call event)
    assert len(lines) >= (5 if t_eval else 12)     # with t_eval: the events part only
    for line in sorted(lines):
        seen = {"calls": 0, "raised": False}

        def interrupt(frame, event, arg, line=line, seen=seen):
            if frame.f_code.co_name != "drain":
                return None
            if event == "call":
                seen["calls"] += 1
            if (event == "line" and frame.f_lineno == line and seen["calls"] >= 2
                    and not seen["raised"]):
                seen["raised"] = True
                raise KeyboardInterrupt
            return interrupt
        try:
            tr = run(interrupt)
        except SimulationInterrupted as stop:
            tr = stop.trajectory
        assert len(tr.t) == len(tr.q) == len(tr.qdot), (line, len(tr.t), len(tr.q))
        assert np.all(np.diff(tr.t) > 0), line
        assert compute_error(tr, ho_exact) <= tr.error_estimate, line


def test_keyboard_interrupt_keeps_the_part_computed(systems):
    def stop(signum, frame):
        raise KeyboardInterrupt
    # load this run's drivers and kernels first, so the alarm falls inside the integration
    # (on a busy machine loading them alone can take longer than the alarm's 0.05 s)
    systems["ho"].simulate([HO_Q0], [HO_V0], (0.0, 1.0), HO, method="dop853", rtol=1e-10)
    old = signal.signal(signal.SIGALRM, stop)
    signal.setitimer(signal.ITIMER_REAL, 0.05)
    try:
        with pytest.raises(SimulationInterrupted) as info:
            systems["ho"].simulate([HO_Q0], [HO_V0], (0.0, 1e7), HO, method="dop853", rtol=1e-10,
                                   stride=100, chunk_steps=500)
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, old)
    tr = info.value.trajectory
    assert isinstance(info.value, KeyboardInterrupt)
    assert tr.status == "interrupted" and 0 < tr.t[-1] < 1e7 and len(tr) > 2
    assert np.all(np.diff(tr.t) > 0)
    assert compute_error(tr, ho_exact) <= tr.error_estimate   # a valid partial trajectory


def test_stride_and_t_eval_limit_memory(systems):
    full = systems["ho"].simulate([HO_Q0], [HO_V0], (0.0, 50.0), HO, method="dop853")
    thin = systems["ho"].simulate([HO_Q0], [HO_V0], (0.0, 50.0), HO, method="dop853", stride=10)
    assert len(full) == full.n_steps + 1
    assert len(thin) == math.ceil(full.n_steps / 10) + 1 or len(thin) == full.n_steps // 10 + 2
    assert thin.t[-1] == 50.0 and np.allclose(thin.q[-1], full.q[-1], rtol=0, atol=0)
    capped = systems["ho"].simulate([HO_Q0], [HO_V0], (0.0, 500.0), HO, method="dop853",
                                    max_points=100)
    assert len(capped) <= 130 and capped.t[0] == 0.0 and capped.t[-1] == 500.0
    assert np.all(np.diff(capped.t) > 0)
    assert compute_error(capped, ho_exact) <= capped.error_estimate
    gaps = np.diff(capped.t)
    assert gaps.max() < 5 * np.median(gaps)          # thinned uniformly over the whole run
    one = systems["ho"].simulate([HO_Q0], [HO_V0], (0.0, 50.0), HO, method="rkn12", t_eval=[50.0])
    assert len(one) == 1 and compute_error(one, ho_exact) < 1e-7


def test_max_steps_stops_early_with_status(systems):
    tr = systems["ho"].simulate([HO_Q0], [HO_V0], (0.0, 100.0), HO, method="dop853",
                                max_steps=7)
    assert tr.status == "max_steps" and tr.n_steps == 7 and tr.t[-1] < 100.0
    assert compute_error(tr, ho_exact) < 1e-8


def test_registry_lists_the_methods():
    for name in ("dop853", "rk8", "rkn12", "rkn12-fixed", "yoshida6", "scipy:DOP853",
                 "scipy:LSODA", "scipy:Radau"):
        assert name in METHODS and METHODS[name].name == name
