"""The driven pendulum in closed form: averaging, its next order, and Acheson's chain.

Conventions (shared/PHYSICS.md): θ from the downward vertical (θ = π upright); pivot
y_p = A cos ωt (vertical) or x_p = A cos ωt (horizontal); viscous damping γ (1/s):

    θ̈ = −γ θ̇ − (g − A ω² cos ωt) sin θ / l          (vertical drive)

Everything here is a closed form, vectorised over arrays of A and ω (numpy speed, no
compilation): first-order (Kapitza/Landau) averaging of the single pendulum for
either drive, the next order for the vertical drive through the Mathieu equation's
series (:mod:`kapitza.closed_forms._characteristic`), the averaging window, and the
N-link chain on a vertically driven pivot (Acheson 1993), whose modes are single
pendulums.  The general method for any system is :mod:`kapitza.averaging` (whose
validity thresholds apply here too); the exact (Floquet) counterparts are
:func:`kapitza.closed_forms.pendulum_window` and
:func:`kapitza.closed_forms.pendulum_stability_map`.
"""
from __future__ import annotations

import functools
import math
import warnings

import numpy as np

from lagrange_core.checks import real_array
from lagrange_core.progress import run_in_chunks

from .. import _arguments as arguments
from .._deprecation import state_was_first
from ..averaging import MAX_AMPLITUDE_RATIO, MIN_FREQUENCY_RATIO, AveragingValidityWarning
from ..results import (
    ComputationInterrupted,
    EquilibriumPrediction,
    MultiplePendulumPrediction,
    PendulumAveraging,
    StabilityWindow,
)
from ..results import scalar_or_array as _s
from ._characteristic import characteristic_value, exponent_squared, mathieu_b1, mathieu_b1_root
from ._mathieu import amplitude_from_q, mathieu_parameters

__all__ = ["MAX_CORRECTION", "pendulum_effective_potential", "pendulum_averaged",
           "multiple_pendulum_upright"]

#: A vertically driven pendulum's prediction is also flagged invalid when the next-order
#: correction changes the slow frequency or growth rate by more than this fraction, or
#: flips the stability: near the Kapitza limit Ω → 0 any fixed-order result loses its
#: relative accuracy.  Measured against exact Floquet values over 532 random valid points
#: (A/l ≤ 0.3, 10 ≤ ω ≤ 300 rad/s, l = 1 m): first order within 7.4 %, second order
#: within 1.6 %.
MAX_CORRECTION = 0.1




#: Peak memory per point of :func:`pendulum_averaged` (bytes): its inputs, the fields of
#: four equilibria and their temporaries (measured 315 with tracemalloc at order 1, 274 at
#: order 2; rounded up).
AVERAGING_BYTES_PER_POINT = 400
#: Peak memory per point of :func:`pendulum_effective_potential` (bytes): the broadcast
#: drive, sin θ, the terms and the result (five arrays of floats, rounded up).
U_EFF_BYTES_PER_POINT = 64


def _check_squares(where, A, omega):
    """Refuse a drive whose ω² or (A ω)² overflows a float (ω or A ω beyond ~1e154): the
    averaged slow frequencies and U_eff need them (they came out NaN, with numpy's
    overflow warnings)."""
    with np.errstate(over="ignore", invalid="ignore"):
        w_over = ~np.isfinite(omega * omega)
        aw_over = ~np.isfinite((A * omega) ** 2)
    if np.any(w_over):
        raise ValueError(f"{where}: omega = {float(omega[w_over].flat[0])!r} rad/s: ω² "
                         "overflows a float; give ω below 1e150 rad/s.")
    if np.any(aw_over):
        k = np.flatnonzero(aw_over.reshape(-1))[0]
        raise ValueError(f"{where}: A = {float(np.broadcast_to(A, aw_over.shape).flat[k])!r} m "
                         f"at omega = {float(np.broadcast_to(omega, aw_over.shape).flat[k])!r} "
                         "rad/s: (A ω)² overflows a float; give A ω below 1e150 m/s.")


