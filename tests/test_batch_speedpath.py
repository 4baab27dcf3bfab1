"""The fast path of ``System.simulate_grid`` (issue 11, point 7): RKN 12(10) on *lanes*.

``lagrange_core._batch_kernels.grid_rkn_lanes`` advances many trajectories per thread
with every loop over them vectorised, calling the drive kernel's ``fast_accel_lanes``
once per stage for all of them, with sin/cos from ``lagrange_core._lane_math``.  Each
fast path is checked here against something independent:

* the lane arithmetic against libm (``numpy.sin``) and ``numpy.linalg.solve``;
* the lanes against the per-point integrator of the same module (the code path
  without lanes, ``batch._USE_LANES = False``): at a fixed step the same steps, the same
  statuses and counts, and states equal to rounding; adaptive, the same step control
  (their step sequences part at rounding-level differences of the error estimate);
* adaptive lanes against ``System.simulate`` at a much tighter tolerance;
* systems with several coordinates (a non-diagonal mass matrix solved on the lanes), two
  drive rates, arguments of sin beyond the lane polynomial's range;
* failures (a blow-up, a zero mass, a singular mass matrix) that stay in their lane: the
  other points are bit for bit what they are without the failing ones.
"""
import math
import threading

import numba
import numpy as np
import pytest
import sympy as sp
from numba import njit

from lagrange_core import Particle, System, batch, coordinates, problems
from lagrange_core import _batch_kernels as bk
from lagrange_core._kernel_calls import FAST_ACCEL_LANES, call_fast_accel_lanes
from lagrange_core._lane_math import BIG_ARGUMENT, lane_cos, lane_sin, lane_solve
from lagrange_core._shared_cursor import take
from lagrange_core._thread_blocks import run_blocks
from lagrange_core.drive_kernel import load_drive_kernel
from lagrange_core.symbols import t as T_SYM

PEND = dict(m=1.0, l=1.0, g=9.81)
UP_BAND = ([math.pi / 2], [3 * math.pi / 2])


def both(system, *args, **kw):
    """The grid on lanes and per point (the lanes kernel is checked to have run)."""
    calls = []
    real = bk.grid_rkn_lanes

    def spy(*a):
        calls.append(len(a[3]))
        return real(*a)

    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(bk, "grid_rkn_lanes", spy)
        lanes = system.simulate_grid(*args, progress=False, **kw)
    assert sum(calls) == lanes.size, "the lanes kernel did not run every point"
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(batch, "_USE_LANES", False)
        point = system.simulate_grid(*args, progress=False, **kw)
    return lanes, point


def assert_same_run(lanes, point, atol, steps=True):
    """Same statuses (and, at a fixed step, the same counts: evaluations where the band
    was not left, since locating an exit takes a rounding-dependent number of trial
    steps); every observable within atol."""
    assert np.array_equal(lanes.status, point.status), (lanes.status_name, point.status_name)
    if steps:
        stayed = lanes.status != 1
        assert np.array_equal(lanes.n_steps, point.n_steps)
        assert np.array_equal(lanes.n_evaluations[stayed], point.n_evaluations[stayed])
        assert np.array_equal(lanes.n_rejected, point.n_rejected)
    for name in ("t_final", "q", "qdot", "q_mean", "strobe_q", "strobe_qdot", "max_deviation",
                 "exit_time", "energy_drift"):
        a, b = getattr(lanes, name), getattr(point, name)
        if a is None:
            continue
        assert np.array_equal(np.isnan(a), np.isnan(b)), name
        ok = ~np.isnan(a)
        assert np.all(np.abs(a[ok] - b[ok]) <= atol * (1 + np.abs(b[ok]))), \
            (name, np.max(np.abs(a[ok] - b[ok])))


@pytest.fixture(scope="module")
def pend():
    return problems.driven_pendulum("vertical")


