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

Characteristic values
---------------------
For q > 0 the characteristic values interlace as a0 < b1 < a1 < b2 < a2 < ...
(DLMF 28.2.16); the undamped equation is stable exactly when a lies in one of
(a0, b1), (a1, b2), (a2, b3), ..., i.e. when an *odd* number of characteristic
values lies below a.  The unstable tongue (b_r, a_r) carries solutions of period
π (drive period T) for even r and 2π (period 2T) for odd r; below a0 the
boundary a0 has period T.

They are computed here as eigenvalues of the four symmetric tridiagonal
Fourier–Floquet matrices (DLMF 28.4; A&S 20.2.5–20.2.11)

    a_{2k}:    diag 0, 4, 16, 36, ...     off-diag √2 q, q, q, ...
    b_{2k+2}:  diag 4, 16, 36, ...        off-diag q, q, ...
    a_{2k+1}:  diag 1 + q, 9, 25, ...     off-diag q, q, ...
    b_{2k+1}:  diag 1 − q, 9, 25, ...     off-diag q, q, ...

by Sturm-count-safeguarded Newton iteration on the LDLᵀ pivots, compiled with
numba.  Truncated at K = r/2 + 8 + 2.5√|q| rows, the eigenvalues agree with the
infinite problem to rounding (≤ 1e-13 relative to max(1, |a|) for r ≤ 8,
q ≤ 80 against LAPACK on 90 rows; ≤ 1e-12 against ``scipy.special.mathieu_a``/
``mathieu_b`` where those are right — they are not for larger q, e.g.
mathieu_a(5, 20.9) = 15.03 instead of 37.38).  Small characteristic values
(a0 ≈ −q²/2 for small q) keep their
*relative* accuracy because the pivot recurrence is relatively accurate in the
row that carries the eigenvector.

