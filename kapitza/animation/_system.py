"""system_animation: planar chains of particles from scenes side by side, each simulated
from its scene's ``[initial]`` state and drawn at its system's own particle positions
(:class:`SystemAnimation`)."""
from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .. import _arguments as arguments
from ._drawing import COLOURS, Panel, Stage, render
from ._frames import UPRIGHT_BAND, check_playback, crossing_time, frame_times, sample_times


@dataclass(frozen=True)
class SystemAnimation:
    """A GIF written by :func:`system_animation`: planar chains side by side.

    Attributes
    ----------
    path : pathlib.Path
        The GIF.
    frames, width, height, bytes : int
        Frame count, frame size (pixels), file size (bytes).
    t : ndarray (frames,)
        Simulated time of each frame (s).
    coordinates : tuple of tuple of str
        Each panel's coordinates.
    q, qdot : tuple of ndarray (frames, n)
        Each panel's simulated coordinates and velocities at ``t`` (SI; angles in rad).
    anchor : ndarray (panels, frames, 2)
        The pivot's position in each frame (m).
    positions : tuple of ndarray (frames, particles, 2)
        Each particle's (x, y) as drawn (m), from the system's own particle positions.
    titles : tuple of str
        The panels' titles.
    about : ndarray or None
        The state each panel is classified against (e.g. all angles π: upright).
    stayed_up : tuple of bool or None
        Every coordinate within π/2 of ``about`` in every frame (None without ``about``;
        a panel's entry None where its drive leaves no equilibrium at θ = 0 or π: a
        horizontal or elliptic pivot).
    fall_time : tuple of float
        When a coordinate first left that band (s; interpolated linearly between the
        samples around it); NaN where it stayed.
    floquet_stable : tuple of bool or None
        Linear stability of ``about`` under each panel's drive (Floquet; undriven: the
        normal modes), None without ``about``.
    fps, frames_per_period, slow_motion, seconds, periods_per_frame
        As for :class:`Animation` (``frames_per_period`` None: real time, no drive).
    """

    path: Path
    frames: int
    width: int
    height: int
    bytes: int
    t: np.ndarray
    coordinates: tuple
    q: tuple
    qdot: tuple
    anchor: np.ndarray
    positions: tuple
    titles: tuple
    about: object
    stayed_up: object
    fall_time: tuple
    floquet_stable: object
    fps: float
    frames_per_period: object
    slow_motion: float
    seconds: float
    periods_per_frame: int | None = None

    def to_dataframe(self):
        """One row per panel and frame: panel, frame, t (s), each coordinate and velocity,
        the pivot's and each particle's x, y (m)."""
        import pandas as pd
        parts = []
        for i, (names, q, qd, pos) in enumerate(zip(self.coordinates, self.q, self.qdot,
                                                    self.positions, strict=True)):
            cols = {"panel": i, "frame": np.arange(self.frames), "t": self.t,
                    "pivot_x": self.anchor[i, :, 0], "pivot_y": self.anchor[i, :, 1]}
            for j, c in enumerate(names):
                cols[c], cols[f"{c}_dot"] = q[:, j], qd[:, j]
            for j in range(pos.shape[1]):
                cols[f"x{j + 1}"], cols[f"y{j + 1}"] = pos[:, j, 0], pos[:, j, 1]
            parts.append(pd.DataFrame(cols))
        return pd.concat(parts, ignore_index=True)


