"""Animations as looping GIFs: the stabilised inverted pendulum beside one that falls
(:func:`pendulum_animation`), and planar chains of particles from scenes side by side,
e.g. Acheson's double pendulum upright and falling (:func:`system_animation`).

What is drawn is what was simulated
-----------------------------------
Both pendulums are integrated by :meth:`kapitza.KapitzaPendulum.simulate` (a scene's system
by :meth:`lagrange_core.System.simulate`) with output at exactly the frame times (the RKN
and DOP853 drivers land on each requested time; no interpolation afterwards), and each
frame draws those angles and the pivot's height y_p = A cos ωt at the same instant
(shared/PHYSICS.md: θ from the downward vertical, θ = π upright); a scene's particles are
drawn at its system's own positions r_i(q, t).

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

Stroboscopic frames for fast drives
-----------------------------------
A drive too fast for that (Kapitza's own 60 Hz: 8 frames a period are 480 frames a second)
is shown stroboscopically instead (``mode="strobe"``, or ``"auto"`` when slow motion would
need more than ``max_frames`` or play more than 10× slower than real time): one frame
every m ≈ 1/(fps T) whole drive periods, t_k = k m T, so the pivot is always at the same
phase (y_p = A, the top) and the frames show the slow motion at about real time, as a
strobe lamp at the drive's frequency would.  What the strobe skips is drawn, not hidden:
the pivot's travel as a grey band, and the pendulum faint at n phases through the drive
period after each frame (the blur a camera exposing for one period would record), all
from the same simulation.

The GIF loops (``loop=0``), is 720 px wide by default, and is written with matplotlib's
``animation.PillowWriter`` (no dependency beyond matplotlib).
"""
from __future__ import annotations

import math
import sys
import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from lagrange_core.progress import ProgressLine

from .. import _arguments as arguments

__all__ = ["Animation", "SystemAnimation", "pendulum_animation", "system_animation"]

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
        When |θ − π| reached π/2 (s; interpolated linearly between the samples around it,
        error ≲ Δt² θ̈ / (8 θ̇): 1.7e-4 s for the default scene at 8 frames a period,
        against the exact 1.11802 s of energy conservation); NaN where it stayed up.
    max_tilt : (float, float)
        max |θ − π| over the frames (rad, wrapped into [0, π]).
    fps : float
        Frame rate stored in the GIF (frames per second; its delays are whole centiseconds).
    frames_per_period : int
        Frames per drive period T.
    slow_motion : float
        Playback slowed down by this factor: simulated time per frame × fps, inverted
        (n / (T · fps) in slow motion; < 1 plays faster than real time).
    seconds : float
        Wall time of simulation and rendering (s).
    periods_per_frame : int or None
        The strobe's m drive periods between frames (t_k = k m T); None: slow motion.
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
    periods_per_frame: int | None = None

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
                                                    self.positions)):
            cols = {"panel": i, "frame": np.arange(self.frames), "t": self.t,
                    "pivot_x": self.anchor[i, :, 0], "pivot_y": self.anchor[i, :, 1]}
            for j, c in enumerate(names):
                cols[c], cols[f"{c}_dot"] = q[:, j], qd[:, j]
            for j in range(pos.shape[1]):
                cols[f"x{j + 1}"], cols[f"y{j + 1}"] = pos[:, j, 0], pos[:, j, 1]
            parts.append(pd.DataFrame(cols))
        return pd.concat(parts, ignore_index=True)


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


def _playback(where, duration, fps, rtol, frames_per_period, width, max_frames):
    """The options every animation shares, checked: (duration, fps, rtol) as floats."""
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
    return duration, fps, rtol


MODES = ("auto", "slow", "strobe")
#: mode="auto" strobes a drive whose slow motion would be slower than this
SLOWEST = 10.0


