"""A user's rig in a scene gets its own states, units and options, never the pendulum's
(issue 22.6).

The rig is a bob on a spring from a vertically shaken pivot (tests/data/spring_rigs.py,
tests/data/spring_pendulum.toml): coordinates r (m) and θ (rad), spring constant k, rest
length l0, pivot y_p = A cos ωt.  In the pivot's frame the bob feels g + ÿ_p, so at θ = 0

    r̈ = g − A ω² cos ωt − (k/m)(r − l0)

is linear: the drive moves the hanging state on the exact periodic orbit
r(t) = r0 + R cos ωt, r0 = l0 + m g / k, R = A ω² / (ω² − k/m), whose r-mode has the
frequency √(k/m) exactly; the θ-mode tends to the pendulum's √(g/r0) as A → 0.  Those are
the closed forms the scene's Floquet analysis is held to, and direct simulation (measure)
is the independent check of the θ-mode at the scene's amplitude.
"""
import inspect
import math
from pathlib import Path

import numpy as np
import pytest

from kapitza import KapitzaPendulum, Scene, SceneError
from kapitza.averaging import AveragedSystem
from kapitza.chaos import bifurcation_diagram, lyapunov
from kapitza.continuation import continuation
from kapitza.floquet import floquet_point, stability_map, window
from kapitza.scenes._schema import ANALYSES
from kapitza.simulation import measure_grid, periodic_orbit
from kapitza.verification import verify
from lagrange_core import System

DATA = Path(__file__).parent / "data"
SCENE = DATA / "spring_pendulum.toml"
A, OMEGA, K, M, G, L0 = 0.01, 30.0, 40.0, 1.0, 9.81, 1.0
R0 = L0 + M * G / K                                 # the static equilibrium's length (m)


@pytest.fixture(autouse=True)
def _rigs_importable(monkeypatch):
    monkeypatch.syspath_prepend(str(DATA))


def _scene(text=None, **replace):
    """The test scene, with lines replaced (old → new)."""
    text = SCENE.read_text() if text is None else text
    for old, new in replace.values():
        assert old in text, old
        text = text.replace(old, new)
    return Scene.from_text(text, source=str(SCENE))


def _problems(err):
    return {p.key: p.message for p in err.value.problems}


def _bare():
    """The test scene as a user writes it first: no units, no states declared."""
    lines = SCENE.read_text().splitlines(keepends=True)
    return "".join(x for x in lines if not x.startswith(("units =", "states =")))


# -- the physics: the declared hanging state and its Floquet analysis ----------------------

def test_floquet_about_the_declared_hanging_state_meets_the_closed_forms():
    """Today the scene picks r = 0 (the nearest multiple of π) and fails with a singular
    mass matrix; now it is about the declared hanging state, which the vertical drive moves:
    the periodic orbit r0 + R cos ωt, exactly."""
    scene = _scene()
    res = scene.run(write=False)
    orbit = res["floquet"]
    assert res.methods["floquet"] == "floquet: periodic orbit by Newton shooting"
    R = A * OMEGA**2 / (OMEGA**2 - K / M)
    assert orbit.q_mean[0] == pytest.approx(R0, abs=1e-9)             # r0 = l0 + m g / k
    assert abs(orbit.q_mean[1]) < 1e-12 and abs(orbit.amplitude[1]) < 1e-12
    assert orbit.amplitude[0] == pytest.approx(R, rel=1e-8)           # the forced response
    r_mode, theta_mode = max(orbit.omega_slow), min(orbit.omega_slow)
    assert r_mode == pytest.approx(math.sqrt(K / M), rel=1e-9)        # linear: exact
    assert orbit.stable

    # the θ-mode against direct simulation from the orbit's state: the measured frequency
    # carries the amplitude's own shift O(θ0²); two amplitudes extrapolate it away
    m1 = res["measure"]
    assert m1.stayed_up
    half = _scene(theta=("theta = 0.001", "theta = 0.0005")).run(write=False)["measure"]
    w1, w2 = m1.omega_slow[0], half.omega_slow[0]
    extrapolated = (4 * w2 - w1) / 3
    error = 2 * (m1.omega_slow_error[0] + half.omega_slow_error[0])
    assert abs(w1 - theta_mode) > 10 * error                 # the shift is resolved ...
    assert abs(extrapolated - theta_mode) < max(error, 1e-9 * theta_mode)   # ... and removed

    # and as A → 0 the pendulum's √(g/r0): the drive's correction is O(A²)
    small = _scene(amplitude=("amplitude = 0.01", "amplitude = 0.0001")).run(
        write=False)["floquet"]
    assert min(small.omega_slow) == pytest.approx(math.sqrt(G / R0), rel=1e-6)


