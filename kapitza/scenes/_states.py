"""The state an analysis is about, as a scene's ``about`` names it: "inverted" (every
coordinate π), "hanging" (0), a list of coordinate values, or "auto" — the persisting
state nearest the initial state (each coordinate's nearest multiple of π) or, for a drive
that leaves no equilibrium, the stable state of averaging nearest it."""
from __future__ import annotations

import math

import numpy as np

from ..averaging import average

__all__ = ["about_state", "averaged_state", "pendulum_state"]


def about_state(scene, setting, q0=None):
    """The state an analysis is about, (n,) or (points, n) coordinates."""
    n = scene.system.n_dof
    q0 = scene.q0 if q0 is None else np.asarray(q0, dtype=float)
    if setting == "inverted":
        return np.full(n, math.pi)
    if setting == "hanging":
        return np.zeros(n)
    if setting not in (None, "auto"):
        about = np.asarray(setting, dtype=float)
        if about.shape != (n,):
            raise ValueError(f"about needs {n} coordinate values "
                             f"({list(scene.system.coordinates)}), got {list(setting)}.")
        return about
    if scene.capabilities["floquet"] == "equilibrium":
        return math.pi * np.round(q0 / math.pi)
    return averaged_state(scene, scene.spec.params, q0)


def averaged_state(scene, params, q0):
    """The stable state of averaging nearest ``q0`` (mod 2π) at scalar ``params``; the
    nearest multiple of π where averaging finds none."""
    stable = [e.about for e in average(scene.system).predict(params, warn=False).equilibria
              if e.stable]
    if not stable:
        return math.pi * np.round(q0 / math.pi)
    turns = [s + 2 * math.pi * np.round((q0 - s) / (2 * math.pi)) for s in stable]
    return min(turns, key=lambda s: float(np.max(np.abs(s - q0))))


def pendulum_state(scene, about):
    """"inverted" or "hanging": the pendulum's persisting state ``about`` names or is nearest."""
    if about in ("inverted", "hanging"):
        return about
    theta = float(about_state(scene, about)[0])
    return "inverted" if abs(math.cos(theta) + 1) < 1e-9 else "hanging"
