"""Figures: stability maps with overlays, the effective potential, the Ince–Strutt chart,
verification maps.

Figures compute no physics: each function draws results it is given (the value types
of :mod:`kapitza.results`) and returns a :class:`matplotlib.figure.Figure` built on the
Agg canvas (no pyplot state, nothing shown); save it with ``fig.savefig(path)``.

Examples
--------
The exact map of the upright pendulum with the first-order averaging limit
A ω = √(2 g l) drawn over it:

>>> import numpy as np
>>> from kapitza import KapitzaPendulum
>>> pend = KapitzaPendulum(l=1.0, g=9.81)
>>> omega = np.linspace(5.0, 200.0, 120)
>>> exact = pend.stability_map(np.linspace(0.0, 0.6, 100), omega)
>>> averaging = pend.stability_window(omega, method="averaging", order=1)
>>> fig = stability_map_figure(exact, overlays=[averaging])
>>> [line.get_label() for line in fig.axes[0].lines]
['averaging (order 1): A ω = √(2 g l)']
"""
from __future__ import annotations

import ast
import textwrap

import numpy as np

from ..results import (BoundaryCurves, InceStruttChart, PendulumAveraging, StabilityMap,
                      StabilityWindow, Verification)

__all__ = ["stability_map_figure", "effective_potential_figure", "ince_strutt_figure",
           "verification_figure", "work_precision_figure", "spot_check_figure",
           "slow_frequency_figure", "slow_frequency_line_figure", "tilt_figure",
           "window_error_figure", "legend_below"]

_COLORS = {0: "#d9f0d3", 1: "#fdd49e", 2: "#c6dbef", 3: "#e7d4e8"}
_NAMES = {0: "stable", 1: "unstable, period-T boundary", 2: "unstable, period-2T boundary",
          3: "unstable, complex multipliers"}
_LINE_STYLES = ("--", ":", "-.", "-")


def _figure(figsize):
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure
    fig = Figure(figsize=figsize, layout="constrained")
    FigureCanvasAgg(fig)
    return fig


def _axes(ax, figsize):
    if ax is not None:
        return ax.figure, ax
    fig = _figure(figsize)
    return fig, fig.add_subplot()


def _check(name, value, kind, fix):
    if not isinstance(value, kind):
        raise TypeError(f"{name} must be a kapitza.results.{kind.__name__}, got "
                        f"{type(value).__name__}; {fix}.")


def _drive_labels(ax, dimensionless, amplitude):
    """Axis labels of an (ω, A) plane: SI (``amplitude`` names A and its unit) or A/l, ω/ω0."""
    if dimensionless:
        ax.set_xlabel("drive frequency ω/ω0  (ω0 = √(g/l))")
        ax.set_ylabel("drive amplitude A/l")
    else:
        ax.set_xlabel("drive angular frequency ω (rad/s)")
        ax.set_ylabel(f"drive amplitude {amplitude}")


def _window_label(window: StabilityWindow) -> str:
    """Legend text of a window overlay, from its fields."""
    if window.method == "averaging":
        if window.order == 1 and window.l is not None:       # the single pendulum's closed form
            return "averaging (order 1): A ω = √(2 g l)"
        return f"averaging (order {window.order})"
    return "Floquet window (exact)"


def _about_text(about) -> str:
    """The equilibrium for a title: its name, or its coordinates in multiples of π."""
    if isinstance(about, str) and not about.startswith(("[", "(")):
        return f"the {about} state"
    try:
        values = ast.literal_eval(about) if isinstance(about, str) else about
        if isinstance(values, dict):
            values = list(values.values())
        values = np.atleast_1d(np.asarray(values, float))
    except (ValueError, TypeError, SyntaxError):
        try:        # a numpy array's str(): "[3.14159265 3.14159265]", no commas
            values = np.array(str(about).strip("[]()").split(), float)
        except ValueError:                           # not numbers: as given, shortened
            return f"the state {str(about)[:40]}"
    parts = []
    for v in values:
        k = v / np.pi
        quarter = round(k * 4) / 4         # 1e-8: arrays printed to 8 digits still read as π
        parts.append(("0" if quarter == 0 else "π" if quarter == 1 else f"{quarter:g}π")
                     if abs(k - quarter) < 1e-8 else f"{v:.4g}")
    return f"the state q = ({', '.join(parts)})"


