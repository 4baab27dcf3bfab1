"""Lyapunov exponents (kapitza.chaos.lyapunov, lyapunov_grid) against independent references.

* The damped pendulum's exponents sum to −γ (phase-space contraction: tr J = −γ, exact),
  for any damping, chaotic or not; a Hamiltonian drive's come in ± pairs (tr J = 0).
* A periodic orbit's exponents are log|μ|/T of its Floquet multipliers μ, from
  ``kapitza.floquet_point`` (a Taylor method on the monodromy, another integrator):
  the hanging pendulum in its first parametric tongue (a saddle: λ₁ > 0), the same state
  damped into stability with real multipliers, and the upright Kapitza pendulum inside
  its window (a stable focus: λ₁ = λ₂ = −γ/2).
* The chaotic damped driven pendulum θ̈ + θ̇/Q + sin θ = F cos ω_d t (Q = 2, F = 1.5,
  ω_d = 2/3, Baker & Gollub's standard example): λ₁ > 0, equal within the stated errors
  to an independent estimate here — two trajectories 1e-7 apart integrated by scipy's
  DOP853, renormalised every drive period (no Jacobian, no kapitza code).
"""
import math

import numpy as np
import pytest
import sympy as sp
from scipy.integrate import ode

import kapitza
from kapitza.chaos import lyapunov, lyapunov_grid
from kapitza.results import ComputationInterrupted
from kapitza.results._chaos import LyapunovGrid, LyapunovSpectrum
from lagrange_core import System, coordinates, problems, t

G = 9.81
W0 = math.sqrt(G)


@pytest.fixture(scope="module")
def ddp():
    """θ̈ + θ̇/Q + sin θ = F cos ωt (units of the natural frequency)."""
    (th,), (thd,) = coordinates("theta")
    Q, F, w = sp.symbols("Q F omega", positive=True)
    return System([th], lagrangian=thd**2 / 2 + sp.cos(th), dissipation=thd**2 / (2 * Q),
                  forces={th: F * sp.cos(w * t)}, name="damped driven pendulum")


@pytest.fixture(scope="module")
def kapitza_damped():
    return problems.driven_pendulum("vertical", damping=True)


def _pend(A, omega, gamma=None):
    p = dict(A=A, g=G, l=1.0, m=1.0, omega=omega)
    if gamma is not None:
        p["gamma"] = gamma
    return p


# -- identities ------------------------------------------------------------------------------

@pytest.mark.parametrize("A, ratio, gamma, theta0", [
    (0.6, 2.0, 0.05, 0.3),       # chaotic
    (0.5, 2.0, 0.3, 0.3),        # chaotic
    (0.05, 40.0, 0.5, 3.0),      # upright, stable
    (0.2, 0.7, 5.0, 0.1),        # overdamped hanging
])
def test_damped_pendulum_exponents_sum_to_minus_gamma(kapitza_damped, A, ratio, gamma, theta0):
    s = lyapunov(kapitza_damped, _pend(A, ratio * W0, gamma), theta0, periods=200,
                 transient=20, progress=False)
    assert s.complete and s.status == "finished"
    residual = abs(s.exponents.sum() + gamma)
    assert residual <= s.sum_error
    assert residual < 1e-8 * max(1.0, gamma)


def test_chaotic_driven_pendulum_sum_is_minus_one_over_q(ddp):
    s = lyapunov(ddp, dict(Q=2.0, F=1.5, omega=2 / 3), 0.2, periods=300, progress=False)
    assert abs(s.exponents.sum() + 0.5) <= s.sum_error
    assert abs(s.exponents.sum() + 0.5) < 1e-9


def test_hamiltonian_drive_gives_pairs():
    """Undamped vertically driven pendulum (tr J = 0): λ₁ = −λ₂; in the chaotic sea
    λ₁ > 0, on a small regular oscillation λ₁ = 0 within its error."""
    s = problems.driven_pendulum("vertical")
    chaotic = lyapunov(s, _pend(0.5, 2 * W0), 2.0, periods=300, transient=30, progress=False)
    assert abs(chaotic.exponents.sum()) <= chaotic.sum_error
    assert abs(chaotic.exponents.sum()) < 1e-8
    assert chaotic.exponents[0] - chaotic.error[0] > 0.3
    regular = lyapunov(s, _pend(0.05, 10 * W0), 0.3, periods=300, transient=30, progress=False)
    assert abs(regular.exponents.sum()) <= regular.sum_error
    assert abs(regular.exponents[0]) <= regular.error[0]


