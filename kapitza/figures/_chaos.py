"""Figures of the route to chaos: the Lyapunov map, the bifurcation diagram's dots, a
Poincaré section, a basin.  They draw results (read by their fields) and compute nothing;
each returns a :class:`matplotlib.figure.Figure` on the Agg canvas (no pyplot state), or
draws into ``ax`` and returns its figure.  matplotlib is imported when one is drawn.
"""
from __future__ import annotations

import math

import numpy as np

__all__ = ["lyapunov_map_figure", "bifurcation_figure", "section_figure", "basin_figure"]


def _axes(ax, figsize):
    """(figure, axes): ``ax`` and its figure, or a new pyplot-free figure with one axes."""
    if ax is not None:
        return ax.figure, ax
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure
    fig = Figure(figsize=figsize, layout="constrained")
    FigureCanvasAgg(fig)
    return fig, fig.add_subplot()


def _coordinate(result, coordinate):
    if isinstance(coordinate, str):
        if coordinate not in result.coordinates:
            raise ValueError(f"coordinate {coordinate!r} is not one of "
                             f"{list(result.coordinates)}.")
        return result.coordinates.index(coordinate)
    j = int(coordinate)
    if not 0 <= j < len(result.coordinates):
        raise ValueError(f"coordinate {coordinate!r} is out of range for the coordinates "
                         f"{list(result.coordinates)}.")
    return j


def _varying_axes(grid):
    """For a 2-D grid: the (name, values) of the parameter that varies along axis 1 (x)
    and along axis 0 (y)."""
    if len(grid.shape) != 2:
        raise ValueError(f"a Lyapunov map needs a 2-D grid (two varying parameters); this one "
                         f"has shape {grid.shape}. Draw its to_dataframe() instead.")
    found = {}
    for name, v in grid.params.items():
        v = np.broadcast_to(v, grid.shape)
        for axis in (0, 1):
            other = 1 - axis
            along = np.take(v, 0, axis=other)
            if np.ptp(along) > 0 and np.all(np.ptp(v, axis=other) == 0) and axis not in found:
                found[axis] = (name, along)
    if set(found) != {0, 1}:
        raise ValueError("a Lyapunov map needs one parameter varying along each axis of the "
                         f"grid; found {[(a, n) for a, (n, _) in found.items()]}.")
    return found[1], found[0]


def lyapunov_map_figure(grid, *, ax=None, per_period=False, cmap="RdBu_r", log_x=None,
                        log_y=None, title=None):
    """λ_max over a 2-D grid's two varying parameters (e.g. (ω, A)): red where positive
    (chaos), blue where negative (attracting), white at 0; a black contour marks λ_max = 0
    and grey the runs that failed.

    Parameters
    ----------
    grid : kapitza.results.LyapunovGrid
    ax : matplotlib Axes, optional
    per_period : bool
        λ_max T (per drive period) instead of λ_max (1/s).
    cmap : str
    log_x, log_y : bool, optional
        Logarithmic axes (default: when the values are spaced geometrically, e.g.
        ``np.geomspace``).
    title : str, optional
    """
    from matplotlib.colors import TwoSlopeNorm
    (xname, x), (yname, y) = _varying_axes(grid)
    z = np.array(grid.exponent * (grid.period if per_period else 1.0), dtype=float)
    fig, ax = _axes(ax, (7.0, 5.2))
    finite = z[np.isfinite(z)]
    lo = float(min(finite.min(), -1e-12)) if finite.size else -1.0
    hi = float(max(finite.max(), 1e-12)) if finite.size else 1.0
    mesh = ax.pcolormesh(x, y, np.ma.masked_invalid(z), cmap=cmap, shading="nearest",
                         norm=TwoSlopeNorm(vmin=lo, vcenter=0.0, vmax=hi), rasterized=True)
    if np.any(~np.isfinite(z)):
        ax.pcolormesh(x, y, np.ma.masked_where(np.isfinite(z), np.ones_like(z)),
                      cmap="Greys", vmin=0, vmax=2, shading="nearest", rasterized=True)
    if finite.size and lo < 0 < hi and min(z.shape) > 1:
        ax.contour(x, y, np.nan_to_num(z, nan=lo), levels=[0.0], colors="k", linewidths=0.8)
    bar = fig.colorbar(mesh, ax=ax, label="λ_max T (per drive period)" if per_period
                       else "largest Lyapunov exponent λ_max (1/s)")
    # ticks on both sides of 0 (the two slopes of the norm differ)
    bar.set_ticks([lo, lo / 2, 0.0, hi / 2, hi])
    bar.ax.set_yticklabels([f"{v:.2g}" for v in (lo, lo / 2, 0.0, hi / 2, hi)])
    for axis, values, log in (("x", x, log_x), ("y", y, log_y)):
        if log is None:
            steps = np.diff(np.log(values)) if np.all(values > 0) and values.size > 2 else None
            log = bool(steps is not None and np.allclose(steps, steps[0], rtol=1e-6)
                       and not np.allclose(np.diff(values), values[1] - values[0], rtol=1e-6))
        if log:
            (ax.set_xscale if axis == "x" else ax.set_yscale)("log")
    ax.set_xlabel(xname)
    ax.set_ylabel(yname)
    ax.set_title(title or f"chaos map: λ_max over {grid.periods} drive periods "
                          f"(after {grid.transient}); {int(np.sum(grid.chaotic))} of "
                          f"{z.size} points chaotic", fontsize=10)
    return fig


