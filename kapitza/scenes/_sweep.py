"""Sweeps: a grid of points cut into tiles, each finished tile kept on disk at once.

A sweep is the Cartesian product of its axes (:class:`kapitza.scenes.Axis`; the
first axis slowest), numbered 0 … N − 1 in C order.  :func:`run_sweep` cuts the
points into *tiles* of consecutive points and computes each with one call of a
*work* function (for a scene: one compiled grid call, :meth:`kapitza.Scene.sweep`).

Rules of the store (each holds for every executor)
--------------------------------------------------
1. **A tile is one call of ≥ ~100 ms.**  Unless ``tile_points`` is given, the tile
   size is calibrated once: the work runs on one point (which also compiles or loads
   every kernel it needs into the on-disk cache), then on 8 points spread over the
   grid until two runs agree within 30 %, all on one numba thread — and where those
   take under a quarter of ``tile_seconds``, on 64 points too, which separates a call's
   fixed cost from its cost per point; a tile gets ``tile_seconds`` (default 0.5 s) of
   that one-thread work, by the fastest pilot runs.
   The plan (tile size, number of points) is written to the dataset's ``_sweep.json``
   before the first tile, and a restarted sweep uses it, so its tiles are the same.
2. **A finished tile is one Parquet part, written atomically**: to a temporary name
   in the same directory, then ``os.replace`` onto ``part-<index>-<key>.parquet``,
   where the key hashes the sweep's key (the scene and the analysis), the tile's
   points and the code's fingerprint (:func:`lagrange_core.module_store.source_fingerprint`).
   A killed process leaves a whole part or none (a stray temporary file, removed by the
   next run), never half a part.
3. **A restarted sweep skips every tile whose part exists** (and passes its check, rule
   7); a tile is one file, so a
   point is never computed into two parts: no row is lost or duplicated, whatever was
   interrupted (Ctrl-C, a killed process, a failed worker).
4. **The result** is the parts read in order: a tidy DataFrame (columns ``point``, the
   axes, then the work's columns; one row per point, or several per point for a work
   that returns several) and the directory as a Parquet dataset
   (``pandas.read_parquet(path)`` reads it).  Every part and ``_common_metadata``
   carry the metadata under the key ``kapitza``: the scene, the axes and fixed
   parameters, package versions, the code fingerprint.  ``csv=True`` also writes
   ``<path>.csv`` beside the directory.
5. **Ctrl-C** stops at the next chunk boundary inside a tile (the grid calls run in
   chunks, :mod:`lagrange_core.progress`); the unfinished tile is dropped and
   :class:`~kapitza.results.ComputationInterrupted` is raised with the finished tiles
   in ``.result`` (they are on disk already).
6. **Progress**: a tqdm bar with the time left on stderr, quiet when stderr is not a
   terminal (``progress=None``; True forces it, False silences it).
7. **Damage never blocks a resume** (:mod:`kapitza.scenes._sweep_store`): each part's
   rows, bytes and SHA-256 go to the ledger ``_parts.jsonl`` as it is written; a resumed
   sweep checks every part, moves a damaged one aside (``_<part>.damaged``, with a
   :class:`~kapitza.scenes._sweep_store.DamagedPartWarning` naming it) and computes its
   tile again.  A part that cannot be written (a full disk) leaves nothing behind and
   stops the sweep with an ``OSError`` saying how to resume.  The lock ``_sweep.lock``
   keeps a second sweep of the dataset from writing (it refuses, naming the first, or
   waits: ``wait``); a lock whose process is gone is taken over.
8. **A result too large for memory is not loaded**: where the parts' rows would take
   more than :func:`lagrange_core.memory.memory_limit`, ``SweepResult.frame`` is None
   (read the dataset in pieces with ``pyarrow.dataset``) and the CSV is written part by
   part.  Metadata store the axes compactly (a range as start, stop, num and scale).

Executors
---------
``executor=None`` or ``"local"`` (default): the tiles one after another in this
process, each grid call parallel over numba's threads.  ``"serial"``: the same on
one numba thread.  A ``distributed.Client``: one task per tile on the cluster
(:mod:`kapitza.scenes._sweep_dask`); each task runs on ``worker_threads`` numba threads
(default 1, set in the task's own thread, as numba's count is per thread), so a worker
with k threads uses k cores, and under numba's workqueue layer (which is not
thread-safe) a worker's tasks call their kernels one at a time.  The client
calibrates (rule 1), which warms the on-disk kernel cache once; the workers then
load the kernels from it instead of compiling.  Parts are written by the client as
tasks finish, so the workers need no shared file system.  Every executor gives the
same data, to the bit: a point's result depends on its own inputs only.
"""
from __future__ import annotations

