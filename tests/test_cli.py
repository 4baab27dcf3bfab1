"""The ``kapitza`` command line (issue 14.1): every command run in-process through
``kapitza.cli.main`` (its ``--json`` numbers equal the API's), the exit codes 0, 1, 2 and
130, ``--help`` with an example, dimensionless inputs equal to SI ones, and one call of the
installed entry point."""
import gc
import json
import math
import shutil
import subprocess
import sys

import numpy as np
import pandas as pd
import pytest

import kapitza
from kapitza import KapitzaPendulum, cli
from kapitza.cli import _commands
from kapitza.cli import _main as cli_main
from kapitza.results import ComputationInterrupted

from helpers import pendulum_scene

W60 = 2 * math.pi * 60
COMMANDS = ["predict", "window", "map", "measure", "verify", "animate", "continue", "bifurcation",
            "lyapunov", "report", "run", "sweep", "warmup", "summary"]


def run_json(capsys, *argv):
    """Run ``kapitza argv --json``; (exit code, parsed stdout, stderr)."""
    code = cli.main([*argv, "--json"])
    out = capsys.readouterr()
    return code, (json.loads(out.out) if out.out.strip() else None), out.err


# -- help, version, usage ---------------------------------------------------------------------

@pytest.mark.parametrize("command", COMMANDS)
def test_every_command_has_help_with_an_example(command, capsys):
    assert cli.main([command, "--help"]) == 0
    text = capsys.readouterr().out
    assert "examples:" in text and f"kapitza {command}" in text


def test_version(capsys):
    assert cli.main(["--version"]) == 0
    assert capsys.readouterr().out.strip() == f"kapitza {kapitza.__version__}"


@pytest.mark.parametrize("argv, says", [
    (["predict", "--A", "0.05"], "--omega"),                       # frequency missing
    (["predict", "--omega", "300"], "--A"),                        # amplitude missing
    (["predict", "--A", "x", "--omega", "300"], "'x'"),            # not a number
    (["predict", "--A", "0.05", "--omega", "1,2"], "one value"),   # a grid where one is due
    (["predict", "--l", "-1", "--A", "0.05", "--omega", "300"], "l must be"),
    (["predict", "--A", "0.05", "--A-over-l", "0.05", "--omega", "1"], "not allowed"),
    (["nonsense"], "invalid choice"),
    (["map", "--A", "0:0.1:3", "--omega", "100", "--data", "x.txt"], "--data"),
    (["run", "no_such_scene.toml"], "no_such_scene.toml"),
    (["window", "--drive", "horizontal", "--omega", "300"], "about='hanging'"),
    (["map", "--A", "0.01,0.05", "--omega", "2:1:3", "--log-omega", "--omega-over-omega0",
      "3"], "not allowed"),
    (["--rtol", "2"], "--rtol"),
])
def test_usage_errors_exit_2_naming_what_is_wrong(argv, says, capsys):
    assert cli.main(argv) == 2
    assert says in capsys.readouterr().err


def test_a_scene_error_exits_2_with_the_key_and_line(tmp_path, capsys):
    bad = tmp_path / "bad.toml"
    bad.write_text('schema = 1\n[system]\nname = "pendulum"\n[parameters]\nl = -1\n')
    assert cli.main(["run", str(bad)]) == 2
    err = capsys.readouterr().err
    assert "parameters.l" in err and "bad.toml:5" in err


def test_bare_kapitza_with_options_runs_the_summary(monkeypatch, capsys):
    seen = {}

    def fake(rtol, progress=None):
        seen["rtol"] = rtol
        return pd.DataFrame([{"problem": "pendulum", "status": "success"}])

    # patched where the summary command looks it up
    monkeypatch.setattr(_commands, "catalogue_summary", fake)
    assert cli.main(["--rtol", "1e-6"]) == 0
    assert seen["rtol"] == 1e-6
    assert "success" in capsys.readouterr().out
    code, data, _ = run_json(capsys, "summary", "--rtol", "1e-7")
    assert code == 0 and data["problems"][0]["status"] == "success"


# -- predict ------------------------------------------------------------------------------------

