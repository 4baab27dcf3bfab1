"""A first use on an empty cache: the compile notice, and inputs that would compile a
kernel twice.  Cheap on purpose: no real cold run (that takes a minute and more; the
benchmark ``benchmarks/bench_cold_start.py --report`` measures it)."""
from __future__ import annotations

import json
import subprocess
import sys
import textwrap
import types

import numpy as np
import pytest
from numba import njit

from lagrange_core import _compile_notice, problems
from lagrange_core.batch import _grid_arrays

NOTICE = "compiling numba kernels for first use"


@pytest.fixture
def fresh_notice(monkeypatch):
    """The notice not yet printed in this process (restored afterwards)."""
    monkeypatch.delenv("LAGRANGE_CORE_COMPILE_NOTICE", raising=False)
    said = _compile_notice._state["said"]
    _compile_notice.reset_for_tests()
    yield
    _compile_notice._state["said"] = said


def _project_function(module):
    """A fresh (never compiled) jitted function that numba sees as ``module``'s."""
    def twice(x):
        return 2 * x
    twice.__module__ = module
    return njit(twice)          # no cache: every call with a new type compiles


def test_first_compile_says_so_once_with_an_estimate(fresh_notice, capsys):
    f = _project_function("lagrange_core._a_kernel_module")
    with _compile_notice.declared("measure, RKN 12"):
        f(1)
        f(1.5)                  # a second compile in the same process: no second line
        _project_function("kapitza.floquet._kernels")(2)
    err = capsys.readouterr().err
    assert err.count(NOTICE) == 1, err
    assert "(measure, RKN 12)" in err and " s;" in err
    seconds = int(err.split("~")[1].split(" s")[0])
    base = _compile_notice.ACTIVITY_SECONDS["measure, RKN 12"]
    assert base - 5 <= seconds <= 4 * base + 5    # scaled by the load (at most 4x), rounded


def test_rkn12s_first_grid_quotes_the_longer_wait_when_it_compiles_alone(monkeypatch):
    """RKN 12's first grid and measure compile the lanes driver's callees in a second
    process too: ~13 and ~16 s (12.5–13.5 and 15.0–17.3 s measured, 2026-11-29,
    thirtieth session).  With none running beside (one core, the switch off) and the
    callees not cached, all of it compiles in this process: 22.1–26.3 and 27.7–27.9 s
    measured, quoted ~20 and ~30 s (estimates of 20 s and more are rounded to tens)."""
    from lagrange_core import _background, _lanes_ahead
    monkeypatch.setattr(_compile_notice.os, "getloadavg", lambda: (0.0, 0.0, 0.0))
    monkeypatch.setattr(_background, "RUNNING", {})
    monkeypatch.setattr(_lanes_ahead, "wanted", lambda: True)
    quoted = {}
    for name in ("simulate_grid, RKN 12", "measure, RKN 12", "measure, DOP853"):
        with _compile_notice.declared(name):
            quoted[name] = _compile_notice.estimate("lagrange_core._batch_kernels")
    assert quoted == {"simulate_grid, RKN 12": 20, "measure, RKN 12": 30, "measure, DOP853": 10}

    class Running:
        def poll(self):
            return None
    monkeypatch.setattr(_background, "RUNNING", {"RKN 12 lanes callees": Running()})
    with _compile_notice.declared("measure, RKN 12"):
        assert _compile_notice.estimate("lagrange_core._batch_kernels") == 16
    monkeypatch.setattr(_background, "RUNNING", {})
    monkeypatch.setattr(_lanes_ahead, "wanted", lambda: False)      # the callees cached
    with _compile_notice.declared("simulate_grid, RKN 12"):
        assert _compile_notice.estimate("lagrange_core._batch_kernels") == 13


def test_a_compile_in_a_pool_thread_quotes_the_callers_activity(fresh_notice, capsys):
    """The grid kernels run on a pool of threads (lagrange_core._thread_blocks), where a
    kernel's first call compiles it: the notice quotes the caller's activity there too
    (it quoted a module's guess instead: ~20 s for the damped pendulum's first measure,
    which compiles in 13–14 s; ~3 s for a chain's first Floquet analysis, 15 s)."""
    from lagrange_core._thread_blocks import run_blocks
    f = _project_function("lagrange_core._a_pool_kernel")
    with _compile_notice.declared("measure, DOP853"):
        run_blocks(lambda b: f(b), 1, stoppable=True)      # (stoppable: on the pool)
    err = capsys.readouterr().err
    assert err.count(NOTICE) == 1 and "(measure, DOP853)" in err, err


