"""Never silent at the frontier (issue 21, point 1): kapitza.window finds every window at
least ``min_width`` wide, says "none" only where it proved there is none, and says
"undecided" (a warning and a flag) where it cannot decide — never a NaN that reads as
"none" where a window was missed.

Before the fix, ``kapitza.window`` on Acheson's equal double pendulum returned NaN at
ω/ω0 = 12.95 … 13.6 (windows 4e-5 … 6e-3 m wide, narrower than the scan's 1e-2 m
spacing), so its onset read as ≈ 14 ω0 instead of 12.9456; the single pendulum's 8 mm
window at ω = ω0 was missed the same way, without a warning.

Independent references: Acheson's mode decomposition — linearised about the upright,
the N-link equal chain splits exactly into N Mathieu equations, mode k a single pendulum
of effective length λ_k (kapitza.multiple_pendulum_upright), whose exact window comes from
the Mathieu characteristic values (kapitza.closed_forms.pendulum_window, no monodromy);
the chain's window is their intersection.  The single pendulum's window is the Mathieu
one directly.  Synthetic monodromies (2 × 2 symplectic blocks of given trace) pin the
frontier search itself, without numba.
"""
import math
import warnings

import numpy as np
import pytest
import sympy as sp

from kapitza import floquet as fq
from kapitza.closed_forms import multiple_pendulum_upright, pendulum_window
from lagrange_core import problems, t

from helpers import W0, G

#: the equal chains' onsets ω_c/ω0 (the modal windows' edges cross; brentq on the gap)
ONSET = {2: 12.945577243821946, 3: 29.606631788937523}


def chain(n):
    A, w = sp.symbols("A omega", positive=True)
    return problems.n_link_pendulum(n, pivot=(0, A * sp.cos(w * t)))


def equal(n):
    return dict({"g": G}, **{f"l{i}": 1.0 for i in range(1, n + 1)},
                **{f"m{i}": 1.0 for i in range(1, n + 1)})


@pytest.fixture(scope="module")
def double():
    return chain(2)


@pytest.fixture(scope="module")
def triple():
    return chain(3)


def modal(omega, n):
    """The equal n-link chain's window by the mode decomposition: (A_min, A_max, each
    mode's edges (modes, 2, len(ω)), the references' accuracy), NaN where none."""
    lam = multiple_pendulum_upright([1.0] * n, [1.0] * n, g=G).effective_lengths
    modes = [pendulum_window(omega, l=float(lk), g=G, tol=1e-14) for lk in lam]
    lo = np.max([m.A_min for m in modes], axis=0)
    hi = np.min([m.A_max for m in modes], axis=0)
    acc = np.max([m.accuracy for m in modes], axis=0)
    edges = np.array([[m.A_min, m.A_max] for m in modes])
    return np.where(lo < hi, lo, np.nan), np.where(lo < hi, hi, np.nan), edges, acc


def quiet(function, *args, **kwargs):
    """Call with every warning an error: a decided answer needs none."""
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        return function(*args, **kwargs)


def assert_modal_window(win, ratios, n):
    lo, hi, _, ref_acc = modal(np.asarray(ratios) * W0, n)
    assert np.all(np.isfinite(lo))
    assert list(win.status) == ["window"] * len(ratios)
    assert np.all(win.accuracy <= 1e-10)
    for edge, ref in ((win.A_min, lo), (win.A_max, hi)):
        # each edge equals the mode decomposition's within the certified accuracies
        assert np.all(np.abs(edge / ref - 1) <= win.accuracy + ref_acc)


# -- Acheson's chains at their onset -------------------------------------------------------

