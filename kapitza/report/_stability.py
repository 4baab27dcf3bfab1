"""The report's sections on where the upright state is stable: the effective potential
(``potential``), the exact (A, ω) map with the averaging prediction over it (``map``), and
direct simulations at a handful of points on it (``spots``; under a horizontal drive, the
tilted state along A instead).  Each computes through the public API and returns its
figure, caption and tables."""
from __future__ import annotations

import math

import numpy as np

from ._job import (
    GRID_METHOD,
    Job,
    SectionResult,
    Skip,
    new_figure,
    no_map_reason,
    pct,
    thin,
    upright,
)


def potential_section(job: Job) -> SectionResult:
    from ..figures import effective_potential_figure
    pend = job.pend
    if pend is None:
        raise Skip(f"the effective potential figure draws U_eff(θ) of the single pendulum "
                    f"(closed form); this system ({job.scene.spec.rig_name}, "
                    f"{job.scene.system.n_dof} coordinates) has its averaged slow modes in "
                    "the slow-frequency and verification sections instead.")
    import pandas as pd
    A, w = job.A, job.omega
    theta = np.linspace(-0.25 * math.pi, 2.25 * math.pi, 901)
    U = pend.effective_potential(A, w, theta=theta)
    pred = pend.averaged(A, w, warn=False)
    fig = effective_potential_figure(
        theta, U, prediction=pred,
        title=f"Effective potential, A = {A:g} m, ω = {w:g} rad/s, {pend.drive} drive\n"
              "(first-order averaging; filled: stable, open: unstable)")
    job.table("effective_potential", pd.DataFrame({"theta": theta, "U_eff_per_mass": U}),
              "potential")
    rows = []
    for eq in pred.equilibria:
        rows.append({"state": eq.name, "theta": float(eq.theta), "exists": bool(eq.exists),
                     "stable": bool(eq.stable), "omega_slow_averaging": float(eq.omega_slow),
                     "valid": bool(eq.valid)})
    eqs = pd.DataFrame(rows)
    job.table("averaged_equilibria", eqs, "potential", shown="Equilibria of the averaged "
              "motion (first-order averaging; Ω in rad/s)")
    if pend.drive == "vertical":
        inv = pred.inverted
        exact = pend.floquet(A, w, about="inverted")
        near = (theta > 0) & (theta < 2 * math.pi)
        barrier = min(U[near & (theta < math.pi)].max(), U[near & (theta > math.pi)].max())
        depth = barrier - float(pend.effective_potential(A, w, theta=math.pi))
        job.numbers.update(omega_slow_averaging=float(inv.omega_slow),
                           omega_slow_floquet=float(exact.omega_slow))
        caption = (f"At A = {A:g} m and ω = {w:g} rad/s (A/l = {A / pend.l:.3g}, "
                   f"ω/ω0 = {w / pend.omega0:.3g}) averaging makes the upright state θ = π "
                   + (f"a minimum of U_eff, {depth:.3g} J/kg deep (per unit mass); "
                      if bool(inv.stable) else "a maximum of U_eff (not stabilised); ")
                   + f"its slow frequency is Ω = {float(inv.omega_slow):.4g} rad/s by "
                   f"first-order averaging and {float(exact.omega_slow):.4g} rad/s by "
                   f"Floquet analysis (exact, linear): "
                   f"{pct(abs(float(inv.omega_slow) / float(exact.omega_slow) - 1))} apart.")
    else:
        tilt = pred.tilted
        caption = (f"Horizontal drive, A = {A:g} m, ω = {w:g} rad/s: "
                   + (f"the minima of U_eff are tilted to θ* = ±{float(tilt.theta):.4g} rad "
                      f"(cos θ* = 2gl/(Aω)² = {2 * pend.g * pend.l / (A * w) ** 2:.4g}), "
                      f"slow frequency {float(tilt.omega_slow):.4g} rad/s by averaging."
                      if bool(tilt.exists) else
                      "(Aω)² ≤ 2gl: no tilted minimum; the pendulum hangs."))
    return SectionResult(job.figure(fig, "effective_potential"), caption,
                   ["effective_potential", "averaged_equilibria"])


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
    """The map's A and ω axes: the scene's, or around its drive."""
    A0, w0 = job.A, job.omega
    if job.pend is not None:
        l = job.pend.l
        lo = 1.3 * job.pend.omega0             # where averaging and the exact edge part
        w_def = np.geomspace(lo, max(10 * w0, 100 * job.pend.omega0), 240)
        # down to half the Kapitza limit √(2gl)/ω at the fastest drive: both edges shown
        A_def = np.geomspace(min(0.003 * l, 0.5 * math.sqrt(2 * job.pend.g * l) / w_def[-1]),
                             2.0 * l, 240)
    else:
        A_def = np.linspace(0.0, 4 * A0, 48)
        w_def = np.geomspace(w0 / 6, 3 * w0, 48)
    A = job.axis("stability_map", "A", A_def)
    w = job.axis("stability_map", "omega", w_def)
    if job.quick:
        A, w = thin(A, 60 if job.pend else 14), thin(w, 60 if job.pend else 14)
    return A, w


