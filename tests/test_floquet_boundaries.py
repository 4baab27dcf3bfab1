"""Exact windows, boundary curves and adaptive maps of any system (issue 12, points 2–5).

Independent references:
* Acheson's modal decoupling: linearised about the upright, the N-link chain on a
  vertically driven pivot splits exactly into N Mathieu equations, mode k a pendulum of
  effective length λ_k (kapitza.multiple_pendulum_upright, from lagrange_core's hanging
  normal modes); each mode's exact window comes from Mathieu characteristic values
  (kapitza.closed_forms.pendulum_window, no monodromy), and the chain's window is
  their intersection.
* The single pendulum's exact windows, undamped and damped (Mathieu).
* The sum resonance of two parametrically coupled oscillators, first order:
  unstable iff |ω − (w1 + w2)| < A / (2 √(w1 w2)).
* scipy's solve_ivp monodromies (tests/helpers.py) and the point-wise classification of
  kapitza.floquet.floquet_grid on both sides of every curve; the uniform stability_map.
"""
import math

import numpy as np
import pytest
import sympy as sp

import lagrange_core as lc
from kapitza import figures as plots
from kapitza import floquet as fq
from kapitza.closed_forms import multiple_pendulum_upright, pendulum_window
from kapitza.floquet import _kernels
from kapitza.floquet._margins import margin
from kapitza.floquet._probe import _Probe
from kapitza.results import AdaptiveMap, BoundaryCurves, StabilityWindow
from lagrange_core import problems, t

from helpers import G, jacobian_monodromy

MASSES, LENGTHS = (1.0, 0.5), (1.0, 0.7)            # an unequal double pendulum
DP = {"g": G, "l1": LENGTHS[0], "l2": LENGTHS[1], "m1": MASSES[0], "m2": MASSES[1]}
TP = {"g": G, "l1": 1.0, "l2": 1.0, "l3": 1.0, "m1": 1.0, "m2": 1.0, "m3": 1.0}


def chain(n):
    A, w = sp.symbols("A omega", positive=True)
    return problems.n_link_pendulum(n, pivot=(0, A * sp.cos(w * t)))


@pytest.fixture(scope="module")
def double():
    return chain(2)


@pytest.fixture(scope="module")
def triple():
    return chain(3)


@pytest.fixture(scope="module")
def coupled():
    """x″ + w1² x + A cos(ωt) y = 0, y″ + w2² y + A cos(ωt) x = 0: the equilibrium 0
    loses stability only to the sum resonance ω ≈ w1 + w2 (complex multipliers)."""
    (x, y), (xd, yd) = lc.coordinates("x y")
    A, w, w1, w2 = sp.symbols("A omega w1 w2", positive=True)
    L = (xd**2 + yd**2) / 2 - (w1**2 * x**2 + w2**2 * y**2) / 2 - A * sp.cos(w * t) * x * y
    return lc.System([x, y], lagrangian=L)


W12 = {"w1": 1.0, "w2": 1.5}


def modal_window(omega, masses, lengths, tol=1e-14):
    """The chain's exact window as the intersection of its modes' Mathieu windows."""
    lam = multiple_pendulum_upright(masses, lengths, g=G).effective_lengths
    modes = [pendulum_window(omega, l=lk, g=G, tol=tol) for lk in lam]
    return (np.max([m.A_min for m in modes], axis=0), np.min([m.A_max for m in modes], axis=0))


# -- 2. exact windows ---------------------------------------------------------------------

def test_double_pendulum_window_is_the_intersection_of_its_modes(double):
    w = np.array([45.0, 60.0, 100.0, 150.0])
    win = fq.window(double, DP, [math.pi, math.pi], omega=w)
    assert isinstance(win, StabilityWindow) and win.method == "floquet" and win.tol == 1e-10
    lo, hi = modal_window(w, MASSES, LENGTHS)
    assert np.all(lo < hi)
    np.testing.assert_allclose(win.A_min, lo, rtol=1e-10)
    np.testing.assert_allclose(win.A_max, hi, rtol=1e-10)
    assert np.all(win.accuracy <= 1e-10)
    df = win.to_dataframe()
    assert df.columns.tolist() == ["omega", "A_min", "A_max", "accuracy", "status"]
    assert len(df) == 4 and set(df.status) == {"window"}


