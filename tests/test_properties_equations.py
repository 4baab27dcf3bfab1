"""Property: the derived and compiled equations equal sympy's LagrangesMethod, numerically.

Two families of random statements, each compared with
``sympy.physics.mechanics.LagrangesMethod``, which differentiates the whole Lagrangian
T − V written out independently (never the engine's Jacobians, nor its Rayleigh
function: a chain's kinematics by sympy's own points and frame, its damping and drag as
forces on the bobs):

* **chains** built by :func:`lagrange_core.effects.build` — 1–4 links, random masses and
  lengths, with a random choice of the effects a scene may name (gravity; a pivot drive
  vertical, horizontal, along a vector, with extra harmonics, or elliptic; damping
  relative to the pivot; quadratic air drag; torsion springs with rest angles);
* **particle systems** stated directly to :class:`lagrange_core.System` — 1–3
  coordinates, 1–3 planar particles whose positions are random trig polynomials of the
  coordinates (and of t), random masses and a random potential (a trig polynomial with
  quadratic terms).

The mass matrix M(q, t) and the forcing F(q, q̇, t) of the compiled kernels
(``System.kernels.mass_forcing``) must equal the reference's at random states, times and
parameter values to a relative 1e-10 of their size (1e-12 of the natural scale
‖M‖ (1 + ‖q̇‖²) where F nearly vanishes); so must the derived equations themselves
(``System.equations``, its entries as derived: the sympy view ``mass_matrix`` is them
after sympy's ``trigsimp``, which took 25 s for some of these statements).

LagrangesMethod's values are kept between runs in the user's cache folder, next to
lagrange_core's kernels (:class:`_Reference`, :class:`_ValueStore`: they depend on the
statements, the states and sympy alone, never on the engine), so a second run derives only
the engine's side: 3.7 s instead of 19.3 s, one process (2026-11-28).

Inputs tried (``--hypothesis-show-statistics``, 2026-11-26): profile "ci" 20 chains and
6 particle systems, 3 states each, all passing — 27 s with the kernels cached (load
average 3 on 2 cores; LagrangesMethod's derivation is most of it), 46 s with an empty
kernel cache (each statement compiles its kernels once; they stay cached, and "ci" draws
the same statements every run).  Profile "thorough" (by hand, with ``--timeout=0``; it
compiles into a temporary cache, so random statements do not fill the user's): 207
chains and 120 particle systems passed before pytest-timeout's 600 s stopped the run.
"""
import functools
import hashlib
import inspect
import json
import math
import os
import tempfile
from pathlib import Path

import numpy as np
import pytest
import sympy as sp
import sympy.physics.mechanics as me
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st
from sympy.physics.mechanics import LagrangesMethod, dynamicsymbols

import lagrange_core as lc
from lagrange_core import effects as fx

_t = dynamicsymbols._t
#: A relative tolerance of 1e-10 (the brief's): rounding in a derivation of ~100 terms.
RTOL = 1e-10


@pytest.fixture(scope="module", autouse=True)
def _kernel_cache():
    """Random statements (any profile but the derandomized "ci") compile into a temporary
    kernel cache: hundreds of one-off modules do not belong in the user's cache."""
    if settings().derandomize:
        yield
        return
    old = os.environ.get("LAGRANGE_CORE_CACHE")
    with tempfile.TemporaryDirectory(prefix="kapitza-properties-") as tmp:
        os.environ["LAGRANGE_CORE_CACHE"] = tmp
        try:
            yield
        finally:
            if old is None:
                os.environ.pop("LAGRANGE_CORE_CACHE", None)
            else:
                os.environ["LAGRANGE_CORE_CACHE"] = old