Series for small q
------------------
For the next order of averaging (:mod:`kapitza.pendulum_closed_forms`) the
characteristic exponent ν²(a, q) and the characteristic values a₀, b₁ are also
given as power series (:func:`exponent_squared`, :func:`mathieu_a0`,
:func:`mathieu_b1`; A&S 20.2.25, DLMF 28.6, 28.15.1), with their accuracy stated.
"""
from __future__ import annotations

import math
import time

import numpy as np
from numba import njit, prange
from scipy.optimize import brentq

from .. import _arguments as arguments
from lagrange_core.progress import run_in_chunks
from ..results import ComputationInterrupted, InceStruttChart, StabilityMap, StabilityWindow

__all__ = ["mathieu_parameters", "amplitude_from_q", "characteristic_value", "mathieu_trace",
           "mathieu_monodromy_trace", "ince_strutt_boundaries", "ince_strutt_chart",
           "stability_counts", "pendulum_stability_window", "pendulum_stability_map",
           "exponent_squared", "mathieu_a0", "mathieu_b1", "mathieu_b1_root"]

# families of the tridiagonal problems (see the module docstring)
_A_EVEN, _B_EVEN, _A_ODD, _B_ODD = 0, 1, 2, 3


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
    a = sign * 4.0 * g / (l * omega**2)
    q = 2.0 * A / l
    c = 2.0 * damping / omega
    return a, q, c


def amplitude_from_q(q, l):
    """The drive amplitude A = q l / 2 (m) of the Mathieu parameter q: the inverse of
    :func:`mathieu_parameters` for q."""
    return np.asarray(q, dtype=float) * l / 2


# -- tridiagonal eigenvalues -----------------------------------------------------------

@njit(cache=True)
def _truncation(k, q):
    # Fourier coefficients of the k-th solution decay like Π_j |q|/(4j²) beyond j ≈ k + √|q|;
    # the eigenvalue error is ≈ the square of the last retained one: k + 8 + 2.5√|q| rows
    # leave it below 1e-17 relative (tested against twice as many rows).
    return k + 8 + int(2.5 * math.sqrt(abs(q)))


@njit(cache=True)
def _fill(family, q, K, d, e2):
    """Diagonal d[:K] and squared off-diagonal e2[:K-1] of one Mathieu matrix."""
    for i in range(K):
        if family == _A_EVEN:
            v = 2.0 * i
        elif family == _B_EVEN:
            v = 2.0 * i + 2.0
        else:
            v = 2.0 * i + 1.0
        d[i] = v * v
        if i < K - 1:
            e2[i] = q * q
    if family == _A_EVEN:
        e2[0] = 2.0 * q * q
    elif family == _A_ODD:
        d[0] += q
    elif family == _B_ODD:
        d[0] -= q


@njit(cache=True)
def _sturm(d, e2, K, x):
    """Number of eigenvalues < x and f′/f for f(x) = det(T − x I).

    LDLᵀ pivots p_i = d_i − x − e2_{i−1}/p_{i−1} (negative pivots count the
    eigenvalues below x) and their derivatives p_i′; f′/f = Σ p_i′/p_i.
    One division per row: this recurrence is the hot loop of the stability map.
    """
    count = 0
    p = d[0] - x
    if p == 0.0:
        p = -1e-300
    inv = 1.0 / p
    dp = -1.0
    s = dp * inv
    count += p < 0.0            # branch-free: the sign pattern is unpredictable
    for i in range(1, K):
        r = e2[i - 1] * inv
        dp = -1.0 + r * dp * inv
        p = d[i] - x - r
        if p == 0.0:
            p = -1e-300
        inv = 1.0 / p
        s += dp * inv
        count += p < 0.0
    return count, s


@njit(cache=True)
def _eigen_k(d, e2, K, k, guess):
    """The k-th smallest (0-based) eigenvalue of the tridiagonal (d, e2).

    Sturm counts keep a bracket [lo, hi] around it; once the bracket isolates the
    k-th eigenvalue, Newton steps on det(T − x) (clipped to the bracket) converge
    quadratically.  A good ``guess`` (continuation in q) isolates it at once.
    """
    isolated = False
    lo = 1e300
    hi = -1e300
    if math.isfinite(guess):
        w = 1e-6 * (1.0 + abs(guess))
        c1, _ = _sturm(d, e2, K, guess - w)
        if c1 == k:
            c2, _ = _sturm(d, e2, K, guess + w)
            if c2 == k + 1:
                lo = guess - w
                hi = guess + w
                isolated = True
    if not isolated:
        for i in range(K):
            r = 0.0
            if i > 0:
                r += math.sqrt(e2[i - 1])
            if i < K - 1:
                r += math.sqrt(e2[i])
            lo = min(lo, d[i] - r)
            hi = max(hi, d[i] + r)
        # bisection until the bracket holds the k-th eigenvalue alone
        for it in range(200):
            x = 0.5 * (lo + hi)
            c, _ = _sturm(d, e2, K, x)
            if c <= k:
                lo = x
            else:
                hi = x
            if c == k or c == k + 1:
                cl, _ = _sturm(d, e2, K, lo)
                ch, _ = _sturm(d, e2, K, hi)
                if cl == k and ch == k + 1:
                    break
        guess = 0.5 * (lo + hi)
    x = guess
    step_prev = 0.0          # no early stop on the first Newton step
    for it in range(200):
        c, s = _sturm(d, e2, K, x)
        if c <= k:
            lo = x
        else:
            hi = x
        xn = x - 1.0 / s if s != 0.0 else 0.5 * (lo + hi)
        if not (lo < xn < hi):
            xn = 0.5 * (lo + hi)
        step = abs(xn - x)
        tol = 4e-16 * abs(xn) + 1e-300
        # quadratic regime (the step shrank ≥ 10×) with |Δ| ≤ 1e-9|x|: the next
        # correction, ~Δ²/gap, is below rounding, so stop one iteration early
        if step <= tol or hi - lo <= tol or (step <= 1e-9 * abs(xn) and step < 0.1 * step_prev):
            return xn
        step_prev = step
        x = xn
    return 0.5 * (lo + hi)


@njit(cache=True)
def _char_value(kind_b, r, q, guess):
    """a_r(q) (kind_b False) or b_r(q) (kind_b True) for one q."""
    if r % 2 == 0:
        family = _B_EVEN if kind_b else _A_EVEN
        k = r // 2 - 1 if kind_b else r // 2
    else:
        family = _B_ODD if kind_b else _A_ODD
        k = (r - 1) // 2
    K = _truncation(k, q)
    d = np.empty(K)
    e2 = np.empty(K)
    _fill(family, q, K, d, e2)
    return _eigen_k(d, e2, K, k, guess)


@njit(cache=True, parallel=True)
def _char_values(kind_b, r, q):
    out = np.empty(q.size)
    for i in prange(q.size):
        out[i] = _char_value(kind_b, r, q[i], np.nan)
    return out


def characteristic_value(kind, r, q):
    """Mathieu characteristic value a_r(q) or b_r(q) (DLMF 28.2(v)).

    Parameters
    ----------
    kind : {"a", "b"}
        "a" for even solutions ce_r (r ≥ 0), "b" for odd solutions se_r (r ≥ 1).
    r : int
        Order.
    q : float or array
        Mathieu parameter (any sign).

    Returns
    -------
    float or ndarray
        Accurate to ≈ 1e-15 relative (see the module docstring).
    """
    if kind not in ("a", "b"):
        raise ValueError(f"kind must be 'a' or 'b', got {kind!r}.")
    if int(r) != r or r < (1 if kind == "b" else 0):
        raise ValueError(f"order r must be an integer ≥ {1 if kind == 'b' else 0} for kind "
                         f"{kind!r}, got {r!r}.")
    qa = np.asarray(q, dtype=float)
    if not np.all(np.isfinite(qa)):
        raise ValueError("q must be finite.")
    out = _char_values(kind == "b", int(r), np.ascontiguousarray(qa.ravel())).reshape(qa.shape)
    return float(out) if out.ndim == 0 else out


# -- boundaries below a level, per q -----------------------------------------------------

@njit(cache=True)
def _boundaries_below(q, amax, vals, orders, hist, qhist):
    """All characteristic values < amax at q, sorted; returns how many.

    ``orders`` gets +r for a_r and −r for b_r.  ``hist[f, k, 0:2]`` holds the
    values of family f, index k at the two previous q of the sweep (``qhist``),
    so the next value is guessed by linear extrapolation (continuation); the
    guess only speeds up the search, the Sturm counts decide.
    """
    n = 0
    kmax = hist.shape[1]
    K = _truncation(kmax, q)
    d = np.empty(K)
    e2 = np.empty(K)
    for family in range(4):
        _fill(family, q, K, d, e2)
        # Gershgorin: the lowest eigenvalue is ≥ min(d_i − |e_i−1| − |e_i|); skip the count
        # (and the family) when that bound is above every a of the grid
        low = 1e300
        for i in range(K):
            rad = 0.0
            if i > 0:
                rad += math.sqrt(e2[i - 1])
            if i < K - 1:
                rad += math.sqrt(e2[i])
            low = min(low, d[i] - rad)
        cnt = 0
        if low < amax:
            cnt, _ = _sturm(d, e2, K, amax)
            cnt = min(cnt, kmax)
        for k in range(cnt):
            g0 = hist[family, k, 0]
            g1 = hist[family, k, 1]
            guess = g0
            if math.isfinite(g1) and qhist[0] != qhist[1]:
                guess = g0 + (g0 - g1) * (q - qhist[0]) / (qhist[0] - qhist[1])
            v = _eigen_k(d, e2, K, k, guess)
            hist[family, k, 1] = g0
            hist[family, k, 0] = v
            if family == _A_EVEN:
                rr = 2 * k
            elif family == _B_EVEN:
                rr = -(2 * k + 2)
            elif family == _A_ODD:
                rr = 2 * k + 1
            else:
                rr = -(2 * k + 1)
            # insertion sort: a handful of values
            j = n
            while j > 0 and vals[j - 1] > v:
                vals[j] = vals[j - 1]
                orders[j] = orders[j - 1]
                j -= 1
            vals[j] = v
            orders[j] = rr
            n += 1
        for k in range(cnt, kmax):
            hist[family, k, 0] = np.nan
            hist[family, k, 1] = np.nan
    qhist[1] = qhist[0]
    qhist[0] = q
    return n


@njit(cache=True)
def _fill_row(stable_row, label_row, a, ascending, vals, n):
    """Classify one row of a *monotone* a-axis by runs between the boundaries vals[:n]."""
    na = a.size
    start = 0
    for cnt in range(n + 1):
        # the run where exactly `cnt` boundaries lie below a: a ∈ (vals[cnt-1], vals[cnt]]
        if cnt < n:
            # first index (in increasing-a order) with a > vals[cnt]
            lo = start
            hi = na
            while lo < hi:
                mid = (lo + hi) // 2
                x = a[mid] if ascending else a[na - 1 - mid]
                if x > vals[cnt]:
                    hi = mid
                else:
                    lo = mid + 1
            stop = lo
        else:
            stop = na
        if stop > start:
            st = cnt % 2 == 1
            lab = 0 if st else (1 if (cnt // 2) % 2 == 0 else 2)
            if ascending:
                stable_row[start:stop] = st
                label_row[start:stop] = lab
            else:
                stable_row[na - stop:na - start] = st
                label_row[na - stop:na - start] = lab
        start = stop


@njit(cache=True)
def _classify_grid(q, a, kmax, stable, label, chunk):
    """stable[i, j], label[i, j] for (q[i], a[j]); label 0 stable, 1 period T, 2 period 2T.

    Characteristic values are computed once per q (continuation along the q axis
    within each chunk); a monotone a axis is then classified by runs between
    them (binary search), any other by a scan per point.  Serial on purpose: the
    whole 1000 × 1000 grid takes a few ms, and on the shared 2-core machine a
    prange version was 2–3× slower (threads wait for a descheduled partner).
    """
    nq = q.size
    na = a.size
    amax = -1e300
    for j in range(na):
        amax = max(amax, a[j])
    ascending = True
    descending = True
    for j in range(1, na):
        if a[j] < a[j - 1]:
            ascending = False
        if a[j] > a[j - 1]:
            descending = False
    nchunks = (nq + chunk - 1) // chunk
    for c in range(nchunks):
        vals = np.empty(4 * kmax + 1)
        orders = np.empty(4 * kmax + 1, dtype=np.int64)
        hist = np.full((4, kmax, 2), np.nan)
        qhist = np.full(2, np.nan)
        for i in range(c * chunk, min(nq, (c + 1) * chunk)):
            n = _boundaries_below(abs(q[i]), amax, vals, orders, hist, qhist)
            if ascending or descending:
                _fill_row(stable[i], label[i], a, ascending, vals, n)
                continue
            for j in range(na):
                x = a[j]
                cnt = 0
                while cnt < n and vals[cnt] < x:
                    cnt += 1
                stable[i, j] = cnt % 2 == 1
                # tongue (b_r, a_r) with r = cnt/2; r = 0: below a0
                label[i, j] = 0 if cnt % 2 == 1 else (1 if (cnt // 2) % 2 == 0 else 2)


#: the most characteristic values per family :func:`stability_counts` computes per q
_KMAX_LIMIT = 1_000


def _kmax_needed(q, a):
    # characteristic values below max(a): a_k, b_k ≥ k² − 2|q| roughly (Gershgorin), so
    # orders up to √(max a + 2|q|) + 2 suffice in each family.  An empty grid needs none.
    if np.size(q) == 0 or np.size(a) == 0:
        return 3
    amax = float(np.max(a))
    return int(math.sqrt(max(amax + 2.0 * float(np.max(np.abs(q))), 0.0)) / 2) + 3


def stability_counts(q, a):
    """Classify the undamped Mathieu equation on the grid q × a from characteristic values.

    Parameters
    ----------
    q, a : 1-d arrays
        Grid axes (characteristic values are computed once per q, then compared
        with every a: O(len(q)) eigenvalue problems + O(len(q)·len(a)) comparisons).

    Returns
    -------
    stable : bool ndarray (len(q), len(a))
    label : int8 ndarray (len(q), len(a))
        0 stable; 1 unstable in a tongue bounded by period-T (τ-period π)
        characteristic values; 2 bounded by period-2T ones.
    """
    q = np.ascontiguousarray(q, dtype=float)
    a = np.ascontiguousarray(a, dtype=float)
    if q.ndim != 1 or a.ndim != 1:
        raise ValueError("q and a must be 1-d arrays (grid axes).")
    if not (np.all(np.isfinite(q)) and np.all(np.isfinite(a))):
        raise ValueError("q and a must be finite.")
    if _kmax_needed(q, a) > _KMAX_LIMIT:
        raise ValueError(f"max(a) = {float(np.max(a)):.3g} (with max|q| = "
                         f"{float(np.max(np.abs(q))):.3g}) lies above more than {_KMAX_LIMIT} "
                         "characteristic values per family; keep a + 2|q| below 4e6.")
    stable = np.empty((q.size, a.size), dtype=np.bool_)
    label = np.empty((q.size, a.size), dtype=np.int8)
    # continuation along q: one chunk of consecutive q per task (a few tasks per core)
    _classify_grid(q, a, _kmax_needed(q, a), stable, label, max(1, -(-q.size // 8)))
    return stable, label


def ince_strutt_boundaries(q, r_max=4):
    """Characteristic curves a_0..a_rmax, b_1..b_rmax on a q array (for the Ince–Strutt chart).

    Returns
    -------
    dict
        {"a0": array, "b1": array, "a1": array, ...}
    """
    q = np.asarray(q, dtype=float)
    out = {}
    for r in range(0, r_max + 1):
        if r >= 1:
            out[f"b{r}"] = characteristic_value("b", r, q)
        out[f"a{r}"] = characteristic_value("a", r, q)
    return out


def ince_strutt_chart(q_max=20.0, a_range=(-20.0, 30.0), r_max=5, n=400) -> InceStruttChart:
    """The Ince–Strutt chart on an n × n grid q ∈ [0, q_max], a ∈ a_range.

    Stability at every point from characteristic values (:func:`stability_counts`) and
    the curves a_0..a_rmax, b_1..b_rmax (:func:`ince_strutt_boundaries`); draw it with
    :func:`kapitza.plots.ince_strutt_figure`.

    Examples
    --------
    >>> chart = ince_strutt_chart(q_max=10, a_range=(-10, 20), r_max=3, n=50)
    >>> sorted(chart.curves)
    ['a0', 'a1', 'a2', 'a3', 'b1', 'b2', 'b3']
    >>> bool(chart.stable[0, -1]), bool(chart.stable[0, 0])   # q = 0: stable iff a ≥ 0
    (True, False)
    """
    if not (q_max > 0 and len(a_range) == 2 and a_range[0] < a_range[1] and n >= 2):
        raise ValueError(f"need q_max > 0, a_range = (low, high) with low < high and n ≥ 2; got "
                         f"q_max={q_max!r}, a_range={a_range!r}, n={n!r}.")
    q = np.linspace(0.0, q_max, n)
    a = np.linspace(a_range[0], a_range[1], n)
    stable, _ = stability_counts(q, a)
    return InceStruttChart(q=q, a=a, stable=stable, curves=ince_strutt_boundaries(q, r_max))


# -- monodromy trace by integration ------------------------------------------------------

@njit(cache=True)
def _half_period(a, q, N, out):
    """RK4 over τ ∈ [0, π/2] for u″ = −(a − 2q cos 2τ) u, both unit solutions.

    Columns are renormalised when large; out = [u1, u1′, u2, u2′, log s1, log s2].
    """
    h = 0.5 * math.pi / N
    x1, v1, x2, v2 = 1.0, 0.0, 0.0, 1.0
    ls1 = 0.0
    ls2 = 0.0
    for n in range(N):
        t0 = n * h
        f0 = -(a - 2.0 * q * math.cos(2.0 * t0))
        fm = -(a - 2.0 * q * math.cos(2.0 * (t0 + 0.5 * h)))
        f1 = -(a - 2.0 * q * math.cos(2.0 * (t0 + h)))
        # RK4 for the linear system (x, v)' = (v, f x), both columns
        for col in range(2):
            x = x1 if col == 0 else x2
            v = v1 if col == 0 else v2
            k1x = v
            k1v = f0 * x
            k2x = v + 0.5 * h * k1v
            k2v = fm * (x + 0.5 * h * k1x)
            k3x = v + 0.5 * h * k2v
            k3v = fm * (x + 0.5 * h * k2x)
            k4x = v + h * k3v
            k4v = f1 * (x + h * k3x)
            x += h / 6.0 * (k1x + 2.0 * k2x + 2.0 * k3x + k4x)
            v += h / 6.0 * (k1v + 2.0 * k2v + 2.0 * k3v + k4v)
            if col == 0:
                x1 = x
                v1 = v
            else:
                x2 = x
                v2 = v
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


@njit(cache=True)
def _trace_tol(a, q, tol, nmax, res):
    """Trace of M_u to tolerance: RK4 at N and 2N steps, Richardson, doubling N.

    res = [trace (±inf if > 1e304), sign, log|trace|, error estimate (relative to
    max(1, |tr|)), steps per half period].
    """
    buf = np.empty(6)
    N = 8 + 4 * int(math.sqrt(abs(a) + 2.0 * abs(q)))
    s1, l1 = _trace_log(a, q, N, buf)
    while True:
        s2, l2 = _trace_log(a, q, 2 * N, buf)
        ref = max(l1, l2, 0.0)
        # values scaled by e^-ref: the error is relative to max(1, |tr|)
        t1 = s1 * math.exp(l1 - ref)
        t2 = s2 * math.exp(l2 - ref)
        est = abs(t2 - t1) / 15.0
        if est <= tol or 2 * N >= nmax:
            t = t2 + (t2 - t1) / 15.0          # Richardson (RK4: error ∝ h⁴)
            sign = 1.0 if t >= 0 else -1.0
            lt = math.log(abs(t)) + ref if t != 0.0 else -np.inf
            res[0] = _from_log(sign, lt)
            res[1] = sign
            res[2] = lt
            res[3] = est
            res[4] = 2 * N
            return
        N *= 2
        s1, l1 = s2, l2


@njit(cache=True, parallel=True)
def _trace_grid(ap, q, tol, nmax, out):
    """out[i, j, :] = _trace_tol(ap[j], q[i]) for a grid (u-equation, a′ per column)."""
    for i in prange(q.size):
        res = np.empty(5)
        for j in range(ap.size):
            _trace_tol(ap[j], q[i], tol, nmax, res)
            for k in range(5):
                out[i, j, k] = res[k]


def mathieu_monodromy_trace(a, q, c=0.0, tol=1e-12, max_steps=1 << 20):
    """Trace of the monodromy of y″ + c y′ + (a − 2q cos 2τ) y = 0 over τ ∈ [0, π].

    Computed by integration (classical RK4 on the damping-free u-equation over
    half a period, using the even symmetry of cos 2τ; N and 2N steps compared
    and Richardson-extrapolated, N doubled until the estimate meets ``tol``).

    Returns
    -------
    trace : float
        tr M_y = e^(−cπ/2) tr M_u (±inf if beyond float range; see ``log_abs``).
    log_abs : float
        log|tr M_y|, finite even when |tr| ≫ 1e308.
    error : float
        Estimated error of tr M_u relative to max(1, |tr M_u|).
    """
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
    damp = (np.pi * c / 2).ravel()
    log_abs = out[0, :, 2] - damp
    sign = out[0, :, 1]
    tr = np.where(log_abs > 700, sign * np.inf, sign * np.exp(np.minimum(log_abs, 700)))
    return tr.reshape(shape), log_abs.reshape(shape), out[0, :, 3].reshape(shape)


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


def pendulum_stability_window(omega, *, l=1.0, g=9.81, damping=0.0, about="inverted",
                              tol=1e-10) -> StabilityWindow:
    """The first window of drive amplitudes A_min < A < A_max that stabilises the pendulum.

    Root-finding on the Floquet condition at each ω:

    * undamped: the characteristic curves, a0(q) = a (A_min, the Kapitza limit)
      and b1(q) = a (A_max, the first period-2T resonance) for the inverted
      pendulum (a = −4ω0²/ω² < 0); for the hanging pendulum A_min = 0 and A_max
      is where the first tongue a_r(q) = a or b_(r+1)(q) = a is reached
      (r² < a < (r+1)²);
    * damped: |tr M_y(q)| = 1 + e^(−γT), with tr M from
      :func:`mathieu_monodromy_trace` at tolerance tol/100.

    Parameters
    ----------
    omega : float or 1-d array
        Drive angular frequency (rad/s); a scalar gives a window of scalar fields.
    l, g, damping : float
        Length (m), gravity (m/s²), damping rate γ (1/s).
    about : {"inverted", "hanging"}
    tol : float
        Requested relative accuracy of A_min and A_max.

    Returns
    -------
    kapitza.results.StabilityWindow
        ``method="floquet"``: A_min, A_max (m) per ω, NaN where there is no window
        (e.g. ω too low to hold the pendulum upright); ``accuracy`` is the
        certified relative accuracy (the Floquet condition changes sign across
        A·(1 ± accuracy)).

    Examples
    --------
    At ω = 10⁴ ω0 the upper edge is the first parametric resonance, A_max → 0.4540 l:

    >>> import math
    >>> win = pendulum_stability_window(1e4 * math.sqrt(9.81), l=1.0, g=9.81)
    >>> print(f"{win.A_max:.4f} m")
    0.4540 m
    >>> bool(win.accuracy <= 1e-10)          # certified to the requested tol
    True
    """
    l, g, damping = arguments.pendulum_constants(l, g, damping)
    sign = arguments.about_sign(about)
    if not (1e-15 <= tol < 1e-1):
        raise ValueError(f"tol must lie in [1e-15, 0.1), got {tol!r}.")
    w = arguments.grid_axis("omega", omega, "rad/s", positive=True)
    Amin = np.full(w.size, np.nan)
    Amax = np.full(w.size, np.nan)
    acc = np.full(w.size, np.nan)
    for i, om in enumerate(w):
        a, _, c = mathieu_parameters(0.0, om, l, g, damping, about)
        a, c = float(a), float(c)
        if damping == 0.0:
            if sign < 0:
                f0 = lambda q: _char_value(False, 0, q, np.nan) - a      # noqa: E731
                f1 = lambda q: _char_value(True, 1, q, np.nan) - a       # noqa: E731
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
                roots = [_first_root(lambda q: _char_value(True, r + 1, q, np.nan) - a, hi, tol)]
                if r >= 1:
                    roots.append(_first_root(lambda q: _char_value(False, r, q, np.nan) - a,
                                             hi, tol))
                q1, e1 = min(roots)
                Amin[i], Amax[i], acc[i] = 0.0, q1, e1
        else:
            thr = 1.0 + math.exp(-2 * math.pi * damping / om)
            ap = a - c * c / 4

            def margin(q):          # > 0 unstable, < 0 stable
                tr, la, _ = mathieu_monodromy_trace(ap, q, 0.0, tol=min(1e-12, tol / 100))
                return math.exp(min(float(la) - math.pi * c / 2, 700.0)) - thr

            qs = np.concatenate([[0.0], np.geomspace(1e-4, 40.0, 240)]) if sign < 0 else \
                np.linspace(0.0, 4 * abs(a) + 20, 400)
            vals = np.array([margin(q) for q in qs])
            st = vals < 0
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
            else:
                if not st[0]:
                    continue
                j1 = np.argmax(~st) if np.any(~st) else None
                if j1 is None:
                    continue
                q1, e1 = _bracket_root(margin, qs[j1 - 1], qs[j1], tol)
                Amin[i], Amax[i], acc[i] = 0.0, q1, e1
    # the roots above are in q (A_min of the hanging pendulum is 0 in either unit)
    A_min, A_max = amplitude_from_q(Amin, l), amplitude_from_q(Amax, l)
    if np.ndim(omega) == 0:           # a scalar call gives scalars
        w, A_min, A_max, acc = float(w[0]), float(A_min[0]), float(A_max[0]), float(acc[0])
    return StabilityWindow(omega=w, A_min=A_min, A_max=A_max, method="floquet", about=about,
                           accuracy=acc, tol=tol, l=l, g=g, damping=damping)


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
    A ≈ 43 cm (compare :func:`pendulum_stability_window`):

    >>> m = pendulum_stability_map([0.05, 0.1, 0.3, 0.5], [60.0])
    >>> m.boundary[:, 0].tolist()
    ['T', 'stable', 'stable', '2T']
    """
    l, g, damping = arguments.pendulum_constants(l, g, damping)
    arguments.about_sign(about)
    A = arguments.grid_axis("A", A, "m", positive=False)
    w = arguments.grid_axis("omega", omega, "rad/s", positive=True)
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
            wmin = float(np.min(w))
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
        out = np.full((q.size, w.size, 5), np.nan)

        def rows(i0, i1):
            _trace_grid(ap, qc[i0:i1], float(tol), 1 << 22, out[i0:i1])

        done, interrupted = run_in_chunks(rows, q.size, progress=progress,
                                          label="Mathieu trace map", unit="rows of A",
                                          first=2)
        out[done:] = np.nan          # a chunk may have finished just as Ctrl-C came
        lg_u = out[:, :, 2]
        log_tr = lg_u - (np.pi * c / 2)[None, :]
        tr = np.where(log_tr > 700, out[:, :, 1] * np.inf,
                      out[:, :, 1] * np.exp(np.minimum(log_tr, 700)))
        # log|λ|max = −cπ/2 + arccosh(|tr M_u|/2) (0 where |tr M_u| ≤ 2), in log form
        with np.errstate(over="ignore", invalid="ignore"):
            big = lg_u > 30
            trm = np.where(big, 0.0, np.exp(np.minimum(lg_u, 30)) / 2)
            ach = np.where(big, lg_u, np.arccosh(np.maximum(trm, 1.0)))
        lg = ach - (np.pi * c / 2)[None, :]
        bad = ~np.isfinite(lg[:done])
        flagged = int(bad.sum())
        if flagged:
            i, j = np.argwhere(bad)[0]
            example = (f"trace not computed at A = {A[i]:.6g} m, ω = {w[j]:.6g} rad/s (RK4 "
                       "overflow: a slow drive or a huge amplitude); NaN, reported unstable. "
                       "kapitza.floquet.stability_map estimates its growth",)
        est = out[:done, :, 3][np.isfinite(out[:done, :, 3])]
        err = float(np.max(est)) if est.size else 0.0
        if damping > 0.0:
            thr = 1.0 + np.exp(-2 * np.pi * damping / w)
            with np.errstate(invalid="ignore"):
                stable = np.where(log_tr > 700, False, np.abs(tr) < thr[None, :])
            label = np.where(stable, 0, np.where(out[:, :, 1] > 0, 1, 2)).astype(np.int8)
            label[done:] = 3
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


