"""Integrate the equations of motion of a :class:`~lagrange_core.System`.

Why one module over 800 lines: the method registry, the chunked driver loop, events and
the ``Trajectory`` they fill are one concept, and most of the length is the methods'
documentation below.

Entry point: :meth:`System.simulate` (which calls :func:`simulate`).  It returns
a frozen :class:`Trajectory`.

Methods
-------
Methods are chosen by name from the registry :data:`METHODS` (a dict
name -> :class:`Method`).  ``list(METHODS)`` gives the valid names:

``"dop853"``
    Dormand–Prince 8(5,3), adaptive, 7th-order dense output (Hairer's DOP853,
    with scipy's coefficient table).  The general-purpose default.
``"rk8"``
    The same 8th-order formula at a fixed step ``h`` (no error control; the
    local error estimates are still summed).
``"rkn12"``
    Dormand, El-Mikkawy & Prince's Runge–Kutta–Nyström 12(10) pair, adaptive,
    for q̈ = f(q, t) (no velocity dependence, no constraints), with a *held*
    step: after the first 16 steps the step stays at the 20 % quantile of the
    ideal steps the error estimates of the last 64 steps propose, re-estimated
    every 64 steps; a step that fails the tolerance is still rejected, retaken
    shorter, and the step grows back (``_integrator_kernels.fast_rkn_chunk``).
    On a driven system the step does not chase the drive's phase (the classic
    controller rejected 20 % of the steps of the driven pendulum; this one about
    1 %) and the drive's rotations are computed once per step size, so a step
    costs what a fixed step costs.  No step spans more than 3/4 of the period
    of the fastest drive harmonic (beyond, the error estimate stops measuring
    the error).
``"rkn12-fixed"``
    The same 12th-order formula at a fixed step ``h``; without ``h`` the step is
    chosen from the tolerance by a pilot run of the classic adaptive controller
    over the first 1/50 of t_span (the 20th percentile of its steps beyond its
    starting ramp, where the controller still grows the step 2-fold or more a step;
    a pilot with fewer than 8 such steps runs again over a window 8 times longer,
    at most t_span), and nothing checks it afterwards (a motion that speeds up later
    gets a step too long for the tolerance).
``"yoshida6"``
    A symplectic, time-reversible 6th-order composition of velocity Verlet
    (Yoshida 1990), fixed step, for q̈ = f(q, t).
``"scipy:<name>"``
    :func:`scipy.integrate.solve_ivp` with ``method=<name>`` (``RK45``,
    ``RK23``, ``DOP853``, ``LSODA``, ``Radau``, ``BDF``); the implicit ones
    get the exact compiled Jacobian.  For comparison: every step crosses the
    Python boundary, and constrained systems get no projection (their
    ``constraint_residual`` shows the drift).

The RKN and symplectic methods evaluate q̈ = f(q, t) with the system's *drive kernel*
(:mod:`lagrange_core.drive_kernel`), generated specially for that form.  Their drivers
advance a harmonic drive cos(αt + β) by rotations instead of new trig calls, and sum
time and state with compensation (Kahan), so 10⁵–10⁶ fixed steps do not accumulate
rounding.

Output at ``t_eval`` and events: DOP853 interpolates with its 7th-order dense
output and locates event roots on it to a few ulps of t (Illinois iteration);
the RKN and symplectic methods have no interpolant, so they shorten steps to
land exactly on each requested time (many closely spaced times cost extra
steps) and locate events by re-stepping from the step start to each trial
time (the method's own accuracy, a few ulps of t).  Constrained states are
projected onto Φ = 0, Φ̇ = 0 after every step and at every output time.

Default method (``method=None``)
--------------------------------
1. A system of the form q̈ = f(q, t) (the derived forcing F does not depend on the
   velocities and there are no constraints; :func:`rkn_eligibility`) gets ``"rkn12"``;
   any other ``"dop853"``.  Naming the method gives the same result to the last bit.
2. ``"rkn12"`` is the fastest accurate method we have for that form at every
   tolerance measured, long runs and short: on the work–precision benchmark of the
   driven pendulum (2000 drive periods) it takes the steps of ``"rkn12-fixed"`` with
   its step chosen from the tolerance, in about the same time, and reaches every
   error level from 1e-3 to 1e-10 at most as slowly as heyoka's Taylor integrator
   (benchmarks/README.md, "Work–precision", issue 11 point 8).  It is the default
   rather than ``"rkn12-fixed"`` because its step is checked at every step and
   re-estimated every 64: a motion that speeds up after the pilot's window (a pendulum
   that falls over late, an oscillator whose frequency grows) keeps its tolerance
   instead of silently losing it.
3. What ``rtol`` (and ``atol``, default ``rtol``) promise: every accepted step's
   embedded error estimate is within atol + rtol·|y| (RMS over the state).  That
   is a *local* promise.  On the work–precision problem it keeps the global error
   |θ(T) − θ_ref(T)| at or below rtol for every rtol from 1e-3 to 1e-10
   (tests/test_default_method.py); over longer spans, and for larger or chaotic
   motion, the global error grows past rtol as it does for every method with local
   error control (heyoka's included) — use ``error_check=True`` to measure it.
4. A short run pays a fixed cost of about 25 µs per call in Python, plus the
   compiled steps (benchmarks/bench_call_overhead.py).

Rules for adding a method (the base-class contract)
---------------------------------------------------
1. A method is a :class:`Method` entry in :data:`METHODS`: its name, its
   family, its order, whether it is adaptive, its coefficient table, a one-line
   description, and the name of the driver that runs it.  The class carries data only.
2. A driver is a ``@njit(cache=True)`` function in :mod:`lagrange_core._integrator_kernels`,
   compiled once per installation for every system: it reaches the system's kernels
   through the address table ``ka`` (:mod:`lagrange_core._kernel_calls`), never by name.
   No Python objects, no allocation inside the step loop, coefficients passed as
   arrays.  Its entry in ``_DRIVERS`` says which kernels it calls and runs one chunk.
3. A driver advances in chunks and keeps its whole state in the arrays it is
   given (the named slots ``TV_*`` and ``ST_*`` of the kernel module), returning
   one of the ``STATUS_*`` codes, so that Python can stop, store output and continue.
4. A method that only applies to some systems declares it (``requires``) and
   :func:`simulate` raises a ValueError saying why a system is not eligible.
5. Every method reports the counts (steps, rejected steps, right-hand-side
   evaluations) and an error estimate, and gets a row in the parametrized tests
   (tests/test_integrate.py) against the closed-form problems.

Error estimate
--------------
``Trajectory.error_estimate`` is, by default, the *sum over accepted steps of
the local error estimates* (max norm over the state, in the units of q and q̇).
For an embedded pair the local estimate is that of the lower-order member, so
for problems without exponential error growth (oscillators, the pendulum) the
sum is an upper bound of the global error of the higher-order solution the
method propagates; for chaotic or unstable motion it is not (errors grow like
e^{λt}).  With ``error_check=True`` the run is repeated at rtol/1000, atol/1000
and the estimate is the largest difference at the stored times (which
estimates the true error whenever the method's error scales with tolerance).
Methods without an embedded estimate (the symplectic one) report NaN unless
``error_check=True``.

Memory and interruption
-----------------------
Without ``t_eval`` every ``stride``-th accepted step is stored (default every
step), but never more than about ``max_points`` rows (default 10⁶): when the
store reaches it, every other stored row is dropped and the stride doubles, so
a very long run keeps a uniformly thinned record of the whole interval (and its
last point) in bounded memory.  With ``t_eval`` only those times are stored.  The
integration runs in chunks of at most ``chunk_steps`` steps in compiled code; between
chunks Python stores output and checks for Ctrl-C.  On KeyboardInterrupt :func:`simulate` raises
:class:`SimulationInterrupted` (a KeyboardInterrupt, so scripts still stop)
whose ``trajectory`` attribute holds everything computed so far (status
``"interrupted"``).
"""
from __future__ import annotations

