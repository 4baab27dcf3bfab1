"""Many trajectories at once: a grid of parameters and initial states in compiled parallel code.

Entry point: :meth:`System.simulate_grid` (which calls :func:`simulate_grid`).  It
returns a frozen :class:`GridTrajectories` holding *observables*, computed inside the
compiled kernel as the steps are taken (:mod:`lagrange_core._batch_kernels`), never the
trajectories: memory grows with the number of points (and strobe samples), not with
the number of steps.

What can be observed (each only when asked; see the kernel module for how)
--------------------------------------------------------------------------
* the final state (always), and the time mean of q over the run (always);
* ``strobe=T``: q and q̇ at t0 + kT (stroboscopic samples of a drive of period T);
* ``reference=q_ref``: the running maximum of |q − q_ref| per coordinate;
* ``band=(lower, upper)``: the first time a coordinate leaves [lower, upper], where
  that trajectory stops (status "left_band");
* ``energy=True``: max |h(t) − h(t0)| (NaN for a statement whose energy function is
  not conserved: a drive, forces or dissipation).

Methods
-------
The names of :data:`lagrange_core.integrate.METHODS` that run compiled: ``"rkn12"``
(adaptive RKN 12(10), the step control of ``simulate``'s "rkn12": held in blocks of 64
steps, at most 3/4 of the fastest drive period), ``"rkn12-fixed"`` (its 12th-order
formula at a fixed step: ``h``, or per point from an adaptive pilot over the first 1/50
of the span (widened as ``simulate``'s), shortened so a whole number of steps spans the
strobe period),
``"yoshida6"`` (symplectic, ``h`` required), for q̈ = f(q, t); ``"dop853"`` and ``"rk8"``
(``h`` required) for any system, constrained ones included.  The strobe samples are the
method's own solution, not an interpolation: the adaptive RKN 12 step (and its held
step) is the longest that divides the strobe period T, so its steps land on every
sample time without being shortened (and keep their drive rotations: no step of another
length between samples); the other methods' steps are shortened to land on them.

``method=None`` follows the rule of :func:`lagrange_core.integrate.simulate`: "rkn12"
when the statement has the form q̈ = f(q, t), "dop853" otherwise.  Why "rkn12" and not
"rkn12-fixed", though a fixed step needs no error norm: on the issue's sweep
(benchmarks/README.md, "Batch simulation") the held step costs about what the piloted
fixed step costs at the same rtol (at rtol 1e-3 24.7k against 25.2k points per second,
at 1e-9 7.2k against 9.6k), and it is checked at every step, so a point whose motion
speeds up after the pilot's window keeps its tolerance.  Name "rkn12-fixed" for a
sweep of periodic drives at tight tolerance.

Both RKN 12 methods run on *lanes* (``lagrange_core._batch_kernels.grid_rkn_lanes``):
each thread advances 128 points together with every loop over them vectorised and one
call of the drive kernel's ``fast_accel_lanes`` per stage for all of them; the results
equal those of the per-point loop (``point_second_order``)
to rounding (sin and cos are the lanes' own polynomials, within 2 ulp of libm), with
the same steps at a given fixed step.  Adaptive ``"dop853"`` runs on lanes too
(``lagrange_core._first_order_lanes``) for a grid of at least
:data:`FIRST_ORDER_LANES_MIN_POINTS` points of an unconstrained system with lanes
kernels and no energy drift asked, with the same results to rounding; smaller grids,
constrained systems, ``"rk8"`` and ``"yoshida6"`` run per point.

Failure is per point
--------------------
A point whose mass matrix turns singular, whose state becomes non-finite, whose step
size falls below the resolution of t or whose step budget (``max_steps``) runs out
gets that status (:data:`STATUS_NAMES`) and the state where it stopped; no other
point is affected and nothing is raised.

Chunks, progress and Ctrl-C
---------------------------
The points run in compiled parallel calls of about a quarter of a second: chunks of
points, and within a long run chunks of steps — a point that has taken its step budget
in a call *pauses* and goes on in the next one exactly where it stopped (its whole
integrator state saved: the same steps and numbers as an unbroken run; see
:mod:`lagrange_core._batch_kernels`).  A progress line is shown on stderr when it is a
terminal (``progress``; a single long run shows its share of the span and the time
left).  Ctrl-C stops the running call within a step — its kernels read
:data:`lagrange_core.progress.KERNEL_STOP`, and each running point pauses at its next
step — and raises :class:`GridInterrupted` (a KeyboardInterrupt) whose ``.result`` holds
every finished point, the points stopped part-way (status "interrupted": their
observables up to ``t_final``) and the points not started (status "not_run").
"""
from __future__ import annotations

import math
import time
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from . import _batch_kernels as _bk
from . import _compile_notice, _lanes_ahead
from . import _first_order_lanes as _fl
from .checks import real_array
from .drive_kernel import load_drive_kernel
from .memory import check_grid_memory
from .progress import KERNEL_STOP, ProgressLine, defer_ctrl_c, interrupt_requested

