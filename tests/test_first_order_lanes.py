"""First-order systems on *lanes* (issue 21.6): the generated lanes kernels, DOP853 on lanes,
and the chaos room's Lyapunov maps and bifurcation diagrams on them.

Each fast path against something independent:

* ``rhs_lanes`` / ``rhs_jvp_lanes`` (lagrange_core._rhs_lanes) against the scalar kernels
  of codegen (``rhs``, and ``jacobian`` times v: the exact Jacobian of another program),
  for one coordinate (q̈ simplified symbolically) and two (M solved on the lanes, J v by
  the same factors); arguments beyond the lane sine's range and singular mass matrices
  go to the scalar kernels (lagrange_core._lane_calls) and stay in their lane;
* DOP853 on lanes (lagrange_core._first_order_lanes) against ``System.simulate_grid``'s
  per-point DOP853 and scipy; a failing point leaves the others bit for bit unchanged; a
  run paused and resumed equals an unbroken one;
* ``lyapunov_grid`` on lanes against the per-point kernel (kapitza.chaos._kernels):
  regular points to 1e-7, chaotic ones within the stated errors; failures stay in
  their lane; paused and resumed runs equal unbroken ones;
* long runs of both through the public calls stop part-way on Ctrl-C (the first progress
  report comes before any run has ended) keeping what they should;
* the argument check of the kernel calls (lagrange_core._kernel_calls).
"""
import math

import numpy as np
import pytest
import sympy as sp
from numba import njit, types
from scipy.integrate import solve_ivp

from kapitza.chaos import _lyapunov, _sections, bifurcation_diagram, lyapunov_grid
from lagrange_core import Particle, System, coordinates, problems, t
from lagrange_core import _batch_kernels as bk
from lagrange_core import _first_order_lanes as fl
from lagrange_core._kernel_calls import (
    RHS_JVP_LANES,
    RHS_LANES,
    SIGNATURES,
    call_rhs_jvp_lanes,
    call_rhs_lanes,
    check_arguments,
)
from lagrange_core._lane_math import BIG_ARGUMENT
from lagrange_core._rhs_lanes import evaluate_lanes, lanes_work_rows, load_rhs_lanes
from lagrange_core._thread_blocks import thread_count

W0 = math.sqrt(9.81)


@pytest.fixture(scope="module")
def pendulum():
    return problems.driven_pendulum("vertical", damping=True)


@pytest.fixture(scope="module")
def double():
    """A damped double pendulum on a vertically driven pivot: a non-diagonal mass matrix,
    forces that depend on the velocities."""
    (th1, th2), (w1, w2) = coordinates(["theta1", "theta2"])
    A, om, g, gam, m1, m2, l1, l2 = sp.symbols("A omega g gamma m1 m2 l1 l2", positive=True)
    pivot = A * sp.cos(om * t)
    x1, y1 = l1 * sp.sin(th1), pivot - l1 * sp.cos(th1)
    x2, y2 = x1 + l2 * sp.sin(th2), y1 - l2 * sp.cos(th2)
    return System([th1, th2], particles=[Particle(m1, (x1, y1), "1"), Particle(m2, (x2, y2), "2")],
                  potential=g * (m1 * y1 + m2 * y2), dissipation=gam * (w1**2 + (w2 - w1)**2) / 2,
                  name="damped driven double pendulum")


def _pend(A, omega, gamma=0.1 * W0):
    return dict(A=A, g=9.81, l=1.0, m=1.0, omega=omega, gamma=gamma)


def _scalar(kernels, tt, y, p, v):
    """dy/dt and J v lane by lane from the scalar kernels."""
    d, L = y.shape
    f, jv = np.empty((d, L)), np.empty((d, L))
    W, J, out = kernels.work_array(), np.zeros((d, d)), np.zeros(d)
    for lane in range(L):
        kernels.rhs(tt[lane], y[:, lane].copy(), p[:, lane].copy(), out, W)
        f[:, lane] = out
        kernels.jacobian(tt[lane], y[:, lane].copy(), p[:, lane].copy(), J)
        jv[:, lane] = J @ v[:, lane]
    return f, jv


# -- the kernels -----------------------------------------------------------------------------