class _ValueStore:
    """LagrangesMethod's values by key, one JSON file a key in ``folder``.

    The user's cache folder, not pytest's (``.pytest_cache``, where they were kept until
    2026-11-29): like the kernels' cache it serves every checkout and copy of the tree and
    runs with ``-p no:cacheprovider``, which derived every value again (~20 CPU-s, the
    most of this file's time, for the same values every run).  ``--cache-clear`` still
    derives them again (and keeps the new ones).  A folder that cannot be written keeps
    nothing: the values are derived."""

    def __init__(self, folder, clear=False):
        self.folder, self.clear = Path(folder), clear

    def get(self, key, default=None):
        if self.clear:
            return default
        try:
            return json.loads((self.folder / f"{key}.json").read_text())
        except (OSError, ValueError):
            return default

    def set(self, key, value):
        path = self.folder / f"{key}.json"
        try:
            self.folder.mkdir(parents=True, exist_ok=True)
            part = path.with_name(f"{path.name}.{os.getpid()}.part")
            part.write_text(json.dumps(value))
            os.replace(part, path)      # whole or not at all: a worker may read it meanwhile
        except OSError:
            pass


#: Where LagrangesMethod's values are kept between runs (None: not kept)
_STORE = None


@pytest.fixture(scope="module", autouse=True)
def _reference_store(request):
    """Keep the reference's values (:class:`_ValueStore`, in ``$XDG_CACHE_HOME`` or
    ``~/.cache``, ``kapitza-tests/lagranges-method``) under the "ci" profile, whose
    statements are the same every run; any other profile draws new ones (hundreds of
    one-off entries) and derives each."""
    global _STORE
    if settings().derandomize:
        root = os.environ.get("XDG_CACHE_HOME") or os.path.expanduser("~/.cache")
        _STORE = _ValueStore(Path(root, "kapitza-tests", "lagranges-method"),
                             clear=bool(request.config.getoption("cacheclear", False)))
    yield
    _STORE = None


# -- the comparison -------------------------------------------------------------------------

def _reference_functions(lm, coordinates, parameters):
    """M and F of ``lm`` as numpy functions of (q, q̇, t, parameter values by name)."""
    qs = [dynamicsymbols(c) for c in coordinates]
    q_plain = sp.symbols([f"q{i}" for i in range(len(qs))])
    v_plain = sp.symbols([f"v{i}" for i in range(len(qs))])
    t_plain = sp.Symbol("t_")
    plain = {d.diff(_t): v for d, v in zip(qs, v_plain, strict=True)}
    plain.update({d: q for d, q in zip(qs, q_plain, strict=True)})
    args = [*q_plain, *v_plain, t_plain, *sp.symbols(list(parameters) or ["_none"])]

    def numeric(matrix):
        expr = matrix.xreplace(plain).xreplace({_t: t_plain})
        return sp.lambdify(args, expr, "numpy")

    M, F = numeric(lm.mass_matrix), numeric(lm.forcing)

    def evaluate(q, qd, t, values):
        p = [values[name] for name in parameters] or [0.0]
        return (np.array(M(*q, *qd, t, *p), dtype=float),
                np.array(F(*q, *qd, t, *p), dtype=float).ravel())
    return evaluate


class _Reference:
    """LagrangesMethod's M and F of one statement at any state, as
    ``reference(q, q̇, t, values) -> (M, F)``.

    Deriving them (``derive()``: sympy's ``form_lagranges_equations``, then ``lambdify``)
    is most of this file's time — ~13 CPU-s of the suite's, for the same statements every
    run under the "ci" profile.  The values are a function of the statement, the state,
    the parameter values, sympy's version and this file's reference code alone, none of
    them the engine's: they are kept (:data:`_STORE`) under a digest of all of these,
    derived again whenever one changes (and on ``pytest --cache-clear``).  The engine's
    side — its derivation, kernels and equations — is computed in every run."""

    def __init__(self, kind, statement, derive):
        self.kind, self.statement, self.derive = kind, statement, derive
        self.stored = False     # whether the last values came from the cache

    def __call__(self, q, qd, t, values):
        key = None
        if _STORE is not None:
            text = repr((self.kind, self.statement, np.asarray(q, float).tolist(),
                         np.asarray(qd, float).tolist(), float(t), sorted(values.items()),
                         sp.__version__, _REFERENCE_CODE))
            key = hashlib.sha256(text.encode()).hexdigest()
            kept = _STORE.get(key, None)
            if kept is not None:
                self.stored = True
                return np.array(kept["M"], dtype=float), np.array(kept["F"], dtype=float)
        n = len(q)
        M, F = self.derive()(q, qd, t, values)
        M, F = np.broadcast_to(M, (n, n)).copy(), np.broadcast_to(F, (n,)).copy()
        if key is not None:
            _STORE.set(key, {"M": M.tolist(), "F": F.tolist()})
        self.stored = False
        return M, F


