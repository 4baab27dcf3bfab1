"""Other drives: the horizontal drive's tilted state and the elliptic pivot.

A pivot that does not move along the vertical leaves no angle at rest under the drive:
the slow states are T-periodic *orbits*.  This study finds them exactly
(:func:`kapitza.periodic_orbit`, Newton shooting on the period map; its multipliers give
stability and the slow frequency Ω) and puts them beside first-order averaging
(shared/PHYSICS.md):

* horizontal drive x_p = A cos ωt: U_eff/m = −g l cos θ + A²ω² cos²θ/4, so the hanging
  state gives way at A²ω² = 2gl to a tilted state cos θ* = 2gl/(A²ω²) with
  Ω² = (A²ω²/2l²) sin²θ*.  The exact hanging orbit is symmetric, θ(t + T/2) = −θ(t), and
  loses stability at a symmetry-breaking pitchfork (a multiplier +1): kapitza shoots it on
  the half-period map, which stays regular there (the full period map is singular), and
  the bifurcation amplitude is the root of tr M − 2 along it, found at several ω/ω0 — it
  lies *below* averaging's A ω = √(2gl) by (3/16)(ω0/ω)²;
* elliptic pivot x_p = A cos ωt, y_p = B sin ωt: U_eff/m = −g l cos θ +
  ω²(A² cos²θ + B² sin²θ)/4.  A circular pivot (A = B) adds a constant: the upright stays
  a maximum of −g l cos θ, unstable with growth rate ω0 whatever the drive;
* damped elliptic pivot: the drive's two phases leave a mean drag torque γωAB/2 (per unit
  mass and length²·l⁻¹) that tilts the hanging state.  PHYSICS.md states
  sin θ ≈ γωAB/(2gl); the torque balance on the full U_eff is
  sin θ [g l + ω²(B² − A²) cos θ/2] = γωAB/2, which is the same only for A = B.

Direct simulation (:func:`kapitza.measure`, :meth:`lagrange_core.System.simulate`)
confirms a horizontal and an elliptic point.
"""
from __future__ import annotations

import math
import sys
import time
from pathlib import Path

import numpy as np
import pandas as pd

import kapitza
from kapitza import KapitzaPendulum, Scene, periodic_orbit

from _common import layout, main, save_figure, write_table

QUESTION = ("How well does first-order averaging describe the horizontal drive's tilted state "
            "and the elliptic pivot (circular: never upright; damped: a tilt), measured "
            "against their exact periodic orbits?")

L, G = 1.0, 9.81
W0 = math.sqrt(G / L)


def _log(msg):
    print(f"other_drives: {msg}", file=sys.stderr, flush=True)


# -- averaging's closed forms --------------------------------------------------------------

def horizontal_averaged(A, omega):
    """First-order averaging of the horizontal drive: (tilt θ* (rad), Ω (rad/s)) of the stable
    slow state — hanging below A²ω² = 2gl, tilted above (kapitza.pendulum_averaged)."""
    avg = kapitza.pendulum_averaged(A, omega, l=L, g=G, drive="horizontal", warn=False)
    tilted = avg.tilted
    theta = np.where(tilted.exists, tilted.theta, 0.0)
    omega_slow = np.where(tilted.exists, tilted.omega_slow, avg.hanging.omega_slow)
    return theta, omega_slow


def tilt_physics_md(A, B, omega, gamma):
    """PHYSICS.md's damped elliptic tilt, sin θ = γωAB/(2gl)."""
    return np.arcsin(gamma * omega * A * B / (2 * G * L))


def tilt_torque_balance(A, B, omega, gamma):
    """The tilt that balances the drag torque against the whole of U_eff:
    sin θ [g l + ω²(B² − A²) cos θ / 2] = γωAB/2, solved by Newton from PHYSICS.md's value."""
    th = tilt_physics_md(A, B, omega, gamma)
    for _ in range(50):
        k = omega**2 * (B**2 - A**2) / 2
        f = np.sin(th) * (G * L + k * np.cos(th)) - gamma * omega * A * B / 2
        df = np.cos(th) * G * L + k * np.cos(2 * th)
        th = th - f / df
    return th


