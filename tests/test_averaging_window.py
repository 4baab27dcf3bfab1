"""AveragedSystem.window: the first-order averaging window of any system, per ω.

References, independent of the general averaging code: the single pendulum's closed
form A_min ω = √(2 g l) (kapitza.closed_forms.pendulum_window), Acheson's N-link chain
(kapitza.multiple_pendulum_upright, built from lagrange_core's hanging normal modes),
the horizontally driven pendulum's U_eff from PHYSICS.md, and the exact Floquet map of
the double pendulum (kapitza.floquet.stability_map).
"""
import math
import time

import numpy as np
import pytest
import sympy as sp

from kapitza.averaging import _average as av
from kapitza.averaging._window import _amplitude_scales_fast_forces
from kapitza.closed_forms import multiple_pendulum_upright, pendulum_window
from kapitza.figures import stability_map_figure
from kapitza.floquet import stability_map
from kapitza.results import StabilityWindow
from lagrange_core import problems, t

from helpers import G

L = 0.7
DP = {"g": G, "l1": 1.0, "l2": 1.0, "m1": 1.0, "m2": 1.0}


@pytest.fixture(scope="module")
def vertical():
    return av.average(problems.driven_pendulum("vertical"))


def chain(n):
    A, w = sp.symbols("A omega", positive=True)
    return av.average(problems.n_link_pendulum(n, pivot=(0, A * sp.cos(w * t))))


def test_single_pendulum_equals_closed_form(vertical):
    w = np.geomspace(5.0, 5000.0, 200)
    win = vertical.window({"m": 1.3, "l": L, "g": G}, [math.pi], omega=w)
    assert isinstance(win, StabilityWindow)
    assert win.method == "averaging" and win.order == 1 and win.about == str([math.pi])
    closed = pendulum_window(w, l=L, g=G, method="averaging", order=1, warn=False)
    np.testing.assert_allclose(win.A_min * w, math.sqrt(2 * G * L), rtol=1e-10)
    np.testing.assert_allclose(win.A_min, closed.A_min, rtol=1e-10)
    np.testing.assert_allclose(win.frequency_ratio, closed.frequency_ratio, rtol=1e-10)
    assert np.all(np.isinf(win.A_max)) and np.all(win.exists)
    # validity: ω/ω0 and the error estimate (ω0/ω)²
    np.testing.assert_allclose(win.frequency_ratio, w / math.sqrt(G / L), rtol=1e-10)
    np.testing.assert_allclose(win.error_estimate, G / L / w**2, rtol=1e-10)
    assert not win.valid[0] and win.valid[-1]
    # a scalar ω gives scalars; params may carry A and omega (ignored)
    one = vertical.window({"m": 1.0, "l": L, "g": G, "A": 9.0, "omega": 1.0}, [math.pi],
                          omega=100.0)
    assert np.ndim(one.A_min) == 0 and one.A_min == pytest.approx(math.sqrt(2 * G * L) / 100,
                                                                  rel=1e-10)
    # the hanging state needs no drive
    assert vertical.window({"m": 1.0, "l": L, "g": G}, [0.0], omega=100.0).A_min == 0


@pytest.mark.parametrize("n, masses, lengths", [(2, [1.0, 1.0], [1.0, 1.0]),
                                                (2, [1.0, 0.3], [0.5, 1.2]),
                                                (3, [1.0, 0.5, 0.8], [0.7, 1.0, 0.4])])
def test_chain_equals_acheson(n, masses, lengths):
    params = {"g": G, **{f"m{i + 1}": masses[i] for i in range(n)},
              **{f"l{i + 1}": lengths[i] for i in range(n)}}
    w = np.linspace(30.0, 600.0, 60)
    win = chain(n).window(params, [math.pi] * n, omega=w)
    drive = multiple_pendulum_upright(masses, lengths, g=G).minimum_drive
    np.testing.assert_allclose(win.A_min * w, drive, rtol=1e-10)
    assert np.all(np.isinf(win.A_max))


def test_chain_is_fast():
    avg = chain(2)
    w = np.linspace(20.0, 500.0, 200)
    avg.window(DP, [math.pi, math.pi], omega=w)          # compile / load
    start = time.perf_counter()
    avg.window(DP, [math.pi, math.pi], omega=w)
    assert time.perf_counter() - start < 1.0


