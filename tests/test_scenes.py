"""Scene files (kapitza.scenes, kapitza.Scene): the issue's file as written, the
equations with and without each effect, every kind of bad file reported at once, the
analyses run (only those asked for) and the tables written."""
import math
import textwrap

import numpy as np
import pandas as pd
import pytest
import sympy as sp

import kapitza
from kapitza import Scene, SceneError
from lagrange_core import effects as fx
from lagrange_core.forms import rkn_form

#: the file of issue 13, exactly as written there
ISSUE_SCENE = '''\
schema = 1
[system]
name = "pendulum"            # a catalogue problem, or "package.module:function"
[parameters]
l = 1.0
g = 9.81
[effects]
gravity = true
[effects.drive]
direction = "vertical"       # or "horizontal", a vector [dx, dy], or an elliptic path
amplitude = 0.05             # m
frequency_hz = 60.0          # or omega in rad/s
[effects.damping]            # leave the table out and no damping term exists
gamma = 0.5                  # 1/s
[initial]
theta = 3.0416
[analyses]
averaging = true
'''


def scene(body: str, source="<text>") -> Scene:
    return Scene.from_text("schema = 1\n" + textwrap.dedent(body), source)


def _symbols_in_equations(system):
    eq = system.equations
    exprs = list(eq.forcing_se) + [e for row in eq.mass_matrix_se for e in row]
    return {str(s) for e in exprs for s in sp.sympify(e).free_symbols}


def test_the_issue_file_loads_as_written(tmp_path):
    path = tmp_path / "kapitza.toml"
    path.write_text(ISSUE_SCENE)
    s = Scene.from_toml(path)
    assert s.path == path
    assert s.system.name == "pendulum + gravity + vertical drive + damping"
    assert s.params == dict(l=1.0, g=9.81, m=1.0, A=0.05, omega=2 * math.pi * 60.0, gamma=0.5)
    assert s.q0.tolist() == [3.0416] and s.qdot0.tolist() == [0.0]
    assert list(s.analyses) == ["averaging"]
    assert s.capabilities["integrator"] == "dop853"        # damping: a velocity force
    # only averaging runs (the plain pendulum: closed forms); upright stable, Ω ≈ 13 rad/s
    res = s.run()
    assert list(res.results) == ["averaging"] and not res.sweeps and not res.written
    avg = res["averaging"]
    assert isinstance(avg, kapitza.PendulumAveraging)
    assert avg.inverted.stable and avg.damping == 0.5
    assert avg.inverted.omega_slow == pytest.approx(math.sqrt(
        (0.05 * 2 * math.pi * 60) ** 2 / 2 - 9.81), rel=1e-12)
    assert set(res.tables()) == {"averaging"}


def test_the_issue_file_builds_the_catalogue_pendulum():
    """The scene's System is the catalogue's damped, vertically driven pendulum."""
    from lagrange_core import problems
    s = Scene.from_text(ISSUE_SCENE)
    ref = problems.driven_pendulum("vertical", damping=True)
    assert set(s.system.parameters) == set(ref.parameters)
    assert sp.simplify(s.system.equations.forcing[0] / s.system.equations.mass_matrix[0, 0]
                       - ref.equations.forcing[0] / ref.equations.mass_matrix[0, 0]) == 0


# -- each effect in or out --------------------------------------------------------------------

_BASE = '''
[system]
name = "pendulum"
[parameters]
l = 0.7
m = 1.3
'''
_EFFECT_TABLES = {
    "gravity": ("[effects]\ngravity = true\n", {"g"}),
    "drive": ("[effects.drive]\namplitude = 0.05\nomega = 100.0\n", {"A", "omega"}),
    "damping": ("[effects.damping]\ngamma = 0.4\n", {"gamma"}),
    "air_drag": ("[effects.air_drag]\nc = 0.2\n", {"c_drag"}),
    "spring": ("[effects.spring.theta]\nk = 2.5\nrest = 0.2\n", {"k_theta"}),
}


@pytest.mark.parametrize("named", [(), ("gravity",), ("drive",), ("damping",), ("air_drag",),
                                   ("spring",), ("gravity", "drive", "damping"),
                                   ("gravity", "drive", "air_drag", "spring")])
def test_equations_hold_exactly_the_named_effects(named):
    """Through a scene file: the derived M and F contain the parameters of exactly the
    effects whose tables are there, and velocity forces decide the RKN form."""
    s = scene(_BASE + "".join(_EFFECT_TABLES[k][0] for k in named))
    syms = _symbols_in_equations(s.system)
    for k, (_, marks) in _EFFECT_TABLES.items():
        assert (marks <= syms) == (k in named), (k, named, syms)
        assert (marks <= set(s.system.parameters)) == (k in named)
    velocity = "damping" in named or "air_drag" in named
    assert rkn_form(s.system.equations)[0] == (not velocity)
    assert s.capabilities["integrator"] == ("dop853" if velocity else "rkn12")