def test_every_grid_and_measure_names_a_driver_with_an_estimate():
    """simulate_grid and measure declare the driver their first call compiles (RKN 12's
    lanes ~27 s, DOP853 ~9 s on the 2-core machine): every method they run has an
    estimate, measured (benchmarks/bench_cold_start.py --only notices)."""
    from lagrange_core.batch import _GRID_METHODS, compile_activity
    undamped, damped = problems.driven_pendulum(), problems.driven_pendulum(damping=True)
    assert compile_activity("measure", undamped.kernels, None) == "measure, RKN 12"
    assert compile_activity("measure", damped.kernels, None) == "measure, DOP853"
    assert compile_activity("simulate_grid", undamped.kernels, "yoshida6") == \
        "simulate_grid, symplectic"
    assert compile_activity("simulate_grid", undamped.kernels, "rk45") is None   # refused
    names = {compile_activity("simulate_grid", undamped.kernels, m) for m in _GRID_METHODS}
    # measure passes no step: the fixed-step methods (but the piloted RKN 12) are refused
    names |= {compile_activity("measure", undamped.kernels, m)
              for m in ("rkn12", "rkn12-fixed", "dop853")}
    assert names <= set(_compile_notice.ACTIVITY_SECONDS), \
        names - set(_compile_notice.ACTIVITY_SECONDS)


def test_a_new_systems_own_kernels_and_foreign_code_are_not_announced(fresh_notice, capsys):
    _project_function("_lc_0123456789abcdef0123")(1)     # a generated system module
    _project_function("some_user_module")(1)
    assert NOTICE not in capsys.readouterr().err


def test_the_notice_can_be_turned_off(fresh_notice, capsys, monkeypatch):
    monkeypatch.setenv("LAGRANGE_CORE_COMPILE_NOTICE", "0")
    _project_function("lagrange_core._another")(1)
    assert NOTICE not in capsys.readouterr().err


def test_said_on_a_cold_cache_and_never_on_a_warm_one(fresh_notice, capsys, monkeypatch,
                                                     tmp_path):
    """Two runs on one numba cache: the first compiles (one line), the second loads the
    machine code and prints nothing.

    A "run" imports the kernels' module afresh with the notice not yet printed, as a new
    process would: a new dispatcher, which looks in numba's cache on disk at its first
    call (and numba tells its listeners of a compile only, not of a load).  Run in this
    process, not in two fresh ones (each imported numba for a one-line function)."""
    import numba
    (tmp_path / "_cold_fake_kernels.py").write_text(textwrap.dedent("""
        from numba import njit

        @njit(cache=True)
        def twice(x):
            return 2 * x
    """))
    monkeypatch.setattr(numba.config, "CACHE_DIR", str(tmp_path / "numba"))
    monkeypatch.setattr(_compile_notice, "SHARED_PREFIXES", ("_cold_fake_kernels",))
    monkeypatch.syspath_prepend(str(tmp_path))

    def run():
        _compile_notice.reset_for_tests()
        monkeypatch.delitem(sys.modules, "_cold_fake_kernels", raising=False)
        import _cold_fake_kernels
        _cold_fake_kernels.twice(1)
        _cold_fake_kernels.twice(2.5)
        stats = _cold_fake_kernels.twice.stats
        return (capsys.readouterr().err, sum(stats.cache_hits.values()),
                sum(stats.cache_misses.values()))

    cold, warm = run(), run()
    assert cold[0].count(NOTICE) == 1 and cold[1:] == (0, 2), cold
    assert NOTICE not in warm[0] and warm[1:] == (2, 0), warm       # loaded, both


def test_grid_inputs_are_writable_whatever_the_caller_gave():
    """numba compiles a grid kernel once more (≈ 30 s cold) for every mix of read-only and
    writable arrays; a broadcast view given by the caller must not reach it read-only."""
    system = problems.driven_pendulum()
    ro = np.broadcast_to(np.linspace(0.1, 0.3, 4)[:, None], (4, 1))   # a read-only view
    assert not ro.flags.writeable
    params = {p: 1.0 for p in system.parameters}
    params["A"] = ro[:, 0]
    g = _grid_arrays(system, ro, 0 * ro, (0.0, ro[:, 0] + 1.0), params, None, ro[:, 0], ro,
                     (ro - 1.0, ro + 1.0))
    arrays = {k: v for k, v in g.items() if isinstance(v, np.ndarray) and k != "params"}
    assert {"Y0", "P", "TS", "TSTR", "REF", "LO", "HI"} <= set(arrays)
    assert all(a.flags.writeable and a.flags.c_contiguous for a in arrays.values()), \
        {k: (a.flags.writeable, a.flags.c_contiguous) for k, a in arrays.items()}