def test_predict_json_equals_the_api(capsys):
    code, data, err = run_json(capsys, "predict", "--A", "0.05", "--omega", str(W60))
    assert code == 0
    pend = KapitzaPendulum()
    avg = pend.averaged(0.05, W60, warn=False).inverted
    exact = pend.floquet(0.05, W60, about="inverted")
    assert data["averaging"]["inverted"]["omega_slow"] == float(avg.omega_slow)
    assert data["averaging"]["inverted"]["stable"] is True
    assert data["floquet"]["omega_slow"] == float(exact.omega_slow)
    assert data["floquet"]["trace"] == float(exact.trace)
    assert data["floquet"]["stable"] is True and data["A_over_l"] == 0.05


def test_dimensionless_inputs_give_the_si_result(capsys):
    l, g = 0.5, 9.81
    w0 = math.sqrt(g / l)
    si = run_json(capsys, "predict", "--l", str(l), "--A", "0.025", "--omega", str(100 * w0))[1]
    ratio = run_json(capsys, "predict", "--l", str(l), "--A-over-l", "0.05",
                     "--omega-over-omega0", "100")[1]
    hz = run_json(capsys, "predict", "--l", str(l), "--A", "0.025",
                  "--f", str(100 * w0 / (2 * math.pi)))[1]
    for other in (ratio, hz):
        assert other["A"] == pytest.approx(si["A"], rel=1e-15)
        assert other["omega"] == pytest.approx(si["omega"], rel=1e-14)
        assert other["floquet"]["omega_slow"] == pytest.approx(si["floquet"]["omega_slow"],
                                                               rel=1e-9)
        assert other["averaging"]["inverted"]["omega_slow"] == pytest.approx(
            si["averaging"]["inverted"]["omega_slow"], rel=1e-12)


def test_predict_horizontal_drive_is_the_tilted_orbit(capsys):
    code, data, _ = run_json(capsys, "predict", "--drive", "horizontal", "--A", "0.05",
                             "--omega", str(W60))
    orbit = KapitzaPendulum(drive="horizontal").floquet(0.05, W60, about="tilted")
    assert code == 0 and data["floquet"]["kind"] == "periodic orbit"
    assert data["floquet"]["theta_mean"] == pytest.approx(float(orbit.q_mean[0]), rel=1e-12)
    assert data["floquet"]["omega_slow"] == pytest.approx(float(orbit.omega_slow), rel=1e-9)


def test_predict_text_goes_to_stdout(capsys):
    assert cli.main(["predict", "--A", "0.05", "--f", "60"]) == 0
    out = capsys.readouterr().out
    assert "Floquet about inverted" in out and "12.98" in out


# -- window, map --------------------------------------------------------------------------------

def test_window_exact_with_averaging_beside(capsys):
    code, data, _ = run_json(capsys, "window", "--omega", "100,200,400")
    pend = KapitzaPendulum()
    exact = pend.window(np.array([100.0, 200.0, 400.0]))
    approx = pend.window(np.array([100.0, 200.0, 400.0]), method="averaging", order=1)
    rows = data["rows"]
    assert code == 0 and [r["omega"] for r in rows] == [100.0, 200.0, 400.0]
    assert [r["A_min"] for r in rows] == exact.A_min.tolist()
    assert [r["A_max"] for r in rows] == exact.A_max.tolist()
    assert [r["A_min_averaging"] for r in rows] == np.asarray(approx.A_min).tolist()
    assert all(r["A_max_averaging"] == "inf" for r in rows)         # no upper edge


def test_window_geometric_frequency_range(capsys):
    code, data, _ = run_json(capsys, "window", "--omega-over-omega0", "10:1000:3",
                             "--log-omega")
    assert code == 0
    assert [r["omega_over_omega0"] for r in data["rows"]] == pytest.approx([10, 100, 1000])


@pytest.mark.parametrize("suffix", [".csv", ".parquet"])
def test_map_writes_the_figure_and_the_data(tmp_path, suffix, capsys):
    png, table = tmp_path / "out" / "map.png", tmp_path / f"map{suffix}"
    code, data, _ = run_json(capsys, "map", "--A", "0:0.5:11", "--omega", "20:2000:8",
                             "--log-omega", "--out", str(png), "--data", str(table))
    assert code == 0 and png.stat().st_size > 10_000
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    frame = pd.read_csv(table) if suffix == ".csv" else pd.read_parquet(table)
    ref = KapitzaPendulum().stability_map(np.linspace(0, 0.5, 11), np.geomspace(20, 2000, 8))
    assert frame["stable"].tolist() == ref.stable.ravel().tolist()
    assert data["stable_points"] == int(ref.stable.sum()) and data["shape"] == [11, 8]


