"""Damaged sweep data never blocks a resume (issue 22, item 9); each fault injected.

* A part cut short (a full disk, an interrupted copy) or changed is found on resume,
  moved aside with a warning naming it, and its tile computed again — with the ledger's
  checksum, and without a ledger (a dataset of an older kapitza).
* Two sweeps of one dataset: the second refuses naming the first, or waits for it; a
  lock whose process is gone is taken over.  They never both write a tile.
* A write that fails for want of space leaves no part behind and says how to resume;
  the resumed sweep completes.
* A Dask worker that dies mid-tile, or a task that raises once: the tile is computed
  again, nothing duplicated — in tests/test_sweeps.py, which shares its LocalCluster.
"""
import json
import os
import socket
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

import kapitza
from kapitza import cli
from kapitza.scenes import Axis
from kapitza.scenes._sweep import run_sweep

from helpers import pendulum_scene

AXES = (Axis("x", tuple(np.linspace(0.0, 1.0, 12))),)
TILES = 4


def _square(columns, points):
    return pd.DataFrame({"point": points, "y": columns["x"] ** 2})


def _sweep(directory, work=_square, **options):
    return run_sweep(work, AXES, directory, key="k", fingerprint="f", metadata={},
                     tile_points=3, **options)


def parts(path):
    return sorted(path.glob("part-*.parquet"))


def _whole(result):
    frame = result.to_dataframe()
    assert frame["point"].tolist() == list(range(12)), "a point lost or twice"
    np.testing.assert_array_equal(frame["y"], np.linspace(0.0, 1.0, 12) ** 2)
    pd.testing.assert_frame_equal(pd.read_parquet(result.path), frame)
    return frame


# -- damaged parts -----------------------------------------------------------------------------

