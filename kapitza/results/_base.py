"""What every result module shares: the stability labels, Ctrl-C's exception, small helpers.

Conventions of every result (shared/PHYSICS.md): SI units; θ from the downward vertical
(θ = π upright); pivot A cos ωt; A in m, ω in rad/s, damping γ in 1/s; T = 2π/ω.
"""
from __future__ import annotations

import numpy as np

__all__ = ["BOUNDARIES", "scalar_or_array", "ComputationInterrupted"]

#: Names of the stability labels 0, 1, 2, 3: stable; unstable in a region bounded by
#: period-T solutions (multiplier +1); by period-2T solutions (multiplier −1); complex
#: multipliers leaving the unit circle (combination resonance).
BOUNDARIES = ("stable", "T", "2T", "complex")


def scalar_or_array(x):
    """A Python scalar for a 0-d value, the array otherwise (results keep their input's shape).

    >>> scalar_or_array(np.float64(2.5)), scalar_or_array([1, 2]).tolist()
    (2.5, [1, 2])
    """
    x = np.asarray(x)
    return x.item() if x.ndim == 0 else x


def boundary_names(label) -> np.ndarray:
    """The names (:data:`BOUNDARIES`) of integer stability labels, elementwise."""
    return np.asarray(BOUNDARIES, dtype=object)[np.asarray(label)]


def unscale(scaled, log_scale):
    """M = scaled · e^log_scale; entries ±inf (NaN for zeros) where e^log_scale overflows."""
    ls = np.asarray(log_scale, dtype=float)[..., None, None]
    with np.errstate(over="ignore", invalid="ignore"):
        return np.where(ls > 700, scaled * np.inf, scaled * np.exp(np.minimum(ls, 700)))


def scalar_if_one(values):
    """One slow frequency (a one-coordinate system) as a float, several as an array."""
    values = np.asarray(values)
    return float(values.reshape(-1)[0]) if values.size == 1 else values


class ComputationInterrupted(KeyboardInterrupt):
    """Ctrl-C during a long grid computation (a Floquet grid or map, a damped Mathieu map).

    A KeyboardInterrupt, so scripts still stop; it carries what was finished.

    Attributes
    ----------
    result
        The partial result (the type the call returns): finished points filled, the
        others NaN (traces, growth), unstable, and flagged where the type has flags.
    computed : bool ndarray
        Which points were finished (the result's grid shape).
    """

    def __init__(self, result, computed):
        self.result = result
        self.computed = np.asarray(computed, dtype=bool)
        super().__init__(f"interrupted: {int(self.computed.sum())} of {self.computed.size} "
                         "grid points were computed; the partial result is in the exception's "
                         ".result (.computed marks the finished points)")
