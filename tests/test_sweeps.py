"""Sweeps (kapitza.scenes._sweep, Scene.sweep): tiles as atomic Parquet parts with metadata, a
restart that skips finished tiles, a killed sweep resumed to the same dataset, Ctrl-C
keeping finished tiles, the analyses over tiles, and serial = numba threads = a Dask
LocalCluster to the bit, and a Dask worker that dies (or a task that fails) mid-tile."""
import json
import math
import os
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

import kapitza
from kapitza import Scene
from kapitza.scenes._file import Axis
from kapitza.scenes._sweep import MANIFEST, compute_tile, run_sweep, tile_columns

from helpers import ctrl_c_in_process, sigint_default
from helpers import pendulum_scene as pendulum

#: the Kapitza pendulum simulated over A × θ0: 12 points in tiles of 4
SCENE = pendulum(theta=3.0, analyses="simulate = { periods = 50 }", sweep="tile_points = 4",
                 axes="A = { start = 0.0, stop = 0.3, num = 6 }\ninitial.theta = [2.9, 3.0]")


def slow_scene(points=96, tile=8, periods=1000):
    """Tiles of ~0.05 s: long enough to kill or interrupt a sweep between them (the
    parent sees a part within 10 ms, and 9 tiles are left then, ~0.5 s; at 2000 periods
    the tiles took twice the CPU for nothing more: the killed sweep's test computes them
    all twice more, resumed and whole)."""
    return (SCENE.replace("num = 6", f"num = {points // 2}")
            .replace("tile_points = 4", f"tile_points = {tile}")
            .replace("periods = 50", f"periods = {periods}"))


def parts(path):
    return sorted(p.name for p in path.glob("part-*.parquet"))


def test_grid_order_and_axes():
    axes = (Axis("a", (1.0, 2.0, 3.0)), Axis("b", (10.0, 20.0)))
    cols = tile_columns(axes, np.arange(6))
    assert cols["a"].tolist() == [1, 1, 2, 2, 3, 3] and cols["b"].tolist() == [10, 20] * 3
    s = Scene.from_text(SCENE.replace('A = { start = 0.0, stop = 0.3, num = 6 }',
                                      'A = { start = 0.01, stop = 1.0, num = 3, scale = "log" }'))
    a = s.spec.sweep["axes"][0]
    assert a.kind == "log" and a.values == pytest.approx((0.01, 0.1, 1.0), rel=1e-15)


def test_sweep_parts_metadata_and_restart(tmp_path, capsys):
    s = Scene.from_text(SCENE)
    res = s.sweep(directory=tmp_path, csv=True)
    assert (res.size, res.tile_points, res.tiles, res.computed, res.skipped) == (12, 4, 3, 3, 0)
    assert res.path.parent == tmp_path and res.path.name.startswith("simulate-")
    df = res.to_dataframe()
    assert df["point"].tolist() == list(range(12))
    assert list(df.columns[:3]) == ["point", "A", "initial.theta"]
    assert df["A"].tolist() == np.repeat(np.linspace(0, 0.3, 6), 2).tolist()
    assert df["initial.theta"].tolist() == [2.9, 3.0] * 6
    assert set(df["status"]) == {"finished"}
    # a point of the sweep is the same integration on its own, to the bit
    i = 7
    one = s.system.simulate_grid([df["initial.theta"][i]], [0.0], (0, 50 * 2 * math.pi / 200),
                                 dict(s.params, A=df["A"][i]), progress=False)
    assert df["theta"][i] == one.q[0] and df["theta_dot"][i] == one.qdot[0]
    # the dataset: one part per tile, the plan, the metadata; pandas reads it as is
    assert len(parts(res.path)) == 3 and (res.path / MANIFEST).exists()
    pd.testing.assert_frame_equal(pd.read_parquet(res.path), df)
    import pyarrow.parquet as pq
    meta = json.loads(pq.read_schema(res.path / "_common_metadata").metadata[b"kapitza"])
    assert meta["scene"] == SCENE and meta["analysis"] == "simulate"
    assert meta["fingerprint"] == kapitza.scenes.code_fingerprint()
    assert meta["versions"]["pyarrow"] and meta["versions"]["numba"]
    assert meta["axes"]["A"]["kind"] == "linear" and meta["parameters"]["omega"] == 200.0
    part_meta = json.loads(pq.read_schema(res.path / parts(res.path)[1]).metadata[b"kapitza"])
    assert part_meta["tile"] == [4, 8] and part_meta["scene"] == SCENE
    csv = pd.read_csv(res.path.parent / f"{res.path.name}.csv")
    np.testing.assert_allclose(csv["theta"], df["theta"], rtol=1e-15)
    # a restart finds every tile and computes nothing; quiet when stderr is no terminal
    capsys.readouterr()
    again = s.sweep(directory=tmp_path)
    assert (again.computed, again.skipped) == (0, 3)
    pd.testing.assert_frame_equal(again.to_dataframe(), df)
    assert capsys.readouterr().err == ""
    s.sweep(directory=tmp_path, progress=True)
    assert "12/12" in capsys.readouterr().err
    # another scene (another number of periods) is another dataset
    other = Scene.from_text(SCENE.replace("periods = 50", "periods = 40"))
    assert other.key("simulate") != s.key("simulate")
    assert other.sweep(directory=tmp_path, tile_points=6).path != res.path