def bifurcation_figure(diagram, *, ax=None, coordinate=0, velocity=False, size=0.4, color="k",
                       title=None):
    """Every strobe sample of one coordinate (or its rate) against the parameter: the
    stroboscopic bifurcation diagram's dots (angles wrapped into [−π, π)).

    Parameters
    ----------
    diagram : kapitza.results.BifurcationDiagram
    ax : matplotlib Axes, optional
        Draw into it (e.g. under continued branches); else a new figure.
    coordinate : int or str
    velocity : bool
        Draw q̇ instead of q.
    size : float
        Marker size (points²).
    color : str
    title : str, optional
    """
    j = _coordinate(diagram, coordinate)
    name = diagram.coordinates[j]
    y = (diagram.qdot if velocity else diagram.q_wrapped)[..., j]
    x = np.broadcast_to(diagram.values[:, None, None], y.shape)
    keep = np.isfinite(y)
    fig, ax = _axes(ax, (7.5, 4.8))
    ax.scatter(x[keep], y[keep], s=size, c=color, marker=".", linewidths=0, rasterized=True)
    ax.set_xlabel(diagram.parameter)
    label = f"d{name}/dt at the strobe" if velocity else f"{name} at the strobe"
    if not velocity and name in diagram.angles:
        label += " (mod 2π)"
        ax.set_ylim(-math.pi, math.pi)
    ax.set_ylabel(label)
    ax.set_title(title or f"stroboscopic bifurcation diagram: {diagram.periods} samples after "
                          f"{diagram.transient} periods, {diagram.q.shape[1]} start(s) per value",
                 fontsize=10)
    return fig


def section_figure(section, *, ax=None, coordinate=0, size=2.0, title=None):
    """The Poincaré section in the (q, q̇) plane of one coordinate; one colour per start."""
    j = _coordinate(section, coordinate)
    name = section.coordinates[j]
    K, n = section.q.shape[-2:]
    q = section.q_wrapped.reshape(-1, K, n)[..., j]
    v = section.qdot.reshape(-1, K, n)[..., j]
    fig, ax = _axes(ax, (6.0, 5.0))
    for s in range(q.shape[0]):
        keep = np.isfinite(q[s]) & np.isfinite(v[s])
        ax.scatter(q[s][keep], v[s][keep], s=size, marker=".", linewidths=0,
                   color=f"C{s % 10}" if q.shape[0] > 1 else "k", rasterized=True)
    ax.set_xlabel(f"{name}" + (" (mod 2π)" if name in section.angles else ""))
    ax.set_ylabel(f"d{name}/dt")
    ax.set_title(title or f"Poincaré section: {K} strobe samples per start (T = "
                          f"{section.period:.4g} s)", fontsize=10)
    return fig


def basin_figure(basin, *, ax=None, title=None):
    """The basin in its plane of [q, q̇]: the cells that stay, with ``about`` marked."""
    from matplotlib.colors import ListedColormap
    ij = basin.plane()
    if ij is None:
        raise ValueError("basin_figure draws a regular 2-D grid in one plane of [q, q̇] (one "
                         "component per axis); draw basin.to_dataframe() otherwise.")
    n = len(basin.coordinates)
    x = np.concatenate([basin.q0, basin.qdot0], axis=-1)
    label = [*basin.coordinates, *(f"d{c}/dt" for c in basin.coordinates)]
    fig, ax = _axes(ax, (6.0, 5.0))
    along0, along1 = x[:, 0, ij[0]], x[0, :, ij[1]]
    # the lower component of [q, q̇] across (a coordinate before its rate)
    if ij[0] < ij[1]:
        (xs, ys, z), (cx, cy) = (along0, along1, basin.stays.T), ij
    else:
        (xs, ys, z), (cx, cy) = (along1, along0, basin.stays), ij[::-1]
    ax.pcolormesh(xs, ys, z.astype(float), cmap=ListedColormap(["#f3d9c9", "#5b8fc9"]),
                  vmin=0, vmax=1, shading="nearest", rasterized=True)
    centre = np.concatenate([basin.about, np.zeros(n)])
    ax.plot(centre[cx], centre[cy], "k+", ms=10)
    ax.plot([], [], "s", color="#5b8fc9", label="stays")
    ax.plot([], [], "s", color="#f3d9c9", label="leaves")
    ax.legend(fontsize=8, loc="upper right")
    ax.set_xlabel(label[cx])
    ax.set_ylabel(label[cy])
    ax.set_title(title or f"basin: {basin.fraction:.1%} of the cells stay for {basin.periods} "
                          "drive periods", fontsize=10)
    return fig
