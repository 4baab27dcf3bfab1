"""Compiled kernels: exactness, the disk cache, and no recompilation on parameter changes."""
import subprocess
import sys
import textwrap

import numpy as np
import pytest
import sympy as sp
from numba import njit

import lagrange_core as lc
from lagrange_core import codegen, problems

PARAMS = dict(m1=1.3, m2=0.7, l1=1.1, l2=0.9, g=9.81)


@pytest.fixture(scope="module")
def double():
    system = problems.double_pendulum()
    return system, system.kernels


def test_jacobian_is_exact(double):
    """Forward-mode Jacobian against the symbolic derivative of q̈ = M⁻¹F."""
    system, k = double
    e = system.equations
    qdd = e.mass_matrix.LUsolve(e.forcing)
    y_syms = [*system.q, *system.qdot]
    J_sym = sp.lambdify([*y_syms, *system.parameter_symbols], qdd.jacobian(y_syms))
    y = np.array([0.3, -1.2, 0.5, 2.0])
    p = system.parameter_array(PARAMS)
    J = np.empty((4, 4))
    assert k.jacobian(0.0, y, p, J) == 0
    np.testing.assert_array_equal(J[:2], [[0, 0, 1, 0], [0, 0, 0, 1]])
    expected = np.array(J_sym(*y, *p), dtype=float)
    np.testing.assert_allclose(J[2:], expected, rtol=1e-13, atol=1e-13 * np.abs(expected).max())


def test_constrained_jacobian_matches_finite_differences():
    (x, y), _ = lc.coordinates("x y")
    m, l, g = sp.symbols("m l g", positive=True)
    system = lc.System([x, y], particles=[lc.Particle(m, (x, y))], potential=m * g * y,
                       constraints=[x**2 + y**2 - l**2])
    k = system.kernels
    p = system.parameter_array(dict(m=1.0, l=1.0, g=9.81))
    state = np.array([np.sin(0.4), -np.cos(0.4), 0.7 * np.cos(0.4), 0.7 * np.sin(0.4)])
    J = np.empty((4, 4))
    assert k.jacobian(0.0, state, p, J) == 0
    W = k.work_array()

    def f(s):
        out = np.empty(4)
        k.rhs(0.0, s, p, out, W)
        return out

    h = 1e-6
    J_fd = np.column_stack([(f(state + h * e) - f(state - h * e)) / (2 * h) for e in np.eye(4)])
    np.testing.assert_allclose(J, J_fd, atol=1e-7)


def _load_variant(source, stem):
    """Load a generated source from the kernel cache directory (numba caches it there)."""
    import hashlib
    name = f"{stem}_{hashlib.sha256(source.encode()).hexdigest()[:16]}"
    path = codegen.cache_dir() / f"{name}.py"
    if not path.exists():
        codegen.write_module(path, source)
    return codegen.load_module(path, name)


def test_common_subexpression_elimination_changes_nothing(double):
    system, k = double
    plain = _load_variant(codegen.generate_source(system.equations, cse=False), "lc_test_plain")
    rng = np.random.default_rng(1)
    p = system.parameter_array(PARAMS)
    for _ in range(5):
        y = rng.uniform(-2, 2, 4)
        a, b = np.empty(4), np.empty(4)
        k.rhs(0.3, y, p, a, k.work_array())
        plain.rhs(0.3, y, p, b, plain.new_work())
        np.testing.assert_allclose(a, b, rtol=1e-13, atol=1e-13)


def test_parameter_change_does_not_recompile(double):
    system, k = double
    W = k.work_array()
    out = np.empty(4)
    q, qdd, lam = np.array([0.1, 0.2]), np.empty(2), np.empty(0)

    def accelerations(g):
        p = system.parameter_array({**PARAMS, "g": g})
        k.accelerations(q, np.zeros(2), 0.0, p, qdd, lam, W)
        system.accelerations(q, [0, 0], 0.0, {**PARAMS, "g": g})

    accelerations(3.0)                                      # compiles on first use
    before = {name: len(getattr(k, name).signatures) for name in ("rhs", "accelerations")}
    assert all(before.values())
    for g in (1.0, 9.81, 24.8):
        k.rhs(0.0, np.ones(4), system.parameter_array({**PARAMS, "g": g}), out, W)
        accelerations(g)
    assert {name: len(getattr(k, name).signatures) for name in before} == before


def _slider_pendulum():
    """A cart on a rail with a pendulum, its bob held by a constraint (3 coordinates)."""
    (x, px, py), _ = lc.coordinates("x px py")
    M, m, l, g = sp.symbols("M m l g", positive=True)
    return lc.System([x, px, py], particles=[lc.Particle(M, (x, 0)), lc.Particle(m, (px, py))],
                     potential=m * g * py, constraints=[(px - x)**2 + py**2 - l**2])


