"""A continued branch against its parameter (:class:`kapitza.results.Branch`).

Read by its fields (``points``, ``bifurcations``, ``coordinates``, ``parameter``); this
room never imports results.
"""
from __future__ import annotations

import math

import numpy as np

from ._common import axes, require

__all__ = ["branch_figure"]

_MARKERS = {"fold": "s", "pitchfork": "D", "transcritical": "X", "period_doubling": "o",
            "neimark_sacker": "^"}


def branch_figure(branch, *, ax=None, y="amplitude", coordinate=0, color=None, label=None):
    """The branch against its parameter: solid where stable, dashed where unstable,
    each bifurcation marked and named.

    Parameters
    ----------
    branch : kapitza.results.Branch
    ax : matplotlib Axes, optional
        Draw into it (e.g. a switched branch over its parent); else a new figure.
    y : {"amplitude", "mean", "state"}
        Half the peak-to-peak range of q, its period mean, or q at t = 0.
    coordinate : int or str
        Which coordinate.
    color, label : optional
        The line's colour and legend label (default: the branch's own name, e.g.
        "2T orbits from the period doubling").

    Returns
    -------
    matplotlib.figure.Figure
    """
    require("branch", branch, "Branch", ("points", "bifurcations", "coordinates",
                                         "parameter"), "draw the result of kapitza.continuation")
    choices = {"amplitude": "amplitude", "mean": "q_mean", "state": "state"}
    if y not in choices:
        raise ValueError(f"y must be one of {list(choices)}, got {y!r}.")
    if isinstance(coordinate, str):
        if coordinate not in branch.coordinates:
            raise ValueError(f"coordinate {coordinate!r} is not one of "
                             f"{list(branch.coordinates)}.")
        coordinate = branch.coordinates.index(coordinate)
    name = branch.coordinates[coordinate]
    fig, ax = axes(ax, (6.4, 4.2))
    pts = branch.points
    values = getattr(pts, choices[y])[:, coordinate]
    color = color or f"C{len(ax.get_legend_handles_labels()[0]) % 10}"
    label = label or branch.label
    _draw_runs(ax, pts.parameter, values, pts.stable, color, label)
    named = {(t.get_text(), *np.round(t.xy, 9)) for t in ax.texts}
    for b in branch.bifurcations:
        xy = (float(pts.parameter[b.index]), float(values[b.index]))
        ax.plot(*xy, _MARKERS.get(b.kind, "o"), ms=8, mfc="white", mec="k", mew=1.4,
                zorder=5)
        text = b.kind.replace("_", " ")
        if (text, *np.round(xy, 9)) not in named:     # a parent's point, named already
            ax.annotate(text, xy, textcoords="offset points", xytext=(6, 6), fontsize=8)
    ax.set_xlabel(f"{branch.parameter}")
    ax.set_ylabel({"amplitude": f"amplitude of {name} (half peak-to-peak)",
                   "mean": f"period mean of {name}", "state": f"{name} at t = 0"}[y])
    from matplotlib.lines import Line2D
    handles = list(ax.get_legend_handles_labels()[0])
    own = {h.get_label() for h in handles}
    extra = [Line2D([], [], color="0.3", ls="-", label="stable"),
             Line2D([], [], color="0.3", ls="--", label="unstable")]
    ax.legend(handles=handles + [h for h in extra if h.get_label() not in own],
              fontsize=8, frameon=False)
    return fig


def _draw_runs(ax, x, y, stable, color, label):
    """Consecutive points of equal stability as one line (solid/dashed), joined where
    the stability changes so the curve is unbroken."""
    ax.plot([], [], color=color, ls="-", lw=1.8, label=label)   # the legend's entry
    if x.size == 0:
        return
    start = 0
    for k in range(1, x.size + 1):
        if k == x.size or stable[k] != stable[start]:
            stop = min(k + 1, x.size)
            ax.plot(x[start:stop], y[start:stop], color=color,
                    ls="-" if stable[start] else "--", lw=1.8)
            start = k
    if math.isfinite(float(np.max(np.abs(y)))) and np.ptp(y) == 0:
        ax.margins(y=0.2)
