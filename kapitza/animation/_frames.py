"""When the frames are taken and how they play (the face's docstring: slow motion and the
strobe), the checks of the options every animation shares, and when a simulated chain
left the upright band."""
from __future__ import annotations

import math

import numpy as np

from .. import _arguments as arguments

#: The band that decides "stays up": |θ − π| < π/2 (as :meth:`KapitzaPendulum.measure`).
UPRIGHT_BAND = math.pi / 2


def tilt_from_upright(theta):
    """|θ − π| wrapped into [0, π] (rad): the distance from the upright."""
    return np.abs((np.asarray(theta) - math.pi + math.pi) % (2 * math.pi) - math.pi)


def check_number(where, name, value, unit, *, minimum=None, strict=True, example=""):
    try:
        return arguments.real_number(value, name, unit=unit, minimum=minimum, strict=strict)
    except ValueError:
        need = "" if minimum is None else f" {'>' if strict else '≥'} {minimum:g}"
        raise ValueError(f"{where}{name} must be a finite number{need} ({unit}), got "
                         f"{value!r}{'; e.g. ' + example if example else ''}.") from None


def check_playback(where, duration, fps, rtol, frames_per_period, width, max_frames):
    """The options every animation shares, checked: (duration, fps, rtol) as floats."""
    duration = check_number(where, "duration", duration, "s", minimum=0.0,
                      example="duration=4 (simulated seconds)")
    fps = check_number(where, "fps", fps, "frames/s", minimum=0.0, example="fps=20")
    rtol = check_number(where, "rtol", rtol, "", minimum=0.0, example="rtol=1e-10")
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


def frame_times(where, omega, duration, fps, frames_per_period, max_frames, fix, mode):
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


def sample_times(t, omega, stride, frames_per_period):
    """The simulation's output times, (frames, s): each frame's time, and with the strobe
    also the n − 1 later phases of its drive period (the rod drawn faint through them)."""
    sub = frames_per_period if stride else 1
    return t[:, None] + np.arange(sub)[None, :] * (2 * math.pi / omega / sub if stride else 0)


def crossing_time(t, dev):
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
