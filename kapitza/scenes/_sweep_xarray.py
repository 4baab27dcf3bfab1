"""A sweep as one labelled grid: :func:`open_sweep` and :meth:`SweepResult.to_xarray`.

A sweep's dataset (:mod:`kapitza.scenes._sweep`) is a directory of Parquet parts, one row
(or several) per point, the point numbered in C order over the axes.  Here it becomes one
:class:`xarray.Dataset` over those axes:

* one dimension per axis, in the sweep's order, its values the coordinate (``A`` in m,
  ``omega`` in rad/s, ``initial.theta`` in rad, …; units where kapitza knows them), and
  ``A_over_l``, ``omega_over_omega0`` beside ``A`` and ``omega`` where the scene's l and g
  are fixed;
* where an analysis gives several rows per point (averaging: one per equilibrium, and per
  mode for a general system), one more dimension per column that tells them apart
  (``equilibrium``, ``mode``), or ``row`` if none does;
* one variable per column with ``units`` and ``long_name`` (:data:`COLUMNS`); a point
  that is missing (an unfinished sweep opened with ``partial=True``, or an equilibrium
  that does not exist at a point) is NaN in a number, "" in a text, and a flag there
  becomes a number (1 true, 0 false, NaN missing; its ``comment`` says so); ``computed``
  marks the points present;
* the scene, the analysis, its method, the fixed parameters (with units), the code's
  fingerprint and the package versions that computed it in ``attrs`` (JSON text where
  they are tables).

Write it with ``ds.to_netcdf(path, engine="h5netcdf")`` (netCDF-4, the extra
``kapitza[xarray]``) or ``ds.to_zarr(path)`` (``pip install zarr``).
"""
from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np

from ..results import LabelledGrid, draw_figure, html_card, html_span, quantity_of
from ._schema import KEY_TARGETS

__all__ = ["open_sweep", "sweep_grid", "sweep_dataset", "sweep_figure", "sweep_card",
           "COLUMNS"]

#: The plan of a sweep's directory: ``kapitza.scenes._sweep.MANIFEST`` (not imported: the
#: sweep imports this module for its ``to_xarray``; tests/test_xarray.py checks they agree).
MANIFEST = "_sweep.json"

#: Columns of the sweeps' tables → (units, long name); "{q}" marks a coordinate's units,
#: "{qdot}" its rate's (where kapitza knows them), "<k>" a mode's number.
COLUMNS = {
    # measure (kapitza.measure_grid)
    "period": ("s", "drive period T"), "stayed_up": (None, "stayed in the band throughout"),
    "fall_time": ("s", "time to leaving the band (NaN: stayed)"),
    "omega_slow": ("rad/s", "slow angular frequency"),
    "omega_slow_error": ("rad/s", "error estimate of the slow angular frequency"),
    "refined": (None, "the slow frequency is the rotation number"),
    "growth_rate": ("1/s", "growth rate of the mode's strobe-map eigenvalue"),
    "fit_residual": ("1", "relative residual of the strobe-map fit"),
    "about": ("{q}", "state the band is centred on"),
    "amplitude": ("{q}", "slow amplitude"), "mean_angle": ("{q}", "time average"),
    "max_deviation": ("{q}", "largest distance from the state"),
    "energy_drift": ("J", "largest drift of the conserved energy"),
    "samples": ("1", "strobe samples recorded"), "status": (None, "how the run ended"),
    # floquet (kapitza.floquet_grid, kapitza.periodic_orbit)
    "log_scale": ("1", "log of the factor divided out of M"),
    "error_estimate": ("1", "estimated error (relative)"),
    "steps": ("1", "Taylor steps per period"), "stable": (None, "linearly stable"),
    "boundary": (None, "kind of the stability region (stable, T, 2T, complex)"),
    "trace": ("1", "trace of the monodromy matrix"),
    "log_growth": ("1", "largest log|λ| per drive period"),
    "margin": ("1", "stability test's distance from its threshold in error bounds"),
    "flags": (None, "accuracy warnings"),
    "max_abs_multiplier": ("1", "largest |λ| of the orbit's monodromy"),
    "residual": (None, "residual of the shooting equations"),
    "iterations": ("1", "Newton iterations"), "error": (None, "why the orbit was not found"),
    "q_mean": ("{q}", "mean of q over the orbit's period"),
    # averaging (kapitza.pendulum_averaged, kapitza.average)
    "theta": ("rad", "angle from the downward vertical"),
    "exists": (None, "the equilibrium exists"),
    "omega_squared": ("rad^2/s^2", "Ω² of the averaged motion"),
    "damped_frequency": ("rad/s", "damped slow angular frequency"),
    "decay_rate": ("1/s", "slowest decay rate"), "overdamped": (None, "overdamped"),
    "frequency_ratio": ("1", "drive frequency over the slow one"),
    "fast_drive": (None, "frequency ratio within averaging's validity"),
    "small_amplitude": (None, "amplitude within averaging's validity"),
    "converged": (None, "next-order correction small enough"),
    "valid": (None, "within averaging's validity"), "order": ("1", "averaging order"),
    "drive": (None, "direction of the drive"), "frequency": ("rad/s", "slow angular frequency"),
    # simulate (lagrange_core's simulate_grid)
    "t_final": ("s", "time at the end of the run"), "n_steps": ("1", "integration steps"),
    "exit_time": ("s", "time of leaving the band"),
    "exit_coordinate": (None, "coordinate that left the band"),
}
#: Columns that tell several rows of one point apart, in the order they are tried.
_KEYS = ("equilibrium", "mode", "start", "sample", "t")
#: Suffixes of a column per coordinate in the simulate tables ("theta_dot", "theta_mean").
_STATE_SUFFIXES = {"": ("{q}", "final value of"), "_dot": ("{qdot}", "final rate of"),
                   "_mean": ("{q}", "time average of"),
                   "_max_deviation": ("{q}", "largest deviation of")}


