"""Results of Floquet analysis: one point, and monodromies and their analysis over a grid.

:class:`FloquetResult` (one parameter point, :func:`kapitza.floquet_point`),
:class:`MonodromyData` (the monodromy matrices over a broadcast grid,
:func:`kapitza.monodromy_data`) and :class:`FloquetGrid` (their analysis,
:func:`kapitza.floquet_grid`).  Stability over an (A, ω) plane is a
:class:`~kapitza.results.StabilityMap`.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from . import _display as display
from ._base import BOUNDARIES, boundary_names, scalar_if_one, unscale
from ._xarray import LabelledGrid

__all__ = ["FloquetResult", "MonodromyData", "FloquetGrid"]


@dataclass(frozen=True)
class FloquetResult:
    """Floquet analysis of one linear time-periodic system x′ = J(t) x.

    Built by :func:`kapitza.floquet.floquet_point` (and
    :meth:`kapitza.KapitzaPendulum.floquet`).

    Attributes
    ----------
    period : float
        Drive period T = 2π/ω (s).
    monodromy_scaled : ndarray (2n, 2n)
        M e^(−log_scale); M itself is :attr:`monodromy` (inf where it overflows).
    log_scale : float
        log of the factor divided out of M (0 unless M would exceed 1e150).
    multipliers : ndarray, complex (2n)
        Floquet multipliers λ (eigenvalues of M) by decreasing modulus; ±inf if
        |λ| overflows a float (see :attr:`log_abs_multipliers`).
    log_abs_multipliers : ndarray (2n)
        log|λ|, finite even for astronomically large growth.
    trace : float
        tr M (±inf if beyond float range).
    stable : bool
        Linear stability, decided on the best estimate of M: 2 × 2: Jury's test
        |tr M| ≤ 1 + det M with the exact det = exp(∮ tr J); undamped (4 × 4 and
        larger): every x = λ + 1/λ real in [−2, 2], the roots of the symmetrised
        (palindromic) characteristic polynomial written in x; damped: all |λ| < 1.
        How sure the decision is, is the grid's ``margin``: points whose test is
        within its uncertainty (10× the error estimate) of the threshold are
        counted as uncertified by maps.
    omega_slow : float or ndarray
        Slow angular frequencies (rad/s) of the stable solutions, arg(λ)/T ∈
        [0, ω/2], one per pair of multipliers (NaN if unstable); a float for a system
        of one coordinate.  For the
        pendulum cos(πβ) = tr M e^(γT/2)/2 and Ω = βω/2: the exact linear value
        that first-order averaging approximates.
    exponents : ndarray, complex (2n)
        Floquet exponents μ = log λ / T (1/s); the real part is the growth rate.
    boundary : str
        "stable", or the kind of instability (:data:`BOUNDARIES`): "T" (real
        multiplier > 1: the region is bounded by period-T solutions), "2T" (real
        < −1: period 2T), "complex" (a complex quadruplet leaves the unit circle).
    error_estimate : float
        Estimated error of M relative to max(1, ‖M‖).
    steps, samples : int
        Taylor steps per period; samples of J per period.
    liouville_residual : float
        |det M / exp(∮ tr J dt) − 1|.
    pairing_residual : float
        max |c_k − c_{2n−k}| of the characteristic polynomial (relative); NaN
        for damped systems (no λ, 1/λ symmetry) or huge growth.
    flags : tuple of str
        Accuracy warnings; empty when every guard passed.
    """

    period: float
    monodromy_scaled: np.ndarray
    log_scale: float
    multipliers: np.ndarray
    log_abs_multipliers: np.ndarray
    trace: float
    stable: bool
    omega_slow: np.ndarray
    exponents: np.ndarray
    boundary: str
    error_estimate: float
    steps: int
    samples: int
    liouville_residual: float
    pairing_residual: float
    flags: tuple = field(default=())

    @property
    def monodromy(self) -> np.ndarray:
        """M (entries ±inf if beyond float range; use monodromy_scaled and log_scale)."""
        return unscale(self.monodromy_scaled, self.log_scale)

    @property
    def log_growth(self) -> float:
        """max log|λ| per period (> 0 unstable); the growth rate is log_growth / period."""
        return float(self.log_abs_multipliers[0])

    def to_dataframe(self):
        """One row per multiplier: λ, |λ|, log|λ|, exponent, stable, boundary."""
        import pandas as pd
        return pd.DataFrame({"multiplier": self.multipliers,
                             "abs": np.abs(self.multipliers),
                             "log_abs": self.log_abs_multipliers,
                             "exponent": self.exponents,
                             "stable": self.stable, "boundary": self.boundary})

    def _repr_html_(self) -> str:
        slow = np.atleast_1d(np.asarray(self.omega_slow, dtype=float))
        rows = [("T", display.quantity(self.period, "s")),
                ("max |λ|", display.number(np.abs(self.multipliers[0]), 6)
                 + f"   (log|λ| = {display.number(self.log_growth, 4)} per period)"),
                ("tr M", display.number(self.trace, 8)),
                ("Ω", ", ".join(display.quantity(w, "rad/s", digits=8) for w in slow)),
                ("error estimate", display.number(self.error_estimate, 2)
                 + " (of M, relative)"),
                ("residuals", f"Liouville {display.number(self.liouville_residual, 2)}, "
                              f"pairing {display.number(self.pairing_residual, 2)}"),
                ("steps / samples", f"{self.steps} / {self.samples} per period")]
        badges = [("stable", "good") if self.stable else (f"unstable ({self.boundary})", "bad")]
        if self.flags:
            badges.append(("flagged", "warn"))
        return display.card("FloquetResult", "", rows=rows, badges=badges,
                            warnings=self.flags)


@dataclass(frozen=True)
class MonodromyData:
    """Monodromy matrices over a broadcast grid of parameter sets.

    Built by :func:`kapitza.floquet.monodromy_data`; every array field has the grid's
    shape (:attr:`shape`), followed by the matrix or vector axes where stated.

    Attributes
    ----------
    params : dict of str to ndarray
        Every parameter of the system by name, broadcast to the grid's shape.
    monodromy_scaled : ndarray (..., 2n, 2n)
        M e^(−log_scale) per point; M itself is :attr:`monodromy`.
    log_scale : ndarray
        log of the factor divided out of M (0 unless M would exceed 1e150).
    error_estimate : ndarray
        Estimated error of M relative to max(1, ‖M‖) (balanced variables, see
        :mod:`kapitza.floquet`).
    steps : int ndarray
        Taylor steps per period.
    samples : int
        Samples of J per period (the same at every point).
    period : ndarray
        Drive period T = 2π/ω (s).
    liouville_exponent : ndarray
        ∮ tr J dt over one period (det M = its exponential; −γT for the damped pendulum).
    """

    params: dict
    monodromy_scaled: np.ndarray
    log_scale: np.ndarray
    error_estimate: np.ndarray
    steps: np.ndarray
    samples: int
    period: np.ndarray
    liouville_exponent: np.ndarray

    @property
    def shape(self) -> tuple:
        """The grid's shape (that of the broadcast parameters)."""
        return np.shape(self.log_scale)

    @property
    def monodromy(self) -> np.ndarray:
        """M per point (entries ±inf where beyond float range)."""
        return unscale(self.monodromy_scaled, self.log_scale)

    def _columns(self) -> dict:
        cols = {k: np.ravel(np.broadcast_to(v, self.shape)) for k, v in self.params.items()}
        cols.update(period=np.ravel(self.period), log_scale=np.ravel(self.log_scale),
                    error_estimate=np.ravel(self.error_estimate), steps=np.ravel(self.steps))
        return cols

    def to_dataframe(self):
        """One row per grid point: the parameters, period, log_scale, error_estimate, steps."""
        import pandas as pd
        return pd.DataFrame(self._columns())

    def _labelled(self, matrices: bool = True) -> LabelledGrid:
        grid = LabelledGrid(type(self).__name__, samples=int(self.samples))
        dims = grid.broadcast_axes(self.params, self.shape)
        length, omega0 = grid.pendulum_scales(self.params)
        grid.drive_axes(length, omega0)
        grid.variable("period", dims, np.broadcast_to(self.period, self.shape), "s",
                      "drive period T = 2π/ω")
        if matrices:
            grid.variable("monodromy_scaled", dims + ("row", "column"), self.monodromy_scaled,
                          "1", "monodromy matrix M e^(−log_scale)")
        grid.variable("log_scale", dims, self.log_scale, "1",
                      "log of the factor divided out of M")
        grid.variable("error_estimate", dims, self.error_estimate, "1",
                      "estimated error of M relative to max(1, ‖M‖)")
        grid.variable("steps", dims, self.steps, "1", "Taylor steps per period")
        return grid

    def to_xarray(self):
        """The grid as an :class:`xarray.Dataset`: its axes named by the parameters that
        vary along them (``A``, ``omega``, … with units; ``axis_<k>`` where none does), the
        fixed parameters in ``attrs``, and per point ``period`` (s), ``monodromy_scaled``
        (over ``row`` × ``column``), ``log_scale``, ``error_estimate`` and ``steps``.
        Needs ``pip install "kapitza[xarray]"``."""
        return self._labelled().to_xarray()

    def _varying(self) -> list:
        """(name, values) of the parameters that vary over the grid."""
        out = []
        for k, v in self.params.items():
            v = np.asarray(v)
            if v.size > 1 and not np.all(v == v.reshape(-1)[0]):
                out.append((k, v))
        return out

    def _repr_html_(self) -> str:
        rows = [("grid", " × ".join(map(str, self.shape)) or "one point")]
        rows += display.axis_rows(self.params)
        rows.append(("error estimate", display.span(self.error_estimate) + " (of M)"))
        return display.card(type(self).__name__, "monodromies", rows=rows)