@state_was_first("kapitza.pendulum_effective_potential")
def pendulum_effective_potential(A, omega, *, theta, l=1.0, g=9.81, drive="vertical"):
    """U_eff(θ)/m (J/kg) of the driven pendulum, first-order averaging.

    vertical:   U_eff/m = −g l cos θ + A² ω² sin² θ / 4
    horizontal: U_eff/m = −g l cos θ + A² ω² cos² θ / 4

    Relative error O(ε²), ε² ~ ω0²/ω² ~ A²/l² (see
    ``kapitza.closed_forms._characteristic.exponent_squared``).  Broadcasts over
    A (m), ω (rad/s) and θ (rad).  The drive comes first (``docs/api-conventions.md``
    §2); before kapitza 0.2 the order was ``(theta, A, omega)``, which still works and
    warns.

    Examples
    --------
    Above A ω = √(2 g l) the upright θ = π is a minimum of U_eff:

    >>> import numpy as np
    >>> U = pendulum_effective_potential(0.05, 150.0, theta=np.pi + np.array([-0.1, 0.0, 0.1]))
    >>> bool(U[1] < U[0] and U[1] < U[2])
    True
    """
    drive = arguments.drive_direction(drive)
    l, g, _ = arguments.pendulum_constants(l, g)
    A, omega = arguments.drive(A, omega)
    theta = real_array(theta, "theta", unit="rad")
    shape = arguments.grid_shape(A, theta)
    if shape is None:
        raise ValueError(f"A, omega (shape {A.shape}) and theta (shape {theta.shape}) must "
                         "broadcast together; for U_eff over θ at every drive, give theta "
                         "an axis of its own, e.g. theta[:, None].")
    arguments.check_grid_memory("A × omega × theta (broadcast)", shape, U_EFF_BYTES_PER_POINT,
                                where="pendulum_effective_potential: ", fix="use a coarser grid")
    _check_squares("pendulum_effective_potential", A, omega)
    shake = np.sin(theta) if drive == "vertical" else np.cos(theta)
    return -g * l * np.cos(theta) + (A * omega * shake) ** 2 / 4


