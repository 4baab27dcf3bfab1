"""Animations: the stabilised inverted pendulum beside one that falls, as a looping GIF.

What is drawn is what was simulated
-----------------------------------
Both pendulums are integrated by :meth:`kapitza.KapitzaPendulum.simulate` with output at
exactly the frame times (the RKN and DOP853 drivers land on each requested time; no
interpolation afterwards), and each frame draws those angles and the pivot's height
y_p = A cos ωt at the same instant (shared/PHYSICS.md: θ from the downward vertical,
θ = π upright).

Slow motion, never aliasing
---------------------------
The drive is far faster than any frame rate a GIF can show (a real Kapitza pendulum
shakes at tens of hertz).  Frames are therefore taken at t_k = k T / n, an integer number
n = ``frames_per_period`` ≥ 4 of frames in every drive period T = 2π/ω: every period is
drawn at the same n phases, so the pivot is seen going up and down at its true frequency
(sampling above the Nyquist rate) and the drive cannot alias into a slow false motion, as
stroboscopic sampling near a multiple of the drive frequency would.  The GIF then plays
slowed down by the factor

    slow_motion = n / (T · fps_shown),

stated on every frame (``fps_shown`` is the frame rate the GIF really stores: its delays
are whole centiseconds).  A scene in which the shake is visible and the physics is the
Kapitza effect is ω/ω0 ≈ 10–30 with A/l ≈ 0.1–0.3 inside the exact window
``KapitzaPendulum.stability_window``; e.g. ω/ω0 = 10, A/l = 0.25 (window 0.142 < A/l <
0.471 for l = 1 m) plays at slow motion ×2 with the defaults.

The GIF loops (``loop=0``), is 720 px wide by default, and is written with matplotlib's
``animation.PillowWriter`` (no dependency beyond matplotlib).
"""
from __future__ import annotations

import math
import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from lagrange_core.progress import ProgressLine

from . import arguments

__all__ = ["Animation", "pendulum_animation"]

#: The band that decides "stays up": |θ − π| < π/2 (as :meth:`KapitzaPendulum.measure`).
UPRIGHT_BAND = math.pi / 2


@dataclass(frozen=True)
class Animation:
    """A GIF written by :func:`pendulum_animation` and the trajectories it draws.

    Attributes
    ----------
    path : pathlib.Path
        The GIF.
    frames : int
        Number of frames (the GIF's, too).
    width, height : int
        Frame size (pixels).
    bytes : int
        File size (bytes).
    t : ndarray (frames,)
        The simulated time of each frame (s): t_k = k T / frames_per_period.
    theta : ndarray (2, frames)
        θ drawn in each frame (rad, from the downward vertical; θ = π upright), row 0 the
        driven (stabilised) pendulum, row 1 the falling one: the simulated angles at ``t``.
    theta_dot : ndarray (2, frames)
        The angular velocities at ``t`` (rad/s).
    pivot : ndarray (2, frames)
        Pivot height y_p = A cos ωt of each pendulum in each frame (m).
    A : ndarray (2,)
        Drive amplitudes (m): the stabilising one and the falling side's (0: undriven).
    omega, l, g, damping : float
        Drive angular frequency (rad/s), length (m), gravity (m/s²), damping rate γ (1/s).
    theta0 : float
        The release angle of both (rad, from the downward vertical), at rest.
    window : (float, float)
        The exact window A_min < A < A_max at ω (m; Floquet, :meth:`stability_window`).
    floquet_stable : (bool, bool)
        Floquet stability of the upright state at each side's drive.
    stayed_up : (bool, bool)
        |θ − π| < π/2 in every frame (sampled every T/n: the fast wobble is resolved).
    fall_time : (float, float)
        First frame time with |θ − π| ≥ π/2 (s); NaN where it stayed up.
    max_tilt : (float, float)
        max |θ − π| over the frames (rad, wrapped into [0, π]).
    fps : float
        Frame rate stored in the GIF (frames per second; its delays are whole centiseconds).
    frames_per_period : int
        Frames per drive period T.
    slow_motion : float
        Playback slowed down by this factor: n / (T · fps).
    seconds : float
        Wall time of simulation and rendering (s).
    """

    path: Path
    frames: int
    width: int
    height: int
    bytes: int
    t: np.ndarray
    theta: np.ndarray
    theta_dot: np.ndarray
    pivot: np.ndarray
    A: np.ndarray
    omega: float
    l: float
    g: float
    damping: float
    theta0: float
    window: tuple
    floquet_stable: tuple
    stayed_up: tuple
    fall_time: tuple
    max_tilt: tuple
    fps: float
    frames_per_period: int
    slow_motion: float
    seconds: float

    @property
    def period(self) -> float:
        """The drive period T = 2π/ω (s)."""
        return 2 * math.pi / self.omega

    def to_dataframe(self):
        """One row per frame: frame, t (s), gif_time (s of playback), and per side
        (``stable_``/``falling_``) theta, theta_dot, pivot_y and the bob's x, y (m)."""
        import pandas as pd
        frame = {"frame": np.arange(self.frames), "t": self.t,
                 "gif_time": np.arange(self.frames) / self.fps}
        for i, side in enumerate(("stable", "falling")):
            x, y = bob_position(self.theta[i], self.pivot[i], self.l)
            frame.update({f"{side}_theta": self.theta[i], f"{side}_theta_dot": self.theta_dot[i],
                          f"{side}_pivot_y": self.pivot[i], f"{side}_bob_x": x,
                          f"{side}_bob_y": y})
        return pd.DataFrame(frame)


