"""Figures of curves against one variable: the effective potential, the error of averaging's
window, slow frequencies and the tilted state against A, work against precision.
"""
from __future__ import annotations

import textwrap
from typing import TYPE_CHECKING

import numpy as np

from ._common import STABILITY_WINDOW, axes, fit_title, require, window_label

if TYPE_CHECKING:
    from ..results import PendulumAveraging, StabilityWindow

__all__ = ["effective_potential_figure", "window_error_figure", "slow_frequency_line_figure",
           "tilt_figure", "work_precision_figure"]

_LINE_STYLES = ("--", ":", "-.", "-")


def effective_potential_figure(theta, potential, *, prediction: PendulumAveraging | None = None,
                               ax=None, title=None, xlabel=None, ylabel=None, label=None,
                               angle=True):
    """The effective potential U_eff(θ)/m with the averaged equilibria marked.

    Parameters
    ----------
    theta, potential : array
        Angles (rad, from the downward vertical) and U_eff/m there (J/kg), e.g. from
        :func:`kapitza.pendulum_effective_potential` at one (A, ω).
    prediction : kapitza.results.PendulumAveraging, optional
        From :func:`kapitza.pendulum_averaged` at the same scalar (A, ω): its equilibria
        are marked on the curve (filled: stable, open: unstable), with their names.
    ax : matplotlib Axes, optional
    title : str, optional
        Wrapped to the figure's width.
    xlabel, ylabel, label : str, optional
        The axes' labels and the curve's legend entry, for a coordinate other than the
        pendulum's angle or a potential not per unit mass.
    angle : bool
        The coordinate is an angle (rad): ticks at multiples of π/2; else plain numbers.

    Returns
    -------
    matplotlib.figure.Figure

    Examples
    --------
    >>> import numpy as np
    >>> from kapitza import pendulum_averaged, pendulum_effective_potential
    >>> theta = np.linspace(-np.pi, 2 * np.pi, 600)
    >>> U = pendulum_effective_potential(A=0.05, omega=2 * np.pi * 60, theta=theta)
    >>> prediction = pendulum_averaged(0.05, 2 * np.pi * 60)
    >>> fig = effective_potential_figure(theta, U, prediction=prediction)
    >>> sorted({t.get_text() for t in fig.axes[0].texts})     # marked (every copy in range)
    ['hanging', 'inverted', 'tilted+', 'tilted-']
    """
    theta = np.asarray(theta, float)
    potential = np.asarray(potential, float)
    if theta.ndim != 1 or potential.shape != theta.shape or theta.size < 2:
        raise ValueError(f"theta and potential must be 1-D arrays of the same length ≥ 2, got "
                         f"shapes {theta.shape} and {potential.shape}; evaluate U_eff at one "
                         "(A, ω) over an array of angles.")
    if prediction is not None:
        require("prediction", prediction, "PendulumAveraging", ("equilibria",),
                "compute one with kapitza.pendulum_averaged at a scalar A and ω")
    fig, ax = axes(ax, (6.4, 4.2))
    ax.plot(theta, potential, color="C0", lw=1.5,
            label=label or "U_eff/m (first-order averaging)")
    if prediction is not None:
        lo, hi = theta.min(), theta.max()
        for eq in prediction.equilibria:
            if not bool(np.all(eq.exists)):
                continue
            th0 = float(np.squeeze(eq.theta))
            for th in th0 + 2 * np.pi * np.arange(-2, 3):       # every copy in the range
                if lo <= th <= hi:
                    u = np.interp(th, theta, potential)
                    stable = bool(np.all(eq.stable))
                    ax.plot([th], [u], "o", ms=7, color="C2" if stable else "C3",
                            mfc=None if stable else "white")
                    ax.annotate(eq.name, (th, u), textcoords="offset points", xytext=(0, 8),
                                ha="center", fontsize=8)
    if angle:                     # an angle: ticks at multiples of π/2
        ticks = np.arange(np.ceil(theta.min() / (np.pi / 2)),
                          np.floor(theta.max() / (np.pi / 2)) + 1)
        ax.set_xticks(ticks * np.pi / 2,
                      [{0: "0", 1: "π/2", 2: "π", 3: "3π/2", -1: "−π/2", -2: "−π"}.get(
                          int(k), f"{k / 2:g}π") for k in ticks])
    pad = 0.04 * (theta.max() - theta.min())          # room for the marks' names
    ax.set_xlim(theta.min() - pad, theta.max() + pad)
    ax.margins(y=0.14)
    ax.set_xlabel(xlabel or "θ from the downward vertical (rad)")
    ax.set_ylabel(ylabel or "U_eff / m (J/kg)")
    fit_title(ax, title or "Effective potential (filled: stable, open: unstable)", fontsize=10)
    ax.legend(loc="lower right", fontsize=8)
    return fig


