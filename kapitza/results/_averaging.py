"""Results of averaging: any system's slow modes, and the driven pendulum and Acheson's
chain in closed form.

Any system (:func:`kapitza.average`): :class:`SlowModes` (about one equilibrium),
:class:`AveragingPrediction` (every equilibrium found), :class:`SlowModeSweep` (one
equilibrium over a parameter grid).  In closed form (:mod:`kapitza.closed_forms`):
:class:`EquilibriumPrediction` and :class:`PendulumAveraging` (the pendulum over arrays of
A and ω), :class:`MultiplePendulumPrediction` (the upright N-link chain).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from . import _display as display
from ._base import scalar_or_array
from ._xarray import LabelledGrid

__all__ = ["SlowModes", "AveragingPrediction", "SlowModeSweep", "EquilibriumPrediction",
           "PendulumAveraging", "MultiplePendulumPrediction"]


@dataclass(frozen=True)
class SlowModes:
    """Small slow oscillations about one equilibrium of the averaged motion.

    Built by :meth:`kapitza.averaging.AveragedSystem.slow_modes`.  The averaged
    linearisation is M δQ̈ + C δQ̇ + H δQ = 0 with H the Hessian of U_eff, M the
    (time-independent) mass matrix, C the averaged damping matrix.

    Attributes
    ----------
    about : ndarray (n,)
        The equilibrium (coordinates in SI units; angles wrapped into (−π, π]).
    omega_squared : ndarray (n,)
        Generalized eigenvalues Ω² of (H, M), ascending (rad²/s²); negative is unstable.
    frequencies : ndarray (n,)
        √Ω² (rad/s); NaN for an unstable mode.
    stable : bool
        All Ω² > 0 (linear stability of the averaged motion; with damping the
        equilibrium is then asymptotically stable).
    eigenvalues : ndarray (2n,), complex
        Roots λ of det(λ² M + λ C + H) = 0 (1/s), sorted by imaginary part
        (the damped slow dynamics; ±iΩ without damping).
    damped_frequencies : ndarray (n,)
        The non-negative imaginary parts of ``eigenvalues`` (rad/s), one per mode.
    decay_rate : float
        −max Re λ (1/s): the slowest decay rate (negative: growth).
    frequency_ratio : float
        ω / max(√|Ω²|): how much faster the drive is than the slow motion.
    amplitude_ratio : float
        Largest singular value of ∂ξ/∂q, the fast displacement amplitude per
        unit slow displacement (A/l for the pendulum).
    valid : bool
        ``frequency_ratio ≥ MIN_FREQUENCY_RATIO`` and ``amplitude_ratio ≤
        MAX_AMPLITUDE_RATIO`` (:mod:`kapitza.averaging`).
    reasons : tuple of str
        Why a prediction is not valid (empty if it is).
    """

    about: np.ndarray
    omega_squared: np.ndarray
    frequencies: np.ndarray
    stable: bool
    eigenvalues: np.ndarray
    damped_frequencies: np.ndarray
    decay_rate: float
    frequency_ratio: float
    amplitude_ratio: float
    valid: bool
    reasons: tuple = ()

    def to_dataframe(self):
        """One row per mode."""
        import pandas as pd
        n = len(self.omega_squared)
        return pd.DataFrame({
            "about": [tuple(self.about.tolist())] * n, "mode": np.arange(n),
            "omega_squared": self.omega_squared, "frequency": self.frequencies,
            "damped_frequency": self.damped_frequencies, "stable": [self.stable] * n,
            "decay_rate": [self.decay_rate] * n, "frequency_ratio": [self.frequency_ratio] * n,
            "amplitude_ratio": [self.amplitude_ratio] * n, "valid": [self.valid] * n,
            "reasons": ["; ".join(self.reasons)] * n})

    def _card(self, kind: str = "SlowModes") -> tuple:
        """(rows, badges, warnings) of this equilibrium's card."""
        rows = [("about", display.state(list(np.asarray(self.about, float)))),
                ("Ω", ", ".join(display.quantity(w, "rad/s") for w in self.frequencies)),
                ("Ω²", ", ".join(display.quantity(w, "rad²/s²") for w in self.omega_squared))]
        if np.any(self.damped_frequencies != self.frequencies):
            rows.append(("damped Ω", ", ".join(display.quantity(w, "rad/s")
                                                for w in self.damped_frequencies)))
            rows.append(("decay rate", display.quantity(self.decay_rate, "1/s")))
        rows += [("ω / Ω", display.number(self.frequency_ratio)),
                 ("fast amplitude ratio", display.number(self.amplitude_ratio))]
        badges = [("stable", "good") if self.stable else ("unstable", "bad")]
        warnings = []
        if not self.valid:
            badges.append(("outside validity", "warn"))
            warnings.append("outside averaging's validity: " + ("; ".join(self.reasons)
                                                                  or "see reasons"))
        return rows, badges, warnings

    def _repr_html_(self) -> str:
        rows, badges, warnings = self._card()
        return display.card("SlowModes", "averaged motion about an equilibrium", rows=rows,
                            badges=badges, warnings=warnings)


