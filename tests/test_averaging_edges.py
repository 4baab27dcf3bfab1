"""Edges of the averaging machinery (issue 10): the averaging window beyond its search range,
memory of large sweeps, the mean drag torque of a two-phase damped drive.

References: scipy.special.mathieu_b (the exact parametric-resonance edge), direct
simulation with lagrange_core, and the closed forms stated in shared/PHYSICS.md.
"""
import math
import warnings

import numpy as np
import pytest
from helpers import G
from scipy.optimize import brentq
from scipy.special import mathieu_b

from kapitza import averaging as av
from kapitza import pendulum_closed_forms as pcf


# -- item 4: the averaging window ------------------------------------------------------------

def test_window_upper_edge_is_the_resonance_at_any_frequency():
    """The order-2 upper edge solves a = b₁(2A/l) wherever the root lies; it used to stop at
    the search limit q = 2.5 (A_max = 0.375 m for l = 0.3 m at every low ω, below A_min)."""
    l = 0.3
    w0 = math.sqrt(G / l)
    omegas = np.array([5.0, 0.8 * w0, 1.2 * w0, 1.6 * w0, 8 * w0])
    win = pcf.stability_window(omegas, l=l, g=G)
    for i, om in enumerate(omegas):
        a = -4 * G / (l * om**2)
        q_hi = brentq(lambda q: mathieu_b(1, q) - a, 0.1, 60.0, xtol=1e-14)
        assert win.A_max[i] == pytest.approx(q_hi * l / 2, rel=1e-6)
    assert len(set(np.round(win.A_max, 9))) == len(omegas)
    # never crossed edges without saying so: a window, or NaN edges with exists False
    assert np.all(win.exists == (win.A_min < win.A_max))
    assert np.all(np.isnan(win.A_min[~win.exists]) & np.isnan(win.A_max[~win.exists]))


def test_window_carries_validity_flags():
    l = 0.3
    w0 = math.sqrt(G / l)
    omegas = np.array([0.8, 3.0, 10.0, 100.0]) * w0
    win = pcf.stability_window(omegas, l=l, g=G)
    np.testing.assert_allclose(win.frequency_ratio, omegas / w0)
    np.testing.assert_array_equal(win.fast_drive, [False, False, True, True])
    np.testing.assert_array_equal(win.small_amplitude, win.A_min / l <= av.MAX_AMPLITUDE_RATIO)
    np.testing.assert_array_equal(win.valid, [False, False, True, True])
    # the error estimate is the order-1 edge's distance from the order-2 edge
    first = pcf.stability_window(omegas, l=l, g=G, order=1)
    np.testing.assert_allclose(win.error_estimate, np.abs(first.A_min / win.A_min - 1), rtol=1e-12)
    assert np.all(np.isinf(first.A_max)) and np.all(first.exists)
    np.testing.assert_array_equal(first.valid, [False, False, True, True])
    # the damping rate counts among the slow rates
    damped = pcf.stability_window(100 * w0, l=l, g=G, damping=30 * w0, warn=False)
    assert damped.fast_drive is False and damped.valid is False
    # scalar: a warning names the reason; arrays only set the flags
    with pytest.warns(av.AveragingValidityWarning, match="× max"):
        pcf.stability_window(0.8 * w0, l=l, g=G)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        pcf.stability_window(100 * w0, l=l, g=G)
        pcf.stability_window(omegas, l=l, g=G)


# -- item 9: memory of large array calls ------------------------------------------------------

_MEMORY_PROBE = """
import resource, sys
import numpy as np
from kapitza import pendulum_closed_forms as pcf
A = np.linspace(0.001, 0.2, {n})
before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
out = pcf.pendulum_averaged(A, 200.0, order=2, warn=False)
peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
kept = sum(v.nbytes for e in out.equilibria for v in vars(e).values() if isinstance(v, np.ndarray))
print((peak - before) * 1024, kept)
"""


def test_large_array_call_works_in_bounded_memory():
    """10⁶ points: beyond the result itself (≈ 240 bytes a point), the call's temporaries
    stay below 80 MB (they were ≈ 150 MB at 10⁶ points, 1.4 GB at 10⁷: every field of every
    equilibrium was computed on the whole array at once)."""
    import subprocess
    import sys
    probe = subprocess.run([sys.executable, "-c", _MEMORY_PROBE.format(n=1_000_000)],
                           capture_output=True, text=True, check=True)
    grown, kept = map(int, probe.stdout.split())
    assert kept > 200e6                         # the result is all there
    assert grown - kept < 80e6


@pytest.mark.parametrize("drive, order", [("vertical", 2), ("vertical", 1), ("horizontal", 1)])
def test_chunked_results_equal_unchunked(monkeypatch, drive, order):
    A = np.linspace(0.0, 0.4, 37)[:, None]
    w = np.geomspace(1.0, 400.0, 101)[None, :]
    whole = pcf.pendulum_averaged(A, w, damping=0.7, drive=drive, order=order, warn=False)
    monkeypatch.setattr(pcf, "CHUNK_POINTS", 1000)     # 37 × 101 points: 4 chunks
    chunked = pcf.pendulum_averaged(A, w, damping=0.7, drive=drive, order=order, warn=False)
    assert [e.name for e in chunked.equilibria] == [e.name for e in whole.equilibria]
    for a, b in zip(whole.equilibria, chunked.equilibria):
        for field, value in vars(a).items():
            assert np.shape(getattr(b, field)) == np.shape(value)
            np.testing.assert_array_equal(getattr(b, field), value, err_msg=f"{a.name}.{field}")
