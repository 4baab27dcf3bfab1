"""Where users meet the frontier (issue 21.1, 21.6): scene analyses name their method and
never put averaging in place of the exact window; the scene analyses ``continuation``,
``bifurcation_diagram`` and ``lyapunov`` run and are written as tables; the commands
``kapitza continue``, ``kapitza bifurcation`` and ``kapitza lyapunov``.

The physics is checked against independent references: the exact window by
``kapitza.window`` called directly and by the stability map of the same run; the hanging
pendulum's period doubling by the damped Mathieu window (``kapitza.pendulum_window``,
characteristic values); the Lyapunov exponents' sum by the phase-space contraction −γ
(tr J of the damped pendulum, exact); the diagram's dots by the hanging state's
stability.
"""
import json
import math

import numpy as np
import pandas as pd
import pytest

import kapitza
from kapitza import Scene, cli
from kapitza.scenes import Branches

G, L = 9.81, 1.0
W0 = math.sqrt(G / L)
GAMMA = 0.47


def _double_pendulum(analyses: str) -> Scene:
    text = kapitza.example_scenes()["double_pendulum"].read_text()
    return Scene.from_text(text.split("[analyses]")[0] + "[analyses]\n" + analyses)


# -- 21.1: the window is exact wherever Floquet applies -----------------------------------------

def test_double_pendulum_window_is_exact_and_agrees_with_the_map():
    """The equal double pendulum (l = 1 m) is held upright only above ω/ω0 ≈ 12.95: no
    window at 20 and 30.7 rad/s (first-order averaging would give one), one at 60 rad/s;
    the scene's window equals kapitza.window's, and the map of the same run is stable
    exactly inside it."""
    omega = [20.0, 30.7, 60.0]
    A = np.linspace(0.0, 0.3, 61)
    scene = _double_pendulum(
        f'window = {{ omega = {omega}, about = "inverted" }}\n'
        f'stability_map = {{ A = {A.tolist()}, omega = {omega}, about = "inverted" }}\n')
    res = scene.run(write=False)
    win = res["window"]
    direct = kapitza.window(scene.system, scene.params, [math.pi, math.pi], omega=omega)
    assert win.method == "floquet" and list(win.status) == ["none", "none", "window"]
    np.testing.assert_array_equal(win.A_min, direct.A_min)
    np.testing.assert_array_equal(win.A_max, direct.A_max)
    # the onset: between 12.9 and 13.0 ω0 (kapitza.window directly)
    onset = kapitza.window(scene.system, scene.params, [math.pi, math.pi],
                           omega=np.array([12.9, 13.0]) * W0)
    assert list(onset.status) == ["none", "window"]
    stable = np.asarray(res["stability_map"].stable)
    assert not stable[:, :2].any()
    lo, hi = win.A_min[2], win.A_max[2]
    clear = (np.abs(A - lo) > 1e-6) & (np.abs(A - hi) > 1e-6)
    np.testing.assert_array_equal(stable[clear, 2], ((A > lo) & (A < hi))[clear])
    tables = res.tables()
    assert set(tables["window"]["method"]) == {"floquet: certified monodromy edges "
                                               "(kapitza.window)"}
    assert res.methods["stability_map"].startswith("floquet")


def test_averaging_window_only_by_name():
    """``method = "averaging"`` gives averaging's window, labelled so: at 20 rad/s the
    double pendulum has one by averaging (A_min ω = √(2 g_eff l)-like) that the exact
    analysis refutes."""
    scene = _double_pendulum('window = { omega = [20.0, 60.0], about = "inverted", '
                             'method = "averaging" }\n')
    res = scene.run(write=False)
    win = res["window"]
    assert win.method == "averaging" and np.isfinite(win.A_min[0])
    assert res.methods["window"] == "averaging: order 1"
    assert set(res.tables()["window"]["method"]) == {"averaging: order 1"}
    ref = kapitza.average(scene.system).window(scene.params, [math.pi, math.pi],
                                               omega=[20.0, 60.0])
    np.testing.assert_array_equal(win.A_min, ref.A_min)