def test_each_effect_table_gives_its_term():
    """θ̈ of the built system, term by term against the closed forms of test_effects."""
    P = dict(m=1.3, l=0.7, g=9.81, A=0.05, omega=100.0, gamma=0.4, c_drag=0.2, k_theta=2.5)
    s = scene(_BASE + "".join(v[0] for v in _EFFECT_TABLES.values()))
    assert s.params == P
    eq = s.system.equations
    expr = eq.forcing[0] / eq.mass_matrix[0, 0]
    expr = expr.subs({x: P[x.name] for x in expr.free_symbols if x.name in P})
    qdd = sp.lambdify([sp.Symbol(n) for n in ("theta", "theta_dot", "t")], expr)
    m, l, g, A, w = P["m"], P["l"], P["g"], P["A"], P["omega"]
    for th0, thd0, t0 in [(0.3, 1.1, 0.01), (2.9, -0.5, 0.3)]:
        want = (-g / l * math.sin(th0) + A * w**2 / l * math.cos(w * t0) * math.sin(th0)
                - P["gamma"] * thd0 - P["k_theta"] * (th0 - 0.2) / (m * l**2))
        # the drag is that of still air: the bob's velocity includes the pivot's
        got = qdd(th0, thd0, t0)
        drag = got - want
        vx = l * math.cos(th0) * thd0
        vy = l * math.sin(th0) * thd0 - A * w * math.sin(w * t0)
        speed = math.hypot(vx, vy)
        torque = -P["c_drag"] * speed * (l * math.cos(th0) * vx + l * math.sin(th0) * vy)
        assert drag == pytest.approx(torque / (m * l**2), rel=1e-10)


def test_elliptic_drive_and_harmonics_and_vectors():
    s = scene('''
        [system]
        name = "pendulum"
        [parameters]
        l = 1.0
        [effects.drive]
        direction = "elliptic"
        amplitude = 0.02
        amplitude_y = -0.01
        omega = 50.0
    ''')
    assert s.params["B"] == -0.01 and s.capabilities["floquet"] == "periodic_orbit"
    s = scene('''
        [system]
        name = "double_pendulum"
        [parameters]
        l1 = 1.0
        l2 = 0.5
        [effects]
        gravity = true
        [effects.drive]
        direction = [0.5, 0.8660254037844386]
        amplitude = 0.03
        frequency_hz = 10.0
        harmonics = [[1, 1.0, 0.0], [2, 0.5, 0.3]]
    ''')
    drive = s.drive
    assert drive is next(e for e in s.effects if isinstance(e, fx.PivotDrive))
    assert drive.harmonics == ((1, 1.0, 0.0), (2, 0.5, 0.3))
    assert drive.path == (0.5, 0.8660254037844386) and not drive.keeps_vertical_equilibria
    assert s.params["m1"] == s.params["m2"] == 1.0 and s.params["g"] == 9.81
    assert s.capabilities["floquet"] == "periodic_orbit"


def test_chain_and_user_module_rigs(tmp_path, monkeypatch):
    s = scene('''
        [system]
        name = "chain"
        links = 3
        [parameters]
        l1 = 1.0
        l2 = 1.0
        l3 = 1.0
        [initial]
        theta3 = 0.1
        theta3_dot = -0.2
    ''')
    assert s.system.coordinates == ("theta1", "theta2", "theta3")
    assert s.drive is None                      # no [effects.drive]
    assert s.q0.tolist() == [0, 0, 0.1] and s.qdot0.tolist() == [0, 0, -0.2]
    (tmp_path / "my_rigs.py").write_text(textwrap.dedent('''
        import sympy as sp
        from lagrange_core import effects, coordinates

        def swing(mass_name="M"):
            (phi,), _ = coordinates("phi")
            M, r = sp.symbols(f"{mass_name} r", positive=True)
            return effects.Rig("swing", (phi,),
                               (("seat", M, lambda px, py: (px + r * sp.sin(phi),
                                                            py - r * sp.cos(phi))),))

        def not_a_rig():
            return 42
    '''))
    monkeypatch.syspath_prepend(str(tmp_path))
    s = scene('''
        [system]
        name = "my_rigs:swing"
        options = { mass_name = "mu" }
        [parameters]
        r = 2.0
        [effects]
        gravity = true
        [effects.spring.phi]
        k = 3.0
    ''')
    assert s.system.parameters == ("g", "k_phi", "mu", "r")
    assert s.params == dict(r=2.0, mu=1.0, g=9.81, k_phi=3.0)      # the mass defaults to 1 kg
    assert kapitza.scenes.code_fingerprint("my_rigs") != kapitza.scenes.code_fingerprint()
    with pytest.raises(SceneError, match="must return a lagrange_core.effects.Rig"):
        scene('[system]\nname = "my_rigs:not_a_rig"\n[parameters]\n')
    with pytest.raises(SceneError, match="Did you mean 'swing'"):
        scene('[system]\nname = "my_rigs:swign"\n[parameters]\n')
    with pytest.raises(SceneError, match="cannot import module 'no_such_rigs'"):
        scene('[system]\nname = "no_such_rigs:swing"\n[parameters]\n')