def test_double_pendulum_windows_at_its_onset_are_found(double):
    """The issue's frequencies: windows 4.2e-5, 5.2e-4, 1.5e-3, 3.3e-3, 6.0e-3 m wide, all
    found (no warning), edges equal to the mode decomposition's; and 3e-6 m wide at
    ω = 12.9459 ω0, just above the onset 12.94558."""
    ratios = [12.95, 13.0, 13.1, 13.3, 13.6]
    win = quiet(fq.window, double, equal(2), [math.pi] * 2, omega=np.array(ratios) * W0)
    assert_modal_window(win, ratios, 2)
    # the example: 0.136053–0.142019 m at 13.6 ω0, 4.2e-5 m wide at 12.95 ω0
    assert (round(win.A_min[-1], 6), round(win.A_max[-1], 6)) == (0.136053, 0.142019)
    assert win.A_max[0] - win.A_min[0] == pytest.approx(4.219e-5, rel=1e-3)
    assert np.all(win.min_width == pytest.approx(1e-8))          # 1e-8 × the 1 m scan
    df = win.to_dataframe()
    assert set(df.status) == {"window"}
    narrow = quiet(fq.window, double, equal(2), [math.pi] * 2, omega=12.9459 * W0)
    assert narrow.status == "window" and 0 < narrow.A_max - narrow.A_min < 4e-6
    assert_modal_window(fq.window(double, equal(2), [math.pi] * 2,
                                  omega=np.array([12.9459]) * W0), [12.9459], 2)


def test_double_pendulum_below_its_onset_is_none_or_says_undecided(double):
    """Below the onset the mode windows do not overlap: "none" (proved at the default
    min_width), A_min = A_max = NaN, no warning.  Asked only to 1e-4 m, 5e-5 m below the
    crossing of the two modes' edges the search cannot tell: "undecided", a warning
    naming ω and the amplitudes, and A_min, A_max an envelope where the window would be
    born — not NaN."""
    ratios = np.array([12.9, 12.94, 12.945])
    win = quiet(fq.window, double, equal(2), [math.pi] * 2, omega=ratios * W0)
    assert list(win.status) == ["none"] * 3
    assert np.all(np.isnan(win.A_min)) and np.all(np.isnan(win.A_max))
    assert np.all(np.isnan(modal(ratios * W0, 2)[0]))
    with pytest.warns(RuntimeWarning, match=r"could not decide.*ω = 40\.5293 rad/s: A in"):
        coarse = fq.window(double, equal(2), [math.pi] * 2, omega=12.94 * W0, min_width=1e-4)
    assert coarse.status == "undecided" and coarse.min_width == 1e-4
    assert np.isfinite(coarse.A_min) and np.isfinite(coarse.A_max) and np.isnan(coarse.accuracy)
    _, _, edges, _ = modal(12.94 * W0, 2)
    # between mode 2's upper edge and mode 1's lower edge is where the window is born
    born = (edges[1, 1], edges[0, 0])
    assert born[0] < born[1]
    assert coarse.A_min <= born[1] and coarse.A_max >= born[0]
    assert coarse.A_max - coarse.A_min < 1e-3


def test_triple_pendulum_windows_just_above_its_onset(triple):
    """N = 3 from ω/ω0 = 29.61 (onset 29.6066; window 8e-6 m wide) up: found, modal
    edges; at 29.6 (the modes' edges cross by 1.6e-5 m) "none"."""
    ratios = [29.61, 29.65, 29.8, 30.2]
    win = quiet(fq.window, triple, equal(3), [math.pi] * 3, omega=np.array(ratios) * W0)
    assert_modal_window(win, ratios, 3)
    assert win.A_max[0] - win.A_min[0] == pytest.approx(8.0e-6, rel=1e-2)
    below = quiet(fq.window, triple, equal(3), [math.pi] * 3, omega=29.6 * W0)
    assert below.status == "none" and math.isnan(below.A_min)


# -- the single pendulum at and below ω0 ---------------------------------------------------

