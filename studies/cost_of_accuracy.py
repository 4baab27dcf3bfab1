"""What accuracy costs in time: one work–precision measurement per capability.

Question
--------
How much wall time does each capability of the toolkit — integrating one trajectory,
Floquet analysis, averaging, simulating a grid of trajectories — spend per extra digit of
accuracy, and how does that compare with scipy (and heyoka where it is installed)?

Method
------
Every panel plots an error against an independent reference (log) over the wall time
(log), best of several runs after a warm-up run, so compiling and loading kernels are
excluded; every point is labelled with the exponent of its tolerance.

1. *Integrators* (:func:`lagrange_core.accuracy_cost.work_precision`): the driven
   pendulum of the benchmarks (A = 0.05 m, l = 1 m, ω = 2π·60 rad/s, θ0 = π − 0.1 at rest)
   over 500 drive periods; error |θ(T) − θ_ref(T)| against our RKN 12 at rtol 1e-14
   cross-checked by DOP853 at 1e-14; ours (``rkn12`` = the default, ``rkn12-fixed``,
   ``dop853``) against scipy's ``solve_ivp`` (DOP853, LSODA) on the same compiled
   right-hand side, and heyoka's Taylor integrator when installed.
2. *Floquet* (``kapitza.floquet_grid`` / ``KapitzaPendulum.floquet``): the upright
   pendulum exactly on its two stability boundaries, where the Mathieu equation
   y″ + (a − 2q cos 2τ) y = 0 (a = −4ω0²/ω², q = 2A/l) has a = a0(q) (tr M = +2 exactly,
   the Kapitza limit) or a = b1(q) (tr M = −2, the first parametric resonance): for each q
   the drive frequency is ω = 2ω0/√(−a_r(q)) from the characteristic value
   (``kapitza.closed_forms.characteristic_value``, accurate to ≈ 1e-15).  Error = max |tr M ∓ 2|
   over the boundary points; time per point of a grid call, and of a single call.
3. *Averaging*: the upright's slow frequency Ω by first-order averaging (closed form
   ``pendulum_averaged(order=1)``, and the general ``kapitza.average(system).sweep``), by
   the next order (``order=2``) and by Floquet at several tolerances, over drives
   ω/ω0 = 10…100 at A ω = 1.5 √(2 g l); error = relative error of Ω against Floquet at
   tol 1e-12; cost = seconds per point.
4. *Batch simulation* (``System.simulate_grid``): the driven pendulum from θ0 = π − 0.1 on
   an (A, ω) grid (A = 5…30 mm, ω/2π = 30…60 Hz) for 200 drive periods with the band
   π/2 < θ < 3π/2 ("fell" when it leaves it); error = max |θ(T) − θ_ref(T)| over the points
   that stayed up, misclassified = points whose fell/held differs from the reference
   (rtol 1e-13, cross-checked by DOP853 at 1e-13); throughput = points per second, against
   a Python loop of ``System.simulate`` over a subset of the same points.

Output table: one row per measured point, ``panel`` (integrators, floquet, averaging, batch),
``method``, ``setting`` (the tolerance; for the averaging closed forms, the order), ``error``
(and ``error_median``/``error_min``/``error_max`` where a panel has many points per
setting), ``seconds_per_point``, ``points``, ``misclassified`` (batch).

Independent checks (``check``)
------------------------------
Errors fall as the tolerance tightens (by ≥ 100× over the range, every method);
the default integrator's error at t1 stays within 10 × rtol wherever the reference resolves
it, DOP853's (ours and scipy's) within 1000 × rtol (a local error control: the stated band);
the integrators' reference agrees with its cross-check to < 1e-11;
the Floquet trace is within **2 × tol** of the exact Mathieu value ±2 at every tolerance
(tol bounds M's error relative to max(1, ‖M‖) and ‖M‖ ≈ 1–2 here; the trace sums two
entries); first-order averaging's relative error scales as ε² (ε = ω0/ω, fitted slope
2 ± 0.3) and the next order is more accurate at every point; the batch grid misclassifies
no point at its tightest tolerance; its error at t1 is within rtol at the median point and
within 100 × rtol at the worst (200 periods, points up to the edge of the basin, where a local
error control does not bound the global error: measured 15× at rtol 1e-5).
"""
from __future__ import annotations

