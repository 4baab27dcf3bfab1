"""Work–precision: what accuracy costs in time, for one system, start and span.

:func:`work_precision` runs each integrator at each tolerance from one initial state over
one time span and records

* the *error* at the final time, ``max_i |q_i(t1) − q_i,ref(t1)|`` (in the units of the
  coordinates: rad for angles), against a reference final state;
* the *wall time*, the best of ``repeat`` runs after a warm-up run (so compiling, loading
  kernels and first-call set-up are excluded: this is the cost of the integration itself,
  as a sweep or a long study pays it);
* the accepted steps and the right-hand-side evaluations.

The reference
-------------
By default it is our most accurate method for the system at ``rtol = atol = 1e-14``
(``"rkn12"`` for equations of the form q̈ = f(q, t), else ``"dop853"``), *cross-checked*
by a second, independent method (``"dop853"`` at the same tolerance, or, when the first is
``"dop853"``, the fixed-step 8th-order ``"rk8"`` at half the adaptive run's mean step).
The difference of the two final states (at least 4 ulps of the coordinates) is
:attr:`WorkPrecision.reference_error`, the reference's own error as far as it can be
known: an error below about ten times it is not resolved (column ``resolved``), and
:meth:`WorkPrecision.time_to_reach` refuses such levels (NaN).  ``reference="heyoka"``
takes heyoka's Taylor integrator in extended precision (``long double``, tol 1e-18) and
cross-checks it against our own reference; an array gives the final coordinates directly
(a closed form), with reference error 0.

Peers
-----
``"scipy:<name>"`` is :func:`scipy.integrate.solve_ivp` on the *same compiled right-hand
side* (``method="scipy:DOP853"`` of :meth:`System.simulate`): the comparison is the
integrator, not the cost of evaluating the equations.  ``"heyoka"`` is heyoka's adaptive
Taylor integrator (``taylor_adaptive``, double precision, its ``tol`` set to the tolerance),
built from the system's derived equations q̈ = M⁻¹F by a symbolic translation
(:func:`heyoka_equations`; unconstrained systems, parameters fixed at their values); its
construction (LLVM compile) is excluded from the time, and it counts Taylor steps, not
right-hand-side evaluations (NaN).  A peer that is not installed, or does not apply to the
system, is skipped and named in :attr:`WorkPrecision.skipped` with the reason.  A method or
peer stops tightening its tolerance once one run takes longer than ``max_seconds``.

Accuracy of the times: the machine's load moves single timings by tens of percent; the
best of several runs is the least disturbed measurement, and ratios between methods timed
in the same process are steadier than absolute times (benchmarks/README.md).
"""
from __future__ import annotations

import math
import sys
import time
from dataclasses import dataclass

import numpy as np

__all__ = ["WorkPrecision", "work_precision", "best_time", "heyoka_equations",
           "DEFAULT_RTOLS"]

#: The tolerances of a default run: 1e-3 … 1e-12, one per decade.
DEFAULT_RTOLS = tuple(10.0 ** -k for k in range(3, 13))

#: An error at most this many times the reference's own error is not resolved.
RESOLVED_FACTOR = 10.0

_REFERENCE_RTOL = 1e-14


