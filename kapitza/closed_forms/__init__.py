"""Closed forms of the single pendulum: the Mathieu equation (characteristic values, the
exact window and map) and the driven pendulum's averaging in closed form (its next
order, the averaging window, Acheson's N-link chain).

Modules: ``_characteristic`` (characteristic values, their series, the Ince–Strutt
chart), ``_mathieu`` (the pendulum's Mathieu parameters, monodromy traces, the exact
window and stability map), ``_pendulum`` (averaging in closed form), ``_window``
(:func:`pendulum_window`, exact or by averaging, and its names before 0.2), ``_floquet``
(the vertically driven pendulum's Floquet numbers from Mathieu's trace).

For sibling rooms (not in ``__all__``): ``pendulum_floquet``, what
:func:`kapitza.floquet_grid` gives about the pendulum's equilibria, without compiling the
general Floquet kernels (the report, ``KapitzaPendulum.verify``, the animation), and
``slow_frequency_error``, the bound of Ω from a monodromy's error (also the verification's).
"""
from ._characteristic import characteristic_value, ince_strutt_chart
from ._floquet import pendulum_floquet as pendulum_floquet
from ._floquet import slow_frequency_error as slow_frequency_error
from ._mathieu import mathieu_monodromy_trace, mathieu_parameters, pendulum_stability_map
from ._pendulum import multiple_pendulum_upright, pendulum_averaged, pendulum_effective_potential
from ._window import averaging_window, pendulum_stability_window, pendulum_window

__all__ = ["mathieu_parameters", "characteristic_value", "mathieu_monodromy_trace",
           "pendulum_window", "pendulum_stability_map", "ince_strutt_chart",
           "pendulum_effective_potential", "pendulum_averaged", "multiple_pendulum_upright",
           # deprecated since 0.2 (pendulum_window)
           "pendulum_stability_window", "averaging_window"]
