"""Floquet analysis of any driven system: the monodromy by a Taylor method on the exact
Jacobian, per point and over grids; stability maps, exact windows and boundary curves,
about an equilibrium or a periodic orbit.

The linear time-periodic system
-------------------------------
Let y* = [q*, 0] be a state that persists under the drive (q̈ = 0 with q̇ = 0 at all t,
e.g. the inverted pendulum θ = π).  Small deviations obey

    x′ = J(t) x,    J(t) = ∂(dy/dt)/∂y at (t, y*),    J(t + T) = J(t),

with J from the system's exact compiled ``jacobian`` kernel (no finite differences) and
T = 2π/ω the drive period.  The monodromy M = X(T) (X′ = J X, X(0) = I, 2n × 2n) decides
stability: the equilibrium is (linearly, asymptotically) stable when every multiplier λ
(eigenvalue of M) has |λ| < 1, and, for an undamped system, when all lie on the unit
circle.  J is sampled over one period and expanded in a trigonometric series, and M is
integrated by a Taylor series method of order 16 whose steps meet the tolerance, with the
error estimate reported (:mod:`kapitza.floquet._monodromy`, :mod:`kapitza.floquet._kernels`);
Liouville's formula and the pairing λ, 1/λ of undamped systems guard every result
(:mod:`kapitza.floquet._multipliers`).

Entry points and results
------------------------
All take ``(system, params, about, *, ...)`` (docs/api-conventions.md), the grid's axes as
keywords named by the parameter they vary:

:func:`floquet_point`
    One parameter set → :class:`~kapitza.results.FloquetResult`.
:func:`floquet_grid`
    A broadcast grid of parameter sets → :class:`~kapitza.results.FloquetGrid`.
:func:`monodromy_data`
    The matrices only → :class:`~kapitza.results.MonodromyData`.
:func:`stability_map`
    An (A, ω) grid, ``A=``, ``omega=`` → :class:`~kapitza.results.StabilityMap`.
:func:`adaptive_map`
    The same map, refined only where the classification changes →
    :class:`~kapitza.results.AdaptiveMap`.
:func:`window`
    The stabilising amplitudes per ω, ``omega=``, certified edges, every window at
    least ``min_width`` wide found (``status`` "window", "none" or "undecided", never a
    silent miss) → :class:`~kapitza.results.StabilityWindow`.
:func:`boundaries`
    The curves A_k(ω) by continuation, ``omega=``, ``A_range=`` →
    :class:`~kapitza.results.BoundaryCurves`.

For the simulation room (not in ``__all__``): the Newton shooting of periodic orbits,
``shoot``, ``Shot``, ``symmetry_defect``, ``flow_or_none``, ``SYMMETRY_RTOL``,
``MAX_HALVINGS`` (:mod:`kapitza.floquet._shooting`), the engine of
:func:`kapitza.periodic_orbit` and of the maps about orbits.

About a periodic orbit
----------------------
Most driven states do not persist: the horizontal and elliptic pivots' hanging and tilted
states, any drive with two phases.  Where ``about`` does not persist under the drive,
:func:`stability_map`, :func:`adaptive_map`, :func:`window` and :func:`boundaries` are about
the T-periodic orbit it names — coordinates at rest or a state [q, q̇] (Newton's guess at
the grid's lowest amplitude, per ω), or a :class:`~kapitza.results.PeriodicOrbit` from
:func:`kapitza.periodic_orbit` (followed from where it was found) — continued from grid
point to grid point by Newton shooting (:mod:`kapitza.floquet._orbits`,
:mod:`kapitza.floquet._shooting`), symmetric orbits on the half-period map (regular at the
symmetry-breaking pitchfork); a point the orbit's branch does not reach has no orbit
(unstable, NaN, flagged), never another branch's.  :func:`floquet_point`,
:func:`floquet_grid` and :func:`monodromy_data` stay about equilibria
(:func:`kapitza.periodic_orbit` is the one orbit).

Windows, boundaries and adaptive maps find where stability changes as roots of smooth
margins such as det(M ∓ I) (:mod:`kapitza.floquet._margins`), not by bisection on the flag;
windows and boundaries look between their scan points too
(:mod:`kapitza.floquet._frontier`).
The single pendulum's maps and windows go through the Mathieu equation instead
(:mod:`kapitza.closed_forms`), which is faster and exact to rounding.

Examples
--------
The inverted pendulum (l = 1 m) shaken vertically with A = 5 cm at 60 Hz is stable:

>>> import math
>>> from lagrange_core import problems
>>> r = floquet_point(problems.driven_pendulum("vertical"),
...                   dict(m=1.0, l=1.0, g=9.81, A=0.05, omega=2 * math.pi * 60), [math.pi])
>>> r.stable, r.boundary
(True, 'stable')
"""
from ._maps import adaptive_map, stability_map
from ._point import floquet_grid, floquet_point, monodromy_data
from ._shooting import MAX_HALVINGS as MAX_HALVINGS
from ._shooting import SYMMETRY_RTOL as SYMMETRY_RTOL
from ._shooting import Shot as Shot
from ._shooting import flow_or_none as flow_or_none
from ._shooting import shoot as shoot
from ._shooting import symmetry_defect as symmetry_defect
from ._window import boundaries, window

__all__ = ["floquet_point", "floquet_grid", "monodromy_data", "stability_map", "window",
           "boundaries", "adaptive_map"]