def test_triple_pendulum_window_to_1e_10(triple):
    win = fq.window(triple, TP, [math.pi] * 3, omega=100.0)
    assert np.ndim(win.A_min) == 0 and win.accuracy <= 1e-10
    lo, hi = modal_window(100.0, [1.0] * 3, [1.0] * 3)
    assert abs(win.A_min / lo - 1) < 1e-10 and abs(win.A_max / hi - 1) < 1e-10
    # solve_ivp (DOP853, rtol 1e-12), nothing of kapitza's monodromy: a multiplier crosses
    # +1 at A_min (det(M − I) changes sign) and −1 at A_max (det(M + I)), 1e-7 either side
    params = dict(TP, omega=100.0)
    for edge, shift in ((win.A_min, 1.0), (win.A_max, -1.0)):
        signs = [np.sign(np.linalg.det(jacobian_monodromy(
            triple, dict(params, A=edge * s), [math.pi] * 3, rtol=1e-12) - shift * np.eye(6)))
            for s in (1 - 1e-7, 1 + 1e-7)]
        assert signs[0] == -signs[1] != 0


def test_single_pendulum_windows_undamped_damped_and_hanging():
    w = np.array([30.0, 80.0])
    params = dict(m=1.0, l=0.8, g=G)
    ref = pendulum_window(w, l=0.8, g=G, tol=1e-14)
    win = fq.window(problems.driven_pendulum("vertical"), params, [math.pi], omega=w)
    np.testing.assert_allclose([win.A_min, win.A_max], [ref.A_min, ref.A_max], rtol=1e-10)
    # damped: the edges are |tr M| = 1 + e^(−γT), the Mathieu reference integrates tr M
    damped = problems.driven_pendulum("vertical", damping=True)
    ref = pendulum_window(w, l=0.8, g=G, damping=0.6, tol=1e-11)
    win = fq.window(damped, dict(params, gamma=0.6), [math.pi], omega=w)
    np.testing.assert_allclose([win.A_min, win.A_max], [ref.A_min, ref.A_max], rtol=1e-9)
    # the hanging state is stable undriven: A_min = 0, A_max the first parametric tongue
    ref = pendulum_window(3.0, l=0.8, g=G, about="hanging", tol=1e-14)
    win = fq.window(problems.driven_pendulum("vertical"), params, [0.0], omega=3.0)
    assert win.A_min == 0.0 and win.A_max == pytest.approx(ref.A_max, rel=1e-10)



# -- fast drives: monodromies near the identity ---------------------------------------------

EQUAL = {n: dict({"g": G}, **{f"l{i}": 1.0 for i in range(1, n + 1)},
                 **{f"m{i}": 1.0 for i in range(1, n + 1)}) for n in (4, 5)}


@pytest.mark.parametrize("n", [4, 5])
def test_chain_windows_at_fast_drives_against_the_modal_decoupling(n):
    """Acheson's chains at ω = 300 and 600 ω0, where every multiplier lies within 0.3 of
    +1: the windows are the modal ones to their certified accuracy, which the margins'
    float64 floor makes coarser than tol (≈ 1e-9 … 4e-8 here, ∝ ω²), said by a warning.
    (Before the fix: N = 5 gave A_min = 0.00397 l, no A_max at 300 ω0, no window at
    600 ω0, without a warning.)"""
    w = np.array([300.0, 600.0]) * math.sqrt(G)
    with pytest.warns(RuntimeWarning, match="certified only to") as rec:
        win = fq.window(chain(n), EQUAL[n], [math.pi] * n, omega=w)
    assert not any("failed their check" in str(r.message) for r in rec)
    lo, hi = modal_window(w, [1.0] * n, [1.0] * n)
    assert np.all(np.isfinite([win.A_min, win.A_max]))
    # the stated bound: the relative error is within the reported accuracy, itself ≤ 1e-7
    assert np.all(win.accuracy <= 1e-7) and np.all(win.accuracy > win.tol)
    for edge, ref in ((win.A_min, lo), (win.A_max, hi)):
        assert np.all(np.abs(edge / ref - 1) <= win.accuracy)
    # the study's scan limit (4 · 0.454 λ_N) lands on the same windows
    lam = multiple_pendulum_upright([1.0] * n, [1.0] * n, g=G).effective_lengths
    with pytest.warns(RuntimeWarning, match="certified only to"):
        other = fq.window(chain(n), EQUAL[n], [math.pi] * n, omega=w,
                          A_range=(0.0, 4 * 0.454 * lam[-1]))
    np.testing.assert_allclose([other.A_min, other.A_max], [lo, hi], rtol=1e-7)



