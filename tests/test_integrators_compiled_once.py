"""The integrators are compiled once per installation and serve every system (issue 9).

A new system's first ``simulate`` compiles only the system's own kernels: the drivers in
``lagrange_core._integrator_kernels`` reach them by address, so numba's cache serves the
same machine code to every system, and a process that finds a system's kernels in the
store neither derives nor compiles.
"""
import json
import math
import subprocess
import sys
import textwrap

import numpy as np

from lagrange_core import _integrator_kernels as kern
from lagrange_core import problems


def _run(code, env=None):
    out = subprocess.run([sys.executable, "-c", textwrap.dedent(code)], capture_output=True,
                         text=True, check=True, env=env)
    return json.loads(out.stdout.strip().splitlines()[-1])


def test_one_compiled_driver_serves_different_systems():
    """Two systems of different sizes run through the same compiled DOP853 driver."""
    single, double = problems.pendulum(), problems.double_pendulum()
    single.simulate([0.3], [0.0], (0, 0.5), {p: 1.0 for p in single.parameters}, method="dop853")
    n_before = len(kern.dop853_chunk.signatures)
    double.simulate([0.3, 0.1], [0.0, 0.0], (0, 0.5), {p: 1.0 for p in double.parameters})
    assert len(kern.dop853_chunk.signatures) == n_before == 1


def test_a_new_system_loads_the_drivers_from_numba_cache(tmp_path):
    """In a fresh process with an empty kernel store (a system never seen), every driver
    the run needs comes from numba's cache: no driver is compiled."""
    import lagrange_core
    lagrange_core.warmup()
    info = _run("""
        import json, math
        import sympy as sp
        import lagrange_core as lc
        from lagrange_core import _integrator_kernels as kern
        (x,), _ = lc.coordinates("x")
        k, m = sp.symbols("k m", positive=True)
        s = lc.System([x], particles=[lc.Particle(m, (x,))], potential=k * x**4 / 4)
        s.simulate([1.0], [0.0], (0, 1), dict(k=1.0, m=1.0))                # rkn12
        s.simulate([1.0], [0.0], (0, 1), dict(k=1.0, m=1.0), method="dop853")
        misses = {f: sum(getattr(kern, f).stats.cache_misses.values())
                  for f in ("dop853_chunk", "fast_rkn_chunk", "along", "initial_step")}
        print(json.dumps(misses))
    """, env={**__import__("os").environ, "LAGRANGE_CORE_CACHE": str(tmp_path)})
    assert info == {"dop853_chunk": 0, "fast_rkn_chunk": 0, "along": 0, "initial_step": 0}


def test_warm_store_never_derives():
    """A process that finds the kernels and the drive kernel in the store integrates with
    the default (RKN) method without deriving the equations."""
    code = """
        import json, math
        from lagrange_core import problems
        s = problems.driven_pendulum()
        p = {k: 1.0 for k in s.parameters}
        tr = s.simulate([math.pi - 0.1], [0.0], (0, 0.2), p)
        print(json.dumps({"derived": "equations" in s.__dict__, "method": tr.method}))
    """
    s = problems.driven_pendulum()                  # fills the store (here: no third process)
    s.simulate([math.pi - 0.1], [0.0], (0, 0.2), {k: 1.0 for k in s.parameters})
    assert _run(code) == {"derived": False, "method": "rkn12"}


