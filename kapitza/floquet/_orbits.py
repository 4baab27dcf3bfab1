"""Periodic orbits followed over a parameter grid by natural continuation: the orbit behind
every point of a map, window or boundary curve about a state that does not persist under
the drive (the horizontal and elliptic pivots, any user rig).

What ``about`` names
--------------------
:func:`orbit_request` reads ``about`` once:

* coordinates (a sequence or a dict by coordinate) whose rest state persists under the
  drive at the probe points — an equilibrium: ``None``, the caller keeps the Taylor
  monodromies about it (:mod:`kapitza.floquet._probe`);
* coordinates that do not persist: the guess of a T-periodic orbit at rest, Newton's start
  at the lowest amplitude of the grid, per ω.  Where the drive has the half-period
  reflection symmetry about them (the horizontal pivot about θ = 0 or π; tested on the
  vector field, :func:`kapitza.floquet._shooting.symmetry_defect`) the orbit asked for is
  the symmetric one, shot on the half-period map, which stays regular at the
  symmetry-breaking pitchfork where the full period map is singular;
* a state [q, q̇] (2n numbers): the same, on the full period map;
* a :class:`~kapitza.results.PeriodicOrbit` (:func:`kapitza.periodic_orbit`): that orbit,
  followed from the (amplitude, ω) at which it was found — the way to name an orbit that
  does not reach the lowest amplitude (the horizontal drive's tilted orbit, born at the
  pitchfork).  Its symmetry is kept where it has one.

How an orbit is followed (:class:`Line`)
----------------------------------------
Along one parameter x (the amplitude at a fixed ω; or ω at the seed's amplitude), each
new point's Newton shooting (:func:`kapitza.floquet._shooting.shoot`) starts from the
tangent predictor y0 + y0′ h, with y′ = −(∂G/∂y)⁻¹ ∂G/∂x (∂G/∂x a difference of the flow
in x).  A step is accepted only where Newton converges and both tangents agree with it:
forwards |y1 − y0 − y0′ h| and backwards |y0 − y1 + y1′ h| within half of the predicted
move (in the balanced variables q, q̇/ω), plus the shooting's own accuracy.  On a smooth
branch both misses are O(h²) against O(h), so fine steps always pass; where the branch
turns — a fold, or the square-root end of a branch born at a pitchfork (the tilted orbit
at the hanging one's pitchfork) — y′ grows without bound, the two tangents disagree
unless h is small against the distance to the turn, and a step landing on another branch
or beyond the end fails one of the two checks whatever its length.  A step across which
det(∂G/∂y) changes sign (on a branch only at a fold or a branch point; a long step can
land on another branch with similar tangents) is accepted only once shorter than 1e-3 of
x.  A rejected step is halved; below 1e-6 of x the branch has ended, and every point
beyond is reported without an orbit, never with the orbit of another branch.  Accepted
points are kept, so later requests at the same ω interpolate between them (the linear
interpolation as the guess, accepted where the corrector stays within half the two
points' difference and det(∂G/∂y) keeps a neighbour's sign).

Limits: natural continuation in x cannot go round a fold (the branch then ends there:
:func:`kapitza.continuation` follows branches through folds), and a branch that turns
within less than a step and lands on another orbit with the same tangents and the same
sign of det(∂G/∂y) is not told apart; finer grids make that rarer.

Accuracy: each orbit to the shooting's residual ``tol`` · max(1, |y|) (flow to tol/100);
its state's error (the Newton–Kantorovich bound, inf where none holds) and the
monodromy's error (integration plus its change over the state's error ball) are those of
:class:`~._shooting.Shot`; the continuation's acceptance tests use the cheaper first-order
scale ‖J⁻¹‖ (residual + flow error) (:attr:`~._shooting.Shot.linear_error`).
"""
from __future__ import annotations

import bisect
import math
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from ..results import PeriodicOrbit
from ._monodromy import _persistence_defect
from ._shooting import SYMMETRY_RTOL, Shot, _Map, shoot, symmetry_defect

__all__ = ["OrbitRequest", "orbit_request", "Line", "Follower"]

