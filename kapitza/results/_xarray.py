"""Labelled grids: a result's numbers on named axes with units, and their xarray ``Dataset``.

Every gridded result builds a :class:`LabelledGrid` (plain numpy: dimensions, coordinates
and variables, each with its units and long name, and the attributes) in a private
``_labelled()`` method; ``to_xarray()`` turns it into an :class:`xarray.Dataset`, and the
figures of gridded data (:func:`kapitza.figures.grid_figure`) read it by its fields, so a
figure needs no xarray.  One builder, so that every Dataset of kapitza reads alike:

* **Dimensions** are named by what varies along them: ``A`` (m) and ``omega`` (rad/s) for
  the drive, a parameter's name for another, ``mode`` (slow modes, ascending Ω),
  ``coordinate`` (the system's coordinates by name), ``curve``, ``start``, ``sample``…
  Every dimension coordinate has ``units`` and ``long_name`` attributes (CF style); a
  dimension that only counts (``mode``, ``start``, ``axis_<k>``) is numbered 0, 1, ….
* Where a pendulum's length l and ω0 = √(g/l) are defined, the dimensionless ``A_over_l``
  (A/l) and ``omega_over_omega0`` (ω/ω0) ride along as non-index coordinates.
* **One variable per quantity**, with ``units`` (UDUNITS spelling: ``m``, ``rad/s``,
  ``1/s``, ``m/s^2``, ``1`` for a dimensionless number; none on a flag, a count of states
  or a text) and ``long_name``.  A stability label carries CF's ``flag_values`` and
  ``flag_meanings``.  Complex numbers are stored as ``<name>_real`` and ``<name>_imag``
  (netCDF has no complex type), tuples of text as one "; "-joined text.
* **Attributes** say what was computed and how: ``kapitza_result`` (the result type),
  ``method``, the tolerances, ``parameters`` (the parameters held fixed, a JSON object
  name → value in SI) with ``parameter_units`` (name → unit, where kapitza knows it),
  ``versions`` (JSON: Python, kapitza, numpy, scipy, xarray) — only text and numbers, so
  that ``ds.to_netcdf(path, engine="h5netcdf")`` and ``ds.to_zarr(path, zarr_format=2)``
  (with ``zarr`` installed; Zarr format 3 has no specification yet for the text variables,
  labels and statuses, and zarr warns so) write them as they are.

Units are known for the drive and the shipped rigs (:data:`PARAMETER_UNITS`; coordinates
named ``theta…`` or ``phi…`` are angles in rad); a user's own parameters and coordinates
get a ``long_name`` and no ``units`` (kapitza cannot know them, and says so in the
``long_name``).
"""
from __future__ import annotations

import json
import math
import re
import sys
from dataclasses import dataclass, field

import numpy as np

__all__ = ["LabelledGrid", "require_xarray", "PARAMETER_UNITS", "quantity_of",
           "coordinate_units", "netcdf_attrs", "package_versions"]

#: The message of the ImportError raised where xarray is missing.
INSTALL = ('needs the optional dependency xarray: pip install "kapitza[xarray]" '
           "(xarray, and h5netcdf to write netCDF files)")

#: Units and long names of the parameters kapitza knows (SI; the drive, the shipped rigs).
PARAMETER_UNITS = {
    "A": ("m", "drive amplitude A"),
    "B": ("m", "second drive amplitude B (horizontal)"),
    "omega": ("rad/s", "drive angular frequency ω"),
    "frequency_hz": ("Hz", "drive frequency f = ω/2π"),
    "l": ("m", "pendulum length l"),
    "g": ("m/s^2", "gravitational acceleration g"),
    "gamma": ("1/s", "damping rate γ"),
    "damping": ("1/s", "damping rate γ"),
    "m": ("kg", "bob mass m"),
    "c_drag": ("kg/m", "air-drag coefficient c = ½ ρ C_d S"),
}
_NUMBERED = {"l": ("m", "length of link {}"), "m": ("kg", "mass of bob {}")}