import contextlib
import functools
import math
import time
from dataclasses import dataclass, field, replace

import numpy as np

from . import _integrator_kernels as _kern
from ._first_calls import compiling
from ._selection import PILOT_MIN_SETTLED, PILOT_SPAN_DIVISOR, PILOT_WIDEN, pilot_step_quantile
from .drive_kernel import load_drive_kernel
from .progress import ProgressLine, defer_ctrl_c, interrupt_requested

__all__ = ["Method", "METHODS", "Event", "turning_point", "crossing", "multiplier_zero",
           "Trajectory", "SimulationInterrupted", "simulate", "check_options", "rkn_eligibility"]


# -- methods -------------------------------------------------------------------------------

@dataclass(frozen=True)
class Method:
    """One integration method: data only (rule 1 of the module docstring).

    Attributes
    ----------
    name : str
        Registry key.
    family : str
        Which driver runs it: ``"dop853"``, ``"rkn"``, ``"symplectic"``, ``"scipy"``.
    order : int
        Order of the propagated solution.
    adaptive : bool
        Step-size control from an embedded error estimate (else a fixed step ``h``).
    requires : str
        ``""`` (any system) or ``"rkn"`` (q̈ = f(q, t): no velocity dependence,
        no constraints).
    description : str
    table : dict
        The coefficient arrays the driver takes.
    driver : str
        The compiled driver that runs it (a key of ``_DRIVERS``; "" for scipy's).
    error_order : int
        Order q of the embedded error estimate (the starting step uses 1/(q + 1)).
    """

    name: str
    family: str
    order: int
    adaptive: bool
    requires: str = ""
    description: str = ""
    table: dict = field(default_factory=dict, repr=False, compare=False)
    driver: str = ""
    error_order: int = 0


class _LazyTable(dict):
    """A coefficient table filled on first use (scipy.integrate costs 0.5 s to import)."""

    def __init__(self, load):
        super().__init__()
        self._load = load

    def __getitem__(self, key):
        if not len(self):
            self.update(self._load())
        return super().__getitem__(key)


def _dop853_coefficients():
    """Hairer's DOP853 table as scipy ships it (``scipy.integrate._ivp.dop853_coefficients``,
    six numpy arrays), read from that module's file: imported by name, it first runs the
    ``scipy.integrate`` package, which imports scipy.optimize and scipy.sparse — 0.33 CPU-s
    of a new system's first ``simulate`` (2.3 s on the 2026-11-29 machine) for a table.
    Where the file is not found or does not read, it is imported by name."""
    c = _scipy_file_module("integrate/_ivp/dop853_coefficients.py")
    if c is None:
        from scipy.integrate._ivp import dop853_coefficients as c
    return {name: np.ascontiguousarray(getattr(c, name), dtype=float)
            for name in ("A", "B", "C", "E3", "E5", "D")}


@functools.cache
def _scipy_file_module(relative: str):
    """The module at ``relative`` inside the scipy package, executed from its file without
    importing the packages above it; None where it cannot be.  Once per process, as an
    import is ("dop853" and "rk8" both read DOP853's table)."""
    import importlib.util
    from pathlib import Path

    import scipy
    path = Path(scipy.__file__).parent / relative
    if not path.is_file():
        return None
    spec = importlib.util.spec_from_file_location(f"_lagrange_core_scipy_{path.stem}", path)
    if spec is None or spec.loader is None:
        return None
    module = importlib.util.module_from_spec(spec)
    try:
        spec.loader.exec_module(module)
    except Exception:           # (another scipy's file): the import by name decides
        return None
    return module


_SCIPY_METHODS = ("RK23", "RK45", "DOP853", "LSODA", "Radau", "BDF")
_IMPLICIT = ("LSODA", "Radau", "BDF")

def _rkn12_table():
    from .integrator_tables import rkn12_table
    t = rkn12_table()
    t["w"] = np.zeros(1)
    return t


def _yoshida6_table():
    from .integrator_tables import yoshida6_weights
    z = np.zeros(1)
    return {"c": z, "A": np.zeros((1, 1)), "b": z, "bp": z, "bh": z, "bph": z,
            "w": yoshida6_weights()}