_HEAVY = ("scipy.optimize", "scipy.linalg", "pandas", "matplotlib")


@pytest.fixture(scope="module")
def fresh_kapitza_process():
    """One fresh interpreter for two checks (an interpreter and kapitza's import each,
    ~2 s, not twice): first what ``import kapitza, kapitza.cli`` imported (a JSON line,
    printed before anything else runs), then the fit kernels' signatures before the
    background group's code, after it, and after a measure and a 3-coordinate record's
    fit (a JSON line); last, whether a DOP853 ``simulate`` (and the damped measure before
    it, on DOP853's grid driver) imported scipy.integrate (a JSON line).  Returns (return
    code, stdout's lines, stderr)."""
    script = textwrap.dedent(f'''
        import json, math, sys
        import kapitza, kapitza.cli
        print(json.dumps([m for m in {_HEAVY!r} if m in sys.modules]), flush=True)
        import numpy as np
        from kapitza import KapitzaPendulum
        from kapitza.simulation import _measurement, slow_frequencies
        def seen():
            return {{k.py_func.__name__: sorted(map(str, k.signatures))
                     for k in _measurement._FIT_KERNELS}}
        before_group = seen()
        exec(_measurement._FIT_CODE)
        after_group = seen()
        KapitzaPendulum(l=1.0, g=9.81, damping=0.5).measure(0.05, 2 * math.pi * 60,
                                                             math.pi - 0.1, periods=200)
        k = np.arange(300)[:, None]
        slow_frequencies(np.cos(0.1 * k * np.arange(1, 4)), np.sin(0.1 * k * np.arange(1, 4)),
                         0.01)
        print(json.dumps([before_group, after_group, seen()]))
        from lagrange_core import problems
        problems.double_pendulum().simulate([1.0, -0.5], [0.0, 0.3], (0.0, 0.5),
                                            dict(m1=1.0, m2=0.5, l1=1.0, l2=0.7, g=9.81),
                                            method="dop853")
        print(json.dumps("scipy.integrate" in sys.modules))
    ''')
    out = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True,
                         timeout=600)
    return out.returncode, out.stdout.splitlines(), out.stderr


def test_import_leaves_the_heavy_libraries_for_first_use(fresh_kapitza_process):
    """``import kapitza`` (every CLI command, every worker process) does not import what
    only some calls need: scipy.optimize and scipy.linalg (~0.4 s, in the averaging and
    closed-form functions that call them), pandas (``to_dataframe``), matplotlib (the
    figures).  Checked in a fresh interpreter, before it does anything else."""
    returncode, lines, stderr = fresh_kapitza_process
    assert lines, stderr[-2000:]                # (the import itself failed)
    imported = json.loads(lines[0])
    assert imported == [], f"imported by `import kapitza`: {' '.join(imported)}"


def test_dop853_runs_leave_scipy_integrate_for_first_use(fresh_kapitza_process):
    """A damped ``measure`` (DOP853's grid driver) and a double pendulum's DOP853
    ``simulate`` in a fresh interpreter read DOP853's table without importing
    scipy.integrate, whose package imports scipy.optimize and scipy.sparse (0.33 CPU-s of
    a new system's first ``simulate``)."""
    returncode, lines, stderr = fresh_kapitza_process
    assert returncode == 0 and len(lines) == 3, stderr[-2000:]
    assert json.loads(lines[2]) is False, "scipy.integrate was imported"


class _Reached(Exception):
    """Raised by a spy where a first use would start compiling."""


