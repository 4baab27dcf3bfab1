"""Stability over the drive's plane: maps, windows, boundary curves, the Ince–Strutt chart.

:class:`StabilityMap` (labels over an (A, ω) grid) and :class:`AdaptiveMap` (one refined
where the labels change), :class:`StabilityWindow` (the amplitudes that hold a state, per
ω, exact or by averaging), :class:`BoundaryCurves` (the exact boundaries A_k(ω)) and
:class:`InceStruttChart` (the Mathieu equation's chart in the (q, a) plane).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike

from ._base import BOUNDARIES, boundary_names

__all__ = ["StabilityMap", "StabilityWindow", "InceStruttChart",
           "BoundaryCurves", "AdaptiveMap"]


@dataclass(frozen=True)
class StabilityMap:
    """Stability of a driven equilibrium over an (A, ω) grid.

    Built by :func:`kapitza.pendulum_stability_map` (the single pendulum;
    :meth:`kapitza.KapitzaPendulum.stability_map`) and by :func:`kapitza.stability_map`
    (any system); drawn by :func:`kapitza.figures.stability_map_figure`.

    Attributes
    ----------
    A, omega : ndarray
        Grid axes: drive amplitude (m) and angular frequency (rad/s).
    stable : bool ndarray (len(A), len(omega))
    label : int8 ndarray (len(A), len(omega))
        Index into :data:`BOUNDARIES`: 0 stable; 1 unstable in a region bounded by
        period-T solutions (multiplier +1); 2 bounded by period-2T solutions
        (multiplier −1); 3 complex multipliers (combination resonance).
    trace : ndarray or None
        tr M per point (None when computed from characteristic values only).
    log_growth : ndarray or None
        max log|λ| per period (None as above).
    error_estimate : float
        Largest error estimate over the grid: of M (relative) for integration,
        of the boundaries (relative, in a) for characteristic values.
    about : str
        The equilibrium: "inverted" or "hanging" for the pendulum, the coordinates
        for any other system.
    method : str
        "characteristic values", "monodromy (Mathieu, damping removed)" or "monodromy".
    l, g, damping : float or None
        The pendulum's length (m), gravity (m/s²) and damping rate γ (1/s); None for
        a map of another system (its constants are in ``params``).
    params : dict
        The fixed parameters of a general system's map (empty for the pendulum).
    seconds : float
        Wall time of the computation (s).
    refined_points, uncertified_points, flagged_points : int
        Monodromy maps: points integrated again to the fine tolerance, points whose
        stability test lies within 10× its error estimate of the threshold, points
        whose accuracy guards failed or that could not be integrated (for the
        Mathieu trace: an RK4 overflow at extreme drives; 0 for characteristic values).
    flags_example : tuple of str
        The flags of the first flagged point (empty if none).
    max_steps_per_period, samples : int
        Monodromy maps: the most Taylor steps per period over the grid, and the
        samples of J per period (0 for the other methods).
    """

    A: np.ndarray
    omega: np.ndarray
    stable: np.ndarray
    label: np.ndarray
    trace: np.ndarray | None
    log_growth: np.ndarray | None
    error_estimate: float
    about: str
    method: str
    l: float | None = None
    g: float | None = None
    damping: float | None = None
    params: dict = field(default_factory=dict)
    seconds: float = math.nan
    refined_points: int = 0
    uncertified_points: int = 0
    flagged_points: int = 0
    flags_example: tuple = ()
    max_steps_per_period: int = 0
    samples: int = 0

    @property
    def boundary(self) -> np.ndarray:
        """Label names per point: "stable", "T", "2T" or "complex"."""
        return boundary_names(self.label)

    def to_dataframe(self):
        """Long format: one row per grid point (A, omega, stable, boundary, trace, log_growth)."""
        import pandas as pd
        AA, WW = np.meshgrid(self.A, self.omega, indexing="ij")
        data = {"A": AA.ravel(), "omega": WW.ravel(), "stable": self.stable.ravel(),
                "boundary": self.boundary.ravel()}
        if self.trace is not None:
            data["trace"] = self.trace.ravel()
        if self.log_growth is not None:
            data["log_growth"] = self.log_growth.ravel()
        return pd.DataFrame(data)


_WINDOW_METHODS = ("floquet", "averaging")


@dataclass(frozen=True)
class StabilityWindow:
    """Drive amplitudes A_min < A < A_max that stabilise the vertically driven pendulum, per ω.

    One type for the exact window (``method="floquet"``) and the averaging prediction
    (``method="averaging"``), both from :func:`kapitza.pendulum_window` and
    :meth:`kapitza.KapitzaPendulum.window`.  Any system's exact window is
    :func:`kapitza.window`; the averaging window of any system's equilibrium (order 1,
    ``l`` and ``g`` None, ``about`` its coordinates as text) is
    :meth:`kapitza.AveragedSystem.window`.

    Attributes
    ----------
    omega : float or ndarray
        Drive angular frequencies (rad/s).
    A_min, A_max : float or ndarray
        Window edges (m).  Exact: NaN where there is no window (e.g. ω too low to
        hold the pendulum upright); with ``status`` (:func:`kapitza.window`), NaN
        only where it is "none", and where it is "undecided" an envelope: the lowest
        window, if any, lies within [A_min, A_max] (accuracy NaN).  Averaging, order 1:
        A_min = √(2 g l)/ω and A_max = +inf (first order cannot see the upper limit);
        order 2: the next order, relative error O(ε⁴), with A_max from the parametric resonance
        a′ = b₁(2A/l) (→ 0.4540 l as ω → ∞); NaN where the edges cross (see
        ``exists``), and see ``valid`` before trusting an edge.
    method : {"floquet", "averaging"}
    about : str
        "inverted" (θ = π) or "hanging" (θ = 0; exact windows only, A_min = 0); for a
        general system the equilibrium's coordinates, e.g. "[3.14159..., 3.14159...]".
    order : int or None
        Averaging order (1 or 2); None for exact windows.
    accuracy : ndarray or None
        Exact windows: certified relative accuracy of the edges (the Floquet
        condition changes sign across A·(1 ± accuracy)); None for averaging.
    tol : float or None
        Exact windows: the requested relative accuracy; None for averaging.
    l, g, damping : float or None
        Length (m), gravity (m/s²), damping rate γ (1/s) of the pendulum.
    exists : bool or ndarray or None
        Averaging: the prediction has a window, A_min < A_max (False: both edges
        NaN); None for exact windows.
    frequency_ratio : float or ndarray or None
        Averaging: ω / max(ω0, γ) (at the lower edge the slow frequency is 0).
    error_estimate : float or ndarray or None
        Averaging: |A_min(order 1) − A_min(order 2)| / A_min(order 2), the size of
        the next-order correction to the lower edge (it estimates the error of
        order 1; that of order 2 is much smaller).
    fast_drive, small_amplitude, converged, valid : bool or ndarray or None
        Averaging, as for :class:`EquilibriumPrediction`: ``frequency_ratio ≥
        MIN_FREQUENCY_RATIO``, ``A_min/l ≤ MAX_AMPLITUDE_RATIO``, ``error_estimate ≤
        MAX_CORRECTION``, and all three with ``exists``.  None for exact windows.
    status : str or ndarray of str or None
        :func:`kapitza.window` (any system): per ω "window" (found, edges certified),
        "none" (proved: no stable interval at least ``min_width`` wide in the amplitudes
        scanned) or "undecided" (a stable sliver narrower than ``min_width`` could not be
        ruled out, or an edge failed its check; warned).  None elsewhere.
    min_width : float or ndarray or None
        :func:`kapitza.window`: the resolution (m) to which ``status`` holds, per ω.
    """

    omega: ArrayLike
    A_min: ArrayLike
    A_max: ArrayLike
    method: str
    about: str = "inverted"
    order: int | None = None
    accuracy: np.ndarray | None = None
    tol: float | None = None
    l: float | None = None
    g: float | None = None
    damping: float | None = None
    exists: ArrayLike | None = None
    frequency_ratio: ArrayLike | None = None
    error_estimate: ArrayLike | None = None
    fast_drive: ArrayLike | None = None
    small_amplitude: ArrayLike | None = None
    converged: ArrayLike | None = None
    valid: ArrayLike | None = None
    status: str | np.ndarray | None = None
    min_width: ArrayLike | None = None

    def __post_init__(self):
        if self.method not in _WINDOW_METHODS:
            raise ValueError(f"StabilityWindow: method must be one of {_WINDOW_METHODS}, got "
                             f"{self.method!r}.")

    def to_dataframe(self):
        """One row per ω: omega, A_min, A_max, then accuracy (exact) or order (averaging)."""
        import pandas as pd
        w, lo, hi = (np.ravel(x) for x in np.broadcast_arrays(self.omega, self.A_min, self.A_max))
        data: dict[str, object] = {"omega": w, "A_min": lo, "A_max": hi}
        if self.accuracy is not None:
            data["accuracy"] = np.ravel(self.accuracy)
        if self.status is not None:
            data["status"] = np.ravel(self.status)
        if self.order is not None:
            data["order"] = self.order
        return pd.DataFrame(data)




@dataclass(frozen=True)
class InceStruttChart:
    """The stability chart of the undamped Mathieu equation y″ + (a − 2q cos 2τ) y = 0.

    Built by :func:`kapitza.ince_strutt_chart`; drawn by
    :func:`kapitza.figures.ince_strutt_figure`.

    Attributes
    ----------
    q, a : ndarray
        Grid axes.
    stable : bool ndarray (len(q), len(a))
        Stability at every grid point (from characteristic values, exact to rounding).
    curves : dict of str to ndarray (len(q),)
        The characteristic curves "a0", "b1", "a1", ... on the q axis (the
        boundaries: stable between a_r and b_(r+1)).
    """

    q: np.ndarray
    a: np.ndarray
    stable: np.ndarray
    curves: dict

    def to_dataframe(self):
        """One row per q: q and every characteristic curve."""
        import pandas as pd
        return pd.DataFrame({"q": self.q, **self.curves})


@dataclass(frozen=True)
class BoundaryCurves:
    """The stability boundaries A_k(ω) of a driven equilibrium over a frequency grid.

    Built by :func:`kapitza.boundaries` (continuation in ω of the roots of smooth
    margins, see :mod:`kapitza.floquet`); drawn over a map by
    :func:`kapitza.figures.stability_map_figure` (``overlays=[curves]``).

    Attributes
    ----------
    omega : ndarray (m,)
        Drive angular frequencies (rad/s).
    A : ndarray (k, m)
        Curve k's amplitude at each ω; NaN where it does not bound the stable region
        there (it does not exist, or both of its sides are unstable).
    accuracy : ndarray (k, m)
        Certified relative accuracy of each point (the curve's margin changes sign
        across A·(1 ± accuracy)).
    kind : tuple of str
        Per curve: "T" (a multiplier reaches +1), "2T" (−1) or "complex" (a complex
        pair leaves the unit circle), as in :data:`BOUNDARIES`.
    stable_below : bool ndarray (k,)
        Whether the stable side of curve k is below it (smaller A).
    about : str
        The equilibrium's coordinates.
    params : dict
        The fixed parameters.
    A_range : tuple of float
        The amplitudes searched (m).
    tol : float
        The requested relative accuracy.
    seconds : float
        Wall time (s).
    monodromies : int
        Monodromies computed (seeding scans, continuation and the side checks).
    """

    omega: np.ndarray
    A: np.ndarray
    accuracy: np.ndarray
    kind: tuple
    stable_below: np.ndarray
    about: str
    params: dict = field(default_factory=dict)
    A_range: tuple = (math.nan, math.nan)
    tol: float = math.nan
    seconds: float = math.nan
    monodromies: int = 0

    def __post_init__(self):
        bad = [k for k in self.kind if k not in BOUNDARIES[1:]]
        if bad:
            raise ValueError(f"BoundaryCurves: kinds must be among {BOUNDARIES[1:]}, got {bad}.")

    def to_dataframe(self):
        """Long format: one row per curve point (curve, kind, stable_side, omega, A,
        accuracy); points where a curve is not a boundary are left out."""
        import pandas as pd
        k, i = np.nonzero(np.isfinite(self.A))
        return pd.DataFrame({
            "curve": k, "kind": np.asarray(self.kind, dtype=object)[k] if k.size else [],
            "stable_side": np.where(np.asarray(self.stable_below)[k], "below", "above"),
            "omega": np.asarray(self.omega)[i], "A": self.A[k, i],
            "accuracy": self.accuracy[k, i]})


@dataclass(frozen=True)
class AdaptiveMap(StabilityMap):
    """A stability map computed only where the classification changes.

    Built by :func:`kapitza.adaptive_map`; a :class:`StabilityMap` on the full
    grid (labels of cells that were not refined are their corners' label), plus:

    Attributes
    ----------
    margin : ndarray (len(A), len(omega))
        A continuous stability margin (> 0 stable, < 0 unstable; see
        :func:`kapitza.adaptive_map`), computed at the refined points
        and interpolated bilinearly inside the cells that were not: its zero contour is
        the boundary, smooth at the grid's full resolution.
    computed : bool ndarray (len(A), len(omega))
        The points whose monodromy was computed.
    monodromies : int
        Their number (a uniform map computes len(A) × len(omega)).
    levels : int
        Refinement levels after the coarse grid.
    coarse_step : int
        The coarse grid's step in grid points.
    """

    margin: np.ndarray | None = None
    computed: np.ndarray | None = None
    monodromies: int = 0
    levels: int = 0
    coarse_step: int = 0

    def to_dataframe(self):
        """As :meth:`StabilityMap.to_dataframe`, with the margin and the computed flag."""
        df = super().to_dataframe()
        for name in ("margin", "computed"):
            value = getattr(self, name)
            if value is not None:
                df[name] = np.ravel(value)
        return df
