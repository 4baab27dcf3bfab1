"""Bifurcations between two consecutive points of a branch: detection by sign changes of
test functions, location by the Anderson–Björck method along the arclength, and the
classification of branch points by probing the branch that emanates.

Test functions (:func:`kapitza.continuation._shooting.test_functions`)
----------------------------------------------------------------------
* det(M − I) changes sign where a multiplier passes +1.  If the tangent's parameter
  component changes sign too, the parameter turns there: a **fold**.  Otherwise another
  branch crosses (a branch point): its emanating direction is the null vector of
  [M − I, ∂φ/∂p] not tangent to this branch, and a probe at a small distance h on each
  side (a corrected point with the component along that vector fixed to ±h) tells the
  two apart: a **pitchfork** has both probes on the same side of the parameter (mirror
  images, the parameter ∝ h²), a **transcritical** point one on each (∝ h).  On a
  branch of period n T a branch point whose orbit has period n T/2 is where it meets the
  orbits of half the period: a **period_doubling** of those.
* det(M + I) changes sign where a multiplier passes −1: a **period_doubling**; a probe
  on the doubled period map along the eigenvector for −1 gives the side of the born
  branch.
* det(M ⊙ M − I) (the bialternate product: Π_{i<j}(λ_i λ_j − 1)) changes sign where a
  complex pair crosses the unit circle, a **neimark_sacker** point, or where two real
  multipliers pass λ_i λ_j = 1 (a neutral saddle, not a bifurcation: skipped).  Not
  used on conservative systems, where it vanishes identically.

Location and accuracy
---------------------
The root of the test function along the arclength between the two points is found by
the Anderson–Björck (Illinois-type) method; each evaluation is a corrected point on the
hyperplane ⟨t, v − v_k⟩ = σ of the step.  It stops when the bracket in the parameter is
below ``1e-3 tol`` (relative to the interval, at least the rounding of p) or where the
test function's value is within its error bound (its sign is then not certified).  The
reported accuracy is the largest distance in the parameter from the located point to the
certified bracket's ends, plus the parameter component of the next Newton correction
(the corrector tolerance's effect), plus at a fold the parabola's rise over the bracket.
"""
from __future__ import annotations

import dataclasses
import math

import numpy as np

from ._points import make_point
from ._shooting import CorrectorFailed, correct, null_directions, test_functions

__all__ = ["detect", "detect_half_period", "TEST_FUNCTIONS"]

TEST_FUNCTIONS = ("det(M − I)", "det(M + I)", "det(M ⊙ M − I)")
#: Distance (scaled units, ~rad) of the probes that classify branch points: the born
#: branch's parameter moves by ~ PROBE² there (a pitchfork), resolved far above the
#: location's accuracy, while the probe stays in the bifurcation's neighbourhood.
PROBE = 1e-2
#: Most evaluations of one location.
MAX_EVALUATIONS = 60


def _at(pm, cur, a, b, sigma, Gs):
    """The corrected point at arclength ``sigma`` of the step from ``cur`` (on the
    hyperplane ⟨cur.t, v − cur.v⟩ = sigma), predicted by interpolating brackets a, b."""
    w = (sigma - a.sigma) / (b.sigma - a.sigma) if b.sigma != a.sigma else 0.0
    v_pred = (1 - w) * a.v + w * b.v
    # the interpolation lies on the hyperplane already; project to remove rounding
    v_pred = v_pred + (sigma - cur.t @ (v_pred - cur.v)) * cur.t
    try:
        ev, _ = correct(pm, v_pred, cur.t, Gs)
    except CorrectorFailed:          # the chord ∂G/∂s from ``cur``: exact at every iterate
        ev, _ = correct(pm, v_pred, cur.t, None)
    return ev


def _point(engine, pm, cur, a, b, sigma):
    ev = _at(pm, cur, a, b, sigma, cur.Gs)
    return make_point(pm, ev, cur.Gs, cur.t, sigma, conservative=engine.conservative)


def _certified_bracket(engine, pm, cur, a, b, c, f):
    """Ends, on each side of ``c`` (whose test function f is within its error bound), as
    close to it as the error allows and with certified signs: from c outwards by 4, 16,
    64 … times the error's width along the arclength (the secant slope of a, b)."""
    (fa, _), (fb, _), (_, ec) = f(a), f(b), f(c)
    slope = abs((fb - fa) / (b.sigma - a.sigma)) if b.sigma != a.sigma else 0.0
    ends = sorted((a, b), key=lambda q: q.sigma)
    out = []
    for end, sign in ((ends[0], -1.0), (ends[1], 1.0)):
        width = 4 * ec / slope if slope > 0 else math.inf
        found, f_end = end, f(end)[0]
        for _ in range(6):
            sigma = c.sigma + sign * width
            if not ends[0].sigma < sigma < ends[1].sigma:
                break
            try:
                q = _point(engine, pm, cur, ends[0], ends[1], sigma)
            except CorrectorFailed:
                break
            fq, eq = f(q)
            if abs(fq) > eq and fq * f_end > 0:
                found = q
                break
            width *= 4
        out.append(found)
    return out[0], out[1]