def _square(columns, points):
    time.sleep(0.002 * len(points))
    return pd.DataFrame({"point": points, "y": columns["x"] ** 2})


def test_the_store_refuses_another_sweep_or_other_tiles(tmp_path):
    axes = (Axis("x", tuple(np.linspace(0, 1, 10))),)
    res = run_sweep(_square, axes, tmp_path / "d", key="k", fingerprint="f1", metadata={},
                    tile_points=3)
    assert res.tiles == 4 and res.to_dataframe()["y"].tolist() == (res.to_dataframe()["x"] ** 2
                                                                   ).tolist()
    with pytest.raises(ValueError, match="holds another sweep"):
        run_sweep(_square, axes, tmp_path / "d", key="k", fingerprint="f2", metadata={})
    with pytest.raises(ValueError, match="was cut into tiles of 3 points"):
        run_sweep(_square, axes, tmp_path / "d", key="k", fingerprint="f1", metadata={},
                  tile_points=4)
    # calibrated tiles: a tile gets tile_seconds of one-thread work
    cal = run_sweep(_square, axes, tmp_path / "e", key="k", fingerprint="f1", metadata={},
                    tile_seconds=0.005)
    assert 1 <= cal.tile_points <= 3
    # a stray temporary file of a dead process is removed; the part of a tile is one file
    (tmp_path / "d" / ".tmp-999999999-abc.parquet").write_text("half a part")
    run_sweep(_square, axes, tmp_path / "d", key="k", fingerprint="f1", metadata={})
    assert not list((tmp_path / "d").glob(".tmp-*"))


def _fixed_cost(columns, points):
    time.sleep(0.02 + 0.0002 * len(points))      # 20 ms a call, 0.2 ms a point
    return pd.DataFrame({"point": points, "y": columns["x"]})


def test_calibrated_tiles_pay_a_calls_fixed_cost_once(tmp_path):
    """A work whose call costs 20 ms besides 0.2 ms a point: a tile of 0.2 s holds ~900
    points (8 points alone would say 21.6/8 ms a point, and tiles of ~74: most of each
    tile's time the fixed cost)."""
    axes = (Axis("x", tuple(np.linspace(0, 1, 2000))),)
    res = run_sweep(_fixed_cost, axes, tmp_path / "d", key="k", fingerprint="f",
                    metadata={}, tile_seconds=0.2, executor="serial")
    assert 500 <= res.tile_points <= 1400, res.tile_points
    assert res.to_dataframe()["point"].tolist() == list(range(2000))


_CHILD = '''\
import sys
import kapitza
scene = kapitza.Scene.from_toml(sys.argv[1])
print("ready", flush=True)
scene.sweep(directory=sys.argv[2], progress=False)
'''


def _child(tmp_path, text):
    """The sweep in a child process that imports this kapitza (same code, same keys)."""
    (tmp_path / "scene.toml").write_text(text)
    (tmp_path / "child.py").write_text(_CHILD)
    here = str(Path(kapitza.__file__).resolve().parents[1])
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(
        p for p in (here, os.environ.get("PYTHONPATH")) if p))
    return subprocess.Popen([sys.executable, str(tmp_path / "child.py"),
                             str(tmp_path / "scene.toml"), str(tmp_path / "out")],
                            stdout=subprocess.PIPE, text=True, env=env,
                            preexec_fn=sigint_default)


def _wait_for_parts(directory, count, timeout=120, until=None):
    """The sweep's parts in ``directory`` once there are ``count``; [] if the event
    ``until`` is set first (the sweep is over)."""
    deadline = time.time() + timeout
    while time.time() < deadline:
        found = list(directory.glob("*/part-*.parquet"))
        if len(found) >= count:
            return found
        if until is not None and until.is_set():
            return []
        time.sleep(0.01)
    raise AssertionError(f"no {count} parts in {directory} after {timeout} s")


