"""The catalogue of the lecture's problems, each a few lines on the engine.

Shared by tests, benchmarks and studies (one factory per problem).  Angles are
measured from the downward vertical; y points up; gravity is −g ŷ.
"""
from __future__ import annotations

import sympy as sp

from .systems import Particle, System, coordinates, t

__all__ = ["pendulum", "n_link_pendulum", "double_pendulum", "driven_pendulum"]


def pendulum() -> System:
    """Simple pendulum: bob of mass ``m`` on a massless rod of length ``l``.

    Coordinate ``theta`` (rad, from the downward vertical); parameters ``g``,
    ``l``, ``m``.  θ̈ = −(g/l) sin θ; small oscillations have ω² = g/l.
    """
    (theta,), _ = coordinates("theta")
    m, l, g = sp.symbols("m l g", positive=True)
    bob = Particle(m, (l * sp.sin(theta), -l * sp.cos(theta)), "bob")
    return System([theta], particles=[bob], potential=m * g * bob.position[1], name="pendulum")


def n_link_pendulum(n: int, *, pivot=(0, 0), name: str | None = None) -> System:
    """Planar chain of ``n`` point masses on massless rods, hanging from a pivot.

    Coordinates ``theta1`` … ``thetan`` (rad, each link from the downward
    vertical); parameters ``g``, ``l1`` … ``ln``, ``m1`` … ``mn``.

    Parameters
    ----------
    n : int
        Number of links (≥ 1).
    pivot : pair of sympy expressions
        Pivot position (m), possibly a function of t (a driven pivot).
    """
    if int(n) != n or n < 1:
        raise ValueError(f"n_link_pendulum needs a whole number of links n ≥ 1, got {n!r}.")
    n = int(n)
    thetas, _ = coordinates([f"theta{i}" for i in range(1, n + 1)])
    g = sp.Symbol("g", positive=True)
    x, y = sp.sympify(pivot[0]), sp.sympify(pivot[1])
    particles, V = [], 0
    for i, th in enumerate(thetas, start=1):
        m, l = sp.symbols(f"m{i} l{i}", positive=True)
        x, y = x + l * sp.sin(th), y - l * sp.cos(th)
        particles.append(Particle(m, (x, y), f"bob {i}"))
        V += m * g * y
    return System(thetas, particles=particles, potential=V, name=name or f"{n}-link pendulum")


def double_pendulum() -> System:
    """Planar double pendulum (``n_link_pendulum(2)``).

    Coordinates ``theta1``, ``theta2``; parameters ``g``, ``l1``, ``l2``, ``m1``,
    ``m2``.  For equal masses and lengths the normal modes are
    ω² = (g/l)(2 ∓ √2).
    """
    return n_link_pendulum(2, name="double pendulum")


def driven_pendulum(direction: str = "vertical", damping: bool = False) -> System:
    """Pendulum whose pivot oscillates as A cos ωt (the Kapitza pendulum).

    Coordinate ``theta`` (rad, from the downward vertical).  Parameters ``A``
    (m), ``g``, ``l``, ``m``, ``omega`` (rad/s) and, with ``damping=True``,
    ``gamma`` (1/s) from the dissipation function D = ½ m l² γ θ̇².
    With the vertical drive y_p = A cos ωt:

        θ̈ = −γ θ̇ − (g − A ω² cos ωt) sin θ / l.

    With the horizontal drive x_p = A cos ωt:
    θ̈ = −γ θ̇ − (g sin θ − A ω² cos ωt cos θ) / l.
    """
    (theta,), (theta_dot,) = coordinates("theta")
    m, l, g, A, omega, gamma = sp.symbols("m l g A omega gamma", positive=True)
    drive = A * sp.cos(omega * t)
    if direction == "vertical":
        pivot = (0, drive)
    elif direction == "horizontal":
        pivot = (drive, 0)
    else:
        raise ValueError(f"direction must be 'vertical' or 'horizontal', got {direction!r}.")
    bob = Particle(m, (pivot[0] + l * sp.sin(theta), pivot[1] - l * sp.cos(theta)), "bob")
    D = m * l**2 * gamma * theta_dot**2 / 2 if damping else 0
    return System([theta], particles=[bob], potential=m * g * bob.position[1], dissipation=D,
                  name=f"{direction}ly driven pendulum" + (" (damped)" if damping else ""))