#: The integration methods by name (``simulate(method=...)``): each a :class:`Method`;
#: ``"scipy:<name>"`` entries call ``scipy.integrate.solve_ivp`` for comparison.
METHODS: dict[str, Method] = {
    "dop853": Method("dop853", "dop853", 8, True, "",
                     "Dormand–Prince 8(5,3), adaptive, dense output (Hairer's DOP853)",
                     _LazyTable(_dop853_coefficients), driver="dop853", error_order=7),
    "rk8": Method("rk8", "dop853", 8, False, "",
                  "the 8th-order DOP853 formula at a fixed step h",
                  _LazyTable(_dop853_coefficients), driver="dop853", error_order=7),
    "rkn12": Method("rkn12", "rkn", 12, True, "rkn",
                    "Dormand–El-Mikkawy–Prince RKN 12(10), adaptive with a held step, "
                    "for q̈ = f(q, t)",
                    _rkn12_table(), driver="rkn", error_order=10),
    "rkn12-fixed": Method("rkn12-fixed", "rkn", 12, False, "rkn",
                          "the 12th-order RKN formula at a fixed step h", _rkn12_table(),
                          driver="rkn", error_order=10),
    "yoshida6": Method("yoshida6", "symplectic", 6, False, "rkn",
                       "Yoshida's symmetric 6th-order composition of velocity Verlet "
                       "(symplectic for constant M), fixed step h", _yoshida6_table(),
                       driver="symplectic"),
}
for _name in _SCIPY_METHODS:
    METHODS[f"scipy:{_name}"] = Method(f"scipy:{_name}", "scipy", 0, True, "",
                                       f"scipy.integrate.solve_ivp(method={_name!r})")


# -- events --------------------------------------------------------------------------------

_EVENT_KINDS = {"coordinate": 0, "velocity": 1, "multiplier": 2, "energy": 3}


@dataclass(frozen=True)
class Event:
    """An event g(t, y) = 0 located during integration.

    Parameters
    ----------
    kind : {"coordinate", "velocity", "multiplier", "energy"}
        g = q_j − value, q̇_j − value, λ_j − value or h − value.
    target : str or int
        Coordinate name (or index) for "coordinate"/"velocity"; multiplier index
        for "multiplier"; ignored for "energy".
    value : float
    direction : int
        +1 only upward crossings (g from − to +), −1 only downward, 0 both.
    terminal : bool
        Stop the integration at the first occurrence.
    name : str
        Label in ``Trajectory.events`` (default from kind and target).

    A root at the very first time is not reported (the run starts on it).
    """

    kind: str
    target: object = 0
    value: float = 0.0
    direction: int = 0
    terminal: bool = False
    name: str = ""

    def __post_init__(self):
        if self.kind not in _EVENT_KINDS:
            raise ValueError(f"Event kind must be one of {list(_EVENT_KINDS)}, got {self.kind!r}.")
        if self.direction not in (-1, 0, 1):
            raise ValueError(f"Event direction must be -1, 0 or +1, got {self.direction!r}.")
        if not math.isfinite(float(self.value)):
            raise ValueError(f"Event value must be finite, got {self.value!r}.")
        if not self.name:
            object.__setattr__(self, "name", f"{self.kind}:{self.target}={self.value:g}")


def turning_point(coordinate, *, direction=0, terminal=False) -> Event:
    """Event q̇_j = 0 (a turning point of coordinate ``coordinate``)."""
    return Event("velocity", coordinate, 0.0, direction, terminal, f"turning point of {coordinate}")


def crossing(coordinate, value=0.0, *, direction=0, terminal=False) -> Event:
    """Event q_j = value."""
    return Event("coordinate", coordinate, float(value), direction, terminal,
                 f"{coordinate} = {value:g}")


def multiplier_zero(index=0, *, direction=0, terminal=False) -> Event:
    """Event λ_index = 0 (a constraint force vanishes: a string goes slack, a bead leaves)."""
    return Event("multiplier", index, 0.0, direction, terminal, f"multiplier {index} = 0")


@dataclass(frozen=True)
class EventRecord:
    """One located event: its name, time (s) and state."""

    name: str
    t: float
    q: np.ndarray
    qdot: np.ndarray


# -- result --------------------------------------------------------------------------------

@dataclass(frozen=True, eq=False)
class Trajectory:
    """The result of :func:`simulate` (immutable).

    Attributes
    ----------
    t : ndarray (N,)
        Times (s).
    q, qdot : ndarray (N, n)
        Coordinates and velocities, one row per time, one column per coordinate.
    energy : ndarray (N,)
        The energy function h along the way (J).
    multipliers : ndarray (N, m) or None
        Lagrange multipliers λ (constrained systems); the generalized constraint
        force is Φ_qᵀ λ.
    constraint_residual : ndarray (N,) or None
        max(|Φ|, |Φ̇|) after projection (constrained systems).
    error_estimate : float
        See the module docstring ("Error estimate"); ``error_estimate_kind`` says
        which estimate it is.
    n_steps, n_rejected, n_rhs : int
        Accepted steps, rejected steps, right-hand-side evaluations (for the
        scipy methods: scipy's steps and ``nfev``; rejections are not reported).
    status : str
        "success", "event" (a terminal event stopped it), "max_steps",
        "interrupted".
    events : tuple of EventRecord
        Located events in time order.
    """

    coordinates: tuple
    t: np.ndarray
    q: np.ndarray
    qdot: np.ndarray
    energy: np.ndarray
    multipliers: np.ndarray | None
    constraint_residual: np.ndarray | None
    error_estimate: float
    error_estimate_kind: str
    n_steps: int
    n_rejected: int
    n_rhs: int
    status: str
    message: str
    events: tuple
    method: str
    rtol: float
    atol: float
    wall_time: float

    def __len__(self):
        return self.t.shape[0]

    @property
    def y(self) -> np.ndarray:
        """The first-order state [q, q̇] as an (N, 2n) array."""
        return np.hstack([self.q, self.qdot])

    def event_times(self, name: str | None = None) -> np.ndarray:
        """Times of the located events (of one name, or all)."""
        return np.array([e.t for e in self.events if name is None or e.name == name])

    def to_dataframe(self):
        """A pandas DataFrame indexed by t: coordinates, ``<name>_dot``, energy, λ, residual."""
        import pandas as pd
        data = {}
        for j, c in enumerate(self.coordinates):
            data[c] = self.q[:, j]
        for j, c in enumerate(self.coordinates):
            data[f"{c}_dot"] = self.qdot[:, j]
        data["energy"] = self.energy
        if self.multipliers is not None:
            for a in range(self.multipliers.shape[1]):
                data[f"lambda{a}"] = self.multipliers[:, a]
            data["constraint_residual"] = self.constraint_residual
        return pd.DataFrame(data, index=pd.Index(self.t, name="t"))


