"""Long single runs (issue 22, point 3): in parts, with progress, stopped by Ctrl-C.

A trajectory of millions of drive periods is integrated in compiled calls of about a
quarter of a second; between them Python shows progress and sees Ctrl-C.  Checked here:

* the parts do not change the numbers: a run cut into hundreds of pauses (the held step,
  its block of error ratios, the compensated sums and the drive's rotations saved and
  restored) equals the unbroken run bit for bit, for every method of ``simulate_grid``;
  ``System.simulate`` with DOP853 (sized by time) likewise;
* Ctrl-C sent to a child process stops ``KapitzaPendulum.measure(periods=3e6)``,
  ``kapitza measure --periods 3000000`` and a long ``System.simulate`` within a second,
  with the part computed: a measurement with status "interrupted", ``t_reached`` and
  ``completed_periods`` (and Ω from the samples so far, equal to a run of that length);
  the command prints it and exits 130, no traceback (runs of 3·10⁶ periods, about a
  minute: their Ctrl-C lands in the run, not in the allocation of a longer run's strobe
  samples, which a test of its own covers);
* Ctrl-C stops a compiled call in flight, not only between calls: with the calls sized to
  a minute, every grid kernel that pauses long runs (RKN 12 on lanes and per point, the
  symplectic composition, DOP853 per point and on lanes, the Lyapunov lanes) returns
  within a second of the signal (``lagrange_core.progress.KERNEL_STOP``); a Ctrl-C
  during the last call is raised, not dropped;
* a progress line with the share done and the time left.
"""
import math
import os
import subprocess
import sys
import time

import numpy as np
import pytest

from lagrange_core import batch, problems

from helpers import ctrl_c_until_said, interrupt_child, sigint_default

PEND = dict(m=1.0, l=1.0, g=9.81)
W60 = 2 * math.pi * 60
T60 = 2 * math.pi / W60


@pytest.fixture(scope="module")
def pend():
    return problems.driven_pendulum("vertical")


FIELDS = ("q", "qdot", "strobe_q", "strobe_qdot", "q_mean", "max_deviation", "exit_time",
          "t_final", "n_steps", "n_rejected", "n_evaluations", "error_estimate", "status")


@pytest.mark.parametrize("method, kw", [
    ("rkn12", {}),                              # on lanes, the held step
    ("rkn12-fixed", {}),                        # lanes, the step from a pilot
    ("rkn12", {"lanes": False}),                # the per-point driver
    ("dop853", {}),
    ("yoshida6", {"h": T60 / 20}),
])
def test_paused_runs_equal_unbroken_runs_bit_for_bit(pend, monkeypatch, method, kw):
    """Four points of 600 periods (three stay up, one falls), every observable on, with
    the calls cut to 64-step budgets (≈ 40 pauses a point): every output equals the
    unbroken run's exactly."""
    lanes = kw.pop("lanes", True)
    monkeypatch.setattr(batch, "_USE_LANES", lanes)
    A = np.array([0.03, 0.05, 0.1, 0.011])

    def run():
        return pend.simulate_grid([np.pi - 0.1], [0.0], (0.0, 600 * T60),
                                  dict(PEND, A=A, omega=W60), method=method, strobe=T60,
                                  reference=[np.pi], band=([np.pi / 2], [3 * np.pi / 2]),
                                  progress=False, **kw)

    whole = run()
    calls = []
    _spied_parts(monkeypatch, calls)           # every budget shrinks to 64 steps
    parts = run()
    assert len(calls) > 30, "the run was not cut into parts"
    assert list(whole.status_name) == ["finished"] * 3 + ["left_band"]
    for name in FIELDS:
        np.testing.assert_array_equal(getattr(parts, name), getattr(whole, name), err_msg=name)



def _spied_parts(monkeypatch, calls):
    """Cut every later run into calls of 64-step budgets, counting the calls."""
    real = batch._run_paused

    def spy(call, *args):
        def counted(*a):
            calls.append(len(a[0]))
            return call(*a)
        return real(counted, *args)

    monkeypatch.setattr(batch, "_TARGET", 1e-9)
    monkeypatch.setattr(batch, "_FIRST_BUDGET", 64)
    monkeypatch.setattr(batch, "_run_paused", spy)


