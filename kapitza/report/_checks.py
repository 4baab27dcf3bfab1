"""The report's sections that set the methods against each other: the slow frequency
along A, predicted and measured (``slow``), the verification over a small (A, ω) grid
(``verification``) and what accuracy costs in time (``work_precision``).  Each computes
through the public API and returns its figure, caption and tables."""
from __future__ import annotations

import math

import numpy as np

from ._job import (
    GRID_METHOD,
    Job,
    SectionResult,
    Skip,
    no_map_reason,
    state_name,
    thin,
    upright,
)


def _upright_pendulum(job) -> bool:
    return job.pend is not None and job.pend_about == "inverted"


def _verify(job, A, omega, periods, line):
    """The verification of the scene's state over (A, ω): the undamped upright pendulum's
    own (:meth:`KapitzaPendulum.verify`: both orders of averaging, the fitted order); any
    other state's by :func:`kapitza.verify`, with the band of each coordinate in its unit
    (the damped pendulum too: its closed-form window, which the pendulum's verification
    computes on 200 frequencies for its boundary distances, costs ≈ 0.1 s per ω)."""
    if _upright_pendulum(job) and job.pend.damping == 0:
        return job.pend.verify(A, omega, periods=periods, line=line, method=GRID_METHOD,
                               progress=job.grid_progress)
    from ..verification import verify
    pend = {} if job.pend is None else {"length": job.pend.l, "omega0": job.pend.omega0}
    return verify(job.scene.system, job.fixed, job.about, A=A, omega=omega, periods=periods,
                  band=job.band(), line=False, method=GRID_METHOD,
                  progress=job.grid_progress, **pend)


def _moved_by_the_drive(job) -> str:
    """Why the comparisons about an equilibrium do not apply to a state the drive moves."""
    return (f"verification compares averaging, Floquet analysis and simulation about an "
            f"equilibrium of the driven system, and the drive moves {state_name(job)} "
            f"{upright(job)} (a length on a shaken pivot is pulled by it): its Floquet analysis "
            "is about the periodic orbit born from it, in the map and spot-check sections.")


def _line_amplitudes(job, n):
    """Amplitudes along the scene's ω that the state is stable at."""
    w = job.omega
    if _upright_pendulum(job):
        win = job.pend.window(w)
        lo, hi = float(win.A_min), float(win.A_max)
        if not np.isfinite(lo):
            raise Skip(f"the upright pendulum has no window of stabilising amplitudes at the "
                        f"scene's ω = {w:g} rad/s; choose a faster drive.")
        return np.geomspace(1.03 * lo, 0.97 * hi, n)
    result = job.state.get("map")
    if result is None:
        raise Skip("the stability map did not finish; the slow frequencies are taken "
                    "along its stable amplitudes.")
    j = int(np.argmin(np.abs(np.log(result.omega / w))))
    stable = result.A[np.asarray(result.stable)[:, j]]
    stable = stable[stable > 0]
    if stable.size < 2:
        raise Skip(f"the map has fewer than two stable amplitudes at ω ≈ {result.omega[j]:.4g} "
                    "rad/s; there is no slow oscillation to measure.")
    return np.linspace(stable.min(), stable.max(), n)


