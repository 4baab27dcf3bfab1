"""kapitza: fast periodic driving on top of lagrange_core.

Public API
----------
(filled by the averaging and Floquet modules)
average, AveragedSystem, pendulum_averaged, stability_window, multiple_pendulum_upright, ...
    Averaging over a fast periodic drive (:mod:`kapitza.averaging`).
"""
__all__: list[str] = []

from .averaging import (AveragedSystem, AveragingValidityWarning, average,  # noqa: E402
                        multiple_pendulum_upright, pendulum_averaged,
                        pendulum_effective_potential, stability_window)

__all__ += ["average", "AveragedSystem", "AveragingValidityWarning", "pendulum_averaged",
            "pendulum_effective_potential", "stability_window", "multiple_pendulum_upright"]
__version__ = "0.1.0"