def test_example_scenes_ship_and_load():
    found = kapitza.example_scenes()
    assert {"kapitza_pendulum", "kapitza_pendulum_map", "horizontal_drive", "elliptic_damped",
            "double_pendulum"} <= set(found)
    for name in found:
        s = Scene.example(name)
        assert s.system.n_dof >= 1 and s.analyses
    assert Scene.example("kapitza_pendulum").spec.title.startswith("Kapitza")
    with pytest.raises(ValueError, match="no example scene 'nope'"):
        Scene.example("nope")


# -- bad files ------------------------------------------------------------------------------

_GOOD = '''\
schema = 1
[system]
name = "pendulum"
[parameters]
l = 1.0
[effects]
gravity = true
[effects.drive]
amplitude = 0.05
omega = 300.0
[analyses]
floquet = true
'''

# (what is changed, a replacement of one line or text appended, [(key, line, message part)])
BAD = {
    "no schema": (("schema = 1\n", ""), [("schema", None, "missing; a scene file starts with "
                                                          "`schema = 1`")]),
    "future schema": (("schema = 1", "schema = 2"),
                      [("schema", 1, "unsupported schema version 2")]),
    "schema text": (("schema = 1", 'schema = "1"'), [("schema", 1, "must be the whole number 1")]),
    "unknown table": ("[analysis]\nfloquet = true\n",
                      [("analysis", 13, "unknown table 'analysis'"),
                       ("analysis", 13, "Did you mean 'analyses'?")]),
    "unknown system": (('name = "pendulum"', 'name = "pendlum"'),
                       [("system.name", 3, "unknown rig 'pendlum'; allowed: pendulum, "),
                        ("system.name", 3, "Did you mean 'pendulum'?")]),
    "system name a number": (('name = "pendulum"', "name = 3"),
                             [("system.name", 3, "must be text, got an integer 3")]),
    "no system": (('[system]\nname = "pendulum"\n', ""), [("system", None, "missing table")]),
    "chain without links": (('name = "pendulum"', 'name = "chain"'),
                            [("system.links", None, "a chain needs its number of links")]),
    "misspelt parameter": (("l = 1.0", "lenght = 1.0"),
                           [("parameters.lenght", 5, "unknown parameter of the pendulum 'lenght'"),
                            ("parameters.l", None, "missing; the pendulum needs l (m), > 0")]),
    "parameter l = 0": (("l = 1.0", "l = 0.0"), [("parameters.l", 5, "must be > 0 (m), got 0.0")]),
    "parameter l < 0": (("l = 1.0", "l = -1.0"), [("parameters.l", 5, "must be > 0 (m)")]),
    "parameter as text": (("l = 1.0", 'l = "1 m"'),
                          [("parameters.l", 5, "must be a finite number (m), got text '1 m'")]),
    "a drive parameter in [parameters]": (("l = 1.0", "l = 1.0\nA = 0.1"),
                                          [("parameters.A", 6, "A is set by "
                                                               "effects.drive.amplitude")]),
    "negative amplitude": (("amplitude = 0.05", "amplitude = -0.05"),
                           [("effects.drive.amplitude", 9, "must be ≥ 0 (m), got -0.05")]),
    "zero omega": (("omega = 300.0", "omega = 0"),
                   [("effects.drive.omega", 10, "must be > 0 (rad/s), got 0")]),
    "negative frequency": (("omega = 300.0", "frequency_hz = -60"),
                           [("effects.drive.frequency_hz", 10, "must be > 0 (Hz)")]),
    "both frequencies": (("omega = 300.0", "omega = 300.0\nfrequency_hz = 50.0"),
                         [("effects.drive.omega", 10, "give one of frequency_hz and omega, "
                                                      "not both")]),
    "no frequency": (("omega = 300.0", ""), [("effects.drive.frequency_hz", 8, "missing; give "
                                                                               "the drive's "
                                                                               "frequency")]),
    "no amplitude": (("amplitude = 0.05", ""),
                     [("effects.drive.amplitude", 8, "missing; the pivot's amplitude A")]),
    "misspelt drive key": (("amplitude = 0.05", "amplitude = 0.05\namplitdue_y = 0.1"),
                           [("effects.drive.amplitdue_y", 10, "Did you mean 'amplitude_y'?")]),
    "bad direction": (("[effects.drive]", '[effects.drive]\ndirection = "diagonal"'),
                      [("effects.drive.direction", 9, "unknown value 'diagonal'; allowed: "
                                                      "vertical, horizontal, elliptic")]),
    "zero direction": (("[effects.drive]", "[effects.drive]\ndirection = [0, 0]"),
                       [("effects.drive.direction", 9, "must not be zero")]),
    "negative damping": ("[effects.damping]\ngamma = -0.5\n",
                         [("effects.damping.gamma", 14, "must be ≥ 0 (1/s), got -0.5")]),
    "damping as a boolean": ("[effects.damping]\ngamma = true\n",
                             [("effects.damping.gamma", 14, "must be a finite number (1/s), "
                                                            "got a boolean True")]),
    "misspelt effect": ("[effects.dampnig]\ngamma = 0.5\n",
                        [("effects.dampnig", 13, "unknown effect 'dampnig'; allowed: gravity, "
                                                 "drive, damping, air_drag, spring. Did you "
                                                 "mean 'damping'?")]),
    "gravity as a table": (("gravity = true", "gravity = { g = 9.81 }"),
                           [("effects.gravity", 7, "its parameter g goes in [parameters]")]),
    "spring on no coordinate": ("[effects.spring.phi]\nk = 1.0\n",
                                [("effects.spring.phi", 13, "unknown coordinate 'phi'; allowed: "
                                                            "theta")]),
    "unknown initial coordinate": ("[initial]\ntheta = 3.0\ntheta_dto = 0.1\n",
                                   [("initial.theta_dto", 15, "Did you mean 'theta_dot'?")]),
    "unknown analysis": (("floquet = true", "floquet = true\nfloqet = true"),
                         [("analyses.floqet", 13, "Did you mean 'floquet'?")]),
    "analysis setting": (("floquet = true", 'floquet = { about = "upright" }'),
                         [("analyses.floquet.about", 12, "unknown value 'upright'; allowed: "
                                                         "inverted, hanging, auto")]),
    "analysis wrong type": (("floquet = true", "floquet = 1"),
                            [("analyses.floquet", 12, "must be a table, got an integer 1")]),
    "measure periods": (("floquet = true", "measure = { periods = 0.5 }"),
                        [("analyses.measure.periods", 12, "must be a whole number")]),
    "verify without axes": (("floquet = true", "verify = { periods = 100 }"),
                            [("analyses.verify.A", 12, "missing; the amplitudes")]),
    "map without axes": (("floquet = true", "stability_map = { about = \"inverted\" }"),
                         [("analyses.stability_map.omega", 12, "missing; give the drive "
                                                               "frequencies"),
                          ("analyses.stability_map.A", 12, "missing; the amplitudes")]),
    "bad range": (("floquet = true", "window = { omega = { start = 0.0, stop = 10.0, num = 5, "
                                     "scale = \"log\" } }"),
                  [("analyses.window.omega.start", 12, "must be > 0 (rad/s), got 0.0")]),
    "range key misspelt": (("floquet = true", "window = { omega = { start = 1.0, stpo = 10.0, "
                                              "num = 5 } }"),
                           [("analyses.window.omega.stpo", 12, "Did you mean 'stop'?"),
                            ("analyses.window.omega.stop", 12, "missing; a range is")]),
    "floquet without a drive": (("[effects.drive]\namplitude = 0.05\nomega = 300.0\n", ""),
                                [("analyses.floquet", 9, "floquet needs a drive")]),
    "map of a horizontal drive": ([("[effects.drive]", '[effects.drive]\ndirection = '
                                                       '"horizontal"'),
                                   ("floquet = true", "stability_map = { A = [0.1], omega = "
                                                      "[100.0] }")],
                                  [("analyses.stability_map", 13, "leaves none")]),
    "sweep axis misspelt": ("[sweep.axes]\namplitde = [0.1, 0.2]\n",
                            [("sweep.axes.amplitde", 14, "unknown sweep axis 'amplitde'")]),
    "sweep of an effect that is off": ("[sweep.axes]\ngamma = [0.1, 0.2]\n",
                                       [("sweep.axes.gamma", 14, "the damping effect is off")]),
    "sweep out of range": ("[sweep.axes]\nA = [0.1, -0.2]\n",
                           [("sweep.axes.A[1]", 14, "must be ≥ 0 (m), got -0.2")]),
    "sweep of a non-sweepable analysis": ("[sweep]\nanalyses = [\"window\"]\n[sweep.axes]\n"
                                          "A = [0.1]\n",
                                          [("sweep.analyses[0]", 14, "unknown sweepable "
                                                                     "analysis 'window'")]),
    "two axes for one parameter": ("[sweep.axes]\nomega = [1.0]\n\"effects.drive.omega\" = "
                                   "[2.0]\n",
                                   [("sweep.axes.effects.drive.omega", 15, "another axis "
                                                                           "sweeps already")]),
    "omega swept twice, once in Hz": ("[sweep.axes]\nomega = [1.0]\nfrequency_hz = [2.0]\n",
                                      [("sweep.axes.frequency_hz", 15, "sweeps omega, which "
                                                                       "another axis sweeps "
                                                                       "already")]),
    "sweep of a frequency ≤ 0 Hz": ("[sweep.axes]\nfrequency_hz = [-2.0]\n",
                                    [("sweep.axes.frequency_hz[0]", 14, "must be > 0 (Hz)")]),
    "a window at 0 Hz": (("floquet = true", "window = { frequency_hz = [0.0] }"),
                         [("analyses.window.frequency_hz[0]", 12, "must be > 0 (Hz)")]),
    # issue 21: the window names its method; the frontier's analyses
    "window order without averaging": (("floquet = true", "window = { omega = [300.0], "
                                                          "order = 2 }"),
                                       [("analyses.window.order", 12, 'only with method = '
                                                                      '"averaging"')]),
    "window method misspelt": (("floquet = true", 'window = { omega = [300.0], method = '
                                                  '"mathieu" }'),
                               [("analyses.window.method", 12, "unknown value 'mathieu'; "
                                                               "allowed: floquet, averaging")]),
    "continuation without stop": (("floquet = true", 'continuation = { parameter = "A" }'),
                                  [("analyses.continuation.stop", 12, "missing; where the "
                                                                      "branch ends")]),
    "continuation = true": (("floquet = true", "continuation = true"),
                            [("analyses.continuation.stop", 12, "missing")]),
    "continuation of no parameter": (("floquet = true", 'continuation = { parameter = "amp", '
                                                        'stop = 0.3 }'),
                                     [("analyses.continuation.parameter", 12,
                                       "unknown parameter 'amp'; allowed: A, g, l, m, omega, "
                                       "frequency_hz")]),
    "continuation stops where it starts": (("floquet = true", "continuation = { stop = 0.05 }"),
                                           [("analyses.continuation.stop", 12, "equals the "
                                                                               "start value")]),
    "continuation to ω < 0": (("floquet = true", 'continuation = { parameter = "omega", stop = '
                                                 '-5.0 }'),
                              [("analyses.continuation.stop", 12, "must be > 0 (rad/s)")]),
    "continuation switch as text": (("floquet = true", 'continuation = { stop = 0.3, switch = '
                                                       '"yes" }'),
                                    [("analyses.continuation.switch", 12, "must be true or "
                                                                          "false")]),
    "diagram without values": (("floquet = true", 'bifurcation_diagram = { parameter = "A" }'),
                               [("analyses.bifurcation_diagram.values", 12, "missing; the values "
                                                                            "of A")]),
    "diagram start of two angles": (("floquet = true", "bifurcation_diagram = { values = [0.1], "
                                                       "starts = [[0.1, 0.2]] }"),
                                    [("analyses.bifurcation_diagram.starts[0]", 12,
                                      "a start needs 1 coordinate values (theta), got 2")]),
    "diagram at a frequency ≤ 0 Hz": (("floquet = true", 'bifurcation_diagram = { parameter = '
                                                         '"frequency_hz", values = [-1.0] }'),
                                      [("analyses.bifurcation_diagram.values[0]", 12,
                                        "must be > 0 (Hz)")]),
    "lyapunov record too short": (("floquet = true", "lyapunov = { periods = 4 }"),
                                  [("analyses.lyapunov.periods", 12, "must be ≥ 8, got 4")]),
    "lyapunov too many exponents": (("floquet = true", "lyapunov = { exponents = 3 }"),
                                    [("analyses.lyapunov.exponents", 12, "must be at most 2")]),
    "lyapunov exponents misspelt": (("floquet = true", 'lyapunov = { exponents = "al" }'),
                                    [("analyses.lyapunov.exponents", 12, "unknown value 'al'; "
                                                                         "allowed: all, "
                                                                         "largest")]),
    "lyapunov transient < 0": (("floquet = true", "lyapunov = { transient = -1 }"),
                               [("analyses.lyapunov.transient", 12, "must be ≥ 0")]),
    "lyapunov without a drive": ([("[effects.drive]\namplitude = 0.05\nomega = 300.0\n", ""),
                                  ("floquet = true", "lyapunov = true")],
                                 [("analyses.lyapunov", 9, "lyapunov needs a drive")]),
    "output formats": ("[output]\nformats = [\"hdf5\"]\n",
                       [("output.formats[0]", 14, "unknown value 'hdf5'; allowed: parquet, "
                                                  "csv")]),
}


