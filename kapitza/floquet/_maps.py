"""Stability maps over an (A, ω) grid: :func:`stability_map` (every point's monodromy →
:class:`~kapitza.results.StabilityMap`) and :func:`adaptive_map` (monodromies only where
the classification changes → :class:`~kapitza.results.AdaptiveMap`).

:func:`refine_map` is the adaptive map's algorithm: it calls ``evaluate(A, omega,
analyse)`` (:class:`kapitza.floquet._probe._Probe`) and knows nothing of how a monodromy
is computed.  Grids of fewer than :data:`kapitza.floquet._kernels.SERIAL_BELOW` points run
on the calling thread.  The single pendulum's maps go through the Mathieu equation instead
(:func:`kapitza.closed_forms.pendulum_stability_map`), which is faster and exact to
rounding.
"""
from __future__ import annotations

import time
from collections.abc import Mapping

import numpy as np

from lagrange_core.progress import _SIGINT
from lagrange_core.progress import defer_ctrl_c as _defer_ctrl_c

from .. import _arguments as arguments
from ..results import AdaptiveMap, ComputationInterrupted, StabilityMap
from ._margins import signed_margin
from ._old_spellings import axes_as_keywords
from ._orbit_probe import NO_ORBIT, OrbitProbe, orbit_map
from ._orbits import orbit_request
from ._point import floquet_grid
from ._probe import fixed_parameters, probe_for

__all__ = ["stability_map", "adaptive_map"]


