"""Figures of a verification: the map of its grid with every disagreement marked and the
measured order of averaging, and the slow frequency by each method along a line of A.

Both read a :class:`~kapitza.results.Verification` through its fields and its methods
``compare`` and ``modes`` (the result decides what agrees; the figure only draws it).
"""
from __future__ import annotations

import textwrap
from typing import TYPE_CHECKING

import numpy as np

from ._common import VERIFICATION, about_text, drive_labels, figure, require

if TYPE_CHECKING:
    from ..results import Verification

__all__ = ["verification_figure", "slow_frequency_figure"]

#: How each method's disagreements with Floquet are marked: (marker, colour).
_VERIFY_MARKS = {"simulation": ("s", "#d62728"), "averaging": ("D", "#ff7f0e"),
                 "averaging_2": ("^", "#9467bd")}
_VERIFY_NAMES = {"simulation": "simulation", "averaging": "averaging (order 1)",
                 "averaging_2": "averaging (next order)"}


def verification_figure(verification: Verification, *, dimensionless=None, title=None):
    """The verification map with every disagreement marked, and the measured order of
    averaging.

    Parameters
    ----------
    verification : kapitza.results.Verification
        From :func:`kapitza.verify` or :meth:`kapitza.KapitzaPendulum.verify` (whose
        ``figure()`` calls this).
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
    require("verification", verification, "Verification", VERIFICATION,
            "compute one with kapitza.verify or KapitzaPendulum.verify")
    v = verification
    fits = tuple(v.fits)
    fig = figure((11.5, 4.8) if fits else (6.6, 4.8))
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
    drive_labels(ax, dimensionless, "A" if v.length is None else "A (m)")
    for axis, x in (("x", w), ("y", A)):       # the points' range: lines clip
        if x.min() > 0 and x.max() > 10 * x.min():     # a geometric grid: log axis
            getattr(ax, f"set_{axis}scale")("log")
            getattr(ax, f"set_{axis}lim")(x.min() / 1.25, x.max() * 1.25)
            continue
        pad = 0.06 * (x.max() - x.min()) or 0.06 * abs(x.max()) or 1.0
        getattr(ax, f"set_{axis}lim")(x.min() - pad, x.max() + pad)
    ax.set_title(title or f"Verification about {about_text(v.about)}: {A.size} points, "
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


#: How each method's Ω is drawn against A.
_SLOW_STYLE = {
    "floquet": dict(color="k", ls="-", marker="o", ms=4, label="Floquet (exact, linear)"),
    "averaging": dict(color="C0", ls="--", marker="", label="first-order averaging"),
    "averaging_2": dict(color="C3", ls=":", marker="", lw=2, label="next-order averaging"),
    "simulation": dict(color="C2", ls="", marker="s", ms=6, mfc="none", mew=1.5,
                       label="measured (simulation)")}


def slow_frequency_figure(verification: Verification, *, title=None):
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
    require("verification", verification, "Verification", VERIFICATION,
            "compute one with kapitza.verify or KapitzaPendulum.verify along a line of A")
    v = verification
    A = np.ravel(v.A)
    if np.ndim(v.A) != 1:
        raise ValueError(f"slow_frequency_figure needs a verification along a 1-d line of "
                         f"amplitudes, got shape {np.shape(v.A)}; use verification_figure "
                         "for a grid.")
    fig = figure((11.5, 4.4))
    ax, ax2 = fig.add_subplot(1, 2, 1), fig.add_subplot(1, 2, 2)
    ref = v.modes("omega_slow_floquet")
    for m in ("floquet", "averaging", "averaging_2", "simulation"):
        if m not in v.methods:
            continue
        style = dict(_SLOW_STYLE[m])
        label = style.pop("label")
        x = v.modes(f"omega_slow_{m}")
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
    ax.set_title(title or f"Slow frequency of {about_text(v.about)} at ω = {w:.4g} rad/s",
                 fontsize=10)
    ax.legend(fontsize=8)
    ax2.set_xlabel(ax.get_xlabel())
    ax2.set_ylabel("|Ω / Ω_Floquet − 1|")
    ax2.set_title("Relative difference from Floquet", fontsize=10)
    if ax2.lines:
        ax2.legend(fontsize=8)
    return fig
