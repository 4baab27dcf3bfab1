"""The frontier's analyses of a scene: branches of periodic orbits and their bifurcations
(``continuation``), the route to chaos by brute force (``bifurcation_diagram``) and by the
growth of perturbations (``lyapunov``).  Each runs once at the scene's point through the
public functions (:func:`kapitza.continuation`, :func:`kapitza.chaos.bifurcation_diagram`,
:func:`kapitza.chaos.lyapunov`); the settings arrive checked and in SI units
(:mod:`._settings`).
"""
from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np

from ..chaos import bifurcation_diagram, lyapunov
from ..continuation import continuation
from ..simulation import periodic_orbit
from ._states import about_state, averaged_state, checked_state, naming_state, persists

__all__ = ["Branches", "FRONTIER_POINT", "frontier_method", "SWITCHABLE"]

#: The bifurcations a branch of periodic orbits is born at (a fold only turns the branch;
#: a Neimark–Sacker point gives birth to a torus, not to periodic orbits).
SWITCHABLE = ("period_doubling", "pitchfork", "transcritical")


@dataclass(frozen=True, eq=False)
class Branches:
    """What a scene's ``continuation`` computed: the branch through the scene's state and,
    with ``switch = true``, the branches born at its bifurcations.

    Attributes
    ----------
    branches : tuple of kapitza.results.Branch
        The continued branch first, then one per bifurcation switched at (in the order
        of the first branch's bifurcations).
    origins : tuple
        Per branch, the Bifurcation (of the first branch) it was born at; None for the
        first.
    notes : tuple of str
        Bifurcations whose branch could not be followed, and why (each also warned).
    method : str
        "continuation: ..." (the ``method`` column of the tables).
    """

    branches: tuple
    origins: tuple = ()
    notes: tuple = ()
    method: str = "continuation: pseudo-arclength on the period map (Newton shooting)"

    @property
    def main(self):
        """The branch through the scene's state."""
        return self.branches[0]

    @property
    def parameter(self) -> str:
        return self.main.parameter

    @property
    def bifurcations(self) -> list:
        """Every bifurcation found, as (branch index, Bifurcation), branch by branch."""
        return [(i, b) for i, br in enumerate(self.branches) for b in br.bifurcations]

    def to_dataframe(self):
        """One row per point of every branch (:meth:`kapitza.results.Branch.to_dataframe`)
        with ``branch`` (its index), ``branch_label`` ("T orbits", "2T orbits from the
        period doubling", …) and ``periods``."""
        import pandas as pd
        frames = []
        for i, br in enumerate(self.branches):
            f = br.to_dataframe()
            f.insert(0, "branch", i)
            f.insert(1, "branch_label", br.label)
            f.insert(2, "periods", br.periods)
            frames.append(f)
        return pd.concat(frames, ignore_index=True)

    def bifurcation_table(self):
        """One row per bifurcation: the branch it lies on, its kind, where (the parameter,
        with its certified accuracy), its criticality and side, the orbit's state there,
        and which branch (if any) was followed from it (``born_branch``, −1: none)."""
        import pandas as pd
        p = self.parameter
        coords = self.main.coordinates
        n = len(coords)
        born = {id(b): j for j, b in enumerate(self.origins) if b is not None}
        rows = []
        for i, b in self.bifurcations:
            row = {"branch": i, "branch_label": self.branches[i].label, "kind": b.kind,
                   p: b.parameter, "accuracy": b.accuracy, "periods": b.periods,
                   "criticality": b.criticality or "", "side": b.side,
                   "test_function": b.test_function,
                   "max_abs_multiplier": float(np.max(np.abs(b.multipliers)))}
            row.update({f"{c}_0": float(b.state[k]) for k, c in enumerate(coords)})
            row.update({f"{c}_dot_0": float(b.state[n + k]) for k, c in enumerate(coords)})
            row.update(born_branch=born.get(id(b), -1), note=b.note)
            rows.append(row)
        columns = ["branch", "branch_label", "kind", p, "accuracy", "periods", "criticality",
                   "side", "test_function", "max_abs_multiplier",
                   *(f"{c}_0" for c in coords), *(f"{c}_dot_0" for c in coords),
                   "born_branch", "note"]
        return pd.DataFrame(rows, columns=columns)

    def figure(self, *, ax=None, y="amplitude", coordinate=0):
        """Every branch against the parameter on one axes (stable solid, unstable dashed,
        bifurcations marked: :func:`kapitza.figures.branch_figure`)."""
        fig = None
        for br in self.branches:
            fig = br.figure(ax=ax, y=y, coordinate=coordinate)
            ax = fig.axes[0] if ax is None else ax
        return fig