# -- exact orbits --------------------------------------------------------------------------

def horizontal_orbit(A, omega):
    """Exact slow state of the horizontal drive: the periodic orbit (hanging or tilted, the
    stable one averaging names) → (period-mean tilt, Ω, max |multiplier|), NaN if Newton fails."""
    pend = KapitzaPendulum(l=L, g=G, drive="horizontal")
    about = "tilted" if (A * omega) ** 2 > 2 * G * L else "hanging"
    try:
        o = pend.floquet(A, omega, about=about)
    except ValueError:
        return math.nan, math.nan, math.nan
    return float(o.q_mean[0]), float(o.omega_slow), float(np.max(np.abs(o.multipliers)))


def horizontal_bifurcation(omega):
    """The exact amplitude where the hanging orbit of the horizontal drive loses stability
    (its multipliers e^(±iΩT) meet at +1: tr M = 2), by brentq on tr M − 2.

    ``floquet(about="hanging")`` returns the symmetric orbit θ(t + T/2) = −θ(t), shot on the
    half-period map (kapitza.periodic_orbit): regular at the pitchfork, so tr M − 2 is a
    smooth function of A through it (∝ A* − A), known to ~1e-13; A* to ~1e-13 relative at
    ω/ω0 = 120 (tests/test_orbit_bifurcation.py: an independent symmetric shooting agrees
    to 1e-10).  The bracket is averaging's √(2gl)/ω × (1 ± (ω0/ω)²): the correction is of
    the next order in (ω0/ω)²."""
    from scipy.optimize import brentq
    pend = KapitzaPendulum(l=L, g=G, drive="horizontal")

    def margin(A):
        o = pend.floquet(A, omega, about="hanging")
        return float(np.real(np.sum(o.multipliers))) - 2.0
    a_avg = math.sqrt(2 * G * L) / omega
    eps = (W0 / omega) ** 2
    return brentq(margin, (1 - eps) * a_avg, (1 + eps) * a_avg, xtol=1e-15 * a_avg,
                  rtol=1e-15)


def elliptic_scene():
    """The shipped scene of the damped elliptic pivot (A = 2 cm, B = 1 cm, ω = 100 rad/s,
    γ = 0.3 /s): its system and parameters."""
    scene = Scene.example("elliptic_damped")
    return scene.system, scene.params


def slope(x, y):
    """Least-squares slope of log y against log x (the error exponent)."""
    ok = np.isfinite(y) & (y > 0)
    return float(np.polyfit(np.log(x[ok]), np.log(y[ok]), 1)[0])


# -- the study -----------------------------------------------------------------------------