def test_a_step_retaken_after_a_rejection_pauses_as_it_runs(pend, monkeypatch):
    """RKN 12 on lanes at rtol 1e-4, no strobe: where a step retaken after a rejection
    meets a new held step (this point of benchmarks/bench_measure.py's grid: the first
    block's last error ratio is a rejection's), the lanes went on with the retaken step,
    the per-point driver with the held one; a pause, which takes the per-point driver's
    path, changed the trajectory (91 of that grid's 4096 points differed).  Now the runs
    cut into 64-step parts equal the unbroken ones bit for bit."""
    A = np.array([0.0730952380952381, 0.03, 0.1])
    omega = 2 * math.pi * np.array([90.95238095238095, 60.0, 40.0])
    T = 2 * math.pi / omega

    def run():
        return pend.simulate_grid([np.pi - 0.1], [0.0], (0.0, 500 * T),
                                  dict(PEND, A=A, omega=omega), rtol=1e-4,
                                  band=([np.pi / 2], [3 * np.pi / 2]), progress=False)

    whole = run()
    calls = []
    _spied_parts(monkeypatch, calls)
    parts = run()
    assert len(calls) > 10, "the run was not cut into parts"
    for name in FIELDS:
        np.testing.assert_array_equal(getattr(parts, name), getattr(whole, name), err_msg=name)


def test_drained_lanes_run_on_as_each_point_alone(pend):
    """A thread's lanes whose last points end at scattered times pause them and run them
    on, on fewer lanes (lagrange_core._batch_kernels.DRAIN_FRACTION): 96 points in
    random order, 46 falling between 70 and 270 periods, the rest staying up for 300,
    together (on 48 lanes a thread, two threads, that drain) equal each point run alone
    (one lane, no drain) bit for bit."""
    A = np.random.default_rng(1).permutation(np.linspace(0.004, 0.02, 96))
    T = 2 * math.pi / W60

    def run(a):
        return pend.simulate_grid([np.pi - 0.1], [0.0], (0.0, 300 * T),
                                  dict(PEND, A=a, omega=W60), rtol=1e-4, strobe=T,
                                  reference=[np.pi], band=([np.pi / 2], [3 * np.pi / 2]),
                                  progress=False)

    together = run(A)
    assert 10 < np.sum(together.status_name == "left_band") < 86, "not a mix of lifetimes"
    for k in range(0, A.size, 7):
        alone = run(A[k:k + 1])
        for name in FIELDS:
            np.testing.assert_array_equal(getattr(alone, name)[0], getattr(together, name)[k],
                                          err_msg=f"{name}, point {k}")

MID_CALL_CHILD = r'''
import json, math, os, signal, threading, time
import numpy as np
signal.signal(signal.SIGINT, signal.default_int_handler)   # a background job ignores SIGINT
from lagrange_core import batch, problems
from lagrange_core.batch import GridInterrupted
from kapitza.chaos import _lyapunov, bifurcation_diagram, lyapunov_grid
from kapitza.results import ComputationInterrupted
batch._TARGET = 60.0                  # every call sized to a minute: Ctrl-C must not wait
batch._FIRST_BUDGET = 1 << 40         # for it (the first call runs its points to the end)
pend = problems.driven_pendulum("vertical")
damped = problems.driven_pendulum("vertical", damping=True)
P = dict(m=1.0, l=1.0, g=9.81)
w = 2 * math.pi * 60
A = np.linspace(0.03, 0.1, 400)
w0 = math.sqrt(9.81)
PD = dict(P, A=0.3, omega=2 * w0, gamma=0.1 * w0)
armed, entered = [], []     # the Ctrl-C's timer; when the long run's first call began
real_run_paused = batch._run_paused


def run_paused(call, *args, **kwargs):
    """batch._run_paused, its calls watched: the first call of an armed run starts the
    timer as it enters the kernel (the Ctrl-C then lands in that call, whatever the load)."""
    def watched(*a):
        if armed:
            entered.append(time.time())
            armed.pop().start()
        return call(*a)
    return real_run_paused(watched, *args, **kwargs)


batch._run_paused = _lyapunov._run_paused = run_paused    # the strobe lanes import it late


def grid(method, lanes=True, **kw):
    def run(span):
        batch._USE_LANES = lanes
        pend.simulate_grid([math.pi - 0.1], [0.0], (0.0, span), dict(P, A=A, omega=w),
                           method=method, progress=False, **kw)
    return run


CASES = {
    "rkn12 on lanes": grid("rkn12"),
    "rkn12 per point": grid("rkn12", lanes=False),
    "yoshida6": grid("yoshida6", h=2 * math.pi / w / 20),
    "dop853": grid("dop853"),
    "lyapunov lanes": lambda span: lyapunov_grid(
        damped, dict(PD, A=np.linspace(0.2, 0.4, 64)), 0.3, periods=max(int(span), 2),
        transient=0, blocks=2, progress=False),
    "dop853 on lanes (diagram)": lambda span: bifurcation_diagram(
        damped, PD, parameter="A", values=np.linspace(0.2, 0.4, 64), q0=0.3, angles="theta",
        periods=2, transient=max(int(span), 1), progress=False),
}
print("ready", flush=True)
for name, run in CASES.items():
    run(0.1)                            # compiled (or loaded) before the clock starts
    sent = []
    entered.clear()

    def ctrl_c():
        sent.append(time.time())
        os.kill(os.getpid(), signal.SIGINT)
    timer = threading.Timer(0.1, ctrl_c)
    armed.append(timer)
    try:
        run(1e6)
        out = {"case": name, "interrupted": False}
    except (GridInterrupted, ComputationInterrupted):
        out = {"case": name, "interrupted": True, "after": time.time() - sent[0],
               "in_call": sent[0] - entered[0]}
    timer.cancel()
    print(json.dumps(out), flush=True)
'''


