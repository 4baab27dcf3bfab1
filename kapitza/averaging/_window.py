"""The averaging window of any system: the amplitudes that hold an equilibrium, per ω.

The first-order averaging overlay of any system's stability map
(:func:`kapitza.floquet.stability_map`, drawn by
:func:`kapitza.figures.stability_map_figure`), reached through
:meth:`kapitza.averaging.AveragedSystem.window`.

Method
------
Per ω, ``A_min`` is the smallest value of the amplitude parameter at which every
eigenvalue of the averaged stiffness about ``about`` is positive (every slow mode real,
Ω² > 0).  When the amplitude only scales the fast forces (f = A g(q), a pivot moving as
A d cos ωt; checked symbolically), the averaged stiffness is exactly H(A) = H₀ + A² H₂,
so with the margin m(s) = λ_min(L⁻¹(H₀ + s H₂)L⁻ᵀ) (M = L Lᵀ, s = A²) the edges are the
roots of m.  m is the smallest eigenvalue of an affine family of symmetric matrices,
hence concave in s, so Newton's method (slope vᵀ L⁻¹H₂L⁻ᵀ v from the lowest eigenvector
v) started at s = 0 climbs to the lower root monotonically, for all ω at once (batched
eigh).  m → −∞ only if H₂ has a negative direction; then an upper edge exists (found the
same way from above), otherwise ``A_max = inf`` (first-order averaging does not see the
parametric resonance that bounds the exact window).  Other amplitude dependences fall
back to ``brentq`` on m(A) per ω within ``A_range`` (needed; the upper edge is then not
searched, +inf).

Accuracy
--------
First-order averaging: relative error of the edge O(ω_s²/ω²), ω_s the slow scale
(ω0 = √(g/l) for the pendulum, where the exact relative error of A_min is ≈ (7/16)
ω0²/ω²); ``error_estimate`` reports (ω_s/ω)².  The roots themselves are solved to
rounding (≈ 1e-15 relative): the single pendulum gives A_min ω = √(2 g l), the N-link
chain √2 g / ω_min (Acheson).
"""
from __future__ import annotations

import math

import numpy as np
import sympy as sp

from ..results import StabilityWindow
from ._codegen import effective, terms
from ._validity import MAX_AMPLITUDE_RATIO, MIN_FREQUENCY_RATIO

__all__ = ["averaged_system_window", "amplitude_range"]


def amplitude_range(A_range, where: str) -> tuple[float, float]:
    """``A_range`` as floats (low, high) with 0 ≤ low < high ≤ inf; (0, inf) for None."""
    if A_range is None:
        return 0.0, math.inf
    try:
        low, high = (float(x) for x in A_range)
    except (TypeError, ValueError):
        raise ValueError(f"{where}: A_range must be a pair (low, high) of amplitudes (m), got "
                         f"{A_range!r}; e.g. A_range=(0.0, 0.5).") from None
    if not (0 <= low < high and not math.isnan(high)):
        raise ValueError(f"{where}: A_range must be (low, high) with 0 ≤ low < high (m), got "
                         f"{A_range!r}; e.g. A_range=(0.0, 0.5).")
    return low, high


