"""Property: a scene file is valid, or refused by one SceneError naming the key — never
another exception.

The scenes are built from strategies over the schema (``kapitza/scenes/_schema.py``):
every rig of the catalogue, a chain, and a user's rig (the spring pendulum of
``tests/data/spring_rigs.py``), the effects with their keys, an initial state, any subset
of the analyses with settings drawn from their keys, a sweep and an output table.  Then
one mutation: a key deleted, a value replaced (wrong type, NaN, ±inf, huge, negative,
zero, unicode text, a date, an empty or nested array or table), or an unknown key added
(unicode names too).  The TOML text written from that is read:

* valid: a :class:`kapitza.scenes.SceneSpec` whose numbers are finite and whose axes are
  not empty, from which :class:`kapitza.Scene` builds its System and its key;
* invalid: a :class:`kapitza.SceneError` whose every problem names a key, one of them the
  mutated key (or a key inside or above it, or the message names it) where the mutation
  made a value wrong in itself;
* anything else (a KeyError, a MemoryError, a numpy warning turned error) fails.

Arbitrary text (not TOML, or TOML that is no scene) is held to the same.

Inputs tried (``--hypothesis-show-statistics``, 2026-11-26): profile "ci" 150 mutated
scenes (about 80 % valid before the mutation), 40 unmutated ones, 50 texts: 8 s (load
average 3 on 2 cores); "thorough" 3000 mutated scenes, 800 and 1000, all passing once the
five bugs in the examples below were fixed.
"""
import datetime
import functools
import json
import math
import re
import sys
from pathlib import Path

import numpy as np
import pytest
from hypothesis import assume, event, example, given, settings
from hypothesis import strategies as st

from kapitza import Scene, SceneError
from kapitza.scenes import SceneSpec
from kapitza.scenes._schema import ABOUT_EQUILIBRIUM, ANALYSES, NEED_DRIVE, SWEEPABLE

DATA = Path(__file__).parent / "data"
UNIT = settings().max_examples          # the profile's unit: 10 in "ci"


@pytest.fixture(scope="module", autouse=True)
def _user_rigs_importable():
    """The user's rig module (tests/data/spring_rigs.py) is importable, as for its tests."""
    sys.path.insert(0, str(DATA))
    yield
    sys.path.remove(str(DATA))


# -- TOML from data ---------------------------------------------------------------------------

def _string(text: str) -> str:
    """A TOML basic string: quote, backslash and control characters escaped, the rest as
    it is (JSON's escapes would write a character beyond U+FFFF as a surrogate pair,
    which TOML refuses)."""
    escaped = "".join(f"\\u{ord(ch):04x}" if ch in '"\\' or ord(ch) < 0x20 or ord(ch) == 0x7F
                      else ch for ch in text)
    return f'"{escaped}"'


def _key(k: str) -> str:
    return k if re.fullmatch(r"[A-Za-z0-9_-]+", k) else _string(k)


def _value(v) -> str:
    """One value as TOML (inline tables and arrays; nan and ±inf as TOML writes them)."""
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        if math.isnan(v):
            return "nan"
        if math.isinf(v):
            return "inf" if v > 0 else "-inf"
        return repr(v)
    if isinstance(v, str):
        return _string(v)
    if isinstance(v, datetime.datetime | datetime.date):
        return v.isoformat()
    if isinstance(v, list):
        return "[" + ", ".join(_value(x) for x in v) + "]"
    if isinstance(v, dict):
        return "{ " + ", ".join(f"{_key(k)} = {_value(x)}" for k, x in v.items()) + " }"
    raise TypeError(type(v))


def to_toml(data: dict) -> str:
    """A scene as a TOML file: scalars first, then a [table] per top-level table, its
    sub-tables inline."""
    lines = [f"{_key(k)} = {_value(v)}" for k, v in data.items() if not isinstance(v, dict)]
    for k, v in data.items():
        if isinstance(v, dict):
            lines.append(f"\n[{_key(k)}]")
            lines += [f"{_key(kk)} = {_value(vv)}" for kk, vv in v.items()]
    return "\n".join(lines) + "\n"


# -- scenes from the schema --------------------------------------------------------------------

_RIGS = {"pendulum": ["theta"], "double_pendulum": ["theta1", "theta2"],
         "triple_pendulum": ["theta1", "theta2", "theta3"], "spring": ["r", "theta"]}
positive = st.floats(0.05, 5.0, allow_nan=False)
angle = st.floats(-3.5, 3.5, allow_nan=False)


