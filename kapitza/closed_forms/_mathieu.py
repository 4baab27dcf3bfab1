"""The Mathieu equation behind the single driven pendulum.

Reduction (shared/PHYSICS.md)
-----------------------------
Linearising θ̈ = −γ θ̇ − (g − A ω² cos ωt) sin θ / l about θ* = 0 (hanging) or
θ* = π (inverted) and writing τ = ωt/2 gives

    y″ + c y′ + (a − 2q cos 2τ) y = 0,

    a = ± 4 ω0² / ω²   (+ hanging, − inverted),   ω0² = g / l,
    q = 2 A / l        (the sign of q does not change any stability result),
    c = 2 γ / ω.

One drive period T = 2π/ω is one τ-period π.  The substitution y = e^(−cτ/2) u
removes the damping,

    u″ + (a′ − 2q cos 2τ) u = 0,    a′ = a − c²/4,

so the monodromy of y is M_y = e^(−cπ/2) S M_u S⁻¹ (S constant), with
tr M_y = e^(−γT/2) tr M_u and det M_y = e^(−γT).  The damped pendulum is stable
iff |tr M_u(a′, q)| < 2 cosh(γT/2), i.e. |tr M_y| < 1 + e^(−γT).

Characteristic values (:mod:`kapitza.closed_forms._characteristic`)
-------------------------------------------------------------------
The undamped equation's stability follows from where a lies among the characteristic
values a_r(q), b_r(q) (DLMF 28.2.16); they are computed there, to rounding, with the
Ince–Strutt chart and the small-q series of the next order of averaging.  This module
holds the mapping from the pendulum, the monodromy trace by integration (damped
points), and the pendulum's exact window and stability map.
"""
from __future__ import annotations

import math
import time
import warnings

import numpy as np
from numba import njit

from lagrange_core._thread_blocks import run_rows
from lagrange_core.integrator_tables import rkn12_table
from lagrange_core.progress import KERNEL_STOP, defer_ctrl_c, run_in_chunks

from .. import _arguments as arguments
from .._deprecation import deprecated_alias
from ..results import ComputationInterrupted, StabilityMap, StabilityWindow
from ._characteristic import _KMAX_LIMIT, _char_value, _kmax_needed, stability_counts

# reached as _mathieu.<name> by tests and studies written before the split (0.2); the
# public path is kapitza.closed_forms
from ._characteristic import characteristic_value as characteristic_value
from ._characteristic import ince_strutt_chart as ince_strutt_chart

__all__ = ["mathieu_parameters", "amplitude_from_q", "mathieu_trace",
           "mathieu_monodromy_trace", "exact_window", "pendulum_stability_map",
           "pendulum_stability_window"]


def mathieu_parameters(A, omega, l, g, damping=0.0, about="inverted"):
    """Map pendulum parameters to the Mathieu form y″ + c y′ + (a − 2q cos 2τ) y = 0.

    The one place where the mapping is written (shared/PHYSICS.md); its inverse for
    the amplitude is :func:`amplitude_from_q`.

    Parameters
    ----------
    A : float or array
        Drive amplitude (m, ≥ 0) of the vertical pivot motion A cos ωt.
    omega : float or array
        Drive angular frequency ω (rad/s), > 0.
    l, g : float
        Rod length (m) and gravitational acceleration (m/s²).
    damping : float
        Viscous damping rate γ (1/s).
    about : {"inverted", "hanging"}
        Equilibrium θ* = π or θ* = 0.

    Returns
    -------
    a, q, c : float or array
        a = ±4 g/(l ω²), q = 2A/l, c = 2γ/ω; τ = ωt/2 (exact; no approximation).
        a and c have the shape of ``omega``, q that of ``A`` (they broadcast where
        they meet; a grid of 1-d axes costs no more than its axes).

    Examples
    --------
    The upright pendulum of length 1 m shaken at ω = 10 ω0 with A = 5 cm:

    >>> import math
    >>> a, q, c = mathieu_parameters(0.05, 10 * math.sqrt(9.81), l=1.0, g=9.81)
    >>> print(f"a = {a:.3f}, q = {q:.3f}, c = {c:.1f}")
    a = -0.040, q = 0.100, c = 0.0
    """
    sign = arguments.about_sign(about)
    l, g, damping = arguments.pendulum_constants(l, g, damping)
    A, omega = arguments.amplitude(A), arguments.frequency(omega)
    with np.errstate(over="ignore"):        # ω² beyond 1.8e308: a = 0, its limit
        a = sign * 4.0 * g / (l * omega**2)
    q = 2.0 * A / l
    c = 2.0 * damping / omega
    return a, q, c


def amplitude_from_q(q, l):
    """The drive amplitude A = q l / 2 (m) of the Mathieu parameter q: the inverse of
    :func:`mathieu_parameters` for q."""
    return np.asarray(q, dtype=float) * l / 2


# -- monodromy trace by integration ------------------------------------------------------

#: RKN 12(10) (Dormand, El-Mikkawy & Prince 1987; :mod:`lagrange_core.integrator_tables`):
#: u″ = f(τ) u has no u′ term, so a Nyström method of order 12 takes it whole
_RKN = rkn12_table()
_RKN_C, _RKN_A, _RKN_B, _RKN_BP = _RKN["c"], _RKN["A"], _RKN["b"], _RKN["bp"]


