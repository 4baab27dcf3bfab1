"""System.simulate_grid (lagrange_core.batch): many trajectories in one compiled call.

Each observable is checked against something independent: the one-trajectory
integrator ``System.simulate`` at a much tighter tolerance (strobe samples, final
states, band exits located by its event finder), the energy's closed form, and the
per-point failure statuses against systems built to fail at one grid point.
"""
import math

import numpy as np
import pytest
import sympy as sp

from lagrange_core import System, coordinates, problems
from lagrange_core.batch import STATUS_NAMES, GridTrajectories
from lagrange_core.integrate import crossing

from helpers import interrupt_child

PEND = dict(m=1.0, l=1.0, g=9.81)
UP_BAND = ([math.pi / 2], [3 * math.pi / 2])


@pytest.fixture(scope="module")
def pend():
    return problems.driven_pendulum("vertical")


@pytest.mark.parametrize("method, kw, bound", [
    ("rkn12", dict(rtol=1e-10), 1e-8),
    ("rkn12-fixed", dict(rtol=1e-10), 1e-8),
    ("rkn12-fixed", dict(h=None), 1e-7),          # the step from the default tolerance
    ("dop853", dict(rtol=1e-10), 1e-8),
])
def test_strobe_samples_match_one_trajectory_runs(pend, method, kw, bound):
    """Strobe samples θ(kT), θ̇(kT) over 60 periods at a 3 × 2 grid of (A, ω) equal those of
    separate ``simulate`` runs at rtol 1e-13 (t_eval at the same times) to the bound."""
    A = np.array([0.02, 0.05, 0.1])[:, None]
    w = 2 * np.pi * np.array([30.0, 45.0])[None, :]
    T = 2 * np.pi / w
    kw = {k: v for k, v in kw.items() if v is not None}
    g = pend.simulate_grid([np.pi - 0.05], [0.0], (0.0, 60 * T), dict(PEND, A=A, omega=w),
                           method=method, strobe=T, **kw)
    assert g.shape == (3, 2) and g.strobe_q.shape == (3, 2, 61, 1)
    assert (g.status == 0).all(), g.status_name
    for i in range(3):
        for j in range(2):
            ref = pend.simulate([np.pi - 0.05], [0.0], (0.0, 60 * T[0, j]),
                                dict(PEND, A=A[i, 0], omega=w[0, j]), rtol=1e-13,
                                t_eval=np.arange(61) * T[0, j])
            assert np.max(np.abs(g.strobe_q[i, j, :, 0] - ref.q[:, 0])) < bound
            assert np.max(np.abs(g.strobe_qdot[i, j, :, 0] - ref.qdot[:, 0])) < 100 * bound
            assert g.q[i, j, 0] == pytest.approx(ref.q[-1, 0], abs=bound)
            assert g.t_final[i, j] == pytest.approx(60 * T[0, j], rel=1e-14)


def test_damped_grid_runs_dop853_and_matches(pend):
    damped = problems.driven_pendulum("vertical", damping=True)
    w = 2 * np.pi * 40
    gam = np.array([0.0, 0.5, 2.0])
    g = damped.simulate_grid([np.pi - 0.05], [0.0], (0.0, 2.0), dict(PEND, A=0.05, omega=w,
                                                                     gamma=gam))
    assert g.method == "dop853"
    for k, gm in enumerate(gam):
        ref = damped.simulate([np.pi - 0.05], [0.0], (0.0, 2.0),
                              dict(PEND, A=0.05, omega=w, gamma=gm), rtol=1e-13)
        assert g.q[k, 0] == pytest.approx(ref.q[-1, 0], abs=1e-7)


