"""Brute force over many trajectories: bifurcation diagrams, Poincaré sections and basins.

All three run :meth:`lagrange_core.System.simulate_grid` (compiled, parallel, in chunks
with progress and Ctrl-C) and keep only what they need — the strobe runs of the first
two go to DOP853 on lanes instead where it applies (:mod:`kapitza.chaos._strobe_lanes`:
a damped or otherwise velocity-dependent system; the same method and steps as
``simulate_grid``'s "dop853", 64 trajectories per thread vectorised, ~6× faster):

* :func:`bifurcation_diagram` — a parameter's values × initial states; ``transient``
  drive periods are run first with nothing observed, then ``periods`` strobe samples
  [q, q̇](t0 + (transient + k) T) are kept (the integrator's own solution at those
  times: its steps land on them).  After the transient a period-p attractor shows p
  dots per start, a chaotic one a cloud.  :meth:`~kapitza.results.BifurcationDiagram.orbit_period`
  counts them.
* :func:`poincare_section` — the same samples for one parameter set and one or more
  starts: the stroboscopic (Poincaré) section of the flow in the extended phase space.
* :func:`basin` — which initial states stay within a band about a state for the whole
  run: the basin of that state as far as the run shows (a start that leaves after the
  run's end is counted in).  What ``studies/inverted_basin.py`` did by hand with
  ``KapitzaPendulum.measure_grid``, for any system; it gives the same cells.
"""
from __future__ import annotations

import math
import time
import warnings

import numpy as np

from lagrange_core.batch import GridInterrupted
from lagrange_core.checks import real_number

from .._arguments import whole_number
from ..results import Basin, BifurcationDiagram, ComputationInterrupted, PoincareSection
from ._common import angle_names, drive_frequency, parameters, state, tolerances
from ._strobe_lanes import lanes_apply, strobe_runs_lanes

__all__ = ["bifurcation_diagram", "poincare_section", "basin"]


def _strobe_runs(system, params, Q0, V0, T, t0, transient, periods, method, rtol, atol,
                 max_steps, progress):
    """Run ``transient`` periods unobserved, then keep ``periods`` strobe samples.

    Returns (q, qdot, status, method, interrupted): q, qdot (S + (K, n)), status (S) as
    names.  On Ctrl-C the finished points' samples are kept (the others NaN).  DOP853 runs
    on lanes (:mod:`kapitza.chaos._strobe_lanes`) where it applies."""
    if lanes_apply(system, method):
        return strobe_runs_lanes(system, params, Q0, V0, T, t0, transient, periods, rtol, atol,
                                 max_steps, progress)
    kw = dict(method=method, rtol=rtol, atol=atol, max_steps=max_steps, progress=progress)
    interrupted = False
    start = t0
    if transient:
        try:
            pre = system.simulate_grid(Q0, V0, (t0, t0 + transient * T), params, **kw)
        except GridInterrupted as stop:
            pre, interrupted = stop.result, True
        Q0, V0 = pre.q, pre.qdot
        start = t0 + transient * T
        pre_status = pre.status_name
    if not interrupted:
        # a span of (periods − 1) T gives samples k = 0 … periods − 1; a single sample
        # needs a span: run a tenth of a period past it
        span = (periods - 1) * T if periods > 1 else 0.1 * T
        # a point that failed in the transient starts from where it stopped (NaN: skipped)
        try:
            run = system.simulate_grid(np.nan_to_num(Q0), np.nan_to_num(V0),
                                       (start, start + span), params, strobe=T, **kw)
        except GridInterrupted as stop:
            run, interrupted = stop.result, True
        q, qdot = run.strobe_q[..., :periods, :], run.strobe_qdot[..., :periods, :]
        status = run.status_name
        used = run.method
        if transient:
            bad = np.asarray(pre_status != "finished", dtype=bool)
            status = np.where(bad, pre_status, status)
            q = np.where(bad[..., None, None], np.nan, q)
            qdot = np.where(bad[..., None, None], np.nan, qdot)
    else:
        shape = pre.shape + (periods, system.n_dof)
        q = qdot = np.full(shape, np.nan)
        status = np.where(pre.status_name == "not_run", "not_run", "not_run").astype(object)
        used = pre.method
    return q, qdot, np.asarray(status, dtype=object), used, interrupted


def _warn_failed(status, where):
    failed = (status != "finished") & (status != "not_run")
    if failed.any():
        names, counts = np.unique(status[failed], return_counts=True)
        how = dict(zip(names.tolist(), counts.tolist(), strict=True))
        warnings.warn(f"{where}: {int(failed.sum())} of {status.size} runs failed ({how}); "
                      "their samples are NaN.", RuntimeWarning, stacklevel=3)