def test_a_killed_sweep_resumes_to_the_same_dataset(tmp_path):
    """SIGKILL after some tiles: the parts on disk are whole; the restarted sweep keeps
    them, computes the rest, and the dataset equals an uninterrupted sweep's."""
    text = slow_scene()
    s = Scene.from_text(text)
    tiles = 12
    proc = _child(tmp_path, text)
    try:
        assert proc.stdout.readline().strip() == "ready"
        _wait_for_parts(tmp_path / "out", 3)
        os.kill(proc.pid, signal.SIGKILL)
        proc.wait(timeout=30)
    finally:
        if proc.poll() is None:
            proc.kill()
    (path,) = (tmp_path / "out").iterdir()
    kept = {name: (path / name).read_bytes() for name in parts(path)}
    assert 3 <= len(kept) < tiles, "the sweep was not killed between its tiles"
    # the killed sweep's lock names a process that is gone: taken over, and said so
    with pytest.warns(UserWarning, match=f"took over the lock of the sweep of pid {proc.pid}"):
        resumed = s.sweep(directory=tmp_path / "out", progress=False)
    assert resumed.path == path
    assert (resumed.skipped, resumed.computed) == (len(kept), tiles - len(kept))
    assert all((path / name).read_bytes() == data for name, data in kept.items())
    assert not list(path.glob(".tmp-*"))
    whole = s.sweep(directory=tmp_path / "whole", progress=False)
    assert whole.computed == tiles
    pd.testing.assert_frame_equal(resumed.to_dataframe(), whole.to_dataframe(), check_exact=True)
    pd.testing.assert_frame_equal(pd.read_parquet(path), pd.read_parquet(whole.path),
                                  check_exact=True)
    assert resumed.to_dataframe()["point"].tolist() == list(range(96))     # no row twice


def test_ctrl_c_keeps_the_finished_tiles(tmp_path):
    """SIGINT after the first tile: the running tile stops at its next chunk and is
    dropped; ComputationInterrupted carries the finished tiles, which are on disk.

    In this process (:func:`helpers.ctrl_c_in_process`: Python's own Ctrl-C handler, the
    signal sent to the process as from outside, the moment a thread sees the first part
    on disk); a child, as the killed sweep's test needs, spent ~2 CPU-s importing kapitza
    and loading the kernels for nothing more."""
    s = Scene.from_text(slow_scene())
    first, over = threading.Event(), threading.Event()

    def watch():                    # sets ``first`` when a part is on disk
        if _wait_for_parts(tmp_path / "out", 1, until=over):
            first.set()

    watcher = threading.Thread(target=watch, daemon=True)
    watcher.start()
    try:
        stop, caught, sent = ctrl_c_in_process(
            lambda: s.sweep(directory=tmp_path / "out", progress=False), 0.0, after=first)
    finally:
        over.set()
        watcher.join()
    assert caught - sent < 5
    kept = len(list(stop.result.path.glob("part-*")))
    assert 1 <= kept < 12 and stop.result.computed == kept
    assert int(stop.computed.sum()) == len(stop.result.frame) == 8 * kept
    (path,) = (tmp_path / "out").iterdir()
    assert len(parts(path)) == kept and not list(path.glob(".tmp-*"))


# -- the analyses over tiles ------------------------------------------------------------------

def test_floquet_and_averaging_sweeps_agree_with_the_exact_window(tmp_path):
    """The upright pendulum over A at ω = 200 rad/s: Floquet (monodromy) and averaging
    (closed forms) against the exact Mathieu window."""
    s = Scene.from_text(pendulum(
        direction="vertical", theta=3.1, analyses="floquet = true\naveraging = true",
        axes="A = { start = 0.005, stop = 0.5, num = 12 }"))
    fl = s.sweep("floquet", directory=tmp_path, progress=False).to_dataframe()
    win = kapitza.KapitzaPendulum(l=1.0, g=9.81).window(200.0)
    inside = (fl["A"] > win.A_min) & (fl["A"] < win.A_max)
    assert fl["stable"].tolist() == inside.tolist() and 0 < inside.sum() < 12
    assert {"trace", "boundary", "omega_slow_0", "flags"} <= set(fl.columns)
    av = s.sweep("averaging", directory=tmp_path, progress=False).to_dataframe()
    up = av[av["equilibrium"] == "inverted"]
    assert up["point"].tolist() == list(range(12))
    np.testing.assert_array_equal(up["stable"], (up["A"] * 200.0) ** 2 > 2 * 9.81)


