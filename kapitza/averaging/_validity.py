"""Where averaging holds: the thresholds every averaging prediction is flagged against,
and the warning a scalar prediction outside them emits (shared by the general method,
its window and the pendulum's closed forms).
"""
from __future__ import annotations

__all__ = ["MIN_FREQUENCY_RATIO", "MAX_AMPLITUDE_RATIO", "AveragingValidityWarning",
           "reasons"]

#: A prediction is flagged invalid when ω < MIN_FREQUENCY_RATIO × (largest slow
#: frequency or growth rate, and ω0 for the pendulum).  At ratio 5 the
#: first-order slow frequency of the pendulum is off by ≲ 3 % (next-order term).
MIN_FREQUENCY_RATIO = 5.0
#: ... or when the fast displacement per unit slow displacement (A/l for the
#: pendulum) exceeds MAX_AMPLITUDE_RATIO.  At A/l = 0.3 the first-order slow
#: frequency of the pendulum is off by up to ≈ 7 % (next-order term 25 q⁴/128).
MAX_AMPLITUDE_RATIO = 0.3


class AveragingValidityWarning(UserWarning):
    """A scalar averaging prediction lies outside the regime where averaging holds."""


def reasons(freq_ratio: float, amp: float) -> tuple:
    """Why a prediction with this frequency ratio and fast-amplitude ratio is not valid
    (empty when it is)."""
    out = []
    if not freq_ratio >= MIN_FREQUENCY_RATIO:
        out.append(f"the drive is only {freq_ratio:.3g} times faster than the slow motion "
                   f"(averaging needs ≥ {MIN_FREQUENCY_RATIO:g})")
    if not amp <= MAX_AMPLITUDE_RATIO:
        out.append(f"the fast motion is large: amplitude ratio {amp:.3g} > {MAX_AMPLITUDE_RATIO:g}")
    return tuple(out)