def _bad_text(change):
    """_GOOD with one line replaced (old, new), several ([(old, new), ...]), or text added."""
    if isinstance(change, str):
        return _GOOD + change
    text = _GOOD
    for old, new in [change] if isinstance(change, tuple) else change:
        assert old in text, old
        text = text.replace(old, new, 1)
    return text


@pytest.mark.parametrize("case", list(BAD))
def test_bad_scene_files_are_explained(case, tmp_path):
    change, expected = BAD[case]
    path = tmp_path / "bad.toml"
    path.write_text(_bad_text(change))
    with pytest.raises(SceneError) as info:
        Scene.from_toml(path)
    err = info.value
    assert err.source == str(path)
    text = str(err)
    for key, line, part in expected:
        hits = [p for p in err.problems if p.key == key and part in p.message]
        assert hits, f"{case}: no problem at {key!r} saying {part!r} in\n{text}"
        if line is not None:
            assert hits[0].line == line, f"{case}: {key} at line {hits[0].line}, not {line}"
            assert f"{path}:{line}: {key}: " in text
        else:
            assert f"{key}: " in text


def test_hertz_are_read_as_rad_per_s_once(tmp_path):
    """frequency_hz wherever the file allows it (the drive, an analysis's axis, a sweep
    axis) is read as omega in rad/s: the checked scene, the analyses and the sweep's
    dataset hold omega only (docs/api-conventions.md §4)."""
    w = 2 * math.pi
    text = (_GOOD.replace("omega = 300.0", "frequency_hz = 50.0")
            .replace("floquet = true", "floquet = true\nwindow = { frequency_hz = { start = "
                     "10.0, stop = 100.0, num = 3, scale = \"log\" } }\nverify = { A = [0.1], "
                     "frequency_hz = [50.0, 60.0] }")
            + "[sweep]\nanalyses = [\"floquet\"]\n[sweep.axes]\nfrequency_hz = [40.0, 60.0]\n"
            + "[output]\ndirectory = \"out\"\n")
    s = Scene.from_text(text, str(tmp_path / "scene.toml"))
    assert s.params["omega"] == w * 50.0
    window = s.analyses["window"]
    assert set(window) == {"omega"} and window["omega"].name == "omega"
    assert window["omega"].kind == "log"
    assert window["omega"].values == pytest.approx(tuple(w * np.geomspace(10.0, 100.0, 3)),
                                                   rel=1e-15)
    assert s.analyses["verify"]["omega"].values == (w * 50.0, w * 60.0)
    (axis,) = s.spec.sweep["axes"]
    assert (axis.name, axis.values, s.spec.sweep["targets"]) == ("omega", (w * 40, w * 60),
                                                                 {"omega": "omega"})
    assert "frequency_hz" not in repr((s.spec.params, s.spec.analyses, s.spec.sweep))
    # the same scene in rad/s is the same scene: the same key, the same numbers
    in_rad_s = Scene.from_text(
        text.replace("frequency_hz = 50.0", f"omega = {w * 50.0!r}")
        .replace("frequency_hz = { start = 10.0, stop = 100.0,",
                 f"omega = {{ start = {w * 10.0!r}, stop = {w * 100.0!r},")
        .replace("frequency_hz = [50.0, 60.0]", f"omega = [{w * 50.0!r}, {w * 60.0!r}]")
        .replace("frequency_hz = [40.0, 60.0]", f"omega = [{w * 40.0!r}, {w * 60.0!r}]"),
        str(tmp_path / "scene.toml"))
    assert in_rad_s.params == s.params and in_rad_s.spec.sweep == s.spec.sweep
    np.testing.assert_allclose(in_rad_s.analyses["window"]["omega"].values,
                               window["omega"].values, rtol=1e-15)
    # the sweep's dataset: an omega column in rad/s, each point Floquet at that omega
    # (about "auto": the hanging state, nearest the initial θ = 0)
    frame = s.sweep("floquet", progress=False).to_dataframe()
    assert "frequency_hz" not in frame and frame["omega"].tolist() == [w * 40, w * 60]
    for i in range(2):
        one = kapitza.floquet_point(s.system, dict(s.params, omega=w * (40, 60)[i]), [0.0])
        assert frame["trace"][i] == pytest.approx(one.trace, rel=1e-9)