def _locate(engine, pm, cur, new, f, *, fold=False):
    """Anderson–Björck on the test function f(point) → (value, error bound) between
    ``cur`` (σ = 0) and ``new``.  Returns (point, accuracy in the parameter)."""
    a = dataclasses.replace(cur, sigma=0.0)
    b = dataclasses.replace(new, sigma=float(cur.t @ (new.v - cur.v)))
    fa, fb = f(a)[0], f(b)[0]
    ptol = max(1e-3 * pm.tol * pm.p_scale, 4 * np.finfo(float).eps * max(abs(a.p), abs(b.p)))
    best, history, uncertain = (a if abs(fa) < abs(fb) else b), [a, b], False
    for _ in range(MAX_EVALUATIONS):
        if abs(a.p - b.p) <= ptol and abs(a.sigma - b.sigma) <= 1e-6 * abs(b.sigma):
            break
        sigma = (a.sigma * fb - b.sigma * fa) / (fb - fa)
        lo, hi = sorted((a.sigma, b.sigma))
        margin = 1e-3 * (hi - lo)                 # keep strictly inside the bracket
        sigma = min(max(sigma, lo + margin), hi - margin)
        try:
            c = _point(engine, pm, cur, a, b, sigma)
        except CorrectorFailed:
            break
        history.append(c)
        fc, ec = f(c)
        if abs(fc) < abs(f(best)[0]):
            best = c
        if abs(fc) <= ec or fc == 0:              # its sign is not certified: stop here
            best, uncertain = c, True
            break
        if fc * fb < 0:
            a, fa = b, fb
        else:
            m = 1.0 - fc / fb
            fa *= m if m > 0 else 0.5
        b, fb = c, fc
    if uncertain:
        a, b = _certified_bracket(engine, pm, cur, a, b, best, f)
    acc = max(abs(best.p - a.p), abs(best.p - b.p))
    # the corrector tolerance's effect: the parameter part of the next Newton correction
    try:
        B = np.block([[pm.jacobian_z(best.ev), cur.Gs[:, None]], [cur.t[None, :]]])
        step = np.linalg.solve(B, -np.r_[best.ev.G, 0.0])
        acc += abs(step[-1]) * pm.p_scale
    except np.linalg.LinAlgError:
        acc = math.inf
    if fold and len(history) >= 3:
        # a fold: the parameter's extreme lies between the bracket's ends
        s = np.array([h.sigma for h in history[-3:]])
        p = np.array([h.p for h in history[-3:]])
        if len(set(s.tolist())) == 3:
            # the parabola through the three: its leading coefficient, the second divided
            # difference (np.polyfit warned "poorly conditioned" on points this close)
            curv = abs(((p[2] - p[1]) / (s[2] - s[1]) - (p[1] - p[0]) / (s[1] - s[0]))
                       / (s[2] - s[0]))
            acc += curv * (a.sigma - b.sigma) ** 2
    acc = max(acc, 4 * np.finfo(float).eps * abs(best.p))
    return best, acc


def _direction(pm, ev, Gs, t):
    """The null direction of [G_z, G_s] orthogonal to the tangent ``t`` (scaled)."""
    basis = null_directions(pm, ev, Gs, 2)
    d = basis - np.outer(basis @ t, t)
    k = int(np.argmax(np.linalg.norm(d, axis=1)))
    d = d[k] / np.linalg.norm(d[k])
    j = int(np.argmax(np.abs(d)))
    return d if d[j] > 0 else -d


def _probe(pm, v, d, h):
    """The parameter of the point of the emanating branch at distance h along d."""
    v_pred = v + h * d
    ev, _ = correct(pm, v_pred, d, None, min_iterations=2)
    return ev.p


def _unscaled(pm, d):
    return np.r_[d[:-1] / pm.D, d[-1] * pm.p_scale]


def _criticality(cur, new, p_star, side):
    """Supercritical where the emanating branch lies on the side on which this branch
    has more unstable multipliers."""
    if side == 0 or cur.unstable == new.unstable:
        return None
    unstable_side = np.sign((new.p if new.unstable > cur.unstable else cur.p) - p_star)
    return "supercritical" if side == unstable_side else "subcritical"


