"""What every figure shares: a pyplot-free Figure, the check of what it is given, labels.

Figures read results by their fields (duck typing): this room never imports
:mod:`kapitza.results` at run time, so that a result may draw itself (``figure()``)
without a circle.  :func:`require` refuses a value that lacks the fields a figure reads,
naming the result type it expects.
"""
from __future__ import annotations

import ast

import numpy as np

__all__ = ["legend_below"]

#: The fields each figure reads of the result types it draws (what :func:`require` checks).
STABILITY_MAP = ("A", "omega", "label", "about", "method", "l", "g")
STABILITY_WINDOW = ("omega", "A_min", "A_max", "method", "order", "l")
BOUNDARY_CURVES = ("omega", "A", "kind", "stable_below")
VERIFICATION = ("A", "omega", "about", "length", "omega0", "methods", "stable_floquet",
                "compare", "modes", "fits", "window", "boundary_A", "boundary_omega",
                "periods")


def figure(figsize):
    """A Figure on the Agg canvas: no pyplot state, nothing shown."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure
    fig = Figure(figsize=figsize, layout="constrained")
    FigureCanvasAgg(fig)
    return fig


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


def legend_below(ax, handles=None):
    """Move ``ax``'s legend (or one of ``handles``) below the axes, two columns, so it
    hides no part of a map."""
    if handles is None:
        handles = list(ax.get_legend().legend_handles)
    ax.legend(handles=handles, loc="upper center", bbox_to_anchor=(0.5, -0.14), ncol=2,
              fontsize=7.5, frameon=False)
