"""Checking a scene's ``[analyses]``: each analysis's settings, its axes and the parameters
it names, against the schema (:mod:`._schema`, which states every key).

Like the rest of the reading (:mod:`._file`), nothing here raises: every problem is
recorded on the :class:`~kapitza.scenes._checker.Checker` with its dotted key, and the
checked settings come back in SI units — a frequency axis given in Hz (``frequency_hz``)
is the axis ``omega`` in rad/s, a parameter "frequency_hz" of ``continuation`` or
``bifurcation_diagram`` is "omega" with its values in rad/s.  Also here: :class:`Axis`,
and the physical range of a parameter (:func:`axis_range`), which the sweep's axes share.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import sympy as sp

from lagrange_core import effects as fx
from lagrange_core.symbols import t as t_symbol

from .. import _arguments as arguments
from ._checker import kind_of
from ._rigs import state_values, velocity_unit
from ._schema import (
    ABOUT_EQUILIBRIUM,
    ANALYSES,
    AXIS,
    NEED_DRIVE,
    UNITS,
    WINDOW_METHODS,
    hz_to_rad_s,
)

__all__ = ["Axis", "check_analyses", "check_axis", "in_rad_s", "hz_fits", "axis_range",
           "rig_symbols"]


@dataclass(frozen=True)
class Axis:
    """One swept (or mapped) quantity: its name and its values (a tuple, SI units).

    The name is as written in the file, except a frequency given in Hz
    (``frequency_hz``), which is read as the axis ``omega`` with values in rad/s.
    """

    name: str
    values: tuple
    kind: str = "list"          # "linear", "log" or "list"

    def __len__(self):
        return len(self.values)


def rig_symbols(rig):
    """(parameters of the rig by name → Symbol, names of its mass parameters)."""
    coords = set(rig.coordinates)
    syms, masses = {}, set()
    for _, m, pos in rig.masses:
        for expr in (m, *pos(sp.Integer(0), sp.Integer(0))):
            for s in sp.sympify(expr).free_symbols - coords - {t_symbol}:
                syms[s.name] = s
        masses |= {s.name for s in sp.sympify(m).free_symbols}
    return syms, masses


def axis_range(target, rig, declaration=None):
    """(kind, minimum, strict, unit) of a quantity's physical range: a parameter's, or an
    initial value's (``initial.<state>``, in its coordinate's unit: ``declaration``)."""
    if target.startswith("initial."):
        units = declaration.units if declaration is not None else {}
        name = target[len("initial."):]
        if name in units or not name.endswith("_dot"):
            return "state", None, False, units.get(name, "rad")
        return "state", None, False, velocity_unit(units.get(name[:-len("_dot")], "rad"))
    if target in ("omega", "frequency_hz"):
        return "param", 0.0, True, UNITS[target]
    if target in ("A", "gamma", "c_drag", "g"):
        return "param", 0.0, False, UNITS[target]
    if target.startswith("k_"):
        return "param", 0.0, True, ""
    if rig is not None:
        syms, masses = rig_symbols(rig)
        if target in syms and syms[target].is_positive:
            return "param", 0.0, True, "kg" if target in masses else "m"
    return "param", None, False, UNITS.get(target, "")


# -- [analyses] -------------------------------------------------------------------------------

def check_analyses(c, analyses, effects, rig, params, declaration=None):
    """The analyses asked for, name → checked settings (in the file's order).
    ``declaration``: the rig's units and named states (:mod:`._rigs`), which ``about``,
    ``band``, ``guesses`` and ``starts`` are checked against."""
    out = {}
    if c.table(analyses, "analyses", ANALYSES, what="analysis") is None:
        return out
    drive = next((e for e in effects if isinstance(e, fx.PivotDrive)), None)
    for name, value in analyses.items():
        if name not in ANALYSES:
            continue
        key = f"analyses.{name}"
        if isinstance(value, bool):
            if value:
                out[name] = _check_settings(c, name, {}, key, rig, params, declaration)
            continue
        s = c.table(value, key, ANALYSES[name], what="setting")
        if s is None:
            continue
        out[name] = _check_settings(c, name, s, key, rig, params, declaration)
    for name in out:
        if name in NEED_DRIVE and drive is None:
            c.error(f"analyses.{name}", f"{name} needs a drive: add [effects.drive]")
        if name in ABOUT_EQUILIBRIUM and drive is not None \
                and not drive.keeps_vertical_equilibria:
            path = drive.path if isinstance(drive.path, str) else "oblique"
            c.error(f"analyses.{name}", f"{name} is about an equilibrium, and a {path} drive "
                                        "leaves none; sweep floquet over A and omega instead "
                                        "([sweep])")
    return out


#: Keys checked once the varied parameter is known (their unit and range are its).
_PARAMETER_VALUES = ("start", "stop", "values")


#: Settings that are a number > 0, and their units (tolerances are relative: none).
_POSITIVE = {"tol": "", "rtol": "", "atol": "", "guard_tol": "", "coarse_tol": "",
             "duration": "s", "offset": "", "min_width": "m", "length": "m", "omega0": "rad/s",
             "h": "s", "step": "", "max_step": ""}
#: Settings that are a whole number, and their least value.
_WHOLE = {"periods": 1, "samples": 2, "transient": 0, "max_points": 2, "scan": 4,
          "max_iterations": 1, "max_steps": 1, "every": 1, "blocks": 2}


def _check_settings(c, name, s, key, rig, params, declaration=None):
    out = {}
    for k, v in s.items():
        if k not in ANALYSES[name] or k in _PARAMETER_VALUES:
            continue
        kk = f"{key}.{k}"
        if k == "about":
            out[k] = _check_about(c, v, kk, rig, declaration)
        elif k == "band":
            out[k] = _check_band(c, v, kk, rig, declaration)
        elif k == "guesses":
            out[k] = _check_guesses(c, v, kk, rig, declaration)
        elif k == "taylor_order":
            out[k] = c.number(v, kk, integer=True, minimum=4)
            if out[k] is not None and out[k] > 40:
                c.error(kk, f"must be at most 40, got {v!r} (12–24 are sensible)")
                out[k] = None
        elif k == "symmetry":
            out[k] = c.choice(v, kk, ("auto", "none"))
        elif k == "shooting":
            out[k] = c.choice(v, kk, ("auto", "single", "multiple"))
        elif k == "observables":
            out[k] = _check_observables(c, v, kk)
        elif k == "tangent":
            out[k] = c.choice(v, kk, ("jacobian", "difference"))
        elif k == "t0":
            out[k] = c.number(v, kk, unit="s")
        elif k == "A_range":
            out[k] = _check_amplitude_range(c, v, kk)
        elif k == "error_check":
            out[k] = c.boolean(v, kk)
        elif k == "order":
            if v not in (1, 2) or isinstance(v, bool):
                c.error(kk, f"must be 1 or 2, got {v!r}")
            else:
                out[k] = v
        elif k in ("fit_order", "switch"):
            out[k] = c.boolean(v, kk)
        elif k in _POSITIVE:
            out[k] = c.number(v, kk, minimum=0.0, strict=True, unit=_POSITIVE[k])
        elif k == "periods" and name == "lyapunov":
            out[k] = c.number(v, kk, integer=True, minimum=1)
            if out[k] is not None and out[k] < 8:
                c.error(kk, f"must be ≥ 8, got {v!r}: the error estimate splits the record "
                            "into 8 blocks of at least one drive period")
                out[k] = None
        elif k in _WHOLE:
            out[k] = c.number(v, kk, integer=True, minimum=_WHOLE[k])
        elif k == "method" and name == "window":
            out[k] = c.choice(v, kk, WINDOW_METHODS)
        elif k == "method":
            from lagrange_core.integrate import METHODS
            out[k] = c.choice(v, kk, tuple(METHODS))
        elif k in ("A", "omega"):
            out[k] = check_axis(c, v, kk, k, minimum=0.0, strict=k != "A", unit=UNITS[k])
        elif k == "frequency_hz":           # read in Hz, kept as omega (rad/s)
            out["omega"] = in_rad_s(check_axis(c, v, kk, k, minimum=0.0, strict=True,
                                               unit=UNITS[k]))
        elif k == "parameter":
            out[k] = _check_parameter(c, v, kk, rig, params)
        elif k == "starts":
            out[k] = _check_starts(c, v, kk, rig, declaration)
        elif k == "exponents":
            out[k] = _check_exponents(c, v, kk, rig)
    if name in ABOUT_EQUILIBRIUM:
        c.one_of(s, key, ("omega", "frequency_hz"), "the drive frequencies, omega (rad/s) or "
                                                    "frequency_hz (Hz): a range {start, stop, "
                                                    "num} or a list")
    if name in ("stability_map", "verify") and "A" not in s:
        c.error(f"{key}.A", "missing; the amplitudes (m): a range {start, stop, num} or a list")
    if name == "simulate":
        c.one_of(s, key, ("periods", "duration"), "", required=False)
    if name == "window" and "order" in s and s.get("method", "floquet") != "averaging":
        c.error(f"{key}.order", 'only with method = "averaging": the exact window (method '
                                '"floquet", the default) has no order')
    if name in ("continuation", "bifurcation_diagram"):
        _check_parameter_values(c, name, s, key, rig, params, out)
    _check_needs_states(c, name, s, key, rig, declaration)
    return out


# -- states, bands, guesses: in the rig's own terms (its declaration, :mod:`._rigs`) ----------

def _declared(rig, declaration):
    """(coordinate names, units, named states) of the rig (None where it is unknown)."""
    if rig is None or declaration is None:
        return None
    return [q.name for q in rig.coordinates], declaration.units, declaration.states


def _check_about(c, v, key, rig=None, declaration=None):
    """A state the rig declares by name, "auto", or explicit values per coordinate (a list
    in the rig's order or a table coordinate → value), each in its coordinate's unit."""
    known = _declared(rig, declaration)
    if isinstance(v, str):
        if known is None:                   # the rig is wrong: reported already
            return v
        names, units, states = known
        allowed = [*states, "auto"] if states else []       # "auto" chooses among them
        if v not in allowed:
            whose = "declares no states" if not states else "declares " + ", ".join(states)
            c.unknown(key, v, allowed, what="value",
                      extra=f' (the {rig.name} {whose}; "auto" is the declared state nearest '
                            "the initial one; or give the state's values, e.g. about = { "
                            + ", ".join(f"{q} = …" for q in names) + " })")
            return None
        return v
    if known is not None and (isinstance(v, dict) or isinstance(v, list) and v):
        names, units, _ = known
        return state_values(c, v, key, names, units)
    if isinstance(v, list) and v:
        vals = [c.number(x, f"{key}[{i}]") for i, x in enumerate(v)]
        return tuple(vals) if None not in vals else None
    c.error(key, f'must be the name of a state the rig declares ("inverted", "hanging" for '
                 f'the catalogue\'s rigs), "auto", a list of coordinate values or a table '
                 f"coordinate → value, got {kind_of(v)} {v!r}")
    return None


def _check_band(c, v, key, rig, declaration):
    """A measurement's band: a number (every angle's half-width, rad) or a table
    coordinate → half-width in its unit (> 0); what is not given keeps its default
    (:func:`kapitza.scenes._rigs.default_band`)."""
    known = _declared(rig, declaration)
    if not isinstance(v, dict):
        return c.number(v, key, minimum=0.0, strict=True, unit="rad")
    if known is None:
        return None
    names, units, _ = known
    out = {}
    for q, w in v.items():
        if q not in names:
            c.unknown(f"{key}.{q}", str(q), names, what="coordinate")
            continue
        w = c.number(w, f"{key}.{q}", minimum=0.0, strict=True, unit=units[q])
        if w is not None:
            out[q] = w
    return out if len(out) == len(v) else None


def _check_guesses(c, v, key, rig, declaration):
    """Averaging's starting points: a non-empty list of states (lists of n values or
    tables coordinate → value)."""
    known = _declared(rig, declaration)
    if not isinstance(v, list) or not v:
        c.error(key, "must be a non-empty list of starting points, each a list of coordinate "
                     "values or a table coordinate → value, e.g. [[1.2, 0.0]], got "
                     f"{kind_of(v)} {v!r}")
        return None
    if known is None:
        return None
    names, units, _ = known
    out = [state_values(c, x, f"{key}[{i}]", names, units) for i, x in enumerate(v)]
    return tuple(out) if None not in out else None


#: Analyses whose ``about`` is optional (default: none, not "auto").
_ABOUT_DEFAULT = {"bifurcation_diagram": None}


def _check_needs_states(c, name, s, key, rig, declaration):
    """"auto" (the default ``about``) and averaging's default starting points need the
    rig's states where a coordinate is not an angle: say so here, not at run time."""
    if declaration is None or declaration.states or all(
            u == "rad" for u in declaration.units.values()):
        return
    names = [q.name for q in rig.coordinates]
    coords = ", ".join(f"{q} ({declaration.units[q]})" for q in names)
    fix = ("declare the rig's states ([system] states = { hanging = { "
           + ", ".join(f"{q} = …" for q in names) + " } }, or a `states` attribute of the rig "
           "function)")
    if "about" in ANALYSES[name] and s.get("about", _ABOUT_DEFAULT.get(name, "auto")) == "auto":
        c.error(f"{key}.about", f'"auto" is the declared state nearest the initial one, and the '
                                f"{rig.name} (coordinates {coords}) declares none: {fix}, or "
                                "give about = { " + ", ".join(f"{q} = …" for q in names) + " }")
    if name == "averaging" and "guesses" not in s:
        c.error(f"{key}.guesses", f"missing; averaging looks for equilibria from starting "
                                  f"points, which for angles are 0, ±π/2, π, but the {rig.name} "
                                  f"has coordinates {coords}: give guesses = [["
                                  + ", ".join("…" for _ in names) + f"]], or {fix}")


