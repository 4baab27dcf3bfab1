"""The physical pendulum: a shaken rod against a point mass of its equivalent length.

Question
--------
Does a uniform rod of length L on a vertically shaken pivot behave exactly as a point
pendulum of the equivalent length L_eq = I/(m d) = 2L/3 — windows, stability maps, slow
frequencies and the nonlinear motion — and how wrong is the naive point pendulum of length L?

The analytic answer first
-------------------------
A rigid body of mass m, moment of inertia I_c about its centre of mass, the centre at
distance d from a pivot that moves as y_p(t); θ the angle of pivot → centre from the
downward vertical.  The centre is at (d sin θ, y_p − d cos θ), so

    T = ½ m (d² θ̇² + 2 d ẏ_p sin θ θ̇ + ẏ_p²) + ½ I_c θ̇²,      V = m g (y_p − d cos θ).

Euler–Lagrange: d/dt ∂T/∂θ̇ = (I_c + m d²) θ̈ + m d ÿ_p sin θ + m d ẏ_p cos θ θ̇ and
∂(T − V)/∂θ = m d ẏ_p cos θ θ̇ − m g d sin θ; the ẏ_p θ̇ terms cancel and, with I = I_c + m d²,

    I θ̈ = −m d (g + ÿ_p) sin θ,     i.e.  θ̈ = −(g + ÿ_p) sin θ / l_eq,   l_eq = I/(m d).

For the point pendulum of length l the same steps give θ̈ = −(g + ÿ_p) sin θ / l.  With
ÿ_p = −A ω² cos ωt both are θ̈ = −(g − A ω² cos ωt) sin θ / l: the rod *is* the point
pendulum of length l_eq, nonlinearly and for every drive, with the same pivot amplitude A
(not rescaled).  A uniform rod about its end: I = m L²/3, d = L/2, l_eq = 2L/3.  So
ω0 = √(g/l_eq), the Mathieu q = 2A/l_eq, and every window, map and slow frequency of the rod
is the point pendulum's at l_eq; a point mass at length L instead has A_min larger by
√(L/l_eq) = √1.5 (+22 %) at high ω and A_max larger by L/l_eq = 1.5 (+50 %).

Method
------
Three pendulums: the rod as :meth:`KapitzaPendulum.rod` (which sets l = 2L/3), the rod as a
rigid body derived independently by lagrange_core (``problems.physical_pendulum(driven=True)``:
a :class:`lagrange_core.RigidBody` with I_c = m L²/12, d = L/2, its own equations and
kernels), and the point masses of length L_eq and L.  Compared: the exact windows
(characteristic values for the point masses, :func:`kapitza.floquet.window` on the rigid
body), stability maps over (A, ω) (:func:`kapitza.floquet.stability_map` on the body against
:meth:`KapitzaPendulum.stability_map`), the exact slow frequency Ω (Floquet), and the
nonlinear motion θ(t) from a large release (0.3 rad from upright) and its measured Ω.
L = 1.5 m, so L_eq = 1 m; g = 9.81 m/s².
"""
from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import sympy as sp

import kapitza
from lagrange_core import problems

from _common import layout, main, save_figure, write_table

QUESTION = ("Is a shaken uniform rod exactly a point pendulum of the equivalent length "
            "2L/3 — windows, stability maps, slow frequencies, nonlinear motion — and how "
            "wrong is a point pendulum of the rod's length L?")

L_ROD, G, M = 1.5, 9.81, 1.0
L_EQ = 2 * L_ROD / 3
W0 = math.sqrt(G / L_EQ)                      # of the rod (= the point mass at L_eq)


def _log(msg):
    print(f"physical_pendulum: {msg}", file=sys.stderr, flush=True)


def rigid_body():
    """The rod as lagrange_core derives it: a RigidBody on a vertically driven pivot."""
    system = problems.physical_pendulum(driven=True)
    params = dict(m=M, I_c=M * L_ROD**2 / 12, d=L_ROD / 2, g=G)
    return system, params


def symbolic_check(system) -> bool:
    """lagrange_core's equation of the body is I θ̈ = −m d (g + ÿ_p) sin θ, symbolically
    (its mass matrix is I = I_c + m d², its generalized force −m d (g + ÿ_p) sin θ)."""
    eq = system.equations
    sym = {x.name: x for x in eq.forcing.free_symbols | eq.mass_matrix.free_symbols}
    m, d, g, A, omega, t, theta = (sym[k] for k in ("m", "d", "g", "A", "omega", "t", "theta"))
    I_c = sym["I_c"]
    ypp = sp.diff(A * sp.cos(omega * t), t, 2)
    inertia = sp.simplify(eq.mass_matrix[0, 0] - (I_c + m * d**2)) == 0
    return inertia and sp.simplify(eq.forcing[0] + m * d * (g + ypp) * sp.sin(theta)) == 0