#: π/2 as the sum of two floats (the second is π/2 − fl(π/2))
_HALF_PI_HI = 1.5707963267948966
_HALF_PI_LO = 6.123233995736766e-17


@njit(cache=True)
def _two_product(x, y):
    """(p, e) with p = fl(x y) and p + e = x y exactly (Dekker's product, Veltkamp's
    splitting; no fused multiply-add needed)."""
    p = x * y
    c = 134217729.0 * x
    xh = c - (c - x)
    xl = x - xh
    c = 134217729.0 * y
    yh = c - (c - y)
    yl = y - yh
    return p, ((xh * yh - p) + xh * yl + xl * yh) + xl * yl


@njit(cache=True)
def _half_period(a, q, N, out):
    """RKN 12 over τ ∈ [0, π/2] for u″ = −(a − 2q cos 2τ) u, both unit solutions, in N
    equal steps.

    Columns are renormalised when large; out = [u1, u1′, u2, u2′, log s1, log s2].
    """
    c, A, b, bp = _RKN_C, _RKN_A, _RKN_B, _RKN_BP
    ns = c.shape[0]
    h = 0.5 * math.pi / N
    # cos 2(τ + c_i h) by rotation from cos 2τ, sin 2τ: no cosine per stage
    cc = np.empty(ns)
    ss = np.empty(ns)
    for i in range(ns):
        cc[i] = math.cos(2.0 * c[i] * h)
        ss[i] = math.sin(2.0 * c[i] * h)
    f = np.empty(ns)
    k1 = np.empty(ns)
    k2 = np.empty(ns)
    x1, v1, x2, v2 = 1.0, 0.0, 0.0, 1.0
    ls1 = 0.0
    ls2 = 0.0
    for n in range(N):
        t0 = n * h
        C0 = math.cos(2.0 * t0)
        S0 = math.sin(2.0 * t0)
        for i in range(ns):
            f[i] = -(a - 2.0 * q * (C0 * cc[i] - S0 * ss[i]))
        for i in range(ns):
            y1 = 0.0
            y2 = 0.0
            for j in range(i):
                y1 += A[i, j] * k1[j]
                y2 += A[i, j] * k2[j]
            k1[i] = f[i] * (x1 + c[i] * h * v1 + h * h * y1)
            k2[i] = f[i] * (x2 + c[i] * h * v2 + h * h * y2)
        sx1 = 0.0
        sv1 = 0.0
        sx2 = 0.0
        sv2 = 0.0
        for i in range(ns):
            sx1 += b[i] * k1[i]
            sv1 += bp[i] * k1[i]
            sx2 += b[i] * k2[i]
            sv2 += bp[i] * k2[i]
        x1, v1 = x1 + h * v1 + h * h * sx1, v1 + h * sv1
        x2, v2 = x2 + h * v2 + h * h * sx2, v2 + h * sv2
        m1 = max(abs(x1), abs(v1))
        if m1 > 1e100:
            x1 /= m1
            v1 /= m1
            ls1 += math.log(m1)
        m2 = max(abs(x2), abs(v2))
        if m2 > 1e100:
            x2 /= m2
            v2 /= m2
            ls2 += math.log(m2)
    # The steps end at N h, not at π/2: h = fl(π/(2N)) and π/2 itself is no float.  Where
    # the solutions swing far within the period the trace is sensitive to that ~1e-16
    # (it moved a trace by 6e-14 relative, at every N); one first-order step of the exact
    # difference δ ends the run at π/2 (cos 2τ = −1 there).
    p_, e_ = _two_product(float(N), h)
    d = ((_HALF_PI_HI - p_) - e_) + _HALF_PI_LO
    fe = -(a + 2.0 * q)
    x1, v1 = x1 + d * v1, v1 + d * fe * x1
    x2, v2 = x2 + d * v2, v2 + d * fe * x2
    out[0] = x1
    out[1] = v1
    out[2] = x2
    out[3] = v2
    out[4] = ls1
    out[5] = ls2


@njit(cache=True)
def _trace_log(a, q, N, buf):
    """tr M_u = 2 (u1 u2′ + u1′ u2)(π/2) as (sign, log|tr|); cos 2τ is even: half a period."""
    _half_period(a, q, N, buf)
    m = buf[0] * buf[3] + buf[1] * buf[2]
    if m == 0.0:
        return 0.0, -np.inf
    return (1.0 if m > 0 else -1.0), math.log(2.0 * abs(m)) + buf[4] + buf[5]


@njit(cache=True)
def _from_log(sign, logv):
    if logv > 700.0:
        return sign * np.inf
    return sign * math.exp(logv)


#: the least error :func:`_trace_tol` reports: rounding, which two runs can share — the
#: traces are compared through their logarithms (|tr| may pass 1e308), and where the
#: solutions swing far within the period rounding is amplified (7e-15 was the largest
#: seen against a 20-digit reference, 2026-11-27)
_ROUNDING = 1.6e-14