def _column_quantity(name: str, coordinates) -> tuple:
    """(units, long name) of a sweep column."""
    from ..results import coordinate_units
    if name in COLUMNS:
        units, text = COLUMNS[name]
        return (None if units and "{" in units else units), text
    for c in coordinates:
        for suffix, (units, text) in _STATE_SUFFIXES.items():
            if name == f"{c}{suffix}":
                q, qdot = coordinate_units(c)
                return {"{q}": q, "{qdot}": qdot}[units], f"{text} {c}"
    match = re.fullmatch(r"(.+)_(\d+)", name)
    if match and match.group(1) in COLUMNS:
        units, text = COLUMNS[match.group(1)]
        return units, f"{text}, mode {match.group(2)}"
    for c in coordinates:
        for base in ("about", "amplitude", "mean_angle", "max_deviation", "q_mean"):
            if name == f"{base}_{c}":
                return coordinate_units(c)[0], f"{COLUMNS[base][1]}: {c}"
    return None, f"{name} (units not known to kapitza)"


def _coordinates(columns, axes) -> list:
    """The system's coordinates, as the table's columns name them (``amplitude_theta``,
    ``theta_dot``, an axis ``initial.theta``)."""
    found = [a.split(".", 1)[1] for a in axes if a.startswith("initial.")]
    for c in map(str, columns):
        for prefix in ("about_", "amplitude_", "mean_angle_", "max_deviation_", "q_mean_"):
            rest = c.removeprefix(prefix)
            if c.startswith(prefix) and not rest.isdigit():
                found.append(rest)
        if c.endswith("_dot"):
            found.append(c.removesuffix("_dot"))
    return list(dict.fromkeys(q.removesuffix("_dot") for q in found))


def axis_values(record) -> list:
    """An axis's values from its record in the metadata or the manifest: a list of values,
    {kind, values}, or a range {kind, start, stop, num} (``kind`` "linear" or "log":
    ``numpy.linspace`` or ``numpy.geomspace``, as :func:`kapitza.scenes._sweep.axis_record`
    states)."""
    if isinstance(record, dict) and "values" in record:
        return [float(v) for v in record["values"]]
    if isinstance(record, dict):
        spread = np.geomspace if record.get("kind") == "log" else np.linspace
        return spread(float(record["start"]), float(record["stop"]),
                      int(record["num"])).tolist()
    return [float(v) for v in record]


def _axis_quantity(name: str) -> tuple:
    return quantity_of(KEY_TARGETS.get(name, name))