import math
import sys
import time
import warnings
from pathlib import Path

import numpy as np
import pandas as pd

import kapitza
from lagrange_core import problems
from lagrange_core.accuracy_cost import best_time, work_precision

from _common import main, save_figure, write_table

QUESTION = ("How much wall time does each capability of the toolkit (integrators, Floquet "
            "analysis, averaging, batch simulation) spend per extra digit of accuracy, and "
            "how does that compare with scipy and heyoka?")

L, G = 1.0, 9.81
W0 = math.sqrt(G / L)
DRIVE = dict(A=0.05, g=G, l=L, m=1.0, omega=2 * math.pi * 60)   # the benchmarks' problem
THETA0 = math.pi - 0.1
FLOQUET_FACTOR = 2.0          # |tr M − tr_exact| ≤ FLOQUET_FACTOR · tol (docstring)


def _tag(x):
    """'1em8' for 1e-8: a findings key."""
    return f"1em{-round(math.log10(x))}"


def _log(msg):
    print(f"cost_of_accuracy: {msg}", file=sys.stderr, flush=True)


# -- 1. integrators ------------------------------------------------------------------------

def integrators(quick):
    periods = 20 if quick else 500
    T = periods * 2 * math.pi / DRIVE["omega"]
    rtols = (1e-4, 1e-6, 1e-8, 1e-10) if quick else tuple(10.0 ** -k for k in range(3, 13))
    methods = ("rkn12", "dop853") if quick else ("rkn12", "rkn12-fixed", "dop853")
    # heyoka compiles an integrator per tolerance (≈ 0.3 s each): the full size only
    peers = ("scipy:DOP853",) if quick else ("scipy:DOP853", "scipy:LSODA", "heyoka")
    return work_precision(problems.driven_pendulum(), [THETA0], [0.0], (0.0, T), DRIVE,
                          methods=methods, rtols=rtols, repeat=1 if quick else 3,
                          peers=peers, max_seconds=0.5 if quick else 1.0)


# -- 2. Floquet against the Mathieu characteristic values ----------------------------------

def _boundary_points(kind, q):
    """(A, ω, exact tr M) on the upright's boundary a = a0(q) (kind "a") or b1(q) ("b")."""
    from kapitza.closed_forms import characteristic_value
    a = characteristic_value(kind, 0 if kind == "a" else 1, q)
    return q * L / 2, 2 * W0 / np.sqrt(-a), 2.0 if kind == "a" else -2.0


def floquet(quick):
    pend = kapitza.KapitzaPendulum(l=L, g=G)
    n = 20 if quick else 1000
    tols = (1e-4, 1e-7, 1e-10) if quick else (1e-4, 1e-5, 1e-6, 1e-7, 1e-8, 1e-9, 1e-10,
                                               1e-11, 1e-12)
    rows = []
    for kind, qs, name in (("a", np.linspace(0.05, 0.4, n), "a0(q): Kapitza limit, tr M = +2"),
                           ("b", np.linspace(0.95, 1.3, n), "b1(q): parametric, tr M = −2")):
        A, omega, exact = _boundary_points(kind, qs)
        params = dict(pend.params(A, omega))
        for tol in tols:
            def grid(params=params, tol=tol):
                return kapitza.floquet_grid(pend.system, params, [math.pi], tol=tol,
                                            progress=False)
            grid()
            sec, res = best_time(grid, 1 if quick else 3)
            norm = np.max(np.abs(res.monodromy_scaled), axis=(-2, -1))
            rows.append(dict(panel="floquet", kind=kind, method=f"floquet_grid, {name}",
                             setting=tol,
                             error=float(np.max(np.abs(res.trace - exact))),
                             seconds_per_point=sec / n, points=n,
                             norm=float(np.max(np.maximum(1.0, norm)))))
        # one call per point: what the fixed cost of a call adds
        k = n // 2
        for tol in tols:
            def one(a_k=float(A[k]), w_k=float(omega[k]), tol=tol):
                return pend.floquet(a_k, w_k, tol=tol)
            one()
            sec, res = best_time(one, 3)
            rows.append(dict(panel="floquet", kind=kind,
                             method=f"KapitzaPendulum.floquet, one {kind}-boundary point",
                             setting=tol, error=abs(res.trace - exact),
                             seconds_per_point=sec, points=1,
                             norm=float(max(1.0, np.max(np.abs(res.monodromy_scaled))))))
    return pd.DataFrame(rows)