@dataclass(frozen=True)
class WorkPrecision:
    """Error at the final time against wall time, per method and tolerance (immutable).

    Attributes
    ----------
    system : str
        The system's label.
    t_span : (float, float)
        Start and end time (s).
    method, kind : ndarray of str, (N,)
        Per run: the method's name (a name of ``lagrange_core.integrate.METHODS``, or
        ``"heyoka"``) and ``"ours"`` or ``"peer"``.
    rtol : ndarray (N,)
        The tolerance of the run (rtol = atol).
    error : ndarray (N,)
        max_i |q_i(t1) − q_i,ref(t1)| (units of the coordinates).
    seconds : ndarray (N,)
        Best wall time of the timed runs (s), compile and first-call set-up excluded.
    steps : ndarray (N,) of int
        Accepted steps.
    evaluations : ndarray (N,)
        Right-hand-side evaluations (NaN where a method does not count them: heyoka).
    resolved : ndarray (N,) of bool
        ``error > RESOLVED_FACTOR * reference_error``: the error is measured, not the
        reference's.
    default_method : str
        What ``System.simulate(method=None)`` uses for this system.
    reference : str
        How the reference was computed.
    reference_error : float
        The reference's own error: the difference from its cross-check (0 for a
        reference given by the caller).
    reference_q : ndarray (n,)
        The reference final coordinates q_ref(t1).
    skipped : tuple of (str, str)
        (method, reason) for every method or peer that did not run.
    interrupted : bool
        True if Ctrl-C stopped the measurement (what finished is kept).
    """

    system: str
    t_span: tuple
    method: np.ndarray
    kind: np.ndarray
    rtol: np.ndarray
    error: np.ndarray
    seconds: np.ndarray
    steps: np.ndarray
    evaluations: np.ndarray
    resolved: np.ndarray
    default_method: str
    reference: str
    reference_error: float
    reference_q: np.ndarray
    skipped: tuple = ()
    interrupted: bool = False

    def __len__(self):
        return len(self.method)

    @property
    def methods(self) -> tuple:
        """The methods that ran, in order (ours first, then the peers)."""
        return tuple(dict.fromkeys(self.method.tolist()))

    def to_dataframe(self):
        """One row per run: method, kind, rtol, error, seconds, steps, evaluations,
        resolved, default (whether the method is the system's default)."""
        import pandas as pd
        return pd.DataFrame(dict(
            method=self.method, kind=self.kind, rtol=self.rtol, error=self.error,
            seconds=self.seconds, steps=self.steps, evaluations=self.evaluations,
            resolved=self.resolved, default=self.method == self.default_method))

    def time_to_reach(self, error: float) -> dict:
        """Seconds each method needs to reach a final-time error ≤ ``error``: its fastest
        run at or below that level (NaN if none did).

        A level below ``RESOLVED_FACTOR`` times :attr:`reference_error` cannot be judged
        against this reference: every method then gets NaN.
        """
        level = float(error)
        if not (level > 0 and math.isfinite(level)):
            raise ValueError(f"error must be a positive number (the level to reach, in the "
                             f"units of the coordinates), got {error!r}.")
        out = {}
        for name in self.methods:
            ok = (self.method == name) & (self.error <= level) & self.resolved
            out[name] = float(self.seconds[ok].min()) if ok.any() and \
                level > RESOLVED_FACTOR * self.reference_error else math.nan
        return out


def best_time(fn, repeat=3, clock=time.perf_counter):
    """(best seconds, last result) of ``repeat`` calls of ``fn()``, and of more (up to
    5 × repeat) while they total under 0.2 s.  The machine is shared: the minimum is the
    least disturbed measurement.  ``clock``: the wall clock, or ``time.process_time``
    (this process's CPU time; disturbed less by other jobs, right for single-threaded runs).
    """
    best, out, total, k = math.inf, None, 0.0, 0
    while k < repeat or (total < 0.2 and k < 5 * repeat):
        t0 = clock()
        out = fn()
        dt = clock() - t0
        best, total, k = min(best, dt), total + dt, k + 1
    return best, out


# -- heyoka ------------------------------------------------------------------------------

def heyoka_equations(system, params):
    """The system's equations as heyoka expressions: ([(q_i, v_i), ...], [(v_i, q̈_i), ...])
    ready for ``heyoka.taylor_adaptive``, with the parameters substituted.

    q̈ = M⁻¹ F is solved symbolically (sympy), so this is for small unconstrained systems
    (the symbolic solve grows fast with the number of coordinates).

    Raises
    ------
    ImportError
        heyoka is not installed.
    ValueError
        The system has constraints, or uses a function heyoka does not know.
    """
    import heyoka as hy
    import sympy as sp
    if system.n_constraints:
        raise ValueError(f"{system._label()} has constraints; heyoka_equations translates "
                         "unconstrained systems only.")
    eq = system.equations
    values = {s: float(params[s.name]) for s in system.parameter_symbols}
    M = eq.mass_matrix.xreplace(values)
    F = eq.forcing.xreplace(values)
    qdd = [F[0] / M[0, 0]] if M.shape == (1, 1) else list(M.LUsolve(F))
    from .symbols import t as t_symbol
    names = [*(s.name for s in system.q), *(s.name for s in system.qdot)]
    hv = hy.make_vars(*names)
    hv = hv if isinstance(hv, (list, tuple)) else [hv]
    n = system.n_dof
    funcs = {"sin": hy.sin, "cos": hy.cos, "tan": hy.tan, "exp": hy.exp, "log": hy.log,
             "sqrt": hy.sqrt, "tanh": hy.tanh, "atan": hy.atan, "asin": hy.asin,
             "acos": hy.acos, "sinh": hy.sinh, "cosh": hy.cosh}
    args = [*system.q, *system.qdot, t_symbol]
    exprs = []
    for k, e in enumerate(qdd):
        f = sp.lambdify(args, e, modules=[funcs])
        try:
            exprs.append(f(*hv, hy.time) + 0.0 * hv[n + k])
        except Exception as exc:      # a function heyoka has no translation for
            raise ValueError(f"heyoka_equations cannot translate q̈_{k} = {e}: {exc}") from exc
    return [(hv[i], hv[n + i]) for i in range(n)] + [(hv[n + i], exprs[i]) for i in range(n)]


