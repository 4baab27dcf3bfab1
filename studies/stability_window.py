"""The stability window of the inverted pendulum: exact against averaging, with damping.

Question
--------
Between which amplitudes A_min < A < A_max does a vertically shaken pivot hold the pendulum
upright, as a function of ω/ω0, and where (and by how much) do first-order and corrected
averaging get those limits wrong?

Method
------
*Exact*: the linearised upright pendulum is the Mathieu equation y″ + (a − 2q cos 2τ) y = 0
with a = −4ω0²/ω², q = 2A/l (shared/PHYSICS.md), and the window is a0(q) < a < b1(q):
``KapitzaPendulum.window`` finds both roots of the characteristic curves and certifies them
(relative accuracy ≤ 1e-10).  With damping γ the edges are |tr M| = 1 + e^(−γT), found on
the integrated monodromy trace.  *Averaging*: ``KapitzaPendulum.window(method="averaging")`` —
order 1 is the Kapitza limit A_min = √(2 g l)/ω with no upper limit at all; order 2 adds the
next term (A²ω²(1 − 7A²/16l²) ≈ 2gl) and the parametric resonance a′ = b1(q) as A_max.
Damping rates γ/ω0 = 0, 0.1, 0.5 and 2 (underdamped to overdamped undriven pendulum).

Independent checks (``check``): the exact edges against scipy's characteristic values
(``scipy.special.mathieu_a``/``mathieu_b``, bracketed root-finding) at moderate q; the
Floquet analysis of the nonlinear system's own Jacobian (``KapitzaPendulum.floquet``, an
integrated monodromy) just inside and just outside every edge, damped and undamped; and
the approach of averaging to the exact edge at the theory's rate: expanding a0(q) =
−q²/2 + 7q⁴/128 gives A_min/l = √2 ε (1 + 7ε²/16 + …), ε = ω0/ω, so first-order averaging's
relative error is −(7/16) ε² (slope 2 in log–log), and order 2's falls faster (slope ≈ 4).
Damping: y = e^(−cτ/2) z turns the damped equation (c = 2γ/ω) into an undamped one with
a′ = a − c²/4, stable while z grows by less than e^(cτ/2); at the lower edge the two shifts
cancel at first order (the averaged Ω² does not depend on γ), and the next term of
ν²(a′, q) = a′ + q²/2 + a′q²/2 + … gives ΔA_min/A_min = (γ/ω)²/2, also checked.

Everything here is in units of l and ω0 (l = 1 m, g = 9.81 m/s²; the results scale).
"""
from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import scipy.optimize
import scipy.special

import kapitza

from _common import layout, main, save_figure, write_table

QUESTION = ("Between which drive amplitudes A_min < A < A_max is the inverted pendulum stable "
            "for ω/ω0 from 1 to 1000, and where and by how much do first-order and corrected "
            "averaging miss these limits, with and without damping?")

L, G = 1.0, 9.81
W0 = math.sqrt(G / L)
GAMMAS = (0.0, 0.1, 0.5, 2.0)          # γ/ω0
#: ε = ω0/ω range for the convergence fits (well inside averaging's regime)
FIT_RANGE = (30.0, 1000.0)


def _log(msg):
    print(f"stability_window: {msg}", file=sys.stderr, flush=True)


# -- the computation ------------------------------------------------------------------------

def windows(ratios, gamma_ratio):
    """Exact and averaged (order 1, 2) windows at ω/ω0 = ``ratios`` for damping γ/ω0, as rows."""
    pend = kapitza.KapitzaPendulum(l=L, g=G, damping=gamma_ratio * W0)
    omega = np.asarray(ratios) * W0
    exact = pend.window(omega)
    rows = [dict(method="exact", A_min=exact.A_min, A_max=exact.A_max,
                 accuracy=exact.accuracy)]
    for order in (1, 2):
        avg = pend.window(omega, method="averaging", order=order)
        rows.append(dict(method=f"averaging order {order}", A_min=avg.A_min, A_max=avg.A_max,
                         accuracy=np.full(omega.size, np.nan)))
    frames = [pd.DataFrame(dict(omega_ratio=ratios, gamma_ratio=gamma_ratio,
                                A_min_l=r["A_min"] / L, A_max_l=r["A_max"] / L,
                                certified_accuracy=r["accuracy"], method=r["method"]))
              for r in rows]
    return pd.concat(frames, ignore_index=True)


