"""The commands, one function each: ``command(args) -> exit code``, reading the parsed
options and calling the public API."""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from .. import _arguments as arguments
from ._catalogue import catalogue_summary
from ._frontier_commands import FRONTIER_COMMANDS
from ._output import (
    EXIT_DISAGREEMENT,
    EXIT_INTERRUPTED,
    EXIT_OK,
    as_table,
    emit,
    plain,
    records,
    save_figure,
    say,
    with_error,
    write_frame,
)
from ._parsing import (
    UsageError,
    data_file,
    drive_point,
    over_omega0,
    parse_amplitude,
    parse_frequency,
    pendulum_from,
    read_scene,
    refuse_with_scene,
    writable,
)


def _predict(args) -> int:
    pend = pendulum_from(args)
    A, omega = parse_amplitude(args), parse_frequency(args)
    avg = pend.averaged(A, omega, order=args.order, warn=False)
    about = args.about or ("tilted" if args.drive == "horizontal" else "inverted")
    if args.drive == "horizontal" and about == "tilted" and (A * omega) ** 2 <= 2 * args.g * args.l:
        about = "hanging"
        say("predict: (Aω)² ≤ 2gl, no tilted state; the Floquet analysis is about the "
             "orbit near θ = 0.")
    exact = pend.floquet(A, omega, about=about, tol=args.tol)
    equilibria = {e.name: plain(e) for e in avg.equilibria}
    if args.drive == "horizontal":
        floquet = {"about": about, "kind": "periodic orbit", "stable": bool(exact.stable),
                   "omega_slow": exact.omega_slow, "theta_mean": float(exact.q_mean[0]),
                   "multipliers_abs": np.abs(exact.multipliers),
                   "error_estimate": exact.error_estimate}
    else:
        floquet = {"about": about, "kind": "equilibrium", "stable": bool(exact.stable),
                   "omega_slow": exact.omega_slow, "trace": exact.trace,
                   "multipliers_abs": np.abs(exact.multipliers),
                   "boundary": exact.boundary, "error_estimate": exact.error_estimate}
    data = {**drive_point(args, A, omega), "averaging": {"order": args.order, **equilibria},
            "floquet": floquet}
    lines = [f"drive {args.drive}: A = {A:.6g} m (A/l = {A / args.l:.6g}), ω = {omega:.6g} rad/s "
             f"(ω/ω0 = {over_omega0(omega, args):.6g}), l = {args.l:g} m, "
             f"g = {args.g:g} m/s², γ = {args.damping:g} 1/s",
             f"averaging (order {args.order}):"]
    for e in avg.equilibria:
        lines.append(f"  {e.name:9s} θ = {float(e.theta):.6g} rad  exists {bool(e.exists)}  "
                     f"stable {bool(e.stable)}  Ω = {float(e.omega_slow):.6g} rad/s  "
                     f"valid {bool(e.valid)}")
    lines.append(f"Floquet about {about} ({floquet['kind']}): stable {floquet['stable']}  "
                 f"Ω = {float(np.max(exact.omega_slow)):.6g} rad/s")
    emit(args, data, "\n".join(lines))
    return EXIT_OK


def _window(args) -> int:
    pend = pendulum_from(args)
    omega = parse_frequency(args, grid=True)
    exact = pend.window(omega, about=args.about, tol=args.tol)
    frame = exact.to_dataframe()
    frame.insert(1, "omega_over_omega0", frame["omega"] / pend.omega0)
    frame["A_min_over_l"] = frame["A_min"] / args.l
    frame["A_max_over_l"] = frame["A_max"] / args.l
    if args.about == "inverted":
        approx = pend.window(omega, method="averaging", order=args.order)
        frame["A_min_averaging"] = np.ravel(np.broadcast_to(approx.A_min, np.shape(omega)))
        frame["A_max_averaging"] = np.ravel(np.broadcast_to(approx.A_max, np.shape(omega)))
        frame["averaging_valid"] = np.ravel(np.broadcast_to(approx.valid, np.shape(omega)))
    data = {"pendulum": drive_point(args, 0.0, 0.0)["pendulum"], "about": args.about,
            "averaging_order": args.order if args.about == "inverted" else None,
            "rows": records(frame)}
    emit(args, data, f"window of stabilising amplitudes about {args.about} (exact, Floquet"
          + (f"; averaging order {args.order} beside it" if args.about == "inverted" else "")
          + "):\n" + as_table(frame))
    return EXIT_OK


