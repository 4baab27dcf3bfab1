"""Reading a scene file: parsed with :mod:`tomllib`, every key checked before anything is built.

:func:`read_scene` (or :func:`read_scene_text`) checks each table against the schema
(:mod:`._schema`, which states it) and returns a :class:`SceneSpec`; every problem found is
collected and raised together as one :class:`~kapitza.SceneError`
(:mod:`._checker`), each naming the file, the dotted key and its line, what is allowed,
and the nearest allowed key for a misspelt one.  :class:`kapitza.Scene` builds the System
and runs the analyses.  A frequency given in Hz is converted to rad/s here, once: a
:class:`SceneSpec` holds ``omega`` only (the parameter, the analyses' axes and the sweep's
axis).

Examples
--------
>>> spec = read_scene_text('''
... schema = 1
... [system]
... name = "pendulum"
... [parameters]
... l = 1.0
... [effects]
... gravity = true
... [effects.drive]
... amplitude = 0.05
... frequency_hz = 60.0
... [analyses]
... window = { frequency_hz = [50.0, 60.0] }
... ''')
>>> sorted(spec.params.items())
[('A', 0.05), ('g', 9.81), ('l', 1.0), ('m', 1.0), ('omega', 376.99111843077515)]
>>> spec.analyses["window"]["omega"].values          # rad/s
(314.1592653589793, 376.99111843077515)
>>> try:
...     read_scene_text('schema = 1\\n[system]\\nname = "pendulm"\\n')
... except SceneError as e:
...     print(e)                                         # doctest: +ELLIPSIS
scene <text> has 2 errors:
  <text>:3: system.name: unknown rig 'pendulm'; allowed: pendulum, ... Did you mean 'pendulum'?
  <text>: parameters: missing table; the rig's parameters go here
"""
from __future__ import annotations

import importlib
import re
import tomllib
from dataclasses import dataclass, field
from pathlib import Path

from lagrange_core import effects as fx

from ._checker import Checker, SceneError, SceneProblem, kind_of
from ._rigs import RigDeclaration, check_declaration, velocity_unit
from ._schema import (
    AXIS,
    CATALOGUE,
    DRIVE,
    EFFECTS,
    KEY_TARGETS,
    ONE_NUMBER_EFFECTS,
    OWNERS,
    SCHEMA,
    SWEEPABLE,
    TOP,
    UNITS,
    hz_to_rad_s,
)
from ._settings import (
    Axis,
    axis_range,
    check_analyses,
    check_axis,
    hz_fits,
    in_rad_s,
    rig_symbols,
)

__all__ = ["SceneSpec", "Axis", "read_scene", "read_scene_text", "read_scene_data"]


@dataclass(frozen=True)
class SceneSpec:
    """A checked scene: everything :class:`kapitza.Scene` builds and runs from.

    Attributes
    ----------
    source : str
        The file's path, or "<text>".
    text : str
        The TOML text as read.
    title : str or None
    rig_name : str
        As written in ``system.name``.
    rig : lagrange_core.effects.Rig
    effects : tuple of effect objects (:mod:`lagrange_core.effects`)
    params : dict name → float
        Every parameter of the System (SI units: the drive's ``omega`` in rad/s even
        where the file gave ``frequency_hz``), defaults filled in.
    initial : dict coordinate → float, and ``<coordinate>_dot`` → float
    analyses : dict name → dict of settings
        Only the analyses asked for, in the file's order.  Axes are :class:`Axis`; a
        frequency axis is always ``omega`` (rad/s), never ``frequency_hz``.
    sweep : dict or None
        ``axes`` (tuple of :class:`Axis`; a ``frequency_hz`` axis is read as ``omega``,
        rad/s), ``targets`` (axis name → what it sets: a parameter or
        ``initial.<state>``), ``analyses`` (tuple), ``tile_points`` (int or None).
    output : dict
        ``directory`` (Path or None) and ``formats`` (tuple).
    data : dict
        The parsed TOML, as written (for the record; Hz where the file has Hz).
    declaration : kapitza.scenes._rigs.RigDeclaration
        The units of the rig's coordinates and its named states (the catalogue's, or what
        a user's rig declares: :mod:`kapitza.scenes._rigs`); also :attr:`units` and
        :attr:`states`.
    """

    source: str
    text: str
    title: str | None
    rig_name: str
    rig: object
    effects: tuple
    params: dict
    initial: dict
    analyses: dict
    sweep: dict | None
    output: dict
    data: dict = field(repr=False, default_factory=dict)
    declaration: RigDeclaration | None = None

    @property
    def units(self) -> dict:
        """The unit of each coordinate ("rad", "m" or "1"), in the rig's order."""
        return dict(self.declaration.units) if self.declaration is not None else {}

    @property
    def states(self) -> dict:
        """The rig's named states: name → coordinates (a tuple, the rig's order and units)."""
        return dict(self.declaration.states) if self.declaration is not None else {}

    def declared_key(self) -> dict:
        """What a user's rig declares (its units and states), for the scene's key: the
        numbers depend on the state ``about`` names.  Empty for a rig that declares nothing
        (the catalogue's, a rig of angles only), whose key is as it was."""
        d = self.declaration
        if d is None or d.declared_by in ("catalogue", "angles"):
            return {}
        return {"rig": {"units": d.units, "states": {k: list(v) for k, v in d.states.items()}}}