def run(out: Path, quick: bool = False) -> dict:
    t_start = time.perf_counter()
    rows = []
    f = {}

    # 1. Horizontal drive at ω/ω0 ≈ 120 (60 Hz, l = 1 m): tilt and Ω across the bifurcation
    w_h = 2 * math.pi * 60
    x = np.linspace(0.5, 3.5, 9 if quick else 61)          # A ω / √(g l)
    # the tilted orbits branch off the hanging one at √2: there they are not isolated (their
    # full-period shooting is near-singular, flagged by periodic_orbit), so the grid skips it
    x = x[np.abs(x - math.sqrt(2)) > 0.02]
    _log(f"horizontal drive: {x.size} orbits across the bifurcation")
    for xi in x:
        A = xi * math.sqrt(G * L) / w_h
        th, om, lam = horizontal_orbit(A, w_h)
        th_a, om_a = horizontal_averaged(A, w_h)
        rows.append(dict(part="horizontal_bifurcation", x=xi, omega_ratio=w_h / W0, A=A, B=0.0,
                         gamma=0.0, exact_tilt=th, averaged_tilt=float(th_a),
                         exact_Omega=om, averaged_Omega=float(om_a), max_abs_multiplier=lam))
    A_c = horizontal_bifurcation(w_h)
    A_c_avg = math.sqrt(2 * G * L) / w_h
    f["bifurcation_A_exact_mm"] = 1e3 * A_c
    f["bifurcation_A_averaging_mm"] = 1e3 * A_c_avg
    f["bifurcation_relative_shift"] = A_c / A_c_avg - 1
    # the shift against ω/ω0: the next order of averaging, −(3/16)(ω0/ω)²
    bif_ratios = np.array([30.0, 60.0, 120.0] if quick else [10.0, 20.0, 30.0, 60.0, 120.0,
                                                              240.0])
    _log(f"horizontal drive: the bifurcation at {bif_ratios.size} frequencies")
    bif_shift = []
    for r in bif_ratios:
        a = horizontal_bifurcation(r * W0)
        a_avg = math.sqrt(2 * G * L) / (r * W0)
        bif_shift.append(a / a_avg - 1)
        rows.append(dict(part="bifurcation", x=a * r * W0 / math.sqrt(G * L), omega_ratio=r,
                         A=a, B=0.0, gamma=0.0, exact_tilt=0.0, averaged_tilt=0.0,
                         exact_Omega=0.0, averaged_Omega=0.0, max_abs_multiplier=1.0,
                         averaged_A=a_avg, relative_shift=bif_shift[-1]))
        if r in (30.0, 60.0, 120.0):
            f[f"bifurcation_shift_w{r:.0f}"] = bif_shift[-1]
            f[f"bifurcation_shift_coefficient_w{r:.0f}"] = bif_shift[-1] * r**2
    bif_shift = np.array(bif_shift)
    f["bifurcation_shift_exponent"] = slope(bif_ratios, -bif_shift)
    bif = [r for r in rows if r["x"] > math.sqrt(2)]
    f["tilt_max_error_rad_w120"] = max(abs(r["exact_tilt"] - r["averaged_tilt"]) for r in bif)
    f["Omega_max_rel_error_w120"] = max(abs(r["exact_Omega"] / r["averaged_Omega"] - 1)
                                        for r in bif if r["x"] > 1.6)

    # 2. The error exponent: along A ω = 2 √(g l) (θ* = 60°), ω/ω0 from 5 to 300
    ratios = np.geomspace(5, 300, 5 if quick else 14)
    _log(f"horizontal drive: {ratios.size} orbits along A ω = 2 √(g l)")
    err_t, err_o = [], []
    for r in ratios:
        w = r * W0
        A = 2 * math.sqrt(G * L) / w
        th, om, lam = horizontal_orbit(A, w)
        th_a, om_a = horizontal_averaged(A, w)
        err_t.append(abs(th - float(th_a)))
        err_o.append(abs(om / float(om_a) - 1))
        rows.append(dict(part="horizontal_error", x=2.0, omega_ratio=r, A=A, B=0.0, gamma=0.0,
                         exact_tilt=th, averaged_tilt=float(th_a), exact_Omega=om,
                         averaged_Omega=float(om_a), max_abs_multiplier=lam))
    err_t, err_o = np.array(err_t), np.array(err_o)
    f["tilt_error_exponent"] = slope(ratios, err_t)
    f["Omega_error_exponent"] = slope(ratios, err_o)
    f["tilt_error_at_w5"] = float(err_t[0])
    f["tilt_error_at_w300"] = float(err_t[-1])
    f["Omega_rel_error_at_w300"] = float(err_o[-1])

    # 3. Circular pivot (A = B, undamped): the orbit through the upright over an (A, ω) grid
    system, scene_params = elliptic_scene()
    # A/l ≤ 0.1: at A = 0.2 l and ω/ω0 = 133 Newton from the rest state θ = π wanders off
    # (periodic_orbit raises ValueError in 0.15 s; the orbit is found from a neighbouring
    # frequency's instead), so the grid stays where the plain start converges everywhere
    amps = np.array([0.01, 0.05, 0.1]) if quick else np.array([0.005, 0.01, 0.02, 0.05, 0.1])
    circ_ratios = np.geomspace(5, 200, 3 if quick else 10)
    _log(f"circular pivot: {amps.size * circ_ratios.size} orbits through the upright")
    lam_max, sigma = [], []
    for A in amps:
        for r in circ_ratios:
            p = dict(scene_params, A=float(A), B=float(A), omega=float(r * W0), gamma=0.0)
            try:
                o = periodic_orbit(system, p, [math.pi])
                lm = float(np.max(np.abs(o.multipliers)))
                q_mean = float(o.q_mean[0])
            except ValueError:
                lm, q_mean = math.nan, math.nan
            lam_max.append(lm)
            sigma.append(math.log(lm) * r * W0 / (2 * math.pi) / W0)
            rows.append(dict(part="circular", x=A * r * W0 / math.sqrt(G * L), omega_ratio=r,
                             A=float(A), B=float(A), gamma=0.0, exact_tilt=q_mean,
                             averaged_tilt=math.pi, exact_Omega=math.nan, averaged_Omega=math.nan,
                             max_abs_multiplier=lm, growth_over_omega0=sigma[-1]))
    lam_max, sigma = np.array(lam_max), np.array(sigma)
    f["circular_points"] = int(lam_max.size)
    f["circular_points_unstable"] = int(np.sum(lam_max > 1))
    f["circular_min_max_abs_multiplier"] = float(np.nanmin(lam_max))
    f["circular_growth_over_omega0_min"] = float(np.nanmin(sigma))
    f["circular_growth_over_omega0_max"] = float(np.nanmax(sigma))
    # the growth rate's excess over ω0 is a correction in (A/l)², not in ω0/ω: read it at
    # the largest amplitude and frequency
    f["circular_growth_excess_over_A2"] = float((sigma.reshape(amps.size, -1)[-1, -1] - 1)
                                                / (amps[-1] / L) ** 2)

    # 4. Damped elliptic pivot (the scene: A = 2 cm, ω = 100 rad/s, γ = 0.3/s): tilt vs B/A
    A0, w_e, gam = scene_params["A"], scene_params["omega"], scene_params["gamma"]
    b_over_a = np.linspace(-1.5, 1.5, 7 if quick else 25)
    b_over_a = b_over_a[b_over_a != 0]
    _log(f"damped elliptic pivot: {b_over_a.size} orbits")
    for ba in b_over_a:
        B = float(ba * A0)
        p = dict(scene_params, B=B)
        o = periodic_orbit(system, p, [0.0])
        rows.append(dict(part="elliptic_damped", x=ba, omega_ratio=w_e / W0, A=A0, B=B,
                         gamma=gam, exact_tilt=float(o.q_mean[0]),
                         averaged_tilt=float(tilt_torque_balance(A0, B, w_e, gam)),
                         physics_md_tilt=float(tilt_physics_md(A0, B, w_e, gam)),
                         exact_Omega=float(o.omega_slow), averaged_Omega=math.nan,
                         max_abs_multiplier=float(np.max(np.abs(o.multipliers)))))
    ell = [r for r in rows if r["part"] == "elliptic_damped"]
    rel_bal = np.array([abs(r["averaged_tilt"] / r["exact_tilt"] - 1) for r in ell])
    rel_md = np.array([abs(r["physics_md_tilt"] / r["exact_tilt"] - 1) for r in ell])
    f["elliptic_torque_balance_max_rel_error"] = float(rel_bal.max())
    f["elliptic_physics_md_max_rel_error"] = float(rel_md.max())
    circ = min(ell, key=lambda r: abs(r["x"] - 1))
    f["elliptic_circular_B_over_A"] = circ["x"]
    f["elliptic_circular_physics_md_rel_error"] = abs(circ["physics_md_tilt"]
                                                      / circ["exact_tilt"] - 1)
    scene_row = min(ell, key=lambda r: abs(r["x"] - 0.5))
    f["scene_tilt_exact_mrad"] = 1e3 * scene_row["exact_tilt"]
    f["scene_tilt_physics_md_mrad"] = 1e3 * scene_row["physics_md_tilt"]
    f["scene_tilt_torque_balance_mrad"] = 1e3 * scene_row["averaged_tilt"]

    # 5. Direct simulation at one point of each drive
    _log("direct simulation: the horizontal drive at A ω = 2 √(g l), ω/ω0 = 20")
    w = 20 * W0
    A = 2 * math.sqrt(G * L) / w
    th, om, _ = horizontal_orbit(A, w)
    pend = KapitzaPendulum(l=L, g=G, drive="horizontal")
    start = pend.floquet(A, w, about="tilted").state      # the orbit's state at t = 0
    # 2 mrad off the orbit: the slow oscillation's own O(a²) shifts of Ω and of the mean
    # stay far below the comparison's 1e-3 (from θ0 = θ̄ the slow amplitude would be
    # the fast motion's A/l ≈ 0.1 rad)
    m = pend.measure(A, w, theta0=start[0] + 0.002, theta_dot0=start[1],
                     periods=400 if quick else 2000)
    f["measured_tilt_rad"] = float(m.mean_angle)
    f["orbit_tilt_rad"] = th
    f["measured_Omega"] = float(m.omega_slow)
    f["measured_Omega_error"] = float(m.omega_slow_error)
    f["orbit_Omega"] = om
    rows.append(dict(part="measured_horizontal", x=2.0, omega_ratio=20.0, A=A, B=0.0, gamma=0.0,
                     exact_tilt=float(m.mean_angle), averaged_tilt=math.nan,
                     exact_Omega=float(m.omega_slow), averaged_Omega=math.nan,
                     max_abs_multiplier=math.nan))
    _log("direct simulation: the scene's damped elliptic pivot from θ = 0.05")
    T = 2 * math.pi / w_e
    # the slow oscillation decays as e^(−γt/2): 0.05 rad → 4e-8 rad after 1500 T = 94 s
    n_settle, n_mean = (1500, 40) if quick else (3000, 200)
    ts = (n_settle + np.arange(64 * n_mean) / 64) * T
    tr = system.simulate([0.05], [0.0], (0.0, ts[-1] + T), scene_params, t_eval=ts, rtol=1e-11)
    f["simulated_scene_tilt_mrad"] = 1e3 * float(np.mean(tr.q[:, 0]))
    rows.append(dict(part="measured_elliptic", x=scene_params["B"] / A0, omega_ratio=w_e / W0,
                     A=A0, B=scene_params["B"], gamma=gam,
                     exact_tilt=float(np.mean(tr.q[:, 0])), averaged_tilt=math.nan,
                     exact_Omega=math.nan, averaged_Omega=math.nan, max_abs_multiplier=math.nan))

    table = pd.DataFrame(rows)
    write_table(table, out, "other_drives")
    save_figure(figure(table, ratios, err_t, err_o, A_c, w_h, f, bif_ratios, bif_shift, quick), out,
                "other_drives", quick=quick)
    f["compute_s"] = round(time.perf_counter() - t_start, 1)
    return f