def _heyoka_runner(system, q0, qdot0, t_span, params, tol, long_double=False):
    """A callable that integrates with heyoka from the start and returns (q(t1), steps)."""
    import heyoka as hy
    sys_eqs = heyoka_equations(system, params)
    n = system.n_dof
    t0, t1 = t_span
    if long_double:
        ld = np.longdouble
        state = np.array([*q0, *qdot0], dtype=ld)
        ta = hy.taylor_adaptive(sys_eqs, state, tol=ld(tol), time=ld(t0), fp_type=ld)
    else:
        state = np.array([*q0, *qdot0], dtype=float)
        ta = hy.taylor_adaptive(sys_eqs, state, tol=tol, time=t0)

    def run():
        ta.time = np.longdouble(t0) if long_double else t0
        ta.state[:] = state
        res = ta.propagate_until(np.longdouble(t1) if long_double else t1)
        if str(res[0]) != "taylor_outcome.time_limit":
            raise RuntimeError(f"heyoka stopped early: {res[0]}")
        return ta.state[:n].copy(), int(res[3])
    return run


def _have_heyoka():
    try:
        import heyoka  # noqa: F401
        return True
    except ImportError:
        return False


# -- the measurement ------------------------------------------------------------------

def _final(traj):
    if traj.status != "success":
        raise RuntimeError(f"the run stopped with status {traj.status!r}: {traj.message}")
    return traj.q[-1].copy()


def _difference(a, b):
    """max |a − b|, but never below 4 ulps of the coordinates: two float64 runs that agree
    to the last bit still carry the rounding of their last step."""
    return max(float(np.max(np.abs(a - b))),
               4 * np.finfo(float).eps * max(1.0, float(np.max(np.abs(a)))))


def _own_reference(system, q0, qdot0, t_span, params, default):
    """(final q, cross-check's final q, description) with two of our methods."""
    kw = dict(rtol=_REFERENCE_RTOL, atol=_REFERENCE_RTOL, stride=10**9)
    first = system.simulate(q0, qdot0, t_span, params, method=default, **kw)
    if default != "dop853":
        second_name = "dop853"
        second = system.simulate(q0, qdot0, t_span, params, method="dop853", **kw)
        what = f"{default} at rtol = atol = 1e-14, cross-checked by dop853 at 1e-14"
    else:
        span = t_span[1] - t_span[0]
        h = span / math.ceil(2 * max(first.n_steps, 1))
        second_name = "rk8"
        second = system.simulate(q0, qdot0, t_span, params, method=second_name, h=h,
                                 stride=10**9)
        what = (f"dop853 at rtol = atol = 1e-14, cross-checked by rk8 at h = {h:.3g} s "
                f"(half its mean step)")
    return _final(first), _final(second), what