def test_plain_pendulum_window_methods():
    """The plain pendulum: exact (Mathieu) by default, the closed-form averaging of order
    1 or 2 by name; the hanging state has no averaging window (said so)."""
    text = kapitza.example_scenes()["kapitza_pendulum"].read_text().split("[analyses]")[0]
    exact = Scene.from_text(text + "[analyses]\nwindow = { omega = [100.0, 300.0] }\n")
    res = exact.run(write=False)
    pend = exact.pendulum
    np.testing.assert_array_equal(res["window"].A_min, pend.window([100.0, 300.0],
                                                                   about="inverted").A_min)
    # the scene is damped (γ = 0.5 1/s): the Mathieu equation's monodromy traces
    assert res.methods["window"] == "floquet: Mathieu monodromy traces (damped)"
    second = Scene.from_text(text + '[analyses]\nwindow = { omega = [100.0, 300.0], '
                                    'method = "averaging", order = 2 }\n').run(write=False)
    ref = pend.window([100.0, 300.0], method="averaging", order=2)
    np.testing.assert_array_equal(second["window"].A_min, ref.A_min)
    assert second.methods["window"] == "averaging: order 2, closed form"
    with pytest.raises(ValueError, match="the averaging window is the upright state's"):
        Scene.from_text(text + '[analyses]\nwindow = { omega = [300.0], about = "hanging", '
                               'method = "averaging" }\n').run(write=False)


def test_every_table_names_its_method(tmp_path):
    """Each analysis's table (and the written files) carries a ``method`` column."""
    text = kapitza.example_scenes()["kapitza_pendulum"].read_text().split("[analyses]")[0]
    path = tmp_path / "scene.toml"
    path.write_text(text + "[analyses]\naveraging = true\nfloquet = true\nmeasure = { periods = "
                    "50 }\nsimulate = { periods = 3, samples = 7 }\n"
                    '[output]\ndirectory = "out"\nformats = ["parquet", "csv"]\n')
    res = Scene.from_toml(path).run()
    for name, frame in res.tables().items():
        assert frame["method"].nunique() == 1, name
        assert frame["method"].iloc[0].split(":")[0] in ("averaging", "floquet", "simulation")
    assert res.methods["floquet"] == "floquet: monodromy about the equilibrium"
    on_disk = pd.read_parquet(tmp_path / "out" / "averaging.parquet")
    assert on_disk["method"].iloc[0] == "averaging: order 1, closed form"


# -- 21.6: the frontier's analyses of a scene ----------------------------------------------------

@pytest.fixture(scope="module")
def period_doubling(tmp_path_factory):
    """The shipped period-doubling scene, its diagram and Lyapunov record shortened, run
    and written."""
    text = kapitza.example_scenes()["period_doubling"].read_text()
    text = (text.replace("num = 141", "num = 29").replace("periods = 64", "periods = 32")
            .replace("periods = 1000", "periods = 400")
            + '\n[output]\ndirectory = "out"\n')
    folder = tmp_path_factory.mktemp("pd")
    path = folder / "period_doubling.toml"
    path.write_text(text)
    scene = Scene.from_toml(path)
    return scene, scene.run(progress=False), folder / "out"


def test_period_doubling_scene_writes_each_table(period_doubling):
    scene, res, out = period_doubling
    assert list(res.results) == ["continuation", "bifurcation_diagram", "lyapunov"]
    assert sorted(p.name for p in out.iterdir()) == [
        "_run.json", "bifurcation_diagram.parquet", "continuation.parquet",
        "continuation_bifurcations.parquet", "lyapunov.parquet"]
    families = {"continuation": "continuation", "continuation_bifurcations": "continuation",
                "bifurcation_diagram": "simulation", "lyapunov": "lyapunov"}
    for name, family in families.items():
        frame = pd.read_parquet(out / f"{name}.parquet")
        assert len(frame) and frame["method"].str.startswith(family + ":").all(), name
    branches = pd.read_parquet(out / "continuation.parquet")
    assert {"branch", "branch_label", "A", "stable", "theta_amplitude",
            "multiplier_0_real"} <= set(branches.columns)
    assert set(branches.branch) == {0, 1}       # switch = true: the 2T branch followed


