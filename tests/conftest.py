"""Shared test fixtures, and how the suite is spread over the workers.

With ``--dist loadgroup`` (pyproject.toml) each test file is one group, so a file's tests
share a worker and the systems it compiles (as ``--dist loadfile`` did); the studies are
one group each, so the workers share them instead of one running all of them at the end.
The longest groups are handed out first (``_FIRST``): the run ends on short groups.
"""
import gc
import os

# A worker (pytest-xdist sets this before it reads this file) imports every test module and
# both packages while it collects: Python's cyclic collector is off until the collection
# ends (pytest_collection_finish): its passes walked the ~600 000 objects that sympy, numba
# and the rest keep alive again and again (the collector's CPU in a worker's whole run
# 2.8–3.1 → 2.2–2.5 s, 3050–3850 → 2000–2660 passes; a collection alone in one process
# 8.6, 7.9 → 6.0, 6.4 CPU-s; the same peak memory; 2026-11-29)
_COLLECTOR_OFF_WHILE_COLLECTING = bool(os.environ.get("PYTEST_XDIST_WORKER"))
if _COLLECTOR_OFF_WHILE_COLLECTING:
    gc.disable()

import numpy as np  # noqa: E402
import pytest  # noqa: E402
from hypothesis import HealthCheck, settings  # noqa: E402

os.environ.setdefault("MPLBACKEND", "Agg")
# On a cold cache (a fresh clone) the first compile prints a one-line notice on stderr, and
# `kapitza report` compiles its later sections in a background process: tests that compare
# stderr, and workers that already use every core, want neither (tests/test_cold_start.py
# switches the notice back on where it is the subject).
os.environ.setdefault("LAGRANGE_CORE_COMPILE_NOTICE", "0")
os.environ.setdefault("KAPITZA_BACKGROUND_COMPILE", "0")
# Two workers share the machine: a grid that passes the memory check (by default half the
# machine's memory, for one process) could take 12 GiB in each, and the kernel's OOM killer
# then ends a worker (xdist may wait for its tests for ever).  The property tests draw
# such grids (a scene axis of 10⁸ values): in the suite a grid may take 4 GiB.
os.environ.setdefault("KAPITZA_MEMORY_LIMIT_GIB", "4")

# A guard for the suite's processes: a test whose process grows past
# KAPITZA_TEST_RSS_LIMIT_GIB (default 6: three workers on a 24 GiB machine) fails with a
# MemoryError raised in it, where it allocates, instead of the kernel's OOM killer ending
# the worker (after which xdist's group scheduling waits for ever, and the run shows
# neither the test nor the place).  Checked every 0.1 s from a daemon thread.
_RSS_LIMIT = float(os.environ.get("KAPITZA_TEST_RSS_LIMIT_GIB", "6")) * 2**30


def _rss_guard():
    import ctypes
    import threading
    import time

    main = threading.main_thread().ident
    page = os.sysconf("SC_PAGE_SIZE")

    def watch():
        while True:
            time.sleep(0.1)
            try:
                with open("/proc/self/statm") as f:
                    rss = int(f.read().split()[1]) * page
            except OSError:
                return
            if rss > _RSS_LIMIT:
                ctypes.pythonapi.PyThreadState_SetAsyncExc(
                    ctypes.c_ulong(main), ctypes.py_object(MemoryError))
                time.sleep(2.0)     # let it unwind and free before looking again

    if os.path.exists("/proc/self/statm") and _RSS_LIMIT > 0:
        threading.Thread(target=watch, name="rss-guard", daemon=True).start()


_rss_guard()

# Property-based tests (tests/test_properties_*.py).  "ci", the default: few examples, the
# same ones every run (derandomized: a failure reproduces, and the kernels of the random
# systems stay in the disk cache), no example database, no per-example deadline (the
# machine is shared; each test bounds its own inputs).  "thorough", by hand
# (``pytest -n 0 tests/test_properties_*.py --hypothesis-profile=thorough``): 20 times as many,
# freshly random, the failures kept in ./.hypothesis; add --timeout=0, as a thorough test
# runs longer than pytest-timeout's 600 s (tests/test_properties_equations.py ~20 min,
# compiling kernels for hundreds of statements).  A test asks for a multiple of
# ``max_examples``, so both profiles scale it.
_PROPERTY_CHECKS = dict(deadline=None, suppress_health_check=[HealthCheck.too_slow],
                        print_blob=True)
