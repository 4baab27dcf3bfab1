"""Floquet analysis per parameter set: :func:`floquet_point` (one set →
:class:`~kapitza.results.FloquetResult`), :func:`floquet_grid` (a broadcast grid →
:class:`~kapitza.results.FloquetGrid`) and :func:`monodromy_data` (the matrices only →
:class:`~kapitza.results.MonodromyData`).

A grid runs in three chunked stages — sampling J(t) and integrating the monodromies
(:mod:`kapitza.floquet._monodromy`), then the analysis of the multipliers
(:mod:`kapitza.floquet._multipliers`) — so that a progress line follows it and Ctrl-C
stops it with the finished points kept (:class:`~kapitza.results.ComputationInterrupted`).
A point that would need more than ``MAX_STEPS_PER_PERIOD`` Taylor steps (ω → 0, a huge
amplitude against a slow drive) is not integrated: it is reported unstable with the
frozen-time estimate log|λ| ≈ ∮ max(0, max Re eig J(t)) dt and a flag (stability
"undecided" when that estimate is small), so one such point never aborts a grid.
"""
from __future__ import annotations

import time

import numpy as np

from lagrange_core._compile_notice import declared
from lagrange_core.progress import _SIGINT, run_in_chunks
from lagrange_core.progress import defer_ctrl_c as _defer_ctrl_c

from ..results import ComputationInterrupted, FloquetGrid, FloquetResult, MonodromyData
from ._monodromy import _integrate, _monodromy_fields, _prepare
from ._multipliers import _analyse_points, _blank

__all__ = ["floquet_point", "floquet_grid", "monodromy_data"]

def monodromy_data(system, params, about, *, frequency="omega", tol=1e-10,
                   order=16, progress=None) -> MonodromyData:
    """Monodromy matrices for a broadcast grid of parameter sets.

    Parameters
    ----------
    system : lagrange_core.System
        Unconstrained; its drive has angular frequency ``params[frequency]``.
    params : dict
        Parameter values by name; scalars or arrays (broadcast together).
    about : sequence or dict
        The equilibrium's coordinates q* (velocities zero).
    tol : float
        Target error of M relative to max(1, ‖M‖).
    progress : None, bool or callable
        As for :func:`floquet_grid` (points not reached before Ctrl-C, and points
        that would need more than ``MAX_STEPS_PER_PERIOD`` Taylor steps, have M = NaN
        and error_estimate = inf).

    Returns
    -------
    kapitza.results.MonodromyData
        ``monodromy_scaled`` (M = e^log_scale · this, grid shape + (2n, 2n)),
        ``log_scale``, ``error_estimate``, ``steps``, ``samples``, ``period``,
        ``liouville_exponent`` (∮ tr J dt); ``.monodromy``, ``.shape``.

    Examples
    --------
    Liouville's formula for the damped pendulum: det M = e^(−γT).

    >>> import math
    >>> import numpy as np
    >>> from lagrange_core import problems
    >>> data = monodromy_data(problems.driven_pendulum("vertical", damping=True),
    ...                       dict(m=1.0, l=1.0, g=9.81, A=0.1, omega=[40.0, 60.0], gamma=0.5),
    ...                       [math.pi])
    >>> data.shape
    (2,)
    >>> bool(np.allclose(np.linalg.det(data.monodromy), np.exp(-0.5 * data.period), rtol=1e-9))
    True
    """
    # (a first compile says how long the Floquet kernels compile)
    with _defer_ctrl_c(), declared("Floquet"):
        prep = _prepare(system, params, about, frequency, tol, progress)
        if prep["stopped"]:
            data = MonodromyData(**_monodromy_fields(prep, *_nothing(prep)))
            raise ComputationInterrupted(data, np.zeros(prep["shape"], dtype=bool))
        Mout, ls, err, steps, _, fin, stopped = _integrate(prep, np.arange(prep["T"].size), tol,
                                                           order, progress)
        data = MonodromyData(**_monodromy_fields(prep, Mout, ls, err, steps))
        if stopped or _SIGINT["hit"] or not fin.all():
            raise ComputationInterrupted(data, fin.reshape(prep["shape"]))
        return data


#: seconds spent analysing the integrated points after Ctrl-C stopped the integration (the
#: others keep their monodromy in the result but count as not computed)
_AFTER_CTRL_C = 0.5


def _nothing(prep):
    """Monodromy fields (M, log scale, error, steps) of a grid of which nothing was
    computed (Ctrl-C while J was sampled): NaN, 0, inf, 0."""
    m, d = prep["T"].size, 2 * prep["n"]
    return (np.full((m, d, d), np.nan), np.zeros(m), np.full(m, np.inf),
            np.zeros(m, dtype=np.int64))