#: The most links a scene's chain may have: its equations are derived symbolically (the
#: 8-link chain derives and compiles in seconds; 10¹² links filled the memory building the
#: coordinates' names, found by tests/test_properties_scenes.py)
MAX_CHAIN_LINKS = 64


def read_scene(path) -> SceneSpec:
    """Read and check the scene file at ``path`` (see the module docstring).

    Raises
    ------
    SceneError
        Every problem found (a TOML syntax error alone, as it stops the reading).
    """
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8")
    except OSError as e:
        raise SceneError(str(path), [SceneProblem("(file)", None, f"cannot be read: {e}")]) \
            from None
    return read_scene_text(text, source=str(path))


def read_scene_text(text: str, source: str = "<text>") -> SceneSpec:
    """Read and check a scene given as TOML text; ``source`` names it in messages and sets
    the directory that ``output.directory`` is relative to (the current one for "<text>")."""
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as e:
        m = re.search(r"line (\d+)", str(e))
        raise SceneError(source, [SceneProblem("(syntax)", int(m.group(1)) if m else None,
                                               f"not valid TOML: {e}")]) from None
    return read_scene_data(data, text=text, source=source)


def read_scene_data(data: dict, *, text: str = "", source: str = "<data>") -> SceneSpec:
    """Check a scene given as the parsed TOML (a dict of tables, as :mod:`tomllib` reads
    a file): what :func:`read_scene_text` does after parsing.  ``text``, when given, is
    the file the data came from (its lines are named in messages); the command line
    builds scenes this way, from its options."""
    c = Checker(source, text)
    c.table(data, "", TOP, what="table")
    _check_schema(c, data)
    title = data.get("title")
    if title is not None and not isinstance(title, str):
        c.error("title", f"must be text, got {kind_of(title)} {title!r}")
        title = None
    rig_name, rig, factory = _check_system(c, data.get("system"))
    effects, effect_params = _check_effects(c, data.get("effects", {}), rig)
    params = _check_parameters(c, data.get("parameters"), rig, effects, effect_params)
    system = data.get("system")
    declaration = check_declaration(c, system if isinstance(system, dict) else {}, rig,
                                    rig_name, factory, params)
    initial = _check_initial(c, data.get("initial", {}), rig, declaration)
    analyses = check_analyses(c, data.get("analyses", {}), effects, rig, params, declaration)
    sweep = _check_sweep(c, data.get("sweep"), rig, params, effects, analyses, declaration)
    output = _check_output(c, data.get("output", {}), source)
    c.done()
    return SceneSpec(source=source, text=text, title=title, rig_name=rig_name, rig=rig,
                     effects=tuple(effects), params=params, initial=initial, analyses=analyses,
                     sweep=sweep, output=output, data=data, declaration=declaration)


