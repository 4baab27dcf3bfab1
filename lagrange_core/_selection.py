"""The k-th smallest of a few numbers, inside numba kernels; the fixed step of a pilot run.

The step-size controllers take a quantile of recent steps (the pilot's fixed step, the
held step of a block).  ``np.sort`` and ``np.partition`` do it, but numba compiles their
generic implementations (quicksort, introselect, and ``np.unique`` to check ``kth``) in
every process that compiles a kernel calling them: 3–4 s of a first ``measure``'s
compilation (measured 2026-11-26).  This selection is one small loop.
"""
from __future__ import annotations

from numba import njit

__all__ = ["kth_smallest", "pilot_step_quantile", "PILOT_MIN_SETTLED", "PILOT_WIDEN",
           "PILOT_SPAN_DIVISOR"]

#: a pilot's step after which the classic controller grew the step at least this much
#: (:func:`lagrange_core._integrator_kernels.rkn_next_step`: min(5, 0.9 err^(-1/11)), so
#: the step's error was below 1.5e-4 of the tolerance) was far shorter than the
#: tolerance allows: the starting ramp
RAMP_GROWTH = 2.0
#: a pilot of "rkn12-fixed" first runs over the span's first 1/PILOT_SPAN_DIVISOR, then
#: again over a window PILOT_WIDEN times longer (at most the whole span) until it has
#: taken PILOT_MIN_SETTLED steps beyond its starting ramp (``integrate``, and the grids'
#: pilots in ``_batch_kernels``: one rule, the same steps)
PILOT_SPAN_DIVISOR = 50.0
PILOT_MIN_SETTLED = 8
PILOT_WIDEN = 8.0


@njit(cache=True, nogil=True)
def kth_smallest(x, k):
    """The ``k``-th smallest (0-based) of the values ``x`` (1-D, finite, not changed):
    ``np.sort(x)[k]``, which equals ``np.partition(x, k)[k]``.

    Hoare's selection (Wirth's variant) on a copy: O(len(x)) on average.
    """
    a = x.copy()
    lo = 0
    hi = a.shape[0] - 1
    while lo < hi:
        mid = (lo + hi) // 2
        # the median of three as the pivot: sorted input (steps that grow) stays O(n)
        if a[mid] < a[lo]:
            a[mid], a[lo] = a[lo], a[mid]
        if a[hi] < a[lo]:
            a[hi], a[lo] = a[lo], a[hi]
        if a[hi] < a[mid]:
            a[hi], a[mid] = a[mid], a[hi]
        pivot = a[mid]
        i = lo
        j = hi
        while i <= j:
            while a[i] < pivot:
                i += 1
            while pivot < a[j]:
                j -= 1
            if i <= j:
                a[i], a[j] = a[j], a[i]
                i += 1
                j -= 1
        # now a[lo..j] <= pivot <= a[i..hi], and j < i
        if k <= j:
            hi = j
        elif k >= i:
            lo = i
        else:
            return a[k]         # between the two parts: equal to the pivot
    return a[k]


@njit(cache=True, nogil=True)
def pilot_step_quantile(steps, m):
    """The 20th percentile of a pilot's ``m`` accepted steps ``steps[:m]`` (in the order
    taken, clipped ones left out) beyond its *starting ramp*, and how many steps that is.

    The ramp is the leading steps after each of which the controller grew the step at
    least :data:`RAMP_GROWTH`-fold: their length was set by the starting guess, not by
    the tolerance (a string of beads whose natural step is a third of its period starts
    at 1/3800 of it, growing about 5-fold a step, and a pilot of a few steps was all
    ramp: "rkn12-fixed" took 3800 steps a period where "rkn12" took 4).  Where every
    step is ramp, the percentile is taken over all of them (and the count is 0).
    ``m`` = 0 gives (0, 0).
    """
    k = 0
    while k + 1 < m and steps[k + 1] >= RAMP_GROWTH * (1.0 - 1e-9) * steps[k]:
        k += 1
    if m == 0:
        return 0.0, 0
    if k + 1 == m:          # all ramp (its last step had no successor to show it)
        return kth_smallest(steps[:m], int(0.2 * (m - 1))), 0
    settled = m - k
    return kth_smallest(steps[k:m], int(0.2 * (settled - 1))), settled


# a first call on the main thread compiles where Ctrl-C need not wait for it
from ._first_calls import guard as _guard_first_calls  # noqa: E402

_guard_first_calls(__name__)
