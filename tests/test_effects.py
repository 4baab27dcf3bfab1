"""Effects as building blocks (lagrange_core.effects): each against the equation a
lecture writes for it, and only the named ones in the equations."""
import itertools
import math

import numpy as np
import pytest
import sympy as sp

from lagrange_core import effects as fx
from lagrange_core import problems
from lagrange_core.forms import rkn_form

P = dict(m=1.3, l=0.7, g=9.81, A=0.05, B=-0.03, omega=100.0, gamma=0.4, c_drag=0.2,
         k_theta=2.5)
STATES = [(0.3, 1.1, 0.01), (2.9, -0.5, 0.3), (-1.2, 4.0, 1.7)]


def accel(system, th, thd, t):
    params = {k: v for k, v in P.items() if k in system.parameters}
    return system.accelerations([th], [thd], t, params)[0]


@pytest.mark.parametrize("direction", ["vertical", "horizontal"])
@pytest.mark.parametrize("damped", [False, True])
def test_driven_pendulum_equals_the_catalogue(direction, damped):
    built = fx.build(fx.pendulum_rig(), [fx.Gravity(), fx.PivotDrive(direction)]
                     + ([fx.Damping()] if damped else []))
    ref = problems.driven_pendulum(direction, damping=damped)
    assert set(built.parameters) == set(ref.parameters)
    for st in STATES:
        assert accel(built, *st) == pytest.approx(accel(ref, *st), rel=1e-13, abs=1e-12)


def test_each_effect_against_its_closed_form():
    """θ̈ for the pendulum (m, l), term by term:
    gravity −(g/l) sin θ; vertical drive +(A ω²/l) cos ωt sin θ; damping −γ θ̇;
    air drag −(c l/m) |θ̇| θ̇ (the bob moves at l θ̇); spring −k (θ − θ0)/(m l²);
    elliptic pivot (A cos ωt, B sin ωt): +(ω²/l)(A cos ωt cos θ + B sin ωt sin θ)."""
    m, l, g, A, B, w = P["m"], P["l"], P["g"], P["A"], P["B"], P["omega"]
    rig = fx.pendulum_rig()
    terms = {
        "gravity": ([fx.Gravity()], lambda th, thd, t: -g / l * math.sin(th)),
        "drive": ([fx.PivotDrive("vertical")],
                  lambda th, thd, t: A * w**2 / l * math.cos(w * t) * math.sin(th)),
        "damping": ([fx.Damping()], lambda th, thd, t: -P["gamma"] * thd),
        "drag": ([fx.AirDrag()], lambda th, thd, t: -P["c_drag"] * l / m * abs(thd) * thd),
        "spring": ([fx.Spring("theta", rest=0.2)],
                   lambda th, thd, t: -P["k_theta"] * (th - 0.2) / (m * l**2)),
        "elliptic": ([fx.PivotDrive("elliptic")],
                     lambda th, thd, t: w**2 / l * (A * math.cos(w * t) * math.cos(th)
                                                    + B * math.sin(w * t) * math.sin(th))),
    }
    for name, (effects, closed) in terms.items():
        s = fx.build(rig, effects)
        for st in STATES:
            assert accel(s, *st) == pytest.approx(closed(*st), rel=1e-12, abs=1e-12), name
    # together they add (the drag is that of still air: with a moving pivot it differs)
    s = fx.build(rig, [fx.Gravity(), fx.PivotDrive("vertical"), fx.Damping(),
                       fx.Spring("theta", rest=0.2)])
    for st in STATES:
        want = sum(terms[k][1](*st) for k in ("gravity", "drive", "damping", "spring"))
        assert accel(s, *st) == pytest.approx(want, rel=1e-12)


def _symbols_in_equations(system):
    eq = system.equations
    exprs = list(eq.forcing_se) + [e for row in eq.mass_matrix_se for e in row]
    return {str(s) for e in exprs for s in sp.sympify(e).free_symbols}


