"""``kapitza continue``, ``kapitza bifurcation``, ``kapitza lyapunov``: the frontier's
analyses of a scene file, or of the pendulum and the drive the options describe.

Both ways end in a scene, checked as a scene file is (:func:`kapitza.scenes.read_scene_data`):
the scene file's tables with the options over its ``[analyses.<name>]``, or a pendulum
scene built from ``--l``, ``--g``, ``--damping``, ``--drive``, the drive (``--A``,
``--omega``, ...) and ``--theta0``.  A problem the check finds is named by its option where
an option set it.  The analysis runs as :meth:`kapitza.Scene.run` runs it
(:func:`kapitza.scenes.run_analysis`), so the numbers are the scene's.
"""
from __future__ import annotations

import copy
from pathlib import Path

import numpy as np

from ._output import EXIT_OK, as_table, emit, records, save_figure, write_frame
from ._parsing import (
    UsageError,
    data_file,
    number_list,
    parse_amplitude,
    parse_frequency,
    refuse_with_scene,
    writable,
)
from ._parsing import read_scene as read_scene_file

__all__ = ["FRONTIER_COMMANDS"]

#: The drive's options, as the command line spells them, and their attribute names.
_DRIVE_OPTIONS = (("--A", "A"), ("--A-over-l", "A_over_l"), ("--omega", "omega"),
                  ("--f", "f"), ("--omega-over-omega0", "omega_over_omega0"))

#: Scene keys of a pendulum built from the options → the option that set them.
_OPTION_KEYS = {"parameters.l": "--l", "parameters.g": "--g", "effects.damping.gamma":
                "--damping", "effects.drive.amplitude": "--A", "effects.drive.omega": "--omega",
                "initial.theta": "--theta0", "initial.theta_dot": "--theta-dot0"}


def _drive_given(args):
    return [name for name, key in _DRIVE_OPTIONS if getattr(args, key) is not None]


def _optional(parse, args, **kw):
    """``parse(args)``, or None where the option is not given."""
    try:
        return parse(args, **kw)
    except UsageError as e:
        if str(e).startswith("give the drive"):
            return None
        raise


def _pendulum_data(args, A, omega):
    """The scene's tables for the pendulum of the options."""
    effects = {"gravity": True,
               "drive": {"direction": args.drive, "amplitude": A, "omega": omega}}
    if args.damping:
        effects["damping"] = {"gamma": args.damping}
    return {"schema": 1, "title": "the pendulum of the command line",
            "system": {"name": "pendulum"}, "parameters": {"l": args.l, "g": args.g},
            "effects": effects,
            "initial": {"theta": 0.1 if args.theta0 is None else args.theta0,
                        "theta_dot": 0.0 if args.theta_dot0 is None else args.theta_dot0}}


def _scene(args, analysis, settings, *, A=None, omega=None):
    """The scene of the command: the file's (its ``[analyses.<analysis>]`` with the options'
    ``settings`` over it, its other analyses and its sweep left out), or the pendulum of the
    options at the drive (A, ω) (the parsed --A and ω where not given)."""
    from ..scenes import Scene, SceneError, read_scene_data
    if args.scene is not None:
        given = _drive_given(args)
        if given:
            raise UsageError(f"{', '.join(given)}: the scene sets the drive; give either a "
                             "scene or the drive options.")
        refuse_with_scene(args, "l", "g", "damping", "drive")
        base = read_scene_file(args.scene)
        data = copy.deepcopy(base.spec.data)
        own = data.get("analyses", {}).get(analysis, {})
        data["analyses"] = {analysis: {**(own if isinstance(own, dict) else {}), **settings}}
        data.pop("sweep", None)
        data.pop("output", None)
        coords = list(base.system.coordinates)
        for value, suffix in ((args.theta0, ""), (args.theta_dot0, "_dot")):
            if value is None:
                continue
            if len(coords) != 1:
                raise UsageError(f"--theta0/--theta-dot0: the scene has the coordinates "
                                 f"{coords}; set its initial state in its [initial].")
            data.setdefault("initial", {})[coords[0] + suffix] = value
        text, source = base.spec.text, base.spec.source
    else:
        A = _optional(parse_amplitude, args) if A is None else A
        omega = _optional(parse_frequency, args) if omega is None else omega
        if A is None:
            raise UsageError("give the drive amplitude: --A (m) or --A-over-l (or a scene file).")
        if omega is None:
            raise UsageError("give the drive frequency: --omega (rad/s), --f (Hz) or "
                             "--omega-over-omega0 (or a scene file).")
        data = _pendulum_data(args, A, omega)
        data["analyses"] = {analysis: dict(settings)}
        text, source = "", "<command line>"
    try:
        return Scene(read_scene_data(data, text=text, source=source))
    except SceneError as e:
        raise UsageError(_explain(e, analysis, settings, args.scene is None)) from None


