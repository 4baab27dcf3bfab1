"""kapitza 0.1's spellings of the Floquet grid functions (issue 20): each still works in
0.2, warns with a DeprecationWarning that names the new call and points at the caller's
line, and gives the same numbers as the new call (docs/api-conventions.md §5).

The reference is the new spelling itself: both must produce equal arrays, bit for bit.
Small grids of the single pendulum (l = 1 m), so the whole file runs in seconds.
"""
import inspect
import math
import re
import warnings

import numpy as np
import pytest

from kapitza import floquet as fq
from lagrange_core import problems

PARAMS = dict(m=1.0, l=1.0, g=9.81)
UP = [math.pi]
A = np.linspace(0.0, 0.6, 9)
W = np.linspace(20.0, 120.0, 9)


@pytest.fixture(scope="module")
def pendulum():
    return problems.driven_pendulum("vertical")


def deprecated(new_call):
    """pytest.warns for a DeprecationWarning naming ``new_call`` (literally)."""
    return pytest.warns(DeprecationWarning, match=re.escape(new_call))


def assert_same(old, new, fields):
    for name in fields:
        np.testing.assert_array_equal(getattr(old, name), getattr(new, name), err_msg=name)


def assert_points_here(record):
    """Every deprecation warning points at this file's line (stacklevel), not kapitza's."""
    hits = [r for r in record if issubclass(r.category, DeprecationWarning)]
    assert hits and all(r.filename == __file__ for r in hits)


def test_new_spellings_do_not_warn(pendulum):
    with warnings.catch_warnings():
        warnings.simplefilter("error", DeprecationWarning)
        fq.stability_map(pendulum, PARAMS, UP, A=A[:3], omega=W[:2])
        fq.adaptive_map(pendulum, PARAMS, UP, A=A[:5], omega=W[:5], coarse_step=2)
        fq.window(pendulum, PARAMS, UP, omega=60.0, A_range=(0.0, 0.8), tol=1e-8)
        fq.boundaries(pendulum, PARAMS, UP, omega=W[2:6], A_range=(0.0, 0.6), tol=1e-8)
    for f in (fq.stability_map, fq.adaptive_map):
        sig = inspect.signature(f).parameters
        assert list(sig)[:3] == ["system", "params", "about"]
        assert sig["A"].kind is sig["omega"].kind is inspect.Parameter.KEYWORD_ONLY
    for f in (fq.window, fq.boundaries):
        sig = inspect.signature(f).parameters
        assert sig["omega"].kind is inspect.Parameter.KEYWORD_ONLY and "A_limit" not in sig


def test_stability_map_old_positional_order(pendulum):
    new = fq.stability_map(pendulum, PARAMS, UP, A=A, omega=W)
    with deprecated("kapitza.stability_map(system, params, about, A=A, omega=omega)") as rec:
        old = fq.stability_map(pendulum, A, W, PARAMS, UP)
    assert_points_here(rec)
    assert "kapitza.stability_map(system, A, omega, params, about) is deprecated" in str(
        rec[0].message)
    assert_same(old, new, ("A", "omega", "stable", "label", "trace", "log_growth"))
    # the old order with params and about as keywords, and the options after them
    with deprecated("kapitza.stability_map(system, params, about, A=A, omega=omega)"):
        kw = fq.stability_map(pendulum, A, W, params=PARAMS, about=UP, tol=1e-8)
    assert_same(kw, new, ("stable", "label", "trace"))


def test_adaptive_map_old_positional_order(pendulum):
    new = fq.adaptive_map(pendulum, PARAMS, UP, A=A, omega=W, coarse_step=4)
    with deprecated("kapitza.adaptive_map(system, params, about, A=A, omega=omega)") as rec:
        old = fq.adaptive_map(pendulum, A, W, PARAMS, UP, coarse_step=4)
    assert_points_here(rec)
    assert_same(old, new, ("stable", "label", "margin", "computed"))
    assert old.monodromies == new.monodromies


def test_window_fourth_positional_omega(pendulum):
    w = np.array([40.0, 60.0])
    new = fq.window(pendulum, PARAMS, UP, omega=w, tol=1e-9)
    with deprecated("kapitza.window(system, params, about, omega=omega)") as rec:
        old = fq.window(pendulum, PARAMS, UP, w, tol=1e-9)
    assert_points_here(rec)
    assert_same(old, new, ("omega", "A_min", "A_max", "accuracy"))


