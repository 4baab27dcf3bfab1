"""Results of verification: the four methods side by side, and the measured order of averaging.

:class:`Verification` (:func:`kapitza.verify`, :meth:`kapitza.KapitzaPendulum.verify`)
holds every method's classification, slow frequencies and their stated errors per grid
point; :class:`OrderFit` the order of averaging measured along a line of drives.

Why the comparison is here and not in :mod:`kapitza.verification`: two methods agree
when their fields say so (the same classification; |Ω_a − Ω_b| ≤ tolerance_a +
tolerance_b), a rule on this result's own numbers, like a map's ``boundary`` names.
:mod:`kapitza.verification` computes the numbers and the tolerances; the result reads
them, and the figures (a room below the analyses, which they may not import) ask the
result.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from . import _display as display
from ._maps import StabilityWindow
from ._xarray import LabelledGrid

__all__ = ["VERIFICATION_METHODS", "OrderFit", "Verification"]

#: The methods a :class:`Verification` compares: first-order averaging, next-order
#: averaging, Floquet analysis (exact, linear) and direct simulation (full, nonlinear).
VERIFICATION_METHODS = ("averaging", "averaging_2", "floquet", "simulation")
#: Simulation statuses that classify a point (the others are failed integrations).
_CLASSIFIED = ("finished", "left_band")
#: What two methods are compared on: the classification, and the slow frequency Ω.
_QUANTITIES = ("stability", "omega_slow")


def _at(x, j):
    """Row i's entry x[i, j[i]] of a (points, modes) array."""
    return np.take_along_axis(x, j, axis=1)[:, 0]


@dataclass(frozen=True)
class OrderFit:
    """The order of an averaging approximation, measured: its relative error in Ω
    against Floquet's exact Ω along a line of drives, fitted as c ε^p.

    Built by :func:`kapitza.verify` (and :meth:`kapitza.KapitzaPendulum.verify`); the line
    and the small parameter ε are stated in ``small_parameter`` (the default line keeps
    the drive's velocity A ω fixed, so that the first-order prediction is fixed and ω0/ω
    and A/l shrink together; see :mod:`kapitza.verification`).

    Attributes
    ----------
    order : int
        1 (first-order averaging) or 2 (next order).
    small_parameter : str
        What ε is and along which line, e.g. "ε = ω0/ω along A ω = 2 √(g l)".
    epsilon, omega, A : ndarray (k,)
        ε, the drive frequency (rad/s) and amplitude (m) of each point of the line.
    error : ndarray (k,)
        |Ω_averaging − Ω_Floquet| / Ω_Floquet (largest over the slow modes).
    floor : ndarray (k,)
        Floquet's own relative error bound on Ω (the fit leaves out points whose
        error is not above ``RESOLVED`` × floor, :mod:`kapitza.verification`).
    used : bool ndarray (k,)
        The points fitted.
    exponent, exponent_error : float
        p of the least-squares line log error = log c + p log ε, and its standard
        error (from the residuals); NaN with fewer than 3 points used.
    prefactor : float
        c.
    theory : float
        The exponent theory predicts (2 for order 1, 4 for order 2; NaN if unknown).
    """

    order: int
    small_parameter: str
    epsilon: np.ndarray
    omega: np.ndarray
    A: np.ndarray
    error: np.ndarray
    floor: np.ndarray
    used: np.ndarray
    exponent: float
    exponent_error: float
    prefactor: float
    theory: float

    def to_dataframe(self):
        """One row per point of the line: epsilon, omega, A, error, floor, used (and order)."""
        import pandas as pd
        return pd.DataFrame({"epsilon": self.epsilon, "omega": self.omega, "A": self.A,
                             "error": self.error, "floor": self.floor, "used": self.used,
                             "order": self.order})

    def _labelled(self) -> LabelledGrid:
        grid = LabelledGrid("OrderFit", order=self.order, small_parameter=self.small_parameter,
                            exponent=self.exponent, exponent_error=self.exponent_error,
                            prefactor=self.prefactor, theory=self.theory,
                            method="least squares, log error = log c + p log ε")
        grid.coord("epsilon", "epsilon", self.epsilon, "1", f"small parameter: "
                   f"{self.small_parameter}")
        grid.coord("omega", "epsilon", self.omega, "rad/s", "drive angular frequency ω")
        grid.coord("A", "epsilon", self.A, "m", "drive amplitude A")
        grid.variable("error", "epsilon", self.error, "1",
                      "relative error of averaging's Ω against Floquet's")
        grid.variable("floor", "epsilon", self.floor, "1", "Floquet's relative error bound on Ω")
        grid.variable("used", "epsilon", np.asarray(self.used, bool), None, "point fitted")
        return grid

    def to_xarray(self):
        """The line as an :class:`xarray.Dataset` over ``epsilon`` (with ``omega`` and
        ``A`` beside it): ``error``, ``floor``, ``used``; the fit in ``attrs``.  Needs
        ``pip install "kapitza[xarray]"``."""
        return self._labelled().to_xarray()

    def _text(self) -> str:
        return (f"p = {display.quantity(self.exponent, '', self.exponent_error)} "
                f"(theory {display.number(self.theory)})")

    def _repr_html_(self) -> str:
        used = int(np.count_nonzero(self.used))
        warnings = []
        if used < 3:
            warnings.append(f"only {used} points resolved above Floquet's floor: no exponent")
        elif abs(self.exponent - self.theory) > 3 * self.exponent_error:
            warnings.append("the exponent differs from theory by more than 3 standard errors")
        return display.card(
            "OrderFit", f"averaging of order {self.order}",
            rows=[("exponent", self._text()), ("ε", self.small_parameter),
                  ("points", f"{used} of {np.size(self.used)} fitted"),
                  ("error", display.span(self.error) + " (relative)")],
            warnings=warnings)


