"""Long orbits by multiple shooting and rotating (winding) orbits of ``periodic_orbit``
(issue 21, point 2 follow-up).

The system is studies/period_doubling.py's: the damped pendulum on a vertically shaken
pivot at ω = 2ω0, γ = 0.1 ω.  References independent of the shooting: direct simulation
(System.simulate, adaptive DOP853), Liouville's formula det M = e^(−γ P T) (the flow's
divergence is −γ), the study's committed doubling amplitudes p_4, p_5 (located by its own
Newton on composed one-period flows, before the library shot them), and a monodromy by
central differences of direct simulations.
"""
import math
import warnings

import numpy as np
import pytest

from kapitza.simulation._periodic_orbit import periodic_orbit
from lagrange_core import problems

G, L = 9.81, 1.0
W0 = math.sqrt(G / L)
OMEGA = 2 * W0
GAMMA = 0.1 * OMEGA
T = 2 * math.pi / OMEGA
#: studies/results/period_doubling (committed before this test): the 16T swing doubles at
#: p_4, the 32T one at p_5; a state on the 16T orbit at p_4 (θ, θ̇ at t = 0)
P4, P5 = 0.3576783998226051, 0.35770310653936405
STATE_P4 = (-0.007862886, 4.541192)


@pytest.fixture(scope="module")
def system():
    return problems.driven_pendulum("vertical", damping=True)


def params(A):
    return dict(m=1.0, l=L, g=G, omega=OMEGA, gamma=GAMMA, A=float(A))


def test_sixteen_period_orbit_by_multiple_shooting(system):
    """The 16T swing halfway between p_3 and p_4, where it is the attractor.  A direct
    simulation from near it settles (640 periods) to a strobe sequence of period 16; the
    library, from that state, shoots it by multiple shooting (automatic from 4 periods on:
    16 one-period segments) to the floor of its flows (tol=0).  The orbit equals the
    simulation's settled state to 1e-8 (measured 1.6e-11), repeats itself under direct
    simulation over 16 T, and its monodromy — the product of 16 segment Jacobians —
    obeys Liouville, det M = e^(−16 γ T), to 1e-10 (measured 2.4e-14).  Its error bound
    is 3.3e-9.  At the study's p_4 the orbit has the multiplier −1
    to 1e-8 (measured 3.3e-11: the study located p_4 by its own Newton on composed flows)."""
    A = 0.3576207699638527
    n = 40 * 16
    tr = system.simulate([STATE_P4[0]], [STATE_P4[1]], (0.0, n * T), params(A),
                         t_eval=np.arange(n - 32, n + 1) * T, rtol=1e-12, method="dop853")
    x = np.c_[tr.q[:, 0], tr.qdot[:, 0]]
    assert np.max(np.abs(x[16:] - x[:-16])) < 1e-8            # settled, period 16 …
    assert np.max(np.abs(x[8:] - x[:-8])) > 1e-3               # … not 8
    y_sim = x[-1]
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        orbit = periodic_orbit(system, params(A), y_sim, periods=16, symmetry=None, tol=0)
    assert "multiple shooting over 16 segments" in orbit.method
    assert orbit.residual < 1e-13 and orbit.stable
    gap = float(np.max(np.abs(orbit.state - y_sim)))
    assert gap < 1e-8
    back = system.simulate(orbit.state[:1], orbit.state[1:], (0.0, 16 * T), params(A),
                           rtol=1e-12, method="dop853")
    assert abs(back.q[-1, 0] - orbit.state[0]) < 1e-9
    assert abs(back.qdot[-1, 0] - orbit.state[1]) < 1e-8
    det = float(np.prod(orbit.multipliers).real)
    assert det == pytest.approx(math.exp(-GAMMA * 16 * T), rel=1e-10)
    assert orbit.error_estimate < 1e-6
    at_p4 = periodic_orbit(system, params(P4), STATE_P4, periods=16, symmetry=None, tol=0)
    assert np.min(np.abs(at_p4.multipliers + 1)) < 1e-8