def test_rigid_triangle_keeps_its_constraints():
    """A constrained system of 9 coordinates and 3 constraints (three masses rigidly joined,
    one held by a spring, in gravity): the projected DOP853 run keeps Φ = 0 and Φ̇ = 0 to
    the tolerance and conserves the energy (all forces conservative)."""
    import sympy as sp

    import lagrange_core as lc
    q, _ = lc.coordinates("x1 y1 z1 x2 y2 z2 x3 y3 z3")
    m, g, k, a = sp.symbols("m g k a", positive=True)
    r = [q[0:3], q[3:6], q[6:9]]
    d2 = lambda u, v: sum((ui - vi) ** 2 for ui, vi in zip(u, v, strict=True))     # noqa: E731
    system = lc.System(q, particles=[lc.Particle(m, tuple(ri)) for ri in r],
                       potential=sum(m * g * ri[2] for ri in r) + k * d2(r[0], (0, 0, 0)) / 2,
                       constraints=[d2(r[0], r[1]) - a**2, d2(r[1], r[2]) - a**2,
                                    d2(r[2], r[0]) - a**2])
    h = math.sqrt(3) / 2
    tr = system.simulate([0, 0, 0, 1, 0, 0, 0.5, h, 0], [0, 0, 0, 0, 0, 0.3, 0, 0, -0.3],
                         (0.0, 5.0), dict(m=1.0, g=9.81, k=50.0, a=1.0), rtol=1e-10)
    assert tr.status == "success"
    assert np.max(tr.constraint_residual) < 1e-9
    assert np.max(np.abs(tr.energy - tr.energy[0])) < 1e-7 * np.max(np.abs(tr.energy))
    assert tr.multipliers.shape == (len(tr.t), 3) and np.all(np.isfinite(tr.multipliers))


def test_numba_cache_is_flushed_when_a_module_it_calls_into_changes(tmp_path, monkeypatch):
    """numba keys a cached function by its own file; guard_numba_cache also empties the
    cache when a module the functions call into changes (a changed kernel slot would
    otherwise call the wrong kernel).

    Each "run" imports the module afresh, as a new process would: a new dispatcher, which
    looks in numba's cache on disk at its first call, and guard_numba_cache, which compares
    the marker on disk (neither keeps anything in the process).  Run in this process, not
    in four fresh ones (10 s: each imported lagrange_core for a one-line function)."""
    (tmp_path / "_flush_dep.py").write_text("VALUE = 1\n")
    (tmp_path / "_flush_user.py").write_text(textwrap.dedent("""
        import sys
        from numba import njit
        import _flush_dep
        from lagrange_core.module_store import guard_numba_cache

        @njit(cache=True)
        def f(x):
            return x + _flush_dep.VALUE

        guard_numba_cache(sys.modules[__name__], _flush_dep)
    """))
    monkeypatch.setenv("LAGRANGE_CORE_CACHE", str(tmp_path / "store"))
    monkeypatch.syspath_prepend(str(tmp_path))

    def run():
        for name in ("_flush_user", "_flush_dep"):
            monkeypatch.delitem(sys.modules, name, raising=False)
        import _flush_user
        return [_flush_user.f(1), sum(_flush_user.f.stats.cache_hits.values())]

    assert run() == [2, 0]          # compiled
    assert run() == [2, 1]          # from the cache
    # (a new length: the import system and inspect tell an edited file by its size and
    # whole-second time, and this edit comes within the second)
    (tmp_path / "_flush_dep.py").write_text("VALUE = 50\n")
    assert run() == [51, 0]         # the callee's module changed: recompiled, not stale
    assert run() == [51, 1]


def test_the_symplectic_grid_compiles_its_driver_without_rkn12():
    """A symplectic grid passes RKN 12's tables as None: numba then prunes every branch
    of the per-point driver that tests them and compiles it without RKN 12's code (its
    first grid 10–11 s on an empty cache, 26–29 s with it: benchmarks/README.md).  Were
    the tables passed, the numbers would not change — only the first grid's wait."""
    from numba import types

    from lagrange_core import _batch_kernels as bk
    pend = problems.pendulum()
    params = dict(g=9.81, l=1.0, m=1.0)
    grid = pend.simulate_grid([1.0], [0.0], (0.0, 2.0), params, method="yoshida6", h=0.2,
                              progress=False)
    one = pend.simulate([1.0], [0.0], (0.0, 2.0), params, method="yoshida6", h=0.2)
    np.testing.assert_allclose(grid.q[0], one.q[-1, 0], rtol=1e-12)    # the same steps
    rkn_types = {sig[1] for sig in bk._second_order_rows.signatures}
    assert types.none in rkn_types, rkn_types


