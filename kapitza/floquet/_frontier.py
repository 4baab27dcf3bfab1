"""Never silent at the frontier: stable slivers (and unstable gaps) between the scan points
of :func:`kapitza.floquet.window` and :func:`kapitza.floquet.boundaries`, found or ruled
out down to a stated width.

A classification scan sees a stable interval only where a scan point falls inside it.
Near the lowest frequency at which a chain can be held up at all, the window is born
with zero width (Acheson's equal double pendulum: 4e-5 m wide at ω = 12.95 ω0, where the
scan's spacing is 1e-2 m), and a scan alone reports "no window".  :func:`refine_scan`
examines every interval between neighbouring scan points of equal classification on two
pieces of evidence from the scan's own monodromies:

* The signed margin u (:func:`kapitza.floquet._margins.signed_margin`: > 0 stable,
  < 0 unstable; continuous and piecewise smooth — the smallest of the per-root margins
  2 − |x_k|, x = λ + 1/λ, and of the roots' pair terms, log-compressed; kinked where
  the smallest changes).  An interval [a, b] of width w is *cleared* where the chord of
  u, widened by ``SAFETY`` · w · Δ/2 (Δ the larger change of slope between the chord
  and its neighbours' secants) and by u's rounding error, stays on its side of zero.
  Δ w/2 bounds |u − chord| both for a smooth u (curvature c: |u − chord| ≤ c w²/8
  while Δ ≥ c w/2) and for a kink inside [a, b] (slopes s and s + J: |u − chord| ≤
  |J| w/4 while Δ ≥ |J|/2), whatever the neighbours' spacing; ``SAFETY`` = 2 allows
  the curvature to double from the neighbours' secants to the interval.
* A multiplier that crosses the whole stable band within the interval (a root x from
  above 2 to below −2: the single pendulum near ω0, where tr M sweeps from +100 to −100
  between two scan points and the compressed u is a spike its neighbours cannot see):
  then det(M − I) and det(M + I) both change sign across it, and the interval is never
  cleared on u alone.

An interval not cleared is split — at the peak its neighbours' secants predict (where
two linear margins cross: a window's birth between two modes' edges), or, for a
crossing multiplier, halfway between the secant roots of det(M − I) and det(M + I)
(where x = 0 for a linear x), else at its middle — and both halves are examined again,
until a point of the other class is found, every interval is cleared, or the intervals
left are narrower than ``min_width``: those are *undecided*, and the caller says so.
An interval that kept more than half of the one it came from is bisected next, so every
interval at least halves every two rounds.

Guarantee: every stable interval at least ``min_width`` wide between unstable scan
points (and every unstable gap as wide between stable ones) is found, as long as u's
curvature on each interval is within ``SAFETY`` times what the neighbouring secants show
and no two multipliers cross the same threshold ±1 inside one interval.  The search
calls ``evaluate(A, omega, True)`` (classification monodromies: stability, label, and
the margins from the same matrices), a few points per frequency a round, all frequencies
together.
"""
from __future__ import annotations

import numpy as np

from ._margins import signed_margin

__all__ = ["refine_scan", "scan_points", "SAFETY"]

#: how far u's curvature on an interval may exceed what its neighbours' secants show
SAFETY = 2.0
#: intervals split per frequency and round (the most promising first)
PER_ROUND = 4
#: the Taylor method's error estimate over its actual error, at least (measured 100–1000)
ERR_OVERESTIMATE = 100.0
#: rounds of splitting before what is left is undecided
MAX_ROUNDS = 100

_KEYS = ("stable", "label", "u", "e", "gT", "g2T")


def scan_points(data, shape):
    """From a classification ``evaluate(..., True)`` over a (rows, ns) grid: a dict of
    arrays (rows, ns): ``stable``, ``label``, the signed margin ``u``, its error ``e``,
    and ``gT``, ``g2T``: det(M − I), det(M + I)."""
    out = _evidence(data)
    return {k: v.reshape(shape) for k, v in out.items()}


