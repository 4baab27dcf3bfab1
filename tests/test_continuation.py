"""kapitza.continuation: branches of periodic orbits, their bifurcations, branch switching.

Every physics check is against something independent of the continuation:

* the upright pendulum's window from the Mathieu equation's characteristic values
  (``kapitza.pendulum_window``) and from exact Floquet windows (``kapitza.window``);
* the born branches' side (criticality) by direct simulation of the full equations;
* the tilted orbits of the horizontal drive by ``kapitza.periodic_orbit`` from averaging's
  guess, and first-order averaging's A ω = √(2 g l);
* the damped parametric pendulum's period doublings by the damped Mathieu window of the
  hanging state, and its period-2 branch's fold and hysteresis by an up-and-down frequency
  sweep of direct simulations.
"""
import math
import warnings

import numpy as np
import pytest

import kapitza
from kapitza.continuation import continuation
from kapitza.results import ComputationInterrupted
from kapitza.results._branches import Bifurcation, Branch
from lagrange_core import problems

G, L = 9.81, 1.0
W0 = math.sqrt(G / L)
OMEGA = 20 * W0                       # ω/ω0 = 20


@pytest.fixture(scope="module")
def vertical():
    return problems.driven_pendulum("vertical")


@pytest.fixture(scope="module")
def horizontal():
    return problems.driven_pendulum("horizontal")


@pytest.fixture(scope="module")
def upright(vertical):
    """The upright pendulum at ω = 20 ω0, A from 0.02 to 0.6 m."""
    return continuation(vertical, dict(m=1.0, l=L, g=G, A=0.02, omega=OMEGA), [math.pi],
                        parameter="A", stop=0.6, progress=False)


# -- (a) the upright pendulum: the window's edges, the period-doubled branch ----------------

def test_upright_branch_finds_the_window_edges(upright, vertical):
    """The Kapitza limit is a pitchfork (+1), the window's top a period doubling (−1):
    both equal to the Mathieu window (characteristic values) to 1e-9, with certified
    accuracies that small, and the exact Floquet window agrees."""
    assert upright.status == "completed"
    kinds = [b.kind for b in upright.bifurcations]
    assert kinds == ["pitchfork", "period_doubling"]
    mathieu = kapitza.pendulum_window(OMEGA, l=L, g=G)
    floquet = kapitza.window(vertical, dict(m=1.0, l=L, g=G), [math.pi], omega=OMEGA)
    for b, ref, ref2 in zip(upright.bifurcations, (mathieu.A_min, mathieu.A_max),
                            (floquet.A_min, floquet.A_max), strict=True):
        assert abs(b.parameter / ref - 1) < 1e-9, (b, ref)
        assert abs(b.parameter / ref2 - 1) < 1e-9, (b, ref2)
        assert b.accuracy < 1e-9 * b.parameter
        assert upright.points.label[b.index] == b.kind
    pf, pd = upright.bifurcations
    assert pf.test_function == "det(M − I)" and pd.test_function == "det(M + I)"
    # stable exactly inside the window; the state is the upright throughout
    pts = upright.points
    lo, hi = pf.parameter, pd.parameter
    inside = (pts.parameter > lo * (1 + 1e-9)) & (pts.parameter < hi * (1 - 1e-9))
    outside = (pts.parameter < lo * (1 - 1e-9)) | (pts.parameter > hi * (1 + 1e-9))
    assert np.all(pts.stable[inside]) and not np.any(pts.stable[outside])
    assert np.allclose(pts.state, [math.pi, 0.0], atol=1e-12)
    assert np.all(pts.amplitude == 0) and np.allclose(pts.q_mean, math.pi)
    # the averaging picture: the tilted orbits born at the Kapitza limit are unstable
    # and exist above it (subcritical); the 2T orbits born at the top exist above it
    assert pf.criticality == "subcritical" and pf.side == 1
    assert pd.criticality == "supercritical" and pd.side == 1


