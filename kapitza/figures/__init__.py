"""Figures: matplotlib ``Figure`` objects that draw results and overlays; they compute no physics.

Each function draws the results it is given (the value types of :mod:`kapitza.results`,
read by their fields: this room never imports them) and returns a
:class:`matplotlib.figure.Figure` on the Agg canvas (no pyplot state, nothing shown); save
it with ``fig.savefig(path)``.

Modules: ``_maps`` (parameter planes: stability maps with windows and boundary curves,
spot checks, the Ince–Strutt chart), ``_lines`` (curves against one variable: the
effective potential, the window's error, slow frequencies and the tilt against A,
work against precision), ``_branches`` (a continued branch and its bifurcations), ``_chaos`` (the
Lyapunov map, the bifurcation diagram's dots, a Poincaré section, a basin),
``_verification`` (a verification's map and its slow
frequencies), ``_windows`` (a window's edges and boundary curves against ω), ``_grids``
(one quantity of a gridded result over its axes: measurement grids, sweeps), ``_common``
(the canvas, the check of what a figure is given, labels).
"""
from ._branches import branch_figure
from ._chaos import basin_figure, bifurcation_figure, lyapunov_map_figure, section_figure
from ._common import agg_canvas as agg_canvas
from ._common import fit_texts as fit_texts
from ._common import fit_title as fit_title
from ._common import legend_below
from ._common import save_png as save_png
from ._grids import grid_figure
from ._lines import (
    effective_potential_figure,
    slow_frequency_line_figure,
    tilt_figure,
    window_error_figure,
    work_precision_figure,
)
from ._maps import ince_strutt_figure, spot_check_figure, stability_map_figure
from ._verification import slow_frequency_figure, verification_figure
from ._windows import boundaries_figure, window_figure

__all__ = ["stability_map_figure", "effective_potential_figure", "ince_strutt_figure",
           "verification_figure", "work_precision_figure", "spot_check_figure",
           "slow_frequency_figure", "slow_frequency_line_figure", "tilt_figure",
           "window_error_figure", "legend_below", "branch_figure", "lyapunov_map_figure",
           "bifurcation_figure", "section_figure", "basin_figure", "window_figure",
           "boundaries_figure", "grid_figure"]
