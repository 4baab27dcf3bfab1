"""The report's section on the frontier (``bifurcations``), shown only when the scene asks
for ``continuation``, ``bifurcation_diagram`` or ``lyapunov``: the branches of periodic
orbits with their bifurcations, the brute-force bifurcation diagram with those
bifurcations marked on it, and the Lyapunov exponents — at the scene's point, and the
largest one along the diagram's parameter.  Each analysis runs as the scene states it
(:func:`kapitza.scenes.run_analysis`), smaller in the quick mode."""
from __future__ import annotations

import numpy as np

from ._job import Job, SectionResult, Skip, new_figure, thin

#: The analyses this section shows.
FRONTIER = ("continuation", "bifurcation_diagram", "lyapunov")


def _quick(name, settings, quick):
    """The scene's settings of ``name``; in the quick mode, shorter runs and fewer values."""
    s = dict(settings)
    if not quick:
        return s
    if name == "bifurcation_diagram":
        from ..scenes import Axis
        values = thin(np.asarray(s["values"].values), 36)
        s["values"] = Axis(s["values"].name, tuple(float(v) for v in values), "list")
        s["periods"] = min(s.get("periods", 200), 32)
        s["transient"] = min(s.get("transient", 500), 200)
    elif name == "lyapunov":
        s["periods"] = min(s.get("periods", 1000), 300)
        s["transient"] = min(s.get("transient", 100), 100)
    elif name == "continuation":
        s["max_points"] = min(s.get("max_points", 500), 200)
    return s


def bifurcations_section(job: Job) -> SectionResult:
    from ..scenes import run_analysis
    asked = [a for a in FRONTIER if a in job.scene.analyses]
    if not asked:
        raise Skip("the scene asks for none of continuation, bifurcation_diagram or lyapunov "
                   "in [analyses]; add one (kapitza/scenes/period_doubling.toml asks for all "
                   "three) to see branches, their bifurcations and the route to chaos here.")
    results, methods = {}, {}
    for name in asked:
        settings = _quick(name, job.scene.analyses[name], job.quick)
        results[name], methods[name] = run_analysis(job.scene, name, settings,
                                                    progress=job.grid_progress)
    branches = results.get("continuation")
    diagram = results.get("bifurcation_diagram")
    spectrum = results.get("lyapunov")
    line = _lyapunov_line(job, diagram, spectrum) if diagram is not None \
        and spectrum is not None else None
    tables, caption = [], []
    if branches is not None:
        tables += _branch_tables(job, branches, methods["continuation"])
        caption.append(_branch_caption(branches, diagram))
    if diagram is not None:
        frame = diagram.to_dataframe()
        frame["method"] = methods["bifurcation_diagram"]
        tables.append(job.table("bifurcation_diagram", frame, "bifurcations"))
        caption.append(_diagram_caption(diagram))
    if spectrum is not None:
        frame = spectrum.to_dataframe()
        frame["method"] = methods["lyapunov"]
        tables.append(job.table("lyapunov", frame, "bifurcations",
                                shown="Lyapunov exponents at the scene's drive (1/s; "
                                      "per_period: × T)"))
        caption.append(_lyapunov_caption(job, spectrum))
    if line is not None:
        frame = line.to_dataframe()
        frame["method"] = methods["lyapunov"]
        tables.append(job.table(f"lyapunov_along_{diagram.parameter}", frame, "bifurcations"))
        caption.append(_line_caption(line, diagram.parameter))
    fig = _figure(job, branches, diagram, spectrum, line)
    return SectionResult(job.figure(fig, "bifurcations"), " ".join(caption), tables)


# -- the computations --------------------------------------------------------------------------

def _lyapunov_line(job, diagram, spectrum):
    """λ_max along the diagram's values, from the scene's initial state, with the record of
    the scene's ``lyapunov`` (kapitza.chaos.lyapunov_grid: compiled, parallel)."""
    from ..chaos import lyapunov_grid
    params = dict(job.params)
    params[diagram.parameter] = np.asarray(diagram.values, dtype=float)
    q0, qdot0 = job.scene.q0, job.scene.qdot0
    if q0.size == 1:                    # one coordinate: its value, the same at every point
        q0, qdot0 = float(q0[0]), float(qdot0[0])
    return lyapunov_grid(job.scene.system, params, q0, qdot0,
                         periods=spectrum.periods, transient=spectrum.transient,
                         progress=job.grid_progress)


def _branch_tables(job, branches, method):
    from ..scenes import storable
    points = storable(branches.to_dataframe())
    points["method"] = method
    bifs = branches.bifurcation_table()
    bifs["method"] = method
    shown = bifs[["branch_label", "kind", branches.parameter, "accuracy", "criticality",
                  "born_branch"]]
    job.table("continuation", points, "bifurcations")
    job.table("continuation_bifurcations", bifs, "bifurcations")
    job.shown.setdefault("bifurcations", []).append(
        ("Bifurcations located on the branches (the parameter with its certified "
         "accuracy; born_branch: the branch followed from it, −1 none)", shown))
    job.numbers["bifurcations"] = [{"branch": int(i), "kind": b.kind,
                                    "parameter": float(b.parameter),
                                    "accuracy": float(b.accuracy)}
                                   for i, b in branches.bifurcations]
    return ["continuation", "continuation_bifurcations"]


