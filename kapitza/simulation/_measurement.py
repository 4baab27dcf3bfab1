"""Measurements from direct simulation: what the full nonlinear motion does, with error bars.

Averaging and Floquet analysis predict; direct integration of the full equations checks
them.  :func:`measure_grid` integrates a driven system over a broadcast grid of
parameters and initial states in one compiled call
(:meth:`lagrange_core.System.simulate_grid`) and reduces every trajectory to a
:class:`~kapitza.results.Measurement`: did it stay near the state ``about``, when did it
leave, its slow frequencies with error estimates, its slow amplitude, its mean position
and (for a conserved energy) the energy drift.  :func:`measure` is one point of it, and
:meth:`kapitza.KapitzaPendulum.measure` / ``measure_grid`` the pendulum's form.

A measurement computes what is asked (``observables``) and no more: the classification
(stayed, fall time, deviation, mean) comes from observables the batch kernel keeps as it
steps, at the engine's speed; the strobe samples are recorded only for the slow
amplitude or Ω, and fitted only for Ω (the fit's loops compiled:
:mod:`kapitza.simulation._strobe_fit`).  A long run goes in parts of about a quarter of a
second, exactly as one run, with progress and Ctrl-C between them.

Stroboscopic samples
--------------------
With a drive of period T = 2π/ω, the state x_k = [q, q̇](t0 + kT) sampled once per
drive period removes the fast motion exactly: x_(k+1) = P(x_k), with P the period map.
A driven equilibrium or a T-periodic orbit (the horizontally driven pendulum's tilted
state, the elliptic pivot's hanging state) is a fixed point x* of P, and the slow
motion about it is the sequence x_k.  The samples are the integrator's own solution at
t0 + kT (its steps land on them), not an interpolation.

The slow frequencies: estimator (:func:`slow_frequencies`)
-----------------------------------------------------------
1. **Linear strobe map** (dynamic-mode decomposition).  A least-squares fit
   x_(k+1) ≈ M x_k + b over the record, each component centred and scaled by its spread.
   The eigenvalues of M come in pairs e^((σ ± iΩ)T); each pair with Im λ > 0 is a slow
   mode: Ω = arg λ / T, growth rate σ = log|λ| / T.  For linear motion the fit is exact
   (M is the monodromy matrix of Floquet analysis) and so are all n slow frequencies of
   an n-coordinate system at once.  For a finite-amplitude oscillation the harmonics of
   the slow motion leave a fit residual r (relative, ``fit_residual``) and bias Ω.
2. **Rotation number** (the refinement).  The projection z_k = vᵀ(x_k − x*) on the
   mode's left eigenvector v turns by the mode's phase every period (exactly λ for
   linear motion).  For nonlinear motion on an invariant curve (a torus for several
   modes) the mean turning angle is still the mode's rotation number ΩT, and the
   weighted Birkhoff average with weights exp(−1/(s(1 − s))), s ∈ (0, 1) the position in
   the record (Das, Saiki, Sander & Yorke, Nonlinearity 30, 2017), converges faster than
   any power of the record length for quasi-periodic or periodic motion.  A mode is
   refined when every turning angle lies within π/2 of arg λ (z winds cleanly about 0);
   otherwise it keeps the linear value (``refined`` is False).
3. **Error estimate** ``omega_slow_error``, the sum of
   (a) ``SAFETY`` × the largest difference between the whole record's Ω and those of its
   first, second and middle halves (steps 1–2 repeated on each; a half record's
   estimate is the worse one, so this bounds the whole record's error wherever the
   error shrinks with the record's length);
   (b) for a mode not refined, the linear fit's bias, ``RESIDUAL_FACTOR`` · r² Ω;
   (c) near a resonance ΩT ≈ 2πp/q that the record cannot resolve (within 1/(q m)
   turns for m sample pairs: the samples visit only q short arcs of the slow orbit), the
   distance to it plus 2π/(q m T) — only for the q whose harmonics matter, r^(q/2) >
   1e-13, and q = 1 (fewer than one slow period in the record);
   (d) for several modes in a combination resonance a Ω_i + b Ω_j ≈ 0 mod ω (|a| + |b| ≤
   12) with a beat longer than the record, the telescoping bound of the weighted mean:
   half the range of the mode's phase departure times Σ|Δw|;
   and never below 1e-12 ω (rounding).  A record's decayed tail (a damped mode below
   1e-3 of its largest distance from x*) is left out first.  On 100 000 synthetic
   sequences with known rotation numbers (nonlinear invariant curves, harmonics up to
   0.3 of the fundamental, 60–1000 samples) the exact Ω lay within the estimate at all
   but two points (outside by 15 % and 5 %, harmonic content ≈ 0.45); the estimate is
   typically ~100× the actual error.  For two modes on a torus with couplings up to 0.05
   about 1 point in 600 lies outside (by up to 4×, a combination resonance).  With fewer
   than 4 (2n + 1) samples Ω is NaN; a half record too short to resolve a mode makes the
   error infinite.

What the error covers, and what it does not:

* It is the error of Ω as the slow frequency of the *simulated* motion.  The strobe
  samples carry the integrator's error (``rtol``), which it does not include: that
  adds of order rtol·|q|/(a ΩT) relative for a slow amplitude a.
* A finite-amplitude oscillation has its own frequency, which differs from the linear
  (small-amplitude) Ω of Floquet analysis or averaging by O(a²): for the upright
  pendulum of Kapitza's 60 Hz, 5 cm example Ω(a) − Ω = −3.09 a² rad/s (measured; the
  quartic term of U_eff, 3βa²/(8Ω) with β = g/(6l) − A²ω²/(3l²), predicts −3.37 a²):
  −2.4·10⁻⁵ relative at a = 0.01 rad.  ``amplitude`` says how far from the linear limit
  a measurement is; two amplitudes a and 2a extrapolate to it, (4 Ω(a) − Ω(2a))/3.

Aliasing: samples once per drive period see e^(iΩkT), which cannot tell Ω from Ω + jω
or from −Ω.  Every slow frequency is therefore reported folded into [0, ω/2] — the
convention of Floquet's ``omega_slow``, arg λ / T — and a mode whose true slow
frequency lies between ω/2 and ω is reported as ω − Ω.  Kapitza's slow motion (Ω ≪ ω)
lies far inside; Ω reaches ω/2 at the upper edge of the stability window (the first
parametric resonance).  The record must also span a few slow periods, K Ω T / (2π) for K
samples: with fewer than about two, the halves disagree and the error is large (with
fewer than 8 (2n + 1) samples, Ω is NaN).

Stayed, fell
------------
``band`` is a half-width about ``about`` (per coordinate; default π/2): a trajectory
that leaves |q_i − about_i| < band_i stops there (the batch kernel's band), and
``stayed_up`` is False with ``fall_time`` the time it left.  For the inverted pendulum
this is the criterion |θ − π| < π/2 throughout.  Slow frequencies are measured on the
samples recorded before the stop.
"""
from __future__ import annotations