__all__ = ["GridTrajectories", "GridInterrupted", "simulate_grid", "STATUS_NAMES"]

#: the per-point status codes of :attr:`GridTrajectories.status`, by value
STATUS_NAMES = ("finished", "left_band", "underflow", "non_finite", "singular", "max_steps",
                "not_run", "interrupted")

#: RKN 12(10) (adaptive, fixed, piloted) runs on lanes (_bk.grid_rkn_lanes), not per point
_USE_LANES = True
#: adaptive DOP853 (systems not of the form q̈ = f(q, t): damped, velocity-dependent) runs
#: on lanes (lagrange_core._first_order_lanes) for grids of this many points or more on
#: unconstrained systems with lanes kernels (lagrange_core._rhs_lanes), with no energy
#: drift asked: 5.7× faster than per point on the damped pendulum's 64 × 64 grid, 2.1× at
#: 128 points, even at 64 (2026-11-28, benchmarks/README.md).  A smaller grid runs per
#: point: ``measure`` and the warm-up compile that path, and a few points do not pay for
#: the lanes' kernels (their driver and the system's ``rhs_lanes``, compiled on a grid's
#: first use: ~5 s more than the per-point path's first grid).
FIRST_ORDER_LANES_MIN_POINTS = 128
_USE_FIRST_ORDER_LANES = True

_GRID_METHODS = {"rkn12": ("second_order", 0, True), "rkn12-fixed": ("second_order", 0, False),
                 "yoshida6": ("second_order", 1, False), "dop853": ("dop853", 0, True),
                 "rk8": ("dop853", 0, False)}


@dataclass(frozen=True, eq=False)
class GridTrajectories:
    """Observables of a grid of trajectories (:func:`simulate_grid`); immutable.

    Every array has the grid's broadcast ``shape`` S in front.

    Attributes
    ----------
    shape : tuple
        The grid's shape S.
    coordinates : tuple of str
    params : dict name -> ndarray S
        Every parameter's value at every point.
    t0, t_final : ndarray S
        Start time and the time each run stopped (s): t1, or where it left the band,
        failed, or was stopped by Ctrl-C (status "interrupted").
    q, qdot : ndarray S + (n,)
        The state at ``t_final``.
    q_mean : ndarray S + (n,)
        Time average of q over [t0, t_final] (corrected trapezoid per step, 4th order).
    strobe_period : ndarray S or None
        The strobe period T (s).
    strobe_q, strobe_qdot : ndarray S + (K, n) or None
        q, q̇ at t0 + kT, k = 0 … K − 1; NaN after a run's end (a shorter span, a stop).
    max_deviation : ndarray S + (n,) or None
        max of |q − q_ref| at t0 and at every step end (``reference``; between
        step ends it is not sampled).
    exit_time : ndarray S or None
        First time a coordinate left the band (NaN: it never did).
    exit_coordinate : ndarray S (int) or None
        Which coordinate (index) left it (−1: none).
    energy_drift : ndarray S or None
        max |h(t) − h(t0)| over step ends (J); NaN when h is not conserved.
    n_steps, n_rejected, n_evaluations : ndarray S (int)
        Accepted and rejected steps, kernel evaluations (a pilot's included).
    error_estimate : ndarray S
        Sum of the local error estimates (as :attr:`Trajectory.error_estimate`; 0 for
        the symplectic method, which has none).
    status : ndarray S (int)
        Index into :data:`STATUS_NAMES`; :attr:`status_name` spells it.
    method : str
    rtol, atol : float
    wall_time : float
        Seconds for the whole grid.
    """

    shape: tuple
    coordinates: tuple
    params: dict
    t0: np.ndarray
    t_final: np.ndarray
    q: np.ndarray
    qdot: np.ndarray
    q_mean: np.ndarray
    strobe_period: np.ndarray | None
    strobe_q: np.ndarray | None
    strobe_qdot: np.ndarray | None
    max_deviation: np.ndarray | None
    exit_time: np.ndarray | None
    exit_coordinate: np.ndarray | None
    energy_drift: np.ndarray | None
    n_steps: np.ndarray
    n_rejected: np.ndarray
    n_evaluations: np.ndarray
    error_estimate: np.ndarray
    status: np.ndarray
    method: str
    rtol: float
    atol: float
    wall_time: float

    @property
    def size(self) -> int:
        return int(np.prod(self.shape, dtype=np.int64))

    @property
    def status_name(self) -> np.ndarray:
        """The status of every point as a string array of shape S."""
        status = np.asarray(self.status)        # a 0-d grid's too: an array, not a str
        return np.asarray(STATUS_NAMES, dtype=object)[status.reshape(-1)].reshape(status.shape)

    @property
    def ok(self) -> np.ndarray:
        """True where the run ended normally: finished, or left the band (bool, S)."""
        return (self.status == 0) | (self.status == 1)

    def counts(self) -> dict:
        """How many points ended with each status."""
        values, k = np.unique(self.status, return_counts=True)
        return {STATUS_NAMES[v]: int(c) for v, c in zip(values, k, strict=True)}

    def to_dataframe(self):
        """One row per grid point: the parameters, the final state, the observables
        asked for (per coordinate), the counts and the status (strobe samples are left
        out: they are a sequence per point; see :attr:`strobe_q`)."""
        import pandas as pd
        flat = self.size
        data = {name: np.broadcast_to(v, self.shape).reshape(flat)
                for name, v in self.params.items()}
        data["t_final"] = self.t_final.reshape(flat)
        for j, c in enumerate(self.coordinates):
            data[c] = self.q[..., j].reshape(flat)
            data[f"{c}_dot"] = self.qdot[..., j].reshape(flat)
            data[f"{c}_mean"] = self.q_mean[..., j].reshape(flat)
            if self.max_deviation is not None:
                data[f"{c}_max_deviation"] = self.max_deviation[..., j].reshape(flat)
        if self.exit_time is not None:
            data["exit_time"] = self.exit_time.reshape(flat)
            data["exit_coordinate"] = self.exit_coordinate.reshape(flat)
        if self.energy_drift is not None:
            data["energy_drift"] = self.energy_drift.reshape(flat)
        data["n_steps"] = self.n_steps.reshape(flat)
        data["error_estimate"] = self.error_estimate.reshape(flat)
        data["status"] = pd.Categorical(self.status_name.reshape(flat), categories=STATUS_NAMES)
        return pd.DataFrame(data)