#: √(|a| + 2|q|) from which :func:`_trace_tol`'s first step count no longer fits an int64
_STEP_RULE_LIMIT = 2.0 ** 63


@njit(cache=True)
def _trace_tol(a, q, tol, nmax, res):
    """Trace of M_u to tolerance: RKN 12 at N and 2N steps, N doubled until they agree.

    The first run takes N ≈ 2√(|a| + 2|q|) steps per half period, a step of ~0.8 over
    the fastest local frequency; from there each doubling shrinks the error ~4096-fold,
    so the run at 2N errs by at most |tr(2N) − tr(N)| — reported as the error (at least
    :data:`_ROUNDING`), not divided by 4095 (a pair still short of that rate would make
    the smaller figure too small), and tr(2N) returned as it is.  Doubling stops at
    ``tol``, at ``nmax`` steps, or where a difference below 1e-9 stops shrinking
    (rounding: the figure then says how far the trace could be resolved).

    res = [trace (±inf if > 1e304), sign, log|trace|, error estimate (relative to
    max(1, |tr|)), steps per half period].

    Where that first N would pass 2^64 steps (√(|a| + 2|q|) ≥ 2^63, e.g. the pendulum at
    ω ≤ 2e-19·√(g/l), or a NaN) no budget reaches it: res = [NaN, −1, NaN, NaN, the last
    step count of the doubling], at once.  That is what the doubling gave there (its
    int(...) overflowed to N = 4 and every run overflowed to NaN, measured for budgets up
    to 2^24 steps), after running to ``nmax`` (1.35 s a point at 2^22); callers flag it.
    Where the first run alone would pass the budget (N > ``nmax``: at 2^20 steps
    √(|a| + 2|q|) > 2^19, the pendulum at ω ≲ 1e-5·√(g/l)) the trace is not computed either:
    res = [NaN, −1, NaN, NaN, 2N], at once — the first run took as many steps as that
    square root (ω = 1e-7 rad/s: over a minute a point; ω = 1e-10: years), and between
    2^62 and 2^63 its step count wrapped negative.  The first pair of runs still goes
    over a smaller budget (``nmax`` = 16 at a = 25: N = 14, the runs 14 and 28 steps).
    """
    s = math.sqrt(abs(a) + 2.0 * abs(q))
    uncomputed = 0.0                # the steps reported where the trace is not computed
    if not s < _STEP_RULE_LIMIT:
        N = 4
        while 4 * N <= nmax and N < (1 << 60):
            N *= 2
        uncomputed = 2.0 * N
    elif 4.0 + 2.0 * math.floor(s) > nmax:       # in floats: 2·int(s) may not fit an int64
        uncomputed = 2.0 * (4.0 + 2.0 * math.floor(s))
    if uncomputed > 0.0:
        res[0] = np.nan
        res[1] = -1.0
        res[2] = np.nan
        res[3] = np.nan
        res[4] = uncomputed
        return
    buf = np.empty(6)
    N = 4 + 2 * int(s)
    s1, l1 = _trace_log(a, q, N, buf)
    last = np.inf
    while True:
        s2, l2 = _trace_log(a, q, 2 * N, buf)
        ref = max(l1, l2, 0.0)
        # values scaled by e^-ref: the error is relative to max(1, |tr|)
        t1 = s1 * math.exp(l1 - ref)
        t2 = s2 * math.exp(l2 - ref)
        est = max(abs(t2 - t1), _ROUNDING)
        if est <= tol or 4 * N > nmax or (est > 0.5 * last and est < 1e-9):
            sign = 1.0 if t2 >= 0 else -1.0
            lt = math.log(abs(t2)) + ref if t2 != 0.0 else -np.inf
            res[0] = _from_log(sign, lt)
            res[1] = sign
            res[2] = lt
            res[3] = est
            res[4] = 2 * N
            return
        last = est
        N *= 2
        s1, l1 = s2, l2


@njit(cache=True, nogil=True)
def _trace_rows(ap, q, tol, nmax, out, stop, finished, lo, hi):
    """out[i, j, :] = _trace_tol(ap[j], q[i]) for the rows lo ≤ i < hi of a grid
    (u-equation, a′ per column), on one thread (:func:`_trace_grid` spreads the rows).

    A row not yet started when ``stop[0]`` is set (Ctrl-C:
    :data:`lagrange_core.progress.KERNEL_STOP`) is skipped; ``finished[i]`` marks the
    rows computed."""
    res = np.empty(5)
    for i in range(lo, hi):
        if stop[0] != 0:
            return
        for j in range(ap.size):
            _trace_tol(ap[j], q[i], tol, nmax, res)
            for k in range(5):
                out[i, j, k] = res[k]
        finished[i] = True


def _trace_grid(ap, q, tol, nmax, out, stop, finished):
    """:func:`_trace_rows` over every row, in blocks on numba's threads, the calling
    thread waiting: it sees a Ctrl-C at once and the blocks stop at their next row
    (numba's ``prange`` ran on the calling thread too, which saw the signal only when the
    whole call returned: a chunk of expensive rows ran 1.1 s past the Ctrl-C)."""
    run_rows(_trace_rows, q.size, ap, q, tol, nmax, out, stop, finished, per_thread=8,
             stoppable=True)