def _check_inputs(system, methods, peers, rtols, repeat, max_seconds, t_span):
    from .integrate import METHODS
    try:
        t0, t1 = (float(x) for x in t_span)
    except (TypeError, ValueError):
        t0 = t1 = math.nan
    if not (math.isfinite(t0) and math.isfinite(t1) and t1 > t0):
        raise ValueError(f"t_span must be (t0, t1) with t1 > t0 (s), got {t_span!r}.")
    rtols = tuple(sorted((float(r) for r in rtols), reverse=True))
    if not rtols:
        raise ValueError("rtols is empty: give at least one tolerance, e.g. (1e-6, 1e-9).")
    for r in rtols:
        if not (1e-15 <= r < 1 and math.isfinite(r)):
            raise ValueError(f"rtols must lie in [1e-15, 1), got {r!r}; float64 cannot "
                             "resolve tighter tolerances.")
    for name in (*methods, *peers):
        if name == "heyoka":
            continue
        if name not in METHODS:
            raise ValueError(f"unknown method {name!r} in methods/peers; valid names: "
                             f"{sorted(METHODS)} and 'heyoka'.")
        m = METHODS[name]
        if not m.adaptive and m.family != "scipy" and name != "rkn12-fixed":
            raise ValueError(f"method {name!r} has a fixed step and no tolerance; a "
                             "work–precision run needs methods that take rtol (e.g. 'rkn12', "
                             "'rkn12-fixed', 'dop853').")
    if not (isinstance(repeat, int) and repeat >= 1):
        raise ValueError(f"repeat must be an integer ≥ 1, got {repeat!r}.")
    if not (max_seconds is None or (isinstance(max_seconds, (int, float)) and max_seconds > 0)):
        raise ValueError(f"max_seconds must be a positive number of seconds or None, got "
                         f"{max_seconds!r}.")
    return rtols


