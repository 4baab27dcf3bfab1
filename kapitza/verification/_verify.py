"""Verification: averaging, Floquet analysis and direct simulation, compared point by point.

Averaging and Floquet analysis predict; direct integration of the full nonlinear motion
checks them.  :func:`verify` runs four methods over a broadcast grid of drive amplitudes
A and frequencies ω about a driven equilibrium of any system, and
:meth:`kapitza.KapitzaPendulum.verify` does it for the pendulum (through
:func:`pendulum_verification`); both return a :class:`~kapitza.results.Verification`.

The four methods
----------------
averaging (first order)
    The pendulum: the closed forms (:func:`kapitza.pendulum_averaged`, order 1).  Any
    system: :meth:`kapitza.averaging.AveragedSystem.slow_modes` at every point.  Stable:
    the averaged linearisation is; Ω: its slow frequencies (the damped ones with damping).
averaging (next order)
    The vertically driven single pendulum only (order 2 of
    :func:`kapitza.pendulum_averaged`, from the Mathieu series).  :mod:`kapitza.averaging`
    is first order, so a general system has no next order here: its ``*_averaging_2``
    fields are None, and ``notes`` says so.
Floquet
    :func:`kapitza.floquet_grid` about the equilibrium: the exact linear stability, and
    Ω = arg λ / T from the multipliers (the vertically driven pendulum: the same from its
    Mathieu equation's monodromy trace, :mod:`kapitza.closed_forms._floquet`).
simulation
    :func:`kapitza.measure_grid` (the pendulum: :meth:`kapitza.KapitzaPendulum.measure_grid`)
    released at rest a small offset from the equilibrium: stable = stayed within the
    band (default π/2; for the pendulum |θ − π| < π/2 throughout) for ``periods`` drive
    periods; Ω from the stroboscopic samples.  A failed integration leaves its point
    unclassified by simulation.

When two slow frequencies agree
-------------------------------
Each method states an error for its Ω, and two methods agree on Ω when
|Ω_a − Ω_b| ≤ tol_a + tol_b for every mode both resolve:

* Floquet: a pair of multipliers e^(±iΩT) whose monodromy is in error by
  δ = error_estimate · max(1, ‖M‖) turns by about δ / |sin ΩT| (first-order
  perturbation; √δ where sin ΩT → 0): tol = δ / (T max(|sin ΩT|, √δ)).
* Simulation: the measurement's ``omega_slow_error`` (:mod:`kapitza.simulation`), plus the
  two errors it states it leaves out: the integration's, rtol·|q|/(a T) (|q| =
  max(1, |about|), a the slow amplitude), and the amplitude's own shift of a finite
  oscillation from the linear Ω, O(a²).  The pendulum: |3 β a² / (8 Ω)| with
  β = g/(6l) − A²ω²/(3l²) (the quartic term of U_eff).  Any system: measured, by a
  second run released at half the offset: SHIFT_SAFETY × (4/3) |Ω(a) − Ω(a/2)| + that
  run's ``omega_slow_error`` (the extrapolation of a shift ∝ a², doubled for the terms
  of higher order; on the double pendulum at A = 4 cm,
  ω = 300 rad/s it is 2 · 10⁻⁴ and 4.5 · 10⁻⁴ of the two Ω at a = 0.01 rad, 10⁴ times
  the estimator's error, and scales as a² from 0.001 to 0.02 rad).
* Next-order averaging (the pendulum): the terms of ν² it drops are O(s³) with
  s = |a′| + q²/2 (the Mathieu parameters a′ = a − γ²/ω², q = 2A/l), so
  tol = ORDER2_FACTOR · s³/(2ν²) · Ω with ν = 2Ω/ω.  Measured against the exact Ω at
  1454 random points where averaging is valid (A/l ≤ 0.3, 1.6 ≤ ω/ω0 ≤ 160, l = 1 m):
  the actual error is at most 1.32 s³/(2ν²) (3.2 up to A/l = 0.45, by the parametric
  resonance).
* First-order averaging, the pendulum: |Ω1 − Ω2| + the next order's tol (the triangle
  inequality; inf where the next order finds no oscillation).
* First-order averaging, any system: ε² Ω per mode with ε² = (Ω/ω)² + r², r the fast
  displacement per unit slow displacement (``amplitude_ratio`` of
  :class:`~kapitza.results.SlowModes`; A/l for the pendulum): the relative size of the
  neglected terms (:mod:`kapitza.averaging`).  On the pendulum this bounds the actual
  error except near the Kapitza limit, where Ω → 0 and the relative error of any fixed
  order grows without bound.

Where methods disagree
----------------------
Every disagreement is kept, not averaged away (``Verification.disagreements``): located
by A, ω, A/l, ω/ω0 and its distance to the nearest Floquet stability boundary along A,
|A − A_b| / A.

* The pendulum: A_b are the edges of the exact window at the point's ω
  (:func:`kapitza.pendulum_window`, certified to ``tol``).  For the
  upright pendulum the first window is the only one below A/l = FIRST_WINDOW_ONLY (the
  next, a₁(q) < a, begins at q = 2A/l ≈ 7.5); beyond it the distance is NaN.
* Any system: the boundaries are located along A at each frequency of the grid, between
  neighbouring amplitudes that Floquet classifies differently, by ``BISECTIONS`` steps of
  bisection (one Floquet grid per step).  A boundary pair between two samples of the same
  class is not seen; a point whose frequency shows no change of class has distance inf.

Disagreements to expect near a boundary.  The simulation differs from linear Floquet in
two ways: a weakly unstable point whose growth e^(σt) is too slow to leave the band
during the run stays up, and a stable point released beyond its separatrix falls.  For
the upright pendulum released at rest at an angle a from the upright, averaging puts the
separatrix at a² = 2δ, δ = A²ω²/(2gl) − 1: releases closer than about a²/4 (relative, in
A) to the lower boundary fall.  Averaging differs from Floquet near the lower boundary by
its own error (first order: O(ε²) relative in A), and beyond the upper (parametric
resonance) boundary, which first-order averaging cannot see.

Only disagreements where both methods claim validity count against them
(``Verification.disagreements_within_validity``; ``kapitza verify`` exits 1 on any):
averaging where its own ``valid`` flag holds (beyond A/l = 0.3, so beyond every upper
edge, it does not), Floquet where its classification is certified (margin > 1), the
simulation where its run classified the point.  The others are reported
(``Verification.outside_validity``), not failed.

The order of averaging
----------------------
First-order averaging neglects terms of relative order ε², ε² ~ ω0²/ω² ~ A²/l²
(shared/PHYSICS.md): both small together.  Along a line of fixed drive velocity A ω
(A ∝ 1/ω) the first-order prediction is fixed (for a pivot drive U_eff depends on A ω
only) and the neglected terms shrink together: the pendulum's relative error in Ω is
ε² |2κ² − 25κ⁴/32| / (κ² − 2) + O(ε⁴) with ε = ω0/ω and κ = A ω/√(g l) (from the next
order), exponent 2, and the next order's is O(ε⁴), exponent 4.  At fixed A/l instead the
error does not vanish as ω → ∞: it tends to (25/32)(A/l)², its O((A/l)²) part
(exponent 0).

The default line: the pendulum κ = 2 (A ω = 2√(g l), where Ω1 = ω0; κ² = 64/25, where
the ε² coefficient vanishes, is avoided), ω = ω0 × LINE_RATIOS (ε from 0.1 to 1/300).
Any system: A ω = √2 × its first-order minimum at the grid's highest ω (κ = 2 on the
pendulum), ε = Ω1/ω with Ω1 the largest first-order slow frequency on the line (ω0 on
the pendulum's line), ω = Ω1 × LINE_RATIOS.  The fit is least squares of log error on
log ε over the points whose error exceeds RESOLVED × Floquet's own bound, with the
slope's standard error from the residuals.
"""
from __future__ import annotations

