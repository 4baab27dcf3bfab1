"""Where stability changes, exactly: :func:`window` (the stabilising amplitudes per ω,
certified edges → :class:`~kapitza.results.StabilityWindow`) and :func:`boundaries` (the
curves A_k(ω) by continuation → :class:`~kapitza.results.BoundaryCurves`).

Both find the roots of smooth margins such as det(M ∓ I) (:mod:`kapitza.floquet._margins`),
not bisection on the flag "stable": a classification scan brackets each change, the
Anderson–Björck method solves it (:mod:`kapitza.floquet._edges`), continuation follows it
over ω (:mod:`kapitza.floquet._curves`), all on the monodromies of
:class:`kapitza.floquet._probe._Probe`.  The single pendulum's windows go through the
Mathieu equation instead (:func:`kapitza.closed_forms.pendulum_window`), which is
faster and exact to rounding.
"""
from __future__ import annotations

import functools
import math
import os
import sys
import time
import warnings

import numpy as np

from lagrange_core.checks import real_number

from .. import _arguments as arguments
from ..results import BoundaryCurves, StabilityWindow
from ._curves import trace_curves
from ._edges import MIN_WIDTH, first_window
from ._margins import KINDS
from ._old_spellings import frequency_as_keyword
from ._probe import probe_for

__all__ = ["window", "boundaries"]

#: the monodromies' tolerance of the classification scans and side checks of windows and
#: boundaries (their brackets are then solved on margins at the edges' own tolerance)
CLASSIFY_TOL = 1e-8


def _margin_tol(tol):
    """The monodromies' tolerance for edges wanted to ``tol`` (relative, in A): 1e-5 tol,
    at least 1e-15 (each factor 100 costs about 30 % more Taylor steps)."""
    return float(min(1e-8, max(1e-15, 1e-5 * tol)))


def _orbit_tol(tol):
    """The shooting's residual tolerance about a periodic orbit for edges wanted to ``tol``
    (relative, in A): tol/100, within 1e-10 … 1e-8.  The flow is integrated to 1/100 of
    it, and float64 flows of a few hundred steps meet no less than ~1e-12 (their rounding
    error: the step doublings stop agreeing); the edges' accuracy is then about 1e-12
    over the margin's slope."""
    return float(min(1e-8, max(1e-10, 1e-2 * tol)))


def _probes(omega, A):
    """Where ``about``'s persistence under the drive is tested: amplitude A at the lowest
    and the highest frequency."""
    return [(float(A), float(x)) for x in (np.min(omega), np.max(omega))] if np.size(omega) \
        else []