_CURVE_COLORS = {"T": "#b35806", "2T": "#2166ac", "complex": "#762a83"}


def _draw_curves(ax, curves: BoundaryCurves, w_scale, a_scale, handles):
    """Exact boundary curves as solid lines, one colour and one legend entry per kind."""
    shown = {h.get_label() for h in handles}
    for kind, A in zip(curves.kind, np.asarray(curves.A, float)):
        label = {"T": "exact boundary: multiplier +1 (T)",
                 "2T": "exact boundary: multiplier −1 (2T)",
                 "complex": "exact boundary: complex pair"}[kind]
        line, = ax.plot(np.asarray(curves.omega) * w_scale, A * a_scale, "-",
                        color=_CURVE_COLORS[kind], lw=1.3, label=label)
        if label not in shown:
            handles.append(line)
            shown.add(label)


def stability_map_figure(result: StabilityMap, *, overlays=(), ax=None, title=None,
                         dimensionless=False, l=None, g=None, log_omega=False, log_A=False,
                         boundaries=True):
    """Stability map (A vertical, ω horizontal), with stability windows drawn over it.

    Parameters
    ----------
    result : kapitza.results.StabilityMap
        From :meth:`kapitza.KapitzaPendulum.stability_map`,
        :func:`kapitza.mathieu.pendulum_stability_map` or
        :func:`kapitza.floquet.stability_map`.
    overlays : sequence of kapitza.results.StabilityWindow or BoundaryCurves
        Windows to draw as lines A_min(ω), A_max(ω) (the parts inside the map's A
        range; infinite edges are left out), e.g. the averaging prediction
        ``KapitzaPendulum.stability_window(omega, method="averaging", order=1)``,
        and exact boundary curves from :func:`kapitza.floquet.boundaries` (solid,
        coloured by kind).  Compute them on a fine ω grid for smooth curves.
    ax : matplotlib Axes, optional
        Draw into this axes instead of a new figure.
    title : str, optional
        Default: the equilibrium and the method.
    dimensionless : bool
        Axes A/l and ω/ω0 (ω0 = √(g/l)) instead of A (m) and ω (rad/s); needs the
        map's l and g (the pendulum's maps carry them) or ``l=`` and ``g=``.
    l, g : float, optional
        Length (m) and gravity (m/s²) for ``dimensionless`` when the map has none.
    log_omega, log_A : bool
        Logarithmic axes (the hanging state's tongues at ω = 2ω0/n only show on a
        logarithmic ω axis).
    boundaries : bool
        Draw the boundaries between stable and unstable regions as lines (for an
        adaptive map, :class:`~kapitza.results.AdaptiveMap`, the zero contour of its
        continuous margin: smooth at the grid's resolution).

    Returns
    -------
    matplotlib.figure.Figure

    Raises
    ------
    ValueError
        ``dimensionless`` without a length and gravity; a logarithmic axis whose
        range includes 0 or negative values.
    """
    from matplotlib.colors import ListedColormap
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch
    _check("result", result, StabilityMap, "compute one with KapitzaPendulum.stability_map")
    for window in overlays:
        if not isinstance(window, BoundaryCurves):
            _check("every overlay", window, StabilityWindow,
                   "compute one with KapitzaPendulum.stability_window or "
                   "kapitza.floquet.boundaries")
    fig, ax = _axes(ax, (6.4, 4.6))
    labels = np.asarray(result.label)
    present = sorted(set(np.unique(labels).tolist()) | {0})
    cmap = ListedColormap([_COLORS[k] for k in range(4)])
    # axis scales: SI, or A/l and ω/ω0
    a_scale, w_scale = 1.0, 1.0
    if dimensionless:
        l = result.l if l is None else l
        g = result.g if g is None else g
        if l is None or g is None:
            raise ValueError("dimensionless=True needs the length and gravity: this map has "
                             "none (a general system's map); pass l=... (m) and g=... (m/s²).")
        a_scale, w_scale = 1.0 / l, 1.0 / np.sqrt(g / l)
    w, A = np.asarray(result.omega) * w_scale, np.asarray(result.A) * a_scale
    for name, on, axis in (("log_omega", log_omega, w), ("log_A", log_A, A)):
        if on and axis.min() <= 0:
            raise ValueError(f"{name}=True needs positive values, but the map's axis starts at "
                             f"{axis.min():g}; compute the map from a positive value.")
    ax.pcolormesh(w, A, labels, cmap=cmap, vmin=-0.5, vmax=3.5, shading="nearest",
                  rasterized=True)
    handles = [Patch(color=_COLORS[k], label=_NAMES[k]) for k in present]
    margin = getattr(result, "margin", None)      # an AdaptiveMap's continuous margin
    if boundaries and 0 < np.count_nonzero(labels == 0) < labels.size:
        field, level = ((labels == 0).astype(float), 0.5) if margin is None else (margin, 0.0)
        ax.contour(w, A, field, levels=[level], colors="#1b7837", linewidths=0.9)
        handles.append(Line2D([], [], color="#1b7837", lw=0.9, label="stability boundary"))
    for k, window in enumerate(overlays):
        if isinstance(window, BoundaryCurves):
            _draw_curves(ax, window, w_scale, a_scale, handles)
            continue
        style = _LINE_STYLES[k % len(_LINE_STYLES)]
        label = _window_label(window)
        for edge in (window.A_min, window.A_max):
            ww, Ab = np.broadcast_arrays(np.asarray(window.omega, float) * w_scale,
                                         np.asarray(edge, float) * a_scale)
            inside = np.isfinite(Ab) & (Ab >= A.min()) & (Ab <= A.max())
            if inside.any():
                line, = ax.plot(ww[inside], Ab[inside], style, color="k", lw=1.2, label=label)
                if not label.startswith("_"):
                    handles.append(line)          # one legend entry per window
                    label = "_" + label
    _drive_labels(ax, dimensionless, "A (m)")
    ax.set_xscale("log" if log_omega else "linear")
    ax.set_yscale("log" if log_A else "linear")
    ax.set_xlim(w.min(), w.max())
    ax.set_ylim(A.min(), A.max())
    ax.set_title(title or f"Floquet stability of {_about_text(result.about)}\n({result.method})",
                 fontsize=10)
    ax.legend(handles=handles, loc="upper right", fontsize=8, framealpha=0.9)
    return fig