import contextlib
import functools
import json
import math
import os
import sys
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from lagrange_core.module_store import content_key
from lagrange_core.progress import defer_ctrl_c, interrupt_requested

from .. import _arguments as arguments
from ..results import ComputationInterrupted
from ._sweep_store import dataset_lock, record_part, verified_tiles

__all__ = ["SweepResult", "run_sweep", "grid_size", "tile_columns", "numba_threads",
           "package_versions", "write_table", "write_text", "storable", "axis_record",
           "MANIFEST"]

#: The plan of a dataset directory (tile size, points, keys), written before the first tile.
MANIFEST = "_sweep.json"
#: Points of the calibration run (after a first one-point run that loads the kernels).
_PILOT = 8


@dataclass(frozen=True, eq=False)
class SweepResult:
    """A finished (or, in :class:`~kapitza.results.ComputationInterrupted`, partial) sweep.

    Attributes
    ----------
    path : pathlib.Path
        The Parquet dataset (a directory of parts).
    frame : pandas.DataFrame or None
        The finished tiles' rows, in point order (:meth:`to_dataframe`); None where they
        would not fit in memory (module docstring, rule 8).
    metadata : dict
        What every part records (scene, axes, parameters, versions, code fingerprint).
    size : int
        Points in the grid.
    tile_points : int
        Points per tile.
    tiles : int
        Tiles in the grid.
    computed, skipped : int
        Tiles computed by this run, and found finished on disk.
    seconds : float
        Wall time of this run.
    executor : str
        "local", "serial" or "dask".
    """

    path: Path
    frame: object = field(repr=False)
    metadata: dict = field(repr=False)
    size: int
    tile_points: int
    tiles: int
    computed: int
    skipped: int
    seconds: float
    executor: str

    def to_dataframe(self):
        """The sweep's rows: ``point``, the axes, then the analysis's columns."""
        if self.frame is None:
            raise arguments.GridTooLargeError(
                f"the sweep's rows in {self.path} would not fit in memory (the limit: "
                f"{arguments.memory_limit()[1]}); read the dataset in pieces, e.g. "
                f"pyarrow.dataset.dataset('{self.path}').to_batches(), or filter it: "
                f"pandas.read_parquet('{self.path}', filters=[('point', '<', 1000)]).",
                argument="the sweep's rows", shape=(self.size,), needed=math.nan,
                limit=math.nan)
        return self.frame.copy()

    def to_xarray(self):
        """The sweep as one :class:`xarray.Dataset` over its axes (units, the analysis's
        columns as variables, the scene and versions in ``attrs``; a partial sweep's
        missing points NaN): :func:`kapitza.open_sweep` reads the same from the
        directory.  Needs ``pip install "kapitza[xarray]"``."""
        from ._sweep_xarray import sweep_dataset
        return sweep_dataset(self)

    def figure(self, variable=None, **options):
        """One column over the sweep's first two axes (default: the slow frequency where
        the run stayed up, or ``stable``): :func:`kapitza.figures.grid_figure`
        (``select=``, ``mask=``, … go to it)."""
        from ._sweep_xarray import sweep_figure
        return sweep_figure(self, variable, **options)

    def _repr_html_(self) -> str:
        from ._sweep_xarray import sweep_card
        return sweep_card(self)


# -- the grid -----------------------------------------------------------------------------

def grid_size(axes) -> int:
    """Points of the Cartesian product of ``axes``."""
    return int(np.prod([len(a.values) for a in axes], dtype=np.int64))