def test_band_exit_time_matches_event_location(pend):
    """Weak drives let the pendulum fall: the exit time is located by the step's cubic
    Hermite interpolant, within 1e-4 s of the event finder of ``simulate`` at rtol 1e-12
    (measured 6e-6 and 3e-6 s); the run stops there, on the boundary."""
    w = 2 * np.pi * 30
    A = np.array([0.01, 0.02])
    g = pend.simulate_grid([np.pi - 0.1], [0.0], (0.0, 100 * 2 * np.pi / w),
                           dict(PEND, A=A, omega=w), band=UP_BAND)
    assert list(g.status_name) == ["left_band", "left_band"]
    for k, a in enumerate(A):
        ref = pend.simulate([np.pi - 0.1], [0.0], (0.0, 10.0), dict(PEND, A=a, omega=w),
                            rtol=1e-12, events=[crossing("theta", math.pi / 2, terminal=True),
                                                crossing("theta", 3 * math.pi / 2,
                                                         terminal=True)])
        assert ref.status == "event"
        assert abs(g.exit_time[k] - ref.t[-1]) < 1e-4
        assert g.t_final[k] == g.exit_time[k]
        assert g.q[k, 0] == pytest.approx(math.pi / 2, abs=1e-9)
        assert g.exit_coordinate[k] == 0


def test_reference_deviation_and_time_mean(pend):
    """Upright and stable, θ stays near π: the running max of |θ − π| is at least the
    initial tilt and below π/2; the time mean of θ is π within the slow oscillation."""
    w = 2 * np.pi * 60
    g = pend.simulate_grid([np.pi - 0.1], [0.0], (0.0, 5.0), dict(PEND, A=0.05, omega=w),
                           reference=[np.pi])
    dev = g.max_deviation[0]
    assert 0.1 - 1e-9 <= dev < 0.3
    assert abs(g.q_mean[0] - np.pi) < 0.1


def test_failures_are_per_point():
    """q̈ = k q³ blows up in finite time for k > 0 (from q = 1 at rest, at t ≈ 1.31/√k);
    a = 0 makes the mass matrix singular.  The failing points get their statuses; the
    good ones are unaffected (equal to a run of their own)."""
    (q,), (qd,) = coordinates("q")
    a, k = sp.symbols("a k", real=True)
    s = System([q], lagrangian=a * qd**2 / 2 + k * q**4 / 4, name="quartic")
    kv = np.array([-1.0, 4.0, -1.0, -1.0])
    av = np.array([1.0, 1.0, 0.0, 2.0])
    g = s.simulate_grid([1.0], [0.0], (0.0, 3.0), dict(a=av, k=kv), method="dop853")
    names = list(g.status_name)
    assert names[0] == "finished" and names[3] == "finished"
    assert names[1] in ("underflow", "non_finite")
    assert names[2] == "singular"
    for i in (0, 3):
        ref = s.simulate([1.0], [0.0], (0.0, 3.0), dict(a=av[i], k=kv[i]), rtol=1e-12)
        assert g.q[i, 0] == pytest.approx(ref.q[-1, 0], abs=1e-7)
    assert g.counts() == {"finished": 2, "underflow" if names[1] == "underflow" else
                          "non_finite": 1, "singular": 1}
    df = g.to_dataframe()
    assert list(df["status"]) == names and len(df) == 4


def test_grid_broadcasts_and_dataframe(pend):
    A = np.linspace(0.02, 0.1, 4)[:, None, None]
    w = 2 * np.pi * np.array([40.0, 60.0])[None, :, None]
    th0 = np.pi - np.array([0.05, 0.1, 0.2])[None, None, :]
    g = pend.simulate_grid(th0[..., None], [0.0], (0.0, 0.2), dict(PEND, A=A, omega=w))
    assert isinstance(g, GridTrajectories) and g.shape == (4, 2, 3)
    assert g.q.shape == (4, 2, 3, 1) and g.params["A"].shape == (4, 2, 3)
    df = g.to_dataframe()
    assert len(df) == 24 and {"A", "omega", "theta", "theta_dot", "status"} <= set(df.columns)
    # a point equals its own one-point grid
    one = pend.simulate_grid([th0[0, 0, 2]], [0.0], (0.0, 0.2), dict(PEND, A=A[3, 0, 0],
                                                                     omega=w[0, 1, 0]))
    assert one.shape == () and one.q[0] == g.q[3, 1, 2, 0]


