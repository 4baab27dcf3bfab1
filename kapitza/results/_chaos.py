"""Results of the route to chaos: Lyapunov exponents, bifurcation diagrams, sections, basins.

Built by :mod:`kapitza.chaos`: :class:`LyapunovSpectrum` (one trajectory's exponents,
:func:`kapitza.chaos.lyapunov`), :class:`LyapunovGrid` (the largest exponent over a
parameter grid, a chaos map: :func:`kapitza.chaos.lyapunov_grid`),
:class:`BifurcationDiagram` (strobe samples after a transient over a parameter's
values × starts: :func:`kapitza.chaos.bifurcation_diagram`), :class:`PoincareSection`
(the stroboscopic section of trajectories: :func:`kapitza.chaos.poincare_section`) and
:class:`Basin` (which starts stay near a state: :func:`kapitza.chaos.basin`).

They hold numbers; ``figure()`` draws through :mod:`kapitza.figures` (imported inside
the method; the figures read results by their fields and never import them).

Conventions (shared/PHYSICS.md): SI units; θ from the downward vertical; T = 2π/ω the
drive period; exponents in 1/s (× T: per drive period, the log of a Floquet multiplier's
modulus for a periodic orbit).  Coordinates named in ``angles`` are reported unwrapped
and drawn wrapped into [−π, π).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from . import _display as display
from ._xarray import LabelledGrid, coordinate_units, quantity_of

__all__ = ["LyapunovSpectrum", "LyapunovGrid", "BifurcationDiagram", "PoincareSection",
           "Basin", "wrap_angles"]


def wrap_angles(q, coordinates, angles):
    """``q`` (..., n) with the coordinates named in ``angles`` wrapped into [−π, π)."""
    q = np.array(q, dtype=float, copy=True)
    for name in angles:
        j = coordinates.index(name)
        q[..., j] = (q[..., j] + math.pi) % (2 * math.pi) - math.pi
    return q


_FIGURES = {"LyapunovGrid": "lyapunov_map_figure", "BifurcationDiagram": "bifurcation_figure",
            "PoincareSection": "section_figure", "Basin": "basin_figure"}


def _draw(result, options):
    """``result`` drawn by its figure function in :mod:`kapitza.figures`."""
    return display.draw(_FIGURES[type(result).__name__], result, **options)


def _state_variables(grid, dims, coordinates, q, qdot, what, prefix=""):
    """``q`` and ``q̇`` (…, n) as variables over ``dims`` + ("coordinate",), with the
    coordinates' units where kapitza knows them (all alike)."""
    q_units = {coordinate_units(c)[0] for c in coordinates}
    rate_units = {coordinate_units(c)[1] for c in coordinates}
    grid.variable(f"{prefix}q", dims + ("coordinate",), q,
                  q_units.pop() if len(q_units) == 1 else None, f"q {what}")
    grid.variable(f"{prefix}qdot", dims + ("coordinate",), qdot,
                  rate_units.pop() if len(rate_units) == 1 else None, f"q̇ {what}")


def _failed(status, ok=("finished",)) -> list:
    """A warning naming the runs that did not finish (empty if all did)."""
    status = np.asarray(status).reshape(-1)
    bad = status[~np.isin(status, ok)]
    if not bad.size:
        return []
    counts = ", ".join(f"{k}: {int((bad == k).sum())}" for k in np.unique(bad))
    return [f"{bad.size} of {status.size} runs did not finish ({counts}); their numbers are "
            "from a shorter record or NaN"]


def _start_dims(shape) -> tuple:
    """Dimension names of a grid of starts: ``start`` for a line, ``start_<k>`` for more."""
    return ("start",) if len(shape) == 1 else tuple(f"start_{k}" for k in range(len(shape)))