# -- periodic orbits against Floquet multipliers ----------------------------------------------

@pytest.mark.parametrize("A, gamma, theta0, sign", [
    (0.3, 0.2, 0.0, 1),          # in the first tongue, exactly on the state: a saddle
    (0.1, 0.8, 0.05, -1),        # the tongue damped into stability, real multipliers
    (0.15, 1.2, 0.05, -1),
])
def test_hanging_state_exponents_are_log_multipliers(kapitza_damped, A, gamma, theta0, sign):
    P = _pend(A, 2 * W0, gamma)
    f = kapitza.floquet_point(kapitza_damped, P, [0.0])
    reference = np.sort(f.log_abs_multipliers / f.period)[::-1]
    assert np.sign(reference[0]) == sign
    s = lyapunov(kapitza_damped, P, theta0, periods=200, transient=50, progress=False)
    assert np.all(np.abs(s.exponents - reference) <= s.error + 1e-9)
    np.testing.assert_allclose(s.exponents, reference, rtol=1e-7)


def test_upright_focus_exponents_are_minus_half_gamma(kapitza_damped):
    """Complex multipliers: both exponents −γ/2; the finite record wobbles (v turns with
    the slow motion), and the stated error covers it."""
    P = _pend(0.05, 40 * W0, 0.5)
    f = kapitza.floquet_point(kapitza_damped, P, [math.pi])
    assert f.stable
    reference = f.log_abs_multipliers / f.period
    s = lyapunov(kapitza_damped, P, math.pi - 0.05, periods=1000, transient=100,
                 progress=False)
    assert np.all(np.abs(s.exponents - reference) <= s.error)
    assert np.all(s.error < 0.15)


# -- chaos --------------------------------------------------------------------------------

def _two_trajectory_reference(Q, F, w, theta0, transient, periods, d0=1e-7, blocks=6):
    """λ₁ from two trajectories d0 apart (scipy DOP853), renormalised every period; the
    error as the batch means of ``blocks`` blocks (2.5 s/√B).

    Hairer's Fortran DOP853 (``scipy.integrate.ode``), the method of solve_ivp's "DOP853"
    at the same tolerances, restarted every period as before: solve_ivp's Python driver
    took 1.4 s for the 340 periods below, the Fortran one 0.4 s.  (A chaotic estimate: the
    other rounding gave 0.114 ± 0.014 where solve_ivp gave 0.120 ± 0.025; lyapunov's is
    0.111 ± 0.008.)"""
    T = 2 * math.pi / w

    def f(tt, y):
        a = F * math.cos(w * tt)
        return [y[1], -y[1] / Q - math.sin(y[0]) + a, y[3], -y[3] / Q - math.sin(y[2]) + a]

    run = ode(f).set_integrator("dop853", rtol=1e-10, atol=1e-10, nsteps=10**6)
    run.set_initial_value([theta0, 0.0, theta0, 0.0], 0.0)
    y = run.integrate(transient * T)[:2]
    assert run.successful()
    run.set_integrator("dop853", rtol=1e-10, atol=1e-12, nsteps=10**6)
    e = np.array([1.0, 1.0]) / math.sqrt(2)
    logs = []
    for k in range(periods):
        t0 = (transient + k) * T
        run.set_initial_value(np.r_[y, y + d0 * e], t0)
        z = run.integrate(t0 + T)
        assert run.successful()
        y, dz = z[:2], z[2:] - z[:2]
        norm = np.linalg.norm(dz)
        logs.append(math.log(norm / d0))
        e = dz / norm
    logs = np.array(logs)
    per_block = np.array([b.sum() / (b.size * T) for b in np.array_split(logs, blocks)])
    return logs.sum() / (periods * T), 2.5 * per_block.std(ddof=1) / math.sqrt(blocks)