#: Peak memory of the map's outputs per grid point (bytes), beyond the figure's fixed
#: ~50 MB: the table, its CSV or Parquet buffers and the image's arrays (tracemalloc over
#: 200 × 100 and 200 × 600 grids: ~110 for CSV, ~210 for Parquet; rounded up).
MAP_OUTPUT_BYTES_PER_POINT = 220


def _map_outputs(args, result, pend, partial=False):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from ..figures import stability_map_figure

    png = Path(args.out)
    data_path = data_file(args.data) or png.with_suffix(".csv")
    frame = result.to_dataframe()
    write_frame(frame, data_path)
    overlays = []
    if args.about == "inverted" and pend.drive == "vertical" and not partial:
        fine = np.geomspace(result.omega.min(), result.omega.max(), 200) \
            if result.omega.min() > 0 else np.linspace(result.omega.min(), result.omega.max(), 200)
        fine = fine[fine > 0]
        if fine.size:
            overlays.append(pend.window(fine, method="averaging", order=1))
    fig = stability_map_figure(result, overlays=overlays, dimensionless=args.dimensionless,
                               log_omega=args.log_omega)
    save_figure(fig, png)
    plt.close(fig)
    return png, data_path, frame


def _map(args) -> int:
    from ..results import ComputationInterrupted
    pend = pendulum_from(args)
    if args.about is None:
        args.about = "hanging" if pend.drive == "horizontal" else "inverted"
    elif pend.drive == "vertical" and args.about not in ("inverted", "hanging"):
        raise UsageError(f"--about {args.about}: the vertical drive keeps the equilibria "
                         "inverted and hanging; tilted orbits need --drive horizontal.")
    A = parse_amplitude(args, grid=True)
    omega = parse_frequency(args, grid=True)
    png = writable("--out", args.out)
    data_file(args.data) or writable("--out", png.with_suffix(".csv"))
    # the API checks its own arrays; the table, the data file and the figure come on top
    arguments.check_grid_memory("--A × --omega", (A.size, omega.size),
                                MAP_OUTPUT_BYTES_PER_POINT, where="the table, data file "
                                "and figure of ")
    try:
        result = pend.stability_map(A, omega, about=args.about, trace=args.trace, tol=args.tol)
    except ComputationInterrupted as stop:
        png, data_path, _ = _map_outputs(args, stop.result, pend, partial=True)
        say(f"map: interrupted; {int(stop.computed.sum())} of {stop.computed.size} points "
             f"finished, saved (the others NaN) in {data_path} and {png}.")
        return EXIT_INTERRUPTED
    png, data_path, frame = _map_outputs(args, result, pend)
    stable = np.asarray(result.stable, bool)
    data = {"pendulum": drive_point(args, 0.0, 0.0)["pendulum"], "about": args.about,
            "method": result.method, "shape": list(stable.shape),
            "stable_points": int(stable.sum()), "points": int(stable.size),
            "error_estimate": result.error_estimate, "figure": png, "data": data_path,
            "A": result.A, "omega": result.omega}
    emit(args, data, f"stability map about {args.about} ({result.method}): "
          f"{int(stable.sum())} of {stable.size} points stable\nfigure: {png}\ndata: {data_path}")
    return EXIT_OK


def _measure(args) -> int:
    pend = pendulum_from(args)
    A, omega = parse_amplitude(args), parse_frequency(args)
    about = _angle_or_name(args.about)
    from ..results import ComputationInterrupted
    try:
        m = pend.measure(A, omega, theta0=args.theta0, theta_dot0=args.theta_dot0,
                         periods=args.periods, about=about, rtol=args.rtol)
        interrupted = False
    except ComputationInterrupted as stop:      # Ctrl-C: the run so far, measured
        m, interrupted = stop.result, True
        if m.status == "not_run":
            say("measure: interrupted before the run started; nothing was integrated.")
        else:
            say(f"measure: interrupted at t = {m.t_reached:.6g} s after {m.completed_periods} "
                f"of {args.periods} periods; the measurement below covers the run so far.")
    fields = {k: getattr(m, k) for k in ("stayed_up", "fall_time", "omega_slow",
                                         "omega_slow_error", "amplitude", "mean_angle",
                                         "growth_rate", "max_deviation", "about", "period",
                                         "periods", "status", "method", "rtol", "t_reached",
                                         "completed_periods")}
    data = {**drive_point(args, A, omega), "theta0": args.theta0, "theta_dot0": args.theta_dot0,
            "measurement": fields}
    # (None after a Ctrl-C that left no time for the fit: the interruption's message says why)
    slow = ("not fitted" if m.omega_slow is None
            else f"{with_error(m.omega_slow, m.omega_slow_error)} rad/s")
    amplitude = "not computed" if m.amplitude is None else f"{m.amplitude:.4g} rad"
    emit(args, data, f"released at θ0 = {args.theta0:.6g} rad, θ̇0 = {args.theta_dot0:g} rad/s, "
          f"{args.periods} periods of A = {A:.6g} m, ω = {omega:.6g} rad/s:\n"
          f"  stayed up {bool(m.stayed_up)}  fall time {m.fall_time:.6g} s\n"
          f"  Ω = {slow}  slow amplitude {amplitude}  "
          f"mean angle {m.mean_angle:.6g} rad\n"
          f"  status {m.status}")
    return EXIT_INTERRUPTED if interrupted else EXIT_OK