@pytest.mark.parametrize("which", ["pendulum", "double"])
def test_lanes_kernels_equal_the_scalar_rhs_and_jacobian(which, request):
    """67 lanes (not a multiple of the vector width): f and J v to rounding, 4e-15 of the
    largest term; a lane beyond the lane sine's range is left to the scalar kernels
    (lagrange_core._lane_calls: libm), whose f it gets exactly and whose J v to the
    order of a sum's terms."""
    s = request.getfixturevalue(which)
    n, L = s.n_dof, 67
    rng = np.random.default_rng(3)
    tt = rng.uniform(0, 50, L)
    y = rng.uniform(-3, 3, (2 * n, L))
    y[0, 5] = 3 * BIG_ARGUMENT                   # libm's sin, by the scalar kernels
    v = rng.standard_normal((2 * n, L))
    p = rng.uniform(0.5, 2.0, (len(s.parameters), L))
    f, jv, status = evaluate_lanes(s.kernels, tt, y, p, v)
    f_only, none, _ = evaluate_lanes(s.kernels, tt, y, p)
    s.kernels.warm(jacobian=True)
    f_ref, jv_ref = _scalar(s.kernels, tt, y, p, v)
    assert not status.any() and none is None
    scale = np.abs(f_ref).max(axis=0) + 1.0
    assert np.all(np.max(np.abs(f - f_ref), axis=0) / scale < 4e-15)
    assert np.all(np.max(np.abs(f_only - f_ref), axis=0) / scale < 4e-15)   # its own CSE
    jscale = np.abs(jv_ref).max(axis=0) + 1.0
    assert np.all(np.max(np.abs(jv - jv_ref), axis=0) / jscale < 4e-15)
    np.testing.assert_array_equal(f[:, 5], f_ref[:, 5])         # the scalar rhs's own
    np.testing.assert_array_equal(f_only[:, 5], f_ref[:, 5])


def _random_lanes(s, L, seed):
    """Times, states, directions and parameters (mass-like, 0.5-2) for L lanes of ``s``."""
    rng = np.random.default_rng(seed)
    n = s.n_dof
    return (rng.uniform(0, 5, L), rng.uniform(-1, 1, (2 * n, L)),
            rng.standard_normal((2 * n, L)), rng.uniform(0.5, 2.0, (len(s.parameters), L)))


@njit(cache=True)
def _raw_lanes(ka, jvp, t, y, v, p, dydt, jv, work):
    """The generated lanes kernel alone, through its C entry point (no scalar fallback)."""
    if jvp:
        return call_rhs_jvp_lanes(ka[RHS_JVP_LANES], t, y, v, p, dydt, jv, work, t.shape[0])
    return call_rhs_lanes(ka[RHS_LANES], t, y, p, dydt, work, t.shape[0])


@pytest.mark.parametrize("which", ["pendulum", "double"])
def test_a_lanes_kernel_marks_and_counts_the_lanes_it_leaves(which, request):
    """The contract of lagrange_core._kernel_calls: the generated kernel returns how many
    lanes it could not answer (an argument beyond the lane sine's range, a zero mass) and
    marks exactly those 1.0 in row 0, the others 0.0; on a clean call it returns 0."""
    s = request.getfixturevalue(which)
    n, L = s.n_dof, 9
    tt, y, v, p = _random_lanes(s, L, seed=5)
    load_rhs_lanes(s.kernels, jvp=True)
    ka = s.kernels.addresses()
    rows = lanes_work_rows(n)
    for jvp in (False, True):
        work = np.full((rows, L), 7.0)
        out = (np.empty((2 * n, L)), np.empty((2 * n, L)))
        assert _raw_lanes(ka, jvp, tt, y, v, p, *out, work) == 0
        bad_p = p.copy()
        bad_p[[i for i, name in enumerate(s.parameters) if name.startswith("m")], 6] = 0.0
        bad_y = y.copy()
        bad_y[0, 2] = 3 * BIG_ARGUMENT
        work = np.full((rows, L), 7.0)
        assert _raw_lanes(ka, jvp, tt, bad_y, v, bad_p, *out, work) == 2
        assert work[0].tolist() == [0, 0, 1, 0, 0, 0, 1, 0, 0]


@pytest.mark.parametrize("which", ["pendulum", "double"])
def test_a_singular_lane_is_flagged_alone(which, request):
    """A lane with zero masses (M = 0) gets status 1 and NaN; its neighbours are bit for
    bit what they are without it."""
    s = request.getfixturevalue(which)
    L = 9
    tt, y, v, p = _random_lanes(s, L, seed=4)
    clean = evaluate_lanes(s.kernels, tt, y, p, v)
    masses = [i for i, name in enumerate(s.parameters) if name.startswith("m")]
    p[masses, 4] = 0.0
    f, jv, status = evaluate_lanes(s.kernels, tt, y, p, v)
    assert status.tolist() == [0, 0, 0, 0, 1, 0, 0, 0, 0]
    assert np.all(np.isnan(f[:, 4])) and np.all(np.isnan(jv[:, 4]))
    keep = np.arange(L) != 4
    np.testing.assert_array_equal(f[:, keep], clean[0][:, keep])
    np.testing.assert_array_equal(jv[:, keep], clean[1][:, keep])


def test_systems_without_lanes_say_why():
    rolling = problems.rolling_disc(constrained=True)
    ok, why = load_rhs_lanes(rolling.kernels)
    assert not ok and "constraints" in why
    with pytest.raises(ValueError, match="no lanes kernels: it has constraints"):
        evaluate_lanes(rolling.kernels, [0.0], np.zeros((2 * rolling.n_dof, 1)),
                       np.ones((len(rolling.parameters), 1)))


# -- DOP853 on lanes ---------------------------------------------------------------------------

def _diagram(system, lanes, **kw):
    real = _sections.lanes_apply
    if not lanes:
        _sections.lanes_apply = lambda s, m: False
    try:
        return bifurcation_diagram(system, _pend(0.0, 2 * W0), parameter="A", angles="theta",
                                   progress=False, **kw)
    finally:
        _sections.lanes_apply = real


