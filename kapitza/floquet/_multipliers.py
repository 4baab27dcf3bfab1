"""From monodromies to multipliers: stability, boundary labels, slow frequencies, margins
and the accuracy guards, for a stack of (scaled) monodromies.

The equilibrium is (linearly, asymptotically) stable when every multiplier λ (eigenvalue
of M) has |λ| < 1, and, for an undamped system, when all lie on the unit circle.  2 × 2:
the Jury condition |tr M| ≤ 1 + det M; undamped 4 × 4 and larger: the reduced polynomial
in x = λ + 1/λ (:func:`kapitza.floquet._margins.reduced_polynomial`), stable iff every
root x is real and in [−2, 2]; damped: max |λ| < 1.  Each classification comes with a
``margin``, the distance of its test from the threshold in units of the test's error.

Accuracy guards
---------------
* Liouville: det M = exp(∮ tr J dt) (tr J = −γ for the damped pendulum, so
  det M = e^(−γT)); ∮ tr J dt is exact from the Fourier mean of J.
* Undamped (∮ tr J dt = 0) Lagrangian systems have a symplectic monodromy: the
  characteristic polynomial is palindromic (multipliers in pairs λ, 1/λ).

A result whose residual exceeds ``guard_tol`` (or, for very large growth, the rounding
floor ≈ 1e-13·max|λ|/min|λ|) is flagged in ``FloquetResult.flags``.
"""
from __future__ import annotations

import numpy as np

from ._margins import poly_eval, reduced_polynomial
from ._monodromy import MAX_STEPS_PER_PERIOD, _balanced, _frozen_growth, _step_count


def _reduced_decision(qc, x, rel_err, norm):
    """Stability and its margin from the reduced polynomial Q(x) (:func:`reduced_polynomial`).

    Stable iff every root x is real (LAPACK returns real eigenvalues of a real matrix
    with zero imaginary part) and |x| ≤ 2.  Each root's uncertainty is Q's error over
    |Q′| (a simple root) or 2√(error/|Q″|) (near a collision), the smaller; Q's error is
    2n × rel_err × max(1, ‖M‖) times Σ|q_k||x|^k.  ``margin`` (> 1 certifies), in units
    of that uncertainty: stable, the smallest over the roots of 2 − |x| and half the gap
    to the nearest other root (where a collision could leave the real axis); unstable,
    the largest distance of a root from the segment [−2, 2].
    """
    npts, n = x.shape
    real = x.imag == 0.0
    stable = np.all(real & (np.abs(x.real) <= 2.0), axis=1)
    k = np.arange(n + 1)
    with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
        dq = (2 * n * rel_err * np.maximum(1.0, norm))[:, None] * np.sum(
            np.abs(qc)[:, None, :] * np.abs(x)[:, :, None] ** k[None, None, :], axis=2)
        d1 = np.abs(poly_eval(qc, x, 1))
        d2 = np.abs(poly_eval(qc, x, 2))
        e = np.minimum(dq / d1, 2.0 * np.sqrt(dq / d2))
        e = np.where(np.isfinite(e), e, np.inf)
        gap = np.abs(x[:, :, None] - x[:, None, :])
        gap[:, np.arange(n), np.arange(n)] = np.inf
        gap = np.where(real[:, :, None] & real[:, None, :], gap, np.inf)
        # stable: every root must stay real and inside; unstable: one root outside suffices
        inside = np.minimum(2.0 - np.abs(x.real), 0.5 * np.min(gap, axis=2))
        outside = np.abs(x - np.clip(x.real, -2.0, 2.0))      # distance to [−2, 2]
        margin = np.where(stable, np.min(inside / e, axis=1), np.max(outside / e, axis=1))
    return stable, np.where(np.isnan(margin), 0.0, margin)