@dataclass(frozen=True)
class AveragingPrediction:
    """Equilibria of the averaged motion with their slow modes.

    Built by :meth:`kapitza.averaging.AveragedSystem.predict`.

    Attributes
    ----------
    params : dict
        The parameter values used.
    equilibria : tuple of SlowModes
        One entry per distinct equilibrium found.
    """

    params: dict
    equilibria: tuple

    @property
    def stable(self) -> tuple:
        """The stable equilibria (SlowModes)."""
        return tuple(e for e in self.equilibria if e.stable)

    def to_dataframe(self):
        """One row per equilibrium and mode (column ``equilibrium`` numbers them)."""
        import pandas as pd
        frames = [e.to_dataframe().assign(equilibrium=i) for i, e in enumerate(self.equilibria)]
        return pd.concat(frames, ignore_index=True) if frames else pd.DataFrame()

    def _repr_html_(self) -> str:
        rows = [("parameters", ", ".join(f"{display.symbol(k)} = "
                                         f"{display.quantity(v, display.unit(k))}"
                                         for k, v in self.params.items()))]
        warnings = []
        for e in self.equilibria:
            where = display.state(list(np.asarray(e.about, float)))
            state = "stable" if e.stable else "unstable"
            slow = ", ".join(display.quantity(w, "rad/s") for w in e.frequencies)
            rows.append((where, f"{state}; Ω = {slow}"
                                + ("" if e.valid else " (outside validity)")))
            if not e.valid:
                warnings.append(f"{where}: outside averaging's validity: "
                                + "; ".join(e.reasons))
        if not self.equilibria:
            warnings.append("no equilibrium found")
        return display.card("AveragingPrediction", f"{len(self.equilibria)} equilibria, "
                            f"{len(self.stable)} stable", rows=rows, warnings=warnings)


@dataclass(frozen=True)
class SlowModeSweep:
    """Slow modes about one equilibrium over a grid of parameter values.

    Built by :meth:`kapitza.averaging.AveragedSystem.sweep`.

    Attributes
    ----------
    params : dict of ndarray
        The broadcast parameter arrays.
    about : ndarray (n,)
    omega_squared : ndarray (..., n)
        Ω² of the averaged linearisation, ascending per point (rad²/s²).
    stable, valid : bool ndarray (...)
        See :class:`SlowModes`.
    """

    params: dict
    about: np.ndarray
    omega_squared: np.ndarray
    stable: np.ndarray
    valid: np.ndarray

    def to_dataframe(self):
        """One row per grid point: the parameters, omega_squared_<k> per mode, stable, valid."""
        import pandas as pd
        cols = {k: np.ravel(v) for k, v in self.params.items()}
        for j in range(self.omega_squared.shape[-1]):
            cols[f"omega_squared_{j}"] = self.omega_squared[..., j].ravel()
        cols["stable"] = self.stable.ravel()
        cols["valid"] = self.valid.ravel()
        return pd.DataFrame(cols)

    def _labelled(self) -> LabelledGrid:
        grid = LabelledGrid("SlowModeSweep", method="first-order averaging",
                            about=np.asarray(self.about).tolist())
        shape = np.shape(self.stable)
        dims = grid.broadcast_axes(self.params, shape)
        grid.drive_axes(*grid.pendulum_scales(self.params))
        grid.variable("omega_squared", dims + ("mode",), self.omega_squared, "rad^2/s^2",
                      "Ω² of the averaged linearisation, ascending (negative: unstable)")
        grid.variable("stable", dims, np.asarray(self.stable, bool), None,
                      "stable by averaging")
        grid.variable("valid", dims, np.asarray(self.valid, bool), None,
                      "within averaging's validity")
        return grid

    def to_xarray(self):
        """The sweep as an :class:`xarray.Dataset`: axes named by the varying parameters,
        ``omega_squared`` (rad²/s²) over ``mode``, ``stable`` and ``valid``.  Needs
        ``pip install "kapitza[xarray]"``."""
        return self._labelled().to_xarray()

    def _repr_html_(self) -> str:
        shape = np.shape(self.stable)
        rows = [("grid", " × ".join(map(str, shape)) or "one point")]
        rows += display.axis_rows(self.params)
        rows += [("stable", display.share(self.stable)), ("valid", display.share(self.valid))]
        invalid = int(np.size(self.valid) - np.count_nonzero(self.valid))
        warnings = [f"outside averaging's validity at {invalid} points"] if invalid else []
        return display.card("SlowModeSweep", "averaged slow modes over a grid", rows=rows,
                            warnings=warnings)