def test_ctrl_c_stops_a_compiled_call_in_flight_within_a_second(tmp_path):
    """With every call sized to a minute (its first call runs its points to the end), a
    Ctrl-C 0.1 s after the long grid's first call entered the kernel stops each kernel
    family within a second: the kernels read the stop flag at every step (measured
    1–6 ms).  Before the flag, the wait was the rest of the call in flight: here the whole
    run.  (The timer starts from inside the call, not at a fixed time before it: the
    signal cannot land in the set-up before the call, where any loop would see it.)"""
    import json
    script = tmp_path / "child.py"
    script.write_text(MID_CALL_CHILD)
    env = dict(os.environ, NUMBA_NUM_THREADS="2")       # the blocks on threads, as usual
    out = subprocess.run([sys.executable, str(script)], capture_output=True, text=True,
                         timeout=300, env=env, preexec_fn=sigint_default)
    lines = out.stdout.splitlines()
    assert lines and lines[0] == "ready", out.stderr[-2000:]
    results = [json.loads(line) for line in lines[1:]]
    assert len(results) == 6, out.stderr[-2000:]
    for r in results:
        assert r["interrupted"], r
        assert r["in_call"] > 0 and r["after"] < 1.0, r     # sent in the call; stopped


def test_a_ctrl_c_during_the_last_call_is_raised_not_dropped(pend):
    """A Ctrl-C that came while the last call ran (its points all ended in it) was dropped:
    the grid returned as if never interrupted and the script went on.  Now it raises
    GridInterrupted all the same, with every point in its result."""
    from lagrange_core import progress as _progress

    def ctrl_c_in_the_last_call(done, total):
        if done == total:
            _progress._SIGINT["hit"] = True         # what the deferred Ctrl-C handler sets
    try:
        with pytest.raises(batch.GridInterrupted) as caught:
            pend.simulate_grid([np.pi - 0.1], [0.0], (0.0, 20 * T60),
                               dict(PEND, A=[0.03, 0.05], omega=W60),
                               progress=ctrl_c_in_the_last_call)
    finally:
        _progress._SIGINT["hit"] = False
    assert list(caught.value.result.status_name) == ["finished"] * 2
    assert "after 2 of 2 points" in str(caught.value)


def test_dop853_simulate_in_chunks_equals_one_chunk():
    """System.simulate sizes DOP853's chunks by their time: its whole state is in the
    driver's arrays, so 997-step chunks give the numbers of a single chunk."""
    damped = problems.driven_pendulum("vertical", damping=True)
    P = dict(PEND, A=0.05, omega=W60, gamma=0.2)
    t_eval = np.arange(0, 3001, 100) * T60
    one = damped.simulate([np.pi - 0.1], [0.0], (0, 3000 * T60), P, t_eval=t_eval,
                          chunk_steps=10**9)
    many = damped.simulate([np.pi - 0.1], [0.0], (0, 3000 * T60), P, t_eval=t_eval,
                           chunk_steps=997)
    assert one.method == "dop853" and one.n_steps > 5 * 997
    np.testing.assert_array_equal(many.q, one.q)
    np.testing.assert_array_equal(many.qdot, one.qdot)