@dataclass(frozen=True, eq=False)
class LyapunovSpectrum:
    """Lyapunov exponents of one trajectory of a driven system (:func:`kapitza.chaos.lyapunov`).

    Attributes
    ----------
    exponents : ndarray (k,)
        λ_1 ≥ … ≥ λ_k (1/s): the mean growth rates of the k leading directions of the
        tangent flow over the record (Benettin's method).  k = 2n is the full spectrum.
    error : ndarray (k,)
        Error estimate of each exponent (1/s): the record's B blocks give B estimates,
        ``error`` = 2.5 × their standard deviation / √B plus the integration's share
        (how it bounds: :mod:`kapitza.chaos`).
    sum_error : float
        The same estimate for Σλ (its blocks' spread: the exponents' fluctuations cancel
        in the sum, which for the full spectrum is the mean of tr J, the phase-space
        contraction rate).
    complete : bool
        Whether this is the full spectrum (k = 2n).
    period : float
        Drive period T (s).
    periods, transient : int
        Drive periods of the record, and those run before it and discarded.
    every : int
        Drive periods per recorded interval (the running estimate's time step).
    blocks : int
        B, the blocks of the record whose spread is the error.
    block_exponents : ndarray (B, k)
        The exponents of each block (1/s).
    times : ndarray (m,)
        The recorded intervals' ends, from the record's start (s).
    running : ndarray (m, k)
        The finite-time estimates at ``times`` (1/s): the convergence of the exponents.
    coordinates : tuple of str
    params : dict
    q0, qdot0 : ndarray (n,)
        The initial state (at t0).
    q, qdot : ndarray (n,)
        The state at the end (``t_final``).
    t0, t_final : float
        Start and end (s).
    tangent : str
        "jacobian" (J v from the exact compiled Jacobian) or "difference" (J v by a
        directional difference of the equations, relative error ~1e-8).
    rtol, atol : float
        DOP853's tolerances on the trajectory and the tangent vectors.
    steps, rejected : int
    status : str
        "finished", or how the run stopped (:data:`lagrange_core.batch.STATUS_NAMES`);
        exponents from a shorter record then.
    wall_time : float
        Seconds.
    """

    exponents: np.ndarray
    error: np.ndarray
    sum_error: float
    complete: bool
    period: float
    periods: int
    transient: int
    every: int
    blocks: int
    block_exponents: np.ndarray
    times: np.ndarray
    running: np.ndarray
    coordinates: tuple
    params: dict
    q0: np.ndarray
    qdot0: np.ndarray
    q: np.ndarray
    qdot: np.ndarray
    t0: float
    t_final: float
    tangent: str
    rtol: float
    atol: float
    steps: int
    rejected: int
    status: str
    wall_time: float

    @property
    def largest(self) -> float:
        """λ_1 (1/s)."""
        return float(self.exponents[0])

    @property
    def per_period(self) -> np.ndarray:
        """The exponents × T: per drive period (for a periodic orbit, log|λ| of the Floquet
        multipliers)."""
        return self.exponents * self.period

    def to_dataframe(self):
        """One row per exponent: index (1 = largest), exponent and error (1/s), per period."""
        import pandas as pd
        k = self.exponents.size
        return pd.DataFrame(dict(index=np.arange(1, k + 1), exponent=self.exponents,
                                 error=self.error, per_period=self.per_period,
                                 period=self.period, periods=self.periods,
                                 transient=self.transient, status=self.status))

    def _repr_html_(self) -> str:
        rows = [("λ₁", display.quantity(self.largest, "1/s", self.error[0])
                 + f"   ({display.number(self.per_period[0])} per period)"),
                ("spectrum", ", ".join(display.number(x) for x in self.exponents) + " 1/s"
                 + ("" if self.complete else " (leading only)")),
                ("Σλ", display.quantity(float(np.sum(self.exponents)), "1/s",
                                        self.sum_error)),
                ("record", f"{self.periods} periods after {self.transient}, "
                           f"{self.blocks} blocks; T = {display.quantity(self.period, 's')}"),
                ("tangent", f"{self.tangent}, rtol {display.number(self.rtol, 2)}")]
        chaotic = self.largest - self.error[0] > 0
        badges = [("λ₁ > 0: chaotic", "bad") if chaotic else ("λ₁ ≤ 0 within its error", "good")]
        return display.card("LyapunovSpectrum", ", ".join(self.coordinates), rows=rows,
                            badges=badges, warnings=_failed(self.status))