import math
from collections.abc import Mapping

import numpy as np

from lagrange_core.checks import real_array

from .. import _arguments as arguments
from ..averaging import average
from ..closed_forms import (
    mathieu_parameters,
    pendulum_averaged,
    pendulum_floquet,
    pendulum_window,
    slow_frequency_error,
)
from ..floquet import floquet_grid
from ..results import OrderFit, Verification
from ..simulation import DEFAULT_PERIODS, measure_grid

__all__ = ["verify", "pendulum_verification", "fit_order", "line_argument", "LINE_RATIOS",
           "ORDER2_FACTOR", "RESOLVED", "BISECTIONS", "FIRST_WINDOW_ONLY", "SHIFT_SAFETY",
           "KAPPA"]

#: The line on which the order of averaging is fitted: ω = Ω1 × these ratios (ε = 0.1 … 1/300).
LINE_RATIOS = np.geomspace(10.0, 300.0, 12)
#: Next-order averaging's Ω tolerance, in units of s³/(2ν²) Ω (see the module docstring).
ORDER2_FACTOR = 2.0
#: A point of the line enters the fit when its error exceeds this many times Floquet's bound.
RESOLVED = 10.0
#: Bisection steps that locate a general system's boundary (the bracket shrinks 2^-24).
BISECTIONS = 24
#: The measured amplitude shift of Ω (a general system's simulation) counts this many times.
SHIFT_SAFETY = 2.0
#: Below this A/l the upright pendulum's first window is its only one (a₁(2A/l) > 0).
FIRST_WINDOW_ONLY = 3.5
#: The pendulum's line: A ω = KAPPA √(g l), where first-order averaging gives Ω1 = ω0.
KAPPA = 2.0