def mathieu_monodromy_trace(a, q, c=0.0, tol=1e-12, max_steps=1 << 20):
    """Trace of the monodromy of y″ + c y′ + (a − 2q cos 2τ) y = 0 over τ ∈ [0, π].

    Computed by integration (RKN 12 on the damping-free u-equation over half a
    period, using the even symmetry of cos 2τ; N and 2N steps compared, N doubled
    until they agree to ``tol``: see :func:`_trace_tol`).

    Returns
    -------
    trace : float
        tr M_y = e^(−cπ/2) tr M_u (±inf if beyond float range; see ``log_abs``).
    log_abs : float
        log|tr M_y|, finite even when |tr| ≫ 1e308.
    error : float
        Estimated error of tr M_u relative to max(1, |tr M_u|): the difference of the
        runs at N and 2N steps.  Above ``tol`` where the step count reached
        ``max_steps`` or the difference stopped shrinking below 1e-9 (rounding); a
        ``RuntimeWarning`` then names how many traces and the largest error.
    """
    trace, log_abs, error = _monodromy_trace(a, q, c, tol, max_steps)
    missed = ~(error <= tol)
    if missed.any():
        unknown = np.isnan(error)
        largest = (f"largest error {np.max(error[~unknown]):.2g}" if (~unknown).any()
                   else "none computed")
        uncomputed = (f"; {int(unknown.sum())} not computed (NaN): the first run alone "
                      f"would pass max_steps, or the trace overflows" if unknown.any() else "")
        warnings.warn(f"mathieu_monodromy_trace: {int(missed.sum())} of {error.size} traces "
                      f"did not reach tol={tol:g} ({largest}): the step count reached "
                      f"max_steps={max_steps} or rounding stopped the refinement; the "
                      f"returned error bounds them{uncomputed}; raise max_steps or loosen "
                      f"tol.", RuntimeWarning, stacklevel=2)
    return trace, log_abs, error


def _monodromy_trace(a, q, c, tol, max_steps=1 << 20):
    """:func:`mathieu_monodromy_trace` without its warning, for callers that carry the
    error into their own bounds (the exact windows' margins, the pendulum's Floquet
    result)."""
    a, q, c = (np.asarray(x, dtype=float) for x in (a, q, c))
    a, q, c = np.broadcast_arrays(a, q, c)
    shape = a.shape
    ap = (a - c**2 / 4).ravel()
    qq = q.ravel()
    out = np.empty((1, ap.size, 5))
    res = np.empty(5)
    for k in range(ap.size):
        _trace_tol(ap[k], qq[k], tol, max_steps, res)
        out[0, k] = res
    error = out[0, :, 3]
    damp = (np.pi * c / 2).ravel()
    log_abs = out[0, :, 2] - damp
    sign = out[0, :, 1]
    tr = np.where(log_abs > 700, sign * np.inf, sign * np.exp(np.minimum(log_abs, 700)))
    return tr.reshape(shape), log_abs.reshape(shape), error.reshape(shape)


def mathieu_trace(a, q, c=0.0, tol=1e-12):
    """tr M of the (damped) Mathieu equation over one τ-period π (float or array). See
    :func:`mathieu_monodromy_trace`."""
    tr, _, _ = mathieu_monodromy_trace(a, q, c, tol)
    return float(tr) if np.ndim(tr) == 0 else tr


# -- the single pendulum: windows and maps ----------------------------------------------

def _bracket_root(f, lo, hi, tol):
    """Root of f in [lo, hi] (sign change) to relative ``tol``; returns (root, verified accuracy).

    Brent's method, then a certificate: f changes sign across root·(1 ± δ); the
    smallest such δ tried (tol/4, tol, 4 tol, ...) is the reported accuracy.
    """
    from scipy.optimize import brentq  # not at import: scipy costs ~0.4 s

    r = brentq(f, lo, hi, xtol=1e-300, rtol=max(tol / 8, 4.5e-16), maxiter=500)
    delta = max(tol / 4, 1e-15)
    for _ in range(40):
        a, b = f(r * (1 - delta)), f(r * (1 + delta))
        if a == 0 or b == 0 or np.sign(a) != np.sign(b):
            return r, delta
        delta *= 4
    return r, np.nan


def _first_root(f, hi, tol, n=400):
    """The smallest q in (0, hi] where f changes sign (scan, then Brent)."""
    qs = np.concatenate([[1e-300], np.geomspace(1e-6, 1e-2, 40)[:-1],
                         np.linspace(1e-2, hi, n)])
    prev = f(qs[0])
    for k in range(1, qs.size):
        cur = f(qs[k])
        if prev == 0:
            return qs[k - 1], 0.0
        if np.sign(cur) != np.sign(prev):
            return _bracket_root(f, qs[k - 1], qs[k], tol)
        prev = cur
    return np.inf, np.nan


#: |margin| at or below this (relative to the threshold 1 + e^(−γT)) cannot be told from 0:
#: the monodromy trace is computed to ≤ 1e-12 relative, the margin's exponential keeps it
_MARGIN_RESOLUTION = 1e-9