def _angle_or_name(text):
    """--about: a state's name as is, an angle (rad) as a number."""
    try:
        return float(text)
    except (TypeError, ValueError):
        return text


def _verify(args) -> int:
    pend = pendulum_from(args)
    A = parse_amplitude(args, grid=True)
    omega = parse_frequency(args, grid=True)
    data_path = data_file(args.data)
    v = pend.verify(A[:, None], omega[None, :], theta0=args.theta0, periods=args.periods,
                    tol=args.tol, rtol=args.rtol, line=None if args.fit_order else False)
    agreement, every = v.agreement, v.disagreements
    counted = every[every["within_validity"].astype(bool)]
    reported = every[~every["within_validity"].astype(bool)]
    outside = v.outside_validity
    per_method = {m: int((outside["method"] == m).sum()) for m in v.methods}
    if data_path:
        write_frame(v.to_dataframe(), data_path)
    data = {"pendulum": drive_point(args, 0.0, 0.0)["pendulum"], "A": A, "omega": omega,
            "points": int(np.prod(v.shape)), "methods": list(v.methods),
            "agreement": records(agreement), "disagreements": records(every),
            "disagreements_within_validity": len(counted),
            "disagreements_outside_validity": len(reported),
            "outside_validity": per_method, "outside_validity_points": records(outside),
            "exponent": v.exponent, "exponent_error": v.exponent_error,
            "notes": list(v.notes), "data": data_path, "agree": bool(len(counted) == 0)}
    text = [f"verification over {len(A)} amplitudes × {len(omega)} frequencies "
            f"({int(np.prod(v.shape))} points):", as_table(agreement)]
    if args.fit_order:
        text.append(f"order of first-order averaging: {v.exponent:.3f} ± "
                    f"{v.exponent_error:.3f} (theory 2)")
    if any(per_method.values()):
        text.append("outside a method's validity (reported, not failed): " + ", ".join(
            f"{m} at {k} point(s)" for m, k in per_method.items() if k))
    if len(reported):
        text += [f"{len(reported)} disagreement(s) where a method is outside its validity "
                 "(not failures):", as_table(reported)]
    if len(counted):
        text += [f"{len(counted)} disagreement(s) beyond the tolerances of methods that both "
                 "claim validity there:", as_table(counted)]
    else:
        text.append("all methods agree within their tolerances where they claim validity.")
    emit(args, data, "\n".join(text))
    if len(counted):
        say(f"kapitza verify: {len(counted)} disagreement(s) between methods that both claim "
            "validity (exit code 1).")
        return EXIT_DISAGREEMENT
    return EXIT_OK