# -- the captions --------------------------------------------------------------------------

def _branch_caption(branches, diagram):
    p = branches.parameter
    parts = []
    for i, br in enumerate(branches.branches):
        bifs = [f"{b.kind.replace('_', ' ')} at {p} = {b.parameter:.7g} ± {b.accuracy:.1g}"
                + (f" ({b.criticality})" if b.criticality else "")
                for b in br.bifurcations if not (i > 0 and b.index == 0)]
        span = f"{br.points.parameter.min():.4g} to {br.points.parameter.max():.4g}"
        parts.append(f"the {br.label} ({len(br.points)} points, {p} from {span}, "
                     f"{br.status}): " + ("; ".join(bifs) if bifs else "no bifurcation"))
    text = (f"Continuation in {p} (pseudo-arclength on the period map, multipliers at every "
            f"point; top: stable solid, unstable dashed): " + "; ".join(parts) + ".")
    if branches.notes:
        text += " Not followed: " + "; ".join(branches.notes) + "."
    if diagram is not None and diagram.parameter == p:
        text += _agreement(branches, diagram)
    return text


def _agreement(branches, diagram) -> str:
    """Where the continued branch is a state that persists (an equilibrium: the same state
    at every point), whether the diagram's dots stay on it (every sample of a start within
    0.01 rad) exactly where the continuation calls it stable; the values within one grid
    step of a bifurcation are left out (a transient there decays as slowly as the
    multiplier is close to the unit circle)."""
    main = branches.main
    n = len(main.coordinates)
    state = main.points.state
    if main.periods != 1 or len(state) < 2 or np.ptp(state, axis=0).max() > 1e-9:
        return ""
    d = diagram.q - state[0, :n]
    for name in diagram.angles:
        j = diagram.coordinates.index(name)
        d[..., j] = (d[..., j] + np.pi) % (2 * np.pi) - np.pi
    with np.errstate(invalid="ignore"):
        near = (np.abs(d).max(axis=(2, 3)) < 0.01).any(axis=1)       # (V,): a start stays
    values = np.asarray(diagram.values, float)
    order = np.argsort(main.points.parameter)
    k = np.clip(np.searchsorted(main.points.parameter[order], values), 0, len(order) - 1)
    stable = main.points.stable[order][k]
    step = _step(values)
    far = np.ones(values.shape, bool)
    for b in main.bifurcations:
        far &= np.abs(values - b.parameter) > step
    inside = (values >= main.points.parameter.min()) & (values <= main.points.parameter.max())
    check = far & inside
    if not check.any():
        return ""
    agree = int((near == stable)[check].sum())
    where = ", ".join(f"{c} = {q:.4g}" for c, q in zip(main.coordinates, state[0, :n],
                                                        strict=True))
    return (f" The bifurcation diagram agrees at {agree} of {int(check.sum())} of its values "
            f"(those more than a grid step, {step:.2g}, from a bifurcation): its dots stay "
            f"at {where} exactly where the continuation finds that state stable.")


def _step(values):
    d = np.diff(np.sort(np.asarray(values, float)))
    return float(np.median(d)) if d.size else float("nan")


def _diagram_caption(diagram):
    top = min(64, diagram.periods - 1)
    per = diagram.orbit_period(max_period=top)
    found, counts = np.unique(per, return_counts=True)
    seen = ", ".join(f"{k}: {c}" for k, c in zip(found.tolist(), counts.tolist(), strict=True)
                     if k > 0)
    none = int(counts[found == 0].sum())
    return (f"Bifurcation diagram (middle): {diagram.values.size} values of "
            f"{diagram.parameter} × {diagram.q.shape[1]} start(s), {diagram.periods} strobe "
            f"samples each after {diagram.transient} drive periods ({diagram.method}, rtol "
            f"{diagram.rtol:g}); the periods of the runs (value × start: how many): "
            f"{seen or 'none'}, and {none} with no period up to {top} (chaos, a longer or "
            "quasi-periodic orbit, or a transient not yet settled).")