def _frame_times(where, omega, duration, fps, frames_per_period, max_frames, fix, mode):
    """The frames' times and how they play.

    Returns (t, fps_shown, slow, stride): frame times t (s); the frame rate the GIF stores;
    the playback's slow-motion factor (simulated s per played s, inverted); ``stride`` None
    for slow motion (t_k = k T/n) or the m drive periods between stroboscopic frames
    (t_k = k m T, m ≈ 1/(fps T): about real time).  Without a drive (``omega`` None) the
    frames are real time, t_k = k/fps.  ``mode="auto"`` takes slow motion when its frames
    fit ``max_frames`` and it is at most :data:`SLOWEST` times slower than real time,
    else the strobe.
    """
    if mode not in MODES:
        raise ValueError(f"{where}mode must be one of {MODES}, got {mode!r}.")
    # whole-centisecond delays are what a GIF stores: state the rate it really plays at
    fps_shown = 100.0 / max(1, round(int(1000 / fps) / 10))
    stride = None
    if omega is None:
        dt, what = 1 / fps_shown, f"1/fps = {1 / fps_shown:.4g} s"
    else:
        period = 2 * math.pi / omega
        dt, what = period / frames_per_period, f"T/n = {period / frames_per_period:.4g} s"
        too_slow = 1 / (dt * fps_shown) > SLOWEST
        if mode == "strobe" or (mode == "auto" and (_count(duration, dt) > max_frames
                                                    or too_slow)):
            stride = max(1, round(1 / (fps_shown * period)))
            dt, what = stride * period, f"{stride} drive period(s) = {stride * period:.4g} s"
    frames = _count(duration, dt)
    if frames < 2:
        raise ValueError(f"{where}duration = {duration:g} s is shorter than one frame "
                         f"interval {what}; use duration ≥ {dt:.4g} s.")
    if frames > max_frames:
        per = ("" if omega is None else f" ({frames_per_period} per drive period of "
               f"{2 * math.pi / omega:.4g} s)" if stride is None else
               f" (one every {what})")
        strobe = ", mode='strobe'" if omega is not None and stride is None else ""
        raise ValueError(f"{where}{frames} frames needed{per} over duration = {duration:g} s, "
                         f"more than max_frames = {max_frames}; shorten duration to ≤ "
                         f"{(max_frames - 1) * dt:.3g} s, {fix}{strobe}, or raise max_frames.")
    return np.arange(frames) * dt, fps_shown, 1 / (dt * fps_shown), stride


def _count(duration, dt):
    return int(math.floor(duration / dt * (1 + 1e-12))) + 1


def _samples(t, omega, stride, frames_per_period):
    """The simulation's output times, (frames, s): each frame's time, and with the strobe
    also the n − 1 later phases of its drive period (the rod drawn faint through them)."""
    sub = frames_per_period if stride else 1
    return t[:, None] + np.arange(sub)[None, :] * (2 * math.pi / omega / sub if stride else 0)


def _render(where, stage, path, fps, progress, label):
    """Draw every frame of ``stage`` into the GIF ``path``; Ctrl-C keeps the frames done."""
    frames = stage.frames
    written = 0
    line = ProgressLine(progress, frames, label, "frames")
    try:
        writer = _gif_writer(fps, exact=[*stage.colours, "0.85", "0.6", "0.4", "0.8"])
        with writer.saving(stage.fig, str(path), dpi=stage.dpi):
            for k in range(frames):
                stage.draw(k)
                writer.grab_frame()
                written = k + 1
                line.update(written)
    except KeyboardInterrupt:
        line.close()
        print(f"\n{where}interrupted after {written} of {frames} frames; they are in "
              f"{path}.", file=sys.stderr, flush=True)
        raise
    finally:
        stage.close()
    line.close()