_EQUILIBRIUM_COLUMNS = ("theta", "exists", "stable", "omega_squared", "omega_slow",
                        "damped_frequency", "decay_rate", "overdamped", "error_estimate",
                        "frequency_ratio", "fast_drive", "small_amplitude", "converged", "valid")
#: Those fields' units and long names (to_xarray).
_EQUILIBRIUM_QUANTITIES = (
    ("theta", "rad", "angle from the downward vertical (NaN where none)"),
    ("exists", None, "the equilibrium exists"),
    ("stable", None, "stable by averaging"),
    ("omega_squared", "rad^2/s^2", "Ω² of the undamped averaged motion"),
    ("omega_slow", "rad/s", "slow angular frequency Ω"),
    ("damped_frequency", "rad/s", "damped slow angular frequency"),
    ("decay_rate", "1/s", "slowest decay rate of small oscillations"),
    ("overdamped", None, "overdamped"),
    ("error_estimate", "1", "relative size of the next-order correction"),
    ("frequency_ratio", "1", "ω / max(ω0, Ω, γ)"),
    ("fast_drive", None, "frequency ratio within averaging's validity"),
    ("small_amplitude", None, "A/l within averaging's validity"),
    ("converged", None, "next-order correction small enough"),
    ("valid", None, "within averaging's validity (all three)"))


@dataclass(frozen=True)
class EquilibriumPrediction:
    """The averaged prediction for one equilibrium of the driven pendulum.

    Array fields have the broadcast shape of (A, ω) (Python scalars for scalar input).

    Attributes
    ----------
    name : str
        "hanging", "inverted", "tilted+" or "tilted-".  The tilted pair is, for the
        vertical drive, the unstable maxima of U_eff at cos θ = −2 g l/(A² ω²)
        (present when the upright is stable; first order at any ``order``); for
        the horizontal drive, the stable tilted minima at cos θ* = 2 g l/(A² ω²).
    theta : array
        Angle from the downward vertical (rad); NaN where it does not exist.
    exists : bool array
    stable : bool array
        Linear stability of the averaged motion (order 2 also checks the
        parametric-resonance limit a′ < b₁(q)).
    omega_squared : array
        Ω² of the undamped averaged motion (rad²/s²); negative: unstable.
    omega_slow : array
        Ω = √Ω² (rad/s), NaN where Ω² < 0.
    damped_frequency : array
        √(Ω² − γ²/4) at order 1, (ω/2) ν(a − γ²/ω², q) at order 2 (rad/s);
        0 when overdamped, NaN when unstable.
    decay_rate : array
        The slowest decay rate of small oscillations (1/s): γ/2 when
        underdamped, γ/2 − √(γ²/4 − Ω²) when overdamped; negative: growth rate.
    overdamped : bool array
    error_estimate : array
        Vertical drive, hanging and upright: |√|Ω₂²| − √|Ω₁²|| / √|Ω₁²|, the relative
        size of the next-order correction to the slow frequency (or growth rate);
        +inf when the correction flips the stability.  It estimates the error of
        order 1 (within a factor ≈ 2, tests/test_averaging.py); the error of
        order 2 is much smaller (see ``MAX_CORRECTION`` in
        :mod:`kapitza.closed_forms`).  NaN for the tilted equilibria and
        the horizontal drive (no next order implemented).
    frequency_ratio : array
        ω / max(ω0, √|Ω²|, γ).
    fast_drive, small_amplitude, converged, valid : bool arrays
        ``frequency_ratio ≥ MIN_FREQUENCY_RATIO``, ``A/l ≤ MAX_AMPLITUDE_RATIO``,
        ``error_estimate ≤ MAX_CORRECTION`` (True where no estimate exists), and
        all three (False where the equilibrium does not exist).
    """

    name: str
    theta: ArrayLike
    exists: ArrayLike
    stable: ArrayLike
    omega_squared: ArrayLike
    omega_slow: ArrayLike
    damped_frequency: ArrayLike
    decay_rate: ArrayLike
    overdamped: ArrayLike
    error_estimate: ArrayLike
    frequency_ratio: ArrayLike
    fast_drive: ArrayLike
    small_amplitude: ArrayLike
    converged: ArrayLike
    valid: ArrayLike

    def _card(self) -> tuple:
        """(rows, warnings) of this equilibrium's part of a card."""
        one = np.ndim(self.theta) == 0

        def show(x, unit=""):
            return display.quantity(x, unit) if one else display.span(x, unit)

        exists = np.asarray(self.exists, bool)
        rows = [("θ", show(self.theta, "rad"))]
        if one and not exists:
            return [("θ", "does not exist")], []
        rows += [("stable", ("stable" if bool(self.stable) else "unstable") if one
                  else display.share(np.asarray(self.stable) & exists)),
                 ("Ω", show(self.omega_slow, "rad/s")),
                 ("error estimate", show(self.error_estimate) + " (relative, of order 1)")]
        if np.any(np.asarray(self.damped_frequency, float) != np.asarray(self.omega_slow,
                                                                         float)):
            rows.append(("damped Ω", show(self.damped_frequency, "rad/s")))
        warnings = []
        invalid = exists & ~np.asarray(self.valid, bool)
        if invalid.any():
            why = [name.replace("_", " ") for name in ("fast_drive", "small_amplitude",
                                                      "converged")
                   if not np.all(np.asarray(getattr(self, name), bool)[exists])]
            where = "" if one else f" at {int(invalid.sum())} of {invalid.size} points"
            warnings.append(f"{self.name}: outside averaging's validity{where} (fails: "
                            f"{', '.join(why) or 'exists'})")
        return rows, warnings

    def _repr_html_(self) -> str:
        rows, warnings = self._card()
        badges = [("outside validity", "warn")] if warnings else []
        return display.card("EquilibriumPrediction", self.name, rows=rows, badges=badges,
                            warnings=warnings)


