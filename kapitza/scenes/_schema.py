"""The scene file's schema: its tables, their keys, units and ranges.

A scene file says what a lecture's figure says — what hangs from the pivot, the
parameter values, the physics switched on, where the motion starts — and which
analyses to run.  This module holds the tables of allowed keys that
:func:`~kapitza.scenes._file.read_scene` checks a file against; the checks themselves
are in :mod:`._file` (the analyses' settings in :mod:`._settings`), the analyses in
:mod:`._analyses` and :mod:`._frontier`.

Schema 1
--------
Top level: ``schema = 1`` (required), ``title`` (text, optional) and the tables

``[system]``
    ``name``: a rig of :data:`lagrange_core.effects.RIGS` ("pendulum",
    "double_pendulum", "triple_pendulum"), "chain" with ``links = n``, or a user's
    function ``"package.module:function"`` that returns a
    :class:`lagrange_core.effects.Rig` (called with the keyword arguments of the
    optional table ``[system.options]``).

    A user's rig declares, in its own terms, what the analyses are about
    (:mod:`kapitza.scenes._rigs`):

    * ``units``: each coordinate's unit, ``{ r = "m", theta = "rad" }`` — "rad" (an
      angle), "m" (a length) or "1" (a pure number); velocities are per second.  An
      undeclared one is inferred: "rad" where every mass's position is 2π-periodic in
      it, "m" where they are linear in it; otherwise it must be declared.
    * ``states``: its named states, ``{ hanging = { r = 1.245, theta = 0.0 }, inverted =
      { r = 0.755, theta = 3.14159 } }`` (a table per state giving every coordinate, or a
      list in the rig's order); ``about`` may name them.

    Either may also be an attribute of the rig function (``spring_pendulum.units = {...}``;
    ``spring_pendulum.states`` a dict, or a function of the scene's parameters ``params →
    {name: {coordinate: value}}``, for states that move with them, r = l0 + m g / k — a
    spring's rest length l0 is not a parameter, so such a function knows it itself; an
    example: ``tests/data/spring_rigs.py``); the scene's keys win, state by state and
    coordinate by coordinate.  A rig of angles only
    that declares no states has the catalogue's "inverted" (every angle π) and "hanging"
    (0); a rig with another coordinate has only the states it declares, and an analysis
    about "auto" (the default) or averaging without ``guesses`` needs them.  The
    catalogue's rigs take neither key: their coordinates are angles from the downward
    vertical, their states "inverted" and "hanging".
``[parameters]``
    The rig's parameters by name (the pendulum: ``l`` (m), ``m`` (kg); a chain ``l1`` …
    ``ln``, ``m1`` … ``mn``) and ``g`` (m/s²) with gravity on.  Lengths are required;
    masses default to 1 kg and ``g`` to 9.81 m/s².  A parameter the rig declares
    positive (lengths, masses) must be > 0; ``g`` ≥ 0.
``[effects]``
    Only the effects named here enter the equations (:mod:`lagrange_core.effects`):

    * ``gravity = true``;
    * ``[effects.drive]``: ``direction`` ("vertical" (default), "horizontal", a vector
      ``[dx, dy]``, or "elliptic": x = A cos ωt, y = B sin ωt), ``amplitude`` A (m, ≥ 0),
      ``amplitude_y`` B (m, the ellipse only; its sign sets the sense of rotation),
      ``frequency_hz`` f (> 0) or ``omega`` (rad/s, > 0), ``harmonics``
      ``[[k, a_k, phase], ...]`` (A Σ a_k cos(kωt + phase); not for the ellipse);
    * ``[effects.damping]``: ``gamma`` (1/s, ≥ 0), θ̈ = −γ θ̇ − …;
    * ``[effects.air_drag]``: ``c`` (kg/m, ≥ 0), −c |v| v on every mass;
    * ``[effects.spring.<coordinate>]``: ``k`` (> 0), ``rest`` (default 0).
``[initial]``
    Initial coordinates by name and velocities ``<coordinate>_dot`` (default 0), in the
    coordinates' units (rad and rad/s for the catalogue's rigs).
``[analyses]``
    Each ``name = true`` or a table of its settings; only those named run (how each is
    computed: :class:`kapitza.Scene`).  An *axis* is a list of values or a range
    ``{start, stop, num, scale = "linear" | "log"}``; ``about`` is a state the rig
    declares by name ("inverted" or "hanging" for the catalogue's rigs), "auto" (default:
    the declared state nearest the initial one; each angle's nearest multiple of π for a
    rig of angles only), or the state's values, a list in the rig's order or a table
    ``{ r = 1.245, theta = 0.0 }``, in the coordinates' units.  A name the rig does not
    declare is refused, listing those it does.

    ======================  =========================================================
    ``averaging``           ``order`` (1, or 2 for the plain pendulum), ``guesses``
                            (starting points of the search for equilibria, a list of
                            states; default: 0, ±π/2, π for angles, the declared states
                            for a rig with another coordinate)
    ``floquet``             ``about``, ``tol``; about an equilibrium ``guard_tol``,
                            ``taylor_order``; about a state the drive moves (the periodic
                            orbit) ``periods`` (1), ``symmetry`` ("auto" or "none"),
                            ``shooting`` ("auto", "single" or "multiple"),
                            ``max_iterations``, ``max_steps``
    ``stability_map``       ``A`` (axis, m), ``omega`` (axis, rad/s) or ``frequency_hz``,
                            ``about``, ``tol``, ``coarse_tol``, ``guard_tol``,
                            ``taylor_order``
    ``window``              ``omega`` or ``frequency_hz`` (axis), ``about``, ``method``
                            ("floquet", the default, or "averaging"), ``order`` (averaging
                            only: 1 (default), or 2 for the plain pendulum), ``tol``,
                            ``A_range`` ([low, high], m), ``scan``, ``min_width`` (m),
                            ``guard_tol``, ``taylor_order``
    ``measure``             ``about``, ``periods`` (1000), ``band`` (below),
                            ``observables`` ("all" (default), "classification", or a list
                            of "amplitude", "omega_slow"), ``rtol``, ``atol``, ``method``,
                            ``t0`` (s), ``max_steps``
    ``simulate``            ``periods`` (100) or ``duration`` (s), ``samples`` (1001),
                            ``method``, ``rtol``, ``atol``, ``max_steps``, ``h`` (s, a
                            fixed-step method's step), ``error_check`` (false)
    ``verify``              ``A``, ``omega`` or ``frequency_hz`` (axes), ``about``,
                            ``periods``, ``offset``, ``band``, ``tol``, ``rtol``,
                            ``fit_order`` (false), ``method``, ``length`` (m), ``omega0``
                            (rad/s)
    ``continuation``        ``parameter`` ("A" (default), "omega", "frequency_hz" or any
                            parameter), ``stop`` (required), ``start`` (default: the
                            scene's value), ``periods`` (1), ``about``, ``switch``
                            (false), ``max_points`` (500), ``tol``, ``step``,
                            ``max_step``
    ``bifurcation_diagram`` ``parameter`` (as for continuation), ``values`` (axis,
                            required), ``starts`` (list of starting coordinates, at rest;
                            default the scene's initial state), ``about`` (optional: the
                            state the diagram is about, kept in its result), ``periods``
                            (200 strobe samples kept), ``transient`` (500 periods),
                            ``t0``, ``method``, ``rtol``, ``atol``, ``max_steps``
    ``lyapunov``            ``periods`` (1000, ≥ 8), ``transient`` (100), ``exponents``
                            ("all" (default), "largest" or how many), ``every``,
                            ``blocks``, ``t0``, ``tangent`` ("jacobian" or
                            "difference"), ``rtol``, ``atol``, ``max_steps``
    ======================  =========================================================

    Every keyword argument of the function an analysis calls has a key (the defaults and
    ranges are the function's: :func:`kapitza.floquet_point`, :func:`kapitza.window`,
    :func:`kapitza.measure`, ...), named as the function names it but ``taylor_order``
    (the Floquet functions' ``order``: ``order`` is averaging's), ``fit_order`` (verify's
    ``line``) and ``samples`` (simulate's ``t_eval``); :data:`API_ONLY` lists the few a
    scene sets otherwise, and why.  A key of the general functions given for the plain
    pendulum (``guesses``, ``guard_tol``, ``taylor_order``, ``coarse_tol``, ``A_range``,
    ``scan``, ``min_width``; verify's ``offset``, ``band``, ``length``, ``omega0``) runs
    the general function instead of the closed form, and the ``method`` column says so.

    **Bands** (``measure``, ``verify``): a trajectory is measured while every coordinate
    stays within its band about the state.  ``band`` is a number (every angle's
    half-width, rad) or a table per coordinate in its unit (``band = { r = 0.2, theta =
    1.0 }``); a coordinate not given keeps its default: π/2 for an angle, half its value
    at the state for a length (:data:`kapitza.scenes._rigs.LENGTH_BAND_FRACTION`), none
    (unbounded) for a pure number or a length at 0.

    **Floquet about a state the drive moves.**  A drive along the vertical keeps the
    catalogue's states (every angle 0 or π), so Floquet analysis is about an equilibrium;
    a length on a vertically shaken pivot (a bob on a spring) is moved by the drive, and
    a drive off the vertical moves every state: then ``floquet`` (and ``continuation``)
    is about the periodic orbit born from the state (Newton shooting), as its ``method``
    column says.  The state tried is named in every error, with its units.

    **Each analysis names its method, and exact and averaging never stand in for each
    other silently.**  ``window`` is the exact window (Floquet: the Mathieu
    characteristic values for the plain pendulum, :func:`kapitza.window`'s certified
    monodromy edges for any other system) for every system where Floquet applies; the
    averaging window is asked for by name, ``window = { method = "averaging" }``.  Every
    table a scene writes carries a ``method`` column, "<family>: <detail>", the family
    one of "averaging", "floquet", "simulation", "comparison" (``verify``),
    "continuation" or "lyapunov" (e.g. "floquet: Mathieu characteristic values",
    "averaging: order 1, closed form").

    The frontier (:mod:`kapitza.continuation`, :mod:`kapitza.chaos`):

    * ``continuation`` follows the branch of (``periods`` T-)periodic orbits through
      ``about`` (an equilibrium that persists under the drive, or for a drive that leaves
      none the periodic orbit found from it) in ``parameter`` from ``start`` to ``stop``
      (:func:`kapitza.continuation`), its bifurcations located and classified; with
      ``switch = true`` also the branches born at them (period doublings, pitchforks,
      transcritical points).  Tables: ``continuation`` (one row per point, column
      ``branch``) and ``continuation_bifurcations``.
    * ``bifurcation_diagram``: strobe samples after ``transient`` drive periods over the
      parameter's ``values`` × the ``starts`` (:func:`kapitza.chaos.bifurcation_diagram`).
    * ``lyapunov``: the Lyapunov exponents of the trajectory from ``[initial]`` at the
      scene's parameters, with their error (:func:`kapitza.chaos.lyapunov`).

    A ``parameter`` given as "frequency_hz" is read as "omega", its values in rad/s.

``[sweep]``
    ``[sweep.axes]``: parameters to sweep, each a range ``{start, stop, num, scale =
    "linear" | "log"}`` or a list of values; several axes form their Cartesian product
    (the first axis slowest).  An axis is named by a parameter (``A``, ``omega``,
    ``gamma``, ``l``, …), ``frequency_hz``, an initial value ``initial.theta``, or the
    scene key that sets it (``effects.drive.amplitude``).  ``analyses``: which of the
    analyses run at every point (default: every one that can); ``tile_points``: points
    per tile (default: calibrated, :func:`kapitza.scenes._sweep.run_sweep`).
``[output]``
    ``directory`` (relative to the scene file) and ``formats`` (["parquet"], or
    ["parquet", "csv"]).

Units
-----
SI throughout, but a frequency may be given in Hz (``frequency_hz``) wherever ``omega``
(rad/s) may.  It is converted to rad/s once, as the file is read: the checked scene
(:class:`~kapitza.scenes._file.SceneSpec`) has the parameter ``omega``, ``omega`` axes of
its analyses and an ``omega`` axis of its sweep (so a sweep over ``frequency_hz`` has the
column ``omega``, in rad/s) — nothing further in sees Hz.
"""
from __future__ import annotations