def test_upright_period_doubled_branch_and_its_criticality_by_simulation(upright, vertical):
    """switch() at the period doubling gives 2T orbits on the side A > A_max; their orbits
    repeat after 2T and not after T (direct simulation), and just beyond A_max the
    simulated pendulum, released next to the now unstable upright, stays within the scale
    of the born orbit (supercritical); just below A_max it stays up."""
    pd = upright.bifurcations[1]
    params = dict(m=1.0, l=L, g=G, A=0.3, omega=OMEGA)
    born = upright.switch(pd, stop=pd.parameter * 1.01)
    assert born.status == "completed" and born.periods == 2
    pts = born.points
    assert pts.label[0] == "period_doubling" and pts.parameter[0] == pd.parameter
    assert np.all(pts.parameter[1:] > pd.parameter)          # the side the probe said
    assert np.all(pts.stable[1:])                            # elliptic: the island
    # amplitude ∝ √(A − A_max) near the bifurcation
    k = slice(1, 6)
    ratio = pts.amplitude[k, 0] / np.sqrt(pts.parameter[k] - pd.parameter)
    assert np.ptp(ratio) < 0.05 * ratio.mean()
    # one orbit, checked by the full equations: back after 2T, not after T
    T = 2 * math.pi / OMEGA
    j = len(pts) // 2
    p = dict(params, A=float(pts.parameter[j]))
    tr = vertical.simulate(pts.state[j, :1], pts.state[j, 1:], (0.0, 2 * T), p,
                           t_eval=[T, 2 * T], rtol=1e-12, method="dop853")
    end = np.r_[tr.q[-1], tr.qdot[-1]]
    half = np.r_[tr.q[0], tr.qdot[0]]
    assert np.max(np.abs(end - pts.state[j])) < 1e-8
    assert np.max(np.abs(half - pts.state[j])) > 1e-2
    # criticality by simulation: released 1e-4 rad from the upright
    A_beyond = pd.parameter * 1.002
    amp = np.interp(A_beyond, pts.parameter[1:], pts.amplitude[1:, 0])
    for A, lo, hi in ((A_beyond, 0.5 * amp, 3 * amp), (pd.parameter * 0.998, 0.0, 2e-4)):
        tr = vertical.simulate([math.pi + 1e-4], [0.0], (0.0, 3000 * T), dict(params, A=A),
                               t_eval=np.arange(3001) * T, rtol=1e-10)
        excursion = float(np.max(np.abs(np.asarray(tr.q)[:, 0] - math.pi)))
        assert lo <= excursion <= hi, (A, excursion, amp)


def test_double_pendulum_upright_window_edges():
    """Two degrees of freedom (4 × 4 monodromies): the upright double pendulum (Acheson)
    continued in A finds its window's edges, a pitchfork and a period doubling, equal to
    the exact Floquet window (kapitza.window) to 1e-9."""
    import sympy as sp

    from lagrange_core import t
    A, w = sp.symbols("A omega", positive=True)
    chain = problems.n_link_pendulum(2, pivot=(0, A * sp.cos(w * t)))
    fixed = dict(m1=1.0, m2=1.0, l1=0.5, l2=0.5, g=G)
    omega = 2 * math.pi * 60
    branch = continuation(chain, dict(fixed, A=0.005, omega=omega), [math.pi, math.pi],
                          parameter="A", stop=0.2, progress=False)
    assert [b.kind for b in branch.bifurcations] == ["pitchfork", "period_doubling"]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)   # its edges certified to 1e-10 here
        win = kapitza.window(chain, fixed, [math.pi, math.pi], omega=omega)
    for b, ref in zip(branch.bifurcations, (win.A_min, win.A_max), strict=True):
        assert abs(b.parameter / ref - 1) < 1e-9, (b, ref)
    assert branch.points.multipliers.shape[1] == 4


# -- (b) the horizontal drive: the hanging orbit's pitchfork, the tilted orbits -----------

@pytest.fixture(scope="module")
def hanging(horizontal):
    """The hanging orbit of the horizontal drive at ω = 20 ω0, A from 0.03 to 0.12 m,
    at the corrector tolerance 1e-12 (the comparisons below are to 1e-10)."""
    return continuation(horizontal, dict(m=1.0, l=L, g=G, A=0.03, omega=OMEGA), [0.0],
                        parameter="A", stop=0.12, tol=1e-12, progress=False)


