"""Smooth margins of a monodromy: functions of M's entries that change sign, through a
simple root, where stability is lost.

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
|g| exceeds its bound.  δ is measured when the caller supplies ``delta``
(:class:`kapitza.floquet._probe._Probe` compares each monodromy with a second one at 100×
the tolerance: the Taylor method's own error estimate runs 100–1000× above the actual
error), else taken from ``err``.  :func:`signed_margin` is a continuous margin of either
sign (> 0 stable) for the adaptive maps' refinement and contour lines.

These functions know nothing of how a monodromy is computed: they take a dict with the
balanced monodromies ``Mb`` (npts, d, d; M = e^ls · Mb), ``ls``, the error estimates
``err`` (relative to max(1, ‖Mb‖)), ``undamped`` (∮ tr J dt = 0) and optionally
``delta``.
"""
from __future__ import annotations

import numpy as np

__all__ = ["reduced_polynomial", "poly_eval", "margin", "signed_margin", "KINDS"]

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
    for _ in range(2, n + 1):
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