def test_about_names_the_rigs_own_states():
    """"inverted" is the declared state (r = l0 − m g / k, θ = π), never r = π."""
    scene = _scene(analyses=("floquet = { about = \"hanging\" }",
                             "floquet = { about = \"inverted\" }"))
    orbit = scene.run(write=False)["floquet"]
    assert orbit.q_mean == pytest.approx([L0 - M * G / K, math.pi], abs=1e-9)
    assert not orbit.stable              # Kapitza: (A ω)² = 0.09 m²/s² ≪ 2 g r
    # explicit values per coordinate, as a table
    scene = _scene(analyses=("floquet = { about = \"hanging\" }",
                             "floquet = { about = { theta = 0.0, r = 1.24525 } }"))
    assert scene.run(write=False)["floquet"].q_mean[0] == pytest.approx(R0, abs=1e-9)


def test_the_module_declares_states_as_a_function_of_the_parameters():
    scene = _scene(name=('name = "spring_rigs:spring_pendulum"\nunits = { r = "m", theta = '
                         '"rad" }\nstates = { hanging = { r = 1.24525, theta = 0.0 }, inverted '
                         '= { r = 0.75475, theta = 3.141592653589793 } }',
                         'name = "spring_rigs:declared_spring_pendulum"'))
    assert scene.spec.units == {"r": "m", "theta": "rad"}
    assert scene.spec.states["hanging"] == pytest.approx((R0, 0.0))
    assert scene.spec.states["inverted"] == pytest.approx((L0 - M * G / K, math.pi))
    assert scene.spec.declaration.declared_by == "module"
    # the scene's declaration wins, name by name
    scene = _scene(scene.spec.text.replace(
        'name = "spring_rigs:declared_spring_pendulum"',
        'name = "spring_rigs:declared_spring_pendulum"\nstates = { hanging = [1.3, 0.0] }'))
    assert scene.spec.states["hanging"] == (1.3, 0.0)
    # the states are part of what the numbers depend on: a sweep's dataset is another
    moved = _scene(scene.spec.text.replace("[1.3, 0.0]", "[1.31, 0.0]"))
    assert moved.key() != scene.key() and moved.key("floquet") != scene.key("floquet")
    assert scene.spec.states["inverted"] == pytest.approx((L0 - M * G / K, math.pi))
    assert scene.spec.declaration.declared_by == "module and scene"


# -- mistakes, named --------------------------------------------------------------------------

def test_an_undeclared_state_is_refused_listing_the_declared_ones():
    with pytest.raises(SceneError) as err:
        _scene(analyses=('floquet = { about = "hanging" }', 'floquet = { about = "upright" }'))
    msg = _problems(err)["analyses.floquet.about"]
    assert "unknown value 'upright'; allowed: hanging, inverted, auto" in msg
    assert "the spring pendulum declares hanging, inverted" in msg
    # a rig that declares none has none: "inverted" is not r = π (as it is today)
    with pytest.raises(SceneError) as err:
        _scene(_bare(), analyses=('floquet = { about = "hanging" }\nmeasure = { about = '
                                  '"hanging", periods = 400 }', 'floquet = { about = '
                                                                '"inverted" }'))
    assert "allowed: none (the spring pendulum declares no states" in \
        _problems(err)["analyses.floquet.about"]