def window_error_figure(exact: StabilityWindow, approximations, *, ax=None, omega0=None,
                        styles=_LINE_STYLES):
    """How far approximate windows' lower edges lie from the exact one, against ω.

    Parameters
    ----------
    exact : kapitza.results.StabilityWindow
        The exact window (``method="floquet"``) on an ω grid.
    approximations : sequence of StabilityWindow
        Averaging windows (order 1, 2) on the same ω grid.
    ax : matplotlib Axes, optional
    omega0 : float, optional
        ω0 = √(g/l): the axis is ω/ω0 when given, else ω (rad/s).
    styles : sequence of str
        The line style of each approximation in turn (matplotlib's: "--", ":", ...), e.g.
        those a map beside it draws them with.

    Draws |A_min(approximation)/A_min(exact) − 1| on log-log axes (first-order
    averaging's error falls as (ω0/ω)², the next order's as (ω0/ω)⁴).

    Returns
    -------
    matplotlib.figure.Figure
    """
    require("exact", exact, "StabilityWindow", STABILITY_WINDOW,
            "compute one with KapitzaPendulum.window")
    fig, ax = axes(ax, (5.2, 4.4))
    w = np.atleast_1d(np.asarray(exact.omega, float))
    x = w / omega0 if omega0 else w
    lo = np.atleast_1d(np.asarray(exact.A_min, float))
    for k, window in enumerate(approximations):
        require("every approximation", window, "StabilityWindow", STABILITY_WINDOW,
                "compute one with KapitzaPendulum.window(omega, method='averaging')")
        approx = np.broadcast_to(np.asarray(window.A_min, float), lo.shape)
        with np.errstate(invalid="ignore", divide="ignore"):
            rel = np.abs(approx / lo - 1)
        ok = np.isfinite(rel) & (rel > 0)
        ax.loglog(x[ok], rel[ok], styles[k % len(styles)], color="k", lw=1.3,
                  label=window_label(window))
    ax.set_xlabel("drive frequency ω/ω0" if omega0 else "drive angular frequency ω (rad/s)")
    ax.set_ylabel("|A_min(averaging) / A_min(exact) − 1|")
    ax.set_title("Error of the averaging window's lower edge", fontsize=10)
    ax.grid(True, which="major", alpha=0.3)
    ax.legend(fontsize=8)
    return fig


def slow_frequency_line_figure(A, curves: dict, *, title=None):
    """Slow frequencies against A by several methods (e.g. the tilted state of the
    horizontal drive): ``curves`` maps a label to Ω (rad/s) at each A (m); a label with
    "measured" is drawn as markers, the others as lines.

    Returns
    -------
    matplotlib.figure.Figure
    """
    A = np.asarray(A, float)
    fig, ax = axes(None, (6.4, 4.4))
    for k, (label, values) in enumerate(curves.items()):
        values = np.asarray(values, float)
        if values.shape != A.shape:
            raise ValueError(f"curve {label!r} has shape {values.shape}, A has {A.shape}.")
        style = (dict(ls="", marker="s", mfc="none", mew=1.5, color="C2") if "measured" in label
                 else dict(ls=("-", "--", ":")[k % 3], marker="o", ms=3, color=f"C{k}"))
        ax.plot(A, values, label=label, **style)
    ax.set_xlabel("drive amplitude A (m)")
    ax.set_ylabel("slow angular frequency Ω (rad/s)")
    ax.set_title(title or "Slow frequency", fontsize=10)
    ax.legend(fontsize=8)
    return fig


def tilt_figure(frame, *, l=None, g=None, title=None):
    """The horizontal drive's tilted state against A: averaging's θ*, the periodic orbit's
    period mean and the simulation's time mean (rad).

    Parameters
    ----------
    frame : pandas.DataFrame
        Columns A (m), omega (rad/s), theta_averaging, theta_orbit_mean,
        theta_measured_mean (rad), stayed_near (bool).
    l, g : float, optional
        Length (m) and gravity (m/s²): averaging's tilt is then drawn as a dense curve.

    Returns
    -------
    matplotlib.figure.Figure
    """
    fig, ax = axes(None, (6.4, 4.4))
    A = np.asarray(frame["A"], float)
    w = float(np.ravel(frame["omega"])[0])
    label = "first-order averaging: cos θ* = 2gl/(Aω)²"
    if l is not None and g is not None:       # the closed form, densely, under the points
        dense = np.linspace(A.min(), A.max(), 300)
        ax.plot(dense, np.arccos(np.clip(2 * g * l / (dense * w) ** 2, -1, 1)), "-",
                color="C0", lw=4, alpha=0.35, label=label)
    else:
        ax.plot(A, frame["theta_averaging"], "--", color="C0", label=label)
    ax.plot(A, frame["theta_orbit_mean"], "o-", ms=4, color="k",
            label="periodic orbit (Newton shooting): period mean")
    near = np.asarray(frame["stayed_near"], bool)
    ax.plot(A[near], np.asarray(frame["theta_measured_mean"])[near], "s", mfc="none", mew=1.5,
            color="C2", label="simulation: time mean (stayed near)")
    if (~near).any():
        ax.plot(A[~near], np.asarray(frame["theta_measured_mean"])[~near], "x", color="C3",
                label="simulation: left the tilt")
    ax.set_xlabel("drive amplitude A (m)")
    ax.set_ylabel("tilt θ from the downward vertical (rad)")
    ax.set_title(title or f"The tilted state of the horizontal drive, ω = {w:.4g} rad/s",
                 fontsize=10)
    ax.legend(fontsize=8)
    return fig