class SimulationInterrupted(KeyboardInterrupt):
    """Ctrl-C during :func:`simulate`; ``.trajectory`` holds the part computed."""

    def __init__(self, trajectory):
        super().__init__(f"integration interrupted at t = {trajectory.t[-1]:.6g} s; the part "
                         "computed is in the exception's .trajectory")
        self.trajectory = trajectory


# -- eligibility ------------------------------------------------------------------------

def rkn_eligibility(kernels) -> tuple[bool, str]:
    """Whether a system has the form q̈ = f(q, t) that RKN and symplectic methods need.

    ``kernels`` is a :class:`~lagrange_core.codegen.Kernels` (or anything with a
    ``kernels`` attribute, such as a System).  Returns (eligible, reason): the form is
    decided once per statement when its kernels are generated
    (:func:`lagrange_core.forms.rkn_form`) and read here from the kernel module.
    """
    kernels = getattr(kernels, "kernels", kernels)
    if kernels.rkn_form:
        return True, ""
    return False, f"for {kernels.label}, {kernels.rkn_reason}"


# -- checking the arguments ----------------------------------------------------------------

@dataclass(frozen=True)
class _Options:
    """The checked options of one :func:`simulate` call."""

    t0: float
    t1: float
    rtol: float
    atol: float
    t_eval: np.ndarray | None
    h: float | None
    stride: int
    max_steps: int | None
    max_points: int
    chunk_steps: int


def check_options(t_span, *, rtol=1e-9, atol=None, t_eval=None, events=(), max_steps=None,
                  h=None, stride=1, error_check=False, chunk_steps=20000,
                  max_points=1_000_000) -> _Options:
    """Check the options of :func:`simulate` (everything but the state and the kernels).

    :meth:`System.simulate` calls it before compiling anything, so a bad argument costs
    no compile time.  Raises ValueError naming the argument, the value and the fix.
    """
    try:
        t0, t1 = (float(v) for v in t_span)
    except (TypeError, ValueError):
        raise ValueError(f"t_span must be a pair (t0, t1) of numbers, got {t_span!r}.") from None
    if not (math.isfinite(t0) and math.isfinite(t1)):
        raise ValueError(f"t_span must be finite, got {t_span!r}.")
    if not t1 > t0:
        raise ValueError(f"t_span = {t_span!r}: the end time must be after the start time "
                         "(backward integration is not supported; substitute t → −t instead).")
    rtol = float(rtol)
    if not (rtol > 0 and math.isfinite(rtol)):
        raise ValueError(f"rtol must be a positive number, got {rtol!r}.")
    if rtol < 1e-15:
        raise ValueError(f"rtol = {rtol:g} is below what float64 can resolve; use rtol ≥ 1e-15.")
    atol = rtol if atol is None else float(atol)
    if not (atol > 0 and math.isfinite(atol)):
        raise ValueError(f"atol must be a positive number, got {atol!r}.")
    if t_eval is not None:
        t_eval = np.asarray(t_eval, dtype=float).reshape(-1)
        if t_eval.size == 0:
            raise ValueError("t_eval is empty: nothing would be stored. Pass None to store steps.")
        if not np.all(np.isfinite(t_eval)):
            raise ValueError("t_eval must be finite.")
        if np.any(np.diff(t_eval) < 0):
            raise ValueError("t_eval must be sorted in increasing order.")
        if t_eval[0] < t0 or t_eval[-1] > t1:
            raise ValueError(f"t_eval must lie within t_span = ({t0}, {t1}); got "
                             f"[{t_eval[0]}, {t_eval[-1]}].")
    if int(stride) != stride or stride < 1:
        raise ValueError(f"stride must be a positive whole number, got {stride!r}.")
    if max_steps is not None and (int(max_steps) != max_steps or max_steps < 1):
        raise ValueError(f"max_steps must be a positive whole number, got {max_steps!r}.")
    if h is not None:
        h = float(h)
        if not (h > 0 and math.isfinite(h)):
            raise ValueError(f"h must be a positive step size (s), got {h!r}.")
    if int(max_points) != max_points or max_points < 2:
        raise ValueError(f"max_points must be a whole number ≥ 2, got {max_points!r}.")
    if int(chunk_steps) != chunk_steps or chunk_steps < 1:
        raise ValueError(f"chunk_steps must be a positive whole number, got {chunk_steps!r}.")
    return _Options(t0, t1, rtol, atol, t_eval, h, int(stride),
                    None if max_steps is None else int(max_steps), int(max_points),
                    int(chunk_steps))


def _choose_method(kernels, method):
    if method is None:
        method = "rkn12" if kernels.rkn_form and "rkn12" in METHODS else "dop853"
    if isinstance(method, Method):
        method = method.name
    if method not in METHODS:
        raise ValueError(f"unknown method {method!r}; valid names: {sorted(METHODS)}.")
    meth = METHODS[method]
    if meth.requires == "rkn" and not kernels.rkn_form:
        raise ValueError(f"method {method!r} needs equations of the form q̈ = f(q, t), but "
                         f"{rkn_eligibility(kernels)[1]}. Use method='dop853' instead.")
    return meth


#: zero-size arrays for runs without events, output times or constraints (nothing writes
#: them; shared, so a short run does not allocate them again)
_NO_EV_INT = np.zeros((0, 4), dtype=np.int64)
_NO_EV_K = np.zeros(0, dtype=np.int64)
_NO_EV_Y = np.zeros((0, 2))
_NO_LAMBDA = np.zeros((0, 1))
_EMPTY = np.zeros(0)