def coupled(n):
    """n driven pendulums on one vertically vibrating support, neighbours coupled by a
    torsion spring, with a constant non-diagonal mass matrix (2 on the diagonal, ½ beside
    it): q̈ = M⁻¹ F(q, t), so the lanes solve M on every evaluation."""
    qs, qds = coordinates([f"th{i}" for i in range(n)])
    m, l, g, A, om, k = sp.symbols("m l g A omega k", positive=True)
    T = sum(m * l**2 * (2 if i == j else sp.Rational(1, 2)) * qds[i] * qds[j] / 2
            for i in range(n) for j in range(n) if abs(i - j) <= 1)
    V = -sum(m * l * (g - A * om**2 * sp.cos(om * T_SYM)) * sp.cos(q) for q in qs)
    V += k * sum((qs[i] - qs[i + 1]) ** 2 for i in range(n - 1)) / 2
    return System(qs, lagrangian=T - V, name=f"{n} coupled driven pendulums")


# -- the lane arithmetic ------------------------------------------------------------------

@njit(cache=True)
def _lane_sin_cos(x, s, c):
    for i in range(x.shape[0]):
        s[i] = lane_sin(x[i])
        c[i] = lane_cos(x[i])


def test_lane_sin_cos_within_two_ulp_of_libm():
    rng = np.random.default_rng(0)
    x = np.concatenate([rng.uniform(-4, 4, 100000), rng.uniform(-1e6, 1e6, 100000),
                        np.arange(-2000, 2000) * (np.pi / 2), [0.0, -0.0, 1e-300, 5e-324]])
    s, c = np.empty_like(x), np.empty_like(x)
    _lane_sin_cos(x, s, c)
    for mine, ref in ((s, np.sin(x)), (c, np.cos(x))):
        ulps = np.abs(mine - ref) / np.spacing(np.abs(ref))
        assert ulps.max() <= 2.0, ulps.max()
    big = np.array([BIG_ARGUMENT * 1.0001, -3e6, np.inf, -np.inf, np.nan])
    s, c = np.empty_like(big), np.empty_like(big)
    _lane_sin_cos(big, s, c)
    assert np.isnan(s).all() and np.isnan(c).all()      # the caller falls back to libm


@njit(cache=True)
def _solve(work, n, L):
    lane_solve(work, n, L)


@pytest.mark.parametrize("n", [1, 2, 3, 5])
def test_lane_solve_matches_numpy_and_flags_singular_lanes(n):
    rng = np.random.default_rng(n)
    L = 13
    w = n + 1
    work = np.zeros((1 + n * w, L))
    M = np.empty((L, n, n))
    F = rng.normal(size=(L, n))
    for l in range(L):
        B = rng.normal(size=(n, n))
        M[l] = B @ B.T + n * np.eye(n)             # symmetric positive definite
    M[3] = 0.0                                     # singular
    M[5, 0, 0] = np.nan                            # not finite
    for i in range(n):
        for j in range(n):
            work[1 + i * w + j] = M[:, i, j]
        work[1 + i * w + n] = F[:, i]
    _solve(work, n, L)
    X = np.stack([work[1 + i * w + n] for i in range(n)], axis=1)
    flagged = work[0] != 0
    assert flagged[3] and flagged[5] and flagged.sum() == 2
    for l in np.flatnonzero(~flagged):
        assert np.allclose(X[l], np.linalg.solve(M[l], F[l]), rtol=1e-13, atol=1e-14)


# -- lanes against the per-point integrator -----------------------------------------------

@pytest.fixture(scope="module")
def sweep():
    """A 9 × 9 grid of the benchmark's problem over 80 periods (some points fall)."""
    A = np.linspace(0.005, 0.2, 9)[:, None]
    w = 2 * np.pi * np.linspace(5.0, 100.0, 9)[None, :]
    T = 2 * np.pi / w
    return ([np.pi - 0.1], [0.0], (0.0, 80 * T), dict(PEND, A=A, omega=w)), T


def test_fixed_step_lanes_take_the_per_point_steps(pend, sweep):
    """At a given fixed step, every observable on: the same steps, counts and statuses,
    states equal to rounding (measured ≤ 7e-14)."""
    args, T = sweep
    lanes, point = both(pend, *args, method="rkn12-fixed", h=T / 3, band=UP_BAND, strobe=T,
                        reference=[np.pi])
    counts = lanes.counts()
    assert counts["finished"] > 20 and counts["left_band"] > 5, counts
    assert_same_run(lanes, point, atol=1e-10)