def slow_section(job: Job) -> SectionResult:
    import pandas as pd

    from ..figures import slow_frequency_figure
    if not job.vertical:
        return _tilt_slow(job)
    if not job.persists:
        raise Skip(_moved_by_the_drive(job))
    n = 5 if job.quick else 12
    A = _line_amplitudes(job, n)
    w = job.omega
    periods = 300 if job.quick else int(job.setting("verify", "periods", 1000))
    v = _verify(job, A, w, periods, False)
    frame = v.to_dataframe()
    keep = [c for c in frame.columns if c.startswith(("A", "omega", "stable_", "tolerance_"))
            or c in ("simulation_status",)]
    job.table("slow_frequency", frame[keep], "slow")
    fig = slow_frequency_figure(v)
    ref = v.modes("omega_slow_floquet")
    parts = []
    for m, name in (("averaging", "first-order averaging"), ("averaging_2", "next order"),
                    ("simulation", "measured (simulation)")):
        if m not in v.methods:
            continue
        with np.errstate(invalid="ignore", divide="ignore"):
            rel = np.abs(v.modes(f"omega_slow_{m}") / ref - 1)
        if np.isfinite(rel).any():
            parts.append(f"{name} {np.nanmedian(rel):.2g} (largest {np.nanmax(rel):.2g})")
            job.numbers[f"slow_median_error_{m}"] = float(np.nanmedian(rel))
    shown = pd.DataFrame({"A (m)": np.ravel(v.A)})
    for m in v.methods:
        x = v.modes(f"omega_slow_{m}")
        for k in range(x.shape[-1]):
            shown[f"Ω {m}" + (f" mode {k}" if x.shape[-1] > 1 else "")] = x[..., k]
    job.shown.setdefault("slow", []).append((f"Ω (rad/s) along A at ω = {w:g} rad/s", shown))
    caption = (f"Slow frequency Ω of {state_name(job)} along A at ω = {w:g} rad/s "
               f"({A.size} amplitudes across the stable range, simulations of {periods} "
               f"periods from a release 0.01 off it). Relative difference from "
               f"Floquet (exact, linear), median: " + "; ".join(parts) + ".")
    with np.errstate(invalid="ignore", divide="ignore"):
        rel1 = np.abs(v.modes("omega_slow_averaging") / ref - 1).max(axis=-1)
        ratio = np.nanmax(ref, axis=-1) / w
    if np.isfinite(rel1).sum() >= 2:
        k = int(np.nanargmax(rel1))
        caption += (f" First-order averaging is furthest off ({rel1[k]:.2g}) at A = "
                    f"{np.ravel(v.A)[k]:.3g} m, where Ω/ω = {ratio[k]:.2g}: the slow motion is "
                    f"no longer slow against the drive.")
    return SectionResult(job.figure(fig, "slow_frequency"), caption, ["slow_frequency"])


def _tilt_slow(job: Job) -> SectionResult:
    import pandas as pd

    from ..figures import slow_frequency_line_figure
    pend, w = job.pend, job.omega
    if pend is None:
        raise Skip(no_map_reason(job))
    A_tilt = math.sqrt(2 * pend.g * pend.l) / w
    A = np.geomspace(1.15 * A_tilt, max(4 * A_tilt, 1.5 * job.A), 4 if job.quick else 8)
    avg = np.asarray(pend.averaged(A, w, warn=False).tilted.omega_slow, float)
    orbit = np.full(A.shape, np.nan)
    for i, a in enumerate(A):
        try:
            orbit[i] = float(np.max(pend.floquet(float(a), w, about="tilted").omega_slow))
        except (ValueError, RuntimeError):
            pass
    theta = np.asarray(pend.averaged(A, w, warn=False).tilted.theta, float)
    periods = 300 if job.quick else 1000
    m = pend.measure_grid(A, w, theta + 0.01, periods=periods, about="tilted",
                          method=GRID_METHOD, progress=job.grid_progress, observables="omega_slow")
    measured = np.where(np.asarray(m.stayed_up, bool), np.asarray(m.omega_slow, float), np.nan)
    frame = pd.DataFrame({"A": A, "omega": w, "omega_slow_averaging": avg,
                          "omega_slow_orbit": orbit, "omega_slow_measured": measured,
                          "omega_slow_measured_error": np.asarray(m.omega_slow_error, float)})
    job.table("slow_frequency", frame, "slow", shown="Ω (rad/s) of the tilted state")
    fig = slow_frequency_line_figure(A, {"first-order averaging": avg,
                                         "Floquet (periodic orbit)": orbit,
                                         "measured (simulation)": measured},
                                     title=f"Slow frequency of the tilted state, ω = {w:g} rad/s")
    with np.errstate(invalid="ignore"):
        e_avg = np.nanmedian(np.abs(avg / orbit - 1))
        e_sim = np.nanmedian(np.abs(measured / orbit - 1))
    caption = (f"Ω of the tilted state along A at ω = {w:g} rad/s: first-order averaging is "
               f"{e_avg:.2g} (median, relative) from the periodic orbit's Floquet value, the "
               f"measured Ω {e_sim:.2g}.")
    return SectionResult(job.figure(fig, "slow_frequency"), caption, ["slow_frequency"])