def _event_arrays(kernels, events):
    events = tuple(events or ())
    if not events:
        return events, _NO_EV_INT, _EMPTY
    ev_int = np.zeros((len(events), 4), dtype=np.int64)
    ev_val = np.zeros(len(events))
    for k, ev in enumerate(events):
        if not isinstance(ev, Event):
            raise TypeError(f"events must be Event objects (see turning_point, crossing, "
                            f"multiplier_zero), got {ev!r}.")
        idx = ev.target
        if ev.kind in ("coordinate", "velocity"):
            if isinstance(idx, str):
                if idx not in kernels.coordinates:
                    raise ValueError(f"event {ev.name!r}: {idx!r} is not a coordinate of "
                                     f"{kernels.label} ({list(kernels.coordinates)}).")
                idx = kernels.coordinates.index(idx)
            elif not (0 <= int(idx) < kernels.n_dof):
                raise ValueError(f"event {ev.name!r}: coordinate index {idx} out of range.")
        elif ev.kind == "multiplier":
            if not (0 <= int(idx) < kernels.n_constraints):
                raise ValueError(f"event {ev.name!r}: {kernels.label} has "
                                 f"{kernels.n_constraints} multiplier(s); index {idx} is invalid.")
        else:
            idx = 0
        ev_int[k] = (_EVENT_KINDS[ev.kind], int(idx), ev.direction, int(ev.terminal))
        ev_val[k] = ev.value
    return events, ev_int, ev_val


# -- the compiled drivers, one entry per Method.driver --------------------------------------

@dataclass
class _Run:
    """Everything one compiled run keeps between chunks (the drivers' arrays)."""

    ka: np.ndarray          # the system's kernel addresses (lagrange_core._kernel_calls)
    m: int                  # constraints
    meth: Method
    opts: _Options
    y: np.ndarray           # [q, q̇] at tv[TV_T]
    f: np.ndarray           # dy/dt there (FSAL)
    p: np.ndarray
    tv: np.ndarray
    stats: np.ndarray
    t_eval: np.ndarray      # empty: store every stride-th step
    tout: np.ndarray
    yout: np.ndarray
    ev_int: np.ndarray
    ev_val: np.ndarray
    ev_g: np.ndarray
    ev_t: np.ndarray
    ev_k: np.ndarray
    ev_y: np.ndarray
    stride: int = 1
    block: np.ndarray = None   # the held step's block of error ratios (adaptive RKN)


def _chunk_dop853(run, budget):
    tab, o = run.meth.table, run.opts
    return _kern.dop853_chunk(run.ka, run.m, run.y, run.f, run.tv, run.stats, run.p, o.rtol,
                              o.atol, tab["A"], tab["B"], tab["C"], tab["E3"], tab["E5"],
                              tab["D"], run.meth.adaptive, budget, run.t_eval, run.stride,
                              run.tout, run.yout, run.ev_int, run.ev_val, run.ev_g, run.ev_t,
                              run.ev_k, run.ev_y)


def _chunk_fast_rkn(run, budget):
    tab, o = run.meth.table, run.opts
    return _kern.fast_rkn_chunk(run.ka, run.y, run.f, run.tv, run.stats, run.p, tab["c"],
                                tab["A"], tab["b"], tab["bp"], tab["bh"], tab["bph"],
                                run.meth.adaptive, o.rtol, o.atol, budget, run.t_eval,
                                run.stride, run.tout, run.yout, run.ev_int, run.ev_val, run.ev_g,
                                run.ev_t, run.ev_k, run.ev_y, run.block)


def _chunk_fast_symplectic(run, budget):
    return _kern.fast_symplectic_chunk(run.ka, run.y, run.f, run.tv, run.stats, run.p,
                                       run.meth.table["w"], budget, run.t_eval, run.stride,
                                       run.tout, run.yout, run.ev_int, run.ev_val, run.ev_g,
                                       run.ev_t, run.ev_k, run.ev_y)


@dataclass(frozen=True)
class _Driver:
    """How to run one family of methods: the kernels it calls, and one chunk."""

    kernels: tuple            # address-table slots it calls (rhs: the starting step)
    drive_kernel: bool        # stages on the drive kernel (lagrange_core.drive_kernel)
    chunk: object             # (run, budget) -> STATUS_*


_DRIVERS = {
    "dop853": _Driver(("rhs",), False, _chunk_dop853),
    "rkn": _Driver(("rhs",), True, _chunk_fast_rkn),
    "symplectic": _Driver(("rhs",), True, _chunk_fast_symplectic),
}


def _addresses(kernels, driver):
    """Compile (or load) the C entry points this run calls; the system's address table."""
    if kernels.n_constraints:                # projection; multipliers come with the rhs
        slots = ("energy", "rhs", "constraint_residual", "constraint_jacobian", *driver.kernels)
    else:                                    # energy: Trajectory.energy (along)
        slots = ("energy", *driver.kernels)
    if driver.drive_kernel:
        load_drive_kernel(kernels)
    return kernels.addresses(*slots)


# -- simulate ----------------------------------------------------------------------------

#: evaluated steps per block of the adaptive RKN's held step (_integrator_kernels.held_step_record)
_HOLD_BLOCK = 64
_NO_STEP_LIMIT = 2**63 - 1
#: steps of a DOP853 run's first chunk; the next are sized to take about _TARGET seconds
#: (at most chunk_steps): Ctrl-C, seen between chunks, waits about that long
_FIRST_CHUNK = 2000
_TARGET = 0.25

def simulate(kernels, q0, qdot0, t_span, p, *, method=None, rtol=1e-9, atol=None,
             t_eval=None, events=(), max_steps=None, h=None, stride=1, error_check=False,
             chunk_steps=20000, max_points=1_000_000, label=None,
             progress=False) -> Trajectory:
    """Integrate a system, given by its compiled ``kernels``, from (q0, q̇0) over ``t_span``.

    ``q0``, ``qdot0`` and ``p`` are float arrays (the coordinates and the parameter values
    in the kernels' order); :meth:`System.simulate` makes them from names and documents
    the options.  ``label`` names the system in messages (default ``kernels.label``).
    """
    o = check_options(t_span, rtol=rtol, atol=atol, t_eval=t_eval, max_steps=max_steps, h=h,
                      stride=stride, chunk_steps=chunk_steps, max_points=max_points)
    return simulate_checked(kernels, q0, qdot0, p, o, method=method, events=events,
                            error_check=error_check, label=label, progress=progress)


