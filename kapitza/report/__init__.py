"""``kapitza report``: one self-contained folder that shows what the toolkit computes.

:func:`build_report` runs a scene (by default the embedded ``scenes/report.toml``: a
1 m pendulum shaken vertically) through every analysis and writes

``DIR/index.html``
    One page, no JavaScript, no external resource (inline CSS, relative links): a
    header saying what was computed (scene, parameters, versions, date, wall time per
    section), one section per analysis with its figure and a caption stating the
    finding in numbers, and a table of the data files.
``DIR/figures/*.png`` (and the animation ``*.gif``)
``DIR/data/*.parquet`` and ``*.csv``
    Every table shown or drawn, in both formats.

The sections, in order (each says on the page why it is skipped where it does not apply):

``potential``
    The effective potential U_eff(θ)/m at the scene's drive (the pendulum's closed form,
    first-order averaging) with its equilibria, and the upright state's slow frequency
    by averaging and by Floquet analysis.
``map``
    The exact stability map over (A, ω) with the exact boundaries and the averaging
    prediction drawn over it: the pendulum's Mathieu map and exact window
    (:meth:`KapitzaPendulum.stability_map`, :meth:`KapitzaPendulum.window`); any other
    system's monodromy map and boundary curves (:func:`kapitza.floquet.stability_map`,
    :func:`kapitza.floquet.boundaries`) with its averaging window.
``spots``
    Direct simulations at a handful of (A, ω) points marked on the map: stayed up or
    fell, and whether that agrees with Floquet analysis (:meth:`KapitzaPendulum.measure_grid`,
    :func:`kapitza.measure_grid`).
``slow``
    The slow frequency Ω along A at the scene's ω: averaging (first and, for the
    pendulum, next order), Floquet and the measured Ω (a verification along a line).
``verification``
    :meth:`KapitzaPendulum.verify` / :func:`kapitza.verify` over a small (A, ω) grid:
    agreement counts, every disagreement with its distance to the nearest boundary, the
    measured order of averaging.
``bifurcations``
    Only when the scene asks for ``continuation``, ``bifurcation_diagram`` or ``lyapunov``
    (skipped, saying so, otherwise): the branches of periodic orbits with their
    bifurcations located (:func:`kapitza.continuation`), the stroboscopic bifurcation
    diagram with those bifurcations marked (:func:`kapitza.chaos.bifurcation_diagram`),
    the Lyapunov exponents at the scene's drive (:func:`kapitza.chaos.lyapunov`) and, with
    a diagram, the largest one along its parameter (:func:`kapitza.chaos.lyapunov_grid`).
``work_precision``
    What accuracy costs in time (:func:`lagrange_core.accuracy_cost.work_precision`).
``animation``
    A GIF of the stabilised inverted pendulum beside one that falls
    (:func:`kapitza.animation.pendulum_animation`); for another planar chain, the
    scene's own system under its drive (:func:`kapitza.animation.system_animation`).

Progress goes to stderr, one line per section with its elapsed time.  Ctrl-C stops the
running section (within a compiled chunk, ≈ 0.25 s), writes the page with the finished
sections and names the missing ones, and raises :class:`ReportInterrupted` (the CLI
exits with 130).  A section that fails is shown on the page with its error and the
others still run (:attr:`Report.failed`).

Time (2 shared cores, measured 2026-11-23): the full default report takes 93 s on a cold
cache, compilation included (124 s under a load average of 4), and 22 s once compiled,
most of it writing the GIF; ``quick=True`` ≈ 15 s compiled.
"""
from ._build import Report, ReportInterrupted, ReportSection, build_report
from ._sections import SECTIONS

__all__ = ["build_report", "Report", "ReportSection", "ReportInterrupted", "SECTIONS"]
