"""One quantity of a labelled grid over its one or two axes: the figure of measurement grids,
Floquet grids and sweeps.

It draws the labelled grid a gridded result builds (its ``_labelled()``: dimensions,
coordinates and variables with units and long names; read by those fields, this room
never imports results) and returns a :class:`matplotlib.figure.Figure` on the Agg canvas.
"""
from __future__ import annotations

import numpy as np

from ._common import axes, require

__all__ = ["grid_figure"]

_TRUE, _FALSE, _MASK = "#1b7837", "#d9d9d9", "#8c8c8c"


def _label(item, fallback):
    if item is None:
        return fallback
    units = f" ({item.units})" if getattr(item, "units", None) not in (None, "1") else ""
    return f"{item.long_name}{units}"


def _geometric(values) -> bool:
    """Whether an axis is evenly spaced in log (a logarithmic sweep axis)."""
    v = np.asarray(values, dtype=float)
    if v.size < 3 or not np.all(v > 0):
        return False
    ratios = v[1:] / v[:-1]
    steps = np.diff(v)
    return bool(np.allclose(ratios, ratios[0], rtol=1e-6) and
                not np.allclose(steps, steps[0], rtol=1e-6))


def _index(grid, dim, wanted):
    """The position along ``dim`` of ``wanted`` (a coordinate value or label), or
    ``wanted`` itself if it is a position."""
    coord = grid.coords.get(dim)
    if coord is not None and coord.dims == (dim,):
        hits = np.flatnonzero(np.asarray(coord.values) == wanted)
        if hits.size:
            return int(hits[0])
    if isinstance(wanted, (int, np.integer)) and 0 <= int(wanted) < grid.dims[dim]:
        return int(wanted)
    raise ValueError(f"select: {wanted!r} is neither a value of {dim!r} nor a position along "
                     f"it (it has {grid.dims[dim]}).")