def effective_potential_figure(theta, potential, *, prediction: PendulumAveraging | None = None,
                               ax=None, title=None):
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

    Returns
    -------
    matplotlib.figure.Figure

    Examples
    --------
    >>> import numpy as np
    >>> from kapitza import pendulum_averaged, pendulum_effective_potential
    >>> theta = np.linspace(-np.pi, 2 * np.pi, 600)
    >>> U = pendulum_effective_potential(theta, 0.05, 2 * np.pi * 60)
    >>> fig = effective_potential_figure(theta, U, prediction=pendulum_averaged(0.05, 2 * np.pi * 60))
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
        _check("prediction", prediction, PendulumAveraging,
               "compute one with kapitza.pendulum_averaged at a scalar A and ω")
    fig, ax = _axes(ax, (6.4, 4.2))
    ax.plot(theta, potential, color="C0", lw=1.5, label="U_eff/m (first-order averaging)")
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
    ticks = np.arange(np.ceil(theta.min() / (np.pi / 2)), np.floor(theta.max() / (np.pi / 2)) + 1)
    ax.set_xticks(ticks * np.pi / 2,
                  [{0: "0", 1: "π/2", 2: "π", 3: "3π/2", -1: "−π/2", -2: "−π"}.get(
                      int(k), f"{k / 2:g}π") for k in ticks])
    pad = 0.04 * (theta.max() - theta.min())          # room for the marks' names
    ax.set_xlim(theta.min() - pad, theta.max() + pad)
    ax.margins(y=0.14)
    ax.set_xlabel("θ from the downward vertical (rad)")
    ax.set_ylabel("U_eff / m (J/kg)")
    ax.set_title(title or "Effective potential (filled: stable, open: unstable)", fontsize=10)
    ax.legend(loc="lower right", fontsize=8)
    return fig


