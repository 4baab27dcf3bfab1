"""Closed forms: the Mathieu equation of the single pendulum (characteristic values,
exact windows and maps) and the driven pendulum's averaging in closed form (its next
order, the averaging window, Acheson's N-link chain).
"""
from ._mathieu import (characteristic_value, ince_strutt_chart, mathieu_monodromy_trace,
                       mathieu_parameters, pendulum_stability_map, pendulum_stability_window)
from ._pendulum import (averaging_window, multiple_pendulum_upright, pendulum_averaged,
                        pendulum_effective_potential)

__all__ = ["mathieu_parameters", "characteristic_value", "mathieu_monodromy_trace",
           "pendulum_stability_window", "pendulum_stability_map", "ince_strutt_chart",
           "pendulum_effective_potential", "pendulum_averaged", "averaging_window",
           "multiple_pendulum_upright"]