def map_section(job: Job) -> SectionResult:
    from ..figures import legend_below, stability_map_figure, window_error_figure
    if not job.vertical:
        raise Skip(no_map_reason(job))
    A, w = _map_axes(job)
    log_A = bool(A.min() > 0 and A.max() / A.min() > 20)
    fine = np.geomspace(w.min(), w.max(), 120 if job.quick else 400)
    if job.pend is not None:
        pend = job.pend
        result = pend.stability_map(A, w, about="inverted", progress=job.grid_progress)
        exact = pend.window(fine)
        avg1 = pend.window(fine, method="averaging", order=1)
        averaging = [avg1]
        if pend.damping == 0:
            averaging.append(pend.window(fine, method="averaging", order=2))
        overlays = [*averaging, _window_curves(exact)]        # the exact edges drawn on top
        job.state["overlays"] = overlays
        frame = exact.to_dataframe().rename(columns={"A_min": "A_min_exact",
                                                     "A_max": "A_max_exact"})
        frame["A_min_averaging_1"] = np.broadcast_to(avg1.A_min, fine.shape)
        if len(averaging) > 1:
            frame["A_min_averaging_2"] = np.broadcast_to(averaging[1].A_min, fine.shape)
            frame["A_max_averaging_2"] = np.broadcast_to(averaging[1].A_max, fine.shape)
        frame.insert(1, "omega_over_omega0", fine / pend.omega0)
        job.table("window", frame, "map")
        lo, hi = np.asarray(exact.A_min, float), np.asarray(exact.A_max, float)
        ok = np.isfinite(lo)
        rel = np.abs(np.asarray(avg1.A_min) / lo - 1)
        k_lo = int(np.flatnonzero(ok)[0]) if ok.any() else 0       # the lowest ω with a window
        k_hi = int(np.flatnonzero(ok)[-1]) if ok.any() else -1
        job.numbers.update(A_max_high_frequency=float(hi[k_hi]),
                           averaging_A_min_error_lowest_omega=float(rel[k_lo]),
                           averaging_A_min_error_highest_omega=float(rel[k_hi]))
        caption = (f"Exact map of the upright pendulum ({result.A.size} × {result.omega.size} "
                   f"points, {result.method}, {result.seconds:.2g} s; green: "
                   f"stable). The exact window (solid) has a lower, Kapitza edge A_min "
                   f"(a Floquet multiplier at +1) and an upper edge A_max (parametric "
                   f"resonance, multiplier −1; {hi[k_hi] / pend.l:.4f} l at ω = "
                   f"{fine[k_hi]:.3g} rad/s); at the lowest ω with a window, "
                   f"{fine[k_lo]:.3g} rad/s (ω/ω0 = {fine[k_lo] / pend.omega0:.3g}), only "
                   f"{lo[k_lo]:.3g} m < A < {hi[k_lo]:.3g} m is stable. First-order averaging "
                   f"(A ω = √(2gl)) has no upper edge, and its lower edge lies "
                   f"{pct(rel[k_hi])} from the exact one at ω/ω0 = "
                   f"{fine[k_hi] / pend.omega0:.3g} but {pct(rel[k_lo])} at ω/ω0 = "
                   f"{fine[k_lo] / pend.omega0:.3g}"
                   + (f"; the next order is "
                      f"{pct(abs(np.asarray(averaging[1].A_min)[k_lo] / lo[k_lo] - 1))} "
                      f"off there (right: the error falls as (ω0/ω)² and (ω0/ω)⁴)."
                      if len(averaging) > 1 else "."))
    else:
        from ..averaging import average
        from ..floquet import boundaries, stability_map
        system, about, fixed = job.scene.system, job.about, job.fixed
        result = stability_map(system, fixed, about, A=A, omega=w, progress=job.grid_progress)
        curves = boundaries(system, fixed, about,
                            omega=np.geomspace(w.min(), w.max(), 40 if job.quick else 120),
                            A_range=(float(A.min()), float(A.max())))
        avg = average(system).window(fixed, about, omega=fine)
        overlays = [avg, curves]                       # the exact curves drawn on top
        job.state["overlays"] = overlays
        job.state["curves"] = curves
        job.table("boundaries", curves.to_dataframe(), "map")
        job.table("window_averaging", avg.to_dataframe(), "map")
        caption = (f"Floquet map of {job.scene.spec.rig_name} about q = π ({result.A.size} × "
                   f"{result.omega.size} points by monodromy integration, "
                   f"{result.seconds:.2g} s; {int(result.stable.sum())} stable) with the exact "
                   f"boundary curves ({len(curves.kind)} curves: {', '.join(curves.kind)}; "
                   f"{curves.monodromies} monodromies) and the first-order averaging window "
                   f"(dashed).")
    job.state["map"] = result
    job.state["log_A"] = log_A
    job.table("stability_map", result.to_dataframe(), "map")
    if job.pend is not None:
        fig = new_figure((12.0, 5.4))
        ax = fig.add_subplot(1, 2, 1)
        stability_map_figure(result, overlays=overlays, log_omega=True, log_A=log_A,
                             boundaries=False, ax=ax)
        window_error_figure(exact, averaging, ax=fig.add_subplot(1, 2, 2), omega0=pend.omega0)
    else:
        fig = stability_map_figure(result, overlays=overlays, log_omega=True, log_A=log_A,
                                   title=f"Floquet stability of the upright state "
                                         f"{upright(job)}\n({result.method})")
    legend_below(fig.axes[0])
    job.numbers["map_points"] = int(result.stable.size)
    return SectionResult(job.figure(fig, "stability_map"), caption,
                   [n for n in ("stability_map", "window", "boundaries", "window_averaging")
                    if n in job.tables])


