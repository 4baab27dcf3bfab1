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

u's error bound is first the Taylor method's estimate, which runs far above the actual
error (near a window's edge at fast drives by 1e5 and more); where only it keeps an
interval open, the interval's ends are evaluated again on the margins' finer, paired
monodromies, ``evaluate(A, omega, False)``, and u's error is measured there
(:func:`_measured`).

An interval not cleared is split by three points — the peak its neighbours' secants
predict (where two linear margins cross: a window's birth between two modes' edges;
for a crossing multiplier, halfway between the secant roots of det(M − I) and
det(M + I), where x = 0 for a linear x; else the middle) and the middles on either side
of it, so that every piece is at most half the interval — and the pieces are examined
again, until a point of the other class is found, every interval is cleared, or the
intervals left are narrower than ``min_width``: those are *undecided*, and the caller
says so.

Guarantee: every stable interval at least ``min_width`` wide between unstable scan
points (and every unstable gap as wide between stable ones) is found, as long as u's
curvature on each interval is within ``SAFETY`` times what the neighbouring secants show
and no two multipliers cross the same threshold ±1 inside one interval; an interval it
cannot clear down to ``min_width`` is reported.  The search calls ``evaluate(A, omega,
True)`` (classification monodromies: stability, label, and u from the same roots that
decided the stability), a few points per frequency a round, all frequencies together.
"""
from __future__ import annotations

import numpy as np

from ._margins import signed_margin

__all__ = ["refine_scan", "scan_points", "SAFETY"]

#: how far u's curvature on an interval may exceed what its neighbours' secants show
SAFETY = 2.0
#: intervals split per frequency and round (the lowest, or the most promising, first)
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
    # the classification's own signed margin where it gives one (the same roots that
    # decided "stable"), else from the matrices
    u = np.asarray(data["signed"], float) if "signed" in data else signed_margin(data)
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
    return towards, flips[0] & flips[1], left, right, w, np.maximum(e[:-1], e[1:])


def _state(row, lowest):
    """One row's intervals: examined and not cleared (``open``), those kept open only by
    u's estimated error (``limited``), and what :func:`_peak` needs."""
    same, want = _examined(row["stable"], lowest)
    towards, crossing, left, right, w, floor = _bounds(row, want)
    open_ = same & (~(towards < 0.0) | crossing)
    with np.errstate(invalid="ignore"):     # inf − inf: a point without a monodromy
        limited = open_ & ~crossing & (towards - floor < 0.0)
    return dict(want=want, towards=towards, crossing=crossing & ~(towards >= 0.0),
                left=left, right=right, w=w, open=open_, limited=limited)


def _peak(row, st, i):
    """Where interval i may hide the other class (see the module docstring): the crossing
    of its neighbours' secants of want · u (the peak between two linear margins), or for
    a multiplier sweeping the band halfway between the secant roots of det(M − I) and
    det(M + I) (x = 0 for a linear x), else the middle; kept w/16 inside."""
    A, u, want = row["A"], row["u"], st["want"][i]
    a, b = A[i], A[i + 1]
    w = b - a
    x = 0.5 * (a + b)
    if st["crossing"][i]:
        r = [a + w * g[i] / (g[i] - g[i + 1]) for g in (row["gT"], row["g2T"])]
        x = 0.5 * (r[0] + r[1])
    else:
        sl, sr = want * st["left"][i], want * st["right"][i]
        if np.isfinite(sl) and np.isfinite(sr) and sl > sr:
            x = (want * u[i + 1] - want * u[i] + sl * a - sr * b) / (sl - sr)
    if not np.isfinite(x):
        x = 0.5 * (a + b)
    return float(np.clip(x, a + w / 16, b - w / 16))


def refine_scan(evaluate, omega, A, points, min_width, *, lowest=True):
    """Split the intervals of the scans (per row r: amplitudes ``A[r]`` ascending, with
    ``points`` from :func:`scan_points`) that may hide a point of the other class, until
    each is found, cleared, or narrower than ``min_width[r]`` (m; see the module
    docstring).

    Each round, per row, at most ``PER_ROUND`` open intervals (the lowest first for the
    window, else the most promising) get three points: the predicted peak x and the
    middles of [a, x] and [x, b] — every piece at most half the interval.  All rows'
    points go in one ``evaluate`` call; a row that did not change is settled.

    Returns (rows, undecided, evaluations): ``rows`` a list of dicts (A and the keys of
    :func:`scan_points`) per row, the scan's points and the new ones, ascending;
    ``undecided`` per row a list of (a, b): intervals left that may still hide a point
    of the other class.
    """
    w = np.atleast_1d(np.asarray(omega, float))
    rows = []
    for r in range(w.size):
        row = {k: np.array(points[k][r]) for k in _KEYS}
        row["A"] = np.asarray(A[r], float)
        row["measured"] = np.zeros(row["A"].size, dtype=bool)
        rows.append(row)
    width = np.broadcast_to(np.asarray(min_width, float), w.size)
    evals = 0
    active = [r for r in range(w.size) if rows[r]["A"].size > 1]
    for _ in range(MAX_ROUNDS):
        measure, split = [], []                  # (row, point index), (row, A)
        for r in active:
            row = rows[r]
            st = _state(row, lowest)
            lim = np.nonzero(st["limited"])[0]
            ends = np.unique(np.r_[lim, lim + 1])
            ends = ends[~row["measured"][ends]]
            measure += [(r, int(j)) for j in ends]
            # an interval whose ends are being measured waits for them
            waiting = np.zeros(st["w"].size, dtype=bool)
            waiting[lim] = ~(row["measured"][lim] & row["measured"][lim + 1])
            idx = np.nonzero(st["open"] & ~waiting & (st["w"] >= width[r]))[0]
            if idx.size == 0:
                continue
            if lowest and np.any(row["stable"]):
                idx = np.sort(idx)          # the window is the lowest stable interval
            else:
                key = np.where(st["crossing"][idx], np.inf, np.nan_to_num(st["towards"][idx],
                                                                          nan=np.inf))
                idx = idx[np.argsort(-key, kind="stable")]
            for i in idx[:PER_ROUND]:
                x = _peak(row, st, i)
                split += [(r, 0.5 * (row["A"][i] + x)), (r, x), (r, 0.5 * (x + row["A"][i + 1]))]
        if not measure and not split:
            break
        changed = set()
        if measure:
            at = np.array([r for r, _ in measure])
            x = np.array([rows[r]["A"][j] for r, j in measure])
            fine = signed_margin(evaluate(x, w[at], False))
            evals += x.size
            for k, (r, j) in enumerate(measure):
                _measured(rows[r], j, fine[k])
                changed.add(r)
        if split:
            at = np.array([r for r, _ in split])
            x = np.array([a for _, a in split])
            new = _evidence(evaluate(x, w[at], True))
            evals += x.size
            for rr in np.unique(at):
                mine = np.nonzero(at == rr)[0]
                _insert(rows[rr], x[mine], {key: v[mine] for key, v in new.items()})
                changed.add(int(rr))
        active = sorted(changed)
    undecided: list[list[tuple[float, float]]] = []
    for row in rows:
        if row["A"].size < 2:
            undecided.append([])
            continue
        st = _state(row, lowest)
        undecided.append([(float(row["A"][i]), float(row["A"][i + 1]))
                          for i in np.nonzero(st["open"])[0]])
        del row["measured"]
    return rows, undecided, evals


def _measured(row, j, fine):
    """Point j of ``row`` measured: u from the margins' finer monodromy, its error the
    difference from the classification's (what the coarser monodromy gets wrong bounds
    the finer one's error; the Taylor method's estimate runs far above the actual error —
    near a window's edge at fast drives by 1e5 and more)."""
    err = abs(fine - row["u"][j]) + 16 * np.finfo(float).eps * max(1.0, abs(fine))
    row["u"][j], row["e"][j] = fine, err if np.isfinite(err) else np.inf
    row["measured"][j] = True


def _insert(row, x, new):
    """Insert evaluated points into a row, keeping it ascending (points outside it or
    already in it are dropped)."""
    A = row["A"]
    keep = np.nonzero((x > A[0]) & (x < A[-1]) & ~np.isin(x, A))[0]
    x, first = np.unique(x[keep], return_index=True)
    if x.size == 0:
        return
    src = keep[first]
    order = np.argsort(np.concatenate([A, x]), kind="stable")
    row["A"] = np.concatenate([A, x])[order]
    for key in _KEYS:
        row[key] = np.concatenate([row[key], new[key][src]])[order]
    row["measured"] = np.concatenate([row["measured"], np.zeros(x.size, dtype=bool)])[order]
