"""User rigs for the scene tests (tests/test_scene_rigs.py): a bob on a spring.

``spring_pendulum``: a point mass ``m`` on a massless spring from the pivot; coordinates
``r`` (m, the spring's length) and ``theta`` (rad, from the downward vertical).  The spring
itself is the scene's ``[effects.spring.r]`` (k, rest length l0).  It declares nothing:
its units are inferred (r linear in the positions: m; theta periodic: rad).

``declared_spring_pendulum``: the same rig declaring its units and, as a function of the
scene's parameters, its states for a spring of rest length :data:`REST` (1 m): hanging,
r = l0 + m g / k, θ = 0 (the static equilibrium: spring force k (r − l0) = m g), and
inverted, r = l0 − m g / k, θ = π (the spring compressed by the bob's weight).
"""
import sympy as sp

from lagrange_core import coordinates, effects

#: The rest length (m) the declared states assume (the scene's effects.spring.r.rest).
REST = 1.0


def spring_pendulum():
    (r, theta), _ = coordinates("r theta")
    m = sp.Symbol("m", positive=True)
    return effects.Rig("spring pendulum", (r, theta),
                       (("bob", m, lambda px, py: (px + r * sp.sin(theta),
                                                   py - r * sp.cos(theta))),))


def declared_spring_pendulum():
    return spring_pendulum()


declared_spring_pendulum.units = {"r": "m", "theta": "rad"}
declared_spring_pendulum.states = lambda p: {
    "hanging": {"r": REST + p["m"] * p["g"] / p["k_r"], "theta": 0.0},
    "inverted": {"r": REST - p["m"] * p["g"] / p["k_r"], "theta": 3.141592653589793},
}


def bead_on_parabola():
    """A bead on the curve y = x²/(2 a): its coordinate x is neither an angle nor linear
    in the positions, so its unit cannot be inferred."""
    (x,), _ = coordinates("x")
    m, a = sp.symbols("m a", positive=True)
    return effects.Rig("bead on a parabola", (x,),
                       (("bead", m, lambda px, py: (px + x, py + x**2 / (2 * a))),))