def run(out: Path, quick: bool = False) -> dict:
    f = {}
    rod = kapitza.KapitzaPendulum.rod(L_ROD, g=G)
    point_eq = kapitza.KapitzaPendulum(l=L_EQ, g=G)
    point_l = kapitza.KapitzaPendulum(l=L_ROD, g=G)
    body, bparams = rigid_body()
    f["rod_l_eq_m"] = rod.l
    f["symbolic_equation_matches"] = bool(symbolic_check(body))

    # -- windows -------------------------------------------------------------------------------
    _log("windows: rod, rigid body (Floquet), point masses at L_eq and L")
    ratios = np.geomspace(2.0, 300.0, 8 if quick else 40)
    omega = ratios * W0
    wins = {"rod (KapitzaPendulum.rod)": rod.window(omega),
            # 1e-9: at 300 ω0 float64 monodromies fix the edges no better than ~3e-10
            "rigid body (Floquet)": kapitza.window(body, bparams, [math.pi], omega=omega,
                                                   tol=1e-9),
            "point mass, l = L_eq": point_eq.window(omega),
            "point mass, l = L": point_l.window(omega)}
    rows = []
    for name, w in wins.items():
        rows += [dict(kind="window", pendulum=name, omega_ratio=r, A_min_over_Leq=a / L_EQ,
                      A_max_over_Leq=b / L_EQ)
                 for r, a, b in zip(ratios, w.A_min, w.A_max, strict=True)]
    ref = wins["point mass, l = L_eq"]

    def rel(w, which):
        return np.asarray(getattr(w, which)) / np.asarray(getattr(ref, which)) - 1

    for key, name in (("rod", "rod (KapitzaPendulum.rod)"), ("body", "rigid body (Floquet)")):
        f[f"window_{key}_vs_point_Leq_max_rel_diff"] = float(max(
            np.max(np.abs(rel(wins[name], "A_min"))), np.max(np.abs(rel(wins[name], "A_max")))))
    f["body_window_certified_accuracy"] = float(np.max(wins["rigid body (Floquet)"].accuracy))
    naive = wins["point mass, l = L"]
    f["naive_A_min_ratio_at_300"] = float(rel(naive, "A_min")[-1] + 1)
    f["naive_A_max_ratio_at_300"] = float(rel(naive, "A_max")[-1] + 1)
    f["naive_A_min_ratio_at_2"] = float(rel(naive, "A_min")[0] + 1)
    f["naive_A_max_ratio_at_2"] = float(rel(naive, "A_max")[0] + 1)

    # -- stability maps ------------------------------------------------------------------------
    _log("stability maps")
    nA, nw = (14, 12) if quick else (70, 60)
    A_axis = np.linspace(0.004, 0.8, nA) * L_EQ
    w_axis = np.geomspace(2.0, 100.0, nw) * W0
    maps = {"rigid body (Floquet)": kapitza.stability_map(body, bparams, [math.pi], A=A_axis,
                                                          omega=w_axis, progress=False),
            "rod (KapitzaPendulum.rod)": rod.stability_map(A_axis, w_axis),
            "point mass, l = L_eq": point_eq.stability_map(A_axis, w_axis),
            "point mass, l = L": point_l.stability_map(A_axis, w_axis)}
    base = np.asarray(maps["point mass, l = L_eq"].stable)
    for key, name in (("body", "rigid body (Floquet)"), ("rod", "rod (KapitzaPendulum.rod)"),
                      ("naive", "point mass, l = L")):
        f[f"map_{key}_vs_point_Leq_differing_points"] = int(np.sum(np.asarray(maps[name].stable)
                                                                  != base))
    f["map_points"] = int(base.size)
    f["map_stable_fraction_point_Leq"] = float(base.mean())

    # -- slow frequency Ω (exact, Floquet) -------------------------------------------------------
    _log("slow frequencies")
    cases = [(0.05, 60.0), (0.1, 30.0), (0.2, 20.0), (0.3, 100.0)]      # (A/L_eq, ω/ω0)
    om = {k: [] for k in ("body", "rod", "point_eq", "point_l", "avg_eq")}
    for a, r in cases:
        A, w = a * L_EQ, r * W0
        om["body"].append(float(np.atleast_1d(kapitza.floquet_point(
            body, dict(bparams, A=A, omega=w), [math.pi]).omega_slow)[0]))
        om["rod"].append(float(np.atleast_1d(rod.floquet(A, w).omega_slow)[0]))
        om["point_eq"].append(float(np.atleast_1d(point_eq.floquet(A, w).omega_slow)[0]))
        pl = point_l.floquet(A, w)
        om["point_l"].append(float(np.atleast_1d(pl.omega_slow)[0]) if pl.stable else math.nan)
        om["avg_eq"].append(float(point_eq.averaged(A, w, warn=False).inverted.omega_slow))
        rows.append(dict(kind="slow frequency", pendulum="all", omega_ratio=r, A_over_Leq=a,
                         Omega_body=om["body"][-1], Omega_rod=om["rod"][-1],
                         Omega_point_Leq=om["point_eq"][-1], Omega_point_L=om["point_l"][-1],
                         Omega_averaging_Leq=om["avg_eq"][-1]))
    pe = np.array(om["point_eq"])
    f["Omega_body_vs_point_Leq_max_rel_diff"] = float(np.max(np.abs(np.array(om["body"]) / pe - 1)))
    f["Omega_rod_vs_point_Leq_max_rel_diff"] = float(np.max(np.abs(np.array(om["rod"]) / pe - 1)))
    naive_om = np.array(om["point_l"]) / pe - 1
    f["Omega_naive_rel_error_min"] = float(np.nanmin(naive_om))
    f["Omega_naive_rel_error_max"] = float(np.nanmax(naive_om))

    # -- nonlinear motion -----------------------------------------------------------------------
    _log("nonlinear motion from 0.3 rad off upright")
    A, w = 0.1 * L_EQ, 40.0 * W0
    periods = 100 if quick else 400
    t_eval = np.linspace(0.0, periods * 2 * math.pi / w, 20 * periods + 1)
    th0 = math.pi - 0.3
    traj = {"rigid body": body.simulate([th0], [0.0], (0.0, t_eval[-1]),
                                        dict(bparams, A=A, omega=w), rtol=1e-11, t_eval=t_eval),
            "point, L_eq": point_eq.simulate(A, w, th0, 0.0, (0.0, t_eval[-1]), rtol=1e-11,
                                             t_eval=t_eval),
            "point, L": point_l.simulate(A, w, th0, 0.0, (0.0, t_eval[-1]), rtol=1e-11,
                                         t_eval=t_eval)}
    th = {k: np.asarray(v.q)[:, 0] for k, v in traj.items()}
    f["theta_body_vs_point_Leq_max_abs_diff_rad"] = float(np.max(np.abs(th["rigid body"]
                                                                      - th["point, L_eq"])))
    f["theta_naive_vs_point_Leq_max_abs_diff_rad"] = float(np.max(np.abs(th["point, L"]
                                                                       - th["point, L_eq"])))
    f["nonlinear_run_periods"] = periods
    m_body = kapitza.measure_grid(body, dict(bparams, A=A, omega=w), [math.pi], [th0],
                                  periods=periods * 5, progress=False)
    m_eq = point_eq.measure(A, w, th0, periods=periods * 5)
    m_l = point_l.measure(A, w, th0, periods=periods * 5)
    f["measured_Omega_body"] = float(np.atleast_1d(m_body.omega_slow).ravel()[0])
    f["measured_Omega_point_Leq"] = float(m_eq.omega_slow)
    f["measured_Omega_point_L"] = float(m_l.omega_slow)
    f["measured_Omega_body_vs_point_Leq_rel_diff"] = abs(f["measured_Omega_body"]
                                                         / f["measured_Omega_point_Leq"] - 1)
    f["nonlinear_Omega_vs_linear_Floquet_rel"] = (f["measured_Omega_point_Leq"] / float(
        np.atleast_1d(point_eq.floquet(A, w).omega_slow)[0]) - 1)
    stride = 20
    for k, v in th.items():
        rows += [dict(kind="theta(t)", pendulum=k, t_s=tt, theta=x)
                 for tt, x in zip(t_eval[::stride], v[::stride], strict=True)]

    table = pd.DataFrame(rows)
    write_table(table, out, "physical_pendulum")
    save_figure(figure(wins, ratios, maps, A_axis, w_axis, t_eval, th, f, quick), out,
                "physical_pendulum", quick=quick)
    return f