def _keys(frame, axes_names) -> list:
    """The columns that tell a point's rows apart (empty if one row per point)."""
    if not len(frame) or not frame["point"].duplicated().any():
        return []
    present = [k for k in _KEYS if k in frame.columns]
    for n in range(1, len(present) + 1):
        if not frame.duplicated(["point", *present[:n]]).any():
            return present[:n]
    return ["row"]


def _fill(values: np.ndarray, missing: bool):
    """(empty array to fill, its fill value, extra attributes) for a column's dtype."""
    kind = values.dtype.kind
    if kind in "US" or values.dtype == object:
        return "", object, {}
    if kind == "b" and missing:
        return np.nan, float, {"comment": "1 true, 0 false, NaN not computed"}
    if kind == "b":
        return False, bool, {}
    if kind in "iu" and not missing:
        return 0, values.dtype, {}
    return np.nan, float, {}


def sweep_grid(frame, axes: list, metadata: dict, *, kind: str = "SweepResult") -> LabelledGrid:
    """The labelled grid of a sweep's rows.

    Parameters
    ----------
    frame : pandas.DataFrame
        The rows (``point``, the axes, the analysis's columns), any subset of the points.
    axes : list of (name, values)
        The sweep's axes in order (the first slowest).
    metadata : dict
        What the parts record (scene, analysis, parameters, versions, …).

    Returns
    -------
    kapitza.results.LabelledGrid
    """
    shape = tuple(len(v) for _, v in axes)
    names = [n for n, _ in axes]
    size = int(np.prod(shape, dtype=np.int64))
    frame = frame.sort_values("point", kind="stable").reset_index(drop=True)
    keys = _keys(frame, names)
    if keys == ["row"]:
        frame = frame.assign(row=frame.groupby("point").cumcount())
    params = dict(metadata.get("parameters") or {})
    grid = LabelledGrid(kind, analysis=metadata.get("analysis", ""))
    for name in ("scene", "source", "system", "scene_key", "fingerprint"):
        if metadata.get(name) is not None:
            grid.attrs[name] = str(metadata[name])
    for name in ("settings", "initial", "targets", "versions"):
        if metadata.get(name) is not None:
            grid.attrs[name] = json.dumps(metadata[name], sort_keys=True, default=str)
    for name in ("tile_points", "tiles", "size"):
        if metadata.get(name) is not None:
            grid.attrs[name] = int(metadata[name])
    grid.attrs["axes_kinds"] = json.dumps(
        {k: v.get("kind") for k, v in (metadata.get("axes") or {}).items()
         if isinstance(v, dict)}, sort_keys=True)
    grid.parameters({k: v for k, v in params.items() if k not in names})
    for name, values in axes:
        units, long_name = _axis_quantity(name)
        grid.coord(name, name, np.asarray(values, dtype=float), units, long_name)
    if not {"l", "g"} & set(names):
        grid.drive_axes(*grid.pendulum_scales(params))
    points = frame["point"].to_numpy(dtype=np.int64)
    if points.size and (points.min() < 0 or points.max() >= size):
        raise ValueError(f"the sweep's rows number points up to {points.max()}, but its axes "
                         f"make {size}; the metadata does not describe these parts.")
    position = np.unravel_index(points, shape) if shape else ()
    index = list(position)
    dims = tuple(names)
    for key in keys:
        labels = list(dict.fromkeys(frame[key].tolist()))        # in order of appearance
        text = np.asarray(labels).dtype.kind in "USO"
        grid.coord(key, key, np.asarray(labels, dtype=str if text else None), None,
                   {"equilibrium": "equilibrium of the averaged motion",
                    "mode": "slow mode", "row": "row of the point"}.get(key, key))
        lookup = {v: i for i, v in enumerate(labels)}
        index.append(np.array([lookup[v] for v in frame[key].tolist()], dtype=np.int64))
        dims += (key,)
    full = shape + tuple(grid.dims[k] for k in keys)
    filled = np.zeros(full, dtype=bool)
    filled[tuple(index)] = True
    computed = np.zeros(shape, dtype=bool)
    computed[tuple(position)] = True
    missing = not filled.all()
    coordinates = _coordinates(frame.columns, names)
    method = None
    for column in frame.columns:
        if column in ("point", *names, *keys):
            continue
        values = frame[column].to_numpy()
        if column == "method" and len(set(values.tolist())) <= 1:
            method = str(values[0]) if len(values) else None
            continue
        if values.dtype == object:
            values = np.asarray(["" if v is None else str(v) for v in values], dtype=str)
        fill, dtype, extra = _fill(values, missing)
        out = np.full(full, fill, dtype=dtype)
        out[tuple(index)] = values.astype(dtype)
        if dtype is object:
            out = out.astype(str)                   # text, as long as its longest entry
        units, long_name = _column_quantity(column, coordinates)
        grid.variable(column, dims, out, units, long_name, **extra)
    if method is not None:
        grid.attrs["method"] = method
    grid.attrs["complete"] = bool(computed.all())
    grid.attrs["computed_points"] = int(computed.sum())
    if not computed.all():
        grid.variable("computed", tuple(names), computed, None,
                      "the point was computed (the others are NaN or empty)")
    return grid