def test_periodic_orbit_and_general_averaging_sweeps(tmp_path):
    """A horizontal drive: Floquet about the tilted orbit per point; the elliptic pivot's
    averaging through the general path (not the pendulum's closed forms)."""
    s = Scene.from_text(pendulum(direction="horizontal", theta=1.0, analyses="floquet = true",
                                 axes="A = [0.04, 0.06]"))
    fl = s.sweep(directory=tmp_path, progress=False).to_dataframe()
    tilt = np.arccos(2 * 9.81 / (fl["A"] * 200.0) ** 2)
    np.testing.assert_allclose(fl["q_mean_theta"], tilt, atol=0.01)
    assert fl["stable"].all() and (fl["error"] == "").all()
    s = Scene.from_text(pendulum(direction="elliptic", theta=0.0, analyses="averaging = true",
                                 axes="gamma = [0.1, 0.5]").replace(
        "amplitude = 0.05", "amplitude = 0.02\namplitude_y = 0.01").replace(
        "[effects]", "[effects.damping]\ngamma = 0.1\n[effects]"))
    av = s.sweep(directory=tmp_path, progress=False).to_dataframe()
    assert {"point", "gamma", "equilibrium", "about_theta", "mode", "stable"} <= set(av.columns)
    tilted = av[av["stable"]].groupby("point")["about_theta"].first()
    # the damped two-phase drive tilts the hanging state; the exact orbit's mean agrees
    for i, gamma in enumerate((0.1, 0.5)):
        p = dict(s.params, gamma=gamma)
        (want,) = [e.about[0] for e in kapitza.average(s.system).predict(p, warn=False)
                   .equilibria if e.stable]
        assert tilted[i] == want > 0
        orbit = kapitza.periodic_orbit(s.system, p, [0.0])
        assert tilted[i] == pytest.approx(orbit.q_mean[0], rel=0.01)


def test_measure_sweep_over_initial_angles(tmp_path):
    s = Scene.from_text(pendulum(
        direction="vertical", theta=3.1, analyses="measure = { periods = 300 }",
        axes="initial.theta = [3.0, 3.1, 0.1]"))
    m = s.sweep(directory=tmp_path, progress=False).to_dataframe()
    # "auto": each run measured about the persisting state nearest its start
    assert m["about_theta"].tolist() == [math.pi, math.pi, 0.0]
    assert m["stayed_up"].all()
    assert m["omega_slow_0"][1] == pytest.approx(math.sqrt((0.05 * 200) ** 2 / 2 - 9.81),
                                                 rel=0.02)


# -- the code fingerprint ----------------------------------------------------------------------

def test_the_code_fingerprint_covers_subpackages_not_figures_or_the_cli():
    """Every module that can change a number counts, at any depth (a subpackage's private
    modules too): changed analysis code starts a new dataset instead of resuming one.
    Figures and the command line do not count."""
    from kapitza.scenes import code_fingerprint, fingerprinted_modules
    from lagrange_core.module_store import source_fingerprint
    mods = fingerprinted_modules()
    names = {m.__name__ for m in mods}
    floquet = sys.modules[kapitza.floquet_point.__module__]        # wherever it lives now
    assert floquet.__name__.startswith("kapitza.floquet.") and floquet in mods
    assert {"kapitza", "kapitza.floquet", "kapitza.scenes._analyses", "kapitza.scenes._file",
            "lagrange_core", "lagrange_core.systems"} <= names
    for excluded in ("kapitza.figures", "kapitza.cli"):
        assert not [n for n in names if n == excluded or n.startswith(excluded + ".")]
    from kapitza.scenes._scene import _package_fingerprint
    _package_fingerprint.cache_clear()          # of the sources as they are now
    assert code_fingerprint() == source_fingerprint(*mods)
    assert source_fingerprint(*[m for m in mods if m is not floquet]) != code_fingerprint()


# -- executors --------------------------------------------------------------------------------

@pytest.fixture(scope="module")
def dask_client():
    """A LocalCluster of 2 worker processes × 1 thread, shared by the executor tests (its
    start is most of their time).

    Before it closes, every worker freezes the objects alive (:func:`gc.freeze`), as the
    ``kapitza`` program does before it exits: a worker's interpreter then skips its last
    full collection over the packages it imported (~0.8 CPU-s a worker; a nanny waits for
    it, and kills a worker still collecting after 4 s).  Only the close is spared: no test
    runs then (a worker restarting after the death test may miss it: errors ignored)."""
    import gc

    distributed = pytest.importorskip("distributed")
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                  dashboard_address=None) as cluster, \
            distributed.Client(cluster) as client:
        yield client
        client.run(gc.freeze, on_error="ignore")