def figure(wins, ratios, maps, A_axis, w_axis, t_eval, th, f, quick=False):
    import matplotlib.pyplot as plt
    from matplotlib.colors import ListedColormap
    fig, (ax, bx, cx) = plt.subplots(1, 3, figsize=(17, 5.2))
    styles = {"point mass, l = L_eq": dict(color="k", lw=3, alpha=0.35),
              "rod (KapitzaPendulum.rod)": dict(color="tab:blue", lw=1.2),
              "rigid body (Floquet)": dict(color="tab:orange", lw=0, marker="o", ms=4,
                                           mfc="none"),
              "point mass, l = L": dict(color="tab:red", lw=1.2, ls="--")}
    for name, st in styles.items():
        w = wins[name]
        ax.plot(ratios, np.asarray(w.A_min) / L_EQ, label=name, **st)
        ax.plot(ratios, np.asarray(w.A_max) / L_EQ, **st)
    ax.set(xscale="log", yscale="log", xlabel="ω/ω0  (ω0 = √(g/L_eq))", ylabel="A/L_eq",
           title=f"(a) upright window: rod L = {L_ROD} m, L_eq = {L_EQ:g} m")
    ax.legend(fontsize=8, loc="lower left")

    body = np.asarray(maps["rigid body (Floquet)"].stable, float)
    naive = np.asarray(maps["point mass, l = L"].stable, float)
    eq = np.asarray(maps["point mass, l = L_eq"].stable, float)
    code = body + 2 * naive        # 0 neither, 1 body only, 2 naive only, 3 both
    cmap = ListedColormap(["white", "tab:blue", "salmon", "0.55"])
    bx.pcolormesh(w_axis / W0, A_axis / L_EQ, code, cmap=cmap, vmin=-0.5, vmax=3.5,
                  shading="nearest")
    bx.contour(w_axis / W0, A_axis / L_EQ, eq, levels=[0.5], colors="k", linewidths=0.8)
    for c, lab in zip(cmap.colors[1:], ("stable: rod only", "stable: point at L only",
                                        "stable: both"), strict=True):
        bx.plot([], [], "s", color=c, ms=9, label=lab)
    bx.plot([], [], "k-", lw=0.8, label="edge, point at L_eq")
    bx.set(xscale="log", xlabel="ω/ω0", ylabel="A/L_eq",
           title=(f"(b) maps: rod (rigid body) vs point at L_eq: "
                  f"{f['map_body_vs_point_Leq_differing_points']} of {f['map_points']} differ"))
    bx.legend(fontsize=8, loc="upper right", framealpha=0.9)

    T = 2 * math.pi / (40.0 * W0)
    show = t_eval <= 60 * T            # the first 60 drive periods (the table has them all)
    tt = t_eval[show] / T
    cx.plot(tt, th["point, L_eq"][show], color="k", lw=3, alpha=0.35, label="point, L_eq")
    cx.plot(tt, th["rigid body"][show], color="tab:orange", lw=0.8, label="rigid-body rod")
    cx.plot(tt, th["point, L"][show], color="tab:red", lw=0.8, ls="--", label="point, L")
    cx.set(xlabel="t / T (drive periods)", ylabel="θ (rad)")
    cx.set_title(f"(c) θ(t) from π − 0.3 at A = 0.1 L_eq, ω = 40 ω0;\nrod − point at L_eq: "
                 f"|Δθ| ≤ {f['theta_body_vs_point_Leq_max_abs_diff_rad']:.0e} rad "
                 f"over {f['nonlinear_run_periods']} periods", fontsize=10)
    lo = min(float(np.min(v)) for v in th.values())
    hi = max(float(np.max(v)) for v in th.values())
    cx.set_ylim(lo - 0.35 * (hi - lo), hi + 0.05 * (hi - lo))
    cx.legend(fontsize=8, loc="lower center", ncol=3)
    layout(fig, quick)
    return fig