MEASURE_CHILD = r'''
import json, math, time
from kapitza import KapitzaPendulum
from kapitza.results import ComputationInterrupted
pend = KapitzaPendulum()
pend.measure(0.05, 2 * math.pi * 60, math.pi - 0.01, periods=20)        # compile


def running(done, total):
    """Says "ready" once the run is under way (its first part, 2048 periods, made)."""
    if done > 0 and not running.said:
        running.said = True
        print("ready", flush=True)


running.said = False
try:
    pend.measure(0.05, 2 * math.pi * 60, math.pi - 0.01, periods=3_000_000, progress=running)
    print(json.dumps({"finished": True}), flush=True)
except ComputationInterrupted as stop:
    t = time.time()
    m = stop.result
    k = int(m.completed_periods)
    same = pend.measure(0.05, 2 * math.pi * 60, math.pi - 0.01, periods=k)
    print(json.dumps({"finished": False, "t": t, "status": m.status, "t_reached": m.t_reached,
                      "periods": k, "omega": m.omega_slow, "error": m.omega_slow_error,
                      "omega_same": same.omega_slow, "message": str(stop)}), flush=True)
'''


def test_ctrl_c_stops_a_long_measure_within_a_second(tmp_path):
    """measure(periods=3e6) — a minute's run — stops within a second of Ctrl-C; the partial
    measurement says how far it got and its Ω is that of a run of its completed periods
    (the samples after the last whole period are the same run's).  The Ctrl-C comes 0.3 s
    after the run's first part (a wait on that event, not on the clock: a fixed 1.5 s
    after the start was mostly spent running, and again re-running the same length)."""
    res, sent = interrupt_child(tmp_path, MEASURE_CHILD, 0.3, 120)
    assert res["finished"] is False
    assert res["t"] - sent < 1.0
    assert res["status"] == "interrupted" and res["periods"] > 1000
    assert res["t_reached"] >= res["periods"] * T60
    assert abs(res["omega"] - 12.98) < 0.01 and res["error"] < 1e-6
    assert abs(res["omega"] - res["omega_same"]) <= 2 * res["error"]
    assert "interrupted" in res["message"] and "3000000 periods" in res["message"]


def test_a_ctrl_c_before_the_first_step_stops_at_once(monkeypatch):
    """A Ctrl-C while a long run's strobe samples are still being allocated (3·10⁷ periods:
    480 MB, 1.7 s to fill here) stops there, and the measurement does not then fit the
    3·10⁷ NaN samples of a run that never started (2–4 s): the test of the command above
    failed now and then, its Ctrl-C landing before the first step (fails before: 2.2–3.7 s)."""
    from kapitza import KapitzaPendulum
    from kapitza.results import ComputationInterrupted
    kp = KapitzaPendulum()
    kp.measure(0.05, W60, math.pi - 0.01, periods=20)                 # compiled or loaded
    monkeypatch.setattr(batch, "interrupt_requested", lambda: True)   # Ctrl-C, deferred
    start = time.perf_counter()
    with pytest.raises(ComputationInterrupted) as stop:
        kp.measure(0.05, W60, math.pi - 0.01, periods=30_000_000)
    took = time.perf_counter() - start
    m = stop.value.result
    assert m.status == "not_run" and int(m.completed_periods) == 0
    assert math.isnan(m.omega_slow) and math.isnan(m.t_reached)
    assert took < 1.0, took            # the whole call, Ctrl-C's bound (measured ~0.1 s)


COMMAND = r'''
import contextlib, io, sys
from kapitza.cli import main
from lagrange_core import batch
with contextlib.redirect_stdout(io.StringIO()):   # compiled (or loaded) before the signal
    main(["measure", "--A", "0.05", "--omega", "377", "--theta0", "3.13", "--periods", "5"])
real_run_paused = batch._run_paused


def run_paused(call, *args, **kwargs):
    """batch._run_paused, saying "running" on stdout as the run's first call begins."""
    def watched(*a):
        if not run_paused.said:
            run_paused.said = True
            print("running", flush=True)
        return call(*a)
    return real_run_paused(watched, *args, **kwargs)


run_paused.said = False
batch._run_paused = run_paused
print("ready", flush=True)
sys.exit(main(["measure", "--A", "0.05", "--omega", "377", "--theta0", "3.13",
               "--periods", "3000000"]))
'''


def test_ctrl_c_stops_the_measure_command_with_its_partial_result():
    """``kapitza measure --periods 3000000`` (its ``main``, once imported): exit 130,
    the warning within a second of Ctrl-C, the run so far printed (status interrupted),
    no traceback.  The Ctrl-C comes 0.3 s after the run's first compiled call began (a
    wait on that event: a fixed second after "ready" was mostly run, and on a loaded
    machine could still land in the allocation before the run)."""
    env = dict(os.environ, PYTHONUNBUFFERED="1")
    proc = subprocess.Popen([sys.executable, "-c", COMMAND], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, env=env,
                            preexec_fn=sigint_default)
    try:
        assert proc.stdout.readline().strip() == "ready"
        assert proc.stdout.readline().strip() == "running", proc.communicate()
        time.sleep(0.3)
        assert proc.poll() is None, proc.communicate()
        took, out, err = ctrl_c_until_said(proc)
    finally:
        if proc.poll() is None:
            proc.kill()
    assert proc.returncode == 130, (out, err)
    assert took < 1.0
    assert "Traceback" not in err and "measure: interrupted at t =" in err
    assert "status interrupted" in out and "stayed up" in out