def test_orbits_branches_and_floquet_declare_what_their_first_call_compiles(monkeypatch):
    """Inside ``periodic_orbit``, ``continuation``, a general system's Floquet analysis and
    ``lyapunov_grid`` a first compile quotes that activity — not the ~3 s of the first
    helper they compile (measured on empty caches: 13–15 s, 4–6 s, 13.5 s and 15.3–16.4 s
    taken; benchmarks/bench_cold_start.py --only notices)."""
    import math

    import kapitza
    from kapitza.chaos import _lyapunov
    from kapitza.continuation import _continuation
    from kapitza.floquet import _point
    from kapitza.simulation import _periodic_orbit
    seen = {}

    def spy(name):
        def record(*args, **kwargs):
            seen[name] = _compile_notice._activity.get()
            raise _Reached
        return record

    monkeypatch.setattr(_periodic_orbit, "_period", spy("periodic_orbit"))
    monkeypatch.setattr(_continuation.Engine, "start", spy("continuation"))
    monkeypatch.setattr(_point, "_prepare", spy("floquet_point"))
    monkeypatch.setattr(_lyapunov, "_lanes", spy("lyapunov_grid"))
    p = dict(m=1.0, l=1.0, g=9.81, A=0.05, omega=2 * math.pi * 60)
    calls = {
        "periodic_orbit": lambda: kapitza.periodic_orbit(
            problems.driven_pendulum("horizontal"), p, [1.5]),
        "continuation": lambda: kapitza.continuation(
            problems.driven_pendulum("vertical"), dict(p, A=0.02, omega=62.6), [math.pi],
            parameter="A", stop=0.6, progress=False),
        "floquet_point": lambda: kapitza.floquet_point(
            problems.driven_pendulum("vertical"), p, [math.pi]),
        "lyapunov_grid": lambda: kapitza.lyapunov_grid(
            problems.driven_pendulum("vertical"), p, [[math.pi - 0.1]], periods=20,
            transient=0),
    }
    for call in calls.values():
        with pytest.raises(_Reached):
            call()
    assert seen == {"periodic_orbit": "periodic orbit", "continuation": "continuation",
                    "floquet_point": "Floquet", "lyapunov_grid": "Lyapunov map"}
    assert set(seen.values()) <= set(_compile_notice.ACTIVITY_SECONDS)


# -- what measure compiles on the other core: RKN 12 lanes driver's callees, the fit ---------

class _FakeProcess:
    """A background process that has ended; it records that someone waited for it."""

    def __init__(self):
        self.waited = 0

    def wait(self, timeout=None):
        self.waited += 1
        return 0

    def poll(self):
        return 0


@pytest.mark.parametrize("damping", [0.5, 0.0], ids=["damped (DOP853)", "undamped (RKN 12)"])
@pytest.mark.parametrize("case", ["cold", "classification only", "switched off", "one core"])
def test_measure_compiles_on_the_other_core_on_a_cold_cache(monkeypatch, case, damping):
    """On a cold cache ``measure`` starts one background process before its grid: the
    fit's kernels when Ω is wanted (the first damped one: 15.5–17 s → 8.5–10.5 s,
    2026-11-28), then RKN 12 lanes driver's callees when the grid runs on them
    (undamped; the first undamped measure on empty caches: 33.2–34.6 s → 27.6–27.9 s,
    2026-11-28; the fit first since 2026-11-29, as the driver's process takes the
    callees from the last back once its driver has compiled); and waits for it before
    fitting.  Nothing with ``KAPITZA_BACKGROUND_COMPILE=0`` or on one core."""
    from kapitza import KapitzaPendulum
    from kapitza.simulation import _measurement
    from lagrange_core import _background, _lanes_ahead
    started = []

    def start(name, code):
        proc = _FakeProcess()
        started.append((name, code, proc))
        _background.RUNNING[name] = proc
        return proc

    monkeypatch.setattr(_background, "RUNNING", {})
    monkeypatch.setattr(_background, "start", start)
    monkeypatch.setattr(_background, "cold", lambda *kernels: True)
    # (simulate_grid's own start of the callees: the next test)
    monkeypatch.setattr(_lanes_ahead, "start_if_cold", lambda: None)
    monkeypatch.setattr(_measurement, "_fit_in_process", lambda: False)
    monkeypatch.setattr(_lanes_ahead, "_driver_in_process", lambda: False)
    monkeypatch.setenv("KAPITZA_BACKGROUND_COMPILE", "0" if case == "switched off" else "1")
    monkeypatch.setattr(_measurement.os, "cpu_count", lambda: 1 if case == "one core" else 2)
    pend = KapitzaPendulum(l=1.0, g=9.81, damping=damping)
    observables = "classification" if case == "classification only" else "all"
    m = pend.measure(0.05, 2 * np.pi * 60, np.pi - 0.1, periods=200, observables=observables)
    lanes = _lanes_ahead.CODE if damping == 0.0 else ""
    if case in ("switched off", "one core") or (case == "classification only" and not lanes):
        assert started == []
        return
    fit = _measurement._FIT_CODE if case == "cold" else ""
    assert [(name, code) for name, code, _ in started] == [("measure kernels", fit + lanes)]
    assert started[0][2].waited == (1 if fit else 0)
    assert np.all(np.isfinite(m.omega_slow)) if fit else m.omega_slow is None


