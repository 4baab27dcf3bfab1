"""What a new system's first simulation costs, and what every step and call cost after it.

Run:  python benchmarks/bench_cold_start.py [--quick] [--baseline REV]
          [--only cold|steps|first-use|new-system|notices|commands]

1. Cold start (issue 9): each case in a fresh process with an *empty* kernel store
   (``LAGRANGE_CORE_CACHE`` a new directory: the system was never seen) while the
   installation's integrators are compiled (numba's cache in the package, warmed by
   ``lagrange_core.warmup()`` first).  Printed per phase: statement, kernels (derive and
   generate; until 2026-11-27 also the compile of ``rhs``, which now compiles on its first
   call), first ``simulate`` (``rhs``, the C entry points it needs and the run), and the
   total from statement to trajectory; medians of 3 processes.
2. Running cost: per step and fixed per ``simulate`` call, from three run lengths in one
   process (per step: the slope between the two longer runs; fixed: the time of a run
   of a few steps less its steps × the per-step cost; minima of 7 repetitions).  With
   ``--baseline REV`` the same measurement runs on the source tree of git revision REV
   (a temporary worktree), alternating old and new processes, and the ratios new/old are
   printed.

3. First use (issue 24, ``--only first-use``): what a user waits for with *every* cache
   empty (``LAGRANGE_CORE_CACHE`` and ``NUMBA_CACHE_DIR`` new directories, as after
   ``pip install .``): ``kapitza report``; ``kapitza.warmup()``; then the first
   ``KapitzaPendulum.measure`` of each drive in a fresh process after the warm-up, and
   (``--without-warmup``) on empty caches.  Wall and CPU seconds (the process and its
   children), with the load average before and after: a figure taken under load
   overstates the wall time.
4. A new system's first use other than ``simulate`` (``--only new-system``): its mass
   matrix, its normal modes, its first bifurcation diagram, two large sparse systems
   (a string of 200 beads' normal modes, of 20 beads' first RKN 12 run), and its lanes
   kernels (a first grid on lanes, a first Lyapunov map on lanes), each in a fresh
   process with an empty kernel store (the shared kernels compiled: a first untimed round
   per tree warms them); what only the system's own kernels cost.  With ``--baseline REV`` the
   same cases on REV's tree, old and new processes alternated, with the ratios.

5. The compile notice's estimate (``--only notices``): each first use in a fresh process on
   empty caches, the seconds the one-line notice quotes (``lagrange_core._compile_notice``)
   against the seconds the call took, and their ratio.
6. A command with warm caches (``--only commands``): ``python -m kapitza ...`` in a fresh
   process, every kernel cached, as a user's second and later commands run; wall seconds,
   medians.  With ``--baseline REV`` REV's tree runs them too, alternated, with the ratios
   (2026-11-28: the program no longer pays Python's last collection at its exit).

Absolute times drift on a shared machine; compare ratios and medians.
"""
from __future__ import annotations

import argparse
import atexit
import contextlib
import json
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
import time

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)


# -- the cases (public API only, so the baseline tree runs them too) -----------------------