def pendulum_averaged(A, omega, *, l=1.0, g=9.81, damping=0.0, drive="vertical", order=1,
                      warn=True, progress=None) -> PendulumAveraging:
    """Equilibria, stability and slow frequencies of the driven pendulum by averaging.

    Parameters
    ----------
    A, omega : float or array
        Drive amplitude (m, ≥ 0) and angular frequency (rad/s, > 0); broadcast.
    l, g, damping : float
        Length (m), gravity (m/s²), viscous damping rate γ (1/s) as in
        θ̈ = −γ θ̇ − (g − A ω² cos ωt) sin θ / l.
    drive : {"vertical", "horizontal"}
    order : {1, 2}
        1: Kapitza/Landau averaging.  Vertical drive: upright stable iff
        A² ω² > 2 g l; Ω² = A² ω²/(2 l²) − g/l (upright), g/l + A² ω²/(2 l²)
        (hanging); relative error of Ω O(ε²), ε² ~ ω0²/ω² ~ A²/l².
        Horizontal drive: tilted equilibria cos θ* = 2 g l/(A² ω²) for
        A² ω² > 2 g l, Ω² = A² ω² sin² θ*/(2 l²); hanging Ω² = g/l − A² ω²/(2 l²).
        2 (vertical drive only): the next order from the Mathieu equation,
        Ω² = (ω²/4) ν²(a, q) with ν² = a + q²/2 + a q²/2 + 25 q⁴/128
        (a = ±4 g/(l ω²), q = 2A/l), i.e. for the upright
        Ω² = A²ω²/(2l²) − g/l − 2 (g/l) A²/l² + 25 A⁴ω²/(32 l⁴), relative error
        O(ε⁴); stability also requires a′ < b₁(q), which gives the upper limit
        A/l → 0.4540 at high ω that first-order averaging cannot see.
    warn : bool
        Emit :class:`~kapitza.averaging.AveragingValidityWarning` for a scalar point
        outside the regime (see ``MIN_FREQUENCY_RATIO``, ``MAX_AMPLITUDE_RATIO`` of
        :mod:`kapitza.averaging` and :data:`MAX_CORRECTION`).
    progress : None, bool or callable
        Arrays of more than :data:`CHUNK_POINTS` points run in chunks of about 0.25 s
        (:func:`lagrange_core.progress.run_in_chunks`): a progress line on stderr for calls
        longer than 0.5 s when stderr is a terminal (None), always (True), never
        (False), or ``progress(done, total)`` after every chunk.

    Raises
    ------
    kapitza.results.ComputationInterrupted
        On Ctrl-C during a chunked call (within a chunk's time): a KeyboardInterrupt
        whose ``.result`` is the PendulumAveraging of the points finished, the first
        ones in flat (C) order of the broadcast (A, ω) (1-d fields, views into the
        arrays being filled: writing NaN into the rest would cost seconds for 10⁷
        points), and ``.computed`` marks them on the broadcast shape.

    Returns
    -------
    kapitza.results.PendulumAveraging
        ``.hanging``, ``.inverted``, ``.tilted`` (:class:`~kapitza.results.EquilibriumPrediction`).

    Notes
    -----
    Damping: the averaged equation is θ̈ + γ θ̇ + ∂U_eff/∂θ = 0: damping does not move the
    equilibria nor the first-order stability limit; small oscillations become
    e^{−γt/2} cos(√(Ω² − γ²/4) t), overdamped when γ > 2Ω.  For the linearised
    pendulum this is exact in form: the damped Mathieu equation equals the
    undamped one at a′ = a − γ²/ω² with multipliers scaled by e^{−γT/2}, so the
    decay rate of an underdamped slow oscillation is exactly γ/2 and order 2
    uses ν²(a′, q), whose a′q²/2 term is the damping's weakening of the fast
    response: Ω² gains −(γ/ω)² A²ω²/(2l²), so the minimum drive rises by a
    relative (γ/ω)²/2 (the exact damped limit, where a Floquet multiplier
    reaches 1, is matched to O(ε⁴)).  The upper (parametric-resonance) limit is evaluated at a′
    without the tongue's damping shift, i.e. it errs on the unstable side by
    O(γ/ω).

    Examples
    --------
    Kapitza's pendulum (l = 1 m) shaken at 60 Hz with A = 5 cm stands upright, with
    the slow frequency Ω² = A²ω²/(2l²) − g/l; the next order moves Ω by 0.2 %, onto
    the exact (Floquet) value 12.980 rad/s (:meth:`kapitza.KapitzaPendulum.floquet`):

    >>> import math
    >>> w = 2 * math.pi * 60
    >>> first = pendulum_averaged(0.05, w)
    >>> first.inverted.stable, abs(first.inverted.omega_squared - ((0.05 * w)**2 / 2 - 9.81)) < 1e-9
    (True, True)
    >>> second = pendulum_averaged(0.05, w, order=2)
    >>> print(f"Ω = {first.inverted.omega_slow:.3f} rad/s, "
    ...       f"next order {second.inverted.omega_slow:.3f} rad/s")
    Ω = 12.955 rad/s, next order 12.980 rad/s
    """
    drive = arguments.drive_direction(drive)
    order = arguments.averaging_order(order)
    if order == 2 and drive != "vertical":
        raise ValueError("the next-order (order=2) theory is implemented for the vertical drive "
                         "only; use order=1 for the horizontal drive.")
    l, g, gam = arguments.pendulum_constants(l, g, damping)
    A, omega = arguments.drive(A, omega)
    arguments.check_grid_memory("A × omega (broadcast)", A.shape, AVERAGING_BYTES_PER_POINT,
                                where="pendulum_averaged: ",
                                fix="use a coarser grid, or compute it in tiles written to "
                                "disk: a scene whose [sweep] runs averaging over these axes, "
                                "with `kapitza sweep`")
    _check_squares("pendulum_averaged", A, omega)
    if not (progress is None or isinstance(progress, bool) or callable(progress)):
        raise ValueError(f"progress must be None, True, False or a callable "
                         f"progress(done, total); got {progress!r}.")
    parts, computed = _in_chunks(functools.partial(_equilibria, l=l, g=g, gam=gam, drive=drive,
                                                   order=order), A, omega, progress)
    if computed is not None:                  # the finished points, flat
        done = int(computed.sum())
        A, omega = A.flat[:done], omega.flat[:done]
    eqs = tuple(EquilibriumPrediction(name=name, **{k: _s(v) for k, v in fields.items()})
                for name, fields in parts)
    out = PendulumAveraging(A=_s(A), omega=_s(omega), l=l, g=g, damping=gam, drive=drive,
                            order=order, equilibria=eqs)
    if computed is not None:
        raise ComputationInterrupted(out, computed)
    if warn and np.ndim(A) == 0:
        bad = [e.name for e in out.equilibria if e.exists and not e.valid]
        if bad:
            e = out[bad[0]]
            why = []
            if not e.small_amplitude:
                why.append(f"A/l = {A / l:.3g} > {MAX_AMPLITUDE_RATIO:g}")
            if not e.fast_drive:
                why.append(f"ω is only {e.frequency_ratio:.3g} × the slow frequencies "
                           f"(< {MIN_FREQUENCY_RATIO:g})")
            if not e.converged:
                why.append(f"the next-order correction is {e.error_estimate:.3g} of the slow "
                           f"frequency (> {MAX_CORRECTION:g}; near a stability limit?)")
            warnings.warn(f"averaging outside its regime for {', '.join(bad)}: "
                          + "; ".join(why), AveragingValidityWarning, stacklevel=2)
    return out


