"""Where stability changes: smooth margins of a monodromy, and the edges, curves and
adaptively refined maps they give.

Smooth margins
--------------
The flag "stable" of a driven equilibrium jumps; what changes smoothly with the
parameters is the monodromy M.  Stability is lost in one of three ways (the labels of
:data:`kapitza.results.BOUNDARIES`), each the sign change of a smooth function of M's
entries — a *margin* — with a simple root at the boundary:

* ``"T"``: a multiplier reaches +1.  Margin det(M − I) = p(1), p the characteristic
  polynomial; for an undamped (symplectic) M it equals Q(2) = Π(2 − x_k), x = λ + 1/λ.
* ``"2T"``: a multiplier reaches −1.  Margin det(M + I) = p(−1).
* ``"complex"``: a complex pair leaves the unit circle.  Undamped: two roots x of the
  reduced polynomial Q (:func:`reduced_polynomial`) collide on [−2, 2] and leave the
  real axis (a Krein collision), so Q's discriminant Π_(i<j) (x_i − x_j)² changes sign.
  Damped: log|λ| of the leading (complex) pair.

The determinants are evaluated on the balanced monodromy (coordinates q and dq/d(ωt)),
with the first-order error bound d · δ · Π σ_i (δ the entries' error, σ_i the singular
values of M ∓ I but the smallest: ‖adj(M ∓ I)‖₂); so a margin's sign is *certain* where
|g| exceeds its bound.  δ is measured when the caller supplies ``delta`` (kapitza.floquet
compares each monodromy with a second one at 100× the tolerance: the Taylor method's own
error estimate runs 100–1000× above the actual error), else taken from ``err``.

Edges, curves, maps
-------------------
:func:`solve_edges` finds roots of margins in brackets by the Anderson–Björck method
(regula falsi with the retained end's value scaled down, superlinear, the bracket kept),
vectorised over the brackets, each step at least a quarter of the tolerance from the
bracket's ends so that the bracket itself closes: an edge is reported with a bracket
[lo, hi] across which the margin changes sign, and ``accuracy`` = max(A − lo, hi − A)/A
(widened by bound/slope where an end's sign is within the margin's error bound); a
RuntimeWarning says where it is coarser than the tolerance asked (near the identity, at
fast drives, float64 monodromies fix a margin's sign only to ≈ ε (ω/ω0)² relative).
:func:`first_window` brackets the lowest stable interval of amplitudes by a
classification scan, solves its two edges and checks each on both sides (NaN and a
warning where a check fails: never a wrong window); :func:`trace_curves` follows every
stability boundary A_k(ω) over a frequency grid by predictor–corrector continuation,
seeded by scans at every few frequencies and checked on both sides by classification;
:func:`refine_map` computes a map on a coarse grid and subdivides only the cells whose
corners disagree (labels, or the sign of the continuous margin :func:`signed_margin`).

These functions know nothing of how a monodromy is computed: they call
``evaluate(A, omega, analyse)``, which returns a dict with the balanced monodromies
``Mb`` (npts, d, d; M = e^ls · Mb), ``ls``, the error estimates ``err`` (relative to
max(1, ‖Mb‖)), ``undamped`` (∮ tr J dt = 0) and, with ``analyse``, ``stable`` and
``label``.  :mod:`kapitza.floquet` builds it on its Taylor method and exposes
:func:`kapitza.floquet.window`, :func:`kapitza.floquet.boundaries` and
:func:`kapitza.floquet.adaptive_map`.
"""
from __future__ import annotations

import warnings

import numpy as np

__all__ = ["reduced_polynomial", "margin", "signed_margin", "solve_edges", "first_window",
           "trace_curves", "refine_map", "KINDS"]

#: margin kinds by label (kapitza.results.BOUNDARIES): 1 "T", 2 "2T", 3 "complex"
KINDS = {1: "T", 2: "2T", 3: "complex"}


# -- the reduced polynomial of a symplectic monodromy ----------------------------------

def reduced_polynomial(lam, n):
    """Undamped (symplectic) monodromies: the palindromic characteristic polynomial from
    the multipliers ``lam`` (npts, 2n), symmetrised (c_k = c_(2n−k), the projection onto
    the symplectic structure), written as λ^(−n) p(λ) = Q(x), x = λ + 1/λ.

    Returns Q's coefficients (npts, n + 1; ascending, monic) and its roots x (npts, n):
    the equilibrium is stable iff every x is real and in [−2, 2].  The coefficients are
    symmetric functions of the multipliers, accurate to O(ε) where the multipliers
    themselves, near a collision, are only accurate to O(√ε).

    The roots are not taken from these coefficients (:func:`_shifted_roots`): at fast
    drives the monodromy is near the identity, every x clusters just below 2, and Q's
    coefficients in powers of x (sizes up to 4ⁿ) lose the cluster's spread — for 5 links
    at ω = 300 ω0 the companion roots' x − 2 ≈ 1e-4 came out with errors ≈ 1e-4 and the
    wrong sign (a stable classification of an unstable point).
    """
    npts, d = lam.shape
    c = np.zeros((npts, d + 1), dtype=complex)
    c[:, 0] = 1.0
    for j in range(d):
        c[:, 1:] = c[:, 1:] - lam[:, j, None] * c[:, :-1]
    c = c.real
    c = 0.5 * (c + c[:, ::-1])
    # λ^m + λ^(−m) = D_m(x): D_0 = 2, D_1 = x, D_(m+1) = x D_m − D_(m−1)
    D = [np.array([2.0]), np.array([0.0, 1.0])]
    for m in range(2, n + 1):
        D.append(np.concatenate([[0.0], D[-1]]) - np.pad(D[-2], (0, 2)))
    qc = np.zeros((npts, n + 1))
    qc[:, 0] = c[:, n]
    for m in range(1, n + 1):
        qc[:, :m + 1] += c[:, n - m, None] * D[m][None, :]
    return qc, 2.0 + _shifted_roots(lam, n)