def work_precision_figure(result, *, ax=None):
    """Error at the final time against wall time, log-log, one line per method (a
    :class:`lagrange_core.accuracy_cost.WorkPrecision`).

    Each point is one tolerance, labelled with its exponent (``-6``: rtol = 1e-6).  The
    system's default method is drawn thick, our other methods in colour, the peers (scipy,
    heyoka) dashed in grey tones; hollow markers are errors not resolved by the reference
    (within ten times its own error, the dotted line).  Down and left is better.
    """
    from lagrange_core.accuracy_cost import RESOLVED_FACTOR, WorkPrecision
    if not isinstance(result, WorkPrecision):
        raise TypeError(f"result must be a lagrange_core.accuracy_cost.WorkPrecision, got "
                        f"{type(result).__name__}; make one with "
                        f"lagrange_core.accuracy_cost.work_precision(...).")
    fig, ax = axes(ax, (6.4, 4.6))
    positive = result.error[result.error > 0]
    floor = 0.5 * positive.min() if positive.size else 1e-16
    ours = [m for m in result.methods if m in set(result.method[result.kind == "ours"])]
    peer_colors = iter(("0.45", "#8c6d31", "0.2", "#7b4173", "0.6"))
    for name in result.methods:
        sel = result.method == name
        order = np.argsort(-result.rtol[sel])
        sec, err = result.seconds[sel][order], np.maximum(result.error[sel][order], floor)
        rtol, res = result.rtol[sel][order], result.resolved[sel][order]
        default = name == result.default_method
        if name in ours:
            color, ls = f"C{ours.index(name)}", "-"
        else:
            color, ls = next(peer_colors, "0.5"), "--"
        label = f"{name} (default)" if default else name
        ax.loglog(sec, err, ls, color=color, lw=2.6 if default else 1.2,
                  zorder=4 if default else 3, label=label)
        ax.loglog(sec[res], err[res], "o", color=color, ms=6 if default else 4, zorder=5)
        ax.loglog(sec[~res], err[~res], "o", mfc="white", mec=color, ms=6 if default else 4,
                  zorder=5)
        steps = result.steps[sel][order]
        k = 0
        while k < len(sec):           # tolerances that gave the same run share one label
            j = k
            while j + 1 < len(sec) and steps[j + 1] == steps[k] and err[j + 1] == err[k]:
                j += 1
            text = _exponent(rtol[k]) + ("" if j == k else f"…{_exponent(rtol[j])}")
            ax.annotate(text, (sec[k], err[k]), textcoords="offset points", xytext=(4, 3),
                        fontsize=6.5, color=color)
            k = j + 1
    if result.reference_error > 0:
        ax.axhline(RESOLVED_FACTOR * result.reference_error, color="k", ls=":", lw=0.8,
                   label=f"{RESOLVED_FACTOR:g} × the reference's own error "
                         f"({result.reference_error:.1e})")
    ax.set_xlabel("wall time per run (s), best of repeats, compile excluded")
    ax.set_ylabel("error at the final time, max |q(t₁) − q_ref(t₁)|")
    t0, t1 = result.t_span
    ax.set_title(textwrap.fill(f"{result.system}, t = {t0:g}…{t1:.4g} s: what accuracy costs "
                               "(point labels: log₁₀ rtol)", 70), fontsize=9)
    ax.grid(True, which="major", lw=0.4, alpha=0.5)
    ax.legend(fontsize=7, loc="best")
    return fig


def _exponent(rtol):
    """'-6' for 1e-6, else '2e-07'."""
    e = np.log10(rtol)
    return f"{e:.0f}" if abs(e - round(e)) < 1e-9 else f"{rtol:.0e}"