def verification_section(job: Job) -> SectionResult:
    import pandas as pd

    from ..figures import verification_figure
    if not job.vertical:
        raise Skip("verification compares averaging, Floquet and simulation about an "
                   "equilibrium that persists under the drive, and " + no_map_reason(job))
    if not job.persists:
        raise Skip(_moved_by_the_drive(job))
    if job.pend is not None:
        l, w0 = job.pend.l, job.pend.omega0
        A_def = np.geomspace(0.01 * l, 0.6 * l, 6)
        w_def = np.geomspace(2.5 * w0, 100 * w0, 6)
        if not _upright_pendulum(job):      # the hanging state: across its first tongues
            A_def, w_def = np.geomspace(0.05 * l, 0.6 * l, 5), np.geomspace(0.8 * w0, 3 * w0, 5)
    else:
        A_def = np.linspace(0.25 * job.A, 3 * job.A, 5)
        w_def = np.geomspace(job.omega / 4, 2 * job.omega, 5)
    A = job.axis("verify", "A", A_def)
    w = job.axis("verify", "omega", w_def)
    periods = int(job.setting("verify", "periods", 1000))
    fit = bool(job.setting("verify", "fit_order", True))
    if job.quick:
        A, w, periods, fit = thin(A, 3), thin(w, 3), min(periods, 300), False
    v = _verify(job, A[:, None], w[None, :], periods, None if fit else False)
    agreement = v.agreement
    dis = v.disagreements
    job.table("verification", v.to_dataframe(), "verification")
    job.table("verification_agreement", agreement, "verification",
              shown="Agreement, per pair of methods (stability and Ω within the stated "
                    "tolerances)")
    cols = [c for c in ("A", "omega", "A_over_l", "omega_over_omega0", "boundary_distance",
                        "quantity", "first", "second", "first_stable", "second_stable",
                        "first_omega_slow", "second_omega_slow", "tolerance") if c in dis]
    located = dis[cols].copy()
    if "boundary_distance" in located:       # inf: no boundary at that ω; shown as "—"
        located["boundary_distance"] = located["boundary_distance"].replace(
            [np.inf, -np.inf], np.nan)
    job.table("verification_disagreements", located, "verification",
              shown=f"Every disagreement ({len(dis)}), located; boundary_distance = "
                    "|A − A_b|/A to the nearest exact boundary (— where none reaches that "
                    "ω)")
    fits = pd.DataFrame([{"order": f.order, "fitted exponent": f.exponent,
                          "standard error": f.exponent_error, "theory": f.theory,
                          "points fitted": int(np.sum(f.used))} for f in v.fits])
    if len(fits):
        job.table("verification_order_fit", fits, "verification",
                  shown="The measured order of averaging (relative error of Ω ∝ ε^p)")
    fig = verification_figure(v)
    stab = agreement[agreement.quantity == "stability"]
    sim = stab[(stab["first"] == "floquet") & (stab["second"] == "simulation")]
    if sim.empty:
        sim = stab[(stab["second"] == "floquet") & (stab["first"] == "simulation")]
    n = int(np.size(v.stable_floquet))
    agree_sim = int(sim.agreeing.iloc[0]) if len(sim) else 0
    compared_sim = int(sim.compared.iloc[0]) if len(sim) else 0
    job.numbers.update(verification_points=n, verification_disagreements=int(len(dis)),
                       floquet_simulation_agreeing=agree_sim,
                       floquet_simulation_compared=compared_sim)
    for f in v.fits:
        job.numbers[f"order_{f.order}_exponent"] = float(f.exponent)
    caption = (f"{n} points (A × ω = {A.size} × {w.size}), {periods} drive periods simulated "
               f"each: Floquet and simulation agree on stability at {agree_sim} of "
               f"{compared_sim}; {len(dis)} disagreements in all between the "
               f"{len(v.methods)} methods")
    if len(dis):
        d = np.asarray(dis.boundary_distance, float)
        d = d[np.isfinite(d)]                 # inf: no exact boundary at that ω
        if d.size:
            caption += f", the farthest {d.max():.2g} (relative in A) from an exact boundary"
    caption += "."
    names = {"averaging": "first-order averaging", "averaging_2": "next-order averaging",
             "simulation": "simulation"}
    against = []
    for m in v.methods:
        if m == "floquet":
            continue
        counts = []
        for quantity in ("stability", "omega_slow"):
            compared, agree = v.compare(m, "floquet", quantity)
            counts.append((int((compared & ~agree).sum()), int(compared.sum())))
        against.append(f"{names.get(m, m)} differs in stability at {counts[0][0]} of "
                       f"{counts[0][1]} points and in Ω beyond the stated tolerances at "
                       f"{counts[1][0]} of {counts[1][1]}")
    if against:
        caption += " Against Floquet: " + "; ".join(against) + "."
    for f in v.fits:
        caption += (f" Order {f.order} averaging: error of Ω ∝ ε^p with p = {f.exponent:.3f} "
                    f"± {f.exponent_error:.3f} (theory {f.theory:g}).")
    return SectionResult(job.figure(fig, "verification"), caption,
                   [t for t in ("verification", "verification_agreement",
                                "verification_disagreements", "verification_order_fit")
                    if t in job.tables])