import math

from lagrange_core import effects as fx

__all__ = ["SCHEMA", "ANALYSES", "API_ONLY", "WINDOW_METHODS", "FRONTIER", "SWEEPABLE",
           "NEED_DRIVE", "ABOUT_EQUILIBRIUM", "TOP", "EFFECTS", "DRIVE", "AXIS", "ABOUT", "UNITS",
           "KEY_TARGETS", "OWNERS", "CATALOGUE", "ONE_NUMBER_EFFECTS", "hz_to_rad_s"]

#: The schema version this module describes.
SCHEMA = 1

#: Analyses a scene may ask for, and their settings (name → allowed keys).
ANALYSES = {
    "averaging": ("order", "guesses"),
    "floquet": ("about", "tol", "guard_tol", "taylor_order", "periods", "symmetry",
                "shooting", "max_iterations", "max_steps"),
    "stability_map": ("A", "omega", "frequency_hz", "about", "tol", "coarse_tol", "guard_tol",
                      "taylor_order"),
    "window": ("omega", "frequency_hz", "about", "method", "order", "tol", "A_range", "scan",
               "min_width", "guard_tol", "taylor_order"),
    "measure": ("about", "periods", "band", "observables", "rtol", "atol", "method", "t0",
                "max_steps"),
    "simulate": ("periods", "duration", "samples", "method", "rtol", "atol", "max_steps", "h",
                 "error_check"),
    "verify": ("A", "omega", "frequency_hz", "about", "periods", "offset", "band", "tol",
               "rtol", "fit_order", "method", "length", "omega0"),
    "continuation": ("parameter", "start", "stop", "periods", "about", "switch",
                     "max_points", "tol", "step", "max_step"),
    "bifurcation_diagram": ("parameter", "values", "starts", "about", "periods", "transient",
                            "t0", "method", "rtol", "atol", "max_steps"),
    "lyapunov": ("periods", "transient", "exponents", "every", "blocks", "t0", "tangent",
                 "rtol", "atol", "max_steps"),
}
#: The API's keyword arguments a scene sets otherwise, or not at all, and why
#: (tests/test_scene_rigs.py holds every analysis's keys to its functions' arguments; a
#: scene key named differently: ``taylor_order`` is the Floquet functions' ``order``,
#: ``fit_order`` verify's ``line``, ``samples`` simulate's ``t_eval``).
API_ONLY = {
    "frequency": "the scene's drive frequency is always the parameter omega",
    "amplitude": "the scene's drive amplitude is always the parameter A",
    "progress": "Scene.run(progress=...) and the command line decide it",
    "q0": "[initial]",
    "qdot0": "[initial]",
    "warn": "averaging's validity is flagged on its result",
    "angles": "the rig's units (its coordinates in rad are the angles)",
    "certify": "a sweep's Floquet tiles are plain grids (certifying needs the whole map)",
    "winding": "a rotating orbit starts from a full state [q, q̇]; a scene's about is at rest",
}
#: The ways a window is computed (``window = { method = ... }``): exact first.
WINDOW_METHODS = ("floquet", "averaging")
#: Analyses of the frontier: branches, the route to chaos (each needs a drive).
FRONTIER = ("continuation", "bifurcation_diagram", "lyapunov")
#: Analyses that run at every point of a sweep (the others are grids of their own).
SWEEPABLE = ("averaging", "floquet", "measure", "simulate")
#: Analyses about an equilibrium or its drive: they need [effects.drive]; those of
#: ``ABOUT_EQUILIBRIUM`` also need a drive that keeps θ = 0, π.
NEED_DRIVE = ("averaging", "floquet", "stability_map", "window", "verify", "continuation",
              "bifurcation_diagram", "lyapunov")