def test_strobe_samples_on_lanes_equal_the_per_point_dop853_and_scipy(pendulum):
    """Regular motion (small drives: oscillations settling and rotations) at rtol 1e-9:
    the lanes' strobe samples equal simulate_grid's per-point DOP853 to 1e-10 (measured
    3e-12: the same steps, rounding apart), and both equal scipy's DOP853 at rtol 1e-13
    to 5e-7 (the method's global error over 30 periods of a rotation: 2.7e-7)."""
    A = np.array([0.05, 0.1, 0.2])
    q0 = np.linspace(-2.0, 2.0, 7)
    kw = dict(values=A, q0=q0, periods=20, transient=10, rtol=1e-9)
    lanes = _diagram(pendulum, True, **kw)
    point = _diagram(pendulum, False, **kw)
    assert lanes.method == point.method == "dop853"
    assert set(lanes.status.ravel()) == {"finished"}
    np.testing.assert_allclose(lanes.q, point.q, rtol=0, atol=1e-10)
    np.testing.assert_allclose(lanes.qdot, point.qdot, rtol=0, atol=1e-10)
    w, g = 2 * W0, 0.1 * W0
    T = 2 * math.pi / w
    for i, j in ((0, 0), (1, 3), (2, 6)):
        def f(tt, y, a=A[i]):
            return [y[1], -g * y[1] - (9.81 - a * w * w * math.cos(w * tt)) * math.sin(y[0])]
        ref = solve_ivp(f, (0, 29 * T), [q0[j], 0.0], method="DOP853", rtol=1e-13, atol=1e-13,
                        t_eval=(10 + np.arange(20)) * T).y
        np.testing.assert_allclose(lanes.q[i, j, :, 0], ref[0], rtol=0, atol=5e-7)
        np.testing.assert_allclose(lanes.qdot[i, j, :, 0], ref[1], rtol=0, atol=5e-7)


def test_a_failing_point_leaves_its_neighbours_unchanged(pendulum):
    """A start whose velocity overflows (non_finite) and one in a zero mass (singular):
    the other points' samples are bit for bit those of a run without them, and their
    lanes are refilled."""
    q0 = np.array([0.3, 0.4, 0.5, 0.6, 0.7])
    qdot0 = np.array([0.0, 1e300, 0.0, 0.0, 0.0])
    kw = dict(values=np.array([0.1, 0.5, 0.9]), periods=6, transient=4)
    with pytest.warns(RuntimeWarning, match="3 of 15 runs failed"):
        bad = _diagram(pendulum, True, q0=q0, qdot0=qdot0, **kw)
    assert set(bad.status[:, 1]) == {"non_finite"}
    assert set(bad.status[:, [0, 2, 3, 4]].ravel()) == {"finished"}
    clean = _diagram(pendulum, True, q0=q0[[0, 2, 3, 4]], **kw)
    np.testing.assert_array_equal(bad.q[:, [0, 2, 3, 4]], clean.q)
    np.testing.assert_array_equal(bad.qdot[:, [0, 2, 3, 4]], clean.qdot)
    with pytest.warns(RuntimeWarning, match="1 of 3 runs failed"):
        zero_mass = bifurcation_diagram(pendulum, _pend(0.5, 2 * W0), parameter="m",
                                        values=[1.0, 0.0, 1.0], q0=0.3, periods=3, transient=2,
                                        progress=False)
    assert zero_mass.status[:, 0].tolist() == ["finished", "singular", "finished"]
    np.testing.assert_array_equal(zero_mass.q[0], zero_mass.q[2])


def _grid_arrays(system, N, periods):
    """Flat inputs of grid_dop853 for N points of the damped pendulum over a strobe run."""
    rng = np.random.default_rng(5)
    P = np.empty((N, len(system.parameters)))
    values = dict(A=rng.uniform(0.1, 1.0, N), g=9.81, gamma=0.1 * W0, l=1.0, m=1.0,
                  omega=2 * W0)
    for k, name in enumerate(system.parameters):
        P[:, k] = values[name]
    T = np.full(N, 2 * math.pi / (2 * W0))
    Y0 = np.zeros((N, 2))
    Y0[:, 0] = rng.uniform(-2, 2, N)
    TS = np.column_stack([np.zeros(N), (periods - 1) * T])
    return Y0, np.ascontiguousarray(P), TS, T


def _outputs(N, K):
    return dict(YF=np.full((N, 2), np.nan), TF=np.full(N, np.nan), SQ=np.full((N, K, 2), np.nan),
                QM=np.zeros((N, 1)), DEV=np.zeros((N, 1)), EXIT=np.full(N, np.nan),
                EXITC=np.full(N, -1), EDRIFT=np.full(N, np.nan),
                COUNTS=np.zeros((N, 3), dtype=np.int64), ERR=np.zeros(N),
                STATUS=np.full(N, bk.GRID_NOT_RUN, dtype=np.int64))


