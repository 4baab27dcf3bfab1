"""Results of direct simulation: what the full motion did, and periodic orbits.

:class:`Measurement` (:func:`kapitza.measure`, :func:`kapitza.measure_grid`) and
:class:`PeriodicOrbit` (:func:`kapitza.periodic_orbit`), both of
:mod:`kapitza.simulation`.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from . import _display as display
from ._xarray import LabelledGrid, coordinate_units

__all__ = ["Measurement", "PeriodicOrbit"]

#: Measurement fields with one entry per slow mode (ascending frequency) or per coordinate.
_MODE_FIELDS = ("omega_slow", "omega_slow_error", "refined", "growth_rate")
_COORDINATE_FIELDS = ("about", "amplitude", "mean_angle", "max_deviation")
_POINT_FIELDS = ("period", "stayed_up", "fall_time", "fit_residual", "samples",
                 "energy_drift", "status", "t_reached", "completed_periods")
#: Units and long names of the fields (to_xarray); None: per coordinate.
_QUANTITIES = {
    "period": ("s", "drive period T"), "stayed_up": (None, "stayed in the band throughout"),
    "fall_time": ("s", "time to leaving the band (NaN: stayed)"),
    "omega_slow": ("rad/s", "slow angular frequency Ω"),
    "omega_slow_error": ("rad/s", "error estimate of the slow angular frequency"),
    "refined": (None, "the slow frequency is the rotation number"),
    "growth_rate": ("1/s", "growth rate log|λ|/T of the mode's strobe-map eigenvalue"),
    "fit_residual": ("1", "relative residual of the linear strobe-map fit"),
    "about": (None, "state the band is centred on"),
    "amplitude": (None, "slow amplitude (half the strobe samples' range)"),
    "mean_angle": (None, "time average of the coordinate"),
    "max_deviation": (None, "largest distance from the state, fast motion included"),
    "energy_drift": ("J", "largest drift of the conserved energy"),
    "samples": ("1", "strobe samples recorded"), "status": (None, "how the run ended"),
    "t_reached": ("s", "time the run reached (its end, exit or interruption)"),
    "completed_periods": ("1", "whole drive periods simulated")}
#: Statuses of a run that measured something (the others are failed integrations).
_RAN = ("finished", "left_band")


@dataclass(frozen=True)
class Measurement:
    """What direct integration of the full nonlinear motion measured, point by point.

    Built by :func:`kapitza.measure_grid` (a broadcast grid: every field an array of the
    grid's shape S, followed by the axis stated), :func:`kapitza.measure` (one point: 0-d
    fields are Python scalars, and a one-coordinate system's per-mode and per-coordinate
    fields are floats) and :meth:`kapitza.KapitzaPendulum.measure` / ``measure_grid`` (one
    coordinate θ: those fields have the grid's shape).  How each number is measured, and
    what its error estimate covers, is in :mod:`kapitza.simulation`.

    Attributes
    ----------
    coordinates : tuple of str
        The system's coordinates, in order.
    params : dict of str to array
        Every parameter's value at every point (broadcast to S).
    about : array (S + (n,))
        The state the band is centred on: a driven equilibrium (the pendulum's
        θ = π) or an estimate of a periodic orbit's position (the tilt θ* of the
        horizontally driven pendulum) (rad for angles).
    period : array (S)
        The drive period T = 2π/ω (s); the strobe samples are t0 + kT.
    periods : int
        Drive periods simulated (K = periods + 1 strobe samples).
    stayed_up : bool array (S)
        The run finished without leaving the band |q_i − about_i| < band_i (for the
        inverted pendulum: it stayed up, |θ − π| < π/2 throughout); False where it
        left the band or the integration failed (see ``status``).
    fall_time : array (S)
        Time from the start to leaving the band (s); NaN where it did not.
    omega_slow : array (S + (n,)) or None
        Slow angular frequencies (rad/s) of the motion, ascending, from the
        stroboscopic samples up to the stop, folded into [0, ω/2] (aliasing); NaN where
        a mode is not resolved (too few samples, a real multiplier).  This field and
        the next four are None where they were not asked for (``observables``), as
        are ``amplitude`` and ``samples`` without the strobe samples.
    omega_slow_error : array (S + (n,))
        Error estimate of ``omega_slow`` (rad/s): the estimator's error for the
        simulated motion (the record's two halves, the fit's bias); not the
        integration error, not the amplitude dependence (see :mod:`kapitza.simulation`).
    refined : bool array (S + (n,))
        The mode's Ω is its rotation number (else the linear strobe map's value).
    growth_rate : array (S + (n,))
        log|λ| / T of each mode's strobe-map eigenvalue (1/s): ≈ 0 for a stable
        undamped oscillation, ≈ −γ/2 for the damped pendulum, > 0 growing.
    fit_residual : array (S)
        Relative residual of the linear strobe map fit: the harmonic content of the
        slow motion (≈ 0 for small oscillations).
    amplitude : array (S + (n,))
        Slow amplitude per coordinate: half the peak-to-peak range of the strobe
        samples q(t0 + kT) (rad for angles), which hold no fast motion.
    mean_angle : array (S + (n,))
        Time average of each coordinate over the run (rad for angles): the mean tilt
        of the horizontally driven pendulum.
    max_deviation : array (S + (n,))
        max |q − about| over the run, the fast motion included.
    energy_drift : array (S) or None
        max |E(t) − E(t0)| (J) where the system's energy function is conserved (no
        drive, forces or dissipation); None for a driven system, which has none.
    samples : int array (S)
        Strobe samples recorded (up to a stop).
    status : str array (S)
        How each run ended: "finished", "left_band", "underflow", "non_finite",
        "singular", "max_steps", or on Ctrl-C "interrupted" (stopped part-way: every
        field measures the run up to ``t_reached``) and "not_run"
        (:data:`lagrange_core.batch.STATUS_NAMES`).
    method : str
        The integration method.
    rtol : float
        Its relative tolerance.
    t_reached : array (S) or None
        The time each run reached (s): t0 + periods·T when it finished, where it left
        the band or failed, or where Ctrl-C stopped it.
    completed_periods : int array (S) or None
        Whole drive periods simulated up to ``t_reached``.
    """

    coordinates: tuple
    params: dict
    about: ArrayLike
    period: ArrayLike
    periods: int
    stayed_up: ArrayLike
    fall_time: ArrayLike
    omega_slow: ArrayLike | None
    omega_slow_error: ArrayLike | None
    refined: ArrayLike | None
    growth_rate: ArrayLike | None
    fit_residual: ArrayLike | None
    amplitude: ArrayLike | None
    mean_angle: ArrayLike
    max_deviation: ArrayLike
    energy_drift: ArrayLike | None
    samples: ArrayLike | None
    status: ArrayLike
    method: str
    rtol: float
    t_reached: ArrayLike | None = None
    completed_periods: ArrayLike | None = None

    @property
    def shape(self) -> tuple:
        """The grid's shape S (() for one point)."""
        return np.shape(self.stayed_up)

    def to_dataframe(self):
        """One row per point: the parameters, then every field (per-mode fields as
        ``omega_slow_0``, ``omega_slow_1``, ... in ascending order, per-coordinate fields
        as ``amplitude_<coordinate>``)."""
        import pandas as pd
        S = self.shape
        size = int(np.prod(S, dtype=np.int64))
        data = {k: np.ravel(np.broadcast_to(np.asarray(v), S)) for k, v in self.params.items()}
        for name in _POINT_FIELDS[:3] + _MODE_FIELDS + _COORDINATE_FIELDS + _POINT_FIELDS[3:]:
            value = getattr(self, name)
            if value is None:
                continue
            value = np.asarray(value)
            if value.ndim == len(S):
                data[name] = value.reshape(size)
                continue
            labels = (range(value.shape[-1]) if name in _MODE_FIELDS else self.coordinates)
            for j, label in enumerate(labels):
                data[f"{name}_{label}"] = value[..., j].reshape(size)
        return pd.DataFrame(data)

    def _labelled(self) -> LabelledGrid:
        S = self.shape
        grid = LabelledGrid("Measurement", method=self.method, rtol=self.rtol,
                            periods=int(self.periods))
        dims = grid.broadcast_axes(self.params, S)
        grid.drive_axes(*grid.pendulum_scales(self.params))
        grid.coord("coordinate", "coordinate", np.asarray(self.coordinates, dtype=str), None,
                   "coordinate of the system")
        known = {coordinate_units(c)[0] for c in self.coordinates}
        coordinate_unit = known.pop() if len(known) == 1 else None
        for name in _POINT_FIELDS[:3] + _MODE_FIELDS + _COORDINATE_FIELDS + _POINT_FIELDS[3:]:
            value = getattr(self, name)
            if value is None:
                continue
            value = np.asarray(value)
            units, long_name = _QUANTITIES[name]
            if name in _POINT_FIELDS:
                grid.variable(name, dims, np.broadcast_to(value, S), units, long_name)
                continue
            if value.ndim == len(S):
                value = value[..., None]            # one coordinate: no trailing axis
            extra = "mode" if name in _MODE_FIELDS else "coordinate"
            if name in _COORDINATE_FIELDS:
                units = coordinate_unit
            grid.variable(name, dims + (extra,), value, units, long_name)
        return grid

    def to_xarray(self):
        """The measurement as an :class:`xarray.Dataset`: the grid's axes named by the
        parameters that vary along them (``A`` in m, ``omega`` in rad/s, with ``A_over_l``
        and ``omega_over_omega0`` for a pendulum; ``axis_<k>`` where no parameter varies,
        e.g. over initial states), every field as a variable (per-mode fields over
        ``mode``, per-coordinate fields over ``coordinate``), the method, ``rtol`` and the
        periods in ``attrs``.  Needs ``pip install "kapitza[xarray]"``."""
        return self._labelled().to_xarray()

    def figure(self, variable: str | None = None, **options):
        """One quantity over the grid's one or two varying axes:
        :func:`kapitza.figures.grid_figure`.  Default: the slow frequency of the lowest
        mode where the run stayed in the band, the runs that left it grey (the fall
        time if none stayed).  ``variable`` names another field (``"fall_time"``,
        ``"amplitude"``, …); ``options`` go to the figure function.

        Raises
        ------
        ValueError
            A measurement of one point (nothing to draw over).
        """
        if not self.shape or int(np.prod(self.shape)) < 2:
            raise ValueError("a Measurement of one point has no figure; measure a grid "
                             "(kapitza.measure_grid) to draw one.")
        grid = self._labelled()
        stayed = np.asarray(self.stayed_up, bool)
        if variable is None:
            variable = ("omega_slow" if stayed.any() and self.omega_slow is not None
                        else "fall_time")
            if variable == "omega_slow":
                options.setdefault("select", {"mode": 0})
                options.setdefault("mask", ~stayed[..., None])
                options.setdefault("mask_label", "left the band")
        return display.draw("grid_figure", grid, variable, **options)

    def _repr_html_(self) -> str:
        S = self.shape
        status = np.asarray(self.status).reshape(-1)
        failed = status[~np.isin(status, _RAN)]
        warnings = [f"{failed.size} of {status.size} runs failed ("
                    + ", ".join(f"{k}: {int((failed == k).sum())}" for k in np.unique(failed))
                    + ")"] if failed.size else []
        slow = np.asarray(self.omega_slow, dtype=float)
        error = np.asarray(self.omega_slow_error, dtype=float)
        if not S:
            stayed = bool(self.stayed_up)
            slow, error = np.atleast_1d(slow), np.atleast_1d(error)
            rows = [("Ω", ", ".join(display.quantity(w, "rad/s", e)
                                    for w, e in zip(slow, error, strict=True))),
                    ("growth rate", ", ".join(display.quantity(r, "1/s") for r in
                                              np.atleast_1d(np.asarray(self.growth_rate,
                                                                       dtype=float)))),
                    ("amplitude", ", ".join(
                        display.quantity(a, coordinate_units(c)[0] or "")
                        for a, c in zip(np.atleast_1d(np.asarray(self.amplitude, float)),
                                        self.coordinates, strict=True))),
                    ("mean", ", ".join(
                        display.quantity(a, coordinate_units(c)[0] or "", digits=6)
                        for a, c in zip(np.atleast_1d(np.asarray(self.mean_angle, float)),
                                        self.coordinates, strict=True))),
                    ("run", f"{self.periods} periods of T = "
                            f"{display.quantity(self.period, 's')}; {np.asarray(self.status)}")]
            badges = [("stayed", "good") if stayed else
                      (f"left at t = {display.quantity(self.fall_time, 's')}", "bad")]
            return display.card("Measurement", f"{', '.join(self.coordinates)} · "
                                f"{self.method}", rows=rows, badges=badges,
                                warnings=warnings)
        rows = [("grid", " × ".join(map(str, S)))]
        rows += display.axis_rows(self.params)
        lowest = slow if slow.ndim <= len(S) else slow[..., 0]     # (None: not measured)
        rows += [("stayed", display.share(self.stayed_up, "runs")),
                 ("Ω (lowest mode)", display.span(lowest, "rad/s")),
                 ("Ω error", display.span(error, "rad/s")),
                 ("run", f"{self.periods} periods each, rtol {display.number(self.rtol, 2)}")]
        drawable = sum(n > 1 for n in S) in (1, 2)
        return display.card("Measurement", f"{', '.join(self.coordinates)} · {self.method}",
                            rows=rows, warnings=warnings,
                            figure=self.figure if drawable else None, alt="measurement grid")