def ince_strutt_figure(chart: InceStruttChart, *, ax=None):
    """Ince–Strutt chart: stable (shaded) and unstable regions of y″ + (a − 2q cos 2τ) y = 0.

    Parameters
    ----------
    chart : kapitza.results.InceStruttChart
        From :func:`kapitza.mathieu.ince_strutt_chart`: the stability grid and the
        characteristic curves a_r(q), b_r(q) (the undamped equation is stable
        between a_r and b_(r+1)).
    ax : matplotlib Axes, optional

    Returns
    -------
    matplotlib.figure.Figure

    Examples
    --------
    >>> from kapitza.mathieu import ince_strutt_chart
    >>> fig = ince_strutt_figure(ince_strutt_chart(q_max=10, a_range=(-10, 20), r_max=5, n=60))
    >>> len(fig.axes[0].lines)                  # a0..a5, b1..b5
    11
    """
    _check("chart", chart, InceStruttChart, "compute one with kapitza.mathieu.ince_strutt_chart")
    fig, ax = _axes(ax, (6.4, 4.8))
    ax.pcolormesh(chart.q, chart.a, chart.stable.T, cmap="Greens", vmin=-0.3, vmax=1.6,
                  shading="nearest", rasterized=True)
    for name, vals in chart.curves.items():
        ax.plot(chart.q, vals, lw=1.0, color="C0" if name[0] == "a" else "C3",
                label={"a0": "$a_r(q)$ (even, ce)", "b1": "$b_r(q)$ (odd, se)"}.get(name))
    ax.legend(loc="lower left", fontsize=8)
    ax.set_xlim(chart.q.min(), chart.q.max())
    ax.set_ylim(chart.a.min(), chart.a.max())
    ax.set_xlabel("q")
    ax.set_ylabel("a")
    ax.set_title("Ince–Strutt chart (shaded: stable)")
    return fig


#: How each method's disagreements with Floquet are marked: (marker, colour).
_VERIFY_MARKS = {"simulation": ("s", "#d62728"), "averaging": ("D", "#ff7f0e"),
                 "averaging_2": ("^", "#9467bd")}
_VERIFY_NAMES = {"simulation": "simulation", "averaging": "averaging (order 1)",
                 "averaging_2": "averaging (next order)"}