import dataclasses
import math
import os
from collections.abc import Mapping

import numpy as np

from lagrange_core import _background, _lanes_ahead
from lagrange_core._compile_notice import declared
from lagrange_core._first_calls import compiling
from lagrange_core.batch import GridInterrupted, compile_activity, default_method, runs_on_lanes
from lagrange_core.checks import real_array, real_number
from lagrange_core.progress import ProgressLine, defer_ctrl_c, interrupt_requested

from .._arguments import (
    SWEEP_FIX,
    check_grid_memory,
    grid_shape,
    measure_bytes_per_point,
    whole_number,
)
from ..results import ComputationInterrupted, Measurement
from . import _strobe_fit
from ._strobe_fit import estimate, record_extent

__all__ = ["measure", "measure_grid", "slow_frequencies", "Measurement", "RESIDUAL_FACTOR",
           "DEFAULT_PERIODS", "CLASSIFICATION_RTOL", "CLASSIFICATION_RTOL_OTHER", "OMEGA_RTOL",
           "OBSERVABLES"]

#: Drive periods simulated by default: about 30 slow periods at Ω/ω ≈ 1/30 (Kapitza's regime).
DEFAULT_PERIODS = 1000
#: The error estimate is this many times the largest difference between the whole record's
#: estimate and those of its halves (first, second, middle); see the module docstring.
SAFETY = 2.0
#: A mode that is not refined by its rotation number carries the linear fit's bias,
#: bounded by this factor times r² Ω (r the relative fit residual); see the module docstring.
RESIDUAL_FACTOR = 10.0
#: Points whose strobe samples are analysed together (bounds the copies' memory).
_CHUNK = 1024
#: The relative tolerance of a measurement that only classifies (stayed up, fall time,
#: deviation; ``observables="classification"``) when ``rtol`` is not given, for RKN 12
#: (the default method of q̈ = f(q, t)).  Its adaptive step is also held to at most 3/4
#: of a drive period, so the trajectory is far more accurate than rtol: on the inverted
#: pendulum's 64 × 64 (A, f) grid of benchmarks/bench_measure.py (500 periods from
#: 0.1 rad) rtol 1e-4 classifies all 4096 points as a reference at 1e-12 does, with the
#: final angle within 7e-4 rad (median 1.4e-5) and fall times within 0.4 % of the
#: reference's; rtol 1e-3 also classified all, with errors 5× larger.  A point within the
#: integration error of the edge of stability can be classified either way at any
#: tolerance: tighten rtol to decide it.
CLASSIFICATION_RTOL = 1e-4
#: The same for every other method (DOP853: damped or velocity-dependent systems), whose
#: steps are not capped by the drive: on the same grid DOP853 misclassified 8 points at
#: rtol 1e-3 and none at 1e-4, 1e-5 or 1e-6; this keeps two decades from the first failure.
#: Damped (γ = 0.5 1/s, DOP853 on lanes: benchmarks/bench_damped_grid.py), against the
#: per-point DOP853 at 1e-11: 5 of 4096 at 1e-3, none at 1e-4, 1e-5 or 1e-6.
CLASSIFICATION_RTOL_OTHER = 1e-6
#: The relative tolerance when slow frequencies are measured (the integration error enters
#: Ω as rtol·|q|/(a Ω T), see above).
OMEGA_RTOL = 1e-9
#: After Ctrl-C the samples recorded are fitted for Ω only up to this many in all (about
#: half a second of the fit), so that the partial result comes back within a second.
_INTERRUPTED_FIT_SAMPLES = 2_000_000
#: What a measurement can compute beyond the classification, and the fields each adds.
OBSERVABLES = {"amplitude": ("amplitude", "samples"),
               "omega_slow": ("omega_slow", "omega_slow_error", "refined", "growth_rate",
                              "fit_residual", "samples")}