class GridInterrupted(KeyboardInterrupt):
    """Ctrl-C during :func:`simulate_grid`; ``.result`` holds the finished points, those
    stopped part-way (status "interrupted") and those not started ("not_run")."""

    def __init__(self, result, done):
        part = int(np.sum(result.status == _bk.GRID_INTERRUPTED))
        super().__init__(f"grid interrupted after {done} of {result.size} points"
                         + (f" ({part} more stopped part-way, status 'interrupted')" if part
                            else "") + "; they are in the exception's .result (status "
                         "'not_run' marks the rest)")
        self.result = result


# -- arguments ---------------------------------------------------------------------------

def point_rows(a, shape, tail=()) -> np.ndarray:
    """``a`` broadcast to ``shape + tail`` with the grid's points as rows: a float array of
    shape (N,) + tail, N = prod(shape), C-ordered and always a writable copy (a view of a
    broadcast input is read-only, and numba compiles a grid kernel once more for every
    read-only/writable mix of its arguments: ~10-30 s each).  The grid kernels of
    ``kapitza.chaos`` take their inputs through it too."""
    n = int(np.prod(shape, dtype=np.int64))
    return np.array(np.broadcast_to(a, tuple(shape) + tail).reshape((n,) + tail),
                    dtype=float, order="C")


#: What a grid too large for memory can do instead.
_MEMORY_FIX = ("use fewer points or fewer strobe periods (strobe=None keeps none), or compute "
               "the grid in parts (slices of its axes), one call each")


def grid_bytes_per_point(n_dof: int, periods: int) -> float:
    """Peak memory (bytes) of one point of :func:`simulate_grid` with ``periods`` strobe
    samples kept (0 without a strobe): 2n floats a sample, and ~200 floats of inputs,
    per-point state and results.  Measured with tracemalloc, the difference of two grid
    sizes' peaks over their difference in points (the driven pendulum and 2- and 4-link
    chains, band and reference on, 2026-11-28): 1240–1600 bytes without a strobe,
    2470–7020 with 101 samples for n = 1–4; this is 27–63 % above each."""
    return 16.0 * n_dof * (periods + 1) + 1600.0 + 200.0 * n_dof


def _most_periods(t0, t1, strobe) -> int:
    """The most strobe samples a point keeps (0 without a strobe): from the unbroadcast
    inputs, so before the grid's arrays are made (the memory check needs it); spans that
    are not positive and finite count as none (refused later)."""
    if strobe is None:
        return 0
    with np.errstate(all="ignore"):
        span = np.asarray((t1 - t0) / strobe, dtype=float)
    span = span[np.isfinite(span) & (span > 0)]
    return int(min(np.floor(span.max() * (1 + 1e-12)), 2.0**62)) + 1 if span.size else 1