# -- 3. averaging orders against Floquet ----------------------------------------------------

def averaging(quick):
    pend = kapitza.KapitzaPendulum(l=L, g=G)
    n = 40 if quick else 400
    ratio = np.geomspace(10, 100, n)
    omega = ratio * W0
    A = 1.5 * math.sqrt(2 * G * L) / omega           # Aω = 1.5 √(2gl): upright stable
    params = dict(pend.params(A, omega))
    exact = kapitza.floquet_grid(pend.system, params, [math.pi], tol=1e-12,
                                 progress=False).omega_slow[..., 0]
    eps = W0 / omega
    rows, per_point = [], {}

    def record(method, setting, omega_slow, sec):
        rel = np.abs(omega_slow / exact - 1)
        per_point[method] = rel
        rows.append(dict(panel="averaging", method=method, setting=setting,
                         error=float(np.median(rel)), error_max=float(np.max(rel)),
                         error_min=float(np.min(rel)), seconds_per_point=sec / n, points=n))

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", kapitza.AveragingValidityWarning)
        for order in (1, 2):
            def closed(order=order):
                r = kapitza.pendulum_averaged(A, omega, l=L, g=G, order=order, warn=False)
                return next(e for e in r.equilibria if e.name == "inverted").omega_slow
            closed()
            sec, w = best_time(closed, 3)
            record(f"averaging, order {order} (closed form)", order, w, sec)
        general = kapitza.average(pend.system)

        def sweep():
            return np.sqrt(general.sweep(params, [math.pi], progress=False)
                           .omega_squared[..., 0])
        sweep()
        sec, w = best_time(sweep, 1)
        record("averaging, order 1 (general: average(system).sweep)", 1, w, sec)
    for tol in ((1e-4, 1e-7) if quick else (1e-3, 1e-4, 1e-5, 1e-6, 1e-7, 1e-8)):
        def fl(tol=tol):
            return kapitza.floquet_grid(pend.system, params, [math.pi], tol=tol,
                                        progress=False).omega_slow[..., 0]
        fl()
        sec, w = best_time(fl, 1 if quick else 3)
        record("Floquet (floquet_grid)", tol, w, sec)
    # the order of first-order averaging: slope of log(error) against log ε
    slope = float(np.polyfit(np.log(eps), np.log(per_point["averaging, order 1 (closed form)"]),
                             1)[0])
    better = bool(np.all(per_point["averaging, order 2 (closed form)"]
                         < per_point["averaging, order 1 (closed form)"]))
    return pd.DataFrame(rows), slope, better


# -- 4. batch simulation -------------------------------------------------------------------