def bob_position(theta, pivot_y, l):
    """The bob of a pendulum of length l (m) at angle θ (rad, from the downward vertical)
    hanging from the pivot (0, pivot_y): (l sin θ, pivot_y − l cos θ) (m)."""
    theta = np.asarray(theta, float)
    return l * np.sin(theta), np.asarray(pivot_y, float) - l * np.cos(theta)


def _tilt(theta):
    """|θ − π| wrapped into [0, π] (rad): the distance from the upright."""
    return np.abs((np.asarray(theta) - math.pi + math.pi) % (2 * math.pi) - math.pi)


def _check(where, name, value, unit, *, minimum=None, strict=True, example=""):
    try:
        return arguments.real_number(value, name, unit=unit, minimum=minimum, strict=strict)
    except ValueError:
        need = "" if minimum is None else f" {'>' if strict else '≥'} {minimum:g}"
        raise ValueError(f"{where}{name} must be a finite number{need} ({unit}), got "
                         f"{value!r}{'; e.g. ' + example if example else ''}.") from None


def pendulum_animation(path, *, A: float, omega: float, l: float = 1.0, g: float = 9.81,
                       theta0: float = math.pi - 0.1, damping: float = 0.0,
                       A_fall: float = 0.0, duration: float = 4.0, fps: float = 20.0,
                       frames_per_period: int = 8, width: int = 720, max_frames: int = 600,
                       rtol: float = 1e-10, progress=None) -> Animation:
    """Write a looping GIF of a stabilised inverted pendulum beside one that falls.

    Two pendulums of length ``l`` are released at rest from the same angle ``theta0``
    near the upright.  The left one's pivot is shaken vertically as A cos ωt inside the
    exact stability window (it stays up, wobbling slowly about θ = π); the right one is
    undriven (``A_fall = 0``) or shaken with an amplitude outside the window at the same
    ω, and falls.  Each panel is labelled with its drive and what happens; every frame
    carries the simulated time and the slow-motion factor.  Module docstring: how the
    frame times avoid aliasing the drive.

    Parameters
    ----------
    path : str or Path
        The GIF to write (``.gif``; parent directories are created).
    A : float
        Drive amplitude of the stabilised pendulum (m): inside the exact window
        A_min < A < A_max at ``omega`` (:meth:`KapitzaPendulum.stability_window`), or
        ``ValueError``.  For a visible shake choose A/l ≈ 0.1–0.3.
    omega : float
        Drive angular frequency (rad/s), the same for both; ω/ω0 ≈ 10–30 keeps the
        GIF short (ω0 = √(g/l)).
    l, g, damping : float
        Length (m), gravity (m/s²) and viscous damping rate γ (1/s) of both pendulums.
    theta0 : float
        Release angle (rad, from the downward vertical; default π − 0.1: 0.1 rad from the
        upright), at rest; 0 < |θ0 − π| < π/2.
    A_fall : float
        Drive amplitude of the falling pendulum (m, ≥ 0): 0 (undriven, the default) or
        any amplitude outside the window (Floquet-unstable upright state).
    duration : float
        Simulated time (s), > 0.  Frames: ⌊duration / (T/n)⌋ + 1.
    fps : float
        Playback frame rate (frames per second), 1–50 (GIF viewers slow faster ones);
        the GIF stores whole-centisecond delays, and ``Animation.fps`` the rate stored.
    frames_per_period : int
        Frames n per drive period T = 2π/ω, ≥ 4, so the drive is resolved, not aliased;
        the slow-motion factor is n / (T · fps).
    width : int
        Frame width (pixels), 300–2000; the height is 0.6 of it.
    max_frames : int
        Refuse to render more frames than this (a guard against e.g. a 60 Hz drive
        drawn 8 times a period for seconds: the error says what to change).
    rtol : float
        Relative tolerance of the integration.
    progress : None, bool or callable
        Progress of the rendering on stderr (:class:`lagrange_core.progress.ProgressLine`:
        None shows a line when stderr is a terminal).  Ctrl-C stops the rendering, writes
        the frames finished so far to ``path`` and raises ``KeyboardInterrupt``.

    Returns
    -------
    Animation
        The file, its frame count and size, the drawn trajectories (``t``, ``theta``,
        ``pivot``) and the classifications (simulated ``stayed_up`` / ``fall_time``,
        ``floquet_stable``); ``to_dataframe()`` gives one row per frame.

    Raises
    ------
    ValueError
        Naming the argument, the value and the fix: A outside the window, A_fall inside
        it, a non-positive duration, too many frames, a path that is not ``.gif``, ...

    Warns
    -----
    UserWarning
        If the simulation contradicts the label's expectation within ``duration``: the
        driven pendulum leaves the upright band (released outside the basin of the
        upright state: use a smaller tilt) or the falling one has not yet fallen (use a
        longer duration).  The labels always state what the simulation did.

    Examples
    --------
    >>> import math, kapitza
    >>> w0 = math.sqrt(9.81)
    >>> anim = kapitza.pendulum_animation("pendulum.gif", A=0.25,
    ...                                   omega=10 * w0)              # doctest: +SKIP
    >>> anim.stayed_up, anim.frames, round(anim.slow_motion, 2)     # doctest: +SKIP
    ((True, False), 160, 1.99)
    """
    import time
    from .pendulum import KapitzaPendulum

    where = "pendulum_animation: "
    started = time.perf_counter()
    path = Path(path)
    if path.suffix.lower() != ".gif":
        raise ValueError(f"{where}path must end in .gif, got {str(path)!r}; e.g. "
                         "'pendulum.gif'.")
    l, g, damping = arguments.pendulum_constants(l, g, damping, where=where)
    omega = _check(where, "omega", omega, "rad/s", minimum=0.0, example="omega=31.3")
    A = _check(where, "A", A, "m", minimum=0.0, strict=False)
    A_fall = _check(where, "A_fall", A_fall, "m", minimum=0.0, strict=False,
                    example="A_fall=0 (undriven)")
    theta0 = _check(where, "theta0", theta0, "rad", example="theta0=math.pi - 0.1")
    duration = _check(where, "duration", duration, "s", minimum=0.0,
                      example="duration=4 (simulated seconds)")
    fps = _check(where, "fps", fps, "frames/s", minimum=0.0, example="fps=20")
    rtol = _check(where, "rtol", rtol, "", minimum=0.0, example="rtol=1e-10")
    if not 1 <= fps <= 50:
        raise ValueError(f"{where}fps must be between 1 and 50 frames/s (GIF viewers show "
                         f"delays under 20 ms slower), got {fps:g}; e.g. fps=20.")
    for name, value, low, high in (("frames_per_period", frames_per_period, 4, 10_000),
                                   ("width", width, 300, 2000),
                                   ("max_frames", max_frames, 2, 100_000)):
        if isinstance(value, bool) or not isinstance(value, (int, np.integer)) \
                or not low <= value <= high:
            raise ValueError(f"{where}{name} must be an integer from {low} to {high}, got "
                             f"{value!r}" + ("; fewer than 4 frames a drive period would "
                                             "alias the drive" if name ==
                                             "frames_per_period" else "") + ".")
    tilt0 = float(_tilt(theta0))
    if not 0 < tilt0 < UPRIGHT_BAND:
        raise ValueError(f"{where}theta0 must be released near the upright, 0 < |θ0 − π| < "
                         f"π/2 (θ from the downward vertical), got theta0 = {theta0!r} rad "
                         f"(|θ0 − π| = {tilt0:.3g}); e.g. theta0=math.pi - 0.1.")

    pend = KapitzaPendulum(l=l, g=g, damping=damping)
    win = pend.stability_window(omega)
    A_min, A_max = float(np.squeeze(win.A_min)), float(np.squeeze(win.A_max))
    if not A_min < A < A_max:
        fix = ("no amplitude holds the pendulum up at this ω; raise omega (ω/ω0 ≳ 3)"
               if not A_min < A_max else
               f"choose A between them, e.g. A = {0.5 * (A_min + min(A_max, 2 * A_min)):.4g} m")
        raise ValueError(f"{where}A = {A:.6g} m is outside the window that holds the "
                         f"pendulum upright at omega = {omega:.6g} rad/s "
                         f"(ω/ω0 = {omega / pend.omega0:.4g}): A_min = {A_min:.6g} m, "
                         f"A_max = {A_max:.6g} m (exact, Floquet); {fix}.")
    stable = (bool(pend.floquet(A, omega).stable), bool(pend.floquet(A_fall, omega).stable))
    if stable[1]:
        raise ValueError(f"{where}A_fall = {A_fall:.6g} m lies inside the window A_min = "
                         f"{A_min:.6g} m < A < A_max = {A_max:.6g} m, so the right-hand "
                         "pendulum would stay up too; use A_fall = 0 (undriven) or "
                         f"A_fall < {A_min:.4g} m.")

    period = 2 * math.pi / omega
    dt = period / frames_per_period
    frames = int(math.floor(duration / dt * (1 + 1e-12))) + 1
    if frames < 2:
        raise ValueError(f"{where}duration = {duration:g} s is shorter than one frame "
                         f"interval T/n = {dt:.4g} s; use duration ≥ {dt:.4g} s.")
    if frames > max_frames:
        raise ValueError(
            f"{where}{frames} frames needed ({frames_per_period} per drive period of "
            f"{period:.4g} s over duration = {duration:g} s), more than max_frames = "
            f"{max_frames}; shorten duration to ≤ {(max_frames - 1) * dt:.3g} s, lower "
            f"omega (ω/ω0 ≈ 10–30 is enough to stabilise), or raise max_frames.")
    # whole-centisecond delays are what a GIF stores: state the rate it really plays at
    delay_cs = max(1, round(int(1000 / fps) / 10))
    fps_shown = 100.0 / delay_cs
    slow = frames_per_period / (period * fps_shown)

    t = np.arange(frames) * dt
    amps = np.array([A, A_fall])
    theta = np.empty((2, frames))
    theta_dot = np.empty((2, frames))
    for i, amp in enumerate(amps):
        traj = pend.simulate(theta0, 0.0, (0.0, float(t[-1])), float(amp), omega, rtol=rtol,
                             t_eval=t)
        if traj.status != "success" or traj.t.shape != t.shape:
            raise RuntimeError(f"{where}the simulation with A = {amp:.6g} m stopped: "
                               f"{traj.status} ({traj.message}).")
        theta[i], theta_dot[i] = traj.q[:, 0], traj.qdot[:, 0]
    pivot = amps[:, None] * np.cos(omega * t)[None, :]
    tilt = _tilt(theta)
    out = tilt >= UPRIGHT_BAND
    stayed = (bool(not out[0].any()), bool(not out[1].any()))
    fall = tuple(float(t[np.argmax(o)]) if o.any() else math.nan for o in out)
    if not stayed[0]:
        warnings.warn(f"{where}the driven pendulum (A = {A:.4g} m, inside the window) fell at "
                      f"t = {fall[0]:.3g} s: a release {tilt0:.3g} rad from the upright is "
                      "outside its basin; use a smaller tilt (theta0 closer to π).",
                      stacklevel=2)
    if stayed[1]:
        warnings.warn(f"{where}the falling pendulum has not fallen within duration = "
                      f"{duration:g} s (max tilt {tilt[1].max():.3g} rad); use a longer "
                      "duration.", stacklevel=2)

    scene = dict(l=l, g=g, damping=damping, omega=omega, omega0=pend.omega0, amps=amps,
                 window=(A_min, A_max), stayed=stayed, fall=fall, floquet=stable,
                 tilt0=tilt0, slow=slow, frames_per_period=frames_per_period)
    stage = _Stage(scene, t, theta, pivot, width)
    written = 0
    line = ProgressLine(progress, frames, "pendulum_animation", "frames")
    try:
        writer = _gif_writer(fps_shown)
        with writer.saving(stage.fig, str(path), dpi=stage.dpi):
            for k in range(frames):
                stage.draw(k)
                writer.grab_frame()
                written = k + 1
                line.update(written)
    except KeyboardInterrupt:
        line.close()
        import sys
        print(f"\n{where}interrupted after {written} of {frames} frames; they are in "
              f"{path}.", file=sys.stderr, flush=True)
        raise
    finally:
        stage.close()
    line.close()
    return Animation(path=path, frames=frames, width=stage.width, height=stage.height,
                     bytes=path.stat().st_size, t=t, theta=theta, theta_dot=theta_dot,
                     pivot=pivot, A=amps, omega=omega, l=l, g=g, damping=damping,
                     theta0=theta0, window=(A_min, A_max), floquet_stable=stable,
                     stayed_up=stayed, fall_time=fall, max_tilt=tuple(map(float, tilt.max(1))),
                     fps=fps_shown, frames_per_period=frames_per_period, slow_motion=slow,
                     seconds=time.perf_counter() - started)