# -- the estimator --------------------------------------------------------------------------

def _resonance(Om, period, count, residual):
    """The error added near a resonance ΩT ≈ 2πp/q that the record cannot resolve.

    Samples whose turning angle ρ = ΩT lies within 2π/(q m) of 2πp/q (m pairs) visit
    only q short arcs of the slow orbit: the record is shorter than the beat period, and
    the estimate cannot be told from the resonant value, and the truth may lie anywhere
    in the window: the error is the distance plus the window's half-width 1/(q m) turns.
    Harmonics of order q of the phase have a relative size of about r^(q/2) (r the fit
    residual), so only q ≤ Q matter, r^(Q/2) = 1e-13, 2 ≤ Q ≤ 64; q = 1 is a record
    shorter than one slow period."""
    with np.errstate(divide="ignore", invalid="ignore"):
        r = np.clip(np.nan_to_num(residual, nan=0.5), 1e-300, 0.9)
        top = np.clip(np.ceil(2 * np.log(1e-13) / np.log(r)), 2, 64).astype(int)[:, None]
    turns = np.nan_to_num(Om * period[:, None] / (2 * np.pi))
    extra = np.zeros_like(Om)
    for q in range(1, int(top.max(initial=2)) + 1):
        d = np.abs(turns - np.round(q * turns) / q)
        near = (q <= top) & ((count[:, None] - 1) * q * d < 1)
        width = d + 1 / (q * np.maximum(count[:, None] - 1, 1))
        extra = np.where(near, np.maximum(extra, 2 * np.pi * width / period[:, None]), extra)
    return extra


def _combination(Om, period, count, residual, largest=12):
    """Modes in a combination resonance a ρ_i + b ρ_j ≈ 2πp (a, b ≠ 0, |a| + |b| ≤ Q)
    whose beat is longer than the record (bool, like ``Om``); Q as in :func:`_resonance`,
    at most ``largest``."""
    P, n = Om.shape
    hit = np.zeros(Om.shape, dtype=bool)
    if n < 2:
        return hit
    with np.errstate(divide="ignore", invalid="ignore"):
        r = np.clip(np.nan_to_num(residual, nan=0.5), 1e-300, 0.9)
        top = np.clip(np.ceil(2 * np.log(1e-13) / np.log(r)), 2, largest).astype(int)
    turns = np.nan_to_num(Om * period[:, None] / (2 * np.pi))
    span = count - 1
    for i in range(n):
        for j in range(i + 1, n):
            for a in range(1, largest):
                for b in range(-(largest - a), largest - a + 1):
                    if b == 0:
                        continue
                    x = a * turns[:, i] + b * turns[:, j]
                    near = (a + abs(b) <= top) & (span * np.abs(x - np.round(x)) < 1)
                    hit[:, i] |= near
                    hit[:, j] |= near
    return hit


#: On a cold cache ``measure`` compiles in one background process, on the other core,
#: while its grid's driver compiles here (:func:`_compile_in_background`): first RKN 12
#: lanes driver's callees, which it calls by address (:mod:`lagrange_core._lanes_ahead`;
#: the first undamped measure 12.6–13.5 s on empty caches, 2026-11-28),
#: then the fit's kernels (5.5 s on an empty cache, 0.6 s to load, 2026-11-27).  The fit's
#: records: two coordinates' slow oscillations and one's (its 2 × 2 solve), long enough
#: for every fit.
_GROUP = "measure kernels"
_FIT_CODE = """\
import numpy as np
from kapitza.simulation import slow_frequencies
k = np.arange(400)
T = 2 * np.pi / 377.0
q = np.stack([np.pi + 0.01 * np.cos(0.05 * k), 0.02 * np.cos(0.13 * k + 0.3)], -1)[None]
qdot = np.stack([-0.01 * 0.05 / T * np.sin(0.05 * k),
                 -0.02 * 0.13 / T * np.sin(0.13 * k + 0.3)], -1)[None]
slow_frequencies(q, qdot, T)
slow_frequencies(q[..., :1], qdot[..., :1], T)
"""


#: the fit's compiled kernels (:mod:`kapitza.simulation._strobe_fit`)
_FIT_KERNELS = (_strobe_fit._valid_lengths, _strobe_fit._moments, _strobe_fit._residuals,
                _strobe_fit._rotation, _strobe_fit._solve_2)


def _fit_in_process() -> bool:
    """Whether this process has the fit's kernels already (compiled or loaded)."""
    return bool(_strobe_fit._moments.signatures)


def _fit_ready() -> bool:
    """Whether the fit's kernels are in this process or load from numba's cache: a fit
    after Ctrl-C must not wait for a compilation (in the background or here)."""
    if _fit_in_process():
        return True
    if compiling():             # a compilation Ctrl-C gave up on holds numba's compiler
        return False
    proc = _background.RUNNING.get(_GROUP)
    if proc is not None and proc.poll() is None:
        return False
    return not _background.cold(*_FIT_KERNELS)