@dataclass(frozen=True, eq=False)
class LyapunovGrid:
    """The largest Lyapunov exponent over a broadcast parameter grid: a chaos map
    (:func:`kapitza.chaos.lyapunov_grid`).

    Attributes
    ----------
    shape : tuple
        The grid's shape S.
    params : dict name -> ndarray S
    coordinates : tuple of str
    exponent, error : ndarray S
        λ_max (1/s) and its error estimate (as :attr:`LyapunovSpectrum.error`); NaN where
        a run failed.
    period : ndarray S
        T (s).
    periods, transient, blocks : int
    block_exponents : ndarray S + (B,)
    q0, qdot0 : ndarray S + (n,)
        The initial states.
    q, qdot : ndarray S + (n,)
        Where each run stopped.
    status : ndarray S of str
    steps : ndarray S (int)
    tangent : str
    rtol, atol : float
    wall_time : float
    """

    shape: tuple
    params: dict
    coordinates: tuple
    exponent: np.ndarray
    error: np.ndarray
    period: np.ndarray
    periods: int
    transient: int
    blocks: int
    block_exponents: np.ndarray
    q0: np.ndarray
    qdot0: np.ndarray
    q: np.ndarray
    qdot: np.ndarray
    status: np.ndarray
    steps: np.ndarray
    tangent: str
    rtol: float
    atol: float
    wall_time: float

    @property
    def chaotic(self) -> np.ndarray:
        """λ_max − error > 0 (bool, S): positive beyond its error."""
        with np.errstate(invalid="ignore"):
            return np.asarray(self.exponent - self.error > 0)

    def to_dataframe(self):
        """One row per grid point: the parameters, λ_max, its error, λ_max T, status."""
        import pandas as pd
        flat = int(np.prod(self.shape, dtype=np.int64))
        data = {k: np.broadcast_to(v, self.shape).reshape(flat) for k, v in self.params.items()}
        data.update(exponent=self.exponent.reshape(flat), error=self.error.reshape(flat),
                    per_period=(self.exponent * self.period).reshape(flat),
                    chaotic=self.chaotic.reshape(flat), steps=self.steps.reshape(flat),
                    status=self.status.reshape(flat))
        return pd.DataFrame(data)

    def figure(self, **options):
        """The map of λ_max over the grid's two varying parameters
        (:func:`kapitza.chaos.lyapunov_map_figure`; ``options`` go to it)."""
        return _draw(self, options)

    def _labelled(self) -> LabelledGrid:
        grid = LabelledGrid("LyapunovGrid", periods=int(self.periods),
                            transient=int(self.transient), blocks=int(self.blocks),
                            tangent=self.tangent, rtol=self.rtol, atol=self.atol,
                            wall_time=self.wall_time,
                            method="Benettin's method on the variational equations")
        dims = grid.broadcast_axes(self.params, self.shape)
        grid.drive_axes(*grid.pendulum_scales(self.params))
        grid.coord("coordinate", "coordinate", np.asarray(self.coordinates, dtype=str), None,
                   "coordinate of the system")
        grid.variable("exponent", dims, self.exponent, "1/s", "largest Lyapunov exponent λ_max")
        grid.variable("error", dims, self.error, "1/s", "error estimate of λ_max")
        grid.variable("per_period", dims, self.exponent * self.period, "1",
                      "λ_max per drive period, λ_max T")
        grid.variable("chaotic", dims, self.chaotic, None, "λ_max − error > 0")
        grid.variable("period", dims, np.broadcast_to(self.period, self.shape), "s",
                      "drive period T")
        grid.variable("block_exponents", dims + ("block",), self.block_exponents, "1/s",
                      "λ_max of each block of the record")
        _state_variables(grid, dims, self.coordinates, self.q0, self.qdot0, "at the start",
                         "initial_")
        _state_variables(grid, dims, self.coordinates, self.q, self.qdot, "where the run "
                         "stopped")
        grid.variable("status", dims, np.asarray(self.status, dtype=str), None,
                      "how the run ended")
        grid.variable("steps", dims, self.steps, "1", "integration steps")
        return grid

    def to_xarray(self):
        """The chaos map as an :class:`xarray.Dataset`: the grid's axes named by the
        varying parameters, ``exponent`` and ``error`` (1/s), ``per_period``, ``chaotic``,
        ``block_exponents`` over ``block``, the initial and final states over
        ``coordinate``, ``status``; the record's settings in ``attrs``.  Needs
        ``pip install "kapitza[xarray]"``."""
        return self._labelled().to_xarray()

    def _repr_html_(self) -> str:
        rows = [("grid", " × ".join(map(str, self.shape)) or "one point")]
        rows += display.axis_rows(self.params)
        rows += [("λ_max", display.span(self.exponent, "1/s")),
                 ("error", display.span(self.error, "1/s")),
                 ("chaotic", display.share(self.chaotic)),
                 ("record", f"{self.periods} periods after {self.transient}")]
        drawable = sum(n > 1 for n in self.shape) == 2
        return display.card("LyapunovGrid", ", ".join(self.coordinates), rows=rows,
                            warnings=_failed(self.status),
                            figure=self.figure if drawable else None, alt="Lyapunov map")


