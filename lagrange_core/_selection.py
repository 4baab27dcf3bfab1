"""The k-th smallest of a few numbers, inside numba kernels; the fixed step of a pilot run.

The step-size controllers take a quantile of recent steps (the pilot's fixed step, the
held step of a block).  ``np.sort`` and ``np.partition`` do it, but numba compiles their
generic implementations (quicksort, introselect, and ``np.unique`` to check ``kth``) in
every process that compiles a kernel calling them: 3–4 s of a first ``measure``'s
compilation (measured 2026-11-26).  This selection is one small loop.
"""
from __future__ import annotations

from numba import njit

__all__ = ["kth_smallest", "kth_smallest_in_place", "pilot_step_quantile", "PILOT_MIN_SETTLED",
           "PILOT_WIDEN", "PILOT_SPAN_DIVISOR"]

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


@njit(cache=True, nogil=True, inline="always")
def _pivot_last(a, lo, hi):
    """The median of a[lo], a[mid], a[hi] moved to a[hi] (the values swap places)."""
    mid = (lo + hi) >> 1
    x, y, z = a[lo], a[mid], a[hi]
    if (x <= y) == (y <= z):
        a[mid], a[hi] = z, y
    elif (y <= x) == (x <= z):
        a[lo], a[hi] = z, x


@njit(cache=True, nogil=True)
def kth_smallest_in_place(a, k):
    """The ``k``-th smallest (0-based) of the values ``a`` (1-D, finite), as
    :func:`kth_smallest`, reordering ``a``: for a caller that has no further use of the
    order (the held step's block of error ratios, refilled from its start after).

    Quickselect with Lomuto's partition written without branches (each element moves
    by selects, not by a jump the processor must guess) around the median of three:
    on 64 distinct values 0.30 µs against 0.83 µs for :func:`kth_smallest` with its
    copy, 3.2× faster also on 4096; the held step's selection was 9 % of RKN 12's lanes
    (perf, 2026-11-28).  A pass that finds nothing below its pivot gathers the values
    equal to it, so ties cost O(len(a)) passes of at most 2 len(a), not O(len(a)²):
    on mostly equal values it is up to 3× slower than :func:`kth_smallest`, which the
    pilot's quantile (steps held equal for blocks) therefore keeps."""
    lo = 0
    hi = a.shape[0] - 1
    while lo < hi:
        _pivot_last(a, lo, hi)
        pivot = a[hi]
        s = lo                  # a[lo:s] < pivot
        for i in range(lo, hi):
            v = a[i]
            w = a[s]
            below = v < pivot
            a[i] = w if below else v
            a[s] = v if below else w
            s += 1 if below else 0
        tied = s == lo
        if tied:                # none below: a[lo:s] == pivot
            for i in range(lo, hi):
                v = a[i]
                w = a[s]
                equal = v <= pivot
                a[i] = w if equal else v
                a[s] = v if equal else w
                s += 1 if equal else 0
        a[hi] = a[s]
        a[s] = pivot
        if k == s or (tied and k < s):
            return pivot
        if k < s:
            hi = s - 1
        else:
            lo = s + 1
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