def test_continuation_finds_the_damped_mathieu_period_doubling(period_doubling):
    """The hanging state period-doubles where the damped Mathieu window of the hanging
    state ends (characteristic values, kapitza.pendulum_window), to 1e-9; the swing born
    there is followed (2T orbits) and breaks its symmetry at a pitchfork."""
    scene, res, _ = period_doubling
    b = res["continuation"]
    assert isinstance(b, Branches) and [br.periods for br in b.branches] == [1, 2]
    (i, pd_), (j, pitch) = b.bifurcations
    assert (i, pd_.kind, j, pitch.kind) == (0, "period_doubling", 1, "pitchfork")
    win = kapitza.pendulum_window(scene.params["omega"], l=L, g=G, damping=GAMMA,
                                  about="hanging")
    assert abs(pd_.parameter / float(win.A_max) - 1) < 1e-9
    table = res.tables()["continuation_bifurcations"]
    assert table.born_branch.tolist() == [1, -1]


def test_diagram_and_lyapunov_agree_with_the_physics(period_doubling):
    """The diagram's dots stay at θ = 0 below the period doubling and leave it above; the
    exponents at A = 0.55 m are chaotic (λ1 > 0 beyond its error) and sum to −γ."""
    _, res, _ = period_doubling
    d = res["bifurcation_diagram"]
    a_pd = res["continuation"].bifurcations[0][1].parameter
    swing = np.nanmax(np.abs(d.q_wrapped[..., 0]), axis=(1, 2))
    below, above = d.values < a_pd - 0.01, (d.values > a_pd + 0.01) & (d.values < 0.25)
    assert np.all(swing[below] < 1e-2) and np.all(swing[above] > 0.1)
    s = res["lyapunov"]
    assert s.complete and s.exponents[0] - s.error[0] > 0
    assert abs(s.exponents.sum() + GAMMA) < 1e-8


def test_about_auto_for_a_drive_that_leaves_no_equilibrium():
    """A horizontal drive: the continuation starts on the periodic orbit (tilted) that
    averaging points to, as kapitza.periodic_orbit finds it."""
    scene = Scene.from_text(kapitza.example_scenes()["horizontal_drive"].read_text()
                            .split("[analyses]")[0]
                            + "[analyses]\ncontinuation = { stop = 0.06, max_points = 40 }\n")
    b = scene.run(write=False)["continuation"]
    first = b.main.points
    orbit = kapitza.periodic_orbit(scene.system, scene.params,
                                   [float(first.q_mean[0, 0])])
    np.testing.assert_allclose(first.state[0], orbit.state, atol=1e-8)
    assert abs(first.q_mean[0, 0]) > 0.3                       # tilted, not hanging


# -- the commands --------------------------------------------------------------------------

def _json(capsys, *argv):
    code = cli.main([*argv, "--json"])
    out = capsys.readouterr()
    return code, (json.loads(out.out) if out.out.strip() else None), out.err


def test_continue_command(tmp_path, capsys):
    code, data, _ = _json(capsys, "continue", "--A", "0.02", "--omega-over-omega0", "20",
                          "--about", "inverted", "--stop", "0.6", "--out",
                          str(tmp_path / "b.png"))
    assert code == 0
    kinds = [(b["kind"], b["A"]) for b in data["bifurcations"]]
    mathieu = kapitza.pendulum_window(20 * W0, l=L, g=G)
    assert [k for k, _ in kinds] == ["pitchfork", "period_doubling"]
    assert kinds[0][1] == pytest.approx(float(mathieu.A_min), rel=1e-8)
    assert kinds[1][1] == pytest.approx(float(mathieu.A_max), rel=1e-8)
    assert (tmp_path / "b.png").stat().st_size > 10_000
    assert len(pd.read_csv(tmp_path / "b.csv")) == data["branches"][0]["points"]
    assert len(pd.read_csv(tmp_path / "b_bifurcations.csv")) == 2