def _equilibria(A, omega, *, l, g, gam, drive, order):
    """The fields of every EquilibriumPrediction of :func:`pendulum_averaged` at the points
    (A, omega): [(name, {field: array})]."""
    w02 = g / l
    small = A / l <= MAX_AMPLITUDE_RATIO
    eqs = []

    def finish(name, theta, exists, w2, w2_damped, stable, err):
        # w2: undamped Ω²; w2_damped: Ω² − γ²/4 (or its order-2 form)
        exists = np.asarray(exists, bool)
        stable = np.asarray(stable, bool) & exists
        root = np.sqrt(np.abs(w2_damped))
        damped = np.where(stable, np.where(w2_damped > 0, root, 0.0), np.nan)
        decay = np.where(w2_damped >= 0, gam / 2, gam / 2 - root)
        ratio = omega / np.maximum.reduce([np.full_like(omega, math.sqrt(w02)),
                                           np.sqrt(np.abs(w2)), np.full_like(omega, gam)])
        fast = ratio >= MIN_FREQUENCY_RATIO
        converged = ~(err > MAX_CORRECTION)              # NaN (no estimate) counts as converged
        nan = np.where(exists, 0.0, np.nan)
        eqs.append((name, dict(
            theta=theta + nan, exists=exists, stable=stable, omega_squared=w2 + nan,
            omega_slow=np.where(w2 >= 0, np.sqrt(np.abs(w2)), np.nan) + nan,
            damped_frequency=damped + nan, decay_rate=decay + nan,
            overdamped=stable & (w2_damped < 0), error_estimate=err + nan,
            frequency_ratio=ratio, fast_drive=fast, small_amplitude=small,
            converged=converged, valid=fast & small & converged & exists)))

    vib = (A * omega) ** 2 / (2 * l * l)          # A²ω²/(2l²)
    if drive == "vertical":
        for name in ("hanging", "inverted"):
            theta = arguments.about_angle(name)
            a, q, c_damp = mathieu_parameters(A, omega, l, g, gam, name)
            shift = c_damp**2 / 4                 # a → a′ = a − c²/4 = a − γ²/ω²
            w2 = {o: omega**2 / 4 * exponent_squared(a, q, o) for o in (1, 2)}
            w2d = omega**2 / 4 * exponent_squared(a - shift, q, order)
            # exact damped criterion: growth of the a′-equation must beat e^{−γt/2}
            stable = w2d > -gam**2 / 4
            if order == 2:
                stable = stable & (a - shift < mathieu_b1(q))
            with np.errstate(invalid="ignore", divide="ignore"):
                r1, r2 = np.sqrt(np.abs(w2[1])), np.sqrt(np.abs(w2[2]))
                err = np.where(np.sign(w2[1]) == np.sign(w2[2]), np.abs(r2 - r1) / r1, np.inf)
            finish(name, np.full_like(A, theta), np.ones_like(A, bool), w2[order], w2d, stable, err)
        # the maxima of U_eff between them, cos θ = −2gl/(A²ω²), exist when the upright is
        # stable (first order at any ``order``): the separatrix of the slow motion
        with np.errstate(divide="ignore", invalid="ignore"):
            c = np.where(vib > 0, -w02 / np.where(vib > 0, vib, 1.0), -np.inf)
        exists = c > -1
        ts = np.arccos(np.clip(c, -1, 1))
        w2 = -vib * np.sin(ts) ** 2
        for name, sgn in (("tilted+", 1.0), ("tilted-", -1.0)):
            finish(name, sgn * ts, exists, w2, w2 - gam**2 / 4, np.zeros_like(exists),
                   np.full_like(A, np.nan))
    else:
        nan = np.full_like(A, np.nan)
        for name, theta, w2 in (("hanging", 0.0, w02 - vib), ("inverted", math.pi, -w02 - vib)):
            finish(name, np.full_like(A, theta), np.ones_like(A, bool), w2, w2 - gam**2 / 4,
                   w2 > 0, nan)
        with np.errstate(divide="ignore", invalid="ignore"):
            c = np.where(vib > 0, w02 / np.where(vib > 0, vib, 1.0), np.inf)   # cos θ* = 2gl/(A²ω²)
        exists = c < 1
        ts = np.arccos(np.clip(c, -1, 1))
        w2 = vib * np.sin(ts) ** 2
        for name, sgn in (("tilted+", 1.0), ("tilted-", -1.0)):
            finish(name, sgn * ts, exists, w2, w2 - gam**2 / 4, exists, nan)
    return eqs