# -- the four methods ----------------------------------------------------------------------

def _floquet_fields(grid):
    """stable (S), Ω (S, n) ascending, its tolerance (S, n) and the margin of a FloquetGrid."""
    omega_slow = np.sort(np.asarray(grid.omega_slow, dtype=float), axis=-1)
    with np.errstate(over="ignore", invalid="ignore"):
        norm = np.sqrt(np.sum(np.abs(grid.monodromy) ** 2, axis=(-2, -1)))
    delta = (np.asarray(grid.error_estimate) * np.maximum(1.0, norm))[..., None]
    tol = slow_frequency_error(omega_slow, np.asarray(grid.period)[..., None], delta)
    return np.asarray(grid.stable, bool), omega_slow, tol, np.asarray(grid.margin, float)


def _general_averaging(avg, p, about, frequency, shape, n):
    """First-order averaging at every point: stable, Ω (S, n), tolerance (S, n), valid."""
    names = list(p)
    arrays = np.broadcast_arrays(*[np.asarray(p[k], float) for k in names])
    stable = np.zeros(shape, bool)
    valid = np.zeros(shape, bool)
    omega_slow = np.full(shape + (n,), np.nan)
    tol = np.full(shape + (n,), np.inf)
    for idx in np.ndindex(shape):
        point = {k: float(a[idx]) for k, a in zip(names, arrays, strict=True)}
        modes = avg.slow_modes(point, about, warn=False)
        freq = np.sort(modes.damped_frequencies)
        stable[idx], valid[idx] = modes.stable, modes.valid
        if modes.stable:
            omega_slow[idx] = freq
            eps2 = (freq / point[frequency]) ** 2 + modes.amplitude_ratio ** 2
            tol[idx] = eps2 * freq
    return stable, omega_slow, tol, valid


def _simulation_fields(measured, about, rtol):
    """stable (S), Ω (S, n), tolerance (S, n) (the measurement's error + the integration's),
    slow amplitude (S), status, fall time of a Measurement."""
    S = measured.shape
    omega_slow = np.asarray(measured.omega_slow, dtype=float).reshape(S + (-1,))
    error = np.asarray(measured.omega_slow_error, dtype=float).reshape(S + (-1,))
    amplitude = np.asarray(measured.amplitude, dtype=float).reshape(S + (-1,)).max(axis=-1)
    scale = max(1.0, float(np.max(np.abs(about))))
    with np.errstate(divide="ignore", invalid="ignore"):
        integration = rtol * scale / (amplitude * np.asarray(measured.period))
    tol = error + integration[..., None]
    return (np.asarray(measured.stayed_up, bool), omega_slow, tol, amplitude,
            np.asarray(measured.status), np.asarray(measured.fall_time, dtype=float))


def _amplitude_shift(omega_slow, half):
    """The shift of the measured Ω from its small-amplitude limit, measured: Ω(a) − Ω(0) ≈
    (4/3) (Ω(a) − Ω(a/2)) for a shift ∝ a², times SHIFT_SAFETY, plus the half-amplitude
    run's own error (0 where either run resolves no Ω)."""
    S = half.shape
    omega_half = np.asarray(half.omega_slow, dtype=float).reshape(S + (-1,))
    error_half = np.asarray(half.omega_slow_error, dtype=float).reshape(S + (-1,))
    shift = SHIFT_SAFETY * 4 / 3 * np.abs(omega_slow - omega_half) + error_half
    return np.where(np.isfinite(shift), shift, 0.0)


# -- boundaries ------------------------------------------------------------------------------

def _nearest(A, candidates):
    """|A − A_b|/A to the nearest of each point's candidate boundaries (P, m; NaN: none),
    and that A_b: (distance, nearest), inf and NaN where a point has none."""
    with np.errstate(divide="ignore", invalid="ignore"):
        d = np.abs(A[:, None] - candidates) / A[:, None]
    d = np.where(np.isfinite(candidates), d, np.inf)
    if d.shape[1] == 0:
        return np.full(A.shape, np.inf), np.full(A.shape, np.nan)
    j = np.argmin(d, axis=1)
    dist = d[np.arange(len(A)), j]
    return dist, np.where(np.isfinite(dist), candidates[np.arange(len(A)), j], np.nan)