def test_fast_drive_boundaries_and_maps_share_the_fix():
    """5 equal links at 250 … 600 ω0: the boundary curves lie on the modal edges within
    their (warned) accuracy, and the uniform and adaptive maps' labels equal the modal
    decoupling's at every point (before the fix 19 of these 65 × 33 points were wrong)."""
    n = 5
    w = np.linspace(280.0, 320.0, 8) * math.sqrt(G)
    with pytest.warns(RuntimeWarning, match="certified only to"):
        curves = fq.boundaries(chain(n), EQUAL[n], [math.pi] * n, omega=w, A_range=(0.0, 0.06),
                               tol=1e-9, seed_every=4)
    assert curves.kind == ("T", "2T")
    lo, hi = modal_window(w, [1.0] * n, [1.0] * n)
    for k, ref in ((0, lo), (1, hi)):
        assert np.all(np.isfinite(curves.A[k]))
        assert np.all(np.abs(curves.A[k] / ref - 1) <= curves.accuracy[k])
        assert np.all(curves.accuracy[k] <= 1e-7)
    A, w = np.linspace(0.0, 0.05, 65), np.linspace(250.0, 600.0, 33) * math.sqrt(G)
    lo, hi = modal_window(w, [1.0] * n, [1.0] * n)
    ref = (A[:, None] > lo[None, :]) & (A[:, None] < hi[None, :])
    adaptive = fq.adaptive_map(chain(n), EQUAL[n], [math.pi] * n, A=A, omega=w, coarse_step=8)
    uniform = fq.stability_map(chain(n), EQUAL[n], [math.pi] * n, A=A, omega=w)
    assert np.array_equal(uniform.stable, ref) and np.array_equal(adaptive.stable, ref)

def test_window_warns_only_when_the_accuracy_misses_tol(triple):
    """At ω = 100 rad/s (32 ω0) the triple pendulum's edges reach 1e-10: no warning; the
    same window asked to 1e-13 cannot get there in float64 and says so."""
    import warnings
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        win = fq.window(triple, TP, [math.pi] * 3, omega=100.0)
    assert win.accuracy <= 1e-10
    with pytest.warns(RuntimeWarning, match=r"coarser than tol = 1e-13"):
        fine = fq.window(triple, TP, [math.pi] * 3, omega=100.0, tol=1e-13)
    assert fine.accuracy > 1e-13
    assert abs(fine.A_min / win.A_min - 1) <= fine.accuracy + win.accuracy


def test_reduced_roots_keep_a_cluster_at_plus_one():
    """Multipliers e^(±iθ_k) with θ_k = 1e-3 … 0.3 and a real pair e^(±σ): x − 2 =
    2 cos θ − 2 and 2 cosh σ − 2 (closed form) to 1e-9 relative, although the roots differ
    from 2 by as little as 1e-6; the real roots are real exactly, a quadruplet's complex."""
    from kapitza.floquet._margins import reduced_polynomial
    theta = np.array([1e-3, 3e-3, 0.05, 0.3])
    sigma = 2e-3
    lam = np.r_[np.exp(1j * theta), np.exp(-1j * theta), np.exp(sigma), np.exp(-sigma)]
    _, x = reduced_polynomial(lam[None, :], 5)
    y = np.sort(x[0].real - 2.0)
    ref = np.sort(np.r_[2 * np.cos(theta) - 2, 2 * np.cosh(sigma) - 2])
    assert np.all(x[0].imag == 0.0)
    np.testing.assert_allclose(y, ref, rtol=1e-9)
    # a Krein quadruplet ρ e^(±iφ), e^(±iφ)/ρ: one complex pair x = (ρ + 1/ρ) cos φ ± ...
    rho, phi = 1.01, 0.02
    quad = np.r_[rho * np.exp(1j * phi), rho * np.exp(-1j * phi), np.exp(1j * phi) / rho,
                 np.exp(-1j * phi) / rho]
    _, x = reduced_polynomial(quad[None, :], 2)
    z = (rho + 1 / rho) * math.cos(phi) + 1j * (rho - 1 / rho) * math.sin(phi)
    np.testing.assert_allclose(np.sort_complex(x[0]), [z.conjugate(), z], rtol=1e-12)