SIMULATE_CHILD = r'''
import json, math, signal, time
import numpy as np
from lagrange_core import problems
from lagrange_core.integrate import SimulationInterrupted
damped = problems.driven_pendulum("vertical", damping=True)
P = dict(m=1.0, l=1.0, g=9.81, A=0.05, omega=2 * math.pi * 60, gamma=0.1)
damped.simulate([math.pi - 0.1], [0.0], (0, 0.1), P)             # compile


def running(done, total):
    """Says "ready" once the run is under way (its first chunk made)."""
    if done > 0 and not running.said:
        running.said = True
        print("ready", flush=True)


running.said = False
try:
    damped.simulate([math.pi - 0.1], [0.0], (0, 1e6), P, stride=1000, progress=running)
    print(json.dumps({"finished": True}), flush=True)
except SimulationInterrupted as stop:
    t = time.time()
    tr = stop.trajectory
    again = damped.simulate([math.pi - 0.1], [0.0], (0, tr.t[-1]), P, t_eval=tr.t[-3:-1])
    print(json.dumps({"finished": False, "t": t, "status": tr.status, "t_last": tr.t[-1],
                      "rows": len(tr.t), "message": tr.message,
                      "same": bool(np.allclose(again.q, tr.q[-3:-1], rtol=0, atol=1e-9))}),
          flush=True)
'''


def test_ctrl_c_stops_a_long_simulate_keeping_the_trajectory(tmp_path):
    """System.simulate over 10⁶ s (DOP853: a damped pendulum) stops within a second of
    Ctrl-C with the trajectory so far, status "interrupted", its message saying where;
    its last rows are those of a run to that time.  The Ctrl-C comes 0.3 s after the
    run's first chunk (a wait on that event; the run so far is run again to compare)."""
    res, sent = interrupt_child(tmp_path, SIMULATE_CHILD, 0.3, 60)
    assert res["finished"] is False
    assert res["t"] - sent < 1.0
    assert res["status"] == "interrupted" and res["rows"] > 10 and res["t_last"] > 1.0
    assert "% of t_span" in res["message"] and res["same"]


def test_a_long_run_shows_progress_with_the_time_left(capfd, monkeypatch):
    """progress=True: a one-point run in several parts writes a line on stderr with the
    share of the run done and the time left (shown at once here: the half second a line
    waits for is set to 0); a callable gets the share as it grows."""
    from kapitza import KapitzaPendulum
    from lagrange_core import progress
    monkeypatch.setattr(progress, "SHOW_AFTER", 0.0)
    monkeypatch.setattr(batch, "_FIRST_BUDGET", 64)       # several parts, however fast
    pend = KapitzaPendulum()
    pend.measure(0.05, W60, math.pi - 0.1, periods=3000, observables="classification",
                 progress=True)
    err = capfd.readouterr().err
    assert "simulate_grid: " in err and "% of the run" in err and "s left" in err, err
    shares = []
    pend.measure(0.05, W60, math.pi - 0.1, periods=3000, observables="classification",
                 progress=lambda done, total: shares.append(done / total))
    assert len(shares) > 2 and shares[-1] == 1.0 and shares == sorted(shares)
    assert 0 < shares[0] < 1


def test_a_simulate_of_several_chunks_shows_progress(capfd, monkeypatch):
    """System.simulate(progress=True) in several chunks writes the share of t_span reached
    and the time left; a run of one chunk writes nothing."""
    from lagrange_core import progress
    monkeypatch.setattr(progress, "SHOW_AFTER", 0.0)
    damped = problems.driven_pendulum("vertical", damping=True)
    P = dict(PEND, A=0.05, omega=W60, gamma=0.2)
    damped.simulate([np.pi - 0.1], [0.0], (0, 300 * T60), P, chunk_steps=500, progress=True)
    err = capfd.readouterr().err
    assert "simulate: " in err and "% of t_span" in err and "s left" in err, err
    damped.simulate([np.pi - 0.1], [0.0], (0, T60), P, progress=True)
    assert capfd.readouterr().err == ""


def test_interrupted_status_is_named():
    assert batch.STATUS_NAMES[7] == "interrupted"
