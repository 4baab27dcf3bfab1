"""The report's ``spots`` section: direct simulations at a handful of (A, ω) points marked on
the map — on either side of every boundary at a few frequencies, and the scene's own drive —
stayed near the state or left it, against Floquet analysis; under a horizontal drive, the
tilted state along A instead (no map exists to mark)."""
from __future__ import annotations

import math

import numpy as np

from ._job import (
    GRID_METHOD,
    Job,
    SectionResult,
    Skip,
    no_map_reason,
    physics_legend,
    state_name,
    upright,
)


def _crossings(curves, w, lo, hi):
    """The amplitudes (m) where the curves cross frequency ``w``, inside (lo, hi), sorted
    (a curve counts only where it is defined on both sides of ``w``)."""
    cw = np.asarray(curves.omega, float)
    j = int(np.searchsorted(cw, w))
    if not 0 < j < cw.size:
        return []
    found = []
    for Ak in np.asarray(curves.A, float):
        if np.isfinite(Ak[j - 1]) and np.isfinite(Ak[j]):
            f = math.log(w / cw[j - 1]) / math.log(cw[j] / cw[j - 1])
            a = (1 - f) * Ak[j - 1] + f * Ak[j]
            if lo < a < hi:
                found.append(float(a))
    return sorted(found)


def _region_points(edges, lo, hi):
    """One amplitude inside each band between ``edges`` (sorted) within [lo, hi]: its
    geometric middle (arithmetic from 0), the bands at the ends 25 % beyond the edge."""
    if not edges:
        return []
    pts = [0.6 * edges[0] if lo <= 0.6 * edges[0] else 0.5 * (lo + edges[0])]
    for a, b in zip(edges[:-1], edges[1:], strict=True):
        pts.append(math.sqrt(a * b) if a > 0 else 0.5 * (a + b))
    pts.append(min(1.25 * edges[-1], 0.5 * (edges[-1] + hi)))
    return [p for p in pts if lo <= p <= hi and p > 0]


