"""The monodromy of one system about one equilibrium at any (amplitude, ω) points: the
``evaluate(A, omega, analyse)`` on which :func:`kapitza.floquet.window`,
:func:`kapitza.floquet.boundaries` and :func:`kapitza.floquet.adaptive_map` run
(:func:`probe_for` chooses it, or the same about a periodic orbit,
:class:`kapitza.floquet._orbit_probe.OrbitProbe`, where ``about`` does not persist).

It returns the balanced monodromies and, for margins, their entries' error measured
against a second monodromy at 100× the tolerance; for classifications, the stability
and label of :mod:`kapitza.floquet._multipliers`.
"""
from __future__ import annotations

import numpy as np

from ._monodromy import _balanced, _check_system, _equilibrium_state, _integrate, _prepare, _series
from ._multipliers import _analyse_points
from ._orbit_probe import OrbitProbe
from ._orbits import orbit_request


def fixed_parameters(system, params, amplitude, frequency):
    """The parameters other than the drive's amplitude and frequency, checked: the system
    unconstrained, both names its parameters and different, the others scalars."""
    _check_system(system)
    for name in (amplitude, frequency):
        if name not in system.parameters:
            raise ValueError(f"{name!r} is not a parameter of {system!r}; its parameters "
                             f"are {list(system.parameters)} (pass amplitude=<name>, "
                             "frequency=<name>).")
    if amplitude == frequency:
        raise ValueError("the amplitude and the frequency must be different parameters.")
    fixed = {k: v for k, v in params.items() if k not in (amplitude, frequency)}
    for k, v in fixed.items():
        if np.ndim(v) != 0:
            raise ValueError(f"the fixed parameters must be scalars; {k!r} is an array.")
    return fixed


def probe_for(system, params, about, amplitude, frequency, tol, order, guard_tol, *,
              probes, start, orbit_tol, paired=False, classify_tol=None):
    """The ``evaluate(A, omega, analyse)`` about ``about``: :class:`_Probe` (Taylor
    monodromies) about an equilibrium that persists under the drive at the ``probes``
    [(A, ω), ...], else :class:`kapitza.floquet._orbit_probe.OrbitProbe` about the
    periodic orbit it names (:func:`kapitza.floquet._orbits.orbit_request`), shot to the
    residual ``orbit_tol`` and followed from the amplitude ``start``."""
    probe = _Probe(system, params, about, amplitude, frequency, tol, order, guard_tol,
                   paired=paired, classify_tol=classify_tol)
    request = orbit_request(system, probe.fixed, about, amplitude, frequency, probes)
    if request is None:
        return probe
    return OrbitProbe(system, params, request, amplitude, frequency, orbit_tol, guard_tol,
                      start, paired=paired)