def _analyse(Ms, ls, T, liou, err, guard_tol, signed=False):
    """Multipliers, stability, labels, margins and guards for a stack of scaled monodromies.

    ``margin`` is the distance of the stability test from its threshold in the
    units of the error estimate's quantity; ``margin > 10 · err`` certifies the
    classification.  With ``signed``, also ``signed``: the continuous signed margin of
    :func:`kapitza.floquet._margins.signed_margin` (> 0 stable) from the same roots x
    that decided ``stable`` (:mod:`kapitza.floquet._frontier` searches on it).
    """
    npts, d, _ = Ms.shape
    n = d // 2
    undamped = np.abs(liou) <= 1e-12 * np.maximum(1.0, T)
    symplectic4 = d == 4 and bool(np.all(undamped))
    if d == 2:
        # λ = (tr ± √(tr² − 4 det))/2 in the scaled frame (det̃ = det e^(−2 ls))
        tr_ = np.trace(Ms, axis1=1, axis2=2).astype(complex)
        det_ = np.linalg.det(Ms)
        sq_ = np.sqrt(tr_ * tr_ - 4 * det_)
        lam = np.stack([0.5 * (tr_ + sq_), 0.5 * (tr_ - sq_)], axis=1)
    elif symplectic4:
        lam = None         # from the reduced quadratic below
    else:
        lam = np.linalg.eigvals(Ms)
    if lam is None:
        with np.errstate(over="ignore", invalid="ignore"):
            t1 = np.trace(Ms, axis1=1, axis2=2)
            t2 = np.trace(Ms @ Ms, axis1=1, axis2=2)
            e2 = 0.5 * (t1 * t1 - t2)                      # scaled: s2 e^(−2 ls)
            # x̃ = x e^(−ls): x̃² − t1 x̃ + (e2 − 2 e^(−2ls)) = 0
            c0 = e2 - 2.0 * np.exp(-2.0 * np.minimum(ls, 300))
            sqd = np.sqrt((t1 * t1 - 4.0 * c0).astype(complex))
            xs = np.stack([0.5 * (t1 + sqd), 0.5 * (t1 - sqd)], axis=1)
            # λ̃ (scaled by e^(−ls)): λ̃² − x̃ λ̃ + e^(−2 ls) = 0
            w = np.sqrt(xs * xs - 4.0 * np.exp(-2.0 * np.minimum(ls, 300))[:, None])
            lam = np.concatenate([0.5 * (xs + w), 0.5 * (xs - w)], axis=1)
    reduce = None
    if d > 2 and not symplectic4:
        # undamped: decide on the best estimate of the symplectic monodromy (the reduced
        # polynomial in x = λ + 1/λ), as the 2 × 2 and 4 × 4 paths do
        reduce = np.nonzero(undamped & (ls == 0.0) & np.all(np.isfinite(Ms), axis=(1, 2)))[0]
        if reduce.size:
            qc, xr = reduced_polynomial(lam[reduce], n)
            root = np.sqrt(xr * xr - 4.0)
            lam = lam.astype(complex)        # eigvals is real when every λ of M̃ is real
            lam[reduce] = np.concatenate([0.5 * (xr + root), 0.5 * (xr - root)], axis=1)
    with np.errstate(divide="ignore"):
        logabs = np.log(np.abs(lam)) + ls[:, None]
    order = np.argsort(-logabs, axis=1)
    lam = np.take_along_axis(lam, order, axis=1)
    logabs = np.take_along_axis(logabs, order, axis=1)
    trace_s = np.trace(Ms, axis1=1, axis2=2)
    with np.errstate(over="ignore", invalid="ignore"):
        trace = np.where(ls > 700, np.sign(trace_s) * np.inf,
                         trace_s * np.exp(np.minimum(ls, 700)))
    det_exact = np.exp(liou)
    with np.errstate(over="ignore"):
        scale_m = np.maximum(1.0, np.max(np.abs(Ms), axis=(1, 2)) * np.exp(np.minimum(ls, 700)))
    tol_abs = np.maximum(10.0 * err, 1e-13) * scale_m     # absolute error bound on entries
    stable = np.empty(npts, dtype=bool)
    label = np.zeros(npts, dtype=np.int8)
    slow = np.full((npts, n), np.nan)
    if d == 2:
        # Jury: both multipliers in the closed unit disk iff |tr| ≤ 1 + det (det ≤ 1)
        # in the scaled frame (M = e^ls Ms), so that astronomically large traces compare
        down = np.exp(-np.minimum(ls, 700))
        tol_s = np.maximum(10.0 * err, 1e-13) * np.maximum(down, np.max(np.abs(Ms), axis=(1, 2)))
        gap = (1.0 + det_exact) * down - np.abs(trace_s)
        # decided on the best estimate (no bias either way); `margin` says how sure
        stable[:] = (gap >= 0.0) & (ls < 700)
        margin = np.abs(gap) / (2 * tol_s)
        label[:] = np.where(stable, 0, np.where(trace > 0, 1, 2))
        with np.errstate(invalid="ignore"):
            c = trace / (2.0 * np.sqrt(det_exact))
        slow[:, 0] = np.where(stable, np.arccos(np.clip(c, -1, 1)) / T, np.nan)
    elif symplectic4:
        # symplectic 4 × 4: x = λ + 1/λ solves x² − s1 x + (s2 − 2) = 0
        with np.errstate(over="ignore", invalid="ignore"):
            tr2 = np.trace(Ms @ Ms, axis1=1, axis2=2) * np.exp(np.minimum(2 * ls, 1400))
            s1 = trace
            s2 = 0.5 * (s1 * s1 - tr2)
            disc = s1 * s1 - 4.0 * (s2 - 2.0)
            sq = np.sqrt(np.maximum(disc, 0.0))
            x1 = 0.5 * (s1 + sq)
            x2 = 0.5 * (s1 - sq)
            # error bounds: tr errors ≤ 4 tol_abs, tr M² ≤ 32 tol_abs ‖M‖; x by first order
            e_s1 = 4 * tol_abs
            e_disc = 16 * tol_abs * scale_m * 4
            e_x = e_s1 + np.where(sq > 0, e_disc / np.maximum(sq, 1e-300), np.sqrt(e_disc))
        # decided on the best estimate (no bias either way); `margin` says how sure
        real = disc >= 0.0
        inside = (np.abs(x1) <= 2.0) & (np.abs(x2) <= 2.0)
        stable[:] = real & inside & (ls < 700)
        with np.errstate(invalid="ignore", divide="ignore"):
            margin = np.minimum(np.abs(disc) / e_disc,
                                np.minimum(np.abs(np.abs(x1) - 2), np.abs(np.abs(x2) - 2)) / e_x)
        margin = np.where(ls >= 700, np.inf, margin)
        label[:] = np.where(stable, 0, np.where(~real, 3, np.where(x1 > -x2, 1, 2)))
        slow[:, 0] = np.where(stable, np.arccos(np.clip(x1 / 2, -1, 1)) / T, np.nan)
        slow[:, 1] = np.where(stable, np.arccos(np.clip(x2 / 2, -1, 1)) / T, np.nan)
    else:
        top = logabs[:, 0]
        e_log = np.sqrt(tol_abs / scale_m)       # eigenvalues near a collision: √ε sensitivity
        # damped: all |λ| < 1; undamped with huge growth (scaled M): unstable
        stable[:] = ~undamped & (top < 0.0)
        margin = np.where(undamped, np.inf, np.abs(top) / e_log)
        if reduce.size:
            st, mg = _reduced_decision(qc, xr, tol_abs[reduce] / scale_m[reduce],
                                       scale_m[reduce])
            stable[reduce] = st
            margin[reduce] = mg
        ang = np.abs(np.angle(lam[:, 0]))
        label[:] = np.where(stable, 0, np.where(ang < 1e-6, 1, np.where(np.pi - ang < 1e-6,
                                                                         2, 3)))
        args = np.sort(np.abs(np.angle(lam)), axis=1)[:, ::2][:, :n]
        slow[:] = np.where(stable[:, None], args / T[:, None], np.nan)
    # guards
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        sign, logdet = np.linalg.slogdet(Ms)
        liou_res = np.abs(sign * np.exp(logdet + d * ls - liou) - 1.0)
        spread = logabs[:, 0] - logabs[:, -1]
        floor = 1e-13 * np.exp(np.minimum(spread, 700))
    pair = np.full(npts, np.nan)
    if np.any(undamped) and d > 2:
        # palindromic characteristic polynomial: power sums → coefficients (Newton)
        Mk = np.broadcast_to(np.eye(d), Ms.shape).copy()
        p = np.zeros((npts, d + 1))
        for k in range(1, d + 1):
            Mk = Mk @ Ms
            p[:, k] = np.trace(Mk, axis1=1, axis2=2)
        e = np.zeros((npts, d + 1))
        e[:, 0] = 1.0
        for k in range(1, d + 1):
            acc = np.zeros(npts)
            for i in range(1, k + 1):
                acc += (-1) ** (i - 1) * e[:, k - i] * p[:, i]
            e[:, k] = acc / k
        with np.errstate(over="ignore", invalid="ignore"):
            # e_k of the scaled matrix carries e^(−k ls)
            ek = e * np.exp(np.arange(d + 1)[None, :] * np.minimum(ls, 50)[:, None])
            scale = np.maximum(1.0, np.max(np.abs(ek), axis=1))
            pr = np.max(np.abs(ek - ek[:, ::-1]), axis=1) / scale
        pair = np.where(undamped & (ls < 50), pr, np.nan)
    elif d == 2:
        pair = np.where(undamped, liou_res, np.nan)      # λ1 λ2 = 1 is the pairing for 2 × 2
    # a guard fails when its residual exceeds what the error estimate allows (×10)
    lim = np.maximum(np.maximum(guard_tol, 10.0 * err), floor)
    checkable = floor < 1e-2
    bad_l = checkable & ~(liou_res <= lim)
    bad_p = checkable & undamped & np.isfinite(pair) & ~(pair <= lim)
    bad_e = err > 1e-3
    flags = [()] * npts
    for i in np.nonzero(bad_l | bad_p | bad_e)[0]:
        f = []
        if bad_l[i]:
            f.append(f"Liouville: |det M/exp(∮tr J) − 1| = {liou_res[i]:.2e} > {lim[i]:.1e}")
        if bad_p[i]:
            f.append(f"multipliers not in pairs λ, 1/λ: residual {pair[i]:.2e} > {lim[i]:.1e}")
        if bad_e[i]:
            f.append(f"monodromy error estimate {err[i]:.1e} (rounding-limited?)")
        flags[i] = tuple(f)
    with np.errstate(over="ignore", invalid="ignore"):
        mult = lam * np.where(ls > 700, np.inf, np.exp(np.minimum(ls, 700)))[:, None]
        expo = (logabs + 1j * np.angle(lam)) / T[:, None]
    out = dict(multipliers=mult, logabs=logabs, trace=trace, stable=stable, label=label,
               slow=slow, exponents=expo, liouville=liou_res, pairing=pair, margin=margin,
               flags=flags)
    if signed:
        out["signed"] = _signed(d, undamped, ls, logabs, trace,
                                (s1, disc) if symplectic4 else None,
                                (reduce, xr) if reduce is not None and reduce.size else None)
    return out


