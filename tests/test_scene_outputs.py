"""What is computed and written, and when it is refused (issue 22, items 1, 5 and 11).

* A grid that cannot fit in memory is refused before any work — by every grid function
  and by a scene — naming the argument, the estimate and the limit (GiB) and the fix;
  the command line says it in one line and exits 2.
* A scene run writes all or nothing (a failed write leaves the previous output as it
  was), its manifest last; axes are stored compactly, not in every table's metadata.
* ``run`` computes ``[analyses]`` at the scene's point and never the ``[sweep]``;
  ``--no-write`` writes nothing.
* Every table that ``run`` and the report write, and every sweep, says what it is: the
  scene (name, SHA-256 of its text), parameters with units, method, tolerances,
  integrator, versions — in Parquet metadata, and in a JSON sidecar for CSV.
"""
import hashlib
import json
import math
import time

import numpy as np
import pandas as pd
import pyarrow.parquet as pq
import pytest

import kapitza
from kapitza import Scene, cli
from lagrange_core import problems

from helpers import pendulum_scene

#: A memory limit of 1 MiB (the environment's override, in GiB): grids of a few thousand
#: points are "too large", so the refusals are tested in milliseconds.
TINY = "0.0009765625"


@pytest.fixture
def tiny_memory(monkeypatch):
    monkeypatch.setenv("KAPITZA_MEMORY_LIMIT_GIB", TINY)


def _refused(call, argument):
    """``call()`` raises kapitza's GridTooLargeError, naming ``argument``, the estimate and
    the limit in GiB, and the way out."""
    with pytest.raises(ValueError, match="GiB") as info:
        call()
    e = info.value
    assert type(e).__name__ == "GridTooLargeError"
    text = str(e)
    assert argument in text and "limit of 0.000977 GiB" in text, text
    assert "KAPITZA_MEMORY_LIMIT_GIB" in text and "kapitza sweep" in text, text
    assert e.needed > e.limit == 2**20
    return text


def _no_work(monkeypatch):
    """Make every grid function's work fail if it starts: a refusal must come first."""
    from kapitza.averaging import _average
    from kapitza.closed_forms import _mathieu
    from kapitza.floquet import _maps
    from lagrange_core.systems import System

    def started(*args, **kwargs):
        raise AssertionError("the work started before the grid was checked")

    for module, name in ((_maps, "floquet_grid"), (_maps, "orbit_request"),
                         (_maps, "probe_for"), (_mathieu, "mathieu_parameters"),
                         (_average, "run_in_chunks")):
        monkeypatch.setattr(module, name, started)
    monkeypatch.setattr(System, "simulate_grid", started)


# -- 1. grids that cannot fit ------------------------------------------------------------------

def test_every_grid_function_refuses_a_grid_that_cannot_fit_before_any_work(tiny_memory,
                                                                            monkeypatch):
    pendulum = problems.driven_pendulum("vertical")
    _no_work(monkeypatch)
    P = dict(m=1.0, l=1.0, g=9.81)
    A, w = np.linspace(0.0, 0.5, 400), np.linspace(50.0, 200.0, 400)
    # 1600 monodromies × ~800 bytes; 160 000 points × 48; 10⁶ points × 4; 10⁵ × 32;
    # 200 runs × 1001 strobe samples (×7 copies)
    _refused(lambda: kapitza.stability_map(pendulum, P, [math.pi], A=A[:40], omega=w[:40]),
             "stability_map: the grid A × omega of 40 × 40")
    _refused(lambda: kapitza.adaptive_map(pendulum, P, [math.pi], A=A, omega=w),
             "adaptive_map: the grid A × omega of 400 × 400")
    _refused(lambda: kapitza.closed_forms.pendulum_stability_map(
        np.linspace(0, 0.5, 1000), np.linspace(20, 2000, 1000)), "A × omega of 1000 × 1000")
    _refused(lambda: kapitza.average(pendulum).sweep(
        dict(P, A=np.linspace(0.1, 0.5, 100_000), omega=100.0), [math.pi], progress=False),
        "AveragedSystem.sweep: the grid params (broadcast) of 100000")
    _refused(lambda: kapitza.measure_grid(
        pendulum, dict(P, A=np.linspace(0.1, 0.2, 200), omega=100.0), [math.pi],
        [math.pi - 0.01], periods=1000, progress=False), "measure_grid: the grid params")
    # what fits is computed as before
    monkeypatch.undo()
    monkeypatch.setenv("KAPITZA_MEMORY_LIMIT_GIB", TINY)
    assert kapitza.closed_forms.pendulum_stability_map([0.1], [60.0]).stable.shape == (1, 1)