def test_bifurcation_command(tmp_path, capsys):
    code, data, _ = _json(capsys, "bifurcation", "--omega", "6.2642", "--damping", "0.47",
                          "--values", "0.05,0.1", "--starts", "0.1", "--periods", "16",
                          "--transient", "200", "--out", str(tmp_path / "d.png"))
    assert code == 0
    assert data["orbit_period"] == [[1], [2]]       # hanging below the doubling, 2T above
    assert data["method"].startswith("simulation:")
    assert len(pd.read_csv(tmp_path / "d.csv")) == 2 * 16


def test_lyapunov_command_point_and_grid(tmp_path, capsys):
    code, data, _ = _json(capsys, "lyapunov", "--A", "0.55", "--omega", "6.2642", "--damping",
                          "0.47", "--periods", "200", "--transient", "50")
    assert code == 0 and data["complete"]
    assert data["sum"] == pytest.approx(-GAMMA, abs=1e-8)
    code, grid, _ = _json(capsys, "lyapunov", "--A", "0.02,0.55", "--omega", "6.2642",
                          "--damping", "0.47", "--periods", "100", "--transient", "50",
                          "--data", str(tmp_path / "g.csv"))
    assert code == 0 and grid["shape"] == [2, 1] and len(grid["rows"]) == 2
    assert grid["rows"][0]["exponent"] < 0          # the hanging state, stable
    assert (tmp_path / "g.csv").is_file()


def test_commands_on_a_scene_file_with_options_over_it(tmp_path, capsys):
    scene = str(kapitza.example_scenes()["period_doubling"])
    code, data, _ = _json(capsys, "continue", scene, "--stop", "0.2", "--no-switch", "--out",
                          str(tmp_path / "c.png"))
    assert code == 0 and len(data["branches"]) == 1
    assert [b["kind"] for b in data["bifurcations"]] == ["period_doubling"]
    code, data, _ = _json(capsys, "lyapunov", scene, "--periods", "64", "--transient", "20")
    assert code == 0 and data["periods"] == 64


@pytest.mark.parametrize("argv, says", [
    (["continue", "--A", "0.02", "--omega", "300"], "--stop: missing"),
    (["continue", "--A", "0.02", "--omega", "300", "--stop", "0.3", "--parameter", "B"],
     "--parameter: unknown parameter 'B'"),
    (["continue", "--omega", "300", "--stop", "0.3"], "--A"),
    (["bifurcation", "--omega", "6.3"], "--values: missing"),
    (["bifurcation", "--omega", "6.3", "--values", "0:1"], "--values"),
    (["lyapunov", "--A", "0.5", "--omega", "6.3", "--periods", "4"], "--periods: must be ≥ 8"),
    (["lyapunov", "--A", "0.5", "--omega", "6.3", "--exponents", "x"], "--exponents"),
    (["lyapunov", "--A", "0.5", "--omega", "6.3", "--damping", "-1"], "--damping"),
    (["lyapunov", str(kapitza.example_scenes()["period_doubling"]), "--A", "0.5"],
     "the scene sets the drive"),
])
def test_frontier_usage_errors_exit_2(argv, says, capsys):
    assert cli.main(argv) == 2
    assert says in capsys.readouterr().err


def test_frontier_of_a_chain_of_two_links():
    """Two coordinates: starts are lists of both angles; the upright chain at ω = 300 rad/s
    held (A = 0.05 m, inside its exact window) keeps its dots near (π, π), and its largest
    exponent is ≤ 0 within its error (no chaos near a stable equilibrium)."""
    scene = _double_pendulum(
        "bifurcation_diagram = { values = [0.05], starts = [[3.13, 3.15], [3.15, 3.13]], "
        "periods = 8, transient = 200 }\n"
        'lyapunov = { periods = 80, transient = 20, exponents = "largest" }\n')
    res = scene.run(write=False)
    d = res["bifurcation_diagram"]
    assert d.q.shape == (1, 2, 8, 2)
    assert np.all(np.abs((d.q % (2 * np.pi)) - np.pi) < 0.1)
    s = res["lyapunov"]
    assert s.exponents.shape == (1,) and s.exponents[0] - s.error[0] <= 0