def _compile_in_background(system, method, fit: bool) -> None:
    """On a cold cache, with background compiles allowed (:mod:`lagrange_core._background`) and
    a second core: start one background process for what this measurement will compile
    and the other core can compile meanwhile — RKN 12 lanes driver's callees when the
    grid runs on them (:func:`lagrange_core.batch.runs_on_lanes`), then the fit's
    kernels when ``fit`` (Ω is wanted); :func:`_estimate_chunked` waits for it.  One
    process, not two: on two cores a third would slow this one's compile."""
    if not _background.enabled() or (os.cpu_count() or 1) < 2:
        return
    code = []
    # the fit's kernels first: the lanes' callees are needed sooner, but this process
    # compiles them too once its driver has compiled, from the last back, while the
    # background process goes from the first (lagrange_core._lanes_callees.addresses);
    # the fit's, needed last, only the background process compiles
    if fit and not _fit_in_process() and _background.cold(*_FIT_KERNELS):
        code.append(_FIT_CODE)
    if runs_on_lanes(system.kernels, method) and _lanes_ahead.wanted():
        code.append(_lanes_ahead.CODE)
    if code:
        _background.start(_GROUP, "".join(code))


def _estimate_chunked(q, qdot, period, progress=False):
    """The estimator (:func:`kapitza.simulation._strobe_fit.estimate`, compiled) over the
    points in chunks of ``_CHUNK`` (bounded copies), with a progress line ("fitting Ω")
    and Ctrl-C between chunks (:func:`lagrange_core.progress.defer_ctrl_c` active): then
    the points not reached are NaN.  Returns (fields, points fitted)."""
    P = q.shape[0]
    _background.wait((_GROUP,))     # the fit's kernels, compiling in the background

    def fit(a, b):
        return estimate(q[a:b], qdot[a:b], period[a:b], safety=SAFETY,
                        residual_factor=RESIDUAL_FACTOR, resonance=_resonance,
                        combination=_combination)

    if P <= _CHUNK:
        return fit(0, P), P
    parts = []
    done, size = 0, _CHUNK
    bar = ProgressLine(progress, P, "fitting Ω", "points")
    while done < P:
        parts.append(fit(done, min(P, done + size)))
        done = min(P, done + size)
        bar.update(done)
        if interrupt_requested():
            break
    bar.close()
    fields = {key: np.concatenate([p[key] for p in parts]) for key in parts[0]}
    if done < P:                         # Ctrl-C: the points not fitted are NaN
        fields = {key: np.concatenate([v, np.full((P - done,) + v.shape[1:], np.nan
                                                  if v.dtype.kind == "f" else 0, v.dtype)])
                  for key, v in fields.items()}
    return fields, done


def slow_frequencies(strobe_q, strobe_qdot, period):
    """Slow angular frequencies from stroboscopic samples, with their error estimates.

    Parameters
    ----------
    strobe_q, strobe_qdot : array_like (..., K, n)
        q and q̇ (SI units of the coordinates, per second) at t0 + kT, k = 0 … K − 1;
        NaN after a record's last sample (only the finite prefix is used).
    period : float or array_like (...)
        The drive period T (s), broadcast against the leading axes.

    Returns
    -------
    omega_slow, omega_slow_error : ndarray (..., n)
        The slow frequencies (rad/s) of each point in ascending order, folded into
        [0, ω/2] (aliasing; see the module docstring), and their error estimates;
        NaN where a mode is not resolved.  The method (a linear strobe map refined by
        the rotation number, the error from the two halves of the record) is in the
        module docstring.

    Examples
    --------
    A linear oscillation at Ω = 2 rad/s sampled every T = 0.1 s (ω = 62.8 rad/s):

    >>> import numpy as np
    >>> k = np.arange(400)
    >>> q = 0.1 * np.cos(2.0 * 0.1 * k + 0.3)[:, None]
    >>> qdot = -0.2 * np.sin(2.0 * 0.1 * k + 0.3)[:, None]
    >>> om, err = slow_frequencies(q, qdot, 0.1)
    >>> print(f"{om[0]:.12f} ± {err[0]:.0e}")
    2.000000000000 ± 6e-11
    """
    q = np.asarray(strobe_q, dtype=float)
    qdot = np.asarray(strobe_qdot, dtype=float)
    if q.ndim < 2 or q.shape != qdot.shape:
        raise ValueError(f"strobe_q and strobe_qdot must have the same shape (..., K, n), got "
                         f"{q.shape} and {qdot.shape}.")
    lead, (K, n) = q.shape[:-2], q.shape[-2:]
    T = np.asarray(period, dtype=float)
    try:
        T = np.broadcast_to(T, lead)
    except ValueError:
        raise ValueError(f"period must broadcast against the leading axes {lead}, got shape "
                         f"{T.shape}.") from None
    if not np.all(np.isfinite(T) & (T > 0)):
        raise ValueError("period must be a positive, finite drive period T (s).")
    P = int(np.prod(lead, dtype=np.int64))
    est, _ = _estimate_chunked(q.reshape(P, K, n), qdot.reshape(P, K, n), T.reshape(P))
    return (est["omega_slow"].reshape(lead + (n,)), est["omega_slow_error"].reshape(lead + (n,)))


# -- measurements ------------------------------------------------------------------------

def _numbers(value, what, finite):
    """``value`` as a float array: finite (:func:`lagrange_core.checks.real_array`), or
    with ±inf allowed (``finite=False``); strings, booleans and NaN refused."""
    if finite:
        return real_array(value, what)
    try:
        if isinstance(value, (str, bool)) or np.asarray(value).dtype.kind not in "iuf":
            raise TypeError
        arr = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise ValueError(f"{what} must be numbers (inf: unbounded), got {value!r}.") from None
    if np.isnan(arr).any():
        raise ValueError(f"{what} must not be NaN (inf: unbounded), got {value!r}.")
    return arr