#: Array calls of :func:`pendulum_averaged` run in chunks of this many points, so that
#: their temporaries stay at a few tens of MB whatever the size (the result itself is
#: ≈ 240 bytes per point).
CHUNK_POINTS = 1 << 16


def _in_chunks(fn, A, omega, progress=None):
    """``fn(A, omega)`` → [(name, {field: array})] over broadcast arrays of any size, in
    chunks (:func:`lagrange_core.progress.run_in_chunks`: about 0.25 s each, progress, Ctrl-C)
    of at most :data:`CHUNK_POINTS` flat points per numpy pass, assembled into arrays of
    A's shape.  Returns (fields, None), or after Ctrl-C (the finished flat prefix of
    every field, computed) with ``computed`` the mask of finished points on A's shape."""
    n = A.size
    if n <= CHUNK_POINTS and (progress is None or progress is False):
        return fn(A, omega), None
    out = [(name, {k: np.empty(n, np.asarray(v).dtype) for k, v in fields.items()})
           for name, fields in fn(A.flat[:1], omega.flat[:1])]

    def work(start, stop):
        for lo in range(start, stop, CHUNK_POINTS):
            hi = min(lo + CHUNK_POINTS, stop)
            part = fn(A.flat[lo:hi], omega.flat[lo:hi])
            for (_, into), (_, fields) in zip(out, part, strict=True):
                for k, v in fields.items():
                    into[k][lo:hi] = v

    done, interrupted = run_in_chunks(work, n, progress=progress, label="pendulum_averaged",
                                      first=min(n, CHUNK_POINTS))
    if interrupted:
        return ([(name, {k: v[:done] for k, v in fields.items()}) for name, fields in out],
                (np.arange(n) < done).reshape(A.shape))
    return [(name, {k: v.reshape(A.shape) for k, v in fields.items()})
            for name, fields in out], None