def _check_schema(c, data):
    if "schema" not in data:
        c.error("schema", f"missing; a scene file starts with `schema = {SCHEMA}`")
        return
    v = data["schema"]
    if isinstance(v, bool) or not isinstance(v, int):
        c.error("schema", f"must be the whole number {SCHEMA}, got {kind_of(v)} {v!r}")
    elif v != SCHEMA:
        c.error("schema", f"unsupported schema version {v}; this kapitza reads schema {SCHEMA}")


# -- system -------------------------------------------------------------------------------

def _check_system(c, system):
    """(name, rig, the user's rig function or None): the rig is None where it is wrong
    (reported)."""
    if system is None:
        c.error("system", "missing table; say what hangs from the pivot, e.g. [system] "
                          'name = "pendulum"')
        return None, None, None
    system = c.table(system, "system", ("name", "links", "options", "units", "states"))
    if system is None:
        return None, None, None
    name = system.get("name")
    if name is None:
        c.error("system.name", 'missing; a rig of the catalogue (' + ", ".join(CATALOGUE)
                + ') or "package.module:function"')
        return None, None, None
    if not isinstance(name, str):
        c.error("system.name", f"must be text, got {kind_of(name)} {name!r}")
        return None, None, None
    options = system.get("options", {})
    if not isinstance(options, dict):
        c.error("system.options", f"must be a table of keyword arguments, got {kind_of(options)}")
        options = {}
    links = system.get("links")
    if name == "chain":
        if links is None:
            c.error("system.links", "missing; a chain needs its number of links, e.g. links = 3")
            return name, None, None
        n = c.number(links, "system.links", integer=True, minimum=1)
        if n is not None and n > MAX_CHAIN_LINKS:
            c.error("system.links", f"a chain of {n} links is more than the {MAX_CHAIN_LINKS} "
                    "a scene builds (its equations are derived symbolically: their size "
                    "grows as links³); give fewer links")
            return name, None, None
        return (name, fx.n_link_rig(n), None) if n is not None else (name, None, None)
    if links is not None:
        c.error("system.links", f"only for name = \"chain\" (system.name is {name!r})")
    if ":" in name:
        return (name, *_user_rig(c, name, options))
    if name not in fx.RIGS:
        c.unknown("system.name", name, CATALOGUE, what="rig",
                  extra=', or "package.module:function"')
        return name, None, None
    if options:
        c.error("system.options", "only for a user's rig (\"package.module:function\")")
    return name, fx.RIGS[name](), None


def _user_rig(c, name, options):
    """(rig, its function): (None, None) where either is wrong (reported)."""
    module, _, function = name.partition(":")
    try:
        mod = importlib.import_module(module)
    except Exception as e:      # noqa: BLE001 - any import failure is the user's to see
        c.error("system.name", f"cannot import module {module!r} ({type(e).__name__}: {e})")
        return None, None
    fn = getattr(mod, function, None)
    if not callable(fn):
        c.unknown("system.name", function,
                  [k for k, v in vars(mod).items() if callable(v) and not k.startswith("_")],
                  what=f"function of {module}")
        return None, None
    try:
        rig = fn(**options)
    except Exception as e:      # noqa: BLE001
        c.error("system.name", f"{name}(**system.options) raised {type(e).__name__}: {e}")
        return None, None
    if not isinstance(rig, fx.Rig):
        c.error("system.name", f"{name} must return a lagrange_core.effects.Rig (coordinates "
                               f"and masses, so that effects can be applied), got "
                               f"{type(rig).__name__}")
        return None, None
    return rig, fn


# -- effects ------------------------------------------------------------------------------