def test_paused_and_resumed_runs_equal_an_unbroken_one(pendulum):
    """The pausing protocol of simulate_grid's drivers (a step budget per call, the state
    saved in point_dop853's layout): calls of 40 steps give bit for bit the run of one; so
    does a first call whose stop flag (Ctrl-C) is set, in which every started point
    pauses after one step (a point not yet started would stay unstarted)."""
    from lagrange_core.integrate import METHODS
    load_rhs_lanes(pendulum.kernels)
    ka = pendulum.kernels.addresses("rhs")
    tab = METHODS["dop853"].table
    tables = (tab["A"], tab["B"], tab["C"], tab["E3"], tab["E5"])
    N, K = 70, 12
    Y0, P, TS, T = _grid_arrays(pendulum, N, K)
    REF = np.zeros((N, 1))

    def run(budget, stopped_first=False):
        out = _outputs(N, K)
        save = np.zeros((N, 12))
        savei = np.zeros((N, 1), dtype=np.int64)
        idx = np.arange(N, dtype=np.int64)
        stop = np.array([1 if stopped_first else 0])
        calls = 0
        while idx.size:
            fl.grid_dop853_lanes(ka, 0, True, idx, Y0, P, TS, np.zeros(N), T, REF, REF, REF,
                                 bk.OBS_STROBE | bk.OBS_REF, 1e-8, 1e-8, 1 << 40, *tables,
                                 *out.values(), budget, stop, idx, save, savei)
            if stop[0]:
                first = (out["STATUS"].copy(), out["COUNTS"][:, 0].copy())
                stop[0] = 0
            idx = idx[np.isin(out["STATUS"][idx], (7, bk.GRID_NOT_RUN))]
            calls += 1
        return out, calls, (first if stopped_first else None)

    whole, one, _ = run(1 << 40)
    paused, many, _ = run(40)
    assert one == 1 and many > 3
    for name, value in whole.items():
        np.testing.assert_array_equal(paused[name], value, err_msg=name)
    assert set(whole["STATUS"]) == {bk.GRID_FINISHED}
    stopped, _, (status, steps) = run(1 << 40, stopped_first=True)
    started = status == 7
    assert started.any() and set(status[~started]) <= {bk.GRID_NOT_RUN}
    assert set(steps[started]) == {1}
    for name, value in whole.items():
        np.testing.assert_array_equal(stopped[name], value, err_msg=name)


# -- simulate_grid on DOP853's lanes ----------------------------------------------------------

def _spied(monkeypatch):
    """The drivers simulate_grid calls, counted: {"lanes": calls, "per point": calls}."""
    from lagrange_core import batch
    calls = {"lanes": 0, "per point": 0}

    def count(key, real):
        def wrapper(*args):
            calls[key] += 1
            return real(*args)
        return wrapper
    monkeypatch.setattr(fl, "grid_dop853_lanes", count("lanes", fl.grid_dop853_lanes))
    monkeypatch.setattr(bk, "grid_dop853", count("per point", bk.grid_dop853))
    assert batch._fl is fl and batch._bk is bk
    return calls


def _escape_starts(n_points):
    """(θ0, θ̇0, A) of :func:`_escapes`."""
    rng = np.random.default_rng(11)
    q0 = rng.uniform(-0.5, 0.5, n_points)
    qdot0 = np.where(np.arange(n_points) < 30, 0.0, rng.uniform(5.0, 8.0, n_points))
    qdot0 *= np.where(rng.random(n_points) < 0.5, -1.0, 1.0)
    return q0, qdot0, rng.uniform(0.0, 0.1, n_points)


def _escapes(pendulum, n_points, lanes, monkeypatch):
    """The damped driven pendulum (ω = 2ω0, A ≤ 0.1 m) from the bottom with speeds of 5–8
    rad/s (over the top within the first swing, away from the separatrix: well-conditioned
    exits) and 30 starts from rest (never leaving), in the band |θ| ≤ 1.5 rad, 20 drive
    periods at rtol 1e-9."""
    from lagrange_core import batch
    monkeypatch.setattr(batch, "_USE_FIRST_ORDER_LANES", lanes)
    q0, qdot0, A = _escape_starts(n_points)
    T = 2 * math.pi / (2 * W0)
    return pendulum.simulate_grid(q0[:, None], qdot0[:, None], (0.0, 20 * T),
                                  _pend(A, 2 * W0), rtol=1e-9, reference=[0.0],
                                  band=([-1.5], [1.5]), progress=False)


