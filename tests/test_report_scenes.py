"""The report is right for every scene (issue 22, item 10): each fix checked on the section
that makes it, run on its own (a :class:`kapitza.report._job.Job`, quick sizes), against
independent references — the damped Mathieu monodromy integrated by scipy
(tests/helpers.py), the closed forms of shared/PHYSICS.md.  The whole report of every
shipped scene, opened in a browser, is tests/test_report_browser.py.
"""
import math
import warnings
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

import kapitza
from kapitza.report import _build, _checks, _html, _stability
from kapitza.report._job import Job, Skip, upright

from helpers import G, L, pendulum_monodromy

DATA = Path(__file__).parent / "data"
#: kapitza.floquet.boundaries flags the fast drives' points it certifies only to ~1e-9 (the
#: report shows that flag as a note); the sections run here on their own, so it reaches pytest
pytestmark = pytest.mark.filterwarnings("ignore:boundaries.*certified only:RuntimeWarning")


def _keeping(kept):
    """A ``Job.figure`` that keeps every Figure a section saves in ``kept``, by name, and
    runs Job.figure on it (titles wrapped to fit) but draws no PNG: the tests here read
    the Figure, never the file (a PNG drawn at 150 dpi, ~0.3 CPU-s a figure), and the
    same quick sections of every shipped scene are drawn, saved and opened in
    tests/test_report_browser.py.  (A scene of a test's own keeps its PNG: the test does
    not ask for ``figures``.)"""
    save = Job.figure

    def figure(self, fig, name):
        kept[name] = fig
        fig.savefig = lambda *args, **kwargs: None      # Job.figure's save: no PNG drawn
        return save(self, fig, name)
    return figure


@pytest.fixture
def figures(monkeypatch):
    """Every Figure a section saves, by name (:func:`_keeping`: no PNG drawn)."""
    kept = {}
    monkeypatch.setattr(Job, "figure", _keeping(kept))
    return kept


def _job(tmp_path, scene, quick=True):
    (tmp_path / "figures").mkdir(exist_ok=True)
    (tmp_path / "data").mkdir(exist_ok=True)
    if not isinstance(scene, kapitza.Scene):
        scene = kapitza.Scene.example(scene)
    return Job(scene=scene, out=tmp_path, quick=quick, grid_progress=False)


def _table(job, name):
    return pd.read_parquet(job.tables[name][0])


def _damped_unstable(A, omega, gamma, sign):
    """scipy's verdict (helpers.pendulum_monodromy): |tr M| > 1 + e^(−γT) (PHYSICS.md)."""
    tr = np.trace(pendulum_monodromy(A, omega, sign, gamma=gamma))
    return abs(tr) > 1 + math.exp(-2 * math.pi * gamma / omega)


def _damped_unstable_at(amplitudes, omega, gamma, sign):
    """:func:`_damped_unstable` at each of ``amplitudes`` (one ω), the monodromies of all
    of them integrated in one solve_ivp call (DOP853): the same linearised equation as
    helpers.pendulum_monodromy, θ̈ = −γ θ̇ − sign (g − A ω² cos ωt) θ / l, 200 calls of
    which took 1.3 CPU-s.  solve_ivp holds the root-mean-square of the error estimate over
    all 4 N components within the tolerance, so each amplitude's own (over its 4) could
    be √N times it: the tolerances are divided by √N, each amplitude's step error is held
    to helpers.monodromy's (rtol 1e-12, atol 1e-13) or tighter."""
    from scipy.integrate import solve_ivp
    amplitudes = np.asarray(amplitudes, float)
    n = amplitudes.size
    shrink = math.sqrt(n)

    def f(t, y):            # y: (N, 2, 2), the fundamental matrix of each amplitude
        x = y.reshape(n, 2, 2)
        k = sign * (G - amplitudes * omega**2 * math.cos(omega * t)) / L
        return np.stack([x[:, 1], -k[:, None] * x[:, 0] - gamma * x[:, 1]], 1).ravel()
    period = 2 * math.pi / omega
    sol = solve_ivp(f, (0.0, period), np.tile(np.eye(2), (n, 1, 1)).ravel(),
                    method="DOP853", rtol=1e-12 / shrink, atol=1e-13 / shrink)
    tr = np.trace(sol.y[:, -1].reshape(n, 2, 2), axis1=1, axis2=2)
    return np.abs(tr) > 1 + math.exp(-gamma * period)