#: Newton iterations of one continuation step before it is rejected (the predictor is
#: good: a converging step takes 2–4)
MAX_NEWTON = 6
#: the corrector may move the state by this fraction of the predictor's move
JUMP = 0.5
#: a step shorter than this × |x| ends the branch
MIN_STEP = 1e-6
#: a step across which det(∂G/∂y) changes sign is accepted only when at most this × |x|
#: long (a branch point crossed on the branch followed, not a jump to another branch)
CROSS_STEP = 1e-3
#: a seed orbit found from a guess must lie within this × max(1, |guess|) of it (balanced
#: variables): the orbit near the guess, not another one Newton wandered to
NEAR = 0.25
#: the longest flow of a seed (fixed steps per interval shot)
MAX_STEPS = 1 << 16
#: a continuation step's flows may take this many times the steps of its neighbour's:
#: a trial state far off (or a flow that cannot meet its tolerance) fails fast
MAX_STEP_GROWTH = 16


@dataclass(frozen=True)
class OrbitRequest:
    """The orbit ``about`` names: its first guess ``state`` [q, q̇], the centre of its
    half-period symmetry (None: the full period map), the (amplitude, ω) of a given
    orbit (None: Newton from ``state`` at each ω's lowest amplitude), and how results
    name it (``label``)."""

    state: np.ndarray
    center: np.ndarray | None
    seed: tuple[float, float] | None
    label: str


def _parameter_array(system, fixed, amplitude, frequency, A, w):
    p = dict(fixed)
    p[amplitude], p[frequency] = float(A), float(w)
    return system.parameter_array(p)


def orbit_request(system, fixed, about, amplitude, frequency, probes) -> OrbitRequest | None:
    """What ``about`` asks for (see the module docstring): None for an equilibrium that
    persists under the drive at the ``probes`` [(A, ω), ...], else the orbit request.

    Raises ValueError for an ``about`` of the wrong size, or a PeriodicOrbit of another
    system or parameters."""
    n = system.n_dof
    if isinstance(about, PeriodicOrbit):
        return _given_orbit(system, fixed, about, amplitude, frequency)
    if about is None:
        raise ValueError("pass the state the analysis is about as `about`: an equilibrium's "
                         "coordinates, a periodic orbit's guess (coordinates at rest, or the "
                         "state [q, q̇]), or a kapitza.periodic_orbit result.")
    if isinstance(about, Mapping):
        y = np.concatenate([system.coordinate_array(about, "about"), np.zeros(n)])
    else:
        try:
            y = np.asarray(about, dtype=float).reshape(-1)
        except (TypeError, ValueError):
            raise ValueError(f"about must be {n} coordinates or the state [q, q̇] ({2 * n} "
                             f"numbers), got {about!r}.") from None
        if y.size == n:
            y = np.concatenate([y, np.zeros(n)])
    if y.size != 2 * n or not np.all(np.isfinite(y)):
        raise ValueError(f"about must be {n} finite coordinates or the state [q, q̇] "
                         f"({2 * n} numbers), got {about!r}.")
    at_rest = not np.any(y[n:])
    if at_rest and all(_persistence_defect(system, _parameter_array(
            system, fixed, amplitude, frequency, A, w), y, 2 * math.pi / w) is None
            for A, w in probes):
        return None
    center = None
    if at_rest and all(symmetry_defect(system, _parameter_array(
            system, fixed, amplitude, frequency, A, w), y[:n], 2 * math.pi / w)
            <= SYMMETRY_RTOL for A, w in probes):
        center = y[:n].copy()
    q = np.round(y[:n], 12).tolist()
    label = (f"periodic orbit symmetric about q = {q}" if center is not None else
             f"periodic orbit near q = {q}" if at_rest else
             f"periodic orbit through [q, q̇] = {np.round(y, 12).tolist()}")
    return OrbitRequest(state=y, center=center, seed=None, label=label)


def _given_orbit(system, fixed, orbit, amplitude, frequency):
    """A :class:`PeriodicOrbit` as the request: its state, seed and symmetry."""
    if tuple(orbit.coordinates) != tuple(system.coordinates):
        raise ValueError(f"about: the periodic orbit has the coordinates "
                         f"{list(orbit.coordinates)}, the system {list(system.coordinates)}.")
    if orbit.periods != 1:
        raise ValueError(f"about: maps, windows and boundaries follow T-periodic orbits; this "
                         f"orbit has periods = {orbit.periods}.")
    for k, v in fixed.items():
        if k in orbit.params and not np.isclose(orbit.params[k], v, rtol=1e-12, atol=0.0):
            raise ValueError(f"about: the periodic orbit was found with {k} = "
                             f"{orbit.params[k]!r}, params has {k} = {v!r}; the orbit must "
                             "belong to the system analysed.")
    for name in (amplitude, frequency):
        if name not in orbit.params:
            raise ValueError(f"about: the periodic orbit's params have no {name!r}.")
    A_s, w_s = float(orbit.params[amplitude]), float(orbit.params[frequency])
    y = np.asarray(orbit.state, dtype=float)
    center = None
    c = np.asarray(orbit.q_mean, dtype=float)
    p = _parameter_array(system, fixed, amplitude, frequency, A_s, w_s)
    T = 2 * math.pi / w_s
    if symmetry_defect(system, p, c, T) <= SYMMETRY_RTOL:
        # the field has the symmetry about the orbit's mean: keep it where the orbit has it
        m = _Map(system, p, T, c, 1e-12, MAX_STEPS)
        fl = m.flow(y, 64)
        if fl is not None and np.max(np.abs(m.residual1(y, fl))) <= 1e-6 * max(1.0, np.max(
                np.abs(y))):
            center = c
    label = (f"periodic orbit through [q, q̇] = {np.round(y, 9).tolist()} at {amplitude} = "
             f"{A_s:.6g}, {frequency} = {w_s:.6g}" + (" (symmetric)" if center is not None
                                                      else ""))
    return OrbitRequest(state=y.copy(), center=center, seed=(A_s, w_s), label=label)