def _edge(ratio, which, method="exact", order=2, gamma_ratio=0.0):
    """One edge (A/l) at one ω/ω0: exact or averaged."""
    pend = kapitza.KapitzaPendulum(l=L, g=G, damping=gamma_ratio * W0)
    if method == "exact":
        win = pend.window(ratio * W0)
    else:       # warn=False: we go outside averaging's regime on purpose, to see it fail
        win = kapitza.pendulum_window(ratio * W0, l=L, g=G, damping=pend.damping,
                                      method="averaging", order=order, warn=False)
    return getattr(win, which) / L


def crossing(error, threshold, lo=1.0, hi=1000.0):
    """The ω/ω0 where |error(ω/ω0)| falls through ``threshold`` (error decreasing in ω)."""
    f = lambda lr: abs(error(math.exp(lr))) - threshold      # noqa: E731
    if f(math.log(hi)) > 0 or f(math.log(lo)) < 0:
        return float("nan")
    return math.exp(scipy.optimize.brentq(f, math.log(lo), math.log(hi), xtol=1e-7))


def scipy_window(ratio):
    """Independent exact window (A/l) from scipy's characteristic values: a0(q) = a, b1(q) = a."""
    a = -4.0 / ratio**2
    q0 = scipy.optimize.brentq(lambda q: scipy.special.mathieu_a(0, q) - a, 1e-6, 6.0,
                               xtol=1e-14, rtol=1e-14)
    q1 = scipy.optimize.brentq(lambda q: scipy.special.mathieu_b(1, q) - a, 1e-6, 6.0,
                               xtol=1e-14, rtol=1e-14)
    return q0 / 2, q1 / 2


def floquet_sides(ratios, gamma_ratio, rel=1e-4):
    """Floquet analysis of the pendulum's own Jacobian at A·(1 ∓ rel) around each exact edge:
    the number of points classified as the window says (stable inside, unstable outside)."""
    pend = kapitza.KapitzaPendulum(l=L, g=G, damping=gamma_ratio * W0)
    right = total = 0
    for r in ratios:
        win = pend.window(r * W0)
        for edge, inside in ((win.A_min, 1 + rel), (win.A_max, 1 - rel)):
            for factor, expect in ((inside, True), (2 - inside, False)):
                res = pend.floquet(A=edge * factor, omega=r * W0, about="inverted")
                right += bool(res.stable) == expect
                total += 1
    return right, total


def slope_fit(ratios, rel_err):
    """Least-squares |rel_err| = C ε^p in log–log, ε = 1/ratio."""
    eps = 1 / np.asarray(ratios)
    p, logc = np.polyfit(np.log(eps), np.log(np.abs(rel_err)), 1)
    return float(p), float(math.exp(logc))


# -- the study -----------------------------------------------------------------------------