def test_auto_and_averaging_need_the_states_of_a_rig_that_is_not_all_angles():
    """Today `floquet = true` picks r = 0 (the nearest multiple of π) and averaging asks
    for an API argument; now both are refused as the file is read, saying what to add."""
    bare = _bare()
    with pytest.raises(SceneError) as err:
        _scene(bare, analyses=("floquet = { about = \"hanging\" }\nmeasure = { about = "
                               "\"hanging\", periods = 400 }", "floquet = true\naveraging = "
                                                              "true"))
    problems = _problems(err)
    assert "declares none: declare the rig's states" in problems["analyses.floquet.about"]
    assert "coordinates r (m), theta (rad)" in problems["analyses.floquet.about"]
    assert "give guesses = [[…, …]]" in problems["analyses.averaging.guesses"]
    # with guesses, averaging runs and finds the hanging state
    scene = _scene(bare, analyses=("floquet = { about = \"hanging\" }\nmeasure = { about = "
                                   "\"hanging\", periods = 400 }",
                                   "averaging = { guesses = [[1.2, 0.0], { r = 0.7, theta = "
                                   "3.0 }] }"))
    found = {tuple(np.round(e.about, 6)) for e in scene.run(write=False)["averaging"].equilibria}
    assert (round(R0, 6), 0.0) in found


def test_a_singular_mass_matrix_names_the_state_tried():
    scene = _scene(_bare(), analyses=('floquet = { about = "hanging" }\nmeasure = { about = '
                                      '"hanging", periods = 400 }',
                                      "floquet = { about = [0.0, 0.0] }"))
    with pytest.raises(ValueError) as err:
        scene.run(write=False)
    msg = str(err.value)
    assert "analysis 'floquet'" in msg
    assert "mass matrix is singular at the state r = 0 m, theta = 0 rad (about = [0.0, 0.0])" \
        in msg
    assert "declare the rig's states" in msg


def test_units_are_declared_or_inferred_and_used_in_messages():
    with pytest.raises(SceneError) as err:          # today: "(rad)", "(rad/s)"
        _scene(_bare(), initial=("r = 1.2557151163", "r = -inf\nr_dot = nan"))
    problems = _problems(err)
    assert "(m)" in problems["initial.r"] and "(m/s)" in problems["initial.r_dot"]
    text = SCENE.read_text().replace('units = { r = "m", theta = "rad" }\n', "")
    assert _scene(text).spec.units == {"r": "m", "theta": "rad"}   # linear in r, periodic in θ
    with pytest.raises(SceneError) as err:
        _scene(units=('units = { r = "m", theta = "rad" }', 'units = { r = "metre" }'))
    assert "unknown unit 'metre' of r; allowed: \"rad\"" in _problems(err)["system.units.r"]
    with pytest.raises(SceneError) as err:
        Scene.from_text('schema = 1\n[system]\nname = "spring_rigs:bead_on_parabola"\n'
                        "[parameters]\na = 1.0\n")
    assert "the unit of the coordinate 'x' is not declared and cannot be inferred" in \
        _problems(err)["system.units"]
    with pytest.raises(SceneError) as err:
        Scene.from_text('schema = 1\n[system]\nname = "pendulum"\nunits = { theta = "rad" }\n'
                        "[parameters]\nl = 1.0\n")
    assert "only for a user's rig" in _problems(err)["system.units"]


# -- bands per coordinate, in its unit ---------------------------------------------------------

def test_measurement_bands_are_per_coordinate_in_its_unit():
    from kapitza.scenes._rigs import default_band
    units = {"r": "m", "theta": "rad"}
    assert default_band(units, ["r", "theta"], [R0, 0.0]) == {"r": 0.5 * R0,
                                                              "theta": math.pi / 2}
    assert default_band(units, ["r", "theta"], [R0, 0.0], 0.3) == {"r": 0.5 * R0, "theta": 0.3}
    assert default_band(units, ["r", "theta"], [0.0, 0.0], {"theta": 0.3}) == {
        "r": math.inf, "theta": 0.3}
    assert default_band({"theta": "rad"}, ["theta"], [math.pi]) == math.pi / 2   # as before
    # a start 0.7 m from the hanging length is outside r's default band (r0/2 = 0.62 m),
    # though inside a quarter turn: refused; a band given for r admits it
    far = _scene(_bare(), initial=("r = 1.2557151163", "r = 1.95"),
                 analyses=('floquet = { about = "hanging" }\nmeasure = { about = "hanging", '
                           'periods = 400 }', "measure = { about = [1.24525, 0.0], periods = "
                                              "40 }"))
    with pytest.raises(ValueError, match="outside the band"):     # today: ±π/2 on r
        far.run(write=False)
    wide = _scene(far.spec.text.replace("periods = 40 }", "periods = 40, band = { r = 0.9 } }"))
    assert wide.spec.analyses["measure"]["band"] == {"r": 0.9}
    assert wide.run(write=False)["measure"].status == "finished"