@dataclass(frozen=True, eq=False)
class BifurcationDiagram:
    """Stroboscopic samples after a transient, over a parameter's values × initial states
    (:func:`kapitza.chaos.bifurcation_diagram`): the attractors' dots.

    Attributes
    ----------
    parameter : str
        The parameter varied.
    values : ndarray (V,)
    coordinates : tuple of str
    q, qdot : ndarray (V, S, K, n)
        [q, q̇] at t0 + (transient + k) T, k = 0 … K − 1, per value and start (NaN after a
        run that failed).
    q0, qdot0 : ndarray (S, n)
        The starts (at t0).
    about : ndarray (n,) or None
        The state the diagram is about (the branch a continuation would follow).
    period : ndarray (V,)
        T (s) per value.
    periods, transient : int
        K samples kept; drive periods run before them.
    angles : tuple of str
        Coordinates drawn (and compared, :meth:`orbit_period`) modulo 2π.
    params : dict
        The other parameters.
    status : ndarray (V, S) of str
    method : str
    rtol : float
    wall_time : float
    """

    parameter: str
    values: np.ndarray
    coordinates: tuple
    q: np.ndarray
    qdot: np.ndarray
    q0: np.ndarray
    qdot0: np.ndarray
    about: np.ndarray | None
    period: np.ndarray
    periods: int
    transient: int
    angles: tuple
    params: dict
    status: np.ndarray
    method: str
    rtol: float
    wall_time: float

    @property
    def q_wrapped(self) -> np.ndarray:
        """:attr:`q` with the ``angles`` wrapped into [−π, π)."""
        return wrap_angles(self.q, self.coordinates, self.angles)

    def orbit_period(self, *, max_period: int = 64, tol: float = 1e-6) -> np.ndarray:
        """The period of each (value, start)'s strobe sequence in drive periods (int,
        (V, S)): the least p ≤ ``max_period`` with x_(k+p) = x_k for every sample k (to
        ``tol``, in q (rad for angles, modulo 2π) and q̇ T/2π); 0 where there is none
        (chaos, a quasi-periodic or longer orbit, a failed run).  A period-1 attractor
        has one strobe point, period 2 two, …"""
        x = _strobe_states(self)
        V, S, K, _ = x.shape
        out = np.zeros((V, S), dtype=int)
        todo = np.all(np.isfinite(x), axis=(2, 3))
        for p in range(1, min(int(max_period), K - 1) + 1):
            d = x[:, :, p:] - x[:, :, :-p]
            for name in self.angles:
                j = self.coordinates.index(name)
                d[..., j] = (d[..., j] + math.pi) % (2 * math.pi) - math.pi
            hit = todo & (out == 0) & np.all(np.abs(d) <= tol, axis=(2, 3))
            out[hit] = p
        return out

    def to_dataframe(self):
        """Long format: one row per (value, start, sample) with q and q̇ per coordinate
        (angles wrapped, as drawn)."""
        import pandas as pd
        V, S, K, n = self.q.shape
        qw = self.q_wrapped
        v, s, k = np.meshgrid(np.arange(V), np.arange(S), np.arange(K), indexing="ij")
        data = {self.parameter: self.values[v.ravel()], "start": s.ravel(), "sample": k.ravel()}
        for j, c in enumerate(self.coordinates):
            data[c] = qw[..., j].ravel()
            data[f"{c}_dot"] = self.qdot[..., j].ravel()
        return pd.DataFrame(data)

    def figure(self, **options):
        """The dots: every strobe sample of a coordinate against the parameter
        (:func:`kapitza.chaos.bifurcation_figure`; ``options`` go to it, e.g. ``ax=``,
        ``coordinate=``)."""
        return _draw(self, options)

    def _labelled(self) -> LabelledGrid:
        grid = LabelledGrid("BifurcationDiagram", parameter=self.parameter,
                            periods=int(self.periods), transient=int(self.transient),
                            angles=list(self.angles), method=self.method, rtol=self.rtol,
                            wall_time=self.wall_time,
                            orbit_period_settings="max_period=64, tol=1e-6")
        grid.parameters(self.params)
        units, long_name = quantity_of(self.parameter)
        p = self.parameter
        grid.coord(p, p, self.values, units, long_name)
        grid.coord("coordinate", "coordinate", np.asarray(self.coordinates, dtype=str), None,
                   "coordinate of the system")
        grid.coord("sample", "sample", np.arange(self.q.shape[2]), None,
                   "strobe sample k, at t0 + (transient + k) T")
        dims = (p, "start", "sample")
        _state_variables(grid, dims, self.coordinates, self.q, self.qdot,
                         "at the strobe samples (angles unwrapped)")
        _state_variables(grid, ("start",), self.coordinates, self.q0, self.qdot0,
                         "at the start", "initial_")
        if self.about is not None:
            grid.variable("about", "coordinate", np.asarray(self.about, float), None,
                          "the state the diagram is about")
        grid.variable("period", p, self.period, "s", "drive period T")
        grid.variable("status", (p, "start"), np.asarray(self.status, dtype=str), None,
                      "how the run ended")
        grid.variable("orbit_period", (p, "start"), self.orbit_period(), "1",
                      "period of the strobe sequence in drive periods (0: none found)")
        return grid

    def to_xarray(self):
        """The diagram as an :class:`xarray.Dataset` over the parameter's values (a
        dimension named by it, with units where known), ``start``, ``sample`` and
        ``coordinate``: ``q`` and ``qdot`` (unwrapped; ``attrs['angles']`` names the
        angles), the starts, ``period``, ``status`` and ``orbit_period``
        (:meth:`orbit_period` with its defaults).  Needs ``pip install "kapitza[xarray]"``."""
        return self._labelled().to_xarray()

    def _repr_html_(self) -> str:
        V, S, K, _ = self.q.shape
        unit = quantity_of(self.parameter)[0] or ""
        periods = self.orbit_period()
        found = ", ".join(f"{k}: {int((periods == k).sum())}" for k in np.unique(periods)
                          if k > 0)
        none = int((periods == 0).sum())
        rows = [(self.parameter, display.span(self.values, unit)),
                ("runs", f"{V} values × {S} starts, {K} samples after {self.transient} "
                         "periods"),
                ("orbit periods", (found or "none") + (f"; none found: {none}" if none else ""))]
        return display.card("BifurcationDiagram", f"{', '.join(self.coordinates)} against "
                            f"{self.parameter}", rows=rows,
                            warnings=_failed(self.status, ("finished", "left_band")),
                            figure=self.figure if V > 1 else None, alt="bifurcation diagram")