@pytest.mark.parametrize("case", ["cold", "driver in process", "switched off", "one core",
                                  "another running", "warm", "DOP853"])
def test_a_first_rkn12_grid_compiles_the_callees_on_the_other_core(monkeypatch, case):
    """``simulate_grid``'s first grid on RKN 12's lanes starts the driver's callees in a
    background process on a cold cache (``lagrange_core._lanes_ahead.start_if_cold``): the
    first RKN 12 grid 20.0–21.0 s without it, 2026-11-28.  Not where this process has the
    driver, with ``KAPITZA_BACKGROUND_COMPILE=0``, on one core, while another background
    compile runs (kapitza's ``measure`` starts its own, with the callees in it), on a warm
    cache, nor for a grid on another method."""
    from lagrange_core import _background, _lanes_ahead
    started = []

    class Running:              # another group's process (a Popen's poll and args)
        args = ["python", "-c", "pass"]

        def poll(self):
            return None

    monkeypatch.setattr(_background, "RUNNING",
                        {"other": Running()} if case == "another running" else {})
    monkeypatch.setattr(_background, "start", lambda name, code: started.append((name, code)))
    monkeypatch.setattr(_background, "cold", lambda *kernels: case != "warm")
    monkeypatch.setattr(_lanes_ahead, "_driver_in_process", lambda: case == "driver in process")
    monkeypatch.setenv("KAPITZA_BACKGROUND_COMPILE", "0" if case == "switched off" else "1")
    monkeypatch.setattr(_lanes_ahead.os, "cpu_count", lambda: 1 if case == "one core" else 2)
    problems.driven_pendulum().simulate_grid(
        [[3.0]], [[0.0]], (0.0, 0.05), dict(A=0.05, g=9.81, l=1.0, m=1.0, omega=377.0),
        method="dop853" if case == "DOP853" else None, progress=False)
    assert started == ([(_lanes_ahead.GROUP, _lanes_ahead.CODE)] if case == "cold" else [])


def test_the_background_fit_compiles_what_a_measure_fits_with(fresh_kapitza_process):
    """The background group's records reach every specialisation of the fit's kernels that
    measuring a pendulum (one coordinate) and a 3-coordinate record use: after it, they
    compile (or load) nothing more.  In a fresh process: there, a kernel has a signature
    once it is called (none before the group: the imports call none)."""
    returncode, lines, stderr = fresh_kapitza_process
    assert returncode == 0, stderr[-2000:]
    before_group, after_group, after_use = json.loads(lines[1])
    assert not any(before_group.values()), before_group
    assert all(after_group.values()), after_group        # the group called every kernel
    assert after_use == after_group


def test_the_lanes_callees_are_compiled_with_their_declared_signatures():
    """RKN 12's lanes driver calls its callees by address, with the signatures that
    ``lagrange_core._lanes_callees.CALLEES`` declares (the driver's compile types each call
    against them, and the second process compiles them ahead): a grid on the lanes runs,
    and numba's cache index of each callee holds exactly the declared signature — one more
    would be a call that compiles the callee again (only slower), beside a stale
    declaration — returning the declared type (which ``native_address`` checks, refusing
    a callee that returns another)."""
    from lagrange_core import _lanes_callees, problems
    driven = problems.driven_pendulum()         # the driver compiled, or loaded
    grid = driven.simulate_grid([[3.0]], [[0.0]], (0.0, 0.05),
                                dict(A=0.05, g=9.81, l=1.0, m=1.0, omega=377.0),
                                method="rkn12", progress=False)
    assert np.all(grid.status == 0)
    assert np.all(_lanes_callees.addresses() != 0)
    for dispatcher, sig in _lanes_callees.callees():
        used = {key[0] for key in dispatcher._cache._cache_file._load_index()}
        assert used == {tuple(sig.args)}, (
            f"{dispatcher.py_func.__qualname__}: numba's cache holds {sorted(map(str, used))}, "
            f"lagrange_core._lanes_callees.CALLEES declares {sig.args}: declare what the "
            "driver calls it with (if another kernel now calls it too, check the driver's "
            "alone)")
        assert dispatcher.overloads[tuple(sig.args)].signature.return_type == sig.return_type
        # called by address only, a callee needs no wrapper callable from Python: without
        # it the callees compile in 7.8-9.3 s, not 9.6-11.0 s (2026-11-29, in turn);
        # pilot_step_quantile is called from Python too (lagrange_core.integrate)
        python_called = dispatcher.py_func.__name__ == "pilot_step_quantile"
        assert dispatcher.targetoptions.get("no_cpython_wrapper", False) != python_called, (
            f"{dispatcher.py_func.__qualname__}: no_cpython_wrapper=True where it is called "
            "by address only, and not where Python calls it")