def _check_effects(c, effects, rig):
    """The effect objects and the values of their parameters."""
    out, values = [], {}
    if c.table(effects, "effects", EFFECTS, what="effect") is None:
        return out, values
    gravity = effects.get("gravity", False)
    if isinstance(gravity, dict):
        c.error("effects.gravity", "is `gravity = true` or `false`; its parameter g goes in "
                                   "[parameters]")
    elif c.boolean(gravity, "effects.gravity"):
        out.append(fx.Gravity())
    if "drive" in effects:
        drive = _check_drive(c, effects["drive"], values)
        if drive is not None:
            out.append(drive)
    for name, (kind, k, param, unit, what) in ONE_NUMBER_EFFECTS.items():
        if name not in effects:
            continue
        d = c.table(effects[name], f"effects.{name}", (k,))
        if d is None:
            continue
        if k not in d:
            c.error(f"effects.{name}.{k}", f"missing; {what}")
        else:
            v = c.number(d[k], f"effects.{name}.{k}", unit=unit, minimum=0.0)
            if v is not None:
                values[param] = v
        out.append(kind())
    if "spring" in effects:
        springs = effects["spring"]
        coords = [q.name for q in rig.coordinates] if rig is not None else None
        if c.table(springs, "effects.spring", coords if coords is not None else springs,
                   what="coordinate") is not None:
            for q, s in springs.items():
                key = f"effects.spring.{q}"
                if coords is not None and q not in coords:
                    continue
                s = c.table(s, key, ("k", "rest"))
                if s is None:
                    continue
                k = c.number(s["k"], f"{key}.k", minimum=0.0, strict=True) if "k" in s \
                    else c.error(f"{key}.k", "missing; the spring constant (> 0)")
                rest = c.number(s.get("rest", 0.0), f"{key}.rest")
                if k is not None:
                    values[f"k_{q}"] = k
                out.append(fx.Spring(q, rest=rest if rest is not None else 0.0))
    return out, values


def _check_drive(c, d, values):
    d = c.table(d, "effects.drive", DRIVE)
    if d is None:
        return None
    key = "effects.drive"
    direction = d.get("direction", "vertical")
    path = None
    if isinstance(direction, str):
        path = c.choice(direction, f"{key}.direction", ("vertical", "horizontal", "elliptic"))
    elif isinstance(direction, list) and len(direction) == 2:
        v = [c.number(x, f"{key}.direction[{i}]") for i, x in enumerate(direction)]
        if None not in v:
            if v[0] == v[1] == 0:
                c.error(f"{key}.direction", "a direction [dx, dy] must not be zero")
            else:
                path = tuple(v)
    else:
        c.error(f"{key}.direction", f'must be "vertical", "horizontal", "elliptic" or a vector '
                                    f"[dx, dy], got {kind_of(direction)} {direction!r}")
    if "amplitude" not in d:
        c.error(f"{key}.amplitude", "missing; the pivot's amplitude A (m), ≥ 0")
    else:
        a = c.number(d["amplitude"], f"{key}.amplitude", unit="m", minimum=0.0)
        if a is not None:
            values["A"] = a
    if path == "elliptic":
        if "amplitude_y" not in d:
            c.error(f"{key}.amplitude_y", "missing; the ellipse's y semi-axis B (m) of "
                                          "y = B sin ωt (negative: clockwise)")
        else:
            b = c.number(d["amplitude_y"], f"{key}.amplitude_y", unit="m")
            if b is not None:
                values["B"] = b
    elif "amplitude_y" in d:
        c.error(f"{key}.amplitude_y", 'only for direction = "elliptic"')
    k = c.one_of(d, key, ("frequency_hz", "omega"), "the drive's frequency as frequency_hz "
                                                     "(Hz) or omega (rad/s), > 0")
    if k is not None:
        v = c.number(d[k], f"{key}.{k}", unit=UNITS[k], minimum=0.0, strict=True)
        if v is not None and (k != "frequency_hz" or hz_fits(c, v, f"{key}.{k}")):
            values["omega"] = hz_to_rad_s(v) if k == "frequency_hz" else v
    harmonics = ((1, 1.0, 0.0),)
    if "harmonics" in d:
        h = d["harmonics"]
        ok = isinstance(h, list) and h and all(
            isinstance(x, list) and len(x) == 3 for x in h)
        if not ok:
            c.error(f"{key}.harmonics", f"must be a list of [k, a_k, phase] (whole k ≥ 1, "
                                        f"relative amplitude, phase in rad), got {h!r}")
        else:
            parsed = []
            for i, (k, a, ph) in enumerate(h):
                k = c.number(k, f"{key}.harmonics[{i}]", integer=True, minimum=1)
                a = c.number(a, f"{key}.harmonics[{i}]")
                ph = c.number(ph, f"{key}.harmonics[{i}]", unit="rad")
                parsed.append((k, a, ph))
            if all(None not in p for p in parsed):
                harmonics = tuple(parsed)
            if path == "elliptic":
                c.error(f"{key}.harmonics", "the elliptic path has no extra harmonics")
                harmonics = ((1, 1.0, 0.0),)
    if path is None:
        return None
    try:
        return fx.PivotDrive(path, harmonics)
    except ValueError as e:
        c.error(key, str(e))
        return None