@dataclass(frozen=True)
class PendulumAveraging:
    """Averaged (Kapitza) predictions for the driven pendulum over arrays of A and ω.

    Built by :func:`kapitza.pendulum_averaged` (and
    :meth:`kapitza.KapitzaPendulum.averaged`).

    Attributes
    ----------
    A, omega : array
        Drive amplitude (m) and angular frequency (rad/s), broadcast.
    l, g, damping : float
        Length (m), gravity (m/s²), damping rate γ (1/s).
    drive : str
        "vertical" or "horizontal".
    order : int
        1 (Kapitza/Landau averaging) or 2 (next order, vertical drive).
    equilibria : tuple of EquilibriumPrediction
    """

    A: ArrayLike
    omega: ArrayLike
    l: float
    g: float
    damping: float
    drive: str
    order: int
    equilibria: tuple

    def __getitem__(self, name) -> EquilibriumPrediction:
        for e in self.equilibria:
            if e.name == name:
                return e
        raise KeyError(f"no equilibrium {name!r}; have {[e.name for e in self.equilibria]}.")

    @property
    def hanging(self) -> EquilibriumPrediction:
        """The hanging state θ = 0."""
        return self["hanging"]

    @property
    def inverted(self) -> EquilibriumPrediction:
        """The upright state θ = π."""
        return self["inverted"]

    @property
    def tilted(self) -> EquilibriumPrediction:
        """The tilted equilibrium θ* > 0 (−θ* is its mirror; see EquilibriumPrediction.name)."""
        return self["tilted+"]

    @property
    def valid(self):
        """The predictions for every existing equilibrium are valid (per point)."""
        return scalar_or_array(np.logical_and.reduce(
            [np.asarray(e.valid) | ~np.asarray(e.exists) for e in self.equilibria]))

    def to_dataframe(self):
        """One row per (A, ω) point and equilibrium."""
        import pandas as pd
        A, w = (np.ravel(x) for x in np.broadcast_arrays(self.A, self.omega))
        rows = []
        for e in self.equilibria:
            cols = {f: np.ravel(np.broadcast_to(np.asarray(getattr(e, f)), np.shape(self.A)))
                    for f in _EQUILIBRIUM_COLUMNS}
            rows.append(pd.DataFrame({"A": A, "omega": w, "equilibrium": e.name, **cols}))
        return pd.concat(rows, ignore_index=True).assign(order=self.order, drive=self.drive)

    def _labelled(self) -> LabelledGrid:
        grid = LabelledGrid("PendulumAveraging", drive=self.drive, order=self.order,
                            method=f"averaging, order {self.order} (closed form)")
        shape = np.broadcast_shapes(np.shape(self.A), np.shape(self.omega))
        dims = grid.broadcast_axes({"A": self.A, "omega": self.omega}, shape)
        grid.parameters({"l": self.l, "g": self.g, "damping": self.damping})
        grid.drive_axes(self.l, math.sqrt(self.g / self.l))
        grid.coord("equilibrium", "equilibrium",
                   np.asarray([e.name for e in self.equilibria], dtype=str), None,
                   "equilibrium of the averaged motion")
        for name, units, long_name in _EQUILIBRIUM_QUANTITIES:
            values = np.stack([np.broadcast_to(np.asarray(getattr(e, name)), shape)
                               for e in self.equilibria], axis=-1)
            grid.variable(name, dims + ("equilibrium",), values, units, long_name)
        return grid

    def to_xarray(self):
        """The predictions as an :class:`xarray.Dataset`: the drive's axes (``A`` in m,
        ``omega`` in rad/s, with ``A_over_l`` and ``omega_over_omega0``; a scalar drive
        goes to ``attrs``), an ``equilibrium`` dimension ("hanging", "inverted", …) and one
        variable per field of :class:`EquilibriumPrediction` (``theta`` in rad,
        ``omega_squared`` in rad²/s², ``omega_slow`` in rad/s, …, the validity flags).
        Needs ``pip install "kapitza[xarray]"``."""
        return self._labelled().to_xarray()

    def _repr_html_(self) -> str:
        one = np.ndim(self.A) == 0 and np.ndim(self.omega) == 0
        if one:
            rows = [("A", display.quantity(self.A, "m")),
                    ("ω", display.quantity(self.omega, "rad/s"))]
        else:
            rows = [("A", display.span(self.A, "m")), ("ω", display.span(self.omega, "rad/s"))]
        rows.append(("l, g", f"{display.quantity(self.l, 'm')}, "
                             f"{display.quantity(self.g, 'm/s²')}"))
        if self.damping:
            rows.append(("γ", display.quantity(self.damping, "1/s")))
        warnings = []
        for e in self.equilibria:
            sub, warn = e._card()
            warnings += warn
            exists = np.asarray(e.exists, bool)
            if not exists.any():
                text = "does not exist"
            elif one:
                text = f"{sub[1][1]}; Ω = {sub[2][1]}"
            else:
                text = (f"exists at {int(exists.sum())} of {exists.size}; stable at "
                        f"{int((np.asarray(e.stable, bool) & exists).sum())}; "
                        f"Ω = {sub[2][1]}")
            rows.append((e.name, text))
        badges = [("outside validity", "warn")] if warnings else []
        return display.card("PendulumAveraging", f"{self.drive} drive, order {self.order}",
                            rows=rows, badges=badges, warnings=warnings)


