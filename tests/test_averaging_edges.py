"""Edges of the averaging machinery (issue 10): the averaging window beyond its search range,
memory of large sweeps, the mean drag torque of a two-phase damped drive.

References: scipy.special.mathieu_b (the exact parametric-resonance edge), direct
simulation with lagrange_core, and the closed forms stated in shared/PHYSICS.md.
"""
import math
import warnings

import numpy as np
import pytest
from scipy.optimize import brentq
from scipy.special import mathieu_b

from kapitza import averaging as av
from kapitza.closed_forms import _pendulum as pcf
from kapitza.closed_forms import pendulum_window

from helpers import G, ctrl_c_in_process

# -- item 4: the averaging window ------------------------------------------------------------

def test_window_upper_edge_is_the_resonance_at_any_frequency():
    """The order-2 upper edge solves a = b₁(2A/l) wherever the root lies; it used to stop at
    the search limit q = 2.5 (A_max = 0.375 m for l = 0.3 m at every low ω, below A_min)."""
    l = 0.3
    w0 = math.sqrt(G / l)
    omegas = np.array([5.0, 0.8 * w0, 1.2 * w0, 1.6 * w0, 8 * w0])
    win = pendulum_window(omegas, method="averaging", l=l, g=G)
    for i, om in enumerate(omegas):
        a = -4 * G / (l * om**2)
        q_hi = brentq(lambda q, a=a: mathieu_b(1, q) - a, 0.1, 60.0, xtol=1e-14)
        assert win.A_max[i] == pytest.approx(q_hi * l / 2, rel=1e-6)
    assert len(set(np.round(win.A_max, 9))) == len(omegas)
    # never crossed edges without saying so: a window, or NaN edges with exists False
    assert np.all(win.exists == (win.A_min < win.A_max))
    assert np.all(np.isnan(win.A_min[~win.exists]) & np.isnan(win.A_max[~win.exists]))


def test_window_carries_validity_flags():
    l = 0.3
    w0 = math.sqrt(G / l)
    omegas = np.array([0.8, 3.0, 10.0, 100.0]) * w0
    win = pendulum_window(omegas, method="averaging", l=l, g=G)
    np.testing.assert_allclose(win.frequency_ratio, omegas / w0)
    np.testing.assert_array_equal(win.fast_drive, [False, False, True, True])
    np.testing.assert_array_equal(win.small_amplitude, win.A_min / l <= av.MAX_AMPLITUDE_RATIO)
    np.testing.assert_array_equal(win.valid, [False, False, True, True])
    # the error estimate is the order-1 edge's distance from the order-2 edge
    first = pendulum_window(omegas, method="averaging", l=l, g=G, order=1)
    np.testing.assert_allclose(win.error_estimate, np.abs(first.A_min / win.A_min - 1), rtol=1e-12)
    assert np.all(np.isinf(first.A_max)) and np.all(first.exists)
    np.testing.assert_array_equal(first.valid, [False, False, True, True])
    # the damping rate counts among the slow rates
    damped = pendulum_window(100 * w0, method="averaging", l=l, g=G, damping=30 * w0,
                             warn=False)
    assert damped.fast_drive is False and damped.valid is False
    # scalar: a warning names the reason; arrays only set the flags
    with pytest.warns(av.AveragingValidityWarning, match="× max"):
        pendulum_window(0.8 * w0, method="averaging", l=l, g=G)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        pendulum_window(100 * w0, method="averaging", l=l, g=G)
        pendulum_window(omegas, method="averaging", l=l, g=G)
        # no gravity to overcome
        weightless = pendulum_window(omegas, method="averaging", l=l, g=0.0)
    assert np.all(weightless.A_min == 0) and np.all(weightless.valid)


# -- item 9: memory of large array calls ------------------------------------------------------

_MEMORY_PROBE = """
import resource, sys
import numpy as np
from kapitza.closed_forms import _pendulum as pcf
A = np.linspace(0.001, 0.2, {n})
before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
out = pcf.pendulum_averaged(A, 200.0, order=2, warn=False)
peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
kept = sum(v.nbytes for e in out.equilibria for v in vars(e).values() if isinstance(v, np.ndarray))
print((peak - before) * 1024, kept)
"""