def simulate_checked(kernels, q0, qdot0, p, options, *, method=None, events=(),
                     error_check=False, label=None, progress=False) -> Trajectory:
    """:func:`simulate` with its options checked already (``options`` from
    :func:`check_options`): what :meth:`System.simulate` calls, so that one call checks
    them once.  ``progress`` as for :class:`lagrange_core.progress.ProgressLine` (shown
    for a run of more than one chunk that takes over half a second)."""
    start = time.perf_counter()
    o = options
    label = kernels.label if label is None else label
    q0 = np.asarray(q0, dtype=float)
    qd0 = np.asarray(qdot0, dtype=float)
    p = np.ascontiguousarray(p, dtype=float)
    meth = _choose_method(kernels, method)
    if not meth.adaptive and meth.family != "scipy" and o.h is None and meth.name != "rkn12-fixed":
        raise ValueError(f"method {meth.name!r} has a fixed step: pass h (s), e.g. "
                         f"h={(o.t1 - o.t0) / 1000:.3g}.")
    events, ev_int, ev_val = _event_arrays(kernels, events)
    if meth.family == "scipy":
        traj = _run_scipy(kernels, label, meth, q0, qd0, p, o, events, ev_int, ev_val, start)
    else:
        if o.h is None and meth.name == "rkn12-fixed":
            o = replace(o, h=_step_from_tolerance(kernels, label, q0, qd0, p, o))
        traj = _run_compiled(kernels, label, meth, q0, qd0, p, o, events, ev_int, ev_val,
                             start, progress=progress)
    if error_check and traj.status in ("success", "event"):
        try:
            ref = simulate(kernels, q0, qd0, (o.t0, traj.t[-1]), p, method=meth.name,
                           rtol=max(o.rtol / 1000, 1e-15), atol=o.atol / 1000, t_eval=traj.t,
                           h=None if o.h is None else o.h / 4, max_steps=None, label=label,
                           progress=progress)
        except SimulationInterrupted:   # the run itself is whole; its error check is not
            raise SimulationInterrupted(replace(
                traj, status="interrupted", message="interrupted (Ctrl-C) during the error "
                "check (a rerun at rtol/1000); the run itself is complete")) from None
        n = min(len(ref.t), len(traj.t))
        diff = max(np.max(np.abs(ref.q[:n] - traj.q[:n])),
                   np.max(np.abs(ref.qdot[:n] - traj.qdot[:n])))
        traj = replace(traj, error_estimate=float(diff),
                       error_estimate_kind="difference from a rerun at rtol/1000"
                       + (" and h/4" if o.h is not None else ""))
    return traj


def _step_from_tolerance(kernels, label, q0, qd0, p, o):
    """Fixed step for "rkn12-fixed" without ``h``: a pilot run of the adaptive RKN 12(10)
    over the first 1/50 of t_span at the same tolerances, run again over a window
    PILOT_WIDEN (8) times longer (at most t_span) while it has fewer than
    PILOT_MIN_SETTLED (8) steps beyond its starting ramp; h is the 20th percentile of
    those steps (:func:`lagrange_core._selection.pilot_step_quantile`; the last, clipped
    step excluded), rounded down so that a whole number of steps spans t_span.  The pilot
    costs about 1/50 of an adaptive run where the span holds many steps, and at most
    about two where it holds few; a widened pilot that fails (a blow-up) gives way to the
    last window that finished (the grids' pilots, :func:`lagrange_core._batch_kernels.
    pilot_step`, take the same steps).
    """
    span = o.t1 - o.t0
    tw = o.t0 + span / PILOT_SPAN_DIVISOR      # the window's end
    h_done = None                   # the step of the last window that finished
    while True:
        pilot = replace(o, t1=tw, t_eval=None, h=None, stride=1, max_steps=None)
        run = _run_compiled(kernels, label, METHODS["rkn12"], q0, qd0, p, pilot, (),
                            _NO_EV_INT, _EMPTY, time.perf_counter(), along=False, hold=False)
        steps = np.ascontiguousarray(np.diff(run.t)[:-1] if len(run.t) > 2
                                     else np.diff(run.t))
        h, settled = pilot_step_quantile(steps, len(steps))
        if run.status != "success":
            # a widened pilot that failed (a blow-up, an underflow): its shrinking steps
            # say nothing; the step of the last window that finished
            h = h_done if h_done is not None else h
            break
        if settled >= PILOT_MIN_SETTLED or not tw < o.t1:
            break
        h_done = h
        tw = min(o.t1, o.t0 + PILOT_WIDEN * (tw - o.t0))
    return span / math.ceil(span / h) if h > 0.0 else span


def _finish(kernels, ka, meth, o, p, T, Y, err, err_kind, counts, status, message, ev_list,
            start, along=True):
    """The Trajectory, with energy, multipliers and constraint residual along it
    (``along=False``: energy NaN, for internal pilot runs)."""
    n, m = kernels.n_dof, kernels.n_constraints
    N = T.shape[0]
    E = np.empty(N)
    # (the multipliers and the residual are written only for a constrained system)
    LAM = np.zeros((N, m)) if m else _NO_LAMBDA
    RES = np.zeros(N) if m else _EMPTY
    if along and status == "interrupted" and compiling():
        # a Ctrl-C left a kernel compiling (lagrange_core._first_calls), which holds numba's
        # compiler: a first call of the energy's kernel would wait for it
        along = False
        message += "; the energy not computed (numba was still compiling)"
    if along:
        _kern.along(ka, m, T, Y, p, E, LAM, RES)
    else:
        E.fill(np.nan)
    return Trajectory(
        coordinates=kernels.coordinates, t=T, q=Y[:, :n].copy(), qdot=Y[:, n:].copy(), energy=E,
        multipliers=LAM if m else None, constraint_residual=RES if m else None,
        error_estimate=float(err), error_estimate_kind=err_kind, n_steps=int(counts[0]),
        n_rejected=int(counts[1]), n_rhs=int(counts[2]), status=status, message=message,
        events=tuple(sorted(ev_list, key=lambda e: e.t)), method=meth.name, rtol=o.rtol,
        atol=o.atol, wall_time=time.perf_counter() - start)