def test_map_about_the_horizontal_drives_orbits(tmp_path, capsys):
    """Issue 21.5: ``kapitza map --drive horizontal`` maps the hanging periodic orbit (it
    was refused); every point equals the orbit's own Floquet verdict, and a tilted state
    of the vertical drive is refused by name."""
    png = tmp_path / "h.png"
    code, data, _ = run_json(capsys, "map", "--drive", "horizontal", "--A", "0.01:0.09:5",
                             "--omega", "60:120:3", "--out", str(png))
    assert code == 0 and data["about"] == "hanging" and data["shape"] == [5, 3]
    pend = KapitzaPendulum(drive="horizontal")
    for i, A in enumerate(np.linspace(0.01, 0.09, 5)):
        for j, w in enumerate(np.linspace(60, 120, 3)):
            verdict = pend.floquet(A, w, about="hanging").stable
            assert pd.read_csv(png.with_suffix(".csv"))["stable"].to_numpy().reshape(5, 3)[
                i, j] == verdict
    code = cli.main(["map", "--about", "tilted", "--A", "0:0.1:3", "--omega", "50:60:2",
                     "--out", str(tmp_path / "v.png")])
    assert code == 2 and "--about tilted" in capsys.readouterr().err


def test_map_interrupted_saves_what_finished(tmp_path, monkeypatch, capsys):
    ref = KapitzaPendulum().stability_map(np.array([0.01, 0.05]), np.array([100.0, 200.0]))

    def stop(self, *a, **k):
        raise ComputationInterrupted(ref, np.array([[True, True], [False, False]]))

    monkeypatch.setattr(KapitzaPendulum, "stability_map", stop)
    png = tmp_path / "m.png"
    assert cli.main(["map", "--A", "0.01,0.05", "--omega", "100,200", "--out", str(png)]) == 130
    assert "2 of 4 points" in capsys.readouterr().err
    assert png.exists() and (tmp_path / "m.csv").exists()


def test_ctrl_c_exits_130(monkeypatch, capsys):
    def stop(*a, **k):
        raise KeyboardInterrupt

    monkeypatch.setattr(KapitzaPendulum, "floquet", stop)
    assert cli.main(["predict", "--A", "0.05", "--omega", "300"]) == 130
    assert "interrupted" in capsys.readouterr().err


def test_interrupted_grid_says_how_far_it_got(monkeypatch, capsys):
    def stop(self, *a, **k):
        raise ComputationInterrupted(None, np.array([True, False, False]))

    monkeypatch.setattr(KapitzaPendulum, "verify", stop)
    assert cli.main(["verify", "--A", "0.01,0.03,0.1", "--f", "40"]) == 130
    assert "after 1 of 3 points" in capsys.readouterr().err


# -- measure, verify ----------------------------------------------------------------------------

def test_measure_json_equals_the_api(capsys):
    code, data, _ = run_json(capsys, "measure", "--A", "0.05", "--omega", str(W60),
                             "--theta0", "3.13", "--periods", "300")
    m = KapitzaPendulum().measure(0.05, W60, theta0=3.13, periods=300)
    assert code == 0
    got = data["measurement"]
    assert got["stayed_up"] is True and got["fall_time"] == "nan"         # NaN, as text
    assert got["omega_slow"] == m.omega_slow and got["amplitude"] == m.amplitude


def test_verify_agreement_exits_0(tmp_path, capsys):
    table = tmp_path / "v.csv"
    code, data, _ = run_json(capsys, "verify", "--A", "0.01,0.03,0.1", "--f", "40",
                             "--periods", "400", "--data", str(table))
    assert code == 0 and data["agree"] is True and data["disagreements"] == []
    v = KapitzaPendulum().verify(np.array([0.01, 0.03, 0.1])[:, None],
                                 np.array([2 * math.pi * 40])[None, :], periods=400, line=False)
    assert pd.read_csv(table)["stable_floquet"].tolist() == v.stable_floquet.ravel().tolist()
    assert data["agreement"] == json.loads(v.agreement.to_json(orient="records"))


def test_verify_disagreement_exits_1(capsys):
    # just above the exact window's lower edge (1.763 cm at 40 Hz), released 0.54 rad
    # from the upright: beyond the separatrix, the simulation falls where Floquet is stable
    code, data, err = run_json(capsys, "verify", "--A", "0.0179", "--f", "40",
                               "--periods", "300", "--theta0", "2.6")
    assert code == 1 and data["agree"] is False
    assert {(d["first"], d["second"]) for d in data["disagreements"]} >= {
        ("floquet", "simulation")}
    assert "disagreement" in err


