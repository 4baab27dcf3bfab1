"""pendulum_animation: the stabilised inverted pendulum beside one that falls, drawn from
two simulations of the single pendulum (:class:`Animation`)."""
from __future__ import annotations

import math
import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .. import _arguments as arguments
from ._drawing import COLOURS, Panel, Stage, render
from ._frames import (
    UPRIGHT_BAND,
    check_number,
    check_playback,
    crossing_time,
    frame_times,
    sample_times,
    tilt_from_upright,
)


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
        The exact window A_min < A < A_max at ω (m; Floquet, :meth:`KapitzaPendulum.window`).
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


def bob_position(theta, pivot_y, l):
    """The bob of a pendulum of length l (m) at angle θ (rad, from the downward vertical)
    hanging from the pivot (0, pivot_y): (l sin θ, pivot_y − l cos θ) (m)."""
    theta = np.asarray(theta, float)
    return l * np.sin(theta), np.asarray(pivot_y, float) - l * np.cos(theta)


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
    carries the simulated time and the slow-motion factor.  :mod:`kapitza.animation`: how
    the frame times avoid aliasing the drive.

    Parameters
    ----------
    path : str or Path
        The GIF to write (``.gif``; parent directories are created).
    A : float
        Drive amplitude of the stabilised pendulum (m): inside the exact window
        A_min < A < A_max at ``omega`` (:meth:`KapitzaPendulum.window`), or
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
        slow motion (:mod:`kapitza.animation`); "auto" (default): slow motion when its frames fit
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
    omega = check_number(where, "omega", omega, "rad/s", minimum=0.0, example="omega=31.3")
    A = check_number(where, "A", A, "m", minimum=0.0, strict=False)
    A_fall = check_number(where, "A_fall", A_fall, "m", minimum=0.0, strict=False,
                    example="A_fall=0 (undriven)")
    theta0 = check_number(where, "theta0", theta0, "rad", example="theta0=math.pi - 0.1")
    duration, fps, rtol = check_playback(where, duration, fps, rtol, frames_per_period, width,
                                    max_frames)
    tilt0 = float(tilt_from_upright(theta0))
    if not 0 < tilt0 < UPRIGHT_BAND:
        raise ValueError(f"{where}theta0 must be released near the upright, 0 < |θ0 − π| < "
                         f"π/2 (θ from the downward vertical), got theta0 = {theta0!r} rad "
                         f"(|θ0 − π| = {tilt0:.3g}); e.g. theta0=math.pi - 0.1.")

    pend = KapitzaPendulum(l=l, g=g, damping=damping)
    win = pend.window(omega)
    A_min, A_max = float(np.squeeze(win.A_min)), float(np.squeeze(win.A_max))
    if not A_min < A < A_max:
        fix = ("no amplitude holds the pendulum up at this ω; raise omega (ω/ω0 ≳ 3)"
               if not A_min < A_max else
               f"choose A between them, e.g. A = {0.5 * (A_min + min(A_max, 2 * A_min)):.4g} m")
        raise ValueError(f"{where}A = {A:.6g} m is outside the window that holds the "
                         f"pendulum upright at omega = {omega:.6g} rad/s "
                         f"(ω/ω0 = {omega / pend.omega0:.4g}): A_min = {A_min:.6g} m, "
                         f"A_max = {A_max:.6g} m (exact, Floquet); {fix}.")
    # Floquet's verdicts from Mathieu's trace (= pend.floquet's, tests/test_verify.py),
    # without compiling the general Floquet kernels for a first animation
    from ..closed_forms import pendulum_floquet
    stable = tuple(bool(s) for s in pendulum_floquet(np.array([A, A_fall]), omega, l=l, g=g,
                                                     damping=damping).stable)
    if stable[1]:
        raise ValueError(f"{where}A_fall = {A_fall:.6g} m lies inside the window A_min = "
                         f"{A_min:.6g} m < A < A_max = {A_max:.6g} m, so the right-hand "
                         "pendulum would stay up too; use A_fall = 0 (undriven) or "
                         f"A_fall < {A_min:.4g} m.")

    t, fps_shown, slow, stride = frame_times(
        where, omega, duration, fps, frames_per_period, max_frames,
        fix="lower omega (ω/ω0 ≈ 10–30 is enough to stabilise)", mode=mode)
    frames = len(t)
    samples = sample_times(t, omega, stride, frames_per_period)
    amps = np.array([A, A_fall])
    theta_all = np.empty((2,) + samples.shape)
    theta_dot_all = np.empty((2,) + samples.shape)
    for i, amp in enumerate(amps):
        traj = pend.simulate(float(amp), omega, theta0, 0.0, (0.0, float(samples[-1, -1])),
                             rtol=rtol, t_eval=samples.ravel())
        if traj.status != "success" or traj.t.shape != (samples.size,):
            raise RuntimeError(f"{where}the simulation with A = {amp:.6g} m stopped: "
                               f"{traj.status} ({traj.message}).")
        theta_all[i] = traj.q[:, 0].reshape(samples.shape)
        theta_dot_all[i] = traj.qdot[:, 0].reshape(samples.shape)
    theta, theta_dot = theta_all[:, :, 0], theta_dot_all[:, :, 0]
    pivot_all = amps[:, None, None] * np.cos(omega * samples)[None]
    pivot = pivot_all[:, :, 0]
    tilt = tilt_from_upright(theta_all).reshape(2, -1)
    out = tilt >= UPRIGHT_BAND
    stayed = (bool(not out[0].any()), bool(not out[1].any()))
    fall = tuple(crossing_time(samples.ravel(), d) for d in tilt)
    if not stayed[0]:
        warnings.warn(f"{where}the driven pendulum (A = {A:.4g} m, inside the window) fell at "
                      f"t = {fall[0]:.3g} s: a release {tilt0:.3g} rad from the upright is "
                      "outside its basin; use a smaller tilt (theta0 closer to π).",
                      stacklevel=2)
    if stayed[1]:
        warnings.warn(f"{where}the falling pendulum has not fallen within duration = "
                      f"{duration:g} s (max tilt {tilt[1].max():.3g} rad); use a longer "
                      "duration.", stacklevel=2)

    stage = pendulum_stage(t, theta_all, pivot_all, amps, l=l, g=g, damping=damping,
                            omega=omega, window=(A_min, A_max), stayed=stayed, fall=fall,
                            floquet=stable, tilt0=tilt0, slow=slow,
                            frames_per_period=frames_per_period, stride=stride, width=width)
    render(where, stage, path, fps_shown, progress, "pendulum_animation")
    return Animation(path=path, frames=frames, width=stage.width, height=stage.height,
                     bytes=path.stat().st_size, t=t, theta=theta, theta_dot=theta_dot,
                     pivot=pivot, A=amps, omega=omega, l=l, g=g, damping=damping,
                     theta0=theta0, window=(A_min, A_max), floquet_stable=stable,
                     stayed_up=stayed, fall_time=fall, max_tilt=tuple(map(float, tilt.max(1))),
                     fps=fps_shown, frames_per_period=frames_per_period, slow_motion=slow,
                     seconds=time.perf_counter() - started, periods_per_frame=stride)


def pendulum_stage(t, theta, pivot, amps, *, l, g, damping, omega, window, stayed, fall,
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
        panels.append(Panel(anchor=chains[:, 0, 0], points=chains[:, 0, 1:],
                             colour=COLOURS[i],
                             title=_pendulum_label(info, float(amps[i]), i),
                             readout=[f"θ − π = {d:+.3f} rad" for d in dev],
                             blur=chains if stride else None))
    title = f"Kapitza pendulum: both released at rest {tilt0:.3g} rad from the upright"
    constants = (f"l = {l:g} m, g = {g:g} m/s²" + (f", damping γ = {damping:g} 1/s" if damping
                                                   else ", no damping"))
    return Stage(panels, t, title, slow, frames_per_period, width, subtitle=constants,
                  stride=stride)


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