def make_case(name):
    import math

    import sympy as sp

    import lagrange_core as lc
    from lagrange_core import problems
    if name == "pendulum (README)":
        system = problems.pendulum()
        params = {p: v for p, v in dict(m=1.0, l=1.0, g=9.81).items() if p in system.parameters}
        return system, [2.0], [0.0], params, 2 * math.pi / 3.13, {"rtol": 1e-10}
    if name == "pendulum, dop853":
        system = problems.pendulum()
        params = {p: v for p, v in dict(m=1.0, l=1.0, g=9.81).items() if p in system.parameters}
        return system, [2.0], [0.0], params, 2.0, {"rtol": 1e-10, "method": "dop853"}
    if name == "driven pendulum, rkn12 + event":
        system = problems.driven_pendulum()
        params = dict(l=1.0, g=9.81, A=0.05, omega=2 * math.pi * 60)
        params = {k: v for k, v in params.items() if k in system.parameters}
        params.update({k: 1.0 for k in system.parameters if k not in params})
        ev = lc.crossing(system.coordinates[0], 10.0)        # never fires: forces the event driver
        return system, [math.pi - 0.1], [0.0], params, 1 / 60, {"rtol": 1e-10, "events": [ev]}
    if name == "double pendulum":
        system = problems.double_pendulum()
        return (system, [1.0, -0.5], [0.0, 0.3], dict(m1=1.0, m2=0.5, l1=1.0, l2=0.7, g=9.81),
                2.0, {"rtol": 1e-10})
    if name == "8-link pendulum":
        system = problems.n_link_pendulum(8)
        params = {p: 1.0 for p in system.parameters}
        params["g"] = 9.81
        return system, [0.3] * 8, [0.0] * 8, params, 5.0, {"rtol": 1e-8}
    if name == "rigid triangle (9 coordinates, 3 constraints)":
        # three point masses in space, rigidly joined (3 distance constraints), one vertex
        # held near the origin by a spring, in gravity
        q, _ = lc.coordinates("x1 y1 z1 x2 y2 z2 x3 y3 z3")
        m, g, k, a = sp.symbols("m g k a", positive=True)
        r = [q[0:3], q[3:6], q[6:9]]
        parts = [lc.Particle(m, tuple(ri)) for ri in r]
        d2 = lambda u, v: sum((ui - vi) ** 2 for ui, vi in zip(u, v, strict=True))     # noqa: E731
        system = lc.System(q, particles=parts,
                           potential=sum(m * g * ri[2] for ri in r) + k * d2(r[0], (0, 0, 0)) / 2,
                           constraints=[d2(r[0], r[1]) - a**2, d2(r[1], r[2]) - a**2,
                                        d2(r[2], r[0]) - a**2], name="rigid triangle")
        h = math.sqrt(3) / 2
        q0 = [0, 0, 0, 1, 0, 0, 0.5, h, 0]
        qd0 = [0, 0, 0, 0, 0, 0.3, 0, 0, -0.3]
        return system, q0, qd0, dict(m=1.0, g=9.81, k=50.0, a=1.0), 2.0, {"rtol": 1e-9}
    raise KeyError(name)


COLD_CASES = ["pendulum (README)", "double pendulum", "8-link pendulum",
              "rigid triangle (9 coordinates, 3 constraints)"]
TARGETS = {"double pendulum": 1.5, "8-link pendulum": 3.0,
           "rigid triangle (9 coordinates, 3 constraints)": 5.0}
STEP_CASES = ["pendulum, dop853", "pendulum (README)", "driven pendulum, rkn12 + event",
              "double pendulum", "8-link pendulum", "rigid triangle (9 coordinates, 3 constraints)"]


# -- workers (run in subprocesses) ------------------------------------------------------------

def worker_cold(name):
    t0 = time.perf_counter()
    import lagrange_core  # noqa: F401
    t1 = time.perf_counter()
    system, q0, qd0, params, span, kw = make_case(name)
    t2 = time.perf_counter()
    _ = system.kernels                  # builds (or loads) them: what is timed
    t3 = time.perf_counter()
    system.simulate(q0, qd0, (0.0, span), params, **kw)
    t4 = time.perf_counter()
    return dict(imp=t1 - t0, statement=t2 - t1, kernels=t3 - t2, simulate=t4 - t3, total=t4 - t1)


