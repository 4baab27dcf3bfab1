"""Hard-case audit: every hard case the tests cover, its error or drift measured again, and the
bound its test asserts.

The test suite guards the toolkit's hard cases — stiff or near-singular statements, long
integrations, drives 10³ times the natural frequency, chaotic double pendulums, symplectic
and non-symplectic energy errors, constraint drift, Mathieu characteristic values where
scipy fails, Floquet analysis at huge and vanishing drives.  Each test asserts a bound.
This study recomputes the quantity each bound guards, with the test's own set-up, and
shows how much room is left: the margin bound / measured.  A margin near 1 is a test on
the edge of failing (or a bound drawn tight on purpose); a margin of 10⁶ is a bound that
guards little.

The bounds are *stated here*, each with the test it comes from (``tests/file.py::name``):
nothing is parsed from the tests, so a test whose bound changes shows up as a
disagreement to be reconciled, not silently followed.

Size: the full run recomputes every case at its test's size.  ``quick=True`` (the test
suite) runs the cheap cases, some at a stated smaller size (fewer periods: a drift bound
over a long run holds a fortiori over its start).
"""

import math
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from _common import layout, main, save_figure, write_table

QUESTION = ("How far inside its asserted bound is each hard case the tests cover — the "
            "error or drift measured again beside the bound, as a margin?")

G = 9.81


@dataclass(frozen=True)
class Case:
    """One hard case: what is measured and the bound its test asserts."""
    label: str             # short, for the figure
    test: str              # tests/<file>.py::<test>
    quantity: str          # what the number is
    bound: float           # the test's bound on ``quantity``
    run: Callable          # run(quick) -> (measured, size): the quantity and the size it ran at
    quick: bool = True     # in the quick subset
    # several rows from one computation share a cached ``run`` (see _shared)


def _shared(fn):
    """Cache a computation per ``quick`` so the cases that read different numbers from one
    run do not repeat it."""
    memo = {}

    def wrapped(quick):
        if quick not in memo:
            memo[quick] = fn(quick)
        return memo[quick]
    return wrapped


# -- tests/test_hard_cases.py -------------------------------------------------------------

def chaotic_energy(quick):
    from lagrange_core import problems
    s = problems.double_pendulum()
    P = dict(g=G, l1=1.0, l2=1.0, m1=1.0, m2=1.0)
    T0 = 2 * math.pi * math.sqrt(P["l1"] / P["g"])
    n = 3e2 if quick else 1e4
    tr = s.simulate([2.0, 2.0], [0.0, 0.0], (0.0, n * T0), P, method="dop853", rtol=1e-13,
                    stride=500)
    assert tr.status == "success" and np.max(np.abs(tr.q[:, 1])) > 10 * math.pi
    return float(np.max(np.abs(tr.energy - tr.energy[0])) / abs(tr.energy[0])), \
        f"{n:.0e} periods, rtol 1e-13"


N_BEADS, STRING = 200, dict(F=80.0, mu=0.005, l=0.65)


@_shared
def bead_string(quick):
    from lagrange_core import problems
    system = problems.bead_string(N_BEADS)
    N, F, mu, l = N_BEADS, STRING["F"], STRING["mu"], STRING["l"]
    h = l / (N + 1)
    k = np.arange(1, N + 1)
    w = system.normal_modes(STRING)
    exact = 2 * math.sqrt(F / (mu * h**2)) * np.sin(k * np.pi / (2 * (N + 1)))
    modes = float(np.max(np.abs(w / exact - 1)))
    low = k[:5]
    rel = 1 - w[:5] / (low * math.pi * math.sqrt(F / mu) / l)
    harmonic = float(np.max(rel / ((low * np.pi / (N + 1)) ** 2 / 24)))
    x = k * h
    amp = 1e-5 * l
    y0 = amp * np.sin(np.pi * x / l)
    tr = system.simulate(y0, np.zeros(N), (0.0, 2 * math.pi / exact[0]), STRING,
                         method="dop853", rtol=1e-9, atol=1e-9 * amp)
    energy = float(np.max(np.abs(tr.energy - tr.energy[0])) / tr.energy[0])
    back = float(np.max(np.abs(tr.q[-1] - y0)) / amp)
    return dict(modes=modes, harmonic=harmonic, energy=energy, back=back)