def run(out: Path, quick: bool = False) -> dict:
    n = 48 if quick else 400
    ratios = np.geomspace(1.0, 1000.0, n)
    damped_ratios = ratios[:: (6 if quick else 2)]
    gammas = (0.0, 2.0) if quick else GAMMAS
    _log(f"exact and averaged windows at {n} frequencies, γ/ω0 = {gammas}")
    frames = [windows(ratios if g == 0 else damped_ratios, g) for g in gammas]
    table = pd.concat(frames, ignore_index=True)
    write_table(table, out, "stability_window")

    und = table[table.gamma_ratio == 0]
    ex = und[und.method == "exact"].set_index("omega_ratio")
    a1 = und[und.method == "averaging order 1"].set_index("omega_ratio")
    a2 = und[und.method == "averaging order 2"].set_index("omega_ratio")
    f = {}
    f["omega_ratio_range"] = f"{ratios[0]:g} to {ratios[-1]:g} ({n} frequencies)"
    f["exact_window_at_every_omega"] = bool(np.all(np.isfinite(ex.A_min_l)
                                                   & np.isfinite(ex.A_max_l)))
    f["max_certified_accuracy"] = float(np.nanmax(table.certified_accuracy))
    for r in (1.0, 3.0, 10.0, 100.0, 1000.0):
        f[f"exact_A_min_l_at_{r:g}"] = _edge(r, "A_min")
        f[f"exact_A_max_l_at_{r:g}"] = _edge(r, "A_max")

    # -- lower limit: where averaging errs by 1 % and 10 % ------------------------------------
    _log("where averaging's limits err by 1 % and 10 %")
    for order in (1, 2):
        err = lambda r, o=order: _edge(r, "A_min", "averaging", o) / _edge(r, "A_min") - 1  # noqa
        for pct in (1, 10):
            f[f"A_min_order{order}_error_above_{pct}pct_below_omega_ratio"] = crossing(
                err, pct / 100)
        f[f"A_min_order{order}_error_at_3"] = err(3.0)
        f[f"A_min_order{order}_error_at_10"] = err(10.0)
    # the exact window never closes on this range; it only narrows towards ω ≈ ω0
    for r in (1.0, 2.0, 3.0):
        f[f"exact_window_relative_width_at_{r:g}"] = _edge(r, "A_max") / _edge(r, "A_min") - 1
    f["order2_frequencies_without_window"] = int(np.sum(~np.isfinite(a2.A_min_l.to_numpy())))

    # -- upper limit ------------------------------------------------------------------------------
    q_inf = scipy.optimize.brentq(lambda q: scipy.special.mathieu_b(1, q), 0.5, 1.5, xtol=1e-14)
    f["A_max_l_high_frequency_limit_scipy"] = q_inf / 2
    f["A_max_order1"] = "inf (first order has no upper limit)"
    asym = lambda r: (q_inf / 2) / _edge(r, "A_max") - 1                        # noqa: E731
    for pct in (1, 10):
        f[f"A_max_asymptote_error_above_{pct}pct_below_omega_ratio"] = crossing(asym, pct / 100)
    f["A_max_asymptote_error_at_3"] = asym(3.0)
    ok = np.isfinite(a2.A_max_l.to_numpy())
    f["A_max_order2_max_rel_error_undamped"] = float(
        np.max(np.abs(a2.A_max_l.to_numpy()[ok] / ex.A_max_l.to_numpy()[ok] - 1)))

    # -- convergence at the theory's rate ---------------------------------------------------------
    sel = (ex.index >= FIT_RANGE[0]) & (ex.index <= FIT_RANGE[1])
    r_fit = ex.index[sel].to_numpy()
    e1 = a1.A_min_l.to_numpy()[sel] / ex.A_min_l.to_numpy()[sel] - 1
    e2 = a2.A_min_l.to_numpy()[sel] / ex.A_min_l.to_numpy()[sel] - 1
    f["order1_error_slope"], c1 = slope_fit(r_fit, e1)
    f["order1_error_coefficient_over_7_16"] = c1 / (7 / 16)
    f["order1_error_sign"] = "below exact" if np.all(e1 < 0) else "mixed"
    f["order2_error_slope"], _ = slope_fit(r_fit[r_fit <= 100], e2[r_fit <= 100])
    f["A_min_times_omega_over_sqrt2gl_at_1000"] = _edge(1000.0, "A_min") * 1000.0 / math.sqrt(2)

    # -- damping ---------------------------------------------------------------------------------
    for g in gammas[1:]:
        for r in (3.0, 10.0, 100.0):
            for which in ("A_min", "A_max"):
                f[f"damping_{g:g}_{which}_shift_at_{r:g}"] = (
                    _edge(r, which, gamma_ratio=g) / _edge(r, which) - 1)
        # at high ω the shifts go as (γ/ω)²: their coefficients at ω/ω0 = 300
        for which in ("A_min", "A_max"):
            f[f"damping_{g:g}_{which}_shift_over_(gamma/omega)^2_at_300"] = (
                (_edge(300.0, which, gamma_ratio=g) / _edge(300.0, which) - 1) / (g / 300.0)**2)
        f[f"damping_{g:g}_order2_A_min_error_at_10"] = (
            _edge(10.0, "A_min", "averaging", 2, g) / _edge(10.0, "A_min", gamma_ratio=g) - 1)
        f[f"damping_{g:g}_order2_A_max_error_at_10"] = (
            _edge(10.0, "A_max", "averaging", 2, g) / _edge(10.0, "A_max", gamma_ratio=g) - 1)

    # -- independent checks -----------------------------------------------------------------------
    _log("checks: scipy characteristic values, Floquet beside every edge")
    diffs = []
    for r in (4.0, 8.0, 20.0, 60.0):
        lo, hi = scipy_window(r)
        diffs += [abs(_edge(r, "A_min") / lo - 1), abs(_edge(r, "A_max") / hi - 1)]
    f["check_scipy_max_rel_diff"] = max(diffs)
    right = total = 0
    for g in (0.0, 0.5):
        ok_, n_ = floquet_sides((5.0, 30.0) if quick else (3.0, 5.0, 30.0, 300.0), g)
        right, total = right + ok_, total + n_
    f["check_floquet_sides_right"] = right
    f["check_floquet_sides_total"] = total

    save_figure(figure(table, q_inf / 2, quick), out, "stability_window", quick=quick)
    return f


