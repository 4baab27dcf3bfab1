"""The state an analysis is about, in the rig's own terms.

A scene's ``about`` is a state the rig declares by name (the catalogue's rigs: "inverted",
every coordinate π, and "hanging", 0; a user's rig: what it declares, :mod:`._rigs`),
explicit values per coordinate, or "auto": the declared state nearest the initial state
— for a rig of angles only that declares none, each coordinate's nearest multiple of π —
or, for a drive that leaves no equilibrium, the stable state of averaging nearest it.
Angles are compared modulo 2π (a state is moved by whole turns to the initial state's
turn); other coordinates as they are.

Before an analysis runs about a state, :func:`checked_state` makes sure the equations can
be linearised there (a mass matrix that is singular at the state is refused, the state
named with its units), and :func:`persists` tells an equilibrium of the driven system
from a state the drive moves (a length pulled by a vertically shaken pivot): Floquet
analysis is about the former and the periodic orbit born from the latter.
"""
from __future__ import annotations

import contextlib
import math

import numpy as np

from ..averaging import average
from ._rigs import format_state

__all__ = ["about_state", "averaged_state", "pendulum_state", "checked_state", "persists",
           "describe_state", "naming_state"]


def _declaration(scene):
    """(coordinate names, units, named states, which coordinates are angles)."""
    names = list(scene.system.coordinates)
    spec = scene.spec
    units = spec.units or {q: "rad" for q in names}
    angle = np.array([units.get(q) == "rad" for q in names])
    return names, units, spec.states, angle


def _nearest_turn(state, q0, angle):
    """``state`` with each angle moved by whole turns to the turn of ``q0``."""
    state = np.asarray(state, dtype=float)
    return np.where(angle, state + 2 * math.pi * np.round((q0 - state) / (2 * math.pi)), state)


def _nearest(states, q0, angle):
    """The state of ``states`` nearest ``q0`` (angles modulo 2π; the largest coordinate
    distance decides, as a band would)."""
    turns = [_nearest_turn(s, q0, angle) for s in states]
    return min(turns, key=lambda s: float(np.max(np.abs(s - q0))))


def about_state(scene, setting, q0=None):
    """The state an analysis is about, (n,) or (points, n) coordinates (a ``q0`` of
    shape (points, n) gives one "auto" state per point)."""
    n = scene.system.n_dof
    q0 = scene.q0 if q0 is None else np.asarray(q0, dtype=float)
    names, units, states, angle = _declaration(scene)
    if isinstance(setting, str) and setting != "auto":
        if setting not in states:
            raise ValueError(f"about = {setting!r} is not a state the {scene.spec.rig.name} "
                             f"declares ({', '.join(states) or 'none'}); declare it or give "
                             "the state's values per coordinate.")
        return np.array(states[setting], dtype=float)
    if setting not in (None, "auto"):
        about = np.asarray(setting, dtype=float)
        if about.shape != (n,):
            raise ValueError(f"about needs {n} coordinate values ({names}), got "
                             f"{list(setting)}.")
        return about
    if scene.capabilities["floquet"] == "equilibrium":
        return _nearest_declared(scene, q0, names, units, states, angle)
    return averaged_state(scene, scene.spec.params, q0)


def _nearest_declared(scene, q0, names, units, states, angle):
    """"auto" where the drive keeps equilibria: the declared state nearest ``q0``; each
    angle's nearest multiple of π for a rig of angles only with no states of its own."""
    if scene.spec.declaration is None or scene.spec.declaration.declared_by in (
            "catalogue", "angles"):
        return math.pi * np.round(q0 / math.pi)
    if not states:
        raise ValueError(f'about = "auto" needs the states of the {scene.spec.rig.name} '
                         f"(coordinates {', '.join(f'{q} ({units[q]})' for q in names)}): "
                         "declare them, or give about per coordinate.")
    if q0.ndim == 2:
        return np.array([_nearest(states.values(), q, angle) for q in q0])
    return _nearest(states.values(), q0, angle)