@dataclass(frozen=True)
class FloquetGrid(MonodromyData):
    """Floquet analysis at every point of a broadcast parameter grid.

    Built by :func:`kapitza.floquet.floquet_grid`.  The monodromy fields are those of
    :class:`MonodromyData`; the analysis adds, per point (grid shape, then the axes
    stated), the fields of :class:`FloquetResult` — :meth:`point` returns one of them.

    Attributes
    ----------
    multipliers, log_abs_multipliers, exponents : ndarray (..., 2n)
        λ by decreasing modulus, log|λ|, log λ / T (1/s).
    trace : ndarray
        tr M (±inf beyond float range).
    stable : bool ndarray
    label : int8 ndarray
        Index into :data:`BOUNDARIES` (0 stable, 1 T, 2 2T, 3 complex); names in
        :attr:`boundary`.
    omega_slow : ndarray (..., n)
        Slow angular frequencies of stable points (rad/s), NaN where unstable.
    liouville_residual, pairing_residual : ndarray
        The accuracy guards (see :class:`FloquetResult`).
    margin : ndarray
        Distance of the stability test from its threshold in units of its error
        bound; > 1 certifies the classification.
    flags : tuple of tuple of str
        Accuracy warnings per point, in flat (C) order of the grid.
    refined_points : int
        Points integrated again to the fine tolerance (``certify=True``).
    """

    multipliers: np.ndarray
    log_abs_multipliers: np.ndarray
    exponents: np.ndarray
    trace: np.ndarray
    stable: np.ndarray
    label: np.ndarray
    omega_slow: np.ndarray
    liouville_residual: np.ndarray
    pairing_residual: np.ndarray
    margin: np.ndarray
    flags: tuple
    refined_points: int

    @property
    def log_growth(self) -> np.ndarray:
        """max log|λ| per period and point (> 0 unstable)."""
        return self.log_abs_multipliers[..., 0]

    @property
    def boundary(self) -> np.ndarray:
        """Label names per point: "stable", "T", "2T" or "complex"."""
        return boundary_names(self.label)

    def point(self, index=()) -> FloquetResult:
        """The :class:`FloquetResult` of one grid point (``index`` into the grid's shape)."""
        index = tuple(np.ravel(index).astype(int).tolist())
        flat = int(np.ravel_multi_index(index, self.shape)) if index else 0
        return FloquetResult(
            period=float(self.period[index]), monodromy_scaled=self.monodromy_scaled[index],
            log_scale=float(self.log_scale[index]), multipliers=self.multipliers[index],
            log_abs_multipliers=self.log_abs_multipliers[index],
            trace=float(self.trace[index]), stable=bool(self.stable[index]),
            omega_slow=scalar_if_one(self.omega_slow[index]), exponents=self.exponents[index],
            boundary=BOUNDARIES[int(self.label[index])],
            error_estimate=float(self.error_estimate[index]), steps=int(self.steps[index]),
            samples=int(self.samples), liouville_residual=float(self.liouville_residual[index]),
            pairing_residual=float(self.pairing_residual[index]), flags=self.flags[flat])

    def to_dataframe(self):
        """One row per grid point: the parameters, stable, boundary, trace, log_growth,
        margin, error_estimate, steps, ..."""
        import pandas as pd
        cols = self._columns()
        cols.update(stable=np.ravel(self.stable), boundary=np.ravel(self.boundary),
                    trace=np.ravel(self.trace), log_growth=np.ravel(self.log_growth),
                    margin=np.ravel(self.margin))
        return pd.DataFrame(cols)

    def _labelled(self, matrices: bool = True) -> LabelledGrid:
        grid = super()._labelled(matrices)
        grid.attrs["refined_points"] = int(self.refined_points)
        dims = tuple(d for d in grid.dims if d not in ("row", "column"))
        grid.variable("stable", dims, np.asarray(self.stable, bool), None, "linearly stable")
        grid.label_variable("label", dims, self.label, "kind of the stability region",
                            BOUNDARIES)
        grid.variable("trace", dims, self.trace, "1", "trace of the monodromy matrix")
        grid.variable("log_growth", dims, self.log_growth, "1",
                      "largest log|λ| per drive period (> 0 unstable)")
        grid.variable("margin", dims, self.margin, "1",
                      "distance of the stability test from its threshold in error bounds "
                      "(> 1 certified)")
        grid.variable("multiplier", dims + ("multiplier",), self.multipliers, "1",
                      "Floquet multiplier λ (by decreasing modulus)")
        grid.variable("exponent", dims + ("multiplier",), self.exponents, "1/s",
                      "Floquet exponent log λ / T")
        grid.variable("omega_slow", dims + ("mode",),
                      np.asarray(self.omega_slow).reshape(self.shape + (-1,)), "rad/s",
                      "slow angular frequency of a stable mode (NaN where unstable)")
        grid.variable("liouville_residual", dims, self.liouville_residual, "1",
                      "|det M / exp(∮ tr J) − 1|")
        grid.variable("pairing_residual", dims, self.pairing_residual, "1",
                      "max |c_k − c_(2n−k)| of the characteristic polynomial (relative)")
        grid.variable("flags", dims, np.array(["; ".join(f) for f in self.flags],
                                              dtype=str).reshape(self.shape), None,
                      "accuracy warnings (empty: every guard passed)")
        return grid

    def to_xarray(self):
        """As :meth:`MonodromyData.to_xarray`, with the analysis per point: ``stable``,
        ``label`` (CF flags: stable, T, 2T, complex), ``trace``, ``log_growth``,
        ``margin``, ``multiplier_real``/``multiplier_imag`` and ``exponent_real``/
        ``exponent_imag`` (1/s) over ``multiplier``, ``omega_slow`` (rad/s) over ``mode``,
        the residuals and ``flags``."""
        return self._labelled().to_xarray()

    def figure(self, variable: str = "stable", **options):
        """One quantity over the grid's one or two varying axes (default ``stable``; e.g.
        ``"log_growth"``, ``"margin"``): :func:`kapitza.figures.grid_figure`
        (``options`` go to it).  Returns a :class:`matplotlib.figure.Figure`."""
        return display.draw("grid_figure", self._labelled(matrices=False), variable,
                            **options)

    def _repr_html_(self) -> str:
        rows = [("grid", " × ".join(map(str, self.shape)) or "one point")]
        rows += display.axis_rows(self.params)
        rows.append(("stable", display.share(self.stable)))
        rows.append(("error estimate", display.span(self.error_estimate) + " (of M)"))
        if self.refined_points:
            rows.append(("refined", f"{self.refined_points} points"))
        flagged = sum(bool(f) for f in self.flags)
        warnings = [f"{flagged} points flagged (e.g. "
                    f"{'; '.join(next(f for f in self.flags if f))})"] if flagged else []
        uncertain = int(np.count_nonzero(np.asarray(self.margin) <= 1))
        if uncertain:
            warnings.append(f"{uncertain} points uncertified (margin ≤ 1: the test is within "
                            "its error bound of the threshold)")
        drawable = 0 < len(self._varying()) and sum(n > 1 for n in self.shape) <= 2
        return display.card("FloquetGrid", "Floquet analysis", rows=rows, warnings=warnings,
                            figure=self.figure if drawable else None, alt="Floquet grid")