def averaged_window(omega, *, l=1.0, g=9.81, damping=0.0, order=2, warn=True,
                    stacklevel=2) -> StabilityWindow:
    """The averaging window of :func:`kapitza.closed_forms.pendulum_window`
    (``method="averaging"``): the amplitudes that keep the vertically driven pendulum
    upright, at each ω, by averaging of order ``order``.

    Order 1: A_min = √(2 g l)/ω, A_max = +inf (first order cannot see the upper
    limit).  Order 2: A_min from ν²(a′, q) = −γ²/ω²
    (``exponent_squared``), i.e. (undamped)
    A²ω²(1 − 7A²/(16 l²)) ≈ 2 g l, relative error O(ε⁴); A_max from the parametric
    resonance a′ = b₁(2A/l), → 0.4540 l as ω → ∞ (b₁ from its series,
    :func:`~kapitza.closed_forms._characteristic.mathieu_b1`, up to q = 1, A/l = 0.5,
    where it is good to 7e-7; beyond, at ω ≲ 6 ω0, from the exact characteristic
    value).  Where the order-2 edges cross (A_min ≥ A_max, at low ω) the prediction
    has no window: both edges are NaN and ``exists`` is False.

    Validity is reported as by :func:`pendulum_averaged`: ``fast_drive``
    (ω ≥ MIN_FREQUENCY_RATIO × max(ω0, γ)), ``small_amplitude`` (A_min/l ≤
    MAX_AMPLITUDE_RATIO), ``converged`` (the next order moves A_min by at most
    :data:`MAX_CORRECTION`) and ``valid`` (all three, and a window exists); with
    ``warn`` a scalar ω whose window is not valid emits an
    :class:`~kapitza.averaging.AveragingValidityWarning` at ``stacklevel``.

    Examples
    --------
    >>> print(f"order 1: {averaged_window(50.0, order=1).A_min:.5f} m = √(2 g l)/ω")
    order 1: 0.08859 m = √(2 g l)/ω
    """
    _, omega = arguments.drive(0.0, omega)
    order = arguments.averaging_order(order)
    l, g, damping = arguments.pendulum_constants(l, g, damping)
    a, _, c_damp = mathieu_parameters(0.0, omega, l, g, damping, "inverted")
    s = c_damp**2 / 4
    ap = a - s
    # ν²(a′, x = q²) = a′ + x/2 + a′x/2 + 25x²/128 = −s  →  quadratic in x
    c2, c1, c0 = 25 / 128, (1 + ap) / 2, a
    x = (-c1 + np.sqrt(c1 * c1 - 4 * c2 * c0)) / (2 * c2)
    lower = {1: np.sqrt(2 * g * l) / omega, 2: amplitude_from_q(np.sqrt(x), l)}
    if order == 1:
        A_min, A_max = lower[1], np.full_like(omega, np.inf)
    else:
        A_min, A_max = lower[2], amplitude_from_q(_b1_root(ap), l)
    exists = A_min < A_max
    A_min, A_max = np.where(exists, A_min, np.nan), np.where(exists, A_max, np.nan)
    with np.errstate(divide="ignore", invalid="ignore"):     # g = 0: both edges are 0
        ratio = omega / max(math.sqrt(g / l), damping)
        err = np.where(lower[2] > 0, np.abs(lower[1] - lower[2]) / lower[2], 0.0)
    fast = ratio >= MIN_FREQUENCY_RATIO
    small = lower[order] / l <= MAX_AMPLITUDE_RATIO
    converged = err <= MAX_CORRECTION
    valid = exists & fast & small & converged
    if warn and np.ndim(omega) == 0 and not valid:
        why = [] if exists else ["the order-2 edges cross (A_min ≥ A_max): no window"]
        if not fast:
            why.append(f"ω is only {ratio:.3g} × max(ω0, γ) (< {MIN_FREQUENCY_RATIO:g})")
        if not small:
            why.append(f"A_min/l = {lower[order] / l:.3g} > {MAX_AMPLITUDE_RATIO:g}")
        if not converged:
            why.append(f"the next order moves A_min by {err:.3g} (> {MAX_CORRECTION:g})")
        warnings.warn(f"averaging window at ω = {float(omega):.4g} rad/s outside its regime: "
                      + "; ".join(why), AveragingValidityWarning, stacklevel=stacklevel)
    return StabilityWindow(method="averaging", about="inverted", order=order, l=l, g=g,
                           damping=damping, omega=_s(omega), A_min=_s(A_min), A_max=_s(A_max),
                           exists=_s(exists), frequency_ratio=_s(ratio), error_estimate=_s(err),
                           fast_drive=_s(fast), small_amplitude=_s(small),
                           converged=_s(converged), valid=_s(valid))