ABOUT_EQUILIBRIUM = ("stability_map", "window", "verify")

#: The top-level keys and tables.
TOP = ("schema", "title", "system", "parameters", "effects", "initial", "analyses", "sweep",
       "output")
#: The tables of [effects].
EFFECTS = ("gravity", "drive", "damping", "air_drag", "spring")
#: The keys of [effects.drive].
DRIVE = ("direction", "amplitude", "amplitude_y", "frequency_hz", "omega", "harmonics")
#: The keys of a range axis.
AXIS = ("start", "stop", "num", "scale")
#: The named states an analysis may be ``about``.
ABOUT = ("inverted", "hanging", "auto")
#: Units of the quantities a message names.
UNITS = {"g": "m/s²", "A": "m", "B": "m", "omega": "rad/s", "gamma": "1/s", "c_drag": "kg/m",
         "frequency_hz": "Hz"}
#: Scene keys that set a parameter (for sweep axes named by the key that sets them).
KEY_TARGETS = {"effects.drive.amplitude": "A", "effects.drive.amplitude_y": "B",
               "effects.drive.omega": "omega", "effects.drive.frequency_hz": "frequency_hz",
               "effects.damping.gamma": "gamma", "effects.air_drag.c": "c_drag"}
#: The parameters an effect sets: parameter → (effect, the key that sets it).
OWNERS = {"g": ("gravity", "[effects] gravity = true"),
          "A": ("drive", "effects.drive.amplitude"),
          "B": ("drive", "effects.drive.amplitude_y"),
          "omega": ("drive", "effects.drive.frequency_hz or effects.drive.omega"),
          "gamma": ("damping", "effects.damping.gamma"),
          "c_drag": ("air_drag", "effects.air_drag.c")}
#: The rigs ``system.name`` may name (besides "package.module:function").
CATALOGUE = tuple(fx.RIGS) + ("chain",)
#: Effects set by one number ≥ 0: table → (effect, key, parameter, unit, what it is).
ONE_NUMBER_EFFECTS = {
    "damping": (fx.Damping, "gamma", "gamma", "1/s",
                "the damping rate γ (1/s), ≥ 0 (leave the table out for no damping)"),
    "air_drag": (fx.AirDrag, "c", "c_drag", "kg/m", "c = ½ ρ C_d S (kg/m), ≥ 0"),
}


def hz_to_rad_s(f: float) -> float:
    """A frequency in Hz as an angular frequency in rad/s: 2π f (exact to rounding)."""
    return 2 * math.pi * f
