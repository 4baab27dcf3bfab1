"""Figures (issue 10, item 15): titles that fit, dimensionless and logarithmic axes,
boundaries as lines, the effective potential with its equilibria marked.  The figures
draw results; the values drawn are checked against the results they were given.  They
read results by their fields and never import them (issue 20): a stand-in with the
fields draws, anything else is refused naming the result type."""
import math

import numpy as np
import pytest

import kapitza
from kapitza import KapitzaPendulum, figures

L, G = 0.5, 9.81
W0 = math.sqrt(G / L)


@pytest.fixture(scope="module")
def pend():
    return KapitzaPendulum(l=L, g=G)


def _inside(fig, artist):
    fig.canvas.draw()
    box = artist.get_window_extent(fig.canvas.get_renderer())
    frame = fig.bbox
    return (box.x0 >= frame.x0 - 0.5 and box.x1 <= frame.x1 + 0.5
            and box.y0 >= frame.y0 - 0.5 and box.y1 <= frame.y1 + 0.5)


def test_dimensionless_log_axes_and_boundaries(pend):
    omega = np.geomspace(3 * W0, 300 * W0, 120)
    m = pend.stability_map(np.linspace(0.001, 0.35, 90), omega)
    avg = pend.window(omega, method="averaging", order=1)
    fig = figures.stability_map_figure(m, overlays=[avg], dimensionless=True, log_omega=True)
    ax = fig.axes[0]
    assert ax.get_xscale() == "log" and "ω/ω0" in ax.get_xlabel() and "A/l" in ax.get_ylabel()
    np.testing.assert_allclose(ax.get_xlim(), (omega[0] / W0, omega[-1] / W0), rtol=1e-12)
    np.testing.assert_allclose(ax.get_ylim(), (0.001 / L, 0.35 / L), rtol=1e-12)
    # the averaging limit A ω = √(2 g l) drawn in A/l against ω/ω0: (A/l)(ω/ω0) = √2
    line = next(li for li in ax.lines if li.get_label().startswith("averaging"))
    x, y = line.get_data()
    np.testing.assert_allclose(np.asarray(x) * np.asarray(y), math.sqrt(2), rtol=1e-12)
    # the stable/unstable boundary is drawn as a line (a contour set)
    assert any(type(c).__name__ in ("QuadContourSet", "ContourSet", "PathCollection",
                                    "LineCollection") for c in ax.collections[1:])
    assert _inside(fig, ax.title)


def test_log_axis_from_zero_and_dimensionless_without_constants_are_refused(pend):
    m = pend.stability_map(np.linspace(0.0, 0.3, 10), np.linspace(10.0, 100.0, 10))
    with pytest.raises(ValueError, match="log_A=True needs positive values"):
        figures.stability_map_figure(m, log_A=True)
    general = kapitza.results.StabilityMap(
        A=m.A, omega=m.omega, stable=m.stable, label=m.label, trace=None, log_growth=None,
        error_estimate=0.0, about="[3.141592653589793, 0.0]", method="monodromy")
    with pytest.raises(ValueError, match="pass l=... .* and g="):
        figures.stability_map_figure(general, dimensionless=True)
    fig = figures.stability_map_figure(general, dimensionless=True, l=L, g=G)
    assert "q = (π, 0)" in fig.axes[0].get_title()
    assert _inside(fig, fig.axes[0].title)


def test_effective_potential_marks_the_equilibria(pend):
    A, omega = 0.04, 2 * math.pi * 50
    theta = np.linspace(-math.pi, 2 * math.pi, 901)
    U = kapitza.pendulum_effective_potential(A, omega, theta=theta, l=L, g=G)
    pred = kapitza.pendulum_averaged(A, omega, l=L, g=G)
    fig = figures.effective_potential_figure(theta, U, prediction=pred)
    ax = fig.axes[0]
    names = sorted({t.get_text() for t in ax.texts})
    assert names == sorted(e.name for e in pred.equilibria if bool(np.all(e.exists)))
    for text in ax.texts:              # each mark sits on the curve, at its equilibrium
        th, u = text.xy
        eq = pred[text.get_text()]
        assert math.cos(th) == pytest.approx(math.cos(float(eq.theta)), abs=1e-12)
        assert u == pytest.approx(float(np.interp(th, theta, U)), rel=1e-12)
    assert _inside(fig, ax.title)
    with pytest.raises(ValueError, match="same length"):
        figures.effective_potential_figure(theta, U[:-1])


