"""Direct simulation: measurements of the full nonlinear motion (stayed up, fall time, the
slow frequencies from strobe samples with their error) and periodic orbits by shooting —
on the period map, or on the half-period map where the drive has the symmetry
θ(t + T/2) = −θ(t) (regular at the symmetry-breaking pitchfork, where the full map's
shooting is singular).

Public: :func:`measure`, :func:`measure_grid`, :func:`periodic_orbit`,
:func:`slow_frequencies`, ``DEFAULT_PERIODS``. For sibling rooms (not in ``__all__``):
the pendulum's helpers ``pendulum_about``, ``point``, ``squeeze``, and
``symmetry_breaking`` (the amplitude of a symmetric orbit's pitchfork).
"""
from ._measurement import DEFAULT_PERIODS, measure, measure_grid, slow_frequencies
from ._measurement import pendulum_about as pendulum_about
from ._measurement import point as point
from ._measurement import squeeze as squeeze
from ._orbit_bifurcation import symmetry_breaking as symmetry_breaking
from ._periodic_orbit import periodic_orbit

__all__ = ["measure", "measure_grid", "periodic_orbit", "slow_frequencies", "DEFAULT_PERIODS"]
