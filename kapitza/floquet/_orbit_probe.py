"""The monodromies of a periodic orbit at any (amplitude, ω) points — the orbit followed
over the grid by :class:`kapitza.floquet._orbits.Follower` — as the same
``evaluate(A, omega, analyse)`` that :class:`kapitza.floquet._probe._Probe` gives about an
equilibrium; so :func:`kapitza.floquet.window`, :func:`kapitza.floquet.boundaries` and
:func:`kapitza.floquet.adaptive_map` run unchanged about orbits; and the orbit's
:func:`stability_map`.

The monodromy of a shot orbit (:class:`kapitza.floquet._shooting.Shot`) is given in the
balanced variables (q, dq/d(ωt)) as the Taylor monodromies are.  Its error estimate
``err`` is the shot's monodromy error (the flow's step-doubling difference, which runs
~2⁸ above the finer flow's actual error as the Taylor estimate runs 100–1000× above its
own, plus the state's error carried through M), × max(1, ω, 1/ω) for the balancing; the
margins' entries' error ``delta`` is measured as :class:`kapitza.floquet._probe._Probe`
measures it, against a second shooting from the orbit at 100× the tolerance.
Liouville: ∮ tr J dt = 0 exactly for a closed orbit of a system without dissipation or
generalised forces (det M = 1 is then a check of the integration); otherwise it is taken
as log |det M| (the guard is then no check) and the orbit counts as damped unless that
is below 1e-12 T.

A point the followed orbit does not reach (its branch ends at a fold or a branch point
first, or Newton finds no orbit from the guess) has no monodromy: NaN, unstable, flagged
"no periodic orbit", and on the stability map the label 4, "no orbit" (undecided, drawn
apart); an orbit whose shooting equations are so ill-conditioned that its
state is known only to more than √tol is flagged "ill-conditioned" and counts as
uncertified.
"""
from __future__ import annotations

import math
import time

import numpy as np
import sympy as sp

from lagrange_core.progress import _SIGINT, run_in_chunks
from lagrange_core.progress import defer_ctrl_c as _defer_ctrl_c

from ..results import ComputationInterrupted, StabilityMap
from ._multipliers import _analyse
from ._orbits import Follower
from ._shooting import Shot

__all__ = ["OrbitProbe", "orbit_map", "conservative"]

#: The map label of a point the orbit followed does not reach (``"no orbit"``: index 4 of
#: :data:`kapitza.results._maps.MAP_LABELS`)
NO_ORBIT = 4


def conservative(system, fixed) -> bool:
    """Whether the system, with the ``fixed`` parameters, has neither a dissipation function
    nor generalised forces (its flow is then symplectic: det M = 1 on a closed orbit)."""
    subs = {s: fixed[k] for s, k in zip(system.parameter_symbols, system.parameters,
                                        strict=True) if k in fixed}
    terms = [system.dissipation, *system.forces]
    return all(sp.sympify(e).subs(subs) == 0 for e in terms)


