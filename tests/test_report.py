"""kapitza report (issue 14.2): the folder it writes, checked against independent calls.

The quick reports of the default scene and of period_doubling.toml are built once per
process (tests/report_builds.py, shared with tests/test_report_browser.py; so is that of
horizontal_drive.toml, built by the command ``kapitza report ... --json``); their tables
are checked against references computed here: the exact window against the map's own
labels and the closed form of first-order averaging, the spot checks' Floquet verdicts
and the slow frequencies against monodromies integrated by scipy (tests/helpers.py).
"""
import html
import json
import math
import re
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from report_builds import quick_report

import kapitza
from kapitza import KapitzaPendulum
from kapitza.cli import main
from kapitza.report import SECTIONS, build_report

from helpers import G, L, pendulum_monodromy

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def quick(tmp_path_factory):
    """The default scene's quick report and its progress lines (tests/report_builds.py: one
    build per process, shared with tests/test_report_browser.py)."""
    built = quick_report("report", tmp_path_factory)
    return built.report, built.progress


def _links(page: str):
    return re.findall(r"""(?:src|href)=['"]([^'"]+)['"]""", page)


#: Sections shown only when the scene asks for them (the default scene does not).
ASKED_FOR = {"bifurcations"}


def test_every_section_written_with_its_files(quick):
    report, lines = quick
    assert [s.name for s in report.sections] == list(SECTIONS)
    assert {s.name: s.status for s in report.sections} == {
        n: "skipped" if n in ASKED_FOR else "done" for n in SECTIONS}
    for s in report.sections:
        if s.name in ASKED_FOR:
            continue
        assert (report.out / s.figure).stat().st_size > 10_000, s.name
        assert s.caption and np.isfinite(s.seconds)
        for t in s.tables:
            parquet, csv = report.tables[t]
            assert pd.read_parquet(parquet).equals(pd.read_parquet(parquet))
            assert len(pd.read_csv(csv)) == len(pd.read_parquet(parquet)) > 0
    assert report.section("animation").figure.suffix == ".gif"
    # progress: one line when each section starts and one when it ends, with times
    ends = [x for x in lines if re.search(r"\[\d/8\] .*: (done|skipped).* s \(elapsed", x)]
    assert len(ends) == len(SECTIONS)
    frame = report.to_dataframe()
    assert list(frame.section) == list(SECTIONS) and frame.seconds.gt(0).all()


def test_frontier_section_skipped_unless_the_scene_asks(quick):
    """The default scene asks for no continuation, diagram or Lyapunov exponents: the
    section says so on the page, and costs nothing."""
    report, _ = quick
    s = report.section("bifurcations")
    assert s.status == "skipped" and s.seconds < 0.5
    assert "continuation, bifurcation_diagram or lyapunov" in s.reason
    assert html.escape(s.reason) in report.index.read_text(encoding="utf-8")


def test_frontier_section_of_the_period_doubling_scene(tmp_path_factory):
    """The section for kapitza/scenes/period_doubling.toml (quick): the branches, the
    diagram and the exponents drawn; its numbers against independent references (the
    damped Mathieu window of the hanging state; the phase-space contraction −γ).  Read off
    the scene's quick report (tests/report_builds.py), which tests/test_report_browser.py
    builds in the same process: the section ran there as in any report (running it here on
    its own computed the same section a second time)."""
    report = quick_report("period_doubling", tmp_path_factory).report
    scene = kapitza.Scene.example("period_doubling")
    result = report.section("bifurcations")
    assert result.status == "done", result.reason
    assert (report.out / result.figure).stat().st_size > 50_000
    assert list(result.tables) == ["continuation", "continuation_bifurcations",
                                   "bifurcation_diagram", "lyapunov", "lyapunov_along_A"]
    for name in result.tables:
        parquet, csv = report.tables[name]
        frame = pd.read_parquet(parquet)
        assert len(frame) == len(pd.read_csv(csv)) > 0 and "method" in frame
    bifs = pd.read_parquet(report.tables["continuation_bifurcations"][0])
    assert bifs.kind.tolist() == ["period_doubling", "pitchfork"]
    win = kapitza.pendulum_window(scene.params["omega"], l=1.0, g=9.81,
                                  damping=scene.params["gamma"], about="hanging")
    assert bifs.A[0] == pytest.approx(float(win.A_max), rel=1e-9)
    lam = pd.read_parquet(report.tables["lyapunov"][0])
    assert lam.exponent.sum() == pytest.approx(-scene.params["gamma"], abs=1e-8)
    assert "chaotic: λ1 > 0" in result.caption and "agrees at" in result.caption
    along = pd.read_parquet(report.tables["lyapunov_along_A"][0])
    assert along.chaotic.any() and not along.chaotic[along.A < 0.4].any()


