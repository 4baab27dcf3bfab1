"""The slow-frequency estimator's work over the samples, compiled: O(K) per point in numba.

:func:`estimate` is the estimator of :mod:`kapitza.simulation` (its module docstring
states the method and what the error covers).  The loops over a record's K samples —
the centred, scaled moments of each fit, the fit's residual, every sample's distance
from the fixed point, the mode projections, turning angles and Birkhoff weights — run
here, in parallel over the points, each point's loops in registers (a one-coordinate
system's in scalars); the small linear algebra of each fit (the d × d pseudo-inverses
and the eigenvectors, d = 2n) stays in NumPy, batched over the points.  Why: the same
estimator written with NumPy over (P, K, d) arrays made a dozen (P, K) temporaries per
fit and took 0.7 ms per point of 500 samples (2.8 s for the 64 × 64 grid of
benchmarks/bench_measure.py, 3× the simulation it measured); here it takes about 1/5 of
that (measured on a loaded machine, both in one process), and its copies are a few
times the samples' own size.

The estimator is the NumPy version's (the module docstring of :mod:`kapitza.simulation`);
only the order of the sums differs — each fit's moments are sums of products of the
centred samples, divided by the scales afterwards; a turning angle is arg(z_(k+1) z̄_k),
the division's positive |z_k|² left out; projections are compared by their squares — so
results agree to rounding: on that grid Ω within 2e-11 relative, the residual 2e-13.
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit

from lagrange_core._thread_blocks import run_rows

__all__ = ["estimate", "record_extent"]

#: The fits of a record: the whole active part, its first and second halves, its middle.
FULL, FIRST, SECOND, MIDDLE = range(4)
#: The pseudo-inverses' cut: singular values below this fraction of the largest count as 0.
RCOND = 1e-13
#: A 2 × 2 matrix whose singular values are within this ratio is inverted by its adjugate
#: (:func:`_solve_2`; the cut above then removes nothing); others go to NumPy's pinv.
WELL = 1e-8
#: Turning angles (relative to arg λ) beyond which a mode's rotation number is not used.
MAX_TURN = math.pi / 2
#: Samples whose mode projection is below this fraction of its largest are not used for the
#: rotation number (a decayed mode's phase is integration noise; an undamped mode's
#: projection varies only by the harmonic content, far less).
FLOOR = 1e-3


def min_pairs(d):
    """Fewest sample pairs one fit uses: 4 per unknown of a row of [M b] (d + 1)."""
    return 4 * (d + 1)


# -- compiled: the loops over samples ---------------------------------------------------------

@njit(cache=True, nogil=True)
def _valid_lengths(q, qdot, scale, X, Kv, amplitude, lo, hi):
    """X = [q, q̇·T/(2π)] per point, the length of each record's finite prefix, and half the
    range of q over it (the slow amplitude)."""
    P, K, n = q.shape
    for p in range(lo, hi):
        k_end = K
        for k in range(K):
            ok = True
            for i in range(n):
                a = q[p, k, i]
                b = qdot[p, k, i] * scale[p]
                X[p, k, i] = a
                X[p, k, n + i] = b
                ok = ok and math.isfinite(a) and math.isfinite(b)
            if not ok:
                k_end = k
                break
        Kv[p] = k_end
        for i in range(n):
            lo = np.inf
            hi = -np.inf
            for k in range(k_end):
                lo = min(lo, q[p, k, i])
                hi = max(hi, q[p, k, i])
            amplitude[p, i] = (hi - lo) / 2 if k_end > 0 else np.nan


@njit(cache=True, nogil=True)
def _moments(X, ranges, centre, scale, ub, C0, C1, spread, lo, hi):
    """Per point and fit (pairs k = a … b − 1 of ``ranges``): the centre c and scale s of
    the starting samples x_k, and in the scaled coordinates u = (x − c)/s the mean image
    ub, C0 = Σ u_k u_kᵀ, C1 = Σ (u_(k+1) − ub) u_kᵀ and Σ |u_(k+1) − ub|².

    Two passes: the means, then the products of the centred samples x − c (summed, then
    divided by s_i s_j: the same terms, no cancellation, as the samples are centred
    before they are multiplied)."""
    P, F = ranges.shape[:2]
    d = X.shape[2]
    for p in range(lo, hi):
        cn = np.empty(d)
        dk = np.empty(d)
        dn = np.empty(d)
        A0 = np.empty((d, d))
        A1 = np.empty((d, d))
        Ek = np.empty(d)
        En = np.empty(d)
        Sn = np.empty(d)
        for f in range(F):
            a = ranges[p, f, 0]
            b = ranges[p, f, 1]
            m = max(b - a, 0)
            msafe = m if m > 0 else 1
            c = centre[p, f]
            s = scale[p, f]
            for i in range(d):
                c[i] = 0.0
                cn[i] = 0.0
            for k in range(a, b):
                for i in range(d):
                    c[i] += X[p, k, i]
                    cn[i] += X[p, k + 1, i]
            for i in range(d):
                c[i] /= msafe
                cn[i] /= msafe
                Ek[i] = 0.0
                En[i] = 0.0
                Sn[i] = 0.0
            A0[:] = 0.0
            A1[:] = 0.0
            if d == 2:                  # one coordinate: the sums in registers
                _moments_2(X[p], a, b, c[0], c[1], A0, A1, Ek, En, Sn)
            for k in range(a, b if d != 2 else a):
                for i in range(d):
                    dk[i] = X[p, k, i] - c[i]
                    dn[i] = X[p, k + 1, i] - c[i]
                    Ek[i] += dk[i]
                    En[i] += dn[i]
                    Sn[i] += dn[i] * dn[i]
                for i in range(d):
                    for j in range(d):
                        A0[i, j] += dk[i] * dk[j]
                        A1[i, j] += dn[i] * dk[j]
            for i in range(d):
                sc = math.sqrt(A0[i, i] / msafe)
                s[i] = sc if sc > 0 else 1.0
                ub[p, f, i] = (cn[i] - c[i]) / s[i]
            sp = 0.0
            for i in range(d):
                u_b = ub[p, f, i]
                sp += Sn[i] / (s[i] * s[i]) - 2.0 * u_b * En[i] / s[i] + m * u_b * u_b
                for j in range(d):
                    C0[p, f, i, j] = A0[i, j] / (s[i] * s[j])
                    C1[p, f, i, j] = A1[i, j] / (s[i] * s[j]) - u_b * Ek[j] / s[j]
            spread[p, f] = sp


@njit(cache=True, inline="always")
def _moments_2(X, a, b, c0, c1, A0, A1, Ek, En, Sn):
    """The centred sums of :func:`_moments` for d = 2 (one coordinate), in scalars."""
    a00 = a01 = a11 = b00 = b01 = b10 = b11 = 0.0
    e0 = e1 = f0 = f1 = s0 = s1 = 0.0
    for k in range(a, b):
        x0 = X[k, 0] - c0
        x1 = X[k, 1] - c1
        y0 = X[k + 1, 0] - c0
        y1 = X[k + 1, 1] - c1
        e0 += x0
        e1 += x1
        f0 += y0
        f1 += y1
        s0 += y0 * y0
        s1 += y1 * y1
        a00 += x0 * x0
        a01 += x0 * x1
        a11 += x1 * x1
        b00 += y0 * x0
        b01 += y0 * x1
        b10 += y1 * x0
        b11 += y1 * x1
    A0[0, 0] = a00
    A0[0, 1] = a01
    A0[1, 0] = a01
    A0[1, 1] = a11
    A1[0, 0] = b00
    A1[0, 1] = b01
    A1[1, 0] = b10
    A1[1, 1] = b11
    Ek[0] = e0
    Ek[1] = e1
    En[0] = f0
    En[1] = f1
    Sn[0] = s0
    Sn[1] = s1


@njit(cache=True, nogil=True)
def _residuals(X, Kv, ranges, centre, scale, ub, M, ustar, residual, distance, lo, hi):
    """The relative residual of fit 0, sqrt(Σ |u_(k+1) − ub − M u_k|² / Σ |u_(k+1) −
    ub|²) over its pairs (where ``residual`` has a column), and every valid sample's
    distance |u_k − u*| from fit 0's fixed point (where ``distance`` has a column per
    sample; 0 beyond the record)."""
    d = X.shape[2]
    for p in range(lo, hi):
        ua = np.empty(d)
        if residual.shape[1] > 0:
            a = ranges[p, 0, 0]
            b = ranges[p, 0, 1]
            c = centre[p, 0]
            s = scale[p, 0]
            r2 = 0.0
            sp = 0.0
            for k in range(a, b):
                for i in range(d):
                    ua[i] = (X[p, k, i] - c[i]) / s[i]
                for i in range(d):
                    w = (X[p, k + 1, i] - c[i]) / s[i] - ub[p, 0, i]
                    sp += w * w
                    mu = 0.0
                    for j in range(d):
                        mu += M[p, 0, i, j] * ua[j]
                    r2 += (w - mu) ** 2
            residual[p, 0] = math.sqrt(r2 / sp) if sp > 0 else np.nan
        for k in range(distance.shape[1]):
            if k >= Kv[p]:
                distance[p, k] = 0.0
                continue
            acc = 0.0
            for i in range(d):
                acc += ((X[p, k, i] - centre[p, 0, i]) / scale[p, 0, i] - ustar[p, 0, i]) ** 2
            distance[p, k] = math.sqrt(acc)


@njit(cache=True)
def _bump(pos, count):
    """Birkhoff weight exp(−1/(s(1 − s))) at s = (pos + ½)/count (0 where count ≤ 0)."""
    if count <= 0:
        return 0.0
    s = (pos + 0.5) / count
    if not (0.0 < s < 1.0):
        return 0.0
    return math.exp(-1.0 / (s * (1.0 - s)))


@njit(cache=True, nogil=True)
def _rotation(X, ranges, centre, scale, ustar, V, lin, floor, max_turn, least, mean_turn,
              clean, bound, lo, hi):
    """The rotation number of each selected mode j of each fit, from the projections
    z_k = vⱼᵀ(u_k − u*): the Birkhoff-weighted mean turning angle relative to
    ``lin`` (arg λ), where a pair's projections are above ``floor`` of their largest;
    ``clean`` says that every such angle is within ``max_turn`` of it, there are ``least``
    such pairs and weights; ``bound`` the telescoping bound of the weighted mean
    (half the range of the phase's departure times Σ |Δw|)."""
    P, F = ranges.shape[:2]
    K, d = X.shape[1], X.shape[2]
    n = V.shape[3]
    floor2 = floor * floor
    for p in range(lo, hi):
        u = np.empty(d)
        z = np.empty(K, dtype=np.complex128)
        size = np.empty(K)
        turn = np.empty(K)
        weight = np.empty(K)
        for f in range(F):
            a = ranges[p, f, 0]
            b = ranges[p, f, 1]
            for j in range(n):
                ln = lin[p, f, j]
                rot = complex(math.cos(-ln), math.sin(-ln)) if math.isfinite(ln) else 1.0 + 0j
                # the projections, and the largest over the starting samples of the pairs
                end = b + 1 if b > a else a
                if d == 2:              # one coordinate: in scalars
                    c0, c1 = centre[p, f, 0], centre[p, f, 1]
                    s0, s1 = scale[p, f, 0], scale[p, f, 1]
                    o0, o1 = ustar[p, f, 0], ustar[p, f, 1]
                    v0r, v0i = V[p, f, 0, j].real, V[p, f, 0, j].imag
                    v1r, v1i = V[p, f, 1, j].real, V[p, f, 1, j].imag
                    for k in range(a, end):
                        u0 = (X[p, k, 0] - c0) / s0 - o0
                        u1 = (X[p, k, 1] - c1) / s1 - o1
                        zr = u0 * v0r + u1 * v1r
                        zi = u0 * v0i + u1 * v1i
                        z[k] = complex(zr, zi)
                        size[k] = zr * zr + zi * zi                      # |z|²
                else:
                    for k in range(a, end):
                        zk = 0j
                        for i in range(d):
                            u[i] = ((X[p, k, i] - centre[p, f, i]) / scale[p, f, i]
                                    - ustar[p, f, i])
                            zk += u[i] * V[p, f, i, j]
                        z[k] = zk
                        size[k] = zk.real * zk.real + zk.imag * zk.imag
                big = 0.0
                for k in range(a, b):
                    big = max(big, size[k])
                # the turning angle of every pair whose projections count (NaN: not):
                # arg(z_(k+1)/z_k · e^(−i arg λ)), the division's |z_k|² left out
                count = np.int64(0)     # (not a literal: _bump would compile twice)
                for k in range(a, b):
                    if size[k] > floor2 * big and size[k + 1] > floor2 * big:
                        c = z[k + 1] * z[k].conjugate() * rot
                        turn[k] = math.atan2(c.imag, c.real)
                        count += 1
                    else:
                        turn[k] = np.nan
                # the weighted mean turning angle
                pos = np.int64(0)
                wsum = 0.0
                acc = 0.0
                ok = True
                for k in range(a, b):
                    if not math.isnan(turn[k]):
                        wk = _bump(pos, count)
                        weight[k] = wk
                        wsum += wk
                        acc += wk * turn[k]
                        ok = ok and abs(turn[k]) < max_turn
                        pos += 1
                mt = acc / wsum if wsum > 0 else np.nan
                mean_turn[p, f, j] = mt
                clean[p, f, j] = ok and wsum > 0 and count >= least
                if f > 0:           # the bound is fit 0's only
                    bound[p, f, j] = np.nan
                    continue
                # the departure g_k = Σ (turn − mean turn), and Σ |Δw| of the weights w/Σw
                mt0 = mt if math.isfinite(mt) else 0.0
                g = 0.0
                g_lo = np.inf
                g_hi = -np.inf
                dw = 0.0
                w_last = 0.0
                pos = 0
                for k in range(a, b):
                    wk = 0.0
                    if not math.isnan(turn[k]):
                        g += turn[k] - mt0
                        g_lo = min(g_lo, g)
                        g_hi = max(g_hi, g)
                        wk = weight[k] / wsum
                        pos += 1
                    dw += abs(wk - w_last)
                    w_last = wk
                dw += abs(w_last)
                bound[p, f, j] = dw * ((g_hi - g_lo) / 2 if pos > 0 else np.nan)


@njit(cache=True)
def _solve_2(C0, C1, ub, M, ustar, done):
    """M = C1 C0⁻¹ and u* = (I − M)⁻¹ ub for 2 × 2 fits (P, F, 2, 2) by the adjugate,
    where C0 (symmetric) and I − M have their singular values within WELL of each other
    (``done``; the pseudo-inverses' cut at RCOND then cuts nothing and they are the
    inverses); elsewhere ``done`` stays False."""
    P, F = C0.shape[:2]
    for p in range(P):
        for f in range(F):
            a, b, c = C0[p, f, 0, 0], C0[p, f, 0, 1], C0[p, f, 1, 1]
            half = math.sqrt(0.25 * (a - c) ** 2 + b * b)
            big = abs(0.5 * (a + c)) + half
            small = abs(abs(0.5 * (a + c)) - half)
            det = a * c - b * b
            if not (small > WELL * big and det != 0.0 and math.isfinite(det)):
                continue
            i00, i01, i11 = c / det, -b / det, a / det
            m00 = C1[p, f, 0, 0] * i00 + C1[p, f, 0, 1] * i01
            m01 = C1[p, f, 0, 0] * i01 + C1[p, f, 0, 1] * i11
            m10 = C1[p, f, 1, 0] * i00 + C1[p, f, 1, 1] * i01
            m11 = C1[p, f, 1, 0] * i01 + C1[p, f, 1, 1] * i11
            p00, p01, p10, p11 = 1.0 - m00, -m01, -m10, 1.0 - m11
            frob = p00 * p00 + p01 * p01 + p10 * p10 + p11 * p11
            da = p00 * p11 - p01 * p10
            smax = math.sqrt(0.5 * (frob + math.sqrt(max(frob * frob - 4 * da * da, 0.0))))
            if not (smax > 0.0 and abs(da) / smax > WELL * smax and math.isfinite(frob)):
                continue
            M[p, f, 0, 0], M[p, f, 0, 1], M[p, f, 1, 0], M[p, f, 1, 1] = m00, m01, m10, m11
            u0, u1 = ub[p, f, 0], ub[p, f, 1]
            ustar[p, f, 0] = (p11 * u0 - p01 * u1) / da
            ustar[p, f, 1] = (p00 * u1 - p10 * u0) / da
            done[p, f] = True


# -- the estimator --------------------------------------------------------------------------

def record_extent(q, qdot):
    """Half the range of q over each record's finite prefix (the slow amplitude; NaN for
    an empty record) and the prefix's length: (amplitude (P, n), samples (P,))."""
    q = np.ascontiguousarray(q, dtype=float)
    P, K, n = q.shape
    X = np.empty((P, K, 2 * n))
    Kv = np.empty(P, dtype=np.int64)
    amplitude = np.empty((P, n))
    run_rows(_valid_lengths, P, q, np.ascontiguousarray(qdot, dtype=float), np.ones(P), X, Kv,
             amplitude)
    return amplitude, Kv


def _fits(X, ranges, Kv, n, *, modes=True):
    """Fit x_(k+1) ≈ M x_k + b on each point's pair ranges (P, F, 2) and return the
    fields of its slow modes, like the NumPy version: ``rho`` (P, F, n) ascending, the
    turning angle per period in [0, π] (the rotation number where refined, else arg λ),
    ``growth`` (log|λ|), ``refined``, ``bound`` (fit 0's only); ``residual`` (P,) of fit
    0.  NaN where a fit has too few pairs.  Without ``modes`` only ``distance`` (P, K),
    each sample's distance from fit 0's fixed point."""
    P, F = ranges.shape[:2]
    K, d = X.shape[1], X.shape[2]
    centre, scale, ub = (np.empty((P, F, d)) for _ in range(3))
    C0, C1 = np.empty((P, F, d, d)), np.empty((P, F, d, d))
    spread = np.empty((P, F))
    run_rows(_moments, P, X, ranges, centre, scale, ub, C0, C1, spread)
    m = ranges[..., 1] - ranges[..., 0]
    enough = m >= min_pairs(d)
    C0[~enough] = np.eye(d)
    C1[~enough] = 0.0
    M = np.empty_like(C1)
    ustar = np.empty_like(ub)
    # M = C1 C0⁺, and the fixed point u* = M u* + ub, u* = (I − M)⁺ ub (pseudo-inverses:
    # a mode at λ = 1 leaves u* undetermined there): by the 2 × 2 inverse where both
    # matrices are well conditioned (one coordinate), else NumPy's pseudo-inverses
    done = np.zeros((P, F), dtype=np.bool_)
    if d == 2:
        _solve_2(C0, C1, ub, M, ustar, done)
    todo = ~done
    if todo.any():
        Mt = C1[todo] @ np.linalg.pinv(C0[todo], rcond=RCOND, hermitian=True)
        M[todo] = Mt
        ustar[todo] = (np.linalg.pinv(np.eye(d) - Mt, rcond=RCOND) @ ub[todo][..., None])[..., 0]
    residual = np.full((P, 1 if modes else 0), np.nan)          # fit 0's only
    distance = np.empty((P, K if not modes else 0))
    run_rows(_residuals, P, X, Kv, ranges, centre, scale, ub, np.ascontiguousarray(M),
             np.ascontiguousarray(ustar), residual, distance)
    if not modes:
        return dict(distance=distance)
    M[~np.isfinite(M).all(axis=(-2, -1))] = 0.0
    lam, V = np.linalg.eig(np.swapaxes(M, -1, -2))               # vᵀ M = λ vᵀ
    key = np.where(lam.imag > 0, np.angle(lam), np.inf)
    order = np.argsort(key, axis=-1)[..., :n]
    mode_ok = np.isfinite(np.take_along_axis(key, order, axis=-1)) & enough[..., None]
    lam_sel = np.take_along_axis(lam, order, axis=-1)
    # complex always: eig returns real vectors when every λ is real, and _rotation would
    # compile a second time for them
    Vsel = np.ascontiguousarray(np.take_along_axis(V, order[..., None, :], axis=-1),
                                dtype=complex)
    lin = np.where(mode_ok, np.angle(lam_sel), np.nan)
    with np.errstate(divide="ignore"):
        growth = np.where(mode_ok, np.log(np.abs(lam_sel)), np.nan)
    mean_turn, bound = np.empty((P, F, n)), np.empty((P, F, n))
    clean = np.empty((P, F, n), dtype=np.bool_)
    run_rows(_rotation, P, X, ranges, centre, scale, np.ascontiguousarray(ustar), Vsel, lin,
             FLOOR, MAX_TURN, min_pairs(d), mean_turn, clean, bound)
    refined = mode_ok & clean
    # folded into [0, π] (aliasing: e^(iρk) is e^(−iρk) and e^(i(ρ + 2π)k) as well)
    rho = np.abs(np.angle(np.exp(1j * np.where(refined, lin + mean_turn, lin))))
    # ascending Ω (refinement may reorder close modes); NaN last
    order = np.argsort(np.where(np.isnan(rho), np.inf, rho), axis=-1)
    fields = {k: np.take_along_axis(v, order, axis=-1)
              for k, v in dict(rho=rho, growth=growth, refined=refined, bound=bound).items()}
    return dict(fields, residual=np.where(enough[:, 0], residual[:, 0], np.nan))


def estimate(q, qdot, period, *, safety, residual_factor, resonance, combination):
    """The estimator on flat inputs: q, qdot (P, K, n), period (P,); a dict of arrays
    (omega_slow, omega_slow_error, refined, growth_rate (P, n); fit_residual (P,);
    amplitude (P, n); samples (P,)).  ``safety`` and ``residual_factor`` are the
    constants of the error estimate, ``resonance(Om, period, count, residual)`` and
    ``combination(...)`` its resonance terms (:mod:`kapitza.simulation`)."""
    q = np.ascontiguousarray(q, dtype=float)
    qdot = np.ascontiguousarray(qdot, dtype=float)
    P, K, n = q.shape
    d = 2 * n
    X = np.empty((P, K, d))
    Kv = np.empty(P, dtype=np.int64)
    amplitude = np.empty((P, n))
    run_rows(_valid_lengths, P, q, qdot, np.ascontiguousarray(period / (2 * np.pi)), X, Kv,
             amplitude)
    # the active part of the record: from the first to the last pair whose samples are
    # above FLOOR of the largest distance from the fixed point (a decayed tail is noise)
    pairs_end = np.maximum(Kv - 1, 0)
    everything = np.stack([np.zeros(P, dtype=np.int64), pairs_end], axis=-1)[:, None, :]
    distance = _fits(X, np.ascontiguousarray(everything), Kv, n, modes=False)["distance"]
    pairs = np.arange(max(K - 1, 0))[None, :] < pairs_end[:, None]
    above = pairs & (np.minimum(distance[:, :-1], distance[:, 1:])
                     >= FLOOR * distance.max(axis=1, initial=0.0)[:, None])
    any_above = above.any(axis=1)
    if K > 1:
        first = np.where(any_above, np.argmax(above, axis=1), 0)
        last = np.where(any_above, K - 2 - np.argmax(above[:, ::-1], axis=1), -1)
    else:
        first, last = np.zeros(P, dtype=np.int64), np.full(P, -1, dtype=np.int64)
    count = np.maximum(last - first + 1, 0)
    half, quarter = first + count // 2, first + count // 4
    ranges = np.empty((P, 4, 2), dtype=np.int64)
    ranges[:, FULL] = np.stack([first, first + count], axis=-1)
    ranges[:, FIRST] = np.stack([first, half], axis=-1)
    ranges[:, SECOND] = np.stack([half, first + count], axis=-1)
    ranges[:, MIDDLE] = np.stack([quarter, quarter + count // 2], axis=-1)
    fit = _fits(X, ranges, Kv, n)
    omega = 2 * np.pi / period[:, None]
    Om = fit["rho"][:, FULL] / period[:, None]
    spread = np.zeros_like(Om)
    for part in (FIRST, SECOND, MIDDLE):
        other = fit["rho"][:, part] / period[:, None]
        with np.errstate(invalid="ignore"):
            spread = np.maximum(spread, np.where(np.isfinite(other), np.abs(Om - other), np.inf))
    spread = safety * spread
    residual = fit["residual"]
    refined = fit["refined"][:, FULL]
    bias = np.where(refined, 0.0, residual_factor * residual[:, None] ** 2 * Om)
    resonant = combination(Om, period, count, residual)
    error = spread + bias + resonance(Om, period, count, residual)
    error = np.maximum(np.where(resonant, error + fit["bound"][:, FULL] / period[:, None],
                                error), 1e-12 * omega)
    error = np.where(np.isfinite(Om), error, np.nan)
    return dict(omega_slow=Om, omega_slow_error=error, refined=refined,
                growth_rate=fit["growth"][:, FULL] / period[:, None], fit_residual=residual,
                amplitude=amplitude, samples=Kv)


# a first call on the main thread compiles where Ctrl-C need not wait for it
from lagrange_core._first_calls import guard as _guard_first_calls  # noqa: E402

_guard_first_calls(__name__)