class OrbitProbe:
    """``evaluate(A, omega, analyse)`` about a periodic orbit (see the module docstring):
    the dict of :class:`kapitza.floquet._probe._Probe` — ``Mb`` (balanced monodromies),
    ``ls`` (0), ``err``, ``undamped``, with ``paired`` the entries' error ``delta``, with
    ``analyse`` ``stable``, ``label``, ``signed`` — and ``flags`` per point.  ``count``
    counts the orbits shot (the predictors' rejected steps included), ``samples`` is 0."""

    def __init__(self, system, params, request, amplitude, frequency, tol, guard_tol,
                 start, paired=False):
        self.fixed = {k: v for k, v in params.items() if k not in (amplitude, frequency)}
        self.system, self.request = system, request
        self.amplitude, self.frequency = amplitude, frequency
        self.tol, self.guard_tol, self.paired = float(tol), guard_tol, paired
        self.follower = Follower(system, self.fixed, request, amplitude, frequency, tol, start)
        self.undamped_system = conservative(system, self.fixed)
        self.samples = 0
        self.label = request.label

    @property
    def count(self) -> int:
        return self.follower.solves

    def orbits(self, A, omega):
        """The :class:`~kapitza.floquet._shooting.Shot` (or None) at every point, each ω's
        amplitudes visited in ascending order (continuation)."""
        A = np.asarray(A, float).ravel()
        w = np.asarray(omega, float).ravel()
        out: list[Shot | None] = [None] * A.size
        for i in np.lexsort((A, w)):
            if _SIGINT["hit"]:
                raise KeyboardInterrupt
            out[i] = self.follower.at(A[i], w[i])
        lines = self.follower.lines
        if lines and all(line is None for line in lines.values()):
            w0 = next(iter(lines))
            y = self.request.state
            n = y.size // 2
            raise ValueError(
                f"about: the state q = {np.round(y[:n], 12).tolist()} does not persist under "
                f"the drive, and no periodic orbit near it was found: "
                f"{self.follower.why.get(w0, 'no orbit')}.  Pass an equilibrium's exact "
                "coordinates, a better guess of the orbit (its state [q, q̇] at t = 0), or a "
                "kapitza.periodic_orbit(...) result (followed from where it was found).")
        return out

    def __call__(self, A, omega, analyse=False):
        A = np.asarray(A, float).ravel()
        w = np.broadcast_to(np.asarray(omega, float).ravel(), A.shape)
        shots = self.orbits(A, w)
        return self.data(shots, w, analyse)

    def data(self, shots, w, analyse):
        m, d = len(shots), 2 * self.system.n_dof
        n = d // 2
        Mb = np.full((m, d, d), np.nan)
        delta = np.full(m, np.inf)
        liou = np.zeros(m)
        flags: list[tuple[str, ...]] = [()] * m
        T = 2 * np.pi / w
        for i, s in enumerate(shots):
            if s is None:
                line = self.follower.lines.get(float(w[i]))
                why = self.follower.why.get(float(w[i])) if line is None else (
                    "the orbit, followed in the amplitude, could not be continued to it: "
                    "its branch ends before (a fold or a branch point), or Newton's "
                    "shooting stopped converging")
                flags[i] = (f"no periodic orbit: {why}",)
                continue
            M = s.monodromy
            Mb[i] = M
            Mb[i, n:, :] /= w[i]
            Mb[i, :, n:] *= w[i]
            # where no bound is established (Kantorovich's h > 1/2 near a bifurcation) the
            # analysis reads the monodromy with its integration error, uncertified (below)
            bounded = math.isfinite(s.monodromy_error)
            delta[i] = (s.monodromy_error if bounded else s.integration_error) * max(
                1.0, w[i], 1.0 / w[i])
            if not self.undamped_system:
                liou[i] = np.linalg.slogdet(M)[1]
            scale = max(1.0, float(np.max(np.abs(s.state))))
            if not bounded or not s.state_error <= math.sqrt(self.tol) * scale:
                known = (f"known only to {s.state_error:.3g}" if bounded else
                         f"not bounded ({s.bound_note})")
                flags[i] = (f"ill-conditioned: ‖J⁻¹‖ = {s.condition:.3g} for the shooting "
                            f"equations (a multiplier near +1: a bifurcation), the orbit's "
                            f"state {known}",)
        have = np.all(np.isfinite(Mb), axis=(1, 2))
        size = np.where(have, np.maximum(1.0, np.max(np.abs(np.where(have[:, None, None], Mb,
                                                                        0.0)), axis=(1, 2))),
                        1.0)
        err = np.where(have, delta / size, np.inf)
        undamped = np.full(m, True) if self.undamped_system else \
            np.abs(liou) <= 1e-12 * np.maximum(1.0, T)
        out = dict(Mb=Mb, ls=np.zeros(m), err=err, undamped=undamped, flags=flags)
        if self.paired and not analyse:
            out["delta"] = self._measured_delta(shots, w, Mb, delta)
        if analyse:
            res = _analyse(np.where(have[:, None, None], Mb, np.eye(d)), np.zeros(m), T,
                           np.where(have, liou, 0.0), np.where(have, err, 0.0),
                           self.guard_tol, signed=True)
            stable, label, signed = res["stable"], res["label"], res["signed"]
            stable[~have], label[~have], signed[~have] = False, 3, np.nan
            res["margin"][~have] = 0.0
            ill = np.array([len(f) > 0 and f[0].startswith("ill") for f in flags], dtype=bool)
            res["margin"][ill] = 0.0
            for k in np.nonzero(have)[0]:
                flags[k] = tuple(flags[k]) + tuple(res["flags"][k])
            out.update(stable=stable, label=label, signed=signed, analysis=res)
        return out

    def _measured_delta(self, shots, w, Mb, bound):
        """The entries' error of the balanced monodromies, measured: the gap to a second
        shooting from the same state at 100× the tolerance (what the coarser one gets
        wrong bounds the finer one's error, as :class:`~kapitza.floquet._probe._Probe`
        measures it); the shot's own bound where the second fails."""
        n = self.system.n_dof
        out = np.full(len(shots), np.inf)
        for i, s in enumerate(shots):
            if s is None:
                continue
            coarse = self.follower.shoot_once(s, w[i], 100.0 * self.tol)
            size = max(1.0, float(np.max(np.abs(Mb[i]))))
            if coarse is None:
                out[i] = bound[i]
                continue
            M2 = coarse.monodromy.copy()
            M2[n:, :] /= w[i]
            M2[:, n:] *= w[i]
            out[i] = max(float(np.max(np.abs(M2 - Mb[i]))), 16 * np.finfo(float).eps * size)
        return out

    def amplitude_scale(self, omega):
        """Per ω, the amplitude at which the drive, at the request's state y0, reaches 2 in
        the balanced variables: its modulation of the Jacobian's lower block (÷ ω², ÷ ω)
        or its forcing of the accelerations (÷ ω²), whichever is larger, per unit
        amplitude, over 16 phases (the single pendulum on a horizontal pivot: 2 l, as the
        vertical drive's Mathieu q = 4)."""
        w = np.atleast_1d(np.asarray(omega, float))
        kernels = self.system.kernels
        W = kernels.work_array()
        d = 2 * self.system.n_dof
        n = d // 2
        y = np.asarray(self.request.state, float)
        out = np.empty(w.size)
        for i, wi in enumerate(w):
            rows = []
            for a in (0.0, 1.0):
                p = self.follower._p(a, wi)
                f, J = np.empty(d), np.empty((d, d))
                acc, jac = [], []
                for k in range(16):
                    t = k * 2 * np.pi / wi / 16
                    kernels.rhs(t, y, p, f, W)
                    kernels.jacobian(t, y, p, J)
                    acc.append(f[n:] / wi**2)
                    jac.append(np.c_[J[n:, :n] / wi**2, J[n:, n:] / wi])
                rows.append((np.array(acc), np.array(jac)))
            slope = max(float(np.max(np.abs(rows[1][0] - rows[0][0]))),
                        float(np.max(np.abs(rows[1][1] - rows[0][1]))))
            if not slope > 0:
                raise ValueError(f"the parameter {self.amplitude!r} does not drive the state "
                                 "about; pass A_range=(0, high) explicitly.")
            out[i] = 2.0 / slope
        return out