def _signed(d, undamped, ls, logabs, trace, quadratic, reduced):
    """The signed margin of :func:`kapitza.floquet._margins.signed_margin` from the roots
    the classification used: undamped and unscaled (ls = 0), u = the smallest of
    2 − |Re x_k| and of ¼ (x_i − x_j)² over the reduced roots x = λ + 1/λ; else
    −max log|λ|; compressed as sign(u) log(1 + |u|)."""
    u = np.full(ls.size, np.nan)
    calm = undamped & (ls == 0.0)
    with np.errstate(invalid="ignore", over="ignore"):
        if d == 2:
            u = np.where(calm, 2.0 - np.abs(trace), u)
        elif quadratic is not None:
            s1, disc = quadratic
            # x = (s1 ± √disc)/2: the smaller 2 − |x| is 2 − (|s1| + √disc)/2 (real
            # roots) or 2 − |s1|/2 (a complex pair); ¼ (x1 − x2)² = disc/4 either way
            v = np.minimum(2.0 - 0.5 * (np.abs(s1) + np.sqrt(np.maximum(disc, 0.0))),
                           0.25 * disc)
            u = np.where(calm, v, u)
        if reduced is not None:
            at, x = reduced
            v = np.min(2.0 - np.abs(x.real), axis=1)
            n = x.shape[1]
            for i in range(n):
                for j in range(i + 1, n):
                    v = np.minimum(v, (0.25 * (x[:, i] - x[:, j]) ** 2).real)
            u[at] = v
        done = np.isfinite(u)
        u = np.where(done, np.sign(u) * np.log1p(np.abs(u)), -logabs[:, 0])
    return u