def system_animation(path, scenes, *, about="inverted", titles=None, title=None,
                     duration: float = 4.0,
                     fps: float = 20.0, frames_per_period: int = 8, width: int = 720,
                     max_frames: int = 600, rtol: float = 1e-10, mode: str = "auto",
                     progress=None) -> SystemAnimation:
    """Write a looping GIF of planar chains of particles side by side, each from a scene.

    The general form of :func:`pendulum_animation`, e.g. Acheson's double pendulum held
    upright by a fast drive beside the same chain undriven, falling.  Each scene's system
    is simulated from its ``[initial]`` state with output at the frame times, and each frame
    draws the system's own particle positions r_i(q, t) (rods joining the pivot and the
    particles in order) and the pivot P(t) of the scene's drive.

    Parameters
    ----------
    path : str or Path
        The GIF (``.gif``).
    scenes : sequence of Scene or str or Path
        One panel each (1–4), drawn left to right: scenes (:class:`kapitza.Scene`) or their
        TOML files, of rigs whose particles move in the (x, y) plane.  The driven ones
        must share one ω (one clock of frames); undriven ones play along.
    about : "inverted", "hanging", sequence of float or None
        The state each panel is classified against: the panel says "STAYS UP" while every
        coordinate stays within π/2 of it, otherwise when it left; and whether it is
        linearly stable (Floquet under a drive, the normal modes without).  None: no
        classification.
    titles : sequence of str, optional
        The panels' first title lines (default: each scene's title).
    title : str, optional
        The figure's title (default: how the chains were released and what "stays up"
        means).
    duration, fps, frames_per_period, width, max_frames, rtol, mode, progress
        As for :func:`pendulum_animation`.  Without any drive the frames are in real time
        (t_k = k/fps).

    Returns
    -------
    SystemAnimation
        The file, the drawn trajectories and positions, the classifications;
        ``to_dataframe()``.

    Examples
    --------
    >>> import kapitza                                                      # doctest: +SKIP
    >>> up = kapitza.Scene.from_toml("double_up.toml")                      # doctest: +SKIP
    >>> down = kapitza.Scene.from_toml("double_undriven.toml")              # doctest: +SKIP
    >>> kapitza.system_animation("acheson.gif", [up, down]).stayed_up       # doctest: +SKIP
    (True, False)
    """
    import time

    import sympy as sp

    from lagrange_core.symbols import t as t_symbol

    from ..floquet import floquet_point
    from ..scenes import Scene

    where = "system_animation: "
    started = time.perf_counter()
    path = Path(path)
    if path.suffix.lower() != ".gif":
        raise ValueError(f"{where}path must end in .gif, got {str(path)!r}; e.g. "
                         "'chains.gif'.")
    duration, fps, rtol = check_playback(where, duration, fps, rtol, frames_per_period, width,
                                    max_frames)
    if isinstance(scenes, (str, Path, Scene)):
        scenes = [scenes]
    scenes = [sc if isinstance(sc, Scene) else Scene.from_toml(sc) for sc in scenes]
    if not 1 <= len(scenes) <= 4:
        raise ValueError(f"{where}scenes: give 1 to 4 scenes (one panel each), got "
                         f"{len(scenes)}.")
    if titles is None:
        titles = [sc.spec.title or sc.system.name for sc in scenes]
    titles = [str(x) for x in titles]
    if len(titles) != len(scenes):
        raise ValueError(f"{where}titles: one per scene ({len(scenes)}), got {len(titles)}.")
    omegas = {float(sc.params["omega"]) for sc in scenes if sc.drive is not None}
    if len(omegas) > 1:
        raise ValueError(f"{where}the driven scenes have different drive frequencies "
                         f"{sorted(omegas)} rad/s; the frames follow one drive period, so give "
                         "them one omega.")
    omega = omegas.pop() if omegas else None
    t, fps_shown, slow, stride = frame_times(where, omega, duration, fps, frames_per_period,
                                              max_frames, fix="or a slower drive", mode=mode)
    samples = sample_times(t, omega, stride, frames_per_period)     # (frames, s)
    flat = samples.ravel()

    panels, qs, qds, anchors, positions, stayed, fall, stable = [], [], [], [], [], [], [], []
    for i, sc in enumerate(scenes):
        system, params = sc.system, dict(sc.params)
        names = tuple(system.coordinates)
        traj = system.simulate(sc.q0, sc.qdot0, (0.0, float(flat[-1])), params, rtol=rtol,
                               t_eval=flat)
        if traj.status != "success" or traj.t.shape != flat.shape:
            raise RuntimeError(f"{where}the simulation of scene {i} ({titles[i]}) stopped: "
                               f"{traj.status} ({traj.message}).")
        q_all = np.asarray(traj.q)                                  # (frames · s, n)
        step = samples.shape[1]
        q, qd = q_all[::step], np.asarray(traj.qdot)[::step]
        drive = sc.drive
        pivot = drive.pivot() if drive is not None else (0, 0)
        exprs = [sp.sympify(c) for c in pivot]
        for particle in system.particles:
            if len(particle.position) != 2:
                raise ValueError(f"{where}scene {i} ({titles[i]}): its particles move in "
                                 f"{len(particle.position)} dimensions; only planar (x, y) "
                                 "chains can be drawn.")
            exprs += [sp.sympify(c) for c in particle.position]
        values = _evaluate(where, exprs, names, q_all, flat, params, t_symbol)
        chains = np.stack([np.stack(values[2 * j: 2 * j + 2], 1)
                           for j in range(1 + len(system.particles))], 1)
        chains = chains.reshape(samples.shape + chains.shape[1:])   # (frames, s, 1 + p, 2)
        anchor, pos = chains[:, 0, 0], chains[:, 0, 1:]
        unheld = (isinstance(about, str) and drive is not None
                  and not drive.keeps_vertical_equilibria)
        if about is None or unheld:
            # a horizontal or elliptic pivot leaves no upright equilibrium to measure from
            centre, ok, when, lin = None, None, math.nan, None
        else:
            centre = (np.full(len(names), arguments.about_angle(about))
                      if isinstance(about, str) else np.asarray(about, float))
            if centre.shape != (len(names),):
                raise ValueError(f"{where}about must be 'inverted', 'hanging', None or one "
                                 f"value per coordinate {names}, got {about!r}.")
            dev = np.abs((q_all - centre + math.pi) % (2 * math.pi) - math.pi).max(1)
            out = dev >= UPRIGHT_BAND
            ok = bool(not out.any())
            when = crossing_time(flat, dev)
            if drive is not None:
                lin = bool(floquet_point(system, params, centre).stable)
            else:
                lin = bool(system.linearize(params, about=centre).stable)
        if drive is not None:
            amp = float(params["A"])
            kind = drive.path if isinstance(drive.path, str) else "oblique"
            sub = f"pivot shaken ({kind}): A = {amp:.3g} m at ω = {omega:.4g} rad/s"
        else:
            sub = "pivot still (no drive)"
        fate = "\nno equilibrium at θ = 0 or π under this drive: not classified" \
            if unheld else ""
        if ok is not None:
            fate = "\n" + ("Floquet" if drive is not None else "normal modes") + \
                (": stable" if lin else ": unstable") + " → " + \
                ("STAYS UP" if ok else f"FALLS at t = {when:.2f} s")
        if centre is None:
            readout = ["  ".join(f"{n} = {v:+.3f}" for n, v in zip(names, row, strict=True))
                       for row in q]
        else:   # the distance from ``about``, wrapped into [−π, π) (rad)
            off = (q - centre + math.pi) % (2 * math.pi) - math.pi
            ref = [n if c == 0 else f"{n} − π" if c == math.pi else f"{n} − {c:.3g}"
                   for n, c in zip(names, centre, strict=True)]
            readout = ["  ".join(f"{r} = {v:+.3f}" for r, v in zip(ref, row, strict=True))
                       for row in off]
        panels.append(Panel(anchor=anchor, points=pos, colour=COLOURS[i],
                             title=f"{titles[i]}\n{sub}{fate}", readout=readout,
                             blur=chains if stride else None))
        qs.append(q)
        qds.append(qd)
        anchors.append(anchor)
        positions.append(pos)
        stayed.append(ok)
        fall.append(when)
        stable.append(lin)

    if title is None:
        title = "Released from each scene's [initial] state" + (
            f"; STAYS UP: every angle within π/2 of {about}"
            if isinstance(about, str) and any(x is not None for x in stayed) else "")
    stage = Stage(panels, t, title, slow, frames_per_period if omega else None, width,
                   stride=stride)
    render(where, stage, path, fps_shown, progress, "system_animation")
    return SystemAnimation(
        path=path, frames=len(t), width=stage.width, height=stage.height,
        bytes=path.stat().st_size, t=t, coordinates=tuple(tuple(sc.system.coordinates)
                                                          for sc in scenes),
        q=tuple(qs), qdot=tuple(qds), anchor=np.stack(anchors), positions=tuple(positions),
        titles=tuple(p.title for p in panels),
        about=None if about is None else np.asarray(centre),
        stayed_up=None if about is None else tuple(stayed), fall_time=tuple(fall),
        floquet_stable=None if about is None else tuple(stable), fps=fps_shown,
        frames_per_period=frames_per_period if omega else None, slow_motion=slow,
        seconds=time.perf_counter() - started, periods_per_frame=stride)


def _evaluate(where, exprs, names, q, t, params, t_symbol):
    """The expressions (of the coordinates ``names``, time and parameters) at every frame,
    each an array of t's shape."""
    import sympy as sp
    symbols = sorted(set().union(*(e.free_symbols for e in exprs)), key=str)
    args = []
    for s in symbols:
        if s == t_symbol:
            args.append(t)
        elif s.name in names:
            args.append(q[:, names.index(s.name)])
        elif s.name in params:
            args.append(float(params[s.name]))
        else:
            raise ValueError(f"{where}a particle's position depends on {s.name}, which is "
                             "neither a coordinate, t nor a parameter of its scene.")
    f = sp.lambdify(symbols, exprs, "numpy")
    return [np.broadcast_to(np.asarray(v, float), t.shape) for v in f(*args)]