def test_damped_driven_pendulum_is_chaotic_and_matches_two_trajectories(ddp):
    s = lyapunov(ddp, dict(Q=2.0, F=1.5, omega=2 / 3), 0.2, periods=800, transient=100,
                 progress=False)
    assert s.exponents[0] - s.error[0] > 0.05
    # the literature range, 0.1–0.2 in units of the natural frequency
    assert 0.08 < s.exponents[0] < 0.2
    ref, ref_error = _two_trajectory_reference(2.0, 1.5, 2 / 3, 0.2, 100, 240)
    assert abs(s.exponents[0] - ref) <= s.error[0] + ref_error
    # the exact Jacobian and the directional difference agree within the errors
    d = lyapunov(ddp, dict(Q=2.0, F=1.5, omega=2 / 3), 0.2, periods=800, transient=100,
                 tangent="difference", progress=False)
    assert abs(d.exponents[0] - s.exponents[0]) <= d.error[0] + s.error[0]


def test_spectrum_fields_and_dataframe(ddp):
    s = lyapunov(ddp, dict(Q=2.0, F=1.5, omega=2 / 3), 0.2, periods=80, transient=10,
                 exponents="largest", every=2, blocks=4, progress=False)
    assert isinstance(s, LyapunovSpectrum)
    assert s.exponents.shape == (1,) and not s.complete
    assert s.periods == 80 and s.blocks == 4 and s.running.shape == (40, 1)
    np.testing.assert_allclose(s.running[-1], s.exponents)
    np.testing.assert_allclose(s.block_exponents.mean(axis=0), s.exponents, rtol=1e-12)
    assert s.t_final == pytest.approx(90 * 2 * math.pi / (2 / 3))
    df = s.to_dataframe()
    assert list(df["index"]) == [1] and df.exponent[0] == s.largest
    np.testing.assert_allclose(s.per_period, s.exponents * s.period)


# -- the grid --------------------------------------------------------------------------------

def test_grid_matches_single_points(kapitza_damped):
    """A (γ, A) grid of hanging states in the first tongue: λ_max = log|μ_max|/T per point,
    as lyapunov gives it; chaotic points of a wider grid agree within their errors."""
    A = np.array([0.1, 0.15, 0.3])
    gamma = np.array([0.2, 0.8, 1.2])
    P = _pend(A[:, None], 2 * W0, gamma[None, :])
    g = lyapunov_grid(kapitza_damped, P, 0.0, periods=160, transient=40, progress=False)
    assert isinstance(g, LyapunovGrid) and g.shape == (3, 3)
    for i in range(3):
        for j in range(3):
            p = _pend(A[i], 2 * W0, gamma[j])
            f = kapitza.floquet_point(kapitza_damped, p, [0.0])
            ref = np.max(f.log_abs_multipliers) / f.period
            assert abs(g.exponent[i, j] - ref) <= g.error[i, j] + 1e-6
    df = g.to_dataframe()
    assert len(df) == 9 and set(df.columns) >= {"A", "gamma", "exponent", "error", "chaotic"}
    exact = lyapunov_grid(kapitza_damped, P, 0.0, periods=160, transient=40,
                          tangent="jacobian", progress=False)
    np.testing.assert_allclose(exact.exponent, g.exponent, rtol=1e-6, atol=1e-8)