def require_xarray(what: str = "to_xarray()"):
    """The xarray module, or an ImportError that names the extra to install."""
    try:
        import xarray
    except ImportError as error:
        raise ImportError(f"{what} {INSTALL}.") from error
    return xarray


def coordinate_units(name: str) -> tuple[str | None, str | None]:
    """(units of the coordinate, units of its rate): rad and rad/s for the angles of the
    shipped rigs (``theta``, ``theta1``…, ``phi``…), (None, None) for a coordinate kapitza
    does not know."""
    if re.fullmatch(r"(theta|phi|psi)\d*", name):
        return "rad", "rad/s"
    return None, None


def quantity_of(name: str) -> tuple[str | None, str]:
    """(units, long name) of a parameter or of a state's component named ``name``
    (``initial.theta`` is the initial angle; an unknown name has no units)."""
    if name in PARAMETER_UNITS:
        return PARAMETER_UNITS[name]
    match = re.fullmatch(r"([a-z]+)(\d+)", name)
    if match and match.group(1) in _NUMBERED:
        units, text = _NUMBERED[match.group(1)]
        return units, text.format(match.group(2))
    if name.startswith("initial."):
        coordinate = name.split(".", 1)[1]
        rate = coordinate.endswith("_dot")
        of_state = coordinate_units(coordinate.removesuffix("_dot"))[int(rate)]
        return of_state, (f"initial {'rate of ' if rate else ''}"
                          f"{coordinate.removesuffix('_dot')}")
    of_coordinate = coordinate_units(name)[0]
    if of_coordinate is not None:
        return of_coordinate, f"coordinate {name}"
    return None, f"{name} (units not known to kapitza)"


def package_versions() -> dict:
    """Versions of Python and of the packages that computed and labelled a result."""
    from importlib import metadata
    out = {"python": sys.version.split()[0]}
    for name in ("kapitza", "numpy", "scipy", "xarray"):
        try:
            out[name] = metadata.version(name)
        except metadata.PackageNotFoundError:
            out[name] = "not installed"
    return out


def _plain(value):
    """``value`` in JSON's terms (numpy scalars and arrays as numbers and lists)."""
    if isinstance(value, dict):
        return {str(k): _plain(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_plain(v) for v in value]
    if isinstance(value, np.ndarray):
        return _plain(value.tolist())
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, float) and not math.isfinite(value):
        return str(value)                       # JSON has no NaN or inf
    return value


def netcdf_attrs(attrs: dict) -> dict:
    """``attrs`` as netCDF can store them: text and numbers as they are, a flag as "true"
    or "false", None left out, anything else (dicts, lists, tuples) as JSON text."""
    out: dict = {}
    for key, value in attrs.items():
        if value is None:
            continue
        if isinstance(value, (bool, np.bool_)):
            out[key] = "true" if value else "false"
        elif isinstance(value, (str, int, float, np.integer, np.floating)):
            out[key] = value.item() if isinstance(value, np.generic) else value
        else:
            out[key] = json.dumps(_plain(value), ensure_ascii=False, sort_keys=True)
    return out


@dataclass
class Labelled:
    """One coordinate or variable: its dimensions, values, units and long name."""

    dims: tuple
    values: np.ndarray
    units: str | None
    long_name: str
    attrs: dict = field(default_factory=dict)

    def all_attrs(self) -> dict:
        attrs = {"long_name": self.long_name}
        if self.units is not None:
            attrs["units"] = self.units
        attrs.update(self.attrs)
        return netcdf_attrs(attrs)


def _storable(values) -> np.ndarray:
    """An array netCDF can hold: object arrays of text as unicode, of tuples as "; "-joined
    text."""
    values = np.asarray(values)
    if values.dtype == object:
        flat = [("; ".join(map(str, v)) if isinstance(v, (tuple, list)) else
                 "" if v is None else str(v)) for v in values.reshape(-1)]
        values = np.asarray(flat, dtype=str).reshape(values.shape)
    return values


