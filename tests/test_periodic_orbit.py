"""Periodic orbits of driven systems and their Floquet stability (issue 12, point 1).

References independent of the Newton shooting: first-order averaging (closed forms of
shared/PHYSICS.md, whose error must shrink at the order it predicts), the exact
Floquet path about a persisting equilibrium, finite differences of the one-trajectory
integrator for the variational flow, and direct simulation.
"""
import math
import sys
import time
import warnings

import numpy as np
import pytest
import sympy as sp

from kapitza import KapitzaPendulum, floquet_point
from kapitza.simulation._periodic_orbit import periodic_orbit
from lagrange_core import Particle, System, coordinates, problems, t
from lagrange_core.variational import flow

G = 9.81


def elliptic_pendulum():
    """Pivot x = A cos ωt, y = B sin ωt (PHYSICS.md), damping ½ m l² γ θ̇²."""
    (th,), (thd,) = coordinates("theta")
    m, l, g, A, B, w, gam = sp.symbols("m l g A B omega gamma", positive=True)
    bob = Particle(m, (A * sp.cos(w * t) + l * sp.sin(th), B * sp.sin(w * t) - l * sp.cos(th)))
    return System([th], particles=[bob], potential=m * g * bob.position[1],
                  dissipation=m * l**2 * gam * thd**2 / 2, name="elliptic pivot")


def test_flow_jacobian_against_finite_differences():
    """X = ∂y(T)/∂y(0) of the variational flow against central differences of
    System.simulate at rtol 1e-13 (step 1e-5): agreement to 1e-7 (measured 2e-9)."""
    s = problems.driven_pendulum("horizontal")
    w = 2 * math.pi * 30
    P = dict(m=1.0, l=1.0, g=G, A=0.05, omega=w)
    y0 = np.array([1.2, 0.3])
    f = flow(s, y0, (0.0, 2 * math.pi / w), P)
    fd = np.empty((2, 2))
    for j in range(2):
        ends = []
        for sgn in (1, -1):
            y = y0.copy()
            y[j] += sgn * 1e-5
            tr = s.simulate(y[:1], y[1:], (0.0, 2 * math.pi / w), P, rtol=1e-13,
                            method="dop853")
            ends.append(np.r_[tr.q[-1], tr.qdot[-1]])
        fd[:, j] = (ends[0] - ends[1]) / 2e-5
    assert np.max(np.abs(f.jacobian - fd)) < 1e-7
    assert f.error_estimate < 1e-11


def test_persisting_equilibrium_reduces_to_floquet_point():
    s = problems.driven_pendulum("vertical")
    P = dict(m=1.0, l=1.0, g=G, A=0.05, omega=2 * math.pi * 60)
    orbit = periodic_orbit(s, P, [math.pi])
    ref = floquet_point(s, P, [math.pi])
    assert orbit.iterations == 0 and "floquet_point" in orbit.method
    assert orbit.omega_slow == ref.omega_slow and orbit.stable == ref.stable
    assert np.all(orbit.amplitude == 0) and orbit.q_mean[0] == pytest.approx(math.pi, abs=1e-15)


def test_horizontal_drive_orbit_against_averaging_at_its_order():
    """The horizontal drive's tilted orbit at fixed pivot speed Aω (so the averaged tilt
    cos θ* = 2gl/(Aω)² is fixed) as ω grows: the period mean of θ and Ω from the
    multipliers approach averaging's θ* and Ω with errors ∝ ω⁻² (first-order averaging
    neglects O(ω0²/ω², A/l·…) = O(ε²)).  Fitted exponents −2.000 and −2.020 over
    f = 15 … 240 Hz; asserted within ±0.15 of −2."""
    pend = KapitzaPendulum(drive="horizontal")
    v = 0.05 * 2 * math.pi * 60
    ws = 2 * math.pi * np.array([15.0, 30.0, 60.0, 120.0, 240.0])
    err_tilt, err_omega = [], []
    for w in ws:
        orbit = pend.floquet(v / w, w, about="tilted")
        avg = pend.averaged(v / w, w, warn=False).tilted
        assert orbit.stable and orbit.residual < 1e-9
        err_tilt.append(abs(orbit.q_mean[0] - avg.theta))
        err_omega.append(abs(orbit.omega_slow - avg.omega_slow) / orbit.omega_slow)
    assert err_tilt[2] < 1e-5 and err_omega[2] < 3e-3          # 60 Hz: 8.7e-6 rad, 2.0e-3
    for err in (err_tilt, err_omega):
        slope = np.polyfit(np.log(ws), np.log(err), 1)[0]
        assert slope == pytest.approx(-2.0, abs=0.15)


