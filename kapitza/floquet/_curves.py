"""The stability boundaries A_k(ω) over a frequency grid, by continuation.

:func:`trace_curves` follows every stability boundary over a frequency grid by
predictor–corrector continuation on the smooth margins (:mod:`kapitza.floquet._margins`),
seeded by classification scans at every few frequencies, solved by
:func:`kapitza.floquet._edges.solve_edges`, and checked on both sides by classification.
It calls ``evaluate(A, omega, analyse)`` as :mod:`kapitza.floquet._edges` does, and knows
nothing of how a monodromy is computed.
"""
from __future__ import annotations

import warnings

import numpy as np

from ._edges import MIN_WIDTH, _bracket_changes, _solve_scanned, _spans, solve_edges
from ._frontier import refine_scan, scan_points
from ._margins import margin

__all__ = ["trace_curves"]

# -- boundary curves over (A, ω) by continuation ----------------------------------------

def trace_curves(evaluate, omega, grid, rtol, *, seed_every=10, side=1e-6, min_width=None):
    """Every stability boundary A_k(ω) over the frequency grid ``omega`` (ascending).

    1. Seeds: at every ``seed_every``-th frequency (and the last) the amplitudes
       ``grid`` are classified, stable slivers and unstable gaps between them searched
       for down to ``min_width`` (m; default ``MIN_WIDTH`` × the grid's top;
       :func:`kapitza.floquet._frontier.refine_scan`), and each change between stable
       and unstable is solved (:func:`solve_edges`) on the margin of the unstable
       side's kind.
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

    Returns dict(A (k, m), accuracy (k, m), kind (k,), stable_below (k,), evaluations,
    undecided: per seed frequency (ω, [(a, b), ...]) where a sliver narrower than
    ``min_width`` could not be ruled out); RuntimeWarnings name the frequencies where a
    point's accuracy is coarser than ``rtol``, and the undecided seed intervals.
    """
    w = np.asarray(omega, float)
    grid = np.asarray(grid, float)
    m, ns = w.size, grid.size
    lo_A, hi_A = grid[0], grid[-1]
    cols = np.unique(np.r_[np.arange(0, m, max(1, seed_every)), m - 1])
    data = evaluate(np.tile(grid, cols.size), np.repeat(w[cols], ns), True)
    evals = cols.size * ns
    # slivers (and gaps) between the scan points, searched down to min_width
    width = MIN_WIDTH * max(abs(hi_A), abs(lo_A)) if min_width is None else min_width
    rows, undecided, ev = refine_scan(evaluate, w[cols], np.broadcast_to(grid, (cols.size, ns)),
                                      scan_points(data, (cols.size, ns)), width, lowest=False)
    evals += ev
    brackets = []                         # (row, lower, upper, kind, stable below)
    for r, row in enumerate(rows):
        change, kind = _bracket_changes(row["stable"], row["label"])
        for i in np.nonzero(change)[0]:
            brackets.append((r, row["A"][i], row["A"][i + 1], kind[i], row["stable"][i]))
    seeds = []                            # dicts: col, A, acc, kind, below
    if brackets:
        rr = np.array([b[0] for b in brackets])
        kinds = np.array([b[3] for b in brackets])
        root, acc, ok, ev = _solve_scanned(evaluate, w[cols[rr]],
                                           np.array([b[1] for b in brackets]),
                                           np.array([b[2] for b in brackets]), kinds, rtol)
        evals += ev
        for k in np.nonzero(ok)[0]:
            seeds.append(dict(col=int(cols[rr[k]]), A=root[k], acc=acc[k], kind=int(kinds[k]),
                              below=bool(brackets[k][4])))
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
            loose = [f for f, keep in zip(loose, on, strict=True) if keep]
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
    found["undecided"] = [(float(w[cols[r]]), spans) for r, spans in enumerate(undecided)
                          if spans]
    if found["undecided"]:
        warnings.warn(
            "boundaries: could not decide whether a stable sliver (or an unstable gap) "
            f"narrower than min_width = {width:.2g} m lies between the scan points at seed "
            + "; ".join(f"ω = {om:.6g} rad/s: A in {_spans(sp)} m"
                        for om, sp in found["undecided"][:3])
            + (f" and {len(found['undecided']) - 3} more seed frequencies"
               if len(found["undecided"]) > 3 else "")
            + ": boundaries there may be missing (a window being born or closing); pass a "
            "smaller min_width, or more scan points.", RuntimeWarning, stacklevel=3)
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
        for f, i, r, ac in zip(live, idx, root, acc, strict=True):
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
    for k, (f, i) in enumerate(zip(fronts, idx, strict=True)):
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
    xs: list[list[tuple[float, float, float]]] = [[] for _ in range(n)]
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
            for (x0, g0, e0), (x1, g1, e1) in zip(pts[:-1], pts[1:], strict=True):
                if np.isfinite(g0) and np.isfinite(g1) and np.sign(g0) * np.sign(g1) < 0:
                    dist = min(abs(x0 - pred[jj]), abs(x1 - pred[jj]))
                    if best is None or dist < best[0]:
                        best = (dist, x0, x1, g0, e0, g1, e1)
            if best is not None:
                _, a[jj], b[jj], ga, ea, gb, eb = best
                for arr, v in zip(ends, (ga, ea, gb, eb), strict=True):
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