def test_horizontal_hanging_orbit_pitchfork(hanging):
    """The hanging orbit loses stability at a symmetry-breaking pitchfork just below
    averaging's A ω = √(2 g l); the two probes of the born branch lie on the same side
    (mirror images), where the hanging orbit is unstable."""
    assert hanging.status == "completed"
    assert [b.kind for b in hanging.bifurcations] == ["pitchfork"]
    pf = hanging.bifurcations[0]
    A_star = math.sqrt(2 * G * L) / OMEGA
    assert 0.99 * A_star < pf.parameter < A_star
    assert pf.accuracy < 1e-10
    assert pf.criticality == "supercritical" and pf.side == 1
    pts = hanging.points
    assert np.all(pts.stable[pts.parameter < pf.parameter * (1 - 1e-9)])
    assert not np.any(pts.stable[pts.parameter > pf.parameter * (1 + 1e-9)])
    # symmetric: hangs on average (at the pitchfork itself the asymmetric direction is
    # the null direction, and the located orbit may lean by the rounding it amplifies)
    regular = pts.label != "pitchfork"
    assert np.max(np.abs(pts.q_mean[regular])) < 1e-8
    assert np.max(np.abs(pts.q_mean[~regular])) < 1e-6
    # a multiplier at +1 there
    lam = hanging.bifurcations[0].multipliers
    assert np.min(np.abs(lam - 1)) < 1e-5


@pytest.mark.parametrize("direction", [1, -1])
def test_switch_onto_the_tilted_orbits_equals_periodic_orbit(hanging, horizontal, direction):
    """The branch switched onto at the pitchfork is the tilted orbits: at its parameter
    values (away from the pitchfork, where the orbit is well conditioned) the state equals
    kapitza.periodic_orbit's from averaging's tilt ±acos(2gl/(Aω)²) to 1e-10 (the branch at
    the tolerance 1e-12, periodic_orbit at 1e-11: at its default 1e-10 two solutions may
    differ by 1e-10 × the orbit's condition ~10); both halves lean to their own side."""
    pf = hanging.bifurcations[0]
    tilted = hanging.switch(pf, direction=direction)
    assert tilted.status == "completed" and tilted.periods == 1
    pts = tilted.points
    assert np.all(pts.stable[1:])
    sign = np.sign(pts.q_mean[-1, 0])
    assert np.all(np.sign(pts.q_mean[2:, 0]) == sign)
    checked = 0
    for k in range(len(pts)):
        A = float(pts.parameter[k])
        if A < 1.05 * pf.parameter or k % 3:
            continue
        guess = sign * math.acos(2 * G * L / (A * OMEGA) ** 2)
        orbit = kapitza.periodic_orbit(horizontal, dict(m=1.0, l=L, g=G, A=A, omega=OMEGA),
                                       [guess], tol=1e-11)
        assert np.max(np.abs(orbit.state - pts.state[k])) < 1e-10, A
        assert np.max(np.abs(np.sort(np.abs(orbit.multipliers)) -
                             np.sort(np.abs(pts.multipliers[k])))) < 1e-8
        checked += 1
    assert checked >= 4


# -- (c) the damped parametric pendulum near ω = 2 ω0 ---------------------------------------

PARAMETRIC = dict(m=1.0, l=L, g=G, A=0.1, gamma=0.15 * W0)


@pytest.fixture(scope="module")
def damped():
    return problems.driven_pendulum("vertical", damping=True)


@pytest.fixture(scope="module")
def parametric(damped):
    """The hanging state continued in ω from 2.4 ω0 down to 1.2 ω0, and the period-2
    branch switched onto at its upper period doubling."""
    trivial = continuation(damped, dict(PARAMETRIC, omega=2.4 * W0), [0.0],
                           parameter="omega", stop=1.2 * W0, progress=False)
    return trivial, trivial.switch(trivial.bifurcations[0])


def test_parametric_resonance_period_doublings(parametric):
    """The hanging state period-doubles at the two edges of the principal resonance
    tongue: each equals the frequency at which the damped Mathieu window of the hanging
    state ends at A = 0.1 m (kapitza.pendulum_window) to 1e-9."""
    trivial, _ = parametric
    assert [b.kind for b in trivial.bifurcations] == ["period_doubling", "period_doubling"]
    upper, lower = trivial.bifurcations
    assert 2 * W0 < upper.parameter < 2.4 * W0 and 1.6 * W0 < lower.parameter < 2 * W0
    for b in (upper, lower):
        win = kapitza.pendulum_window(b.parameter, l=L, g=G, damping=PARAMETRIC["gamma"],
                                      about="hanging")
        assert abs(win.A_max / PARAMETRIC["A"] - 1) < 1e-9, (b, win)
        assert b.accuracy < 1e-9 * b.parameter
    # softening: the period-2 orbits lean to lower frequencies: born stable at the upper
    # edge (supercritical), unstable at the lower one (subcritical)
    assert upper.criticality == "supercritical" and upper.side == -1
    assert lower.criticality == "subcritical" and lower.side == -1