def batch(quick):
    system = problems.driven_pendulum()
    n = 8 if quick else 32
    periods = 50 if quick else 200
    A = np.linspace(0.005, 0.03, n)[:, None]
    omega = 2 * math.pi * np.linspace(30, 60, n)[None, :]
    params = dict(m=1.0, l=L, g=G, A=A, omega=omega)
    span = (0.0, periods * 2 * math.pi / omega)
    band = ([math.pi / 2], [3 * math.pi / 2])

    def run(rtol, method=None):
        return system.simulate_grid([THETA0], [0.0], span, params, method=method, rtol=rtol,
                                    band=band, progress=False)
    ref = run(1e-13)
    cross = run(1e-13, "dop853")
    held = ref.status_name == "finished"
    both = held & (cross.status_name == "finished")
    ref_error = float(np.max(np.abs(ref.q[..., 0] - cross.q[..., 0])[both]))
    cross_misclassified = int(np.sum(ref.status != cross.status))
    rows = []
    rtols = (1e-4, 1e-7, 1e-10) if quick else tuple(10.0 ** -k for k in range(3, 13))
    for rtol in rtols:
        run(rtol)
        sec, g = best_time(lambda rtol=rtol: run(rtol), 1 if quick else 3)
        stayed = held & (g.status_name == "finished")
        err = np.abs(g.q[..., 0] - ref.q[..., 0])[stayed]
        rows.append(dict(panel="batch", method="simulate_grid (one compiled parallel call)",
                         setting=rtol, error=float(err.max()), error_median=float(np.median(err)),
                         seconds_per_point=sec / held.size, points=held.size,
                         misclassified=int(np.sum(g.status != ref.status))))
    # the same points one call each (a subset: every 4th along each axis)
    sub = [(float(A[i, 0]), float(omega[0, j])) for i in range(0, n, 4) for j in range(0, n, 4)]
    for rtol in rtols[::2] if not quick else rtols:
        def loop(rtol=rtol):
            for a, w in sub:
                system.simulate([THETA0], [0.0], (0.0, periods * 2 * math.pi / w),
                                dict(m=1.0, l=L, g=G, A=a, omega=w), rtol=rtol, stride=10**9)
        loop()
        sec, _ = best_time(loop, 1 if quick else 3)
        rows.append(dict(panel="batch", method="System.simulate, one call per point",
                         setting=rtol, error=math.nan, seconds_per_point=sec / len(sub),
                         points=len(sub)))
    return pd.DataFrame(rows), ref_error, cross_misclassified, int(held.sum()), held.size


# -- the study -----------------------------------------------------------------------------