def _evidence(data):
    """The per-point evidence of :func:`scan_points`, flat.

    u's error: the entries' error times the dimension, through the log compression
    (|du/d(raw)| = e^(−|u|)); the entries' error is the Taylor method's estimate ``err``
    (relative to max(1, ‖Mb‖)) over ``ERR_OVERESTIMATE`` (the estimate runs 100–1000×
    above the actual error, :mod:`kapitza.floquet._probe`)."""
    Mb, ls = data["Mb"], np.asarray(data["ls"], float)
    d = Mb.shape[1]
    u = signed_margin(data)
    with np.errstate(over="ignore", invalid="ignore"):
        size = np.maximum(1.0, np.max(np.abs(Mb), axis=(1, 2)))
        e = d * np.asarray(data["err"], float) * size * np.exp(-np.abs(u)) / ERR_OVERESTIMATE
        M = Mb * np.exp(np.minimum(ls, 700.0))[:, None, None]
        finite = np.all(np.isfinite(M), axis=(1, 2))
        gT = np.full(len(ls), np.nan)
        g2T = np.full(len(ls), np.nan)
        if finite.any():
            gT[finite] = np.linalg.det(M[finite] - np.eye(d))
            g2T[finite] = np.linalg.det(M[finite] + np.eye(d))
    return dict(stable=np.asarray(data["stable"], bool), label=np.asarray(data["label"]),
                u=u, e=np.where(np.isfinite(e), e, np.inf), gT=gT, g2T=g2T)


def _examined(stable, lowest):
    """Which intervals (i, i + 1) of one row are examined, and the class looked for:
    ``want`` +1 (a stable point between unstable ones) or −1 (an unstable one between
    stable ones).  ``lowest``: only below the first stable point and inside the first
    stable run (the window); else every interval of equal classification (boundaries)."""
    same = stable[:-1] == stable[1:]
    want = np.where(stable[:-1], -1, 1)
    if lowest:
        s = np.nonzero(stable)[0]
        if s.size:
            f = s[0]
            after = np.nonzero(~stable[f:])[0]
            g = f + after[0] if after.size else stable.size
            i = np.arange(stable.size - 1)
            same &= (i < f) | ((i >= f) & (i < g - 1))
    return same, want


def _bounds(row, want):
    """Per interval: the bound of want · u towards the other class (its largest possible
    value), whether a multiplier crosses the whole band (det(M ∓ I) both change sign),
    the neighbours' secants of u (NaN where none) and the width."""
    A, u, e = row["A"], row["u"], row["e"]
    w = np.diff(A)
    with np.errstate(divide="ignore", invalid="ignore"):
        c = np.diff(u) / w
    left = np.r_[np.nan, c[:-1]]
    right = np.r_[c[1:], np.nan]
    dev = np.fmax(np.abs(c - left), np.abs(right - c))      # NaN only with no neighbour
    dev = np.where(np.isnan(dev), np.inf, dev)
    reach = SAFETY * w * dev / 2 + np.maximum(e[:-1], e[1:])
    towards = np.maximum(want * u[:-1], want * u[1:]) + reach
    towards = np.where(np.isfinite(u[:-1]) & np.isfinite(u[1:]), towards, np.inf)
    flips = [np.sign(g[:-1]) * np.sign(g[1:]) < 0 for g in (row["gT"], row["g2T"])]
    return towards, flips[0] & flips[1], left, right, w


def _proposal(row, left, right, want, crossing, i):
    """Where to split interval i (see the module docstring)."""
    A, u = row["A"], row["u"]
    a, b = A[i], A[i + 1]
    w = b - a
    mid = 0.5 * (a + b)
    if w > 0.5 * row["born"][i]:
        return mid
    if crossing:
        # halfway between where det(M − I) and det(M + I) vanish by linear
        # interpolation: x = 0 for a root x that sweeps the band linearly
        r = [a + w * g[i] / (g[i] - g[i + 1]) for g in (row["gT"], row["g2T"])]
        x = 0.5 * (r[0] + r[1])
    else:
        sl, sr = want * left[i], want * right[i]
        if not (np.isfinite(sl) and np.isfinite(sr) and sl > sr):
            return mid
        # the two secant lines' crossing: the peak of want · u between two linear margins
        x = (want * u[i + 1] - want * u[i] + sl * a - sr * b) / (sl - sr)
    if not np.isfinite(x):
        return mid
    return float(np.clip(x, a + w / 16, b - w / 16))


