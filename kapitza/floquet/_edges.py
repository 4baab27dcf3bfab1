"""Roots of margins in brackets, and the first window of stabilising amplitudes.

:func:`solve_edges` finds roots of the smooth margins (:mod:`kapitza.floquet._margins`)
in brackets by the Anderson–Björck method (regula falsi with the retained end's value
scaled down, superlinear, the bracket kept), vectorised over the brackets, each step at
least a quarter of the tolerance from the bracket's ends so that the bracket itself
closes: an edge is reported with a bracket [lo, hi] across which the margin changes sign,
and ``accuracy`` = max(A − lo, hi − A)/A (widened by bound/slope where an end's sign is
within the margin's error bound); a RuntimeWarning says where it is coarser than the
tolerance asked (near the identity, at fast drives, float64 monodromies fix a margin's
sign only to ≈ ε (ω/ω0)² relative).  :func:`first_window` brackets the lowest stable
interval of amplitudes by a classification scan, searched between its points down to a
stated width (:mod:`kapitza.floquet._frontier`), solves its two edges and checks each on
both sides (status "undecided" and a warning where a check fails: never a wrong window).

These functions know nothing of how a monodromy is computed: they call
``evaluate(A, omega, analyse)``, which returns a dict with the balanced monodromies
``Mb`` (npts, d, d; M = e^ls · Mb), ``ls``, the error estimates ``err`` (relative to
max(1, ‖Mb‖)), ``undamped`` (∮ tr J dt = 0) and, with ``analyse``, ``stable`` and
``label`` (:class:`kapitza.floquet._probe._Probe` on the Taylor method).
"""
from __future__ import annotations

import warnings

import numpy as np

from ._frontier import refine_scan, scan_points
from ._margins import margin, signed_margin

__all__ = ["solve_edges", "first_window"]

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

#: the default resolution of :func:`first_window`: min_width = MIN_WIDTH × the scan's top
MIN_WIDTH = 1e-8