def test_piloted_fixed_step_on_lanes(pend, sweep):
    """"rkn12-fixed" without h: the pilot (adaptive, over the first 1/50 of the span) runs
    on the lanes too.  Its step sequence reacts to rounding-level differences of the
    error estimate, so the chosen step may differ by one step per strobe period: the
    same statuses, step counts within one per period (80 periods), states within the
    tolerance."""
    args, T = sweep
    lanes, point = both(pend, *args, method="rkn12-fixed", rtol=1e-8, band=UP_BAND, strobe=T,
                        reference=[np.pi])
    assert_same_run(lanes, point, atol=1e-6, steps=False)
    assert np.all(np.abs(lanes.n_steps - point.n_steps) <= 80 + 2)


def test_adaptive_lanes_follow_the_per_point_step_control(pend):
    """Adaptive ("rkn12", the default): the same controller (held step); the step
    sequences part where rounding moves an error estimate across one of the held
    step's thresholds (a new held step replaces the old one only if they differ by
    10 %), so the counts agree within a step per drive period (as the per-point grid
    and ``simulate`` do: measured up to 88 of 700 there) and the states to the
    tolerance (at a band exit, to the accuracy of the step's cubic Hermite interpolant
    there, O(h⁴): measured 1e-6 in θ̇)."""
    A = np.linspace(0.02, 0.2, 6)[:, None]
    w = 2 * np.pi * np.linspace(20.0, 100.0, 6)[None, :]
    T = 2 * np.pi / w
    lanes, point = both(pend, [np.pi - 0.1], [0.0], (0.0, 100 * T), dict(PEND, A=A, omega=w),
                        band=UP_BAND, strobe=T, rtol=1e-10)
    assert lanes.method == "rkn12"
    assert_same_run(lanes, point, atol=1e-5, steps=False)
    assert np.all(np.abs(lanes.n_steps - point.n_steps) <= 100 + 2)


def test_adaptive_lanes_match_simulate(pend):
    """Strobe samples of the default method at rtol 1e-10 on lanes against separate
    ``simulate`` runs at rtol 1e-13 (as test_batch's per-point check), and the held
    step takes about the steps of simulate's "rkn12" at the same tolerance."""
    A = np.array([0.03, 0.1])[:, None]
    w = 2 * np.pi * np.array([25.0, 70.0])[None, :]
    T = 2 * np.pi / w
    g, _ = both(pend, [np.pi - 0.05], [0.0], (0.0, 60 * T), dict(PEND, A=A, omega=w),
                strobe=T, rtol=1e-10)
    for i in range(2):
        for j in range(2):
            p = dict(PEND, A=A[i, 0], omega=w[0, j])
            ref = pend.simulate([np.pi - 0.05], [0.0], (0.0, 60 * T[0, j]), p, rtol=1e-13,
                                t_eval=np.arange(61) * T[0, j])
            assert np.max(np.abs(g.strobe_q[i, j, :, 0] - ref.q[:, 0])) < 1e-8
            same = pend.simulate([np.pi - 0.05], [0.0], (0.0, 60 * T[0, j]), p, rtol=1e-10,
                                 t_eval=np.arange(61) * T[0, j])
            assert abs(g.n_steps[i, j] - same.n_steps) <= 60 + 2     # a step per period


@pytest.mark.parametrize("n", [2, 3])
@pytest.mark.parametrize("method, step, atol, steps", [
    ("rkn12-fixed", dict(h=0.1 / 20), 1e-10, True), ("rkn12", dict(rtol=1e-9), 1e-7, False)])