@dataclass(frozen=True)
class Verification:
    """Averaging, Floquet analysis and direct simulation of one driven equilibrium,
    compared point by point over a broadcast (A, ω) grid.

    Built by :func:`kapitza.verify` (any driven system) and
    :meth:`kapitza.KapitzaPendulum.verify`; how each number is obtained, and the
    tolerances, are in :mod:`kapitza.verification`.  Method names:
    :data:`VERIFICATION_METHODS` ("averaging" is first order, "averaging_2" the next
    order, absent (None fields) where there is none).  The methods compare the fields
    (:meth:`compare`, :attr:`agreement`, :attr:`disagreements`) and draw them
    (:meth:`figure`); they compute no physics.

    Per-point fields have the grid's shape S; the slow frequencies and their
    tolerances have shape S for a system of one coordinate and S + (n,) otherwise
    (modes in ascending order of Ω).

    Attributes
    ----------
    A, omega : ndarray (S)
        Drive amplitude (units of the amplitude parameter; m for a pivot) and angular
        frequency (rad/s) of every point.
    about : str
        The equilibrium verified ("inverted", or the coordinates as text).
    length, omega0 : float or None
        The length and frequency that make A/l and ω/ω0 (the pendulum's l and √(g/l));
        None where not given.
    stable_averaging, stable_averaging_2, stable_floquet, stable_simulation : bool ndarray (S)
        The classification by each method: linear stability of the averaged motion
        (first and next order), of the exact linearisation (Floquet), and "stayed
        near the equilibrium" in the full simulation (the band of
        :func:`kapitza.measure_grid`; for the pendulum |θ − π| < π/2 throughout).
    omega_slow_averaging, omega_slow_averaging_2, omega_slow_floquet, omega_slow_simulation
        Ω (rad/s) by each method, NaN where that method finds no stable oscillation
        (the simulation's Ω is measured up to a fall; it is compared only where the
        run stayed up).  With damping, the damped slow frequency.
    tolerance_averaging, tolerance_averaging_2, tolerance_floquet, tolerance_simulation
        Each method's stated error of its Ω (rad/s; inf: no claim).  Two methods
        agree on Ω when |Ω_a − Ω_b| ≤ tolerance_a + tolerance_b for every mode.
    averaging_valid : bool ndarray (S)
        First-order averaging's own validity flag (``valid`` of its prediction).
    floquet_margin : ndarray (S)
        Distance of the Floquet stability test from its threshold in units of its
        error bound (> 1: certified).
    simulation_status : str ndarray (S)
        How each run ended ("finished", "left_band", or a failure, which leaves the
        point unclassified by simulation).
    fall_time : ndarray (S)
        Time to leaving the band (s), NaN where the run stayed.
    amplitude : ndarray (S)
        The simulated slow amplitude (largest over the coordinates).
    boundary_distance : ndarray (S)
        |A − A_b| / A to the nearest Floquet stability boundary A_b at the point's ω
        (along A); inf where none was found (see :mod:`kapitza.verification` for where
        each builder looks), NaN where not located.
    nearest_boundary : ndarray (S)
        That A_b (NaN where none).
    boundary_A, boundary_omega : ndarray (m,)
        Every boundary located at the grid's frequencies (for the figure).
    window : StabilityWindow or None
        The exact window on a fine ω grid over the grid's range (the pendulum), drawn
        as the boundary lines; None for a general system.
    fits : tuple of OrderFit
        The order of averaging, measured (order 1, and 2 where there is a next order);
        empty if not computed.
    periods : int
        Drive periods simulated per point.
    tol, rtol : float
        Floquet's tolerance and the simulation's relative tolerance.
    notes : tuple of str
        What was not available or not located, said once.
    averaging_2_valid : bool ndarray (S) or None
        Next-order averaging's own validity flag (``valid`` of its prediction); None where
        there is no next order, or where it was not given (then next-order averaging
        claims validity at every point).

    Notes
    -----
    Where a method claims validity.  A disagreement counts against the methods
    (:attr:`disagreements_within_validity`; ``kapitza verify`` exits 1) only where both
    claim validity at the point (:meth:`valid`): first-order averaging where
    ``averaging_valid`` (its fast-drive, small-amplitude and convergence criteria; it
    cannot see the upright pendulum's upper edge A_max, 0.454 l as ω → ∞, and flags
    every A/l > 0.3 invalid), next-order averaging where ``averaging_2_valid``, Floquet where
    its classification is certified (``floquet_margin`` > 1), simulation where the run
    classified the point.  The rest are reported, not failed: :attr:`outside_validity`
    lists every point outside a method's validity, and the ``within_validity`` column of
    :attr:`disagreements` marks the disagreements that count.
    """

    A: np.ndarray
    omega: np.ndarray
    about: str
    length: float | None
    omega0: float | None
    stable_averaging: np.ndarray
    stable_averaging_2: np.ndarray | None
    stable_floquet: np.ndarray
    stable_simulation: np.ndarray
    omega_slow_averaging: np.ndarray
    omega_slow_averaging_2: np.ndarray | None
    omega_slow_floquet: np.ndarray
    omega_slow_simulation: np.ndarray
    tolerance_averaging: np.ndarray
    tolerance_averaging_2: np.ndarray | None
    tolerance_floquet: np.ndarray
    tolerance_simulation: np.ndarray
    averaging_valid: np.ndarray
    floquet_margin: np.ndarray
    simulation_status: np.ndarray
    fall_time: np.ndarray
    amplitude: np.ndarray
    boundary_distance: np.ndarray
    nearest_boundary: np.ndarray
    boundary_A: np.ndarray
    boundary_omega: np.ndarray
    window: StabilityWindow | None
    fits: tuple
    periods: int
    tol: float
    rtol: float
    notes: tuple = ()
    averaging_2_valid: np.ndarray | None = None

    @property
    def shape(self) -> tuple:
        """The grid's shape S."""
        return np.shape(self.stable_floquet)

    @property
    def methods(self) -> tuple:
        """The methods present (next-order averaging only where there is one)."""
        return tuple(m for m in VERIFICATION_METHODS if getattr(self, f"stable_{m}") is not None)

    def valid(self, method: str) -> np.ndarray:
        """Where ``method`` claims validity (class docstring): a bool ndarray (S).

        Parameters
        ----------
        method : str
            A method of :attr:`methods`.

        Raises
        ------
        ValueError
            A method this verification does not have.
        """
        if method not in self.methods:
            raise ValueError(f"no method {method!r} in this verification; it has "
                             f"{list(self.methods)}.")
        flag: object
        if method == "averaging":
            flag = self.averaging_valid
        elif method == "averaging_2":
            flag = True if self.averaging_2_valid is None else self.averaging_2_valid
        elif method == "floquet":
            with np.errstate(invalid="ignore"):
                flag = np.asarray(self.floquet_margin, dtype=float) > 1.0
        else:
            flag = np.isin(self.simulation_status, _CLASSIFIED)
        return np.array(np.broadcast_to(np.asarray(flag, bool), self.shape))

    @property
    def outside_validity(self):
        """Every point outside a method's validity (:meth:`valid`), one row per method and
        point: method, point (flat index), the point's location (A, ω, A/l, ω/ω0, boundary
        distance) and why.  Disagreements at these points are reported, not counted
        against the methods."""
        import pandas as pd
        where = self._location()
        why = {"averaging": "first-order averaging flags itself invalid (averaging_valid)",
               "averaging_2": "next-order averaging flags itself invalid",
               "floquet": "Floquet's classification is not certified (floquet_margin ≤ 1)"}
        frames = []
        for m in self.methods:
            out = np.flatnonzero(~np.ravel(self.valid(m)))
            if not out.size:
                continue
            reason = (np.char.add("the run did not classify the point: ",
                                  np.ravel(self.simulation_status)[out].astype(str))
                      if m == "simulation" else why[m])
            frames.append(pd.DataFrame({"method": m, "point": out,
                                        **{k: v[out] for k, v in where.items()},
                                        "reason": reason}))
        if not frames:
            return pd.DataFrame(columns=["method", "point", *where, "reason"])
        return pd.concat(frames, ignore_index=True)

    @property
    def disagreements_within_validity(self):
        """The rows of :attr:`disagreements` where both methods claim validity at the point:
        the disagreements that count against the methods (``kapitza verify`` exits 1 on
        any)."""
        bad = self.disagreements
        return bad[bad["within_validity"].astype(bool)].reset_index(drop=True)

    @property
    def exponent(self) -> float:
        """The fitted order of first-order averaging's relative error in Ω (NaN if not fitted)."""
        return self._fit(1, "exponent")

    @property
    def exponent_error(self) -> float:
        """Standard error of :attr:`exponent`."""
        return self._fit(1, "exponent_error")

    @property
    def exponent_theory(self) -> float:
        """The exponent theory gives for first-order averaging (2)."""
        return self._fit(1, "theory")

    def _fit(self, order, name):
        for f in self.fits:
            if f.order == order:
                return getattr(f, name)
        return math.nan

    def modes(self, name: str) -> np.ndarray:
        """A slow-frequency field with its mode axis always present: shape S + (n,).

        Parameters
        ----------
        name : str
            ``"omega_slow_<method>"`` or ``"tolerance_<method>"`` for a method of
            :attr:`methods`, e.g. ``"omega_slow_floquet"``.

        Returns
        -------
        float ndarray (S + (n,))
            The field (rad/s), with a last axis of length 1 for a system of one
            coordinate (whose fields have shape S), as is for several (S + (n,), modes in
            ascending order of Ω).

        Raises
        ------
        ValueError
            ``name`` is not such a field of this verification.
        """
        allowed = [f"{kind}_{m}" for kind in ("omega_slow", "tolerance") for m in self.methods]
        if name not in allowed:
            raise ValueError(f"Verification.modes: no field {name!r} here; pass one of "
                             f"{allowed}.")
        x = np.asarray(getattr(self, name), dtype=float)
        return x[..., None] if x.ndim == len(self.shape) else x

    def compare(self, first: str, second: str, quantity: str = "stability"):
        """Which points two methods were compared on, and which of them agree.

        Parameters
        ----------
        first, second : str
            Method names (:data:`VERIFICATION_METHODS`).
        quantity : {"stability", "omega_slow"}
            The classification (compared wherever both methods classified the point;
            simulation failures are not), or Ω (compared where both call the point
            stable and give a finite Ω for some mode; agree when |Ω_a − Ω_b| ≤
            tolerance_a + tolerance_b for every such mode).

        Returns
        -------
        compared, agree : bool ndarray (S)
            ``agree`` is True where the point was not compared.

        Raises
        ------
        ValueError
            A method this verification does not have, or another quantity.
        """
        for m in (first, second):
            if m not in self.methods:
                raise ValueError(f"no method {m!r} in this verification; it has "
                                 f"{list(self.methods)}.")
        if quantity not in _QUANTITIES:
            raise ValueError(f"quantity must be 'stability' or 'omega_slow', got {quantity!r}.")
        sa, sb = (np.asarray(getattr(self, f"stable_{m}"), bool) for m in (first, second))
        compared = np.ones(self.shape, bool)
        if "simulation" in (first, second):
            compared &= np.isin(self.simulation_status, _CLASSIFIED)
        if quantity == "stability":
            return compared, ~compared | (sa == sb)
        wa, wb = (self.modes(f"omega_slow_{m}") for m in (first, second))
        ta, tb = (self.modes(f"tolerance_{m}") for m in (first, second))
        both = np.isfinite(wa) & np.isfinite(wb)
        with np.errstate(invalid="ignore"):
            close = ~both | (np.abs(wa - wb) <= ta + tb)
        compared &= sa & sb & both.any(axis=-1)
        return compared, ~compared | close.all(axis=-1)

    def _comparisons(self):
        """(first, second, quantity, compared, agree) for every pair of methods and quantity."""
        ms = self.methods
        for i, a in enumerate(ms):
            for b in ms[i + 1:]:
                for quantity in _QUANTITIES:
                    yield (a, b, quantity, *self.compare(a, b, quantity))

    @property
    def agreement(self):
        """Agreement statistics: one row per pair of methods and quantity ("stability",
        "omega_slow") with the points compared, agreeing, disagreeing, the fraction
        agreeing (NaN where none was compared) and the disagreements where both methods
        claim validity (``disagreeing_within_validity``, :meth:`valid`)."""
        import pandas as pd
        rows = []
        for a, b, quantity, compared, agree in self._comparisons():
            n, k = int(compared.sum()), int((compared & agree).sum())
            counted = int((compared & ~agree & self.valid(a) & self.valid(b)).sum())
            rows.append({"first": a, "second": b, "quantity": quantity, "compared": n,
                         "agreeing": k, "disagreeing": n - k,
                         "fraction": k / n if n else math.nan,
                         "disagreeing_within_validity": counted})
        return pd.DataFrame(rows)

    def _location(self) -> dict:
        """Per-point columns that locate a point (flat, C order)."""
        cols = {"A": np.ravel(self.A), "omega": np.ravel(self.omega)}
        if self.length is not None:
            cols["A_over_l"] = np.ravel(self.A) / self.length
        if self.omega0 is not None:
            cols["omega_over_omega0"] = np.ravel(self.omega) / self.omega0
        cols.update(boundary_distance=np.ravel(self.boundary_distance),
                    nearest_boundary=np.ravel(self.nearest_boundary))
        return cols

    @property
    def disagreements(self):
        """Every disagreement, located: one row per point, pair of methods and quantity
        that disagree, with the point's A, ω (A/l, ω/ω0), distance to the nearest Floquet
        boundary, both methods' classifications and Ω (the mode that differs most,
        relative to the tolerance), the tolerance, first-order averaging's validity, the
        simulation's status and ``within_validity`` (both methods claim validity at the
        point, :meth:`valid`: the disagreement counts against them)."""
        import pandas as pd
        where = self._location()
        frames = []
        for a, b, quantity, compared, agree in self._comparisons():
            bad = np.flatnonzero(np.ravel(compared & ~agree))
            if not bad.size:
                continue
            wa, wb = (self.modes(f"omega_slow_{m}") for m in (a, b))
            wa, wb = (x.reshape(-1, x.shape[-1])[bad] for x in (wa, wb))
            tt = self.modes(f"tolerance_{a}") + self.modes(f"tolerance_{b}")
            tt = tt.reshape(-1, tt.shape[-1])[bad]
            with np.errstate(invalid="ignore", divide="ignore"):
                score = np.where(np.isfinite(wa) & np.isfinite(wb), np.abs(wa - wb) / tt,
                                 -np.inf)
            j = np.argmax(score, axis=1)[:, None]      # the mode that differs most
            frames.append(pd.DataFrame({
                "point": bad, **{k: v[bad] for k, v in where.items()},
                "quantity": quantity, "first": a, "second": b,
                "first_stable": np.ravel(getattr(self, f"stable_{a}"))[bad],
                "second_stable": np.ravel(getattr(self, f"stable_{b}"))[bad],
                "first_omega_slow": _at(wa, j), "second_omega_slow": _at(wb, j),
                "tolerance": _at(tt, j) if quantity == "omega_slow" else math.nan,
                "averaging_valid": np.ravel(self.averaging_valid)[bad],
                "simulation_status": np.ravel(self.simulation_status)[bad],
                "within_validity": np.ravel(self.valid(a) & self.valid(b))[bad]}))
        if not frames:
            return pd.DataFrame(columns=["point", *where, "quantity", "first", "second",
                                         "first_stable", "second_stable", "first_omega_slow",
                                         "second_omega_slow", "tolerance", "averaging_valid",
                                         "simulation_status", "within_validity"])
        return pd.concat(frames, ignore_index=True)

    def to_dataframe(self):
        """One row per point: A, omega (A_over_l, omega_over_omega0), boundary_distance,
        nearest_boundary, then per method stable_<method>, omega_slow_<method> and
        tolerance_<method> (``_0``, ``_1``, ... per mode for several coordinates), then
        averaging_valid, floquet_margin, simulation_status, fall_time, amplitude and
        disagreements (the pairs of methods that disagree at the point, "; "-joined)."""
        import pandas as pd
        data = self._location()
        for m in self.methods:
            data[f"stable_{m}"] = np.ravel(getattr(self, f"stable_{m}"))
            for name in (f"omega_slow_{m}", f"tolerance_{m}"):
                x = np.asarray(getattr(self, name), dtype=float)
                if x.ndim == len(self.shape):
                    data[name] = np.ravel(x)
                else:
                    for k in range(x.shape[-1]):
                        data[f"{name}_{k}"] = x[..., k].ravel()
        data.update(averaging_valid=np.ravel(self.averaging_valid),
                    floquet_margin=np.ravel(self.floquet_margin),
                    simulation_status=np.ravel(self.simulation_status),
                    fall_time=np.ravel(self.fall_time), amplitude=np.ravel(self.amplitude))
        labels: list[list[str]] = [[] for _ in range(int(np.prod(self.shape, dtype=np.int64)))]
        for a, b, quantity, compared, agree in self._comparisons():
            for i in np.flatnonzero(np.ravel(compared & ~agree)):
                labels[i].append(f"{a}≠{b} ({quantity})")
        data["disagreements"] = ["; ".join(x) for x in labels]
        return pd.DataFrame(data)

    def figure(self, **options):
        """The verification map with every disagreement marked, and the measured order
        of averaging: :func:`kapitza.figures.verification_figure` (``options`` go to it).
        Returns a :class:`matplotlib.figure.Figure`."""
        from ..figures import verification_figure  # lazily: results never import figures at load
        return verification_figure(self, **options)

    def _labelled(self) -> LabelledGrid:
        S = self.shape
        grid = LabelledGrid("Verification", about=str(self.about), periods=int(self.periods),
                            tol=self.tol, rtol=self.rtol, notes=list(self.notes),
                            methods=list(self.methods),
                            method="averaging, Floquet analysis and direct simulation, "
                                   "compared point by point")
        dims = grid.broadcast_axes({"A": self.A, "omega": self.omega}, S)
        omega0 = self.omega0
        grid.drive_axes(self.length, omega0)
        if self.length is not None:
            grid.parameters({"l": self.length})
        for fit in self.fits:
            for name in ("exponent", "exponent_error", "theory"):
                grid.attrs[f"order_{fit.order}_{name}"] = getattr(fit, name)
            grid.attrs[f"order_{fit.order}_small_parameter"] = fit.small_parameter
        names = {"averaging": "first-order averaging", "averaging_2": "next-order averaging",
                 "floquet": "Floquet analysis", "simulation": "direct simulation"}
        for m in self.methods:
            grid.variable(f"stable_{m}", dims, np.asarray(getattr(self, f"stable_{m}"), bool),
                          None, f"stable by {names[m]}")
            grid.variable(f"omega_slow_{m}", dims + ("mode",), self.modes(f"omega_slow_{m}"),
                          "rad/s", f"slow angular frequency by {names[m]}")
            grid.variable(f"tolerance_{m}", dims + ("mode",), self.modes(f"tolerance_{m}"),
                          "rad/s", f"stated error of {names[m]}'s slow frequency")
        grid.variable("averaging_valid", dims, np.asarray(self.averaging_valid, bool), None,
                      "first-order averaging's own validity flag")
        second = getattr(self, "averaging_2_valid", None)
        if second is not None:
            grid.variable("averaging_2_valid", dims, np.asarray(second, bool), None,
                          "next-order averaging's own validity flag")
        for name, units, long_name in (
                ("floquet_margin", "1", "distance of Floquet's test from its threshold in "
                                        "error bounds (> 1 certified)"),
                ("simulation_status", None, "how the simulated run ended"),
                ("fall_time", "s", "time to leaving the band (NaN: stayed)"),
                ("amplitude", None, "simulated slow amplitude (largest over coordinates)"),
                ("boundary_distance", "1", "|A − A_b|/A to the nearest Floquet boundary"),
                ("nearest_boundary", "m", "nearest Floquet boundary A_b at the point's ω")):
            grid.variable(name, dims, np.asarray(getattr(self, name)), units, long_name)
        labels = self.to_dataframe()["disagreements"].to_numpy(dtype=str).reshape(S)
        grid.variable("disagreements", dims, labels, None,
                      "pairs of methods that disagree at the point")
        grid.variable("boundary_A", "boundary_point", self.boundary_A, "m",
                      "a Floquet boundary located at the grid's frequencies")
        grid.variable("boundary_omega", "boundary_point", self.boundary_omega, "rad/s",
                      "its drive angular frequency")
        if self.window is not None:
            w = np.atleast_1d(np.asarray(self.window.omega, float))
            grid.variable("window_omega", "window_omega_point", w, "rad/s",
                          "exact window: drive angular frequency")
            for edge in ("A_min", "A_max"):
                grid.variable(f"window_{edge}", "window_omega_point",
                              np.broadcast_to(np.asarray(getattr(self.window, edge), float),
                                              np.shape(self.window.omega)).reshape(-1), "m",
                              f"exact window: {edge}")
        return grid

    def to_xarray(self):
        """The verification as an :class:`xarray.Dataset` over the grid's axes (``A`` in m
        and ``omega`` in rad/s, with ``A_over_l`` and ``omega_over_omega0``; ``axis_<k>``
        where neither varies alone): per method ``stable_<method>``, and
        ``omega_slow_<method>`` and ``tolerance_<method>`` (rad/s) over ``mode``; the
        validity flags, ``floquet_margin``, ``simulation_status``, ``fall_time``,
        ``boundary_distance``, ``nearest_boundary``, ``disagreements`` (text per point);
        the located boundaries and the exact window on their own dimensions; the
        equilibrium, tolerances, notes and the fitted orders of averaging in ``attrs``.
        Needs ``pip install "kapitza[xarray]"``."""
        return self._labelled().to_xarray()

    def _repr_html_(self) -> str:
        S = self.shape
        rows = [("grid", " × ".join(map(str, S)) or "one point")]
        rows += display.axis_rows({"A": self.A, "omega": self.omega})
        if self.length is not None and self.omega0 is not None:
            rows += [(f"{k}", v) for k, v in display.axis_rows(
                {"A/l": np.asarray(self.A) / self.length,
                 "ω/ω0": np.asarray(self.omega) / self.omega0})]
        table = self.agreement
        warnings = []
        for quantity in ("stability", "omega_slow"):
            part = table[table["quantity"] == quantity]
            text = "; ".join(f"{r.first}–{r.second} {r.agreeing}/{r.compared}"
                             for r in part.itertuples())
            rows.append((f"agree on {'stability' if quantity == 'stability' else 'Ω'}",
                         text or "—"))
            if "disagreeing_within_validity" in part:
                counted = int(part["disagreeing_within_validity"].sum())
            else:
                counted = int(part["disagreeing"].sum())
            if counted:
                warnings.append(f"{counted} disagreements on {quantity} where both methods "
                                "claim validity")
        for fit in self.fits:
            rows.append((f"order {fit.order} exponent", fit._text()))
        rows.append(("simulation", f"{self.periods} periods, rtol {display.number(self.rtol)}; "
                                   f"Floquet tol {display.number(self.tol)}"))
        badges = [("disagreements", "warn")] if warnings else [("methods agree", "good")]
        drawable = sum(n > 1 for n in S) == 2
        return display.card("Verification", display.state(self.about), rows=rows,
                            badges=badges,
                            warnings=warnings, notes=self.notes,
                            figure=self.figure if drawable else None, alt="verification map")