# -- scenes: run, sweep -------------------------------------------------------------------------

_SWEPT = pendulum_scene(theta=3.0916, analyses='measure = { periods = 50, about = "inverted" }',
                        sweep='analyses = ["measure"]',
                        axes="A = [0.01, 0.05]\nomega = [100.0, 200.0]")


def test_run_scene_json_equals_the_api(capsys):
    path = kapitza.example_scenes()["kapitza_pendulum"]
    code, data, err = run_json(capsys, "run", str(path), "--no-write")
    assert code == 0 and "averaging" in err
    res = kapitza.Scene.from_toml(path).run(write=False)
    rows = {r["equilibrium"]: r for r in data["analyses"]["averaging"]}
    assert rows["inverted"]["omega_slow"] == float(res["averaging"].inverted.omega_slow)
    assert data["analyses"]["floquet"][0]["abs"] == pytest.approx(
        float(abs(res["floquet"].multipliers[0])), rel=1e-12)


def test_sweep_scene_and_resume(tmp_path, capsys):
    scene = tmp_path / "swept.toml"
    scene.write_text(_SWEPT)
    out = tmp_path / "out"
    code, data, _ = run_json(capsys, "sweep", str(scene), "--directory", str(out))
    assert code == 0 and data["size"] == 4 and data["computed"] == data["tiles"]
    frame = pd.read_parquet(data["path"])
    assert len(frame) == 4 and "stayed_up" in frame
    code, again, _ = run_json(capsys, "sweep", str(scene), "--directory", str(out))
    assert code == 0 and again["computed"] == 0 and again["skipped"] == data["tiles"]


def test_sweep_without_a_sweep_table_exits_2(capsys):
    path = kapitza.example_scenes()["kapitza_pendulum"]
    assert cli.main(["sweep", str(path)]) == 2
    assert "[sweep]" in capsys.readouterr().err


def test_sweep_interrupted_exits_130(tmp_path, monkeypatch, capsys):
    scene = tmp_path / "swept.toml"
    scene.write_text(_SWEPT)

    def stop(self, *a, **k):
        raise ComputationInterrupted(None, np.zeros(1, bool))

    monkeypatch.setattr(kapitza.Scene, "sweep", stop)
    assert cli.main(["sweep", str(scene)]) == 130
    assert "resume" in capsys.readouterr().err


def test_warmup_calls_the_api(monkeypatch, capsys):
    module = sys.modules["kapitza.warmup"]
    monkeypatch.setattr(module, "warmup", lambda verbose=False: 1.5)
    code, data, _ = run_json(capsys, "warmup")
    assert code == 0 and data == {"seconds": 1.5}


# -- the installed entry point ------------------------------------------------------------------

def test_the_program_exits_with_main_s_code_after_freezing_what_is_alive(monkeypatch):
    """The program (console script, ``python -m kapitza``) runs ``main`` and exits with its
    code, having frozen the objects alive first: Python's shutdown then skips its last
    full collection (0.3–0.5 s of each command; benchmarks/bench_cold_start.py --only
    commands).  ``main`` itself, run in a user's process, never freezes."""
    calls = []
    monkeypatch.setattr(gc, "freeze", lambda: calls.append("freeze"))
    assert cli.main(["predict", "--A", "0.05", "--f", "60"]) == 0 and calls == []
    monkeypatch.setattr(cli_main, "main", lambda: calls.append("main") or 2)
    with pytest.raises(SystemExit) as stop:
        cli_main.program()
    assert stop.value.code == 2 and calls == ["main", "freeze"]


def test_installed_entry_point():
    exe = shutil.which("kapitza")
    if exe is None:
        pytest.skip("the kapitza entry point is not installed (pip install -e .)")
    done = subprocess.run([exe, "predict", "--A", "0.05", "--f", "60", "--json"],
                          capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    data = json.loads(done.stdout)
    assert data["floquet"]["stable"] is True
    assert data["floquet"]["omega_slow"] == pytest.approx(12.9804, abs=1e-4)
    bad = subprocess.run([exe, "predict", "--A", "0.05"], capture_output=True, text=True,
                         timeout=300)
    assert bad.returncode == 2 and "--omega" in bad.stderr and not bad.stdout