def _strobe_states(result):
    """Strobe samples as (…, K, 2n) in comparable units: q, and q̇ T/2π."""
    T = np.asarray(result.period, dtype=float)
    T = T.reshape(T.shape + (1,) * (result.qdot.ndim - T.ndim))
    return np.concatenate([result.q, result.qdot * T / (2 * math.pi)], axis=-1)


@dataclass(frozen=True, eq=False)
class PoincareSection:
    """The stroboscopic (Poincaré) section of trajectories: [q, q̇] once per drive period
    (:func:`kapitza.chaos.poincare_section`).

    Attributes
    ----------
    coordinates : tuple of str
    q, qdot : ndarray S + (K, n)
        At t0 + (transient + k) T, k = 0 … K − 1 (NaN after a run that failed); S the
        starts' shape (() for one).
    q0, qdot0 : ndarray S + (n,)
    period : float
        T (s).
    t0 : float
        The start (s); the section's drive phase is ω t0.
    periods, transient : int
    angles : tuple of str
    params : dict
    status : ndarray S of str
    method : str
    rtol : float
    wall_time : float
    """

    coordinates: tuple
    q: np.ndarray
    qdot: np.ndarray
    q0: np.ndarray
    qdot0: np.ndarray
    period: float
    t0: float
    periods: int
    transient: int
    angles: tuple
    params: dict
    status: np.ndarray
    method: str
    rtol: float
    wall_time: float

    @property
    def q_wrapped(self) -> np.ndarray:
        return wrap_angles(self.q, self.coordinates, self.angles)

    @property
    def times(self) -> np.ndarray:
        """The section's times t0 + (transient + k) T (s), (K,)."""
        return self.t0 + (self.transient + np.arange(self.q.shape[-2])) * self.period

    def to_dataframe(self):
        """Long format: one row per (start, sample): time, q and q̇ (angles wrapped)."""
        import pandas as pd
        K, n = self.q.shape[-2:]
        qw = self.q_wrapped.reshape(-1, K, n)
        qd = self.qdot.reshape(-1, K, n)
        S = qw.shape[0]
        s, k = np.meshgrid(np.arange(S), np.arange(K), indexing="ij")
        data = {"start": s.ravel(), "sample": k.ravel(), "t": self.times[k.ravel()]}
        for j, c in enumerate(self.coordinates):
            data[c] = qw[..., j].ravel()
            data[f"{c}_dot"] = qd[..., j].ravel()
        return pd.DataFrame(data)

    def figure(self, **options):
        """The section's dots in the (q, q̇) plane of one coordinate
        (:func:`kapitza.chaos.section_figure`)."""
        return _draw(self, options)

    def _labelled(self) -> LabelledGrid:
        grid = LabelledGrid("PoincareSection", period=self.period, t0=self.t0,
                            periods=int(self.periods), transient=int(self.transient),
                            angles=list(self.angles), method=self.method, rtol=self.rtol,
                            wall_time=self.wall_time)
        grid.parameters(self.params)
        starts = _start_dims(np.shape(self.status))
        grid.coord("coordinate", "coordinate", np.asarray(self.coordinates, dtype=str), None,
                   "coordinate of the system")
        grid.coord("t", "sample", self.times, "s", "time of the strobe sample")
        _state_variables(grid, starts + ("sample",), self.coordinates, self.q, self.qdot,
                         "on the section (angles unwrapped)")
        _state_variables(grid, starts, self.coordinates, self.q0, self.qdot0, "at the start",
                         "initial_")
        grid.variable("status", starts, np.asarray(self.status, dtype=str), None,
                      "how the run ended")
        return grid

    def to_xarray(self):
        """The section as an :class:`xarray.Dataset` over the starts (``start``, or
        ``start_0``, … for a grid of them; none for one trajectory), ``sample`` (with its
        time ``t`` in s) and ``coordinate``: ``q``, ``qdot``, the starts and ``status``.
        Needs ``pip install "kapitza[xarray]"``."""
        return self._labelled().to_xarray()

    def _repr_html_(self) -> str:
        K = self.q.shape[-2]
        starts = int(np.size(self.status))
        rows = [("samples", f"{K} per start, after {self.transient} periods"),
                ("starts", str(starts)),
                ("T", display.quantity(self.period, "s")),
                ("phase ω t0", display.quantity(2 * math.pi * self.t0 / self.period, "rad"))]
        return display.card("PoincareSection", ", ".join(self.coordinates), rows=rows,
                            warnings=_failed(self.status, ("finished", "left_band")),
                            figure=self.figure if K > 1 else None, alt="Poincaré section")