def test_window_A_limit(pendulum):
    new = fq.window(pendulum, PARAMS, UP, omega=60.0, A_range=(0, 0.8), tol=1e-9)
    with deprecated("kapitza.window(..., A_range=(0, 0.8))") as rec:
        old = fq.window(pendulum, PARAMS, UP, omega=60.0, A_limit=0.8, tol=1e-9)
    assert_points_here(rec)
    assert_same(old, new, ("A_min", "A_max", "accuracy"))
    # both old spellings in one call: two warnings, the same numbers
    with pytest.warns(DeprecationWarning) as rec:
        both = fq.window(pendulum, PARAMS, UP, 60.0, A_limit=0.8, tol=1e-9)
    assert_points_here(rec)
    said = sorted(str(r.message) for r in rec if issubclass(r.category, DeprecationWarning))
    assert len(said) == 2
    assert said[0].endswith("call kapitza.window(..., A_range=(0, 0.8)).")
    assert said[1].endswith("call kapitza.window(system, params, about, omega=omega).")
    assert_same(both, new, ("A_min", "A_max", "accuracy"))


def test_boundaries_fourth_positional_omega(pendulum):
    w = np.linspace(30.0, 60.0, 4)
    new = fq.boundaries(pendulum, PARAMS, UP, omega=w, tol=1e-8)
    with deprecated("kapitza.boundaries(system, params, about, omega=omega)") as rec:
        old = fq.boundaries(pendulum, PARAMS, UP, w, tol=1e-8)
    assert_points_here(rec)
    assert_same(old, new, ("omega", "A", "accuracy", "kind", "stable_below", "A_range"))


def test_boundaries_old_call_with_A_range_unchanged(pendulum):
    """boundaries had A_range already: only the positional omega is deprecated."""
    w = np.linspace(30.0, 60.0, 4)
    new = fq.boundaries(pendulum, PARAMS, UP, omega=w, A_range=(0.0, 0.6), tol=1e-8)
    with deprecated("kapitza.boundaries(system, params, about, omega=omega)") as rec:
        old = fq.boundaries(pendulum, PARAMS, UP, w, A_range=(0.0, 0.6), tol=1e-8)
    assert sum(issubclass(r.category, DeprecationWarning) for r in rec) == 1
    assert_same(old, new, ("omega", "A", "accuracy", "kind", "stable_below", "A_range"))
    assert new.A_range == (0.0, 0.6) and new.kind == ("T", "2T")


def test_ambiguous_and_refused_spellings(pendulum):
    with pytest.raises(TypeError, match="both A_limit= .deprecated. and A_range="):
        fq.window(pendulum, PARAMS, UP, omega=60.0, A_limit=0.8, A_range=(0, 0.8))
    with pytest.raises(TypeError, match="omega both as the fourth positional argument"):
        fq.window(pendulum, PARAMS, UP, 60.0, omega=60.0)
    with pytest.raises(TypeError, match="both by position"):
        fq.stability_map(pendulum, A, W, PARAMS, UP, params=PARAMS)
    with pytest.raises(TypeError, match=re.escape("call kapitza.adaptive_map(system, params, "
                                                  "about, A=A, omega=omega)")):
        fq.adaptive_map(pendulum, A, W)            # the old order without params and about
    # a window's scan starts at A = 0: a lower end above 0 is refused, naming the fix
    with pytest.raises(ValueError, match=re.escape("pass A_range=(0, 0.5)")):
        fq.window(pendulum, PARAMS, UP, omega=60.0, A_range=(0.1, 0.5))
    for bad in ((0.5, 0.1), (0.0, math.inf), (0.0,), "ab", 0.5, (0.0, True)):
        with pytest.raises(ValueError, match="A_range must be"):
            fq.window(pendulum, PARAMS, UP, omega=60.0, A_range=bad)
        with pytest.raises(ValueError, match="A_range must be"):
            fq.boundaries(pendulum, PARAMS, UP, omega=[30.0, 60.0], A_range=bad)
