"""Maps, windows and boundaries about periodic orbits (issue 21.5): the orbit followed over
the grid by Newton shooting (kapitza.floquet._orbits), checked against independent
references:

* the horizontal drive's hanging orbit loses stability at the symmetry-breaking pitchfork,
  located by ``kapitza.simulation.symmetry_breaking`` (brentq on det(I + R X_h) along the
  symmetric orbit, its own shooting; tests/test_orbit_bifurcation.py validates it): the
  map's boundary along A lies in the grid cell that holds it, and ``window``'s A_max and
  ``boundaries``' curve equal it to 1e-9;
* every map point against ``kapitza.periodic_orbit`` solved there on its own (Newton from
  the rest state or from averaging's tilt, not from a neighbour);
* the damped elliptic pivot (no half-period symmetry, dissipative: the full period map and
  log det M ≠ 0), whose orbit from the hanging state turns into a tilted one as A grows,
  against ``periodic_orbit`` from the averaged torque balance's tilt (studies/other_drives.py);
* the tilted orbit exists only above the pitchfork: the pendulum's "tilted" map is the
  complement of its "hanging" map, with "no periodic orbit" where it does not exist, never
  the hanging orbit's stability.
"""
import math
import warnings

import numpy as np
import pytest

import kapitza
from kapitza import KapitzaPendulum, Scene, periodic_orbit
from kapitza.results import ComputationInterrupted
from kapitza.simulation import symmetry_breaking
from lagrange_core import problems

G, L = 9.81, 1.0
BASE = dict(m=1.0, l=L, g=G)


@pytest.fixture(scope="module")
def horizontal():
    return problems.driven_pendulum("horizontal")


@pytest.fixture(scope="module")
def pitchfork(horizontal):
    """The exact pitchfork amplitude per ω (symmetric shooting and brentq)."""
    out = {}
    for w in (30.0, 45.0, 60.0):
        a = math.sqrt(2 * G * L) / w
        out[w] = symmetry_breaking(horizontal, dict(BASE, A=a, omega=w), [0.0],
                                   A_range=(0.8 * a, 1.2 * a)).amplitude
    return out


@pytest.fixture(scope="module")
def hanging_map(horizontal):
    return kapitza.stability_map(horizontal, BASE, [0.0], A=np.linspace(0.0, 0.2, 41),
                                 omega=np.array([30.0, 45.0, 60.0]))


def test_hanging_map_turns_unstable_at_the_pitchfork(hanging_map, pitchfork):
    m = hanging_map
    assert m.method.startswith("periodic orbit: Newton shooting on the half-period map")
    assert m.about == "periodic orbit symmetric about q = [0.0]"
    assert m.flagged_points == 0 and m.uncertified_points == 0
    for j, w in enumerate(m.omega):
        first = int(np.argmax(~m.stable[:, j]))
        assert m.stable[:first, j].all() and not m.stable[first:, j].any()
        # the boundary lies in the grid cell that holds the pitchfork
        assert m.A[first - 1] < pitchfork[w] <= m.A[first]
        # unstable through a multiplier at +1 (the tilted orbits branch off): label "T"
        assert set(m.boundary[first:first + 3, j]) == {"T"}
    # the orbit's monodromy is symplectic: det M = 1 decides with the trace, |tr M| ≤ 2
    assert np.all(np.abs(m.trace[m.stable]) <= 2.0)


def test_window_about_the_hanging_orbit_ends_at_the_pitchfork(horizontal, pitchfork):
    w = np.array([30.0, 60.0])
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        win = kapitza.window(horizontal, BASE, [0.0], omega=w, A_range=(0.0, 0.3))
    assert win.status.tolist() == ["window", "window"]
    assert win.A_min.tolist() == [0.0, 0.0]
    for k, wk in enumerate(w):
        assert abs(win.A_max[k] / pitchfork[wk] - 1) < 1e-9
        assert win.accuracy[k] < 1e-9
    # the pendulum's window about the hanging orbit is the same
    pend = KapitzaPendulum(l=L, g=G, drive="horizontal")
    assert pend.window(60.0, "hanging").A_max == pytest.approx(pitchfork[60.0], rel=1e-9)
    with pytest.raises(ValueError, match="horizontal drive.*only the hanging orbit"):
        pend.window(60.0, "tilted")