def _view_functions(system):
    """M and F of the derived equations (``system.equations``, as derived: the sympy view
    ``mass_matrix`` is the same entries after sympy's ``trigsimp``) as numpy functions."""
    eq = system.equations
    args = [*system.q, *system.qdot, lc.t, *system.parameter_symbols]
    n = system.n_dof
    M = sp.lambdify(args, sp.Matrix(n, n, [eq._to_sympy(e) for row in eq.mass_matrix_se
                                            for e in row]), "numpy")
    F = sp.lambdify(args, sp.Matrix([eq._to_sympy(e) for e in eq.forcing_se]), "numpy")

    def evaluate(q, qd, t, p):
        return (np.array(M(*q, *qd, t, *p), dtype=float),
                np.array(F(*q, *qd, t, *p), dtype=float).ravel())
    return evaluate


def _assert_equal_equations(system, reference, view, states, values):
    """Kernels and the sympy view against the reference at every state."""
    n = system.n_dof
    p = system.parameter_array(values)
    for q, qd, t in states:
        q, qd = np.asarray(q, float), np.asarray(qd, float)
        M_ref, F_ref = reference(q, qd, t, values)
        M_ref = np.broadcast_to(M_ref, (n, n))
        F_ref = np.broadcast_to(F_ref, (n,))
        M, F = np.empty((n, n)), np.empty(n)
        system.kernels.mass_forcing(q, qd, float(t), p, M, F)
        M_view, F_view = view(q, qd, t, p)
        scale_M = max(np.abs(M_ref).max(), 1e-300)
        # F is a sum of terms of size ~ ‖M‖ (1 + |q̇|²) (velocity and drive terms) and of
        # the potential's gradient: where they nearly cancel, F is compared to that scale
        natural = 1e-2 * scale_M * (1.0 + float(np.dot(qd, qd)))
        scale_F = max(np.abs(F_ref).max(), natural)
        where = f"{system.name} at q={q.tolist()}, q̇={qd.tolist()}, t={t}, params={values}"
        if getattr(reference, "stored", False):
            where += (" (the reference's values kept from an earlier run: --cache-clear"
                      " derives them again)")
        for name, ours in (("kernels", (M, F)), ("derived equations", (M_view, F_view))):
            err_M = np.abs(ours[0] - M_ref).max() / scale_M
            err_F = np.abs(ours[1] - F_ref).max() / scale_F
            assert err_M <= RTOL, f"M of the {name} of {where}: relative error {err_M:.2e}"
            assert err_F <= RTOL, f"F of the {name} of {where}: relative error {err_F:.2e}"
        assert np.all(np.isfinite(M)) and np.all(np.isfinite(F)), where


# -- chains from effects --------------------------------------------------------------------

_DRIVES = ("none", "vertical", "horizontal", "vector", "harmonics", "elliptic")