def worker_steps(name, quick):
    """Per step: the slope between a run and one 10x (quick 5x) longer; fixed: a run of a
    few steps less its steps at that cost.  Minima over repetitions."""
    system, q0, qd0, params, span, kw = make_case(name)
    spans = (span / 200, span, span * (5 if quick else 10))
    system.simulate(q0, qd0, (0.0, spans[0]), params, **kw)       # compile / load
    best, steps = [], []
    for s in spans:
        times = []
        for _ in range(3 if quick else 7):
            t0 = time.perf_counter()
            tr = system.simulate(q0, qd0, (0.0, s), params, **kw)
            times.append(time.perf_counter() - t0)
        best.append(min(times))
        steps.append(tr.n_steps)
    per_step = (best[2] - best[1]) / (steps[2] - steps[1])
    return dict(per_step=per_step, fixed=best[0] - steps[0] * per_step, steps=steps[1])


MEASURE_CASES = [("vertical", 0.0), ("vertical", 0.5), ("horizontal", 0.0), ("horizontal", 0.5)]


def worker_measure(name):
    """The first ``measure`` of drive ``name`` ("vertical" or "horizontal", ", damped")."""
    import math

    from kapitza import KapitzaPendulum
    drive, _, damped = name.partition(",")
    pend = KapitzaPendulum(l=1.0, g=9.81, drive=drive, damping=0.5 if damped else 0.0)
    A, omega = 0.05, 2 * math.pi * 60
    theta0 = (math.pi - 0.1 if drive == "vertical"
              else math.acos(2 * 9.81 / (A * omega) ** 2) + 0.05)
    t0 = time.perf_counter()
    pend.measure(A, omega, theta0, periods=200)
    return dict(first=time.perf_counter() - t0)


NOTICE_CASES = ["simulate, driven pendulum", "simulate_grid rkn12, driven pendulum",
                "simulate_grid yoshida6, pendulum", "simulate_grid dop853, driven pendulum",
                "simulate_grid dop853 lanes, damped pendulum",
                "measure, vertical", "measure, vertical, damped",
                "measure_grid 16 × 16, vertical, damped",
                "floquet_point, driven 2-link chain", "pendulum_window",
                "pendulum_stability_map, damped", "lyapunov_grid, damped driven pendulum",
                "periodic_orbit, horizontal drive", "continuation, driven pendulum",
                "bifurcation_diagram, damped driven pendulum",
                "poincare_section, damped driven pendulum"]