# -- parameters, initial state ------------------------------------------------------------------

def _check_parameters(c, given, rig, effects, effect_params):
    if given is None:
        c.error("parameters", "missing table; the rig's parameters go here")
        return dict(effect_params)
    if not isinstance(given, dict):
        c.table(given, "parameters", ())
        return dict(effect_params)
    params = dict(effect_params)
    if rig is None:             # reported already; check the values only
        for k, v in given.items():
            c.number(v, f"parameters.{k}")
        return params
    syms, masses = rig_symbols(rig)
    gravity = any(isinstance(e, fx.Gravity) for e in effects)
    allowed = sorted(syms) + (["g"] if gravity else [])
    for k, v in given.items():
        key = f"parameters.{k}"
        if k == "g" and not gravity:
            c.error(key, "g is gravity's parameter, but gravity is off: add `gravity = true` "
                         "under [effects], or remove g")
            continue
        if k in OWNERS and k != "g" or k.startswith("k_"):
            where = OWNERS[k][1] if k in OWNERS else f"effects.spring.{k[2:]}.k"
            c.error(key, f"{k} is set by {where}, not in [parameters]")
            continue
        if k not in allowed:
            c.unknown(key, k, allowed, what=f"parameter of the {rig.name}")
            continue
        positive = k in syms and bool(syms[k].is_positive)
        v = c.number(v, key, unit=UNITS.get(k, "m" if k.startswith("l") else
                                              "kg" if k in masses else ""),
                     minimum=0.0 if positive or k == "g" else None, strict=positive)
        if v is not None:
            params[k] = v
    for k in syms:
        if k not in given:
            if k in masses:
                params[k] = 1.0
            else:
                c.error(f"parameters.{k}", f"missing; the {rig.name} needs {k}"
                                           + (" (m), > 0" if k.startswith("l") else ""))
    if gravity and "g" not in given:
        params["g"] = 9.81
    return params


def _check_initial(c, initial, rig, declaration):
    if c.table(initial, "initial", initial if rig is None else _state_names(rig),
               what="coordinate") is None or rig is None:
        return {}
    out = {}
    for k, v in initial.items():
        if k in _state_names(rig):
            v = c.number(v, f"initial.{k}", unit=state_unit(k, declaration))
            if v is not None:
                out[k] = v
    return out


def state_unit(name, declaration):
    """The unit of a coordinate or of its rate ``<coordinate>_dot`` (rad, rad/s for a rig
    whose declaration is unknown: reported already)."""
    units = declaration.units if declaration is not None else {}
    if name in units or not name.endswith("_dot"):
        return units.get(name, "rad")
    return velocity_unit(units.get(name[:-len("_dot")], "rad"))


def _state_names(rig):
    names = [q.name for q in rig.coordinates]
    return names + [f"{q}_dot" for q in names]


# -- sweep, output -------------------------------------------------------------------------------

def _flatten_axes(c, axes, key, prefix=()):
    """Axis specs by dotted name (a nested table is a namespace unless it is a range)."""
    out = {}
    for k, v in axes.items():
        name = prefix + (k,)
        if isinstance(v, dict) and not (set(v) & set(AXIS)):
            out.update(_flatten_axes(c, v, key, name))
        else:
            out[".".join(name)] = v
    return out