@_shared
def kepler(quick):
    from lagrange_core import problems
    from lagrange_core.integrate import turning_point
    s = problems.central_force()
    m, k, a, e = 2.0, 3.0, 1.0, 0.99
    T = 2 * math.pi * math.sqrt(m * a**3 / k)
    ra = a * (1 + e)
    L = math.sqrt(m * k * a * (1 - e**2))
    tr = s.simulate([ra, 0.0], [0.0, L / (m * ra**2)], (0.0, 5 * T), dict(m=m, k=k),
                    rtol=1e-11, events=[turning_point("r", direction=1)])
    times = tr.event_times()
    return dict(
        times=float(np.max(np.abs(times - T * (np.arange(5) + 0.5))) / T),
        radius=float(max(abs(ev.q[0] / (a * (1 - e)) - 1) for ev in tr.events)),
        energy=float(np.max(np.abs(tr.energy / (-k / (2 * a)) - 1))),
        momentum=float(np.max(np.abs(m * tr.q[:, 0] ** 2 * tr.qdot[:, 1] / L - 1))))


@_shared
def omega_ratio_1e3(quick):
    import scipy.integrate

    from lagrange_core import problems
    s = problems.driven_pendulum("vertical")
    g, l = G, 1.0
    omega, A = 1e3 * math.sqrt(g / l), 0.01 * l
    P = dict(m=1.0, g=g, l=l, A=A, omega=omega)
    Td = 2 * math.pi / omega
    th0 = math.pi - 0.05
    t_check = np.linspace(0.0, 200 * Td, 11)
    ours = s.simulate([th0], [0.0], (0.0, t_check[-1]), P, rtol=1e-11, t_eval=t_check)

    def rhs(t, y):
        return [y[1], -(g - A * omega**2 * math.cos(omega * t)) * math.sin(y[0]) / l]

    if quick:
        # Hairer's Fortran DOP853 (scipy.integrate.ode), solve_ivp's "DOP853" method at the
        # same tolerances without its Python driver's per-step cost (as the test does since
        # 92a024a), stopped at each check time: 0.04 CPU-s where solve_ivp took 0.26; the
        # two references differ by 1.4e-13 rad, far inside the bound 1e-10 (measured: 1.7e-12
        # either way).  The full run keeps solve_ivp, so its findings are unchanged.
        ode = scipy.integrate.ode(rhs).set_integrator("dop853", rtol=1e-12, atol=1e-12,
                                                      nsteps=10**6)
        ode.set_initial_value([th0, 0.0], 0.0)
        ref = np.array([th0] + [ode.integrate(tk)[0] for tk in t_check[1:]])
        if not ode.successful():
            raise RuntimeError("scipy's DOP853 (ode) failed on the ω/ω0 = 10³ reference")
    else:
        ref = scipy.integrate.solve_ivp(rhs, (0.0, t_check[-1]), [th0, 0.0], method="DOP853",
                                        rtol=1e-12, atol=1e-12, t_eval=t_check).y[0]
    scipy_diff = float(np.max(np.abs(ours.q[:, 0] - ref)))
    Omega = math.sqrt(A**2 * omega**2 / (2 * l**2) - g / l)
    n_periods = int(8 * 2 * math.pi / Omega / Td)
    t_eval = np.arange(n_periods * 32 + 1) * (Td / 32)
    tr = s.simulate([th0], [0.0], (0.0, t_eval[-1]), P, rtol=1e-10, t_eval=t_eval)
    dev = tr.q[:, 0] - math.pi
    slow = dev[:-1].reshape(n_periods, 32).mean(axis=1)
    t_mid = (np.arange(n_periods) + 0.5) * Td
    return dict(scipy=scipy_diff, band=float(np.max(np.abs(dev))),
                slow=float(np.max(np.abs(slow + 0.05 * np.cos(Omega * t_mid))) / 0.05))


@_shared
def wedge(quick):
    from lagrange_core import problems
    free, held = problems.block_on_wedge(), problems.block_on_wedge(normal_coordinate=True)
    m, M = 0.6, 2.3
    acc, path = 0.0, 0.0
    for alpha in (1e-8, 1e-4, math.pi / 2 - 1e-4, math.pi / 2 - 1e-8):
        P = dict(m=m, M=M, alpha=alpha, g=G)
        D = M + m * math.sin(alpha) ** 2
        Xdd = -m * G * math.sin(alpha) * math.cos(alpha) / D
        sdd = (M + m) * G * math.sin(alpha) / D
        N = M * m * G * math.cos(alpha) / D
        a = free.accelerations([0.0, 0.0], [0.0, 0.0], params=P)
        a2, lam = held.accelerations([0.0, 0.0, 0.0], [0.0, 0.0, 0.0], params=P)
        acc = max(acc, abs(a[0] / Xdd - 1), abs(a[1] / sdd - 1), abs(a2[0] / Xdd - 1),
                  abs(a2[1] / sdd - 1), abs(lam[0] / N - 1))
        t_eval = np.linspace(0.0, 1.0, 5)
        tr = held.simulate([0, 0, 0], [0, 0, 0], (0.0, 1.0), P, t_eval=t_eval)
        te = t_eval[1:]
        path = max(path, float(np.max(np.abs(tr.q[1:, 0] / (Xdd * te**2 / 2) - 1))),
                   float(np.max(np.abs(tr.q[1:, 1] / (sdd * te**2 / 2) - 1))),
                   float(np.max(np.abs(tr.multipliers[:, 0] / N - 1))))
    return dict(acc=float(acc), path=float(path))