def _side(shot):
    """The sign of det(∂G/∂y) of the equations shot (X − I, or R X_h − I): it changes
    only where the branch has a fold or a branch point (or where a step jumped)."""
    J = (shot.reduced if shot.reduced is not None else shot.monodromy) \
        - np.eye(shot.state.size)
    return int(np.sign(np.linalg.det(J)))


class Line:
    """Orbits of one branch along one parameter x (see the module docstring).

    ``solve(x, y, steps)`` shoots from the guess y at x (a :class:`Shot` or None);
    ``residual(x, y, steps)`` gives G(y) of the equations shot at x, for the tangents;
    ``scale(x)`` the weights of the balanced variables (1 for q, 1/ω for q̇)."""

    def __init__(self, x0, shot0, solve, residual, scale, tol):
        self.x = [float(x0)]
        self.shots = [shot0]
        self.slopes: list[np.ndarray | None] = [None]
        self.solve, self.residual, self.scale, self.tol = solve, residual, scale, tol
        self.dead = [-math.inf, math.inf]      # beyond these the branch has ended
        self.solves = 0

    def at(self, x) -> Shot | None:
        """The branch's orbit at x, or None where the branch does not reach x."""
        x = float(x)
        i = bisect.bisect_left(self.x, x)
        if i < len(self.x) and self.x[i] == x:
            return self.shots[i]
        if not (self.dead[0] < x < self.dead[1]):
            return None
        if 0 < i < len(self.x):
            # between two solved points of one branch (joined by accepted steps): the
            # linear interpolation, accepted where the corrector stays within JUMP × the
            # two points' difference
            (xa, sa), (xb, sb) = (self.x[i - 1], self.shots[i - 1]), (self.x[i], self.shots[i])
            u = (x - xa) / (xb - xa)
            pred = (1 - u) * sa.state + u * sb.state
            self.solves += 1
            shot = self.solve(x, pred, max(sa.steps, sb.steps))
            if shot is not None and self._small(x, shot.state - pred, sb.state - sa.state,
                                                shot) and _side(shot) in (_side(sa), _side(sb)):
                self._insert(x, shot, None)
                return shot
            return self._march(x, i - 1 if u < 0.5 else i)
        return self._march(x, 0 if i == 0 else len(self.x) - 1)

    def _insert(self, x, shot, slope):
        i = bisect.bisect_left(self.x, x)
        self.x.insert(i, x)
        self.shots.insert(i, shot)
        self.slopes.insert(i, slope)

    def _small(self, x, error, step, shot):
        """|error| ≤ JUMP |step| + the shooting's accuracy (balanced variables)."""
        d = self.scale(x)
        size = max(1.0, float(np.max(np.abs(d * shot.state))))
        # the shooting's own first-order accuracy (a scale, not a bound; none where J is
        # singular: then only the tolerance)
        linear = shot.linear_error if math.isfinite(shot.linear_error) else 0.0
        floor = max(100.0 * self.tol, 10.0 * linear) * size
        return float(np.max(np.abs(d * error))) <= JUMP * float(np.max(np.abs(d * step))) \
            + floor

    def _slope(self, x, shot):
        """dy/dx at a solved point: the tangent −(∂G/∂y)⁻¹ ∂G/∂x, with ∂G/∂y the shot's
        (X − I, or R X_h − I on the half period) and ∂G/∂x ≈ G(x + h, y)/h (G(x, y) is the
        converged residual, ≤ tol: the slope's relative error is ~ tol/(h |∂G/∂x|) ≈ 1e-3,
        ample for a predictor and its check); None where it cannot be had."""
        h = 1e-5 * max(abs(x), 1e-2)
        g = self.residual(x + h, shot.state, shot.steps)
        J = (shot.reduced if shot.reduced is not None else shot.monodromy) \
            - np.eye(shot.state.size)
        if g is None:
            return None
        try:
            v = -np.linalg.solve(J, g / h)
        except np.linalg.LinAlgError:
            return None
        return v if np.all(np.isfinite(v)) else None

    def _march(self, x, k):
        """Continue from the solved point k to x in accepted steps (halved where
        rejected); None (and the branch marked ended) where the step falls below
        MIN_STEP.

        A step h from (x0, y0) to x1 predicts y0 + y0′ h (Euler, on the tangent) and is
        accepted where Newton converges to y1 with |y1 − y0 − y0′ h| and, backwards,
        |y0 − y1 + y1′ h| both within JUMP × the predicted move (plus the shooting's
        accuracy): on a smooth branch the misses are O(h²) against O(h), and where the
        branch turns (a fold, the square-root end of a branch born at a pitchfork) the
        tangents at the two ends disagree unless h is small against the distance to the
        turn — a step that lands on another branch, or beyond the end, fails one of the
        two, whatever its length.  A step across which det(∂G/∂y) changes sign is also
        rejected unless shorter than CROSS_STEP × |x|: the sign changes on a branch only
        at a fold or a branch point, and a long step that lands on another branch with
        similar tangents (the damped elliptic pivot's hanging orbit turning sharply into
        the tilted one, with the far side of a fold nearby) changes it; refined, the
        branch followed either shows the crossing within a short step or turns away."""
        direction = 1 if x > self.x[k] else -1
        h = x - self.x[k]
        failed = x               # the nearest point a step failed to reach: not overshot
        while True:
            x0, s0 = self.x[k], self.shots[k]
            if self.slopes[k] is None:
                self.slopes[k] = self._slope(x0, s0)
            v0 = self.slopes[k]
            if v0 is None:                      # singular at x0: the branch turns here
                self.dead[1 if direction > 0 else 0] = x0
                return None
            h = direction * min(abs(h), abs(failed - x0))
            while True:
                x1 = x0 + h if abs(failed - x0 - h) > 1e-12 * max(abs(x), 1.0) else failed
                pred = s0.state + v0 * (x1 - x0)
                self.solves += 1
                shot = self.solve(x1, pred, s0.steps)
                v1 = None
                crossing = shot is not None and _side(shot) != _side(s0) and \
                    abs(x1 - x0) > CROSS_STEP * max(abs(x0), abs(x1))
                if shot is not None and not crossing and self._small(
                        x1, shot.state - pred, pred - s0.state, shot):
                    v1 = self._slope(x1, shot)
                    back = shot.state - v1 * (x1 - x0) if v1 is not None else None
                    if back is not None and self._small(x0, s0.state - back,
                                                        shot.state - back, s0):
                        break
                failed = x1
                h /= 2
                if abs(h) < MIN_STEP * max(abs(x0), abs(x), 1e-300):
                    self.dead[1 if direction > 0 else 0] = x0 + 2 * h
                    return None
            self._insert(x1, shot, v1)
            if x1 == x:
                return shot
            if x1 == failed:                    # reached after all, from closer
                failed = x
            k = bisect.bisect_left(self.x, x1)
            h *= 2