@st.composite
def chain_statements(draw):
    """(links, gravity, drive, damping, drag, springs): what ``effects.build`` is given."""
    links = draw(st.integers(1, 4))
    gravity = draw(st.booleans())
    drive = draw(st.sampled_from(_DRIVES))
    vector = (draw(st.integers(-3, 3)), draw(st.integers(-3, 3)))
    if drive == "vector" and vector == (0, 0):
        vector = (1, 2)
    harmonics = ((1, 1.0, 0.0),)
    if drive == "harmonics":
        harmonics = tuple(draw(st.lists(st.tuples(st.integers(1, 3), st.sampled_from(
            (0.25, 0.5, 1.0, -0.75)), st.sampled_from((0.0, 0.5, -1.25))), min_size=1,
            max_size=3)))
    damping = draw(st.booleans())
    drag = draw(st.booleans())
    springs = tuple(sorted(draw(st.sets(st.integers(1, links), max_size=links))))
    rests = tuple(draw(st.sampled_from((0.0, 0.5, -1.0, 3.0))) for _ in springs)
    return links, gravity, drive, vector, harmonics, damping, drag, springs, rests


def _pivot_path(drive, vector, harmonics):
    if drive in ("none", "vertical", "horizontal", "elliptic"):
        return drive
    if drive == "vector":
        return vector
    return "vertical"


def _chain_system(links, gravity, drive, vector, harmonics, damping, drag, springs, rests):
    effects = [fx.Gravity()] if gravity else []
    if drive != "none":
        effects.append(fx.PivotDrive(_pivot_path(drive, vector, harmonics), harmonics))
    if damping:
        effects.append(fx.Damping())
    if drag:
        effects.append(fx.AirDrag())
    effects += [fx.Spring(f"theta{j}", rest=r) for j, r in zip(springs, rests, strict=True)]
    return fx.build(fx.n_link_rig(links), effects)


@functools.lru_cache(maxsize=64)
def _chain_reference(*statement):
    """(the engine's system, the reference, the engine's derived equations) of a chain."""
    system = _chain_system(*statement)
    return system, _Reference("chain", statement, lambda: _chain_lagranges_method(
        *statement, system.coordinates, system.parameters)), _view_functions(system)


@functools.lru_cache(maxsize=64)
def _chain_lagranges_method(links, gravity, drive, vector, harmonics, damping, drag, springs,
                            rests, coordinates, parameters):
    """The same chain stated with sympy.physics.mechanics: points in a frame, the pivot
    written out from PHYSICS.md, forces on the bobs; LagrangesMethod derives it."""
    N = me.ReferenceFrame("N")
    O = me.Point("O")
    O.set_vel(N, 0)
    A, w, B, g, gamma, c = sp.symbols("A omega B g gamma c_drag")
    wave = sum(a * sp.cos(k * w * _t + ph) for k, a, ph in harmonics)
    if drive == "none":
        px, py = 0, 0
    elif drive == "elliptic":
        px, py = A * sp.cos(w * _t), B * sp.sin(w * _t)
    else:
        d = {"vertical": (0, 1), "horizontal": (1, 0), "harmonics": (0, 1)}.get(drive, vector)
        norm = math.hypot(*d)
        px, py = d[0] / norm * A * wave, d[1] / norm * A * wave
    pivot = O.locatenew("P", px * N.x + py * N.y)
    qs = dynamicsymbols(" ".join(f"theta{i}" for i in range(1, links + 1)), seq=True)
    bobs, masses, point = [], [], pivot
    for i, th in enumerate(qs, start=1):
        m_i, l_i = sp.symbols(f"m{i} l{i}")
        point = point.locatenew(f"B{i}", l_i * sp.sin(th) * N.x - l_i * sp.cos(th) * N.y)
        bobs.append(point)
        masses.append(m_i)
    T, V, forces = 0, 0, []
    for m_i, bob in zip(masses, bobs, strict=True):
        v = bob.pos_from(O).dt(N)
        bob.set_vel(N, v)
        T += m_i * v.dot(v) / 2
        if gravity:
            V += m_i * g * bob.pos_from(O).dot(N.y)
        force = 0 * N.x
        if damping:         # D = γ T_rel: the force −γ m v_rel, v_rel relative to the pivot
            force += -gamma * m_i * bob.pos_from(pivot).dt(N)
        if drag:
            force += -c * sp.sqrt(v.dot(v)) * v
        if force != 0 * N.x:
            forces.append((bob, force))
    for j, rest in zip(springs, rests, strict=True):
        V += sp.Symbol(f"k_theta{j}") * (qs[j - 1] - rest) ** 2 / 2
    # multiplied out (sympy's expand_mul, an identity): LagrangesMethod then differentiates a
    # sum of products of the coordinates' sines and cosines, a third faster than the
    # squares of sums that the points' velocities give
    lm = LagrangesMethod(sp.expand_mul(T - V), qs, forcelist=forces or None, frame=N)
    lm.form_lagranges_equations()
    return _reference_functions(lm, coordinates, parameters)