def verification_figure(verification, *, dimensionless=None, title=None):
    """The verification map with every disagreement marked, and the measured order of
    averaging.

    Parameters
    ----------
    verification : kapitza.results.Verification
        From :func:`kapitza.verify.verify` or :meth:`kapitza.KapitzaPendulum.verify`.
    dimensionless : bool, optional
        Axes A/l and ω/ω0 (the verification's ``length`` and ``omega0``); default: when
        it has both.
    title : str, optional

    Left: every grid point, filled where Floquet analysis (the exact linear reference)
    calls it stable, open where unstable; the Floquet boundaries (the exact window's
    edges for the pendulum, the located boundary points otherwise); and, per method,
    the points where it disagrees with Floquet: a large open marker for the
    classification, a "+" for Ω (disagreements between two other methods are in
    ``verification.disagreements``).  Right, when ``verification.fits`` is not empty:
    each averaging order's relative error in Ω against the small parameter on log-log
    axes (filled: fitted, open: below Floquet's own resolution), the fitted line c ε^p
    and the theory's slope through the fit's middle.  An axis whose grid spans more than
    a decade (all positive) is logarithmic.

    Returns
    -------
    matplotlib.figure.Figure
    """
    from matplotlib.lines import Line2D
    _check("verification", verification, Verification,
           "compute one with kapitza.verify or KapitzaPendulum.verify")
    v = verification
    fits = tuple(v.fits)
    fig = _figure((11.5, 4.8) if fits else (6.6, 4.8))
    ax = fig.add_subplot(1, 2, 1) if fits else fig.add_subplot()
    if dimensionless is None:
        dimensionless = v.length is not None and v.omega0 is not None
    if dimensionless and (v.length is None or v.omega0 is None):
        raise ValueError("dimensionless=True needs the verification's length and omega0; this "
                         "one has none (pass length= and omega0= to kapitza.verify).")
    a_scale, w_scale = (1 / v.length, 1 / v.omega0) if dimensionless else (1.0, 1.0)
    A, w = np.ravel(v.A) * a_scale, np.ravel(v.omega) * w_scale
    stable = np.ravel(v.stable_floquet)
    ax.scatter(w[stable], A[stable], s=28, color="#a6dba0", edgecolors="#1b7837", zorder=3)
    ax.scatter(w[~stable], A[~stable], s=28, color="white", edgecolors="#888888", zorder=3)
    handles = [Line2D([], [], ls="", marker="o", color="#a6dba0", mec="#1b7837",
                      label="Floquet: stable"),
               Line2D([], [], ls="", marker="o", color="white", mec="#888888",
                      label="Floquet: unstable")]
    if v.window is not None:
        for edge in (v.window.A_min, v.window.A_max):
            ww, Ab = np.asarray(v.window.omega) * w_scale, np.asarray(edge) * a_scale
            ax.plot(ww, Ab, "-", color="#1b7837", lw=1.1, zorder=2)
        handles.append(Line2D([], [], color="#1b7837", lw=1.1,
                              label="Floquet boundary (exact window)"))
    elif np.size(v.boundary_A):
        ax.plot(np.asarray(v.boundary_omega) * w_scale, np.asarray(v.boundary_A) * a_scale,
                "_", color="#1b7837", ms=14, mew=2, zorder=2)
        handles.append(Line2D([], [], ls="", marker="_", color="#1b7837", ms=14, mew=2,
                              label="Floquet boundary (located)"))
    for m in v.methods:
        if m == "floquet":
            continue
        marker, color = _VERIFY_MARKS[m]
        for quantity, size, mk in (("stability", 120, marker), ("omega_slow", 70, "+")):
            compared, agree = v.compare(m, "floquet", quantity)
            bad = np.ravel(compared & ~agree)
            if not bad.any():
                continue
            style = (dict(color=color) if mk == "+"
                     else dict(facecolors="none", edgecolors=color))
            ax.scatter(w[bad], A[bad], s=size, marker=mk, linewidths=1.5, zorder=4, **style)
            what = "stability" if quantity == "stability" else "Ω"
            handles.append(Line2D([], [], ls="", marker=mk, mfc="none", mec=color, mew=1.5,
                                  ms=9 if mk != "+" else 8,
                                  label=f"{_VERIFY_NAMES[m]} ≠ Floquet ({what}): {int(bad.sum())}"))
    _drive_labels(ax, dimensionless, "A" if v.length is None else "A (m)")
    for axis, x in (("x", w), ("y", A)):       # the points' range: lines clip
        if x.min() > 0 and x.max() > 10 * x.min():     # a geometric grid: log axis
            getattr(ax, f"set_{axis}scale")("log")
            getattr(ax, f"set_{axis}lim")(x.min() / 1.25, x.max() * 1.25)
            continue
        pad = 0.06 * (x.max() - x.min()) or 0.06 * abs(x.max()) or 1.0
        getattr(ax, f"set_{axis}lim")(x.min() - pad, x.max() + pad)
    ax.set_title(title or f"Verification about {_about_text(v.about)}: {A.size} points, "
                 f"{v.periods} periods simulated", fontsize=10)
    ax.legend(handles=handles, loc="upper center", bbox_to_anchor=(0.5, -0.13), ncol=2,
              fontsize=7, frameon=False)                 # below the axes: no point hidden
    if fits:
        _order_panel(fig.add_subplot(1, 2, 2), fits)
    return fig


def _order_panel(ax, fits):
    """Relative error of averaging's Ω against ε, log-log, with the fitted and theory slopes."""
    for k, fit in enumerate(fits):
        color = ("C0", "C3")[k % 2]
        eps, err, used = (np.asarray(x) for x in (fit.epsilon, fit.error, fit.used))
        ax.loglog(eps[used], err[used], "o", color=color, ms=5)
        ax.loglog(eps[~used], err[~used], "o", color=color, mfc="none", ms=5)
        if np.isfinite(fit.exponent):
            e = eps[used]
            line = np.geomspace(e.min(), e.max(), 50)
            ax.loglog(line, fit.prefactor * line ** fit.exponent, "-", color=color, lw=1.2,
                      label=f"order {fit.order}: fitted p = {fit.exponent:.3f} ± "
                            f"{fit.exponent_error:.3f} (theory {fit.theory:g})")
            if np.isfinite(fit.theory):
                mid = np.sqrt(e.min() * e.max())
                ax.loglog(line, fit.prefactor * mid ** fit.exponent * (line / mid) ** fit.theory,
                          "--", color="k", lw=0.8, zorder=3)
    ax.plot([], [], "--", color="k", lw=0.8, label="theory's slope (through the fit's middle)")
    ax.set_xlabel(textwrap.fill(fits[0].small_parameter, 60), fontsize=9)
    ax.set_ylabel("relative error of Ω against Floquet")
    ax.set_title("The order of averaging (filled: fitted)", fontsize=10)
    ax.legend(loc="lower right", fontsize=7)


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
    fig, ax = _axes(ax, (6.4, 4.6))
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


