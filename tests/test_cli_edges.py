"""The command line at its edges (issue 22, items 2, 7 and 8), run in-process through
``kapitza.cli.main``.

* Every error is one line on stderr naming the option, the value and the fix, exit 2 —
  paths that cannot be written (a file where a folder is due, a folder where a file is,
  a file in the middle of a path), argparse's own errors, a ValueError the API raises
  (a grid too large among them), memory exhausted; an unexpected exception is one line
  with the hint to see the traceback, exit 70; the codes are in ``kapitza --help``.
* ``kapitza verify`` exits 1 only where methods that both claim validity disagree; beyond
  the window's upper edge A_max first-order averaging flags itself invalid, and its
  disagreement there is reported, not failed.
* Legal but implausible inputs warn (A/l > 1: centimetres meant? |θ0| > 2π: degrees
  meant?); options a command does not use are refused, naming the option and the
  command; messages show plain numbers; text and JSON write ∞ and NaN as the same
  tokens ("inf", "nan") for every command.
"""
import json
import math
import os
import re
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

import kapitza
from kapitza import KapitzaPendulum, cli
from kapitza.cli import _commands

from helpers import pendulum_scene

SCENES = kapitza.example_scenes()


def run(capsys, *argv):
    """``kapitza argv``: (exit code, stdout, stderr lines that are not empty)."""
    code = cli.main(list(argv))
    out = capsys.readouterr()
    return code, out.out, [line for line in out.err.splitlines() if line.strip()]


def one_line_error(err, *names):
    """The stderr of a refused command: one line, naming each of ``names``, no traceback."""
    assert len(err) == 1, err
    assert "Traceback" not in err[0] and "error" in err[0]
    for name in names:
        assert str(name) in err[0], (name, err[0])
    return err[0]


# -- item 2: every error one line, exit 2 -------------------------------------------------------

@pytest.fixture
def a_file(tmp_path):
    path = tmp_path / "taken"
    path.write_text("a user's file\n")
    return path


@pytest.mark.parametrize("argv, option", [
    (["report", "--quick", "--out", "{file}"], "--out"),
    (["sweep", "{scene}", "--directory", "{file}"], "--directory"),
    (["map", "--A", "0.01,0.05", "--omega", "100", "--out", "{file}/map.png"], "--out"),
    (["map", "--A", "0.01,0.05", "--omega", "100", "--out", "{dir}"], "--out"),
    (["verify", "--A", "0.05", "--f", "40", "--periods", "50", "--data", "{file}/v.csv"],
     "--data"),
    (["animate", "--A", "0.2", "--omega", "40", "--duration", "0.2", "--out",
      "{file}/a.gif"], "--out"),
    (["bifurcation", "--omega", "6.2642", "--values", "0.1,0.2", "--out", "{file}/b.png"],
     "--out"),
])
def test_a_path_that_cannot_be_written_is_one_line_before_any_work(argv, option, a_file,
                                                                   tmp_path, capsys):
    """``kapitza report --out an_existing_file`` raised NotADirectoryError (exit 1, a
    traceback); the others raised, or computed first and then failed."""
    scene = tmp_path / "s.toml"
    scene.write_text(pendulum_scene(analyses="averaging = true", sweep='analyses = ["averaging"]',
                                    axes="A = [0.01, 0.05]"))
    (tmp_path / "folder").mkdir()
    in_the_way = tmp_path / "folder" if "{dir}" in argv else a_file
    argv = [a.format(file=a_file, scene=scene, dir=tmp_path / "folder") for a in argv]
    code, out, err = run(capsys, *argv)
    assert code == 2 and not out
    one_line_error(err, option, in_the_way)
    assert a_file.read_text() == "a user's file\n"              # nothing overwritten


@pytest.mark.skipif(os.name != "posix" or os.geteuid() == 0,
                    reason="root may write anywhere; permissions need a plain user")