def test_parametric_period_two_branch_has_a_fold(parametric):
    """The period-2 branch from the upper edge turns at a fold (stable → unstable) and
    ends where it meets the hanging state again, at the lower edge's period doubling."""
    trivial, branch = parametric
    upper, lower = trivial.bifurcations
    assert branch.periods == 2 and branch.status == "completed"
    kinds = [b.kind for b in branch.bifurcations]
    assert kinds == ["fold", "period_doubling"], kinds
    fold, meet = branch.bifurcations
    assert fold.parameter < lower.parameter and fold.accuracy < 1e-8
    assert abs(meet.parameter - lower.parameter) < 1e-9 * lower.parameter
    pts = branch.points
    before = np.arange(len(pts)) < fold.index
    after = (np.arange(len(pts)) > fold.index) & (np.arange(len(pts)) < meet.index)
    assert np.all(pts.stable[before][1:]) and not np.any(pts.stable[after])
    assert pts.amplitude[fold.index, 0] > 1.0
    # the fold is where the parameter turns: the smallest ω on the branch
    assert fold.parameter <= pts.parameter.min() + fold.accuracy


def _sweep(system, omegas, periods=200):
    """Half peak-to-peak of θ over the last 10 drive periods of ``periods`` at each ω,
    the state carried over from the previous frequency (phase zero of the drive)."""
    y, amps = np.array([1e-3, 0.0]), []
    for w in omegas:
        if np.max(np.abs(y)) < 1e-3:              # the hanging state persists: a nudge
            y = y + np.array([1e-3, 0.0])
        T = 2 * math.pi / w
        tr = system.simulate([y[0]], [y[1]], (0.0, periods * T), dict(PARAMETRIC, omega=w),
                             t_eval=np.linspace((periods - 10) * T, periods * T, 801),
                             rtol=1e-9)
        q = np.asarray(tr.q)[:, 0]
        amps.append(0.5 * (q.max() - q.min()))
        y = np.array([q[-1], np.asarray(tr.qdot)[-1, 0]])
    return np.array(amps)


def test_parametric_hysteresis_by_frequency_sweeps(parametric, damped):
    """An up-and-down frequency sweep by direct simulation jumps up at the subcritical
    period doubling and down at the fold: the jump frequencies bracket them (to one grid
    step: critical slowing down near a bifurcation delays a jump), the sweeps disagree
    exactly between them, and the large amplitude is the branch's stable one."""
    trivial, branch = parametric
    fold = branch.bifurcations[0].parameter
    lower = trivial.bifurcations[1].parameter
    step = 0.01 * W0
    omegas = np.arange(1.70, 2.0, 0.01) * W0
    up = _sweep(damped, omegas)
    down = _sweep(damped, omegas[::-1])[::-1]
    big_up, big_down = up > 0.3, down > 0.3
    # going up, the hanging state is left where a nudge of 1e-3 rad grows instead of dying
    jump_up = omegas[np.argmax(up > 1.5e-3)]
    jump_down = omegas[np.argmax(big_down)]                 # the last large going down
    assert jump_up - step <= lower <= jump_up, (jump_up / W0, lower / W0)
    assert jump_down - step <= fold <= jump_down + step, (jump_down / W0, fold / W0)
    hysteresis = (omegas > fold + step) & (omegas < lower - step)
    assert hysteresis.sum() >= 5
    assert np.all(big_down[hysteresis]) and not np.any(big_up[hysteresis])
    outside = (omegas < fold - step) | (omegas > lower + step)
    assert np.all(big_up[outside] == big_down[outside])
    # the simulated amplitude is the stable branch's (801 samples of 10 drive periods
    # resolve the peak to ~3e-4 rad)
    pts = branch.points
    stable = pts.stable & (pts.label == "")
    order = np.argsort(pts.parameter[stable])
    on = big_down & (omegas > fold + step)
    ref = np.interp(omegas[on], pts.parameter[stable][order], pts.amplitude[stable, 0][order])
    assert np.max(np.abs(down[on] - ref)) < 2e-3


# -- results, errors and never-silent endings ----------------------------------------------