def pendulum_animation(path, *, A: float, omega: float, l: float = 1.0, g: float = 9.81,
                       theta0: float = math.pi - 0.1, damping: float = 0.0,
                       A_fall: float = 0.0, duration: float = 4.0, fps: float = 20.0,
                       frames_per_period: int = 8, width: int = 720, max_frames: int = 600,
                       rtol: float = 1e-10, mode: str = "auto", progress=None) -> Animation:
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
        the slow-motion factor is n / (T · fps).  With the strobe: the phases at which
        the chain is drawn faint through each frame's drive period.
    mode : {"auto", "slow", "strobe"}
        "slow": n frames every drive period, in slow motion; "strobe": one frame every
        m ≈ 1/(fps T) drive periods at the same phase (about real time), the pendulum
        drawn faint through the period after each frame, for drives too fast to show in
        slow motion (module docstring); "auto" (default): slow motion when its frames fit
        ``max_frames`` and it plays at most 10× slower than real time, else the strobe.
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
    from ..pendulum import KapitzaPendulum

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
    duration, fps, rtol = _playback(where, duration, fps, rtol, frames_per_period, width,
                                    max_frames)
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

    t, fps_shown, slow, stride = _frame_times(
        where, omega, duration, fps, frames_per_period, max_frames,
        fix="lower omega (ω/ω0 ≈ 10–30 is enough to stabilise)", mode=mode)
    frames = len(t)
    samples = _samples(t, omega, stride, frames_per_period)
    amps = np.array([A, A_fall])
    theta_all = np.empty((2,) + samples.shape)
    theta_dot_all = np.empty((2,) + samples.shape)
    for i, amp in enumerate(amps):
        traj = pend.simulate(theta0, 0.0, (0.0, float(samples[-1, -1])), float(amp), omega,
                             rtol=rtol, t_eval=samples.ravel())
        if traj.status != "success" or traj.t.shape != (samples.size,):
            raise RuntimeError(f"{where}the simulation with A = {amp:.6g} m stopped: "
                               f"{traj.status} ({traj.message}).")
        theta_all[i] = traj.q[:, 0].reshape(samples.shape)
        theta_dot_all[i] = traj.qdot[:, 0].reshape(samples.shape)
    theta, theta_dot = theta_all[:, :, 0], theta_dot_all[:, :, 0]
    pivot_all = amps[:, None, None] * np.cos(omega * samples)[None]
    pivot = pivot_all[:, :, 0]
    tilt = _tilt(theta_all).reshape(2, -1)
    out = tilt >= UPRIGHT_BAND
    stayed = (bool(not out[0].any()), bool(not out[1].any()))
    fall = tuple(_crossing(samples.ravel(), d) for d in tilt)
    if not stayed[0]:
        warnings.warn(f"{where}the driven pendulum (A = {A:.4g} m, inside the window) fell at "
                      f"t = {fall[0]:.3g} s: a release {tilt0:.3g} rad from the upright is "
                      "outside its basin; use a smaller tilt (theta0 closer to π).",
                      stacklevel=2)
    if stayed[1]:
        warnings.warn(f"{where}the falling pendulum has not fallen within duration = "
                      f"{duration:g} s (max tilt {tilt[1].max():.3g} rad); use a longer "
                      "duration.", stacklevel=2)

    stage = _pendulum_stage(t, theta_all, pivot_all, amps, l=l, g=g, damping=damping,
                            omega=omega, window=(A_min, A_max), stayed=stayed, fall=fall,
                            floquet=stable, tilt0=tilt0, slow=slow,
                            frames_per_period=frames_per_period, stride=stride, width=width)
    _render(where, stage, path, fps_shown, progress, "pendulum_animation")
    return Animation(path=path, frames=frames, width=stage.width, height=stage.height,
                     bytes=path.stat().st_size, t=t, theta=theta, theta_dot=theta_dot,
                     pivot=pivot, A=amps, omega=omega, l=l, g=g, damping=damping,
                     theta0=theta0, window=(A_min, A_max), floquet_stable=stable,
                     stayed_up=stayed, fall_time=fall, max_tilt=tuple(map(float, tilt.max(1))),
                     fps=fps_shown, frames_per_period=frames_per_period, slow_motion=slow,
                     seconds=time.perf_counter() - started, periods_per_frame=stride)


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
    duration, fps, rtol = _playback(where, duration, fps, rtol, frames_per_period, width,
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
    omegas = {float(sc.params["omega"]) for sc in scenes if sc._drive is not None}
    if len(omegas) > 1:
        raise ValueError(f"{where}the driven scenes have different drive frequencies "
                         f"{sorted(omegas)} rad/s; the frames follow one drive period, so give "
                         "them one omega.")
    omega = omegas.pop() if omegas else None
    t, fps_shown, slow, stride = _frame_times(where, omega, duration, fps, frames_per_period,
                                              max_frames, fix="or a slower drive", mode=mode)
    samples = _samples(t, omega, stride, frames_per_period)     # (frames, s)
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
        drive = sc._drive
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
            when = _crossing(flat, dev)
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
            readout = ["  ".join(f"{n} = {v:+.3f}" for n, v in zip(names, row)) for row in q]
        else:   # the distance from ``about``, wrapped into [−π, π) (rad)
            off = (q - centre + math.pi) % (2 * math.pi) - math.pi
            ref = [n if c == 0 else f"{n} − π" if c == math.pi else f"{n} − {c:.3g}"
                   for n, c in zip(names, centre)]
            readout = ["  ".join(f"{r} = {v:+.3f}" for r, v in zip(ref, row)) for row in off]
        panels.append(_Panel(anchor=anchor, points=pos, colour=_COLOURS[i],
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
    stage = _Stage(panels, t, title, slow, frames_per_period if omega else None, width,
                   stride=stride)
    _render(where, stage, path, fps_shown, progress, "system_animation")
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


def _crossing(t, dev):
    """When ``dev`` (distance from the upright, rad, sampled at ``t``) first reaches π/2 (s):
    linear interpolation between the two samples around it (its error is second order in
    their spacing, the drawn frames' or the strobe's phases'); NaN if it never does."""
    out = dev >= UPRIGHT_BAND
    if not out.any():
        return math.nan
    k = int(np.argmax(out))
    if k == 0:
        return float(t[0])
    d0, d1 = dev[k - 1], dev[k]
    return float(t[k - 1] + (t[k] - t[k - 1]) * (UPRIGHT_BAND - d0) / (d1 - d0))


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


def _gif_writer(fps, exact=()):
    """matplotlib's PillowWriter, writing every frame with one shared palette of 64 colours
    and no dithering (each pixel its nearest palette colour): flat colours compress better
    than the per-frame dithered palettes PillowWriter writes (the default 160-frame scene:
    0.44 MB against 1.86 MB, 4.2× smaller, and faster to write)."""
    from matplotlib.animation import PillowWriter
    from matplotlib.colors import to_rgb
    from PIL import Image

    class GifWriter(PillowWriter):
        def finish(self):
            if not self._frames:
                return
            rgb = [np.asarray(f.convert("RGB")) for f in self._frames]
            # the palette from first, middle and last frame side by side (every colour drawn)
            mosaic = Image.fromarray(np.hstack([rgb[0], rgb[len(rgb) // 2], rgb[-1]]))
            palette = np.array(mosaic.quantize(colors=64 - len(self.exact),
                                               method=Image.Quantize.MEDIANCUT,
                                               dither=Image.Dither.NONE).getpalette(),
                               float).reshape(-1, 3)
            # median cut averages its boxes: the colours drawn flat (background, text, rods,
            # the pivot's band) are added exactly, so they stay what was drawn
            palette = np.vstack([np.array(self.exact, float) * 255, palette])
            frames = []
            for f in rgb:
                code = (f[..., 0].astype(np.int32) << 16) | (f[..., 1].astype(np.int32) << 8) \
                    | f[..., 2]
                colours, where = np.unique(code, return_inverse=True)
                c = np.stack([colours >> 16, (colours >> 8) & 255, colours & 255], 1)
                nearest = np.argmin(((c[:, None, :] - palette[None]) ** 2).sum(2), 1)
                im = Image.fromarray(nearest[where].reshape(code.shape).astype(np.uint8), "P")
                im.putpalette(np.round(palette).astype(np.uint8).ravel().tolist())
                frames.append(im)
            frames[0].save(self.outfile, save_all=True, append_images=frames[1:],
                           duration=int(1000 / self.fps), loop=0)

    writer = GifWriter(fps=fps)
    writer.exact = [(1.0, 1.0, 1.0), (0.0, 0.0, 0.0), *map(to_rgb, exact)]
    return writer


def _pendulum_stage(t, theta, pivot, amps, *, l, g, damping, omega, window, stayed, fall,
                    floquet, tilt0, slow, frames_per_period, width, stride=None):
    """pendulum_animation's figure: two single-link chains from their pivots (0, y_p).

    ``theta`` and ``pivot`` are (2, frames) or (2, frames, s): each frame's state first,
    then (strobe) the later phases of its drive period, drawn faint."""
    theta, pivot = np.asarray(theta), np.asarray(pivot)
    if theta.ndim == 2:
        theta, pivot = theta[..., None], pivot[..., None]
    info = dict(l=l, omega=omega, omega0=math.sqrt(g / l), window=window, stayed=stayed,
                fall=fall, floquet=floquet)
    panels = []
    for i in range(2):
        x, y = bob_position(theta[i], pivot[i], l)                     # (frames, s)
        chains = np.stack([np.stack([np.zeros_like(x), pivot[i]], -1),
                           np.stack([x, y], -1)], 2)                  # (frames, s, 2, 2)
        dev = (theta[i, :, 0] - math.pi + math.pi) % (2 * math.pi) - math.pi
        panels.append(_Panel(anchor=chains[:, 0, 0], points=chains[:, 0, 1:],
                             colour=_COLOURS[i],
                             title=_pendulum_label(info, float(amps[i]), i),
                             readout=[f"θ − π = {d:+.3f} rad" for d in dev],
                             blur=chains if stride else None))
    title = f"Kapitza pendulum: both released at rest {tilt0:.3g} rad from the upright"
    constants = (f"l = {l:g} m, g = {g:g} m/s²" + (f", damping γ = {damping:g} 1/s" if damping
                                                   else ", no damping"))
    return _Stage(panels, t, title, slow, frames_per_period, width, subtitle=constants,
                  stride=stride)


_COLOURS = ("tab:blue", "tab:red", "tab:green", "tab:purple")


def _pendulum_label(s, A, i):
    """The title of pendulum_animation's panel i: its drive, the window, what happens."""
    l, w0, omega = s["l"], s["omega0"], s["omega"]
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


@dataclass(frozen=True)
class _Panel:
    """One chain to draw: anchor (frames, 2) and particles (frames, n, 2) in m, joined in
    order by rods; its colour, title and a text per frame; with the strobe, the whole chain
    (pivot first) at s phases of the drive period starting at each frame, drawn faint."""

    anchor: np.ndarray
    points: np.ndarray
    colour: str
    title: str
    readout: list
    blur: np.ndarray | None = None      # (frames, s, links + 1, 2): the chain over a period


class _Stage:
    """The figure of side-by-side panels, each a chain of particles hanging from a pivot
    that may move, and how frame k is drawn on it.

    ``draw(k)`` sets the artists from the arrays it was given, nothing else: the tests read
    the artists' data back (``rods``, ``bobs``) against an independent simulation.  Every
    panel has the same scale: its half-width is the largest reach max|anchor| + Σ|links|.
    """

    def __init__(self, panels, t, title, slow, frames_per_period, width, subtitle="",
                 stride=None):
        import matplotlib
        from matplotlib.figure import Figure
        from matplotlib.backends.backend_agg import FigureCanvasAgg

        self.panels, self.t, self.slow = panels, t, slow
        self.frames = len(t)
        self.frames_per_period, self.stride = frames_per_period, stride
        self.colours = [p.colour for p in panels]
        self.dpi = 100
        n = len(panels)
        self.width = int(width)
        self.height = int(round(width * (0.7 if n <= 2 else 0.2 + 1.0 / n)))
        fig = Figure(figsize=(self.width / self.dpi, self.height / self.dpi), dpi=self.dpi)
        FigureCanvasAgg(fig)
        self.fig = fig
        reach = 1.06 * max(_reach(p) for p in panels)
        scale = self.width / 720 * (1 if n <= 2 else 2 / n) ** 0.5
        big, font, small = ({"fontsize": s * scale} for s in (11, 10, 8.5))
        self.rods, self.bobs, self.trails, self.tilts, self.pivots = [], [], [], [], []
        self.blurs = []
        # margins for the titles and the clock: fixed in points, so a fraction of the height
        frac = 504 * scale / self.height
        top, bottom = 1 - 0.245 * frac, 0.13 * frac
        with matplotlib.rc_context({"font.size": 10 * scale}):
            axes = np.atleast_1d(fig.subplots(1, n, gridspec_kw=dict(
                left=0.01, right=0.99, bottom=bottom, top=top, wspace=0.03)))
            for ax, panel in zip(axes, panels):
                ax.set_xlim(-reach, reach)
                ax.set_ylim(-reach, reach)
                ax.set_aspect("equal")
                ax.set_xticks([])
                ax.set_yticks([])
                for side in ax.spines.values():
                    side.set_color("0.8")
                c = panel.colour
                # the pivot's path (its shake) as a thick grey band, and the upright direction
                band = _travel(panel.anchor if panel.blur is None
                               else panel.blur[:, :, 0].reshape(-1, 2))
                ax.plot(band[:, 0], band[:, 1], color="0.85", lw=14 * scale,
                        solid_capstyle="butt", zorder=0)
                x0, y0 = panel.anchor.mean(0)
                ax.plot([x0, x0], [y0, y0 + 0.95 * reach], ls=(0, (4, 4)), color="0.6",
                        lw=0.8, zorder=0)
                trail, = ax.plot([], [], color=c, lw=1.2, alpha=0.4, zorder=1)
                # strobe: the chain at the later phases of the frame's drive period, faint
                blur = [] if panel.blur is None else [
                    ax.plot([], [], color=c, lw=1.5 * scale, alpha=0.3, zorder=1)[0]
                    for _ in range(panel.blur.shape[1] - 1)]
                rod, = ax.plot([], [], color=c, lw=3 * scale, solid_capstyle="round",
                               solid_joinstyle="round", zorder=2)
                bob, = ax.plot([], [], "o", color=c, ms=13 * scale, zorder=3, ls="none")
                piv, = ax.plot([], [], "s", color="k", ms=6 * scale, zorder=4)
                # below the panel: a swinging chain would cross any text inside it
                tilt = ax.text(0.5, -0.008, "", transform=ax.transAxes, ha="center",
                               va="top", family="monospace", **small)
                head = ax.set_title(panel.title, color=c, pad=5, linespacing=1.35, **font)
                _fit(head, 0.98 * self.width / n)
                self.rods.append(rod)
                self.bobs.append(bob)
                self.trails.append(trail)
                self.pivots.append(piv)
                self.tilts.append(tilt)
                self.blurs.append(blur)
            _fit(fig.suptitle(title, y=0.985, **big), 0.98 * self.width)
            if subtitle:
                fig.text(0.5, 1 - 0.074 * frac, subtitle, ha="center", va="bottom",
                         color="0.3", **small)
            self.clock = fig.text(0.5, 0.052 * frac, "", ha="center", va="bottom", **font)
            bob = "bob's" if max(p.points.shape[1] for p in panels) == 1 else "outer bob's"
            faint = (f"faint: the chain and the {bob} path through the drive period after "
                     "the frame" if stride else f"faint curve: the {bob} path over the last "
                     + ("drive period" if frames_per_period else "second"))
            _fit(fig.text(0.5, 0.012 * frac, "grey band: the pivot's travel    dashed: the "
                          f"upright    {faint}", ha="center", va="bottom", color="0.4",
                          **small), 0.98 * self.width)

    def draw(self, k):
        n = self.frames_per_period or 1
        for i, p in enumerate(self.panels):
            chain = np.vstack([p.anchor[k], p.points[k]])
            self.rods[i].set_data(chain[:, 0], chain[:, 1])
            self.bobs[i].set_data(p.points[k, :, 0], p.points[k, :, 1])
            self.pivots[i].set_data([p.anchor[k, 0]], [p.anchor[k, 1]])
            if p.blur is None:
                # the last bob's path over the last drive period: the fast wobble, as a smear
                j = slice(max(0, k - n), k + 1)
                self.trails[i].set_data(p.points[j, -1, 0], p.points[j, -1, 1])
            else:
                # the drive period after the frame, which the strobe skips: drawn faint
                self.trails[i].set_data(p.blur[k, :, -1, 0], p.blur[k, :, -1, 1])
                for line, phase in zip(self.blurs[i], p.blur[k, 1:]):
                    line.set_data(phase[:, 0], phase[:, 1])
            self.tilts[i].set_text(p.readout[k])
        if self.stride:
            motion = (f"stroboscopic: one frame every {self.stride} drive period"
                      f"{'s' if self.stride > 1 else ''}, same phase ({_pace(self.slow)})")
        elif self.frames_per_period:
            motion = (f"{_pace(self.slow)} ({self.frames_per_period} frames per drive "
                      "period)")
        else:
            motion = "real time"
        self.clock.set_text(f"t = {self.t[k]:5.3f} s    {motion}")

    def close(self):
        self.fig.clear()


def _pace(slow):
    """How fast the GIF plays: "slow motion ×4", "real time" (within 5 %), "×2 fast"."""
    if slow > 1.05:
        return f"slow motion ×{slow:.3g}"
    if slow >= 1 / 1.05:
        return "real time"
    return f"×{1 / slow:.3g} fast"


def _fit(text, width_px):
    """Shrink ``text``'s font until it is at most ``width_px`` wide (long titles)."""
    renderer = text.figure.canvas.get_renderer()
    for _ in range(8):          # glyph widths are hinted: not quite proportional to size
        wide = text.get_window_extent(renderer).width
        if wide <= width_px:
            return
        text.set_fontsize(text.get_fontsize() * 0.99 * width_px / wide)


def _travel(anchor):
    """The pivot's path to draw as its band: the segment between its extremes when it moves
    on a line (vertical, horizontal, oblique drive), else the path itself (an ellipse)."""
    centred = anchor - anchor.mean(0)
    if not np.any(centred):
        return anchor[:1]
    _, sv, vt = np.linalg.svd(centred, full_matrices=False)
    if sv[1] > 1e-9 * sv[0]:
        return anchor
    along = centred @ vt[0]
    return anchor[[np.argmin(along), np.argmax(along)]]


def _reach(panel):
    """max |anchor| + the chain's length at frame 0 (m): the farthest a bob can go."""
    chain = np.vstack([panel.anchor[0], panel.points[0]])
    anchors = panel.anchor if panel.blur is None else panel.blur[:, :, 0]
    return float(np.abs(anchors).max() + np.linalg.norm(np.diff(chain, axis=0), axis=1).sum())