def test_a_folder_without_permission_is_named(tmp_path, capsys):
    locked = tmp_path / "locked"
    locked.mkdir(mode=0o500)
    code, _, err = run(capsys, "map", "--A", "0.01,0.05", "--omega", "100", "--out",
                       str(locked / "m.png"))
    assert code == 2
    one_line_error(err, "--out", "permission")


@pytest.mark.parametrize("argv, names", [
    (["predict", "--A"], ["--A", "expected one argument"]),
    (["measure", "--A", "0.05", "--f", "60", "--periods", "1e9"], ["--periods", "1e9"]),
    (["window", "--omega", "100", "--about", "sideways"], ["--about", "sideways"]),
    (["nonsense"], ["nonsense", "invalid choice"]),
])
def test_argparse_errors_are_one_line(argv, names, capsys):
    """argparse printed its whole usage before the error."""
    code, _, err = run(capsys, *argv)
    assert code == 2
    one_line_error(err, *names, "--help")


def test_a_value_error_of_the_api_is_one_line_exit_2(monkeypatch, capsys):
    """Any ValueError the API raises (the up-front "grid too large" refusal is one) is the
    user's input: one line, exit 2, numpy's reprs shown as plain numbers."""
    class GridTooLarge(ValueError):
        pass

    def refuse(self, A, omega, **kw):
        raise GridTooLarge(f"the grid of {np.int64(10**10)} points needs "
                           f"{np.float64(74.5)} GiB, over the limit of 8 GiB; use a smaller "
                           "grid or kapitza sweep.")

    monkeypatch.setattr(KapitzaPendulum, "stability_map", refuse)
    code, _, err = run(capsys, "map", "--A", "0:0.5:3", "--omega", "20:2000:3")
    line = one_line_error(err, "kapitza map", "74.5 GiB", "10000000000 points")
    assert code == 2 and "np." not in line


def test_memory_exhausted_is_one_line_exit_2(monkeypatch, capsys):
    def allocate(self, A, omega, **kw):
        raise MemoryError("Unable to allocate 74.5 GiB for an array with shape "
                          "(100000, 100000) and data type float64")

    monkeypatch.setattr(KapitzaPendulum, "stability_map", allocate)
    code, _, err = run(capsys, "map", "--A", "0:0.5:3", "--omega", "20:2000:3")
    assert code == 2
    one_line_error(err, "out of memory", "74.5 GiB", "kapitza sweep")


def test_an_internal_error_is_one_line_with_the_way_to_the_traceback(monkeypatch, capsys):
    """A bug (any other exception) escaped as a traceback with exit 1, the code of "methods
    disagree"; now one line, exit 70, and the traceback on request."""
    def bug(self, *a, **k):
        raise TypeError("an internal mistake")

    monkeypatch.setattr(KapitzaPendulum, "averaged", bug)
    argv = ["predict", "--A", "0.05", "--omega", "300"]
    code, _, err = run(capsys, *argv)
    assert code == 70
    one_line_error(err, "internal error", "TypeError: an internal mistake", "--traceback",
                   "KAPITZA_DEBUG=1")
    code, _, err = run(capsys, *argv, "--traceback")
    assert code == 70 and err[0].startswith("Traceback") and "an internal mistake" in err[-1]
    monkeypatch.setenv("KAPITZA_DEBUG", "1")
    code, _, err = run(capsys, *argv)
    assert code == 70 and err[0].startswith("Traceback")


def test_help_states_the_exit_codes(capsys):
    assert cli.main(["--help"]) == 0
    text = capsys.readouterr().out
    for code in ("0", "1", "2", "70", "130"):
        assert re.search(rf"^\s*{code}\s+\S", text, re.M), code
    assert "--traceback" in text and '"inf"' in text
    doc = sys.modules["kapitza.cli._parsing"].__doc__
    assert "70 an internal error" in doc and "130 interrupted" in doc