def _spot_points(job):
    """A handful of (A, ω) points: inside the window, below it, above it, and where
    first-order averaging and the exact map disagree."""
    result = job.state["map"]
    A_axis, w_axis = result.A, result.omega
    pts = []
    if job.pend is not None:
        pend = job.pend
        ws = np.geomspace(w_axis.min(), w_axis.max(), 7)[1:-1:]
        win = pend.window(ws)
        for w, lo, hi in zip(ws, np.atleast_1d(win.A_min), np.atleast_1d(win.A_max),
                             strict=True):
            if not np.isfinite(lo):
                continue
            for a in (0.6 * lo, math.sqrt(lo * hi), 1.25 * hi):
                if a == math.sqrt(lo * hi) and abs(w / job.omega - 1) < 0.05:
                    continue                      # the scene's own point stands there
                if A_axis.min() <= a <= A_axis.max():
                    pts.append((a, w))
        # where averaging's lower edge is furthest below the exact one: averaging says
        # stable, the exact analysis says it falls
        fine = np.geomspace(w_axis.min(), w_axis.max(), 200)
        ex = pend.window(fine)
        av = pend.window(fine, method="averaging", order=1)
        gap = np.where(np.isfinite(ex.A_min), np.asarray(ex.A_min) - np.asarray(av.A_min), 0)
        score = gap / np.where(np.isfinite(ex.A_min), ex.A_min, 1)
        score[:10] = score[-10:] = 0                     # not on the map's edge
        k = int(np.argmax(score))
        if gap[k] > 0.03 * ex.A_min[k]:
            pts.append((0.5 * (ex.A_min[k] + av.A_min[k]), fine[k]))
        pts.insert(0, (job.A, job.omega))                  # the scene's own drive
    else:
        stable = np.asarray(result.stable)
        for j in np.linspace(0, w_axis.size - 1, 5).round().astype(int)[1:-1]:
            col = A_axis[stable[:, j] & (A_axis > 0)]
            if not col.size:
                continue
            lo, hi = col.min(), col.max()
            for a in (0.6 * lo, math.sqrt(lo * hi), 1.25 * hi):
                if A_axis.min() <= a <= A_axis.max():
                    pts.append((a, w_axis[j]))
    if job.quick:
        pts = pts[::2] + ([pts[-1]] if len(pts) % 2 == 0 else [])
    A = np.array([p[0] for p in pts], float)
    w = np.array([p[1] for p in pts], float)
    return A, w


def _curve_distance(curves, A, w):
    """|A − A_b|/A to the nearest boundary curve at each point's ω (interpolated in log ω);
    NaN without curves, inf where no curve reaches that ω."""
    if curves is None:
        return np.full(np.shape(A), np.nan)
    cw = np.log(np.asarray(curves.omega, float))
    out = np.full(np.shape(A), np.inf)
    for Ak in np.asarray(curves.A, float):
        ok = np.isfinite(Ak)
        if ok.sum() < 2:
            continue
        Ab = np.interp(np.log(w), cw[ok], Ak[ok], left=np.nan, right=np.nan)
        with np.errstate(invalid="ignore"):
            out = np.fmin(out, np.abs(A - Ab) / A)
    return out


