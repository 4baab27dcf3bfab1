"""Figures: matplotlib ``Figure``s that draw results and overlays; they compute no physics.
"""
from ._plots import (_figure, effective_potential_figure, ince_strutt_figure, legend_below,
                     slow_frequency_figure, slow_frequency_line_figure, spot_check_figure,
                     stability_map_figure, tilt_figure, verification_figure,
                     window_error_figure, work_precision_figure)

__all__ = ["stability_map_figure", "effective_potential_figure", "ince_strutt_figure",
           "verification_figure", "work_precision_figure", "spot_check_figure",
           "slow_frequency_figure", "slow_frequency_line_figure", "tilt_figure",
           "window_error_figure", "legend_below"]