# -- item 7: verify fails only where both methods claim validity ----------------------------------

def test_verify_beyond_the_upper_edge_is_reported_not_failed(capsys):
    """At 40 Hz the exact window closes at A_max = 0.454 m; at A = 0.5 m first-order
    averaging (which has no upper edge) still calls the upright stable, but flags itself
    invalid (A/l > 0.3): exit 0, its disagreements listed as outside its validity."""
    w = 2 * math.pi * 40
    A_max = float(KapitzaPendulum().window(np.array([w])).A_max[0])
    assert A_max < 0.5                          # the exact window, an independent method
    code, out, err = run(capsys, "verify", "--A", "0.01,0.03,0.1,0.5", "--f", "40",
                         "--periods", "200", "--json")
    data = json.loads(out)
    assert code == 0 and data["agree"] is True and not err
    assert data["disagreements_within_validity"] == 0
    rows = data["disagreements"]
    assert rows and all(r["A"] == 0.5 and r["first"] == "averaging" and
                        r["within_validity"] is False for r in rows)
    outside = data["outside_validity_points"]
    assert {(r["method"], r["A"]) for r in outside} >= {("averaging", 0.5)}
    assert data["outside_validity"]["averaging"] == 1
    assert data["outside_validity"]["floquet"] == data["outside_validity"]["simulation"] == 0
    code, out, _ = run(capsys, "verify", "--A", "0.01,0.03,0.1,0.5", "--f", "40",
                       "--periods", "200")
    assert code == 0 and "outside its validity (not failures)" in out
    assert "averaging at 1 point(s)" in out


def test_the_verification_says_where_each_method_claims_validity():
    pend = KapitzaPendulum()
    w = 2 * math.pi * 40
    v = pend.verify(np.array([0.03, 0.5])[:, None], np.array([w])[None, :], periods=200,
                    line=False)
    np.testing.assert_array_equal(v.valid("averaging"), [[True], [False]])
    np.testing.assert_array_equal(
        v.valid("averaging_2"),
        np.asarray(pend.averaged(np.array([0.03, 0.5]), w, order=2,
                                 warn=False).inverted.valid)[:, None])
    np.testing.assert_array_equal(v.valid("floquet"), v.floquet_margin > 1)
    assert len(v.disagreements) == 3 and not v.disagreements.within_validity.any()
    assert v.disagreements_within_validity.empty
    stats = v.agreement.set_index(["first", "second", "quantity"])
    assert stats.loc[("averaging", "floquet", "stability"), "disagreeing"] == 1
    assert stats.loc[("averaging", "floquet", "stability"),
                     "disagreeing_within_validity"] == 0
    with pytest.raises(ValueError, match="no method 'perturbation'"):
        v.valid("perturbation")


# -- item 8: implausible inputs warn, unused options are refused ---------------------------------

@pytest.mark.parametrize("argv, says", [
    (["predict", "--A", "5", "--omega", "300"],
     ["--A 5", "A/l = 5 > 1", "A is in metres", "did you mean 0.05"]),
    (["predict", "--A-over-l", "5", "--omega", "300"], ["--A-over-l 5", "did you mean 0.05"]),
    (["measure", "--A", "0.05", "--f", "60", "--theta0", "179", "--periods", "20"],
     ["--theta0 179", "θ0 is in radians", "did you mean 179° = 3.124 rad?"]),
])
def test_implausible_inputs_run_with_a_warning(argv, says, capsys):
    """``--A 5`` (5 cm meant) and ``--theta0 179`` (degrees) ran silently with exit 0."""
    code, out, err = run(capsys, *argv)
    assert code == 0 and out
    warnings = [line for line in err if "warning" in line]
    assert len(warnings) == 1, err
    for s in says:
        assert s in warnings[0], (s, warnings[0])