def test_horizontal_orbit_against_direct_simulation():
    """Started on the orbit, the pendulum repeats it: the state after 20 drive periods
    (System.simulate, rtol 1e-12) is the orbit's state at t = 0 to 1e-8."""
    pend = KapitzaPendulum(drive="horizontal")
    w = 2 * math.pi * 60
    orbit = pend.floquet(0.05, w, about="tilted")
    tr = pend.simulate(0.05, w, orbit.state[0], orbit.state[1], (0.0, 20 * 2 * math.pi / w),
                       rtol=1e-12, method="dop853")
    assert abs(tr.q[-1, 0] - orbit.state[0]) < 1e-8
    assert abs(tr.qdot[-1, 0] - orbit.state[1]) < 1e-6


def test_circular_drive_never_stabilises_the_upright():
    """A = B (circular pivot path): U_eff is −g l cos θ + const, so no drive holds the
    upright (PHYSICS.md).  The orbit near θ = π is unstable at every (A, ω) tried, up to
    strong fast drives (Aω up to 30 m/s, ω/ω0 up to 200); the elliptic drive with the
    long axis vertical (B ≫ A) does hold it."""
    s = elliptic_pendulum()
    for A, f in [(0.02, 30.0), (0.05, 60.0), (0.05, 100.0), (0.1, 50.0)]:
        P = dict(m=1.0, l=1.0, g=G, A=A, B=A, omega=2 * math.pi * f, gamma=0.0)
        orbit = periodic_orbit(s, P, [math.pi])
        assert not orbit.stable, (A, f, orbit.multipliers)
        assert abs(orbit.q_mean[0] - math.pi) < 1e-6
    P = dict(m=1.0, l=1.0, g=G, A=0.002, B=0.05, omega=2 * math.pi * 60, gamma=0.0)
    assert periodic_orbit(s, P, [math.pi]).stable


@pytest.mark.parametrize("sense", [1.0, -1.0])
def test_damped_elliptic_tilt(sense):
    """With damping the two phases of a circular drive drag the hanging pendulum round:
    sin θ = γ ω A B/(2 g l) (first order in γ/ω, PHYSICS.md), to the side the pivot turns.
    The orbit's period mean agrees to 3e-3 relative (corrections O(A²/l², ω0²/ω², γ²/ω²);
    measured 8e-4), and the orbit is asymptotically stable (|λ| = e^(−γT/2) < 1)."""
    s = elliptic_pendulum()
    A, B, w, gam = 0.05, sense * 0.05, 100.0, 2.0
    P = dict(m=1.0, l=1.0, g=G, A=A, B=B, omega=w, gamma=gam)
    closed = math.asin(gam * w * A * B / (2 * G))
    orbit = periodic_orbit(s, P, [closed])
    assert np.sign(orbit.q_mean[0]) == sense
    assert orbit.q_mean[0] == pytest.approx(closed, rel=3e-3)
    assert np.max(np.abs(orbit.multipliers)) < 1
    assert np.prod(np.abs(orbit.multipliers)) == pytest.approx(math.exp(-gam * 2 * math.pi / w),
                                                               rel=1e-8)


def test_orbit_errors_name_the_fix():
    s = problems.driven_pendulum("horizontal")
    P = dict(m=1.0, l=1.0, g=G, A=0.05, omega=2 * math.pi * 60)
    with pytest.raises(ValueError, match="2 stable slow equilibria"):
        periodic_orbit(s, P)
    with pytest.raises(ValueError, match="drive frequency 'w'"):
        periodic_orbit(s, P, [1.5], frequency="w")
    with pytest.raises(ValueError, match="about must be 1 finite coordinates"):
        periodic_orbit(s, P, [1.5, 0.0, 0.0])
    with pytest.raises(ValueError, match=r"\(Aω\)² > 2gl"):
        KapitzaPendulum(drive="horizontal").floquet(0.001, 10.0, about="tilted")
    with pytest.raises(ValueError, match="about must be 'tilted'"):
        KapitzaPendulum(drive="horizontal").floquet(0.05, 300.0, about="upright")