def _shifted_roots(lam, n):
    """The roots y = x − 2 = (λ − 1)²/λ of the reduced polynomial, accurate where the
    multipliers cluster at +1 (a monodromy near the identity: a fast drive).

    Each multiplier gives y = (λ − 1)²/λ (relative accuracy ε in λ − 1, where x = λ + 1/λ
    would carry an absolute ε ≈ 1e-16 of 2); λ and its partner 1/λ (λ̄ on the circle)
    give the same y, so the 2n values are matched in nearest pairs and averaged.  The n
    averages are made the roots of a polynomial in y whose coefficients' real parts are
    kept — the projection that makes a root real exactly (LAPACK returns real
    eigenvalues of a real matrix with zero imaginary part) where the multipliers are on
    the circle or real, complex where they form a quadruplet.  In powers of y the
    coefficients are graded (Π y_k ≈ 1e-14 at 5 links, ω = 300 ω0) and each has O(ε)
    relative error, so the small roots keep their few ulps.
    """
    npts, d = lam.shape
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        y = (lam - 1.0) ** 2 / lam
    # nearest pairs, greedily: λ with 1/λ (equal y), or λ with λ̄ (conjugate y ≈ equal)
    dist = np.abs(y[:, :, None] - y[:, None, :])
    dist[:, np.arange(d), np.arange(d)] = np.inf
    dist = np.where(np.isnan(dist), np.inf, dist)
    rows = np.arange(npts)
    pairs = np.zeros((npts, n), dtype=complex)
    for k in range(n):
        flat = np.argmin(dist.reshape(npts, -1), axis=1)
        i, j = np.divmod(flat, d)
        pairs[:, k] = 0.5 * (y[rows, i] + y[rows, j])
        for u in (i, j):
            dist[rows, u, :] = np.inf
            dist[rows, :, u] = np.inf
    # the polynomial Π (y − y_k), real part (ascending coefficients, monic)
    c = np.zeros((npts, n + 1), dtype=complex)        # descending
    c[:, 0] = 1.0
    for k in range(n):
        c[:, 1:] = c[:, 1:] - pairs[:, k, None] * c[:, :-1]
    c = c.real[:, ::-1]                                 # ascending
    roots = np.full((npts, n), np.nan, dtype=complex)
    ok = np.all(np.isfinite(c), axis=1)
    if ok.any():
        comp = np.zeros((int(ok.sum()), n, n))
        comp[:, np.arange(1, n), np.arange(n - 1)] = 1.0
        comp[:, :, n - 1] = -c[ok, :n]
        roots[ok] = np.linalg.eigvals(comp)
    return roots


def poly_eval(qc, x, deriv=0):
    """Σ_k qc[:, k] x^k (or its derivative of order ``deriv``) at each root column of x."""
    k = np.arange(qc.shape[1])
    w = qc.copy()
    for _ in range(deriv):
        w = w[:, 1:] * k[1:w.shape[1] + 1][None, :]
        k = np.arange(w.shape[1])
    return np.sum(w[:, None, :] * x[:, :, None] ** k[None, None, :], axis=2)