def _spring_pendulum():
    """A pendulum on a spring (2 coordinates: length and angle), this test's own statement."""
    (r, th), _ = lc.coordinates("r th")
    m, k, l0, g = sp.symbols("m k l0 g", positive=True)
    return lc.System([r, th], particles=[lc.Particle(m, (r * sp.sin(th), -r * sp.cos(th)))],
                     potential=-m * g * r * sp.cos(th) + k * (r - l0)**2 / 2)


@pytest.mark.parametrize("which", ["spring pendulum", "constrained"])
def test_accelerations_and_linearize_compile_no_accelerations_kernel(which):
    """``System.accelerations`` takes q̈ and λ from ``rhs`` (which every integration of a
    system compiles) and ``linearize`` from M and F (or the augmented system), which it
    evaluates anyway: neither compiles the ``accelerations`` kernel for the same numbers
    (for a string of 200 beads 5.2 s cold), ``linearize`` not even ``rhs``; the values
    equal that kernel's to 1e-13, and both equilibria's ω² their closed forms."""
    if which == "spring pendulum":
        system, p_by_name = _spring_pendulum(), dict(m=0.4, k=30.0, l0=0.8, g=9.81)
        q, qd = np.array([0.9, -1.2]), np.array([0.5, 2.0])
    else:
        system, p_by_name = _slider_pendulum(), dict(M=2.0, m=0.7, l=1.1, g=9.81)
        q = np.array([0.2, 0.2 + 1.1 * np.sin(0.4), -1.1 * np.cos(0.4)])
        qd = np.array([0.3, 0.3 + 0.8 * np.cos(0.4), 0.8 * np.sin(0.4)])
    k = system.kernels
    # this process has called neither (nor the generators: this test's own statements)
    assert k.accelerations.signatures == [] and k.rhs.signatures == []
    # the equilibrium hanging at rest: ω² in closed form
    if which == "spring pendulum":
        g = p_by_name["g"]
        r_eq = p_by_name["l0"] + p_by_name["m"] * g / p_by_name["k"]
        w2 = system.linearize(p_by_name, about=[r_eq, 0.0]).omega_squared
        np.testing.assert_allclose(w2, sorted([g / r_eq, p_by_name["k"] / p_by_name["m"]]),
                                   rtol=1e-12)
    else:        # the cart translates freely; the pendulum swings at g (M + m) / (M l)
        M_, m_, l_, g = (p_by_name[name] for name in ("M", "m", "l", "g"))
        w2 = system.linearize(p_by_name, about=[0.0, 0.0, -l_]).omega_squared
        np.testing.assert_allclose(w2, [0.0, g * (M_ + m_) / (M_ * l_)], rtol=1e-12,
                                   atol=1e-12 * g / l_)
    assert k.accelerations.signatures == [] and k.rhs.signatures == []
    got = system.accelerations(q, qd, 0.1, p_by_name)
    qdd_got, lam_got = got if system.n_constraints else (got, np.empty(0))
    assert k.accelerations.signatures == []             # nothing compiled for it
    n, m = system.n_dof, system.n_constraints
    qdd, lam = np.empty(n), np.empty(m)
    p = system.parameter_array(p_by_name)
    assert k.accelerations(q, qd, 0.1, p, qdd, lam, k.work_array()) == 0
    np.testing.assert_allclose(qdd_got, qdd, rtol=1e-13, atol=1e-13 * np.abs(qdd).max())
    np.testing.assert_allclose(lam_got, lam, rtol=1e-13)
    if m:
        assert lam_got.shape == (1,) and lam_got[0] != 0.0


def test_kernels_are_callable_from_numba_code(double):
    system, k = double
    rhs = k.rhs

    @njit
    def euler(y, p, h, steps):
        W = np.zeros((8, 3))   # any scratch with at least WORK_SHAPE rows works
        dy = np.empty_like(y)
        for _ in range(steps):
            rhs(0.0, y, p, dy, W)
            y = y + h * dy
        return y

    assert k.work_array().shape[1] == 3
    y = euler(np.array([0.1, 0.0, 0.0, 0.0]), system.parameter_array(PARAMS), 1e-4, 10)
    assert np.all(np.isfinite(y)) and y[0] < 0.1


_FRESH_FACTORIES = ("double_pendulum()", "n_link_pendulum(8)")


def _first_calls(system):
    """The system's kernels (from the store, or derived and written to it) and a first call
    of ``rhs`` and ``jacobian`` (from numba's cache, or compiled and written to it)."""
    k = system.kernels
    n = system.n_dof
    k.rhs(0.0, np.zeros(2 * n), np.ones(len(system.parameters)), np.empty(2 * n),
          k.work_array())
    k.jacobian(0.0, np.zeros(2 * n), np.ones(len(system.parameters)),
               np.empty((2 * n, 2 * n)))
    return k


