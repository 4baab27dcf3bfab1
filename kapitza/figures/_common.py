"""What every figure shares: a pyplot-free Figure, the check of what it is given, labels.

Figures read results by their fields (duck typing): this room never imports
:mod:`kapitza.results` at run time, so that a result may draw itself (``figure()``)
without a circle.  :func:`require` refuses a value that lacks the fields a figure reads,
naming the result type it expects.
"""
from __future__ import annotations

import ast

import numpy as np

__all__ = ["legend_below"]   # and fit_texts, fit_title: on the face, not in __all__

#: The fields each figure reads of the result types it draws (what :func:`require` checks).
STABILITY_MAP = ("A", "omega", "label", "about", "method", "l", "g")
STABILITY_WINDOW = ("omega", "A_min", "A_max", "method", "order", "l")
BOUNDARY_CURVES = ("omega", "A", "kind", "stable_below")
VERIFICATION = ("A", "omega", "about", "length", "omega0", "methods", "stable_floquet",
                "compare", "modes", "fits", "window", "boundary_A", "boundary_omega",
                "periods")


def figure(figsize):
    """A Figure on the Agg canvas: no pyplot state, nothing shown."""
    from matplotlib.figure import Figure
    fig = Figure(figsize=figsize, layout="constrained")
    agg_canvas(fig)
    return fig


_CANVAS = None


def agg_canvas(fig):
    """Put ``fig`` on an Agg canvas whose renderers share one mathtext parser.

    Each Agg renderer (one per figure and resolution) has its own parser, and matplotlib
    caches a parsed formula per parser: every figure re-parsed the same log-axis tick
    labels ("10^{-2}") when it was laid out and again when saved, ~10 ms a formula and
    most of the cost of measuring text.  A shared parser's cache is keyed as before (the
    formula, resolution, font, antialiasing, hinting), so the drawn pixels are the same."""
    global _CANVAS
    if _CANVAS is None:
        from matplotlib.backends.backend_agg import FigureCanvasAgg
        from matplotlib.mathtext import MathTextParser
        parser = MathTextParser("path")          # what RendererAgg makes for itself

        class SharedParserCanvas(FigureCanvasAgg):
            """An Agg canvas whose renderers parse formulas with one shared parser."""

            def get_renderer(self):
                renderer = super().get_renderer()
                renderer.mathtext_parser = parser
                return renderer

        _CANVAS = SharedParserCanvas
    if not isinstance(fig.canvas, _CANVAS):
        _CANVAS(fig)
    return fig.canvas


def axes(ax, figsize):
    """(figure, axes): ``ax`` and its figure, or a new figure of ``figsize`` with one axes."""
    if ax is not None:
        return ax.figure, ax
    fig = figure(figsize)
    return fig, fig.add_subplot()


def require(name, value, kind, fields, fix):
    """Refuse ``value`` unless it has every one of ``fields`` (those of
    ``kapitza.results.<kind>`` that the figure reads).

    >>> require("chart", 3.0, "InceStruttChart", ("q",), "make one")
    Traceback (most recent call last):
    ...
    TypeError: chart must be a kapitza.results.InceStruttChart, got float (it has no q); make one.
    """
    missing = [f for f in fields if not hasattr(value, f)]
    if missing:
        raise TypeError(f"{name} must be a kapitza.results.{kind}, got {type(value).__name__} "
                        f"(it has no {', '.join(missing)}); {fix}.")


def is_boundary_curves(value) -> bool:
    """Whether an overlay is a BoundaryCurves (else it should be a StabilityWindow)."""
    return all(hasattr(value, f) for f in BOUNDARY_CURVES)


def drive_labels(ax, dimensionless, amplitude):
    """Axis labels of an (ω, A) plane: SI (``amplitude`` names A and its unit) or A/l, ω/ω0."""
    if dimensionless:
        ax.set_xlabel("drive frequency ω/ω0  (ω0 = √(g/l))")
        ax.set_ylabel("drive amplitude A/l")
    else:
        ax.set_xlabel("drive angular frequency ω (rad/s)")
        ax.set_ylabel(f"drive amplitude {amplitude}")


