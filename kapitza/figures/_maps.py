"""Figures in a parameter plane: stability maps with windows and boundary curves over them,
spot checks by simulation on a map, the Ince–Strutt chart.

Examples
--------
The exact map of the upright pendulum with the first-order averaging limit
A ω = √(2 g l) drawn over it:

>>> import numpy as np
>>> from kapitza import KapitzaPendulum
>>> pend = KapitzaPendulum(l=1.0, g=9.81)
>>> omega = np.linspace(5.0, 200.0, 120)
>>> exact = pend.stability_map(np.linspace(0.0, 0.6, 100), omega)
>>> averaging = pend.window(omega, method="averaging", order=1)
>>> fig = stability_map_figure(exact, overlays=[averaging])
>>> [line.get_label() for line in fig.axes[0].lines]
['averaging (order 1): A ω = √(2 g l)']
"""
from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from ._common import (
    STABILITY_MAP,
    STABILITY_WINDOW,
    about_text,
    axes,
    drive_labels,
    is_boundary_curves,
    legend_below,
    require,
    window_label,
)

if TYPE_CHECKING:
    from ..results import BoundaryCurves, InceStruttChart, StabilityMap

__all__ = ["stability_map_figure", "spot_check_figure", "ince_strutt_figure"]

_COLORS = {0: "#d9f0d3", 1: "#fdd49e", 2: "#c6dbef", 3: "#e7d4e8", 4: "#bdbdbd"}
_NAMES = {0: "stable", 1: "unstable, period-T boundary", 2: "unstable, period-2T boundary",
          3: "unstable, complex multipliers",
          4: "no periodic orbit found (undecided)"}
#: Characters per title line at the title's font size (10 pt) on the 6.4 in wide axes
_TITLE_WIDTH = 72
_LINE_STYLES = ("--", ":", "-.", "-")
_CURVE_COLORS = {"T": "#b35806", "2T": "#2166ac", "complex": "#762a83"}


def _draw_curves(ax, curves: BoundaryCurves, w_scale, a_scale, handles):
    """Exact boundary curves as solid lines, one colour and one legend entry per kind."""
    shown = {h.get_label() for h in handles}
    for kind, A in zip(curves.kind, np.asarray(curves.A, float), strict=True):
        label = {"T": "exact boundary: multiplier +1 (T)",
                 "2T": "exact boundary: multiplier −1 (2T)",
                 "complex": "exact boundary: complex pair"}[kind]
        line, = ax.plot(np.asarray(curves.omega) * w_scale, A * a_scale, "-",
                        color=_CURVE_COLORS[kind], lw=1.3, label=label)
        if label not in shown:
            handles.append(line)
            shown.add(label)