# -- the report's figures (kapitza.report) ----------------------------------------------------

def spot_check_figure(result: StabilityMap, A, omega, stayed_up, agrees, *, overlays=(),
                      log_omega=False, log_A=False, title=None):
    """A stability map with direct-simulation spot checks marked on it.

    Parameters
    ----------
    result : kapitza.results.StabilityMap
        The map (as for :func:`stability_map_figure`, with ``overlays``, ``log_omega``,
        ``log_A``).
    A, omega : 1-d arrays
        The simulated points (m, rad/s).
    stayed_up, agrees : bool arrays
        Per point: the simulation stayed up (filled circle) or fell (cross); and whether
        that agrees with Floquet analysis (black edge) or not (red, large).

    Returns
    -------
    matplotlib.figure.Figure
    """
    from matplotlib.lines import Line2D
    A, omega = np.asarray(A, float), np.asarray(omega, float)
    stayed_up, agrees = np.asarray(stayed_up, bool), np.asarray(agrees, bool)
    if not (A.shape == omega.shape == stayed_up.shape == agrees.shape) or A.ndim != 1:
        raise ValueError(f"A, omega, stayed_up and agrees must be 1-d arrays of one length, "
                         f"got shapes {A.shape}, {omega.shape}, {stayed_up.shape}, "
                         f"{agrees.shape}.")
    fig = stability_map_figure(result, overlays=overlays, log_omega=log_omega, log_A=log_A,
                               boundaries=not overlays,
                               title=title or f"Spot checks by direct simulation on the "
                                              f"Floquet map of {_about_text(result.about)}")
    ax = fig.axes[0]
    handles = list(ax.get_legend().legend_handles)
    for up, marker, text in ((True, "o", "simulation: stayed up"),
                             (False, "X", "simulation: fell")):
        for ok, color in ((True, "k"), (False, "#d62728")):
            sel = (stayed_up == up) & (agrees == ok)
            if sel.any():
                ax.scatter(omega[sel], A[sel], marker=marker, s=70 if ok else 130,
                           facecolors=("#1b7837" if up else "#444444") if ok else "none",
                           edgecolors=color, linewidths=1.2 if ok else 2.2, zorder=5)
        if (stayed_up == up).any():
            handles.append(Line2D([], [], ls="", marker=marker, ms=8, mec="k",
                                  mfc="#1b7837" if up else "#444444", label=text))
    if (~agrees).any():
        handles.append(Line2D([], [], ls="", marker="o", ms=10, mfc="none", mec="#d62728",
                              mew=2.2, label=f"disagrees with Floquet: {int((~agrees).sum())}"))
    legend_below(ax, handles)
    return fig


def legend_below(ax, handles=None):
    """Move ``ax``'s legend (or one of ``handles``) below the axes, two columns, so it
    hides no part of a map."""
    if handles is None:
        handles = list(ax.get_legend().legend_handles)
    ax.legend(handles=handles, loc="upper center", bbox_to_anchor=(0.5, -0.14), ncol=2,
              fontsize=7.5, frameon=False)


_SLOW_STYLE = {"floquet": dict(color="k", ls="-", marker="o", ms=4, label="Floquet (exact, linear)"),
               "averaging": dict(color="C0", ls="--", marker="", label="first-order averaging"),
               "averaging_2": dict(color="C3", ls=":", marker="", lw=2,
                                   label="next-order averaging"),
               "simulation": dict(color="C2", ls="", marker="s", ms=6, mfc="none", mew=1.5,
                                  label="measured (simulation)")}