class _Callee:
    """A callee of the sharing tests: its compiles, and a numba cache it lands in."""

    def __init__(self, slot, log):
        self.slot, self.log, self.landed = slot, log, False

    def compile(self, args):
        self.log.append(("compiled", self.slot))


def _shared_out(monkeypatch, tmp_path, n=6):
    """_lanes_callees with ``n`` fake callees, its folder of claims under ``tmp_path``."""
    from lagrange_core import _lanes_callees
    log = []
    pairs = [(_Callee(k, log), types.SimpleNamespace(args=(k,))) for k in range(n)]
    monkeypatch.setattr(_lanes_callees, "callees", lambda: pairs)
    monkeypatch.setattr(_lanes_callees, "_claims", lambda pid: tmp_path / f"claims-{pid}")
    return _lanes_callees, pairs, log


def test_the_process_compiling_the_callees_ahead_skips_those_taken(monkeypatch, tmp_path):
    """The second process (``compile_ahead``) compiles from the first slot on every callee
    the driver's process has not taken (here the last two), and removes the folder of
    claims when it ends."""
    import os
    lc, pairs, log = _shared_out(monkeypatch, tmp_path)
    folder = lc._claims(os.getpid())
    for slot in (4, 5):
        assert lc._take(folder, slot)
    lc.compile_ahead()
    assert log == [("compiled", k) for k in range(4)]
    assert not folder.exists()


def test_the_driver_process_shares_the_callees_out_with_the_second_process(
        monkeypatch, tmp_path):
    """Once its driver has compiled, the driver's process takes the callees from the last
    back, each not yet taken by the second process compiling them ahead (here it has
    taken 0–2); those it waits for until numba's cache has them, then loads them — each
    callee compiled once, in one of the two (the first undamped ``measure`` on empty
    caches: 14.6–15.9 s → 13.8–14.4 s, three alternated pairs, 2026-11-29)."""
    from lagrange_core import _background
    lc, pairs, log = _shared_out(monkeypatch, tmp_path)

    class Ahead:                # the second process, running compile_ahead
        pid = 4242
        args = ["python", "-c", lc.AHEAD_CODE]

        def poll(self):
            return None

    monkeypatch.setattr(_background, "RUNNING", {"measure kernels": Ahead()})
    folder = lc._claims(Ahead.pid)
    for slot in (0, 1, 2):
        assert lc._take(folder, slot)
    looks = {}

    def cold(dispatcher):       # each of the second process's callees lands after 2 looks
        looks[dispatcher.slot] = looks.get(dispatcher.slot, 0) + 1
        return looks[dispatcher.slot] <= 2

    monkeypatch.setattr(_background, "cold", cold)
    monkeypatch.setattr(lc.time, "sleep", lambda s: None)
    monkeypatch.setattr(lc, "native_address",
                        lambda d, sig: (log.append(("address", d.slot)), 1000 + d.slot)[1])
    at_exit = []
    monkeypatch.setattr(lc.atexit, "register", lambda *call: at_exit.append(call))
    table = lc._compiled_addresses()
    assert list(table) == [1000 + k for k in range(6)]
    # its own from the last back, then the second process's once they landed (3 looks)
    assert log == [("address", k) for k in (5, 4, 3, 2, 1, 0)]
    assert looks == {2: 3, 1: 3, 0: 3}
    assert not folder.exists()
    # at exit (after a Ctrl-C, say) the second process is ended and its folder removed
    (call, partner, where), = at_exit
    assert call is lc._end_and_remove and where == folder and partner.pid == Ahead.pid


