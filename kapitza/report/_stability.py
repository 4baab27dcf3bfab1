"""The report's ``map`` section: where the scene's state is stable, the exact (A, ω) map with
its boundaries drawn as curves and the averaging prediction over them (the spot checks on
it are ``_spots``).  It computes through the public API and returns its figure, caption
and tables.

The map is about the state the scene's analyses are about (:attr:`Job.about`): the
upright pendulum gets its exact window in closed form and the error of averaging's;
every other state (the hanging pendulum's resonance tongues, a chain, a user's rig) gets
its boundaries traced as curves by :func:`kapitza.floquet.boundaries`, so that a tongue
thinner than the map's grid step is still drawn whole, never as a staircase of cells or
an island.
"""
from __future__ import annotations

import math

import numpy as np

from ._job import (
    Job,
    SectionResult,
    Skip,
    new_figure,
    no_map_reason,
    pct,
    physics_legend,
    state_name,
    thin,
    upright,
)

#: Relative accuracy to which the report locates where the pendulum's window opens.
ONSET_RTOL = 1e-6
#: The legend's words for a boundary curve's kind (shared/PHYSICS.md: a multiplier at +1
#: bounds a period-T instability, at −1 a period-2T one).
KIND_WORDS = {"T": "period-T boundary (multiplier +1)",
              "2T": "period-2T boundary (multiplier −1)",
              "complex": "boundary of complex multipliers (|μ| = 1 off the real axis)"}


def _window_curves(window):
    """The pendulum's exact window as boundary curves: A_min (a multiplier at +1, stable
    above) and A_max (at −1, stable below), drawn solid by the map figure."""
    from ..results import BoundaryCurves
    lo, hi = (np.atleast_1d(np.asarray(x, float)) for x in (window.A_min, window.A_max))
    acc = np.broadcast_to(np.nan if window.accuracy is None else
                          np.asarray(window.accuracy, float), lo.shape)
    return BoundaryCurves(omega=np.atleast_1d(np.asarray(window.omega, float)),
                          A=np.stack([lo, hi]), accuracy=np.stack([acc, acc]),
                          kind=("T", "2T"), stable_below=np.array([False, True]),
                          about="inverted", tol=math.nan if window.tol is None else window.tol)


def _map_axes(job):
    """The map's A and ω axes: the scene's, or around its drive and state."""
    A0, w0 = job.A, job.omega
    pend = job.pend
    if pend is not None and job.pend_about == "inverted":
        l = pend.l
        lo = 1.3 * pend.omega0             # where averaging and the exact edge part
        w_def = np.geomspace(lo, max(10 * w0, 100 * pend.omega0), 240)
        # down to half the Kapitza limit √(2gl)/ω at the fastest drive: both edges shown
        A_def = np.geomspace(min(0.003 * l, 0.5 * math.sqrt(2 * pend.g * l) / w_def[-1]),
                             2.0 * l, 240)
    elif pend is not None:
        # the hanging pendulum: its first resonance tongues at ω = 2ω0/n, n = 1, 2, 3
        w_def = np.geomspace(0.6 * pend.omega0, max(3.2 * pend.omega0, 1.5 * w0), 240)
        A_def = np.linspace(0.0, max(1.5 * A0, 0.5 * pend.l), 240)
    else:
        A_def = np.linspace(0.0, 4 * A0, 48)
        w_def = np.geomspace(w0 / 6, 3 * w0, 48)
    A = job.axis("stability_map", "A", A_def)
    w = job.axis("stability_map", "omega", w_def)
    if job.quick:
        A, w = thin(A, 60 if pend else 14), thin(w, 60 if pend else 14)
    return A, w


def map_section(job: Job) -> SectionResult:
    if not job.vertical:
        raise Skip(no_map_reason(job))
    A, w = _map_axes(job)
    log_A = bool(A.min() > 0 and A.max() / A.min() > 20)
    if job.pend is not None and job.pend_about == "inverted":
        result, fig, caption = _upright_pendulum_map(job, A, w, log_A)
    else:
        result, fig, caption = _curves_map(job, A, w, log_A)
    job.state["map"] = result
    job.state["log_A"] = log_A
    job.table("stability_map", result.to_dataframe(), "map")
    physics_legend(fig.axes[0])
    job.numbers["map_points"] = int(result.stable.size)
    return SectionResult(job.figure(fig, "stability_map"), caption,
                         [n for n in ("stability_map", "window", "boundaries",
                                      "window_averaging") if n in job.tables])