# -- every analysis option of the API has a scene key -----------------------------------------

#: The functions each analysis calls (the general ones; the plain pendulum's closed forms
#: take a subset), and the scene keys named differently from their keywords.
_CALLS = {
    "averaging": (AveragedSystem.predict, KapitzaPendulum.averaged),
    "floquet": (floquet_point, periodic_orbit),
    "stability_map": (stability_map,),
    "window": (window, AveragedSystem.window),
    "measure": (measure_grid,),
    "simulate": (System.simulate,),
    "verify": (verify,),
    "continuation": (continuation,),
    "bifurcation_diagram": (bifurcation_diagram,),
    "lyapunov": (lyapunov,),
}
_RENAMED = {"taylor_order": "order", "fit_order": "line", "samples": "t_eval"}
#: System.simulate's documented **options that a scene's simulate sets.
_SIMULATE_OPTIONS = ("atol", "max_steps", "h", "error_check")


@pytest.mark.parametrize("analysis", sorted(_CALLS))
def test_every_keyword_of_the_api_has_a_scene_key(analysis):
    from kapitza.scenes import _schema
    API_ONLY = getattr(_schema, "API_ONLY", {})     # (absent before: every key then counts)
    keys = {_RENAMED.get(k, k) for k in ANALYSES[analysis]}
    missing = set()
    for fn in _CALLS[analysis]:
        for p in list(inspect.signature(fn).parameters.values())[1:]:
            optional = p.default is not inspect.Parameter.empty \
                or p.kind is inspect.Parameter.KEYWORD_ONLY
            if optional and p.kind not in (p.VAR_KEYWORD, p.VAR_POSITIONAL) \
                    and p.name not in keys | set(API_ONLY) | {"params"}:
                missing.add(f"{fn.__qualname__}({p.name}=)")
    assert not missing, f"{analysis}: no scene key for {sorted(missing)}"
    if analysis == "simulate":
        assert set(_SIMULATE_OPTIONS) <= keys


def test_new_keys_reach_the_api(monkeypatch):
    """A few of the new keys, followed to the function they set: the shooting's settings
    of the orbit, measure's integrator; a key for the other branch is refused; averaging's
    guesses on the plain pendulum run general averaging from them."""
    from kapitza.scenes import _analyses
    seen = {}

    def spy(name, fn):
        def wrapper(*args, **kwargs):
            seen[name] = kwargs
            return fn(*args, **kwargs)
        monkeypatch.setattr(_analyses, name, wrapper)
    spy("periodic_orbit", periodic_orbit)
    spy("measure", _analyses.measure)
    scene = _scene(analyses=('floquet = { about = "hanging" }\nmeasure = { about = "hanging", '
                             'periods = 400 }',
                             'floquet = { about = "hanging", symmetry = "none", max_iterations '
                             '= 7 }\nmeasure = { about = "hanging", periods = 40, method = '
                             '"dop853", t0 = 0.05, atol = 1e-12 }'))
    res = scene.run(write=False)
    assert seen["periodic_orbit"]["symmetry"] is None
    assert seen["periodic_orbit"]["max_iterations"] == 7
    assert {k: seen["measure"][k] for k in ("method", "t0", "atol")} == {
        "method": "dop853", "t0": 0.05, "atol": 1e-12}
    assert res["measure"].method == "dop853"
    with pytest.raises(ValueError, match="guard_tol are the monodromy's settings"):
        _scene(analyses=('floquet = { about = "hanging" }', 'floquet = { about = "hanging", '
                                                            "guard_tol = 1e-6 }")).run(
            write=False)
    pendulum = Scene.from_text('schema = 1\n[system]\nname = "pendulum"\n[parameters]\nl = '
                               '1.0\n[effects]\ngravity = true\n[effects.drive]\namplitude = '
                               '0.05\nomega = 300.0\n[analyses]\naveraging = { guesses = '
                               '[[3.0]] }\n')
    res = pendulum.run(write=False)
    assert res.methods["averaging"] == "averaging: order 1 (kapitza.average)"
    assert [round(float(e.about[0]), 9) for e in res["averaging"].equilibria] == [
        round(math.pi, 9)]