def test_several_coordinates_on_lanes(n, method, step, atol, steps):
    """n = 2, 3 coupled driven pendulums near upright (non-diagonal M: the lanes solve it
    without pivoting, the per-point kernel with pivoting), a 3 × 2 grid of drives; the
    fixed step given (a pilot's may differ by a rounding-decided rejection:
    test_piloted_fixed_step_on_lanes)."""
    s = coupled(n)
    A = np.array([0.0, 0.01, 0.05])[:, None]
    w = 2 * np.pi * np.array([20.0, 40.0])[None, :]
    q0 = [np.pi - 0.05, np.pi + 0.03, np.pi - 0.02][:n]
    lanes, point = both(s, q0, [0.0] * n, (0.0, 1.0), dict(m=1.0, l=1.0, g=9.81, k=2.0, A=A,
                                                         omega=w), method=method,
                        strobe=0.1, **step)
    assert (lanes.status == 0).all()
    assert_same_run(lanes, point, atol=atol, steps=steps)


def test_a_sparse_mass_matrix_on_lanes_and_per_point():
    """A string of 6 beads: its [M | F] is mostly zeros (M diagonal), which the drive
    kernels zero by a loop and do not write one by one (the 20-bead string's first RKN 12
    run compiled in 4.4–4.8 s instead of 9.6–11.5 s).  Its fundamental mode over one
    period, a 3-point grid of amplitudes: on lanes and per point the same run, and both
    within 1e-9 of the amplitude of DOP853 on the first-order kernel, which is generated
    by another code path."""
    from lagrange_core.drive_kernel import _generated_source
    N, P = 6, dict(F=80.0, mu=0.005, l=0.65)
    s = problems.bead_string(N)
    assert "Wn[_i, _j] = 0.0" in _generated_source(s.equations)       # the sparse form
    h = P["l"] / (N + 1)
    shape = np.sin(np.pi * np.arange(1, N + 1) * h / P["l"])
    w1 = 2 * math.sqrt(P["F"] / (P["mu"] * h**2)) * math.sin(math.pi / (2 * (N + 1)))
    amplitudes = np.array([1e-5, 1e-4, 1e-3]) * P["l"]
    y0 = amplitudes[:, None] * shape
    span = (0.0, 2 * np.pi / w1)
    # a fixed step (200 a period, 46 a period of the highest mode): the same steps
    lanes, point = both(s, y0, np.zeros_like(y0), span, P, method="rkn12-fixed",
                        h=span[1] / 200)
    assert (lanes.status == 0).all()
    assert_same_run(lanes, point, atol=1e-12)
    for k, a in enumerate(amplitudes):
        ref = s.simulate(y0[k], np.zeros(N), span, P, method="dop853", rtol=1e-12,
                         atol=1e-12 * a)
        assert np.max(np.abs(lanes.q[k] - ref.q[-1])) < 1e-9 * a


@pytest.mark.parametrize("periods", [1, 30])
def test_a_piloted_step_comes_from_steps_past_the_starting_ramp(periods):
    """A string of 6 beads in its fundamental mode: its RKN 12 step at rtol 1e-9 is about
    a third of the period, and the controller starts at 1/3800 of it, growing the step
    5-fold a step.  The pilot over 1/50 of a span of 1 or 30 periods was all that ramp, and
    "rkn12-fixed" took 3800 (or 760) steps a period where "rkn12" took 4–8 (before the fix:
    3814 and 762).  The pilot now runs again over a window 8 times longer until it has 8
    steps past the ramp: the piloted run, pilot included, takes at most 4 times the
    adaptive run's steps (measured: 3.0 and 1.06), on lanes, per point and in
    ``simulate``; and its error against DOP853 at rtol 1e-13 stays within 100 rtol of the
    amplitude, as the adaptive run's (measured: 4.7e-8 adaptive, 4.4e-9 piloted, over 30
    periods).  Lanes and per point are each held to this, not to each other: on this
    string a rounding decides some of the pilot's rejections (the adaptive run itself
    takes 117 steps on lanes and 118 per point)."""
    N, P = 6, dict(F=80.0, mu=0.005, l=0.65)
    s = problems.bead_string(N)
    h = P["l"] / (N + 1)
    shape = np.sin(np.pi * np.arange(1, N + 1) * h / P["l"])
    w1 = 2 * math.sqrt(P["F"] / (P["mu"] * h**2)) * math.sin(math.pi / (2 * (N + 1)))
    amplitudes = np.array([1e-5, 1e-4, 1e-3]) * P["l"]
    y0 = amplitudes[:, None] * shape
    span = (0.0, periods * 2 * np.pi / w1)
    lanes, point = both(s, y0, np.zeros_like(y0), span, P, method="rkn12-fixed")
    adaptive = s.simulate_grid(y0, np.zeros_like(y0), span, P, method="rkn12", progress=False)
    assert (adaptive.status == 0).all()
    for run in (lanes, point):
        assert (run.status == 0).all()
        assert np.all(run.n_steps <= 4 * adaptive.n_steps), (run.n_steps, adaptive.n_steps)
    for k, a in enumerate(amplitudes):
        ref = s.simulate(y0[k], np.zeros(N), span, P, method="dop853", rtol=1e-13,
                         atol=1e-13 * a).q[-1]
        for run in (lanes, point, adaptive):
            assert np.max(np.abs(run.q[k] - ref)) < 100 * lanes.rtol * a, run.method
        one = s.simulate(y0[k], np.zeros(N), span, P, method="rkn12-fixed")
        assert len(one.t) - 1 <= 4 * adaptive.n_steps[k]
        assert np.max(np.abs(one.q[-1] - ref)) < 100 * lanes.rtol * a


