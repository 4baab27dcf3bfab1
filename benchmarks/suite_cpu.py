"""Where the test suite's CPU goes: a pytest plugin that charges every test the CPU-seconds
its process spent on it and those of the subprocesses it waited for, and prints the sum per
test file at the end of the run.

    PYTHONPATH=benchmarks python -m pytest -p suite_cpu

The warm suite is CPU-bound (three workers on two cores), so its wall time follows its
CPU-seconds, and these are what a change to the tests or the library must cut
(benchmarks/README.md, issue 24.3).  Per test: the worker's own user + sys CPU from set-up
to tear-down (a shared fixture's set-up is charged to the first test that uses it) and the
CPU of the children it reaped meanwhile (subprocesses, kernels, a Dask cluster's workers
when it closes); with xdist, each worker writes its rows to ``$SUITE_CPU_DIR`` (default
``kapitza-suite-cpu`` in the temporary folder, emptied at the start) and the controller adds
them up.
The rows stay there as ``<pid>.tsv`` (node id, own CPU-s, children's CPU-s, wall s) for a
closer look.  A child that outlives its test, or is never waited for (a killed
grandchild), is charged to no test: compare the total with ``/usr/bin/time``'s.

The shared machine's speed is not the same from one day to the next (on 2026-11-29 the
warm suite took 1.5× its CPU-s of the day before, the same code, its files 1.3–2×): the
summary ends with a *yardstick*, the CPU-s of a fixed pure-Python loop timed in the
controller after the run (the best of three), and the total divided by it — the figure
to compare between days.
"""
from __future__ import annotations

import collections
import os
import shutil
import tempfile
import time
from pathlib import Path

import pytest

_ROWS: list[tuple[str, float, float, float]] = []
#: files printed at the end of the run, the costliest first
TOP = 30
#: steps of the yardstick's loop (0.20 CPU-s on the 2026-11-29 machine)
YARDSTICK_STEPS = 3_000_000


def _folder() -> Path:
    default = Path(tempfile.gettempdir()) / "kapitza-suite-cpu"
    return Path(os.environ.get("SUITE_CPU_DIR", default)).resolve()


def yardstick() -> float:
    """CPU-s of a fixed pure-Python loop, the best of three: the machine's speed now."""
    best = float("inf")
    for _ in range(3):
        start = time.process_time()
        total = 0
        for i in range(YARDSTICK_STEPS):
            total += i
        best = min(best, time.process_time() - start)
    return best


def pytest_configure(config):
    if not hasattr(config, "workerinput"):          # the controller, or a run without -n
        shutil.rmtree(_folder(), ignore_errors=True)
        _folder().mkdir(parents=True)


@pytest.hookimpl(hookwrapper=True)
def pytest_runtest_protocol(item, nextitem):
    before = os.times()
    yield
    after = os.times()
    _ROWS.append((item.nodeid,
                  (after.user + after.system) - (before.user + before.system),
                  (after.children_user + after.children_system)
                  - (before.children_user + before.children_system),
                  after.elapsed - before.elapsed))


def pytest_sessionfinish(session):
    if _ROWS:
        with open(_folder() / f"{os.getpid()}.tsv", "w") as rows:
            rows.writelines(f"{node}\t{own:.3f}\t{children:.3f}\t{wall:.3f}\n"
                            for node, own, children, wall in _ROWS)


def pytest_terminal_summary(terminalreporter):
    own, children = collections.Counter(), collections.Counter()
    for path in _folder().glob("*.tsv"):
        for line in path.read_text().splitlines():
            nodeid, mine, theirs, _ = line.rsplit("\t", 3)
            name = nodeid.split("::")[0]
            own[name] += float(mine)
            children[name] += float(theirs)
    if not own:
        return
    total = {name: own[name] + children[name] for name in own}
    write = terminalreporter.write_line
    terminalreporter.section("CPU-s per test file (suite_cpu)")
    write(f"{'all':>8s} {'own':>8s} {'children':>8s}  file")
    for name, cpu in sorted(total.items(), key=lambda kv: -kv[1])[:TOP]:
        write(f"{cpu:8.1f} {own[name]:8.1f} {children[name]:8.1f}  {name}")
    write(f"{sum(total.values()):8.1f} {sum(own.values()):8.1f} "
          f"{sum(children.values()):8.1f}  all {len(total)} files")
    stick = yardstick()
    write(f"yardstick: a {YARDSTICK_STEPS:.0e}-step Python loop {stick:.3f} CPU-s; "
          f"the suite's CPU-s in yardsticks: {sum(total.values()) / stick:.0f}")