def test_branch_result_table_and_figure(upright):
    df = upright.to_dataframe()
    assert len(df) == len(upright.points)
    for col in ("A", "label", "stable", "theta_0", "theta_dot_0", "theta_mean",
                "theta_amplitude", "max_abs_multiplier", "multiplier_0", "multiplier_1"):
        assert col in df.columns
    assert set(df.label) >= {"start", "pitchfork", "period_doubling", "end"}
    assert isinstance(upright.bifurcations[0], Bifurcation) and isinstance(upright, Branch)
    assert "pitchfork" in repr(upright) and "period_doubling" in str(upright.bifurcations[1])
    from matplotlib.figure import Figure
    fig = upright.figure()
    assert isinstance(fig, Figure)
    born = upright.switch(upright.bifurcations[1], stop=0.5)
    fig2 = born.figure(ax=fig.axes[0])
    assert fig2 is fig and len(fig.axes[0].get_legend().get_texts()) == 4
    with pytest.raises(ValueError, match="y must be one of"):
        upright.figure(y="energy")


def test_bad_input_is_named(vertical):
    p = dict(m=1.0, l=L, g=G, A=0.3, omega=OMEGA)
    with pytest.raises(ValueError, match="parameter = 'B'"):
        continuation(vertical, p, [math.pi], parameter="B", stop=0.5)
    with pytest.raises(ValueError, match="stop = 0.3 equals the start"):
        continuation(vertical, p, [math.pi], stop=0.3)
    with pytest.raises(ValueError, match="tol must be"):
        continuation(vertical, p, [math.pi], stop=0.5, tol=1e-3)
    with pytest.raises(ValueError, match="about must be 1 finite coordinates"):
        continuation(vertical, p, [math.pi, 0.0, 1.0], stop=0.5)
    with pytest.raises(ValueError, match="periods must be"):
        continuation(vertical, p, [math.pi], stop=0.5, periods=0)
    with pytest.raises(ValueError, match="max_step"):
        continuation(vertical, p, [math.pi], stop=0.5, step=0.1, max_step=0.01)
    with pytest.raises(TypeError, match="lagrange_core.System"):
        continuation("pendulum", p, [math.pi], stop=0.5)


def test_switch_refuses_what_has_no_branch(parametric, upright):
    _, branch = parametric
    with pytest.raises(ValueError, match="a fold has no emanating branch"):
        branch.switch(branch.bifurcations[0])
    with pytest.raises(ValueError, match="one of this branch's"):
        upright.switch(branch.bifurcations[0])
    with pytest.raises(ValueError, match="direction must be"):
        upright.switch(upright.bifurcations[0], direction=2)


def test_max_points_warns_and_returns_the_branch_so_far(vertical):
    p = dict(m=1.0, l=L, g=G, A=0.1, omega=OMEGA)
    with pytest.warns(RuntimeWarning, match="max_points = 5"):
        b = continuation(vertical, p, [math.pi], stop=0.4, max_points=5, progress=False)
    assert b.status == "max_points" and len(b.points) == 5 and "max_points" in b.message


def test_a_failing_corrector_stops_with_status_and_warning(vertical, monkeypatch):
    """Where the flow fails from some parameter on, the step shrinks to its minimum and
    the branch ends there with the points so far, a status and a warning."""
    from kapitza.continuation import _shooting
    evaluate = _shooting.PeriodMap.evaluate

    def failing(self, v):
        return None if self.value(v) > 0.2 else evaluate(self, v)

    monkeypatch.setattr(_shooting.PeriodMap, "evaluate", failing)
    p = dict(m=1.0, l=L, g=G, A=0.1, omega=OMEGA)
    with pytest.warns(RuntimeWarning, match="continuation: .*the step shrank"):
        b = continuation(vertical, p, [math.pi], stop=0.4, progress=False)
    assert b.status == "corrector_failed"
    assert b.points.parameter[-1] <= 0.2 and len(b.points) > 3


def test_ctrl_c_keeps_the_branch_so_far(vertical):
    p = dict(m=1.0, l=L, g=G, A=0.1, omega=OMEGA)

    def progress(done, total):
        if done >= 6:
            raise KeyboardInterrupt

    with pytest.raises(ComputationInterrupted) as info:
        continuation(vertical, p, [math.pi], stop=0.4, progress=progress)
    branch = info.value.result
    assert isinstance(branch, Branch) and branch.status == "interrupted"
    assert len(branch.points) >= 6


