"""Scale-out of sweeps on a Dask ``distributed`` cluster: one task per tile.

Used by :func:`kapitza.scenes._sweep.run_sweep` when its ``executor`` is a
``distributed.Client`` (the optional extra ``kapitza[dask]``); the rules of the
store and the guarantees are in :mod:`kapitza.scenes._sweep`.

* One task per tile: a tile is ≥ ~100 ms of compiled work, far above Dask's
  0.2–1 ms per task.
* The workers do not oversubscribe the cores: a task sets numba's thread count in
  its own thread (numba counts per thread) to ``worker_threads`` (default 1), so a
  worker with k threads runs at most k·worker_threads numba threads; under numba's
  workqueue layer a worker's tasks call their kernels one at a time
  (:func:`kapitza.scenes._sweep.compute_tile`).
* :class:`WorkerSettings`, registered once per client, imports kapitza in every
  worker and sets numba's count for the worker's own thread as well.  The kernels
  come from the on-disk cache (``$LAGRANGE_CORE_CACHE``, inherited by local workers;
  a cluster's workers need it on a shared disk or warmed by the same installation),
  warmed by the client's calibration run before anything is submitted.
* The client writes each part as its task finishes (workers need no shared disk); on
  Ctrl-C it cancels the tasks not finished.
* A failed tile is computed again: a worker that dies mid-tile has its tasks rescheduled
  by the scheduler (up to its ``allowed-failures``), and a task that raises is retried
  :data:`RETRIES` times before its error stops the sweep.  A tile's part is written once,
  whichever attempt finishes (:func:`kapitza.scenes._sweep.run_sweep`): no point is lost
  or duplicated.
"""
from __future__ import annotations

try:
    from distributed import WorkerPlugin, as_completed
except ImportError:         # the optional extra is absent: run_tiles says so
    WorkerPlugin, as_completed = object, None

__all__ = ["WorkerSettings", "run_tiles", "RETRIES"]

#: Retries of a tile whose task raised (a worker out of memory, a transient failure); a
#: mistake in the work raises the same on every try and stops the sweep after them.
RETRIES = 2


class WorkerSettings(WorkerPlugin):
    """Set up a worker for sweeps: import kapitza's compiled modules once, and numba's
    thread count for the worker's thread."""

    name = "kapitza-sweep"

    def __init__(self, threads: int = 1):
        self.threads = int(threads)

    def setup(self, worker):
        import numba

        import kapitza  # noqa: F401 - loads the analyses before the first task
        numba.set_num_threads(max(1, min(self.threads, numba.config.NUMBA_NUM_THREADS)))


def run_tiles(client, task, work, axes, bounds: dict, threads: int, finish):
    """Submit ``task(work, axes, start, stop, threads)`` for every tile of ``bounds``
    (index → (start, stop)) and call ``finish(index, frame)`` as each completes."""
    if as_completed is None:
        raise ImportError("a sweep on a Dask cluster needs the optional extra: "
                          "pip install 'kapitza[dask]' (dask[distributed]).")
    client.register_plugin(WorkerSettings(threads))
    futures = {client.submit(task, work, axes, start, stop, threads, pure=False,
                             retries=RETRIES): i
               for i, (start, stop) in bounds.items()}
    try:
        for fut in as_completed(futures):
            finish(futures[fut], fut.result())
    except BaseException:
        client.cancel(list(futures))
        raise