def figure(table, a_inf, quick=False):
    import matplotlib.pyplot as plt
    fig, (ax, bx, cx) = plt.subplots(1, 3, figsize=(16, 5.2))
    und = table[table.gamma_ratio == 0]
    ex = und[und.method == "exact"]
    a1 = und[und.method == "averaging order 1"]
    a2 = und[und.method == "averaging order 2"]
    r = ex.omega_ratio.to_numpy()
    ax.fill_between(r, ex.A_min_l, ex.A_max_l, color="0.85", label="exact window (γ = 0)")
    ax.plot(r, ex.A_min_l, "k-", lw=1.6, label="exact edges")
    ax.plot(r, ex.A_max_l, "k-", lw=1.6)
    ax.plot(a1.omega_ratio, a1.A_min_l, "r--", lw=1.4,
            label="averaging order 1: √2 ω0/ω (no A_max)")
    ax.plot(a2.omega_ratio, a2.A_min_l, "b:", lw=2, label="averaging order 2")
    ax.plot(a2.omega_ratio, a2.A_max_l, "b:", lw=2)
    ax.axhline(a_inf, color="tab:green", lw=1, ls="-.", label=f"A_max → {a_inf:.4f} l (ω → ∞)")
    d = table[(table.gamma_ratio == 2.0) & (table.method == "exact")]
    ax.plot(d.omega_ratio, d.A_min_l, color="tab:purple", lw=1, ls="--",
            label="exact edges, γ/ω0 = 2")
    ax.plot(d.omega_ratio, d.A_max_l, color="tab:purple", lw=1, ls="--")
    ax.set(xscale="log", yscale="log", xlabel="ω/ω0", ylabel="A/l",
           title="(a) the upright window", ylim=(1e-3, 8))
    ax.legend(fontsize=8, loc="upper right")

    e1 = np.abs(a1.A_min_l.to_numpy() / ex.A_min_l.to_numpy() - 1)
    e2 = np.abs(a2.A_min_l.to_numpy() / ex.A_min_l.to_numpy() - 1)
    ea = np.abs(a_inf / ex.A_max_l.to_numpy() - 1)
    bx.loglog(r, e1, "r-", label="A_min, order 1")
    bx.loglog(r, 7 / 16 / r**2, "r:", lw=1, label="(7/16)(ω0/ω)²")
    bx.loglog(r, np.where(e2 > 0, e2, np.nan), "b-", label="A_min, order 2")
    bx.loglog(r, ea, "g-", label=f"A_max: the ω→∞ value {a_inf:.4f} l")
    e2max = np.abs(a2.A_max_l.to_numpy() / ex.A_max_l.to_numpy() - 1)
    # below ω/ω0 ≈ 6 (q > 1) order 2 takes b1 itself: equal to rounding, nothing to draw
    bx.loglog(r, np.where(e2max > 1e-11, e2max, np.nan), "c-", lw=1,
              label="A_max, order 2 (b1 series; exact b1 below ω/ω0 ≈ 6)")
    for y in (0.01, 0.1):
        bx.axhline(y, color="0.6", lw=0.7, ls="--")
    bx.set(xlabel="ω/ω0", ylabel="|averaged / exact − 1|", title="(b) averaging's relative error",
           ylim=(1e-13, 2))
    bx.legend(fontsize=8, loc="lower left")

    styles = {0.1: "tab:blue", 0.5: "tab:orange", 2.0: "tab:purple"}
    for g, c in styles.items():
        d = table[(table.gamma_ratio == g) & (table.method == "exact")]
        if d.empty:
            continue
        base = ex.set_index("omega_ratio").loc[d.omega_ratio]
        cx.loglog(d.omega_ratio, np.abs(d.A_min_l.to_numpy() / base.A_min_l.to_numpy() - 1),
                  color=c, ls="-", label=f"A_min, γ/ω0 = {g:g}")
        cx.loglog(d.omega_ratio, np.abs(d.A_max_l.to_numpy() / base.A_max_l.to_numpy() - 1),
                  color=c, ls="--", label=f"A_max, γ/ω0 = {g:g}")
    cx.set(xlabel="ω/ω0", ylabel="|edge(γ) / edge(0) − 1|",
           title="(c) damping's shift of the exact edges (both move up)")
    cx.legend(fontsize=8, loc="lower left", ncol=2)
    layout(fig, quick)
    return fig