def _per_frequency(omega, boundary_A, boundary_omega):
    """Each point's candidate boundaries: those located at its frequency (P, m), NaN-padded."""
    keys, inverse = np.unique(omega, return_inverse=True)
    lists = [boundary_A[boundary_omega == k] for k in keys]
    width = max((len(x) for x in lists), default=0)
    table = np.full((len(keys), width), np.nan)
    for i, x in enumerate(lists):
        table[i, :len(x)] = x
    return table[inverse.reshape(-1)]


def _located_boundaries(system, fixed, about, amplitude, frequency, A, omega, stable, tol):
    """Boundaries along A at each frequency of the grid, by bisection between neighbouring
    amplitudes Floquet classifies differently: (A_b, ω_b)."""
    a, w, s = A.ravel(), omega.ravel(), stable.ravel()
    lo, hi, below, at = [], [], [], []
    for key in np.unique(w):
        idx = np.flatnonzero(w == key)
        idx = idx[np.argsort(a[idx], kind="stable")]
        for j in np.flatnonzero((s[idx][1:] != s[idx][:-1]) & (a[idx][1:] > a[idx][:-1])):
            lo.append(a[idx[j]])
            hi.append(a[idx[j + 1]])
            below.append(s[idx[j]])
            at.append(key)
    lo, hi, below, at = (np.asarray(x, dtype=d) for x, d in ((lo, float), (hi, float),
                                                              (below, bool), (at, float)))
    for _ in range(BISECTIONS if lo.size else 0):
        mid = (lo + hi) / 2
        grid = floquet_grid(system, dict(fixed, **{amplitude: mid, frequency: at}), about,
                            frequency=frequency, tol=tol, progress=False)
        same = np.asarray(grid.stable) == below
        lo, hi = np.where(same, mid, lo), np.where(same, hi, mid)
    return (lo + hi) / 2, at


# -- the order of averaging --------------------------------------------------------------------

def fit_order(epsilon, error, floor):
    """Least-squares exponent of ``error`` ≈ c ε^p on log-log axes.

    Parameters
    ----------
    epsilon, error, floor : array_like (k,)
        The small parameter, the relative error, and the reference's own relative error
        bound; points whose error is not above ``RESOLVED`` × floor (or not finite) are
        left out.

    Returns
    -------
    exponent, exponent_error, prefactor : float
        p, its standard error from the residuals (NaN with fewer than 3 points), c.
    used : bool ndarray (k,)

    Examples
    --------
    An error 3 ε² (1 + ε), whose next order bends the line a little:

    >>> import numpy as np
    >>> eps = np.geomspace(0.1, 0.01, 5)
    >>> p, se, c, used = fit_order(eps, 3 * eps**2 * (1 + eps), np.zeros(5))
    >>> print(f"p = {p:.3f} ± {se:.3f}, c = {c:.2f}, {used.sum()} points")
    p = 2.036 ± 0.007, c = 3.54, 5 points
    """
    eps = np.asarray(epsilon, dtype=float)
    err = np.asarray(error, dtype=float)
    with np.errstate(invalid="ignore"):
        used = np.isfinite(eps) & (eps > 0) & np.isfinite(err) & (err > 0) & \
            (err > RESOLVED * np.nan_to_num(np.asarray(floor, dtype=float), nan=np.inf))
    k = int(used.sum())
    if k < 3:
        return math.nan, math.nan, math.nan, used
    x, y = np.log(eps[used]), np.log(err[used])
    dx = x - x.mean()
    p = float(dx @ (y - y.mean()) / (dx @ dx))
    intercept = float(y.mean() - p * x.mean())
    residual = y - intercept - p * x
    se = float(math.sqrt(residual @ residual / (k - 2) / (dx @ dx)))
    return p, se, math.exp(intercept), used


def _order_fit(order, text, eps, omega, A, omega_slow, reference, tol_reference, theory):
    """An OrderFit from the line's averaging Ω (k, n) against Floquet's (k, n)."""
    with np.errstate(invalid="ignore", divide="ignore"):
        error = np.fmax.reduce(np.abs(omega_slow - reference) / reference, axis=-1)
        floor = np.max(tol_reference / reference, axis=-1)
    p, se, c, used = fit_order(eps, error, floor)
    return OrderFit(order=order, small_parameter=text, epsilon=eps, omega=omega, A=A,
                    error=error, floor=floor, used=used, exponent=p, exponent_error=se,
                    prefactor=c, theory=theory)