def test_first_window_refuses_a_window_its_check_contradicts():
    """Two synthetic modes (2 × 2 blocks, x_k = tr, det 1): mode 1 stable for 1 < A < 5,
    mode 2 for 2 < A < 3, so the window is [2, 3].  A scan that lies — 'stable' for
    1.05 < A < 1.6, as the near-identity scans did — brackets mode 1's +1 crossing at
    A = 1, a true root of det(M − I); its side check finds A(1 + η) unstable, and the
    window is "undecided" with a warning, not [1, 3] (A_min, A_max then only bound the
    amplitudes in question, accuracy NaN).  A lie that leaves an edge without a root
    is "undecided" with a warning too; told the truth, the same scan gives [2, 3]."""
    from kapitza.floquet._edges import first_window

    def block(x):
        one = np.ones_like(x)
        return np.stack([np.stack([x / 2, one], -1), np.stack([x * x / 4 - 1, x / 2], -1)], -2)

    def scan(lie):
        def evaluate(A, omega, analyse):
            A = np.asarray(A, float)
            x1, x2 = 2.0 - (A - 1.0), 2.0 - 4.0 * (A - 2.0)
            Mb = np.zeros((A.size, 4, 4))
            Mb[:, :2, :2], Mb[:, 2:, 2:] = block(x1), block(x2)
            out = {"Mb": Mb, "ls": np.zeros(A.size), "err": np.full(A.size, 1e-15),
                   "undamped": np.ones(A.size, dtype=bool)}
            if analyse:
                stable = (np.abs(x1) <= 2) & (np.abs(x2) <= 2) | ((A > lie[0]) & (A < lie[1]))
                label = np.where((x1 > 2) | (x2 > 2), 1, 2)
                out.update(stable=stable, label=np.where(stable, 0, label))
            return out
        return evaluate

    grid = np.array([0.0, 0.5, 0.9, 1.1, 1.5, 2.5, 3.5, 4.0])
    for lie in ((1.05, 1.6), (1.05, 1.2)):
        with pytest.warns(RuntimeWarning, match="failed their check"):
            out = first_window(scan(lie), np.array([1.0]), grid, 1e-10)
        assert out["status"][0] == "undecided" and np.isnan(out["accuracy"][0])
        assert out["A_min"][0] <= 1.1 and out["A_max"][0] >= 1.5     # the lie's stable points
        assert not out["checked"][0]
    out = first_window(scan((0.0, 0.0)), np.array([1.0]), grid, 1e-10)
    assert out["checked"][0] and out["accuracy"][0] <= 1e-10 and out["status"][0] == "window"
    np.testing.assert_allclose([out["A_min"][0], out["A_max"][0]], [2.0, 3.0], rtol=1e-10)

def test_window_without_stable_amplitudes_is_nan(double):
    win = fq.window(double, DP, [math.pi, math.pi], omega=10.0)      # too slow to hold it up
    assert math.isnan(win.A_min) and math.isnan(win.A_max) and win.status == "none"


def test_window_and_boundaries_refuse_bad_input(double):
    with pytest.raises(ValueError, match="'B' is not a parameter"):
        fq.window(double, DP, [math.pi, math.pi], omega=100.0, amplitude="B")
    with pytest.raises(ValueError, match="tol must be"):
        fq.window(double, DP, [math.pi, math.pi], omega=100.0, tol=0.5)
    with pytest.raises(ValueError, match="ascending"):
        fq.boundaries(double, DP, [math.pi, math.pi], omega=[100.0, 50.0])
    with pytest.raises(ValueError, match="A_range"):
        fq.boundaries(double, DP, [math.pi, math.pi], omega=[50.0, 100.0], A_range=(0.3, 0.1))
    with pytest.raises(ValueError, match="does not persist"):
        fq.window(double, DP, [1.0, math.pi], omega=100.0)