def _check_observables(c, v, key):
    """What a measurement measures: "all", "classification", or a non-empty list of
    "amplitude", "omega_slow" (a tuple)."""
    if isinstance(v, str):
        return c.choice(v, key, ("all", "classification"))
    if not isinstance(v, list) or not v:
        c.error(key, 'must be "all", "classification" or a list of "amplitude", "omega_slow", '
                     f"got {kind_of(v)} {v!r}")
        return None
    out = [c.choice(x, f"{key}[{i}]", ("amplitude", "omega_slow")) for i, x in enumerate(v)]
    return tuple(out) if None not in out else None


def _check_amplitude_range(c, v, key):
    """A window's scanned amplitudes [low, high] (m), 0 ≤ low < high."""
    if not isinstance(v, list) or len(v) != 2:
        c.error(key, f"must be [low, high] (m) with 0 ≤ low < high, got {kind_of(v)} {v!r}")
        return None
    lo, hi = (c.number(x, f"{key}[{i}]", unit="m", minimum=0.0) for i, x in enumerate(v))
    if None in (lo, hi):
        return None
    if not lo < hi:
        c.error(key, f"must be [low, high] (m) with low < high, got {v!r}")
        return None
    return (lo, hi)


#: Memory per value of an axis read from a range (bytes): the tuple's float objects and
#: their slots, and numpy's array while making them (measured 41 with tracemalloc; rounded
#: up).
AXIS_BYTES_PER_VALUE = 64