def _analyse_chunked(prep, idx, Ms, ls, err, skip, finished, guard_tol, progress,
                     budget=None):
    """:func:`_analyse_points` in chunks (:func:`run_in_chunks`) up to the last finished
    point.  Returns (result, analysed, stopped): after Ctrl-C, or when ``budget`` seconds
    have passed (after an interrupted integration), the points not analysed are marked not
    computed."""
    m = idx.size
    last = np.flatnonzero(finished)
    limit = int(last[-1]) + 1 if last.size else 0
    parts = []
    t0 = time.perf_counter()

    def work(a, b):
        if budget is not None and time.perf_counter() - t0 > budget:
            raise KeyboardInterrupt
        parts.append(_analyse_points(prep, idx[a:b], Ms[a:b], ls[a:b], err[a:b], skip[a:b],
                                     finished[a:b], guard_tol))

    _, stopped = run_in_chunks(work, limit, progress=progress, label="Floquet grid: analysis",
                               first=4096, target=0.25 if budget is None else 0.1)
    stopped = stopped or limit < m
    done = sum(p["trace"].size for p in parts)
    parts.append(_blank(m - done, prep["n"]))
    if len(parts) == 2 and done == m:
        res = parts[0]
    else:
        res = {k: np.concatenate([p[k] for p in parts]) for k in parts[0] if k != "flags"}
        res["flags"] = [f for p in parts for f in p["flags"]]
    analysed = np.zeros(m, dtype=bool)
    analysed[:done] = True
    return res, analysed, stopped


def floquet_grid(system, params, about, *, frequency="omega", tol=1e-10, guard_tol=1e-8,
                 order=16, certify=False, coarse_tol=1e-4, progress=None) -> FloquetGrid:
    """Floquet analysis for every parameter set of a broadcast grid.

    Parameters
    ----------
    system, about, frequency, tol, guard_tol, order
        As for :func:`floquet_point`.
    params : dict
        Parameter values by name; scalars or arrays, broadcast together.
    certify : bool
        Classification mode for maps: integrate every point to ``coarse_tol``
        first, then again to ``tol`` only where the stability test is within 10×
        the error estimate of its threshold.  Far from boundaries the reported
        trace is then accurate to ``coarse_tol`` (see the "error" array), and
        every classification is certified by its margin.
    progress : None, bool or callable
        The grid runs in three stages — sampling J(t), integration, analysis — each in
        chunks of about 0.25 s; a progress line on stderr when it is a terminal (None),
        always (True), never (False), or ``progress(done, total)`` called after each
        chunk (each stage counts its own points from 0 to ``total``).  Ctrl-C stops
        any stage within a chunk (it is held back during the NumPy code between the
        chunks) and raises :class:`~kapitza.results.ComputationInterrupted` (a
        KeyboardInterrupt) whose ``.result`` is this grid with the finished points
        filled (the others NaN, unstable, label 3, flagged "not computed") and
        ``.computed`` marks them: none during the sampling; after the integration,
        the integrated points analysed within 0.5 s (the rest keep their monodromy).

    Returns
    -------
    kapitza.results.FloquetGrid
        Arrays over the grid's shape: ``stable``, ``label`` / ``boundary``, ``trace``,
        ``log_growth``, ``multipliers``, ``omega_slow``, ``error_estimate``,
        ``steps``, ``margin``, ``flags`` (flat order), ...; ``point(index)`` gives
        one point's :class:`~kapitza.results.FloquetResult`.

    Examples
    --------
    The upright pendulum over three amplitudes at ω = 60 rad/s (the exact window is
    7.4 cm < A < 43 cm, :func:`kapitza.closed_forms.pendulum_window`):

    >>> import math
    >>> from lagrange_core import problems
    >>> grid = floquet_grid(problems.driven_pendulum("vertical"),
    ...                     dict(m=1.0, l=1.0, g=9.81, A=[0.05, 0.2, 0.5], omega=60.0), [math.pi])
    >>> grid.boundary.tolist()
    ['T', 'stable', '2T']
    >>> grid.point(1).stable
    True
    """
    # (a first compile says how long the Floquet kernels compile)
    with _defer_ctrl_c(), declared("Floquet"):
        return _floquet_grid(system, params, about, frequency, tol, guard_tol, order, certify,
                             coarse_tol, progress)