def test_grid_chaotic_point_agrees_with_lyapunov(ddp):
    """A chaotic exponent is a statistical quantity: a trajectory's round-off (another CPU,
    another step sequence) gives another finite-time estimate.  So the grid and the
    per-point path are compared as ensembles over starts on the attractor, and the error
    estimate's claim — a 95 % interval — is checked by its coverage over the ensemble.
    (One start each, the difference exceeded the summed intervals in one CI run: both
    intervals were low draws of s_B, which has 7 degrees of freedom.)"""
    starts = np.linspace(-1.0, 1.0, 64)
    F = np.concatenate([[1.35], np.full(starts.size, 1.5)])
    q0 = np.concatenate([[0.2], starts])
    g = lyapunov_grid(ddp, dict(Q=2.0, F=F, omega=2 / 3), q0, periods=800, transient=100,
                      rtol=1e-9, progress=False)
    assert not g.chaotic[0] and g.chaotic[1:].all()
    lam_g, err_g = g.exponent[1:], g.error[1:]
    mean_g, se_g = lam_g.mean(), lam_g.std(ddof=1) / math.sqrt(lam_g.size)
    # coverage of the stated 95 % interval: ≈ 3 of 64 outside expected, ≥ 10 has p ≈ 0.002
    outside = int(np.sum(np.abs(lam_g - mean_g) > err_g))
    assert outside <= 9, f"{outside} of 64 grid estimates outside their error"
    per_point = np.array([
        lyapunov(ddp, dict(Q=2.0, F=1.5, omega=2 / 3), q, periods=800, transient=100,
                 exponents="largest", progress=False).exponents[0]
        for q in starts[::8]])
    mean_p, se_p = per_point.mean(), per_point.std(ddof=1) / math.sqrt(per_point.size)
    # the two means estimate the same exponent: Welch's t, ≈ 9 degrees of freedom,
    # |t| > 4.5 has p ≈ 0.0015
    assert abs(mean_g - mean_p) <= 4.5 * math.hypot(se_g, se_p), (mean_g, mean_p, se_g, se_p)


# -- interruption and bad input --------------------------------------------------------------

def _stop_after(calls):
    seen = []

    def progress(done, total):
        seen.append(done)
        if len(seen) >= calls:
            raise KeyboardInterrupt
    return progress


def test_ctrl_c_keeps_the_record_so_far(ddp):
    with pytest.raises(ComputationInterrupted) as info:
        lyapunov(ddp, dict(Q=2.0, F=1.5, omega=2 / 3), 0.2, periods=400, transient=0,
                 progress=_stop_after(2))
    part = info.value.result
    assert isinstance(part, LyapunovSpectrum) and 0 < part.periods < 400
    assert np.all(np.isfinite(part.exponents)) and bool(info.value.computed)


def test_grid_ctrl_c_keeps_the_finished_points(ddp):
    # more points than the first call of the lanes takes (they fill the lanes)
    from kapitza.chaos._lanes import call_points
    F = np.linspace(1.0, 1.5, call_points() + 88)
    with pytest.raises(ComputationInterrupted) as info:
        lyapunov_grid(ddp, dict(Q=2.0, F=F, omega=2 / 3), 0.2, periods=40, transient=0,
                      progress=_stop_after(1))
    part, done = info.value.result, info.value.computed
    assert 0 < done.sum() < F.size
    assert np.all(np.isfinite(part.exponent[done])) and np.all(np.isnan(part.exponent[~done]))
    assert set(part.status[~done]) == {"not_run"}


def test_bad_input_is_refused_by_name(ddp):
    P = dict(Q=2.0, F=1.5, omega=2 / 3)
    with pytest.raises(ValueError, match="exponents=3"):
        lyapunov(ddp, P, 0.2, exponents=3)
    with pytest.raises(ValueError, match="'F' is an array"):
        lyapunov(ddp, dict(P, F=np.array([1.0, 1.5])), 0.2)
    with pytest.raises(ValueError, match="fewer than blocks"):
        lyapunov(ddp, P, 0.2, periods=10, every=5)
    with pytest.raises(ValueError, match="tangent"):
        lyapunov(ddp, P, 0.2, tangent="finite")
    with pytest.raises(ValueError, match="frequency parameter 'w'"):
        lyapunov(ddp, P, 0.2, frequency="w")
    with pytest.raises(ValueError, match="missing"):
        lyapunov_grid(ddp, dict(Q=2.0, omega=2 / 3), 0.2)
    with pytest.raises(ValueError, match="broadcast"):
        lyapunov_grid(ddp, dict(P, F=np.ones(3)), np.zeros(4))
    rolling = problems.rolling_disc(constrained=True)
    with pytest.raises(ValueError, match="constraints"):
        lyapunov(rolling, {p: 1.0 for p in rolling.parameters}, 0.0, frequency=1.0)
