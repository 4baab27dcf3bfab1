"""The ``kapitza`` command line.

Commands (``kapitza COMMAND --help`` shows each one's options and an example):

  predict   averaging and Floquet analysis at one drive (A, ω)
  window    the exact window of stabilising amplitudes per ω, the averaging one beside it
  map       the exact (A, ω) stability map: a PNG and the data (CSV or Parquet)
  measure   simulate the full nonlinear motion at one drive and measure it
  verify    averaging, Floquet and simulation compared over a grid (exit 1: disagreement)
  animate   a GIF of the stabilised inverted pendulum beside one that falls
  report    the whole story in one folder: an HTML page, figures, a GIF and the data
  run       run the analyses a scene file asks for
  sweep     run a scene's [sweep] over its grid, in resumable tiles
  warmup    compile what every analysis needs, once per installation
  summary   derive, compile and integrate the catalogue (the default: ``kapitza --rtol 1e-6``)

Drive parameters are SI numbers (``--A`` m, ``--omega`` rad/s or ``--f`` Hz) or
dimensionless ratios (``--A-over-l``, ``--omega-over-omega0`` with ω0 = √(g/l)).
``--json`` writes the results as JSON on stdout; messages and progress go to stderr.
Exit codes: 0 success, 1 a verification found disagreement beyond the methods'
tolerances (or a catalogue problem failed), 2 a usage or scene error, 130 interrupted.
"""
from __future__ import annotations

import argparse
import dataclasses
import json
import math
import os
import sys
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

__all__ = ["main", "catalogue_summary"]

EXIT_OK, EXIT_DISAGREEMENT, EXIT_USAGE, EXIT_INTERRUPTED = 0, 1, 2, 130


@dataclass(frozen=True)
class Case:
    """One catalogue problem with parameter values and an initial state."""

    label: str
    make: object            # () -> System
    params: dict
    q0: list
    qdot0: list
    t_end: float            # s


def _cases():
    from lagrange_core import problems as P
    g = 9.81
    return [
        Case("pendulum", P.pendulum, dict(m=1.0, l=1.0, g=g), [2.0], [0.0], 20.0),
        Case("double pendulum (chaotic)", P.double_pendulum,
             dict(m1=1.0, m2=1.0, l1=1.0, l2=1.0, g=g), [2.0, 2.5], [0.0, 0.0], 20.0),
        Case("8-link pendulum", lambda: P.n_link_pendulum(8),
             {**{f"m{i}": 1.0 for i in range(1, 9)}, **{f"l{i}": 0.25 for i in range(1, 9)},
              "g": g}, [0.3] * 8, [0.0] * 8, 5.0),
        Case("Kapitza pendulum (inverted)", P.driven_pendulum,
             dict(m=1.0, l=1.0, g=g, A=0.05, omega=2 * math.pi * 60), [math.pi - 0.1], [0.0], 5.0),
        Case("central force (Kepler, e = 0.5)", P.central_force, dict(m=1.0, k=1.0),
             [1.0, 0.0], [0.0, math.sqrt(1.5)], 30.0),
        Case("spherical pendulum", P.spherical_pendulum, dict(m=1.0, l=1.0, g=g),
             [1.0, 0.0], [0.0, 2.0], 20.0),
        Case("block on a sliding wedge", P.block_on_wedge,
             dict(m=1.0, M=3.0, alpha=math.radians(30), g=g), [0.0, 0.0], [0.0, 0.0], 1.0),
        Case("swinging Atwood machine", P.swinging_atwood, dict(m=1.0, g=g),
             [1.0, 0.5], [0.0, 0.0], 2.0),
        Case("string of 20 beads", lambda: P.bead_string(20), dict(F=100.0, l=1.0, mu=0.01),
             [0.001 * math.sin(math.pi * (i + 1) / 21) for i in range(20)], [0.0] * 20, 0.05),
    ]


def catalogue_summary(rtol: float = 1e-10, progress=None):
    """Derive, compile and integrate each catalogue problem; a pandas DataFrame, one row each.

    Columns: problem, dof, constraints, derive_s, compile_s, integrate_s, method, steps,
    energy_drift_J (max |h − h0| in J where the energy function h is conserved, else NaN),
    error_estimate, status.
    """
    import pandas as pd

    rows = []
    cases = _cases()
    for i, case in enumerate(cases):
        if progress:
            progress(f"[{i + 1}/{len(cases)}] {case.label}")
        row = {"problem": case.label}
        try:
            t0 = time.perf_counter()
            system = case.make()
            eq = system.equations
            t1 = time.perf_counter()
            system.kernels
            t2 = time.perf_counter()
            traj = system.simulate(case.q0, case.qdot0, (0.0, case.t_end), case.params, rtol=rtol)
            t3 = time.perf_counter()
            drift = float(np.max(np.abs(traj.energy - traj.energy[0]))) \
                if eq.energy_conserved else float("nan")
            row.update(dof=system.n_dof, constraints=system.n_constraints, derive_s=t1 - t0,
                       compile_s=t2 - t1, integrate_s=t3 - t2, method=traj.method,
                       steps=traj.n_steps, energy_drift_J=drift,
                       error_estimate=traj.error_estimate, status=traj.status)
        except Exception as exc:      # one failing problem must not hide the others
            row.update(status=f"error: {exc}")
        rows.append(row)
    return pd.DataFrame(rows)