def line_argument(line):
    """The ``line`` argument of :func:`verify` checked: None, False, or (velocity, omega)
    as (float, 1-d array)."""
    if line is None or line is False:
        return line
    try:
        velocity, omega = line
    except (TypeError, ValueError):
        raise ValueError("line must be None (the default line), False (no fit) or "
                         "(velocity, omega): the drive velocity A ω and the frequencies "
                         "(rad/s) of the line A = velocity/ω.") from None
    velocity = arguments.real_number(velocity, "line velocity", minimum=0.0, strict=True)
    omega = arguments.grid_axis("line omega", omega, "rad/s", positive=True)
    return velocity, omega


# -- any system ------------------------------------------------------------------------------

def verify(system, params, about, *, A, omega, amplitude="A", frequency="omega", q0=None,
           qdot0=0.0, offset=0.01, periods=DEFAULT_PERIODS, band=math.pi / 2, tol=1e-10,
           rtol=1e-9, method=None, length=None, omega0=None, line=None,
           progress=None) -> Verification:
    """Averaging, Floquet analysis and direct simulation of a driven equilibrium, compared.

    Parameters
    ----------
    system : lagrange_core.System
        Driven periodically through the parameters named ``amplitude`` and ``frequency``
        (e.g. an N-link chain on a pivot moving as (0, A cos ωt)), with an equilibrium
        ``about`` that persists under the drive (Floquet analysis needs one).
    params : dict
        The other parameters (scalars).
    about : sequence or dict
        The equilibrium's coordinates.
    A, omega : array_like
        The drive amplitudes and angular frequencies (rad/s), broadcast numpy-style
        (``A[:, None], omega[None, :]`` for a grid).
    amplitude, frequency : str
        The names of the drive's amplitude and angular-frequency parameters.
    q0, qdot0 : array_like, optional
        The simulations' initial state (arrays (..., n) broadcast with the grid, or a
        scalar ``qdot0``); default ``about`` + ``offset`` × (+1, −1, +1, …) per
        coordinate, at rest.  A second run from half the offset (``about`` + (q0 −
        about)/2, qdot0/2) measures the amplitude's own shift of Ω (module docstring).
    offset : float
        The default release's distance from ``about``.
    periods, band, rtol, method
        Drive periods simulated, the band the motion must stay within, the integration's
        relative tolerance and method (:func:`kapitza.measure_grid`).
    tol : float
        Floquet's tolerance (:func:`kapitza.floquet_grid`).
    length, omega0 : float, optional
        The length and frequency that make the dimensionless axes A/length and
        ω/omega0 of the table and the figure.
    line : None, False or (velocity, omega)
        Where the order of first-order averaging is fitted: the points
        A = velocity/ω at the given ω.  None: the default line (module docstring);
        False: no fit.
    progress : None, bool or callable
        For the Floquet grid and the simulations (:func:`kapitza.floquet_grid`,
        :func:`kapitza.measure_grid`).

    Returns
    -------
    kapitza.results.Verification
        ``stable_*``, ``omega_slow_*``, ``tolerance_*`` per method and point (no
        next-order averaging: ``*_averaging_2`` are None), ``agreement``,
        ``disagreements``, the boundary distances, ``fits`` (the order of first-order
        averaging), ``to_dataframe()``, ``figure()``.  Tolerances, boundaries and the
        line: :mod:`kapitza.verification`.

    Examples
    --------
    The upright double pendulum (1 m links, 1 kg bobs) on a vertically shaken pivot,
    at three drive amplitudes at ω = 300 rad/s (first-order minimum: A = 1.93 cm):

    >>> import math, numpy as np, sympy as sp
    >>> from lagrange_core import problems, t
    >>> a, w = sp.symbols("A omega", positive=True)
    >>> chain = problems.n_link_pendulum(2, pivot=(0, a * sp.cos(w * t)))
    >>> v = verify(chain, dict(g=9.81, l1=1.0, l2=1.0, m1=1.0, m2=1.0), [math.pi, math.pi],
    ...            A=np.array([0.015, 0.03, 0.06]), omega=300.0, periods=500, line=False)
    >>> v.stable_floquet.tolist(), v.stable_simulation.tolist()
    ([False, True, True], [False, True, True])
    >>> v.agreement.query("first == 'floquet' and second == 'simulation'").fraction.tolist()
    [1.0, 1.0]
    """
    if not isinstance(params, Mapping):
        raise ValueError(f"params must be a dict of the parameters of {system!r} other than "
                         f"the drive's: {list(system.parameters)}.")
    for name, what in ((amplitude, "amplitude"), (frequency, "frequency")):
        if name not in system.parameters:
            raise ValueError(f"the drive's {what} {name!r} is not a parameter of {system!r} "
                             f"({list(system.parameters)}); pass {what}=<name>.")
    line = line_argument(line)
    fixed = {k: v for k, v in params.items() if k not in (amplitude, frequency)}
    for k, v in fixed.items():
        if np.ndim(v):
            raise ValueError(f"params must be scalars (the grid is A × omega); {k!r} is an "
                             "array.")
    A = real_array(A, amplitude)
    omega = arguments.frequency(omega, where="verify: ")
    try:
        A, omega = (np.array(x, dtype=float) for x in np.broadcast_arrays(A, omega))
    except ValueError:
        raise ValueError(f"A and omega must broadcast together, got shapes {np.shape(A)} and "
                         f"{np.shape(omega)}.") from None
    S, n = A.shape, system.n_dof
    qa = system.coordinate_array(about, "about")
    if q0 is None:
        q0 = qa + offset * (-1.0) ** np.arange(n)
    p = dict(fixed, **{amplitude: A, frequency: omega})
    avg = average(system, frequency=frequency)
    stable_avg, omega_avg, tol_avg, valid = _general_averaging(avg, p, qa, frequency, S, n)
    stable_fl, omega_fl, tol_fl, margin = _floquet_fields(
        floquet_grid(system, p, qa, frequency=frequency, tol=tol, progress=progress))
    measured = measure_grid(system, p, qa, q0, qdot0, periods=periods, band=band,
                            frequency=frequency, method=method, rtol=rtol, progress=progress,
                            observables=("omega_slow", "amplitude"))
    sim = list(_simulation_fields(measured, qa, rtol))
    half = measure_grid(system, p, qa, qa + (np.asarray(q0, dtype=float) - qa) / 2,
                        np.asarray(qdot0, dtype=float) / 2, periods=periods, band=band,
                        frequency=frequency, method=method, rtol=rtol, progress=progress,
                        observables="omega_slow")
    sim[2] = sim[2] + _amplitude_shift(sim[1], half)
    A_b, omega_b = _located_boundaries(system, fixed, qa, amplitude, frequency, A, omega,
                                       stable_fl, tol)
    distance, nearest = _nearest(A.ravel(), _per_frequency(omega.ravel(), A_b, omega_b))
    notes = ["next-order averaging: none for a general system (kapitza.averaging is first "
             "order; the vertically driven single pendulum has one, KapitzaPendulum.verify)",
             f"boundaries located by bisection along {amplitude} at the grid's frequencies, "
             "between neighbouring amplitudes Floquet classifies differently; inf: none there"]
    fits = ()
    if line is not False:
        fit, note = _general_line(avg, system, fixed, qa, amplitude, frequency, A, omega,
                                  stable_avg, tol, line)
        fits = (fit,) if fit is not None else ()
        notes += [note] if note else []
    squeeze = (lambda x: x[..., 0]) if n == 1 else (lambda x: x)    # noqa: E731
    return Verification(
        A=A, omega=omega, about=str(np.asarray(qa).tolist()), length=length, omega0=omega0,
        stable_averaging=stable_avg, stable_averaging_2=None, stable_floquet=stable_fl,
        stable_simulation=sim[0], omega_slow_averaging=squeeze(omega_avg),
        omega_slow_averaging_2=None, omega_slow_floquet=squeeze(omega_fl),
        omega_slow_simulation=squeeze(sim[1]), tolerance_averaging=squeeze(tol_avg),
        tolerance_averaging_2=None, tolerance_floquet=squeeze(tol_fl),
        tolerance_simulation=squeeze(sim[2]), averaging_valid=valid, floquet_margin=margin,
        simulation_status=sim[4], fall_time=sim[5], amplitude=sim[3],
        boundary_distance=distance.reshape(S), nearest_boundary=nearest.reshape(S),
        boundary_A=A_b, boundary_omega=omega_b, window=None, fits=fits, periods=periods,
        tol=tol, rtol=rtol, notes=tuple(notes))