def test_margins_have_simple_roots_at_the_edges(triple):
    """det(M ∓ I) changes sign across each edge, with an error bound far below |g|."""
    win = fq.window(triple, TP, [math.pi] * 3, omega=100.0)
    probe = _Probe(triple, TP, [math.pi] * 3, "A", "omega", 1e-15, 16, 1e-8, paired=True)
    for edge, kind in ((win.A_min, 1), (win.A_max, 2)):
        A = edge * np.array([1 - 1e-8, 1 + 1e-8])
        g, bound = margin(probe(A, np.full(2, 100.0)), np.full(2, kind))
        assert g[0] * g[1] < 0 and np.all(bound < 0.1 * np.abs(g))


def test_a_ctrl_c_in_the_paired_pass_stops_the_probe(triple, monkeypatch):
    """The paired margin integrates twice; a Ctrl-C caught in the second pass (its chunk
    loop returns ``stopped``) raises as in the first — it was ignored, and the report's
    map section ran on for 23 s after Ctrl-C in a CI run."""
    import kapitza.floquet._probe as probe_module
    calls = []
    original = probe_module._integrate

    def second_pass_interrupted(*args, **kwargs):
        out = original(*args, **kwargs)
        calls.append(1)
        return out if len(calls) == 1 else out[:-1] + (True,)
    monkeypatch.setattr(probe_module, "_integrate", second_pass_interrupted)
    probe = _Probe(triple, TP, [math.pi] * 3, "A", "omega", 1e-15, 16, 1e-8, paired=True)
    with pytest.raises(KeyboardInterrupt):
        probe(np.array([0.01]), np.array([100.0]))
    assert len(calls) == 2


# -- 3. boundary curves -------------------------------------------------------------------

def _both_sides(system, params, about, curves, side=1e-6):
    """Point-wise classification (floquet_grid) at A(1 ∓ side) of every curve point:
    the stable side stable, the other not."""
    k, i = np.nonzero(np.isfinite(curves.A))
    A = curves.A[k, i]
    w = curves.omega[i]
    grid = fq.floquet_grid(system, dict(params, A=np.r_[A * (1 - side), A * (1 + side)],
                                        omega=np.r_[w, w]), about, progress=False)
    below, above = np.split(grid.stable, 2)
    stable_below = curves.stable_below[k]
    return np.all(np.where(stable_below, below & ~above, ~below & above)), k.size


def test_double_pendulum_boundaries_against_modes_and_both_sides(double):
    w = np.linspace(20.0, 150.0, 60)
    curves = fq.boundaries(double, DP, [math.pi, math.pi], omega=w, A_range=(0.0, 0.3),
                           tol=1e-9)
    assert isinstance(curves, BoundaryCurves)
    assert curves.kind == ("T", "2T") and curves.stable_below.tolist() == [False, True]
    lo, hi = modal_window(w, MASSES, LENGTHS)
    window = lo < hi
    # every curve point lies on the modal edge, to the tolerance, and is certified
    for k, ref in ((0, lo), (1, hi)):
        ok = np.isfinite(curves.A[k])
        assert np.array_equal(ok, window)               # a boundary exactly where a window is
        np.testing.assert_allclose(curves.A[k][ok], ref[ok], rtol=1e-9)
        assert np.all(curves.accuracy[k][ok] <= 1e-9)
    good, count = _both_sides(double, DP, [math.pi, math.pi], curves)
    assert good and count == 2 * window.sum()
    df = curves.to_dataframe()
    assert len(df) == count and set(df.kind) == {"T", "2T"}
    assert set(df.stable_side) == {"above", "below"}


