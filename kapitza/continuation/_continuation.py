"""``kapitza.continuation``: a branch of periodic orbits of a driven system followed in one
parameter, through folds, with its Floquet multipliers and its bifurcations.

Method
------
*Shooting.*  A T-periodic orbit (nT with ``periods=n``) is a root x of
F(x, p) = φ_nT(x; p) − x, x the state [q, q̇] at the drive's phase zero; an equilibrium
that persists under the drive is one too (F ≡ 0 there).  A rotating orbit, q(t + nT) =
q(t) + 2π k (``winding=k``: a pendulum whirling in step with the drive), is a root of
F − (2π k, 0); its branch's doubled orbits turn 2k times over 2n periods.  φ and its
Jacobian M (the monodromy, whose eigenvalues are the Floquet multipliers) come from the
variational equations on the system's exact compiled Jacobian
(:func:`lagrange_core.variational.flow`); ∂F/∂p is a forward difference at the same step
count (:mod:`._shooting`).

*Pseudo-arclength continuation.*  From a point u_k = (x_k, p_k) with unit tangent t_k
the predictor is u_k + h t_k; the corrector is Newton's method on
[F(u); ⟨t_k, u − u_k⟩ − h] = 0, the bordered system [[M − I, F_p], [t_kᵀ]], which is
regular at a fold (where M − I alone is singular), so the branch is followed round
folds.  The tangent at the new point solves the same bordered system with right side
e_last.  Lengths are measured in scaled variables: q and q̇/ω as angles, the parameter
as a fraction of the interval |stop − start| (one radian of state counts as much as the
whole interval).  The step grows ×1.5 after a correction of ≤ 3 Newton iterations,
shrinks ×0.6 after ≥ 6, and is halved and retried where the corrector fails, moves the
point more than half a step, or the tangent turns by more than ~25°.

*Bifurcations* (:mod:`._bifurcations`).  Sign changes between consecutive points of
det(M − I) (fold if the parameter turns, else a branch point: pitchfork or transcritical
by probing the emanating branch), det(M + I) (period doubling) and the bialternate
product det(M ⊙ M − I) (Neimark–Sacker; not on conservative systems, where it vanishes
identically); each is located by the Anderson–Björck method along the arclength to
about 1e-3 ``tol`` of the interval, with a certified accuracy.  Two crossings of the
same test function within one step cancel and are missed: ``max_step`` bounds the step.

Accuracy
--------
Each point: |φ(x) − x|∞ ≤ ``tol`` · max(1, |x|∞), the flow integrated to ``tol``/100
(as :func:`kapitza.periodic_orbit`); multipliers to about the flow's error estimate
times their condition.  Stability: every |λ| ≤ 1 + δ, δ = max(100 × that error, 1e-9).
Bifurcations: ``Bifurcation.accuracy`` (see :class:`kapitza.results.Bifurcation`).

Never silent: a corrector that keeps failing, a step shrinking below 1e-5 of ``step``,
a singular bordered system, or ``max_points`` reached before ``stop`` end the branch
with the points so far, a ``status``/``message`` and a RuntimeWarning; Ctrl-C raises
:class:`kapitza.ComputationInterrupted` whose ``.result`` is the branch so far.
"""
from __future__ import annotations

import math
from collections.abc import Mapping

import numpy as np

from lagrange_core._compile_notice import declared

from .._arguments import whole_number
from ..results import Branch
from ._branch import Engine

__all__ = ["continuation"]


def _number(name, value, *, positive=False):
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)) \
            or not math.isfinite(float(value)) or (positive and not value > 0):
        raise ValueError(f"continuation: {name} must be a finite{' positive' if positive else ''}"
                         f" number, got {value!r}.")
    return float(value)


def _winding(n, winding):
    """The turns per coordinate over the orbit (floats holding whole numbers), or None."""
    try:
        k = np.asarray(winding, dtype=float).reshape(-1)
    except (TypeError, ValueError):
        k = np.array([math.nan])
    if isinstance(winding, bool) or k.size not in (1, n) or not np.all(np.isfinite(k)) \
            or np.any(k != np.round(k)):
        raise ValueError(f"continuation: winding must be a whole number of turns (or one per "
                         f"coordinate, {n} numbers): q(t + periods·T) = q(t) + 2π·winding; "
                         f"got {winding!r}.")
    k = np.broadcast_to(k, (n,)).copy()
    return k if k.any() else None


def _about(system, about):
    n = system.n_dof
    if isinstance(about, Mapping):
        missing = [c for c in system.coordinates if c not in about]
        if missing:
            raise ValueError(f"continuation: about is missing the coordinates {missing} "
                             f"(it needs all of {list(system.coordinates)}).")
        about = [about[c] for c in system.coordinates]
    try:
        x = np.asarray(about, dtype=float).reshape(-1)
    except (TypeError, ValueError):
        raise ValueError(f"continuation: about must be {n} coordinates or the state [q, q̇] "
                         f"({2 * n} numbers), got {about!r}.") from None
    if x.size == n:
        x = np.r_[x, np.zeros(n)]
    if x.size != 2 * n or not np.all(np.isfinite(x)):
        raise ValueError(f"continuation: about must be {n} finite coordinates or the state "
                         f"[q, q̇] ({2 * n} numbers), got {about!r}.")
    return x