def grid_figure(grid, variable, *, select=None, mask=None, mask_label="masked", ax=None,
                title=None, log_x=None, log_y=None):
    """One variable of a labelled grid: a line over one axis, a map over two.

    Parameters
    ----------
    grid : kapitza.results._xarray.LabelledGrid
        What a gridded result's ``_labelled()`` returns (its ``to_xarray()`` is the
        same as a Dataset).
    variable : str
        The variable to draw.  Numbers are coloured (a colour bar with the long name and
        units), flags in two colours, text by category.
    select : dict, optional
        Dimension → value (or position) for the dimensions not drawn; default the first
        of each (a grid with more than two axes of length > 1 is drawn over its first
        two).
    mask : bool ndarray, optional
        Points (the variable's shape) drawn grey instead, labelled ``mask_label`` (e.g.
        the runs that fell, whose slow frequency means nothing).
    ax : matplotlib Axes, optional
    title : str, optional
    log_x, log_y : bool, optional
        Logarithmic axes (default: where the axis is evenly spaced in log).

    Returns
    -------
    matplotlib.figure.Figure

    Raises
    ------
    ValueError
        An unknown variable or selection.
    """
    from matplotlib.colors import ListedColormap
    from matplotlib.patches import Patch
    require("grid", grid, "LabelledGrid", ("kind", "dims", "coords", "variables"),
            "draw a gridded result with its figure()")
    if variable not in grid.variables:
        raise ValueError(f"variable must be one of {list(grid.variables)}, got {variable!r}.")
    var = grid.variables[variable]
    values = np.asarray(var.values)
    masked = None if mask is None else np.broadcast_to(np.asarray(mask, bool), values.shape)
    select = dict(select or {})
    for d in select:
        if d not in var.dims:
            raise ValueError(f"select: {variable} has no dimension {d!r}; its dimensions are "
                             f"{list(var.dims)}.")
    shown = [d for d in var.dims if d not in select and grid.dims[d] > 1][:2]
    fixed = []
    index = []
    for d in var.dims:
        if d in shown:
            index.append(slice(None))
            continue
        i = _index(grid, d, select.get(d, 0))
        index.append(i)
        coord = grid.coords.get(d)
        if grid.dims[d] > 1:
            fixed.append(f"{d} = {coord.values[i] if coord is not None else i}")
    values = values[tuple(index)]
    masked = None if masked is None else masked[tuple(index)]

    def axis(d):
        coord = grid.coords.get(d)
        numeric = coord is not None and np.asarray(coord.values).dtype.kind in "iuf"
        if numeric and coord.dims == (d,):
            return np.asarray(coord.values, dtype=float), _label(coord, d)
        return np.arange(grid.dims[d], dtype=float), f"{d} (index)"

    fig, ax = axes(ax, (6.4, 4.4))
    handles = []
    kind = values.dtype.kind
    label = _label(var, variable)
    if len(shown) <= 1:
        x, xlabel = axis(shown[0]) if shown else (np.zeros(1), "")
        y = values.reshape(-1).astype(float) if kind in "biuf" else values.reshape(-1)
        keep = np.ones(y.shape, bool) if masked is None else ~masked.reshape(-1)
        if kind in "iuf":
            ax.plot(x[keep], y[keep], "o-", ms=3, lw=1.2, color="C0", label=label)
        else:
            ax.plot(x[keep], y[keep], "o", ms=4, color=_TRUE)
        if masked is not None and masked.any():
            ax.plot(x[~keep], np.full((~keep).sum(), np.nanmin(y[keep]) if keep.any()
                                      and kind in "biuf" else 0.0), "x", color=_MASK,
                    label=mask_label)
            ax.legend(fontsize=8)
        if kind == "b":
            ax.set_yticks([0, 1], ["no", "yes"])
        ax.set_xlabel(xlabel)
        ax.set_ylabel(label)
        if (log_x if log_x is not None else _geometric(x)):
            ax.set_xscale("log")
    else:
        if "omega" in shown and shown[0] == "omega":     # ω horizontal, as on every map
            shown = shown[::-1]
            values = values.T
            masked = None if masked is None else masked.T
        (y, ylabel), (x, xlabel) = axis(shown[0]), axis(shown[1])
        Z = values
        if kind == "b":
            ax.pcolormesh(x, y, Z.astype(float), cmap=ListedColormap([_FALSE, _TRUE]),
                          vmin=0, vmax=1, shading="nearest", rasterized=True)
            handles += [Patch(color=_TRUE, label=f"{label}: yes"),
                        Patch(color=_FALSE, label=f"{label}: no")]
        elif kind in "iuf":
            data = np.where(masked, np.nan, Z.astype(float)) if masked is not None else Z
            mesh = ax.pcolormesh(x, y, np.ma.masked_invalid(data), cmap="viridis",
                                 shading="nearest", rasterized=True)
            fig.colorbar(mesh, ax=ax, label=label)
        else:
            names, codes = np.unique(Z.astype(str), return_inverse=True)
            colors = [f"C{k % 10}" for k in range(len(names))]
            ax.pcolormesh(x, y, codes.reshape(Z.shape), cmap=ListedColormap(colors),
                          vmin=-0.5, vmax=len(names) - 0.5, shading="nearest",
                          rasterized=True)
            handles += [Patch(color=c, label=str(n)) for c, n in zip(colors, names, strict=True)]
        if masked is not None and masked.any():
            ax.pcolormesh(x, y, np.ma.masked_where(~masked, np.ones(masked.shape)),
                          cmap=ListedColormap([_MASK]), shading="nearest", rasterized=True)
            handles.append(Patch(color=_MASK, label=mask_label))
        ax.set_xlabel(xlabel)
        ax.set_ylabel(ylabel)
        if (log_x if log_x is not None else _geometric(x)):
            ax.set_xscale("log")
        if (log_y if log_y is not None else _geometric(y)):
            ax.set_yscale("log")
        if handles:
            ax.legend(handles=handles, loc="upper center", bbox_to_anchor=(0.5, -0.14),
                      ncol=2, fontsize=7.5, frameon=False)
    where = f" at {', '.join(fixed)}" if fixed else ""
    ax.set_title(title or f"{grid.kind}: {var.long_name}{where}", fontsize=10)
    return fig