def _axis(values, *, log=False):
    """An axis: a short list of values, or a range of a few points."""
    short_list = st.lists(values, min_size=1, max_size=3)
    a_range = st.builds(lambda lo, hi, num, scale: {"start": lo, "stop": hi, "num": num,
                                                   **({"scale": scale} if scale else {})},
                        values, values, st.integers(1, 4),
                        st.sampled_from(["linear", "log", None] if log else ["linear", None]))
    return st.one_of(short_list, a_range)


def _about(coords):
    return st.one_of(st.sampled_from(["inverted", "hanging", "auto"]),
                     st.lists(angle, min_size=len(coords), max_size=len(coords)),
                     st.fixed_dictionaries({q: angle for q in coords}))


@functools.cache
def _settings(name, coords):
    """A table of the analysis ``name``: its required settings and a few optional ones,
    valid-looking (``true`` where it needs none).  ``coords`` is a tuple: the strategy is
    built once per analysis and rig (building it afresh at every draw, ~30 strategies
    each time, was a third of this file's time); it draws exactly what a new one would."""
    amplitude = st.floats(0.0, 0.3, allow_nan=False)
    omega = st.floats(1.0, 400.0, allow_nan=False)
    required = {"stability_map": {"A": _axis(amplitude), "omega": _axis(omega, log=True)},
                "window": {"omega": _axis(omega, log=True)},
                "verify": {"A": _axis(amplitude), "omega": _axis(omega)},
                "continuation": {"stop": amplitude},
                "bifurcation_diagram": {"values": _axis(amplitude)}}.get(name, {})
    optional = {
        "averaging": {"order": st.sampled_from([1, 2]),
                      "guesses": st.lists(st.lists(angle, min_size=len(coords),
                                                   max_size=len(coords)), min_size=1,
                                          max_size=2)},
        "floquet": {"about": _about(coords), "tol": st.sampled_from([1e-8, 1e-10]),
                    "taylor_order": st.integers(4, 40), "periods": st.integers(1, 3),
                    "symmetry": st.sampled_from(["auto", "none"])},
        "stability_map": {"about": _about(coords), "tol": st.sampled_from([1e-6, 1e-10])},
        "window": {"method": st.just("floquet"), "A_range": st.tuples(
            amplitude, amplitude).map(lambda ab: sorted(ab)).filter(lambda ab: ab[0] < ab[1])},
        "measure": {"about": _about(coords), "periods": st.integers(1, 50),
                    "band": st.one_of(positive, st.fixed_dictionaries({q: positive
                                                                       for q in coords})),
                    "observables": st.sampled_from(["all", "classification", ["amplitude"]])},
        "simulate": {"periods": st.integers(1, 50), "samples": st.integers(2, 50),
                     "method": st.sampled_from(["rkn12", "dop853"])},
        "verify": {"periods": st.integers(1, 50), "fit_order": st.booleans()},
        "continuation": {"max_points": st.integers(2, 20), "switch": st.booleans()},
        "bifurcation_diagram": {"periods": st.integers(1, 20), "transient": st.integers(0, 9),
                                "starts": st.lists(st.lists(angle, min_size=len(coords),
                                                            max_size=len(coords)),
                                                   min_size=1, max_size=2)},
        "lyapunov": {"periods": st.integers(8, 40), "exponents": st.sampled_from(
            ["all", "largest", 1])},
    }[name]
    table = st.fixed_dictionaries(required, optional=optional)
    return table if required else st.one_of(st.just(True), table)