def test_two_drive_rates_on_lanes():
    """A pendulum whose pivot moves as (A cos ω₁t, B cos ω₂t): two drive rates, rotated
    separately on the lanes."""
    (th,), _ = coordinates("theta")
    m, l, g, A, B, w1, w2 = sp.symbols("m l g A B omega1 omega2", positive=True)
    bob = Particle(m, (A * sp.cos(w1 * T_SYM) + l * sp.sin(th),
                       B * sp.cos(w2 * T_SYM) - l * sp.cos(th)))
    s = System([th], particles=[bob], potential=m * g * bob.position[1], name="two-rate")
    p = dict(m=1.0, l=1.0, g=9.81, A=0.02, B=np.array([0.03, 0.05]), omega1=2 * np.pi * 30,
             omega2=2 * np.pi * np.array([[47.0], [61.0]]))
    # at a fixed step (12 a strobe period): a pilot's step may differ on lanes and per
    # point by a rejection that a rounding decides (test_piloted_fixed_step_on_lanes)
    lanes, point = both(s, [np.pi - 0.1], [0.0], (0.0, 3.0), p, method="rkn12-fixed",
                        h=0.1 / 12, strobe=0.1)
    assert_same_run(lanes, point, atol=1e-10)


def test_arguments_beyond_the_lane_sine_go_to_libm(pend):
    """θ beyond BIG_ARGUMENT (a pendulum counted 3·10⁵ turns round): the lane sine gives
    NaN there, and the kernel computes those lanes again with libm, as the per-point
    kernel does; a neighbour at an ordinary angle is untouched."""
    q0 = np.array([2 * np.pi * 3e5 + np.pi - 0.1, np.pi - 0.1])[:, None]
    assert abs(q0[0, 0]) > BIG_ARGUMENT
    # at a fixed step (136 over the span, what a pilot at rtol 1e-8 picks): a pilot's steps
    # at 3·10⁵ turns are not the same on lanes and per point to the last rejection (the
    # adaptive run takes 81 and 82 steps), so its fixed step need not be either
    lanes, point = both(pend, q0, [0.0], (0.0, 0.5), dict(PEND, A=0.05, omega=2 * np.pi * 50),
                        method="rkn12-fixed", h=0.5 / 136)
    assert (lanes.status == 0).all()
    assert_same_run(lanes, point, atol=1e-10)