def first_window(evaluate, omega, grid, rtol, *, side=1e-5, min_width=None):
    """The lowest interval of stabilising amplitudes at each frequency.

    ``grid`` (ns,) or (len(omega), ns): ascending amplitudes of the classification scan
    per ω.  Between scan points of equal classification — below the first stable one,
    and inside the first stable run — stable slivers (and unstable gaps) are searched
    down to ``min_width`` (m, per ω or one for all; default ``MIN_WIDTH`` × the scan's
    top) by :func:`kapitza.floquet._frontier.refine_scan`.

    Returns dict(A_min, A_max, accuracy, status, kind_min, kind_max, evaluations,
    checked).  ``status`` per ω: "window" (A_min = grid[0], accuracy 0, where the first
    scan point is stable; A_max = +inf where the scan ends stable), "none" (no stable
    interval at least min_width wide: A_min, A_max NaN) or "undecided" (A_min, A_max an
    envelope of the amplitudes within which the lowest window lies, if there is one;
    accuracy NaN; a RuntimeWarning names the frequencies).

    Each solved edge is checked on both sides, at A(1 ∓ η), η = max(``side``,
    4 accuracy), by the sign of :func:`signed_margin` on the margins' (finer)
    monodromies: the window's side must be stable, the other unstable.  Where a check
    fails (the scan mislabelled a point, or an edge's margin did not change sign) or
    an edge was not found although a point is stable, the status is "undecided" and
    ``checked`` False, with a RuntimeWarning naming the frequencies — never a wrong
    window.  A RuntimeWarning also names the frequencies whose certified accuracy is
    worse than ``rtol`` (float64 monodromies near the identity: fast drives).
    """
    w = np.atleast_1d(np.asarray(omega, float))
    grid = np.broadcast_to(np.asarray(grid, float), (w.size, np.shape(grid)[-1]))
    ns = grid.shape[1]
    data = evaluate(grid.ravel(), np.repeat(w, ns), True)
    evals = grid.size
    width = MIN_WIDTH * grid[:, -1] if min_width is None else \
        np.broadcast_to(np.asarray(min_width, float), w.size)
    rows, undecided, ev = refine_scan(evaluate, w, grid, scan_points(data, grid.shape),
                                      width, lowest=True)
    evals += ev
    out = {k: np.full(w.size, np.nan) for k in ("A_min", "A_max", "acc_min", "acc_max")}
    kmin = np.zeros(w.size, dtype=np.int8)
    kmax = np.zeros(w.size, dtype=np.int8)
    lo_br, hi_br = [], []                # (ω index, lower, upper end): an edge's bracket
    outer = np.full((w.size, 2), np.nan)  # the brackets' outer ends (envelopes)
    for r, row in enumerate(rows):
        A, st, lab = row["A"], row["stable"], row["label"]
        s = np.nonzero(st)[0]
        if s.size == 0:
            continue
        i = s[0]
        if i == 0:
            out["A_min"][r], out["acc_min"][r] = A[0], 0.0
            outer[r, 0] = A[0]
        else:
            lo_br.append((r, A[i - 1], A[i]))
            kmin[r] = lab[i - 1]
            outer[r, 0] = A[i - 1]
        after = np.nonzero(~st[i:])[0]
        if after.size == 0:
            out["A_max"][r], out["acc_max"][r] = np.inf, 0.0
            outer[r, 1] = np.inf
        else:
            j = i + after[0]
            hi_br.append((r, A[j - 1], A[j]))
            kmax[r] = lab[j]
            outer[r, 1] = A[j]
    br = lo_br + hi_br
    if br:
        rr = np.array([b[0] for b in br])
        kinds = np.concatenate([kmin[[b[0] for b in lo_br]], kmax[[b[0] for b in hi_br]]])
        root, acc, ok, ev = _solve_scanned(evaluate, w[rr], np.array([b[1] for b in br]),
                                           np.array([b[2] for b in br]), kinds, rtol)
        evals += ev
        nlo = len(lo_br)
        out["A_min"][rr[:nlo]], out["acc_min"][rr[:nlo]] = root[:nlo], acc[:nlo]
        out["A_max"][rr[nlo:]], out["acc_max"][rr[nlo:]] = root[nlo:], acc[nlo:]
        kmin[rr[:nlo]], kmax[rr[nlo:]] = kinds[:nlo], kinds[nlo:]
    found = np.array([bool(np.any(row["stable"])) for row in rows])
    checked, ev = _check_edges(evaluate, w, out, side)
    evals += ev
    checked &= ~(np.isnan(out["A_min"]) | np.isnan(out["A_max"]))   # an edge not found
    bad = found & ~checked
    open_ = np.array([bool(u_) for u_ in undecided])
    status = np.where(found, "window", "none").astype(object)
    status[bad | open_] = "undecided"
    accuracy = np.fmax(out["acc_min"], out["acc_max"])
    A_min, A_max = out["A_min"].copy(), out["A_max"].copy()
    for k in np.nonzero(status == "undecided")[0]:
        # the envelope: the lowest window, if any, lies in it (the undecided intervals,
        # and the window found: its edges if checked, its brackets' outer ends if not)
        lo = [a for a, _ in undecided[k]]
        hi = [b for _, b in undecided[k]]
        if found[k]:
            lo.append(A_min[k] if checked[k] else outer[k, 0])
            hi.append(A_max[k] if checked[k] else outer[k, 1])
        A_min[k], A_max[k], accuracy[k] = min(lo), max(hi), np.nan
    status = status.astype(str)

    def freq(which):
        return ", ".join(f"{x:.6g}" for x in w[which])

    if bad.any():
        warnings.warn(
            f"window: the edges at ω = {freq(bad)} rad/s failed their check (the side "
            "that should be stable is not, or an edge's margin has no root in the scan's "
            "bracket): status 'undecided', A_min and A_max only bound where the window "
            "lies, not a wrong window.  A finer scan (more scan points, a smaller A_range) "
            "may resolve them.", RuntimeWarning, stacklevel=3)
    sliver = open_ & ~bad
    if sliver.any():
        spans = "; ".join(f"ω = {w[r]:.6g} rad/s: A in {_spans(undecided[r])} m"
                          for r in np.nonzero(sliver)[0])
        warnings.warn(
            f"window: could not decide whether a stable interval (or, inside the window, an "
            f"unstable gap) narrower than min_width lies between the scan points at {spans} "
            "(status 'undecided'; A_min, A_max give the envelope within which the lowest "
            "window lies, if any).  The margin there comes within its curvature of zero: a "
            "window is being born or closing.  Pass a smaller min_width (m), or look with "
            "kapitza.floquet_point at those amplitudes.", RuntimeWarning, stacklevel=3)
    coarse = (status == "window") & (accuracy > rtol)
    if coarse.any():
        warnings.warn(
            f"window: at ω = {freq(coarse)} rad/s the edges are certified only to "
            f"{', '.join(f'{a:.2g}' for a in accuracy[coarse])} (relative), coarser than "
            f"tol = {rtol:.2g}: the margins' sign is fixed no better in float64 (monodromies "
            "near the identity at fast drives: the achievable accuracy grows about as ω²).",
            RuntimeWarning, stacklevel=3)
    return dict(A_min=A_min, A_max=A_max, accuracy=accuracy, status=status,
                kind_min=kmin, kind_max=kmax, evaluations=evals, checked=checked | ~found,
                undecided=undecided)


def _spans(intervals, most=3):
    """Intervals as text: '[a, b]' each, the first ``most``."""
    text = ", ".join(f"[{a:.9g}, {b:.9g}]" for a, b in intervals[:most])
    return text + (f" (and {len(intervals) - most} more intervals)"
                   if len(intervals) > most else "")


def _check_edges(evaluate, w, out, side):
    """Per ω, whether every solved edge in ``out`` (A_min, A_max, acc_min, acc_max) has
    its window's side stable and its other side unstable at A(1 ∓ η), η = max(side,
    4 accuracy), by :func:`signed_margin` (> 0 stable); edges at the scan's ends (accuracy
    0: A_min = grid[0], A_max = inf) are not checked.  Returns (ok (m,), evaluations)."""
    ok = np.ones(w.size, dtype=bool)
    xs, ats, wants = [], [], []
    for edge, acc, below_stable in (("A_min", "acc_min", False), ("A_max", "acc_max", True)):
        A, a = out[edge], out[acc]
        solved = np.isfinite(A) & (a > 0)
        r = np.nonzero(solved)[0]
        eta = np.maximum(side, 4.0 * a[r])
        xs += [A[r] * (1 - eta), A[r] * (1 + eta)]
        ats += [r, r]
        wants += [np.full(r.size, below_stable), np.full(r.size, not below_stable)]
    x, at, want = np.concatenate(xs), np.concatenate(ats), np.concatenate(wants)
    if x.size == 0:
        return ok, 0
    with np.errstate(invalid="ignore"):
        stable = signed_margin(evaluate(x, w[at], False)) > 0.0
    np.logical_and.at(ok, at, stable == want)
    return ok, x.size