def work_precision_section(job: Job) -> SectionResult:
    from lagrange_core.accuracy_cost import work_precision

    from ..figures import work_precision_figure
    pend = job.pend
    system = job.scene.system
    w = job.omega
    T = 2 * math.pi / w
    q0 = job.scene.q0
    t_span = (0.0, (8 if job.quick else 20) * T)
    result = work_precision(system, q0, job.scene.qdot0, t_span, job.params,
                            rtols=(1e-3, 1e-6, 1e-9) if job.quick else
                            (1e-3, 1e-5, 1e-7, 1e-9, 1e-11), repeat=1 if job.quick else 3)
    if getattr(result, "interrupted", False):     # it keeps its finished runs and returns
        raise KeyboardInterrupt("work_precision was interrupted")
    job.table("work_precision", result.to_dataframe(), "work_precision")
    fig = work_precision_figure(result)
    caption = (f"Error at the final time t = {t_span[1]:.3g} s ({t_span[1] / T:.0f} drive "
               f"periods of {'the pendulum' if pend else system.name}) against wall time per "
               f"run (compile excluded), each method at each tolerance; the reference's own "
               f"error is {result.reference_error:.2g}.")
    for level in (1e-6, 1e-9):
        times = result.time_to_reach(level)
        mine = times.get(result.default_method, math.nan)
        others = {k: v for k, v in times.items() if k != result.default_method}
        if np.isfinite(mine):
            caption += (f" To reach {level:g}, {result.default_method} (the default) takes "
                        f"{1e3 * mine:.3g} ms"
                        + "".join(f", {k} {v / mine:.3g}× as long" if np.isfinite(v) else
                                  f", {k} never gets there at the tolerances tried"
                                  for k, v in others.items()) + ".")
            job.numbers[f"work_precision_seconds_{level:g}"] = mine
            break
    return SectionResult(job.figure(fig, "work_precision"), caption, ["work_precision"])