def tile_columns(axes, points) -> dict:
    """Each axis's value at the flat grid indices ``points`` (C order: first axis slowest)."""
    points = np.asarray(points, dtype=np.int64)
    idx = np.unravel_index(points, tuple(len(a.values) for a in axes))
    return {a.name: np.asarray(a.values, dtype=float)[i] for a, i in zip(axes, idx, strict=True)}


@contextlib.contextmanager
def numba_threads(n):
    """Run the block on ``n`` numba threads (None: unchanged); numba's count is per
    calling thread, so this sets it for the current thread only."""
    if n is None:
        yield
        return
    import numba
    old = numba.get_num_threads()
    numba.set_num_threads(max(1, min(int(n), numba.config.NUMBA_NUM_THREADS)))
    try:
        yield
    finally:
        numba.set_num_threads(old)


_KERNEL_LOCK = threading.Lock()


def _workqueue_layer() -> bool:
    """Whether numba's parallel kernels run (or will run) under the workqueue layer, which
    must not be entered from two threads at once."""
    import importlib

    import numba
    try:
        return numba.threading_layer() == "workqueue"
    except ValueError:              # no parallel kernel has run in this process yet
        if numba.config.THREADING_LAYER == "workqueue":
            return True
        for pool in ("omppool", "tbbpool"):
            try:
                importlib.import_module(f"numba.np.ufunc.{pool}")
                return False
            except ImportError:
                pass
        return True


def compute_tile(work, axes, start, stop, threads=None):
    """The rows of points start … stop − 1: ``work(columns, points)`` with the axis
    columns put in front (``point`` first).  The task a cluster runs, too."""
    points = np.arange(start, stop, dtype=np.int64)
    cols = tile_columns(axes, points)
    guard = _KERNEL_LOCK if threads is not None and _workqueue_layer() else contextlib.nullcontext()
    with numba_threads(threads), guard:
        frame = work(cols, points)
    return _with_axes(frame, axes, cols, points)


def axis_record(axis) -> dict:
    """An axis as metadata record it, compactly: a range as {kind, start, stop, num} (its
    values are ``numpy.linspace``/``geomspace(start, stop, num)``), a list as its
    values."""
    values = [float(v) for v in axis.values]
    if axis.kind in ("linear", "log") and len(values) > 1:
        return {"kind": axis.kind, "start": values[0], "stop": values[-1], "num": len(values)}
    return {"kind": axis.kind, "values": values}


def _with_axes(frame, axes, cols, points):
    import pandas as pd
    frame = frame.reset_index(drop=True)
    pos = np.searchsorted(points, frame["point"].to_numpy())
    front = {"point": frame["point"].to_numpy(dtype=np.int64)}
    front.update({a.name: cols[a.name][pos] for a in axes})
    rest = frame.drop(columns=["point"] + [a.name for a in axes if a.name in frame])
    for c in rest.columns:
        if isinstance(rest[c].dtype, pd.CategoricalDtype):
            rest[c] = rest[c].astype(str)
    return pd.concat([pd.DataFrame(front), rest], axis=1)


# -- metadata, parts ---------------------------------------------------------------------------

def package_versions() -> dict:
    """Versions of Python and of the packages that compute and store a result (a new dict
    each call).

    Read from the installed packages' metadata once per process (~6 ms: every table a
    scene, sweep or report writes records them): the versions of the code this process
    has loaded, which an upgrade during its run does not change."""
    return dict(_package_versions())


@functools.cache
def _package_versions() -> dict:
    from importlib import metadata
    out = {"python": sys.version.split()[0]}
    for name in ("kapitza", "numpy", "scipy", "sympy", "symengine", "numba", "pandas",
                 "pyarrow"):
        try:
            out[name] = metadata.version(name)
        except metadata.PackageNotFoundError:
            out[name] = None
    return out


def _tmp_name(directory: Path, suffix: str) -> Path:
    return directory / f".tmp-{os.getpid()}-{os.urandom(6).hex()}{suffix}"