def _animate(args) -> int:
    from ..animation import pendulum_animation, system_animation
    writable("--out", args.out)
    scenes = [read_scene(path) for path in args.scene]
    if scenes:
        given = [n for n, k in (("--A", "A"), ("--A-over-l", "A_over_l"), ("--omega", "omega"),
                                ("--f", "f"), ("--omega-over-omega0", "omega_over_omega0"))
                 if getattr(args, k) is not None]
        if given:
            raise UsageError(f"{', '.join(given)}: the scene sets the drive; give either "
                             "scenes or the drive options.")
        refuse_with_scene(args, "l", "g", "damping", "drive", "theta0")
    pend = scenes[0].pendulum if len(scenes) == 1 else None
    if scenes and (pend is None or pend.drive != "vertical"):
        refuse_with_scene(args, "A_fall", why="each scene is a panel of its own; none falls "
                          "beside it")
    try:
        if scenes and (pend is None or pend.drive != "vertical"):
            # chains (or several scenes): each scene a panel, from its own [initial] state
            anim = system_animation(args.out, scenes, duration=args.duration, fps=args.fps,
                                    frames_per_period=args.frames_per_period,
                                    width=args.width, max_frames=args.max_frames,
                                    mode=args.mode)
            data, head, fate = _gif_summary(anim)
            data.update(scenes=list(args.scene), titles=list(anim.titles))
            emit(args, data, head + "".join(f"\n  {path}: {f}"
                                             for path, f in zip(args.scene, fate, strict=False)))
            return EXIT_OK
        if scenes:
            p = scenes[0].params
            A, omega, theta0 = float(p["A"]), float(p["omega"]), float(scenes[0].q0[0])
            l, g, damping = pend.l, pend.g, pend.damping
        else:
            if args.drive != "vertical":
                raise UsageError("--drive: animate shows the vertical drive only.")
            A, omega, theta0 = parse_amplitude(args), parse_frequency(args), args.theta0
            l, g, damping = args.l, args.g, args.damping
        anim = pendulum_animation(args.out, A=A, omega=omega, l=l, g=g, damping=damping,
                                  theta0=theta0, A_fall=args.A_fall, duration=args.duration,
                                  fps=args.fps, frames_per_period=args.frames_per_period,
                                  width=args.width, max_frames=args.max_frames,
                                  mode=args.mode)
    except KeyboardInterrupt:
        say(f"kapitza animate: interrupted; the frames finished are in {args.out}.")
        return EXIT_INTERRUPTED
    data, head, fate = _gif_summary(anim)
    data.update(A=anim.A[0], A_fall=anim.A[1], omega=omega, A_over_l=anim.A[0] / l,
                omega_over_omega0=omega / math.sqrt(g / l) if g > 0 else math.inf,
                theta0=theta0, window=anim.window,
                pendulum={"l": l, "g": g, "damping": damping, "omega0": math.sqrt(g / l)})
    emit(args, data, f"{head}\n  shaken A = {A:.4g} m (window {anim.window[0]:.4g} < A < "
          f"{anim.window[1]:.4g} m): {fate[0]}\n  A = {anim.A[1]:.4g} m: {fate[1]}")
    return EXIT_OK


def _gif_summary(anim):
    """What every animation reports: (JSON fields, the text's first line, per panel what
    happened)."""
    data = {"path": anim.path, "frames": anim.frames, "width": anim.width,
            "height": anim.height, "bytes": anim.bytes, "fps": anim.fps,
            "slow_motion": anim.slow_motion, "frames_per_period": anim.frames_per_period,
            "duration": float(anim.t[-1]), "periods_per_frame": anim.periods_per_frame,
            "stayed_up": anim.stayed_up, "fall_time": anim.fall_time,
            "floquet_stable": anim.floquet_stable, "seconds": anim.seconds}
    pace = (f"stroboscopic, one frame every {anim.periods_per_frame} drive periods, "
            if anim.periods_per_frame else "") + f"slow motion ×{anim.slow_motion:.3g}"
    head = (f"{anim.path}: {anim.frames} frames, {anim.width}×{anim.height} px, "
            f"{anim.bytes / 1e6:.2f} MB, {pace}")
    fate = ["not classified" if up is None else "stays up" if up else
            f"falls at t = {t:.3g} s" for up, t in zip(anim.stayed_up or (), anim.fall_time,
                                                    strict=False)]
    return data, head, fate


def _report(args) -> int:
    from ..report import ReportInterrupted, build_report
    writable("--out", args.out, folder=True)
    scene = None if args.scene is None else read_scene(args.scene)
    from ..warmup import start_background
    start_background()      # empty cache: the later sections' kernels compile on the other core
    try:
        report = build_report(scene, args.out, quick=args.quick)
    except ReportInterrupted:       # build_report has said what it kept and what is missing
        return EXIT_INTERRUPTED
    frame = report.to_dataframe()
    data = {"out": report.out, "index": report.index, "scene": report.scene,
            "seconds": report.seconds, "quick": report.quick,
            "sections": records(frame.drop(columns=["caption"])),
            "figures": {k: str(v) for k, v in report.figures.items()},
            "tables": {k: [str(p) for p in v] for k, v in report.tables.items()},
            "numbers": report.numbers, "failed": list(report.failed)}
    lines = [f"{row.section:15s} {row.status:8s} {row.seconds:6.1f} s"
             + (f"  ({row.reason})" if row.reason else "") for row in frame.itertuples()]
    emit(args, data, "\n".join([*lines, f"report: {report.index} ({report.seconds:.1f} s)"]))
    if report.failed:
        say(f"kapitza report: section(s) failed: {', '.join(report.failed)} (see the page).")
        return EXIT_DISAGREEMENT
    return EXIT_OK


_MAX_JSON_ROWS = 1000