@st.composite
def scenes(draw):
    """A scene as parsed TOML, built from the schema's tables and keys."""
    rig = draw(st.sampled_from(["pendulum", "double_pendulum", "triple_pendulum", "chain",
                                "spring"]))
    system: dict = {}
    if rig == "chain":
        links = draw(st.integers(1, 4))
        coords = [f"theta{i}" for i in range(1, links + 1)]
        system = {"name": "chain", "links": links}
    elif rig == "spring":
        coords = _RIGS[rig]
        system = {"name": "spring_rigs:spring_pendulum"}
        if draw(st.integers(0, 3)):         # mostly declared: without, most analyses refuse
            system["units"] = {"r": "m", "theta": "rad"}
            system["states"] = {"hanging": {"r": 1.245, "theta": 0.0},
                                "inverted": {"r": 0.755, "theta": math.pi}}
    else:
        coords = _RIGS[rig]
        system = {"name": rig}
    if rig == "spring":
        parameters = {"m": draw(positive)}
    elif rig == "pendulum":
        parameters = {"l": draw(positive), **({"m": draw(positive)} if draw(st.booleans())
                                              else {})}
    else:
        parameters = {f"{p}{i}": draw(positive) for i in range(1, len(coords) + 1)
                      for p in ("l", "m")}
    effects: dict = {}
    if draw(st.booleans()) or rig == "spring":
        effects["gravity"] = True
        if draw(st.booleans()):
            parameters["g"] = draw(st.floats(0.0, 20.0, allow_nan=False))
    names = draw(st.lists(st.sampled_from(sorted(ANALYSES)), unique=True, min_size=1,
                          max_size=3))
    if set(names) & set(NEED_DRIVE) or draw(st.booleans()):
        direction = draw(st.sampled_from(
            ["vertical"] if set(names) & set(ABOUT_EQUILIBRIUM) else
            ["vertical", "vertical", "horizontal", "elliptic", [1.0, 2.0]]))
        drive = {"direction": direction, "amplitude": draw(st.floats(0.0, 0.3))}
        drive[draw(st.sampled_from(["omega", "frequency_hz"]))] = draw(st.floats(1.0, 400.0))
        if direction == "elliptic":
            drive["amplitude_y"] = draw(st.floats(-0.3, 0.3))
        elif draw(st.booleans()):
            drive["harmonics"] = [[1, 1.0, 0.0], [2, draw(st.floats(-1, 1)), 0.5]]
        effects["drive"] = drive
    if draw(st.booleans()):
        effects["damping"] = {"gamma": draw(st.floats(0.0, 2.0))}
    if draw(st.booleans()):
        effects["air_drag"] = {"c": draw(st.floats(0.0, 1.0))}
    springs = draw(st.lists(st.sampled_from(coords), unique=True, max_size=2))
    if rig == "spring" and "r" not in springs:
        springs.append("r")
    if springs:
        effects["spring"] = {q: {"k": draw(st.floats(1.0, 50.0)), "rest": 1.0 if q == "r"
                                 else draw(angle)} for q in springs}
    data = {"schema": 1}
    if draw(st.booleans()):
        data["title"] = draw(st.text(max_size=20))
    data.update(system=system, parameters=parameters, effects=effects)
    if draw(st.booleans()):
        data["initial"] = draw(st.fixed_dictionaries(
            {}, optional={**{q: angle for q in coords},
                          **{f"{q}_dot": angle for q in coords}}))
        if rig == "spring":
            data["initial"]["r"] = 1.25
    data["analyses"] = {name: draw(_settings(name, tuple(coords))) for name in names}
    swept = [n for n in names if n in SWEEPABLE]
    if swept and draw(st.booleans()):
        data["sweep"] = {"axes": {"A": {"start": 0.0, "stop": 0.2, "num": draw(
            st.integers(1, 5))}}, "analyses": swept[:1]}
    if draw(st.booleans()):
        data["output"] = {"directory": "out", "formats": draw(st.sampled_from(
            [["parquet"], ["parquet", "csv"]]))}
    return data


# -- mutations --------------------------------------------------------------------------------

def _paths(node, prefix=()):
    """Every (path, value) below ``node``: path a tuple of dict keys and list indices."""
    items = node.items() if isinstance(node, dict) else enumerate(node) \
        if isinstance(node, list) else ()
    for k, v in items:
        yield prefix + (k,), v
        yield from _paths(v, prefix + (k,))


def dotted(path) -> str:
    """A path as the scene's messages name it: ``analyses.window.omega[1]``."""
    out = ""
    for p in path:
        out += f"[{p}]" if isinstance(p, int) else (f".{p}" if out else str(p))
    return out


huge = st.sampled_from([1e308, -1e308, 1.7976931348623157e308, 10**12, 10**18, -10**18,
                        10**30, 2**63 - 1])
junk_scalars = st.one_of(
    st.floats(allow_nan=True, allow_infinity=True), huge, st.integers(-10, 0),
    st.integers(-2**63, 2**63 - 1), st.booleans(), st.text(max_size=8),
    st.sampled_from(["", "ω", "😀", "inverted\u200b", "π", "1e3", "nan", "vertical "]),
    st.datetimes(min_value=datetime.datetime(1, 1, 1), max_value=datetime.datetime(9999, 1, 1)),
)
junk = st.one_of(junk_scalars, st.lists(junk_scalars, max_size=3),
                 st.dictionaries(st.text(max_size=5), junk_scalars, max_size=2),
                 st.just([]), st.just({}), st.just([[]]))