@axes_as_keywords
def stability_map(system, params, about, *, A, omega, amplitude="A", frequency="omega",
                  tol=1e-8, coarse_tol=None, guard_tol=1e-6, order=16,
                  progress=None) -> StabilityMap:
    """Stability map of a driven equilibrium over an (A, ω) grid by monodromy integration.

    Every point is integrated to ``tol``; ``uncertified_points`` of the result counts
    those whose stability test lies within 10× its error estimate of the
    threshold.  With ``coarse_tol`` the grid is first integrated to that
    tolerance and only the uncertified points again to ``tol`` (worth it when
    boundaries are far apart on the grid; for near-identity monodromies — slow
    motion, ω ≫ ω0 — nearly every point needs ``tol`` anyway).

    The grid's axes are keywords named by the parameter they vary (``A=``, ``omega=``,
    docs/api-conventions.md); kapitza 0.1's order ``stability_map(system, A, omega,
    params, about)`` still works in 0.2, with a DeprecationWarning.

    Parameters
    ----------
    system : lagrange_core.System
    params : dict
        The other parameters (scalars); values of ``amplitude`` and ``frequency`` in it
        are ignored.
    about : sequence, dict or kapitza.results.PeriodicOrbit
        The equilibrium's coordinates (velocities zero).  Where that state does not
        persist under the drive, the map is of the T-periodic orbit ``about`` names
        (see the Notes): coordinates at rest or the state [q, q̇]
        at t = 0 (Newton's guess at each ω's lowest amplitude), or a
        :class:`~kapitza.results.PeriodicOrbit` (followed from its own amplitude and ω).
    A, omega : 1-d arrays
        Grid axes (m, rad/s) for the parameters named ``amplitude`` and ``frequency``.
    amplitude, frequency : str
        The names of the drive's amplitude and angular frequency parameters.
    tol : float
        Target error of the monodromy near boundaries (relative to max(1, ‖M‖)); about
        a periodic orbit, the shooting's residual (at least 1e-10).
    progress : None, bool or callable
        Progress line and Ctrl-C, as for :func:`floquet_grid`; the
        :class:`~kapitza.results.ComputationInterrupted` raised carries this map
        with the finished points filled (about an orbit: the finished ω columns).

    Returns
    -------
    kapitza.results.StabilityMap
        Arrays of shape (len(A), len(omega)); ``about`` is the equilibrium's coordinates as
        text (the orbit's description about an orbit), ``params`` the fixed parameters, with
        timing, the numbers of refined, uncertified and flagged points; ``l``, ``g``,
        ``damping`` are None (they name the single pendulum's constants).

    Notes
    -----
    About a periodic orbit: each ω's orbit is found by Newton shooting from ``about`` at the
    lowest amplitude of the grid (or, for a PeriodicOrbit, followed in ω from where it was
    found) and continued along the amplitudes by natural continuation: each point's shooting
    starts from the tangent predictor of its neighbour, and a step is accepted only where
    the tangents at both ends agree with it (a jump to another branch, or past a fold or the
    branch point where a tilted orbit is born, fails) — rejected steps are halved down to
    1e-6 of A (:mod:`kapitza.floquet._orbits`). Orbits with the half-period reflection
    symmetry about ``about`` (the horizontal drive about θ = 0, π; tested on the vector
    field) are shot on the half-period map, regular at the symmetry-breaking pitchfork where
    the full period map is singular. Stability, labels and margins come from the orbit's
    monodromy as above (``method`` says which map was shot). A point the orbit does not
    reach is unstable with label 4 ("no orbit", undecided), NaN ``trace``, and flagged "no
    periodic orbit"; an orbit whose state is known only to more than √tol (the shooting
    equations ill-conditioned) is flagged and counted uncertified. ``coarse_tol`` and
    ``order`` do not apply. ValueError where Newton finds no orbit near ``about`` at any ω.

    Examples
    --------
    The double pendulum on a vertically driven pivot: no drive, no upright (Acheson).

    >>> import math
    >>> import sympy as sp
    >>> from lagrange_core import problems, t
    >>> A, w = sp.symbols("A omega", positive=True)
    >>> chain = problems.n_link_pendulum(2, pivot=(0, A * sp.cos(w * t)))
    >>> m = stability_map(chain, dict(g=9.81, l1=1.0, l2=1.0, m1=1.0, m2=1.0),
    ...                   [math.pi, math.pi], A=[0.0, 0.1], omega=[100.0], tol=1e-8)
    >>> m.stable[:, 0].tolist(), m.flagged_points
    ([False, True], 0)

    The pendulum on a horizontally driven pivot: no angle persists, and the map is that
    of the hanging orbit, stable up to the pitchfork at A = 7.38 cm (ω = 60 rad/s):

    >>> horizontal = problems.driven_pendulum("horizontal")
    >>> m = stability_map(horizontal, dict(m=1.0, l=1.0, g=9.81), [0.0],
    ...                   A=[0.05, 0.07, 0.08], omega=[60.0])
    >>> m.stable[:, 0].tolist(), m.about
    ([True, True, False], 'periodic orbit symmetric about q = [0.0]')
    """
    _check_params("stability_map", params)
    A = arguments.grid_axis(amplitude, A, None, positive=None)
    omega = arguments.grid_axis(frequency, omega, "rad/s", positive=True)
    arguments.check_grid_memory(f"{amplitude} × {frequency}", (A.size, omega.size),
                                arguments.monodromy_bytes_per_point(getattr(system, "n_dof", 1)),
                                where="stability_map: ")
    fixed = {k: v for k, v in params.items() if k not in (amplitude, frequency)}
    if A.size and omega.size and all(np.ndim(v) == 0 for v in fixed.values()):
        request = orbit_request(system, fixed_parameters(system, params, amplitude, frequency),
                                about, amplitude, frequency, _probes(A, omega))
        if request is not None:
            return orbit_map(system, params, request, A, omega, amplitude, frequency,
                             _orbit_tol(tol), guard_tol, progress)
    p = dict(fixed)
    p[amplitude] = A[:, None]
    p[frequency] = omega[None, :]
    t0 = time.perf_counter()
    with _defer_ctrl_c():
        try:
            g = floquet_grid(system, p, about, frequency=frequency, tol=tol,
                             guard_tol=guard_tol, order=order, certify=coarse_tol is not None,
                             coarse_tol=coarse_tol if coarse_tol is not None else tol,
                             progress=progress)
        except ComputationInterrupted as e:
            partial = _map_from_grid(e.result, A, omega, about, fixed, t0)
            raise ComputationInterrupted(partial, e.computed) from None
        result = _map_from_grid(g, A, omega, about, fixed, t0)
        if _SIGINT["hit"]:             # Ctrl-C after the last chunk: everything is computed
            raise ComputationInterrupted(result, np.ones(result.stable.shape, dtype=bool))
        return result


