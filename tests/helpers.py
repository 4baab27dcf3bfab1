"""References shared by the test files (test_floquet.py, test_averaging.py, ...), and the
child-process harness of the Ctrl-C tests (:func:`interrupt_child`).

Every reference is independent of kapitza: monodromy matrices integrated here with
scipy's solve_ivp (DOP853) at tight tolerance, from the linearised equations as written
in shared/PHYSICS.md or from lagrange_core's compiled Jacobian.
"""
import math

import numpy as np
from scipy.integrate import solve_ivp

G, L = 9.81, 1.0
W0 = math.sqrt(G / L)


def monodromy(matrix, period, *, rtol=1e-12, atol=1e-13):
    """Monodromy of x′ = matrix(t) x over one period: all columns of the fundamental
    matrix integrated together by solve_ivp (DOP853)."""
    d = np.shape(matrix(0.0))[0]

    def f(tt, y):
        return (np.asarray(matrix(tt)) @ y.reshape(d, d)).ravel()
    sol = solve_ivp(f, (0.0, period), np.eye(d).ravel(), method="DOP853", rtol=rtol, atol=atol)
    return sol.y[:, -1].reshape(d, d)


def pendulum_monodromy(A, omega, sign, gamma=0.0, l=L, g=G):
    """Over one drive period: θ̈ = −γ θ̇ − sign (g − A ω² cos ωt) θ / l (sign +1 hanging,
    −1 upright; PHYSICS.md)."""
    def mat(tt):
        k = sign * (g - A * omega**2 * math.cos(omega * tt)) / l
        return np.array([[0.0, 1.0], [-k, -gamma]])
    return monodromy(mat, 2 * math.pi / omega)


def mathieu_ivp_trace(a, q, c=0.0):
    """tr M of y″ + c y′ + (a − 2q cos 2τ) y = 0 over τ ∈ [0, π], damping kept as is."""
    def mat(tau):
        return np.array([[0.0, 1.0], [-(a - 2 * q * np.cos(2 * tau)), -c]])
    return np.trace(monodromy(mat, np.pi, rtol=1e-12, atol=1e-14))


def mathieu_mpmath_trace(a, q):
    """tr M_u of u″ = −(a − 2q cos 2τ) u over τ ∈ [0, π] to ~20 digits: mpmath's Taylor
    integrator at 20 digits over half the period (tr = 2 (u1 u2′ + u1′ u2)(π/2), cos 2τ
    being even).  About a second a call for q ≤ 16."""
    import mpmath as mp
    with mp.workdps(20):
        a_, q_ = mp.mpf(a), mp.mpf(q)

        def f(t, y):
            k = -(a_ - 2 * q_ * mp.cos(2 * t))
            return [y[1], k * y[0], y[3], k * y[2]]
        u1, v1, u2, v2 = mp.odefun(f, 0, [1, 0, 0, 1])(mp.pi / 2)
        return float(2 * (u1 * v2 + v1 * u2))


def jacobian_monodromy(system, params, about, *, rtol, atol=1e-13):
    """Monodromy of x′ = J(t) x about the state (q = about, q̇ = 0) over one period
    2π/params["omega"], J from the system's compiled ``jacobian`` kernel."""
    k = system.kernels
    P = system.parameter_array(params)
    ystar = np.concatenate([np.asarray(about, float), np.zeros(len(about))])
    J = np.empty((ystar.size, ystar.size))

    def mat(tt):
        k.jacobian(tt, ystar, P, J)
        return J.copy()
    return monodromy(mat, 2 * math.pi / params["omega"], rtol=rtol, atol=atol)


def sigint_default():
    """``preexec_fn`` of a child that must see Ctrl-C: SIGINT back to its default action.

    A shell's background job (``cmd &``, as CI may start the suite) ignores SIGINT, its
    children inherit SIG_IGN across exec, and Python then installs no KeyboardInterrupt
    handler: the child would never notice the signal the test sends."""
    import signal
    signal.signal(signal.SIGINT, signal.SIG_DFL)