def test_the_driver_process_compiles_what_an_ended_second_process_left(monkeypatch, tmp_path):
    """A second process that has ended (Ctrl-C, killed) with callees taken but not in
    numba's cache: the driver's process does not wait for them; it compiles them itself
    (``native_address`` compiles what the cache lacks)."""
    from lagrange_core import _background
    lc, pairs, log = _shared_out(monkeypatch, tmp_path)

    class Ended:
        pid = 4343
        args = ["python", "-c", lc.AHEAD_CODE]
        polls = 0

        def poll(self):         # running when looked for, ended afterwards
            Ended.polls += 1
            return None if Ended.polls == 1 else -2

    monkeypatch.setattr(_background, "RUNNING", {"g": Ended()})
    for slot in (0, 1):
        assert lc._take(lc._claims(Ended.pid), slot)
    monkeypatch.setattr(_background, "cold", lambda d: True)
    monkeypatch.setattr(lc.time, "sleep", lambda s: pytest.fail("waited for an ended process"))
    monkeypatch.setattr(lc, "native_address",
                        lambda d, sig: (log.append(("address", d.slot)), 1000 + d.slot)[1])
    monkeypatch.setattr(lc.atexit, "register", lambda *call: None)
    assert list(lc._compiled_addresses()) == [1000 + k for k in range(6)]
    assert sorted(log) == [("address", k) for k in range(6)]


def test_a_real_second_process_shares_the_callees_out(monkeypatch):
    """The same with a real second process (``_background.start``, as ``measure`` starts
    it): the driver's process finds it by its code, both take slots in its folder (each
    loads what numba's cache has, compiles what it lacks), every address is found, the
    second process ends cleanly and its folder is gone."""
    from lagrange_core import _background
    from lagrange_core import _lanes_callees as lc
    monkeypatch.setattr(_background, "RUNNING", {})
    monkeypatch.setenv("KAPITZA_BACKGROUND_COMPILE", "1")
    proc = _background.start("lanes callees (test)", lc.AHEAD_CODE)
    assert lc._ahead_process() is proc
    table = lc._compiled_addresses()
    assert table.shape == (lc.N_CALLEES,) and np.all(table != 0)
    assert proc.wait(timeout=300) == 0
    assert not lc._claims(proc.pid).exists()


def test_a_background_compile_that_cannot_start_is_skipped(monkeypatch):
    """A background process the system refuses (OSError: its process limit) is no error:
    ``start`` returns None, nothing waits for it, and the kernels compile where called."""
    from lagrange_core import _background

    def refuse(*args, **kwargs):
        raise OSError(11, "Resource temporarily unavailable")

    monkeypatch.setattr(_background, "RUNNING", {})
    monkeypatch.setattr(_background.subprocess, "Popen", refuse)
    assert _background.start("measure kernels", "pass") is None
    assert _background.RUNNING == {}
    assert _background.wait(("measure kernels",)) < 0.05


def test_commands_whose_first_compile_no_api_activity_covers_declare_themselves(monkeypatch):
    """``kapitza animate``, ``continue``, ``lyapunov`` and ``map`` compile first in the
    command line's own checks (the closed forms: "~3 s") and then for 8–25 s on empty
    caches: the command is the activity, from the checks on; ``measure`` is left to its
    own, finer one ("measure, RKN 12" or "measure, DOP853")."""
    from kapitza.cli import _main, main
    seen = {}

    def spy(where, then=None):
        def record(args, *rest):
            seen.setdefault(args.command, []).append((where, _compile_notice._activity.get()))
            return then(args, *rest) if then is not None else 0
        return record

    monkeypatch.setattr(_main, "check_pendulum_options",
                        spy("checks", _main.check_pendulum_options))
    for command in ("animate", "continue", "lyapunov", "map", "measure"):
        monkeypatch.setitem(_main.COMMANDS, command, spy("command"))
    for argv in (["animate", "--out", "x.gif"], ["continue", "--stop", "0.6"],
                 ["lyapunov", "--damping", "0.2"], ["map"], ["measure"]):
        assert main(argv) == 0
    for command in ("animate", "continue", "lyapunov", "map"):
        assert seen[command] == [("checks", f"kapitza {command}"),
                                 ("command", f"kapitza {command}")]
        assert f"kapitza {command}" in _compile_notice.ACTIVITY_SECONDS
    assert seen["measure"] == [("checks", None), ("command", None)]