def check(findings: dict, quick: bool) -> None:
    f = findings
    # the exact window against scipy's characteristic values (independent root-finding)
    assert f["check_scipy_max_rel_diff"] < 1e-8, f["check_scipy_max_rel_diff"]
    # the integrated monodromy of the pendulum's Jacobian agrees on both sides of every edge
    assert f["check_floquet_sides_right"] == f["check_floquet_sides_total"] > 0
    assert f["max_certified_accuracy"] <= 1e-9
    # averaging converges to exact at the theory's rate: −(7/16) ε², then faster at order 2
    assert abs(f["order1_error_slope"] - 2) < 0.01, f["order1_error_slope"]
    assert abs(f["order1_error_coefficient_over_7_16"] - 1) < 0.01
    assert f["order1_error_sign"] == "below exact"
    assert f["order2_error_slope"] > 3.5, f["order2_error_slope"]
    assert abs(f["A_min_times_omega_over_sqrt2gl_at_1000"] - 1) < 1e-6
    # the upper limit tends to the root of b1(q) = 0 (scipy), q = 0.9080...
    assert abs(f["exact_A_max_l_at_1000"] / f["A_max_l_high_frequency_limit_scipy"] - 1) < 1e-5
    assert abs(f["A_max_l_high_frequency_limit_scipy"] - 0.45402) < 1e-4
    # first order errs by > 1 % below ω/ω0 ≈ 6.6 (7ε²/16 = 0.01 → ω/ω0 = 6.61)
    assert 6.0 < f["A_min_order1_error_above_1pct_below_omega_ratio"] < 7.2
    # damping: at first order the upright's Ω² does not depend on γ, so A_min barely moves;
    # the next order of ν²(a − c²/4, q) = −c²/4 (c = 2γ/ω) gives ΔA_min/A_min = (γ/ω)²/2
    damped = [k for k in f if k.endswith("_A_min_shift_over_(gamma/omega)^2_at_300")]
    assert damped
    for key in damped:
        assert abs(f[key] - 0.5) < 2e-3, (key, f[key])
        g = key.split("_")[1]
        assert f[f"damping_{g}_A_max_shift_at_10"] > 0       # damping widens the window


if __name__ == "__main__":
    sys.exit(main(Path(__file__).stem, run))     # __name__ is "__main__" here