def _explain(err, analysis, settings, from_options):
    """A scene's problems, each named by the option that set the key where one did."""
    lines = []
    for p in err.problems:
        key = p.key
        option = None
        prefix = f"analyses.{analysis}."
        name = key[len(prefix):].split("[")[0].split(".")[0] if key.startswith(prefix) else ""
        if name and (name in settings or from_options):
            option = "--" + name.replace("_", "-")
        elif from_options:
            option = _OPTION_KEYS.get(key)
        lines.append(f"{option}: {p.message}" if option else p.format(err.source))
    return "\n  ".join(lines)


def _values(text, name):
    """``START:STOP:NUM`` as a scene's range, ``a,b,c`` as a list."""
    if text is None:
        return None
    if ":" in text:
        values = number_list(text, name)
        return {"start": float(values[0]), "stop": float(values[-1]), "num": int(values.size)}
    return [float(v) for v in number_list(text, name)]


def _states(text, name):
    """``a,b`` (one coordinate per start) or ``a1 a2,b1 b2``: a list of starts."""
    if text is None:
        return None
    try:
        rows = [[float(x) for x in part.split()] for part in text.split(",") if part.strip()]
    except ValueError:
        raise UsageError(f"{name}: expected angles a,b,c (several coordinates: a1 a2,b1 b2), "
                         f"got {text!r}.") from None
    if not rows:
        raise UsageError(f"{name}: no values in {text!r}.")
    return [r[0] if len(r) == 1 else r for r in rows]


def _about(text):
    if text is None or text in ("inverted", "hanging", "auto"):
        return text
    try:
        return [float(x) for x in text.replace(",", " ").split()]
    except ValueError:
        raise UsageError(f"--about: expected inverted, hanging, auto or angles (rad), got "
                         f"{text!r}.") from None


def _given(**settings):
    return {k: v for k, v in settings.items() if v is not None}


def _write_figure(fig, path):
    return save_figure(fig, path)


# -- continue ---------------------------------------------------------------------------------

def _continue(args) -> int:
    from ..scenes import run_analysis, storable
    settings = _given(parameter=args.parameter, start=args.start, stop=args.stop,
                      periods=args.periods, switch=args.switch, max_points=args.max_points,
                      about=_about(args.about))
    parameter = settings.get("parameter", "A")
    data_path = data_file(args.data) or writable("--out", Path(args.out).with_suffix(".csv"))
    writable("--out", args.out)
    start = args.start
    scene = _scene(args, "continuation", settings,
                   A=start if parameter == "A" and start is not None else None,
                   omega=start if parameter == "omega" and start is not None else None)
    branches, method = run_analysis(scene, "continuation")
    points = storable(branches.to_dataframe())
    points["method"] = method
    bifs = branches.bifurcation_table()
    bifs["method"] = method
    write_frame(points, data_path)
    bif_path = write_frame(bifs, data_path.with_name(f"{data_path.stem}_bifurcations"
                                                     f"{data_path.suffix}"))
    png = _write_figure(branches.figure(), args.out)
    p = branches.parameter
    data = {"scene": scene.spec.source, "parameter": p, "method": method,
            "branches": [{"branch": i, "label": br.label, "periods": br.periods,
                          "points": len(br.points), "status": br.status,
                          "message": br.message, "start": float(br.points.parameter[0]),
                          "end": float(br.points.parameter[-1])}
                         for i, br in enumerate(branches.branches)],
            "bifurcations": records(bifs.drop(columns=["method"])),
            "notes": list(branches.notes), "figure": png, "data": data_path,
            "bifurcations_data": bif_path}
    lines = [f"continuation in {p} ({method}):"]
    for i, br in enumerate(branches.branches):
        lines.append(f"  branch {i}: {br.label}, {len(br.points)} points, {p} from "
                     f"{br.points.parameter[0]:.6g} to {br.points.parameter[-1]:.6g} "
                     f"({br.status})")
    if len(bifs):
        lines += ["bifurcations:", as_table(bifs[["branch", "kind", p, "accuracy",
                                                  "criticality", "born_branch"]])]
    else:
        lines.append("no bifurcation on the branch.")
    lines += [*(f"not followed: {n}" for n in branches.notes),
              f"figure: {png}", f"data: {data_path}, {bif_path}"]
    emit(args, data, "\n".join(lines))
    return EXIT_OK