def _coordinate_values(system, values, what, missing=None, finite=True):
    """A per-coordinate input as a float array (..., n): an array whose last axis has n
    entries, a scalar (every coordinate), or a dict coordinate -> value(s) (a coordinate
    left out takes ``missing``, or is an error when ``missing`` is None); ±inf allowed
    unless ``finite``."""
    n, names = system.n_dof, list(system.coordinates)
    if isinstance(values, Mapping):
        unknown = sorted(set(map(str, values)) - set(names))
        absent = [c for c in names if c not in values]
        if unknown or (absent and missing is None):
            raise ValueError(f"{what}: the coordinates are {names}; unknown {unknown}, "
                             f"missing {absent}.")
        cols = [_numbers(values.get(c, missing), f"{what}[{c!r}]", finite) for c in names]
        return np.stack(np.broadcast_arrays(*cols), axis=-1)
    arr = _numbers(values, what, finite)
    if arr.ndim == 0:
        return np.full(n, float(arr))
    if arr.shape[-1] != n:
        raise ValueError(f"{what} must have a last axis of {n} entries (one per coordinate "
                         f"{names}), got shape {arr.shape}; or pass a dict coordinate -> "
                         "value(s).")
    return arr


def _strobe_frequency(system, params, frequency):
    """ω of the strobe (rad/s, an array): the parameter named ``frequency``, or a number."""
    names = system.parameters
    if not isinstance(params, Mapping):
        raise ValueError(f"params must be a dict of the parameters of {system!r}: "
                         f"{list(names)}.")
    if isinstance(frequency, str):
        if frequency not in names:
            raise ValueError(f"the drive frequency parameter {frequency!r} is not a parameter "
                             f"of {system!r} ({list(names)}); pass frequency=<name>, or the "
                             "strobe's angular frequency (rad/s) as a number.")
        if frequency not in params:
            raise ValueError(f"params has no value for the drive frequency {frequency!r}.")
        omega = real_array(params[frequency], f"parameter {frequency!r}")
    else:
        omega = real_array(frequency, "frequency", unit="rad/s")
    if not np.all(omega > 0):
        raise ValueError(f"the drive frequency {frequency!r} must be > 0 (rad/s), got "
                         f"{omega if omega.ndim == 0 else omega.min()}.")
    return omega