def _general_line(avg, system, fixed, about, amplitude, frequency, A, omega, stable, tol, line):
    """The order of first-order averaging along A ω = const: (OrderFit or None, note)."""
    def slow(a, w):
        modes = avg.slow_modes(dict(fixed, **{amplitude: a, frequency: w}), about, warn=False)
        return np.where(modes.stable, np.sort(modes.damped_frequencies), np.nan)

    if line is None:
        w_ref = float(omega.max())
        try:
            a_min = avg.minimum_amplitude(dict(fixed, **{frequency: w_ref}), about,
                                          amplitude=amplitude)
        except ValueError as err:
            return None, f"no order fit: {err}"
        velocity = math.sqrt(2.0) * a_min * w_ref
        if velocity == 0.0:
            if not stable.any():
                return None, "no order fit: averaging finds no stable point to draw a line through"
            velocity = float(np.median((A * omega)[stable]))
        top = np.fmax.reduce(slow(velocity / w_ref, w_ref))
        if not np.isfinite(top):
            return None, (f"no order fit: first-order averaging finds {amplitude}·ω = "
                          f"{velocity:.4g} unstable at ω = {w_ref:.4g} rad/s")
        w_line = top * LINE_RATIOS
    else:
        velocity, w_line = line
    a_line = velocity / w_line
    averaged = np.array([slow(a, w) for a, w in zip(a_line, w_line, strict=True)])
    top = np.fmax.reduce(averaged, axis=-1)
    spread = float(np.nanmax(np.abs(top / top[0] - 1))) if np.isfinite(top[0]) else math.inf
    stable_fl, omega_fl, tol_fl, _ = _floquet_fields(floquet_grid(
        system, dict(fixed, **{amplitude: a_line, frequency: w_line}), about,
        frequency=frequency, tol=tol, progress=False))
    omega_fl = np.where(stable_fl[:, None], omega_fl, np.nan)
    note = ""
    theory = 2.0
    if not spread < 1e-6:
        theory = math.nan
        note = (f"order fit: first-order averaging's Ω varies along the line {amplitude}·ω = "
                f"{velocity:.4g} (by {spread:.2g}): the drive is not a pivot's, and the theory's "
                "exponent is not known here")
    text = f"ε = Ω1/ω along {amplitude}·ω = {velocity:.4g} (Ω1 = {top[0]:.4g} rad/s)"
    return _order_fit(1, text, top[0] / w_line, w_line, a_line, averaged, omega_fl, tol_fl,
                      theory), note