def _jit_decorated(function):
    """(jitted, inlined): whether a function definition carries a numba decorator, and
    whether numba inlines it into its callers (``inline=`` anything but "never")."""
    import ast
    for decorator in function.decorator_list:
        target = decorator.func if isinstance(decorator, ast.Call) else decorator
        name = target.attr if isinstance(target, ast.Attribute) else getattr(target, "id", "")
        if "jit" in name:
            inline = [k.value for k in getattr(decorator, "keywords", ()) if k.arg == "inline"]
            inlined = bool(inline) and not (isinstance(inline[0], ast.Constant)
                                            and inline[0].value == "never")
            return True, inlined
    return False, False


def test_no_kernel_is_compiled_again_for_a_constant_argument():
    """numba types a bare integer or boolean constant argument (``0``, ``1``, ``True``) as
    a literal, and compiles the callee once for each literal and once more for a variable:
    the second-order event functions (family 0 and 1: 4 s more on an empty cache), the
    Floquet period map's Taylor series (True and False, 2.5 s), the chaos lanes' tangent
    (1 and L, 2.8 s) and the lanes' scalar fallback (False and True, 0.5 s) were compiled
    twice so.  In the source of both packages, no jitted function calls another one that
    is not inlined with a bare constant at an argument where some other call passes a
    different constant or a variable (pass np.int64(…)/np.bool_(…)).  A reading of the
    source, not of numba's caches: a kernel loaded from the cache with its caller never
    shows its own signatures, so a first use would have to compile everything to see it."""
    import ast
    from pathlib import Path

    root = Path(__file__).resolve().parent.parent
    # Only a file whose text contains "jit" can hold a jitted function (the decorator's
    # name must contain it, _jit_decorated), so only those are parsed -- a quarter of the
    # lines -- and each is walked once, for its jitted functions.
    texts = {path: path.read_text() for package in ("lagrange_core", "kapitza")
             for path in sorted((root / package).rglob("*.py"))}
    jitted_functions = []       # (path, function definition) of every jitted function
    compiled = set()            # jitted functions numba compiles as functions of their own
    for path, text in texts.items():
        if "jit" not in text:
            continue
        for node in ast.walk(ast.parse(text)):
            if isinstance(node, ast.FunctionDef):
                jitted, inlined = _jit_decorated(node)
                if jitted:
                    jitted_functions.append((path, node))
                if jitted and not inlined:
                    compiled.add(node.name)

    def constant(arg):
        value = arg.operand if isinstance(arg, ast.UnaryOp) and isinstance(arg.op, ast.USub) \
            else arg
        ok = isinstance(value, ast.Constant) and isinstance(value.value, (bool, int))
        return ast.unparse(arg) if ok else None         # (−1 stays −1)

    passed = {}                 # (callee, position) -> {constant or "a variable": [where]}
    for path, function in jitted_functions:
        for call in ast.walk(function):
            if not isinstance(call, ast.Call):
                continue
            f = call.func
            name = f.attr if isinstance(f, ast.Attribute) else getattr(f, "id", None)
            if name not in compiled:
                continue
            for k, arg in enumerate(call.args):
                value = constant(arg) or "a variable"
                passed.setdefault((name, k), {}).setdefault(value, []).append(
                    f"{path.relative_to(root)}:{call.lineno}")
    twice = {f"{name} argument {k}": values for (name, k), values in passed.items()
             if len(values) > 1 and set(values) != {"a variable"}}
    assert not twice, twice
    # the reading sees the kernels it is about (a decorator spelt otherwise would hide them)
    assert {"second_order_events", "_taylor_period", "_tangent", "_rhs_again"} <= compiled