@pytest.fixture(scope="module")
def fresh_process_kernels():
    """factory -> what one new process found for that system: whether it derived, and
    its kernels' numba cache hits and misses.

    The calls are made here first (they fill the store and numba's cache if this is the
    first test to need them: a cold cache), then by one new process for both systems
    (the systems are independent: each has its own store entry and numba cache)."""
    import json
    for factory in _FRESH_FACTORIES:
        _first_calls(eval(f"problems.{factory}"))
    script = textwrap.dedent(f"""
        import json, numpy as np, lagrange_core as lc
        info = {{}}
        for factory in {_FRESH_FACTORIES!r}:
            s = eval(f"lc.problems.{{factory}}")
            k = s.kernels                               # the calls of _first_calls
            n = s.n_dof
            k.rhs(0.0, np.zeros(2 * n), np.ones(len(s.parameters)), np.empty(2 * n),
                  k.work_array())
            k.jacobian(0.0, np.zeros(2 * n), np.ones(len(s.parameters)),
                       np.empty((2 * n, 2 * n)))
            info[factory] = {{"derived": "equations" in s.__dict__,
                             "hits": sum(k.rhs.stats.cache_hits.values())
                                     + sum(k.jacobian.stats.cache_hits.values()),
                             "misses": sum(k.rhs.stats.cache_misses.values())
                                       + sum(k.jacobian.stats.cache_misses.values())}}
        print(json.dumps(info))
    """)
    out = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True,
                         check=True)
    return json.loads(out.stdout.strip().splitlines()[-1])


@pytest.mark.parametrize("factory", _FRESH_FACTORIES, ids=["printed kernels", "LLVM program"])
def test_fresh_process_loads_from_disk_cache_without_deriving(factory, fresh_process_kernels):
    """The disk cache is keyed by the statement: a new process neither derives nor compiles
    (for printed kernels and for the intrinsic-based program alike)."""
    assert fresh_process_kernels[factory] == {"derived": False, "hits": 2, "misses": 0}


@pytest.mark.parametrize("make", [lambda: problems.n_link_pendulum(4), "cartesian pendulum"],
                         ids=["4-link", "constrained"])
def test_program_and_unrolled_assembly_agree(make):
    """Large systems evaluate M and F by the LLVM program (_ir); small ones by printed code."""
    if make == "cartesian pendulum":
        (x, y), _ = lc.coordinates("x y")
        m, l, g = sp.symbols("m l g", positive=True)
        system = lc.System([x, y], particles=[lc.Particle(m, (x, y))], potential=m * g * y,
                           constraints=[x**2 + y**2 - l**2], name="cartesian pendulum")
        state = np.array([np.sin(0.4), -np.cos(0.4), 0.7 * np.cos(0.4), 0.7 * np.sin(0.4)])
    else:
        system = make()
        state = np.random.default_rng(3).uniform(-2, 2, 2 * system.n_dof)
    n = system.n_dof
    p = np.random.default_rng(4).uniform(0.5, 2.0, len(system.parameters))
    results = []
    for unroll in (True, False):
        mod = _load_variant(codegen.generate_source(system.equations, unroll=unroll),
                            f"lc_test_unroll_{unroll}")
        out, J = np.empty(2 * n), np.empty((2 * n, 2 * n))
        assert mod.rhs(0.2, state, p, out, mod.new_work()) == 0
        assert mod.jacobian(0.2, state, p, J) == 0
        X = np.full((mod.N_PARTICLES, 3), np.nan)
        mod.particle_positions(state[:n], 0.2, p, X)
        results.append((out, J, mod.energy(state[:n], state[n:], 0.2, p), X))
    (a, Ja, ha, Xa), (b, Jb, hb, Xb) = results
    np.testing.assert_allclose(a, b, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(Ja, Jb, rtol=1e-11, atol=1e-11)
    assert ha == pytest.approx(hb, rel=1e-13)
    np.testing.assert_allclose(Xa, Xb, rtol=1e-14, atol=1e-15)    # zero-padded, no NaN left


def test_fingerprint_ignores_docstrings_and_comments(tmp_path):
    """Editing prose keeps the kernel cache; editing code does not."""
    import importlib.util

    def fingerprint(text, name):
        path = tmp_path / f"{name}.py"
        path.write_text(text)
        spec = importlib.util.spec_from_file_location(name, path)
        module = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(module)
        return codegen.source_fingerprint(module)

    base = fingerprint('"""Doc."""\ndef f(x):\n    """Doc."""\n    return x + 1\n', "fp_a")
    prose = fingerprint('"""Other."""\ndef f(x):\n    # why\n    return x + 1\n', "fp_b")
    code = fingerprint('"""Doc."""\ndef f(x):\n    """Doc."""\n    return x + 2\n', "fp_c")
    assert base == prose != code
