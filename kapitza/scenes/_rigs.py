"""A rig's declaration: the units of its coordinates and its named states.

An analysis is *about* a state (``about = "hanging"``), a measurement stays within a band
about it, and a message names the state tried — all in the rig's own terms, never the
pendulum's.  Every rig therefore has a :class:`RigDeclaration`:

* the catalogue's rigs (the pendulum, the chains): every coordinate an angle (rad) from
  the downward vertical, states ``inverted`` (every angle π) and ``hanging`` (0);
* a user's rig (``system.name = "package.module:function"``) declares its own, on the
  rig function (attributes ``units`` and ``states``, :func:`module_declaration`) and/or
  in the scene's ``[system]`` (keys ``units`` and ``states``; the scene's win, name by
  name and coordinate by coordinate).  A coordinate whose unit is not declared is
  inferred: an angle (rad) where every mass's position is 2π-periodic in it, a length
  (m) where the positions are linear in it; anything else must be declared.  A rig of
  angles only that declares no states has the catalogue's ``inverted`` and ``hanging``;
  a rig with a coordinate that is not an angle has only the states it declares.

Units are "rad" (an angle), "m" (a length) or "1" (a pure number); velocities are in
rad/s, m/s or 1/s.  What a unit sets: the default half-width of a measurement's band
about a state (:func:`default_band`): π/2 for an angle (a quarter turn), half the
state's value for a length (:data:`LENGTH_BAND_FRACTION`), none for a pure number or a
length at 0 (unbounded; give ``band`` to bound it).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import sympy as sp

__all__ = ["RigDeclaration", "UNITS_OF_COORDINATES", "LENGTH_BAND_FRACTION",
           "catalogue_declaration", "check_declaration", "module_declaration", "format_state",
           "velocity_unit", "default_band"]

#: The units a coordinate may have, and what each is.
UNITS_OF_COORDINATES = {"rad": "an angle", "m": "a length", "1": "a pure number"}
#: A length's default band: this fraction of its value at the state (|r − r*| < r*/2).
LENGTH_BAND_FRACTION = 0.5
#: The angle's default band: a quarter turn.
ANGLE_BAND = math.pi / 2


@dataclass(frozen=True)
class RigDeclaration:
    """The units of a rig's coordinates and its named states.

    Attributes
    ----------
    units : dict coordinate → "rad", "m" or "1"
    states : dict name → tuple of floats
        Each state's coordinates, in the rig's order and units.
    declared_by : str
        Where the states come from: "catalogue", "angles" (a user's rig of angles only
        that declares none: the catalogue's two), "scene", "module", "module and scene",
        or "none" (a rig with a coordinate that is not an angle, declaring none).
    """

    units: dict
    states: dict
    declared_by: str

    @property
    def angles(self) -> tuple:
        """The coordinates that are angles."""
        return tuple(q for q, u in self.units.items() if u == "rad")


def catalogue_declaration(rig) -> RigDeclaration:
    """The catalogue's rigs: angles from the downward vertical, inverted and hanging."""
    names = [q.name for q in rig.coordinates]
    n = len(names)
    return RigDeclaration({q: "rad" for q in names},
                          {"inverted": (math.pi,) * n, "hanging": (0.0,) * n}, "catalogue")


def velocity_unit(unit: str) -> str:
    """The unit of a coordinate's rate: rad/s, m/s or 1/s."""
    return f"{unit}/s" if unit != "1" else "1/s"


def format_state(names, units, q) -> str:
    """"r = 1.245 m, theta = 0 rad": a state's coordinates with their units."""
    return ", ".join(f"{c} = {float(v):.6g}" + (f" {units.get(c)}" if units.get(c, "1") != "1"
                                                  else "")
                     for c, v in zip(names, np.ravel(q), strict=True))


def module_declaration(factory) -> tuple:
    """The ``units`` and ``states`` attributes of a rig function (None where absent)."""
    return getattr(factory, "units", None), getattr(factory, "states", None)


# -- inference ----------------------------------------------------------------------------

def _positions(rig):
    return [sp.sympify(x) for _, _, pos in rig.masses for x in pos(sp.Integer(0), sp.Integer(0))]


def _numeric(exprs, rng):
    """The expressions at random values of every symbol (0.3 … 1.7), as floats."""
    symbols = set().union(*(e.free_symbols for e in exprs)) if exprs else set()
    values = {s: float(rng.uniform(0.3, 1.7)) for s in symbols}
    return [complex(e.evalf(subs=values)) for e in exprs]


def inferred_unit(rig, q) -> str | None:
    """"rad" where every position is 2π-periodic in ``q``, "m" where every position is
    linear in it, else None (tested at random points: a coordinate that passes by chance
    would have to do so at three random points)."""
    exprs = [e for e in _positions(rig) if q in e.free_symbols]
    if not exprs:
        return None
    rng = np.random.default_rng(7)
    shifted = [e.subs(q, q + 2 * sp.pi) - e for e in exprs]
    curved = [sp.diff(e, q, 2) for e in exprs]
    scale = [max(1.0, abs(v)) for v in _numeric(exprs, rng)]
    for _ in range(3):
        if not all(abs(d) <= 1e-9 * s for d, s in zip(_numeric(shifted, rng), scale, strict=True)):
            break
    else:
        return "rad"
    for _ in range(3):
        if not all(abs(d) <= 1e-9 * s for d, s in zip(_numeric(curved, rng), scale, strict=True)):
            return None
    return "m"


# -- checking -----------------------------------------------------------------------------

def check_declaration(c, system, rig, rig_name, factory, params) -> RigDeclaration | None:
    """The declaration of ``rig``: the catalogue's, or a user's rig's from its function
    (``factory``) and the scene's ``[system]`` table (``units``, ``states``), checked;
    every problem is reported on ``c`` with its key.  ``params``: the scene's parameter
    values, for states declared as a function of them."""
    if rig is None:
        return None
    names = [q.name for q in rig.coordinates]
    if factory is None:
        decl = catalogue_declaration(rig)
        for key in ("units", "states"):
            if key in system:
                c.error(f"system.{key}", f"only for a user's rig (\"package.module:function\"); "
                                         f"the {rig_name}'s coordinates are angles (rad) and "
                                         "its states inverted and hanging")
        return decl
    mod_units, mod_states = module_declaration(factory)
    where = f"{rig_name}.units"
    units = {}
    if mod_units is not None:
        units.update(_check_units(c, mod_units, "system.name", names, prefix=f"{where}: "))
    if "units" in system:
        units.update(_check_units(c, system["units"], "system.units", names))
    for q in rig.coordinates:
        if q.name in units:
            continue
        unit = inferred_unit(rig, q)
        if unit is None:
            c.error("system.units", f"the unit of the coordinate {q.name!r} is not declared "
                                    f"and cannot be inferred (the masses' positions are neither "
                                    f"2π-periodic nor linear in it); declare it, e.g. units = "
                                    f"{{ {q.name} = \"m\" }} (one of "
                                    f"{', '.join(UNITS_OF_COORDINATES)})")
            unit = "1"
        units[q.name] = unit
    units = {q: units[q] for q in names}
    states, by = {}, []
    if mod_states is not None:
        declared = mod_states
        if callable(declared):
            try:
                declared = declared(dict(params))
            except Exception as e:      # noqa: BLE001 - the user's function, the user's error
                c.error("system.name", f"{rig_name}.states(parameters) raised "
                                       f"{type(e).__name__}: {e}")
                declared = {}
        states.update(_check_states(c, declared, "system.name", names, units,
                                    prefix=f"{rig_name}.states: "))
        by.append("module")
    if "states" in system:
        states.update(_check_states(c, system["states"], "system.states", names, units))
        by.append("scene")
    if not by and all(u == "rad" for u in units.values()):
        n = len(names)
        return RigDeclaration(units, {"inverted": (math.pi,) * n, "hanging": (0.0,) * n},
                              "angles")
    return RigDeclaration(units, states, " and ".join(by) or "none")


def _check_units(c, value, key, names, prefix=""):
    if not isinstance(value, dict):
        c.error(key, f"{prefix}must be a table coordinate → unit, e.g. {{ {names[0]} = "
                     f"\"m\" }}, got {type(value).__name__} {value!r}")
        return {}
    out = {}
    for q, u in value.items():
        if q not in names:
            c.unknown(f"{key}.{q}" if not prefix else key, str(q), names,
                      what=f"{prefix}coordinate")
        elif not isinstance(u, str) or u not in UNITS_OF_COORDINATES:
            c.error(f"{key}.{q}" if not prefix else key,
                    f"{prefix}unknown unit {u!r} of {q}; allowed: "
                    + ", ".join(f"\"{k}\" ({v})" for k, v in UNITS_OF_COORDINATES.items()))
        else:
            out[q] = u
    return out


def _check_states(c, value, key, names, units, prefix=""):
    """name → tuple of coordinates, each state a table coordinate → value (every
    coordinate) or a list of n values."""
    if not isinstance(value, dict):
        c.error(key, f"{prefix}must be a table of named states, e.g. {{ hanging = {{ "
                     + ", ".join(f"{q} = 0.0" for q in names)
                     + f" }} }}, got {type(value).__name__} {value!r}")
        return {}
    out = {}
    for name, state in value.items():
        k = f"{key}.{name}" if not prefix else key
        if name == "auto":
            c.error(k, f"{prefix}\"auto\" is not a name a state may have: it means the "
                       "declared state nearest the initial one")
            continue
        q = state_values(c, state, k, names, units, prefix=f"{prefix}{name}: ")
        if q is not None:
            out[str(name)] = q
    return out


def state_values(c, v, key, names, units, prefix=""):
    """A state given as a table coordinate → value (every coordinate) or a list of n
    values, as a tuple in the rig's order (None, reported, if it is not one)."""
    n = len(names)
    if isinstance(v, dict):
        missing = [q for q in names if q not in v]
        for q in v:
            if q not in names:
                c.unknown(key if prefix else f"{key}.{q}", str(q), names,
                          what=f"{prefix}coordinate")
                return None
        if missing:
            c.error(key, f"{prefix}missing {', '.join(missing)}; a state gives every "
                         f"coordinate ({', '.join(f'{q} ({units.get(q, 1)})' for q in names)})")
            return None
        vals = [c.number(v[q], key if prefix else f"{key}.{q}", unit=units.get(q, ""))
                for q in names]
    elif isinstance(v, (list, tuple)) and not isinstance(v, str):
        if len(v) != n:
            c.error(key, f"{prefix}needs {n} coordinate value{'s' if n > 1 else ''} "
                         f"({', '.join(names)}), got {len(v)}")
            return None
        vals = [c.number(x, f"{key}[{i}]", unit=units.get(q, ""))
                for i, (x, q) in enumerate(zip(v, names, strict=True))]
    else:
        c.error(key, f"{prefix}must be a table {{ "
                     + ", ".join(f"{q} = …" for q in names)
                     + f" }} or a list of {n} values, got {type(v).__name__} {v!r}")
        return None
    return tuple(vals) if None not in vals else None


def default_band(units, names, about, band=None):
    """The half-widths of a measurement's band about ``about`` ((n,) or (points, n)):
    a dict coordinate → half-width (coordinates left out are unbounded), or a float where
    every coordinate is an angle with the same half-width (as the API's default).

    ``band``: the scene's setting — None (defaults), a number (every angle's half-width,
    rad; the other coordinates keep their defaults) or a dict coordinate → half-width in
    its unit (the others keep their defaults)."""
    if band is None or isinstance(band, (int, float)):
        angle = ANGLE_BAND if band is None else float(band)
        if all(units[q] == "rad" for q in names):
            return angle
        given = {}
    else:
        angle, given = ANGLE_BAND, dict(band)
    about = np.asarray(about, dtype=float)
    out = {}
    for j, q in enumerate(names):
        if q in given:
            out[q] = given[q]
        elif units[q] == "rad":
            out[q] = angle
        elif units[q] == "m":
            half = LENGTH_BAND_FRACTION * np.abs(about[..., j])
            half = np.where(half > 0, half, np.inf)     # a length at 0: no scale, unbounded
            out[q] = half if half.ndim else float(half)
    return out