def _spot_points(job):
    """A handful of (A, ω) points: the scene's own drive, and on either side of every
    boundary at a few frequencies (for the upright pendulum also where first-order
    averaging and the exact map disagree)."""
    result = job.state["map"]
    A_axis, w_axis = result.A, result.omega
    pts = []
    pend = job.pend
    if pend is not None and job.pend_about == "inverted":
        exact = job.state["window"]         # the map's exact window, on its fine ω grid
        fine = np.asarray(exact.omega, float)
        ws = np.geomspace(w_axis.min(), w_axis.max(), 7)[1:-1:]
        near = np.abs(np.log(fine)[:, None] - np.log(ws)[None, :]).argmin(axis=0)
        ws = fine[near]
        for w, lo, hi in zip(ws, np.asarray(exact.A_min, float)[near],
                             np.asarray(exact.A_max, float)[near], strict=True):
            if not np.isfinite(lo):
                continue
            for a in (0.6 * lo, math.sqrt(lo * hi), 1.25 * hi):
                if a == math.sqrt(lo * hi) and abs(w / job.omega - 1) < 0.05:
                    continue                      # the scene's own point stands there
                if A_axis.min() <= a <= A_axis.max():
                    pts.append((a, w))
        # where averaging's lower edge is furthest below the exact one: averaging says
        # stable, the exact analysis says it falls
        ex_lo = np.asarray(exact.A_min, float)
        av_lo = np.broadcast_to(np.asarray(pend.window(fine, method="averaging",
                                                       order=1).A_min, float), fine.shape)
        gap = np.where(np.isfinite(ex_lo), ex_lo - av_lo, 0)
        score = gap / np.where(np.isfinite(ex_lo), ex_lo, 1)
        edge = max(1, fine.size // 20)
        score[:edge] = score[-edge:] = 0                     # not on the map's edge
        k = int(np.argmax(score))
        if gap[k] > 0.03 * ex_lo[k]:
            pts.append((0.5 * (ex_lo[k] + av_lo[k]), fine[k]))
    else:
        curves = job.state.get("curves")
        stable = np.asarray(result.stable)
        for j in np.linspace(0, w_axis.size - 1, 5).round().astype(int)[1:-1]:
            ww = float(w_axis[j])
            edges = [] if curves is None else _crossings(curves, ww, A_axis.min(), A_axis.max())
            if edges:
                pts += [(a, ww) for a in _region_points(edges, A_axis.min(), A_axis.max())]
                continue
            if curves is None:                       # no curves: the map's stable rows
                col = A_axis[stable[:, j] & (A_axis > 0)]
                edges = [float(col.min()), float(col.max())] if col.size else []
                pts += [(a, ww) for a in _region_points(edges, A_axis.min(), A_axis.max())]
            else:                                    # one region from edge to edge: its middle
                top, bottom = float(A_axis.max()), float(A_axis.min())
                pts.append((math.sqrt(top * bottom) if bottom > 0 else 0.5 * (top + bottom),
                            ww))
    if job.quick:
        pts = pts[::2] + ([pts[-1]] if len(pts) % 2 == 0 else [])
    pts.insert(0, (job.A, job.omega))                  # the scene's own drive
    A = np.array([p[0] for p in pts], float)
    w = np.array([p[1] for p in pts], float)
    return A, w


def _curve_distance(curves, A, w):
    """|A − A_b|/A to the nearest boundary curve at each point's ω (interpolated in log ω);
    NaN without curves and where no curve reaches that ω (the table says so)."""
    if curves is None:
        return np.full(np.shape(A), np.nan)
    cw = np.log(np.asarray(curves.omega, float))
    out = np.full(np.shape(A), np.nan)
    for Ak in np.asarray(curves.A, float):
        ok = np.isfinite(Ak)
        if ok.sum() < 2:
            continue
        Ab = np.interp(np.log(w), cw[ok], Ak[ok], left=np.nan, right=np.nan)
        with np.errstate(invalid="ignore"):
            out = np.fmin(out, np.abs(A - Ab) / A)
    return out


#: The shortest spot-check run (s): a weakly unstable state (growth rate of order 1/s)
#: must have time to topple a 0.1 rad tilt at any ω.
_SPOT_SECONDS = 8.0


def _per_frequency(run, A, w, periods):
    """``run(A, ω, periods)`` once per distinct ω, each for ``periods`` drive periods or
    :data:`_SPOT_SECONDS`, whichever is longer; the fields the spot checks use, per point,
    and the periods each point ran."""
    out = {"stayed_up": np.zeros(A.shape, bool), "fall_time": np.full(A.shape, np.nan),
           "max_deviation": np.full(A.shape, np.nan), "status": np.full(A.shape, "", object)}
    runs = np.zeros(A.shape, int)
    for ww in np.unique(w):
        sel = w == ww
        k = max(int(periods), math.ceil(_SPOT_SECONDS * ww / (2 * math.pi)))
        m = run(A[sel], np.full(sel.sum(), ww), k)
        out["stayed_up"][sel] = np.asarray(m.stayed_up, bool)
        out["fall_time"][sel] = np.asarray(m.fall_time, float)
        out["max_deviation"][sel] = np.asarray(m.max_deviation, float).reshape(
            int(sel.sum()), -1).max(axis=1)
        out["status"][sel] = np.asarray(m.status).astype(str)
        runs[sel] = k
    out["status"] = out["status"].astype(str)
    return out, runs


def _floquet_at(job, A, w):
    """Floquet analysis at the points (A_i, ω_i): (stable, log|μ|max per period)."""
    system, about = job.scene.system, job.about
    if job.persists:
        from ..floquet import floquet_grid
        grid = floquet_grid(system, {**job.fixed, "A": A, "omega": w}, about,
                            progress=job.grid_progress)
        return np.asarray(grid.stable, bool), np.asarray(grid.log_growth, float)
    # the periodic orbit born from the state
    from ..floquet import stability_map
    uA, uw = np.unique(A), np.unique(w)
    grid = stability_map(system, job.fixed, about, A=uA, omega=uw, progress=job.grid_progress)
    i, j = np.searchsorted(uA, A), np.searchsorted(uw, w)
    return (np.asarray(grid.stable, bool)[i, j],
            np.asarray(grid.log_growth, float)[i, j])


def growth_text(log10_growth: float) -> str:
    """A growth factor given by its log10, as the page writes it: "3.49e+95", or
    "> 1e300" (the factor itself overflows a float)."""
    if not np.isfinite(log10_growth):
        return "n/a"
    if log10_growth > 300:
        return f"10^{log10_growth:.4g} (> 1e300)"
    return f"{10 ** log10_growth:.3g}"


def spots_section(job: Job) -> SectionResult:
    import pandas as pd

    from ..figures import spot_check_figure
    if not job.vertical:
        return _tilt_spots(job)
    if "map" not in job.state:
        raise Skip("the stability map did not finish, and the spot checks are drawn on it.")
    A, w = _spot_points(job)
    periods = int(job.setting("measure", "periods", 400))
    periods = min(periods, 150) if job.quick else periods
    offset = 0.1
    extra = {}
    curves = job.state.get("curves")
    if job.pend is not None:
        pend, which = job.pend, job.pend_about
        centre = math.pi if which == "inverted" else 0.0
        m, runs = _per_frequency(
            lambda a, ww, k: pend.measure_grid(a, ww, centre - offset, periods=k,
                                               about=which, method=GRID_METHOD,
                                               progress=job.grid_progress), A, w, periods)
        exact = pend.stability_map(np.unique(A), np.unique(w), about=which)
        floquet = exact.stable[np.searchsorted(exact.A, A), np.searchsorted(exact.omega, w)]
        dist = _curve_distance(curves, A, w)
        if which == "inverted":
            extra["stable_averaging_1"] = A * w >= math.sqrt(2 * pend.g * pend.l)
    else:
        system, about = job.scene.system, job.about
        q0 = job.release(offset)
        band = job.band()
        m, runs = _per_frequency(
            lambda a, ww, k: measure_grid(system, {**job.fixed, "A": a, "omega": ww}, about,
                                          q0, periods=k, band=band, method=GRID_METHOD,
                                          progress=job.grid_progress), A, w, periods)
        floquet, log_growth = _floquet_at(job, A, w)
        dist = _curve_distance(curves, A, w)
        # how much the linear instability can grow over the simulated run, as log10: a
        # weakly unstable point (near 0) need not fall within it; the factor itself
        # overflows a float beyond 1e308 (a strongly unstable point over a long run)
        extra["floquet_log10_growth_over_run"] = log_growth * runs / math.log(10)
    stayed = np.asarray(m["stayed_up"], bool)
    agree = stayed == floquet
    frame = pd.DataFrame({"A": A, "omega": w, "stayed_up": stayed,
                          "fall_time": m["fall_time"], "periods": runs,
                          "stable_floquet": floquet, "agrees": agree,
                          "max_deviation": m["max_deviation"],
                          "boundary_distance": dist, **extra,
                          "status": m["status"]})
    released = ("0.1 rad" if job.angles.all() else
                "0.1 rad in each angle, 1 % in each other coordinate")
    job.table("spot_checks", frame, "spots", shown=f"Spot checks (released {released} from "
              f"{upright(job)}, for {periods} drive periods or {_SPOT_SECONDS:g} s, "
              f"whichever is longer; boundary_distance = |A − A_edge|/A to the nearest exact "
              "edge, — where no boundary reaches that ω"
              + ("; floquet_log10_growth_over_run: log10 of the linear growth factor over "
                 "the run" if "floquet_log10_growth_over_run" in extra else "") + ")")
    overlays = job.state.get("overlays", [])
    fig = spot_check_figure(job.state["map"], A, w, stayed, agree, overlays=overlays,
                            log_omega=True, log_A=job.state.get("log_A", False),
                            title=f"Spot checks by direct simulation on the Floquet map of "
                                  f"{state_name(job)} {upright(job)}")
    physics_legend(fig.axes[0], None if job.upright_state else {
        "simulation: stayed up": "simulation: stayed near the state",
        "simulation: fell": "simulation: left it"})
    n_bad = int((~agree).sum())
    job.numbers.update(spot_checks=int(A.size), spot_checks_agreeing=int(agree.sum()))
    kept = "stayed up" if job.upright_state else "stayed near it"
    caption = (f"{A.size} direct simulations of the full nonlinear equations (DOP853, rtol "
               f"1e-9), released {released} from {state_name(job)} and run {periods} drive "
               f"periods or {_SPOT_SECONDS:g} s, whichever is longer: "
               f"{int(stayed.sum())} {kept}, {int((~stayed).sum())} left it; "
               f"{int(agree.sum())} of {A.size} agree with Floquet analysis"
               + ("." if not n_bad else f" ({n_bad} disagree: see the table"))
    if n_bad:
        caption += _disagreement_text(frame, dist, agree, stayed, extra)
    if "stable_averaging_1" in extra:
        fooled = extra["stable_averaging_1"] & ~floquet
        if fooled.any():
            caption += (f" At {int(fooled.sum())} of the points first-order averaging predicts "
                        f"an upright pendulum and the exact analysis does not (above A_max, "
                        f"which averaging cannot see, or between the two lower edges at low "
                        f"ω); the simulation fell at {int((fooled & ~stayed).sum())} of them.")
    return SectionResult(job.figure(fig, "spot_checks"), caption, ["spot_checks"])


def measure_grid(*args, **kwargs):
    """:func:`kapitza.simulation.measure_grid` (imported when first used)."""
    from ..simulation import measure_grid as measure
    return measure(*args, **kwargs)


def _disagreement_text(frame, dist, agree, stayed, extra) -> str:
    text = ""
    d = dist[~agree]
    if np.isfinite(d).any():
        text += (f"; they lie within {np.nanmax(d[np.isfinite(d)]):.2g} (relative in A) of a "
                 "boundary")
    held = ~agree & stayed
    if held.any():
        text += (f"; where the simulation stayed against an unstable Floquet verdict its "
                 f"largest deviation was {np.max(frame.max_deviation[held]):.2g} (the band "
                 "is π/2 for an angle)")
        if "floquet_log10_growth_over_run" in extra:
            log10 = float(np.min(extra["floquet_log10_growth_over_run"][held]))
            text += (f", although the linearisation grows {growth_text(log10)}× or more over "
                     f"the run: " + ("the instability saturates nonlinearly, the motion "
                                     "stays bounded near the state" if log10 > 3 else
                                     "the instability is too weak for the run"))
    return text + ")."


def _tilt_spots(job: Job) -> SectionResult:
    """Horizontal drive: the tilt of the slow state, by averaging, the periodic orbit and
    simulation, along A at the scene's ω (no map exists to mark points on)."""
    import pandas as pd

    from ..figures import tilt_figure
    pend, w = job.pend, job.omega
    if pend is None:
        raise Skip(no_map_reason(job))
    A_tilt = math.sqrt(2 * pend.g * pend.l) / w           # (Aω)² = 2gl: the tilt appears
    A = np.geomspace(1.15 * A_tilt, max(4 * A_tilt, 1.5 * job.A), 4 if job.quick else 8)
    pred = pend.averaged(A, w, warn=False).tilted
    theta_avg = np.asarray(pred.theta, float)
    orbit = np.full(A.shape, np.nan)
    orbit_stable = np.zeros(A.shape, bool)
    for i, a in enumerate(A):
        try:
            o = pend.floquet(float(a), w, about="tilted")
            orbit[i], orbit_stable[i] = float(o.q_mean[0]), bool(o.stable)
        except (ValueError, RuntimeError):
            pass
    periods = 150 if job.quick else int(job.setting("measure", "periods", 400))
    m = pend.measure_grid(A, w, theta_avg + 0.05, periods=periods, about="tilted",
                          method=GRID_METHOD, progress=job.grid_progress)
    frame = pd.DataFrame({"A": A, "omega": w, "theta_averaging": theta_avg,
                          "theta_orbit_mean": orbit, "orbit_stable": orbit_stable,
                          "theta_measured_mean": np.asarray(m.mean_angle, float),
                          "stayed_near": np.asarray(m.stayed_up, bool)})
    job.table("tilt_checks", frame, "spots", shown="The tilted state (rad): averaging, the "
              "periodic orbit's period mean, the simulation's time mean")
    fig = tilt_figure(frame, l=pend.l, g=pend.g)
    err = np.nanmax(np.abs(frame.theta_measured_mean - frame.theta_orbit_mean))
    err_avg = np.nanmax(np.abs(frame.theta_averaging - frame.theta_orbit_mean))
    caption = (f"No equilibrium persists under the horizontal drive, so there is no map to "
               f"mark; instead {A.size} simulations along A at ω = {w:g} rad/s, released "
               f"0.05 rad beside the averaged tilt: {int(frame.stayed_near.sum())} stayed near "
               f"it; the measured mean tilt is within {err:.2g} rad of the periodic orbit's "
               f"(Newton shooting), and first-order averaging's tilt within {err_avg:.2g} rad.")
    return SectionResult(job.figure(fig, "tilt_checks"), caption, ["tilt_checks"])