def _varies(values: np.ndarray, axis: int) -> bool:
    """Whether ``values`` changes along ``axis``."""
    first = np.take(values, [0], axis=axis)
    return not np.array_equal(values, np.broadcast_to(first, values.shape), equal_nan=True)


class LabelledGrid:
    """A result's numbers on named dimensions, with units, long names and attributes.

    Built by a result's ``_labelled()``; :meth:`to_xarray` makes the Dataset, and the
    figures of gridded data read the fields.

    Attributes
    ----------
    kind : str
        The result type ("StabilityMap", …).
    dims : dict
        Dimension name → length, in order.
    coords, variables : dict of str to Labelled
    attrs : dict
    """

    def __init__(self, kind: str, **attrs):
        self.kind = kind
        self.dims: dict[str, int] = {}
        self.coords: dict[str, Labelled] = {}
        self.variables: dict[str, Labelled] = {}
        self.attrs: dict = {"kapitza_result": kind}
        self.attrs.update(attrs)

    # -- building ---------------------------------------------------------------------
    def _check(self, name, dims, values):
        if len(dims) != values.ndim:
            raise ValueError(f"{self.kind}: {name} has {values.ndim} axes for dims {dims}")
        for d, n in zip(dims, values.shape, strict=True):
            if self.dims.setdefault(d, n) != n:
                raise ValueError(f"{self.kind}: {name} has {n} values along {d}, not "
                                 f"{self.dims[d]}")

    def coord(self, name: str, dims, values, units: str | None, long_name: str, **attrs):
        """Add a coordinate (a dimension coordinate when ``dims == (name,)``)."""
        dims = (dims,) if isinstance(dims, str) else tuple(dims)
        values = _storable(values)
        self._check(name, dims, values)
        self.coords[name] = Labelled(dims, values, units, long_name, attrs)

    def variable(self, name: str, dims, values, units: str | None, long_name: str, **attrs):
        """Add a variable; complex values become ``<name>_real`` and ``<name>_imag``."""
        dims = (dims,) if isinstance(dims, str) else tuple(dims)
        values = np.asarray(values)
        if np.iscomplexobj(values):
            self.variable(f"{name}_real", dims, values.real, units, f"{long_name}, real part",
                          **attrs)
            self.variable(f"{name}_imag", dims, values.imag, units,
                          f"{long_name}, imaginary part", **attrs)
            return
        values = _storable(values)
        self._check(name, dims, values)
        self.variables[name] = Labelled(dims, values, units, long_name, attrs)

    def label_variable(self, name: str, dims, label, long_name: str, meanings):
        """An integer label with CF's ``flag_values`` and ``flag_meanings``."""
        self.variable(name, dims, np.asarray(label, dtype=np.int8), None, long_name,
                      flag_values=np.arange(len(meanings), dtype=np.int8),
                      flag_meanings=" ".join(meanings))

    def drive_axes(self, length=None, omega0=None):
        """Beside the drive's coordinates ``A`` and ``omega`` (where present), the
        dimensionless ``A_over_l`` (A/l) and ``omega_over_omega0`` (ω/ω0) where l and ω0
        are known."""
        if length is not None and "A" in self.coords:
            c = self.coords["A"]
            self.coord("A_over_l", c.dims, np.asarray(c.values, float) / length, "1",
                       "drive amplitude over the pendulum's length, A/l")
        if omega0 is not None and "omega" in self.coords:
            c = self.coords["omega"]
            self.coord("omega_over_omega0", c.dims, np.asarray(c.values, float) / omega0,
                       "1", "drive frequency over the small-swing frequency, ω/ω0 "
                       "(ω0 = √(g/l))")

    def pendulum_scales(self, params: dict) -> tuple:
        """(l, ω0) of a pendulum's parameters (scalars ``l`` and ``g``), else (None, None)."""
        l, g = params.get("l"), params.get("g")
        if l is None or g is None or np.ndim(l) or np.ndim(g) or not float(l) > 0:
            return None, None
        return float(l), math.sqrt(float(g) / float(l))

    def broadcast_axes(self, values: dict, shape: tuple, prefer=("A", "omega"),
                       fixed_to: str = "parameters") -> tuple:
        """Name the axes of a broadcast grid of shape ``shape`` by what varies along them.

        ``values`` maps names (parameters, the drive) to arrays broadcastable to
        ``shape``.  An axis along which one of them varies, and nothing else of it does,
        is named by it (those of ``prefer`` first) and gets it as its dimension
        coordinate; an axis along which nothing varies is ``axis_<k>``.  A quantity
        that varies along several axes becomes a coordinate over them; one that varies
        nowhere goes to the attribute ``fixed_to`` (the ``parameters``, with their units,
        by default; else a JSON object).  Returns the dimension names.
        """
        shape = tuple(shape)
        full = {k: np.broadcast_to(np.asarray(v), shape) for k, v in values.items()}
        along = {k: [a for a in range(len(shape)) if shape[a] > 1 and _varies(v, a)]
                 for k, v in full.items()}
        order = [k for k in prefer if k in full] + [k for k in full if k not in prefer]
        dims: list[str] = []
        for a in range(len(shape)):
            name = next((k for k in order if along[k] == [a] and k not in dims), None)
            dims.append(name if name is not None else f"axis_{a}")
        fixed = {}
        for k in order:
            v = full[k]
            units, long_name = quantity_of(k)
            if not along[k]:
                fixed[k] = v.reshape(-1)[0].item() if v.size else math.nan
                continue
            if len(along[k]) == 1:
                a = along[k][0]
                index = tuple(slice(None) if b == a else 0 for b in range(len(shape)))
                self.coord(k, (dims[a],), v[index], units, long_name)
            else:
                self.coord(k, tuple(dims), v, units, long_name)
        if fixed_to == "parameters":
            self.parameters(fixed)
        else:
            self.attrs[fixed_to] = json.dumps(_plain(fixed), sort_keys=True)
        return tuple(dims)

    def parameters(self, params: dict):
        """Record the parameters held fixed (scalars) in the attributes, with their units."""
        fixed = {str(k): (np.asarray(v).item() if np.ndim(v) == 0 else np.asarray(v).tolist())
                 for k, v in params.items()}
        current = json.loads(self.attrs.get("parameters", "{}"))
        current.update(fixed)
        self.attrs["parameters"] = json.dumps(_plain(current), sort_keys=True)
        units = {k: quantity_of(k)[0] for k in current if quantity_of(k)[0] is not None}
        self.attrs["parameter_units"] = json.dumps(units, sort_keys=True, ensure_ascii=False)

    # -- reading ----------------------------------------------------------------------
    def values(self, name: str) -> np.ndarray:
        """A coordinate's or a variable's values."""
        return (self.coords.get(name) or self.variables[name]).values

    def to_xarray(self):
        """The :class:`xarray.Dataset`: coordinates, variables and netCDF-safe attributes."""
        xr = require_xarray(f"{self.kind}.to_xarray()")
        attrs = dict(self.attrs)
        attrs.setdefault("versions", package_versions())
        coords = {k: (c.dims, c.values, c.all_attrs()) for k, c in self.coords.items()}
        for dim, size in self.dims.items():       # a numbered axis (mode, start, …): 0, 1, …
            if dim not in coords:
                coords[dim] = ((dim,), np.arange(size), {"long_name": f"{dim} number"})
        data = {k: (v.dims, v.values, v.all_attrs()) for k, v in self.variables.items()}
        return xr.Dataset(data, coords=coords, attrs=netcdf_attrs(attrs))