def work_precision(system, q0, qdot0, t_span, params, *, methods=("rkn12", "dop853"),
                   rtols=DEFAULT_RTOLS, reference=None, repeat=3,
                   peers=("scipy:DOP853",), max_seconds=2.0, rounds=1, cpu_time=False,
                   progress=None) -> WorkPrecision:
    """Error at the final time against time, for each method and tolerance.

    Parameters
    ----------
    system : System
    q0, qdot0 : sequence of float
        The initial state (order of ``system.coordinates``).
    t_span : (t0, t1)
        The span (s).  Short spans measure the fixed cost of a call as much as the steps.
    params : dict
        Parameter values by name.
    methods : sequence of str
        Our methods (names of ``lagrange_core.integrate.METHODS`` that take a tolerance).
        One that does not apply to the system (an RKN method for velocity-dependent
        forces) is skipped with the reason.
    rtols : sequence of float
        Tolerances (rtol = atol), each in [1e-15, 1); run loosest first.
    reference : None, "heyoka" or array
        The reference final coordinates: see the module docstring.
    repeat : int
        Timed runs per configuration after the warm-up (best kept).
    peers : sequence of str
        ``"scipy:<name>"`` and/or ``"heyoka"``; those not installed or not applicable are
        skipped (:attr:`WorkPrecision.skipped`).
    max_seconds : float or None
        A method stops tightening its tolerance once a run takes longer (s).
    rounds : int
        Time every configuration this many times, one configuration after the other,
        keeping the best (a busy spell of a shared machine then costs one configuration
        one round); the errors come from the first round.
    cpu_time : bool
        Time with this process's CPU time instead of the wall clock.
    progress : None, bool or callable
        A progress line on stderr (:class:`lagrange_core.progress.ProgressLine`).

    Returns
    -------
    WorkPrecision

    Raises
    ------
    ValueError
        Bad input (named), or a reference that disagrees with its cross-check by more
        than the loosest tolerance (it could not judge any run).
    """
    from .integrate import METHODS, rkn_eligibility
    from .progress import ProgressLine
    methods, peers = tuple(methods), tuple(peers)
    rtols = _check_inputs(system, methods, peers, rtols, repeat, max_seconds, t_span)
    if not (isinstance(rounds, int) and rounds >= 1):
        raise ValueError(f"rounds must be an integer ≥ 1, got {rounds!r}.")
    # the start and the parameters are checked here, once (the messages name the argument)
    q0 = system.coordinate_array(q0, "q0").tolist()
    qdot0 = system.coordinate_array(qdot0, "qdot0").tolist()
    params = dict(zip(system.parameters, system.parameter_array(params).tolist(), strict=True))
    t_span = (float(t_span[0]), float(t_span[1]))
    clock = time.process_time if cpu_time else time.perf_counter
    eligible, why = rkn_eligibility(system.kernels)
    default = "rkn12" if eligible and "rkn12" in METHODS else "dop853"

    # the reference
    if reference is None or isinstance(reference, str):
        own, cross, what = _own_reference(system, q0, qdot0, t_span, params, default)
    if reference is None:
        ref, ref_error = own, _difference(own, cross)
    elif isinstance(reference, str):
        if reference != "heyoka":
            raise ValueError(f"reference must be None, 'heyoka' or the final coordinates, "
                             f"got {reference!r}.")
        if not _have_heyoka():
            raise ValueError("reference='heyoka' but heyoka is not installed "
                             "(pip install heyoka); use reference=None (our own).")
        ref = _heyoka_runner(system, q0, qdot0, t_span, params, 1e-18, long_double=True)()[0]
        ref = ref.astype(float)
        ref_error = _difference(ref, own)
        what = (f"heyoka long double at tol 1e-18, cross-checked by {default} at rtol = "
                "atol = 1e-14")
    else:
        ref = np.asarray(reference, dtype=float).reshape(-1)
        if ref.shape != (system.n_dof,) or not np.all(np.isfinite(ref)):
            raise ValueError(f"reference must be None, 'heyoka' or the {system.n_dof} final "
                             f"coordinates q(t1) (finite), got {reference!r}.")
        ref_error, what = 0.0, "given by the caller"
    if ref_error > rtols[0]:
        raise ValueError(f"the reference and its cross-check disagree by {ref_error:.2e}, "
                         f"more than the loosest tolerance {rtols[0]:g}: no run could be "
                         f"judged ({what}). Shorten t_span (chaotic or unstable motion?).")

    # the configurations: (name, kind, rtol, run() -> (q(t1), steps, evaluations))
    skipped, plan = [], []
    for name in methods:
        if METHODS[name].requires == "rkn" and not eligible:
            skipped.append((name, why))
            continue
        plan.append((name, "ours"))
    for name in peers:
        if name == "heyoka":
            if not _have_heyoka():
                skipped.append((name, "heyoka is not installed (pip install heyoka)"))
                continue
            try:
                heyoka_equations(system, params)
            except ValueError as exc:
                skipped.append((name, str(exc)))
                continue
        plan.append((name, "peer"))

    def runner(name, rtol):
        if name == "heyoka":
            run = _heyoka_runner(system, q0, qdot0, t_span, params, rtol)
            return lambda: (*run(), math.nan)

        def run():
            tr = system.simulate(q0, qdot0, t_span, params, method=name, rtol=rtol, atol=rtol,
                                 stride=10**9)
            return _final(tr), tr.n_steps, float(tr.n_rhs)
        return run

    rows, runners, interrupted = [], [], False
    line = ProgressLine(progress, len(plan) * len(rtols), "work–precision", "runs")
    done = 0
    try:
        for name, kind in plan:
            for rtol in rtols:
                run = runner(name, rtol)
                run()                                   # warm-up: compile, load, first call
                sec, (qf, steps, nev) = best_time(run, repeat, clock)
                rows.append([name, kind, rtol, float(np.max(np.abs(qf - ref))), sec, steps,
                             nev])
                runners.append(run)
                done += 1
                line.update(done)
                if max_seconds is not None and sec > max_seconds:
                    done += len(rtols) - 1 - rtols.index(rtol)
                    break
        for _ in range(rounds - 1):
            for row, run in zip(rows, runners, strict=True):
                row[4] = min(row[4], best_time(run, repeat, clock)[0])
    except KeyboardInterrupt:
        interrupted = True
        print(f"work_precision: interrupted; keeping the {len(rows)} finished runs",
              file=sys.stderr)
    line.close()
    cols = list(zip(*rows, strict=True)) if rows else [()] * 7
    error = np.array(cols[3], dtype=float)
    return WorkPrecision(
        system=system._label(), t_span=t_span,
        method=np.array(cols[0], dtype=object), kind=np.array(cols[1], dtype=object),
        rtol=np.array(cols[2], dtype=float), error=error,
        seconds=np.array(cols[4], dtype=float), steps=np.array(cols[5], dtype=np.int64),
        evaluations=np.array(cols[6], dtype=float),
        resolved=error > RESOLVED_FACTOR * ref_error, default_method=default,
        reference=what, reference_error=ref_error, reference_q=np.asarray(ref, dtype=float),
        skipped=tuple(skipped),
        interrupted=interrupted)
