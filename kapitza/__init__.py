"""kapitza: fast periodic driving on top of lagrange_core.

Conventions (shared/PHYSICS.md): SI units; θ from the downward vertical (θ = π upright);
pivot A cos ωt; damping γ (1/s); Mathieu form τ = ωt/2, a = ±4ω0²/ω², q = 2A/l.
The API's one rule (docs/api-conventions.md): functions on any system take
``(system, params, about, *, A=, omega=, ...)``; ``KapitzaPendulum`` methods take the drive
``(A, omega)`` first and the state after; windows are one family, ``window``.

This module lists the whole public API; each name lives in a room (a subpackage that
answers one question, its ``__init__`` the room's public face):

The pendulum (:mod:`kapitza.pendulum`)
    KapitzaPendulum
        The driven pendulum: averaging, Floquet stability and direct integration in
        one object.

Averaging of any system (:mod:`kapitza.averaging`)
    average
        Average a lagrange_core System over its fast periodic drive (Landau–Lifshitz §30).
    AveragedSystem
        The slow description: U_eff (sympy and compiled), equilibria, slow modes, the
        averaging window (``AveragedSystem.window``).
    AveragingValidityWarning
        Warns when a scalar prediction lies outside the regime where averaging holds.

Floquet analysis of any system (:mod:`kapitza.floquet`)
    floquet_point, floquet_grid, monodromy_data
        Monodromy, multipliers and stability about a driven equilibrium; over a grid.
    stability_map, adaptive_map
        Stability over an (A, ω) grid; refined only where the classification changes.
    window
        The exact window of stabilising amplitudes, per ω, with certified edges.
    boundaries
        The stability boundaries A_k(ω) by continuation, with their kind.

Closed forms: the Mathieu equation and the pendulum (:mod:`kapitza.closed_forms`)
    mathieu_parameters, characteristic_value, mathieu_monodromy_trace, ince_strutt_chart
        The Mathieu form (a, q, c), characteristic values to rounding, tr M, the chart.
    pendulum_window
        The pendulum's window per ω: exact (Mathieu characteristic values) or, with
        ``method="averaging"``, averaging of order 1 or 2.
    pendulum_stability_map
        The exact stability map over A × ω (characteristic values: milliseconds).
    pendulum_effective_potential, pendulum_averaged
        U_eff(θ)/m; equilibria, stability and slow frequencies by averaging, over arrays.
    multiple_pendulum_upright
        Minimum drive and slow modes of the upright N-link chain (Acheson's theorem).

Direct simulation (:mod:`kapitza.simulation`)
    measure, measure_grid
        Simulate and measure: stayed near ``about`` or fell (when), slow frequencies with
        error estimates, slow amplitude, mean position; over a broadcast grid in one
        compiled parallel integration.
    periodic_orbit
        The T-periodic orbit of any driven system (shooting on the period map) and its
        Floquet multipliers: the slow states of drives that leave no equilibrium.

Continuation and bifurcations (:mod:`kapitza.continuation`)
    continuation
        Follow a branch of (n)T-periodic orbits in one parameter through folds, with the
        multipliers along it and its bifurcations located and classified; returns a
        ``Branch`` (``Branch.switch(bifurcation)`` starts the emanating branch).
    Branch, Bifurcation
        A continued branch (its points, multipliers and bifurcations); one bifurcation.

The route to chaos (:mod:`kapitza.chaos`)
    lyapunov, lyapunov_grid
        Lyapunov exponents by the variational equations (Benettin), with their error: the
        spectrum of one trajectory; the largest over a broadcast grid (a chaos map).
    bifurcation_diagram
        Strobe samples after a transient over a parameter's values × starts (brute force).
    poincare_section, basin
        The stroboscopic section of a trajectory; the starts that stay near a state.
    LyapunovSpectrum, LyapunovGrid, BifurcationDiagram, PoincareSection, Basin
        What each of them returns.

Verification (:mod:`kapitza.verification`)
    verify
        Averaging, Floquet analysis and direct simulation over an (A, ω) grid, compared
        point by point; every disagreement located; the measured order of averaging.

Results (:mod:`kapitza.results`; frozen dataclasses with ``to_dataframe()``)
    ComputationInterrupted
        Ctrl-C during a long map, grid or sweep; ``.result`` holds the finished points.
    What the analyses return
        FloquetResult, FloquetGrid, MonodromyData, StabilityMap, StabilityWindow,
        BoundaryCurves, AdaptiveMap, InceStruttChart, SlowModes, AveragingPrediction,
        SlowModeSweep, PendulumAveraging, EquilibriumPrediction,
        MultiplePendulumPrediction, PeriodicOrbit, Measurement, Verification, OrderFit

Figures (:mod:`kapitza.figures`; they draw results and compute nothing)
    Exported here
        stability_map_figure, effective_potential_figure, ince_strutt_figure,
        verification_figure; the others are in :mod:`kapitza.figures`.

Animation (:mod:`kapitza.animation`)
    pendulum_animation, system_animation, Animation, SystemAnimation
        GIFs drawn from the simulation: the stabilised pendulum beside one that falls;
        planar chains from scenes.

Scenes and sweeps (:mod:`kapitza.scenes`)
    Scene, SceneResults, SceneError, SweepResult, example_scenes
        A set-up in a TOML file, the analyses it asks for, resumable Parquet sweeps.
    open_sweep
        A finished sweep's directory as one xarray Dataset over its axes (the optional
        extra ``kapitza[xarray]``).

The report (:mod:`kapitza.report`; the CLI's ``kapitza report``)
    build_report, Report
        One self-contained folder: an HTML page, its figures, a GIF and the data.

Installation
    warmup
        Compile the integrators and the Floquet and Mathieu kernels once per installation.

Deprecated (0.2; removed in 0.3; each warns and names its replacement)
    averaging_window
        → ``pendulum_window(omega, method="averaging")``.
    pendulum_stability_window
        → ``pendulum_window(omega)``.
    FloquetWindow
        → ``StabilityWindow``.

Examples
--------
>>> import math
>>> import kapitza
>>> pend = kapitza.KapitzaPendulum(l=1.0, g=9.81)
>>> pend.averaged(A=0.05, omega=2 * math.pi * 60).inverted.stable     # first-order averaging
True
>>> pend.floquet(A=0.05, omega=2 * math.pi * 60, about="inverted").stable   # exact, linear
True
"""
from ._arguments import GridTooLargeError as GridTooLargeError
from ._version import __version__ as __version__
from .animation import Animation as Animation
from .animation import SystemAnimation as SystemAnimation
from .animation import pendulum_animation as pendulum_animation
from .animation import system_animation as system_animation
from .averaging import AveragedSystem as AveragedSystem
from .averaging import AveragingValidityWarning as AveragingValidityWarning
from .averaging import average as average
from .chaos import basin as basin
from .chaos import bifurcation_diagram as bifurcation_diagram
from .chaos import lyapunov as lyapunov
from .chaos import lyapunov_grid as lyapunov_grid
from .chaos import poincare_section as poincare_section
from .closed_forms import averaging_window as averaging_window  # deprecated
from .closed_forms import characteristic_value as characteristic_value
from .closed_forms import ince_strutt_chart as ince_strutt_chart
from .closed_forms import mathieu_monodromy_trace as mathieu_monodromy_trace
from .closed_forms import mathieu_parameters as mathieu_parameters
from .closed_forms import multiple_pendulum_upright as multiple_pendulum_upright
from .closed_forms import pendulum_averaged as pendulum_averaged
from .closed_forms import pendulum_effective_potential as pendulum_effective_potential
from .closed_forms import pendulum_stability_map as pendulum_stability_map
from .closed_forms import pendulum_stability_window as pendulum_stability_window  # deprecated
from .closed_forms import pendulum_window as pendulum_window
from .continuation import continuation as continuation
from .figures import effective_potential_figure as effective_potential_figure
from .figures import ince_strutt_figure as ince_strutt_figure
from .figures import stability_map_figure as stability_map_figure
from .figures import verification_figure as verification_figure
from .floquet import adaptive_map as adaptive_map
from .floquet import boundaries as boundaries
from .floquet import floquet_grid as floquet_grid
from .floquet import floquet_point as floquet_point
from .floquet import monodromy_data as monodromy_data
from .floquet import stability_map as stability_map
from .floquet import window as window
from .pendulum import KapitzaPendulum as KapitzaPendulum
from .report import Report as Report
from .report import build_report as build_report
from .results import AdaptiveMap as AdaptiveMap
from .results import AveragingPrediction as AveragingPrediction
from .results import Basin as Basin
from .results import Bifurcation as Bifurcation
from .results import BifurcationDiagram as BifurcationDiagram
from .results import BoundaryCurves as BoundaryCurves
from .results import Branch as Branch
from .results import ComputationInterrupted as ComputationInterrupted
from .results import EquilibriumPrediction as EquilibriumPrediction
from .results import FloquetGrid as FloquetGrid
from .results import FloquetResult as FloquetResult
from .results import InceStruttChart as InceStruttChart
from .results import LyapunovGrid as LyapunovGrid
from .results import LyapunovSpectrum as LyapunovSpectrum
from .results import Measurement as Measurement
from .results import MonodromyData as MonodromyData
from .results import MultiplePendulumPrediction as MultiplePendulumPrediction
from .results import OrderFit as OrderFit
from .results import PendulumAveraging as PendulumAveraging
from .results import PeriodicOrbit as PeriodicOrbit
from .results import PoincareSection as PoincareSection
from .results import SlowModes as SlowModes
from .results import SlowModeSweep as SlowModeSweep
from .results import StabilityMap as StabilityMap
from .results import StabilityWindow as StabilityWindow
from .results import Verification as Verification
from .scenes import Scene as Scene
from .scenes import SceneError as SceneError
from .scenes import SceneResults as SceneResults
from .scenes import SweepResult as SweepResult
from .scenes import example_scenes as example_scenes
from .scenes import open_sweep as open_sweep
from .simulation import measure as measure
from .simulation import measure_grid as measure_grid
from .simulation import periodic_orbit as periodic_orbit
from .verification import verify as verify
from .warmup import warmup as warmup

