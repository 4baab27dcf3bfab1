"""Every result of kapitza: frozen dataclasses with named fields and ``to_dataframe()``.

The lowest room of the package: it imports no other kapitza subpackage (a result's
``figure()`` draws itself through :mod:`kapitza.figures`, which reads results but never
imports them at run time).
"""
from ._results import (BOUNDARIES, VERIFICATION_METHODS, AdaptiveMap, AveragingPrediction,
                       BoundaryCurves, ComputationInterrupted, EquilibriumPrediction,
                       FloquetGrid, FloquetResult, FloquetWindow, InceStruttChart, Measurement,
                       MonodromyData, MultiplePendulumPrediction, OrderFit, PendulumAveraging,
                       PeriodicOrbit, SlowModes, SlowModeSweep, StabilityMap, StabilityWindow,
                       Verification, scalar_or_array)

__all__ = [
    "ComputationInterrupted", "FloquetResult", "MonodromyData", "FloquetGrid", "StabilityMap",
    "StabilityWindow", "FloquetWindow", "InceStruttChart", "SlowModes", "AveragingPrediction",
    "SlowModeSweep", "EquilibriumPrediction", "PendulumAveraging", "MultiplePendulumPrediction",
    "Measurement", "PeriodicOrbit", "OrderFit", "Verification", "BoundaryCurves", "AdaptiveMap",
]