def bifurcation_diagram(system, params, about=None, *, parameter, values, q0=None, qdot0=0.0,
                        periods=200, transient=500, frequency="omega", angles=(), t0=0.0,
                        method=None, rtol=1e-8, atol=None, max_steps=None,
                        progress=None) -> BifurcationDiagram:
    """The stroboscopic bifurcation diagram of a driven system, by brute force.

    Every value of ``parameter`` × every start runs ``transient`` drive periods, then
    keeps ``periods`` strobe samples (once per drive period); the dots of all starts at a
    value are the attractors the starts found there.

    Parameters
    ----------
    system : lagrange_core.System
    params : dict
        The other parameters (scalars; ``params[parameter]``, if given, is ignored).
    about : array_like (n,), dict or None
        The state the diagram is about: the branch a continuation would follow (kept in
        the result), and the start when ``q0`` is not given.
    parameter : str
        The parameter varied (it may be the drive's frequency itself: T then varies).
    values : array_like (V,)
        Its values.
    q0, qdot0 : array_like (S, n), (n,), float or dict coordinate -> values (S,)
        The starts at t0 (for a system of one coordinate also (S,): one value per start).
        Default: ``about`` (zeros without it), at rest.
    periods : int
        Strobe samples kept per run (K).
    transient : int
        Drive periods run first and discarded.
    frequency : str or float
        The drive's angular-frequency parameter, or ω (rad/s).
    angles : str or sequence of str, or True
        Coordinates that are angles: drawn and compared modulo 2π (True: all).
    t0 : float
        Start time (s): the section's drive phase is ω t0.
    method, rtol, atol, max_steps, progress
        As :meth:`lagrange_core.System.simulate_grid` (rtol 1e-8 by default: the dots'
        error, far below what a figure shows, small enough for ``orbit_period``'s 1e-6).

    Returns
    -------
    kapitza.results.BifurcationDiagram
        ``figure()`` draws the dots; ``orbit_period()`` counts them per start.

    Raises
    ------
    ValueError
        Bad input.
    kapitza.results.ComputationInterrupted
        On Ctrl-C, with the finished points' samples.

    Notes
    -----
    Which integrator runs (``method=None``): a system of the form q̈ = f(q, t)
    (undamped, no velocity-dependent force) runs RKN 12 on ``simulate_grid``'s lanes; any
    other unconstrained system of at most six coordinates whose equations have lanes
    kernels (:mod:`lagrange_core._rhs_lanes`: at most 1500 operations) runs DOP853 on
    lanes (:mod:`kapitza.chaos._strobe_lanes`: the same method, step control and
    statuses as ``simulate_grid``'s "dop853", 64 trajectories per thread vectorised,
    ~7× faster on the damped pendulum; also with ``method="dop853"``).  Everything else
    — constraints, more coordinates, larger equations, other methods — runs
    ``simulate_grid``'s per-point kernels.  All pause long runs after a step budget, so
    Ctrl-C stops within about a second and keeps the samples taken so far.
    """
    where = "bifurcation_diagram"
    clock = time.perf_counter()
    if not isinstance(parameter, str) or parameter not in system.parameters:
        raise ValueError(f"{where}: parameter must name one of the system's parameters "
                         f"{list(system.parameters)}, got {parameter!r}.")
    vals = np.atleast_1d(np.asarray(values, dtype=float))
    if vals.ndim != 1 or vals.size == 0 or not np.all(np.isfinite(vals)):
        raise ValueError(f"{where}: values must be a 1-D array of finite values of "
                         f"{parameter!r}, got shape {vals.shape}.")
    fixed = {str(k): v for k, v in dict(params).items() if str(k) != parameter}
    pv = parameters(system, {**fixed, parameter: 0.0}, where, scalar=True)
    pv[parameter] = vals[:, None]
    omega = drive_frequency(system, pv, frequency, where)
    T = np.broadcast_to(2 * np.pi / omega, (vals.size, 1))
    ref = None if about is None else state(system, about, "about", single=True)
    if q0 is None:
        q0 = ref if ref is not None else 0.0
    Q0 = state(system, q0, "q0", starts=True)
    V0 = state(system, qdot0, "qdot0", starts=True)
    try:
        starts = np.broadcast_shapes(Q0.shape[:-1], V0.shape[:-1])
    except ValueError:
        raise ValueError(f"{where}: q0 and qdot0 give different numbers of starts "
                         f"({Q0.shape[:-1]} and {V0.shape[:-1]}).") from None
    if len(starts) > 1:
        raise ValueError(f"{where}: the starts must be a list (S, n), got shape "
                         f"{starts + (system.n_dof,)}.")
    n = system.n_dof
    S = starts[0] if starts else 1
    Q0 = np.broadcast_to(Q0, (S, n))
    V0 = np.broadcast_to(V0, (S, n))
    periods = whole_number(periods, "periods", 1)
    transient = whole_number(transient, "transient", 0)
    t0 = real_number(t0, "t0", unit="s")
    rtol, atol = tolerances(rtol, atol)
    names = angle_names(system, angles)
    grid_params = {k: (v if k == parameter else float(v)) for k, v in pv.items()}
    q, qdot, status, used, interrupted = _strobe_runs(
        system, grid_params, Q0[None], V0[None], T, t0, transient, periods, method, rtol, atol,
        max_steps, progress)
    status = np.broadcast_to(status, (vals.size, S))
    q = np.broadcast_to(q, (vals.size, S, periods, n))
    qdot = np.broadcast_to(qdot, (vals.size, S, periods, n))
    result = BifurcationDiagram(
        parameter=parameter, values=vals, coordinates=tuple(system.coordinates),
        q=np.array(q), qdot=np.array(qdot), q0=np.array(Q0), qdot0=np.array(V0), about=ref,
        period=np.array(T[:, 0]), periods=periods, transient=transient, angles=names,
        params={k: float(v) for k, v in pv.items() if k != parameter},
        status=np.array(status), method=used, rtol=rtol, wall_time=time.perf_counter() - clock)
    if interrupted:
        raise ComputationInterrupted(result, result.status != "not_run")
    _warn_failed(result.status, where)
    return result


