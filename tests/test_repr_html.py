"""Results in Jupyter (issue 23.2): every result type has a compact ``_repr_html_`` — valid,
escaped HTML of bounded size, the headline numbers with their units, warnings visible, a
thumbnail for a grid (drawn within a bounded time) — and a ``figure()`` where a picture
is the natural summary."""
import base64
import dataclasses
import html.parser
import inspect
import time

import numpy as np
import pytest
from matplotlib.figure import Figure
from small_results import BUILDERS, SWEEP_AXES, result

import kapitza
import kapitza.results
from kapitza.results import _display

from helpers import pendulum_scene

#: Size bounds of a card (bytes): the table alone, and with its thumbnail (a PNG of
#: THUMBNAIL_PIXELS across, base64).
TABLE_BYTES, THUMBNAIL_BYTES = 8_000, 60_000
#: A card's drawing time bound (s) under a loaded 2-core machine (measured: 0.1–0.4 s for
#: a map's thumbnail, 1–1.7 s for the verification's two-panel figure, at load 5–8).
SECONDS = 4.0
#: What each case's card must say (the headline numbers' units, the flags).
EXPECTED = {
    "stability_map": ["0 … 0.3 m (12 values)", "20 … 200 rad/s (15 values)", "stable",
                      "m/s²"],
    "window": ["A_min", "A_max", " m (12 values)", "rad/s"],
    "window_averaging": ["outside validity", "fails: fast drive"],
    "floquet_point": ["0.03142 s", "rad/s", "stable"],
    "measurement": ["rad/s ± ", "1/s", "stayed"],
    "measurement_grid": ["0.02 … 0.1 m (3 values)", "150 … 250 rad/s (2 values)"],
    "periodic_orbit": ["theta = 1.36", " rad", "rad/s"],
    "pendulum_averaging_one": ["0.05 m", "30 rad/s", "unstable", "does not exist"],
    "verification": ["agree on stability", "p = 2.0", "theory 2"],
    "branch": ["max_points", "stopped early"],
    "lyapunov_spectrum": ["1/s ± "],
    "slow_modes": ["q = (π)", "rad/s"],
}


#: Cases whose card shows a thumbnail (grids), and cases of one point (none).
WITH_THUMBNAIL = ("stability_map", "adaptive_map", "window", "boundaries", "floquet_grid",
                  "measurement_grid", "verification", "branch", "lyapunov_grid", "basin")
WITHOUT_THUMBNAIL = ("floquet_point", "measurement", "periodic_orbit", "lyapunov_spectrum",
                     "slow_modes", "pendulum_averaging_one", "equilibrium_prediction")


class _Checker(html.parser.HTMLParser):
    """Parses a card and records what is wrong with it: a closing tag that does not match
    the open one, a tag left open."""

    VOID = {"img", "br", "hr", "meta", "input"}

    def __init__(self):
        super().__init__(convert_charrefs=True)
        self.stack, self.problems, self.images, self.text = [], [], [], []

    def handle_starttag(self, tag, attrs):
        if tag == "img":
            self.images.append(dict(attrs))
        if tag not in self.VOID:
            self.stack.append(tag)

    def handle_endtag(self, tag):
        if not self.stack or self.stack.pop() != tag:
            self.problems.append(f"</{tag}> closes nothing open")

    def handle_data(self, data):
        self.text.append(data)


def _parse(markup):
    checker = _Checker()
    checker.feed(markup)
    checker.close()
    assert not checker.problems and not checker.stack, (checker.problems, checker.stack)
    return checker


def test_every_public_result_type_has_a_card_and_a_case_here():
    types = [getattr(kapitza.results, n) for n in kapitza.results.__all__
             if n != "ComputationInterrupted"]
    types += [kapitza.SweepResult, kapitza.SceneResults]
    missing = [t.__name__ for t in types if not callable(getattr(t, "_repr_html_", None))]
    assert not missing, f"no _repr_html_: {missing}"
    covered = {type(result(name)).__name__ for name in BUILDERS}
    untested = {t.__name__ for t in types} - covered - {"SweepResult", "SceneResults",
                                                         "BranchPoints", "Bifurcation"}
    assert not untested, f"no case in tests/small_results.py: {untested}"
    # the parts of a branch (the sweep's and the scene's cards: test_sweep_and_scene_cards)
    points = "".join(_parse(result("branch").points._repr_html_()).text)
    assert points.startswith("BranchPoints") and "8 of 8 points" in points
    fold = kapitza.Bifurcation(kind="fold", parameter=0.25, accuracy=3e-9, state=np.zeros(2),
                               multipliers=np.array([1.0 + 0j, 0.4 + 0j]), index=3, periods=1,
                               test_function="det(M − I)", note="<probe undecided>")
    text = "".join(_parse(fold._repr_html_()).text)
    assert "0.25 ± 3e-09" in text and "<probe undecided>" in text