def test_plausible_inputs_do_not_warn(capsys):
    code, _, err = run(capsys, "measure", "--A", "0.3", "--f", "60", "--theta0", "3.1",
                       "--periods", "20")
    assert code == 0 and not [line for line in err if "warning" in line]


@pytest.mark.parametrize("argv, names", [
    (["window", "--A", "0.05", "--omega", "100"], ["--A", "kapitza window", "predict"]),
    (["window", "--omega", "100", "--theta0", "3"], ["--theta0", "kapitza window"]),
    (["run", "{scene}", "--l", "2", "--no-write"], ["--l", "kapitza run"]),
    (["lyapunov", "{period_doubling}", "--damping", "0.1"], ["--damping", "scene"]),
    (["animate", "{report}", "--theta0", "3", "--out", "{tmp}/a.gif"], ["--theta0", "scene"]),
])
def test_an_option_the_command_does_not_use_is_refused(argv, names, tmp_path, capsys):
    """``kapitza window --A 0.05`` ignored --A; options beside a scene file that sets them
    were ignored too."""
    argv = [a.format(scene=SCENES["kapitza_pendulum"], report=SCENES["report"], tmp=tmp_path,
                     period_doubling=SCENES["period_doubling"]) for a in argv]
    code, out, err = run(capsys, *argv)
    assert code == 2 and not out
    one_line_error(err, *names)


def test_a_misspelt_option_is_named_with_the_nearest(capsys):
    code, _, err = run(capsys, "predict", "--A", "0.05", "--omgea", "300")
    assert code == 2
    one_line_error(err, "--omgea", "kapitza predict", "did you mean --omega?")


@pytest.mark.parametrize("argv, shown", [
    (["predict", "--A", "-0.05", "--omega", "300"], "got -0.05"),
    (["predict", "--A", "0.05", "--omega", "0"], "got 0.0"),
])
def test_messages_show_plain_numbers(argv, shown, capsys):
    """The API's messages said "got array(-0.05)"."""
    code, _, err = run(capsys, *argv)
    line = one_line_error(err, shown)
    assert code == 2 and "array(" not in line


def test_plain_message_drops_numpy_reprs():
    from kapitza.cli._output import plain_message
    assert plain_message("got array(0.).") == "got 0.0."
    assert plain_message("A = np.float64(0.05), n = np.int64(3)") == "A = 0.05, n = 3"
    assert plain_message("got array([1., 2.])") == "got [1.0, 2.0]"
    assert plain_message("marray(3) stays") == "marray(3) stays"


# -- text and JSON agree: ∞ and NaN are "inf" and "nan" in both ------------------------------------

_NOT_TOKENS = re.compile(r"\b(NaN|Infinity|-Infinity|null|None)\b|array\(|np\.float")


def _strict_json(text):
    def refuse(name):
        raise AssertionError(f"JSON with a non-standard literal {name}")
    return json.loads(text, parse_constant=refuse)


def _non_finite_strings(x, found):
    """Collect the JSON's non-finite numbers (strings "inf", "-inf", "nan") and check no
    float is non-finite (json cannot hold one; allow_nan=False)."""
    if isinstance(x, dict):
        for v in x.values():
            _non_finite_strings(v, found)
    elif isinstance(x, list):
        for v in x:
            _non_finite_strings(v, found)
    elif isinstance(x, str) and x in ("inf", "-inf", "nan"):
        found.add(x)
    return found


def _both(capsys, *argv):
    code, text, _ = run(capsys, *argv)
    code_json, out, _ = run(capsys, *argv, "--json")
    assert code == code_json == 0
    return text, _strict_json(out)


_SWEPT = pendulum_scene(theta=3.0916, analyses='measure = { periods = 20, about = "inverted" }',
                        sweep='analyses = ["measure"]', axes="A = [0.01, 0.05]")