# -- series for small q (the next order of averaging) ----------------------------------
#
# About θ = 0 (hanging, +) and θ = π (upright, −) the vertically driven pendulum is the
# Mathieu equation with solutions e^{iντ} × (π-periodic); the slow angular frequency of
# the pendulum is Ω = ν ω / 2.  Damping γ enters *exactly* as a′ = a − c²/4 = a − γ²/ω²
# with the multipliers scaled by e^{−γT/2} (see the module docstring).

def exponent_squared(a, q, order: int = 2):
    """Characteristic exponent squared ν²(a, q) of the Mathieu equation, small a and q.

    Inverting DLMF 28.15.1 (a = ν² + q²/(2(ν² − 1)) + (5ν² + 7) q⁴/(32 (ν² − 1)³ (ν² − 4)) + …)
    in the Kapitza scaling a ~ q² ~ ε²:

    * ``order=1`` (first-order averaging): ν² = a + q²/2, error O(ε⁴);
    * ``order=2``: ν² = a + q²/2 + a q²/2 + 25 q⁴/128, error O(ε⁶).

    Both are exact at q = 0 (ν² = a), and order 2 vanishes on the series of
    a₀(q) = −q²/2 + 7q⁴/128 + O(q⁶) (the Kapitza limit).  The relative error
    of Ω = νω/2 is O(ε²) (order 1) and O(ε⁴) (order 2) away from ν = 0.

    Parameters
    ----------
    a, q : array_like
    order : {1, 2}

    Returns
    -------
    ndarray
        ν²; negative means the solutions grow as e^{√(−ν²) τ}.

    Examples
    --------
    On the Kapitza limit a = a₀(q) the exponent vanishes, to O(q⁶) at order 2:

    >>> q = 0.1
    >>> a = characteristic_value("a", 0, q)
    >>> print(f"{exponent_squared(a, q, 1):.1e} {exponent_squared(a, q, 2):.1e}")
    5.5e-06 1.5e-08
    """
    a, q = np.asarray(a, float), np.asarray(q, float)
    q2 = q * q
    if arguments.averaging_order(order) == 1:
        return a + q2 / 2
    return a + q2 / 2 + a * q2 / 2 + 25.0 * q2 * q2 / 128


