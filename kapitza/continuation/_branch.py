"""Following a branch: pseudo-arclength steps, their control, the end of the branch, the
result; and switching onto the branch that emanates from a bifurcation."""
from __future__ import annotations

import math
import warnings

import numpy as np

from lagrange_core.progress import ProgressLine

from ..results import Bifurcation, Branch, BranchPoints, ComputationInterrupted
from ._bifurcations import detect, detect_half_period
from ._points import make_point, orbit_statistics
from ._shooting import CorrectorFailed, PeriodMap, correct, tangent

__all__ = ["Engine"]

#: Consecutive unit tangents must agree to this cosine (about 25°), else the step is
#: retried shorter (it may have jumped to another branch or over a sharp turn).
MIN_COSINE = 0.9
#: A step is retried shorter when the corrector moved the point farther than this many
#: steps from the predictor.
MAX_CORRECTION = 0.5
#: The smallest step, relative to the first.
MIN_STEP = 1e-5


class Engine:
    """Everything a branch of one system needs to continue: the system, the parameters,
    the options; builds :class:`~kapitza.results.Branch` results and switches branches
    (it is the ``_engine`` of every branch it builds)."""

    def __init__(self, system, params, parameter, frequency, tol, progress):
        self.system, self.params = system, dict(params)
        self.parameter, self.frequency = parameter, frequency
        self.tol, self.progress = tol, progress
        self.conservative = None

    # -- tracing ---------------------------------------------------------------------
    def trace(self, pm, start, *, domain, step, max_step, max_points, stacklevel=4,
              origin=""):
        """Follow the branch from ``start`` (a list of Points, the last with its
        tangent) through ``domain`` = (lo, hi) of the parameter; returns a Branch.
        ``stacklevel`` points a warning at the user's call; ``origin`` says where a
        switched branch starts."""
        h = step / pm.p_scale
        h_max, h_min = max_step / pm.p_scale, MIN_STEP * step / pm.p_scale
        lo, hi = ((d - pm.p0) / pm.p_scale for d in domain)
        points, bifurcations = list(start), []
        first = points[0]
        status, message = None, ""
        bar = ProgressLine(self.progress, max_points, "continuation", "points")
        flows0 = pm.flows
        near_start = True
        previous = points[-2] if len(points) > 1 else None   # the last two steps' points
        try:
            while status is None:
                if len(points) >= max_points:
                    status = "max_points"
                    message = (f"stopped after max_points = {max_points} points at "
                               f"{self.parameter} = {points[-1].p:.10g}, before the end of "
                               f"the interval {domain}; raise max_points (or step)")
                    break
                cur = points[-1]
                try:
                    new = self._step(pm, cur, h, previous)
                except CorrectorFailed as e:
                    if h / 2 >= h_min:
                        h /= 2
                        continue
                    status = "singular" if e.singular else (
                        "step_too_small" if e.retry else "corrector_failed")
                    message = (f"{e}; the step shrank below its minimum "
                               f"({h_min * pm.p_scale:.3g} in {self.parameter}) at "
                               f"{self.parameter} = {cur.p:.10g}")
                    break
                ended = not (lo - 1e-12 <= new.v[-1] <= hi + 1e-12)
                if ended:
                    try:
                        new = self._boundary(pm, cur, new, lo if new.v[-1] < lo else hi)
                    except CorrectorFailed as e:    # retried shorter
                        if h / 2 >= h_min:
                            h /= 2
                            continue
                        status, message = "corrector_failed", f"at the interval's end: {e}"
                        break
                half = detect_half_period(self, pm, cur, new)
                if half is not None:
                    new, ended = half[0], True     # the branch ends at the meeting point
                # det(M − I) vanishes where the branch ends on orbits of half the period
                for pt, info in detect(self, pm, cur, new, skip=(0,) if half else ()):
                    bifurcations.append((pt, info))
                    points.append(pt)
                if half is not None:
                    bifurcations.append(half)
                points.append(new)
                previous = cur
                bar.update(min(len(points), max_points))
                if half is not None:
                    status = "completed"
                    message = f"at {self.parameter} = {new.p:.10g}, {half[1]['note']}"
                    break
                if ended:
                    new.label = "end"
                    status = "completed"
                    message = f"reached the end of the interval at {self.parameter} = {new.p:.10g}"
                    break
                dist = float(np.linalg.norm(new.v - first.v))
                if near_start:
                    near_start = dist < 2 * h
                elif dist < 0.5 * h and len(points) > 4:
                    status = "closed"
                    message = ("the branch came back to its first point (a closed curve) at "
                               f"{self.parameter} = {new.p:.10g}")
                    break
                its = new.iterations
                h = min(h * 1.5, h_max) if its <= 3 else (h * 0.6 if its >= 6 else h)
        except KeyboardInterrupt:
            bar.close()
            result = self._result(pm, points, bifurcations, domain, "interrupted",
                                  "interrupted (Ctrl-C): the points computed so far",
                                  pm.flows - flows0, origin)
            raise ComputationInterrupted(result, np.ones(len(result.points), bool)) from None
        bar.close()
        if status not in ("completed", "closed"):
            warnings.warn(f"continuation: {message} (status {status!r}; the branch so far is "
                          "returned).", RuntimeWarning, stacklevel=stacklevel)
        return self._result(pm, points, bifurcations, domain, status, message,
                            pm.flows - flows0, origin)

    def _step(self, pm, cur, h, previous):
        """One pseudo-arclength step of length h from ``cur``; raises CorrectorFailed
        where it must be retried shorter.

        The corrector's ∂G/∂s column is extrapolated linearly along the arclength from
        the last two points (error O(h²): a chord from ``cur`` alone converges only
        linearly where ∂G/∂s changes fast, e.g. near a branch point, where it grows from
        zero); the first step, or one whose extrapolated corrector fails, computes it at
        every iterate."""
        v_pred = cur.v + h * cur.t
        Gs = None
        if previous is not None and cur.sigma > previous.sigma:
            Gs = cur.Gs + (cur.Gs - previous.Gs) * h / (cur.sigma - previous.sigma)
        try:
            ev, its = correct(pm, v_pred, cur.t, Gs)
        except CorrectorFailed:
            if Gs is None:
                raise
            ev, its = correct(pm, v_pred, cur.t, None)
        if float(np.linalg.norm(ev.v - v_pred)) > MAX_CORRECTION * h:
            raise CorrectorFailed("the corrector moved the point farther than half a step "
                                  "from the predictor", retry=True)
        if its == 0 and Gs is not None:
            # the predictor was on the branch to the tolerance (a straight branch, e.g.
            # an equilibrium that persists): the extrapolated column is exact to O(h²)
            Gs = Gs
        else:
            Gs = pm.derivative_s(ev)
        t = tangent(pm, ev, Gs, cur.t)
        if float(t @ cur.t) < MIN_COSINE:
            raise CorrectorFailed("the branch's tangent turned by more than 25° in one step",
                                  retry=True)
        new = make_point(pm, ev, Gs, t, cur.sigma + h, conservative=self.conservative)
        new.iterations = its
        return new

    def _boundary(self, pm, cur, new, s_end):
        """The point at the interval's end s_end, between ``cur`` and ``new``."""
        w = (s_end - cur.v[-1]) / (new.v[-1] - cur.v[-1])
        v_pred = (1 - w) * cur.v + w * new.v
        v_pred[-1] = s_end
        row = np.zeros(pm.d + 1)
        row[-1] = 1.0
        try:
            ev, _ = correct(pm, v_pred, row, cur.Gs)
        except CorrectorFailed:
            ev, _ = correct(pm, v_pred, row, None)
        Gs = pm.derivative_s(ev)
        t = tangent(pm, ev, Gs, cur.t)
        return make_point(pm, ev, Gs, t, cur.sigma + float(cur.t @ (ev.v - cur.v)),
                          conservative=self.conservative)

    # -- results ---------------------------------------------------------------------
    def _result(self, pm, points, bifurcations, domain, status, message, flows, origin):
        n = pm.n
        k = len(points)
        stats = [orbit_statistics(pm, pt.ev.x, pt.p) for pt in points]
        mult = np.array([pt.multipliers for pt in points]).reshape(k, 2 * n)
        table = BranchPoints(
            parameter=np.array([pt.p for pt in points]),
            state=np.array([pt.ev.x for pt in points]).reshape(k, 2 * n),
            q_mean=np.array([s[0] for s in stats]).reshape(k, n),
            amplitude=np.array([s[1] for s in stats]).reshape(k, n),
            multipliers=mult,
            stable=np.array([pt.stable for pt in points], dtype=bool),
            arclength=np.array([pt.sigma for pt in points]),
            residual=np.array([pt.ev.residual for pt in points]),
            error_estimate=np.array([pt.ev.error for pt in points]),
            label=np.array([pt.label for pt in points], dtype=object))
        index = {id(pt): i for i, pt in enumerate(points)}
        bifs = tuple(Bifurcation(state=pt.ev.x.copy(), multipliers=pt.multipliers.copy(),
                                 index=index[id(pt)], periods=pm.periods,
                                 **dict(info, parameter=float(info["parameter"]),
                                        accuracy=float(info["accuracy"])))
                     for pt, info in bifurcations)
        params = dict(self.params)
        params[self.parameter] = float(points[0].p) if points else params.get(self.parameter)
        branch = Branch(coordinates=tuple(self.system.coordinates), parameter=self.parameter,
                        params=params, frequency=self.frequency, periods=pm.periods,
                        points=table, bifurcations=bifs, domain=tuple(float(d) for d in domain),
                        status=status, message=message, tol=self.tol, flows=int(flows),
                        origin=origin, winding=pm.winding(), _engine=_Handle(self, pm))
        return branch

    # -- starting ----------------------------------------------------------------------
    def start(self, x0, p0, stop, *, periods, step, max_step, max_points, winding=None):
        """The branch through the orbit nearest x0 at p0 (rotating ``winding`` turns per
        coordinate over ``periods``, or None), followed towards ``stop``."""
        self.options = dict(step=step, max_step=max_step, max_points=max_points)
        p_scale = abs(stop - p0)
        pm = PeriodMap(self.system, self.params, self.parameter, self.frequency, periods,
                       self.tol, p0, p_scale, winding=winding)
        v0 = pm.scaled(x0, p0)
        ev = pm.evaluate(v0)
        if ev is None:
            raise ValueError(f"continuation: the flow over one period from about = "
                             f"{x0.tolist()} failed (non-finite or not converged); start from "
                             "another state.")
        self.conservative = abs(float(np.linalg.det(ev.M)) - 1.0) <= 1e-8
        row = np.zeros(pm.d + 1)
        row[-1] = 1.0
        try:
            Gs = pm.derivative_s(ev)
            ev, _ = correct(pm, v0, row, Gs, ev=ev, max_iterations=40)
            Gs = pm.derivative_s(ev)
            t = tangent(pm, ev, Gs, math.copysign(1.0, stop - p0) * row)
        except CorrectorFailed as e:
            raise ValueError(f"continuation: no periodic orbit found near about = "
                             f"{x0.tolist()} at {self.parameter} = {p0!r} ({e}); start from "
                             "a state on the orbit (e.g. kapitza.periodic_orbit's .state).") \
                from None
        first = make_point(pm, ev, Gs, t, 0.0, conservative=self.conservative, label="start")
        return self.trace(pm, [first], domain=(min(p0, stop), max(p0, stop)), step=step,
                          max_step=max_step, max_points=max_points)

    # -- switching ---------------------------------------------------------------------
    def switch(self, pm, branch, b, *, direction, step, stop, max_points):
        opts = self.options
        if b.kind == "fold":
            raise ValueError("a fold has no emanating branch: the branch only turns there "
                             "(it is followed through it already).")
        if b.kind == "neimark_sacker":
            raise ValueError("a Neimark–Sacker point gives birth to quasi-periodic motion on a "
                             "torus, not to periodic orbits: there is no branch to switch to.")
        step = opts["step"] if step is None else float(step)
        max_points = opts["max_points"] if max_points is None else int(max_points)
        domain = branch.domain if stop is None else (min(b.parameter, stop),
                                                     max(b.parameter, stop))
        origin = (f"the {b.kind.replace('_', ' ')} at {self.parameter} = {b.parameter:.10g}"
                  f" (direction {direction:+d})")
        trace = dict(domain=domain, step=step, max_step=opts["max_step"],
                     max_points=max_points, stacklevel=5, origin=origin)
        halving = b.kind == "period_doubling" and b.test_function != "det(M + I)"
        if halving:
            # met from a branch of twice the period: the orbits of half the period through
            # the point, a regular branch there (their multiplier is −1, not +1)
            new_pm = pm.with_periods(pm.periods // 2)
        elif b.kind == "period_doubling":
            new_pm = pm.with_periods(2 * pm.periods)
        else:
            new_pm = pm
        v_star = new_pm.scaled(b.state, b.parameter)
        ev0 = new_pm.evaluate(v_star)
        if ev0 is None:
            raise ValueError(f"the flow at the {b.kind} point failed.")
        Gs0 = new_pm.derivative_s(ev0)
        if halving:
            row = np.zeros(new_pm.d + 1)
            row[-1] = float(direction)
            t0 = tangent(new_pm, ev0, Gs0, row)
            first = make_point(new_pm, ev0, Gs0, t0, 0.0, conservative=self.conservative,
                               label=b.kind)
            return self.trace(new_pm, [first], **trace)
        d = np.r_[new_pm.D * b.direction[:-1], b.direction[-1] / new_pm.p_scale]
        d = direction * d / np.linalg.norm(d)
        first = make_point(new_pm, ev0, Gs0, d, 0.0, conservative=self.conservative,
                           label=b.kind)
        # the first point off the bifurcation: at distance h along d (the corrector keeps
        # that component), ∂G/∂s exact at every iterate (it vanishes on a branch of
        # equilibria that persist, and changes fast near any branch point)
        h = step / new_pm.p_scale
        for _ in range(12):
            try:
                ev1, _ = correct(new_pm, v_star + h * d, d, None)
                Gs1 = new_pm.derivative_s(ev1)
                t1 = tangent(new_pm, ev1, Gs1, d)
                break
            except CorrectorFailed:
                h /= 2
        else:
            raise ValueError(f"could not start the branch emanating from the {b.kind} at "
                             f"{self.parameter} = {b.parameter:.10g}: the corrector failed "
                             "even at small distances.")
        second = make_point(new_pm, ev1, Gs1, t1, h, conservative=self.conservative)
        return self.trace(new_pm, [first, second], **trace)


class _Handle:
    """A branch's ``_engine``: the engine and the period map it was traced on."""

    def __init__(self, engine, pm):
        self.engine, self.pm = engine, pm

    def switch(self, branch, b, **options):
        return self.engine.switch(self.pm, branch, b, **options)
