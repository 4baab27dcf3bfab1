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

from . import _display as display
from ._base import BOUNDARIES
from ._xarray import LabelledGrid

__all__ = ["StabilityMap", "StabilityWindow", "InceStruttChart",
           "BoundaryCurves", "AdaptiveMap"]

#: Names of a stability map's labels: :data:`BOUNDARIES` (0 stable, 1 "T", 2 "2T",
#: 3 "complex") and 4 "no orbit" (a map about a periodic orbit, where none was found).
MAP_LABELS = (*BOUNDARIES, "no orbit")


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
        Index into :data:`MAP_LABELS`: 0 stable; 1 unstable in a region bounded by
        period-T solutions (multiplier +1); 2 bounded by period-2T solutions
        (multiplier −1); 3 complex multipliers (combination resonance); 4 "no orbit":
        a map about a periodic orbit where the orbit followed does not reach the point
        (its branch ends at a fold or a branch point, or Newton found none), so
        stability is not decided there (``stable`` False, ``trace`` NaN; the reason in
        ``flags_example``).
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
        Mathieu trace: an overflow at extreme drives; 0 for characteristic values).
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
        """Label names per point: "stable", "T", "2T", "complex" or "no orbit"."""
        return np.asarray(MAP_LABELS, dtype=object)[np.asarray(self.label)]

    def to_dataframe(self):
        """Long format: one row per grid point (A, omega, stable, boundary, trace, log_growth);
        ``boundary`` is "no orbit" where no periodic orbit was found (label 4)."""
        import pandas as pd
        AA, WW = np.meshgrid(self.A, self.omega, indexing="ij")
        data = {"A": AA.ravel(), "omega": WW.ravel(), "stable": self.stable.ravel(),
                "boundary": self.boundary.ravel()}
        if self.trace is not None:
            data["trace"] = self.trace.ravel()
        if self.log_growth is not None:
            data["log_growth"] = self.log_growth.ravel()
        return pd.DataFrame(data)

    def figure(self, **options):
        """The map (A vertical, ω horizontal), stable regions shaded:
        :func:`kapitza.figures.stability_map_figure` (``options`` go to it, e.g.
        ``overlays=[window]``, ``dimensionless=True``).  Returns a
        :class:`matplotlib.figure.Figure`."""
        return display.draw("stability_map_figure", self, **options)

    def _labelled(self) -> LabelledGrid:
        grid = LabelledGrid(type(self).__name__, about=str(self.about), method=self.method,
                            error_estimate=self.error_estimate, seconds=self.seconds,
                            refined_points=self.refined_points,
                            uncertified_points=self.uncertified_points,
                            flagged_points=self.flagged_points,
                            flags_example=list(self.flags_example),
                            max_steps_per_period=self.max_steps_per_period,
                            samples=self.samples)
        grid.coord("A", "A", self.A, "m", "drive amplitude A")
        grid.coord("omega", "omega", self.omega, "rad/s", "drive angular frequency ω")
        fixed = {k: v for k, v in (("l", self.l), ("g", self.g), ("damping", self.damping))
                 if v is not None}
        grid.parameters({**self.params, **fixed})
        length, omega0 = grid.pendulum_scales({**self.params, **fixed})
        grid.drive_axes(length, omega0)
        dims = ("A", "omega")
        grid.variable("stable", dims, np.asarray(self.stable, bool), None, "linearly stable")
        grid.label_variable("label", dims, self.label, "kind of the stability region",
                            tuple(m.replace(" ", "_") for m in MAP_LABELS))
        if self.trace is not None:
            grid.variable("trace", dims, self.trace, "1", "trace of the monodromy matrix")
        if self.log_growth is not None:
            grid.variable("log_growth", dims, self.log_growth, "1",
                          "largest log|λ| per drive period (> 0 unstable)")
        return grid

    def to_xarray(self):
        """The map as an :class:`xarray.Dataset` over dimensions ``A`` (m) and ``omega``
        (rad/s) (with ``A_over_l`` and ``omega_over_omega0`` where the pendulum's l and g
        are known): ``stable``, ``label`` (CF flags: stable, T, 2T, complex, no_orbit),
        ``trace`` and ``log_growth`` where computed; the equilibrium, method, error
        estimate, counts and parameters in ``attrs``.  Needs ``pip install
        "kapitza[xarray]"``; write it with ``ds.to_netcdf(path, engine="h5netcdf")``."""
        return self._labelled().to_xarray()

    def _card_rows(self) -> list:
        rows = [("A", display.span(self.A, "m")), ("ω", display.span(self.omega, "rad/s")),
                ("stable", display.share(self.stable))]
        unstable = [f"{MAP_LABELS[k]}: {int(np.count_nonzero(np.asarray(self.label) == k))}"
                    for k in range(1, len(MAP_LABELS)) if np.any(np.asarray(self.label) == k)]
        if unstable:
            rows.append(("unstable by kind", ", ".join(unstable)))
        rows.append(("error estimate", display.number(self.error_estimate, 2) + " (relative)"))
        if self.damping:
            rows.append(("γ", display.quantity(self.damping, "1/s")))
        if self.l is not None:
            rows.append(("l, g", f"{display.quantity(self.l, 'm')}, "
                                 f"{display.quantity(self.g, 'm/s²')}"))
        return rows

    def _card_warnings(self) -> list:
        out = []
        if self.flagged_points:
            example = f" (e.g. {'; '.join(self.flags_example)})" if self.flags_example else ""
            out.append(f"{self.flagged_points} points flagged: accuracy guards failed or not "
                       f"integrated{example}")
        if self.uncertified_points:
            out.append(f"{self.uncertified_points} points uncertified: their stability test "
                       "is within 10× its error estimate of the threshold")
        return out

    def _repr_html_(self) -> str:
        return display.card(type(self).__name__,
                            f"{display.state(self.about)} · {self.method}",
                            rows=self._card_rows(), warnings=self._card_warnings(),
                            figure=self.figure if np.size(self.label) > 1 else None,
                            alt="stability map")


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
        ruled out, or an edge failed its check; warned).  The damped closed form of the
        single pendulum (``pendulum_window(..., damping=γ)``) says the same three per ω.
        None elsewhere.
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

    def figure(self, **options):
        """The window against ω: A_min and A_max, the stable band between them shaded, the
        frequencies without a window or undecided marked:
        :func:`kapitza.figures.window_figure` (``options`` go to it).  Returns a
        :class:`matplotlib.figure.Figure`."""
        return display.draw("window_figure", self, **options)

    def _labelled(self) -> LabelledGrid:
        grid = LabelledGrid("StabilityWindow", method=self.method, about=str(self.about),
                            order=self.order, tol=self.tol)
        omega = np.atleast_1d(np.asarray(self.omega, dtype=float))
        grid.coord("omega", "omega", omega, "rad/s", "drive angular frequency ω")
        fixed = {k: v for k, v in (("l", self.l), ("g", self.g), ("damping", self.damping))
                 if v is not None}
        grid.parameters(fixed)
        grid.drive_axes(omega0=grid.pendulum_scales(fixed)[1])

        def per_omega(x, dtype=float):
            return np.broadcast_to(np.asarray(x, dtype=dtype).reshape(-1)
                                   if np.ndim(x) else np.asarray(x, dtype=dtype), omega.shape)

        grid.variable("A_min", "omega", per_omega(self.A_min), "m",
                      "lower edge of the window, A_min")
        grid.variable("A_max", "omega", per_omega(self.A_max), "m",
                      "upper edge of the window, A_max")
        for name, units, long_name, dtype in (
                ("accuracy", "1", "certified relative accuracy of the edges", float),
                ("status", None, "window, none (proved) or undecided", str),
                ("min_width", "m", "resolution to which status holds", float),
                ("exists", None, "the prediction has a window (A_min < A_max)", bool),
                ("frequency_ratio", "1", "ω / max(ω0, γ)", float),
                ("error_estimate", "1", "relative size of the next-order correction to "
                 "A_min", float),
                ("fast_drive", None, "frequency ratio within averaging's validity", bool),
                ("small_amplitude", None, "A_min/l within averaging's validity", bool),
                ("converged", None, "next-order correction small enough", bool),
                ("valid", None, "averaging's prediction valid (all of the above)", bool)):
            value = getattr(self, name)
            if value is not None:
                grid.variable(name, "omega", per_omega(value, dtype), units, long_name)
        return grid

    def to_xarray(self):
        """The window as an :class:`xarray.Dataset` over ``omega`` (rad/s; with
        ``omega_over_omega0`` for the pendulum): ``A_min`` and ``A_max`` (m), and the
        fields of its method (exact: ``accuracy``, ``status``, ``min_width``; averaging:
        ``exists``, ``error_estimate``, the validity flags); a scalar ω gives a dimension of
        length 1.  Needs ``pip install "kapitza[xarray]"``."""
        return self._labelled().to_xarray()

    def _repr_html_(self) -> str:
        omega = np.atleast_1d(np.asarray(self.omega, dtype=float))
        lo, hi = (np.broadcast_to(np.asarray(x, float), np.shape(self.omega)).reshape(-1)
                  for x in (self.A_min, self.A_max))
        one = omega.size == 1
        rows = [("ω", display.span(omega, "rad/s")),
                ("A_min", display.quantity(lo[0], "m") if one else display.span(lo, "m")),
                ("A_max", display.quantity(hi[0], "m") if one else display.span(hi, "m"))]
        method = self.method + (f", order {self.order}" if self.order is not None else "")
        if self.accuracy is not None:
            rows.append(("accuracy", display.number(np.nanmax(np.append(
                np.asarray(self.accuracy, float).reshape(-1), 0.0)), 2) + " (relative)"))
        if self.error_estimate is not None:
            rows.append(("error estimate", display.span(self.error_estimate) + " (relative)"))
        warnings, notes, badges = [], [], []
        if self.status is not None:
            status = np.asarray(self.status).reshape(-1)
            undecided = int(np.count_nonzero(status == "undecided"))
            if undecided:
                warnings.append(f"undecided at {undecided} of {status.size} frequencies: the "
                                "edges there are an envelope (see min_width)")
            none = int(np.count_nonzero(status == "none"))
            if none:
                notes.append(f"no window at {none} of {status.size} frequencies (proved)")
        elif np.isnan(lo).any() and self.method == "floquet":
            notes.append(f"no window at {int(np.isnan(lo).sum())} of {lo.size} frequencies")
        if self.valid is not None:
            valid = np.asarray(self.valid, bool).reshape(-1)
            if not valid.all():
                why = [name.replace("_", " ") for name in ("fast_drive", "small_amplitude",
                                                          "converged", "exists")
                       if not np.all(getattr(self, name))]
                warnings.append(f"outside averaging's validity at {int((~valid).sum())} of "
                                f"{valid.size} frequencies (fails: {', '.join(why)})")
                badges.append(("outside validity", "warn"))
        return display.card("StabilityWindow", f"{display.state(self.about)} · {method}",
                            rows=rows,
                            badges=badges, warnings=warnings, notes=notes,
                            figure=None if one else self.figure, alt="stability window")




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

    def figure(self, **options):
        """The chart, stable regions shaded: :func:`kapitza.figures.ince_strutt_figure`."""
        return display.draw("ince_strutt_figure", self, **options)

    def _labelled(self) -> LabelledGrid:
        grid = LabelledGrid("InceStruttChart", method="characteristic values",
                            equation="y'' + (a - 2 q cos 2τ) y = 0")
        grid.coord("q", "q", self.q, "1", "Mathieu parameter q")
        grid.coord("a", "a", self.a, "1", "Mathieu parameter a")
        grid.coord("curve", "curve", np.asarray(list(self.curves), dtype=str), None,
                   "characteristic curve (a_r: even, b_r: odd)")
        grid.variable("stable", ("q", "a"), np.asarray(self.stable, bool), None,
                      "the undamped Mathieu equation is stable")
        grid.variable("characteristic_value", ("curve", "q"),
                      np.array([self.curves[k] for k in self.curves], dtype=float).reshape(
                          len(self.curves), len(self.q)), "1",
                      "characteristic value a_r(q) or b_r(q)")
        return grid

    def to_xarray(self):
        """The chart as an :class:`xarray.Dataset` over ``q`` and ``a``: ``stable`` and the
        characteristic curves (``characteristic_value`` over ``curve`` × ``q``).  Needs
        ``pip install "kapitza[xarray]"``."""
        return self._labelled().to_xarray()

    def _repr_html_(self) -> str:
        return display.card(
            "InceStruttChart", "y″ + (a − 2q cos 2τ) y = 0",
            rows=[("q", display.span(self.q)), ("a", display.span(self.a)),
                  ("stable", display.share(self.stable)),
                  ("curves", ", ".join(self.curves))],
            figure=self.figure if np.size(self.stable) > 1 else None, alt="Ince–Strutt chart")


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

    def figure(self, **options):
        """The curves A_k(ω), coloured by kind, the stable side hatched:
        :func:`kapitza.figures.boundaries_figure` (``options`` go to it)."""
        return display.draw("boundaries_figure", self, **options)

    def _labelled(self) -> LabelledGrid:
        grid = LabelledGrid("BoundaryCurves", about=str(self.about), A_range=list(self.A_range),
                            A_range_units="m", tol=self.tol, seconds=self.seconds,
                            monodromies=self.monodromies,
                            method="continuation in ω of the roots of smooth margins")
        grid.coord("omega", "omega", self.omega, "rad/s", "drive angular frequency ω")
        grid.coord("curve", "curve", np.arange(len(self.kind)), None, "boundary curve")
        grid.coord("kind", "curve", np.asarray(self.kind, dtype=str), None,
                   "multiplier at the boundary: T (+1), 2T (−1), complex")
        grid.coord("stable_below", "curve", np.asarray(self.stable_below, bool), None,
                   "the stable side is below the curve (smaller A)")
        grid.parameters(self.params)
        grid.drive_axes(omega0=grid.pendulum_scales(self.params)[1])
        dims = ("curve", "omega")
        A = np.asarray(self.A, dtype=float).reshape(len(self.kind), np.size(self.omega))
        grid.variable("A", dims, A, "m", "boundary amplitude A_k(ω) (NaN: no boundary there)")
        grid.variable("accuracy", dims, np.asarray(self.accuracy, float).reshape(A.shape), "1",
                      "certified relative accuracy of A_k")
        return grid

    def to_xarray(self):
        """The curves as an :class:`xarray.Dataset` over ``curve`` × ``omega`` (rad/s):
        ``A`` (m, NaN where a curve does not bound the stable region) and ``accuracy``,
        with each curve's ``kind`` and ``stable_below`` as coordinates.  Needs
        ``pip install "kapitza[xarray]"``."""
        return self._labelled().to_xarray()

    def _repr_html_(self) -> str:
        kinds = ", ".join(f"{k} ({'stable below' if b else 'stable above'})"
                          for k, b in zip(self.kind, np.asarray(self.stable_below),
                                          strict=True)) or "none"
        return display.card(
            "BoundaryCurves", display.state(self.about),
            rows=[("ω", display.span(self.omega, "rad/s")), ("curves", kinds),
                  ("A", display.span(self.A, "m")),
                  ("accuracy", display.number(np.nanmax(np.append(
                      np.asarray(self.accuracy, float).reshape(-1), 0.0)), 2) + " (relative)"),
                  ("A searched", f"{display.number(self.A_range[0])} … "
                                 f"{display.number(self.A_range[1])} m"),
                  ("monodromies", str(self.monodromies))],
            figure=self.figure if np.size(self.omega) > 1 and len(self.kind) else None,
            alt="stability boundaries")


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

    def _labelled(self) -> LabelledGrid:
        grid = super()._labelled()
        grid.attrs.update(monodromies=self.monodromies, levels=self.levels,
                          coarse_step=self.coarse_step)
        if self.margin is not None:
            grid.variable("margin", ("A", "omega"), self.margin, "1",
                          "continuous stability margin (> 0 stable; its zero contour is the "
                          "boundary)")
        if self.computed is not None:
            grid.variable("computed", ("A", "omega"), np.asarray(self.computed, bool), None,
                          "the point's monodromy was computed (else interpolated)")
        return grid

    def to_xarray(self):
        """As :meth:`StabilityMap.to_xarray`, with ``margin`` and ``computed``, and the
        monodromies, levels and coarse step in ``attrs``."""
        return self._labelled().to_xarray()

    def _repr_html_(self) -> str:
        rows = self._card_rows()
        rows.append(("monodromies", f"{self.monodromies} of {np.size(self.label)} points "
                                    f"({self.levels} refinement levels)"))
        return display.card("AdaptiveMap", f"{display.state(self.about)} · {self.method}",
                            rows=rows,
                            warnings=self._card_warnings(),
                            figure=self.figure if np.size(self.label) > 1 else None,
                            alt="stability map")
