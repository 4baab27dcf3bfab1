"""Results of continuation: a branch of periodic orbits and the bifurcations on it.

:class:`Branch` (built by :func:`kapitza.continuation`) holds the orbits along a curve in
(state, parameter) space — :class:`BranchPoints` — and the :class:`Bifurcation` s found on
it; :meth:`Branch.switch` starts the branch that emanates from one of them.

Conventions (shared/PHYSICS.md): SI units; θ from the downward vertical; the state of an
orbit is [q, q̇] at the drive's phase zero (t = 0 mod T); multipliers are the
eigenvalues of the monodromy over the orbit's own period (``periods`` drive periods).
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from . import _display as display
from ._xarray import LabelledGrid, coordinate_units, quantity_of

__all__ = ["BIFURCATION_KINDS", "BRANCH_STATUSES", "BranchPoints", "Bifurcation", "Branch"]

#: The kinds of :class:`Bifurcation`: a multiplier at +1 where the parameter turns
#: ("fold") or where another branch crosses ("pitchfork": the other branch on one side,
#: mirror images; "transcritical": through), at −1 ("period_doubling"), a complex pair on
#: the unit circle ("neimark_sacker").
BIFURCATION_KINDS = ("fold", "pitchfork", "transcritical", "period_doubling",
                     "neimark_sacker")

#: How a branch ended: reached ``stop`` ("completed"), came back to its start ("closed"),
#: or stopped early with the points so far and a warning ("max_points", "corrector_failed",
#: "step_too_small", "singular", "interrupted").
BRANCH_STATUSES = ("completed", "closed", "max_points", "corrector_failed",
                   "step_too_small", "singular", "interrupted")


@dataclass(frozen=True, eq=False)
class BranchPoints:
    """The orbits along a branch, in arclength order (arrays, one row per point).

    Attributes
    ----------
    parameter : ndarray (k,)
        The continued parameter's value (its SI unit).
    state : ndarray (k, 2n)
        [q, q̇] on the orbit at t = 0 (rad, rad/s for angles).
    q_mean : ndarray (k, n)
        Mean of q over the orbit's period (the slow state of averaging).
    amplitude : ndarray (k, n)
        Half the peak-to-peak range of q over the orbit's period.
    multipliers : ndarray, complex (k, 2n)
        Floquet multipliers over the orbit's period, by decreasing modulus.
    stable : ndarray of bool (k,)
        Every |λ| ≤ 1 + δ, δ = max(100 × the monodromy's error estimate, 1e-9).
    arclength : ndarray (k,)
        Position along the branch (scaled units: see :func:`kapitza.continuation`).
    residual : ndarray (k,)
        |φ(x) − x|∞ at the point (the corrector's tolerance bounds it).
    error_estimate : ndarray (k,)
        The monodromy's error estimate (max abs of its entries).
    label : ndarray of str (k,)
        "" for a regular point, else the kind of the bifurcation located there
        (:data:`BIFURCATION_KINDS`), "start" or "end".
    """

    parameter: np.ndarray
    state: np.ndarray
    q_mean: np.ndarray
    amplitude: np.ndarray
    multipliers: np.ndarray
    stable: np.ndarray
    arclength: np.ndarray
    residual: np.ndarray
    error_estimate: np.ndarray
    label: np.ndarray

    def __len__(self) -> int:
        return int(self.parameter.size)

    def _repr_html_(self) -> str:
        return display.card("BranchPoints", f"{len(self)} orbits",
                            rows=[("parameter", display.span(self.parameter)),
                                  ("stable", display.share(self.stable, "points")),
                                  ("residual", display.span(self.residual))])


@dataclass(frozen=True, eq=False)
class Bifurcation:
    """A bifurcation located on a branch.

    Attributes
    ----------
    kind : str
        One of :data:`BIFURCATION_KINDS`.
    parameter : float
        The parameter's value there.
    accuracy : float
        Certified bound on |parameter − the true value| (the parameter's unit): the last
        bracket of the test function's root whose ends' signs exceed the test
        function's error bound, plus the corrector tolerance's effect on the parameter
        (and, at a fold, the parabola's rise over the bracket).
    state : ndarray (2n,)
        The orbit's [q, q̇] at t = 0 there.
    multipliers : ndarray, complex (2n,)
    index : int
        Its row in ``Branch.points`` (label = kind).
    periods : int
        Drive periods of the branch's orbits (the born branch of a period doubling has
        twice as many).
    test_function : str
        The function whose sign change found it: "det(M − I)", "det(M + I)" or
        "det(M ⊙ M − I)" (the bialternate product).
    criticality : str or None
        "supercritical" (the emanating branch lies on the side where this branch is
        unstable), "subcritical" (on the stable side), None where it does not apply
        (fold, transcritical, Neimark–Sacker) or was not decided (see ``note``).
    side : int
        The sign of (parameter of the emanating branch − ``parameter``) found by a
        probe at a small distance (0 where not probed or undecided).
    direction : ndarray (2n + 1,) or None
        Direction of the emanating branch in (state, parameter) (unscaled): the
        eigenvector of M for −1 at a period doubling, the null vector of [M − I, ∂φ/∂p]
        not tangent to this branch at a branch point; None at a fold.
    note : str
    """

    kind: str
    parameter: float
    accuracy: float
    state: np.ndarray
    multipliers: np.ndarray
    index: int
    periods: int
    test_function: str
    criticality: str | None = None
    side: int = 0
    direction: np.ndarray | None = None
    note: str = ""

    def __str__(self) -> str:
        crit = f", {self.criticality}" if self.criticality else ""
        return (f"{self.kind} at {self.parameter:.12g} (± {self.accuracy:.2g}){crit}")

    def _repr_html_(self) -> str:
        rows = [("parameter", display.quantity(self.parameter, "", self.accuracy, digits=10)),
                ("test function", self.test_function),
                ("multipliers", ", ".join(f"{display.number(m.real, 6)}"
                                          f"{'+' if m.imag >= 0 else '−'}"
                                          f"{display.number(abs(m.imag), 3)}i"
                                          for m in np.asarray(self.multipliers, complex))),
                ("orbit period", f"{self.periods} drive periods")]
        if self.side:
            rows.append(("emanating branch", "above" if self.side > 0 else "below"))
        badges = [(self.criticality, "info")] if self.criticality else []
        return display.card("Bifurcation", self.kind.replace("_", " "), rows=rows,
                            badges=badges, notes=[self.note] if self.note else [])


@dataclass(frozen=True, eq=False)
class Branch:
    """A branch of periodic orbits (equilibria that persist under the drive included)
    followed in one parameter, with their Floquet multipliers and the bifurcations on it.

    Built by :func:`kapitza.continuation` (its docstring states the method and the
    accuracy) and :meth:`switch`.

    Attributes
    ----------
    coordinates : tuple of str
    parameter : str
        The continued parameter's name.
    params : dict
        The other parameters' values (and the continued one's start value).
    frequency : str
        The drive's angular-frequency parameter.
    periods : int
        Drive periods per orbit (1: T-periodic; 2: born at a period doubling).
    points : BranchPoints
    bifurcations : tuple of Bifurcation
        In arclength order.
    domain : (float, float)
        The parameter interval the branch was followed in.
    status : str
        One of :data:`BRANCH_STATUSES`; anything but "completed" or "closed" came with
        a RuntimeWarning.
    message : str
        What happened, in words.
    tol : float
        The corrector's tolerance: |φ(x) − x|∞ ≤ tol · max(1, |x|∞).
    flows : int
        Flows of the period map computed (the cost).
    origin : str
        "" for a branch started by :func:`kapitza.continuation`; for one started by
        :meth:`switch`, the bifurcation it emanates from.
    winding : tuple of int
        A branch of rotating orbits: the turns of each coordinate over ``periods`` drive
        periods, q(t + periods·T) = q(t) + 2π·winding (``continuation(winding=...)``);
        () for orbits that return to themselves.
    """

    coordinates: tuple
    parameter: str
    params: dict
    frequency: str
    periods: int
    points: BranchPoints
    bifurcations: tuple
    domain: tuple
    status: str
    message: str
    tol: float
    flows: int
    origin: str = ""
    winding: tuple = ()
    _engine: Any = field(default=None, repr=False, compare=False)

    def __repr__(self) -> str:
        p = self.points.parameter
        bif = "; ".join(str(b) for b in self.bifurcations) or "none"
        span = f"{p[0]:.6g} → {p[-1]:.6g}" if p.size else "empty"
        origin = f", from {self.origin}" if self.origin else ""
        turns = f", winding={self.winding}" if self.winding else ""
        return (f"Branch({self.parameter}: {span}, {len(self.points)} points, "
                f"periods={self.periods}{turns}{origin}, status={self.status!r}; "
                f"bifurcations: {bif})")

    def _label(self) -> str:
        """The legend's name: "T orbits", "2T orbits from the period doubling",
        "T orbits from the pitchfork (−)" (the other half)."""
        name = f"{self.periods}T orbits" if self.periods > 1 else "T orbits"
        if self.origin:
            name += f" from {self.origin.split(' at ')[0]}"
            if "direction -1" in self.origin:
                name += " (−)"
        return name

    def switch(self, bifurcation, *, direction=1, step=None, stop=None, max_points=None):
        """The branch that emanates from ``bifurcation`` (one of :attr:`bifurcations`).

        At a period doubling: the orbits of twice the period, started along the
        eigenvector of M for −1 on the doubled period map.  At a pitchfork or a
        transcritical point: the other branch, along the null vector of the bordered
        Jacobian that is not tangent to this one (``direction=-1``: the other half; at
        a pitchfork the mirror image).  The new branch starts at the bifurcation point
        (its first row, labelled with the kind) and is followed through ``domain`` (or
        from the bifurcation to ``stop``) with this branch's options unless given.

        Returns
        -------
        Branch

        Raises
        ------
        ValueError
            ``bifurcation`` is not on this branch, or has no branch of periodic orbits
            to switch to (a fold: the branch only turns; a Neimark–Sacker point: the
            born solutions are quasi-periodic, on a torus).
        """
        if self._engine is None:
            raise ValueError("this Branch carries no continuation engine (it was not built "
                             "by kapitza.continuation in this process); recompute it.")
        if not any(bifurcation is b for b in self.bifurcations):
            raise ValueError(f"bifurcation must be one of this branch's .bifurcations, got "
                             f"{bifurcation!r}.")
        if direction not in (1, -1):
            raise ValueError(f"direction must be 1 or -1, got {direction!r}.")
        return self._engine.switch(self, bifurcation, direction=direction, step=step,
                                   stop=stop, max_points=max_points)

    def to_dataframe(self):
        """One row per point: the parameter, label, stability, per coordinate the state
        at t = 0, the period mean and the amplitude, the largest |λ|, each multiplier
        (complex), arclength, residual."""
        import pandas as pd
        pts, cols = self.points, {}
        n = len(self.coordinates)
        cols[self.parameter] = pts.parameter
        cols["label"] = pts.label
        cols["stable"] = pts.stable
        for i, c in enumerate(self.coordinates):
            cols[f"{c}_0"] = pts.state[:, i]
            cols[f"{c}_dot_0"] = pts.state[:, n + i]
            cols[f"{c}_mean"] = pts.q_mean[:, i]
            cols[f"{c}_amplitude"] = pts.amplitude[:, i]
        cols["max_abs_multiplier"] = np.max(np.abs(pts.multipliers), axis=1) \
            if len(pts) else np.zeros(0)
        for k in range(pts.multipliers.shape[1]):
            cols[f"multiplier_{k}"] = pts.multipliers[:, k]
        cols["arclength"] = pts.arclength
        cols["residual"] = pts.residual
        return pd.DataFrame(cols)

    def figure(self, **options):
        """The branch against its parameter, stable solid and unstable dashed, each
        bifurcation marked: :func:`kapitza.figures.branch_figure` (``options`` go to it:
        ``ax=`` to draw over a parent branch, ``y=``, ``coordinate=``, ``color=``,
        ``label=``). Returns a :class:`matplotlib.figure.Figure`."""
        from ..figures import branch_figure
        return branch_figure(self, **options)

    def _labelled(self) -> LabelledGrid:
        pts, n = self.points, len(self.coordinates)
        grid = LabelledGrid(
            "Branch", parameter=self.parameter, frequency=self.frequency,
            periods=int(self.periods), status=self.status, message=self.message, tol=self.tol,
            flows=int(self.flows), origin=self.origin, domain=list(self.domain),
            method="pseudo-arclength continuation on the period map (Newton shooting)",
            bifurcations=[{"kind": b.kind, "parameter": b.parameter, "accuracy": b.accuracy,
                           "index": b.index, "criticality": b.criticality,
                           "test_function": b.test_function} for b in self.bifurcations])
        grid.parameters({k: v for k, v in self.params.items() if k != self.parameter})
        units, long_name = quantity_of(self.parameter)
        grid.coord("point", "point", np.arange(len(pts)), None,
                   "point along the branch, in arclength order")
        grid.coord(self.parameter, "point", pts.parameter, units, long_name)
        grid.coord("arclength", "point", pts.arclength, None, "position along the branch "
                   "(scaled units)")
        grid.coord("coordinate", "coordinate", np.asarray(self.coordinates, dtype=str), None,
                   "coordinate of the system")
        q_units = {coordinate_units(c)[0] for c in self.coordinates}
        rate_units = {coordinate_units(c)[1] for c in self.coordinates}
        q_unit = q_units.pop() if len(q_units) == 1 else None
        rate_unit = rate_units.pop() if len(rate_units) == 1 else None
        dims = ("point", "coordinate")
        grid.variable("q0", dims, pts.state[:, :n].reshape(len(pts), n), q_unit,
                      "q on the orbit at t = 0")
        grid.variable("qdot0", dims, pts.state[:, n:].reshape(len(pts), n), rate_unit,
                      "q̇ on the orbit at t = 0")
        grid.variable("q_mean", dims, pts.q_mean.reshape(len(pts), n), q_unit,
                      "mean of q over the orbit's period")
        grid.variable("amplitude", dims, pts.amplitude.reshape(len(pts), n), q_unit,
                      "half the peak-to-peak range of q over the orbit's period")
        grid.variable("multiplier", ("point", "multiplier"),
                      pts.multipliers.reshape(len(pts), 2 * n), "1",
                      "Floquet multiplier over the orbit's period (by decreasing modulus)")
        grid.variable("stable", "point", np.asarray(pts.stable, bool), None, "stable orbit")
        grid.variable("residual", "point", pts.residual, None, "|φ(x) − x|∞ at the point")
        grid.variable("error_estimate", "point", pts.error_estimate, "1",
                      "the monodromy's error estimate")
        grid.variable("label", "point", np.asarray(pts.label, dtype=str), None,
                      "bifurcation located at the point, start or end (empty: regular)")
        return grid

    def to_xarray(self):
        """The branch as an :class:`xarray.Dataset` over ``point`` (arclength order; the
        continued parameter and ``arclength`` as coordinates beside it) and
        ``coordinate``: ``q0``, ``qdot0``, ``q_mean``, ``amplitude``,
        ``multiplier_real``/``multiplier_imag``, ``stable``, ``residual``,
        ``error_estimate``, ``label``; the status, tolerance and bifurcations (JSON) in
        ``attrs``.  Needs ``pip install "kapitza[xarray]"``."""
        return self._labelled().to_xarray()

    def _repr_html_(self) -> str:
        pts = self.points
        unit = quantity_of(self.parameter)[0] or ""
        rows = [(self.parameter, display.span(pts.parameter, unit, digits=6, what="points")),
                ("stable", display.share(pts.stable)),
                ("orbits", f"{self.periods}T-periodic" if self.periods > 1 else "T-periodic"),
                ("bifurcations", "; ".join(str(b) for b in self.bifurcations) or "none"),
                ("tolerance", f"{display.number(self.tol, 2)} (corrector), "
                              f"{self.flows} flows")]
        ended = self.status in ("completed", "closed")
        badges = [(self.status, "good" if ended else "warn")]
        warnings = [] if ended else [f"stopped early ({self.status}): {self.message}"]
        notes = [f"from {self.origin}"] if self.origin else []
        return display.card("Branch", f"{', '.join(self.coordinates)} along "
                            f"{self.parameter}", rows=rows, badges=badges,
                            warnings=warnings, notes=notes,
                            figure=self.figure if len(pts) > 1 else None, alt="branch")

    @property
    def label(self) -> str:
        """The legend's name: "T orbits", "2T orbits from the period doubling",
        "T orbits from the pitchfork (−)" (the other half)."""
        return self._label()