def _half_periodic(pm, ev):
    """Whether an orbit of period n T (n even) is one of period n T/2."""
    if pm.periods % 2:
        return False
    half = pm.with_periods(pm.periods // 2)
    e = half.evaluate(ev.v)
    return e is not None and e.residual <= 1e-6 * max(1.0, float(np.max(np.abs(ev.x))))


def _classify_branch_point(engine, pm, cur, new, pt, acc):
    Gs = pm.derivative_s(pt.ev)
    d = _direction(pm, pt.ev, Gs, cur.t)
    out = dict(direction=_unscaled(pm, d), test_function=TEST_FUNCTIONS[0])
    if _half_periodic(pm, pt.ev):
        out.update(kind="period_doubling", note=f"the {period_name(pm.periods)} branch meets "
                   f"the orbits of period {period_name(pm.periods // 2)}, which period-double "
                   "here")
        return out
    try:
        dp = [_probe(pm, pt.v, d, s * PROBE) - pt.p for s in (1.0, -1.0)]
    except CorrectorFailed as e:
        out.update(kind="pitchfork", note=f"pitchfork assumed: the probes of the emanating "
                   f"branch failed ({e})")
        return out
    resolved = [abs(x) > 10 * acc for x in dp]
    if not all(resolved):
        out.update(kind="pitchfork", note="pitchfork assumed: the emanating branch's "
                   f"parameter moved by {dp[0]:.2g}, {dp[1]:.2g} at the probes (not "
                   "resolved against the location's accuracy)")
        return out
    if dp[0] * dp[1] > 0:
        side = int(np.sign(dp[0]))
        out.update(kind="pitchfork", side=side, criticality=_criticality(cur, new, pt.p, side),
                   note=f"probes at ±{PROBE:g}: parameter {dp[0]:+.3g}, {dp[1]:+.3g}")
    else:
        out.update(kind="transcritical", note=f"probes at ±{PROBE:g}: parameter "
                   f"{dp[0]:+.3g}, {dp[1]:+.3g}")
    return out


def _classify_period_doubling(engine, pm, cur, new, pt, acc):
    lam, vec = np.linalg.eig(pt.ev.M)
    k = int(np.argmin(np.abs(lam + 1.0)))
    x_dir = np.real(vec[:, k])
    d = np.r_[pm.D * x_dir, 0.0]
    d /= np.linalg.norm(d)
    j = int(np.argmax(np.abs(d)))
    d = d if d[j] > 0 else -d
    out = dict(kind="period_doubling", direction=_unscaled(pm, d),
               test_function=TEST_FUNCTIONS[1])
    double = pm.with_periods(2 * pm.periods)
    try:
        dp = _probe(double, pt.v, d, PROBE) - pt.p
    except CorrectorFailed as e:
        out["note"] = f"the born branch's side was not probed ({e})"
        return out
    if abs(dp) > 10 * acc:
        side = int(np.sign(dp))
        out.update(side=side, criticality=_criticality(cur, new, pt.p, side),
                   note=f"probe at {PROBE:g} on the {period_name(2 * pm.periods)} map: parameter "
                        f"{dp:+.3g}")
    else:
        out["note"] = (f"the born branch's side is not resolved (parameter moved by "
                       f"{dp:.2g} at the probe)")
    return out


def _neimark_sacker(pt):
    lam = pt.multipliers
    pair = (np.abs(lam.imag) > 1e-8) & (np.abs(np.abs(lam) - 1.0) <= 1e-4)
    return bool(np.any(pair))


def period_name(n) -> str:
    """"T", "2T", …: n drive periods."""
    return "T" if n == 1 else f"{n}T"


def _test(i):
    return lambda q: (q.psi[i], q.psi_error[i])


def detect(engine, pm, cur, new, *, skip=()):
    """The bifurcations between ``cur`` and ``new`` as (Point, dict of Bifurcation
    fields), in arclength order; ``skip``: test functions (indices) not to use."""
    found = []
    for i in range(3):
        if i in skip:
            continue
        fa, fb = cur.psi[i], new.psi[i]
        if not (math.isfinite(fa) and math.isfinite(fb)) or fa * fb >= 0:
            continue
        fold = i == 0 and cur.t[-1] * new.t[-1] < 0
        pt, acc = _locate(engine, pm, cur, new, _test(i), fold=fold)
        if fold:
            info = dict(kind="fold", test_function=TEST_FUNCTIONS[0],
                        note="the parameter turns (the tangent's parameter component "
                             "changes sign)")
        elif i == 0:
            info = _classify_branch_point(engine, pm, cur, new, pt, acc)
        elif i == 1:
            info = _classify_period_doubling(engine, pm, cur, new, pt, acc)
        else:
            if not _neimark_sacker(pt):
                continue               # a neutral saddle: not a bifurcation
            info = dict(kind="neimark_sacker", test_function=TEST_FUNCTIONS[2],
                        note="a complex pair crosses the unit circle")
        pt.label = info["kind"]
        pt.sigma += cur.sigma             # from the step's own arclength to the branch's
        info.update(parameter=pt.p, accuracy=acc)
        found.append((pt, info))
    found.sort(key=lambda f: f[0].sigma)
    return found


def detect_half_period(engine, pm, cur, new):
    """Where a branch of n T-periodic orbits (n even) passes through an orbit of period
    n T/2 — it meets the branch of those, at their period doubling, and beyond it
    retraces its own orbits shifted by n T/2: (Point, dict of Bifurcation fields), or
    None.  Found where D (φ_{nT/2}(x) − x), which vanishes there and changes its sign
    through it, turns by more than 90° in one step; located as the root of its component
    along its direction at ``cur``."""
    if cur.half is None or new.half is None:
        return None
    ref = np.linalg.norm(cur.half)
    if not ref > 0 or float(cur.half @ new.half) >= 0:
        return None
    e = cur.half / ref

    def f(q):
        if q.half is None:
            return math.nan, math.inf
        return float(q.half @ e), 100 * pm.d * max(q.half_error, q.ev.error)

    pt, acc = _locate(engine, pm, cur, new, f)
    scale = max(1.0, float(np.max(np.abs(pt.v[:-1]))))
    if pt.half is None or float(np.max(np.abs(pt.half))) > 1e-6 * scale:
        return None                       # it only turned: no orbit of half the period
    # Near the meeting point the hyperplane of the step cuts both branches, and the root
    # found may lie on the half-period one a little off the crossing: the crossing is that
    # branch's period doubling, solved for on it directly (a secant on det(M + I) in p).
    try:
        ev, acc = _period_doubling_of(engine, pm.half, pt.ev.x, pt.p)
        ev = pm.evaluate(pm.scaled(ev.x, ev.p))
        if ev is None:
            raise CorrectorFailed("the flow at the meeting point failed")
        Gs = pm.derivative_s(ev)
        pt = make_point(pm, ev, Gs, cur.t, cur.t @ (ev.v - cur.v),
                        conservative=engine.conservative)
    except CorrectorFailed:
        pass                              # keep the located point and its accuracy
    pt.label = "period_doubling"
    pt.sigma += cur.sigma
    whole, half = period_name(pm.periods), period_name(pm.periods // 2)
    return pt, dict(kind="period_doubling", parameter=pt.p, accuracy=acc,
                    test_function=f"φ_{half}(x) − x",
                    note=f"the {whole} branch meets the orbits of period {half}, which "
                         "period-double here; beyond, it retraces its own orbits shifted "
                         f"by {half}")


def _period_doubling_of(engine, pm, x, p):
    """The period doubling of the branch of ``pm``'s orbits near (x, p): secant steps in
    p on det(M + I), each orbit corrected at fixed p.  Returns (Evaluation, accuracy)."""
    row = np.zeros(pm.d + 1)
    row[-1] = 1.0
    zero = np.zeros(pm.d)              # p is fixed: the ∂G/∂s column is not used

    def g(p, x):
        ev, _ = correct(pm, pm.scaled(x, p), row, zero)
        psi, err = test_functions(ev.M, ev.error, conservative=engine.conservative)
        return psi[1], err[1], ev

    ptol = max(1e-3 * pm.tol * pm.p_scale, 4 * np.finfo(float).eps * abs(p))
    f0, _, ev0 = g(p, x)
    p1 = p + 1e-6 * pm.p_scale
    f1, e1, ev1 = g(p1, ev0.x)
    for _ in range(30):
        if f1 == f0:
            break
        p2 = p1 - f1 * (p1 - p) / (f1 - f0)
        p, f0, ev0 = p1, f1, ev1
        p1 = p2
        f1, e1, ev1 = g(p1, ev0.x)
        if abs(p1 - p) <= ptol or abs(f1) <= e1:
            break
    else:
        raise CorrectorFailed("the secant on det(M + I) did not converge")
    # certify: the sign changes across p1 ± w, w from the error and the secant slope
    slope = abs((f1 - f0) / (p1 - p)) if p1 != p else 0.0
    w = 2 * (abs(f1) + e1) / slope if slope > 0 else math.inf
    w = max(w, ptol)
    try:
        (fa, ea, _), (fb, eb, _) = g(p1 - w, ev1.x), g(p1 + w, ev1.x)
    except CorrectorFailed:
        return ev1, abs(p1 - p) + w
    if fa * fb < 0 and abs(fa) > ea and abs(fb) > eb:
        return ev1, w
    return ev1, abs(p1 - p) + w