# near the tongue's tip (A → 0) two frequencies' points are certified to ~1.5e-9, not 1e-9:
# boundaries says so in a warning (tested elsewhere); this test checks the curves' values
@pytest.mark.filterwarnings("ignore:boundaries.*certified only:RuntimeWarning")
def test_complex_boundaries_of_the_sum_resonance(coupled):
    w = np.linspace(2.2, 2.8, 61)
    curves = fq.boundaries(coupled, W12, [0.0, 0.0], omega=w, A_range=(0.0, 0.6), tol=1e-9)
    assert curves.kind == ("complex", "complex") and curves.stable_below.all()
    good, count = _both_sides(coupled, W12, [0.0, 0.0], curves)
    assert good and count >= 40          # the tongue covers about 2 × 25 of the frequencies
    # near the tongue's tip, first order: A = 2 √(w1 w2) |ω − (w1 + w2)|
    sigma = np.abs(w - 2.5)
    near = (sigma > 0) & (sigma < 0.03)
    A = np.fmin(*curves.A)                   # the tongue's edge at each ω (NaN outside)
    np.testing.assert_allclose(A[near], 2 * math.sqrt(1.5) * sigma[near], rtol=0.05)
    # the exact window at one ω is bounded by the same curve
    win = fq.window(coupled, W12, [0.0, 0.0], omega=w[10])
    assert win.A_min == 0.0 and win.A_max == pytest.approx(A[10], rel=1e-9)


def test_boundaries_drawn_as_lines_over_a_map(double):
    w = np.linspace(40.0, 150.0, 30)
    curves = fq.boundaries(double, DP, [math.pi, math.pi], omega=w, A_range=(0.0, 0.3),
                           tol=1e-9)
    m = fq.stability_map(double, DP, [math.pi, math.pi], A=np.linspace(0.0, 0.3, 20), omega=w)
    fig = plots.stability_map_figure(m, overlays=[curves])
    labels = [line.get_label() for line in fig.axes[0].lines]
    assert labels == ["exact boundary: multiplier +1 (T)", "exact boundary: multiplier −1 (2T)"]
    legend = [t.get_text() for t in fig.axes[0].get_legend().get_texts()]
    assert "exact boundary: multiplier −1 (2T)" in legend


# -- 4. adaptive maps ---------------------------------------------------------------------

@pytest.mark.parametrize("case", ["double", "coupled"])
def test_adaptive_map_equals_the_uniform_map_with_10x_fewer_monodromies(case, double, coupled):
    if case == "double":
        system, params, about = double, DP, [math.pi, math.pi]
        A, w = np.linspace(0.0, 0.3, 257), np.linspace(20.0, 150.0, 257)
    else:
        system, params, about = coupled, W12, [0.0, 0.0]
        A, w = np.linspace(0.0, 0.8, 257), np.linspace(2.0, 3.0, 257)
    m = fq.adaptive_map(system, params, about, A=A, omega=w, coarse_step=16)
    uniform = fq.stability_map(system, params, about, A=A, omega=w)
    assert isinstance(m, AdaptiveMap) and m.stable.shape == (257, 257)
    assert np.array_equal(m.label, uniform.label)
    assert m.monodromies == m.computed.sum() and 10 * m.monodromies <= A.size * w.size
    # the continuous margin has the map's sign wherever it was computed (it is 0 where
    # the undriven oscillators' multipliers coincide: ω = w1 + w2, ω = 2 w2 at A = 0)
    c = m.computed & (m.margin != 0)
    assert np.all((m.margin[c] > 0) == m.stable[c])
    fig = plots.stability_map_figure(m)
    assert fig.axes[0].get_title().endswith("(adaptive monodromy)")
    df = m.to_dataframe()
    assert {"margin", "computed"} <= set(df.columns) and len(df) == 257 * 257


# -- 5. the cost of one point: small grids stay on the calling thread ---------------------

def test_small_grids_run_on_the_calling_thread_with_the_same_results(triple):
    import numba
    before = numba.get_num_threads()
    # the first chunk (64 points) runs on the calling thread, larger ones in parallel
    A = np.linspace(0.06, 0.08, 4 * _kernels.SERIAL_BELOW)
    big = fq.floquet_grid(triple, dict(TP, A=A, omega=100.0), [math.pi] * 3, progress=False)
    assert numba.get_num_threads() == before
    for i in (0, 100, len(A) - 1):
        one = fq.floquet_point(triple, dict(TP, A=A[i], omega=100.0), [math.pi] * 3)
        assert one.trace == pytest.approx(big.trace[i], rel=1e-12, abs=1e-12)
        assert one.stable == big.stable[i]
    assert numba.get_num_threads() == before