@dataclass(frozen=True)
class MultiplePendulumPrediction:
    """Upright N-link pendulum on a pivot shaken vertically as A cos ωt (Acheson).

    Built by :func:`kapitza.multiple_pendulum_upright`, which
    states the theory and its accuracy.

    Attributes
    ----------
    masses, lengths : ndarray (N,)
        Bob masses (kg) and rod lengths (m), from the pivot outwards.
    g : float
        Gravity (m/s²).
    hanging_frequencies : ndarray (N,)
        ω_k of the undriven hanging chain (rad/s), ascending.
    effective_lengths : ndarray (N,)
        λ_k = g/ω_k² (m), descending.
    minimum_drive : float
        (A ω)_min = √2 g / ω_1 (m/s), first order.
    A, omega : array or None
        The drive, if given; then the fields below have its broadcast shape (+ (N,)).
    omega_squared : ndarray (..., N) or None
        Slow Ω_k² about the upright, in the order of ``hanging_frequencies``.
    stable, valid : bool array or None
        Every mode stable; every mode's prediction inside the averaging regime.
    mode_predictions : tuple of PendulumAveraging or None
        The single-pendulum prediction of each mode (``inverted`` holds the
        upright result); carries the validity flags.
    order : int
        1 or 2, as in :func:`kapitza.pendulum_averaged`.
    """

    masses: np.ndarray
    lengths: np.ndarray
    g: float
    hanging_frequencies: np.ndarray
    effective_lengths: np.ndarray
    minimum_drive: float
    A: ArrayLike | None = None
    omega: ArrayLike | None = None
    omega_squared: ArrayLike | None = None
    stable: ArrayLike | None = None
    valid: ArrayLike | None = None
    mode_predictions: tuple | None = None
    order: int = 1

    def to_dataframe(self):
        """One row per mode (and drive point, if given)."""
        import pandas as pd
        if self.mode_predictions is None:
            return pd.DataFrame({"mode": np.arange(len(self.masses)),
                                 "hanging_frequency": self.hanging_frequencies,
                                 "effective_length": self.effective_lengths})
        frames = []
        for k, pred in enumerate(self.mode_predictions):
            df = pred.to_dataframe()
            df = df[df.equilibrium == "inverted"].drop(columns="equilibrium")
            frames.append(df.assign(mode=k, hanging_frequency=self.hanging_frequencies[k],
                                    effective_length=self.effective_lengths[k]))
        return pd.concat(frames, ignore_index=True)

    def _labelled(self) -> LabelledGrid:
        grid = LabelledGrid("MultiplePendulumPrediction", order=self.order,
                            minimum_drive=self.minimum_drive, minimum_drive_units="m/s",
                            method=f"averaging, order {self.order} (Acheson)")
        grid.parameters({"g": self.g})
        grid.coord("link", "link", np.arange(len(self.masses)), None,
                   "link, from the pivot outwards")
        grid.variable("mass", "link", self.masses, "kg", "bob mass")
        grid.variable("length", "link", self.lengths, "m", "rod length")
        grid.coord("mode", "mode", np.arange(len(self.hanging_frequencies)), None,
                   "mode of the hanging chain, ascending frequency")
        grid.variable("hanging_frequency", "mode", self.hanging_frequencies, "rad/s",
                      "angular frequency of the undriven hanging chain")
        grid.variable("effective_length", "mode", self.effective_lengths, "m",
                      "effective length g/ω_k²")
        if self.A is not None and self.omega_squared is not None:
            shape = np.broadcast_shapes(np.shape(np.asarray(self.A, dtype=float)),
                                        np.shape(np.asarray(self.omega, dtype=float)))
            dims = grid.broadcast_axes({"A": self.A, "omega": self.omega}, shape)
            grid.variable("omega_squared", dims + ("mode",),
                          np.broadcast_to(self.omega_squared, shape + (len(self.masses),)),
                          "rad^2/s^2", "slow Ω_k² about the upright")
            grid.variable("stable", dims, np.broadcast_to(np.asarray(self.stable, bool),
                                                          shape), None, "every mode stable")
            grid.variable("valid", dims, np.broadcast_to(np.asarray(self.valid, bool), shape),
                          None, "every mode within averaging's validity")
        return grid

    def to_xarray(self):
        """The chain as an :class:`xarray.Dataset`: ``mass`` (kg) and ``length`` (m) over
        ``link``, ``hanging_frequency`` (rad/s) and ``effective_length`` (m) over ``mode``,
        and with a drive, its axes (``A``, ``omega``) and ``omega_squared`` (rad²/s²),
        ``stable``, ``valid``.  Needs ``pip install "kapitza[xarray]"``."""
        return self._labelled().to_xarray()

    def _repr_html_(self) -> str:
        rows = [("links", str(len(self.masses))),
                ("(A ω)_min", display.quantity(self.minimum_drive, "m/s")),
                ("hanging ω_k", ", ".join(display.quantity(w, "rad/s")
                                          for w in self.hanging_frequencies))]
        warnings, badges = [], []
        if self.A is not None:
            one = np.ndim(self.A) == 0 and np.ndim(np.asarray(self.omega, dtype=float)) == 0
            rows += [("A", display.quantity(self.A, "m") if one else display.span(self.A, "m")),
                     ("ω", display.quantity(self.omega, "rad/s") if one
                      else display.span(self.omega, "rad/s")),
                     ("stable", display.number(bool(self.stable)) if one
                      else display.share(self.stable))]
            valid = np.asarray(self.valid, bool)
            if not valid.all():
                badges.append(("outside validity", "warn"))
                warnings.append("outside averaging's validity"
                                + ("" if one else f" at {int((~valid).sum())} of "
                                                  f"{valid.size} points"))
        return display.card("MultiplePendulumPrediction",
                            f"upright {len(self.masses)}-link chain, order {self.order}",
                            rows=rows, badges=badges, warnings=warnings)