def mathieu_a0(q):
    """a₀(q) from its power series (A&S 20.2.25), through q⁸.

    Absolute error ≈ 1e-10 at q = 0.2, 1e-6 at q = 0.5 (against
    :func:`characteristic_value`).

    Examples
    --------
    >>> print(f"{abs(mathieu_a0(0.2) - characteristic_value('a', 0, 0.2)):.0e}")
    1e-10
    """
    q = np.asarray(q, float)
    return -q**2 / 2 + 7 * q**4 / 128 - 29 * q**6 / 2304 + 68687 * q**8 / 18874368


def mathieu_b1(q):
    """b₁(q) from its power series (A&S 20.2.25), through q⁸.

    Absolute error < 1e-12 at q = 0.2, ≈ 3e-7 at q = 0.9 (against
    :func:`characteristic_value`); b₁ = 0 at q = 0.90805 (the upright pendulum's
    upper limit A/l = 0.4540 for ω → ∞).

    Examples
    --------
    >>> print(f"{abs(mathieu_b1(0.9) - characteristic_value('b', 1, 0.9)):.0e}")
    3e-07
    """
    q = np.asarray(q, float)
    return (1 - q - q**2 / 8 + q**3 / 64 - q**4 / 1536 - 11 * q**5 / 36864 + 49 * q**6 / 589824
            - 55 * q**7 / 9437184 - 83 * q**8 / 35389440)


def mathieu_b1_root(a):
    """q ∈ [0, 2.5] with :func:`mathieu_b1`(q) = a (the series decreases there); vectorised
    bisection to rounding.

    Examples
    --------
    >>> print(f"{mathieu_b1_root(0.0):.5f}")      # A/l = q/2 = 0.4540 for ω → ∞
    0.90805
    """
    target = np.asarray(a, float)
    lo, hi = np.zeros_like(target), np.full_like(target, 2.5)
    for _ in range(60):
        mid = (lo + hi) / 2
        above = mathieu_b1(mid) > target
        lo, hi = np.where(above, mid, lo), np.where(above, hi, mid)
    return (lo + hi) / 2
