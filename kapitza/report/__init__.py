"""``kapitza report``: one self-contained folder that shows what the toolkit computes.

:func:`build_report` runs a scene (by default the embedded ``scenes/report.toml``: a
1 m pendulum shaken vertically) through every analysis and writes

``DIR/index.html``
    One page, no JavaScript, no external resource (inline CSS, relative links): a
    header saying what was computed (scene, parameters, versions, date, wall time per
    section), one section per analysis with its figure and a caption stating the
    finding in numbers, and a table of the data files.
``DIR/figures/*.png`` (and the animation ``*.gif``)
    The figures of the sections.
``DIR/data/*.parquet`` and ``*.csv``
    Every table shown or drawn, in both formats.

The sections, in order (each says on the page why it is skipped where it does not apply),
each about the state the scene's analyses are about (their ``about``, e.g. the upright
pendulum, the hanging one of ``period_doubling.toml``, a user's rig's declared state):

``potential``
    The effective potential U_eff at the scene's drive with its equilibria marked, at the
    averaging order the scene asks for (``averaging = { order = 2 }``: the equilibria and
    slow frequencies by the next order; U_eff itself is first order), and the state's
    slow frequency by averaging and by Floquet analysis (or its instability, named).  The
    single pendulum in closed form; any other system of one coordinate by
    :func:`kapitza.averaging.average` (with the mean drag of damping: the elliptic pivot's
    tilted state) against the periodic orbit born from it.
``map``
    The exact stability map over (A, ω) with its boundaries drawn as curves and the
    averaging prediction over them: the upright pendulum's Mathieu map and exact window
    (:meth:`KapitzaPendulum.stability_map`; the window in closed form undamped, traced by
    :func:`kapitza.floquet.boundaries` damped), the low-ω end of the window stated — the
    map's lower edge, or where the window opens, located by bisection; any other state
    (the hanging pendulum's resonance tongues, a chain, a user's rig) with its boundary
    curves from :func:`kapitza.floquet.boundaries`, traced again on a finer ω grid across
    any feature of the map one column wide (a thin tongue sampled once is drawn whole).
``spots``
    Direct simulations at a handful of (A, ω) points marked on the map: stayed near the
    state or left it, and whether that agrees with Floquet analysis
    (:meth:`KapitzaPendulum.measure_grid`, :func:`kapitza.measure_grid`, each coordinate's
    band in its unit); the linear growth over each run as its log10.
``slow``
    The slow frequency Ω along A at the scene's ω: averaging (first and, for the upright
    pendulum, next order), Floquet and the measured Ω (a verification along a line).
``verification``
    :meth:`KapitzaPendulum.verify` / :func:`kapitza.verify` over a small (A, ω) grid:
    agreement counts, every disagreement with its distance to the nearest boundary, the
    measured order of averaging.  Not for a state the drive moves (a length on a shaken
    pivot: its Floquet analysis is about the periodic orbit, in the map).
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
    (:func:`kapitza.animation.pendulum_animation`); for any other scene of a planar chain,
    the scene's own system under its drive (:func:`kapitza.animation.system_animation`).

The page shows numbers to four significant digits (the data files keep them all), each
table in a wrapper that scrolls sideways inside the page; every figure's titles are
wrapped to fit it; each section's warnings are notes on the page, none reaches the
terminal.

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