#: The scan's traces are computed to this tolerance (relative to max(1, |tr|)); a scan point
#: only needs the margin's sign, and where its estimated error could flip it the margin is
#: computed again at the full tolerance.  The roots and dips are found at the full one.
_SCAN_TOL = 1e-8


def _margin_and_error(log_abs_u, error, c, thr):
    """The damped margin |tr M_y| − thr = e^(log|tr M_u| − πc/2) − thr and its error, from
    :func:`mathieu_monodromy_trace`'s log|tr M_u| and error (relative to max(1, |tr M_u|));
    arrays or scalars."""
    value = np.exp(np.minimum(log_abs_u - math.pi * c / 2, 700.0)) - thr
    return value, error * np.exp(np.minimum(np.maximum(log_abs_u, 0.0), 700.0) -
                                 math.pi * c / 2)


def _scanned_margin(margin, ap, c, thr, qs):
    """The damped margin |tr M_y| − thr at every scan point ``qs``: one parallel compiled
    call at :data:`_SCAN_TOL` (fewer steps than the full tolerance, on every core), then
    ``margin`` (full tolerance) where |value| ≤ 10 × its error estimate."""
    out = np.empty((qs.size, 1, 5))
    # one short call (a window's scan): never stopped in the middle
    _trace_grid(np.array([ap], float), np.asarray(qs, float), _SCAN_TOL, 1 << 22, out,
                np.zeros_like(KERNEL_STOP), np.zeros(qs.size, dtype=np.bool_))
    vals, err = _margin_and_error(out[:, 0, 2], out[:, 0, 3], c, thr)
    for k in np.flatnonzero(~(np.abs(vals) > 10.0 * err)):
        vals[k] = margin(float(qs[k]))
    return vals


def _resolved_scan(margin, qs, vals, tol, coarse=None):
    """The damped margin's scan with its dips towards 0 resolved.

    Between scan points the margin can cross 0 twice, unseen: a stable sliver (or an
    unstable tongue) narrower than the scan's spacing (~5.5 % of q for the inverted
    pendulum), as at the onset frequency of the window.  At each interior scan point where
    |margin| has a local minimum and the margin keeps its sign on both sides, the extremum
    of the margin between the two neighbours (bounded Brent, to ``tol`` relative in q) is
    added to the scan.  With ``coarse`` (q → (margin, error bound) at a looser, cheaper
    tolerance) the extremum is searched on it first, and again on ``margin`` only where
    the extremum comes within max(100 × its error, 1e-6) of 0: farther away, its sign
    (all the scan keeps of it; the roots are bracketed on ``margin``) is decided.

    Returns (qs, vals, undecided): the scan with the added points, in order, and whether
    some dip came within :data:`_MARGIN_RESOLUTION` of 0 without crossing it (a sliver
    narrower than the margin resolves cannot be ruled out there).
    """
    from scipy.optimize import minimize_scalar  # not at import: scipy costs ~0.4 s

    extra_q, extra_v, undecided = [], [], False
    for k in range(1, qs.size - 1):
        sg = np.sign(vals[k])
        if not (sg != 0 and np.sign(vals[k - 1]) == sg == np.sign(vals[k + 1])
                and abs(vals[k]) <= abs(vals[k - 1]) and abs(vals[k]) <= abs(vals[k + 1])):
            continue
        options = {"xatol": max(tol * qs[k], 1e-300)}
        if coarse is not None:
            res = minimize_scalar(lambda q, sg=sg: sg * coarse(q)[0],
                                  bounds=(qs[k - 1], qs[k + 1]), method="bounded",
                                  options=options)
            v, e = coarse(float(res.x))
            if abs(v) > max(100.0 * e, 1e-6):       # its sign decided at the coarse tolerance
                if np.sign(v) != sg:                # a crossing: the roots are found later,
                    extra_q.append(float(res.x))    # at the full one, from the sign alone
                    extra_v.append(v)
                continue
        res = minimize_scalar(lambda q, sg=sg: sg * margin(q), bounds=(qs[k - 1], qs[k + 1]),
                              method="bounded", options=options)
        v = margin(float(res.x))
        if np.sign(v) != sg:
            extra_q.append(float(res.x))
            extra_v.append(v)
        elif abs(v) <= _MARGIN_RESOLUTION * 2.0:
            undecided = True
    if extra_q:
        qs = np.concatenate([qs, extra_q])
        vals = np.concatenate([vals, extra_v])
        order = np.argsort(qs, kind="stable")
        qs, vals = qs[order], vals[order]
    return qs, vals, undecided


