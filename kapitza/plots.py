"""Figures: stability maps with overlays, and the Ince–Strutt chart.

Figures compute no physics: each function draws results it is given (the value types
of :mod:`kapitza.results`) and returns a :class:`matplotlib.figure.Figure` built on the
Agg canvas (no pyplot state, nothing shown); save it with ``fig.savefig(path)``.

Examples
--------
The exact map of the upright pendulum with the first-order averaging limit
A ω = √(2 g l) drawn over it:

>>> import numpy as np
>>> from kapitza import KapitzaPendulum
>>> pend = KapitzaPendulum(l=1.0, g=9.81)
>>> omega = np.linspace(5.0, 200.0, 120)
>>> exact = pend.stability_map(np.linspace(0.0, 0.6, 100), omega)
>>> averaging = pend.stability_window(omega, method="averaging", order=1)
>>> fig = stability_map_figure(exact, overlays=[averaging])
>>> [line.get_label() for line in fig.axes[0].lines]
['averaging (order 1): A ω = √(2 g l)']
"""
from __future__ import annotations

import numpy as np

from .results import InceStruttChart, StabilityMap, StabilityWindow

__all__ = ["stability_map_figure", "ince_strutt_figure"]

_COLORS = {0: "#d9f0d3", 1: "#fdd49e", 2: "#c6dbef", 3: "#e7d4e8"}
_NAMES = {0: "stable", 1: "unstable, period-T boundary", 2: "unstable, period-2T boundary",
          3: "unstable, complex multipliers"}
_LINE_STYLES = ("--", ":", "-.", "-")


def _figure(figsize):
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure
    fig = Figure(figsize=figsize, layout="constrained")
    FigureCanvasAgg(fig)
    return fig


def _axes(ax, figsize):
    if ax is not None:
        return ax.figure, ax
    fig = _figure(figsize)
    return fig, fig.add_subplot()


def _check(name, value, kind, fix):
    if not isinstance(value, kind):
        raise TypeError(f"{name} must be a kapitza.results.{kind.__name__}, got "
                        f"{type(value).__name__}; {fix}.")


def _window_label(window: StabilityWindow) -> str:
    """Legend text of a window overlay, from its fields."""
    if window.method == "averaging":
        if window.order == 1:
            return "averaging (order 1): A ω = √(2 g l)"
        return f"averaging (order {window.order})"
    return "Floquet window (exact)"


def stability_map_figure(result: StabilityMap, *, overlays=(), ax=None, title=None):
    """Stability map (A vertical, ω horizontal), with stability windows drawn over it.

    Parameters
    ----------
    result : kapitza.results.StabilityMap
        From :meth:`kapitza.KapitzaPendulum.stability_map`,
        :func:`kapitza.mathieu.pendulum_stability_map` or
        :func:`kapitza.floquet.stability_map`.
    overlays : sequence of kapitza.results.StabilityWindow
        Windows to draw as lines A_min(ω), A_max(ω) (the parts inside the map's A
        range; infinite edges are left out), e.g. the averaging prediction
        ``KapitzaPendulum.stability_window(omega, method="averaging", order=1)``.
        Compute them on a fine ω grid for smooth curves.
    ax : matplotlib Axes, optional
        Draw into this axes instead of a new figure.
    title : str, optional
        Default: the equilibrium and the method.

    Returns
    -------
    matplotlib.figure.Figure
    """
    from matplotlib.colors import ListedColormap
    from matplotlib.patches import Patch
    _check("result", result, StabilityMap, "compute one with KapitzaPendulum.stability_map")
    for window in overlays:
        _check("every overlay", window, StabilityWindow,
               "compute one with KapitzaPendulum.stability_window")
    fig, ax = _axes(ax, (6.4, 4.6))
    labels = np.asarray(result.label)
    present = sorted(set(np.unique(labels).tolist()) | {0})
    cmap = ListedColormap([_COLORS[k] for k in range(4)])
    w, A = np.asarray(result.omega), np.asarray(result.A)
    ax.pcolormesh(w, A, labels, cmap=cmap, vmin=-0.5, vmax=3.5, shading="nearest",
                  rasterized=True)
    handles = [Patch(color=_COLORS[k], label=_NAMES[k]) for k in present]
    for k, window in enumerate(overlays):
        style = _LINE_STYLES[k % len(_LINE_STYLES)]
        label = _window_label(window)
        for edge in (window.A_min, window.A_max):
            ww, Ab = np.broadcast_arrays(np.asarray(window.omega, float), np.asarray(edge, float))
            inside = np.isfinite(Ab) & (Ab >= A.min()) & (Ab <= A.max())
            if inside.any():
                line, = ax.plot(ww[inside], Ab[inside], style, color="k", lw=1.2, label=label)
                if not label.startswith("_"):
                    handles.append(line)          # one legend entry per window
                    label = "_" + label
    ax.set_xlabel("drive angular frequency ω (rad/s)")
    ax.set_ylabel("drive amplitude A (m)")
    ax.set_xlim(w.min(), w.max())
    ax.set_ylim(A.min(), A.max())
    ax.set_title(title or f"Floquet stability of the {result.about} state\n({result.method})")
    ax.legend(handles=handles, loc="upper right", fontsize=8, framealpha=0.9)
    return fig


def ince_strutt_figure(chart: InceStruttChart, *, ax=None):
    """Ince–Strutt chart: stable (shaded) and unstable regions of y″ + (a − 2q cos 2τ) y = 0.

    Parameters
    ----------
    chart : kapitza.results.InceStruttChart
        From :func:`kapitza.mathieu.ince_strutt_chart`: the stability grid and the
        characteristic curves a_r(q), b_r(q) (the undamped equation is stable
        between a_r and b_(r+1)).
    ax : matplotlib Axes, optional

    Returns
    -------
    matplotlib.figure.Figure

    Examples
    --------
    >>> from kapitza.mathieu import ince_strutt_chart
    >>> fig = ince_strutt_figure(ince_strutt_chart(q_max=10, a_range=(-10, 20), r_max=5, n=60))
    >>> len(fig.axes[0].lines)                  # a0..a5, b1..b5
    11
    """
    _check("chart", chart, InceStruttChart, "compute one with kapitza.mathieu.ince_strutt_chart")
    fig, ax = _axes(ax, (6.4, 4.8))
    ax.pcolormesh(chart.q, chart.a, chart.stable.T, cmap="Greens", vmin=-0.3, vmax=1.6,
                  shading="nearest", rasterized=True)
    for name, vals in chart.curves.items():
        ax.plot(chart.q, vals, lw=1.0, color="C0" if name[0] == "a" else "C3",
                label={"a0": "$a_r(q)$ (even, ce)", "b1": "$b_r(q)$ (odd, se)"}.get(name))
    ax.legend(loc="lower left", fontsize=8)
    ax.set_xlim(chart.q.min(), chart.q.max())
    ax.set_ylim(chart.a.min(), chart.a.max())
    ax.set_xlabel("q")
    ax.set_ylabel("a")
    ax.set_title("Ince–Strutt chart (shaded: stable)")
    return fig