def _grid_arrays(system, q0, qdot0, t_span, params, h, strobe, reference, band):
    """Broadcast every per-point input to the grid shape S; flat (N, ...) float arrays."""
    n = system.n_dof
    names = system.parameters

    def state(values, what):
        if isinstance(values, Mapping):
            unknown = sorted(set(map(str, values)) - set(system.coordinates))
            if unknown:
                raise ValueError(f"{what}: unknown coordinate(s) {unknown}; the coordinates "
                                 f"are {list(system.coordinates)}.")
            cols = [real_array(values.get(c, 0.0), f"{what}[{c!r}]")
                    for c in system.coordinates]
            return np.stack(np.broadcast_arrays(*cols), axis=-1)
        arr = real_array(values, what)
        if arr.ndim == 0 or arr.shape[-1] != n:
            raise ValueError(f"{what} must have a last axis of {n} entries (one per coordinate "
                             f"{list(system.coordinates)}), got shape {arr.shape}; or pass a "
                             "dict coordinate -> value(s).")
        return arr

    Q0 = state(q0, "q0")
    V0 = state(qdot0, "qdot0")
    params = {} if params is None else dict(params)
    params = {str(k): v for k, v in params.items()}
    unknown = sorted(set(params) - set(names))
    if unknown:
        raise ValueError(f"unknown parameter(s) {unknown}; the parameters are {list(names)}.")
    missing = [p for p in names if p not in params]
    if missing:
        raise ValueError(f"missing value(s) for parameter(s) {missing}; pass them in params "
                         "(scalars or arrays that broadcast against each other).")
    pv = {k: real_array(params[k], f"parameter {k!r}") for k in names}
    try:
        t0, t1 = t_span
    except (TypeError, ValueError):
        raise ValueError(f"t_span must be a pair (t0, t1) (scalars or arrays), got "
                         f"{t_span!r}.") from None
    t0 = real_array(t0, "t_span[0]")
    t1 = real_array(t1, "t_span[1]")
    extras = {"h": h, "strobe": strobe}
    extras = {k: real_array(v, k) for k, v in extras.items() if v is not None}
    per_coord = {}
    if reference is not None:
        per_coord["reference"] = state(reference, "reference")
    if band is not None:
        try:
            lo, hi = band
        except (TypeError, ValueError):
            raise ValueError("band must be a pair (lower, upper) of coordinate values "
                             "(±inf for an unbounded side).") from None
        for what, v, side in (("band lower", lo, -np.inf), ("band upper", hi, np.inf)):
            per_coord[what] = _bounds(system, v, what, side)
    shapes = {"q0": Q0.shape[:-1], "qdot0": V0.shape[:-1], "t_span[0]": t0.shape,
              "t_span[1]": t1.shape}
    shapes.update({f"parameter {k!r}": v.shape for k, v in pv.items()})
    shapes.update({k: v.shape for k, v in extras.items()})
    shapes.update({k: v.shape[:-1] for k, v in per_coord.items()})
    try:
        S = np.broadcast_shapes(*shapes.values())
    except ValueError:
        desc = ", ".join(f"{k} {s}" for k, s in shapes.items() if s)
        raise ValueError(f"the grid inputs do not broadcast against each other: {desc}. Give "
                         "each axis its own dimension, e.g. A[:, None] and omega[None, :].") \
            from None
    label = " × ".join(f"{k} {s}" for k, s in shapes.items() if s)
    strobe_period = extras.get("strobe")
    # first from the shapes alone (one strobe sample a point at least): _most_periods
    # broadcasts t_span against strobe, 8 bytes a point, which for a grid far too large
    # would fail in numpy, naming no argument, before the check below could refuse it
    check_grid_memory(label, S, grid_bytes_per_point(n, 0 if strobe_period is None else 1),
                      where="simulate_grid: ", fix=_MEMORY_FIX)
    K = _most_periods(t0, t1, strobe_period)
    check_grid_memory(label, S, grid_bytes_per_point(n, K), where="simulate_grid: ",
                      fix=_MEMORY_FIX)
    N = int(np.prod(S, dtype=np.int64))

    def flat(a, tail=()):
        return point_rows(a, S, tail)

    T0, T1 = flat(t0), flat(t1)
    bad = ~(T1 > T0)
    if N and bad.any():
        k = int(np.argmax(bad))
        raise ValueError(f"t_span: the end time must be after the start time at every point; "
                         f"at flat index {k} t0 = {T0[k]!r}, t1 = {T1[k]!r}.")
    out = dict(S=S, N=N, Y0=np.hstack([flat(Q0, (n,)), flat(V0, (n,))]),
               P=np.stack([flat(pv[k]) for k in names], axis=1) if names else np.zeros((N, 0)),
               TS=np.stack([T0, T1], axis=1),
               params={k: np.broadcast_to(v, S) for k, v in pv.items()})
    if N == 0:
        out["P"] = out["P"].reshape(0, len(names))
    H = flat(extras["h"]) if "h" in extras else np.zeros(N)
    if "h" in extras and not np.all(H > 0):
        raise ValueError("h must be a positive step size (s) at every point.")
    out["H"] = H
    if "strobe" in extras:
        TSTR = flat(extras["strobe"])
        if not np.all(TSTR > 0):
            raise ValueError("strobe must be a positive period T (s) at every point, e.g. "
                             "strobe=2*np.pi/omega.")
        out["TSTR"] = TSTR
        out["K"] = K if N else 1
    else:
        out["TSTR"] = np.zeros(N)
        out["K"] = 0
    out["REF"] = flat(per_coord["reference"], (n,)) if "reference" in per_coord \
        else np.zeros((N, n))
    lo = flat(per_coord["band lower"], (n,)) if "band lower" in per_coord \
        else np.full((N, n), -np.inf)
    hi = flat(per_coord["band upper"], (n,)) if "band upper" in per_coord \
        else np.full((N, n), np.inf)
    if band is not None:
        inside = (out["Y0"][:, :n] >= lo) & (out["Y0"][:, :n] <= hi)
        if N and not inside.all():
            k = int(np.argmax(~inside.all(axis=1)))
            raise ValueError(f"band: the initial state at flat index {k}, q0 = "
                             f"{out['Y0'][k, :n].tolist()}, lies outside [{lo[k].tolist()}, "
                             f"{hi[k].tolist()}]; a run must start inside its band.")
        if not np.all(lo < hi):
            raise ValueError("band: every lower bound must be below its upper bound.")
    out["LO"], out["HI"] = lo, hi
    return out