def _scan_grid(lo, hi, points):
    """Ascending amplitudes from lo to hi: ``points`` evenly spaced plus a third as many
    spaced geometrically towards lo (edges near lo, e.g. at fast drives, are resolved)."""
    u = np.unique(np.r_[0.0, np.geomspace(1e-4, 1.0, max(2, points // 3)),
                        np.linspace(0.0, 1.0, points + 1)])
    return lo + (hi - lo) * u


_PACKAGE = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def _warnings_at_caller(func):
    """Re-raise the warnings of ``func`` at the user's call line: the first frame outside
    the kapitza package (a fixed ``stacklevel`` in the internals pointed at the deprecation
    wrapper or at whichever kapitza function called).  Python 3.11 has no
    ``skip_file_prefixes``; the warnings are collected and raised again in order, after the
    computation (filters such as "error" apply then)."""
    @functools.wraps(func)
    def wrapper(*args, **kwargs):
        caught: list = []
        try:
            with warnings.catch_warnings(record=True) as caught:
                warnings.simplefilter("always")
                return func(*args, **kwargs)
        finally:
            level, frame = 1, sys._getframe(0)
            while frame is not None and os.path.abspath(
                    frame.f_code.co_filename).startswith(_PACKAGE + os.sep):
                frame, level = frame.f_back, level + 1
            for w in caught:
                warnings.warn(w.message, w.category, stacklevel=level)
    return wrapper


@frequency_as_keyword
@_warnings_at_caller
def window(system, params, about, *, omega, A_range=None, amplitude="A", frequency="omega",
           tol=1e-10, scan=96, min_width=None, order=16, guard_tol=1e-8) -> StabilityWindow:
    """The exact window of drive amplitudes A_min < A < A_max that stabilises ``about``,
    per ω, with certified edges.

    At each ω the amplitudes 0 … ``A_range[1]`` are classified (``scan`` points, plus
    geometric ones towards 0) to find the lowest stable interval; each of its edges is
    then the root of the smooth margin of the boundary's kind — det(M − I) where a
    multiplier reaches +1 ("T"), det(M + I) at −1 ("2T"), the reduced polynomial's
    discriminant or the leading log|λ| where a complex pair leaves the circle — found by
    the Anderson–Björck method in the scan's bracket, with the monodromies integrated to
    1e-5 tol and their error measured against a second monodromy at 100× that
    tolerance (:mod:`kapitza.floquet._margins`, :mod:`kapitza.floquet._edges`).  Not
    bisection on the flag "stable": after the scan, each edge takes six or seven margin
    evaluations.

    Never silent at the frontier: a window narrower than the scan's spacing (a chain
    near the lowest frequency that holds it up, the window born with zero width) is
    searched for between the scan points, down to ``min_width``
    (:mod:`kapitza.floquet._frontier`).  Every interval between neighbouring scan
    points of equal classification below the first stable one (and inside the first
    stable run, for an unstable gap) is examined on the monodromies' signed margin u
    (> 0 stable) and on det(M ∓ I): it is ruled out where u's chord, widened by the
    change of slope that its neighbours' secants show (× 2) and by u's rounding error,
    stays below zero and no multiplier sweeps across the whole band [−1, 1] inside it;
    otherwise it is split (where the neighbours' secants predict the margin's peak)
    and examined again.  **Guarantee**: every stable interval at least ``min_width``
    wide in ``A_range`` is found (``status`` "window", the lowest one reported), or
    there is none (``status`` "none": A_min, A_max NaN), as long as the margin's
    curvature on each interval is within twice what its neighbours' secants show and
    no two multipliers cross the same threshold ±1 between two neighbouring points;
    where an interval narrower than ``min_width`` still cannot be ruled out,
    ``status`` is "undecided" and a RuntimeWarning names the frequencies and
    amplitudes.  On the common case this costs a handful of monodromies per ω (the scan
    takes ~130); at a window's birth a few dozen.

    kapitza 0.1's ``window(system, params, about, omega)`` and ``A_limit=x`` still work in
    0.2, with a DeprecationWarning (now ``omega=omega`` and ``A_range=(0, x)``).

    Parameters
    ----------
    system : lagrange_core.System
    params : dict
        The other parameters (scalars); values of ``amplitude`` and ``frequency`` in
        it are ignored.
    about : sequence, dict or kapitza.results.PeriodicOrbit
        The driven equilibrium's coordinates (velocities zero); where that state does
        not persist under the drive, the T-periodic orbit it names, followed in the
        amplitude from A = 0 at each ω (a PeriodicOrbit: from where it was found) as
        :func:`kapitza.stability_map` does (its Notes).  The
        orbit's margins are those of its monodromy, their entries' error measured
        against a second shooting at 100× the tolerance; the shooting's residual is
        tol/100 within 1e-10 … 1e-8 (float64 flows meet ~1e-12), so edges reach
        about 1e-11 (the hanging orbit's pitchfork, horizontal drive).  Where the scan
        reaches a point the orbit does not (its branch ends), the window there is
        "undecided".  The default ``A_range`` about an orbit: up to where the drive's
        modulation or forcing at ``about`` reaches 2 in the balanced variables (2 l for
        a pendulum on a horizontal pivot).
    omega : float or 1-d array
        Drive angular frequencies (rad/s), keyword; a scalar gives a window of scalar
        fields.
    A_range : (0, float), optional
        The amplitudes scanned (m), ``(0, high)``; default, per ω, up to where the drive's
        modulation of the linearised equations reaches 2 in the balanced variables (2 l
        for a pendulum of length l: Mathieu q = 4).  The window is the *lowest* stable
        interval, from A = 0 (A_min = 0 where the undriven state is stable), so a lower
        end above 0 is refused; the boundaries inside a band of amplitudes are
        :func:`boundaries`' ``A_range``.
    amplitude, frequency : str
        The names of the drive's amplitude and angular frequency parameters.
    tol : float
        Requested relative accuracy of the edges.
    scan : int
        Evenly spaced scan points (plus a third as many spaced geometrically towards
        A = 0); windows narrower than their spacing are searched for between them down
        to ``min_width``.
    min_width : float, optional
        The resolution (m): every stable interval at least this wide is found (see the
        guarantee above).  Default 1e-8 × the scan's upper limit per ω (1e-8 m for a
        1 m range); larger is no faster on the common case, and only where a window is
        being born does a smaller one cost a few more monodromies.

    Returns
    -------
    kapitza.results.StabilityWindow
        ``method="floquet"``: A_min, A_max per ω; ``status`` per ω "window", "none" or
        "undecided" and ``min_width`` (m).  "window": A_min = 0 where the undriven
        state is already stable (the hanging chain), A_max = inf where the scan ends
        stable; ``accuracy``: the larger certified relative accuracy of the two edges.
        "none": A_min, A_max NaN — proved, at ``min_width``, for the amplitudes scanned
        (a window above ``A_range`` is not looked for).  "undecided": A_min, A_max an
        envelope within which the lowest window lies, if there is one; accuracy NaN.
        ``l``, ``g`` are None.

    Warns
    -----
    RuntimeWarning
        Where the certified ``accuracy`` is coarser than ``tol``: at fast drives the
        monodromy is near the identity and float64 fixes the margins' sign only to about
        ε_mach (ω/ω0)² (so 1e-10 is out of reach from ~100–300 ω0 on; ask for 1e-8 there).
        Where a solved edge fails its check on both sides (A(1 ∓ η) classified on the fine
        monodromies), or a stable amplitude was scanned but an edge not found, that ω is
        "undecided" and the warning names the frequencies: never a wrong window.  Where
        a sliver narrower than ``min_width`` could not be ruled out: "undecided", and the
        warning names the frequencies and amplitudes (pass a smaller ``min_width``).

    Examples
    --------
    The upright pendulum's window at ω = 60 rad/s agrees with the Mathieu equation's
    characteristic values (:func:`kapitza.closed_forms.pendulum_window`):

    >>> import math
    >>> from lagrange_core import problems
    >>> from kapitza.closed_forms import pendulum_window
    >>> win = window(problems.driven_pendulum("vertical"), dict(m=1.0, l=1.0, g=9.81),
    ...              [math.pi], omega=60.0)
    >>> ref = pendulum_window(60.0, l=1.0, g=9.81)
    >>> print(f"{win.A_min:.10f} {win.A_max:.10f}")
    0.0739120532 0.4585959178
    >>> bool(abs(win.A_min / ref.A_min - 1) < 1e-10 and win.accuracy <= 1e-10)
    True
    >>> print(win.status)
    window

    At ω = ω0 the window is 8 mm wide at A ≈ 1.9 m, narrower than the scan's spacing
    (2 cm), and found between the scan points:

    >>> near = window(problems.driven_pendulum("vertical"), dict(m=1.0, l=1.0, g=9.81),
    ...               [math.pi], omega=math.sqrt(9.81))
    >>> print(near.status, f"{near.A_min:.4f} {near.A_max:.4f}")
    window 1.9053 1.9136
    """
    w = arguments.grid_axis(frequency, omega, "rad/s", positive=True)
    scalar = np.ndim(omega) == 0            # after the check: a ragged list has no ndim
    with np.errstate(over="ignore"):        # the drive's terms carry ω²: it must be a float
        fast = w[~np.isfinite(w * w)]
    if fast.size:
        raise ValueError(f"window: {frequency} = {float(fast[0])!r} rad/s: ω² overflows a float; "
                         "give ω below 1e150 rad/s.")
    _check_tol(tol)
    _check_min_width(min_width)
    if A_range is not None:
        lo, hi = _amplitude_range(A_range)
        if lo != 0.0:
            raise ValueError(
                f"window: A_range={A_range!r} starts above 0, but the window is the lowest "
                "interval of stabilising amplitudes, found by a scan from A = 0 (A_min = 0 "
                f"where the undriven state is stable); pass A_range=(0, {hi!r}).  For the "
                "stability boundaries within a band of amplitudes use "
                "kapitza.boundaries(..., A_range=(low, high)).")
    probe = probe_for(system, params, about, amplitude, frequency, _margin_tol(tol), order,
                      guard_tol, paired=True, classify_tol=CLASSIFY_TOL,
                      probes=_probes(w, 1.0 if A_range is None else hi), start=0.0,
                      orbit_tol=_orbit_tol(tol))
    if w.size == 0:
        edges = dict(A_min=np.zeros(0), A_max=np.zeros(0), accuracy=np.zeros(0),
                     status=np.zeros(0, dtype=str))
        width = np.zeros(0)
    else:
        limit = probe.amplitude_scale(w) if A_range is None else np.full(w.size, hi)
        grid = np.stack([_scan_grid(0.0, top, scan) for top in limit])
        width = MIN_WIDTH * limit if min_width is None else np.full(w.size, float(min_width))
        edges = first_window(probe, w, grid, tol, min_width=width)
    pick = (lambda x: x[0].item()) if scalar else (lambda x: x)
    return StabilityWindow(omega=pick(w), A_min=pick(edges["A_min"]),
                           A_max=pick(edges["A_max"]), method="floquet", about=probe.label,
                           accuracy=pick(edges["accuracy"]), tol=tol,
                           status=pick(edges["status"]), min_width=pick(width))


def _check_tol(tol):
    if isinstance(tol, bool) or not isinstance(tol, (int, float)) or not (1e-13 <= tol < 1e-2):
        raise ValueError(f"tol must be a number in [1e-13, 1e-2) (relative, in A), got {tol!r}.")


def _check_min_width(min_width):
    if min_width is not None and (isinstance(min_width, bool) or not isinstance(
            min_width, (int, float)) or not (0.0 < min_width < math.inf)):
        raise ValueError(f"min_width must be a positive number of metres (the narrowest "
                         f"window certainly found), or None for 1e-8 × the scan's top; "
                         f"got {min_width!r}.")


def _amplitude_range(A_range):
    """``A_range`` as floats (low, high), checked: finite, 0 ≤ low < high (m)."""
    try:
        lo, hi = (real_number(x, "A_range") for x in A_range)
    except (TypeError, ValueError):
        lo = hi = math.nan
    if not (0.0 <= lo < hi and math.isfinite(hi)):
        raise ValueError(f"A_range must be (low, high) in m with 0 ≤ low < high, both finite, "
                         f"got {A_range!r}.")
    return float(lo), float(hi)


@frequency_as_keyword
@_warnings_at_caller
def boundaries(system, params, about, *, omega, A_range=None, amplitude="A",
               frequency="omega", tol=1e-10, seed_every=10, scan=64, side=1e-6,
               min_width=None, order=16, guard_tol=1e-8) -> BoundaryCurves:
    """The stability boundaries A_k(ω) of ``about`` over a frequency grid, by continuation.

    Every ``seed_every``-th frequency (and the last) is scanned over ``A_range`` for
    changes between stable and unstable — between the scan points too, down to
    ``min_width``, as :func:`window` does; each change is solved to ``tol`` on the
    smooth margin of its kind ("T", "2T", "complex"; see :func:`window`), and followed
    through the
    frequencies in between by predictor–corrector continuation (a few monodromies per
    point), all curves together; finally every point is classified at A(1 ∓ ``side``)
    and kept only where exactly its stable side is stable
    (``kapitza.floquet._curves.trace_curves``).

    Parameters
    ----------
    system, params, about, amplitude, frequency, tol, order, guard_tol
        As for :func:`window` (about a periodic orbit too: followed from the lowest
        amplitude of ``A_range``).
    omega : 1-d array
        Drive angular frequencies (rad/s), ascending, keyword; the finer, the shorter each
        continuation step.  (kapitza 0.1's ``boundaries(system, params, about, omega)``
        still works in 0.2, with a DeprecationWarning.)
    A_range : (float, float), optional
        Amplitudes searched (m), ``(low, high)`` with 0 ≤ low < high; default from 0 to
        the largest scan limit of :func:`window`.
    seed_every, scan : int
        Seed frequencies' spacing (in grid points) and their scans' evenly spaced
        points.  Slivers thinner than the scan's spacing are searched for at the seed
        frequencies as :func:`window` does (guarantee there, ``min_width``); a curve
        that bounds only a sliver between two seed frequencies and none at a seed is
        found only if continuation reaches it.
    min_width : float, optional
        The resolution (m) of the seed scans; default 1e-8 × the largest amplitude of
        ``A_range``.  Where a sliver narrower than it cannot be ruled out at a seed
        frequency, a RuntimeWarning names the frequency and amplitudes.
    side : float
        Relative offset of the side checks.

    Returns
    -------
    kapitza.results.BoundaryCurves
        ``A`` (curves × ω; NaN where a curve does not bound the stable region),
        ``accuracy``, ``kind``, ``stable_below``; draw them over a map with
        ``kapitza.stability_map_figure(map, overlays=[curves])``.

    Examples
    --------
    The upright pendulum: the Kapitza limit (a multiplier at +1, stable above) and the
    first parametric resonance (at −1, stable below), as the Mathieu equation has them:

    >>> import math
    >>> import numpy as np
    >>> from lagrange_core import problems
    >>> from kapitza.closed_forms import pendulum_window
    >>> w = np.linspace(30.0, 60.0, 7)
    >>> curves = boundaries(problems.driven_pendulum("vertical"), dict(m=1.0, l=1.0, g=9.81),
    ...                     [math.pi], omega=w, A_range=(0.0, 0.6))
    >>> curves.kind, curves.stable_below.tolist()
    (('T', '2T'), [False, True])
    >>> ref = pendulum_window(w, l=1.0, g=9.81)
    >>> bool(np.allclose(curves.A, [ref.A_min, ref.A_max], rtol=1e-9))
    True
    """
    t0 = time.perf_counter()
    w = arguments.grid_axis(frequency, omega, "rad/s", positive=True)
    if w.size < 2 or not np.all(np.diff(w) > 0):
        raise ValueError(f"{frequency} must be an ascending grid of at least 2 frequencies.")
    _check_tol(tol)
    if A_range is not None:
        lo, hi = _amplitude_range(A_range)
    probe = probe_for(system, params, about, amplitude, frequency, _margin_tol(tol), order,
                      guard_tol, paired=True, classify_tol=CLASSIFY_TOL,
                      probes=_probes(w, 1.0 if A_range is None else hi),
                      start=0.0 if A_range is None else lo, orbit_tol=_orbit_tol(tol))
    if A_range is None:
        lo, hi = 0.0, float(np.max(probe.amplitude_scale(w[[0, -1]])))
    _check_min_width(min_width)
    found = trace_curves(probe, w, _scan_grid(lo, hi, scan), tol, seed_every=seed_every,
                         side=side, min_width=min_width)
    return BoundaryCurves(omega=w, A=found["A"], accuracy=found["accuracy"],
                          kind=tuple(KINDS[int(k)] for k in found["kind"]),
                          stable_below=found["stable_below"], about=probe.label,
                          params=dict(probe.fixed), A_range=(lo, hi), tol=tol,
                          seconds=time.perf_counter() - t0, monodromies=probe.count)
