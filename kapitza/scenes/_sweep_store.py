"""The integrity of a sweep's dataset: the ledger of finished parts, the check of each part
on resume, and the lock that keeps two sweeps from writing one dataset.

Used by :func:`kapitza.scenes._sweep.run_sweep` (the rules of the store are in
:mod:`kapitza.scenes._sweep`); here is how they hold when things go wrong.

* **The ledger** ``_parts.jsonl``: one line per finished part — its name, rows, bytes and
  SHA-256 — appended right after the part is renamed into place.
* **On resume every part is checked** (:func:`verified_tiles`): a part with a ledger line
  must have its bytes and checksum; a part without one (a process killed between the
  rename and the ledger line, or a dataset of an older kapitza) must read whole and hold
  exactly its tile's points, and is then entered in the ledger.  A damaged part (cut
  short by a full disk or an interrupted copy, changed by hand) is renamed aside to
  ``_<part>.damaged`` (a leading ``_`` keeps it out of the Parquet dataset), a
  :class:`DamagedPartWarning` names it, and its tile is computed again.
* **The lock** ``_sweep.lock``, created exclusively (``O_CREAT | O_EXCL``) with the
  owner's pid, host and start time: a second sweep of the same dataset refuses
  (:class:`SweepLockedError`, naming the first) or, with ``wait``, waits for it.  A lock
  whose process is gone (same host, pid not running) is stale and taken over; a lock of
  another host is never assumed stale.
"""
from __future__ import annotations

import contextlib
import hashlib
import json
import math
import os
import socket
import time
import warnings
from pathlib import Path

import numpy as np

from lagrange_core.progress import interrupt_requested

__all__ = ["LEDGER", "LOCK", "DamagedPartWarning", "SweepLockedError", "sha256_file",
           "record_part", "verified_tiles", "dataset_lock"]

#: One JSON line per finished part.
LEDGER = "_parts.jsonl"
#: The lock of a dataset being written.
LOCK = "_sweep.lock"
#: How often a waiting sweep looks at the lock again (s).
_POLL = 0.2
#: Age (s) past which a lock file that is empty or unreadable (its writer killed between
#: creating and filling it) counts as stale.
_UNREADABLE_LOCK_AGE = 10.0


class DamagedPartWarning(UserWarning):
    """A part of a sweep's dataset failed its check on resume: it was moved aside and its
    tile is computed again."""


class SweepLockedError(ValueError):
    """Another sweep is writing this dataset (its pid, host and start time are in the
    message and in ``holder``)."""

    def __init__(self, message, holder):
        super().__init__(message)
        self.holder = holder


def sha256_file(path) -> str:
    """The SHA-256 of a file's bytes (hex)."""
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


# -- the ledger ---------------------------------------------------------------------------------

def read_ledger(directory: Path) -> dict:
    """Part name → its record (the last line of a part wins; a line cut short by a crash
    is ignored, and its part then checked by reading it)."""
    out = {}
    try:
        text = (directory / LEDGER).read_text()
    except FileNotFoundError:
        return out
    for line in text.splitlines():
        try:
            rec = json.loads(line)
            out[rec["part"]] = rec
        except (ValueError, KeyError, TypeError):
            continue
    return out


def record_part(directory: Path, path: Path, rows: int):
    """Append the record of the finished part ``path`` to the ledger, in one write (an
    appended line is whole or cut short, and a line cut short is ignored).  Not synced to
    disk: a record lost in a crash only means its part is checked by reading it, and a
    part whose bytes a crash lost fails its record's checksum."""
    rec = {"part": path.name, "rows": int(rows), "bytes": path.stat().st_size,
           "sha256": sha256_file(path)}
    line = (json.dumps(rec, sort_keys=True) + "\n").encode()
    fd = os.open(directory / LEDGER, os.O_WRONLY | os.O_CREAT | os.O_APPEND, 0o644)
    try:
        os.write(fd, line)
    finally:
        os.close(fd)


def _check_part(path: Path, bounds, rec) -> str | None:
    """Why the part at ``path`` is damaged, or None if it is whole."""
    size = path.stat().st_size
    if rec is not None:
        if size != rec.get("bytes"):
            return f"{size} bytes, the ledger recorded {rec.get('bytes')}"
        if sha256_file(path) != rec.get("sha256"):
            return "its SHA-256 differs from the ledger's"
        return None
    import pyarrow.parquet as pq
    try:
        points = pq.read_table(path, columns=["point"]).column("point").to_numpy()
    except Exception as e:      # pyarrow's errors for a file cut short are of several types
        return f"unreadable ({type(e).__name__}: {e})"
    start, stop = bounds
    if not np.array_equal(np.unique(points), np.arange(start, stop)):
        return f"its rows are not the points {start}…{stop - 1} of its tile"
    return None