def test_g_without_gravity():
    text = _GOOD.replace("gravity = true", "gravity = false").replace("l = 1.0",
                                                                       "l = 1.0\ng = 9.81")
    with pytest.raises(SceneError, match="g is gravity's parameter, but gravity is off"):
        Scene.from_text(text)


def test_many_errors_are_reported_together(tmp_path):
    path = tmp_path / "many.toml"
    path.write_text(textwrap.dedent('''\
        schema = 1
        [system]
        name = "pendulum"
        [parameters]
        l = -1.0
        [effects]
        gravity = "yes"
        [effects.drive]
        amplitude = -0.1
        omega = 0.0
        [effects.damping]
        gamma = -2
        [initial]
        thetta = 1.0
        [analyses]
        averagng = true
    '''))
    with pytest.raises(SceneError) as info:
        Scene.from_toml(path)
    got = [(p.key, p.line) for p in info.value.problems]
    assert got == [("effects.gravity", 7), ("effects.drive.amplitude", 9),
                   ("effects.drive.omega", 10), ("effects.damping.gamma", 12),
                   ("parameters.l", 5), ("initial.thetta", 14), ("analyses.averagng", 16)]
    text = str(info.value)
    assert text.startswith(f"scene {path} has 7 errors:")
    assert "Did you mean 'theta'?" in text and "Did you mean 'averaging'?" in text
    assert isinstance(info.value, ValueError)