def test_single_pendulum_at_and_below_omega0():
    """At ω = ω0 the window is 1.9053–1.9136 m (8 mm; the scan's spacing is 2 cm): found.
    Below ω0 it lies above the default scan's 2 l: "none" (proved for the amplitudes
    scanned); with A_range = (0, 3 m) the windows at 0.8–0.95 ω0 (2.6–8 mm wide) are
    found and those above 3 m (0.6, 0.7 ω0) are "none"."""
    system, params = problems.driven_pendulum("vertical"), dict(m=1.0, l=1.0, g=G)
    at = quiet(fq.window, system, params, [math.pi], omega=W0)
    ref = pendulum_window(W0, l=1.0, g=G, tol=1e-14)
    assert at.status == "window"
    assert (round(at.A_min, 4), round(at.A_max, 4)) == (1.9053, 1.9136)
    assert abs(at.A_min / ref.A_min - 1) <= at.accuracy and at.accuracy <= 1e-10
    assert abs(at.A_max / ref.A_max - 1) <= at.accuracy
    below = np.array([0.8, 0.9, 0.95]) * W0
    ref = pendulum_window(below, l=1.0, g=G, tol=1e-14)
    assert np.all(ref.A_min > 2.0)
    default = quiet(fq.window, system, params, [math.pi], omega=below)
    assert list(default.status) == ["none"] * 3 and np.all(np.isnan(default.A_min))
    wide = quiet(fq.window, system, params, [math.pi], omega=below, A_range=(0.0, 3.0))
    assert list(wide.status) == ["window"] * 3
    np.testing.assert_allclose([wide.A_min, wide.A_max], [ref.A_min, ref.A_max], rtol=1e-10)
    far = np.array([0.6, 0.7]) * W0
    assert np.all(pendulum_window(far, l=1.0, g=G).A_min > 3.0)
    none = quiet(fq.window, system, params, [math.pi], omega=far, A_range=(0.0, 3.0))
    assert list(none.status) == ["none"] * 2


# -- boundaries seed the same slivers ------------------------------------------------------

def test_boundaries_find_the_slivers_at_their_seeds(double):
    """boundaries' seed scans search between their points too: at the onset every curve
    point is found (before: only at 13.6 ω0), and an undecided seed says so."""
    ratios = np.array([12.95, 13.0, 13.1, 13.3, 13.6])
    lo, hi, _, _ = modal(ratios * W0, 2)
    for every in (1, 4):
        curves = quiet(fq.boundaries, double, equal(2), [math.pi] * 2, omega=ratios * W0,
                       A_range=(0.0, 0.3), seed_every=every)
        assert curves.kind == ("T", "2T") and curves.stable_below.tolist() == [False, True]
        np.testing.assert_allclose(curves.A, [lo, hi], rtol=1e-9)
    with pytest.warns(RuntimeWarning, match="boundaries: could not decide"):
        fq.boundaries(double, equal(2), [math.pi] * 2, omega=np.array([12.94, 12.942]) * W0,
                      A_range=(0.0, 0.3), seed_every=1, min_width=1e-4)


def test_min_width_is_checked(double):
    for bad in (0.0, -1e-3, math.inf, True, "1e-6"):
        with pytest.raises(ValueError, match="min_width must be a positive number"):
            fq.window(double, equal(2), [math.pi] * 2, omega=50.0, min_width=bad)
    with pytest.raises(ValueError, match="min_width"):
        fq.boundaries(double, equal(2), [math.pi] * 2, omega=[40.0, 50.0], min_width=-1.0)


# -- the search itself, on synthetic monodromies ---------------------------------------------

def _block(x):
    """A symplectic 2 × 2 matrix of trace x (det 1)."""
    one = np.ones_like(x)
    return np.stack([np.stack([x / 2, one], -1), np.stack([x * x / 4 - 1, x / 2], -1)], -2)