#: Keys a user might add by mistake: misspellings, other units, unicode.
new_keys = st.one_of(st.text(min_size=1, max_size=8),
                     st.sampled_from(["amplitud", "omega_hz", "Omega", "ω", "θ", "l ", "periods",
                                      "about", "A", "hz", "tol"]))


@st.composite
def mutations(draw, data):
    """(the mutated data, what was done, the dotted key it was done at)."""
    data = json.loads(json.dumps(data))             # a deep copy (the data is JSON-like)
    paths = list(_paths(data))
    op = draw(st.sampled_from(["delete", "replace", "replace", "add"]))
    if op == "add":
        tables = [((), data)] + [(p, v) for p, v in paths if isinstance(v, dict)]
        path, table = draw(st.sampled_from(tables))
        key = draw(new_keys)
        assume(key not in table)
        table[key] = draw(junk)
        return data, op, dotted(path + (key,))
    path, _ = draw(st.sampled_from(paths))
    parent = data
    for p in path[:-1]:
        parent = parent[p]
    if op == "delete":
        del parent[path[-1]]
    else:
        parent[path[-1]] = draw(junk)
    return data, op, dotted(path)


# -- the property ----------------------------------------------------------------------------

def _related(problem, key: str) -> bool:
    """Whether a problem names ``key``: the same key, one inside or above it, or the key
    in its message."""
    plain = re.sub(r"\[\d+\]", "", key)
    for k in (problem.key, re.sub(r"\[\d+\]", "", problem.key)):
        for x in (key, plain):
            if k == x or k.startswith((x + ".", x + "[")) or x.startswith((k + ".", k + "[")):
                return True
    last = re.split(r"[.\[]", plain)[-1]
    return (key in problem.message or plain in problem.message
            or len(last) >= 3 and last in problem.message)


def _finite(value) -> bool:
    if isinstance(value, float):
        return math.isfinite(value)
    if isinstance(value, dict):
        return all(_finite(v) for v in value.values())
    if isinstance(value, list | tuple):
        return all(_finite(v) for v in value)
    if hasattr(value, "values") and isinstance(value.values, tuple):     # an Axis
        return len(value.values) > 0 and _finite(value.values)
    return True


def _read(text):
    """The scene from ``text``: its spec, or the SceneError (any other exception fails)."""
    try:
        return Scene.from_text(text), None
    except SceneError as e:
        assert e.problems, f"a SceneError with no problem: {e}"
        for p in e.problems:
            assert p.key and isinstance(p.key, str) and p.message, p
        return None, e


def _check_valid(scene, text):
    spec = scene.spec
    assert isinstance(spec, SceneSpec)
    assert _finite(spec.params) and _finite(spec.initial), text
    for name, settings_ in spec.analyses.items():
        assert _finite(settings_), f"analyses.{name} holds a non-finite value: {settings_}"
    if spec.sweep:
        assert _finite(list(spec.sweep["axes"])), spec.sweep
    system = scene.system                      # the System the scene builds
    assert set(spec.params) == set(system.parameters), (spec.params, system.parameters)
    assert len(scene.key()) > 10


#: A range of 10¹² points: before the fix it raised numpy's MemoryError from the reading.
_HUGE_AXIS = ({"schema": 1, "system": {"name": "pendulum"}, "parameters": {"l": 1.0},
               "effects": {"gravity": True, "drive": {"amplitude": 0.1, "omega": 50.0}},
               "analyses": {"stability_map": {"A": {"start": 0.0, "stop": 0.3,
                                                    "num": 10**12},
                                              "omega": [50.0]}}},
              "replace", "analyses.stability_map.A.num")
#: A range whose ends are finite but whose width overflows: it held NaN and inf.
_OVERFLOWING_AXIS = ({"schema": 1, "system": {"name": "pendulum"}, "parameters": {"l": 1.0},
                      "effects": {"gravity": True, "drive": {"amplitude": 0.1, "omega": 50.0}},
                      "analyses": {"measure": True},
                      "sweep": {"axes": {"initial.theta": {"start": -1e308, "stop": 1e308,
                                                           "num": 3}}}},
                     "replace", "sweep.axes.initial.theta")


#: A drive whose harmonics all have a_k = 0: the scene was valid, but its System had lost
#: A and omega (found by this property; PivotDrive refuses it now).
_MOTIONLESS_DRIVE = ({"schema": 1, "system": {"name": "pendulum"}, "parameters": {"l": 1.0},
                      "effects": {"drive": {"amplitude": 0.0, "omega": 1.0,
                                            "harmonics": [[2, 0.0, 0.5]]}},
                      "analyses": {"averaging": True}},
                     "delete", "effects.drive.harmonics[0]")