def test_the_limit_is_half_the_memory_unless_the_environment_says(monkeypatch):
    from kapitza import _arguments as arguments
    monkeypatch.delenv("KAPITZA_MEMORY_LIMIT_GIB", raising=False)
    limit, what = arguments.memory_limit()
    import os
    total = os.sysconf("SC_PHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
    assert 0 < limit <= 0.5 * total and "50% of this machine's" in what
    monkeypatch.setenv("KAPITZA_MEMORY_LIMIT_GIB", "2")
    assert arguments.memory_limit() == (2 * 2**30, "KAPITZA_MEMORY_LIMIT_GIB=2")
    monkeypatch.setenv("KAPITZA_MEMORY_LIMIT_GIB", "lots")
    with pytest.raises(ValueError, match="KAPITZA_MEMORY_LIMIT_GIB must be a number"):
        arguments.memory_limit()


def test_the_issue_map_exits_2_at_once_in_one_line(monkeypatch, capsys, tmp_path):
    """The issue's `kapitza map` of 10⁵ × 10⁵ points ran 38 s and died with a NumPy
    traceback; with 8 GiB allowed it is refused in one line, exit 2, before any work."""
    monkeypatch.setenv("KAPITZA_MEMORY_LIMIT_GIB", "8")
    monkeypatch.chdir(tmp_path)
    t0 = time.perf_counter()
    code = cli.main(["map", "--A", "0:0.5:100000", "--omega", "20:2000:100000"])
    seconds = time.perf_counter() - t0
    err = capsys.readouterr().err
    assert code == 2 and seconds < 30, (code, seconds, err)     # it ran 38 s before
    assert err.count("\n") == 1 and "Traceback" not in err
    # the CLI's own check comes first: the map's table, data file and figure (220 bytes a
    # point) outweigh the map's arrays (37.3 GiB here, refused by the API if asked directly)
    assert "--A × --omega of 100000 × 100000" in err and "limit of 8 GiB" in err
    assert "2,049 GiB (220 bytes per point)" in err
    assert list(tmp_path.iterdir()) == []


def test_a_smaller_grid_too_large_for_the_limit_exits_2(tiny_memory, capsys, tmp_path,
                                                        monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert cli.main(["map", "--A", "0:0.5:1000", "--omega", "20:2000:1000"]) == 2
    err = capsys.readouterr().err
    assert "--A × --omega of 1000 × 1000" in err and err.count("\n") == 1
    assert list(tmp_path.iterdir()) == []


_MAP_SCENE = pendulum_scene(analyses="averaging = true\nfloquet = true\nstability_map = { "
                            "A = { start = 0.0, stop = 0.5, num = NUM }, omega = { start = 20.0, "
                            'stop = 2000.0, num = NUM }, about = "inverted" }').split(
    "[sweep]")[0] + '[output]\ndirectory = "out"\nformats = ["parquet", "csv"]\n'


def test_a_scene_refuses_its_huge_map_before_any_analysis(tiny_memory, tmp_path, monkeypatch):
    path = tmp_path / "map.toml"
    path.write_text(_MAP_SCENE.replace("NUM", "300"))
    calls = []
    from kapitza.scenes import _analyses
    for name in ("averaging", "floquet"):          # nothing may run before the refusal
        monkeypatch.setitem(_analyses.POINT, name, lambda *a, n=name: calls.append(n))
    text = _refused(Scene.from_toml(path).run, "[analyses] stability_map: A × omega")
    assert "300 × 300" in text and "analyses.stability_map" in text and not calls
    assert not (tmp_path / "out").exists()


def test_a_run_writes_all_or_nothing(tmp_path, monkeypatch):
    """A full disk at the second table: the previous complete output is untouched (no
    table of the new run among the old ones), nothing half-written or temporary is left;
    the manifest of a finished run lists every file with its checksum."""
    text = _MAP_SCENE.replace("NUM", "12")
    path = tmp_path / "map.toml"
    path.write_text(text)
    first = Scene.from_toml(path).run(progress=False)
    out = tmp_path / "out"
    before = {p.name: p.read_bytes() for p in out.iterdir()}

    import pyarrow.parquet
    real = pyarrow.parquet.write_table
    written = []

    def full_disk(table, where, *args, **kwargs):
        written.append(where)
        if len(written) == 2:           # half a file, then no space
            with open(where, "wb") as f:
                f.write(b"PAR1" + b"\0" * 100)
            raise OSError(28, "No space left on device")
        return real(table, where, *args, **kwargs)

    monkeypatch.setattr(pyarrow.parquet, "write_table", full_disk)
    path.write_text(text.replace("amplitude = 0.05", "amplitude = 0.07"))   # another run
    with pytest.raises(OSError, match="No space left"):
        Scene.from_toml(path).run(progress=False)
    assert len(written) == 2
    after = {p.name: p.read_bytes() for p in out.iterdir()}
    assert after == before, "the previous output was changed"
    manifest = json.loads((out / "_run.json").read_text())
    assert set(manifest["tables"]) == {"averaging", "floquet", "stability_map"}
    for entry in manifest["tables"].values():
        for name, digest in entry["files"].items():
            assert hashlib.sha256(before[name]).hexdigest() == digest
    assert [p.name for p in first.written][-1] == "_run.json"
    monkeypatch.setattr(pyarrow.parquet, "write_table", real)
    again = Scene.from_toml(path).run(progress=False)
    meta = json.loads(pq.read_schema(out / "floquet.parquet").metadata[b"kapitza"])
    assert meta["parameters"]["A"] == 0.07 and not list(out.glob(".*"))
    assert len(again.written) == len(first.written)


def test_axes_are_not_embedded_in_table_metadata(tmp_path):
    """A 20 000-point axis: each table's metadata stays small (the axis as its range, and
    only the table's own analysis's settings)."""
    text = (_MAP_SCENE.replace("NUM", "2").replace("num = 2 }, omega", "num = 20000 }, omega")
            .replace("averaging = true\n", ""))
    path = tmp_path / "map.toml"
    path.write_text(text)
    Scene.from_toml(path).run(progress=False)
    for name in ("floquet", "stability_map"):
        raw = pq.read_schema(tmp_path / "out" / f"{name}.parquet").metadata[b"kapitza"]
        assert len(raw) < 20_000, (name, len(raw))
    meta = json.loads(pq.read_schema(tmp_path / "out" / "stability_map.parquet")
                      .metadata[b"kapitza"])
    assert meta["settings"]["A"] == {"name": "A", "kind": "linear", "start": 0.0, "stop": 0.5,
                                     "num": 20000}
    assert "floquet" not in meta["settings"]
    frame = pd.read_parquet(tmp_path / "out" / "stability_map.parquet")
    np.testing.assert_array_equal(np.unique(frame["A"]), np.linspace(0.0, 0.5, 20000))


# -- 5. run runs [analyses] at the scene's point; --no-write writes nothing --------------------

_SWEPT = pendulum_scene(theta=3.0916, analyses='measure = { periods = 50, about = "inverted" }',
                        sweep='analyses = ["measure"]',
                        axes="A = [0.01, 0.03, 0.05]\nomega = [100.0, 150.0, 200.0, 250.0]"
                        ) + '[output]\ndirectory = "out"\nformats = ["parquet", "csv"]\n'


def test_run_computes_the_point_not_the_sweep_and_no_write_writes_nothing(tmp_path,
                                                                           monkeypatch, capsys):
    folder = tmp_path / "work"
    folder.mkdir()
    path = folder / "swept.toml"
    path.write_text(_SWEPT)
    monkeypatch.chdir(folder)
    code = cli.main(["run", str(path), "--no-write", "--json"])
    captured = capsys.readouterr()
    assert code == 0, captured.err
    data = json.loads(captured.out)
    assert len(data["analyses"]["measure"]) == 1          # the scene's point, not 12 rows
    assert data["written"] == [] and "kapitza sweep" in captured.err
    assert sorted(p.name for p in folder.rglob("*")) == ["swept.toml"], "--no-write wrote"
    # the API: the measurement at the scene's point (A = 5 cm, ω = 200 rad/s), no sweep
    res = Scene.from_toml(path).run(write=False)
    m = res["measure"]
    assert m.params["A"] == 0.05 and m.params["omega"] == 200.0 and np.ndim(m.stayed_up) == 0
    assert res.sweeps == {} and sorted(p.name for p in folder.rglob("*")) == ["swept.toml"]
    direct = kapitza.measure(res.scene.system, res.scene.params, [math.pi], [3.0916], [0.0],
                             periods=50, band=math.pi / 2)
    assert m.omega_slow == direct.omega_slow
    # written, the point's tables only: no sweep dataset
    Scene.from_toml(path).run()
    assert sorted(p.name for p in (folder / "out").iterdir()) == [
        "_run.json", "measure.csv", "measure.csv-metadata.json", "measure.parquet"]


# -- 11. every table says what it is ---------------------------------------------------------

_RECORDED = (pendulum_scene(theta=3.0916, analyses='averaging = true\nfloquet = { tol = 1e-9 }\n'
                            'measure = { periods = 50, about = "inverted" }\n'
                            "simulate = { periods = 3, samples = 7 }")
             .split("[sweep]")[0].replace("gravity = true\n", "gravity = true\n"
                                          "[effects.damping]\ngamma = 0.2\n")
             + '[output]\ndirectory = "out"\nformats = ["parquet", "csv"]\n')
_UNITS = {"A": "m", "omega": "rad/s", "g": "m/s²", "l": "m", "m": "kg", "gamma": "1/s"}


def _check_record(meta, text, table):
    assert meta["scene_sha256"] == hashlib.sha256(text.encode()).hexdigest()
    assert meta["scene"] == text and meta["scene_name"]
    assert meta["units"] == {k: _UNITS[k] for k in meta["parameters"]}, meta["units"]
    assert meta["initial_units"]["theta"] == "rad"
    assert meta["versions"]["numpy"] == np.__version__
    assert meta["versions"]["kapitza"] and meta["fingerprint"]
    if "method" in table:
        assert meta["method"] == table["method"].iloc[0]


def test_every_table_run_writes_says_what_it_is(tmp_path):
    path = tmp_path / "recorded.toml"
    path.write_text(_RECORDED)
    res = Scene.from_toml(path).run(progress=False)
    out = tmp_path / "out"
    tables = res.tables()
    assert set(tables) == {"averaging", "floquet", "measure", "simulate"}
    for name, table in tables.items():
        meta = json.loads(pq.read_schema(out / f"{name}.parquet").metadata[b"kapitza"])
        _check_record(meta, _RECORDED, table)
        assert meta["analysis"] == name and meta["parameters"]["gamma"] == 0.2
        side = json.loads((out / f"{name}.csv-metadata.json").read_text())
        assert side["url"] == f"{name}.csv" and side["kapitza"] == meta
        csv = pd.read_csv(out / f"{name}.csv")
        assert [c["name"] for c in side["tableSchema"]["columns"]] == list(csv.columns)
    tolerances = {n: json.loads(pq.read_schema(out / f"{n}.parquet").metadata[b"kapitza"])
                  for n in tables}
    assert tolerances["floquet"]["tolerances"]["tol"] == 1e-9          # as the scene says
    assert tolerances["measure"]["tolerances"]["rtol"] == res["measure"].rtol == 1e-9
    assert tolerances["measure"]["integrator"] == res["measure"].method
    assert tolerances["simulate"]["integrator"] == res["simulate"].method
    assert tolerances["averaging"]["integrator"] is None


def test_every_table_the_report_writes_says_what_it_is(tmp_path):
    from kapitza.report._job import Job
    scene = Scene.example("report")
    (tmp_path / "data").mkdir()
    job = Job(scene=scene, out=tmp_path, quick=True, grid_progress=False)
    frame = pd.DataFrame({"A": [0.1, 0.2], "stable": [True, False],
                          "method": ["floquet: Mathieu characteristic values"] * 2})
    job.table("stability_map", frame, "map", shown="a map")
    parquet, csv = job.tables["stability_map"]
    meta = json.loads(pq.read_schema(parquet).metadata[b"kapitza"])
    _check_record(meta, scene.spec.text, frame)
    assert meta["section"] == "map" and meta["analysis"] == "stability_map"
    assert meta["settings"]["A"]["num"] == 240 and meta["report"] == "quick"
    side = json.loads(csv.with_name(csv.name + "-metadata.json").read_text())
    assert side["kapitza"] == meta
    pd.testing.assert_frame_equal(pd.read_parquet(parquet), frame)


def test_a_sweep_records_units_integrator_and_tolerances(tmp_path):
    text = pendulum_scene(theta=3.0916, analyses='measure = { periods = 20, about = '
                          '"inverted", rtol = 1e-8 }', sweep='analyses = ["measure"]\n'
                          "tile_points = 2", axes="A = [0.03, 0.05]\ninitial.theta = "
                          "[3.0916, 3.1]")
    res = Scene.from_text(text).sweep(directory=tmp_path, progress=False)
    for where in [res.path / "_common_metadata", *sorted(res.path.glob("part-*"))]:
        meta = json.loads(pq.read_schema(where).metadata[b"kapitza"])
        assert meta["tolerances"]["rtol"] == 1e-8 and meta["integrator"] == "rkn12"
        assert meta["axis_units"] == {"A": "m", "initial.theta": "rad"}
        assert meta["units"]["omega"] == "rad/s" and meta["versions"]["pyarrow"]
        assert meta["axes"]["A"] == {"kind": "list", "values": [0.03, 0.05]}
    frame = res.to_dataframe()
    assert (frame["method"] == meta["method"]).all()