def test_syntax_errors_and_unreadable_files(tmp_path):
    path = tmp_path / "broken.toml"
    path.write_text("schema = 1\n[system\nname = 'pendulum'\n")
    with pytest.raises(SceneError, match=r"broken.toml:2: \(syntax\): not valid TOML"):
        Scene.from_toml(path)
    with pytest.raises(SceneError, match="cannot be read"):
        Scene.from_toml(tmp_path / "missing.toml")


def test_key_lines_follow_tables_inline_tables_and_multiline_arrays():
    from kapitza.scenes._checker import key_lines
    lines = key_lines(textwrap.dedent('''\
        a = 1   # a comment with [brackets]
        [b]
        c = [
          [1, 2],
          [3, 4],
        ]
        d = { e = 1, f = "x # not a comment" }
        "g.h" = 2
        [b.i]
        j.k = 3
    '''))
    assert lines == {"a": 1, "b": 2, "b.c": 3, "b.d": 7, "b.d.e": 7, "b.d.f": 7, "b.g.h": 8,
                     "b.i": 9, "b.i.j.k": 10}


# -- running and writing --------------------------------------------------------------------

def test_only_the_analyses_asked_for_run_and_tables_are_written(tmp_path):
    path = tmp_path / "scene.toml"
    path.write_text(_GOOD.replace("[analyses]", "[initial]\ntheta = 3.1\n[analyses]")
                    .replace("floquet = true", "floquet = true\nwindow = { omega = [100.0, "
                             "300.0] }\nsimulate = { periods = 5, samples = 11 }")
                    + '[output]\ndirectory = "out"\nformats = ["parquet", "csv"]\n')
    s = Scene.from_toml(path)
    res = s.run()
    assert list(res.results) == ["floquet", "window", "simulate"]
    fl = res["floquet"]
    assert isinstance(fl, kapitza.FloquetResult) and fl.stable      # Kapitza: upright held
    exact = kapitza.KapitzaPendulum(l=1.0, g=9.81).window(np.array([100.0, 300.0]))
    np.testing.assert_array_equal(res["window"].A_min, exact.A_min)   # the exact window
    tr = res["simulate"]
    assert tr.t.shape == (11,) and tr.t[-1] == pytest.approx(5 * 2 * math.pi / 300.0)
    out = tmp_path / "out"
    assert sorted(p.name for p in out.iterdir()) == [      # each CSV with its sidecar
        "_run.json", "floquet.csv", "floquet.csv-metadata.json", "floquet.parquet",
        "simulate.csv", "simulate.csv-metadata.json", "simulate.parquet", "window.csv",
        "window.csv-metadata.json", "window.parquet"]
    import json

    import pyarrow.parquet as pq
    table = pq.read_table(out / "simulate.parquet")
    meta = json.loads(table.schema.metadata[b"kapitza"])
    assert meta["scene"] == path.read_text() and meta["analysis"] == "simulate"
    assert meta["parameters"]["omega"] == 300.0 and meta["versions"]["numpy"] == np.__version__
    assert meta["fingerprint"] == kapitza.scenes.code_fingerprint()
    frame = table.to_pandas()
    assert list(frame.columns[:2]) == ["t", "theta"] and len(frame) == 11
    fl_table = pd.read_parquet(out / "floquet.parquet")         # complex multipliers, split
    assert {"multiplier_real", "multiplier_imag"} <= set(fl_table.columns)
    pd.testing.assert_frame_equal(pd.read_csv(out / "simulate.csv"), frame, check_exact=False,
                                  rtol=1e-12)