def exact_window(omega, *, l=1.0, g=9.81, damping=0.0, about="inverted",
                 tol=1e-10) -> StabilityWindow:
    """The exact window of :func:`kapitza.closed_forms.pendulum_window` (``method="floquet"``).

    Root-finding on the Floquet condition at each ω:

    * undamped: the characteristic curves, a0(q) = a (A_min, the Kapitza limit)
      and b1(q) = a (A_max, the first period-2T resonance) for the inverted
      pendulum (a = −4ω0²/ω² < 0); for the hanging pendulum A_min = 0 and A_max
      is where the first tongue a_r(q) = a or b_(r+1)(q) = a is reached
      (r² < a < (r+1)²);
    * damped: |tr M_y(q)| = 1 + e^(−γT), with tr M from
      :func:`mathieu_monodromy_trace` at tolerance tol/100 (the scan's signs at 1e-8,
      recomputed at tol/100 where the error could flip one), scanned in q (241
      log-spaced points, inverted; 401 linear, hanging) and every dip of the margin
      towards 0 between scan points resolved (:func:`_resolved_scan`): a stable interval
      (or an unstable tongue) narrower than the scan's spacing is found, down to the
      width the trace resolves.  ``status`` says per ω "window", "none", or
      "undecided" (a dip of the margin within 1e-9 of 0 without a crossing: a sliver
      could not be ruled out; warned, A_min and A_max NaN there).

    Each root is certified: the Floquet condition changes sign across
    A·(1 ± accuracy), ``accuracy`` ≤ ``tol`` (reported per ω).

    Examples
    --------
    At ω = 10⁴ ω0 the upper edge is the first parametric resonance, A_max → 0.4540 l:

    >>> import math
    >>> win = exact_window(1e4 * math.sqrt(9.81), l=1.0, g=9.81)
    >>> print(f"{win.A_max:.4f} m")
    0.4540 m
    >>> bool(win.accuracy <= 1e-10)          # certified to the requested tol
    True
    """
    l, g, damping = arguments.pendulum_constants(l, g, damping)
    sign = arguments.about_sign(about)
    if not (1e-15 <= tol < 1e-1):
        raise ValueError(f"tol must lie in [1e-15, 0.1) (the edges' relative accuracy), got "
                         f"{tol!r}.")
    w = arguments.grid_axis("omega", omega, "rad/s", positive=True)
    Amin = np.full(w.size, np.nan)
    Amax = np.full(w.size, np.nan)
    acc = np.full(w.size, np.nan)
    status = np.full(w.size, "none", dtype=object) if damping != 0.0 else None
    for i, om in enumerate(w):
        a, _, c = mathieu_parameters(0.0, om, l, g, damping, about)
        a, c = float(a), float(c)
        if damping == 0.0:
            if sign < 0:
                f0 = lambda q, a=a: _char_value(False, 0, q, np.nan) - a      # noqa: E731
                f1 = lambda q, a=a: _char_value(True, 1, q, np.nan) - a       # noqa: E731
                # a0(q) ≤ −q²/2 + 7q⁴/128 and b1(q) ≤ 1 − q bound the brackets
                q0, e0 = _first_root(f0, max(2.0, 4 * math.sqrt(-a) + 4), tol)
                q1, e1 = _first_root(f1, max(4.0, 2 * (1 - a) + 4), tol)
                if q0 < q1:
                    Amin[i], Amax[i], acc[i] = q0, q1, max(e0, e1)
            else:
                r = int(math.floor(math.sqrt(a)))
                if r * r == a:
                    Amin[i], Amax[i], acc[i] = 0.0, 0.0, 0.0      # on a resonance at q = 0
                    continue
                hi = 4 * a + 20
                f_b = lambda q, r=r, a=a: _char_value(True, r + 1, q, np.nan) - a  # noqa: E731
                roots = [_first_root(f_b, hi, tol)]
                if r >= 1:
                    f_a = lambda q, r=r, a=a: _char_value(False, r, q, np.nan) - a  # noqa: E731
                    roots.append(_first_root(f_a, hi, tol))
                q1, e1 = min(roots)
                Amin[i], Amax[i], acc[i] = 0.0, q1, e1
        else:
            thr = 1.0 + math.exp(-2 * math.pi * damping / om)
            ap = a - c * c / 4

            # the loop's values bound as defaults (margin is called in this iteration only)
            def margin(q, ap=ap, c=c, thr=thr):          # > 0 unstable, < 0 stable
                tr, la, _ = _monodromy_trace(ap, q, 0.0, tol=min(1e-12, tol / 100))
                return math.exp(min(float(la) - math.pi * c / 2, 700.0)) - thr

            qs = np.concatenate([[0.0], np.geomspace(1e-4, 40.0, 240)]) if sign < 0 else \
                np.linspace(0.0, 4 * abs(a) + 20, 400)
            def coarse(q, ap=ap, c=c, thr=thr):          # (margin, its error bound)
                _, la, err = _monodromy_trace(ap, q, 0.0, tol=_SCAN_TOL)
                value, bound = _margin_and_error(float(la), float(err), c, thr)
                return float(value), float(bound)

            vals = _scanned_margin(margin, ap, c, thr, qs)
            qs, vals, undecided = _resolved_scan(margin, qs, vals, tol, coarse)
            st = vals < 0
            if undecided:
                status[i] = "undecided"
            if sign < 0:
                k = np.nonzero(st)[0]
                if k.size == 0 or k[0] == 0:
                    continue
                j0 = k[0]
                j1 = j0 + np.argmax(~st[j0:]) if np.any(~st[j0:]) else None
                if j1 is None:
                    continue
                q0, e0 = _bracket_root(margin, qs[j0 - 1], qs[j0], tol)
                q1, e1 = _bracket_root(margin, qs[j1 - 1], qs[j1], tol)
                Amin[i], Amax[i], acc[i] = q0, q1, max(e0, e1)
                status[i] = "window"
            else:
                if not st[0]:
                    continue
                j1 = np.argmax(~st) if np.any(~st) else None
                if j1 is None:
                    continue
                q1, e1 = _bracket_root(margin, qs[j1 - 1], qs[j1], tol)
                Amin[i], Amax[i], acc[i] = 0.0, q1, e1
                status[i] = "window"
    if status is not None:
        odd = status == "undecided"
        Amin[odd] = Amax[odd] = acc[odd] = np.nan
        if odd.any():
            warnings.warn(
                f"exact_window: at ω = {', '.join(f'{x:.6g}' for x in w[odd][:5])} rad/s"
                f"{' …' if odd.sum() > 5 else ''} the damped margin comes within 1e-9 of 0 "
                "without crossing it: a stable sliver narrower than the trace resolves "
                "cannot be ruled out (status 'undecided', A_min and A_max NaN there); "
                "a slightly different ω decides.", RuntimeWarning, stacklevel=2)
    # the roots above are in q (A_min of the hanging pendulum is 0 in either unit)
    A_min, A_max = amplitude_from_q(Amin, l), amplitude_from_q(Amax, l)
    if np.ndim(omega) == 0:           # a scalar call gives scalars
        w, A_min, A_max, acc = float(w[0]), float(A_min[0]), float(A_max[0]), float(acc[0])
        if status is not None:
            status = str(status[0])
    elif status is not None:
        status = status.astype(str)
    return StabilityWindow(omega=w, A_min=A_min, A_max=A_max, method="floquet", about=about,
                           accuracy=acc, tol=tol, l=l, g=g, damping=damping, status=status)