def window_label(window) -> str:
    """Legend text of a StabilityWindow overlay, from its fields."""
    if window.method == "averaging":
        if window.order == 1 and window.l is not None:       # the single pendulum's closed form
            return "averaging (order 1): A ω = √(2 g l)"
        return f"averaging (order {window.order})"
    return "Floquet window (exact)"


def about_text(about) -> str:
    """The equilibrium for a title: its name, or its coordinates in multiples of π.

    >>> about_text("inverted"), about_text("[3.141592653589793, 0.0]")
    ('the inverted state', 'the state q = (π, 0)')
    """
    if isinstance(about, str) and not about.startswith(("[", "(")):
        return f"the {about} state"
    try:
        values = ast.literal_eval(about) if isinstance(about, str) else about
        if isinstance(values, dict):
            values = list(values.values())
        values = np.atleast_1d(np.asarray(values, float))
    except (ValueError, TypeError, SyntaxError):
        try:        # a numpy array's str(): "[3.14159265 3.14159265]", no commas
            values = np.array(str(about).strip("[]()").split(), float)
        except ValueError:                           # not numbers: as given, shortened
            return f"the state {str(about)[:40]}"
    parts = []
    for v in values:
        k = v / np.pi
        quarter = round(k * 4) / 4         # 1e-8: arrays printed to 8 digits still read as π
        parts.append(("0" if quarter == 0 else "π" if quarter == 1 else f"{quarter:g}π")
                     if abs(k - quarter) < 1e-8 else f"{v:.4g}")
    return f"the state q = ({', '.join(parts)})"


def fit_title(ax, text, **kwargs):
    """Set ``ax``'s title, its lines wrapped where they would run past the figure's edge
    (:func:`fit_texts`); returns the title's Text."""
    title = ax.set_title(text, **kwargs)
    fit_texts(ax.figure)
    return title


def _titles(fig):
    """Every title of ``fig``: the axes' (centre, left, right) and the figure's own."""
    found = [t for ax in fig.axes for t in (ax.title, ax._left_title, ax._right_title)]
    if fig._suptitle is not None:
        found.append(fig._suptitle)
    return [t for t in found if t.get_visible() and t.get_text()]


def fit_texts(fig, margin=4.0):
    """Wrap every title of ``fig`` whose lines run past the figure's edge, so that no
    title is cut (the figure keeps its size; constrained layout makes room for the extra
    lines).

    A title is centred on its axes, so the width it may take is twice the distance from
    its centre to the nearer edge of the figure, less ``margin`` (px); each of its lines
    is wrapped at the number of characters that fits, measured on the drawn text (three
    rounds at most: a wrapped title moves the layout; each round wraps the title as
    given, so a line is never broken twice).  Returns the titles changed.
    """
    import textwrap
    changed = []
    if _clearly_fit(fig, margin):
        return changed
    given = {}
    for _ in range(3):
        renderer = _laid_out(fig)
        width = fig.bbox.width
        again = False
        for title in _titles(fig):
            box = title.get_window_extent(renderer)
            if box.x0 >= -0.5 and box.x1 <= width + 0.5:
                continue
            centre = 0.5 * (box.x0 + box.x1)
            room = 2 * min(centre, width - centre) - 2 * margin
            longest = max(len(line) for line in title.get_text().split("\n"))
            chars = max(12, int(longest * max(room, 1.0) / box.width))
            text = given.setdefault(title, title.get_text())
            title.set_text("\n".join(_unbroken(textwrap.fill(_glued(line), chars))
                                      for line in text.split("\n")))
            if title not in changed:
                changed.append(title)
            again = True
        if not again:
            break
    return changed