# -- the pendulum ----------------------------------------------------------------------------

def pendulum_verification(A, omega, measured, *, l, g, damping, tol=1e-10, rtol=1e-9,
                          line=None) -> Verification:
    """The upright pendulum's verification from its simulations (the vertical drive).

    The work behind :meth:`kapitza.KapitzaPendulum.verify`, which simulates and calls
    this: ``A``, ``omega`` (broadcast to ``measured``'s shape), ``measured`` the
    :class:`~kapitza.results.Measurement` of :meth:`~kapitza.KapitzaPendulum.measure_grid`
    about θ = π, ``l``, ``g``, ``damping`` the pendulum's constants; ``tol`` (Floquet's),
    ``rtol`` and ``line`` as for :func:`verify` (the default line: A ω = 2√(g l), ε = ω0/ω).
    Averaging in closed form at first and next order, Floquet from the Mathieu equation's
    monodromy trace (:mod:`kapitza.closed_forms._floquet`: the numbers of
    :func:`kapitza.floquet_grid` for this system), boundary distances to the exact window's
    edges.
    """
    line = line_argument(line)
    S = measured.shape
    A, omega = (np.array(np.broadcast_to(x, S), dtype=float) for x in (A, omega))
    w0 = math.sqrt(g / l)
    constants = dict(l=l, g=g, damping=damping)
    # the general monodromy's numbers from Mathieu's trace (closed_forms._floquet: equal to
    # floquet_grid's within their error bounds, tests/test_verify.py), without
    # compiling the general Floquet kernels (~20 s of a first report on an empty cache)
    exact = pendulum_floquet(A, omega, l=l, g=g, damping=damping, about="inverted", tol=tol)
    stable_fl, omega_fl, tol_fl, margin = (exact.stable, exact.omega_slow[..., None],
                                           exact.omega_slow_error[..., None], exact.margin)
    avg = _pendulum_averaging(A, omega, **constants)
    sim = _simulation_fields(measured, [math.pi], rtol)
    stable_sim, omega_sim, tol_sim, amp = sim[:4]
    beta = g / (6 * l) - (A * omega / l) ** 2 / 3
    with np.errstate(divide="ignore", invalid="ignore"):
        tol_sim = tol_sim + (3 * np.abs(beta) * amp ** 2)[..., None] / (8 * omega_sim)
    # the exact window at the grid's frequencies (distances) and on a fine ω grid (figure)
    keys = np.unique(omega)
    edges = pendulum_window(keys, method="floquet", tol=tol, **constants)
    A_b = np.concatenate([edges.A_min, edges.A_max])
    omega_b = np.concatenate([keys, keys])
    candidates = _per_frequency(omega.ravel(), A_b, omega_b)
    distance, nearest = _nearest(A.ravel(), candidates)
    beyond = A.ravel() / l > FIRST_WINDOW_ONLY
    distance[beyond], nearest[beyond] = np.nan, np.nan
    fine = np.linspace(keys[0], keys[-1], 200) if keys.size > 1 else keys
    window = pendulum_window(fine, method="floquet", tol=tol, **constants)
    finite = np.isfinite(A_b)
    notes = [f"boundary distances: to the edges of the exact window at the point's ω (the "
             f"only window below A/l = {FIRST_WINDOW_ONLY}; NaN beyond; inf where ω holds no "
             "window)"]
    fits = ()
    if line is not False:
        fits = _pendulum_line(w0, tol, line, constants)
    return Verification(
        A=A, omega=omega, about="inverted", length=l, omega0=w0,
        stable_averaging=avg[0], stable_averaging_2=avg[1], stable_floquet=stable_fl,
        stable_simulation=stable_sim, omega_slow_averaging=avg[2],
        omega_slow_averaging_2=avg[3], omega_slow_floquet=omega_fl[..., 0],
        omega_slow_simulation=omega_sim[..., 0], tolerance_averaging=avg[4],
        tolerance_averaging_2=avg[5], tolerance_floquet=tol_fl[..., 0],
        tolerance_simulation=tol_sim[..., 0], averaging_valid=avg[6], floquet_margin=margin,
        simulation_status=sim[4], fall_time=sim[5], amplitude=amp,
        boundary_distance=distance.reshape(S), nearest_boundary=nearest.reshape(S),
        boundary_A=A_b[finite], boundary_omega=omega_b[finite], window=window, fits=fits,
        periods=measured.periods, tol=tol, rtol=rtol, notes=tuple(notes),
        averaging_2_valid=avg[7])