def test_refilled_lanes_and_part_empty_tails(pend):
    """More points than lanes, of very different lengths (spans of 1 to 40 periods, some
    falling early): lanes are refilled as points end and run part-empty at the end of a
    block; every point as per point."""
    rng = np.random.default_rng(3)
    N = 2 * bk.LANES + 37
    A = rng.uniform(0.003, 0.03, N)             # weak drives: many fall, at various times
    w = 2 * np.pi * rng.uniform(5, 100, N)
    T = 2 * np.pi / w
    span = rng.integers(1, 40, N) * T
    lanes, point = both(pend, [np.pi - 0.1], [0.0], (0.0, span), dict(PEND, A=A, omega=w),
                        band=UP_BAND, method="rkn12-fixed", h=T / 4)
    assert 10 < lanes.counts()["left_band"] < N - 10
    assert_same_run(lanes, point, atol=1e-10)


@njit(nogil=True, cache=True)
def _take_all(cursor, end, taker, me):
    taken = 0
    while True:
        k = take(cursor)
        if k >= end:
            return taken
        taker[k] = me
        taken += 1


def test_the_shared_cursor_hands_each_point_to_one_thread():
    """Two threads taking 2·10⁶ points from one cursor at once (lagrange_core.
    _shared_cursor): each point taken exactly once — an increment that is not atomic
    loses updates, and then two threads take the same point and the counts add up to
    more than the points.

    The check means something only where both threads took points.  They start together
    (a barrier), yet on a loaded machine one thread can take all 2·10⁶ (~20 ms) before the
    other gets a core (seen once in a fresh clone's run, its workers compiling; with a
    non-atomic increment, on the idle machine, 3 runs in 10 had both threads taking points,
    and each of those failed the check): up to twenty runs, every one checked, until three
    had both threads taking points; none in twenty fails (the blocks never ran at once)."""
    if numba.config.NUMBA_NUM_THREADS < 2:
        pytest.skip("one thread: nothing is shared")
    cursor, taker = np.zeros(1, dtype=np.int64), np.zeros(2_000_000, dtype=np.int64)
    _take_all(np.zeros(1, dtype=np.int64), 0, taker, 0)           # compiled first
    start = threading.Barrier(2)
    shared = 0
    before = numba.get_num_threads()
    numba.set_num_threads(2)                    # run_blocks' threads: numba's count
    try:
        for _ in range(20):
            cursor[0], taker[:], counts = 0, 0, []

            def block(b, counts=counts):
                start.wait(timeout=60)
                counts.append(_take_all(cursor, taker.size, taker, b + 1))

            run_blocks(block, 2)
            assert (sum(counts) == taker.size and np.all(taker > 0)
                    and cursor[0] == taker.size + 2)
            shared += set(np.unique(taker)) == {1, 2}
            if shared == 3:
                break
    finally:
        numba.set_num_threads(before)           # the worker's later tests keep their count
    assert shared, "in 20 runs one thread took every point: the blocks never ran at once"


def test_points_shared_by_the_threads_are_each_thread_alone(pend):
    """Points of mixed lifetimes taken by two threads from one cursor (the lanes refill
    and drain in whatever order the threads reach them) are bit for bit the run on one
    thread: a point's numbers do not depend on its lane, its thread or its neighbours."""
    if numba.config.NUMBA_NUM_THREADS < 2:
        pytest.skip("one thread: nothing is shared")
    rng = np.random.default_rng(5)
    N = 3 * bk.LANES + 11
    A = rng.uniform(0.003, 0.03, N)
    w = 2 * np.pi * rng.uniform(5, 100, N)
    T = 2 * np.pi / w
    span = rng.integers(1, 40, N) * T
    runs = []
    before = numba.get_num_threads()
    try:
        for threads in (2, 1):
            numba.set_num_threads(threads)
            runs.append(pend.simulate_grid([np.pi - 0.1], [0.0], (0.0, span),
                                           dict(PEND, A=A, omega=w), band=UP_BAND,
                                           strobe=T, rtol=1e-7, progress=False))
    finally:
        numba.set_num_threads(before)
    shared, alone = runs
    assert 10 < alone.counts()["left_band"] < N - 10
    for name in ("status", "n_steps", "n_rejected", "n_evaluations", "t_final", "q", "qdot",
                 "q_mean", "strobe_q", "strobe_qdot", "exit_time", "error_estimate"):
        np.testing.assert_array_equal(getattr(shared, name), getattr(alone, name),
                                      err_msg=name)