def _gif_writer(fps):
    """matplotlib's PillowWriter, writing every frame with one shared palette of 64 colours
    and no dithering: flat colours compress ~4× better than per-frame dithered palettes."""
    from matplotlib.animation import PillowWriter
    from PIL import Image

    class GifWriter(PillowWriter):
        def finish(self):
            if not self._frames:
                return
            rgb = [f.convert("RGB") for f in self._frames]
            # the palette from a mosaic of first, middle and last frame (every colour drawn)
            picks = [rgb[0], rgb[len(rgb) // 2], rgb[-1]]
            mosaic = Image.new("RGB", (sum(f.width for f in picks), picks[0].height))
            x = 0
            for f in picks:
                mosaic.paste(f, (x, 0))
                x += f.width
            palette = mosaic.quantize(colors=64, method=Image.Quantize.MEDIANCUT,
                                      dither=Image.Dither.NONE)
            # median cut averages its boxes: make the entry nearest white pure white again
            colours = np.array(palette.getpalette()[:192], float).reshape(-1, 3)
            white = int(np.argmin(np.abs(colours - 255).sum(1)))
            colours[white] = 255
            palette.putpalette(colours.astype(np.uint8).ravel().tolist())
            frames = [f.quantize(palette=palette, dither=Image.Dither.NONE) for f in rgb]
            frames[0].save(self.outfile, save_all=True, append_images=frames[1:],
                           duration=int(1000 / self.fps), loop=0)

    return GifWriter(fps=fps)


class _Stage:
    """The figure of two pendulums and how frame k is drawn on it.

    ``draw(k)`` sets the artists from the arrays it was given, nothing else: the tests read
    the artists' data back (``rods``, ``bobs``) against an independent simulation.
    """

    colours = ("tab:blue", "tab:red")

    def __init__(self, scene, t, theta, pivot, width):
        import matplotlib
        from matplotlib.figure import Figure
        from matplotlib.backends.backend_agg import FigureCanvasAgg

        self.scene, self.t, self.theta, self.pivot = scene, t, theta, pivot
        self.dpi = 100
        self.width, self.height = int(width), int(round(0.7 * width))
        fig = Figure(figsize=(self.width / self.dpi, self.height / self.dpi), dpi=self.dpi)
        FigureCanvasAgg(fig)
        self.fig = fig
        l = scene["l"]
        amps = scene["amps"]
        reach = 1.12 * l + float(amps.max())
        scale = self.width / 720
        big, font, small = ({"fontsize": s * scale} for s in (11.5, 10, 8.5))
        self.trail_len = scene["frames_per_period"]
        self.rods, self.bobs, self.trails, self.tilts = [], [], [], []
        self.pivots = []
        with matplotlib.rc_context({"font.size": 10 * scale}):
            axes = fig.subplots(1, 2, gridspec_kw=dict(left=0.01, right=0.99, bottom=0.115,
                                                       top=0.755, wspace=0.03))
            for i, ax in enumerate(axes):
                ax.set_xlim(-reach, reach)
                ax.set_ylim(-reach, reach)
                ax.set_aspect("equal")
                ax.set_xticks([])
                ax.set_yticks([])
                for s in ax.spines.values():
                    s.set_color("0.8")
                amp = float(amps[i])
                # the pivot's range of travel (its shake, ±A) and the upright direction
                if amp > 0:
                    ax.fill_between([-0.07 * l, 0.07 * l], -amp, amp, color="0.85", lw=0,
                                    zorder=0)
                ax.plot([0, 0], [0, 1.1 * l], ls=(0, (4, 4)), color="0.6", lw=0.8, zorder=0)
                trail, = ax.plot([], [], color=self.colours[i], lw=1.2, alpha=0.4, zorder=1)
                rod, = ax.plot([], [], color=self.colours[i], lw=3 * scale,
                               solid_capstyle="round", zorder=2)
                bob, = ax.plot([], [], "o", color=self.colours[i], ms=13 * scale, zorder=3)
                piv, = ax.plot([], [], "s", color="k", ms=6 * scale, zorder=4)
                tilt = ax.text(0.03, 0.03, "", transform=ax.transAxes, ha="left",
                               va="bottom", family="monospace", **small)
                ax.set_title(self._label(i), color=self.colours[i], pad=5, linespacing=1.35,
                             **font)
                self.rods.append(rod)
                self.bobs.append(bob)
                self.trails.append(trail)
                self.pivots.append(piv)
                self.tilts.append(tilt)
            fig.suptitle(f"Kapitza pendulum: both released at rest {scene['tilt0']:.3g} rad "
                         f"from the upright (l = {l:g} m, g = {scene['g']:g} m/s²"
                         + (f", γ = {scene['damping']:g} 1/s" if scene["damping"] else "")
                         + ")", y=0.985, **big)
            self.clock = fig.text(0.5, 0.052, "", ha="center", va="bottom", **font)
            fig.text(0.5, 0.012, "grey bar: the pivot's travel ±A    dashed: the upright    "
                     "faint curve: the bob's path over the last drive period",
                     ha="center", va="bottom", color="0.4", **small)

    def _label(self, i):
        s = self.scene
        l, w0, omega = s["l"], s["omega0"], s["omega"]
        A = float(s["amps"][i])
        A_min, A_max = s["window"]
        f = omega / (2 * math.pi)
        if A > 0:
            drive = (f"pivot shaken: A/l = {A / l:.3g}, ω/ω0 = {omega / w0:.3g}\n"
                     f"(A = {A:.3g} m at f = {f:.3g} Hz)")
        else:
            drive = "pivot not shaken (A = 0)\n "
        where = ("inside" if A_min < A < A_max else "outside") + \
            f" the window {A_min / l:.3g} < A/l < {A_max / l:.3g}"
        floquet = "Floquet: stable" if s["floquet"][i] else "Floquet: unstable"
        if s["stayed"][i]:
            fate = "STAYS UP"
        else:       # the simulation's verdict: past the horizontal, |θ − π| ≥ π/2
            fate = f"FALLS at t = {s['fall'][i]:.2f} s"
        return f"{drive}\n{where}\n{floquet} → {fate}"

    def draw(self, k):
        l = self.scene["l"]
        for i in range(2):
            x, y = bob_position(self.theta[i, k], self.pivot[i, k], l)
            self.rods[i].set_data([0.0, x], [self.pivot[i, k], y])
            self.bobs[i].set_data([x], [y])
            self.pivots[i].set_data([0.0], [self.pivot[i, k]])
            # the bob's path over the last drive period: the fast wobble, seen as a smear
            j = slice(max(0, k - self.trail_len), k + 1)
            tx, ty = bob_position(self.theta[i, j], self.pivot[i, j], l)
            self.trails[i].set_data(tx, ty)
            dev = (self.theta[i, k] - math.pi + math.pi) % (2 * math.pi) - math.pi
            self.tilts[i].set_text(f"θ − π = {dev:+.3f} rad")
        self.clock.set_text(f"t = {self.t[k]:5.3f} s    slow motion ×{self.scene['slow']:.3g} "
                            f"({self.scene['frames_per_period']} frames per drive period)")

    def close(self):
        self.fig.clear()