def measure_grid(system, params, about, q0, qdot0=0.0, *, periods=DEFAULT_PERIODS,
                 band=math.pi / 2, frequency="omega", t0=0.0, observables="all", method=None,
                 rtol=None, atol=None, max_steps=None, progress=None) -> Measurement:
    """Simulate a driven system over a broadcast grid and measure every trajectory.

    Parameters
    ----------
    system : lagrange_core.System
        Driven with angular frequency ``params[frequency]`` (period T = 2π/ω); any
        statement :meth:`~lagrange_core.System.simulate_grid` runs (N-link chains on
        a vibrating pivot, the elliptic pivot, user systems).
    params : dict
        Every parameter by name: scalars or arrays, broadcast numpy-style with each
        other and with ``about``, ``q0``, ``qdot0`` and ``band`` (e.g.
        ``A[:, None], omega[None, :]`` for an (A, ω) grid).
    about : array_like (..., n) or dict coordinate -> value(s)
        The state the motion is measured about (coordinates; as ``about`` of
        :func:`kapitza.floquet.floquet_point`): a driven equilibrium, or the position
        of a T-periodic orbit (a drive with no equilibrium); it may vary over the grid.
        It centres the band and is the reference of ``max_deviation``.
    q0, qdot0 : array_like (..., n) or dict coordinate -> value(s)
        The initial state at t0 (a scalar ``qdot0`` for every coordinate).
    periods : int
        Drive periods to simulate; the strobe samples are t0 + kT, k = 0 … periods.
    band : float, array_like (..., n), dict coordinate -> half-width, or None
        Half-width of the band |q_i − about_i| < band_i (a dict leaves the coordinates
        it omits unbounded); a trajectory that leaves it stops there and has not
        ``stayed_up``.  Default π/2 (an angle's quarter turn); None: no band.
    frequency : str or float
        The name of the drive's angular-frequency parameter ω, or ω itself (rad/s; e.g.
        to sample a system without a drive, whose energy drift is then measured).
    t0 : float
        Start time (s): the drive's phase at the start.
    observables : "all", "classification", or a collection of "amplitude", "omega_slow"
        What to measure; a measurement computes what is asked and no more.  Always, as
        the steps are taken and at no extra cost: ``stayed_up``, ``fall_time``,
        ``status``, ``max_deviation``, ``mean_angle``, ``energy_drift``, ``t_reached``,
        ``completed_periods``.  "amplitude" adds the slow amplitude (from the strobe
        samples: the steps are then the longest that divide the drive period, so they
        land on every sample); "omega_slow" adds ``omega_slow`` with its error,
        ``refined``, ``growth_rate`` and ``fit_residual`` (the strobe samples and their
        fit, the module docstring).  "all" (default) is both; "classification" neither
        (those fields are None).
    method, rtol, atol, max_steps, progress
        As for :meth:`lagrange_core.System.simulate_grid`.  ``rtol`` None: 1e-9
        (:data:`OMEGA_RTOL`) when Ω or the amplitude is measured; to classify only, what
        a classification needs: 1e-4 with RKN 12 (:data:`CLASSIFICATION_RTOL`, where its
        accuracy is stated), 1e-6 with another method (DOP853, damped systems).
        ``progress``: a line on stderr when it is a terminal and the run takes over half
        a second (a long run shows its share of the span reached and the time left).

    Returns
    -------
    kapitza.results.Measurement
        Every field an array of the grid's shape S (+ (n,) per mode or coordinate).
        How each is measured: the module docstring.

    Raises
    ------
    ValueError
        Bad input, or an initial state outside its band.
    kapitza.results.ComputationInterrupted
        On Ctrl-C (within a second; the integration within milliseconds: a long run is
        integrated in parts, which pause at the next step on Ctrl-C and otherwise go on
        exactly where the last part stopped): ``.result`` is the
        measurement of everything computed — the finished points, the points stopped
        part-way (status "interrupted", measured up to ``t_reached``,
        ``completed_periods``) and the points not started (status "not_run");
        ``.computed`` marks the finished ones.

    Examples
    --------
    The upright 2-link chain (equal links, 1 m, 1 kg) on a pivot shaken vertically at
    A = 5 cm, ω = 300 rad/s stays up; both slow modes are measured at once, a little
    below Floquet's linear 5.736 and 36.611 rad/s (the 0.01 rad amplitude's own shift):

    >>> import numpy as np, sympy as sp
    >>> from lagrange_core import problems, t
    >>> A, w = sp.symbols("A omega", positive=True)
    >>> chain = problems.n_link_pendulum(2, pivot=(0, A * sp.cos(w * t)))
    >>> P = dict(g=9.81, l1=1.0, l2=1.0, m1=1.0, m2=1.0, A=0.05, omega=300.0)
    >>> m = measure(chain, P, [np.pi, np.pi], [np.pi - 0.01, np.pi + 0.01], periods=2000)
    >>> m.stayed_up, m.omega_slow.round(3).tolist(), bool(np.all(m.omega_slow_error < 1e-7))
    (True, [5.735, 36.595], True)
    """
    periods = whole_number(periods, "periods", 1)
    wanted = _observables(observables)
    if rtol is None:
        run = default_method(system.kernels) if method is None else method
        rkn = run in ("rkn12", "rkn12-fixed")
        rtol = (OMEGA_RTOL if wanted else CLASSIFICATION_RTOL if rkn
                else CLASSIFICATION_RTOL_OTHER)
    omega = _strobe_frequency(system, params, frequency)
    period = 2 * np.pi / omega
    t0 = real_number(t0, "t0", unit="s")
    ref = _coordinate_values(system, about, "about")
    start = _coordinate_values(system, q0, "q0")
    rate = _coordinate_values(system, qdot0, "qdot0")
    shape = grid_shape(*params.values(), ref[..., 0], start[..., 0], rate[..., 0])
    check_grid_memory("params, about, q0, qdot0 (broadcast)", shape,
        measure_bytes_per_point(system.n_dof, periods if wanted else 0), where="measure_grid: ",
        fix="use fewer periods (the strobe samples of every period are kept for Ω and the "
            "amplitude) or observables='classification' (none kept: any number of periods); "
            "or " + SWEEP_FIX)
    lohi = None
    if band is not None:
        half = _coordinate_values(system, band, "band", missing=np.inf, finite=False)
        if not np.all(half > 0):
            raise ValueError("band must be a positive half-width (inf: unbounded) per "
                             "coordinate.")
        lohi = (ref - half, ref + half)
        if np.any(lohi[0] == lohi[1]):      # |about| so large the band rounds away
            raise ValueError(f"about = {ref.reshape(-1)[:3].tolist()} ...: so large that a "
                             "float cannot resolve the band about it (about ± band round to "
                             "one value); give the state within a few turns of 0 (angles "
                             "mod 2π).")
        try:
            outside = ~(np.abs(start - ref) < half)
        except ValueError:
            outside = np.zeros(1, dtype=bool)      # shapes that do not broadcast: said below
        if outside.any():
            raise ValueError(
                f"q0 = {np.broadcast_to(start, outside.shape)[outside][:3].tolist()} ... lies "
                f"outside the band |q − about| < band about "
                f"{np.broadcast_to(ref, outside.shape)[outside][:3].tolist()}: "
                "a run must start inside it. Pass the state it starts near as `about`, a wider "
                "band, or band=None.")
    # Ctrl-C, from here on, stops the simulation or the fit between compiled calls; a
    # first compile of the shared kernels says how long measuring with this driver
    # compiles (the grid's and the fit's kernels)
    _compile_in_background(system, method, "omega_slow" in wanted)
    points = None if shape is None else math.prod(shape)
    with defer_ctrl_c(), declared(compile_activity("measure", system.kernels, method, points)):
        try:
            grid = system.simulate_grid(start, rate, (t0, t0 + periods * period), params,
                                        method=method, rtol=rtol, atol=atol,
                                        strobe=period if wanted else None, reference=ref,
                                        band=lohi,
                                        energy=bool(system.kernels.energy_conserved),
                                        max_steps=max_steps, progress=progress)
        except GridInterrupted as stop:
            # what ran is measured; Ω only where its fit is quick (Ctrl-C: "stop now")
            with np.errstate(invalid="ignore"):
                ran = np.floor((stop.result.t_final - stop.result.t0) / period)
            samples = float(np.sum(ran[np.isfinite(ran)]))
            if wanted and not _fit_ready():     # Ω and the amplitude use its kernels
                why = "the fit's kernels were still compiling"
                fitted = frozenset()
            elif "omega_slow" in wanted and samples > _INTERRUPTED_FIT_SAMPLES:
                why = (f"over {_INTERRUPTED_FIT_SAMPLES:.0e} strobe samples: a fit of "
                       "seconds after Ctrl-C")
                fitted = wanted - {"omega_slow"}
            else:
                why, fitted = None, wanted
            partial, _ = _from_grid(system, stop.result, ref, periods, period, fitted, False)
            raise _interrupted(partial, why, wanted - fitted) from None
        result, fitted = _from_grid(system, grid, ref, periods, period, wanted, progress)
        if fitted is not None:       # Ctrl-C during the fit: Ω of the points fitted
            stop = ComputationInterrupted(result, np.arange(result.stayed_up.size).reshape(
                result.shape) < fitted)
            stop.args = (f"measurement interrupted while fitting Ω: every run finished, Ω "
                         f"fitted for {fitted} of {result.stayed_up.size} points (NaN for the "
                         "others, marked False in .computed); the measurement is in the "
                         "exception's .result",)
            raise stop
    return result