def _modes(*traces):
    """``evaluate(A, omega, analyse)`` of uncoupled modes, mode k's tr M = traces[k](A):
    stable iff every |tr| ≤ 2 (label 1 where one exceeds +2, else 2)."""
    def evaluate(A, omega, analyse):
        A = np.asarray(A, float)
        xs = [f(A) for f in traces]
        d = 2 * len(xs)
        Mb = np.zeros((A.size, d, d))
        for k, x in enumerate(xs):
            Mb[:, 2 * k:2 * k + 2, 2 * k:2 * k + 2] = _block(x)
        out = {"Mb": Mb, "ls": np.zeros(A.size), "err": np.full(A.size, 1e-15),
               "undamped": np.ones(A.size, dtype=bool)}
        if analyse:
            stable = np.all([np.abs(x) <= 2 for x in xs], axis=0)
            label = np.where(np.any([x > 2 for x in xs], axis=0), 1, 2)
            out.update(stable=stable, label=np.where(stable, 0, label))
        return out
    return evaluate


GRID = np.array([0.0, 0.3, 0.55, 0.8, 1.05, 1.3, 1.55, 1.8, 2.05, 2.3, 2.55, 2.8])


@pytest.mark.parametrize("top, found", [(1.0001, True), (0.9999, False)])
def test_frontier_finds_a_birth_between_two_modes(top, found):
    """Mode 1 stable for A in [1, 5], mode 2 for [top − 1, top]: a window [1, 1.0001]
    (1e-4 wide, the scan's spacing 0.25) is found; its mirror image, the edges crossed by
    1e-4, is "none"."""
    from kapitza.floquet._edges import first_window
    ev = _modes(lambda A: 2.0 - (A - 1.0), lambda A: -2.0 + 4.0 * (top - A))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        out = first_window(ev, np.array([1.0]), GRID, 1e-10)
    if found:
        assert out["status"][0] == "window"
        np.testing.assert_allclose([out["A_min"][0], out["A_max"][0]], [1.0, 1.0001],
                                   rtol=1e-10)
    else:
        assert out["status"][0] == "none" and np.isnan(out["A_min"][0])
        # a search stopped at 0.3 cannot separate the crossing edges: undecided, said so
        with pytest.warns(RuntimeWarning, match="could not decide"):
            coarse = first_window(ev, np.array([1.0]), GRID, 1e-10, min_width=0.3)
        assert coarse["status"][0] == "undecided"
        assert coarse["A_min"][0] <= 0.9999 and coarse["A_max"][0] >= 1.0


def test_frontier_sees_a_multiplier_sweep_through_the_band():
    """tr M from +100 to −100 between two scan points (the single pendulum near ω0): the
    log-compressed margin is a spike its neighbours cannot see, but det(M − I) and
    det(M + I) both change sign — the window [1.42, 1.425] is found."""
    from kapitza.floquet._edges import first_window
    ev = _modes(lambda A: 2.0 - 800.0 * (A - 1.42))
    out = first_window(ev, np.array([1.0]), GRID, 1e-10)
    assert out["status"][0] == "window"
    np.testing.assert_allclose([out["A_min"][0], out["A_max"][0]], [1.42, 1.425], rtol=1e-10)


def test_frontier_finds_an_unstable_gap_inside_the_window():
    """Mode 1 stable for A in [1, 5], mode 2 for |A − 2| < 0.500006 but for a dip below
    −2 at |A − 2| < 2.5e-3 (between the scan points 1.8 and 2.05): the window is
    [1.499994, 1.9975], ending at the gap, not at mode 2's upper edge 2.500006."""
    from kapitza.floquet._edges import first_window
    ev = _modes(lambda A: 2.0 - (A - 1.0), lambda A: -2.0001 + 16.0 * (A - 2.0) ** 2)
    out = first_window(ev, np.array([1.0]), GRID, 1e-10)
    assert out["status"][0] == "window"
    np.testing.assert_allclose([out["A_min"][0], out["A_max"][0]],
                               [2.0 - math.sqrt(4.0001 / 16), 2.0 - math.sqrt(1e-4 / 16)],
                               rtol=1e-9)