def write_table(frame, path, metadata: dict | None = None) -> Path:
    """Write ``frame`` as one Parquet file at ``path``, atomically (a temporary file in
    the same directory, then ``os.replace``), with ``metadata`` as JSON under the
    schema key ``kapitza``."""
    import pyarrow as pa
    import pyarrow.parquet as pq
    path = Path(path)
    table = pa.Table.from_pandas(storable(frame), preserve_index=False)
    if metadata is not None:
        meta = dict(table.schema.metadata or {})
        meta[b"kapitza"] = json.dumps(metadata, sort_keys=True, default=str).encode()
        table = table.replace_schema_metadata(meta)
    tmp = _tmp_name(path.parent, ".parquet")
    try:
        pq.write_table(table, tmp)
        os.replace(tmp, path)
    finally:
        if tmp.exists():
            tmp.unlink()
    return path


def storable(frame):
    """``frame`` with what Parquet cannot hold spelled out: a complex column as
    ``<name>_real`` and ``<name>_imag``, a column of tuples or arrays as text."""
    out = {}
    for c in frame.columns:
        col = frame[c]
        if np.iscomplexobj(col.to_numpy()):
            values = col.to_numpy(dtype=complex)
            out[f"{c}_real"], out[f"{c}_imag"] = values.real, values.imag
        elif col.dtype == object and len(col) and isinstance(col.iloc[0], (tuple, list,
                                                                           np.ndarray)):
            out[c] = col.map(lambda v: json.dumps(np.asarray(v).tolist()))
        else:
            out[c] = col
    import pandas as pd
    return pd.DataFrame(out, index=frame.index)


def write_text(path: Path, text: str):
    """Write ``text`` at ``path`` atomically (a temporary file, then ``os.replace``)."""
    tmp = _tmp_name(path.parent, path.suffix)
    try:
        tmp.write_text(text)
        os.replace(tmp, path)
    finally:
        if tmp.exists():
            tmp.unlink()


def _remove_stray_temporaries(directory: Path):
    """Temporary files of processes that no longer run (killed while writing)."""
    for p in directory.glob(".tmp-*"):
        try:
            pid = int(p.name.split("-")[1])
            os.kill(pid, 0)
        except ProcessLookupError:
            p.unlink(missing_ok=True)
        except (ValueError, IndexError, PermissionError, OSError):
            pass