def continuation(system, params, about, *, parameter="A", stop, periods=1, winding=0,
                 frequency="omega", step=None, max_step=None, max_points=500, tol=1e-10,
                 progress=None) -> Branch:
    """Follow a branch of T- (or nT-) periodic orbits of a driven system in one parameter.

    Equilibria that persist under the drive (the vertically driven pendulum's θ = 0, π)
    are T-periodic orbits too.  The branch is followed by pseudo-arclength continuation
    through folds, with the Floquet multipliers at every point, and its bifurcations are
    located: see the module docstring for the method and the accuracy.

    Parameters
    ----------
    system : lagrange_core.System
        Unconstrained, driven with the period 2π/ω of ``params[frequency]``.
    params : dict
        Parameter values (scalars) by name; ``params[parameter]`` is where the branch
        starts.
    about : sequence or dict
        The starting orbit: an equilibrium's coordinates (at rest), or the state
        [q, q̇] at t = 0 on (or near) the orbit (e.g. ``kapitza.periodic_orbit(...).state``).
    parameter : str
        The continued parameter (default the drive amplitude "A"; the drive frequency
        works too).
    stop : float
        Follow the branch while the parameter stays between its start and ``stop``.
    periods : int
        Orbits of ``periods`` drive periods.
    winding : int or sequence of int
        Rotating orbits: q(t + periods·T) = q(t) + 2π·winding (one whole number per
        coordinate, or one for all; 0, the default: orbits that return to themselves).
        Their ``mean`` and ``amplitude`` in ``points`` are those of q(t) − 2π·winding·t /
        (periods·T), the uniform rotation removed (as :func:`kapitza.periodic_orbit`'s).
    frequency : str
        The drive's angular-frequency parameter (rad/s).
    step : float, optional
        The first step, in the parameter's unit (arclength in the scaled variables);
        default |stop − start|/100.
    max_step : float, optional
        The largest step; default |stop − start|/20 and at least ``step``.
    max_points : int
        Stop (with a warning) after this many points.
    tol : float
        The corrector's tolerance: |φ(x) − x|∞ ≤ tol · max(1, |x|∞); in [1e-13, 1e-6].
    progress : None, bool or callable
        A progress line (None: when stderr is a terminal), or ``progress(done, total)``.

    Returns
    -------
    kapitza.results.Branch
        ``.points`` (parameter, state, period mean, amplitude, multipliers, stability),
        ``.bifurcations``, ``.status``/``.message``; ``.switch(bifurcation)`` starts the
        emanating branch; ``to_dataframe()``, ``figure()``.

    Raises
    ------
    ValueError
        Bad input (the message names the argument), or no periodic orbit near ``about``.

    Warns
    -----
    RuntimeWarning
        The branch ended before ``stop`` (``status`` says why).

    Examples
    --------
    The upright pendulum at ω = 20 ω0, continued in the drive amplitude: stable between
    the Kapitza limit (a pitchfork: multiplier +1) and the period doubling at the window's
    upper edge:

    >>> import math
    >>> from lagrange_core import problems
    >>> w = 20 * math.sqrt(9.81)
    >>> branch = continuation(problems.driven_pendulum("vertical"),
    ...                       dict(m=1.0, l=1.0, g=9.81, A=0.02, omega=w), [math.pi],
    ...                       parameter="A", stop=0.6, progress=False)
    >>> [(b.kind, round(b.parameter, 6)) for b in branch.bifurcations]
    [('pitchfork', 0.070788), ('period_doubling', 0.458219)]
    """
    from lagrange_core import System
    if not isinstance(system, System):
        raise TypeError(f"continuation: system must be a lagrange_core.System, got "
                        f"{type(system).__name__}.")
    if system.n_constraints:
        raise ValueError("continuation: constrained systems are not supported; state the "
                         "system in independent coordinates.")
    if not isinstance(params, Mapping):
        raise TypeError(f"continuation: params must be a dict of parameter values, got "
                        f"{type(params).__name__}.")
    params = dict(params)
    for name, what in ((parameter, "parameter"), (frequency, "frequency")):
        if name not in system.parameters:
            raise ValueError(f"continuation: {what} = {name!r} is not a parameter of the "
                             f"system; its parameters are {list(system.parameters)}.")
        if name not in params:
            raise ValueError(f"continuation: params has no value for {name!r} ({what}); "
                             f"it is where the branch starts.")
    for k, v in params.items():
        if np.ndim(v) != 0:
            raise ValueError(f"continuation takes scalar parameters; {k!r} is an array.")
    p0 = _number(f"params[{parameter!r}]", params[parameter])
    stop = _number("stop", stop)
    if stop == p0:
        raise ValueError(f"continuation: stop = {stop!r} equals the start value "
                         f"params[{parameter!r}]; give the other end of the interval.")
    _number(f"params[{frequency!r}]", params[frequency], positive=True)
    whole_number(periods, "continuation: periods", 1, integral_floats=True)
    if isinstance(tol, bool) or not isinstance(tol, (int, float)) or not 1e-13 <= tol <= 1e-6:
        raise ValueError(f"continuation: tol must be a number in [1e-13, 1e-6], got {tol!r}.")
    whole_number(max_points, "continuation: max_points", 2, integral_floats=True)
    span = abs(stop - p0)
    step = span / 100 if step is None else _number("step", step, positive=True)
    max_step = max(span / 20, step) if max_step is None else _number("max_step", max_step,
                                                                     positive=True)
    if max_step < step:
        raise ValueError(f"continuation: max_step = {max_step!r} is smaller than step = "
                         f"{step!r}.")
    x0 = _about(system, about)
    turns = _winding(system.n_dof, winding)
    engine = Engine(system, params, parameter, frequency, float(tol), progress)
    # a first compile says how long a branch's kernels compile (declared here, not by a
    # wrapper: the warnings' stacklevels count frames)
    with declared("continuation"):
        return engine.start(x0, p0, stop, periods=int(periods), step=step, max_step=max_step,
                            max_points=int(max_points), winding=turns)