def worker_notice(name):
    """One first use (the public API) on empty caches; the notice goes to stderr."""
    import math

    import numpy as np
    import sympy as sp

    import kapitza
    from lagrange_core import problems, t
    driven = problems.driven_pendulum("vertical", damping=False)
    p = dict(A=0.05, g=9.81, l=1.0, m=1.0, omega=2 * math.pi * 60)
    q0, qd0 = [[math.pi - 0.1], [math.pi - 0.2]], [[0.0], [0.0]]
    w0 = math.sqrt(9.81)
    damped = dict(A=0.1, g=9.81, l=1.0, m=1.0, omega=2 * w0, gamma=0.1 * w0)
    A, w = sp.symbols("A omega", positive=True)
    cases = {
        "simulate, driven pendulum": lambda: driven.simulate([math.pi - 0.1], [0.0],
                                                             (0.0, 1.0), p),
        "simulate_grid rkn12, driven pendulum": lambda: driven.simulate_grid(
            q0, qd0, (0.0, 1.0), p, method="rkn12", progress=False),
        "simulate_grid yoshida6, pendulum": lambda: problems.pendulum().simulate_grid(
            q0, qd0, (0.0, 1.0), dict(g=9.81, l=1.0, m=1.0), method="yoshida6", h=0.01,
            progress=False),
        "simulate_grid dop853, driven pendulum": lambda: driven.simulate_grid(
            q0, qd0, (0.0, 1.0), p, method="dop853", progress=False),
        # 256 points: on DOP853's lanes (lagrange_core.batch.FIRST_ORDER_LANES_MIN_POINTS)
        "simulate_grid dop853 lanes, damped pendulum": lambda: problems.driven_pendulum(
            "vertical", damping=True).simulate_grid(
            np.linspace(math.pi - 0.3, math.pi + 0.3, 256)[:, None], np.zeros((256, 1)),
            (0.0, 1.0), damped, method="dop853", progress=False),
        "measure, vertical": lambda: worker_measure("vertical"),
        "measure, vertical, damped": lambda: worker_measure("vertical,damped"),
        # 256 points: on DOP853's lanes (lagrange_core.batch.FIRST_ORDER_LANES_MIN_POINTS)
        "measure_grid 16 × 16, vertical, damped": lambda: kapitza.KapitzaPendulum(
            l=1.0, g=9.81, damping=0.5).measure_grid(
            *np.meshgrid(np.linspace(0.005, 0.2, 16), 2 * np.pi * np.linspace(5, 100, 16),
                         indexing="ij"), math.pi - 0.1, periods=500,
            observables="classification", progress=False),
        "floquet_point, driven 2-link chain": lambda: kapitza.floquet_point(
            problems.n_link_pendulum(2, pivot=(0, A * sp.cos(w * t))),
            dict(g=9.81, l1=1.0, l2=1.0, m1=1.0, m2=1.0, A=0.05, omega=300.0),
            [math.pi, math.pi]),
        "pendulum_window": lambda: kapitza.pendulum_window(300.0),
        "pendulum_stability_map, damped": lambda: kapitza.pendulum_stability_map(
            np.linspace(0.01, 0.1, 4), np.linspace(100, 400, 4), damping=0.5,
            progress=False),
        "lyapunov_grid, damped driven pendulum": lambda: kapitza.lyapunov_grid(
            problems.driven_pendulum("vertical", damping=True), damped, 0.3, periods=4,
            transient=0, blocks=2, progress=False),
        "periodic_orbit, horizontal drive": lambda: kapitza.periodic_orbit(
            problems.driven_pendulum("horizontal"), dict(p, omega=2 * math.pi * 60), [1.5]),
        "continuation, driven pendulum": lambda: kapitza.continuation(
            driven, dict(p, A=0.02, omega=20 * w0), [math.pi], parameter="A", stop=0.6,
            progress=False),
        "bifurcation_diagram, damped driven pendulum": lambda: kapitza.bifurcation_diagram(
            problems.driven_pendulum("vertical", damping=True), damped, parameter="A",
            values=[0.1, 0.2], angles="theta", periods=2, transient=1, progress=False),
        "poincare_section, damped driven pendulum": lambda: kapitza.poincare_section(
            problems.driven_pendulum("vertical", damping=True), damped, 0.3, periods=50,
            progress=False),
    }
    t0 = time.perf_counter()
    cases[name]()
    return dict(seconds=time.perf_counter() - t0)


def notices_table():
    print(f"5. The compile notice's estimate against the first use (each in a fresh process, "
          f"empty caches; load before {os.getloadavg()[0]:.1f}), s")
    print(f"{'first use':>40} {'call':>7} {'notice':>7} {'notice/call':>11}  notice")
    for name in NOTICE_CASES:
        env = empty_caches()
        env.pop("LAGRANGE_CORE_COMPILE_NOTICE", None)
        out = subprocess.run([sys.executable, os.path.abspath(__file__), "--worker", "notice",
                              name], env=env, capture_output=True, text=True, check=False)
        if out.returncode != 0:
            raise RuntimeError(f"{name} failed:\n{out.stderr[-3000:]}")
        call = json.loads(out.stdout.strip().splitlines()[-1])["seconds"]
        lines = [x for x in out.stderr.splitlines() if "compiling numba kernels" in x]
        quoted = float(lines[0].split("~")[1].split(" s")[0]) if lines else float("nan")
        said = lines[0].split("first use")[1].split(";")[0].strip(" ,") if lines else "none"
        print(f"{name:>40} {call:7.1f} {quoted:7.0f} {quoted / call:11.2f}  {said}",
              flush=True)
    print(f"load after: {os.getloadavg()[0]:.1f}")