def test_page_is_self_contained_and_links_only_written_files(quick):
    report, _ = quick
    page = report.index.read_text(encoding="utf-8")
    links = _links(page)
    local = [x for x in links if not x.startswith("#")]
    assert local, "no figure or data link on the page"
    for x in local:
        assert "://" not in x and not x.startswith("/"), x
        assert (report.out / x).is_file(), x
    for name in report.tables:
        assert f"data/{name}.parquet" in local and f"data/{name}.csv" in local
    for path in report.figures.values():
        assert path.relative_to(report.out).as_posix() in local
    assert "<script" not in page.lower()
    for name, title in SECTIONS.items():
        assert f"id={name}>" in page and title in page
    assert "Incomplete" not in page and "Still running" not in page


def test_map_window_and_averaging_tables_agree_with_independent_values(quick):
    report, _ = quick
    win = pd.read_parquet(report.tables["window"][0])
    pend = KapitzaPendulum(l=L, g=G)
    # first-order averaging: A ω = √(2 g l) (closed form)
    assert np.allclose(win.A_min_averaging_1 * win.omega, math.sqrt(2 * G * L), rtol=1e-12)
    # the exact edges, an independent call at a few frequencies
    some = win.iloc[::17]
    again = pend.window(some.omega.to_numpy())
    assert np.allclose(some.A_min_exact, again.A_min, rtol=1e-9)
    assert np.allclose(some.A_max_exact, again.A_max, rtol=1e-9)
    # the map's labels against the window: stable inside, unstable outside (2 % margin)
    grid = pd.read_parquet(report.tables["stability_map"][0])
    lo = np.interp(np.log(grid.omega), np.log(win.omega), win.A_min_exact)
    hi = np.interp(np.log(grid.omega), np.log(win.omega), win.A_max_exact)
    inside = (grid.A > 1.02 * lo) & (grid.A < 0.98 * hi)
    outside = (grid.A < 0.98 * lo) | ((grid.A > 1.02 * hi) & (grid.A < 1.2 * hi))
    assert inside.sum() > 100 and outside.sum() > 100
    assert grid.stable[inside].all() and not grid.stable[outside].any()
    # the edges meet the independent reference: |tr M| = 2 just at A_min (scipy monodromy)
    w = float(win.omega.iloc[len(win) // 2])
    a_min = float(win.A_min_exact.iloc[len(win) // 2])
    traces = [abs(np.trace(pendulum_monodromy(a, w, -1))) for a in (0.999 * a_min,
                                                                       1.001 * a_min)]
    assert traces[0] > 2 > traces[1]


def test_spot_checks_agree_with_scipy_floquet_away_from_boundaries(quick):
    report, _ = quick
    spots = pd.read_parquet(report.tables["spot_checks"][0])
    assert len(spots) >= 5 and spots.stayed_up.any() and (~spots.stayed_up).any()
    for row in spots.itertuples():
        stable = abs(np.trace(pendulum_monodromy(row.A, row.omega, -1))) < 2
        assert stable == row.stable_floquet, row
        if row.boundary_distance > 0.2:              # far from an edge: the run decides
            assert row.stayed_up == stable, row
    # the scene's own drive is one of them, and it holds the pendulum up
    own = spots[np.isclose(spots.A, 0.2) & np.isclose(spots.omega, 40.0)]
    assert len(own) == 1 and bool(own.stayed_up.iloc[0])


def test_slow_frequencies_agree_with_scipy_floquet(quick):
    report, _ = quick
    slow = pd.read_parquet(report.tables["slow_frequency"][0])
    assert len(slow) >= 4 and slow.stable_floquet.all()
    for row in slow.itertuples():
        tr = np.trace(pendulum_monodromy(row.A, row.omega, -1))
        exact = row.omega / 2 * math.acos(tr / 2) / math.pi      # cos(πβ) = tr/2, Ω = βω/2
        assert row.omega_slow_floquet == pytest.approx(exact, rel=1e-7)
        assert row.omega_slow_simulation == pytest.approx(exact, rel=1e-3)
        # first-order averaging: Ω² = (A ω)²/(2 l²) − g/l
        assert row.omega_slow_averaging == pytest.approx(
            math.sqrt((row.A * row.omega) ** 2 / (2 * L**2) - G / L), rel=1e-12)
    caption = report.section("slow").caption
    assert "first-order averaging" in caption and "next order" in caption


def test_verification_numbers(quick):
    report, _ = quick
    n = report.numbers
    assert n["verification_points"] == 9
    assert n["floquet_simulation_agreeing"] == n["floquet_simulation_compared"] == 9
    agreement = pd.read_csv(report.tables["verification_agreement"][1])
    assert set(agreement.quantity) == {"stability", "omega_slow"}
    dis = pd.read_parquet(report.tables["verification_disagreements"][0])
    assert len(dis) == n["verification_disagreements"]
    assert str(len(dis)) in report.section("verification").caption


def test_cli_horizontal_scene_json(tmp_path_factory):
    """``kapitza report kapitza/scenes/horizontal_drive.toml --out DIR --quick --json``: exit
    0 and the JSON of the report.  The command is run, in process, as the scene's quick
    build (tests/report_builds.py), which tests/test_report_browser.py opens: the command
    and build_report built the same quick report twice."""
    built = quick_report("horizontal_drive", tmp_path_factory)
    assert built.cli is not None, "tests/report_builds.py built the scene without the command"
    rc, stdout = built.cli
    out = json.loads(stdout)
    assert rc == 0
    assert out["out"] == str(built.report.out) and out["quick"] is True
    status = {s["section"]: s["status"] for s in out["sections"]}
    assert status["potential"] == status["spots"] == status["slow"] == "done"
    assert status["map"] == status["verification"] == status["animation"] == "skipped"
    tilt = pd.read_csv(out["tables"]["tilt_checks"][1])
    # cos θ* = 2 g l/(A ω)² (averaging) and the periodic orbit's mean within 0.02 rad
    assert np.allclose(np.cos(tilt.theta_averaging), 2 * G * L / (tilt.A * tilt.omega) ** 2)
    assert np.allclose(tilt.theta_orbit_mean, tilt.theta_averaging, atol=0.02)


def test_bad_scene_exit_2_with_message(tmp_path, capsys):
    bad = tmp_path / "bad.toml"
    bad.write_text('schema = 1\n[system]\nname = "pendulum"\n[parameters]\nl = 1.0\n'
                   '[effects]\ngravity = true\n[effects.drive]\namplitud = 0.1\nomega = 50.0\n')
    assert main(["report", str(bad), "--out", str(tmp_path / "r")]) == 2
    err = capsys.readouterr().err
    assert "kapitza report: error" in err and "amplitud" in err and "amplitude" in err
    assert not (tmp_path / "r").exists()
    assert main(["report", str(tmp_path / "missing.toml")]) == 2
    assert "no scene file" in capsys.readouterr().err


def test_undriven_scene_is_refused(tmp_path):
    text = ('schema = 1\n[system]\nname = "pendulum"\n[parameters]\nl = 1.0\n'
            '[effects]\ngravity = true\n[initial]\ntheta = 0.1\n')
    path = tmp_path / "free.toml"
    path.write_text(text)
    with pytest.raises(ValueError, match="driven system.*effects.drive"):
        build_report(path, tmp_path / "r", quick=True, progress=False)


# One child process for the three Ctrl-C tests (each started Python and imported kapitza,
# ~1 CPU-s, in a process of its own): it builds the report three times in turn, and the
# parent interrupts each build DELAYS[name] s after it prints "ready".  "finished": the
# default scene as a user runs it, "ready" once the first section is written;
# "swallowed" and "weakref": the "potential" section replaced by a function that loses the
# Ctrl-C (the sections then never start).  Each build has its stderr kept to be read
# (what the user's terminal would show).  Between builds the child waits for the
# report's repeat thread (it raises the Ctrl-C again every REPEAT_AFTER s while a section
# runs; named "Thread-N (_repeat)") to end, so that no repeat of one build can reach the
# next.
_CTRL_C_CHILD = """
import io, json, sys, threading, time, weakref
sys.path.insert(0, {root!r})
from kapitza.report import ReportInterrupted, build_report
from kapitza.report import _sections


def first_written(message):     # "ready" once the first section is written
    if message.startswith("[1/8]") and ": done" in message:
        print("ready", flush=True)


def swallowing(job):        # the Ctrl-C lost inside the section (as in a weakref callback)
    print("ready", flush=True)
    try:
        time.sleep(30)
    except KeyboardInterrupt:
        pass
    time.sleep(30)          # then a long computation that would see the next one
    raise AssertionError("never stopped")


class Thing:
    pass


calls = []


def callback(ref):          # the Ctrl-C arrives while this weakref callback runs
    calls.append(1)
    if len(calls) == 1:
        time.sleep(1.0)


def in_callback(job):
    print("ready", flush=True)
    deadline = time.time() + 30
    while time.time() < deadline:
        thing = Thing()
        ref = weakref.ref(thing, callback)
        del thing           # runs the callback
        time.sleep(0.01)
    raise AssertionError("never stopped")


potential = _sections.BUILDERS["potential"]
for name, builder in (("finished", potential), ("swallowed", swallowing),
                      ("weakref", in_callback)):
    _sections.BUILDERS["potential"] = builder
    err = sys.stderr = io.StringIO()
    try:
        build_report(out={out!r} + "/" + name, quick=True,
                     progress=first_written if builder is potential else False)
        print(json.dumps({{"finished": True}}), flush=True)
    except ReportInterrupted as stop:
        r = stop.report
        print(json.dumps({{"stopped": time.time(), "missing": list(r.missing),
                          "done": [s.name for s in r.sections if s.status == "done"],
                          "page": r.index.read_text(), "stderr": err.getvalue()}}),
              flush=True)
    finally:
        sys.stderr = sys.__stderr__
    for thread in threading.enumerate():       # the repeat thread (not lagrange_core's)
        if thread.name.endswith("(_repeat)") and name != "weakref":
            thread.join(timeout=5)
"""
#: s from a build's "ready" to its Ctrl-C
DELAYS = {"finished": 0.5, "swallowed": 0.3, "weakref": 0.3}


@pytest.fixture(scope="module")
def interrupted(tmp_path_factory, quick):
    """``{name: (the child's JSON report, the time its Ctrl-C was sent)}`` for the builds of
    :data:`_CTRL_C_CHILD`, and the folder they wrote to (after the in-process quick build:
    the kernels are in the disk cache before the child loads them)."""
    import os
    import signal
    import subprocess
    import sys
    import time

    from helpers import sigint_default
    tmp = tmp_path_factory.mktemp("ctrl-c")
    script = tmp / "child.py"
    script.write_text(_CTRL_C_CHILD.format(root=str(ROOT), out=str(tmp)))
    proc = subprocess.Popen([sys.executable, str(script)], stdout=subprocess.PIPE, text=True,
                            preexec_fn=sigint_default)
    results = {}
    try:
        for name, delay in DELAYS.items():
            line = proc.stdout.readline()
            if line.strip() != "ready":
                break           # the tests of this build and the later ones say so
            time.sleep(delay)
            sent = time.time()
            os.kill(proc.pid, signal.SIGINT)
            results[name] = (json.loads(proc.stdout.readline()), sent)
        proc.wait(timeout=60)
    finally:
        if proc.poll() is None:
            proc.kill()
    return results, tmp


def _interrupted(interrupted, name):
    results, tmp = interrupted
    assert name in results, (f"the child ended before its {name!r} build was interrupted "
                             f"(it ran {list(results)})")
    res, sent = results[name]
    return res, sent, tmp / name


def test_ctrl_c_keeps_the_finished_sections(interrupted):
    res, sent, out = _interrupted(interrupted, "finished")
    assert "finished" not in res, "the report finished before the interrupt"
    assert res["stopped"] - sent < 1.5
    assert res["missing"] and res["done"]
    assert "Incomplete" in res["page"]
    for name in res["missing"]:
        assert SECTIONS[name] in res["page"].split("Incomplete")[1].split("</p>")[0]
    for x in _links(res["page"]):
        assert x.startswith("#") or (out / x).is_file()


def test_a_ctrl_c_lost_inside_a_section_is_raised_again(interrupted):
    """A KeyboardInterrupt can vanish (Python only reports one raised in a weakref callback
    or ``__del__``; a computation may catch it and go on): the report raises it again
    into the section until it stops — here a section that swallows the first one stops
    within REPEAT_AFTER (1 s) of the Ctrl-C, plus the child's own latency (without the
    repeat: when its 60 s were up)."""
    res, sent, _ = _interrupted(interrupted, "swallowed")
    assert "finished" not in res
    assert res["stopped"] - sent < 2.0
    assert "potential" in res["missing"]


def test_a_ctrl_c_lost_in_a_weakref_callback_shows_no_traceback(interrupted):
    """A Ctrl-C that lands in a weakref callback is dropped by Python, which prints
    "Exception ignored in: <function ...>" and a traceback on stderr (seen in the CLI's
    property test): the report keeps that off the terminal and raises the Ctrl-C again,
    so the section stops within REPEAT_AFTER (1 s) plus the child's latency."""
    res, sent, _ = _interrupted(interrupted, "weakref")
    assert "finished" not in res
    assert res["stopped"] - sent < 2.0
    assert "potential" in res["missing"]
    assert "Traceback" not in res["stderr"] and "Exception ignored" not in res["stderr"], \
        res["stderr"]


def test_a_section_waits_for_the_background_compile_of_its_kernels(monkeypatch):
    """On an empty cache the report's sections wait for the background process compiling
    their kernels (kapitza.warmup.wait_for) instead of compiling them a second time beside
    it: the wait lasts until the process ends, is immediate for a group that has none, and
    every section that runs compiled kernels names an existing group."""
    import importlib
    import subprocess
    import sys
    import time

    from kapitza.report._sections import COMPILED_IN
    from lagrange_core import _background
    warm = importlib.import_module("kapitza.warmup")    # (kapitza.warmup is the function)
    assert set(COMPILED_IN) <= set(SECTIONS)
    assert {g for groups in COMPILED_IN.values() for g in groups} <= set(warm.GROUPS)
    proc = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(1.0)"])
    monkeypatch.setitem(_background.RUNNING, "report integrators", proc)
    assert warm.wait_for(("grids (dop853)",)) < 0.05            # none running
    start = time.perf_counter()
    waited = warm.wait_for(COMPILED_IN["work_precision"])
    assert proc.poll() is not None and 0.5 < waited <= time.perf_counter() - start + 1e-9