def _pendulum_averaging(A, omega, *, l, g, damping):
    """The upright's averaging at first and next order with their tolerances (module
    docstring): stable1, stable2, Ω1, Ω2, tol1, tol2, valid1, valid2 (each order's own
    validity flag)."""
    first, second = (pendulum_averaged(A, omega, l=l, g=g, damping=damping, order=k,
                                       warn=False).inverted for k in (1, 2))
    stable1, stable2 = (np.asarray(e.stable, bool) for e in (first, second))
    omega1, omega2 = (np.where(s, np.asarray(e.damped_frequency, dtype=float), np.nan)
                      for s, e in ((stable1, first), (stable2, second)))
    a, q, c = mathieu_parameters(A, omega, l, g, damping, "inverted")
    s = np.abs(a - c ** 2 / 4) + q ** 2 / 2
    with np.errstate(divide="ignore", invalid="ignore"):
        tol2 = ORDER2_FACTOR * s ** 3 / (2 * (2 * omega2 / omega) ** 2) * omega2
        tol2 = np.where(np.isfinite(tol2), tol2, np.inf)
        tol1 = np.where(np.isfinite(omega1), np.abs(omega1 - omega2) + tol2, np.inf)
        tol1 = np.where(np.isfinite(tol1), tol1, np.inf)
    valid1, valid2 = (np.broadcast_to(np.asarray(e.valid, bool), A.shape).copy()
                      for e in (first, second))
    return stable1, stable2, omega1, omega2, tol1, tol2, valid1, valid2


def _pendulum_line(w0, tol, line, constants):
    """The order of first- and next-order averaging along A ω = const: (OrderFit, OrderFit)."""
    g, l = constants["g"], constants["l"]
    if line is None:
        velocity, w_line = KAPPA * math.sqrt(g * l), w0 * LINE_RATIOS
    else:
        velocity, w_line = line
    a_line = velocity / w_line
    exact = pendulum_floquet(a_line, w_line, l=l, g=g, damping=constants["damping"],
                             about="inverted", tol=tol)
    # (Ω and its error are NaN where Floquet finds the state unstable)
    omega_fl, tol_fl = exact.omega_slow[:, None], exact.omega_slow_error[:, None]
    avg = _pendulum_averaging(a_line, w_line, **constants)
    kappa = velocity / math.sqrt(g * l)
    text = f"ε = ω0/ω along A ω = {kappa:.4g} √(g l)"
    return tuple(_order_fit(order, text, w0 / w_line, w_line, a_line, avg[order + 1][:, None],
                            omega_fl, tol_fl, theory)
                 for order, theory in ((1, 2.0), (2, 4.0)))