def test_no_orbit_near_about_is_an_error():
    """An undamped oscillator driven at its resonance has no periodic orbit: a clear
    error, not a silent branch."""
    import sympy as sp

    from lagrange_core import Particle, System, coordinates, t
    (x,), _ = coordinates("x")
    m, k, F, w = sp.symbols("m k F omega", positive=True)
    oscillator = System([x], particles=[Particle(m, (x, 0), "mass")],
                        potential=k * x**2 / 2 - F * x * sp.cos(w * t))
    with pytest.raises(ValueError, match="no periodic orbit found near about"):
        continuation(oscillator, dict(m=1.0, k=4.0, F=1.0, omega=2.0), [0.0], parameter="F",
                     stop=2.0)


def test_neimark_sacker_test_function_on_monodromies():
    """The bialternate test function changes sign where a complex pair crosses the unit
    circle, and stays off for real pairs and conservative systems."""
    from kapitza.continuation._shooting import test_functions

    def M(r, angle=0.7, other=0.5):
        c, s = math.cos(angle), math.sin(angle)
        out = np.zeros((4, 4))
        out[:2, :2] = r * np.array([[c, -s], [s, c]])
        out[2:, 2:] = np.diag([other, 0.3])
        return out

    below, _ = test_functions(M(0.99), 1e-14, conservative=False)
    above, _ = test_functions(M(1.01), 1e-14, conservative=False)
    assert below[2] * above[2] < 0
    assert below[0] * above[0] > 0 and below[1] * above[1] > 0
    cons, _ = test_functions(M(1.0), 1e-14, conservative=True)
    assert math.isnan(cons[2])


@pytest.mark.parametrize("options,named", [(dict(periods="a"), "periods"),
                                           (dict(periods=None), "periods"),
                                           (dict(periods=1.5), "periods"),
                                           (dict(max_points="x"), "max_points"),
                                           (dict(winding=0.5), "winding"),
                                           (dict(winding="x"), "winding"),
                                           (dict(winding=[1, 1]), "winding"),
                                           (dict(winding=True), "winding")])
def test_counts_that_are_not_whole_numbers_are_named(options, named):
    """A count given as a string, None or 1.5 is refused naming the argument (it raised
    int()'s own message before)."""
    system = problems.driven_pendulum("vertical")
    params = dict(m=1.0, l=1.0, g=9.81, A=0.02, omega=20 * math.sqrt(9.81))
    with pytest.raises(ValueError, match=f"continuation: {named} must be a whole number"):
        kapitza.continuation(system, params, [math.pi], parameter="A", stop=0.6, **options)


def _coupled_pendulums():
    """Two pendulums (lengths l1 ≠ l2) on one vertically shaken axle, coupled by a torsion
    spring κ and damped (c per axle): the drive modulates gravity, which the spring does
    not, so the normal modes couple and the sum-type combination resonance
    ω = Ω1 + Ω2 opens a tongue where a complex pair of the hanging state's multipliers
    leaves the unit circle — a Neimark–Sacker bifurcation of a physical system."""
    import sympy as sp

    from lagrange_core import Particle, System, coordinates, t
    (th1, th2), (v1, v2) = coordinates("theta1 theta2")
    m, l1, l2, g, A, w, kappa, c = sp.symbols("m l1 l2 g A omega kappa c", positive=True)
    pivot_y = A * sp.cos(w * t)
    b1 = Particle(m, (l1 * sp.sin(th1), pivot_y - l1 * sp.cos(th1)), "bob1")
    b2 = Particle(m, (l2 * sp.sin(th2), pivot_y - l2 * sp.cos(th2)), "bob2")
    system = System([th1, th2], particles=[b1, b2],
                    potential=m * g * (b1.position[1] + b2.position[1])
                    + kappa * (th1 - th2)**2 / 2,
                    dissipation=c * (v1**2 + v2**2) / 2, name="coupled pendulums")
    params = dict(m=1.0, l1=1.0, l2=0.5, g=9.81, kappa=2.0, c=0.02, A=0.0)
    M = np.diag([params["l1"]**2, params["l2"]**2])
    K = params["g"] * np.diag([params["l1"], params["l2"]]) \
        + params["kappa"] * np.array([[1.0, -1.0], [-1.0, 1.0]])
    Omega = np.sqrt(np.sort(np.linalg.eigvals(np.linalg.solve(M, K)).real))
    params["omega"] = float(Omega.sum())
    return system, params, M, K