def _singular_error(label, m, t, y):
    n = y.shape[0] // 2
    return ValueError(
        f"integration of {label} stopped at t = {t!r} s: the mass matrix"
        f"{' augmented by the constraint Jacobian' if m else ''} is singular "
        f"(q = {y[:n].tolist()}, q̇ = {y[n:].tolist()}). The coordinates are degenerate there "
        "(e.g. a pole of spherical coordinates) or the constraints became redundant; restate the "
        "system in coordinates that are regular along the motion.")


def _run_compiled(kernels, label, meth, q0, qd0, p, o, events, ev_int, ev_val, start,
                  along=True, hold=True, progress=False):
    """Run a compiled driver chunk by chunk; the Trajectory (``hold=False``: the adaptive
    RKN with its classic step-size controller throughout, for the pilot of rkn12-fixed)."""
    n, m = kernels.n_dof, kernels.n_constraints
    n2 = 2 * n
    driver = _DRIVERS[meth.driver]
    ka = _addresses(kernels, driver)
    t0 = o.t0
    y = np.empty(n2)
    y[:n] = q0
    y[n:] = qd0
    if m and _kern.project_start(ka, m, t0, y, p) != 0:
        raise _singular_error(label, m, t0, y)
    f = np.empty(n2)
    status = (_kern.fast_start(ka, y, f, t0, p) if driver.drive_kernel
              else _kern.derivative_start(ka, m, t0, y, p, f))
    if status != 0:
        raise _singular_error(label, m, t0, y)
    h0 = (_kern.initial_step(ka, m, t0, y, f, p, o.rtol, o.atol, 1.0 / (meth.error_order + 1))
          if meth.adaptive else o.h)
    tv = np.zeros(_kern.TV_SIZE)
    tv[_kern.TV_T] = t0
    tv[_kern.TV_END] = o.t1
    tv[_kern.TV_H] = h0
    stats = np.zeros(_kern.STATS_SIZE, dtype=np.int64)
    stats[_kern.ST_RHS] = 1 + (2 if meth.adaptive else 0)
    if o.t_eval is not None:
        t_eval = o.t_eval
        cap = t_eval.shape[0]
        k0 = int(np.searchsorted(t_eval, t0, side="right"))
    else:                     # every stride-th step, from the initial state on
        t_eval = _EMPTY
        cap = 4096
        k0 = 1
    tout = np.empty(cap)
    yout = np.empty((cap, n2))
    tout[:k0] = t0 if o.t_eval is None else t_eval[:k0]
    yout[:k0] = y
    stats[_kern.ST_STORED] = k0
    stats[_kern.ST_NEXT_EVAL] = k0 if o.t_eval is not None else 0
    if events:
        ev_g = np.array([_event_value_py(kernels, ev_int[k], ev_val[k], t0, y, p)
                         for k in range(len(events))], dtype=float)
        ev_cap = max(64, 4 * len(events))
        ev_t, ev_k, ev_y = (np.empty(ev_cap), np.empty(ev_cap, dtype=np.int64),
                            np.empty((ev_cap, n2)))
    else:
        ev_g, ev_t, ev_k, ev_y = _EMPTY, _EMPTY, _NO_EV_K, _NO_EV_Y
    run = _Run(ka, m, meth, o, y, f, p, tv, stats, t_eval, tout, yout, ev_int, ev_val, ev_g,
               ev_t, ev_k, ev_y, o.stride,
               np.empty(_HOLD_BLOCK) if meth.adaptive and hold else _EMPTY)
    ev_list = []
    total_limit = o.max_steps if o.max_steps is not None else _NO_STEP_LIMIT
    status_name, message = "success", "reached the end of t_span"
    # without t_eval: the rows stored so far, as (t, y) pairs.  A Ctrl-C is a
    # KeyboardInterrupt at any bytecode (in the first chunk nothing defers it), so each
    # piece is kept by one list operation — a pair, never t without its y (CI saw 1426
    # times against 1421 rows when t and y were two lists) — and the handler's drain
    # skips what a drain it interrupted had kept already (rows and events not past the
    # last kept time), never twice
    sign = 1.0 if o.t1 >= o.t0 else -1.0
    pieces = []
    stored = 0

    def drain():
        nonlocal stored
        k = int(stats[_kern.ST_EVENTS])
        last = ev_list[-1].t if ev_list else -math.inf * sign
        ev_list.extend([EventRecord(events[ev_k[i]].name, float(ev_t[i]),
                                    ev_y[i, :n].copy(), ev_y[i, n:].copy())
                        for i in range(k) if (ev_t[i] - last) * sign > 0])
        stats[_kern.ST_EVENTS] = 0
        if o.t_eval is None:
            k = int(stats[_kern.ST_STORED])
            first = 0
            if k and pieces and pieces[-1][0].size:
                ahead = (tout[:k] - pieces[-1][0][-1]) * sign
                first = int(np.argmax(ahead > 0)) if np.any(ahead > 0) else k
            if k > first:
                pieces.append((tout[first:k].copy(), yout[first:k].copy()))
                stored += k - first
            stats[_kern.ST_STORED] = 0
            if stored > o.max_points:
                # memory bound: keep every other stored row (and the last), store half as often
                T_, Y_ = _joined(pieces, tout, yout)
                keep = np.r_[np.arange(0, len(T_) - 1, 2), len(T_) - 1]
                pieces[:] = [(T_[keep], Y_[keep])]
                stored = len(keep)
                run.stride *= 2

    interrupted = False
    bar = None
    stack = contextlib.ExitStack()
    # DOP853 goes on exactly across chunks (its whole state is in y, f, tv), so its chunks
    # are sized by their time; the RKN and symplectic drivers restart their compensated
    # sums and their drive's cos/sin at a chunk's start (a rounding), so theirs stay
    # chunk_steps long wherever the machine is fast or slow: the same numbers every run
    size = min(o.chunk_steps, _FIRST_CHUNK) if meth.driver == "dop853" else o.chunk_steps
    span = o.t1 - o.t0
    try:
        with stack:
            while True:
                if interrupt_requested():
                    raise KeyboardInterrupt
                budget = int(min(size, total_limit - stats[_kern.ST_STEPS]))
                if o.t_eval is None and budget > 0:   # a chunk stores ≤ budget/stride rows
                    budget = min(budget, run.stride * max(o.max_points // 4, 1))
                if budget <= 0:
                    status_name = "max_steps"
                    message = (f"stopped after max_steps = {o.max_steps} steps at "
                               f"t = {tv[_kern.TV_T]:.6g} s")
                    break
                started = time.perf_counter()
                code = driver.chunk(run, budget)
                if meth.driver == "dop853":
                    took = max(time.perf_counter() - started, 1e-6)
                    size = int(min(o.chunk_steps, 8 * size, max(64.0, size * _TARGET / took)))
                drain()
                if code == _kern.STATUS_DONE:
                    if bar is not None:
                        bar.update(1.0)
                    break
                if code == _kern.STATUS_EVENT:
                    status_name = "event"
                    message = f"terminal event at t = {tv[_kern.TV_T]:.17g} s"
                    break
                if code == _kern.STATUS_SINGULAR:
                    raise _singular_error(label, m, float(tv[_kern.TV_T]), y)
                if code == _kern.STATUS_UNDERFLOW:
                    raise FloatingPointError(
                        f"integration of {label} failed at t = {float(tv[_kern.TV_T])!r} s: "
                        "the step size fell below the resolution of t (state q = "
                        f"{y[:n].tolist()}, q̇ = {y[n:].tolist()}). The solution may blow "
                        "up or become non-finite there; check parameters and initial "
                        "conditions.")
                if bar is None:         # more than one chunk: Ctrl-C waits for the chunk's
                    stack.enter_context(defer_ctrl_c())      # end, and a progress line
                    bar = ProgressLine(progress, 1, "simulate", "of t_span", fraction=True)
                bar.update(min(max((tv[_kern.TV_T] - o.t0) / span, 0.0), 1.0))
    except KeyboardInterrupt:
        drain()
        interrupted = True
        status_name = "interrupted"
        message = (f"interrupted (Ctrl-C) at t = {tv[_kern.TV_T]:.6g} s, "
                   f"{100 * (tv[_kern.TV_T] - o.t0) / span:.3g} % of t_span")
    finally:
        if bar is not None:
            bar.close()
    if o.t_eval is not None:
        k = int(stats[_kern.ST_STORED])
        T, Y = tout[:k], yout[:k]
    else:
        T, Y = _joined(pieces, tout, yout)
    err = tv[_kern.TV_ERROR] if meth.family != "symplectic" else math.nan
    kind = "sum of local error estimates" if math.isfinite(err) else "none"
    counts = (stats[_kern.ST_STEPS], stats[_kern.ST_REJECTED], stats[_kern.ST_RHS])
    traj = _finish(kernels, ka, meth, o, p, T, Y, err, kind, counts, status_name, message,
                   ev_list, start, along)
    if interrupted:
        raise SimulationInterrupted(traj)
    return traj


def _joined(pieces, tout, yout):
    """The (t, y) pairs a run kept, as two arrays (none kept — a Ctrl-C before the first
    chunk ended: empty ones shaped like the output buffers)."""
    if len(pieces) == 1:
        return pieces[0]
    if not pieces:
        return tout[:0], yout[:0]
    return (np.concatenate([t_ for t_, _ in pieces]),
            np.concatenate([y_ for _, y_ in pieces]))


def _event_value_py(kernels, row, val, t, y, p):
    n = kernels.n_dof
    kind, idx = int(row[0]), int(row[1])
    if kind == _kern.EV_COORDINATE:
        return y[idx] - val
    if kind == _kern.EV_VELOCITY:
        return y[n + idx] - val
    if kind == _kern.EV_MULTIPLIER:
        return kernels.accelerations_at(y[:n], y[n:], t, p)[1][idx] - val
    return kernels.energy(y[:n], y[n:], t, p) - val


# -- scipy ------------------------------------------------------------------------------

def _run_scipy(kernels, label, meth, q0, qd0, p, o, events, ev_int, ev_val, start):
    from scipy.integrate import solve_ivp
    k = kernels
    n, m = kernels.n_dof, kernels.n_constraints
    t0, t1, t_eval = o.t0, o.t1, o.t_eval
    W = k.work_array()
    name = meth.name.split(":", 1)[1]

    def fun(t, y):
        out = np.empty(2 * n)
        if k.rhs(t, y, p, out, W) != 0:
            raise _singular_error(label, m, t, y)
        return out

    def jac(t, y):
        J = np.empty((2 * n, 2 * n))
        k.jacobian(t, y, p, J)
        return J

    ev_funcs = []
    for e in range(len(events)):
        def g(t, y, _e=e):
            return _event_value_py(kernels, ev_int[_e], ev_val[_e], t, y, p)
        g.terminal = bool(ev_int[e, 3])
        g.direction = float(ev_int[e, 2])
        ev_funcs.append(g)
    kw = {"jac": jac} if name in _IMPLICIT else {}
    y0 = np.concatenate([q0, qd0])
    sol = solve_ivp(fun, (t0, t1), y0, method=name, rtol=o.rtol, atol=o.atol,
                    dense_output=t_eval is not None, events=ev_funcs or None, **kw)
    if not sol.success and sol.status != 1:
        raise FloatingPointError(f"scipy {name} failed on {label}: {sol.message}")
    n_steps = max(len(sol.t) - 1, 0)
    T, Y = sol.t, sol.y.T
    if t_eval is not None:     # scipy's own t_eval also evaluates the dense output
        T = t_eval[t_eval <= sol.t[-1]]
        Y = sol.sol(T).T if len(T) else np.empty((0, 2 * n))
    elif o.stride > 1:
        keep = np.r_[np.arange(0, len(T) - 1, o.stride), len(T) - 1]
        T, Y = T[keep], Y[keep]
    ev_list = []
    for e in range(len(events)):
        for te, ye in zip(sol.t_events[e], sol.y_events[e], strict=True):
            if te > t0:
                ev_list.append(EventRecord(events[e].name, float(te), ye[:n].copy(), ye[n:].copy()))
    counts = (n_steps, 0, sol.nfev)
    status = "event" if sol.status == 1 else "success"
    slots = ("energy", "rhs", "constraint_residual") if m else ("energy",)
    return _finish(kernels, kernels.addresses(*slots), meth, o, p, T, Y, float("nan"),
                   "none (scipy)", counts, status, sol.message, ev_list, start)