@pytest.fixture
def tiny_commands(tmp_path, monkeypatch):
    """Each command on a tiny case (the catalogue and warmup faked: they are the slow
    ones, and their output, not their work, is compared)."""
    monkeypatch.chdir(tmp_path)
    (tmp_path / "swept.toml").write_text(_SWEPT)
    monkeypatch.setattr(_commands, "catalogue_summary", lambda rtol, progress=None: pd.DataFrame(
        [{"problem": "pendulum", "dof": 1, "energy_drift_J": 1e-9, "status": "success"},
         {"problem": "driven", "dof": 1, "energy_drift_J": math.nan, "status": "success"}]))
    monkeypatch.setattr(sys.modules["kapitza.warmup"], "warmup", lambda verbose=False: 1.5)
    return {
        "predict": ["predict", "--A", "0.05", "--f", "60"],
        "window": ["window", "--f", "10,60"],
        "map": ["map", "--A", "0:0.5:4", "--omega", "50,400", "--out", "m.png"],
        "measure": ["measure", "--A", "0.05", "--f", "60", "--periods", "30"],
        "verify": ["verify", "--A", "0.03,0.5", "--f", "40", "--periods", "50"],
        "lyapunov": ["lyapunov", "--A", "0.55", "--omega", "6.2642", "--damping", "0.47",
                     "--periods", "16", "--transient", "0"],
        "run": ["run", str(SCENES["kapitza_pendulum"]), "--no-write"],
        "sweep": ["sweep", "swept.toml", "--directory", "out"],
        "warmup": ["warmup"],
        "summary": ["summary"],
    }


def test_text_and_json_write_non_finite_numbers_alike(tiny_commands, capsys):
    """JSON wrote null where the text printed inf or nan; now both print the tokens
    "inf", "-inf", "nan", and neither shows NaN, null, None or numpy's reprs."""
    for name, argv in tiny_commands.items():
        text, data = _both(capsys, *argv)
        assert not _NOT_TOKENS.search(text), (name, _NOT_TOKENS.search(text))
        for token in _non_finite_strings(data, set()):
            assert re.search(rf"(?<![\w.-]){re.escape(token)}\b", text) or name in (
                "map", "sweep", "lyapunov", "warmup"), (name, token)


def test_window_table_equals_its_json(capsys):
    """The window's text table and JSON rows, cell by cell: first-order averaging has no
    upper edge, "inf" in both (JSON said null)."""
    text, data = _both(capsys, "window", "--f", "10,60")
    table = pd.read_csv(pd.io.common.StringIO(text.split("\n", 1)[1]), sep=r"\s+")
    assert list(table.columns) == list(data["rows"][0])
    for row, (_, cells) in zip(data["rows"], table.iterrows(), strict=True):
        for key, value in row.items():
            if isinstance(value, bool):
                assert str(cells[key]) == str(value)
            else:
                assert float(cells[key]) == pytest.approx(float(value), rel=1e-5), key
    assert {r["A_max_averaging"] for r in data["rows"]} == {"inf"}


def test_measure_text_equals_its_json(capsys):
    """The fall time of a run that stays up is NaN: "nan" in the text and in the JSON."""
    text, data = _both(capsys, "measure", "--A", "0.05", "--f", "60", "--periods", "30")
    m = data["measurement"]
    assert m["fall_time"] == "nan" and "fall time nan s" in text
    assert f"stayed up {m['stayed_up']}" in text
    assert f"mean angle {float(m['mean_angle']):.6g} rad" in text


# -- sweep --wait, a sweep too large to load, map's own memory, map's write errors ---------------

def _swept_dataset(tmp_path, capsys):
    """The tiny measure sweep of ``_SWEPT`` run once: (its scene file, its dataset)."""
    scene = tmp_path / "swept.toml"
    scene.write_text(_SWEPT)
    code, out, _ = run(capsys, "sweep", str(scene), "--directory", str(tmp_path / "out"),
                       "--json")
    assert code == 0
    return scene, Path(json.loads(out)["path"])