def _coupled_monodromy(params, M, K, amplitude):
    """The hanging state's monodromy by scipy's DOP853 on the linearised equations
    M θ̈ + c θ̇ + [K − A ω² cos ωt diag(l)] θ = 0 at rtol 1e-13 (independent of the
    library's derivation, kernels and integrator)."""
    from scipy.integrate import solve_ivp
    w = params["omega"]
    drive = np.diag([params["l1"], params["l2"]]) * params["m"]
    Mi = np.linalg.inv(M * params["m"])

    def f(time, z):
        Y = z.reshape(4, 4)
        stiffness = K * params["m"] - amplitude * w * w * math.cos(w * time) * drive
        J = np.block([[np.zeros((2, 2)), np.eye(2)],
                      [-Mi @ stiffness, -params["c"] * Mi]])
        return (J @ Y).ravel()
    run = solve_ivp(f, (0.0, 2 * math.pi / w), np.eye(4).ravel(), method="DOP853",
                    rtol=1e-13, atol=1e-15)
    return run.y[:, -1].reshape(4, 4)


def test_neimark_sacker_of_coupled_pendulums_against_scipy_and_simulation():
    """A physical Neimark–Sacker point: the hanging state of two damped, spring-coupled
    pendulums on a vertically shaken axle at ω = Ω1 + Ω2, continued in A.  The branch's
    first bifurcation is a Neimark–Sacker point (found by the bialternate test function,
    a complex pair, not ±1) at the A where scipy's monodromy of the linearised equations
    has its largest |multiplier| cross 1 (brentq on it: agreement within the certified
    accuracy plus 1e-9 relative); direct simulation of the nonlinear equations shows a
    small displacement decaying below that A and growing above it."""
    from scipy.optimize import brentq
    system, params, M, K = _coupled_pendulums()
    branch = continuation(system, params, [0.0, 0.0], parameter="A", stop=0.05,
                          progress=False)
    assert branch.status == "completed"
    first = branch.bifurcations[0]
    assert first.kind == "neimark_sacker"
    assert first.test_function == "det(M ⊙ M − I)"
    pair = first.multipliers[np.argsort(-np.abs(first.multipliers))[:2]]
    assert np.allclose(np.abs(pair), 1.0, atol=1e-6)
    assert np.all(np.abs(pair.imag) > 0.5)          # a complex pair, far from ±1

    def excess(a):
        return np.max(np.abs(np.linalg.eigvals(_coupled_monodromy(params, M, K, a)))) - 1.0
    reference = brentq(excess, 0.5 * first.parameter, 1.5 * first.parameter, xtol=1e-15,
                       rtol=1e-14)
    assert abs(first.parameter - reference) <= first.accuracy + 1e-9 * reference

    # nonlinear direct simulation: a small kick decays below, grows above
    T = 2 * math.pi / params["omega"]
    strobe = np.arange(0.0, 800.5) * T
    growth = []
    for factor in (0.7, 1.4):
        run = system.simulate([1e-4, -1e-4], [0.0, 0.0], (0.0, strobe[-1]),
                              dict(params, A=factor * reference), rtol=1e-10,
                              t_eval=strobe)
        size = np.hypot(np.abs(run.q).max(axis=1), T * np.abs(run.qdot).max(axis=1))
        growth.append(size[-100:].max() / size[:100].max())     # over ~700 periods
    assert growth[0] < 0.3 and growth[1] > 3.0, growth