def test_floquet_follows_the_effects():
    """A drive off the vertical: Floquet about the periodic orbit (Newton shooting), the
    tilted state of averaging nearest the initial angle."""
    s = Scene.example("horizontal_drive")
    assert s.capabilities["floquet"] == "periodic_orbit"
    orbit = s.run(write=False)["floquet"]
    assert isinstance(orbit, kapitza.PeriodicOrbit) and orbit.stable
    tilt = math.acos(2 * 9.81 * 1.0 / (0.05 * 200.0) ** 2)        # averaging, PHYSICS.md
    assert orbit.q_mean[0] == pytest.approx(tilt, abs=0.01)
    with pytest.raises(ValueError, match="analysis 'averaging': order 2 is the plain "
                                         "pendulum's closed form"):
        scene('''
            [system]
            name = "double_pendulum"
            [parameters]
            l1 = 1.0
            l2 = 1.0
            [effects]
            gravity = true
            [effects.drive]
            amplitude = 0.05
            omega = 300.0
            [analyses]
            averaging = { order = 2 }
        ''').run()


def test_map_and_window_of_a_system_off_the_plain_pendulum():
    """A spring at the upright (rest = π) makes the scene a general system: the map by
    monodromy (kapitza.stability_map) and the exact window by kapitza.window (issue 21.1:
    never averaging in its place); the averaging window only when asked for by name.
    Its linearisation is the pendulum's with g' = g − k/(m l): the exact Mathieu map and
    window, and averaging's A_min ω = √(2 g' l), are independent references."""
    A = [0.01, 0.02, 0.4, 0.5]
    text = (_GOOD.replace("[analyses]", f"[effects.spring.theta]\nk = 2.0\nrest = "
                                        f"{math.pi!r}\n[analyses]")
            .replace("floquet = true", f"stability_map = {{ A = {A}, omega = [300.0], about = "
                                       "\"inverted\" }\nwindow = { omega = [300.0, 600.0], "
                                       "about = \"inverted\", tol = 1e-9 }"))
    s = Scene.from_text(text)
    assert s.pendulum is None
    res = s.run(write=False)
    g_eff = 9.81 - 2.0 / (1.0 * 1.0)
    exact = kapitza.KapitzaPendulum(l=1.0, g=g_eff).stability_map(np.array(A), np.array([300.0]))
    np.testing.assert_array_equal(res["stability_map"].stable, exact.stable)
    assert exact.stable[:, 0].tolist() == [False, True, True, False]
    window = res["window"]
    assert window.method == "floquet" and list(window.status) == ["window", "window"]
    mathieu = kapitza.pendulum_window(np.array([300.0, 600.0]), l=1.0, g=g_eff)
    np.testing.assert_allclose(window.A_min, mathieu.A_min, rtol=1e-8)
    np.testing.assert_allclose(window.A_max, mathieu.A_max, rtol=1e-8)
    tables = res.tables()
    assert set(tables["window"]["method"]) == {"floquet: certified monodromy edges "
                                               "(kapitza.window)"}
    assert set(tables["stability_map"]["method"]) == {"floquet: monodromy"}
    averaged = Scene.from_text(text.replace('about = "inverted", tol = 1e-9 }',
                                            'about = "inverted", method = "averaging" }'))
    res = averaged.run(write=False)
    assert res["window"].method == "averaging"
    assert res.methods["window"] == "averaging: order 1"
    np.testing.assert_allclose(res["window"].A_min, np.sqrt(2 * g_eff) / np.array([300.0, 600.0]),
                               rtol=1e-12)


def test_verify_compares_the_methods_over_a_grid():
    res = Scene.from_text(_GOOD.replace("[analyses]", "[initial]\ntheta = 3.13\n[analyses]")
                          .replace("floquet = true", "verify = { A = [0.03, 0.05], omega = "
                                                     "[300.0], periods = 300 }")).run()
    v = res["verify"]
    assert type(v).__name__ == "Verification"
    table = res.to_dataframe("verify")
    assert len(table) == 2 and table["stable_floquet"].all()
    assert (table["stable_simulation"] == table["stable_floquet"]).all()
    assert table["omega_slow_simulation"].to_numpy() == pytest.approx(
        table["omega_slow_floquet"].to_numpy(), rel=1e-3)
