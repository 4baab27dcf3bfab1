"""The report's ``potential`` section: the effective potential U_eff at the scene's drive
with the averaged equilibria marked, at the averaging order the scene asks for, and the
slow state the sections are about, by averaging and by Floquet analysis.

The single pendulum (vertical or horizontal drive) has U_eff in closed form; any other
system of one coordinate (the pendulum on an elliptic pivot, a user's rig) gets U_eff
from :func:`kapitza.averaging.average`, its equilibria with the mean drag of damping
included, and the periodic orbit born from its state (:func:`kapitza.scenes.run_analysis`
"floquet").  Only U_eff itself is first order at any order: the next order exists for
the vertically driven pendulum's equilibria and slow frequencies, not as a potential.
"""
from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np

from ._job import Job, SectionResult, Skip, coordinate_text, pct, state_name, upright


def averaging_order(job: Job) -> int:
    """The averaging order the scene asks for (``[analyses] averaging = { order = 2 }``);
    1 where it does not ask, and for every drive but the vertical one (order 2 is the
    vertically driven pendulum's closed form)."""
    order = int(job.setting("averaging", "order", 1))
    vertical_pendulum = job.pend is not None and job.pend.drive == "vertical"
    return order if vertical_pendulum else 1


def potential_section(job: Job) -> SectionResult:
    if job.pend is not None:
        return _pendulum_potential(job)
    if job.scene.system.n_dof == 1 and job.scene.capabilities.get("averaging"):
        return _general_potential(job)
    where = (" — its averaged slow modes are compared with Floquet analysis and simulation "
             "in the slow-frequency and verification sections instead"
             if job.vertical and job.persists else "")
    raise Skip(f"the effective potential is drawn against one coordinate; this system "
               f"({job.scene.spec.rig_name}) has {job.scene.system.n_dof}{where}.")


def _well_depth(U_of, centre) -> float:
    """How deep the well of U_eff at ``centre`` is: the lower of the two barriers within
    half a turn on either side, less U_eff there (J/kg; ≤ 0: not a well)."""
    left = U_of(centre - np.linspace(0.0, math.pi, 721)[1:])
    right = U_of(centre + np.linspace(0.0, math.pi, 721)[1:])
    return float(min(left.max(), right.max()) - U_of(np.array([centre]))[0])


def _pendulum_potential(job: Job) -> SectionResult:
    import pandas as pd

    from ..figures import effective_potential_figure
    pend = job.pend
    A, w = job.A, job.omega
    order = averaging_order(job)
    theta = np.linspace(-0.25 * math.pi, 2.25 * math.pi, 901)
    U = pend.effective_potential(A, w, theta=theta)
    first = pend.averaged(A, w, warn=False)
    pred = pend.averaged(A, w, order=order, warn=False) if order > 1 else first
    fig = effective_potential_figure(
        theta, U, prediction=pred,
        title=f"Effective potential, A = {A:g} m, ω = {w:g} rad/s, {pend.drive} drive\n"
              + ("(U_eff to first order; the marks by next-order averaging; "
                 if order > 1 else "(first-order averaging; ")
              + "filled: stable, open: unstable)")
    job.table("effective_potential", pd.DataFrame({"theta": theta, "U_eff_per_mass": U}),
              "potential")
    rows = []
    for eq in first.equilibria:
        row = {"state": eq.name, "theta": float(eq.theta), "exists": bool(eq.exists),
               "stable_averaging_1": bool(eq.stable),
               "omega_slow_averaging_1": float(eq.omega_slow)}
        if order > 1:
            eq2 = pred[eq.name]
            row.update(stable_averaging_2=bool(eq2.stable),
                       omega_slow_averaging_2=float(eq2.omega_slow))
        row["valid"] = bool(pred[eq.name].valid)
        rows.append(row)
    job.table("averaged_equilibria", pd.DataFrame(rows), "potential",
              shown="Equilibria of the averaged motion (Ω in rad/s; averaging of order 1"
                    + (" and 2; valid: at order 2)" if order > 1 else ")"),
              tolerances={"order": order})
    if pend.drive == "vertical":
        caption = _vertical_caption(job, first, pred, order)
    else:
        tilt = pred.tilted
        caption = (f"Horizontal drive, A = {A:g} m, ω = {w:g} rad/s: "
                   + (f"the minima of U_eff are tilted to θ* = ±{float(tilt.theta):.4g} rad "
                      f"(cos θ* = 2gl/(Aω)² = {2 * pend.g * pend.l / (A * w) ** 2:.4g}), "
                      f"slow frequency {float(tilt.omega_slow):.4g} rad/s by averaging."
                      if bool(tilt.exists) else
                      "(Aω)² ≤ 2gl: no tilted minimum; the pendulum hangs."))
        if int(job.setting("averaging", "order", 1)) > 1:
            caption += (" (The scene asks for order 2, which exists for the vertical drive "
                        "only: first order is shown.)")
    return SectionResult(job.figure(fig, "effective_potential"), caption,
                         ["effective_potential", "averaged_equilibria"])