@pytest.mark.parametrize("failure", [FloatingPointError, ValueError])
def test_failing_trial_flow_is_a_rejected_step(monkeypatch, failure):
    """A Newton trial state whose one-period flow fails (flow raises FloatingPointError for
    a non-finite state or step doublings that do not converge, ValueError for a singular
    mass matrix) is a rejected step: the step is halved and the iteration goes on to the
    same orbit (the horizontal drive's tilted orbit, to the residual tolerance).  Before,
    the exception escaped from the first trial."""
    po = sys.modules["kapitza.floquet._shooting"]
    s = problems.driven_pendulum("horizontal")
    P = dict(m=1.0, l=1.0, g=G, A=0.05, omega=2 * math.pi * 60)
    ref = periodic_orbit(s, P, [1.5])
    calls = []

    def failing_first_trial(*args, **kwargs):
        calls.append(args[1])
        if len(calls) == 2:                     # call 1: the guess; call 2: the full step
            raise failure("injected: the trial state's flow failed")
        return flow(*args, **kwargs)
    monkeypatch.setattr(po, "flow", failing_first_trial)
    orbit = periodic_orbit(s, P, [1.5])
    # the third flow is the halved step: y + ½ δy, half-way between the guess and call 2
    assert np.allclose(calls[2], (calls[0] + calls[1]) / 2, rtol=0, atol=1e-15)
    assert np.max(np.abs(orbit.state - ref.state)) < 1e-9
    assert orbit.stable and orbit.omega_slow == pytest.approx(ref.omega_slow, rel=1e-9)

    monkeypatch.setattr(po, "flow", lambda *a, **k: (_ for _ in ()).throw(failure("x")))
    with pytest.raises(ValueError, match="flow over one period from the guess .* failed"):
        periodic_orbit(s, P, [1.5])


def test_circular_pivot_at_omega_ratio_133_ends_in_seconds():
    """The set-up that took 352 s and ended in FloatingPointError (studies/other_drives.py:
    circular pivot A = B = 0.2 l, ω/ω0 = 133, undamped).  The cause: each accepted Newton
    step doubled the flow's step count (flow returns at least twice the count it starts
    from), 2^19 steps per period after 14 steps.  Now from the at-rest guess θ = π Newton
    does not reach the orbit (the orbit starts at θ ≈ π + A/l with q̇ = 4 rad/s; the
    iteration wanders off to θ ≈ 5 rad): a ValueError naming the guess in about a second
    (measured 0.15 s compiled).  Continued from the orbit at ω/ω0 = 200 it converges in a
    few steps to the unstable upright orbit, period mean π, whose growth per period is
    averaging's e^(ω0 T) = 1.0484 (U_eff = −g l cos θ + const, PHYSICS.md) to 3e-3
    (measured |λ| = 1.0497: the excess is O(A²/l²)))."""
    s = elliptic_pendulum()
    w0 = math.sqrt(G)
    P = dict(m=1.0, l=1.0, g=G, A=0.2, B=0.2, omega=132.7465766 * w0, gamma=0.0)
    t0 = time.perf_counter()
    with pytest.raises(ValueError, match="no periodic orbit reached from this guess"):
        periodic_orbit(s, P, [math.pi])
    assert time.perf_counter() - t0 < 30.0
    start = periodic_orbit(s, dict(P, omega=200 * w0), [math.pi]).state
    orbit = periodic_orbit(s, P, start)
    assert orbit.iterations <= 10 and not orbit.stable
    assert abs(orbit.q_mean[0] - math.pi) < 1e-6
    assert np.max(np.abs(orbit.multipliers)) == pytest.approx(math.exp(2 * math.pi * w0 /
                                                                       P["omega"]), rel=3e-3)


def test_guess_keyword_is_deprecated_for_about():
    """``guess=`` (kapitza 0.1) still works in 0.2, warns with the new spelling, and gives
    the same orbit to the last bit; giving both is an error."""
    s = problems.driven_pendulum("horizontal")
    P = dict(m=1.0, l=1.0, g=G, A=0.05, omega=2 * math.pi * 60)
    new = periodic_orbit(s, P, [1.5])
    with pytest.warns(DeprecationWarning, match=r"periodic_orbit\(about=\.\.\.\)") as rec:
        old = periodic_orbit(s, P, guess=[1.5])
    assert rec[0].filename == __file__                  # points at the caller's line
    np.testing.assert_array_equal(old.state, new.state)
    np.testing.assert_array_equal(old.multipliers, new.multipliers)
    assert old.error_estimate == new.error_estimate
    with pytest.raises(TypeError, match="pass only about"):
        periodic_orbit(s, P, [1.5], guess=[1.5])
    with pytest.raises(TypeError, match="unexpected keyword"):
        periodic_orbit(s, P, [1.5], gues=[1.5])


