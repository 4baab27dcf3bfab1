"""Effects: the physics a set-up names, as building blocks of a System statement.

A *rig* states what hangs from a pivot — coordinates, and point masses at positions
r(q) relative to the pivot — as a lecture draws it.  :func:`build` puts the pivot at
P(t) and adds the named *effects*, each as the term a lecture would write, and nothing
else: an effect left out contributes no term to the statement, so none to the derived
equations, the generated kernels or the cost of a run (tests inspect the equations;
``benchmarks/bench_effects.py`` measures the saving).

===================  =============================================  ====================
effect               term of the statement                          parameters
===================  =============================================  ====================
:class:`Gravity`     V += Σ m_i g y_i                               ``g`` (m/s²)
:class:`PivotDrive`  P(t) = A Σ_k a_k d cos(k ω t + φ_k) along a    ``A`` (m), ``omega``
                     direction d (vertical, horizontal, a vector),  (rad/s); elliptic:
                     or the ellipse (A cos ωt, B sin ωt)            also ``B`` (m)
:class:`Damping`     D = γ T_rel (T_rel: kinetic energy relative    ``gamma`` (1/s)
                     to the pivot), i.e. −γ M q̇ in the equations:
                     θ̈ = −γ θ̇ − … for the pendulum
:class:`AirDrag`     F_i = −c |v_i| v_i on every mass (v_i its      ``c_drag`` (kg/m)
                     velocity through still air), by virtual work
:class:`Spring`      V += ½ k (q_j − q_j0)² (a torsion spring at a  ``k_<coordinate>``
                     joint, or a linear spring on a length)         (N m/rad or N/m)
===================  =============================================  ====================

What each effect allows (:func:`capabilities`): velocity forces (damping, drag) rule
out the Runge–Kutta–Nyström and symplectic integrators (q̈ = f(q, t) is needed); a
drive that moves the pivot off the vertical line (horizontal, oblique, elliptic)
leaves no equilibrium, so Floquet analysis goes about a periodic orbit
(:func:`kapitza.periodic_orbit`) instead of a persisting state.

Examples
--------
>>> from lagrange_core import effects
>>> s = effects.build(effects.pendulum_rig(), [effects.Gravity(), effects.PivotDrive("vertical")])
>>> s.parameters
('A', 'g', 'l', 'm', 'omega')
>>> effects.capabilities([effects.Gravity(), effects.PivotDrive("vertical")])["integrator"]
'rkn12'
"""
from __future__ import annotations

import functools
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import sympy as sp

from .symbols import coordinates, t, velocity_symbol
from .systems import Particle, System

__all__ = ["Rig", "pendulum_rig", "n_link_rig", "Gravity", "PivotDrive", "Damping", "AirDrag",
           "Spring", "build", "capabilities", "RIGS"]


# -- rigs -----------------------------------------------------------------------------------

@dataclass(frozen=True)
class Rig:
    """What hangs from the pivot: coordinates and point masses at ``r(q, pivot)``.

    Attributes
    ----------
    name : str
    coordinates : tuple of sympy Symbols
    masses : tuple of (name, mass expression, position function)
        ``position(px, py)`` returns the mass's (x, y) for the pivot at (px, py).
    """

    name: str
    coordinates: tuple
    masses: tuple

    def particles(self, px, py):
        return [Particle(m, pos(px, py), label) for label, m, pos in self.masses]


def pendulum_rig() -> Rig:
    """A point mass ``m`` on a massless rod of length ``l``; ``theta`` from the downward
    vertical (rad)."""
    (th,), _ = coordinates("theta")
    m, l = sp.symbols("m l", positive=True)
    return Rig("pendulum", (th,),
               (("bob", m, lambda px, py: (px + l * sp.sin(th), py - l * sp.cos(th))),))


def n_link_rig(n: int) -> Rig:
    """A chain of ``n`` point masses ``m1 … mn`` on massless rods ``l1 … ln``; each
    ``theta_i`` from the downward vertical (rad)."""
    if int(n) != n or n < 1:
        raise ValueError(f"n_link_rig needs a whole number of links n ≥ 1, got {n!r}.")
    ths, _ = coordinates([f"theta{i}" for i in range(1, int(n) + 1)])
    masses = []
    for i in range(int(n)):
        m, _l = sp.symbols(f"m{i + 1} l{i + 1}", positive=True)

        def pos(px, py, i=i):
            x, y = px, py
            for j in range(i + 1):
                lj = sp.Symbol(f"l{j + 1}", positive=True)
                x, y = x + lj * sp.sin(ths[j]), y - lj * sp.cos(ths[j])
            return (x, y)
        masses.append((f"bob {i + 1}", m, pos))
    return Rig(f"{int(n)}-link pendulum", tuple(ths), tuple(masses))


#: the catalogue of rigs a scene may name
RIGS: dict[str, Callable[[], Rig]] = {
    "pendulum": pendulum_rig,
    "double_pendulum": lambda: n_link_rig(2),
    "triple_pendulum": lambda: n_link_rig(3),
}


