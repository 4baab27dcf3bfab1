"""kapitza: fast periodic driving on top of lagrange_core.

Conventions (shared/PHYSICS.md): SI units; θ from the downward vertical (θ = π upright);
pivot A cos ωt; damping γ (1/s); Mathieu form τ = ωt/2, a = ±4ω0²/ω², q = 2A/l.

Public API
----------
The pendulum
    KapitzaPendulum
        The driven pendulum: averaging, Floquet stability and direct integration in
        one object (:mod:`kapitza.pendulum`).

Averaging of any system (:mod:`kapitza.averaging`)
    average
        Average a lagrange_core System over its fast periodic drive (Landau–Lifshitz §30).
    AveragedSystem
        The slow description: U_eff (sympy and compiled), equilibria, slow modes, sweeps.
    AveragingValidityWarning
        Warns when a scalar prediction lies outside the regime where averaging holds.

The pendulum and Acheson's chain in closed form (:mod:`kapitza.pendulum_closed_forms`)
    pendulum_effective_potential
        U_eff(θ)/m of the vertically or horizontally driven pendulum (J/kg).
    pendulum_averaged
        Equilibria, stability and slow frequencies by averaging, order 1 or 2, over arrays.
    averaging_window
        The averaging prediction of the amplitudes that hold the pendulum upright, per ω
        (the exact window: ``KapitzaPendulum.stability_window``).
    multiple_pendulum_upright
        Minimum drive and slow modes of the upright N-link chain (Acheson's theorem).

Floquet analysis (:mod:`kapitza.floquet`)
    floquet_point
        Monodromy, multipliers and stability about a driven equilibrium of any system.
    floquet_grid
        The same over a broadcast grid of parameter sets.
    monodromy_data
        Only the monodromy matrices over a grid.
    stability_map
        Stability of any system's driven equilibrium over an (A, ω) grid.
    window
        The exact window of stabilising amplitudes of any system, per ω, with certified
        edges (roots of smooth margins such as det(M ∓ I)).
    boundaries
        The stability boundaries A_k(ω) of any system by continuation, with their kind.
    adaptive_map
        A stability map refined only where the classification changes.

Periodic orbits (:mod:`kapitza.periodic_orbit`)
    periodic_orbit
        The T-periodic orbit of any driven system (Newton shooting on the period map) and
        its Floquet multipliers: the slow states of drives that leave no equilibrium.

Measurements from direct simulation (:mod:`kapitza.measurement`)
    measure
        Simulate one parameter set of any driven system and measure the motion: stayed
        near ``about`` or fell (when), slow frequencies with error estimates, slow
        amplitude, mean position, energy drift.
    measure_grid
        The same over a broadcast grid, in one compiled parallel integration.

Verification (:mod:`kapitza.verify`)
    verify
        Averaging, Floquet analysis and direct simulation of any driven equilibrium over
        an (A, ω) grid, compared point by point: agreement, every disagreement located,
        the measured order of averaging (``KapitzaPendulum.verify`` for the pendulum).

The Mathieu equation of the single pendulum (:mod:`kapitza.mathieu`)
    mathieu_parameters
        The mapping (A, ω, l, g, γ, about) → (a, q, c), written once.
    characteristic_value
        a_r(q), b_r(q) to rounding (where scipy.special is wrong too).
    mathieu_monodromy_trace
        tr M of the (damped) Mathieu equation by integration, with error estimate.
    pendulum_stability_window
        The exact window A_min < A < A_max per ω, certified.
    pendulum_stability_map
        The exact stability map over A × ω (characteristic values: milliseconds).
    ince_strutt_chart
        The Mathieu equation's stability chart and characteristic curves.

Results (:mod:`kapitza.results`; frozen dataclasses with ``to_dataframe()``)
    ComputationInterrupted
        Ctrl-C during a long map, grid or sweep (a KeyboardInterrupt); ``.result`` holds
        the finished points, ``.computed`` which they are.
    FloquetResult
        One point's Floquet analysis: multipliers, trace, stability, slow frequency, guards.
    FloquetGrid, MonodromyData
        Floquet analysis / monodromies over a parameter grid.
    StabilityMap
        Stability labels over (A, ω) with the pendulum's l, g, damping, about, method.
    StabilityWindow
        A_min, A_max per ω, exact (``method="floquet"``) or by averaging
        (``method="averaging"``); ``FloquetWindow`` is its old name.
    BoundaryCurves, AdaptiveMap
        Exact boundary curves over (A, ω); a map with its continuous margin.
    InceStruttChart
        Stability grid and characteristic curves in the (q, a) plane.
    SlowModes, AveragingPrediction, SlowModeSweep
        Results of the general averaging.
    PendulumAveraging, EquilibriumPrediction, MultiplePendulumPrediction
        Results of the pendulum's closed forms.
    PeriodicOrbit
        A periodic orbit: state, period mean, fast amplitude, multipliers, stability.
    Measurement
        What direct simulation measured, per point (``measure``, ``measure_grid``,
        ``KapitzaPendulum.measure``).
    Verification, OrderFit
        The four methods compared per point, with agreement statistics and located
        disagreements (``verify``); the measured order of averaging.

Figures (:mod:`kapitza.plots`; they draw results and compute nothing)
    stability_map_figure
        A stability map with stability windows (e.g. the averaging limit) drawn over it.
    effective_potential_figure
        U_eff(θ) with the averaged equilibria marked (stable / unstable).
    ince_strutt_figure
        The Ince–Strutt chart.
    verification_figure
        A verification's map with its disagreements marked, and the order of averaging.

Animation (:mod:`kapitza.animation`)
    pendulum_animation
        A looping GIF of the stabilised inverted pendulum beside one that falls, drawn
        from the simulation in stated slow motion; returns an ``Animation``.
    system_animation
        The same for planar chains of particles from scenes, side by side (e.g.
        Acheson's double pendulum upright vs falling); returns a ``SystemAnimation``.

Scenes and sweeps (:mod:`kapitza.scene`, :mod:`kapitza.scene_file`, :mod:`kapitza.sweep`)
    Scene
        A set-up in a TOML file (``Scene.from_toml(path)``): ``.system`` with only the
        effects it names, ``.run()`` the analyses it asks for, ``.sweep()`` over its grid.
    SceneResults, SceneError
        What ``Scene.run`` computed; every problem of a scene file, reported together.
    SweepResult
        A sweep's tidy DataFrame and its Parquet dataset (tiles kept on disk, resumable;
        serial, numba threads or a Dask cluster).
    example_scenes
        The scene files that ship with kapitza.

The report (:mod:`kapitza.report`; the CLI's ``kapitza report``)
    build_report
        Run a scene (default: a 1 m pendulum shaken vertically) through every analysis
        and write one folder: index.html, PNG figures, a GIF and the data (Parquet, CSV).
    Report
        What it wrote: paths, per-section wall times and status, the headline numbers.

Installation
    warmup
        Compile the integrators and the Floquet and Mathieu kernels once per
        installation (:mod:`kapitza.warmup`; includes :func:`lagrange_core.warmup`).

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
from ._version import __version__
from .averaging import AveragedSystem, AveragingValidityWarning, average
from .floquet import (adaptive_map, boundaries, floquet_grid, floquet_point, monodromy_data,
                      stability_map, window)
from .closed_forms import (characteristic_value, ince_strutt_chart, mathieu_monodromy_trace,
                           mathieu_parameters, pendulum_stability_map, pendulum_stability_window)
from .closed_forms import (multiple_pendulum_upright, pendulum_averaged,
                           pendulum_effective_potential, averaging_window)
from .simulation import measure, measure_grid, periodic_orbit
from .pendulum import KapitzaPendulum
from .figures import (effective_potential_figure, ince_strutt_figure, stability_map_figure,
                      verification_figure)
from .verification import verify
from .animation import Animation, SystemAnimation, pendulum_animation, system_animation
from .report import Report, build_report
from .warmup import warmup
from .scenes import Scene, SceneError, SceneResults, SweepResult, example_scenes
from .results import (AveragingPrediction, ComputationInterrupted, EquilibriumPrediction,
                      FloquetGrid, FloquetResult, FloquetWindow, InceStruttChart, Measurement,
                      MonodromyData, MultiplePendulumPrediction, PendulumAveraging,
                      PeriodicOrbit, SlowModes, SlowModeSweep, StabilityMap, StabilityWindow)
from .results import OrderFit, Verification
from .results import AdaptiveMap, BoundaryCurves

__all__ = [
    "KapitzaPendulum",
    "average", "AveragedSystem", "AveragingValidityWarning",
    "pendulum_effective_potential", "pendulum_averaged", "averaging_window",
    "multiple_pendulum_upright",
    "floquet_point", "floquet_grid", "monodromy_data", "stability_map",
    "window", "boundaries", "adaptive_map", "BoundaryCurves", "AdaptiveMap",
    "periodic_orbit", "PeriodicOrbit",
    "measure", "measure_grid",
    "verify", "Verification", "OrderFit", "verification_figure",
    "mathieu_parameters", "characteristic_value", "mathieu_monodromy_trace",
    "pendulum_stability_window", "pendulum_stability_map", "ince_strutt_chart",
    "ComputationInterrupted", "FloquetResult", "FloquetGrid", "MonodromyData", "StabilityMap",
    "StabilityWindow",
    "FloquetWindow", "InceStruttChart", "SlowModes", "AveragingPrediction", "SlowModeSweep",
    "PendulumAveraging", "EquilibriumPrediction", "MultiplePendulumPrediction", "Measurement",
    "stability_map_figure", "effective_potential_figure", "ince_strutt_figure", "warmup",
    "Scene", "SceneResults", "SceneError", "SweepResult", "example_scenes",
    "pendulum_animation", "Animation", "build_report", "Report",
    "system_animation", "SystemAnimation",
]