# -- the upright pendulum: the exact window in closed form ------------------------------------

def exact_window(job, omega):
    """The upright pendulum's exact window at ``omega`` (ascending, ≥ 2 values).

    Undamped: in closed form (Mathieu characteristic values, to 1e-10 relative).  Damped:
    from the boundary curves of :func:`kapitza.floquet.boundaries` — certified to 1e-10
    and seeded at every third frequency — over the map's amplitudes: the damped closed
    form scans A on a fixed grid, which steps over the thin window at low ω (it returns
    no window at scattered frequencies there), and costs ≈ 0.1 s per ω against ≈ 0.01 s.
    A_min is the lowest period-T boundary with the stable side above, A_max the lowest
    period-2T boundary with it below (NaN: none at that ω)."""
    pend = job.pend
    if pend.damping == 0:
        return pend.window(omega)
    from ..floquet import boundaries
    from ..results import StabilityWindow
    A_lo, A_hi = job.state.get("A_range", (1e-4 * pend.l, 2.0 * pend.l))
    curves = boundaries(job.scene.system, job.fixed, job.about, omega=omega,
                        A_range=(A_lo, A_hi), seed_every=3)
    A = np.asarray(curves.A, float).reshape(len(curves.kind), -1)
    below = np.asarray(curves.stable_below, bool)
    kinds = np.asarray(curves.kind)
    edges, accuracy = [], []
    for want, side in (("T", False), ("2T", True)):
        rows = A[(kinds == want) & (below == side)]
        acc = np.asarray(curves.accuracy, float).reshape(A.shape)[(kinds == want) &
                                                                    (below == side)]
        if not rows.size:
            edges.append(np.full(A.shape[1], np.nan))
            accuracy.append(np.full(A.shape[1], np.nan))
            continue
        with np.errstate(invalid="ignore"):
            k = np.where(np.isfinite(rows), rows, np.inf).argmin(axis=0)
        pick = rows[k, np.arange(rows.shape[1])]
        edges.append(pick)
        accuracy.append(acc[k, np.arange(rows.shape[1])])
    lo, hi = edges
    acc = np.fmax(*accuracy)
    none = ~(np.isfinite(lo) & np.isfinite(hi) & (lo < hi))
    # where a curve is not kept (at fast drives its side checks are not resolved in float64:
    # the monodromy is near the identity) the closed form, where it finds a window, is exact
    fill = none
    if fill.any():
        closed = pend.window(np.asarray(omega, float)[fill])
        lo[fill], hi[fill] = closed.A_min, closed.A_max
        acc[fill] = closed.accuracy
        none &= ~fill
    lo, hi = np.where(none, np.nan, lo), np.where(none, np.nan, hi)
    return StabilityWindow(omega=np.asarray(curves.omega, float), A_min=lo, A_max=hi,
                           method="floquet", about="inverted", accuracy=acc, tol=curves.tol,
                           l=pend.l, g=pend.g, damping=pend.damping)