# -- effects ----------------------------------------------------------------------------------

@dataclass(frozen=True)
class Gravity:
    """Uniform gravity along −y: V = Σ m g y (parameter ``g``, m/s²)."""

    velocity_forces = False
    keeps_vertical_equilibria = True


_DIRECTIONS = {"vertical": (0, 1), "horizontal": (1, 0)}


@dataclass(frozen=True)
class PivotDrive:
    """The pivot's motion P(t).

    Parameters
    ----------
    path : "vertical", "horizontal", (dx, dy) or "elliptic"
        A line (its direction is normalised) along which the pivot moves as
        A Σ_k a_k cos(k ω t + φ_k), or the ellipse x = A cos ωt, y = B sin ωt
        (shared/PHYSICS.md; B < 0 turns it clockwise).
    harmonics : sequence of (k, a_k, φ_k)
        Harmonic number, relative amplitude and phase (rad) of each term; default
        the single term (1, 1, 0): A cos ωt.  Not for the ellipse.
    """

    path: object = "vertical"
    harmonics: tuple = ((1, 1.0, 0.0),)
    velocity_forces = False

    def __post_init__(self):
        if isinstance(self.path, str):
            if self.path not in ("vertical", "horizontal", "elliptic"):
                raise ValueError(f"PivotDrive: path must be 'vertical', 'horizontal', "
                                 f"'elliptic' or a vector (dx, dy), got {self.path!r}.")
        else:
            try:
                dx, dy = (float(v) for v in self.path)
            except (TypeError, ValueError):
                raise ValueError(f"PivotDrive: a direction must be two numbers (dx, dy), got "
                                 f"{self.path!r}.") from None
            if not (math.isfinite(dx) and math.isfinite(dy)) or dx == dy == 0:
                raise ValueError(f"PivotDrive: the direction (dx, dy) must be finite and not "
                                 f"zero, got {self.path!r}.")
            object.__setattr__(self, "path", (dx, dy))
        harm = tuple(tuple(h) for h in self.harmonics)
        for h in harm:
            if len(h) != 3 or int(h[0]) != h[0] or h[0] < 1:
                raise ValueError(f"PivotDrive: each harmonic is (k, a_k, phase) with a whole "
                                 f"k ≥ 1, got {h!r}.")
        if self.path == "elliptic" and harm != ((1, 1.0, 0.0),):
            raise ValueError("PivotDrive: the elliptic path has no extra harmonics.")
        object.__setattr__(self, "harmonics", harm)
        # a drive whose terms vanish or cancel (every a_k = 0, or a cos(kωt) beside
        # −a cos(kωt)) moves nothing: its statement would lose A and omega, which every
        # analysis of the drive asks for
        px, py = self.pivot() if self.path != "elliptic" else (1, 1)
        if px == 0 and py == 0:
            raise ValueError(f"PivotDrive: the harmonics {harm} cancel (Σ a_k cos(k ω t + φ_k) "
                             "is 0 at every t), so the pivot does not move; give a nonzero "
                             "relative amplitude a_k, or leave the drive out.")

    @property
    def direction(self):
        if self.path == "elliptic":
            return None
        d = _DIRECTIONS.get(self.path, self.path)
        norm = math.hypot(*d)
        return (d[0] / norm, d[1] / norm)

    @property
    def keeps_vertical_equilibria(self) -> bool:
        """θ = 0 and π of a hanging rig persist only when the pivot stays on the vertical."""
        d = self.direction
        return d is not None and d[0] == 0

    def pivot(self):
        A, w = sp.symbols("A omega", positive=True)
        if self.path == "elliptic":
            B = sp.Symbol("B", real=True)
            return A * sp.cos(w * t), B * sp.sin(w * t)
        s = sum(_exact(a) * sp.cos(int(k) * w * t + _exact(ph)) for k, a, ph in self.harmonics)
        dx, dy = (_exact(c) for c in self.direction)
        return dx * A * s, dy * A * s


def _exact(x):
    """``sympy.nsimplify(x)``: the exact number a float stands for (0.7071067811865476 →
    √2/2), remembered: for a float without a short exact form (0.3719…) nsimplify searches
    with mpmath's PSLQ, 5–60 ms a number, and a drive's numbers are asked for again each
    time its statement is written (its own check, each build, each scene read from the
    same values: the scene tests asked 2331 times for 41 numbers, 10 s)."""
    try:
        return _exact_remembered(x)
    except TypeError:           # unhashable: nsimplify alone decides, as before
        return sp.nsimplify(x)


_exact_remembered = functools.lru_cache(maxsize=1024)(sp.nsimplify)


@dataclass(frozen=True)
class Damping:
    """Viscous damping relative to the pivot: D = γ T_rel, γ (1/s) the parameter
    ``gamma``; the pendulum gets θ̈ = −γ θ̇ − … (shared/PHYSICS.md)."""

    velocity_forces = True
    keeps_vertical_equilibria = True