NEW_SYSTEM_CASES = ["mass matrix, 4-link pendulum", "normal modes, 8-link pendulum",
                    "bifurcation diagram, damped driven pendulum",
                    "normal modes, string of 200 beads", "rkn12 simulate, string of 20 beads",
                    "grid on lanes, 2 coupled driven pendulums",
                    "Lyapunov map on lanes, damped 2-link driven chain"]


def worker_new_system(name):
    """One first use of a system never seen (the kernel store is empty)."""
    import math
    import warnings

    import numpy as np

    from lagrange_core import problems
    t0 = time.perf_counter()
    if name.startswith("mass matrix"):
        system = problems.n_link_pendulum(4)
        n = system.n_dof
        p = np.ones(len(system.parameters))
        M, F = np.empty((n, n)), np.empty(n)
        system.kernels.mass_forcing(np.full(n, 0.3), np.zeros(n), 0.0, p, M, F)
    elif name == "normal modes, string of 200 beads":      # tests/test_hard_cases.py
        problems.bead_string(200).normal_modes(dict(F=80.0, mu=0.005, l=0.65))
    elif name == "rkn12 simulate, string of 20 beads":      # a sparse [M | F]
        N = 20
        y0 = 1e-5 * np.sin(np.pi * np.arange(1, N + 1) / (N + 1))
        problems.bead_string(N).simulate(y0, np.zeros(N), (0.0, 0.01),
                                         dict(F=80.0, mu=0.005, l=0.65), method="rkn12")
    elif name.startswith("grid on lanes"):  # fast_accel_lanes (+ the scalar fast_accel)
        import sympy as sp

        from lagrange_core import System, coordinates, t
        # (tests/test_batch_speedpath.py: q̈ = M⁻¹ F(q, t), M constant and not diagonal)
        qs, qds = coordinates(["th0", "th1"])
        m, l, g, A, om, k = sp.symbols("m l g A omega k", positive=True)
        T = m * l**2 * (qds[0]**2 + qds[1]**2 + qds[0] * qds[1] / 2)
        V = -sum(m * l * (g - A * om**2 * sp.cos(om * t)) * sp.cos(q) for q in qs)
        V += k * (qs[0] - qs[1]) ** 2 / 2
        system = System(qs, lagrangian=T - V, name="2 coupled driven pendulums")
        p = dict(m=1.0, l=1.0, g=9.81, k=2.0, A=np.array([0.01, 0.02, 0.03, 0.04]),
                 omega=2 * np.pi * 20.0)
        system.simulate_grid([3.0, 3.1], [0.0, 0.0], (0.0, 0.5), p, method="rkn12",
                             progress=False)
    elif name.startswith("Lyapunov map"):   # rhs_lanes, rhs_jvp_lanes (+ rhs, jacobian)
        from kapitza.chaos import lyapunov_grid
        from lagrange_core import effects as fx
        system = fx.build(fx.n_link_rig(2), [fx.Gravity(), fx.PivotDrive("vertical"),
                                             fx.Damping()])
        p = dict(A=np.array([0.01, 0.02, 0.03, 0.04]), g=9.81, gamma=0.5, l1=1.0, l2=1.0,
                 m1=1.0, m2=1.0, omega=2 * np.pi * 20.0)
        lyapunov_grid(system, p, [3.0, 3.1], periods=4, transient=0, blocks=2,
                      progress=False)
    elif name.startswith("normal modes"):
        system = problems.n_link_pendulum(8)
        system.normal_modes({p: (9.81 if p == "g" else 1.0) for p in system.parameters})
    else:
        from kapitza.chaos import bifurcation_diagram
        warnings.simplefilter("ignore")
        system = problems.driven_pendulum("vertical", damping=True)
        w0 = math.sqrt(9.81)
        p = dict(A=0.1, g=9.81, l=1.0, m=1.0, omega=2 * w0, gamma=0.1 * w0)
        bifurcation_diagram(system, p, parameter="A", values=[0.1, 0.2], angles="theta",
                            periods=2, transient=1, progress=False)
    return dict(first=time.perf_counter() - t0)