def test_error_estimate_covers_the_state_error():
    """``error_estimate`` bounds the state's error (‖J⁻¹‖ × (residual + flow error)) and the
    monodromy's: a loose orbit (tol = 1e-6) against the same orbit shot to 2e-12 differs by
    less than its estimate, and the estimate is not vacuous (within 1000× of the difference;
    measured 5.4e-7 state, 2.1e-7 monodromy for an estimate of 7.8e-5: the flow's
    step-doubling difference overstates its error).  At the default tol the estimate is
    below 1e-9 (the horizontal drive's tilted orbit at 60 Hz and the elliptic pivot's
    upright orbit)."""
    pend = KapitzaPendulum(drive="horizontal")
    w = 2 * math.pi * 60
    fine = pend.floquet(0.05, w, about="tilted", tol=2e-12)
    loose = pend.floquet(0.05, w, about="tilted", tol=1e-6)
    err = np.max(np.abs(loose.state - fine.state))
    assert err <= loose.error_estimate < 1000 * err
    assert np.max(np.abs(loose.monodromy - fine.monodromy)) <= loose.error_estimate
    default = pend.floquet(0.05, w, about="tilted")
    assert np.max(np.abs(default.state - fine.state)) <= default.error_estimate < 1e-9
    s = elliptic_pendulum()
    P = dict(m=1.0, l=1.0, g=G, A=0.002, B=0.05, omega=2 * math.pi * 60, gamma=0.0)
    loose = periodic_orbit(s, P, [math.pi], tol=1e-6)
    fine = periodic_orbit(s, P, loose.state, tol=2e-12)
    assert np.max(np.abs(loose.state - fine.state)) <= loose.error_estimate < 1e-3
    assert periodic_orbit(s, P, [math.pi]).error_estimate < 1e-9


def test_symmetry_is_tested_not_assumed():
    """The half-period shooting is used only where the vector field has the symmetry
    f(2c − q, −q̇, t + T/2) = −f(q, q̇, t): the horizontal drive about θ = 0 (auto, or
    declared with a full-state guess), not about the tilted guess, not the elliptic pivot
    (B ≠ 0 breaks it; declaring it there is an error), never for an even ``periods``."""
    s = problems.driven_pendulum("horizontal")
    P = dict(m=1.0, l=1.0, g=G, A=0.01, omega=2 * math.pi * 30)
    auto = periodic_orbit(s, P, [0.0])
    assert "half-period" in auto.method and abs(auto.q_mean[0]) < 1e-12
    declared = periodic_orbit(s, P, auto.state + [1e-3, 0.0], symmetry=[0.0])
    assert "half-period" in declared.method
    assert np.max(np.abs(declared.state - auto.state)) < 1e-12
    full = periodic_orbit(s, P, [0.0], symmetry=None)
    assert "half-period" not in full.method
    assert np.max(np.abs(full.state - auto.state)) < 1e-9
    # the two monodromies agree: (R X_h)² is the full period's
    assert np.max(np.abs(full.monodromy - auto.monodromy)) < 1e-9
    assert "half-period" not in periodic_orbit(s, dict(P, A=0.05, omega=2 * math.pi * 60),
                                               [1.5]).method
    with pytest.raises(ValueError, match="even number of periods"):
        periodic_orbit(s, P, [0.0], symmetry=[0.0], periods=2)
    assert "half-period" not in periodic_orbit(s, P, [0.0], periods=2).method
    e = elliptic_pendulum()
    Pe = dict(m=1.0, l=1.0, g=G, A=0.002, B=0.05, omega=2 * math.pi * 60, gamma=0.0)
    with pytest.raises(ValueError, match="does not have the half-period reflection symmetry"):
        periodic_orbit(e, Pe, [math.pi], symmetry=[math.pi])
    assert "half-period" not in periodic_orbit(e, Pe, [math.pi]).method
    with pytest.raises(ValueError, match="symmetry must be 'auto'"):
        periodic_orbit(s, P, [0.0], symmetry="yes")
    with warnings.catch_warnings():
        warnings.simplefilter("error")              # a well-conditioned orbit warns nothing
        periodic_orbit(s, P, [0.0])