def test_thirty_two_period_orbit_at_the_study_doubling(system):
    """The 32T swing at the study's p_5: multiple shooting finds the multiplier −1 there
    to 1e-8 (measured 5.2e-10) and the other, Liouville's e^(−32 γ T)/λ_1, to 1e-12
    (measured 3e-15); its bound (Newton–Kantorovich on the 32-segment system; 8e-8, the
    monodromy's share) is finite."""
    A = P5
    guess = np.array([-0.008319, 4.541734])
    orbit = periodic_orbit(system, params(A), guess, periods=32, symmetry=None, tol=0)
    assert "multiple shooting over 32 segments" in orbit.method
    lam = orbit.multipliers[np.argsort(np.abs(orbit.multipliers + 1))]
    assert abs(lam[0] + 1) < 1e-8
    assert abs(lam[1].real - math.exp(-GAMMA * 32 * T) / lam[0].real) < 1e-12
    assert orbit.error_estimate < 1e-4
    # one flow over 32 periods cannot converge in its Jacobian at the default tolerance
    with pytest.raises(ValueError, match="flow over 32 periods from the guess"):
        periodic_orbit(system, params(A), orbit.state, periods=32, symmetry=None,
                       shooting="single")


def _finite_difference_monodromy(system, A, y, h=1e-5):
    """∂y(T)/∂y(0) by central differences of System.simulate (DOP853, rtol 1e-13)."""
    M = np.empty((2, 2))
    for j in range(2):
        ends = []
        for sign in (1, -1):
            z = np.array(y, dtype=float)
            z[j] += sign * h
            tr = system.simulate(z[:1], z[1:], (0.0, T), params(A), rtol=1e-13,
                                 method="dop853")
            ends.append(np.r_[tr.q[-1], tr.qdot[-1]])
        M[:, j] = (ends[0] - ends[1]) / (2 * h)
    return M


def test_rotating_orbit_against_simulation_and_finite_differences(system):
    """At A = 0.35762 l the pendulum, started at (0.36 rad, 4.5 rad/s), settles into
    whirling once per drive period.  ``periodic_orbit(winding=1)`` from the settled state
    (taken mod 2π) finds that rotating orbit: direct simulation from it advances θ by
    2π per period to 1e-8 over 5 periods and returns θ̇; its multipliers equal the
    eigenvalues of a finite-difference monodromy of direct simulations to 1e-6 (measured
    1.3e-9) and obey Liouville, |λ|² = e^(−γT), to 1e-10; it is stable, as the settling
    says."""
    A = 0.35762
    tr = system.simulate([0.36], [4.5], (0.0, 400 * T), params(A),
                         t_eval=np.arange(396, 401) * T, rtol=1e-11, method="dop853")
    turns = np.diff(tr.q[:, 0]) / (2 * math.pi)
    assert np.allclose(turns, 1.0, atol=1e-6)                 # whirling, once per period
    y = np.array([math.remainder(tr.q[-1, 0], 2 * math.pi), tr.qdot[-1, 0]])
    orbit = periodic_orbit(system, params(A), y, winding=1)
    assert "rotating" in orbit.method and orbit.stable
    assert abs(orbit.state[0] - y[0]) + abs(orbit.state[1] - y[1]) < 1e-6
    run = system.simulate(orbit.state[:1], orbit.state[1:], (0.0, 5 * T), params(A),
                          t_eval=np.arange(6) * T, rtol=1e-12, method="dop853")
    assert np.max(np.abs(np.diff(run.q[:, 0]) - 2 * math.pi)) < 1e-8
    assert np.max(np.abs(run.qdot[:, 0] - orbit.state[1])) < 1e-7
    fd = np.linalg.eigvals(_finite_difference_monodromy(system, A, orbit.state))
    lam = orbit.multipliers
    assert np.max(np.abs(np.sort_complex(fd) - np.sort_complex(lam))) < 1e-6
    assert np.abs(lam[0]) ** 2 == pytest.approx(math.exp(-GAMMA * T), rel=1e-10)
    # the rotation is removed from the period mean and the amplitude
    assert abs(orbit.amplitude[0]) < 1.0 and abs(orbit.q_mean[0]) < 4 * math.pi
    # the same orbit by multiple shooting over two periods (winding 2): the same state
    two = periodic_orbit(system, params(A), orbit.state, winding=2, periods=2,
                         shooting="multiple")
    assert np.max(np.abs(two.state - orbit.state)) < 1e-9


def test_winding_and_shooting_arguments_are_checked(system):
    P = params(0.35762)
    with pytest.raises(ValueError, match="winding must be a whole number"):
        periodic_orbit(system, P, [0.0, 5.0], winding=0.5)
    with pytest.raises(ValueError, match="rotating orbit has no half-period reflection"):
        periodic_orbit(system, P, [0.0, 5.0], winding=1, symmetry=[0.0])
    with pytest.raises(ValueError, match="shooting must be one of"):
        periodic_orbit(system, P, [0.0, 5.0], shooting="double")
    with pytest.raises(ValueError, match="tol must be a number in"):
        periodic_orbit(system, P, [0.0, 5.0], tol=-1.0)