def _probes(A, omega):
    """Where ``about``'s persistence under the drive is tested: the largest amplitude at
    the lowest and the highest frequency."""
    a = float(np.max(np.abs(A)))
    return [(a, float(np.min(omega))), (a, float(np.max(omega)))]


def _orbit_tol(tol):
    """The shooting's residual tolerance for a map's ``tol``, within 1e-10 … 1e-6 (the flow
    is integrated to 1/100 of it; float64 flows meet no less than ~1e-12)."""
    return float(min(1e-6, max(1e-10, tol)))


def _map_from_grid(g, A, omega, about, fixed, t0) -> StabilityMap:
    flagged = [f for f in g.flags if f]
    return StabilityMap(A=A, omega=omega, stable=g.stable, label=g.label, trace=g.trace,
                        log_growth=g.log_growth, error_estimate=_largest_finite(g.error_estimate),
                        about=str(about), method="monodromy", params=fixed,
                        seconds=time.perf_counter() - t0, refined_points=g.refined_points,
                        uncertified_points=int(np.sum(~(g.margin > 1.0))),
                        flagged_points=len(flagged), flags_example=flagged[0] if flagged else (),
                        max_steps_per_period=int(np.max(g.steps, initial=0)),
                        samples=g.samples)


def _largest_finite(x):
    """The largest finite entry (0 if none): the error estimate over the integrated points."""
    x = np.asarray(x)[np.isfinite(x)]
    return float(np.max(x)) if x.size else 0.0


def _check_params(where, params):
    if not isinstance(params, Mapping):
        raise TypeError(f"{where}: params must be a dict of parameter values (name → value), "
                        f"got a {type(params).__name__}; call kapitza.{where}(system, params, "
                        "about, A=A, omega=omega).")