def averaged_system_window(avg, params, about, omega, *, amplitude: str = "A",
                           A_range=None) -> StabilityWindow:
    """The window of :meth:`kapitza.averaging.AveragedSystem.window` (see there and the
    module docstring)."""
    import scipy.optimize  # not at import: scipy costs ~0.4 s

    where = "AveragedSystem.window"
    system = avg.system
    names = system.parameters
    frequency = avg.omega.name
    if not isinstance(amplitude, str) or amplitude not in names:
        raise ValueError(f"{where}: amplitude={amplitude!r} is not a parameter; the parameters "
                         f"are {list(names)}.")
    if amplitude == frequency:
        raise ValueError(f"{where}: amplitude={amplitude!r} is the drive frequency; name the "
                         "drive amplitude parameter.")
    if avg._drag_pairs:
        raise ValueError(f"{where}: this damped drive has two phases, whose mean drag moves "
                         "the equilibrium with the amplitude; use slow_modes or sweep at each "
                         "amplitude instead.")
    w_in = np.asarray(omega, float)
    ws = np.atleast_1d(w_in).ravel()
    if not np.all(np.isfinite(ws) & (ws > 0)):
        raise ValueError(f"{where}: the drive frequencies omega must be finite and > 0 (rad/s), "
                         f"got {w_in}.")
    low, limit = amplitude_range(A_range, where)
    n = system.n_dof
    qa = system.coordinate_array(about, "about")
    base = {k: v for k, v in dict(params).items() if k not in (amplitude, frequency)}
    base[amplitude], base[frequency] = 0.0, 1.0
    p = avg._p(base)
    ia, iw = names.index(amplitude), names.index(frequency)
    K = avg.kernels
    k_w = len(ws)

    def stiffness(a, w):
        p[ia], p[iw] = a, w
        G, H = np.empty(n), np.empty((n, n))
        effective(K, qa, p, G, H)
        if np.max(np.abs(G)) > 1e-8 * (1 + np.max(np.abs(H))):
            raise ValueError(
                f"{where}: q={qa.tolist()} is not an equilibrium of the averaged motion at "
                f"{amplitude}={a:g}, {frequency}={w:g} (∂U_eff/∂q = {G.tolist()}); the window "
                "needs an equilibrium for every amplitude.")
        return (H + H.T) / 2

    # M = L Lᵀ and C at A = 0 (M, C do not depend on the drive when the structure holds)
    Ls = np.empty((k_w, n, n))
    Cs = np.zeros((k_w, n, n))
    S0 = np.empty((k_w, n, n))
    for j, w in enumerate(ws):
        H0 = stiffness(0.0, w)
        M = terms(K, qa, p, n)[0]
        Ls[j] = np.linalg.inv(np.linalg.cholesky(M))
        K.damping(qa, p, Cs[j])
        S0[j] = Ls[j] @ H0 @ Ls[j].T
    slow0 = np.max(np.abs(np.linalg.eigvalsh(S0)), axis=-1)
    rates = np.max(np.abs(np.linalg.eigvals(Ls @ Cs @ np.swapaxes(Ls, 1, 2))), axis=-1)

    if _amplitude_scales_fast_forces(avg, amplitude):
        # H₂ from one evaluation at a reference amplitude where A² H₂ is as large as H₀
        # (so that H(A_ref) − H₀ loses no digits)
        S2 = np.empty_like(S0)
        for j, w in enumerate(ws):
            a_ref = 1.0
            for _ in range(2):
                S1 = Ls[j] @ stiffness(a_ref, w) @ Ls[j].T
                S2[j] = (S1 - S0[j]) / a_ref**2
                big = np.max(np.abs(S2[j]))
                if big == 0:
                    break
                a_ref = math.sqrt(max(np.max(np.abs(S0[j])), 1e-300) / big)
        s_lo, s_hi = _concave_roots(S0, S2, limit**2)
        A_lo, A_hi = np.sqrt(s_lo), np.sqrt(s_hi)
        below = A_hi < low                  # the whole window lies below the range
        A_lo[below], A_hi[below] = np.nan, np.nan
    else:
        if not math.isfinite(limit):
            raise ValueError(f"{where}: {amplitude!r} does not only scale the fast forces, so "
                             "the window is searched by root-finding within A_range; pass "
                             "A_range=(0.0, A_high) (the amplitudes to consider, m).")
        A_lo, A_hi = np.full(k_w, np.nan), np.full(k_w, np.nan)
        for j, w in enumerate(ws):
            def margin(a, w=w, j=j):
                S = Ls[j] @ stiffness(a, w) @ Ls[j].T
                return float(np.linalg.eigvalsh(S)[0])

            # the lower edge: 0 where already stable, else the root below the first stable
            # end of [0, low] or [low, high]
            if margin(0.0) >= 0:
                A_lo[j] = 0.0
            elif low > 0 and margin(low) > 0:
                A_lo[j] = scipy.optimize.brentq(margin, 0.0, low, xtol=1e-15 * low,
                                                rtol=4 * np.finfo(float).eps)
            elif margin(limit) > 0:
                A_lo[j] = scipy.optimize.brentq(margin, low, limit, xtol=1e-15 * limit,
                                                rtol=4 * np.finfo(float).eps)
            A_hi[j] = math.inf if np.isfinite(A_lo[j]) else math.nan
        S2 = None
    exists = np.isfinite(A_lo)
    # validity: the slow scale (A = 0 and at the lower edge) and the fast displacement
    slow_edge = np.zeros(k_w)
    amp = np.full(k_w, np.nan)
    for j, w in enumerate(ws):
        if not exists[j]:
            continue
        if S2 is not None:
            S_edge = S0[j] + A_lo[j] ** 2 * S2[j]
        else:
            S_edge = Ls[j] @ stiffness(A_lo[j], w) @ Ls[j].T
        slow_edge[j] = np.max(np.abs(np.linalg.eigvalsh(S_edge)))
        p[ia], p[iw] = A_lo[j], w
        M, _, f, fg, wk = terms(K, qa, p, n)
        amp[j] = max([float(np.linalg.norm(np.linalg.solve(M, fg[k]) * 4 * wk[k], 2))
                      for k in range(len(wk))] + [0.0])
    rate = np.maximum(np.sqrt(np.maximum(slow0, slow_edge)), rates)
    with np.errstate(divide="ignore"):
        ratio = np.where(rate > 0, ws / np.where(rate > 0, rate, 1.0), np.inf)
    error = 1.0 / ratio**2
    fast = ratio >= MIN_FREQUENCY_RATIO
    small = exists & (amp <= MAX_AMPLITUDE_RATIO)
    valid = exists & fast & small
    shape = w_in.shape

    def out(x):
        x = np.asarray(x).reshape(shape)
        return x[()] if x.ndim == 0 else x

    return StabilityWindow(
        omega=out(ws), A_min=out(A_lo), A_max=out(A_hi), method="averaging",
        about=str(avg._wrap(qa).tolist()), order=1, exists=out(exists),
        frequency_ratio=out(ratio), error_estimate=out(error), fast_drive=out(fast),
        small_amplitude=out(small), valid=out(valid))