def run(out, quick=False):
    start = time.perf_counter()
    _log("integrators …")
    wp = integrators(quick)
    _log(f"floquet … ({time.perf_counter() - start:.0f} s)")
    fq = floquet(quick)
    _log(f"averaging … ({time.perf_counter() - start:.0f} s)")
    av, slope, order2_better = averaging(quick)
    _log(f"batch … ({time.perf_counter() - start:.0f} s)")
    bt, batch_ref_error, batch_ref_mis, n_held, n_points = batch(quick)

    integ = wp.to_dataframe().rename(columns=dict(rtol="setting", seconds="seconds_per_point"))
    integ.insert(0, "panel", "integrators")
    table = pd.concat([integ, fq, av, bt], ignore_index=True)
    write_table(table, out, "cost_of_accuracy")
    save_figure(figure(wp, fq, av, bt, batch_ref_error), out, "cost_of_accuracy", quick=quick)

    f = {}
    f["integrator_span_s"] = round(wp.t_span[1], 4)
    f["integrator_reference_error"] = wp.reference_error
    f["heyoka"] = "ran" if "heyoka" in wp.methods else "not installed"
    for level in (1e-6, 1e-8, 1e-10):
        reach = wp.time_to_reach(level)
        tag = _tag(level)
        for name in wp.methods:
            f[f"time_to_{tag}_{name.replace(':', '_')}_ms"] = reach[name] * 1e3
        for peer in ("scipy:DOP853", "heyoka"):
            if peer in reach:
                f[f"ratio_{tag}_{peer.replace(':', '_')}_over_rkn12"] = \
                    reach[peer] / reach["rkn12"]
    for name in wp.methods:                  # the band check: worst error / rtol, resolved
        sel = (wp.method == name) & wp.resolved
        f[f"worst_error_over_rtol_{name.replace(':', '_')}"] = \
            float(np.max(wp.error[sel] / wp.rtol[sel])) if sel.any() else math.nan
        f[f"error_drop_{name.replace(':', '_')}"] = \
            float(wp.error[wp.method == name][0] / max(wp.error[wp.method == name][-1], 1e-300))
    grid = fq[fq.points > 1]
    f["floquet_worst_error_over_tol"] = float(np.max(grid.error / grid.setting))
    f["floquet_grid_us_per_point_tol_1e-4"] = 1e6 * float(grid[grid.setting == 1e-4]
                                                             .seconds_per_point.mean())
    f["floquet_grid_us_per_point_tol_1e-10"] = 1e6 * float(grid[grid.setting == 1e-10]
                                                              .seconds_per_point.mean())
    single = fq[fq.points == 1]
    f["floquet_single_call_ms"] = 1e3 * float(single.seconds_per_point.median())
    f["floquet_error_drop"] = float(grid[grid.setting == grid.setting.max()].error.max()
                                    / grid[grid.setting == grid.setting.min()].error.max())
    for label, key in (("averaging, order 1 (closed form)", "order1"),
                       ("averaging, order 2 (closed form)", "order2"),
                       ("averaging, order 1 (general: average(system).sweep)", "general")):
        r = av[av.method == label].iloc[0]
        f[f"averaging_{key}_median_rel_error"] = r.error
        f[f"averaging_{key}_max_rel_error"] = r.error_max
        f[f"averaging_{key}_us_per_point"] = 1e6 * r.seconds_per_point
    fl = av[av.method.str.startswith("Floquet")]
    f["averaging_floquet_us_per_point_loosest"] = 1e6 * float(fl.seconds_per_point.iloc[0])
    f["averaging_floquet_median_rel_error_loosest"] = float(fl.error.iloc[0])
    f["averaging_order1_slope_in_eps"] = slope
    f["averaging_order2_better_everywhere"] = order2_better
    f["averaging_floquet_error_drop"] = float(fl.error.iloc[0] / max(fl.error.iloc[-1], 1e-300))
    g = bt[bt.method.str.startswith("simulate_grid")]
    lp = bt[bt.method.str.startswith("System.simulate")]
    f["batch_points"] = n_points
    f["batch_points_held"] = n_held
    f["batch_reference_error"] = batch_ref_error
    f["batch_reference_misclassified"] = batch_ref_mis
    for _, r in g.iterrows():
        tag = _tag(r.setting)
        f[f"batch_points_per_s_{tag}"] = 1.0 / r.seconds_per_point
        f[f"batch_max_error_{tag}"] = r.error
        f[f"batch_misclassified_{tag}"] = int(r.misclassified)
    resolved = g.error > 10 * batch_ref_error
    f["batch_worst_error_over_rtol"] = float(np.max(g.error[resolved] / g.setting[resolved]))
    f["batch_worst_median_error_over_rtol"] = float(np.max(g.error_median[resolved]
                                                           / g.setting[resolved]))
    f["batch_misclassified_tightest"] = int(g.misclassified.iloc[-1])
    f["batch_error_drop"] = float(g.error.iloc[0] / max(g.error.iloc[-1], 1e-300))
    common = sorted(set(g.setting) & set(lp.setting))
    ratios = [float(lp[lp.setting == s].seconds_per_point.iloc[0]
                    / g[g.setting == s].seconds_per_point.iloc[0]) for s in common]
    f["batch_speedup_over_loop_min"] = min(ratios)
    f["batch_speedup_over_loop_max"] = max(ratios)
    return f