def check(findings: dict, quick: bool) -> None:
    f = findings
    assert f["symbolic_equation_matches"]                   # I θ̈ = −m d (g + ÿ_p) sin θ
    assert abs(f["rod_l_eq_m"] - 1.0) < 1e-15
    # the rod through KapitzaPendulum.rod is the point at L_eq to rounding
    assert f["window_rod_vs_point_Leq_max_rel_diff"] < 1e-13
    assert f["map_rod_vs_point_Leq_differing_points"] == 0
    assert f["Omega_rod_vs_point_Leq_max_rel_diff"] < 1e-8
    # the independently derived rigid body agrees to the methods' tolerances
    assert f["window_body_vs_point_Leq_max_rel_diff"] < 1e-8
    assert f["map_body_vs_point_Leq_differing_points"] == 0
    assert f["Omega_body_vs_point_Leq_max_rel_diff"] < 1e-7
    assert f["theta_body_vs_point_Leq_max_abs_diff_rad"] < 1e-6
    assert f["measured_Omega_body_vs_point_Leq_rel_diff"] < 1e-6
    # the naive point at L: A_min × √1.5 and A_max × 1.5 at high frequency
    assert abs(f["naive_A_min_ratio_at_300"] / math.sqrt(1.5) - 1) < 1e-4
    assert abs(f["naive_A_max_ratio_at_300"] / 1.5 - 1) < 1e-3
    assert f["map_naive_vs_point_Leq_differing_points"] > 0
    assert f["theta_naive_vs_point_Leq_max_abs_diff_rad"] > 0.1


if __name__ == "__main__":
    sys.exit(main(Path(__file__).stem, run))     # __name__ is "__main__" here
