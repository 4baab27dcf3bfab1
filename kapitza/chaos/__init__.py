"""The route to chaos, measured: Lyapunov exponents, bifurcation diagrams, sections, basins.

Functions on any driven system (``lagrange_core.System``; the drive's angular frequency is
the parameter named by ``frequency``, T = 2π/ω):

``lyapunov(system, params, q0, qdot0=0.0, *, periods, transient, exponents, ...)``
    One trajectory's Lyapunov exponents (all, the largest, or the k largest) with their
    error, by Benettin's method on the variational equations (compiled).
``lyapunov_grid(system, params, q0, qdot0=0.0, *, periods, transient, ...)``
    The largest exponent over a broadcast grid (a chaos map over (A, ω)), compiled and
    parallel; for systems of up to six coordinates on *lanes* (64 points per thread,
    vectorised, J v exact by forward mode).
``bifurcation_diagram(system, params, about=None, *, parameter, values, q0, ...)``
    Strobe samples after a transient over a parameter's values × starts.
``poincare_section(system, params, q0, qdot0=0.0, *, periods, ...)``
    The stroboscopic section of trajectories.
``basin(system, params, about, *, q0, qdot0, periods, band, ...)``
    Which starts stay near a state for the whole run.

Results (:mod:`kapitza.results`): ``LyapunovSpectrum``, ``LyapunovGrid``,
``BifurcationDiagram``, ``PoincareSection``, ``Basin``; their ``figure()`` draws with the
functions of :mod:`kapitza.figures` (``lyapunov_map_figure``,
``bifurcation_figure``, ``section_figure``, ``basin_figure``, exported here too).
"""
from ..figures import basin_figure as basin_figure
from ..figures import bifurcation_figure as bifurcation_figure
from ..figures import lyapunov_map_figure as lyapunov_map_figure
from ..figures import section_figure as section_figure
from ._lyapunov import lyapunov, lyapunov_grid
from ._sections import basin, bifurcation_diagram, poincare_section

__all__ = ["lyapunov", "lyapunov_grid", "bifurcation_diagram", "poincare_section", "basin",
           "lyapunov_map_figure", "bifurcation_figure", "section_figure", "basin_figure"]
