"""Every result of kapitza: frozen dataclasses with named fields and ``to_dataframe()``.

The lowest room of the package: it imports no other kapitza subpackage (a result's
``figure()`` draws itself through :mod:`kapitza.figures`, imported inside the method;
the figures read results but never import them at run time).

By concept: Floquet analysis (``FloquetResult``, ``MonodromyData``, ``FloquetGrid``);
stability over the drive's plane (``StabilityMap``, ``AdaptiveMap``, ``StabilityWindow``,
``BoundaryCurves``, ``InceStruttChart``); averaging (``SlowModes``,
``AveragingPrediction``, ``SlowModeSweep``, and in closed form ``EquilibriumPrediction``,
``PendulumAveraging``, ``MultiplePendulumPrediction``); direct simulation
(``Measurement``, ``PeriodicOrbit``); verification (``Verification``, ``OrderFit``);
continuation (``Branch``, ``BranchPoints``, ``Bifurcation``); the route to chaos
(``LyapunovSpectrum``, ``LyapunovGrid``, ``BifurcationDiagram``, ``PoincareSection``,
``Basin``); and
``ComputationInterrupted``, Ctrl-C during a long grid with the finished part.

For sibling rooms (not in ``__all__``): ``BOUNDARIES`` (the names of the stability
labels), ``VERIFICATION_METHODS``, ``BIFURCATION_KINDS``, ``BRANCH_STATUSES`` and
``scalar_or_array``; for a sweep's display and Dataset (:mod:`kapitza.scenes`):
``LabelledGrid``, ``quantity_of``, ``coordinate_units`` and ``require_xarray`` (the shared
xarray builder, ``_xarray``), ``html_card``, ``html_span``, ``html_share``,
``html_quantity`` and ``draw_figure`` (the cards of ``_repr_html_``, ``_display``).

Every result has a compact ``_repr_html_`` (Jupyter); every gridded result has
``to_xarray()`` (an :class:`xarray.Dataset` with named, united coordinates: the optional
extra ``kapitza[xarray]``); where a picture is the natural summary, ``figure()``.
"""
from ._averaging import (
    AveragingPrediction,
    EquilibriumPrediction,
    MultiplePendulumPrediction,
    PendulumAveraging,
    SlowModes,
    SlowModeSweep,
)
from ._base import BOUNDARIES as BOUNDARIES
from ._base import ComputationInterrupted
from ._base import scalar_or_array as scalar_or_array
from ._branches import BIFURCATION_KINDS as BIFURCATION_KINDS
from ._branches import BRANCH_STATUSES as BRANCH_STATUSES
from ._branches import Bifurcation, Branch, BranchPoints
from ._chaos import Basin, BifurcationDiagram, LyapunovGrid, LyapunovSpectrum, PoincareSection
from ._display import card as html_card  # noqa: F401 - for kapitza.scenes, not in __all__
from ._display import draw as draw_figure  # noqa: F401
from ._display import quantity as html_quantity  # noqa: F401
from ._display import share as html_share  # noqa: F401
from ._display import span as html_span  # noqa: F401
from ._floquet import FloquetGrid, FloquetResult, MonodromyData
from ._maps import (
    AdaptiveMap,
    BoundaryCurves,
    InceStruttChart,
    StabilityMap,
    StabilityWindow,
)
from ._simulation import Measurement, PeriodicOrbit
from ._verification import VERIFICATION_METHODS as VERIFICATION_METHODS
from ._verification import OrderFit, Verification
from ._xarray import LabelledGrid as LabelledGrid
from ._xarray import coordinate_units as coordinate_units
from ._xarray import quantity_of as quantity_of
from ._xarray import require_xarray as require_xarray

__all__ = [
    "ComputationInterrupted", "FloquetResult", "MonodromyData", "FloquetGrid", "StabilityMap",
    "StabilityWindow", "InceStruttChart", "SlowModes", "AveragingPrediction",
    "SlowModeSweep", "EquilibriumPrediction", "PendulumAveraging", "MultiplePendulumPrediction",
    "Measurement", "PeriodicOrbit", "OrderFit", "Verification", "BoundaryCurves", "AdaptiveMap",
    "Branch", "BranchPoints", "Bifurcation", "LyapunovSpectrum", "LyapunovGrid",
    "BifurcationDiagram", "PoincareSection", "Basin",
]


def __getattr__(name):
    # FloquetWindow: StabilityWindow's name before 0.2 (deprecated; removed in 0.3)
    if name == "FloquetWindow":
        from .._deprecation import warn_deprecated
        warn_deprecated("kapitza.results.FloquetWindow", "kapitza.results.StabilityWindow",
                        stacklevel=3)
        return StabilityWindow
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