def test_figures_read_results_by_their_fields(pend):
    """Figures never import kapitza.results: any object with a result's fields draws, and
    anything else is refused with the result type expected and the fields it lacks."""
    from types import SimpleNamespace
    m = pend.stability_map(np.linspace(0.0, 0.3, 12), np.linspace(10.0, 100.0, 14))
    fields = {f: getattr(m, f) for f in m.__dataclass_fields__}
    twin = figures.stability_map_figure(SimpleNamespace(**fields))
    fig = figures.stability_map_figure(m)
    assert twin.axes[0].get_title() == fig.axes[0].get_title()
    with pytest.raises(TypeError, match=r"result must be a kapitza.results.StabilityMap, got "
                                        r"DataFrame \(it has no label, about, method"):
        figures.stability_map_figure(m.to_dataframe())
    with pytest.raises(TypeError, match="every overlay must be a kapitza.results.StabilityWindow"):
        figures.stability_map_figure(m, overlays=[m])
    with pytest.raises(TypeError, match="Verification, got StabilityMap"):
        figures.verification_figure(m)
    with pytest.raises(TypeError, match="InceStruttChart, got StabilityMap"):
        figures.ince_strutt_figure(m)


def test_boundary_curves_and_windows_are_told_apart(pend):
    """Overlays of both kinds on one map: a window as black dashed edges, boundary curves
    as solid lines coloured by kind (one legend entry per kind)."""
    omega = np.linspace(20.0, 120.0, 40)
    m = pend.stability_map(np.linspace(0.001, 0.2, 30), omega)
    exact = pend.window(omega)
    curves = kapitza.BoundaryCurves(
        omega=omega, A=np.vstack([exact.A_min, exact.A_max]),
        accuracy=np.full((2, omega.size), 1e-10), kind=("T", "2T"),
        stable_below=np.array([False, True]), about="inverted")
    avg = pend.window(omega, method="averaging", order=1)
    ax = figures.stability_map_figure(m, overlays=[avg, curves]).axes[0]
    labels = [t.get_text() for t in ax.get_legend().get_texts()]
    assert "averaging (order 1): A ω = √(2 g l)" in labels
    assert {"exact boundary: multiplier +1 (T)",
            "exact boundary: multiplier −1 (2T)"} <= set(labels)
    solid = [li for li in ax.lines if li.get_label().startswith("exact boundary")]
    np.testing.assert_array_equal(solid[0].get_ydata(), exact.A_min)


def _within(fig):
    """Whether everything drawn (titles, labels, legends) lies within the figure (inches)."""
    tight, frame = fig.get_tightbbox(), fig.bbox_inches
    return (tight.x0 >= frame.x0 - 0.01 and tight.x1 <= frame.x1 + 0.01
            and tight.y0 >= frame.y0 - 0.01 and tight.y1 <= frame.y1 + 0.01)