def _read_manifest(path: Path) -> dict:
    manifest = path / MANIFEST
    if not path.is_dir():
        raise FileNotFoundError(f"open_sweep: {str(path)!r} is not a directory; pass the "
                                "directory of a sweep (SweepResult.path, or the one "
                                "`kapitza run` printed).")
    if not manifest.exists():
        raise ValueError(f"open_sweep: {str(path)!r} is not a sweep's directory (it has no "
                         f"{MANIFEST}); pass the directory Scene.sweep wrote.")
    return json.loads(manifest.read_text())


def open_sweep(path, *, partial: bool = False):
    """A finished sweep's directory as one :class:`xarray.Dataset` over its axes.

    Parameters
    ----------
    path : str or path
        The sweep's directory (:attr:`kapitza.SweepResult.path`: the Parquet parts and
        ``_sweep.json``).
    partial : bool
        Open an unfinished sweep too: the points not computed are NaN (numbers) or ""
        (text), and the variable ``computed`` marks the others.

    Returns
    -------
    xarray.Dataset
        Dimensions: the sweep's axes in order (their values as coordinates, with units:
        ``A`` in m, ``omega`` in rad/s, …; ``A_over_l`` and ``omega_over_omega0`` beside
        them for a pendulum with l and g fixed), then ``equilibrium`` or ``mode`` where an
        analysis gives several rows per point.  One variable per column of the table
        (``units``, ``long_name``).  ``attrs``: the scene's text, the analysis and its
        method, the fixed parameters (JSON) with their units, the code's fingerprint,
        the versions that computed it.  Write it with
        ``ds.to_netcdf(path, engine="h5netcdf")`` or ``ds.to_zarr(path)``.

    Raises
    ------
    ImportError
        xarray is not installed (``pip install "kapitza[xarray]"``).
    FileNotFoundError, ValueError
        ``path`` is not a sweep's directory; the sweep is unfinished and ``partial`` is
        False (run it again: it resumes where it stopped).

    Examples
    --------
    The slow frequency where the pendulum stayed up, at the frequency nearest 200 rad/s
    (``res = scene.sweep("measure")`` wrote the directory ``res.path``)::

        ds = kapitza.open_sweep(res.path)
        ds["omega_slow_0"].where(ds["stayed_up"]).sel(omega=200.0, method="nearest")
        ds.to_netcdf("measure.nc", engine="h5netcdf")
    """
    from ..results import require_xarray
    require_xarray("kapitza.open_sweep")
    import pyarrow as pa
    import pyarrow.parquet as pq
    path = Path(path)
    manifest = _read_manifest(path)
    axes = [(name, axis_values(record)) for name, record in manifest["axes"].items()]
    parts = sorted(path.glob("part-*.parquet"))
    tables = [pq.read_table(p) for p in parts]
    size = int(manifest["size"])
    if tables:
        table = pa.concat_tables(tables, promote_options="permissive")
        frame = table.to_pandas()
        source = path / "_common_metadata"
        schema = pq.read_schema(source) if source.exists() else tables[0].schema
        metadata = json.loads((schema.metadata or {}).get(b"kapitza", b"{}"))
        metadata.pop("tile", None)
    else:
        import pandas as pd
        frame = pd.DataFrame({"point": np.zeros(0, np.int64)})
        metadata = {}
    done = int(frame["point"].nunique()) if len(frame) else 0
    if done < size and not partial:
        raise ValueError(f"open_sweep: {str(path)!r} is an unfinished sweep: {done} of {size} "
                         f"points computed ({len(parts)} of {manifest.get('tiles', '?')} "
                         "tiles). Run the sweep again to finish it (it resumes where it "
                         "stopped), or pass partial=True to open what is there (the missing "
                         "points NaN).")
    return sweep_grid(frame, axes, metadata).to_xarray()