# -- tests/test_batch_physics.py ----------------------------------------------------------

PEND = dict(m=1.0, l=1.0, g=G)
UP_BAND = ([math.pi / 2], [3 * math.pi / 2])


def inside_window(quick):
    from kapitza import KapitzaPendulum
    from lagrange_core import problems
    pend = problems.driven_pendulum("vertical")
    w = 2 * math.pi * 20
    win = KapitzaPendulum().window(w)
    A = np.array([1.5 * win.A_min, 0.5 * (win.A_min + win.A_max), 0.9 * win.A_max])
    g = pend.simulate_grid([math.pi - 0.02], [0.0], (0.0, 1e4 * 2 * math.pi / w),
                           dict(PEND, A=A, omega=w), band=UP_BAND, reference=[math.pi],
                           progress=False)
    assert (g.status == 0).all()
    return max(0.0, float(np.max(g.max_deviation[:, 0]) - 0.02)), "3 inside points, 1e4 periods"


@_shared
def batch_1e3(quick):
    from lagrange_core import problems
    pend = problems.driven_pendulum("vertical")
    w = 1000 * math.sqrt(G)
    T = 2 * math.pi / w
    n = 1e4 if quick else 1e5
    runs = [pend.simulate_grid([math.pi - 0.05], [0.0], (0.0, n * T),
                               dict(PEND, A=0.01, omega=w), strobe=100 * T, band=UP_BAND,
                               rtol=rtol, progress=False) for rtol in (1e-9, 1e-13)]
    assert all(r.status_name == "finished" for r in runs)
    return dict(strobe=float(np.nanmax(np.abs(runs[0].strobe_q - runs[1].strobe_q))),
                mean=float(abs(runs[0].q_mean[0] - math.pi)), size=f"{n:.0e} periods")


@_shared
def symplectic_1e6(quick):
    from lagrange_core import problems
    s = problems.pendulum()
    T0 = 2 * math.pi / math.sqrt(G)
    ends = np.array([1e3, 1e4]) if quick else np.array([1e5, 1e6])
    g = s.simulate_grid([1.0], [0.0], (0.0, ends * T0), dict(PEND), method="yoshida6",
                        h=T0 / 10, energy=True, progress=False)
    E = G * (1 - math.cos(1.0))
    d5, d6 = g.energy_drift
    return dict(drift=float(d6 / E), ratio=float(d6 / d5),
                size=f"{ends[0]:.0e} and {ends[1]:.0e} periods")


@_shared
def chaotic_grid(quick):
    from lagrange_core import problems
    s = problems.double_pendulum()
    P = dict(g=G, l1=1.0, l2=1.0, m1=1.0, m2=1.0)
    th = np.array([0.1, 2.5]) if quick else np.array([0.1, 1.5, 2.0, 2.5])
    q0 = np.stack(np.broadcast_arrays(th[:, None], th[None, :]), axis=-1)
    T0 = 2 * math.pi
    g = s.simulate_grid(q0, [0.0, 0.0], (0.0, 100 * T0), P, rtol=1e-12, energy=True,
                        progress=False)
    assert (g.status == 0).all()
    E = np.array([[s.kernels.energy(q0[i, j], np.zeros(2), 0.0, s.parameter_array(P))
                   for j in range(th.size)] for i in range(th.size)])
    ref = s.simulate(q0[0, 0], [0.0, 0.0], (0.0, 100 * T0), P, rtol=1e-13)
    return dict(energy=float(np.max(g.energy_drift / np.abs(E))),
                corner=float(np.max(np.abs(g.q[0, 0] - ref.q[-1]))),
                size=f"{th.size}×{th.size} grid, 100 periods")


# -- tests/test_integrate.py ----------------------------------------------------------------

PEND_I = dict(g=G, l=1.3, m=0.5)