def test_long_titles_are_wrapped_never_cut(pend):
    """Issue 22.10: a title longer than the figure is wrapped (a short parenthesis such as
    "(π, π)" and "θ = π" kept whole), by the figure functions themselves and, for any
    figure, by figures.fit_texts (the report runs it on every figure it saves)."""
    theta = np.linspace(-np.pi, 2 * np.pi, 300)
    U = kapitza.pendulum_effective_potential(0.05, 150.0, theta=theta)
    long = ("Spot checks by direct simulation on the Floquet map of the upright state of a "
            "chain, q = (π, π), at θ = π")
    fig = figures.effective_potential_figure(theta, U, title=long)
    assert _within(fig)
    title = fig.axes[0].get_title()
    assert "\n" in title and "(π, π)" in title and "θ = π" in title
    m = pend.stability_map(np.linspace(0.01, 0.3, 8), np.geomspace(10.0, 100.0, 8))
    fig = figures.stability_map_figure(m, title=long)
    fig.canvas.draw()
    assert not _within(fig)                          # as drawn by the caller's title: cut
    assert figures.fit_texts(fig) and _within(fig)
    assert figures.fit_texts(fig) == []              # once fitted, left alone


def test_a_title_is_wrapped_exactly_when_the_drawn_figure_cuts_it():
    """For titles of 4 to 31 words, on a plain panel and on a panel with a colour bar (the
    layout moves its centre), fit_texts wraps the title exactly when the drawn figure cuts
    it unwrapped — its quick check skips no title that needs it — and no title is cut
    afterwards.  Beside the colour bar the equal-aspect panel shrinks as its title grows:
    when each round wrapped the wrapped title again, the longest title was broken into
    single words ("inverted", "state") and still cut."""
    import matplotlib.pyplot as plt
    words = ("the slow frequency of the inverted state q = (π, π) of a damped chain of "
             "two links driven at ω = 60 Hz measured by direct simulation over many periods")
    for colorbar in (False, True):
        # 4 and 9 words: passed by the quick check; 14: measured, fits on the plain panel
        # and is cut beside the colour bar; all 31: cut
        for n in (4, 9, 14, len(words.split())):
            text = " ".join(words.split()[:n])
            fig, ax = plt.subplots(figsize=(6, 3), layout="constrained")
            image = ax.imshow(np.eye(3))
            if colorbar:
                fig.colorbar(image, ax=ax)
            ax.set_title(text)
            fig.canvas.draw()
            cut = not _within(fig)
            changed = figures.fit_texts(fig)
            fig.canvas.draw()
            assert bool(changed) == cut, (colorbar, text)
            assert _within(fig), (colorbar, text)
            plt.close(fig)


def test_save_png_draws_the_pixels_savefig_draws(pend, tmp_path):
    """The report saves its figures with figures.save_png (the layout run once at the
    file's resolution, then one draw): the same pixels as ``savefig`` (which lays out in a
    draw pass of its own first), each from a figure made afresh (a constrained layout
    starts from the positions of the last one), for a map with its colorbar and a wrapped
    title and a curve with its legend below; the figure's engine and resolution are as
    before."""
    from matplotlib.image import imread
    m = pend.stability_map(np.linspace(0.01, 0.3, 8), np.geomspace(10.0, 100.0, 8))
    theta = np.linspace(-np.pi, 2 * np.pi, 300)
    U = kapitza.pendulum_effective_potential(0.05, 150.0, theta=theta)

    def made(k):
        if k == 0:
            fig = figures.stability_map_figure(m, title="Stability of the upright pendulum " * 4)
        else:
            fig = figures.effective_potential_figure(theta, U)
            fig.axes[0].plot(theta, 1.1 * U, label="a second curve, for the legend below")
            figures.legend_below(fig.axes[0])
        figures.fit_texts(fig)
        assert fig.get_layout_engine() is not None, "the case worth checking: an engine's"
        return fig

    for k in (0, 1):
        made(k).savefig(tmp_path / f"savefig{k}.png", dpi=150)
        fig = made(k)
        engine, dpi = fig.get_layout_engine(), fig.dpi
        figures.save_png(fig, tmp_path / f"save_png{k}.png", 150)
        assert fig.get_layout_engine() is engine and fig.dpi == dpi
        a, b = imread(tmp_path / f"savefig{k}.png"), imread(tmp_path / f"save_png{k}.png")
        assert a.shape == b.shape and np.array_equal(a, b), f"figure {k}: pixels differ"
