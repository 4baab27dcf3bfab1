"""Figures for the Floquet analysis: stability maps and the Ince–Strutt chart.

Every function returns a :class:`matplotlib.figure.Figure` built on the Agg
canvas (no pyplot state, nothing shown); save it with ``fig.savefig(path)``.
"""
from __future__ import annotations

import numpy as np

__all__ = ["stability_map_figure", "ince_strutt_figure"]

_COLORS = {0: "#d9f0d3", 1: "#fdd49e", 2: "#c6dbef", 3: "#e7d4e8"}
_NAMES = {0: "stable", 1: "unstable, period-T boundary", 2: "unstable, period-2T boundary",
          3: "unstable, complex multipliers"}


def _figure(figsize):
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure
    fig = Figure(figsize=figsize, layout="constrained")
    FigureCanvasAgg(fig)
    return fig


def _averaging_boundary(omega, l, g):
    """First-order Kapitza limit A ω = √(2 g l) (PHYSICS.md), via kapitza.averaging if there."""
    try:
        from .averaging import stability_window
        return np.asarray(stability_window(omega, l=l, g=g, order=1).A_min, dtype=float)
    except (ImportError, AttributeError):   # the closed form is the same first-order result
        return np.sqrt(2 * g * l) / np.asarray(omega, dtype=float)


def stability_map_figure(result, *, averaging=True, l=None, g=None, ax=None, title=None):
    """Stability map (A vertical, ω horizontal) with the averaging prediction overlaid.

    Parameters
    ----------
    result : kapitza.floquet.StabilityMap
    averaging : bool
        Overlay the first-order Kapitza limit A ω = √(2 g l) (inverted pendulum;
        needs l and g, taken from ``result.meta`` when present).
    ax : matplotlib Axes, optional
        Draw into this axes instead of a new figure.

    Returns
    -------
    matplotlib.figure.Figure
    """
    from matplotlib.colors import ListedColormap
    from matplotlib.patches import Patch
    if ax is None:
        fig = _figure((6.4, 4.6))
        ax = fig.add_subplot()
    else:
        fig = ax.figure
    labels = np.asarray(result.label)
    present = sorted(set(np.unique(labels).tolist()) | {0})
    cmap = ListedColormap([_COLORS[k] for k in range(4)])
    w, A = np.asarray(result.omega), np.asarray(result.A)
    ax.pcolormesh(w, A, labels, cmap=cmap, vmin=-0.5, vmax=3.5, shading="nearest",
                  rasterized=True)
    handles = [Patch(color=_COLORS[k], label=_NAMES[k]) for k in present]
    l = l if l is not None else result.meta.get("l")
    g = g if g is not None else result.meta.get("g")
    if averaging and result.about == "inverted" and l is not None and g is not None:
        ww = np.linspace(w.min(), w.max(), 400)
        Ab = _averaging_boundary(ww, l, g)
        inside = (Ab >= A.min()) & (Ab <= A.max())
        line, = ax.plot(ww[inside], Ab[inside], "k--", lw=1.2,
                        label="averaging: A ω = √(2 g l)")
        handles.append(line)
    ax.set_xlabel("drive angular frequency ω (rad/s)")
    ax.set_ylabel("drive amplitude A (m)")
    ax.set_xlim(w.min(), w.max())
    ax.set_ylim(A.min(), A.max())
    ax.set_title(title or f"Floquet stability of the {result.about} state ({result.method})")
    ax.legend(handles=handles, loc="upper right", fontsize=8, framealpha=0.9)
    return fig


def ince_strutt_figure(q_max=20.0, a_range=(-20.0, 30.0), r_max=5, n=400, *, ax=None):
    """Ince–Strutt chart: stable (shaded) and unstable regions of y″ + (a − 2q cos 2τ) y = 0.

    The boundaries are the characteristic curves a_r(q), b_r(q)
    (:func:`kapitza.mathieu.characteristic_value`); the undamped equation is
    stable between a_r and b_(r+1).

    Returns
    -------
    matplotlib.figure.Figure
    """
    from .mathieu import ince_strutt_boundaries, stability_counts
    if ax is None:
        fig = _figure((6.4, 4.8))
        ax = fig.add_subplot()
    else:
        fig = ax.figure
    q = np.linspace(0.0, q_max, n)
    a = np.linspace(a_range[0], a_range[1], n)
    stable, _ = stability_counts(q, a)
    ax.pcolormesh(q, a, stable.T, cmap="Greens", vmin=-0.3, vmax=1.6, shading="nearest",
                  rasterized=True)
    curves = ince_strutt_boundaries(q, r_max)
    for name, vals in curves.items():
        ax.plot(q, vals, lw=1.0, color="C0" if name[0] == "a" else "C3",
                label={"a0": "$a_r(q)$ (even, ce)", "b1": "$b_r(q)$ (odd, se)"}.get(name))
    ax.legend(loc="lower left", fontsize=8)
    ax.set_xlim(0, q_max)
    ax.set_ylim(*a_range)
    ax.set_xlabel("q")
    ax.set_ylabel("a")
    ax.set_title("Ince–Strutt chart (shaded: stable)")
    return fig