def test_only_named_effects_enter_the_equations():
    """Every subset of {gravity, drive, damping, drag}: the derived M and F contain the
    parameters of exactly the named effects, and velocity forces decide the RKN form."""
    rig = fx.pendulum_rig()
    pool = {"g": fx.Gravity(), "drive": fx.PivotDrive("vertical"), "gamma": fx.Damping(),
            "c_drag": fx.AirDrag()}
    marks = {"g": {"g"}, "drive": {"A", "omega"}, "gamma": {"gamma"}, "c_drag": {"c_drag"}}
    for r in range(0, 5):
        for chosen in itertools.combinations(pool, r):
            s = fx.build(rig, [pool[k] for k in chosen])
            syms = _symbols_in_equations(s)
            for k in pool:
                assert (marks[k] <= syms) == (k in chosen), (chosen, syms)
            velocity = "gamma" in chosen or "c_drag" in chosen
            assert rkn_form(s.equations)[0] == (not velocity)     # no kernels compiled
            cap = fx.capabilities([pool[k] for k in chosen])
            assert cap["integrator"] == ("dop853" if velocity else "rkn12")


def test_capabilities_choose_the_floquet_path():
    assert fx.capabilities([fx.Gravity(), fx.PivotDrive("vertical")])["floquet"] == "equilibrium"
    for path in ("horizontal", "elliptic", (1.0, 2.0)):
        assert fx.capabilities([fx.Gravity(), fx.PivotDrive(path)])["floquet"] == \
            "periodic_orbit"
    assert fx.capabilities([fx.Gravity()])["energy_conserved"]


def test_chain_with_elliptic_drive_and_harmonics():
    """The 2-link chain on a pivot with two harmonics A(cos ωt + ½ cos(2ωt + 0.3)) along
    a 30° line: the built system equals the hand-written catalogue chain with that pivot."""
    from lagrange_core.symbols import t
    A, w = sp.symbols("A omega", positive=True)
    d = (math.cos(math.pi / 3), math.sin(math.pi / 3))
    drive = fx.PivotDrive(d, harmonics=((1, 1.0, 0.0), (2, 0.5, 0.3)))
    built = fx.build(fx.n_link_rig(2), [fx.Gravity(), drive])
    s = A * (sp.cos(w * t) + sp.Rational(1, 2) * sp.cos(2 * w * t + sp.nsimplify(0.3)))
    ref = problems.n_link_pendulum(2, pivot=(sp.nsimplify(d[0]) * s, sp.nsimplify(d[1]) * s))
    p = dict(g=9.81, A=0.03, omega=50.0, l1=1.0, l2=0.5, m1=1.0, m2=2.0)
    for q, qd, tt in [([0.3, -0.2], [1.0, 0.5], 0.1), ([3.0, 2.0], [-1.0, 2.0], 0.77)]:
        np.testing.assert_allclose(built.accelerations(q, qd, tt, p),
                                   ref.accelerations(q, qd, tt, p), rtol=1e-12, atol=1e-12)


@pytest.mark.parametrize("make, match", [
    (lambda: fx.PivotDrive("sideways"), "path must be"),
    (lambda: fx.PivotDrive((0.0, 0.0)), "not zero"),
    (lambda: fx.PivotDrive("vertical", harmonics=((0, 1.0, 0.0),)), "whole k"),
    (lambda: fx.PivotDrive("elliptic", harmonics=((1, 1.0, 0.0), (2, 1.0, 0.0))),
     "no extra harmonics"),
    (lambda: fx.build(fx.pendulum_rig(), [fx.Gravity(), fx.Gravity()]), "named twice"),
    (lambda: fx.build(fx.pendulum_rig(), [fx.Spring("phi")]), "not a coordinate"),
    (lambda: fx.build(fx.pendulum_rig(), ["gravity"]), "effects must be"),
    (lambda: fx.n_link_rig(0), "whole number of links"),
])
def test_bad_effects_are_explained(make, match):
    with pytest.raises((ValueError, TypeError), match=match):
        make()