# -- the state the report is about --------------------------------------------------------------

def test_a_user_rig_is_about_its_declared_state_not_pi(tmp_path, monkeypatch):
    """The spring pendulum (r in m, θ in rad; tests/data): about = "hanging" is the static
    equilibrium r0 = l0 + m g/k, θ = 0 — not π in every coordinate — with a band and a
    release per coordinate in its unit; the drive pulls r, so the comparisons made about
    an equilibrium say why they do not apply, naming the state."""
    monkeypatch.syspath_prepend(str(DATA))
    scene = kapitza.Scene.from_toml(DATA / "spring_pendulum.toml")
    job = _job(tmp_path, scene)
    r0 = 1.0 + 1.0 * 9.81 / 40.0                          # l0 + m g / k
    np.testing.assert_allclose(job.about, [r0, 0.0], rtol=1e-6)
    assert upright(job) == "r = 1.245 m, θ = 0"
    band = job.band()
    assert band["r"] == pytest.approx(0.5 * r0, rel=1e-6)
    assert band["theta"] == pytest.approx(math.pi / 2)
    np.testing.assert_allclose(job.release(0.1), [1.01 * r0, -0.1], rtol=1e-6)
    # r̈ = (g − A ω² cos ωt) cos θ + ... at the state: the drive moves it
    assert not job.persists
    for section in (_checks.slow_section, _checks.verification_section):
        with pytest.raises(Skip, match=r"drive moves the hanging state r = 1\.245 m"):
            section(job)


def test_the_default_scene_stays_upright(tmp_path):
    job = _job(tmp_path, "report")
    np.testing.assert_allclose(job.about, [math.pi])
    assert job.pend_about == "inverted" and job.upright_state and job.persists
    assert upright(job) == "θ = π"


# -- the map: tongues as curves, the window's low end computed ---------------------------------