@contextlib.contextmanager
def trees(baseline):
    """[("new", env)], and with ``baseline`` ("old", env) whose PYTHONPATH is git revision
    ``baseline``'s source tree (a temporary worktree, removed afterwards)."""
    envs = [("new", dict(os.environ))]
    tmp = None
    if baseline:
        tmp = tempfile.mkdtemp(prefix="kapitza-baseline-")
        subprocess.run(["git", "-C", ROOT, "worktree", "add", "--detach", tmp, baseline],
                       check=True, capture_output=True)
        # its bytecode written, as this tree's is: where PYTHONDONTWRITEBYTECODE is set
        # (this machine) every process would compile REV's ~150 modules from source, 0.5 s
        subprocess.run([sys.executable, "-m", "compileall", "-q", os.path.join(tmp, "kapitza"),
                        os.path.join(tmp, "lagrange_core")], check=True, capture_output=True)
        envs.append(("old", {**os.environ, "PYTHONPATH": tmp}))
    try:
        yield envs
    finally:
        if tmp:
            subprocess.run(["git", "-C", ROOT, "worktree", "remove", "--force", tmp],
                           check=False, capture_output=True)


def alternated(envs, rounds, measure):
    """{label: [measure(env), ...]} for each tree of ``envs`` (:func:`trees`), ``rounds``
    times, the trees' processes alternated (so that a drift of the machine's pace falls
    on both)."""
    res = {label: [] for label, _ in envs}
    for _ in range(rounds):
        for label, env in envs:
            res[label].append(measure(env))
    return res


def print_alternated(cases, envs, rounds, title, width):
    """For each (name, measure) of ``cases``: one untimed round per tree (what it compiles
    or loads once), then :func:`alternated`; a row of medians, new/old with a baseline,
    and every value."""
    baseline = len(envs) > 1
    print(f"{title:>{width}} {'new':>7}" + (f" {'old':>7} {'new/old':>8}" if baseline else ""))
    for name, measure in cases:
        for _, env in envs:
            measure(env)
        res = alternated(envs, rounds, measure)
        med = {k: statistics.median(v) for k, v in res.items()}
        row = f"{name:>{width}} {med['new']:7.2f}"
        if baseline:
            row += f" {med['old']:7.2f} {med['new'] / med['old']:8.2f}"
        print(row + "   (new: " + ", ".join(f"{x:.2f}" for x in res["new"])
              + (("; old: " + ", ".join(f"{x:.2f}" for x in res["old"])) if baseline
                 else "") + ")", flush=True)


def new_system_table(quick, baseline):
    rounds = 1 if quick else 3
    print(f"\n4. A new system's first use (empty kernel store; medians of {rounds} "
          "processes), s")

    def once(name, env):
        with tempfile.TemporaryDirectory() as store:     # (REV's packages by PYTHONPATH)
            return run_worker("new-system", name, env={
                **env, "LAGRANGE_CORE_CACHE": store, "LAGRANGE_CORE_COMPILE_NOTICE": "0"})["first"]

    with trees(baseline) as envs:
        print_alternated([(name, lambda env, name=name: once(name, env))
                          for name in NEW_SYSTEM_CASES], envs, rounds, "case", 48)


def timed(cmd, env, cwd=None):
    """Wall and CPU seconds (the process and its children) of ``cmd``."""
    import resource
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    out = subprocess.run(cmd, env=env, capture_output=True, text=True, check=False, cwd=cwd)
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    if out.returncode not in (0, 1):          # the report exits 1 when a section failed
        raise RuntimeError(f"{cmd} failed:\n{out.stderr[-3000:]}")
    return wall, cpu, out


#: (label, the command line after ``kapitza``): warm commands a user types
COMMAND_CASES = [("predict", ["predict", "--A", "0.05", "--f", "60"]),
                 ("measure, 50 periods", ["measure", "--A", "0.05", "--f", "60",
                                          "--periods", "50"]),
                 ("--version", ["--version"])]