settings.register_profile("ci", max_examples=10, derandomize=True, database=None,
                          **_PROPERTY_CHECKS)
settings.register_profile("thorough", max_examples=200, **_PROPERTY_CHECKS)
settings.load_profile("ci")

#: Test files that take longest, in that order, started first (the longest first, so that
#: the run ends on short groups: at the end, one worker running a long group while the
#: others idle is what makes a run long); the rest keep their collection order, the
#: doctests last.  The order is each file's time summed over its tests (its group's, for
#: the files that share one), warm and on a fresh clone (where the per-point reference
#: kernels of test_batch_speedpath.py and test_first_order_lanes.py compile), 2026-11-28.
#: pyproject.toml's ``--no-loadscope-reorder`` makes pytest-xdist hand the groups out in
#: this order: by default it hands out the groups with the most tests first, and so the
#: notebooks and the studies (a test a group) came last (measured: the run's last 14 s
#: were notebooks, two workers idle).
_FIRST = ("test_report_browser.py", "test_report.py", "test_docs.py", "test_docs_browser.py",
          "test_properties_equations.py", "test_batch_speedpath.py", "test_long_runs.py",
          "test_first_order_lanes.py", "test_sweeps.py", "test_integrators_compiled_once.py",
          "test_properties_cli.py", "test_ctrl_c_compiling.py", "test_floquet_edges.py",
          "test_notebooks.py", "test_batch_physics.py", "test_report_scenes.py",
          "test_studies.py", "test_xarray.py", "test_core_codegen.py", "test_cli_pty.py",
          "test_animation.py", "test_repr_html.py", "test_cold_start.py",
          "test_averaging_edges.py", "test_batch.py", "test_lyapunov.py",
          "test_continuation.py", "test_floquet_boundaries.py", "test_verify.py")


def pytest_xdist_auto_num_workers(config):
    """``-n auto`` (pyproject.toml): one worker more than the cores this process may use.
    About a tenth of a worker's time is spent waiting — on a CLI or Ctrl-C test's
    subprocess, a notebook's kernel, the site's build, a timer before a Ctrl-C — and the
    extra worker fills it.  Measured 2026-11-28 on the 2-core machine, warm caches:
    2 workers 223 and 229 s, 3 workers 185–206 s (five runs), 4 workers 216 s (and the
    timing-bound Ctrl-C tests then wait behind three other processes)."""
    return len(os.sched_getaffinity(0)) + 1 if hasattr(os, "sched_getaffinity") \
        else (os.cpu_count() or 1) + 1


def _group(item) -> str:
    path = item.nodeid.split("::")[0]
    if path.endswith("test_studies.py") and hasattr(item, "callspec"):
        return f"{path}::{item.callspec.id}"
    # the site is built once for both files (tests/docs_site.py); each notebook runs on
    # its own, so the workers share them
    if path.endswith(("test_docs.py", "test_docs_browser.py")):
        return "docs-site"
    # the quick reports likewise (tests/report_builds.py)
    if path.endswith(("test_report.py", "test_report_browser.py")):
        return "quick-reports"
    if (path.endswith("test_notebooks.py")
            and getattr(item, "originalname", "") == "test_notebook_runs"):
        return f"notebook-{item.callspec.id}"     # as marked in the file
    return path


def _rank(item) -> int:
    name = item.nodeid.split("::")[0].rsplit("/", 1)[-1]
    return _FIRST.index(name) if name in _FIRST else len(_FIRST)