def test_boundaries_and_adaptive_map_about_the_hanging_orbit(horizontal, pitchfork,
                                                              hanging_map):
    curves = kapitza.boundaries(horizontal, BASE, [0.0], omega=[30.0, 45.0, 60.0],
                                A_range=(0.0, 0.2), seed_every=2)
    assert curves.kind == ("T",) and curves.stable_below.tolist() == [True]
    assert np.allclose(curves.A[0], [pitchfork[w] for w in (30.0, 45.0, 60.0)], rtol=1e-9)
    adaptive = kapitza.adaptive_map(horizontal, BASE, [0.0], A=hanging_map.A,
                                    omega=hanging_map.omega, coarse_step=8)
    assert np.array_equal(adaptive.stable, hanging_map.stable)
    assert adaptive.method == "adaptive, periodic orbit"


def test_map_points_agree_with_periodic_orbit(horizontal, hanging_map):
    """Random points of the map against the orbit solved there on its own (Newton from
    the rest state θ = 0, symmetric shooting), the map's cells at the pitchfork excepted."""
    m = hanging_map
    rng = np.random.default_rng(5)
    points = [(int(rng.integers(1, m.A.size)), int(rng.integers(0, m.omega.size)))
              for _ in range(6)]
    for i, j in points:
        orbit = periodic_orbit(horizontal, dict(BASE, A=m.A[i], omega=m.omega[j]), [0.0])
        assert orbit.stable == m.stable[i, j]
        trace = float(np.sum(orbit.multipliers).real)
        assert trace == pytest.approx(m.trace[i, j], rel=1e-7, abs=1e-9)


def _torque_balance_tilt(A, B, omega, gamma):
    """Averaging's tilt of the damped elliptic pivot on the drag torque's side:
    sin θ [g l + ω²(B² − A²) cos θ / 2] = γωAB/2 (studies/other_drives.py)."""
    k = omega**2 * (B**2 - A**2) / 2
    rhs = gamma * omega * A * B / 2
    th = math.asin(rhs / (G * L + k)) if G * L + k > 0 else math.acos(-G * L / k)
    for _ in range(60):
        f = math.sin(th) * (G * L + k * math.cos(th)) - rhs
        th -= f / (math.cos(th) * G * L + k * math.cos(2 * th))
    return th


def test_elliptic_orbit_agrees_with_periodic_orbit():
    """The damped elliptic pivot (A cos ωt, B sin ωt): no half-period symmetry, dissipative.
    The orbit followed from the hanging state at A = 0 tilts by the drag torque and, past
    ω²(A² − B²) = 2gl, becomes the tilted orbit on the torque's side: the map agrees with
    periodic_orbit from averaging's tilt at every point, tilts of 3e-4 to 1.4 rad."""
    scene = Scene.example("elliptic_damped")
    system, params = scene.system, dict(scene.params)
    A = np.array([0.0, 0.02, 0.06, 0.1])
    omega = np.array([100.0, 150.0])
    m = kapitza.stability_map(system, params, [0.0], A=A, omega=omega)
    assert m.method == "periodic orbit: Newton shooting on the period map, continued over the grid"
    assert m.flagged_points == 0
    tilts = []
    for i in range(1, A.size):
        for j in range(omega.size):
            p = dict(params, A=A[i], omega=omega[j])
            guess = _torque_balance_tilt(A[i], params["B"], omega[j], params["gamma"])
            orbit = periodic_orbit(system, p, [guess])
            tilts.append(float(orbit.q_mean[0]))
            assert orbit.stable == m.stable[i, j]
            trace = float(np.sum(orbit.multipliers).real)
            assert trace == pytest.approx(m.trace[i, j], rel=1e-8)
    assert min(tilts) < 1e-3 and max(tilts) > 1.3
    # damped: the multipliers lie inside the unit circle
    assert np.all(m.log_growth < 0)


def test_tilted_map_is_the_complement_of_the_hanging_map():
    pend = KapitzaPendulum(l=L, g=G, drive="horizontal")
    A = np.linspace(0.02, 0.2, 10)
    omega = np.array([40.0, 80.0])
    hanging = pend.stability_map(A, omega, about="hanging")
    tilted = pend.stability_map(A, omega, about="tilted")
    assert hanging.about == "hanging" and tilted.about == "tilted" and tilted.l == L
    assert np.array_equal(tilted.stable, ~hanging.stable)
    # below the pitchfork there is no tilted orbit: flagged, NaN, never the hanging one's
    none = ~tilted.stable
    assert tilted.flagged_points == int(none.sum()) > 0
    assert np.all(np.isnan(tilted.trace[none])) and np.all(np.isfinite(tilted.trace[~none]))
    assert "no periodic orbit" in tilted.flags_example[0]
    # ... and labelled so: 4, "no orbit" (before: 3, "complex", read as an instability),
    # in the table and drawn apart in the figure, with its legend entry
    assert np.all(tilted.label[none] == 4) and not np.any(tilted.label == 3)
    assert set(tilted.boundary[none]) == {"no orbit"}
    table = tilted.to_dataframe()
    assert (table.boundary == "no orbit").sum() == int(none.sum())
    fig = tilted.figure()
    legend = [t.get_text() for t in fig.axes[0].get_legend().get_texts()]
    assert "no periodic orbit found (undecided)" in legend
    assert "unstable, complex multipliers" not in legend
    # the same map about the tilted orbit given as a kapitza.periodic_orbit result
    orbit = pend.floquet(0.2, 80.0, about="tilted")
    general = kapitza.stability_map(pend.system, BASE, orbit, A=A, omega=omega)
    assert np.array_equal(general.stable, tilted.stable)
    assert general.about.startswith("periodic orbit through [q, q̇]")
    # its long title (the orbit and the method) is wrapped inside the figure, not cut off
    fig = general.figure()
    fig.canvas.draw()
    box = fig.axes[0].title.get_window_extent(fig.canvas.get_renderer())
    assert fig.bbox.x0 - 0.5 <= box.x0 and box.x1 <= fig.bbox.x1 + 0.5
    assert box.y1 <= fig.bbox.y1 + 0.5
    # the mirror image has the same stability
    assert np.array_equal(pend.stability_map(A, omega, about="tilted-").stable, tilted.stable)


