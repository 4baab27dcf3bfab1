"""Floquet analysis of any driven system: the monodromy by a Taylor method on the exact
Jacobian, per point and over grids; stability maps; exact windows and boundary curves.
"""
from ._analysis import (adaptive_map, boundaries, floquet_grid, floquet_point, monodromy_data,
                        stability_map, window)

__all__ = ["floquet_point", "floquet_grid", "monodromy_data", "stability_map", "window",
           "boundaries", "adaptive_map"]