def test_large_array_call_works_in_bounded_memory():
    """10⁶ points: beyond the result itself (≈ 240 bytes a point), the call's temporaries
    stay below 80 MB (they were ≈ 150 MB at 10⁶ points, 1.4 GB at 10⁷: every field of every
    equilibrium was computed on the whole array at once)."""
    import subprocess
    import sys
    probe = subprocess.run([sys.executable, "-c", _MEMORY_PROBE.format(n=1_000_000)],
                           capture_output=True, text=True, check=True)
    grown, kept = map(int, probe.stdout.split())
    assert kept > 200e6                         # the result is all there
    assert grown - kept < 80e6


@pytest.mark.parametrize("drive, order", [("vertical", 2), ("vertical", 1), ("horizontal", 1)])
def test_chunked_results_equal_unchunked(monkeypatch, drive, order):
    A = np.linspace(0.0, 0.4, 37)[:, None]
    w = np.geomspace(1.0, 400.0, 101)[None, :]
    whole = pcf.pendulum_averaged(A, w, damping=0.7, drive=drive, order=order, warn=False)
    monkeypatch.setattr(pcf, "CHUNK_POINTS", 1000)     # 37 × 101 points: 4 chunks
    chunked = pcf.pendulum_averaged(A, w, damping=0.7, drive=drive, order=order, warn=False)
    assert [e.name for e in chunked.equilibria] == [e.name for e in whole.equilibria]
    for a, b in zip(whole.equilibria, chunked.equilibria, strict=True):
        for field, value in vars(a).items():
            assert np.shape(getattr(b, field)) == np.shape(value)
            np.testing.assert_array_equal(getattr(b, field), value, err_msg=f"{a.name}.{field}")


# -- item 5: the mean drag torque of a damped two-phase drive ---------------------------------

def _elliptic_pendulum():
    """The pendulum on a pivot moving as x = A cos ωt, y = B sin ωt (PHYSICS.md), damped by
    the dissipation function ½ m l² γ θ̇² (θ̈ = −γ θ̇ − …)."""
    import sympy as sp

    from lagrange_core import Particle, System, coordinates, t
    (th,), (thd,) = coordinates("theta")
    m, l, g, A, B, w, gam = sp.symbols("m l g A B omega gamma", positive=True)
    bob = Particle(m, (A * sp.cos(w * t) + l * sp.sin(th), B * sp.sin(w * t) - l * sp.cos(th)))
    return System([th], particles=[bob], potential=m * g * bob.position[1],
                  dissipation=m * l**2 * gam * thd**2 / 2, name="elliptic pivot (damped)")


@pytest.fixture(scope="module")
def elliptic():
    return _elliptic_pendulum()


def test_elliptic_drive_drag_torque_closed_form(elliptic):
    """D = m γ ω A B / 2 (first order in γ/ω; the exact 1-DOF fast response gives
    m γ ω A B / (2 (1 + γ²/ω²))); none without damping or with one phase."""
    avg = av.average(elliptic)
    P = dict(m=0.3, l=0.7, g=G, A=0.02, B=0.03, omega=120.0, gamma=4.0)
    for th in (0.0, 0.4, 2.0):
        assert avg.mean_drag(P, [th])[0] == pytest.approx(0.3 * 4.0 * 120.0 * 0.02 * 0.03 / 2,
                                                          rel=1e-12)
    assert avg.mean_drag({**P, "gamma": 0.0}, [0.3])[0] == 0.0
    assert avg.mean_drag({**P, "B": 0.0}, [0.3])[0] == 0.0
    # the tilted hanging state: m g l sin θ + m ω² (B² − A²) sin θ cos θ / 2 = m γ ω A B / 2
    hanging = min(avg.equilibria(P), key=lambda q: abs(q[0]))[0]
    resid = (G * 0.7 * math.sin(hanging) + 120.0**2 * (0.03**2 - 0.02**2)
             * math.sin(hanging) * math.cos(hanging) / 2 - 4.0 * 120.0 * 0.02 * 0.03 / 2)
    assert abs(resid) < 1e-10
    modes = avg.slow_modes(P, [hanging])
    assert modes.stable and modes.valid