def stability_map_figure(result: StabilityMap, *, overlays=(), ax=None, title=None,
                         dimensionless=False, l=None, g=None, log_omega=False, log_A=False,
                         boundaries=True):
    """Stability map (A vertical, ω horizontal), with stability windows drawn over it.

    Parameters
    ----------
    result : kapitza.results.StabilityMap
        From :meth:`kapitza.KapitzaPendulum.stability_map`,
        :func:`kapitza.pendulum_stability_map` or :func:`kapitza.stability_map`.
    overlays : sequence of kapitza.results.StabilityWindow or BoundaryCurves
        Windows to draw as lines A_min(ω), A_max(ω) (the parts inside the map's A
        range; infinite edges are left out), e.g. the averaging prediction
        ``KapitzaPendulum.window(omega, method="averaging", order=1)``, and exact
        boundary curves from :func:`kapitza.boundaries` (solid, coloured by kind).
        Compute them on a fine ω grid for smooth curves.
    ax : matplotlib Axes, optional
        Draw into this axes instead of a new figure.
    title : str, optional
        Default: the equilibrium and the method.
    dimensionless : bool
        Axes A/l and ω/ω0 (ω0 = √(g/l)) instead of A (m) and ω (rad/s); needs the
        map's l and g (the pendulum's maps carry them) or ``l=`` and ``g=``.
    l, g : float, optional
        Length (m) and gravity (m/s²) for ``dimensionless`` when the map has none.
    log_omega, log_A : bool
        Logarithmic axes (the hanging state's tongues at ω = 2ω0/n only show on a
        logarithmic ω axis).
    boundaries : bool
        Draw the boundaries between stable and unstable regions as lines (for an
        adaptive map, :class:`~kapitza.results.AdaptiveMap`, the zero contour of its
        continuous margin: smooth at the grid's resolution).

    Returns
    -------
    matplotlib.figure.Figure

    Raises
    ------
    ValueError
        ``dimensionless`` without a length and gravity; a logarithmic axis whose
        range includes 0 or negative values.
    """
    from matplotlib.colors import ListedColormap
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch
    require("result", result, "StabilityMap", STABILITY_MAP,
            "compute one with KapitzaPendulum.stability_map or kapitza.stability_map")
    for window in overlays:
        if not is_boundary_curves(window):
            require("every overlay", window, "StabilityWindow", STABILITY_WINDOW,
                    "compute one with KapitzaPendulum.window, or boundary curves with "
                    "kapitza.boundaries")
    fig, ax = axes(ax, (6.4, 4.6))
    labels = np.asarray(result.label)
    present = sorted(set(np.unique(labels).tolist()) | {0})
    cmap = ListedColormap([_COLORS[k] for k in range(len(_COLORS))])
    # axis scales: SI, or A/l and ω/ω0
    a_scale, w_scale = 1.0, 1.0
    if dimensionless:
        l = result.l if l is None else l
        g = result.g if g is None else g
        if l is None or g is None:
            raise ValueError("dimensionless=True needs the length and gravity: this map has "
                             "none (a general system's map); pass l=... (m) and g=... (m/s²).")
        a_scale, w_scale = 1.0 / l, 1.0 / np.sqrt(g / l)
    w, A = np.asarray(result.omega) * w_scale, np.asarray(result.A) * a_scale
    for name, on, axis in (("log_omega", log_omega, w), ("log_A", log_A, A)):
        if on and axis.min() <= 0:
            raise ValueError(f"{name}=True needs positive values, but the map's axis starts at "
                             f"{axis.min():g}; compute the map from a positive value.")
    ax.pcolormesh(w, A, labels, cmap=cmap, vmin=-0.5, vmax=len(_COLORS) - 0.5,
                  shading="nearest", rasterized=True)
    handles = [Patch(color=_COLORS[k], label=_NAMES[k]) for k in present]
    margin = getattr(result, "margin", None)      # an AdaptiveMap's continuous margin
    if boundaries and 0 < np.count_nonzero(labels == 0) < labels.size:
        field, level = ((labels == 0).astype(float), 0.5) if margin is None else (margin, 0.0)
        ax.contour(w, A, field, levels=[level], colors="#1b7837", linewidths=0.9)
        handles.append(Line2D([], [], color="#1b7837", lw=0.9, label="stability boundary"))
    for k, window in enumerate(overlays):
        if is_boundary_curves(window):
            _draw_curves(ax, window, w_scale, a_scale, handles)
            continue
        style = _LINE_STYLES[k % len(_LINE_STYLES)]
        label = window_label(window)
        for edge in (window.A_min, window.A_max):
            ww, Ab = np.broadcast_arrays(np.asarray(window.omega, float) * w_scale,
                                         np.asarray(edge, float) * a_scale)
            inside = np.isfinite(Ab) & (Ab >= A.min()) & (Ab <= A.max())
            if inside.any():
                line, = ax.plot(ww[inside], Ab[inside], style, color="k", lw=1.2, label=label)
                if not label.startswith("_"):
                    handles.append(line)          # one legend entry per window
                    label = "_" + label
    drive_labels(ax, dimensionless, "A (m)")
    ax.set_xscale("log" if log_omega else "linear")
    ax.set_yscale("log" if log_A else "linear")
    ax.set_xlim(w.min(), w.max())
    ax.set_ylim(A.min(), A.max())
    ax.set_title(title or _default_title(result), fontsize=10)
    ax.legend(handles=handles, loc="upper right", fontsize=8, framealpha=0.9)
    return fig