def test_simulate_grid_runs_dop853_on_lanes_from_its_threshold(pendulum, monkeypatch):
    """Adaptive DOP853 grids of FIRST_ORDER_LANES_MIN_POINTS points or more go to the lanes
    driver, smaller ones per point; so do grids asking for the energy drift of a
    conservative first-order system (the lanes do not compute it), whose lanes run
    otherwise."""
    from lagrange_core import batch
    calls = _spied(monkeypatch)

    def driver(run):
        calls.update({"lanes": 0, "per point": 0})
        out = run()
        assert min(calls.values()) == 0, calls      # one driver, one or more calls of it
        return max(calls, key=calls.get), out
    least = batch.FIRST_ORDER_LANES_MIN_POINTS
    assert driver(lambda: _escapes(pendulum, least, True, monkeypatch))[0] == "lanes"
    assert driver(lambda: _escapes(pendulum, least - 1, True, monkeypatch))[0] == "per point"
    double = problems.double_pendulum()     # q̈ depends on q̇: DOP853; energy conserved
    assert double.kernels.energy_conserved and not double.kernels.rkn_form
    q0 = np.linspace(0.1, 1.0, least)[:, None] * np.ones(2)
    run = dict(qdot0=[0.0, 0.0], t_span=(0.0, 1.0), progress=False,
               params=dict(g=9.81, l1=1.0, l2=0.5, m1=1.0, m2=2.0))
    used, with_energy = driver(lambda: double.simulate_grid(q0, energy=True, **run))
    assert used == "per point"
    used, plain = driver(lambda: double.simulate_grid(q0, **run))
    assert used == "lanes"
    assert np.all(with_energy.energy_drift < 1e-7)
    np.testing.assert_allclose(plain.q, with_energy.q, rtol=0, atol=1e-7)


def test_band_exits_on_lanes_equal_the_per_point_dop853_and_scipy(pendulum, monkeypatch):
    """Points leaving their band on the lanes: the same statuses, exit coordinates and
    steps as the per-point DOP853; exit times and the state there to 1e-9 (measured 3e-11
    and 7e-10), the time mean to 1e-8 (2.5e-9), the deviation — a maximum over the steps'
    ends — to 1e-6 (9e-8: the steps end a little apart, as the error estimate, a
    difference of nearly equal sums, carries the lanes' rounding — fused multiply-adds,
    sin and cos within 2 ulp — to ~1e-7 of a step).  Exit times equal scipy's DOP853 with a
    terminal event at rtol 1e-13 to 5e-5 s: both paths locate the exit on the step's cubic
    Hermite interpolant, error O(h⁴) (lagrange_core._batch_kernels; measured 2.2e-5 s at
    worst over every seventh point, steps of ~0.06 s)."""
    n = 300
    lanes = _escapes(pendulum, n, True, monkeypatch)
    point = _escapes(pendulum, n, False, monkeypatch)
    left = lanes.status == bk.GRID_LEFT_BAND
    assert left.sum() == n - 30 and not left[:30].any()
    np.testing.assert_array_equal(lanes.status, point.status)
    np.testing.assert_array_equal(lanes.exit_coordinate, point.exit_coordinate)
    np.testing.assert_array_equal(lanes.n_steps, point.n_steps)
    for name, rtol in (("exit_time", 1e-9), ("t_final", 1e-9), ("q", 1e-9), ("qdot", 1e-9),
                       ("q_mean", 1e-8), ("max_deviation", 1e-6)):
        a, b = getattr(lanes, name), getattr(point, name)
        np.testing.assert_array_equal(np.isnan(a), np.isnan(b), err_msg=name)
        np.testing.assert_allclose(a, b, rtol=rtol, atol=1e-12, err_msg=name)
    assert np.all(np.abs(np.abs(lanes.q[left, 0]) - 1.5) < 1e-12)
    q0, qdot0, A = _escape_starts(n)
    w, g = 2 * W0, 0.1 * W0
    for i in range(30, n, 30):
        def f(tt, y, a=A[i]):
            return [y[1], -g * y[1] - (9.81 - a * w * w * math.cos(w * tt)) * math.sin(y[0])]

        def leaves(tt, y):
            return abs(y[0]) - 1.5
        leaves.terminal = True
        ref = solve_ivp(f, (0.0, 20 * 2 * math.pi / w), [q0[i], qdot0[i]], method="DOP853",
                        rtol=1e-13, atol=1e-13, events=leaves)
        assert abs(lanes.exit_time[i] - ref.t_events[0][0]) < 5e-5, i


