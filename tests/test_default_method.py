"""What ``simulate(..., method=None)`` gives (issue 11, point 8): the method named, its
accuracy on the work–precision problem, and a step that keeps the tolerance when the
motion speeds up.  Speed is measured in benchmarks/ (bench_work_precision.py,
bench_call_overhead.py), not here.
"""
from __future__ import annotations

import math

import numpy as np
import pytest
import sympy as sp

from lagrange_core import Particle, System, coordinates, problems
from lagrange_core import t as T_SYM

# the work–precision problem of benchmarks/bench_work_precision.py
DRIVEN = dict(A=0.05, g=9.81, l=1.0, m=1.0, omega=2 * math.pi * 60)
THETA0 = math.pi - 0.1
SPAN = (0.0, 2000 * 2 * math.pi / DRIVEN["omega"])


@pytest.fixture(scope="module")
def driven():
    return problems.driven_pendulum()


@pytest.fixture(scope="module")
def reference(driven):
    """θ(T) by another method on other kernels (DOP853 on the generic right-hand side) at
    rtol 1e-13; it agrees with heyoka's Taylor integrator in long double (tol 1e-18) to
    7e-12 (benchmarks/README.md), and with the RKN 12 at rtol 1e-12 below."""
    ref = driven.simulate([THETA0], [0.0], SPAN, DRIVEN, method="dop853", rtol=1e-13,
                          atol=1e-13, stride=10**9)
    return float(ref.q[-1, 0])


def test_the_reference_agrees_with_the_default_at_tight_tolerance(driven, reference):
    tight = driven.simulate([THETA0], [0.0], SPAN, DRIVEN, rtol=1e-12, stride=10**9)
    assert abs(tight.q[-1, 0] - reference) < 2e-11


@pytest.mark.parametrize("rtol", [1e-3, 1e-4, 1e-5, 1e-6, 1e-7, 1e-8, 1e-9, 1e-10])
def test_default_reaches_rtol_on_the_work_precision_problem(driven, reference, rtol):
    """2000 drive periods of the upright Kapitza pendulum: |θ(T) − θ_ref(T)| ≤ rtol (the
    module docstring's rule 3; measured 0.02–0.9 rtol)."""
    tr = driven.simulate([THETA0], [0.0], SPAN, DRIVEN, rtol=rtol, stride=10**9)
    assert tr.method == "rkn12" and tr.status == "success"
    err = abs(tr.q[-1, 0] - reference)
    assert err <= rtol, (rtol, err)
    # and the sum of the local estimates, an upper bound for this motion, bounds it too
    assert err <= tr.error_estimate


def test_held_step_rejects_few_steps_and_matches_the_fixed_step(driven):
    """The held step takes about the steps of rkn12-fixed (its step chosen from the same
    tolerance by a pilot) and rejects about 1 % (the classic controller: 20 %)."""
    held = driven.simulate([THETA0], [0.0], SPAN, DRIVEN, rtol=1e-8, stride=10**9)
    fixed = driven.simulate([THETA0], [0.0], SPAN, DRIVEN, method="rkn12-fixed", rtol=1e-8,
                            stride=10**9)
    assert held.n_rejected < 0.02 * held.n_steps
    assert abs(held.n_steps - fixed.n_steps) < 0.05 * fixed.n_steps


@pytest.mark.parametrize("kw", [{}, {"t_eval": np.linspace(0.0, 0.1, 7)}, {"rtol": 1e-5},
                                {"stride": 3}])
def test_default_is_the_named_method_to_the_last_bit(driven, kw):
    """A short run (6 drive periods): method=None gives what naming "rkn12" gives."""
    args = ([THETA0], [0.0], (0.0, 0.1), DRIVEN)
    default = driven.simulate(*args, **kw)
    named = driven.simulate(*args, method="rkn12", **kw)
    assert default.method == named.method == "rkn12"
    for name in ("t", "q", "qdot", "energy"):
        assert np.array_equal(getattr(default, name), getattr(named, name)), name
    assert (default.n_steps, default.n_rejected, default.n_rhs) == \
        (named.n_steps, named.n_rejected, named.n_rhs)


def test_default_is_dop853_when_the_forcing_depends_on_the_velocities():
    damped = problems.driven_pendulum(damping=True)
    params = dict(DRIVEN, gamma=0.5)
    default = damped.simulate([THETA0], [0.0], (0.0, 0.1), params)
    named = damped.simulate([THETA0], [0.0], (0.0, 0.1), params, method="dop853")
    assert default.method == "dop853"
    assert np.array_equal(default.t, named.t) and np.array_equal(default.q, named.q)


def test_default_keeps_the_tolerance_when_the_motion_speeds_up():
    """Why the default is "rkn12", whose step is checked at every step, and not
    "rkn12-fixed", whose step its pilot chooses at the start and nothing checks after.

    An oscillator whose frequency grows 11-fold over the run (q̈ = −(1 + t/20)² q, 200 s):
    the pilot finds its 8 steps past the starting ramp in the first 32 s (its first window,
    4 s, held too few), and the fixed step loses the phase (1.9e-2 of an amplitude 0.3,
    against DOP853 at rtol 1e-13); the default keeps the tolerance (4.7e-10).  A comet
    (Kepler orbit, eccentricity 0.9, Cartesian coordinates) from aphelion for three
    orbits, its speed growing 19-fold at perihelion: the default keeps the tolerance, with
    rejections where the comet speeds up.  (The comet's slow start gives the pilot too
    few steps, so it runs again over the perihelion; its fixed step keeps the orbit too:
    energy to 1.4e-8.  Before the pilot looked past its starting ramp, it chose the step
    from the slow start and lost the orbit.)"""
    (q,), (qd,) = coordinates("q")
    c = sp.Symbol("c", positive=True)
    chirp = System([q], lagrangian=qd**2 / 2 - (1 + c * T_SYM)**2 * q**2 / 2,
                   name="chirped oscillator")
    span, params = (0.0, 200.0), dict(c=0.05)
    ref = chirp.simulate([1.0], [0.0], span, params, method="dop853", rtol=1e-13, atol=1e-13)
    default = chirp.simulate([1.0], [0.0], span, params, rtol=1e-9)
    fixed = chirp.simulate([1.0], [0.0], span, params, method="rkn12-fixed", rtol=1e-9)
    assert default.method == "rkn12"
    assert abs(default.q[-1, 0] - ref.q[-1, 0]) < 1e-8
    assert abs(fixed.q[-1, 0] - ref.q[-1, 0]) > 1e-3

    x, y = sp.symbols("x y", real=True)
    m, k = sp.symbols("m k", positive=True)
    comet = System([x, y], particles=[Particle(m, (x, y))],
                   potential=-k / sp.sqrt(x**2 + y**2), name="comet")
    e = 0.9                                     # a = 1, k = m = 1: period 2π
    r_a, v_a = 1 + e, math.sqrt((1 - e) / (1 + e))
    E0 = v_a**2 / 2 - 1 / r_a
    params = dict(m=1.0, k=1.0)
    span = (0.0, 3 * 2 * math.pi)
    default = comet.simulate([r_a, 0.0], [0.0, v_a], span, params, rtol=1e-9)
    assert default.method == "rkn12" and default.n_rejected > 0
    assert np.max(np.abs(default.energy - E0)) < 1e-8
    assert math.hypot(default.q[-1, 0] - r_a, default.q[-1, 1]) < 1e-7
    fixed = comet.simulate([r_a, 0.0], [0.0, v_a], span, params, method="rkn12-fixed",
                           rtol=1e-9)
    assert np.max(np.abs(fixed.energy - E0)) < 1e-7