def averaged_state(scene, params, q0):
    """The stable state of averaging nearest ``q0`` (angles modulo 2π) at scalar
    ``params``; where averaging finds none, the nearest declared state (each angle's
    nearest multiple of π for a rig of angles only).  A rig with a coordinate that is not
    an angle starts averaging's search from its declared states."""
    names, units, states, angle = _declaration(scene)
    guesses = None if angle.all() else np.array(list(states.values()), dtype=float)
    prediction = average(scene.system).predict(params, guesses, warn=False)
    stable = [e.about for e in prediction.equilibria if e.stable]
    if not stable:
        if angle.all():
            return math.pi * np.round(q0 / math.pi)
        return _nearest(states.values(), q0, angle)
    return _nearest(stable, q0, angle)


def pendulum_state(scene, about):
    """"inverted" or "hanging": the pendulum's persisting state ``about`` names or is nearest."""
    if about in ("inverted", "hanging"):
        return about
    theta = float(about_state(scene, about)[0])
    return "inverted" if abs(math.cos(theta) + 1) < 1e-9 else "hanging"


# -- the state tried: named, checked ------------------------------------------------------------

def describe_state(scene, q, setting=None) -> str:
    """"the state r = 1.245 m, theta = 0 rad (about = 'hanging')"."""
    names, units, _, _ = _declaration(scene)
    how = "auto" if setting is None else setting
    how = how if isinstance(how, str) else list(how)
    return f"the state {format_state(names, units, q)} (about = {how!r})"


def _fix(scene) -> str:
    decl = scene.spec.declaration
    if decl is not None and decl.declared_by in ("catalogue",):
        return "give another about"
    return ("declare the rig's states ([system] states = { name = { coordinate = value, … } } "
            "or a `states` attribute of the rig function) or give about per coordinate")


def checked_state(scene, q, setting=None, params=None):
    """``q`` where the equations can be linearised: a ValueError naming the state (with
    units, and how ``about`` chose it) where the mass matrix is singular there."""
    params = scene.spec.params if params is None else params
    q = np.asarray(q, dtype=float)
    for row in np.unique(np.atleast_2d(q), axis=0):        # a tile's states: each once
        M, _ = scene.system.mass_forcing(row, np.zeros_like(row), 0.0, params)
        s = np.linalg.svd(np.atleast_2d(M), compute_uv=False)
        if not s[-1] > 1e-12 * max(s[0], 1e-300):
            raise ValueError(f"the mass matrix is singular at {describe_state(scene, row, setting)}"
                             f": the coordinates do not fix the masses there, so the motion "
                             f"cannot be linearised or integrated; {_fix(scene)}.")
    return q


def persists(scene, q, params=None) -> bool:
    """Is the rest state at ``q`` an equilibrium of the driven system — q̈ = 0 at eight
    phases of the drive's period, to 1e-9 of the linearised equations' size (as Floquet
    analysis checks it)?  False where the drive moves it (a length of a rig on a vertically
    shaken pivot)."""
    if scene.capabilities["floquet"] != "equilibrium":
        return False
    params = scene.spec.params if params is None else params
    system = scene.system
    q = np.asarray(q, dtype=float)
    zero = np.zeros_like(q)
    omega = params.get("omega")
    period = 2 * math.pi / omega if omega else 1.0
    h = 1e-6
    for k in range(8):
        t = k * period / 8
        qdd = np.atleast_1d(system.accelerations(q, zero, t, params))
        scale = 1.0
        for j in range(q.size):
            step = np.zeros_like(q)
            step[j] = h * max(1.0, abs(q[j]))
            moved = np.atleast_1d(system.accelerations(q + step, zero, t, params))
            scale = max(scale, float(np.max(np.abs(moved - qdd))) / step[j])
        if not np.all(np.abs(qdd) <= 1e-9 * scale):
            return False
    return True


@contextlib.contextmanager
def naming_state(scene, q, setting=None):
    """Re-raise a plain ValueError of the analysis inside with the state it was about."""
    try:
        yield
    except ValueError as e:
        if type(e) is not ValueError or "(about = " in str(e):
            raise
        raise ValueError(f"{str(e).rstrip('.')}; at {describe_state(scene, q, setting)}.") \
            from e
