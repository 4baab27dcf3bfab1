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
``KapitzaPendulum.window``; e.g. ω/ω0 = 10, A/l = 0.25 (window 0.142 < A/l <
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
from ._pendulum import Animation, pendulum_animation
from ._system import SystemAnimation, system_animation

__all__ = ["pendulum_animation", "system_animation", "Animation", "SystemAnimation"]