def slow_frequency_figure(verification, *, title=None):
    """Predicted against measured slow frequency along a line of amplitudes.

    Parameters
    ----------
    verification : kapitza.results.Verification
        Over a 1-d array of A at one ω (:meth:`kapitza.KapitzaPendulum.verify` or
        :func:`kapitza.verify` with ``line=False``).

    Left: Ω (rad/s) against A by each method (several modes: one line each); right: each
    method's relative difference from Floquet's Ω, log scale (where both are finite).

    Returns
    -------
    matplotlib.figure.Figure
    """
    _check("verification", verification, Verification,
           "compute one with kapitza.verify or KapitzaPendulum.verify along a line of A")
    v = verification
    A = np.ravel(v.A)
    if np.ndim(v.A) != 1:
        raise ValueError(f"slow_frequency_figure needs a verification along a 1-d line of "
                         f"amplitudes, got shape {np.shape(v.A)}; use verification_figure "
                         "for a grid.")
    fig = _figure((11.5, 4.4))
    ax, ax2 = fig.add_subplot(1, 2, 1), fig.add_subplot(1, 2, 2)
    ref = v._modes("omega_slow_floquet")
    for m in ("floquet", "averaging", "averaging_2", "simulation"):
        if m not in v.methods:
            continue
        style = dict(_SLOW_STYLE[m])
        label = style.pop("label")
        x = v._modes(f"omega_slow_{m}")
        for k in range(x.shape[-1]):
            ax.plot(A, x[:, k], label=label if k == 0 else None, **style)
            if m == "floquet":
                continue
            with np.errstate(invalid="ignore", divide="ignore"):
                rel = np.abs(x[:, k] / ref[:, k] - 1)
            ok = np.isfinite(rel) & (rel > 0)
            if ok.any():
                st = {**style, "marker": style.get("marker") or "."}
                ax2.semilogy(A[ok], rel[ok], label=label if k == 0 else None, **st)
    w = float(np.ravel(v.omega)[0])
    ax.set_xlabel("drive amplitude A (m)" if v.length is not None else "drive amplitude A")
    ax.set_ylabel("slow angular frequency Ω (rad/s)")
    ax.set_title(title or f"Slow frequency of {_about_text(v.about)} at ω = {w:.4g} rad/s",
                 fontsize=10)
    ax.legend(fontsize=8)
    ax.set_xlabel("drive amplitude A (m)")
    ax2.set_xlabel("drive amplitude A (m)")
    ax2.set_ylabel("|Ω / Ω_Floquet − 1|")
    ax2.set_title("Relative difference from Floquet", fontsize=10)
    if ax2.lines:
        ax2.legend(fontsize=8)
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
    fig, ax = _axes(None, (6.4, 4.4))
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
    fig, ax = _axes(None, (6.4, 4.4))
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


def window_error_figure(exact: StabilityWindow, approximations, *, ax=None, omega0=None):
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

    Draws |A_min(approximation)/A_min(exact) − 1| on log-log axes (first-order
    averaging's error falls as (ω0/ω)², the next order's as (ω0/ω)⁴).

    Returns
    -------
    matplotlib.figure.Figure
    """
    _check("exact", exact, StabilityWindow, "compute one with KapitzaPendulum.stability_window")
    fig, ax = _axes(ax, (5.2, 4.4))
    w = np.atleast_1d(np.asarray(exact.omega, float))
    x = w / omega0 if omega0 else w
    lo = np.atleast_1d(np.asarray(exact.A_min, float))
    for k, window in enumerate(approximations):
        _check("every approximation", window, StabilityWindow,
               "compute one with KapitzaPendulum.stability_window(method='averaging')")
        approx = np.broadcast_to(np.asarray(window.A_min, float), lo.shape)
        with np.errstate(invalid="ignore", divide="ignore"):
            rel = np.abs(approx / lo - 1)
        ok = np.isfinite(rel) & (rel > 0)
        ax.loglog(x[ok], rel[ok], _LINE_STYLES[k % len(_LINE_STYLES)], color="k", lw=1.3,
                  label=_window_label(window))
    ax.set_xlabel("drive frequency ω/ω0" if omega0 else "drive angular frequency ω (rad/s)")
    ax.set_ylabel("|A_min(averaging) / A_min(exact) − 1|")
    ax.set_title("Error of the averaging window's lower edge", fontsize=10)
    ax.grid(True, which="major", alpha=0.3)
    ax.legend(fontsize=8)
    return fig