def poincare_section(system, params, q0, qdot0=0.0, *, periods=1000, transient=0,
                     frequency="omega", angles=(), t0=0.0, method=None, rtol=1e-9, atol=None,
                     max_steps=None, progress=None) -> PoincareSection:
    """The stroboscopic (Poincaré) section of one trajectory, or of several starts.

    [q, q̇] at t0 + (transient + k) T, k = 0 … periods − 1: the flow of a T-periodic
    system seen once per drive period (a fixed point is a T-periodic orbit, a closed
    curve a quasi-periodic one, a cloud chaos).

    Parameters
    ----------
    system : lagrange_core.System
    params : dict
        Every parameter (scalars).
    q0, qdot0 : array_like (n,) or (..., n), float or dict coordinate -> value(s)
        The start(s) at t0; for a system of one coordinate any array (one per start).
    periods, transient : int
        Samples kept, and drive periods run before the first (discarded).
    frequency, angles, t0, method, rtol, atol, max_steps, progress
        As :func:`bifurcation_diagram` (its Notes say which integrator runs).

    Returns
    -------
    kapitza.results.PoincareSection
        Samples of shape S + (periods, n), S the starts' shape (() for one start).
    """
    where = "poincare_section"
    clock = time.perf_counter()
    pv = parameters(system, params, where, scalar=True)
    omega = float(drive_frequency(system, pv, frequency, where))
    T = 2 * math.pi / omega
    Q0 = state(system, q0, "q0")
    V0 = state(system, qdot0, "qdot0")
    try:
        S = np.broadcast_shapes(Q0.shape[:-1], V0.shape[:-1])
    except ValueError:
        raise ValueError(f"{where}: q0 and qdot0 do not broadcast together ({Q0.shape[:-1]} "
                         f"and {V0.shape[:-1]}).") from None
    n = system.n_dof
    Q0 = np.broadcast_to(Q0, S + (n,))
    V0 = np.broadcast_to(V0, S + (n,))
    periods = whole_number(periods, "periods", 1)
    transient = whole_number(transient, "transient", 0)
    t0 = real_number(t0, "t0", unit="s")
    rtol, atol = tolerances(rtol, atol)
    names = angle_names(system, angles)
    q, qdot, status, used, interrupted = _strobe_runs(
        system, {k: float(v) for k, v in pv.items()}, Q0, V0, T, t0, transient, periods,
        method, rtol, atol, max_steps, progress)
    result = PoincareSection(
        coordinates=tuple(system.coordinates), q=np.array(q), qdot=np.array(qdot),
        q0=np.array(Q0), qdot0=np.array(V0), period=T, t0=t0, periods=periods,
        transient=transient, angles=names, params={k: float(v) for k, v in pv.items()},
        status=np.array(status), method=used, rtol=rtol, wall_time=time.perf_counter() - clock)
    if interrupted:
        raise ComputationInterrupted(result, result.status != "not_run")
    _warn_failed(result.status, where)
    return result