def _reduced_roots(Mb):
    """The roots x = λ + 1/λ of symplectic monodromies (npts, d, d), their polynomial Q,
    and Q's absolute error per unit relative error of the entries (at each root)."""
    d = Mb.shape[1]
    if d == 2:
        x = np.trace(Mb, axis1=1, axis2=2)[:, None].astype(complex)
        qc = np.stack([-x[:, 0].real, np.ones(len(Mb))], axis=1)
    else:
        qc, x = reduced_polynomial(np.linalg.eigvals(Mb).astype(complex), d // 2)
    k = np.arange(qc.shape[1])
    size = np.sum(np.abs(qc)[:, None, :] * np.abs(x)[:, :, None] ** k[None, None, :], axis=2)
    return x, qc, d * size


# -- margins -----------------------------------------------------------------------------

def margin(data, kinds):
    """The smooth margins ``kinds`` (labels 1, 2, 3: "T", "2T", "complex"; one per point)
    of the monodromies in ``data`` (see the module docstring), and their error bounds.

    Returns (g, bound): g changes sign, through a simple root, where a boundary of its
    kind is crossed; |g| > bound makes its sign certain.  NaN where the monodromy is not
    finite.
    """
    Mb, ls, err, undamped = data["Mb"], data["ls"], data["err"], data["undamped"]
    kinds = np.broadcast_to(np.asarray(kinds), ls.shape)
    npts, d, _ = Mb.shape
    with np.errstate(over="ignore", invalid="ignore"):
        M = Mb * np.exp(np.minimum(ls, 700.0))[:, None, None]
        # the entries' error: measured (``delta``) or from the error estimate
        delta = data["delta"] if "delta" in data else \
            err * np.maximum(1.0, np.max(np.abs(M), axis=(1, 2)))
    g = np.full(npts, np.nan)
    bound = np.full(npts, np.inf)
    finite = np.all(np.isfinite(M), axis=(1, 2))
    for kind, shift in ((1, 1.0), (2, -1.0)):
        at = np.nonzero((kinds == kind) & finite)[0]
        if at.size:
            X = M[at] - shift * np.eye(d)
            g[at] = np.linalg.det(X)
            sv = np.linalg.svd(X, compute_uv=False)
            # |δ det X| ≤ ‖adj X‖₂ ‖δX‖₂, ‖adj X‖₂ = Π σ_i but the smallest
            bound[at] = d * delta[at] * np.prod(sv[:, :-1], axis=1) \
                + 4 * d * np.finfo(float).eps * np.prod(sv, axis=1)
    at = np.nonzero((kinds == 3) & finite & undamped & (d > 2))[0]
    if at.size:
        g[at], bound[at] = _discriminant(M[at], delta[at])
    at = np.nonzero((kinds == 3) & finite & ~undamped)[0]
    if at.size:
        g[at], bound[at] = _leading_log(M[at], delta[at])
    return g, bound


def _discriminant(M, delta):
    """Π_(i<j) (x_i − x_j)² of the reduced polynomial, with a first-order error bound."""
    x, qc, size = _reduced_roots(M)
    n = x.shape[1]
    eq = delta[:, None] * size                                     # error of Q at each root
    with np.errstate(divide="ignore", invalid="ignore"):
        ex = np.minimum(eq / np.abs(poly_eval(qc, x, 1)),
                        2.0 * np.sqrt(eq / np.abs(poly_eval(qc, x, 2))))
    ex = np.where(np.isfinite(ex), ex, np.inf)
    g = np.ones(len(M))
    terms, errs = [], []
    for i in range(n):
        for j in range(i + 1, n):
            t = ((x[:, i] - x[:, j]) ** 2).real
            e = ex[:, i] + ex[:, j]
            terms.append(t)
            errs.append(2 * np.abs(x[:, i] - x[:, j]) * e + e * e)
            g = g * t
    bound = np.zeros(len(M))
    for k, e in enumerate(errs):
        others = np.ones(len(M))
        for m, t in enumerate(terms):
            if m != k:
                others = others * np.abs(t)
        bound = bound + e * others
    return g, bound


def _leading_log(M, delta):
    """log|λ| of the leading multiplier, with its first-order error (condition number)."""
    import scipy.linalg
    g = np.empty(len(M))
    bound = np.empty(len(M))
    for i, A in enumerate(M):
        w, vl, vr = scipy.linalg.eig(A, left=True, right=True)
        k = int(np.argmax(np.abs(w)))
        cond = np.linalg.norm(vl[:, k]) * np.linalg.norm(vr[:, k]) / max(
            abs(np.vdot(vl[:, k], vr[:, k])), 1e-300)
        g[i] = np.log(abs(w[k]))
        bound[i] = len(A) * cond * delta[i] / max(abs(w[k]), 1e-300)
    return g, bound


def signed_margin(data):
    """A continuous margin of stability: > 0 stable, < 0 unstable, ≈ linear across the
    T and 2T boundaries (for the adaptive maps' refinement and contour lines).

    Undamped: u = the smallest of 2 − |Re x| over the reduced roots x (a root crossing
    ±2: T, 2T) and of (x_i − x_j)²/4 over their pairs (real: > 0; a complex pair
    c ± ib: −b², so a Krein collision crosses 0 linearly too), compressed as
    sign(u) log(1 + |u|) (linear near 0); damped: −max log|λ|.  Roots of modes that do
    not interact may cross on the circle: u touches 0 there without changing sign.
    """
    Mb, ls, undamped = data["Mb"], data["ls"], data["undamped"]
    npts = len(ls)
    s = np.full(npts, np.nan)
    finite = np.all(np.isfinite(Mb), axis=(1, 2))
    calm = undamped & finite & (ls == 0.0)
    at = np.nonzero(calm)[0]
    if at.size:
        x, _, _ = _reduced_roots(Mb[at])
        u = np.min(2.0 - np.abs(x.real), axis=1)
        n = x.shape[1]
        for i in range(n):
            for j in range(i + 1, n):
                u = np.minimum(u, (0.25 * (x[:, i] - x[:, j]) ** 2).real)
        s[at] = np.sign(u) * np.log1p(np.abs(u))
    at = np.nonzero(finite & ~calm)[0]
    if at.size:
        with np.errstate(divide="ignore"):
            top = np.max(np.log(np.abs(np.linalg.eigvals(Mb[at]))), axis=1) + ls[at]
        s[at] = -top
    return s


# -- roots of margins in brackets --------------------------------------------------------

def solve_edges(evaluate, omega, a, b, kinds, rtol, *, ends=None, max_evals=60):
    """Roots of the margins ``kinds`` in the brackets [a, b] at frequencies ``omega``
    (arrays of one length), by the Anderson–Björck method, vectorised over the brackets.

    Each step evaluates the margins of the brackets still open in one call of
    ``evaluate``.  A bracket closes when its width is below ``rtol`` times its ends'
    size, or when the newest point's margin is within its error bound (the rounding
    floor).  ``ends`` = (g(a), bound(a), g(b), bound(b)) when already known.

    Returns (root, accuracy, ok, evaluations): ``accuracy`` is the certified relative
    half-width (see the module docstring); ``ok`` False where the margin did not change
    sign across the bracket or was not finite (root NaN).
    """
    a = np.array(a, float)
    b = np.array(b, float)
    w = np.asarray(omega, float)
    kinds = np.asarray(kinds)
    m = a.size
    evals = 0

    def g_at(x, idx):
        return margin(evaluate(x, w[idx], False), kinds[idx])

    if ends is None:
        both = np.arange(m)
        ga, ea = g_at(a, both)
        gb, eb = g_at(b, both)
        evals += 2 * m
    else:
        ga, ea, gb, eb = (np.array(v, float) for v in ends)
    ra = ga.copy()                      # the margin at a, unweighted
    fa = ga.copy()                      # the Anderson–Björck weighted value at a
    root = np.full(m, np.nan)
    acc = np.full(m, np.nan)
    ok = np.isfinite(ga) & np.isfinite(gb) & (np.sign(ga) * np.sign(gb) < 0)
    # a margin exactly 0 at an end: that end is the root
    for x, g in ((a, ga), (b, gb)):
        hit = (g == 0.0) & ~ok
        root[hit], acc[hit] = x[hit], 0.0
        ok |= hit
    active = ok & np.isnan(root)
    for _ in range(max_evals):
        lo, hi = np.minimum(a, b), np.maximum(a, b)
        size = np.maximum(np.abs(a), np.abs(b))
        closed = active & (hi - lo <= rtol * size)
        if closed.any():
            _close(closed, a, b, ra, gb, ea, eb, root, acc)
            active &= ~closed
        idx = np.nonzero(active)[0]
        if idx.size == 0:
            break
        lo, hi, size = lo[idx], hi[idx], size[idx]
        with np.errstate(divide="ignore", invalid="ignore"):
            c = b[idx] - gb[idx] * (b[idx] - a[idx]) / (gb[idx] - fa[idx])
        c = np.where(np.isfinite(c), c, 0.5 * (lo + hi))
        step = 0.25 * rtol * size       # never closer than this to an end: the bracket closes
        c = np.clip(c, lo + step, hi - step)
        gc, ec = g_at(c, idx)
        evals += idx.size
        bad = ~np.isfinite(gc)
        if bad.any():
            ok[idx[bad]] = False
            active[idx[bad]] = False
        floor = ~bad & (np.abs(gc) <= ec)
        if floor.any():
            # the sign at c is within the margin's error: c is the root to that accuracy
            j = idx[floor]
            with np.errstate(divide="ignore", invalid="ignore"):
                slope = np.abs(gb[j] - ra[j]) / np.abs(b[j] - a[j])
            root[j] = c[floor]
            acc[j] = np.maximum(ec[floor] / slope, step[floor]) / np.abs(c[floor])
            active[j] = False
        go = ~bad & ~floor
        j, c, gc, ec = idx[go], c[go], gc[go], ec[go]
        flip = np.sign(gc) != np.sign(gb[j])
        # the newest point replaces b; b becomes a where the sign changed, else a's value
        # is scaled down (Anderson–Björck)
        jf, jk = j[flip], j[~flip]
        a[jf], fa[jf], ra[jf], ea[jf] = b[jf], gb[jf], gb[jf], eb[jf]
        with np.errstate(divide="ignore", invalid="ignore"):
            scale = 1.0 - gc[~flip] / gb[jk]
        fa[jk] *= np.where(scale > 0, scale, 0.5)
        b[j], gb[j], eb[j] = c, gc, ec
    if active.any():                    # out of evaluations: what the bracket certifies
        _close(active.copy(), a, b, ra, gb, ea, eb, root, acc)
    return root, acc, ok & np.isfinite(root), evals


def _close(which, a, b, ra, gb, ea, eb, root, acc):
    """Close the brackets ``which``: the secant root inside [a, b] and the certified
    half-width, widened by bound/slope at an end whose sign is uncertain."""
    i = np.nonzero(which)[0]
    lo, hi = np.minimum(a[i], b[i]), np.maximum(a[i], b[i])
    with np.errstate(divide="ignore", invalid="ignore"):
        r = b[i] - gb[i] * (b[i] - a[i]) / (gb[i] - ra[i])
        slope = np.abs(gb[i] - ra[i]) / np.abs(b[i] - a[i])
    r = np.where(np.isfinite(r), np.clip(r, lo, hi), 0.5 * (lo + hi))
    half = np.maximum(r - lo, hi - r)
    with np.errstate(divide="ignore", invalid="ignore"):
        unsure = np.where(np.abs(ra[i]) <= ea[i], ea[i] / slope, 0.0)
        unsure = np.maximum(unsure, np.where(np.abs(gb[i]) <= eb[i], eb[i] / slope, 0.0))
    root[i] = r
    acc[i] = (half + np.where(np.isfinite(unsure), unsure, np.inf)) / np.abs(r)


def _bracket_changes(stable, label):
    """Where a classification scan (…, ns) changes between stable and unstable: indices
    i with stable[i] != stable[i + 1], and the label of the unstable end."""
    change = stable[..., :-1] != stable[..., 1:]
    kind = np.where(stable[..., :-1], label[..., 1:], label[..., :-1])
    return change, kind


def _solve_scanned(evaluate, w, lo, hi, kinds, rtol, sub=16):
    """:func:`solve_edges` on brackets from a classification scan; a bracket whose margin
    does not change sign at the fine tolerance (the scan misjudged the kind, or two roots
    lie inside) is rescanned with ``sub`` points and solved once more."""
    root, acc, ok, evals = solve_edges(evaluate, w, lo, hi, kinds, rtol)
    redo = np.nonzero(~ok)[0]
    if redo.size:
        t = np.linspace(0.0, 1.0, sub + 1)
        pts = lo[redo, None] + (hi[redo] - lo[redo])[:, None] * t[None, :]
        data = evaluate(pts.ravel(), np.repeat(w[redo], sub + 1), True)
        evals += pts.size
        st = data["stable"].reshape(pts.shape)
        lab = data["label"].reshape(pts.shape)
        change, kind = _bracket_changes(st, lab)
        for r, k in enumerate(redo):
            hits = np.nonzero(change[r])[0]
            if hits.size == 0:
                continue
            # the change nearest the stable end (the window's side of the bracket)
            h = hits[0] if st[r, 0] else hits[-1]
            rr, aa, oo, ee = solve_edges(evaluate, w[k:k + 1], pts[r, h:h + 1],
                                         pts[r, h + 1:h + 2], kind[r, h:h + 1], rtol)
            evals += ee
            root[k], acc[k], ok[k] = rr[0], aa[0], oo[0]
            kinds[k] = kind[r, h]
    return root, acc, ok, evals


# -- the first window of stabilising amplitudes -----------------------------------------

def first_window(evaluate, omega, grid, rtol, *, side=1e-5):
    """The lowest interval of stabilising amplitudes at each frequency.

    ``grid`` (ns,) or (len(omega), ns): ascending amplitudes of the classification scan
    per ω.  Returns dict(A_min, A_max, accuracy, kind_min, kind_max, evaluations,
    checked): A_min = grid[0] (accuracy 0) where the first scan point is stable;
    A_max = +inf where the scan ends stable; both NaN where no scan point is stable.

    Each solved edge is checked on both sides, at A(1 ∓ η), η = max(``side``,
    4 accuracy), by the sign of :func:`signed_margin` on the margins' (finer)
    monodromies: the window's side must be stable, the other unstable.  Where a check
    fails (the scan mislabelled a point, or an edge's margin did not change sign) or
    an edge was not found although a scan point is stable, both edges are NaN and
    ``checked`` is False, with a RuntimeWarning naming the frequencies — never a wrong
    window.  A RuntimeWarning also names the frequencies whose certified accuracy is
    worse than ``rtol`` (float64 monodromies near the identity: fast drives).
    """
    w = np.atleast_1d(np.asarray(omega, float))
    grid = np.broadcast_to(np.asarray(grid, float), (w.size, np.shape(grid)[-1]))
    ns = grid.shape[1]
    data = evaluate(grid.ravel(), np.repeat(w, ns), True)
    evals = grid.size
    stable = data["stable"].reshape(grid.shape)
    label = data["label"].reshape(grid.shape)
    out = {k: np.full(w.size, np.nan) for k in ("A_min", "A_max", "acc_min", "acc_max")}
    kmin = np.zeros(w.size, dtype=np.int8)
    kmax = np.zeros(w.size, dtype=np.int8)
    lo_br, hi_br = [], []                # (ω index, i): brackets grid[i], grid[i + 1]
    for r in range(w.size):
        s = np.nonzero(stable[r])[0]
        if s.size == 0:
            continue
        i = s[0]
        if i == 0:
            out["A_min"][r], out["acc_min"][r] = grid[r, 0], 0.0
        else:
            lo_br.append((r, i - 1))
            kmin[r] = label[r, i - 1]
        after = np.nonzero(~stable[r, i:])[0]
        if after.size == 0:
            out["A_max"][r], out["acc_max"][r] = np.inf, 0.0
        else:
            j = i + after[0]
            hi_br.append((r, j - 1))
            kmax[r] = label[r, j]
    br = lo_br + hi_br
    if br:
        rows = np.array([r for r, _ in br])
        cols = np.array([i for _, i in br])
        kinds = np.concatenate([kmin[[r for r, _ in lo_br]], kmax[[r for r, _ in hi_br]]])
        root, acc, ok, ev = _solve_scanned(evaluate, w[rows], grid[rows, cols],
                                           grid[rows, cols + 1], kinds, rtol)
        evals += ev
        nlo = len(lo_br)
        out["A_min"][rows[:nlo]], out["acc_min"][rows[:nlo]] = root[:nlo], acc[:nlo]
        out["A_max"][rows[nlo:]], out["acc_max"][rows[nlo:]] = root[nlo:], acc[nlo:]
        kmin[rows[:nlo]], kmax[rows[nlo:]] = kinds[:nlo], kinds[nlo:]
    found = np.any(stable, axis=1)
    checked, ev = _check_edges(evaluate, w, out, side)
    evals += ev
    checked &= ~(np.isnan(out["A_min"]) | np.isnan(out["A_max"]))   # an edge not found
    bad = found & ~checked
    for k in ("A_min", "A_max", "acc_min", "acc_max"):
        out[k][bad] = np.nan
    accuracy = np.fmax(out["acc_min"], out["acc_max"])

    def freq(which):
        return ", ".join(f"{x:.6g}" for x in w[which])

    if bad.any():
        warnings.warn(
            f"window: the edges at ω = {freq(bad)} rad/s failed their check (the side "
            "that should be stable is not, or an edge's margin has no root in the scan's "
            "bracket); they are NaN, not a wrong window.  A finer scan (more scan points, "
            "a smaller A_limit) may resolve them.",
            RuntimeWarning, stacklevel=3)
    coarse = accuracy > rtol
    if coarse.any():
        warnings.warn(
            f"window: at ω = {freq(coarse)} rad/s the edges are certified only to "
            f"{', '.join(f'{a:.2g}' for a in accuracy[coarse])} (relative), coarser than "
            f"tol = {rtol:.2g}: the margins' sign is fixed no better in float64 (monodromies "
            "near the identity at fast drives: the achievable accuracy grows about as ω²).",
            RuntimeWarning, stacklevel=3)
    return dict(A_min=out["A_min"], A_max=out["A_max"], accuracy=accuracy,
                kind_min=kmin, kind_max=kmax, evaluations=evals, checked=checked | ~found)


def _check_edges(evaluate, w, out, side):
    """Per ω, whether every solved edge in ``out`` (A_min, A_max, acc_min, acc_max) has
    its window's side stable and its other side unstable at A(1 ∓ η), η = max(side,
    4 accuracy), by :func:`signed_margin` (> 0 stable); edges at the scan's ends (accuracy
    0: A_min = grid[0], A_max = inf) are not checked.  Returns (ok (m,), evaluations)."""
    ok = np.ones(w.size, dtype=bool)
    x, at, want = [], [], []
    for edge, acc, below_stable in (("A_min", "acc_min", False), ("A_max", "acc_max", True)):
        A, a = out[edge], out[acc]
        solved = np.isfinite(A) & (a > 0)
        r = np.nonzero(solved)[0]
        eta = np.maximum(side, 4.0 * a[r])
        x += [A[r] * (1 - eta), A[r] * (1 + eta)]
        at += [r, r]
        want += [np.full(r.size, below_stable), np.full(r.size, not below_stable)]
    x, at, want = np.concatenate(x), np.concatenate(at), np.concatenate(want)
    if x.size == 0:
        return ok, 0
    with np.errstate(invalid="ignore"):
        stable = signed_margin(evaluate(x, w[at], False)) > 0.0
    np.logical_and.at(ok, at, stable == want)
    return ok, x.size


# -- boundary curves over (A, ω) by continuation ----------------------------------------

def trace_curves(evaluate, omega, grid, rtol, *, seed_every=10, side=1e-6):
    """Every stability boundary A_k(ω) over the frequency grid ``omega`` (ascending).

    1. Seeds: at every ``seed_every``-th frequency (and the last) the amplitudes
       ``grid`` are classified; each change between stable and unstable is solved
       (:func:`solve_edges`) on the margin of the unstable side's kind.
    2. Continuation: from each seed a front steps to the next seed frequency, one
       frequency at a time — predictor: extrapolation of its last points; corrector: a
       bracket around the prediction (widened ×4 until the margin changes sign) solved
       to ``rtol`` — all fronts in one evaluation per step.  An arrival that meets a seed
       of the same kind (to 1e-6) joins the two; a seed that no front reached sends a
       front backwards; fronts that meet nothing go on while the curve still bounds the
       stable region there.  A front stops where its margin has no root near the
       prediction (the curve turns back or leaves the grid).
    3. Every point found is classified at A(1 ∓ ``side``): it is kept (else NaN) where
       exactly the side the seed said is stable.

    Returns dict(A (k, m), accuracy (k, m), kind (k,), stable_below (k,), evaluations);
    a RuntimeWarning names the frequencies where a point's accuracy is coarser than
    ``rtol``.
    """
    w = np.asarray(omega, float)
    grid = np.asarray(grid, float)
    m, ns = w.size, grid.size
    lo_A, hi_A = grid[0], grid[-1]
    cols = np.unique(np.r_[np.arange(0, m, max(1, seed_every)), m - 1])
    data = evaluate(np.tile(grid, cols.size), np.repeat(w[cols], ns), True)
    evals = cols.size * ns
    stable = data["stable"].reshape(cols.size, ns)
    label = data["label"].reshape(cols.size, ns)
    change, kind = _bracket_changes(stable, label)
    rr, ii = np.nonzero(change)
    seeds = []                            # dicts: col, A, acc, kind, below
    if rr.size:
        kinds = kind[rr, ii].copy()
        root, acc, ok, ev = _solve_scanned(evaluate, w[cols[rr]], grid[ii], grid[ii + 1],
                                           kinds, rtol)
        evals += ev
        for k in np.nonzero(ok)[0]:
            seeds.append(dict(col=int(cols[rr[k]]), A=root[k], acc=acc[k], kind=int(kinds[k]),
                              below=bool(stable[rr[k], ii[k]])))
    parent = list(range(len(seeds)))

    def find(u):
        while parent[u] != u:
            parent[u] = parent[parent[u]]
            u = parent[u]
        return u

    points = [(s, seeds[s]["col"], seeds[s]["A"], seeds[s]["acc"]) for s in range(len(seeds))]
    col_pos = {int(c): k for k, c in enumerate(cols)}
    reached = set()                       # seeds a front arrived at (from the left)
    fronts = [(s, +1) for s in range(len(seeds)) if seeds[s]["col"] < m - 1]
    while fronts:
        arrivals, ev = _march(evaluate, w, seeds, fronts, cols, col_pos, lo_A, hi_A, rtol,
                              points)
        evals += ev
        new = []
        loose = []
        for s, direction, col, A, acc in arrivals:
            match = [t for t in range(len(seeds))
                     if seeds[t]["col"] == col and seeds[t]["kind"] == seeds[s]["kind"]
                     and seeds[t]["below"] == seeds[s]["below"]
                     and abs(seeds[t]["A"] - A) <= 1e-6 * abs(A)]
            if match:
                parent[find(match[0])] = find(s)
                if direction > 0:
                    reached.add(match[0])
            else:
                loose.append((s, direction, col, A, acc))
        if loose:
            # no seed here: the front goes on (a new seed of the same curve) only while the
            # curve still bounds the stable region (its stable side is stable)
            x = np.array([A * (1 - side if seeds[s]["below"] else 1 + side)
                          for s, _, _, A, _ in loose])
            on = evaluate(x, w[[c for _, _, c, _, _ in loose]], True)["stable"]
            evals += x.size
            loose = [f for f, keep in zip(loose, on) if keep]
        for s, direction, col, A, acc in loose:
            points.append((s, col, A, acc))
            seeds.append(dict(col=col, A=A, acc=acc, kind=seeds[s]["kind"],
                              below=seeds[s]["below"]))
            parent.append(find(s))
            t = len(seeds) - 1
            if direction > 0:
                reached.add(t)
            else:
                seeds[t]["back"] = True
            if 0 < col < m - 1:
                new.append((t, direction))
        # seeds that no forward front reached send a front backwards (once)
        for t in range(len(seeds)):
            if t not in reached and seeds[t]["col"] > 0 and not seeds[t].get("back"):
                seeds[t]["back"] = True
                new.append((t, -1))
        fronts = new
    found = _assemble(evaluate, w, seeds, find, points, side, evals)
    with np.errstate(invalid="ignore"):
        coarse = np.any(found["accuracy"] > rtol, axis=0)
    if coarse.any():
        warnings.warn(
            f"boundaries: {int(coarse.sum())} of {w.size} frequencies (from ω = "
            f"{w[coarse][0]:.6g} rad/s) have points certified only to "
            f"{np.nanmax(found['accuracy'][:, coarse]):.2g} (relative), coarser than "
            f"tol = {rtol:.2g}: the margins' sign is fixed no better in float64 (monodromies "
            "near the identity at fast drives, ∝ ω²; a tongue's tip, where the curve's A → 0) "
            "— see ``accuracy``.", RuntimeWarning, stacklevel=3)
    return found


def _march(evaluate, w, seeds, fronts, cols, col_pos, lo_A, hi_A, rtol, points):
    """Advance ``fronts`` ((seed, direction)) to their next seed column together; append
    the points found to ``points``; return the arrivals (seed, direction, col, A, acc)."""
    state = []
    for s, direction in fronts:
        k = col_pos[seeds[s]["col"]]          # every seed lies on a seed column
        target = cols[min(k + 1, cols.size - 1)] if direction > 0 else cols[max(k - 1, 0)]
        state.append(dict(seed=s, dir=direction, at=seeds[s]["col"], target=int(target),
                          hist=[(seeds[s]["col"], seeds[s]["A"])], alive=True))
    arrivals = []
    evals = 0
    while True:
        live = [f for f in state if f["alive"]]
        if not live:
            break
        idx = np.array([f["at"] + f["dir"] for f in live])
        kinds = np.array([seeds[f["seed"]]["kind"] for f in live])
        pred, delta = _predict(live, idx, w)
        a, b, ends, found, ev = _bracket(evaluate, w[idx], pred, delta, kinds, lo_A, hi_A)
        evals += ev
        root = np.full(len(live), np.nan)
        acc = np.full(len(live), np.nan)
        if found.any():
            j = np.nonzero(found)[0]
            r, ac, ok, ev = solve_edges(evaluate, w[idx[j]], a[j], b[j], kinds[j], rtol,
                                        ends=tuple(e[j] for e in ends))
            evals += ev
            root[j[ok]], acc[j[ok]] = r[ok], ac[ok]
        for f, i, r, ac in zip(live, idx, root, acc):
            if not np.isfinite(r):
                f["alive"] = False
                continue
            f["at"] = int(i)
            f["hist"] = (f["hist"] + [(int(i), r)])[-3:]
            if i == f["target"]:
                f["alive"] = False
                arrivals.append((f["seed"], f["dir"], int(i), r, ac))
            else:
                points.append((f["seed"], int(i), r, ac))
    return arrivals, evals


def _predict(fronts, idx, w):
    """Predictions of the next amplitude by extrapolating each front's last points in ω,
    and a half-width for the first bracket (a few times the extrapolation's error)."""
    pred = np.empty(len(fronts))
    delta = np.empty(len(fronts))
    for k, (f, i) in enumerate(zip(fronts, idx)):
        h = f["hist"]
        x = np.array([w[j] for j, _ in h])
        y = np.array([A for _, A in h])
        if len(h) == 1:
            pred[k], delta[k] = y[0], 1e-3 * abs(y[0])
            continue
        lin = y[-1] + (y[-1] - y[-2]) * (w[i] - x[-1]) / (x[-1] - x[-2])
        if len(h) == 3:
            # the quadratic through the three points (Lagrange form)
            u = w[i]
            quad = sum(y[j] * np.prod([(u - x[m]) / (x[j] - x[m]) for m in range(3) if m != j])
                       for j in range(3))
            pred[k], delta[k] = quad, 2.0 * abs(quad - lin)
        else:
            pred[k], delta[k] = lin, 0.3 * abs(lin - y[-1])
        delta[k] = max(delta[k], 1e-8 * abs(pred[k]))
    return pred, delta


def _bracket(evaluate, w, pred, delta, kinds, lo_A, hi_A, widen=4.0, tries=8):
    """Brackets [a, b] of a sign change of each margin around its prediction: the points
    pred ± δ, δ widened ×``widen`` until two neighbouring points differ in sign (the
    change nearest the prediction).  Returns (a, b, (g_a, e_a, g_b, e_b), found, evals)."""
    n = pred.size
    xs = [[] for _ in range(n)]
    a = np.full(n, np.nan)
    b = np.full(n, np.nan)
    ends = tuple(np.full(n, np.nan) for _ in range(4))
    found = np.zeros(n, dtype=bool)
    open_ = np.ones(n, dtype=bool)
    evals = 0
    d = delta.copy()
    for _ in range(tries):
        j = np.nonzero(open_)[0]
        if j.size == 0:
            break
        left = np.maximum(pred[j] - d[j], lo_A)
        right = np.minimum(pred[j] + d[j], hi_A)
        x = np.concatenate([left, right])
        g, e = margin(evaluate(x, np.concatenate([w[j], w[j]]), False),
                      np.concatenate([kinds[j], kinds[j]]))
        evals += x.size
        for k, jj in enumerate(j):
            xs[jj] += [(left[k], g[k], e[k]), (right[k], g[k + j.size], e[k + j.size])]
            pts = sorted(set(xs[jj]))
            best = None
            for (x0, g0, e0), (x1, g1, e1) in zip(pts[:-1], pts[1:]):
                if np.isfinite(g0) and np.isfinite(g1) and np.sign(g0) * np.sign(g1) < 0:
                    dist = min(abs(x0 - pred[jj]), abs(x1 - pred[jj]))
                    if best is None or dist < best[0]:
                        best = (dist, x0, x1, g0, e0, g1, e1)
            if best is not None:
                _, a[jj], b[jj], ga, ea, gb, eb = best
                for arr, v in zip(ends, (ga, ea, gb, eb)):
                    arr[jj] = v
                found[jj] = True
                open_[jj] = False
            elif left[k] <= lo_A and right[k] >= hi_A:
                open_[jj] = False
        d[j] *= widen
    return a, b, ends, found, evals


def _assemble(evaluate, w, seeds, find, points, side, evals):
    """Curves from the seeds' components; each point checked on both sides."""
    m = w.size
    roots = sorted({find(s) for s in range(len(seeds))})
    pos = {r: k for k, r in enumerate(roots)}
    A = np.full((len(roots), m), np.nan)
    acc = np.full((len(roots), m), np.nan)
    for s, i, r, ac in points:
        k = pos[find(s)]
        if not (acc[k, i] <= ac):         # a point found twice: the more accurate
            A[k, i], acc[k, i] = r, ac
    for s, sd in enumerate(seeds):
        k = pos[find(s)]
        if not (acc[k, sd["col"]] <= sd["acc"]):
            A[k, sd["col"]], acc[k, sd["col"]] = sd["A"], sd["acc"]
    kind = np.array([seeds[r]["kind"] for r in roots], dtype=np.int8)
    below = np.array([seeds[r]["below"] for r in roots], dtype=bool)
    kk, ii = np.nonzero(np.isfinite(A))
    if kk.size:
        eta = np.maximum(side, 4.0 * acc[kk, ii])
        x = np.concatenate([A[kk, ii] * (1 - eta), A[kk, ii] * (1 + eta)])
        data = evaluate(x, np.concatenate([w[ii], w[ii]]), True)
        evals += x.size
        st_lo, st_hi = np.split(data["stable"], 2)
        good = np.where(below[kk], st_lo & ~st_hi, ~st_lo & st_hi)
        A[kk[~good], ii[~good]] = np.nan
        acc[kk[~good], ii[~good]] = np.nan
    keep = np.any(np.isfinite(A), axis=1)
    order = np.lexsort((np.nanmean(np.where(keep[:, None], A, 0.0), axis=1), kind))
    order = order[keep[order]]
    return dict(A=A[order], accuracy=acc[order], kind=kind[order], stable_below=below[order],
                evaluations=evals)


# -- adaptive maps -----------------------------------------------------------------------

def refine_map(evaluate, A, omega, step, *, guard=0.25):
    """A stability map on the grid A × omega that computes only where it must.

    The grid's every ``step``-th row and column (and the last) are computed first; then,
    level by level, each cell whose corners disagree — in label, in the sign of
    :func:`signed_margin`, or with a corner margin within ``guard`` × the corners'
    spread of zero (a boundary may pass between them) — is split in four, and the new
    corners computed in one call.  The points of a cell that is not split take its
    corners' label and the bilinear interpolation of their margins.

    Returns dict(stable, label, margin (len(A), len(omega)), computed (bool), levels).
    """
    A = np.asarray(A, float)
    w = np.asarray(omega, float)
    nA, nw = A.size, w.size
    label = np.zeros((nA, nw), dtype=np.int8)
    stable = np.zeros((nA, nw), dtype=bool)
    s = np.full((nA, nw), np.nan)
    computed = np.zeros((nA, nw), dtype=bool)

    def compute(ii, jj):
        key = np.unique(np.ravel_multi_index((ii, jj), (nA, nw)))
        key = key[~computed.ravel()[key]]
        if key.size == 0:
            return
        i, j = np.unravel_index(key, (nA, nw))
        data = evaluate(A[i], w[j], True)
        stable[i, j], label[i, j] = data["stable"], data["label"]
        s[i, j] = signed_margin(data)
        computed[i, j] = True

    ia = np.unique(np.r_[np.arange(0, nA, step), nA - 1])
    jw = np.unique(np.r_[np.arange(0, nw, step), nw - 1])
    I, J = np.meshgrid(ia, jw, indexing="ij")
    compute(I.ravel(), J.ravel())
    I0, J0 = np.meshgrid(ia[:-1], jw[:-1], indexing="ij")
    I1, J1 = np.meshgrid(ia[1:], jw[1:], indexing="ij")
    cells = np.stack([I0.ravel(), I1.ravel(), J0.ravel(), J1.ravel()], axis=1)
    levels = 0
    while cells.size:
        i0, i1, j0, j1 = cells.T
        corners = [(i0, j0), (i0, j1), (i1, j0), (i1, j1)]
        lab = np.stack([label[c] for c in corners])
        mar = np.stack([s[c] for c in corners])
        with np.errstate(invalid="ignore"):
            spread = np.max(mar, axis=0) - np.min(mar, axis=0)
            near = np.min(np.abs(mar), axis=0) < guard * spread
        split = (np.any(lab != lab[0], axis=0) | np.any(np.sign(mar) != np.sign(mar[0]), axis=0)
                 | near | np.any(np.isnan(mar), axis=0))
        split &= (i1 - i0 > 1) | (j1 - j0 > 1)
        for c in cells[~split]:
            _fill(c, label, stable, s, computed)
        cells = cells[split]
        if cells.size == 0:
            break
        levels += 1
        i0, i1, j0, j1 = cells.T
        im = np.where(i1 - i0 > 1, (i0 + i1) // 2, i0)
        jm = np.where(j1 - j0 > 1, (j0 + j1) // 2, j0)
        pts_i = np.concatenate([im, im, im, i0, i1])
        pts_j = np.concatenate([j0, jm, j1, jm, jm])
        compute(pts_i, pts_j)
        children = []
        for a0, a1, b0, b1, am, bm in zip(i0, i1, j0, j1, im, jm):
            for r0, r1 in ((a0, am), (am, a1)) if am > a0 else ((a0, a1),):
                for c0, c1 in ((b0, bm), (bm, b1)) if bm > b0 else ((b0, b1),):
                    children.append((r0, r1, c0, c1))
        cells = np.array(children, dtype=np.int64).reshape(-1, 4)
    return dict(stable=stable, label=label, margin=s, computed=computed, levels=levels)


def _fill(cell, label, stable, s, computed):
    """The points of an unsplit cell not computed: its corners' label, bilinear margin."""
    i0, i1, j0, j1 = cell
    if i1 - i0 <= 1 and j1 - j0 <= 1:
        return
    block = ~computed[i0:i1 + 1, j0:j1 + 1]
    if not block.any():
        return
    u = np.linspace(0.0, 1.0, i1 - i0 + 1)[:, None]
    v = np.linspace(0.0, 1.0, j1 - j0 + 1)[None, :]
    bil = ((1 - u) * (1 - v) * s[i0, j0] + (1 - u) * v * s[i0, j1] + u * (1 - v) * s[i1, j0]
           + u * v * s[i1, j1])
    label[i0:i1 + 1, j0:j1 + 1][block] = label[i0, j0]
    stable[i0:i1 + 1, j0:j1 + 1][block] = stable[i0, j0]
    s[i0:i1 + 1, j0:j1 + 1][block] = bil[block]