def _run(args) -> int:
    scene = read_scene(args.scene)
    say(f"run: {scene.spec.source}: {scene.system.name}; analyses {list(scene.analyses)}")
    if scene.spec.sweep:        # run computes [analyses] at the scene's point only
        say(f"run: the [sweep] of {', '.join(scene.spec.sweep['analyses'])} is not run here; "
            f"run it with: kapitza sweep {args.scene}")
    res = scene.run(write=not args.no_write)
    tables = res.tables()
    data = {"scene": scene.spec.source, "system": scene.system.name, "seconds": res.seconds,
            "written": list(res.written), "analyses": {}}
    text = []
    for name, frame in tables.items():
        if len(frame) <= _MAX_JSON_ROWS:
            data["analyses"][name] = records(frame)
        else:
            data["analyses"][name] = {"rows": len(frame), "columns": list(frame.columns)}
        text += [f"== {name} ({len(frame)} rows)", as_table(frame.head(20))]
    if res.written:
        text.append("written: " + ", ".join(str(p) for p in res.written))
    emit(args, data, "\n".join(text))
    return EXIT_OK


def _sweep(args) -> int:
    from ..results import ComputationInterrupted
    if args.directory is not None:
        writable("--directory", args.directory, folder=True)
    wait = args.wait
    if wait is not True and wait is not False and not (math.isfinite(wait) and wait >= 0):
        raise UsageError(f"--wait: the seconds to wait must be a finite number ≥ 0, got "
                         f"{wait:g}; or give --wait alone to wait as long as it takes.")
    scene = read_scene(args.scene)
    try:
        result = scene.sweep(args.analysis, directory=args.directory,
                             tile_points=args.tile_points, wait=wait)
    except ComputationInterrupted as stop:
        partial = stop.result
        where = getattr(partial, "path", "the sweep's directory")
        say(f"sweep: interrupted; the finished tiles are saved in {where}; run the same "
             "command again to resume.")
        return EXIT_INTERRUPTED
    data = {"scene": scene.spec.source, "path": result.path, "size": result.size,
            "tiles": result.tiles, "computed": result.computed, "skipped": result.skipped,
            "seconds": result.seconds, "columns": _sweep_columns(result)}
    emit(args, data, f"sweep: {result.size} points in {result.tiles} tiles "
          f"({result.computed} computed, {result.skipped} already on disk), "
          f"{result.seconds:.1f} s\ndataset: {result.path}")
    return EXIT_OK


def _sweep_columns(result) -> list:
    """The dataset's column names, read from its Parquet schema: the rows themselves may
    not fit in memory (``result.frame`` is None then)."""
    if result.frame is not None:
        return list(result.frame.columns)
    import pyarrow as pa
    import pyarrow.parquet as pq
    common = Path(result.path) / "_common_metadata"     # a finished sweep's unified schema
    if common.exists():
        return list(pq.read_schema(common).names)
    parts = sorted(p for p in Path(result.path).glob("*.parquet") if p.name[0] not in "._")
    return list(pa.unify_schemas([pq.read_schema(p) for p in parts],
                                 promote_options="permissive").names) if parts else []


def _warmup(args) -> int:
    from ..warmup import warmup
    say("warmup: compiling (or loading from the cache) what the analyses need ...")
    seconds = warmup(verbose=False)
    emit(args, {"seconds": seconds}, f"warmup done in {seconds:.1f} s")
    return EXIT_OK


def _summary(args) -> int:
    import pandas as pd

    if not (0 < args.rtol < 1):
        raise UsageError(f"--rtol must be in (0, 1), got {args.rtol}")
    say("kapitza: deriving, compiling and integrating the lecture's problems "
         f"(rtol = {args.rtol:g}); compiled kernels are cached on disk, so a second run is fast.")
    df = catalogue_summary(args.rtol, progress=lambda s: say("  " + s))
    if args.json:
        emit(args, {"rtol": args.rtol, "problems": records(df)}, "")
    else:
        with pd.option_context("display.width", 200, "display.max_columns", 20,
                               "display.float_format", "{:.3g}".format):
            print()
            print(df.to_string(index=False, na_rep="nan"))
    failed = df["status"].astype(str).str.startswith("error")
    if failed.any():
        say(f"\n{int(failed.sum())} problem(s) failed.")
        return EXIT_DISAGREEMENT
    return EXIT_OK


#: Each command's function, by its name on the command line.
COMMANDS = {"predict": _predict, "window": _window, "map": _map, "measure": _measure,
            "verify": _verify, "animate": _animate, **FRONTIER_COMMANDS, "report": _report,
            "run": _run, "sweep": _sweep, "warmup": _warmup, "summary": _summary}