class _Probe:
    """Monodromies of one system about one equilibrium at any (amplitude, ω) points, the
    other parameters fixed: the ``evaluate(A, omega, analyse)`` that the edge, curve and
    map algorithms call (:mod:`kapitza.floquet._edges`, :mod:`kapitza.floquet._curves`,
    :func:`kapitza.floquet._maps.refine_map`).  Margins (``analyse`` False) are evaluated
    at ``tol`` (with ``paired``, their entries' error measured against a second
    monodromy), classifications (``analyse`` True) at ``classify_tol``.  The parameters
    and the persistence of the equilibrium are checked, and J's sampling plan made, on
    the first call; ``count`` counts the monodromies computed.  Ctrl-C raises
    KeyboardInterrupt."""

    def __init__(self, system, params, about, amplitude, frequency, tol, order, guard_tol,
                 paired=False, classify_tol=None):
        self.fixed = fixed_parameters(system, params, amplitude, frequency)
        self.system, self.about = system, about
        self.amplitude, self.frequency = amplitude, frequency
        self.tol, self.order, self.guard_tol = tol, order, guard_tol
        self.paired = paired
        self.classify_tol = tol if classify_tol is None else classify_tol
        self.samples = None
        self.count = 0
        self.label = str(about)

    def prepare(self, A, omega, tol=None):
        A = np.asarray(A, float).ravel()
        w = np.asarray(omega, float).ravel()
        tol = self.tol if tol is None else tol
        if self.samples is None:        # the first call checks everything
            p = dict(self.fixed)
            p[self.amplitude], p[self.frequency] = A, w
            prep = _prepare(self.system, p, self.about, self.frequency, tol)
            if prep["T"].size and not prep["stopped"]:
                self.samples = prep["samples"]
                names = self.system.parameters
                self.row = np.array([self.fixed.get(k, 0.0) for k in names], dtype=float)
                self.columns = (names.index(self.amplitude), names.index(self.frequency))
                self.ystar = _equilibrium_state(self.system, self.about)
        else:                           # then only the two axes change
            P = np.repeat(self.row[None, :], A.size, axis=0)
            P[:, self.columns[0]], P[:, self.columns[1]] = A, w
            prep = _series(self.system, P, self.ystar, w, 2 * np.pi / w, A.shape,
                           {self.amplitude: A, self.frequency: w}, tol, samples=self.samples)
        if prep["stopped"]:
            raise KeyboardInterrupt
        return prep

    def __call__(self, A, omega, analyse=False):
        tol = self.classify_tol if analyse else self.tol
        prep = self.prepare(A, omega, tol)
        idx = np.arange(prep["T"].size)
        Ms, ls, err, _, skip, fin, stopped = _integrate(prep, idx, tol, self.order)
        if stopped or not fin.all():
            raise KeyboardInterrupt
        self.count += idx.size
        Mb = self._balanced(Ms, prep)
        out = dict(Mb=Mb, ls=ls, err=err,
                   undamped=np.abs(prep["liouville"]) <= 1e-12 * np.maximum(1.0, prep["T"]))
        if self.paired and not analyse:
            # the entries' error, for the margins: against a second monodromy at 100× the
            # tolerance (what the coarser one gets wrong bounds the finer one's error);
            # the Taylor estimate runs 100–1000× above the actual error
            M2, ls2, _, _, _, fin2, stopped = _integrate(prep, idx, min(1e-6, 1e2 * self.tol),
                                                         self.order)
            if stopped or not fin2.all():     # Ctrl-C in the second pass stops as in the first
                raise KeyboardInterrupt
            with np.errstate(invalid="ignore"):
                gap = np.max(np.abs(Mb - self._balanced(M2, prep)), axis=(1, 2))
                size = np.maximum(1.0, np.max(np.abs(Mb), axis=(1, 2)))
                out["delta"] = np.where((ls2 == ls) & np.isfinite(gap),
                                        np.maximum(gap, 16 * np.finfo(float).eps * size),
                                        err * size)
        if analyse:
            res = _analyse_points(prep, idx, Ms, ls, err, skip, fin, self.guard_tol,
                                  signed=True)
            out.update(stable=res["stable"], label=res["label"], signed=res["signed"])
        return out

    @staticmethod
    def _balanced(Ms, prep):
        """Monodromies in the balanced variables (q, dq/d(ωt)): rows of dq/dt ÷ ω,
        columns × ω (their determinants and eigenvalues are those of M)."""
        n, om = prep["n"], prep["omega"][:, None, None]
        Mb = Ms.copy()
        Mb[:, n:, :] /= om
        Mb[:, :, n:] *= om
        return Mb

    def amplitude_scale(self, omega):
        """Per ω, the amplitude at which the drive's modulation of J, in the balanced
        variables, reaches 2 (the single pendulum: A = 2 l, Mathieu q = 4, well past its
        first window's A = 0.454 l)."""
        w = np.atleast_1d(np.asarray(omega, float))
        h = []
        for a in (0.0, 1.0):
            prep = self.prepare(np.full(w.size, a), w)
            C, S = _balanced(prep, np.arange(w.size))
            h.append(np.sum(np.max(np.abs(C[:, 1:]), axis=(2, 3))
                            + np.max(np.abs(S[:, 1:]), axis=(2, 3)), axis=1))
        slope = np.abs(h[1] - h[0])
        if not np.all(slope > 0):
            raise ValueError(f"the parameter {self.amplitude!r} does not modulate the "
                             "linearised drive; pass A_range=(0, high) explicitly.")
        return 2.0 / slope