@dataclass(frozen=True, eq=False)
class Basin:
    """Which initial states stay near a state for a whole run: its basin (as far as the run
    shows), :func:`kapitza.chaos.basin`.

    Attributes
    ----------
    coordinates : tuple of str
    params : dict
    about : ndarray (n,)
        The state (coordinates).
    q0, qdot0 : ndarray S + (n,)
        The cells' initial states (at t0).
    band : ndarray (n,)
        Half-widths: a run stays while |q_i − about_i| < band_i.
    stays : ndarray S (bool)
        Stayed in the band for the whole run (status "finished").
    exit_time : ndarray S
        How long after t0 it left (s; NaN: it stayed, or failed).
    status : ndarray S of str
    period : float
    periods : int
        Drive periods each run lasts.
    method : str
    rtol : float
    wall_time : float
    """

    coordinates: tuple
    params: dict
    about: np.ndarray
    q0: np.ndarray
    qdot0: np.ndarray
    band: np.ndarray
    stays: np.ndarray
    exit_time: np.ndarray
    status: np.ndarray
    period: float
    periods: int
    method: str
    rtol: float
    wall_time: float

    @property
    def shape(self) -> tuple:
        return self.stays.shape

    @property
    def fraction(self) -> float:
        """The fraction of the cells that stay."""
        return float(np.mean(self.stays)) if self.stays.size else math.nan

    def plane(self):
        """For a 2-D grid whose two axes vary two components of the state [q, q̇] (one
        each): (i, j), their indices in [q, q̇] (0 … 2n − 1), or None."""
        if self.stays.ndim != 2 or min(self.stays.shape) < 2:
            return None
        x = np.concatenate([self.q0, self.qdot0], axis=-1)
        d0, d1 = x[1, 0] - x[0, 0], x[0, 1] - x[0, 0]
        i, j = np.flatnonzero(d0), np.flatnonzero(d1)
        if i.size != 1 or j.size != 1 or i[0] == j[0]:
            return None
        return int(i[0]), int(j[0])

    @property
    def area(self) -> float:
        """The basin's area in its plane: cells that stay × the cell area |Δx_i Δx_j| (rad²/s
        for an angle and its rate), for a regular 2-D grid (:meth:`plane`); NaN otherwise."""
        ij = self.plane()
        if ij is None:
            return math.nan
        x = np.concatenate([self.q0, self.qdot0], axis=-1)
        cell = abs((x[1, 0, ij[0]] - x[0, 0, ij[0]]) * (x[0, 1, ij[1]] - x[0, 0, ij[1]]))
        return float(np.count_nonzero(self.stays) * cell)

    def to_dataframe(self):
        """One row per cell: the initial state, stays, exit time, status."""
        import pandas as pd
        flat = int(np.prod(self.shape, dtype=np.int64))
        data = {}
        for j, c in enumerate(self.coordinates):
            data[f"{c}0"] = self.q0[..., j].reshape(flat)
            data[f"{c}_dot0"] = self.qdot0[..., j].reshape(flat)
        data.update(stays=self.stays.reshape(flat), exit_time=self.exit_time.reshape(flat),
                    status=self.status.reshape(flat))
        return pd.DataFrame(data)

    def figure(self, **options):
        """The basin in its plane (:func:`kapitza.chaos.basin_figure`)."""
        return _draw(self, options)

    def _labelled(self) -> LabelledGrid:
        grid = LabelledGrid("Basin", about=np.asarray(self.about).tolist(),
                            band=np.asarray(self.band).tolist(), period=self.period,
                            periods=int(self.periods), method=self.method, rtol=self.rtol,
                            wall_time=self.wall_time, fraction=self.fraction,
                            area=self.area)
        grid.parameters(self.params)
        starts = {}
        for j, c in enumerate(self.coordinates):
            starts[f"initial.{c}"] = self.q0[..., j]
            starts[f"initial.{c}_dot"] = self.qdot0[..., j]
        dims = grid.broadcast_axes(starts, self.shape, prefer=(), fixed_to="initial_state")
        grid.variable("stays", dims, np.asarray(self.stays, bool), None,
                      "stayed in the band for the whole run")
        grid.variable("exit_time", dims, self.exit_time, "s",
                      "time after t0 it left the band (NaN: stayed, or failed)")
        grid.variable("status", dims, np.asarray(self.status, dtype=str), None,
                      "how the run ended")
        return grid

    def to_xarray(self):
        """The basin as an :class:`xarray.Dataset` over its grid of starts (axes named by
        the component of the initial state that varies along them, e.g.
        ``initial.theta`` in rad and ``initial.theta_dot`` in rad/s): ``stays``,
        ``exit_time`` (s), ``status``; the state, band, fraction and area in ``attrs``.
        Needs ``pip install "kapitza[xarray]"``."""
        return self._labelled().to_xarray()

    def _repr_html_(self) -> str:
        rows = [("grid", " × ".join(map(str, self.shape)) or "one start"),
                ("stays", display.share(self.stays, "starts")),
                ("area", display.number(self.area) if self.plane() else "— (not a plane)"),
                ("about", display.state(list(np.asarray(self.about, float)))),
                ("run", f"{self.periods} periods of T = {display.quantity(self.period, 's')}")]
        return display.card("Basin", ", ".join(self.coordinates), rows=rows,
                            warnings=_failed(self.status, ("finished", "left_band")),
                            figure=self.figure if self.plane() else None, alt="basin")