def _lyapunov_caption(job, s):
    lam = ", ".join(f"{x:.4g} ± {e:.2g}" for x, e in zip(s.exponents, s.error, strict=True))
    lead, err = float(s.exponents[0]), float(s.error[0])
    verdict = ("chaotic: λ1 > 0 beyond its error" if lead - err > 0 else
               "regular: λ1 < 0 beyond its error (an attracting periodic orbit)"
               if lead + err < 0 else "undecided: |λ1| within its error (quasi-periodic "
               "or marginal)")
    state = ", ".join(f"{c} = {q:g}" for c, q in zip(job.scene.system.coordinates,
                                                     job.scene.q0, strict=True))
    text = (f"Lyapunov exponents at the scene's drive (A = {job.A:g} m, ω = {job.omega:g} "
            f"rad/s) from {state}, {s.periods} drive periods after {s.transient} "
            f"(Benettin's method on the variational equations): λ = {lam} 1/s; {verdict}.")
    job.numbers.update(lyapunov_exponents=[float(x) for x in s.exponents],
                       lyapunov_errors=[float(x) for x in s.error])
    if s.complete:
        total = float(s.exponents.sum())
        text += f" Their sum is {total:.9g} ± {s.sum_error:.2g} 1/s"
        if job.pend is not None:
            # the damped pendulum's phase-space contraction: tr J = −γ everywhere
            text += (f", the phase-space contraction −γ = {-job.pend.damping:g} 1/s exactly "
                     f"(tr J of the pendulum), off by {abs(total + job.pend.damping):.2g}")
        text += "."
    return text


def _line_caption(line, parameter):
    chaotic = np.asarray(line.chaotic)
    values = np.broadcast_to(np.asarray(line.params[parameter], float), line.shape)
    text = (f"Bottom: the largest exponent along {parameter} from the same start "
            f"({line.periods} periods after {line.transient}, J v by a directional "
            f"difference): positive beyond its error at {int(chaotic.sum())} of "
            f"{chaotic.size} values")
    if chaotic.any():
        text += (f", from {parameter} = {values[chaotic].min():.4g} to "
                 f"{values[chaotic].max():.4g}")
    return text + "."


# -- the figure ---------------------------------------------------------------------------------

def _figure(job, branches, diagram, spectrum, line):
    panels = [k for k, r in (("branches", branches), ("diagram", diagram)) if r is not None]
    panels.append("line" if line is not None else "running" if spectrum is not None else None)
    panels = [p for p in panels if p is not None]
    fig = new_figure((8.5, 3.1 * len(panels) + 0.4))
    share = None
    same = len({r.parameter for r in (branches, diagram) if r is not None}) <= 1
    axes = {}
    for k, name in enumerate(panels):
        ax = fig.add_subplot(len(panels), 1, k + 1,
                             sharex=share if same and name != "running" else None)
        if name != "running":
            share = share or ax
        axes[name] = ax
    if branches is not None:
        ax = axes["branches"]
        branches.figure(ax=ax)
        ax.set_title(f"Branches of periodic orbits in {branches.parameter} (continuation)",
                     fontsize=10)
    if diagram is not None:
        ax = axes["diagram"]
        diagram.figure(ax=ax, size=2.0 if diagram.values.size < 60 else 0.6)
        if branches is not None and branches.parameter == diagram.parameter:
            for i, b in branches.bifurcations:
                if i > 0 and b.index == 0:
                    continue                          # the point it was born at, drawn once
                ax.axvline(b.parameter, color="C3", lw=0.7, ls=":")
                ax.annotate(b.kind.replace("_", " "), (b.parameter, 1.0),
                            xycoords=("data", "axes fraction"), rotation=90, fontsize=7,
                            color="C3", ha="right", va="top")
    if line is not None:
        _draw_line(axes["line"], line, diagram.parameter, job, spectrum)
    elif spectrum is not None:
        _draw_running(axes["running"], spectrum)
    return fig


def _draw_line(ax, line, parameter, job, spectrum):
    x = np.broadcast_to(np.asarray(line.params[parameter], float), line.shape)
    lam, err = np.asarray(line.exponent, float), np.asarray(line.error, float)
    ax.fill_between(x, lam - err, lam + err, color="0.8", lw=0, label="± error")
    ax.plot(x, lam, "k-", lw=0.9, label="largest exponent λ1")
    chaotic = np.asarray(line.chaotic)
    ax.plot(x[chaotic], lam[chaotic], "o", color="C3", ms=2.5, label="λ1 > 0: chaos")
    ax.axhline(0.0, color="0.4", lw=0.6)
    here = job.params.get(parameter)
    if here is not None:
        ax.errorbar([here], [spectrum.exponents[0]], yerr=[spectrum.error[0]], fmt="D",
                    color="C0", ms=5, capsize=3, label="the scene's drive")
    ax.set_xlabel(parameter)
    ax.set_ylabel("λ1 (1/s)")
    ax.set_title(f"Largest Lyapunov exponent along {parameter}", fontsize=10)
    ax.legend(fontsize=7, loc="best")


def _draw_running(ax, s):
    for k in range(s.running.shape[1]):
        ax.plot(s.times, s.running[:, k], lw=0.9, color=f"C{k}", label=f"λ{k + 1}")
        ax.axhspan(s.exponents[k] - s.error[k], s.exponents[k] + s.error[k], color=f"C{k}",
                   alpha=0.15, lw=0)
    ax.axhline(0.0, color="0.4", lw=0.6)
    ax.set_xlabel("time into the record (s)")
    ax.set_ylabel("running estimate (1/s)")
    ax.set_title("Lyapunov exponents at the scene's drive: convergence (band: ± error)",
                 fontsize=10)
    ax.legend(fontsize=7, loc="best")