def basin(system, params, about, *, q0, qdot0=0.0, periods=500, band=math.pi / 2,
          frequency="omega", t0=0.0, method=None, rtol=1e-9, atol=None, max_steps=None,
          progress=None) -> Basin:
    """The basin of a state: which initial states stay near it for the whole run.

    A run from (q0, qdot0) stays while |q_i − about_i| < band_i for every coordinate; it
    stops the moment it leaves (the batch integrator's band, located within the step).

    Parameters
    ----------
    system : lagrange_core.System
    params : dict
        Every parameter (scalars).
    about : array_like (n,) or dict coordinate -> value
        The state (coordinates): a driven equilibrium (e.g. the upright pendulum, θ = π)
        or the position of a periodic orbit.
    q0, qdot0 : array_like (..., n), float or dict coordinate -> value(s)
        The cells' initial states at t0, broadcast together: e.g. for one coordinate
        ``q0=theta[:, None], qdot0=rate[None, :]`` (a system of one coordinate takes any
        arrays).  Every start must lie inside the band.
    periods : int
        Drive periods each run lasts.
    band : float, array_like (n,) or dict coordinate -> half-width
        Half-width of the band about ``about`` (a dict leaves the coordinates it omits
        unbounded); default π/2.
    frequency, t0, method, rtol, atol, max_steps, progress
        As :func:`bifurcation_diagram`.

    Returns
    -------
    kapitza.results.Basin
        ``stays`` per cell, the exit times, ``fraction``, ``area`` (a regular 2-D grid in
        one plane of [q, q̇]) and ``figure()``.

    Raises
    ------
    ValueError
        Bad input, a start outside the band.
    kapitza.results.ComputationInterrupted
        On Ctrl-C, with the finished cells.
    """
    where = "basin"
    clock = time.perf_counter()
    pv = parameters(system, params, where, scalar=True)
    omega = float(drive_frequency(system, pv, frequency, where))
    T = 2 * math.pi / omega
    n = system.n_dof
    ref = state(system, about, "about", single=True)
    if isinstance(band, dict):
        half = np.array([float(band.get(c, math.inf)) for c in system.coordinates])
        unknown = sorted(set(map(str, band)) - set(system.coordinates))
        if unknown:
            raise ValueError(f"band: unknown coordinate(s) {unknown}; the coordinates are "
                             f"{list(system.coordinates)}.")
    else:
        half = np.broadcast_to(np.asarray(band, dtype=float), (n,)).copy()
    if not np.all(half > 0):
        raise ValueError(f"band must be a positive half-width per coordinate (inf: unbounded), "
                         f"got {half.tolist()}.")
    Q0 = state(system, q0, "q0")
    V0 = state(system, qdot0, "qdot0")
    try:
        S = np.broadcast_shapes(Q0.shape[:-1], V0.shape[:-1])
    except ValueError:
        raise ValueError(f"{where}: q0 and qdot0 do not broadcast together ({Q0.shape[:-1]} "
                         f"and {V0.shape[:-1]}).") from None
    Q0 = np.broadcast_to(Q0, S + (n,))
    V0 = np.broadcast_to(V0, S + (n,))
    outside = ~np.all(np.abs(Q0 - ref) < half, axis=-1)
    if outside.any():
        bad = Q0[outside][0]
        raise ValueError(f"{where}: the start q0 = {bad.tolist()} lies outside the band "
                         f"|q − about| < {half.tolist()} about {ref.tolist()}; every cell must "
                         "start inside it. Narrow the grid or widen the band.")
    periods = whole_number(periods, "periods", 1)
    t0 = real_number(t0, "t0", unit="s")
    rtol, atol = tolerances(rtol, atol)
    interrupted = False
    try:
        run = system.simulate_grid(Q0, V0, (t0, t0 + periods * T),
                                   {k: float(v) for k, v in pv.items()}, method=method,
                                   rtol=rtol, atol=atol, band=(ref - half, ref + half),
                                   max_steps=max_steps, progress=progress)
    except GridInterrupted as stop:
        run, interrupted = stop.result, True
    status = np.asarray(run.status_name, dtype=object)
    with np.errstate(invalid="ignore"):
        exit_time = np.where(status == "left_band", run.exit_time - t0, np.nan)
    result = Basin(
        coordinates=tuple(system.coordinates), params={k: float(v) for k, v in pv.items()},
        about=ref, q0=np.array(Q0), qdot0=np.array(V0), band=half, stays=status == "finished",
        exit_time=exit_time, status=status, period=T, periods=periods, method=run.method,
        rtol=rtol, wall_time=time.perf_counter() - clock)
    if interrupted:
        raise ComputationInterrupted(result, status != "not_run")
    failed = ~np.isin(status, ("finished", "left_band"))
    if failed.any():
        warnings.warn(f"{where}: {int(failed.sum())} of {status.size} runs failed "
                      f"({sorted(set(status[failed]))}); they are counted as not staying.",
                      RuntimeWarning, stacklevel=2)
    return result