#: A unit given as an array: the check of the units raised TypeError (unhashable list).
_UNIT_AS_ARRAY = ({"schema": 1, "system": {"name": "spring_rigs:spring_pendulum",
                                           "units": {"r": [], "theta": "rad"}},
                   "parameters": {"m": 1.0},
                   "effects": {"gravity": True, "drive": {"amplitude": 0.0, "omega": 1.0},
                               "spring": {"r": {"k": 1.0, "rest": 1.0}}},
                   "analyses": {"floquet": {"about": {"r": 1.245, "theta": 0.0}}}},
                  "replace", "system.units.r")


#: 1e308 Hz is finite, 2π × 1e308 rad/s is not: the drive's omega was inf, accepted.
_HZ_OVERFLOW = ({"schema": 1, "system": {"name": "pendulum"}, "parameters": {"l": 1.0},
                 "effects": {"drive": {"amplitude": 0.0, "frequency_hz": 1e308}},
                 "analyses": {"stability_map": {"A": [0.0], "frequency_hz": [1e308]}}},
                "replace", "effects.drive.frequency_hz")


#: A chain of 10¹² links: building its coordinates' names filled the memory (a suite worker
#: was OOM-killed; found by this property).  At most 64 links are read.
_HUGE_CHAIN = ({"schema": 1, "system": {"name": "chain", "links": 10**12},
                "parameters": {"l1": 1.0, "m1": 1.0}, "effects": {"gravity": True},
                "analyses": {"averaging": True}},
               "replace", "system.links")


@settings(max_examples=15 * UNIT)
@given(base=scenes(), data=st.data())
@example(base=_HUGE_CHAIN[0], data=_HUGE_CHAIN[1:])
@example(base=_HUGE_AXIS[0], data=_HUGE_AXIS[1:])
@example(base=_OVERFLOWING_AXIS[0], data=_OVERFLOWING_AXIS[1:])
@example(base=_MOTIONLESS_DRIVE[0], data=_MOTIONLESS_DRIVE[1:])
@example(base=_UNIT_AS_ARRAY[0], data=_UNIT_AS_ARRAY[1:])
@example(base=_HZ_OVERFLOW[0], data=_HZ_OVERFLOW[1:])
def test_a_mutated_scene_is_valid_or_refused_naming_the_key(base, data):
    """One key of a scene deleted, replaced or added: valid, or a SceneError; where the
    scene was valid before, a problem names the key."""
    if isinstance(data, tuple):             # an explicit example: already mutated
        mutated, (op, key) = base, data
        base_valid = True
    else:
        mutated, op, key = data.draw(mutations(base), label="mutation")
        base_valid = _read(to_toml(base))[0] is not None
    event(f"the scene before the mutation is {'valid' if base_valid else 'invalid'}")
    text = to_toml(mutated)
    scene, error = _read(text)
    event(f"{op}: {'valid' if scene is not None else 'SceneError'}")
    if scene is not None:
        _check_valid(scene, text)
        return
    if base_valid:
        assert any(_related(p, key) for p in error.problems), (
            f"{op} at {key}: no problem names it:\n{error}\n--- the scene:\n{text}")


@settings(max_examples=4 * UNIT)
@given(data=scenes())
def test_a_scene_from_the_schema_is_valid_or_refused(data):
    text = to_toml(data)
    scene, _ = _read(text)
    if scene is not None:
        _check_valid(scene, text)


@settings(max_examples=5 * UNIT)
@given(text=st.one_of(st.text(max_size=200), st.sampled_from([
    "", "schema = 1", "schema = 1\n[system]\nname = 'pendulum'\n[parameters]\nl = nan\n",
    "[system\nname=", "schema = 1\n[[analyses]]\n", "schema = 1\nsystem = 3\n",
    "\ufeffschema = 1\n", "schema = 1.0\n", "schema = 99999999999999999999\n"])))
def test_any_text_is_a_scene_or_a_scene_error(text):
    scene, _ = _read(text)
    if scene is not None:
        _check_valid(scene, text)


def test_the_toml_writer_round_trips():
    """The writer the properties use writes what tomllib reads back (NaN compared as NaN)."""
    import tomllib
    data = {"schema": 1, "title": "ω \"quoted\" \U00010000\x7f", "x": {"a": [1.0, -math.inf, 1e308],
                                                         "b c": {"ü": True}}}
    back = tomllib.loads(to_toml(data))
    assert back == data
    assert math.isnan(tomllib.loads(to_toml({"v": math.nan}))["v"])
    assert np.isfinite(back["x"]["a"][2])