def _upright_pendulum_map(job, A, w, log_A):
    from ..figures import stability_map_figure, window_error_figure
    pend = job.pend
    fine = np.geomspace(w.min(), w.max(), 120 if job.quick else 400)
    result = pend.stability_map(A, w, about="inverted", progress=job.grid_progress)
    job.state["A_range"] = (float(A.min()), float(A.max()))
    exact = exact_window(job, fine)
    job.state["window"] = exact
    avg1 = pend.window(fine, method="averaging", order=1)
    averaging = [avg1]
    if pend.damping == 0:
        averaging.append(pend.window(fine, method="averaging", order=2))
    # the exact edges first, averaging's over them: a broken line that runs along an exact
    # edge stays visible on it (drawn under it, it would be hidden there)
    overlays = [_window_curves(exact), *averaging]
    job.state["overlays"] = overlays
    job.state["curves"] = overlays[0]
    frame = exact.to_dataframe().rename(columns={"A_min": "A_min_exact",
                                                 "A_max": "A_max_exact"})
    frame["A_min_averaging_1"] = np.broadcast_to(avg1.A_min, fine.shape)
    if len(averaging) > 1:
        frame["A_min_averaging_2"] = np.broadcast_to(averaging[1].A_min, fine.shape)
        frame["A_max_averaging_2"] = np.broadcast_to(averaging[1].A_max, fine.shape)
    frame.insert(1, "omega_over_omega0", fine / pend.omega0)
    job.table("window", frame, "map")
    lo, hi = np.asarray(exact.A_min, float), np.asarray(exact.A_max, float)
    # a window on the map: the damped closed form also finds the slivers far above the
    # map's amplitudes at low ω (6 m at ω/ω0 = 0.48); the caption speaks of the map
    ok = np.isfinite(lo) & (lo <= job.state["A_range"][1])
    with np.errstate(invalid="ignore", divide="ignore"):
        rel = np.abs(np.asarray(avg1.A_min) / lo - 1)
    k_lo = int(np.flatnonzero(ok)[0]) if ok.any() else 0
    k_hi = int(np.flatnonzero(ok)[-1]) if ok.any() else -1
    job.numbers.update(A_max_high_frequency=float(hi[k_hi]),
                       averaging_A_min_error_lowest_omega=float(rel[k_lo]),
                       averaging_A_min_error_highest_omega=float(rel[k_hi]))
    how = ("" if pend.damping == 0 else "; damped: traced by kapitza.floquet.boundaries, "
           "to 1e-10 where certified")
    caption = (f"Exact map of the upright pendulum ({result.A.size} × {result.omega.size} "
               f"points, {result.method}, {result.seconds:.2g} s; green: "
               f"stable). The exact window (solid{how}) has a lower, Kapitza edge A_min — a "
               f"period-T boundary, multiplier +1 — and an upper edge A_max — parametric "
               f"resonance, a period-2T boundary, multiplier −1 — at {hi[k_hi] / pend.l:.4f} l "
               f"at ω = {fine[k_hi]:.3g} rad/s. " + _low_frequency_end(job, fine, lo, hi, ok))
    if ok.any():
        caption += (f" First-order averaging (A ω = √(2gl), dotted) has no upper edge, and "
                    f"its lower edge lies {pct(rel[k_hi])} from the exact one at ω/ω0 = "
                    f"{fine[k_hi] / pend.omega0:.3g} but {pct(rel[k_lo])} at ω/ω0 = "
                    f"{fine[k_lo] / pend.omega0:.3g}")
        if len(averaging) > 1:
            err2 = abs(np.asarray(averaging[1].A_min)[k_lo] / lo[k_lo] - 1)
            caption += (f"; the next order (dash-dotted) is {pct(err2)} off there (right: the "
                        f"error falls as (ω0/ω)² and (ω0/ω)⁴).")
        else:
            caption += "."
    fig = new_figure((12.0, 5.4))
    ax = fig.add_subplot(1, 2, 1)
    stability_map_figure(result, overlays=overlays, log_omega=True, log_A=log_A,
                         boundaries=False, ax=ax)
    # the same line for each order as on the map
    window_error_figure(exact, averaging, ax=fig.add_subplot(1, 2, 2), omega0=pend.omega0,
                        styles=(":", "-."))
    return result, fig, caption


def _low_frequency_end(job, fine, lo, hi, ok) -> str:
    """What the page says about the window at low ω, computed: its width at the map's lower
    edge (and whether it narrows towards it), or the frequency where it opens, located by
    bisection; and where the exact window's search returned no window above its onset."""
    pend = job.pend
    if not ok.any():
        return (f"No exact window exists anywhere on the map (ω from {fine[0]:.4g} to "
                f"{fine[-1]:.4g} rad/s).")
    k = int(np.flatnonzero(ok)[0])
    r = fine[k] / pend.omega0
    if k == 0:
        text = (f"At the map's lower edge, ω = {fine[0]:.3g} rad/s (ω/ω0 = {r:.3g}), the "
                f"window is {lo[0]:.3g} m < A < {hi[0]:.3g} m")
        if ok[1] and (hi[0] - lo[0]) / lo[0] < (hi[1] - lo[1]) / lo[1]:
            text += (f", {pct((hi[0] - lo[0]) / lo[0])} of A_min wide and narrowing "
                     "towards lower ω")
        text += "."
    else:
        onset, (lo_e, hi_e) = _window_onset(job, fine[k - 1], fine[k])
        top = job.state["A_range"][1]
        where = (f"ω = {onset:.6g} rad/s (ω/ω0 = {onset / pend.omega0:.4g}, located by "
                 f"bisection to {ONSET_RTOL:g} relative)")
        if hi_e > 0.95 * top:
            text = (f"Below {where} the window lies above the map's highest amplitude, "
                    f"{top:.3g} m: it moves to larger A as ω falls (there it is "
                    f"{lo_e:.4g} m < A < {hi_e:.4g} m).")
        else:
            text = (f"The window opens at {where}, where its edges meet at A ≈ "
                    f"{0.5 * (lo_e + hi_e):.4g} m; below it no amplitude holds the pendulum "
                    "upright.")
    holes = ~ok[k:]
    if holes.any():
        where = fine[k:][holes]
        n = int(holes.sum())
        text += (f" At {n} frequenc{'y' if n == 1 else 'ies'} above that (ω from "
                 f"{where.min():.4g} "
                 f"to {where.max():.4g} rad/s) the exact window's search returned no "
                 "window (gaps in the solid lines): unresolved there, not shown closed.")
    return text