#: the exact window's name before kapitza 0.2 (same arguments, same numbers)
pendulum_stability_window = deprecated_alias(
    exact_window, "kapitza.pendulum_stability_window(omega, ...)",
    "kapitza.pendulum_window(omega, ...)")


def pendulum_stability_map(A, omega, *, l=1.0, g=9.81, damping=0.0, about="inverted",
                           trace=False, tol=1e-10, progress=None) -> StabilityMap:
    """Stability of the driven pendulum's equilibrium on the grid A × ω.

    Undamped: from characteristic values computed once per A (q = 2A/l) and
    compared with a = ±4ω0²/ω² for every ω — O(len(A)) eigenvalue problems plus
    O(len(A)·len(ω)) comparisons; the boundaries are exact to ≈ 1e-15 relative
    in a (so ≈ 1e-15 relative in A and ω).  Damped, or with ``trace=True``: the
    trace of the monodromy at every point by integration of the damping-free
    u-equation (:func:`mathieu_monodromy_trace`, tolerance ``tol``).

    The traces run in chunks of rows (about 0.25 s each) with a progress line on
    stderr when it is a terminal (``progress`` None; True always, False never, or a
    callable ``progress(done_rows, total_rows)``).  Ctrl-C stops within a chunk and
    raises :class:`~kapitza.results.ComputationInterrupted` (a KeyboardInterrupt)
    whose ``.result`` is the map with the finished rows of A filled (the others:
    trace and log_growth NaN; damped: unstable, label 3) and ``.computed`` marks them.

    Returns
    -------
    kapitza.results.StabilityMap
        With the pendulum's ``l``, ``g``, ``damping`` and ``about``.

    Examples
    --------
    At ω = 60 rad/s the upright pendulum (l = 1 m) is held between A ≈ 7.4 cm and
    A ≈ 43 cm (compare :func:`kapitza.closed_forms.pendulum_window`):

    >>> m = pendulum_stability_map([0.05, 0.1, 0.3, 0.5], [60.0])
    >>> m.boundary[:, 0].tolist()
    ['T', 'stable', 'stable', '2T']
    """
    l, g, damping = arguments.pendulum_constants(l, g, damping)
    arguments.about_sign(about)
    A = arguments.grid_axis("A", A, "m", positive=False)
    w = arguments.grid_axis("omega", omega, "rad/s", positive=True)
    arguments.check_grid_memory("A × omega", (A.size, w.size), arguments.MATHIEU_MAP_BYTES if (
        damping == 0.0 and not trace) else arguments.MATHIEU_TRACE_MAP_BYTES,
        where="pendulum_stability_map: ")
    t0 = time.perf_counter()
    with np.errstate(over="ignore", divide="ignore"):
        a, q, c = mathieu_parameters(A, w, l, g, damping, about)    # a, c per ω; q per A
    if not np.all(np.isfinite(a)):
        slow = float(w[~np.isfinite(a)][0])
        raise ValueError(f"omega = {slow!r} rad/s is too slow for the Mathieu form: a = "
                         f"±4 g/(l ω²) overflows. Use ω ≥ 1e-150 rad/s, or "
                         "kapitza.floquet.stability_map(pendulum.system, ...), which reports "
                         "such points with a frozen-time growth estimate and a flag.")
    flagged, example = 0, ()
    tr = lg = None
    err = 1e-15
    if damping == 0.0:
        if _kmax_needed(q, a) > _KMAX_LIMIT:
            wmin, amax = float(np.min(w)), float(np.max(A))
            if 2.0 * float(np.max(np.abs(q))) > float(np.max(a)):     # the drive is too big
                raise ValueError(
                    f"A = {amax!r} m: q = 2A/l = {2.0 * amax / l:.3g} lies above "
                    f"~{_kmax_needed(q, a):.2g} resonance tongues, too many to count; the "
                    "pivot swings that far only in a mistake (A is in metres): use A/l ≤ 1e6, "
                    "or kapitza.floquet.stability_map(pendulum.system, ...).")
            raise ValueError(
                f"about={about!r} with omega = {wmin!r} rad/s: a = 4 g/(l ω²) = "
                f"{float(np.max(a)):.3g} lies above ~{_kmax_needed(q, a):.2g} resonance "
                "tongues, too many to count (seconds per A). Use ω ≥ 1e-3·√(g/l) here, or "
                "kapitza.floquet.stability_map(pendulum.system, ...) (monodromy integration).")
        stable, label = stability_counts(q, a)
        method = "characteristic values"
    if damping > 0.0 or trace:
        ap = np.ascontiguousarray(a - c * c / 4)
        qc = np.ascontiguousarray(q)
        # (only the finished rows, out[:done], are read below: no fill of the whole grid)
        out = np.empty((q.size, w.size, 5))

        def rows(i0, i1):
            # a row of many expensive points can make a chunk run several times its
            # 0.25 s on a loaded machine: Ctrl-C stops the call in flight, not only the
            # next one (the rows before the first unfinished one count)
            finished = np.zeros(i1 - i0, dtype=np.bool_)
            _trace_grid(ap, qc[i0:i1], float(tol), 1 << 22, out[i0:i1], KERNEL_STOP,
                        finished)
            return int(np.argmin(finished)) if not finished.all() else i1 - i0

        with defer_ctrl_c():
            done, interrupted = run_in_chunks(rows, q.size, progress=progress,
                                              label="Mathieu trace map", unit="rows of A",
                                              first=2)
        # the finished rows only (the rest NaN, unstable, label 3; rows a stopped chunk
        # computed after its first unfinished one are dropped): after a Ctrl-C early in a
        # large map, the whole grid's arithmetic took 0.5 s of the second allowed
        o = out[:done]
        lg_u = o[:, :, 2]
        log_tr = lg_u - (np.pi * c / 2)[None, :]
        tr = np.full((q.size, w.size), np.nan)
        lg = np.full((q.size, w.size), np.nan)
        tr[:done] = np.where(log_tr > 700, o[:, :, 1] * np.inf,
                             o[:, :, 1] * np.exp(np.minimum(log_tr, 700)))
        # log|λ|max = −cπ/2 + arccosh(|tr M_u|/2) (0 where |tr M_u| ≤ 2), in log form
        with np.errstate(over="ignore", invalid="ignore"):
            big = lg_u > 30
            trm = np.where(big, 0.0, np.exp(np.minimum(lg_u, 30)) / 2)
            ach = np.where(big, lg_u, np.arccosh(np.maximum(trm, 1.0)))
        lg[:done] = ach - (np.pi * c / 2)[None, :]
        bad = ~np.isfinite(lg[:done])
        flagged = int(bad.sum())
        if flagged:
            i, j = np.argwhere(bad)[0]
            example = (f"trace not computed at A = {A[i]:.6g} m, ω = {w[j]:.6g} rad/s (trace "
                       "overflow: a slow drive or a huge amplitude); NaN, reported unstable. "
                       "kapitza.floquet.stability_map estimates its growth",)
        est = out[:done, :, 3][np.isfinite(out[:done, :, 3])]
        err = float(np.max(est)) if est.size else 0.0
        if damping > 0.0:
            thr = 1.0 + np.exp(-2 * np.pi * damping / w)
            stable = np.zeros((q.size, w.size), dtype=bool)
            label = np.full((q.size, w.size), 3, dtype=np.int8)
            with np.errstate(invalid="ignore"):
                stable[:done] = np.where(log_tr > 700, False, np.abs(tr[:done]) < thr[None, :])
            label[:done] = np.where(stable[:done], 0, np.where(o[:, :, 1] > 0, 1, 2))
            label[:done][bad] = 3
            method = "monodromy (Mathieu, damping removed)"
        if interrupted:
            computed = np.zeros(stable.shape, dtype=bool)
            computed[:done] = True
            partial = StabilityMap(A=A, omega=w, stable=stable, label=label, trace=tr,
                                   log_growth=lg, error_estimate=err, about=about,
                                   method=method, l=l, g=g, damping=damping,
                                   seconds=time.perf_counter() - t0, flagged_points=flagged,
                                   flags_example=example)
            raise ComputationInterrupted(partial, computed)
    return StabilityMap(A=A, omega=w, stable=stable, label=label, trace=tr, log_growth=lg,
                        error_estimate=err, about=about, method=method, l=l, g=g,
                        damping=damping, seconds=time.perf_counter() - t0,
                        flagged_points=flagged, flags_example=example)


# a first call on the main thread compiles where Ctrl-C need not wait for it
from lagrange_core._first_calls import guard as _guard_first_calls  # noqa: E402

_guard_first_calls(__name__)