@axes_as_keywords
def adaptive_map(system, params, about, *, A, omega, amplitude="A", frequency="omega",
                 coarse_step=16, tol=1e-8, guard=0.25, order=16,
                 guard_tol=1e-6) -> AdaptiveMap:
    """A stability map over the (A, ω) grid that computes monodromies only where the
    classification changes.

    Every ``coarse_step``-th row and column are computed first; then each cell whose
    corners disagree — in label, in the sign of a continuous stability margin, or with
    a margin closer to zero than ``guard`` × the corners' spread — is split in four,
    level by level, down to the grid's own spacing
    (:func:`refine_map`).  The labels match a uniform
    :func:`stability_map` of the same grid wherever no stable or unstable region is
    thinner than the coarse cells, at a fraction of the monodromies; the margin's zero
    contour draws the boundaries smoothly.

    Parameters
    ----------
    system, params, about, amplitude, frequency, order, guard_tol
        As for :func:`stability_map` (about a periodic orbit too: a point the orbit does
        not reach has label 4, "no orbit"); kapitza 0.1's order
        ``adaptive_map(system, A, omega, params, about)`` still works in 0.2, with a
        DeprecationWarning.
    A, omega : 1-d arrays
        The full grid's axes (m, rad/s), keywords.
    coarse_step : int
        The coarse grid's spacing in grid points (a power of 2 splits evenly).
    tol : float
        Target error of each monodromy.

    Returns
    -------
    kapitza.results.AdaptiveMap
        A :class:`~kapitza.results.StabilityMap` (``trace`` and ``log_growth`` None)
        with ``margin``, ``computed``, ``monodromies``, ``levels``.

    Examples
    --------
    >>> import math
    >>> import numpy as np
    >>> from lagrange_core import problems
    >>> m = adaptive_map(problems.driven_pendulum("vertical"), dict(m=1.0, l=1.0, g=9.81),
    ...                  [math.pi], A=np.linspace(0, 0.6, 129),
    ...                  omega=np.linspace(20.0, 120.0, 129))
    >>> bool(m.monodromies < 129 * 129 / 5), m.stable.shape
    (True, (129, 129))
    """
    t0 = time.perf_counter()
    _check_params("adaptive_map", params)
    A = arguments.grid_axis(amplitude, A, None, positive=None)
    w = arguments.grid_axis(frequency, omega, "rad/s", positive=True)
    arguments.check_grid_memory(f"{amplitude} × {frequency}", (A.size, w.size),
                                arguments.ADAPTIVE_MAP_BYTES, where="adaptive_map: ")
    if isinstance(coarse_step, bool) or not isinstance(coarse_step, int) or coarse_step < 1:
        raise ValueError(f"coarse_step must be an integer ≥ 1, got {coarse_step!r}.")
    probe = probe_for(system, params, about, amplitude, frequency, tol, order, guard_tol,
                      probes=_probes(A, w) if A.size and w.size else [],
                      start=float(np.min(A)) if A.size else 0.0, orbit_tol=_orbit_tol(tol))
    orbit = isinstance(probe, OrbitProbe)
    out = refine_map(_with_no_orbit_label(probe) if orbit else probe, A, w, coarse_step,
                     guard=guard)
    return AdaptiveMap(A=A, omega=w, stable=out["stable"], label=out["label"], trace=None,
                       log_growth=None, error_estimate=tol, about=probe.label,
                       method="adaptive, periodic orbit" if orbit else "adaptive monodromy",
                       params=dict(probe.fixed),
                       seconds=time.perf_counter() - t0, samples=int(probe.samples or 0),
                       margin=out["margin"], computed=out["computed"],
                       monodromies=probe.count, levels=out["levels"], coarse_step=coarse_step)


def _with_no_orbit_label(probe):
    """``probe`` about a periodic orbit, its points without an orbit labelled
    :data:`NO_ORBIT` ("no orbit", undecided) as on :func:`stability_map`'s orbit path.
    The probe itself labels them 3, which the boundary tracers (:mod:`._edges`,
    :mod:`._curves`) read as an instability of their own, so the label is changed here
    only: a point has no orbit where its monodromy is not finite."""
    def evaluate(A, omega, analyse):
        data = probe(A, omega, analyse)
        missing = ~np.all(np.isfinite(data["Mb"]), axis=(1, 2))
        data["label"] = np.where(missing, NO_ORBIT, data["label"]).astype(np.int8)
        return data
    return evaluate


# -- the adaptive refinement ------------------------------------------------------------