def _floquet_grid(system, params, about, frequency, tol, guard_tol, order, certify,
                  coarse_tol, progress) -> FloquetGrid:
    # three chunked stages (sampling J, integration, analysis): Ctrl-C stops any of them at
    # a chunk's end; the integrated points are still analysed (a second Ctrl-C stops that)
    prep = _prepare(system, params, about, frequency, tol, progress)
    shape = prep["shape"]
    npts = prep["T"].size
    if prep["stopped"]:
        grid = _grid(prep, *_nothing(prep), _blank(npts, prep["n"]), 0)
        raise ComputationInterrupted(grid, np.zeros(shape, dtype=bool))
    idx = np.arange(npts)
    first = max(tol, coarse_tol) if certify else tol
    Ms, ls, err, steps, skip, fin, res, interrupted = _pass(prep, idx, first, order, guard_tol,
                                                           progress)
    refined = 0
    if certify and first > tol and not interrupted:
        redo = np.nonzero(~(res["margin"] > 1.0) & ~skip)[0]
        if redo.size:
            M2, l2, e2, s2, _, f2, r2, interrupted = _pass(prep, redo, tol, order, guard_tol,
                                                           progress)
            # after Ctrl-C the points not refined keep their coarse result
            keep = np.nonzero(f2)[0]
            redo = redo[keep]
            refined = redo.size
            Ms[redo], ls[redo], err[redo], steps[redo] = M2[keep], l2[keep], e2[keep], s2[keep]
            for k, v in r2.items():
                if k == "flags":
                    for j, i in zip(keep, redo, strict=True):
                        res["flags"][i] = v[j]
                else:
                    res[k][redo] = v[keep]
    grid = _grid(prep, Ms, ls, err, steps, res, refined)
    if interrupted or _SIGINT["hit"]:
        raise ComputationInterrupted(grid, fin.reshape(shape))
    return grid


def _pass(prep, idx, tol, order, guard_tol, progress):
    """Integrate and analyse the grid points ``idx`` at ``tol``: (monodromies, log scales,
    error estimates, steps, skipped, finished, analysis, interrupted).  After a Ctrl-C in
    the integration the points integrated are still analysed, for at most _AFTER_CTRL_C."""
    Ms, ls, err, steps, skip, fin, stopped = _integrate(prep, idx, tol, order, progress)
    stopped = stopped or _SIGINT["hit"]
    _SIGINT["hit"] = False
    res, analysed, analysis_stopped = _analyse_chunked(prep, idx, Ms, ls, err, skip, fin,
                                                       guard_tol, progress,
                                                       _AFTER_CTRL_C if stopped else None)
    fin &= analysed
    return Ms, ls, err, steps, skip, fin, res, stopped or analysis_stopped or not fin.all()


def _grid(prep, Ms, ls, err, steps, res, refined) -> FloquetGrid:
    shape = prep["shape"]
    out = {k: v.reshape(shape + v.shape[1:]) for k, v in res.items() if k != "flags"}
    return FloquetGrid(**_monodromy_fields(prep, Ms, ls, err, steps),
                       multipliers=out["multipliers"], log_abs_multipliers=out["logabs"],
                       exponents=out["exponents"], trace=out["trace"], stable=out["stable"],
                       label=out["label"], omega_slow=out["slow"],
                       liouville_residual=out["liouville"], pairing_residual=out["pairing"],
                       margin=out["margin"], flags=tuple(res["flags"]), refined_points=refined)


def floquet_point(system, params, about, *, frequency="omega", tol=1e-10, guard_tol=1e-8,
                  order=16) -> FloquetResult:
    """Floquet analysis of ``system`` linearised about the driven equilibrium ``about``.

    Parameters
    ----------
    system : lagrange_core.System
        Unconstrained, driven with angular frequency ``params[frequency]``
        (period T = 2π/ω).
    params : dict
        Parameter values (scalars).
    about : sequence or dict
        Coordinates of a state that persists under the drive (velocities zero).
    tol : float
        Target error of the monodromy relative to max(1, ‖M‖); the Taylor
        steps are chosen to meet it and the estimate is reported.
    order : int
        Taylor order (steps get longer with the order; 12–24 are sensible).
    guard_tol : float
        Liouville / pairing residual above which the result is flagged.

    Returns
    -------
    kapitza.results.FloquetResult

    Examples
    --------
    The inverted pendulum (l = 1 m) shaken vertically with A = 5 cm at 60 Hz is stable;
    its exact slow frequency is within 0.2 % of the averaging value √(A²ω²/2 − g/l):

    >>> import math
    >>> from lagrange_core import problems
    >>> w = 2 * math.pi * 60
    >>> r = floquet_point(problems.driven_pendulum("vertical"),
    ...                   dict(m=1.0, l=1.0, g=9.81, A=0.05, omega=w), [math.pi])
    >>> r.stable, r.boundary, r.flags
    (True, 'stable', ())
    >>> averaging = math.sqrt((0.05 * w)**2 / 2 - 9.81)
    >>> print(f"Ω = {r.omega_slow:.2f} rad/s, averaging {averaging:.2f} rad/s")
    Ω = 12.98 rad/s, averaging 12.96 rad/s
    """
    for k, v in params.items():
        if np.ndim(v) != 0:
            raise ValueError(f"floquet_point takes scalar parameters; {k!r} is an array. Use "
                             "floquet_grid or stability_map for grids.")
    return floquet_grid(system, params, about, frequency=frequency, tol=tol, guard_tol=guard_tol,
                        order=order, progress=False).point()