def orbit_map(system, params, request, A, omega, amplitude, frequency, tol, guard_tol,
              progress) -> StabilityMap:
    """The stability map of the periodic orbit ``request`` over the grid A × omega: each
    ω's column followed in the amplitude from its lowest (or from the given orbit), in
    chunks of columns with a progress line and Ctrl-C (the finished columns kept)."""
    t0 = time.perf_counter()
    order = np.argsort(A, kind="stable")
    start = float(A[order[0]]) if A.size else 0.0
    probe = OrbitProbe(system, params, request, amplitude, frequency, tol, guard_tol, start)
    nA, nw = A.size, omega.size
    fields = dict(stable=np.zeros((nA, nw), dtype=bool), label=np.full((nA, nw), 3, np.int8),
                  trace=np.full((nA, nw), np.nan), log_growth=np.full((nA, nw), np.nan),
                  margin=np.zeros((nA, nw)), err=np.full((nA, nw), np.nan))
    flags = np.empty((nA, nw), dtype=object)
    flags.fill(())
    columns = np.argsort(np.abs(omega - request.seed[1]) if request.seed else np.arange(nw),
                         kind="stable")

    def work(a, b):
        for j in columns[a:b]:
            data = probe(A, np.full(nA, omega[j]), True)
            res = data["analysis"]
            found = np.isfinite(data["Mb"][:, 0, 0])
            # no orbit there: label 4, "no orbit" (kapitza.results.MAP_LABELS), undecided
            fields["stable"][:, j] = data["stable"]
            fields["label"][:, j] = np.where(found, data["label"], NO_ORBIT)
            fields["trace"][:, j] = np.where(np.isfinite(data["Mb"][:, 0, 0]), res["trace"],
                                             np.nan)
            fields["log_growth"][:, j] = np.where(np.isfinite(data["Mb"][:, 0, 0]),
                                                  res["logabs"][:, 0], np.nan)
            fields["margin"][:, j] = res["margin"]
            fields["err"][:, j] = data["err"]
            for i in range(nA):
                flags[i, j] = data["flags"][i]

    done, stopped = 0, False
    with _defer_ctrl_c():
        if nA and nw:
            done, stopped = run_in_chunks(work, nw, progress=progress, unit="columns",
                                          label="Floquet map about a periodic orbit", first=1)
        result = _orbit_result(fields, flags, A, omega, request, probe, t0)
        if stopped or _SIGINT["hit"]:
            computed = np.zeros((nA, nw), dtype=bool)
            computed[:, columns[:done]] = True
            raise ComputationInterrupted(result, computed)
        return result


def _orbit_result(fields, flags, A, omega, request, probe, t0) -> StabilityMap:
    flat = [f for f in flags.ravel() if f]
    err = fields["err"][np.isfinite(fields["err"])]
    method = ("periodic orbit: Newton shooting on the "
              + ("half-period map (symmetric orbit)" if request.center is not None
                 else "period map")
              + ", continued over the grid")
    return StabilityMap(A=A, omega=omega, stable=fields["stable"], label=fields["label"],
                        trace=fields["trace"], log_growth=fields["log_growth"],
                        error_estimate=float(np.max(err)) if err.size else 0.0,
                        about=request.label, method=method, params=dict(probe.fixed),
                        seconds=time.perf_counter() - t0, refined_points=0,
                        uncertified_points=int(np.sum(~(fields["margin"] > 1.0))),
                        flagged_points=len(flat), flags_example=flat[0] if flat else (),
                        max_steps_per_period=0, samples=0)