def commands_table(rounds, baseline):
    print(f"\n6. A command with warm caches (python -m kapitza ..., a fresh process each; "
          f"medians of {rounds}), wall s")
    # run from a folder of its own: ``python -m`` puts the working folder first on the
    # path, which from the repository's root would be this tree's package for both trees
    with tempfile.TemporaryDirectory(prefix="kapitza-commands-") as where, \
            trees(baseline) as envs:
        def once(argv, env):
            return timed([sys.executable, "-m", "kapitza", *argv], env, cwd=where)[0]

        print_alternated([(name, lambda env, argv=argv: once(argv, env))
                          for name, argv in COMMAND_CASES], envs, rounds, "command", 24)


#: the empty cache folders made for this run, removed when it ends (each run left ~3 MB
#: per cold process in the temporary folder: 134 MB after a few dozen runs)
_EMPTIED: list[str] = []
atexit.register(lambda: [shutil.rmtree(d, ignore_errors=True) for d in _EMPTIED])


def empty_caches():
    """This process's environment with both caches pointed at new, empty folders."""
    env = {**os.environ, "LAGRANGE_CORE_CACHE": tempfile.mkdtemp(prefix="lc-cold-"),
           "NUMBA_CACHE_DIR": tempfile.mkdtemp(prefix="numba-cold-")}
    _EMPTIED.extend((env["LAGRANGE_CORE_CACHE"], env["NUMBA_CACHE_DIR"]))
    return env


def first_use_table(without_warmup, report=True):
    load = os.getloadavg()
    print(f"3. First use on empty caches (load before {load[0]:.1f}, {os.cpu_count()} CPUs), s")
    print(f"{'what':>52} {'wall':>7} {'cpu':>7} {'target':>8}")

    def row(what, wall, cpu, target=""):
        print(f"{what:>52} {wall:7.1f} {cpu:7.1f} {target:>8}", flush=True)

    if report:
        with tempfile.TemporaryDirectory() as out:
            wall, cpu, res = timed([sys.executable, "-m", "kapitza", "report", "--out", out],
                                   empty_caches())
        notices = res.stderr.count("compiling numba kernels for first use")
        row(f"kapitza report (compile notices: {notices})", wall, cpu, "<= 45")
    env = empty_caches()
    wall, cpu, _ = timed([sys.executable, "-c", "import kapitza; kapitza.warmup()"], env)
    row("kapitza.warmup()", wall, cpu)
    for drive, damping in MEASURE_CASES:
        name = drive + (",damped" if damping else "")
        wall, cpu, res = timed([sys.executable, os.path.abspath(__file__), "--worker",
                                "measure", name], env)
        first = json.loads(res.stdout.strip().splitlines()[-1])["first"]
        row(f"process with first measure, {name}, after warmup", wall, cpu)
        row(f"  of which the measure call, {name}", first, float("nan"), "<= 5")
    if without_warmup:
        for drive, damping in MEASURE_CASES:
            name = drive + (",damped" if damping else "")
            wall, cpu, res = timed([sys.executable, os.path.abspath(__file__), "--worker",
                                    "measure", name], empty_caches())
            first = json.loads(res.stdout.strip().splitlines()[-1])["first"]
            row(f"first measure, {name}, empty caches", first, cpu, "<= 15")
    print(f"load after: {os.getloadavg()[0]:.1f}")


def run_worker(kind, name, *, env=None, quick=False):
    cmd = [sys.executable, os.path.abspath(__file__), "--worker", kind, name]
    if quick:
        cmd.append("--quick")
    out = subprocess.run(cmd, env=env, capture_output=True, text=True, check=False)
    if out.returncode != 0:
        raise RuntimeError(f"worker {kind} {name!r} failed:\n{out.stderr[-3000:]}")
    return json.loads(out.stdout.strip().splitlines()[-1])