def save_png(fig, path, dpi):
    """Save ``fig`` as a PNG of ``dpi`` to ``path`` (a file name, whatever its suffix, or a
    binary file), drawn once.

    ``savefig`` of a figure with a layout engine draws it twice: first with drawing
    disabled, a pass that runs the layout and then walks every artist (ticks, tick
    labels, legends) for nothing, then for the pixels.  Here the layout engine runs
    alone, as that pass runs it (each axes' aspect applied, then the engine, at ``dpi``
    on the renderer that then draws), and the figure is saved without an engine: the
    same layout, the same file byte for byte, one walk (the report's figures: 15 % less
    CPU; a result's thumbnail in Jupyter ~15 %).  The figure's engine and resolution are
    restored after."""
    import matplotlib as mpl
    engine = fig.get_layout_engine()
    if engine is None or not fig.axes:
        fig.savefig(path, dpi=dpi, format="png")
        return
    screen = fig.dpi
    try:
        fig.dpi = dpi
        _laid_out(fig)
        with mpl.rc_context({"figure.autolayout": False,
                             "figure.constrained_layout.use": False}):
            fig.set_layout_engine(None)    # None, not "none": savefig then lays nothing out
        fig.savefig(path, dpi=dpi, format="png")
    finally:
        fig.set_layout_engine(engine)
        fig.dpi = screen


def _laid_out(fig):
    """``fig`` laid out as its next draw lays it out, and the renderer to measure on.

    Only the layout engine runs (the positions a title is centred on), not the draw pass
    of every artist: ``savefig`` draws again, and the draw pass was a third of a measuring
    round (a full draw of a map or a long record, rasterised, 8x as long as the layout).
    An axes of fixed aspect is shrunk into its box here as in a draw (``apply_aspect``,
    before the layout and after)."""
    renderer = fig.canvas.get_renderer()
    engine = fig.get_layout_engine()
    if engine is not None and fig.axes:
        _apply_aspects(fig, renderer)
        engine.execute(fig)
    _apply_aspects(fig, renderer)
    return renderer


def _apply_aspects(fig, renderer):
    for ax in fig.axes:
        locator = ax.get_axes_locator()
        ax.apply_aspect(locator(ax, renderer) if locator else None)


def _clearly_fit(fig, margin, slack=0.25):
    """Whether every title of ``fig`` fits with a quarter of the figure's width to spare,
    measured before any layout: a title's width does not depend on the layout, and its
    centre moves with it by far less than the slack (checked on every figure of the
    shipped scenes' reports: none that passes here was wrapped by the full measure).
    Half of those figures pass, and skip the layout that measuring on the drawn figure
    takes (~0.3 s a figure, as long as the draw of ``savefig`` itself)."""
    renderer = fig.canvas.get_renderer()
    width = fig.bbox.width
    for title in _titles(fig):
        ax = title.axes
        box = ax.get_position() if ax is not None else None
        centre = width * (0.5 if box is None else 0.5 * (box.x0 + box.x1))
        room = 2 * min(centre, width - centre) - 2 * margin - slack * width
        if title.get_window_extent(renderer).width > room:
            return False
    return True


_NBSP = "\u00a0"


def _glued(line: str) -> str:
    """``line`` with the spaces a wrap must not break at made non-breaking: inside a short
    parenthesis ("(π, π)") and around "=" ("θ = π")."""
    import re
    line = re.sub(r"\(([^()]{1,24})\)", lambda m: m.group(0).replace(" ", _NBSP), line)
    return line.replace(" = ", f"{_NBSP}={_NBSP}")


def _unbroken(text: str) -> str:
    return text.replace(_NBSP, " ")


def legend_below(ax, handles=None):
    """Move ``ax``'s legend (or one of ``handles``) below the axes, two columns, so it
    hides no part of a map."""
    if handles is None:
        handles = list(ax.get_legend().legend_handles)
    ax.legend(handles=handles, loc="upper center", bbox_to_anchor=(0.5, -0.14), ncol=2,
              fontsize=7.5, frameon=False)