def test_window_warnings_point_at_the_callers_line():
    """``kapitza.window``'s accuracy RuntimeWarning (the single pendulum at ω = 300 rad/s
    asked for tol = 1e-13, certified to 3.5e-11) names the caller's file and line, also
    through the deprecated positional ``omega`` (whose wrapper sat between: the warning
    pointed into kapitza/floquet/_old_spellings.py before), and so does ``boundaries``'."""
    import kapitza
    system, params = problems.driven_pendulum("vertical"), dict(m=1.0, l=1.0, g=G)
    for call in (lambda: kapitza.window(system, params, [math.pi], omega=300.0, tol=1e-13),
                 lambda: kapitza.window(system, params, [math.pi], 300.0, tol=1e-13)):
        with warnings.catch_warnings(record=True) as rec:
            warnings.simplefilter("always")
            call()
        accuracy = [r for r in rec if "certified only to" in str(r.message)]
        assert accuracy and all(r.filename == __file__ for r in accuracy), \
            [(r.filename, str(r.message)[:40]) for r in rec]
        assert all(r.filename == __file__ for r in rec)
    with warnings.catch_warnings(record=True) as rec:
        warnings.simplefilter("always")
        fq.boundaries(system, params, [math.pi], omega=[300.0, 310.0], A_range=(0.0, 0.2),
                      tol=1e-13)
    assert rec and all(r.filename == __file__ for r in rec), \
        [(r.filename, str(r.message)[:40]) for r in rec]


def _damped_multiplier(A, omega, gamma, l=1.0):
    """max |λ| of φ'' + γφ' − (g/l − (Aω²/l) cos ωt)φ = 0 (the damped pendulum linearised
    about the upright) over one period, by scipy's DOP853 at rtol 1e-12 — no Mathieu
    trace, no kapitza code."""
    from scipy.integrate import solve_ivp

    def rhs(t_, y):
        return [y[1], -gamma * y[1] + (G / l - A * omega**2 / l * math.cos(omega * t_)) * y[0]]
    T = 2 * math.pi / omega
    M = np.column_stack([solve_ivp(rhs, (0.0, T), e, method="DOP853", rtol=1e-12,
                                   atol=1e-14).y[:, -1] for e in ([1.0, 0.0], [0.0, 1.0])])
    return float(np.max(np.abs(np.linalg.eigvals(M))))


@pytest.mark.parametrize("ratio", [0.5, 1.0, 1.455])
def test_damped_window_narrower_than_the_scan_is_found(ratio):
    """The damped exact window of the single pendulum at low ω/ω0 is narrower than its
    margin scan's 5.5 % spacing in q (γ = 0.5 1/s: 1.7e-5 of A wide at ω/ω0 = 0.5, 0.5 % at
    1, 3 % at 1.455, where a 30 000-point scan puts the stable q at 2.3067 … 2.377): it came
    back NaN ("no window"), silently.  Now it is found, its edges checked against a direct
    monodromy (scipy): stable in the middle, unstable one window-width outside either
    edge."""
    gamma, omega = 0.5, ratio * W0
    win = pendulum_window(omega, damping=gamma, method="floquet")
    assert win.status == "window" and 0 < win.A_min < win.A_max
    width = win.A_max - win.A_min
    assert width / win.A_min < 0.04                     # narrower than the scan's step
    assert _damped_multiplier(0.5 * (win.A_min + win.A_max), omega, gamma) < 1.0
    assert _damped_multiplier(win.A_min - width, omega, gamma) > 1.0
    assert _damped_multiplier(win.A_max + width, omega, gamma) > 1.0


def test_damped_window_status_says_none_where_there_is_none():
    """Where no amplitude holds the damped pendulum up (γ = 5 1/s, ω = 0.3 ω0) the status
    says "none" (not a NaN alone), without a warning; at 3 ω0 it says "window"."""
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        win = pendulum_window(np.array([0.3 * W0, 3 * W0]), damping=5.0, method="floquet")
    assert list(win.status) == ["none", "window"]
    assert np.isnan(win.A_min[0]) and win.A_min[1] > 0