def check_axis(c, v, key, name, *, minimum=None, strict=False, unit=""):
    """An axis: a list of numbers, or a range {start, stop, num, scale}."""
    if isinstance(v, list):
        if not v:
            c.error(key, "an empty list; give at least one value")
            return None
        vals = [c.number(x, f"{key}[{i}]", unit=unit, minimum=minimum, strict=strict)
                for i, x in enumerate(v)]
        if unit == "Hz":
            vals = [x if hz_fits(c, x, f"{key}[{i}]") else None for i, x in enumerate(vals)]
        return Axis(name, tuple(vals), "list") if None not in vals else None
    if not isinstance(v, dict):
        c.error(key, f"must be a list of values or a range {{start, stop, num, scale}}, got "
                     f"{kind_of(v)} {v!r}")
        return None
    c.table(v, key, AXIS)
    missing = [k for k in ("start", "stop", "num") if k not in v]
    for k in missing:
        c.error(f"{key}.{k}", "missing; a range is {start, stop, num} (scale = \"linear\" "
                              "or \"log\", default linear)")
    scale = c.choice(v.get("scale", "linear"), f"{key}.scale", ("linear", "log"))
    if missing or scale is None:
        return None
    log = scale == "log"
    lo = c.number(v["start"], f"{key}.start", unit=unit, minimum=0.0 if log else minimum,
                  strict=strict or log)
    hi = c.number(v["stop"], f"{key}.stop", unit=unit, minimum=0.0 if log else minimum,
                  strict=strict or log)
    num = c.number(v["num"], f"{key}.num", integer=True, minimum=1)
    if None in (lo, hi, num):
        return None
    try:        # the values are held as a tuple of floats: refuse, before making them,
        # a range that cannot fit (a grid of axes is checked again before it runs)
        arguments.check_grid_memory(key, (num,), AXIS_BYTES_PER_VALUE,
                                    fix="give fewer points (num)")
    except arguments.GridTooLargeError as e:
        c.error(f"{key}.num", str(e))
        return None
    if not log and num > 1 and not math.isfinite(hi - lo):
        c.error(key, f"the range from {lo!r} to {hi!r}{unit and f' ({unit})'} is wider than a "
                     "float holds (stop − start overflows to inf): give nearer ends")
        return None
    if unit == "Hz" and not (hz_fits(c, lo, f"{key}.start") and hz_fits(c, hi, f"{key}.stop")):
        return None
    import numpy as np
    vals = np.geomspace(lo, hi, num) if log else np.linspace(lo, hi, num)
    return Axis(name, tuple(float(x) for x in vals), scale)