def figure(wp, fq, av, bt, batch_ref_error):
    from matplotlib.figure import Figure

    from kapitza.figures import work_precision_figure
    fig = Figure(figsize=(13.5, 10.5))
    fig.subplots_adjust(left=0.07, right=0.98, bottom=0.06, top=0.92, wspace=0.2, hspace=0.3)
    axes = fig.subplots(2, 2)
    work_precision_figure(wp, ax=axes[0, 0])
    axes[0, 0].set_title(f"1. Integrators: driven pendulum, {wp.t_span[1]:.2f} s "
                         f"({wp.t_span[1] * DRIVE['omega'] / (2 * math.pi):.0f} drive periods)"
                         "\npoint labels: log₁₀ rtol", fontsize=9)

    ax = axes[0, 1]
    for k, kind in enumerate(("a", "b")):
        for name, d in fq[fq.kind == kind].groupby("method", sort=False):
            d = d.sort_values("setting", ascending=False)
            single = d.points.iloc[0] == 1
            ax.loglog(d.seconds_per_point, d.error, "--" if single else "-", marker="o", ms=4,
                      color=f"C{k}", label=name)
            for x, y, s in zip(d.seconds_per_point, d.error, d.setting, strict=True):
                ax.annotate(f"{np.log10(s):.0f}", (x, y), textcoords="offset points",
                            xytext=(4, 3), fontsize=6.5, color=f"C{k}")
    ax.grid(True, lw=0.4, alpha=0.5)
    tols = np.array(sorted(fq.setting.unique()))
    ax.set_xlabel("seconds per point (best of repeats, compile excluded)")
    ax.set_ylabel("|tr M − tr M_exact|  (exact ±2 from a0(q), b1(q))")
    ax.set_title("2. Floquet: the upright pendulum on its Mathieu boundaries\n"
                 f"point labels: log₁₀ tol ({tols.min():.0e}…{tols.max():.0e}); solid: "
                 f"a grid of {int(fq.points.max())} points, dashed: one call", fontsize=9)
    ax.legend(fontsize=7, loc="upper center")

    ax = axes[1, 0]
    for k, (name, d) in enumerate(av.groupby("method", sort=False)):
        c = f"C{k}"
        yerr = np.vstack([d.error - d.error_min, d.error_max - d.error])
        ax.errorbar(d.seconds_per_point, d.error, yerr=yerr, fmt="o-" if len(d) > 1 else "s",
                    color=c, ms=5, capsize=3, lw=1, label=name)
        if name.startswith("Floquet"):
            for x, y, s in zip(d.seconds_per_point, d.error, d.setting, strict=True):
                ax.annotate(f"{np.log10(s):.0f}", (x, y), textcoords="offset points",
                            xytext=(5, 3), fontsize=6.5, color=c)
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.grid(True, lw=0.4, alpha=0.5)
    ax.set_xlabel("seconds per point")
    ax.set_ylabel("relative error of the upright's slow Ω\nagainst Floquet (tol 1e-12): "
                  "median, bars min…max")
    ax.set_title("3. Averaging orders against Floquet: ω/ω0 = 10…100, Aω = 1.5√(2gl)\n"
                 "Floquet point labels: log₁₀ tol", fontsize=9)
    ax.legend(fontsize=7, loc="lower left")

    ax = axes[1, 1]
    g = bt[bt.method.str.startswith("simulate_grid")].sort_values("setting", ascending=False)
    lp = bt[bt.method.str.startswith("System.simulate")].sort_values("setting",
                                                                     ascending=False)
    ax.loglog(g.seconds_per_point, g.error, "o-", color="C0", ms=4,
              label="max |θ(T) − θ_ref(T)| over the points that stayed up")
    ax.loglog(g.seconds_per_point, g.error_median, "o:", color="C0", ms=3, mfc="white",
              label="median")
    last = None
    for x, y, s, m in zip(g.seconds_per_point, g.error, g.setting, g.misclassified, strict=True):
        if last is not None and np.isclose(y, last[1], rtol=0.05, atol=0):
            continue                # the same error as the looser tolerance: one label
        same = g.setting[np.isclose(g.error, y, rtol=0.05, atol=0)]
        text = f"{np.log10(s):.0f}" + (f"…{np.log10(same.min()):.0f}" if len(same) > 1 else "")
        ax.annotate(text + (f" ({m} wrong)" if m else ""), (x, y),
                    textcoords="offset points", xytext=(4, 3), fontsize=6.5, color="C0")
        last = (x, y)
    ax.axhline(10 * batch_ref_error, color="k", ls=":", lw=0.8,
               label=f"10 × the reference's own error ({batch_ref_error:.1e}; below: "
                     "not resolved)")
    for x, s in zip(lp.seconds_per_point, lp.setting, strict=True):
        ax.axvline(x, color="C3", lw=0.8, ls="--")
        ax.annotate(f"rtol {s:.0e}", (x, 0.97), xycoords=("data", "axes fraction"),
                    textcoords="offset points", xytext=(2, 0), rotation=90, fontsize=6.5,
                    color="C3", va="top")
    ax.plot([], [], "--", color="C3", lw=0.8,
            label=f"System.simulate, one call per point ({int(lp.points.iloc[0])} of the "
                  "points): seconds per point")
    ax.grid(True, lw=0.4, alpha=0.5)
    n = int(g.points.iloc[0])
    from matplotlib.ticker import NullFormatter
    ax.xaxis.set_minor_formatter(NullFormatter())     # a short axis: minor labels collide
    ax.set_xlabel("seconds per point (wall time of the grid call / points)")
    ax.set_ylabel("error at the final time (rad)")
    ax.set_title(f"4. Batch simulation: simulate_grid over {n} (A, ω) points\n"
                 "labels: log₁₀ rtol (and points whose fell/held is wrong)", fontsize=9)
    ax.legend(fontsize=7, loc="lower left")
    fig.suptitle("What accuracy costs in time (down and left is better; compile excluded)",
                 fontsize=11)
    return fig