def refine_scan(evaluate, omega, A, points, min_width, *, lowest=True):
    """Split the intervals of the scans (per row r: amplitudes ``A[r]`` ascending, with
    ``points`` from :func:`scan_points`) that may hide a point of the other class, until
    each is found, cleared, or narrower than ``min_width[r]`` (m; see the module
    docstring).

    Returns (rows, undecided, evaluations): ``rows`` a list of dicts (A and the keys of
    :func:`scan_points`) per row, the scan's points and the new ones, ascending;
    ``undecided`` per row a list of (a, b): intervals left that may still hide a point
    of the other class.
    """
    w = np.atleast_1d(np.asarray(omega, float))
    rows = []
    for r in range(w.size):
        row = {k: np.asarray(points[k][r]) for k in _KEYS}
        row["A"] = np.asarray(A[r], float)
        row["born"] = np.full(row["A"].size - 1, np.inf)
        rows.append(row)
    width = np.broadcast_to(np.asarray(min_width, float), w.size)
    evals = 0
    for _ in range(MAX_ROUNDS):
        xs, at = [], []
        for r, row in enumerate(rows):
            for x in _split_points(row, width[r], lowest):
                xs.append(x)
                at.append(r)
        if not xs:
            break
        xs, at = np.array(xs), np.array(at)
        new = _evidence(evaluate(xs, w[at], True))
        evals += xs.size
        for r in np.unique(at):
            k = np.nonzero(at == r)[0]
            _insert(rows[r], xs[k], {key: v[k] for key, v in new.items()})
    undecided = []
    for row in rows:
        idx, _, _, _, _ = _suspects(row, 0.0, lowest)
        undecided.append([(float(row["A"][i]), float(row["A"][i + 1])) for i in np.sort(idx)])
        del row["born"]
    return rows, undecided, evals


def _suspects(row, min_width, lowest):
    """The intervals of ``row`` not cleared and at least ``min_width`` wide, the most
    promising first (largest bound; crossings first), with what :func:`_proposal`
    needs."""
    empty = np.zeros(0, dtype=int)
    if row["A"].size < 2:
        return empty, None, None, None, None
    same, want = _examined(row["stable"], lowest)
    towards, crossing, left, right, w = _bounds(row, want)
    open_ = same & (~(towards < 0.0) | crossing) & (w >= min_width)
    idx = np.nonzero(open_)[0]
    key = np.where(crossing[idx], np.inf, np.where(np.isnan(towards[idx]), np.inf, towards[idx]))
    idx = idx[np.argsort(-key, kind="stable")]
    return idx, want, left, right, crossing & ~(towards >= 0.0)


def _split_points(row, min_width, lowest):
    """The points to evaluate next in ``row``: at most ``PER_ROUND`` intervals."""
    idx, want, left, right, crossing = _suspects(row, min_width, lowest)
    if idx.size == 0:
        return []
    if lowest and np.any(row["stable"]):
        # the window is the lowest stable interval: the lowest suspects first
        idx = np.sort(idx)
    return [_proposal(row, left, right, want[i], crossing[i], i) for i in idx[:PER_ROUND]]


def _insert(row, x, new):
    """Insert evaluated points into a row, keeping it ascending; the two halves of a
    split interval remember the width they came from."""
    for k in np.argsort(x):
        A = row["A"]
        j = int(np.searchsorted(A, x[k]))
        if j == 0 or j == A.size or A[j] == x[k]:
            continue                    # outside, or already there: nothing to split
        parent = A[j] - A[j - 1]
        row["A"] = np.insert(A, j, x[k])
        for key in _KEYS:
            row[key] = np.insert(row[key], j, new[key][k])
        born = row["born"]
        row["born"] = np.r_[born[:j - 1], parent, parent, born[j:]]