def test_hanging_state_tongue_drawn_as_a_curve(tmp_path, figures):
    """period_doubling.toml is about the hanging state (its continuation's about): the map
    is of θ = 0, its parametric-resonance tongue at ω = 2ω0 traced by
    kapitza.floquet.boundaries and drawn as a line (no contour of grid cells), its points
    on the damped Floquet condition |tr M| = 1 + e^(−γT) of scipy's monodromy."""
    job = _job(tmp_path, "period_doubling")
    gamma = job.scene.params["gamma"]
    result = _stability.map_section(job)
    assert job.pend_about == "hanging"
    assert "hanging state θ = 0" in result.caption and "cannot see" in result.caption
    curves = job.state["curves"]
    assert "2T" in curves.kind
    tongue = np.asarray(curves.A, float)[list(curves.kind).index("2T")]
    w = np.asarray(curves.omega, float)
    ok = np.flatnonzero(np.isfinite(tongue))
    assert ok.size > 10
    for k in ok[:: max(1, ok.size // 4)]:
        a = tongue[k]
        assert _damped_unstable(1.001 * a, w[k], gamma, +1) != \
            _damped_unstable(0.999 * a, w[k], gamma, +1), (w[k], a)
    # its lowest point is the period doubling of the damped hanging pendulum at 2ω0
    ref = kapitza.pendulum_window(job.omega, l=1.0, g=9.81, damping=gamma, about="hanging")
    assert np.nanmin(tongue) == pytest.approx(float(ref.A_max), rel=0.02)
    ax = figures["stability_map"].axes[0]
    assert not any("Contour" in type(c).__name__ for c in ax.collections)   # no staircase
    lines = [ln for ln in ax.lines if "period-2T boundary" in ln.get_label()]
    assert lines
    np.testing.assert_allclose(np.asarray(lines[0].get_ydata(), float), tongue,
                               equal_nan=True)
    legend = [t.get_text() for t in ax.get_legend().get_texts()]
    assert "exact period-2T boundary (multiplier −1)" in legend
    assert not any(t.startswith("unstable, period") for t in legend)


def test_a_thin_tongue_sampled_by_one_column_is_traced_whole(tmp_path, figures):
    """The undamped hanging pendulum's second tongue (ω ≈ ω0, a period-T resonance) is
    about 2 % wide in ω at A = 0.3 m: a map whose column at 0.995 ω0 is the only one
    inside it shows it one cell wide.  The report traces its boundaries across that
    column on a finer ω grid and draws them as curves: several frequencies each, every
    point on scipy's Floquet condition tr M = 2."""
    scene = kapitza.Scene.from_text(
        'schema = 1\n[system]\nname = "pendulum"\n[parameters]\nl = 1.0\ng = 9.81\n'
        '[effects]\ngravity = true\n[effects.drive]\ndirection = "vertical"\n'
        'amplitude = 0.2\nomega = 3.1\n[initial]\ntheta = 0.1\n'
        '[analyses]\nfloquet = { about = "hanging" }\n', "thin.toml")
    job = _job(tmp_path, scene)
    w0 = math.sqrt(9.81)
    A = np.linspace(0.0, 0.3, 13)
    w = w0 * np.array([0.6, 0.75, 0.9, 0.995, 1.1, 1.3, 1.6, 1.9, 2.3])
    result, fig, caption = _stability._curves_map(job, A, w, False)
    assert 3 in _stability._one_column_features(result)
    local = [c for c in job.state["overlays"][1:] if hasattr(c, "kind")]
    assert local and "T" in local[0].kind, caption
    assert "one column wide were traced" in caption
    traced = local[0]
    for Ak in np.asarray(traced.A, float):
        ok = np.flatnonzero(np.isfinite(Ak))
        assert ok.size >= 3                                 # a curve, not one point
        for k in ok[:: max(1, ok.size // 3)]:
            tr = [np.trace(pendulum_monodromy(f * Ak[k], traced.omega[k], +1))
                  for f in (0.999, 1.001)]
            assert (tr[0] - 2) * (tr[1] - 2) < 0, (traced.omega[k], Ak[k], tr)


def test_damped_window_without_holes_and_the_maps_edge_named(tmp_path, figures):
    """kapitza_pendulum.toml (γ = 0.5 1/s): the exact window is defined at every ω above
    where it first exists — the damped closed form returned none at scattered thin-window
    frequencies — its edges on scipy's |tr M| = 1 + e^(−γT); the caption calls the map's
    lowest ω the map's lower edge (the window goes on below it), not "the lowest ω with
    a window"."""
    job = _job(tmp_path, "kapitza_pendulum")
    gamma = job.scene.params["gamma"]
    result = _stability.map_section(job)
    win = _table(job, "window")
    finite = np.isfinite(win.A_min_exact.to_numpy())
    assert finite[0] and finite.all()
    for row in win.iloc[[0, 3, 10, len(win) // 2]].itertuples():
        for edge in (row.A_min_exact, row.A_max_exact):
            assert _damped_unstable(1.0001 * edge, row.omega, gamma, -1) != \
                _damped_unstable(0.9999 * edge, row.omega, gamma, -1), row
    assert "lowest ω with a window" not in result.caption
    assert f"At the map's lower edge, ω = {win.omega.iloc[0]:.3g} rad/s" in result.caption


def test_where_the_window_leaves_the_map_is_computed_not_read_off_the_grid(tmp_path):
    """A damped map whose lowest frequencies hold no window inside its amplitudes (up to
    4 m): the caption gives the frequency below which the window lies above the map,
    located by bisection to 1e-6.  scipy's monodromy: just above it a stable amplitude
    below 4 m (the window's middle); just below it (0.1 % lower) none in a dense scan of
    the map's top 5 %, while kapitza.floquet.window there, searched higher, finds the
    window above 4 m."""
    import re
    text = (DATA.parent.parent / "kapitza" / "scenes" / "kapitza_pendulum.toml").read_text()
    text += ('stability_map = { A = { start = 0.5, stop = 4.0, num = 24, scale = "log" }, '
             'omega = { start = 1.5, stop = 20.0, num = 24, scale = "log" }, '
             'about = "inverted" }\n')
    job = _job(tmp_path, kapitza.Scene.from_text(text, "onset.toml"))
    gamma = job.scene.params["gamma"]
    caption = _stability.map_section(job).caption
    found = re.search(r"Below ω = ([0-9.]+) rad/s .* lies above the map's highest amplitude, "
                      r"4 m", caption)
    assert found, caption
    assert "lowest ω with a window" not in caption and "opens" not in caption
    edge = float(found.group(1))
    above = kapitza.floquet.window(job.scene.system, job.fixed, [math.pi],
                                   omega=edge * 1.001, A_range=(0.0, 4.0))
    middle = 0.5 * (float(above.A_min) + float(above.A_max))
    assert middle < 4.0 and not _damped_unstable(middle, edge * 1.001, gamma, -1)
    below = edge * 0.999
    scan = np.linspace(3.8, 4.0, 200)
    assert _damped_unstable_at(scan, below, gamma, -1).all()
    higher = kapitza.floquet.window(job.scene.system, job.fixed, [math.pi], omega=below,
                                    A_range=(0.0, 8.0))
    assert 4.0 < float(higher.A_min) < float(higher.A_max)


# -- legends and the spot checks' growth ------------------------------------------------------

def _pixels(fig):
    fig.canvas.draw()
    return np.asarray(fig.canvas.buffer_rgba()).copy()


def invisible_legend_lines(fig):
    """Legend entries of the first axes whose lines change no pixel of the drawn figure when
    hidden (drawn under another line, or outside the axes).  The figure is laid out by its
    first draw only: each redraw with a line hidden keeps that layout (the layout engine
    off, restored after), so that the pixels compared differ by the line alone, and a
    redraw runs no layout."""
    ax = fig.axes[0]
    base = _pixels(fig)
    engine = fig.get_layout_engine()
    fig.set_layout_engine(None)
    bad = []
    try:
        for label in [t.get_text() for t in ax.get_legend().get_texts()]:
            lines = [ln for ln in ax.lines if ln.get_label() == label
                     or ln.get_label() == "_" + label]
            if not lines:
                continue
            for ln in lines:
                ln.set_visible(False)
            changed = int(np.any(_pixels(fig) != base, axis=-1).sum())
            for ln in lines:
                ln.set_visible(True)
            if changed < 30:
                bad.append(f"{label}: {changed} px")
    finally:
        fig.set_layout_engine(engine)
    return bad


@pytest.fixture(scope="module")
def double_pendulum_map(tmp_path_factory):
    """The map section of double_pendulum.toml (quick), run once for the two tests that read
    it: (its job, the figure it saved; :func:`_keeping`: no PNG drawn)."""
    job = _job(tmp_path_factory.mktemp("double-pendulum-map"), "double_pendulum")
    kept = {}
    with pytest.MonkeyPatch.context() as mp, warnings.catch_warnings():
        warnings.filterwarnings("ignore", "boundaries.*certified only", RuntimeWarning)
        mp.setattr(Job, "figure", _keeping(kept))
        _stability.map_section(job)
    return job, kept["stability_map"]


def test_map_legend_in_physics_words_every_entry_visible(double_pendulum_map):
    """Acheson's double pendulum: averaging's window edge runs along the exact period-T
    boundary; drawn over it, both entries show (under it, the dashed line was hidden);
    the legend speaks of period-T/2T boundaries and their multipliers."""
    _, fig = double_pendulum_map
    assert invisible_legend_lines(fig) == []
    legend = [t.get_text() for t in fig.axes[0].get_legend().get_texts()]
    assert "exact period-T boundary (multiplier +1)" in legend
    assert "exact period-2T boundary (multiplier −1)" in legend
    assert "unstable: real multiplier > +1 (period-T)" in legend
    assert not any(type(c).__name__.endswith("ContourSet") for c in fig.axes[0].collections)


def test_spot_check_growth_never_overflows(tmp_path, double_pendulum_map):
    """The growth of the linear instability over a spot check's run is kept as its log10
    (e^(log|μ| · periods) overflows a float for a strongly unstable point), agreeing with
    kapitza.floquet_point at each point; no numpy warning is raised."""
    from kapitza.report import _spots
    # the scene's 2000 periods (not quick): far beyond 1e308 where unstable; on the quick
    # map, handed over as the report hands it (job.state), in a job of this test's own
    job = _job(tmp_path, "double_pendulum", quick=False)
    job.state.update(double_pendulum_map[0].state)
    with warnings.catch_warnings():
        warnings.simplefilter("error", RuntimeWarning)
        _spots.spots_section(job)
    spots = _table(job, "spot_checks")
    log10 = spots.floquet_log10_growth_over_run.to_numpy()
    assert np.isfinite(log10).all() and log10.max() > 308         # beyond a float's range
    for row in spots.itertuples():
        point = kapitza.floquet_point(job.scene.system,
                                      {**job.fixed, "A": row.A, "omega": row.omega},
                                      job.about)
        expected = max(float(point.log_growth), 0.0) * row.periods / math.log(10)
        assert max(row.floquet_log10_growth_over_run, 0.0) == pytest.approx(
            expected, rel=1e-6, abs=1e-6)
    assert _spots.growth_text(400.0) == "10^400 (> 1e300)"
    assert _spots.growth_text(2.0) == "100"


# -- the effective potential at the scene's order, and without a closed form -------------------

def test_potential_at_the_scenes_averaging_order(tmp_path, figures):
    """report.toml asks for averaging of order 2: the equilibria and the caption carry the
    order-2 Ω, which lies within 0.5 % of scipy's Floquet Ω (cos πβ = tr M/2), where
    first order is 2.8 % off."""
    from kapitza.report import _potential
    job = _job(tmp_path, "report")
    result = _potential.potential_section(job)
    eqs = _table(job, "averaged_equilibria").set_index("state")
    second = eqs.omega_slow_averaging_2["inverted"]
    first = eqs.omega_slow_averaging_1["inverted"]
    tr = np.trace(pendulum_monodromy(job.A, job.omega, -1))
    exact = job.omega / 2 * math.acos(tr / 2) / math.pi
    assert abs(second / exact - 1) < 0.005 < abs(first / exact - 1)
    assert "averaging of order 2" in result.caption and f"{second:.4g} rad/s" in result.caption
    title = figures["effective_potential"].axes[0].get_title()
    assert "next-order averaging" in title


def test_potential_of_the_elliptic_pivot(tmp_path, figures):
    """elliptic_damped.toml has no closed-form U_eff in kapitza: the general averaging draws
    it, and the hanging state's tilt by the mean drag solves PHYSICS.md's
    sin θ [g l + ω²(B² − A²) cos θ / 2] = γ ω A B / 2; the periodic orbit's mean agrees."""
    from kapitza.report import _potential
    job = _job(tmp_path, "elliptic_damped")
    result = _potential.potential_section(job)
    p = job.scene.params
    eqs = _table(job, "averaged_equilibria")
    tilt = float(eqs.theta[eqs.stable].iloc[0])

    def balance(th):
        return (math.sin(th) * (p["g"] * p["l"] + p["omega"] ** 2 * (p["B"] ** 2 - p["A"] ** 2)
                                * math.cos(th) / 2) - p["gamma"] * p["omega"] * p["A"] * p["B"] / 2)
    from scipy.optimize import brentq
    assert tilt == pytest.approx(brentq(balance, 0.0, 0.1), rel=1e-3)
    assert job.numbers["orbit_mean"] == pytest.approx(tilt, rel=0.01)
    assert "periodic orbit" in result.caption and "nan" not in result.caption


def test_potential_caption_without_nan_when_floquet_finds_the_state_unstable(tmp_path,
                                                                             figures):
    """period_doubling.toml's drive is inside the hanging state's tongue: the caption says
    Floquet finds it unstable (period-2T, the largest multiplier from scipy's monodromy)
    instead of writing Ω = nan."""
    from kapitza.report import _potential
    job = _job(tmp_path, "period_doubling")
    caption = _potential.potential_section(job).caption
    import re
    assert not re.search(r"\bnan\b|n/a", caption), caption
    mu = np.linalg.eigvals(pendulum_monodromy(job.A, job.omega, +1,
                                              gamma=job.scene.params["gamma"]))
    assert f"|multiplier| {np.abs(mu).max():.4g}" in caption
    assert "period-2T" in caption


# -- the page ---------------------------------------------------------------------------------

def test_page_numbers_to_four_digits_tables_in_a_scrolling_wrapper():
    assert _html._fmt(3.4852e95) == "3.485e+95" and _html._fmt(0.14104) == "0.141"
    assert _html._fmt(1234.5678) == "1235" and _html._fmt(2.5e-7) == "2.500e-7"
    assert _html._fmt(float("nan")) == "—" and _html._fmt(0.0) == "0"
    table = _html._html_table(pd.DataFrame({"a": [1.0], "b": ["x"]}))
    assert table.startswith("<div class=tw><table>") and ".tw{" in _html._CSS
    assert "overflow-x:auto" in _html._CSS.split(".tw{")[1].split("}")[0]


def test_notes_give_the_message_not_pythons_category():
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        warnings.warn("boundaries: 3 of 40 frequencies ...", RuntimeWarning, stacklevel=1)
        warnings.warn("outside validity", kapitza.averaging.AveragingValidityWarning,
                      stacklevel=1)
    notes = [_build._note(w) for w in caught]
    assert notes == ["boundaries: 3 of 40 frequencies ...",
                     "AveragingValidityWarning: outside validity"]
