"""The report's ``animation`` section: a GIF of the stabilised pendulum beside one that
falls, or of the scene's own chain under its drive."""
from __future__ import annotations

import math
from pathlib import Path

from ._job import Job, SectionResult, Skip, state_name, upright


def animation_section(job: Job) -> SectionResult:
    from ..animation import pendulum_animation, system_animation
    # quick: a short small clip (the tests), most of whose cost is writing the GIF
    sizes = ({"duration": 1.0, "frames_per_period": 4, "width": 360, "max_frames": 40}
             if job.quick else {})
    if not job.vertical:
        raise Skip("the animation shows the state the report is about under a vertical "
                   "drive; this scene's drive leaves no equilibrium.")
    if job.pend is None or job.pend_about != "inverted":
        return _chain_animation(job, system_animation, sizes)
    pend = job.pend
    rel = Path("figures") / "pendulum.gif"
    win = pend.window(job.omega)
    A = job.A if float(win.A_min) < job.A < float(win.A_max) else \
        math.sqrt(float(win.A_min) * float(win.A_max))
    theta0 = float(job.scene.q0[0])
    if not 0 < abs(theta0 - math.pi) < math.pi / 2:        # not released near the upright
        theta0 = math.pi - 0.1
    result = pendulum_animation(job.out / rel, l=pend.l, g=pend.g, A=A, omega=job.omega,
                                theta0=theta0, damping=pend.damping, **sizes)
    caption = (f"Left: driven with A = {A:g} m at ω = {job.omega:g} rad/s (inside the exact "
               f"window {float(win.A_min):.3g} m < A < {float(win.A_max):.3g} m), it stays up; "
               f"right: the same release without a sufficient drive falls.")
    job.table("animation", result.to_dataframe(), "animation")
    return SectionResult(rel, caption, ["animation"])


def _chain_animation(job: Job, system_animation, sizes) -> SectionResult:
    """Any scene but the upright single pendulum (Acheson's chain, the hanging pendulum
    under a resonant drive, a user's rig): the scene itself, released from its [initial]
    state under its drive, in one panel, classified against the state the report is about
    where that state persists and every coordinate is an angle (the band is π/2)."""
    rel = Path("figures") / "animation.gif"
    about = job.about if job.persists and job.angles.all() else None
    try:
        result = system_animation(job.out / rel, [job.scene], about=about, **sizes)
    except ValueError as e:       # not a planar chain of particles: nothing to draw
        raise Skip(f"the animation draws planar chains of particles: {e}") from None
    name = f"{state_name(job)} {upright(job)}"
    if about is None:
        fate = (f"the drive moves {name}, so the clip is not classified against it"
                if not job.persists else "the clip is not classified (a coordinate is not an "
                "angle, so no band of π/2 applies)")
        verdict = ""
    else:
        stayed, stable = result.stayed_up[0], result.floquet_stable[0]
        fate = (f"it stays within π/2 of {name} for the whole clip" if stayed else
                f"it leaves {name} at t = {result.fall_time[0]:.3g} s")
        verdict = (f"; Floquet analysis calls {state_name(job)} "
                   f"{'stable' if stable else 'unstable'} at this drive")
    caption = (f"The scene's system released from its initial state with the drive "
               f"A = {job.A:g} m, ω = {job.omega:g} rad/s: {fate}{verdict}.")
    job.table("animation", result.to_dataframe(), "animation")
    return SectionResult(rel, caption, ["animation"])