def _amplitude_scales_fast_forces(avg, amplitude: str) -> bool:
    """True when the parameter ``amplitude`` enters only the fast forces, linearly and
    homogeneously (f = A g(q)): then the averaged stiffness is H₀ + A² H₂ exactly."""
    cache = avg.__dict__.setdefault("_scales_cache", {})
    if amplitude not in cache:
        a = next(s for s in avg.system.parameter_symbols if s.name == amplitude)
        elsewhere = any(a in expr.free_symbols for expr in (
            avg.mass_matrix, avg.slow_potential, avg.damping_matrix))
        linear = all(
            all(sp.simplify(e.xreplace({a: 0})) == 0 and sp.simplify(sp.diff(e, a, 2)) == 0
                for e in f)
            for _, _, f in avg.fast_forces)
        cache[amplitude] = bool(not elsewhere and linear and avg.fast_forces)
    return cache[amplitude]


def _concave_roots(S0, S2, s_limit):
    """Edges (s_lo, s_hi) of {s ≥ 0: λ_min(S0 + s S2) > 0} for a stack of symmetric pencils.

    m(s) = λ_min(S0 + s S2) is concave (the minimum of the linear functions vᵀ(S0 + s S2)v),
    so Newton's method with the slope vᵀ S2 v of the lowest eigenvector converges to the
    lower root monotonically from s = 0 and to the upper root monotonically from any s
    beyond it.  NaN where there is no root in [0, s_limit]; s_hi = inf where S2 ≥ 0 (m
    never falls again).
    """
    k = len(S0)
    eps = np.finfo(float).eps

    def margin(idx, s):
        lam, V = np.linalg.eigh(S0[idx] + s[:, None, None] * S2[idx])
        v = V[..., 0]
        return lam[:, 0], np.einsum("ki,kij,kj->k", v, S2[idx], v)

    def newton(idx, s, direction):
        """Newton from s (m(s) ≤ 0 on the side ``direction`` of the root) for the points idx."""
        root = np.full(len(idx), np.nan)
        active = np.arange(len(idx))
        for _ in range(200):
            if not len(active):
                break
            m, d = margin(idx[active], s[active])
            ok = (d * direction > 0) & np.isfinite(m)
            step = np.where(ok, -m / np.where(ok, d, 1.0), 0.0)
            new = s[active] + step
            # converged: the step is at rounding level, or m has crossed (a rounding-level
            # overshoot; the exact iteration never crosses the root of a concave m)
            done = ok & ((step * direction <= 0) | (np.abs(step) <= 16 * eps * np.abs(new)))
            new = np.where(done & (step * direction <= 0), s[active], new)
            root[active[done]] = new[done]
            alive = ok & ~done & (new >= 0) & (new <= max(s_limit, 0) * 1e6 + 1e-300
                                                if np.isfinite(s_limit) else new < 1e300)
            s[active] = np.where(ok, new, s[active])
            active = active[alive]
        return root

    idx = np.arange(k)
    m0, _ = margin(idx, np.zeros(k))
    s_lo = np.where(m0 >= 0, 0.0, np.nan)
    climb = idx[m0 < 0]
    if len(climb):
        s_lo[climb] = newton(climb, np.zeros(len(climb)), +1)
    s_lo[s_lo > s_limit] = np.nan
    s_hi = np.where(np.isfinite(s_lo), np.inf, np.nan)
    # an upper edge only where S2 has a negative direction (m → −∞)
    scale = np.max(np.abs(S2), axis=(1, 2))
    falls = idx[np.isfinite(s_lo) & (np.linalg.eigvalsh(S2)[:, 0] < -1e-12 * scale)]
    if len(falls):
        s = np.maximum(2 * s_lo[falls], 1e-300)
        for _ in range(2100):                       # double until beyond the upper root
            m, _ = margin(falls, s)
            if np.all(m < 0):
                break
            s = np.where(m < 0, s, 2 * s)
        s_hi[falls] = newton(falls, s, -1)
    return s_lo, s_hi