@dataclass(frozen=True, eq=False)
class PeriodicOrbit:
    """A periodic orbit of a driven system and its Floquet stability (immutable).

    Built by :func:`kapitza.periodic_orbit` (Newton shooting on the period map; its
    docstring states the method and the accuracy).

    Attributes
    ----------
    coordinates : tuple of str
    params : dict
        The parameter values (scalars).
    period : float
        The orbit's period (s): ``periods`` × 2π/ω.
    periods : int
        Drive periods per orbit period (1: T-periodic; 2: a subharmonic orbit).
    state : ndarray (2n,)
        [q, q̇] on the orbit at t = 0 (the drive's phase zero).
    q_mean : ndarray (n,)
        Mean of q over one period (the slow state of averaging).
    amplitude : ndarray (n,)
        Half the peak-to-peak range of q over one period (the fast motion).
    multipliers : ndarray, complex (2n,)
        Eigenvalues of the monodromy, by decreasing modulus.
    monodromy : ndarray (2n, 2n) or None
        The monodromy matrix (None for a persisting equilibrium, analysed by
        :func:`kapitza.floquet_point`).
    stable : bool
        Every |λ| ≤ 1 up to the error (see :func:`kapitza.periodic_orbit`).
    omega_slow : float or ndarray (n,)
        Slow frequency |arg λ|/T of each stable pair (rad/s, in [0, ω/2]); NaN if
        unstable; a float for one coordinate.
    residual : float
        The residual of the equations shot at the returned state: |φ_T(y0) − y0|, or for
        a symmetric orbit shot on the half period |φ_{T/2}(y0) − S y0|.
    error_estimate : float
        A bound on the error of the state and the monodromy (the larger): the
        Newton–Kantorovich bound for the state (β = ‖J⁻¹‖ of the Newton matrix J of the
        equations shot, η ≥ ‖J⁻¹F‖, K J's Lipschitz constant measured near the orbit;
        ≤ 2η/(1 + √(1 − 2βKη)), integration errors included) and the monodromy's
        integration error plus its change over the state's error ball.  inf where no
        bound can be established (βKη > 1/2: near a multiplier +1 of the map shot), the
        reason in ``flags``.
    iterations : int
        Newton steps taken (0: a persisting equilibrium).
    method : str
        Which map was shot ("period map", "half-period map (symmetric)"), whether by
        multiple shooting (one segment per drive period) or for a rotating orbit, and,
        where it is ill-conditioned, by how much.
    condition : float
        ‖J⁻¹‖∞ of the Newton matrix of the equations shot (NaN for a persisting
        equilibrium): how much a residual is amplified into an error of the state.
    flags : tuple of str
        Accuracy warnings (each also raised as a RuntimeWarning); empty when the
        orbit is decided to its tolerance.
    """

    coordinates: tuple
    params: dict
    period: float
    periods: int
    state: np.ndarray
    q_mean: np.ndarray
    amplitude: np.ndarray
    multipliers: np.ndarray
    monodromy: np.ndarray | None
    stable: bool
    omega_slow: float | np.ndarray
    residual: float
    error_estimate: float
    iterations: int
    method: str
    condition: float = math.nan
    flags: tuple = ()

    def to_dataframe(self):
        """One row per coordinate: state at t = 0, period mean, fast amplitude (and the
        orbit's period, stability and slow frequency repeated)."""
        import pandas as pd
        n = len(self.coordinates)
        slow = np.broadcast_to(np.asarray(self.omega_slow, dtype=float), (n,))
        return pd.DataFrame({"q0": self.state[:n], "qdot0": self.state[n:],
                             "q_mean": self.q_mean, "amplitude": self.amplitude,
                             "omega_slow": slow, "period": self.period, "stable": self.stable},
                            index=pd.Index(self.coordinates, name="coordinate"))

    def _repr_html_(self) -> str:
        n = len(self.coordinates)
        slow = np.atleast_1d(np.asarray(self.omega_slow, dtype=float))

        def units(c):
            return coordinate_units(c)[0] or ""

        rows = [("period", display.quantity(self.period, "s")
                 + (f" ({self.periods} drive periods)" if self.periods > 1 else "")),
                ("q(0)", ", ".join(f"{c} = {display.quantity(q, units(c), digits=8)}"
                                   for c, q in zip(self.coordinates, self.state[:n],
                                                   strict=True))),
                ("mean q", ", ".join(display.quantity(q, units(c), digits=6)
                                     for c, q in zip(self.coordinates, self.q_mean,
                                                     strict=True))),
                ("fast amplitude", ", ".join(display.quantity(q, units(c))
                                             for c, q in zip(self.coordinates, self.amplitude,
                                                             strict=True))),
                ("max |λ|", display.number(np.max(np.abs(self.multipliers)), 8)),
                ("Ω", ", ".join(display.quantity(w, "rad/s", digits=8) for w in slow)),
                ("residual", display.number(self.residual, 2)),
                ("error estimate", display.number(self.error_estimate, 2)),
                ("Newton", f"{self.iterations} iterations, condition "
                           f"{display.number(self.condition, 2)}")]
        badges = [("stable", "good") if self.stable else ("unstable", "bad")]
        if self.flags:
            badges.append(("flagged", "warn"))
        return display.card("PeriodicOrbit", self.method, rows=rows, badges=badges,
                            warnings=self.flags)