def test_upper_edge_horizontal_drive():
    """Horizontal drive (PHYSICS.md): U_eff = −g l cos θ + A² ω² cos² θ / 4, so the hanging
    state is stable only while A² ω² < 2 g l (then it tilts): A_min = 0, A_max = √(2gl)/ω."""
    avg = av.average(problems.driven_pendulum("horizontal"))
    w = np.array([20.0, 80.0, 300.0])
    win = avg.window({"m": 1.0, "l": L, "g": G}, [0.0], omega=w)
    np.testing.assert_array_equal(win.A_min, 0.0)
    np.testing.assert_allclose(win.A_max * w, math.sqrt(2 * G * L), rtol=1e-10)
    # A_range's lower end: a window wholly below it is no window; one that meets it is
    # reported whole (edges not clipped)
    high = avg.window({"m": 1.0, "l": L, "g": G}, [0.0], omega=w, A_range=(0.03, 1.0))
    assert math.isnan(high.A_min[2]) and not high.exists[2]        # A_max(300) = 1.2 cm
    np.testing.assert_array_equal(high.A_min[:2], 0.0)
    np.testing.assert_array_equal(high.A_max[:2], win.A_max[:2])


def test_search_limit_and_nonlinear_amplitude(vertical):
    p = {"m": 1.0, "l": L, "g": G}
    w = np.array([10.0, 100.0])
    win = vertical.window(p, [math.pi], omega=w, A_range=(0.0, 0.1))
    assert math.isnan(win.A_min[0]) and math.isnan(win.A_max[0]) and not win.exists[0]
    assert win.A_min[1] == pytest.approx(math.sqrt(2 * G * L) / 100, rel=1e-10)
    # a pivot y = a² cos ωt: a enters nonlinearly, so the window is root-found on the margin
    a, om = sp.symbols("a omega", positive=True)
    sq = av.average(problems.n_link_pendulum(1, pivot=(0, a**2 * sp.cos(om * t))))
    assert not _amplitude_scales_fast_forces(sq, "a")
    p1 = {"m1": 1.0, "l1": L, "g": G}
    with pytest.raises(ValueError, match="A_range"):
        sq.window(p1, [math.pi], omega=w, amplitude="a")
    win = sq.window(p1, [math.pi], omega=w, amplitude="a", A_range=(0.0, 2.0))
    np.testing.assert_allclose(win.A_min**2 * w, math.sqrt(2 * G * L), rtol=1e-10)
    # the root below A_range's lower end when that end is already stable (a_min(100) = 0.19)
    above = sq.window(p1, [math.pi], omega=100.0, amplitude="a", A_range=(0.5, 2.0))
    assert above.A_min == pytest.approx(win.A_min[1], rel=1e-12)


def test_errors(vertical):
    p = {"m": 1.0, "l": L, "g": G}
    with pytest.raises(ValueError, match="not a parameter"):
        vertical.window(p, [math.pi], omega=100.0, amplitude="B")
    with pytest.raises(ValueError, match="> 0"):
        vertical.window(p, [math.pi], omega=[100.0, 0.0])
    with pytest.raises(ValueError, match="not an equilibrium"):
        vertical.window(p, [1.0], omega=100.0)
    for bad in [(-1.0, 1.0), (0.5, 0.1), 0.3, (0.0, float("nan"))]:
        with pytest.raises(ValueError, match="A_range"):
            vertical.window(p, [math.pi], omega=100.0, A_range=bad)


def test_overlay_on_double_pendulum_map():
    """The window drawn over the exact map of the double pendulum, where it belongs."""
    n = 2
    avg = chain(n)
    A, W = sp.symbols("A omega", positive=True)
    system = problems.n_link_pendulum(n, pivot=(0, A * sp.cos(W * t)))
    amps, freqs = np.linspace(0.0, 0.12, 7), np.linspace(60.0, 150.0, 4)
    m = stability_map(system, params=DP, about=[math.pi, math.pi], A=amps, omega=freqs,
                      tol=1e-8)
    win = avg.window(DP, [math.pi, math.pi], omega=np.linspace(60.0, 150.0, 50))
    # averaging agrees with the exact map away from its edge (its error ~ (ω_s/ω)² ≲ 1 %)
    edge = avg.window(DP, [math.pi, math.pi], omega=freqs).A_min
    ratio = amps[:, None] / edge[None, :]
    assert np.all(m.stable[ratio > 1.15]) and not np.any(m.stable[ratio < 0.85])
    fig = stability_map_figure(m, overlays=[win])
    lines = [ln for ln in fig.axes[0].get_lines() if "averaging" in ln.get_label()]
    assert len(lines) == 1                             # A_max = inf is left out
    np.testing.assert_array_equal(lines[0].get_xdata(), win.omega)
    np.testing.assert_array_equal(lines[0].get_ydata(), win.A_min)