def _move_aside(path: Path) -> Path:
    target = path.with_name(f"_{path.name}.damaged")
    k = 1
    while target.exists():
        k += 1
        target = path.with_name(f"_{path.name}.{k}.damaged")
    os.replace(path, target)
    return target


def verified_tiles(directory: Path, plan) -> list:
    """The tiles whose parts are whole (module docstring); each damaged part is moved
    aside with a :class:`DamagedPartWarning`, and each whole part without a ledger line
    is entered in the ledger."""
    ledger = read_ledger(directory)
    done = []
    for i in range(plan.tiles):
        path = directory / plan.part(i)
        if not path.exists():
            continue
        rec = ledger.get(path.name)
        why = _check_part(path, plan.bounds(i), rec)
        if why is None:
            if rec is None:
                import pyarrow.parquet as pq
                record_part(directory, path, pq.read_metadata(path).num_rows)
            done.append(i)
            continue
        aside = _move_aside(path)
        start, stop = plan.bounds(i)
        warnings.warn(f"sweep {directory}: the part {path.name} (tile {i}, points "
                      f"{start}…{stop - 1}) is damaged: {why}. It was moved aside to "
                      f"{aside.name} and its tile is computed again.", DamagedPartWarning,
                      stacklevel=3)
    return done


# -- the lock -------------------------------------------------------------------------------

def _pid_running(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:         # another user's process: it runs
        return True
    except OSError:
        return True
    return True


def _read_lock(path: Path):
    try:
        return json.loads(path.read_text())
    except FileNotFoundError:
        return None
    except (ValueError, OSError):
        return {}


def _stale(path: Path, holder) -> bool:
    if holder is None:
        return False                        # gone already: try again
    if not holder:                          # empty or unreadable: stale once it is old
        try:
            return time.time() - path.stat().st_mtime > _UNREADABLE_LOCK_AGE
        except FileNotFoundError:
            return False
    if holder.get("host") != socket.gethostname():
        return False
    pid = holder.get("pid")
    return isinstance(pid, int) and not _pid_running(pid)


def _take_over(path: Path, holder) -> bool:
    """Remove the stale lock ``holder``: renamed aside first (atomic: of two sweeps that
    find it stale, one wins), then checked to be the lock judged stale."""
    aside = path.with_name(f".{LOCK}.stale-{os.getpid()}-{os.urandom(4).hex()}")
    try:
        os.replace(path, aside)
    except FileNotFoundError:
        return False
    if _read_lock(aside) != holder:         # another sweep's fresh lock: put it back
        with contextlib.suppress(OSError):
            os.link(aside, path)
        aside.unlink(missing_ok=True)
        return False
    aside.unlink(missing_ok=True)
    return True


def _describe(holder) -> str:
    if not holder:
        return "a sweep whose lock file is empty or unreadable"
    return (f"the sweep of pid {holder.get('pid')} on host {holder.get('host')}, started "
            f"{holder.get('started')}")


@contextlib.contextmanager
def dataset_lock(directory: Path, wait=False):
    """Hold the dataset's lock for the block.

    ``wait``: False (refuse at once if another sweep holds it), True (wait for as long as
    it takes; Ctrl-C stops waiting) or a number of seconds.
    """
    path = directory / LOCK
    if isinstance(wait, bool):
        deadline = math.inf if wait else 0.0
    else:
        deadline = float(wait)
    t0 = time.monotonic()
    token = os.urandom(8).hex()
    while True:
        try:
            fd = os.open(path, os.O_CREAT | os.O_EXCL | os.O_WRONLY, 0o644)
        except FileExistsError:
            holder = _read_lock(path)
            if _stale(path, holder):
                if _take_over(path, holder):
                    warnings.warn(f"sweep {directory}: took over the lock of "
                                  f"{_describe(holder)}, which no longer runs.", stacklevel=4)
                continue
            if holder is None:
                continue
            if time.monotonic() - t0 >= deadline:
                raise SweepLockedError(
                    f"{directory} is being written by {_describe(holder)} (lock file "
                    f"{path}); wait for it to finish (wait=True, `kapitza sweep --wait`), "
                    "or give another directory. If that sweep no longer runs, remove the "
                    "lock file.", holder) from None
            if interrupt_requested():
                raise KeyboardInterrupt from None
            time.sleep(_POLL)
            continue
        with os.fdopen(fd, "w") as f:
            json.dump({"pid": os.getpid(), "host": socket.gethostname(),
                       "started": time.strftime("%Y-%m-%dT%H:%M:%S%z"), "token": token}, f)
        break
    try:
        yield
    finally:
        held = _read_lock(path)
        if held and held.get("token") == token:
            path.unlink(missing_ok=True)