@dataclass(frozen=True)
class _Plan:
    key: str
    fingerprint: str
    size: int
    tile_points: int

    @property
    def tiles(self) -> int:
        return -(-self.size // self.tile_points)

    def bounds(self, i):
        return i * self.tile_points, min(self.size, (i + 1) * self.tile_points)

    def part(self, i) -> str:
        start, stop = self.bounds(i)
        key = content_key(self.key, f"points {start}:{stop}", self.fingerprint)
        return f"part-{i:06d}-{key[:16]}.parquet"


def _warm(work, axes):
    """Run the work on one point: it compiles, or loads from the on-disk cache, every
    kernel it needs (so a cluster's workers find them there)."""
    first = np.zeros(1, dtype=np.int64)
    with numba_threads(1):
        work(tile_columns(axes, first), first)


def _calibrate(work, axes, size, tile_seconds) -> int:
    """Points per tile: ``tile_seconds`` of the work on one numba thread, measured on
    pilots spread over the grid (after one point that loads or compiles the kernels).

    A call costs a fixed time plus a time per point.  Where 8 points take under a quarter
    of ``tile_seconds`` (the fixed cost may dominate them) a pilot of 64 points is timed
    too, and the two separate the costs; a tile is then ``tile_seconds`` of both."""
    _warm(work, axes)
    n1, t1 = _pilot(work, axes, size, _PILOT)
    per_point, fixed = t1 / n1, 0.0
    if t1 < tile_seconds / 4 and n1 < size:
        n2, t2 = _pilot(work, axes, size, 8 * _PILOT)
        # the slope, not less than a tenth of the mean (timing noise must not make a
        # tile huge)
        per_point = max((t2 - t1) / (n2 - n1), 0.1 * t2 / n2)
        fixed = min(max(0.0, t1 - per_point * n1), tile_seconds / 2)
    points = (tile_seconds - fixed) / max(per_point, 1e-9)
    return int(max(1, min(size, math.ceil(points))))


def _pilot(work, axes, size, n) -> tuple[int, float]:
    """(points, seconds) of the work on ``n`` points spread over the grid, one numba
    thread: run until two runs agree within 30 % (at most 4 times; a pilot may still
    load code that one point did not need), the fastest."""
    pilot = np.unique(np.linspace(0, size - 1, min(size, n)).round().astype(np.int64))
    cols = tile_columns(axes, pilot)
    times = []
    with numba_threads(1):
        while len(times) < 4 and not (len(times) >= 2 and times[-1] > 0.7 * times[-2]
                                      and times[-1] < times[-2] / 0.7):
            t0 = time.perf_counter()
            work(cols, pilot)
            times.append(time.perf_counter() - t0)
    return len(pilot), min(times)


def _plan(directory: Path, work, axes, key, fingerprint, tile_points, tile_seconds):
    size = grid_size(axes)
    manifest = directory / MANIFEST
    if manifest.exists():
        saved = json.loads(manifest.read_text())
        if (saved.get("key"), saved.get("fingerprint"), saved.get("size")) != (key, fingerprint,
                                                                                size):
            raise ValueError(f"{directory} holds another sweep (another scene, grid or code "
                             f"version; see its {MANIFEST}); give another directory or remove "
                             "it.")
        if tile_points is not None and tile_points != saved["tile_points"]:
            raise ValueError(f"{directory} was cut into tiles of {saved['tile_points']} points; "
                             f"tile_points={tile_points} would recompute them. Pass "
                             f"tile_points={saved['tile_points']} (or None), or remove the "
                             "directory.")
        return _Plan(key, fingerprint, size, int(saved["tile_points"])), False
    calibrated = tile_points is None
    if calibrated:
        tile_points = _calibrate(work, axes, size, tile_seconds)
    plan = _Plan(key, fingerprint, size, int(tile_points))
    write_text(manifest, json.dumps({"key": key, "fingerprint": fingerprint, "size": size,
                                      "tile_points": plan.tile_points, "tiles": plan.tiles,
                                      "axes": {a.name: axis_record(a) for a in axes},
                                      "created": time.strftime("%Y-%m-%dT%H:%M:%S%z")},
                                     indent=1))
    return plan, calibrated


class _NoBar:
    """The bar of ``progress=False``: nothing drawn, and nothing of tqdm imported (its
    notebook detection warns in a Jupyter kernel without ipywidgets)."""

    def update(self, n=1):
        pass

    def close(self):
        pass


def _in_notebook_with_widgets() -> bool:
    """A Jupyter kernel (not a Qt console or Spyder) with ipywidgets installed: where
    tqdm's notebook bar draws (the test of ``tqdm.autonotebook``, without its warning)."""
    if "ipykernel.zmqshell" not in sys.modules:
        return False
    if any(k == "QT_API" or k.startswith("SPYDER") for k in os.environ):
        return False
    try:
        import ipywidgets  # noqa: F401
    except ImportError:
        return False
    return True


def _bar(progress, total, initial, label):
    if progress is False:
        return _NoBar()
    if _in_notebook_with_widgets():
        from tqdm.notebook import tqdm
    else:
        from tqdm import tqdm
    disable = None if progress is None else not progress
    # a terminal that reports no size (a pseudo-terminal nobody sized: script(1), CI
    # runners, editors' shells) made tqdm draw nothing at all: 80 × 24 there
    try:
        sized = min(os.get_terminal_size(sys.stderr.fileno())) > 0
    except (AttributeError, OSError, ValueError):
        sized = False
    return tqdm(total=total, initial=initial, unit="pt", desc=label, disable=disable,
                file=sys.stderr, dynamic_ncols=sized, ncols=None if sized else 80,
                nrows=None if sized else 24, leave=True)


# -- running ----------------------------------------------------------------------------------

def run_sweep(work, axes, directory, *, key: str, fingerprint: str, metadata: dict,
              tile_points: int | None = None, tile_seconds: float = 0.5, executor=None,
              worker_threads: int = 1, progress=None, csv: bool = False,
              label: str = "sweep", wait=False) -> SweepResult:
    """Compute ``work`` over the grid of ``axes`` tile by tile into the dataset ``directory``.

    Parameters
    ----------
    work : callable (columns, points) -> pandas.DataFrame
        ``columns`` maps each axis name to its values at the flat indices ``points``; the
        frame has a column ``point`` (those indices) and one or more rows per point.
        Picklable (a module-level object) for a cluster.
    axes : sequence of :class:`kapitza.scenes.Axis`
    directory : path
        The dataset's directory (created).
    key : str
        What the data depend on besides the code (the scene and the analysis).
    fingerprint : str
        The code's fingerprint.
    metadata : dict
        JSON-able record stored with every part (the versions and fingerprint are added).
    tile_points : int, optional
        Points per tile (default: calibrated, see the module docstring).
    tile_seconds : float
        One-thread seconds of work per calibrated tile.
    executor : None, "local", "serial" or a distributed.Client
    worker_threads : int
        numba threads per task on a cluster.
    progress : None, bool
    csv : bool
        Also write ``<directory>.csv``.
    label : str
        The progress bar's label.
    wait : bool or float
        Another sweep writing the dataset: refuse (False), wait for it (True) or wait at
        most this many seconds.

    Returns
    -------
    SweepResult

    Raises
    ------
    kapitza.results.ComputationInterrupted
        On Ctrl-C, with the finished tiles in ``.result`` and ``.computed`` marking their
        points.
    ValueError
        The directory holds another sweep, or was cut into other tiles.
    kapitza.scenes._sweep_store.SweepLockedError
        Another sweep writes the dataset (a ValueError naming it).
    OSError
        A part could not be written (e.g. no space): nothing of it is left behind, the
        finished tiles are kept, and the same sweep run again resumes.

    Warns
    -----
    kapitza.scenes._sweep_store.DamagedPartWarning
        A part on disk failed its check: moved aside, its tile computed again.
    """
    start_time = time.perf_counter()
    axes = tuple(axes)
    if not axes:
        raise ValueError("a sweep needs at least one axis.")
    directory = Path(directory)
    directory.mkdir(parents=True, exist_ok=True)
    mode = _executor_name(executor)
    with dataset_lock(directory, wait):
        _remove_stray_temporaries(directory)
        plan, calibrated = _plan(directory, work, axes, key, fingerprint, tile_points,
                                 tile_seconds)
        return _run_plan(work, axes, directory, plan, calibrated, metadata, executor, mode,
                         worker_threads, progress, csv, label, start_time)


def _run_plan(work, axes, directory, plan, calibrated, metadata, executor, mode,
              worker_threads, progress, csv, label, start_time):
    """The tiles of ``plan`` not finished on disk (the dataset's lock held)."""
    meta = dict(metadata, fingerprint=plan.fingerprint, versions=package_versions(),
                tile_points=plan.tile_points, tiles=plan.tiles, size=plan.size,
                axes={a.name: axis_record(a) for a in axes})
    done = verified_tiles(directory, plan)
    todo = [i for i in range(plan.tiles) if i not in set(done)]
    skipped = len(done)
    points_done = sum(np.subtract(*plan.bounds(i)[::-1]) for i in done)
    bar = _bar(progress, plan.size, int(points_done), label)
    computed = []

    def finish(i, frame):
        if i in computed:           # a retried task that finished twice: one part per tile
            return
        path = directory / plan.part(i)
        try:
            write_table(frame, path, dict(meta, tile=list(plan.bounds(i))))
            record_part(directory, path, len(frame))
        except OSError as e:
            kept = skipped + len(computed)
            raise OSError(e.errno, f"sweep {directory}: the part of tile {i} could not be "
                          f"written ({e.strerror or e}); nothing of it is left behind and "
                          f"the {kept} finished tiles are kept. Free the space (or fix the "
                          "cause) and run the same sweep again: it resumes.") from e
        computed.append(i)
        bar.update(plan.bounds(i)[1] - plan.bounds(i)[0])

    try:
        if mode == "dask":
            from . import _sweep_dask as sweep_dask
            if todo and not calibrated:
                _warm(work, axes)       # the workers load the kernels from the disk cache
            sweep_dask.run_tiles(executor, compute_tile, work, axes,
                                 {i: plan.bounds(i) for i in todo}, worker_threads, finish)
        else:
            _run_local(work, axes, plan, todo, 1 if mode == "serial" else None, finish)
    except KeyboardInterrupt:
        bar.close()
        partial = _result(directory, plan, meta, skipped, computed, start_time, mode, csv=False)
        finished = np.zeros(plan.size, dtype=bool)
        for i in done + computed:
            a, b = plan.bounds(i)
            finished[a:b] = True
        raise ComputationInterrupted(partial, finished) from None
    finally:
        bar.close()
    return _result(directory, plan, meta, skipped, computed, start_time, mode, csv=csv,
                   complete=True)


def _executor_name(executor) -> str:
    if executor is None or executor == "local":
        return "local"
    if executor == "serial":
        return "serial"
    if hasattr(executor, "submit") and hasattr(executor, "gather"):
        return "dask"
    raise ValueError(f"executor must be None, 'local', 'serial' or a distributed.Client, got "
                     f"{executor!r}.")


def _run_local(work, axes, plan, todo, threads, finish):
    with defer_ctrl_c():
        for i in todo:
            if interrupt_requested():
                raise KeyboardInterrupt
            start, stop = plan.bounds(i)
            with numba_threads(threads):
                frame = compute_tile(work, axes, start, stop)
            finish(i, frame)
        if interrupt_requested():      # Ctrl-C during the last part's write: all is done
            raise KeyboardInterrupt


def _result(directory, plan, meta, skipped, computed, start_time, mode, *, csv,
            complete=False) -> SweepResult:
    import pyarrow as pa
    import pyarrow.parquet as pq
    parts = [p for p in (directory / plan.part(i) for i in range(plan.tiles)) if p.exists()]
    files = [pq.ParquetFile(p) for p in parts]
    schema = (pa.unify_schemas([f.schema_arrow for f in files], promote_options="permissive")
              if files else None)
    # the rows' size in memory: the parts' uncompressed bytes (rule 8)
    in_memory = sum(f.metadata.row_group(k).total_byte_size for f in files
                    for k in range(f.metadata.num_row_groups))
    limit = arguments.memory_limit()[0]
    frame = _read_frame(parts) if limit is None or in_memory <= limit else None
    if complete and schema is not None:
        common = schema.with_metadata(
            dict(schema.metadata or {},
                 kapitza=json.dumps(meta, sort_keys=True, default=str).encode()))
        tmp = _tmp_name(directory, ".parquet")
        try:
            pq.write_metadata(common, tmp)
            os.replace(tmp, directory / "_common_metadata")
        finally:
            if tmp.exists():
                tmp.unlink()
        if csv:
            _write_csv(directory.parent / f"{directory.name}.csv", parts, schema.names, frame)
    return SweepResult(path=directory, frame=frame, metadata=meta, size=plan.size,
                       tile_points=plan.tile_points, tiles=plan.tiles, computed=len(computed),
                       skipped=skipped, seconds=time.perf_counter() - start_time, executor=mode)


def _read_frame(parts):
    import pandas as pd
    import pyarrow as pa
    import pyarrow.parquet as pq
    if not parts:
        return pd.DataFrame()
    return pa.concat_tables([pq.read_table(p) for p in parts],
                            promote_options="permissive").to_pandas()


def _write_csv(path: Path, parts, columns, frame):
    """The dataset as one CSV file, atomically: from ``frame``, or part by part where the
    rows were not loaded (each part's columns in the dataset's order)."""
    if frame is not None:
        write_text(path, frame.to_csv(index=False))
        return
    import pyarrow.parquet as pq
    tmp = _tmp_name(path.parent, path.suffix)
    try:
        with open(tmp, "w") as f:
            for k, p in enumerate(parts):
                part = pq.read_table(p).to_pandas().reindex(columns=columns)
                part.to_csv(f, index=False, header=k == 0)
        os.replace(tmp, path)
    finally:
        if tmp.exists():
            tmp.unlink()