# -- bifurcation --------------------------------------------------------------------------------

def _bifurcation(args) -> int:
    from ..scenes import run_analysis
    values = _values(args.values, "--values")
    settings = _given(parameter=args.parameter, values=values,
                      starts=_states(args.starts, "--starts"), periods=args.periods,
                      transient=args.transient)
    if values is None and args.scene is None:
        raise UsageError("--values: missing; the values of the parameter (--parameter, "
                         "default A), START:STOP:NUM or a,b,c.")
    parameter = settings.get("parameter", "A")
    first = None
    if values is not None:
        first = values["start"] if isinstance(values, dict) else values[0]
    data_path = data_file(args.data) or writable("--out", Path(args.out).with_suffix(".csv"))
    writable("--out", args.out)
    scene = _scene(args, "bifurcation_diagram", settings,
                   A=first if parameter == "A" else None,
                   omega=first if parameter == "omega" and first else None)
    diagram, method = run_analysis(scene, "bifurcation_diagram")
    frame = diagram.to_dataframe()
    frame["method"] = method
    write_frame(frame, data_path)
    # dots big enough to see where there are few values, fine where there are many
    png = _write_figure(diagram.figure(size=1.5 if diagram.values.size <= 80 else 0.5),
                        args.out)
    per = diagram.orbit_period(max_period=min(64, diagram.periods - 1))
    found, counts = np.unique(per, return_counts=True)
    data = {"scene": scene.spec.source, "parameter": diagram.parameter,
            "values": diagram.values, "starts": diagram.q0, "periods": diagram.periods,
            "transient": diagram.transient, "method": method,
            "orbit_period": per, "figure": png, "data": data_path,
            "seconds": diagram.wall_time}
    seen = ", ".join(f"{'none' if k == 0 else k}: {c}" for k, c in zip(found.tolist(),
                                                                       counts.tolist(),
                                                                       strict=True))
    emit(args, data, f"bifurcation diagram over {diagram.values.size} values of "
         f"{diagram.parameter} × {diagram.q.shape[1]} start(s), {diagram.periods} strobe "
         f"samples after {diagram.transient} periods ({method}), {diagram.wall_time:.1f} s\n"
         f"periods found (value × start: how many; none = no period ≤ "
         f"{min(64, diagram.periods - 1)}): {seen}\nfigure: {png}\ndata: {data_path}")
    return EXIT_OK


# -- lyapunov -----------------------------------------------------------------------------------

def _exponents(text):
    if text is None or text in ("all", "largest"):
        return text
    try:
        return int(text)
    except ValueError:
        raise UsageError(f"--exponents: expected all, largest or a whole number, got "
                         f"{text!r}.") from None


def _lyapunov(args) -> int:
    from ..scenes import run_analysis
    settings = _given(periods=args.periods, transient=args.transient,
                      exponents=_exponents(args.exponents))
    A = omega = None
    if args.scene is None:
        A = _optional(parse_amplitude, args, grid=True)
        omega = _optional(parse_frequency, args, grid=True)
        if A is not None and omega is not None and (A.size > 1 or omega.size > 1):
            return _lyapunov_grid(args, settings, A, omega)
        A, omega = (None if x is None else float(x[0]) for x in (A, omega))
    if "log_omega" in getattr(args, "given", ()):
        raise UsageError("--log-omega: for a grid of ω given as START:STOP:NUM; here is one "
                         "drive" + (" (the scene's)" if args.scene is not None else "") + ".")
    if args.out or args.data:
        raise UsageError("--out, --data: for a grid of several --A or ω values.")
    scene = _scene(args, "lyapunov", settings, A=A, omega=omega)
    s, method = run_analysis(scene, "lyapunov")
    lead, err = float(s.exponents[0]), float(s.error[0])
    chaotic = bool(lead - err > 0)
    p = scene.params
    data = {"scene": scene.spec.source, "A": p["A"], "omega": p["omega"],
            "q0": s.q0, "qdot0": s.qdot0, "exponents": s.exponents, "error": s.error,
            "sum": float(s.exponents.sum()), "sum_error": s.sum_error,
            "complete": s.complete, "per_period": s.per_period, "period": s.period,
            "periods": s.periods, "transient": s.transient, "chaotic": chaotic,
            "status": s.status, "method": method, "seconds": s.wall_time}
    verdict = ("chaotic (λ1 > 0 beyond its error)" if chaotic else
               "regular (λ1 < 0 beyond its error)" if lead + err < 0 else
               "undecided (|λ1| within its error)")
    lam = "\n".join(f"  λ{k + 1} = {x:.6g} ± {e:.2g} 1/s  ({x * s.period:.4g} per period)"
                    for k, (x, e) in enumerate(zip(s.exponents, s.error, strict=True)))
    total = (f"\n  sum {s.exponents.sum():.9g} ± {s.sum_error:.2g} 1/s (the mean of tr J)"
             if s.complete else "")
    emit(args, data, f"Lyapunov exponents at A = {p['A']:.6g} m, ω = {p['omega']:.6g} rad/s "
         f"from q0 = {s.q0.tolist()}, {s.periods} periods after {s.transient} ({method}):\n"
         f"{lam}{total}\n  {verdict}; status {s.status}")
    return EXIT_OK