def refine_map(evaluate, A, omega, step, *, guard=0.25):
    """A stability map on the grid A × omega that computes only where it must.

    The grid's every ``step``-th row and column (and the last) are computed first; then,
    level by level, each cell whose corners disagree — in label, in the sign of
    :func:`signed_margin`, or with a corner margin within ``guard`` × the corners'
    spread of zero (a boundary may pass between them) — is split in four, and the new
    corners computed in one call.  The points of a cell that is not split take its
    corners' label and the bilinear interpolation of their margins.

    Returns dict(stable, label, margin (len(A), len(omega)), computed (bool), levels).
    """
    A = np.asarray(A, float)
    w = np.asarray(omega, float)
    nA, nw = A.size, w.size
    label = np.zeros((nA, nw), dtype=np.int8)
    stable = np.zeros((nA, nw), dtype=bool)
    s = np.full((nA, nw), np.nan)
    computed = np.zeros((nA, nw), dtype=bool)

    def compute(ii, jj):
        key = np.unique(np.ravel_multi_index((ii, jj), (nA, nw)))
        key = key[~computed.ravel()[key]]
        if key.size == 0:
            return
        i, j = np.unravel_index(key, (nA, nw))
        data = evaluate(A[i], w[j], True)
        stable[i, j], label[i, j] = data["stable"], data["label"]
        s[i, j] = signed_margin(data)
        computed[i, j] = True

    ia = np.unique(np.r_[np.arange(0, nA, step), nA - 1])
    jw = np.unique(np.r_[np.arange(0, nw, step), nw - 1])
    I, J = np.meshgrid(ia, jw, indexing="ij")
    compute(I.ravel(), J.ravel())
    I0, J0 = np.meshgrid(ia[:-1], jw[:-1], indexing="ij")
    I1, J1 = np.meshgrid(ia[1:], jw[1:], indexing="ij")
    cells = np.stack([I0.ravel(), I1.ravel(), J0.ravel(), J1.ravel()], axis=1)
    levels = 0
    while cells.size:
        i0, i1, j0, j1 = cells.T
        corners = [(i0, j0), (i0, j1), (i1, j0), (i1, j1)]
        lab = np.stack([label[c] for c in corners])
        mar = np.stack([s[c] for c in corners])
        with np.errstate(invalid="ignore"):
            spread = np.max(mar, axis=0) - np.min(mar, axis=0)
            near = np.min(np.abs(mar), axis=0) < guard * spread
        split = (np.any(lab != lab[0], axis=0) | np.any(np.sign(mar) != np.sign(mar[0]), axis=0)
                 | near | np.any(np.isnan(mar), axis=0))
        split &= (i1 - i0 > 1) | (j1 - j0 > 1)
        for c in cells[~split]:
            _fill(c, label, stable, s, computed)
        cells = cells[split]
        if cells.size == 0:
            break
        levels += 1
        i0, i1, j0, j1 = cells.T
        im = np.where(i1 - i0 > 1, (i0 + i1) // 2, i0)
        jm = np.where(j1 - j0 > 1, (j0 + j1) // 2, j0)
        pts_i = np.concatenate([im, im, im, i0, i1])
        pts_j = np.concatenate([j0, jm, j1, jm, jm])
        compute(pts_i, pts_j)
        children = []
        for a0, a1, b0, b1, am, bm in zip(i0, i1, j0, j1, im, jm, strict=True):
            for r0, r1 in ((a0, am), (am, a1)) if am > a0 else ((a0, a1),):
                for c0, c1 in ((b0, bm), (bm, b1)) if bm > b0 else ((b0, b1),):
                    children.append((r0, r1, c0, c1))
        cells = np.array(children, dtype=np.int64).reshape(-1, 4)
    return dict(stable=stable, label=label, margin=s, computed=computed, levels=levels)


def _fill(cell, label, stable, s, computed):
    """The points of an unsplit cell not computed: its corners' label, bilinear margin."""
    i0, i1, j0, j1 = cell
    if i1 - i0 <= 1 and j1 - j0 <= 1:
        return
    block = ~computed[i0:i1 + 1, j0:j1 + 1]
    if not block.any():
        return
    u = np.linspace(0.0, 1.0, i1 - i0 + 1)[:, None]
    v = np.linspace(0.0, 1.0, j1 - j0 + 1)[None, :]
    bil = ((1 - u) * (1 - v) * s[i0, j0] + (1 - u) * v * s[i0, j1] + u * (1 - v) * s[i1, j0]
           + u * v * s[i1, j1])
    label[i0:i1 + 1, j0:j1 + 1][block] = label[i0, j0]
    stable[i0:i1 + 1, j0:j1 + 1][block] = stable[i0, j0]
    s[i0:i1 + 1, j0:j1 + 1][block] = bil[block]