@pytest.mark.parametrize("name", list(BUILDERS))
def test_a_card_is_valid_bounded_and_shows_its_numbers(name):
    r = result(name)
    t0 = time.perf_counter()
    markup = r._repr_html_()
    seconds = time.perf_counter() - t0
    page = _parse(markup)
    text = "".join(page.text)
    assert text.startswith(type(r).__name__)
    for expected in EXPECTED.get(name, []):
        assert expected in text, f"{name}: {expected!r} not in {text!r}"
    assert seconds < SECONDS, f"{name}: the card took {seconds:.2f} s"
    if page.images:
        (img,) = page.images
        assert len(markup) < THUMBNAIL_BYTES
        assert img["src"].startswith("data:image/png;base64,") and img["alt"]
        png = base64.b64decode(img["src"].split(",", 1)[1])
        assert png[:8] == b"\x89PNG\r\n\x1a\n"
        assert int(img["width"]) == _display.THUMBNAIL_PIXELS
        assert len(markup) - len(img["src"]) < TABLE_BYTES
    else:
        assert len(markup) < TABLE_BYTES
    if name in WITH_THUMBNAIL:
        assert page.images, f"{name}: a grid's card has a thumbnail"
    if name in WITHOUT_THUMBNAIL:
        assert not page.images, f"{name}: one point's card has no thumbnail"


def test_text_is_escaped():
    m = dataclasses.replace(result("stability_map"), about="<script>alert('x')</script>",
                            flagged_points=2, flags_example=("a < b & c",))
    markup = m._repr_html_()
    assert "<script>" not in markup and "&lt;script&gt;" in markup
    assert "a &lt; b &amp; c" in markup
    _parse(markup)


def test_warnings_and_flags_are_visible():
    flagged = dataclasses.replace(result("floquet_point"), flags=("pairing residual 1e-3",))
    markup = flagged._repr_html_()
    assert "⚠ pairing residual 1e-3" in markup and "flagged" in markup
    assert _display._TONES["warn"][0] in markup.split(">", 1)[0]   # the card's amber edge
    clean = result("floquet_point")._repr_html_()
    assert "⚠" not in clean and _display._TONES["warn"][0] not in clean.split(">", 1)[0]
    # averaging outside its validity says so at the top of the card
    assert "outside validity" in result("window_averaging")._repr_html_().split("<table", 1)[0]
    orbit = dataclasses.replace(result("periodic_orbit"), flags=("ill-conditioned",))
    assert "⚠ ill-conditioned" in orbit._repr_html_()


def test_thumbnails_can_be_turned_off_and_a_failing_figure_leaves_a_note(monkeypatch):
    monkeypatch.setattr(_display, "THUMBNAILS", False)
    assert "<img" not in result("stability_map")._repr_html_()
    monkeypatch.setattr(_display, "THUMBNAILS", True)

    def broken(*args, **options):
        raise RuntimeError("no canvas")

    monkeypatch.setattr(_display, "draw", broken)
    markup = result("window")._repr_html_()        # does not raise
    assert "<img" not in markup and "no thumbnail: RuntimeError: no canvas" in markup


@pytest.mark.parametrize("name", ["stability_map", "adaptive_map", "window", "boundaries",
                                  "ince_strutt_chart", "floquet_grid", "measurement_grid",
                                  "verification", "branch", "lyapunov_grid",
                                  "bifurcation_diagram", "poincare_section", "basin"])
def test_figure_where_a_picture_is_the_summary(name, tmp_path):
    fig = result(name).figure()
    assert isinstance(fig, Figure) and fig.axes
    fig.savefig(tmp_path / f"{name}.png", dpi=40)


def test_the_new_figures_draw_what_they_are_given():
    w = result("window")
    ax = w.figure().axes[0]
    lines = {line.get_label(): line for line in ax.lines}
    np.testing.assert_array_equal(lines["A_min"].get_ydata(), w.A_min)
    np.testing.assert_array_equal(lines["A_max"].get_ydata(), w.A_max)
    b = result("boundaries")
    ax = b.figure().axes[0]
    assert len(ax.lines) == len(b.kind)
    m = result("measurement_grid")
    ax = m.figure().axes[0]
    assert ax.get_xlabel().startswith("drive angular frequency") and "(m)" in ax.get_ylabel()
    mesh = ax.collections[0]
    drawn = np.ma.filled(mesh.get_array(), np.nan).reshape(3, 2)
    want = np.where(m.stayed_up, m.omega_slow, np.nan)
    np.testing.assert_array_equal(np.isnan(drawn), np.isnan(want))
    np.testing.assert_allclose(drawn[~np.isnan(drawn)], want[~np.isnan(want)])
    with pytest.raises(ValueError, match="one point has no figure"):
        result("measurement").figure()
    with pytest.raises(ValueError, match="variable must be one of"):
        m.figure("nonsense")


def test_sweep_and_scene_cards(tmp_path):
    scene = kapitza.Scene.from_text(pendulum_scene(
        theta=3.1, analyses="measure = { periods = 100 }", axes=SWEEP_AXES,
        sweep="tile_points = 6"))
    res = scene.sweep(directory=tmp_path, progress=False)
    page = _parse(res._repr_html_())
    text = "".join(page.text)
    assert "12 of 12" in text and "100 … 300 rad/s (3 values), log" in text
    assert len(page.images) == 1
    assert isinstance(res.figure(), Figure) and isinstance(res.figure("fall_time"), Figure)
    run = kapitza.SceneResults(scene=scene, results={"window": result("window")},
                               sweeps={"measure": res}, methods={"window": "floquet: exact"})
    text = "".join(_parse(run._repr_html_()).text)
    assert "StabilityWindow — floquet: exact" in text and "12 points" in text


def test_cards_are_declared_not_inherited_by_accident():
    """Each result type states its own card (a subclass's title is its own name)."""
    for cls in (kapitza.AdaptiveMap, kapitza.FloquetGrid):
        assert "_repr_html_" in vars(cls)
    assert inspect.signature(kapitza.StabilityMap._repr_html_).parameters.keys() == {"self"}