def test_rotating_orbits_continued_through_their_fold():
    """The damped pendulum on a vertically shaken pivot (studies/period_doubling.py's,
    ω = 2ω0, γ = 0.1 ω) whirls once per drive period at A = 0.35762 m
    (tests/test_orbit_shooting.py).  Continued with ``winding=1`` down in A, the rotating
    branch turns at a fold — where whirling is born — and comes back unstable; up in A it
    period-doubles.  Checked independently: every point is ``periodic_orbit(winding=1)``'s
    orbit at its A (to 1e-9); the fold's A is where the stable and unstable rotating orbits
    of ``periodic_orbit`` meet (their distance² vanishes at A_fold: a cubic in A − A_fold
    through five amplitudes puts its root within 1e-9 relative); the period doubling lies
    where periodic_orbit's multiplier crosses −1, and the branch born there whirls twice
    per two periods, unevenly; direct simulation whirls at 1.02 A_fold and stops whirling
    at 0.98 A_fold."""
    g, l = 9.81, 1.0
    omega = 2 * math.sqrt(g / l)
    T = 2 * math.pi / omega
    system = problems.driven_pendulum("vertical", damping=True)

    def params(A):
        return dict(m=1.0, l=l, g=g, omega=omega, gamma=0.1 * omega, A=float(A))
    start = kapitza.periodic_orbit(system, params(0.35762), [2.61955, 5.34930], winding=1)
    assert start.stable and "rotating" in start.method
    with warnings.catch_warnings():
        warnings.simplefilter("error")          # nothing to warn about on this branch
        down = continuation(system, params(0.35762), start.state, parameter="A", stop=0.1,
                            winding=1, progress=False)
        up = continuation(system, params(0.35762), start.state, parameter="A", stop=0.5,
                          winding=1, progress=False)
    assert [b.kind for b in down.bifurcations] == ["fold"]
    assert [b.kind for b in up.bifurcations][:1] == ["period_doubling"]
    fold, doubling = down.bifurcations[0], up.bifurcations[0]
    assert down.winding == up.winding == (1,) and "winding=(1,)" in repr(down)
    pts = down.points
    assert pts.stable[0] and not pts.stable[-1]          # stable, then unstable past the fold
    # every point: periodic_orbit's rotating orbit at its A
    for i in range(0, len(pts.parameter), 7):
        orbit = kapitza.periodic_orbit(system, params(pts.parameter[i]), pts.state[i],
                                       winding=1)
        assert np.max(np.abs(orbit.state - pts.state[i])) < 1e-9
    # the fold: the two rotating orbits of periodic_orbit meet there, d² ∝ A − A_fold
    stable_side = np.flatnonzero(pts.stable)
    unstable_side = np.flatnonzero(~pts.stable)
    d2, amps = [], fold.parameter * (1 + np.array([1e-4, 2e-4, 3e-4, 4e-4, 5e-4]))
    for a in amps:
        near_s = stable_side[np.argmin(np.abs(pts.parameter[stable_side] - a))]
        near_u = unstable_side[np.argmin(np.abs(pts.parameter[unstable_side] - a))]
        s_orbit = kapitza.periodic_orbit(system, params(a), pts.state[near_s], winding=1)
        u_orbit = kapitza.periodic_orbit(system, params(a), pts.state[near_u], winding=1)
        assert s_orbit.stable and not u_orbit.stable
        d2.append(np.sum((s_orbit.state - u_orbit.state) ** 2))
    # d² is a power series in A − A_fold starting at the first power: the root of the
    # cubic through the five points (a line put it 4e-7 off, the cubic 1.6–2.8e-10)
    roots = np.roots(np.polyfit(amps - fold.parameter, d2, 3))
    offset = roots[np.argmin(np.abs(roots))]
    assert abs(offset.imag) < 1e-12 and abs(offset.real) < 1e-9 * fold.parameter
    # the period doubling: periodic_orbit's multiplier crosses −1 there
    for side, factor in ((1, 0.999), (-1, 1.001)):
        orbit = kapitza.periodic_orbit(system, params(factor * doubling.parameter),
                                       doubling.state, winding=1)
        assert side * (np.min(orbit.multipliers.real) + 1.0) > 0
    # the branch born at the period doubling whirls twice in two periods, unevenly
    two = up.switch(doubling)
    assert two.periods == 2 and two.status == "completed" and two.winding == (2,)
    k = len(two.points.parameter) // 2
    a, y = two.points.parameter[k], two.points.state[k]
    run = system.simulate(y[:1], y[1:], (0.0, 4 * T), params(a), rtol=1e-11,
                          t_eval=np.arange(5) * T)
    turns = np.diff(run.q[:, 0]) / (2 * math.pi)
    assert np.allclose(turns[0::2] + turns[1::2], 2.0, atol=1e-6)      # 2 turns per 2T
    assert np.allclose(turns[:2], turns[2:], atol=1e-6)                # period 2T ...
    assert abs(turns[0] - turns[1]) > 1e-3                             # ... not T
    # direct simulation: whirling just above the fold, none just below
    for factor, whirls in ((1.02, True), (0.98, False)):
        run = system.simulate(fold.state[:1], fold.state[1:], (0.0, 300 * T),
                              params(factor * fold.parameter), rtol=1e-10,
                              t_eval=np.arange(280, 301) * T)
        turns = np.diff(run.q[:, 0]) / (2 * math.pi)
        assert np.allclose(turns, 1.0, atol=1e-3) == whirls