@pytest.mark.parametrize("method", ["rkn12", "rkn12-fixed"])
def test_step_budget_per_point_on_lanes(pend, method):
    w = 2 * np.pi * np.array([10.0, 60.0])
    lanes, point = both(pend, [np.pi - 0.1], [0.0], (0.0, 30 * 2 * np.pi / w),
                        dict(PEND, A=0.05, omega=w), method=method, rtol=1e-6, max_steps=25)
    assert list(lanes.status_name) == ["max_steps", "max_steps"]
    assert np.array_equal(lanes.n_steps, point.n_steps)
    assert_same_run(lanes, point, atol=1e-10 if method == "rkn12-fixed" else 1e-5,
                    steps=method == "rkn12-fixed")


def test_energy_drift_on_lanes():
    """The undriven pendulum's energy drift at a fixed step, on lanes and per point.  At
    h = 0.05 s (ω0 h = 0.16) RKN12's truncation is below rounding (halving h leaves the
    drift at 1.07e-14 J, doubling it gives 5.3e-14 J): 1e-12 J is ~300 ulps of the
    largest energy (19.6 J), ×94 over the measured."""
    pe = problems.pendulum()
    q0 = np.linspace(0.2, 3.0, 9)[:, None]
    lanes, point = both(pe, q0, [0.0], (0.0, 20.0), dict(PEND), method="rkn12-fixed",
                        h=0.05, energy=True)
    assert np.all(lanes.energy_drift < 1e-12)
    assert_same_run(lanes, point, atol=1e-11)


# -- failures stay in their lane ------------------------------------------------------------

def test_blow_up_and_zero_mass_do_not_poison_their_neighbours():
    """q̈ = k q³ / a: k = 4 blows up in finite time, a = 0 divides by zero.  Those points
    get "non_finite" (or "underflow"); every other point is bit for bit what it is in
    the same grid with the failing points replaced by harmless ones."""
    (q,), (qd,) = coordinates("q")
    a, k = sp.symbols("a k", real=True)
    s = System([q], lagrangian=a * qd**2 / 2 + k * q**4 / 4, name="quartic")
    kv = np.array([-1.0, 4.0, -2.0, -1.0, 4.0, -3.0, -0.5, -1.5] * 3)
    av = np.array([1.0, 1.0, 0.0, 2.0, 1.0, 1.0, 0.5, 1.0] * 3)
    bad = (kv > 0) | (av == 0)
    for method in ("rkn12", "rkn12-fixed"):
        g, _ = both(s, [1.0], [0.0], (0.0, 3.0), dict(a=av, k=kv), method=method, rtol=1e-8)
        names = g.status_name
        assert all(nm in ("non_finite", "underflow") for nm in names[bad]), names
        assert (names[~bad] == "finished").all(), names
        clean, _ = both(s, [1.0], [0.0], (0.0, 3.0),
                        dict(a=np.where(bad, 1.0, av), k=np.where(bad, -1.0, kv)),
                        method=method, rtol=1e-8)
        for name in ("q", "qdot", "q_mean", "n_steps", "n_evaluations", "t_final"):
            assert np.array_equal(getattr(g, name)[~bad], getattr(clean, name)[~bad]), name


def test_singular_mass_matrix_in_one_lane():
    """m = 0 at one point of a 2-coordinate grid: that point is "singular" (found by the
    scalar kernel's pivoting, to which the lane goes back), the others unaffected.  At a
    fixed step (8 a drive period): a pilot's step may differ on lanes and per point by a
    rejection that a rounding decides (test_piloted_fixed_step_on_lanes)."""
    s = coupled(2)
    m = np.array([1.0, 0.0, 2.0, 1.5])
    h = 1 / 40 / 8
    g, point = both(s, [np.pi - 0.05, np.pi + 0.03], [0.0, 0.0], (0.0, 0.5),
                    dict(m=m, l=1.0, g=9.81, k=2.0, A=0.05, omega=2 * np.pi * 40),
                    method="rkn12-fixed", h=h)
    assert list(g.status_name) == ["finished", "singular", "finished", "finished"]
    clean, _ = both(s, [np.pi - 0.05, np.pi + 0.03], [0.0, 0.0], (0.0, 0.5),
                    dict(m=np.where(m == 0, 1.0, m), l=1.0, g=9.81, k=2.0, A=0.05,
                         omega=2 * np.pi * 40), method="rkn12-fixed", h=h)
    ok = m != 0
    assert np.array_equal(g.q[ok], clean.q[ok])
    assert_same_run(g, point, atol=1e-10)