@dataclass(frozen=True)
class AirDrag:
    """Quadratic drag −c |v| v on every mass moving through still air (parameter
    ``c_drag``, kg/m: c = ½ ρ C_d S)."""

    velocity_forces = True
    keeps_vertical_equilibria = True


@dataclass(frozen=True)
class Spring:
    """A spring on one coordinate: V = ½ k (q − q0)², k the parameter ``k_<coordinate>``
    (N m/rad for an angle), q0 = ``rest``."""

    coordinate: str
    rest: float = 0.0
    velocity_forces = False
    keeps_vertical_equilibria = True


EFFECT_TYPES = (Gravity, PivotDrive, Damping, AirDrag, Spring)


# -- building a statement -------------------------------------------------------------------

def _check_effects(effects: Sequence) -> list:
    effects = list(effects)
    for e in effects:
        if not isinstance(e, EFFECT_TYPES):
            raise TypeError(f"effects must be Gravity, PivotDrive, Damping, AirDrag or Spring "
                            f"objects, got {e!r}.")
    for kind in (Gravity, PivotDrive, Damping, AirDrag):
        if sum(isinstance(e, kind) for e in effects) > 1:
            raise ValueError(f"effects: {kind.__name__} is named twice; name each effect once.")
    return effects


def build(rig: Rig, effects: Sequence = (), *, name: str | None = None) -> System:
    """The System of ``rig`` with exactly the named ``effects``.

    Parameters
    ----------
    rig : Rig
        What hangs from the pivot (:data:`RIGS`, :func:`pendulum_rig`, :func:`n_link_rig`,
        or a user's).
    effects : sequence of effect objects
        Each at most once (springs once per coordinate).
    name : str, optional
        Default: the rig's name and the effects, e.g. "pendulum + gravity + vertical drive".

    Returns
    -------
    lagrange_core.System
    """
    effects = _check_effects(effects)
    drive = next((e for e in effects if isinstance(e, PivotDrive)), None)
    px, py = drive.pivot() if drive is not None else (sp.Integer(0), sp.Integer(0))
    particles = rig.particles(px, py)
    V = sp.Integer(0)
    D = sp.Integer(0)
    forces = []
    labels = []
    for e in effects:
        if isinstance(e, Gravity):
            g = sp.Symbol("g", positive=True)
            V += sum(p.mass * g * p.position[1] for p in particles)
            labels.append("gravity")
        elif isinstance(e, PivotDrive):
            labels.append(f"{e.path if isinstance(e.path, str) else 'oblique'} drive")
        elif isinstance(e, Damping):
            gam = sp.Symbol("gamma", positive=True)
            rel = rig.particles(0, 0)           # positions relative to the pivot
            T_rel = sum(p.mass * sum(_rate(c, rig.coordinates) ** 2 for c in p.position)
                        for p in rel) / 2
            D += gam * T_rel
            labels.append("damping")
        elif isinstance(e, AirDrag):
            c = sp.Symbol("c_drag", nonnegative=True)
            for p in particles:
                v = [_rate(x, rig.coordinates) for x in p.position]
                speed = sp.sqrt(sum(vi ** 2 for vi in v))
                forces.append((p, tuple(-c * speed * vi for vi in v)))
            labels.append("air drag")
        elif isinstance(e, Spring):
            names = [q.name for q in rig.coordinates]
            if e.coordinate not in names:
                raise ValueError(f"Spring: {e.coordinate!r} is not a coordinate of the "
                                 f"{rig.name} ({names}).")
            q = rig.coordinates[names.index(e.coordinate)]
            k = sp.Symbol(f"k_{e.coordinate}", positive=True)
            V += k * (q - _exact(e.rest)) ** 2 / 2
            labels.append(f"spring on {e.coordinate}")
    return System(list(rig.coordinates), particles=particles, potential=V, dissipation=D,
                  forces=forces or None,
                  name=name or " + ".join([rig.name] + labels))


def _rate(expr, coords):
    """d(expr)/dt along the motion: Σ ∂expr/∂q_j q̇_j + ∂expr/∂t."""
    return sum(sp.diff(expr, q) * velocity_symbol(q) for q in coords) + sp.diff(expr, t)


def capabilities(effects: Sequence) -> dict:
    """What the named effects allow, and the best method for each analysis.

    Returns
    -------
    dict
        ``integrator``: "rkn12" (q̈ = f(q, t): no velocity forces) or "dop853";
        ``floquet``: "equilibrium" (θ = 0, π persist: a vertical or no drive) or
        "periodic_orbit" (the pivot leaves the vertical line);
        ``averaging``: True when a drive is named (there is something to average);
        ``energy_conserved``: no drive and no velocity forces.
    """
    effects = _check_effects(effects)
    velocity = any(e.velocity_forces for e in effects)
    drive = next((e for e in effects if isinstance(e, PivotDrive)), None)
    return {"integrator": "dop853" if velocity else "rkn12",
            "floquet": ("equilibrium" if drive is None or drive.keeps_vertical_equilibria
                        else "periodic_orbit"),
            "averaging": drive is not None,
            "energy_conserved": drive is None and not velocity}