#: b₁'s series (:func:`~kapitza.closed_forms._characteristic.mathieu_b1`) is used for q ≤
#: this (absolute error 7e-7 here, 3e-5 at q = 1.5, 2e-3 at q = 2.5); beyond, the exact
#: characteristic value.
_B1_SERIES_LIMIT = 1.0


def _b1_root(a):
    """q > 0 with b₁(q) = a (b₁ decreases from 1 at q = 0; a ≤ 1)."""
    a = np.asarray(a, float)
    q = mathieu_b1_root(a)              # the series (on [0, 2.5]; kept where q ≤ the limit)
    beyond = a < mathieu_b1(_B1_SERIES_LIMIT)
    if np.any(beyond):
        # exact b₁ is decreasing and below 1 − q: the root lies in [limit, 1 − a]
        target = a[beyond]
        lo = np.full_like(target, _B1_SERIES_LIMIT)
        hi = np.maximum(1 - target, _B1_SERIES_LIMIT)
        for _ in range(60):
            mid = (lo + hi) / 2
            above = np.asarray(characteristic_value("b", 1, mid)) > target
            lo, hi = np.where(above, mid, lo), np.where(above, hi, mid)
        q = np.array(q, float)
        q[beyond] = (lo + hi) / 2
    return q


def multiple_pendulum_upright(masses, lengths, *, g=9.81, A=None, omega=None, order=1,
                              warn=True) -> MultiplePendulumPrediction:
    """Acheson's multiple inverted pendulum: minimum drive and slow modes of the upright chain.

    About the upright state the linearised equations M θ̈ = (g − A ω² cos ωt) L θ
    (M_ij = l_i l_j μ_max(i,j), L = diag(l_i μ_i), μ_i = Σ_{j≥i} m_j) decouple in
    the eigenvectors of M⁻¹L into N Mathieu equations, each a single pendulum of
    effective length λ_k = g / ω_k², ω_k the normal-mode frequencies of the
    *hanging* chain (Acheson 1993, "A pendulum theorem").  First-order
    averaging (the Hessian of U_eff) gives

        Ω_k² = A² ω² ω_k⁴ / (2 g²) − ω_k²,

    so all links stay upright iff A ω > √2 g / ω_min (the slowest hanging mode;
    (2 + √2) g l for the equal double pendulum), and at order 2 each mode obeys
    the single-pendulum limits with l → λ_k, the upper one
    A < 0.4540 g / ω_max² at high ω (the fastest hanging mode).

    Parameters
    ----------
    masses, lengths : sequence of float (N,)
        Bob masses (kg) and rod lengths (m), from the pivot outwards.
    g : float
        Gravity (m/s²).
    A, omega : float or array, optional
        Vertical drive amplitude (m) and frequency (rad/s); with them, the slow
        frequencies and stability are computed (broadcast, no re-derivation).
    order : {1, 2}
        Per-mode accuracy as in :func:`pendulum_averaged`.

    Returns
    -------
    kapitza.results.MultiplePendulumPrediction

    Examples
    --------
    The equal double pendulum needs A ω > √((2 + √2) g l):

    >>> import math
    >>> mp = multiple_pendulum_upright([1.0, 1.0], [1.0, 1.0])
    >>> print(f"{mp.minimum_drive:.4f} m/s = {math.sqrt((2 + math.sqrt(2)) * 9.81):.4f} m/s")
    5.7874 m/s = 5.7874 m/s
    >>> bool(multiple_pendulum_upright([1, 1], [1, 1], A=0.02, omega=400.0).stable)
    True
    """
    m = np.asarray(masses, float).ravel()
    ls = np.asarray(lengths, float).ravel()
    if m.shape != ls.shape or m.size == 0:
        raise ValueError(f"masses and lengths need the same length N ≥ 1, got {m.size} and "
                         f"{ls.size}.")
    if not (np.all(m > 0) and np.all(ls > 0) and np.all(np.isfinite(m))
            and np.all(np.isfinite(ls))):
        raise ValueError("masses and lengths must be finite and > 0.")
    if not g > 0:
        raise ValueError(f"g must be > 0 (m/s²), got {g}.")
    n = m.size
    mu = np.cumsum(m[::-1])[::-1]                        # μ_i = Σ_{j≥i} m_j
    idx = np.maximum.outer(np.arange(n), np.arange(n))
    M = np.outer(ls, ls) * mu[idx]
    L = np.diag(ls * mu)
    import scipy.linalg  # not at import: scipy costs ~0.4 s

    w2 = np.sort(scipy.linalg.eigh(g * L, M, eigvals_only=True))
    wk = np.sqrt(w2)
    lam = g / w2
    out = dict(masses=m, lengths=ls, g=float(g), hanging_frequencies=wk, effective_lengths=lam,
               minimum_drive=float(math.sqrt(2) * g / wk[0]), order=order)
    if A is None and omega is None:
        return MultiplePendulumPrediction(**out)
    if A is None or omega is None:
        raise ValueError("give both A and omega (or neither).")
    A, omega = arguments.drive(A, omega)
    preds = tuple(pendulum_averaged(A, omega, l=float(lk), g=float(g), order=order, warn=False)
                  for lk in lam)
    W2 = np.stack([np.asarray(p.inverted.omega_squared, float) for p in preds], axis=-1)
    stable = np.logical_and.reduce([np.asarray(p.inverted.stable) for p in preds])
    valid = np.logical_and.reduce([np.asarray(p.inverted.valid) for p in preds])
    if warn and np.ndim(A) == 0 and not valid:
        warnings.warn(f"averaging outside its regime for the {n}-link pendulum (a mode has "
                      f"A/λ_k > {MAX_AMPLITUDE_RATIO:g} or ω < {MIN_FREQUENCY_RATIO:g} × its slow "
                      "frequency)", AveragingValidityWarning, stacklevel=2)
    return MultiplePendulumPrediction(**out, A=_s(A), omega=_s(omega), omega_squared=W2,
                                      stable=_s(stable), valid=_s(valid), mode_predictions=preds)