def _check_sweep(c, sweep, rig, params, effects, analyses, declaration):
    if sweep is None:
        return None
    if c.table(sweep, "sweep", ("axes", "analyses", "tile_points")) is None:
        return None
    axes_in = sweep.get("axes")
    if not isinstance(axes_in, dict) or not axes_in:
        c.error("sweep.axes", "missing; the swept parameters, e.g. [sweep.axes] A = {start = "
                              "0.0, stop = 0.2, num = 21}")
        return None
    targets = _sweep_targets(rig, params)
    axes, where, written = [], {}, {}        # written: an axis's name → its name in the file
    for name, v in _flatten_axes(c, axes_in, "sweep.axes").items():
        key = f"sweep.axes.{name}"
        target = targets.get(name)
        if target is None:
            c.unknown(key, name, [k for k in targets if "." not in k or k.startswith("initial.")],
                      what="sweep axis", extra=" (or the scene key that sets one)")
            continue
        swept = "omega" if target == "frequency_hz" else target
        if swept in where.values():
            c.error(key, f"sweeps {swept}, which another axis sweeps already")
            continue
        kind, minimum, strict, unit = axis_range(target, rig, declaration)
        ax = check_axis(c, v, key, name, minimum=minimum, strict=strict, unit=unit)
        if ax is not None and target == "frequency_hz":    # read in Hz, swept as omega (rad/s)
            ax = in_rad_s(ax)
        if ax is not None:
            axes.append(ax)
            where[ax.name] = swept
            written[ax.name] = name
    chosen = sweep.get("analyses")
    if chosen is None:
        chosen = [a for a in analyses if a in SWEEPABLE]
    elif not isinstance(chosen, list) or not all(isinstance(a, str) for a in chosen):
        c.error("sweep.analyses", f"must be a list of analysis names, got {chosen!r}")
        chosen = []
    else:
        for i, a in enumerate(chosen):
            if a not in SWEEPABLE:
                c.unknown(f"sweep.analyses[{i}]", a, SWEEPABLE, what="sweepable analysis")
            elif a not in analyses:
                c.error(f"sweep.analyses[{i}]", f"{a} is not asked for in [analyses]")
    if not chosen:
        c.error("sweep.analyses", "nothing to sweep: ask for one of "
                                  + ", ".join(SWEEPABLE) + " in [analyses]")
    tile = sweep.get("tile_points")
    if tile is not None:
        tile = c.number(tile, "sweep.tile_points", integer=True, minimum=1)
    for name, target in where.items():
        owner = OWNERS.get(target)
        if owner and target not in params:
            c.error(f"sweep.axes.{written[name]}",
                    f"sweeps {target}, but the {owner[0]} effect is off")
    return {"axes": tuple(axes), "targets": where, "analyses": tuple(chosen),
            "tile_points": tile}


def _sweep_targets(rig, params):
    """Every name a sweep axis may have → what it sets (a parameter, an initial value
    ``initial.<state>``, or frequency_hz: omega given in Hz, converted as it is read)."""
    names = set(params) | {"A", "omega", "gamma", "c_drag", "g", "B"}
    targets = {p: p for p in names}
    targets["frequency_hz"] = "frequency_hz"
    targets.update({f"parameters.{p}": p for p in params})
    targets.update(KEY_TARGETS)
    targets.update({f"effects.spring.{p[2:]}.k": p for p in params if p.startswith("k_")})
    if rig is not None:
        targets.update({f"initial.{s}": f"initial.{s}" for s in _state_names(rig)})
    return targets


def _check_output(c, output, source):
    out = {"directory": None, "formats": ("parquet",)}
    if c.table(output, "output", ("directory", "formats")) is None:
        return out
    base = Path(source).parent if source != "<text>" else Path.cwd()
    if "directory" in output:
        d = output["directory"]
        if not isinstance(d, str) or not d:
            c.error("output.directory", f"must be a path (text), got {kind_of(d)} {d!r}")
        else:
            out["directory"] = (base / d).resolve()
    if "formats" in output:
        f = output["formats"]
        if not isinstance(f, list) or not f:
            c.error("output.formats", f'must be a list, e.g. ["parquet", "csv"], got {f!r}')
        else:
            ok = [c.choice(x, f"output.formats[{i}]", ("parquet", "csv"))
                  for i, x in enumerate(f)]
            if None not in ok:
                out["formats"] = tuple(ok)
    return out