# -- main -------------------------------------------------------------------------------------

def cold_table(repeats):
    print("1. Cold start: a system never seen, integrators compiled once per installation "
          f"(medians of {repeats} fresh processes), s")
    subprocess.run([sys.executable, "-c", "import lagrange_core; lagrange_core.warmup()"],
                   check=True)
    print(f"{'case':>48} {'import':>7} {'statement':>9} {'kernels':>8} {'simulate':>9} "
          f"{'total':>7} {'target':>7}")
    for name in COLD_CASES:
        runs = []
        for _ in range(repeats):
            with tempfile.TemporaryDirectory() as store:
                runs.append(run_worker("cold", name,
                                       env={**os.environ, "LAGRANGE_CORE_CACHE": store}))
        med = {k: statistics.median(r[k] for r in runs) for k in runs[0]}
        target = TARGETS.get(name)
        print(f"{name:>48} {med['imp']:7.2f} {med['statement']:9.3f} {med['kernels']:8.2f} "
              f"{med['simulate']:9.2f} {med['total']:7.2f} "
              f"{'< ' + str(target) if target else '':>7}")


def steps_table(quick, baseline):
    print("\n2. Running cost: per step and fixed per simulate call (minima of repeated runs)")
    with trees(baseline) as envs:
        head = f"{'case':>48} {'ns/step':>9} {'fixed ms':>9}"
        if baseline:
            head += f" {'old ns/step':>11} {'old fixed':>9} {'step ratio':>10} {'fixed ratio':>11}"
        print(head)
        for name in STEP_CASES:
            res = alternated(envs, 1 if quick else 3, lambda env, name=name: run_worker(
                "steps", name, env=env, quick=quick))
            med = {k: {f: statistics.median(r[f] for r in v) for f in v[0]} for k, v in res.items()}
            row = f"{name:>48} {med['new']['per_step'] * 1e9:9.0f} {med['new']['fixed'] * 1e3:9.3f}"
            if baseline:
                o = med["old"]
                row += (f" {o['per_step'] * 1e9:11.0f} {o['fixed'] * 1e3:9.3f} "
                        f"{med['new']['per_step'] / o['per_step']:10.2f} "
                        f"{med['new']['fixed'] / o['fixed']:11.2f}")
            print(row)


def main():
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--quick", action="store_true", help="fewer repetitions (a smoke run)")
    ap.add_argument("--baseline", metavar="REV", help="also measure git revision REV")
    ap.add_argument("--worker", nargs=2, metavar=("KIND", "CASE"), help=argparse.SUPPRESS)
    ap.add_argument("--only", choices=["cold", "steps", "first-use", "new-system", "notices",
                                       "commands"],
                    help="run one of the parts (first-use, new-system, notices, commands: "
                         "only when asked)")
    ap.add_argument("--no-report", action="store_true",
                    help="first-use: leave out the report (the longest part)")
    ap.add_argument("--without-warmup", action="store_true",
                    help="first-use: also each drive's first measure on empty caches")
    args = ap.parse_args()
    if args.worker:
        kind, name = args.worker
        out = (worker_cold(name) if kind == "cold" else worker_measure(name)
               if kind == "measure" else worker_new_system(name) if kind == "new-system"
               else worker_notice(name) if kind == "notice"
               else worker_steps(name, args.quick))
        print(json.dumps(out))
        return
    if args.only in (None, "cold"):
        cold_table(1 if args.quick else 3)
    if args.only in (None, "steps"):
        steps_table(args.quick, args.baseline)
    if args.only == "first-use":
        first_use_table(args.without_warmup, report=not args.no_report)
    if args.only == "new-system":
        new_system_table(args.quick, args.baseline)
    if args.only == "notices":
        notices_table()
    if args.only == "commands":
        commands_table(3 if args.quick else 9, args.baseline)


if __name__ == "__main__":
    main()