def _bounds(system, values, what, unbounded):
    """One side of a band as an array (..., n): a number, an array, or a dict
    coordinate -> bound (missing coordinates unbounded); ±inf allowed, NaN refused."""
    n = system.n_dof
    if isinstance(values, Mapping):
        unknown = sorted(set(map(str, values)) - set(system.coordinates))
        if unknown:
            raise ValueError(f"{what}: unknown coordinate(s) {unknown}; the coordinates are "
                             f"{list(system.coordinates)}.")
        cols = [np.asarray(values.get(c, unbounded), dtype=float) for c in system.coordinates]
        arr = np.stack(np.broadcast_arrays(*cols), axis=-1)
    else:
        try:
            arr = np.asarray(values, dtype=float)
        except (TypeError, ValueError):
            raise ValueError(f"{what} must be numbers (±inf for unbounded), got "
                             f"{values!r}.") from None
        if arr.ndim == 0:
            arr = np.full(n, float(arr))
        if arr.shape[-1] != n:
            raise ValueError(f"{what} must have a last axis of {n} entries (one per coordinate "
                             f"{list(system.coordinates)}), got shape {arr.shape}.")
    if np.isnan(arr).any():
        raise ValueError(f"{what} contains NaN; use ±inf for an unbounded side.")
    return arr


def _check_scalars(rtol, atol, max_steps):
    rtol = float(rtol)
    if not (math.isfinite(rtol) and 1e-15 <= rtol):
        raise ValueError(f"rtol must be a number ≥ 1e-15, got {rtol!r}.")
    atol = rtol if atol is None else float(atol)
    if not (math.isfinite(atol) and atol > 0):
        raise ValueError(f"atol must be a positive number, got {atol!r}.")
    if max_steps is None:
        max_steps = 1 << 62
    elif int(max_steps) != max_steps or max_steps < 1:
        raise ValueError(f"max_steps must be a positive whole number, got {max_steps!r}.")
    return rtol, atol, int(max_steps)


def compile_activity(what: str, kernels, method, points: int | None = None) -> str | None:
    """The compile notice's activity (:mod:`lagrange_core._compile_notice`) for ``what``
    ("simulate_grid", "measure") running grids of ``method`` (None: the default for
    ``kernels``) over ``points`` points (None: few), named by the driver it compiles on an
    empty cache: e.g. "measure, RKN 12", "measure, DOP853 lanes".  None for a method
    :func:`simulate_grid` refuses (it says why)."""
    method = default_method(kernels) if method is None else method
    if method not in _GRID_METHODS:
        return None
    family, sub, adaptive = _GRID_METHODS[method]
    driver = "DOP853" if family == "dop853" else "symplectic" if sub else "RKN 12"
    if points is not None and _first_order_lanes_fit(kernels, family, adaptive, points):
        driver = "DOP853 lanes"
    return f"{what}, {driver}"


def default_method(kernels) -> str:
    """A grid's method when none is given: RKN 12 where q̈ = f(q, t), else DOP853 (the
    one rule: ``simulate_grid``, the compile notice and kapitza's ``measure`` read it
    here)."""
    return "rkn12" if kernels.rkn_form else "dop853"


def _runs_on_lanes(family, sub) -> bool:
    """Whether a grid of this method family runs on RKN 12's lanes (:func:`_grid_method`)."""
    return family == "second_order" and sub == 0 and _USE_LANES


def _first_order_lanes_fit(kernels, family, adaptive, npoints) -> bool:
    """Whether a grid's method, size and system call for DOP853's lanes, from what is known
    before anything is generated (:data:`FIRST_ORDER_LANES_MIN_POINTS`)."""
    return (_USE_FIRST_ORDER_LANES and family == "dop853" and adaptive
            and npoints >= FIRST_ORDER_LANES_MIN_POINTS and not kernels.n_constraints)


def _runs_on_first_order_lanes(kernels, family, adaptive, flags, npoints) -> bool:
    """Whether a grid runs DOP853 on lanes (:func:`_first_order_lanes_fit`, no energy drift
    asked, the system has lanes kernels); loads them when it does (generated on their
    first use)."""
    if not _first_order_lanes_fit(kernels, family, adaptive, npoints) \
            or flags & _bk.OBS_ENERGY:
        return False
    from ._rhs_lanes import load_rhs_lanes
    return load_rhs_lanes(kernels)[0]