#: The shortest spot-check run (s): a weakly unstable upright state (growth rate of
#: order 1/s) must have time to topple a 0.1 rad tilt at any ω.
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
    if job.pend is not None:
        pend = job.pend
        m, runs = _per_frequency(
            lambda a, ww, k: pend.measure_grid(a, ww, math.pi - offset, periods=k,
                                               about="inverted", method=GRID_METHOD,
                                               progress=job.grid_progress), A, w, periods)
        exact = pend.stability_map(np.unique(A), np.unique(w), about="inverted")
        floquet = exact.stable[np.searchsorted(exact.A, A), np.searchsorted(exact.omega, w)]
        win = pend.window(w)
        lo, hi = np.asarray(win.A_min), np.asarray(win.A_max)
        with np.errstate(invalid="ignore"):
            dist = np.nanmin(np.abs(np.stack([A - lo, A - hi])) / A, axis=0)
        avg = A * w >= math.sqrt(2 * pend.g * pend.l)
        extra = {"stable_averaging_1": avg}
    else:
        from ..floquet import floquet_grid
        from ..simulation import measure_grid
        system, about = job.scene.system, job.about
        params = {**job.fixed, "A": A, "omega": w}
        q0 = about + offset * (-1.0) ** np.arange(about.size)
        m, runs = _per_frequency(
            lambda a, ww, k: measure_grid(system, {**job.fixed, "A": a, "omega": ww}, about,
                                          q0, periods=k, method=GRID_METHOD,
                                          progress=job.grid_progress), A, w, periods)
        grid = floquet_grid(system, params, about, progress=job.grid_progress)
        floquet = np.asarray(grid.stable)
        dist = _curve_distance(job.state.get("curves"), A, w)
        # how much the linear instability can grow over the simulated run: a weakly
        # unstable point (growth near 1) need not fall within it
        extra = {"floquet_growth_over_run": np.exp(np.asarray(grid.log_growth) * runs)}
    stayed = np.asarray(m["stayed_up"], bool)
    agree = stayed == floquet
    frame = pd.DataFrame({"A": A, "omega": w, "stayed_up": stayed,
                          "fall_time": m["fall_time"], "periods": runs,
                          "stable_floquet": floquet, "agrees": agree,
                          "max_deviation": m["max_deviation"],
                          "boundary_distance": dist, **extra,
                          "status": m["status"]})
    job.table("spot_checks", frame, "spots", shown="Spot checks (released "
              f"{offset} rad from upright, for {periods} drive periods or {_SPOT_SECONDS:g} s, "
              f"whichever is longer; boundary_distance = "
              "|A − A_edge|/A to the nearest exact edge)")
    overlays = job.state.get("overlays", [])
    fig = spot_check_figure(job.state["map"], A, w, stayed, agree, overlays=overlays,
                            log_omega=True, log_A=job.state.get("log_A", False),
                            title=f"Spot checks by direct simulation on the Floquet map of "
                                  f"the upright state {upright(job)}")
    n_bad = int((~agree).sum())
    job.numbers.update(spot_checks=int(A.size), spot_checks_agreeing=int(agree.sum()))
    caption = (f"{A.size} direct simulations of the full nonlinear equation (DOP853, rtol "
               f"1e-9), released "
               f"{offset} rad from the upright and run {periods} drive periods or "
               f"{_SPOT_SECONDS:g} s, whichever is longer: "
               f"{int(stayed.sum())} stayed up, {int((~stayed).sum())} fell; "
               f"{int(agree.sum())} of {A.size} agree with Floquet analysis"
               + ("." if not n_bad else f" ({n_bad} disagree: see the table"))
    if n_bad:
        d = dist[~agree]
        if np.isfinite(d).any():
            caption += (f"; they lie within {np.nanmax(d[np.isfinite(d)]):.2g} (relative "
                        "in A) of a boundary")
        held = ~agree & stayed
        if held.any():
            caption += (f"; where the simulation stayed up against an unstable Floquet "
                        f"verdict its largest deviation from upright was "
                        f"{np.max(frame.max_deviation[held]):.2g} rad (the band is π/2)")
            if "floquet_growth_over_run" in extra:
                growth = float(np.min(extra["floquet_growth_over_run"][held]))
                caption += (f", although the linearisation grows {growth:.3g}× or more over "
                            f"the run: " + ("the instability saturates nonlinearly, the motion "
                                            "stays bounded near the upright"
                                            if growth > 1e3 else
                                            "the instability is too weak for the run"))
        caption += ")."
    if "stable_averaging_1" in extra:
        fooled = extra["stable_averaging_1"] & ~floquet
        if fooled.any():
            caption += (f" At {int(fooled.sum())} of the points first-order averaging predicts "
                        f"an upright pendulum and the exact analysis does not (above A_max, "
                        f"which averaging cannot see, or between the two lower edges at low "
                        f"ω); the simulation fell at {int((fooled & ~stayed).sum())} of them.")
    return SectionResult(job.figure(fig, "spot_checks"), caption, ["spot_checks"])


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