#: Every parameter a chain or a particle system may have, with the range of its values.
_RANGES = {"A": (0.0, 0.5), "omega": (0.1, 200.0), "B": (-0.5, 0.5), "g": (0.0, 20.0),
           "gamma": (0.0, 5.0), "c_drag": (0.0, 2.0),
           **{f"{p}{i}": (0.1, 10.0) for p in ("l", "m", "k_theta") for i in range(1, 5)},
           **{f"{p}{i}": (0.1, 10.0) for p in ("m", "k") for i in range(3)}}


def _values():
    """Values of every parameter of :data:`_RANGES` (a system takes those it has)."""
    return st.fixed_dictionaries({name: st.floats(low, high, allow_nan=False)
                                  for name, (low, high) in _RANGES.items()})


def _states(count=3, n=4):
    """``count`` states (q (rad), q̇ (rad/s), t (s)) of ``n`` coordinates (a system takes
    its first ones)."""
    angles = st.lists(st.floats(-math.pi, math.pi, allow_nan=False), min_size=n, max_size=n)
    rates = st.lists(st.floats(-5.0, 5.0, allow_nan=False), min_size=n, max_size=n)
    return st.lists(st.tuples(angles, rates, st.floats(0.0, 10.0, allow_nan=False)),
                    min_size=count, max_size=count)


def _check(system, reference, view, values, states):
    values = {name: values[name] for name in system.parameters}
    n = system.n_dof
    states = [(q[:n], qd[:n], t) for q, qd, t in states]
    _assert_equal_equations(system, reference, view, states, values)


_KAPITZA = (1, True, "vertical", (0, 0), ((1, 1.0, 0.0),), False, False, (), ())


@settings(max_examples=2 * settings().max_examples)
@given(statement=chain_statements(), values=_values(), states=_states())
@example(statement=_KAPITZA, values={**{k: 1.0 for k in _RANGES}, "A": 0.05, "omega": 377.0,
                                     "g": 9.81},
         states=[([3.0] * 4, [0.5] * 4, 0.1)] * 3).via("the Kapitza pendulum")
def test_chains_match_lagranges_method(statement, values, states):
    """M and F of a random chain (1–4 links, random effects) equal LagrangesMethod's."""
    _check(*_chain_reference(*statement), values, states)


# -- particle systems -------------------------------------------------------------------------

_FACTORS = ("1", "sin", "cos")


@st.composite
def trig_polynomials(draw, n, *, time=False, constant=True):
    """A random trig polynomial Σ c · f(k q_i) · g(q_j) [· cos(t)] of the coordinates
    q0 … q(n-1), as a tuple of terms (hashable, so the statement can be cached)."""
    terms = []
    for _ in range(draw(st.integers(1, 3))):
        c = draw(st.sampled_from((1, -1, 2, sp.Rational(1, 2), sp.Rational(-3, 2))))
        i, j = draw(st.integers(0, n - 1)), draw(st.integers(0, n - 1))
        f1, f2 = draw(st.sampled_from(_FACTORS[1:])), draw(st.sampled_from(_FACTORS))
        k = draw(st.integers(1, 2))
        tt = draw(st.booleans()) if time else False
        terms.append((c, f1, k, i, f2, j, tt))
    if constant and draw(st.booleans()):
        terms.append((draw(st.sampled_from((1, -2))), "1", 1, 0, "1", 0, False))
    return tuple(terms)