def test_serial_threads_and_a_dask_cluster_give_identical_data(tmp_path, dask_client):
    """One task per tile on a LocalCluster of 2 worker processes × 1 thread: the same
    dataset, to the bit, as this process on one numba thread and on numba's threads."""
    s = Scene.from_text(slow_scene(points=24, tile=6, periods=300))
    serial = s.sweep(directory=tmp_path / "serial", executor="serial", progress=False)
    local = s.sweep(directory=tmp_path / "local", progress=False)
    dask = s.sweep(directory=tmp_path / "dask", executor=dask_client, progress=False)
    # a task's numba threads: set in the task's own thread (numba counts per thread)
    axes = (Axis("x", (0.0, 1.0)),)
    threads = dask_client.submit(compute_tile, _threads, axes, 0, 2, 1, pure=False).result()
    assert (serial.executor, local.executor, dask.executor) == ("serial", "local", "dask")
    assert dask.computed == dask.tiles == 4
    for other in (local, dask):
        pd.testing.assert_frame_equal(other.to_dataframe(), serial.to_dataframe(),
                                      check_exact=True)
    assert threads["threads"].tolist() == [1, 1]


def _threads(columns, points):
    import numba
    return pd.DataFrame({"point": points, "threads": numba.get_num_threads()})


class _Faulty:
    """x², but the first attempt at tile 1 kills its worker process and the first at
    tile 2 raises (each fault once: a marker file created exclusively)."""

    def __init__(self, folder):
        self.folder = folder

    def _first(self, name):
        try:
            os.close(os.open(os.path.join(self.folder, name), os.O_CREAT | os.O_EXCL))
            return True
        except FileExistsError:
            return False

    def __call__(self, columns, points):
        tile = int(points[0]) // 3 if len(points) == 3 else -1
        if tile == 1 and self._first("died-1"):
            os._exit(1)
        if tile == 2 and self._first("raised-2"):
            raise RuntimeError("a transient failure")
        return pd.DataFrame({"point": points, "y": columns["x"] ** 2})


@pytest.mark.slow
def test_a_dask_worker_that_dies_or_a_task_that_fails_mid_tile_is_retried(tmp_path,
                                                                          dask_client):
    """Issue 22.9: the worker killed mid-tile (its nanny restarts it; the scheduler gives
    the tile to the other) and the task that raised once (retried): every tile computed,
    each part written once, no point lost or twice (a few seconds on the shared cluster)."""
    faults = tmp_path / "faults"
    faults.mkdir()
    axes = (Axis("x", tuple(np.linspace(0.0, 1.0, 12))),)
    res = run_sweep(_Faulty(str(faults)), axes, tmp_path / "d", key="k", fingerprint="f",
                    metadata={}, tile_points=3, executor=dask_client, progress=False)
    assert sorted(p.name for p in faults.iterdir()) == ["died-1", "raised-2"]
    assert (res.computed, res.tiles, res.executor) == (4, 4, "dask")
    frame = res.to_dataframe()
    assert frame["point"].tolist() == list(range(12))
    np.testing.assert_array_equal(frame["y"], np.linspace(0.0, 1.0, 12) ** 2)
    assert len(parts(res.path)) == 4
    assert len((res.path / "_parts.jsonl").read_text().splitlines()) == 4


@pytest.mark.parametrize("progress", [False, True])
def test_no_tqdm_warning_in_a_notebook_without_ipywidgets(progress, tmp_path, monkeypatch):
    """A Jupyter kernel without ipywidgets (faked: ipykernel's shell module present,
    ipywidgets not importable): the sweep imported ``tqdm.auto`` even with
    progress=False, whose notebook detection warned TqdmWarning "IProgress not found";
    now progress=False imports nothing of tqdm, and a bar there is tqdm's plain one."""
    import types
    import warnings

    import IPython  # noqa: F401  (tqdm's detection reads sys.modules["IPython"])
    from tqdm import TqdmWarning
    for name in ("tqdm.auto", "tqdm.autonotebook", "tqdm.notebook"):
        monkeypatch.delitem(sys.modules, name, raising=False)
    monkeypatch.setitem(sys.modules, "ipykernel.zmqshell", types.ModuleType("zmqshell"))
    monkeypatch.setitem(sys.modules, "ipywidgets", None)        # import fails
    axes = (Axis("x", tuple(np.linspace(0, 1, 4))),)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        res = run_sweep(_square, axes, tmp_path / "d", key="k", fingerprint="f",
                        metadata={}, tile_points=2, progress=progress)
    assert res.computed == 2
    assert not [w for w in caught if issubclass(w.category, TqdmWarning)], \
        [str(w.message) for w in caught]
    assert "tqdm.autonotebook" not in sys.modules