def _observables(observables):
    """The groups of :data:`OBSERVABLES` asked for (a frozenset; empty: classification)."""
    given = (observables,) if isinstance(observables, str) else observables
    try:
        names = {str(x) for x in given} if not isinstance(given, (bytes, Mapping)) else None
    except TypeError:
        names = None
    choices = ("all", "classification", *OBSERVABLES)
    if names is None or not names <= set(choices) or not names:
        raise ValueError(f"observables must be 'all', 'classification', or a list of "
                         f"{sorted(OBSERVABLES)}; got {observables!r}.")
    if "all" in names:
        return frozenset(OBSERVABLES)
    return frozenset(names - {"classification"})


def _interrupted(partial, why=None, left=frozenset()):
    """ComputationInterrupted for a measurement stopped by Ctrl-C, saying how far it got
    (and why the observables ``left`` were not computed)."""
    status = np.asarray(partial.status)
    finished = (status != "not_run") & (status != "interrupted")
    stop = ComputationInterrupted(partial, finished)
    part = status == "interrupted"
    if part.any():
        reached = np.asarray(partial.completed_periods)[part]
        first = np.asarray(partial.t_reached)[part].reshape(-1)[0]
        stop.args = (f"measurement interrupted: {int(finished.sum())} of {finished.size} "
                     f"points finished, {int(part.sum())} stopped part-way (the first at t = "
                     f"{first:.6g} s, {int(reached.reshape(-1)[0])} of {partial.periods} "
                     "periods); the partial measurement (status 'interrupted', t_reached, "
                     "completed_periods) is in the exception's .result"
                     + (f"; {' and '.join(sorted(left))} not computed ({why}): "
                        "their fields are None" if left else ""),)
    return stop


def _from_grid(system, grid, ref, periods, period, wanted, progress):
    """The measurement of every point of a :class:`lagrange_core.batch.GridTrajectories`
    (the groups of observables ``wanted``: :func:`_observables`), and None — or, if
    Ctrl-C stopped the fit of Ω, the number of points fitted (in flat order)."""
    S, n = grid.shape, system.n_dof
    P = int(np.prod(S, dtype=np.int64))
    period = np.broadcast_to(period, S)
    fields = dict.fromkeys(OBSERVABLES["amplitude"] + OBSERVABLES["omega_slow"])
    stopped = None
    if wanted:
        # the samples up to the last any run reached (a run stopped early, by a fall or
        # Ctrl-C, has NaN beyond: no need to copy them)
        with np.errstate(invalid="ignore"):
            reached = np.floor((grid.t_final - grid.t0) / period * (1 + 1e-12))
        # (no run started — Ctrl-C before the first step — leaves nothing to fit: not the
        # 3·10⁷ NaN samples of a long run, 2–4 s of a fit after the Ctrl-C)
        last = np.nanmax(reached) if np.isfinite(reached).any() else 0.0
        K = int(min(grid.strobe_q.shape[-2], last + 2))
        q = grid.strobe_q[..., :K, :].reshape(P, K, n)
        qdot = grid.strobe_qdot[..., :K, :].reshape(P, K, n)
        if "omega_slow" in wanted:
            est, done = _estimate_chunked(q, qdot, period.reshape(P), progress)
            stopped = done if done < P else None
        else:
            est = dict(zip(("amplitude", "samples"), record_extent(q, qdot), strict=True))
        for name in set().union(*(OBSERVABLES[w] for w in wanted)):
            shape = S + (n,) if name in ("omega_slow", "omega_slow_error", "refined",
                                         "growth_rate", "amplitude") else S
            fields[name] = est[name].reshape(shape)
    status = grid.status_name
    left = status == "left_band"
    with np.errstate(invalid="ignore"):
        fall = np.where(left, grid.exit_time - grid.t0, np.nan) if grid.exit_time is not None \
            else np.full(S, np.nan)
        done = np.floor((grid.t_final - grid.t0) / period * (1 + 1e-12))
    completed = np.where(np.isfinite(done), done, 0).astype(np.int64)
    energy = grid.energy_drift if system.kernels.energy_conserved else None
    return Measurement(
        coordinates=tuple(system.coordinates), params=dict(grid.params),
        about=np.broadcast_to(ref, S + (n,)).copy(), period=np.array(period),
        periods=periods, stayed_up=status == "finished", fall_time=fall,
        mean_angle=grid.q_mean, max_deviation=grid.max_deviation, energy_drift=energy,
        status=status, method=grid.method, rtol=grid.rtol, t_reached=grid.t_final,
        completed_periods=np.minimum(completed, periods), **fields), stopped