def test_sweep_wait_waits_for_the_lock_then_refuses_or_runs(tmp_path, capsys):
    """``--wait [SECONDS]`` reaches Scene.sweep(wait=): with another sweep's lock in place
    (this live process's pid), --wait 0.4 waits that long and refuses in one line naming
    the lock; --wait alone runs once the lock goes.  (It was not an option.)"""
    import socket
    import threading
    import time

    scene, path = _swept_dataset(tmp_path, capsys)
    lock = path / "_sweep.lock"
    lock.write_text(json.dumps({"pid": os.getpid(), "host": socket.gethostname(),
                                "started": "2026-01-01T00:00:00"}))
    argv = ["sweep", str(scene), "--directory", str(tmp_path / "out")]
    t0 = time.monotonic()
    code, _, err = run(capsys, *argv, "--wait", "0.4")
    assert code == 2 and time.monotonic() - t0 >= 0.4
    one_line_error(err, "_sweep.lock", f"pid {os.getpid()}", "--wait")
    code, _, err = run(capsys, *argv, "--wait", "-1")
    assert code == 2
    one_line_error(err, "--wait", "-1")
    threading.Timer(0.5, lock.unlink).start()
    t0 = time.monotonic()
    code, _, _ = run(capsys, *argv, "--wait")
    assert code == 0 and time.monotonic() - t0 >= 0.4


def test_sweep_names_the_columns_of_a_dataset_too_large_to_load(tmp_path, capsys,
                                                                monkeypatch):
    """A memory limit below the rows' size: SweepResult.frame is None and the command
    read the column names with to_dataframe(), which raised (exit 2); the names come from
    the Parquet schema now."""
    scene, _ = _swept_dataset(tmp_path, capsys)
    monkeypatch.setenv("KAPITZA_MEMORY_LIMIT_GIB", "1e-9")         # ~1 byte
    code, out, _ = run(capsys, "sweep", str(scene), "--directory", str(tmp_path / "out"),
                       "--json")
    assert code == 0
    columns = json.loads(out)["columns"]
    assert columns[:2] == ["point", "A"] and "stayed_up" in columns


def test_map_refuses_outputs_that_would_not_fit_before_any_work(tmp_path, capsys,
                                                                 monkeypatch):
    """The table, data file and figure of a map are checked against the memory limit on
    top of the API's own check: refused in one line naming the grid, nothing written."""
    called = []
    monkeypatch.setattr(KapitzaPendulum, "stability_map", lambda *a, **k: called.append(1))
    monkeypatch.setattr(_commands, "MAP_OUTPUT_BYTES_PER_POINT", 1e12)
    png = tmp_path / "m.png"
    code, _, err = run(capsys, "map", "--A", "0:0.5:4", "--omega", "50,400", "--out", str(png))
    assert code == 2 and not called and not png.exists()
    one_line_error(err, "--A × --omega", "4 × 2", "kapitza sweep")


@pytest.mark.parametrize("data", [None, "m.parquet"])
def test_an_os_error_writing_the_map_is_one_line_exit_2(data, tmp_path, capsys, monkeypatch):
    """A full disk while the map's table is written: one line naming the file, exit 2, and
    no file (or temporary file) left half-written."""
    import errno

    def full(*args, **kwargs):
        raise OSError(errno.ENOSPC, "No space left on device")
    monkeypatch.setattr(pd.DataFrame, "to_csv", full)
    monkeypatch.setattr(pd.DataFrame, "to_parquet", full)
    argv = ["map", "--A", "0:0.5:4", "--omega", "50,400", "--out", str(tmp_path / "m.png")]
    if data:
        argv += ["--data", str(tmp_path / data)]
    code, _, err = run(capsys, *argv)
    assert code == 2
    one_line_error(err, tmp_path / (data or "m.csv"), "no space left")
    assert not [p for p in tmp_path.iterdir() if p.suffix in (".csv", ".parquet", ".tmp")]