class Follower:
    """The orbits of one request over any (amplitude, ω) points: per ω a :class:`Line` in
    the amplitude, seeded by Newton from the request's guess at ``start`` (the lowest
    amplitude of the grid), or — for a given orbit — from a Line in ω at the orbit's
    amplitude, itself seeded by the orbit.  ``at(A, ω)`` → :class:`Shot` or None."""

    def __init__(self, system, fixed, request, amplitude, frequency, tol, start):
        self.system, self.fixed, self.request = system, dict(fixed), request
        self.amplitude, self.frequency, self.tol = amplitude, frequency, float(tol)
        self.start = float(start)
        self.lines: dict[float, Line | None] = {}
        self.why: dict[float, str] = {}
        self.across = None            # the Line in ω of a given orbit
        self.n = system.n_dof

    # -- the equations shot at one (A, ω) -------------------------------------------------
    def _p(self, A, w):
        return _parameter_array(self.system, self.fixed, self.amplitude, self.frequency, A, w)

    def shoot(self, A, w, y, steps=None) -> Shot | None:
        try:
            shot = shoot(self.system, self._p(A, w), np.asarray(y, float), 2 * math.pi / w,
                         center=self.request.center, tol=self.tol, max_iterations=MAX_NEWTON,
                         max_steps=min(MAX_STEPS, MAX_STEP_GROWTH * steps) if steps
                         else MAX_STEPS, steps=steps if steps else None)
        except (ValueError, np.linalg.LinAlgError, FloatingPointError):
            return None
        if not (np.all(np.isfinite(shot.state)) and np.all(np.isfinite(shot.monodromy))):
            return None
        return shot

    def shoot_once(self, shot, w, tol) -> Shot | None:
        """The orbit of ``shot`` (at ω = ``w``, its amplitude) shot again from its state to
        the residual ``tol`` (a second monodromy, for its error)."""
        A = self._amplitude_of(shot, w)
        try:
            return shoot(self.system, self._p(A, w), shot.state, 2 * math.pi / w,
                         center=self.request.center, tol=tol, max_iterations=MAX_NEWTON,
                         max_steps=min(MAX_STEPS, MAX_STEP_GROWTH * max(shot.steps, 8)),
                         steps=shot.steps)
        except (ValueError, np.linalg.LinAlgError, FloatingPointError):
            return None

    def _amplitude_of(self, shot, w):
        line = self.lines[float(w)]
        assert line is not None              # the shot came from it
        return line.x[next(i for i, s in enumerate(line.shots) if s is shot)]

    def _residual(self, A, w, y, steps):
        m = _Map(self.system, self._p(A, w), 2 * math.pi / w, self.request.center,
                 self.tol / 100, MAX_STEPS)
        fl = m.flow(y, max(8, steps // 2))
        return None if fl is None else m.residual1(y, fl)

    def _scale(self, w):
        return np.r_[np.ones(self.n), np.full(self.n, 1.0 / w)]

    def _line_in_A(self, w, A0, shot):
        return Line(A0, shot, lambda A, y, s: self.shoot(A, w, y, s),
                    lambda A, y, s: self._residual(A, w, y, s), lambda A: self._scale(w),
                    self.tol)

    # -- per ω ---------------------------------------------------------------------------
    def _near(self, y, guess, w):
        """Whether a seed orbit's state is near the guess: within NEAR × max(1, |guess|) in
        the balanced variables (Newton from a state near no orbit wanders to another one,
        e.g. an equilibrium a radian away)."""
        d = self._scale(w)
        return float(np.max(np.abs(d * (y - guess)))) <= NEAR * max(
            1.0, float(np.max(np.abs(d * guess))))

    def line(self, w) -> Line | None:
        w = float(w)
        if w in self.lines:
            return self.lines[w]
        req = self.request
        if req.seed is None:
            A0 = self.start
            shot = self.shoot(A0, w, req.state)
            where = f"at {self.amplitude} = {A0:.6g}, {self.frequency} = {w:.6g}"
            if shot is None:
                self.why[w] = f"Newton shooting from about found no periodic orbit {where}"
            elif not self._near(shot.state, req.state, w):
                self.why[w] = (f"Newton shooting from about went to the orbit through "
                               f"{np.round(shot.state, 6).tolist()} {where}, not one near about")
                shot = None
        else:
            A0, w_s = req.seed
            if self.across is None:
                first = self.shoot(A0, w_s, req.state)
                if first is None:
                    raise ValueError(f"about: Newton shooting from the given orbit's state "
                                     f"found no periodic orbit at {self.amplitude} = {A0:.6g}, "
                                     f"{self.frequency} = {w_s:.6g} (the orbit's own "
                                     "parameters); pass the orbit of this system and params.")
                self.across = Line(w_s, first, lambda x, y, s: self.shoot(A0, x, y, s),
                                   lambda x, y, s: self._residual(A0, x, y, s), self._scale,
                                   self.tol)
            shot = self.across.at(w)
            if shot is None:
                self.why[w] = (f"the given orbit, followed in {self.frequency} at "
                               f"{self.amplitude} = {A0:.6g}, does not reach {w:.6g} (its "
                               "branch ends at a fold or a branch point before)")
        self.lines[w] = None if shot is None else self._line_in_A(w, A0, shot)
        return self.lines[w]

    def at(self, A, w) -> Shot | None:
        line = self.line(w)
        return None if line is None else line.at(A)

    @property
    def solves(self) -> int:
        lines = [ln for ln in self.lines.values() if ln is not None]
        if self.across is not None:
            lines.append(self.across)
        return sum(ln.solves for ln in lines)
