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
    Initial coordinates by name and velocities ``<coordinate>_dot`` (default 0).
``[analyses]``
    Each ``name = true`` or a table of its settings; only those named run (how each is
    computed: :class:`kapitza.Scene`).  An *axis* is a list of values or a range
    ``{start, stop, num, scale = "linear" | "log"}``; ``about`` is "inverted",
    "hanging", "auto" (default) or a list of coordinate values.

    ======================  =========================================================
    ``averaging``           ``order`` (1, or 2 for the plain pendulum)
    ``floquet``             ``about``, ``tol``
    ``stability_map``       ``A`` (axis, m), ``omega`` (axis, rad/s) or ``frequency_hz``,
                            ``about``, ``tol``
    ``window``              ``omega`` or ``frequency_hz`` (axis), ``about``, ``method``
                            ("floquet", the default, or "averaging"), ``order`` (averaging
                            only: 1 (default), or 2 for the plain pendulum), ``tol``
    ``measure``             ``about``, ``periods`` (1000), ``band`` (π/2 rad), ``rtol``
    ``simulate``            ``periods`` (100) or ``duration`` (s), ``samples`` (1001),
                            ``method``, ``rtol``
    ``verify``              ``A``, ``omega`` or ``frequency_hz`` (axes), ``about``,
                            ``periods``, ``offset``, ``band``, ``tol``, ``rtol``,
                            ``fit_order`` (false)
    ``continuation``        ``parameter`` ("A" (default), "omega", "frequency_hz" or any
                            parameter), ``stop`` (required), ``start`` (default: the
                            scene's value), ``periods`` (1), ``about``, ``switch``
                            (false), ``max_points`` (500)
    ``bifurcation_diagram`` ``parameter`` (as for continuation), ``values`` (axis,
                            required), ``starts`` (list of starting coordinates, at rest;
                            default the scene's initial state), ``periods`` (200 strobe
                            samples kept), ``transient`` (500 periods)
    ``lyapunov``            ``periods`` (1000, ≥ 8), ``transient`` (100), ``exponents``
                            ("all" (default), "largest" or how many)
    ======================  =========================================================

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

__all__ = ["SCHEMA", "ANALYSES", "WINDOW_METHODS", "FRONTIER", "SWEEPABLE", "NEED_DRIVE",
           "ABOUT_EQUILIBRIUM", "TOP", "EFFECTS", "DRIVE", "AXIS", "ABOUT", "UNITS", "KEY_TARGETS",
           "OWNERS", "CATALOGUE", "ONE_NUMBER_EFFECTS", "hz_to_rad_s"]

#: The schema version this module describes.
SCHEMA = 1

#: Analyses a scene may ask for, and their settings (name → allowed keys).
ANALYSES = {
    "averaging": ("order",),
    "floquet": ("about", "tol"),
    "stability_map": ("A", "omega", "frequency_hz", "about", "tol"),
    "window": ("omega", "frequency_hz", "about", "method", "order", "tol"),
    "measure": ("about", "periods", "band", "rtol"),
    "simulate": ("periods", "duration", "samples", "method", "rtol"),
    "verify": ("A", "omega", "frequency_hz", "about", "periods", "offset", "band", "tol",
               "rtol", "fit_order"),
    "continuation": ("parameter", "start", "stop", "periods", "about", "switch",
                     "max_points"),
    "bifurcation_diagram": ("parameter", "values", "starts", "periods", "transient"),
    "lyapunov": ("periods", "transient", "exponents"),
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