def _analyse_points(prep, idx, Ms, ls, err, skip, finished, guard_tol, signed=False):
    """:func:`_analyse` for the grid points ``idx``; the points that were not integrated
    (``skip``, see :func:`_integrate`) get the frozen-time growth estimate and a flag,
    those not reached before Ctrl-C (``~finished``) NaN and a flag."""
    T, liou = prep["T"][idx], prep["liouville"][idx]
    d = Ms.shape[1]
    res = _analyse(np.where(skip[:, None, None], np.eye(d), Ms), np.where(skip, 0.0, ls), T,
                   liou, np.where(skip, 0.0, err), guard_tol, signed)
    where = np.nonzero(skip & finished)[0]
    _not_computed(res, np.nonzero(~finished)[0])
    if where.size == 0:
        return res
    growth, real = _frozen_growth(prep, idx[where])
    with np.errstate(invalid="ignore"):
        need = _step_count(*_balanced(prep, idx[where]))
    decided = growth > 30.0           # unstable even if the estimate were off by a factor 2
    for k in ("multipliers", "exponents"):
        res[k][where] = np.nan
    for k in ("logabs", "slow"):
        res[k][where] = np.nan
    res["logabs"][where, 0] = growth
    if signed:
        res["signed"][where] = -growth
    with np.errstate(over="ignore", invalid="ignore"):
        res["exponents"][where, 0] = growth / T[where]
    res["trace"][where] = np.nan
    res["stable"][where] = False
    res["label"][where] = np.where(real, 1, 3)
    res["liouville"][where] = np.nan
    res["pairing"][where] = np.nan
    res["margin"][where] = np.where(decided, np.inf, 0.0)
    for j, i in enumerate(where):
        res["flags"][i] = (
            f"not integrated: ~{need[j]:.1e} Taylor steps per period needed (more than "
            f"{MAX_STEPS_PER_PERIOD}; a slow drive or a huge amplitude); log|λ| ≈ {growth[j]:.4g}"
            " per period is the frozen-time (adiabatic) estimate"
            + ("" if decided[j] else "; stability undecided (reported unstable)"),)
    return res


def _blank(m, n):
    """An :func:`_analyse` result for ``m`` points that were not computed (Ctrl-C)."""
    d = 2 * n
    res = dict(multipliers=np.full((m, d), np.nan, dtype=complex), logabs=np.full((m, d), np.nan),
               trace=np.full(m, np.nan), stable=np.zeros(m, dtype=bool),
               label=np.full(m, 3, dtype=np.int8), slow=np.full((m, n), np.nan),
               exponents=np.full((m, d), np.nan, dtype=complex), liouville=np.full(m, np.nan),
               pairing=np.full(m, np.nan), margin=np.zeros(m), flags=[()] * m)
    _not_computed(res, np.arange(m))
    return res


def _not_computed(res, where):
    """Mark the points ``where`` of an :func:`_analyse` result as not computed (Ctrl-C)."""
    for k in ("multipliers", "exponents", "logabs", "slow", "trace", "liouville", "pairing",
              "signed"):
        if k in res:
            res[k][where] = np.nan
    res["stable"][where] = False
    res["label"][where] = 3
    res["margin"][where] = 0.0
    for i in where:
        res["flags"][i] = ("not computed: interrupted (Ctrl-C)",)