def _pendulum_period(theta0=2.0):
    from scipy.special import ellipk
    return 4 * ellipk(math.sin(theta0 / 2) ** 2) / math.sqrt(PEND_I["g"] / PEND_I["l"])


@_shared
def symplectic_bounded(quick):
    """The test's envelope check: 10⁴ periods at h = T/20.37 (incommensurate with the
    period, every step sampled), growth = max|ΔE| of the last tenth / first tenth − 1."""
    from lagrange_core import problems
    s = problems.pendulum()
    T = _pendulum_period()
    tr = s.simulate([2.0], [0.0], (0.0, 1e4 * T), PEND_I, method="yoshida6", h=T / 20.37)
    dE = np.abs(tr.energy - tr.energy[0]) / abs(tr.energy[0])
    first, last = dE[: len(dE) // 10].max(), dE[-len(dE) // 10:].max()
    return dict(max=float(dE.max()), growth=float(abs(last / first - 1)))


def _cartesian_pendulum():
    import sympy as sp

    from lagrange_core import Particle, System
    x, y = sp.symbols("x y", real=True)
    m, g, l = sp.symbols("m g l", positive=True)
    return System([x, y], particles=[Particle(m, (x, y))], potential=m * g * y,
                  constraints=[x**2 + y**2 - l**2], name="cartesian pendulum")


@_shared
def cartesian(quick):
    from lagrange_core import problems
    th0, l = 1.2, PEND_I["l"]
    t_eval = np.linspace(0.0, 8.0, 81)
    tr = _cartesian_pendulum().simulate([l * math.sin(th0), -l * math.cos(th0)], [0.0, 0.0],
                                        (0.0, 8.0), PEND_I, method="dop853", rtol=1e-11,
                                        atol=1e-11, t_eval=t_eval)
    ref = problems.pendulum().simulate([th0], [0.0], (0.0, 8.0), PEND_I, method="dop853",
                                       rtol=1e-12, atol=1e-12, t_eval=t_eval)
    theta = np.arctan2(tr.q[:, 0], -tr.q[:, 1])
    return dict(angle=float(np.max(np.abs(theta - ref.q[:, 0]))),
                residual=float(np.max(tr.constraint_residual)))


# -- tests/test_floquet.py, test_floquet_edges.py --------------------------------------------

@_shared
def mathieu_large_q(quick):
    import scipy.linalg
    import scipy.special

    from kapitza import closed_forms as mm
    K = 80
    d = (2 * np.arange(K) + 1.0) ** 2
    d[0] += 20.9
    ref = scipy.linalg.eigvalsh_tridiagonal(d, np.full(K - 1, 20.9))[2]
    a5 = abs(mm.characteristic_value("a", 5, 20.9) / ref - 1)
    scipy_err = abs(scipy.special.mathieu_a(5, 20.9) - ref)
    worst = 0.0
    for q in (40.0, 90.0):
        d = (2.0 * np.arange(K)) ** 2
        e = np.full(K - 1, q)
        e[0] *= math.sqrt(2)
        ref = scipy.linalg.eigvalsh_tridiagonal(d, e)[:3]
        got = np.array([mm.characteristic_value("a", r, q) for r in (0, 2, 4)])
        worst = max(worst, float(np.max(np.abs(got - ref) / (1e-12 / 1e-13 + np.abs(ref)))))
    # the test asserts |got − ref| ≤ 1e-12 + 1e-13 |ref|: as a relative error with that floor
    series_q = np.array([1e-6, 1e-4, 1e-3, 1e-2])
    series = -series_q**2 / 2 + 7 * series_q**4 / 128 - 29 * series_q**6 / 2304
    small = float(np.max(np.abs(mm.characteristic_value("a", 0, series_q) / series - 1)))
    return dict(a5=float(a5), large=worst, small=small, scipy=float(scipy_err))


@_shared
def huge_amplitude(quick):
    from kapitza import closed_forms as mm
    from kapitza.pendulum import KapitzaPendulum
    pend = KapitzaPendulum(l=1.0, g=G)
    worst = 0.0
    for A, w in ((1e3, 0.5), (1e3, 60.0), (1e4, 2.0), (1e4, 10.0)):
        r = pend.floquet(A, w)
        a, q, _ = mm.mathieu_parameters(A, w, 1.0, G, 0.0, "inverted")
        _, log_tr, _ = mm.mathieu_monodromy_trace(a, q, tol=1e-12)
        assert not r.stable
        worst = max(worst, abs(r.log_growth / float(log_tr) - 1))
    return float(worst), "4 points, A up to 1e4 m"


def slow_drive(quick):
    from kapitza.pendulum import KapitzaPendulum
    gam = 0.3
    m = KapitzaPendulum(l=1.0, g=G, damping=gam).stability_map([0.1], [1e-3], progress=False)
    rate = -gam / 2 + math.sqrt(gam**2 / 4 + G)
    return float(abs(m.log_growth[0, 0] / (rate * 2 * math.pi / 1e-3) - 1)), "ω = 1e-3 rad/s"


def triple_edge(quick):
    """The upright triple pendulum 1e-9 below its window edge: the growth per period
    (≈ 5.7e-6) from floquet_point against solve_ivp on the compiled Jacobian (the test's
    reference, tests/helpers.py)."""
    import sympy as sp
    from scipy.integrate import solve_ivp

    import kapitza
    from lagrange_core import problems
    from lagrange_core import t as t_sym
    A_s, w_s = sp.symbols("A omega", positive=True)
    triple = problems.n_link_pendulum(3, pivot=(0, A_s * sp.cos(w_s * t_sym)))
    TP = {"g": G, "l1": 1.0, "l2": 1.0, "l3": 1.0, "m1": 1.0, "m2": 1.0, "m3": 1.0}
    A = 0.068706532019068 * (1 - 1e-9)
    params = dict(TP, A=A, omega=100.0)
    r = kapitza.floquet_point(triple, params, [math.pi] * 3)
    k = triple.kernels
    P = triple.parameter_array(params)
    ystar = np.concatenate([np.full(3, math.pi), np.zeros(3)])
    J = np.empty((6, 6))

    def f(tt, y):
        k.jacobian(tt, ystar, P, J)
        return (J @ y.reshape(6, 6)).ravel()
    sol = solve_ivp(f, (0.0, 2 * math.pi / 100.0), np.eye(6).ravel(), method="DOP853",
                    rtol=1e-12, atol=1e-13)
    lam = np.linalg.eigvals(sol.y[:, -1].reshape(6, 6))
    ref = math.log(np.max(np.abs(lam)))
    return float(abs(r.log_growth / ref - 1)), "A = edge × (1 − 1e-9)"


# -- tests/test_averaging_edges.py, test_pendulum_edges.py, test_measure.py ----------------

def elliptic_tilt(quick):
    """Damped circular pivot (A = B = 5 cm, ω = 100/s, γ = 2/s): the period mean of θ over
    the last 40 of 200 drive periods against sin θ = γωAB/(2gl).  The system is the
    shipped scene's (kapitza/scenes/elliptic_damped.toml), the test states its own."""
    from kapitza import Scene
    scene = Scene.example("elliptic_damped")
    A, B, w, gam = 0.05, 0.05, 100.0, 2.0
    P = dict(scene.params, A=A, B=B, omega=w, gamma=gam, l=1.0)
    closed = math.asin(gam * w * A * B / (2 * G * 1.0))
    T = 2 * math.pi / w
    t_eval = np.linspace(160 * T, 200 * T, 40 * 64 + 1)
    tr = scene.system.simulate([closed], [0.0], (0.0, 200 * T), P, rtol=1e-10, t_eval=t_eval)
    return float(abs(np.mean(tr.q[:-1, 0]) / closed - 1)), "200 periods"


def rod(quick):
    from kapitza import KapitzaPendulum
    from lagrange_core import problems
    L_ROD, m = 0.9, 2.0
    body_sys = problems.physical_pendulum(driven=True)
    A, omega = 0.04, 2 * math.pi * 50
    t_eval = np.linspace(0.0, 2.0, 41)
    ours = KapitzaPendulum.rod(L_ROD, g=G).simulate(A, omega, math.pi - 0.2, 0.0, (0.0, 2.0),
                                                    rtol=1e-11, t_eval=t_eval)
    body = body_sys.simulate([math.pi - 0.2], [0.0], (0.0, 2.0),
                             dict(m=m, I_c=m * L_ROD**2 / 12, d=L_ROD / 2, g=G, A=A,
                                  omega=omega), rtol=1e-11, t_eval=t_eval)
    return float(np.max(np.abs(ours.q[:, 0] - body.q[:, 0]))), "2 s"


def undriven_double_energy(quick):
    import kapitza
    from lagrange_core import problems
    dp = problems.double_pendulum()
    P = dict(g=G, l1=1.0, l2=1.0, m1=1.0, m2=1.0)
    m = kapitza.measure_grid(dp, P, [0.0, 0.0], np.array([[1e-3, 0.0], [2e-3, 0.0]]),
                             frequency=15.0, periods=1000, rtol=1e-13, progress=False)
    return float(np.max(m.energy_drift)), "2 points, 1000 strobe periods"


def lanes_energy(quick):
    from lagrange_core import problems
    pe = problems.pendulum()
    g = pe.simulate_grid(np.linspace(0.2, 3.0, 9)[:, None], [0.0], (0.0, 20.0), dict(PEND),
                         method="rkn12-fixed", h=0.05, energy=True, progress=False)
    return float(np.max(g.energy_drift)), "9 points, 20 s, h = 0.05 s"


# -- the audit ------------------------------------------------------------------------------

def _pick(fn, key, size=None):
    """A case reading ``key`` from the shared computation ``fn``."""
    def run(quick):
        out = fn(quick)
        return out[key], out.get("size", size)
    return run


HC, BP, IN, FQ, FE = ("tests/test_hard_cases.py", "tests/test_batch_physics.py",
                      "tests/test_integrate.py", "tests/test_floquet.py",
                      "tests/test_floquet_edges.py")

CASES = [
    Case("chaotic double pendulum: energy", f"{HC}::test_chaotic_double_pendulum_conserves_"
         "energy_over_1e4_periods", "max |ΔE|/|E| (DOP853)", 1e-8, chaotic_energy),
    Case("200 beads: normal modes", f"{HC}::test_bead_string_200_normal_modes",
         "max |ω_k/ω_k,exact − 1|", 2e-12, _pick(bead_string, "modes", "N = 200"), quick=False),
    Case("200 beads: harmonic series", f"{HC}::test_bead_string_200_normal_modes",
         "max (1 − ω_k/kπc/l) / ((kπ/(N+1))²/24), k ≤ 5", 1.01,
         _pick(bead_string, "harmonic", "N = 200"), quick=False),
    Case("200 beads: energy", f"{HC}::test_bead_string_200_conserves_energy",
         "max |ΔE|/E over a period", 1e-12, _pick(bead_string, "energy", "1 period"),
         quick=False),
    Case("200 beads: return", f"{HC}::test_bead_string_200_conserves_energy",
         "|q(T) − q(0)| / amplitude", 1e-9, _pick(bead_string, "back", "1 period"),
         quick=False),
    Case("Kepler e = 0.99: perihelion times", f"{HC}::test_kepler_eccentricity_099_over_"
         "several_orbits", "max |t_n − (n+½)T| / T", 1e-9, _pick(kepler, "times", "5 orbits")),
    Case("Kepler e = 0.99: perihelion radius", f"{HC}::test_kepler_eccentricity_099_over_"
         "several_orbits", "max |r_p/(a(1−e)) − 1|", 1e-10, _pick(kepler, "radius", "5 orbits")),
    Case("Kepler e = 0.99: energy", f"{HC}::test_kepler_eccentricity_099_over_several_orbits",
         "max |E/E_exact − 1|", 1e-9, _pick(kepler, "energy", "5 orbits")),
    Case("Kepler e = 0.99: angular momentum", f"{HC}::test_kepler_eccentricity_099_over_"
         "several_orbits", "max |L/L_exact − 1|", 1e-10, _pick(kepler, "momentum", "5 orbits")),
    Case("ω/ω0 = 10³: vs scipy DOP853", f"{HC}::test_driven_pendulum_at_omega_ratio_1e3",
         "max |θ − θ_scipy| (rad)", 1e-10, _pick(omega_ratio_1e3, "scipy", "200 periods")),
    Case("ω/ω0 = 10³: stays in band", f"{HC}::test_driven_pendulum_at_omega_ratio_1e3",
         "max |θ − π| (rad)", 0.06, _pick(omega_ratio_1e3, "band", "1142 periods")),
    Case("ω/ω0 = 10³: slow motion vs averaging", f"{HC}::test_driven_pendulum_at_omega_"
         "ratio_1e3", "max |θ̄ − (π − a cos Ωt)| / a", 0.05,
         _pick(omega_ratio_1e3, "slow", "1142 periods")),
    Case("wedge near 0 and 90°: accelerations", f"{HC}::test_wedge_near_flat_and_vertical",
         "max relative error of Ẍ, s̈, N", 100 * 2.220446049250313e-16,
         _pick(wedge, "acc", "4 angles")),
    Case("wedge near 0 and 90°: 1 s run", f"{HC}::test_wedge_near_flat_and_vertical",
         "max relative error of X(t), s(t), N(t)", 1e-12, _pick(wedge, "path", "4 angles")),
    Case("inside the window: no growth", f"{BP}::test_inside_the_exact_window_stays_up_"
         "outside_falls", "max deviation − initial tilt (rad)", 2e-15, inside_window,
         quick=False),
    Case("grid ω/ω0 = 10³: strobe vs rtol 1e-13", f"{BP}::test_hard_case_drive_1000_times_"
         "the_natural_frequency", "max |Δθ| of strobe samples (rad)", 1e-7,
         _pick(batch_1e3, "strobe")),
    Case("grid ω/ω0 = 10³: time mean", f"{BP}::test_hard_case_drive_1000_times_the_natural_"
         "frequency", "|⟨θ⟩ − π| (rad)", 1e-3, _pick(batch_1e3, "mean")),
    Case("symplectic 10⁶ periods: energy", f"{BP}::test_hard_case_symplectic_energy_bounded_"
         "over_a_million_periods", "max |ΔE| / E (Yoshida 6)", 1e-3,
         _pick(symplectic_1e6, "drift")),
    Case("symplectic 10⁶ periods: no secular drift", f"{BP}::test_hard_case_symplectic_energy_"
         "bounded_over_a_million_periods", "max|ΔE|(10 t) / max|ΔE|(t)", 1.5,
         _pick(symplectic_1e6, "ratio")),
    Case("chaotic grid: energy", f"{BP}::test_hard_case_chaotic_double_pendulums_in_a_grid",
         "max energy drift / |E|", 2e-8, _pick(chaotic_grid, "energy")),
    Case("chaotic grid: regular corner", f"{BP}::test_hard_case_chaotic_double_pendulums_in_"
         "a_grid", "max |q − q_ref| (rad)", 1e-8, _pick(chaotic_grid, "corner")),
    Case("Yoshida 6, 10⁴ periods: energy", f"{IN}::test_symplectic_energy_error_bounded_not_"
         "drifting", "max |ΔE|/|E|", 1e-3, _pick(symplectic_bounded, "max", "1e4 periods")),
    Case("Yoshida 6, 10⁴ periods: envelope growth", f"{IN}::test_symplectic_energy_error_"
         "bounded_not_drifting", "|max|ΔE| last tenth / first tenth − 1| (drift: 9)", 1e-4,
         _pick(symplectic_bounded, "growth", "1e4 periods, h = T/20.37")),
    Case("Cartesian pendulum: constraint drift", f"{IN}::test_cartesian_pendulum_matches_"
         "angle_form_and_tension", "max |x² + y² − l²| residual", 2e-14,
         _pick(cartesian, "residual", "8 s")),
    Case("Cartesian pendulum: angle", f"{IN}::test_cartesian_pendulum_matches_angle_form_and_"
         "tension", "max |θ − θ_angle form| (rad)", 1e-8, _pick(cartesian, "angle", "8 s")),
    Case("Mathieu a₅(20.9) (scipy wrong)", f"{FQ}::test_characteristic_values_where_scipy_"
         "fails", "|a/a_tridiagonal − 1|", 1e-13, _pick(mathieu_large_q, "a5", "K = 80")),
    Case("Mathieu a₀,₂,₄ at q = 40, 90", f"{FQ}::test_characteristic_values_where_scipy_fails",
         "max |a − a_ref| / (10 + |a_ref|)", 1e-13, _pick(mathieu_large_q, "large", "K = 80")),
    Case("Mathieu a₀ at q = 1e-6…1e-2", f"{FQ}::test_a0_small_q_keeps_relative_accuracy",
         "max |a₀/series − 1|", 1e-13, _pick(mathieu_large_q, "small", "4 points")),
    Case("Floquet, huge amplitude", f"{FE}::test_huge_amplitude_growth_against_mathieu",
         "max |log growth / log|tr M| − 1|", 2e-12, huge_amplitude),
    Case("Floquet, ω = 1e-3 rad/s", f"{FE}::test_mathieu_map_at_extreme_slow_drives",
         "|log growth / closed form − 1|", 2e-14, slow_drive),
    Case("triple pendulum 1e-9 below its edge", f"{FE}::test_triple_pendulum_small_growth_is_"
         "unstable", "|log|λ| / log|λ|_solve_ivp − 1|", 1e-3, triple_edge, quick=False),
    Case("damped circular pivot: tilt", "tests/test_averaging_edges.py::test_elliptic_drive_"
         "tilt_against_direct_simulation", "|θ̄_simulated / θ_formula − 1|", 3e-3,
         elliptic_tilt),
    Case("rod vs rigid body", "tests/test_pendulum_edges.py::test_rod_motion_equals_the_rigid_"
         "body", "max |θ_l_eq − θ_body| (rad)", 5e-12, rod),
    Case("undriven double pendulum: energy", "tests/test_measure.py::test_undriven_double_"
         "pendulum_normal_modes_and_energy", "max energy drift (J)", 1e-12,
         undriven_double_energy, quick=False),
    Case("lanes: fixed-step energy", "tests/test_batch_speedpath.py::test_energy_drift_on_"
         "lanes", "max energy drift (J)", 1e-12, lanes_energy),
]

#: A measured value of exactly zero (rounding gave the exact answer) counts as one rounding
#: error (double precision's ε) for the margin, so the log-scale bar stays finite; the table
#: keeps the 0.
FLOOR = 2.2e-16


def _log(msg):
    print(f"hard_case_audit: {msg}", file=sys.stderr, flush=True)


def run(out: Path, quick: bool = False) -> dict:
    cases = [c for c in CASES if c.quick or not quick]
    rows = []
    for i, c in enumerate(cases, 1):
        t0 = time.perf_counter()
        measured, size = c.run(quick)
        seconds = time.perf_counter() - t0
        _log(f"[{i}/{len(cases)}] {c.label}: {measured:.3g} (bound {c.bound:g}, {seconds:.1f} s)")
        rows.append(dict(case=c.label, test=c.test, quantity=c.quantity, size=size,
                         measured=float(measured), bound=c.bound,
                         margin=c.bound / max(float(measured), FLOOR),
                         within=bool(measured <= c.bound), seconds=round(seconds, 2)))
    table = pd.DataFrame(rows)
    write_table(table, out, "hard_case_audit")
    save_figure(figure(table, quick), out, "hard_case_audit", quick=quick)
    (Path(out) / "hard_case_audit.md").write_text(markdown(table))
    tight = table.loc[table.margin.idxmin()]
    loose = table.loc[table.margin.idxmax()]
    return dict(cases=len(table), within_bound=int(table.within.sum()),
                min_margin=float(table.margin.min()), min_margin_case=str(tight.case),
                max_margin=float(table.margin.max()), max_margin_case=str(loose.case),
                median_margin=float(table.margin.median()),
                cases_margin_below_3=int((table.margin < 3).sum()),
                cases_margin_above_1e3=int((table.margin > 1e3).sum()))


def markdown(table) -> str:
    """The audit as a Markdown table (for studies/README.md)."""
    lines = ["| case | test | measured | bound | margin | size |", "|---|---|---|---|---|---|"]
    for r in table.itertuples():
        name = r.test.split("::")
        what = f"{r.case} ({r.quantity})".replace("|", "\\|")     # | would end the cell
        lines.append(f"| {what} | `{name[0].removeprefix('tests/')}::{name[1]}` | "
                     f"{r.measured:.2g} | {r.bound:g} | {r.margin:.3g} | {r.size} |")
    return "\n".join(lines) + "\n"


def figure(table, quick):
    import matplotlib.pyplot as plt
    n = len(table)
    fig, ax = plt.subplots(figsize=(10, 0.32 * n + 1.6))
    y = np.arange(n)[::-1]
    colors = np.where(table.margin < 3, "C3", np.where(table.margin < 100, "C1", "C0"))
    ax.barh(y, table.margin, color=colors, height=0.7)
    ax.set_xscale("log")
    ax.axvline(1.0, color="k", lw=1.2)
    ax.set_yticks(y)
    ax.set_yticklabels(table.case, fontsize=8)
    ax.set_xlim(0.5, max(10.0, table.margin.max() * 1e3))     # room for the longest label
    for yi, m, v in zip(y, table.margin, table.measured, strict=True):
        ax.text(m * 1.1, yi, f"{m:.3g}  (measured {v:.2g})", va="center", fontsize=7)
    ax.set_xlabel("margin = bound asserted by the test / value measured again  (log scale; "
                  "1 = on the bound)")
    size = "quick subset" if quick else "every case at its test's size"
    ax.set_title(f"Hard-case audit: {n} cases, {int(table.within.sum())} within their bound "
                 f"({size})\nred: margin < 3, orange: < 100, blue: ≥ 100")
    ax.grid(axis="x", which="major", alpha=0.3)
    layout(fig, quick)
    return fig


def check(findings: dict, quick: bool) -> None:
    # every recomputed value lies within the bound its test asserts (the reference of each
    # is independent: a closed form, scipy, a tridiagonal eigenproblem, a tighter run)
    assert findings["within_bound"] == findings["cases"], findings
    assert findings["min_margin"] >= 1.0
    assert findings["cases"] >= (20 if quick else 30)


if __name__ == "__main__":
    sys.exit(main(Path(__file__).stem, run))     # __name__ is "__main__" here