def check(f, quick):
    # 1. integrators
    assert f["integrator_reference_error"] < 1e-11, f["integrator_reference_error"]
    for key, value in f.items():
        if key.startswith("error_drop_"):
            assert value > 100, (key, value)
    assert f["worst_error_over_rtol_rkn12"] <= 10, f["worst_error_over_rtol_rkn12"]
    for name in ("dop853", "scipy_DOP853"):
        assert f[f"worst_error_over_rtol_{name}"] <= 1000, (name, f)
    # the default reaches 1e-6 faster than scipy's DOP853, and 1e-8 too (or scipy never did)
    assert f["time_to_1em6_rkn12_ms"] < f["time_to_1em6_scipy_DOP853_ms"]
    assert not f["time_to_1em8_scipy_DOP853_ms"] <= f["time_to_1em8_rkn12_ms"]
    # 2. Floquet against the Mathieu characteristic values
    assert f["floquet_worst_error_over_tol"] <= FLOQUET_FACTOR, f["floquet_worst_error_over_tol"]
    assert f["floquet_error_drop"] > 1e4
    # 3. averaging: order 1 misses by O(ε²), order 2 by less
    assert abs(f["averaging_order1_slope_in_eps"] - 2) < 0.3, f["averaging_order1_slope_in_eps"]
    assert f["averaging_order2_better_everywhere"]
    assert f["averaging_order2_max_rel_error"] < f["averaging_order1_max_rel_error"] / 10
    # the general averaging is the same first-order physics as the closed form
    assert math.isclose(f["averaging_general_median_rel_error"],
                        f["averaging_order1_median_rel_error"], rel_tol=1e-6)
    assert f["averaging_floquet_error_drop"] > 100
    # 4. batch
    assert f["batch_reference_error"] < 1e-9 and f["batch_reference_misclassified"] == 0
    assert f["batch_misclassified_tightest"] == 0
    assert f["batch_worst_median_error_over_rtol"] <= 1, f["batch_worst_median_error_over_rtol"]
    assert f["batch_worst_error_over_rtol"] <= 100, f["batch_worst_error_over_rtol"]
    assert f["batch_error_drop"] > 100
    assert 0 < f["batch_points_held"] < f["batch_points"]


if __name__ == "__main__":
    sys.exit(main(Path(__file__).stem, run))     # __name__ is "__main__" here