def sweep_dataset(result):
    """:meth:`SweepResult.to_xarray`: the result's rows over its axes."""
    from ..results import require_xarray
    require_xarray("SweepResult.to_xarray()")
    return result_grid(result).to_xarray()


def result_grid(result) -> LabelledGrid:
    """The labelled grid of a :class:`SweepResult` (its rows in memory)."""
    frame = result.to_dataframe()            # refuses a sweep too large for memory
    axes_meta = result.metadata.get("axes") or {}
    order = [c for c in frame.columns if c in axes_meta] or list(axes_meta)
    order += [k for k in axes_meta if k not in order]
    axes = [(name, axis_values(axes_meta[name])) for name in order]
    return sweep_grid(frame, axes, result.metadata)


def _default_variable(grid) -> tuple:
    """(variable, options) a sweep's figure draws by default."""
    names = list(grid.variables)
    if "stayed_up" in names and "omega_slow_0" in names:
        stayed = np.asarray(grid.variables["stayed_up"].values)
        if np.nan_to_num(stayed.astype(float)).any():
            return "omega_slow_0", {"mask": ~(stayed.astype(float) > 0.5),
                                    "mask_label": "left the band"}
        return "fall_time", {}
    select = {}
    if "equilibrium" in grid.dims:
        labels = list(grid.coords["equilibrium"].values)
        select["equilibrium"] = "inverted" if "inverted" in labels else labels[0]
    for name in ("stable", "stayed_up"):
        if name in names:
            return name, {"select": select} if select else {}
    numeric = [n for n in names if grid.variables[n].values.dtype.kind in "biuf"]
    if not numeric:
        raise ValueError("this sweep has no numeric column to draw; pass variable=.")
    return numeric[0], {"select": select} if select else {}


def sweep_figure(result, variable=None, **options):
    """:meth:`SweepResult.figure`: one column over the sweep's first two axes."""
    grid = result_grid(result)
    if variable is None:
        variable, defaults = _default_variable(grid)
        options = {**defaults, **options}
    return draw_figure("grid_figure", grid, variable, **options)


def sweep_card(result) -> str:
    """:meth:`SweepResult._repr_html_`: the sweep's card."""
    meta = result.metadata or {}
    axes = meta.get("axes") or {}
    rows = [("analysis", str(meta.get("analysis", "?")))]
    for name, axis in axes.items():
        units = _axis_quantity(name)[0] or ""
        kind = axis.get("kind") if isinstance(axis, dict) else None
        rows.append((name, html_span(axis_values(axis), units) + (f", {kind}" if kind else "")))
    frame = result.frame
    done = int(frame["point"].nunique()) if frame is not None and len(frame) else 0
    rows += [("points", f"{done} of {result.size} in {result.tiles} tiles of "
                        f"{result.tile_points}"),
             ("this run", f"{result.computed} tiles computed, {result.skipped} found on disk, "
                          f"{result.seconds:.3g} s ({result.executor})"),
             ("path", str(result.path))]
    if frame is None:
        warnings = ["too large to load: read the dataset in pieces (pyarrow.dataset)"]
    elif done < result.size:
        warnings = [f"unfinished: {result.size - done} points missing (run the sweep again "
                    "to resume)"]
    else:
        warnings = []
    drawable = done > 1 and any(len(axis_values(a)) > 1 for a in axes.values())
    return html_card("SweepResult", str(meta.get("system", "")), rows=rows,
                     warnings=warnings, figure=(lambda: sweep_figure(result)) if drawable
                     else None, alt="sweep")
