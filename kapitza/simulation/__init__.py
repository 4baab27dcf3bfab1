"""Direct simulation: measurements of the full nonlinear motion (stayed up, fall time, the
slow frequencies from strobe samples with their error) and periodic orbits by shooting.

For sibling subpackages: ``DEFAULT_PERIODS`` and the pendulum's helpers
``pendulum_about``, ``point`` and ``squeeze``.
"""
from ._measurement import (DEFAULT_PERIODS, measure, measure_grid, pendulum_about, point,
                           slow_frequencies, squeeze)
from ._periodic_orbit import periodic_orbit

__all__ = ["measure", "measure_grid", "periodic_orbit", "slow_frequencies", "DEFAULT_PERIODS"]
