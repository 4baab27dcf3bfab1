"""Figures against the drive frequency: a stability window's edges, boundary curves.

They draw :class:`kapitza.results.StabilityWindow` and
:class:`kapitza.results.BoundaryCurves` (read by their fields; this room never imports
results) and return a :class:`matplotlib.figure.Figure` on the Agg canvas.
"""
from __future__ import annotations

import numpy as np

from ._common import BOUNDARY_CURVES, STABILITY_WINDOW, about_text, axes, require, window_label

__all__ = ["window_figure", "boundaries_figure"]

_KIND_COLORS = {"T": "#b35806", "2T": "#2166ac", "complex": "#762a83"}
_KIND_NAMES = {"T": "multiplier +1 (T)", "2T": "multiplier −1 (2T)",
               "complex": "complex pair"}
_UNDECIDED = "#e08214"


def window_figure(window, *, ax=None, log_omega=False, title=None):
    """A stability window against ω: A_min(ω) and A_max(ω), the stable band shaded.

    Parameters
    ----------
    window : kapitza.results.StabilityWindow
        Over several frequencies (from :func:`kapitza.window`,
        :meth:`kapitza.KapitzaPendulum.window`, …).  An infinite upper edge (first-order
        averaging) is shaded up to the top of the axes; frequencies whose status is
        "undecided" are marked in orange (their edges are an envelope), and an averaging
        prediction's points outside its validity are drawn as open circles.
    ax : matplotlib Axes, optional
    log_omega : bool
        A logarithmic ω axis.
    title : str, optional
        Default: the state and the method.

    Returns
    -------
    matplotlib.figure.Figure

    Examples
    --------
    >>> import numpy as np
    >>> from kapitza import KapitzaPendulum
    >>> w = KapitzaPendulum(l=1.0, g=9.81).window(np.linspace(10.0, 100.0, 40))
    >>> fig = window_figure(w)
    >>> [line.get_label() for line in fig.axes[0].lines][:2]
    ['A_min', 'A_max']
    """
    require("window", window, "StabilityWindow", STABILITY_WINDOW,
            "compute one with kapitza.window or KapitzaPendulum.window over an array of ω")
    omega = np.atleast_1d(np.asarray(window.omega, dtype=float))
    lo = np.broadcast_to(np.asarray(window.A_min, float), np.shape(window.omega)).reshape(-1)
    hi = np.broadcast_to(np.asarray(window.A_max, float), np.shape(window.omega)).reshape(-1)
    order = np.argsort(omega)
    omega, lo, hi = omega[order], lo[order], hi[order]
    fig, ax = axes(ax, (6.4, 4.2))
    finite = np.concatenate([lo[np.isfinite(lo)], hi[np.isfinite(hi)]])
    top = 1.25 * finite.max() if finite.size else 1.0
    ax.fill_between(omega, np.where(np.isfinite(lo), lo, np.nan),
                    np.where(np.isposinf(hi), top, hi), color="#d9f0d3", lw=0,
                    label="stable band")
    ax.plot(omega, lo, "-", color="#1b7837", lw=1.4, label="A_min")
    ax.plot(omega, np.where(np.isfinite(hi), hi, np.nan), "-", color="#762a83", lw=1.4,
            label="A_max")
    status = getattr(window, "status", None)
    if status is not None:
        undecided = (np.broadcast_to(np.asarray(status), np.shape(window.omega))
                     .reshape(-1)[order] == "undecided")
        if undecided.any():
            for edge in (lo, hi):
                ax.plot(omega[undecided], edge[undecided], "o", color=_UNDECIDED, ms=4,
                        label="undecided (envelope)")
    valid = getattr(window, "valid", None)
    if valid is not None:
        bad = ~np.broadcast_to(np.asarray(valid, bool), np.shape(window.omega)).reshape(-1)[
            order]
        if bad.any():
            ax.plot(omega[bad], lo[bad], "o", mfc="white", mec="#b35806", ms=4,
                    label="outside averaging's validity")
    ax.set_ylim(0.0, top)
    ax.set_xscale("log" if log_omega else "linear")
    ax.set_xlabel("drive angular frequency ω (rad/s)")
    ax.set_ylabel("drive amplitude A (m)")
    ax.set_title(title or f"Stability window of {about_text(window.about)}\n"
                          f"({window_label(window)})", fontsize=10)
    handles, labels = ax.get_legend_handles_labels()
    unique = dict(zip(labels, handles, strict=True))
    ax.legend(unique.values(), unique.keys(), loc="upper left", fontsize=8, framealpha=0.9)
    return fig


def boundaries_figure(curves, *, ax=None, log_omega=False, title=None):
    """Stability boundary curves A_k(ω), coloured by kind, a light band on each curve's
    stable side.

    Parameters
    ----------
    curves : kapitza.results.BoundaryCurves
        From :func:`kapitza.boundaries`.
    ax : matplotlib Axes, optional
    log_omega : bool
        A logarithmic ω axis.
    title : str, optional

    Returns
    -------
    matplotlib.figure.Figure
    """
    require("curves", curves, "BoundaryCurves", BOUNDARY_CURVES,
            "compute them with kapitza.boundaries")
    fig, ax = axes(ax, (6.4, 4.2))
    omega = np.asarray(curves.omega, dtype=float)
    A = np.asarray(curves.A, dtype=float).reshape(len(curves.kind), omega.size)
    finite = A[np.isfinite(A)]
    band = 0.03 * (finite.max() - finite.min() if finite.size > 1 and np.ptp(finite) > 0
                   else 1.0)
    shown = set()
    for kind, a, below in zip(curves.kind, A, np.asarray(curves.stable_below, bool),
                              strict=True):
        label = f"boundary: {_KIND_NAMES[kind]}"
        color = _KIND_COLORS[kind]
        ax.plot(omega, a, "-", color=color, lw=1.4, label=None if label in shown else label)
        shown.add(label)
        ax.fill_between(omega, a, a - band if below else a + band, color=color, alpha=0.15,
                        lw=0)
    ax.set_xscale("log" if log_omega else "linear")
    ax.set_xlabel("drive angular frequency ω (rad/s)")
    ax.set_ylabel("drive amplitude A (m)")
    ax.set_title(title or f"Stability boundaries of {about_text(curves.about)}\n"
                          "(shaded: the stable side)", fontsize=10)
    if shown:
        ax.legend(loc="upper left", fontsize=8, framealpha=0.9)
    return fig