def _expression(terms, q, t):
    funcs = {"1": lambda x: 1, "sin": sp.sin, "cos": sp.cos}
    return sum(c * funcs[f1](k * q[i]) * funcs[f2](q[j]) * (sp.cos(t) if tt else 1)
               for c, f1, k, i, f2, j, tt in terms)


@st.composite
def particle_statements(draw):
    n = draw(st.integers(1, 3))
    particles = tuple(
        (draw(st.sampled_from(("number", "symbol"))),
         draw(trig_polynomials(n, time=True)), draw(trig_polynomials(n, time=True)))
        for _ in range(draw(st.integers(1, 3))))
    potential = draw(trig_polynomials(n, constant=False))
    quadratic = tuple(sorted(draw(st.sets(st.integers(0, n - 1), max_size=n))))
    return n, particles, potential, quadratic


def _particle_system(n, particles, potential, quadratic, q, t):
    """The statement in the symbols ``q`` and the time ``t`` (the engine's or dynamic)."""
    bodies, masses = [], []
    for i, (mass, x, y) in enumerate(particles):
        m = sp.Rational(3, 2) + i if mass == "number" else sp.Symbol(f"m{i}")
        bodies.append((m, (_expression(x, q, t), _expression(y, q, t))))
        masses.append(m)
    V = sp.Symbol("g") * _expression(potential, q, t) + sum(
        sp.Symbol(f"k{j}") * q[j] ** 2 / 2 for j in quadratic)
    return bodies, V


@functools.lru_cache(maxsize=16)
def _particle_reference(*statement):
    """(the engine's system, the reference, the engine's derived equations)."""
    n, particles, potential, quadratic = statement
    coords, _ = lc.coordinates([f"x{i}" for i in range(n)])
    bodies, V = _particle_system(n, particles, potential, quadratic, coords, lc.t)
    system = lc.System(coords, particles=[lc.Particle(m, r) for m, r in bodies],
                       potential=V, name="random particle system")
    return system, _Reference("particles", statement, lambda: _particle_lagranges_method(
        *statement, system.coordinates, system.parameters)), _view_functions(system)


@functools.lru_cache(maxsize=16)
def _particle_lagranges_method(n, particles, potential, quadratic, coordinates, parameters):
    """The particles' T − V in sympy's dynamic symbols; LagrangesMethod derives it."""
    qs = dynamicsymbols(" ".join(f"x{i}" for i in range(n)), seq=True)
    ref_bodies, ref_V = _particle_system(n, particles, potential, quadratic, qs, _t)
    T = sum(m * sum(c.diff(_t) ** 2 for c in r) for m, r in ref_bodies) / 2
    lm = LagrangesMethod(T - ref_V, qs)
    lm.form_lagranges_equations()
    return _reference_functions(lm, coordinates, parameters)


#: The reference's own code: a change to any of it derives every stored value again.
_REFERENCE_CODE = hashlib.sha256("".join(inspect.getsource(f) for f in (
    _reference_functions, _chain_lagranges_method, _particle_lagranges_method,
    _particle_system, _expression)).encode()).hexdigest()


def _moves(statement) -> bool:
    """Every particle's position depends on a coordinate (the engine refuses, rightly,
    a particle that cannot move with the system: tested in tests/test_core_errors.py)."""
    _, particles, _, _ = statement
    return all(any(f != "1" for term in x + y for f in (term[1], term[4]))
               for _, x, y in particles)


@settings(max_examples=max(1, 6 * settings().max_examples // 10),
          suppress_health_check=[HealthCheck.too_slow, HealthCheck.filter_too_much])
@given(statement=particle_statements().filter(_moves), values=_values(), states=_states())
def test_particle_systems_match_lagranges_method(statement, values, states):
    """M and F of random planar particles at trig-polynomial positions equal
    LagrangesMethod's."""
    _check(*_particle_reference(*statement), values, states)
