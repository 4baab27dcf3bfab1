"""Animations drawn from simulation: the stabilised pendulum beside one that falls, and
planar chains from scenes.
"""
from ._animation import Animation, SystemAnimation, pendulum_animation, system_animation

__all__ = ["pendulum_animation", "system_animation", "Animation", "SystemAnimation"]