def _window_onset(job, below, above):
    """The lowest ω of the window between ``below`` (no window) and ``above`` (a window),
    by bisection in log ω to :data:`ONSET_RTOL`, and its edges (m) at the upper end of the
    final bracket (they meet where the window opens; near the map's top amplitude where
    it only leaves the map).  Each step
    asks the closed form (undamped) or :func:`kapitza.floquet.window` (damped: certified,
    no amplitude band thinner than its ``min_width`` missed)."""
    pend = job.pend
    if pend.damping == 0:
        def at(omega):
            win = pend.window(omega)
            return float(win.A_min), float(win.A_max)
    else:
        from ..floquet import window

        def at(omega):
            win = window(job.scene.system, job.fixed, job.about, omega=omega,
                         A_range=(0.0, job.state["A_range"][1]))
            return float(np.ravel(win.A_min)[0]), float(np.ravel(win.A_max)[0])
    edges = at(above)
    while above / below - 1 > ONSET_RTOL:
        mid = math.sqrt(below * above)
        lo, hi = at(mid)
        if np.isfinite(lo) and np.isfinite(hi) and lo < hi:
            above, edges = mid, (lo, hi)
        else:
            below = mid
    return above, edges


# -- any other state: boundaries traced as curves ---------------------------------------------

def _kinds_text(curves) -> str:
    kinds = list(curves.kind)
    if not kinds:
        return "no boundary crosses this range"
    counts = {k: kinds.count(k) for k in dict.fromkeys(kinds)}
    return "; ".join(f"{n} {KIND_WORDS[k]}" + ("" if n == 1 else " curves")
                     for k, n in counts.items())


def _narrowest_band(curves):
    """(width in m, ω) of the narrowest band between two neighbouring curves at one ω."""
    A = np.asarray(curves.A, float)
    if A.shape[0] < 2:
        return math.inf, math.nan
    best = (math.inf, math.nan)
    for j, ww in enumerate(np.asarray(curves.omega, float)):
        col = np.sort(A[np.isfinite(A[:, j]), j])
        if col.size >= 2:
            d = np.diff(col)
            if d.min() < best[0]:
                best = (float(d.min()), float(ww))
    return best


#: At most this many one-column features of a map are traced on a finer ω grid.
MAX_LOCAL_SEARCHES = 4


def _one_column_features(result):
    """The interior columns (ω indices) where the map's stability differs from both
    neighbours while they agree: a feature narrower in ω than the grid (a thin tongue
    sampled once), at most :data:`MAX_LOCAL_SEARCHES` of them."""
    stable = np.asarray(result.stable, bool)
    found = []
    for j in range(1, stable.shape[1] - 1):
        left, here, right = stable[:, j - 1], stable[:, j], stable[:, j + 1]
        if np.any((here != left) & (left == right)):
            found.append(j)
    return found[:MAX_LOCAL_SEARCHES]


def _trace_feature(system, fixed, about, low, high, A_range, points=13, zooms=3):
    """The boundary curves of a feature of the map between frequencies ``low`` and ``high``
    (rad/s): traced on ``points`` frequencies seeded at each, zoomed (up to ``zooms``
    times) onto the frequencies where a curve was found until it is drawn at five or more;
    None where no curve is found."""
    from ..floquet import boundaries
    curves = None
    for _ in range(zooms + 1):
        omega = np.geomspace(low, high, points)
        found = boundaries(system, fixed, about, omega=omega, A_range=A_range, seed_every=1)
        A = np.asarray(found.A, float).reshape(len(found.kind), -1)
        defined = np.isfinite(A).any(axis=0)
        if not defined.any():
            return curves
        curves = found
        if defined.sum() >= 5:
            break
        k = np.flatnonzero(defined)
        low, high = omega[max(k[0] - 1, 0)], omega[min(k[-1] + 1, points - 1)]
    return curves