@pytest.mark.parametrize("damage", ["truncated", "truncated, no ledger", "changed bytes"])
def test_a_damaged_part_is_moved_aside_and_computed_again(tmp_path, damage):
    first = _sweep(tmp_path / "d")
    _whole(first)
    victim = parts(first.path)[1]
    data = victim.read_bytes()
    if damage.startswith("truncated"):
        victim.write_bytes(data[:len(data) // 2])           # as a full disk leaves it
    else:
        flipped = bytearray(data)
        flipped[len(data) // 2] ^= 0xFF
        victim.write_bytes(bytes(flipped))
    if damage.endswith("no ledger"):
        (first.path / "_parts.jsonl").unlink()
    with pytest.warns(UserWarning, match=f"the part {victim.name} \\(tile 1, points 3…5\\) "
                                         "is damaged") as record:
        again = _sweep(tmp_path / "d")
    assert len(record) == 1 and type(record[0].message).__name__ == "DamagedPartWarning"
    assert (again.computed, again.skipped) == (1, TILES - 1)
    assert (first.path / f"_{victim.name}.damaged").exists()
    assert victim.read_bytes() == data
    _whole(again)
    ledger = (first.path / "_parts.jsonl").read_text().splitlines()
    assert {json.loads(line)["part"] for line in ledger} == {p.name for p in parts(first.path)}


def test_kapitza_sweep_resumes_past_a_truncated_part(tmp_path, capsys):
    """The issue: every later `kapitza sweep` exited 2 with pyarrow's "magic bytes not
    found"; now the part is named, moved aside and its tile computed again."""
    scene = tmp_path / "swept.toml"
    scene.write_text(pendulum_scene(theta=3.0916, analyses='measure = { periods = 50, about = '
                                    '"inverted" }', sweep='analyses = ["measure"]\n'
                                    "tile_points = 1", axes="A = [0.01, 0.05]\n"
                                    "omega = [100.0, 200.0]"))
    out = tmp_path / "out"
    assert cli.main(["sweep", str(scene), "--directory", str(out)]) == 0
    (dataset,) = out.iterdir()
    before = pd.read_parquet(dataset)
    victim = parts(dataset)[2]
    victim.write_bytes(victim.read_bytes()[:100])
    capsys.readouterr()
    code = cli.main(["sweep", str(scene), "--directory", str(out), "--json"])
    captured = capsys.readouterr()
    assert code == 0, captured.err
    assert f"the part {victim.name} (tile 2, points 2…2) is damaged" in captured.err
    data = json.loads(captured.out)
    assert (data["computed"], data["skipped"]) == (1, 3)
    pd.testing.assert_frame_equal(pd.read_parquet(dataset), before)


# -- no space ----------------------------------------------------------------------------------

def test_a_failed_write_leaves_no_part_and_the_sweep_resumes(tmp_path, monkeypatch):
    import pyarrow.parquet
    real = pyarrow.parquet.write_table
    calls = []

    def full_disk(table, where, *args, **kwargs):
        calls.append(where)
        if len(calls) == 2:                 # the second part: half written, then no space
            with open(where, "wb") as f:
                f.write(b"PAR1" + b"\0" * 64)
            raise OSError(28, "No space left on device")
        return real(table, where, *args, **kwargs)

    monkeypatch.setattr(pyarrow.parquet, "write_table", full_disk)
    directory = tmp_path / "d"
    with pytest.raises(OSError, match="could not be written .No space left on device.; "
                                      "nothing of it is left behind") as info:
        _sweep(directory)
    assert info.value.errno == 28 and "run the same sweep again" in str(info.value)
    assert str(directory) in str(info.value)
    assert [p.name for p in directory.iterdir() if not p.name.startswith("_")] == [
        parts(directory)[0].name], "a temporary file or half a part was left"
    assert len((directory / "_parts.jsonl").read_text().splitlines()) == 1
    monkeypatch.setattr(pyarrow.parquet, "write_table", real)
    resumed = _sweep(directory)
    assert (resumed.computed, resumed.skipped) == (TILES - 1, 1)
    _whole(resumed)


# -- two sweeps, one dataset -----------------------------------------------------------------

_CHILD = '''\
import sys, time
from pathlib import Path
import numpy as np, pandas as pd
from kapitza.scenes import Axis
from kapitza.scenes._sweep import run_sweep

started = Path(sys.argv[2])

def slow_square(columns, points):
    started.touch()
    time.sleep(0.4)
    return pd.DataFrame({"point": points, "y": columns["x"] ** 2})

axes = (Axis("x", tuple(np.linspace(0.0, 1.0, 12))),)
run_sweep(slow_square, axes, sys.argv[1], key="k", fingerprint="f", metadata={},
          tile_points=3, progress=False)
print("done", flush=True)
'''


def _child_sweep(tmp_path, directory):
    script = tmp_path / "child.py"
    script.write_text(_CHILD)
    here = str(Path(kapitza.__file__).resolve().parents[1])
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(
        p for p in (here, os.environ.get("PYTHONPATH")) if p))
    started = tmp_path / "started"
    proc = subprocess.Popen([sys.executable, str(script), str(directory), str(started)],
                            stdout=subprocess.PIPE, text=True, env=env)
    deadline = time.time() + 120
    while not started.exists():
        assert proc.poll() is None and time.time() < deadline, "the child sweep did not start"
        time.sleep(0.02)
    return proc


def test_a_second_sweep_refuses_naming_the_first_or_waits_for_it(tmp_path):
    directory = tmp_path / "d"
    proc = _child_sweep(tmp_path, directory)
    try:
        with pytest.raises(ValueError, match=f"is being written by the sweep of pid "
                                             f"{proc.pid} on host {socket.gethostname()}"):
            _sweep(directory)
        assert proc.poll() is None, "the child finished before the second sweep was refused"
        waited = _sweep(directory, wait=True)          # waits, then finds every tile done
        assert proc.wait(timeout=60) == 0 and proc.stdout.read().strip() == "done"
    finally:
        if proc.poll() is None:
            proc.kill()
    assert (waited.computed, waited.skipped) == (0, TILES)
    _whole(waited)
    ledger = [json.loads(line)["part"]
              for line in (directory / "_parts.jsonl").read_text().splitlines()]
    assert sorted(ledger) == [p.name for p in parts(directory)], "a tile written twice"
    assert not (directory / "_sweep.lock").exists()


def test_a_stale_lock_is_taken_over_and_another_hosts_is_not(tmp_path):
    directory = tmp_path / "d"
    directory.mkdir()
    gone = subprocess.Popen([sys.executable, "-c", "pass"])
    gone.wait()
    lock = directory / "_sweep.lock"
    lock.write_text(json.dumps({"pid": gone.pid, "host": socket.gethostname(),
                                "started": "yesterday"}))
    with pytest.warns(UserWarning, match=f"took over the lock of the sweep of pid {gone.pid}"):
        _whole(_sweep(directory))
    assert not lock.exists()
    lock.write_text(json.dumps({"pid": gone.pid, "host": "elsewhere", "started": "today"}))
    t0 = time.perf_counter()
    with pytest.raises(ValueError, match="on host elsewhere, started today"):
        _sweep(directory, wait=0.5)
    assert 0.5 <= time.perf_counter() - t0 < 5
    assert lock.exists()
