"""Averaging, Floquet analysis and direct simulation side by side over a grid: agreement,
every disagreement located, the measured order of averaging.
"""
from ._verify import fit_order, line_argument, pendulum_verification, verify

__all__ = ["verify", "fit_order"]