def ctrl_c_until_said(proc, read=()):
    """Send SIGINT to ``proc`` (started with :func:`sigint_default`, stdout and stderr
    piped as text) and read its stderr until a line says "interrupted".  ``read``: the
    stderr lines read before.  Returns (seconds from the signal to that line, stdout, the
    whole stderr), the process ended."""
    import signal
    import time
    lines = list(read)
    sent = time.time()
    proc.send_signal(signal.SIGINT)
    while not any("interrupted" in line for line in lines):
        lines.append(proc.stderr.readline())      # the warning, as soon as it is said
        assert lines[-1], "stderr closed without saying it was interrupted"
    took = time.time() - sent
    out, err = proc.communicate(timeout=60)
    return took, out, "".join(lines) + err


def interrupt_child(tmp_path, source, delay, timeout):
    """Run ``source`` in a child process, send it SIGINT ``delay`` s after it prints
    "ready", and return (its JSON report, the time the signal was sent)."""
    import json
    import os
    import signal
    import subprocess
    import sys
    import time
    script = tmp_path / "child.py"
    script.write_text(source)
    proc = subprocess.Popen([sys.executable, str(script)], stdout=subprocess.PIPE, text=True,
                            preexec_fn=sigint_default)
    try:
        assert proc.stdout.readline().strip() == "ready"
        time.sleep(delay)
        sent = time.time()
        os.kill(proc.pid, signal.SIGINT)
        out = proc.stdout.readline()
        proc.wait(timeout=timeout)
    finally:
        if proc.poll() is None:
            proc.kill()
    return json.loads(out), sent


# -- scene files ---------------------------------------------------------------------------

_PENDULUM_SCENE = '''\
schema = 1
[system]
name = "pendulum"
[parameters]
l = 1.0
[effects]
gravity = true
[effects.drive]
direction = "{direction}"
amplitude = 0.05
omega = 200.0
[initial]
theta = {theta}
[analyses]
{analyses}
[sweep]
{sweep}
[sweep.axes]
{axes}
'''


def pendulum_scene(direction="vertical", theta=3.1, analyses="", axes="", sweep=""):
    """A pendulum scene on a pivot driven at A = 5 cm, ω = 200 rad/s, swept over ``axes``."""
    return _PENDULUM_SCENE.format(direction=direction, theta=theta, analyses=analyses,
                                  axes=axes, sweep=sweep)


def ctrl_c_in_process(call, delay, after=None):
    """Run ``call()`` in this process with Python's own Ctrl-C handler (as in an interactive
    run: a shell's background job, and so perhaps this worker, has SIGINT ignored) and send
    this process SIGINT from a thread, as from outside, ``delay`` s after the call began —
    or after the event ``after`` is set (by the call, e.g. from its progress callback: the
    call's set-up then lies behind it).  Returns (the ComputationInterrupted raised, the
    time it was caught, the time the signal was sent, both ``time.time()``); fails if the
    call finished or a plain KeyboardInterrupt escaped it.

    In process, not in a child: a child spent ~1 CPU-s importing the packages and loading
    the kernels before its "ready" (the suite's process has both), and the kernels see the
    signal the same way (the handler of ``defer_ctrl_c`` runs in the main thread wherever
    SIGINT comes from).  After the call a late signal ends nothing: the handler is a no-op
    until the thread is gone."""
    import os
    import signal
    import threading
    import time

    from kapitza.results import ComputationInterrupted
    started = after if after is not None else threading.Event()
    if after is None:
        started.set()
    done = threading.Event()
    sent = []

    def fire():
        started.wait()
        if not done.wait(delay):
            sent.append(time.time())
            os.kill(os.getpid(), signal.SIGINT)

    old = signal.signal(signal.SIGINT, signal.default_int_handler)
    thread = threading.Thread(target=fire, daemon=True)
    outcome = "the call finished: it was never interrupted"
    try:
        try:
            thread.start()
            call()
        except ComputationInterrupted as e:
            outcome = (e, time.time())
        finally:
            signal.signal(signal.SIGINT, lambda signum, frame: None)
            done.set()
            started.set()
            thread.join()
    except KeyboardInterrupt:
        outcome = "a plain KeyboardInterrupt, not ComputationInterrupted"
    finally:
        signal.signal(signal.SIGINT, old)
    assert isinstance(outcome, tuple), outcome
    return outcome[0], outcome[1], sent[0]
