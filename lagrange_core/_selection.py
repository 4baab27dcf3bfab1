"""The k-th smallest of a few numbers, inside numba kernels.

The step-size controllers take a quantile of recent steps (the pilot's fixed step, the
held step of a block).  ``np.sort`` and ``np.partition`` do it, but numba compiles their
generic implementations (quicksort, introselect, and ``np.unique`` to check ``kth``) in
every process that compiles a kernel calling them: 3–4 s of a first ``measure``'s
compilation (measured 2026-11-26).  This selection is one small loop.
"""
from __future__ import annotations

from numba import njit

__all__ = ["kth_smallest"]


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