def _continuation(scene, s, progress):
    """The branch from ``about`` at ``start`` (default the scene's value) to ``stop``; the
    branches born at its bifurcations with ``switch``."""
    system = scene.system
    parameter = s.get("parameter", "A")
    params = dict(scene.spec.params)
    params[parameter] = float(s.get("start", params[parameter]))
    about = s.get("about", "auto")
    if scene.capabilities["floquet"] == "equilibrium" or about not in (None, "auto"):
        x0 = checked_state(scene, about_state(scene, about), about, params)
    else:
        x0 = checked_state(scene, averaged_state(scene, params, scene.q0), about, params)
    with naming_state(scene, x0, about):
        if not persists(scene, x0, params):
            # the drive moves the state (no equilibrium, or a length on a shaken pivot):
            # start on the periodic orbit born from it
            x0 = periodic_orbit(system, params, x0).state
        main = continuation(system, params, x0, parameter=parameter, stop=s["stop"],
                            periods=s.get("periods", 1), max_points=s.get("max_points", 500),
                            progress=progress,
                            **{k: s[k] for k in ("tol", "step", "max_step") if k in s})
    branches, origins, notes = [main], [None], []
    if s.get("switch"):
        for b in main.bifurcations:
            if b.kind not in SWITCHABLE:
                continue
            try:
                branches.append(main.switch(b))
                origins.append(b)
            except ValueError as e:
                notes.append(f"the {b.kind} at {parameter} = {b.parameter:.10g}: {e}")
                warnings.warn(f"continuation: the branch born at the {b.kind} at {parameter} "
                              f"= {b.parameter:.10g} could not be followed: {e}",
                              RuntimeWarning, stacklevel=2)
    return Branches(tuple(branches), tuple(origins), tuple(notes))


def _bifurcation_diagram(scene, s, progress):
    """Strobe samples over ``values`` × ``starts`` (at rest; default the scene's initial
    state).  The rig's angles (its coordinates in rad: every one of the catalogue's rigs')
    are drawn modulo 2π."""
    starts = s.get("starts")
    if starts is None:
        q0, qdot0 = scene.q0[None, :], scene.qdot0[None, :]
    else:
        q0, qdot0 = np.array(starts, dtype=float), np.zeros((len(starts), scene.system.n_dof))
    if scene.system.n_dof == 1:         # one coordinate: its value per start, shape (S,)
        q0, qdot0 = q0[:, 0], qdot0[:, 0]
    units = scene.spec.units
    angles = tuple(q for q in scene.system.coordinates if units.get(q) == "rad")
    angles = True if len(angles) == scene.system.n_dof else angles
    about = None if s.get("about") is None else about_state(scene, s["about"])
    return bifurcation_diagram(scene.system, scene.spec.params, about,
                               parameter=s.get("parameter", "A"),
                               values=np.asarray(s["values"].values), q0=q0, qdot0=qdot0,
                               periods=s.get("periods", 200), transient=s.get("transient", 500),
                               angles=angles, progress=progress,
                               **{k: s[k] for k in _INTEGRATION if k in s})


def _lyapunov(scene, s, progress):
    """The exponents of the trajectory from the scene's initial state."""
    return lyapunov(scene.system, scene.spec.params, scene.q0, scene.qdot0,
                    periods=s.get("periods", 1000), transient=s.get("transient", 100),
                    exponents=s.get("exponents", "all"), progress=progress,
                    **{k: s[k] for k in ("every", "blocks", "t0", "tangent", "rtol", "atol",
                                         "max_steps") if k in s})


#: The integration settings a diagram passes on (as :meth:`lagrange_core.System.simulate_grid`).
_INTEGRATION = ("t0", "method", "rtol", "atol", "max_steps")


#: The frontier's analyses at the scene's point: name → function(scene, settings, progress).
FRONTIER_POINT = {"continuation": _continuation, "bifurcation_diagram": _bifurcation_diagram,
                  "lyapunov": _lyapunov}


def frontier_method(name, result=None) -> str:
    """The ``method`` column of a frontier analysis's tables ("<family>: <detail>")."""
    if name == "continuation":
        return Branches.method
    if name == "bifurcation_diagram":
        how = f" ({result.method})" if getattr(result, "method", None) else ""
        return f"simulation: strobe samples after a transient{how}"
    if name == "lyapunov":
        tangent = getattr(result, "tangent", "jacobian")
        return (f"lyapunov: Benettin's method on the variational equations ({tangent} "
                "tangent)")
    raise KeyError(f"no method known for the analysis {name!r}")