@pytest.mark.parametrize("kwargs, match", [
    (dict(params=dict(PEND, A=np.ones(3), omega=np.ones(4))), "do not broadcast"),
    (dict(params=dict(PEND, A=0.1)), r"missing value\(s\) for parameter\(s\) \['omega'\]"),
    (dict(params=dict(PEND, A=0.1, omega=1.0, mass=1.0)), "unknown parameter"),
    (dict(t_span=(1.0, np.array([2.0, 0.5]))), "end time must be after"),
    (dict(strobe=-1.0), "strobe must be a positive period"),
    (dict(band=([3.2], [4.0])), "lies outside"),
    (dict(method="rk4"), "simulate_grid runs methods"),
    (dict(method="yoshida6"), "fixed step: pass h"),
    (dict(q0=[1.0, 2.0]), "last axis of 1 entries"),
    (dict(rtol=0.0), "rtol must be"),
])
def test_bad_input_names_the_argument(pend, kwargs, match):
    args = dict(q0=[3.0], qdot0=[0.0], t_span=(0.0, 1.0), params=dict(PEND, A=0.1, omega=60.0))
    args.update(kwargs)
    q0, qd0, ts, p = args.pop("q0"), args.pop("qdot0"), args.pop("t_span"), args.pop("params")
    with pytest.raises(ValueError, match=match):
        pend.simulate_grid(q0, qd0, ts, p, **args)


def test_status_names_are_documented():
    assert STATUS_NAMES[:2] == ("finished", "left_band") and "not_run" in STATUS_NAMES


CHILD = r'''
import json, math, signal, sys, time
import numpy as np
signal.signal(signal.SIGINT, signal.default_int_handler)   # a background job ignores SIGINT
from lagrange_core import batch, problems
from lagrange_core.batch import GridInterrupted
pend = problems.driven_pendulum("vertical")
P = dict(m=1.0, l=1.0, g=9.81)
w = 2 * np.pi * 60
A = np.linspace(0.03, 0.1, 4000)
pend.simulate_grid([np.pi - 0.1], [0.0], (0.0, 0.01), dict(P, A=A[:4], omega=w))  # compile
real_run_paused = batch._run_paused


def run_paused(call, N, TS, TF, STATUS, *args, **kwargs):
    """batch._run_paused, saying "ready" after the first call that finished a point."""
    def watched(*a):
        call(*a)
        if not run_paused.said and (STATUS == 0).any():
            run_paused.said = True
            print("ready", flush=True)
    return real_run_paused(watched, N, TS, TF, STATUS, *args, **kwargs)


run_paused.said = False
batch._run_paused = run_paused
try:
    pend.simulate_grid([np.pi - 0.1], [0.0], (0.0, 200.0), dict(P, A=A, omega=w),
                       progress=False)
    print(json.dumps({"finished": True, "t": time.time()}), flush=True)
except GridInterrupted as e:
    t = time.time()
    r = e.result
    done = np.flatnonzero(r.status == 0)
    k = int(done[len(done) // 2])
    one = pend.simulate_grid([np.pi - 0.1], [0.0], (0.0, 200.0), dict(P, A=A[k], omega=w))
    part = r.status_name == "interrupted"
    print(json.dumps({"finished": False, "t": t, "done": int(len(done)),
                      "not_run": int(np.sum(r.status_name == "not_run")),
                      "part": int(part.sum()),
                      "part_ok": bool(np.isfinite(r.q[part]).all()
                                      and np.all((r.t_final[part] > 0) & (r.t_final[part] < 200))),
                      "same": bool(one.q[0] == r.q[k, 0]),
                      "nan_rest": bool(np.isnan(r.q[r.status == 6]).all())}), flush=True)
'''


def test_ctrl_c_keeps_the_finished_points(tmp_path):
    """Ctrl-C during a long grid (4000 points × 200 s) stops within a second and raises
    GridInterrupted carrying every finished point (equal to a run of its own), the points
    stopped part-way ("interrupted": their state where they stopped, before the end) and
    the rest marked "not_run" with NaN states.  The Ctrl-C comes 0.2 s after the call
    that finished the first points (~0.4 s of work: a wait on that event; a fixed 1.5 s
    after the start ran on two threads for nothing, and on a loaded machine could come
    before any point had finished)."""
    res, sent = interrupt_child(tmp_path, CHILD, 0.2, 60)
    assert res["finished"] is False
    assert res["t"] - sent < 1.0
    assert res["done"] > 0 and res["not_run"] > 0 and res["part_ok"]
    assert res["done"] + res["part"] + res["not_run"] == 4000
    assert res["same"] and res["nan_rest"]