def _vertical_caption(job, first, pred, order) -> str:
    from ..closed_forms import pendulum_floquet
    pend, A, w = job.pend, job.A, job.omega
    which = job.pend_about
    name = f"{state_name(job)} {upright(job)}"
    eq1, eq = first[which], pred[which]
    # Floquet's numbers from Mathieu's trace: those of pend.floquet (tests/test_verify.py),
    # without compiling the general Floquet kernels (~20 s of a cold first report)
    exact = pendulum_floquet(A, w, l=pend.l, g=pend.g, damping=pend.damping, about=which)
    depth = _well_depth(lambda th: pend.effective_potential(A, w, theta=th),
                        math.pi if which == "inverted" else 0.0)
    text = (f"At A = {A:g} m and ω = {w:g} rad/s (A/l = {A / pend.l:.3g}, ω/ω0 = "
            f"{w / pend.omega0:.3g}) first-order averaging makes {name} "
            + (f"a minimum of U_eff, {depth:.3g} J/kg deep (per unit mass)"
               if bool(eq1.stable) else "a maximum of U_eff (not held)"))
    if order > 1:
        text += (f"; averaging of order {order} (the scene's) calls it "
                 + ("stable" if bool(eq.stable) else "unstable"))
    averaged_omega = float(eq.omega_slow)
    if bool(eq.stable) and np.isfinite(averaged_omega):
        text += (f"; its slow frequency is Ω = {averaged_omega:.4g} rad/s by averaging of "
                 f"order {order}" + (f" ({float(eq1.omega_slow):.4g} rad/s at first order)"
                                     if order > 1 else ""))
        job.numbers.update(omega_slow_averaging=averaged_omega)
    if not bool(pred[which].valid):
        text += (f" (outside averaging's validity here: ω/ω0 = {w / pend.omega0:.3g}, "
                 f"A/l = {A / pend.l:.3g})")
    if bool(exact.stable):
        job.numbers.update(omega_slow_floquet=float(exact.omega_slow))
        text += (f". Floquet analysis (exact, linear): stable, Ω = "
                 f"{float(exact.omega_slow):.4g} rad/s")
        if bool(eq.stable) and np.isfinite(averaged_omega):
            text += (f", {pct(abs(averaged_omega / float(exact.omega_slow) - 1))} from "
                     f"order-{order} averaging")
        return text + "."
    kind = {"T": "a real multiplier beyond +1 (a period-T instability)",
            "2T": "a real multiplier beyond −1 (a period-2T instability: parametric "
                  "resonance)"}.get(str(exact.boundary), "complex multipliers off the unit circle")
    largest = float(np.max(np.abs(exact.multipliers)))
    text += (f". Floquet analysis (exact, linear): unstable, {kind}, the largest |multiplier| "
             f"{largest:.4g} per drive period")
    if bool(eq.stable):
        text += " — an instability averaging cannot see"
    return text + "."


# -- a system of one coordinate without a closed form ---------------------------------------