@pytest.mark.parametrize("sense", [1.0, -1.0])
def test_elliptic_drive_tilt_against_direct_simulation(elliptic, sense):
    """The hanging pendulum tilts to sin θ = γ ω A B / (2 g l), toward the side the pivot
    turns to: B > 0 turns the pivot counterclockwise (from (A, 0) towards +y), and the
    pendulum leans to θ > 0 (the bob at +x); B < 0 (clockwise), θ < 0.  Direct
    simulation: the mean of θ over the last 40 drive periods of 200, after the transient
    (e^(−γt/2)) has decayed."""
    avg = av.average(elliptic)
    A, B, w, gam, l = 0.05, sense * 0.05, 100.0, 2.0, 1.0
    P = dict(m=1.0, l=l, g=G, A=A, B=B, omega=w, gamma=gam)
    closed = math.asin(gam * w * A * B / (2 * G * l))
    averaged = min(avg.equilibria(P), key=lambda q: abs(q[0]))[0]
    assert averaged == pytest.approx(closed, rel=1e-12)          # circle: no ω²(B²−A²) term
    T = 2 * math.pi / w
    t_end = 200 * T
    t_eval = np.linspace(t_end - 40 * T, t_end, 40 * 64 + 1)
    traj = elliptic.simulate([closed], [0.0], (0.0, t_end), P, rtol=1e-10, t_eval=t_eval)
    mean = float(np.mean(np.asarray(traj.q)[:-1, 0]))
    assert np.sign(mean) == sense
    # relative corrections O(A²/l², ω0²/ω², γ²/ω²) ≈ 1e-3; measured 8e-4
    assert mean == pytest.approx(averaged, rel=3e-3)


def test_two_link_drag_against_direct_simulation():
    """The general formula (mass matrix and damping matrix depending on q): a double
    pendulum on the elliptic pivot, damped relative to the pivot (C = γ M(q) plus a joint
    damper).  Without the drag the averaged hanging state is θ = 0; with it both links
    lean by ≈ 0.09 and 0.05 rad, matched by the simulated period mean to 0.3 %."""
    import sympy as sp

    from lagrange_core import Particle, System, coordinates, t
    (a, b), (ad, bd) = coordinates("a b")
    m1, m2, l1, l2, g, A, B, w, gam, c = sp.symbols("m1 m2 l1 l2 g A B omega gamma c",
                                                     positive=True)
    r1 = (A * sp.cos(w * t) + l1 * sp.sin(a), B * sp.sin(w * t) - l1 * sp.cos(a))
    r2 = (r1[0] + l2 * sp.sin(b), r1[1] - l2 * sp.cos(b))
    v1 = (l1 * sp.cos(a) * ad, l1 * sp.sin(a) * ad)              # relative to the pivot
    v2 = (v1[0] + l2 * sp.cos(b) * bd, v1[1] + l2 * sp.sin(b) * bd)
    R = (gam * (m1 * (v1[0]**2 + v1[1]**2) + m2 * (v2[0]**2 + v2[1]**2)) / 2
         + c * (bd - ad)**2 / 2)
    chain = System([a, b], particles=[Particle(m1, r1), Particle(m2, r2)],
                   potential=g * (m1 * r1[1] + m2 * r2[1]), dissipation=R)
    avg = av.average(chain)
    P = dict(m1=1.0, m2=0.5, l1=1.0, l2=0.7, g=G, A=0.04, B=0.03, omega=150.0, gamma=3.0,
             c=0.4)
    hanging = min(avg.equilibria(P), key=lambda q: np.abs(q).sum())
    undamped = min(avg.equilibria({**P, "gamma": 0.0, "c": 0.0}), key=lambda q: np.abs(q).sum())
    np.testing.assert_allclose(undamped, 0.0, atol=1e-12)
    assert avg.slow_modes(P, hanging).valid
    T = 2 * math.pi / P["omega"]
    t_end = 400 * T                             # slowest decay 1.5/s: the transient is e^-25
    t_eval = np.linspace(t_end - 40 * T, t_end, 40 * 64 + 1)
    traj = chain.simulate(hanging, [0.0, 0.0], (0.0, t_end), P, rtol=1e-10, t_eval=t_eval)
    mean = np.asarray(traj.q)[:-1].mean(axis=0)
    np.testing.assert_allclose(mean, hanging, rtol=3e-3)       # measured 2.3e-3, 1.1e-3


# -- item 8 (averaging): progress and Ctrl-C on long array calls ------------------------------

def test_long_array_call_reports_progress_and_is_quiet_off_terminal(capsys):
    A = np.linspace(0.0, 0.2, 3 * pcf.CHUNK_POINTS + 17)
    seen = []
    out = pcf.pendulum_averaged(A, 300.0, order=2, warn=False,
                                progress=lambda done, total: seen.append((done, total)))
    assert seen[-1] == (A.size, A.size) and len(seen) >= 2
    assert all(d1 < d2 for (d1, _), (d2, _) in zip(seen, seen[1:], strict=False))
    whole = pcf.pendulum_averaged(A, 300.0, order=2, warn=False, progress=False)
    np.testing.assert_array_equal(out.inverted.omega_squared, whole.inverted.omega_squared)
    pcf.pendulum_averaged(A, 300.0, order=2, warn=False)      # stderr is not a terminal here
    assert capsys.readouterr().err == ""
    with pytest.raises(ValueError, match="progress must be"):
        pcf.pendulum_averaged(0.1, 300.0, progress="yes")