def hz_fits(c, f, key) -> bool:
    """Whether a frequency ``f`` (Hz) is finite in rad/s (2π f); reported if not."""
    if f is not None and not math.isfinite(hz_to_rad_s(f)):
        c.error(key, f"{f!r} Hz is {hz_to_rad_s(f)} in rad/s (2π f overflows a float); give "
                     "a frequency below 2.8e307 Hz")
        return False
    return True


def in_rad_s(axis):
    """A frequency axis read in Hz as the ``omega`` axis in rad/s (None stays None)."""
    if axis is None:
        return None
    return Axis("omega", tuple(hz_to_rad_s(f) for f in axis.values), axis.kind)


# -- the frontier's settings ----------------------------------------------------------------

def _check_parameter(c, v, key, rig, params):
    """The name of the parameter a continuation or a diagram varies: one of the system's
    (as the scene sets them), or "frequency_hz" for omega in Hz."""
    allowed = sorted(params) + (["frequency_hz"] if "omega" in params else [])
    if not isinstance(v, str):
        c.error(key, f"must be the name of a parameter ({', '.join(allowed)}), got "
                     f"{kind_of(v)} {v!r}")
        return None
    if rig is not None and v not in allowed:
        c.unknown(key, v, allowed, what="parameter",
                  extra=" (a parameter the scene sets; the drive's are A and omega)")
        return None
    return v