def _general_potential(job: Job) -> SectionResult:
    import pandas as pd

    from ..averaging import average
    from ..figures import effective_potential_figure
    from ..scenes import run_analysis
    system, params = job.scene.system, job.params
    (name,) = system.coordinates
    unit = job.units.get(name, "rad")
    averaged = average(system)
    about = float(job.about[0])
    if unit == "rad":
        q = np.linspace(-0.25 * math.pi, 2.25 * math.pi, 451)
    else:
        span = max(abs(about), 1.0)
        q = np.linspace(about - span, about + span, 451)
    U = np.array([averaged.evaluate(params, [x])[0] for x in q])
    prediction = run_analysis(job.scene, "averaging", {})[0]
    marks = _marks(job, prediction.equilibria, unit)
    fig = effective_potential_figure(
        q, U, prediction=SimpleNamespace(equilibria=marks),
        title=f"Effective potential of the {job.scene.spec.rig_name} rig ({_path(job)} drive), "
              f"A = {job.A:g} m, ω = {job.omega:g} rad/s\n(first-order averaging; marks: its "
              f"equilibria with the mean drag; filled: stable, open: unstable)",
        xlabel=f"{coordinate_text(name)} ({unit})", ylabel="U_eff (J)",
        label="U_eff (first-order averaging)", angle=unit == "rad")
    job.table("effective_potential", pd.DataFrame({name: q, "U_eff": U}), "potential")
    frame = pd.DataFrame([{"state": m.name, name: m.theta, "stable": m.stable,
                           "omega_slow_averaging": m.omega_slow, "valid": m.valid}
                          for m in marks])
    job.table("averaged_equilibria", frame, "potential",
              shown=f"Equilibria of the averaged motion (first-order averaging; {name} in "
                    f"{unit}, Ω in rad/s)")
    path = _path(job)
    other = "".join(f", {k} = {v:g} m" for k, v in job.fixed.items() if k == "B")
    caption = (f"The {job.scene.spec.rig_name} rig under the {path} drive (A = {job.A:g} m"
               f"{other}, ω = {job.omega:g} rad/s): first-order averaging, with the mean drag "
               f"of the damping where there is one, finds {len(marks)} equilibria, "
               f"{sum(m.stable for m in marks)} stable"
               + "".join(f"; {m.name} at {name} = {m.theta:.4g} {unit}"
                         + (f" (Ω = {m.omega_slow:.4g} rad/s)" if m.stable else " (unstable)")
                         for m in marks) + ".")
    stable = [m for m in marks if m.stable]
    if stable:
        caption += _orbit_comparison(job, min(stable, key=lambda m: abs(m.theta - about)),
                                     name, unit, run_analysis)
    return SectionResult(job.figure(fig, "effective_potential"), caption,
                         ["effective_potential", "averaged_equilibria"])


def _path(job) -> str:
    path = job.scene.drive.path
    return path if isinstance(path, str) else "oblique"


def _marks(job, equilibria, unit):
    """The averaged equilibria as the figure marks them, each named after the declared
    state nearest it (angles modulo 2π) where one lies within 0.5 of its unit."""
    states = job.scene.spec.states or {}
    marks = []
    for e in equilibria:
        x = float(np.ravel(e.about)[0])
        label = f"q = {x:.3g}"
        for sname, values in states.items():
            d = x - values[0]
            if unit == "rad":
                d = (d + math.pi) % (2 * math.pi) - math.pi
            if abs(d) < 0.5:
                label = sname if abs(d) < 1e-9 else f"{sname} {d:+.2g}"
        omega = np.asarray(e.frequencies, float)
        marks.append(SimpleNamespace(name=label, theta=x, exists=True, stable=bool(e.stable),
                                     omega_slow=float(omega.min()) if omega.size else math.nan,
                                     valid=bool(e.valid)))
    return marks


def _orbit_comparison(job, mark, name, unit, run_analysis) -> str:
    """The periodic orbit born from the averaged state (Newton shooting), its period mean
    against averaging's state: how far first-order averaging is off."""
    try:
        orbit, _ = run_analysis(job.scene, "floquet", {"about": [mark.theta]})
    except (ValueError, RuntimeError) as e:
        return f" The periodic orbit near it was not found ({e})."
    mean = float(np.ravel(getattr(orbit, "q_mean", [math.nan]))[0])
    if not np.isfinite(mean):
        return ""
    job.numbers.update(orbit_mean=mean, averaged_state=mark.theta)
    stable = "stable" if bool(orbit.stable) else "unstable"
    return (f" The periodic orbit born from the stable one ({stable}, Newton shooting on the "
            f"full equations) has the period mean {name} = {mean:.6g} {unit}; averaging's "
            f"{mark.theta:.6g} {unit} lies {abs(mean - mark.theta):.2g} {unit} from it.")