def test_ctrl_c_keeps_the_finished_points():
    """Ctrl-C (here raised from the progress callback, between chunks) raises a
    KeyboardInterrupt carrying the finished part: the first points in flat order, equal
    to the full call's; ``computed`` marks them on the grid."""
    from kapitza.results import ComputationInterrupted
    A = np.linspace(0.0, 0.2, 4 * pcf.CHUNK_POINTS).reshape(4, -1)
    w = np.array([[200.0], [300.0], [400.0], [500.0]])

    def stop(done, total):
        if done < total:
            raise KeyboardInterrupt
    with pytest.raises(ComputationInterrupted) as info:
        pcf.pendulum_averaged(A, w, order=2, warn=False, progress=stop)
    assert isinstance(info.value, KeyboardInterrupt)
    part, computed = info.value.result, info.value.computed
    assert computed.shape == A.shape and 0 < computed.sum() < A.size
    done = int(computed.sum())
    assert np.all(computed.ravel()[:done]) and not np.any(computed.ravel()[done:])
    np.testing.assert_array_equal(part.A, A.ravel()[:done])
    np.testing.assert_array_equal(part.omega, np.broadcast_to(w, A.shape).ravel()[:done])
    whole = pcf.pendulum_averaged(A, w, order=2, warn=False)
    for a, b in zip(whole.equilibria, part.equilibria, strict=True):
        for field, value in vars(a).items():
            if field != "name":
                np.testing.assert_array_equal(getattr(b, field), np.ravel(value)[:done])


def test_ctrl_c_stops_a_long_call_within_a_second():
    """A real SIGINT into a 10⁷-point call (0.3 s after its first chunk): the exception
    arrives within a second, with the chunks finished.

    In this process, not a child (which spent 0.8 CPU-s importing kapitza before the
    call): :func:`helpers.ctrl_c_in_process`.  The call's temporaries and the kept part
    take ≈ 250 MB, freed on return."""
    import threading

    A = np.linspace(0.0, 0.2, 10_000_000)
    # compiled (or loaded) before the signal: the call below, order 2 (on an empty cache an
    # order-1 call here left order 2's kernels to compile through the Ctrl-C: nothing kept)
    pcf.pendulum_averaged(A[:10], 300.0, order=2, warn=False)
    started = threading.Event()     # the first chunk reported: the call's set-up (~0.5 s
    #                                 for 10⁷ points, more on a loaded machine) is behind it
    e, t, sent = ctrl_c_in_process(
        lambda: pcf.pendulum_averaged(A, 300.0, order=2, warn=False,
                                      progress=lambda d, total: d and started.set()),
        0.3, after=started)
    assert t - sent < 1.0 and int(e.computed.sum()) > 0


def test_general_sweep_progress_and_ctrl_c():
    from kapitza.pendulum import KapitzaPendulum
    from kapitza.results import ComputationInterrupted
    from lagrange_core import problems
    avg = av.average(problems.driven_pendulum("vertical"))
    base = KapitzaPendulum().params(0.1, 200.0)
    params = {**base, "A": np.linspace(0.02, 0.1, 300).reshape(3, 100)}
    seen = []
    whole = avg.sweep(params, [math.pi], progress=lambda d, t: seen.append((d, t)))
    assert seen[-1] == (300, 300)
    # the closed form Ω² = A²ω²/(2l²) − g/l (PHYSICS.md) at every point
    np.testing.assert_allclose(whole.omega_squared[..., 0],
                               params["A"]**2 * 200.0**2 / 2 - base["g"], rtol=1e-10)

    def stop(done, total):
        raise KeyboardInterrupt
    with pytest.raises(ComputationInterrupted) as info:
        avg.sweep(params, [math.pi], progress=stop)
    part, computed = info.value.result, info.value.computed
    assert computed.shape == (3, 100) and 0 < computed.sum() < 300
    np.testing.assert_array_equal(part.omega_squared[computed], whole.omega_squared[computed])
    assert np.all(np.isnan(part.omega_squared[~computed]))
    assert not np.any(part.stable[~computed] | part.valid[~computed])
    np.testing.assert_array_equal(part.stable[computed], whole.stable[computed])
