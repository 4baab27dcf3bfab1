"""Scale-out of a scene sweep: one process on one numba thread, on numba's threads, and a
2-worker Dask LocalCluster (issue 24.5).

The sweep: the undamped Kapitza pendulum (l = 1 m, g = 9.81 m/s²) released 0.05 rad from
the upright, ``measure`` (``--periods`` drive periods, RKN 12, rtol 1e-9, band π/2 about
θ = π) at every point of A ∈ [0.01, 0.3] m × ω ∈ [50, 500] rad/s (log), ``--points``
points in all (default 10⁵).  Every executor writes its own dataset of the same tiles
(the tile size calibrated once, as a sweep does: 0.5 s of one-thread work; or
``--tile-points``) and must give the same rows, to the bit.

Reported per executor: wall time, points/s, tiles, the time inside the work (the
compiled grid calls; on the cluster the tasks' compute time from Dask's task stream),
the per-tile overhead — (wall × workers − work) / tiles: building the tile's inputs,
writing its Parquet part, its checksum and ledger line, and on the cluster scheduling
and moving the frame — and the parallel efficiency, serial time / (2 × wall).  The
target of issue 24.5: the LocalCluster within 1.3× of one process on numba's threads.

The machine is shared: the load average is printed beside every timing.

Usage::

    python benchmarks/bench_sweep_scaleout.py                     # 10⁵ points
    python benchmarks/bench_sweep_scaleout.py --points 1000000 --only threads,dask
    python benchmarks/bench_sweep_scaleout.py --quick             # 2·10³ points
"""
from __future__ import annotations

import argparse
import math
import os
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

SCENE = '''schema = 1
[system]
name = "pendulum"
[parameters]
l = 1.0
[effects]
gravity = true
[effects.drive]
direction = "vertical"
amplitude = 0.05
omega = 200.0
[initial]
theta = 3.0916
[analyses]
measure = {{ periods = {periods}, about = "inverted" }}
[sweep]
analyses = ["measure"]
[sweep.axes]
A = {{ start = 0.01, stop = 0.3, num = {nA} }}
omega = {{ start = 50.0, stop = 500.0, num = {nw}, scale = "log" }}
'''


class Timed:
    """The sweep's work, with the seconds spent inside it summed (one process only)."""

    def __init__(self, work):
        self.work, self.seconds, self.calls = work, 0.0, 0

    def __call__(self, columns, points):
        t0 = time.perf_counter()
        try:
            return self.work(columns, points)
        finally:
            self.seconds += time.perf_counter() - t0
            self.calls += 1


def _warm_one(work, axes):
    """Run the work on one point (a worker loads its kernels)."""
    from kapitza.scenes._sweep import tile_columns
    first = np.zeros(1, dtype=np.int64)
    work(tile_columns(axes, first), first)


def load() -> str:
    return "load " + "/".join(f"{x:.1f}" for x in os.getloadavg())


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--points", type=float, default=1e5)
    parser.add_argument("--periods", type=int, default=100)
    parser.add_argument("--tile-points", type=int, default=None)
    parser.add_argument("--only", default="serial,threads,dask")
    parser.add_argument("--quick", action="store_true")
    args = parser.parse_args(argv)
    if args.quick:
        args.points = 2e3
    import kapitza
    from kapitza.scenes._scene import _SweepWork
    from kapitza.scenes._sweep import _calibrate, grid_size, run_sweep

    nA = int(round(math.sqrt(args.points)))
    nw = int(round(args.points / nA))
    scene = kapitza.Scene.from_text(SCENE.format(periods=args.periods, nA=nA, nw=nw))
    axes = scene.spec.sweep["axes"]
    size = grid_size(axes)
    work = _SweepWork(scene.spec.text, scene.spec.source, "measure")
    print(f"sweep: measure, {args.periods} periods, {nA} × {nw} = {size} points; "
          f"{os.cpu_count()} cores; {load()}")
    t0 = time.perf_counter()
    tile = args.tile_points or _calibrate(work, axes, size, 0.5)
    print(f"tile: {tile} points ({-(-size // tile)} tiles; calibrated/warmed in "
          f"{time.perf_counter() - t0:.1f} s); {load()}")
    folder = Path(tempfile.mkdtemp(prefix="scaleout-"))
    common = dict(key=scene.key("measure"), fingerprint="bench", metadata={},
                  tile_points=tile, progress=False)
    rows, frames = {}, {}
    for name in args.only.split(","):
        before = load()
        if name == "dask":
            import distributed
            with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                          dashboard_address=None) as cluster, \
                    distributed.Client(cluster) as client:
                # not timed: start-up, and the kernels loaded (or, after a source changed,
                # compiled) in each worker
                client.run(_warm_one, work, axes)
                with distributed.get_task_stream(client) as stream:
                    t0 = time.perf_counter()
                    res = run_sweep(work, axes, folder / name, executor=client, **common)
                    wall = time.perf_counter() - t0
                inside = sum(s["stop"] - s["start"] for task in stream.data
                             for s in task["startstops"] if s["action"] == "compute")
            workers = 2
        else:
            timed = Timed(work)
            t0 = time.perf_counter()
            res = run_sweep(timed, axes, folder / name,
                            executor="serial" if name == "serial" else "local", **common)
            wall = time.perf_counter() - t0
            inside = timed.seconds
            workers = 1
        frames[name] = res.to_dataframe()
        rows[name] = dict(wall=wall, rate=size / wall, tiles=res.tiles, inside=inside,
                          overhead=(wall * workers - inside) / res.tiles)
        print(f"{name:8s} {wall:8.1f} s  {size / wall:9.0f} points/s  {res.tiles} tiles  "
              f"work {inside:.1f} s  overhead/tile {1e3 * rows[name]['overhead']:.1f} ms  "
              f"({before} → {load()})", flush=True)
    names = list(frames)
    for other in names[1:]:
        same = frames[other].equals(frames[names[0]])
        print(f"{other} rows equal {names[0]}'s to the bit: {same}")
    if "serial" in rows:
        for name in ("threads", "dask"):
            if name in rows:
                print(f"efficiency of {name}: serial / (2 × wall) = "
                      f"{rows['serial']['wall'] / (2 * rows[name]['wall']):.2f}")
    if "dask" in rows and "threads" in rows:
        ratio = rows["dask"]["wall"] / rows["threads"]["wall"]
        print(f"LocalCluster / threads: {ratio:.2f} (target ≤ 1.3: "
              f"{'met' if ratio <= 1.3 else 'not met'})")
    print(f"datasets in {folder}")
    return rows


if __name__ == "__main__":
    np.seterr(all="ignore")
    main()