def figure(table, ratios, err_t, err_o, A_c, w_h, f, bif_ratios, bif_shift, quick=False):
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(2, 3, figsize=(15, 8.6))
    fig.suptitle("Other drives: exact periodic orbits (points) against first-order averaging "
                 "(lines); l = 1 m, g = 9.81 m/s²")
    # (a) tilt across the bifurcation
    b = table[table.part == "horizontal_bifurcation"]
    xs = np.linspace(0.45, 3.55, 400)
    th_a, om_a = horizontal_averaged(xs * math.sqrt(G * L) / w_h, w_h)
    x_c = A_c * w_h / math.sqrt(G * L)
    a = ax[0, 0]
    a.plot(xs, np.degrees(th_a), "C0-", label="averaging: cos θ* = 2gl/(Aω)²")
    a.plot(b.x, np.degrees(b.exact_tilt), "ko", ms=4, label="exact orbit (period mean)")
    a.axvline(x_c, color="C3", ls=":", label=f"exact bifurcation Aω/√(gl) = {x_c:.6f} "
              f"(averaging √2 {f['bifurcation_relative_shift']:+.2e})")
    a.set(xlabel="A ω / √(g l)", ylabel="mean tilt θ̄ (deg)",
          title=f"(a) horizontal drive, ω/ω0 = {w_h / W0:.0f}: tilt")
    a.legend(fontsize=8, loc="center right")
    # (b) Ω across the bifurcation
    a = ax[0, 1]
    a.plot(xs, om_a / W0, "C0-", label="averaging")
    a.plot(b.x, b.exact_Omega / W0, "ko", ms=4, label="exact orbit: |arg λ|/T")
    a.axvline(x_c, color="C3", ls=":", label="exact bifurcation")
    a.set(xlabel="A ω / √(g l)", ylabel="slow frequency Ω / ω0",
          title="(b) horizontal drive: slow frequency")
    a.legend(fontsize=8)
    # (c) error exponent
    a = ax[0, 2]
    a.loglog(ratios, err_t, "o-", label=f"|θ̄ − θ*| (rad), slope {f['tilt_error_exponent']:.2f}")
    a.loglog(ratios, err_o, "s-",
             label=f"|Ω/Ω_avg − 1|, slope {f['Omega_error_exponent']:.2f}")
    ref = err_o[0] * (ratios / ratios[0]) ** -2.0
    a.loglog(ratios, ref, "k:", label="∝ (ω/ω0)⁻²")
    a.loglog(bif_ratios, -bif_shift, "C3D", ms=6,
             label="bifurcation: 1 − A*/(√(2gl)/ω) (exact below averaging)")
    a.loglog(ratios, 3 / 16 * ratios**-2.0, "C3--", lw=1, label="(3/16)(ω0/ω)²")
    a.set(xlabel="ω / ω0", ylabel="exact − averaging",
          title="(c) horizontal drive along Aω = 2√(gl) (θ* = 60°); the bifurcation")
    a.legend(fontsize=8)
    # (d) circular drive: growth rate of the upright
    c = table[table.part == "circular"]
    a = ax[1, 0]
    for A, grp in c.groupby("A"):
        a.semilogx(grp.omega_ratio, grp.growth_over_omega0, "o-", ms=4, label=f"A = B = {A:g} l")
    a.axhline(1.0, color="k", ls=":", label="averaging: σ = ω0")
    a.set(xlabel="ω / ω0", ylabel="growth rate σ / ω0 = ln max|λ| / (T ω0)",
          title=f"(d) circular pivot: upright unstable at "
                f"{f['circular_points_unstable']}/{f['circular_points']} points")
    a.legend(fontsize=8, ncol=2)
    # (e) damped elliptic tilt
    e = table[table.part == "elliptic_damped"].sort_values("x")
    s = table[table.part == "measured_elliptic"]
    a = ax[1, 1]
    a.plot(e.x, 1e3 * e.physics_md_tilt, "C1--", label="PHYSICS.md: sin θ = γωAB/(2gl)")
    a.plot(e.x, 1e3 * e.averaged_tilt, "C0-",
           label="torque balance on U_eff: sin θ [gl + ω²(B²−A²)cos θ/2] = γωAB/2")
    a.plot(e.x, 1e3 * e.exact_tilt, "ko", ms=4, label="exact orbit (period mean)")
    a.plot(s.x, 1e3 * s.exact_tilt, "r*", ms=12, label="direct simulation (the scene)")
    a.set(xlabel="B / A", ylabel="mean tilt θ̄ (mrad)",
          title="(e) damped elliptic pivot: A = 2 cm, ω = 100/s, γ = 0.3/s")
    a.legend(fontsize=7, loc="lower right")
    # (f) relative error of the two formulas
    a = ax[1, 2]
    a.semilogy(e.x, np.abs(e.physics_md_tilt / e.exact_tilt - 1), "C1o--", ms=4,
               label="PHYSICS.md formula")
    a.semilogy(e.x, np.abs(e.averaged_tilt / e.exact_tilt - 1), "C0s-", ms=4,
               label="torque balance on U_eff")
    a.axvline(1.0, color="gray", ls=":", lw=1)
    a.axvline(-1.0, color="gray", ls=":", lw=1)
    a.set(xlabel="B / A  (dotted: circular, B = ±A)", ylabel="|θ_formula / θ_exact − 1|",
          title="(f) damped elliptic pivot: error of each formula")
    a.legend(fontsize=8)
    layout(fig, quick)
    return fig