#: Names kept for 0.2 only, each → the call that replaces it (they warn when used).
DEPRECATED = {
    "averaging_window": "kapitza.pendulum_window(omega, method='averaging')",
    "pendulum_stability_window": "kapitza.pendulum_window(omega)",
    "FloquetWindow": "kapitza.StabilityWindow",
}

__all__ = [
    "KapitzaPendulum",
    "average", "AveragedSystem", "AveragingValidityWarning",
    "floquet_point", "floquet_grid", "monodromy_data", "stability_map", "adaptive_map",
    "window", "boundaries",
    "mathieu_parameters", "characteristic_value", "mathieu_monodromy_trace",
    "ince_strutt_chart", "pendulum_window", "pendulum_stability_map",
    "pendulum_effective_potential", "pendulum_averaged", "multiple_pendulum_upright",
    "measure", "measure_grid", "periodic_orbit",
    "continuation", "Branch", "Bifurcation",
    "lyapunov", "lyapunov_grid", "bifurcation_diagram", "poincare_section", "basin",
    "LyapunovSpectrum", "LyapunovGrid", "BifurcationDiagram", "PoincareSection", "Basin",
    "verify",
    "ComputationInterrupted", "FloquetResult", "FloquetGrid", "MonodromyData",
    "StabilityMap", "StabilityWindow", "BoundaryCurves", "AdaptiveMap", "InceStruttChart",
    "SlowModes", "AveragingPrediction", "SlowModeSweep", "PendulumAveraging",
    "EquilibriumPrediction", "MultiplePendulumPrediction", "PeriodicOrbit", "Measurement",
    "Verification", "OrderFit",
    "stability_map_figure", "effective_potential_figure", "ince_strutt_figure",
    "verification_figure",
    "pendulum_animation", "system_animation", "Animation", "SystemAnimation",
    "Scene", "SceneResults", "SceneError", "SweepResult", "example_scenes", "open_sweep",
    "GridTooLargeError",
    "build_report", "Report",
    "warmup",
    # deprecated (DEPRECATED): they warn and name their replacement
    "averaging_window", "pendulum_stability_window", "FloquetWindow",
]


def __getattr__(name):
    # a deprecated class alias warns when it is looked up (a function alias when called)
    if name == "FloquetWindow":
        from ._deprecation import warn_deprecated
        warn_deprecated("kapitza.FloquetWindow", DEPRECATED[name], stacklevel=3)
        return StabilityWindow
    raise AttributeError(f"module 'kapitza' has no attribute {name!r}")