@njit(cache=True)
def _raw_accel_lanes(ka, q, t, cs, p, out, work):
    """The drive kernel's ``fast_accel_lanes`` alone, through its C entry point."""
    return call_fast_accel_lanes(ka[FAST_ACCEL_LANES], q, t, cs, p, out, work, t.shape[0])


@pytest.mark.parametrize("n", [1, 2])
def test_fast_accel_lanes_marks_and_counts_the_lanes_it_leaves(pend, n):
    """The contract of lagrange_core._kernel_calls: ``fast_accel_lanes`` returns how many
    lanes it could not answer (θ beyond the lane sine's range; for n = 2 a zero mass, which
    elimination without pivoting flags) and marks exactly those 1.0 in row 0; the drivers'
    lagrange_core._lane_calls computes them again (the grid tests above)."""
    s = pend if n == 1 else coupled(2)
    load_drive_kernel(s.kernels, lanes=True)
    ka = s.kernels.addresses()
    L = 8
    q = np.full((n, L), np.pi - 0.1)
    t = np.linspace(0.0, 0.1, L)
    cs = np.vstack([np.cos(40.0 * t), np.sin(40.0 * t)])
    p = np.ones((len(s.parameters), L))
    out, work = np.empty((n, L)), np.full((1 + n * (n + 1), L), 7.0)
    assert _raw_accel_lanes(ka, q, t, cs, p, out, work) == 0
    q[0, 2] = 3 * BIG_ARGUMENT
    left = [2]
    if n == 2:
        p[s.parameters.index("m"), 5] = 0.0
        left.append(5)
    work[:] = 7.0
    assert _raw_accel_lanes(ka, q, t, cs, p, out, work) == len(left)
    assert work[0].tolist() == [1.0 if lane in left else 0.0 for lane in range(L)]


# -- the method a grid gets by default, and the benchmark's question ----------------------

def test_default_method_is_rkn12_on_lanes(pend):
    args = ([np.pi - 0.1], [0.0], (0.0, 0.3), dict(PEND, A=np.array([0.03, 0.08]),
                                                   omega=2 * np.pi * 50))
    default = pend.simulate_grid(*args, progress=False)
    named = pend.simulate_grid(*args, method="rkn12", progress=False)
    assert default.method == "rkn12"
    assert np.array_equal(default.q, named.q) and np.array_equal(default.n_steps,
                                                                  named.n_steps)


def test_sweep_classifies_as_the_tight_reference(pend):
    """The benchmark's question on a 10 × 10 grid over 100 periods: "stayed up" by the
    default method at rtol 1e-3 and by rkn12-fixed at rtol 1e-3, on lanes, equals the
    classification of the per-point integrator at rtol 1e-12."""
    A = np.linspace(0.005, 0.2, 10)[:, None]
    w = 2 * np.pi * np.linspace(5.0, 100.0, 10)[None, :]
    args = ([np.pi - 0.1], [0.0], (0.0, 100 * 2 * np.pi / w), dict(PEND, A=A, omega=w))
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(batch, "_USE_LANES", False)
        ref = pend.simulate_grid(*args, band=UP_BAND, rtol=1e-12, progress=False)
    up = ref.status == 0
    assert 0.2 < up.mean() < 0.95
    for kw in (dict(rtol=1e-3), dict(method="rkn12-fixed", rtol=1e-3)):
        g = pend.simulate_grid(*args, band=UP_BAND, progress=False, **kw)
        assert np.array_equal(g.status == 0, up), kw