def _lyapunov_grid(args, settings, A, omega) -> int:
    """λ_max over the A × ω grid of the options (kapitza.chaos.lyapunov_grid)."""
    from ..chaos import lyapunov_grid
    if "exponents" in settings:
        raise UsageError("--exponents: a grid computes the largest exponent only.")
    data_path = data_file(args.data)
    if args.out:
        writable("--out", args.out)
    scene = _scene(args, "lyapunov", settings, A=float(A[0]), omega=float(omega[0]))
    s = scene.analyses["lyapunov"]
    params = {**scene.params, "A": A[:, None], "omega": omega[None, :]}
    q0, qdot0 = scene.q0, scene.qdot0
    if q0.size == 1:                    # one coordinate: its value, the same at every point
        q0, qdot0 = float(q0[0]), float(qdot0[0])
    grid = lyapunov_grid(scene.system, params, q0, qdot0,
                         periods=s.get("periods", 1000), transient=s.get("transient", 100))
    frame = grid.to_dataframe()
    frame["method"] = "lyapunov: Benettin's method, largest exponent (directional difference)"
    if data_path is not None:
        write_frame(frame, data_path)
    png = None
    if args.out:
        png = _write_figure(_grid_figure(grid, A, omega), args.out)
    chaotic = np.asarray(grid.chaotic)
    data = {"A": A, "omega": omega, "shape": list(grid.shape), "periods": grid.periods,
            "transient": grid.transient, "chaotic_points": int(chaotic.sum()),
            "points": int(chaotic.size), "rows": records(frame), "figure": png,
            "data": data_path, "seconds": grid.wall_time}
    emit(args, data, f"largest Lyapunov exponent over {A.size} × {omega.size} (A, ω), "
         f"{grid.periods} periods after {grid.transient}: {int(chaotic.sum())} of "
         f"{chaotic.size} points chaotic (λ1 > 0 beyond its error), {grid.wall_time:.1f} s\n"
         + as_table(frame.drop(columns=["method"]).head(40))
         + (f"\nfigure: {png}" if png else "") + (f"\ndata: {data_path}" if data_path else ""))
    return EXIT_OK


def _grid_figure(grid, A, omega):
    """The chaos map over (ω, A), or λ1 along the one varying axis."""
    if A.size > 1 and omega.size > 1:
        return grid.figure()
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure
    fig = Figure(figsize=(6.4, 4.0), layout="constrained")
    FigureCanvasAgg(fig)
    ax = fig.add_subplot()
    x, name = (A, "A (m)") if A.size > 1 else (omega, "ω (rad/s)")
    lam, err = np.ravel(grid.exponent), np.ravel(grid.error)
    ax.fill_between(x, lam - err, lam + err, color="0.8", lw=0, label="± error")
    ax.plot(x, lam, "k-", lw=0.9, label="λ1")
    ax.axhline(0.0, color="0.4", lw=0.6)
    ax.set_xlabel(name)
    ax.set_ylabel("largest Lyapunov exponent λ1 (1/s)")
    ax.legend(fontsize=8)
    return fig


#: The frontier's commands by name.
FRONTIER_COMMANDS = {"continue": _continue, "bifurcation": _bifurcation, "lyapunov": _lyapunov}