# -- output ---------------------------------------------------------------------------------

class UsageError(Exception):
    """A command's arguments are wrong (exit code 2); the message names what."""


def _plain(x):
    """``x`` in JSON's terms: arrays as lists, NaN and ±inf as null, complex as [re, im]."""
    if dataclasses.is_dataclass(x) and not isinstance(x, type):
        return {f.name: _plain(getattr(x, f.name)) for f in dataclasses.fields(x)
                if f.repr and not callable(getattr(x, f.name))}
    if isinstance(x, dict):
        return {str(k): _plain(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [_plain(v) for v in x]
    if isinstance(x, np.ndarray):
        return _plain(x.tolist())
    if isinstance(x, np.generic):
        return _plain(x.item())
    if isinstance(x, bool) or x is None or isinstance(x, (int, str)):
        return x
    if isinstance(x, float):
        return x if math.isfinite(x) else None
    if isinstance(x, complex):
        return [_plain(x.real), _plain(x.imag)]
    if isinstance(x, Path):
        return str(x)
    return str(x)


def _records(frame):
    """A DataFrame as a list of JSON rows."""
    return _plain(frame.to_dict(orient="records"))


def _emit(args, data: dict, text: str) -> None:
    """Results on stdout: JSON with ``--json``, else ``text``."""
    if args.json:
        json.dump(_plain(data), sys.stdout, indent=1, allow_nan=False)
        sys.stdout.write("\n")
    else:
        print(text)
    sys.stdout.flush()


def _say(message: str) -> None:
    print(message, file=sys.stderr, flush=True)


def _table(frame) -> str:
    import pandas as pd
    with pd.option_context("display.width", 200, "display.max_columns", 30,
                           "display.max_rows", 60, "display.float_format", "{:.6g}".format):
        return frame.to_string(index=False)


# -- parameters: SI numbers or dimensionless ratios -----------------------------------------

def _pendulum(args):
    from ..pendulum import KapitzaPendulum
    return KapitzaPendulum(l=args.l, g=args.g, damping=args.damping, drive=args.drive)


def _number_list(text: str, name: str) -> np.ndarray:
    """``"0.05"``, ``"0.01,0.03,0.1"`` or ``"START:STOP:NUM"`` (NUM points, linear)."""
    try:
        if ":" in text:
            parts = text.split(":")
            if len(parts) != 3:
                raise ValueError
            start, stop, num = float(parts[0]), float(parts[1]), int(parts[2])
            if num < 1:
                raise ValueError
            return np.linspace(start, stop, num)
        values = np.array([float(v) for v in text.split(",") if v.strip()])
        if not values.size:
            raise ValueError
        return values
    except ValueError:
        raise UsageError(f"{name}: expected a number, a comma-separated list or START:STOP:NUM, "
                         f"got {text!r}.") from None


def _geometric(text: str, name: str) -> np.ndarray:
    """As :func:`_number_list`, but START:STOP:NUM spaced geometrically (for ω)."""
    values = _number_list(text, name)
    if ":" in text and len(values) > 1:
        if values[0] <= 0 or values[-1] <= 0:
            raise UsageError(f"{name}: a logarithmic range needs positive ends, got {text!r}.")
        values = np.geomspace(values[0], values[-1], len(values))
    return values


def _amplitude(args, grid: bool = False):
    """Drive amplitude (m) from --A or --A-over-l (times l)."""
    text = args.A if args.A is not None else args.A_over_l
    if text is None:
        raise UsageError("give the drive amplitude: --A (m) or --A-over-l.")
    name = "--A" if args.A is not None else "--A-over-l"
    values = _number_list(text, name)
    if args.A is None:
        values = values * args.l
    if not grid:
        if values.size != 1:
            raise UsageError(f"{name}: one value here, got {text!r}.")
        return float(values[0])
    return values


def _frequency(args, grid: bool = False):
    """Drive angular frequency (rad/s) from --omega, --f (Hz) or --omega-over-omega0."""
    given = [(n, getattr(args, k)) for n, k in (("--omega", "omega"), ("--f", "f"),
                                                 ("--omega-over-omega0", "omega_over_omega0"))
             if getattr(args, k) is not None]
    if not given:
        raise UsageError("give the drive frequency: --omega (rad/s), --f (Hz) or "
                         "--omega-over-omega0.")
    name, text = given[0]
    log = getattr(args, "log_omega", False)
    values = _geometric(text, name) if log else _number_list(text, name)
    if name == "--f":
        values = 2 * math.pi * values
    elif name == "--omega-over-omega0":
        values = values * math.sqrt(args.g / args.l)
    if not grid:
        if values.size != 1:
            raise UsageError(f"{name}: one value here, got {text!r}.")
        return float(values[0])
    return values


def _point(args, A, omega) -> dict:
    omega0 = math.sqrt(args.g / args.l)
    return {"A": A, "omega": omega, "A_over_l": np.asarray(A) / args.l,
            "omega_over_omega0": np.asarray(omega) / omega0,
            "pendulum": {"l": args.l, "g": args.g, "damping": args.damping,
                         "drive": args.drive, "omega0": omega0}}


# -- the commands -----------------------------------------------------------------------------

def _predict(args) -> int:
    pend = _pendulum(args)
    A, omega = _amplitude(args), _frequency(args)
    avg = pend.averaged(A, omega, order=args.order, warn=False)
    about = args.about or ("tilted" if args.drive == "horizontal" else "inverted")
    if args.drive == "horizontal" and about == "tilted" and (A * omega) ** 2 <= 2 * args.g * args.l:
        about = "hanging"
        _say("predict: (Aω)² ≤ 2gl, no tilted state; the Floquet analysis is about the "
             "orbit near θ = 0.")
    exact = pend.floquet(A, omega, about=about, tol=args.tol)
    equilibria = {e.name: _plain(e) for e in avg.equilibria}
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
    data = {**_point(args, A, omega), "averaging": {"order": args.order, **equilibria},
            "floquet": floquet}
    lines = [f"drive {args.drive}: A = {A:.6g} m (A/l = {A / args.l:.6g}), ω = {omega:.6g} rad/s "
             f"(ω/ω0 = {omega / math.sqrt(args.g / args.l):.6g}), l = {args.l:g} m, "
             f"g = {args.g:g} m/s², γ = {args.damping:g} 1/s",
             f"averaging (order {args.order}):"]
    for e in avg.equilibria:
        lines.append(f"  {e.name:9s} θ = {float(e.theta):.6g} rad  exists {bool(e.exists)}  "
                     f"stable {bool(e.stable)}  Ω = {float(e.omega_slow):.6g} rad/s  "
                     f"valid {bool(e.valid)}")
    lines.append(f"Floquet about {about} ({floquet['kind']}): stable {floquet['stable']}  "
                 f"Ω = {float(np.max(exact.omega_slow)):.6g} rad/s")
    _emit(args, data, "\n".join(lines))
    return EXIT_OK


def _window(args) -> int:
    pend = _pendulum(args)
    omega = _frequency(args, grid=True)
    exact = pend.stability_window(omega, about=args.about, tol=args.tol)
    frame = exact.to_dataframe()
    frame.insert(1, "omega_over_omega0", frame["omega"] / pend.omega0)
    frame["A_min_over_l"] = frame["A_min"] / args.l
    frame["A_max_over_l"] = frame["A_max"] / args.l
    if args.about == "inverted":
        approx = pend.stability_window(omega, method="averaging", order=args.order)
        frame["A_min_averaging"] = np.ravel(np.broadcast_to(approx.A_min, np.shape(omega)))
        frame["A_max_averaging"] = np.ravel(np.broadcast_to(approx.A_max, np.shape(omega)))
        frame["averaging_valid"] = np.ravel(np.broadcast_to(approx.valid, np.shape(omega)))
    data = {"pendulum": _point(args, 0.0, 0.0)["pendulum"], "about": args.about,
            "averaging_order": args.order if args.about == "inverted" else None,
            "rows": _records(frame)}
    _emit(args, data, f"window of stabilising amplitudes about {args.about} (exact, Floquet"
          + (f"; averaging order {args.order} beside it" if args.about == "inverted" else "")
          + "):\n" + _table(frame))
    return EXIT_OK


def _data_path(text):
    """A data file's path: .csv or .parquet."""
    if text is None:
        return None
    path = Path(text)
    if path.suffix not in (".csv", ".parquet"):
        raise UsageError(f"--data must end in .csv or .parquet, got {text!r}.")
    return path


def _write_frame(frame, path: Path) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    if path.suffix == ".parquet":
        frame.to_parquet(path, index=False)
    else:
        frame.to_csv(path, index=False)
    return path


def _map_outputs(args, result, pend, partial=False):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from ..figures import stability_map_figure

    png = Path(args.out)
    data_path = _data_path(args.data) or png.with_suffix(".csv")
    frame = result.to_dataframe()
    _write_frame(frame, data_path)
    overlays = []
    if args.about == "inverted" and not partial:
        fine = np.geomspace(result.omega.min(), result.omega.max(), 200) \
            if result.omega.min() > 0 else np.linspace(result.omega.min(), result.omega.max(), 200)
        fine = fine[fine > 0]
        if fine.size:
            overlays.append(pend.stability_window(fine, method="averaging", order=1))
    fig = stability_map_figure(result, overlays=overlays, dimensionless=args.dimensionless,
                               log_omega=args.log_omega)
    png.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(png, dpi=120)
    plt.close(fig)
    return png, data_path, frame


def _map(args) -> int:
    from ..results import ComputationInterrupted
    pend = _pendulum(args)
    A = _amplitude(args, grid=True)
    omega = _frequency(args, grid=True)
    _data_path(args.data)
    try:
        result = pend.stability_map(A, omega, about=args.about, trace=args.trace, tol=args.tol)
    except ComputationInterrupted as stop:
        png, data_path, _ = _map_outputs(args, stop.result, pend, partial=True)
        _say(f"map: interrupted; {int(stop.computed.sum())} of {stop.computed.size} points "
             f"finished, saved (the others NaN) in {data_path} and {png}.")
        return EXIT_INTERRUPTED
    png, data_path, frame = _map_outputs(args, result, pend)
    stable = np.asarray(result.stable, bool)
    data = {"pendulum": _point(args, 0.0, 0.0)["pendulum"], "about": args.about,
            "method": result.method, "shape": list(stable.shape),
            "stable_points": int(stable.sum()), "points": int(stable.size),
            "error_estimate": result.error_estimate, "figure": png, "data": data_path,
            "A": result.A, "omega": result.omega}
    _emit(args, data, f"stability map about {args.about} ({result.method}): "
          f"{int(stable.sum())} of {stable.size} points stable\nfigure: {png}\ndata: {data_path}")
    return EXIT_OK


def _measure(args) -> int:
    pend = _pendulum(args)
    A, omega = _amplitude(args), _frequency(args)
    about = args.about
    m = pend.measure(A, omega, theta0=args.theta0, theta_dot0=args.theta_dot0,
                     periods=args.periods, about=about, rtol=args.rtol)
    fields = {k: getattr(m, k) for k in ("stayed_up", "fall_time", "omega_slow",
                                         "omega_slow_error", "amplitude", "mean_angle",
                                         "growth_rate", "max_deviation", "about", "period",
                                         "periods", "status", "method", "rtol")}
    data = {**_point(args, A, omega), "theta0": args.theta0, "theta_dot0": args.theta_dot0,
            "measurement": fields}
    _emit(args, data, f"released at θ0 = {args.theta0:.6g} rad, θ̇0 = {args.theta_dot0:g} rad/s, "
          f"{args.periods} periods of A = {A:.6g} m, ω = {omega:.6g} rad/s:\n"
          f"  stayed up {bool(m.stayed_up)}  fall time {m.fall_time:.6g} s\n"
          f"  Ω = {_with_error(m.omega_slow, m.omega_slow_error)} rad/s  "
          f"slow amplitude {m.amplitude:.4g} rad  mean angle {m.mean_angle:.6g} rad\n"
          f"  status {m.status}")
    return EXIT_OK


def _with_error(value, error) -> str:
    """``value ± error`` with the value's digits down to the error's second digit."""
    if not (math.isfinite(value) and math.isfinite(error) and error > 0):
        return f"{value:.6g} ± {error:.2g}"
    decimals = min(12, max(0, 1 - math.floor(math.log10(error))))
    return f"{value:.{decimals}f} ± {error:.2g}"


def _verify(args) -> int:
    pend = _pendulum(args)
    A = _amplitude(args, grid=True)
    omega = _frequency(args, grid=True)
    data_path = _data_path(args.data)
    v = pend.verify(A[:, None], omega[None, :], theta0=args.theta0, periods=args.periods,
                    tol=args.tol, rtol=args.rtol, line=None if args.fit_order else False)
    agreement, bad = v.agreement, v.disagreements
    if data_path:
        _write_frame(v.to_dataframe(), data_path)
    data = {"pendulum": _point(args, 0.0, 0.0)["pendulum"], "A": A, "omega": omega,
            "points": int(np.prod(v.shape)), "methods": list(v.methods),
            "agreement": _records(agreement), "disagreements": _records(bad),
            "exponent": v.exponent, "exponent_error": v.exponent_error,
            "notes": list(v.notes), "data": args.data, "agree": bool(len(bad) == 0)}
    text = [f"verification over {len(A)} amplitudes × {len(omega)} frequencies "
            f"({int(np.prod(v.shape))} points):", _table(agreement)]
    if args.fit_order:
        text.append(f"order of first-order averaging: {v.exponent:.3f} ± "
                    f"{v.exponent_error:.3f} (theory 2)")
    if len(bad):
        text += [f"{len(bad)} disagreement(s) beyond the methods' tolerances:", _table(bad)]
    else:
        text.append("all methods agree within their tolerances.")
    _emit(args, data, "\n".join(text))
    if len(bad):
        _say(f"verify: {len(bad)} disagreement(s) beyond tolerance (exit code 1).")
        return EXIT_DISAGREEMENT
    return EXIT_OK


def _animate(args) -> int:
    from ..animation import pendulum_animation, system_animation
    scenes = [_scene(path) for path in args.scene]
    if scenes:
        given = [n for n, k in (("--A", "A"), ("--A-over-l", "A_over_l"), ("--omega", "omega"),
                                ("--f", "f"), ("--omega-over-omega0", "omega_over_omega0"))
                 if getattr(args, k) is not None]
        if given:
            raise UsageError(f"{', '.join(given)}: the scene sets the drive; give either "
                             "scenes or the drive options.")
    pend = scenes[0].pendulum if len(scenes) == 1 else None
    try:
        if scenes and (pend is None or pend.drive != "vertical"):
            # chains (or several scenes): each scene a panel, from its own [initial] state
            anim = system_animation(args.out, scenes, duration=args.duration, fps=args.fps,
                                    frames_per_period=args.frames_per_period,
                                    width=args.width, max_frames=args.max_frames,
                                    mode=args.mode)
            data, head, fate = _gif_summary(anim)
            data.update(scenes=list(args.scene), titles=list(anim.titles))
            _emit(args, data, head + "".join(f"\n  {path}: {f}"
                                             for path, f in zip(args.scene, fate)))
            return EXIT_OK
        if scenes:
            p = scenes[0].params
            A, omega, theta0 = float(p["A"]), float(p["omega"]), float(scenes[0].q0[0])
            l, g, damping = pend.l, pend.g, pend.damping
        else:
            if args.drive != "vertical":
                raise UsageError("--drive: animate shows the vertical drive only.")
            A, omega, theta0 = _amplitude(args), _frequency(args), args.theta0
            l, g, damping = args.l, args.g, args.damping
        anim = pendulum_animation(args.out, A=A, omega=omega, l=l, g=g, damping=damping,
                                  theta0=theta0, A_fall=args.A_fall, duration=args.duration,
                                  fps=args.fps, frames_per_period=args.frames_per_period,
                                  width=args.width, max_frames=args.max_frames,
                                  mode=args.mode)
    except KeyboardInterrupt:
        _say(f"kapitza animate: interrupted; the frames finished are in {args.out}.")
        return EXIT_INTERRUPTED
    data, head, fate = _gif_summary(anim)
    data.update(A=anim.A[0], A_fall=anim.A[1], omega=omega, A_over_l=anim.A[0] / l,
                omega_over_omega0=omega / math.sqrt(g / l), theta0=theta0, window=anim.window,
                pendulum={"l": l, "g": g, "damping": damping, "omega0": math.sqrt(g / l)})
    _emit(args, data, f"{head}\n  shaken A = {A:.4g} m (window {anim.window[0]:.4g} < A < "
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
            f"falls at t = {t:.3g} s" for up, t in zip(anim.stayed_up or (), anim.fall_time)]
    return data, head, fate


def _report(args) -> int:
    from ..report import ReportInterrupted, build_report
    scene = None if args.scene is None else _scene(args.scene)
    try:
        report = build_report(scene, args.out, quick=args.quick)
    except ReportInterrupted as stop:
        _say(f"kapitza report: interrupted; {stop.report.index} shows the finished sections "
             f"(missing: {', '.join(stop.report.missing)}).")
        return EXIT_INTERRUPTED
    frame = report.to_dataframe()
    data = {"out": report.out, "index": report.index, "scene": report.scene,
            "seconds": report.seconds, "quick": report.quick,
            "sections": _records(frame.drop(columns=["caption"])),
            "figures": {k: str(v) for k, v in report.figures.items()},
            "tables": {k: [str(p) for p in v] for k, v in report.tables.items()},
            "numbers": report.numbers, "failed": list(report.failed)}
    lines = [f"{row.section:15s} {row.status:8s} {row.seconds:6.1f} s"
             + (f"  ({row.reason})" if row.reason else "") for row in frame.itertuples()]
    _emit(args, data, "\n".join([*lines, f"report: {report.index} ({report.seconds:.1f} s)"]))
    if report.failed:
        _say(f"kapitza report: section(s) failed: {', '.join(report.failed)} (see the page).")
        return EXIT_DISAGREEMENT
    return EXIT_OK


def _scene(path):
    from ..scenes import Scene
    if not Path(path).is_file():
        raise UsageError(f"no scene file {path!r}.")
    return Scene.from_toml(path)


_MAX_JSON_ROWS = 1000


def _run(args) -> int:
    scene = _scene(args.scene)
    _say(f"run: {scene.spec.source}: {scene.system.name}; analyses {list(scene.analyses)}")
    res = scene.run(write=not args.no_write)
    tables = res.tables()
    data = {"scene": scene.spec.source, "system": scene.system.name, "seconds": res.seconds,
            "written": list(res.written), "analyses": {}}
    text = []
    for name, frame in tables.items():
        if len(frame) <= _MAX_JSON_ROWS:
            data["analyses"][name] = _records(frame)
        else:
            data["analyses"][name] = {"rows": len(frame), "columns": list(frame.columns)}
        text += [f"== {name} ({len(frame)} rows)", _table(frame.head(20))]
    if res.written:
        text.append("written: " + ", ".join(str(p) for p in res.written))
    _emit(args, data, "\n".join(text))
    return EXIT_OK


def _sweep(args) -> int:
    from ..results import ComputationInterrupted
    scene = _scene(args.scene)
    try:
        result = scene.sweep(args.analysis, directory=args.directory,
                             tile_points=args.tile_points)
    except ComputationInterrupted as stop:
        partial = stop.result
        where = getattr(partial, "path", "the sweep's directory")
        _say(f"sweep: interrupted; the finished tiles are saved in {where}; run the same "
             "command again to resume.")
        return EXIT_INTERRUPTED
    frame = result.to_dataframe()
    data = {"scene": scene.spec.source, "path": result.path, "size": result.size,
            "tiles": result.tiles, "computed": result.computed, "skipped": result.skipped,
            "seconds": result.seconds, "columns": list(frame.columns)}
    _emit(args, data, f"sweep: {result.size} points in {result.tiles} tiles "
          f"({result.computed} computed, {result.skipped} already on disk), "
          f"{result.seconds:.1f} s\ndataset: {result.path}")
    return EXIT_OK


def _warmup(args) -> int:
    from ..warmup import warmup
    _say("warmup: compiling (or loading from the cache) what the analyses need ...")
    seconds = warmup(verbose=False)
    _emit(args, {"seconds": seconds}, f"warmup done in {seconds:.1f} s")
    return EXIT_OK


def _summary(args) -> int:
    import pandas as pd

    if not (0 < args.rtol < 1):
        raise UsageError(f"--rtol must be in (0, 1), got {args.rtol}")
    _say("kapitza: deriving, compiling and integrating the lecture's problems "
         f"(rtol = {args.rtol:g}); compiled kernels are cached on disk, so a second run is fast.")
    df = catalogue_summary(args.rtol, progress=lambda s: _say("  " + s))
    if args.json:
        _emit(args, {"rtol": args.rtol, "problems": _records(df)}, "")
    else:
        with pd.option_context("display.width", 200, "display.max_columns", 20,
                               "display.float_format", "{:.3g}".format):
            print()
            print(df.to_string(index=False))
    failed = df["status"].astype(str).str.startswith("error")
    if failed.any():
        _say(f"\n{int(failed.sum())} problem(s) failed.")
        return 1
    return 0


# -- the parser ---------------------------------------------------------------------------

_EXAMPLES = {
    "predict": ["kapitza predict --A 0.05 --f 60",
                "kapitza predict --A-over-l 0.05 --omega-over-omega0 120.4 --json",
                "kapitza predict --drive horizontal --A 0.05 --omega 377"],
    "window": ["kapitza window --omega 100,200,400",
               "kapitza window --omega-over-omega0 10:1000:30 --log-omega --json"],
    "map": ["kapitza map --A 0:0.5:101 --omega 20:2000:100 --log-omega --out map.png",
            "kapitza map --A-over-l 0:0.5:51 --omega-over-omega0 5:500:60 --log-omega "
            "--data map.parquet --dimensionless"],
    "measure": ["kapitza measure --A 0.05 --f 60 --theta0 3.13",
                "kapitza measure --A 0.05 --omega 377 --drive horizontal --theta0 1.0 --json"],
    "verify": ["kapitza verify --A 0.01,0.03,0.1 --f 40 --periods 400",
               "kapitza verify --A 0.01:0.3:10 --omega 50:500:5 --log-omega --data v.csv --json"],
    "animate": ["kapitza animate --A-over-l 0.25 --omega-over-omega0 10 --out pendulum.gif",
                "kapitza animate --A 0.2 --omega 40 --A-fall 0.05 --duration 3 --json",
                "kapitza animate kapitza/scenes/report.toml --out report.gif",
                "kapitza animate up.toml undriven.toml --out chains.gif"],
    "report": ["kapitza report                      # the default scene, into ./kapitza-report",
               "kapitza report kapitza/scenes/double_pendulum.toml --out dp-report",
               "kapitza report --quick --out /tmp/r --json"],
    "run": ["kapitza run kapitza/scenes/kapitza_pendulum.toml",
            "kapitza run my_scene.toml --json --no-write"],
    "sweep": ["kapitza sweep kapitza/scenes/kapitza_pendulum_map.toml",
              "kapitza sweep scene.toml --analysis measure --directory out/"],
    "warmup": ["kapitza warmup"],
    "summary": ["kapitza summary --rtol 1e-8", "kapitza --rtol 1e-6"],
}


def _epilog(name):
    return "examples:\n" + "\n".join(f"  {e}" for e in _EXAMPLES[name])


def _common(p, json_only=False):
    """The options every command shares (added to each parser: argparse's ``parents``
    would lose the drive's group title in the help)."""
    p.add_argument("--json", action="store_true",
                   help="write the results as JSON on stdout (messages go to stderr)")
    if json_only:
        return
    g = p.add_argument_group("the pendulum")
    g.add_argument("--l", type=float, default=1.0, help="length l (m; default 1)")
    g.add_argument("--g", type=float, default=9.81, help="gravity g (m/s²; default 9.81)")
    g.add_argument("--damping", type=float, default=0.0, help="damping rate γ (1/s; default 0)")
    g.add_argument("--drive", choices=("vertical", "horizontal"), default="vertical",
                   help="direction of the pivot's oscillation A cos ωt (default vertical)")
    d = p.add_argument_group("the drive (SI numbers or dimensionless ratios; grids as "
                             "a,b,c or START:STOP:NUM where a command takes several)")
    a = d.add_mutually_exclusive_group()
    a.add_argument("--A", metavar="A", help="amplitude A (m)")
    a.add_argument("--A-over-l", dest="A_over_l", metavar="A/l", help="amplitude as A/l")
    f = d.add_mutually_exclusive_group()
    f.add_argument("--omega", metavar="ω", help="angular frequency ω (rad/s)")
    f.add_argument("--f", metavar="Hz", help="frequency f = ω/2π (Hz)")
    f.add_argument("--omega-over-omega0", dest="omega_over_omega0", metavar="ω/ω0",
                   help="ω as a ratio to ω0 = √(g/l)")


def _parser() -> argparse.ArgumentParser:
    from .._version import __version__
    raw = argparse.RawDescriptionHelpFormatter
    parser = argparse.ArgumentParser(prog="kapitza", description=__doc__, formatter_class=raw)
    parser.add_argument("--version", action="version", version=f"kapitza {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    pend, plain = False, True

    def add(name, helptext, json_only):
        p = sub.add_parser(name, help=helptext, description=helptext, epilog=_epilog(name),
                           formatter_class=raw)
        _common(p, json_only)
        return p

    p = add("predict", "averaging and Floquet analysis at one drive (A, ω)", pend)
    p.add_argument("--about", help="Floquet about: inverted (default) or hanging; horizontal "
                   "drive: tilted (default), tilted-, hanging, inverted")
    p.add_argument("--order", type=int, choices=(1, 2), default=1, help="order of averaging")
    p.add_argument("--tol", type=float, default=1e-10, help="Floquet tolerance (default 1e-10)")
    p.set_defaults(run=_predict)

    p = add("window", "the exact window A_min < A < A_max per ω (vertical drive), the "
            "averaging window beside it", pend)
    p.add_argument("--about", choices=("inverted", "hanging"), default="inverted")
    p.add_argument("--order", type=int, choices=(1, 2), default=1,
                   help="order of the averaging window (default 1)")
    p.add_argument("--tol", type=float, default=1e-10, help="relative accuracy of the edges")
    p.add_argument("--log-omega", action="store_true", help="START:STOP:NUM of ω geometric")
    p.set_defaults(run=_window)

    p = add("map", "the exact (A, ω) stability map (vertical drive): a PNG and its data",
            pend)
    p.add_argument("--about", choices=("inverted", "hanging"), default="inverted")
    p.add_argument("--out", default="kapitza-map.png", help="figure (default kapitza-map.png)")
    p.add_argument("--data", help="data file, .csv or .parquet (default: the figure's name "
                   "with .csv)")
    p.add_argument("--trace", action="store_true", help="compute the monodromy trace everywhere")
    p.add_argument("--tol", type=float, default=1e-10, help="Floquet tolerance (with --trace "
                   "or damping)")
    p.add_argument("--log-omega", action="store_true",
                   help="START:STOP:NUM of ω geometric, and a logarithmic ω axis")
    p.add_argument("--dimensionless", action="store_true", help="axes A/l and ω/ω0")
    p.set_defaults(run=_map)

    p = add("measure", "simulate the full nonlinear motion at one drive and measure it", pend)
    p.add_argument("--theta0", type=float, default=math.pi - 0.01,
                   help="release angle from the downward vertical (rad; default π − 0.01)")
    p.add_argument("--theta-dot0", dest="theta_dot0", type=float, default=0.0,
                   help="release angular velocity (rad/s; default 0)")
    p.add_argument("--periods", type=int, default=None,
                   help="drive periods simulated (default: measure's)")
    p.add_argument("--about", help="inverted, hanging, tilted or an angle (default: inverted "
                   "for the vertical drive, tilted for the horizontal)")
    p.add_argument("--rtol", type=float, default=1e-9, help="integration tolerance")
    p.set_defaults(run=_measure)

    p = add("verify", "averaging, Floquet and simulation of the upright pendulum compared "
            "over an A × ω grid; exit code 1 where they disagree beyond tolerance", pend)
    p.add_argument("--theta0", type=float, default=math.pi - 0.01,
                   help="the simulations' release angle (rad; default π − 0.01)")
    p.add_argument("--periods", type=int, default=None,
                   help="drive periods simulated per point (default: measure's)")
    p.add_argument("--tol", type=float, default=1e-10, help="Floquet tolerance")
    p.add_argument("--rtol", type=float, default=1e-9, help="integration tolerance")
    p.add_argument("--fit-order", action="store_true",
                   help="also fit the order of averaging along A ω = 2√(gl)")
    p.add_argument("--data", help="write the per-point table (.csv or .parquet)")
    p.add_argument("--log-omega", action="store_true", help="START:STOP:NUM of ω geometric")
    p.set_defaults(run=_verify)

    p = add("animate", "a looping GIF of the stabilised inverted pendulum beside one that "
            "falls (vertical drive, slow motion)", pend)
    p.add_argument("scene", metavar="SCENE.toml", nargs="*",
                   help="one pendulum scene: l, g, damping, the drive and θ0 from it (the "
                   "falling one beside it as with the options); a chain's scene, or several "
                   "scenes: one panel each, from their [initial] states")
    p.add_argument("--theta0", type=float, default=math.pi - 0.1,
                   help="release angle of both (rad from the downward vertical; default "
                   "π − 0.1)")
    p.add_argument("--A-fall", dest="A_fall", type=float, default=0.0,
                   help="drive amplitude of the falling one (m; default 0, undriven; "
                   "must lie outside the window)")
    p.add_argument("--duration", type=float, default=4.0, help="simulated time (s; default 4)")
    p.add_argument("--fps", type=float, default=20.0, help="playback frames/s (default 20)")
    p.add_argument("--frames-per-period", dest="frames_per_period", type=int, default=8,
                   help="frames per drive period, ≥ 4 (default 8; sets the slow motion)")
    p.add_argument("--width", type=int, default=720, help="frame width (px; default 720)")
    p.add_argument("--max-frames", dest="max_frames", type=int, default=600,
                   help="refuse to render more frames (default 600)")
    p.add_argument("--mode", choices=("auto", "slow", "strobe"), default="auto",
                   help="slow motion (n frames a drive period), strobe (one frame every few "
                   "periods at one phase, the period drawn faint) or auto (slow motion when "
                   "it fits --max-frames and is at most 10× slower than real; default)")
    p.add_argument("--out", default="pendulum.gif", help="the GIF (default pendulum.gif)")
    p.set_defaults(run=_animate)

    p = add("report", "the main job: run a scene (default: a 1 m pendulum shaken "
            "vertically) through every analysis and write a self-contained folder: "
            "index.html, PNG figures, a GIF and the data (Parquet and CSV); progress on "
            "stderr, Ctrl-C keeps the finished sections (exit 130), exit 1 if a section "
            "failed. The default scene takes about 1.5 min on a fresh installation "
            "(compiling included) and 20 s after", plain)
    p.add_argument("scene", metavar="SCENE.toml", nargs="?", default=None,
                   help="a scene file (default: the embedded kapitza/scenes/report.toml)")
    p.add_argument("--out", default="kapitza-report",
                   help="the report folder (default ./kapitza-report)")
    p.add_argument("--quick", action="store_true", help="small grids and short runs")
    p.set_defaults(run=_report)

    p = add("run", "run the analyses a scene file (TOML) asks for", plain)
    p.add_argument("scene", metavar="SCENE.toml")
    p.add_argument("--no-write", action="store_true", help="do not write [output] tables")
    p.set_defaults(run=_run)

    p = add("sweep", "run a scene's [sweep] over its grid in resumable tiles", plain)
    p.add_argument("scene", metavar="SCENE.toml")
    p.add_argument("--analysis", help="the swept analysis (default: the only one)")
    p.add_argument("--directory", help="where the dataset goes (default: the scene's output)")
    p.add_argument("--tile-points", dest="tile_points", type=int)
    p.set_defaults(run=_sweep)

    p = add("warmup", "compile what every analysis needs, once per installation", plain)
    p.set_defaults(run=_warmup)

    p = add("summary", "derive, compile and integrate the catalogue (the default)", plain)
    p.add_argument("--rtol", type=float, default=1e-10,
                   help="integration tolerance (default 1e-10)")
    p.set_defaults(run=_summary)
    return parser


def main(argv=None) -> int:
    """Run ``kapitza`` with ``argv`` (default ``sys.argv[1:]``); the exit code."""
    argv = list(sys.argv[1:] if argv is None else argv)
    parser = _parser()
    if (not argv or argv[0].startswith("-")) and not {"-h", "--help", "--version"} & set(argv):
        argv = ["summary", *argv]               # the default command takes its options
    try:
        args = parser.parse_args(argv)
    except SystemExit as stop:                  # --help, --version (0) or a usage error (2)
        return int(stop.code or 0)
    name = f"kapitza {args.command}"
    try:
        if getattr(args, "periods", 1) is None:
            from ..simulation import DEFAULT_PERIODS
            args.periods = DEFAULT_PERIODS
        return args.run(args)
    except UsageError as e:
        _say(f"{name}: error: {e}")
        return EXIT_USAGE
    except BrokenPipeError:                     # stdout closed early (| head): not an error
        sys.stdout = open(os.devnull, "w")
        return EXIT_OK
    except KeyboardInterrupt as stop:           # ComputationInterrupted too
        done = getattr(stop, "computed", None)
        finished = (f" after {int(done.sum())} of {done.size} points" if done is not None
                    and done.size else "")
        kept = ("tables already written and finished sweep tiles are kept (run it again to "
                "resume the sweep)" if args.command == "run" else "nothing was written")
        _say(f"\n{name}: interrupted{finished}; {kept}. Compiled kernels stay cached.")
        return EXIT_INTERRUPTED
    except (ValueError, FileNotFoundError) as e:      # SceneError is a ValueError
        _say(f"{name}: error: {e}")
        return EXIT_USAGE


if __name__ == "__main__":
    sys.exit(main())