def test_a_periodic_orbit_result_names_its_orbit(horizontal, hanging_map):
    """The hanging orbit given as a kapitza.periodic_orbit result (found at A = 6 cm,
    ω = 60 rad/s; symmetric about its mean θ = 0) is followed from there, in ω and then
    in A: the same map as from the rest state θ = 0, to the shooting's accuracy."""
    orbit = periodic_orbit(horizontal, dict(BASE, A=0.06, omega=60.0), [0.0])
    m = kapitza.stability_map(horizontal, BASE, orbit, A=hanging_map.A,
                              omega=hanging_map.omega)
    assert m.about.endswith("(symmetric)") and "half-period" in m.method
    assert np.array_equal(m.stable, hanging_map.stable)
    assert np.max(np.abs(m.trace - hanging_map.trace)) < 1e-8


def test_orbit_map_input_and_interruption(horizontal):
    # no orbit near about: Newton from θ = 1 at A = 0 (the undriven pendulum) goes elsewhere
    with pytest.raises(ValueError, match="does not persist.*no periodic orbit near it"):
        kapitza.stability_map(horizontal, BASE, [1.0], A=[0.0, 0.1], omega=[60.0])
    with pytest.raises(ValueError, match="about must be 1 finite coordinates"):
        kapitza.stability_map(horizontal, BASE, [0.0, 0.0, 0.0], A=[0.1], omega=[60.0])
    with pytest.raises(ValueError, match="'sideways'"):
        KapitzaPendulum(drive="horizontal").stability_map([0.1], [60.0], about="sideways")
    orbit = periodic_orbit(horizontal, dict(BASE, A=0.1, omega=60.0, g=9.0), [1.0],
                           symmetry=None)
    with pytest.raises(ValueError, match="found with g = 9.0"):
        kapitza.stability_map(horizontal, BASE, orbit, A=[0.1], omega=[60.0])
    # Ctrl-C (here from the progress callback) keeps the finished ω columns
    calls = []

    def stop(done, total):
        calls.append(done)
        raise KeyboardInterrupt

    with pytest.raises(ComputationInterrupted) as info:
        kapitza.stability_map(horizontal, BASE, [0.0], A=np.linspace(0, 0.1, 5),
                              omega=[30.0, 40.0, 50.0], progress=stop)
    part = info.value
    assert part.computed[:, 0].all() and not part.computed[:, 1:].any()
    assert np.isfinite(part.result.trace[:, 0]).all()


def test_adaptive_map_labels_points_without_the_orbit_no_orbit():
    """The adaptive map about the tilted orbit of the horizontal drive: below the pitchfork
    there is no tilted orbit, labelled 4 "no orbit" (undecided) as on the uniform map (the
    adaptive one labelled them 3, "complex", read as an instability)."""
    pend = KapitzaPendulum(l=L, g=G, drive="horizontal")
    A = np.linspace(0.02, 0.2, 5)
    omega = np.array([40.0, 80.0])
    orbit = pend.floquet(0.2, 80.0, about="tilted")
    uniform = kapitza.stability_map(pend.system, BASE, orbit, A=A, omega=omega)
    adaptive = kapitza.adaptive_map(pend.system, BASE, orbit, A=A, omega=omega,
                                    coarse_step=2)
    none = uniform.label == 4
    assert none.any() and (~none).any()
    assert np.array_equal(adaptive.label, uniform.label)
    assert np.array_equal(adaptive.stable, uniform.stable)
    assert set(adaptive.boundary[none]) == {"no orbit"}