# first: xdist's own hook (registered after this file, so called before it otherwise) reads
# the xdist_group marks to name each test's group; marks added after it are never seen
@pytest.hookimpl(tryfirst=True)
def pytest_collection_modifyitems(config, items):
    for item in items:
        item.add_marker(pytest.mark.xdist_group(_group(item)))
    items.sort(key=_rank)          # stable: within a rank the collection order is kept


def pytest_collection_finish(session):
    """In a worker, once every test module (and with them sympy, numba and both packages)
    is imported: freeze the objects alive, so that the collector's full passes, ~28 in a
    worker's run, walk only what the tests make (the ~600 000 objects of a worker took
    0.4 s a pass, 11 s a worker, measured 2026-11-28 with ``gc.callbacks``); and switch
    the collector back on (off since this file was read, above)."""
    if hasattr(session.config, "workerinput"):
        gc.freeze()
    if _COLLECTOR_OFF_WHILE_COLLECTING:     # (also in a pytest started inside a worker)
        gc.enable()


def _pytest_drops_xdist_groups() -> bool:
    """Whether this pytest ignores the ``item._nodeid`` that pytest-xdist's loadgroup sets
    (pytest 9.2: ``nodeid`` is a property of the structured id)."""
    import inspect

    from _pytest import nodes
    return "return self._nodeid" not in inspect.getsource(nodes.Node.nodeid.fget)


def pytest_configure(config):
    """On a cold numba cache (a fresh clone), compile the kernels the whole suite shares
    once, before the workers start (kapitza.warmup's groups in two processes, the two
    scripts of :data:`_SUITE_KERNELS` beside them): each worker would otherwise compile
    the same ones at the same time (the RKN 12 lanes ~20 s).  In the controller of a
    ``-n`` run only; ``KAPITZA_TEST_WARMUP=0`` skips it."""
    if hasattr(config, "workerinput") or not getattr(config.option, "numprocesses", None):
        return
    if config.getvalue("dist") == "loadgroup" and _pytest_drops_xdist_groups():
        raise pytest.UsageError(
            f"pytest {pytest.__version__} drops pytest-xdist's groups (a test's nodeid is "
            "derived from its structured id, so the '@group' suffix never takes): every "
            "shared fixture would be built once per worker.  Install the pinned one: "
            "pip install -e '.[test]'.")
    _write_bytecode()
    _rewrite_test_modules(config)
    if os.environ.get("KAPITZA_TEST_WARMUP", "1") == "0":
        return
    import subprocess
    import sys
    import time

    from kapitza.warmup import GROUPS, cold
    from kapitza.warmup import _parallel as compile_in_processes
    if not cold():
        return
    start = time.perf_counter()
    # beside kapitza.warmup's groups, the kernels many test files share that a user's
    # first call does not (_SUITE_KERNELS), each script in a process of its own
    suite = [subprocess.Popen([sys.executable, "-c", script], stdout=subprocess.DEVNULL,
                              stderr=subprocess.DEVNULL) for script in _SUITE_KERNELS]
    compile_in_processes(list(GROUPS), 2, False, start)
    for process in suite:
        process.wait()
    print(f"\nconftest: numba's cache was cold: the shared kernels compiled in "
          f"{time.perf_counter() - start:.0f} s before the workers start")


def _write_bytecode():
    """Compile the packages' bytecode (``__pycache__``) once, before the workers start,
    where no process would: with ``PYTHONDONTWRITEBYTECODE`` set (this machine sets it)
    every process of the run — the workers, the pre-compile, each CLI, Ctrl-C and
    fresh-process test, the docs build — compiled the ~150 modules of ``import kapitza``
    from source, 0.5 s each time (``import kapitza`` 1.5 s → 0.95 s with bytecode).
    ``py_compile`` writes whatever that setting says; an up-to-date file is left alone."""
    import sys
    if not sys.dont_write_bytecode:
        return          # the first import writes them
    import compileall
    from pathlib import Path
    root = Path(__file__).resolve().parent.parent
    for package in ("lagrange_core", "kapitza"):
        compileall.compile_dir(root / package, quiet=1)