def _default_title(result) -> str:
    """The state and the method, each wrapped to the axes' width (a periodic orbit's
    method string is long enough to run off the figure)."""
    import textwrap
    head = textwrap.fill(f"Floquet stability of {about_text(result.about)}", _TITLE_WIDTH)
    method = textwrap.fill(f"({result.method})", _TITLE_WIDTH)
    return f"{head}\n{method}"


def spot_check_figure(result: StabilityMap, A, omega, stayed_up, agrees, *, overlays=(),
                      log_omega=False, log_A=False, title=None):
    """A stability map with direct-simulation spot checks marked on it.

    Parameters
    ----------
    result : kapitza.results.StabilityMap
        The map (as for :func:`stability_map_figure`, with ``overlays``, ``log_omega``,
        ``log_A``).
    A, omega : 1-d arrays
        The simulated points (m, rad/s).
    stayed_up, agrees : bool arrays
        Per point: the simulation stayed up (filled circle) or fell (cross); and whether
        that agrees with Floquet analysis (black edge) or not (red, large).

    Returns
    -------
    matplotlib.figure.Figure
    """
    from matplotlib.lines import Line2D
    A, omega = np.asarray(A, float), np.asarray(omega, float)
    stayed_up, agrees = np.asarray(stayed_up, bool), np.asarray(agrees, bool)
    if not (A.shape == omega.shape == stayed_up.shape == agrees.shape) or A.ndim != 1:
        raise ValueError(f"A, omega, stayed_up and agrees must be 1-d arrays of one length, "
                         f"got shapes {A.shape}, {omega.shape}, {stayed_up.shape}, "
                         f"{agrees.shape}.")
    fig = stability_map_figure(result, overlays=overlays, log_omega=log_omega, log_A=log_A,
                               boundaries=not overlays,
                               title=title or f"Spot checks by direct simulation on the "
                                              f"Floquet map of {about_text(result.about)}")
    ax = fig.axes[0]
    handles = list(ax.get_legend().legend_handles)
    for up, marker, text in ((True, "o", "simulation: stayed up"),
                             (False, "X", "simulation: fell")):
        for ok, color in ((True, "k"), (False, "#d62728")):
            sel = (stayed_up == up) & (agrees == ok)
            if sel.any():
                ax.scatter(omega[sel], A[sel], marker=marker, s=70 if ok else 130,
                           facecolors=("#1b7837" if up else "#444444") if ok else "none",
                           edgecolors=color, linewidths=1.2 if ok else 2.2, zorder=5)
        if (stayed_up == up).any():
            handles.append(Line2D([], [], ls="", marker=marker, ms=8, mec="k",
                                  mfc="#1b7837" if up else "#444444", label=text))
    if (~agrees).any():
        handles.append(Line2D([], [], ls="", marker="o", ms=10, mfc="none", mec="#d62728",
                              mew=2.2, label=f"disagrees with Floquet: {int((~agrees).sum())}"))
    legend_below(ax, handles)
    return fig


def ince_strutt_figure(chart: InceStruttChart, *, ax=None):
    """Ince–Strutt chart: stable (shaded) and unstable regions of y″ + (a − 2q cos 2τ) y = 0.

    Parameters
    ----------
    chart : kapitza.results.InceStruttChart
        From :func:`kapitza.ince_strutt_chart`: the stability grid and the
        characteristic curves a_r(q), b_r(q) (the undamped equation is stable
        between a_r and b_(r+1)).
    ax : matplotlib Axes, optional

    Returns
    -------
    matplotlib.figure.Figure

    Examples
    --------
    >>> from kapitza import ince_strutt_chart
    >>> fig = ince_strutt_figure(ince_strutt_chart(q_max=10, a_range=(-10, 20), r_max=5, n=60))
    >>> len(fig.axes[0].lines)                  # a0..a5, b1..b5
    11
    """
    require("chart", chart, "InceStruttChart", ("q", "a", "stable", "curves"),
            "compute one with kapitza.ince_strutt_chart")
    fig, ax = axes(ax, (6.4, 4.8))
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