def _curves_map(job, A, w, log_A):
    import pandas as pd

    from ..figures import stability_map_figure
    from ..floquet import boundaries, stability_map
    system, about, fixed = job.scene.system, job.about, job.fixed
    hanging = job.pend is not None           # the pendulum about θ = 0: its Mathieu map
    if hanging:
        result = job.pend.stability_map(A, w, about="hanging", progress=job.grid_progress)
    else:
        result = stability_map(system, fixed, about, A=A, omega=w, progress=job.grid_progress)
    A_range = (float(A.min()), float(A.max()))
    curves = boundaries(system, fixed, about,
                        omega=np.geomspace(w.min(), w.max(), 40 if job.quick else 120),
                        A_range=A_range, seed_every=5 if job.quick else 3)
    job.state["curves"] = curves
    # a tongue narrower in ω than the seeds' spacing is missed by them; where the map shows
    # a feature one column wide (a thin tongue sampled once), its boundaries are traced on
    # a fine ω grid across that column, seeded at every frequency: drawn as curves, not as
    # a one-cell island
    local = [_trace_feature(system, fixed, about, w[j - 1], w[j + 1], A_range)
             for j in _one_column_features(result)]
    local = [c for c in local if c is not None]
    frames = [curves.to_dataframe().assign(search="seeds every few frequencies")]
    frames += [c.to_dataframe().assign(search="across a one-column feature of the map")
               for c in local]
    job.table("boundaries", pd.concat(frames, ignore_index=True), "map")
    # exact curves first, averaging's broken line (dotted: the second overlay) over them, the
    # curves of one-column features last
    overlays = [curves]
    averaging_text = ""
    if hanging:
        averaging_text = (" First-order averaging holds the hanging state at every A and ω "
                          "(U_eff only deepens its well): it cannot see the resonance "
                          "tongues at ω ≈ 2ω0/n, where the drive is not fast against ω0.")
    else:
        from ..averaging import average
        fine = np.geomspace(w.min(), w.max(), 120 if job.quick else 400)
        try:
            avg = average(system).window(fixed, about, omega=fine)
        except ValueError as e:            # e.g. not an equilibrium of the averaged motion
            averaging_text = f" No averaging window: {e}"
        else:
            job.table("window_averaging", avg.to_dataframe(), "map")
            edges = np.concatenate([np.ravel(avg.A_min), np.ravel(avg.A_max)])
            # an edge on the map's border (A_min = 0 at A = 0) would be drawn on the axis,
            # listed in the legend and seen nowhere: only edges strictly inside are drawn
            inside = np.isfinite(edges) & (edges > A.min()) & (edges < A.max())
            if inside.any():
                overlays.append(avg)
                averaging_text = (" The first-order averaging window is dotted, over the "
                                  "exact curves.")
            elif np.all(np.ravel(avg.A_min) <= A.min()) and \
                    np.all(np.ravel(avg.A_max) >= A.max()):
                averaging_text = (" First-order averaging holds the state over the whole "
                                  "map: its window has no edge inside it.")
            else:
                averaging_text = " First-order averaging's window edges lie outside this map."
    overlays += local
    job.state["overlays"] = overlays
    name = f"{state_name(job)} {upright(job)}"
    orbit = "" if job.persists else " (the periodic orbit born from it: the drive moves it)"
    caption = (f"Floquet map of {name}{orbit} ({result.A.size} × {result.omega.size} points, "
               f"{result.method}, {result.seconds:.2g} s; green: stable, "
               f"{int(np.sum(result.stable))} points) with its boundaries traced as curves "
               f"(solid; {_kinds_text(curves)}; {curves.monodromies} monodromies, "
               f"continuation from seed scans, to {curves.tol:g} relative).{averaging_text}")
    if local:
        caption += (f" {len(local)} feature(s) of the map one column wide were traced on a "
                    f"finer ω grid across their column: "
                    + "; ".join(f"{_kinds_text(c)} between ω = {c.omega[0]:.4g} and "
                                f"{c.omega[-1]:.4g} rad/s" for c in local) + ".")
    width, at = _narrowest_band(curves)
    steps = np.diff(np.asarray(result.A, float))
    if np.isfinite(width) and steps.size and width < steps.max():
        caption += (f" The narrowest band between two curves is {width:.2g} m wide (at ω = "
                    f"{at:.4g} rad/s), finer than the map's A step of {steps.max():.2g} m: "
                    "the cells show it in part or not at all, the curves whole.")
    fig = stability_map_figure(result, overlays=overlays, log_omega=True, log_A=log_A,
                               boundaries=False,
                               title=f"Floquet stability of {name}\n({result.method})")
    return result, fig, caption