class _BandedLanes:
    """The damped pendulum's grid of :func:`_grid_arrays` with a band |θ| ≤ 2.5 rad (every
    other point started at −``speed`` … ``speed`` rad/s: most of those leave over the top),
    run on DOP853's lanes by calls of ``call(idx, budget)`` into fresh outputs."""

    def __init__(self, pendulum, N, K, speed):
        from lagrange_core.integrate import METHODS
        load_rhs_lanes(pendulum.kernels)
        self.ka = pendulum.kernels.addresses("rhs")
        tab = METHODS["dop853"].table
        self.tables = (tab["A"], tab["B"], tab["C"], tab["E3"], tab["E5"])
        self.N, self.K = N, K
        self.Y0, self.P, self.TS, self.T = _grid_arrays(pendulum, N, K)
        self.Y0[::2, 1] = np.linspace(-speed, speed, N // 2)
        self.REF = np.zeros((N, 1))
        self.LO, self.HI = np.full((N, 1), -2.5), np.full((N, 1), 2.5)

    def outputs(self):
        self.save = np.zeros((self.N, 12))
        self.savei = np.zeros((self.N, 1), dtype=np.int64)
        self.out = _outputs(self.N, self.K)
        return self.out

    def call(self, idx, budget):
        idx = np.asarray(idx, dtype=np.int64)
        fl.grid_dop853_lanes(self.ka, 0, True, idx, self.Y0, self.P, self.TS, np.zeros(self.N),
                             self.T, self.REF, self.LO, self.HI,
                             bk.OBS_STROBE | bk.OBS_REF | bk.OBS_BAND, 1e-8, 1e-8, 1 << 40,
                             *self.tables, *self.out.values(), budget,
                             np.zeros(1, dtype=np.int64), idx, self.save, self.savei)


def test_band_exits_paused_and_resumed_equal_an_unbroken_run(pendulum):
    """Calls of 7 steps (most exits come in a resumed call) give bit for bit the run of
    one call: statuses, exit times and coordinates, states, means, deviations, counts."""
    grid = _BandedLanes(pendulum, 90, 12, 6.0)

    def run(budget):
        out = grid.outputs()
        idx = np.arange(grid.N, dtype=np.int64)
        calls = 0
        while idx.size:
            grid.call(idx, budget)
            idx = idx[out["STATUS"][idx] == 7]
            calls += 1
        return out, calls

    whole, one = run(1 << 40)
    paused, many = run(7)
    assert one == 1 and many > 10
    left = whole["STATUS"] == bk.GRID_LEFT_BAND
    assert 10 < left.sum() < grid.N and np.all(whole["EXITC"][left] == 0)
    assert np.all(np.isnan(whole["EXIT"][~left]))
    for name, value in whole.items():
        np.testing.assert_array_equal(paused[name], value, err_msg=name)


def test_drained_lanes_run_on_as_each_point_alone(pendulum, monkeypatch):
    """A thread whose lanes have taken every point drains once at most 3/4 of its lanes
    still run: they pause and run on at once on fewer lanes.  200 points of mixed
    lifetimes (175 leave their band at scattered times, the others run 30 periods), taken
    by the threads from one shared cursor, give bit for bit what each point gives alone
    on one lane, where nothing drains; so do their statuses, exits, samples and counts.
    Checked to drain, through a wrapper of ``_block``: it runs again on fewer lanes than
    a thread's first run had (62, 37, 24 … of 100 on two threads, 2026-11-28)."""
    grid = _BandedLanes(pendulum, 200, 31, 7.0)
    block, widths = fl._block, []

    def counted(*args):                 # (ka, idx, cursor, end, width, ...)
        widths.append(args[4])
        return block(*args)

    monkeypatch.setattr(fl, "_block", counted)
    together = grid.outputs()
    grid.call(np.arange(grid.N), 1 << 40)
    monkeypatch.setattr(fl, "_block", block)
    first = max(widths)
    assert first == -(-grid.N // thread_count()) or first == fl.LANES
    assert [w for w in widths if 0 < w < first], widths       # it drained
    alone = grid.outputs()
    for i in range(grid.N):
        grid.call([i], 1 << 40)
    left = together["STATUS"] == bk.GRID_LEFT_BAND
    assert 10 < left.sum() < grid.N - 10
    assert set(together["STATUS"][~left]) == {bk.GRID_FINISHED}
    for name, value in together.items():
        np.testing.assert_array_equal(alone[name], value, err_msg=name)


def test_a_long_damped_measure_grid_on_lanes_stops_part_way(pendulum, monkeypatch):
    """Ctrl-C at the first progress report of a long damped grid on the lanes (256 points
    that stay up, 20 000 periods): the measurement stops there; the first call's points
    (paused by its step budget) are "interrupted" part-way, with the time and the periods
    they reached, the others "not_run" (NaN): nothing half-written."""
    from kapitza import KapitzaPendulum
    calls = _spied(monkeypatch)
    A, omega = np.meshgrid(np.linspace(0.06, 0.1, 16), 200.0 * np.linspace(1.0, 2.0, 16),
                           indexing="ij")
    damped = KapitzaPendulum(l=1.0, g=9.81, damping=0.5)
    done, stop = _first_progress_stops(lambda progress: damped.measure_grid(
        A, omega, math.pi - 0.1, periods=20_000, observables="classification",
        progress=progress))
    assert calls["lanes"] > 0 and calls["per point"] == 0
    assert 0 < done < A.size
    part = stop.result
    status = np.asarray(part.status)
    reached = np.asarray(part.t_reached)
    stopped = status == "interrupted"
    assert set(np.unique(status)) == {"interrupted", "not_run"} and stopped.any()
    end = (20_000 * 2 * np.pi / omega)[stopped]
    assert np.all((reached[stopped] > 0) & (reached[stopped] < end))
    assert np.all(np.asarray(part.completed_periods)[stopped] > 0)
    assert np.all(np.isnan(reached[~stopped]))


# -- Lyapunov maps on lanes ------------------------------------------------------------------

def _lyap_grid(system, params, lanes, q0=0.0, **kw):
    real = _lyapunov._lanes
    if not lanes:
        _lyapunov._lanes = lambda s, jvp=False: False
    try:
        return lyapunov_grid(system, params, q0, progress=False, **kw)
    finally:
        _lyapunov._lanes = real


@pytest.mark.parametrize("tangent", ["jacobian", "difference"])
def test_lyapunov_grid_on_lanes_equals_the_per_point_kernel(pendulum, tangent):
    """Hanging states in the first tongue (saddles and damped nodes: regular) — λ_max to
    1e-7 of the per-point kernel's, the same steps to 1 %; by default the exact J v."""
    A = np.array([0.1, 0.15, 0.3])
    gamma = np.array([0.2, 0.8, 1.2])
    P = _pend(A[:, None], 2 * W0, gamma[None, :])
    lanes = _lyap_grid(pendulum, P, True, periods=160, transient=40, tangent=tangent)
    point = _lyap_grid(pendulum, P, False, periods=160, transient=40, tangent=tangent)
    np.testing.assert_allclose(lanes.exponent, point.exponent, rtol=0, atol=1e-7)
    np.testing.assert_allclose(lanes.steps, point.steps, rtol=0.01)
    assert lanes.tangent == point.tangent == tangent
    default = _lyap_grid(pendulum, P, True, periods=160, transient=40)
    assert default.tangent == "jacobian"
    assert _lyap_grid(pendulum, P, False, periods=8, transient=0).tangent == "difference"


def test_chaotic_points_on_lanes_agree_within_their_errors():
    """Baker & Gollub's chaotic pendulum (Q = 2, F = 1.5, ω = 2/3) and its period-1 neighbour:
    the lanes' λ_max and the per-point kernel's within the sum of their stated errors."""
    (th,), (thd,) = coordinates("theta")
    Q, F, w = sp.symbols("Q F omega", positive=True)
    ddp = System([th], lagrangian=thd**2 / 2 + sp.cos(th), dissipation=thd**2 / (2 * Q),
                 forces={th: F * sp.cos(w * t)}, name="damped driven pendulum")
    P = dict(Q=2.0, F=np.array([1.35, 1.5]), omega=2 / 3)
    kw = dict(periods=400, transient=100, rtol=1e-8, q0=0.2)
    lanes = _lyap_grid(ddp, P, True, **kw)
    point = _lyap_grid(ddp, P, False, **kw)
    assert lanes.chaotic.tolist() == point.chaotic.tolist() == [False, True]
    assert np.all(np.abs(lanes.exponent - point.exponent) <= lanes.error + point.error)


def test_failing_lyapunov_points_stay_in_their_lane(pendulum):
    """A zero length (singular at the start) and an overflowing start (non-finite): the
    other points' exponents and steps are bit for bit those of a run without them."""
    l = np.array([1.0, 0.0, 1.0, 1.0, 1.0])
    qdot0 = np.array([0.0, 0.0, 0.0, 1e300, 0.0])
    P = dict(_pend(0.3, 2 * W0), l=l)
    with pytest.warns(RuntimeWarning, match="2 of 5 runs failed"):
        g = lyapunov_grid(pendulum, P, 0.3, qdot0, periods=40, transient=0, blocks=2,
                          progress=False)
    assert g.status.tolist() == ["finished", "singular", "finished", "non_finite", "finished"]
    clean = lyapunov_grid(pendulum, dict(P, l=l[[0, 2, 4]]), 0.3, periods=40, transient=0,
                          blocks=2, progress=False)
    np.testing.assert_array_equal(g.exponent[[0, 2, 4]], clean.exponent)
    np.testing.assert_array_equal(g.steps[[0, 2, 4]], clean.steps)


def test_paused_and_resumed_lyapunov_lanes_equal_an_unbroken_run(pendulum):
    """The pausing protocol on the Lyapunov lanes (so lyapunov_grid can stop on Ctrl-C in a
    long run): calls of 25 accepted steps give bit for bit the exponents' logs, states,
    times, counts and statuses of one call, and a point failing mid-way keeps its status;
    so does a first call with the stop flag (Ctrl-C) set, which pauses every started point
    after one step."""
    from kapitza.chaos import _lanes as lk
    from kapitza.chaos._common import record_stops
    from lagrange_core.integrate import METHODS
    load_rhs_lanes(pendulum.kernels, jvp=True)
    ka = pendulum.kernels.addresses("rhs")
    tab = METHODS["dop853"].table
    tables = (tab["A"], tab["B"], tab["C"], tab["E3"], tab["E5"])
    N = 70
    Y0, P, _, T = _grid_arrays(pendulum, N, 1)
    T0 = np.zeros(N)
    stops = record_stops(3, 12, 3)
    v0 = np.array([0.6, 0.8])

    def run(budget, max_steps=1 << 40, stopped_first=False):
        LOGS, YF, TF = np.zeros((N, stops.size)), np.full((N, 2), np.nan), np.full(N, np.nan)
        COUNTS = np.zeros((N, 3), dtype=np.int64)
        STATUS = np.full(N, 6, dtype=np.int64)
        save = np.zeros((N, lk.save_width(1)))
        savei = np.zeros((N, 1), dtype=np.int64)
        idx = np.arange(N, dtype=np.int64)
        stop = np.array([1 if stopped_first else 0])
        calls = 0
        while idx.size:
            lk.grid_largest_lanes(ka, lk.JVP, idx, Y0, P, T, T0, stops, v0, 1e-8, 1e-8, max_steps,
                                  *tables, LOGS, YF, TF, COUNTS, STATUS, budget, stop, idx,
                                  save, savei)
            if stop[0]:                 # Ctrl-C in the first call: started points paused
                assert set(STATUS[STATUS != 6]) == {lk.INTERRUPTED}
                assert np.any(STATUS == lk.INTERRUPTED)
                assert set(COUNTS[STATUS == lk.INTERRUPTED, 0]) == {1}
                stop[0] = 0
            idx = idx[np.isin(STATUS[idx], (lk.INTERRUPTED, 6))]
            calls += 1
        return dict(LOGS=LOGS, YF=YF, TF=TF, COUNTS=COUNTS, STATUS=STATUS), calls

    free, _ = run(1 << 40)
    # max_steps (kept across the pauses) at the median count: half the points run out
    limit = int(np.median(free["COUNTS"][:, 0]))
    whole, one = run(1 << 40, limit)
    paused, many = run(25, limit)
    assert one == 1 and many > 4
    for name, value in whole.items():
        np.testing.assert_array_equal(paused[name], value, err_msg=name)
    stopped, _ = run(1 << 40, limit, stopped_first=True)
    for name, value in whole.items():
        np.testing.assert_array_equal(stopped[name], value, err_msg=name)
    assert set(whole["STATUS"]) == {0, 5}
    finished = whole["STATUS"] == 0
    np.testing.assert_array_equal(whole["LOGS"][finished], free["LOGS"][finished])


def _first_progress_stops(call):
    """Run ``call(progress)`` stopped (Ctrl-C) at its first progress report; returns the
    points done at that report and the ComputationInterrupted raised."""
    from kapitza.results import ComputationInterrupted
    seen = []

    def progress(done, total):
        seen.append(done)
        raise KeyboardInterrupt

    with pytest.raises(ComputationInterrupted) as info:
        call(progress)
    return seen[0], info.value


def test_a_long_lyapunov_map_on_lanes_stops_part_way(pendulum):
    """Four points of 3000 periods (~22 000 steps each): the lanes pause them after the
    first call's step budget (lagrange_core.batch._FIRST_BUDGET, 8192 steps), so the first
    progress report (where Ctrl-C is seen) comes part-way through their runs — each at
    most budget / 20 000 of its way (before the budget: after the whole runs, done = 4);
    the paused points are returned as never run (NaN, status "not_run"), nothing
    half-written."""
    from lagrange_core import batch
    P = _pend(np.array([0.2, 0.4, 0.6, 0.8]), 2 * W0)
    done, stop = _first_progress_stops(lambda progress: lyapunov_grid(
        pendulum, P, 0.3, periods=3000, transient=0, progress=progress))
    assert 0 < done < 4 * batch._FIRST_BUDGET / 20_000 < 2
    part = stop.result
    assert part.tangent == "jacobian"             # the lanes ran
    assert not stop.computed.any() and set(part.status) == {"not_run"}
    assert np.all(np.isnan(part.exponent)) and np.all(np.isnan(part.q))


def test_a_long_damped_diagram_on_lanes_stops_part_way(pendulum):
    """The strobe runs on lanes pause as simulate_grid's do: stopped at the first progress
    report part-way through 3000 periods of four starts, the samples taken so far are
    kept (the first finite, the last NaN), each run's status "interrupted"."""
    done, stop = _first_progress_stops(lambda progress: bifurcation_diagram(
        pendulum, _pend(0.0, 2 * W0), parameter="A", values=[0.5], q0=[0.1, 0.2, 0.3, 0.4],
        periods=3000, transient=0, angles="theta", progress=progress))
    assert 0 < done < 1
    part = stop.result
    assert set(part.status.ravel()) == {"interrupted"}
    assert np.all(np.isfinite(part.q[..., 0, 0])) and np.all(np.isnan(part.q[..., -1, 0]))


# -- the argument check of the kernel calls ----------------------------------------------------

def test_kernel_call_arguments_are_checked_in_full():
    """A call with too few or too many arguments is an error naming the slot, not a
    silently truncated argument list (zip stopped at the shorter one)."""
    arr = types.Array(types.float64, 1, "C")
    args = (types.float64, arr, arr, arr, arr)
    assert check_arguments("rhs", args)
    assert not check_arguments("rhs", (types.float64, arr, arr, types.float64, arr))
    with pytest.raises(TypeError, match=r"call_rhs takes the kernel's address and 5"):
        check_arguments("rhs", args[:4])
    with pytest.raises(TypeError, match="call_rhs_lanes .* got 7"):
        check_arguments("rhs_lanes", args + (types.int64, types.int64))
    assert len(SIGNATURES["rhs_jvp_lanes"].args) == 8