def _rewrite_test_modules(config):
    """Write pytest's rewritten test modules (their asserts made to explain themselves)
    once, before the workers start, where no process would: with ``PYTHONDONTWRITEBYTECODE``
    set, pytest keeps no rewritten copy, and each worker rewrote every test module it
    collected (~4 s each).  Written as pytest writes them (an atomic rename), where pytest
    reads them whatever that setting says; an up-to-date file is left alone.  This reaches
    into pytest's private ``_pytest.assertion.rewrite``: where it differs (or a file cannot
    be written), nothing more is written, and the workers rewrite as before."""
    import fnmatch
    import sys
    if not sys.dont_write_bytecode or config.getoption("assertmode") != "rewrite":
        return
    try:
        from _pytest.assertion import rewrite
        state = config.stash[rewrite.assertstate_key]
        tail, read, rewritten, write, cache_dir = (
            rewrite.PYC_TAIL, rewrite._read_pyc, rewrite._rewrite_test, rewrite._write_pyc,
            rewrite.get_cache_dir)
    except (ImportError, AttributeError, KeyError):
        return
    from pathlib import Path
    here = Path(__file__).resolve().parent
    patterns = config.getini("python_files")
    for path in sorted(here.glob("*.py")):
        if path.name != "conftest.py" and not any(fnmatch.fnmatch(path.name, pattern)
                                                  for pattern in patterns):
            continue
        try:
            cache = cache_dir(path)
            pyc = cache / (path.name[:-3] + tail)
            if read(path, pyc) is not None:
                continue
            cache.mkdir(exist_ok=True)
            source_stat, code = rewritten(path, config)
            write(state, code, source_stat, pyc)
        except SyntaxError:         # collecting it says so, naming the file
            continue
        except (TypeError, ValueError, OSError):     # another pytest's signatures, a
            return                                  # read-only tree: only slower


#: The kernels many test files share that a user's first call does not, compiled before the
#: workers start on a cold cache (:func:`pytest_configure`), two scripts in two processes:
#: (1) the grid's symplectic driver with the energy record (~50 s cold) and RKN 12's
#: per-point driver, the lanes' reference in tests/test_batch_speedpath.py and
#: tests/test_long_runs.py (each file compiled it at once in its own worker: 2 × 32 s
#: of a fresh clone's run, 2026-11-28); (2) the chaos room's lanes (Lyapunov and the
#: strobe's DOP853, ~90 s) and its per-point Lyapunov kernel (two files' tests called it
#: at once, and each compiled it: 5 s).
_SUITE_KERNELS = ("""
import math, warnings
warnings.simplefilter("ignore")
from lagrange_core import batch, problems
pend = problems.pendulum()
pend.simulate_grid([1.0], [0.0], (0.0, 2.0), dict(g=9.81, l=1.0, m=1.0), method="yoshida6",
                   h=0.2, energy=True, progress=False)
batch._USE_LANES = False
w = 2 * math.pi * 60
problems.driven_pendulum("vertical").simulate_grid(
    [math.pi - 0.1], [0.0], (0.0, 3 / 60), dict(g=9.81, l=1.0, m=1.0, A=[0.05], omega=[w]),
    band=([math.pi / 2], [3 * math.pi / 2]), strobe=1 / 60, reference=[math.pi],
    progress=False)
""", """
import math, warnings
warnings.simplefilter("ignore")
from lagrange_core import problems
from kapitza.chaos import bifurcation_diagram, lyapunov, lyapunov_grid
driven = problems.driven_pendulum("vertical", damping=True)
w0 = math.sqrt(9.81)
p = dict(A=0.1, g=9.81, l=1.0, m=1.0, omega=2 * w0, gamma=0.1 * w0)
lyapunov_grid(driven, p, 0.3, periods=4, transient=0, blocks=2, progress=False)
bifurcation_diagram(driven, p, parameter="A", values=[0.1, 0.2], angles="theta", periods=2,
                    transient=1, progress=False)
lyapunov(driven, p, 0.3, periods=4, transient=0, blocks=2, progress=False)
""")


@pytest.fixture(scope="session")
def rng():
    return np.random.default_rng(20261122)