def runs_on_lanes(kernels, method=None) -> bool:
    """Whether ``System.simulate_grid`` of these kernels with ``method`` (None: the
    default) and no fixed step ``h`` runs on RKN 12's lanes; False where it refuses the
    method (it says why)."""
    try:
        _, family, sub, _ = _grid_method(kernels, method, False)
    except ValueError:
        return False
    return _runs_on_lanes(family, sub)


def _grid_method(kernels, method, h_given):
    from .integrate import rkn_eligibility
    if method is None:
        method = default_method(kernels)
    if method not in _GRID_METHODS:
        raise ValueError(f"simulate_grid runs methods {sorted(_GRID_METHODS)}, got {method!r}.")
    family, sub, adaptive = _GRID_METHODS[method]
    if family == "second_order" and not kernels.rkn_form:
        raise ValueError(f"method {method!r} needs equations of the form q̈ = f(q, t), but "
                         f"{rkn_eligibility(kernels)[1]}. Use method='dop853' instead.")
    if not adaptive and not h_given and method != "rkn12-fixed":
        raise ValueError(f"method {method!r} has a fixed step: pass h (s), e.g. h=T/20 for a "
                         "drive of period T.")
    return method, family, sub, adaptive


# -- the calls: chunks of points, long runs paused and resumed ----------------------------

#: seconds one compiled call is sized to take: progress is shown between calls (Ctrl-C
#: does not wait for a call: its kernels read KERNEL_STOP at every step)
_TARGET = 0.25
#: steps a point may take in the first call (the next calls' budget is sized from its time):
#: a grid's points end within it (the damped pendulum's 64 × 64 grid of 500 periods takes
#: ~2100 DOP853 steps a point at rtol 1e-6: at 2048 most of its points paused once, and
#: the calls that resumed them ended on one thread; 0.567–0.571 → 0.530–0.546 s at 8192,
#: 2026-11-28), while a long run still pauses within milliseconds of its start
_FIRST_BUDGET = 8192


#: a call's points may grow this much over the last call's, its step budget 8×: a grid
#: of 64 × 64 points goes in calls of 16, 1024 and 3056 points (at 8×: 16, 128, 1024 and
#: 2928; every call ends with its lanes emptying, 2 % of that grid's time, 2026-11-28)
_GROWTH = 64.0


#: elements of the strobe's samples filled between two looks for Ctrl-C (32 MiB, ~0.1 s)
_FILL_CHUNK = 1 << 22


def _nan_filled(shape):
    """A float array of NaN, or None when Ctrl-C came while it was filled.

    The strobe's samples of a long run are large (3·10⁷ periods: 480 MB, 1.7 s to fill on
    the 2-core machine of benchmarks/README.md, most of it the first touch of each page):
    filled a slice at a time, looking for a deferred Ctrl-C between slices, so that the
    call stops within a second of it even before its first step."""
    out = np.empty(shape)
    flat = out.reshape(-1)
    for start in range(0, flat.size, _FILL_CHUNK):
        if start and interrupt_requested():
            return None
        flat[start:start + _FILL_CHUNK] = np.nan
    return out


def _run_paused(call, N, TS, TF, STATUS, width, progress, first, label="simulate_grid"):
    """Integrate every point through ``call(idx, budget, slot, SAVE, SAVEI)`` in calls of
    about :data:`_TARGET` seconds; returns (points ended, interrupted) — interrupted also
    when the Ctrl-C came during the last call and every point ended.

    A call takes the points paused by the last one (their saved state first) and new
    points up to ``size``; a point that has taken ``budget`` steps in a call pauses
    (:mod:`lagrange_core._batch_kernels`, status GRID_INTERRUPTED) and goes on in the
    next.  ``size`` (points) and ``budget`` (steps) are sized from the time each call
    took, at most :data:`_GROWTH` and 8× the last, so a grid of short runs goes by chunks
    of points and a long run by chunks of steps.  Progress counts a paused point by the
    share of its span it has reached.  On Ctrl-C (the call in flight pauses its running
    points at their next step: :data:`lagrange_core.progress.KERNEL_STOP`) the paused
    points keep status GRID_INTERRUPTED with their observables so far, the points never
    started "not_run".
    """
    bar = ProgressLine(progress, N, label, "points" if N != 1 else "of the run",
                       fraction=N == 1)
    span = TS[:, 1] - TS[:, 0]
    nxt = ended = 0
    size = max(1, min(first, N))
    budget = _FIRST_BUDGET
    paused = np.zeros(0, dtype=np.int64)
    save = np.zeros((0, width))
    savei = np.zeros((0, _bk.SAVEI_WIDTH), dtype=np.int64)
    try:
        while len(paused) or nxt < N:
            if interrupt_requested():
                raise KeyboardInterrupt
            take = min(max(size - len(paused), 0), N - nxt)
            idx = np.concatenate([paused, np.arange(nxt, nxt + take, dtype=np.int64)])
            SAVE = np.zeros((len(idx), width))
            SAVEI = np.zeros((len(idx), _bk.SAVEI_WIDTH), dtype=np.int64)
            SAVE[:len(paused)] = save
            SAVEI[:len(paused)] = savei
            start = time.perf_counter()
            call(idx, budget, np.arange(len(idx), dtype=np.int64), SAVE, SAVEI)
            dt = max(time.perf_counter() - start, 1e-6)
            nxt += take
            stop = STATUS[idx] == _bk.GRID_INTERRUPTED
            paused, save, savei = idx[stop], SAVE[stop], SAVEI[stop]
            ended += len(idx) - len(paused)
            if len(paused):
                budget = int(min(max(64.0, budget * _TARGET / dt), 8.0 * budget))
            else:
                size = int(min(max(1.0, len(idx) / dt * _TARGET), _GROWTH * size))
            with np.errstate(invalid="ignore", divide="ignore"):
                share = np.clip((TF[paused] - TS[paused, 0]) / span[paused], 0.0, 1.0)
            bar.update(ended + float(np.sum(share)))
    except KeyboardInterrupt:
        bar.close()
        return ended, True
    bar.close()
    # a Ctrl-C during the last call (its points all ended) is not dropped: the caller
    # raises its interruption, with the whole result in it
    return ended, interrupt_requested()