def _check_parameter_values(c, name, s, key, rig, params, out):
    """start, stop (continuation) or values (bifurcation_diagram), in the varied parameter's
    unit and range; a parameter given as frequency_hz becomes omega (rad/s) here."""
    if "parameter" in s and out.get("parameter") is None:
        return                                       # reported; its range is unknown
    parameter = out.get("parameter", "A")
    kind, minimum, strict, unit = axis_range(parameter, rig)
    hz = parameter == "frequency_hz"
    if hz:
        out["parameter"] = "omega"
    if name == "bifurcation_diagram":
        if "values" not in s:
            c.error(f"{key}.values", f"missing; the values of {parameter} ({unit or 'SI'}): a "
                                     "range {start, stop, num} or a list")
            return
        axis = check_axis(c, s["values"], f"{key}.values", parameter, minimum=minimum,
                          strict=strict, unit=unit)
        out["values"] = in_rad_s(axis) if hz else axis
        return
    ends = {}
    for k in ("start", "stop"):
        if k in s:
            v = c.number(s[k], f"{key}.{k}", unit=unit, minimum=minimum, strict=strict)
            if hz and not hz_fits(c, v, f"{key}.{k}"):
                v = None
            ends[k] = hz_to_rad_s(v) if hz and v is not None else v
    if "stop" not in s:
        c.error(f"{key}.stop", f"missing; where the branch ends: the other end of the interval "
                               f"of {parameter} ({unit or 'SI'}) from its start")
        return
    out.update({k: v for k, v in ends.items() if v is not None})
    start = ends.get("start", params.get(out.get("parameter", parameter)))
    if start is not None and ends.get("stop") is not None and start == ends["stop"]:
        c.error(f"{key}.stop", f"equals the start value of {parameter} ({start!r}"
                               + ("" if "start" in s else ", the scene's") + "); give the "
                               "other end of the interval")


def _check_starts(c, v, key, rig, declaration=None):
    """A list of starting coordinates: numbers (one coordinate each) or lists of n, each
    in its coordinate's unit."""
    n = len(rig.coordinates) if rig is not None else None
    names = [q.name for q in rig.coordinates] if rig is not None else []
    units = declaration.units if declaration is not None else {}
    if not isinstance(v, list) or not v:
        c.error(key, "must be a non-empty list of starting coordinates (rad), e.g. [0.1, 2.0] "
                     "for one coordinate or [[0.1, 0.0], [2.0, 1.0]] for two, got "
                     f"{kind_of(v)} {v!r}")
        return None
    out = []
    for i, x in enumerate(v):
        row = x if isinstance(x, list) else [x]
        vals = [c.number(y, f"{key}[{i}]",
                         unit=units.get(names[j], "rad") if j < len(names) else "rad")
                for j, y in enumerate(row)]
        if n is not None and len(vals) != n:
            c.error(f"{key}[{i}]", f"a start needs {n} coordinate values ({', '.join(names)}), "
                                   f"got {len(vals)}")
            return None
        out.append(tuple(vals))
    return tuple(out) if all(None not in r for r in out) else None


def _check_exponents(c, v, key, rig):
    if isinstance(v, str):
        return c.choice(v, key, ("all", "largest"))
    k = c.number(v, key, integer=True, minimum=1)
    d = 2 * len(rig.coordinates) if rig is not None else None
    if k is not None and d is not None and k > d:
        c.error(key, f"must be at most {d} (the phase space's dimension), got {k}; or \"all\"")
        return None
    return k
