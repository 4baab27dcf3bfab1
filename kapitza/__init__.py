"""kapitza: fast periodic driving on top of lagrange_core.

Public API
----------
KapitzaPendulum
    The driven pendulum: averaging, Floquet stability and direct integration in one
    object (:mod:`kapitza.pendulum`).
average, AveragedSystem, pendulum_averaged, stability_window, multiple_pendulum_upright, ...
    Averaging over a fast periodic drive (:mod:`kapitza.averaging`).
floquet_grid, stability_map, FloquetResult, StabilityMap, FloquetWindow (and floquet.floquet)
    Floquet analysis of any lagrange_core system about a driven equilibrium
    (:mod:`kapitza.floquet`).
characteristic_value, mathieu_parameters, pendulum_stability_map, ...
    The Mathieu equation of the single pendulum (:mod:`kapitza.mathieu`).
stability_map_figure, ince_strutt_figure
    Figures (:mod:`kapitza.plots`).
"""
from .pendulum import KapitzaPendulum

__all__: list[str] = ["KapitzaPendulum"]

from .averaging import (AveragedSystem, AveragingValidityWarning, average,  # noqa: E402
                        multiple_pendulum_upright, pendulum_averaged,
                        pendulum_effective_potential, stability_window)

__all__ += ["average", "AveragedSystem", "AveragingValidityWarning", "pendulum_averaged",
            "pendulum_effective_potential", "stability_window", "multiple_pendulum_upright"]
# (the function kapitza.floquet.floquet is not re-exported: it would hide the module)
from .floquet import (FloquetResult, FloquetWindow, StabilityMap,  # noqa: E402
                      floquet_grid, stability_map)
from .mathieu import (characteristic_value, mathieu_monodromy_trace,  # noqa: E402
                      mathieu_parameters, pendulum_stability_map, pendulum_stability_window)
from .plots import ince_strutt_figure, stability_map_figure  # noqa: E402

__all__ += ["floquet_grid", "stability_map", "FloquetResult", "FloquetWindow",
            "StabilityMap", "characteristic_value", "mathieu_parameters",
            "mathieu_monodromy_trace", "pendulum_stability_map", "pendulum_stability_window",
            "stability_map_figure", "ince_strutt_figure"]
__version__ = "0.1.0"
