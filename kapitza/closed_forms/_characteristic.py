"""Mathieu characteristic values a_r(q), b_r(q): the boundaries of the stability chart.

The Mathieu equation y″ + (a − 2q cos 2τ) y = 0 (the single driven pendulum's reduction:
:mod:`kapitza.closed_forms._mathieu`, shared/PHYSICS.md); here its characteristic values,
the stability of a grid (q, a) counted from them, the Ince–Strutt chart, and the small-q
series behind the next order of averaging.

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
For the next order of averaging (:mod:`kapitza.closed_forms._pendulum`) the
characteristic exponent ν²(a, q) and the characteristic values a₀, b₁ are also
given as power series (:func:`exponent_squared`, :func:`mathieu_a0`,
:func:`mathieu_b1`; A&S 20.2.25, DLMF 28.6, 28.15.1), with their accuracy stated.
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

from .. import _arguments as arguments
from ..results import InceStruttChart

__all__ = ["characteristic_value", "stability_counts", "ince_strutt_boundaries",
           "ince_strutt_chart", "exponent_squared", "mathieu_a0", "mathieu_b1",
           "mathieu_b1_root"]

# families of the tridiagonal problems (see the module docstring)
_A_EVEN, _B_EVEN, _A_ODD, _B_ODD = 0, 1, 2, 3


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
        for _it in range(200):
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
    for _it in range(200):
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


@njit(cache=True)
def _char_values_serial(kind_b, r, q):
    """:func:`_char_values` on the calling thread: the same values, bit for bit."""
    out = np.empty(q.size)
    for i in range(q.size):
        out[i] = _char_value(kind_b, r, q[i], np.nan)
    return out


#: Below this many values :func:`characteristic_value` loops on the calling thread (a call
#: under 0.1 ms).  A value takes ~1.5–2.5 µs; a parallel region costs ~5 µs to start, and
#: afterwards OpenMP's idle threads spin, waiting for the next one, while the caller runs
#: Python — the window's bisections call it ~1400 times on 1–2 values (a stability_window
#: study's small run: 4.6–11 CPU-s with the threads spinning on a loaded machine, ~2 with
#: them passive), and a first call compiled the parallel kernel for a handful of values.
#: Measured 2026-11-29, 2 cores: serial/parallel wall 0.7× at 1 value, 1.4× at 4, 1.7× at
#: 16–1024; CPU-s equal from 16 values on.
_SERIAL_BELOW = 64


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
    values = _char_values_serial if qa.size < _SERIAL_BELOW else _char_values
    out = values(kind == "b", int(r), np.ascontiguousarray(qa.ravel())).reshape(qa.shape)
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
    ascending = np.bool_(True)     # (not a literal: _fill_row would compile twice)
    descending = np.bool_(True)
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
    if q.size == 0 or a.size == 0:      # an empty map: no characteristic value is needed
        return np.empty((q.size, a.size), dtype=np.bool_), np.empty((q.size, a.size), np.int8)
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
    :func:`kapitza.figures.ince_strutt_figure`.

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


# a first call on the main thread compiles where Ctrl-C need not wait for it
from lagrange_core._first_calls import guard as _guard_first_calls  # noqa: E402

_guard_first_calls(__name__)