# -- simulate_grid -----------------------------------------------------------------------

def simulate_grid(system, q0, qdot0, t_span, params=None, *, method=None, rtol=1e-9,
                  atol=None, h=None, strobe=None, reference=None, band=None, energy=False,
                  max_steps=None, progress=None) -> GridTrajectories:
    """Integrate ``system`` at every point of a broadcast grid; see the module docstring.

    Parameters
    ----------
    system : lagrange_core.System
    q0, qdot0 : array_like (..., n) or dict coordinate -> value(s)
        Initial coordinates and velocities; the leading axes broadcast with the rest.
    t_span : (t0, t1)
        Start and end time (s); each may be an array (e.g. a number of drive periods
        ``(0, 500 * 2 * np.pi / omega)``).
    params : dict name -> float or array
        Every parameter, scalars or arrays that broadcast against each other.
    method, rtol, atol, h
        Method name (module docstring), tolerances, fixed step (s; scalar or array).
    strobe : float or array, optional
        Period T (s) of the stroboscopic samples.
    reference : array_like (..., n), optional
        q_ref for the running maximum of |q − q_ref|.
    band : (lower, upper), optional
        Arrays (..., n) (±inf: unbounded) or dicts coordinate -> bound.
    energy : bool
        Record the energy drift.
    max_steps : int, optional
        Step budget per point (status "max_steps" when used up).
    progress : None, bool or callable
        See :class:`lagrange_core.progress.ProgressLine`.

    Returns
    -------
    GridTrajectories

    Raises
    ------
    ValueError
        Bad input (naming the argument), an ineligible method.
    lagrange_core.memory.GridTooLargeError
        A grid whose arrays would not fit in memory (:func:`grid_bytes_per_point` per
        point against :func:`lagrange_core.memory.memory_limit`), before any is allocated.
    GridInterrupted
        On Ctrl-C, with the finished points in ``.result``.
    """
    start = time.perf_counter()
    rtol, atol, max_steps = _check_scalars(rtol, atol, max_steps)
    g = _grid_arrays(system, q0, qdot0, t_span, params, h, strobe, reference, band)
    kernels = system.kernels
    method, family, sub, adaptive = _grid_method(kernels, method, h is not None)
    n, m, N, K = system.n_dof, kernels.n_constraints, g["N"], g["K"]
    flags = ((_bk.OBS_STROBE if strobe is not None else 0)
             | (_bk.OBS_REF if reference is not None else 0)
             | (_bk.OBS_BAND if band is not None else 0)
             | (_bk.OBS_ENERGY if energy and kernels.energy_conserved else 0))
    slots = {"rhs", "energy"} if energy else {"rhs"}
    if m:
        slots |= {"constraint_residual", "constraint_jacobian"}
    lanes = _runs_on_lanes(family, sub)
    if family == "second_order":
        load_drive_kernel(kernels, lanes=lanes)
    if lanes:           # on a cold cache the driver's callees compile on the other core
        _lanes_ahead.start_if_cold()
    first_order_lanes = _runs_on_first_order_lanes(kernels, family, adaptive, flags, N)
    ka = kernels.addresses(*sorted(slots))

    # from here on Ctrl-C is deferred (the allocations included: the strobe samples of a
    # long run take a while): the call in flight pauses its points at their next step
    # (KERNEL_STOP), and the run stops with what it computed; a first compile of the
    # shared kernels says how long this method's compile takes
    with defer_ctrl_c(), _compile_notice.declared(compile_activity("simulate_grid", kernels,
                                                                   method, N)):
        YF = np.full((N, 2 * n), np.nan)
        TF = np.full(N, np.nan)
        sq_shape = (N, max(K, 1) if strobe is not None else 1, 2 * n)
        SQ = _nan_filled(sq_shape)
        QM = np.zeros((N, n))
        DEV = np.zeros((N, n))
        EXIT = np.full(N, np.nan)
        EXITC = np.full(N, -1, dtype=np.int64)
        EDRIFT = np.full(N, np.nan)
        COUNTS = np.zeros((N, 3), dtype=np.int64)
        ERR = np.zeros(N)
        STATUS = np.full(N, _bk.GRID_NOT_RUN, dtype=np.int64)
        from .integrate import METHODS
        tab = METHODS[method].table
        pilot = method == "rkn12-fixed" and h is None
        common = (g["Y0"], g["P"], g["TS"], g["H"], g["TSTR"], g["REF"], g["LO"], g["HI"],
                  flags, rtol, atol, max_steps)
        outs = (YF, TF, SQ, QM, DEV, EXIT, EXITC, EDRIFT, COUNTS, ERR, STATUS)

        import numba

        from .integrate import _HOLD_BLOCK
        lane_mode = (_bk.LANES_ADAPTIVE if adaptive else _bk.LANES_PILOT if pilot
                     else _bk.LANES_FIXED)
        stages = tab["c"].shape[0] if family == "second_order" and sub == 0 else \
            tab["w"].shape[0] + 1 if family == "second_order" else 13
        rates = (_bk.drive_rates(ka, g["P"][0]).shape[0] if family == "second_order" and N
                 else 0)
        width = _bk.save_width(n, stages, rates, _HOLD_BLOCK)

        def call(idx, budget, slot, save, savei):
            if lanes:
                _bk.grid_rkn_lanes(ka, lane_mode, _HOLD_BLOCK, idx, *common, tab["c"],
                                   tab["A"], tab["b"], tab["bp"], tab["bh"], tab["bph"], *outs,
                                   budget, KERNEL_STOP, slot, save, savei)
            elif first_order_lanes:
                _fl.grid_dop853_lanes(ka, m, adaptive, idx, *common, tab["A"], tab["B"],
                                      tab["C"], tab["E3"], tab["E5"], *outs, budget,
                                      KERNEL_STOP, slot, save, savei)
            elif family == "second_order":
                # (None: numba compiles the symplectic driver without RKN 12's code)
                rkn = None if sub else (tab["c"], tab["A"], tab["b"], tab["bp"], tab["bh"],
                                        tab["bph"])
                _bk.grid_second_order(ka, rkn, tab["w"], adaptive, pilot, _HOLD_BLOCK, idx,
                                      *common, *outs, budget, KERNEL_STOP, slot, save, savei)
            else:
                _bk.grid_dop853(ka, m, adaptive, idx, *common, tab["A"], tab["B"], tab["C"],
                                tab["E3"], tab["E5"], *outs, budget, KERNEL_STOP, slot,
                                save, savei)

        if SQ is None:              # Ctrl-C came while the strobe's samples were filled
            SQ = np.broadcast_to(np.nan, sq_shape)      # no point ran (read-only, no memory)
            done, interrupted = 0, True
        else:
            done, interrupted = _run_paused(call, N, g["TS"], TF, STATUS, width, progress,
                                            8 * numba.get_num_threads())
    run = STATUS != _bk.GRID_NOT_RUN
    span = TF - g["TS"][:, 0]
    with np.errstate(invalid="ignore", divide="ignore"):
        QM = np.where((span > 0)[:, None], QM / span[:, None], YF[:, :n])
    QM[~run] = np.nan
    if not (flags & _bk.OBS_ENERGY):
        EDRIFT[:] = np.nan
    S = g["S"]
    result = GridTrajectories(
        shape=S, coordinates=tuple(system.coordinates), params=g["params"],
        t0=g["TS"][:, 0].reshape(S), t_final=TF.reshape(S), q=YF[:, :n].reshape(S + (n,)),
        qdot=YF[:, n:].reshape(S + (n,)), q_mean=QM.reshape(S + (n,)),
        strobe_period=g["TSTR"].reshape(S) if strobe is not None else None,
        strobe_q=SQ[:, :K, :n].reshape(S + (K, n)) if strobe is not None else None,
        strobe_qdot=SQ[:, :K, n:].reshape(S + (K, n)) if strobe is not None else None,
        max_deviation=DEV.reshape(S + (n,)) if reference is not None else None,
        exit_time=EXIT.reshape(S) if band is not None else None,
        exit_coordinate=EXITC.reshape(S) if band is not None else None,
        energy_drift=EDRIFT.reshape(S) if energy else None,
        n_steps=COUNTS[:, _bk.CNT_STEPS].reshape(S),
        n_rejected=COUNTS[:, _bk.CNT_REJECTED].reshape(S),
        n_evaluations=COUNTS[:, _bk.CNT_EVALS].reshape(S), error_estimate=ERR.reshape(S),
        status=STATUS.reshape(S), method=method, rtol=rtol, atol=atol,
        wall_time=time.perf_counter() - start)
    if interrupted:
        raise GridInterrupted(result, done)
    return result