def measure(system, params, about, q0, qdot0=0.0, **options) -> Measurement:
    """Simulate one parameter set of a driven system and measure the motion.

    The one-point form of :func:`measure_grid` (same arguments and options, scalar
    parameters, ``about``, ``q0`` and ``qdot0`` of one state each).  Returns a
    :class:`~kapitza.results.Measurement` whose point fields are Python scalars and whose
    per-mode and per-coordinate fields are arrays of n entries (floats for a system of
    one coordinate).  Example: :func:`measure_grid`.

    A long run (``periods`` in the millions) is integrated in parts of about a quarter
    of a second, each going on exactly where the last stopped: a progress line with the
    time left shows on a terminal, and Ctrl-C raises
    :class:`~kapitza.results.ComputationInterrupted` within a second, whose ``.result``
    is the measurement of the run so far (status "interrupted", ``t_reached``,
    ``completed_periods``; Ω from the samples up to there).
    """
    if isinstance(params, Mapping):
        for k, v in params.items():
            if np.ndim(v) != 0:
                raise ValueError(f"measure takes scalar parameters; {k!r} is an array. Use "
                                 "measure_grid for grids.")
    try:
        result = measure_grid(system, params, about, q0, qdot0, **options)
    except ComputationInterrupted as stop:
        raise one_point_interrupted(stop) from None
    if result.shape != ():
        raise ValueError(f"measure measures one point; about, q0 and qdot0 give the grid "
                         f"shape {result.shape}. Use measure_grid for grids.")
    return point(result)


def one_point_interrupted(stop):
    """The ComputationInterrupted of a one-point measurement: its ``.result`` as
    :func:`point` makes it (Python scalars), the message kept."""
    result = stop.result
    one = ComputationInterrupted(point(result) if result.shape == () else result, stop.computed)
    one.args = stop.args
    return one


def point(m: Measurement) -> Measurement:
    """A one-point measurement with Python scalars (0-d fields) and, for a system of one
    coordinate, floats in the per-mode and per-coordinate fields."""
    def value(x):
        if x is None or isinstance(x, (str, int, float, tuple)):
            return x
        x = np.asarray(x)
        if x.ndim == 1 and x.size == 1:
            x = x[0]
        return x.item() if x.ndim == 0 else x
    return dataclasses.replace(
        m, params={k: value(v) for k, v in m.params.items()},
        **{f.name: value(getattr(m, f.name)) for f in dataclasses.fields(m)
           if f.name not in ("coordinates", "params", "method", "rtol", "periods")})


def squeeze(m: Measurement) -> Measurement:
    """A one-coordinate system's measurement with the per-mode and per-coordinate fields
    of the grid's shape (the last axis, of one entry, dropped)."""
    return dataclasses.replace(
        m, **{name: None if getattr(m, name) is None else np.asarray(getattr(m, name))[..., 0]
              for name in ("about", "omega_slow", "omega_slow_error", "refined", "growth_rate",
                           "amplitude", "mean_angle", "max_deviation")})


# -- the driven pendulum's states ------------------------------------------------------------

def pendulum_about(about, A, omega, theta0, *, l, g, drive):
    """θ (rad) of the state the pendulum's motion is measured about, per point.

    ``about``: "inverted" (θ = π), "hanging" (θ = 0), "tilted" (horizontal drive: the
    averaged tilt cos θ* = 2 g l/(A² ω²) on θ0's side, θ = 0 where A² ω² ≤ 2 g l and the
    hanging state is the stable one; shared/PHYSICS.md), None (vertical drive "inverted",
    horizontal "tilted"), or angles (rad).  A named state is taken in θ0's turn (the
    copy nearest θ0: θ0 = 3π − 0.1 is measured about 3π)."""
    if about is None:
        about = "inverted" if drive == "vertical" else "tilted"
    theta0 = np.asarray(theta0, dtype=float)
    if isinstance(about, str):
        if about == "inverted":
            return math.pi + 2 * math.pi * np.round((theta0 - math.pi) / (2 * math.pi))
        turn = 2 * math.pi * np.round(theta0 / (2 * math.pi))
        if about == "hanging":
            return turn
        if about != "tilted":
            raise ValueError(f"about must be 'inverted', 'hanging', 'tilted' (horizontal drive) "
                             f"or an angle (rad), got {about!r}.")
        if drive != "horizontal":
            raise ValueError("about='tilted' is the horizontally driven pendulum's state; the "
                             "vertical drive's tilted equilibria are unstable. Use 'inverted' "
                             "or 'hanging'.")
        with np.errstate(divide="ignore"):
            tilt = np.arccos(np.minimum(1.0, 2 * g * l / (np.asarray(A) * omega) ** 2))
        return turn + np.where(theta0 - turn >= 0, 1.0, -1.0) * tilt
    return real_array(about, "about")