def check(findings: dict, quick: bool) -> None:
    f = findings
    # Averaging is first order in the small parameters: the exact bifurcation is *below*
    # A²ω² = 2gl by (3/16)(ω0/ω)² (1.3e-5 at ω/ω0 = 120; the coefficient's remainder is
    # O((ω0/ω)²): measured 5.5e-6 at 30, 3.5e-7 at 120), and the tilt's error falls as
    # (ω/ω0)^-2.  (An independent symmetric shooting agrees with these amplitudes to 1e-10:
    # tests/test_orbit_bifurcation.py.)
    assert -1e-3 < f["bifurcation_relative_shift"] < 0, f["bifurcation_relative_shift"]
    for r in (30, 60, 120):
        c = f[f"bifurcation_shift_coefficient_w{r}"]
        assert abs(c + 3 / 16) < 0.01 * 30**2 / r**2, (r, c)
    assert (abs(f["bifurcation_shift_coefficient_w120"] + 3 / 16)
            < abs(f["bifurcation_shift_coefficient_w30"] + 3 / 16) / 8)
    assert abs(f["bifurcation_shift_exponent"] + 2) < 0.01, f["bifurcation_shift_exponent"]
    assert abs(f["tilt_error_exponent"] + 2) < 0.2, f["tilt_error_exponent"]
    assert abs(f["Omega_error_exponent"] + 2) < 0.2, f["Omega_error_exponent"]
    assert f["tilt_error_at_w300"] < 1e-4 and f["Omega_rel_error_at_w300"] < 1e-4
    assert f["tilt_max_error_rad_w120"] < 1e-3
    # the circular pivot never holds the upright; its growth rate is ω0 (averaging: U_eff's
    # drive term is constant) to within the O(A/l)² and O(ω0/ω)² corrections
    assert f["circular_points_unstable"] == f["circular_points"]
    assert f["circular_min_max_abs_multiplier"] > 1.0
    assert 0.97 < f["circular_growth_over_omega0_min"] <= f["circular_growth_over_omega0_max"] < 1.1
    # the damped tilt: the torque balance on the whole U_eff within 1 % of the exact orbit
    # everywhere; PHYSICS.md's formula only at the circular drive
    assert f["elliptic_torque_balance_max_rel_error"] < 0.01
    assert f["elliptic_circular_physics_md_rel_error"] < 0.01
    assert f["elliptic_physics_md_max_rel_error"] > 0.1
    # direct simulation agrees with the orbits
    assert abs(f["measured_tilt_rad"] - f["orbit_tilt_rad"]) < 1e-4
    assert abs(f["measured_Omega"] / f["orbit_Omega"] - 1) < 1e-3
    assert abs(f["simulated_scene_tilt_mrad"] / f["scene_tilt_exact_mrad"] - 1) < 1e-3


if __name__ == "__main__":
    sys.exit(main(Path(__file__).stem, run))     # __name__ is "__main__" here
